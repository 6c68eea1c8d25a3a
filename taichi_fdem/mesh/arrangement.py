"""The planar arrangement of a polygon and embedded lines (private, pure NumPy).

:func:`arrange` turns a polygon outline and a list of :class:`~taichi_fdem.mesh.lines.Segments`
into a planar straight-line graph: one node at every polygon vertex, line point, line-line
crossing, T-junction and line-boundary meeting; the polygon outline as a ring of nodes; the
lines as pieces between consecutive nodes.  Both mesh engines of
:func:`~taichi_fdem.mesh.polygon` (the built-in constrained Delaunay and gmsh) mesh this graph.

Rules (checked here, with ValueErrors naming the line and the point):

* every line lies inside the polygon or on its boundary (end points may be on the boundary);
* collinear overlapping pieces are refused: two lines running along each other, or a line
  running along the polygon outline (whose edges are mesh edges already);
* points closer than ``tol = 1e-9 *`` the polygon's size are merged into one node (polygon
  vertices are never merged with each other).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .lines import Segments

__all__: list = []   # private module

#: geometric tolerance, relative to the largest extent of the polygon
REL_TOL = 1e-9
_CHUNK = 1 << 20


@dataclass
class Arrangement:
    """A planar straight-line graph (private).

    nodes : (N, 2) float64 [m]; ring : (r,) node ids of the outline, counter-clockwise;
    pieces : (P, 2) node ids of the line pieces; piece_line : (P,) index of the line of
    each piece; tol : the merge tolerance [m].
    """
    nodes: np.ndarray
    ring: np.ndarray
    pieces: np.ndarray
    piece_line: np.ndarray
    tol: float


def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[...,0]


def _fmt(p) -> str:
    return f"({float(p[0]):.6g}, {float(p[1]):.6g})"


def _line_label(lines, i) -> str:
    name = lines[i].name
    return f"line {i}" + (f" ({name!r})" if name is not None else "")


def _inside_polygon(p: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Even-odd point-in-polygon test for points ``p`` (N, 2) and polygon ``v`` (k, 2)."""
    a, b = v, np.roll(v, -1, axis=0)
    inside = np.zeros(len(p), dtype=bool)
    for start in range(0, len(p), 2048):
        q = p[start:start + 2048, None, :]
        straddle = (a[None, :, 1] > q[..., 1]) != (b[None, :, 1] > q[..., 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            xint = a[None, :, 0] + (q[..., 1] - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / (b[None, :, 1] - a[None, :, 1])
        inside[start:start + 2048] = (np.count_nonzero(straddle & (q[..., 0] < xint), axis=1) % 2) == 1
    return inside


def _distance_to_polygon(p: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Distance from points ``p`` (N, 2) to the closed polyline ``v`` (k, 2)."""
    a, b = v, np.roll(v, -1, axis=0)
    ab = b - a
    ll = np.maximum((ab * ab).sum(1), 1e-300)
    dist = np.empty(len(p))
    for start in range(0, len(p), 2048):
        q = p[start:start + 2048, None, :]
        t = np.clip(((q - a[None]) * ab[None]).sum(-1) / ll[None], 0.0, 1.0)
        d = q - (a[None] + t[..., None] * ab[None])
        dist[start:start + 2048] = np.sqrt((d * d).sum(-1).min(axis=1))
    return dist


def _inside_or_on(p: np.ndarray, v: np.ndarray, tol: float) -> np.ndarray:
    """Points ``p`` (N, 2) inside the polygon ``v`` (even-odd) or within ``tol`` of its outline."""
    return _inside_polygon(p, v) | (_distance_to_polygon(p, v) <= tol)


def _merge(points: np.ndarray, fixed: int, tol: float) -> np.ndarray:
    """Representative index of every point: the first point within ``tol`` of it (the first
    ``fixed`` points only represent themselves and each other never merge)."""
    n = len(points)
    rep = np.arange(n)
    rows = max(1, _CHUNK // max(n, 1))
    for start in range(fixed, n, rows):
        q = points[start:start + rows]
        d = q[:, None, :] - points[None, :, :]
        close = (d * d).sum(-1) <= tol * tol
        rep[start:start + len(q)] = np.argmax(close, axis=1)     # the first close one (itself at worst)
    for _ in range(64):
        nxt = rep[rep]
        if np.array_equal(nxt, rep):
            break
        rep = nxt
    return rep


def arrange(v: np.ndarray, lines: list[Segments], where: str) -> Arrangement:
    """The planar arrangement of the counter-clockwise simple polygon ``v`` (k, 2) [m] and
    ``lines``; ValueError for lines outside the polygon or overlapping (see the module)."""
    k = len(v)
    scale = float(np.ptp(v, axis=0).max())
    tol = REL_TOL * scale
    bnd = np.stack([v, np.roll(v, -1, axis=0)], axis=1)                       # (k, 2, 2)
    segs = np.concatenate([ln.segments for ln in lines])                      # (L, 2, 2)
    owner = np.concatenate([np.full(len(ln), i) for i, ln in enumerate(lines)])
    L = len(segs)

    # 1. every line point inside the polygon or on its outline
    ends = segs.reshape(-1, 2)
    ok = _inside_or_on(ends, v, tol)
    if not ok.all():
        j = int(np.flatnonzero(~ok)[0])
        raise ValueError(f"{where}: {_line_label(lines, owner[j // 2])} leaves the polygon: its point "
                         f"{_fmt(ends[j])} lies outside")

    # 2. crossings of every line segment with every other segment (outline and lines)
    allsegs = np.concatenate([bnd, segs])                                     # outline first
    A, D = allsegs[:, 0], allsegs[:, 1] - allsegs[:, 0]
    lens = np.sqrt((D * D).sum(1))
    found = _crossings(A, D, lens, k, tol, lines, owner, where)

    # 3. nodes: polygon vertices, line points, crossings; points closer than tol merged
    pool = np.concatenate([v, ends] + found)
    rep = _merge(pool, k, tol)
    uniq, node_of = np.unique(rep, return_inverse=True)
    node_of = node_of.ravel()
    nodes = pool[uniq]
    seg_start = np.concatenate([np.arange(k), k + 2 * np.arange(L)])
    seg_end = np.concatenate([(np.arange(k) + 1) % k, k + 2 * np.arange(L) + 1])
    n_start, n_end = node_of[seg_start], node_of[seg_end]

    # 4. the nodes lying on each segment, in order along it
    chains = _chains(nodes, A, D, lens, n_start, n_end, tol)
    ring = np.array([c for chain in chains[:k] for c in chain[:-1]], dtype=np.int64)
    pieces, piece_line = [], []
    for s in range(L):
        chain = chains[k + s]
        pieces.extend(zip(chain[:-1], chain[1:]))
        piece_line.extend([int(owner[s])] * (len(chain) - 1))
    pieces = np.array(pieces, dtype=np.int64).reshape(-1, 2)
    piece_line = np.array(piece_line, dtype=np.int64)
    if len(np.unique(ring)) != len(ring):                                     # pragma: no cover
        raise RuntimeError(f"{where}: internal error: the outline visits a node twice")

    # 5. every piece inside the polygon: a piece between two crossings of the outline is outside
    mids = 0.5 * (nodes[pieces[:, 0]] + nodes[pieces[:, 1]])
    ok = _inside_or_on(mids, v, tol)
    if not ok.all():
        j = int(np.flatnonzero(~ok)[0])
        raise ValueError(f"{where}: {_line_label(lines, piece_line[j])} leaves the polygon between "
                         f"{_fmt(nodes[pieces[j, 0]])} and {_fmt(nodes[pieces[j, 1]])} (its point {_fmt(mids[j])} "
                         f"lies outside)")
    # a piece given twice (e.g. a line repeated): keep one
    key = np.sort(pieces, axis=1)
    _, first = np.unique(key[:, 0] * len(nodes) + key[:, 1], return_index=True)
    first = np.sort(first)
    return Arrangement(nodes, ring, pieces[first], piece_line[first], tol)


def _crossings(A, D, lens, k: int, tol: float, lines, owner, where: str) -> list:
    """The points where each line segment meets another segment, the outline's or a line's
    (arrays of points (c, 2)), for the segments p = A + t D of length ``lens``, the ``k``
    outline segments first; ValueError for a line running along the outline or along another
    line (collinear overlap longer than ``tol``)."""
    L = len(A) - k
    found = []
    rows = max(1, _CHUNK // len(A))
    for start in range(0, L, rows):
        i = np.arange(start, min(L, start + rows)) + k                        # rows: line segments
        p, r, lr = A[i][:, None], D[i][:, None], lens[i][:, None]
        q, s, ls = A[None], D[None], lens[None]
        qp = q - p
        denom = _cross(r, s)
        parallel = np.abs(denom) <= 1e-12 * lr * ls
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(parallel, np.nan, _cross(qp, s) / denom)
            u = np.where(parallel, np.nan, _cross(qp, r) / denom)
        meet = (~parallel & (t * lr >= -tol) & (t * lr <= lr + tol) & (u * ls >= -tol) & (u * ls <= ls + tol))
        jj = np.arange(len(A))[None]
        meet &= jj != i[:, None]
        rr, cc = np.nonzero(meet)
        if rr.size:
            tt = np.clip(t[rr, cc], 0.0, 1.0)[:, None]
            found.append(A[i[rr]] + tt * D[i[rr]])
        # collinear overlaps
        off = np.abs(_cross(qp, r)) / lr
        t0 = (qp * r).sum(-1) / lr
        t1 = ((qp + s) * r).sum(-1) / lr
        overlap = np.minimum(lr, np.maximum(t0, t1)) - np.maximum(0.0, np.minimum(t0, t1))
        bad = parallel & (off <= tol) & (overlap > tol) & (jj != i[:, None])
        if bad.any():
            rr, cc = np.argwhere(bad)[0]
            a = A[i[rr]] + D[i[rr]] * max(0.0, min(t0[rr, cc], t1[rr, cc])) / lr[rr, 0]
            me = _line_label(lines, owner[i[rr] - k])
            if cc < k:
                raise ValueError(f"{where}: {me} runs along the polygon boundary (edge {cc}) from {_fmt(a)}; "
                                 f"boundary edges are mesh edges already, leave that part out of the line")
            raise ValueError(f"{where}: {me} and {_line_label(lines, owner[cc - k])} overlap (collinear) from "
                             f"{_fmt(a)}; overlapping lines are not merged, give the common part once")
    return found


def _chains(nodes, A, D, lens, n_start, n_end, tol: float) -> list:
    """For each segment p = A + t D (length ``lens``, from node ``n_start`` to node ``n_end``),
    the chain of node ids along it: its start, the ``nodes`` within ``tol`` of its inside in
    order along it, its end (no node twice in a row)."""
    chains = []
    rows = max(1, _CHUNK // len(nodes))
    for start in range(0, len(A), rows):
        i = np.arange(start, min(len(A), start + rows))
        r, lr = D[i][:, None], lens[i][:, None]
        w = nodes[None] - A[i][:, None]
        along = (w * r).sum(-1) / lr
        across = np.abs(_cross(w, r)) / lr
        on = (across <= tol) & (along > tol) & (along < lr - tol)
        for row, seg in enumerate(i.tolist()):
            inner = np.flatnonzero(on[row])
            inner = inner[(inner != n_start[seg]) & (inner != n_end[seg])]
            inner = inner[np.argsort(along[row, inner], kind="stable")]
            chain = [int(n_start[seg])] + inner.tolist() + [int(n_end[seg])]
            chains.append([c for j, c in enumerate(chain) if j == 0 or c != chain[j - 1]])
    return chains


def distance_to_segments(p: np.ndarray, segs: np.ndarray) -> np.ndarray:
    """Distance from points ``p`` (N, 2) to the nearest of the segments ``segs`` (k, 2, 2) [m]."""
    a, ab = segs[:, 0], segs[:, 1] - segs[:, 0]
    ll = np.maximum((ab * ab).sum(1), 1e-300)
    dist = np.full(len(p), np.inf)
    rows = max(1, _CHUNK // max(len(segs), 1))
    for start in range(0, len(p), rows):
        q = p[start:start + rows, None, :]
        t = np.clip(((q - a[None]) * ab[None]).sum(-1) / ll[None], 0.0, 1.0)
        d = q - (a[None] + t[..., None] * ab[None])
        dist[start:start + rows] = np.sqrt((d * d).sum(-1).min(axis=1))
    return dist

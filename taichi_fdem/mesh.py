"""Two-dimensional triangle meshes: construction, loading and validation (pure NumPy).

A :class:`TriMesh` is an immutable pair of arrays

* ``points``    -- ``(n, 2)`` float64 node coordinates [m],
* ``triangles`` -- ``(m, 3)`` int32 node indices, every triangle counter-clockwise,

checked when it is created: finite coordinates, indices in range, no repeated node in a
triangle, no zero-area triangle, no two triangles overlapping across an edge.  Clockwise
triangles are silently reoriented.  Both arrays are read-only.

Named constructors (also available as static methods of :class:`TriMesh`)::

    rectangle(width, height, h, pattern="alternating", origin=None)
    disk(radius, h, center=(0, 0))
    annulus(r_inner, r_outer, h, center=(0, 0))
    polygon(vertices, h=None)
    load(path, cell_block=None)          # any file meshio reads (gmsh .msh, .vtu, ...)
    load_groups(path, key=None)          # one mesh per physical group / cell tag
    merge(meshes)                        # concatenate several meshes into one

``h`` is always the target element edge length [m].  The module does not import Taichi
and never loops in Python over the elements of an existing mesh; the generators
(:func:`disk`, :func:`annulus`, :func:`polygon`) use Python loops that are linear (rings)
or roughly ``O(n log n)`` (incremental Delaunay) in the number of nodes.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

__all__ = ["TriMesh", "rectangle", "disk", "annulus", "polygon", "load", "load_groups", "scene_from_groups",
           "merge"]

#: A triangle is degenerate when |2A| <= DEGENERACY_TOL * (longest edge)^2.
DEGENERACY_TOL = 1e-12
#: Generators refuse to build more triangles than this (a typo in ``h`` would hang).
MAX_GENERATED_TRIANGLES = 2_000_000


# --------------------------------------------------------------------------- helpers
def _nround(x: float) -> int:
    """Nearest integer, halves rounded down (2.5 -> 2), robust to last-bit noise."""
    return int(math.floor(x + 0.5 - 1e-9))


def _positive(name: str, value, where: str) -> float:
    """``value`` as a finite, strictly positive float, or a ValueError naming it."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: {name} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0.0:
        raise ValueError(f"{where}: {name} must be finite and > 0, got {value!r}")
    return v


def _vec2(name: str, value, where: str) -> np.ndarray:
    """``value`` as a finite float64 array of shape (2,), or a ValueError naming it."""
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: {name} must be a pair (x, y), got {value!r}") from None
    if v.shape != (2,):
        raise ValueError(f"{where}: {name} must be a pair (x, y), got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{where}: {name} must be finite, got {value!r}")
    return v


def _guard_size(estimate: float, where: str, h: float) -> None:
    if estimate > MAX_GENERATED_TRIANGLES:
        raise ValueError(f"{where}: h={h:g} would create about {estimate:.3g} triangles "
                         f"(limit {MAX_GENERATED_TRIANGLES}); use a larger h")


def _readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def _more(count: int) -> str:
    return f" (and {count - 1} more)" if count > 1 else ""


# --------------------------------------------------------------------------- TriMesh
@dataclass(frozen=True, eq=False, repr=False)
class TriMesh:
    """An immutable, validated 2D triangle mesh.

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Node coordinates [m].  Stored as a read-only C-contiguous float64 array.
    triangles : array_like of int, shape (m, 3)
        Node indices of each triangle.  Stored as a read-only int32 array in which every
        triangle is counter-clockwise (clockwise input rows get two nodes swapped).

    Raises
    ------
    ValueError
        Wrong shapes, an empty mesh, non-finite coordinates (naming the point),
        negative or out-of-range indices, a triangle repeating a node, a zero-area
        triangle (``|2A| <= 1e-12 * longest_edge**2``; naming the triangle and its
        nodes), or two triangles that overlap across an edge (both traverse the same
        directed edge once oriented counter-clockwise, i.e. an edge shared by more than
        two triangles or a folded mesh).

    Notes
    -----
    Points that no triangle uses are allowed; :meth:`compact` removes them.  Instances
    compare by identity (``eq=False``) since their fields are arrays.

    The module-level constructors are also static methods: ``TriMesh.rectangle``,
    ``TriMesh.disk``, ``TriMesh.annulus``, ``TriMesh.polygon``, ``TriMesh.load`` and
    ``TriMesh.merge``.
    """

    points: np.ndarray
    triangles: np.ndarray

    # ------------------------------------------------------------------ validation
    def __post_init__(self):
        try:
            pts = np.array(self.points, dtype=np.float64, order="C", copy=True)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"TriMesh: points must be a numeric (n, 2) array ({exc})") from None
        tri_in = np.asarray(self.triangles)
        if pts.size == 0 or tri_in.size == 0:
            raise ValueError(f"TriMesh: empty mesh (points shape {pts.shape}, triangles shape {tri_in.shape})")
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise ValueError(f"TriMesh: points must have shape (n, 2), got {pts.shape}")
        if tri_in.ndim != 2 or tri_in.shape[1] != 3:
            raise ValueError(f"TriMesh: triangles must have shape (m, 3), got {tri_in.shape}")
        n = pts.shape[0]
        if n > np.iinfo(np.int32).max:
            raise ValueError(f"TriMesh: too many points for int32 indices ({n})")

        bad = np.flatnonzero(~np.isfinite(pts).all(axis=1))
        if bad.size:
            i = int(bad[0])
            raise ValueError(f"TriMesh: point {i} has a non-finite coordinate "
                             f"{tuple(pts[i].tolist())}{_more(bad.size)}")

        if tri_in.dtype.kind in "iu":
            tri64 = tri_in.astype(np.int64, copy=False)
        elif tri_in.dtype.kind == "f":
            tri64 = np.full(tri_in.shape, -1, dtype=np.int64)
            ok = np.isfinite(tri_in) & (tri_in == np.round(tri_in))
            if not ok.all():
                t = int(np.flatnonzero(~ok.all(axis=1))[0])
                raise ValueError(f"TriMesh: triangle {t} has non-integer node indices "
                                 f"{tuple(tri_in[t].tolist())}")
            tri64[...] = tri_in
        else:
            raise ValueError(f"TriMesh: triangles must be integer node indices, got dtype {tri_in.dtype}")

        out = np.flatnonzero(((tri64 < 0) | (tri64 >= n)).any(axis=1))
        if out.size:
            t = int(out[0])
            raise ValueError(f"TriMesh: triangle {t} has node indices {tuple(tri64[t].tolist())} out of "
                             f"range for {n} points (valid: 0..{n - 1}){_more(out.size)}")
        tri = tri64.astype(np.int32)

        rep = np.flatnonzero((tri[:, 0] == tri[:, 1]) | (tri[:, 1] == tri[:, 2]) | (tri[:, 2] == tri[:, 0]))
        if rep.size:
            t = int(rep[0])
            raise ValueError(f"TriMesh: triangle {t} repeats a node (nodes {', '.join(map(str, tri[t]))})"
                             f"{_more(rep.size)}")

        a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
        ab, ac, bc = b - a, c - a, c - b
        twice = ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0]
        longest2 = np.maximum(np.maximum((ab * ab).sum(1), (ac * ac).sum(1)), (bc * bc).sum(1))
        degenerate = np.flatnonzero(np.abs(twice) <= DEGENERACY_TOL * longest2)
        if degenerate.size:
            t = int(degenerate[0])
            raise ValueError(f"TriMesh: triangle {t} has zero area (nodes {', '.join(map(str, tri[t]))})"
                             f"{_more(degenerate.size)}")
        cw = twice < 0
        if cw.any():
            tri[cw, 1], tri[cw, 2] = tri[cw, 2].copy(), tri[cw, 1].copy()
            twice = np.abs(twice)

        # two counter-clockwise triangles traversing the same directed edge overlap
        directed = np.stack([tri, np.roll(tri, -1, axis=1)], axis=2).reshape(-1, 2).astype(np.int64)
        keys = directed[:, 0] * n + directed[:, 1]
        order = np.argsort(keys, kind="stable")
        dup = np.flatnonzero(keys[order][1:] == keys[order][:-1])
        if dup.size:
            e0, e1 = int(order[dup[0]]), int(order[dup[0] + 1])
            u, v = directed[e0]
            raise ValueError(f"TriMesh: triangles {e0 // 3} and {e1 // 3} both contain edge {u}->{v} with "
                             f"the same orientation, so they overlap (an edge may be shared by at most two "
                             f"triangles, lying on opposite sides of it){_more(dup.size)}")

        object.__setattr__(self, "points", _readonly(pts))
        object.__setattr__(self, "triangles", _readonly(np.ascontiguousarray(tri)))
        object.__setattr__(self, "_areas", _readonly(0.5 * twice))

    def __setstate__(self, state):
        # unpickling (checkpoints): restore the fields and mark the arrays read-only again
        for key, value in state.items():
            object.__setattr__(self, key, _readonly(value) if isinstance(value, np.ndarray) else value)

    def __repr__(self) -> str:
        x0, y0, x1, y1 = self.bounding_box()
        return (f"TriMesh({self.point_count} points, {self.triangle_count} triangles, "
                f"area={self.area:.6g} m^2, bbox=({x0:.4g}, {y0:.4g}, {x1:.4g}, {y1:.4g}))")

    # ------------------------------------------------------------------ properties
    @property
    def point_count(self) -> int:
        """Number of nodes ``n`` (including unused ones)."""
        return int(self.points.shape[0])

    @property
    def triangle_count(self) -> int:
        """Number of triangles ``m``."""
        return int(self.triangles.shape[0])

    @property
    def areas(self) -> np.ndarray:
        """Triangle areas, shape (m,) [m^2], all > 0 (read-only)."""
        return self._areas

    @property
    def area(self) -> float:
        """Total area [m^2]."""
        return float(self._areas.sum())

    @property
    def centroid(self) -> np.ndarray:
        """Area-weighted centroid of the triangles, shape (2,) [m]."""
        cent = self.points[self.triangles].mean(axis=1)
        return (self._areas[:, None] * cent).sum(axis=0) / self._areas.sum()

    # ------------------------------------------------------------------ topology
    def _directed_edges(self) -> np.ndarray:
        """All (3m, 2) directed edges (t0->t1, t1->t2, t2->t0 for each triangle), int64."""
        t = self.triangles.astype(np.int64)
        return np.stack([t, np.roll(t, -1, axis=1)], axis=2).reshape(-1, 2)

    def edges(self) -> np.ndarray:
        """Unique undirected edges, shape (k, 2) int32, each row ``i < j``, rows sorted."""
        d = np.sort(self._directed_edges(), axis=1)
        keys = np.unique(d[:, 0] * self.point_count + d[:, 1])
        return np.stack([keys // self.point_count, keys % self.point_count], axis=1).astype(np.int32)

    def boundary_edges(self) -> np.ndarray:
        """Edges belonging to one triangle only, shape (b, 2) int32.

        Each edge is directed as it appears in its (counter-clockwise) triangle, so the
        body lies on its left and outer boundaries run counter-clockwise, holes
        clockwise.  Rows are in the order of the triangles (then local edge 01, 12, 20).
        """
        d = self._directed_edges()
        s = np.sort(d, axis=1)
        keys = s[:, 0] * self.point_count + s[:, 1]
        _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
        return d[counts[inverse.ravel()] == 1].astype(np.int32)

    def boundary_nodes(self) -> np.ndarray:
        """Sorted unique indices of the nodes on the boundary, shape (k,) int32."""
        return np.unique(self.boundary_edges()).astype(np.int32)

    # ------------------------------------------------------------------ measures
    def _edge_vectors(self):
        p = self.points[self.triangles]
        return p[:, 1] - p[:, 0], p[:, 2] - p[:, 1], p[:, 0] - p[:, 2]

    def min_altitude(self) -> float:
        """Smallest triangle altitude [m]: min over triangles of ``2 A / longest edge``."""
        e = self._edge_vectors()
        longest = np.sqrt(np.max([(v * v).sum(1) for v in e], axis=0))
        return float(np.min(2.0 * self._areas / longest))

    def min_angle(self) -> float:
        """Smallest interior angle of any triangle [rad]."""
        e0, e1, e2 = self._edge_vectors()
        l0, l1, l2 = (np.sqrt((v * v).sum(1)) for v in (e0, e1, e2))
        twice = 2.0 * self._areas
        # the angle opposite edge k: sin = 2A / (product of the two other edges)
        s = np.stack([twice / (l1 * l2), twice / (l2 * l0), twice / (l0 * l1)])
        # the smallest angle is opposite the shortest edge, hence acute: asin is exact there
        return float(np.arcsin(np.clip(s, 0.0, 1.0)).min()) if s.size else 0.0

    def mean_edge_length(self) -> float:
        """Mean length of the unique edges [m]."""
        e = self.edges()
        v = self.points[e[:, 1]] - self.points[e[:, 0]]
        return float(np.sqrt((v * v).sum(1)).mean())

    def bounding_box(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` of all points [m]."""
        lo, hi = self.points.min(axis=0), self.points.max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    # ------------------------------------------------------------------ transforms
    def translated(self, offset) -> "TriMesh":
        """A copy moved by ``offset`` = (dx, dy) [m]."""
        return TriMesh(self.points + _vec2("offset", offset, "TriMesh.translated"), self.triangles)

    def rotated(self, angle: float, about=None) -> "TriMesh":
        """A copy rotated counter-clockwise by ``angle`` [rad] about ``about`` (x, y) [m]
        (default: the area-weighted :attr:`centroid`)."""
        ang = float(angle)
        if not math.isfinite(ang):
            raise ValueError(f"TriMesh.rotated: angle must be finite, got {angle!r}")
        c = self.centroid if about is None else _vec2("about", about, "TriMesh.rotated")
        co, si = math.cos(ang), math.sin(ang)
        rot = np.array([[co, -si], [si, co]])
        return TriMesh(c + (self.points - c) @ rot.T, self.triangles)

    def scaled(self, factor, about=(0.0, 0.0)) -> "TriMesh":
        """A copy with coordinates scaled by ``factor`` about ``about`` (default: the origin,
        so ``scaled(1e-3)`` converts a mesh drawn in mm to m).

        ``factor`` is a positive number or a pair ``(fx, fy)`` of positive numbers.
        """
        f = np.asarray(factor, dtype=np.float64)
        if f.shape not in ((), (2,)) or not np.all(np.isfinite(f)) or not np.all(f > 0):
            raise ValueError(f"TriMesh.scaled: factor must be a positive number or a pair of "
                             f"positive numbers, got {factor!r}")
        c = _vec2("about", about, "TriMesh.scaled")
        return TriMesh(c + (self.points - c) * f, self.triangles)

    def compact(self) -> "TriMesh":
        """A copy without the points that no triangle uses (indices renumbered, order kept).
        Returns ``self`` when every point is used."""
        used = np.zeros(self.point_count, dtype=bool)
        used[self.triangles.ravel()] = True
        if used.all():
            return self
        new_index = np.cumsum(used, dtype=np.int64) - 1
        return TriMesh(self.points[used], new_index[self.triangles])


# --------------------------------------------------------------------------- rectangle
_PATTERNS = ("alternating", "crossed", "right")


def rectangle(width: float, height: float, h: float, pattern: str = "alternating",
              origin=None) -> TriMesh:
    """A structured triangle mesh of a ``width`` x ``height`` rectangle [m].

    The rectangle is divided into ``nx = max(1, round(width / h))`` by
    ``ny = max(1, round(height / h))`` cells (halves round down), so cells measure
    ``width / nx`` by ``height / ny`` -- close to, not exactly, ``h``.

    Parameters
    ----------
    width, height : float [m], > 0
    h : float [m], > 0.  Target cell size.
    pattern : how each cell is split.
        ``"alternating"`` (default): one diagonal per cell, alternating in a
        checkerboard (2 triangles/cell, no preferred crack direction on average);
        ``"crossed"``: a node at each cell centre and 4 triangles per cell (unbiased);
        ``"right"``: every cell split along the same (lower-left to upper-right)
        diagonal (2 triangles/cell, biased).
    origin : (x, y) [m] of the lower-left corner; default None centres the rectangle on
        (0, 0).

    Returns
    -------
    TriMesh with ``(nx+1)(ny+1)`` (+ ``nx*ny`` for "crossed") points and ``2 nx ny``
    (``4 nx ny``) triangles.
    """
    where = "rectangle"
    w = _positive("width", width, where)
    hh = _positive("height", height, where)
    h = _positive("h", h, where)
    if pattern not in _PATTERNS:
        raise ValueError(f"{where}: unknown pattern {pattern!r}; choose one of {list(_PATTERNS)}")
    nx, ny = max(1, _nround(w / h)), max(1, _nround(hh / h))
    per_cell = 4 if pattern == "crossed" else 2
    if nx * ny * per_cell > 50 * MAX_GENERATED_TRIANGLES:
        raise ValueError(f"{where}: h={h:g} would create {nx * ny * per_cell} triangles; use a larger h")
    o = np.array([-0.5 * w, -0.5 * hh]) if origin is None else _vec2("origin", origin, where)

    xs = o[0] + w * np.arange(nx + 1) / nx
    ys = o[1] + hh * np.arange(ny + 1) / ny
    xs[-1], ys[-1] = o[0] + w, o[1] + hh
    gx, gy = np.meshgrid(xs, ys)  # (ny+1, nx+1), node (i, j) -> j * (nx+1) + i
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)

    i, j = np.meshgrid(np.arange(nx), np.arange(ny))
    i, j = i.ravel(), j.ravel()
    n00 = j * (nx + 1) + i
    n10, n01, n11 = n00 + 1, n00 + nx + 1, n00 + nx + 2
    if pattern == "crossed":
        centre = (nx + 1) * (ny + 1) + np.arange(nx * ny)
        pts = np.vstack([pts, np.stack([0.5 * (xs[i] + xs[i + 1]), 0.5 * (ys[j] + ys[j + 1])], axis=1)])
        tri = np.stack([np.stack([n00, n10, centre], 1), np.stack([n10, n11, centre], 1),
                        np.stack([n11, n01, centre], 1), np.stack([n01, n00, centre], 1)], axis=1).reshape(-1, 3)
    else:
        flip = ((i + j) % 2 == 1) if pattern == "alternating" else np.zeros(i.shape, dtype=bool)
        # diagonal n00-n11 (not flipped) or n10-n01 (flipped)
        t1 = np.where(flip[:, None], np.stack([n00, n10, n01], 1), np.stack([n00, n10, n11], 1))
        t2 = np.where(flip[:, None], np.stack([n10, n11, n01], 1), np.stack([n00, n11, n01], 1))
        tri = np.stack([t1, t2], axis=1).reshape(-1, 3)
    return TriMesh(pts, tri)


# --------------------------------------------------------------------------- disk / annulus
_GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)


def _ring(center: np.ndarray, r: float, count: int, phase: float) -> np.ndarray:
    theta = 2.0 * math.pi * (np.arange(count) + phase) / count
    return np.stack([center[0] + r * np.cos(theta), center[1] + r * np.sin(theta)], axis=1)


def _zip_rings(pts: np.ndarray, center: np.ndarray, inner: range, outer: range, out: list) -> None:
    """Triangulate the band between two counter-clockwise rings of nodes around ``center``.

    ``inner``/``outer`` are index ranges into ``pts``.  Walks both rings once, each step
    adding the triangle whose new diagonal is shorter.  Appends CCW triangles to ``out``.
    """
    a, b = list(inner), list(outer)
    na, nb = len(a), len(b)
    cx, cy = float(center[0]), float(center[1])

    def ang(k):
        return math.atan2(pts[k, 1] - cy, pts[k, 0] - cx)
    # start the outer ring at the node closest in angle to inner node 0
    a0 = ang(a[0])
    j0 = min(range(nb), key=lambda j: abs(math.remainder(ang(b[j]) - a0, 2 * math.pi)))
    b = b[j0:] + b[:j0]
    if na == 1:  # fan around the centre node
        c = a[0]
        out.extend((b[j], b[(j + 1) % nb], c) for j in range(nb))
        return
    px, py = pts[:, 0], pts[:, 1]

    def d2(p, q):
        return (px[p] - px[q]) ** 2 + (py[p] - py[q]) ** 2

    i = j = 0
    while i < na or j < nb:
        ai, ai1 = a[i % na], a[(i + 1) % na]
        bj, bj1 = b[j % nb], b[(j + 1) % nb]
        if j == nb or (i < na and d2(ai1, bj) <= d2(ai, bj1)):
            out.append((ai1, ai, bj))
            i += 1
        else:
            out.append((bj, bj1, ai))
            j += 1


def _rings_mesh(center: np.ndarray, radii: Sequence[float], h: float) -> TriMesh:
    """Concentric rings (radius 0 = a single centre node) zipped into triangles."""
    blocks, ranges, start = [], [], 0
    for k, r in enumerate(radii):
        if r == 0.0:
            blocks.append(center[None, :].copy())
            count = 1
        else:
            count = max(6, _nround(2.0 * math.pi * r / h))
            blocks.append(_ring(center, r, count, (k * _GOLDEN) % 1.0))
        ranges.append(range(start, start + count))
        start += count
    pts = np.vstack(blocks)
    tris: list = []
    for k in range(len(radii) - 1):
        _zip_rings(pts, center, ranges[k], ranges[k + 1], tris)
    return TriMesh(pts, np.array(tris, dtype=np.int32))


def disk(radius: float, h: float, center=(0.0, 0.0)) -> TriMesh:
    """A disk of ``radius`` [m] meshed with triangles of edge length about ``h`` [m].

    Nodes lie on concentric rings: ring 0 is the centre, ring ``k`` has radius
    ``k * radius / nr`` with ``nr = max(1, round(radius / h))`` and about
    ``2 pi r_k / h`` (at least 6) nodes, rings rotated by golden-ratio phases so that no
    radial line runs through the mesh.  The outer ring lies exactly on the circle, so the
    mesh is the inscribed polygon.  Neighbouring rings are zipped together choosing the
    shorter diagonal at each step; the smallest angle is above 35 degrees for every
    ``radius / h`` from 0.5 to 100.

    Example: ``disk(0.05, 0.02)`` has 25 nodes and 32 triangles.

    Raises ValueError for a non-positive radius or h, or h > 2 radius (the diameter).
    """
    where = "disk"
    r = _positive("radius", radius, where)
    h = _positive("h", h, where)
    c = _vec2("center", center, where)
    if h > 2.0 * r * (1.0 + 1e-9):
        raise ValueError(f"{where}: h={h:g} is larger than the diameter {2 * r:g}; use h <= {2 * r:g}")
    _guard_size(2.4 * math.pi * r * r / (h * h), where, h)
    nr = max(1, _nround(r / h))
    radii = [r * k / nr for k in range(nr)] + [r]
    return _rings_mesh(c, radii, h)


def annulus(r_inner: float, r_outer: float, h: float, center=(0.0, 0.0)) -> TriMesh:
    """A ring ``r_inner < |x - center| < r_outer`` [m] meshed with triangles of size ~``h`` [m].

    Same construction as :func:`disk`: ``nr = max(1, round((r_outer - r_inner) / h))``
    bands of equal width between rings of about ``2 pi r / h`` (at least 6) nodes; the
    nodes of the inner and outer rings lie exactly on the two circles.  Triangles are
    well shaped when ``r_inner`` is at least about ``h`` (smallest angle above 25
    degrees); a hole much smaller than ``h`` gives slender triangles around it.

    Raises ValueError unless ``0 < r_inner < r_outer``, for a non-positive h, or for
    h > 2 (r_outer - r_inner).
    """
    where = "annulus"
    ri = _positive("r_inner", r_inner, where)
    ro = _positive("r_outer", r_outer, where)
    h = _positive("h", h, where)
    c = _vec2("center", center, where)
    if ro <= ri:
        raise ValueError(f"{where}: r_outer={ro:g} must be larger than r_inner={ri:g}")
    if h > 2.0 * (ro - ri) * (1.0 + 1e-9):
        raise ValueError(f"{where}: h={h:g} is more than twice the ring width {ro - ri:g}; "
                         f"use h <= {2 * (ro - ri):g}")
    _guard_size(2.4 * math.pi * (ro * ro - ri * ri) / (h * h), where, h)
    nr = max(1, _nround((ro - ri) / h))
    radii = [ri + (ro - ri) * k / nr for k in range(nr)] + [ro]
    return _rings_mesh(c, radii, h)


# --------------------------------------------------------------------------- polygon
def _segments_intersect(p1, p2, q1, q2, tol):
    """Vectorised closed-segment intersection test (broadcasting over leading axes)."""
    def orient(a, b, c):
        return (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0])

    def on_segment(a, b, c):  # c collinear with a-b: is it within the bounding box?
        return ((np.minimum(a[..., 0], b[..., 0]) - tol <= c[..., 0]) & (c[..., 0] <= np.maximum(a[..., 0], b[..., 0]) + tol)
                & (np.minimum(a[..., 1], b[..., 1]) - tol <= c[..., 1]) & (c[..., 1] <= np.maximum(a[..., 1], b[..., 1]) + tol))

    eps = tol * tol
    d1, d2 = orient(q1, q2, p1), orient(q1, q2, p2)
    d3, d4 = orient(p1, p2, q1), orient(p1, p2, q2)
    proper = (((d1 > eps) & (d2 < -eps)) | ((d1 < -eps) & (d2 > eps))) & \
             (((d3 > eps) & (d4 < -eps)) | ((d3 < -eps) & (d4 > eps)))
    touch = ((np.abs(d1) <= eps) & on_segment(q1, q2, p1)) | ((np.abs(d2) <= eps) & on_segment(q1, q2, p2)) | \
            ((np.abs(d3) <= eps) & on_segment(p1, p2, q1)) | ((np.abs(d4) <= eps) & on_segment(p1, p2, q2))
    return proper | touch


def _check_simple(v: np.ndarray, where: str) -> None:
    """Raise ValueError if the closed polygon ``v`` (k, 2) is not simple."""
    k = len(v)
    scale = float(np.ptp(v, axis=0).max())
    tol = 1e-12 * scale
    a, b = v, np.roll(v, -1, axis=0)
    # adjacent edges folding back onto each other (a spike)
    e_in, e_out = b - a, np.roll(b - a, -1, axis=0)
    cross = e_in[:, 0] * e_out[:, 1] - e_in[:, 1] * e_out[:, 0]
    dot = (e_in * e_out).sum(1)
    norm = np.sqrt((e_in * e_in).sum(1) * (e_out * e_out).sum(1))
    spike = np.flatnonzero((np.abs(cross) <= 1e-12 * norm) & (dot < 0))
    if spike.size:
        i = int(spike[0])
        raise ValueError(f"{where}: polygon is not simple: edges {i} and {(i + 1) % k} fold back onto "
                         f"each other at vertex {(i + 1) % k}")
    if k < 4:
        return
    idx = np.arange(k)
    for start in range(0, k, 256):
        rows = idx[start:start + 256]
        hit = _segments_intersect(a[rows, None], b[rows, None], a[None], b[None], tol)
        ii, jj = np.meshgrid(rows, idx, indexing="ij")
        adjacent = (jj == ii) | (jj == (ii + 1) % k) | (ii == (jj + 1) % k)
        hit &= ~adjacent & (jj > ii)
        if hit.any():
            r, c = np.argwhere(hit)[0]
            i, j = int(rows[r]), int(c)
            raise ValueError(f"{where}: polygon is not simple (self-intersecting): edge {i} (vertices {i}-"
                             f"{(i + 1) % k}) meets edge {j} (vertices {j}-{(j + 1) % k})")


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


def polygon(vertices, h: float | None = None) -> TriMesh:
    """A triangle mesh of the simple polygon ``vertices`` [(x, y), ...] [m].

    The vertices may be given in either orientation, optionally with the first vertex
    repeated at the end.

    * ``h=None``: the vertices alone are triangulated (a constrained Delaunay
      triangulation: ``k - 2`` triangles for ``k`` vertices, the best-shaped
      triangulation with no extra nodes).
    * ``h`` given: every edge is divided into ``ceil(length / h)`` equal pieces, interior
      nodes are put on a hexagonal lattice of spacing ``h`` keeping those inside the
      polygon and farther than ``0.55 h`` from its boundary, and all nodes are
      triangulated by a constrained Delaunay triangulation (incremental Bowyer-Watson,
      boundary edges restored by edge flips).  Works for any simple polygon, convex or
      not.  Limitations: angles of the polygon sharper than ~30 degrees, and parts
      narrower than ``h``, get correspondingly slender triangles (no extra refinement is
      done there), and so do polygon edges much shorter than ``h`` (the vertices are
      kept); otherwise the smallest angle is typically above 25 degrees.

    Raises ValueError for fewer than 3 distinct vertices, non-finite coordinates, repeated
    consecutive vertices, zero area, a self-intersecting (non-simple) polygon, or a
    non-positive h.
    """
    where = "polygon"
    try:
        v = np.array(vertices, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: vertices must be a sequence of (x, y) pairs") from None
    if v.ndim != 2 or v.shape[1] != 2:
        raise ValueError(f"{where}: vertices must have shape (k, 2), got {v.shape}")
    bad = np.flatnonzero(~np.isfinite(v).all(axis=1))
    if bad.size:
        raise ValueError(f"{where}: vertex {int(bad[0])} is not finite: {tuple(v[bad[0]].tolist())}")
    if len(v) > 3 and np.array_equal(v[0], v[-1]):
        v = v[:-1]
    if len(v) < 3:
        raise ValueError(f"{where}: a polygon needs at least 3 vertices, got {len(v)}")
    scale = float(np.ptp(v, axis=0).max())
    step = np.roll(v, -1, axis=0) - v
    same = np.flatnonzero(np.sqrt((step * step).sum(1)) <= 1e-12 * scale)
    if same.size:
        i = int(same[0])
        raise ValueError(f"{where}: vertices {i} and {(i + 1) % len(v)} coincide at {tuple(v[i].tolist())}")
    signed = 0.5 * float(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
    if abs(signed) <= 1e-12 * scale * scale:
        sv = np.linalg.svd(v - v.mean(axis=0), compute_uv=False)
        if sv[1] > 1e-12 * sv[0]:  # not all collinear: e.g. a bow-tie
            _check_simple(v, where)
        raise ValueError(f"{where}: polygon has zero area")
    _check_simple(v, where)
    if signed < 0:
        v = v[::-1].copy()

    if h is None:
        boundary = v
        interior = np.empty((0, 2))
    else:
        h = _positive("h", h, where)
        _guard_size(2.4 * abs(signed) / (h * h), where, h)
        pieces = []
        for i in range(len(v)):
            a, b = v[i], v[(i + 1) % len(v)]
            count = max(1, math.ceil(float(np.hypot(*(b - a))) / h - 1e-9))
            t = np.arange(count)[:, None] / count
            pieces.append(a + t * (b - a))
        boundary = np.vstack(pieces)
        interior = _hex_lattice(v, h)
        if len(interior):
            interior = interior[_inside_polygon(interior, v)]
            interior = interior[_distance_to_polygon(interior, v) > 0.55 * h]
    pts = np.vstack([boundary, interior])
    nb = len(boundary)
    segments = [(i, (i + 1) % nb) for i in range(nb)]
    cdt = _CDT(pts)
    cdt.insert_all()
    cdt.recover(segments)
    tri = cdt.triangles()
    cent = pts[tri].mean(axis=1)
    tri = tri[_inside_polygon(cent, boundary)]
    mesh = TriMesh(pts, tri)
    if not math.isclose(mesh.area, abs(signed), rel_tol=1e-9) or len(mesh.boundary_edges()) != nb:
        raise RuntimeError(f"{where}: internal error: triangulation does not cover the polygon "
                           f"(area {mesh.area:.12g} vs {abs(signed):.12g})")
    return mesh.compact()


def _hex_lattice(v: np.ndarray, h: float) -> np.ndarray:
    """Hexagonal lattice points of spacing ``h`` covering the bounding box of ``v``."""
    lo, hi = v.min(axis=0), v.max(axis=0)
    dy = h * math.sqrt(3.0) / 2.0
    nx = int(math.floor((hi[0] - lo[0]) / h)) + 2
    ny = int(math.floor((hi[1] - lo[1]) / dy)) + 2
    cx, cy = 0.5 * (lo + hi)
    # centre the lattice on the bounding box so that symmetric shapes stay symmetric
    x0 = cx - h * (nx // 2)
    y0 = cy - dy * (ny // 2)
    i, j = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1))
    x = x0 + h * (i + 0.5 * (j % 2))
    y = y0 + dy * j
    p = np.stack([x.ravel(), y.ravel()], axis=1)
    keep = (p[:, 0] > lo[0]) & (p[:, 0] < hi[0]) & (p[:, 1] > lo[1]) & (p[:, 1] < hi[1])
    return p[keep]


class _CDT:
    """Constrained Delaunay triangulation of a point set (private helper).

    Incremental Bowyer-Watson insertion inside a large super-triangle, then constrained
    edges restored by Sloan's edge-flipping and the Delaunay property re-established by
    Lawson flips that never cross a constrained edge.  Triangles are CCW index triples;
    ``E`` maps each directed edge to the triangle that contains it, which gives the
    adjacency.  Predicates run on coordinates normalised to [-1, 1].
    """

    def __init__(self, points: np.ndarray):
        p = np.asarray(points, dtype=np.float64)
        lo, hi = p.min(axis=0), p.max(axis=0)
        c, s = 0.5 * (lo + hi), 0.5 * float((hi - lo).max())
        q = (p - c) / (s if s > 0 else 1.0)
        self.n = n = len(q)
        big = 1.0e3
        sup = [(0.0, 2.0 * big), (-math.sqrt(3.0) * big, -big), (math.sqrt(3.0) * big, -big)]
        self.x = q[:, 0].tolist() + [s_[0] for s_ in sup]
        self.y = q[:, 1].tolist() + [s_[1] for s_ in sup]
        self.T: list = [(n, n + 1, n + 2)]
        self.E: dict = {(n, n + 1): 0, (n + 1, n + 2): 0, (n + 2, n): 0}
        self.free: list = []
        self.last = 0
        self.constrained: set = set()

    # predicates ------------------------------------------------------------
    def orient(self, a, b, c):
        x, y = self.x, self.y
        return (x[b] - x[a]) * (y[c] - y[a]) - (y[b] - y[a]) * (x[c] - x[a])

    def well_oriented(self, a, b, c):
        """CCW and not nearly degenerate (stricter than TriMesh's degeneracy test)."""
        x, y = self.x, self.y
        abx, aby, acx, acy = x[b] - x[a], y[b] - y[a], x[c] - x[a], y[c] - y[a]
        bcx, bcy = x[c] - x[b], y[c] - y[b]
        d = abx * acy - aby * acx
        return d > 1e-10 * max(abx * abx + aby * aby, acx * acx + acy * acy, bcx * bcx + bcy * bcy)

    def in_circle(self, t, p):
        """> 0 when point p is strictly inside the circumcircle of triangle t (CCW)."""
        a, b, c = self.T[t]
        x, y = self.x, self.y
        px, py = x[p], y[p]
        adx, ady, bdx, bdy, cdx, cdy = x[a] - px, y[a] - py, x[b] - px, y[b] - py, x[c] - px, y[c] - py
        ad, bd, cd = adx * adx + ady * ady, bdx * bdx + bdy * bdy, cdx * cdx + cdy * cdy
        t1, t2, t3 = bdx * cdy - cdx * bdy, cdx * ady - adx * cdy, adx * bdy - bdx * ady
        det = ad * t1 + bd * t2 + cd * t3
        perm = ad * abs(t1) + bd * abs(t2) + cd * abs(t3)
        return det > 1e-12 * perm

    # triangle bookkeeping ---------------------------------------------------
    def _add(self, a, b, c):
        if self.free:
            t = self.free.pop()
            self.T[t] = (a, b, c)
        else:
            t = len(self.T)
            self.T.append((a, b, c))
        E = self.E
        E[(a, b)] = t
        E[(b, c)] = t
        E[(c, a)] = t
        return t

    def _remove(self, t):
        a, b, c = self.T[t]
        E = self.E
        for key in ((a, b), (b, c), (c, a)):
            if E.get(key) == t:
                del E[key]
        self.T[t] = None
        self.free.append(t)

    # insertion ---------------------------------------------------------------
    def locate(self, p):
        t = self.last
        if self.T[t] is None:
            t = next(k for k, tri in enumerate(self.T) if tri is not None)
        E, x, y = self.E, self.x, self.y
        px, py = x[p], y[p]

        def outside(u, v):
            # p farther than 1e-12 (normalised units) on the right of u->v?
            ex, ey = x[v] - x[u], y[v] - y[u]
            o = ex * (py - y[u]) - ey * (px - x[u])
            return o < 0.0 and o * o > 1e-24 * (ex * ex + ey * ey)

        for step in range(4 * len(self.T) + 10):
            a, b, c = self.T[t]
            edges = ((a, b), (b, c), (c, a))
            for k in range(3):
                u, v = edges[(k + step) % 3]
                if outside(u, v):
                    t = E[(v, u)]
                    break
            else:
                return t
        for t, tri in enumerate(self.T):  # pragma: no cover - walk failed (should not happen)
            if tri is not None and not any(outside(u, v) for u, v in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0]))):
                return t
        raise RuntimeError("delaunay: point location failed")  # pragma: no cover

    def insert(self, p):
        t0 = self.locate(p)
        x, y = self.x, self.y
        for q in self.T[t0]:
            if abs(x[q] - x[p]) + abs(y[q] - y[p]) <= 1e-13:
                raise ValueError(f"polygon: duplicate node ({p} and {q})")
        E, T = self.E, self.T
        cavity = {t0}
        rejected = set()
        stack = [t0]
        while stack:
            t = stack.pop()
            a, b, c = T[t]
            for u, v in ((a, b), (b, c), (c, a)):
                nb = E.get((v, u))
                if nb is None or nb in cavity or nb in rejected:
                    continue
                if self.in_circle(nb, p):
                    cavity.add(nb)
                    stack.append(nb)
                else:
                    rejected.add(nb)
        for _ in range(len(cavity) + 8):
            # keep the connected part containing t0, then check it is star-shaped from p
            comp, stack = {t0}, [t0]
            while stack:
                t = stack.pop()
                a, b, c = T[t]
                for u, v in ((a, b), (b, c), (c, a)):
                    nb = E.get((v, u))
                    if nb is not None and nb in cavity and nb not in comp:
                        comp.add(nb)
                        stack.append(nb)
            cavity = comp
            boundary, offenders = [], []
            for t in cavity:
                a, b, c = T[t]
                for u, v in ((a, b), (b, c), (c, a)):
                    if E.get((v, u)) in cavity:
                        continue
                    boundary.append((u, v))
                    if not self.well_oriented(u, v, p):
                        offenders.append((t, u, v))
            if not offenders:
                break
            for t, u, v in offenders:
                if t != t0:
                    cavity.discard(t)
                else:  # p lies on an edge of t0: take the triangle on the other side too
                    nb = E.get((v, u))
                    if nb is None:
                        raise RuntimeError("delaunay: point on the super-triangle boundary")  # pragma: no cover
                    cavity.add(nb)
        else:  # pragma: no cover
            raise RuntimeError("delaunay: could not form a star-shaped cavity")
        for t in cavity:
            self._remove(t)
        for u, v in boundary:
            self.last = self._add(u, v, p)

    def insert_all(self):
        """Insert every input point in a biased randomised order (BRIO): rounds of
        doubling size drawn from a fixed-seed permutation, each round in row-snake order,
        so that cavities stay small and point location walks stay short."""
        n = self.n
        if n == 0:
            return
        q = np.stack([np.array(self.x[:n]), np.array(self.y[:n])], axis=1)
        rank = np.empty(n, dtype=np.int64)
        rank[np.random.default_rng(20240607).permutation(n)] = np.arange(n)
        rnd = np.floor(np.log2(rank + 1.0)).astype(np.int64)
        lo, span = q.min(axis=0), np.maximum(np.ptp(q, axis=0), 1e-300)
        rows = max(1, int(math.sqrt(n / 4.0)))
        r = np.minimum(((q[:, 1] - lo[1]) / span[1] * rows).astype(np.int64), rows - 1)
        key_x = np.where(r % 2 == 0, q[:, 0], -q[:, 0])
        for p in np.lexsort((key_x, r, rnd)).tolist():
            self.insert(p)

    # constrained edges --------------------------------------------------------
    def _third(self, t, u, v):
        a, b, c = self.T[t]
        return c if (a, b) == (u, v) else a if (b, c) == (u, v) else b

    def _flip(self, p, q):
        """Flip edge p-q shared by (p, q, x) and (q, p, y); returns the new edge (x, y)."""
        E, T = self.E, self.T
        t1, t2 = E[(p, q)], E[(q, p)]
        x, y = self._third(t1, p, q), self._third(t2, q, p)
        del E[(p, q)], E[(q, p)]
        T[t1], T[t2] = (x, p, y), (y, q, x)
        E[(x, p)] = E[(p, y)] = E[(y, x)] = t1
        E[(y, q)] = E[(q, x)] = E[(x, y)] = t2
        return x, y

    def _convex(self, p, q):
        E = self.E
        x, y = self._third(E[(p, q)], p, q), self._third(E[(q, p)], q, p)
        return self.well_oriented(x, p, y) and self.well_oriented(y, q, x), x, y

    def _crosses(self, u, v, a, b):
        if a in (u, v) or b in (u, v):
            return False
        o = self.orient
        return o(u, v, a) * o(u, v, b) < 0.0 and o(a, b, u) * o(a, b, v) < 0.0

    def _crossing_edges(self, u, v):
        """Edges (l, r) crossed by segment u-v, l left of u->v, walking from u."""
        o = self.orient
        start = None
        for t, tri in enumerate(self.T):
            if tri is None or u not in tri:
                continue
            k = tri.index(u)
            a, b = tri[(k + 1) % 3], tri[(k + 2) % 3]
            oa, ob = o(u, a, v), o(u, b, v)
            if oa > 0.0 and ob < 0.0:
                start = (b, a)
                break
            if (oa == 0.0 and o(u, v, a) == 0.0 and (self.x[a] - self.x[u]) * (self.x[v] - self.x[u])
                    + (self.y[a] - self.y[u]) * (self.y[v] - self.y[u]) > 0.0):
                raise ValueError(f"polygon: node {a} lies on boundary segment {u}-{v}")
        if start is None:
            raise RuntimeError(f"delaunay: cannot start walking segment {u}-{v}")  # pragma: no cover
        out = [start]
        l, r = start
        for _ in range(len(self.T) + 1):
            c = self._third(self.E[(l, r)], l, r)
            if c == v:
                return out
            side = o(u, v, c)
            if side > 0.0:
                l = c
            elif side < 0.0:
                r = c
            else:
                raise ValueError(f"polygon: node {c} lies on boundary segment {u}-{v}")
            out.append((l, r))
        raise RuntimeError(f"delaunay: walk along segment {u}-{v} did not terminate")  # pragma: no cover

    def recover(self, segments):
        """Make every (u, v) in ``segments`` an edge; then restore Delaunay elsewhere."""
        E = self.E
        for u, v in segments:
            self.constrained.add((min(u, v), max(u, v)))
        for u, v in segments:
            if (u, v) in E or (v, u) in E:
                continue
            queue = deque(self._crossing_edges(u, v))
            new_edges = []
            limit = 50 * len(queue) * len(queue) + 100
            while queue:
                limit -= 1
                if limit < 0:
                    raise RuntimeError(f"delaunay: could not recover segment {u}-{v}")  # pragma: no cover
                p, q = queue.popleft()
                ok, x, y = self._convex(p, q)
                if not ok:
                    queue.append((p, q))
                    continue
                self._flip(p, q)
                if self._crosses(u, v, x, y):
                    queue.append((x, y))
                else:
                    new_edges.append((x, y))
            self._lawson(new_edges)

    def _lawson(self, edges):
        E, stack = self.E, list(edges)
        guard = 100 * (len(self.T) + 10)
        while stack and guard > 0:
            guard -= 1
            p, q = stack.pop()
            if (min(p, q), max(p, q)) in self.constrained or (p, q) not in E or (q, p) not in E:
                continue
            t2 = E[(q, p)]
            y = self._third(t2, q, p)
            if not self.in_circle(E[(p, q)], y):
                continue
            ok, x, y = self._convex(p, q)
            if not ok:
                continue
            self._flip(p, q)
            stack.extend(((p, y), (y, q), (q, x), (x, p)))

    def triangles(self) -> np.ndarray:
        """Triangles not touching the super-triangle, (m, 3) int64."""
        n = self.n
        tri = np.array([t for t in self.T if t is not None], dtype=np.int64).reshape(-1, 3)
        return tri[(tri < n).all(axis=1)]


# --------------------------------------------------------------------------- load / merge
_IGNORED_CELLS = {"vertex", "line", "line3", "line4", "line5", "line6"}
_VOLUME_CELLS = ("tetra", "hexahedron", "wedge", "pyramid")


def _topological_dimension(cell_type: str) -> int | None:
    if cell_type in _IGNORED_CELLS or cell_type.startswith("line"):
        return 1
    if cell_type.startswith(_VOLUME_CELLS):
        return 3
    if cell_type.startswith(("triangle", "quad", "polygon")):
        return 2
    try:
        from meshio._mesh import topological_dimension  # private, best effort
        return topological_dimension.get(cell_type)
    except Exception:  # pragma: no cover
        return None


def _read_planar(path, where: str):
    """``(name, meshio.Mesh, points (n, 2) float64)`` of a file meshio can read, the z
    coordinate dropped when constant; ValueError naming the file otherwise."""
    import meshio

    name = str(path)
    try:
        m = meshio.read(path)
    except OSError:
        raise
    except (meshio.ReadError, SystemExit, ValueError, IndexError, KeyError, UnicodeDecodeError) as exc:
        # meshio calls sys.exit(1) when no candidate reader accepts the file
        detail = f": {exc}" if str(exc) and not isinstance(exc, SystemExit) else ""
        raise ValueError(f"{where}: cannot read {name!r} as a mesh{detail}") from None
    pts = np.asarray(m.points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3) or len(pts) == 0:
        raise ValueError(f"{where}: {name!r} has no usable points (shape {pts.shape})")
    if pts.shape[1] == 3:
        z = pts[:, 2]
        extent = float(np.ptp(pts[:, :2], axis=0).max()) if len(pts) > 1 else 0.0
        if np.ptp(z) > 1e-10 * max(extent, 1e-300):
            raise ValueError(f"{where}: {name!r} is a 3D mesh (z varies from {z.min():g} to {z.max():g}); "
                             f"only planar meshes in the xy plane are supported")
        pts = pts[:, :2]
    return name, m, pts


def _triangle_block_indices(m, name: str, where: str) -> list[int]:
    """Indices of the linear "triangle" blocks of ``m``; points and lines are ignored, every
    other cell type (quadratic triangles, quads, polygons, volume cells) refused."""
    selected = []
    for k, block in enumerate(m.cells):
        dim = _topological_dimension(block.type)
        if block.type == "triangle":
            selected.append(k)
        elif block.type.startswith("triangle"):
            raise ValueError(f"{where}: {name!r} contains higher-order {block.type!r} cells (block {k}); "
                             f"only linear 3-node 'triangle' cells are supported (re-mesh with order 1)")
        elif dim == 3:
            raise ValueError(f"{where}: {name!r} is a 3D mesh (contains {block.type!r} cells)")
        elif dim == 2:
            raise ValueError(f"{where}: {name!r} contains {block.type!r} cells (block {k}); only 'triangle' "
                             f"cells are supported (mixed meshes are refused)")
    if not selected:
        raise ValueError(f"{where}: {name!r} contains no triangle cells "
                         f"(found: {sorted({b.type for b in m.cells}) or 'no cells'})")
    return selected


def _mesh_of(pts: np.ndarray, tri: np.ndarray, name: str, where: str) -> TriMesh:
    try:
        mesh = TriMesh(pts, tri)
    except ValueError as exc:
        raise ValueError(f"{where}: {name!r}: {exc}") from None
    return mesh.compact()


def load(path, cell_block: int | None = None) -> TriMesh:
    """Read a triangle mesh from any file meshio can read (gmsh ``.msh`` 2.2/4.1, ``.vtu``,
    ``.vtk``, ``.xdmf``, ...).

    Parameters
    ----------
    path : str or os.PathLike
    cell_block : index into meshio's ``mesh.cells`` of the one block to use (it must be a
        "triangle" block).  Default None concatenates every "triangle" block.

    The z coordinate is dropped when it is constant (a mesh drawn in a plane z = const);
    a genuinely 3D mesh is refused.  Point and line cells (gmsh boundary elements) are
    ignored; quadratic triangles ("triangle6"), quads, polygons or volume cells are
    refused, as is a file without triangles.  Clockwise triangles are reoriented,
    degenerate ones refused (see :class:`TriMesh`), and points no triangle uses (e.g.
    gmsh geometry points) dropped with :meth:`TriMesh.compact`.  Coordinates are taken
    as metres.  To split a file into one mesh per physical group, use :func:`load_groups`.
    """
    name, m, pts = _read_planar(path, "load")
    blocks = list(m.cells)
    if cell_block is not None:
        if not isinstance(cell_block, (int, np.integer)) or not -len(blocks) <= cell_block < len(blocks):
            raise ValueError(f"load: cell_block={cell_block!r} is not a valid block index for {name!r} "
                             f"({len(blocks)} blocks: {[b.type for b in blocks]})")
        chosen = blocks[cell_block]
        if chosen.type != "triangle":
            raise ValueError(f"load: block {cell_block} of {name!r} holds {chosen.type!r} cells, not 'triangle'")
        selected = [chosen]
    else:
        selected = [blocks[k] for k in _triangle_block_indices(m, name, "load")]
    tri = np.concatenate([np.asarray(b.data, dtype=np.int64).reshape(-1, 3) for b in selected])
    return _mesh_of(pts, tri, name, "load")


#: cell-data keys tried, in order, by :func:`load_groups` when no ``key`` is given.
GROUP_KEYS = ("gmsh:physical", "cell_tags", "medit:ref", "tag", "tags", "region", "regions")


def load_groups(path, key: str | None = None) -> dict:
    """Read a triangle mesh and split it into one :class:`TriMesh` per physical group / cell tag.

    Parameters
    ----------
    path : str or os.PathLike, any file meshio reads (gmsh ``.msh`` 2.2 and 4.1, ``.vtu``, ...).
    key : name of the integer cell-data array holding the group tag of every cell.  Default:
        the first of :data:`GROUP_KEYS` present in the file (``"gmsh:physical"`` for gmsh
        files, i.e. the physical groups).

    Returns
    -------
    dict mapping each group to its mesh, in increasing tag order.  A group is keyed by its
    name when the file names it (gmsh ``$PhysicalNames`` of dimension 2, meshio
    ``field_data``), otherwise by its integer tag.

    Each group becomes a separate mesh with its own nodes: nodes on the interface of two
    groups are duplicated (each group compacted with :meth:`TriMesh.compact`), so groups
    added as bodies touch along the interface and interact by contact.  The checks of
    :func:`load` apply (planar mesh, linear triangles only, clockwise triangles
    reoriented, degenerate ones refused); point and line cells (boundary groups) are
    ignored.  ValueError names the file and the key when the tags are missing or invalid.
    """
    where = "load_groups"
    name, m, pts = _read_planar(path, where)
    selected = _triangle_block_indices(m, name, where)
    cell_data = dict(m.cell_data)
    if key is None:
        key = next((k for k in GROUP_KEYS if k in cell_data), None)
        if key is None:
            raise ValueError(f"{where}: {name!r} has no cell tags (none of the cell-data arrays "
                             f"{list(GROUP_KEYS)}; found {sorted(cell_data) or 'no cell data'}); "
                             f"give key=... or use load() for a single mesh")
    elif not isinstance(key, str):
        raise ValueError(f"{where}: key must be a cell-data name (str), got {key!r}")
    elif key not in cell_data:
        raise ValueError(f"{where}: {name!r} has no cell-data array {key!r} "
                         f"(found {sorted(cell_data) or 'no cell data'})")
    data = cell_data[key]
    if len(data) != len(m.cells):
        # meshio's gmsh 4.1 reader lists tags only for the entities that have a physical group
        raise ValueError(f"{where}: {name!r}: cell data {key!r} covers {len(data)} of {len(m.cells)} cell "
                         f"blocks; in gmsh, put every surface in a physical group (or none of them)")
    tris, tags = [], []
    for k in selected:
        t = np.asarray(m.cells[k].data, dtype=np.int64).reshape(-1, 3)
        g = np.asarray(data[k])
        if g.ndim == 2 and g.shape[1] == 1:
            g = g[:, 0]
        if g.shape != (len(t),):
            raise ValueError(f"{where}: {name!r}: cell data {key!r} of block {k} has shape {g.shape}, "
                             f"expected one tag per triangle ({len(t)},)")
        if g.dtype.kind == "f":
            if not (np.all(np.isfinite(g)) and np.all(g == np.round(g))):
                raise ValueError(f"{where}: {name!r}: cell data {key!r} of block {k} is not integer-valued")
        elif g.dtype.kind not in "iu":
            raise ValueError(f"{where}: {name!r}: cell data {key!r} of block {k} has dtype {g.dtype}, "
                             f"expected integer tags")
        tris.append(t)
        tags.append(g.astype(np.int64))
    tri = np.concatenate(tris)
    tag = np.concatenate(tags)
    # names of the 2D physical groups: field_data[name] = [tag, dim] (gmsh) or [tag]
    names = {}
    for group_name, fd in (m.field_data or {}).items():
        fd = np.asarray(fd).ravel()
        if fd.size == 0 or (fd.size >= 2 and int(fd[1]) != 2):
            continue
        names.setdefault(int(fd[0]), str(group_name))
    out = {}
    for value in np.unique(tag).tolist():
        label = names.get(int(value), int(value))
        try:
            out[label] = _mesh_of(pts, tri[tag == value], name, where)
        except ValueError as exc:
            raise ValueError(f"{exc} (group {label!r}, {key} = {value})") from None
    return out


def scene_from_groups(scene, path, materials, key: str | None = None, **add_body_kwargs) -> dict:
    """Add one body per physical group of a mesh file to ``scene``.

    Parameters
    ----------
    scene : :class:`~taichi_fdem.scene.Scene`.
    path : mesh file, read with :func:`load_groups`.
    materials : a :class:`~taichi_fdem.material.Material` for every group, or a dict
        mapping each group (its name, or integer tag when unnamed) to a Material.  Every
        group of the file must have a material, and every key must be a group of the file.
    key : cell-data tag array (see :func:`load_groups`).
    **add_body_kwargs : passed to :meth:`Scene.add_body` for every body (e.g. ``velocity``,
        ``fixed``).  ``position`` and ``name`` are not allowed: bodies keep the file's
        coordinates [m] and are named after their group.

    Returns
    -------
    dict group -> :class:`~taichi_fdem.scene.Body`, in increasing tag order.
    """
    from .material import Material

    where = "scene_from_groups"
    for bad in ("position", "name"):
        if bad in add_body_kwargs:
            raise ValueError(f"{where}: {bad}= is not allowed (bodies keep the file's coordinates and are "
                             f"named after their group)")
    groups = load_groups(path, key=key)
    if isinstance(materials, Material):
        mats = {g: materials for g in groups}
    elif isinstance(materials, dict):
        missing = [g for g in groups if g not in materials]
        extra = [g for g in materials if g not in groups]
        if missing or extra:
            parts = []
            if missing:
                parts.append(f"no material for group(s) {missing}")
            if extra:
                parts.append(f"material key(s) {extra} are not groups of the file")
            raise ValueError(f"{where}: {str(path)!r}: {'; '.join(parts)} (groups: {list(groups)})")
        for g, mat in materials.items():
            if not isinstance(mat, Material):
                raise ValueError(f"{where}: materials[{g!r}] must be a Material, got {type(mat).__name__}")
        mats = materials
    else:
        raise ValueError(f"{where}: materials must be a Material or a dict group -> Material, "
                         f"got {type(materials).__name__}")
    return {g: scene.add_body(mesh, mats[g], name=str(g), **add_body_kwargs) for g, mesh in groups.items()}


def merge(meshes: Iterable[TriMesh]) -> TriMesh:
    """Concatenate meshes into one (node indices offset; no nodes are shared or fused)."""
    ms = list(meshes)
    if not ms:
        raise ValueError("merge: no meshes given")
    for k, mm in enumerate(ms):
        if not isinstance(mm, TriMesh):
            raise ValueError(f"merge: item {k} is a {type(mm).__name__}, not a TriMesh")
    offsets = np.cumsum([0] + [mm.point_count for mm in ms[:-1]])
    pts = np.vstack([mm.points for mm in ms])
    tri = np.vstack([mm.triangles.astype(np.int64) + off for mm, off in zip(ms, offsets)])
    return TriMesh(pts, tri)


# named constructors, scikit-fem style: TriMesh.disk(...), TriMesh.load(...), ...
TriMesh.rectangle = staticmethod(rectangle)
TriMesh.disk = staticmethod(disk)
TriMesh.annulus = staticmethod(annulus)
TriMesh.polygon = staticmethod(polygon)
TriMesh.load = staticmethod(load)
TriMesh.load_groups = staticmethod(load_groups)
TriMesh.merge = staticmethod(merge)

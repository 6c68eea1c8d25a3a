"""Mesh generators: :func:`rectangle`, :func:`disk`, :func:`annulus` and :func:`polygon` (pure NumPy).

``h`` is always the target element edge length [m].  The generators use Python loops that
are linear (rings) or roughly ``O(n log n)`` (incremental Delaunay, in
:mod:`~taichi_fdem.mesh.triangulate`) in the number of nodes; they never loop in Python
over the elements of an existing mesh.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from .arrangement import _distance_to_polygon, _inside_polygon, arrange, distance_to_segments
from .lines import Segments, as_segments
from .triangulate import _CDT
from .trimesh import MAX_COORDINATE, TriMesh, _guard_size, _nround, _positive, _vec2

__all__ = ["rectangle", "disk", "annulus", "polygon", "plate_with_hole"]


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
    per_cell = 4 if pattern == "crossed" else 2
    # guard in floats before rounding to integers: w / h may be far beyond any integer count
    _guard_size(max(1.0, w / h) * max(1.0, hh / h) * per_cell, where, h)
    nx, ny = max(1, _nround(w / h)), max(1, _nround(hh / h))
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


def _rings_mesh(center: np.ndarray, radii: Sequence[float], h: float, layout: str = "symmetric") -> TriMesh:
    """Concentric rings (radius 0 = a single centre node) zipped into triangles."""
    if layout == "symmetric":
        return _symmetric_rings_mesh(center, radii, h)
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


def _symmetric_rings_mesh(center: np.ndarray, radii: Sequence[float], h: float) -> TriMesh:
    """Concentric rings with D2 symmetry: mirror images of one quadrant about both axes.

    Ring ``k`` of radius ``r_k > 0`` has ``4 m_k`` nodes at angles ``t pi / (2 m_k)``,
    ``m_k = max(2, round(pi r_k / (2 h)))``, so every ring has nodes on both axes.  The
    quadrant ``0 <= angle <= 90 deg`` is zipped ring to ring (shorter diagonal first) and
    mirrored about the y axis, then the upper half about the x axis; mirrored coordinates
    are exact negations before the translation by ``center``.
    """
    m = np.array([0 if r == 0.0 else max(2, _nround(0.5 * math.pi * r / h)) for r in radii])
    count = np.maximum(1, 4 * m)
    base = np.concatenate([[0], np.cumsum(count)[:-1]])
    local = np.zeros((int(count.sum()), 2))
    for k, (r, mk) in enumerate(zip(radii, m)):
        if mk == 0:
            continue
        th = 0.5 * math.pi * np.arange(mk + 1) / mk
        q = np.stack([r * np.cos(th), r * np.sin(th)], axis=1)
        q[0] = (r, 0.0)
        q[-1] = (0.0, r)
        ring = local[base[k]:base[k] + 4 * mk]
        ring[:mk + 1] = q
        t = np.arange(mk + 1, 2 * mk + 1)
        ring[t] = q[2 * mk - t] * (-1.0, 1.0)
        t = np.arange(2 * mk + 1, 4 * mk)
        ring[t] = ring[4 * mk - t] * (1.0, -1.0)

    def d2(p, q):
        return float(((local[p] - local[q]) ** 2).sum())

    quad: list = []  # triangles of the first quadrant as (ring, angular index) triples
    for k in range(len(radii) - 1):
        outer = [(k + 1, j) for j in range(m[k + 1] + 1)]
        if m[k] == 0:
            quad.extend(((k, 0), outer[j], outer[j + 1]) for j in range(m[k + 1]))
            continue
        inner = [(k, i) for i in range(m[k] + 1)]
        i = j = 0
        while i < m[k] or j < m[k + 1]:
            ai, bj = base[k] + i, base[k + 1] + j
            if j == m[k + 1] or (i < m[k] and d2(ai + 1, bj) <= d2(ai, bj + 1)):
                quad.append((inner[i], outer[j], inner[i + 1]))
                i += 1
            else:
                quad.append((inner[i], outer[j], outer[j + 1]))
                j += 1
    q = np.array(quad)                                    # (T, 3, 2): ring, angular index
    ring, t = q[..., 0], q[..., 1]
    mk, n = m[ring], count[ring]
    tris = []
    for flip_x, flip_y in ((False, False), (True, False), (False, True), (True, True)):
        tt = t.copy()
        if flip_x:
            tt = (2 * mk - tt) % n
        if flip_y:
            tt = (n - tt) % n
        ids = np.where(mk == 0, base[ring], base[ring] + tt)
        tris.append(ids[:, ::-1] if flip_x != flip_y else ids)
    return TriMesh(local + center, np.vstack(tris).astype(np.int32))


def disk(radius: float, h: float, center=(0.0, 0.0), layout: str = "symmetric") -> TriMesh:
    """A disk of ``radius`` [m] meshed with triangles of edge length about ``h`` [m].

    Nodes lie on concentric rings: ring 0 is the centre, ring ``k`` has radius
    ``k * radius / nr`` with ``nr = max(1, round(radius / h))``.  The outer ring lies exactly
    on the circle, so the mesh is the inscribed polygon.  ``layout``:

    - ``"symmetric"`` (default): ring ``k`` has ``4 m_k`` nodes, ``m_k = max(2, round(pi r_k
      / (2 h)))``, with nodes on both axes through ``center``; the mesh is the mirror image of
      one quadrant about both axes (bit for bit about ``center = (0, 0)``; the nodes are then
      translated by ``center``), so its centre of mass is ``center`` and a normal impact on a
      flat surface along an axis exerts no torque.  The smallest angle is above 37 degrees for every
      ``radius / h`` from 0.5 to 100.
    - ``"spiral"``: rings of about ``2 pi r_k / h`` (at least 6) nodes rotated by golden-ratio
      phases, so that no radial line runs through the mesh (no mirror symmetry): the layout
      for a fracturing specimen, whose crack would otherwise follow the straight lines of edges
      along the axes; the smallest angle is above 35 degrees for every ``radius / h`` from 0.5
      to 100.

    Neighbouring rings are zipped together choosing the shorter diagonal at each step.

    Example: ``disk(0.05, 0.02)`` has 25 nodes and 32 triangles in either layout.

    Raises ValueError for a non-positive radius or h, h > 2 radius (the diameter), or an
    unknown ``layout``.
    """
    where = "disk"
    r = _positive("radius", radius, where)
    h = _positive("h", h, where)
    c = _vec2("center", center, where)
    _check_layout(layout, where)
    if h > 2.0 * r * (1.0 + 1e-9):
        raise ValueError(f"{where}: h={h:g} is larger than the diameter {2 * r:g}; use h <= {2 * r:g}")
    _guard_size(2.4 * math.pi * r * r / (h * h), where, h)
    nr = max(1, _nround(r / h))
    radii = [r * k / nr for k in range(nr)] + [r]
    return _rings_mesh(c, radii, h, layout)


_LAYOUTS = ("symmetric", "spiral")


def _check_layout(layout, where: str) -> None:
    if layout not in _LAYOUTS:
        raise ValueError(f"{where}: layout={layout!r} is not one of {', '.join(map(repr, _LAYOUTS))}")


def annulus(r_inner: float, r_outer: float, h: float, center=(0.0, 0.0), layout: str = "symmetric") -> TriMesh:
    """A ring ``r_inner < |x - center| < r_outer`` [m] meshed with triangles of size ~``h`` [m].

    Same construction and ``layout`` as :func:`disk`: ``nr = max(1, round((r_outer -
    r_inner) / h))`` bands of equal width between rings; the nodes of the inner and outer
    rings lie exactly on the two circles.  Triangles are
    well shaped when ``r_inner`` is at least about ``h`` (smallest angle above 25
    degrees); a hole much smaller than ``h`` gives slender triangles around it.

    Raises ValueError unless ``0 < r_inner < r_outer``, for a non-positive h, for
    h > 2 (r_outer - r_inner), or an unknown ``layout``.
    """
    where = "annulus"
    _check_layout(layout, where)
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
    return _rings_mesh(c, radii, h, layout)


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


def _checked_outline(vertices, where: str):
    """(v (k, 2) float64, the signed area [m²] of ``vertices``): the polygon ``vertices`` checked
    (finite, within MAX_COORDINATE, at least 3 distinct consecutive vertices, a non-zero area,
    simple) as a counter-clockwise outline without the repeated closing vertex; ValueError
    naming what is wrong."""
    try:
        v = np.array(vertices, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: vertices must be a sequence of (x, y) pairs") from None
    if v.ndim != 2 or v.shape[1] != 2:
        raise ValueError(f"{where}: vertices must have shape (k, 2), got {v.shape}")
    bad = np.flatnonzero(~np.isfinite(v).all(axis=1))
    if bad.size:
        raise ValueError(f"{where}: vertex {int(bad[0])} is not finite: {tuple(v[bad[0]].tolist())}")
    far = np.flatnonzero(np.abs(v).max(axis=1) > MAX_COORDINATE)
    if far.size:
        raise ValueError(f"{where}: vertex {int(far[0])} = {tuple(v[far[0]].tolist())} lies beyond {MAX_COORDINATE:g} m "
                         f"from the origin (coordinates are in metres)")
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
    return v, signed


def polygon(vertices, h: float | None = None, lines=None, engine: str = "builtin") -> TriMesh:
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

    Embedded lines (``lines``): a list of :class:`~taichi_fdem.mesh.Polyline`,
    :class:`~taichi_fdem.mesh.Segments` or ``(n, 2)`` point arrays (each an open polyline)
    -- faults, joints, cracks -- that the mesh edges must follow.

    * Every line lies inside the polygon or on its boundary.  An end point may lie on the
      boundary (the boundary gets a node there) or inside (a crack tip inside the body).
    * Crossings of lines with each other (a discrete fracture network), T-junctions and
      meetings with the boundary become nodes; points closer than ``1e-9`` times the
      polygon's size are merged into one node.
    * Collinear overlapping parts are refused (ValueError), not merged: two lines running
      along each other, or a line running along the boundary (boundary edges are mesh
      edges already).  Give the common part once.
    * With ``h``, each line piece between nodes is divided into ``ceil(length / h)``
      equal pieces and lattice nodes closer than ``0.55 h`` to a line are dropped.  The
      line pieces are constrained edges of the triangulation, so that
      ``Polyline(...).select_edges(mesh.points, mesh.edges())`` selects edges whose total
      length is the line's length.  Input features smaller than ``h`` (a line end a
      little off another line or the boundary, lines crossing at a small angle, pieces
      much shorter than ``h``) give correspondingly small angles: no node is moved.

    engine : ``"builtin"`` (default: the triangulator above, no dependency, the same
        result everywhere), ``"gmsh"`` (gmsh's Python API, ``pip install
        "taichi-fdem[mesh]"``; needs ``h``; ImportError without gmsh) or ``"auto"``
        (gmsh when importable, else builtin).

    Raises ValueError for fewer than 3 distinct vertices, non-finite coordinates, repeated
    consecutive vertices, zero area, a self-intersecting (non-simple) polygon, a
    non-positive h, a line leaving the polygon (naming the line and the point outside)
    or overlapping lines.  RuntimeError if the built-in triangulator cannot make every
    line piece an edge (it then never returns a mesh that does not follow the lines).
    """
    where = "polygon"
    v, signed = _checked_outline(vertices, where)
    if engine not in _ENGINES:
        raise ValueError(f"{where}: unknown engine {engine!r}; choose one of {list(_ENGINES)}")
    if h is not None:
        h = _positive("h", h, where)
        _guard_size(2.4 * abs(signed) / (h * h), where, h)
    line_list = _line_list(lines, where)
    arr = arrange(v, line_list, where) if line_list else None
    if engine == "auto":
        engine = "gmsh" if _gmsh_importable() else "builtin"
    if engine == "gmsh":
        from .gmsh_engine import polygon_gmsh
        mesh = polygon_gmsh(v, h, arr, where)
        _check_mesh(mesh, v, arr, abs(signed), "gmsh", where)
        return mesh
    return _polygon_builtin(v, h, arr, abs(signed), where)


def _check_mesh(mesh: TriMesh, v: np.ndarray, arr, area: float, engine: str, where: str) -> None:
    """RuntimeError unless ``mesh`` covers the polygon and its edges follow every line piece."""
    if not math.isclose(mesh.area, area, rel_tol=1e-9):
        raise RuntimeError(f"{where}: the {engine} mesh does not cover the polygon (area {mesh.area:.12g} "
                           f"vs {area:.12g})")
    if arr is None or not len(arr.pieces):
        return
    e = mesh.edges()
    for k in range(len(arr.pieces)):   # one piece at a time: a loop over the (few) line pieces
        piece = Segments(arr.nodes[arr.pieces[k]][None])
        got = float(mesh.edge_lengths(e[piece.select_edges(mesh.points, e, tol=arr.tol)]).sum())
        if not math.isclose(got, piece.length, rel_tol=1e-9):
            raise RuntimeError(f"{where}: the {engine} mesh does not follow line {int(arr.piece_line[k])} from "
                               f"{tuple(arr.nodes[arr.pieces[k, 0]].tolist())} to "
                               f"{tuple(arr.nodes[arr.pieces[k, 1]].tolist())}")


_ENGINES = ("builtin", "gmsh", "auto")


def _gmsh_importable() -> bool:
    try:
        import gmsh  # noqa: F401
    except (ImportError, OSError):   # OSError: the wheel is there but a system library is not
        return False
    return True


def _line_list(lines, where: str) -> list:
    """``lines`` as a list of :class:`Segments` (None or empty: no lines)."""
    if lines is None:
        return []
    if isinstance(lines, (Segments, np.ndarray)):
        raise ValueError(f"{where}: lines must be a list of Polyline / Segments / (n, 2) point arrays; "
                         f"wrap a single line in a list: lines=[line]")
    try:
        items = list(lines)
    except TypeError:
        raise ValueError(f"{where}: lines must be a list, got {type(lines).__name__}") from None
    out = [as_segments(line, where, i) for i, line in enumerate(items)]
    for i, seg in enumerate(out):
        far = np.abs(seg.segments).max()
        if far > MAX_COORDINATE:
            raise ValueError(f"{where}: line {i} has a point beyond {MAX_COORDINATE:g} m from the origin")
    return out


def _divide(p: np.ndarray, q: np.ndarray, h: float | None) -> np.ndarray:
    """Points dividing p-q into ceil(|pq| / h) equal pieces, p included, q excluded, (c, 2)."""
    count = 1 if h is None else max(1, math.ceil(float(np.hypot(*(q - p))) / h - 1e-9))
    t = np.arange(count)[:, None] / count
    return p + t * (q - p)


def _polygon_builtin(v: np.ndarray, h, arr, area: float, where: str) -> TriMesh:
    """The built-in engine: boundary (and line) nodes every ~h, a hexagonal lattice inside,
    constrained Delaunay triangulation with the outline and the line pieces as constraints."""
    if arr is None:
        ring_pts, ring_nodes = v, None
    else:
        ring_nodes = arr.nodes[arr.ring]
        ring_pts = ring_nodes
    if h is None:
        boundary = ring_pts
    else:
        boundary = np.vstack([_divide(ring_pts[i], ring_pts[(i + 1) % len(ring_pts)], h)
                              for i in range(len(ring_pts))])
    nb = len(boundary)
    blocks = [boundary]
    line_edges: list = []
    line_of_edge: list = []
    if arr is not None:
        # ids of the arrangement nodes in the point list: ring nodes are boundary points
        # (found by position), the others follow the boundary
        node_id = np.full(len(arr.nodes), -1, dtype=np.int64)
        if h is None:
            node_id[arr.ring] = np.arange(len(arr.ring))
        else:
            counts = [len(_divide(ring_pts[i], ring_pts[(i + 1) % len(ring_pts)], h)) for i in range(len(ring_pts))]
            node_id[arr.ring] = np.concatenate([[0], np.cumsum(counts)[:-1]])
        free = np.flatnonzero(node_id < 0)
        node_id[free] = nb + np.arange(len(free))
        blocks.append(arr.nodes[free])
        nxt = nb + len(free)
        for (a, b), line in zip(arr.pieces.tolist(), arr.piece_line.tolist()):
            inner = _divide(arr.nodes[a], arr.nodes[b], h)[1:]
            ids = [int(node_id[a])] + list(range(nxt, nxt + len(inner))) + [int(node_id[b])]
            nxt += len(inner)
            blocks.append(inner)
            line_edges.extend(zip(ids[:-1], ids[1:]))
            line_of_edge.extend([line] * (len(ids) - 1))
    if h is not None:
        interior = _hex_lattice(v, h)
        if len(interior):
            interior = interior[_inside_polygon(interior, v)]
            interior = interior[_distance_to_polygon(interior, v) > 0.55 * h]
            if arr is not None and len(arr.pieces):
                piece_segs = arr.nodes[arr.pieces]
                interior = interior[distance_to_segments(interior, piece_segs) > 0.55 * h]
        blocks.append(interior)
    pts = np.vstack(blocks)
    segments = [(i, (i + 1) % nb) for i in range(nb)]
    cdt = _CDT(pts)
    cdt.insert_all()
    cdt.recover(segments)
    if line_edges:
        try:
            cdt.recover(line_edges)
        except (ValueError, RuntimeError) as exc:
            raise RuntimeError(f"{where}: the built-in triangulator could not make the lines mesh edges "
                               f"({exc}); try another h, or engine='gmsh'") from None
    tri = cdt.triangles()
    cent = pts[tri].mean(axis=1)
    tri = tri[_inside_polygon(cent, boundary)]
    mesh = TriMesh(pts, tri)
    if not math.isclose(mesh.area, area, rel_tol=1e-9) or len(mesh.boundary_edges()) != nb:
        raise RuntimeError(f"{where}: internal error: triangulation does not cover the polygon "
                           f"(area {mesh.area:.12g} vs {area:.12g})")
    if line_edges:
        n = mesh.point_count
        have = mesh.edges().astype(np.int64)
        want = np.sort(np.array(line_edges, dtype=np.int64), axis=1)
        missing = ~np.isin(want[:, 0] * n + want[:, 1], have[:, 0] * n + have[:, 1])
        if missing.any():
            j = int(np.flatnonzero(missing)[0])
            raise RuntimeError(f"{where}: the built-in triangulator lost a piece of line {line_of_edge[j]} "
                               f"from {tuple(pts[want[j, 0]].tolist())} to {tuple(pts[want[j, 1]].tolist())}; "
                               f"try another h, or engine='gmsh'")
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


# --------------------------------------------------------------------------- plate with a hole
def plate_with_hole(width: float, height: float, radius: float, h_hole: float, center=(0.0, 0.0)) -> TriMesh:
    """A ``width`` x ``height`` rectangle [m] with a central circular hole of ``radius`` [m],
    meshed by a graded O-grid: fine (edge ~``h_hole`` [m]) at the hole, coarser outwards.

    Rays from the centre at ``n`` angles (about ``2 pi radius / h_hole``, a multiple of 4; the
    four corners and the four axis directions are rays, so the mesh is symmetric about both
    axes and can be cut into quarters along them) carry nodes from the hole (radius ``radius``)
    to the rectangle at radii ``radius (R_k / radius)^(j / m)``, R_k where ray k meets the
    rectangle: cells are near-square at the hole and grow geometrically (log-polar grading,
    ``m`` layers).  Each cell is split along its shorter diagonal.  Built for stress
    concentration problems (Kirsch, docs/theory/loads.md §12.6), where the fine cells are needed at the
    hole only.

    Raises ValueError for non-positive sizes, a hole that does not fit
    (``2 radius >= min(width, height)``) or ``h_hole`` larger than the radius.
    """
    where = "plate_with_hole"
    w = _positive("width", width, where)
    hh = _positive("height", height, where)
    a = _positive("radius", radius, where)
    h = _positive("h_hole", h_hole, where)
    c = _vec2("center", center, where)
    if 2.0 * a >= min(w, hh) * (1.0 - 1e-9):
        raise ValueError(f"{where}: the hole (radius {a:g}) does not fit in {w:g} x {hh:g}")
    if h > a:
        raise ValueError(f"{where}: h_hole={h:g} is larger than the radius {a:g}; use h_hole <= radius")
    X, Y = 0.5 * w, 0.5 * hh
    alpha = math.atan2(Y, X)                          # angle of the upper-right corner
    # rays: per quadrant, n1 between the x axis and the corner, n2 between the corner and the y axis
    n1 = max(1, _nround(alpha * a / h))
    n2 = max(1, _nround((0.5 * math.pi - alpha) * a / h))
    q1 = np.concatenate([np.linspace(0.0, alpha, n1 + 1)[:-1], np.linspace(alpha, 0.5 * math.pi, n2 + 1)])
    half = np.concatenate([q1, (math.pi - q1[::-1])[1:]])                 # 0 .. pi, mirrored about the y axis
    theta = np.concatenate([half[:-1], (2.0 * math.pi - half[::-1])[:-1]])  # 0 .. 2 pi, mirrored about x
    n = len(theta)
    ct, st = np.cos(theta), np.sin(theta)
    with np.errstate(divide="ignore"):
        R = np.minimum(np.where(np.abs(ct) > 1e-12, X / np.abs(ct), np.inf),
                       np.where(np.abs(st) > 1e-12, Y / np.abs(st), np.inf))
    dtheta = 2.0 * math.pi / n
    m = max(1, _nround(math.log(float(np.mean(R)) / a) / dtheta))
    _guard_size(2.0 * n * m, where, h)
    t = np.arange(m + 1) / m
    r = a * (R[None, :] / a) ** t[:, None]             # (m+1, n)
    pts = np.stack([c[0] + r * ct[None, :], c[1] + r * st[None, :]], axis=2).reshape(-1, 2)
    # snap the outer ring exactly onto the rectangle (corners and sides)
    outer = slice(m * n, (m + 1) * n)
    pts[outer, 0] = np.clip(pts[outer, 0], c[0] - X, c[0] + X)
    pts[outer, 1] = np.clip(pts[outer, 1], c[1] - Y, c[1] + Y)
    j, k = np.meshgrid(np.arange(m), np.arange(n), indexing="ij")
    j, k = j.ravel(), k.ravel()
    n00 = j * n + k
    n10 = j * n + (k + 1) % n                          # next ray, same layer
    n01, n11 = n00 + n, n10 + n
    d1 = np.hypot(*(pts[n00] - pts[n11]).T)
    d2 = np.hypot(*(pts[n10] - pts[n01]).T)
    short = (d1 <= d2)[:, None]
    t1 = np.where(short, np.stack([n00, n10, n11], 1), np.stack([n00, n10, n01], 1))
    t2 = np.where(short, np.stack([n00, n11, n01], 1), np.stack([n10, n11, n01], 1))
    return TriMesh(pts, np.concatenate([t1, t2]).astype(np.int32))

"""Bedding lines: the traces of parallel bedding planes through a region (pure NumPy).

:func:`bedding_lines` returns the bedding planes at a dip ``angle`` and a ``spacing`` as
:class:`~taichi_fdem.mesh.Segments` clipped to a region (a box, a polygon or the outline of a
:class:`~taichi_fdem.mesh.TriMesh`), ready to be embedded in a mesh
(``fdem.mesh.polygon(outline, h, lines=[bedding_lines(outline, angle, spacing)])``) so that the
mesh edges follow them (docs/guide/anisotropy.md, "Weak bedding planes").
"""
from __future__ import annotations

import math

import numpy as np

from .lines import Segments
from .trimesh import TriMesh

__all__ = ["bedding_lines"]


def _region_edges(region, where: str) -> np.ndarray:
    """The boundary of ``region`` as (k, 2, 2) segments: a TriMesh (its boundary edges, every
    loop, holes included), a box (xmin, ymin, xmax, ymax) or polygon vertices (n, 2)."""
    if isinstance(region, TriMesh):
        b = region.boundary_edges()
        return np.asarray(region.points, np.float64)[b]
    a = np.asarray(region, dtype=np.float64)
    if a.shape == (4,):
        x0, y0, x1, y1 = a
        if not (np.isfinite(a).all() and x1 > x0 and y1 > y0):
            raise ValueError(f"{where}: a box must be finite (xmin, ymin, xmax, ymax) with xmax > xmin and "
                             f"ymax > ymin, got {tuple(a.tolist())}")
        a = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    if a.ndim != 2 or a.shape[1] != 2 or len(a) < 3 or not np.isfinite(a).all():
        raise ValueError(f"{where}: region must be a TriMesh, a box (xmin, ymin, xmax, ymax) or polygon "
                         f"vertices of shape (n >= 3, 2), got shape {a.shape}")
    if np.array_equal(a[0], a[-1]):
        a = a[:-1]
    return np.stack([a, np.roll(a, -1, axis=0)], axis=1)


def _clip(edges: np.ndarray, origin: np.ndarray, t: np.ndarray, n: np.ndarray, offset: float, tol: float) -> list:
    """The pieces [(p, q), ...] of the line {x : n·(x − origin) = offset} inside the region bounded
    by ``edges`` (even-odd rule; a vertex on the line counts on the side n·x <= offset, so a
    line through a vertex or along a boundary edge is handled consistently)."""
    d = (edges - origin) @ n - offset                        # (k, 2) signed distances of the ends
    above = d > 0.0
    cross = above[:, 0] != above[:, 1]
    if not cross.any():
        return []
    e, de = edges[cross], d[cross]
    s = de[:, 0] / (de[:, 0] - de[:, 1])                     # where each crossing edge meets the line
    pts = e[:, 0] + s[:, None] * (e[:, 1] - e[:, 0])
    along = np.sort((pts - origin) @ t)
    base = origin + offset * n
    out = []
    for a, b in zip(along[0::2], along[1::2]):
        mid = base + 0.5 * (a + b) * t
        if b - a > tol and _distance(mid, edges) > tol:      # not a piece along a boundary edge
            out.append((base + a * t, base + b * t))
    return out


def _distance(p: np.ndarray, edges: np.ndarray) -> float:
    """Distance from the point ``p`` to the nearest of the segments ``edges`` (k, 2, 2)."""
    a, d = edges[:, 0], edges[:, 1] - edges[:, 0]
    s = np.clip(((p - a) * d).sum(1) / np.maximum((d * d).sum(1), 1e-300), 0.0, 1.0)
    return float(np.hypot(*(a + s[:, None] * d - p).T).min())


def bedding_lines(region, angle: float, spacing: float, origin=(0.0, 0.0), name: str = "bedding"):
    """The bedding planes through ``region`` as :class:`~taichi_fdem.mesh.Segments` [m], or None
    when no plane crosses it.

    ``region``: a box ``(xmin, ymin, xmax, ymax)``, the vertices of a polygon (n, 2) or a
    :class:`~taichi_fdem.mesh.TriMesh` (clipped to its outline, holes included).  ``angle``: the
    dip of the planes from the x axis [degrees, counter-clockwise]; ``spacing``: the distance
    between neighbouring planes [m] (measured normal to them); ``origin``: a point one plane
    passes through [m].  Each plane inside the region is one segment per piece (a plane that
    leaves and re-enters a non-convex region gives several); planes that only touch the
    boundary, or run along a boundary edge, are left out.  Embed them in a mesh with
    ``fdem.mesh.polygon(vertices, h, lines=[bedding_lines(vertices, angle, spacing)])``.
    """
    where = "mesh.bedding_lines"
    for key, v in (("angle", angle), ("spacing", spacing)):
        if not (isinstance(v, (int, float)) and math.isfinite(v)):
            raise ValueError(f"{where}: {key} must be a finite number, got {v!r}")
    if spacing <= 0:
        raise ValueError(f"{where}: spacing must be > 0 m, got {spacing!r}")
    o = np.asarray(origin, dtype=np.float64)
    if o.shape != (2,) or not np.isfinite(o).all():
        raise ValueError(f"{where}: origin must be a finite point (x, y), got {origin!r}")
    edges = _region_edges(region, where)
    a = math.radians(angle)
    t = np.array([math.cos(a), math.sin(a)])                 # along the planes
    n = np.array([-t[1], t[0]])                              # their normal
    d = (edges.reshape(-1, 2) - o) @ n
    size = float(np.ptp(edges.reshape(-1, 2), axis=0).max())
    tol = 1e-9 * size
    k0, k1 = math.ceil(d.min() / spacing), math.floor(d.max() / spacing)
    if k1 - k0 > 1e6:
        raise ValueError(f"{where}: spacing {spacing!r} m gives more than a million planes through a region of "
                         f"size {size:.3g} m")
    pieces = []
    for k in range(k0, k1 + 1):
        pieces.extend(_clip(edges, o, t, n, k * spacing, tol))
    if not pieces:
        return None
    return Segments(np.array([[p, q] for p, q in pieces]), name=name)

"""Straight-segment sets and polylines: fracture lines, joints, faults (pure NumPy).

* :class:`Segments` -- an immutable set of ``k`` straight segments, array ``(k, 2, 2)`` [m];
* :class:`Polyline` -- a :class:`Segments` made of consecutive points, open or closed.

Both serve two purposes:

* as *embedded lines* of :func:`~taichi_fdem.mesh.polygon` (``lines=[...]``): the mesh
  edges follow them, so that a crack, joint or fault can later open along mesh edges;
* as *edge selectors*: :meth:`Segments.select_edges` marks the mesh edges that lie along
  the segments (for example to make only those edges breakable joints, or to split the
  mesh along them as a pre-existing crack).

:func:`~taichi_fdem.mesh.load_groups` (``lines=True``) returns the physical line groups of a
gmsh file as :class:`Segments`.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["Segments", "Polyline", "SELECT_TOL"]

#: Default relative tolerance of :meth:`Segments.select_edges`: ``tol = SELECT_TOL *`` the
#: diagonal of the bounding box of the mesh points.
SELECT_TOL = 1e-6

# edges x segments evaluated at once by select_edges (about 8 float64 arrays of this size)
_CHUNK = 1 << 20


def _as_float_array(value, what: str, where: str) -> np.ndarray:
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: {what} must be numeric, got {type(value).__name__}") from None
    return a


class Segments:
    """An immutable set of straight segments [m].

    Parameters
    ----------
    segments : array_like, shape (k, 2, 2)
        ``segments[i] = [[x0, y0], [x1, y1]]``, the two end points of segment ``i`` [m];
        a single segment of shape (2, 2) is accepted.  Stored as a read-only float64 copy.
    name : str or None
        An optional label (e.g. the physical group of a mesh file), shown by ``repr``.

    Raises
    ------
    ValueError
        Wrong shape, no segment, a non-finite coordinate, or a segment of zero length
        (the message names the segment).
    """

    __slots__ = ("_segments", "_name")

    def __init__(self, segments, name: str | None = None):
        where = type(self).__name__
        s = _as_float_array(segments, "segments", where)
        if s.shape == (2, 2):
            s = s[None]
        if s.ndim != 3 or s.shape[1:] != (2, 2):
            raise ValueError(f"{where}: segments must have shape (k, 2, 2), got {s.shape}")
        if len(s) == 0:
            raise ValueError(f"{where}: no segments given")
        bad = np.flatnonzero(~np.isfinite(s).reshape(len(s), 4).all(axis=1))
        if bad.size:
            i = int(bad[0])
            raise ValueError(f"{where}: segment {i} has a non-finite coordinate {s[i].tolist()}")
        d = s[:, 1] - s[:, 0]
        length = np.sqrt((d * d).sum(1))
        scale = max(float(np.abs(s).max()), 1e-300)
        zero = np.flatnonzero(length <= 1e-14 * scale)
        if zero.size:
            i = int(zero[0])
            raise ValueError(f"{where}: segment {i} has zero length (both ends at {tuple(s[i, 0].tolist())})")
        if name is not None and not isinstance(name, str):
            raise ValueError(f"{where}: name must be a str or None, got {name!r}")
        s.flags.writeable = False
        self._segments = s
        self._name = name

    # ------------------------------------------------------------------ properties
    @property
    def segments(self) -> np.ndarray:
        """The segments, shape (k, 2, 2) [m] (read-only)."""
        return self._segments

    @property
    def name(self) -> str | None:
        """The label given at construction (or None)."""
        return self._name

    @property
    def lengths(self) -> np.ndarray:
        """Length of each segment, shape (k,) [m]."""
        d = self._segments[:, 1] - self._segments[:, 0]
        return np.sqrt((d * d).sum(1))

    @property
    def length(self) -> float:
        """Total length of the segments [m]."""
        return float(self.lengths.sum())

    def __len__(self) -> int:
        return int(self._segments.shape[0])

    def __reduce__(self):
        # pickles (checkpoints) rebuild through the constructor: validated, read-only again
        return (Segments, (np.array(self._segments), self._name))

    def __repr__(self) -> str:
        label = f", name={self._name!r}" if self._name is not None else ""
        return f"{type(self).__name__}({len(self)} segments, length={self.length:.6g} m{label})"

    # ------------------------------------------------------------------ selection
    def select_edges(self, points, edges, tol: float | None = None) -> np.ndarray:
        """Which mesh edges lie along one of the segments.

        Parameters
        ----------
        points : array_like, shape (n, 2)
            Mesh node coordinates [m] (e.g. ``mesh.points``).
        edges : array_like of int, shape (e, 2)
            Node pairs into ``points`` (e.g. ``mesh.edges()``, ``mesh.boundary_edges()`` or
            ``mesh.interior_edges()[0]``).
        tol : float [m] or None
            Distance tolerance.  Default: ``SELECT_TOL = 1e-6`` times the diagonal of the
            bounding box of ``points``.

        Returns
        -------
        bool array of shape (e,): True for an edge whose two end nodes both lie within
        ``tol`` of the line through one and the same segment and within that segment's
        extent (its end points, extended by ``tol``), i.e. the edge is collinear with the
        segment and inside it.  An edge that merely crosses a segment or touches it at
        one node is not selected.
        """
        where = f"{type(self).__name__}.select_edges"
        p = _as_float_array(points, "points", where)
        if p.ndim != 2 or p.shape[1] != 2 or len(p) == 0:
            raise ValueError(f"{where}: points must have shape (n, 2) with n >= 1, got {p.shape}")
        e = np.asarray(edges)
        if e.size == 0:
            return np.zeros(0, dtype=bool)
        if e.ndim != 2 or e.shape[1] != 2 or e.dtype.kind not in "iu":
            raise ValueError(f"{where}: edges must be an integer array of shape (e, 2), got "
                             f"{e.shape} {e.dtype}")
        if e.min() < 0 or e.max() >= len(p):
            raise ValueError(f"{where}: edges hold node indices out of range for {len(p)} points")
        if tol is None:
            diag = float(np.hypot(*np.ptp(p, axis=0)))
            tol = SELECT_TOL * (diag if diag > 0 else 1.0)
        else:
            tol = float(tol)
            if not (math.isfinite(tol) and tol >= 0.0):
                raise ValueError(f"{where}: tol must be finite and >= 0, got {tol!r}")
        a = self._segments[:, 0]
        d = self._segments[:, 1] - a
        length = np.sqrt((d * d).sum(1))
        u = d / length[:, None]                               # unit directions (k, 2)
        pa, pb = p[e[:, 0]], p[e[:, 1]]
        out = np.zeros(len(e), dtype=bool)
        k = len(self)
        rows = max(1, _CHUNK // k)
        for start in range(0, len(e), rows):
            sl = slice(start, start + rows)
            hit = np.ones((len(pa[sl]), k), dtype=bool)
            for q in (pa[sl], pb[sl]):
                r = q[:, None, :] - a[None]                   # (c, k, 2)
                along = r[..., 0] * u[None, :, 0] + r[..., 1] * u[None, :, 1]
                across = r[..., 0] * u[None, :, 1] - r[..., 1] * u[None, :, 0]
                hit &= (np.abs(across) <= tol) & (along >= -tol) & (along <= length[None] + tol)
            out[sl] = hit.any(axis=1)
        return out


class Polyline(Segments):
    """A chain of straight segments through ``points`` [m], open or closed.

    Parameters
    ----------
    points : array_like, shape (n, 2), n >= 2
        The vertices in order [m].  Consecutive repeated points are an error.
    closed : bool
        When True the last point is joined back to the first (``n >= 3``; a repeated
        closing point ``points[-1] == points[0]`` is dropped).
    name : str or None
        An optional label.

    Attributes
    ----------
    points : (n, 2) read-only float64 array of the vertices.
    closed : bool.
    """

    __slots__ = ("_points", "_closed")

    def __init__(self, points, closed: bool = False, name: str | None = None):
        where = "Polyline"
        p = _as_float_array(points, "points", where)
        if p.ndim != 2 or p.shape[1] != 2:
            raise ValueError(f"{where}: points must have shape (n, 2), got {p.shape}")
        bad = np.flatnonzero(~np.isfinite(p).all(axis=1))
        if bad.size:
            i = int(bad[0])
            raise ValueError(f"{where}: point {i} is not finite: {tuple(p[i].tolist())}")
        closed = bool(closed)
        if closed and len(p) > 3 and np.array_equal(p[0], p[-1]):
            p = p[:-1]
        need = 3 if closed else 2
        if len(p) < need:
            raise ValueError(f"{where}: a{' closed' if closed else 'n open'} polyline needs at least {need} "
                             f"points, got {len(p)}")
        scale = max(float(np.abs(p).max()), 1e-300)
        nxt = np.roll(p, -1, axis=0) if closed else p[1:]
        step = nxt - p[:len(nxt)]
        same = np.flatnonzero(np.sqrt((step * step).sum(1)) <= 1e-14 * scale)
        if same.size:
            i = int(same[0])
            raise ValueError(f"{where}: points {i} and {(i + 1) % len(p)} coincide at {tuple(p[i].tolist())} "
                             f"(repeated consecutive point)")
        super().__init__(np.stack([p[:len(nxt)], nxt], axis=1), name=name)
        p.flags.writeable = False
        self._points = p
        self._closed = closed

    def __reduce__(self):
        return (Polyline, (np.array(self._points), self._closed, self._name))

    @property
    def points(self) -> np.ndarray:
        """The vertices, shape (n, 2) [m] (read-only)."""
        return self._points

    @property
    def closed(self) -> bool:
        """True when the last point is joined to the first."""
        return self._closed

    def __repr__(self) -> str:
        label = f", name={self._name!r}" if self._name is not None else ""
        kind = ", closed" if self._closed else ""
        return f"Polyline({len(self._points)} points{kind}, length={self.length:.6g} m{label})"


def as_segments(line, where: str, index: int) -> Segments:
    """``line`` as :class:`Segments`: a Segments/Polyline is returned as is, an (n, 2) array
    of points becomes an open :class:`Polyline`.  ValueError naming ``index`` otherwise."""
    if isinstance(line, Segments):
        return line
    try:
        return Polyline(line)
    except ValueError as exc:
        raise ValueError(f"{where}: line {index}: {exc}") from None

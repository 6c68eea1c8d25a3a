"""The :class:`TriMesh` data class, its geometry functions, :func:`merge`, and the small argument
checks shared by the mesh constructors (pure NumPy).

A :class:`TriMesh` is an immutable pair of arrays

* ``points``    -- ``(n, 2)`` float64 node coordinates [m],
* ``triangles`` -- ``(m, 3)`` int32 node indices, every triangle counter-clockwise,

checked when it is created: finite coordinates, indices in range, no repeated node in a
triangle, no zero-area triangle, no two triangles overlapping across an edge.  Clockwise
triangles are silently reoriented.  Both arrays are read-only.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable

import numpy as np

__all__ = ["TriMesh", "merge", "DEGENERACY_TOL", "MAX_GENERATED_TRIANGLES", "MAX_LENGTH", "MIN_LENGTH", "MAX_COORDINATE"]

#: A triangle is degenerate when ``|2A|`` <= DEGENERACY_TOL * (longest edge)^2.
DEGENERACY_TOL = 1e-12
#: Generators refuse to build more triangles than this (a typo in ``h`` would hang).
MAX_GENERATED_TRIANGLES = 2_000_000
#: Lengths given to the generators (sizes, radii, h) must lie within these bounds [m]: beyond
#: them ``size / h`` or ``size**2`` overflow a float64, and no scene of this solver is larger
#: than a thousand kilometres or finer than a nanometre.
MAX_LENGTH = 1.0e6
MIN_LENGTH = 1.0e-9
#: Coordinates [m] (of every mesh, and the centres and origins given to generators) must be
#: within this distance of the origin on each axis (map coordinates such as UTM fit).
MAX_COORDINATE = 1.0e9


# --------------------------------------------------------------------------- geometry
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
    if not MIN_LENGTH <= v <= MAX_LENGTH:
        raise ValueError(f"{where}: {name}={v:g} m is outside [{MIN_LENGTH:g}, {MAX_LENGTH:g}] m "
                         f"(lengths are in metres)")
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
    if np.abs(v).max() > MAX_COORDINATE:
        raise ValueError(f"{where}: {name}={tuple(v.tolist())} lies beyond {MAX_COORDINATE:g} m from the origin "
                         f"(coordinates are in metres)")
    return v


def _guard_size(estimate: float, where: str, h: float) -> None:
    if not estimate <= MAX_GENERATED_TRIANGLES:     # also refuses inf and nan
        raise ValueError(f"{where}: h={h:g} would create about {estimate:.3g} triangles "
                         f"(limit {MAX_GENERATED_TRIANGLES}); use a larger h")


def _readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def _more(count: int) -> str:
    return f" (and {count - 1} more)" if count > 1 else ""


def _integer_indices(tri_in: np.ndarray) -> np.ndarray:
    """The node indices ``tri_in`` (m, 3) as int64: integer input as is, floats only when every
    value is a finite integer; ValueError naming the first offending triangle otherwise."""
    if tri_in.dtype.kind in "iu":
        return tri_in.astype(np.int64, copy=False)
    if tri_in.dtype.kind == "f":
        tri64 = np.full(tri_in.shape, -1, dtype=np.int64)
        ok = np.isfinite(tri_in) & (tri_in == np.round(tri_in))
        if not ok.all():
            t = int(np.flatnonzero(~ok.all(axis=1))[0])
            raise ValueError(f"TriMesh: triangle {t} has non-integer node indices "
                             f"{tuple(tri_in[t].tolist())}")
        tri64[...] = tri_in
        return tri64
    raise ValueError(f"TriMesh: triangles must be integer node indices, got dtype {tri_in.dtype}")


def _check_no_overlap(tri: np.ndarray, n: int) -> None:
    """ValueError when two of the counter-clockwise triangles ``tri`` (m, 3) over ``n`` points
    traverse the same directed edge (they overlap: an edge shared by more than two triangles,
    or a folded mesh)."""
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
        far = np.flatnonzero(np.abs(pts).max(axis=1) > MAX_COORDINATE)
        if far.size:
            i = int(far[0])
            raise ValueError(f"TriMesh: point {i} = {tuple(pts[i].tolist())} lies beyond {MAX_COORDINATE:g} m "
                             f"from the origin{_more(far.size)} (coordinates are in metres)")

        tri64 = _integer_indices(tri_in)
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

        _check_no_overlap(tri, n)
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

    def interior_edges(self) -> tuple[np.ndarray, np.ndarray]:
        """Edges shared by two triangles, and those two triangles.

        Returns
        -------
        edges : (k, 2) int32 node pairs, each row ``i < j``, rows sorted (the order of
            :meth:`edges` restricted to interior edges).
        tris : (k, 2) int32 triangle indices: ``tris[:, 0]`` is the triangle on the left of
            ``i -> j`` (the one traversing it as ``i -> j``), ``tris[:, 1]`` the one on its right.
        """
        d = self._directed_edges()
        n = self.point_count
        owner = np.repeat(np.arange(self.triangle_count, dtype=np.int64), 3)
        lo, hi = np.minimum(d[:, 0], d[:, 1]), np.maximum(d[:, 0], d[:, 1])
        keys = lo * n + hi
        order = np.argsort(keys, kind="stable")
        ks = keys[order]
        first = np.flatnonzero(ks[1:] == ks[:-1])       # a key occurs at most twice (validated)
        e0, e1 = order[first], order[first + 1]
        forward = d[e0, 0] < d[e0, 1]                      # e0 traverses lo -> hi: it is the left one
        left = np.where(forward, owner[e0], owner[e1])
        right = np.where(forward, owner[e1], owner[e0])
        edges = np.stack([lo[e0], hi[e0]], axis=1).astype(np.int32)
        return edges, np.stack([left, right], axis=1).astype(np.int32)

    def edge_midpoints(self, edges=None) -> np.ndarray:
        """Midpoints of ``edges`` (node pairs, (k, 2); default :meth:`edges`), shape (k, 2) [m]."""
        e = self.edges() if edges is None else np.asarray(edges)
        if e.ndim != 2 or e.shape[1] != 2 or (e.size and (e.min() < 0 or e.max() >= self.point_count)):
            raise ValueError(f"TriMesh.edge_midpoints: edges must be (k, 2) node indices in 0..{self.point_count - 1}")
        return 0.5 * (self.points[e[:, 0]] + self.points[e[:, 1]])

    def edge_lengths(self, edges=None) -> np.ndarray:
        """Lengths of ``edges`` (node pairs, (k, 2); default :meth:`edges`), shape (k,) [m]."""
        e = self.edges() if edges is None else np.asarray(edges)
        if e.ndim != 2 or e.shape[1] != 2 or (e.size and (e.min() < 0 or e.max() >= self.point_count)):
            raise ValueError(f"TriMesh.edge_lengths: edges must be (k, 2) node indices in 0..{self.point_count - 1}")
        v = self.points[e[:, 1]] - self.points[e[:, 0]]
        return np.sqrt((v * v).sum(1))

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



# --------------------------------------------------------------------------- merge
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

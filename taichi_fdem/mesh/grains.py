"""Grain-based specimens: Voronoi grains meshed with triangles (NumPy; SciPy, a dependency of
the package, for the Voronoi diagram).

:func:`voronoi_grains` draws ``round(area / grain_size**2)`` seeds uniformly in the specimen
(a seeded :class:`numpy.random.Generator`), moves them by a few Lloyd iterations towards the
centroids of their cells (estimated on a dense sample, so grains are of similar size and
Voronoi edges much shorter than ``h`` are rare), takes the Voronoi diagram
(:class:`scipy.spatial.Voronoi`), clips its edges to the specimen, merges edge end points
closer than ``h / 2`` (a short Voronoi edge would force slender triangles) and meshes the
specimen with the grain boundaries as embedded lines (:func:`~taichi_fdem.mesh.polygon`).
Each triangle's grain is the connected component of triangles reached without crossing a
grain boundary, so the labels are constant on every grain polygon by construction.
"""
from __future__ import annotations

import math

import numpy as np

from .generators import polygon
from .lines import Segments
from .trimesh import TriMesh, _positive

__all__ = ["voronoi_grains", "GrainLabels"]


class GrainLabels(np.ndarray):
    """(m,) int32 grain index of every triangle (0 to ``grain_count - 1``), a NumPy array
    with the grains' data attached:

    * ``grain_mineral`` -- (G,) mineral name of every grain (``None`` without minerals);
    * ``grain_area`` -- (G,) area of every grain [m²];
    * ``seeds`` -- (G', 2) the Voronoi seeds [m] (G' ≥ G: a seed whose cell collapsed in the
      merging of short edges joins a neighbour);
    * ``boundaries`` -- the grain boundaries as :class:`~taichi_fdem.mesh.Segments` [m].
    """

    def __array_finalize__(self, obj):
        for k in ("grain_mineral", "grain_area", "seeds", "boundaries"):
            setattr(self, k, getattr(obj, k, None))

    @property
    def grain_count(self) -> int:
        """Number of grains G."""
        return int(len(self.grain_area))

    @property
    def mineral(self) -> np.ndarray:
        """(m,) mineral name of every triangle (object array); ValueError without minerals."""
        if self.grain_mineral is None:
            raise ValueError("GrainLabels.mineral: the grains were made without minerals=")
        return np.asarray(self.grain_mineral, dtype=object)[np.asarray(self)]

    def materials(self, by_mineral: dict) -> dict:
        """The ``material`` dict of :meth:`Scene.add_body` for ``groups=labels``: grain index ->
        the Material of its mineral (``by_mineral`` maps every mineral name to a Material).
        Each grain is its own group, so ``fracture="interfaces"`` selects every grain boundary."""
        if self.grain_mineral is None:
            raise ValueError("GrainLabels.materials: the grains were made without minerals=; "
                             "give add_body a dict {grain index: Material} directly")
        missing = sorted(set(self.grain_mineral) - set(by_mineral))
        if missing:
            raise ValueError(f"GrainLabels.materials: no Material for mineral(s) {missing}")
        return {g: by_mineral[name] for g, name in enumerate(self.grain_mineral)}


def _import_scipy():
    try:
        import scipy.spatial  # noqa: F401
        import scipy.sparse.csgraph  # noqa: F401
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError("voronoi_grains needs SciPy, a dependency of taichi-fdem that is missing "
                          "from this environment: pip install scipy") from exc
    import scipy
    return scipy


def _outline(shape: str, width: float, height: float, h: float) -> np.ndarray:
    """The specimen's counter-clockwise outline, centred on the origin [m]."""
    if shape == "rectangle":
        w, t = 0.5 * width, 0.5 * height
        return np.array([[-w, -t], [w, -t], [w, t], [-w, t]])
    r = 0.5 * width
    n = max(12, math.ceil(2.0 * math.pi * r / h))
    a = 2.0 * math.pi * np.arange(n) / n
    return r * np.stack([np.cos(a), np.sin(a)], axis=1)


def _inside(p: np.ndarray, v: np.ndarray, tol: float = 0.0) -> np.ndarray:
    """Points p (n, 2) inside the convex CCW polygon v (k, 2), at least ``tol`` from its edges."""
    e = np.roll(v, -1, axis=0) - v
    c = e[None, :, 0] * (p[:, None, 1] - v[None, :, 1]) - e[None, :, 1] * (p[:, None, 0] - v[None, :, 0])
    return (c / np.hypot(e[:, 0], e[:, 1])[None] >= tol).all(axis=1)


def _sample(rng, v: np.ndarray, count: int) -> np.ndarray:
    """``count`` points uniform in the convex polygon v (rejection from its bounding box)."""
    lo, hi = v.min(axis=0), v.max(axis=0)
    out, have = [], 0
    while have < count:
        p = lo + (hi - lo) * rng.random((2 * count + 16, 2))
        p = p[_inside(p, v)]
        out.append(p)
        have += len(p)
    return np.concatenate(out)[:count]


def _clip(seg: np.ndarray, v: np.ndarray):
    """Segments (s, 2, 2) clipped to the convex CCW polygon v (Cyrus-Beck); (kept, mask)."""
    a, d = seg[:, 0], seg[:, 1] - seg[:, 0]
    t0, t1 = np.zeros(len(seg)), np.ones(len(seg))
    e = np.roll(v, -1, axis=0) - v
    nrm = np.stack([-e[:, 1], e[:, 0]], axis=1)                                 # inward normals
    for k in range(len(v)):                                                     # loop over outline edges
        num = ((a - v[k]) * nrm[k]).sum(1)                                      # >= 0 inside
        den = (d * nrm[k]).sum(1)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -num / den
        t0 = np.where(den > 0, np.maximum(t0, t), t0)
        t1 = np.where(den < 0, np.minimum(t1, t), t1)
        t1 = np.where((den == 0) & (num < 0), -1.0, t1)
    keep = t1 > t0
    out = np.stack([a + t0[:, None] * d, a + t1[:, None] * d], axis=1)
    return out[keep]


def _merge_points(pts: np.ndarray, fixed: np.ndarray, radius: float, scipy) -> np.ndarray:
    """Each point's representative after merging clusters closer than ``radius``: a cluster
    with an outline vertex or a point on the outline (``fixed``, ranked 2 and 1) keeps that
    point, others take their mean."""
    n = len(pts)
    pairs = scipy.spatial.cKDTree(pts).query_pairs(radius, output_type="ndarray")
    g = scipy.sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, comp = scipy.sparse.csgraph.connected_components(g, directed=False)
    rep = np.zeros((comp.max() + 1, 2))
    np.add.at(rep, comp, pts)
    rep /= np.bincount(comp)[:, None]
    order = np.lexsort((np.arange(n), -fixed))           # highest rank first, then input order
    best = np.full(comp.max() + 1, -1)
    first = np.unique(comp[order], return_index=True)[1]
    best[comp[order][first]] = order[first]
    has_fixed = fixed[best] > 0
    rep[has_fixed] = pts[best[has_fixed]]
    return rep[comp]


def voronoi_grains(width: float, height: float, grain_size: float, h: float, seed: int = 0,
                   minerals: dict | None = None, shape: str = "rectangle", relax: int = 3,
                   center=(0.0, 0.0)):
    """A grain-based specimen: Voronoi grains meshed with triangles.

    Parameters
    ----------
    width, height : the rectangle's size [m]; for ``shape="disc"`` ``width`` is the diameter
        and ``height`` must equal it.
    grain_size : mean grain edge length d [m]: ``round(area / d**2)`` seeds are drawn.
    h : target element edge length [m] (``h < grain_size``: a grain spans several triangles).
    seed : the seed of the random generator: the same seed gives the same mesh and labels.
    minerals : optional ``{name: proportion}`` (proportions > 0, normalised to sum 1): grains
        are drawn in a random order and each is given the mineral whose area share is most
        below its target (a reproducible area-weighted draw: the area fractions match the
        proportions to within about one grain's area).
    shape : ``"rectangle"`` or ``"disc"`` (a Brazilian disc).
    relax : Lloyd iterations of the seeds (0: plain Poisson-Voronoi grains).
    center : the specimen's centre [m].

    Returns
    -------
    (mesh, labels) : the :class:`~taichi_fdem.mesh.TriMesh` and the (m,) :class:`GrainLabels`
        (grain index per triangle, with ``grain_mineral``, ``grain_area``, ``materials()``).
        Use: ``scene.add_body(mesh, labels.materials({...}), groups=labels,
        fracture=True)`` then ``scene.add_joint_set("grain_boundaries", "interfaces", weak)``
        so that intra-grain and grain-boundary joints take their own properties.
    """
    width, height, d, h, names, props = _check_arguments(width, height, grain_size, h, minerals, shape, relax)
    scipy = _import_scipy()
    rng = np.random.default_rng(seed)
    v = _outline(shape, width, height, h)
    area = 0.5 * float(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
    count = max(2, round(area / (d * d)))
    seeds = _relaxed_seeds(rng, v, count, relax, scipy)
    merged = _grain_boundaries(seeds, v, width, height, h, scipy)
    boundaries = Segments(merged, name="grain boundaries")
    shift = np.asarray(center, float)
    mesh = polygon(v + shift, h=h, lines=[Segments(merged + shift)])
    edges = mesh.edges()
    grain = _grain_of_triangles(mesh, edges, boundaries.select_edges(mesh.points - shift, edges), scipy)
    tri_area = np.asarray(mesh.areas, np.float64)
    garea = np.bincount(grain, tri_area, minlength=int(grain.max()) + 1)
    labels = grain.view(GrainLabels)
    labels.grain_mineral = None if names is None else _draw_minerals(rng, garea, names, props)
    labels.grain_area = garea
    labels.seeds = seeds + shift
    labels.boundaries = Segments(merged + shift, name="grain boundaries")
    return mesh, labels


def _check_arguments(width, height, grain_size, h, minerals, shape, relax):
    """The checked arguments of :func:`voronoi_grains`: (width, height, grain size, h [m], the
    mineral names and their proportions normalised to sum 1, or None, None); ValueError naming
    a wrong one."""
    where = "voronoi_grains"
    width = _positive("width", width, where)
    height = _positive("height", height, where)
    d = _positive("grain_size", grain_size, where)
    h = _positive("h", h, where)
    if shape not in ("rectangle", "disc"):
        raise ValueError(f"{where}: shape must be 'rectangle' or 'disc', got {shape!r}")
    if shape == "disc" and abs(width - height) > 1e-12 * width:
        raise ValueError(f"{where}: a disc needs width == height (the diameter), got {width} and {height}")
    if h >= d:
        raise ValueError(f"{where}: h ({h}) must be smaller than grain_size ({d})")
    if not isinstance(relax, (int, np.integer)) or relax < 0:
        raise ValueError(f"{where}: relax must be an integer >= 0, got {relax!r}")
    names, props = None, None
    if minerals is not None:
        if not isinstance(minerals, dict) or not minerals:
            raise ValueError(f"{where}: minerals must be a non-empty dict {{name: proportion}}")
        names = list(minerals)
        props = np.array([float(minerals[k]) for k in names])
        if not np.all(np.isfinite(props)) or np.any(props <= 0):
            raise ValueError(f"{where}: mineral proportions must be positive numbers, got {minerals}")
        props = props / props.sum()
    return width, height, d, h, names, props


def _relaxed_seeds(rng, v: np.ndarray, count: int, relax: int, scipy) -> np.ndarray:
    """``count`` seeds (count, 2) drawn uniformly in the outline ``v``, then moved ``relax`` times
    to the centroids of their Voronoi cells (Lloyd iterations; the cells estimated on a dense
    uniform sample of 200 points per seed)."""
    seeds = _sample(rng, v, count)
    if relax:
        dense = _sample(rng, v, 200 * count)
        for _ in range(relax):
            owner = scipy.spatial.cKDTree(seeds).query(dense)[1]
            w = np.bincount(owner, minlength=count)
            sx = np.bincount(owner, dense[:, 0], minlength=count)
            sy = np.bincount(owner, dense[:, 1], minlength=count)
            moved = w > 0
            seeds[moved] = np.stack([sx[moved], sy[moved]], axis=1) / w[moved, None]
    return seeds


def _grain_boundaries(seeds: np.ndarray, v: np.ndarray, width: float, height: float, h: float, scipy) -> np.ndarray:
    """The grain boundaries (s, 2, 2) [m]: the edges of the Voronoi diagram of ``seeds`` clipped
    to the outline ``v``, with end points closer than ``h / 2`` merged (the outline's vertices and
    points on the outline stay put), without collapsed or repeated segments nor segments along
    the outline."""
    count = len(seeds)
    far = 10.0 * max(width, height)
    ghosts = far * np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
    vor = scipy.spatial.Voronoi(np.concatenate([seeds, ghosts]))
    rp, rv = np.asarray(vor.ridge_points), np.asarray(vor.ridge_vertices)
    real = (rp < count).all(axis=1) & (rv >= 0).all(axis=1)
    seg = _clip(vor.vertices[rv[real]], v)
    # merge end points closer than h/2; the outline's vertices and points on it stay put
    ends = seg.reshape(-1, 2)
    e = np.roll(v, -1, axis=0) - v
    dist = np.abs(e[None, :, 0] * (ends[:, None, 1] - v[None, :, 1]) - e[None, :, 1] * (ends[:, None, 0] - v[None, :, 0]))
    on = (dist / np.hypot(e[:, 0], e[:, 1])[None]).min(axis=1) < 1e-9 * width
    pts = np.concatenate([v, ends])
    fixed = np.concatenate([np.full(len(v), 2), on.astype(int)])
    merged = _merge_points(pts, fixed, 0.5 * h, scipy)[len(v):].reshape(-1, 2, 2)
    # drop collapsed and repeated segments, and those along the outline (its edges are mesh edges)
    keep = np.hypot(*(merged[:, 1] - merged[:, 0]).T) > 1e-9 * width
    merged = merged[keep]
    p0, p1 = merged[:, 0], merged[:, 1]
    swap = (p0[:, 0] > p1[:, 0]) | ((p0[:, 0] == p1[:, 0]) & (p0[:, 1] > p1[:, 1]))
    merged = np.where(swap[:, None, None], merged[:, ::-1], merged)
    key = np.round(merged.reshape(-1, 4) / (1e-9 * width))
    merged = merged[np.unique(key, axis=0, return_index=True)[1]]
    mid = merged.mean(axis=1)
    return merged[_inside(mid, v, 1e-9 * width)]


def _grain_of_triangles(mesh: TriMesh, edges: np.ndarray, cut: np.ndarray, scipy) -> np.ndarray:
    """The grain of each triangle of ``mesh`` (m,) int32: the connected components of triangles
    across its ``edges`` (``mesh.edges()``) that are not grain boundaries (``cut``, a mask over
    them), numbered in the order of their lowest triangle index."""
    tri = np.asarray(mesh.triangles, np.int64)
    m = len(tri)
    t = np.repeat(np.arange(m), 3)
    k = np.tile(np.arange(3), m)
    a, b = tri[t, k], tri[t, (k + 1) % 3]
    n_nodes = len(mesh.points)
    ekey = np.minimum(a, b) * n_nodes + np.maximum(a, b)
    cut_key = set((np.minimum(edges[cut, 0], edges[cut, 1]) * n_nodes + np.maximum(edges[cut, 0], edges[cut, 1])).tolist())
    cut_key = np.fromiter(cut_key, np.int64, len(cut_key))
    order = np.argsort(ekey, kind="stable")
    ks = ekey[order]
    pair = np.nonzero(ks[:-1] == ks[1:])[0]
    ia, ib = order[pair], order[pair + 1]
    link = ~np.isin(ekey[ia], cut_key)
    g = scipy.sparse.coo_matrix((np.ones(int(link.sum())), (t[ia][link], t[ib][link])), shape=(m, m))
    _, comp = scipy.sparse.csgraph.connected_components(g, directed=False)
    # number the grains by their lowest triangle index (deterministic)
    first = np.full(comp.max() + 1, m)
    np.minimum.at(first, comp, np.arange(m))
    rank = np.empty_like(first)
    rank[np.argsort(first)] = np.arange(len(first))
    return rank[comp].astype(np.int32)


def _draw_minerals(rng, garea: np.ndarray, names: list, props: np.ndarray) -> list:
    """The mineral name of each grain: the grains, in a random order, each take the mineral
    whose area share (``garea`` [m²]) is most below its proportion ``props``."""
    G = len(garea)
    gmin = [None] * G
    have = np.zeros(len(names))
    total = float(garea.sum())
    for gi in rng.permutation(G).tolist():        # loop over grains at build time
        j = int(np.argmax(props * total - have)) if have.sum() > 0 else int(rng.choice(len(names), p=props))
        gmin[gi] = names[j]
        have[j] += garea[gi]
    return gmin

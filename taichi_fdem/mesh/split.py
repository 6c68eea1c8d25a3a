"""Splitting a mesh along chosen edges: selective cohesive joints and pre-existing cracks
(docs/theory/discontinuities.md §13.1, topology-based insertion after Paulino, Celes, Espinha & Zhang 2008).

For each node, the triangles around it form a fan (closed inside the body, open on its
boundary).  The selected edges cut each fan into sectors and every sector gets its own copy of
the node.  An edge is *split* when its two triangles no longer share both nodes; a cohesive
edge that is split gets a 4-node joint (§7.1 order), a crack edge gets none (its faces meet by
contact only).  A crack or a joint line ending inside the body keeps one shared node at its
tip.  Selecting every interior edge gives back §7.1: one node copy per triangle corner,
numbered 3t + k, and the same joints in the same order as :func:`explode`.

Edge selectors (:func:`select_interior_edges`) are any of ``True`` (every interior edge),
``False`` / ``None`` (none), a callable ``where(x, y)`` evaluated at interior-edge midpoints,
an (k, 2) array of node-index pairs, an object with a ``select_edges(points, edges)`` method
(:class:`~taichi_fdem.mesh.Polyline`, line groups of a mesh file), the string
``"interfaces"`` (edges between different material groups) or a list (or dict, e.g. every line
group of a file) of these: their union.

Pure NumPy, vectorised; no Taichi.
"""
from __future__ import annotations

import numpy as np

from .trimesh import TriMesh

__all__ = ["interior_edge_table", "select_interior_edges", "split_mesh", "explode"]


def interior_edge_table(triangles: np.ndarray):
    """The interior edges of a triangle array, in a fixed order.

    Returns (u, v, tA, kA, tB, kB): edge u→v is edge kA (nodes kA → kA+1) of triangle A in
    its counter-clockwise order, and edge kB of triangle B (which runs v→u).  Sorted by
    (min(u, v), max(u, v)).
    """
    tri = np.asarray(triangles, np.int64)
    m = len(tri)
    t = np.repeat(np.arange(m), 3)
    k = np.tile(np.arange(3), m)
    u = tri[t, k]
    v = tri[t, (k + 1) % 3]
    key = np.minimum(u, v) * (int(tri.max(initial=0)) + 1) + np.maximum(u, v)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    first = np.nonzero(ks[:-1] == ks[1:])[0]        # interior edges: two consecutive entries
    ia, ib = order[first], order[first + 1]
    return u[ia], v[ia], t[ia], k[ia], t[ib], k[ib]


def _pairs_mask(selector: np.ndarray, u, v, n_points: int, where: str) -> np.ndarray:
    a = np.asarray(selector)
    if a.ndim != 2 or a.shape[1] != 2 or a.dtype.kind not in "iu":
        raise ValueError(f"{where}: an edge array must be (k, 2) integer node pairs, got shape {a.shape} "
                         f"and dtype {a.dtype}")
    if len(a) == 0:
        return np.zeros(len(u), bool)
    if a.min() < 0 or a.max() >= n_points:
        raise ValueError(f"{where}: edge node index out of range [0, {n_points}) (min {a.min()}, max {a.max()})")
    base = n_points + 1
    key = np.minimum(u, v).astype(np.int64) * base + np.maximum(u, v)
    want = np.minimum(a[:, 0], a[:, 1]).astype(np.int64) * base + np.maximum(a[:, 0], a[:, 1])
    return np.isin(key, want)


def select_interior_edges(mesh: TriMesh, selector, where: str, table=None, groups=None) -> np.ndarray:
    """Boolean mask over the interior edges of ``mesh`` (order of :func:`interior_edge_table`).

    ``groups``: the per-triangle material-group index, for the ``"interfaces"`` selector.
    Array selectors may name boundary edges (an edge group of a mesh file often does): those
    are ignored; a pair that is no edge of the mesh at all is an error.
    """
    u, v, tA, _, tB, _ = interior_edge_table(mesh.triangles) if table is None else table
    n = len(u)
    if selector is None or selector is False:
        return np.zeros(n, bool)
    if selector is True:
        return np.ones(n, bool)
    if isinstance(selector, str):
        if selector != "interfaces":
            raise ValueError(f"{where}: unknown edge selector {selector!r} (the only named one is 'interfaces')")
        if groups is None:
            return np.zeros(n, bool)
        g = np.asarray(groups)
        return g[tA] != g[tB]
    if isinstance(selector, dict):                  # e.g. all the line groups of a mesh file
        selector = list(selector.values())
    if isinstance(selector, (list, tuple)):
        try:
            arr = np.asarray(selector)
        except (TypeError, ValueError):
            arr = None
        if arr is not None and arr.ndim == 2 and arr.shape[1] == 2 and arr.dtype.kind in "iu":
            selector = arr                          # a list of node pairs
        else:                                       # a list of selectors: their union
            mask = np.zeros(n, bool)
            for s in selector:
                mask |= select_interior_edges(mesh, s, where, (u, v, tA, None, tB, None), groups)
            return mask
    pts = mesh.points
    if hasattr(selector, "select_edges"):
        mask = np.asarray(selector.select_edges(pts, np.stack([u, v], axis=1)), bool)
        if mask.shape != (n,):
            raise ValueError(f"{where}: {type(selector).__name__}.select_edges returned shape {mask.shape}, "
                             f"expected ({n},)")
        _warn_partly_followed(mesh, selector, mask, u, v, where)
        return mask
    if callable(selector):
        mid = 0.5 * (pts[u] + pts[v])
        try:
            mask = np.asarray(selector(mid[:, 0].copy(), mid[:, 1].copy()))
        except Exception as exc:
            raise ValueError(f"{where}: the edge selector where(x, y) failed on the edge midpoints: {exc}") from exc
        if mask.shape == ():
            mask = np.full(n, bool(mask))
        if mask.shape != (n,):
            raise ValueError(f"{where}: where(x, y) must return one boolean per edge midpoint, got shape "
                             f"{mask.shape} for {n} edges")
        return mask.astype(bool)
    a = np.asarray(selector)
    if a.ndim == 2 and a.shape[1] == 2 and a.dtype.kind in "iu":
        mask = _pairs_mask(a, u, v, len(pts), where)
        # a pair that is no edge of the mesh at all (boundary edges are fine) is an error
        all_edges = np.concatenate([np.stack([u, v], 1), mesh.boundary_edges().reshape(-1, 2)])
        known = _pairs_mask(all_edges, a[:, 0], a[:, 1], len(pts), where)
        if not np.all(known):
            i = int(np.flatnonzero(~known)[0])
            raise ValueError(f"{where}: node pair {tuple(a[i].tolist())} (row {i}) is not an edge of the mesh")
        return mask
    raise TypeError(f"{where}: an edge selector is True/False, a callable where(x, y), an (k, 2) integer "
                    f"array of node pairs, a Polyline / line group, 'interfaces' or a list of these; got "
                    f"{type(selector).__name__}")


def _warn_partly_followed(mesh, line, mask, u, v, where: str) -> None:
    """Warn when mesh edges follow less than 99 % of a line's length (a line the mesh was not
    built along, or one that leaves the body: only the followed part becomes joints / cracks)."""
    total = float(getattr(line, "length", 0.0) or 0.0)
    if total <= 0.0:
        return
    pts = mesh.points
    b = mesh.boundary_edges().reshape(-1, 2)
    on_b = np.asarray(line.select_edges(pts, b), bool) if len(b) else np.zeros(0, bool)
    followed = np.linalg.norm(pts[u[mask]] - pts[v[mask]], axis=1).sum() \
        + np.linalg.norm(pts[b[on_b, 0]] - pts[b[on_b, 1]], axis=1).sum()
    if followed < 0.99 * total:
        import warnings
        name = getattr(line, "name", None)
        warnings.warn(f"{where}: mesh edges follow only {followed:.4g} m of the {total:.4g} m of "
                      f"{type(line).__name__}{' ' + repr(name) if name else ''}; build the mesh along it "
                      f"(fdem.mesh.polygon(..., lines=[...])) or clip it to the body", RuntimeWarning, stacklevel=5)


def split_mesh(mesh: TriMesh, cut: np.ndarray, table=None):
    """Split ``mesh`` along the interior edges where ``cut`` is True (§13.1).

    Returns (split mesh, origin (m, 3) node indices of each triangle in ``mesh``, split (k,)
    bool: the interior edges whose two triangles no longer share both nodes, joint_nodes
    (k, 4) of every interior edge in the split numbering (j0, j1, j2, j3) = (A's u, A's v,
    B's v, B's u), joint_tris (k, 2)).  Triangle order is kept; node copies are numbered by
    their first corner 3t + k.
    """
    u, v, tA, kA, tB, kB = interior_edge_table(mesh.triangles) if table is None else table
    tri = np.asarray(mesh.triangles, np.int64)
    m = len(tri)
    cut = np.asarray(cut, bool)
    # corners c = 3t + k; glue the corners of a node across every uncut interior edge
    cA_u, cA_v = 3 * tA + kA, 3 * tA + (kA + 1) % 3
    cB_v, cB_u = 3 * tB + kB, 3 * tB + (kB + 1) % 3     # B runs v → u
    keep = ~cut
    a = np.concatenate([cA_u[keep], cA_v[keep]])
    b = np.concatenate([cB_u[keep], cB_v[keep]])
    label = np.arange(3 * m)
    if len(a):
        while True:                                # min-label propagation with pointer jumping
            lo = np.minimum(label[a], label[b])
            new = label.copy()
            np.minimum.at(new, a, lo)
            np.minimum.at(new, b, lo)
            new = new[new]
            if np.array_equal(new, label):
                break
            label = new
    # corners glued together always belong to one original node; a node whose triangles meet
    # only at that point (a "bow tie") gets one copy per fan even where nothing is cut
    roots, new_id = np.unique(label, return_inverse=True)   # roots are each class's smallest corner
    points = mesh.points[tri.ravel()[roots]]
    new_tri = new_id.reshape(m, 3)
    out = TriMesh(points, new_tri)
    j0, j1 = new_tri[tA, kA], new_tri[tA, (kA + 1) % 3]
    j2, j3 = new_tri[tB, kB], new_tri[tB, (kB + 1) % 3]
    split = (j0 != j3) | (j1 != j2)
    joint_nodes = np.stack([j0, j1, j2, j3], axis=1).astype(np.int32)
    joint_tris = np.stack([tA, tB], axis=1).astype(np.int32)
    return out, tri.astype(np.int32), split, joint_nodes, joint_tris


def explode(mesh: TriMesh):
    """Every interior edge a joint (docs/theory/joints.md §7.1): (exploded mesh, joint_nodes, joint_tris)."""
    table = interior_edge_table(mesh.triangles)
    out, _, split, jn, jt = split_mesh(mesh, np.ones(len(table[0]), bool), table)
    return out, jn[split], jt[split]

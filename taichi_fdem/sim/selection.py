"""Selections of the build: the nodes or boundary edges that a scene's predicate ``where(x, y)``
picks on the initial coordinates, for the loads (:mod:`taichi_fdem.sim.model`) and the thermal
boundary conditions (:mod:`taichi_fdem.sim.heat`).
"""
from __future__ import annotations

import numpy as np

__all__ = ["select"]


def select(where, body, bodies, X, what: str, edges=None) -> list:
    """The nodes, or with ``edges`` the boundary edges, that ``where(x, y)`` selects on the
    initial coordinates ``X`` (N, 2) [m], in the bodies of ``bodies`` (``body`` alone when it
    is not None).

    Returns [(b, i, j, t)] per body b: ``i`` the selected nodes (global indices; j, t None) or,
    with ``edges`` (``edges(b)``: local triangle and local edge k, nodes k → k+1, of each
    boundary edge of b), the boundary edges i → j (global nodes) whose two nodes are selected
    and ``t`` their local triangles, in the order of ``edges(b)``.  ValueError naming ``what``
    when ``where`` does not return a boolean array (N,) or selects nothing.
    """
    sel = np.asarray(where(X[:, 0].copy(), X[:, 1].copy()), dtype=bool)
    if sel.shape != (len(X),):
        raise ValueError(f"{what}: where(x, y) must return a boolean array of shape ({len(X)},)")
    out = []
    for b in bodies:
        if body is not None and body.index != b.index:
            continue
        if edges is None:
            out.append((b, np.nonzero(sel[b.nodes])[0] + b.node_start, None, None))
            continue
        t, e = edges(b)
        tri = b.mesh.triangles
        ni = tri[t, e] + b.node_start
        nj = tri[t, (e + 1) % 3] + b.node_start
        on = sel[ni] & sel[nj]
        out.append((b, ni[on], nj[on], t[on]))
    if not any(len(i) for _, i, _, _ in out):
        raise ValueError(f"{what}: the predicate selects no {'node' if edges is None else 'boundary edge'}"
                         f"{' of ' + body.name if body is not None else ''}"
                         f"{'' if edges is None else ' (an edge needs both its nodes selected)'}"
                         " (initial coordinates)")
    return out

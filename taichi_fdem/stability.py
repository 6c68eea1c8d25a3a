"""Numerical stability: a penetration diagnostic and the stress tests of issue 5.

* :func:`couple_penetrations` / :func:`max_couple_penetration`: how deep contact couples overlap
  (used by :meth:`Simulation.run`'s ``max_penetration`` check).
* :func:`stress_run`: run a built simulation and record stable / not, the cause, energy drift,
  maximum penetration and inverted elements.
* ``scenario_*``: scenes that push the solver (time step 0.25×–4× the limit, penalty 1–1000·E,
  fast impacts, sliver triangles, a node touched by many contacts, a dense pile, a fast spin).
  :func:`run_suite` runs them all; ``benchmarks/stability.py`` prints and stores the table.

Penetration measure: for a couple of triangles A, B with overlap area A_ov and mean edge length
L̄ of the two, the depth is d = A_ov / L̄ [m] (exact for a flat face pushed d deep along a whole
edge) and the fraction is d / L̄.  A fraction of 0.5 means the overlap covers about half a
triangle: the penalty no longer keeps the bodies apart.
"""

import math
import time as _time
import warnings

import numpy as np
import taichi as ti

from .diagnostics import clip_moments


@ti.kernel
def couple_penetrations(node_x: ti.types.ndarray(), tri_nodes: ti.types.ndarray(), couple_a: ti.types.ndarray(),
                        couple_b: ti.types.ndarray(), couple_count: ti.i32, depth: ti.types.ndarray(),
                        fraction: ti.types.ndarray()):
    """depth[c] = overlap area / mean edge length [m], fraction[c] = depth / mean edge length, per couple."""
    for c in range(couple_count):
        na = tri_nodes[couple_a[c]]
        nb = tri_nodes[couple_b[c]]
        a0, a1, a2 = node_x[na[0]], node_x[na[1]], node_x[na[2]]
        b0, b1, b2 = node_x[nb[0]], node_x[nb[1]], node_x[nb[2]]
        # relative to one vertex: absolute coordinates far from the origin would cost digits
        o = a0
        area, mom = clip_moments(a0 - o, a1 - o, a2 - o, b0 - o, b1 - o, b2 - o)
        L = ((a1 - a0).norm() + (a2 - a1).norm() + (a0 - a2).norm()
             + (b1 - b0).norm() + (b2 - b1).norm() + (b0 - b2).norm()) / 6.0
        d = ti.max(area, 0.0) / L
        depth[c] = d
        fraction[c] = d / L


def max_couple_penetration(sim) -> dict:
    """The deepest contact couple of ``sim``: {"depth" [m], "fraction", "triangles": (a, b)}.

    Zeros (and triangles (-1, -1)) without contact or couples.
    """
    n = sim.couple_count if sim.contact else 0
    if n == 0:
        return {"depth": 0.0, "fraction": 0.0, "triangles": (-1, -1)}
    cache = getattr(sim, "_pen_buffers", None)
    if cache is None or cache[0].shape[0] < n:
        cap = max(n, 2 * (cache[0].shape[0] if cache else 0))
        cache = (ti.ndarray(sim._rti, shape=cap), ti.ndarray(sim._rti, shape=cap))
        sim._pen_buffers = cache
    couple_penetrations(sim.node_x, sim.tri_nodes, sim.couple_a, sim.couple_b, n, cache[0], cache[1])
    frac = cache[1].to_numpy()[:n]
    k = int(np.argmax(frac))
    depth = float(cache[0].to_numpy()[k])
    a, b = int(sim.couple_a.to_numpy()[k]), int(sim.couple_b.to_numpy()[k])
    return {"depth": depth, "fraction": float(frac[k]), "triangles": (a, b)}

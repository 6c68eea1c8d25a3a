"""Excavation: removing triangles from a running simulation (:meth:`Simulation.remove
<taichi_fdem.sim.simulation.Simulation.remove>`): their forces stop, their mass leaves their nodes,
nodes left without a triangle are held, and the energy they held is booked (docs/theory/loads.md §12.4).
"""
from __future__ import annotations

import numpy as np

from .. import backend
from ..engine.arrays import MODEL, STATE
from ..engine.groups import DACC_FORCE, SWITCH_BC
from .arrays import allocate
from .state import state_sizes

__all__ = ["remove", "apply_removal"]


def remove(sim, body=None, where=None) -> int:
    """:meth:`Simulation.remove <taichi_fdem.sim.simulation.Simulation.remove>`."""
    md, st = sim.model, sim.state
    if body is None and where is None:
        raise ValueError("remove: give body= and/or where= (a predicate on initial coordinates)")
    sel = np.ones(md.tri_count, bool)
    if body is not None:
        sel[:] = False
        sel[sim._body_obj(body).triangles] = True
    if where is not None:
        if not callable(where):
            raise TypeError("remove: where must be a callable where(x, y) -> bool array (initial coordinates)")
        c = md.node_rest[md.tri_nodes_np].mean(axis=1)
        w = np.asarray(where(c[:, 0].copy(), c[:, 1].copy()), dtype=bool)
        if w.shape != sel.shape:
            raise ValueError(f"remove: where(x, y) must return a boolean array of shape ({md.tri_count},) "
                             "for the triangle centroids")
        sel &= w
    intact = st.tri_intact.to_numpy()
    sel &= intact >= 0
    if not sel.any():
        raise ValueError("remove: the selection holds no triangle that is still present")
    before = sim.energies()["total"]
    intact[sel] = -1
    st.tri_intact.from_numpy(intact)
    apply_removal(sim)
    sim._repack()
    sim._refresh_neighbours()
    sim._excavated_energy = getattr(sim, "_excavated_energy", 0.0) + before - sim.energies()["total"]
    return int(sel.sum())


def apply_removal(sim) -> None:
    """Masses, held orphan nodes and joints after triangles were removed (tri_intact < 0)."""
    md, st = sim.model, sim.state
    active = st.tri_intact.to_numpy() >= 0
    tris = md.tri_nodes_np
    rho = np.array([m.density for m in md.materials])[md.tri_mat_np]
    mass = np.zeros(md.node_count)
    np.add.at(mass, tris[active].ravel(), np.repeat(rho[active] * md.tri_area0_np[active] / 3.0, 3))
    orphans = mass <= 0.0
    sim._orphans = orphans
    mass[orphans] = md.node_mass_full[orphans]     # held still: any positive mass will do
    md.node_mass_np = mass
    md.node_mass.from_numpy(mass.astype(backend.real_np()))
    real = backend.real_np()
    n = md.node_count
    if not md.has_bc:                         # the scene had no prescribed velocities: full-size arrays
        md.has_bc = md.sizes["bc"] = True
        allocate(md, MODEL, md.sizes, {"node_free": np.ones((n, 2), real)}, names=("node_free",))
        allocate(st, STATE, state_sizes(md, st), names=("node_vbc", "node_react"))
        st.counters.switches = st.counters.switches | SWITCH_BC
    free = md.node_free.to_numpy()
    free[orphans] = 0.0
    md.node_free.from_numpy(free)
    for name in ("node_vbc", "node_v"):
        a = getattr(st, name).to_numpy()
        a[orphans] = 0.0
        getattr(st, name).from_numpy(a)
    if md.fracture:                           # joints of removed triangles stop (and book nothing)
        jt = md.joint_tris_np
        dead = ~(active[jt[:, 0]] & active[jt[:, 1]])
        g = st.joint_g.to_numpy()
        g[: len(jt)][dead] = 0.0
        st.joint_g.from_numpy(g)
    if md.contact:
        st.counters.dacc = DACC_FORCE                     # re-detect without the removed triangles

"""Per-phase timing of a simulation's steps (``sim.solver.profile``): one launch per phase,
so that each phase's wall time can be measured (the strategies fuse them); and the nodal forces of
the current state from the same single-phase kernels (:meth:`Simulation.forces`)."""
from __future__ import annotations

import time as _time

import numpy as np

from . import guards
from ..engine import step as kernels


def profile(sim, steps: int = 100) -> dict:
    """Run ``steps`` steps with one launch per phase and time each phase [s].

    Returns {"elastic", "joints", "detection", "contact", "integration", "total", "steps"}:
    wall seconds spent in each phase (the state advances exactly as with :meth:`step`).
    """
    md = sim.model
    t = {"elastic": 0.0, "joints": 0.0, "detection": 0.0, "contact": 0.0, "integration": 0.0}
    pc = _time.perf_counter
    due = sim._detect_due()
    sim._forget_apart()
    for _ in range(int(steps)):
        if due:
            t0 = pc(); sim._detect(); t["detection"] += pc() - t0
        p = sim._packs
        t0 = pc()
        kernels.eval_elastic(p["nodes"], p["tris"], p["mats"], p["step"], sim.solver.features())
        t1 = pc(); t["elastic"] += t1 - t0
        if md.fracture:
            kernels.eval_joints(p["nodes"], p["tris"], p["mats"], p["joints"], p["step"])
            t0, t1 = t1, pc(); t["joints"] += t1 - t0
        if md.contact:
            kernels.eval_contact(p["nodes"], p["tris"], p["mats"], p["contact"], p["step"], md.friction,
                                 md.fracture)
        t2 = pc(); t["contact"] += t2 - t1
        if md.loads:
            kernels.eval_loads(p["nodes"], p["step"])
        code = kernels.integrate(p["nodes"], p["step"], md.local_damping)
        if md.fracture:
            kernels.book_joint_work(p["nodes"], p["tris"], p["mats"], p["joints"], p["step"])
        if md.loads:
            kernels.book_loads_work(p["nodes"], p["step"])
        t["integration"] += pc() - t2
        sim.step_count += 1
        due = md.contact and bool(code & 1)
        if code & 2:
            guards.raise_unstable(sim)
    if guards.is_unstable(sim):
        guards.raise_unstable(sim)
    t["total"] = sum(t.values())
    t["steps"] = int(steps)
    return t


def evaluate_forces(sim, contact_only: bool = False) -> np.ndarray:
    """:meth:`Simulation.forces`: the nodal forces [N] at the current state from the single-phase
    kernels (elastic, joints, contact), the state left untouched."""
    st, md, p = sim.state, sim.model, sim._packs
    keep = {k: v for k, v in st.ndarrays().items()
            if k.startswith(("step_", "joint_")) or k in ("couple_hist", "tri_diss", "tri_intact")}
    saved = {k: v.to_numpy() for k, v in keep.items()}
    st.node_f.fill(0)
    sim._forget_apart()
    if not contact_only:
        sim._launch("eval_elastic", kernels.eval_elastic, p["nodes"], p["tris"], p["mats"], p["step"],
                    sim.solver.features())
        if md.fracture:
            sim._launch("eval_joints", kernels.eval_joints, p["nodes"], p["tris"], p["mats"], p["joints"],
                        p["step"])
    if md.contact:
        sim._launch("eval_contact", kernels.eval_contact, p["nodes"], p["tris"], p["mats"], p["contact"],
                    p["step"], md.friction, md.fracture)
    f = st.node_f.to_numpy().astype(np.float64) * sim.thickness
    st.node_f.fill(0)
    for k, v in saved.items():
        keep[k].from_numpy(v)
    return f

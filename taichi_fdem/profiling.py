"""Per-phase timing of a simulation's steps (:meth:`Simulation.profile`): one launch per phase,
so that each phase's wall time can be measured (the strategies fuse them)."""
from __future__ import annotations

import time as _time

from . import guards
from .engine import step as kernels


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
        kernels.eval_elastic(p["nodes"], p["tris"], p["mats"], p["step"])
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

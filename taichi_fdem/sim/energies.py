"""The energy account of a simulation [J] (docs/verification.md §8; ground rule 6: spurious energy is visible).

kinetic, strain, contact (penalty potential p∫(φ_c + φ_t)dA plus friction springs), gravity
(−Σ m g·x), damping / friction / contact_damping (work dissipated so far), boundary_work (work
done on the system by prescribed velocities), joints (work done on intact joints: stored
elastically, plus any damage so far) and fracture (work done on joints that have broken:
dissipated in cracking), load_work (work done on the system by applied pressure, tractions and
forces, docs/theory/loads.md §12), local_damping (work dissipated by the quasi-static damping), absorbed
(work taken out by absorbing boundaries), excavated (energy the removed triangles took with
them: strain, kinetic and gravity energy at removal), fluid_work (work done on the solid by
the fluid pressure on the fracture faces, scenes with a fluid only), thermal_work (the change of
the strain energy as the thermal strains changed at fixed geometry, scenes with heat only,
docs/theory/heat.md §16.6), and
total = kinetic + strain + contact + gravity + joints + dissipated + excavated − boundary_work
− load_work − fluid_work − thermal_work, which is conserved up to the time-discretisation error.  The strain energy includes
the potential S⁰:E of an initial stress.

A scene with heat also has its heat account, outside ``total``: heat_flux_in, heat_held_in,
heat_supplied (their sum) and heat_stored (:func:`taichi_fdem.sim.heat.heat_account`).
"""
from __future__ import annotations

import numpy as np
import taichi as ti

from .. import backend
from ..engine.diagnostics import energy_terms
from ..engine.fluid import F_WORK
from .heat import heat_account
from ..engine.groups import WORK_ABSORB, WORK_BOUNDARY, WORK_CDAMPING, WORK_FRICTION, WORK_LOAD, WORK_LOCAL


# the terms of ``total`` and their signs (work done on the system enters with −1)
TOTAL_TERMS = (("kinetic", 1), ("strain", 1), ("contact", 1), ("gravity", 1), ("joints", 1), ("damping", 1),
               ("friction", 1), ("contact_damping", 1), ("fracture", 1), ("local_damping", 1), ("absorbed", 1),
               ("excavated", 1), ("boundary_work", -1), ("load_work", -1))
# terms of ``total`` present only when the scene has the feature (a fluid: scene.set_fluid)
OPTIONAL_TERMS = (("fluid_work", -1), ("thermal_work", -1))


def compute_energies(sim) -> dict:
    """The energy account of ``sim`` (per the scene thickness), see the module docstring."""
    md, st = sim.model, sim.state
    out = getattr(sim, "_energy_out", None)
    if out is None:
        out = sim._energy_out = ti.ndarray(backend.real_ti(), shape=8)
    p = sim._packs
    energy_terms(p["nodes"], p["tris"], p["mats"], p["contact"], p["step"], sim.solver.couple_count, out, md.friction,
                 md.fracture, sim.solver.features())
    o = out.to_numpy().astype(np.float64)
    t = sim.thickness
    w = st.step_real.to_numpy().astype(np.float64)
    e = {"kinetic": o[0] * t, "strain": o[1] * t, "contact": o[2] * t, "gravity": o[3] * t,
         "damping": (o[4] if md.damping else 0.0) * t, "friction": w[WORK_FRICTION] * t,
         "contact_damping": w[WORK_CDAMPING] * t, "boundary_work": w[WORK_BOUNDARY] * t,
         "load_work": w[WORK_LOAD] * t, "local_damping": w[WORK_LOCAL] * t, "absorbed": w[WORK_ABSORB] * t,
         "excavated": float(getattr(sim, "_excavated_energy", 0.0))}
    e["joints"] = e["fracture"] = 0.0
    if md.fracture:
        work = st.joint_work.to_numpy().astype(np.float64)
        broken = st.joint_state.to_numpy() != 0
        e["joints"] = float(work[~broken].sum()) * t
        e["fracture"] = float(work[broken].sum()) * t
    if getattr(md, "fluid", False):
        e["fluid_work"] = float(st.fluid_real[F_WORK]) * t
    if getattr(md, "heat", False):
        e.update(heat_account(sim))
    e["total"] = sum(sign * e[k] for k, sign in TOTAL_TERMS + OPTIONAL_TERMS if k in e)
    return e

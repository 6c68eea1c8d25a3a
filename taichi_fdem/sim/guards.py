"""Stability guards: the diagnosis of an unstable step, the run-time checks of energy growth and
penetration, and the last good state to roll back to (docs/theory/elements.md §6.2; issue 5).

The kernels stop on non-finite values, inverted elements and node speeds above the limit every
step (:mod:`taichi_fdem.engine.integrate`); :meth:`Simulation.run` adds the checks here on an
adaptive schedule.
"""
from __future__ import annotations

import math
import time as _time
import warnings

import numpy as np
import taichi as ti

from .. import backend
from ..engine.diagnostics import couple_penetrations, overlap_areas
from ..engine.groups import INVERTED, NONFINITE, VMAX
from .fluid import fluid_failure


class SimulationError(RuntimeError):
    """The run became unstable or invalid; carries a diagnosis.

    Attributes: ``cause`` (short text), ``step``, ``time`` [s], ``suggested_dt`` [s].
    """

    def __init__(self, cause: str, step: int, time: float, suggested_dt: float, detail: str = ""):
        self.cause, self.step, self.time, self.suggested_dt = cause, step, time, suggested_dt
        msg = (f"simulation stopped at step {step} (t = {time:.6g} s): {cause}. {detail}"
               f" Suggested time step: {suggested_dt:.3g} s or smaller (build(dt=...) or a smaller safety).")
        super().__init__(msg)


def raise_unstable(sim) -> None:
    """Raise :class:`SimulationError` naming what the kernels flagged (node, triangle or speed)."""
    ints, reals = sim.state.step_int.to_numpy(), sim.state.step_real.to_numpy()
    nonfinite, inverted, vmax = int(ints[NONFINITE]), int(ints[INVERTED]), float(reals[VMAX])
    speed = vmax > sim.model.speed_limit
    fluid = fluid_failure(sim)
    if fluid:
        cause = fluid
    elif nonfinite:
        cause = f"non-finite position or velocity at node {nonfinite - 1}"
    elif speed:
        cause = (f"a node moved at {vmax:.4g} m/s, above the bound "
                 f"{sim.model.speed_limit:.4g} m/s (speed_limit; default 2× the largest P-wave speed)")
    else:
        e = inverted - 1
        cause = (f"inverted element: triangle {e} (body {sim.bodies[sim.model.tri_body_np[e]].name}) "
                 f"has non-positive area")
    raise SimulationError(cause, sim.step_count, sim.time, suggested_dt=0.5 * min(sim.dt, sim.model.dt_limit),
                          detail=f"Time step {sim.dt:.3g} s, estimated limit {sim.model.dt_limit:.3g} s.")


def is_unstable(sim) -> bool:
    ints, reals = sim.state.step_int.to_numpy(), sim.state.step_real.to_numpy()
    return bool(ints[NONFINITE] or ints[INVERTED] or reals[VMAX] > sim.model.speed_limit)


# ---- penetration --------------------------------------------------------------------------------
def max_couple_penetration(sim) -> dict:
    """The deepest contact couple of ``sim``: {"depth" [m], "fraction", "triangles": (a, b)}.

    Zeros (and triangles (-1, -1)) without contact or couples.  Depth = overlap area / mean
    edge length of the two triangles; fraction = depth / mean edge length
    (:func:`taichi_fdem.engine.diagnostics.couple_penetrations`).
    """
    n = sim.solver.couple_count if sim.model.contact else 0
    if n == 0:
        return {"depth": 0.0, "fraction": 0.0, "triangles": (-1, -1)}
    cache = getattr(sim, "_pen_buffers", None)
    if cache is None or cache[0].shape[0] < n:
        cap = max(n, 2 * (cache[0].shape[0] if cache else 0))
        cache = (ti.ndarray(backend.real_ti(), shape=cap), ti.ndarray(backend.real_ti(), shape=cap))
        sim._pen_buffers = cache
    st = sim.state
    couple_penetrations(st.node_x, sim.model.tri_nodes, st.couple_a, st.couple_b, n, st.tri_nb_on,
                        sim.model.nb_count, cache[0], cache[1])
    frac = cache[1].to_numpy()[:n]
    k = int(np.argmax(frac))
    depth = float(cache[0].to_numpy()[k])
    a, b = int(st.couple_a.to_numpy()[k]), int(st.couple_b.to_numpy()[k])
    return {"depth": depth, "fraction": float(frac[k]), "triangles": (a, b)}


# ---- last good state ---------------------------------------------------------------------------
def snapshot(sim) -> dict:
    """A copy of the whole state (every ndarray of ``sim.state``, the couple capacity, the step,
    the time step and the clock of :attr:`Simulation.time`)."""
    st = sim.state
    return {"step_count": sim.step_count, "couple_max": st.couple_max, "dt": sim.model.dt, "clock": sim._clock,
            "arrays": {k: v.to_numpy() for k, v in st.ndarrays().items()}}


def restore(sim, snap: dict) -> None:
    """Write a :func:`snapshot` back into ``sim.state`` (the couple buffer keeps its capacity)."""
    st = sim.state
    for k, saved in snap["arrays"].items():
        cur = getattr(st, k)
        if tuple(cur.shape) != saved.shape[:len(cur.shape)]:
            if saved.shape[0] < cur.shape[0]:          # the couple buffer has grown since: pad
                pad = np.zeros((cur.shape[0],) + saved.shape[1:], saved.dtype)
                pad[:saved.shape[0]] = saved
                saved = pad
            else:
                raise RuntimeError(f"restore_last_good: array {k} shrank since the saved state")
        cur.from_numpy(saved)
    sim.step_count = snap["step_count"]
    sim._clock = snap["clock"]
    sim.model.dt = snap["dt"]
    sim.state.counters.dt = snap["dt"]
    sim._after_restore()


# ---- run-time checks -----------------------------------------------------------------------------
def energy_scale(e: dict) -> float:
    """The energy scale of an energy account [J]: kinetic + ``|strain|`` + ``|contact|`` + dissipated + ``|boundary work|``
    + ``|load work|``."""
    return (e["kinetic"] + abs(e["strain"]) + abs(e["contact"]) + e["damping"] + e["friction"]
            + e["contact_damping"] + abs(e["boundary_work"]) + abs(e.get("load_work", 0.0))
            + e.get("local_damping", 0.0) + e.get("absorbed", 0.0) + abs(e.get("excavated", 0.0))
            + abs(e.get("fluid_work", 0.0)))        # (and |fluid work| with a fluid)


class RunGuard:
    """The checks of one :meth:`Simulation.run` (see its docstring for the parameters)."""

    def __init__(self, sim, check_energy, energy_tol, max_penetration, check_every):
        energy_tol = float(energy_tol)
        if not (math.isfinite(energy_tol) and energy_tol > 0):
            raise ValueError(f"run: energy_tol must be a positive fraction, got {energy_tol}")
        if max_penetration is not None:
            max_penetration = float(max_penetration)
            if not (math.isfinite(max_penetration) and max_penetration > 0):
                raise ValueError(f"run: max_penetration must be a positive fraction of the element size or None, "
                                 f"got {max_penetration}")
        self.auto = check_every is None
        check_every = 50 if self.auto else int(check_every)
        if check_every < 1:
            raise ValueError(f"run: check_every must be >= 1 step, got {check_every}")
        self.sim = sim
        self.energy, self.tol = bool(check_energy), energy_tol
        self.pen = max_penetration if sim.model.contact else None
        self.every, self.since, self.step_wall = check_every, 0, 0.0
        if self.energy:
            e = sim.energies()
            self.e0, self.scale = e["total"], energy_scale(e)
            eps = 1e3 * float(np.finfo(backend.real_np()).eps)
            # an absolute floor as well: a rise below the strain energy of a 1e-6 strain over the
            # whole model is round-off, not instability (a body at rest has energies ~0, and the
            # relative floor alone would flag contact-energy round-off of 1e-11 J)
            md = sim.model
            e_max = max(m.young for m in md.materials)
            absolute = 0.5 * 1e-12 * e_max * float(np.abs(md.tri_area0_np).sum()) * sim.thickness
            self.floor = eps * (abs(e["total"]) + abs(e["gravity"]) + self.scale) + absolute
        sim._save_last_good()

    def steps_to_next_check(self) -> int:
        return max(1, self.every - self.since)

    def check(self, steps: int, last: bool = False) -> None:
        """Count ``steps`` more steps; run the checks when they are due (or at the ``last`` step)."""
        self.since += steps
        if self.since < self.every and not last:
            return
        self.since = 0
        sim = self.sim
        t_check = _time.perf_counter()
        limit_note = f"Time step {sim.dt:.3g} s, estimated limit {sim.model.dt_limit:.3g} s."
        suggested = 0.5 * min(sim.dt, sim.model.dt_limit)
        if self.energy:
            e = sim.energies()
            total = e["total"]
            if not math.isfinite(total):
                raise SimulationError("the total energy is not finite", sim.step_count, sim.time, suggested,
                                      detail=limit_note)
            self.scale = max(self.scale, energy_scale(e))
            rise = total - self.e0
            bound = self.tol * self.scale + self.floor
            if rise > bound:
                raise SimulationError(
                    f"energy growth: the total energy rose by {rise:.4g} J since the start of the run, above the "
                    f"bound {bound:.4g} J (energy_tol = {self.tol:g} × the energy scale {self.scale:.4g} J)",
                    sim.step_count, sim.time, suggested, detail=limit_note)
        if self.pen is not None and sim.solver.couple_count:
            worst = max_couple_penetration(sim)
            if worst["fraction"] > self.pen:
                ba, bb = (sim.bodies[sim.model.tri_body_np[t]].name for t in worst["triangles"])
                raise SimulationError(
                    f"penetration: triangles {worst['triangles'][0]} ({ba}) and {worst['triangles'][1]} ({bb}) "
                    f"overlap {worst['depth']:.4g} m deep, {worst['fraction']:.3g} × their element size, above "
                    f"max_penetration = {self.pen:g}", sim.step_count, sim.time, suggested,
                    detail=limit_note + " Raise the contact penalty, or lower the impact speed or the time step.")
        sim._save_last_good()
        if self.auto and self.step_wall > 0:
            # keep the checks near 10 % of the stepping time, but at least every 500 steps
            cost = _time.perf_counter() - t_check
            self.every = int(min(500, max(20, cost / (0.1 * self.step_wall))))


def warn_overlaps(sim) -> None:
    """Warn when bodies overlap at the start (contact would push them apart violently)."""
    n = sim.solver.couple_count
    if n == 0:
        return
    st, md = sim.state, sim.model
    out = ti.ndarray(backend.real_ti(), shape=n)
    overlap_areas(st.node_x, md.tri_nodes, st.couple_a, st.couple_b, n, st.tri_nb_on, md.nb_count, out)
    area = out.to_numpy()
    tol = 1e-9 * float(np.abs(md.tri_area0_np).mean())
    bad = np.nonzero(area > tol)[0]
    if len(bad):
        a = st.couple_a.to_numpy()[bad]
        b = st.couple_b.to_numpy()[bad]
        pairs = sorted({tuple(sorted((int(md.tri_body_np[i]), int(md.tri_body_np[j])))) for i, j in zip(a, b)})
        names = ", ".join(f"{sim.bodies[i].name}–{sim.bodies[j].name}" for i, j in pairs[:5])
        warnings.warn(f"bodies overlap at the start ({len(bad)} triangle pairs, total overlap "
                      f"{area[bad].sum():.3g} m²): {names}. Contact will push them apart violently.",
                      RuntimeWarning, stacklevel=4)

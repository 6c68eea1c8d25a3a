"""Stable time-step estimates (docs/theory/elements.md §6.2) and the choice of the step at build.

The book's estimates set the default step; the stable limit used to refuse a time step is
tighter, by the factors of the stress tests (docs/stability.md): face-on-face contact of
coarse meshes is unstable from 0.45 × h√(ρ/p) (a corner node carries one triangle's mass and
both passes push it), so contact and joint terms count × :data:`CONTACT_LIMIT_FACTOR`; and
viscous damping is rated with the element size that sets k_s (h_eq), not the smallest
altitude.
"""
from __future__ import annotations

import math

import numpy as np

CONTACT_LIMIT_FACTOR = 0.4      # stable contact / joint step = 0.4 × the book's h√(ρ/p) (docs/stability.md)


def estimate_time_steps(*, altitude, area0, cp, beta, moving, contact_altitude, contact_penalty, rho_min,
                        xi_max, joint_h, joint_rho, joint_penalty, fluid_step=math.inf) -> dict:
    """The per-mechanism estimates and the limit [s].

    Parameters (per triangle unless said): altitude (smallest altitude [m]), area0 [m²], cp
    (P-wave speed [m/s]; of the stiffest direction for a bedded material, ``Material.p_wave_speed``,
    docs/theory/anisotropy.md), beta (damping ratio), moving (bool: not every node prescribed);
    contact_altitude (altitudes of contact triangles, may be empty), contact_penalty (largest
    penalty in use [Pa], 0 without contact), rho_min [kg/m³], xi_max (largest contact damping
    ratio); joint_h, joint_rho, joint_penalty (per joint; empty without fracture); fluid_step
    (the step 2√(m a_min/(K L)) of the fluid's stiffness in the narrowest channels, inf without
    a fluid: :func:`taichi_fdem.sim.fluid.fluid_stiffness_step`), which enters as the joints'
    term does (its limit × CONTACT_LIMIT_FACTOR).

    Returns {"elastic", "contact", "joint", "fluid", "estimate", "limit"}; without anything that moves,
    estimate = limit = 1e-3 s (any step is stable).
    """
    damp_factor = np.sqrt(1.0 + beta ** 2) - beta
    dt_el = float(np.min((altitude / cp * damp_factor)[moving])) if moving.any() else math.inf
    dt_c = math.inf
    if len(contact_altitude) and contact_penalty > 0:
        dt_c = float(np.min(contact_altitude) * math.sqrt(rho_min / contact_penalty)
                     * (math.sqrt(1 + xi_max ** 2) - xi_max))
    dt_j = float(np.min(joint_h * np.sqrt(joint_rho / joint_penalty))) if len(joint_h) else math.inf
    estimate = min(dt_el, dt_c, dt_j, fluid_step)
    xi_eff = beta * np.sqrt(4.0 * area0 / math.sqrt(3.0)) / altitude
    dt_el_lim = float(np.min((altitude / cp * (np.sqrt(1.0 + xi_eff ** 2) - xi_eff))[moving])) if moving.any() \
        else math.inf
    limit = min(dt_el_lim, CONTACT_LIMIT_FACTOR * dt_c, CONTACT_LIMIT_FACTOR * dt_j, CONTACT_LIMIT_FACTOR * fluid_step)
    if not math.isfinite(limit):
        limit = estimate = 1e-3
    return {"elastic": dt_el, "contact": dt_c, "joint": dt_j, "fluid": float(fluid_step), "estimate": float(estimate),
            "limit": float(limit)}


def choose_time_step(steps: dict, dt, safety: float, force_dt: bool) -> float:
    """The time step [s] to run with: ``dt`` if given, else ``safety`` × the estimate; refused
    (ValueError naming the limit) above the stable limit unless ``force_dt``."""
    if dt is None:
        dt = float(safety) * steps["estimate"]
        if dt > steps["limit"] and not force_dt:
            raise ValueError(
                f"Scene.build: safety = {safety} gives dt = {dt:.4g} s, above the stable limit "
                f"{steps['limit']:.4g} s; use safety <= {steps['limit'] / steps['estimate']:.3g} "
                "(or force_dt=True to run it anyway)")
        return dt
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"Scene.build: dt must be a positive finite time step [s], got {dt}")
    if dt > steps["limit"] and not force_dt:
        raise ValueError(
            f"Scene.build: dt = {dt:.4g} s is above the estimated stable limit {steps['limit']:.4g} s "
            f"(elements {steps['elastic']:.4g} s, contact {CONTACT_LIMIT_FACTOR * steps['contact']:.4g} s, "
            f"joints {CONTACT_LIMIT_FACTOR * steps['joint']:.4g} s"
            + (f", fluid {CONTACT_LIMIT_FACTOR * steps['fluid']:.4g} s" if math.isfinite(steps.get('fluid', math.inf))
               else "") + f"); use dt <= {steps['limit']:.4g} s "
            f"(the default is {safety * steps['estimate']:.4g} s), or force_dt=True to run it anyway")
    return dt

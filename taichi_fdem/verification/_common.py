"""Shared material constants and functions of the verification cases."""
from __future__ import annotations

import math
import time as _time
import warnings

import numpy as np

from .. import backend


# one material for all cases: E = 100 MPa, ρ = 2500 kg/m³, ν = 0.25 (c_p ≈ 210 m/s)
E, RHO, NU = 1.0e8, 2500.0, 0.25


def _precision(precision: str) -> None:
    if not backend.is_initialised():
        backend.init(precision=precision)
    elif backend.precision() != precision:
        raise ValueError(f"verification: Taichi runs in {backend.precision()}, the case asks for {precision}; "
                         f"call fdem.init(precision={precision!r}) first (it resets Taichi: use a fresh process)")


def _build(scene, safety, **kw):
    t0 = _time.perf_counter()
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="bodies overlap", category=RuntimeWarning)
        sim = scene.build(safety=safety, **kw)
    return sim, _time.perf_counter() - t0


def _crossing(ts, ys, level):
    """First time the sampled signal ys(ts) reaches ``level`` (linear interpolation); nan if never."""
    ys = np.asarray(ys)
    idx = np.flatnonzero(ys >= level)
    if len(idx) == 0:
        return math.nan
    i = idx[0]
    if i == 0:
        return ts[0]
    return ts[i - 1] + (level - ys[i - 1]) / (ys[i] - ys[i - 1]) * (ts[i] - ts[i - 1])


def _centroid_velocity(sim, body):
    m = sim.node_masses(body)
    return (m[:, None] * sim.node_velocities(body)).sum(0) / m.sum()


def _result(sim, wall, build, **values):
    # wall: seconds inside Simulation.step (the solver); wall_total: with the measuring
    out = {"wall": sim._stats["wall_steps"], "wall_total": wall, "build": build, "steps": sim.step_count, "dt": sim.dt, "triangles": sim.model.tri_count,
           "precision": backend.precision()}
    out.update(values)
    return out


# ------------------------------------------------------------------------------------------------
# §8.3 P-wave arrival in a long strip
# ------------------------------------------------------------------------------------------------

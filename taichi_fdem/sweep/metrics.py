"""The metrics registry of sweeps: :data:`METRICS` (name -> columns, unit, description) and
:class:`registry_metrics`, a picklable metrics function made of those names.
"""
from __future__ import annotations

import difflib
import math

from .params import SweepError

__all__ = ["METRICS", "registry_metrics"]


# ----------------------------------------------------------------------------------------------
# metrics registry
# ----------------------------------------------------------------------------------------------
def _body_of(sim, name: str):
    for b in sim.bodies:
        if b.name == name:
            return b
    raise ValueError(f"metric: no body named {name!r} (bodies: {', '.join(b.name for b in sim.bodies)})")


def _centroid(sim, body, what):
    m = sim.node_masses(body)
    x = {"displacement": sim.node_displacements, "position": sim.node_positions,
         "velocity": sim.node_velocities}[what](body)
    return (m[:, None] * x).sum(axis=0) / m.sum()


#: Metrics of :class:`Sweep` and sweep files, by name: (columns, unit, description).
METRICS = {
    "time": ("time", "s", "simulated time at the end"),
    "steps": ("steps", "", "time steps taken"),
    "dt": ("dt", "s", "time step"),
    "couple_count": ("couple_count", "", "contact couples at the end"),
    "energies": ("energy_kinetic, energy_strain, energy_contact, energy_gravity, energy_damping, energy_friction, "
                 "energy_contact_damping, energy_boundary_work, energy_total", "J", "Simulation.energies() at the end"),
    "displacement:BODY": ("BODY_dx, BODY_dy, BODY_displacement", "m",
                          "displacement of the body's centre of mass (and its length)"),
    "position:BODY": ("BODY_x, BODY_y", "m", "centre of mass of the body at the end"),
    "velocity:BODY": ("BODY_vx, BODY_vy", "m/s", "velocity of the body's centre of mass at the end"),
}


def _metric_values(name: str, sim) -> dict:
    kind, _, body = name.partition(":")
    if kind == "time":
        return {"time": sim.time}
    if kind == "steps":
        return {"steps": sim.step_count}
    if kind == "dt":
        return {"dt": sim.dt}
    if kind == "couple_count":
        return {"couple_count": sim.solver.couple_count}
    if kind == "energies":
        return {f"energy_{k}": float(v) for k, v in sim.energies().items()}
    b = _body_of(sim, body)
    c = _centroid(sim, b, kind)
    if kind == "displacement":
        return {f"{body}_dx": float(c[0]), f"{body}_dy": float(c[1]), f"{body}_displacement": float(math.hypot(*c))}
    if kind == "position":
        return {f"{body}_x": float(c[0]), f"{body}_y": float(c[1])}
    return {f"{body}_vx": float(c[0]), f"{body}_vy": float(c[1])}


class registry_metrics:
    """A picklable metrics function made of names of :data:`METRICS` (checked here)."""

    def __init__(self, names, body_names=None, where: str = "metrics"):
        if isinstance(names, str) or not isinstance(names, (list, tuple)) or not names:
            raise SweepError(f"{where}: give a non-empty list of metric names, e.g. [\"time\", \"energies\"]")
        plain = [k for k in METRICS if ":" not in k]
        kinds = [k.split(":")[0] for k in METRICS if ":" in k]
        for n in names:
            if not isinstance(n, str):
                raise SweepError(f"{where}: metric names are strings, got {n!r}")
            kind, colon, body = n.partition(":")
            if colon:
                if kind not in kinds:
                    close = difflib.get_close_matches(kind, kinds, n=1)
                    raise SweepError(f"{where}: unknown metric {n!r}" + (f" (did you mean '{close[0]}:{body}'?)" if close else "")
                                     + f"; known: {', '.join(METRICS)}")
                if not body:
                    raise SweepError(f"{where}: metric {n!r} needs a body name, e.g. '{kind}:block'")
                if body_names is not None and body not in body_names:
                    close = difflib.get_close_matches(body, list(body_names), n=1)
                    raise SweepError(f"{where}: metric {n!r}: no body named {body!r}"
                                     + (f" (did you mean {close[0]!r}?)" if close else "")
                                     + f"; bodies: {', '.join(body_names)}")
            elif n not in plain:
                close = difflib.get_close_matches(n, list(METRICS), n=1)
                raise SweepError(f"{where}: unknown metric {n!r}" + (f" (did you mean {close[0]!r}?)" if close else "")
                                 + f"; known: {', '.join(METRICS)}")
        self.names = list(names)

    def __call__(self, sim) -> dict:
        out = {}
        for n in self.names:
            out.update(_metric_values(n, sim))
        return out

    def __repr__(self):
        return f"registry_metrics({self.names!r})"

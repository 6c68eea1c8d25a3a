"""The time step, the clock and the model values of a :class:`~taichi_fdem.sim.simulation.Simulation`
(a mixin): ``sim.dt`` (a validated setter that also updates the kernels' ``step_real[DT]``),
``sim.time``, and read-only properties for the commonly read model values; assigning a name of
the model or the state on the simulation raises instead of changing nothing."""
from __future__ import annotations

import math
import warnings


__all__ = ["ModelValues", "MOVED"]

_CRACKS = {"crack_events": "events", "write_crack_events": "write_events", "ae_events": "ae_events",
           "write_ae_events": "write_ae_events", "crack_segments": "segments", "crack_length": "length",
           "crack_length_history": "length_history", "fragments": "fragments", "fragment_sizes": "fragment_sizes",
           "fragment_passing": "fragment_passing", "fragment_count": "fragment_count",
           "broken_joint_count": "broken_count", "broken_joints": "broken", "joint_damage": "joint_damage",
           "tri_damage": "tri_damage"}
_FLUID = {"fluid_pressures": "pressures", "node_fluid_pressures": "node_pressures", "fluid_volume": "volume",
          "fluid_work": "work", "injection_rates": "injection_rates", "injected_volumes": "injected_volumes",
          "injection_pressure": "injection_pressure"}
_SOLVER = ("strategy", "assembly", "force_blocks", "team_workers", "team_steps", "steps_per_launch", "profile",
           "detection_count", "launches", "scratch", "couple_count")
_MODEL = ("dt_limit", "node_count", "tri_count", "joint_count", "contact", "friction", "fracture", "damping",
          "contact_damping", "buffer")
#: name of version 0.1.0 on Simulation -> (where it lives now, its name there)
MOVED = {**{k: ("cracks", v) for k, v in _CRACKS.items()}, **{k: ("fluid", v) for k, v in _FLUID.items()},
         **{k: ("solver", k) for k in _SOLVER}, **{k: ("model", k) for k in _MODEL},
         "load_forces": ("loads", "forces"), "load_factors": ("loads", "factors")}


class ModelValues:
    """Mixin of :class:`~taichi_fdem.sim.simulation.Simulation` (which holds ``model``,
    ``state`` and ``step_count``)."""

    # the simulated time is _clock[0] + (step_count - _clock[1]) * dt: (0, 0) until dt is set
    _clock = (0.0, 0)

    @property
    def time(self) -> float:
        """Simulated time [s]: the steps run times their time steps (:attr:`dt` may change)."""
        t0, n0 = self._clock
        return t0 + (self.step_count - n0) * self.model.dt

    @property
    def dt(self) -> float:
        """The time step [s].  Settable between calls: a positive finite value, at most the
        stable limit ``sim.model.dt_limit`` (unless the scene was built with ``force_dt=True``) and,
        with absorbing boundaries, below their dashpots' limit; the kernels integrate with it
        from the next step on and :attr:`time` continues from its current value.  Loads and
        velocity curves follow the simulated time, so they are unaffected."""
        return self.model.dt

    @dt.setter
    def dt(self, value) -> None:
        try:
            dt = float(value)
        except (TypeError, ValueError):
            raise TypeError(f"sim.dt: a time step [s] must be a number, got {value!r}") from None
        md = self.model
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"sim.dt: the time step must be a positive finite time [s], got {value!r}")
        if dt > md.dt_limit and not md.force_dt:
            raise ValueError(f"sim.dt = {dt:.4g} s is above the estimated stable limit {md.dt_limit:.4g} s "
                             f"(sim.model.dt_limit); use dt <= {md.dt_limit:.4g} s, or build with "
                             "Scene.build(dt=..., force_dt=True) to run above it")
        if md.dashpot_rate * dt >= 1.0:
            raise ValueError(f"sim.dt = {dt:.4g} s: the absorbing boundary's dashpots are unstable at this time "
                             f"step (rate × dt = {md.dashpot_rate * dt:.3g} >= 1, docs/theory/loads.md §12.5); use "
                             f"dt < {1.0 / md.dashpot_rate:.4g} s")
        object.__setattr__(self, "_clock", (self.time, self.step_count))
        md.dt = dt
        self.state.counters.dt = dt               # step_real[DT], through host_write

    def __getattr__(self, name):
        # the names of version 0.1.0 that moved to sim.cracks, sim.fluid, sim.loads, sim.solver
        # and sim.model: still answered, with a DeprecationWarning
        moved = MOVED.get(name)
        if moved is None or name.startswith("__"):
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        where, new = moved
        warnings.warn(f"sim.{name} is deprecated: use sim.{where}.{new}", DeprecationWarning, stacklevel=2)
        return getattr(getattr(self, where), new)

    def __setattr__(self, name, value) -> None:
        if name in MOVED and name not in self.__dict__ and not hasattr(type(self), name):
            where, new = MOVED[name]
            if where != "solver":
                raise AttributeError(f"sim.{name} is read-only (sim.{where}.{new})")
            warnings.warn(f"sim.{name} = ... is deprecated: use sim.solver.{new} = ...", DeprecationWarning,
                          stacklevel=2)
            setattr(self.solver, new, value)
            return
        # a name of the model or the state assigned on the simulation would change nothing
        model, state = self.__dict__.get("model"), self.__dict__.get("state")
        if not hasattr(type(self), name) and name not in self.__dict__ and (
                (model is not None and name in vars(model)) or (state is not None and name in vars(state))):
            where = "model" if model is not None and name in vars(model) else "state"
            raise AttributeError(f"sim.{name}: a value of the {where} is not a setting of the simulation; "
                                 f"read it as sim.{where}.{name} (model values are fixed at Scene.build)")
        object.__setattr__(self, name, value)

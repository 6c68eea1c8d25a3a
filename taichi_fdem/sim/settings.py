"""The time step, the clock and the model values of a :class:`~taichi_fdem.sim.simulation.Simulation`
(a mixin): ``sim.dt`` (a validated setter that also updates the kernels' ``step_dt``),
``sim.time``, and read-only properties for the commonly read model values; assigning a name of
the model or the state on the simulation raises instead of changing nothing."""
from __future__ import annotations

import math

from .model import host_write

__all__ = ["ModelValues"]


def _model_value(name: str, doc: str) -> property:
    """A read-only property of :class:`Simulation` answering ``sim.model.<name>``."""
    return property(lambda self: getattr(self.model, name), doc=f"{doc}  (``sim.model.{name}``; read-only)")


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
        stable limit :attr:`dt_limit` (unless the scene was built with ``force_dt=True``) and,
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
                             f"(sim.dt_limit); use dt <= {md.dt_limit:.4g} s, or build with "
                             "Scene.build(dt=..., force_dt=True) to run above it")
        if md.dashpot_rate * dt >= 1.0:
            raise ValueError(f"sim.dt = {dt:.4g} s: the absorbing boundary's dashpots are unstable at this time "
                             f"step (rate × dt = {md.dashpot_rate * dt:.3g} >= 1, docs/theory/loads.md §12.5); use "
                             f"dt < {1.0 / md.dashpot_rate:.4g} s")
        object.__setattr__(self, "_clock", (self.time, self.step_count))
        md.dt = dt
        host_write(md.step_dt, None, dt)

    dt_limit = _model_value("dt_limit", "Estimated stable time step [s] of the scene.")
    node_count = _model_value("node_count", "Number of nodes.")
    tri_count = _model_value("tri_count", "Number of triangles.")
    joint_count = _model_value("joint_count", "Number of joints (crack elements) between triangles.")
    contact = _model_value("contact", "Whether the scene has contact (bool).")
    friction = _model_value("friction", "Whether any contact pair has friction (bool).")
    fracture = _model_value("fracture", "Whether the scene has joints that can break (bool).")
    damping = _model_value("damping", "Whether any material has viscous damping (bool).")
    contact_damping = _model_value("contact_damping", "Whether any contact pair has contact damping (bool).")
    buffer = _model_value("buffer", "Detection buffer [m]: contact detection runs again once a node may have "
                                    "moved this far.")

    def __setattr__(self, name, value) -> None:
        # a name of the model or the state assigned on the simulation would change nothing
        model, state = self.__dict__.get("model"), self.__dict__.get("state")
        if not hasattr(type(self), name) and name not in self.__dict__ and (
                (model is not None and name in vars(model)) or (state is not None and name in vars(state))):
            where = "model" if model is not None and name in vars(model) else "state"
            raise AttributeError(f"sim.{name}: a value of the {where} is not a setting of the simulation; "
                                 f"read it as sim.{where}.{name} (model values are fixed at Scene.build)")
        object.__setattr__(self, name, value)

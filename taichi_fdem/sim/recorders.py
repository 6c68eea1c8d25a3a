"""Recorders: what :meth:`Simulation.run <taichi_fdem.sim.simulation.Simulation.run>` writes
as it goes, passed as ``run(duration, record=[...])``.

A recorder is an object with the methods of :class:`Recorder`; ``run`` opens every recorder
before the first step, tells it after each stretch of steps, after each check that passed and
after each of its frame intervals, and closes it at the end, also when the run stops with an
error.  The recorders of the simulation layer are :class:`History` (a CSV row every
``every`` steps) and :class:`CrackEvents` (a CSV row per broken joint); the renderer's
:class:`~taichi_fdem.render.recorder.Video` and the exporter's
:class:`~taichi_fdem.io.vtu.VTU` sit above the simulation and plug in the same way.
:class:`Checks` sets the run's stability checks.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Recorder", "History", "CrackEvents", "Callback", "Checks"]


class Recorder:
    """The protocol of a recorder (every method does nothing by default).

    ``frame_dt`` [s]: simulated time between two calls of :meth:`frame` (None: the recorder
    takes no frames); ``every`` [steps]: steps between two calls of :meth:`row` (None: no
    rows).  Either may be resolved in :meth:`open`, which sees the run's length.
    """
    frame_dt: float | None = None
    every: int | None = None

    def open(self, sim, steps: int, duration: float) -> None:
        """Before the first step of a run of ``steps`` steps (``duration`` [s]): open files,
        write the initial state."""

    def after_steps(self, sim, done: int) -> None:
        """After a stretch of steps (``done`` steps of the run so far)."""

    def row(self, sim, done: int) -> None:
        """Every ``every`` steps and at the end, after the run's checks passed."""

    def frame(self, sim, done: int) -> None:
        """After every frame interval (``frame_dt``) and at the end."""

    def close(self) -> None:
        """After the run, also when it stopped with an error: flush and close."""


def _path(value, what: str) -> str:
    import os
    try:
        return os.fspath(value)
    except TypeError:
        raise TypeError(f"{what}: path must be a str or os.PathLike, got {value!r}") from None


class History(Recorder):
    """A CSV history (:class:`taichi_fdem.sim.results.HistoryFile` columns: time, reactions,
    curve amplitudes, mean displacements, fracture and fluid totals, energies): a row at the
    start, every ``every`` steps (default: about 200 rows over the run) and at the end; each
    row is flushed, an existing file is appended to."""

    def __init__(self, path, every: int | None = None):
        self.path = _path(path, "History")
        if every is not None and (isinstance(every, bool) or int(every) != every or int(every) < 1):
            raise ValueError(f"History: every must be an integer >= 1 step or None, got {every!r}")
        self.requested = None if every is None else int(every)
        self.every = self.requested
        self.file = None

    def open(self, sim, steps, duration):
        from .results import HistoryFile
        self.every = max(1, steps // 200) if self.requested is None else self.requested
        self.file = HistoryFile(sim, self.path)
        self.file.write()

    def row(self, sim, done):
        self.file.write()

    def close(self):
        if self.file is not None:
            self.file.close()
            self.file = None


class CrackEvents(Recorder):
    """A CSV file of crack events (:meth:`sim.cracks.events
    <taichi_fdem.sim.cracks.Cracks.events>` columns ``joint, time_s, x_m, y_m, mode,
    energy_J, length_m, set, pressure_Pa``): the joints broken so far at the start, new ones
    after every stretch of steps and at the end, also when the run stops with an error; each
    write is flushed.  An existing file is appended to without repeating the joints it lists
    (:class:`taichi_fdem.sim.cracks.CrackEventLog`)."""

    def __init__(self, path):
        self.path = _path(path, "CrackEvents")
        self.log = None

    def open(self, sim, steps, duration):
        from .cracks import CrackEventLog
        self.log = CrackEventLog(sim, self.path)
        self.log.write()

    def after_steps(self, sim, done):
        self.log.write()

    def close(self):
        if self.log is not None:
            self.log.close()
            self.log = None


class Callback(Recorder):
    """Call ``fn(sim)`` every ``frame_dt`` seconds of simulated time (default: 100 times over
    the run) and at the end."""

    def __init__(self, fn, frame_dt: float | None = None):
        if not callable(fn):
            raise TypeError(f"Callback: fn must be callable as fn(sim), got {fn!r}")
        if frame_dt is not None and not (isinstance(frame_dt, (int, float)) and not isinstance(frame_dt, bool)
                                         and math.isfinite(frame_dt) and frame_dt > 0):
            raise ValueError(f"Callback: frame_dt must be a positive time [s] or None, got {frame_dt!r}")
        self.fn, self.requested_dt, self.frame_dt = fn, frame_dt, frame_dt

    def open(self, sim, steps, duration):
        if self.requested_dt is None:
            self.frame_dt = duration / 100 if duration > 0 else sim.dt

    def frame(self, sim, done):
        self.fn(sim)


@dataclass(frozen=True)
class Checks:
    """The checks :meth:`Simulation.run` makes after every chunk of steps (besides the
    kernels' own per-step checks of non-finite values, inverted elements and ``speed_limit``).

    * ``energy``: the total of :meth:`energies` must not rise above its value at the start of the
      run by more than ``energy_tol`` × the energy scale (the largest kinetic + strain +
      contact + dissipated + ``|boundary work|`` seen so far).
    * ``energy_tol``: that fraction (> 0).
    * ``max_penetration``: no contact couple may overlap by more than this fraction of its element
      size (:func:`taichi_fdem.sim.guards.max_couple_penetration`); None: not checked.
    * ``every``: steps between two checks (None: adaptive, keeping their cost near 10 % of the
      stepping time, between every 20 and every 500 steps).
    """
    energy: bool = True
    energy_tol: float = 0.1
    max_penetration: float | None = 0.5
    every: int | None = None

    def __post_init__(self):
        tol = float(self.energy_tol)
        if not (math.isfinite(tol) and tol > 0):
            raise ValueError(f"Checks: energy_tol must be a positive fraction, got {self.energy_tol!r}")
        if self.max_penetration is not None:
            p = float(self.max_penetration)
            if not (math.isfinite(p) and p > 0):
                raise ValueError(f"Checks: max_penetration must be a positive fraction of the element size or "
                                 f"None, got {self.max_penetration!r}")
        if self.every is not None and (isinstance(self.every, bool) or int(self.every) != self.every
                                       or int(self.every) < 1):
            raise ValueError(f"Checks: every must be an integer >= 1 step or None, got {self.every!r}")

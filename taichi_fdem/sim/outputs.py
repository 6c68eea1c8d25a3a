"""The outputs of :meth:`Simulation.run <taichi_fdem.sim.simulation.Simulation.run>`: its
recorders (:mod:`taichi_fdem.sim.recorders`) and the progress bar, opened and closed together.

``run`` asks :class:`RunOutputs` how many steps it may take before the next row or frame
(:meth:`RunOutputs.steps_to_next`), and tells it after each stretch of steps
(:meth:`RunOutputs.after_steps`), after the checks of a stretch passed
(:meth:`RunOutputs.after_check`: rows) and at each frame boundary
(:meth:`RunOutputs.after_frame`: frames, the progress bar).
"""
from __future__ import annotations

import sys
from contextlib import ExitStack

from .recorders import Recorder

__all__ = ["RunOutputs"]


class RunOutputs:
    """The recorders of one :meth:`Simulation.run` of ``total`` steps (``duration`` [s]) and
    its progress bar; a context manager that closes every recorder it opened, also when the
    run stops with an error.  Anything in ``recorders`` that is not a
    :class:`~taichi_fdem.sim.recorders.Recorder` raises TypeError before any is opened.
    """

    def __init__(self, sim, total: int, duration: float, recorders=(), progress=None):
        recorders = list(recorders)
        for k, r in enumerate(recorders):
            if not isinstance(r, Recorder):
                raise TypeError(f"run: record[{k}] is {r!r}, not a recorder (fdem.Video, fdem.History, "
                                f"fdem.CrackEvents, fdem.export.VTU, or a subclass of "
                                f"taichi_fdem.sim.recorders.Recorder)")
        self.sim, self.total, self.duration = sim, total, duration
        self.recorders = recorders
        self._progress = sys.stdout.isatty() if progress is None else bool(progress)
        self._stack = ExitStack()
        self._bar = self._task = None
        self.frame_steps: list = []

    def _steps_of(self, dt) -> int:
        return max(1, int(round(float(dt) / self.sim.dt)))

    def __enter__(self) -> "RunOutputs":
        sim, stack = self.sim, self._stack
        with ExitStack() as opening:                  # (closes what was opened if a later one fails)
            if self._progress:
                from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn
                self._bar = Progress(TextColumn("[bold]taichi_fdem[/]"), BarColumn(),
                                     TextColumn("t = {task.fields[t]} s"), TextColumn("{task.percentage:>5.1f}%"),
                                     TimeRemainingColumn(), transient=True)
                opening.enter_context(self._bar)
            for r in self.recorders:
                opening.callback(r.close)
                r.open(sim, self.total, self.duration)
            stack.push(opening.pop_all())
        self.frame_steps = [None if r.frame_dt is None else self._steps_of(r.frame_dt) for r in self.recorders]
        if self._bar is not None:
            self._task = self._bar.add_task("run", total=self.total, t="0")
        return self

    def __exit__(self, *exc) -> bool:
        return self._stack.__exit__(*exc)

    def steps_to_next(self, done: int, k: int) -> int:
        """At most ``k`` steps, cut at the next row or frame of a recorder after ``done`` steps."""
        for r, fs in zip(self.recorders, self.frame_steps):
            if r.every is not None:
                k = min(k, r.every - done % r.every)
            if fs is not None:
                k = min(k, fs - done % fs)
        return k

    def after_steps(self, done: int) -> None:
        for r in self.recorders:
            r.after_steps(self.sim, done)

    def after_check(self, done: int) -> None:
        """After the checks passed (``done`` steps so far): the rows that are due (every
        ``every`` steps and at the end), then the frames that are due."""
        last = done >= self.total
        for r in self.recorders:
            if r.every is not None and (done % r.every == 0 or last):
                r.row(self.sim, done)
        for r, fs in zip(self.recorders, self.frame_steps):
            if fs is not None and (done % fs == 0 or last):
                r.frame(self.sim, done)
        if self._bar is not None:
            self._bar.update(self._task, completed=done, t=f"{self.sim.time:.4g}")

"""The outputs of :meth:`Simulation.run <taichi_fdem.sim.simulation.Simulation.run>`: video
frames, the progress bar, the history CSV and the crack-event CSV, opened and closed together.

``run`` asks :class:`RunOutputs` how many steps it may take before the next history row
(:meth:`RunOutputs.steps_to_next_row`), and tells it after each stretch of steps
(:meth:`RunOutputs.after_steps`: crack events; :meth:`RunOutputs.after_check`: history rows) and after each frame interval
(:meth:`RunOutputs.after_frame`: a video frame, the progress bar).
"""
from __future__ import annotations

import sys
from contextlib import ExitStack, closing

from .cracks import CrackEventLog
from .results import History

__all__ = ["RunOutputs"]


class RunOutputs:
    """The writers of one :meth:`Simulation.run` of ``total`` steps (see its parameters); a
    context manager that closes every file it opened, also when the run stops with an error.

    The history file gets a row at the start, every ``history_every`` steps (default
    ``max(1, total // 200)``) and at the end; the crack-event file the joints broken so far at
    the start and the new ones after every stretch of steps.  Bad settings raise ValueError
    before any file is opened.
    """

    def __init__(self, sim, total: int, video=None, fps: int = 30, png_dir=None, renderer=None, progress=None,
                 history=None, history_every=None, crack_events=None, video_cracks: bool = False):
        if video is not None:
            if type(sim).video_sink_factory is None:
                raise RuntimeError("run(video=...): no video writer installed (import taichi_fdem installs one)")
            if renderer is not None and video_cracks:
                raise ValueError("run: video_cracks= applies to the default renderer; give cracks= to the "
                                 "RendererImage passed as renderer=")
        elif video_cracks:
            raise ValueError("run: video_cracks=True needs video=")
        self.every = None
        if history is not None:
            self.every = max(1, total // 200) if history_every is None else int(history_every)
            if self.every < 1:
                raise ValueError(f"run: history_every must be >= 1 step, got {history_every}")
        self.sim, self.total = sim, total
        self._settings = (video, fps, png_dir, renderer, bool(video_cracks), history, crack_events)
        self._progress = sys.stdout.isatty() if progress is None else bool(progress)
        self._stack = ExitStack()
        self.writer = self._draw = self.history = self.cracks = self._bar = self._task = None

    def __enter__(self) -> "RunOutputs":
        video, fps, png_dir, renderer, video_cracks, history, crack_events = self._settings
        sim, stack = self.sim, self._stack
        with ExitStack() as opening:                  # (closes what was opened if a later one fails)
            if video is not None:
                self.writer, self._draw = type(sim).video_sink_factory(sim, video, fps, png_dir, renderer,
                                                                       cracks=video_cracks)
            if self._progress:
                from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn
                self._bar = Progress(TextColumn("[bold]taichi_fdem[/]"), BarColumn(),
                                     TextColumn("t = {task.fields[t]} s"), TextColumn("{task.percentage:>5.1f}%"),
                                     TimeRemainingColumn(), transient=True)
            if history is not None:
                self.history = History(sim, history)
                opening.enter_context(closing(self.history))
                self.history.write()
            if crack_events is not None:
                self.cracks = CrackEventLog(sim, crack_events)
                opening.enter_context(closing(self.cracks))
                self.cracks.write()
            for ctx in (self.writer, self._bar):
                if ctx is not None:
                    opening.enter_context(ctx)
            stack.push(opening.pop_all())
        if self._bar is not None:
            self._task = self._bar.add_task("run", total=self.total, t="0")
        if self.writer is not None:
            self._draw()
        return self

    def __exit__(self, *exc) -> bool:
        return self._stack.__exit__(*exc)

    def steps_to_next_row(self, done: int, k: int) -> int:
        """At most ``k`` steps, cut at the next history row after ``done`` steps."""
        return k if self.every is None else min(k, self.every - done % self.every)

    def after_steps(self) -> None:
        """After a stretch of steps: the new crack events."""
        if self.cracks is not None:
            self.cracks.write()

    def after_check(self, done: int) -> None:
        """After the checks of a stretch of steps passed (``done`` so far): a history row when
        one is due (every ``history_every`` steps and at the end)."""
        if self.history is not None and (done % self.every == 0 or done >= self.total):
            self.history.write()

    def after_frame(self, done: int) -> None:
        """After a frame interval: a video frame and the progress bar."""
        if self.writer is not None:
            self._draw()
        if self._bar is not None:
            self._bar.update(self._task, completed=done, t=f"{self.sim.time:.4g}")

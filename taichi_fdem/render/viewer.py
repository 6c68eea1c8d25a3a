"""Live viewer: a window (Taichi's ``ti.GUI``) showing a running Simulation.

The window shows the images of a :class:`~taichi_fdem.render.RendererImage` (the same
off-screen renderer used for videos), so what you see live is exactly what a video shows.
This is the only module of taichi_fdem that opens windows.

Keys: SPACE pause / resume, ``s`` one frame of steps while paused, ``c`` next colour mode,
``q`` or ESC quit; closing the window ends :meth:`Viewer.run` too.

Without a display (no ``DISPLAY``, or an X server that cannot be opened), :meth:`Viewer.run`
warns and renders off-screen to ``fallback_video`` instead.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import warnings

import numpy as np

from .. import render
from . import COLOR_MODES, RendererImage, VideoWriter

__all__ = ["Viewer"]

_PROBE_TIMEOUT = 60.0   # seconds for the GUI-creation probe subprocess
_probe_cache: dict = {}


def _to_gui(img: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8, row 0 at the top -> (W, H, 3) float32 in [0, 1], indexed [x, y] with
    y up, as ``ti.GUI.set_image`` expects."""
    return np.ascontiguousarray(img[::-1].transpose(1, 0, 2), dtype=np.float32) * np.float32(1.0 / 255.0)


def _from_gui(canvas: np.ndarray) -> np.ndarray:
    """Inverse of :func:`_to_gui` for a GUI canvas ((W, H, 3 or 4) float in [0, 1])."""
    rgb = np.asarray(canvas)[:, :, :3].transpose(1, 0, 2)[::-1]
    return np.clip(rgb * 255.0 + 0.5, 0, 255).astype(np.uint8)


class Viewer:
    """Show a :class:`~taichi_fdem.sim.simulation.Simulation` live while it runs.

    Parameters
    ----------
    sim : the simulation to advance and show.
    renderer : a :class:`~taichi_fdem.render.RendererImage` (default: 960 x 540, colour by body);
        its size is the window size.
    steps_per_frame : time steps between two displayed frames (default: about 50 ms of
        stepping work, the chunk size :meth:`Simulation.run` uses).
    name : window title.
    fallback_video : video written by :meth:`run` when no display is available.
    fps : frame rate of the fallback video [frames/s].
    readback : also read the window canvas back after every frame (see :meth:`window_image`).
    """

    def __init__(self, sim, renderer: RendererImage | None = None, steps_per_frame: int | None = None,
                 name: str = "taichi_fdem", fallback_video="out/viewer.mp4", fps: int = 30,
                 readback: bool = False):
        self.sim = sim
        self.renderer = renderer if renderer is not None else RendererImage()
        if steps_per_frame is None:
            steps_per_frame = sim.solver.steps_per_launch()
        if isinstance(steps_per_frame, bool) or int(steps_per_frame) != steps_per_frame or steps_per_frame < 1:
            raise ValueError(f"Viewer: steps_per_frame must be an integer >= 1, got {steps_per_frame!r}")
        self.steps_per_frame = int(steps_per_frame)
        self.name = str(name)
        self.fallback_video = fallback_video
        self.fps = fps
        self.readback = bool(readback)
        self.paused = False
        self.frames = 0          # frames displayed (or written) by the last run
        self.mode = None         # "window" or "video" after run()
        self._last = None        # last displayed (H, W, 3) uint8 image
        self._window = None      # last canvas read back from the window, (H, W, 3) uint8
        self._gui = None
        self._on_frame = None
        self._steps_left = math.inf

    # -- display detection -------------------------------------------------------------------
    @staticmethod
    def available(probe: bool = True) -> tuple[bool, str]:
        """Whether a window can be opened: ``(True, "")`` or ``(False, reason)``.

        Checks that ``DISPLAY`` is set and, with ``probe``, that ``ti.GUI`` can open a window
        there, in a subprocess (cached per display) so that a failing window system cannot
        crash this process.  (The X server is not opened in this process: an extra libX11
        connection made here breaks Taichi's own window creation later.)
        """
        display = os.environ.get("DISPLAY", "")
        if not display:
            return False, "no display: the DISPLAY environment variable is not set"
        if not probe:
            return True, ""
        if display in _probe_cache:
            return _probe_cache[display]
        code = ("import taichi as ti\n"
                "ti.init(arch=ti.cpu, log_level=ti.ERROR)\n"
                "g = ti.GUI('probe', res=(32, 32), show_gui=True)\n"
                "g.show()\n"
                "g.close()\n")
        try:
            for _ in range(2):          # once more after a crash (a signal): X servers starting up race
                p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                   timeout=_PROBE_TIMEOUT)
                if p.returncode >= 0:
                    break
            if p.returncode == 0:
                res = (True, "")
            else:
                last = [ln for ln in (p.stderr or p.stdout).strip().splitlines() if ln.strip()][-1:]
                res = (False, f"ti.GUI could not open a window on DISPLAY={display!r} "
                              f"(exit code {p.returncode}){': ' + last[0] if last else ''}")
        except subprocess.TimeoutExpired:
            res = (False, f"ti.GUI window creation on {display!r} timed out")
        except OSError as exc:  # pragma: no cover
            res = (False, f"could not probe the display: {exc}")
        _probe_cache[display] = res
        return res

    # -- images ----------------------------------------------------------------------------
    def screenshot(self) -> np.ndarray | None:
        """The last displayed frame, (H, W, 3) uint8 (a copy), or None before the first frame."""
        return None if self._last is None else self._last.copy()

    def window_image(self) -> np.ndarray | None:
        """The window canvas of the last frame as read back from ``ti.GUI`` (``gui.get_image()``,
        taken right before ``gui.show()``), (H, W, 3) uint8; needs ``readback=True``.  None
        when nothing was read back (no window, or readback off)."""
        return None if self._window is None else self._window.copy()

    # -- loop ------------------------------------------------------------------------------
    def _frame_budget(self, duration, max_frames):
        """Frames to show (the initial frame included) and steps to take (inf = unlimited)."""
        frames, steps = math.inf, math.inf
        if duration is not None:
            duration = float(duration)
            if not (math.isfinite(duration) and duration >= 0):
                raise ValueError(f"Viewer.run: duration must be a finite time >= 0 s, got {duration}")
            steps = int(round(duration / self.sim.dt))
            frames = 1 + math.ceil(steps / self.steps_per_frame)
        if max_frames is not None:
            if isinstance(max_frames, bool) or int(max_frames) != max_frames or max_frames < 1:
                raise ValueError(f"Viewer.run: max_frames must be an integer >= 1, got {max_frames!r}")
            frames = min(frames, int(max_frames))
        return frames, steps

    def _advance(self):
        k = self.steps_per_frame if not math.isfinite(self._steps_left) else int(
            min(self.steps_per_frame, self._steps_left))
        if k > 0:
            self.sim.step(k)
            self._steps_left -= k

    def run(self, duration: float | None = None, max_frames: int | None = None,
            fallback_frames: int = 150, on_frame=None) -> str:
        """Step and display until ``duration`` seconds of simulated time have passed (None:
        until the window is closed or ``q`` / ESC), or ``max_frames`` frames were shown.

        Without a display, warns (RuntimeWarning) and writes the frames to ``fallback_video``
        instead; then ``duration=None`` and ``max_frames=None`` mean ``fallback_frames``
        frames (all counts include the initial frame).  ``on_frame(viewer)`` is called after every displayed (or written) frame,
        while the window is still open.  Returns ``"window"`` or ``"video"``.
        """
        self._on_frame = on_frame
        budget, self._steps_left = self._frame_budget(duration, max_frames)
        ok, why = self.available()
        self.frames = 0
        if not ok:
            msg = (f"Viewer: {why}; rendering off-screen to {os.fspath(self.fallback_video)!r} instead "
                   "of opening a window")
            warnings.warn(msg, RuntimeWarning, stacklevel=2)
            print(msg, file=sys.stderr)
            if not math.isfinite(budget):
                budget = int(fallback_frames)
            self.mode = "video"
            self._run_video(budget)
            return "video"
        self.mode = "window"
        self._run_window(budget)
        return "window"

    def _run_video(self, budget):
        with VideoWriter(self.fallback_video, fps=self.fps) as writer:
            self._show_video(writer)
            while self.frames < budget:
                self._advance()
                self._show_video(writer)

    def _show_video(self, writer):
        img = self.renderer.render_sim(self.sim)
        writer.append(img)
        self._last = img
        self.frames += 1
        if self._on_frame is not None:
            self._on_frame(self)

    def _run_window(self, budget):
        import taichi as ti

        r = self.renderer
        bg = render._check_color("background", r.background)
        bg_hex = (int(bg[0] * 255) << 16) | (int(bg[1] * 255) << 8) | int(bg[2] * 255)
        gui = ti.GUI(self.name, res=(r.width, r.height), background_color=bg_hex, show_gui=True)
        self._gui = gui
        try:
            shown = 0
            step_once = False
            while gui.running and shown < budget:
                quit_ = False
                for e in gui.get_events(ti.GUI.PRESS):
                    if e.key in (ti.GUI.ESCAPE, "q", ti.GUI.EXIT):
                        quit_ = True
                    elif e.key == ti.GUI.SPACE:
                        self.paused = not self.paused
                    elif e.key == "s" and self.paused:
                        step_once = True
                    elif e.key == "c":
                        self.cycle_color()
                if quit_:
                    break
                if not self.paused:
                    if shown > 0:
                        self._advance()
                elif step_once:
                    self._advance()
                    step_once = False
                img = r.render_sim(self.sim)
                if img.shape[:2] != (gui.res[1], gui.res[0]):
                    raise RuntimeError("Viewer: the renderer was resized while the window is open")
                gui.set_image(_to_gui(img))
                if self.readback:
                    self._window = _from_gui(gui.get_image())
                self._last = img
                gui.show()
                if not self.paused or shown == 0:
                    shown += 1
                    self.frames = shown
                if self._on_frame is not None:
                    self._on_frame(self)
        finally:
            self._gui = None
            gui.close()

    def cycle_color(self) -> str:
        """Switch the renderer to the next colour mode (order of ``COLOR_MODES``; ``"fluid_pressure"``
        only in a scene with a fluid, ``"bedding"`` in one with a bedded material, ``"temperature"`` in one
        with heat); returns it."""
        model = getattr(self.sim, "model", None)
        fluid = bool(getattr(model, "fluid", False))
        bedding = bool(getattr(model, "bedding", False))
        heat = bool(getattr(model, "heat", False))
        modes = [m for m in COLOR_MODES if (fluid or m != "fluid_pressure") and (bedding or m != "bedding")
                 and (heat or m != "temperature")]
        i = modes.index(self.renderer.color_by) if self.renderer.color_by in modes else -1
        self.renderer.color_by = modes[(i + 1) % len(modes)]
        return self.renderer.color_by

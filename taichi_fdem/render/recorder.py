"""The video recorder of :meth:`Simulation.run <taichi_fdem.sim.simulation.Simulation.run>`:
``sim.run(duration, record=[fdem.Video("out/run.mp4")])``."""
from __future__ import annotations

import math
import numbers
import os

from ..sim.recorders import Recorder
from .colors import body_colors
from .raster import RendererImage
from .video import VideoWriter

__all__ = ["Video"]


class Video(Recorder):
    """Render the simulation every ``frame_dt`` seconds of simulated time into a video.

    * ``path``: ``.mp4``, ``.gif``, or a directory for a PNG sequence.
    * ``fps``: frames per second of the video.
    * ``frame_dt``: simulated time between two frames [s] (default: the run spread over 5 s of video
      at ``fps``).  Frames are drawn at the start, every ``frame_dt`` and at the end, never
      every step, and streamed to the file.
    * ``renderer``: a :class:`~taichi_fdem.render.RendererImage` (default: fitted view, body colours).
    * ``png_dir``: also write every frame as PNG into this directory.
    * ``cracks``: draw the broken joints (both crack faces) with the default renderer; with
      ``renderer=``, set its ``cracks`` option instead (both raise ValueError).
    """

    def __init__(self, path, fps: int = 30, frame_dt: float | None = None, renderer=None, png_dir=None,
                 cracks: bool = False):
        self.path = os.fspath(path)
        if isinstance(fps, bool) or not isinstance(fps, numbers.Real) or not (fps > 0 and math.isfinite(fps)):
            raise ValueError(f"Video: fps must be a positive number, got {fps!r}")
        if frame_dt is not None and not (isinstance(frame_dt, numbers.Real) and math.isfinite(frame_dt)
                                         and frame_dt > 0):
            raise ValueError(f"Video: frame_dt must be a positive time [s] or None, got {frame_dt!r}")
        if renderer is not None and cracks:
            raise ValueError("Video: cracks= applies to the default renderer; give cracks= to the RendererImage "
                             "passed as renderer=")
        self.fps, self.requested_dt, self.renderer = fps, frame_dt, renderer
        self.png_dir, self.cracks = png_dir, bool(cracks)
        self.frame_dt = frame_dt
        self.writer = None
        self._draw = None

    def open(self, sim, steps, duration):
        if self.requested_dt is None:
            self.frame_dt = duration / max(1, 5 * self.fps) if duration > 0 else sim.dt
        renderer = self.renderer or RendererImage(cracks=self.cracks)
        self.writer = VideoWriter(self.path, fps=self.fps, png_dir=self.png_dir)
        self.writer.__enter__()
        if hasattr(renderer, "render_sim"):
            self._draw = lambda: self.writer.append(renderer.render_sim(sim))
        else:
            colors = body_colors(sim.model.tri_body_np)
            self._draw = lambda: self.writer.append(renderer.render(sim.state.node_x, sim.model.tri_nodes, colors))
        self._draw()

    def frame(self, sim, done):
        self._draw()

    def close(self):
        if self.writer is not None:
            self.writer.__exit__(None, None, None)
            self.writer = None

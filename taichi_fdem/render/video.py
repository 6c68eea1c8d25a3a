"""Image and video output: :func:`save_png` and :class:`VideoWriter` (``.mp4`` with libx264,
``.gif``, or a PNG sequence directory), streaming frames through imageio / imageio-ffmpeg.
"""
import math
import numbers
import os
from pathlib import Path

import numpy as np

from ._util import _as_uint8_image

__all__ = ["save_png", "VideoWriter"]


def save_png(path, image) -> None:
    """Write an (H, W, 3) uint8 (or float in [0, 1]) image as PNG, creating parent dirs."""
    from PIL import Image

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(_as_uint8_image(image)).save(path, format="PNG", compress_level=3)


def _path_kind(path) -> str:
    s = os.fspath(path)
    p = Path(s)
    if s.endswith(("/", os.sep)) or p.is_dir() or p.suffix == "":
        return "png"
    suf = p.suffix.lower()
    if suf == ".mp4":
        return "mp4"
    if suf == ".gif":
        return "gif"
    raise ValueError(f"VideoWriter: unsupported output {s!r}; use a .mp4 or .gif file or a "
                     "directory (PNG sequence)")


class VideoWriter:
    """Stream frames to an ``.mp4`` (libx264), a ``.gif`` or a PNG sequence directory.

    Frames are handed to the encoder as they come, so memory does not grow with the number of
    frames.  ``png_dir`` optionally also writes every frame as ``frame_00000.png`` ... there.
    Use as a context manager: the file is closed (and therefore valid) even when the block is
    left by an exception or KeyboardInterrupt.  All frames must have the same size; odd sizes
    are padded by one edge row/column for mp4 (yuv420p needs even sizes).
    """

    def __init__(self, path, fps=30, png_dir=None, quality=7):
        if isinstance(fps, bool) or not isinstance(fps, numbers.Real) or not (fps > 0 and math.isfinite(fps)):
            raise ValueError(f"VideoWriter: fps must be a positive number, got {fps!r}")
        if isinstance(quality, bool) or not isinstance(quality, numbers.Real) or not (1 <= quality <= 10):
            raise ValueError(f"VideoWriter: quality must be in 1..10, got {quality!r}")
        self.path = Path(path)
        self.kind = _path_kind(path)
        self.fps = float(fps)
        self.quality = float(quality)
        self.png_dir = Path(png_dir) if png_dir is not None else None
        if self.kind == "png":
            self.path.mkdir(parents=True, exist_ok=True)
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        if self.png_dir is not None:
            self.png_dir.mkdir(parents=True, exist_ok=True)
            if self.kind == "png" and self.png_dir.resolve() == self.path.resolve():
                self.png_dir = None
        self._count = 0
        self._size = None      # (H, W) of the first frame
        self._writer = None    # imageio writer (mp4, gif fallback)
        self._gen = None       # imageio_ffmpeg write_frames generator (gif)
        self._closed = False

    @property
    def frame_count(self) -> int:
        return self._count

    @property
    def closed(self) -> bool:
        return self._closed

    def _open(self, h, w):
        if self.kind == "mp4":
            import imageio.v2 as imageio

            self._writer = imageio.get_writer(
                os.fspath(self.path), format="FFMPEG", mode="I", fps=self.fps, codec="libx264",
                quality=self.quality, macro_block_size=1, pixelformat="yuv420p",
                ffmpeg_log_level="error")
        elif self.kind == "gif":
            try:
                import imageio_ffmpeg

                # per-frame palettes: good colours, and still a single streaming pass
                vf = ("split[s0][s1];[s0]palettegen=stats_mode=single:reserve_transparent=0[p];"
                      "[s1][p]paletteuse=new=1:dither=bayer")
                gen = imageio_ffmpeg.write_frames(
                    os.fspath(self.path), (w, h), fps=self.fps, codec="gif", pix_fmt_in="rgb24",
                    pix_fmt_out="pal8", quality=None, macro_block_size=1, ffmpeg_log_level="error",
                    output_params=["-vf", vf, "-loop", "0"])
                gen.send(None)
                self._gen = gen
            except Exception:  # no usable ffmpeg: Pillow via imageio (buffers frames in memory)
                import imageio.v2 as imageio

                self._gen = None
                self._writer = imageio.get_writer(os.fspath(self.path), mode="I",
                                                  duration=1000.0 / self.fps, loop=0)

    def append(self, image) -> None:
        """Add one frame, an (H, W, 3) uint8 array (float in [0, 1] is converted)."""
        if self._closed:
            raise RuntimeError("VideoWriter.append: the writer is closed")
        img = _as_uint8_image(image)
        h, w = img.shape[:2]
        if self._size is None:
            self._size = (h, w)
            self._open(*self._padded(h, w))
        elif self._size != (h, w):
            raise ValueError(f"VideoWriter.append: frame size {(h, w)} differs from the first "
                             f"frame's {self._size}")
        idx = self._count
        if self.kind == "mp4":
            ph, pw = self._padded(h, w)
            if (ph, pw) != (h, w):
                img = np.pad(img, ((0, ph - h), (0, pw - w), (0, 0)), mode="edge")
            self._writer.append_data(img)
        elif self.kind == "gif":
            if self._gen is not None:
                self._gen.send(img.tobytes())
            else:
                self._writer.append_data(img)
        else:
            save_png(self.path / f"frame_{idx:05d}.png", img)
        if self.png_dir is not None:
            save_png(self.png_dir / f"frame_{idx:05d}.png", img)
        self._count += 1

    def _padded(self, h, w):
        if self.kind == "mp4":
            return h + (h % 2), w + (w % 2)
        return h, w

    def close(self) -> None:
        """Finish the file (idempotent)."""
        if self._closed:
            return
        self._closed = True
        gen, writer = self._gen, self._writer
        self._gen = self._writer = None
        if gen is not None:
            gen.close()
        if writer is not None:
            writer.close()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close()
        return False

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass

    def __repr__(self):
        return f"VideoWriter({os.fspath(self.path)!r}, kind={self.kind}, frames={self._count})"

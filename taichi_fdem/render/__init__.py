"""Off-screen rendering of FDEM meshes, colour maps and video output.

* :class:`RendererImage` rasterises the triangles of a 2D mesh into an RGB image with Taichi
  kernels (no window, no OpenGL): one thread per triangle fills the pixels of its bounding box
  whose centres pass the (inclusive) edge-function test, optionally drawing the triangle
  edges, with optional supersampling (box-filtered down on the device).
  :meth:`RendererImage.render_sim` draws a :class:`~taichi_fdem.sim.simulation.Simulation`
  coloured by body, material, stress (von Mises, principal), speed or displacement, with a
  colour bar, a time/step stamp and a fitted, fixed or body-following camera.
* :func:`colormap` / :func:`body_colors` turn scalar fields and body ids into per-triangle
  colours (built-in tables, no matplotlib).
* :class:`VideoWriter` streams frames to ``.mp4`` (libx264), ``.gif`` or a PNG directory.
* :func:`save_png`, :func:`annotate` are small image functions.

All kernels take ``ti.types.ndarray()`` arguments, so a new scene or image size never causes
a recompilation (kernels are compiled once per dtype / dimensionality).

Modules (imports run downwards only; none imports :mod:`taichi_fdem.sim.simulation`, a simulation
is only read through the object handed in):

* :mod:`._util` -- argument checks and Taichi / NumPy array conversions;
* :mod:`.colors` -- :data:`COLOR_MODES`, :data:`COLORMAPS`, :func:`colormap`, :func:`body_colors`;
* :mod:`.kernels` -- the Taichi kernels (rasterisers, colouring scalars, bounding boxes, clearing);
* :mod:`.labels` -- colour bar, labels and stamp (Pillow), :func:`annotate`;
* :mod:`.raster` -- :class:`RendererImage`;
* :mod:`.video` -- :func:`save_png`, :class:`VideoWriter`.
"""
from ._util import _check_color
from .colors import COLOR_MODES, COLORMAPS, body_colors, colormap
from .kernels import (_bbox_kernel, _centroid_kernel, _clear_kernel, _clear_u8_kernel, _raster_kernel,
                      _raster_u8_kernel, _resolve_kernel, _sim_scalar_kernel, _to_pixels_kernel,
                      _tri_scalar_kernel)
from .labels import _fmt, annotate
from .raster import RendererImage
from .video import VideoWriter, save_png

__all__ = ["RendererImage", "colormap", "body_colors", "VideoWriter", "save_png", "annotate",
           "COLORMAPS", "COLOR_MODES"]
# The private kernels and functions above are re-exported for the tests that drive them directly.

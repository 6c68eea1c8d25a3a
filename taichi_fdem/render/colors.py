"""Colour modes, colour maps and body colours (NumPy; built-in tables, no matplotlib).

* :data:`COLOR_MODES` -- the ``color_by`` modes of
  :meth:`~taichi_fdem.render.RendererImage.render_sim` with their colour-bar titles
  (``"fluid_pressure"`` colours the fracture network, not the triangles);
* :data:`COLORMAPS` / :func:`colormap` -- scalar fields to RGB (viridis, gray, coolwarm);
* :func:`body_colors` -- a distinct palette colour per body (or material) id;
* :func:`bedding_colors` -- a hue per bedding angle (``color_by="bedding"``).

The raster kernel applies the same tables on the device (see
:func:`~taichi_fdem.render.kernels._cmap`), so both paths give the same colours.
"""
import math

import numpy as np

from ._util import _to_np

__all__ = ["COLOR_MODES", "COLORMAPS", "colormap", "body_colors", "bedding_colors", "SOLID_UNDER_FLUID",
           "ISOTROPIC_COLOR"]

# color_by modes of RendererImage.render_sim: name -> (kernel mode id or None for categorical,
# colour-bar title with units).  The stress titles have two spaces before "stress": a space of
# Pillow's default label font is 2 px wide at the default text size of small frames (10 px), so
# that "von Mises stress" read "von Misesstress" and "principal stress" "principalstress".
COLOR_MODES = {
    "body": (None, "body"),
    "material": (None, "material"),
    "speed": (0, "speed |v| [m/s]"),
    "displacement": (1, "displacement |x - X| [m]"),
    "von_mises": (2, "von Mises  stress [Pa]"),
    "max_principal": (3, "max principal  stress [Pa]"),
    "min_principal": (4, "min principal  stress [Pa]"),
    "damage": (-1, "damage"),       # sim.cracks.tri_damage() (joint model), range [0, 1]
    # the network edges coloured by the fluid pressure over a grey solid (scenes with a fluid)
    "fluid_pressure": (-2, "fluid  pressure [Pa]"),
    # a hue per bedding angle, isotropic triangles in ISOTROPIC_COLOR (scenes with a bedded material)
    "bedding": (-3, "bedding angle"),
    # the mean of the nodes' temperatures of each triangle (scenes with heat: sim.temperatures())
    "temperature": (-4, "temperature"),
}
#: fill colour of the triangles of isotropic materials in the "bedding" mode (RGB in [0, 1])
ISOTROPIC_COLOR = (0.6, 0.6, 0.6)
#: fill colour of the solid under the fluid network in the "fluid_pressure" mode (RGB in [0, 1])
SOLID_UNDER_FLUID = (0.86, 0.86, 0.86)


def _check_color_by(mode):
    if mode not in COLOR_MODES:
        raise ValueError(f"color_by must be one of {list(COLOR_MODES)}, got {mode!r}")
    return mode


# matplotlib's viridis sampled at table indices 0, 8, ..., 248, 255 (max interpolation error
# < 2/255 against the full 256-entry table).
_VIRIDIS_IDX = np.array(list(range(0, 256, 8)) + [255], dtype=np.float64) / 255.0
_VIRIDIS = np.array([
    (0.267004, 0.004874, 0.329415), (0.277018, 0.050344, 0.375715), (0.282327, 0.094955, 0.417331),
    (0.282884, 0.135920, 0.453427), (0.278826, 0.175490, 0.483397), (0.270595, 0.214069, 0.507052),
    (0.258965, 0.251537, 0.524736), (0.244972, 0.287675, 0.537260), (0.229739, 0.322361, 0.545706),
    (0.214298, 0.355619, 0.551184), (0.199430, 0.387607, 0.554642), (0.185556, 0.418570, 0.556753),
    (0.172719, 0.448791, 0.557885), (0.160665, 0.478540, 0.558115), (0.149039, 0.508051, 0.557250),
    (0.137770, 0.537492, 0.554906), (0.127568, 0.566949, 0.550556), (0.120565, 0.596422, 0.543611),
    (0.120638, 0.625828, 0.533488), (0.132268, 0.655014, 0.519661), (0.157851, 0.683765, 0.501686),
    (0.196571, 0.711827, 0.479221), (0.246070, 0.738910, 0.452024), (0.304148, 0.764704, 0.419943),
    (0.369214, 0.788888, 0.382914), (0.440137, 0.811138, 0.340967), (0.515992, 0.831158, 0.294279),
    (0.595839, 0.848717, 0.243329), (0.678489, 0.863742, 0.189503), (0.762373, 0.876424, 0.137064),
    (0.845561, 0.887322, 0.099702), (0.926106, 0.897330, 0.104071), (0.993248, 0.906157, 0.143936),
], dtype=np.float64)

# Moreland's diverging cool-warm map (5 anchors), handy for signed quantities.
_COOLWARM = np.array([(59, 76, 192), (141, 176, 254), (221, 221, 221), (244, 154, 123),
                      (180, 4, 38)], dtype=np.float64) / 255.0

COLORMAPS = {
    "viridis": (_VIRIDIS_IDX, _VIRIDIS),
    "gray": (np.array([0.0, 1.0]), np.array([(0.0, 0.0, 0.0), (1.0, 1.0, 1.0)])),
    "coolwarm": (np.linspace(0.0, 1.0, len(_COOLWARM)), _COOLWARM),
}
COLORMAPS["grey"] = COLORMAPS["gray"]

_NAN_COLOR = np.array([0.5, 0.5, 0.5], dtype=np.float32)


def colormap(values, vmin=None, vmax=None, name="viridis") -> np.ndarray:
    """Map scalars to RGB colours: ``values`` of shape S -> float32 array of shape S + (3,).

    ``vmin``/``vmax`` default to the finite min/max of ``values``; values are clipped to
    [vmin, vmax]; vmin maps to the first table colour, vmax to the last.  NaN maps to grey.
    Available maps: ``viridis`` (default), ``gray``, ``coolwarm``.
    """
    if name not in COLORMAPS:
        raise ValueError(f"colormap: unknown name {name!r}; choose one of {sorted(COLORMAPS)}")
    pos, table = COLORMAPS[name]
    v = np.asarray(_to_np(values), dtype=np.float64)
    finite = np.isfinite(v)
    if vmin is None:
        vmin = float(v[finite].min()) if finite.any() else 0.0
    if vmax is None:
        vmax = float(v[finite].max()) if finite.any() else 1.0
    vmin, vmax = float(vmin), float(vmax)
    if not (math.isfinite(vmin) and math.isfinite(vmax)):
        raise ValueError(f"colormap: vmin and vmax must be finite, got {vmin}, {vmax}")
    if vmax < vmin:
        raise ValueError(f"colormap: vmax ({vmax}) < vmin ({vmin})")
    span = vmax - vmin
    t = np.clip((v - vmin) / span, 0.0, 1.0) if span > 0 else np.zeros_like(v)
    t = np.where(finite, t, 0.0)
    out = np.empty(v.shape + (3,), dtype=np.float32)
    flat_t = t.reshape(-1)
    flat = out.reshape(-1, 3)
    for k in range(3):
        flat[:, k] = np.interp(flat_t, pos, table[:, k])
    out[~finite] = _NAN_COLOR
    return out


# Tableau-10 qualitative palette (pleasant, distinct; cycles for more bodies).
_BODY_PALETTE = np.array([
    (78, 121, 167), (242, 142, 43), (225, 87, 89), (118, 183, 178), (89, 161, 79),
    (237, 201, 72), (176, 122, 161), (255, 157, 167), (156, 117, 95), (186, 176, 172),
], dtype=np.float32) / 255.0


def body_colors(tri_body) -> np.ndarray:
    """A distinct colour per body id: ``(m,)`` ints -> ``(m, 3)`` float32 (palette cycles)."""
    ids = np.asarray(_to_np(tri_body))
    if ids.size and not np.issubdtype(ids.dtype, np.integer):
        raise ValueError(f"body_colors: body ids must be integers, got dtype {ids.dtype}")
    ids = ids.astype(np.int64).reshape(-1)
    return _BODY_PALETTE[np.mod(ids, len(_BODY_PALETTE))]


def bedding_colors(tri_bedding) -> np.ndarray:
    """(m, 3) float32 RGB of the ``"bedding"`` colour mode: the bedding direction (cos, sin) of
    each triangle (``sim.model.tri_bedding``) as a hue, its angle modulo 180° around the colour
    circle (0° red, 60° green, 120° blue); (0, 0), a triangle of an isotropic material, in
    :data:`ISOTROPIC_COLOR`."""
    cs = np.asarray(_to_np(tri_bedding), dtype=np.float64).reshape(-1, 2)
    hue = np.mod(np.degrees(np.arctan2(cs[:, 1], cs[:, 0])), 180.0) / 180.0
    k = np.mod(np.array([5.0, 3.0, 1.0])[None, :] + hue[:, None] * 6.0, 6.0)     # HSV → RGB, s = 0.75, v = 0.9
    rgb = 0.9 - 0.9 * 0.75 * np.clip(np.minimum(k, 4.0 - k), 0.0, 1.0)
    rgb[np.all(cs == 0.0, axis=1)] = ISOTROPIC_COLOR
    return rgb.astype(np.float32)

"""Off-screen rendering of FDEM meshes, colour maps and video output.

* :class:`RendererImage` rasterises the triangles of a 2D mesh into an RGB image with Taichi
  kernels (no window, no OpenGL): one thread per triangle fills the pixels of its bounding box
  whose centres pass the (inclusive) edge-function test, optionally drawing the triangle
  edges, with optional supersampling (box-filtered down on the device).
  :meth:`RendererImage.render_sim` draws a :class:`~taichi_fdem.simulation.Simulation`
  coloured by body, material, stress (von Mises, principal), speed or displacement, with a
  colour bar, a time/step stamp and a fitted, fixed or body-following camera.
* :func:`colormap` / :func:`body_colors` turn scalar fields and body ids into per-triangle
  colours (built-in tables, no matplotlib).
* :class:`VideoWriter` streams frames to ``.mp4`` (libx264), ``.gif`` or a PNG directory.
* :func:`save_png`, :func:`annotate` are small image helpers.

All kernels take ``ti.types.ndarray()`` arguments, so a new scene or image size never causes
a recompilation (kernels are compiled once per dtype / dimensionality).
"""

import math
import numbers
import os
import weakref
from pathlib import Path

import numpy as np
import taichi as ti

from taichi_fdem import backend
from taichi_fdem.engine.elastic import cauchy_elastic, deformation

__all__ = ["RendererImage", "colormap", "body_colors", "VideoWriter", "save_png", "annotate",
           "COLORMAPS", "COLOR_MODES"]

# color_by modes of RendererImage.render_sim: name -> (kernel mode id or None for categorical,
# colour-bar title with units)
COLOR_MODES = {
    "body": (None, "body"),
    "material": (None, "material"),
    "speed": (0, "speed |v| [m/s]"),
    "displacement": (1, "displacement |x - X| [m]"),
    "von_mises": (2, "von Mises stress [Pa]"),
    "max_principal": (3, "max principal stress [Pa]"),
    "min_principal": (4, "min principal stress [Pa]"),
    "damage": (-1, "damage"),       # Simulation.tri_damage() (joint model), range [0, 1]
}

# Pixel coordinates are clamped to +-_PIX_LIMIT (also maps NaN to -_PIX_LIMIT) so that runaway
# nodes can never produce absurd loop bounds.
_PIX_LIMIT = 1.0e7

_vec3f = ti.types.vector(3, ti.f32)


# ----------------------------------------------------------------------------------------------
# Kernels (module level; ndarray arguments only)
# ----------------------------------------------------------------------------------------------
@ti.kernel
def _bbox_kernel(x: ti.types.ndarray(), out: ti.types.ndarray()):
    """out[0..3] = xmin, xmax, ymin, ymax of the vector ndarray x (n >= 1); out[4] = 1 when a
    coordinate is NaN (the box is then not usable).  A serial loop: cheaper than contended
    atomics for the node counts of a frame, and deterministic."""
    xmin = x[0][0]
    xmax = x[0][0]
    ymin = x[0][1]
    ymax = x[0][1]
    bad = 0
    ti.loop_config(serialize=True)
    for i in range(x.shape[0]):
        px = x[i][0]
        py = x[i][1]
        if px != px or py != py:
            bad = 1
        xmin = ti.min(xmin, px)
        xmax = ti.max(xmax, px)
        ymin = ti.min(ymin, py)
        ymax = ti.max(ymax, py)
    out[0] = xmin
    out[1] = xmax
    out[2] = ymin
    out[3] = ymax
    out[4] = bad


@ti.kernel
def _to_pixels_kernel(x: ti.types.ndarray(), params: ti.types.ndarray(), p: ti.types.ndarray()):
    """World -> (supersampled) pixel coordinates.  params = [x_left, y_top, pixels_per_metre].

    Pixel x grows to the right, pixel y grows downwards (row 0 is the top of the image).
    """
    for i in range(x.shape[0]):
        px = (x[i][0] - params[0]) * params[2]
        py = (params[1] - x[i][1]) * params[2]
        if not px > -_PIX_LIMIT:  # also catches NaN
            px = -_PIX_LIMIT
        if px > _PIX_LIMIT:
            px = _PIX_LIMIT
        if not py > -_PIX_LIMIT:
            py = -_PIX_LIMIT
        if py > _PIX_LIMIT:
            py = _PIX_LIMIT
        p[i] = ti.Vector([ti.cast(px, ti.f32), ti.cast(py, ti.f32)])


@ti.kernel
def _clear_kernel(img: ti.types.ndarray(), bg: _vec3f):
    for i, j in ti.ndrange(img.shape[0], img.shape[1]):
        img[i, j] = bg


@ti.kernel
def _raster_kernel(p: ti.types.ndarray(), tri: ti.types.ndarray(), col: ti.types.ndarray(),
                   img: ti.types.ndarray(), edge_col: _vec3f, half_w: ti.f32, draw_edges: ti.i32):
    """Fill every triangle; one thread per triangle, serial loops over its pixel box."""
    H = img.shape[0]
    W = img.shape[1]
    n = p.shape[0]
    for t in range(tri.shape[0]):
        ia = tri[t][0]
        ib = tri[t][1]
        ic = tri[t][2]
        if 0 <= ia < n and 0 <= ib < n and 0 <= ic < n:
            a = p[ia]
            b = p[ib]
            c = p[ic]
            area2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
            if area2 != 0.0:
                sgn = 1.0 if area2 > 0.0 else -1.0
                # pixel (row r, column q) has its centre at (q + 0.5, r + 0.5)
                xlo = ti.min(a[0], b[0], c[0])
                xhi = ti.max(a[0], b[0], c[0])
                ylo = ti.min(a[1], b[1], c[1])
                yhi = ti.max(a[1], b[1], c[1])
                q0 = ti.cast(ti.max(ti.ceil(xlo - 0.5), 0.0), ti.i32)
                q1 = ti.cast(ti.min(ti.floor(xhi - 0.5), W - 1.0), ti.i32)
                r0 = ti.cast(ti.max(ti.ceil(ylo - 0.5), 0.0), ti.i32)
                r1 = ti.cast(ti.min(ti.floor(yhi - 0.5), H - 1.0), ti.i32)
                # inverse edge lengths: edge function / length = distance to the edge line
                inv_a = 1.0 / ti.max((c - b).norm(), 1e-12)
                inv_b = 1.0 / ti.max((a - c).norm(), 1e-12)
                inv_c = 1.0 / ti.max((b - a).norm(), 1e-12)
                fill = ti.Vector([col[t][0], col[t][1], col[t][2]], dt=ti.f32)
                for r in range(r0, r1 + 1):
                    yc = ti.cast(r, ti.f32) + 0.5
                    for q in range(q0, q1 + 1):
                        xc = ti.cast(q, ti.f32) + 0.5
                        wa = sgn * ((c[0] - b[0]) * (yc - b[1]) - (c[1] - b[1]) * (xc - b[0]))
                        wb = sgn * ((a[0] - c[0]) * (yc - c[1]) - (a[1] - c[1]) * (xc - c[0]))
                        wc = sgn * ((b[0] - a[0]) * (yc - a[1]) - (b[1] - a[1]) * (xc - a[0]))
                        if wa >= 0.0 and wb >= 0.0 and wc >= 0.0:
                            colour = fill
                            if draw_edges != 0:
                                d = ti.min(wa * inv_a, wb * inv_b, wc * inv_c)
                                if d < half_w:
                                    colour = edge_col
                            img[r, q] = colour


@ti.kernel
def _resolve_kernel(img: ti.types.ndarray(), out: ti.types.ndarray(), s: ti.i32):
    """Box-filter the (s*H, s*W) float image down to the (H, W, 3) uint8 image."""
    inv = ti.cast(1.0, ti.f32) / ti.cast(s * s, ti.f32)
    for i, j in ti.ndrange(out.shape[0], out.shape[1]):
        acc = ti.Vector([0.0, 0.0, 0.0], dt=ti.f32)
        for di, dj in ti.ndrange(s, s):
            acc += img[i * s + di, j * s + dj]
        acc *= inv
        for k in ti.static(range(3)):
            v = ti.min(ti.max(acc[k], 0.0), 1.0)
            out[i, j, k] = ti.cast(v * 255.0 + 0.5, ti.u8)


@ti.kernel
def _tri_scalar_kernel(x: ti.types.ndarray(), v: ti.types.ndarray(), x0: ti.types.ndarray(),
                       tri: ti.types.ndarray(), rest_inv: ti.types.ndarray(), tri_mat: ti.types.ndarray(),
                       mat_mu: ti.types.ndarray(), mat_lam: ti.types.ndarray(), mode: ti.i32,
                       out: ti.types.ndarray()):
    """Per-triangle scalar for colouring, ``out[e]``:

    mode 0: speed, mean of |v| over the 3 nodes [m/s];  1: displacement, mean |x - X| [m];
    2: von Mises stress of the in-plane elastic Cauchy stress (plane-stress form
    sqrt(sxx^2 - sxx syy + syy^2 + 3 sxy^2)) [Pa];  3 / 4: max / min principal stress [Pa].
    Stresses follow elastic.cauchy_elastic; an inverted triangle (J <= 0) gives NaN.
    """
    for e in range(tri.shape[0]):
        out[e] = _tri_scalar(x, v, x0, tri, rest_inv, tri_mat, mat_mu, mat_lam, mode, e)


@ti.func
def _tri_scalar(x: ti.template(), v: ti.template(), x0: ti.template(), tri: ti.template(),
                rest_inv: ti.template(), tri_mat: ti.template(), mat_mu: ti.template(),
                mat_lam: ti.template(), mode, e):
    """The colouring scalar of triangle e (see _tri_scalar_kernel)."""
    n = tri[e]
    val = 0.0
    if True:
        if mode == 0:
            val = (v[n[0]].norm() + v[n[1]].norm() + v[n[2]].norm()) / 3.0
        elif mode == 1:
            val = ((x[n[0]] - x0[n[0]]).norm() + (x[n[1]] - x0[n[1]]).norm()
                   + (x[n[2]] - x0[n[2]]).norm()) / 3.0
        else:
            Fx, F, J = deformation(x[n[0]], x[n[1]], x[n[2]], rest_inv[e])
            if J > 0.0:
                m = tri_mat[e]
                T = cauchy_elastic(F, J, mat_mu[m], mat_lam[m])
                sxx, syy, sxy = T[0, 0], T[1, 1], 0.5 * (T[0, 1] + T[1, 0])
                if mode == 2:
                    val = ti.sqrt(ti.max(sxx * sxx - sxx * syy + syy * syy + 3.0 * sxy * sxy, 0.0))
                else:
                    c = 0.5 * (sxx + syy)
                    r = ti.sqrt(0.25 * (sxx - syy) ** 2 + sxy * sxy)
                    val = c + r if mode == 3 else c - r
            else:
                val = ti.math.nan
    return val


@ti.kernel
def _centroid_kernel(x: ti.types.ndarray(), start: ti.i32, end: ti.i32, out: ti.types.ndarray()):
    """out[0], out[1] = mean position [m] of nodes start..end-1; out[2] = count of finite nodes."""
    out[0] = 0.0
    out[1] = 0.0
    out[2] = 0.0
    for i in range(start, end):
        p = x[i]
        if p[0] == p[0] and p[1] == p[1]:
            out[0] += p[0]
            out[1] += p[1]
            out[2] += 1.0
    if out[2] > 0.0:
        out[0] /= out[2]
        out[1] /= out[2]


@ti.func
def _to_u8(c):
    """f32 RGB -> u8 exactly as _resolve_kernel does for supersample 1."""
    acc = ti.Vector([c[0], c[1], c[2]], dt=ti.f32)
    out = ti.Vector([0, 0, 0], dt=ti.u8)
    for k in ti.static(range(3)):
        v = ti.min(ti.max(acc[k], 0.0), 1.0)
        out[k] = ti.cast(v * 255.0 + 0.5, ti.u8)
    return out


@ti.kernel
def _clear_u8_kernel(img: ti.types.ndarray(), bg: _vec3f):
    """Fill an (H, W, 3) u8 image with the background (same conversion as the raster)."""
    for i, j in ti.ndrange(img.shape[0], img.shape[1]):
        c = _to_u8(bg)
        for k in ti.static(range(3)):
            img[i, j, k] = c[k]


@ti.kernel
def _sim_scalar_kernel(x: ti.types.ndarray(), v: ti.types.ndarray(), x0: ti.types.ndarray(),
                       tri: ti.types.ndarray(), rest_inv: ti.types.ndarray(), tri_mat: ti.types.ndarray(),
                       mat_mu: ti.types.ndarray(), mat_lam: ti.types.ndarray(), mode: ti.i32,
                       scal: ti.types.ndarray(), info: ti.types.ndarray()):
    """Per-triangle scalars into scal (see _tri_scalar_kernel) and, in one launch, their finite
    range: info[0] = min, info[1] = max, info[2] = number of finite values."""
    for e in range(tri.shape[0]):
        scal[e] = _tri_scalar(x, v, x0, tri, rest_inv, tri_mat, mat_mu, mat_lam, mode, e)
    lo = 0.0
    hi = 0.0
    cnt = 0
    ti.loop_config(serialize=True)
    for e in range(tri.shape[0]):
        s = scal[e]
        if s == s and ti.abs(s) < ti.math.inf:
            if cnt == 0:
                lo = s
                hi = s
            lo = ti.min(lo, s)
            hi = ti.max(hi, s)
            cnt += 1
    info[0] = lo
    info[1] = hi
    info[2] = cnt


@ti.kernel
def _raster_u8_kernel(x: ti.types.ndarray(), tri: ti.types.ndarray(), col: ti.types.ndarray(),
                      scal: ti.types.ndarray(), use_scal: ti.i32, cpos: ti.types.ndarray(),
                      ctab: ti.types.ndarray(), params: ti.types.ndarray(), img: ti.types.ndarray(),
                      edge_col: _vec3f, half_w: ti.f32, draw_edges: ti.i32):
    """The supersample-1 frame in one launch: world -> pixel transform of each triangle's nodes
    (as _to_pixels_kernel), its colour (col[t], or scal[t] through the colour map table
    cpos/ctab exactly as :func:`colormap` does), and the fill / edge test of _raster_kernel,
    written straight into the (H, W, 3) u8 image (already holding the background).

    params = [x_left, y_top, pixels_per_metre, vmin, vmax] (in the dtype of x).
    """
    H = img.shape[0]
    W = img.shape[1]
    n = x.shape[0]
    K = cpos.shape[0]
    for t in range(tri.shape[0]):
        ia = tri[t][0]
        ib = tri[t][1]
        ic = tri[t][2]
        if 0 <= ia < n and 0 <= ib < n and 0 <= ic < n:
            pa = _pix(x[ia], params)
            pb = _pix(x[ib], params)
            pc = _pix(x[ic], params)
            fill = ti.Vector([0.0, 0.0, 0.0], dt=ti.f32)
            if use_scal != 0:
                fill = _cmap(scal[t], params[3], params[4], cpos, ctab, K)
            else:
                fill = ti.Vector([col[t][0], col[t][1], col[t][2]], dt=ti.f32)
            _fill_tri(pa, pb, pc, _to_u8(fill), _to_u8(edge_col), half_w, draw_edges, img, H, W)


@ti.func
def _pix(xi, params: ti.template()):
    px = (xi[0] - params[0]) * params[2]
    py = (params[1] - xi[1]) * params[2]
    if not px > -_PIX_LIMIT:  # also catches NaN
        px = -_PIX_LIMIT
    if px > _PIX_LIMIT:
        px = _PIX_LIMIT
    if not py > -_PIX_LIMIT:
        py = -_PIX_LIMIT
    if py > _PIX_LIMIT:
        py = _PIX_LIMIT
    return ti.Vector([ti.cast(px, ti.f32), ti.cast(py, ti.f32)])


@ti.func
def _cmap(val, vmin, vmax, cpos: ti.template(), ctab: ti.template(), K):
    """np.interp of the colour map table at clip((val - vmin) / (vmax - vmin), 0, 1) in the
    precision of val (f64 by default, as :func:`colormap`); NaN / inf -> grey."""
    out = ti.Vector([0.5, 0.5, 0.5], dt=ti.f32)   # _NAN_COLOR
    if val == val and ti.abs(val) < ti.math.inf:
        span = vmax - vmin
        t = val * 0.0
        if span > 0:
            t = ti.min(ti.max((val - vmin) / span, 0.0), 1.0)
        res = ti.Vector([val * 0.0, val * 0.0, val * 0.0])
        if t >= cpos[K - 1]:
            res = ti.Vector([ctab[K - 1, 0], ctab[K - 1, 1], ctab[K - 1, 2]])
        else:
            j = 0
            for k in range(1, K - 1):
                if cpos[k] <= t:
                    j = k
            for c in ti.static(range(3)):
                slope = (ctab[j + 1, c] - ctab[j, c]) / (cpos[j + 1] - cpos[j])
                res[c] = slope * (t - cpos[j]) + ctab[j, c]
        out = ti.Vector([ti.cast(res[0], ti.f32), ti.cast(res[1], ti.f32), ti.cast(res[2], ti.f32)])
    return out


@ti.func
def _fill_tri(a, b, c, fill8, edge8, half_w, draw_edges, img: ti.template(), H, W):
    area2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    if area2 != 0.0:
        sgn = 1.0 if area2 > 0.0 else -1.0
        xlo = ti.min(a[0], b[0], c[0])
        xhi = ti.max(a[0], b[0], c[0])
        ylo = ti.min(a[1], b[1], c[1])
        yhi = ti.max(a[1], b[1], c[1])
        q0 = ti.cast(ti.max(ti.ceil(xlo - 0.5), 0.0), ti.i32)
        q1 = ti.cast(ti.min(ti.floor(xhi - 0.5), W - 1.0), ti.i32)
        r0 = ti.cast(ti.max(ti.ceil(ylo - 0.5), 0.0), ti.i32)
        r1 = ti.cast(ti.min(ti.floor(yhi - 0.5), H - 1.0), ti.i32)
        inv_a = 1.0 / ti.max((c - b).norm(), 1e-12)
        inv_b = 1.0 / ti.max((a - c).norm(), 1e-12)
        inv_c = 1.0 / ti.max((b - a).norm(), 1e-12)
        for r in range(r0, r1 + 1):
            yc = ti.cast(r, ti.f32) + 0.5
            for q in range(q0, q1 + 1):
                xc = ti.cast(q, ti.f32) + 0.5
                wa = sgn * ((c[0] - b[0]) * (yc - b[1]) - (c[1] - b[1]) * (xc - b[0]))
                wb = sgn * ((a[0] - c[0]) * (yc - c[1]) - (a[1] - c[1]) * (xc - c[0]))
                wc = sgn * ((b[0] - a[0]) * (yc - a[1]) - (b[1] - a[1]) * (xc - a[0]))
                if wa >= 0.0 and wb >= 0.0 and wc >= 0.0:
                    colour = fill8
                    if draw_edges != 0:
                        d = ti.min(wa * inv_a, wb * inv_b, wc * inv_c)
                        if d < half_w:
                            colour = edge8
                    for k in ti.static(range(3)):
                        img[r, q, k] = colour[k]


# ----------------------------------------------------------------------------------------------
# Argument validation helpers
# ----------------------------------------------------------------------------------------------
def _check_pos_int(name, v, lo=1, hi=None):
    if isinstance(v, bool) or not isinstance(v, numbers.Integral):
        raise ValueError(f"{name} must be an integer, got {v!r}")
    v = int(v)
    if v < lo or (hi is not None and v > hi):
        rng = f">= {lo}" if hi is None else f"in {lo}..{hi}"
        raise ValueError(f"{name} must be {rng}, got {v}")
    return v


def _check_color(name, c):
    try:
        arr = np.asarray(c, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an RGB triple of floats in [0, 1], got {c!r}") from None
    if arr.shape != (3,) or not np.all(np.isfinite(arr)) or np.any(arr < 0.0) or np.any(arr > 1.0):
        raise ValueError(f"{name} must be an RGB triple of floats in [0, 1], got {c!r}")
    return tuple(float(v) for v in arr)


def _check_real(name, v, lo=None, hi=None):
    if isinstance(v, bool) or not isinstance(v, numbers.Real) or not math.isfinite(float(v)):
        raise ValueError(f"{name} must be a finite number, got {v!r}")
    v = float(v)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise ValueError(f"{name} must be in [{lo}, {hi}], got {v}")
    return v


def _check_view(view):
    if isinstance(view, str):
        if view != "fit":
            raise ValueError(f"view must be 'fit' or a tuple (xmin, xmax, ymin, ymax), got {view!r}")
        return "fit"
    try:
        vals = tuple(float(v) for v in view)
    except (TypeError, ValueError):
        raise ValueError(f"view must be 'fit' or a tuple (xmin, xmax, ymin, ymax), got {view!r}") from None
    if len(vals) != 4 or not all(math.isfinite(v) for v in vals):
        raise ValueError(f"view must be 'fit' or 4 finite numbers (xmin, xmax, ymin, ymax), got {view!r}")
    xmin, xmax, ymin, ymax = vals
    if not (xmax > xmin and ymax > ymin):
        raise ValueError(f"view needs xmax > xmin and ymax > ymin, got {view!r}")
    return vals


def _check_color_by(mode):
    if mode not in COLOR_MODES:
        raise ValueError(f"color_by must be one of {list(COLOR_MODES)}, got {mode!r}")
    return mode


def _check_range(vmin, vmax):
    vmin = None if vmin is None else _check_real("vmin", vmin)
    vmax = None if vmax is None else _check_real("vmax", vmax)
    if vmin is not None and vmax is not None and not vmax > vmin:
        raise ValueError(f"vmax must be > vmin, got vmin={vmin}, vmax={vmax}")
    return vmin, vmax


def _fmt(v):
    return f"{v:.3g}"


def _is_ndarray(a):
    return isinstance(a, ti.Ndarray)


# ----------------------------------------------------------------------------------------------
# Renderer
# ----------------------------------------------------------------------------------------------
class RendererImage:
    """Off-screen triangle rasteriser producing ``(height, width, 3)`` uint8 images.

    Parameters
    ----------
    width, height : image size in pixels.
    view : ``"fit"`` (fit the bounding box of the nodes every frame, aspect preserved, with
        ``margin``) or a fixed world box ``(xmin, xmax, ymin, ymax)`` [m], which is expanded in
        one direction (letter-boxed) to match the image aspect ratio.
    background, edge_color : RGB in [0, 1].
    edge_width : edge line width in output pixels (0 disables edges).
    draw_edges : draw triangle edges.
    supersample : 1..4; rasterise at ``supersample`` times the resolution and box-filter down.
    margin : fraction of the larger bounding-box extent added on every side in ``"fit"`` mode.


    Options of :meth:`render_sim` (drawing a Simulation):

    color_by : ``"body"`` (default; a palette colour per body), ``"material"``, or a scalar
        per triangle drawn with ``cmap`` (viridis): ``"speed"`` (mean |v| of the 3 nodes,
        m/s), ``"displacement"`` (mean |x - X| of the 3 nodes, m), ``"von_mises"`` (von Mises
        of the in-plane elastic Cauchy stress, plane-stress form
        sqrt(sxx^2 - sxx syy + syy^2 + 3 sxy^2), Pa), ``"max_principal"`` / ``"min_principal"``
        (principal stresses, Pa).  Scalars are computed by a Taichi kernel from the
        simulation's arrays; inverted triangles are grey.
    vmin, vmax : colour range of the scalar modes, in the quantity's unit.  ``None`` (default)
        = automatic, the finite min / max of the current frame (so colours are not comparable
        between frames); give both for videos so that a colour means the same value in every
        frame.  Values outside are clipped to the ends of the colour map.
    cmap : colour map name (see :data:`COLORMAPS`), default ``"viridis"``.
    colorbar : draw a vertical colour bar at the right of the image (scalar modes only) with
        its max / min labels and a title naming the quantity and its unit.  The view is
        shifted left so that the bar does not hide the mesh.
    stamp : write ``t = 0.0123 s  step 4567`` at the top-left.
    follow : a :class:`~taichi_fdem.scene.Body`; the camera is centred on the body's node
        centroid every frame and shows ``follow_width`` metres horizontally (overrides
        ``view``).
    follow_width : width of the followed view [m] (default: 4 x the body's initial extent).
    text_size : font height of the labels in pixels (default ~ height / 30, at least 10).

    ``render(node_x, tri_nodes, tri_color)`` accepts Taichi vector ndarrays (as held by the
    simulation) or NumPy arrays of shape (n, 2), (m, 3) and (m, 3) (``tri_color`` may also be
    a single RGB triple, ``None`` for grey, or uint8 0..255).  The world y axis points up: row 0
    of the image is the top of the view.
    """

    def __init__(self, width=960, height=540, view="fit", background=(1.0, 1.0, 1.0),
                 edge_color=(0.1, 0.1, 0.1), edge_width=1.0, draw_edges=True, supersample=1,
                 margin=0.05, color_by="body", vmin=None, vmax=None, cmap="viridis",
                 colorbar=True, stamp=True, follow=None, follow_width=None, text_size=None):
        self.width = _check_pos_int("width", width)
        self.height = _check_pos_int("height", height)
        self.supersample = _check_pos_int("supersample", supersample, 1, 4)
        self.background = _check_color("background", background)
        self.edge_color = _check_color("edge_color", edge_color)
        self.edge_width = _check_real("edge_width", edge_width, 0.0, 1.0e4)
        self.draw_edges = bool(draw_edges)
        self.margin = _check_real("margin", margin, 0.0, 10.0)
        self.view = _check_view(view)
        self.last_view = None  # (xmin, xmax, ymin, ymax) of the last rendered, letter-boxed view
        self._img = None      # (s*H, s*W) vec3 f32 working image
        self._out = None      # (H, W, 3) u8 image
        self._img_key = None
        self._cache = {}      # name -> ndarray converted from NumPy input (reused when shape fits)
        self._small = {}      # (purpose, dtype) -> tiny ndarray (bbox, view params)
        self.color_by = _check_color_by(color_by)
        self.vmin, self.vmax = _check_range(vmin, vmax)
        if cmap not in COLORMAPS:
            raise ValueError(f"cmap must be one of {sorted(COLORMAPS)}, got {cmap!r}")
        self.cmap = cmap
        self.colorbar = bool(colorbar)
        self.stamp = bool(stamp)
        self.follow = follow
        self.follow_width = None if follow_width is None else _check_real("follow_width", follow_width, 0.0)
        if self.follow_width is not None and self.follow_width <= 0.0:
            raise ValueError(f"follow_width must be > 0 m, got {follow_width}")
        self.text_size = None if text_size is None else _check_pos_int("text_size", text_size, 4, 1000)
        self._last_scalars = None  # (m,) float64 per-triangle values of the last scalar frame
        self._last_scal_nd = None  # ... or the ndarray holding them (converted on access)
        self._sprites = {}         # (text, anchor, font px) -> label sprite (see _label_sprite)
        self._grad = {}            # (rows, cmap) -> colour-bar gradient (rows, 3) u8
        self._bg_frame = None      # ((H, W, background), (H, W, 3) u8 background image)
        self._np_small = {}        # purpose -> small NumPy array handed to kernels (no copies)
        self.last_range = None    # (vmin, vmax) used by the last scalar frame
        self._sim_ref = None      # weakref to the simulation whose constant arrays are cached
        self._sim_data = {}       # per-simulation constants: initial positions, category colours
        self._font = None

    @property
    def last_scalars(self):
        """(m,) float64 per-triangle values of the last scalar frame (None otherwise)."""
        if self._last_scalars is None and self._last_scal_nd is not None:
            self._last_scalars = self._last_scal_nd.to_numpy().astype(np.float64)
        return self._last_scalars

    @last_scalars.setter
    def last_scalars(self, value):
        self._last_scalars = value
        self._last_scal_nd = None

    # -- configuration ---------------------------------------------------------------------
    def set_view(self, view="fit", margin=None):
        """Switch to ``"fit"`` or to a fixed world box ``(xmin, xmax, ymin, ymax)``."""
        self.view = _check_view(view)
        if margin is not None:
            self.margin = _check_real("margin", margin, 0.0, 10.0)

    def set_range(self, vmin=None, vmax=None):
        """Colour range of the scalar modes (``None`` = automatic per frame)."""
        self.vmin, self.vmax = _check_range(vmin, vmax)

    def resize(self, width, height):
        self.width = _check_pos_int("width", width)
        self.height = _check_pos_int("height", height)

    # -- buffers -----------------------------------------------------------------------------
    def _buffers(self):
        s = self.supersample
        key = (self.width, self.height, s)
        if self._img_key != key:
            self._img = ti.ndarray(dtype=_vec3f, shape=(self.height * s, self.width * s))
            self._out = ti.ndarray(dtype=ti.u8, shape=(self.height, self.width, 3))
            self._img_key = key
        return self._img, self._out

    def _small_nd(self, purpose, dtype, size):
        key = (purpose, str(dtype))
        arr = self._small.get(key)
        if arr is None:
            arr = ti.ndarray(dtype=dtype, shape=(size,))
            self._small[key] = arr
        return arr

    def _from_numpy(self, name, a, ncomp, np_dtype, ti_dtype):
        arr = np.asarray(a)
        if arr.ndim == 1 and arr.size == 0:
            arr = arr.reshape(0, ncomp)
        if arr.ndim != 2 or arr.shape[1] != ncomp:
            raise ValueError(f"{name} must have shape (k, {ncomp}), got {arr.shape}")
        arr = np.ascontiguousarray(arr, dtype=np_dtype)
        k = arr.shape[0]
        if k == 0:
            return None  # Taichi has no empty ndarrays: callers treat None as "nothing"
        nd = self._cache.get(name)
        if nd is None or nd.shape != (k,) or nd.dtype != ti_dtype:
            nd = ti.ndarray(dtype=ti.types.vector(ncomp, ti_dtype), shape=(k,))
            self._cache[name] = nd
        nd.from_numpy(arr)
        return nd

    def _prepare(self, node_x, tri_nodes, tri_color):
        real_ti, real_np = backend.real_ti(), backend.real_np()
        # nodes
        if _is_ndarray(node_x) and getattr(node_x, "n", None) == 2 and len(node_x.shape) == 1:
            x_nd = node_x
        else:
            x_nd = self._from_numpy("node_x", _to_np(node_x), 2, real_np, real_ti)
        # triangles
        if _is_ndarray(tri_nodes) and getattr(tri_nodes, "n", None) == 3 and len(tri_nodes.shape) == 1:
            t_nd = tri_nodes
        else:
            t_np = np.asarray(_to_np(tri_nodes))
            if t_np.size and not np.issubdtype(t_np.dtype, np.integer):
                raise ValueError(f"tri_nodes must hold integers, got dtype {t_np.dtype}")
            t_nd = self._from_numpy("tri_nodes", t_np, 3, np.int32, ti.i32)
        m = 0 if t_nd is None else t_nd.shape[0]
        if m == 0:
            return x_nd, None, None
        # colours
        if _is_ndarray(tri_color) and getattr(tri_color, "n", None) == 3 and len(tri_color.shape) == 1:
            c_nd = tri_color
        else:
            if tri_color is None:
                c_np = np.full((m, 3), 0.7, np.float32)
            else:
                c_np = np.asarray(_to_np(tri_color))
                if c_np.dtype == np.uint8:
                    c_np = c_np.astype(np.float32) / 255.0
                if c_np.shape == (3,):
                    c_np = np.broadcast_to(c_np.astype(np.float32), (m, 3))
            c_nd = self._from_numpy("tri_color", c_np, 3, np.float32, ti.f32)
        if c_nd is None or c_nd.shape[0] != m:
            raise ValueError(f"tri_color has {0 if c_nd is None else c_nd.shape[0]} entries but there are {m} triangles")
        return x_nd, t_nd, c_nd

    # -- view ------------------------------------------------------------------------------
    def _world_box(self, x_nd):
        """World box to show (before letter-boxing)."""
        if self.view != "fit":
            return self.view
        if x_nd is None:
            return self.last_view if self.last_view is not None else (-1.0, 1.0, -1.0, 1.0)
        bb = self._np_small.get("bbox")
        if bb is None:
            bb = self._np_small["bbox"] = np.zeros(5, dtype=np.float64)
        _bbox_kernel(x_nd, bb)
        xmin, xmax, ymin, ymax = (float(v) for v in bb[:4])
        if bb[4] != 0.0 or not all(math.isfinite(v) for v in (xmin, xmax, ymin, ymax)):
            return self.last_view if self.last_view is not None else (-1.0, 1.0, -1.0, 1.0)
        ext = max(xmax - xmin, ymax - ymin)
        if ext <= 0.0:
            ext = max(abs(xmin), abs(ymin), 1.0) * 1e-3  # a single point: show a small box
        pad = self.margin * ext
        cx, cy = 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)
        hw = 0.5 * (xmax - xmin) + pad
        hh = 0.5 * (ymax - ymin) + pad
        if hw <= 0.0:  # nodes on a vertical line and no margin
            hw = 0.5 * ext
        if hh <= 0.0:
            hh = 0.5 * ext
        return (cx - hw, cx + hw, cy - hh, cy + hh)

    def _letterbox(self, box, reserve_right=0):
        """Fit ``box`` into the image minus ``reserve_right`` pixel columns at the right (kept
        for the colour bar); returns the full-image world box and the pixels per metre."""
        xmin, xmax, ymin, ymax = box
        bw, bh = xmax - xmin, ymax - ymin
        w_eff = max(1, self.width - int(reserve_right))
        scale = min(w_eff / bw, self.height / bh)  # output pixels per metre
        cx, cy = 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)
        left = cx - 0.5 * w_eff / scale
        hh = 0.5 * self.height / scale
        return (left, left + self.width / scale, cy - hh, cy + hh), scale

    def world_to_pixel(self, xy):
        """Map world points (k, 2) to continuous output-pixel coordinates (col, row) using the
        view of the last :meth:`render` call."""
        if self.last_view is None:
            raise RuntimeError("world_to_pixel: nothing rendered yet")
        xmin, xmax, ymin, ymax = self.last_view
        scale = self.width / (xmax - xmin)
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        return np.stack([(xy[:, 0] - xmin) * scale, (ymax - xy[:, 1]) * scale], axis=1)

    # -- drawing ---------------------------------------------------------------------------
    def render(self, node_x, tri_nodes, tri_color=None) -> np.ndarray:
        """Rasterise the mesh and return a new ``(height, width, 3)`` uint8 array."""
        backend.ensure_init()
        x_nd, t_nd, c_nd = self._prepare(node_x, tri_nodes, tri_color)
        return self._draw(x_nd, t_nd, c_nd, self._world_box(x_nd))

    def _background(self):
        key = (self.height, self.width, self.background)
        if self._bg_frame is None or self._bg_frame[0] != key:
            bg = np.empty((self.height, self.width, 3), dtype=np.uint8)
            _clear_u8_kernel(bg, ti.Vector(self.background, dt=ti.f32))
            self._bg_frame = (key, bg)
        return self._bg_frame[1]

    def _cmap_nd(self, name):
        """The colour map table (positions, RGB) as ndarrays of the real dtype, uploaded once."""
        real_ti, real_np = backend.real_ti(), backend.real_np()
        key = ("cmap", name, str(real_ti))
        tab = self._small.get(key)
        if tab is None:
            pos, rgb = COLORMAPS[name]
            cpos = ti.ndarray(dtype=real_ti, shape=(len(pos),))
            cpos.from_numpy(np.ascontiguousarray(pos, dtype=real_np))
            ctab = ti.ndarray(dtype=real_ti, shape=(len(pos), 3))
            ctab.from_numpy(np.ascontiguousarray(rgb, dtype=real_np))
            tab = self._small[key] = (cpos, ctab)
        return tab

    def _draw(self, x_nd, t_nd, c_nd, box, reserve_right=0, scal=None, rng=None) -> np.ndarray:
        """Rasterise; colours are c_nd, or (supersample 1 only) the scalars scal mapped through
        the colour map over rng = (vmin, vmax) inside the raster kernel."""
        s = self.supersample
        view, scale = self._letterbox(box, reserve_right)
        self.last_view = view
        if s == 1:  # one launch straight into a u8 NumPy image: no float image, no copies
            img = self._background().copy()
            if x_nd is not None and t_nd is not None:
                vmin, vmax = rng if rng is not None else (0.0, 1.0)
                params = np.array([view[0], view[3], scale, vmin, vmax], dtype=_np_dtype(x_nd.dtype))
                cpos, ctab = self._cmap_nd(self.cmap)
                use_scal = int(scal is not None and rng is not None)
                if scal is None:
                    scal = self._small_nd("dummy_scal", backend.real_ti(), 1)
                if c_nd is None:
                    c_nd = self._small_nd("dummy_col", ti.types.vector(3, ti.f32), 1)
                draw = self.draw_edges and self.edge_width > 0.0
                _raster_u8_kernel(x_nd, t_nd, c_nd, scal, use_scal,
                                  cpos, ctab, params, img, ti.Vector(self.edge_color, dt=ti.f32),
                                  float(0.5 * self.edge_width), int(draw))
            return img
        img, out = self._buffers()

        _clear_kernel(img, ti.Vector(self.background, dt=ti.f32))
        if x_nd is not None and t_nd is not None:
            n = x_nd.shape[0]
            params = self._small_nd("params", x_nd.dtype, 3)
            params.from_numpy(np.array([view[0], view[3], scale * s], dtype=_np_dtype(x_nd.dtype)))
            pkey = "pixels"
            p_nd = self._cache.get(pkey)
            if p_nd is None or p_nd.shape != (n,):
                p_nd = ti.ndarray(dtype=ti.types.vector(2, ti.f32), shape=(n,))
                self._cache[pkey] = p_nd
            _to_pixels_kernel(x_nd, params, p_nd)
            draw = self.draw_edges and self.edge_width > 0.0
            _raster_kernel(p_nd, t_nd, c_nd, img, ti.Vector(self.edge_color, dt=ti.f32),
                           float(0.5 * self.edge_width * s), int(draw))
        _resolve_kernel(img, out, s)
        return out.to_numpy()

    __call__ = render

    # -- simulations -----------------------------------------------------------------------
    def _sim_consts(self, sim):
        """Constant per-simulation data (converted once per simulation, not per frame)."""
        ref = self._sim_ref() if self._sim_ref is not None else None
        if ref is not sim:
            self._sim_ref = weakref.ref(sim)
            self._sim_data = {}
        return self._sim_data

    def tri_scalars(self, sim, color_by=None) -> np.ndarray:
        """The per-triangle scalar of a scalar colour mode, (m,) float64 in the mode's unit
        (m/s, m or Pa; NaN for inverted triangles), computed by a Taichi kernel."""
        mode = _check_color_by(self.color_by if color_by is None else color_by)
        kid = COLOR_MODES[mode][0]
        if kid is None:
            raise ValueError(f"tri_scalars: color_by={mode!r} is not a scalar mode")
        if kid < 0:      # "damage"
            return np.asarray(sim.tri_damage(), dtype=np.float64)
        backend.ensure_init()
        consts = self._sim_consts(sim)
        x0 = consts.get("x0")
        if x0 is None:
            x0 = ti.Vector.ndarray(2, sim.node_x.dtype, shape=(sim.node_count,))
            x0.from_numpy(np.ascontiguousarray(sim._X, dtype=_np_dtype(sim.node_x.dtype)))
            consts["x0"] = x0
        out = consts.get("scalars")
        if out is None:
            out = ti.ndarray(dtype=sim.node_x.dtype, shape=(sim.tri_count,))
            consts["scalars"] = out
        _tri_scalar_kernel(sim.node_x, sim.node_v, x0, sim.tri_nodes, sim.tri_rest_inv, sim.tri_mat,
                           sim.mat_mu, sim.mat_lam, int(kid), out)
        return out.to_numpy().astype(np.float64)

    def _frame_scalars(self, sim, kid):
        """Per-triangle scalars of mode id kid into a per-simulation ndarray (kept on the
        device) and their finite [min, max, count] in a small NumPy array."""
        consts = self._sim_consts(sim)
        x0 = consts.get("x0")
        if x0 is None:
            x0 = ti.Vector.ndarray(2, sim.node_x.dtype, shape=(sim.node_count,))
            x0.from_numpy(np.ascontiguousarray(sim._X, dtype=_np_dtype(sim.node_x.dtype)))
            consts["x0"] = x0
        scal = consts.get("frame_scalars")
        if scal is None:
            scal = consts["frame_scalars"] = ti.ndarray(dtype=sim.node_x.dtype, shape=(sim.tri_count,))
        info = self._np_small.get("range")
        if info is None:
            info = self._np_small["range"] = np.zeros(3, dtype=np.float64)
        if kid < 0:      # "damage": per-triangle joint damage from the simulation, fixed range [0, 1]
            scal.from_numpy(np.ascontiguousarray(sim.tri_damage(), dtype=_np_dtype(sim.node_x.dtype)))
            info[:] = (0.0, 1.0, sim.tri_count)
            return scal, info
        _sim_scalar_kernel(sim.node_x, sim.node_v, x0, sim.tri_nodes, sim.tri_rest_inv, sim.tri_mat,
                           sim.mat_mu, sim.mat_lam, int(kid), scal, info)
        return scal, info

    def _follow_box(self, sim):
        body = self.follow
        if isinstance(body, numbers.Integral) and not isinstance(body, bool):
            body = sim.bodies[int(body)]
        if not any(b is body for b in sim.bodies):
            raise ValueError(f"render_sim: follow={self.follow!r} is not a body of this simulation")
        consts = self._sim_consts(sim)
        width = self.follow_width
        if width is None:
            pts = body.mesh.points
            width = 4.0 * max(float(np.ptp(pts[:, 0])), float(np.ptp(pts[:, 1])), 1e-12)
        c = self._small_nd("centroid", sim.node_x.dtype, 3)
        _centroid_kernel(sim.node_x, body.nodes.start, body.nodes.stop, c)
        cx, cy, cnt = (float(v) for v in c.to_numpy())
        if cnt <= 0 or not (math.isfinite(cx) and math.isfinite(cy)):
            if self.last_view is not None:
                return (self.last_view[0], self.last_view[1], self.last_view[2], self.last_view[3])
            cx, cy = (float(v) for v in body.mesh.centroid)
        consts["follow_centre"] = (cx, cy)
        hh = 0.5 * width * self.height / self.width
        return (cx - 0.5 * width, cx + 0.5 * width, cy - hh, cy + hh)

    def render_sim(self, sim, color_by=None) -> np.ndarray:
        """Draw a :class:`~taichi_fdem.simulation.Simulation`; returns ``(height, width, 3)`` uint8.

        ``color_by`` overrides the renderer's mode for this frame (see the class docstring
        for the modes, the colour range, colour bar, stamp and camera options).
        """
        backend.ensure_init()
        mode = _check_color_by(self.color_by if color_by is None else color_by)
        consts = self._sim_consts(sim)
        kid, title = COLOR_MODES[mode]
        bar = None
        if kid is None:
            key = "colors_" + mode
            colors = consts.get(key)
            if colors is None:
                ids = sim._tri_body_np if mode == "body" else sim._tri_mat_np
                colors = ti.Vector.ndarray(3, ti.f32, shape=(sim.tri_count,))
                colors.from_numpy(np.ascontiguousarray(body_colors(ids), dtype=np.float32))
                consts[key] = colors
            c_nd = colors
            self.last_scalars = None
            self.last_range = None
        else:
            # scalars and their finite range in one launch; nothing per-triangle leaves the device
            scal, info = self._frame_scalars(sim, kid)
            finite_any = info[2] > 0
            vmin, vmax = self.vmin, self.vmax
            if vmin is None:
                vmin = float(info[0]) if finite_any else 0.0
                if vmax is not None and vmin > vmax:
                    vmin = vmax
            if vmax is None:
                vmax = float(info[1]) if finite_any else 1.0
                if vmax < vmin:
                    vmax = vmin
            if self.supersample == 1:
                c_nd = None     # coloured inside the raster kernel
            else:
                cols = colormap(scal.to_numpy().astype(np.float64), vmin, vmax, self.cmap)
                c_nd = consts.get("scalar_colors")
                if c_nd is None:
                    c_nd = ti.Vector.ndarray(3, ti.f32, shape=(sim.tri_count,))
                    consts["scalar_colors"] = c_nd
                c_nd.from_numpy(cols)
            self._last_scalars = None
            self._last_scal_nd = scal
            self.last_range = (vmin, vmax)
            if self.colorbar:
                bar = (vmin, vmax, title)
        if self.follow is not None:
            box = self._follow_box(sim)
        else:
            box = self._world_box(sim.node_x)
        layout = self._bar_layout() if bar is not None else None
        img = self._draw(sim.node_x, sim.tri_nodes, c_nd, box, layout["reserve"] if layout else 0,
                         scal=None if kid is None else scal, rng=None if kid is None else (vmin, vmax))
        stamp = f"t = {sim.time:.4g} s  step {sim.step_count}" if self.stamp else None
        if bar is not None or stamp is not None:
            img = self._overlay(img, bar, layout, stamp)
        return img

    # -- overlays --------------------------------------------------------------------------
    def _text_px(self):
        return self.text_size if self.text_size is not None else max(10, self.height // 30)

    def _get_font(self):
        size = self._text_px()
        if self._font is None or self._font[0] != size:
            from PIL import ImageFont

            try:
                font = ImageFont.load_default(size=size)
            except TypeError:  # Pillow < 10.1: fixed-size bitmap font
                font = ImageFont.load_default()
            self._font = (size, font)
        return self._font[1]

    def _bar_layout(self):
        """Pixel geometry of the colour bar: strip columns [x0, x1), rows [y0, y1) and the width
        reserved at the right of the image for strip and labels."""
        W, H = self.width, self.height
        ts = self._text_px()
        bw = max(6, min(W // 40, 30))
        x1 = W - max(4, ts // 2)
        x0 = x1 - bw
        y0 = min(H - 2, int(0.5 * ts) * 2 + ts + 4)   # room for the title above
        y1 = max(y0 + 2, H - ts - 4)
        label_w = int(5.5 * ts)                       # about "-1.23e+05"
        return {"x0": x0, "x1": x1, "y0": y0, "y1": y1, "reserve": min(W // 2, W - x0 + label_w + 6)}

    def _label_sprite(self, text, anchor):
        """A label (text on a translucent white box) rendered once per distinct text with PIL:
        ``(dx, dy, RGBA image)``, the box's top-left relative to the anchor point.  Glyph
        rasterisation is invariant under integer shifts, so pasting the sprite gives the same
        pixels as drawing the label in place."""
        size = self._text_px()
        key = (text, anchor, size)
        sp = self._sprites.get(key)
        if sp is None:
            from PIL import Image, ImageDraw

            font = self._get_font()
            probe = ImageDraw.Draw(Image.new("RGBA", (1, 1)))
            l, t, r, b = probe.textbbox((0, 0), text, font=font, anchor=anchor)
            dx, dy = int(l) - 2, int(t) - 2          # the box (l-2, t-2, r+2, b+2), inclusive
            w, h = int(r) - int(l) + 5, int(b) - int(t) + 5
            layer = Image.new("RGBA", (w, h), (0, 0, 0, 0))
            draw = ImageDraw.Draw(layer)
            draw.rectangle((0, 0, w - 1, h - 1), fill=(255, 255, 255, 170))
            draw.text((-dx, -dy), text, font=font, fill=(0, 0, 0, 255), anchor=anchor)
            if len(self._sprites) >= 512:            # auto-range labels change every frame
                self._sprites.clear()
            sp = self._sprites[key] = (dx, dy, layer)
        return sp

    def _gradient(self, rows):
        key = (rows, self.cmap)
        g = self._grad.get(key)
        if g is None:
            grad = colormap(np.linspace(1.0, 0.0, rows), 0.0, 1.0, self.cmap)   # top row = vmax
            g = self._grad[key] = np.clip(grad * 255.0 + 0.5, 0, 255).astype(np.uint8)
        return g

    def _overlay(self, img, bar, layout, stamp):
        """Colour bar, its labels and the stamp, drawn on small crops only (labels are cached
        sprites composited with PIL on their own box); the result equals drawing everything on
        one full-frame RGBA layer and compositing it."""
        from PIL import Image

        H, W = img.shape[:2]
        if not img.flags.writeable:
            img = np.array(img, copy=True)
        labels = []
        if bar is not None:
            vmin, vmax, title = bar
            x0, x1, y0, y1 = layout["x0"], layout["x1"], layout["y0"], layout["y1"]
            grad8 = self._gradient(y1 - y0)
            img[y0:y1, x0:x1] = grad8[:, None, :]
            labels += [((x0 - 4, y0), _fmt(vmax), "ra"), ((x0 - 4, y1), _fmt(vmin), "rd"),
                       ((x1, max(0, y0 - 6)), title, "rd")]
        if stamp is not None:
            labels.append(((4, 4), stamp, "la"))
        # every label box composited over the frame as it was before any label (a later label
        # replaces an earlier one where boxes overlap, as on a shared layer)
        jobs = []
        for (x, y), text, anchor in labels:
            dx, dy, sprite = self._label_sprite(text, anchor)
            bx0, by0 = x + dx, y + dy
            cx0, cy0 = max(bx0, 0), max(by0, 0)
            cx1, cy1 = min(bx0 + sprite.width, W), min(by0 + sprite.height, H)
            if cx1 > cx0 and cy1 > cy0:
                jobs.append((cx0, cy0, cx1, cy1, bx0, by0, sprite, img[cy0:cy1, cx0:cx1].copy()))
        for cx0, cy0, cx1, cy1, bx0, by0, sprite, base in jobs:
            if (cx0, cy0, cx1 - bx0, cy1 - by0) != (bx0, by0, sprite.width, sprite.height):
                sprite = sprite.crop((cx0 - bx0, cy0 - by0, cx1 - bx0, cy1 - by0))
            comp = Image.alpha_composite(Image.fromarray(base).convert("RGBA"), sprite)
            img[cy0:cy1, cx0:cx1] = np.asarray(comp.convert("RGB"))
        if bar is not None:
            # 1-px black frame (x0 - 1, y0 - 1) .. (x1, y1) inclusive, under the label boxes
            fx0, fy0, fx1, fy1 = x0 - 1, y0 - 1, x1, y1
            sx0, sy0, sx1, sy1 = max(fx0, 0), max(fy0, 0), min(fx1, W - 1), min(fy1, H - 1)
            if sx1 >= sx0 and sy1 >= sy0:
                rr = np.arange(sy0, sy1 + 1)[:, None]
                cc = np.arange(sx0, sx1 + 1)[None, :]
                mask = (rr == fy0) | (rr == fy1) | (cc == fx0) | (cc == fx1)
                for cx0, cy0, cx1, cy1, *_ in jobs:
                    mask &= ~((rr >= cy0) & (rr < cy1) & (cc >= cx0) & (cc < cx1))
                img[sy0:sy1 + 1, sx0:sx1 + 1][mask] = 0
            img[y0:y1, x0:x1] = grad8[:, None, :]   # keep the gradient exact
        return img


def _to_np(a):
    if _is_ndarray(a):
        return a.to_numpy()
    return a


def _np_dtype(ti_dtype):
    if ti_dtype == ti.f64:
        return np.float64
    if ti_dtype == ti.f32:
        return np.float32
    raise ValueError(f"node positions must be f32 or f64, got {ti_dtype}")


# ----------------------------------------------------------------------------------------------
# Colour maps
# ----------------------------------------------------------------------------------------------
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


# ----------------------------------------------------------------------------------------------
# Images and video
# ----------------------------------------------------------------------------------------------
def _as_uint8_image(image) -> np.ndarray:
    img = np.asarray(_to_np(image))
    if img.ndim == 2:
        img = np.repeat(img[:, :, None], 3, axis=2)
    if img.ndim != 3 or img.shape[2] not in (3, 4) or img.shape[0] < 1 or img.shape[1] < 1:
        raise ValueError(f"image must have shape (H, W, 3), got {img.shape}")
    if img.shape[2] == 4:
        img = img[:, :, :3]
    if img.dtype != np.uint8:
        if np.issubdtype(img.dtype, np.floating):
            img = np.clip(np.nan_to_num(img), 0.0, 1.0) * 255.0 + 0.5
        img = np.clip(img, 0, 255).astype(np.uint8)
    return np.ascontiguousarray(img)


def save_png(path, image) -> None:
    """Write an (H, W, 3) uint8 (or float in [0, 1]) image as PNG, creating parent dirs."""
    from PIL import Image

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(_as_uint8_image(image)).save(path, format="PNG", compress_level=3)


def annotate(image, text, xy=(4, 4), color=(0, 0, 0), size=None, box=True) -> np.ndarray:
    """Return a copy of ``image`` with ``text`` stamped at pixel ``xy`` (top-left by default).

    ``color`` is an RGB triple in 0..255; ``size`` the font height in pixels (default: about
    1/30 of the image height, at least 10); ``box`` draws a translucent white box behind the
    text for legibility.
    """
    from PIL import Image, ImageDraw, ImageFont

    img = _as_uint8_image(image)
    size = int(size) if size is not None else max(10, img.shape[0] // 30)
    try:
        font = ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: fixed-size bitmap font
        font = ImageFont.load_default()
    # draw on a layer covering only the label (shifted by whole pixels: same glyphs) and
    # composite that crop; the rest of the image is untouched
    text = str(text)
    xy = tuple(xy)
    H, W = img.shape[:2]
    l, t, r, b = ImageDraw.Draw(Image.new("RGBA", (1, 1))).textbbox(xy, text, font=font)
    cx0, cy0 = max(int(math.floor(l)) - 3, 0), max(int(math.floor(t)) - 3, 0)
    cx1, cy1 = min(int(math.ceil(r)) + 4, W), min(int(math.ceil(b)) + 4, H)
    if not all(float(v).is_integer() for v in xy):   # fractional positions: no shifting
        cx0, cy0, cx1, cy1 = 0, 0, W, H
    out = np.array(img, copy=True)
    if cx1 <= cx0 or cy1 <= cy0:
        return out
    pil = Image.fromarray(img[cy0:cy1, cx0:cx1]).convert("RGBA")
    layer = Image.new("RGBA", pil.size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(layer)
    sxy = (xy[0] - cx0, xy[1] - cy0)
    if box:
        draw.rectangle((l - 2 - cx0, t - 2 - cy0, r + 2 - cx0, b + 2 - cy0), fill=(255, 255, 255, 170))
    draw.text(sxy, text, font=font, fill=tuple(int(c) for c in color) + (255,))
    out[cy0:cy1, cx0:cx1] = np.asarray(Image.alpha_composite(pil, layer).convert("RGB"))
    return out


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

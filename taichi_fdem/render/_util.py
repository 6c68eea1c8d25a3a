"""Argument checks and array conversions shared by the render modules (private).

The ``_check_*`` functions turn a user value into a validated Python value or raise a
ValueError naming the argument; ``_to_np`` / ``_is_ndarray`` / ``_np_dtype`` bridge Taichi
ndarrays and NumPy; ``_as_uint8_image`` normalises an image for the writers.
"""
import math
import numbers

import numpy as np
import taichi as ti


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


def _check_range(vmin, vmax):
    vmin = None if vmin is None else _check_real("vmin", vmin)
    vmax = None if vmax is None else _check_real("vmax", vmax)
    if vmin is not None and vmax is not None and not vmax > vmin:
        raise ValueError(f"vmax must be > vmin, got vmin={vmin}, vmax={vmax}")
    return vmin, vmax


def _is_ndarray(a):
    return isinstance(a, ti.Ndarray)


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

"""Functions shared by the demos (command line, timing, per-body kinematics)."""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def parse_args(name: str, description: str, argv=None) -> argparse.Namespace:
    """``--short`` (quick version used by the tests) and ``--out PATH`` (default out/NAME.mp4)."""
    ap = argparse.ArgumentParser(prog=f"demos/{name}.py", description=description)
    ap.add_argument("--short", action="store_true", help="a short run with a small video (used by the tests)")
    ap.add_argument("--out", default=None, help=f"video path (.mp4, .gif or a directory); default out/{name}.mp4")
    ap.add_argument("--precision", choices=("f64", "f32"), default="f64")
    args = ap.parse_args(argv)
    if args.out is None:
        args.out = os.path.join(ROOT, "out", f"{name}.mp4" if not args.short else f"{name}_short.mp4")
    return args


def init(precision: str = "f64") -> None:
    """Initialise taichi_fdem once (a second init would invalidate simulations of a caller)."""
    from taichi_fdem import backend
    if not backend.is_initialised():
        backend.init(arch="cpu", precision=precision)


class Timer:
    def __init__(self):
        self.t0 = time.perf_counter()

    def __call__(self) -> float:
        return time.perf_counter() - self.t0


def video_frames(path) -> int:
    """Number of frames in a written video (mp4 / gif) or PNG directory."""
    if os.path.isdir(path):
        return len([f for f in os.listdir(path) if f.endswith(".png")])
    import imageio.v3 as iio
    return sum(1 for _ in iio.imiter(path))


def fmt_vec(v) -> str:
    v = np.asarray(v, dtype=float)
    return "(" + ", ".join(f"{c:+.4g}" for c in v) + ")"


def hatch_bedding(image, dip, spacing, view, keep=None, inside=None):
    """``image`` (H, W, 3 uint8, the world box ``view`` = (xmin, xmax, ymin, ymax) [m] drawn on it)
    with bedding planes of ``dip`` [° from the x axis], ``spacing`` [m] apart (one through the
    origin), blended in white, one pixel wide.  ``keep``: an RGB colour in [0, 1] left untouched
    (the drawn cracks); ``inside(x, y)``: where to draw (NumPy arrays of world coordinates [m])."""
    import math
    H, W = image.shape[:2]
    x0, x1, y0, y1 = view
    px = (x1 - x0) / W
    X, Y = np.meshgrid(x0 + (np.arange(W) + 0.5) * px, y1 - (np.arange(H) + 0.5) * (y1 - y0) / H)
    d = -X * math.sin(math.radians(dip)) + Y * math.cos(math.radians(dip))
    near = np.abs(d - spacing * np.round(d / spacing)) < 0.6 * px
    if inside is not None:
        near &= inside(X, Y)
    if keep is not None:
        near &= np.any(image != np.round(255.0 * np.asarray(keep)).astype(np.uint8), axis=-1)
    out = image.astype(np.float32)
    out[near] = 0.45 * out[near] + 0.55 * 255.0
    return out.astype(np.uint8)


def sidewall_closure(sim, rock, radius: float) -> float:
    """Horizontal closure [m] of the two sidewall points (x = ±radius, y = 0) of a circular tunnel
    centred on the origin: the mean x displacement of the three rock nodes nearest each point (on
    the rock side of the wall: excavated nodes are held still once orphaned), left minus right."""
    X = sim.model.node_rest[rock.nodes]
    u = sim.node_displacements(rock)
    outside = np.hypot(X[:, 0], X[:, 1]) >= radius
    d = (np.where(outside, np.hypot(X[:, 0] - radius, X[:, 1]), np.inf),
         np.where(outside, np.hypot(X[:, 0] + radius, X[:, 1]), np.inf))
    return float(u[np.argsort(d[1])[:3], 0].mean() - u[np.argsort(d[0])[:3], 0].mean())

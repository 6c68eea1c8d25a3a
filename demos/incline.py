"""A block slides down a 30 degree incline with Coulomb friction mu = 0.3.

    python demos/incline.py            # writes out/incline.mp4
    python demos/incline.py --short    # a quick version (used by tests/test_demos_gallery.py)
    python demos/incline.py --still docs/gallery/incline.png   # also save a mid-run frame

The incline is a fixed rectangle rotated by -theta; the deformable block starts at rest,
rotated likewise and exactly touching it.  A rigid block would slide with the constant
acceleration a = g (sin theta - mu cos theta) along the slope, s(t) = a t^2 / 2.  Every frame
draws the analytic position as a red cross next to the simulated block's centroid.  ``check``
verifies that the simulated distance along the slope at the end is within 2 % of s(t).
"""
from __future__ import annotations

import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "incline"
G = 9.81
THETA = math.radians(30.0)
MU = 0.3
BW, BH = 0.2, 0.1        # block [m]
L, T = 2.0, 0.06         # incline length and thickness [m]
MATERIAL = dict(density=1000.0, young=2.0e7, poisson=0.3, friction=MU, damping=0.05, contact_damping=0.3)
PENALTY = 5.0


def accel() -> float:
    return G * (math.sin(THETA) - MU * math.cos(THETA))


def build(short: bool):
    import taichi_fdem as fdem
    mat = fdem.Material(**MATERIAL, penalty=PENALTY * MATERIAL["young"], name="block")
    scene = fdem.Scene(gravity=(0.0, -G))
    down = np.array([math.cos(THETA), -math.sin(THETA)])     # unit vector down the slope
    normal = np.array([math.sin(THETA), math.cos(THETA)])    # outward normal of the slope's top
    slope = scene.add_body(fdem.mesh.rectangle(L, T, T), mat, position=(0.0, 0.0), rotation=-THETA,
                           fixed=True, name="incline")
    start = -0.5 * L + 0.6 * BW                               # along the slope from its centre
    pos = start * down + (0.5 * T + 0.5 * BH) * normal
    block = scene.add_body(fdem.mesh.rectangle(BW, BH, 0.025 if short else 0.0125), mat, position=pos, rotation=-THETA, name="block")
    sim = scene.build()
    duration = 0.25 if short else 1.0
    return sim, slope, block, down, duration


def centroid(sim, block) -> np.ndarray:
    return sim.body_motion(block).center


def check(sim, block, c0, down) -> dict:
    c = centroid(sim, block)
    s_sim = float((c - c0) @ down)
    s_ana = 0.5 * accel() * sim.time ** 2
    off = float(np.linalg.norm((c - c0) - s_sim * down))       # motion off the slope direction
    err = abs(s_sim - s_ana) / s_ana
    out = {"time": sim.time, "steps": sim.step_count, "distance_sim_m": s_sim, "distance_analytic_m": s_ana,
           "rel_error": err, "off_slope_m": off, "acceleration_analytic": accel()}
    assert err < 0.02, f"slid {s_sim:.4g} m, analytic {s_ana:.4g} m ({100 * err:.2f} % off)"
    return out


def draw_cross(img, px, py, half=6, color=(220, 0, 0), width=2):
    h, w = img.shape[:2]
    for d in range(-half, half + 1):
        for k in range(-(width // 2), width - width // 2):
            for x, y in ((px + d, py + d + k), (px + d, py - d + k)):
                if 0 <= x < w and 0 <= y < h:
                    img[y, x] = color


def main(argv=None) -> dict:
    import argparse
    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("--still", default=None)
    extra, rest = ap.parse_known_args(argv if argv is not None else sys.argv[1:])
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], rest)
    clock = _common.Timer()
    _common.init(args.precision)
    from taichi_fdem.render import RendererImage, VideoWriter, annotate, save_png

    sim, slope, block, down, duration = build(args.short)
    c0 = centroid(sim, block)
    info = sim.info()
    print(f"{NAME}: {info['triangles']} triangles, dt = {info['dt']:.3g} s, {duration:g} s simulated "
          f"({int(round(duration / sim.dt)):,} steps), strategy {info['strategy']}", flush=True)
    frames = 10 if args.short else 75            # 5 s of video at 15 fps (rendering < 10 % of the run)
    size = (320, 180) if args.short else (960, 540)
    renderer = RendererImage(*size, view=(-1.05, 1.05, -0.65, 0.65), color_by="body",
                             stamp=not args.short, draw_edges=True, edge_width=0.5)
    a = accel()
    total = int(round(duration / sim.dt))
    per_frame = max(1, int(round(duration / frames / sim.dt)))
    still_at = 0.5 * duration
    with VideoWriter(args.out, fps=15) as writer:
        while True:
            img = renderer.render_sim(sim).copy()
            s = 0.5 * a * sim.time ** 2
            px, py = (int(round(v)) for v in np.asarray(renderer.world_to_pixel(c0 + s * down)).ravel()[:2])
            draw_cross(img, px, py, half=max(3, size[1] // 60))
            if not args.short:
                img = annotate(img, f"red x: analytic s = g(sin30 - 0.3 cos30) t^2/2 = {s:.3f} m", xy=(8, size[1] - 30))
            writer.append(img)
            if extra.still and abs(sim.time - still_at) < 0.5 * per_frame * sim.dt:
                save_png(extra.still, img)
            if sim.step_count >= total:
                break
            sim.step(min(per_frame, total - sim.step_count))
    result = check(sim, block, c0, down)
    result.update(video=os.path.abspath(args.out), wall_s=clock())
    print(f"  slid {result['distance_sim_m']:.4f} m in {sim.time:.3g} s; analytic {result['distance_analytic_m']:.4f} m "
          f"(a = {a:.4f} m/s^2): error {100 * result['rel_error']:.2f} %")
    print(f"  wrote {args.out}; {result['wall_s']:.1f} s wall time")
    return result


if __name__ == "__main__":
    main()
    sys.exit(0)

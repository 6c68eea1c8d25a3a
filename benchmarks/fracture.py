"""Fracturing benchmark: a plate (every interior edge a cohesive joint) hit by a projectile.

    python benchmarks/fracture.py [--sizes 10000 100000] [--steps 200] [--precision f64]

Reports triangles, joints, couples, steps/s and triangle-steps/s of the parallel strategy
(target ≥ 5 million triangle-steps/s at 100k triangles in f64 on the 2-core CPU), and the phase
shares from Simulation.profile, as a Markdown table.
"""
from __future__ import annotations

import argparse
import math
import time


def scene_for(n_tri: int):
    import taichi_fdem as fdem
    W, H = 2.0, 0.5
    h = math.sqrt(2.0 * W * H / n_tri)              # 2 triangles per h × h cell
    mat = fdem.Material(density=2500.0, young=1e9, poisson=0.25, tensile_strength=1e6, fracture_energy=50.0,
                        name="plate")
    proj = fdem.Material(density=7800.0, young=1e9, poisson=0.25, name="projectile")
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(W, H, h), mat, fracture=True, name="plate")
    scene.add_body(fdem.mesh.disk(0.1, max(h, 0.01)), proj, position=(0.0, 0.25 + 0.1 + 0.5 * h),
                   velocity=(0.0, -50.0), name="projectile")
    return scene


def run(n_tri: int, steps: int, strategy: str) -> dict:
    scene = scene_for(n_tri)
    sim = scene.build(strategy=strategy)
    sim.step(20)                                   # compile + first detection
    t0 = time.perf_counter()
    sim.step(steps)
    wall = time.perf_counter() - t0
    prof = sim.profile(max(20, steps // 4))
    phases = ("elastic", "joints", "detection", "contact", "integration")
    total = sum(prof[k] for k in phases) or 1.0
    info = sim.info()
    return {"triangles": info["triangles"], "joints": info["joints"], "couples": sim.couple_count,
            "steps_per_s": steps / wall, "tri_steps_per_s": steps * info["triangles"] / wall,
            "broken": sim.broken_joint_count, "shares": {k: prof[k] / total for k in phases}}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[10000, 100000])
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--precision", choices=("f64", "f32"), default="f64")
    ap.add_argument("--strategy", default="parallel")
    args = ap.parse_args(argv)
    import taichi_fdem as fdem
    fdem.init(arch="cpu", precision=args.precision)
    rows = [run(n, args.steps, args.strategy) for n in args.sizes]
    print(f"\nFracture benchmark ({args.precision}, strategy {args.strategy}, {args.steps} steps)\n")
    print("| triangles | joints | couples | broken | steps/s | triangle-steps/s | elastic | joints | detection | contact | integration |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        s = r["shares"]
        print(f"| {r['triangles']:,} | {r['joints']:,} | {r['couples']:,} | {r['broken']} | {r['steps_per_s']:.1f} | "
              f"{r['tri_steps_per_s'] / 1e6:.2f} M | {s['elastic']:.0%} | {s['joints']:.0%} | {s['detection']:.0%} | "
              f"{s['contact']:.0%} | {s['integration']:.0%} |")
    return rows


if __name__ == "__main__":
    main()

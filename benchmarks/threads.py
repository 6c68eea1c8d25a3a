"""Thread scaling of the parallel strategy measured in one process: a team of one worker against
a team of two, in alternating windows, so that a noisy shared host slows both alike.

    python benchmarks/threads.py                                  # the default set below
    python benchmarks/threads.py --scene pile --sizes 1000 10000 100000
    python benchmarks/threads.py --scene plate --sizes 10000 --warmup 4500 --window 300

Two simulations of the same scene run side by side, one with ``Simulation.team_workers = 1``
and one with 2 (Taichi started with 2 CPU threads).  Both run the same steps and give the same
bits (the script checks it at the end: the block sums are added in block order whoever runs
them), so the ratio of their rates is the 2-worker / 1-worker speed-up of the same work.  The
fracture plate (``--scene plate``) is the scene of benchmarks/fracture.py; ``--warmup`` steps
take it into the impact (first contact at step ~3,000) before the timed windows.

Separate processes with 1 and 2 threads (pile.py, fracture.py) measure what a user gets; their
ratio also carries whatever else the host did during each run (one run each, minutes apart).
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def build(fdem, scene_kind: str, size: int):
    if scene_kind == "pile":
        import pile
        scene, _ = pile.build_scene(fdem, size)
        return scene.build(strategy="parallel")
    import fracture
    scene, dt, _ = fracture.scene_for(fdem, size)
    return scene.build(dt=dt, strategy="parallel")


def measure(fdem, scene_kind: str, size: int, window: int, reps: int, warmup: int) -> dict:
    sims = {}
    for workers in (1, 2):
        sim = build(fdem, scene_kind, size)
        sim.team_workers = workers
        sim.step(warmup)
        sims[workers] = sim
    rates = {1: [], 2: []}
    for r in range(reps):
        for workers in ((1, 2) if r % 2 == 0 else (2, 1)):      # alternate who goes first
            t0 = time.perf_counter()
            sims[workers].step(window)
            rates[workers].append(window / (time.perf_counter() - t0))
    a, b = sims[1], sims[2]
    same = bool(np.array_equal(a.node_positions(), b.node_positions())
                and np.array_equal(a.node_velocities(), b.node_velocities()))
    med = {w: float(np.median(v)) for w, v in rates.items()}
    best = {w: float(max(v)) for w, v in rates.items()}
    return {"scene": scene_kind, "triangles": a.tri_count, "couples": a.couple_count, "window": window,
            "reps": reps, "first": warmup + 1, "last": a.step_count, "median1": med[1], "median2": med[2],
            "best1": best[1], "best2": best[2], "ratio_median": med[2] / med[1], "ratio_best": best[2] / best[1],
            "same_bits": same, "paused": b.paused_steps}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", choices=("pile", "plate", "both"), default="both")
    ap.add_argument("--sizes", type=int, nargs="+", default=None,
                    help="triangle counts (default: pile 1000 10000 100000, plate 10000)")
    ap.add_argument("--window", type=int, default=0,
                    help="steps per timed window (default: ~0.1-0.3 s of work, by size)")
    ap.add_argument("--reps", type=int, default=12, help="windows per team size (default 12)")
    ap.add_argument("--warmup", type=int, default=None,
                    help="steps before timing (default: pile 50, plate 4500: into the fragmentation)")
    args = ap.parse_args(argv)
    import taichi_fdem as fdem
    fdem.init(arch="cpu", cpu_max_num_threads=2)
    runs = []
    if args.scene in ("pile", "both"):
        runs += [("pile", n) for n in (args.sizes or [1000, 10000, 100000])]
    if args.scene in ("plate", "both"):
        runs += [("plate", n) for n in (args.sizes or [10000])]
    print("| scene | triangles | steps timed | window × reps | 1 worker steps/s (median, best) "
          "| 2 workers steps/s (median, best) | 2 / 1 median | 2 / 1 best | same bits | paused steps |")
    print("|:--|---:|:--|:--|---:|---:|---:|---:|:--|---:|")
    for kind, n in runs:
        warmup = args.warmup if args.warmup is not None else (50 if kind == "pile" else 4500)
        window = args.window or (max(20, 4_000_000 // n) if kind == "pile" else 300)
        r = measure(fdem, kind, n, window, args.reps, warmup)
        print(f"| {kind} | {r['triangles']:,} | {r['first']:,}-{r['last']:,} | {window} × {args.reps} "
              f"| {r['median1']:,.0f}, {r['best1']:,.0f} | {r['median2']:,.0f}, {r['best2']:,.0f} "
              f"| **{r['ratio_median']:.2f}×** | {r['ratio_best']:.2f}× | {r['same_bits']} | {r['paused']:,} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

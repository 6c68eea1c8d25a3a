"""Thread scaling measured in one process: the serial strategy, a team of one worker and a team
of two, in alternating windows, so that a noisy shared host slows all three alike.

    python benchmarks/threads.py                                  # the default set below
    python benchmarks/threads.py --scene pile --sizes 1000 10000 100000
    python benchmarks/threads.py --scene plate --sizes 10000 --warmup 4500 --window 300

Three simulations of the same scene run side by side (Taichi started with 2 CPU threads): one
with ``strategy="serial"`` (one serialized launch per batch of steps: what ``strategy="auto"``
runs on one thread), and two with the parallel strategy, ``Simulation.team_workers = 1`` and 2.
The two teams run the same steps and give the same bits (the script checks it at the end: the
block sums are added in block order whoever runs them), so their ratio is the 2-worker /
1-worker speed-up of the same work; "2 workers / serial" is what a user gains from the second
thread with ``strategy="auto"``.  Each ratio is the median of the ratios of adjacent windows.
(The serial strategy's contact detection of a large scene is a parallel launch, which may use
the second thread: ~1 % of the pile's time.)  The fracture plate (``--scene plate``) is the
scene of benchmarks/fracture.py; ``--warmup`` steps take it into the impact (first contact at
step ~3,000) before the timed windows.

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


def build(fdem, scene_kind: str, size: int, strategy: str = "parallel"):
    if scene_kind == "pile":
        import pile
        scene, _ = pile.build_scene(fdem, size)
        return scene.build(strategy=strategy)
    import fracture
    scene, dt, _ = fracture.scene_for(fdem, size)
    return scene.build(dt=dt, strategy=strategy)


def measure(fdem, scene_kind: str, size: int, window: int, reps: int, warmup: int) -> dict:
    """Time three simulations of one scene in alternating windows: the serial strategy (what
    ``strategy="auto"`` runs on one thread; its steps are one serialized launch), a team of one
    worker and a team of two.  Each ratio is the median over the rounds of the ratio of two rates
    measured in the same round (adjacent windows), which cancels the host's slow drifts."""
    sims = {}
    for key, strategy, workers in (("serial", "serial", None), (1, "parallel", 1), (2, "parallel", 2)):
        sim = build(fdem, scene_kind, size, strategy)
        if workers is not None:
            sim.solver.team_workers = workers
        sim.step(warmup)
        sims[key] = sim
    order = ["serial", 1, 2]
    rates = {k: [] for k in order}
    for r in range(reps):
        for key in order[r % 3:] + order[:r % 3]:                # rotate who goes first
            t0 = time.perf_counter()
            sims[key].step(window)
            rates[key].append(window / (time.perf_counter() - t0))
    a, b = sims[1], sims[2]
    same = bool(np.array_equal(a.node_positions(), b.node_positions())
                and np.array_equal(a.node_velocities(), b.node_velocities()))
    med = {k: float(np.median(v)) for k, v in rates.items()}
    best = {k: float(max(v)) for k, v in rates.items()}
    pair = lambda x, y: float(np.median(np.asarray(rates[x]) / np.asarray(rates[y])))   # noqa: E731
    return {"scene": scene_kind, "triangles": a.model.tri_count, "couples": a.solver.couple_count, "window": window,
            "reps": reps, "first": warmup + 1, "last": a.step_count, "median": med, "best": best,
            "ratio_team": pair(2, 1), "ratio_auto": pair(2, "serial"), "ratio_best": best[2] / best[1],
            "ratio_best_auto": best[2] / best["serial"], "same_bits": same, "paused": b.info()["team"]["solo_steps"]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", choices=("pile", "plate", "both"), default="both")
    ap.add_argument("--sizes", type=int, nargs="+", default=None,
                    help="triangle counts (default: pile 1000 10000 100000, plate 10000)")
    ap.add_argument("--window", type=int, default=0,
                    help="steps per timed window (default: ~0.1-0.3 s of work, by size)")
    ap.add_argument("--reps", type=int, default=12, help="rounds of windows, one window per simulation in each (default 12)")
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
    print("| scene | triangles | steps timed | window × rounds | serial steps/s (median, best) "
          "| 1 worker (median, best) | 2 workers (median, best) | 2 workers / serial | 2 / 1 worker "
          "| best / best (serial, 1 worker) | same bits | solo steps |")
    print("|:--|---:|:--|:--|---:|---:|---:|---:|---:|:--|:--|---:|")
    for kind, n in runs:
        warmup = args.warmup if args.warmup is not None else (50 if kind == "pile" else 4500)
        window = args.window or (max(20, 4_000_000 // n) if kind == "pile" else 300)
        r = measure(fdem, kind, n, window, args.reps, warmup)
        m, b = r["median"], r["best"]
        print(f"| {kind} | {r['triangles']:,} | {r['first']:,}-{r['last']:,} | {window} × {args.reps} "
              f"| {m['serial']:,.0f}, {b['serial']:,.0f} | {m[1]:,.0f}, {b[1]:,.0f} | {m[2]:,.0f}, {b[2]:,.0f} "
              f"| **{r['ratio_auto']:.2f}×** | **{r['ratio_team']:.2f}×** "
              f"| {r['ratio_best_auto']:.2f}×, {r['ratio_best']:.2f}× | {r['same_bits']} | {r['paused']:,} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

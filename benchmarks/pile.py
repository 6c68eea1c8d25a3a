"""Performance benchmark of taichi_fdem: a dense pile of deformable disks in a fixed box.

    python benchmarks/pile.py                          # default sizes 1k, 10k, 100k, 300k triangles
    python benchmarks/pile.py --sizes 1000 10000 --markdown
    python benchmarks/pile.py --strategy serial,parallel --csv out/bench.csv
    python benchmarks/pile.py --threads 2 --sizes 100000 --no-startup

Every scene is a hexagonal packing of equal disks (``fdem.mesh.disk(r, 0.4 r, layout="spiral")``: 32 triangles
each) at centre spacing exactly 2r, so each disk touches its six neighbours (the meshed disk is
the inscribed polygon: gaps of < 1 % of r, inside the contact buffer), resting on a fixed floor
between two fixed side walls, under gravity, with a small random initial velocity.  That gives
about two contact couples per triangle.

For each size and strategy it prints one row (see benchmarks/README.md for the columns): size,
couples, steps/s (over the timed run, and in the best of its 10 windows: the machine is shared),
triangle-steps/s, the share of each phase (``Simulation.profile``; parallel strategy only: the
serial strategy fuses the phases into one launch), build time, first step, and the cold / warm
start (time to first step of a fresh process with an empty / filled offline kernel cache, measured in subprocesses running this script with ``--startup``).
It also checks that a new scene size does not recompile the kernels.

Every thread count of ``--threads`` (default 1 and 2) runs in its own subprocess of this script,
since Taichi takes ``cpu_max_num_threads`` once, at ``ti.init``; the table has one row per
strategy, size and thread count, followed by the 2-thread / 1-thread ratios.

This is a benchmark, not a test: it asserts nothing except that the runs are stable.
"""
from __future__ import annotations

import time

_T_START = time.perf_counter()   # before importing Taichi: the start-up clock of --startup

import argparse
import csv
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

# ---- the scene ------------------------------------------------------------------------------
RADIUS = 0.05            # disk radius [m]
H_FACTOR = 0.4           # element size h = 0.4 r: disk() gives 32 triangles, 25 nodes
WALL_H = H_FACTOR * RADIUS
ROCK = dict(density=2500.0, young=1.0e8, poisson=0.25, friction=0.3)   # SI units
V_RANDOM = 0.1           # std. dev. of the random initial velocity components [m/s]
STARTUP_SIZE = 1000      # triangles of the scene used to measure cold / warm start
WINDOWS = 10             # the timed run's windows (steps/s over the run, and in its best window)

DEFAULT_SIZES = (1000, 10_000, 100_000, 300_000)


def build_scene(fdem, target_triangles: int, seed: int = 0, v_random: float = V_RANDOM):
    """The pile scene with about ``target_triangles`` triangles (walls included).

    Returns (scene, dict with the layout numbers).
    """
    disk = fdem.mesh.disk(RADIUS, H_FACTOR * RADIUS, layout="spiral")
    per_disk = disk.triangle_count
    dy = math.sqrt(3.0) * RADIUS                     # row spacing of the hexagonal packing
    s = 2.0 * RADIUS                                 # centre spacing in a row
    # a box about as wide as the pile is tall; walls take ~2 % of the triangles at 1k, less above
    n_disks = max(2, round(0.97 * target_triangles / per_disk))
    for _ in range(3):
        nx = max(2, int(round(math.sqrt(n_disks * dy / s))))
        ny = math.ceil(n_disks / nx)
        width = nx * s + RADIUS                      # odd rows are shifted by r
        height = (ny - 1) * dy + 2.0 * RADIUS
        wall_tris = 2 * round((width + 2 * WALL_H) / WALL_H) + 4 * round((height + RADIUS) / WALL_H)
        n_disks = max(2, round((target_triangles - wall_tris) / per_disk))
    nx = max(2, int(round(math.sqrt(n_disks * dy / s))))
    ny = math.ceil(n_disks / nx)
    width = nx * s + RADIUS
    height = (ny - 1) * dy + 2.0 * RADIUS

    rock = fdem.Material(**ROCK, name="rock")
    scene = fdem.Scene(gravity=(0.0, -9.81))
    t = WALL_H                                       # wall thickness: one row of cells
    wall_h = height + RADIUS
    scene.add_body(fdem.mesh.rectangle(width + 2 * t, t, WALL_H), rock, position=(0.5 * width, -0.5 * t),
                   fixed=True, name="floor")
    scene.add_body(fdem.mesh.rectangle(t, wall_h, WALL_H), rock, position=(-0.5 * t, 0.5 * wall_h),
                   fixed=True, name="left")
    scene.add_body(fdem.mesh.rectangle(t, wall_h, WALL_H), rock, position=(width + 0.5 * t, 0.5 * wall_h),
                   fixed=True, name="right")
    rng = np.random.default_rng(seed)
    vel = rng.normal(0.0, v_random, size=(n_disks, 2))
    k = 0
    for j in range(ny):
        for i in range(nx):
            if k == n_disks:
                break
            x = RADIUS + i * s + (RADIUS if j % 2 else 0.0)
            scene.add_body(disk, rock, position=(x, RADIUS + j * dy), velocity=vel[k])
            k += 1
    return scene, {"disks": n_disks, "width": width, "height": height}


# ---- start-up mode (runs in a fresh subprocess) ---------------------------------------------
def startup_main(args) -> None:
    """Import, build a small pile, take one step; print the times as one JSON line."""
    t_proc = _T_START
    import taichi_fdem as fdem
    fdem.init(arch="cpu", precision=args.precision)
    t_import = time.perf_counter()
    scene, _ = build_scene(fdem, args.startup_size)
    sim = scene.build(strategy=args.strategy)
    t_build = time.perf_counter()
    sim.step(1)
    t_first = time.perf_counter()
    sim.step(1)
    t_second = time.perf_counter()
    print("STARTUP " + json.dumps({
        "import": t_import - t_proc, "build": t_build - t_import, "first_step": t_first - t_build,
        "second_step": t_second - t_first, "to_first_step": t_first - t_proc,
        "strategy": sim.solver.strategy, "triangles": sim.model.tri_count}), flush=True)


def measure_startup(strategy: str, precision: str, size: int) -> dict:
    """Cold and warm start in two fresh subprocesses sharing a new, empty offline cache dir."""
    cache = tempfile.mkdtemp(prefix="taichi_fdem_bench_cache_")
    env = dict(os.environ, TAICHI_FDEM_CACHE=cache)
    cmd = [sys.executable, os.path.abspath(__file__), "--startup", "--strategy", strategy,
           "--precision", precision, "--startup-size", str(size)]
    out = {}
    try:
        for label in ("cold", "warm"):
            t0 = time.perf_counter()
            res = subprocess.run(cmd, env=env, capture_output=True, text=True)
            wall = time.perf_counter() - t0
            line = next((l for l in res.stdout.splitlines() if l.startswith("STARTUP ")), None)
            if res.returncode != 0 or line is None:
                raise RuntimeError(f"start-up subprocess failed ({label}, rc={res.returncode}):\n"
                                   f"{res.stdout[-2000:]}\n{res.stderr[-4000:]}")
            d = json.loads(line[len("STARTUP "):])
            d["process_wall"] = wall
            out[label] = d
        out["cache_mb"] = sum(os.path.getsize(os.path.join(dp, f)) for dp, _, fs in os.walk(cache)
                              for f in fs) / 1e6
    finally:
        shutil.rmtree(cache, ignore_errors=True)
    return out


# ---- measurements in this process ------------------------------------------------------------
def recompile_check(fdem, strategy: str) -> dict:
    """Two different scene sizes in one process: the first step of the second must not compile."""
    out = {}
    for label, size in (("first", 600), ("second", 2500)):
        scene, _ = build_scene(fdem, size, seed=1)
        t0 = time.perf_counter()
        sim = scene.build(strategy=strategy)
        t1 = time.perf_counter()
        sim.step(1)
        t2 = time.perf_counter()
        sim.step(1)
        t3 = time.perf_counter()
        out[label] = {"triangles": sim.model.tri_count, "build": t1 - t0, "first_step": t2 - t1, "second_step": t3 - t2}
    out["strategy"] = sim.solver.strategy
    # a recompile costs seconds; a step of 2.5k triangles (plus one detection) well under 0.1 s
    out["recompiled"] = out["second"]["first_step"] > 0.25
    return out


def bench_size(fdem, size: int, strategy: str, steps: int | None, seconds: float, profile: bool,
               v_random: float = V_RANDOM, windows: int = WINDOWS) -> dict:
    t0 = time.perf_counter()
    scene, layout = build_scene(fdem, size, v_random=v_random)
    t1 = time.perf_counter()
    sim = scene.build(strategy=strategy)
    t2 = time.perf_counter()
    info = sim.info()
    couples0 = sim.solver.couple_count

    sim.step(1)                                          # first step: compiles (or loads) kernels
    t3 = time.perf_counter()
    # warm-up and calibration: ~0.3 s of steps
    probe = 1
    while True:
        ta = time.perf_counter()
        sim.step(probe)
        el = time.perf_counter() - ta
        if el > 0.3 or probe >= 1 << 20:
            break
        probe *= 4
    per_step = el / probe
    n = steps if steps else max(5, int(math.ceil(seconds / per_step)))
    det0 = sim.solver.detection_count
    step0 = sim.step_count
    paused0 = sim.info()["team"]["solo_steps"]
    # the timed run in WINDOWS equal windows: the whole run's rate, and its best window's (the
    # machine is shared: a window another process slowed down shows in the mean, not the best)
    per = [n // windows + (1 if k < n % windows else 0) for k in range(windows)]
    wall, best = 0.0, 0.0
    for m in per:
        if m == 0:
            continue
        ta = time.perf_counter()
        sim.step(m)
        el = time.perf_counter() - ta
        wall += el
        best = max(best, m / el)
    assert sim.step_count - step0 == n, (sim.step_count, step0, n)
    dets = sim.solver.detection_count - det0
    # steps run by one worker because it timed faster than the team (a busy host;
    # sim.team.TeamScheduler.choose)
    paused = sim.info()["team"]["solo_steps"] - paused0
    x = sim.node_positions()
    if not np.all(np.isfinite(x)):
        raise RuntimeError(f"size {size}: non-finite positions after {sim.step_count} steps")

    row = {"triangles": sim.model.tri_count, "nodes": sim.model.node_count, "bodies": len(sim.bodies),
           "couples": sim.solver.couple_count, "couples_per_tri": sim.solver.couple_count / sim.model.tri_count,
           "couples_at_build": couples0, "strategy": sim.solver.strategy, "precision": info["precision"],
           "dt": sim.dt, "steps": n, "seconds": wall, "steps_per_s": n / wall, "steps_per_s_best": best,
           "mtri_steps_per_s": n * sim.model.tri_count / wall / 1e6,
           "detections_per_1k_steps": 1000.0 * dets / n, "paused_steps": paused,
           "scene_s": t1 - t0, "build_s": t2 - t1, "first_step_s": t3 - t2}
    for ph in ("elastic", "detection", "contact", "integration"):
        row[ph] = None
    if profile and sim.solver.strategy == "parallel":
        # phases as separate launches: ~1/3 of the timed run, at least 5 steps
        psteps = max(5, min(n, int(math.ceil(0.5 * seconds / per_step))))
        p = sim.solver.profile(psteps)
        for ph in ("elastic", "detection", "contact", "integration"):
            row[ph] = p[ph] / p["total"] if p["total"] > 0 else float("nan")
        row["profile_steps"] = psteps
        row["profile_steps_per_s"] = psteps / p["total"]
    return row


# ---- output ----------------------------------------------------------------------------------
COLUMNS = [  # (header, key, format)
    ("triangles", "triangles", "{:,}"), ("strategy", "strategy", "{}"), ("threads", "threads", "{}"),
    ("couples", "couples", "{:,}"),
    ("couples/tri", "couples_per_tri", "{:.2f}"), ("steps", "steps", "{:,}"),
    ("steps/s", "steps_per_s", "{:,.0f}"), ("best window", "steps_per_s_best", "{:,.0f}"),
    ("Mtri-steps/s", "mtri_steps_per_s", "{:.1f}"),
    ("det/1k steps", "detections_per_1k_steps", "{:.1f}"), ("solo steps", "paused_steps", "{:,}"),
    ("elastic", "elastic", "{:.0%}"), ("detection", "detection", "{:.0%}"), ("contact", "contact", "{:.0%}"),
    ("integration", "integration", "{:.0%}"), ("scene s", "scene_s", "{:.2f}"), ("build s", "build_s", "{:.2f}"),
    ("1st step s", "first_step_s", "{:.3f}"), ("cold start s", "cold_s", "{:.1f}"),
    ("warm start s", "warm_s", "{:.1f}"),
]


def fmt_row(row):
    out = []
    for _, key, f in COLUMNS:
        v = row.get(key)
        out.append("n/a" if v is None or (isinstance(v, float) and math.isnan(v)) else f.format(v))
    return out


def print_table(rows, markdown: bool) -> None:
    head = [c[0] for c in COLUMNS]
    body = [fmt_row(r) for r in rows]
    if markdown:
        print("| " + " | ".join(head) + " |")
        print("|" + "|".join("---:" if i != 1 else ":---" for i in range(len(head))) + "|")
        for r in body:
            print("| " + " | ".join(r) + " |")
    else:
        w = [max(len(h), *(len(r[i]) for r in body)) for i, h in enumerate(head)]
        print("  ".join(h.rjust(w[i]) for i, h in enumerate(head)))
        for r in body:
            print("  ".join(c.rjust(w[i]) for i, c in enumerate(r)))


def measure(args, strategies):
    """The measurements of one process (one thread count): the recompile check and every size."""
    import taichi as ti
    import taichi_fdem as fdem
    fdem.init(arch="cpu", precision=args.precision, cpu_max_num_threads=args.worker_threads)
    threads = int(ti.lang.impl.current_cfg().cpu_max_num_threads)
    print(f"taichi_fdem {fdem.__version__}, Taichi {'.'.join(map(str, ti.__version__))}, "
          f"precision {args.precision}, {threads} of {os.cpu_count()} CPU threads (cpu_max_num_threads), "
          f"python {sys.version.split()[0]}")
    probe, _ = build_scene(fdem, 1000)
    print(f"scene: hexagonal pile of disks r = {RADIUS} m, h = {H_FACTOR} r "
          f"({probe.bodies[-1].mesh.triangle_count} triangles each), in a fixed box; "
          f"E = {ROCK['young']:.0e} Pa, rho = {ROCK['density']:.0f} kg/m3, nu = {ROCK['poisson']}, "
          f"friction {ROCK['friction']}; gravity; random initial velocity sd {args.velocity} m/s", flush=True)

    rows, resolved = [], {}
    for strategy in strategies:
        rc = recompile_check(fdem, strategy)
        resolved[strategy] = rc["strategy"]
        print(f"[recompile check, {rc['strategy']}, {threads} thread(s)] {rc['first']['triangles']} triangles: "
              f"first step {rc['first']['first_step']:.3f} s (compiles or loads the kernels); then a new scene of "
              f"{rc['second']['triangles']} triangles in the same process: first step "
              f"{1e3 * rc['second']['first_step']:.1f} ms, second {1e3 * rc['second']['second_step']:.2f} ms -> "
              f"{'RECOMPILED (a new size should not recompile)' if rc['recompiled'] else 'no recompilation'}",
              flush=True)
        for size in args.sizes:
            steps = args.steps or json.loads(args.steps_map).get(f"{strategy}:{size}")
            row = bench_size(fdem, size, strategy, steps, args.seconds, not args.no_profile, args.velocity,
                             args.windows)
            row["threads"] = threads
            row["size"] = size
            rows.append(row)
            print(f"  {row['triangles']:>8,} triangles ({row['strategy']}, {threads} thread(s)): {row['couples']:,} "
                  f"couples ({row['couples_per_tri']:.2f}/triangle), {row['steps_per_s']:,.1f} steps/s = "
                  f"{row['mtri_steps_per_s']:.1f} M triangle-steps/s over {row['steps']:,} steps "
                  f"(best of {args.windows} windows {row['steps_per_s_best']:,.0f} steps/s); "
                  f"build {row['scene_s'] + row['build_s']:.2f} s", flush=True)
    return rows, resolved


def argv_for_worker(args, threads: int, steps_map: dict | None = None) -> list:
    a = ["--sizes", *map(str, args.sizes), "--seconds", str(args.seconds), "--precision", args.precision,
         "--strategy", args.strategy, "--velocity", str(args.velocity), "--worker-threads", str(threads),
         "--windows", str(args.windows)]
    if args.steps:
        a += ["--steps", str(args.steps)]
    elif steps_map:
        a += ["--steps-map", json.dumps(steps_map)]
    if args.no_profile:
        a.append("--no-profile")
    return a


def run_worker(argv: list):
    """Run this script with ``argv`` in a subprocess, echo its output, return its (rows, resolved)."""
    cmd = [sys.executable, os.path.abspath(__file__), *argv]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
    out, tail = None, []
    for line in proc.stdout:
        if line.startswith("ROWS "):
            out = json.loads(line[len("ROWS "):])
        elif not line.startswith("[Taichi]"):
            print(line, end="", flush=True)
            tail = (tail + [line])[-40:]
    rc = proc.wait()
    if rc != 0 or out is None:
        raise RuntimeError(f"benchmark subprocess failed (rc={rc}): {' '.join(cmd)}\n" + "".join(tail))
    return out["rows"], out["resolved"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=list(DEFAULT_SIZES),
                    help="target triangle counts (default: 1000 10000 100000 300000)")
    ap.add_argument("--steps", type=int, default=None,
                    help="timed steps per size (default: enough for --seconds of wall time)")
    ap.add_argument("--seconds", type=float, default=2.0, help="target wall time of each timed run (default 2)")
    ap.add_argument("--precision", choices=("f64", "f32"), default="f64")
    ap.add_argument("--strategy", default="auto",
                    help="auto, serial, parallel, or a comma list such as serial,parallel (default auto)")
    ap.add_argument("--velocity", type=float, default=V_RANDOM,
                    help=f"std. dev. of the random initial velocity [m/s] (default {V_RANDOM}); larger: "
                         "more frequent contact detection")
    ap.add_argument("--windows", type=int, default=WINDOWS,
                    help=f"windows of the timed run (default {WINDOWS}): steps/s is given over the run and in its best "
                         "window, which a busy host slowed least")
    ap.add_argument("--csv", default=None, help="also write the rows to this CSV file")
    ap.add_argument("--markdown", action="store_true", help="print a Markdown table")
    ap.add_argument("--no-startup", action="store_true", help="skip the cold / warm start subprocesses")
    ap.add_argument("--no-profile", action="store_true", help="skip the per-phase profile")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2],
                    help="CPU thread counts (Taichi cpu_max_num_threads), each measured in its own "
                         "subprocess (default 1 2)")
    ap.add_argument("--worker-threads", type=int, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--steps-map", default="{}", help=argparse.SUPPRESS)
    ap.add_argument("--startup", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--startup-size", type=int, default=STARTUP_SIZE, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.windows < 1:
        ap.error(f"--windows must be at least 1, got {args.windows}")

    strategies = [s.strip() for s in args.strategy.split(",") if s.strip()]
    for s in strategies:
        if s not in ("auto", "serial", "parallel"):
            ap.error(f"unknown strategy {s!r}")
    if args.startup:
        args.strategy = strategies[0]
        startup_main(args)
        return 0

    if args.worker_threads is not None:
        rows, resolved = measure(args, strategies)
        print("ROWS " + json.dumps({"rows": rows, "resolved": resolved}), flush=True)
        return 0

    # the driver: one subprocess per thread count (Taichi takes cpu_max_num_threads once, at ti.init)
    # every thread count runs the steps the first one calibrated (for --seconds): the pile settles
    # as it runs and its steps get dearer, so a faster run of more steps would meet a later, slower
    # pile (the 10k pile's windows ran at 6,900 down to 4,500 steps/s in one 2-thread run), which
    # biased the thread ratios low
    rows, resolved, steps_map = [], {}, {}
    t_all = time.perf_counter()
    for threads in args.threads:
        r, res = run_worker(argv_for_worker(args, threads, steps_map))
        rows += r
        resolved.update(res)
        if not steps_map:
            inverse = {v: k for k, v in res.items()}
            steps_map = {f"{inverse.get(row['strategy'], row['strategy'])}:{row['size']}": row["steps"] for row in r}

    startup = {}
    if not args.no_startup:
        for strategy in strategies:
            key = resolved[strategy]
            if key in startup:
                continue
            print(f"[start-up, {key}] two fresh processes, {args.startup_size}-triangle pile, new empty "
                  f"TAICHI_FDEM_CACHE ...", flush=True)
            st = measure_startup(key, args.precision, args.startup_size)
            startup[key] = st
            c, w = st["cold"], st["warm"]
            print(f"  cold: {c['to_first_step']:.1f} s to first step (import {c['import']:.2f} s, build "
                  f"{c['build']:.2f} s, first step {c['first_step']:.2f} s); warm: {w['to_first_step']:.1f} s "
                  f"(import {w['import']:.2f} s, build {w['build']:.2f} s, first step {w['first_step']:.2f} s); "
                  f"cache {st['cache_mb']:.1f} MB", flush=True)
        for row in rows:
            st = startup.get(row["strategy"])
            if st:
                row["cold_s"] = st["cold"]["to_first_step"]
                row["warm_s"] = st["warm"]["to_first_step"]

    order = {s: i for i, s in enumerate(resolved[k] for k in strategies)}
    rows.sort(key=lambda r: (order.get(r["strategy"], 99), r["triangles"], r["threads"]))
    print()
    print_table(rows, args.markdown)
    by = {(r["strategy"], r["triangles"], r["threads"]): r for r in rows}
    gains = [f"{r['strategy']} {r['triangles']:,}: {r['threads']} threads / 1 = "
             f"{r['steps_per_s'] / by[(r['strategy'], r['triangles'], 1)]['steps_per_s']:.2f}x "
             f"(best windows {r['steps_per_s_best'] / by[(r['strategy'], r['triangles'], 1)]['steps_per_s_best']:.2f}x)"
             for r in rows if r["threads"] != 1 and (r["strategy"], r["triangles"], 1) in by]
    if gains:
        print("\nthread scaling (steps/s over the run, and in the best of its windows, which a busy host slowed "
              "least): " + "; ".join(gains))
    print(f"\n(total benchmark time {time.perf_counter() - t_all:.0f} s; phase shares from Simulation.profile "
          "on the parallel strategy, n/a for the serial strategy whose phases run fused in one launch; "
          "cold/warm start: time to first step of a fresh process on the "
          f"{args.startup_size}-triangle pile with an empty / reused offline cache)")
    if args.csv:
        os.makedirs(os.path.dirname(os.path.abspath(args.csv)), exist_ok=True)
        keys = sorted({k for r in rows for k in r})
        with open(args.csv, "w", newline="") as f:
            wr = csv.DictWriter(f, fieldnames=keys)
            wr.writeheader()
            wr.writerows(rows)
        print(f"rows written to {args.csv}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

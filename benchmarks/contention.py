"""The default strategy against the serial one under CPU contention, from one run.

    python benchmarks/contention.py                                # plate impact 10k and pile 100k
    python benchmarks/contention.py --scene plate --size 10000 --steps 6000
    python benchmarks/contention.py --conditions idle busy --markdown

Each measurement is a fresh process (its own Taichi runtime) that builds the scene, runs a few
steps (compiling the kernels; the offline cache makes it short after the first run), then times
``--steps`` steps and prints triangle-steps per second.  Both strategies are measured in each
condition, ``--reps`` times each in the order auto, serial, serial, auto, ... (so that a drift
of the host's speed affects both alike), and a strategy's rate is its steps over its total
time:

* ``idle``: nothing else runs (besides what the host itself runs);
* ``busy``: one CPU-bound process (a Python busy loop) runs beside it;
* ``taskset``: the process may run on CPU 0 only (``os.sched_setaffinity``, as ``taskset -c 0``,
  a one-core cpuset, a Slurm job or a CI runner would give it);
* ``pair``: two measurements of the same strategy side by side (a 2-worker sweep), each
  reported (the row shows their mean and the slowest of them).

The columns: the rate of ``strategy="auto"`` and of ``strategy="serial"`` [M triangle-steps/s],
their ratio, auto / serial, and the team's counters summed over the auto runs
(``Simulation.info()["team"]``: waits past their bound, switches to one worker and back, steps
run by one worker).  ``--scene plate`` is the plate impact of benchmarks/fracture.py (every
interior edge jointed, hit at 50 m/s; first contact near step 3,000, so 6,000 steps run
through the impact and the fragmentation); ``--scene pile`` the pile of benchmarks/pile.py.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
CONDITIONS = ("idle", "busy", "taskset", "pair")


def worker(scene_kind: str, size: int, steps: int, strategy: str) -> None:
    """Build, compile, time ``steps`` steps; print one JSON line."""
    sys.path.insert(0, HERE)
    import taichi_fdem as fdem
    fdem.init(arch="cpu")
    if scene_kind == "plate":
        import fracture
        scene, dt, _ = fracture.scene_for(fdem, size)
        sim = scene.build(dt=dt, strategy=strategy)
    else:
        import pile
        scene, _ = pile.build_scene(fdem, size)
        sim = scene.build(strategy=strategy)
    sim.step(20)
    t0 = time.perf_counter()
    sim.step(steps)
    wall = time.perf_counter() - t0
    info = sim.info()
    print(json.dumps({"rate": sim.model.tri_count * steps / wall, "wall": wall, "strategy": sim.solver.strategy,
                      "team": info["team"], "threads": info["threads"]}))


def _spawn(args, strategy: str, pin: bool):
    cmd = [sys.executable, os.path.abspath(__file__), "--worker", "--scene", args.scene, "--size", str(args.size),
           "--steps", str(args.steps), "--strategy", strategy]
    pre = (lambda: os.sched_setaffinity(0, {0})) if pin else None
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, preexec_fn=pre)


def _result(proc) -> dict:
    out, _ = proc.communicate()
    lines = [ln for ln in out.splitlines() if ln.startswith("{")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"a measurement failed (exit {proc.returncode})")
    return json.loads(lines[-1])


def measure(args, condition: str, strategy: str) -> list[dict]:
    """The results of one condition for one strategy (two in ``pair``)."""
    hog = None
    if condition == "busy":
        hog = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        if condition == "pair":
            procs = [_spawn(args, strategy, False) for _ in range(2)]
        else:
            procs = [_spawn(args, strategy, condition == "taskset")]
        return [_result(p) for p in procs]
    finally:
        if hog is not None:
            hog.kill()
            hog.wait()


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", choices=("plate", "pile", "both"), default="both")
    ap.add_argument("--size", type=int, default=None, help="triangles (default: plate 10,000, pile 100,000)")
    ap.add_argument("--steps", type=int, default=None, help="timed steps (default: plate 6,000, pile 1,500)")
    ap.add_argument("--conditions", nargs="+", choices=CONDITIONS, default=list(CONDITIONS))
    ap.add_argument("--reps", type=int, default=2, help="measurements of each strategy per condition (default 2)")
    ap.add_argument("--markdown", action="store_true", help="print a Markdown table")
    ap.add_argument("--json", default=None, help="also write every measurement to this JSON file")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--strategy", default="auto", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        worker(args.scene, args.size, args.steps, args.strategy)
        return
    scenes = ("plate", "pile") if args.scene == "both" else (args.scene,)
    every = {}
    for scene in scenes:
        run = argparse.Namespace(**vars(args))
        run.scene = scene
        run.size = args.size or (10_000 if scene == "plate" else 100_000)
        run.steps = args.steps or (6_000 if scene == "plate" else 1_500)
        rows = []
        for cond in args.conditions:
            res = {"auto": [], "serial": []}
            for k in range(args.reps):
                for s in (("auto", "serial") if k % 2 == 0 else ("serial", "auto")):
                    res[s] += measure(run, cond, s)
            every[f"{scene}/{cond}"] = res
            rate = {s: len(rs) / sum(1.0 / r["rate"] for r in rs) for s, rs in res.items()}
            low = {s: min(r["rate"] for r in rs) for s, rs in res.items()}
            team = {key: sum(r["team"][key] for r in res["auto"]) for key in res["auto"][0]["team"]}
            rows.append((cond, rate["auto"], low["auto"], rate["serial"], low["serial"], rate["auto"] / rate["serial"],
                         res["auto"][0]["strategy"], team))
        title = f"{scene} {run.size:,} triangles, {run.steps:,} steps"
        if args.markdown:
            print(f"\n**{title}** [M triangle-steps/s]\n")
            print("| condition | auto | serial | auto / serial | auto ran | team: timeouts, to one worker / back, "
                  "steps by one worker |")
            print("|:--|--:|--:|--:|:--|:--|")
            for cond, a, al, s, sl, ratio, strat, team in rows:
                extra = f" (slowest {al / 1e6:.2f} / {sl / 1e6:.2f})" if cond == "pair" else ""
                print(f"| {cond}{extra} | {a / 1e6:.2f} | {s / 1e6:.2f} | {ratio:.2f} | {strat} | "
                      f"{team['timeouts']}, {team['to_solo']} / {team['to_team']}, {team['solo_steps']:,} |")
        else:
            print(title)
            for cond, a, al, s, sl, ratio, strat, team in rows:
                print(f"  {cond:8s} auto {a / 1e6:7.2f} M  serial {s / 1e6:7.2f} M  auto/serial {ratio:5.2f}  "
                      f"({strat}; team {team})")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(every, f, indent=1)


if __name__ == "__main__":
    main()

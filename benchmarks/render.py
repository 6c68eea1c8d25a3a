"""Cost of the off-screen renderer (issue 3: "at default settings rendering takes under 10% of a
demo's run time; measure it in the benchmark").

    python benchmarks/render.py                       # per-frame costs + every demo (full runs)
    python benchmarks/render.py --short               # demos in their short mode (quick)
    python benchmarks/render.py --no-demos            # only the per-frame costs
    python benchmarks/render.py --no-frames --demos pile tower

(a) Per frame: ``RendererImage.render_sim`` at default settings (960 x 540, fitted view, edges,
    colour bar and time stamp) on a ~1k and a ~100k triangle pile (benchmarks/pile.py's scene)
    for every colour mode, split into

    * ``labels``: time inside ``RendererImage._overlay`` (colour bar, its labels, the stamp),
    * ``copies``: host <-> device copies (every ``Ndarray`` to_numpy / from_numpy),
    * ``kernels``: the rest (kernel launches + Python glue).

(b) Per demo: runs ``demos/NAME.py``'s ``main`` (in a subprocess, normal mode or ``--short``)
    with timing hooks on ``RendererImage.render_sim`` (rendering) and ``VideoWriter.append`` /
    ``VideoWriter.close`` (handing frames to the ffmpeg subprocess and waiting for it to finish:
    the encoding itself runs in ffmpeg, partly in parallel with the simulation), and prints a
    Markdown table: demo, run time, frames, render time, video-encode time, render share.

This is a benchmark: it asserts nothing.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEMOS = ("two_disks", "pile", "tower", "incline", "brazilian", "fragment_plate")


# ---- timing hooks --------------------------------------------------------------------------
class Acc:
    """Accumulated wall time and call count of wrapped functions, by label."""

    def __init__(self):
        self.t = {}
        self.n = {}
        self._depth = {}

    def wrap(self, owner, name, label):
        fn = getattr(owner, name, None)
        if fn is None:
            return
        acc = self

        def wrapped(*a, **k):
            d = acc._depth.get(label, 0)
            acc._depth[label] = d + 1
            t0 = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                acc._depth[label] = d
                if d == 0:   # count nested calls (render_sim -> render_sim) once
                    acc.t[label] = acc.t.get(label, 0.0) + time.perf_counter() - t0
                    acc.n[label] = acc.n.get(label, 0) + 1

        wrapped.__wrapped__ = fn
        setattr(owner, name, wrapped)

    def reset(self):
        self.t.clear()
        self.n.clear()


def install_copy_hooks(acc):
    from taichi.lang import _ndarray

    for name in ("_ndarray_to_numpy", "_ndarray_matrix_to_numpy", "_ndarray_from_numpy",
                 "_ndarray_matrix_from_numpy"):
        acc.wrap(_ndarray.Ndarray, name, "copies")


# ---- (a) per-frame cost ----------------------------------------------------------------------
def frame_costs(sizes, frames, modes=None):
    sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
    import taichi_fdem as fdem
    from taichi_fdem import backend, render
    from pile import build_scene

    if not backend.is_initialised():
        backend.init(arch="cpu")
    acc = Acc()
    install_copy_hooks(acc)
    acc.wrap(render.RendererImage, "_overlay", "labels")
    modes = list(render.COLOR_MODES) if modes is None else modes
    rows = []
    for size in sizes:
        scene, _ = build_scene(fdem, size)
        sim = scene.build()
        sim.step(2)
        for mode in modes:
            r = render.RendererImage(color_by=mode)          # default settings otherwise
            for _ in range(3):                                # warm-up (compilation, caches)
                r.render_sim(sim)
            acc.reset()
            t0 = time.perf_counter()
            for _ in range(frames):
                r.render_sim(sim)
            total = (time.perf_counter() - t0) / frames
            labels = acc.t.get("labels", 0.0) / frames
            copies = acc.t.get("copies", 0.0) / frames
            rows.append({"triangles": sim.model.tri_count, "mode": mode, "total_ms": 1e3 * total,
                         "kernels_ms": 1e3 * (total - labels - copies), "labels_ms": 1e3 * labels,
                         "copies_ms": 1e3 * copies, "copy_calls": acc.n.get("copies", 0) / frames})
        del sim
    return rows


def print_frame_table(rows):
    print("| triangles | colour mode | render_sim [ms/frame] | kernels + Python [ms] | labels [ms] | "
          "host<->device copies [ms] (calls) |")
    print("|---:|---|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['triangles']:,} | {r['mode']} | {r['total_ms']:.2f} | {r['kernels_ms']:.2f} | "
              f"{r['labels_ms']:.2f} | {r['copies_ms']:.2f} ({r['copy_calls']:.0f}) |")


# ---- (b) demos -------------------------------------------------------------------------------
def demo_child(name, short):
    """Run one demo with the timing hooks (in this process); print a JSON line."""
    sys.path.insert(0, os.path.join(ROOT, "demos"))
    import importlib

    from taichi_fdem import render

    acc = Acc()
    acc.wrap(render.RendererImage, "render_sim", "render")
    acc.wrap(render, "annotate", "annotate")          # demos/incline.py's extra label
    acc.wrap(render.VideoWriter, "append", "encode")
    acc.wrap(render.VideoWriter, "close", "close")
    mod = importlib.import_module(name)
    out = os.path.join(ROOT, "out", f"bench_render_{name}{'_short' if short else ''}.mp4")
    argv = ["--out", out] + (["--short"] if short else [])
    t0 = time.perf_counter()
    mod.main(argv)
    run = time.perf_counter() - t0
    res = {"demo": name, "run_s": run, "frames": acc.n.get("render", 0),
           "render_s": acc.t.get("render", 0.0) + acc.t.get("annotate", 0.0),
           "encode_s": acc.t.get("encode", 0.0) + acc.t.get("close", 0.0)}
    print("BENCH_RENDER_JSON " + json.dumps(res), flush=True)


def run_demos(names, short):
    rows = []
    for name in names:
        if not os.path.exists(os.path.join(ROOT, "demos", f"{name}.py")):
            continue
        cmd = [sys.executable, os.path.abspath(__file__), "--child", name] + (["--short"] if short else [])
        print(f"running demos/{name}.py{' --short' if short else ''} ...", file=sys.stderr, flush=True)
        p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
        line = [ln for ln in p.stdout.splitlines() if ln.startswith("BENCH_RENDER_JSON ")]
        if p.returncode != 0 or not line:
            print(f"  demos/{name}.py failed (exit {p.returncode}):\n{p.stderr[-2000:]}", file=sys.stderr)
            continue
        rows.append(json.loads(line[-1].split(" ", 1)[1]))
    return rows


def print_demo_table(rows, short):
    print(f"| demo{' (--short)' if short else ''} | run time [s] | frames | render time [s] | "
          "ms/frame | video encode [s] | render share |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        per = 1e3 * r["render_s"] / max(1, r["frames"])
        print(f"| {r['demo']} | {r['run_s']:.1f} | {r['frames']} | {r['render_s']:.2f} | {per:.1f} | "
              f"{r['encode_s']:.2f} | {100 * r['render_s'] / r['run_s']:.1f} % |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--short", action="store_true", help="run the demos in their short mode")
    ap.add_argument("--demos", nargs="*", default=list(DEMOS), help="demos to run (default: all present)")
    ap.add_argument("--no-demos", action="store_true")
    ap.add_argument("--no-frames", action="store_true")
    ap.add_argument("--sizes", nargs="*", type=int, default=[1000, 100_000])
    ap.add_argument("--frames", type=int, default=20, help="timed frames per size and mode")
    ap.add_argument("--modes", nargs="*", default=None)
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        demo_child(args.child, args.short)
        return 0
    if not args.no_frames:
        rows = frame_costs(args.sizes, args.frames, args.modes)
        print("\n### render_sim per frame (960 x 540, default settings)\n")
        print_frame_table(rows)
    if not args.no_demos:
        rows = run_demos(args.demos, args.short)
        print("\n### demos: share of the run time spent rendering\n")
        print_demo_table(rows, args.short)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""GPU benchmark: the pile (benchmarks/pile.py) and the plate impact (benchmarks/fracture.py) on
a GPU and on the CPU in the same run.

    python benchmarks/gpu.py                       # 100k and 1M triangles, f32 and f64, arch="gpu" vs cpu
    python benchmarks/gpu.py --sizes 100000 --precisions f32 --arch vulkan --steps 200
    python benchmarks/gpu.py --tiny                # ~200 triangles, a few steps (what CI runs)

Each (device, scene, size, precision) runs in its own subprocess of this script (Taichi is
initialised once per process) and prints one row: triangles, steps/s, triangle-steps/s, the
compile time (first step minus a later step), the device and its memory:

* ``arrays``: the bytes of every Taichi ndarray the simulation allocated (its model, state and
  scratch arrays, :func:`array_bytes`), on every backend: what the scene needs on the device;
* ``pool``: on CUDA, the memory Taichi pre-allocates, the ``device_memory_GB`` setting
  (``--device-memory-GB``) or, without it, Taichi's default (``device_memory_fraction`` of the
  device); other backends allocate per array and have no pool (``-``).

This is a benchmark, not a test: it asserts only that the runs finish and stay stable.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)


def ndarray_bytes(arr) -> int:
    """Bytes of one Taichi ndarray: its entries × the components of an entry × their size."""
    import numpy as np
    from taichi.lang.util import to_numpy_type
    comps = int(getattr(arr, "n", None) or 1) * int(getattr(arr, "m", None) or 1)     # vector n, matrix n × m
    return int(np.prod(arr.shape, dtype=np.int64)) * comps * np.dtype(to_numpy_type(arr.dtype)).itemsize


def array_bytes(sim) -> int:
    """Bytes of the Taichi ndarrays of ``sim.model``, ``sim.state`` and ``sim.solver.scratch``."""
    import taichi as ti
    seen, total = set(), 0
    for holder in (sim.model, sim.state, sim.solver.scratch):
        for v in vars(holder).values():
            if isinstance(v, ti.lang._ndarray.Ndarray) and id(v) not in seen:
                seen.add(id(v))
                total += ndarray_bytes(v)
    return total


def worker(a) -> dict:
    import taichi_fdem as fdem
    kw = {"device_memory_GB": a.device_memory_GB} if a.device_memory_GB else {}
    fdem.init(arch=a.arch, precision=a.precision, **kw)
    if a.scene == "pile":
        import pile
        scene, _ = pile.build_scene(fdem, a.size)
        sim = scene.build(strategy="parallel")
    else:
        import fracture
        scene, dt, _ = fracture.scene_for(fdem, a.size)
        sim = scene.build(dt=dt, strategy="parallel")
    t0 = time.perf_counter()
    sim.step(1)
    t1 = time.perf_counter()
    sim.step(1)
    t2 = time.perf_counter()
    sim.step(a.steps)
    sim.node_positions()                     # waits for the device
    t3 = time.perf_counter()
    sps = a.steps / (t3 - t2)
    return {"device": sim.info()["device"], "scene": a.scene, "precision": a.precision, "triangles": sim.model.tri_count,
            "steps_per_s": sps, "tri_steps_per_s": sps * sim.model.tri_count, "compile_s": max(0.0, (t1 - t0) - (t2 - t1)),
            "device_memory_GB": a.device_memory_GB, "array_bytes": array_bytes(sim),
            "pool": (f"{a.device_memory_GB} GB" if a.device_memory_GB else "default fraction")
            if sim.info()["device"] == "cuda" else "-",
            "broken": int(getattr(sim, "broken_joint_count", 0))}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    p.add_argument("--precisions", default="f32,f64")
    p.add_argument("--scenes", default="pile,impact")
    p.add_argument("--arch", default="gpu", help="the GPU arch (gpu, cuda, vulkan, metal)")
    p.add_argument("--no-cpu", action="store_true", help="skip the CPU rows")
    p.add_argument("--steps", type=int, default=100)
    p.add_argument("--device-memory-GB", type=float, default=None)
    p.add_argument("--tiny", action="store_true", help="~200 triangles, 5 steps (CI)")
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--scene", default="pile", help=argparse.SUPPRESS)
    p.add_argument("--size", type=int, default=0, help=argparse.SUPPRESS)
    p.add_argument("--precision", default="f64", help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.worker:
        print("ROW " + json.dumps(worker(a)), flush=True)
        return []
    if a.tiny:
        a.sizes, a.steps = [200], 5
    rows = []
    for scene in a.scenes.split(","):
        for size in a.sizes:
            for prec in a.precisions.split(","):
                for arch in [a.arch] + ([] if a.no_cpu else ["cpu"]):
                    cmd = [sys.executable, os.path.abspath(__file__), "--worker", "--scene", scene, "--size", str(size),
                           "--precision", prec, "--arch", arch, "--steps", str(a.steps)]
                    if a.device_memory_GB:
                        cmd += ["--device-memory-GB", str(a.device_memory_GB)]
                    r = subprocess.run(cmd, capture_output=True, text=True)
                    line = [s for s in r.stdout.splitlines() if s.startswith("ROW ")]
                    if r.returncode != 0 or not line:
                        raise RuntimeError(f"{scene} {size} {prec} on {arch} failed:\n{r.stderr[-2000:]}")
                    row = json.loads(line[-1][4:])
                    rows.append(row)
                    print(f"{row['scene']:7s} {row['device']:7s} {row['precision']} {row['triangles']:>9d} tri  "
                          f"{row['steps_per_s']:9.1f} steps/s  {row['tri_steps_per_s']:.3g} tri-steps/s  "
                          f"compile {row['compile_s']:.1f} s  arrays {row['array_bytes'] / 1e6:.3f} MB  pool {row['pool']}",
                          flush=True)
    return rows


if __name__ == "__main__":
    main()

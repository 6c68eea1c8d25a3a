"""Skip what a scene doesn't need: the cost of unused features is (close to) zero.

1. **Unused features.**  One elastic body (a 0.5 × 0.5 m block, ~2000 triangles, no gravity, a
   velocity field that keeps it vibrating) timed in steps/s:

   * ``alone``: one body: no contact detection or contact kernel is compiled or launched;
   * ``+ far fixed body``: the same plus a fixed body 10 m away: contact is on (detection,
     couple loop) but finds no couple;
   * ``+ far body, friction``: the same with a friction coefficient (friction history on);
   * ``+ far body, fracture`` when the package has fracture (``Material(..., fracture=...)``), else skipped.

   Rendering costs nothing unless ``run(video=...)`` is asked for: the core never imports it.

2. **Sparse contact.**  A row of 64 disks, all far apart, of which ``k`` pairs are moved into
   touching distance.  The couple count and the contact phase of ``Simulation.profile`` (parallel
   strategy: one launch per phase) grow with the touching pairs, not with the number of bodies.

    .venv/bin/python benchmarks/skip.py [--seconds 2] [--out docs/skip.md]
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def steps_per_second(sim, seconds: float) -> float:
    sim.step(10)                                    # compile / warm up
    n, t0 = 0, time.perf_counter()
    k = 50
    while time.perf_counter() - t0 < seconds:
        sim.step(k)
        n += k
    return n / (time.perf_counter() - t0)


def unused_features(fdem, seconds: float) -> list:
    E = 1e7
    rows = []
    variants = [("alone", None, {}), ("+ far fixed body", "far", {}), ("+ far body, friction", "far", {"friction": 0.5})]
    try:
        fdem.Material(density=1000.0, young=E, poisson=0.25, fracture=True)
        variants.append(("+ far body, fracture material", "far", {"fracture": True}))
    except TypeError:
        pass
    for name, extra, kw in variants:
        mat = fdem.Material(density=1000.0, young=E, poisson=0.25)
        other = mat.with_(**kw) if kw else mat
        scene = fdem.Scene(gravity=(0.0, 0.0))
        body = scene.add_body(fdem.mesh.rectangle(0.5, 0.5, 0.5 / 32), other if "fracture" in kw else mat,
                              velocity=(0.0, 0.0), angular_velocity=1.0)
        if extra == "far":
            scene.add_body(fdem.mesh.rectangle(0.5, 0.1, 0.05), other, position=(10.0, 0.0), fixed=True)
        sim = scene.build()
        r = sim.info()
        sim.step(10)                                 # compile outside the timing
        rows.append(dict(variant=name, triangles=sim.model.tri_count, moving_triangles=body.mesh.triangle_count,
                         contact=r["contact"], friction=r["friction"], couples=sim.solver.couple_count,
                         steps_per_s=0.0, sim=sim))
    # interleaved rounds, best of each: the machine is shared, so take the least disturbed round
    for _ in range(3):
        for r in rows:
            r["steps_per_s"] = max(r["steps_per_s"], steps_per_second(r["sim"], seconds / 3))
    for r in rows:
        del r["sim"]
        print(r, flush=True)
    base = rows[0]["steps_per_s"]
    for r in rows:
        r["relative"] = r["steps_per_s"] / base
    return rows


def sparse_contact(fdem, pairs=(0, 1, 4, 16, 32), steps: int = 500) -> list:
    rows = []
    R = 0.05
    mat = fdem.Material(density=1000.0, young=1e7, poisson=0.25)
    disk = fdem.mesh.disk(R, R / 4, layout="spiral")
    for k in pairs:
        scene = fdem.Scene(gravity=(0.0, 0.0))
        x = 0.0
        for i in range(32):
            # pair i: two disks; the first k pairs touch (gap 0), the others are 1 m apart
            scene.add_body(disk, mat, position=(x, 0.0), velocity=(0.01, 0.0))
            x += 2 * R if i < k else 1.0
            scene.add_body(disk, mat, position=(x, 0.0), velocity=(-0.01, 0.0))
            x += 1.0
        sim = scene.build(strategy="parallel")
        sim.solver.profile(20)                              # warm up
        prof = min((sim.solver.profile(steps) for _ in range(3)), key=lambda p: p["total"])
        serial = scene.build()
        sps = max(steps_per_second(serial, 0.5) for _ in range(3))
        rows.append(dict(touching_pairs=k, bodies=64, triangles=sim.model.tri_count, couples=sim.solver.couple_count,
                         contact_ms_per_step=1e3 * prof["contact"] / steps,
                         total_ms_per_step=1e3 * prof["total"] / steps, serial_steps_per_s=sps))
        print(rows[-1], flush=True)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="timing per variant [s]")
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "skip.md"))
    args = ap.parse_args(argv)
    import taichi_fdem as fdem
    fdem.init()
    a = unused_features(fdem, args.seconds)
    b = sparse_contact(fdem)
    lines = ["# Skip what a scene doesn't need", "",
             "Generated by `benchmarks/skip.py` on the 2-core development CPU (shared with other jobs: "
             "differences of a few % are noise).", "",
             "## Unused features cost (almost) nothing", "",
             "One elastic block (32 × 32 cells) in every row; the other rows add a fixed body 10 m away, "
             "so contact detection and the couple loop are compiled and run but find nothing.", "",
             "| variant | triangles | contact | friction | couples | steps/s | relative |",
             "|:--|--:|:--|:--|--:|--:|--:|"]
    for r in a:
        lines.append(f"| {r['variant']} | {r['triangles']} | {r['contact']} | {r['friction']} | {r['couples']} | "
                     f"{r['steps_per_s']:.0f} | {r['relative']:.2f} |")
    lines += ["", "Feature switches are `ti.static` template arguments (the kernels are "
              "specialised per combination), so a one-body scene runs a kernel with no contact, friction or "
              "fracture code at all; rendering is only imported by `run(video=...)`.  The residual cost of "
              "contact with no couple is the re-detection bookkeeping (the bounding circles of the far body's "
              "surface triangles and the 2Δt·v_max accumulator), not the narrow phase; with friction on, the "
              "re-detections (the block spins, so they do happen) also carry the friction history over, which "
              "is the ~10 % seen in that row (with the machine's noise of a few %).", "",
              "## Sparse contact: time goes where bodies touch", "",
              "64 disks (32 triangles each) in 32 pairs along a line; the first k pairs touch, the others are "
              "1 m apart.  Contact phase from `Simulation.profile` (parallel strategy, one launch per phase).", "",
              "| touching pairs | triangles | couples | contact ms/step | total ms/step | serial steps/s |",
              "|--:|--:|--:|--:|--:|--:|"]
    for r in b:
        lines.append(f"| {r['touching_pairs']} | {r['triangles']} | {r['couples']} | {r['contact_ms_per_step']:.3f} | "
                     f"{r['total_ms_per_step']:.3f} | {r['serial_steps_per_s']:.0f} |")
    lines += ["", "The couple count is proportional to the touching pairs (about "
              f"{(b[-1]['couples'] / max(1, b[-1]['touching_pairs'])):.0f} per touching pair) and zero for "
              "bodies far apart: the broad phase (hashed grid, counting sort) only pairs triangles whose "
              "bounding circles come within the buffer, and the narrow phase runs over couples only.", ""]
    with open(args.out, "w") as f:
        f.write("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()

"""Fracturing benchmark: a jointed plate hit by a disk, timed through the impact and the fragmentation.

    python benchmarks/fracture.py                       # 10k triangles, 1 and 2 threads
    python benchmarks/fracture.py --sizes 10000 100000 --threads 1 2 --markdown
    python benchmarks/fracture.py --strategy parallel --threads 2
    python benchmarks/fracture.py --smoke               # a few seconds: checks that the script runs

The scene (issue 10): a 0.2 x 0.1 m plate of ~N triangles (nearly square cells cut along
alternating diagonals, ``fdem.mesh.rectangle(..., pattern="alternating")``) with a cohesive
joint on every interior edge (``fracture=True``), hit at the centre of its top edge by an
elastic disk of radius 10 mm at 50 m/s whose lowest point starts one element size above the
plate.  E = 30 GPa, nu = 0.25, rho = 2700 kg/m3, plane strain, no gravity; joints f_t = 5 MPa,
c = 20 MPa, tan(phi) = 0.5, G_I = 50 J/m2, G_II = 100 J/m2, p_f = 10 E; contact penalty 10 E,
tangential penalty 1 E, friction 0.5; damping beta = 0.1;
dt = 0.1 * (smallest altitude) * sqrt(rho / (10 E)).

With that dt the disk needs ~2,980 steps (independent of the mesh size) to close the one-element
gap, so the run is ``max(--steps, first contact + --after-contact)`` steps rounded up to whole
chunks: 8,000 steps by default, 5,000 of them after first contact.

Each (size, thread count) runs in its own subprocess, because Taichi takes
``cpu_max_num_threads`` once, at ``ti.init``.  In that process the kernels are first compiled
(or loaded from the offline cache) on a small copy of the scene, then the full scene is built
and stepped in chunks of ``--chunk`` (1,000) steps with ``Simulation.step``; only the steps are
timed.  After each chunk it records triangle-steps/s, couples, broken joints, detections and the
energy balance |E - E0| / E0.  After the run, ``Simulation.profile`` times each phase over
``--profile-steps`` more steps (the fragmenting plate, well after the impact).

This is a benchmark, not a test: it asserts nothing but that the runs complete.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time

PLATE_W, PLATE_H = 0.2, 0.1          # m
DISK_R = 0.01                        # m
SPEED = 50.0                         # m/s
E, NU, RHO = 30e9, 0.25, 2700.0
PHASES = ("elastic", "joints", "detection", "contact", "integration")


def materials(fdem):
    """(plate, disk) materials of the issue-10 scene."""
    common = dict(density=RHO, young=E, poisson=NU, friction=0.5, damping=0.1, penalty=10.0 * E,
                  tangential_penalty=1.0 * E)
    plate = fdem.Material(**common, tensile_strength=5e6, cohesion=20e6,
                          friction_angle=math.degrees(math.atan(0.5)), fracture_energy=50.0,
                          fracture_energy_shear=100.0, joint_penalty=10.0 * E, name="plate")
    disk = fdem.Material(**common, name="disk")
    return plate, disk


def scene_for(fdem, n_tri: int):
    """The plate-impact scene with about ``n_tri`` plate triangles.

    Returns (scene, dt, layout dict).
    """
    h = math.sqrt(2.0 * PLATE_W * PLATE_H / n_tri)          # 2 triangles per h x h cell
    plate_mat, disk_mat = materials(fdem)
    plate = fdem.mesh.rectangle(PLATE_W, PLATE_H, h, pattern="alternating")
    disk = fdem.mesh.disk(DISK_R, h, layout="spiral")
    scene = fdem.Scene(gravity=(0.0, 0.0), plane="strain")
    scene.add_body(plate, plate_mat, fracture=True, name="plate")
    # ``position`` places the disk's centroid; put its lowest node one element size above the top edge
    top = float(plate.points[:, 1].max())
    cy = float(disk.centroid[1])
    lowest = float(disk.points[:, 1].min())
    gap = h
    scene.add_body(disk, disk_mat, position=(0.0, top + gap + (cy - lowest)), velocity=(0.0, -SPEED), name="disk")
    alt = min(plate.min_altitude(), disk.min_altitude())
    dt = 0.1 * alt * math.sqrt(RHO / (10.0 * E))
    return scene, dt, {"h": h, "gap": gap, "min_altitude": alt, "disk_triangles": disk.triangle_count,
                       "plate_triangles": plate.triangle_count}


# ---- one (size, threads) run, in its own process --------------------------------------------
def worker(args) -> dict:
    import taichi as ti
    import taichi_fdem as fdem
    fdem.init(arch="cpu", precision=args.precision, cpu_max_num_threads=args.worker_threads)
    threads = int(ti.lang.impl.current_cfg().cpu_max_num_threads)

    # compile (or load) every kernel the run and the profile use, on a small copy of the scene
    t0 = time.perf_counter()
    small, small_dt, _ = scene_for(fdem, 400)
    s = small.build(dt=small_dt, strategy=args.strategy)
    s.step(2)
    s.solver.profile(2)
    s.energies()
    compile_s = time.perf_counter() - t0

    t0 = time.perf_counter()
    scene, dt, lay = scene_for(fdem, args.worker_size)
    sim = scene.build(dt=dt, strategy=args.strategy, handover_damage=args.handover_damage)
    if args.force_blocks:
        sim.solver.force_blocks = args.force_blocks
    build_s = time.perf_counter() - t0
    if sim.solver.strategy != s.solver.strategy:
        # "auto" resolved otherwise for the real scene than for the small copy: compile (or load)
        # that strategy's kernels too, before the timed run (otherwise the first timed chunk pays
        # the compile)
        t0 = time.perf_counter()
        s.solver.strategy = sim.solver.strategy
        s.step(2)
        compile_s += time.perf_counter() - t0
    del s, small
    info = sim.info()
    ntri = info["triangles"]
    e0 = sim.energies()["total"]
    contact_step = int(math.ceil(lay["gap"] / (SPEED * dt)))      # the disk moves rigidly until then
    chunk = args.chunk
    total = max(args.steps, contact_step + args.after_contact) if args.after_contact > 0 else args.steps
    total = chunk * int(math.ceil(total / chunk))
    print(f"  [{ntri:,} triangles, {threads} thread(s), strategy {sim.solver.strategy}] {info['joints']:,} joints, "
          f"dt = {dt:.4g} s, first contact at step ~{contact_step:,}, {total:,} steps in chunks of {chunk:,}; "
          f"kernels ready in {compile_s:.1f} s, build {build_s:.2f} s", flush=True)

    chunks = []
    det_prev = sim.solver.detection_count
    for k in range(total // chunk):
        t0 = time.perf_counter()
        sim.step(chunk)
        wall = time.perf_counter() - t0
        det = sim.solver.detection_count
        e = sim.energies()
        c = {"first": k * chunk + 1, "last": (k + 1) * chunk, "seconds": wall,
             "mtri_steps_per_s": chunk * ntri / wall / 1e6, "couples": sim.solver.couple_count,
             "broken": sim.cracks.broken_count, "detections": det - det_prev,
             "energy_error": abs(e["total"] - e0) / e0, "contact_started": (k + 1) * chunk >= contact_step}
        det_prev = det
        chunks.append(c)
        print(f"    steps {c['first']:>6,}-{c['last']:<6,} {c['mtri_steps_per_s']:6.2f} M tri-steps/s  "
              f"{c['couples']:>8,} couples  {c['broken']:>6,} broken  {c['detections']:>3} detections  "
              f"|dE|/E0 {c['energy_error']:.2e}", flush=True)
    e_end = sim.energies()

    def rate(sel):
        secs = sum(c["seconds"] for c in sel)
        return len(sel) * chunk * ntri / secs / 1e6 if secs > 0 else float("nan")

    first_window = [c for c in chunks if c["last"] <= args.steps]
    after = [c for c in chunks if c["first"] > contact_step]

    prof = None
    if args.profile_steps > 0:
        p = sim.solver.profile(args.profile_steps)
        tot = sum(p[k] for k in PHASES) or 1.0
        prof = {"steps": args.profile_steps, "ms_per_step": 1e3 * tot / args.profile_steps,
                "couples": sim.solver.couple_count, "broken": sim.cracks.broken_count,
                "first": sim.step_count - args.profile_steps + 1, "last": sim.step_count,
                "shares": {k: p[k] / tot for k in PHASES},
                "ms": {k: 1e3 * p[k] / args.profile_steps for k in PHASES}}
        print(f"    profile of steps {prof['first']:,}-{prof['last']:,}: {prof['ms_per_step']:.2f} ms/step; "
              + ", ".join(f"{k} {prof['shares'][k]:.0%}" for k in PHASES), flush=True)

    return {"triangles": ntri, "joints": info["joints"], "nodes": info["nodes"], "threads": threads,
            "requested_threads": args.worker_threads, "strategy": sim.solver.strategy, "precision": args.precision,
            "handover_damage": args.handover_damage, "force_blocks": sim.solver.force_blocks,
            "dt": dt, "h": lay["h"], "contact_step": contact_step, "steps": total, "chunk": chunk,
            "compile_s": compile_s, "build_s": build_s, "run_s": sum(c["seconds"] for c in chunks),
            "rate_all": rate(chunks), "rate_first_window": rate(first_window) if first_window else None,
            "first_window_steps": len(first_window) * chunk, "rate_after_contact": rate(after) if after else None,
            "after_contact_steps": len(after) * chunk,
            "rate_min_chunk": min(c["mtri_steps_per_s"] for c in chunks),
            "couples_max": max(c["couples"] for c in chunks), "broken": sim.cracks.broken_count,
            "broken_at_end_of_run": chunks[-1]["broken"],
            "energy_error_end": abs(e_end["total"] - e0) / e0,
            "energy_error_max": max(c["energy_error"] for c in chunks),
            "e0": e0, "fracture_energy": e_end["fracture"], "chunks": chunks, "profile": prof}


# ---- the driver: one subprocess per (size, threads) ------------------------------------------
def run_subprocess(args, size: int, threads: int) -> dict:
    cmd = [sys.executable, os.path.abspath(__file__), "--worker-size", str(size), "--worker-threads", str(threads),
           "--steps", str(args.steps), "--after-contact", str(args.after_contact), "--chunk", str(args.chunk),
           "--strategy", args.strategy, "--precision", args.precision, "--profile-steps", str(args.profile_steps),
           "--handover-damage", repr(args.handover_damage), "--force-blocks", str(args.force_blocks)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
    result, tail = None, []
    for line in proc.stdout:
        if line.startswith("RESULT "):
            result = json.loads(line[len("RESULT "):])
        elif not line.startswith("[Taichi]"):
            print(line, end="", flush=True)
            tail = (tail + [line])[-40:]
    rc = proc.wait()
    if rc != 0 or result is None:
        raise RuntimeError(f"fracture benchmark subprocess failed (size {size}, {threads} threads, rc={rc}):\n"
                           + "".join(tail))
    return result


def _f(v, fmt):
    return "n/a" if v is None or (isinstance(v, float) and math.isnan(v)) else fmt.format(v)


def table(head, rows, markdown: bool, left=()):
    if markdown:
        print("| " + " | ".join(head) + " |")
        print("|" + "|".join(":---" if i in left else "---:" for i in range(len(head))) + "|")
        for r in rows:
            print("| " + " | ".join(r) + " |")
    else:
        w = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(head)]
        print("  ".join(h.rjust(w[i]) for i, h in enumerate(head)))
        for r in rows:
            print("  ".join(c.rjust(w[i]) for i, c in enumerate(r)))


def report(results, args) -> None:
    md = args.markdown
    print(f"\nFracture benchmark: plate impact (issue 10), {args.precision}, strategy {args.strategy}, "
          f"handover_damage {args.handover_damage:g}"
          + (f", force_blocks {args.force_blocks}" if args.force_blocks else "") + "\n")
    head = ["triangles", "joints", "threads", "strategy", "steps", "1st contact", "M tri-steps/s (all)",
            f"first {args.steps:,}", "after contact", "slowest chunk", "max couples", "broken", "ΔE/E0 end",
            "run s", "kernels s"]
    rows = [[f"{r['triangles']:,}", f"{r['joints']:,}", str(r["threads"]), r["strategy"], f"{r['steps']:,}",
             f"{r['contact_step']:,}", _f(r["rate_all"], "{:.2f}"), _f(r["rate_first_window"], "{:.2f}"),
             _f(r["rate_after_contact"], "{:.2f}"), _f(r["rate_min_chunk"], "{:.2f}"), f"{r['couples_max']:,}",
             f"{r['broken_at_end_of_run']:,}", f"{r['energy_error_end']:.1e}", f"{r['run_s']:.1f}",
             f"{r['compile_s']:.1f}"] for r in results]
    table(head, rows, md, left=(3,))

    print("\nPer chunk (M triangle-steps/s; couples, broken joints and ΔE/E0 = |E - E0| / E0 at the end of the chunk)\n")
    head = ["triangles", "threads", "steps", "M tri-steps/s", "couples", "broken", "detections", "ΔE/E0"]
    rows = []
    for r in results:
        for c in r["chunks"]:
            mark = "" if c["first"] > r["contact_step"] else (" (contact)" if c["last"] >= r["contact_step"] else
                                                                " (before)")
            rows.append([f"{r['triangles']:,}", str(r["threads"]), f"{c['first']:,}-{c['last']:,}{mark}",
                         f"{c['mtri_steps_per_s']:.2f}", f"{c['couples']:,}", f"{c['broken']:,}",
                         str(c["detections"]), f"{c['energy_error']:.1e}"])
    table(head, rows, md, left=(2,))

    if any(r["profile"] for r in results):
        print("\nPhase profile (Simulation.profile: one launch per phase) after the run\n")
        head = ["triangles", "threads", "steps", "couples", "ms/step"] + list(PHASES)
        rows = []
        for r in results:
            p = r["profile"]
            if not p:
                continue
            rows.append([f"{r['triangles']:,}", str(r["threads"]), f"{p['first']:,}-{p['last']:,}",
                         f"{p['couples']:,}", f"{p['ms_per_step']:.2f}"]
                        + [f"{p['shares'][k]:.0%} ({p['ms'][k]:.2f} ms)" for k in PHASES])
        table(head, rows, md, left=(2,))

    by = {(r["triangles"], r["threads"]): r for r in results}
    lines = []
    for (n, t), r in sorted(by.items()):
        one = by.get((n, 1))
        if t != 1 and one:
            lines.append(f"{n:,} triangles: {t} threads / 1 thread = {r['rate_all'] / one['rate_all']:.2f}x "
                         f"over the whole run, {_f(_ratio(r, one, 'rate_after_contact'), '{:.2f}')}x after contact")
    if lines:
        print("\n" + "\n".join(lines))


def _ratio(a, b, key):
    return a[key] / b[key] if a.get(key) and b.get(key) else None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[10000],
                    help="plate triangle counts (default 10000; 100000 is the large case)")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2],
                    help="CPU thread counts (cpu_max_num_threads), each in its own process (default 1 2)")
    ap.add_argument("--steps", type=int, default=6000, help="at least this many steps (default 6000)")
    ap.add_argument("--after-contact", type=int, default=5000,
                    help="and at least this many steps after first contact (default 5000; 0: exactly --steps)")
    ap.add_argument("--chunk", type=int, default=1000, help="steps per timed chunk (default 1000)")
    ap.add_argument("--strategy", default="auto", help="auto (default), serial or parallel")
    ap.add_argument("--precision", choices=("f64", "f32"), default="f64")
    ap.add_argument("--handover-damage", type=float, default=0.0,
                    help="Scene.build(handover_damage=...): damage at which a joint hands its pair over to "
                         "contact (default 0, the library's: the first damage; 0.05 is the speed option)")
    ap.add_argument("--force-blocks", type=int, default=0,
                    help="Simulation.force_blocks of the parallel strategy (default 0: the library's, 2)")
    ap.add_argument("--profile-steps", type=int, default=200,
                    help="steps of the phase profile after the run (default 200; 0: none)")
    ap.add_argument("--markdown", action="store_true", help="print Markdown tables")
    ap.add_argument("--json", default=None, help="also write every measured number to this JSON file")
    ap.add_argument("--smoke", action="store_true",
                    help="a tiny run (600 triangles, 1 thread, 300 steps, no wait for contact) to check the script")
    ap.add_argument("--worker-size", type=int, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--worker-threads", type=int, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.strategy not in ("auto", "serial", "parallel"):
        ap.error(f"unknown strategy {args.strategy!r}")

    if args.worker_size is not None:
        res = worker(args)
        print("RESULT " + json.dumps(res), flush=True)
        return res

    if args.smoke:
        args.sizes, args.threads, args.steps, args.after_contact, args.chunk = [600], [1], 300, 0, 100
        args.profile_steps = min(args.profile_steps, 10)
    import platform
    print(f"fracture benchmark: sizes {args.sizes}, threads {args.threads}, strategy {args.strategy}, "
          f"{args.precision}; {os.cpu_count()} CPUs, python {platform.python_version()}", flush=True)
    t_all = time.perf_counter()
    results = [run_subprocess(args, n, t) for n in args.sizes for t in args.threads]
    report(results, args)
    print(f"\n(total benchmark time {time.perf_counter() - t_all:.0f} s)")
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)
        print(f"results written to {args.json}")
    return results


if __name__ == "__main__":
    main()

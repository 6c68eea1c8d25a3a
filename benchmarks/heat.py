"""Wall time per mechanical step of a heated scene whose heat step is below the mechanical one
(the heat sub-cycles every step: the regime of a time-scaled conductivity), and of the same scene
pressed against a second body (contact conduction).

    python benchmarks/heat.py [--steps N] [--threads T] [--json PATH]

A strip 1 m × 0.1 m (h = 12.5 mm, 1,280 triangles) held at 1 K at its left end, κ = 1 m²/s, so that
the heat takes about a dozen heat steps per mechanical step; each strategy runs 300 steps to warm
up, then ``N`` timed steps.  Prints ms per mechanical step, the heat steps per mechanical step and
the launches per step; the temperatures' sum is printed as a check that trees agree.
"""
import argparse
import json
import time
import warnings

import numpy as np

import taichi_fdem as fdem


def scene(contact: bool):
    sc = fdem.Scene(gravity=(0.0, 0.0))
    mat = fdem.Material(density=1000.0, young=1e5, poisson=0.25, conductivity=1.0, heat_capacity=1e-3)
    sc.add_body(fdem.mesh.rectangle(1.0, 0.1, 0.0125, origin=(0.0, 0.0)), mat, fixed=contact)
    if contact:
        other = sc.add_body(fdem.mesh.rectangle(0.2, 0.1, 0.0125, origin=(1.0 - 2.5e-5, 0.0)), mat)
        sc.fix_nodes(lambda x, y: x < 1.15, body=other)
    sc.set_temperature(0.0)
    sc.heat(lambda x, y: x < 1e-9, temperature=1.0)
    return sc


def run(strategy: str, contact: bool, steps: int) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)       # the pressed bodies overlap at the start
        sim = scene(contact).build(strategy=strategy)
    sim.step(300)
    before = sum(sim.solver.launches.values())
    t0 = time.perf_counter()
    sim.step(steps)
    wall = time.perf_counter() - t0
    launches = sum(sim.solver.launches.values()) - before
    return {"strategy": strategy, "contact": contact, "ms_per_step": wall / steps * 1e3,
            "heat_steps_per_step": sim.dt / float(sim.state.heat_real.to_numpy()[1]),
            "launches_per_step": launches / steps, "temperature_sum": float(np.sum(sim.temperatures()))}


def main(argv=None) -> list:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    fdem.init(arch="cpu", cpu_max_num_threads=args.threads)
    rows = [run(s, c, args.steps) for c in (False, True) for s in ("serial", "parallel")]
    for r in rows:
        print(f"{r['strategy']:9s} contact={r['contact']!s:5s} {r['ms_per_step']:7.3f} ms/step  "
              f"{r['heat_steps_per_step']:5.1f} heat steps/step  {r['launches_per_step']:4.1f} launches/step  "
              f"ΣT = {r['temperature_sum']:.12g}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return rows


if __name__ == "__main__":
    main()

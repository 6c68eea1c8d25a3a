"""Cost of one contact couple [ns], by path: box rejected, early out, touching.

    python benchmarks/contact.py [--pairs 20000] [--steps 200] [--friction 0.5]

Two bodies, each a set of ``--pairs`` disjoint right triangles (side h) on a coarse lattice, so
that every triangle of A meets exactly one triangle of B:

* ``box``: B's triangle lies beside A's, within the contact buffer (a couple) but their boxes do
  not overlap: the cheapest path (:func:`taichi_fdem.engine.contact.boxes_overlap`);
* ``early out``: the boxes overlap but B lies wholly outside one edge line of A (the exact
  early out of ``contact_pass``);
* ``touching``: B's corner penetrates A by 1 % of h: both passes clip edges and integrate.

Two measures, on one thread:

* **phase**: the contact phase alone (``Simulation.profile``, its own launch, forces added with
  atomics) divided by the couple count;
* **step**: what a couple adds to a step of the parallel strategy (team launch, block
  assembly, no atomics: the path the simulations take), i.e. the step time of the case less
  that of the same bodies set apart beyond the buffer (``far``: no couples), per couple.

No gravity, no friction unless ``--friction`` (the plate impact of ``fracture.py`` has 0.5:
the pass then also reads the node velocities); the bodies are held still (A prescribed at rest,
B free and pushed only over a few steps), so the geometry stays as built.  A benchmark: it
asserts nothing.
"""
from __future__ import annotations

import argparse
import math


def scene(fdem, pairs: int, case: str, h: float = 0.01, friction: float = 0.0):
    import numpy as np
    n = int(math.ceil(math.sqrt(pairs)))
    ij = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), -1).reshape(-1, 2)[:pairs]
    origin = ij * (4.0 * h)
    tri = np.array([[0.0, 0.0], [h, 0.0], [0.0, h]])
    offset = {"box": (0.0, 1.05 * h),               # B above A: boxes apart, circles within reach
              "early out": (0.55 * h, 0.55 * h),    # B beyond A's hypotenuse, boxes overlapping
              "touching": (0.49 * h, 0.49 * h),      # B's corner 1 % of h inside A
              "far": (2.0 * h, 2.0 * h)}[case]        # beyond the buffer: no couples
    pts_a = (origin[:, None, :] + tri[None]).reshape(-1, 2)
    pts_b = (origin[:, None, :] + tri[None] + np.array(offset)).reshape(-1, 2)
    cells = np.arange(3 * pairs).reshape(-1, 3)
    mat = fdem.Material(density=1000.0, young=1e7, poisson=0.25, friction=friction)
    sc = fdem.Scene(gravity=(0.0, 0.0))
    sc.add_body(fdem.mesh.TriMesh(pts_a, cells), mat, prescribed_velocity=(0.0, 0.0), name="A")
    sc.add_body(fdem.mesh.TriMesh(pts_b, cells), mat, name="B")       # free: pairs of fixed bodies are no couples
    return sc


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pairs", type=int, default=20000)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--friction", type=float, default=0.0, help="friction coefficient of the bodies (default 0)")
    args = ap.parse_args()
    import taichi_fdem as fdem
    fdem.init(cpu_max_num_threads=1)
    import time
    print(f"friction {args.friction}\n")
    print("| path | couples | ns per couple, phase | ns per couple, step |\n|:--|---:|---:|---:|")

    def step_time(case):
        sim = scene(fdem, args.pairs, case, friction=args.friction).build(strategy="parallel", check_overlap=False,
                                                                          force_dt=True)
        sim.step(50)
        sim.step(50)                                          # compiled, team engaged
        t0 = time.perf_counter()
        sim.step(2 * args.steps)
        return (time.perf_counter() - t0) / (2 * args.steps)

    base = step_time("far")
    for case in ("box", "early out", "touching"):
        sim = scene(fdem, args.pairs, case, friction=args.friction).build(strategy="serial", check_overlap=False,
                                                                          force_dt=True)
        sim.profile(5)                                        # compile
        prof = sim.profile(args.steps)
        n = max(1, sim.couple_count)
        ns = prof["contact"] / args.steps / n * 1e9
        ns_step = (step_time(case) - base) / n * 1e9
        print(f"| {case} | {sim.couple_count:,} | {ns:.0f} | {ns_step:.0f} |")


if __name__ == "__main__":
    main()

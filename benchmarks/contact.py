"""Cost of one contact couple [ns], by path: certified apart, box test, separating-axis test, touching.

    python benchmarks/contact.py [--pairs 20000] [--steps 200] [--friction 0.5]

Two bodies, each a set of ``--pairs`` disjoint right triangles (side h) on a coarse lattice, so
that every triangle of A meets exactly one triangle of B (a couple: within the contact buffer):

* ``certified``: B lies beyond A's hypotenuse by 0.07 h, boxes overlapping: its certificate of
  separation (:func:`taichi_fdem.engine.contact.couple_forces`) skips it for one read until the
  nodes have moved by that gap (in the step measure; the phase measure's launches reset the
  certificates, so there it is tested like ``apart``);
* ``box``: B lies just above A, their boxes apart by 1e-9 h, below the certificates' rounding
  margin, so it is tested every step: the box test alone
  (:func:`taichi_fdem.engine.contact.box_gap`);
* ``apart``: B's corner lies just beyond A's hypotenuse (1e-9 h), boxes overlapping: the
  separating-axis test every step (:func:`taichi_fdem.engine.contact.couple_certificate`), the
  common case of the neighbours of a fragmenting mesh, which lie apart by less than the margin;
* ``touching``: B's corner penetrates A by 1 % of h: both passes clip edges and integrate.

Two measures, on one thread:

* **phase**: the contact phase alone (``Simulation.profile``, its own launch, forces added with
  atomics) divided by the couple count;
* **step**: what a couple adds to a step of the parallel strategy (team launch, block
  assembly, no atomics: the path the simulations take), i.e. the step time of the case less
  that of the same bodies set apart beyond the buffer (``far``: no couples), per couple.

No gravity, no friction unless ``--friction`` (the plate impact of ``fracture.py`` has 0.5:
the pass then also reads the node velocities).  A is prescribed at rest; B is free (pairs of
fixed bodies are no couples) but 1000 times denser, so that the contact forces leave the
geometry as built: the last two columns say how far B's nodes moved over the timed steps
(relative to h) and how many couples still overlap at their end (all of them in the touching
case; before B was made heavy, the contact pushed it out of A during the warm-up steps and the
touching case timed couples that no longer touched: 69 ns on the Intel host, 12 ns on the AMD
host where a touching couple costs ~400 ns).  A benchmark: it asserts nothing.
"""
from __future__ import annotations

import argparse
import math


H = 0.01    # side of the triangles [m]


def scene(fdem, pairs: int, case: str, h: float = H, friction: float = 0.0):
    import numpy as np
    n = int(math.ceil(math.sqrt(pairs)))
    ij = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), -1).reshape(-1, 2)[:pairs]
    origin = ij * (4.0 * h)
    tri = np.array([[0.0, 0.0], [h, 0.0], [0.0, h]])
    tiny = 1e-9 * h                                  # below the certificates' rounding margin, 1e-8 h
    offset = {"certified": (0.55 * h, 0.55 * h),     # B beyond A's hypotenuse by 0.07 h: skipped
              "box": (0.0, h + tiny),                # B just above A: boxes apart, tested every step
              "apart": (0.5 * h + tiny, 0.5 * h + tiny),   # B's corner just beyond A's hypotenuse
              "touching": (0.49 * h, 0.49 * h),      # B's corner 1 % of h inside A
              "far": (2.0 * h, 2.0 * h)}[case]        # beyond the buffer: no couples
    pts_a = (origin[:, None, :] + tri[None]).reshape(-1, 2)
    pts_b = (origin[:, None, :] + tri[None] + np.array(offset)).reshape(-1, 2)
    cells = np.arange(3 * pairs).reshape(-1, 3)
    mat = fdem.Material(density=1000.0, young=1e7, poisson=0.25, friction=friction)
    # B is free (pairs of fixed bodies are no couples) but so heavy that the contact forces do not
    # move it over the run: a B of the same density as A was pushed out of A within the warm-up
    # steps, after which the "touching" case timed couples that no longer touched
    heavy = fdem.Material(density=1.0e6, young=1e7, poisson=0.25, friction=friction)
    sc = fdem.Scene(gravity=(0.0, 0.0))
    sc.add_body(fdem.mesh.TriMesh(pts_a, cells), mat, prescribed_velocity=(0.0, 0.0), name="A")
    sc.add_body(fdem.mesh.TriMesh(pts_b, cells), heavy, name="B")
    return sc


def touching(sim) -> int:
    """How many couples overlap (positive overlap area) at the current positions."""
    import numpy as np
    import taichi as ti
    from taichi_fdem import backend
    from taichi_fdem.engine.diagnostics import overlap_areas
    n = sim.solver.couple_count
    if n == 0:
        return 0
    st, md = sim.state, sim.model
    out = ti.ndarray(backend.real_ti(), shape=n)
    overlap_areas(st.node_x, md.tri_nodes, st.couple_a, st.couple_b, n, st.tri_nb_on, md.nb_count, out)
    return int(np.count_nonzero(out.to_numpy() > 0.0))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pairs", type=int, default=20000)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--friction", type=float, default=0.0, help="friction coefficient of the bodies (default 0)")
    args = ap.parse_args()
    import taichi_fdem as fdem
    fdem.init(cpu_max_num_threads=1)
    import time
    print(f"friction {args.friction}, {args.pairs:,} pairs, 1 thread\n")
    print("| path | couples | ns per couple, phase | ns per couple, step | B moved / h | overlapping at the end |\n|:--|---:|---:|---:|---:|---:|")

    def step_time(case):
        sim = scene(fdem, args.pairs, case, friction=args.friction).build(strategy="parallel", check_overlap=False,
                                                                          force_dt=True)
        sim.step(50)
        sim.step(50)                                          # compiled, team engaged
        x0 = sim.node_positions()
        t0 = time.perf_counter()
        sim.step(2 * args.steps)
        el = (time.perf_counter() - t0) / (2 * args.steps)
        moved = float(abs(sim.node_positions() - x0).max())
        return el, moved, touching(sim)

    base, _, _ = step_time("far")
    for case in ("certified", "box", "apart", "touching"):
        sim = scene(fdem, args.pairs, case, friction=args.friction).build(strategy="serial", check_overlap=False,
                                                                          force_dt=True)
        sim.solver.profile(5)                                        # compile
        prof = sim.solver.profile(args.steps)
        n = max(1, sim.solver.couple_count)
        ns = prof["contact"] / args.steps / n * 1e9
        t_case, moved, still = step_time(case)
        ns_step = (t_case - base) / n * 1e9
        print(f"| {case} | {sim.solver.couple_count:,} | {ns:.0f} | {ns_step:.0f} | {moved / H:.1e} | {still:,} |")


if __name__ == "__main__":
    main()

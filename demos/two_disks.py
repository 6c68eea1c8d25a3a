"""Two equal elastic disks collide head-on (no gravity, no friction, no damping).

    python demos/two_disks.py            # writes out/two_disks.mp4
    python demos/two_disks.py --short    # a quick version (used by tests/test_demos.py)

Disk A moves at V towards disk B at rest.  Like billiard balls, equal bodies in a head-on
elastic collision exchange their velocities; deformable disks keep a little of the energy as
vibration, so the exchange is approximate.  ``check`` verifies at the end that total momentum is
conserved to 1e-10 (relative), that the velocities are approximately exchanged and that the
total energy (kinetic + strain + contact) stays within 1 % of the initial kinetic energy.
"""
from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "two_disks"
RADIUS = 0.1          # m
V = V_A = 1.0         # m/s, initial speed of disk A
MATERIAL = dict(density=1000.0, young=1.0e7, poisson=0.3, friction=0.0, damping=0.0)   # rubber-like
VMAX_STRESS = 1.5e5   # Pa, top of the colour scale of the video


def build(short: bool):
    """The scene of taichi_fdem.verification.two_disks_scene (one copy, shared with the tests):
    B is A's mesh mirrored about the y axis, so the collision is mirror-symmetric about x = 0
    and the contact force is exactly along x (the meshed disks are polygons, not circles)."""
    from taichi_fdem import verification as V
    h = 0.4 * RADIUS if short else 0.1 * RADIUS
    gap = 0.1 * RADIUS if short else 0.5 * RADIUS      # initial gap between the two disks [m]
    sim, a, b = V.two_disks_scene(RADIUS, h, velocity_a=(V_A, 0.0), velocity_b=(0.0, 0.0), gap=gap,
                                  material=dict(MATERIAL, name="rubber"))
    # contact lasts ~ pi sqrt(m_red / k), a few ms here; run until B is well clear of A
    duration = (gap / V_A) + (0.012 if short else 0.15)
    return sim, (a, b), duration


def state(sim, bodies) -> dict:
    kin = [sim.body_motion(b) for b in bodies]
    e = sim.energies()
    return {"mass": [k.mass for k in kin], "com": [k.center for k in kin], "momentum": [k.momentum for k in kin],
            "velocity": [k.velocity for k in kin], "energy": e}


def check(sim, bodies, initial: dict | None = None) -> dict:
    """Physics checks after the collision; asserts and returns the numbers.

    ``initial`` is the :func:`state` before the run (default: recomputed from the initial
    conditions of the scene, A at (V, 0), B at rest).
    """
    a, b = bodies
    final = state(sim, bodies)
    if initial is None:
        m = final["mass"]
        initial = {"momentum": [np.array([m[0] * V, 0.0]), np.zeros(2)],
                   "velocity": [np.array([V, 0.0]), np.zeros(2)],
                   "energy": {"total": 0.5 * m[0] * V * V, "kinetic": 0.5 * m[0] * V * V}}
    p0 = initial["momentum"][0] + initial["momentum"][1]
    p1 = final["momentum"][0] + final["momentum"][1]
    dp_rel = float(np.linalg.norm(p1 - p0) / np.linalg.norm(p0))
    va0, vb0 = initial["velocity"]
    va1, vb1 = final["velocity"]
    # exchange: A ends with B's initial velocity and B with A's (errors relative to V)
    exch_a = float(np.linalg.norm(va1 - vb0) / V)
    exch_b = float(np.linalg.norm(vb1 - va0) / V)
    e0, e1 = initial["energy"], final["energy"]
    de_rel = float(abs(e1["total"] - e0["total"]) / e0["kinetic"])
    # apart again: no contact energy left and B moving away from A
    separated = bool(abs(final["energy"]["contact"]) <= 1e-9 * initial["energy"]["kinetic"]
                     and (vb1 - va1)[0] > 0.5 * V)
    out = {"momentum_rel_error": dp_rel, "exchange_error_A": exch_a, "exchange_error_B": exch_b,
           "velocity_A": va1.tolist(), "velocity_B": vb1.tolist(), "energy_rel_error": de_rel,
           "kinetic_fraction_kept": float(e1["kinetic"] / e0["kinetic"]),
           "couples_end": sim.solver.couple_count, "separated": separated}
    assert dp_rel < 1e-10, f"momentum not conserved: relative error {dp_rel:.3g}"
    assert separated, "the disks did not separate"
    assert exch_a < 0.05 and exch_b < 0.05, f"velocities not exchanged: A {va1}, B {vb1} (V = {V})"
    assert de_rel < 0.01, f"total energy drifted by {100 * de_rel:.3g} % of the initial kinetic energy"
    return out


def main(argv=None) -> dict:
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], argv)
    clock = _common.Timer()
    _common.init(args.precision)
    import taichi_fdem as fdem
    from taichi_fdem.render import RendererImage

    sim, bodies, duration = build(args.short)
    initial = state(sim, bodies)
    frames = 12 if args.short else 50            # 3.3 s of video at 15 fps (rendering < 10 % of the run)
    size = (320, 160) if args.short else (960, 384)
    view = (-2.6 * RADIUS, 4.0 * RADIUS, -1.3 * RADIUS, 1.3 * RADIUS) if not args.short else \
        (-2.2 * RADIUS, 2.2 * RADIUS, -1.1 * RADIUS, 1.1 * RADIUS)
    # colour: von Mises stress on a fixed scale (the contact stress appears during the impact)
    renderer = RendererImage(*size, view=view, color_by="von_mises", vmin=0.0, vmax=VMAX_STRESS,
                             colorbar=not args.short, stamp=not args.short)
    info = sim.info()
    print(f"{NAME}: {info['triangles']} triangles, dt = {info['dt']:.3g} s, {duration:.3g} s simulated "
          f"({int(round(duration / sim.dt)):,} steps), strategy {info['strategy']}")
    sim.run(duration, record=[fdem.Video(args.out, fps=15, frame_dt=duration / frames, renderer=renderer)],
            progress=False)
    result = check(sim, bodies, initial)
    result["video"] = os.path.abspath(args.out)
    result["wall_s"] = clock()
    result["steps"] = sim.step_count
    va, vb = result["velocity_A"], result["velocity_B"]
    print(f"  before: v_A = {_common.fmt_vec(initial['velocity'][0])} m/s, v_B = {_common.fmt_vec(initial['velocity'][1])} m/s")
    print(f"  after:  v_A = {_common.fmt_vec(va)} m/s, v_B = {_common.fmt_vec(vb)} m/s "
          f"(exchange errors {result['exchange_error_A']:.2%}, {result['exchange_error_B']:.2%} of V)")
    print(f"  momentum relative error {result['momentum_rel_error']:.2e}; total energy error "
          f"{result['energy_rel_error']:.3%} of the initial kinetic energy; "
          f"{result['kinetic_fraction_kept']:.1%} of it is kinetic again (the rest vibrates)")
    print(f"  wrote {args.out}; {result['wall_s']:.1f} s wall time")
    return result


if __name__ == "__main__":
    main()
    sys.exit(0)

"""A projectile fragments a jointed plate (every interior edge a cohesive joint).

    python demos/fragment_plate.py            # writes out/fragment_plate.mp4
    python demos/fragment_plate.py --short    # a quick version (used by tests/test_demos.py)

A stiff disc hits the middle of a free brittle plate (no gravity).  Joints break, fragments fly
off, and the broken faces interact only by contact.  ``check`` verifies that joints broke, that
the plate is in at least two fragments (connected components through intact joints), and that
the energy balance (kinetic + strain + contact + joints + fracture work) stays within 2 % of the
initial kinetic energy throughout.  The video is coloured by joint damage.
"""
from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "fragment_plate"
SPEED = 30.0       # m/s


def build(short: bool):
    """The scene of taichi_fdem.verification.fragment_plate_scene (one copy, shared with the tests)."""
    from taichi_fdem import verification as V
    sim, bodies = V.fragment_plate_scene(h_plate=0.02 if short else 0.008, h_ball=0.015 if short else 0.006,
                                         speed=SPEED)
    duration = 0.006 if short else 0.012
    return sim, bodies, duration


def main(argv=None) -> dict:
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], argv)
    clock = _common.Timer()
    _common.init(args.precision)
    import taichi_fdem as fdem
    from taichi_fdem.render import RendererImage

    sim, (plate, ball), duration = build(args.short)
    info = sim.info()
    print(f"{NAME}: {info['triangles']} triangles, {info['joints']} joints, dt = {info['dt']:.3g} s, "
          f"{duration:.3g} s simulated")
    e0 = sim.energies()["total"]
    worst = [0.0]
    frames = 12 if args.short else 150
    size = (320, 200) if args.short else (960, 600)
    renderer = RendererImage(*size, view=(-0.3, 0.3, -0.2, 0.15), color_by="damage", vmin=0.0, vmax=1.0,
                             colorbar=not args.short, stamp=not args.short)

    def watch(s, *a, **k):
        worst[0] = max(worst[0], abs(s.energies()["total"] - e0) / e0)
    sim.run(duration, record=[fdem.Video(args.out, fps=30, frame_dt=duration / frames, renderer=renderer)],
            progress=False, callback=watch)
    e = sim.energies()
    result = {"broken_joints": sim.cracks.broken_count, "fragments": sim.cracks.fragment_count(plate),
              "energy_rel_error_max": float(worst[0]), "fracture_energy_J": e["fracture"],
              "initial_energy_J": e0, "triangles": info["triangles"], "joints": info["joints"]}
    assert result["broken_joints"] >= 5, "too few joints broke"
    assert result["fragments"] >= 2, "the plate did not fragment"
    assert result["energy_rel_error_max"] < 0.02, f"energy drift {result['energy_rel_error_max']:.2%}"
    result["video"] = os.path.abspath(args.out)
    result["sim"] = sim                      # for the tests' independent checks (fragments by brute force)
    result["wall_s"] = clock()
    print(f"  {result['broken_joints']} joints broken, {result['fragments']} fragments; fracture work "
          f"{e['fracture']:.3g} J of {e0:.3g} J; worst energy error {worst[0]:.3%}; {result['wall_s']:.1f} s wall time")
    return result


if __name__ == "__main__":
    main()
    sys.exit(0)

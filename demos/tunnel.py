"""A tunnel excavated in a stressed, jointed rock mass (docs/theory/loads.md §12.4).

    python demos/tunnel.py            # writes out/tunnel.mp4 and out/tunnel_history.csv
    python demos/tunnel.py --short    # a quick, coarser version (used by tests/test_demos_rock.py)

A 2 × 2 m block of rock meshed on a triangular lattice, every interior edge a cohesive joint
(``fracture=True``: c = f_t = 0.1 MPa, φ = 30°, G_I = 5, G_II = 25 J/m²), is brought to an in-situ stress σv = 0.15 MPa,
σh = 0.075 MPa by boundary pressures (``apply_pressure`` on the top and right edges, ramped by a
``Curve``; rollers on the left and bottom edges) and settles with ``quasi_static=True``.
Intact cohesive joints do not carry an ``initial_stress`` prestress (Scene.initial_stress),
so a fracturing mass is stressed by its boundaries instead.  Then ``sim.remove`` excavates a
circular tunnel of radius 0.3 m at once.  The hoop stress at the sidewalls of an elastic
opening would be 3σv − σh = 0.375 MPa, above the mass's unconfined strength 2c cos φ/(1 − sin φ)
= 0.346 MPa: the joints fail around the sidewalls and the tunnel converges.  The history
(``run(history=...)``: reactions, load factors, energies) is written to CSV; the video is
coloured by joint damage.  ``check``: no joint damaged over 0.5 before the excavation, failed joints (damage > 0.5
or broken) after it, concentrated around the opening (most within 3 radii), and the sidewalls closing (their closure
is printed next to the elastic Kirsch value).
"""
from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "tunnel"
L, A = 2.0, 0.3                       # block size, tunnel radius [m]
SV, SH = 0.15e6, 0.075e6              # in-situ stress [Pa, compression positive]
# element size h [m], joint penalty [× E], the in-situ ramp, the settling after it and the run after
# the excavation [P-wave transits of the block], video frames
SIZE = {True: dict(h=0.2, penalty=30, ramp=4, settle=2, after=6, frames=20),
        False: dict(h=0.08, penalty=10, ramp=10, settle=5, after=40, frames=60)}


def build(short: bool):
    import numpy as np
    import taichi_fdem as fdem
    from taichi_fdem.verification import TRIAXIAL_MATERIAL, jointed_specimen_mesh
    s = SIZE[short]
    mat = fdem.Material(**dict(TRIAXIAL_MATERIAL, fracture_energy=5.0, fracture_energy_shear=25.0,
                               joint_penalty=s["penalty"] * TRIAXIAL_MATERIAL["young"]))
    h = s["h"]
    scene = fdem.Scene(gravity=(0.0, 0.0))
    rock = scene.add_body(jointed_specimen_mesh(L, L, h), mat, fracture=True, name="rock")
    tol = 1e-6
    cp = mat.p_wave_speed("strain")
    t_ramp = s["ramp"] * L / cp
    ramp = fdem.Curve.ramp(t_ramp, name="in_situ")
    scene.fix_nodes(lambda x, y: x < -0.5 * L + tol, body=rock, velocity=(0.0, None))
    scene.fix_nodes(lambda x, y: y < -0.5 * L + tol, body=rock, velocity=(None, 0.0))
    scene.apply_pressure(lambda x, y: y > 0.5 * L - tol, SV, body=rock, curve=ramp)
    scene.apply_pressure(lambda x, y: x > 0.5 * L - tol, SH, body=rock, curve=ramp)
    sim = scene.build(quasi_static=True)
    return sim, rock, dict(t_ramp=t_ramp, transit=L / cp, h=h, material=mat)


def sidewalls(sim, rock):
    """Horizontal closure [m] of the two sidewall points (x = ±A, y = 0) of the tunnel."""
    return _common.sidewall_closure(sim, rock, A)


def main(argv=None) -> dict:
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], argv)
    clock = _common.Timer()
    _common.init(args.precision)
    import taichi_fdem as fdem
    import numpy as np
    from taichi_fdem.render import RendererImage, VideoWriter

    sim, rock, p = build(args.short)
    print(f"{NAME}: {sim.model.tri_count} triangles, dt = {sim.dt:.3g} s")
    size = (320, 320) if args.short else (720, 720)
    renderer = RendererImage(*size, view=(-1.05, 1.05, -1.05, 1.05), color_by="damage", vmin=0.0, vmax=1.0,
                             colorbar=not args.short, stamp=not args.short)
    csv_path = os.path.join(os.path.dirname(os.path.abspath(args.out)), "tunnel_history.csv")
    os.makedirs(os.path.dirname(csv_path), exist_ok=True)
    if os.path.exists(csv_path):
        os.remove(csv_path)
    s = SIZE[args.short]
    frames = s["frames"]
    with VideoWriter(args.out, fps=10 if args.short else 30) as video:
        t_settle = p["t_ramp"] + s["settle"] * p["transit"]
        t_after = s["after"] * p["transit"]
        every = max(1, round((t_settle + t_after) / sim.dt / 200))     # about 200 history rows over the run
        for _ in range(frames // 2):
            sim.run(t_settle / (frames // 2), record=[fdem.History(csv_path, every=every)])
            video.append(renderer.render_sim(sim))
        broken_before = sim.cracks.broken_count
        damaged_before = int((sim.cracks.joint_damage() > 0.5).sum())
        u0 = sidewalls(sim, rock)
        removed = sim.remove(where=lambda x, y: x * x + y * y < A * A)
        for _ in range(frames):
            sim.run(t_after / frames, record=[fdem.History(csv_path, every=every)])
            video.append(renderer.render_sim(sim))
    closure = sidewalls(sim, rock) - u0
    mat = p["material"]
    # Kirsch (plane strain): inward wall displacement of an opening cut in a stressed mass,
    # u = σv a/(4G) [(1 + K) − (1 − K)(3 − 4ν) cos 2θ], θ from the horizontal, K = σh/σv
    G = mat.young / (2 * (1 + mat.poisson))
    K = SH / SV
    u_wall = SV * A / (4 * G) * ((1 + K) - (1 - K) * (3 - 4 * mat.poisson))
    elastic_closure = 2 * u_wall
    # damaged joints (D > 0.5 or broken) and where they are: the failure pattern
    D = sim.cracks.joint_damage()
    jn = rock.joint_nodes                                  # (k, 4) node indices within the body
    mid = sim.model.node_rest[rock.nodes][jn].mean(axis=1)
    dist = np.hypot(mid[:, 0], mid[:, 1])
    failed = D > 0.5
    near = float(np.mean(dist[failed] < 3 * A)) if failed.any() else 0.0
    out = dict(removed=removed, broken_before=broken_before, broken_after=sim.cracks.broken_count,
               damaged_before=damaged_before, damaged_after=int(failed.sum()),
               fraction_near=near, closure=closure, elastic_closure=elastic_closure,
               steps=sim.step_count, video=os.path.abspath(args.out), csv=csv_path, wall_s=clock(),
               energies=sim.energies())
    print(f"  excavated {removed} triangles; joints damaged over 0.5: {damaged_before} before, {int(failed.sum())} after "
          f"({near:.0%} within 3 radii), {sim.cracks.broken_count} broken; sidewall closure {closure * 1e3:.3f} mm (elastic Kirsch "
          f"{elastic_closure * 1e3:.3f} mm); {sim.step_count} steps")
    assert damaged_before == 0, "joints failed before the excavation"
    assert failed.any() and near > 0.5, "no failure around the opening"
    assert closure > 0.5 * elastic_closure, "the sidewalls did not close"
    print(f"  wrote {args.out} and {csv_path}; {out['wall_s']:.1f} s wall time")
    return out


if __name__ == "__main__":
    main()

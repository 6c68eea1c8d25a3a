"""Injection into a rock mass cut by a discrete fracture network (docs/theory/hydro.md,
docs/guide/fluid.md).

    python demos/dfn_injection.py            # writes out/dfn_injection.mp4 and its CSV files
    python demos/dfn_injection.py --short    # a quick, coarser version (used by tests/test_demos.py)

A square block of rock (plane strain, E = 10 GPa, f_t = 0.3 MPa, c = 2 MPa, G_I = 2 J/m²; every
interior edge a cohesive joint; ``quasi_static=True`` damps the waves of each break) under the
in-situ stress σ_H = 2 MPa along x, σ_h = 0.5 MPa (initial stress and matching tractions), with
water (K = 100 MPa, residual aperture 0.1 mm) injected at a constant rate, holds three
pre-existing fractures (``add_body(cracks=...)`` with
``fdem.mesh.Polyline``; contact and friction μ = 0.6):

* A, horizontal through the centre, where water is injected at a constant rate;
* B, steep, crossing A: connected to the well from the start;
* C, steep, beyond A's right tip with a gap of intact rock: not connected.

The fluid fills A and flows into B through their crossing; new cracks grow from the wet
fractures and link C to the network, whose pressure then rises too.  The run stops when C holds
fluid (or after a step budget).

Checked (``check``): B's pressure rises before any joint breaks next to it, and C becomes wet
only through broken joints (wet: a pressure above ``P_WET`` = 0.1 MPa at a node of the fracture
farther than 1.5 h from A).  Written: a video coloured by the fluid pressure, the history with
the injection columns (``dfn_injection_history.csv``), the crack events with the fluid pressure
at each break (``dfn_injection_cracks.csv``) and the largest pressure on each fracture over time
(``dfn_injection_fractures.csv``).
"""
from __future__ import annotations

import csv
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "dfn_injection"
SIGMA_H, SIGMA_h = 2.0e6, 0.5e6      # in-situ stresses [Pa], compression; σ_H along x
RATE = 2.0e-2                        # injection rate [m²/s per unit thickness]
P_MAX = 3.0e6                        # top of the video's colour range [Pa]
COHESION, FRACTURE_ENERGY = 2.0e6, 2.0   # joints' cohesion [Pa] and mode-I fracture energy [J/m²]
P_WET = 1.0e5                        # a fracture is wet once its pressure exceeds this [Pa]
#: the fractures (end points [m]) in a block of side 0.4 m
FRACTURES = {"A": ((-0.08, 0.0), (0.08, 0.0)), "B": ((0.02, -0.08), (0.06, 0.08)),
             "C": ((0.11, -0.07), (0.09, 0.07))}


def rock_mass(h: float, size: float = 0.4):
    """(scene, Polylines by name) of the block with its fractures, fed at A's centre."""
    import numpy as np
    import taichi_fdem as fdem
    rock = fdem.Material(density=2700.0, young=10e9, poisson=0.25, tensile_strength=3e5, cohesion=COHESION,
                         fracture_energy=FRACTURE_ENERGY, name="rock")
    lines = {k: fdem.mesh.Polyline(np.array(p), name=k) for k, p in FRACTURES.items()}
    s = 0.5 * size
    mesh = fdem.mesh.polygon([(-s, -s), (s, -s), (s, s), (-s, s)], h, lines=list(lines.values()))
    scene = fdem.Scene(gravity=(0.0, 0.0), plane="strain")
    scene.add_body(mesh, rock, fracture=True, cracks=list(lines.values()), crack_friction=0.6, name="rock")
    scene.initial_stress(-SIGMA_H, -SIGMA_h)
    tol = 1e-6 * h
    a = s - tol
    scene.apply_traction(lambda x, y: x > a, (-SIGMA_H, 0.0))
    scene.apply_traction(lambda x, y: x < -a, (SIGMA_H, 0.0))
    scene.apply_traction(lambda x, y: y > a, (0.0, -SIGMA_h))
    scene.apply_traction(lambda x, y: y < -a, (0.0, SIGMA_h))
    scene.set_fluid(fdem.Fluid(bulk_modulus=1e8), aperture_min=1e-4)
    scene.inject(lambda x, y: np.hypot(x, y) < 0.3 * h, rate=RATE)
    return scene, lines


def _on_segment(pos, seg, tol):
    """Mask of the points ``pos`` (k, 2) within ``tol`` [m] of the segment ``seg``."""
    import numpy as np
    a, b = np.asarray(seg[0], float), np.asarray(seg[1], float)
    d = b - a
    t = np.clip((pos - a) @ d / (d @ d), 0.0, 1.0)
    return np.linalg.norm(pos - (a + t[:, None] * d), axis=1) < tol


def fracture_pressures(sim, h) -> dict:
    """The largest fluid pressure [Pa] on each fracture's network nodes (by initial position)
    farther than 1.5 h from fracture A, whose own value is taken over all its nodes (B's
    crossing with A is then not counted as B's)."""
    _, p = sim.fluid.pressures()
    rest = sim.model.fluid_node_rest
    off_a = ~_on_segment(rest, FRACTURES["A"], 1.5 * h)
    return {k: float(p[_on_segment(rest, seg, 1e-3 * h) & (off_a | (k == "A"))].max()) for k, seg in FRACTURES.items()}


def main(argv=None) -> dict:
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], argv)
    clock = _common.Timer()
    _common.init(args.precision)
    import numpy as np
    from taichi_fdem.render import RendererImage, VideoWriter
    from taichi_fdem.sim.results import History

    h = 0.02 if args.short else 0.01
    out_dir = os.path.dirname(os.path.abspath(args.out))
    os.makedirs(out_dir, exist_ok=True)
    scene, lines = rock_mass(h)
    sim = scene.build(strategy="serial", quasi_static=True)
    print(f"{NAME}: {sim.model.tri_count} triangles (h = {h * 1e3:g} mm), {sim.model.joint_count} joints, "
          f"{sim.model.fluid_edge_count} network edges, dt = {sim.dt:.3g} s")
    hist_path = os.path.join(out_dir, f"{NAME}_history.csv")
    cracks_path = os.path.join(out_dir, f"{NAME}_cracks.csv")
    frac_path = os.path.join(out_dir, f"{NAME}_fractures.csv")
    for p in (hist_path,):
        if os.path.exists(p):
            os.remove(p)
    size = (240, 240) if args.short else (600, 600)
    renderer = RendererImage(*size, color_by="fluid_pressure", vmin=0.0, vmax=P_MAX, draw_edges=False,
                             crack_width=2.0 if args.short else 3.0, stamp=not args.short)
    chunk, budget = (40, 8000) if args.short else (100, 60000)
    rows = []
    first_wet = {}
    broken_near = {}
    history = History(sim, hist_path)
    history.write()
    jn = sim.model.joint_nodes.to_numpy()[: sim.model.joint_count]
    joint_mid = sim.model.node_rest[jn].mean(axis=1)
    near = {k: _on_segment(joint_mid, seg, 1.5 * h) for k, seg in FRACTURES.items()}
    with VideoWriter(args.out, fps=10 if args.short else 20) as video:
        video.append(renderer.render_sim(sim))
        try:
            while sim.step_count < budget:
                sim.step(chunk)
                history.write()
                fp = fracture_pressures(sim, h)
                broken = sim.cracks.joint_damage() >= 1.0
                rows.append((sim.time, sim.cracks.broken_count, sim.fluid.injection_pressure(), *fp.values()))
                for k, v in fp.items():
                    if v > P_WET and k not in first_wet:
                        first_wet[k] = sim.time
                        broken_near[k] = int((broken & near[k]).sum())
                video.append(renderer.render_sim(sim))
                if "C" in first_wet and sim.time >= 1.2 * first_wet["C"]:
                    break
        finally:
            history.close()
        for _ in range(3):
            video.append(renderer.render_sim(sim))
    sim.cracks.write_events(cracks_path)
    with open(frac_path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time_s", "broken_joints", "injection_pressure_Pa"] + [f"pressure_{k}_Pa" for k in FRACTURES])
        for r in rows:
            w.writerow([f"{v:.6g}" for v in r])
    final = fracture_pressures(sim, h)
    out = dict(triangles=sim.model.tri_count, h=h, steps=sim.step_count, time=sim.time, broken=sim.cracks.broken_count,
               first_wet=first_wet, broken_near_when_wet=broken_near, final_pressures=final,
               injected=float(sim.fluid.injected_volumes()[0]), stored=sim.fluid.volume(), history=hist_path,
               cracks=cracks_path, fractures_csv=frac_path, video=os.path.abspath(args.out), sim=sim,
               wall_s=clock())
    print(f"  {out['broken']} joints broken in {out['steps']} steps ({out['time'] * 1e3:.3f} ms); fractures wet at "
          + ", ".join(f"{k} {t * 1e3:.3f} ms ({broken_near[k]} broken joints next to it)" for k, t in first_wet.items())
          + "; final pressures " + ", ".join(f"{k} {v / 1e6:.2f} MPa" for k, v in final.items()))
    assert "B" in first_wet and broken_near["B"] == 0, "the crossing fracture B did not fill through the crossing"
    assert "C" in first_wet and broken_near["C"] > 0, "no new crack linked fracture C to the network"
    print(f"  wrote {args.out}, {hist_path}, {cracks_path} and {frac_path}; {out['wall_s']:.1f} s wall time")
    return out


if __name__ == "__main__":
    main()

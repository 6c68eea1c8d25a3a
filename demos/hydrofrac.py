"""A hydraulic fracture from a borehole in a jointed rock mass under an anisotropic in-situ stress
(docs/theory/hydro.md, docs/guide/fluid.md).

    python demos/hydrofrac.py            # writes out/hydrofrac.mp4 and its CSV files
    python demos/hydrofrac.py --short    # a quick, coarser version (used by tests/test_demos.py)

A square block of rock (plane strain, E = 10 GPa, f_t = 0.3 MPa, c = 2 MPa, G_I = 1 J/m²) in
which every interior mesh edge is a cohesive joint (``fracture=True``) starts in equilibrium
under the in-situ stress σ_H = 2 MPa, σ_h = 0.5 MPa (compression; ``scene.initial_stress`` with
the matching tractions on its four sides).  The borehole is a small cross of pre-existing
cracks at the centre (a horizontal and a vertical one, 3 cells long), so that the seed does not
pick a direction.  Water (compressible, K = 100 MPa) is injected at a constant rate at the
centre node.  The fluid opens the cross, breaks the joints ahead of it and follows into them;
the fracture opens against the least stress and grows along σ_H.  The run is repeated with the
stresses swapped (σ_H along y): the fracture turns by 90°.

Checked (``check``): the long axis of the broken joints (principal axis of their positions) lies
within 20° of σ_H in both runs.  Written: a video coloured by the fluid pressure
(``color_by="fluid_pressure"``; both runs, one after the other), the history of each run with
the injection columns (``*_history.csv``: injection pressure, injected and stored volume, rate)
and its crack events with the fluid pressure at each break (``*_cracks.csv``).
"""
from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "hydrofrac"
SIGMA_H, SIGMA_h = 2.0e6, 0.5e6      # in-situ stresses [Pa], compression
RATE = 2.0e-2                        # injection rate [m²/s per unit thickness]
P_MAX = 3.0e6                        # top of the video's colour range [Pa]


def rock_mass(sigma_h_along_x: bool, size: float, h: float):
    """(scene, seed half-length [m]): the block of side ``size`` [m], cells ``h`` [m], under the
    in-situ stress with σ_H along x (``sigma_h_along_x``) or along y, fed at its centre."""
    import numpy as np
    import taichi_fdem as fdem
    rock = fdem.Material(density=2700.0, young=10e9, poisson=0.25, tensile_strength=3e5, cohesion=2e6,
                         fracture_energy=1.0, name="rock")
    tol = 1e-6 * h
    seed = 1.5 * h
    cross = lambda x, y: (((np.abs(y) < tol) & (np.abs(x) < seed + tol))            # noqa: E731
                          | ((np.abs(x) < tol) & (np.abs(y) < seed + tol)))
    scene = fdem.Scene(gravity=(0.0, 0.0), plane="strain")
    scene.add_body(fdem.mesh.rectangle(size, size, h), rock, fracture=True, cracks=cross, name="rock")
    sxx, syy = (-SIGMA_H, -SIGMA_h) if sigma_h_along_x else (-SIGMA_h, -SIGMA_H)
    scene.initial_stress(sxx, syy)
    a = 0.5 * size - tol
    scene.apply_traction(lambda x, y: x > a, (sxx, 0.0))
    scene.apply_traction(lambda x, y: x < -a, (-sxx, 0.0))
    scene.apply_traction(lambda x, y: y > a, (0.0, syy))
    scene.apply_traction(lambda x, y: y < -a, (0.0, -syy))
    scene.set_fluid(fdem.Fluid(bulk_modulus=1e8), aperture_min=1e-5)
    scene.inject(lambda x, y: (np.abs(x) < tol) & (np.abs(y) < tol), rate=RATE)
    return scene, seed


def fracture_axis(x, y):
    """(angle of the long axis from x [deg] in [0, 90], minor/major spread) of points (the
    principal axes of their scatter about the centroid)."""
    import numpy as np
    P = np.column_stack([x, y]).astype(float)
    P = P - P.mean(axis=0)
    w, v = np.linalg.eigh(P.T @ P)
    d = v[:, 1]
    return float(math.degrees(math.atan2(abs(d[1]), abs(d[0])))), float(math.sqrt(max(w[0], 0.0) / max(w[1], 1e-300)))


def grow(sigma_h_along_x: bool, short: bool, out_dir: str, label: str, frame=None) -> dict:
    """Inject until a broken joint lies 0.3 × the block's side from the centre (or a step budget)."""
    import numpy as np
    from taichi_fdem.sim.results import History
    size, h = (0.4, 0.025) if short else (0.8, 0.02)
    scene, seed = rock_mass(sigma_h_along_x, size, h)
    sim = scene.build(strategy="serial")
    hist_path = os.path.join(out_dir, f"{NAME}_{label}_history.csv")
    cracks_path = os.path.join(out_dir, f"{NAME}_{label}_cracks.csv")
    if os.path.exists(hist_path):
        os.remove(hist_path)
    history = History(sim, hist_path)
    history.write()
    chunk, budget, reach = (40, 4000, 0.3 * size) if short else (100, 40000, 0.3 * size)
    peak = 0.0
    try:
        while sim.step_count < budget:
            sim.step(chunk)
            history.write()
            peak = max(peak, sim.fluid.injection_pressure())
            if frame is not None:
                frame(sim)
            ev = sim.cracks.events()
            if len(ev["x"]) and float(np.hypot(ev["x"], ev["y"]).max()) > reach:
                break
    finally:
        history.close()
    sim.cracks.write_events(cracks_path)
    ev = sim.cracks.events()
    angle, spread = fracture_axis(ev["x"], ev["y"])
    return dict(sim=sim, angle_deg=angle, spread=spread, broken=sim.cracks.broken_count, steps=sim.step_count,
                time=sim.time, peak_pressure=peak, injected=float(sim.fluid.injected_volumes()[0]),
                stored=sim.fluid.volume(), history=hist_path, cracks=cracks_path, size=size, h=h, seed=seed,
                triangles=sim.model.tri_count)


def main(argv=None) -> dict:
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], argv)
    clock = _common.Timer()
    _common.init(args.precision)
    from taichi_fdem.render import RendererImage, VideoWriter

    out_dir = os.path.dirname(os.path.abspath(args.out))
    os.makedirs(out_dir, exist_ok=True)
    size = (240, 200) if args.short else (640, 540)
    renderer = RendererImage(*size, color_by="fluid_pressure", vmin=0.0, vmax=P_MAX, draw_edges=False,
                             crack_width=2.0 if args.short else 3.0, colorbar=True, stamp=not args.short)
    results = {}
    with VideoWriter(args.out, fps=10 if args.short else 20) as video:
        for label, along_x in (("sH_x", True), ("sH_y", False)):
            r = grow(along_x, args.short, out_dir, label, frame=lambda sim: video.append(renderer.render_sim(sim)))
            for _ in range(3):
                video.append(renderer.render_sim(r["sim"]))
            results[label] = r
            print(f"{NAME} [σ_H along {'x' if along_x else 'y'}]: {r['triangles']} triangles, {r['broken']} joints "
                  f"broken in {r['steps']} steps ({r['time'] * 1e3:.3f} ms); fracture axis {r['angle_deg']:.1f}° from x "
                  f"(spread {r['spread']:.2f}); peak injection pressure {r['peak_pressure'] / 1e6:.2f} MPa; "
                  f"injected {r['injected']:.4g} m², stored {r['stored']:.4g} m²")
    ax, ay = results["sH_x"]["angle_deg"], results["sH_y"]["angle_deg"]
    out = dict(angle_sH_x=ax, angle_sH_y=ay, results=results, video=os.path.abspath(args.out), wall_s=clock(),
               **{f"{k}_{lab}": r[k] for lab, r in results.items()
                  for k in ("broken", "peak_pressure", "injected", "stored", "history", "cracks", "spread")})
    assert ax < 20.0, f"σ_H along x: the fracture's axis is {ax:.1f}° from x"
    assert ay > 70.0, f"σ_H along y: the fracture's axis is {ay:.1f}° from x"
    print(f"  the fracture follows σ_H: {ax:.1f}° from x with σ_H along x, {ay:.1f}° with σ_H along y; "
          f"wrote {args.out}; {out['wall_s']:.1f} s wall time")
    return out


if __name__ == "__main__":
    main()

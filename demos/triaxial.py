"""Compression tests of a jointed rock specimen: unconfined (UCS) and triaxial (docs/theory/loads.md §12.6).

    python demos/triaxial.py            # UCS + triaxial at σ3 = 0.1 and 0.2 MPa: out/triaxial.mp4, out/triaxial_curves.csv
    python demos/triaxial.py --short    # a quick, coarser version (used by tests/test_demos_rock.py)
    python demos/triaxial.py --ucs      # the unconfined test only (out/ucs.mp4, out/ucs_curves.csv)

A 0.05 × 0.1 m specimen meshed on a triangular lattice, every interior edge a cohesive joint
(``fracture=True``; c = f_t = 0.1 MPa, φ = 30°, brittle: G_I = 2, G_II = 10 J/m²), is confined
by a pressure σ3 on its sides (``apply_pressure``, ramped by a ``Curve``) and loaded by two
frictionless platens (prescribed velocities, started by a ``Curve``; the load is
``sim.reaction``).  ``quasi_static=True``.  Each test's axial stress–strain and lateral strain
curves are written to CSV; the video shows the specimens coloured by joint damage: a shear
band forms on a ±60° lattice line (the Mohr–Coulomb plane at 45° + φ/2).  ``check``: each peak
within 15 % of Mohr–Coulomb σ1 = σ3 N_φ + 2c√N_φ of the joints (brittle joints fail
progressively, a few % below the ductile peaks of ``verification.case_triaxial``), and the
confined peaks higher, in order of σ3.
"""
from __future__ import annotations

import csv
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "triaxial"


def material():
    from taichi_fdem.verification import TRIAXIAL_MATERIAL
    return dict(TRIAXIAL_MATERIAL, fracture_energy=2.0, fracture_energy_shear=10.0)


def check(results) -> dict:
    out = {}
    for r in results:
        ratio = r["peak"] / r["peak_mc"]
        assert abs(ratio - 1) < 0.15, f"σ3 = {r['sigma3']:g} Pa: peak {r['peak']:.4g} Pa is {ratio:.3f} × Mohr–Coulomb"
        out[f"peak_over_mc_{r['sigma3']:g}"] = ratio
    for weaker, stronger in zip(results, results[1:]):
        assert stronger["peak"] > weaker["peak"], (f"σ3 = {stronger['sigma3']:g} Pa is not stronger than "
                                                   f"σ3 = {weaker['sigma3']:g} Pa")
    return out


def main(argv=None) -> dict:
    import argparse
    extra = argparse.ArgumentParser(add_help=False)
    extra.add_argument("--ucs", action="store_true")
    known, rest = extra.parse_known_args(argv)
    name = "ucs" if known.ucs else NAME
    args = _common.parse_args(name, __doc__.split("\n\n")[0], rest)
    clock = _common.Timer()
    _common.init(args.precision)
    import numpy as np
    from taichi_fdem.render import RendererImage, VideoWriter
    from taichi_fdem.verification import triaxial_test

    # UCS, then triaxial tests at two confinements (one in the short mode)
    confinements = [0.0] if known.ucs else ([0.0, 1e5] if args.short else [0.0, 1e5, 2e5])
    res = 4 if args.short else 8
    size = (240, 360) if args.short else (480, 720)
    view = (-0.045, 0.045, -0.068, 0.068)
    renderer = RendererImage(*size, view=view, color_by="damage", vmin=0.0, vmax=1.0,
                             colorbar=not args.short, stamp=not args.short)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)) or ".", exist_ok=True)
    results = []
    with VideoWriter(args.out, fps=15 if args.short else 30) as video:
        for s3 in confinements:
            count = [0]

            def frame(sim, rec):
                count[0] += 1
                if count[0] % (3 if args.short else 1) == 0:
                    video.append(renderer.render_sim(sim))
            r = triaxial_test(s3, resolution=res, material=material(), samples=60 if args.short else 200,
                              strain_rate_transits=30.0 if args.short else 80.0, stop_drop=0.6, frame=frame)
            for _ in range(5):
                video.append(renderer.render_sim(r["sim"]))
            results.append(r)
            print(f"{name}: σ3 = {s3 / 1e6:.2f} MPa: peak σ1 = {r['peak'] / 1e6:.4f} MPa at ε = {r['peak_strain']:.4f} "
                  f"(Mohr–Coulomb {r['peak_mc'] / 1e6:.4f} MPa); {r['broken']} joints broken, "
                  f"{r['sim'].model.tri_count} triangles, {r['sim'].step_count} steps, {r['wall']:.0f} s")
    csv_path = os.path.join(os.path.dirname(os.path.abspath(args.out)), f"{name}_curves.csv")
    with open(csv_path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["sigma3_Pa", "time_s", "axial_strain", "axial_stress_Pa", "lateral_strain"])
        for r in results:
            for row in zip(r["time"], r["strain"], r["stress"], r["lateral"]):
                w.writerow([f"{r['sigma3']:g}"] + [f"{v:.6g}" for v in row])
    out = check(results)
    out.update(peaks=[r["peak"] for r in results], peaks_mc=[r["peak_mc"] for r in results],
               confinements=confinements, broken=[r["broken"] for r in results],
               final_over_peak=[float(r["stress"][-1] / r["peak"]) for r in results],
               moduli=[float(np.polyfit(r["strain"][(r["stress"] > 0.2 * r["peak"]) & (np.arange(len(r["stress"])) < np.argmax(r["stress"]))],
                                        r["stress"][(r["stress"] > 0.2 * r["peak"]) & (np.arange(len(r["stress"])) < np.argmax(r["stress"]))], 1)[0])
                       for r in results],
               young=results[0]["material"].young, poisson=results[0]["material"].poisson,
               video=os.path.abspath(args.out), csv=csv_path, wall_s=clock())
    print(f"  wrote {args.out} and {csv_path}; {out['wall_s']:.1f} s wall time")
    return out


if __name__ == "__main__":
    main()

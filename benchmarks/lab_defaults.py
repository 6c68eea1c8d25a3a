"""The lab tests at their defaults: the Brazilian strength over the parameter range of ordinary
rock, what it depends on, the jointed UCS moduli and the convergence checks.

    python benchmarks/lab_defaults.py --json out/lab.json [--jobs 2] [--quick]
    python benchmarks/report.py --lab out/lab.json          # into results.json and results.md

Every Brazilian run is ``fdem.lab.brazilian(material, 0.05, h)`` (a 50 mm disc, 20 elements
across unless stated) with nothing else set but what a row names; the material has E = 20 GPa,
ν = 0.2, ρ = 2600 kg/m³ unless stated and l_ch = E G_I / f_t² = 9.375 mm (G_I scaled with
f_t² / E).  Numbers are ``centre_stress / f_t`` (BTS over the tensile strength, the Hondros
factor of the loaded arc included) and ``central_fraction``.
"""
from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor

D, H = 0.05, 0.0025
LCH = 9.375e-3


def rock(ft, young=20e9, c_over_ft=3.0, phi=35.0, lch=LCH, **kw):
    import taichi_fdem as fdem
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return fdem.Material(density=2600.0, young=young, poisson=0.2, tensile_strength=ft, cohesion=c_over_ft * ft,
                             friction_angle=phi, fracture_energy=lch * ft * ft / young, **kw)


def brazilian(case: dict) -> dict:
    """One Brazilian run: case = dict(material=kwargs of rock(), h=, call=kwargs of lab.brazilian,
    spiral=True for the spiral mesh)."""
    import numpy as np
    import taichi_fdem as fdem
    mkw = dict(case["material"])
    kw = dict(case.get("call", {}))
    h = case.get("h", H)
    if case.get("spiral"):
        kw["mesh"] = fdem.mesh.disk(0.5 * D, h, layout="spiral")
    ft = mkw["ft"]
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        r = fdem.lab.brazilian(rock(**mkw), D, h, **kw)
    bj = r.sim.cracks.broken()
    first = bj["position"][:5].tolist()
    return dict(case=case, ratio=r.centre_stress / ft, central=r.central_fraction, peaked=bool(r.peaked),
                kinetic=r.kinetic_ratio, convergence=r.convergence, settings=r.settings, first=first,
                modes=[str(m) for m in bj["mode"][:20]], wall=time.perf_counter() - t0,
                warnings=sorted({str(x.message)[:120] for x in w}))


def ucs(case: dict) -> dict:
    import taichi_fdem as fdem
    m = fdem.Material(density=2600.0, young=20e9, poisson=0.2, tensile_strength=6e6, cohesion=20e6,
                      friction_angle=35.0, fracture_energy=50.0, **case.get("material", {}))
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        r = fdem.lab.ucs(m, 0.05, 0.1, case.get("h", 0.005), **case.get("call", {}))
    return dict(case=case, E=r.young_initial / m.young, nu=r.poisson_initial / m.poisson, peak=r.peak_stress,
                convergence=r.convergence, settings=r.settings, wall=time.perf_counter() - t0,
                warnings=sorted({str(x.message)[:120] for x in w}))


def run(case):
    import taichi_fdem as fdem
    fdem.init()
    return (ucs if case.get("test") == "ucs" else brazilian)(case)


# f_t [Pa], E [Pa], c / f_t, φ [°]: corners and edges of ordinary rock (f_t 2–20 MPa,
# E 5–80 GPa, c 2–5 f_t, φ 25–45°; f_t/E 1e-4 to 1e-3)
RANGE = [(2e6, 20e9, 2.0, 25.0), (2e6, 20e9, 5.0, 45.0), (2e6, 5e9, 3.0, 35.0), (5e6, 5e9, 3.0, 35.0),
         (20e6, 80e9, 2.0, 25.0), (20e6, 80e9, 5.0, 45.0), (20e6, 20e9, 3.0, 35.0), (4e6, 20e9, 3.0, 35.0),
         (8e6, 20e9, 2.0, 45.0), (8e6, 20e9, 5.0, 25.0)]


def cases(quick: bool = False) -> dict:
    out = {}
    # the table: its materials and calls (G_I = 30 J/m² × (f_t / 8 MPa)², l_ch = 9.375 mm)
    out["issue"] = [dict(material=dict(ft=6e6, c_over_ft=20 / 6)),
                    dict(material=dict(ft=4e6, damping=1.0)),
                    dict(material=dict(ft=8e6, damping=1.0)),
                    dict(test="ucs"), dict(test="ucs", material=dict(damping=1.0))]
    out["range"] = [dict(material=dict(ft=a, young=b, c_over_ft=c, phi=p)) for a, b, c, p in RANGE]
    # the spiral mesh (no line of edges along the loaded diameter) against the default one
    spiral = [(2e6, 20e9, 3.0, 35.0), (4e6, 20e9, 3.0, 35.0), (8e6, 20e9, 3.0, 35.0), (2e6, 20e9, 2.0, 25.0),
              (8e6, 20e9, 5.0, 35.0)]
    out["mesh"] = [dict(material=dict(ft=a, young=b, c_over_ft=c, phi=p), spiral=True) for a, b, c, p in spiral]
    # the size effect of the cohesive crack: l_ch / D
    out["size"] = [dict(material=dict(ft=4e6, lch=l)) for l in (2.5e-3, 37.5e-3, 150e-3)]
    out["convergence"] = [dict(material=dict(ft=4e6), call=dict(check="both")),
                          dict(test="ucs", call=dict(check="both"))]
    if quick:
        out = {k: v[:1] for k, v in out.items()}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", required=True, help="where to write the raw results (and the tables for report.py)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--quick", action="store_true", help="one case per table (a smoke test)")
    ap.add_argument("--only", nargs="*", help="only these tables (issue, range, mesh, size, convergence)")
    args = ap.parse_args(argv)
    todo = cases(args.quick)
    if args.only:
        todo = {k: v for k, v in todo.items() if k in args.only}
    flat = [(k, c) for k, v in todo.items() for c in v]
    with ProcessPoolExecutor(args.jobs) as ex:
        res = list(ex.map(run, [c for _, c in flat]))
    raw = {}
    for (k, _), r in zip(flat, res):
        raw.setdefault(k, []).append(r)
    with open(args.json, "w") as fh:
        json.dump(dict(raw=raw, date=datetime.date.today().isoformat(), host=platform.platform()), fh, indent=1,
                  default=str)
    print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

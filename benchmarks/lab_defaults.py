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
from concurrent.futures import ProcessPoolExecutor, as_completed

# the repository's taichi_fdem, whatever the working directory (the script's own directory comes
# first on sys.path, not the checkout)
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

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
                split_start=list(r.split_start),
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
    out["convergence"] = [dict(material=dict(ft=4e6), call=dict(check="both")),
                          dict(test="ucs", h=0.01, call=dict(check="both"))]
    # the table: its materials and calls (G_I = 30 J/m² × (f_t / 8 MPa)², l_ch = 9.375 mm)
    out["issue"] = [dict(material=dict(ft=6e6, c_over_ft=20 / 6)),
                    dict(material=dict(ft=4e6, damping=1.0)),
                    dict(material=dict(ft=8e6, damping=1.0)),
                    dict(test="ucs"), dict(test="ucs", material=dict(damping=1.0))]
    out["rate"] = [dict(material=dict(ft=4e6), call=dict(load_time=t)) for t in (15.0, 30.0, 60.0)]
    out["range"] = [dict(material=dict(ft=a, young=b, c_over_ft=c, phi=p)) for a, b, c, p in RANGE]
    out["range_brittle"] = [dict(material=dict(ft=a, young=b, c_over_ft=c, phi=p, lch=2.5e-3))
                            for a, b, c, p in ((2e6, 20e9, 2.0, 25.0), (20e6, 80e9, 5.0, 45.0), (5e6, 5e9, 3.0, 35.0))]
    # the spiral mesh (no line of joints along the loaded diameter), not in results.md: --only mesh
    spiral = [(2e6, 20e9, 3.0, 35.0), (4e6, 20e9, 3.0, 35.0), (8e6, 20e9, 3.0, 35.0), (2e6, 20e9, 2.0, 25.0)]
    out["mesh"] = [dict(material=dict(ft=a, young=b, c_over_ft=c, phi=p), spiral=True) for a, b, c, p in spiral]
    # the size effect of the cohesive crack: l_ch / D
    out["size"] = [dict(material=dict(ft=4e6, lch=l)) for l in (37.5e-3, 9.375e-3, 5e-3, 2.5e-3, 1.25e-3)]
    if quick:
        out = {k: v[:1] for k, v in out.items()}
    return out


def _mpa(v):
    return f"{v / 1e6:g} MPa"


def _gpa(v):
    return f"{v / 1e9:g} GPa"


def _bts(r):
    cell = f"{r['ratio']:.3f}"
    if not r["peaked"]:
        cell += " (not split after 3 loading times)"
    return cell


def _start(r):
    """``|y|`` [mm] of the first joint broken in tension."""
    if "split_start" in r:
        y = r["split_start"][1]
    else:
        i = r["modes"].index("I") if "I" in r["modes"] else 99
        y = r["first"][i][1] if i < len(r["first"]) else math.nan
    return "–" if not math.isfinite(y) else f"{abs(y) * 1e3:.1f}"


def tables(raw: dict, date: str, host: str) -> dict:
    """The tables of results.json's "lab" entry (report.py renders them) from the raw results."""
    out = []
    if "issue" in raw:
        rows = []
        for r in raw["issue"]:
            c = r["case"]
            if c.get("test") == "ucs":
                what = "`lab.ucs` of a specimen with joints on every edge" + (", `damping=1.0`" if c.get("material") else "")
                rows.append([what, f"E {r['E']:.4f} E_mat, ν {r['nu']:.4f} ν_mat", "E, ν within 3 %"])
            else:
                m = c["material"]
                what = (f"`lab.brazilian`, f_t = {_mpa(m['ft'])}, c = {m.get('c_over_ft', 3.0) * m['ft'] / 1e6:.0f} MPa"
                        + (", `damping=1.0`" if m.get("damping") else ", undamped"))
                rows.append([what, f"{r['ratio']:.3f} f_t (`central_fraction` {r['central']:.2f})", "≈ f_t"])
        out.append(dict(title="The issue's table, re-measured",
                        text="The calls of issue 46 (E = 20 GPa, ν = 0.2, ρ = 2600 kg/m³, φ = 35°, 20 elements across "
                             "a 50 mm disc, `h = 0.0025`, G_I = 30 J/m² × (f_t / 8 MPa)²); UCS: 0.05 × 0.1 m, "
                             "`h = 0.005`, f_t = 6 MPa, c = 20 MPa, G_I = 50 J/m², tangent E and ν below 30 % of "
                             "the peak (`young_initial`, `poisson_initial`).",
                        columns=["call", "=result", "=expected"], rows=rows))
    for key, title, text in (
            ("range", "Brazilian strength over ordinary rock, l_ch = 9.4 mm (D / 5.3)",
             "The default call; G_I = l_ch f_t² / E.  `split at` is ``|y|`` of the first joint broken in tension "
             "(D/6 = 8.3 mm bounds the central third)."),
            ("range_brittle", "The same, l_ch = 2.5 mm (D / 20)", "Three corners."),
            ("mesh", "The spiral disc (`mesh=fdem.mesh.disk(0.025, 0.0025, layout=\"spiral\")`): no line of joints "
                     "along the loaded diameter", "")):
        if key not in raw:
            continue
        rows = []
        for r in raw[key]:
            m = r["case"]["material"]
            rows.append([_mpa(m["ft"]), _gpa(m.get("young", 20e9)), f"{m.get('c_over_ft', 3.0):g}",
                         f"{m.get('phi', 35.0):g}°", f"{m['ft'] / m.get('young', 20e9):.2g}", _bts(r),
                         f"{r['central']:.2f}", _start(r)])
        out.append(dict(title=title, text=text, columns=["f_t", "E", "=c / f_t", "=φ", "=f_t / E", "=BTS / f_t",
                                                           "=central_fraction", "=split at [mm]"], rows=rows))
    if "size" in raw:
        rows = [[f"{r['case']['material']['lch'] * 1e3:g}", f"{0.05 / r['case']['material']['lch']:.1f}", _bts(r),
                 f"{r['central']:.2f}"] for r in raw["size"]]
        out.append(dict(title="Size effect: f_t = 4 MPa, E = 20 GPa, c = 3 f_t, φ = 35°",
                        text="", columns=["=l_ch [mm]", "=D / l_ch", "=BTS / f_t", "=central_fraction"], rows=rows))
    if "rate" in raw:
        rows = [[f"{r['case']['call']['load_time']:g}", f"{r['ratio']:.3f}"] for r in raw["rate"]]
        out.append(dict(title="Loading rate: f_t = 4 MPa, E = 20 GPa, c = 3 f_t, φ = 35°, l_ch = 9.4 mm",
                        text="`load_time=` (the loading to the expected peak, in D/c_p; the default is 60).",
                        columns=["=load_time [D/c_p]", "=BTS / f_t"], rows=rows))
    if "convergence" in raw:
        rows = []
        for r in raw["convergence"]:
            what = "`lab.ucs(m, 0.05, 0.1, 0.01, check=\"both\")` (`peak_stress`)" if r["case"].get("test") == "ucs" \
                else "`lab.brazilian(m, 0.05, 0.0025, check=\"both\")`, f_t = 4 MPa (`centre_stress`)"
            cv = r["convergence"]
            rows.append([what, f"{cv.get('rate', math.nan):+.4f}", f"{cv.get('mesh', math.nan):+.4f}"])
        out.append(dict(title="Convergence check at the defaults",
                        text="`result.convergence`: the relative change of the peak when the test is rerun at "
                             "half the loading rate and at half `h`.",
                        columns=["call", "=rate", "=mesh"], rows=rows))
    setup = ("Brazilian runs: `fdem.lab.brazilian(material, 0.05, h)` with nothing else set, `h = 0.0025` "
             "(20 elements across), E = 20 GPa, ν = 0.2, ρ = 2600 kg/m³ unless stated, G_I = l_ch f_t² / E.  "
             "BTS / f_t is `centre_stress / f_t` (the Hondros factor of the loaded arc included).  Why the numbers "
             "are what they are: docs/guide/lab.md, \"What the Brazilian strength measures\".")
    return dict(command="python benchmarks/lab_defaults.py --json out/lab_raw.json --tables out/lab.json",
                date=date, host=host, setup=setup, tables=out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", required=True, help="where to write the raw results (and the tables for report.py)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--tables", help="write the tables for report.py --lab here")
    ap.add_argument("--from-raw", action="store_true", help="only make --tables from an existing --json")
    ap.add_argument("--quick", action="store_true", help="one case per table (a smoke test)")
    ap.add_argument("--only", nargs="*", help="only these tables (issue, range, range_brittle, size, rate, convergence; "
                                              "mesh: the spiral disc)")
    args = ap.parse_args(argv)
    if args.from_raw:
        with open(args.json) as fh:
            data = json.load(fh)
        with open(args.tables, "w") as fh:
            json.dump(tables({k: [r for r in v if r] for k, v in data["raw"].items()}, data["date"], data["host"]),
                      fh, indent=1)
        print(f"wrote {args.tables}")
        return 0
    todo = cases(args.quick)
    if not args.only:
        todo.pop("mesh")
    if args.only:
        todo = {k: todo[k] for k in args.only}
    raw = {k: [None] * len(v) for k, v in todo.items()}
    with ProcessPoolExecutor(args.jobs) as ex:
        futures = {ex.submit(run, c): (k, i) for k, v in todo.items() for i, c in enumerate(v)}
        for fut in as_completed(futures):
            k, i = futures[fut]
            r = raw[k][i] = fut.result()
            print(k, json.dumps({a: r[a] for a in ("case", "ratio", "central", "peaked", "E", "nu", "convergence",
                                                  "first", "wall") if a in r}, default=str), flush=True)
            with open(args.json, "w") as fh:
                json.dump(dict(raw=raw, date=datetime.date.today().isoformat(), host=platform.platform()), fh,
                          indent=1, default=str)
    print(f"wrote {args.json}")
    if args.tables:
        with open(args.tables, "w") as fh:
            json.dump(tables({k: [r for r in v if r] for k, v in raw.items()}, datetime.date.today().isoformat(), platform.platform()), fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

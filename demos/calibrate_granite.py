"""A grain-based granite model calibrated to the E, ν, UCS and BTS of Lac du Bonnet granite.

    python demos/calibrate_granite.py            # 3 calibration stages, 2 workers -> out/calibrate_granite.csv, .png
    python demos/calibrate_granite.py --short    # tiny specimens, 2 evaluations per stage (used by the tests)

Targets (Lac du Bonnet granite, the grey granite of AECL's Underground Research Laboratory,
Manitoba; laboratory values of Martin & Chandler 1994, "The progressive fracture of Lac du
Bonnet granite", Int. J. Rock Mech. Min. Sci. 31(6) 643–659, and Martin 1997, "Seventeenth
Canadian Geotechnical Colloquium: the effect of cohesion loss and stress path on brittle rock
strength", Can. Geotech. J. 34, 698–725; the set of macro-properties that Potyondy & Cundall
2004, Int. J. Rock Mech. Min. Sci. 41, 1329–1364, calibrate their bonded-particle model to):
Young's modulus E = 69 GPa, Poisson's ratio ν = 0.26, uniaxial compressive strength
UCS = 200 MPa, Brazilian tensile strength BTS = 9.3 MPa.

The model: Voronoi grains (``fdem.mesh.voronoi_grains``, grain size 2 h) of quartz, feldspar and
biotite (35 / 55 / 10 % of the area) with Young's moduli 1.3, 1.0 and 0.5 × a grain modulus
E_g and a common ν_g; every interior edge is a cohesive joint (``fracture=True``), the joints
inside the grains twice as strong as the grain-boundary joints, which are a joint set
(``("grain_boundaries", "interfaces", boundary)``) with tensile strength f_t, cohesion c, φ =
35°, G_I = 20 J/m²; joint penalty 13 E_g (10 × the stiffest mineral).  Plane strain.

Strategy: four micro-parameters, three :func:`fdem.calibrate` stages, each fitting the
parameters a measurement is most sensitive to, cheapest first:

1. E_g, ν_g to (E, ν): ``fdem.lab.ucs`` of the jointed specimen loaded to 30 % of its expected
   peak only (the elastic part; the joints add their compliance, which the fit absorbs);
2. f_t to the BTS: ``fdem.lab.brazilian`` of a grain disc (c fixed at its range's middle);
3. c to the UCS: ``fdem.lab.ucs`` to failure, with the f_t of stage 2.

A final run of both tests at the calibrated parameters gives the curves drawn against the
targets and the four errors (the BTS moves a little when stage 3 changes c).  Each stage
writes its history to the CSV (a ``stage`` column); the figure shows the UCS stress–strain curve
(target slope E and target UCS), the Brazilian σ = 2P/(πD) against the platen approach (target
BTS) and the convergence of the three stages.  The fit is to a small 2D specimen at a
quasi-static but fast loading (30 P-wave transits to the peak): its micro-parameters are the
ones of this specimen size and rate, not a resolution-independent property.
"""
from __future__ import annotations

import argparse
import csv
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "calibrate_granite"
SOURCE = "Lac du Bonnet granite (Martin & Chandler 1994; Martin 1997)"
TARGETS = {"young": 69e9, "poisson": 0.26, "ucs": 200e6, "bts": 9.3e6}
MINERALS = {"quartz": 0.35, "feldspar": 0.55, "biotite": 0.10}
STIFFNESS = {"quartz": 1.3, "feldspar": 1.0, "biotite": 0.5}       # × the grain modulus E_g
INTRA = 2.0                 # intra-grain joint strengths (f_t, c, G_I) over the grain boundary's
DENSITY = 2650.0            # kg/m³
PHI = 35.0                  # friction angle of the joints [°]
G_I = 20.0                  # J/m², grain boundaries
PENALTY = 13.0              # joint penalty × E_g
RATE_TRANSITS = 30.0        # P-wave transits to the expected peak (lab.ucs rate_transits)
ELASTIC_FRACTION = 0.6      # stage 1 loads to this fraction of the expected peak strain
PARAMS = {"grain_young": (40e9, 110e9), "grain_poisson": (0.15, 0.35),
          "tensile_strength": (3e6, 20e6), "cohesion": (30e6, 150e6)}
SPECIMEN = {  # width, height, h of the UCS specimen; diameter, h of the disc [m]
    False: dict(width=0.015, height=0.03, h=0.0025, diameter=0.02, disc_h=0.002),
    True: dict(width=0.01, height=0.02, h=0.0025, diameter=0.015, disc_h=0.0025)}
BUDGET = {False: (20, 15, 15), True: (2, 2, 2)}   # evaluations of the stages
SEED = 1


def materials(p: dict):
    """({mineral: Material}, grain-boundary Material) of micro-parameters ``p``: grain_young [Pa],
    grain_poisson, tensile_strength [Pa] and cohesion [Pa] of the grain boundaries."""
    import taichi_fdem as fdem
    E, nu, ft, c = p["grain_young"], p["grain_poisson"], p["tensile_strength"], p["cohesion"]
    common = dict(density=DENSITY, poisson=nu, friction_angle=PHI, joint_penalty=PENALTY * E)
    by = {k: fdem.Material(young=f * E, tensile_strength=INTRA * ft, cohesion=INTRA * c,
                           fracture_energy=INTRA * G_I, name=k, **common) for k, f in STIFFNESS.items()}
    boundary = fdem.Material(young=E, tensile_strength=ft, cohesion=c, fracture_energy=G_I, name="boundary",
                             **common)
    return by, boundary


def specimen(p: dict, disc: bool = False):
    """(material dict, mesh, labels, joint_sets) of the rectangle or the disc of size ``p["short"]``."""
    from taichi_fdem import mesh
    s = SPECIMEN[bool(p.get("short", False))]
    if disc:
        m, lab = mesh.voronoi_grains(s["diameter"], s["diameter"], 2 * s["disc_h"], s["disc_h"], seed=SEED,
                                     minerals=MINERALS, shape="disc")
    else:
        m, lab = mesh.voronoi_grains(s["width"], s["height"], 2 * s["h"], s["h"], seed=SEED, minerals=MINERALS)
    by, boundary = materials(p)
    return lab.materials(by), m, lab, [("grain_boundaries", "interfaces", boundary)]


def run_ucs(p: dict, elastic: bool = False):
    """``fdem.lab.ucs`` of the grain specimen, loaded so that the expected peak strain
    ε_e = σ_MC(c) / E_g (Mohr–Coulomb of the grain boundaries, σ_MC = 2 c √N_φ, over the grain
    modulus: within 15 % of the measured peak strain here) is reached in ``RATE_TRANSITS``
    P-wave transits, up to 2 ε_e; ``elastic``: up to ``ELASTIC_FRACTION`` × ε_e only."""
    import taichi_fdem as fdem
    from taichi_fdem.lab.specimens import mohr_coulomb_peak
    s = SPECIMEN[bool(p.get("short", False))]
    mats, m, lab, js = specimen(p)
    eps = mohr_coulomb_peak(0.0, p["cohesion"], PHI) / p["grain_young"]
    # lab.ucs sets its rate from the first material's joints (intra-grain: INTRA × c) over E/2
    first = next(iter(mats.values()))
    eps_lab = mohr_coulomb_peak(0.0, first.cohesion, PHI) / (0.5 * first.young)
    return fdem.lab.ucs(mats, s["width"], s["height"], s["h"], mesh=m, groups=lab, fracture=True, joint_sets=js,
                        rate_transits=RATE_TRANSITS * eps_lab / eps,
                        max_strain=(ELASTIC_FRACTION if elastic else 2.0) * eps, samples=100 if elastic else 200)


def run_bts(p: dict):
    """``fdem.lab.brazilian`` of the grain disc."""
    import taichi_fdem as fdem
    s = SPECIMEN[bool(p.get("short", False))]
    mats, m, lab, js = specimen(p, disc=True)
    return fdem.lab.brazilian(mats, s["diameter"], s["disc_h"], mesh=m, groups=lab, joint_sets=js, load_time=50.0)


def model_elastic(p: dict) -> dict:
    """Stage 1: {young [Pa], poisson} of the elastic part of the UCS test."""
    r = run_ucs(p, elastic=True)
    return {"young": r.young, "poisson": r.poisson}


def model_bts(p: dict) -> dict:
    """Stage 2: {bts [Pa]} (σ_t = 2P/(πD) of lab.brazilian)."""
    return {"bts": run_bts(p).peak_stress}


def model_ucs(p: dict) -> dict:
    """Stage 3: {ucs [Pa]} (the peak stress of lab.ucs)."""
    return {"ucs": run_ucs(p).peak_stress}


class _Partial:
    """model(params) with some parameters fixed (picklable for the worker processes)."""

    def __init__(self, func, fixed: dict):
        self.func, self.fixed = func, dict(fixed)

    def __call__(self, p: dict) -> dict:
        return self.func({**self.fixed, **p})


def stages(short: bool):
    """[(stage name, model, params, targets, budget)] of the three stages (the later models get the
    earlier results through ``fixed`` at run time)."""
    b1, b2, b3 = BUDGET[short]
    return [("elastic", model_elastic, ("grain_young", "grain_poisson"), ("young", "poisson"), b1),
            ("bts", model_bts, ("tensile_strength",), ("bts",), b2),
            ("ucs", model_ucs, ("cohesion",), ("ucs",), b3)]


def write_csv(path: str, records: list) -> str:
    cols = ["stage", "evaluation", "batch", *PARAMS, *TARGETS, "score", "status", "error", "wall_s"]
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in records:
            w.writerow([repr(r[c]) if isinstance(r.get(c), float) else r.get(c, "") for c in cols])
    return path


def plot(ucs_r, bts_r, cals, path: str) -> bool:
    """UCS and Brazilian curves at the calibrated parameters against the targets, and the
    convergence of every stage; False without matplotlib."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    import numpy as np
    fig, (a1, a2, a3) = plt.subplots(1, 3, figsize=(14, 4))
    eps, sig = ucs_r.curve["axial_strain"], ucs_r.curve["axial_stress_Pa"]
    a1.plot(1e3 * eps, sig / 1e6, "-", label="calibrated model")
    a1.axhline(TARGETS["ucs"] / 1e6, color="k", ls="--", label=f"target UCS {TARGETS['ucs'] / 1e6:.0f} MPa")
    # the target modulus in plane strain: E / (1 - ν²) is the slope of the plane model's curve
    e1 = TARGETS["young"] / (1 - TARGETS["poisson"] ** 2)
    x = np.linspace(0.0, float(eps.max()), 20)
    a1.plot(1e3 * x, e1 * x / 1e6, "k:", label="target E/(1−ν²) (plane strain)")
    a1.set_ylim(0, 1.15 * max(float(sig.max()), TARGETS["ucs"]) / 1e6)
    a1.set_xlabel("axial strain [‰]")
    a1.set_ylabel("axial stress [MPa]")
    a1.set_title("UCS test")
    a1.legend(fontsize=8)
    D = SPECIMEN[cals["short"]]["diameter"]
    a2.plot(1e3 * bts_r.curve["approach_m"], 2 * bts_r.curve["load_N_per_m"] / (math.pi * D) / 1e6, "-",
            label="calibrated model")
    a2.axhline(TARGETS["bts"] / 1e6, color="k", ls="--", label=f"target BTS {TARGETS['bts'] / 1e6:.1f} MPa")
    a2.set_xlabel("platen approach [mm]")
    a2.set_ylabel("2P/(πD) [MPa]")
    a2.set_title("Brazilian test")
    a2.legend(fontsize=8)
    n0 = 0
    for name, cal in cals["stages"]:
        s = np.array([r["score"] for r in cal.history], float)
        n = n0 + np.arange(1, len(s) + 1)
        a3.semilogy(n, np.maximum(s, 1e-12), ".", ms=5)
        a3.semilogy(n, np.maximum(np.minimum.accumulate(s), 1e-12), "-", label=f"stage {name}")
        n0 += len(s)
    a3.set_xlabel("evaluation")
    a3.set_ylabel("objective Σ ((m − t)/t)²")
    a3.set_title("calibration")
    a3.legend(fontsize=8)
    fig.suptitle(f"grain-based granite calibrated to {SOURCE}", fontsize=10)
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return True


def parse(argv=None):
    ap = argparse.ArgumentParser(prog=f"demos/{NAME}.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--short", action="store_true", help="tiny specimens, 2 evaluations per stage (used by the tests)")
    ap.add_argument("--out", default=None, help=f"CSV path; default out/{NAME}.csv (the plot is written next to it)")
    ap.add_argument("--workers", type=int, default=None, help="local worker processes (default 2; 1 with --short)")
    ap.add_argument("--budget", type=int, nargs=3, default=None, metavar=("ELASTIC", "BTS", "UCS"),
                    help="evaluations of the three stages (default 20 15 15; 2 2 2 with --short)")
    ap.add_argument("--precision", choices=("f64", "f32"), default="f64")
    args = ap.parse_args(argv)
    if args.workers is None:
        args.workers = 1 if args.short else 2
    if args.workers < 1:
        ap.error(f"--workers must be >= 1, got {args.workers}")
    if args.budget is not None and min(args.budget) < 2:
        ap.error(f"--budget: every stage needs at least 2 evaluations, got {args.budget}")
    if args.out is None:
        args.out = os.path.join(_common.ROOT, "out", f"{NAME}_short.csv" if args.short else f"{NAME}.csv")
    return args


def main(argv=None) -> dict:
    import taichi_fdem as fdem
    args = parse(argv)
    clock = _common.Timer()
    _common.init(args.precision)
    if __name__ != "__main__" and args.workers > 1:
        # the worker processes import the model by reference: only from the script itself
        args.workers = 1
    print(f"{NAME}: targets of {SOURCE}: E = {TARGETS['young'] / 1e9:.0f} GPa, ν = {TARGETS['poisson']}, "
          f"UCS = {TARGETS['ucs'] / 1e6:.0f} MPa, BTS = {TARGETS['bts'] / 1e6:.1f} MPa", flush=True)
    fixed = {"short": args.short, "grain_young": 70e9, "grain_poisson": 0.25,
             "tensile_strength": 0.5 * sum(PARAMS["tensile_strength"]), "cohesion": 0.5 * sum(PARAMS["cohesion"])}
    records, cals = [], []
    for k, (name, func, names, tnames, budget) in enumerate(stages(args.short)):
        budget = args.budget[k] if args.budget else budget
        model = _Partial(func, {q: v for q, v in fixed.items() if q not in names})
        print(f"  stage {name}: {', '.join(names)} to {', '.join(tnames)}, {budget} evaluations", flush=True)

        def report(cal, name=name):
            r = cal.history[-1]
            print(f"    [{cal.evaluations}] best score {cal.best_score:.3g} at "
                  + ", ".join(f"{q} = {cal.best[q]:.4g}" for q in cal.best) + f"; last {r['status']} in "
                  f"{r['wall_s']:.1f} s ({clock():.0f} s)", flush=True)

        cal = fdem.calibrate(model, {q: PARAMS[q] for q in names}, {t: TARGETS[t] for t in tnames}, budget=budget,
                             seed=SEED, workers=args.workers, popsize=1,
                             init={"arch": "cpu", "precision": args.precision}, on_batch=report)
        fixed.update(cal.best)
        cals.append((name, cal))
        records += [{"stage": name, **r} for r in cal.history]
    best = {q: fixed[q] for q in PARAMS}
    print("  final run at " + ", ".join(f"{q} = {v:.4g}" for q, v in best.items()), flush=True)
    u, b = run_ucs(fixed), run_bts(fixed)
    measured = {"young": u.young, "poisson": u.poisson, "ucs": u.peak_stress, "bts": b.peak_stress}
    errors = {k: (measured[k] - t) / t for k, t in TARGETS.items()}
    records.append({"stage": "final", "evaluation": len(records) + 1, **best, **measured, "status": "ok",
                    "score": sum(e * e for e in errors.values()), "wall_s": u.summary["wall"] + b.summary["wall"]})
    out = write_csv(args.out, records)
    png = os.path.splitext(out)[0] + ".png"
    if not plot(u, b, {"short": args.short, "stages": cals}, png):
        png = None
    evaluations = sum(c.evaluations for _, c in cals)
    failed = sum(1 for r in records if r["status"] != "ok")
    print()
    print("| measured | target | calibrated model | error |")
    print("|---|---:|---:|---:|")
    unit = {"young": (1e9, "GPa"), "poisson": (1.0, ""), "ucs": (1e6, "MPa"), "bts": (1e6, "MPa")}
    for k, t in TARGETS.items():
        f, s = unit[k]
        print(f"| {k} | {t / f:.4g} {s} | {measured[k] / f:.4g} {s} | {100 * errors[k]:+.1f} % |")
    print()
    wall = clock()
    print(f"  {evaluations} evaluations ({failed} failed) in 3 stages on {args.workers} worker(s), "
          f"{wall:.0f} s wall time; wrote {out}" + (f" and {png}" if png else
                                                   " (no plot: pip install 'taichi-fdem[plot]')"))
    return {"best": best, "measured": measured, "errors": errors, "targets": dict(TARGETS),
            "evaluations": evaluations, "failed": failed, "wall_s": wall, "csv": os.path.abspath(out), "png": png,
            "calibrations": cals, "ucs": u, "bts": b}


if __name__ == "__main__":
    main()
    sys.exit(0)

"""Calibration methods compared on the same problems and budgets (``fdem.calibrate(method=...)``).

The targets are values the model itself produced at known parameters, so the error of the
calibrated parameters is known.  Each method runs to its budget (or its own convergence); the
table gives the evaluations after which the best point so far first has every parameter within
2 % and within 5 % of the truth (``Calibration.evaluations_to``), "—" where it never does.

Problems (E = 20 GPa, ν = 0.2, ρ = 2600 kg/m³, φ = 35°, G_I = l_ch f_t²/E with l_ch = 9.375 mm):

* ``bts``: f_t in [2, 12] MPa from the Brazilian strength (``centre_stress``) of a 50 mm disc
  with 20 elements across that f_t = 6 MPa produced; c = 3 f_t.  Budget 12.
* ``bts+ucs``: f_t in [2, 12] MPa and c in [10, 60] MPa from that Brazilian strength and the UCS
  of a 50 × 100 mm specimen (``h`` = 12.5 mm) that f_t = 6 MPa, c = 20 MPa produced.  Budget 40.

    python benchmarks/calibration.py                          # every method, both problems
    python benchmarks/calibration.py --problems bts --methods bracket least_squares
    python benchmarks/calibration.py --json out/calibration.json

Only evaluation counts are compared (wall times depend on the host's load).  ``"bayes"`` needs
Optuna (``pip install "taichi-fdem[calibrate]"``); without it that method is left out.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import warnings

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

import taichi_fdem as fdem  # noqa: E402

LCH = 9.375e-3          # characteristic length E G_I / f_t² [m]
YOUNG = 20e9


def rock(ft: float, c: float) -> "fdem.Material":
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return fdem.Material(density=2600.0, young=YOUNG, poisson=0.2, tensile_strength=ft, cohesion=c,
                             friction_angle=35.0, fracture_energy=LCH * ft * ft / YOUNG)


def bts(ft: float, c: float) -> float:
    """Brazilian strength (centre stress) [Pa] of a 50 mm disc, 20 elements across."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return fdem.lab.brazilian(rock(ft, c), 0.05, 0.05 / 20).centre_stress


def ucs(ft: float, c: float) -> float:
    """UCS [Pa] of a 50 × 100 mm specimen, h = 12.5 mm, joints on every edge."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return fdem.lab.ucs(rock(ft, c), 0.05, 0.1, 0.0125).peak_stress


def model_bts(p: dict) -> dict:
    ft = p["tensile_strength"]
    return {"bts": bts(ft, 3.0 * ft)}


def model_bts_ucs(p: dict) -> dict:
    ft, c = p["tensile_strength"], p["cohesion"]
    return {"bts": bts(ft, c), "ucs": ucs(ft, c)}


PROBLEMS = {
    "bts": dict(model=model_bts, true={"tensile_strength": 6e6}, params={"tensile_strength": (2e6, 12e6)},
                budget=12),
    "bts+ucs": dict(model=model_bts_ucs, true={"tensile_strength": 6e6, "cohesion": 20e6},
                    params={"tensile_strength": (2e6, 12e6), "cohesion": (10e6, 60e6)}, budget=40),
}
METHODS = ("bracket", "least_squares", "bayes", "de")


def run(problems, methods, seed=0, workers=1, log=print) -> list:
    rows = []
    for name in problems:
        pr = PROBLEMS[name]
        targets = pr["model"](pr["true"])
        log(f"{name}: targets {targets}")
        for m in methods:
            if m == "bracket" and len(pr["params"]) > 1:
                continue
            cal = fdem.calibrate(pr["model"], pr["params"], targets, budget=pr["budget"], seed=seed,
                                 workers=workers, method=m)
            err = {k: cal.best[k] / v - 1 for k, v in pr["true"].items()}
            row = {"problem": name, "method": m, "budget": pr["budget"], "evaluations": cal.evaluations,
                   "to_2pc": cal.evaluations_to(pr["true"], 0.02), "to_5pc": cal.evaluations_to(pr["true"], 0.05),
                   "best_error": {k: round(v, 5) for k, v in err.items()}, "converged": cal.converged}
            rows.append(row)
            log(json.dumps(row))
    return rows


def table(rows) -> str:
    """Markdown of the comparison (benchmarks/report.py renders the same table in results.md)."""
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from report import calibration_table
    return calibration_table(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problems", nargs="+", default=list(PROBLEMS), choices=list(PROBLEMS))
    ap.add_argument("--methods", nargs="+", default=list(METHODS), choices=list(METHODS))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--json", help="write the rows as JSON to this path")
    args = ap.parse_args(argv)
    methods = list(args.methods)
    if "bayes" in methods:
        try:
            import optuna  # noqa: F401
        except ImportError:
            print("optuna is not installed: method 'bayes' left out")
            methods.remove("bayes")
    fdem.init(arch="cpu")
    rows = run(args.problems, methods, seed=args.seed, workers=args.workers)
    print(table(rows))
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Run time against error: sweeps of the verification cases (taichi_fdem.verification).

For each case it varies, one at a time around the case's default setting: the mesh size
(``resolution``), the time-step safety factor, the contact penalty (in units of E, contact
cases only) and the precision (f64, f32: each precision runs in its own subprocess, because
``fdem.init(precision=...)`` resets Taichi).  Every run records its error against the analytic
value and its wall time (the seconds spent inside ``Simulation.step``; measuring, build and
kernel compilation excluded: each worker first runs every case once, unrecorded, to compile
its kernels).

Writes ``docs/accuracy/results.csv``, ``docs/accuracy/results.md`` (tables, Pareto fronts,
convergence orders) and ``docs/accuracy/CASE.png`` (error against work = triangles × time
steps, exact where sub-second wall times are noise; Pareto front by work marked) when matplotlib is installed (``pip install taichi_fdem[plot]``).

    .venv/bin/python benchmarks/accuracy.py --quick            # ~10 min on 2 cores
    .venv/bin/python benchmarks/accuracy.py                     # full sweeps
    .venv/bin/python benchmarks/accuracy.py --cases wave hertz --precisions f64
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "docs", "accuracy")

# per case: default keyword arguments, resolution sweep (full, quick), whether it has contact,
# and the order of convergence the theory gives (in h and in Δt), None where it gives none
CASES = {
    # the half-amplitude point of a step front in the (dispersive) discrete chain lags by a
    # fraction of the Airy-front width ∝ h^(2/3) t^(1/3): order 2/3 in h for this measurement;
    # in 1D, lumped masses and central differences are exact at the Courant limit, so the
    # error does not grow with Δt
    "wave": dict(default=dict(resolution=100), res=([50, 100, 200, 400], [50, 100, 200]), contact=False,
                 order_h="2/3", order_dt=None, note="P-wave arrival, plane strain, rollers (§8.3)"),
    "two_bars": dict(default=dict(resolution=40), res=([20, 40, 80, 160], [20, 40, 80]), contact=True,
                     order_h=None, order_dt=None, note="two-bar impact: duration, stress, energy (§8.4)"),
    "hertz": dict(default=dict(resolution=10, penalty_factor=100.0), res=([6, 8, 10, 14], [6, 8, 10]),
                  contact=True, penalties=[10.0, 100.0, 1000.0], order_h=None, order_dt=None,
                  note="Hertz cylinder on a rigid flat: a and p0 (§8.5)"),
    "cantilever": dict(default=dict(resolution=8), res=([2, 4, 8, 16], [2, 4, 8]), contact=False,
                       order_h=2, order_dt=None, note="cantilever tip deflection, plane stress (§8.6)"),
    "incline": dict(default=dict(resolution=2), res=([1, 2, 4], [1, 2]), contact=True, order_h=None,
                    order_dt=None, note="block sliding down a 30° incline, μ = 0.3 (§8.2)"),
    "disks": dict(default=dict(resolution=3), res=([2, 3, 5, 8], [2, 3, 5]), contact=True, order_h=None,
                  order_dt=None, note="two-disk impact: energy balance after separation (§8.4)"),
    "rotation": dict(default=dict(resolution=4), res=([4], [4]), contact=False, order_h=None, order_dt=None,
                     note="rigid rotation of the beam: max |σ|/E (objectivity, §8.6)"),
    # fracture (§8.7): resolution = load increments per δ_p (joint pull), elements across the
    # strip (direct tension); the penalty sweep is over the joint penalty p_f/E
    "joint_pull": dict(default=dict(resolution=100), res=([25, 50, 100, 200], [25, 100]), contact=True,
                       penalties=[1.0, 100.0], order_h=None, order_dt=None,
                       note="single-joint mode I pull: peak, breakage opening, work (§8.7)"),
    "direct_tension": dict(default=dict(resolution=2), res=([2, 4], [2]), contact=True, penalties=[100.0],
                           order_h=None, order_dt=None, note="direct tension of a jointed strip: peak = f_t (§8.7)"),
    # loads and rock mechanics (§12.6): resolution = cells along a quarter of the hole (Kirsch),
    # elements through the wall (Lamé), across the specimen (uniaxial, triaxial)
    "kirsch": dict(default=dict(resolution=32), res=([16, 24, 32, 48], [24, 32]), contact=False, order_h=None,
                   order_dt=None, note="Kirsch: hoop stress 3σ and −σ at the hole (§12.6)"),
    "lame": dict(default=dict(resolution=8), res=([4, 8, 16, 32], [4, 8, 16]), contact=False, order_h=2,
                 order_dt=None, note="Lamé cylinder: bore and outer displacement, hoop stress (§12.6)"),
    "uniaxial": dict(default=dict(resolution=8), res=([4, 8, 16], [4, 8]), contact=True, order_h=None,
                     order_dt=None, note="uniaxial compression between platens: modulus (§12.6)"),
    "triaxial": dict(default=dict(resolution=6), res=([4, 6, 8], [6]), contact=True, penalties=[10.0],
                     order_h=None, order_dt=None, note="jointed specimen: peak against Mohr–Coulomb, σ3 = 0, 0.1 MPa (§12.6)"),
}
# safety > 0.4 is refused by Scene.build (above sim.model.dt_limit) unless forced: the sweep stops at 0.4
SAFETIES = ([0.05, 0.1, 0.2, 0.4], [0.1, 0.2, 0.4])
PENALTIES = [1.0, 10.0, 100.0]


def configs(case: str, quick: bool) -> list:
    """The settings swept for ``case``: dicts of keyword arguments of the case function."""
    spec = CASES[case]
    base = dict(safety=0.2, penalty_factor=10.0)
    base.update(spec["default"])
    out = []
    for r in spec["res"][1 if quick else 0]:
        out.append(dict(base, resolution=r, sweep="resolution"))
    if case != "rotation":
        for s in SAFETIES[1 if quick else 0]:
            if s != base["safety"]:
                out.append(dict(base, safety=s, sweep="safety"))
    if spec["contact"]:
        for p in spec.get("penalties", PENALTIES):
            if p != base["penalty_factor"]:
                out.append(dict(base, penalty_factor=p, sweep="penalty"))
    return out


# ------------------------------------------------------------------------------------------------
# worker: one precision, in its own process
# ------------------------------------------------------------------------------------------------
def worker(precision: str, jobs: list) -> None:
    sys.path.insert(0, ROOT)
    import taichi_fdem as fdem
    from taichi_fdem import verification as V
    fdem.init(precision=precision)
    warmed = set()
    for job in jobs:
        case = job["case"]
        kw = {k: v for k, v in job.items() if k not in ("case", "sweep")}
        if case not in warmed:                      # compile the kernels outside the timing
            small = dict(kw, resolution=min(CASES[case]["res"][1]))
            try:
                V.CASES[case](precision=precision, **small)
            except Exception:
                pass
            warmed.add(case)
        t0 = time.perf_counter()
        try:
            r = V.CASES[case](precision=precision, **kw)
            status = "ok"
        except fdem.SimulationError as err:
            r = {"error": math.inf, "wall": time.perf_counter() - t0, "wall_total": time.perf_counter() - t0,
                 "steps": err.step}
            status = f"unstable: {err.cause}"
        except ValueError as err:                   # e.g. a safety factor above the stable limit: refused
            r = {"error": math.inf, "wall": 0.0, "wall_total": 0.0, "steps": 0}
            status = f"refused: {str(err).split(';')[0]}"
        row = dict(job, precision=precision, status=status)
        for k, v in r.items():
            if isinstance(v, (bool, int, float, str)) or hasattr(v, "item"):
                row[k] = v.item() if hasattr(v, "item") else v
        row["total_wall"] = time.perf_counter() - t0
        print("ROW " + json.dumps(row), flush=True)


# ------------------------------------------------------------------------------------------------
# analysis
# ------------------------------------------------------------------------------------------------
def pareto(rows: list, cost: str = "wall") -> list:
    """Indices of the rows not dominated in (cost, error): no other row is at least as cheap and as
    accurate and better in one of them.  ``cost``: "wall" [s] or "work" (triangles × steps)."""
    front = []
    for i, a in enumerate(rows):
        dominated = any((b[cost] <= a[cost] and b["error"] <= a["error"])
                        and (b[cost] < a[cost] or b["error"] < a["error"]) for j, b in enumerate(rows) if j != i)
        if not dominated and math.isfinite(a["error"]):
            front.append(i)
    return front


def slope(xs, ys):
    """Least-squares slope of log y against log x (None with fewer than 2 usable points)."""
    pts = [(math.log(x), math.log(y)) for x, y in zip(xs, ys) if x > 0 and y > 0 and math.isfinite(y)]
    if len(pts) < 2:
        return None
    mx = sum(p[0] for p in pts) / len(pts)
    my = sum(p[1] for p in pts) / len(pts)
    sxx = sum((p[0] - mx) ** 2 for p in pts)
    return sum((p[0] - mx) * (p[1] - my) for p in pts) / sxx if sxx > 0 else None


def is_default(row) -> bool:
    spec = CASES[row["case"]]
    d = dict(safety=0.2, penalty_factor=10.0)
    d.update(spec["default"])
    return all(abs(float(row[k]) - float(v)) < 1e-12 for k, v in d.items()) and row["precision"] == "f64"


def fmt(x, digits=3):
    if isinstance(x, float):
        if not math.isfinite(x):
            return "∞" if x > 0 else "nan"
        return f"{x:.{digits}g}"
    return str(x)


def analyse(rows: list, out_dir: str) -> str:
    lines = ["# Run time against error", "",
             "Generated by `benchmarks/accuracy.py` (see `docs/accuracy/README.md` for the reading).",
             "`wall` = seconds inside `Simulation.step` (the solver; measuring, build and kernel compilation "
             "excluded); "
             "`error` = relative error against the analytic value; ★ = on the Pareto front of the case "
             "(no other run both faster and more accurate), by wall time and by work = triangles × steps "
             "(wall times below ~0.3 s are noisy on the shared machine; the work is exact); **bold** = the package defaults "
             "(safety 0.2, penalty 10·E, f64; Hertz uses 100·E as docs/verification.md §8.5 asks).", ""]
    summary = ["## Convergence orders (log-log slopes)", "",
               "| case | precision | order in h (measured) | theory | order in Δt (measured) | theory |",
               "|:--|:--|--:|--:|--:|--:|"]
    for case in CASES:
        crow = [r for r in rows if r["case"] == case]
        if not crow:
            continue
        for r in crow:
            r["work"] = float(r.get("triangles", 0)) * float(r.get("steps", 0))
        front = set(pareto(crow))
        front_work = set(pareto(crow, "work"))
        spec = CASES[case]
        lines += [f"## {case}: {spec['note']}", "",
                  "| sweep | precision | resolution | safety | penalty ·E | triangles | steps | wall s | error | front (wall) | front (work) |",
                  "|:--|:--|--:|--:|--:|--:|--:|--:|--:|:--|:--|"]
        order = sorted(range(len(crow)), key=lambda i: (crow[i]["precision"], crow[i]["sweep"], crow[i]["resolution"],
                                                        crow[i]["safety"], crow[i]["penalty_factor"]))
        for i in order:
            r = crow[i]
            cells = [r["sweep"], r["precision"], fmt(r["resolution"]), fmt(r["safety"]), fmt(r["penalty_factor"]),
                     fmt(r.get("triangles", "")), fmt(r.get("steps", "")), fmt(r["wall"], 3), fmt(r["error"], 3),
                     ("★" if i in front else "") + ("" if r["status"] == "ok" else " " + r["status"]),
                     "★" if i in front_work else ""]
            if is_default(r):
                cells = [f"**{c}**" if c else c for c in cells]
            lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
        for prec in ("f64", "f32"):
            res_rows = [r for r in crow if r["sweep"] == "resolution" and r["precision"] == prec]
            dt_rows = [r for r in crow if (r["sweep"] == "safety" or (r["sweep"] == "resolution" and is_default(r)))
                       and r["precision"] == prec]
            if not res_rows:
                continue
            # runs whose error exceeds 10 % diverged (see the tables): left out of the fits
            res_rows = [r for r in res_rows if r["error"] < 0.1]
            dt_rows = [r for r in dt_rows if r["error"] < 0.1]
            oh = slope([1.0 / r["resolution"] for r in res_rows], [r["error"] for r in res_rows])
            odt = slope([r["safety"] for r in dt_rows], [r["error"] for r in dt_rows])
            summary.append(f"| {case} | {prec} | {fmt(oh, 2) if oh is not None else '–'} | "
                           f"{spec['order_h'] or '–'} | {fmt(odt, 2) if odt is not None else '–'} | "
                           f"{spec['order_dt'] or '–'} |")
        d = [i for i in range(len(crow)) if is_default(crow[i])]
        if d:
            i = d[0]
            on = i in front_work
            cheaper = [crow[j] for j in front_work if crow[j]["work"] <= crow[i]["work"]]
            best = min(cheaper, key=lambda r: r["error"], default=crow[i])
            how = "" if on else (f" (error {fmt(crow[i]['error'])} against {fmt(best['error'])} for "
                                 f"{best['sweep']} = {best[{'resolution': 'resolution', 'safety': 'safety', 'penalty': 'penalty_factor'}[best['sweep']]]} "
                                 f"{best['precision']} at {fmt(best['work'] / crow[i]['work'], 2)} × the work)")
            lines.append(f"Default setting: {'on' if on else 'off'} the work (triangle-steps) Pareto front{how}; "
                         f"{'on' if i in front else 'off'} the wall-time front (sub-second wall times are noise).")
            lines.append("")
        plot_case(case, crow, front_work, out_dir)
    summary += ["", "Order in h: slope of log(error) against log(1/resolution) over the resolution sweep; "
                "order in Δt: slope against log(safety) at the default resolution; runs with an error above "
                "10 % (diverged) are left out of the fits.  A slope near 0 means "
                "the error there is dominated by something else (the other discretisation, the penalty, "
                "round-off, or the measurement)."]
    return "\n".join(lines[:5] + summary + [""] + lines[5:]) + "\n"


def _work_label(x, _pos=None) -> str:
    """Tick label of a work axis: 3k, 20k, 1.5M, ... (triangle-steps)."""
    for div, unit in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if x >= div:
            return f"{x / div:g}{unit}"
    return f"{x:g}"


def plot_case(case, rows, front, out_dir):
    """Error against work (triangles × steps: exact, unlike the wall time of sub-second runs,
    which is machine noise), Pareto front by work dashed."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    except ImportError:
        if not getattr(plot_case, "warned", False):
            print("matplotlib is not installed: plots skipped (pip install taichi_fdem[plot])")
            plot_case.warned = True
        return
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    markers = {"resolution": "o", "safety": "s", "penalty": "^"}
    colours = {"f64": "tab:blue", "f32": "tab:orange"}
    for r in rows:
        if not (math.isfinite(r["error"]) and r["error"] > 0 and r["work"] > 0):
            continue
        ax.scatter(r["work"], r["error"], marker=markers[r["sweep"]], color=colours[r["precision"]],
                   s=60 if is_default(r) else 30, edgecolors="k" if is_default(r) else "none", zorder=3)
        label = {"resolution": f"n={r['resolution']}", "safety": f"α={r['safety']:g}",
                 "penalty": f"p={r['penalty_factor']:g}E"}[r["sweep"]]
        ax.annotate(label, (r["work"], r["error"]), fontsize=7, xytext=(3, 3), textcoords="offset points")
    fr = sorted((rows[i] for i in front if rows[i]["error"] > 0), key=lambda r: r["work"])
    if fr:
        ax.step([r["work"] for r in fr], [r["error"] for r in fr], where="post", color="k", lw=1, ls="--",
                label="Pareto front (work)", zorder=2)
    for sweep, m in markers.items():
        ax.scatter([], [], marker=m, color="gray", label=f"{sweep} sweep")
    for p, c in colours.items():
        ax.scatter([], [], marker="o", color=c, label=p)
    ax.scatter([], [], marker="o", color="w", edgecolors="k", s=60, label="defaults")
    ax.set_xscale("log")
    ax.set_yscale("log")
    # fixed tick labels: majors at 1, 2, 5 × 10^k written 20k / 1.5M, no minor labels (they overlapped)
    ax.xaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(FuncFormatter(_work_label))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("work: triangles × time steps")
    ax.set_ylabel("relative error")
    ax.set_title(f"{case}: {CASES[case]['note']}", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, f"{case}.png"), dpi=110)
    plt.close(fig)


FIELDS = ["case", "sweep", "precision", "resolution", "safety", "penalty_factor", "triangles", "steps", "dt",
          "wall", "wall_total", "error", "status"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer and coarser settings")
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--precisions", default="f64,f32", help="comma list of precisions (default f64,f32)")
    ap.add_argument("--out", default=OUT, help="output directory (default docs/accuracy)")
    ap.add_argument("--reanalyse", action="store_true", help="only redo the tables and plots from results.csv")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--jobs", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        worker(args.worker, json.loads(open(args.jobs).read()))
        return
    os.makedirs(args.out, exist_ok=True)
    if args.reanalyse:
        with open(os.path.join(args.out, "results.csv")) as f:
            rows = list(csv.DictReader(f))
        for r in rows:
            for k in ("resolution", "triangles", "steps"):
                r[k] = int(r[k]) if r[k] else 0
            for k in ("safety", "penalty_factor", "dt", "wall", "wall_total", "error"):
                r[k] = float(r[k]) if r[k] else math.nan
        md = analyse(rows, args.out)
        with open(os.path.join(args.out, "results.md"), "w") as f:
            f.write(md)
        print(md)
        return
    rows = []
    for prec in args.precisions.split(","):
        jobs = []
        for case in args.cases:
            cf = configs(case, args.quick)
            if prec != "f64":       # other precisions: the resolution sweep only
                cf = [c for c in cf if c["sweep"] == "resolution"]
            jobs += [dict(c, case=case) for c in cf]
        path = os.path.join(args.out, f".jobs_{prec}.json")
        with open(path, "w") as f:
            json.dump(jobs, f)
        print(f"--- {prec}: {len(jobs)} runs in a subprocess", flush=True)
        proc = subprocess.Popen([sys.executable, os.path.abspath(__file__), "--worker", prec, "--jobs", path],
                                stdout=subprocess.PIPE, text=True, cwd=ROOT)
        for line in proc.stdout:
            if line.startswith("ROW "):
                r = json.loads(line[4:])
                rows.append(r)
                print(f"{r['case']:10s} {r['sweep']:10s} {prec} n={r['resolution']:<4} α={r['safety']:<5g} "
                      f"p={r['penalty_factor']:<6g} wall {r['wall']:8.3f} s  error {r['error']:.3e}  {r['status']}",
                      flush=True)
        proc.wait()
        os.remove(path)
    with open(os.path.join(args.out, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    md = analyse(rows, args.out)
    with open(os.path.join(args.out, "results.md"), "w") as f:
        f.write(md)
    print(md)


if __name__ == "__main__":
    main()

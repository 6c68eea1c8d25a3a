"""Friction and contact penalty swept against the analytic stop distance of a sliding block.

    python demos/sweep_friction.py            # 6 points on 2 worker processes -> out/sweep_friction.csv, .png
    python demos/sweep_friction.py --short    # 4 points, shorter runs (used by tests/test_sweep.py)
    python demos/sweep_friction.py --scheduler tcp://host:8786    # the same sweep on a Dask cluster

A block launched at v0 = 1 m/s on a fixed floor (examples/sliding_block.toml) slows down under
Coulomb friction and stops after d = v0² / (2 μ g).  The sweep runs μ in {0.2, 0.4, 0.6} times
the contact penalty p in {10 E, 50 E} as a grid, one simulation per point in its own worker
process, and appends each result to a CSV as it completes.  It prints a Markdown table, draws
the simulated and analytic stop distances against μ (if matplotlib is installed: the plot
extra), and ``check`` asserts that every point stopped within 3 % of the analytic distance.
"""
from __future__ import annotations

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "sweep_friction"
SCENE = os.path.join(_common.ROOT, "examples", "sliding_block.toml")
G = 9.81                    # m/s², as the scene's gravity
V0 = 1.0                    # m/s, the block's initial velocity in the scene
YOUNG = 1.0e7               # Pa, the scene's Young's modulus
MU = (0.2, 0.4, 0.6)
PENALTY = (10, 50)          # × young
TOLERANCE = 0.03            # relative error of the stop distance


def stop_distance(mu: float) -> float:
    """Stop distance of a rigid block with Coulomb friction, v0² / (2 μ g) [m]."""
    return V0 * V0 / (2.0 * mu * G)


def make_sweep(short: bool):
    from taichi_fdem.sweep import Sweep
    mus = MU[1:] if short else MU
    # run a little past the slowest stop, t = v0 / (μ g)
    duration = 1.2 * V0 / (min(mus) * G)
    return Sweep(SCENE, axes={"materials.rock.friction": list(mus),
                              "materials.rock.penalty": [k * YOUNG for k in PENALTY]},
                 metrics=["displacement:block", "velocity:block", "time"], duration=duration)


def table(rows) -> list[dict]:
    out = []
    for r in rows:
        mu, p = r["materials.rock.friction"], r["materials.rock.penalty"]
        d_ana = stop_distance(mu)
        ok = r["status"] == "ok"
        d = r.get("block_dx") if ok else None
        out.append({"mu": mu, "penalty_over_E": p / YOUNG, "d_sim": d, "d_analytic": d_ana,
                    "rel_error": (d - d_ana) / d_ana if ok else None, "v_end": r.get("block_vx") if ok else None,
                    "status": r["status"], "error": r["error"], "wall_s": r["wall_s"]})
    return out


def markdown(results) -> str:
    lines = ["| μ | penalty | stop distance sim [m] | v0²/(2μg) [m] | error | v end [m/s] | wall [s] | status |",
             "|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in results:
        if r["status"] == "ok":
            lines.append(f"| {r['mu']:.1f} | {r['penalty_over_E']:.0f} E | {r['d_sim']:.4f} | {r['d_analytic']:.4f} | "
                         f"{100 * r['rel_error']:+.2f} % | {r['v_end']:+.1e} | {r['wall_s']:.1f} | ok |")
        else:
            lines.append(f"| {r['mu']:.1f} | {r['penalty_over_E']:.0f} E | – | {r['d_analytic']:.4f} | – | – | "
                         f"{r['wall_s']:.1f} | {r['status']}: {r['error'][:60]} |")
    return "\n".join(lines)


def plot(results, path: str) -> bool:
    """Stop distance against μ (analytic curve, simulated points per penalty); False without matplotlib."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    import numpy as np
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    mu = np.linspace(0.15, 0.65, 200)
    ax.plot(mu, [stop_distance(m) for m in mu], "k-", label="analytic v0²/(2μg)")
    for k, marker in zip(PENALTY, ("o", "s")):
        pts = [r for r in results if r["status"] == "ok" and round(r["penalty_over_E"]) == k]
        ax.plot([r["mu"] for r in pts], [r["d_sim"] for r in pts], marker, mfc="none", ms=9, label=f"FDEM, p = {k} E")
        ax2.plot([r["mu"] for r in pts], [100 * r["rel_error"] for r in pts], marker + "-", label=f"p = {k} E")
    ax.set_xlabel("friction coefficient μ")
    ax.set_ylabel("stop distance [m]")
    ax.legend()
    ax.set_title("sliding block: stop distance")
    ax2.axhspan(-100 * TOLERANCE, 100 * TOLERANCE, color="0.9", label="±3 %")
    ax2.axhline(0.0, color="k", lw=0.8)
    ax2.set_xlabel("friction coefficient μ")
    ax2.set_ylabel("error of the stop distance [%]")
    ax2.legend()
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return True


def check(results) -> dict:
    worst = max(abs(r["rel_error"]) for r in results if r["status"] == "ok") if results else float("nan")
    out = {"points": len(results), "max_rel_error": worst}
    bad = [r for r in results if r["status"] != "ok"]
    assert not bad, f"{len(bad)} points failed: {bad[0]['status']}: {bad[0]['error']}"
    for r in results:
        assert abs(r["rel_error"]) < TOLERANCE, (f"μ = {r['mu']}, p = {r['penalty_over_E']:.0f} E: stopped after "
                                                 f"{r['d_sim']:.4f} m, analytic {r['d_analytic']:.4f} m "
                                                 f"({100 * r['rel_error']:+.2f} %)")
        assert abs(r["v_end"]) < 1e-3 * V0, f"μ = {r['mu']}: the block is still moving at {r['v_end']:.3g} m/s"
    return out


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(prog=f"demos/{NAME}.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--short", action="store_true", help="4 points, shorter runs (used by the tests)")
    ap.add_argument("--out", default=None, help=f"CSV path; default out/{NAME}.csv (the plot is written next to it)")
    ap.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
    ap.add_argument("--scheduler", default=None, help="a Dask scheduler address tcp://host:port instead")
    ap.add_argument("--resume", action="store_true", help="keep the points already in the CSV")
    ap.add_argument("--precision", choices=("f64", "f32"), default="f64")
    args = ap.parse_args(argv)
    out = args.out or os.path.join(_common.ROOT, "out", f"{NAME}_short.csv" if args.short else f"{NAME}.csv")
    clock = _common.Timer()
    sweep = make_sweep(args.short)
    sweep.init = {"arch": "cpu", "precision": args.precision}
    where = f"Dask scheduler {args.scheduler}" if args.scheduler else f"{args.workers} worker processes"
    print(f"{NAME}: {len(sweep)} points (μ x penalty) on {where}, {sweep.duration:.3g} s simulated each", flush=True)

    def report(row, done, total):
        print(f"  [{done}/{total}] μ = {row['materials.rock.friction']}, p = {row['materials.rock.penalty']} Pa: "
              f"{row['status']} in {float(row['wall_s']):.1f} s", flush=True)

    rows = sweep.run(workers=args.workers, output=out, resume=args.resume, scheduler=args.scheduler,
                     on_result=report)
    results = table(rows)
    print()
    print(markdown(results))
    print()
    png = os.path.splitext(out)[0] + ".png"
    if plot(results, png):
        print(f"  wrote {out} and {png}")
    else:
        png = None
        print(f"  wrote {out}; matplotlib is not installed, no plot (pip install 'taichi-fdem[plot]')")
    result = check(results)
    result.update(csv=os.path.abspath(out), png=png, results=results, wall_s=clock())
    print(f"  largest stop-distance error {100 * result['max_rel_error']:.2f} % (tolerance {100 * TOLERANCE:.0f} %); "
          f"{result['wall_s']:.1f} s wall time")
    return result


if __name__ == "__main__":
    main()
    sys.exit(0)

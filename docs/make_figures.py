"""Figures and the measured-error table of the verification page.

Runs every case of ``taichi_fdem.verification.CASES`` at the settings its test uses
(``tests/test_verification.py``, ``tests/test_fracture.py``, ``tests/test_rock_verification.py``:
the cases' defaults) and writes

* ``docs/figures/verification_errors.png``: the relative error of each case, on a log scale;
* ``docs/verification_results.md``: the table the verification page includes (case, measured
  error, steps, triangles where known).

    python docs/make_figures.py                 # every case (a few minutes on 2 cores)
    python docs/make_figures.py wave hertz      # chosen cases; the others keep their last row

The per-case convergence plots in ``docs/accuracy/`` come from ``benchmarks/accuracy.py``.
"""
from __future__ import annotations

import json
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
RESULTS = os.path.join(HERE, "figures", "verification_results.json")


def run_cases(names, save=None) -> dict:
    """{case: {"error", "steps", "seconds"}} for the named cases of ``verification.CASES``;
    ``save(results)`` is called after each case, so an interrupted run keeps what it measured."""
    import taichi_fdem as fdem
    from taichi_fdem import verification as V
    fdem.init(arch="cpu", precision="f64")
    out = {}
    for name in names:
        t0 = time.perf_counter()
        r = V.CASES[name]()
        out[name] = {"error": float(r["error"]), "steps": int(r.get("steps", 0)),
                     "seconds": round(time.perf_counter() - t0, 1)}
        print(f"{name:16s} error {out[name]['error']:.3g}  ({out[name]['seconds']} s)", flush=True)
        if save is not None:
            save(out)
    return out


def write_outputs(results: dict) -> None:
    """The PNG bar chart and the Markdown table from ``results``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(results)
    errs = [max(results[n]["error"], 1e-16) for n in names]
    fig, ax = plt.subplots(figsize=(7.0, 3.2), dpi=110)
    ax.bar(range(len(names)), errs, color="#3b6ea8")
    ax.set_yscale("log")
    ax.set_xticks(range(len(names)), names, rotation=40, ha="right", fontsize=8)
    ax.set_ylabel("relative error")
    ax.set_title("verification cases at their test settings", fontsize=9)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "figures", "verification_errors.png"))
    plt.close(fig)
    lines = ["| case | measured relative error | time steps |", "|---|--:|--:|"]
    for n in names:
        lines.append(f"| `{n}` | {results[n]['error']:.3g} | {results[n]['steps'] or '—'} |")
    with open(os.path.join(HERE, "verification_results.md"), "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")


def main(argv=None) -> int:
    from taichi_fdem.verification import CASES
    names = list(argv if argv is not None else sys.argv[1:]) or list(CASES)
    unknown = [n for n in names if n not in CASES]
    if unknown:
        print(f"unknown case(s) {unknown}; choose from {list(CASES)}", file=sys.stderr)
        return 2
    old = json.load(open(RESULTS)) if os.path.exists(RESULTS) else {}
    os.makedirs(os.path.dirname(RESULTS), exist_ok=True)

    def save(new):
        merged = {n: {**old, **new}[n] for n in CASES if n in {**old, **new}}
        with open(RESULTS, "w") as f:
            json.dump(merged, f, indent=1)
        write_outputs(merged)

    run_cases(names, save=save)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""demos/calibrate_granite.py: the grain-based granite model and its calibration demo."""
import csv
import math
import os

import pytest

from conftest import load_demo

pytest.importorskip("scipy")


def test_argument_handling():
    mod = load_demo("calibrate_granite")
    a = mod.parse(["--short"])
    assert a.workers == 1 and a.out.endswith("calibrate_granite_short.csv")
    assert mod.parse([]).workers == 2
    for bad in (["--budget", "1", "5", "5"], ["--workers", "0"]):
        with pytest.raises(SystemExit):
            mod.parse(bad)


def test_elastic_stage_modulus_proportional_to_the_grain_modulus():
    """Stage 1's model at fixed dimensionless groups (every modulus, the joint penalty and the
    strengths scale with E_g; the density is fixed, so time scales as 1/√E_g): the measured E
    scales with E_g and ν does not change, to the sampling of the curve (the run's step count
    and sample times round differently, 6e-4 measured)."""
    mod = load_demo("calibrate_granite")
    mod._common.init()
    p = {"short": True, "grain_young": 50e9, "grain_poisson": 0.25, "tensile_strength": 8e6, "cohesion": 60e6}
    a = mod.model_elastic(p)
    b = mod.model_elastic({**p, "grain_young": 100e9, "tensile_strength": 16e6, "cohesion": 120e6})
    assert b["young"] / a["young"] == pytest.approx(2.0, rel=3e-3)
    assert b["poisson"] == pytest.approx(a["poisson"], rel=3e-3)
    # the jointed grain aggregate: softer than the Voigt mean of the minerals' moduli (joint
    # compliance, Reuss-like averaging), stiffer than the softest mineral
    voigt = sum(mod.MINERALS[k] * mod.STIFFNESS[k] for k in mod.MINERALS) * 50e9
    assert 0.5 * 50e9 < a["young"] < voigt
    assert 0.15 < a["poisson"] < 0.35


@pytest.mark.slow
def test_short_mode_writes_history_and_plot(tmp_path):
    """--short: 3 stages of 2 evaluations, a CSV row per evaluation plus the final run, and the
    final measurements are the ones of the lab tests at the best parameters."""
    mod = load_demo("calibrate_granite")
    out = tmp_path / "cal.csv"
    r = mod.main(["--short", "--out", str(out)])
    assert r["evaluations"] == 6
    rows = list(csv.DictReader(open(out)))
    assert len(rows) == 7 and [x["stage"] for x in rows] == ["elastic"] * 2 + ["bts"] * 2 + ["ucs"] * 2 + ["final"]
    for k, t in r["targets"].items():
        assert r["errors"][k] == pytest.approx((r["measured"][k] - t) / t, rel=1e-12)
        assert math.isfinite(r["measured"][k])
    # the best of each stage is one of its evaluations, and the final run uses them all
    for name, cal in r["calibrations"]:
        assert any(all(h[q] == v for q, v in cal.best.items()) for h in cal.history), name
        for q, v in cal.best.items():
            assert r["best"][q] == v
    assert r["ucs"].peak_stress == r["measured"]["ucs"] and r["bts"].peak_stress == r["measured"]["bts"]
    if r["png"]:
        assert os.path.getsize(r["png"]) > 0

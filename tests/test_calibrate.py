"""fdem.calibrate: differential evolution over batches of sweep points."""
import math

import numpy as np
import pytest

import taichi_fdem as fdem

pytest.importorskip("scipy")


def analytic(p):
    """Two measured values of two parameters (u = a b, v = a / b + b); fails for a < 0.3."""
    a, b = p["a"], p["b"]
    if a < 0.3:
        raise RuntimeError("diverged")
    return {"u": a * b, "v": a / b + b, "unused": math.sin(a)}


TRUE = {"a": 1.7, "b": 0.6}
BOUNDS = {"a": (0.1, 3.0), "b": (0.2, 2.0)}


def _targets():
    t = analytic(TRUE)
    return {"u": t["u"], "v": (t["v"], 2.0)}


@pytest.fixture(scope="module")
def serial():
    return fdem.calibrate(analytic, BOUNDS, _targets(), budget=300, seed=3, workers=1)


def test_recovers_two_parameters_within_5_percent(serial, tmp_path):
    for k, v in TRUE.items():
        assert abs(serial.best[k] - v) / v < 0.05, (k, serial.best)
    assert serial.evaluations <= 300 and len(serial.history) == serial.evaluations
    # failures (a < 0.3) are recorded, not fatal
    failed = [r for r in serial.history if r["status"] != "ok"]
    assert failed and all(r["a"] < 0.3 and "diverged" in r["error"] for r in failed)
    assert all(r["score"] == fdem.sweep.calibrate.FAILED_SCORE for r in failed)
    # the best record's score is the objective of its parameters
    m = analytic(serial.best)
    t = _targets()
    s = ((m["u"] - t["u"]) / t["u"]) ** 2 + 2.0 * ((m["v"] - t["v"][0]) / t["v"][0]) ** 2
    assert serial.best_score == pytest.approx(s, rel=1e-12)
    assert min(r["score"] for r in serial.history) == serial.best_score
    rows = open(serial.to_csv(tmp_path / "h.csv")).read().splitlines()
    assert len(rows) == serial.evaluations + 1 and rows[0].startswith("evaluation,batch,a,b,u,v,score")
    serial.plot(tmp_path / "c.png")
    assert (tmp_path / "c.png").stat().st_size > 0


def test_same_seed_same_result_with_two_workers(serial):
    par = fdem.calibrate(analytic, BOUNDS, _targets(), budget=300, seed=3, workers=2)
    assert par.best == serial.best
    assert [r["score"] for r in par.history] == [r["score"] for r in serial.history]
    other = fdem.calibrate(analytic, BOUNDS, _targets(), budget=60, seed=4, workers=1)
    assert [r["a"] for r in other.history[:5]] != [r["a"] for r in serial.history[:5]]


def test_bad_input_is_named():
    with pytest.raises(ValueError, match=r"params\['a'\] needs finite low < high"):
        fdem.calibrate(analytic, {"a": (2.0, 1.0)}, {"u": 1.0})
    with pytest.raises(ValueError, match="weights for names that are no target"):
        fdem.calibrate(analytic, BOUNDS, {"u": 1.0}, weights={"x": 1.0})
    with pytest.raises(ValueError, match="smaller than one generation"):
        fdem.calibrate(analytic, BOUNDS, {"u": 1.0}, budget=5, popsize=5)
    with pytest.raises(fdem.sweep.SweepError, match="every one of the"):
        fdem.calibrate(analytic, {"a": (0.0, 0.2), "b": (1.0, 2.0)}, {"u": 1.0}, budget=20, popsize=5)


def elastic_ucs(p):
    """E and ν measured by fdem.lab.ucs on a coarse elastic specimen (a real FDEM run, ~1 s)."""
    m = fdem.Material(density=2600.0, young=p["young"], poisson=p["poisson"])
    r = fdem.lab.ucs(m, 0.05, 0.1, 0.025, samples=20, rate_transits=10, safety=0.4, max_strain=5e-4)
    return {"E": r.young, "nu": r.poisson}


@pytest.mark.slow
def test_recovers_E_and_nu_of_a_real_fdem_model():
    """Targets produced by the model itself at E = 30 GPa, ν = 0.25: calibration over
    E in [15, 60] GPa, ν in [0.1, 0.4] finds both within 5 % (60 evaluations of ~1-2 s)."""
    true = {"young": 30e9, "poisson": 0.25}
    t = elastic_ucs(true)
    cal = fdem.calibrate(elastic_ucs, {"young": (15e9, 60e9), "poisson": (0.1, 0.4)}, {"E": t["E"], "nu": t["nu"]},
                         budget=60, seed=1, workers=1, popsize=5)
    for k, v in true.items():
        assert abs(cal.best[k] / v - 1) < 0.05, (k, cal.best, cal.evaluations)
    assert all(r["status"] == "ok" for r in cal.history)


def test_dask_path_gives_the_serial_result(serial):
    """The same seed on a Dask scheduler (an in-process LocalCluster) evaluates the same points."""
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as lc, \
            distributed.Client(lc) as client:
        dk = fdem.calibrate(analytic, BOUNDS, _targets(), budget=300, seed=3, scheduler=client)
    assert dk.evaluations == serial.evaluations
    assert [r["score"] for r in dk.history] == pytest.approx([r["score"] for r in serial.history], rel=1e-9)
    assert dk.best == pytest.approx(serial.best, rel=1e-9)
    assert [r["status"] for r in dk.history] == [r["status"] for r in serial.history]


def test_budget_smaller_than_the_population_of_one_parameter():
    """A budget that cuts the first generation short (2 of SciPy's 5 members, 1 parameter) stops
    after exactly 2 evaluations, and the best is the better of the two."""
    cal = fdem.calibrate(lambda p: {"u": p["a"] ** 2}, {"a": (0.5, 2.0)}, {"u": 1.0}, budget=2, seed=0,
                         workers=1, popsize=1)
    assert cal.evaluations == 2
    scores = [(r["a"] ** 2 - 1.0) ** 2 for r in cal.history]
    assert cal.best_score == pytest.approx(min(scores), rel=1e-12)

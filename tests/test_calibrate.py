"""fdem.calibrate: its methods (bracketing, least squares, Bayesian, differential evolution) over
batches of sweep points, on analytic responses and on real lab tests."""
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
    return fdem.calibrate(analytic, BOUNDS, _targets(), budget=300, seed=3, workers=1, method="de")


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
    par = fdem.calibrate(analytic, BOUNDS, _targets(), budget=300, seed=3, workers=2, method="de")
    assert par.best == serial.best
    assert [r["score"] for r in par.history] == [r["score"] for r in serial.history]
    other = fdem.calibrate(analytic, BOUNDS, _targets(), budget=60, seed=4, workers=1, method="de")
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
        dk = fdem.calibrate(analytic, BOUNDS, _targets(), budget=300, seed=3, scheduler=client, method="de")
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


# ----------------------------------------------------------------------------------------------
# the methods for few evaluations: "bracket", "least_squares", "bayes"; the result's uncertainty
# ----------------------------------------------------------------------------------------------
def power(p):
    """A monotone response of one parameter (u = 1.1 a^1.2)."""
    return {"u": 1.1 * p["a"] ** 1.2}


def test_auto_brackets_one_parameter_from_one_target():
    """One parameter, one target: the two ends of the box, then Brent's method, until the target is
    within rtol (tolerance / 10 = 0.2 %); a power law is matched in a handful of evaluations."""
    t = power({"a": 6.0})["u"]
    cal = fdem.calibrate(power, {"a": (2.0, 20.0)}, {"u": t}, budget=12)
    assert cal.method == "bracket" and cal.converged
    assert [r["a"] for r in cal.history[:2]] == [2.0, 20.0] and cal.history[0]["batch"] == cal.history[1]["batch"]
    assert cal.evaluations <= 6
    assert abs(cal.best_measured["u"] / t - 1) <= 0.002
    # u within 0.2 % means a within 0.2 / 1.2 %
    assert abs(cal.best["a"] / 6.0 - 1) < 0.002
    assert cal.evaluations_to({"a": 6.0}, 0.02) <= cal.evaluations
    lo, hi = cal.uncertainty["a"]
    assert lo <= cal.best["a"] <= hi
    assert all(abs(power(r)["u"] / t - 1) <= 0.02 for r in cal.within)
    assert {r["a"] for r in cal.within} >= {cal.best["a"]}
    assert min(r["a"] for r in cal.within) == lo and max(r["a"] for r in cal.within) == hi


def test_bracket_reports_a_target_outside_the_response():
    cal = fdem.calibrate(power, {"a": (2.0, 3.0)}, {"u": 100.0}, budget=12, method="bracket")
    assert cal.evaluations == 2 and not cal.converged
    assert "is not bracketed" in cal.message and "widen the box" in cal.message
    assert cal.within == [] and all(math.isnan(v) for v in cal.uncertainty["a"])


def test_least_squares_recovers_two_parameters_in_few_evaluations():
    """Two parameters, two targets (the analytic response above): the default method is the
    trust-region least squares on the relative errors, within 1 % in at most 40 evaluations;
    the same evaluations on two worker processes."""
    cal = fdem.calibrate(analytic, BOUNDS, _targets(), budget=40)
    assert cal.method == "least_squares" and cal.converged, cal
    assert cal.evaluations <= 40
    for k, v in TRUE.items():
        assert abs(cal.best[k] / v - 1) < 0.01, (k, cal.best)
    assert cal.evaluations_to(TRUE, 0.05) <= cal.evaluations
    # every record's score is the objective of its parameters
    t = _targets()
    for r in cal.history:
        m = analytic(r)
        s = ((m["u"] - t["u"]) / t["u"]) ** 2 + 2.0 * ((m["v"] - t["v"][0]) / t["v"][0]) ** 2
        assert r["score"] == pytest.approx(s, rel=1e-12)
    par = fdem.calibrate(analytic, BOUNDS, _targets(), budget=40, workers=2)
    assert [(r["a"], r["b"], r["score"]) for r in par.history] == [(r["a"], r["b"], r["score"]) for r in cal.history]


def test_least_squares_from_a_start_point_and_its_uncertainty():
    cal = fdem.calibrate(analytic, BOUNDS, _targets(), budget=40, start={"a": 1.0, "b": 1.0}, tolerance=0.05)
    assert cal.history[0]["a"] == 1.0 and cal.history[0]["b"] == 1.0
    assert cal.tolerance == 0.05 and cal.within
    for k in TRUE:
        lo, hi = cal.uncertainty[k]
        assert lo <= cal.best[k] <= hi
        assert lo == min(r[k] for r in cal.within) and hi == max(r[k] for r in cal.within)
    for r in cal.within:
        assert all(abs(e) <= 0.05 for e in cal.relative_errors(r).values())


def test_bayes_calibrates_with_optuna():
    pytest.importorskip("optuna", reason="method='bayes' needs the optional Optuna (pip install taichi-fdem[calibrate])")
    t = power({"a": 6.0})["u"]
    a = fdem.calibrate(power, {"a": (2.0, 20.0)}, {"u": t}, budget=25, seed=2, method="bayes")
    b = fdem.calibrate(power, {"a": (2.0, 20.0)}, {"u": t}, budget=25, seed=2, method="bayes")
    assert a.method == "bayes" and a.evaluations <= 25
    assert [r["a"] for r in a.history] == [r["a"] for r in b.history]         # the seed fixes the run
    assert abs(a.best["a"] / 6.0 - 1) < 0.1, a


def test_bayes_without_optuna_names_the_extra(monkeypatch):
    import sys
    monkeypatch.setitem(sys.modules, "optuna", None)
    with pytest.raises(ImportError, match=r"taichi-fdem\[calibrate\]"):
        fdem.calibrate(power, {"a": (2.0, 20.0)}, {"u": 5.0}, budget=10, method="bayes")


def test_bad_method_settings_are_named():
    t = {"u": 5.0}
    with pytest.raises(ValueError, match="method must be one of"):
        fdem.calibrate(power, {"a": (2.0, 20.0)}, t, method="newton")
    with pytest.raises(ValueError, match="one parameter from one target"):
        fdem.calibrate(analytic, BOUNDS, {"u": 1.0}, method="bracket")
    with pytest.raises(ValueError, match="popsize is a setting of method='de'"):
        fdem.calibrate(power, {"a": (2.0, 20.0)}, t, method="least_squares", popsize=5)
    with pytest.raises(ValueError, match="start is a setting of method='least_squares'"):
        fdem.calibrate(power, {"a": (2.0, 20.0)}, t, method="bracket", start={"a": 3.0})
    with pytest.raises(ValueError, match=r"start\['a'\] = 30.0 lies outside"):
        fdem.calibrate(power, {"a": (2.0, 20.0)}, t, method="least_squares", start={"a": 30.0})
    with pytest.raises(ValueError, match="tolerance must be"):
        fdem.calibrate(power, {"a": (2.0, 20.0)}, t, tolerance=0.0)
    with pytest.raises(ValueError, match="every target has weight 0"):
        fdem.calibrate(power, {"a": (2.0, 20.0)}, {"u": (5.0, 0.0)})
    # a setting of differential evolution given to "auto" runs differential evolution
    assert fdem.calibrate(power, {"a": (2.0, 20.0)}, t, budget=10, popsize=5).method == "de"


# ----------------------------------------------------------------------------------------------
# real lab tests: targets the model itself produced
# ----------------------------------------------------------------------------------------------
LCH = 9.375e-3          # characteristic length E G_I / f_t² [m] of the rocks below


def _rock(ft, c):
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return fdem.Material(density=2600.0, young=20e9, poisson=0.2, tensile_strength=ft, cohesion=c,
                             friction_angle=35.0, fracture_energy=LCH * ft * ft / 20e9)


def _bts(ft, c, across=20, samples=240):
    """Brazilian strength (centre stress) of a 50 mm disc, ``across`` elements across, ``samples``
    load samples (``fdem.lab.brazilian``'s setting), the other settings the lab defaults."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return fdem.lab.brazilian(_rock(ft, c), 0.05, 0.05 / across, samples=samples).centre_stress


def bts_of_ft(p):
    """The Brazilian strength of a disc 16 elements across, the load sampled 80 times, at
    f_t = p["tensile_strength"], c = 3 f_t."""
    ft = p["tensile_strength"]
    return {"bts": _bts(ft, 3.0 * ft, across=16, samples=80)}


def bts_and_ucs(p):
    import warnings
    ft, c = p["tensile_strength"], p["cohesion"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        u = fdem.lab.ucs(_rock(ft, c), 0.05, 0.1, 0.0125).peak_stress
    return {"bts": _bts(ft, c), "ucs": u}


def test_recovers_the_tensile_strength_from_a_brazilian_strength_within_2_percent_in_12_runs():
    """f_t in [2, 12] MPa (c = 3 f_t, l_ch fixed) from the Brazilian strength that f_t = 6 MPa
    produced: the default method (bracketing) ends within 2 % of 6 MPa in at most 12 runs."""
    t = bts_of_ft({"tensile_strength": 6e6})["bts"]
    cal = fdem.calibrate(bts_of_ft, {"tensile_strength": (2e6, 12e6)}, {"bts": t}, budget=12)
    assert cal.method == "bracket" and cal.evaluations <= 12
    assert all(r["status"] == "ok" for r in cal.history)
    assert abs(cal.best["tensile_strength"] / 6e6 - 1) < 0.02, cal.history
    assert cal.evaluations_to({"tensile_strength": 6e6}, 0.02) <= 12
    lo, hi = cal.uncertainty["tensile_strength"]
    assert lo <= cal.best["tensile_strength"] <= hi


@pytest.mark.slow
def test_recovers_tensile_strength_and_cohesion_from_bts_and_ucs_within_5_percent_in_40_runs():
    """f_t in [2, 12] MPa and c in [10, 60] MPa from the Brazilian strength and the UCS that
    f_t = 6 MPa, c = 20 MPa produced: the default method (least squares) ends within 5 % of both
    in at most 40 runs."""
    true = {"tensile_strength": 6e6, "cohesion": 20e6}
    t = bts_and_ucs(true)
    cal = fdem.calibrate(bts_and_ucs, {"tensile_strength": (2e6, 12e6), "cohesion": (10e6, 60e6)}, t, budget=40)
    assert cal.method == "least_squares" and cal.evaluations <= 40
    for k, v in true.items():
        assert abs(cal.best[k] / v - 1) < 0.05, (k, cal.best, cal.evaluations)
    assert cal.evaluations_to(true, 0.05) <= 40

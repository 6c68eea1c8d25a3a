"""Calibration: micro-parameters of a model tuned until its measured values match lab targets.

::

    def model(p):                                   # module-level: sent to worker processes
        r = fdem.lab.brazilian(fdem.Material(tensile_strength=p["tensile_strength"], ...), 0.05, 0.0025)
        return {"bts": r.centre_stress}

    cal = fdem.calibrate(model, params={"tensile_strength": (2e6, 20e6)}, targets={"bts": 9.8e6},
                         budget=12, workers=2)
    cal.best, cal.uncertainty, cal.history, cal.plot("convergence.png"), cal.to_csv("history.csv")

Each evaluation is a simulation of seconds to minutes, so the methods are chosen for few
evaluations (``method=``):

* ``"bracket"`` (one parameter, one target whose value is monotone in it): the two ends of the
  box (one batch), then Brent's method (:func:`scipy.optimize.brentq`: inverse quadratic
  interpolation safeguarded by bisection; Brent 1973) on the residual ``log(m / t)`` against
  ``log(x)`` (``(m - t) / t`` against ``x`` where the range or the values are not positive), so
  that a power law ``m = k x**p`` is matched by the first interpolated point.
* ``"least_squares"`` (any number of parameters and targets): SciPy's trust-region reflective
  least squares (:func:`scipy.optimize.least_squares`, ``method="trf"``) on the residuals
  ``sqrt(w_k) log(m_k / t_k)``, over the logarithms of the parameters with a positive range (the
  others linear), the box scaled to the unit cube, from its centre (or ``start``); the Jacobian
  by forward differences of ``diff_step`` (a fraction of each scaled range), its ``d``
  evaluations one batch.
* ``"bayes"``: Bayesian optimisation of the objective by Optuna's TPE sampler (Bergstra et al.
  2011) or its Gaussian-process sampler (``sampler="gp"``, which needs PyTorch), ``workers``
  trials per batch; ``pip install "taichi-fdem[calibrate]"``.
* ``"de"``: SciPy's differential evolution (Storn & Price 1997;
  :func:`scipy.optimize.differential_evolution`) with a Latin-hypercube initial population and
  deferred updating, each generation one batch.
* ``"auto"`` (the default): ``"de"`` when a setting of differential evolution (``popsize``,
  ``tol``) is given; else ``"bracket"`` for one parameter and one target; else
  ``"least_squares"``.

``"bracket"``, ``"least_squares"`` and ``"bayes"`` stop once an evaluation has every target's
relative error at most ``rtol`` (a converged calibration, ``converged`` True), or when their
own step tolerance is met (the first two) or the budget is used.  A batch runs on the sweep runner's local worker processes (kept for the
whole calibration, so that each initialises Taichi once), or as a
:class:`~taichi_fdem.sweep.Sweep` on a Dask scheduler; ``workers=1`` runs it in this process
through :func:`~taichi_fdem.sweep.run_point`, the sweep's worker function.  The evaluations
are a function of the inputs and ``seed`` alone, whatever the number of workers, except for
``"bayes"``, whose batches hold ``workers`` trials.

Objective: ``sum_k w_k ((m_k - t_k) / t_k)**2`` over the targets k (measured m_k, target t_k,
weight w_k; relative errors, so targets of different units weigh alike).  An evaluation that
fails (raises, is unstable, lacks a target's value or returns a non-finite one) is recorded in
the history with its error and scored :data:`FAILED_SCORE`.  The uncertainty of the result is
the spread of the evaluated points whose every target lies within ``tolerance``
(:attr:`Calibration.uncertainty`).
"""
from __future__ import annotations

import csv
import math
import os
import pickle
import tempfile
import time

import numpy as np

from .methods import (FAILED_SCORE, _BudgetReached, _Converged, _Stopped, _run_bayes, _run_bracket, _run_de,
                      _run_least_squares)
from .params import SweepError
from .worker import FunctionPoint, run_point

__all__ = ["calibrate", "Calibration", "FAILED_SCORE", "METHODS"]

#: the values of ``calibrate(method=...)``
METHODS = ("auto", "bracket", "least_squares", "bayes", "de")


class Calibration:
    """The result of :func:`calibrate`.

    * ``best`` -- dict {parameter: value} of the lowest objective seen;
    * ``best_score`` -- that objective; ``best_measured`` -- the model's values there;
    * ``history`` -- list of dicts, one per evaluation in order: ``evaluation``, ``batch``,
      the parameters, the measured values, ``score``, ``status`` ("ok" or the failure),
      ``error``, ``wall_s``;
    * ``within`` -- the records of ``history`` whose every target (of non-zero weight) is
      within ``tolerance`` (relative error); ``uncertainty`` -- {parameter: (low, high)}, the
      range of those points (NaN when none is);
    * ``evaluations``, ``batches``, ``wall_s`` (total wall time [s]), ``method`` (the one
      run), ``converged`` (the method's own convergence test stopped it, not the budget),
      ``message`` (why it stopped), ``params``, ``targets`` (name -> (value, weight)),
      ``tolerance``.
    """

    def __init__(self, params, targets, tolerance: float = 0.02, method: str = "de"):
        self.params, self.targets = params, targets
        self.tolerance, self.method = float(tolerance), method
        self.history: list = []
        self.best: dict = {}
        self.best_score = math.inf
        self.best_measured: dict = {}
        self.batches = 0
        self.wall_s = 0.0
        self.message = ""
        self.converged = False

    @property
    def evaluations(self) -> int:
        """Number of model evaluations (failures included)."""
        return len(self.history)

    def relative_errors(self, record: dict | None = None) -> dict:
        """(m - t) / t of every target at ``best`` (or at a record of :attr:`history`)."""
        got = self.best_measured if record is None else record
        out = {}
        for k, (t, _) in self.targets.items():
            v = got.get(k)
            out[k] = (float(v) - t) / t if v is not None else math.nan
        return out

    @property
    def within(self) -> list:
        """The ``ok`` records of :attr:`history` whose every target of non-zero weight has a
        relative error of at most :attr:`tolerance`."""
        out = []
        for r in self.history:
            if r["status"] != "ok":
                continue
            e = self.relative_errors(r)
            if all(abs(e[k]) <= self.tolerance for k, (_, w) in self.targets.items() if w > 0):
                out.append(r)
        return out

    @property
    def uncertainty(self) -> dict:
        """{parameter: (low, high)}: the range of the points within :attr:`tolerance` (a zero
        width when one point is; NaN when none is)."""
        pts = self.within
        if not pts:
            return {k: (math.nan, math.nan) for k in self.params}
        return {k: (min(r[k] for r in pts), max(r[k] for r in pts)) for k in self.params}

    def evaluations_to(self, true: dict, rel: float) -> int | None:
        """The number of evaluations after which the best point so far first has every
        parameter within ``rel`` (relative) of ``true`` = {parameter: value} (a calibration to
        targets of known origin); None if it never has."""
        best = math.inf
        for i, r in enumerate(self.history):
            if r["status"] == "ok" and r["score"] < best:
                best = r["score"]
                if all(abs(r[k] / v - 1) <= rel for k, v in true.items()):
                    return i + 1
        return None

    def to_csv(self, path) -> str:
        """Write :attr:`history` as CSV (one row per evaluation); returns the path."""
        path = os.fspath(path)
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        cols = ["evaluation", "batch", *self.params, *self.targets, "score", "status", "error", "wall_s"]
        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(cols)
            for r in self.history:
                w.writerow([repr(r.get(c)) if isinstance(r.get(c), float) else r.get(c, "") for c in cols])
        return path

    def plot(self, path=None):
        """Convergence figure (matplotlib, ``pip install "taichi-fdem[plot]"``): every
        evaluation's objective and the best so far against the evaluation number (log scale);
        saved to ``path`` if given.  Returns the figure."""
        import matplotlib
        if path is not None:
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
        s = np.array([r["score"] for r in self.history], float)
        n = np.arange(1, len(s) + 1)
        fig, ax = plt.subplots(figsize=(6, 4))
        ax.semilogy(n, np.maximum(s, 1e-300), ".", ms=3, alpha=0.5, label="evaluation")
        ax.semilogy(n, np.maximum(np.minimum.accumulate(s), 1e-300), "-", label="best so far")
        ax.set_xlabel("evaluation")
        ax.set_ylabel("objective  Σ w (m − t)² / t²")
        ax.legend()
        fig.tight_layout()
        if path is not None:
            fig.savefig(os.fspath(path), dpi=120)
        return fig

    def __repr__(self) -> str:
        return (f"Calibration(method={self.method!r}, best={self.best}, score={self.best_score:.3g}, "
                f"evaluations={self.evaluations}, converged={self.converged}, wall_s={self.wall_s:.1f})")


def _check(params, targets, weights, budget, workers):
    where = "calibrate"
    if not isinstance(params, dict) or not params:
        raise ValueError(f"{where}: params must be a non-empty dict {{name: (low, high)}}")
    bounds = {}
    for k, b in params.items():
        try:
            lo, hi = (float(b[0]), float(b[1]))
        except (TypeError, ValueError, IndexError):
            raise ValueError(f"{where}: params[{k!r}] must be a (low, high) pair, got {b!r}") from None
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ValueError(f"{where}: params[{k!r}] needs finite low < high, got {b!r}")
        bounds[k] = (lo, hi)
    if not isinstance(targets, dict) or not targets:
        raise ValueError(f"{where}: targets must be a non-empty dict {{name: value or (value, weight)}}")
    weights = dict(weights or {})
    unknown = sorted(set(weights) - set(targets))
    if unknown:
        raise ValueError(f"{where}: weights for names that are no target: {unknown}")
    tg = {}
    for k, t in targets.items():
        if isinstance(t, (tuple, list)):
            if len(t) != 2:
                raise ValueError(f"{where}: targets[{k!r}] must be a value or (value, weight), got {t!r}")
            if k in weights:
                raise ValueError(f"{where}: target {k!r} has a weight in targets and in weights=")
            v, w = float(t[0]), float(t[1])
        else:
            v, w = float(t), float(weights.get(k, 1.0))
        if not math.isfinite(v) or v == 0:
            raise ValueError(f"{where}: targets[{k!r}] must be finite and non-zero (relative errors), got {t!r}")
        if not math.isfinite(w) or w < 0:
            raise ValueError(f"{where}: the weight of target {k!r} must be >= 0, got {w!r}")
        tg[k] = (v, w)
    if isinstance(budget, bool) or not isinstance(budget, (int, np.integer)) or budget < 2:
        raise ValueError(f"{where}: budget (the number of model evaluations) must be an integer >= 2, got {budget!r}")
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"{where}: workers must be an integer >= 1, got {workers!r}")
    return bounds, tg


class _Pool:
    """Local worker processes of the sweep runner (:func:`~taichi_fdem.sweep.worker._worker_main`,
    started once with ``spawn`` and kept for every batch, so that Taichi is initialised once
    per worker); a worker that dies is replaced and its point recorded as "crashed"."""

    def __init__(self, workers: int, init):
        import multiprocessing as mp
        from .runner import worker_init
        self.ctx = mp.get_context("spawn")
        self.init = worker_init(dict(init or {}), workers)
        self.procs = [self._start() for _ in range(workers)]

    def _start(self):
        from .worker import _worker_main
        parent, child = self.ctx.Pipe()
        proc = self.ctx.Process(target=_worker_main, args=(child, self.init), daemon=True,
                                name="taichi-fdem-calibrate-worker")
        proc.start()
        child.close()
        return {"proc": proc, "conn": parent, "task": None}

    def map(self, payloads: list) -> list:
        from multiprocessing.connection import wait
        out = [None] * len(payloads)
        pending = list(range(len(payloads)))[::-1]
        while pending or any(w["task"] is not None for w in self.procs):
            for w in self.procs:
                if w["task"] is None and pending:
                    w["task"] = i = pending.pop()
                    w["conn"].send((i, payloads[i]))
            busy = [w for w in self.procs if w["task"] is not None]
            ready = wait([w["conn"] for w in busy] + [w["proc"].sentinel for w in busy])
            for k, w in enumerate(self.procs):
                if w["task"] is None or (w["conn"] not in ready and w["proc"].sentinel not in ready):
                    continue
                try:
                    i, res = w["conn"].recv()
                except (EOFError, OSError):
                    res = {"status": "crashed", "metrics": {}, "wall_s": 0.0,
                           "error": f"the worker process died (exit code {w['proc'].exitcode})"}
                    i = w["task"]
                    w["conn"].close()
                    self.procs[k] = self._start()
                else:
                    w["task"] = None
                out[i] = res
        return out

    def close(self):
        for w in self.procs:
            try:
                w["conn"].send(None)
            except (OSError, ValueError):
                pass
            w["proc"].join(timeout=5)
            if w["proc"].is_alive():
                w["proc"].kill()
                w["proc"].join()
            w["conn"].close()


class _Evaluator:
    """Runs batches of points (in this process, on local worker processes or on Dask), records
    each evaluation in the Calibration and keeps the budget."""

    def __init__(self, cal, model, names, budget, workers, scheduler, timeout, init, workdir, on_batch):
        self.cal, self.names, self.budget = cal, names, int(budget)
        self.point = FunctionPoint(model)
        self.workers, self.scheduler, self.timeout, self.init = int(workers), scheduler, timeout, init
        self.workdir, self.on_batch = workdir, on_batch
        self.pool = None
        self.t_start = time.perf_counter()
        self.rtol = None

    @property
    def left(self) -> int:
        return self.budget - self.cal.evaluations

    def score(self, measured: dict):
        s = 0.0
        for k, (t, w) in self.cal.targets.items():
            v = measured.get(k)
            if v is None:
                return None, f"the model returned no {k!r} (it returned {sorted(measured)})"
            try:
                v = float(v)
            except (TypeError, ValueError):
                return None, f"the model's {k!r} is not a number: {v!r}"
            if not math.isfinite(v):
                return None, f"the model's {k!r} is {v}"
            s += w * ((v - t) / t) ** 2
        return s, ""

    def run(self, pts: list) -> list:
        names, init = self.names, self.init
        if self.scheduler is None:
            if self.pool is None:
                raw = [run_point(self.point, p, None, None, init) for p in pts]
            else:
                raw = self.pool.map([pickle.dumps((self.point, p, None, None)) for p in pts])
            return [{**p, **r["metrics"], "status": r["status"], "error": r["error"], "wall_s": r["wall_s"]}
                    for p, r in zip(pts, raw)]
        from .runner import Sweep
        uniq = list({tuple(p[k] for k in names): p for p in pts}.values())
        sw = Sweep(self.point, points=uniq, metrics=_no_metrics, init=init)
        path = os.path.join(self.workdir, f"batch{self.cal.batches:04d}.csv")
        rows = sw.run(workers=self.workers, output=path, resume=False, scheduler=self.scheduler,
                      timeout=self.timeout)
        by = {tuple(r[k] for k in names): r for r in rows}
        results = []
        for p in pts:
            r = by.get(tuple(p[k] for k in names))
            results.append(dict(r) if r is not None else {**p, "status": "failed", "error": "no result", "wall_s": 0.0})
        return results

    def batch(self, xs) -> list:
        """Evaluate the parameter vectors ``xs`` (as many as the budget leaves; raises
        _BudgetReached when it leaves none) and return their history records."""
        cal, names = self.cal, self.names
        if self.left <= 0:
            raise _BudgetReached
        xs = [np.asarray(x, float) for x in xs][:self.left]
        pts = [{k: float(x[i]) for i, k in enumerate(names)} for x in xs]
        results = self.run(pts)
        out = []
        for p, r in zip(pts, results):
            measured = {k: r[k] for k in r if k not in ("status", "error", "wall_s", "worker") and k not in names}
            rec = {"evaluation": cal.evaluations + 1, "batch": cal.batches, **p}
            s, err = (None, r.get("error") or r.get("status"))
            if r.get("status") == "ok":
                s, err = self.score(measured)
            rec.update({k: measured.get(k) for k in cal.targets})
            rec.update(score=FAILED_SCORE if s is None else s, status="ok" if s is not None else
                       (r.get("status") if r.get("status") != "ok" else "failed"),
                       error=err or "", wall_s=float(r.get("wall_s") or 0.0))
            cal.history.append(rec)
            if s is not None and s < cal.best_score:
                cal.best_score, cal.best, cal.best_measured = s, dict(p), measured
            out.append(rec)
        cal.batches += 1
        cal.wall_s = time.perf_counter() - self.t_start
        if self.on_batch is not None:
            self.on_batch(cal)
        return out

    def matched(self, rec) -> bool:
        """Every target of the record within ``rtol`` (the stopping test of the local methods)."""
        if rec["status"] != "ok" or self.rtol is None:
            return False
        e = self.cal.relative_errors(rec)
        return all(abs(e[k]) <= self.rtol for k, (_, w) in self.cal.targets.items() if w > 0)


# ----------------------------------------------------------------------------------------------
# the function
# ----------------------------------------------------------------------------------------------
def calibrate(model, params: dict, targets: dict, budget: int = 200, seed: int = 0, workers: int = 1,
              weights: dict | None = None, popsize: int | None = None, tol: float | None = None,
              scheduler=None, timeout: float | None = None, init: dict | None = None,
              workdir=None, on_batch=None, *, method: str = "auto", tolerance: float = 0.02,
              rtol: float | None = None, start: dict | None = None, diff_step: float = 0.02,
              sampler: str = "tpe") -> Calibration:
    """Tune ``params`` until ``model(params)`` matches ``targets``.

    Parameters
    ----------
    model : callable
        ``model(params: dict) -> dict`` of measured values (e.g. the summaries of the
        ``fdem.lab`` tests); a module-level function when ``workers > 1`` (it is pickled).
    params : dict
        {name: (low, high)}: the search box.
    targets : dict
        {measured name: value} or {name: (value, weight)}; ``weights`` = {name: weight}
        is the other way to weigh them (default weight 1).
    budget : int
        The largest number of model evaluations (at least 2).
    seed : int
        The seed of ``"de"`` and ``"bayes"``: the same seed gives the same evaluations and
        result (``"bracket"`` and ``"least_squares"`` are deterministic).
    workers : int
        Evaluations run at once (local worker processes of the sweep runner; 1: in this
        process).
    weights : dict or None
        {name: weight} of the targets (default 1 each).
    popsize : int or None
        ``"de"``: population multiplier (SciPy's ``popsize``; default 15, or what fits the
        budget with at least 5 generations, at least 5); one generation is ``popsize ×
        len(params)`` evaluations and the budget must hold one.
    tol : float or None
        ``"de"``: convergence tolerance (relative spread of the population's objectives;
        default 1e-6).
    scheduler : None, str or dask.distributed.Client
        A Dask scheduler address or Client instead of local processes.
    timeout : float or None
        Wall seconds after which a local evaluation is stopped and recorded as failed.
    init : dict or None
        Keyword arguments of :func:`taichi_fdem.init` in the workers.
    workdir : str or None
        Folder of the sweep CSVs of each batch on Dask (default: a temporary folder).
    on_batch : callable or None
        ``on_batch(calibration)`` called after every batch (progress).
    method : str
        One of :data:`METHODS` (see the module docstring); ``"auto"``: ``"de"`` when
        ``popsize`` or ``tol`` is given, else ``"bracket"`` for one parameter and one target,
        else ``"least_squares"``.
    tolerance : float
        Relative error of every target within which an evaluated point counts for
        :attr:`Calibration.uncertainty` (default 2 %).
    rtol : float or None
        ``"bracket"``, ``"least_squares"``, ``"bayes"``: stop once an evaluation has every
        target within this relative error (default ``tolerance / 10``).
    start : dict or None
        ``"least_squares"``: the first point {name: value} (default: the centre of the box).
    diff_step : float
        ``"least_squares"``: the finite-difference step of the Jacobian, a fraction of each
        parameter's range (default 0.02; above the model's noise).
    sampler : str
        ``"bayes"``: ``"tpe"`` (default) or ``"gp"``.

    Returns
    -------
    Calibration
        ``best``, ``uncertainty``, ``history``, ``evaluations``, ``converged``, ``plot(path)``,
        ``to_csv(path)``.
    """
    bounds, tg, method, rtol = _check_settings(model, params, targets, weights, budget, workers, method, popsize,
                                               tol, start, sampler, diff_step, tolerance, rtol)
    cal = Calibration(dict(bounds), tg, tolerance=tolerance, method=method)
    ev = _Evaluator(cal, model, list(bounds), budget, workers, scheduler, timeout, init, workdir, on_batch)
    _search(ev, bounds, budget, rtol, seed=seed, popsize=popsize, tol=tol, start=start, diff_step=diff_step,
            sampler=sampler)
    if not cal.best:
        raise SweepError(f"calibrate: every one of the {cal.evaluations} evaluations failed; the first error: "
                         f"{cal.history[0]['error'] if cal.history else 'none'}")
    return cal


def _check_settings(model, params, targets, weights, budget, workers, method, popsize, tol, start, sampler,
                    diff_step, tolerance, rtol):
    """The checked arguments of :func:`calibrate`: (bounds {name: (low, high)}, targets {name:
    (value, weight)}, the method (``"auto"`` resolved), rtol (default ``tolerance / 10``)).
    ImportError without SciPy, TypeError for a model that is not callable, ValueError naming
    any other argument that is wrong or that is a setting of another method."""
    try:
        import scipy.optimize  # noqa: F401
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError("calibrate needs SciPy, a dependency of taichi-fdem that is missing from this "
                          "environment: pip install scipy") from exc
    if not callable(model):
        raise TypeError(f"calibrate: model must be a callable model(params) -> dict, got {model!r}")
    bounds, tg = _check(params, targets, weights, budget, workers)
    names = list(bounds)
    d = len(names)
    if method not in METHODS:
        raise ValueError(f"calibrate: method must be one of {', '.join(map(repr, METHODS))}, got {method!r}")
    de_only = [k for k, v in (("popsize", popsize), ("tol", tol)) if v is not None]
    positive = [k for k, (_, w) in tg.items() if w > 0]
    if not positive:
        raise ValueError("calibrate: every target has weight 0; give at least one a positive weight")
    if method == "auto":
        method = "de" if de_only else ("bracket" if d == 1 and len(tg) == 1 else "least_squares")
    elif de_only and method != "de":
        raise ValueError(f"calibrate: {', '.join(de_only)} {'is a setting' if len(de_only) == 1 else 'are settings'} "
                         f"of method='de', not of method={method!r}")
    for key, val, m in (("start", start, "least_squares"), ("sampler", None if sampler == "tpe" else sampler, "bayes"),
                        ("diff_step", None if diff_step == 0.02 else diff_step, "least_squares")):
        if val is not None and method != m:
            raise ValueError(f"calibrate: {key} is a setting of method={m!r}, not of method={method!r}")
    if method == "bracket" and (d != 1 or len(tg) != 1):
        raise ValueError(f"calibrate: method='bracket' solves for one parameter from one target, got "
                         f"{d} parameters {names} and {len(tg)} targets {sorted(tg)}; use 'least_squares'")
    if not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"calibrate: tolerance must be a relative error > 0, got {tolerance!r}")
    if rtol is None:
        rtol = tolerance / 10.0
    elif not (isinstance(rtol, (int, float)) and math.isfinite(rtol) and rtol >= 0):
        raise ValueError(f"calibrate: rtol must be a relative error >= 0, got {rtol!r}")
    if not (isinstance(diff_step, (int, float)) and 0 < diff_step <= 0.5):
        raise ValueError(f"calibrate: diff_step must be a fraction of the range in (0, 0.5], got {diff_step!r}")
    if sampler not in ("tpe", "gp"):
        raise ValueError(f"calibrate: sampler must be 'tpe' or 'gp', got {sampler!r}")
    if start is not None:
        if not isinstance(start, dict) or set(start) != set(names):
            raise ValueError(f"calibrate: start must be a dict with a value for each of {names}, got {start!r}")
        for k in names:
            if not bounds[k][0] <= float(start[k]) <= bounds[k][1]:
                raise ValueError(f"calibrate: start[{k!r}] = {start[k]!r} lies outside its box {bounds[k]}")
    return bounds, tg, method, rtol


def _search(ev, bounds, budget, rtol, *, seed, popsize, tol, start, diff_step, sampler) -> None:
    """Run the calibration's method with the evaluator ``ev`` until it converges, stops or uses
    the ``budget``, recording in ``ev.cal`` its message, whether it converged and its wall time.
    The worker processes (``ev.workers`` > 1 without a scheduler) and the temporary folder of
    the Dask batches (a scheduler without ``ev.workdir``) live as long as the search."""
    cal, method = ev.cal, ev.cal.method
    tmp = None
    if ev.workdir is None and ev.scheduler is not None:
        tmp = tempfile.TemporaryDirectory(prefix="fdem-calibrate-")
        ev.workdir = tmp.name
    if method != "de":
        ev.rtol = float(rtol)
    xrtol = 1e-4
    try:
        if ev.workers > 1 and ev.scheduler is None:
            ev.pool = _Pool(ev.workers, ev.init)
        if method == "de":
            cal.message = _run_de(ev, bounds, budget, seed, popsize, tol)
        elif method == "bracket":
            cal.message = _run_bracket(ev, bounds, xrtol)
            cal.converged = cal.message.startswith("the bracket")
        elif method == "least_squares":
            cal.message = _run_least_squares(ev, bounds, start, diff_step, xrtol)
            cal.converged = True
        else:
            cal.message = _run_bayes(ev, bounds, seed, sampler, budget)
    except _BudgetReached:
        cal.message = f"stopped: the budget of {budget} evaluations is used"
    except _Stopped as exc:
        cal.message = str(exc)
    except _Converged:
        cal.converged = True
        cal.message = f"every target is within rtol = {rtol:g}"
    finally:
        if ev.pool is not None:
            ev.pool.close()
        if tmp is not None:
            tmp.cleanup()
    cal.wall_s = time.perf_counter() - ev.t_start


def _no_metrics(sim):  # pragma: no cover - FunctionPoint never builds a simulation
    return {}

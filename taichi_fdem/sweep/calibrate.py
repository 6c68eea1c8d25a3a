"""Calibration: micro-parameters of a model tuned until its measured values match lab targets.

::

    def model(p):                                   # module-level: sent to worker processes
        r = fdem.lab.ucs(fdem.Material(young=p["young"], ...), 0.05, 0.1, 0.005)
        return {"E": r.young, "ucs": r.peak_stress}

    cal = fdem.calibrate(model, params={"young": (10e9, 80e9), "tensile_strength": (2e6, 20e6)},
                         targets={"E": 69e9, "ucs": (200e6, 2.0)}, budget=200, seed=1, workers=2)
    cal.best, cal.history, cal.plot("convergence.png"), cal.to_csv("history.csv")

The optimiser is SciPy's differential evolution (Storn & Price 1997;
:func:`scipy.optimize.differential_evolution`; SciPy is a dependency of the package),
with a Latin-hypercube initial population and deferred updating, so that each generation is one batch
of evaluations: the batch runs on the sweep runner's local worker processes (kept for the whole
calibration, so that each initialises Taichi once), or as a :class:`~taichi_fdem.sweep.Sweep` on
a Dask scheduler; ``workers=1`` runs it in this process through
:func:`~taichi_fdem.sweep.run_point`, the sweep's worker function.  The same seed gives the same
sequence of evaluations, whatever the number of workers.

Objective: ``sum_k w_k ((m_k - t_k) / t_k)**2`` over the targets k (measured m_k, target t_k,
weight w_k; relative errors, so targets of different units weigh alike).  An evaluation that
fails (raises, is unstable, lacks a target's value or returns a non-finite one) is recorded in
the history with its error and scored :data:`FAILED_SCORE`.
"""
from __future__ import annotations

import csv
import math
import os
import pickle
import tempfile

import numpy as np

from .params import SweepError
from .worker import FunctionPoint, run_point

__all__ = ["calibrate", "Calibration", "FAILED_SCORE"]

#: objective value of a failed evaluation (finite, so the optimiser's statistics stay defined)
FAILED_SCORE = 1.0e6


class _BudgetReached(Exception):
    pass


class Calibration:
    """The result of :func:`calibrate`.

    * ``best`` -- dict {parameter: value} of the lowest objective seen;
    * ``best_score`` -- that objective; ``best_measured`` -- the model's values there;
    * ``history`` -- list of dicts, one per evaluation in order: ``evaluation``, ``batch``,
      the parameters, the measured values, ``score``, ``status`` ("ok" or the failure),
      ``error``, ``wall_s``;
    * ``evaluations``, ``batches``, ``wall_s`` (total wall time [s]), ``message`` (the
      optimiser's), ``params``, ``targets`` (name -> (value, weight)).
    """

    def __init__(self, params, targets):
        self.params, self.targets = params, targets
        self.history: list = []
        self.best: dict = {}
        self.best_score = math.inf
        self.best_measured: dict = {}
        self.batches = 0
        self.wall_s = 0.0
        self.message = ""

    @property
    def evaluations(self) -> int:
        """Number of model evaluations (failures included)."""
        return len(self.history)

    def relative_errors(self) -> dict:
        """(m - t) / t of every target at ``best``."""
        return {k: (self.best_measured.get(k, math.nan) - t) / t for k, (t, _) in self.targets.items()}

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
        return (f"Calibration(best={self.best}, score={self.best_score:.3g}, evaluations={self.evaluations}, "
                f"wall_s={self.wall_s:.1f})")


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


def calibrate(model, params: dict, targets: dict, budget: int = 200, seed: int = 0, workers: int = 1,
              weights: dict | None = None, popsize: int | None = None, tol: float = 1e-6,
              scheduler=None, timeout: float | None = None, init: dict | None = None,
              workdir=None, on_batch=None) -> Calibration:
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
        The largest number of model evaluations.  Differential evolution runs generations
        of ``popsize × len(params)`` evaluations (the Latin-hypercube initial population is
        the first) until its convergence test (``tol``, relative spread of the population's
        objectives) or the budget stops it; the budget must hold the initial population.
    seed : int
        The optimiser's seed: the same seed gives the same evaluations and result.
    workers : int
        Evaluations run at once (local worker processes of the sweep runner; 1: in this
        process).
    weights : dict or None
        {name: weight} of the targets (default 1 each).
    popsize : int or None
        Population multiplier (SciPy's ``popsize``; default 15, or what fits the budget
        with at least 5 generations, at least 5).
    tol : float
        Convergence tolerance of differential evolution (relative spread of the objectives).
    scheduler : None, str or dask.distributed.Client
        A Dask scheduler address or Client instead of local processes.
    timeout : float or None
        Wall seconds after which a local evaluation is stopped and recorded as failed.
    init : dict or None
        Keyword arguments of :func:`taichi_fdem.init` in the workers.
    workdir : str or None
        Folder of the sweep CSVs of each batch (default: a temporary folder).
    on_batch : callable or None
        ``on_batch(calibration)`` called after every batch (progress).

    Returns
    -------
    Calibration
        ``best``, ``history``, ``plot(path)``, ``to_csv(path)``.
    """
    try:
        from scipy.optimize import differential_evolution
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError("calibrate needs SciPy, a dependency of taichi-fdem that is missing from this "
                          "environment: pip install scipy") from exc
    if not callable(model):
        raise TypeError(f"calibrate: model must be a callable model(params) -> dict, got {model!r}")
    bounds, tg = _check(params, targets, weights, budget, workers)
    names = list(bounds)
    d = len(names)
    if popsize is None:
        popsize = max(5, min(15, int(budget // (5 * d))))
    if popsize * d > budget:
        raise ValueError(f"calibrate: budget {budget} is smaller than one generation (popsize {popsize} × "
                         f"{d} parameters = {popsize * d} evaluations)")
    cal = Calibration(dict(bounds), tg)
    point = FunctionPoint(model)
    tmp = None
    if workdir is None:
        tmp = tempfile.TemporaryDirectory(prefix="fdem-calibrate-")
        workdir = tmp.name
    import time
    t_start = time.perf_counter()

    def score(measured: dict):
        s = 0.0
        for k, (t, w) in tg.items():
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

    def evaluate(xs):
        """Objectives of a batch of parameter vectors (one sweep)."""
        left = budget - cal.evaluations
        if left <= 0:
            raise _BudgetReached
        xs = [np.asarray(x, float) for x in xs]
        asked = len(xs)
        xs = xs[:left]
        pts = [{k: float(x[i]) for i, k in enumerate(names)} for x in xs]
        if scheduler is None:
            if pool is None:
                raw = [run_point(point, p, None, None, init) for p in pts]
            else:
                raw = pool.map([pickle.dumps((point, p, None, None)) for p in pts])
            results = [{**p, **r["metrics"], "status": r["status"], "error": r["error"], "wall_s": r["wall_s"]}
                       for p, r in zip(pts, raw)]
        else:
            from .runner import Sweep
            uniq = list({tuple(p[k] for k in names): p for p in pts}.values())
            sw = Sweep(point, points=uniq, metrics=_no_metrics, init=init)
            path = os.path.join(workdir, f"batch{cal.batches:04d}.csv")
            rows = sw.run(workers=int(workers), output=path, resume=False, scheduler=scheduler, timeout=timeout)
            by = {tuple(r[k] for k in names): r for r in rows}
            results = []
            for p in pts:
                r = by.get(tuple(p[k] for k in names))
                results.append(dict(r) if r is not None else {**p, "status": "failed", "error": "no result", "wall_s": 0.0})
        out = []
        for p, r in zip(pts, results):
            measured = {k: r[k] for k in r if k not in ("status", "error", "wall_s", "worker") and k not in names}
            rec = {"evaluation": cal.evaluations + 1, "batch": cal.batches, **p}
            s, err = (None, r.get("error") or r.get("status"))
            if r.get("status") == "ok":
                s, err = score(measured)
            rec.update({k: measured.get(k) for k in tg})
            rec.update(score=FAILED_SCORE if s is None else s, status="ok" if s is not None else
                       (r.get("status") if r.get("status") != "ok" else "failed"),
                       error=err or "", wall_s=float(r.get("wall_s") or 0.0))
            cal.history.append(rec)
            if s is not None and s < cal.best_score:
                cal.best_score, cal.best, cal.best_measured = s, dict(p), measured
            out.append(rec["score"])
        cal.batches += 1
        cal.wall_s = time.perf_counter() - t_start
        if on_batch is not None:
            on_batch(cal)
        # the budget cut the batch short: the optimiser still needs one score per member
        out += [FAILED_SCORE] * (asked - len(out))
        return out

    def mapper(func, iterable):
        return evaluate(list(iterable))

    def single(x):
        return evaluate([x])[0]

    gens = max(1, budget // (popsize * d))
    pool = None
    try:
        if workers > 1 and scheduler is None:
            pool = _Pool(int(workers), init)
        res = differential_evolution(single, [bounds[k] for k in names], seed=seed, popsize=popsize,
                                     maxiter=max(1, gens - 1), tol=tol, init="latinhypercube", polish=False,
                                     updating="deferred", workers=mapper,
                                     callback=lambda *a, **k: cal.evaluations >= budget)
        cal.message = str(res.message)
    except _BudgetReached:
        cal.message = f"stopped: the budget of {budget} evaluations is used"
    finally:
        if pool is not None:
            pool.close()
        if tmp is not None:
            tmp.cleanup()
    cal.wall_s = time.perf_counter() - t_start
    if not cal.best:
        raise SweepError(f"calibrate: every one of the {cal.evaluations} evaluations failed; the first error: "
                         f"{cal.history[0]['error'] if cal.history else 'none'}")
    return cal


def _no_metrics(sim):  # pragma: no cover - FunctionPoint never builds a simulation
    return {}

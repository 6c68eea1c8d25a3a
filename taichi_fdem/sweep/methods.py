"""The search methods of :func:`taichi_fdem.sweep.calibrate.calibrate` (its module docstring
describes them): each drives an evaluator ``ev`` (``ev.names``, batches of evaluations, the
budget and the convergence test) over the box ``bounds`` until it raises :class:`_BudgetReached`,
:class:`_Converged` or :class:`_Stopped`, or its own step tolerance is met.
"""
from __future__ import annotations

import math

import numpy as np

#: objective value of a failed evaluation (finite, so the optimiser's statistics stay defined)
FAILED_SCORE = 1.0e6

#: relative error standing in for each target of a failed evaluation in ``"least_squares"``
_FAILED_RESIDUAL = 10.0


class _BudgetReached(Exception):
    pass


class _Converged(Exception):
    pass


class _Stopped(Exception):
    """A method cannot go on (its message says why); the calibration returns what it has."""


def _run_de(ev, bounds, budget, seed, popsize, tol):
    from scipy.optimize import differential_evolution
    names = ev.names
    d = len(names)
    if popsize is None:
        popsize = max(5, min(15, int(budget // (5 * d))))
    if popsize * d > budget:
        raise ValueError(f"calibrate: budget {budget} is smaller than one generation (popsize {popsize} × "
                         f"{d} parameters = {popsize * d} evaluations)")

    def mapper(func, iterable):
        xs = list(iterable)
        out = [r["score"] for r in ev.batch(xs)]
        # the budget cut the batch short: the optimiser still needs one score per member
        return out + [FAILED_SCORE] * (len(xs) - len(out))

    def single(x):
        return ev.batch([x])[0]["score"]

    gens = max(1, budget // (popsize * d))
    res = differential_evolution(single, [bounds[k] for k in names], seed=seed, popsize=popsize,
                                 maxiter=max(1, gens - 1), tol=1e-6 if tol is None else tol,
                                 init="latinhypercube", polish=False, updating="deferred", workers=mapper,
                                 callback=lambda *a, **k: ev.left <= 0)
    ev.cal.converged = bool(res.success) and ev.left > 0
    return str(res.message)


def _log_residual(m: float, t: float) -> float:
    """log(m / t) for m, t > 0 (a power law of the parameter is linear in log-log); a finite value
    of the right sign otherwise."""
    if t > 0 and m > 0:
        return math.log(m / t)
    return (m - t) / abs(t) - (50.0 if m <= 0 < t else 0.0) + (50.0 if m >= 0 > t else 0.0)


def _run_bracket(ev, bounds, xrtol):
    from scipy.optimize import brentq
    (name,) = ev.names
    (target,) = list(ev.cal.targets)
    t = ev.cal.targets[target][0]
    lo, hi = bounds[name]
    logs = lo > 0
    seen = {}

    def residual(rec):
        if rec["status"] != "ok":
            raise _Stopped(f"stopped: the evaluation at {name} = {rec[name]!r} failed ({rec['error']}); "
                           f"a bracketing method needs every evaluation")
        m = float(rec[target])
        return _log_residual(m, t) if logs else (m - t) / t

    ends = ev.batch([[lo], [hi]])
    for r in ends:
        seen[r[name]] = r
        if ev.matched(r):
            raise _Converged
    if len(ends) < 2:
        raise _BudgetReached
    fa, fb = residual(ends[0]), residual(ends[1])
    if fa * fb > 0:
        ea, eb = ((float(r[target]) - t) / t for r in ends)
        return (f"the target {target!r} is not bracketed: its relative error is {ea:+.3g} at {name} = {lo:g} "
                f"and {eb:+.3g} at {name} = {hi:g}; widen the box")

    def f(s):
        x = min(hi, max(lo, math.exp(s) if logs else s))
        r = seen.get(x)
        if r is None:
            (r,) = ev.batch([[x]])
            seen[x] = r
            if ev.matched(r):
                raise _Converged
        return residual(r)

    a, b = (math.log(lo), math.log(hi)) if logs else (lo, hi)
    seen[math.exp(a) if logs else a] = ends[0]
    seen[math.exp(b) if logs else b] = ends[1]
    brentq(f, a, b, xtol=xrtol * (b - a), rtol=4 * np.finfo(float).eps, maxiter=10 ** 6)
    return f"the bracket of {name} is narrower than {xrtol:g} of the box"


def _run_least_squares(ev, bounds, start, diff_step, xrtol):
    from scipy.optimize import least_squares
    names = ev.names
    lo = np.array([bounds[k][0] for k in names])
    hi = np.array([bounds[k][1] for k in names])
    logs = lo > 0                                    # positive ranges are searched in logarithms
    a = np.where(logs, np.log(np.where(logs, lo, 1.0)), lo)
    b = np.where(logs, np.log(np.where(logs, hi, 1.0)), hi)
    tg = [(k, t, math.sqrt(w)) for k, (t, w) in ev.cal.targets.items() if w > 0]
    cache = {}

    def to_x(u):
        v = a + (b - a) * np.asarray(u, float)
        return np.clip(np.where(logs, np.exp(v), v), lo, hi)

    def residuals(rec):
        if rec["status"] != "ok":
            return np.full(len(tg), _FAILED_RESIDUAL)
        return np.array([s * _log_residual(float(rec[k]), t) for k, t, s in tg])

    def evaluate(us):
        todo = [u for u in us if tuple(u) not in cache]
        if todo:
            recs = ev.batch([to_x(u) for u in todo])
            for u, r in zip(todo, recs):
                cache[tuple(u)] = residuals(r)
            for r in recs:
                if ev.matched(r):
                    raise _Converged
            if len(recs) < len(todo):
                raise _BudgetReached
        return [cache[tuple(u)] for u in us]

    def fun(u):
        return evaluate([np.asarray(u, float)])[0]

    def jac(u, f0=None):
        u = np.asarray(u, float)
        if f0 is None:
            f0 = fun(u)
        steps = []
        for i in range(len(u)):
            h = diff_step if u[i] + diff_step <= 1.0 else -diff_step
            v = u.copy()
            v[i] += h
            steps.append((v, h))
        fs = evaluate([v for v, _ in steps])
        return np.column_stack([(fi - f0) / h for fi, (_, h) in zip(fs, steps)])

    if start is None:
        u0 = np.full(len(names), 0.5)
    else:
        x0 = np.array([float(start[k]) for k in names])
        u0 = np.clip((np.where(logs, np.log(np.where(logs, x0, 1.0)), x0) - a) / (b - a), 0.0, 1.0)
    res = least_squares(fun, u0, jac=jac, bounds=(0.0, 1.0), method="trf", x_scale=1.0,
                        xtol=xrtol, ftol=1e-10, gtol=1e-10, max_nfev=10 ** 6)
    return str(res.message)


def _run_bayes(ev, bounds, seed, sampler, budget):
    try:
        import optuna
    except ImportError as exc:
        raise ImportError('calibrate(method="bayes") needs Optuna, an optional dependency: '
                          'pip install "taichi-fdem[calibrate]" (or pip install optuna)') from exc
    names = ev.names
    d = len(names)
    startup = min(max(2, 2 * d + 1), max(1, budget // 3))
    if sampler == "tpe":
        smp = optuna.samplers.TPESampler(seed=seed, n_startup_trials=startup, multivariate=True,
                                         constant_liar=ev.workers > 1)
    else:
        try:
            import torch  # noqa: F401
        except ImportError as exc:
            raise ImportError('calibrate(method="bayes", sampler="gp") needs PyTorch (Optuna\'s GP sampler): '
                              'pip install torch, or use sampler="tpe"') from exc
        smp = optuna.samplers.GPSampler(seed=seed, n_startup_trials=startup)
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(direction="minimize", sampler=smp)
    while ev.left > 0:
        trials = [study.ask() for _ in range(min(ev.workers, ev.left))]
        xs = [[t.suggest_float(k, *bounds[k]) for k in names] for t in trials]
        recs = ev.batch(xs)
        for t, r in zip(trials, recs):
            if r["status"] == "ok":
                study.tell(t, math.log10(r["score"] + 1e-30))
            else:
                study.tell(t, state=optuna.trial.TrialState.FAIL)
        if any(ev.matched(r) for r in recs):
            raise _Converged
    raise _BudgetReached

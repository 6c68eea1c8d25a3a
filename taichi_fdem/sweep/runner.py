""":class:`Sweep`: the points of a sweep (a grid of axes or a list), checked, and their run on
local worker processes (``spawn``, replaced when they die or time out) or on a Dask cluster.
"""
from __future__ import annotations

import itertools
import math
import os
import pickle
import socket
import time
from collections import deque
from typing import Callable

from .metrics import registry_metrics
from .params import SOLVER_BUILD_KEYS, SweepError, _cell, _check_value, _parse_cell
from .table import _Table
from .worker import _worker_main, run_point

__all__ = ["Sweep"]


# ----------------------------------------------------------------------------------------------
# the sweep
# ----------------------------------------------------------------------------------------------
def worker_init(init: dict, workers: int) -> dict:
    """The :func:`taichi_fdem.init` arguments of each of ``workers`` local worker processes:
    ``init``, with ``cpu_max_num_threads`` = usable cores // workers (at least 1) unless given."""
    init = dict(init)
    if "cpu_max_num_threads" not in init and init.get("arch", "cpu") == "cpu":
        from .. import backend
        init["cpu_max_num_threads"] = max(1, backend.usable_cores() // max(1, workers))
    return init


class Sweep:
    """A parameter sweep: a base scene, points (a grid of ``axes`` or a list of ``points``),
    a metrics function and a simulated duration per point.

    Parameters
    ----------
    base : ``base(params) -> Scene | Simulation | (Simulation, duration)`` (see the module
        docstring for the contract), or the path of a scene file whose dotted keys the points set.
    axes : {key: [values]}: the grid of every combination (in the order given).
    points : [{key: value}, ...]: an explicit list (every point with the same keys).
    metrics : ``metrics(sim) -> dict`` or a list of names of :data:`METRICS`.
    duration : simulated time of each point [s] (see the module docstring for precedence).
    init : keyword arguments of :func:`taichi_fdem.init` in the workers (default CPU, f64).
    """

    def __init__(self, base, axes: dict | None = None, points: list | None = None, metrics=None,
                 duration: float | None = None, init: dict | None = None):
        self._spec = None
        if isinstance(base, (str, os.PathLike)):
            base = os.path.abspath(os.fspath(base))
            from ..io import scenefile
            try:
                self._spec = scenefile.load(base)
            except scenefile.SceneFileError as exc:
                raise SweepError(f"Sweep: base scene: {exc}") from None
        elif not callable(base):
            raise SweepError(f"Sweep: base must be a callable base(params) or a scene file path, got {base!r}")
        self.base = base
        if (axes is None) == (points is None):
            raise SweepError("Sweep: give exactly one of axes={key: [values]} (a grid) or points=[{key: value}, ...]")
        if axes is not None:
            if not isinstance(axes, dict) or not axes:
                raise SweepError(f"Sweep: axes must be a non-empty dict {{key: [values]}}, got {axes!r}")
            for k, vals in axes.items():
                if not isinstance(k, str) or not k:
                    raise SweepError(f"Sweep: axis names must be non-empty strings, got {k!r}")
                if isinstance(vals, (str, bytes)) or not hasattr(vals, "__len__") or len(vals) == 0:
                    raise SweepError(f"Sweep: axis {k!r} must be a non-empty list of values, got {vals!r}")
                for v in vals:
                    _check_value(f"Sweep: axis {k!r}", v)
                cells = [_cell(v) for v in vals]
                if len(set(cells)) != len(cells):
                    raise SweepError(f"Sweep: axis {k!r} repeats a value: {list(vals)!r}")
            keys = list(axes)
            self.points = [dict(zip(keys, combo)) for combo in itertools.product(*(list(axes[k]) for k in keys))]
        else:
            if not isinstance(points, (list, tuple)) or not points or not all(isinstance(p, dict) for p in points):
                raise SweepError(f"Sweep: points must be a non-empty list of dicts, got {points!r}")
            keys = list(points[0])
            if not keys:
                raise SweepError("Sweep: points[0] has no parameters")
            for i, p in enumerate(points):
                if set(p) != set(keys):
                    raise SweepError(f"Sweep: points[{i}] has keys {sorted(p)} but points[0] has {sorted(keys)}; "
                                     f"every point must set the same parameters")
                for k, v in p.items():
                    _check_value(f"Sweep: points[{i}][{k!r}]", v)
            self.points = [dict(p) for p in points]
            seen = {}
            for i, p in enumerate(self.points):
                key = tuple(_cell(p[k]) for k in keys)
                if key in seen:
                    raise SweepError(f"Sweep: points[{i}] repeats points[{seen[key]}]: {p!r}")
                seen[key] = i
        self.param_cols = keys
        if self._spec is not None:
            from ..io import scenefile
            for i, p in enumerate(self.points):
                try:
                    scenefile.load(base, overrides=p)
                except scenefile.SceneFileError as exc:
                    raise SweepError(f"Sweep: point {i} {p!r}: {exc}") from None
        else:
            bad = [k for k in keys if k.startswith("solver.") and k.split(".", 1)[1] not in SOLVER_BUILD_KEYS + ("duration",)]
            if bad:
                raise SweepError(f"Sweep: unknown solver parameter {bad[0]!r}; solver.* keys are "
                                 f"{', '.join('solver.' + k for k in SOLVER_BUILD_KEYS + ('duration',))}")
        if metrics is None:
            metrics = ["time", "steps", "energies"]
        if isinstance(metrics, (list, tuple)):
            metrics = registry_metrics(metrics, self._spec.body_names if self._spec is not None else None)
        elif not callable(metrics):
            raise SweepError(f"Sweep: metrics must be a callable metrics(sim) -> dict or a list of names, got {metrics!r}")
        self.metrics = metrics
        if duration is not None:
            try:
                duration = float(duration)
            except (TypeError, ValueError):
                raise SweepError(f"Sweep: duration must be a time in s, got {duration!r}") from None
            if not (math.isfinite(duration) and duration >= 0):
                raise SweepError(f"Sweep: duration must be a finite time >= 0 s, got {duration!r}")
        self.duration = duration
        self.init = dict(init or {})

    def __len__(self) -> int:
        return len(self.points)

    def key(self, params: dict) -> tuple:
        """The identity of a point in the CSV: its parameter values as written there."""
        return tuple(_cell(params.get(c)) for c in self.param_cols)

    # ------------------------------------------------------------------------------------------
    def run(self, workers: int = 2, output: str = "sweep.csv", resume: bool = True, scheduler=None,
            timeout: float | None = None, on_result: Callable | None = None) -> list[dict]:
        """Run every point not already done; returns one dict per point, in point order.

        Parameters
        ----------
        workers : int
            Local worker processes (ignored with ``scheduler``).  Unless ``init`` sets
            ``cpu_max_num_threads``, each local worker gets the usable cores divided by the
            workers (at least 1), so that workers whose scenes run the parallel strategy do not
            oversubscribe the CPU.
        output : str
            The CSV path (its folder is created).
        resume : bool
            Keep the ``ok`` rows of an existing ``output`` and skip their points;
            False overwrites it.
        scheduler : None, str or dask.distributed.Client
            None (local processes), a Dask scheduler address ``"tcp://host:port"`` or a
            ``dask.distributed.Client``.
        timeout : float or None
            Wall seconds after which a local point is stopped and recorded as "timeout".
        on_result : callable or None
            ``on_result(row, done, total)`` called as each point completes (row: the CSV
            texts of that row).

        Returns
        -------
        list of dict
            Each dict holds the point's parameters, its metrics, ``status``, ``error``,
            ``wall_s`` and ``worker``; values of resumed rows are parsed back from the CSV.
        """
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise SweepError(f"Sweep.run: workers must be an integer >= 1, got {workers!r}")
        if timeout is not None and not (isinstance(timeout, (int, float)) and timeout > 0):
            raise SweepError(f"Sweep.run: timeout must be a positive number of seconds, got {timeout!r}")
        table = _Table(output, self.param_cols, resume)
        done = table.done_keys()
        todo = [i for i, p in enumerate(self.points) if self.key(p) not in done]
        self.skipped = len(self.points) - len(todo)
        count = [len(self.points) - len(todo)]

        def record(i, res):
            row = table.append(self.points[i], res)
            count[0] += 1
            if on_result is not None:
                on_result(row, count[0], len(self.points))

        try:
            if todo:
                if scheduler is not None:
                    self._run_dask(todo, scheduler, record)
                else:
                    self._run_local(todo, workers, timeout, record)
        finally:
            table.close()
        by_key = {tuple(r[c] for c in self.param_cols): r for r in table.rows}
        out = []
        for p in self.points:
            r = by_key.get(self.key(p))
            if r is None:
                continue                                   # interrupted before this point
            row = dict(p)
            row.update({c: _parse_cell(r[c]) for c in table.metric_cols if c in r})
            row.update(status=r["status"], error=r["error"], wall_s=float(r["wall_s"] or 0.0), worker=r["worker"])
            out.append(row)
        return out

    # ------------------------------------------------------------------------------------------
    def _payload(self, i: int) -> bytes:
        try:
            return pickle.dumps((self.base, self.points[i], self.metrics, self.duration))
        except Exception as exc:  # noqa: BLE001
            raise SweepError(f"Sweep: base, metrics and the points must be picklable to reach the worker processes "
                             f"(module-level functions, not lambdas or local functions): {exc}") from None

    def _run_local(self, todo: list, workers: int, timeout, record) -> None:
        import multiprocessing as mp
        from multiprocessing.connection import wait
        payloads = {i: self._payload(i) for i in todo}
        init = worker_init(self.init, min(workers, len(todo)))
        ctx = mp.get_context("spawn")
        pending = deque(todo)
        pool: list[dict] = []

        def start():
            parent, child = ctx.Pipe()
            proc = ctx.Process(target=_worker_main, args=(child, init), daemon=True,
                               name="taichi-fdem-sweep-worker")
            proc.start()
            child.close()
            return {"proc": proc, "conn": parent, "task": None, "t0": 0.0}

        def stop(w, hard=False):
            try:
                if not hard:
                    w["conn"].send(None)
            except (OSError, ValueError):
                pass
            if hard:
                w["proc"].terminate()
            w["proc"].join(timeout=5 if not hard else 2)
            if w["proc"].is_alive():
                w["proc"].kill()
                w["proc"].join()
            w["conn"].close()

        try:
            for _ in range(min(workers, len(todo))):
                pool.append(start())
            while pending or any(w["task"] is not None for w in pool):
                for w in pool:
                    if w["task"] is None and pending:
                        i = pending.popleft()
                        w["task"], w["t0"] = i, time.perf_counter()
                        w["conn"].send((i, payloads[i]))
                busy = [w for w in pool if w["task"] is not None]
                wait_for = None
                if timeout is not None:
                    wait_for = max(0.0, min(w["t0"] + timeout for w in busy) - time.perf_counter())
                ready = wait([w["conn"] for w in busy] + [w["proc"].sentinel for w in busy], timeout=wait_for)
                for w in busy:
                    i = w["task"]
                    worker = f"{socket.gethostname()}:{w['proc'].pid}"
                    if w["conn"] in ready or w["proc"].sentinel in ready:
                        try:
                            got, res = w["conn"].recv()
                        except (EOFError, OSError):
                            w["proc"].join(timeout=5)
                            res = {"status": "crashed", "metrics": {}, "wall_s": time.perf_counter() - w["t0"],
                                   "worker": worker, "error": f"the worker process died (exit code "
                                   f"{w['proc'].exitcode}) while running this point"}
                        else:
                            w["task"] = None
                            record(got, res)
                            continue
                    elif timeout is not None and time.perf_counter() - w["t0"] > timeout:
                        res = {"status": "timeout", "metrics": {}, "wall_s": time.perf_counter() - w["t0"],
                               "worker": worker, "error": f"stopped after the timeout of {timeout:g} s"}
                    else:
                        continue
                    # the worker is dead or stuck: end it, record the point, start a fresh worker
                    stop(w, hard=True)
                    pool.remove(w)
                    record(i, res)
                    if pending:
                        pool.append(start())
        finally:
            for w in pool:
                stop(w, hard=w["task"] is not None)

    def _run_dask(self, todo: list, scheduler, record) -> None:
        try:
            from dask.distributed import Client, as_completed
        except ImportError:
            raise SweepError("Sweep.run(scheduler=...) needs Dask: pip install 'taichi-fdem[distributed]' "
                             "(dask[distributed])") from None
        own = not isinstance(scheduler, Client)
        if own:
            if not isinstance(scheduler, str) or not scheduler:
                raise SweepError(f"Sweep.run: scheduler must be an address 'tcp://host:port' or a dask Client, "
                                 f"got {scheduler!r}")
            try:
                client = Client(scheduler, timeout="20s")
            except (OSError, TimeoutError, ValueError) as exc:
                raise SweepError(f"Sweep.run: cannot connect to the Dask scheduler {scheduler!r}: {exc}") from None
        else:
            client = scheduler
        try:
            futures = {}
            for i in todo:
                fut = client.submit(run_point, self.base, self.points[i], self.metrics, self.duration, self.init,
                                    pure=False, key=f"taichi-fdem-point-{i}-{os.getpid()}-{time.time_ns()}")
                futures[fut] = i
            for fut in as_completed(list(futures)):
                i = futures[fut]
                try:
                    res = fut.result()
                except Exception as exc:  # noqa: BLE001 -- a lost worker, an unpicklable result ...
                    res = {"status": "crashed", "metrics": {}, "wall_s": 0.0, "worker": "",
                           "error": f"{type(exc).__name__}: {exc}"}
                record(i, res)
        finally:
            if own:
                client.close()

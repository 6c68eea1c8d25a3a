"""One sweep point, as it runs in a worker process: :func:`run_point` (build, run, measure; a
failure of the point is recorded, never raised) and :func:`_worker_main`, the loop of a local
worker process started by :meth:`Sweep.run <taichi_fdem.sweep.Sweep.run>`.  Dask workers call
:func:`run_point` directly.
"""
from __future__ import annotations

import os
import pickle
import socket
import threading
import time

from .params import _plain, group_params

__all__ = ["run_point", "FunctionPoint"]


class FunctionPoint:
    """A sweep base that is a plain function ``fn(params) -> dict`` of measured values (it runs
    its own simulations, e.g. the standard lab tests): the point's metrics are that dict, with
    no simulation built by the sweep.  ``fn`` must be picklable (a module-level function) for
    local worker processes."""

    def __init__(self, fn):
        if not callable(fn):
            raise TypeError(f"FunctionPoint: fn must be callable, got {fn!r}")
        self.fn = fn

    def __call__(self, params: dict) -> dict:
        return self.fn(dict(params))


# ----------------------------------------------------------------------------------------------
# one point (runs in a worker process)
# ----------------------------------------------------------------------------------------------
_LOCK = threading.Lock()      # one Taichi run at a time per process (Dask workers may have threads)


def _ensure_init(init: dict | None) -> None:
    from .. import backend
    if not backend.is_initialised():
        backend.init(**(init or {}))


def _build_point(base, params: dict, duration):
    from ..scene import Scene
    from ..sim.simulation import Simulation
    params = dict(params)
    dur = params.get("solver.duration")
    if isinstance(base, (str, os.PathLike)):
        from ..io import scenefile
        sim, settings = scenefile.load(base, overrides=params).build()
        # precedence: the point's solver.duration, then the sweep's duration, then the file's
        return sim, duration if duration is not None and "solver.duration" not in params else settings.duration
    out = base(params)
    returned = None
    if isinstance(out, tuple):
        if len(out) != 2 or not isinstance(out[0], Simulation):
            raise TypeError(f"base(params) returned a tuple that is not (Simulation, duration): {out!r}")
        out, returned = out
    if isinstance(out, Scene):
        solver = {k: v for k, v in group_params(params)["solver"].items() if k != "duration"}
        out = out.build(**solver)
    if not isinstance(out, Simulation):
        raise TypeError(f"base(params) must return a Scene, a Simulation or (Simulation, duration); "
                        f"got {type(out).__name__}")
    for d in (dur, returned, duration):
        if d is not None:
            return out, d
    raise ValueError("no duration: give Sweep(duration=...), a 'solver.duration' parameter, "
                     "or return (Simulation, duration) from base")


def run_point(base, params: dict, metrics, duration=None, init: dict | None = None) -> dict:
    """Build, run and measure one point; never raises for a failure of the point itself.

    Returns {"status", "error", "metrics", "wall_s", "worker"}: status "ok", "unstable"
    (SimulationError) or "failed" (any other exception, in ``base``, the run or ``metrics``).
    This is the function that the local workers and the Dask workers call.
    """
    from ..sim.simulation import SimulationError
    t0 = time.perf_counter()
    res = {"status": "ok", "error": "", "metrics": {}, "worker": f"{socket.gethostname()}:{os.getpid()}"}
    with _LOCK:
        try:
            _ensure_init(init)
            if isinstance(base, FunctionPoint):
                m = base(params)
                if not isinstance(m, dict):
                    raise TypeError(f"model(params) must return a dict, got {type(m).__name__}")
            else:
                sim, dur = _build_point(base, params, duration)
                sim.run(float(dur), progress=False)
                m = metrics(sim) if metrics is not None else {}
                if not isinstance(m, dict):
                    raise TypeError(f"metrics(sim) must return a dict, got {type(m).__name__}")
            res["metrics"] = {str(k): _plain(v) for k, v in m.items()}
        except SimulationError as exc:
            res.update(status="unstable", error=f"SimulationError: {exc}")
        except Exception as exc:  # noqa: BLE001 -- a point's failure is data, not a crash of the sweep
            res.update(status="failed", error=f"{type(exc).__name__}: {exc}")
    res["wall_s"] = time.perf_counter() - t0
    return res


def _worker_main(conn, init) -> None:
    """Entry point of a local worker process: initialise once, then run points until told to stop."""
    try:
        _ensure_init(init)
    except Exception:  # noqa: BLE001 -- reported per point by run_point
        pass
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError, KeyboardInterrupt):
            return
        if msg is None:
            return
        idx, payload = msg
        try:
            base, params, metrics, duration = pickle.loads(payload)
        except Exception as exc:  # noqa: BLE001 -- e.g. base's module cannot be imported in the worker
            res = {"status": "failed", "error": f"cannot unpickle the point in the worker: {type(exc).__name__}: {exc}",
                   "metrics": {}, "wall_s": 0.0, "worker": f"{socket.gethostname()}:{os.getpid()}"}
        else:
            res = run_point(base, params, metrics, duration, init)
        try:
            conn.send((idx, res))
        except (OSError, ValueError):
            return

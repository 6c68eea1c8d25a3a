"""Parameter sweeps: one scene, many parameter values, one CSV row per point.

    def base(params):                              # builds the scene of one point
        g = fdem.sweep.group_params(params)        # {"material": {...}, "solver": {...}}
        mat = fdem.Material(density=1000.0, young=1e7, **g["material"])
        scene = fdem.Scene()
        ...
        return scene                               # or a Simulation, or (Simulation, duration)

    def metrics(sim):
        return {"kinetic": sim.energies()["kinetic"]}

    sweep = fdem.sweep.Sweep(base, axes={"material.friction": [0.2, 0.4], "solver.safety": [0.1, 0.2]},
                             metrics=metrics, duration=0.1)
    rows = sweep.run(workers=2, output="sweep.csv")              # local worker processes
    rows = sweep.run(output="sweep.csv", scheduler="tcp://host:8786")   # a Dask cluster

The contract of ``base``
------------------------
``base(params)`` receives one point, a dict {dotted key: value}, and builds its scene.  By
convention keys are ``"material.<Material field>"`` (``material.friction``,
``material.penalty`` [Pa], ``material.young`` [Pa], ...), ``"contact.<field>"`` for
:meth:`Scene.set_interaction` values, ``"solver.<build argument>"`` (``solver.safety``,
``solver.dt`` [s], ``solver.buffer`` [m], ``solver.strategy``) and ``"solver.duration"`` [s];
:func:`group_params` splits them by prefix.  ``base`` returns

* a :class:`~taichi_fdem.scene.Scene`: the sweep builds it with the ``solver.*`` values of the
  point (other than ``solver.duration``) as :meth:`Scene.build` arguments;
* a :class:`~taichi_fdem.simulation.Simulation` (``base`` applied the solver values itself);
* or ``(Simulation, duration [s])``.

The simulated time of a point is ``solver.duration`` of the point, else the duration that
``base`` returned, else the sweep's ``duration``.  ``base`` may instead be the path of a scene
file: the point's keys are then dotted keys into that file (``"materials.rock.friction"``,
``"bodies.block.velocity"``, ``"solver.safety"``), see :func:`taichi_fdem.scenefile.apply_overrides`.

``metrics(sim)`` returns a dict {column name: value} after the run; or give a list of names
from :data:`METRICS` (``"time"``, ``"steps"``, ``"couple_count"``, ``"energies"``,
``"displacement:BODY"``, ``"position:BODY"``, ``"velocity:BODY"``).

Execution
---------
Every point runs in a worker process started with the ``spawn`` method (Taichi must never
be forked after it is initialised); each worker calls :func:`taichi_fdem.init` itself and
runs its points one after the other, so the compiled kernels are reused (sweep values are
kernel arguments, never compile-time constants).  A point that raises, becomes unstable
(:class:`~taichi_fdem.simulation.SimulationError`), exceeds ``timeout`` or kills its worker
is recorded with its status and error text; a dead worker is replaced and the sweep goes on.
``base`` and ``metrics`` are sent to the workers by pickling, so for local runs they must be
module-level functions (Dask's cloudpickle also accepts lambdas).

The CSV
-------
One row per point: the parameters, the metrics, ``status`` (``ok``, ``failed``, ``unstable``,
``timeout``, ``crashed``), ``error``, ``wall_s`` (wall time of the point in its worker, s)
and ``worker`` (host:pid).  Each row is appended and flushed to disk as soon as its point
completes, so an interrupted sweep keeps every completed point.  With ``resume=True`` a
re-run reads the CSV, keeps the ``ok`` rows, drops the others and runs only the points
without an ``ok`` row (points are matched by their parameter values as written in the CSV).
"""
from __future__ import annotations

import csv
import difflib
import itertools
import json
import math
import os
import pickle
import socket
import threading
import time
from collections import deque
from typing import Callable

__all__ = ["Sweep", "SweepError", "METRICS", "group_params", "registry_metrics", "run_point", "load"]

STATUS_COLUMNS = ("status", "error", "wall_s", "worker")
SOLVER_BUILD_KEYS = ("dt", "safety", "buffer", "strategy", "force_dt", "check_overlap")


class SweepError(ValueError):
    """A sweep definition (Python arguments or a sweep file) was refused; the message names it."""


# ----------------------------------------------------------------------------------------------
# parameters
# ----------------------------------------------------------------------------------------------
def group_params(params: dict) -> dict:
    """Split dotted keys by their prefix: {"material.friction": 0.3, "solver.safety": 0.1, "x": 1}
    → {"material": {"friction": 0.3}, "solver": {"safety": 0.1}, "": {"x": 1}}.

    The groups "material", "contact" and "solver" are always present (possibly empty).
    """
    out: dict = {"material": {}, "contact": {}, "solver": {}}
    for key, value in params.items():
        head, _, rest = key.partition(".")
        if rest:
            out.setdefault(head, {})[rest] = value
        else:
            out.setdefault("", {})[key] = value
    return out


def _plain(v):
    """NumPy scalars and arrays to plain Python values (for pickling and the CSV)."""
    if hasattr(v, "tolist") and not isinstance(v, (str, bytes)):
        return v.tolist()
    return v


def _cell(v) -> str:
    """The CSV text of a value: the same text for the same value, so that resume can match points."""
    v = _plain(v)
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, (int, str)):
        return str(v)
    return json.dumps(v)


def _parse_cell(s: str):
    """Inverse of :func:`_cell` where it can be (numbers back to int / float)."""
    if s == "":
        return None
    if s in ("true", "false"):
        return s == "true"
    for conv in (int, float):
        try:
            return conv(s)
        except ValueError:
            pass
    if s[:1] in "[{":
        try:
            return json.loads(s)
        except ValueError:
            pass
    return s


def _check_value(where: str, v) -> None:
    v = _plain(v)
    if isinstance(v, bool) or isinstance(v, (int, str)):
        return
    if isinstance(v, float):
        if not math.isfinite(v):
            raise SweepError(f"{where}: values must be finite, got {v!r}")
        return
    if isinstance(v, (list, tuple)) and all(isinstance(c, (int, float)) and not isinstance(c, bool) for c in v):
        return
    raise SweepError(f"{where}: a value must be a number, a string, a boolean or a list of numbers, got {v!r}")


# ----------------------------------------------------------------------------------------------
# metrics registry
# ----------------------------------------------------------------------------------------------
def _body_of(sim, name: str):
    for b in sim.bodies:
        if b.name == name:
            return b
    raise ValueError(f"metric: no body named {name!r} (bodies: {', '.join(b.name for b in sim.bodies)})")


def _centroid(sim, body, what):
    m = sim.node_masses(body)
    x = {"displacement": sim.node_displacements, "position": sim.node_positions,
         "velocity": sim.node_velocities}[what](body)
    return (m[:, None] * x).sum(axis=0) / m.sum()


#: Metrics of :class:`Sweep` and sweep files, by name: (columns, unit, description).
METRICS = {
    "time": ("time", "s", "simulated time at the end"),
    "steps": ("steps", "", "time steps taken"),
    "dt": ("dt", "s", "time step"),
    "couple_count": ("couple_count", "", "contact couples at the end"),
    "energies": ("energy_kinetic, energy_strain, energy_contact, energy_gravity, energy_damping, energy_friction, "
                 "energy_contact_damping, energy_boundary_work, energy_total", "J", "Simulation.energies() at the end"),
    "displacement:BODY": ("BODY_dx, BODY_dy, BODY_displacement", "m",
                          "displacement of the body's centre of mass (and its length)"),
    "position:BODY": ("BODY_x, BODY_y", "m", "centre of mass of the body at the end"),
    "velocity:BODY": ("BODY_vx, BODY_vy", "m/s", "velocity of the body's centre of mass at the end"),
}


def _metric_values(name: str, sim) -> dict:
    kind, _, body = name.partition(":")
    if kind == "time":
        return {"time": sim.time}
    if kind == "steps":
        return {"steps": sim.step_count}
    if kind == "dt":
        return {"dt": sim.dt}
    if kind == "couple_count":
        return {"couple_count": sim.couple_count}
    if kind == "energies":
        return {f"energy_{k}": float(v) for k, v in sim.energies().items()}
    b = _body_of(sim, body)
    c = _centroid(sim, b, kind)
    if kind == "displacement":
        return {f"{body}_dx": float(c[0]), f"{body}_dy": float(c[1]), f"{body}_displacement": float(math.hypot(*c))}
    if kind == "position":
        return {f"{body}_x": float(c[0]), f"{body}_y": float(c[1])}
    return {f"{body}_vx": float(c[0]), f"{body}_vy": float(c[1])}


class registry_metrics:
    """A picklable metrics function made of names of :data:`METRICS` (checked here)."""

    def __init__(self, names, body_names=None, where: str = "metrics"):
        if isinstance(names, str) or not isinstance(names, (list, tuple)) or not names:
            raise SweepError(f"{where}: give a non-empty list of metric names, e.g. [\"time\", \"energies\"]")
        plain = [k for k in METRICS if ":" not in k]
        kinds = [k.split(":")[0] for k in METRICS if ":" in k]
        for n in names:
            if not isinstance(n, str):
                raise SweepError(f"{where}: metric names are strings, got {n!r}")
            kind, colon, body = n.partition(":")
            if colon:
                if kind not in kinds:
                    close = difflib.get_close_matches(kind, kinds, n=1)
                    raise SweepError(f"{where}: unknown metric {n!r}" + (f" (did you mean '{close[0]}:{body}'?)" if close else "")
                                     + f"; known: {', '.join(METRICS)}")
                if not body:
                    raise SweepError(f"{where}: metric {n!r} needs a body name, e.g. '{kind}:block'")
                if body_names is not None and body not in body_names:
                    close = difflib.get_close_matches(body, list(body_names), n=1)
                    raise SweepError(f"{where}: metric {n!r}: no body named {body!r}"
                                     + (f" (did you mean {close[0]!r}?)" if close else "")
                                     + f"; bodies: {', '.join(body_names)}")
            elif n not in plain:
                close = difflib.get_close_matches(n, list(METRICS), n=1)
                raise SweepError(f"{where}: unknown metric {n!r}" + (f" (did you mean {close[0]!r}?)" if close else "")
                                 + f"; known: {', '.join(METRICS)}")
        self.names = list(names)

    def __call__(self, sim) -> dict:
        out = {}
        for n in self.names:
            out.update(_metric_values(n, sim))
        return out

    def __repr__(self):
        return f"registry_metrics({self.names!r})"


# ----------------------------------------------------------------------------------------------
# one point (runs in a worker process)
# ----------------------------------------------------------------------------------------------
_LOCK = threading.Lock()      # one Taichi run at a time per process (Dask workers may have threads)


def _ensure_init(init: dict | None) -> None:
    from . import backend
    if not backend.is_initialised():
        backend.init(**(init or {}))


def _build_point(base, params: dict, duration):
    from .scene import Scene
    from .simulation import Simulation
    params = dict(params)
    dur = params.get("solver.duration")
    if isinstance(base, (str, os.PathLike)):
        from .io import scenefile
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
    from .simulation import SimulationError
    t0 = time.perf_counter()
    res = {"status": "ok", "error": "", "metrics": {}, "worker": f"{socket.gethostname()}:{os.getpid()}"}
    with _LOCK:
        try:
            _ensure_init(init)
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


# ----------------------------------------------------------------------------------------------
# the CSV table
# ----------------------------------------------------------------------------------------------
class _Table:
    """The sweep's CSV: rows appended and flushed as points complete; rewritten atomically when a
    new metric column appears or when resume drops rows that did not succeed."""

    def __init__(self, path: str, param_cols: list, resume: bool):
        self.path = os.fspath(path)
        self.param_cols = list(param_cols)
        self.metric_cols: list = []
        self.rows: list[dict] = []
        self._fh = None
        folder = os.path.dirname(os.path.abspath(self.path))
        os.makedirs(folder, exist_ok=True)
        if resume and os.path.exists(self.path) and os.path.getsize(self.path) > 0:
            self._read()
        self._rewrite()

    @property
    def columns(self) -> list:
        return self.param_cols + self.metric_cols + list(STATUS_COLUMNS)

    def _read(self) -> None:
        try:
            with open(self.path, newline="", encoding="utf-8") as f:
                reader = csv.DictReader(f)
                header = list(reader.fieldnames or [])
                rows = list(reader)
        except (OSError, csv.Error, UnicodeDecodeError) as exc:
            raise SweepError(f"{self.path}: cannot read the existing sweep table to resume: {exc}") from None
        missing = [c for c in self.param_cols + ["status"] if c not in header]
        if missing:
            raise SweepError(f"{self.path}: the existing table has columns {header} but this sweep needs "
                             f"{', '.join(missing)}: it belongs to another sweep; choose another output, "
                             f"or run with resume=False (--no-resume) to overwrite it")
        # metric columns are those that are neither parameters nor status columns
        self.metric_cols = [c for c in header if c not in self.param_cols and c not in STATUS_COLUMNS]
        for r in rows:
            if r.get("status") == "ok":
                self.rows.append({c: r.get(c, "") or "" for c in self.columns})

    def done_keys(self) -> set:
        return {tuple(r[c] for c in self.param_cols) for r in self.rows}

    def _open(self):
        if self._fh is None:
            self._fh = open(self.path, "a", newline="", encoding="utf-8")
        return self._fh

    def _rewrite(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None
        tmp = self.path + ".tmp"
        with open(tmp, "w", newline="", encoding="utf-8") as f:
            w = csv.DictWriter(f, fieldnames=self.columns)
            w.writeheader()
            for r in self.rows:
                w.writerow({c: r.get(c, "") for c in self.columns})
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, self.path)

    def append(self, params: dict, res: dict) -> dict:
        row = {c: _cell(params.get(c)) for c in self.param_cols}
        new = [k for k in res["metrics"] if k not in self.metric_cols and k not in self.param_cols]
        row.update({k: _cell(v) for k, v in res["metrics"].items()})
        row.update(status=res["status"], error=" ".join(str(res.get("error", "")).split()),
                   wall_s=f"{res.get('wall_s', 0.0):.4f}", worker=res.get("worker", ""))
        self.rows.append(row)
        if new:
            self.metric_cols += new
            self._rewrite()
        else:
            f = self._open()
            csv.DictWriter(f, fieldnames=self.columns).writerow({c: row.get(c, "") for c in self.columns})
            f.flush()
            os.fsync(f.fileno())
        return row

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None


# ----------------------------------------------------------------------------------------------
# the sweep
# ----------------------------------------------------------------------------------------------
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
            from .io import scenefile
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
            from .io import scenefile
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
        workers : local worker processes (ignored with ``scheduler``).
        output : the CSV path (its folder is created).
        resume : keep the ``ok`` rows of an existing ``output`` and skip their points;
            False overwrites it.
        scheduler : None (local processes), a Dask scheduler address ``"tcp://host:port"`` or a
            ``dask.distributed.Client``.
        timeout : wall seconds after which a local point is stopped and recorded as "timeout".
        on_result : ``on_result(row, done, total)`` called as each point completes (row: the CSV
            texts of that row).

        Each returned dict holds the point's parameters, its metrics, ``status``, ``error``,
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
        ctx = mp.get_context("spawn")
        pending = deque(todo)
        pool: list[dict] = []

        def start():
            parent, child = ctx.Pipe()
            proc = ctx.Process(target=_worker_main, args=(child, self.init), daemon=True,
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


# ----------------------------------------------------------------------------------------------
# sweep files
# ----------------------------------------------------------------------------------------------
SWEEP_KEYS = ("scene", "output", "workers", "metrics", "duration", "scheduler", "timeout", "resume", "axes", "points")


def load(path) -> tuple[Sweep, dict]:
    """Read a sweep file; returns (Sweep, run options {output, workers, scheduler, timeout, resume}).

    Format (paths read are relative to the sweep file, the output to the working directory)::

        [sweep]
        scene = "pile_small.toml"           # the base scene file (required)
        output = "out/sweep.csv"            # [<sweep file name>.csv]
        workers = 2                         # local worker processes [2]
        metrics = ["time", "energies", "displacement:disk1"]   # names of METRICS [time, steps, energies]
        duration = 0.1                      # s [the scene's solver.duration]
        scheduler = "tcp://10.0.0.5:8786"   # a Dask scheduler [none: local processes]
        timeout = 600.0                     # s per point, local runs [none]
        resume = true                       # skip points already ok in the output [true]

        [sweep.axes]                        # a grid: dotted keys into the scene file
        "materials.rock.friction" = [0.2, 0.4, 0.6]
        "solver.safety" = [0.1, 0.2]

        # or, instead of [sweep.axes], an explicit list:
        # [[sweep.points]]
        # "materials.rock.friction" = 0.2
    """
    from .io import scenefile
    path = os.fspath(path)
    try:
        data, text = scenefile.read_toml(path)
    except scenefile.SceneFileError as exc:
        raise SweepError(str(exc)) from None
    ck = scenefile._Checker(path, text)
    top = [k for k in data if k != "sweep"]
    if top:
        raise SweepError(str(ck.error((top[0],), f"unknown table {top[0]!r}{scenefile._suggest(top[0], ['sweep'])}; "
                                      f"a sweep file has one [sweep] table", table=())))
    s = data.get("sweep")
    if not isinstance(s, dict):
        raise SweepError(f"{path}: no [sweep] table (scene = \"file.toml\", [sweep.axes] or [[sweep.points]], metrics, ...)")
    sp = ("sweep",)
    for key in s:
        if key not in SWEEP_KEYS:
            raise SweepError(str(ck.error(sp + (key,), f"unknown key {key!r}{scenefile._suggest(key, SWEEP_KEYS)}; "
                                          f"allowed keys: {', '.join(SWEEP_KEYS)}")))
    K = scenefile._Key
    try:
        v = {
            "scene": ck.value(s, "scene", K("str", required=True), sp),
            "output": ck.value(s, "output", K("str"), sp),
            "workers": ck.value(s, "workers", K("int", 2, lo=1), sp),
            "duration": ck.value(s, "duration", K("float", unit="s", lo=0.0), sp),
            "scheduler": ck.value(s, "scheduler", K("str"), sp),
            "timeout": ck.value(s, "timeout", K("float", unit="s", lo=0.0, lo_open=True), sp),
            "resume": ck.value(s, "resume", K("bool", True), sp),
        }
    except scenefile.SceneFileError as exc:
        raise SweepError(str(exc)) from None
    scene = v["scene"] if os.path.isabs(v["scene"]) else os.path.join(os.path.dirname(os.path.abspath(path)), v["scene"])
    if not os.path.isfile(scene):
        raise SweepError(str(ck.error(sp + ("scene",), f"scene file {v['scene']!r} not found (looked for {scene}; "
                                      f"paths are relative to the sweep file's folder)")))
    if ("axes" in s) == ("points" in s):
        raise SweepError(str(ck.error(sp, "give exactly one of [sweep.axes] (a grid) or [[sweep.points]] (a list)",
                                      table=sp)))
    axes = points = None
    if "axes" in s:
        axes = s["axes"]
        if not isinstance(axes, dict) or not axes:
            raise SweepError(str(ck.error(sp + ("axes",), "[sweep.axes] must be a table of \"dotted.key\" = [values]")))
        for k, vals in axes.items():
            if not isinstance(vals, list) or not vals:
                raise SweepError(str(ck.error(sp + ("axes", k), f"axis {k!r} must be a non-empty list of values, "
                                              f"got {vals!r}", table=sp + ("axes",))))
    else:
        points = s["points"]
        if not isinstance(points, list) or not points or not all(isinstance(p, dict) for p in points):
            raise SweepError(str(ck.error(sp + ("points",), "points must be an array of tables [[sweep.points]]")))
    metrics = s.get("metrics", ["time", "steps", "energies"])
    where_m = ck.where(sp + ("metrics",))
    try:
        spec = scenefile.load(scene)
    except scenefile.SceneFileError as exc:
        raise SweepError(f"{ck.where(sp + ('scene',))}: [sweep] scene: {exc}") from None
    metrics = registry_metrics(metrics, spec.body_names, where=f"{where_m}: [sweep] metrics")
    try:
        sweep = Sweep(scene, axes=axes, points=points, metrics=metrics, duration=v["duration"])
    except SweepError as exc:
        key = "axes" if axes is not None else "points"
        raise SweepError(f"{ck.where(sp + (key,))}: [sweep.{key}] {exc}") from None
    output = v["output"] or os.path.splitext(os.path.basename(path))[0] + ".csv"
    return sweep, {"output": output, "workers": v["workers"], "scheduler": v["scheduler"],
                   "timeout": v["timeout"], "resume": v["resume"]}

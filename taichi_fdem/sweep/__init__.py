"""Parameter sweeps: one scene, many parameter values, one CSV row per point.

::

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
* a :class:`~taichi_fdem.sim.simulation.Simulation` (``base`` applied the solver values itself);
* or ``(Simulation, duration [s])``.

The simulated time of a point is ``solver.duration`` of the point, else the duration that
``base`` returned, else the sweep's ``duration``.  ``base`` may instead be the path of a scene
file: the point's keys are then dotted keys into that file (``"materials.rock.friction"``,
``"bodies.block.velocity"``, ``"solver.safety"``), see :func:`taichi_fdem.io.scenefile.apply_overrides`.

``metrics(sim)`` returns a dict {column name: value} after the run; or give a list of names
from :data:`METRICS` (``"time"``, ``"steps"``, ``"couple_count"``, ``"energies"``,
``"displacement:BODY"``, ``"position:BODY"``, ``"velocity:BODY"``).

Execution
---------
Every point runs in a worker process started with the ``spawn`` method (Taichi must never
be forked after it is initialised); each worker calls :func:`taichi_fdem.init` itself and
runs its points one after the other, so the compiled kernels are reused (sweep values are
kernel arguments, never compile-time constants).  A point that raises, becomes unstable
(:class:`~taichi_fdem.sim.simulation.SimulationError`), exceeds ``timeout`` or kills its worker
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

Modules
-------
:mod:`.params` (parameters, :class:`SweepError`, CSV cells), :mod:`.metrics` (:data:`METRICS`),
:mod:`.worker` (one point in a worker process: :func:`run_point`), :mod:`.table` (the CSV),
:mod:`.runner` (:class:`Sweep` and its local and Dask runs), :mod:`.sweepfile` (:func:`load`) and
:mod:`.calibrate` (``fdem.calibrate``: bracketing, least squares, Bayesian or differential
evolution over batches of sweep points).
Every public name is importable from ``taichi_fdem.sweep``.
"""
from __future__ import annotations

from .metrics import METRICS, registry_metrics
from .params import SOLVER_BUILD_KEYS, STATUS_COLUMNS, SweepError, group_params  # noqa: F401 (constants re-exported)
from .runner import Sweep
from .sweepfile import SWEEP_KEYS, load  # noqa: F401
from .worker import FunctionPoint, run_point

__all__ = ["Sweep", "SweepError", "METRICS", "group_params", "registry_metrics", "run_point", "load", "FunctionPoint"]

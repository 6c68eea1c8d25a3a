"""Simulation: the driver over a built model and its state (step, run, forces, profile, results).

``Scene.build()`` computes the :class:`~taichi_fdem.sim.model.Model` once, allocates the
:class:`~taichi_fdem.sim.model.State` and hands both to a :class:`Simulation`, which launches the
kernels of :mod:`taichi_fdem.engine.step` with the array groups as argpacks (time steps:
:mod:`taichi_fdem.sim.timestep`; guards: :mod:`taichi_fdem.sim.guards`; energies:
:mod:`taichi_fdem.sim.energies`; results: :mod:`taichi_fdem.sim.results`).

Stepping is the solver's job (:mod:`taichi_fdem.sim.solver`): ``sim.solver`` is the active
:class:`~taichi_fdem.sim.solver.SerialSolver` or :class:`~taichi_fdem.sim.solver.ParallelSolver`,
and :meth:`Simulation.step` calls its ``advance``.  A scene with a fluid (``scene.set_fluid``)
runs no team launch: its parallel solver runs one step per launch, so "auto" runs it serial
on the CPU.  Otherwise "auto" picks parallel on the CPU from 2 threads and usable cores and
:data:`AUTO_PARALLEL_ITEMS` items (triangles + joints + couples), and on GPUs.
"""
from __future__ import annotations

import math
import time as _time

import numpy as np

from . import excavation, guards
from .. import backend
from ..engine import refresh
from ..engine.tiutil import launch_cached
from .guards import SimulationError
from ..engine.groups import COUPLES, DACC
from .model import build_model, counter
from .state import allocate_scratch, allocate_state, grow_couples, pack_groups, size_assembly, size_couple_scratch
from .outputs import RunOutputs
from .recorders import Checks, CrackEvents, History, Recorder
from .cracks import Cracks
from .fluid import FluidResults
from .results import Loads, SimulationResults
from .solver import SERIAL_MAX_STEPS, SERIAL_TRI_STEPS, TEAM_TRI_STEPS, ParallelSolver, SerialSolver, Solver
from .settings import ModelValues
from .timestep import CONTACT_LIMIT_FACTOR  # noqa: F401  (re-exported)

__all__ = ["Simulation", "SimulationError", "SERIAL_MAX_STEPS", "SERIAL_TRI_STEPS", "TEAM_TRI_STEPS",
           "AUTO_PARALLEL_ITEMS", "DETECT_SERIAL_TRIS"]

AUTO_PARALLEL_ITEMS = 600        # triangles + joints + couples from which "auto" runs parallel on >= 2 CPU threads
DETECT_SERIAL_TRIS = 15_000      # up to this many contact triangles, detection runs as one serial launch

_LEGACY_VIDEO = ("video", "fps", "frame_dt", "renderer", "png_dir", "video_cracks")
_LEGACY_CHECKS = {"check_energy": "energy", "energy_tol": "energy_tol", "max_penetration": "max_penetration",
                  "check_every": "every"}
_LEGACY_RUN = _LEGACY_VIDEO + ("history", "history_every", "crack_events") + tuple(_LEGACY_CHECKS)


def _legacy_run_arguments(record, checks, kw: dict):
    """(recorders, checks, callback interval [s] or None) of a :meth:`Simulation.run` call that
    used the keywords of version 0.1.0 (or a video path as its second argument); each such use
    warns once per call."""
    import warnings
    if isinstance(record, Recorder):
        record = [record]
    elif isinstance(record, (str, bytes)) or hasattr(record, "__fspath__"):
        kw = dict(kw, video=record)
        record = []
    else:
        try:
            record = list(record)
        except TypeError:
            raise TypeError(f"run: record must be a list of recorders, got {record!r}") from None
    unknown = sorted(set(kw) - set(_LEGACY_RUN))
    if unknown:
        raise TypeError(f"run() got unexpected keyword argument(s) {', '.join(unknown)}")
    used = [k for k in _LEGACY_RUN if k in kw]
    if not used:
        return record, checks, None
    callback_dt = None
    warnings.warn(f"run({', '.join(k + '=' for k in used)}...) is deprecated: pass recorders, "
                  f"run(duration, record=[fdem.Video(...), fdem.History(...), fdem.CrackEvents(...)]), and "
                  f"checks=fdem.Checks(...)", DeprecationWarning, stacklevel=3)
    if kw.get("video") is not None:
        import importlib
        video_cls = importlib.import_module("taichi_fdem.render.recorder").Video   # the render layer's recorder
        record.append(video_cls(kw["video"], fps=kw.get("fps") or 30, frame_dt=kw.get("frame_dt"),
                                renderer=kw.get("renderer"), png_dir=kw.get("png_dir"),
                                cracks=bool(kw.get("video_cracks"))))
    else:
        callback_dt = kw.get("frame_dt")         # without a video, frame_dt spaced the callbacks
        orphans = [k for k in ("fps", "renderer", "png_dir", "video_cracks") if kw.get(k) not in (None, False)]
        if orphans:
            raise ValueError(f"run: {', '.join(k + '=' for k in orphans)} set(s) a video, but no video= is given")
    if kw.get("history") is None and kw.get("history_every") is not None:
        raise ValueError("run: history_every= needs history=")
    if kw.get("history") is not None:
        record.append(History(kw["history"], every=kw.get("history_every")))
    if kw.get("crack_events") is not None:
        record.append(CrackEvents(kw["crack_events"]))
    legacy = {new: kw[old] for old, new in _LEGACY_CHECKS.items() if old in kw}
    if legacy:
        if checks is not None:
            raise TypeError(f"run: give checks= or {', '.join(k + '=' for k in _LEGACY_CHECKS if k in kw)}, "
                            f"not both")
        checks = Checks(**legacy)
    return record, checks, callback_dt


class Simulation(SimulationResults, ModelValues):
    """A built scene: model, state and the stepping loop.  Create with :meth:`Scene.build`.

    Units: SI.  Positions [m], velocities [m/s], masses [kg], energies [J] (the solver works per
    unit thickness; reported masses and energies are multiplied by the scene's thickness).

    ``sim.model`` (built once, :class:`~taichi_fdem.sim.model.Model`) and ``sim.state`` (what a
    step changes, :class:`~taichi_fdem.sim.model.State`) hold the arrays.  The commonly read
    model values have read-only properties (:attr:`dt_limit`, :attr:`tri_count`,
    :attr:`node_count`, :attr:`joint_count`, :attr:`contact`, :attr:`friction`,
    :attr:`fracture`, :attr:`damping`, :attr:`contact_damping`, :attr:`buffer`); every other
    value is read from ``sim.model``.  :attr:`dt` may be set (validated).  Assigning a name of
    the model or the state on the simulation raises (it would change nothing).
    """

    @staticmethod
    def _checkpoint_io():
        """The checkpoint module (``save(sim, path)``, ``load(path)``), which sits above the
        simulation (it rebuilds one from its scene), imported by name when first used."""
        import importlib
        return importlib.import_module("taichi_fdem.io.checkpoint")

    def __init__(self, scene, dt=None, safety=0.2, force_dt=False, buffer=None, strategy="auto", check_overlap=True,
                 speed_limit=None, quasi_static=0.0, joined_pairs="joint", handover_damage=None):
        backend.ensure_init()
        self._generation = backend.generation()
        if strategy not in ("auto", "serial", "parallel"):
            raise ValueError(f"Scene.build: strategy must be 'auto', 'serial' or 'parallel', got {strategy!r}")
        self.scene = scene
        self.thickness = scene.thickness
        for name, view in (("cracks", Cracks), ("fluid", FluidResults), ("loads", Loads)):
            object.__setattr__(self, name, view(self))      # (sim.fluid is not sim.model.fluid, a flag)
        self.model = build_model(scene, dt=dt, safety=safety, force_dt=force_dt, buffer=buffer, speed_limit=speed_limit,
                                 quasi_static=quasi_static, joined_pairs=joined_pairs, handover_damage=handover_damage)
        object.__setattr__(self, "bodies", self.model.bodies)     # (also a model value)
        self.state = allocate_state(self.model)
        auto = strategy == "auto"
        if auto:
            strategy = "serial" if backend.arch() == "cpu" else "parallel"
        self._solvers = {"serial": SerialSolver(), "parallel": ParallelSolver(
            assembly="blocks" if backend.arch() == "cpu" else "slots")}
        for solver in self._solvers.values():
            solver._attach(self)
        self._use_solver(strategy)
        par = self._solvers["parallel"]
        self._scratch = allocate_scratch(self.model, self.state, parallel=strategy == "parallel",
                                        blocks=par.assembly == "blocks", force_blocks=par.force_blocks)
        self.step_count = 0
        self._launches: dict[str, int] = {}
        self._stats = {"wall_steps": 0.0, "wall_detect": 0.0}
        self._repack()
        self._refresh_neighbours()
        if self.model.contact:
            self._detect()
            if check_overlap:
                guards.warn_overlaps(self)
        elif strategy == "parallel":
            self.solver.prepare(refresh=False)    # no contact: the node lists never change
        if auto and self._strategy == "serial" and self._parallel_pays():
            self._use_solver("parallel")

    # ---- the solver (sim.solver) ------------------------------------------------------------------
    @property
    def solver(self) -> Solver:
        """The active solver (:mod:`taichi_fdem.sim.solver`): its strategy, settings, launch and
        detection counters, and per-phase profile."""
        return self._solvers[self._strategy]

    def _use_solver(self, strategy: str) -> None:
        """Make the solver of ``strategy`` the active one."""
        if strategy not in ("serial", "parallel"):
            raise ValueError(f"strategy must be 'serial' or 'parallel', got {strategy!r}")
        self._strategy = strategy
        self._sync_assembly()

    @property
    def _teams(self):
        """The parallel solver's team executor (:class:`~taichi_fdem.sim.team.TeamScheduler`)."""
        return self._solvers["parallel"].teams

    def _parallel_pays(self) -> bool:
        """Whether the parallel strategy beats the serial one on this CPU (module docstring): at
        least two threads and two usable cores (affinity set, CPU quota), and enough items.  Never
        with a fluid: its parallel strategy launches every step (no team), which costs more on
        the CPU than the serial launch of many steps."""
        if self.model.fluid:
            return False
        cores = min(backend.cpu_threads(), backend.usable_cores())
        return cores >= 2 and self._items() >= AUTO_PARALLEL_ITEMS

    def _items(self) -> int:
        """Work items of a step: triangles + joints + contact couples."""
        md = self.model
        return md.tri_count + (md.joint_count if md.fracture else 0) + self._couple_count()

    def _repack(self) -> None:
        """Rebuild the argpacks (after an array of the state was reallocated)."""
        self._packs = pack_groups(self.model, self.state, self._scratch)
        self._launch_cache = {}

    def _sync_assembly(self) -> None:
        """Make the scratch's assembly arrays follow strategy, assembly and force_blocks (once
        parallel, they stay allocated), and rebuild what depends on them."""
        sw = self.__dict__.get("_scratch")
        if sw is None:
            return                               # during __init__, before the scratch exists
        par = self._solvers["parallel"]
        want = (sw.parallel or self._strategy == "parallel", par.assembly == "blocks", par.force_blocks)
        if (sw.parallel, sw.blocks, sw.force_blocks) == want:
            return
        sw.parallel, sw.blocks, sw.force_blocks = want
        size_assembly(self.model, self.state, sw)
        self._repack()
        if self._strategy == "parallel":
            self.solver.prepare(refresh=True)

    def _after_restore(self) -> None:
        """Re-derive scratch sizes, argpacks and node lists after the state was replaced
        (checkpoint load, restore_last_good)."""
        par = self._solvers["parallel"]
        for name in ("assembly", "force_blocks", "team_workers", "team_steps"):
            if "_" + name in self.__dict__:      # a checkpoint that kept the settings on the simulation
                object.__setattr__(par, "_" + name, self.__dict__.pop("_" + name))
        for solver in self._solvers.values():
            solver._attach(self)
        self._scratch.blocks = par.assembly == "blocks"
        self._scratch.force_blocks = par.force_blocks
        size_couple_scratch(self.model, self.state, self._scratch)
        if np.any(self.state.tri_intact.to_numpy() < 0):
            self._apply_removal()                 # the rebuilt model lacks the excavations
        self._repack()
        self._refresh_neighbours()
        if self.model.fracture:
            self._launch("refresh_joint_z", refresh.refresh_joint_z, self._packs["joints"])
        if self._strategy == "parallel":
            self.solver.prepare(refresh=True)

    def _refresh_neighbours(self) -> None:
        """Which neighbour pairs are no longer bonded (``tri_nb_on``), from the joints and the
        tri_intact bits."""
        if self.model.contact and self.model.nb_count:
            p = self._packs
            self._launch("refresh_neighbours", refresh.refresh_neighbours, p["tris"], p["contact"], p["joints"],
                         p["step"])

    # ------------------------------------------------------------------------------------------
    # excavation
    # ------------------------------------------------------------------------------------------
    def remove(self, body=None, where=None) -> int:
        """Remove triangles now (an excavation): those of ``body`` and/or whose initial centroid
        satisfies ``where(x, y)``.  Returns how many were removed.

        A removed triangle exerts no more force (elastic, contact, joints) and its mass leaves
        its nodes; nodes left without any triangle are held still.  In a stressed mass the new
        surface is left with the unbalanced initial stress, so the rock relaxes dynamically
        (docs/theory/loads.md §12.4).  The energy the removed triangles held (strain, kinetic, gravity) is
        booked in ``energies()["excavated"]`` so that the balance still closes.  Loads on edges
        of removed triangles stay applied.  Selecting no present triangle is an error.
        """
        return excavation.remove(self, body, where)

    def _apply_removal(self) -> None:
        """Masses, held orphan nodes and joints after triangles were removed (tri_intact < 0)."""
        excavation.apply_removal(self)

    def _grow_couples(self, capacity: int) -> None:
        grow_couples(self.model, self.state, capacity)
        size_couple_scratch(self.model, self.state, self._scratch)
        self._repack()
        if self._strategy == "parallel":
            self.solver.prepare(refresh=False)   # the slot arrays were reallocated

    _alloc_couples = _grow_couples

    def _launch(self, name, kernel, *args):
        self._launches[name] = self._launches.get(name, 0) + 1
        return kernel(*args)

    def _launch_cached(self, name, kernel, *args):
        """:meth:`_launch` for the kernels launched often (the steps, detection), without Taichi's
        per-call variant lookup (:func:`taichi_fdem.engine.tiutil.launch_cached`)."""
        self._launches[name] = self._launches.get(name, 0) + 1
        return launch_cached(self._launch_cache, name, kernel, *args)


    def _couple_count(self) -> int:
        return counter(self.state.step_int, COUPLES) if self.state.couple_max else 0

    # ------------------------------------------------------------------------------------------
    # contact detection (parallel strategy, and at build)
    # ------------------------------------------------------------------------------------------
    def _detect(self) -> None:
        """Contact detection now, by the active solver (:meth:`Solver.detect`)."""
        t0 = _time.perf_counter()
        self.solver.detect()
        self._stats["wall_detect"] += _time.perf_counter() - t0

    # ------------------------------------------------------------------------------------------
    # stepping
    # ------------------------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """Advance ``n`` time steps."""
        n = int(n)
        if n < 0:
            raise ValueError(f"step: n must be >= 0, got {n}")
        backend.check_generation(self._generation)
        t0 = _time.perf_counter()
        self._forget_apart()
        self.solver.advance(n)
        self._stats["wall_steps"] += _time.perf_counter() - t0

    def _forget_apart(self) -> None:
        """Drop the certificates of separation (``scratch.couple_skip``, engine.contact): positions
        set from the host between launches need not move as the steps account for."""
        if self.model.contact and self.state.couple_max:
            self._scratch.couple_skip.fill(0)

    def _detect_due(self) -> bool:
        st = self.state
        return bool(self.model.contact and counter(st.step_real, DACC) >= self.model.buffer)

    def _detect_serially(self) -> bool:
        """Whether detection runs as one serial task (:data:`DETECT_SERIAL_TRIS`): a launch of its
        own on the host, or inside a team launch."""
        return self.model.ctri_count <= DETECT_SERIAL_TRIS

    def _team(self) -> int:
        """Workers of the next team launch, 0 for one launch per step."""
        par = self._solvers["parallel"]
        return par.teams.workers(self) if par.team_launches() else 0

    def _team_size(self) -> int:
        """The most workers a team launch may have (:meth:`ParallelSolver.team_size`)."""
        return self._solvers["parallel"].team_size()

    def forces(self, contact_only: bool = False) -> np.ndarray:
        """Total nodal forces [N] at the current state (elastic + contact), without stepping.

        Shape (n, 2), multiplied by the thickness.  Gravity is not included.  The state is left
        untouched: the friction slip history and the dissipation accumulators are restored.
        """
        from .profiling import evaluate_forces
        return evaluate_forces(self, contact_only)

    # ---- last good state (run's checks) ---------------------------------------------------------
    _last_good = None

    def _save_last_good(self) -> None:
        self._last_good = guards.snapshot(self)

    def restore_last_good(self) -> int:
        """Roll the state back to the last one that passed :meth:`run`'s checks; returns its step.

        After a :class:`SimulationError` raised inside :meth:`run`, this is the state at the
        last check before the failure (at most one chunk of steps earlier); it can then be
        inspected, rendered or saved.  RuntimeError if no run has recorded a state yet.
        """
        if self._last_good is None:
            raise RuntimeError("restore_last_good: no good state recorded yet (run() records one at its start "
                               "and after every check that passes)")
        guards.restore(self, self._last_good)
        return self.step_count

    def _energy_scale(self, e: dict) -> float:
        return guards.energy_scale(e)

    # ------------------------------------------------------------------------------------------
    # run
    # ------------------------------------------------------------------------------------------
    def run(self, duration: float, record=(), *, progress: bool | None = None, callback=None,
            checks: Checks | None = None, **deprecated) -> None:
        """Advance by ``duration`` seconds of simulated time.

        Every step the kernels stop on non-finite values, inverted elements and node speeds above
        ``speed_limit``.  In addition, ``run`` checks the energy balance and the contact
        penetration after every chunk of steps, as ``checks`` (a :class:`~taichi_fdem.sim.recorders.Checks`,
        default ``Checks()``) sets.  A failed check raises :class:`SimulationError` (cause,
        step, time, suggested dt), like the per-step checks.  The state of the last check that
        passed (or of the start of the run) is kept: :meth:`restore_last_good` rolls back to it,
        e.g. to save it.

        Parameters
        ----------
        record : recorders, written as the run goes (:mod:`taichi_fdem.sim.recorders`):
            ``fdem.Video(path, ...)`` (frames), ``fdem.History(path, every=None)`` (a CSV row
            every ``every`` steps), ``fdem.CrackEvents(path)`` (a CSV row per broken joint),
            ``fdem.export.VTU(directory, frame_dt=None)`` (a VTU series), or any
            :class:`~taichi_fdem.sim.recorders.Recorder`.  Each writes at the start, on its
            own schedule and at the end, and is closed also when the run stops with an error.
        progress : show a progress bar (default: when stdout is a terminal).
        callback : ``callback(sim)`` called at every frame of the first recorder that takes
            frames, or 100 times over the run without one.
        checks : the run's checks (:class:`~taichi_fdem.sim.recorders.Checks`).

        The keywords of version 0.1.0 (``video``, ``fps``, ``frame_dt``, ``renderer``,
        ``png_dir``, ``video_cracks``, ``history``, ``history_every``, ``crack_events``,
        ``check_energy``, ``energy_tol``, ``max_penetration``, ``check_every``) still work and
        warn (DeprecationWarning); any other keyword raises TypeError.
        """
        record, checks, callback_dt = _legacy_run_arguments(record, checks, deprecated)
        duration = float(duration)
        if not (math.isfinite(duration) and duration >= 0):
            raise ValueError(f"run: duration must be a finite time >= 0 s, got {duration}")
        total = int(round(duration / self.dt))
        checks = Checks() if checks is None else checks
        if not isinstance(checks, Checks):
            raise TypeError(f"run: checks must be a taichi_fdem.Checks, got {checks!r}")
        outputs = RunOutputs(self, total, duration, record, progress)
        with outputs:
            framed = [fs for fs in outputs.frame_steps if fs is not None]
            if callback is not None:
                if callback_dt is not None:
                    every_cb = max(1, int(round(float(callback_dt) / self.dt)))
                else:
                    every_cb = framed[0] if framed else max(1, int(round(duration / 100 / self.dt)))
            per_launch = self.solver.steps_per_launch()
            done = 0
            guard = guards.RunGuard(self, checks.energy, checks.energy_tol, checks.max_penetration, checks.every)
            while done < total:
                k = min(per_launch, total - done)
                if callback is not None:
                    k = min(k, every_cb - done % every_cb)
                j = outputs.steps_to_next(done, min(k, guard.steps_to_next_check()))
                t_step = _time.perf_counter()
                self.step(j)
                guard.step_wall = (_time.perf_counter() - t_step) / j
                done += j
                outputs.after_steps(done)
                guard.check(j, last=done >= total)
                outputs.after_check(done)
                if callback is not None and (done % every_cb == 0 or done >= total):
                    callback(self)

    # ------------------------------------------------------------------------------------------
    # info and checkpoints
    # ------------------------------------------------------------------------------------------
    def info(self) -> dict:
        """Sizes, features, time step and strategy of this simulation; ``"threads"`` (Taichi's
        CPU threads, the usable cores and the team's largest size) and ``"team"``: the team
        launches' counters (waits past their bound, launches resumed by one worker, switches
        to one worker on a shared CPU and back, steps run by one worker; zeros before any team
        launch, :class:`~taichi_fdem.sim.team.TeamScheduler`).  ``device``: the arch it runs on ("cpu", "cuda", "vulkan", ...; see :func:`taichi_fdem.init`)."""
        md = self.model
        return {"nodes": md.node_count, "triangles": md.tri_count, "bodies": len(self.bodies),
                "contact_triangles": md.ctri_count, "couples": self._couple_count(), "dt": md.dt,
                "dt_limit": md.dt_limit, "dt_estimate": md.dt_estimate, "dt_elastic": md.dt_elastic,
                "dt_contact": md.dt_contact,
                "strategy": self._strategy, "contact": md.contact, "friction": md.friction,
                "damping": md.damping, "contact_damping": md.contact_damping, "buffer": md.buffer,
                "fracture": md.fracture, "joints": md.joint_count, "dt_joint": md.dt_joint,
                "fluid": md.fluid, "dt_fluid": md.dt_fluid, "fluid_edges": md.fluid_edge_count,
                "joint_sets": {name: int((md.joint_set_np == k).sum())
                               for k, name in enumerate(getattr(md, "joint_set_names", ["default"]))},
                "crack_edges": sum(getattr(b, "crack_count", 0) for b in self.bodies),
                "precision": backend.precision(), "device": backend.arch(),
                "threads": {"taichi": backend.cpu_threads(), "usable_cores": backend.usable_cores(),
                            "team": self._team_size() if self._solvers["parallel"].team_launches() else 0},
                "team": dict(self._teams.stats)}

    def save(self, path) -> None:
        """Write a checkpoint of the whole state to ``path`` (one file, written atomically).

        The state (every array a step changes), the step count and the scene are stored;
        :meth:`load` rebuilds the model from the scene and continues the run exactly.  See
        :mod:`taichi_fdem.io.checkpoint`.
        """
        Simulation._checkpoint_io().save(self, path)

    @classmethod
    def load(cls, path) -> "Simulation":
        """A Simulation restored from a checkpoint written by :meth:`save`.

        Raises :class:`taichi_fdem.io.checkpoint.CheckpointError` (a ValueError) for a corrupt
        file, another format version or another precision.  Only load files you trust (the
        scene is unpickled).
        """
        return Simulation._checkpoint_io().load(path)

"""Simulation: the driver over a built model and its state (step, run, forces, profile, results).

``Scene.build()`` computes the :class:`~taichi_fdem.sim.model.Model` once, allocates the
:class:`~taichi_fdem.sim.model.State` and hands both to a :class:`Simulation`, which launches the
kernels of :mod:`taichi_fdem.engine.step` with the array groups as argpacks (time steps:
:mod:`taichi_fdem.sim.timestep`; guards: :mod:`taichi_fdem.sim.guards`; energies:
:mod:`taichi_fdem.sim.energies`; results: :mod:`taichi_fdem.sim.results`).

Execution strategy (:mod:`taichi_fdem.engine.step`): the serial one runs thousands of steps per
launch on one core; the parallel one sums the forces without atomics and, on the CPU, runs
thousands of steps per launch in a team of worker threads (:mod:`taichi_fdem.engine.team`,
``sim.solver.team_steps``) whose waits are bounded, sized to the usable cores, and replaced
by one worker while another busy process shares the cores (:mod:`taichi_fdem.sim.team`).  A scene with a fluid
(``scene.set_fluid``) runs no team launch: its parallel strategy runs one step per launch
(:func:`taichi_fdem.engine.step.step_parallel_fluid`), so "auto" runs it serial on the CPU.
Otherwise "auto" picks parallel on the CPU from 2 threads and usable cores and
:data:`AUTO_PARALLEL_ITEMS` items (triangles + joints + couples), and on GPUs.
"""
from __future__ import annotations

import math
import time as _time

import numpy as np

from . import excavation, guards
from .. import backend
from ..engine import refresh, step as kernels
from ..engine.tiutil import launch_cached
from .guards import SimulationError
from ..engine.groups import COUPLES, DACC, DETECTIONS, FORCE_BLOCKS, FOUND, MAX_FORCE_BLOCKS, REBALANCE
from .model import build_model, counter, set_counter
from .state import allocate_scratch, allocate_state, grow_couples, pack_groups, size_assembly, size_couple_scratch
from .outputs import RunOutputs
from .recorders import Checks, CrackEvents, History, Recorder
from .cracks import Cracks
from .fluid import FluidResults
from .results import Loads, SimulationResults
from .solver import Solver
from .settings import ModelValues
from .team import TeamScheduler
from .timestep import CONTACT_LIMIT_FACTOR  # noqa: F401  (re-exported)

__all__ = ["Simulation", "SimulationError", "SERIAL_MAX_STEPS", "SERIAL_TRI_STEPS", "TEAM_TRI_STEPS",
           "AUTO_PARALLEL_ITEMS", "DETECT_SERIAL_TRIS"]

SERIAL_MAX_STEPS = 2000          # at most this many steps per serial launch
SERIAL_TRI_STEPS = 2_000_000     # ~50 ms of work per serial launch: responsive progress and Ctrl-C
TEAM_TRI_STEPS = 10_000_000      # the same for a team launch (sim.solver.steps_per_launch)
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

    #: parallel strategy on the CPU: run many steps per launch in a team of
    #: at most min(:attr:`force_blocks`, threads, usable cores) workers
    #: (:func:`taichi_fdem.engine.step.run_steps_blocks`); False: one launch per step.  The same
    #: bits either way.
    _team_steps = True
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
        for name, view in (("solver", Solver), ("cracks", Cracks), ("fluid", FluidResults), ("loads", Loads)):
            object.__setattr__(self, name, view(self))      # (sim.fluid is not sim.model.fluid, a flag)
        self.model = build_model(scene, dt=dt, safety=safety, force_dt=force_dt, buffer=buffer, speed_limit=speed_limit,
                                 quasi_static=quasi_static, joined_pairs=joined_pairs, handover_damage=handover_damage)
        object.__setattr__(self, "bodies", self.model.bodies)     # (also a model value)
        self.state = allocate_state(self.model)
        auto = strategy == "auto"
        if auto:
            strategy = "serial" if backend.arch() == "cpu" else "parallel"
        self._set_strategy(strategy)
        self._assembly = "blocks" if backend.arch() == "cpu" else "slots"
        self._force_blocks = FORCE_BLOCKS
        self._scratch = allocate_scratch(self.model, self.state, parallel=strategy == "parallel",
                                        blocks=self._assembly == "blocks", force_blocks=self._force_blocks)
        self.step_count = 0
        self._teams = TeamScheduler()
        self._launches: dict[str, int] = {}
        self._stats = {"wall_steps": 0.0, "wall_detect": 0.0}
        self._repack()
        self._refresh_neighbours()
        if self.model.contact:
            self._detect()
            if check_overlap:
                guards.warn_overlaps(self)
        elif strategy == "parallel":
            self._build_node_slots()             # no contact: the node lists never change
        if auto and self._strategy == "serial" and self._parallel_pays():
            self._set_strategy("parallel")

    # ---- execution settings (sim.solver) ----------------------------------------------------------
    def _set_strategy(self, value: str) -> None:
        if value not in ("serial", "parallel"):
            raise ValueError(f"strategy must be 'serial' or 'parallel', got {value!r}")
        self._strategy = value
        self._sync_assembly()

    def _set_assembly(self, value: str) -> None:
        if value not in ("blocks", "slots"):
            raise ValueError(f"assembly must be 'blocks' or 'slots', got {value!r}")
        self._assembly = value
        self._sync_assembly()

    def _set_force_blocks(self, value: int) -> None:
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= MAX_FORCE_BLOCKS:
            raise ValueError(f"force_blocks must be an integer from 1 to {MAX_FORCE_BLOCKS}, got {value!r}")
        if int(value) != self._force_blocks and "state" in self.__dict__:
            set_counter(self.state.step_int, REBALANCE, 0)     # the couple ranges follow the blocks
        self._force_blocks = int(value)
        self._sync_assembly()

    def _set_team_workers(self, value) -> None:
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1):
            raise ValueError(f"team_workers must be None or an integer >= 1, got {value!r}")
        self._team_workers = None if value is None else int(value)

    _team_workers = None

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
        p = self._packs
        # the groups each step kernel takes, in order
        self._groups = {"serial": (p["nodes"], p["tris"], p["mats"], p["contact"], p["detect"], p["joints"], p["step"]),
                        "parallel": (p["nodes"], p["tris"], p["mats"], p["contact"], p["joints"], p["step"], p["asm"]),
                        "team": (p["team"],)}
        if self.model.fluid:
            self._groups["serial"] = (p["serial_fluid"],)
            self._groups["parallel"] = self._groups["parallel"] + (p["fluid"],)


    def _sync_assembly(self) -> None:
        """Make the scratch's assembly arrays follow strategy, assembly and force_blocks (once
        parallel, they stay allocated), and rebuild what depends on them."""
        sw = self.__dict__.get("_scratch")
        if sw is None:
            return                               # during __init__, before the scratch exists
        want = (sw.parallel or self._strategy == "parallel", self._assembly == "blocks", self._force_blocks)
        if (sw.parallel, sw.blocks, sw.force_blocks) == want:
            return
        sw.parallel, sw.blocks, sw.force_blocks = want
        size_assembly(self.model, self.state, sw)
        self._repack()
        if self._strategy == "parallel":
            self._build_node_slots(refresh=True)

    def _after_restore(self) -> None:
        """Re-derive scratch sizes, argpacks and node lists after the state was replaced
        (checkpoint load, restore_last_good)."""
        self._scratch.blocks = self.__dict__.get("_assembly", "blocks") == "blocks"
        self._scratch.force_blocks = self.__dict__.get("_force_blocks", FORCE_BLOCKS)
        size_couple_scratch(self.model, self.state, self._scratch)
        if np.any(self.state.tri_intact.to_numpy() < 0):
            self._apply_removal()                 # the rebuilt model lacks the excavations
        self._repack()
        self._refresh_neighbours()
        if self.model.fracture:
            self._launch("refresh_joint_z", refresh.refresh_joint_z, self._packs["joints"])
        if self._strategy == "parallel":
            self._build_node_slots(refresh=True)

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
            self._build_node_slots()             # the slot arrays were reallocated

    def _build_node_slots(self, refresh: bool = False) -> None:
        """The slot assembly's node lists; with ``refresh`` (a restore, a new scratch), the block
        assembly's node ranges and chunk masks (engine.step.refresh_blocks)."""
        p = self._packs
        if not self._scratch.blocks:
            self._launch("build_node_slots", kernels.build_node_slots, p["tris"], p["contact"], p["joints"], p["step"],
                         p["asm"], self.model.contact, self.model.fracture)
        elif refresh:
            self._launch("refresh_blocks", kernels.refresh_blocks, p["nodes"], p["tris"], p["contact"], p["joints"],
                         p["step"], p["asm"], *self._switches())

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

    def _switches(self):
        # contact, friction, fracture, loads, the local damping and more than two force blocks
        # (engine.blocks.block_forces) are compile-time switches (absent features are not
        # compiled); damping, contact damping, prescribed velocities and initial stress are
        # runtime switches in the step group (a branch each), which keeps compiled variants few
        md, many = self.model, self._strategy == "parallel" and self._assembly == "blocks" and self._force_blocks > 2
        return (kernels.Features(bool(md.contact), bool(md.friction), bool(md.fracture), bool(md.loads),
                                 bool(md.local_damping), many, bool(md.fluid)),)

    def _steps_per_launch(self) -> int:
        budget = TEAM_TRI_STEPS if self._strategy == "parallel" and self._team_launches() else SERIAL_TRI_STEPS
        return max(1, min(SERIAL_MAX_STEPS, budget // max(1, self.model.tri_count)))

    # ------------------------------------------------------------------------------------------
    # contact detection (parallel strategy, and at build)
    # ------------------------------------------------------------------------------------------
    def _detect(self) -> None:
        t0 = _time.perf_counter()
        p = self._packs
        if self._detect_serially():                          # one serial launch (small scenes)
            args = (p["nodes"], p["tris"], p["detect"], p["contact"], p["step"], self.model.friction)
            found = self._launch_cached("detect_serial", kernels.detect_serial, *args)
            if found > self.state.couple_max:
                self._grow_couples(int(found * 1.5) + 64)
                p = self._packs
                self._launch_cached("detect_serial", kernels.detect_serial, p["nodes"], p["tris"], p["detect"],
                                    p["contact"], p["step"], self.model.friction)
        else:
            found = self._launch("detect_count", kernels.detect_count, p["nodes"], p["tris"], p["detect"],
                                 p["contact"], p["step"])
            if found > self.state.couple_max:
                self._grow_couples(int(found * 1.5) + 64)
                p = self._packs
            self._launch("detect_fill", kernels.detect_fill, p["tris"], p["detect"], p["contact"], p["step"],
                         self.model.friction)
        if self._strategy == "parallel":
            self._build_node_slots()
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
        if self._strategy == "serial":
            self._step_serial(n)
        else:
            self._step_parallel(n)
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

    def _team_launches(self) -> bool:
        """Whether the parallel strategy runs team launches (block assembly on the CPU, team_steps;
        never with a fluid, whose scenes run one parallel step per launch)."""
        return bool(self._scratch.blocks and backend.arch() == "cpu" and self._team_steps and not self.model.fluid)

    def _team(self) -> int:
        """Workers of the next team launch (:class:`~taichi_fdem.sim.team.TeamScheduler`), 0 for one
        launch per step."""
        return self._teams.workers(self) if self._team_launches() else 0

    def _team_size(self) -> int:
        """The most workers a team launch may have: the blocks, Taichi's threads, the cores this
        process may use (:func:`backend.usable_cores`: affinity set, CPU quota) and
        :attr:`team_workers`."""
        return max(1, min(self._force_blocks, backend.cpu_threads(), backend.usable_cores(),
                          self._team_workers or MAX_FORCE_BLOCKS))

    def _step_parallel(self, n: int) -> None:
        switches = self._switches()
        due = self._detect_due()
        if self._team_launches():
            self._teams.run(self, n, due, switches)
            return
        for _ in range(n):
            if due:
                self._detect()
            if self.model.fluid:
                code = self._launch_cached("step_parallel_fluid", kernels.step_parallel_fluid, *self._groups["parallel"],
                                           *switches, self._scratch.blocks)
            else:
                code = self._launch_cached("step_parallel", kernels.step_parallel, *self._groups["parallel"], *switches,
                                           self._scratch.blocks)
            self.step_count += 1
            due = self.model.contact and bool(code & 1)
            if code & 2:
                guards.raise_unstable(self)

    def _step_serial(self, n: int) -> None:
        switches = self._switches()
        per_launch = self._steps_per_launch()
        while n > 0:
            chunk = min(n, per_launch)
            if self.model.fluid:
                done = self._launch_cached("run_steps_serial_fluid", kernels.run_steps_serial_fluid, chunk,
                                           *self._groups["serial"], *switches)
            else:
                done = self._launch_cached("run_steps_serial", kernels.run_steps_serial, chunk, *self._groups["serial"],
                                           *switches)
            unstable = done >= kernels.UNSTABLE_BIT
            done &= kernels.UNSTABLE_BIT - 1
            self.step_count += done
            n -= done
            if unstable:
                guards.raise_unstable(self)
            if done < chunk:
                found = counter(self.state.step_int, FOUND)
                if found > self.state.couple_max:          # the kernel stopped for a bigger buffer
                    self._grow_couples(int(found * 1.5) + 64)

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
            per_launch = self._steps_per_launch()
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
                            "team": self._team_size() if self._team_launches() else 0},
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

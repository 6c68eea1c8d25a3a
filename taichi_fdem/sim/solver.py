"""The solvers: how a :class:`~taichi_fdem.sim.simulation.Simulation` advances its state.

A solver has one job and one entry point, :meth:`Solver.advance` (``advance(n)``: run ``n``
time steps of the simulation's model on its state, raising
:class:`~taichi_fdem.sim.guards.SimulationError` after an unstable step).  ``sim.solver`` is the
active one; ``Scene.build(strategy=...)`` or ``sim.solver.strategy = ...`` chooses it:

* :class:`SerialSolver` ("serial"): thousands of whole steps per launch in one serial loop,
  detection included (:func:`taichi_fdem.engine.step.run_steps_serial`);
* :class:`ParallelSolver` ("parallel"): the forces summed without atomic float adds (block or
  slot assembly); on the CPU its executor is a team of worker threads running many steps per
  launch (:func:`taichi_fdem.engine.step.run_steps_blocks`, scheduled by
  :class:`~taichi_fdem.sim.team.TeamScheduler`), otherwise one launch per step.

The fluid in the fracture network is a sub-solver coupled into either one
(:class:`FluidCoupling`): its phase runs inside every step.  Heat conduction is a sub-solver that
runs its own kernels between mechanical launches (:class:`HeatCoupling`): the solvers split their
batches of steps at its updates.  A solver's settings live on it
(the parallel solver's: :attr:`~ParallelSolver.assembly`, :attr:`~ParallelSolver.force_blocks`,
:attr:`~ParallelSolver.team_workers`, :attr:`~ParallelSolver.team_steps`; the serial solver
passes them to the parallel one, which uses them once the strategy switches).  Changing a
setting changes how the steps run, never what they compute beyond round-off
(docs/guide/strategies.md).
"""
from __future__ import annotations

import math

import numpy as np

from ..engine import heat as heat_kernels, step as kernels
from ..engine.groups import DETECTIONS, DT, FORCE_BLOCKS, FOUND, MAX_FORCE_BLOCKS, REBALANCE, TIME
from ..engine.heat import H_DT, H_DT_CONTACT, H_EVERY, H_SINCE, H_SUB, H_TIME, H_UPDATES
from . import guards
from .model import counter, set_counter
from .team import TeamScheduler

__all__ = ["Solver", "SerialSolver", "ParallelSolver", "FluidCoupling", "HeatCoupling", "SERIAL_MAX_STEPS", "SERIAL_TRI_STEPS",
           "TEAM_TRI_STEPS", "HEAT_EVERY_MAX"]

SERIAL_MAX_STEPS = 2000          # at most this many steps per launch
SERIAL_TRI_STEPS = 2_000_000     # triangle-steps per serial launch: responsive progress and Ctrl-C
TEAM_TRI_STEPS = 10_000_000      # the same for a team launch

HEAT_EVERY_MAX = 100            # mechanical steps between two heat updates at most (HeatCoupling.every)

_STEPS = kernels.UNSTABLE_BIT - 1    # the steps in a launch's result


class FluidCoupling:
    """The fluid in the fracture network as a sub-solver of the mechanical step
    (:mod:`taichi_fdem.engine.fluid`, docs/theory/fluid.md): its phase runs in every step of
    the active solver, after the loads and before the integration (apertures, pressures, the
    pressure forces on the faces, the flow over the step), and its work is booked after the
    integration.  It is compiled into the solvers' step kernels (``Features.fluid``); this
    object gives them its group: with it, the serial solver launches every group in one
    argpack (:func:`~taichi_fdem.engine.step.run_steps_serial_fluid`) and the parallel one one
    step per launch (:func:`~taichi_fdem.engine.step.step_parallel_fluid`: the team's stages
    have no fluid unit)."""

    def serial_groups(self, packs: dict) -> tuple:
        return (packs["serial_fluid"],)

    def parallel_groups(self, packs: dict) -> tuple:
        return (packs["fluid"],)


def _heat_launches(m: int) -> list:
    """The heat steps of each launch for ``m`` steps: :data:`~taichi_fdem.engine.heat.HEAT_STEPS_PER_LAUNCH`
    while at least that many remain, then the binary digits of the rest (13 → 8, 4, 1)."""
    k = heat_kernels.HEAT_STEPS_PER_LAUNCH
    rest = m % k
    return [k] * (m // k) + [b for b in (4, 2, 1) if b < k and rest & b]


class HeatCoupling:
    """Heat conduction as a sub-solver between mechanical launches (:mod:`taichi_fdem.engine.heat`,
    docs/theory/heat.md §16): every n = :meth:`every` mechanical steps it advances the temperatures over
    the time those steps took, in m = ⌈n Δt / Δt_h⌉ heat steps of n Δt / m each (Δt_h the stable
    heat step ``sim.model.dt_heat``; several per mechanical step when Δt_h < Δt: the mechanical
    step is never shortened), then writes each triangle's thermal strain.  The solvers split
    their batches of steps at its updates; the steps since the last update and the count of
    updates are state (``heat_int``), so a checkpoint resumes the schedule."""

    def __init__(self, sim):
        self._sim = sim

    @property
    def time(self) -> float:
        """The time [s] the temperatures are at: the end of the last heat update."""
        return counter(self._sim.state.heat_real, H_TIME)

    @property
    def updates(self) -> int:
        """Heat updates so far."""
        return counter(self._sim.state.heat_int, H_UPDATES)

    def every(self) -> int:
        """Mechanical steps per heat update: ⌊Δt_h / Δt⌋, at least 1 and at most
        :data:`HEAT_EVERY_MAX` (the thermal strains then change in small increments against
        the mechanical response)."""
        sim = self._sim
        ratio = sim.model.dt_heat / counter(sim.state.step_real, DT)
        return int(max(1, min(ratio, HEAT_EVERY_MAX)))

    def steps_to_update(self) -> int:
        """Mechanical steps until the next heat update (at least 1)."""
        return max(1, self.every() - counter(self._sim.state.heat_int, H_SINCE))

    def after_steps(self, k: int) -> None:
        """Book ``k`` mechanical steps; update the heat when an interval is complete."""
        hi = self._sim.state.heat_int
        since = counter(hi, H_SINCE) + k
        set_counter(hi, H_SINCE, since)
        if since >= self.every():
            self.update()

    def update(self) -> None:
        """Advance the temperatures over the mechanical steps since the last update, then write
        the triangles' thermal strains.  With contact, the conducting contacts are found first
        at the current positions, and the heat steps are short enough for them too.  (The
        schedule's counters are read and written element by element: a whole-array copy costs
        a launch.)"""
        sim = self._sim
        st, md = sim.state, sim.model
        since = counter(st.heat_int, H_SINCE)
        span = since * counter(st.step_real, DT)
        if span > 0.0:
            p = sim._packs
            contact = bool(md.contact)
            dt_heat = md.dt_heat
            if contact:
                sim._launch_cached("heat_contacts", heat_kernels.heat_contacts, p["heat_step"])
                dt_contact = counter(st.heat_real, H_DT_CONTACT)
                if dt_contact > 0.0:
                    dt_heat = min(dt_heat, dt_contact)
            m = max(1, int(math.ceil(span / dt_heat * (1.0 + 1e-12)))) if math.isfinite(dt_heat) else 1
            hr = st.heat_real
            for slot, value in ((H_TIME, counter(st.step_real, TIME) - span), (H_DT, span / m), (H_SUB, m),
                                (H_EVERY, since)):
                set_counter(hr, slot, value)
            for k in _heat_launches(m):
                sim._launch_cached("heat_substeps", heat_kernels.heat_substeps, p["heat_step"], contact, k)
            self.thermal_strain()
        set_counter(st.heat_int, H_SINCE, 0)
        set_counter(st.heat_int, H_UPDATES, counter(st.heat_int, H_UPDATES) + 1)

    def thermal_strain(self) -> None:
        """Write each triangle's thermal strain from the temperatures (engine.heat), and book the
        change of its strain energy as thermal work."""
        sim = self._sim
        p = sim._packs
        sim._launch_cached("thermal_strain", heat_kernels.thermal_strain, p["nodes"], p["tris"], p["mats"], p["step"],
                           p["heat"], sim.solver.features()._replace(many_blocks=False))


class Solver:
    """How ``sim`` advances (module docstring): the entry point :meth:`advance`, the settings,
    and the launch and detection counters.  Every setting is validated and may be changed
    between calls of ``sim.step`` or ``sim.run``; an unknown one raises."""

    strategy_name = ""

    def __init__(self, sim=None):
        self._sim = sim
        self._fluid = None
        self._heat = None

    def _attach(self, sim) -> None:
        """Drive ``sim`` (at build, and after a checkpoint restored the settings)."""
        self._sim = sim
        self._fluid = FluidCoupling() if sim.model.fluid else None
        self._heat = HeatCoupling(sim) if getattr(sim.model, "heat", False) else None

    @property
    def heat(self) -> HeatCoupling | None:
        """The heat conduction sub-solver (:class:`HeatCoupling`), None without heat."""
        return self._heat

    @property
    def fluid(self) -> FluidCoupling | None:
        """The coupled fluid sub-solver (:class:`FluidCoupling`), None without a fluid."""
        return self._fluid

    def __setattr__(self, name, value):
        if not name.startswith("_") and not hasattr(type(self), name):
            raise AttributeError(f"sim.solver has no setting {name!r}; settings: strategy, assembly, "
                                 f"force_blocks, team_workers, team_steps")
        object.__setattr__(self, name, value)

    # the settings are what a checkpoint keeps of a solver
    def _settings(self) -> dict:
        return {}

    def __getstate__(self):
        return self._settings()

    def __setstate__(self, state):
        self.__init__()
        for name, value in state.items():
            object.__setattr__(self, "_" + name, value)

    def __eq__(self, other):
        return type(self) is type(other) and self._settings() == other._settings()

    __hash__ = None

    def __repr__(self) -> str:
        return f"{type(self).__name__}(strategy={self.strategy!r})"

    # ---- the entry point ----------------------------------------------------------------------
    def advance(self, n: int) -> None:
        """Run ``n`` time steps; :class:`~taichi_fdem.sim.guards.SimulationError` after an
        unstable one (a non-finite value, an inverted element, a speed above the limit).  With
        heat, the steps run in batches that end at the heat updates (:class:`HeatCoupling`)."""
        heat = self._heat
        if heat is None:
            self._advance_steps(n)
            return
        while n > 0:
            k = min(n, heat.steps_to_update())
            self._advance_steps(k)
            n -= k
            heat.after_steps(k)

    def _advance_steps(self, n: int) -> None:
        """Run ``n`` mechanical time steps (the strategy's launches)."""
        raise NotImplementedError

    def prepare(self) -> None:
        """Ready the scratch arrays this solver needs (when it becomes active, or after a
        restore)."""

    # ---- what every solver has ------------------------------------------------------------------
    @property
    def strategy(self) -> str:
        """"serial" or "parallel" (docs/guide/strategies.md; ``build(strategy="auto")`` picks
        one).  Setting it makes the other solver active (``sim.solver`` is then that one)."""
        return self.strategy_name

    @strategy.setter
    def strategy(self, value: str) -> None:
        self._sim._use_solver(value)

    def features(self) -> kernels.Features:
        """The compile-time features of this simulation's step kernels."""
        md = self._sim.model
        return kernels.Features(bool(md.contact), bool(md.friction), bool(md.fracture), bool(md.loads),
                                bool(md.local_damping), self._many_blocks(), bool(md.fluid), bool(md.bedding),
                                bool(md.heat))

    def _many_blocks(self) -> bool:
        return False

    def steps_per_launch(self) -> int:
        """Steps one launch runs: the chunk of ``run`` without frames (:data:`SERIAL_TRI_STEPS`
        / triangles, a team launch :data:`TEAM_TRI_STEPS` / triangles; at most
        :data:`SERIAL_MAX_STEPS`)."""
        return max(1, min(SERIAL_MAX_STEPS, SERIAL_TRI_STEPS // max(1, self._sim.model.tri_count)))

    def detect(self) -> None:
        """Contact detection now: one serial launch in small scenes, else the parallel broad phase;
        the couple buffer grows when the couples do not fit."""
        sim = self._sim
        p = sim._packs
        friction = sim.model.friction
        if sim._detect_serially():                          # one serial launch (small scenes)
            found = sim._launch_cached("detect_serial", kernels.detect_serial, p["nodes"], p["tris"], p["contact"],
                                       p["detect"], p["step"], friction)
            if found > sim.state.couple_max:
                sim._grow_couples(int(found * 1.5) + 64)
                p = sim._packs
                sim._launch_cached("detect_serial", kernels.detect_serial, p["nodes"], p["tris"], p["contact"],
                                   p["detect"], p["step"], friction)
        else:
            found = sim._launch("detect_count", kernels.detect_count, p["nodes"], p["tris"], p["contact"],
                                p["detect"], p["step"])
            if found > sim.state.couple_max:
                sim._grow_couples(int(found * 1.5) + 64)
                p = sim._packs
            sim._launch("detect_fill", kernels.detect_fill, p["tris"], p["contact"], p["detect"], p["step"], friction)

    @property
    def couple_count(self) -> int:
        """Number of contact couples in the current list (``sim.couples()`` lists them)."""
        return self._sim._couple_count()

    @property
    def detection_count(self) -> int:
        """How many contact detections have run."""
        return counter(self._sim.state.step_int, DETECTIONS)

    @property
    def launches(self) -> dict:
        """Kernel launches so far, by kernel name."""
        return self._sim._launches

    @property
    def scratch(self):
        """The work arrays of detection and of the parallel assembly
        (:class:`~taichi_fdem.sim.model.Scratch`; rewritten at each detection, never saved)."""
        return self._sim._scratch

    def profile(self, steps: int = 100) -> dict:
        """Run ``steps`` steps with one launch per phase and time each phase [s]
        (:func:`taichi_fdem.sim.profiling.profile`)."""
        from .profiling import profile
        return profile(self._sim, steps)


class ParallelSolver(Solver):
    """The parallel strategy: no atomic float add on the forces (the block assembly on the CPU,
    the slot assembly on GPUs); on the CPU its executor is a team of worker threads, many steps
    per launch (:mod:`taichi_fdem.engine.team`, :class:`~taichi_fdem.sim.team.TeamScheduler`).
    The same bits for any thread count and team size."""

    strategy_name = "parallel"

    def __init__(self, sim=None, assembly: str = "blocks"):
        super().__init__(sim)
        self._assembly = assembly
        self._force_blocks = FORCE_BLOCKS
        self._team_workers = None
        self._team_steps = True
        self._teams = TeamScheduler()

    @property
    def teams(self) -> TeamScheduler:
        """The executor of the team launches (its counters: ``sim.info()["team"]``)."""
        return self._teams

    def _settings(self) -> dict:
        return {"assembly": self._assembly, "force_blocks": self._force_blocks, "team_workers": self._team_workers,
                "team_steps": self._team_steps}

    def __repr__(self) -> str:
        return (f"ParallelSolver(assembly={self.assembly!r}, force_blocks={self.force_blocks}, "
                f"team_workers={self.team_workers}, team_steps={self.team_steps})")

    # ---- settings -----------------------------------------------------------------------------
    @property
    def assembly(self) -> str:
        """How the forces are summed without atomic float adds:

        * "blocks" (default on the CPU): the items are dealt to :attr:`force_blocks` blocks,
          block 0 adding into the nodal forces and every other block into its own copy, added
          per node in block order; run by a team of worker threads, many steps per launch
          (:attr:`team_steps`);
        * "slots" (default on GPUs): every triangle, joint and couple writes its forces into its
          own slots, summed per node through sorted lists rebuilt at each detection.

        Both give the same bits for any thread count; they differ from each other and from the
        serial strategy by round-off.
        """
        return self._assembly

    @assembly.setter
    def assembly(self, value: str) -> None:
        if value not in ("blocks", "slots"):
            raise ValueError(f"assembly must be 'blocks' or 'slots', got {value!r}")
        self._assembly = value
        self._sim._sync_assembly()

    @property
    def force_blocks(self) -> int:
        """Blocks of the block assembly (default :data:`~taichi_fdem.engine.groups.FORCE_BLOCKS`):
        at most this many threads share the force work of a step.  The results depend on it (the
        blocks' sums are added in block order), not on the thread count; set it to the cores of
        the machine (benchmarks/README.md measures the choice)."""
        return self._force_blocks

    @force_blocks.setter
    def force_blocks(self, value: int) -> None:
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= MAX_FORCE_BLOCKS:
            raise ValueError(f"force_blocks must be an integer from 1 to {MAX_FORCE_BLOCKS}, got {value!r}")
        if int(value) != self._force_blocks:
            set_counter(self._sim.state.step_int, REBALANCE, 0)     # the couple ranges follow the blocks
        self._force_blocks = int(value)
        self._sim._sync_assembly()

    @property
    def team_workers(self) -> int | None:
        """Worker threads of a team launch: None (default) for min(:attr:`force_blocks`, CPU
        threads); an integer caps it (at least 1).  Any number gives the same bits (the blocks'
        sums are added in block order whoever ran them)."""
        return self._team_workers

    @team_workers.setter
    def team_workers(self, value) -> None:
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1):
            raise ValueError(f"team_workers must be None or an integer >= 1, got {value!r}")
        self._team_workers = None if value is None else int(value)

    @property
    def team_steps(self) -> bool:
        """On the CPU, run many steps per launch in a team of at most min(:attr:`force_blocks`,
        threads, usable cores) workers (:func:`taichi_fdem.engine.step.run_steps_blocks`); False:
        one launch per step.  The same bits either way."""
        return bool(self._team_steps)

    @team_steps.setter
    def team_steps(self, value) -> None:
        if not isinstance(value, bool):
            raise ValueError(f"team_steps must be True or False, got {value!r}")
        self._team_steps = value

    def _many_blocks(self) -> bool:
        return self._sim._strategy == "parallel" and self._assembly == "blocks" and self._force_blocks > 2

    # ---- the executor -------------------------------------------------------------------------
    def team_launches(self) -> bool:
        """Whether steps run in team launches (block assembly on the CPU, :attr:`team_steps`, no
        fluid)."""
        from .. import backend
        return bool(self._sim._scratch.blocks and backend.arch() == "cpu" and self._team_steps and self._fluid is None)

    def team_size(self) -> int:
        """The most workers a team launch may have: the blocks, Taichi's threads, the cores this
        process may use (:func:`backend.usable_cores`: affinity set, CPU quota) and
        :attr:`team_workers`."""
        from .. import backend
        return max(1, min(self._force_blocks, backend.cpu_threads(), backend.usable_cores(),
                          self._team_workers or MAX_FORCE_BLOCKS))

    def steps_per_launch(self) -> int:
        if not self.team_launches():
            return super().steps_per_launch()
        return max(1, min(SERIAL_MAX_STEPS, TEAM_TRI_STEPS // max(1, self._sim.model.tri_count)))

    def prepare(self, refresh: bool = True) -> None:
        """The slot assembly's node lists; with ``refresh`` (a restore, a new scratch), the block
        assembly's node ranges (engine.step.refresh_blocks)."""
        sim = self._sim
        p = sim._packs
        if not sim._scratch.blocks:
            sim._launch("build_node_slots", kernels.build_node_slots, p["tris"], p["contact"], p["joints"], p["step"],
                        p["asm"], self.features())
        elif refresh:
            sim._launch("refresh_blocks", kernels.refresh_blocks, p["nodes"], p["tris"], p["contact"], p["joints"],
                        p["step"], p["asm"], self.features())

    def detect(self) -> None:
        super().detect()
        self.prepare(refresh=False)

    def _advance_steps(self, n: int) -> None:
        sim = self._sim
        due = sim._detect_due()
        if self.team_launches():
            self._teams.run(sim, n, due, self.features())
            return
        feat = self.features()
        name, kernel = "step_parallel", kernels.step_parallel
        if self.fluid is not None:
            name, kernel = "step_parallel_fluid", kernels.step_parallel_fluid
        for _ in range(n):
            if due:
                sim._detect()
            p = sim._packs
            groups = (p["nodes"], p["tris"], p["mats"], p["contact"], p["joints"], p["step"], p["asm"])
            if self.fluid is not None:
                groups += self.fluid.parallel_groups(p)
            code = sim._launch_cached(name, kernel, *groups, feat, sim._scratch.blocks)
            sim.step_count += 1
            due = sim.model.contact and bool(code & 1)
            if code & 2:
                guards.raise_unstable(sim)


class SerialSolver(Solver):
    """The serial strategy: thousands of whole steps per launch in one serial loop, detection
    included (:func:`taichi_fdem.engine.step.run_steps_serial`); forces are added to the nodes
    directly.  Its settings are the common ones; the parallel solver's (:attr:`assembly`,
    :attr:`force_blocks`, :attr:`team_workers`, :attr:`team_steps`) are passed to it."""

    strategy_name = "serial"

    def _parallel(self) -> ParallelSolver:
        return self._sim._solvers["parallel"]

    @property
    def assembly(self) -> str:
        """:attr:`ParallelSolver.assembly` (used once the strategy is "parallel")."""
        return self._parallel().assembly

    @assembly.setter
    def assembly(self, value) -> None:
        self._parallel().assembly = value

    @property
    def force_blocks(self) -> int:
        """:attr:`ParallelSolver.force_blocks` (used once the strategy is "parallel")."""
        return self._parallel().force_blocks

    @force_blocks.setter
    def force_blocks(self, value) -> None:
        self._parallel().force_blocks = value

    @property
    def team_workers(self):
        """:attr:`ParallelSolver.team_workers` (used once the strategy is "parallel")."""
        return self._parallel().team_workers

    @team_workers.setter
    def team_workers(self, value) -> None:
        self._parallel().team_workers = value

    @property
    def team_steps(self) -> bool:
        """:attr:`ParallelSolver.team_steps` (used once the strategy is "parallel")."""
        return self._parallel().team_steps

    @team_steps.setter
    def team_steps(self, value) -> None:
        self._parallel().team_steps = value

    def _advance_steps(self, n: int) -> None:
        sim = self._sim
        feat = self.features()
        per_launch = self.steps_per_launch()
        while n > 0:
            chunk = min(n, per_launch)
            p = sim._packs
            if self.fluid is not None:
                done = sim._launch_cached("run_steps_serial_fluid", kernels.run_steps_serial_fluid, chunk,
                                          *self.fluid.serial_groups(p), feat)
            else:
                done = sim._launch_cached("run_steps_serial", kernels.run_steps_serial, chunk, p["nodes"], p["tris"],
                                          p["mats"], p["contact"], p["detect"], p["joints"], p["step"], feat)
            unstable = done >= kernels.UNSTABLE_BIT
            done &= _STEPS
            sim.step_count += done
            n -= done
            if unstable:
                guards.raise_unstable(sim)
            if done < chunk:
                found = counter(sim.state.step_int, FOUND)
                if found > sim.state.couple_max:          # the kernel stopped for a bigger buffer
                    sim._grow_couples(int(found * 1.5) + 64)


SOLVERS = {"serial": SerialSolver, "parallel": ParallelSolver}

"""``sim.solver``: how a :class:`~taichi_fdem.sim.simulation.Simulation` executes its steps.

The execution settings and counters of one simulation, apart from its physics: the strategy
(serial or parallel), the parallel strategy's force assembly, its blocks and team, the steps per
launch, the launch and detection counters and a per-phase profile.  Changing any setting
changes how the steps run, never what they compute beyond round-off (docs/guide/strategies.md).
"""
from __future__ import annotations

from ..engine.groups import DETECTIONS
from .model import counter

__all__ = ["Solver"]


class Solver:
    """The execution settings of ``sim`` (``sim.solver``); every setting is validated and may
    be changed between calls of ``step`` or ``run``."""

    __slots__ = ("_sim",)

    def __init__(self, sim):
        object.__setattr__(self, "_sim", sim)

    def __setattr__(self, name, value):
        if not hasattr(type(self), name):
            raise AttributeError(f"sim.solver has no setting {name!r}; settings: strategy, assembly, "
                                 f"force_blocks, team_workers, team_steps")
        object.__setattr__(self, name, value)

    def __repr__(self) -> str:
        return (f"Solver(strategy={self.strategy!r}, assembly={self.assembly!r}, force_blocks={self.force_blocks}, "
                f"team_workers={self.team_workers}, team_steps={self.team_steps})")

    @property
    def strategy(self) -> str:
        """"serial" or "parallel" (docs/guide/strategies.md; ``build(strategy="auto")`` picks one)."""
        return self._sim._strategy

    @strategy.setter
    def strategy(self, value: str) -> None:
        self._sim._set_strategy(value)

    @property
    def assembly(self) -> str:
        """How the parallel strategy sums the nodal forces without atomic float adds (no effect
        on the serial strategy):

        * "blocks" (default on the CPU): the items are dealt to :attr:`force_blocks` blocks,
          block 0 adding into the nodal forces and every other block into its own copy, added
          per node in block order; run by a team of worker threads, many steps per launch
          (:attr:`team_steps`);
        * "slots" (default on GPUs): every triangle, joint and couple writes its forces into its
          own slots, summed per node through sorted lists rebuilt at each detection.

        Both give the same bits for any thread count; they differ from each other and from the
        serial strategy by round-off.
        """
        return self._sim._assembly

    @assembly.setter
    def assembly(self, value: str) -> None:
        self._sim._set_assembly(value)

    @property
    def force_blocks(self) -> int:
        """Blocks of the block assembly (default :data:`~taichi_fdem.engine.groups.FORCE_BLOCKS`):
        at most this many threads share the force work of a parallel step.  The results depend
        on it (the blocks' sums are added in block order), not on the thread count; set it to
        the cores of the machine (benchmarks/README.md measures the choice)."""
        return self._sim._force_blocks

    @force_blocks.setter
    def force_blocks(self, value: int) -> None:
        self._sim._set_force_blocks(value)

    @property
    def team_workers(self) -> int | None:
        """Worker threads of a team launch of the parallel strategy on the CPU: None (default)
        for min(:attr:`force_blocks`, CPU threads); an integer caps it (at least 1).  Any number
        gives the same bits (the blocks' sums are added in block order whoever ran them)."""
        return self._sim._team_workers

    @team_workers.setter
    def team_workers(self, value) -> None:
        self._sim._set_team_workers(value)

    @property
    def team_steps(self) -> bool:
        """Parallel strategy on the CPU: run many steps per launch in a team of at most
        min(:attr:`force_blocks`, threads, usable cores) workers
        (:func:`taichi_fdem.engine.step.run_steps_blocks`); False: one launch per step.  The same
        bits either way."""
        return bool(self._sim._team_steps)

    @team_steps.setter
    def team_steps(self, value) -> None:
        if not isinstance(value, bool):
            raise ValueError(f"team_steps must be True or False, got {value!r}")
        self._sim._team_steps = value

    def steps_per_launch(self) -> int:
        """Steps one launch runs: the chunk of ``run`` without frames (serial:
        ``SERIAL_TRI_STEPS`` / triangles; a team launch: ``TEAM_TRI_STEPS`` / triangles; at most
        ``SERIAL_MAX_STEPS``; constants of :mod:`taichi_fdem.sim.simulation`)."""
        return self._sim._steps_per_launch()

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

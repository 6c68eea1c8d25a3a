"""How the parallel strategy runs its team launches on the CPU (:mod:`taichi_fdem.engine.team`):
the bound of a wait, resumption after a wait past it, and the choice between the team and one
worker on a shared CPU.  Every choice here changes the speed, never the bits."""
from __future__ import annotations

import time as _time

from .. import backend
from ..engine import step as kernels
from . import guards

TEAM_WAIT_MIN = 0.02             # a team's wait is bounded by this [s], or by TEAM_WAIT_STEPS of its steps
TEAM_WAIT_STEPS = 8.0            # (mean step times of the last launch), whichever is longer
TEAM_SPINS_PER_S = 5e7           # tries of a team's wait per second (an i32 atomic each, ~10-20 ns)
TEAM_PROBE_FIRST = 1.0           # the team and one worker are timed against each other after this [s],
TEAM_PROBE_MAX = 16.0            # then twice as long after each probe that agrees, up to this [s]
TEAM_CPU_SHARE = 0.85            # ... and at once after a launch whose workers got less than this share of
                                 # their cores (descheduled: another busy process shares them)
TEAM_PROBE_STEPS = 8             # a probe launch runs 1/8 of a launch's steps

_STEPS = kernels.UNSTABLE_BIT - 1    # the steps in a launch's result


class TeamScheduler:
    """The team launches of one simulation.

    ``stats``: waits that ran past their bound (``timeouts``), launches resumed by one worker
    after one (``resumed``), probes timing the team against one worker (``probes``) and steps
    run by one worker because it timed faster (``solo_steps``); ``Simulation.info()["team"]``.
    """

    def __init__(self):
        self.stats = {"timeouts": 0, "resumed": 0, "probes": 0, "solo_steps": 0}
        self.solo = False          # one worker timed faster than the team (choose)
        self.probe_at = 0.0        # perf_counter time of the next probe (0: no team launch yet)
        self.probe_wait = TEAM_PROBE_FIRST
        self.step_s = 0.0          # mean wall time of a step in the last team launch [s]

    def workers(self, sim) -> int:
        """Workers of the next team launch: the team's size, or one while one timed faster."""
        return 1 if self.solo else sim._team_size()

    def spin_bound(self) -> int:
        """The bound of a team's wait, in tries: TEAM_WAIT_MIN, or TEAM_WAIT_STEPS mean step times
        of the last launch, whichever is longer.  A wait that long means another worker lost its
        core: a legitimate wait is for a unit another worker runs, a small share of a step."""
        return int(min(2**31 - 1, TEAM_SPINS_PER_S * max(TEAM_WAIT_MIN, TEAM_WAIT_STEPS * self.step_s)))

    def launch(self, sim, nsteps: int, nwork: int, flags: int, switches) -> int:
        """One team launch of ``nsteps`` steps; a launch that stopped at a stage boundary because a
        wait ran past its bound is resumed by one worker (the same bits).  Returns the kernel's
        result with the steps of every part."""
        t0, c0 = _time.perf_counter(), _time.process_time()
        args = (*sim._groups["team"], *switches)
        ret = sim._launch_cached("run_steps_blocks", kernels.run_steps_blocks, nsteps, nwork, flags,
                                 self.spin_bound(), *args)
        timed_out = bool(ret & kernels.TIMEOUT_BIT)
        self.stats["timeouts"] += timed_out
        done = 0
        while ret & kernels.ABORT_BIT:
            self.stats["resumed"] += 1
            done += ret & _STEPS
            ret = sim._launch_cached("run_steps_blocks", kernels.run_steps_blocks, nsteps - done, 1, flags | 2,
                                     self.spin_bound(), *args)
        steps = done + (ret & _STEPS)
        ret = (ret & ~_STEPS & ~kernels.TIMEOUT_BIT) | steps
        wall = _time.perf_counter() - t0
        if steps:
            self.step_s = wall / steps
        # a wait past its bound, or workers that did not get their cores (a spinning worker
        # counts as busy: only a descheduled one lowers the share): time the two again now
        starved = wall > 5e-3 and _time.process_time() - c0 < TEAM_CPU_SHARE * nwork * wall
        if nwork > 1 and (timed_out or starved) and self.probe_at > t0:
            self.probe_at = t0
        return ret

    def choose(self, sim, nwork: int, chunk: int, flags: int, switches) -> tuple[int, int]:
        """When a probe is due (TEAM_PROBE_FIRST seconds after the first team launch, then twice as
        long after each probe that agrees with the choice, up to TEAM_PROBE_MAX; at once after a
        wait past its bound or a launch whose workers lacked their cores), time a short launch of one worker and one of the team, and run on
        with the faster: a team on a CPU shared with other busy processes waits for its
        descheduled workers.  Returns (steps the probes ran, the kernel's last result)."""
        now = _time.perf_counter()
        if self.probe_at == 0.0:
            self.probe_at = now + TEAM_PROBE_FIRST      # (the first launch compiles)
            return 0, 0
        if now < self.probe_at or chunk < 2 * TEAM_PROBE_STEPS:
            return 0, 0
        steps = max(1, chunk // TEAM_PROBE_STEPS)
        rates, done, ret = {}, 0, 0
        for workers in (1, nwork):
            t0 = _time.perf_counter()
            ret = self.launch(sim, steps, workers, flags, switches)
            k = ret & _STEPS
            done += k
            rates[workers] = k / max(_time.perf_counter() - t0, 1e-9)
            if ret & (kernels.UNSTABLE_BIT | kernels.DUE_BIT) or k < steps:
                return done, ret
        self.stats["probes"] += 1
        solo = rates[1] > rates[nwork]
        self.probe_wait = min(TEAM_PROBE_MAX, 2.0 * self.probe_wait) if solo == self.solo else TEAM_PROBE_FIRST
        self.solo = solo
        self.probe_at = _time.perf_counter() + self.probe_wait
        return done, ret

    def run(self, sim, n: int, due: bool, switches) -> None:
        """Advance ``sim`` by ``n`` steps in team launches of at most ``sim.steps_per_launch()``
        steps; small scenes detect inside the launch (the serial task of ``Simulation._detect``),
        large ones return to the host for the parallel broad phase."""
        per_launch = sim.steps_per_launch()
        flags = int(sim._detect_serially())
        while n > 0:
            if due:
                sim._detect()
            chunk = min(n, per_launch)
            size = sim._team_size()
            ret = 0
            if size > 1:
                done, ret = self.choose(sim, size, chunk, flags, switches)
                sim.step_count += done
                n -= done
                chunk -= done
            if chunk > 0 and not ret & (kernels.UNSTABLE_BIT | kernels.DUE_BIT):
                nwork = self.workers(sim)
                ret = self.launch(sim, chunk, nwork, flags, switches)
                if nwork == 1:
                    self.stats["solo_steps"] += ret & _STEPS
                sim.step_count += ret & _STEPS
                n -= ret & _STEPS
            due = bool(sim.model.contact and ret & kernels.DUE_BIT)
            if ret & kernels.UNSTABLE_BIT:
                guards.raise_unstable(sim)

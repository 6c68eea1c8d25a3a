"""How the parallel strategy runs its team launches on the CPU (:mod:`taichi_fdem.engine.team`):
the bound of a wait, resumption after a wait past it, and the choice between the team and one
worker on a shared CPU.  Every choice here changes the speed, never the bits.

The choice reads two counters of the operating system, never a timed trial launch:

* after a team launch (the first ones, and the first after one worker ran, short:
  :data:`TEAM_TRIAL_S`), the CPU time the process got: below :data:`TEAM_CPU_SHARE` of its
  workers' wall time (a spinning worker counts as busy, so only a descheduled one lowers it),
  or a wait past its bound, means another busy process shares the cores, and one worker runs on;
* while one worker runs, the idle time of the process's other usable cores (Linux
  ``/proc/stat``): when they were idle for :data:`TEAM_IDLE_SHARE` of the time, the team runs
  again.  Where the idle times cannot be read, the team is tried again after
  :data:`TEAM_RETRY_FIRST` seconds, twice as long after each try that failed, up to
  :data:`TEAM_RETRY_MAX`; the same back-off delays a return after a failed one everywhere.
"""
from __future__ import annotations

import os
import time as _time

from ..engine import step as kernels
from . import guards

TEAM_WAIT_MIN = 0.02             # a team's wait is bounded by this [s], or by TEAM_WAIT_STEPS of its steps
TEAM_WAIT_STEPS = 8.0            # (mean step times of the last launch), whichever is longer
TEAM_SPINS_PER_S = 5e7           # tries of a team's wait per second (an i32 atomic read each)
TEAM_CPU_SHARE = 0.85            # a team launch whose workers got less CPU time than this share of their
                                 # wall time was descheduled: one worker runs on
TEAM_IDLE_SHARE = 0.75           # one worker returns to the team when the other usable cores were idle
                                 # this share of its wall time
TEAM_JUDGE_S = 0.05              # a verdict needs launches that span this long [s] (added up)
TEAM_TRIAL_S = 0.1               # a team's first launches, and its first after one worker ran, last about this
                                 # long [s] until one is judged
TEAM_RETRY_FIRST = 1.0           # the least time one worker runs after a team launch was descheduled [s],
TEAM_RETRY_MAX = 16.0            # twice as long after each return that failed, up to this [s]

_STEPS = kernels.UNSTABLE_BIT - 1    # the steps in a launch's result


def idle_seconds(cpus=None) -> float | None:
    """Idle time [s] (idle + iowait) of the CPUs ``cpus`` (default: this process's affinity set)
    since boot, from Linux ``/proc/stat``; None where it cannot be read."""
    try:
        cpus = os.sched_getaffinity(0) if cpus is None else cpus
        tick = os.sysconf("SC_CLK_TCK")
        total = 0
        with open("/proc/stat") as f:
            for line in f:
                if line.startswith("cpu") and line[3].isdigit():
                    name, *vals = line.split()
                    if int(name[3:]) in cpus:
                        total += int(vals[3]) + int(vals[4])
        return total / tick
    except (OSError, AttributeError, ValueError, IndexError):
        return None


class TeamScheduler:
    """The team launches of one simulation (module docstring).

    ``stats``: waits that ran past their bound (``timeouts``), launches resumed by one worker
    after one (``resumed``), switches from the team to one worker (``to_solo``) and back
    (``to_team``), and steps run by one worker (``solo_steps``); ``Simulation.info()["team"]``.
    """

    def __init__(self):
        self.stats = {"timeouts": 0, "resumed": 0, "to_solo": 0, "to_team": 0, "solo_steps": 0}
        self.solo = False          # one worker runs: the team's workers were descheduled
        self.retry_wait = TEAM_RETRY_FIRST
        self.retry_at = 0.0        # perf_counter time before which the team is not tried again
        self.warm = False          # a team launch has run (the first one compiles: not judged)
        self.trial = True          # no team launch judged since the team (re)started: short launches
        self.span_wall = 0.0       # wall time of the launches since the last verdict [s], and their
        self.span_x = 0.0          # CPU time (team) or the other cores' idle time (one worker) [s]
        self.step_s = 0.0          # mean wall time of a step in the last launch [s]

    def workers(self, sim) -> int:
        """Workers of the next team launch: the team's size, or one on a shared CPU."""
        return 1 if self.solo else sim._team_size()

    def spin_bound(self) -> int:
        """The bound of a team's wait, in tries: TEAM_WAIT_MIN, or TEAM_WAIT_STEPS mean step times
        of the last launch, whichever is longer.  A wait that long means another worker lost its
        core: a legitimate wait is for a unit another worker runs, a small share of a step."""
        return int(min(2**31 - 1, TEAM_SPINS_PER_S * max(TEAM_WAIT_MIN, TEAM_WAIT_STEPS * self.step_s)))

    def launch(self, sim, nsteps: int, nwork: int, flags: int, feat) -> int:
        """One team launch of ``nsteps`` steps; a launch that stopped at a stage boundary because a
        wait ran past its bound is resumed by one worker (the same bits).  Returns the kernel's
        result with the steps of every part, and judges the launch (:meth:`judge`)."""
        idle0 = idle_seconds() if nwork == 1 and self.solo else None
        t0, c0 = _time.perf_counter(), _time.process_time()
        args = (sim._packs["team"], feat)
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
        wall = _time.perf_counter() - t0
        if steps:
            self.step_s = wall / steps
        if nwork == 1:
            self.stats["solo_steps"] += steps
        self.judge(sim, nwork, wall, _time.process_time() - c0, timed_out, idle0)
        return (ret & ~_STEPS & ~kernels.TIMEOUT_BIT) | steps

    def judge(self, sim, nwork: int, wall: float, cpu: float, timed_out: bool, idle0) -> None:
        """Team or one worker for the next launches (module docstring), from the team's CPU time
        (``cpu`` [s] in this launch's ``wall`` [s]) and a wait past its bound, or from the idle
        time of the other usable cores while one worker ran (``idle0``: theirs before this
        launch).  Launches are added up until they span TEAM_JUDGE_S."""
        now = _time.perf_counter()
        if nwork > 1:
            if not self.warm:
                self.warm = True            # (this launch compiled)
                return
            self.span_wall += wall
            self.span_x += cpu
            if timed_out or (self.span_wall >= TEAM_JUDGE_S and self.span_x < TEAM_CPU_SHARE * nwork * self.span_wall):
                self.solo = True
                self.stats["to_solo"] += 1
                self.retry_at = now + self.retry_wait
                self.retry_wait = min(TEAM_RETRY_MAX, 2.0 * self.retry_wait)
            elif self.span_wall >= TEAM_JUDGE_S:
                self.trial = False
                self.retry_wait = TEAM_RETRY_FIRST
            else:
                return
            self.span_wall = self.span_x = 0.0
            return
        if not self.solo or sim._team_size() < 2:
            return
        idle1 = idle_seconds() if idle0 is not None else None
        if idle1 is not None:
            self.span_wall += wall
            self.span_x += idle1 - idle0
            if self.span_wall < TEAM_JUDGE_S:
                return
            free = self.span_x >= TEAM_IDLE_SHARE * (sim._team_size() - 1) * self.span_wall
            self.span_wall = self.span_x = 0.0
            if not free:
                return
        if now >= self.retry_at:
            self.solo, self.trial = False, True
            self.stats["to_team"] += 1
            self.span_wall = self.span_x = 0.0

    def launch_steps(self, nwork: int, most: int) -> int:
        """Steps of the next launch, at most ``most``: one for the first team launch (it compiles),
        then about TEAM_TRIAL_S of steps until a team launch is judged."""
        if nwork == 1 or not self.trial:
            return most
        if not self.warm:
            return 1
        return max(1, min(most, int(TEAM_TRIAL_S / max(self.step_s, 1e-9))))

    def run(self, sim, n: int, due: bool, feat) -> None:
        """Advance ``sim`` by ``n`` steps in team launches of at most ``sim.solver.steps_per_launch()``
        steps (:meth:`launch_steps`) with the compile-time features ``feat``; small scenes detect
        inside the launch (the serial broad phase), large ones return to the host for the parallel
        broad phase."""
        per_launch = sim.solver.steps_per_launch()
        flags = int(sim._detect_serially())
        while n > 0:
            if due:
                sim._detect()
            nwork = self.workers(sim)
            ret = self.launch(sim, self.launch_steps(nwork, min(n, per_launch)), nwork, flags, feat)
            sim.step_count += ret & _STEPS
            n -= ret & _STEPS
            due = bool(sim.model.contact and ret & kernels.DUE_BIT)
            if ret & kernels.UNSTABLE_BIT:
                guards.raise_unstable(sim)

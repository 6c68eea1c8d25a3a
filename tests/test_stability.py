"""Stress tests of numerical stability (issue 5), CI-sized: the automatic time step survives
forced steps, stiff penalties, fast impacts, slivers, many contacts at a node, a dense pile and a
fast spin; unstable runs stop early with a diagnosis and keep the last good state; the energy
drift of conservative runs is bounded.  The full-size table is benchmarks/stability.py → docs/stability.md."""
import math

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem import stability as S

SUITE = S.suite(quick=True)


@pytest.mark.parametrize("item", SUITE, ids=[f"{g}-{p}".replace(" ", "_") for g, p, _ in SUITE])
def test_stress_scenario(item):
    """Default settings (automatic dt, safety 0.2): stable, no inverted element, penetration
    below 10 % of the element size.  Forced steps above the limit: stopped early, with a cause."""
    group, param, make = item
    sim, duration, _ = make()
    r = S.stress_run(sim, duration)
    if sim.dt > sim.dt_limit and r["stable"]:
        # dt_limit is conservative (contact × 0.4 of the book's estimate, measured on the worst
        # case, face-on-face contact); a forced step up to ~2.5× it may still run stably
        assert sim.dt <= 2.5 * sim.dt_limit, r
        return
    if sim.dt > sim.dt_limit:
        assert not r["stable"], r
        assert r["kind"] in ("non-finite", "inverted", "speed", "energy", "penetration"), r
        assert r["step"] <= 100, r                       # within a few steps / the first check
        assert 0 < r["suggested_dt"] < sim.dt_limit
        return
    assert r["stable"], r
    assert not r["inverted"], r
    assert r["max_penetration"] < 0.1, r


def test_unstable_run_stops_with_diagnosis_and_keeps_the_last_good_state(tmp_path):
    sim, duration, _ = S.scenario_disks(dt_factor=4.0)
    with pytest.raises(fdem.SimulationError) as err:
        sim.run(duration, progress=False)
    e = err.value
    assert e.cause and 0 < e.step <= 100
    assert f"step {e.step}" in str(e) and "Suggested time step" in str(e)
    assert e.time == pytest.approx(e.step * sim.dt)
    assert 0 < e.suggested_dt < sim.dt_limit
    step = sim.restore_last_good()
    assert step < e.step and sim.step_count == step
    assert np.isfinite(sim.node_positions()).all() and np.isfinite(sim.node_velocities()).all()
    assert math.isfinite(sim.energies()["total"])
    if hasattr(sim, "save"):                                  # checkpoints (another issue)
        sim.save(str(tmp_path / "last_good"))


def test_energy_growth_is_detected():
    """Energy injected behind the solver's back (velocities doubled in a callback) is caught at
    the next check as energy growth; the state before it can be restored."""
    sim, duration, _ = S.scenario_disks(speed=1.0)
    ke0 = sim.energies()["kinetic"]
    calls = []

    def inject(s):
        calls.append(s.step_count)
        if len(calls) == 3:
            s.set_node_velocities(2.0 * s.node_velocities())

    with pytest.raises(fdem.SimulationError, match="energy growth") as err:
        sim.run(duration, callback=inject, frame_dt=duration / 20, progress=False)
    assert err.value.step > calls[2]
    assert sim.restore_last_good() <= calls[2]          # the last check before the injection
    assert sim.energies()["kinetic"] == pytest.approx(ke0, rel=0.05)


def test_penetration_bound_is_checked():
    """The same impact passes the default bound (50 % of the element size) but not a bound of
    0.2 % (the penalty contact does penetrate a little)."""
    sim, duration, _ = S.scenario_disks(speed=5.0, penalty_factor=1.0)
    r = S.stress_run(sim, duration)
    assert r["stable"] and 0.002 < r["max_penetration"] < 0.5
    sim, duration, _ = S.scenario_disks(speed=5.0, penalty_factor=1.0)
    with pytest.raises(fdem.SimulationError, match="penetration"):
        sim.run(duration, max_penetration=0.002, check_every=20, progress=False)


def test_run_check_options():
    sim, duration, _ = S.scenario_disks()
    with pytest.raises(RuntimeError, match="no good state"):
        sim.restore_last_good()
    with pytest.raises(ValueError, match="energy_tol"):
        sim.run(duration, energy_tol=0.0)
    with pytest.raises(ValueError, match="max_penetration"):
        sim.run(duration, max_penetration=-1.0)
    sim.run(duration, check_energy=False, max_penetration=None, progress=False)   # checks off
    assert sim.step_count > 0


@pytest.mark.parametrize("scenario, bound", [("disks", 0.01), ("spin", 5e-3)])
def test_energy_drift_of_conservative_runs_is_bounded(scenario, bound):
    """No damping, friction or fracture: the total energy stays within 1 % (impact, penalty
    contact) and 0.5 % (free spin at 0.3 c_p) of the energy scale."""
    if scenario == "disks":
        sim, duration, _ = S.scenario_disks(speed=2.0, offset=0.02)
    else:
        sim, duration, _ = S.scenario_spin(rim_fraction=0.3)
    assert not (sim.damping or sim.friction or sim.contact_damping)
    r = S.stress_run(sim, duration)
    assert r["stable"]
    assert r["energy_drift"] < bound, r

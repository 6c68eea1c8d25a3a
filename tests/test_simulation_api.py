"""The simulation's public surface: the validated time-step setter, read-only model values,
no silently ignored assignments, and the declared arrays of Model and State."""
import math

import numpy as np
import pytest

import taichi_fdem as fdem

ROCK = dict(density=2700.0, young=30e9, poisson=0.25)
G = -9.81


def _falling_disk(**build):
    scene = fdem.Scene(gravity=(0.0, G))
    scene.add_body(fdem.mesh.disk(radius=0.05, h=0.025), fdem.Material(**ROCK), position=(0.0, 0.2))
    return scene.build(strategy="serial", **build)


def _mean_velocity(sim):
    m = sim.node_masses()
    return (m[:, None] * sim.node_velocities()).sum(0) / m.sum()


def test_setting_dt_changes_the_integration_and_the_clock():
    """After ``sim.dt = dt / 2`` and 100 steps of free fall, the time is 100·dt/2 and the
    mass-weighted velocity g·100·dt/2 (internal forces cancel in the sum); the time then
    continues from there at the new step."""
    sim = _falling_disk()
    dt = sim.dt
    sim.dt = dt / 2
    assert sim.dt == dt / 2 and sim.model.dt == dt / 2 and sim.state.counters.dt == dt / 2
    sim.step(100)
    assert sim.time == pytest.approx(100 * dt / 2, rel=1e-14)
    np.testing.assert_allclose(_mean_velocity(sim), [0.0, G * 100 * dt / 2], rtol=1e-10, atol=1e-14)
    sim.dt = dt
    sim.step(10)
    assert sim.time == pytest.approx(100 * dt / 2 + 10 * dt, rel=1e-14)
    np.testing.assert_allclose(_mean_velocity(sim)[1], G * (50 + 10) * dt, rtol=1e-10)


def test_dt_is_checked_against_the_stable_limit():
    sim = _falling_disk()
    dt = sim.dt
    for bad in (0.0, -dt, math.inf, math.nan):
        with pytest.raises(ValueError, match="positive finite"):
            sim.dt = bad
    with pytest.raises(TypeError, match="number"):
        sim.dt = "fast"
    with pytest.raises(ValueError, match="stable limit.*force_dt"):
        sim.dt = 2 * sim.model.dt_limit
    assert sim.dt == dt and sim.state.counters.dt == dt            # a refused value changes nothing
    forced = _falling_disk(dt=0.5 * sim.model.dt_limit, force_dt=True)
    forced.dt = 2 * forced.model.dt_limit                                   # built with force_dt: accepted
    assert forced.state.counters.dt == 2 * forced.model.dt_limit


def test_model_values_are_read_only_and_other_names_raise():
    sim = _falling_disk()
    assert (sim.model.tri_count, sim.model.node_count, sim.model.dt_limit) == (sim.model.tri_count, sim.model.node_count,
                                                             sim.model.dt_limit)
    for name in ("tri_count", "buffer", "contact", "dt_limit"):
        with pytest.raises(AttributeError):
            setattr(sim, name, 1)
    for name, where in (("node_x", "state"), ("speed_limit", "model"), ("node_rest", "model")):
        with pytest.raises(AttributeError, match=f"sim.{where}.{name}"):
            setattr(sim, name, 1)
    with pytest.raises(AttributeError):
        sim._X                                                         # the old aliases are gone
    sim.my_note = "kept"                                               # a user's own attribute
    assert sim.my_note == "kept"


def test_restore_last_good_restores_the_time_step():
    sim = _falling_disk()
    dt = sim.dt
    sim.run(20 * dt, checks=fdem.Checks(every=10))
    sim.dt = dt / 4
    sim.step(8)
    assert sim.time == pytest.approx(22 * dt)
    sim.restore_last_good()
    assert sim.step_count == 20 and sim.dt == dt and sim.state.counters.dt == dt
    assert sim.time == pytest.approx(20 * dt)


def _scenes():
    """A plain body, and a fracturing block on a fixed base with a load and a prescribed
    velocity (contact, joints, loads, boundary conditions)."""
    rock = fdem.Material(**ROCK, friction=0.5, tensile_strength=5e6, fracture_energy=50.0)
    plain = fdem.Scene(gravity=(0.0, G))
    plain.add_body(fdem.mesh.disk(radius=0.05, h=0.03), rock)
    rich = fdem.Scene(gravity=(0.0, G))
    top = rich.add_body(fdem.mesh.rectangle(0.2, 0.1, 0.03), rock, position=(0.0, 0.2), fracture=True)
    rich.add_body(fdem.mesh.rectangle(0.5, 0.1, 0.05), rock, position=(0.0, 0.0), fixed=True)
    rich.apply_pressure(lambda x, y: y > 0.24, 1e5, body=top)
    return [plain.build(), rich.build()]


@pytest.mark.parametrize("which", [0, 1])
def test_every_array_is_declared_and_every_declared_array_allocated(which):
    """Model and State hold exactly the Taichi arrays of their declarations (and the Model
    exactly its declared NumPy arrays); each declared shape has as many axes as the array."""
    from taichi_fdem.sim.arrays import MODEL_ARRAYS, MODEL_HOST_ARRAYS, STATE_ARRAYS
    sim = _scenes()[which]
    import taichi as ti
    for obj, declared in ((sim.model, MODEL_ARRAYS), (sim.state, STATE_ARRAYS)):
        held = {k for k, v in vars(obj).items() if isinstance(v, ti.Ndarray)}
        assert held == set(declared), (f"{type(obj).__name__}: undeclared {sorted(held - set(declared))}, "
                                       f"not allocated {sorted(set(declared) - held)}")
        assert list(obj.ndarrays()) == list(declared)
        for name, spec in declared.items():
            axes = len(spec.shape)
            assert len(getattr(obj, name).shape) == axes, (name, spec.shape, getattr(obj, name).shape)
            assert spec.unit and spec.doc
    host = {k for k, v in vars(sim.model).items() if isinstance(v, np.ndarray)}
    assert host == set(MODEL_HOST_ARRAYS), sorted(host ^ set(MODEL_HOST_ARRAYS))

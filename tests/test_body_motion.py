"""Body kinematics (``Simulation.body_motion``), the torque-free impact of a symmetric disk and
exact zero reactions: checked against rigid-body mechanics and brute-force sums."""
from __future__ import annotations

import numpy as np
import pytest

import taichi_fdem as fdem

R = 0.05


def disk_on_floor(layout: str, speed: float = 1.0):
    scene = fdem.Scene(gravity=(0.0, 0.0))
    mat = fdem.Material(density=2000.0, young=1e8, poisson=0.25, friction=0.0)
    floor = scene.add_body(fdem.mesh.rectangle(0.4, 0.05, 0.02), mat, fixed=True, position=(0.0, -0.025))
    disk = scene.add_body(fdem.mesh.disk(R, R / 10, layout=layout), mat, position=(0.0, R + 0.002),
                          velocity=(0.0, -speed))
    return scene.build(), floor, disk


def test_rigid_motion_is_recovered_exactly():
    sim, floor, disk = disk_on_floor("spiral")
    x = sim.node_positions(disk)
    m = sim.node_masses(disk)
    c = (m[:, None] * x).sum(0) / m.sum()
    v0, omega = np.array([0.3, -0.7]), 4.0
    v = v0 + omega * np.stack([-(x[:, 1] - c[1]), x[:, 0] - c[0]], axis=1)
    sim.set_node_velocities(v, body=disk)
    bm = sim.body_motion(disk)
    inertia = float((m * ((x - c) ** 2).sum(1)).sum())
    assert bm.mass == pytest.approx(m.sum(), rel=1e-15)
    np.testing.assert_allclose(bm.center, c, rtol=1e-14)
    np.testing.assert_allclose(bm.velocity, v0, rtol=1e-12)
    assert bm.angular_velocity == pytest.approx(omega, rel=1e-12)
    assert bm.inertia == pytest.approx(inertia, rel=1e-14)
    # the lumped-mass inertia of the meshed disk is close to the solid disk's M R^2 / 2
    assert bm.inertia == pytest.approx(0.5 * bm.mass * R * R, rel=0.05)
    assert bm.translational_energy == pytest.approx(0.5 * m.sum() * (v0 @ v0), rel=1e-12)
    assert bm.rotational_energy == pytest.approx(0.5 * inertia * omega ** 2, rel=1e-12)
    assert bm.kinetic_energy == pytest.approx(0.5 * float((m * (v * v).sum(1)).sum()), rel=1e-14)
    assert bm.vibrational_energy <= 1e-12 * bm.kinetic_energy
    # a body index names the same body; a foreign object raises
    assert sim.body_motion(disk.index).mass == bm.mass
    with pytest.raises(ValueError, match="body"):
        sim.body_motion("disk")


def test_energy_split_adds_up_for_a_deforming_body():
    sim, floor, disk = disk_on_floor("spiral")
    rng = np.random.default_rng(3)
    n = len(sim.node_masses(disk))
    sim.set_node_velocities(rng.normal(size=(n, 2)), body=disk)
    bm = sim.body_motion(disk)
    total = bm.translational_energy + bm.rotational_energy + bm.vibrational_energy
    assert total == pytest.approx(bm.kinetic_energy, rel=1e-12)
    assert bm.vibrational_energy > 0.5 * bm.kinetic_energy


def test_frictionless_normal_impact_of_a_symmetric_disk_does_not_spin_it():
    omega_r = {}
    for layout in ("symmetric", "spiral"):
        sim, floor, disk = disk_on_floor(layout)
        sim.run(0.006, progress=False)          # contact at ~2 ms, the disk has left by 6 ms
        bm = sim.body_motion(disk)
        assert bm.velocity[1] > 0.9             # rebounded (elastic, undamped)
        omega_r[layout] = bm.angular_velocity * R
    # the mirror-symmetric mesh: no torque, spin at round-off; the spiral layout spins
    assert abs(omega_r["symmetric"]) < 1e-12
    assert abs(omega_r["spiral"]) > 1e-4


def test_reaction_of_an_untouched_fixed_body_is_exactly_zero():
    sim, floor, disk = disk_on_floor("symmetric")
    sim.step(50)                                # the disk has not reached the floor yet
    assert sim.reaction(floor).tolist() == [0.0, 0.0]
    sim.run(0.003, progress=False)              # in contact now
    assert sim.reaction(floor)[1] > 1.0          # holds the floor up against the disk

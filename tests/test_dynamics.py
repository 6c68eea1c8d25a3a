"""Rigid-body and collision dynamics (docs/theory/elements.md §6.1, §8.2, §8.4): free fall, elastic impact of
two disks, a block sliding and stopping under Coulomb friction, a block on an incline."""

import numpy as np
import pytest

import taichi_fdem as fdem
from conftest import mass_centroid
from taichi_fdem import verification as V

E = 1.0e7
RHO = 1000.0
G = 9.81


def rigid_kinetic_energy(sim, body):
    """Kinetic energy of the body's rigid motion: ½ M v_c² + ½ L²/I about its centroid."""
    m = sim.node_masses(body)
    x, v = sim.node_positions(body), sim.node_velocities(body)
    xc, vc = mass_centroid(sim, body)
    r, u = x - xc, v - vc
    I = np.sum(m * (r ** 2).sum(1))
    L = np.sum(m * (r[:, 0] * u[:, 1] - r[:, 1] * u[:, 0]))
    return 0.5 * m.sum() * vc @ vc + 0.5 * L * L / I


# ------------------------------------------------------------------------------------------------
def test_free_fall_matches_the_discrete_and_continuous_parabola():
    """Constant acceleration: with v stored at half steps (v_{-1/2} = v0) the scheme gives
    exactly y_n = y0 + v0 n Δt − g Δt² n(n+1)/2 = y0 + v0 t − ½ g t² − ½ g Δt t."""
    mat = fdem.Material(density=RHO, young=E, poisson=0.3)
    scene = fdem.Scene(gravity=(0.0, -G))
    v0 = np.array([0.3, 2.0])
    body = scene.add_body(fdem.mesh.disk(0.05, 0.02), mat, position=(0.0, 1.0), velocity=v0)
    sim = scene.build()
    c0, _ = mass_centroid(sim, body)
    n = 0
    for chunk in (1, 9, 90, 900):
        sim.step(chunk)
        n += chunk
        dt, t = sim.dt, sim.time
        assert t == pytest.approx(n * dt, rel=1e-15)
        c, vc = mass_centroid(sim, body)
        y_discrete = c0[1] + v0[1] * n * dt - G * dt * dt * n * (n + 1) / 2
        y_continuous = c0[1] + v0[1] * t - 0.5 * G * t * t
        drop = abs(y_discrete - c0[1]) + abs(v0[1] * t)
        tol = 1e-12 * (abs(c0[1]) + drop)
        assert c[1] == pytest.approx(y_discrete, abs=tol)                      # exact to round-off
        assert abs(c[1] - y_continuous) == pytest.approx(0.5 * G * dt * t, rel=1e-6)  # the half-step lag
        assert c[0] == pytest.approx(c0[0] + v0[0] * t, abs=tol)
        assert vc[1] == pytest.approx(v0[1] - G * n * dt, abs=1e-12 * abs(v0[1]))
        # a uniformly accelerated body does not deform
        assert np.abs(sim.stresses()).max() < 1e-9 * E
    e = sim.energies()
    e0_total = 0.5 * sim.node_masses().sum() * (v0 @ v0) + sim.node_masses().sum() * G * c0[1]
    assert e["total"] == pytest.approx(e0_total, rel=1e-3)   # O(Δt) half-step kinetic-energy offset


def two_disks(offset=0.0, safety=0.2, strategy="auto"):
    """Two equal elastic disks (radius 5 cm, h = 2 cm) approaching at ±2 m/s along x
    (verification.two_disks_scene: B mirrored, so a head-on contact is symmetric); ``offset``
    shifts them ±offset in y."""
    v = 2.0
    sim, a, b = V.two_disks_scene(0.05, 0.02, (v, 0.0), (-v, 0.0), offset=offset,
                                  material=dict(density=RHO, young=E, poisson=0.25), safety=safety, strategy=strategy)
    return sim, a, b, v


def momentum(sim):
    m = sim.node_masses()
    x, v = sim.node_positions(), sim.node_velocities()
    return (m[:, None] * v).sum(0), float(np.sum(m * (x[:, 0] * v[:, 1] - x[:, 1] * v[:, 0])))


def test_head_on_elastic_impact_of_two_disks():
    """§8.4: momentum conserved to round-off; after separation the rigid-body kinetic energy is
    ≥ 90 % of the initial one (the rest is vibration), kinetic + strain + contact energy within
    1 %, and the disks have exchanged their velocities (within 5 % of |v|)."""
    sim, a, b, v = two_disks()
    M = sim.node_masses(a).sum()
    e0 = sim.energies()
    assert e0["kinetic"] == pytest.approx(M * v * v, rel=1e-12)
    _, va0 = mass_centroid(sim, a)
    _, vb0 = mass_centroid(sim, b)
    touched = False
    worst_p = worst_e = 0.0
    for _ in range(30):
        sim.step(50)
        p, _ = momentum(sim)
        worst_p = max(worst_p, np.abs(p).max() / (M * v))
        e = sim.energies()
        worst_e = max(worst_e, abs(e["kinetic"] + e["strain"] + e["contact"] - e0["total"]) / e0["total"])
        touched |= e["contact"] > 0
    assert touched
    assert e["contact"] == 0.0                   # separated
    assert worst_p < 1e-12                       # |Σ m v| / (M v) throughout
    assert worst_e < 0.01                        # energy within 1 % throughout
    _, va = mass_centroid(sim, a)
    _, vb = mass_centroid(sim, b)
    rigid = rigid_kinetic_energy(sim, a) + rigid_kinetic_energy(sim, b)
    assert rigid >= 0.9 * e0["kinetic"]
    assert np.linalg.norm(va - vb0) < 0.05 * v
    assert np.linalg.norm(vb - va0) < 0.05 * v
    # restitution: e = −(v_b' − v_a')·n / ((v_b − v_a)·n), with the vibration energy left out
    restitution = -(vb[0] - va[0]) / (vb0[0] - va0[0])
    assert 0.9 < restitution <= 1.0
    assert va[0] < 0.0 < vb[0]


def test_oblique_impact_conserves_linear_and_angular_momentum():
    """Off-centre impact (the disks spin up and are deflected): linear and angular momentum are
    conserved to round-off (§8.4), since each couple's forces have zero sum and zero moment."""
    sim, a, b, v = two_disks(offset=0.03)
    M = sim.node_masses(a).sum()
    p0, L0 = momentum(sim)
    assert abs(L0) > 0.01 * M * v * 0.05
    for _ in range(10):
        sim.step(100)
        p, L = momentum(sim)
        assert np.abs(p - p0).max() < 1e-12 * M * v
        assert abs(L - L0) < 1e-12 * M * v * 0.1          # relative to M·|v|·(size of the scene)
    _, va = mass_centroid(sim, a)
    assert abs(va[1]) > 0.05 * v                            # really deflected
    assert sim.solver.detection_count >= 2


# ------------------------------------------------------------------------------------------------
MU = 0.3


def block_on_floor(gravity, v0=0.0):
    """A 0.1 × 0.05 m block (h = 0.025) resting exactly on a fixed floor (top at y = 0), μ = 0.3.

    Element damping (β = 0.2) and contact damping (ξ = 0.5) remove the vibrations of the
    penalty contact, so that the normal force equals the weight."""
    mat = fdem.Material(density=RHO, young=E, poisson=0.25, friction=MU, damping=0.2, contact_damping=0.5)
    scene = fdem.Scene(gravity=gravity)
    floor = scene.add_body(fdem.mesh.rectangle(0.6, 0.05, 0.025, origin=(-0.1, -0.05)), mat, fixed=True)
    block = scene.add_body(fdem.mesh.rectangle(0.1, 0.05, 0.025, origin=(-0.05, 0.0)), mat, velocity=(v0, 0.0))
    sim = scene.build(safety=0.25)
    assert sim.model.friction and sim.model.contact_damping and sim.model.damping
    return sim, floor, block


def test_block_sliding_stops_after_coulomb_distance():
    """§8.2: a block launched at v0 = 0.5 m/s on a horizontal floor decelerates at μg and
    stops after v0²/(2μg) at t = v0/(μg) (accept 2 %), then stays put (static friction).
    The energy account kinetic + strain + contact + gravity + dissipated (friction, damping,
    contact damping) stays constant within 1 % of the initial kinetic energy."""
    v0 = 0.5
    sim, floor, block = block_on_floor((0.0, -G), v0)
    c0, _ = mass_centroid(sim, block)
    e0 = sim.energies()
    ke0 = 0.5 * sim.node_masses(block).sum() * v0 * v0
    assert e0["kinetic"] == pytest.approx(ke0, rel=1e-12)
    t_stop = x_stop = None
    prev = (0.0, 0.0, v0)
    worst_e = 0.0
    while sim.time < 0.24:
        sim.step(100)
        c, vc = mass_centroid(sim, block)
        e = sim.energies()
        worst_e = max(worst_e, abs(e["total"] - e0["total"]) / ke0)
        if t_stop is None and vc[0] < 0.01 * v0:
            t0, x0, u0 = prev
            s = (u0 - 0.01 * v0) / (u0 - vc[0])                 # interpolate inside the chunk
            t_stop = t0 + s * (sim.time - t0)
            x_stop = x0 + s * (c[0] - c0[0] - x0)
        prev = (sim.time, c[0] - c0[0], vc[0])
    assert t_stop is not None
    assert x_stop == pytest.approx(v0 ** 2 / (2 * MU * G), rel=0.02)
    assert t_stop == pytest.approx(0.99 * v0 / (MU * G), rel=0.02)
    assert worst_e < 0.01
    assert e["friction"] == pytest.approx(ke0, rel=0.05)            # friction took the kinetic energy
    c_end, v_end = mass_centroid(sim, block)
    assert np.linalg.norm(v_end) < 1e-3 * v0                          # at rest, sticking
    assert c_end[0] - c0[0] == pytest.approx(x_stop, abs=0.02 * x_stop)
    assert abs(c_end[1] - c0[1]) < 1e-4                                # it neither sank nor jumped
    assert np.abs(sim.node_displacements(floor)).max() == 0.0         # the floor is fixed


# the block on an incline (§8.2) is verification.case_incline: tests/test_verification.py

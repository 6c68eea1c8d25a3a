"""'Skip what a scene doesn't need': features compiled in or out per scene, and the two
execution strategies giving the same answer."""
import numpy as np
import pytest

import taichi_fdem as fdem
from conftest import mass_centroid
from taichi_fdem.mesh import TriMesh

MAT = fdem.Material(density=1000.0, young=1e7, poisson=0.25)
CONTACT_KERNELS = ("detect_count", "detect_fill", "eval_contact")


@pytest.mark.parametrize("strategy", ["serial", "parallel"])
def test_single_body_never_runs_contact(strategy):
    scene = fdem.Scene(gravity=(0.0, -9.81))
    scene.add_body(fdem.mesh.disk(0.1, 0.03), MAT, angular_velocity=3.0)
    sim = scene.build(strategy=strategy)
    assert sim.model.contact is False
    assert sim.info()["contact"] is False
    assert sim.model.friction is False and sim.model.contact_damping is False and sim.model.damping is False
    sim.step(50)
    sim.forces()
    sim.energies()
    assert not any(k in sim.solver.launches for k in CONTACT_KERNELS), sim.solver.launches
    assert sim.solver.detection_count == 0
    assert sim.solver.couple_count == 0
    assert len(sim.couples()) == 0
    assert sim.step_count == 50


def test_single_body_with_self_contact_does_detect():
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.4, 0.1, 0.05), MAT, self_contact=True)
    # a buffer above the element size (0.05 m), so that triangles of the body at rest are within
    # reach of each other (with the default, 1/4 of an edge, they all lie beyond an edge line)
    sim = scene.build(buffer=0.06)
    assert sim.model.contact is True
    assert sim.solver.detection_count >= 1
    # self-contact couples exist (triangles of the same body near each other) and never join
    # triangles that share a node
    t = np.asarray(sim.scene.bodies[0].mesh.triangles)
    couples = sim.couples()
    assert len(couples) > 0
    for a, b in couples:
        assert not set(t[a]) & set(t[b])


def two_blocks(friction_a=0.0, friction_b=0.0, damping=0.0, contact_damping=0.0):
    ma = MAT.with_(friction=friction_a, damping=damping, contact_damping=contact_damping)
    mb = MAT.with_(friction=friction_b, damping=damping, contact_damping=contact_damping)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05, origin=(0.0, 0.0)), ma)
    scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05, origin=(0.12, 0.0)), mb, velocity=(-1.0, 0.0))
    return scene


def test_feature_flags_follow_the_materials():
    sim = two_blocks().build()
    assert sim.model.contact and not sim.model.friction and not sim.model.damping and not sim.model.contact_damping
    assert sim.solver.detection_count >= 1
    info = sim.info()
    assert info["contact"] is True and info["friction"] is False and info["damping"] is False
    sim_f = two_blocks(friction_a=0.4, friction_b=0.5).build()
    assert sim_f.model.friction and sim_f.info()["friction"] is True
    sim_d = two_blocks(damping=0.3).build()
    assert sim_d.model.damping and not sim_d.model.friction
    sim_c = two_blocks(contact_damping=0.2).build()
    assert sim_c.model.contact_damping and not sim_c.model.damping


def test_zero_friction_interaction_overrides_material_friction():
    rock = MAT.with_(friction=0.6, name="rock")
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05, origin=(0.0, 0.0)), rock)
    scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05, origin=(0.12, 0.0)), rock)
    assert scene.build().model.friction
    scene.set_interaction(rock, rock, friction=0.0)
    assert scene.build().model.friction is False


def test_two_bodies_detect_and_collide():
    sim = two_blocks().build()
    d0 = sim.solver.detection_count
    assert d0 >= 1
    sim.step(2000)
    assert sim.solver.detection_count > d0
    # the build-time detection: one serial task for a scene this small (detect_serial), the
    # parallel count-and-fill kernels otherwise
    assert sim.solver.launches.get("detect_serial", 0) + sim.solver.launches.get("detect_count", 0) >= 1
    b0, b1 = sim.bodies
    _, v1 = mass_centroid(sim, b1)
    _, v0 = mass_centroid(sim, b0)
    # equal blocks, head on, elastic: apart again (no contact energy), momentum conserved to
    # round-off (v0 + v1 = −1 m/s), total energy within 1 %, and the velocities nearly exchanged:
    # restitution of the rigid motions e = v1 − v0 (−1 m/s before) between 0.8 and 1 (the rest
    # of the energy rings in the blocks as vibration)
    e = sim.energies()
    assert e["contact"] == 0.0
    assert v0[0] + v1[0] == pytest.approx(-1.0, abs=1e-12)
    e0 = 0.5 * sim.node_masses(b1).sum() * 1.0 ** 2
    assert e["kinetic"] + e["strain"] == pytest.approx(e0, rel=0.01)
    assert 0.8 < v1[0] - v0[0] <= 1.0
    assert v0[0] < -0.9                          # the first block took ≥ 90 % of the momentum


def small_collision(strategy):
    """Two mirror-image disks hitting off-centre, with friction and contact damping on."""
    mat = MAT.with_(friction=0.3, contact_damping=0.1)
    d = fdem.mesh.disk(0.05, 0.02)
    scene = fdem.Scene(gravity=(0.0, -9.81))
    scene.add_body(d, mat, position=(-0.053, -0.01), velocity=(2.0, 0.0))
    scene.add_body(TriMesh(d.points * np.array([-1.0, 1.0]), d.triangles), mat, position=(0.053, 0.01),
                   velocity=(-2.0, 0.5), angular_velocity=5.0)
    return scene.build(strategy=strategy)


def test_serial_and_parallel_strategies_give_the_same_trajectory():
    """Both strategies run the same physics; only the floating-point order of the atomic
    scatter differs, so the trajectories agree to 1e-9 relative."""
    sims = {s: small_collision(s) for s in ("serial", "parallel")}
    assert sims["serial"].dt == sims["parallel"].dt
    for _ in range(6):
        for sim in sims.values():
            sim.step(150)
        xs, xp = (s.node_positions() for s in sims.values())
        vs, vp = (s.node_velocities() for s in sims.values())
        disp = np.abs(sims["serial"].node_displacements()).max()
        assert np.abs(xs - xp).max() < 1e-9 * disp
        assert np.abs(vs - vp).max() < 1e-9 * np.abs(vs).max()
        assert sims["serial"].solver.detection_count == sims["parallel"].solver.detection_count
        assert {tuple(c) for c in sims["serial"].couples()} == {tuple(c) for c in sims["parallel"].couples()}
    es, ep = (s.energies() for s in sims.values())
    assert es["friction"] > 0 and es["contact_damping"] > 0          # the features were exercised
    for key in ("kinetic", "strain", "friction", "contact_damping", "total"):
        assert es[key] == pytest.approx(ep[key], rel=1e-9, abs=1e-12 * abs(es["kinetic"]))


def test_switching_strategy_and_profile_keep_the_trajectory():
    """Changing ``sim.solver.strategy`` between calls, or advancing with ``profile()`` (one launch per
    phase), continues the same trajectory as plain serial stepping (to 1e-9 relative)."""
    ref = small_collision("serial")
    mixed = small_collision("serial")
    ref.step(900)
    mixed.step(300)
    mixed.solver.strategy = "parallel"
    mixed.step(300)
    timings = mixed.solver.profile(150)
    assert timings["steps"] == 150
    mixed.solver.strategy = "serial"
    mixed.step(150)
    assert mixed.step_count == ref.step_count == 900
    disp = np.abs(ref.node_displacements()).max()
    assert np.abs(mixed.node_positions() - ref.node_positions()).max() < 1e-9 * disp
    assert np.abs(mixed.node_velocities() - ref.node_velocities()).max() < 1e-9 * np.abs(ref.node_velocities()).max()
    assert mixed.solver.detection_count == ref.solver.detection_count


def test_thickness_scales_reported_quantities_only():
    """The solver works per unit thickness: the trajectory does not depend on the thickness t,
    while masses, forces and energies are reported × t."""
    def build(t):
        scene = fdem.Scene(gravity=(0.0, -9.81), thickness=t)
        scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05, origin=(0.0, 0.0)), MAT)
        scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05, origin=(0.105, 0.0)), MAT, velocity=(-1.0, 0.2))
        sim = scene.build()
        sim.step(400)
        return sim

    one, quarter = build(1.0), build(0.25)
    assert np.array_equal(one.node_positions(), quarter.node_positions())
    assert np.allclose(quarter.node_masses(), 0.25 * one.node_masses(), rtol=1e-15, atol=0)
    assert one.node_masses().sum() == pytest.approx(1000.0 * 0.02, rel=1e-14)
    f1, f4 = one.forces(), quarter.forces()
    assert np.abs(f1).max() > 0
    assert np.allclose(f4, 0.25 * f1, rtol=1e-14, atol=1e-14 * np.abs(f1).max())
    e1, e4 = one.energies(), quarter.energies()
    for key, value in e1.items():
        assert e4[key] == pytest.approx(0.25 * value, rel=1e-12, abs=1e-15), key


def test_set_node_velocities_and_run():
    scene = fdem.Scene(gravity=(0.0, 0.0))
    a = scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05, origin=(0.0, 0.0)), MAT)
    b = scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05, origin=(0.5, 0.0)), MAT)
    sim = scene.build()
    sim.set_node_velocities(np.array([0.0, 1.5]), body=b)
    assert np.all(sim.node_velocities(b) == [0.0, 1.5])
    assert np.all(sim.node_velocities(a) == 0.0)
    duration = 0.01
    sim.run(duration)
    assert sim.step_count == int(round(duration / sim.dt))
    assert sim.time == pytest.approx(sim.step_count * sim.dt, rel=1e-15)
    assert np.allclose(sim.node_displacements(b)[:, 1], 1.5 * sim.time, rtol=1e-12, atol=0)
    assert np.abs(sim.node_displacements(a)).max() == 0.0
    assert np.array_equal(sim.node_positions(1), sim.node_positions(b))      # a body by index
    assert sim.stresses(b).shape == (b.mesh.triangle_count, 2, 2)


# ------------------------------------------------------------------------------------------------
# README "Defaults and why": couple properties and the contact buffer
# ------------------------------------------------------------------------------------------------
def _pressed_blocks(mat_a, mat_b, steps=300):
    """Block B (0.1 m) pressed into and sliding over block A: B starts overlapping A by 1 mm and
    moving at (1, −0.2) m/s.  Returns the simulation after ``steps`` steps at a fixed dt."""
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.3, 0.1, 0.05, origin=(-0.15, -0.1)), mat_a, fixed=True)
    scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05, origin=(-0.05, -0.001)), mat_b, velocity=(1.0, -0.2))
    import warnings
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="bodies overlap", category=RuntimeWarning)
        sim = scene.build(dt=2e-6)
    sim.step(steps)
    return sim


def test_couple_penalty_and_friction_are_the_smaller_of_the_two_materials():
    """README: a couple uses the smaller of its two materials' penalty and friction coefficient.
    Materials (p = 10·E, μ = 0.6) and (p = 30·E, μ = 0.2) give bit-identical contact forces and
    trajectory to both bodies made of (p = 10·E, μ = 0.2), in either order, and differ from
    (p = 30·E, μ = 0.6) and from (p = 10·E, μ = 0.6)."""
    soft_rough = MAT.with_(penalty=10 * MAT.young, friction=0.6)
    stiff_smooth = MAT.with_(penalty=30 * MAT.young, friction=0.2)
    low = MAT.with_(penalty=10 * MAT.young, friction=0.2)
    ref = _pressed_blocks(low, low)
    assert ref.energies()["friction"] > 0                    # it slid: friction was exercised
    for a, b in ((soft_rough, stiff_smooth), (stiff_smooth, soft_rough)):
        sim = _pressed_blocks(a, b)
        np.testing.assert_array_equal(sim.forces(contact_only=True), ref.forces(contact_only=True))
        np.testing.assert_array_equal(sim.node_positions(), ref.node_positions())
    for other in (MAT.with_(penalty=30 * MAT.young, friction=0.6), MAT.with_(penalty=10 * MAT.young, friction=0.6)):
        sim = _pressed_blocks(other, other)
        assert np.abs(sim.node_positions() - ref.node_positions()).max() > 1e-9


def test_contact_buffer_is_a_quarter_of_the_mean_edge_length():
    """README: buffer b = ¼ × the mean edge length of the contact triangles.  Two 0.1 m squares
    meshed at h = 0.05 (every triangle touches the surface): right-angled triangles with edges
    h, h, h√2, so b = ¼ h (2 + √2)/3, by hand."""
    sim = two_blocks().build()
    h = 0.05
    assert sim.model.buffer == pytest.approx(0.25 * h * (2 + 2 ** 0.5) / 3, rel=1e-12)
    assert sim.info()["buffer"] == sim.model.buffer

"""Input validation and failure reporting: clear errors that name the offending input."""
import math
import warnings

import numpy as np
import pytest

import taichi_fdem as fdem
from conftest import one_triangle, twice_area
from taichi_fdem.mesh import TriMesh

MAT = fdem.Material(density=1000.0, young=1e6, poisson=0.25)


# ------------------------------------------------------------------------------------------------
# meshes
# ------------------------------------------------------------------------------------------------
def test_clockwise_triangle_is_reoriented_and_simulates():
    cw = np.array([[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]])
    assert twice_area(cw) < 0
    mesh = one_triangle(cw)
    assert twice_area(mesh.points[mesh.triangles[0]]) == pytest.approx(1.0)   # now CCW
    scene = fdem.Scene(gravity=(0.0, 0.0))
    body = scene.add_body(mesh, MAT)
    sim = scene.build()
    assert sim.node_masses(body).sum() == pytest.approx(1000.0 * 0.5, rel=1e-14)   # ρ A, positive
    # a stretched CW-input triangle pulls back (a reversed triangle would push further out)
    x = sim.node_positions()
    sim.state.node_x.from_numpy(x * 1.01)
    f = sim.forces()
    assert np.all(np.sum(f * (x - x.mean(0)), axis=1) < 0)


def test_clockwise_contactor_is_repulsive():
    """§9.1: a CW triangle given to the scene must still push an overlapping triangle away."""
    scene = fdem.Scene(gravity=(0.0, 0.0))
    a = scene.add_body(one_triangle([[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]]), MAT)            # CW input
    b = scene.add_body(one_triangle([[0.9, 0.9], [0.2, 0.5], [0.6, 0.1]]), MAT)            # CW input
    with pytest.warns(RuntimeWarning, match="overlap"):
        sim = scene.build()
    f = sim.forces(contact_only=True)
    x = sim.node_positions()
    direction = x[b.nodes].mean(0) - x[a.nodes].mean(0)
    assert f[b.nodes].sum(0) @ direction > 0
    assert f[a.nodes].sum(0) @ direction < 0


@pytest.mark.parametrize("points", [
    [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]],          # collinear
    [[0.0, 0.0], [1.0, 1.0], [1.0, 1.0]],          # repeated point
    [[0.0, 0.0], [1.0, 0.0], [0.5, 1e-14]],        # numerically flat
])
def test_zero_area_triangle_raises(points):
    with pytest.raises(ValueError, match="zero area"):
        one_triangle(points)


def test_bad_mesh_inputs_raise():
    with pytest.raises(ValueError, match="repeats a node"):
        TriMesh(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), np.array([[0, 1, 1]]))
    with pytest.raises(ValueError, match="out of\\s+range"):
        TriMesh(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), np.array([[0, 1, 3]]))
    with pytest.raises(ValueError, match="non-finite"):
        TriMesh(np.array([[0.0, 0.0], [np.nan, 0.0], [0.0, 1.0]]), np.array([[0, 1, 2]]))


# ------------------------------------------------------------------------------------------------
# materials
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, name", [
    (dict(density=-1.0), "density"),
    (dict(density=0.0), "density"),
    (dict(young=float("nan")), "young"),
    (dict(young=-3e9), "young"),
    (dict(young=float("inf")), "young"),
    (dict(poisson=0.5), "poisson"),
    (dict(poisson=0.7), "poisson"),
    (dict(poisson=-1.0), "poisson"),
    (dict(friction=-0.1), "friction"),
    (dict(damping=1.5), "damping"),
    (dict(damping=-0.1), "damping"),
    (dict(penalty=0.0), "penalty"),
    (dict(penalty=-1e9), "penalty"),
    (dict(tangential_penalty=-1.0), "tangential_penalty"),
    (dict(contact_damping=2.0), "contact_damping"),
])
def test_invalid_material_raises_value_error_naming_the_parameter(kwargs, name):
    with pytest.raises(ValueError) as err:
        fdem.Material(**kwargs)
    assert name in str(err.value)


@pytest.mark.parametrize("kwargs, name", [
    (dict(density="heavy"), "density"),
    (dict(young=None), "young"),
    (dict(friction=[0.3]), "friction"),
])
def test_non_numeric_material_raises_type_error_naming_the_parameter(kwargs, name):
    with pytest.raises(TypeError) as err:
        fdem.Material(**kwargs)
    assert name in str(err.value)


def test_valid_material_edge_values_are_accepted():
    fdem.Material(poisson=0.499, friction=0.0, damping=1.0, contact_damping=0.0)
    fdem.Material(poisson=-0.99)


# ------------------------------------------------------------------------------------------------
# scenes
# ------------------------------------------------------------------------------------------------
def test_unknown_plane_raises():
    with pytest.raises(ValueError, match="plane"):
        fdem.Scene(plane="axisymmetric")
    fdem.Scene(plane="stress")
    fdem.Scene(plane="strain")


@pytest.mark.parametrize("kwargs, name", [
    (dict(thickness=0.0), "thickness"),
    (dict(thickness=float("nan")), "thickness"),
    (dict(gravity=(0.0, float("inf"))), "gravity"),
    (dict(gravity=(1.0, 2.0, 3.0)), "gravity"),
])
def test_invalid_scene_parameters_raise(kwargs, name):
    with pytest.raises(ValueError) as err:
        fdem.Scene(**kwargs)
    assert name in str(err.value)


def test_add_body_type_errors():
    scene = fdem.Scene()
    with pytest.raises(TypeError, match="mesh"):
        scene.add_body(np.zeros((3, 2)), MAT)
    with pytest.raises(TypeError, match="material"):
        scene.add_body(fdem.mesh.rectangle(1, 1, 0.5), {"density": 1000})
    with pytest.raises(ValueError, match="velocity"):
        scene.add_body(fdem.mesh.rectangle(1, 1, 0.5), MAT, velocity=(1.0, float("nan")))


def test_empty_scene_and_bad_build_options_raise():
    with pytest.raises(ValueError, match="no bodies"):
        fdem.Scene().build()
    scene = fdem.Scene()
    scene.add_body(fdem.mesh.rectangle(1, 1, 0.5), MAT)
    with pytest.raises(ValueError, match="safety"):
        scene.build(safety=1.5)
    with pytest.raises(ValueError, match="strategy"):
        scene.build(strategy="gpu-magic")
    with pytest.raises(ValueError, match="dt"):
        scene.build(dt=-1.0)


def test_fix_nodes_selecting_nothing_raises():
    scene = fdem.Scene()
    scene.add_body(fdem.mesh.rectangle(1, 1, 0.5), MAT)
    scene.fix_nodes(lambda x, y: x > 100.0)
    with pytest.raises(ValueError, match="selects no node"):
        scene.build()


def test_dt_above_stable_limit_raises_unless_forced():
    scene = fdem.Scene()
    scene.add_body(fdem.mesh.rectangle(1, 1, 0.25), MAT)
    limit = scene.build().model.dt_limit
    assert scene.build().dt == pytest.approx(0.2 * scene.build().model.dt_estimate, rel=1e-12)   # default safety 0.2
    with pytest.raises(ValueError, match="stable limit"):
        scene.build(dt=2.0 * limit)
    sim = scene.build(dt=2.0 * limit, force_dt=True)
    assert sim.dt == 2.0 * limit
    assert scene.build(dt=0.5 * limit).dt == 0.5 * limit


def test_stable_limit_follows_the_spec_formula():
    """§6.2: Δt_el = h_min/c_p (plane strain c_p), Δt_c = h_min √(ρ/p) over contact triangles.

    These are the book's estimates (``dt_estimate``, the base of the default step); the limit
    used to refuse a step (``dt_limit``) takes 0.4 of the contact term, as measured.
    """
    E, nu, rho = 1e6, 0.25, 1000.0
    mesh = fdem.mesh.rectangle(1.0, 0.5, 0.25)
    h_min = mesh.min_altitude()
    cp = math.sqrt(E * (1 - nu) / (rho * (1 + nu) * (1 - 2 * nu)))
    scene = fdem.Scene()
    scene.add_body(mesh, MAT)
    assert scene.build().model.dt_estimate == pytest.approx(h_min / cp, rel=1e-12)
    assert scene.build().model.dt_limit == pytest.approx(h_min / cp, rel=1e-12)
    scene.add_body(mesh, MAT, position=(0.0, 2.0))
    p = 10.0 * E                                                            # default penalty 10 E
    assert scene.build().model.dt_estimate == pytest.approx(h_min * math.sqrt(rho / p), rel=1e-12)
    assert scene.build().model.dt_limit == pytest.approx(0.4 * h_min * math.sqrt(rho / p), rel=1e-12)
    # damping ratio ξ lowers the limits by √(1+ξ²) − ξ (elements: β; contact: ξ of §5.2)
    damped = fdem.Scene()
    damped.add_body(mesh, MAT.with_(damping=0.5))
    assert damped.build().model.dt_estimate == pytest.approx(h_min / cp * (math.sqrt(1.25) - 0.5), rel=1e-12)
    assert damped.build().model.dt_limit < damped.build().model.dt_estimate      # damping rated on h_eq ≥ h_min
    cdamped = fdem.Scene()
    cdamped.add_body(mesh, MAT.with_(contact_damping=0.5))
    cdamped.add_body(mesh, MAT.with_(contact_damping=0.5), position=(0.0, 2.0))
    assert cdamped.build().model.dt_estimate == pytest.approx(h_min * math.sqrt(rho / p) * (math.sqrt(1.25) - 0.5),
                                                        rel=1e-12)


def test_overlapping_bodies_warn_and_touching_bodies_do_not():
    scene = fdem.Scene()
    scene.add_body(fdem.mesh.rectangle(1, 1, 0.5, origin=(0, 0)), MAT, name="left")
    scene.add_body(fdem.mesh.rectangle(1, 1, 0.5, origin=(0.9, 0)), MAT, name="right")
    with pytest.warns(RuntimeWarning, match="overlap") as rec:
        scene.build()
    assert "left" in str(rec[0].message) and "right" in str(rec[0].message)
    touching = fdem.Scene()
    touching.add_body(fdem.mesh.rectangle(1, 1, 0.5, origin=(0, 0)), MAT)
    touching.add_body(fdem.mesh.rectangle(1, 1, 0.5, origin=(1.0, 0)), MAT)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        touching.build()


@pytest.mark.parametrize("strategy", ["serial", "parallel"])
def test_forced_huge_dt_raises_simulation_error(strategy):
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(1, 0.5, 0.25), MAT, angular_velocity=1.0, velocity=(0.1, 0.0))
    probe = scene.build()
    sim = scene.build(dt=5.0 * probe.model.dt_limit, force_dt=True, strategy=strategy)
    with pytest.raises(fdem.SimulationError) as err:
        sim.step(300)
    e = err.value
    assert 0 < e.step <= 300
    assert e.step == sim.step_count
    assert e.time == pytest.approx(e.step * sim.dt)
    assert f"step {e.step}" in str(e)
    assert 0 < e.suggested_dt < sim.model.dt_limit
    assert e.cause


# ------------------------------------------------------------------------------------------------
# absurd sizes (issue 12): refused before any count overflows, with the usual ValueError
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("make,name", [
    (lambda: fdem.mesh.rectangle(1e308, 1.0, 0.1), "width"),
    (lambda: fdem.mesh.rectangle(1.0, 1.0, 1e-320), "h"),
    (lambda: fdem.mesh.rectangle(1.0, 1e308, 1e300), "height"),
    (lambda: fdem.mesh.rectangle(1e6, 0.05, 0.05), "triangles"),
    (lambda: fdem.mesh.disk(1e308, 0.1), "radius"),
    (lambda: fdem.mesh.disk(1.0, 1e-320), "h"),
    (lambda: fdem.mesh.disk(1.0, 0.1, center=(1e308, 0.0)), "center"),
    (lambda: fdem.mesh.annulus(1.0, 1e308, 0.1), "r_outer"),
    (lambda: fdem.mesh.annulus(1.0, 2.0, 1e-320), "h"),
    (lambda: fdem.mesh.polygon([(0, 0), (1e308, 0), (0, 1e308)], 1e-3), "vertex"),
    (lambda: fdem.mesh.polygon([(0, 0), (1, 0), (0, 1)], 1e-320), "h"),
    (lambda: fdem.mesh.rectangle(1.0, 1.0, 0.5).translated((1e308, 0.0)), "offset"),
    (lambda: TriMesh(np.array([[0.0, 0.0], [1e300, 0.0], [0.0, 1e300]]), np.array([[0, 1, 2]])), "point 1"),
])
def test_mesh_generators_refuse_absurd_sizes(make, name):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)      # no overflow warning on the way
        with pytest.raises(ValueError, match=name):
            make()


@pytest.mark.parametrize("key,value", [("young", 1e308), ("density", 1e308), ("penalty", 1e308),
                                       ("young", 1e-300), ("friction", 1e308), ("tensile_strength", 1e300),
                                       ("fracture_energy", 1e300), ("joint_penalty", 1e308)])
def test_material_refuses_absurd_values(key, value):
    with pytest.raises(ValueError, match=f"{key}=.*outside the accepted range"):
        fdem.Material(**{key: value})


def test_material_extreme_but_sane_values_build_without_overflow():
    """The largest accepted modulus and density give a finite time step and damping constant."""
    mat = fdem.Material(density=1e6, young=1e16, poisson=0.25, damping=1.0)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(1.0, 1.0, 0.5), mat)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        sim = scene.build()
    assert math.isfinite(sim.dt) and sim.dt > 0

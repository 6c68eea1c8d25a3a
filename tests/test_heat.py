"""Heat conduction and thermal strains (docs/theory/heat.md, docs/guide/heat.md): analytic
solutions (Carslaw & Jaeger's half-space, the thick cylinder of Timoshenko & Goodier, the
heated plate), the heat balance, strategies and checkpoints."""
import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import erfc

import taichi_fdem as fdem

fdem.init(arch="cpu")

ALL = lambda x, y: np.ones_like(x, dtype=bool)  # noqa: E731


def _stresses(sim):
    """Cauchy stress (E, 2, 2) of the isotropic triangles from the elastic part F_e = F F_th⁻¹ of
    their deformation (F_th = I + ε*, ε* = state.tri_thermal), the law of engine.elastic."""
    x = sim.node_positions()
    t = sim.model.tri_nodes_np
    F = np.stack([x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]]], axis=2) @ sim.model.tri_rest_inv.to_numpy()
    th = sim.state.tri_thermal.to_numpy()
    Fth = np.stack([np.stack([1.0 + th[:, 0], th[:, 2]], 1), np.stack([th[:, 2], 1.0 + th[:, 1]], 1)], 1)
    Fe = F @ np.linalg.inv(Fth)
    J = np.linalg.det(Fe)[:, None, None]
    lame = sim.model.mat_lame.to_numpy()[sim.model.tri_mat_np]
    mu, lam = lame[:, 0, None, None], lame[:, 1, None, None]
    return (mu / J) * (Fe @ Fe.transpose(0, 2, 1) - np.eye(2)) + lam * (J - 1.0 / J) * np.eye(2)


def _mat(**kw):
    base = dict(density=1000.0, young=1e5, poisson=0.25, conductivity=1.0, heat_capacity=1.0)
    base.update(kw)
    return fdem.Material(**base)


def _strip(flux=None, strategy="serial"):
    """A strip 1 m × 0.05 m, its left end held 1 K above the initial 0 (or heated by ``flux``)."""
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(1.0, 0.05, 0.0125, origin=(0.0, 0.0)), _mat())
    scene.set_temperature(0.0)
    if flux is None:
        scene.heat(lambda x, y: x < 1e-9, temperature=1.0)
    else:
        scene.heat(lambda x, y: x < 1e-9, flux=flux)
        scene.heat(lambda x, y: x > 1.0 - 1e-9, temperature=0.0)
    return scene.build(strategy=strategy)


def test_half_space_after_a_step_in_surface_temperature():
    """T = T0 + ΔT erfc(x / (2√(κt))), κ = k/(ρc) (Carslaw & Jaeger §2.4): within 2 % of ΔT."""
    sim = _strip()
    kappa = 1.0 / 1000.0
    sim.step(int(round(10.0 / sim.dt)))
    t = sim.solver.heat.time
    assert t > 9.9
    x = sim.model.node_rest[:, 0]
    ref = erfc(x / (2.0 * math.sqrt(kappa * t)))
    err = float(np.abs(sim.temperatures() - ref).max())
    assert err < 0.02, err


def test_heat_balance_supplied_equals_stored_plus_conducted_out():
    """A flux into one end, the other end held: flux in = stored − held in (the heat the held end
    takes out), to round-off."""
    sim = _strip(flux=50.0)
    sim.step(int(round(20.0 / sim.dt)))
    e = sim.energies()
    assert e["heat_flux_in"] > 0 and e["heat_held_in"] < 0
    assert e["heat_flux_in"] == pytest.approx(50.0 * 0.05 * sim.solver.heat.time, rel=1e-9)
    assert abs(e["heat_supplied"] - e["heat_stored"]) <= 1e-6 * e["heat_flux_in"]


def _cylinder_stress(a, b, Ta, Tb, E, nu, alpha, r):
    """(σ_r, σ_θ) of a long hollow cylinder in plane strain under the steady temperature
    T(r) = Ta + (Tb − Ta) ln(r/a) / ln(b/a) above the stress-free one (Timoshenko & Goodier §151)."""
    T = lambda s: Ta + (Tb - Ta) * math.log(s / a) / math.log(b / a)  # noqa: E731
    whole = quad(lambda s: T(s) * s, a, b)[0]
    part = quad(lambda s: T(s) * s, a, r)[0]
    k = alpha * E / ((1.0 - nu) * r * r)
    sr = k * ((r * r - a * a) / (b * b - a * a) * whole - part)
    st = k * ((r * r + a * a) / (b * b - a * a) * whole + part - T(r) * r * r)
    return sr, st


def test_thick_cylinder_steady_conduction_and_thermal_stresses():
    """Inner face held at 100 K above the outer: the logarithmic profile and the plane-strain
    stresses of Timoshenko & Goodier within 3 % of their largest value."""
    a, b, E, nu, alpha = 0.5, 1.0, 1e6, 0.25, 1e-5
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.annulus(a, b, 0.05), _mat(young=E, poisson=nu, density=1000.0, conductivity=100.0,
                                                       expansion=alpha))
    scene.set_temperature(0.0)
    ramp = fdem.Curve.ramp(0.5)
    scene.heat(lambda x, y: np.hypot(x, y) < a + 1e-6, temperature=100.0, curve=ramp)
    scene.heat(lambda x, y: np.hypot(x, y) > b - 1e-6, temperature=0.0)
    sim = scene.build(strategy="serial", quasi_static=True)
    sim.run(3.0, progress=False)
    X = sim.model.node_rest
    r = np.hypot(X[:, 0], X[:, 1])
    Tref = 100.0 * (1.0 - np.log(r / a) / math.log(b / a))
    assert float(np.abs(sim.temperatures() - Tref).max()) < 1.0          # 1 % of the difference
    c = X[sim.model.tri_nodes_np].mean(axis=1)
    rc = np.hypot(c[:, 0], c[:, 1])
    er, et = c / rc[:, None], np.stack([-c[:, 1], c[:, 0]], axis=1) / rc[:, None]
    s = _stresses(sim)
    s_r = np.einsum("ei,eij,ej->e", er, s, er)
    s_t = np.einsum("ei,eij,ej->e", et, s, et)
    ref = np.array([_cylinder_stress(a, b, 100.0, 0.0, E, nu, alpha, q) for q in rc])
    scale = float(np.abs(ref).max())
    bins = np.linspace(a, b, 11)
    k = np.digitize(rc, bins) - 1
    for col, got in ((0, s_r), (1, s_t)):
        for i in range(10):
            sel = k == i
            err = abs(got[sel].mean() - ref[sel, col].mean()) / scale
            assert err < 0.03, (col, i, err)


@pytest.mark.parametrize("plane", ["strain", "stress"])
def test_plate_held_on_all_sides_and_heated(plane):
    """σ = −EαΔT/(1 − 2ν) in plane strain, −EαΔT/(1 − ν) in plane stress, within 1 %; the
    thermal work closes the energy account."""
    E, nu, alpha, dT = 1e6, 0.25, 1e-5, 100.0
    scene = fdem.Scene(gravity=(0.0, 0.0), plane=plane)
    scene.add_body(fdem.mesh.rectangle(1.0, 1.0, 0.25), _mat(young=E, poisson=nu, expansion=alpha))
    scene.set_temperature(20.0)
    scene.heat(ALL, temperature=20.0 + dT, curve=fdem.Curve.ramp(0.5))
    scene.fix_nodes(lambda x, y: (np.abs(x) > 0.5 - 1e-9) | (np.abs(y) > 0.5 - 1e-9))
    sim = scene.build(strategy="serial", quasi_static=True)
    sim.run(1.0, progress=False)
    s = _stresses(sim)
    expect = -E * alpha * dT / ((1.0 - 2.0 * nu) if plane == "strain" else (1.0 - nu))
    assert np.allclose(s[:, 0, 0], expect, rtol=0.01) and np.allclose(s[:, 1, 1], expect, rtol=0.01)
    assert np.abs(s[:, 0, 1]).max() < 1e-3 * abs(expect)
    e = sim.energies()
    assert e["thermal_work"] == pytest.approx(e["strain"], rel=1e-9)
    assert abs(e["total"]) < 1e-9 * e["strain"]


@pytest.mark.parametrize("plane", ["strain", "stress"])
def test_free_plate_heated_expands_without_stress(plane):
    """Expansion αΔT(1 + ν) in plane strain, αΔT in plane stress, and no stress."""
    E, nu, alpha, dT = 1e6, 0.25, 1e-5, 100.0
    scene = fdem.Scene(gravity=(0.0, 0.0), plane=plane)
    scene.add_body(fdem.mesh.rectangle(1.0, 1.0, 0.25), _mat(young=E, poisson=nu, expansion=alpha))
    scene.set_temperature(20.0)
    scene.heat(ALL, temperature=20.0 + dT, curve=fdem.Curve.ramp(0.5))
    sim = scene.build(strategy="serial", quasi_static=True)
    sim.run(1.5, progress=False)
    x = sim.node_positions()
    width = float(np.ptp(x[:, 0]))
    expect = alpha * dT * ((1.0 + nu) if plane == "strain" else 1.0)
    assert width - 1.0 == pytest.approx(expect, rel=0.01)
    assert np.abs(_stresses(sim)).max() < 0.01 * E * alpha * dT


def _gradient(x, y):
    return 20.0 + 100.0 * x


def _left(x, y):
    return x < -0.05 + 1e-9


def _heated_grains(strategy, **solver):
    m = _mat(density=2700.0, young=1e8, conductivity=3.0, heat_capacity=800.0, expansion=1e-5,
             tensile_strength=1e5, cohesion=3e5, fracture_energy=1.0)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.02), m, fracture=True)
    scene.set_temperature(_gradient)                       # (module functions: a checkpoint pickles the scene)
    scene.heat(_left, temperature=220.0, curve=fdem.Curve.ramp(0.001))
    sim = scene.build(strategy=strategy)
    for k, v in solver.items():
        setattr(sim.solver, k, v)
    return sim


def test_serial_and_parallel_temperatures_are_the_same_bits():
    """The heat kernels are the same for every strategy; with joints intact the temperatures do not
    depend on the mechanics' round-off; the parallel strategy gives the same bits for any team."""
    runs = {}
    for name, strategy, kw in (("serial", "serial", {}), ("one", "parallel", {"team_workers": 1}),
                               ("two", "parallel", {"team_workers": 2})):
        sim = _heated_grains(strategy, **kw)
        sim.step(450)
        assert sim.solver.heat.updates >= 2 and sim.joint_count > 0
        runs[name] = (sim.temperatures(), sim.node_positions(), sim.state.tri_thermal.to_numpy())
    assert np.array_equal(runs["serial"][0], runs["one"][0])
    for k in range(3):
        assert runs["one"][k].tobytes() == runs["two"][k].tobytes()


def test_checkpoint_round_trip_with_heat(tmp_path):
    """A run saved and loaded continues with the same bits as the run that went on."""
    sim = _heated_grains("serial")
    sim.step(130)                          # mid-way between two heat updates
    sim.save(tmp_path / "h.ckpt")
    sim.step(250)
    back = fdem.Simulation.load(tmp_path / "h.ckpt")
    back.step(250)
    assert back.solver.heat.updates == sim.solver.heat.updates
    assert back.temperatures().tobytes() == sim.temperatures().tobytes()
    assert back.node_positions().tobytes() == sim.node_positions().tobytes()
    assert back.energies()["heat_stored"] == sim.energies()["heat_stored"]


def test_a_scene_without_heat_launches_none_of_it():
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05), _mat())
    sim = scene.build(strategy="serial")
    sim.step(5)
    assert sim.solver.heat is None and not [k for k in sim.solver.launches if k.startswith(("heat", "thermal"))]
    assert "heat_stored" not in sim.energies()
    with pytest.raises(ValueError, match="conducts no heat"):
        sim.temperatures()


def test_outputs_with_heat(tmp_path):
    sim = _strip()
    sim.run(0.5, record=[fdem.History(tmp_path / "h.csv")], progress=False)
    head = (tmp_path / "h.csv").read_text().splitlines()[0].split(",")
    for col in ("temperature_min", "temperature_max", "temperature_mean", "E_heat_supplied", "E_heat_stored"):
        assert col in head
    from taichi_fdem.io.vtu import frame_fields
    assert np.array_equal(frame_fields(sim)["point_data"]["temperature"], sim.temperatures())
    from taichi_fdem.render import RendererImage
    r = RendererImage(64, 32, color_by="temperature")
    assert r.render_sim(sim).shape == (32, 64, 3)
    t = r.tri_scalars(sim)
    assert np.allclose(t, sim.temperatures()[sim.model.tri_nodes_np].mean(axis=1))
    q = sim.heat_flow()
    assert q.shape == (sim.tri_count, 2) and q[:, 0].max() > 0      # heat flows from the hot left end


def test_heat_input_errors():
    scene = fdem.Scene(gravity=(0.0, 0.0))
    body = scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05), fdem.Material(density=1000.0, young=1e5))
    with pytest.raises(ValueError, match="exactly one of temperature"):
        scene.heat(ALL, temperature=1.0, flux=2.0)
    with pytest.raises(ValueError, match="exactly one of temperature"):
        scene.heat(ALL)
    with pytest.raises(ValueError, match="temperature"):
        scene.heat(ALL, temperature=float("nan"))
    with pytest.raises(TypeError, match="where"):
        scene.heat(1.0, temperature=1.0)
    with pytest.raises(ValueError, match="initial"):
        scene.set_temperature(float("inf"))
    scene.heat(ALL, body=body, temperature=1.0)
    with pytest.raises(ValueError, match="no conductivity"):
        scene.build()
    scene2 = fdem.Scene(gravity=(0.0, 0.0))
    scene2.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05), _mat())
    scene2.heat(lambda x, y: x > 10.0, flux=1.0)
    with pytest.raises(ValueError, match="selects no boundary edge"):
        scene2.build()
    scene3 = fdem.Scene(gravity=(0.0, 0.0))
    scene3.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05), _mat())
    scene3.set_temperature(lambda x, y: np.zeros(3))
    with pytest.raises(ValueError, match="shape"):
        scene3.build()


SCENE_FILE = """
[scene]
gravity = [0.0, 0.0]

[materials.rock]
density = 1000.0
young = 1e5
conductivity = 1.0
heat_capacity = 1.0
expansion = 1e-5

[[bodies]]
name = "strip"
material = "rock"
shape = "rectangle"
width = 1.0
height = 0.05
h = 0.0125

[temperature]
initial = 20.0

[[heat]]
xmax = -0.5
temperature = 21.0
ramp = 0.5

[[heat]]
xmin = 0.5
flux = 3.0

[solver]
duration = 1.0
strategy = "serial"
"""


def _left_end(x, y):
    return x <= -0.5


def _right_end(x, y):
    return x >= 0.5


def test_scene_file_heat_tables_build_the_same_scene():
    import tomllib
    from taichi_fdem.io import scenefile
    sim_file, _ = scenefile.loads(tomllib.loads(SCENE_FILE), SCENE_FILE).build()
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(1.0, 0.05, 0.0125), _mat(expansion=1e-5))
    scene.set_temperature(20.0)
    scene.heat(_left_end, temperature=21.0, curve=fdem.Curve.ramp(0.5))
    scene.heat(_right_end, flux=3.0)
    sim_py = scene.build(strategy="serial")
    for sim in (sim_file, sim_py):
        sim.run(1.0, progress=False)
    assert sim_file.temperatures().tobytes() == sim_py.temperatures().tobytes()
    assert sim_file.temperatures().max() > 20.5
    bad = SCENE_FILE.replace("flux = 3.0", "flux = 3.0\ntemperature = 1.0")
    with pytest.raises(scenefile.SceneFileError, match="exactly one of temperature"):
        scenefile.loads(tomllib.loads(bad), bad)



def test_free_bedded_plate_expands_along_and_across_its_bedding():
    """Plane stress, bedding at 30°: the free plate's strain is R diag(α1, α2) Rᵀ ΔT
    (docs/theory/heat.md §16.5), α1 along the bedding, α2 across it, within 1 %."""
    E, nu, a1, a2, dT, angle = 1e6, 0.25, 1e-5, 3e-5, 100.0, 30.0
    bed = fdem.Bedding(angle=angle, young_normal=E, poisson_normal=nu, shear_modulus=E / (2.0 * (1.0 + nu)),
                       expansion_normal=a2)
    scene = fdem.Scene(gravity=(0.0, 0.0), plane="stress")
    scene.add_body(fdem.mesh.rectangle(1.0, 1.0, 0.25), _mat(young=E, poisson=nu, expansion=a1, bedding=bed))
    scene.heat(ALL, temperature=dT, curve=fdem.Curve.ramp(0.5))
    sim = scene.build(strategy="serial", quasi_static=True)
    sim.run(1.5, progress=False)
    X = sim.model.node_rest
    u = sim.node_positions() - X
    A = np.column_stack([X, np.ones(len(X))])
    grad = np.linalg.lstsq(A, u, rcond=None)[0][:2].T                      # du_i/dX_j
    eps = 0.5 * (grad + grad.T)
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    R = np.array([[c, -s], [s, c]])
    expect = R @ np.diag([a1, a2]) @ R.T * dT
    assert np.abs(eps - expect).max() < 0.01 * a2 * dT, (eps, expect)

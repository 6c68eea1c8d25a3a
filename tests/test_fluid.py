"""Fluid in the fracture network (hydro-mechanical coupling, taichi_fdem.engine.fluid): input
validation, the cubic law against its analytic steady rate and linear pressure profile, the mass
balance through fracture growth, the energy balance with the fluid's work, and the serial and
parallel strategies against each other."""
import csv
import warnings

import numpy as np
import pytest

import taichi_fdem as fdem

ROCK = dict(density=2700.0, young=10e9, poisson=0.25)
MU = 1e-3            # water [Pa·s]
W0 = 1e-4            # residual aperture [m]
P_IN = 1e5           # inlet pressure [Pa]
LENGTH = 1.0         # crack length [m]
RATE = 2e-2          # injection rate of the fracturing block [m²/s]


def cubic_law_scene():
    """A fixed 1 m × 0.2 m body cut through by a crack along y = 0, at the residual aperture
    W0; pressure P_IN at x = 0 and 0 at x = 1 m."""
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(LENGTH, 0.2, 0.1), fdem.Material(**ROCK), position=(0.5, 0.0), fixed=True,
                   cracks=lambda x, y: np.abs(y) < 1e-9)
    scene.set_fluid(fdem.Fluid(viscosity=MU), aperture_min=W0)
    scene.inject(lambda x, y: x < 1e-9, pressure=P_IN)
    scene.inject(lambda x, y: x > LENGTH - 1e-9, pressure=0.0)
    return scene


def fracture_scene(strategy="serial", conduct="broken"):
    """A free jointed block with a 0.1 m crack at its centre, fed at the crack's centre at a
    constant rate: the fluid opens the crack and the joints ahead of its tips break."""
    rock = fdem.Material(**ROCK, tensile_strength=3e5, cohesion=9e5, fracture_energy=1.0)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.4, 0.4, 0.05), rock, fracture=True,
                   cracks=lambda x, y: (np.abs(y) < 1e-9) & (np.abs(x) < 0.06))
    scene.set_fluid(fdem.Fluid(bulk_modulus=1e8), aperture_min=1e-5, conduct=conduct)
    scene.inject(lambda x, y: (np.abs(x) < 1e-9) & (np.abs(y) < 1e-9), rate=RATE)
    return scene.build(strategy=strategy)


@pytest.fixture(scope="module")
def cubic():
    sim = cubic_law_scene().build(strategy="serial")
    v0 = sim.fluid.volume()
    sim.step(30)             # the diffusion time L² 12 μ/(K w²) is 0.5 ms: steady after 6 ms
    return sim, v0


# ---- validation ------------------------------------------------------------------------------------
def test_fluid_validates_its_parameters():
    with pytest.raises(ValueError, match="viscosity must be > 0"):
        fdem.Fluid(viscosity=0.0)
    with pytest.raises(ValueError, match="density"):
        fdem.Fluid(density=float("nan"))
    with pytest.raises(TypeError, match="bulk_modulus must be a number"):
        fdem.Fluid(bulk_modulus="stiff")
    with pytest.warns(RuntimeWarning, match="viscosity"):
        fdem.Fluid(viscosity=1.0e5)          # 1e5 Pa·s: a unit slip
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        f = fdem.Fluid()
    assert (f.density, f.bulk_modulus, f.viscosity) == (1000.0, 2.2e9, 1e-3)


def test_set_fluid_and_inject_reject_bad_input():
    scene = fdem.Scene()
    scene.add_body(fdem.mesh.rectangle(1.0, 0.2, 0.1), fdem.Material(**ROCK), cracks=lambda x, y: np.abs(y) < 1e-9)
    with pytest.raises(ValueError, match="set_fluid"):
        scene.inject(lambda x, y: x < 0, rate=1e-3)               # no fluid yet
    with pytest.raises(TypeError, match="Fluid"):
        scene.set_fluid(fdem.Material(**ROCK), aperture_min=1e-4)
    for kwargs, msg in ((dict(aperture_min=0.0), "aperture_min must be > 0"),
                        (dict(aperture_min=1e-4, aperture_max=1e-4), "aperture_max must be >"),
                        (dict(aperture_min=1e-4, initial_pressure=-1.0), "initial_pressure"),
                        (dict(aperture_min=1e-4, conduct="open"), "conduct")):
        with pytest.raises(ValueError, match=msg):
            scene.set_fluid(fdem.Fluid(), **kwargs)
    scene.set_fluid(fdem.Fluid(), aperture_min=1e-4)
    with pytest.raises(ValueError, match="exactly one"):
        scene.inject(lambda x, y: x < 0, rate=1e-3, pressure=1e5)
    with pytest.raises(ValueError, match="exactly one"):
        scene.inject(lambda x, y: x < 0)
    with pytest.raises(ValueError, match="rate must be >= 0"):
        scene.inject(lambda x, y: x < 0, rate=-1e-3)
    with pytest.raises(TypeError, match="callable"):
        scene.inject("centre", rate=1e-3)
    with pytest.raises(TypeError, match="Curve"):
        scene.inject(lambda x, y: x < 0, rate=1e-3, curve=[0, 1])
    scene.inject(lambda x, y: x > 10.0, rate=1e-3)                # selects nothing: at build
    with pytest.raises(ValueError, match="inject #0: the predicate selects no node of the fracture network"):
        scene.build()


def test_set_fluid_needs_a_fracture_network():
    scene = fdem.Scene()
    scene.add_body(fdem.mesh.rectangle(1.0, 0.2, 0.1), fdem.Material(**ROCK))
    scene.set_fluid(fdem.Fluid(), aperture_min=1e-4)
    with pytest.raises(ValueError, match="no fracture network"):
        scene.build()


# ---- cubic law --------------------------------------------------------------------------------------
def test_cubic_law_steady_rate_and_linear_profile(cubic):
    """Steady flow through a channel of aperture W0: q = W0³ Δp / (12 μ L) within 2 %, the same
    rate out at the drain, and a linear pressure profile."""
    sim, _ = cubic
    q = W0 ** 3 * P_IN / (12.0 * MU * LENGTH)
    rate_in, rate_out = sim.fluid.injection_rates()
    assert abs(rate_in - q) <= 0.02 * q, (rate_in, q)
    assert abs(rate_out + q) <= 0.02 * q, (rate_out, q)
    pos, p = sim.fluid.pressures()
    assert pos.shape == (len(p), 2) and len(p) == 11           # the 11 vertices along the crack
    assert np.allclose(pos[:, 1], 0.0)
    assert np.max(np.abs(p - P_IN * (1.0 - pos[:, 0] / LENGTH))) <= 0.02 * P_IN
    assert sim.fluid.injection_pressure() == pytest.approx(P_IN)


def test_cubic_law_mass_balance(cubic):
    """What the inlet put in = the change of the stored volume + what the drain took out."""
    sim, v0 = cubic
    vin, vout = sim.fluid.injected_volumes()
    assert vin > 0 > vout
    assert abs((sim.fluid.volume() - v0) - (vin + vout)) <= 1e-6 * vin


def test_history_has_the_fluid_columns(cubic, tmp_path):
    sim, v0 = cubic
    path = tmp_path / "h.csv"
    sim.run(5 * sim.dt, record=[fdem.History(path)])
    rows = list(csv.DictReader(open(path)))
    last = rows[-1]
    for key in ("fluid_injection_pressure", "fluid_injected_volume", "fluid_stored_volume", "fluid_rate_0",
                "fluid_rate_1", "E_fluid_work"):
        assert key in last, key
    assert float(last["fluid_injection_pressure"]) == pytest.approx(P_IN)
    assert float(last["fluid_injected_volume"]) == pytest.approx(sim.fluid.injected_volumes().sum(), rel=1e-9)
    assert float(last["fluid_stored_volume"]) == pytest.approx(sim.fluid.volume(), rel=1e-12)
    assert float(last["E_fluid_work"]) == 0.0                 # a fixed body takes no work


# ---- fracture growth --------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def growing():
    sim = fracture_scene("serial")
    v0 = sim.fluid.volume()
    e0 = sim.energies()["total"]
    conducting0 = int((sim.state.fluid_edge_val.to_numpy()[:, 0] > 0).sum())
    sim.step(2000)
    return sim, v0, e0, conducting0


def test_mass_balance_through_fracture_growth(growing):
    """Joints break, their edges join the network, and the injected volume is what the network
    stores, to 1e-6."""
    sim, v0, _, _ = growing
    assert sim.cracks.broken_count > 0
    conducting = int((sim.state.fluid_edge_val.to_numpy()[:, 0] > 0).sum())
    assert conducting > 10                              # the crack's 2 edges, and broken joints
    injected = sim.fluid.injected_volumes()[0]
    assert injected == pytest.approx(RATE * sim.time, rel=1e-9)
    assert abs(sim.fluid.volume() - v0 - injected) <= 1e-6 * injected


def conducting_edges(sim) -> int:
    return int((sim.state.fluid_edge_val.to_numpy()[:, 0] > 0).sum())


def test_which_joints_conduct(growing):
    """conduct="broken": the crack edges and the broken joints conduct; "damaged": also every
    joint with damage past its peak."""
    sim = growing[0]
    cracks = 2
    assert conducting_edges(sim) == cracks + sim.cracks.broken_count
    other = fracture_scene("serial", conduct="damaged")
    other.step(400)
    damaged = int((other.cracks.joint_damage() > 0).sum())
    assert damaged > other.cracks.broken_count
    assert conducting_edges(other) == cracks + damaged


def test_energy_balance_books_the_fluid_work(growing):
    """The fluid's work on the solid enters the balance as the loads' does: the total stays
    within 2 % of that work."""
    sim, _, e0, _ = growing
    e = sim.energies()
    assert e["fluid_work"] > 0
    assert abs(e["total"] - e0) <= 0.02 * e["fluid_work"], (e["total"], e["fluid_work"])


def test_serial_and_parallel_agree():
    steps = 300
    out = {}
    for strategy in ("serial", "parallel"):
        sim = fracture_scene(strategy)
        sim.step(steps)
        out[strategy] = (sim.node_positions(), sim.fluid.pressures()[1], sim.fluid.injected_volumes())
    (xs, ps, vs), (xp, pp, vp) = out["serial"], out["parallel"]
    assert np.max(np.abs(xs - xp)) <= 1e-12 * 0.4
    assert np.max(np.abs(ps - pp)) <= 1e-9 * np.max(ps)
    assert np.allclose(vs, vp, rtol=1e-12)


def test_fluid_results_need_a_fluid():
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.2, 0.2, 0.1), fdem.Material(**ROCK))
    sim = scene.build()
    with pytest.raises(ValueError, match="no fluid"):
        sim.fluid.injection_rates()
    assert "fluid_work" not in sim.energies()


def test_checkpoint_round_trip_continues_exactly(cubic, tmp_path):
    """A checkpoint keeps the fluid (contents, sources, counters): the loaded run goes on with
    the same bits as the original."""
    sim, _ = cubic
    path = tmp_path / "c.npz"
    sim.save(path)
    other = fdem.Simulation.load(path)
    sim.step(3)
    other.step(3)
    assert np.array_equal(sim.fluid.pressures()[1], other.fluid.pressures()[1])
    assert np.array_equal(sim.fluid.injected_volumes(), other.fluid.injected_volumes())


# ---- scene files ------------------------------------------------------------------------------------
SCENE_FILE = """
[scene]
gravity = [0.0, 0.0]
[materials.rock]
density = 2700.0
young = 10e9
[[bodies]]
material = "rock"
shape = "rectangle"
width = 1.0
height = 0.2
h = 0.1
position = [0.5, 0.0]
fixed = true
cracks = [[[-0.5, 0.0], [0.5, 0.0]]]
[fluid]
viscosity = 1e-3
aperture_min = 1e-4
[[inject]]
xmax = 1e-9
pressure = 1e5
[[inject]]
xmin = 0.999999
pressure = 0.0
[solver]
duration = 0.006
strategy = "serial"
"""


def test_scene_file_expresses_the_fluid(tmp_path):
    """[fluid] and [[inject]]: the cubic-law channel from a scene file."""
    path = tmp_path / "s.toml"
    path.write_text(SCENE_FILE)
    sim, settings = fdem.scenefile.load(str(path)).build()
    settings.run(sim, progress=False)
    q = W0 ** 3 * P_IN / (12.0 * MU * LENGTH)
    rates = sim.fluid.injection_rates()
    assert len(rates) == 2 and abs(rates[0] - q) <= 0.02 * q
    bad = SCENE_FILE.replace("[fluid]\nviscosity = 1e-3\naperture_min = 1e-4\n", "")
    path.write_text(bad)
    with pytest.raises(fdem.scenefile.SceneFileError, match="needs a \\[fluid\\] table"):
        fdem.scenefile.load(str(path))
    path.write_text(SCENE_FILE.replace("pressure = 0.0", "pressure = 0.0\nrate = 1e-3"))
    with pytest.raises(fdem.scenefile.SceneFileError, match="exactly one of rate"):
        fdem.scenefile.load(str(path))
    path.write_text(SCENE_FILE.replace("aperture_min = 1e-4", "aperture_min = 1e-4\nsprite = 1"))
    with pytest.raises(fdem.scenefile.SceneFileError, match="sprite"):
        fdem.scenefile.load(str(path))


def test_vtu_has_the_fluid_pressure(cubic):
    from taichi_fdem.io.vtu import frame_fields
    sim, _ = cubic
    f = frame_fields(sim)["point_data"]["fluid_pressure"]
    assert f.shape == (sim.model.node_count,)
    x = sim.node_positions()
    on = np.abs(x[:, 1]) < 1e-9                       # the crack's face nodes (both copies)
    assert np.allclose(f[on], P_IN * (1.0 - x[on, 0] / LENGTH), atol=0.02 * P_IN)
    assert np.all(f[~on] == 0.0)


def test_a_flow_too_fast_for_the_step_stops_with_a_diagnosis():
    """A step that would need more than SUBSTEPS_MAX flow substeps stops the run, naming why."""
    sim = cubic_law_scene().build(strategy="serial", dt=1.0, force_dt=True)    # needs ~7e5 substeps
    with pytest.raises(fdem.SimulationError, match="substeps"):
        sim.step(1)


def test_initial_pressure_and_curves():
    """A closed channel filled at initial_pressure stays at it; a source's curve scales its
    pressure (a ramp: half-way up at half the ramp time)."""
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(LENGTH, 0.2, 0.1), fdem.Material(**ROCK), position=(0.5, 0.0), fixed=True,
                   cracks=lambda x, y: np.abs(y) < 1e-9)
    scene.set_fluid(fdem.Fluid(viscosity=MU), aperture_min=W0, initial_pressure=3e4)
    sim = scene.build(strategy="serial")
    sim.step(5)
    assert np.allclose(sim.fluid.pressures()[1], 3e4, rtol=1e-9)
    scene.inject(lambda x, y: x < 1e-9, pressure=P_IN, curve=fdem.Curve.ramp(1e-3))
    sim = scene.build(strategy="serial", dt=1e-4)
    sim.step(5)                                      # t = 5e-4 s at the end; the last step started at 4e-4
    assert sim.fluid.injection_pressure() == pytest.approx(0.5 * P_IN, rel=1e-9)


def test_a_source_off_the_cracks_warns():
    rock = fdem.Material(**ROCK, tensile_strength=3e5, cohesion=9e5, fracture_energy=1.0)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.2, 0.2, 0.05), rock, fracture=True)
    scene.set_fluid(fdem.Fluid(), aperture_min=1e-5)
    scene.inject(lambda x, y: (np.abs(x) < 1e-9) & (np.abs(y) < 1e-9), rate=1e-3)
    with pytest.warns(RuntimeWarning, match="inject #0: none of its 1 network node"):
        scene.build()


def test_auto_runs_a_fluid_scene_serial_on_the_cpu(monkeypatch):
    """'auto' never picks the parallel strategy for a scene with a fluid on the CPU (it runs one
    step per launch there, without the team), however many items it has."""
    import taichi_fdem.sim.simulation as simmod
    monkeypatch.setattr(simmod, "AUTO_PARALLEL_ITEMS", 1)
    monkeypatch.setattr(simmod.backend, "cpu_threads", lambda: 2)
    monkeypatch.setattr(simmod.backend, "usable_cores", lambda: 2)
    assert cubic_law_scene().build().solver.strategy == "serial"


def test_scene_file_colours_the_video_by_fluid_pressure(tmp_path):
    """[output] color_by = "fluid_pressure" writes a video of the fluid in a scene file with a
    [fluid] table, and is refused by name without one."""
    path = tmp_path / "s.toml"
    video = tmp_path / "fluid.gif"
    path.write_text(SCENE_FILE.replace("duration = 0.006", "duration = 0.001") + f"""[output]
video = "{video}"
color_by = "fluid_pressure"
width = 96
height = 32
""")
    sim, settings = fdem.scenefile.load(str(path)).build()
    settings.run(sim, progress=False)
    assert video.exists() and video.stat().st_size > 0
    dry = SCENE_FILE.split("[fluid]")[0] + f"""[solver]
duration = 0.001
[output]
video = "{video}"
color_by = "fluid_pressure"
"""
    path.write_text(dry)
    with pytest.raises(fdem.scenefile.SceneFileError, match="color_by.*needs a \\[fluid\\] table"):
        fdem.scenefile.load(str(path))

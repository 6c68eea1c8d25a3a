"""Scene files say what the Python API says: for each capability (material groups and grains,
joint sets, edge selectors, load curves, loads, in-situ stress, contact interactions,
excavation, fluid sources, run checks, lab options) a small scene built from a file and the
same scene built in Python give the same model and state, bit for bit, after a few steps; bad
input is refused naming the file, the line, the table and the key."""
from __future__ import annotations

import os
import warnings

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem.io import scenefile
from taichi_fdem.io.scenefile import SceneFileError

from test_scenefile_guide import _assert_same


def _load(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return scenefile.load(str(path))


def _build(tmp_path, text):
    spec = _load(tmp_path, text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return spec.build()


def _quiet(fn, *a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return fn(*a, **kw)


ROCK = dict(density=2600.0, young=1e9, poisson=0.25, friction=0.5, tensile_strength=1e6, cohesion=3e6,
            fracture_energy=50.0)
ROCK_TOML = """
[materials.rock]
density = 2600.0
young = 1e9
poisson = 0.25
friction = 0.5
tensile_strength = 1e6
cohesion = 3e6
fracture_energy = 50.0
"""


# ------------------------------------------------------------------------------------------------
# the same scene both ways
# ------------------------------------------------------------------------------------------------
def test_grains_minerals_and_an_interface_joint_set(tmp_path):
    """shape = "grains" (fdem.mesh.voronoi_grains) with a material per mineral, joints on every edge,
    the grain boundaries a joint set of their own; a platen pushes down with a velocity curve."""
    text = ROCK_TOML + """
[materials.quartz]
like = "rock"
young = 2e9
tensile_strength = 2e6
cohesion = 6e6

[materials.weak]
like = "rock"
tensile_strength = 3e5
cohesion = 9e5

[curves.push]
times = [0.0, 1e-4, 1.0]
values = [0.0, 1.0, 1.0]

[[bodies]]
name = "specimen"
shape = "grains"
width = 0.1
height = 0.05
grain_size = 0.025
h = 0.01
seed = 3
minerals = { quartz = 0.4, feldspar = 0.6 }
materials = { quartz = "quartz", feldspar = "rock" }
fracture = true

[[bodies]]
name = "platen"
material = "rock"
shape = "rectangle"
width = 0.12
height = 0.01
h = 0.01
position = [0.0, 0.0305]
prescribed_velocity = [0.0, -0.5]
velocity_curve = "push"

[[joint_sets]]
name = "grain_boundaries"
material = "weak"
interfaces = true
weibull_modulus = 5.0
strength_seed = 2

[solver]
duration = 1e-3
check_overlap = false
"""
    sim_toml, _ = _build(tmp_path, text)
    rock = fdem.Material(**ROCK, name="rock")
    quartz = rock.with_(young=2e9, tensile_strength=2e6, cohesion=6e6, name="quartz")
    weak = rock.with_(tensile_strength=3e5, cohesion=9e5, name="weak")
    m, labels = fdem.mesh.voronoi_grains(0.1, 0.05, 0.025, 0.01, seed=3, minerals={"quartz": 0.4, "feldspar": 0.6})
    scene = fdem.Scene()
    scene.add_body(m, labels.materials({"quartz": quartz, "feldspar": rock}), groups=labels, fracture=True,
                   name="specimen")
    scene.add_body(fdem.mesh.rectangle(0.12, 0.01, 0.01), rock, position=(0.0, 0.0305),
                   prescribed_velocity=(0.0, -0.5), name="platen",
                   velocity_curve=fdem.Curve([0.0, 1e-4, 1.0], [0.0, 1.0, 1.0]))
    scene.add_joint_set("grain_boundaries", "interfaces", weak, strength=fdem.Weibull(5.0, seed=2))
    sim_py = _quiet(scene.build, check_overlap=False)
    assert sim_py.bodies[0].joint_count > 0 and len(set(labels.grain_mineral)) == 2
    _assert_same(sim_py, sim_toml, "grains")
    sim_py.step(30)
    sim_toml.step(30)
    _assert_same(sim_py, sim_toml, "grains after 30 steps")


def test_material_groups_of_a_mesh_file_and_edge_selectors(tmp_path):
    """file + groups = true (fdem.mesh.load_tagged) with a material per group; fracture on the
    interfaces and in a ring, an open crack given by a region, a contact interaction."""
    import meshio
    src = fdem.mesh.rectangle(0.2, 0.1, 0.025)
    c = src.points[src.triangles].mean(axis=1)
    tag = np.where(c[:, 0] < 0.0, 1, 2)
    meshio.write(tmp_path / "two.msh",
                 meshio.Mesh(np.c_[src.points, np.zeros(src.point_count)], [("triangle", src.triangles)],
                             cell_data={"gmsh:physical": [tag], "gmsh:geometrical": [tag]},
                             field_data={"host": np.array([1, 2]), "dyke": np.array([2, 2])}),
                 file_format="gmsh22", binary=False)
    text = ROCK_TOML + """
[materials.dyke]
like = "rock"
tensile_strength = 1e5
cohesion = 3e5

[[bodies]]
file = "two.msh"
groups = true
materials = { host = "rock", dyke = "dyke" }
fracture = ["interfaces", { center = [0.05, 0.0], r_max = 0.03 }]
cracks = { xmin = -0.076, xmax = -0.074, ymax = 0.02 }
velocity = [0.0, -1.0]

[[bodies]]
material = "rock"
shape = "rectangle"
width = 0.4
height = 0.05
h = 0.05
position = [0.0, -0.0751]
fixed = true

[[interactions]]
materials = ["rock", "dyke"]
friction = 0.1
contact_damping = 0.2

[solver]
duration = 1e-3
"""
    sim_toml, _ = _build(tmp_path, text)
    rock = fdem.Material(**ROCK, name="rock")
    dyke = rock.with_(tensile_strength=1e5, cohesion=3e5, name="dyke")
    m, labels, _ = fdem.mesh.load_tagged(tmp_path / "two.msh")
    scene = fdem.Scene()
    scene.add_body(m, {"host": rock, "dyke": dyke}, groups=labels, velocity=(0.0, -1.0),
                   fracture=["interfaces", lambda x, y: np.hypot(x - 0.05, y) <= 0.03],
                   cracks=lambda x, y: (x >= -0.076) & (x <= -0.074) & (y <= 0.02))
    scene.add_body(fdem.mesh.rectangle(0.4, 0.05, 0.05), rock, position=(0.0, -0.0751), fixed=True)
    scene.set_interaction(rock, dyke, friction=0.1, contact_damping=0.2)
    sim_py = _quiet(scene.build)
    _assert_same(sim_py, sim_toml, "tagged file")
    sim_py.step(200)
    sim_toml.step(200)
    _assert_same(sim_py, sim_toml, "tagged file after 200 steps")
    assert sim_toml.state.node_v.to_numpy()[:, 1].max() > -1.0     # it hit the floor


def test_loads_curves_constraints_and_initial_stress(tmp_path):
    """Pressure on a ring, a force with a tabulated curve, a traction, an absorbing boundary, a
    roller with a curve and a lithostatic initial stress with a gradient."""
    text = ROCK_TOML + """
[scene]
gravity = [0.0, -9.81]

[curves.pulse]
times = [0.0, 2e-4, 4e-4]
values = [0.0, 1.0, 0.0]

[curves.ramp]
ramp = 3e-4
start = 1e-4

[[bodies]]
name = "block"
material = "rock"
shape = "annulus"
r_inner = 0.03
r_outer = 0.1
h = 0.01

[[constraints]]
body = "block"
ymax = -0.099
vy = 0.0
curve = "ramp"

[[loads]]
kind = "pressure"
pressure = 2e5
r_max = 0.0301
curve = "ramp"

[[loads]]
kind = "force"
force = [10.0, -5.0]
body = "block"
center = [0.1, 0.0]
r_max = 0.001
curve = "pulse"

[[loads]]
kind = "traction"
traction = [0.0, -1e4]
ymin = 0.099

[[loads]]
kind = "absorbing"
xmin = 0.0
ymin = -0.02
ymax = 0.02
r_min = 0.099

[[initial_stress]]
sxx = -1e5
syy = -2e5
sxy = 1e4
gradient = [1e4, 2e4]
y_ref = 0.1

[solver]
duration = 1e-3
speed_limit = 500.0
"""
    sim_toml, _ = _build(tmp_path, text)
    rock = fdem.Material(**ROCK, name="rock")
    scene = fdem.Scene()
    block = scene.add_body(fdem.mesh.annulus(0.03, 0.1, 0.01), rock, name="block")
    ramp = fdem.Curve.ramp(3e-4, 1e-4)
    scene.fix_nodes(lambda x, y: y <= -0.099, body=block, velocity=(None, 0.0), curve=ramp)
    scene.apply_pressure(lambda x, y: np.hypot(x, y) <= 0.0301, 2e5, curve=ramp)
    scene.apply_force(lambda x, y: np.hypot(x - 0.1, y) <= 0.001, (10.0, -5.0), body=block,
                      curve=fdem.Curve([0.0, 2e-4, 4e-4], [0.0, 1.0, 0.0]))
    scene.apply_traction(lambda x, y: y >= 0.099, (0.0, -1e4))
    scene.absorbing_boundary(lambda x, y: (x >= 0.0) & (y >= -0.02) & (y <= 0.02) & (np.hypot(x, y) >= 0.099))
    scene.initial_stress(-1e5, -2e5, 1e4, gradient=(1e4, 2e4), y_ref=0.1)
    sim_py = _quiet(scene.build, speed_limit=500.0)
    assert sim_toml.model.speed_limit == 500.0
    _assert_same(sim_py, sim_toml, "loads")
    sim_py.step(40)
    sim_toml.step(40)
    _assert_same(sim_py, sim_toml, "loads after 40 steps")
    assert np.abs(sim_toml.state.load_force.to_numpy()).max() > 0


def test_excavation_during_the_run(tmp_path):
    """[[excavate]] removes the triangles at its time, as sim.run(t); sim.remove(...); sim.run(...)
    does; a body removed at time 0 goes before the first step."""
    text = ROCK_TOML + """
[scene]
gravity = [0.0, 0.0]

[[bodies]]
name = "rock"
material = "rock"
shape = "rectangle"
width = 0.2
height = 0.1
h = 0.02

[[bodies]]
name = "plug"
material = "rock"
shape = "disk"
radius = 0.01
h = 0.01
position = [0.3, 0.0]

[[constraints]]
ymax = -0.049
vx = 0.0
vy = 0.0

[[initial_stress]]
sxx = -1e6
syy = -1e6
body = "rock"

[[loads]]
kind = "pressure"
pressure = 1e6
body = "rock"
ymin = -0.049

[[loads]]
kind = "pressure"
pressure = 1e6
body = "rock"
xmin = 0.099

[[loads]]
kind = "pressure"
pressure = 1e6
body = "rock"
xmax = -0.099

[[excavate]]
time = 0.0
body = "plug"

[[excavate]]
time = 2e-4
center = [0.0, 0.0]
r_max = 0.025

[solver]
duration = 4e-4
dt = 1e-6
"""
    sim_toml, settings = _build(tmp_path, text)
    settings.run(sim_toml, progress=False)
    rock = fdem.Material(**ROCK, name="rock")
    scene = fdem.Scene(gravity=(0.0, 0.0))
    body = scene.add_body(fdem.mesh.rectangle(0.2, 0.1, 0.02), rock, name="rock")
    plug = scene.add_body(fdem.mesh.disk(0.01, 0.01), rock, position=(0.3, 0.0), name="plug")
    scene.fix_nodes(lambda x, y: y <= -0.049, velocity=(0.0, 0.0))
    scene.initial_stress(-1e6, -1e6, body=body)
    for where in (lambda x, y: y >= -0.049, lambda x, y: x >= 0.099, lambda x, y: x <= -0.099):
        scene.apply_pressure(where, 1e6, body=body)
    sim_py = _quiet(scene.build, dt=1e-6)
    sim_py.remove(body=plug)
    sim_py.run(2e-4, progress=False)
    removed = sim_py.remove(where=lambda x, y: np.hypot(x, y) <= 0.025)
    sim_py.run(2e-4, progress=False)
    assert removed > 0
    _assert_same(sim_py, sim_toml, "excavation")
    assert sim_toml.energies()["excavated"] != 0.0


def test_fluid_source_with_a_curve_and_the_run_checks(tmp_path):
    text = """
[scene]
gravity = [0.0, 0.0]

[materials.rock]
density = 2700.0
young = 10e9
poisson = 0.25

[curves.cycle]
times = [0.0, 1e-4, 2e-4]
values = [0.0, 1.0, 0.5]

[[bodies]]
material = "rock"
shape = "rectangle"
width = 0.4
height = 0.2
h = 0.05
fixed = true
cracks = [[[-0.2, 0.0], [0.2, 0.0]]]

[fluid]
aperture_min = 1e-4
aperture_max = 1e-3
conduct = "damaged"

[[inject]]
xmin = -0.01
xmax = 0.01
rate = 1e-4
curve = "cycle"

[solver]
duration = 3e-4
strategy = "serial"

[checks]
energy_tol = 0.2
max_penetration = 0
every = 10
"""
    sim_toml, settings = _build(tmp_path, text)
    assert settings.checks == {"energy": True, "energy_tol": 0.2, "max_penetration": 0.0, "every": 10}
    rock = fdem.Material(density=2700.0, young=10e9, poisson=0.25, name="rock")
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.4, 0.2, 0.05), rock, fixed=True,
                   cracks=[fdem.mesh.Polyline([(-0.2, 0.0), (0.2, 0.0)])])
    scene.set_fluid(fdem.Fluid(), aperture_min=1e-4, aperture_max=1e-3, conduct="damaged")
    scene.inject(lambda x, y: (x >= -0.01) & (x <= 0.01), rate=1e-4,
                 curve=fdem.Curve([0.0, 1e-4, 2e-4], [0.0, 1.0, 0.5]))
    sim_py = _quiet(scene.build, strategy="serial")
    settings.run(sim_toml, progress=False)
    sim_py.run(3e-4, progress=False, checks=fdem.Checks(energy_tol=0.2, max_penetration=None, every=10))
    _assert_same(sim_py, sim_toml, "fluid")
    assert sim_toml.fluid.injection_rates()[0] > 0


def test_lab_keys_reach_the_lab_function(tmp_path, monkeypatch):
    """Every [lab] key is passed to fdem.lab as its keyword (materials by name, the strength as a
    Weibull); a key of another test is refused."""
    from taichi_fdem import lab
    seen = {}
    monkeypatch.setattr(lab, "brazilian", lambda *a, **kw: seen.update(args=a, kw=kw) or "result")
    monkeypatch.setattr(lab, "compression", lambda *a, **kw: seen.update(args=a, kw=kw) or "result")
    monkeypatch.setattr(lab, "triaxial", lambda *a, **kw: seen.update(args=a, kw=kw) or "result")
    text = ROCK_TOML + """
[materials.steel]
density = 7800.0
young = 200e9
poisson = 0.3

[lab]
test = "brazilian"
material = "rock"
diameter = 0.05
h = 0.005
check = "rate"
quasi_static = 0.0
safety = 0.15
alpha_deg = 8.0
max_time = 2.0
joint_penalty_factor = 100.0
platen = "steel"
weibull_modulus = 6.0
strength_seed = 4
"""
    spec = _load(tmp_path, text)
    assert spec.run_lab() == "result"
    kw = seen["kw"]
    assert seen["args"][1:] == (0.05, 0.005)
    assert kw["check"] == "rate" and kw["quasi_static"] is False and kw["safety"] == 0.15
    assert kw["alpha_deg"] == 8.0 and kw["max_time"] == 2.0 and kw["joint_penalty_factor"] == 100.0
    assert kw["platen"] is spec.materials["steel"] and kw["strength"] == fdem.Weibull(6.0, seed=4)
    assert "load_time" not in kw                       # the test chooses it
    spec = _load(tmp_path, text.replace('test = "brazilian"', 'test = "triaxial"')
                 .replace("diameter = 0.05", "width = 0.05\nheight = 0.1\nconfinement = 1e6")
                 .replace("alpha_deg = 8.0\nmax_time = 2.0\njoint_penalty_factor = 100.0\n", "")
                 .replace("weibull_modulus = 6.0\nstrength_seed = 4\n", "stop_drop = 0.7\nhistory = \"h.csv\"\n"))
    spec.run_lab()
    assert seen["kw"]["stop_drop"] == 0.7 and seen["kw"]["history"] == "h.csv"
    with pytest.raises(SceneFileError, match=r"scene.toml:\d+: \[lab\] key 'alpha_deg' does not apply to the 'ucs'"):
        _load(tmp_path, ROCK_TOML + '[lab]\ntest = "ucs"\nmaterial = "rock"\nwidth = 0.05\nheight = 0.1\n'
                                    'h = 0.01\nalpha_deg = 5.0\n')


# ------------------------------------------------------------------------------------------------
# bad input: the file, the line, the table, the key
# ------------------------------------------------------------------------------------------------
BODY = """
[[bodies]]
name = "b"
material = "rock"
shape = "rectangle"
width = 0.2
height = 0.1
h = 0.05
"""
SOLVER = "\n[solver]\nduration = 1e-3\n"


@pytest.mark.parametrize("extra,pattern", [
    ('\n[[loads]]\nkind = "pressure"\npressure = 1.0\nxmin = 0.0\ncurve = "rmp"\n',
     r"scene.toml:\d+: \[loads\[0\]\] unknown curve 'rmp'"),
    ('\n[[loads]]\nkind = "pressure"\npressure = 1.0\n',
     r"\[loads\[0\]\] give at least one of xmin, xmax, ymin, ymax, r_min, r_max"),
    ('\n[[loads]]\nkind = "force"\npressure = 1.0\nxmin = 0.0\n',
     r"scene.toml:\d+: \[loads\[0\]\] a 'force' load takes 'force', not 'pressure'"),
    ('\n[[loads]]\nkind = "traction"\nxmin = 0.0\n', r"\[loads\[0\]\] a 'traction' load needs 'traction' \[Pa\]"),
    ('\n[[loads]]\nkind = "pressure"\npressure = 1.0\ncenter = [0.0, 0.0]\nxmin = 0.0\n',
     r"\[loads\[0\]\] center needs r_min and/or r_max"),
    ('\n[[loads]]\nkind = "pressure"\npressure = 1.0\nr_min = 0.2\nr_max = 0.1\n',
     r"\[loads\[0\]\] r_min \(0.2 m\) must be <= r_max \(0.1 m\)"),
    ('\n[[loads]]\nkind = "pressure"\npressure = 1.0\nxmin = 5.0\n', r"\[loads\[0\]\] the box selects no node"),
    ('\n[[joint_sets]]\nname = "j"\nmaterial = "rock"\n',
     r"\[joint_sets\[0\]\] give exactly one edge selector"),
    ('\n[[joint_sets]]\nname = "j"\nmaterial = "soft"\ninterfaces = true\n',
     r"\[joint_sets\[0\]\] unknown material 'soft'"),
    ('\n[[joint_sets]]\nname = "j"\nmaterial = "rock"\nxmin = 9.0\n',
     r"\[joint_sets\[0\]\] Scene.add_joint_set\('j'\): the selector picks no interior edge"),
    ('\n[[initial_stress]]\nsxx = 1.0\nsyy = 1.0\ngradient = [1.0]\n',
     r"\[initial_stress\[0\]\] gradient must be \[dsxx/dy, dsyy/dy\]"),
    ('\n[[initial_stress]]\nsxx = 1.0\n', r"\[initial_stress\[0\]\] missing required key 'syy'"),
    ('\n[[interactions]]\nmaterials = ["rock"]\nfriction = 0.1\n', r"\[interactions\[0\]\] materials must name two"),
    ('\n[[interactions]]\nmaterials = ["rock", "rock"]\n', r"\[interactions\[0\]\] give at least one of friction"),
    ('\n[[excavate]]\ntime = 1.0\nbody = "b"\n', r"\[excavate\[0\]\] time \(1.0 s\) is after the end of the run"),
    ('\n[[excavate]]\ntime = 0.0\n', r"\[excavate\[0\]\] give body and/or a region"),
    ('\n[[excavate]]\ntime = 1e-4\nbody = "b"\n[[excavate]]\ntime = 0.0\nbody = "b"\n',
     r"\[excavate\[1\]\] \[\[excavate\]\] tables must come in order of time"),
    ('\n[curves.c]\ntimes = [0.0, 0.0]\nvalues = [0.0, 1.0]\n', r"\[curves.c\] Curve: times must be strictly increasing"),
    ('\n[curves.c]\nramp = 1.0\nvalues = [0.0, 1.0]\n', r"\[curves.c\] give either ramp \(and start\) or times"),
    ('\n[curves.c]\ntimes = [0.0, 1.0]\n', r"\[curves.c\] curve 'c': give times \[s\] and values, or ramp"),
    ('\n[checks]\nmax_penetraton = 0.3\n', r"\[checks\] unknown key 'max_penetraton' \(did you mean 'max_penetration'\?\)"),
])
def test_bad_tables_name_the_file_table_and_key(tmp_path, extra, pattern):
    with pytest.raises(SceneFileError, match=pattern):
        _build(tmp_path, ROCK_TOML + BODY + extra + SOLVER)


@pytest.mark.parametrize("old,new,pattern", [
    ('material = "rock"\nshape', 'materials = { a = "rock" }\nshape',
     r"scene.toml:\d+: \[bodies\[0\]\] a 'rectangle' mesh has one material group"),
    ('material = "rock"\nshape', 'material = "rock"\nmaterials = { a = "rock" }\nshape',
     r"\[bodies\[0\]\] body 'b': give exactly one of material"),
    ('h = 0.05\n', 'h = 0.05\nfracture = "interface"\n', r"\[bodies\[0\]\] fracture must be true, false, \"interfaces\""),
    ('h = 0.05\n', 'h = 0.05\nfracture = { lines = [[[0.0, 0.0], [0.1, 0.0]]], xmin = 0.0 }\n',
     r"\[bodies\[0\].fracture\] give one of a region \(xmin, ..., r_max\), lines or line_group"),
    ('h = 0.05\n', 'h = 0.05\ncracks = { line_group = "fault" }\n',
     r"\[bodies\[0\]\] line_group selects edges along a line group of the body's mesh file: it needs file"),
    ('h = 0.05\n', 'h = 0.05\ncracks = { xmin = 0.0, zmax = 1.0 }\n',
     r"scene.toml:\d+: \[bodies\[0\].cracks\] unknown key 'zmax' \(did you mean"),
    ('h = 0.05\n', 'h = 0.05\nvelocity_curve = "c"\n', r"\[bodies\[0\]\] unknown curve 'c'"),
    ('shape = "rectangle"\nwidth = 0.2\nheight = 0.1\nh = 0.05\n',
     'shape = "grains"\nwidth = 0.2\nheight = 0.1\nh = 0.05\ngrain_size = 0.04\n',
     r"\[bodies\[0\]\] h \(0.05 m\) must be smaller than grain_size"),
])
def test_bad_body_keys(tmp_path, old, new, pattern):
    text = ROCK_TOML + BODY.replace(old, new) + SOLVER
    with pytest.raises(SceneFileError, match=pattern):
        _build(tmp_path, text)


def test_materials_like_another(tmp_path):
    spec = _load(tmp_path, ROCK_TOML + '\n[materials.weak]\nlike = "rock"\nfriction = 0.2\n' + BODY + SOLVER)
    assert spec.materials["weak"] == fdem.Material(**ROCK, name="rock").with_(friction=0.2, name="weak")
    with pytest.raises(SceneFileError, match=r"scene.toml:\d+: \[materials.a\] materials refer to each other in a loop"):
        _load(tmp_path, '[materials.a]\nlike = "b"\n[materials.b]\nlike = "a"\n' + BODY + SOLVER)
    with pytest.raises(SceneFileError, match=r"\[materials.weak\] unknown material 'rok' \(did you mean 'rock'\?\)"):
        _load(tmp_path, ROCK_TOML + '\n[materials.weak]\nlike = "rok"\n' + BODY + SOLVER)


def test_new_tables_are_in_the_generated_reference():
    import sys
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "docs", "_ext"))
    import scenefile_ref
    text = scenefile_ref.render()
    for title in ("[curves.NAME]", "[[joint_sets]]", "[[interactions]]", "[[loads]]", "[[initial_stress]]",
                  "[[excavate]]", "[checks]", "[temperature]", "[[heat]]"):
        assert f"## `{title}`" in text, title


def test_the_toml_blocks_of_the_scene_file_guide_load(tmp_path):
    """The ```toml examples of docs/guide/scenefiles.md are valid scene files (checked, built)."""
    import re
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    text = open(os.path.join(root, "docs", "guide", "scenefiles.md"), encoding="utf-8").read()
    blocks = re.findall(r"^```toml\n(.*?)^```", text, re.S | re.M)
    assert blocks
    for k, block in enumerate(blocks):
        spec = _load(tmp_path, block, f"guide_{k}.toml")
        scene, bodies = _quiet(spec.build_scene)
        assert bodies and scene.joint_sets


def test_a_sweep_overrides_keys_of_the_new_tables(tmp_path):
    text = ROCK_TOML + BODY + '\n[curves.c]\nramp = 1e-3\n\n[[loads]]\nkind = "pressure"\npressure = 1.0\n' \
        'xmin = 0.0\ncurve = "c"\n' + SOLVER
    path = tmp_path / "s.toml"
    path.write_text(text, encoding="utf-8")
    spec = scenefile.load(str(path), overrides={"loads.0.pressure": 5.0, "curves.c.ramp": 2e-3})
    assert spec.loads[0]["pressure"] == 5.0 and spec.curves["c"]["times"] == [0.0, 2e-3]
    with pytest.raises(SceneFileError, match=r"override 'loads.0.pressure'.*must be a number"):
        scenefile.load(str(path), overrides={"loads.0.pressure": "high"})


def test_an_excavation_after_the_run_warns_and_a_resumed_run_does_not_repeat_one(tmp_path):
    text = ROCK_TOML + BODY + '\n[[excavate]]\ntime = 4e-6\nxmin = 0.05\n' + \
        '\n[solver]\nduration = 1e-5\ndt = 1e-6\ngravity = [0.0, 0.0]\n'.replace("gravity = [0.0, 0.0]\n", "")
    sim, settings = _build(tmp_path, text)
    with pytest.warns(RuntimeWarning, match=r"\[\[excavate\]\] at 4e-06 s is after the end of this run"):
        settings.run(sim, progress=False, duration=2e-6)
    assert (sim.state.tri_intact.to_numpy() >= 0).all()
    settings.run(sim, progress=False, duration=2e-6)         # steps 2..4: the excavation at step 4
    removed = (sim.state.tri_intact.to_numpy() < 0).sum()
    assert removed > 0 and sim.step_count == 4
    settings.run(sim, progress=False, duration=2e-6)         # already done: not repeated
    assert (sim.state.tri_intact.to_numpy() < 0).sum() == removed


def test_a_grain_specimen_in_a_lab_file(tmp_path, monkeypatch):
    """[lab] grain_size, minerals, materials and [[lab.joint_sets]] become the test's mesh=,
    groups=, material dict and joint_sets= triples."""
    from taichi_fdem import lab
    seen = {}
    monkeypatch.setattr(lab, "brazilian", lambda *a, **kw: seen.update(args=a, kw=kw) or "result")
    text = ROCK_TOML + """
[materials.quartz]
like = "rock"
young = 2e9

[materials.boundary]
like = "rock"
tensile_strength = 5e5
cohesion = 1.5e6

[lab]
test = "brazilian"
materials = { quartz = "quartz", feldspar = "rock" }
diameter = 0.05
h = 0.004
grain_size = 0.012
grain_seed = 5
minerals = { quartz = 0.3, feldspar = 0.7 }

[[lab.joint_sets]]
name = "grain_boundaries"
material = "boundary"
interfaces = true

[[lab.joint_sets]]
name = "centre"
material = "boundary"
r_max = 0.005
"""
    spec = _load(tmp_path, text)
    assert spec.run_lab() == "result"
    mat, d, h = seen["args"]
    kw = seen["kw"]
    m, labels = fdem.mesh.voronoi_grains(0.05, 0.05, 0.012, 0.004, seed=5, minerals={"quartz": 0.3, "feldspar": 0.7},
                                         shape="disc")
    assert (d, h) == (0.05, 0.004)
    assert np.array_equal(kw["mesh"].points, m.points) and np.array_equal(kw["mesh"].triangles, m.triangles)
    assert np.array_equal(np.asarray(kw["groups"]), np.asarray(labels))
    assert mat == labels.materials({"quartz": spec.materials["quartz"], "feldspar": spec.materials["rock"]})
    (n1, s1, m1), (n2, s2, m2) = kw["joint_sets"]
    assert (n1, s1, m1) == ("grain_boundaries", "interfaces", spec.materials["boundary"])
    assert n2 == "centre" and m2 is spec.materials["boundary"]
    assert list(s2(np.array([0.0, 0.004, 0.006]), np.zeros(3))) == [True, True, False]
    with pytest.raises(SceneFileError, match=r"scene.toml:\d+: \[lab.joint_sets\[1\]\] give exactly one edge"):
        _load(tmp_path, text.replace("r_max = 0.005\n", ""))
    with pytest.raises(SceneFileError, match=r"\[lab\] materials must name one material for each mineral"):
        _load(tmp_path, text.replace("minerals = { quartz = 0.3, feldspar = 0.7 }", "minerals = { quartz = 1.0 }"))
    with pytest.raises(SceneFileError, match=r"\[lab\] needs exactly one of material"):
        _load(tmp_path, text.replace('test = "brazilian"', 'test = "brazilian"\nmaterial = "rock"'))


def test_one_body_per_group_of_a_mesh_file(tmp_path):
    """group = "NAME" takes one group of a file (fdem.mesh.load_groups): two [[bodies]] give the
    bodies of fdem.mesh.scene_from_groups, bit for bit; an unknown group is refused by name."""
    import meshio
    src = fdem.mesh.rectangle(0.2, 0.1, 0.025)
    c = src.points[src.triangles].mean(axis=1)
    tag = np.where(c[:, 0] < 0.0, 1, 2)
    meshio.write(tmp_path / "two.msh",
                 meshio.Mesh(np.c_[src.points, np.zeros(src.point_count)], [("triangle", src.triangles)],
                             cell_data={"gmsh:physical": [tag], "gmsh:geometrical": [tag]},
                             field_data={"host": np.array([1, 2]), "dyke": np.array([2, 2])}),
                 file_format="gmsh22", binary=False)
    text = ROCK_TOML + """
[[bodies]]
name = "host"
file = "two.msh"
group = "host"
velocity = [1.0, 0.0]

[[bodies]]
name = "dyke"
file = "two.msh"
group = "dyke"
velocity = [1.0, 0.0]
material = "rock"

[solver]
duration = 1e-3
check_overlap = false
""".replace('group = "host"\n', 'group = "host"\nmaterial = "rock"\n')
    sim_toml, _ = _build(tmp_path, text)
    rock = fdem.Material(**ROCK, name="rock")
    scene = fdem.Scene()
    fdem.mesh.scene_from_groups(scene, tmp_path / "two.msh", rock, velocity=(1.0, 0.0))
    sim_py = _quiet(scene.build, check_overlap=False)
    sim_py.step(10)
    sim_toml.step(10)
    _assert_same(sim_py, sim_toml, "groups as bodies")
    with pytest.raises(SceneFileError, match=r"scene.toml:\d+: \[bodies\[1\]\] body 'dyke': cannot make its file "
                                             r"mesh: no group 'dike' in the file; its groups: host, dyke"):
        _build(tmp_path, text.replace('group = "dyke"', 'group = "dike"'))


def test_line_groups_of_a_mesh_file_select_cracks_and_joints(tmp_path):
    """cracks = { line_group = "fault" }, fracture = { line_group = "joint" }: the physical line
    groups of the body's file, as the Segments of fdem.mesh.load_groups(..., lines=True)."""
    import meshio
    src = fdem.mesh.rectangle(0.2, 0.1, 0.025)
    pts3 = np.c_[src.points, np.zeros(src.point_count)]
    on_y0 = [e for e in src.edges().tolist() if abs(src.points[e[0], 1]) < 1e-12 and abs(src.points[e[1], 1]) < 1e-12]
    on_x0 = [e for e in src.edges().tolist() if abs(src.points[e[0], 0]) < 1e-12 and abs(src.points[e[1], 0]) < 1e-12]
    lines = np.array(on_y0 + on_x0)
    ltag = np.array([10] * len(on_y0) + [11] * len(on_x0))
    ttag = np.ones(src.triangle_count, int)
    meshio.write(tmp_path / "faults.msh",
                 meshio.Mesh(pts3, [("line", lines), ("triangle", src.triangles)],
                             cell_data={"gmsh:physical": [ltag, ttag], "gmsh:geometrical": [ltag, ttag]},
                             field_data={"fault": np.array([10, 1]), "joint": np.array([11, 1]),
                                         "rock": np.array([1, 2])}),
                 file_format="gmsh22", binary=False)
    text = ROCK_TOML + """
[[bodies]]
material = "rock"
file = "faults.msh"
cracks = { line_group = "fault" }
fracture = { line_group = "joint" }
velocity = [0.5, 0.0]
angular_velocity = 3.0

[solver]
duration = 1e-3
"""
    sim_toml, _ = _build(tmp_path, text)
    assert (sim_toml.bodies[0].joint_count, sim_toml.bodies[0].crack_count) == (4, 8)
    groups, line_groups = fdem.mesh.load_groups(tmp_path / "faults.msh", lines=True)
    scene = fdem.Scene()
    scene.add_body(fdem.mesh.load(tmp_path / "faults.msh"), fdem.Material(**ROCK, name="rock"),
                   cracks=line_groups["fault"], fracture=line_groups["joint"], velocity=(0.5, 0.0),
                   angular_velocity=3.0)
    sim_py = _quiet(scene.build)
    sim_py.step(10)
    sim_toml.step(10)
    _assert_same(sim_py, sim_toml, "line groups")
    with pytest.raises(SceneFileError, match=r"\[bodies\[0\]\] body 'body0': no line group 'faults' in its mesh "
                                             r"file; its line groups: fault, joint"):
        _build(tmp_path, text.replace('{ line_group = "fault" }', '{ line_group = "faults" }'))


def test_a_plate_with_a_hole(tmp_path):
    text = ROCK_TOML + """
[[bodies]]
material = "rock"
shape = "plate_with_hole"
width = 0.2
height = 0.1
radius = 0.02
h = 0.01

[[loads]]
kind = "traction"
traction = [1e5, 0.0]
xmin = 0.0999

[[constraints]]
xmax = -0.0999
vx = 0.0

[solver]
duration = 1e-3
"""
    sim_toml, _ = _build(tmp_path, text)
    scene = fdem.Scene()
    scene.add_body(fdem.mesh.plate_with_hole(0.2, 0.1, 0.02, 0.01), fdem.Material(**ROCK, name="rock"))
    scene.apply_traction(lambda x, y: x >= 0.0999, (1e5, 0.0))
    scene.fix_nodes(lambda x, y: x <= -0.0999, velocity=(0.0, None))
    sim_py = _quiet(scene.build)
    sim_py.step(10)
    sim_toml.step(10)
    _assert_same(sim_py, sim_toml, "plate with a hole")
    with pytest.raises(SceneFileError, match=r"\[bodies\[0\]\] body 'body0': cannot make its plate_with_hole mesh: "
                                             r"plate_with_hole: the hole"):
        _build(tmp_path, text.replace("radius = 0.02", "radius = 0.06"))

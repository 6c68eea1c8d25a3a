"""Scene files (taichi_fdem.scenefile): the examples build, every key is checked, errors name
the file, the line, the table and the key, and overrides (used by sweeps) apply."""
from __future__ import annotations

import os
import re
import textwrap

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem.io import scenefile
from taichi_fdem.io.scenefile import SceneFileError

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXAMPLES = os.path.join(ROOT, "examples")

BASE = """\
[scene]
gravity = [0.0, -9.81]

[materials.rock]
density = 2000.0
young = 1.0e7
poisson = 0.25
friction = 0.5

[[bodies]]
name = "floor"
material = "rock"
shape = "rectangle"
width = 1.0
height = 0.1
h = 0.1
position = [0.0, -0.05]
fixed = true

[[bodies]]
name = "block"
material = "rock"
shape = "rectangle"
width = 0.2
height = 0.1
h = 0.1
position = [0.0, 0.05]
velocity = [1.0, 0.0]

[solver]
duration = 0.001
"""


def write(tmp_path, text, name="scene.toml"):
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return str(p)


def refused(tmp_path, text, *patterns):
    """Load ``text``; assert it is refused with a message matching every regex of ``patterns``."""
    path = write(tmp_path, text)
    with pytest.raises(SceneFileError) as info:
        scenefile.load(path)
    msg = str(info.value)
    assert msg.startswith(path), msg
    for p in patterns:
        assert re.search(p, msg), f"{p!r} not in {msg!r}"
    return msg


def line_of(text, needle):
    return next(i for i, l in enumerate(text.splitlines(), 1) if needle in l)


# ------------------------------------------------------------------------------------------------
def test_examples_load_and_build():
    for name in ("two_disks", "pile_small", "sliding_block"):
        spec = scenefile.load(os.path.join(EXAMPLES, f"{name}.toml"))
        sim, settings = spec.build()
        assert sim.model.tri_count > 0 and settings.duration > 0
        assert [b.name for b in sim.bodies] == spec.body_names
    spec = scenefile.load(os.path.join(EXAMPLES, "two_disks.toml"))
    sim, settings = spec.build()
    assert settings.video.endswith(".mp4") and settings.color_by == "von_mises"
    assert np.allclose(sim.node_velocities(0), [1.0, 0.0]) and np.allclose(sim.node_velocities(1), 0.0)
    assert np.allclose(sim.scene.gravity, 0.0)
    assert sim.model.materials[0].young == 1.0e7 and sim.model.materials[0].name == "rubber"


def test_base_scene_values(tmp_path):
    spec = scenefile.load(write(tmp_path, BASE))
    assert spec.solver["duration"] == 0.001 and spec.solver["safety"] == 0.2 and spec.solver["dt"] is None
    rock = spec.materials["rock"]
    assert (rock.density, rock.young, rock.friction, rock.penalty) == (2000.0, 1.0e7, 0.5, None)
    assert spec.solver["joined_pairs"] == "joint"
    sim, settings = spec.build()
    assert settings.video is None and settings.duration == 0.001
    assert sim.model.joined_pairs == "joint"
    sim2, _ = scenefile.load(write(tmp_path, BASE + 'joined_pairs = "contact"\n', "b.toml")).build()
    assert sim2.model.joined_pairs == "contact"
    assert spec.solver["handover_damage"] == 0.0 and sim.model.handover_damage == 0.0
    sim3, _ = scenefile.load(write(tmp_path, BASE + 'handover_damage = 0.05\n', "c.toml")).build()
    assert sim3.model.handover_damage == 0.05
    floor, block = sim.bodies
    assert floor.fixed and not block.fixed
    # the block's centroid is placed at (0, 0.05) m
    assert np.allclose(block.mesh.centroid, [0.0, 0.05])
    assert np.allclose(sim.node_velocities(block), [1.0, 0.0])
    assert sim.model.friction


def test_run_settings_run(tmp_path):
    spec = scenefile.load(write(tmp_path, BASE + '\n[output]\nvideo = "%s"\nwidth = 64\nheight = 32\nframe_dt = 0.0005\n'
                                % (tmp_path / "v.gif").as_posix()))
    sim, settings = spec.build()
    settings.run(sim, progress=False)
    assert sim.time == pytest.approx(0.001, abs=sim.dt)
    assert (tmp_path / "v.gif").stat().st_size > 0


def test_constraints_box(tmp_path):
    text = BASE.replace("fixed = true\n", "") + textwrap.dedent("""
        [[constraints]]
        body = "floor"
        ymax = -0.05
        vx = 0.0
        vy = 0.0

        [[constraints]]
        body = "block"
        xmin = 0.09
        vx = 0.5
        """)
    spec = scenefile.load(write(tmp_path, text))
    sim, _ = spec.build()
    floor, block = sim.bodies
    X = floor.mesh.points
    v = sim.node_velocities(floor)
    bottom = X[:, 1] <= -0.05 + 1e-12
    assert bottom.any() and np.allclose(v[bottom], 0.0)
    Xb = block.mesh.points
    right = Xb[:, 0] >= 0.09
    assert right.any() and np.allclose(sim.node_velocities(block)[right, 0], 0.5)
    assert np.allclose(sim.node_velocities(block)[~right], [1.0, 0.0])   # others keep the initial velocity
    sim.step(5)
    assert np.allclose(sim.node_velocities(block)[right, 0], 0.5)       # vy of those nodes stays free
    assert np.allclose(sim.node_velocities(floor)[bottom], 0.0)


def test_mesh_file_body(tmp_path):
    import meshio
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float) * 0.1
    meshio.write(str(tmp_path / "sq.vtu"), meshio.Mesh(pts, [("triangle", np.array([[0, 1, 2], [0, 2, 3]]))]))
    text = BASE.replace('shape = "rectangle"\nwidth = 0.2\nheight = 0.1\nh = 0.1\n', 'file = "sq.vtu"\n')
    spec = scenefile.load(write(tmp_path, text))
    assert spec.bodies[1]["shape"] == "file" and os.path.isabs(spec.bodies[1]["file"])
    sim, _ = spec.build()
    assert sim.bodies[1].mesh.triangle_count == 2
    assert np.allclose(sim.bodies[1].mesh.centroid, [0.0, 0.05])


def test_all_shapes(tmp_path):
    text = BASE + textwrap.dedent("""
        [[bodies]]
        name = "d"
        material = "rock"
        shape = "disk"
        radius = 0.05
        h = 0.025
        position = [-0.3, 0.3]

        [[bodies]]
        name = "a"
        material = "rock"
        shape = "annulus"
        r_inner = 0.03
        r_outer = 0.06
        h = 0.02
        position = [0.3, 0.3]

        [[bodies]]
        name = "p"
        material = "rock"
        shape = "polygon"
        vertices = [[0.0, 0.0], [0.1, 0.0], [0.1, 0.1], [0.0, 0.1]]
        position = [0.0, 0.5]
        rotation = 0.5
        """)
    sim, _ = scenefile.load(write(tmp_path, text)).build()
    assert [b.name for b in sim.bodies] == ["floor", "block", "d", "a", "p"]
    assert sim.bodies[4].mesh.triangle_count == 2          # polygon without h: the vertices alone
    assert abs(sim.bodies[3].mesh.area - np.pi * (0.06 ** 2 - 0.03 ** 2)) < 0.1 * np.pi * 0.06 ** 2


# ------------------------------------------------------------------------------------------------
# bad input: every message names the file, the line, the table and the key
# ------------------------------------------------------------------------------------------------
def test_unknown_key_line_and_suggestion(tmp_path):
    text = BASE.replace("friction = 0.5", "frction = 0.5")
    msg = refused(tmp_path, text, r"\[materials\.rock\]", r"unknown key 'frction'", r"did you mean 'friction'")
    assert msg.split(": ")[0].endswith(f":{line_of(text, 'frction')}")


def test_unknown_key_in_second_body_names_its_line(tmp_path):
    text = BASE.replace('velocity = [1.0, 0.0]', 'velocty = [1.0, 0.0]')
    msg = refused(tmp_path, text, r"\[bodies\[1\]\]", r"did you mean 'velocity'")
    assert f":{line_of(text, 'velocty')}:" in msg


def test_unknown_table(tmp_path):
    text = BASE + "\n[solvr]\ndt = 1e-6\n"
    msg = refused(tmp_path, text, r"unknown key 'solvr'", r"did you mean 'solver'")
    assert f":{line_of(text, '[solvr]')}:" in msg


@pytest.mark.parametrize("old,new,patterns", [
    ("density = 2000.0", 'density = "heavy"', [r"density must be a number \[kg/m³\]"]),
    ("density = 2000.0", "density = true", [r"density must be a number"]),
    ("poisson = 0.25", "poisson = 0.6", [r"\[materials\.rock\]", r"poisson"]),
    ("young = 1.0e7", "young = -1.0", [r"young"]),
    ('position = [0.0, 0.05]', 'position = [0.0]', [r"position must be a pair of finite numbers \[x, y\] \[m\]"]),
    ('position = [0.0, 0.05]', 'position = [0.0, nan]', [r"position must be a pair of finite"]),
    ('h = 0.1\nposition = [0.0, 0.05]', 'h = -0.1\nposition = [0.0, 0.05]', [r"h must be > 0 \[m\]"]),
    ('material = "rock"\nshape = "rectangle"\nwidth = 0.2', 'material = "rocks"\nshape = "rectangle"\nwidth = 0.2',
     [r"unknown material 'rocks'", r"did you mean 'rock'"]),
    ('shape = "rectangle"\nwidth = 0.2', 'shape = "rectangel"\nwidth = 0.2', [r"shape must be one of", "did you mean 'rectangle'"]),
    ('width = 0.2', 'radius = 0.2', [r"'radius' does not apply to 'rectangle'"]),
    ('width = 0.2\n', '', [r"rectangle needs 'width' \[m\]"]),
    ('shape = "rectangle"\nwidth = 0.2', 'shape = "rectangle"\nfile = "x.msh"\nwidth = 0.2', [r"exactly one of shape"]),
    ("duration = 0.001", "dt = 1e-6", [r"\[solver\] missing required key 'duration'"]),
    ("duration = 0.001", "duration = -1.0", [r"duration must be >= 0 \[s\]"]),
    ("duration = 0.001", "duration = 0.001\nsafety = 1.5", [r"safety must be <= 1"]),
    ("duration = 0.001", 'duration = 0.001\nstrategy = "fast"', [r"strategy must be one of 'auto', 'serial', 'parallel'"]),
    ("duration = 0.001", 'duration = 0.001\njoined_pairs = "joints"', [r"joined_pairs must be one of 'joint', 'contact'"]),
    ("duration = 0.001", "duration = 0.001\nhandover_damage = 1.5", [r"handover_damage must be <= 1"]),
    ('name = "block"', 'name = "floor"', [r"body name 'floor' is used twice"]),
    ("fixed = true", "fixed = 1", [r"fixed must be true or false"]),
    ('[scene]\ngravity = [0.0, -9.81]', '[scene]\nplane = "stres"', [r"plane must be one of", "did you mean 'stress'"]),
    ('[scene]\ngravity = [0.0, -9.81]', '[scene]\nthickness = 0', [r"thickness must be > 0 \[m\]"]),
])
def test_bad_values(tmp_path, old, new, patterns):
    assert old in BASE
    text = BASE.replace(old, new, 1)
    refused(tmp_path, text, *patterns)


def test_mesh_file_not_found(tmp_path):
    text = BASE.replace('shape = "rectangle"\nwidth = 0.2\nheight = 0.1\nh = 0.1\n', 'file = "nope.msh"\n')
    msg = refused(tmp_path, text, r"\[bodies\[1\]\]", r"mesh file 'nope.msh' not found", r"relative to the scene file")
    assert f":{line_of(text, 'nope.msh')}:" in msg


def test_bad_mesh_file_is_refused_at_build(tmp_path):
    (tmp_path / "bad.msh").write_text("this is not a mesh\n")
    text = BASE.replace('shape = "rectangle"\nwidth = 0.2\nheight = 0.1\nh = 0.1\n', 'file = "bad.msh"\n')
    spec = scenefile.load(write(tmp_path, text))
    with pytest.raises(SceneFileError, match=r"body 'block': cannot make its file mesh"):
        spec.build()


def test_toml_syntax_error_names_line(tmp_path):
    text = BASE.replace("poisson = 0.25", "poisson = = 0.25")
    refused(tmp_path, text, rf":{line_of(text, 'poisson')}: not valid TOML")


def test_missing_file():
    with pytest.raises(SceneFileError, match=r"nope\.toml: no such file"):
        scenefile.load("nope.toml")


def test_no_bodies_no_materials(tmp_path):
    refused(tmp_path, "[solver]\nduration = 1.0\n", r"no materials")
    refused(tmp_path, "[materials.rock]\ndensity = 1000.0\n[solver]\nduration = 1.0\n", r"no bodies")


def test_constraint_errors(tmp_path):
    refused(tmp_path, BASE + "[[constraints]]\nxmin = 0.0\n", r"give vx and/or vy")
    refused(tmp_path, BASE + "[[constraints]]\nvx = 0.0\n", r"at least one of xmin")
    refused(tmp_path, BASE + '[[constraints]]\nxmin = 0.0\nvx = 0.0\nbody = "blok"\n', r"did you mean 'block'")
    refused(tmp_path, BASE + "[[constraints]]\nxmin = 1.0\nxmax = 0.0\nvx = 0.0\n", r"xmin \(1.0 m\) must be <= xmax")
    text = BASE + "[[constraints]]\nxmin = 5.0\nvx = 0.0\n"
    spec = scenefile.load(write(tmp_path, text))
    with pytest.raises(SceneFileError, match=r"\[constraints\[0\]\] the box selects no node") as info:
        spec.build()
    assert f":{line_of(text, '[[constraints]]')}:" in str(info.value)


def test_dt_above_limit_refused_at_build(tmp_path):
    spec = scenefile.load(write(tmp_path, BASE.replace("duration = 0.001", "duration = 0.001\ndt = 0.01")))
    with pytest.raises(SceneFileError, match=r"\[solver\].*above the estimated stable limit"):
        spec.build()


def test_output_features_that_need_other_modules(tmp_path):
    import importlib.util
    text = BASE + '\n[output]\nvtu = "vtu_out"\n'
    if importlib.util.find_spec("taichi_fdem.io.vtu") is None:
        refused(tmp_path, text, r"\[output\]", r"needs taichi_fdem.io.vtu")
    else:
        assert scenefile.load(write(tmp_path, text)).output["vtu"] == "vtu_out"
    text = BASE + '\n[output]\ncheckpoint = "state.ckpt"\n'
    if not hasattr(fdem.Simulation, "save"):
        refused(tmp_path, text, r"\[output\]", r"need Simulation.save")
    else:
        assert scenefile.load(write(tmp_path, text)).output["checkpoint"] == "state.ckpt"
    refused(tmp_path, BASE + "\n[output]\nvtu_every = 2\n", r"vtu_every needs vtu")
    refused(tmp_path, BASE + '\n[output]\ncolor_by = "sped"\n', r"did you mean 'speed'")


# ------------------------------------------------------------------------------------------------
def test_overrides(tmp_path):
    path = write(tmp_path, BASE)
    spec = scenefile.load(path, overrides={"materials.rock.friction": 0.2, "materials.rock.penalty": 5e8,
                                           "bodies.block.velocity": [2.0, 0.0], "bodies.0.h": 0.05,
                                           "solver.safety": 0.1, "scene.gravity": [0.0, -1.0]})
    assert spec.materials["rock"].friction == 0.2 and spec.materials["rock"].penalty == 5e8
    assert spec.bodies[1]["velocity"] == (2.0, 0.0) and spec.bodies[0]["h"] == 0.05
    assert spec.solver["safety"] == 0.1 and spec.scene["gravity"] == (0.0, -1.0)
    # the file itself is unchanged
    assert scenefile.load(path).materials["rock"].friction == 0.5
    with pytest.raises(SceneFileError, match=r"override 'materials.rok.friction'.*did you mean 'rock'"):
        scenefile.load(path, overrides={"materials.rok.friction": 0.2})
    with pytest.raises(SceneFileError, match=r"override 'bodies.blok.velocity'.*did you mean 'block'"):
        scenefile.load(path, overrides={"bodies.blok.velocity": [1.0, 0.0]})
    with pytest.raises(SceneFileError, match=r"override 'materials.rock.frict'.*unknown key 'frict'.*did you mean 'friction'"):
        scenefile.load(path, overrides={"materials.rock.frict": 0.2})
    with pytest.raises(SceneFileError, match=r"override 'materials.rock.friction'.*friction must be a number"):
        scenefile.load(path, overrides={"materials.rock.friction": "high"})


def test_spec_pickles(tmp_path):
    import pickle
    spec = scenefile.load(write(tmp_path, BASE + "[[constraints]]\nymax = -0.09\nvy = 0.0\n"))
    again = pickle.loads(pickle.dumps(spec))
    assert again.body_names == spec.body_names and again.materials["rock"] == spec.materials["rock"]


def test_docstring_lists_every_key():
    doc = scenefile.__doc__
    for schema in (scenefile.SCENE_KEYS, scenefile.MATERIAL_KEYS, scenefile.BODY_KEYS, scenefile.CONSTRAINT_KEYS,
                   scenefile.FLUID_KEYS, scenefile.INJECT_KEYS, scenefile.TEMPERATURE_KEYS, scenefile.HEAT_KEYS,
                   scenefile.SOLVER_KEYS, scenefile.OUTPUT_KEYS):
        for key, spec in schema.items():
            assert re.search(rf"\b{key}\b", doc), f"{key} is not documented"
            if spec.unit and spec.unit not in ("1/s", "px"):
                assert spec.unit in doc


# ------------------------------------------------------------------------------------------------
# values no one means: huge, subnormal, out-of-range (issue 12: mutants that crashed)
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("old,new,key", [
    ("width = 1.2", "width = 1e308", "width"),
    ("h = 0.05\nposition = [0.0, -0.025]", "h = 1e-320\nposition = [0.0, -0.025]", "h"),
    ("young = 1.0e7", "young = 1e308", "young"),
    ("density = 1000.0", "density = 1e308", "density"),
    ("gravity = [0.0, -9.81]", "gravity = [1e308, 0.0]", "gravity"),
    ("velocity = [1.0, 0.0]", "velocity = [1e308, 0.0]", "velocity"),
    ("position = [-0.45, 0.025]", "position = [1e308, 0.025]", "position"),
    ("duration = 0.6", "duration = 1e308", "duration"),
])
def test_absurd_values_refused(tmp_path, old, new, key):
    text = open(os.path.join(EXAMPLES, "sliding_block.toml")).read()
    text = re.sub(r"[ \t]*#[^\n]*", "", text)            # strip comments so that old matches exactly
    assert old in text, old
    p = tmp_path / "s.toml"
    p.write_text(text.replace(old, new, 1))
    with _no_overflow_warning():
        with pytest.raises(ValueError, match=key):
            scenefile.load(p).build()


class _no_overflow_warning:
    """Turn NumPy's overflow / invalid-value RuntimeWarnings into errors inside the block."""

    def __enter__(self):
        import warnings
        self._cm = warnings.catch_warnings()
        self._cm.__enter__()
        for msg in ("overflow", "invalid value", "divide by zero"):
            warnings.filterwarnings("error", message=f".*{msg}.*")
        warnings.filterwarnings("ignore", message="bodies overlap")
        return self

    def __exit__(self, *exc):
        return self._cm.__exit__(*exc)


_FUZZ_VALUES = ["0", "-1.0", "1e308", "-1e308", "1e-320", "5e-324", "inf", "-inf", "nan", "\"x\"", "true", "[]",
                "[1.0]", "[1e308, 1e308]", "[[0.0, 0.0], [1e308, 0.0], [0.0, 1e308]]", "{}", "1e30", "1e-30",
                "12345678901234567890", "-0.0", "2", "0.5", "1e6"]


def _mutants(text, rng, n):
    """n careless edits of a scene file: bad values, dropped, duplicated and unknown keys, truncation."""
    lines = text.splitlines()
    kv = [i for i, line in enumerate(lines) if re.match(r"^\s*[A-Za-z_]+\s*=", line)]
    heads = [i for i, line in enumerate(lines) if line.strip().startswith("[")]
    for _ in range(n):
        kind = rng.choice(["value", "value", "value", "drop", "dup", "unknown", "trunc"])
        out = list(lines)
        if kind == "value":
            i = rng.choice(kv)
            out[i] = f"{out[i].split('=')[0]}= {rng.choice(_FUZZ_VALUES)}"
        elif kind == "drop":
            del out[rng.choice(kv)]
        elif kind == "dup":
            i = rng.choice(kv + heads)
            out.insert(i + 1, out[i])
        elif kind == "unknown":
            out.insert(rng.choice(heads) + 1, f"{rng.choice(['hh', 'densty', 'foo', 'Young', 'widht'])} = 1.0")
        else:
            whole = "\n".join(out)
            yield kind, whole[:rng.randrange(len(whole))]
            continue
        yield kind, "\n".join(out)


def test_fuzzed_scene_files_build_or_refuse_clearly(tmp_path):
    """200 seeded mutants of examples/*.toml: each builds, or is refused with a ValueError
    (SceneFileError) carrying a message; never another exception, never an overflow warning."""
    import random
    rng = random.Random(12)
    files = [f for f in sorted(os.listdir(EXAMPLES)) if f.endswith(".toml") and not f.startswith("sweep")]
    outcomes = {"built": 0, "refused": 0}
    for k in range(200):
        name = files[k % len(files)]
        text = open(os.path.join(EXAMPLES, name)).read()
        kind, mutant = next(_mutants(text, rng, 1))
        p = tmp_path / f"m{k}.toml"
        p.write_text(mutant)
        with _no_overflow_warning():
            try:
                scenefile.load(p).build()
                outcomes["built"] += 1
            except ValueError as exc:
                assert str(exc).strip(), f"{name} mutant {k} ({kind}): empty message"
                outcomes["refused"] += 1
            except Exception as exc:                    # pragma: no cover - the failure being tested
                pytest.fail(f"{name} mutant {k} ({kind}) raised {type(exc).__name__}: {exc}\n{mutant}")
    assert outcomes["refused"] > 100 and outcomes["built"] > 0, outcomes


# ------------------------------------------------------------------------------------------------
FRACTURE = """\
[scene]
gravity = [0.0, -9.81]

[materials.rock]
density = 2500.0
young = 1e8
friction = 0.5
tensile_strength = 1e5
fracture_energy = 10.0
cohesion = 2e5

[[bodies]]
name = "slab"
material = "rock"
shape = "polygon"
vertices = [[0.0, 0.0], [0.4, 0.0], [0.4, 0.2], [0.0, 0.2]]
h = 0.05
position = [1.0, 0.5]
fracture = true
cracks = [[[0.0, 0.05], [0.4, 0.15]]]
crack_friction = 0.3
weibull_modulus = 5.0
strength_seed = 3

[solver]
duration = 0.001
"""


def test_fracture_cracks_and_strength_from_a_scene_file(tmp_path):
    import math
    spec = scenefile.load(write(tmp_path, FRACTURE))
    scene, bodies = spec.build_scene()
    slab = bodies["slab"]
    # the crack runs corner to corner of the polygon's sides (length √(0.4² + 0.1²)), moved with the body
    u, v, *_ = slab.edge_table
    pts = slab.source_mesh.points
    L = np.linalg.norm(pts[u[slab.crack_mask]] - pts[v[slab.crack_mask]], axis=1).sum()
    assert L == pytest.approx(math.hypot(0.4, 0.1), rel=1e-9)
    assert slab.crack_count > 0 and slab.fracture and slab.crack_friction == 0.3
    # joint strengths: Weibull draws around f_t, c scaled by the same factor, reproducible by seed
    ft = slab.joint_prop[:, 0]
    np.testing.assert_allclose(slab.joint_prop[:, 1] / ft, 2.0)
    assert ft.std() > 0.05 * 1e5
    again = scenefile.load(write(tmp_path, FRACTURE, "again.toml")).build_scene()[1]["slab"]
    np.testing.assert_array_equal(again.joint_prop, slab.joint_prop)
    refused(tmp_path, FRACTURE.replace("tensile_strength = 1e5\n", ""), r"joints need tensile_strength")
    refused(tmp_path, FRACTURE.replace("strength_seed = 3", "strength_cov = 0.2"), r"either weibull_modulus or")
    refused(tmp_path, FRACTURE.replace("[[[0.0, 0.05], [0.4, 0.15]]]", "[[0.0, 0.05]]"), r"cracks must be a list of polylines")

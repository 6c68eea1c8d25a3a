"""Every example of the guide that builds a scene is also a scene file (examples/guide/), and
the two build the same simulation: the Python of the page (its ```python block, run up to
``scene.build``) and the file (``scenefile.load(...).build()``) are stepped alike and every
Taichi array of the model and of the state (positions, velocities, forces, joint state, ...)
must be equal bit for bit, as must the time step, the energies and the simulated time.

The examples run at their own sizes (the largest, the README's, has about 900 triangles).
The lab example runs its whole test both ways and compares the curves and the summary.
``fdem.init`` lines are left out of the page's code: Taichi is initialised once per test run
(conftest.py, CPU and f64, what the examples ask for).
"""
from __future__ import annotations

import math
import os
import re
import warnings

import numpy as np
import pytest

from taichi_fdem.io import scenefile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GUIDE = os.path.join(ROOT, "examples", "guide")
_FENCE = re.compile(r"^```python[^\n]*\n(.*?)^```\s*$", re.S | re.M)

#: (page, index of its ```python block, scene file, steps compared)
EXAMPLES = [
    ("README.md", 0, "readme.toml", 20),
    ("docs/getting_started.md", 0, "getting_started_1.toml", 20),
    ("docs/getting_started.md", 1, "getting_started_2.toml", 20),
    ("docs/guide/checkpoints.md", 0, "checkpoints.toml", 20),
    ("docs/guide/fluid.md", 0, "fluid.toml", 20),
    ("docs/guide/fracture.md", 0, "fracture.toml", 10),
    ("docs/guide/heat.md", 0, "heat.toml", 20),
    ("docs/guide/loads.md", 0, "loads_lame.toml", 20),
    ("docs/guide/loads.md", 1, "loads_bar.toml", 20),
    ("docs/guide/outputs.md", 0, "outputs_recorders.toml", 20),
    ("docs/guide/outputs.md", 1, "outputs_vtu.toml", 20),
    ("docs/guide/outputs.md", 2, "outputs_body_motion.toml", 20),
    ("docs/guide/anisotropy.md", 0, "anisotropy.toml", 20),
    ("docs/guide/anisotropy.md", 1, "anisotropy_strength.toml", 20),
    ("docs/guide/anisotropy.md", 2, "anisotropy_planes.toml", 20),
]
#: blocks of the guide that build no scene: a material, meshes, an envelope fit
NO_SCENE = [("docs/guide/materials.md", 0), ("docs/guide/meshes.md", 0), ("docs/guide/meshes.md", 1),
            ("docs/guide/calibration.md", 0)]
LAB = ("docs/guide/lab.md", 0, "lab_ucs.toml")


def _block(page: str, index: int) -> str:
    text = open(os.path.join(ROOT, page), encoding="utf-8").read()
    return _FENCE.findall(text)[index]


def _run_python(page: str, index: int, stop: str) -> dict:
    """The namespace of the page's block run up to (and including) the first line that starts
    with ``stop`` (the whole block when none does), without its ``fdem.init`` lines."""
    lines = _block(page, index).splitlines()
    end = next((i + 1 for i, line in enumerate(lines) if line.startswith(stop)), len(lines))
    code = "\n".join(line for line in lines[:end] if not line.startswith("fdem.init("))
    ns: dict = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        exec(compile(code, f"{page} block {index}", "exec"), ns)
    return ns


def _arrays(sim) -> dict:
    out = {}
    for kind, bag in (("model", sim.model), ("state", sim.state)):
        for name, arr in bag.ndarrays().items():
            out[f"{kind}.{name}"] = arr.to_numpy()
    return out


def _assert_same(a, b, what: str) -> None:
    assert a.dt == b.dt, f"{what}: dt {a.dt!r} != {b.dt!r}"
    assert a.step_count == b.step_count and a.time == b.time
    xa, xb = _arrays(a), _arrays(b)
    assert xa.keys() == xb.keys(), f"{what}: arrays {sorted(set(xa) ^ set(xb))} in one build only"
    bad = [k for k in xa if xa[k].shape != xb[k].shape or not np.array_equal(xa[k], xb[k], equal_nan=True)]
    assert not bad, f"{what}: arrays that differ: {bad}"
    ea, eb = a.energies(), b.energies()
    assert ea.keys() == eb.keys()
    assert all(ea[k] == eb[k] or (math.isnan(ea[k]) and math.isnan(eb[k])) for k in ea), (what, ea, eb)


@pytest.mark.parametrize("page,index,toml,steps", EXAMPLES, ids=[e[2][:-5] for e in EXAMPLES])
def test_guide_example_as_a_scene_file(page, index, toml, steps):
    ns = _run_python(page, index, "sim = scene.build(")
    sim_py = ns["sim"] if "sim" in ns else ns["scene"].build()
    spec = scenefile.load(os.path.join(GUIDE, toml))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        sim_toml, settings = spec.build()
    _assert_same(sim_py, sim_toml, f"{toml} at the start")
    assert sim_toml.model.node_count > 0 and len(sim_py.bodies) == len(sim_toml.bodies)
    for b_py, b_toml in zip(sim_py.bodies, sim_toml.bodies):
        assert (b_py.nodes, b_py.triangles, b_py.joint_count) == (b_toml.nodes, b_toml.triangles, b_toml.joint_count)
    sim_py.step(steps)
    sim_toml.step(steps)
    _assert_same(sim_py, sim_toml, f"{toml} after {steps} steps")
    moved = np.abs(sim_toml.state.node_x.to_numpy() - sim_toml.model.node_rest).max()
    assert moved > 0 or toml == "fluid.toml", f"{toml}: nothing moved in {steps} steps"


def test_the_guide_lab_example_as_a_scene_file(tmp_path, monkeypatch):
    """The lab example: the page's ``fdem.lab.ucs`` call and the file's [lab] give the same curve
    and summary, bit for bit."""
    monkeypatch.chdir(tmp_path)
    page, index, toml = LAB
    r_py = _run_python(page, index, "r = fdem.lab.ucs(")["r"]
    spec = scenefile.load(os.path.join(GUIDE, toml))
    r_toml = spec.run_lab()
    assert r_py.curve.keys() == r_toml.curve.keys()
    for k in r_py.curve:
        assert np.array_equal(np.asarray(r_py.curve[k]), np.asarray(r_toml.curve[k]), equal_nan=True), k
    assert r_py.summary.keys() == r_toml.summary.keys()
    for k, v in r_py.summary.items():
        if k in ("wall", "build"):          # wall-clock times of the run and the build
            continue
        w = r_toml.summary[k]
        assert v == w or (isinstance(v, float) and math.isnan(v) and math.isnan(w)), (k, v, w)
    assert os.path.getsize(tmp_path / "ucs.csv") > 0


def test_every_scene_block_of_the_guide_has_its_scene_file():
    """The guide's ```python blocks are all listed here: each one that builds a Scene (or runs a
    lab test) has a scene file in examples/guide/, and every file there is one of them."""
    pages = ["README.md", "docs/getting_started.md"] + sorted(
        os.path.join("docs", "guide", f) for f in os.listdir(os.path.join(ROOT, "docs", "guide")) if f.endswith(".md"))
    listed = {(p, i) for p, i, _, _ in EXAMPLES} | set(NO_SCENE) | {LAB[:2]}
    found = set()
    for page in pages:
        for i, block in enumerate(_FENCE.findall(open(os.path.join(ROOT, page), encoding="utf-8").read())):
            found.add((page, i))
            code = "\n".join(line.split("#")[0] for line in block.splitlines())      # comments left out
            builds = "fdem.Scene(" in code or "fdem.lab." in code
            assert builds == ((page, i) not in NO_SCENE), f"{page} block {i}: a scene block without a scene file"
    assert found == listed, f"blocks not listed: {sorted(found - listed)}; listed, not found: {sorted(listed - found)}"
    files = {e[2] for e in EXAMPLES} | {LAB[2]}
    assert files == {f for f in os.listdir(GUIDE) if f.endswith(".toml")}

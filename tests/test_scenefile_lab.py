"""Scene files express the options of a lab run: [solver] quasi_static, [output] history."""
import os

import pytest

from taichi_fdem.io import scenefile
from taichi_fdem.io.scenefile import SceneFileError

from test_scenefile import BASE, write


def test_quasi_static_and_history_reach_the_run(tmp_path):
    text = BASE + "quasi_static = 0.7\n\n[output]\nhistory = \"h.csv\"\nhistory_every = 5\n"
    spec = scenefile.load(write(tmp_path, text))
    sim, settings = spec.build()
    assert sim.model.qs_alpha == pytest.approx(0.7)
    assert settings.history == "h.csv" and settings.history_every == 5
    settings.history = str(tmp_path / "h.csv")
    settings.run(sim, progress=False)
    assert os.path.getsize(tmp_path / "h.csv") > 0


def test_misspelt_keys_get_did_you_mean(tmp_path):
    with pytest.raises(SceneFileError, match="did you mean 'quasi_static'"):
        scenefile.load(write(tmp_path, BASE + "quasi_statc = 0.7\n"))
    with pytest.raises(SceneFileError, match="history_every needs history"):
        scenefile.load(write(tmp_path, BASE + "\n[output]\nhistory_every = 5\n"))


LAB = """\
[materials.rock]
density = 2600.0
young = 20e9
poisson = 0.2

[lab]
test = "ucs"
material = "rock"
width = 0.05
height = 0.1
h = 0.0125
rate_transits = 30
samples = 40
csv = "{csv}"
"""


def test_a_lab_section_runs_the_test_from_the_cli(tmp_path, capsys):
    """An elastic UCS from a [lab] file: the CLI prints the summary, which returns the material's E and ν
    (the same check as tests/test_lab.py), and writes the curve."""
    from taichi_fdem import cli
    csv = tmp_path / "out" / "ucs.csv"
    path = write(tmp_path, LAB.format(csv=csv))
    spec = scenefile.load(path)
    assert spec.lab["test"] == "ucs" and spec.lab["rate_transits"] == 30
    assert cli.main(["run", path]) == 0
    out = capsys.readouterr().out
    young = float(next(line.split()[1] for line in out.splitlines() if line.strip().startswith("young ")))
    poisson = float(next(line.split()[1] for line in out.splitlines() if line.strip().startswith("poisson ")))
    assert abs(young / 20e9 - 1) < 0.02 and abs(poisson / 0.2 - 1) < 0.02, out
    assert os.path.getsize(csv) > 0
    with pytest.raises(ValueError, match="run_lab"):
        spec.build()


def test_lab_section_keys_are_checked(tmp_path):
    base = LAB.format(csv="x.csv")
    with pytest.raises(SceneFileError, match="'diameter' does not apply to the 'ucs' test"):
        scenefile.load(write(tmp_path, base + "diameter = 0.05\n"))
    with pytest.raises(SceneFileError, match="'brazilian' test needs 'diameter'"):
        scenefile.load(write(tmp_path, base.replace('"ucs"', '"brazilian"').replace("width = 0.05\nheight = 0.1\n", "")
                             .replace("rate_transits = 30\n", "")))
    with pytest.raises(SceneFileError, match="'triaxial' test needs 'confinement'"):
        scenefile.load(write(tmp_path, base.replace('"ucs"', '"triaxial"')))
    with pytest.raises(SceneFileError, match="unknown material 'granit'"):
        scenefile.load(write(tmp_path, base.replace('material = "rock"', 'material = "granit"')))
    with pytest.raises(SceneFileError, match="did you mean 'rate_transits'"):
        scenefile.load(write(tmp_path, base.replace("rate_transits", "rate_transit")))
    with pytest.raises(SceneFileError, match="has no \\[solver\\]"):
        scenefile.load(write(tmp_path, base + "\n[solver]\nduration = 1.0\n"))
    with pytest.raises(SceneFileError, match="needs tensile_strength"):
        scenefile.load(write(tmp_path, base.replace('"ucs"', '"brazilian"').replace("width = 0.05\nheight = 0.1\n",
                                                                                   "diameter = 0.05\n")
                             .replace("rate_transits = 30\n", "")))


def test_lab_direct_shear_takes_joint(tmp_path):
    text = LAB.format(csv="x.csv").replace('"ucs"', '"direct_shear"')
    text = text.replace("h = 0.0125", "h = 0.0125\nnormal_stress = 1e6\njoint = true")
    spec = scenefile.load(write(tmp_path, text))
    assert spec.lab["joint"] is True and spec.lab["normal_stress"] == 1e6
    with pytest.raises(SceneFileError, match="'joint' does not apply to the 'ucs' test"):
        scenefile.load(write(tmp_path, LAB.format(csv="x.csv") + "joint = true\n"))

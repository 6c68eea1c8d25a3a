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

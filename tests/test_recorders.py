"""run(duration, record=[...]): recorders write at the start, on their own schedule and at the
end; the keywords of version 0.1.0 map onto them with a DeprecationWarning; recording never
changes the results."""
from __future__ import annotations

import csv
import warnings

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem.sim.recorders import Recorder


def falling_ball():
    scene = fdem.Scene(gravity=(0.0, -9.81))
    rock = fdem.Material(density=2600.0, young=1e8, poisson=0.25)
    scene.add_body(fdem.mesh.rectangle(0.4, 0.05, 0.025), rock, fixed=True, position=(0.0, -0.025))
    ball = scene.add_body(fdem.mesh.disk(0.03, 0.01), rock, position=(0.0, 0.04))
    return scene.build(), ball


class Counting(Recorder):
    def __init__(self, frame_dt=None, every=None):
        self.frame_dt, self.every = frame_dt, every
        self.calls = {"open": 0, "after_steps": 0, "row": [], "frame": [], "close": 0}

    def open(self, sim, steps, duration):
        self.calls["open"] += 1
        self.steps = steps

    def after_steps(self, sim, done):
        self.calls["after_steps"] += 1

    def row(self, sim, done):
        self.calls["row"].append(done)

    def frame(self, sim, done):
        self.calls["frame"].append(done)

    def close(self):
        self.calls["close"] += 1


def test_custom_recorder_sees_its_schedule():
    sim, _ = falling_ball()
    n = 100
    rows, frames = Counting(every=30), Counting(frame_dt=25 * sim.dt)
    sim.run(n * sim.dt, record=[rows, frames], progress=False)
    assert rows.steps == n and rows.calls["open"] == 1 and rows.calls["close"] == 1
    assert rows.calls["row"] == [30, 60, 90, 100]
    assert frames.calls["frame"] == [25, 50, 75, 100]
    assert rows.calls["after_steps"] >= 4


def test_recorders_are_closed_when_the_run_fails():
    sim, _ = falling_ball()
    rec = Counting(every=10)

    def boom(s):
        raise RuntimeError("stop")
    with pytest.raises(RuntimeError, match="stop"):
        sim.run(50 * sim.dt, record=[rec], callback=boom, progress=False)
    assert rec.calls["open"] == 1 and rec.calls["close"] == 1


def test_history_and_crack_files(tmp_path):
    sim, ball = falling_ball()
    path = tmp_path / "h.csv"
    sim.run(90 * sim.dt, record=[fdem.History(path, every=20), fdem.CrackEvents(tmp_path / "c.csv")], progress=False)
    rows = list(csv.DictReader(open(path)))
    assert [int(r["step"]) for r in rows] == [0, 20, 40, 60, 80, 90]
    assert (tmp_path / "c.csv").read_text().startswith("joint,time_s")


def test_recording_does_not_change_the_results(tmp_path):
    a, _ = falling_ball()
    b, _ = falling_ball()
    a.run(300 * a.dt, progress=False)
    b.run(300 * b.dt, record=[fdem.History(tmp_path / "h.csv", every=7), Counting(frame_dt=13 * b.dt)],
          progress=False)
    np.testing.assert_array_equal(a.node_positions(), b.node_positions())
    np.testing.assert_array_equal(a.node_velocities(), b.node_velocities())


def test_legacy_keywords_warn_and_do_the_same(tmp_path):
    new, _ = falling_ball()
    old, _ = falling_ball()
    new.run(60 * new.dt, record=[fdem.History(tmp_path / "new.csv", every=20)],
            checks=fdem.Checks(max_penetration=None), progress=False)
    with pytest.deprecated_call(match="record="):
        old.run(60 * old.dt, history=str(tmp_path / "old.csv"), history_every=20, max_penetration=None,
                progress=False)
    assert (tmp_path / "new.csv").read_text() == (tmp_path / "old.csv").read_text()
    np.testing.assert_array_equal(new.node_positions(), old.node_positions())


def test_bad_arguments_raise_early(tmp_path):
    sim, _ = falling_ball()
    with pytest.raises(TypeError, match=r"record\[1\]"):
        sim.run(sim.dt, record=[fdem.History(tmp_path / "h.csv"), "not a recorder"], progress=False)
    assert not (tmp_path / "h.csv").exists()
    with pytest.raises(TypeError, match="unexpected keyword"):
        sim.run(sim.dt, vidoe="x.mp4")
    with pytest.raises(TypeError, match="Checks"):
        sim.run(sim.dt, checks={"energy": False})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        with pytest.raises(ValueError, match="history_every"):
            sim.run(sim.dt, history_every=5)
        with pytest.raises(ValueError, match="fps"):
            sim.run(sim.dt, fps=60)
        with pytest.raises(TypeError, match="not both"):
            sim.run(sim.dt, checks=fdem.Checks(), energy_tol=0.2)
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="energy_tol"):
            fdem.Checks(energy_tol=bad)
    with pytest.raises(ValueError, match="every"):
        fdem.Checks(every=0)
    with pytest.raises(ValueError, match="every"):
        fdem.History(tmp_path / "x.csv", every=0)
    with pytest.raises(ValueError, match="frame_dt"):
        fdem.Video(tmp_path / "x.mp4", frame_dt=-1.0)
    with pytest.raises(ValueError, match="frame_dt"):
        fdem.export.VTU(tmp_path / "v", frame_dt=0.0)


def test_vtu_and_video_recorders(tmp_path):
    sim, _ = falling_ball()
    vtu = fdem.export.VTU(tmp_path / "vtu", frame_dt=20 * sim.dt)
    sim.run(60 * sim.dt, record=[vtu, fdem.Video(tmp_path / "png", frame_dt=30 * sim.dt)], progress=False)
    assert vtu.exporter.frame_count == 4                    # t = 0, 20, 40, 60 steps
    assert len(list((tmp_path / "png").glob("*.png"))) == 3  # t = 0, 30, 60 steps
    sim.run(20 * sim.dt, record=[vtu], progress=False)      # the series goes on, no repeated frame
    times = [t for t, _ in vtu.exporter.frames]
    assert len(times) == 5 and len(set(times)) == 5

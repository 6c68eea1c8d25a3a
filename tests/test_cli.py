"""The taichi-fdem command line: run, sweep, demo, info; exit codes 0 / 1 / 2 and clear messages."""
from __future__ import annotations

import csv
import os
import subprocess
import sys
import textwrap

import pytest

from taichi_fdem import cli

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TWO_DISKS = os.path.join(ROOT, "examples", "two_disks.toml")

SLIDE = """\
[materials.rock]
density = 1000.0
young = 1.0e7
friction = 0.3

[[bodies]]
name = "floor"
material = "rock"
shape = "rectangle"
width = 0.6
height = 0.05
h = 0.05
position = [0.0, -0.025]
fixed = true

[[bodies]]
name = "block"
material = "rock"
shape = "rectangle"
width = 0.1
height = 0.05
h = 0.05
position = [0.0, 0.025]
velocity = [1.0, 0.0]

[solver]
duration = 0.005
"""


def run(capsys, *argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_info(capsys):
    code, out, err = run(capsys, "info")
    assert code == 0
    import taichi_fdem
    assert f"taichi_fdem   {taichi_fdem.__version__}" in out
    assert "taichi        1.7" in out and "arch          cpu" in out and "precision     f64" in out
    assert "cpu threads" in out


def test_run_example(capsys, tmp_path):
    video = tmp_path / "v.gif"
    code, out, err = run(capsys, "run", TWO_DISKS, "--duration", "0.002", "--video", str(video), "--no-progress")
    assert code == 0, err
    assert "two_disks.toml: 2 bodies" in out
    import re
    assert float(re.search(r"done: t = ([0-9.e+-]+) s", out).group(1)) == pytest.approx(0.002, abs=3e-5)
    assert "kinetic" in out and "total" in out and f"wrote video: {video}" in out
    assert video.stat().st_size > 0


def test_run_no_video_and_outputs_of_the_file(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)                        # output paths are relative to the working directory
    (tmp_path / "s.toml").write_text(SLIDE + '\n[output]\nvideo = "out/s.gif"\nwidth = 64\nheight = 32\n')
    code, out, err = run(capsys, "run", "s.toml", "--no-video", "--no-progress")
    assert code == 0, err
    assert not (tmp_path / "out").exists() and "wrote video" not in out
    code, out, err = run(capsys, "run", "s.toml", "--no-progress")
    assert code == 0, err
    assert (tmp_path / "out" / "s.gif").stat().st_size > 0


def test_run_vtu(capsys, tmp_path):
    import importlib.util
    if importlib.util.find_spec("taichi_fdem.io.vtu") is None:
        code, out, err = run(capsys, "run", TWO_DISKS, "--vtu", str(tmp_path / "vtu"), "--no-video")
        assert code == 2 and "needs taichi_fdem.io.vtu" in err
        return
    (tmp_path / "s.toml").write_text(SLIDE + f'\n[output]\nvtu = "{(tmp_path / "vtu").as_posix()}"\nframe_dt = 0.001\n')
    code, out, err = run(capsys, "run", str(tmp_path / "s.toml"), "--no-progress")
    assert code == 0, err
    files = sorted(os.listdir(tmp_path / "vtu"))
    assert any(f.endswith(".pvd") for f in files)
    assert sum(f.endswith(".vtu") for f in files) == 6           # t = 0 and 5 frames of 1 ms


def test_run_bad_input_exit_2(capsys, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(SLIDE.replace("friction = 0.3", "frictoin = 0.3"))
    code, out, err = run(capsys, "run", str(bad))
    assert code == 2
    assert f"{bad}:4: [materials.rock] unknown key 'frictoin' (did you mean 'friction'?)" in err
    assert "Traceback" not in err
    code, out, err = run(capsys, "run", str(tmp_path / "missing.toml"))
    assert code == 2 and "missing.toml: no such file" in err
    code, out, err = run(capsys, "run", TWO_DISKS, "--duration", "-1")
    assert code == 2 and "--duration must be a finite time >= 0 s" in err
    dt = tmp_path / "dt.toml"
    dt.write_text(SLIDE.replace("duration = 0.005", "duration = 0.005\ndt = 0.01"))
    code, out, err = run(capsys, "run", str(dt))
    assert code == 2 and "[solver]" in err and "stable limit" in err


def test_run_unstable_exit_1(capsys, tmp_path):
    p = tmp_path / "unstable.toml"
    p.write_text(SLIDE.replace("duration = 0.005", "duration = 0.02\ndt = 0.002\nforce_dt = true"))
    code, out, err = run(capsys, "run", str(p), "--no-progress")
    assert code == 1
    assert "the simulation failed" in err and "Suggested time step" in err and "Traceback" not in err


def test_demo_list_and_unknown(capsys):
    code, out, err = run(capsys, "demo")
    assert code == 0 and "two_disks" in out and "pile" in out and "_common" not in out
    code, out, err = run(capsys, "demo", "two_disk")
    assert code == 2 and "no demo named 'two_disk' (did you mean 'two_disks'?)" in err


def test_demo_runs(capsys, tmp_path):
    out_video = tmp_path / "d.mp4"
    code, out, err = run(capsys, "demo", "two_disks", "--short", "--out", str(out_video))
    assert code == 0, err
    assert "two_disks:" in out and out_video.stat().st_size > 0


def test_sweep(capsys, tmp_path):
    (tmp_path / "slide.toml").write_text(SLIDE)
    sw = tmp_path / "sw.toml"
    sw.write_text(textwrap.dedent("""
        [sweep]
        scene = "slide.toml"
        metrics = ["time", "velocity:block"]
        workers = 2

        [[sweep.points]]
        "solver.dt" = 1.0e-5
        "solver.force_dt" = false

        [[sweep.points]]
        "solver.dt" = 2.0e-3          # far above the stable limit: unstable
        "solver.force_dt" = true
        """))
    csv_path = tmp_path / "r.csv"
    code, out, err = run(capsys, "sweep", str(sw), "--output", str(csv_path))
    assert code == 1                                   # a point did not succeed
    assert "2 points on 2 local worker processes" in out and "1 ok, 1 not ok" in out
    rows = list(csv.DictReader(open(csv_path)))
    assert sorted(r["status"] for r in rows) == ["ok", "unstable"]
    ok = next(r for r in rows if r["status"] == "ok")
    # the block slides on the floor under Coulomb friction: v(t) = v0 − μ g t (analytic); the
    # velocity lost to friction, μ g t = 0.0147 m/s, within 10 %
    t = float(ok["time"])
    assert t == pytest.approx(0.005)
    assert float(ok["block_vx"]) == pytest.approx(1.0 - 0.3 * 9.81 * t, abs=0.1 * 0.3 * 9.81 * t)
    bad = tmp_path / "bad.toml"
    bad.write_text('[sweep]\nscene = "slide.toml"\n[sweep.axes]\n"materials.rock.frction" = [0.1]\n')
    code, out, err = run(capsys, "sweep", str(bad))
    assert code == 2 and "did you mean 'friction'" in err and "Traceback" not in err
    code, out, err = run(capsys, "sweep", str(sw), "--workers", "0")
    assert code == 2 and "--workers must be >= 1" in err


def test_console_script_process():
    """The installed entry point and the real process exit codes (no traceback on bad input)."""
    from importlib.metadata import entry_points
    scripts = {e.name: e.value for e in entry_points(group="console_scripts")}
    assert scripts.get("taichi-fdem") == "taichi_fdem.cli:main"
    p = subprocess.run([sys.executable, "-m", "taichi_fdem.cli", "run", "nope.toml"], capture_output=True, text=True)
    assert p.returncode == 2 and "nope.toml: no such file" in p.stderr and "Traceback" not in p.stderr
    p = subprocess.run([sys.executable, "-m", "taichi_fdem.cli", "run", "--help"], capture_output=True, text=True)
    assert p.returncode == 0 and "--duration" in p.stdout and "SCENE.toml" in p.stdout
    p = subprocess.run([sys.executable, "-m", "taichi_fdem.cli", "bogus"], capture_output=True, text=True)
    assert p.returncode == 2 and "invalid choice" in p.stderr


def test_run_checkpoint(capsys, tmp_path):
    import taichi_fdem as fdem
    if not hasattr(fdem.Simulation, "save"):
        (tmp_path / "s.toml").write_text(SLIDE + '\n[output]\ncheckpoint = "c.ckpt"\n')
        code, out, err = run(capsys, "run", str(tmp_path / "s.toml"))
        assert code == 2 and "need Simulation.save" in err
        return
    ck = tmp_path / "ck" / "s.ckpt"
    (tmp_path / "s.toml").write_text(SLIDE + f'\n[output]\ncheckpoint = "{ck.as_posix()}"\n')
    code, out, err = run(capsys, "run", str(tmp_path / "s.toml"), "--no-progress")
    assert code == 0, err
    assert f"wrote checkpoint: {ck.as_posix()}" in out
    sim = fdem.Simulation.load(str(ck))
    assert sim.time == pytest.approx(0.005, abs=sim.dt) and [b.name for b in sim.bodies] == ["floor", "block"]
    # continue from it: the run starts where the checkpoint ended
    (tmp_path / "s2.toml").write_text(SLIDE)
    code, out, err = run(capsys, "run", str(tmp_path / "s2.toml"), "--no-progress", "--no-video",
                         "--from", str(ck), "--duration", "0.002")
    assert code == 0, err
    assert "resumed from" in out
    import re
    t_end = float(re.search(r"done: t = ([0-9.eE+-]+) s", out).group(1))
    assert t_end == pytest.approx(0.007, abs=2 * sim.dt)          # 0.005 s + 0.002 s
    code, out, err = run(capsys, "run", str(tmp_path / "s2.toml"), "--from", str(tmp_path / "missing.ckpt"))
    assert code == 2 and "no checkpoint file" in err


def test_help_and_version_print_no_taichi_banner():
    """--help and --version start no Taichi and print no banner; --help names the scene-file
    reference page, --version the package's one version."""
    import taichi_fdem
    for argv, stream in ((["--help"], "stdout"), (["run", "--help"], "stdout"), (["--version"], "stdout")):
        p = subprocess.run([sys.executable, "-m", "taichi_fdem.cli", *argv], capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
        assert "[Taichi]" not in p.stdout + p.stderr, argv
    p = subprocess.run([sys.executable, "-m", "taichi_fdem.cli", "--help"], capture_output=True, text=True)
    assert "docs/reference/scenefile.md" in " ".join(p.stdout.split())
    p = subprocess.run([sys.executable, "-m", "taichi_fdem.cli", "--version"], capture_output=True, text=True)
    assert p.stdout.strip() == f"taichi-fdem {taichi_fdem.__version__}"


def test_a_command_that_starts_taichi_prints_its_banner_once_on_stderr():
    p = subprocess.run([sys.executable, "-m", "taichi_fdem.cli", "info"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert "[Taichi]" not in p.stdout                         # stdout: the command's own output
    assert p.stderr.count("[Taichi] version") == 1 and "Starting on arch" not in p.stderr


def test_energy_summary_prints_every_term_of_the_total(capsys):
    """The printed terms of the energy summary (each with the sign it enters the total with) add
    up to the printed total, on the cracked slab (joints and fracture present)."""
    import re
    from taichi_fdem.sim.energies import TOTAL_TERMS
    code, out, err = run(capsys, "run", os.path.join(ROOT, "examples", "cracked_slab.toml"), "--duration", "0.01",
                         "--no-video", "--no-progress")
    assert code == 0, err
    block = out[out.index("energies at the end:"):]
    vals = dict(re.findall(r"^\s+(- \w+|\w+)\s+([+-][0-9.]+e[+-]\d+) J$", block, re.M))
    total = float(vals.pop("total"))
    assert {k.removeprefix("- ") for k in vals} == {k for k, _ in TOTAL_TERMS}
    assert "joints" in vals and "fracture" in vals and "- load_work" in vals
    terms = [float(v) for v in vals.values()]
    # each term printed to 7 significant digits
    assert sum(terms) == pytest.approx(total, abs=len(terms) * 5e-7 * max(map(abs, terms)))

"""Parameter sweeps (taichi_fdem.sweep): worker processes, failure isolation, the CSV, resume,
sweep files, and the same sweep on a real local Dask cluster (loopback)."""
from __future__ import annotations

import csv
import os
import textwrap
import time
import uuid

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem import sweep as fsweep
from taichi_fdem.sweep import Sweep, SweepError

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MARKERS = "TAICHI_FDEM_TEST_SWEEP_MARKERS"      # folder where base() leaves one file per call
DURATION = 0.01                                   # s of simulated time per point


# ------------------------------------------------------------------------------------------------
# the tiny scene of every point: a block sliding on a fixed floor with friction (~28 triangles).
# Module level, so that the spawned worker processes can import them.
# ------------------------------------------------------------------------------------------------
def base_block(params):
    folder = os.environ.get(MARKERS)
    if folder:
        open(os.path.join(folder, uuid.uuid4().hex), "w").close()
    g = fsweep.group_params(params)
    if g["material"].get("friction") == 0.77:
        os._exit(7)                               # a point that kills its worker process
    if g["material"].get("friction") == 0.66:
        time.sleep(600)                           # a point that hangs
    mat = fdem.Material(density=1000.0, young=1.0e7, poisson=0.25, **g["material"])
    scene = fdem.Scene(gravity=(0.0, -9.81))
    scene.add_body(fdem.mesh.rectangle(0.6, 0.05, 0.05), mat, position=(0.0, -0.025), fixed=True, name="floor")
    scene.add_body(fdem.mesh.rectangle(0.1, 0.05, 0.05), mat, position=(0.0, 0.025), velocity=(1.0, 0.0),
                   name="block")
    safety = g["solver"].get("safety", 0.2)
    if safety > 1.0:                              # an unstable point: dt above the stable limit
        limit = scene.build().model.dt_limit
        return scene.build(dt=safety * limit, force_dt=True), DURATION
    return scene                                  # built by the sweep with the solver.* values


def block_metrics(sim):
    block = sim.bodies[1]
    m = sim.node_masses(block)
    v = (m[:, None] * sim.node_velocities(block)).sum(0) / m.sum()
    dx = (m[:, None] * sim.node_displacements(block)).sum(0) / m.sum()
    return {"vx": float(v[0]), "dx": float(dx[0]), "friction_J": sim.energies()["friction"], "steps": sim.step_count}


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture
def markers(tmp_path, monkeypatch):
    folder = tmp_path / "markers"
    folder.mkdir()
    monkeypatch.setenv(MARKERS, str(folder))     # inherited by the spawned workers
    return lambda: len(os.listdir(folder))


GRID = {"material.friction": [0.2, 0.4], "solver.safety": [0.15, 0.2]}


@pytest.fixture(scope="module")
def grid_run(tmp_path_factory):
    """The 4-point grid run once with 2 local workers: (sweep, rows, csv path, progress calls)."""
    folder = tmp_path_factory.mktemp("grid")
    out = folder / "sweep.csv"
    sw = Sweep(base_block, axes=GRID, metrics=block_metrics, duration=DURATION)
    seen = []
    rows = sw.run(workers=2, output=str(out), on_result=lambda row, done, total: seen.append((done, total)))
    return sw, rows, out, seen


def test_grid_csv(grid_run):
    sw, rows, out, seen = grid_run
    assert len(sw) == 4 and sw.points[1] == {"material.friction": 0.2, "solver.safety": 0.2}
    assert sorted(seen) == [(1, 4), (2, 4), (3, 4), (4, 4)]
    assert [r["status"] for r in rows] == ["ok"] * 4
    table = read_csv(out)
    assert len(table) == 4
    assert list(table[0])[:2] == ["material.friction", "solver.safety"]
    assert {"vx", "dx", "friction_J", "steps", "status", "error", "wall_s", "worker"} <= set(table[0])
    assert all(r["status"] == "ok" and r["error"] == "" and float(r["wall_s"]) > 0 for r in table)
    # the work was spread over (at most) 2 worker processes, none of them this one
    pids = {r["worker"].rsplit(":", 1)[1] for r in table}
    assert 1 <= len(pids) <= 2 and str(os.getpid()) not in pids
    # physics: the block slows down; more friction, more slowing and more dissipated energy
    by = {(r["material.friction"], r["solver.safety"]): r for r in rows}
    for s in (0.15, 0.2):
        lo, hi = by[(0.2, s)], by[(0.4, s)]
        assert 0 < hi["vx"] < lo["vx"] < 1.0
        assert hi["friction_J"] > lo["friction_J"] > 0
    # a smaller safety factor means a smaller dt: more steps for the same duration
    assert by[(0.2, 0.15)]["steps"] > by[(0.2, 0.2)]["steps"]


def test_resume(grid_run, tmp_path, markers):
    sw, rows, done_csv, _ = grid_run
    out = tmp_path / "sweep.csv"
    out.write_bytes(done_csv.read_bytes())
    # nothing to do: the rows come back from the CSV, no worker runs
    rows2 = sw.run(workers=2, output=str(out))
    assert markers() == 0 and sw.skipped == 4
    assert [(r["vx"], r["status"], r["steps"]) for r in rows2] == [(r["vx"], r["status"], r["steps"]) for r in rows]
    # an interrupted sweep: drop one row, re-run: only that point runs again, with the same result
    with open(out, newline="") as f:
        lines = f.readlines()
    dropped = lines.pop(2)
    with open(out, "w", newline="") as f:
        f.writelines(lines)
    rows3 = sw.run(workers=2, output=str(out))
    assert markers() == 1 and sw.skipped == 3
    table = read_csv(out)
    assert len(table) == 4 and [r["status"] for r in table] == ["ok"] * 4
    assert [r["vx"] for r in rows3] == pytest.approx([r["vx"] for r in rows], rel=1e-12)
    assert lines[1:] == open(out, newline="").readlines()[1:4]      # the kept rows are untouched
    assert open(out, newline="").readlines()[4].split(",")[:2] == dropped.split(",")[:2]


def test_failures_are_recorded_and_do_not_stop_the_sweep(tmp_path, markers):
    out = tmp_path / "points.csv"
    points = [{"material.friction": 0.3, "solver.safety": 0.2},
              {"material.friction": -1.0, "solver.safety": 0.2},     # Material refuses: failed
              {"material.friction": 0.3, "solver.safety": 8.0},     # dt 8x the stable limit: unstable
              {"material.friction": 0.77, "solver.safety": 0.2},    # kills its worker: crashed
              {"material.friction": 0.5, "solver.safety": 0.2}]
    rows = Sweep(base_block, points=points, metrics=block_metrics, duration=DURATION).run(workers=2, output=str(out))
    status = [r["status"] for r in rows]
    assert status == ["ok", "failed", "unstable", "crashed", "ok"]
    assert "friction coefficient must be >= 0" in rows[1]["error"] and rows[1]["error"].startswith("ValueError")
    assert rows[2]["error"].startswith("SimulationError") and "Suggested time step" in rows[2]["error"]
    assert "exit code 7" in rows[3]["error"]
    assert rows[4]["vx"] < rows[0]["vx"]
    table = read_csv(out)
    assert len(table) == 5 and sorted(r["status"] for r in table) == sorted(status)
    assert all(r["vx"] == "" for r in table if r["status"] != "ok")
    # resume re-runs only the points that did not succeed (3 of them), and keeps one row per point
    before = markers()
    rows = Sweep(base_block, points=points, metrics=block_metrics, duration=DURATION).run(workers=2, output=str(out))
    assert markers() == before + 3
    assert [r["status"] for r in rows] == status and len(read_csv(out)) == 5


def test_timeout(tmp_path):
    rows = Sweep(base_block, points=[{"material.friction": 0.66}], metrics=block_metrics,
                 duration=DURATION).run(workers=1, output=str(tmp_path / "t.csv"), timeout=2.0)
    assert rows[0]["status"] == "timeout" and "timeout of 2 s" in rows[0]["error"]


def test_scene_file_sweep_and_metrics_registry(tmp_path):
    scene = tmp_path / "slide.toml"
    scene.write_text(textwrap.dedent("""
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
        duration = 0.01
        """))
    sweep_file = tmp_path / "sw.toml"
    sweep_file.write_text(textwrap.dedent("""
        [sweep]
        scene = "slide.toml"
        metrics = ["time", "displacement:block", "velocity:block", "energies", "couple_count"]
        workers = 2
        [sweep.axes]
        "materials.rock.friction" = [0.1, 0.5]
        """))
    sw, opts = fsweep.load(sweep_file)
    assert opts == {"output": "sw.csv", "workers": 2, "scheduler": None, "timeout": None, "resume": True}
    rows = sw.run(workers=opts["workers"], output=str(tmp_path / opts["output"]))
    assert [r["status"] for r in rows] == ["ok", "ok"]
    lo, hi = rows
    assert lo["time"] == pytest.approx(0.01, rel=1e-3)
    assert 0 < hi["block_dx"] < lo["block_dx"] < 0.01 and lo["block_displacement"] >= lo["block_dx"]
    assert hi["block_vx"] < lo["block_vx"] < 1.0
    assert hi["energy_friction"] > lo["energy_friction"] > 0 and lo["couple_count"] > 0
    assert set(read_csv(tmp_path / "sw.csv")[0]) >= {"materials.rock.friction", "block_dx", "energy_total", "status"}


# ------------------------------------------------------------------------------------------------
# bad input
# ------------------------------------------------------------------------------------------------
def test_bad_sweep_arguments(tmp_path):
    with pytest.raises(SweepError, match=r"exactly one of axes"):
        Sweep(base_block, metrics=block_metrics)
    with pytest.raises(SweepError, match=r"exactly one of axes"):
        Sweep(base_block, axes=GRID, points=[{}], metrics=block_metrics)
    with pytest.raises(SweepError, match=r"axis 'material.friction' must be a non-empty list"):
        Sweep(base_block, axes={"material.friction": []})
    with pytest.raises(SweepError, match=r"axis 'material.friction' repeats a value"):
        Sweep(base_block, axes={"material.friction": [0.1, 0.1]})
    with pytest.raises(SweepError, match=r"must be finite"):
        Sweep(base_block, axes={"material.friction": [float("nan")]})
    with pytest.raises(SweepError, match=r"points\[1\] has keys"):
        Sweep(base_block, points=[{"a": 1}, {"b": 1}])
    with pytest.raises(SweepError, match=r"points\[1\] repeats points\[0\]"):
        Sweep(base_block, points=[{"a": 1}, {"a": 1}])
    with pytest.raises(SweepError, match=r"unknown solver parameter 'solver.safty'"):
        Sweep(base_block, axes={"solver.safty": [0.1]})
    with pytest.raises(SweepError, match=r"base must be a callable"):
        Sweep(42, axes=GRID)
    with pytest.raises(SweepError, match=r"unknown metric 'energy' \(did you mean 'energies'\?\)"):
        Sweep(base_block, axes=GRID, metrics=["energy"])
    with pytest.raises(SweepError, match=r"duration must be a finite time"):
        Sweep(base_block, axes=GRID, duration=-1.0)
    sw = Sweep(base_block, axes=GRID, metrics=block_metrics, duration=DURATION)
    with pytest.raises(SweepError, match=r"workers must be an integer >= 1"):
        sw.run(workers=0, output=str(tmp_path / "x.csv"))
    with pytest.raises(SweepError, match=r"must be picklable"):
        Sweep(lambda p: None, axes=GRID, metrics=block_metrics).run(output=str(tmp_path / "y.csv"))
    # a CSV of another sweep is not resumed into
    other = tmp_path / "other.csv"
    other.write_text("a,b,status\n1,2,ok\n")
    with pytest.raises(SweepError, match=r"other.csv: .*belongs to another sweep.*resume=False"):
        sw.run(output=str(other))


def test_bad_sweep_files(tmp_path):
    (tmp_path / "s.toml").write_text((open(os.path.join(ROOT, "examples", "two_disks.toml")).read()))

    def refused(text, pattern):
        p = tmp_path / "sw.toml"
        p.write_text(textwrap.dedent(text))
        with pytest.raises(SweepError, match=pattern):
            fsweep.load(p)

    refused('[sweep]\nscene = "s.toml"\nworkrs = 2\n[sweep.axes]\n"solver.safety" = [0.1]\n',
            r"sw.toml:3: \[sweep\] unknown key 'workrs' \(did you mean 'workers'\?\)")
    refused('[sweep]\nscene = "nope.toml"\n[sweep.axes]\n"solver.safety" = [0.1]\n', r"sw.toml:2: .*'nope.toml' not found")
    refused('[sweep]\nscene = "s.toml"\n', r"exactly one of \[sweep.axes\]")
    refused('[sweep]\nscene = "s.toml"\nworkers = "2"\n[sweep.axes]\n"solver.safety" = [0.1]\n',
            r"sw.toml:3: .*workers must be an integer")
    refused('[sweep]\nscene = "s.toml"\n[sweep.axes]\n"materials.rubber.frction" = [0.1]\n',
            r"\[sweep.axes\].*unknown key 'frction'.*did you mean 'friction'")
    refused('[sweep]\nscene = "s.toml"\n[sweep.axes]\n"materials.rubbr.friction" = [0.1]\n',
            r"no table 'materials.rubbr'.*did you mean 'rubber'")
    refused('[sweep]\nscene = "s.toml"\n[sweep.axes]\n"materials.rubber.friction" = [-0.1]\n',
            r"friction coefficient must be >= 0")
    refused('[sweep]\nscene = "s.toml"\nmetrics = ["displacement:C"]\n[sweep.axes]\n"solver.safety" = [0.1]\n',
            r"sw.toml:3: \[sweep\] metrics: metric 'displacement:C': no body named 'C'")
    refused('[sweep]\nscene = "s.toml"\n[sweep.axes]\n"solver.safety" = 0.1\n',
            r"sw.toml:4: .*axis 'solver.safety' must be a non-empty list")
    refused('[sweeps]\nscene = "s.toml"\n', r"sw.toml:1: unknown table 'sweeps' \(did you mean 'sweep'\?\)")


# ------------------------------------------------------------------------------------------------
# Dask
# ------------------------------------------------------------------------------------------------
def test_dask_cluster_gives_the_local_results(grid_run, tmp_path, markers):
    distributed = pytest.importorskip("dask.distributed", reason="dask[distributed] is not installed "
                                      "(the test extra that CI installs has it: pip install -e '.[test]')")
    sw, local, _, _ = grid_run
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        worker_pids = {str(w.process.pid) for w in cluster.workers.values()}
        remote = sw.run(output=str(tmp_path / "dask.csv"), scheduler=cluster.scheduler_address)
        assert markers() == 4
        # resume works the same way on the cluster
        again = sw.run(output=str(tmp_path / "dask.csv"), scheduler=cluster.scheduler_address)
        assert markers() == 4 and sw.skipped == 4
    assert [r["status"] for r in remote] == ["ok"] * 4
    for a, b in zip(local, remote):
        for k in ("vx", "dx", "friction_J"):
            assert b[k] == pytest.approx(a[k], rel=1e-12, abs=1e-15)
        assert b["steps"] == a["steps"]
    assert {r["worker"].rsplit(":", 1)[1] for r in remote} <= worker_pids
    assert [r["vx"] for r in again] == [r["vx"] for r in remote]
    assert len(read_csv(tmp_path / "dask.csv")) == 4


def test_dask_missing_scheduler_is_a_clear_error(tmp_path):
    pytest.importorskip("dask.distributed", reason="dask[distributed] is not installed (the test extra that CI "
                        "installs has it: pip install -e '.[test]')")
    sw = Sweep(base_block, axes={"material.friction": [0.2]}, metrics=block_metrics, duration=DURATION)
    with pytest.raises(SweepError, match=r"scheduler must be an address"):
        sw.run(output=str(tmp_path / "x.csv"), scheduler=12)


def test_sweep_friction_demo_short(tmp_path):
    """demos/sweep_friction.py --short: every point stops within 3 % of v0²/(2 μ g)."""
    from conftest import load_demo
    mod = load_demo("sweep_friction")
    out = tmp_path / "sf.csv"
    r = mod.main(["--short", "--out", str(out)])
    assert r["points"] == 4
    assert len(read_csv(out)) == 4
    for row in r["results"]:
        # the stop distance of a block launched at 1 m/s: v0²/(2 μ g), written out here; and it stopped
        assert row["d_sim"] == pytest.approx(1.0 / (2 * row["mu"] * 9.81), rel=0.03)
        assert abs(row["v_end"]) < 0.01
    pytest.importorskip("matplotlib", reason="matplotlib is not installed (the test extra that CI installs has "
                        "it: pip install -e '.[test]')")
    assert os.path.getsize(r["png"]) > 0


def test_example_sweep_file_loads():
    sw, opts = fsweep.load(os.path.join(ROOT, "examples", "sweep_friction.toml"))
    assert len(sw) == 6 and opts["workers"] == 2 and opts["output"] == "out/sweep_friction_cli.csv"
    assert sw.param_cols == ["materials.rock.friction", "materials.rock.penalty"]


def test_local_workers_share_the_cores():
    """Local workers split the usable cores (the parallel strategy of a large point must not
    oversubscribe the CPU); an explicit thread count or another arch is left as given."""
    import os
    from taichi_fdem.sweep.runner import worker_init
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert worker_init({}, 1)["cpu_max_num_threads"] == cores
    assert worker_init({}, cores)["cpu_max_num_threads"] == 1
    assert worker_init({}, 4 * cores)["cpu_max_num_threads"] == 1
    assert worker_init({"precision": "f32"}, 1) == {"precision": "f32", "cpu_max_num_threads": cores}
    assert worker_init({"cpu_max_num_threads": 3}, 2) == {"cpu_max_num_threads": 3}
    assert "cpu_max_num_threads" not in worker_init({"arch": "cuda"}, 2)

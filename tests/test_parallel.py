"""The parallel strategy assembles forces without atomic float adds (force slots + sorted node
lists): its results are bit-identical from run to run and for any thread count, and agree with
the serial strategy to round-off."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import taichi_fdem as fdem

SCRIPT = r"""
import hashlib, json, sys
import taichi_fdem as fdem
fdem.init(cpu_max_num_threads=int(sys.argv[1]))
from taichi_fdem.verification import fragment_plate_scene
sim, (plate, ball) = fragment_plate_scene(h_plate=0.025, h_ball=0.02)
sim = sim.scene.build(strategy="parallel")
sim.run(0.004, progress=False)
x, v = sim.node_positions(), sim.node_velocities()
print(json.dumps({"hash": hashlib.sha1(x.tobytes() + v.tobytes()).hexdigest(),
                  "broken": sim.broken_joint_count, "couples": sim.couple_count}))
"""


def _run(threads: int) -> dict:
    r = subprocess.run([sys.executable, "-c", SCRIPT, str(threads)], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_parallel_is_bit_identical_across_thread_counts():
    """A fragmenting impact (joints breaking, couples changing) on 1 and 2 threads: same bits."""
    one, two = _run(1), _run(2)
    assert one["broken"] > 0 and one["couples"] > 0
    assert one == two


def test_parallel_agrees_with_serial():
    """Same fragmenting scene, both strategies: the same joints break and positions agree to
    round-off amplified by the fragmentation (a missing or doubled force would be O(1))."""
    out = {}
    for strategy in ("serial", "parallel"):
        from taichi_fdem.verification import fragment_plate_scene
        sim, _ = fragment_plate_scene(h_plate=0.025, h_ball=0.02)
        sim = sim.scene.build(strategy=strategy)
        sim.run(0.003, progress=False)
        out[strategy] = (sim.node_positions(), sim.broken_joint_count, sim.energies()["total"])
    xs, xp = out["serial"][0], out["parallel"][0]
    assert out["serial"][1] == out["parallel"][1]
    assert np.abs(xs - xp).max() <= 1e-5 * np.abs(xs).max()
    assert out["parallel"][2] == pytest.approx(out["serial"][2], rel=1e-6)


def test_parallel_node_lists_cover_every_contribution():
    """The gathered force of every node equals the scattered (serial) force, on a scene with
    contact, friction, joints and prescribed velocities."""
    mat = fdem.Material(density=1000.0, young=1e7, poisson=0.25, friction=0.4, tensile_strength=1e5,
                        fracture_energy=10.0)
    scene = fdem.Scene(gravity=(0.0, -9.81))
    scene.add_body(fdem.mesh.rectangle(0.3, 0.05, 0.02), mat, fixed=True, name="floor")
    scene.add_body(fdem.mesh.rectangle(0.1, 0.05, 0.02), mat, position=(0.0, 0.0505), fracture=True,
                   velocity=(0.3, -0.2), name="block")
    runs = {}
    for strategy in ("serial", "parallel"):
        sim = scene.build(strategy=strategy)
        sim.step(300)
        runs[strategy] = sim.node_positions()
    assert np.abs(runs["serial"] - runs["parallel"]).max() <= 1e-12


def test_fast_compile_gives_the_same_trajectory():
    """fdem.init(fast_compile=True) (no advanced IR optimisation) runs the same physics: a
    two-disk impact in a fresh process agrees with the default build to round-off."""
    code = r"""
import json, sys
import taichi_fdem as fdem
fdem.init(fast_compile=sys.argv[1] == "1")
from taichi_fdem.verification import two_disks_scene
sim = two_disks_scene()
sim = sim[0] if isinstance(sim, tuple) else sim
sim.step(400)
print(json.dumps(sim.node_positions().tolist()))
"""
    runs = []
    for flag in ("0", "1"):
        r = subprocess.run([sys.executable, "-c", code, flag], capture_output=True, text=True, timeout=900)
        assert r.returncode == 0, r.stderr[-3000:]
        runs.append(np.array(json.loads(r.stdout.strip().splitlines()[-1])))
    assert np.abs(runs[0] - runs[1]).max() <= 1e-9 * np.abs(runs[0]).max()

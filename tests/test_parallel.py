"""The parallel strategy assembles forces without atomic float adds, in either assembly (block
copies of the nodal forces, the CPU default; force slots + sorted node lists, the GPU default):
its results are bit-identical from run to run and for any thread count, and agree with the
serial strategy to round-off."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest

import taichi_fdem as fdem

SCRIPT = r"""
import hashlib, json, sys
import taichi_fdem as fdem
fdem.init(cpu_max_num_threads=int(sys.argv[1]))
from taichi_fdem.verification import fragment_plate_scene
sim, (plate, ball) = fragment_plate_scene(h_plate=0.025, h_ball=0.02, friction=0.5)
sim = sim.scene.build(strategy="parallel")
sim.solver.assembly = sys.argv[2]
sim.solver.force_blocks = int(sys.argv[3])
sim.run(0.004, progress=False)
x, v = sim.node_positions(), sim.node_velocities()
e = sim.energies()
print(json.dumps({"hash": hashlib.sha1(x.tobytes() + v.tobytes()).hexdigest(),
                  "broken": sim.cracks.broken_count, "couples": sim.solver.couple_count,
                  "friction": e["friction"].hex(), "fracture": e["fracture"].hex(), "joints": e["joints"].hex(),
                  "energies": [e[k].hex() for k in ("kinetic", "strain", "contact", "gravity", "damping")]}))
"""


def _run(threads: int, assembly: str, blocks: int = 2) -> dict:
    r = subprocess.run([sys.executable, "-c", SCRIPT, str(threads), assembly, str(blocks)], capture_output=True,
                       text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("assembly,blocks", [("blocks", 2), ("blocks", 3), ("slots", 2)])
def test_parallel_is_bit_identical_across_thread_counts(assembly, blocks):
    """A fragmenting impact (joints breaking, couples changing, friction) on 1 and 2 threads:
    the same bits, positions and velocities and (blocks: summed in block order) the friction
    work and the joints' work too; for 3 blocks as well (more blocks than threads).  The energy
    account of the same state is the same bits too (``energies()`` sums serially)."""
    one, two = _run(1, assembly, blocks), _run(2, assembly, blocks)
    assert one["broken"] > 0 and one["couples"] > 0 and float.fromhex(one["friction"]) > 0.0
    if assembly == "slots":                     # its friction work is summed with atomics
        one.pop("friction"), two.pop("friction")
    assert one == two


@pytest.mark.parametrize("assembly", ["blocks", "slots"])
def test_parallel_agrees_with_serial(assembly):
    """Same fragmenting scene, both strategies: the same joints break, positions agree to
    round-off amplified by the fragmentation (a missing or doubled force would be O(1)), and so
    do the energy terms, friction work included (booked per block, or per couple)."""
    out = {}
    for strategy in ("serial", "parallel"):
        from taichi_fdem.verification import fragment_plate_scene
        sim, _ = fragment_plate_scene(h_plate=0.025, h_ball=0.02, friction=0.5)
        sim = sim.scene.build(strategy=strategy)
        sim.solver.assembly = assembly
        sim.run(0.003, progress=False)
        out[strategy] = (sim.node_positions(), sim.cracks.broken_count, sim.energies())
    xs, xp = out["serial"][0], out["parallel"][0]
    assert out["serial"][1] == out["parallel"][1]
    assert np.abs(xs - xp).max() <= 1e-5 * np.abs(xs).max()
    es, ep = out["serial"][2], out["parallel"][2]
    assert es["friction"] > 0.01 * es["total"]
    # (2e-7 to 1.7e-6 measured over 2, 3 and 4 blocks: round-off the fragmentation amplifies)
    assert ep["total"] == pytest.approx(es["total"], rel=5e-6)
    # the terms, to the round-off the fragmentation amplifies (1e-5 to 4e-5 measured, either
    # assembly); a term dropped or booked twice would be off by O(1)
    for key in ("kinetic", "strain", "friction", "fracture", "joints"):
        assert ep[key] == pytest.approx(es[key], rel=2e-4, abs=1e-6 * es["total"]), key


@pytest.mark.parametrize("assembly", ["blocks", "slots"])
def test_parallel_node_lists_cover_every_contribution(assembly):
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
        sim.solver.assembly = assembly
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


def test_init_again_with_the_same_settings_keeps_built_simulations():
    """A second ``fdem.init()`` with the settings in force (a pasted README example, a notebook
    cell run twice) leaves Taichi as it is: a simulation built before keeps running, to the same
    bits as one that never saw the second call.  (Re-initialising would free its arrays.)"""
    code = r"""
import gc, hashlib, sys
import taichi_fdem as fdem
fdem.init()
from taichi_fdem.verification import two_disks_scene
sims = [two_disks_scene() for _ in range(2)]
sims = [s[0] if isinstance(s, tuple) else s for s in sims]
sims[0].step(100)
if sys.argv[1] == "1":
    fdem.init()
    fdem.init(arch="cpu", precision="f64")
    gc.collect()
sims[0].step(100)
sims[1].step(200)
print(hashlib.sha1(sims[0].node_positions().tobytes()).hexdigest(),
      hashlib.sha1(sims[1].node_positions().tobytes()).hexdigest())
"""
    outs = []
    for again in ("0", "1"):
        r = subprocess.run([sys.executable, "-c", code, again], capture_output=True, text=True, timeout=900)
        assert r.returncode == 0, r.stderr[-3000:]
        outs.append(r.stdout.split()[-2:])
    assert outs[0] == outs[1]
    assert outs[0][0] == outs[0][1]


def test_init_with_other_settings_stops_old_simulations_with_a_clear_error():
    """Re-initialising Taichi with other settings frees the arrays of every simulation built
    before: stepping one raises a RuntimeError that says so (not Taichi's 'argument not found'
    or a crash), and a simulation built afterwards runs."""
    code = r"""
import taichi_fdem as fdem
fdem.init()
from taichi_fdem.verification import two_disks_scene
old = two_disks_scene()
old = old[0] if isinstance(old, tuple) else old
old.step(10)
fdem.init(cpu_max_num_threads=1)
try:
    old.step(10)
except RuntimeError as err:
    print("ERR", err)
new = two_disks_scene()
new = new[0] if isinstance(new, tuple) else new
new.step(10)
print("OK")
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "ERR this simulation was built before fdem.init(...) re-initialised Taichi" in r.stdout
    assert r.stdout.strip().endswith("OK")


def test_auto_strategy_follows_the_work_and_the_threads(monkeypatch):
    """'auto' runs parallel on the CPU with >= 2 threads once triangles + joints + couples reach
    AUTO_PARALLEL_ITEMS, serial below it (and always serial on one thread)."""
    import taichi_fdem.sim.simulation as simmod
    from taichi_fdem import backend
    from taichi_fdem.verification import fragment_plate_scene
    sim, _ = fragment_plate_scene(h_plate=0.025, h_ball=0.02)
    scene = sim.scene
    items = sim.model.tri_count + sim.model.joint_count + sim.solver.couple_count
    monkeypatch.setattr(simmod, "AUTO_PARALLEL_ITEMS", items + 1)
    assert scene.build().solver.strategy == "serial"
    monkeypatch.setattr(simmod, "AUTO_PARALLEL_ITEMS", items)
    big = scene.build()
    assert big.solver.strategy == ("parallel" if backend.cpu_threads() >= 2 else "serial")
    assert big.solver.assembly == "blocks"
    big.step(50)                                # and it runs
    assert np.isfinite(big.node_positions()).all()


def test_assembly_can_change_between_calls():
    """``sim.solver.assembly`` switches between blocks and slots mid-run (the arrays are re-sized, the
    node lists rebuilt): the run continues as one that never switched, to round-off; a wrong
    name is refused."""
    from taichi_fdem.verification import fragment_plate_scene
    runs = []
    for switch in (False, True):
        sim, _ = fragment_plate_scene(h_plate=0.025, h_ball=0.02, friction=0.5)
        sim = sim.scene.build(strategy="parallel")
        for k in range(4):
            if switch:
                sim.solver.assembly = "slots" if k % 2 else "blocks"
            sim.step(150)
        runs.append((sim.node_positions(), sim.cracks.broken_count))
    assert runs[0][1] == runs[1][1] > 0
    # blocks and slots sum a node's forces in different orders: round-off, which the breaking
    # joints of 600 steps amplify to ~1e-9 of the plate size at a few nodes (3e-10 m measured)
    assert np.abs(runs[0][0] - runs[1][0]).max() <= 1e-8 * np.abs(runs[0][0]).max()
    with pytest.raises(ValueError, match="assembly"):
        sim.solver.assembly = "atomic"


def test_force_blocks_agree_and_are_checked(tmp_path):
    """Any number of blocks gives the serial result to round-off (each item's forces land in one
    block, every block is gathered); the count survives a checkpoint; a bad count is refused."""
    from taichi_fdem.verification import fragment_plate_scene
    sim, _ = fragment_plate_scene(h_plate=0.025, h_ball=0.02, friction=0.5)
    scene = sim.scene
    ref = scene.build(strategy="serial")
    ref.step(400)
    for blocks in (1, 3, 5):
        par = scene.build(strategy="parallel")
        par.solver.force_blocks = blocks
        par.step(400)
        assert par.cracks.broken_count == ref.cracks.broken_count
        assert np.abs(par.node_positions() - ref.node_positions()).max() <= 1e-9 * np.abs(ref.node_positions()).max()
        assert par.energies()["friction"] == pytest.approx(ref.energies()["friction"], rel=1e-6)
    par.save(tmp_path / "c")
    back = fdem.Simulation.load(tmp_path / "c")
    assert back.solver.force_blocks == 5 and back.solver.strategy == "parallel"
    back.step(10)
    par.step(10)
    np.testing.assert_array_equal(back.node_positions(), par.node_positions())
    for bad in (0, -1, 2.5, True, "2", 65):
        with pytest.raises(ValueError, match="force_blocks"):
            par.solver.force_blocks = bad


@pytest.mark.parametrize("team", [True, False])
def test_block_copies_are_gathered_over_the_nodes_they_can_write(team):
    """Each block b > 0 adds into its copy of the nodal forces, and the gather adds and resets
    that copy over the block's node range only (step_int[RANGE + 2b], set with the couple ranges
    by ``blocks.block_node_ranges``): an entry written outside it would survive the step.  After
    steps of a fragmenting plate in 5 blocks, mid-launch state included, every copy is zero
    again; each range holds every node of its block's triangles, joints and couples (brute force
    from the arrays and the couple split), and the ranges are narrower than the nodes (else they
    would save nothing here)."""
    from taichi_fdem.engine.groups import COUPLES, RANGE, SPLIT
    from taichi_fdem.verification import fragment_plate_scene
    sim, _ = fragment_plate_scene(h_plate=0.02, h_ball=0.02, friction=0.5)
    sim = sim.scene.build(strategy="parallel")
    sim.solver.force_blocks = 5
    sim.solver.team_steps = team
    sim.step(300)
    assert sim.cracks.broken_count > 0
    N, nblk = sim.model.node_count, 5
    copies = sim.solver.scratch.asm_force.to_numpy()[: (nblk - 1) * N]
    assert not np.any(copies)
    ints = sim.state.step_int.to_numpy()
    tri = sim.model.tri_nodes.to_numpy()
    jn = sim.model.joint_nodes.to_numpy()
    T, J, C = len(tri), sim.model.joint_count, int(ints[COUPLES])
    ca = sim.state.couple_a.to_numpy()[:C]
    cb = sim.state.couple_b.to_numpy()[:C]
    span = 0
    written = []
    for b in range(nblk):
        lo_c = 0 if b == 0 else min(max(int(ints[SPLIT + b]), 0), C)
        hi_c = C if b == nblk - 1 else min(max(int(ints[SPLIT + b + 1]), 0), C)
        nodes = np.concatenate([tri[b * T // nblk:(b + 1) * T // nblk].ravel(),
                                jn[b * J // nblk:(b + 1) * J // nblk].ravel(),
                                tri[ca[lo_c:hi_c]].ravel(), tri[cb[lo_c:hi_c]].ravel()])
        written.append(nodes)
        lo, hi = int(ints[RANGE + 2 * b]), int(ints[RANGE + 2 * b + 1])
        assert lo == nodes.min() and hi == nodes.max() + 1, (b, lo, hi, nodes.min(), nodes.max())
        span += hi - lo if b > 0 else 0
    assert 0 < span < 0.5 * (nblk - 1) * N, span


def test_block_zero_range_holds_its_items_and_the_loads():
    """The gather adds block 0's forces and the loads from node_f, and every other block's copy
    over that block's node range only, so the ranges must hold every node each block's runner
    writes: block 0's triangles and couples, and every node a load writes (``apply_load`` runs
    after block 0's forces).  On the bar under every kind of load, brute force from the arrays: the
    loads' nodes lie outside block 0's triangles, and the range reaches them."""
    from taichi_fdem.engine.groups import COUPLES, RANGE, SPLIT
    from taichi_fdem.engine.loads import LOAD_FORCE, LOAD_VELOCITY
    sim = _loaded_pair()
    sim.step(50)
    ints = sim.state.step_int.to_numpy()
    tri = sim.model.tri_nodes.to_numpy()
    T, C, nblk = len(tri), int(ints[COUPLES]), sim.solver.force_blocks
    ca = sim.state.couple_a.to_numpy()[:C]
    cb = sim.state.couple_b.to_numpy()[:C]
    hi_c = min(max(int(ints[SPLIT + 1]), 0), C)
    ld = sim.model.load_nodes.to_numpy()
    seg = ~np.isin(ld[:, 0], (LOAD_FORCE, LOAD_VELOCITY))
    own = np.concatenate([tri[: T // nblk].ravel(), tri[ca[:hi_c]].ravel(), tri[cb[:hi_c]].ravel()])
    loads = np.concatenate([ld[:, 1], ld[seg, 2]])
    assert loads.max() > own.max() or loads.min() < own.min()
    every = np.concatenate([own, loads])
    assert (int(ints[RANGE]), int(ints[RANGE + 1])) == (every.min(), every.max() + 1)
    other = np.concatenate([tri[T // nblk:].ravel(), tri[ca[hi_c:]].ravel(), tri[cb[hi_c:]].ravel()])
    assert (int(ints[RANGE + 2]), int(ints[RANGE + 3])) == (other.min(), other.max() + 1)


def test_team_chunks_tile_the_nodes():
    """The team integrates the nodes in chunks (``blocks.chunk_count``, ``blocks.chunk_nodes``)
    that depend on the node count alone (so a chunk's sums, and the bits, do not depend on the
    workers): they tile the nodes in order, each holds at most TEAM_CHUNK nodes and none is
    empty."""
    import taichi as ti
    from taichi_fdem.engine.blocks import chunk_count, chunk_nodes
    from taichi_fdem.engine.groups import TEAM_CHUNK

    def cut(N, out):
        for c in range(chunk_count(N)):
            lo, hi = chunk_nodes(c, chunk_count(N), N)
            out[c, 0] = lo
            out[c, 1] = hi
        out[out.shape[0] - 1, 0] = chunk_count(N)

    cut.__annotations__ = {"N": ti.i32, "out": ti.types.ndarray()}
    cut = ti.kernel(cut)

    for N in (1, 2, 3, 255, 256, 257, 511, 1000, 4097, 78013):
        out = np.zeros((N // TEAM_CHUNK + 8, 2), np.int32)
        cut(N, out)
        nch = int(out[-1, 0])
        lo, hi = out[:nch, 0], out[:nch, 1]
        assert nch == -(-N // TEAM_CHUNK) and lo[0] == 0 and hi[-1] == N, N
        assert np.array_equal(lo[1:], hi[:-1]) and np.all(hi - lo <= TEAM_CHUNK) and np.all(hi > lo), N


def test_team_workers_try_every_unit_once():
    """The order in which a worker of the team tries a stage's units (``team.unit_of``): its own
    share first (block w; chunks from w n / workers), then the rest in turn: every unit once, for
    1 to 4 workers and 1 to 9 units, in each kind of stage."""
    import taichi as ti
    from taichi_fdem.engine.team import FORCE, INTEG, JWORK, PRE, unit_of

    def order(kind, w, nwork, n, out):
        for k in range(n):
            out[k] = unit_of(kind, k, w, nwork, n)

    order.__annotations__ = dict(kind=ti.i32, w=ti.i32, nwork=ti.i32, n=ti.i32, out=ti.types.ndarray())
    order = ti.kernel(order)
    for kind in (PRE, FORCE, INTEG, JWORK):
        for nwork in range(1, 5):
            for n in range(1, 10):
                for w in range(nwork):
                    out = np.zeros(n, np.int32)
                    order(kind, w, nwork, n, out)
                    assert sorted(out) == list(range(n)), (kind, nwork, n, w, out)
                    first = w * n // nwork if kind == INTEG else w % n
                    assert out[0] == first


def _loaded_pair(strategy="parallel"):
    """A bar under every kind of load and constraint, pressed by a sliding block: a curve-driven
    prescribed velocity (its work booked), a traction, a pressure, a point force, an absorbing
    boundary, the local (quasi-static) damping, and contact with friction."""
    mat = fdem.Material(density=1000.0, young=1e7, poisson=0.25, friction=0.4)
    scene = fdem.Scene(gravity=(0.0, -9.81))
    bar = scene.add_body(fdem.mesh.rectangle(0.4, 0.1, 0.025), mat)
    block = scene.add_body(fdem.mesh.rectangle(0.1, 0.05, 0.025, origin=(-0.05, 0.0505)), mat, velocity=(1.0, -0.3))
    scene.fix_nodes(lambda x, y: x < -0.199, body=bar, velocity=(0.05, 0.0), curve=fdem.Curve.ramp(0.005))
    scene.apply_traction(lambda x, y: x > 0.199, (0.0, -2e3), body=bar, curve=fdem.Curve([0, 0.01], [0, 1]))
    scene.apply_pressure(lambda x, y: y > 0.049, 300.0, body=bar)
    scene.apply_force(lambda x, y: (x > 0.049) & (y > 0.1), (5.0, 0.0), body=block)
    scene.absorbing_boundary(lambda x, y: y < -0.049, body=bar)
    return scene.build(strategy=strategy, quasi_static=0.3)


def test_team_steps_give_the_same_bits_as_one_launch_per_step(monkeypatch):
    """The parallel strategy on the CPU runs many steps per launch, one thread per block and
    barriers between the phases (``run_steps_blocks``); with ``team_steps = False`` it launches
    once per step.  Loads, constraints, local damping, contact and friction: the same positions
    and velocities bit for bit, the same energy terms (the constraint and local-damping work
    are summed in another order: round-off)."""
    import taichi_fdem.sim.simulation as simmod
    out = {}
    for team in (True, False):
        sim = _loaded_pair()
        sim.solver.team_steps = team
        sim.run(0.02, progress=False)
        assert ("run_steps_blocks" in sim.solver.launches) == team
        assert ("step_parallel" in sim.solver.launches) != team
        out[team] = sim
    a, b = out[True], out[False]
    assert a.step_count == b.step_count and a.solver.detection_count == b.solver.detection_count > 1
    assert np.array_equal(a.node_positions(), b.node_positions())
    assert np.array_equal(a.node_velocities(), b.node_velocities())
    ea, eb = a.energies(), b.energies()
    for key in ("load_work", "boundary_work", "absorbed", "local_damping", "friction"):
        assert abs(eb[key]) > 0.0, key
    for key, val in eb.items():
        assert ea[key] == pytest.approx(val, rel=1e-12, abs=1e-15), key


def test_team_detects_inside_its_launch_with_the_same_bits(monkeypatch):
    """Up to DETECT_SERIAL_TRIS contact triangles the team's first worker runs each contact
    detection inside the launch (the serial broad phase; no return to the host, whose waking of
    the team cost ~1 ms per launch on the 2-core VM); above it the launch ends when detection is
    due and the host runs the parallel broad phase.  The same couples, so the same bits.  (A
    couple buffer too small for the new couples ends the launch and the host grows it:
    tests/test_detection.py::test_redetection_while_moving_and_buffer_growth.)"""
    import taichi_fdem.sim.simulation as simmod
    import taichi_fdem.sim.team as teammod
    _team_stays(monkeypatch, teammod)     # launch counts compared below
    runs = {}
    for inside in (True, False):
        monkeypatch.setattr(simmod, "DETECT_SERIAL_TRIS", 10**9 if inside else 0)
        sim = _loaded_pair()
        sim.run(0.02, progress=False)
        runs[inside] = sim
    a, b = runs[True], runs[False]
    assert a.step_count == b.step_count and a.solver.detection_count == b.solver.detection_count >= 3
    assert np.array_equal(a.couples(), b.couples())
    assert np.array_equal(a.node_positions(), b.node_positions())
    assert np.array_equal(a.node_velocities(), b.node_velocities())
    # the host detected at build, the team every other time
    assert a.solver.launches["detect_serial"] == 1
    assert b.solver.launches.get("detect_serial", 0) == 0 and b.solver.launches["detect_fill"] >= b.solver.detection_count - 1
    assert "detect_fill" not in a.solver.launches


def test_team_steps_stop_at_the_unstable_step(monkeypatch):
    """A time step 4× the stable limit: the team launch stops after the first unstable step,
    as the per-step launches do, and the run ends with a diagnosis."""
    import taichi_fdem.sim.simulation as simmod
    import taichi_fdem.sim.team as teammod
    _team_stays(monkeypatch, teammod)     # launch counts compared below
    steps = {}
    for team in (True, False):
        mat = fdem.Material(density=1000.0, young=1e7, poisson=0.25)
        scene = fdem.Scene(gravity=(0.0, 0.0))
        scene.add_body(fdem.mesh.rectangle(0.2, 0.1, 0.025), mat, angular_velocity=3.0)
        sim = scene.build(strategy="parallel", dt=None)
        sim = scene.build(strategy="parallel", dt=4.0 * sim.model.dt_limit, force_dt=True)
        sim.solver.team_steps = team
        with pytest.raises(fdem.SimulationError):
            sim.step(5000)
        steps[team] = sim.step_count
    assert steps[True] == steps[False] < 5000


def test_parallel_detection_lists_the_couples_in_the_serial_order(monkeypatch):
    """The parallel broad phase bins the triangles with atomic slot counters, in whatever order
    the threads take them; each cell is then sorted, so the couple list is the one the serial
    strategy's in-kernel detection builds from the same positions, entry for entry (the block
    assembly deals couples by list position: a different order would change the sums).  The
    one-launch serial detection of the parallel strategy's smaller scenes
    (``DETECT_SERIAL_TRIS``) lists them in that order too."""
    import taichi_fdem.sim.simulation as simmod
    from taichi_fdem.engine.groups import DACC, DACC_FORCE
    from taichi_fdem.sim.model import set_counter
    monkeypatch.setattr(simmod, "DETECT_SERIAL_TRIS", 0)
    mat = fdem.Material(density=1000.0, young=1e7, poisson=0.25)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    rng = np.random.default_rng(3)
    for i in range(14):
        for j in range(7):
            scene.add_body(fdem.mesh.disk(0.05, 0.012), mat, position=(0.1 * i, 0.1 * j),
                           velocity=tuple(rng.normal(0.0, 0.5, 2)))
    sim = scene.build(strategy="parallel")
    assert sim.model.tri_count > 10_000
    sim.step(200)                                 # the disks have moved and met
    set_counter(sim.state.step_real, DACC, DACC_FORCE)
    launches = dict(sim.solver.launches)
    sim._detect()                                 # the parallel kernels
    par = sim.couples()
    assert sim.solver.launches["detect_fill"] == launches.get("detect_fill", 0) + 1
    monkeypatch.setattr(simmod, "DETECT_SERIAL_TRIS", sim.model.tri_count)
    sim._detect()                                 # one serial launch
    one = sim.couples()
    assert sim.solver.launches["detect_serial"] == launches.get("detect_serial", 0) + 1
    assert np.array_equal(par, one)
    sim.solver.strategy = "serial"
    set_counter(sim.state.step_real, DACC, DACC_FORCE)
    sim.step(1)                                   # the serial kernel detects from the same positions
    ser = sim.couples()
    assert len(par) > 2_000 and np.array_equal(par, ser)


def _per_step_reference():
    """The bar under every load, run with one launch per step (no team): the reference bits."""
    sim = _loaded_pair()
    sim.solver.team_steps = False
    sim.run(0.01, progress=False)
    return sim


def _same_bits(a, b):
    assert a.step_count == b.step_count and a.solver.detection_count == b.solver.detection_count > 1
    assert np.array_equal(a.node_positions(), b.node_positions())
    assert np.array_equal(a.node_velocities(), b.node_velocities())


def test_a_team_with_more_workers_than_threads_finishes_with_the_same_bits(monkeypatch):
    """A team launch of 8 workers on Taichi's threads (2 here, or 1): no worker waits for a
    worker that has no thread, so the launch ends whatever the runtime does with the surplus
    workers (they run later, or alongside), and with the same bits as one launch per step."""
    import taichi_fdem.sim.simulation as simmod
    monkeypatch.setattr(simmod.Simulation, "_team_size", lambda self: 8)
    ref = _loaded_pair()
    ref.solver.force_blocks = 8
    ref.solver.team_steps = False
    ref.run(0.01, progress=False)
    sim = _loaded_pair()
    sim.solver.force_blocks = 8
    seen = []
    launch = sim._launch_cached

    def spy(name, kernel, *args):
        if name == "run_steps_blocks":
            seen.append(args[1])
        return launch(name, kernel, *args)
    sim._launch_cached = spy
    sim.run(0.01, progress=False)
    assert 8 in seen and 8 > backend_threads()
    _same_bits(sim, ref)


_PINNED_TEAM = """
import os, sys, json
os.sched_setaffinity(0, {0})
import numpy as np
import taichi_fdem as fdem
from taichi_fdem.sim.simulation import Simulation
fdem.init(arch="cpu", cpu_max_num_threads=2)
sys.path.insert(0, sys.argv[1])
from test_parallel import _loaded_pair
assert fdem.backend.usable_cores() == 1
out = {}
for team in (True, False):
    Simulation._team_size = lambda self: 2       # a team of 2 on 1 usable core
    sim = _loaded_pair()
    sim.solver.team_steps = team
    seen = []
    launch = sim._launch_cached
    def spy(name, kernel, *args, launch=launch, seen=seen):
        if name == "run_steps_blocks":
            seen.append(args[1])
        return launch(name, kernel, *args)
    sim._launch_cached = spy
    sim.run(0.01, progress=False)
    out[team] = (sim, seen)
(a, seen), (b, _) = out[True], out[False]
print(json.dumps({"workers": max(seen), "steps": [a.step_count, b.step_count],
                  "detections": [a.solver.detection_count, b.solver.detection_count],
                  "same": bool(np.array_equal(a.node_positions(), b.node_positions())
                               and np.array_equal(a.node_velocities(), b.node_velocities())),
                  "team": a.info()["team"]}))
"""


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="needs os.sched_setaffinity (Linux)")
def test_a_team_of_two_on_one_usable_core_finishes_with_the_same_bits():
    """``taskset -c 0`` (a one-core cpuset): a team of two workers forced onto two Taichi threads
    that share one core.  Every wait is bounded and no worker waits for work nobody started, so
    the run ends (bounded waits, resumption, one worker) with the same bits as one launch per
    step.  Run in a fresh process pinned to CPU 0."""
    here = os.path.dirname(os.path.abspath(__file__))
    res = subprocess.run([sys.executable, "-c", _PINNED_TEAM, here], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    got = json.loads(res.stdout.strip().splitlines()[-1])
    assert got["workers"] == 2
    assert got["steps"][0] == got["steps"][1] > 0 and got["detections"][0] == got["detections"][1] > 1
    assert got["same"], got


def test_a_team_stopped_between_stages_resumes_with_the_same_bits(monkeypatch):
    """A launch that stops between two stages (as when a wait runs past its bound) is resumed by
    one worker, which claims what is left: here every launch stops after each stage (flag bit
    2 of ``run_steps_blocks``), and the trajectory is the same bits as one launch per step; the
    resumptions are counted in ``sim.info()``."""
    import taichi_fdem.sim.team as simmod
    ref = _per_step_reference()
    sim = _loaded_pair()
    launch = sim._launch_cached

    def stop_after_each_stage(name, kernel, *args):
        if name == "run_steps_blocks":
            args = args[:2] + (args[2] | 4,) + args[3:]
        return launch(name, kernel, *args)
    sim._launch_cached = stop_after_each_stage
    sim.run(0.01, progress=False)
    _same_bits(sim, ref)
    stats = sim.info()["team"]
    assert stats["resumed"] > 1.5 * sim.step_count     # two stages or more per step (forces, integration)
    # waits bounded at one try: whatever the timing, the same bits
    monkeypatch.setattr(simmod, "TEAM_SPINS_PER_S", 0.0)
    monkeypatch.setattr(simmod, "TEAM_WAIT_MIN", 0.0)
    sim = _loaded_pair()
    sim.run(0.01, progress=False)
    _same_bits(sim, ref)


def _team_stays(monkeypatch, teammod):
    """No switch to one worker and no wait past its bound, whatever the load beside the test:
    launch counts are then a function of the scene alone."""
    monkeypatch.setattr(teammod, "TEAM_CPU_SHARE", 0.0)
    monkeypatch.setattr(teammod, "TEAM_WAIT_MIN", 60.0)


def test_a_team_on_a_shared_cpu_switches_to_one_worker_and_back_with_the_same_bits(monkeypatch):
    """A team launch whose workers got less CPU time than TEAM_CPU_SHARE of their wall time
    hands the next launches to one worker, which hands them back when the other cores were
    idle (``TeamScheduler.judge``).  Here every team launch counts as descheduled and every
    solo one as idle, so the run switches at every launch: the same bits as one launch per
    step, and the counters say so; with one worker throughout, the same bits too."""
    import taichi_fdem.sim.team as teammod
    ref = _per_step_reference()
    monkeypatch.setattr(teammod, "TEAM_CPU_SHARE", 1e9)
    monkeypatch.setattr(teammod, "TEAM_IDLE_SHARE", 0.0)
    monkeypatch.setattr(teammod, "TEAM_JUDGE_S", 0.0)
    monkeypatch.setattr(teammod, "TEAM_RETRY_FIRST", 0.0)
    monkeypatch.setattr(teammod, "TEAM_RETRY_MAX", 0.0)
    sim = _loaded_pair()
    sim.run(0.01, progress=False)
    stats = sim.info()["team"]
    assert stats["to_solo"] >= 1 and stats["to_team"] >= 1
    assert 0 < stats["solo_steps"] < sim.step_count
    _same_bits(sim, ref)
    sim = _loaded_pair()
    sim._teams.solo, sim._teams.retry_at = True, float("inf")
    sim.run(0.01, progress=False)
    assert sim.info()["team"]["solo_steps"] == sim.step_count
    assert sim.info()["team"]["to_team"] == 0
    _same_bits(sim, ref)


def test_idle_seconds_reads_the_affinity_set():
    """The idle time of the usable cores grows with the wall clock and never by more than the
    cores' count times it (Linux /proc/stat; None elsewhere)."""
    import os
    import time
    from taichi_fdem.sim.team import idle_seconds
    if not os.path.exists("/proc/stat"):
        assert idle_seconds() is None
        return
    cpus = os.sched_getaffinity(0)
    a, t0 = idle_seconds(), time.perf_counter()
    time.sleep(0.3)
    b, t1 = idle_seconds(), time.perf_counter()
    assert 0.0 <= b - a <= len(cpus) * (t1 - t0) + 0.05
    assert idle_seconds(set()) == 0.0


def _couple_costs(sim) -> np.ndarray:
    """Brute-force reference of ``engine.blocks.couple_cost`` for every couple, in numpy: a bonded
    neighbour pair; touching (boxes overlap and no separating edge normal among six); apart by
    less than the rounding margin; or apart by more (then its certificate of separation skips
    it, plus the share of steps it is tested again: the growth of D_acc per step over the gap)."""
    from taichi_fdem.engine.groups import COST_BONDED, COST_CERTIFIED, COST_SEPARATED, COST_TOUCHING, VMAX
    from taichi_fdem.sim.model import counter
    rel = 1e-8                                  # engine.contact.couple_certificate, f64
    x = sim.node_positions()
    tn = sim.model.tri_nodes.to_numpy()
    pairs = sim.couples()
    A, B = x[tn[pairs[:, 0]]], x[tn[pairs[:, 1]]]              # (C, 3, 2)
    gap = np.maximum(B.min(1) - A.max(1), A.min(1) - B.max(1)).max(1)
    ext = (A.max(1) - A.min(1)).max(1)
    cert = np.where(gap < 0.0, -1.0, gap - rel * ext)

    def edge_cert(T, P, cert):
        for k in range(3):
            e0 = T[:, k]
            d = T[:, (k + 1) % 3] - e0
            n = np.stack([d[:, 1], -d[:, 0]], axis=1)
            dist = np.einsum("cpi,ci->cp", P - e0[:, None, :], n).min(1)        # g |e|
            n2 = (n * n).sum(1)
            c = np.where(dist > 2.0 * rel * n2, (dist - rel * n2) / np.sqrt(n2), 0.0)
            cert = np.where((cert < 0.0) & (gap < 0.0) & (dist >= 0.0), c, cert)
        return cert

    cert = edge_cert(B, A, edge_cert(A, B, cert))
    touching = (gap < 0.0) & (cert < 0.0)
    growth = 2.0 * sim.dt * counter(sim.state.step_real, VMAX)
    certified = COST_CERTIFIED + np.floor(COST_SEPARATED * np.minimum(1.0, growth / np.maximum(cert, 1e-300)))
    cost = np.where(touching, COST_TOUCHING, np.where(cert <= 0.0, COST_SEPARATED, certified))
    M = sim.model.nb_count
    cost[:M] = np.where(sim.state.tri_nb_on.to_numpy()[:M] == 0, COST_BONDED, cost[:M])
    return cost


def _block_fixed_costs(sim, nblk) -> np.ndarray:
    """Brute-force reference of ``engine.blocks.block_fixed_cost``: each block's triangles and
    joints (ranges by count), a joint costing as intact, damaged or broken."""
    from taichi_fdem.engine.groups import COST_BROKEN, COST_JOINT, COST_JOINT_DAMAGED, COST_TRI
    T, J = sim.model.tri_count, sim.model.joint_count
    state = sim.state.joint_state.to_numpy()
    damaged = (sim.state.joint_dmax.to_numpy() > 0.0).any(1)
    jc = np.where(state != 0, COST_BROKEN, np.where(damaged, COST_JOINT_DAMAGED, COST_JOINT))
    return np.array([((b + 1) * T // nblk - b * T // nblk) * COST_TRI + jc[b * J // nblk:(b + 1) * J // nblk].sum()
                     for b in range(nblk)])


def test_block_couple_ranges_follow_the_estimated_cost():
    """The block assembly splits the couples into contiguous ranges so that the blocks' estimated
    costs (their triangles and joints by count, their couples) come out about equal
    (``engine.blocks.rebalance_couples``), recomputed from the state: checked against a brute-force
    costing of every couple and joint in a plate breaking under a disc, 3 blocks, where ranges
    of equal counts would be far from equal cost.  Each block boundary is within one touching
    couple of its share of the total; the ranges cover the couples once, in order."""
    from taichi_fdem.engine.groups import COST_TOUCHING, REBALANCE, REBALANCE_STEPS, SPLIT
    from taichi_fdem.sim.model import counter, set_counter
    from taichi_fdem.verification import fragment_plate_scene
    sim, _ = fragment_plate_scene(h_plate=0.012, h_ball=0.02, friction=0.5)
    sim = sim.scene.build(strategy="parallel")
    sim.solver.force_blocks = 3
    sim.step(250)                              # the first joints break under the disc
    assert sim.cracks.broken_count > 0
    cost = _couple_costs(sim)                  # at the state the next step starts from
    fixed = _block_fixed_costs(sim, 3)
    set_counter(sim.state.step_int, REBALANCE, 0)
    sim.step(1)
    assert counter(sim.state.step_int, REBALANCE) == REBALANCE_STEPS - 1
    C = len(cost)
    split = sim.state.step_int.to_numpy()[SPLIT:SPLIT + 4]
    assert split[0] == 0 and split[3] == C and np.all(np.diff(split) >= 0)
    prefix = np.concatenate([[0], np.cumsum(cost)])
    total = prefix[-1] + fixed.sum()
    for b in (1, 2):
        before = fixed[:b].sum() + prefix[split[b]]          # the blocks before b
        assert abs(before - b * total / 3) <= COST_TOUCHING, (b, split, before, total)
    # the test can fail: equal counts would leave the blocks' costs far apart here
    by_count = [fixed[:b].sum() + prefix[b * C // 3] for b in (1, 2)]
    assert max(abs(by_count[b - 1] - b * total / 3) for b in (1, 2)) > 10 * COST_TOUCHING



def test_team_workers_cap_the_team_and_keep_the_bits(monkeypatch):
    """``sim.solver.team_workers`` caps the workers of a team launch (benchmarks/threads.py
    compares a team of one with a team of two in one process): the same bits either way, and a
    bad value is refused by name."""
    import taichi_fdem.sim.simulation as simmod
    import taichi_fdem.sim.team as teammod
    _team_stays(monkeypatch, teammod)     # launch counts compared below
    out = {}
    for workers in (1, None):
        sim = _loaded_pair()
        sim.solver.team_workers = workers
        assert sim.solver.team_workers == workers
        assert sim._team() == (1 if workers == 1 else min(sim.solver.force_blocks, backend_threads()))
        sim.run(0.01, progress=False)
        assert "run_steps_blocks" in sim.solver.launches
        out[workers] = sim
    assert np.array_equal(out[1].node_positions(), out[None].node_positions())
    assert np.array_equal(out[1].node_velocities(), out[None].node_velocities())
    for bad in (0, -1, 1.5, True, "2"):
        with pytest.raises(ValueError, match="team_workers"):
            out[1].solver.team_workers = bad


def backend_threads():
    from taichi_fdem import backend
    return backend.cpu_threads()


def test_team_scheduler_judges_cpu_time_and_idle_cores(monkeypatch):
    """``TeamScheduler.judge`` from the counters alone (no launch): the compiling launch is not
    judged; team launches that lacked CPU time hand over to one worker once they span
    TEAM_JUDGE_S, a wait past its bound at once; one worker hands back only when the other cores
    were idle and the back-off has passed, and the back-off doubles after each failed return."""
    import taichi_fdem.sim.team as teammod

    class Sim:
        def _team_size(self):
            return 2

    sim, ts = Sim(), teammod.TeamScheduler()
    clock = [100.0]
    monkeypatch.setattr(teammod._time, "perf_counter", lambda: clock[0])
    ts.judge(sim, 2, 5.0, 1.0, False, None)                 # compiled: no verdict
    assert not ts.solo and ts.trial and ts.warm
    ts.judge(sim, 2, 0.03, 0.06, False, None)               # full share, too short for a verdict
    assert ts.trial
    ts.judge(sim, 2, 0.03, 0.06, False, None)               # now 0.06 s at a full share: healthy
    assert not ts.solo and not ts.trial
    ts.judge(sim, 2, 0.1, 0.1, False, None)                 # half the CPU time: descheduled
    assert ts.solo and ts.stats["to_solo"] == 1 and ts.retry_at == 100.0 + teammod.TEAM_RETRY_FIRST
    idle = [0.0]
    monkeypatch.setattr(teammod, "idle_seconds", lambda cpus=None: idle[0])
    idle[0] = 0.01                                          # the other core busy
    ts.judge(sim, 1, 0.1, 0.1, False, 0.0)
    assert ts.solo
    idle[0] = 0.1                                           # idle, but before the back-off ends
    ts.judge(sim, 1, 0.1, 0.1, False, 0.0)
    assert ts.solo
    clock[0] = 101.5
    ts.judge(sim, 1, 0.1, 0.1, False, 0.0)                  # idle and past it: the team again
    assert not ts.solo and ts.trial and ts.stats["to_team"] == 1
    ts.judge(sim, 2, 0.001, 0.002, True, None)              # a wait past its bound: at once
    assert ts.solo and ts.stats["to_solo"] == 2
    assert ts.retry_at == 101.5 + 2 * teammod.TEAM_RETRY_FIRST
    monkeypatch.setattr(teammod, "idle_seconds", lambda cpus=None: None)
    clock[0] = 110.0                                        # no idle counters: the back-off alone
    ts.judge(sim, 1, 0.1, 0.1, False, None)
    assert not ts.solo and ts.stats["to_team"] == 2

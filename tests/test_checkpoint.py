"""Checkpoints: Simulation.save / Simulation.load continue a run exactly; atomic writes; bad files."""
from __future__ import annotations

import json
import os
import pickle

import numpy as np
import pytest
import taichi as ti

import taichi_fdem as fdem
from taichi_fdem.io import checkpoint
from taichi_fdem.io.checkpoint import CheckpointError


def block_on_floor(strategy="serial"):
    """A damped block thrown onto a deformable floor whose bottom is held by a fix_nodes lambda:
    contact with friction (pair override by set_interaction), contact damping, viscous damping."""
    floor = fdem.Material(density=1000.0, young=2e7, poisson=0.3, friction=0.5, name="floor")
    block = fdem.Material(density=1200.0, young=1e7, poisson=0.25, friction=0.5, damping=0.05,
                          contact_damping=0.05, name="block")
    scene = fdem.Scene(gravity=(0.0, -9.81))
    fl = scene.add_body(fdem.mesh.rectangle(0.4, 0.05, 0.05), floor, position=(0.0, -0.025), name="floor")
    scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05), block, position=(0.0, 0.0501), velocity=(1.0, -0.5),
                   name="block")
    scene.fix_nodes(lambda x, y: y < -0.049, body=fl)
    scene.set_interaction(floor, block, friction=0.3)
    return scene.build(strategy=strategy)


def ndarrays(sim) -> dict:
    """Every Taichi array of the simulation: model, state and detection scratch."""
    out = {}
    for part in (sim.model, sim.state, sim.solver.scratch):
        out.update({k: v.to_numpy() for k, v in vars(part).items() if isinstance(v, ti.Ndarray)})
    return out


@pytest.mark.parametrize("strategy", ["serial", "parallel"])
def test_restart_continues_exactly(tmp_path, strategy):
    path = tmp_path / "run.ckpt"
    a = block_on_floor(strategy)
    a.step(150)
    a._alloc_couples(3 * a.state.couple_max)         # a couple buffer that grew: its shape differs from a fresh build
    a.step(50)
    a.save(path)
    saved_step, saved_max = a.step_count, a.state.couple_max
    a.step(300)                                 # state A: the uninterrupted run

    b = fdem.Simulation.load(path)
    assert b.step_count == saved_step and b.state.couple_max == saved_max
    assert b.time == saved_step * a.dt
    b.step(300)                                 # state B: the restarted run

    assert b.step_count == a.step_count and b.time == a.time and b.dt == a.dt
    assert [x.name for x in b.bodies] == ["floor", "block"]
    assert a.model.friction and a.model.damping and a.model.contact_damping and a.model.has_bc and a.solver.couple_count > 0
    ea, eb = a.energies(), b.energies()         # (before comparing arrays: fills the _energy_out scratch)
    for key in ea:
        assert eb[key] == pytest.approx(ea[key], rel=1e-12, abs=1e-15), key
    # the block slid with friction and the restarted run saw the same friction history
    assert ea["friction"] > 0.1
    A, B = ndarrays(a), ndarrays(b)
    assert A.keys() == B.keys()
    for name in A:
        assert A[name].shape == B[name].shape, name
        if strategy == "serial" or name in ("node_x", "node_v", "couple_hist", "tri_diss"):
            # serial: one thread, same operations; parallel: the forces and the per-item
            # accumulators are summed in a fixed order (block assembly): bit-identical
            np.testing.assert_array_equal(A[name], B[name], err_msg=name)
        else:                                   # per-chunk atomic sums (boundary work) may differ
            np.testing.assert_allclose(A[name], B[name], rtol=1e-12, atol=1e-15, err_msg=name)
    np.testing.assert_array_equal(a.couples(), b.couples())


def test_loaded_simulation_is_complete(tmp_path):
    a = block_on_floor()
    a.step(100)
    a.save(tmp_path / "c")                      # any name: no ".npz" appended
    assert sorted(os.listdir(tmp_path)) == ["c"]
    b = fdem.Simulation.load(str(tmp_path / "c"))
    # every attribute of the simulation and of its state and model is restored, arrays included
    parts = [(vars(a), b), (vars(a.state), b.state), (vars(a.model), b.model)]
    rebuilt = ("model", "state", "scratch", "_scratch", "_packs", "_groups", "_launch_cache", "_teams")
    views = ("solver", "cracks", "fluid", "loads")          # the simulation's views, made anew by load()
    for name, va, b_part in [(n, v, bp) for va_, bp in parts for n, v in va_.items()
                             if n not in rebuilt and not (bp is b and n in views)]:
        vb = getattr(b_part, name)
        if isinstance(va, ti.Ndarray):
            np.testing.assert_array_equal(va.to_numpy(), vb.to_numpy(), err_msg=name)
        elif isinstance(va, np.ndarray):
            np.testing.assert_array_equal(va, vb, err_msg=name)
        elif name not in ("scene", "bodies", "materials", "_real", "_rti", "_stats"):
            assert vb == va, name
    # the fix_nodes lambda was stored as the node mask it selected, in the restored scene too
    assert len(b.scene._constraints) == 1
    mask = b.scene._constraints[0].where(a.model.node_rest[:, 0], a.model.node_rest[:, 1])
    np.testing.assert_array_equal(mask, a.model.node_rest[:, 1] < -0.049)
    # the interaction override survives (keyed by the restored material objects)
    fl, bl = b.bodies[0].material, b.bodies[1].material
    assert b.scene._interactions[(id(fl), id(bl))] == {"friction": 0.3}
    # the restored meshes are still immutable
    assert not b.bodies[1].mesh.points.flags.writeable
    # the user's scene is untouched by saving
    assert callable(a.scene._constraints[0].where) and not isinstance(a.scene._constraints[0].where,
                                                                       checkpoint._NodeMask)


def test_crash_during_save_keeps_previous_checkpoint(tmp_path, monkeypatch):
    path = tmp_path / "run.ckpt"
    sim = block_on_floor()
    sim.step(50)
    sim.save(path)
    x_saved = sim.node_positions()
    sim.step(50)

    real_savez = np.savez

    def crashing_savez(file, *args, **kwargs):
        file.write(b"PK\x03\x04 half a zip archive")       # some bytes reach the disk, then...
        raise KeyboardInterrupt                            # ...the process is interrupted

    monkeypatch.setattr(np, "savez", crashing_savez)
    with pytest.raises(KeyboardInterrupt):
        sim.save(path)
    monkeypatch.setattr(np, "savez", real_savez)
    assert sorted(os.listdir(tmp_path)) == ["run.ckpt"]    # no temporary file left behind
    back = fdem.Simulation.load(path)                       # the previous checkpoint is intact
    assert back.step_count == 50
    np.testing.assert_array_equal(back.node_positions(), x_saved)


def _rewrite_meta(src, dst, **changes):
    with np.load(src) as z:
        data = {k: z[k] for k in z.files}
    meta = json.loads(str(data["meta"]))
    meta.update(changes)
    data["meta"] = np.array(json.dumps(meta))
    with open(dst, "wb") as fh:
        np.savez(fh, **data)


def test_bad_checkpoints_refused(tmp_path):
    good = tmp_path / "good.ckpt"
    sim = block_on_floor()
    sim.step(10)
    sim.save(good)
    raw = good.read_bytes()

    garbage = tmp_path / "garbage.ckpt"
    garbage.write_bytes(b"this is not a checkpoint at all" * 10)
    with pytest.raises(CheckpointError, match=r"garbage\.ckpt' is not a readable taichi_fdem checkpoint"):
        fdem.Simulation.load(garbage)

    truncated = tmp_path / "truncated.ckpt"
    truncated.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(CheckpointError, match=r"truncated\.ckpt' is not a readable .*corrupt or truncated"):
        fdem.Simulation.load(truncated)

    flipped = bytearray(raw)                   # damage bytes inside the archive's data
    for k in range(len(flipped) // 3, len(flipped) // 3 + 64):
        flipped[k] ^= 0xFF
    corrupt = tmp_path / "corrupt.ckpt"
    corrupt.write_bytes(bytes(flipped))
    with pytest.raises(CheckpointError, match=r"corrupt\.ckpt"):
        fdem.Simulation.load(corrupt)

    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, x=np.zeros(3))
    with pytest.raises(CheckpointError, match=r"foreign\.npz' is not a taichi_fdem checkpoint \(missing meta"):
        fdem.Simulation.load(foreign)

    single = tmp_path / "single.npy"
    np.save(single, np.zeros(3))
    with pytest.raises(CheckpointError, match=r"single NumPy array"):
        fdem.Simulation.load(single)

    newer = tmp_path / "newer.ckpt"
    _rewrite_meta(good, newer, version=checkpoint.FORMAT_VERSION + 1)
    v = checkpoint.FORMAT_VERSION
    with pytest.raises(CheckpointError, match=rf"format version {v + 1}; this taichi_fdem reads version {v}"):
        fdem.Simulation.load(newer)

    f32 = tmp_path / "f32.ckpt"
    _rewrite_meta(good, f32, precision="f32")
    with pytest.raises(CheckpointError, match=r"written with precision 'f32' but taichi_fdem runs in 'f64'; "
                                              r"call fdem.init\(precision='f32'\)"):
        fdem.Simulation.load(f32)

    with pytest.raises(FileNotFoundError):
        fdem.Simulation.load(tmp_path / "missing.ckpt")
    assert isinstance(CheckpointError("x"), ValueError)


def test_unstorable_attribute_named(tmp_path):
    sim = block_on_floor()
    sim.on_frame = lambda s: None              # something a user hung on the simulation
    try:
        with pytest.raises(TypeError, match=r"attribute 'on_frame' \(function\) cannot be stored"):
            sim.save(tmp_path / "x.ckpt")
    finally:
        del sim.on_frame
    assert not os.listdir(tmp_path)
    with pytest.raises(FileNotFoundError, match=r"directory .*nowhere.* does not exist"):
        sim.save(tmp_path / "nowhere" / "x.ckpt")


def test_scene_pickle_is_plain_data(tmp_path):
    """The scene stored in a checkpoint unpickles without Taichi objects (meshes, materials, bodies)."""
    sim = block_on_floor()
    sim.save(tmp_path / "s.ckpt")
    with np.load(tmp_path / "s.ckpt") as z:
        bundle = pickle.loads(z["scene"].tobytes())
    scene = bundle["scene"]
    assert [b.name for b in scene.bodies] == ["floor", "block"]
    assert scene.bodies[1].material.damping == 0.05
    assert scene.node_count == sim.model.node_count and scene.tri_count == sim.model.tri_count


def test_checkpoint_after_run_keeps_last_good_state(tmp_path):
    """run() records a last good state; a checkpoint carries it, so restore_last_good works after load."""
    a = block_on_floor()
    a.run(100 * a.dt, progress=False)
    a.step(30)
    a.save(tmp_path / "r.ckpt")
    b = fdem.Simulation.load(tmp_path / "r.ckpt")
    assert b.step_count == a.step_count == 130
    assert b.restore_last_good() == a.restore_last_good() == 100
    np.testing.assert_array_equal(b.node_positions(), a.node_positions())
    # the penetration check's scratch buffers (a tuple of Taichi ndarrays) came back as ndarrays
    pen = b._pen_buffers
    assert len(pen) == 2 and all(isinstance(x, ti.Ndarray) for x in pen)


def test_ndarrays_inside_containers_are_stored(tmp_path):
    a = block_on_floor()
    scratch = ti.ndarray(ti.f64, shape=5)
    scratch.from_numpy(np.arange(5.0))
    a.my_cache = {"buffers": (scratch, [scratch]), "n": 3}
    try:
        a.save(tmp_path / "c.ckpt")
    finally:
        del a.my_cache
    b = fdem.Simulation.load(tmp_path / "c.ckpt")
    assert b.my_cache["n"] == 3
    first, (second,) = b.my_cache["buffers"]
    assert isinstance(first, ti.Ndarray) and isinstance(second, ti.Ndarray)
    np.testing.assert_array_equal(first.to_numpy(), np.arange(5.0))
    np.testing.assert_array_equal(second.to_numpy(), np.arange(5.0))


def test_checkpoint_without_parameter_slots_loads(tmp_path):
    """A checkpoint written before the parameter slots (step_real ended at HANDOVER, step_int at
    RANGE; time step, buffer, speed limit, gravity and switches were arrays of the model) takes them
    from the rebuilt model and continues as the saved run."""
    from taichi_fdem.engine import groups
    path, old = tmp_path / "run.ckpt", tmp_path / "old.ckpt"
    a = block_on_floor("serial")
    a.step(100)
    a.save(path)
    with np.load(path) as z:
        data = {k: z[k] for k in z.files}
    meta = json.loads(str(data["meta"]))
    data["nd.step_real"] = data["nd.step_real"][: groups.HANDOVER + 1]
    data["nd.step_int"] = data["nd.step_int"][: groups.SWITCHES]
    meta["ndarrays"]["step_real"]["shape"] = [groups.HANDOVER + 1]
    meta["ndarrays"]["step_int"]["shape"] = [groups.SWITCHES]
    data["meta"] = np.array(json.dumps(meta))
    with open(old, "wb") as fh:
        np.savez(fh, **data)
    b = fdem.Simulation.load(old)
    new = fdem.Simulation.load(path)
    np.testing.assert_array_equal(b.state.step_real.to_numpy(), new.state.step_real.to_numpy())
    c = b.state.counters
    assert c.dt == a.dt and c.buffer == a.model.buffer and (c.gravity_x, c.gravity_y) == pytest.approx((0.0, -9.81))
    assert c.switches == a.state.counters.switches != 0
    a.step(50)
    b.step(50)
    np.testing.assert_array_equal(a.state.node_x.to_numpy(), b.state.node_x.to_numpy())


def test_checkpoint_naming_the_records_under_scene_loads(tmp_path, monkeypatch):
    """Checkpoints pickled Body, Curve and the records of constraints, loads, initial stress, fluid
    and heat under ``taichi_fdem.scene`` before they moved to ``taichi_fdem.records``; such a
    checkpoint loads (scene.py re-exports them) and continues as the saved run."""
    from taichi_fdem import records
    floor = fdem.Material(density=1000.0, young=2e7, poisson=0.3, friction=0.5)
    scene = fdem.Scene(gravity=(0.0, -9.81))
    fl = scene.add_body(fdem.mesh.rectangle(0.4, 0.05, 0.05), floor, position=(0.0, -0.025), name="floor")
    scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05), floor, position=(0.0, 0.0501), name="block")
    scene.fix_nodes(lambda x, y: y < -0.049, body=fl, curve=fdem.Curve.ramp(1e-3))
    scene.apply_force(lambda x, y: y > 0.1, (0.0, -5.0), curve=fdem.Curve([0.0, 1e-3], [1.0, 2.0], name="up"))
    a = scene.build(strategy="serial")
    a.step(60)
    path, old = tmp_path / "new.ckpt", tmp_path / "old.ckpt"
    a.save(path)
    with np.load(path) as z:
        data = {k: z[k] for k in z.files}
    assert b"taichi_fdem.records" in data["scene"].tobytes()
    bundle = pickle.loads(data["scene"].tobytes())
    extra = [records._HeatSpec(None, None, 20.0, None, fdem.Curve.ramp(1.0)),
             records._FluidSpec(fdem.Fluid(bulk_modulus=1e8), 1e-5, None, 0.0, "broken"),
             records._Injection(None, 1e-3, None), records._InitialStress(None, np.ones(3), np.zeros(3), 0.0)]
    moved = [c for c in vars(records).values() if isinstance(c, type) and c.__module__ == records.__name__]
    assert {c.__name__ for c in moved} >= {"Body", "Curve", "_NodeConstraint", "_Load", "_HeatSpec", "_FluidSpec"}
    with monkeypatch.context() as m:                # pickle them as the earlier versions did
        for c in moved:
            m.setattr(c, "__module__", "taichi_fdem.scene")
        data["scene"] = np.frombuffer(pickle.dumps(bundle, protocol=pickle.HIGHEST_PROTOCOL), dtype=np.uint8)
        extra_bytes = pickle.dumps(extra)
    assert b"taichi_fdem.records" not in data["scene"].tobytes() + extra_bytes
    assert [type(r) for r in pickle.loads(extra_bytes)] == [type(r) for r in extra]
    assert pickle.loads(extra_bytes)[0].curve == extra[0].curve
    with open(old, "wb") as fh:
        np.savez(fh, **data)
    b = fdem.Simulation.load(old)
    assert type(b.bodies[0]) is records.Body and b.scene._loads[0].curve.name == "up"
    a.step(40)
    b.step(40)
    np.testing.assert_array_equal(a.state.node_x.to_numpy(), b.state.node_x.to_numpy())

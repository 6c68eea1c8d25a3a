"""ExporterVtu: a VTU series with a ParaView .pvd index, read back with meshio and xml.etree."""
from __future__ import annotations

import os
import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem.io.vtu import ExporterVtu, frame_fields


def sliding_block(velocity=(1.0, -0.5)):
    """A soft 0.1 m block hitting / sliding on a fixed floor (two bodies, two materials, friction)."""
    floor_mat = fdem.Material(density=1000.0, young=2e7, poisson=0.3, friction=0.4, name="floor")
    block_mat = fdem.Material(density=1000.0, young=1e7, poisson=0.25, friction=0.4, name="block")
    scene = fdem.Scene(gravity=(0.0, -9.81))
    scene.add_body(fdem.mesh.rectangle(0.4, 0.05, 0.05), floor_mat, position=(0.0, -0.025), fixed=True,
                   name="floor")
    scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05), block_mat, position=(0.0, 0.0501), velocity=velocity,
                   name="block")
    return scene.build(strategy="serial")


def read_pvd(path):
    """[(timestep, file)] of a ParaView collection file (raises if it is not valid XML)."""
    root = ET.parse(path).getroot()
    assert root.tag == "VTKFile" and root.get("type") == "Collection"
    return [(float(d.get("timestep")), d.get("file")) for d in root.find("Collection").findall("DataSet")]


def test_series_values_roundtrip(tmp_path):
    sim = sliding_block()
    expected = []
    with ExporterVtu(tmp_path / "out", prefix="run") as exp:
        for _ in range(3):
            sim.step(40)
            exp.write(sim)
            expected.append((sim.time, sim.node_positions(), sim.node_displacements(), sim.node_velocities(),
                             sim.stresses()))
    assert exp.closed and exp.frame_count == 3
    entries = read_pvd(tmp_path / "out" / "run.pvd")
    assert [f for _, f in entries] == ["run_000000.vtu", "run_000001.vtu", "run_000002.vtu"]
    assert [t for t, _ in entries] == [e[0] for e in expected]       # exact: timestep written with repr
    assert entries[0][0] < entries[1][0] < entries[2][0]
    assert not [p for p in os.listdir(tmp_path / "out") if p.endswith(".tmp")]

    tri_body = np.repeat([0, 1], [sim.bodies[0].mesh.triangle_count, sim.bodies[1].mesh.triangle_count])
    node_body = np.repeat([0, 1], [sim.bodies[0].mesh.point_count, sim.bodies[1].mesh.point_count])
    for (t, x, u, v, T), (_, name) in zip(expected, entries):
        m = meshio.read(tmp_path / "out" / name)
        np.testing.assert_array_equal(m.points[:, :2], x)
        np.testing.assert_array_equal(m.points[:, 2], 0.0)
        np.testing.assert_array_equal(m.cells_dict["triangle"], sim.model.tri_nodes_np)
        np.testing.assert_allclose(m.point_data["displacement"][:, :2], u, rtol=0, atol=1e-15)
        np.testing.assert_array_equal(m.point_data["velocity"][:, :2], v)
        np.testing.assert_array_equal(m.point_data["body_id"], node_body)
        stress = m.cell_data["stress"][0]
        np.testing.assert_array_equal(stress, np.stack([T[:, 0, 0], T[:, 1, 1], T[:, 0, 1]], axis=1))
        # von Mises: its value is checked against hand computations in tests/test_render.py
        # (plane stress; plane strain with σ_zz); here only that it is written, per triangle
        assert m.cell_data["von_mises"][0].shape == (sim.model.tri_count,)
        np.testing.assert_array_equal(m.cell_data["body_id"][0], tri_body)
        np.testing.assert_array_equal(m.cell_data["material_id"][0], tri_body)   # one material per body here
        np.testing.assert_array_equal(m.cell_data["damage"][0], 0.0)
        assert m.cell_data["strain"][0].shape == (sim.model.tri_count, 3)
    # the block has moved and is stressed by the impact; the fixed floor has not moved
    u_last = expected[-1][2]
    assert np.abs(u_last[node_body == 1]).max() > 1e-3 and np.abs(u_last[node_body == 0]).max() == 0.0
    assert np.abs(expected[-1][4][tri_body == 1]).max() > 1e3


def test_strain_is_green_lagrange():
    """A homogeneous stretch x = diag(1.01, 0.98) X: E = ½(FᵀF − I) exactly, and the Cauchy stress of
    the material law for that F."""
    mat = fdem.Material(density=1000.0, young=1e7, poisson=0.25)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.1, 0.1, 0.05), mat)
    sim = scene.build()
    x = sim.state.node_x.to_numpy()
    sim.state.node_x.from_numpy(x * np.array([1.01, 0.98]))
    f = frame_fields(sim)
    Exx, Eyy = 0.5 * (1.01 ** 2 - 1), 0.5 * (0.98 ** 2 - 1)
    np.testing.assert_allclose(f["cell_data"]["strain"], np.tile([Exx, Eyy, 0.0], (sim.model.tri_count, 1)),
                               rtol=1e-12, atol=1e-15)
    # Cauchy stress by hand (docs/theory/elements.md §3.2, plane strain): T = (μ/J)(B − I) + λ_Y (J − 1/J) I with
    # μ = E/(2(1+ν)), λ_Y = Eν/(2(1+ν)(1−2ν)) (half the Lamé λ), B = F Fᵀ, J = det F
    E, nu = 1e7, 0.25
    mu, lam_y = E / (2 * (1 + nu)), E * nu / (2 * (1 + nu) * (1 - 2 * nu))
    J = 1.01 * 0.98
    sxx = mu / J * (1.01 ** 2 - 1) + lam_y * (J - 1 / J)
    syy = mu / J * (0.98 ** 2 - 1) + lam_y * (J - 1 / J)
    np.testing.assert_allclose(f["cell_data"]["stress"], np.tile([sxx, syy, 0.0], (sim.model.tri_count, 1)),
                               rtol=1e-10, atol=1e-10 * abs(sxx))
    np.testing.assert_allclose(f["point_data"]["displacement"], x * np.array([0.01, -0.02]), atol=1e-16)


def test_tri_damage_exported(tmp_path, monkeypatch):
    sim = sliding_block()
    np.testing.assert_array_equal(frame_fields(sim)["cell_data"]["damage"], 0.0)     # no joints
    damage = np.linspace(0.0, 1.0, sim.model.tri_count)
    monkeypatch.setattr(type(sim.cracks), "tri_damage", lambda self: damage)
    path = ExporterVtu(tmp_path).write(sim)
    np.testing.assert_array_equal(meshio.read(path).cell_data["damage"][0], damage)
    monkeypatch.setattr(type(sim.cracks), "tri_damage", lambda self: np.zeros(3))
    with pytest.raises(ValueError, match=r"tri_damage\(\) has 3 values"):
        frame_fields(sim)


def test_run_callback_every(tmp_path):
    sim = sliding_block()
    exp = ExporterVtu(tmp_path, every=2)
    exp.write(sim)                                    # t = 0
    sim.run(6 * 20 * sim.dt, record=[fdem.Callback(exp.callback, frame_dt=20 * sim.dt)])   # 6 frame intervals
    assert exp.calls == 6 and exp.frame_count == 4
    entries = read_pvd(exp.pvd_path)
    np.testing.assert_allclose([t for t, _ in entries], np.array([0, 2, 4, 6]) * 20 * sim.dt, rtol=1e-12)
    for _, name in entries:
        assert meshio.read(tmp_path / name).points.shape == (sim.model.node_count, 3)


def test_interrupted_run_leaves_valid_series(tmp_path):
    sim = sliding_block()
    times = []

    class Interrupted(Exception):
        pass

    with pytest.raises(Interrupted):
        with ExporterVtu(tmp_path) as exp:
            for k in range(5):
                sim.step(10)
                exp.write(sim)
                times.append(sim.time)
                if k == 1:
                    raise Interrupted
    entries = read_pvd(tmp_path / "frame.pvd")       # valid XML
    assert entries == [(times[0], "frame_000000.vtu"), (times[1], "frame_000001.vtu")]
    assert sorted(os.listdir(tmp_path)) == ["frame.pvd", "frame_000000.vtu", "frame_000001.vtu"]
    with pytest.raises(ValueError, match=r"write\(\) after close\(\)"):
        exp.write(sim)


def test_crash_while_writing_a_frame_keeps_the_index(tmp_path, monkeypatch):
    sim = sliding_block()
    exp = ExporterVtu(tmp_path)
    exp.write(sim)

    def broken_write(path, *args, **kwargs):
        with open(path, "wb") as fh:
            fh.write(b"<?xml version")            # half a file, then the disk fills up
        raise OSError("No space left on device")

    monkeypatch.setattr(meshio, "write", broken_write)
    with pytest.raises(OSError, match="No space"):
        exp.write(sim)
    assert read_pvd(exp.pvd_path) == [(0.0, "frame_000000.vtu")]
    assert sorted(os.listdir(tmp_path)) == ["frame.pvd", "frame_000000.vtu"]


@pytest.mark.parametrize("kwargs, match", [
    ({"every": 0}, r"every must be an integer >= 1, got 0"),
    ({"every": 1.5}, r"every must be an integer >= 1"),
    ({"prefix": ""}, r"prefix must be a non-empty file name"),
    ({"prefix": "a/b"}, r"prefix must be a non-empty file name without a path separator, got 'a/b'"),
])
def test_bad_arguments(tmp_path, kwargs, match):
    with pytest.raises(ValueError, match=match):
        ExporterVtu(tmp_path, **kwargs)


def test_directory_is_a_file(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(ValueError, match=r"exists and is not a directory"):
        ExporterVtu(tmp_path / "f")


def test_resume_series_after_checkpoint_restart(tmp_path):
    """Frames 0-2 written, checkpoint after frame 1, crash after frame 2; the restarted run resumes
    the series: frame 2 is recomputed, frame 3 appended, and the series equals the uninterrupted one."""
    sim = sliding_block()
    exp = ExporterVtu(tmp_path / "run")
    for k in range(3):
        sim.step(20)
        exp.write(sim)
        if k == 1:
            sim.save(tmp_path / "ckpt")
    # ... the process dies here.  An uninterrupted reference run for comparison:
    ref = sliding_block()
    ref_exp = ExporterVtu(tmp_path / "ref")
    for _ in range(4):
        ref.step(20)
        ref_exp.write(ref)

    restarted = fdem.Simulation.load(tmp_path / "ckpt")
    exp2 = ExporterVtu(tmp_path / "run", resume=True)
    assert exp2.frame_count == 3                       # read from the index
    for _ in range(2):
        restarted.step(20)
        exp2.write(restarted)
    assert read_pvd(exp2.pvd_path) == read_pvd(ref_exp.pvd_path)
    assert len(read_pvd(exp2.pvd_path)) == 4
    for _, name in read_pvd(exp2.pvd_path):
        a, b = meshio.read(tmp_path / "run" / name), meshio.read(tmp_path / "ref" / name)
        np.testing.assert_array_equal(a.points, b.points)
        np.testing.assert_array_equal(a.cell_data["stress"][0], b.cell_data["stress"][0])

    # resuming without an index starts a new series; a broken index is refused
    assert ExporterVtu(tmp_path / "new", resume=True).frame_count == 0
    (tmp_path / "run" / "frame.pvd").write_text("<VTKFile><Collection>")
    with pytest.raises(ValueError, match=r"cannot resume from .*frame\.pvd"):
        ExporterVtu(tmp_path / "run", resume=True)


def test_excavated_triangles_are_neither_written_nor_drawn(tmp_path):
    """After sim.remove(...), the VTU frame lists only the remaining triangles and the renderer
    leaves the excavated region at the background colour."""
    import taichi_fdem as fdem
    from taichi_fdem.io.vtu import frame_fields
    mat = fdem.Material(density=1000.0, young=1e7, poisson=0.25)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.2, 0.2, 0.02), mat)
    scene.fix_nodes(lambda x, y: np.abs(x) > 0.099)
    sim = scene.build()
    before = frame_fields(sim)
    r = fdem.render.RendererImage(width=80, height=80, draw_edges=False, stamp=False, colorbar=False,
                                  view=(-0.11, 0.11, -0.11, 0.11))
    img0 = r.render_sim(sim)
    removed = sim.remove(where=lambda x, y: x * x + y * y < 0.05 ** 2)
    assert removed > 0
    after = frame_fields(sim)
    assert len(after["triangles"]) == len(before["triangles"]) - removed
    assert all(len(v) == len(after["triangles"]) for v in after["cell_data"].values())
    img1 = r.render_sim(sim)
    centre0, centre1 = img0[40, 40].astype(int), img1[40, 40].astype(int)
    background = img1[0, 0].astype(int)
    assert np.abs(centre0 - background).max() > 10        # drawn before
    assert np.abs(centre1 - background).max() <= 1        # background where the hole is

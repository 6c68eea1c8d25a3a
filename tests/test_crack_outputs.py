"""Crack outputs (issue #11): crack events and their CSV (written and streamed), crack length,
VTU polylines of the broken joints, fragments and their sizes, and the renderer's crack overlay.

The single joint of tests/test_fracture.py (JointPair: every node prescribed, exact kinematics)
gives one mode-I event with an analytic energy; a coarse fragmenting plate
(verification.fragment_plate_scene) gives a few dozen events and fragments; hand-made
two-triangle meshes check the connectivity rules (shared node, intact joint, removed triangle).
"""
from __future__ import annotations

import csv
import math

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem import verification as V
from taichi_fdem.sim.cracks import CSV_COLUMNS, read_crack_events
from taichi_fdem.mesh import TriMesh
from conftest import shared_node_pairs, union_find_roots

Z_INTEGRAL = 0.3863      # ∫₀¹ z(D) dD (docs/theory/joints.md §7.5)
EVENT_KEYS = ("index", "time", "x", "y", "mode", "energy", "length", "set", "pressure")


def _same_events(a: dict, b: dict) -> None:
    for k in EVENT_KEYS:
        assert len(a[k]) == len(b[k]), k
        if a[k].dtype == object:
            assert list(a[k]) == list(b[k]), k
        else:
            assert np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind == "f"), k


def _u8(rgb):
    """RGB in [0, 1] -> u8 as the render kernels convert it (f32, + 0.5, truncated)."""
    return (np.asarray(rgb, np.float32) * np.float32(255.0) + np.float32(0.5)).astype(np.uint8)


# ------------------------------------------------------------------------------------------------
# one joint pulled apart in mode I
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def pulled():
    p = V.JointPair()
    dp = 2.0 * p.L * p.ft / p.pf           # §7.4
    dn = 3.0 * p.gI / p.ft                 # Y-Geo softening span
    p.drive(p.n, 0, dp, dn)
    p.dp, p.dn = dp, dn
    return p


def test_single_joint_pull_one_mode_I_event(pulled):
    p = pulled
    sim = p.sim
    ev = sim.cracks.events()
    assert list(ev["index"]) == [0] and list(ev["mode"]) == ["I"] and list(ev["mode_id"]) == [1]
    assert list(ev["set"]) == ["default"]
    # released energy = area under the traction–opening curve × L (§7.6, §7.9):
    # L f_t (2δ_p/3 + 0.3863 Δ_n), the pre-peak parabola plus the z(D) softening
    w_ref = p.L * p.ft * (2.0 * p.dp / 3.0 + Z_INTEGRAL * p.dn)
    assert ev["energy"][0] == pytest.approx(w_ref, rel=2e-3)
    assert ev["energy"][0] == pytest.approx(sim.energies()["fracture"], rel=1e-12)
    assert ev["length"][0] == pytest.approx(math.sqrt(2.0), rel=1e-12)     # the unit square's diagonal
    assert ev["time"][0] == sim.cracks.broken()["time"][0]
    assert 0.0 < ev["time"][0] < sim.time
    assert np.allclose([ev["x"][0], ev["y"][0]], [0.5, 0.5], atol=0.05)
    assert sim.cracks.length() == pytest.approx(math.sqrt(2.0), rel=1e-12)
    t, L = sim.cracks.length_history()
    assert np.array_equal(t, ev["time"]) and np.allclose(L, [math.sqrt(2.0)])


def test_event_energy_scales_with_thickness(pulled):
    sim = pulled.sim
    e1 = sim.cracks.events()["energy"][0]
    m1 = sim.cracks.fragments()["mass"].copy()
    old = sim.thickness
    try:
        sim.thickness = 0.25
        assert sim.cracks.events()["energy"][0] == pytest.approx(0.25 * e1, rel=1e-12)
        assert sim.cracks.events()["energy"].sum() == pytest.approx(sim.energies()["fracture"], rel=1e-12)
        assert np.allclose(sim.cracks.fragments()["mass"], 0.25 * m1, rtol=1e-12)
    finally:
        sim.thickness = old


def test_single_joint_fragments(pulled):
    f = pulled.sim.cracks.fragments()
    assert f["count"] == 2 == pulled.sim.cracks.fragment_count()
    assert np.allclose(f["area"], [0.5, 0.5], rtol=1e-12)
    assert np.allclose(f["mass"], 1000.0 * 0.5, rtol=1e-12)          # ρ = 1000 kg/m³, t = 1 m
    x = pulled.sim.node_positions()
    tn = pulled.sim.model.tri_nodes_np
    for k in range(2):                                               # centroid of each triangle
        t = np.nonzero(f["label"] == k)[0]
        assert np.allclose(f["centroid"][k], x[tn[t[0]]].mean(axis=0), atol=1e-12)


def test_crack_overlay_draws_exactly_the_crack_faces(pulled):
    from taichi_fdem.render import RendererImage
    sim = pulled.sim
    kw = dict(width=160, height=160, view=(-0.2, 1.2, -0.2, 1.2), stamp=False, draw_edges=False)
    plain = RendererImage(**kw).render_sim(sim)
    r = RendererImage(cracks=True, crack_width=2.0, **kw)
    img = r.render_sim(sim)
    seg = sim.cracks.segments()
    assert seg.shape == (1, 4)
    # crack_segments: the midline from ½(x_j0 + x_j3) to ½(x_j1 + x_j2), from the nodes themselves
    x = sim.node_positions()
    j = sim.model.joint_nodes.to_numpy()[0]
    assert np.allclose(seg[0], np.r_[0.5 * (x[j[0]] + x[j[3]]), 0.5 * (x[j[1]] + x[j[2]])], atol=1e-15)
    # the overlay: both faces, x_j0 → x_j1 and x_j3 → x_j2 (the pulled pair has opened)
    rows, cols = np.mgrid[0:160, 0:160]
    pc = np.stack([cols + 0.5, rows + 0.5], axis=-1)
    dist = np.full((160, 160), np.inf)
    for p, q in ((j[0], j[1]), (j[3], j[2])):
        a, b = r.world_to_pixel(x[p])[0], r.world_to_pixel(x[q])[0]
        ab = b - a
        t = np.clip(((pc - a) @ ab) / (ab @ ab), 0.0, 1.0)
        dist = np.minimum(dist, np.linalg.norm(pc - (a + t[..., None] * ab), axis=-1))
    crack = _u8(r.crack_color)
    changed = np.any(img != plain, axis=-1)
    assert changed.sum() > 100                                       # ~2 px × ~145 px per face
    assert np.all(dist[changed] <= 1.0 + 1e-3)                       # only pixels on the faces change
    assert np.all(img[dist <= 0.99] == crack)                        # ... and those take its colour
    assert np.array_equal(img[dist > 1.01], plain[dist > 1.01])      # the rest is untouched
    # nothing broken: the overlay draws nothing
    fresh = V.JointPair().sim
    assert np.array_equal(RendererImage(cracks=True, **kw).render_sim(fresh), RendererImage(**kw).render_sim(fresh))


def test_overlay_options_validated():
    from taichi_fdem.render import RendererImage
    with pytest.raises(ValueError, match="cracks"):
        RendererImage(cracks="yes")
    with pytest.raises(ValueError, match="crack_color"):
        RendererImage(crack_color=(2.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="crack_width"):
        RendererImage(crack_width=0.0)


def test_run_video_cracks(tmp_path):
    """run(record=[Video(..., cracks=True)]) draws the broken joint on the frames; False does not."""
    from PIL import Image
    from taichi_fdem.render import RendererImage
    counts = {}
    for flag in (True, False):
        p = V.JointPair()
        dp, dn = 2.0 * p.L * p.ft / p.pf, 3.0 * p.gI / p.ft
        p.move_A(p.n * (dp + dn) / 100 / p.dt)                      # broken after ~100 steps
        out = tmp_path / f"frames_{flag}"
        p.sim.run(150 * p.dt, record=[fdem.Video(out, frame_dt=50 * p.dt, cracks=flag)], progress=False,
                  checks=fdem.Checks(energy=False))
        assert p.sim.cracks.broken_count == 1
        last = np.asarray(Image.open(sorted(out.glob("*.png"))[-1]).convert("RGB"))
        counts[flag] = int(np.all(last == _u8(RendererImage().crack_color), axis=-1).sum())
    assert counts[True] > 50 and counts[False] == 0
    with pytest.raises(ValueError, match="cracks"):
        fdem.Video(tmp_path / "x", renderer=RendererImage(), cracks=True)
    with pytest.deprecated_call(), pytest.raises(ValueError, match="video_cracks"):
        p.sim.run(p.dt, video_cracks=True, progress=False)


def test_crack_events_file_must_be_a_crack_event_csv(tmp_path):
    path = tmp_path / "other.csv"
    path.write_text("time,step\n0.0,0\n")
    sim = V.JointPair().sim
    with pytest.raises(ValueError, match="not a crack-event file"):
        sim.run(sim.dt, record=[fdem.CrackEvents(path)], progress=False)
    assert path.read_text() == "time,step\n0.0,0\n"                  # left untouched


# ------------------------------------------------------------------------------------------------
# a coarse plate fragmented by an impact: many events, streamed
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def plate_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("plate")
    sim, (plate, ball) = V.fragment_plate_scene(h_plate=0.04, h_ball=0.03)
    stream, hist = d / "stream.csv", d / "history.csv"
    seen = []                        # (broken joints, rows in the streamed file) at each callback

    def watch(s):
        with open(stream) as fh:
            seen.append((s.cracks.broken_count, sum(1 for _ in fh) - 1))
    sim.run(0.003, record=[fdem.CrackEvents(stream), fdem.History(hist)], callback=watch, progress=False)
    sim.run(0.003, record=[fdem.CrackEvents(stream), fdem.History(hist)], callback=watch, progress=False)  # appended
    return {"sim": sim, "plate": plate, "ball": ball, "stream": stream, "history": hist, "seen": seen, "dir": d}


def test_plate_event_energies_sum_to_fracture_energy(plate_run):
    sim = plate_run["sim"]
    ev = sim.cracks.events()
    assert len(ev["index"]) == sim.cracks.broken_count >= 10
    assert np.all(np.diff(ev["time"]) >= 0.0)
    assert set(ev["mode"]) <= {"I", "II", "I+II", "mixed"}
    assert np.all(ev["energy"] > 0.0)
    assert ev["energy"].sum() == pytest.approx(sim.energies()["fracture"], rel=1e-9)
    X = sim.model.node_rest
    jn = sim.model.joint_nodes.to_numpy()[ev["index"]]
    assert np.allclose(ev["length"], np.linalg.norm(X[jn[:, 1]] - X[jn[:, 0]], axis=1), rtol=1e-12)
    t, L = sim.cracks.length_history()
    assert np.all(np.diff(L) > 0) and L[-1] == pytest.approx(sim.cracks.length(), rel=1e-12)
    assert sim.cracks.broken()["index"].tolist() == ev["index"].tolist()


def test_crack_csv_roundtrip(plate_run, tmp_path):
    sim = plate_run["sim"]
    path = sim.cracks.write_events(tmp_path / "events.csv")
    with open(path) as fh:
        header = next(csv.reader(fh))
    assert tuple(header) == CSV_COLUMNS and "time_s" in header and "energy_J" in header
    _same_events(read_crack_events(path), sim.cracks.events())


def test_streamed_csv_equals_final_write(plate_run, tmp_path):
    sim, seen = plate_run["sim"], plate_run["seen"]
    final = sim.cracks.write_events(tmp_path / "final.csv")
    assert plate_run["stream"].read_text() == open(final).read()      # two runs appended, no repeats
    # streamed as the joints broke: at every callback the file held every event so far
    assert all(broken == rows for broken, rows in seen)
    assert len({broken for broken, _ in seen}) > 3


def test_history_has_crack_columns(plate_run):
    sim = plate_run["sim"]
    with open(plate_run["history"]) as fh:
        rows = list(csv.DictReader(fh))
    assert int(rows[0]["broken_joints"]) == 0 and float(rows[0]["crack_length"]) == 0.0
    assert int(rows[-1]["broken_joints"]) == sim.cracks.broken_count
    assert float(rows[-1]["crack_length"]) == pytest.approx(sim.cracks.length(), rel=1e-12)
    assert np.all(np.diff([int(r["broken_joints"]) for r in rows]) >= 0)


def test_stream_keeps_events_when_the_run_stops_with_an_error(tmp_path):
    sim, _ = V.fragment_plate_scene(h_plate=0.04, h_ball=0.03)
    path = tmp_path / "cracks.csv"

    def stop(s):
        if s.cracks.broken_count >= 5:
            raise RuntimeError("stop here")
    with pytest.raises(RuntimeError, match="stop here"):
        sim.run(0.006, record=[fdem.CrackEvents(path)], callback=stop, progress=False)
    assert sim.cracks.broken_count >= 5
    _same_events(read_crack_events(path), sim.cracks.events())


def test_cracks_vtu_lines(plate_run, tmp_path):
    import meshio
    from taichi_fdem.io.vtu import write_cracks_vtu
    sim = plate_run["sim"]
    ev = sim.cracks.events()
    path = write_cracks_vtu(str(tmp_path / "cracks.vtu"), sim)
    m = meshio.read(path)
    assert [c.type for c in m.cells] == ["line"] and len(m.cells[0].data) == len(ev["index"])
    pts = m.points[m.cells[0].data]                                   # (k, 2 ends, 3)
    x = sim.node_positions()
    jn = sim.model.joint_nodes.to_numpy()[ev["index"]]
    assert np.allclose(pts[:, 0, :2], 0.5 * (x[jn[:, 0]] + x[jn[:, 3]]), atol=1e-12)
    assert np.allclose(pts[:, 1, :2], 0.5 * (x[jn[:, 1]] + x[jn[:, 2]]), atol=1e-12)
    assert np.all(pts[..., 2] == 0.0)
    cd = {k: v[0] for k, v in m.cell_data.items()}
    assert np.array_equal(cd["joint"], ev["index"]) and np.array_equal(cd["time"], ev["time"])
    assert np.array_equal(cd["mode"], ev["mode_id"]) and np.array_equal(cd["energy"], ev["energy"])
    assert np.array_equal(cd["length"], ev["length"]) and np.all(cd["set"] == 0)
    with pytest.raises(ValueError, match=".vtu"):
        write_cracks_vtu(str(tmp_path / "cracks.txt"), sim)


def test_cracks_vtu_without_broken_joints(tmp_path):
    import xml.etree.ElementTree as ET
    from taichi_fdem.io.vtu import write_cracks_vtu
    sim = V.JointPair().sim
    path = write_cracks_vtu(str(tmp_path / "none.vtu"), sim)
    piece = ET.parse(path).getroot().find("UnstructuredGrid/Piece")
    assert piece.get("NumberOfPoints") == "0" and piece.get("NumberOfCells") == "0"


# ------------------------------------------------------------------------------------------------
# fragments
# ------------------------------------------------------------------------------------------------
def _union_find_labels(sim, body=None):
    """Brute force: union-find over shared nodes and intact joints; per triangle the smallest
    triangle index of its component (−1 removed)."""
    md = sim.model
    m = md.tri_count
    active = sim.active_triangles()
    pairs = shared_node_pairs(md.tri_nodes_np, active)
    if md.fracture:
        state = sim.state.joint_state.to_numpy()
        pairs += [(a, b) for j, (a, b) in enumerate(md.joint_tris_np) if state[j] == 0 and active[a] and active[b]]
    roots = np.where(active, union_find_roots(m, pairs), -1)
    if body is not None:
        roots = roots[body.triangles]
    return roots


def _same_partition(label, roots):
    assert np.array_equal(label < 0, roots < 0)
    pairs = {(int(a), int(b)) for a, b in zip(label[label >= 0], roots[roots >= 0])}
    assert len(pairs) == len({a for a, _ in pairs}) == len({b for _, b in pairs})


def test_plate_fragments_match_union_find(plate_run):
    sim, plate = plate_run["sim"], plate_run["plate"]
    f = sim.cracks.fragments(plate)
    _same_partition(f["label"], _union_find_labels(sim, plate))
    assert f["count"] == len(set(_union_find_labels(sim, plate))) == sim.cracks.fragment_count(plate) >= 2
    assert sim.cracks.fragment_count() == f["count"] + 1                     # the projectile is one piece
    assert f["area"].sum() == pytest.approx(0.4 * 0.1, rel=1e-12)
    assert f["mass"].sum() == pytest.approx(1000.0 * 0.4 * 0.1, rel=1e-12)
    # mass-weighted centroid, brute force
    x = sim.node_positions()
    tn = sim.model.tri_nodes_np[plate.triangles]
    a0 = sim.model.tri_area0_np[plate.triangles]
    for k in range(f["count"]):
        sel = f["label"] == k
        c = (x[tn[sel]].mean(axis=1) * a0[sel, None]).sum(axis=0) / a0[sel].sum()
        assert np.allclose(f["centroid"][k], c, atol=1e-12)
    s = sim.cracks.fragment_sizes(plate)
    assert np.all(np.diff(s["area"]) <= 0) and np.allclose(s["diameter"], np.sqrt(4 * s["area"] / np.pi))
    assert np.array_equal(np.sort(s["area"]), np.sort(f["area"]))
    d, frac = sim.cracks.fragment_passing(body=plate)
    assert np.all(np.diff(d) >= 0) and np.all(np.diff(frac) >= 0) and frac[-1] == pytest.approx(1.0)
    mid = float(np.median(d))
    ref = f["mass"][np.sqrt(4 * f["area"] / np.pi) <= mid].sum() / f["mass"].sum()
    assert sim.cracks.fragment_passing(mid, body=plate) == pytest.approx(ref, rel=1e-12)
    assert np.allclose(sim.cracks.fragment_passing([0.0, 10.0], body=plate), [0.0, 1.0])


def _two_triangles(points, tris, fracture=False):
    mat = fdem.Material(density=100.0, young=1e6, poisson=0.25, tensile_strength=1e3, fracture_energy=1.0)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(TriMesh(np.array(points, float), np.array(tris)), mat, fracture=fracture)
    return scene.build()


def test_two_triangles_sharing_a_node_are_one_fragment():
    bow_tie = _two_triangles([[0, 0], [1, 0], [0.5, 0.5], [1, 1], [0, 1]], [[0, 1, 2], [2, 3, 4]])
    f = bow_tie.cracks.fragments()
    assert f["count"] == 1 == bow_tie.cracks.fragment_count() and list(f["label"]) == [0, 0]
    assert f["area"][0] == pytest.approx(0.5, rel=1e-12)
    apart = _two_triangles([[0, 0], [1, 0], [0, 1], [2, 0], [3, 0], [2, 1]], [[0, 1, 2], [3, 4, 5]])
    assert apart.cracks.fragment_count() == 2 and list(apart.cracks.fragments()["label"]) == [0, 1]


def test_intact_joint_joins_and_broken_joint_or_removal_separates():
    sq = _two_triangles([[0, 0], [1, 0], [1, 1], [0, 1]], [[0, 1, 2], [0, 2, 3]], fracture=True)
    assert sq.model.joint_count == 1 and sq.cracks.fragment_count() == 1        # exploded mesh: joined by the joint
    st = sq.state.joint_state.to_numpy()
    st[0] = 1
    sq.state.joint_state.from_numpy(st)
    assert sq.cracks.fragment_count() == 2
    assert sq.cracks.length() == pytest.approx(math.sqrt(2.0))
    st[0] = 0
    sq.state.joint_state.from_numpy(st)
    sq.remove(where=lambda x, y: x > y)                              # the lower-right triangle
    f = sq.cracks.fragments()
    assert f["count"] == 1 and sorted(f["label"]) == [-1, 0] and f["area"][0] == pytest.approx(0.5)


# ------------------------------------------------------------------------------------------------
# scene files
# ------------------------------------------------------------------------------------------------
def test_scene_file_crack_outputs(tmp_path):
    """[output] cracks and crack_events reach the renderer and run(); cracks needs a video."""
    from taichi_fdem.io import scenefile
    from taichi_fdem.io.scenefile import SceneFileError
    base = """
[materials.rock]
density = 1000.0
young = 1.0e8
poisson = 0.25

[[bodies]]
material = "rock"
shape = "rectangle"
width = 0.2
height = 0.1
h = 0.05

[solver]
duration = 0.0001
"""
    p = tmp_path / "s.toml"
    p.write_text(base + f'\n[output]\nvideo = "{(tmp_path / "v").as_posix()}"\nwidth = 32\nheight = 32\n'
                 f'cracks = true\ncrack_events = "{(tmp_path / "c.csv").as_posix()}"\n')
    sim, settings = scenefile.load(str(p)).build()
    assert settings.cracks is True and settings.crack_events.endswith("c.csv")
    settings.run(sim, progress=False)
    assert (tmp_path / "c.csv").read_text().splitlines() == [",".join(CSV_COLUMNS)]   # no fracture: no events
    assert len(list((tmp_path / "v").glob("*.png"))) >= 2
    p.write_text(base + "\n[output]\ncracks = true\n")
    with pytest.raises(SceneFileError, match="cracks"):
        scenefile.load(str(p))


def test_joint_set_names_from_the_model():
    """With joint sets (model.joint_set_np / joint_set_names), events carry their set's name."""
    p = V.JointPair()
    sim = p.sim
    sim.model.joint_set_np = np.array([1], np.int32)
    sim.model.joint_set_names = ["bedding", "fault"]
    st = sim.state.joint_state.to_numpy()
    st[0] = 2
    sim.state.joint_state.from_numpy(st)
    ev = sim.cracks.events()
    assert list(ev["set"]) == ["fault"] and list(ev["set_id"]) == [1] and list(ev["mode"]) == ["II"]


# ---- the fluid pressure of crack events ---------------------------------------------------------
def _injected_block():
    """A free jointed block with a crack at its centre fed at a constant rate: the fluid opens the
    crack and breaks the joints ahead of its tips."""
    rock = fdem.Material(density=2700.0, young=10e9, poisson=0.25, tensile_strength=3e5, cohesion=9e5,
                         fracture_energy=1.0)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.4, 0.4, 0.05), rock, fracture=True,
                   cracks=lambda x, y: (np.abs(y) < 1e-9) & (np.abs(x) < 0.06))
    scene.set_fluid(fdem.Fluid(bulk_modulus=1e8), aperture_min=1e-5)
    scene.inject(lambda x, y: (np.abs(x) < 1e-9) & (np.abs(y) < 1e-9), rate=2e-2)
    return scene.build(strategy="serial")


def test_crack_events_carry_the_fluid_pressure_at_breakage(tmp_path):
    """An event's pressure is the mean of the pressures of its joint's two network nodes at the
    start of the step that broke it: re-run to the step of the first wet break, read the network's
    pressures there (sim.fluid.pressures()), take one step, and compare.  The pressure survives a
    CSV round trip; a scene without a fluid has NaN."""
    first = _injected_block()
    first.step(1500)
    ev = first.cracks.events()
    assert len(ev["index"]) > 0 and np.all(np.isfinite(ev["pressure"])) and ev["pressure"].max() > 0
    wet = int(np.nonzero(ev["pressure"] > 0)[0][0])          # the first joint broken by a wet edge
    k = int(round(ev["time"][wet] / first.dt))
    sim = _injected_block()
    sim.step(k)
    assert sim.cracks.broken_count == wet
    _, p_before = sim.fluid.pressures()
    sim.step(1)
    now = sim.cracks.events()
    now = {key: v[wet:] for key, v in now.items()}             # the joints broken in this step
    assert len(now["index"]) > 0 and np.all(now["time"] == ev["time"][wet])
    fe = sim.model.fluid_edge.to_numpy()
    edge_of = {int(j): e for e, j in enumerate(fe[:, 6]) if j >= 0}
    rows = fe[[edge_of[int(j)] for j in now["index"]]]
    expect = 0.5 * (p_before[rows[:, 4]] + p_before[rows[:, 5]])
    assert expect.max() > 0
    np.testing.assert_allclose(now["pressure"], expect, rtol=1e-12, atol=0)
    back = read_crack_events(first.cracks.write_events(tmp_path / "c.csv"))
    assert np.array_equal(back["pressure"], ev["pressure"])


def test_crack_events_without_fluid_have_nan_pressure(plate_run):
    ev = plate_run["sim"].cracks.events()
    assert len(ev["pressure"]) == len(ev["index"]) > 0 and np.all(np.isnan(ev["pressure"]))

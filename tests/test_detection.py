"""Broad phase: contact couples (docs/theory/contact.md §4) against a brute-force O(N²) search.

Criterion (§4.1): triangles a, b form a couple when |c_a − c_b| < r_a + r_b + b (centroids,
bounding-circle radii max_v |x_v − c|, buffer b = sim.model.buffer), excluding pairs of the same
body (unless it has self-contact), pairs sharing a node and pairs of two fully fixed bodies;
only triangles touching their body's surface take part (all of them with self-contact).
"""
import numpy as np
import pytest

import taichi_fdem as fdem
from conftest import bounding_circles, brute_force_couples, build_quiet, couple_set, one_triangle, random_triangle

MAT = fdem.Material(density=1000.0, young=1e6, poisson=0.25, penalty=1e7)
STRATEGIES = ["serial", "parallel"]


def scene_arrays(scene):
    """Global triangles, triangle → body, contact candidates, self-contact and fixed body sets,
    computed from the scene's bodies (independently of the simulation's arrays)."""
    tris, tri_body, cand = [], [], []
    for b in scene.bodies:
        t = np.asarray(b.mesh.triangles, dtype=np.int64)
        tris.append(t + b.node_start)
        tri_body.append(np.full(len(t), b.index))
        ids = b.tri_start + np.arange(len(t))
        if not b.self_contact:
            surface = np.isin(t, b.mesh.boundary_nodes()).any(axis=1)
            ids = ids[surface]
        cand.append(ids)
    selfc = {b.index for b in scene.bodies if b.self_contact}
    fixed = {b.index for b in scene.bodies if b.fixed}
    return np.vstack(tris), np.concatenate(tri_body), np.concatenate(cand), selfc, fixed


def expected_couples(sim, scene, x=None):
    tris, tri_body, cand, selfc, fixed = scene_arrays(scene)
    x = sim.node_positions() if x is None else x
    return brute_force_couples(x, tris, cand, tri_body, sim.model.buffer, selfc, fixed)


def random_triangle_scene(seed, n, box=1.0, size=(0.01, 0.03), overlap=True, speed=0.0, origin=(0.0, 0.0)):
    """n one-triangle bodies at random positions in a box.  With overlap=False the bounding
    circles are kept disjoint (no contact at the start, but many couples within the buffer)."""
    rng = np.random.default_rng(seed)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    placed = []
    while len(placed) < n:
        r = rng.uniform(*size)
        c = np.asarray(origin) + rng.uniform(0.0, box, 2)
        T = random_triangle(rng, c, r, min_angle_deg=25.0)
        cc, rr = bounding_circles(T, np.array([[0, 1, 2]]))
        if not overlap and any(np.linalg.norm(cc[0] - c2) < rr[0] + r2 for c2, r2 in placed):
            continue
        placed.append((cc[0], rr[0]))
        v = speed * rng.uniform(-1.0, 1.0, 2)
        scene.add_body(one_triangle(T), MAT, velocity=v, angular_velocity=rng.uniform(-1, 1) * speed / r * 0.2)
    return scene


# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("strategy", STRATEGIES)
def test_random_triangles_match_brute_force(strategy):
    scene = random_triangle_scene(seed=1, n=700, overlap=True, origin=(-0.4, -0.7))   # cells of both signs
    with pytest.warns(RuntimeWarning, match="overlap"):
        sim = scene.build(strategy=strategy)
    assert sim.solver.strategy == strategy
    expected = expected_couples(sim, scene)
    assert len(expected) > 300                   # a non-trivial scene
    assert couple_set(sim) == expected
    assert sim.solver.couple_count == len(expected)
    assert sim.solver.detection_count == 1


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_mixed_bodies_exclusions_match_brute_force(strategy):
    """Multi-triangle bodies: no couples inside a body (except with self-contact, and then not
    between triangles sharing a node), interior triangles left out, fixed–fixed pairs left out."""
    rng = np.random.default_rng(5)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    rect = fdem.mesh.rectangle(0.12, 0.08, 0.02, pattern="crossed")
    disk = fdem.mesh.disk(0.05, 0.015)
    for k in range(12):
        pos = (0.11 * (k % 4) + rng.uniform(-0.01, 0.01), 0.11 * (k // 4) + rng.uniform(-0.01, 0.01))
        mesh = rect if k % 2 else disk
        scene.add_body(mesh, MAT, position=pos, rotation=rng.uniform(0, 6.28), self_contact=(k % 3 == 0))
    # two fixed walls touching each other and the others
    scene.add_body(fdem.mesh.rectangle(0.5, 0.05, 0.025, origin=(-0.1, -0.12)), MAT, fixed=True)
    scene.add_body(fdem.mesh.rectangle(0.05, 0.4, 0.025, origin=(-0.15, -0.12)), MAT, fixed=True)
    # a buffer a little over one element size (~4× the default) reaches the second neighbours
    # in a self-contacting body: the default leaves them more than a buffer beyond an edge line
    sim = build_quiet(scene, strategy=strategy, buffer=0.023)   # (0.02 would tie with distances)
    expected = expected_couples(sim, scene)
    got = couple_set(sim)
    assert got == expected
    tri_body = np.concatenate([np.full(b.mesh.triangle_count, b.index) for b in scene.bodies])
    same_body = sum(tri_body[a] == tri_body[b] for a, b in got)
    assert same_body > 0                         # self-contact couples exist ...
    assert all(scene.bodies[tri_body[a]].self_contact for a, b in got if tri_body[a] == tri_body[b])


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_couple_buffer_grows_at_build(strategy):
    """Many mutually overlapping triangles in a small region: far more couples than the initial
    capacity 2K + 64; none may be dropped."""
    rng = np.random.default_rng(3)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    for _ in range(150):
        scene.add_body(one_triangle(random_triangle(rng, rng.uniform(0.0, 0.05, 2), 0.02)), MAT)
    with pytest.warns(RuntimeWarning, match="overlap"):
        sim = scene.build(strategy=strategy)
    K = sim.info()["contact_triangles"]
    expected = expected_couples(sim, scene)
    assert len(expected) > 2 * K + 64
    assert couple_set(sim) == expected
    _assert_both_fill_paths(sim)


def _assert_both_fill_paths(sim):
    """The fill writes a contact triangle's couples from the partners its count scan kept, up to
    DET_CAND of them, and scans again beyond (``engine.detection.fill_partners``): the scene
    must have triangles of both kinds for a brute-force comparison to check both."""
    from taichi_fdem.engine.groups import DET_CAND
    per = np.bincount(sim.couples()[:, 0])
    per = per[per > 0]
    assert per.min() <= DET_CAND < per.max(), (per.min(), per.max())


def contracting_lattice(n=15, spacing=0.05, radius=0.01, final_spacing=0.0215, buffer=0.02):
    """An n × n lattice of one-triangle bodies contracting homologously (v = −k (c − centre)) from
    ``spacing`` to ``final_spacing`` in 0.03 s: no couple at the start, about 8 per triangle
    at the end (≈ 4K > 2K + 64) while the bounding circles never overlap (no contact)."""
    rng = np.random.default_rng(11)
    duration = 0.03
    k = (1.0 - final_spacing / spacing) / duration
    scene = fdem.Scene(gravity=(0.0, 0.0))
    centre = 0.5 * spacing * (n - 1) * np.ones(2)
    for i in range(n):
        for j in range(n):
            c = spacing * np.array([i, j], dtype=float)
            T = random_triangle(rng, c, radius, min_angle_deg=40.0)
            g = T.mean(0)
            T = T - g + c                                # centroid on the lattice point
            scene.add_body(one_triangle(T), MAT, velocity=-k * (c - centre))
    return scene, duration, buffer


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_redetection_while_moving_and_buffer_growth(strategy):
    """Each detection during the run (serial: inside the many-step kernel; parallel: between
    launches) finds exactly the brute-force couples of the positions it saw, x_n = x_{n+1} − Δt v,
    including when the count outgrows the couple buffer mid-run."""
    scene, duration, buffer = contracting_lattice()
    sim = scene.build(strategy=strategy, buffer=buffer)
    K = sim.info()["contact_triangles"]
    assert sim.solver.couple_count == 0
    checked = 0
    last = sim.solver.detection_count
    steps = int(duration / sim.dt)
    for _ in range(steps):
        sim.step(1)
        if sim.solver.detection_count != last:
            last = sim.solver.detection_count
            x_seen = sim.node_positions() - sim.dt * sim.node_velocities()
            assert couple_set(sim) == expected_couples(sim, scene, x_seen)
            checked += 1
    assert checked >= 5
    assert sim.solver.couple_count > 2 * K + 64         # the buffer had to grow during the run
    assert sim.energies()["contact"] == 0.0      # and the triangles never touched


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_couples_follow_moving_bodies(strategy):
    """After a run with collisions every pair whose bounding circles overlap *now* is a couple
    (the buffer argument of §4.1), and no couple is farther apart than r_a + r_b + 2b."""
    scene = random_triangle_scene(seed=2, n=300, box=0.6, overlap=False, speed=3.0)
    sim = scene.build(strategy=strategy)
    d0 = sim.solver.detection_count
    sim.step(2000)
    assert sim.solver.detection_count >= d0 + 5
    assert sim.energies()["contact"] > 0.0      # collisions are going on
    tris, tri_body, cand, selfc, fixed = scene_arrays(scene)
    x = sim.node_positions()
    must = brute_force_couples(x, tris, cand, tri_body, 0.0, selfc, fixed, margin=0.0)
    may = brute_force_couples(x, tris, cand, tri_body, 0.0, selfc, fixed, margin=2.0 * sim.model.buffer)
    got = couple_set(sim)
    assert len(must) > 0
    assert must <= got
    assert got <= may

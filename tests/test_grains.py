"""Grain-based specimens: fdem.mesh.voronoi_grains."""
import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem import mesh

pytest.importorskip("scipy")

ROCK = dict(density=2650.0, young=5e9, poisson=0.25, tensile_strength=1e6, cohesion=3e6, fracture_energy=10.0)


def test_grain_count_close_to_area_over_grain_size_squared():
    for shape, w, ht in (("rectangle", 0.04, 0.08), ("disc", 0.06, 0.06)):
        m, lab = mesh.voronoi_grains(w, ht, 0.01, 0.003, seed=3, shape=shape)
        area = w * ht if shape == "rectangle" else np.pi * (w / 2) ** 2
        expected = area / 0.01 ** 2
        # one grain per Voronoi seed; a cell merged into a neighbour (short-edge merging) is
        # rare: the count is within 10 % of area / d²
        assert abs(lab.grain_count - expected) <= 0.1 * expected
        np.testing.assert_allclose(lab.grain_area.sum(), m.areas.sum(), rtol=1e-12)
        np.testing.assert_allclose(m.areas.sum(), area, rtol=0.02)       # disc: inscribed polygon


def test_same_seed_same_mesh_other_seed_differs():
    a = mesh.voronoi_grains(0.03, 0.03, 0.01, 0.004, seed=11)
    b = mesh.voronoi_grains(0.03, 0.03, 0.01, 0.004, seed=11)
    c = mesh.voronoi_grains(0.03, 0.03, 0.01, 0.004, seed=12)
    np.testing.assert_array_equal(a[0].points, b[0].points)
    np.testing.assert_array_equal(a[0].triangles, b[0].triangles)
    np.testing.assert_array_equal(a[1], b[1])
    assert a[0].points.shape != c[0].points.shape or not np.array_equal(a[0].points, c[0].points)


def test_labels_constant_on_every_grain_polygon():
    m, lab = mesh.voronoi_grains(0.04, 0.04, 0.01, 0.003, seed=5)
    edges = m.edges()
    on_boundary = lab.boundaries.select_edges(m.points, edges)
    # interior edges with the two triangles on either side
    tri = m.triangles.astype(np.int64)
    t = np.repeat(np.arange(len(tri)), 3)
    k = np.tile(np.arange(3), len(tri))
    u, v = tri[t, k], tri[t, (k + 1) % 3]
    key = np.minimum(u, v) * len(m.points) + np.maximum(u, v)
    order = np.argsort(key, kind="stable")
    pair = np.nonzero(key[order][:-1] == key[order][1:])[0]
    ia, ib = order[pair], order[pair + 1]
    ekey = np.minimum(edges[:, 0], edges[:, 1]) * len(m.points) + np.maximum(edges[:, 0], edges[:, 1])
    bkeys = ekey[on_boundary]
    differ = lab[t[ia]] != lab[t[ib]]
    crosses = np.isin(key[ia], bkeys)
    # a label changes only across a grain boundary, and every grain boundary separates two grains
    assert not np.any(differ & ~crosses)
    assert np.all(differ[crosses])
    # the grains are (up to the merged short edges) the Voronoi cells: nearest seed
    c = m.points[tri].mean(axis=1)
    near = np.argmin(((c[:, None] - lab.seeds[None]) ** 2).sum(-1), axis=1)
    same = np.zeros(len(tri), bool)
    for g in range(lab.grain_count):
        sel = lab == g
        same[sel] = near[sel] == np.bincount(near[sel]).argmax()
    assert same.mean() > 0.95


def test_mineral_area_fractions_match_proportions():
    props = {"quartz": 0.3, "feldspar": 0.6, "biotite": 0.1}
    m, lab = mesh.voronoi_grains(0.2, 0.2, 0.01, 0.006, seed=2, minerals=props, relax=1)
    assert lab.grain_count > 300
    a = m.areas
    mineral = lab.mineral
    for name, p in props.items():
        assert abs(a[mineral == name].sum() / a.sum() - p) < 0.01, name
    with pytest.raises(ValueError, match="no Material for mineral"):
        lab.materials({"quartz": fdem.Material(**ROCK)})


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="smaller than grain_size"):
        mesh.voronoi_grains(0.02, 0.02, 0.005, 0.01)
    with pytest.raises(ValueError, match="shape"):
        mesh.voronoi_grains(0.02, 0.02, 0.01, 0.005, shape="square")
    with pytest.raises(ValueError, match="proportions"):
        mesh.voronoi_grains(0.02, 0.02, 0.01, 0.005, minerals={"quartz": -1})


def test_grain_specimen_with_grain_boundary_joints_builds_and_steps():
    m, lab = mesh.voronoi_grains(0.02, 0.02, 0.008, 0.004, seed=1, minerals={"quartz": 0.5, "feldspar": 0.5})
    quartz = fdem.Material(**ROCK, name="quartz")
    feldspar = fdem.Material(**{**ROCK, "young": 3e9}, name="feldspar")
    weak = fdem.Material(**{**ROCK, "tensile_strength": 2e5, "cohesion": 6e5}, name="boundary")
    scene = fdem.Scene(gravity=(0.0, 0.0))
    b = scene.add_body(m, lab.materials({"quartz": quartz, "feldspar": feldspar}), groups=lab, fracture=True,
                       velocity=(0.0, -0.1))
    scene.add_joint_set("grain_boundaries", "interfaces", weak)
    js = b.joint_set == 1
    assert js.any() and (~js).any()
    np.testing.assert_allclose(b.joint_prop[js], np.tile(weak.joint_properties(), (js.sum(), 1)))
    sim = scene.build()
    sim.step(20)
    x = sim.state.node_x.to_numpy()
    assert np.all(np.isfinite(x))
    assert sim.info()["joint_sets"]["grain_boundaries"] == int(js.sum())


def test_lab_tests_take_grain_boundary_joint_sets_and_name_a_bad_one():
    """``joint_sets=`` of fdem.lab.ucs / brazilian: a malformed entry is refused before any run,
    naming its index."""
    m, lab = mesh.voronoi_grains(0.02, 0.04, 0.01, 0.005, seed=1, minerals={"quartz": 1.0})
    mats = lab.materials({"quartz": fdem.Material(**ROCK, name="quartz")})
    with pytest.raises(ValueError, match=r"joint_sets\[0\] must be a \(name, selector, Material\) triple"):
        fdem.lab.ucs(mats, 0.02, 0.04, 0.005, mesh=m, groups=lab, joint_sets=[("gb", "interfaces")])
    d, dl = mesh.voronoi_grains(0.04, 0.04, 0.01, 0.005, seed=1, minerals={"quartz": 1.0}, shape="disc")
    with pytest.raises(ValueError, match=r"lab.brazilian: joint_sets\[1\]"):
        fdem.lab.brazilian(dl.materials({"quartz": fdem.Material(**ROCK, name="quartz")}), 0.04, 0.005, mesh=d,
                           groups=dl, joint_sets=[("gb", "interfaces", fdem.Material(**ROCK)), "weak"])

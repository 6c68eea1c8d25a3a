"""Discontinuities and heterogeneity (docs/theory/discontinuities.md §13): selective joints, pre-existing cracks,
joint sets, interfaces, statistical strength, and the verification problems of issue #11."""
import math

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem import Material, Scene, mesh
from taichi_fdem.verification import discontinuities as vd
from conftest import shared_node_pairs, union_find_roots

ROCK = dict(density=2000.0, young=1e8, poisson=0.25, tensile_strength=2e5, fracture_energy=10.0)


def _fans(tri: np.ndarray, cut_pairs: set) -> int:
    """Brute force (§13.1): the number of node copies = Σ over nodes of the sectors of its fan,
    the fan's triangles linked across the edges at the node that are not cut."""
    total = 0
    for n in np.unique(tri):
        around = [t for t in range(len(tri)) if n in tri[t]]
        parent = {t: t for t in around}

        def find(a):
            while parent[a] != a:
                a = parent[a]
            return a
        for i, a in enumerate(around):
            for b in around[i + 1:]:
                shared = set(tri[a]) & set(tri[b])
                if len(shared) == 2:
                    (p, q) = sorted(shared)
                    if (p, q) not in cut_pairs:
                        parent[find(a)] = find(b)
        total += len({find(t) for t in around})
    return total


def _interior_pairs(m):
    u, v, *_ = mesh.split.interior_edge_table(m.triangles)
    return np.stack([np.minimum(u, v), np.maximum(u, v)], axis=1)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_split_matches_brute_force_fans(seed):
    src = mesh.rectangle(0.1, 0.06, 0.02)
    pairs = _interior_pairs(src)
    rng = np.random.default_rng(seed)
    pick = pairs[rng.random(len(pairs)) < 0.4]
    scene = Scene(gravity=(0, 0))
    b = scene.add_body(src, Material(**ROCK), fracture=pick)
    cut = {tuple(p) for p in pick.tolist()}
    assert b.mesh.point_count == _fans(np.asarray(src.triangles), cut)
    # triangles keep their shape and position; every joint's node pairs coincide
    np.testing.assert_array_equal(b.mesh.points[b.mesh.triangles], src.points[src.triangles])
    jn = b.joint_nodes
    np.testing.assert_array_equal(b.mesh.points[jn[:, 0]], b.mesh.points[jn[:, 3]])
    np.testing.assert_array_equal(b.mesh.points[jn[:, 1]], b.mesh.points[jn[:, 2]])
    # a joint sits on a selected edge whose triangles no longer share both nodes
    orig = b.origin_triangles
    assert len(jn) <= len(pick)
    for k in range(len(jn)):
        ta, tb = b.joint_tris[k]
        common = set(orig[ta]) & set(orig[tb])
        assert tuple(sorted(common)) in cut
        assert len(set(b.mesh.triangles[ta]) & set(b.mesh.triangles[tb])) < 2


def test_every_edge_gives_private_nodes_and_one_joint_per_interior_edge():
    src = mesh.disk(0.05, 0.02)
    scene = Scene(gravity=(0, 0))
    b = scene.add_body(src, Material(**ROCK), fracture=True)
    assert b.mesh.point_count == 3 * src.triangle_count
    np.testing.assert_array_equal(b.mesh.triangles, np.arange(3 * src.triangle_count).reshape(-1, 3))
    assert b.joint_count == len(_interior_pairs(src))


def test_crack_ending_inside_keeps_its_tip_node():
    src = mesh.rectangle(1.0, 1.0, 0.25)          # nodes every 0.25 m, x, y in [-0.5, 0.5]
    scene = Scene(gravity=(0, 0))
    b = scene.add_body(src, Material(**ROCK), cracks=lambda x, y: (np.abs(y) < 1e-9) & (x < 0.1))
    # crack along y = 0 from the left boundary (x = −0.5) to the tip (0, 0): nodes −0.5, −0.25
    # get a second copy, the tip does not
    assert b.crack_count == 2
    assert b.mesh.point_count == src.point_count + 2
    assert b.joint_count == 0 and not b.fracture and b.self_contact


def test_interfaces_between_material_groups():
    src = mesh.rectangle(0.2, 0.1, 0.02)
    c = src.points[src.triangles].mean(axis=1)
    labels = np.where(c[:, 0] < 0.0, "host", "dyke")
    host, dyke = Material(**ROCK, name="host"), Material(**{**ROCK, "tensile_strength": 5e4}, name="dyke")
    scene = Scene(gravity=(0, 0))
    b = scene.add_body(src, {"host": host, "dyke": dyke}, groups=labels, fracture="interfaces")
    # the interface x = 0 has 0.1/0.02 = 5 edges; the joints take the weaker material
    assert b.joint_count == 5
    mid = 0.5 * (b.mesh.points[b.joint_nodes[:, 0]] + b.mesh.points[b.joint_nodes[:, 1]])
    np.testing.assert_allclose(mid[:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(b.joint_prop, np.tile(dyke.joint_properties(), (5, 1)))
    sim = scene.build()
    tri_mat = sim.model.tri_mat_np
    assert {sim.model.materials[i].name for i in tri_mat[c[:, 0] < 0]} == {"host"}
    assert {sim.model.materials[i].name for i in tri_mat[c[:, 0] > 0]} == {"dyke"}


def test_joint_sets_carry_their_own_properties():
    scene = Scene(gravity=(0, 0))
    rock = Material(**ROCK, name="rock")
    weak = Material(**{**ROCK, "tensile_strength": 1e4, "fracture_energy": 2.0, "friction_angle": 20.0})
    b = scene.add_body(mesh.rectangle(0.2, 0.1, 0.025), rock, fracture=lambda x, y: x < 0.0)
    n_own = b.joint_count
    scene.add_joint_set("band", lambda x, y: np.abs(y) < 1e-9, weak)
    assert scene.joint_set_names == ["default", "band"]
    in_set = b.joint_set == 1
    # y = 0 has 0.2/0.025 = 8 edges; the 4 with x < 0 were joints already and change set
    assert in_set.sum() == 8 and b.joint_count == n_own + 4
    np.testing.assert_allclose(b.joint_prop[in_set], np.tile(weak.joint_properties(), (8, 1)))
    np.testing.assert_allclose(b.joint_prop[~in_set], np.tile(rock.joint_properties(), ((~in_set).sum(), 1)))
    sim = scene.build()
    np.testing.assert_allclose(sim.model.joint_prop.to_numpy()[:, :6], b.joint_prop)     # (then k_x/L and μ)
    assert sim.info()["joint_sets"] == {"default": b.joint_count - 8, "band": 8}
    with pytest.raises(ValueError, match="picks no interior edge"):
        scene.add_joint_set("none", lambda x, y: x > 10.0, weak)
    with pytest.raises(ValueError, match="exists already"):
        scene.add_joint_set("band", lambda x, y: x > 0, weak)


def test_weibull_and_normal_strength_statistics():
    rng = np.random.default_rng(7)
    for m in (3.0, 8.0):
        f = fdem.Weibull(m).factors(400_000, rng)
        cov = math.sqrt(math.gamma(1 + 2 / m) / math.gamma(1 + 1 / m) ** 2 - 1)
        assert abs(f.mean() - 1.0) < 0.005
        assert abs(f.std() / f.mean() / cov - 1.0) < 0.01
    f = fdem.NormalStrength(0.2).factors(400_000, rng)
    assert abs(f.mean() - 1.0) < 0.005 and abs(f.std() - 0.2) < 0.005 and f.min() >= 0.05


def test_strength_is_reproducible_by_seed_and_scales_ft_and_c():
    def props(seed):
        scene = Scene(gravity=(0, 0))
        b = scene.add_body(mesh.rectangle(0.2, 0.1, 0.02), Material(**ROCK), fracture=True,
                           strength=fdem.Weibull(4.0, seed=seed))
        return b.joint_prop
    a, b, c = props(3), props(3), props(4)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    ft, coh, tanphi, gI, gII, pf = Material(**ROCK).joint_properties()
    np.testing.assert_allclose(a[:, 1] / a[:, 0], coh / ft)            # one factor for f_t and c
    np.testing.assert_array_equal(a[:, 3], gI)                          # energies kept (scale_energy=False)
    assert abs(a[:, 0].mean() / ft - 1.0) < 0.1 and a[:, 0].std() / ft > 0.15
    with pytest.raises(ValueError, match="modulus"):
        fdem.Weibull(0.0)
    with pytest.raises(TypeError, match="strength"):
        Scene().add_body(mesh.rectangle(0.2, 0.1, 0.05), Material(**ROCK), fracture=True, strength=0.3)


def test_selector_errors_are_clear():
    scene = Scene(gravity=(0, 0))
    m = mesh.rectangle(0.2, 0.1, 0.05)
    with pytest.raises(ValueError, match="not an edge of the mesh"):
        scene.add_body(m, Material(**ROCK), fracture=np.array([[0, 7]]))
    with pytest.raises(ValueError, match="selects no interior edge"):
        scene.add_body(m, Material(**ROCK), cracks=lambda x, y: x > 1.0)
    with pytest.raises(ValueError, match="unknown edge selector"):
        scene.add_body(m, Material(**ROCK), fracture="everywhere")
    with pytest.raises(ValueError, match="tensile_strength"):
        scene.add_body(m, Material(density=1.0, young=1.0, poisson=0.2), fracture=True)


# ---------------------------------------------------------------------------- verification
def test_block_slides_on_a_preexisting_crack_iff_tan_theta_exceeds_mu():
    """docs/theory/discontinuities.md §13.1 + §8.2: a = g (sin θ − μ cos θ) within 3 % when tan θ > μ; else it sticks."""
    r = vd.case_crack_slide(theta_deg=30.0, friction=0.3)
    assert r["slides"] and r["crack_edges"] == 4
    assert r["error"] < 0.03, r
    r = vd.case_crack_slide(theta_deg=30.0, friction=0.7)
    assert not r["slides"] and r["error"] < 0.01, r


def test_crack_friction_overrides_the_material():
    # material μ = 0.7 would stick; the crack's own μ = 0.3 slides at g (sin θ − 0.3 cos θ)
    r = vd.case_crack_slide(theta_deg=30.0, friction=0.7, crack_friction=0.3)
    assert r["slides"] and r["error"] < 0.03, r


def _components(sim, body) -> int:
    """Brute force: triangles linked by a shared node or an intact joint (union-find)."""
    tri = body.mesh.triangles
    state = sim.state.joint_state.to_numpy()
    pairs = shared_node_pairs(tri) + [(a, b) for j, (a, b) in enumerate(body.joint_tris) if state[j] == 0]
    return len(set(union_find_roots(len(tri), pairs)))


def test_fracture_confined_to_a_jointed_band():
    sim, plate = vd.band_plate_scene(band=0.02)
    assert _components(sim, plate) == 1
    sim.step(30000)
    bj = sim.cracks.broken()
    assert len(bj["index"]) > 10
    X0 = sim.model.node_rest
    jn = sim.model.joint_nodes.to_numpy()[bj["index"]]
    mid0 = 0.5 * (X0[jn[:, 0]] + X0[jn[:, 1]])
    assert np.all(np.abs(mid0[:, 1]) < 0.02)         # every broken joint started in the band
    assert _components(sim, plate) >= 2             # the plate came apart
    # outside the band the mesh stays continuous: no node copies there
    out = np.abs(plate.mesh.points[:, 1]) > 0.02 + 1e-9
    assert len(np.unique(plate.mesh.points[out].round(12), axis=0)) == out.sum()


@pytest.mark.parametrize("notched", [True, False])
def test_new_crack_starts_at_the_notch_tip(notched):
    h = 0.01
    sim, beam, tip = vd.notched_beam_scene(h=h, notched=notched, speed=0.1)
    first = vd.first_cracks(sim, count=2)
    p = first["position"][0]
    if notched:
        # the first joint to break is the one just above the notch tip
        assert abs(p[0]) < 0.5 * h and tip[1] < p[1] < tip[1] + 1.5 * h, first
    else:
        # without the notch the beam cracks at the bottom, under the load
        assert abs(p[0]) < 1.5 * h and p[1] < -0.05 + 1.5 * h, first


def test_polyline_crack_in_a_mesh_that_follows_it():
    """A crack given as a Polyline through a mesh built with polygon(lines=...): the split edges'
    total length equals the line's length, and the body has that many crack edges."""
    fault = mesh.Polyline([(-0.3, -0.2), (0.3, 0.2)], name="fault")
    m = mesh.polygon([(-0.3, -0.2), (0.3, -0.2), (0.3, 0.2), (-0.3, 0.2)], 0.05, lines=[fault])
    scene = Scene(gravity=(0, 0))
    b = scene.add_body(m, Material(**ROCK), cracks=fault, crack_friction=0.3)
    u, v, *_ = b.edge_table
    L = np.linalg.norm(m.points[u[b.crack_mask]] - m.points[v[b.crack_mask]], axis=1).sum()
    assert L == pytest.approx(fault.length, rel=1e-9)
    # the fault runs corner to corner: it cuts the body in two, and every node on it is doubled
    on = fault.select_edges(m.points, np.stack([u, v], 1))
    assert np.array_equal(on, b.crack_mask)
    nodes_on = np.unique(np.concatenate([u[on], v[on]]))
    assert b.mesh.point_count == m.point_count + len(nodes_on)
    sim = scene.build()
    pair = sim.model.mat_pair.to_numpy()
    assert len(sim.model.materials) == 2          # the rock and its crack-face copy
    rock, face = (0, 1) if sim.model.materials[1].friction == 0.3 else (1, 0)
    # faces against faces and against the rest of the body: the crack's μ; rock on rock: its own
    assert pair[face, face, 2] == pair[face, rock, 2] == pair[rock, face, 2] == 0.3
    assert pair[rock, rock, 2] == sim.model.materials[rock].friction != 0.3


def test_material_groups_from_a_tagged_mesh_file(tmp_path):
    """load_tagged: one mesh + a label per triangle; the interface of the two groups jointed."""
    import meshio
    src = mesh.rectangle(0.2, 0.1, 0.025)
    c = src.points[src.triangles].mean(axis=1)
    tag = np.where(c[:, 0] < 0.0, 1, 2)
    path = tmp_path / "two.msh"
    meshio.write(path, meshio.Mesh(np.c_[src.points, np.zeros(src.point_count)], [("triangle", src.triangles)],
                                   cell_data={"gmsh:physical": [tag], "gmsh:geometrical": [tag]},
                                   field_data={"host": np.array([1, 2]), "dyke": np.array([2, 2])}),
                 file_format="gmsh22", binary=False)
    m, labels, lines = mesh.load_tagged(path)
    host, dyke = Material(**ROCK, name="host"), Material(**{**ROCK, "tensile_strength": 1e5}, name="dyke")
    scene = Scene(gravity=(0, 0))
    b = scene.add_body(m, {"host": host, "dyke": dyke}, groups=labels, fracture="interfaces")
    assert b.joint_count == 4                      # x = 0, four 0.025 m edges
    np.testing.assert_allclose(b.joint_prop[:, 0], 1e5)


def test_checkpoint_restart_with_cracks_and_joint_sets_is_exact(tmp_path):
    sim, _ = vd.band_plate_scene(band=0.02, speed=2.0)
    sim.step(2000)
    sim.save(tmp_path / "c.ckpt")
    sim.step(1500)
    back = fdem.Simulation.load(tmp_path / "c.ckpt")
    back.step(1500)
    assert sim.cracks.broken_count > 0
    np.testing.assert_array_equal(back.node_positions(), sim.node_positions())
    np.testing.assert_array_equal(back.state.joint_state.to_numpy(), sim.state.joint_state.to_numpy())
    np.testing.assert_array_equal(back.model.joint_prop.to_numpy(), sim.model.joint_prop.to_numpy())


def test_heterogeneous_brazilian_mean_and_scatter():
    """docs/theory/discontinuities.md §13.3, issue #11: Weibull joint strength (m = 6, mean f_t) over 5 seeds on a
    20-element disc: mean peak 0.85 f_t, standard deviation 0.06 f_t; homogeneous 0.92 f_t on the
    same mesh (σ_t × Hondros / f_t; the README quotes these)."""
    r = vd.heterogeneous_brazilian(seeds=(1, 2, 3, 4, 5), modulus=6.0, elements=20, load_time=40.0)
    assert r["homogeneous"] == pytest.approx(0.92, abs=0.01)
    assert r["mean"] == pytest.approx(0.85, abs=0.01)
    assert r["std"] == pytest.approx(0.06, abs=0.01)
    assert r["mean"] < r["homogeneous"]             # the weakest joints start the split


def test_serial_and_parallel_agree_on_a_partly_jointed_body_with_a_crack_tip():
    """A line of joints ending inside the body (a shared tip node: a joint whose j0 = j3 or
    j1 = j2) and an open crack ending inside it, sheared and pulled apart: both strategies give
    the same run to round-off."""
    def build(strategy):
        mat = Material(**ROCK, damping=0.1, friction=0.4)
        scene = Scene(gravity=(0.0, 0.0))
        scene.add_body(mesh.rectangle(0.2, 0.1, 0.01), mat, fracture=lambda x, y: (np.abs(y) < 1e-9) & (x < 0.05),
                       cracks=lambda x, y: (np.abs(x) < 1e-9) & (y < -0.01))
        scene.fix_nodes(lambda x, y: y > 0.05 - 1e-9, velocity=(0.3, 1.0))
        scene.fix_nodes(lambda x, y: y < -0.05 + 1e-9, velocity=(0.0, -1.0))
        return scene.build(strategy=strategy)
    a, b = build("serial"), build("parallel")
    jn = a.model.joint_nodes.to_numpy()
    assert np.any((jn[:, 0] == jn[:, 3]) | (jn[:, 1] == jn[:, 2]))         # a tip joint
    a.step(6000)
    b.step(6000)
    assert a.cracks.broken_count == b.cracks.broken_count > 5
    np.testing.assert_allclose(a.node_positions(), b.node_positions(), rtol=0, atol=1e-11)
    assert a.energies()["total"] == pytest.approx(b.energies()["total"], rel=1e-9)


def test_guide_discontinuity_example_runs_as_written(capsys):
    """docs/guide/fracture.md "Joints on chosen edges, cracks, joint sets and heterogeneity": the example runs as written; its
    band of joints, its crack (x = 0 below y = −0.1: 3 edges of 0.05 m) and its joint set
    (y = 0.15: 20 edges) are where it says."""
    import os
    import re
    readme = open(os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "docs", "guide", "fracture.md")).read()
    sec = readme[readme.index("## Joints on chosen edges, cracks, joint sets and heterogeneity"):]
    code = re.search(r"```python\n(.*?)```", sec, re.S).group(1)
    scope: dict = {}
    exec(compile(code, "docs/guide/fracture.md", "exec"), scope)
    assert "['default', 'bedding']" in capsys.readouterr().out
    block = scope["block"]
    assert block.crack_count == 3
    assert (block.joint_set == 1).sum() == 20
    mid = 0.5 * (block.mesh.points[block.joint_nodes[:, 0]] + block.mesh.points[block.joint_nodes[:, 1]])
    own = block.joint_set == 0
    assert np.all(np.abs(mid[own, 1]) <= 0.1 + 1e-9) and np.allclose(mid[~own, 1], 0.15)    # the band's midpoints


def test_a_line_the_mesh_does_not_follow_is_reported():
    m = mesh.rectangle(1.0, 1.0, 0.25)
    scene = Scene(gravity=(0, 0))
    with pytest.warns(RuntimeWarning, match=r"follow only 1 m of the 1\.4 m"):
        b = scene.add_body(m, Material(**ROCK), cracks=mesh.Polyline([(-0.5, 0.0), (0.9, 0.0)]))
    assert b.crack_count == 4                        # the part inside the body is cracked
    with pytest.warns(RuntimeWarning, match="follow only 0 m"), pytest.raises(ValueError, match="selects no"):
        scene.add_body(m, Material(**ROCK), cracks=mesh.Polyline([(-0.5, 0.0), (0.5, 0.1)]))


def test_line_groups_of_a_mesh_file_as_crack_and_joint_selectors(tmp_path):
    """A gmsh file with physical line groups: load_groups(...).lines (or lines=True) gives
    Segments usable as cracks= / fracture= selectors on the mesh of that file."""
    import meshio
    src = mesh.rectangle(0.2, 0.1, 0.025)
    pts3 = np.c_[src.points, np.zeros(src.point_count)]
    on_y0 = [e for e in src.edges().tolist() if abs(src.points[e[0], 1]) < 1e-12 and abs(src.points[e[1], 1]) < 1e-12]
    on_x0 = [e for e in src.edges().tolist() if abs(src.points[e[0], 0]) < 1e-12 and abs(src.points[e[1], 0]) < 1e-12]
    lines = np.array(on_y0 + on_x0)
    ltag = np.array([10] * len(on_y0) + [11] * len(on_x0))
    ttag = np.ones(src.triangle_count, int)
    path = tmp_path / "faults.msh"
    meshio.write(path, meshio.Mesh(pts3, [("line", lines), ("triangle", src.triangles)],
                                   cell_data={"gmsh:physical": [ltag, ttag], "gmsh:geometrical": [ltag, ttag]},
                                   field_data={"fault": np.array([10, 1]), "joint": np.array([11, 1]),
                                               "rock": np.array([1, 2])}),
                 file_format="gmsh22", binary=False)
    groups = mesh.load_groups(path)
    assert list(groups.lines) == ["fault", "joint"]
    scene = Scene(gravity=(0, 0))
    b = scene.add_body(groups["rock"], Material(**ROCK), cracks=groups.lines["fault"], fracture=groups.lines["joint"])
    assert b.crack_count == 8                         # y = 0: 0.2 m / 0.025 m
    assert b.joint_count == 4                         # x = 0: 0.1 m / 0.025 m, not on the crack
    both = Scene(gravity=(0, 0)).add_body(groups["rock"], Material(**ROCK), cracks=groups.lines)
    assert both.crack_count == 12                     # a dict of line groups: their union


def test_a_fracture_body_without_fracture_energy_names_its_material_as_given():
    """The error names the material by its name, its group label or (unnamed) its repr."""
    no_gf = fdem.Material(density=2600.0, young=1e9, poisson=0.25, tensile_strength=1e6)
    mesh = fdem.mesh.rectangle(1.0, 1.0, 0.25)
    cases = ((no_gf.with_(name="granite"), {}, "material 'granite'"),
             ({"host": no_gf}, {"groups": np.full(mesh.triangle_count, "host")}, "group 'host'"),
             (no_gf, {}, "Material(density=2600.0"))
    for material, kw, named in cases:
        scene = fdem.Scene()
        with pytest.raises(ValueError, match="fracture_energy") as err:
            scene.add_body(mesh, material, fracture=True, **kw)
            scene.build()
        assert named in str(err.value) and "np.int32" not in str(err.value)

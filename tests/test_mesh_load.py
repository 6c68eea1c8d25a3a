"""Mesh import by physical group / cell tag: mesh.load_groups and mesh.scene_from_groups.

The files are written with meshio in gmsh 2.2 and gmsh 4.1 (ASCII and binary) formats.  The
test mesh is a 2 m x 1 m strip of four triangles: tag 1 ("left") covers x in [0, 1], tag 2
("right") x in [1, 2]; a line group "bottom" of dimension 1 re-uses tag 1 and must not name
the surface group.  One triangle of "left" is written clockwise.
"""
from __future__ import annotations

import meshio
import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem import mesh as M

PTS = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [0.0, 1.0], [1.0, 1.0], [2.0, 1.0]])
TRI_LEFT = np.array([[0, 1, 4], [0, 3, 4]])     # the second one is clockwise
TRI_RIGHT = np.array([[1, 2, 5], [1, 5, 4]])
LINES = np.array([[0, 1], [1, 2]])
FIELD = {"left": np.array([1, 2]), "right": np.array([2, 2]), "bottom": np.array([1, 1])}


def write_gmsh22(path, field_data=FIELD, binary=False):
    m = meshio.Mesh(np.c_[PTS, np.zeros(len(PTS))],
                    [("line", LINES), ("triangle", np.vstack([TRI_LEFT, TRI_RIGHT]))],
                    cell_data={"gmsh:physical": [np.array([1, 1]), np.array([1, 1, 2, 2])],
                               "gmsh:geometrical": [np.array([1, 1]), np.array([1, 1, 2, 2])]},
                    field_data=field_data)
    meshio.write(path, m, file_format="gmsh22", binary=binary)


def write_gmsh41(path, field_data=FIELD, binary=False):
    # gmsh 4.1 stores physical groups per entity: one triangle block per surface entity,
    # and every node assigned to an entity (gmsh:dim_tags)
    fd = {k: v for k, v in field_data.items() if v[1] == 2} if field_data else field_data
    dim_tags = np.array([[2, 1], [2, 1], [2, 2], [2, 1], [2, 1], [2, 2]])
    m = meshio.Mesh(np.c_[PTS, np.zeros(len(PTS))], [("triangle", TRI_LEFT), ("triangle", TRI_RIGHT)],
                    point_data={"gmsh:dim_tags": dim_tags},
                    cell_data={"gmsh:physical": [np.array([1, 1]), np.array([2, 2])],
                               "gmsh:geometrical": [np.array([1, 1]), np.array([2, 2])]},
                    field_data=fd)
    meshio.write(path, m, file_format="gmsh", binary=binary)


def check_split(groups):
    """The two groups of the strip, with their own (duplicated interface) nodes, CCW."""
    assert list(groups) == ["left", "right"]
    left, right = groups["left"], groups["right"]
    for g, x0 in ((left, 0.0), (right, 1.0)):
        assert g.triangle_count == 2 and g.point_count == 4
        assert g.area == pytest.approx(1.0, rel=1e-14)
        np.testing.assert_allclose(g.bounding_box(), (x0, 0.0, x0 + 1.0, 1.0))
        p = g.points[g.triangles]
        twice = ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                 - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))
        np.testing.assert_allclose(twice, 1.0)       # all counter-clockwise, area 1/2 each
    # the interface x = 1 belongs to both groups (duplicated nodes, not shared)
    assert np.sum(np.isclose(left.points[:, 0], 1.0)) == 2
    assert np.sum(np.isclose(right.points[:, 0], 1.0)) == 2


@pytest.mark.parametrize("writer", [write_gmsh22, write_gmsh41], ids=["gmsh22", "gmsh41"])
@pytest.mark.parametrize("binary", [False, True], ids=["ascii", "binary"])
def test_groups_split_by_physical_name(tmp_path, writer, binary):
    path = tmp_path / "strip.msh"
    writer(path, binary=binary)
    groups = M.load_groups(path)
    check_split(groups)
    # the whole file still loads as one mesh (4 triangles, 6 shared nodes)
    whole = M.load(path)
    assert whole.triangle_count == 4 and whole.point_count == 6
    assert M.TriMesh.load_groups is M.load_groups


@pytest.mark.parametrize("writer", [write_gmsh22, write_gmsh41], ids=["gmsh22", "gmsh41"])
def test_unnamed_groups_keyed_by_tag(tmp_path, writer):
    path = tmp_path / "strip.msh"
    writer(path, field_data={})
    groups = M.load_groups(path)
    assert list(groups) == [1, 2]
    assert groups[1].bounding_box() == (0.0, 0.0, 1.0, 1.0)
    assert groups[2].bounding_box() == (1.0, 0.0, 2.0, 1.0)


def test_cell_tags_of_other_formats(tmp_path):
    path = tmp_path / "strip.vtu"
    tri = np.vstack([TRI_LEFT, TRI_RIGHT])
    meshio.write(path, meshio.Mesh(np.c_[PTS, np.zeros(6)], [("triangle", tri)],
                                   cell_data={"region": [np.array([7, 7, 3, 3], dtype=np.int32)],
                                              "stress": [np.zeros(4)]}))
    groups = M.load_groups(path)                    # "region" is one of GROUP_KEYS
    assert list(groups) == [3, 7]
    assert groups[3].bounding_box()[0] == 1.0 and groups[7].bounding_box()[0] == 0.0
    # any integer-valued cell data can be named explicitly (here a float array of zeros: one group)
    assert list(M.load_groups(path, key="stress")) == [0]
    with pytest.raises(ValueError, match=r"no cell-data array 'material'.*found \['region', 'stress'\]"):
        M.load_groups(path, key="material")


def test_no_tags_refused(tmp_path):
    path = tmp_path / "plain.vtu"
    meshio.write(path, meshio.Mesh(PTS, [("triangle", TRI_RIGHT)]))
    with pytest.raises(ValueError, match=r"load_groups: .*plain\.vtu.* has no cell tags"):
        M.load_groups(path)


@pytest.mark.parametrize("kind, match", [
    ("quad", r"contains 'quad' cells .*mixed meshes are refused"),
    ("triangle6", r"higher-order 'triangle6' cells"),
    ("tetra", r"3D mesh \(contains 'tetra' cells\)"),
    ("z", r"is a 3D mesh \(z varies"),
    ("degenerate", r"triangle 1 has zero area.*group 'right'"),
])
def test_bad_meshes_refused(tmp_path, kind, match):
    path = tmp_path / f"{kind}.msh"
    pts3 = np.c_[PTS, np.zeros(6)]
    phys = lambda n, t: np.full(n, t)
    if kind == "quad":
        cells = [("triangle", TRI_LEFT), ("quad", np.array([[1, 2, 5, 4]]))]
        tags = [phys(2, 1), phys(1, 2)]
    elif kind == "triangle6":
        pts3 = np.vstack([pts3, [[0.5, 0.0, 0.0], [0.5, 0.5, 0.0], [0.0, 0.5, 0.0]]])
        cells = [("triangle6", np.array([[0, 1, 3, 6, 7, 8]]))]
        tags = [phys(1, 1)]
    elif kind == "tetra":
        # a volume cell is refused even when all its nodes happen to lie in the plane
        cells = [("triangle", TRI_LEFT), ("tetra", np.array([[0, 1, 3, 4]]))]
        tags = [phys(2, 1), phys(1, 3)]
    elif kind == "z":
        pts3[5, 2] = 0.5
        cells = [("triangle", np.vstack([TRI_LEFT, TRI_RIGHT]))]
        tags = [np.array([1, 1, 2, 2])]
    else:  # degenerate: the second triangle of "right" has three collinear nodes
        cells = [("triangle", np.vstack([TRI_LEFT, [[1, 2, 5], [0, 1, 2]]]))]
        tags = [np.array([1, 1, 2, 2])]
    meshio.write(path, meshio.Mesh(pts3, cells, cell_data={"gmsh:physical": tags, "gmsh:geometrical": tags},
                                   field_data={"left": np.array([1, 2]), "right": np.array([2, 2])}),
                 file_format="gmsh22", binary=False)
    with pytest.raises(ValueError, match=match) as info:
        M.load_groups(path)
    assert str(path) in str(info.value)


def test_garbage_file_refused(tmp_path):
    path = tmp_path / "junk.msh"
    path.write_text("$MeshFormat\nthis is not a mesh\n")
    with pytest.raises(ValueError, match=r"load_groups: cannot read .*junk\.msh"):
        M.load_groups(path)


def test_scene_from_groups(tmp_path):
    path = tmp_path / "strip.msh"
    write_gmsh41(path)
    soft = fdem.Material(density=1000.0, young=1e6, poisson=0.3, name="soft")
    hard = fdem.Material(density=3000.0, young=1e9, poisson=0.2, name="hard")
    scene = fdem.Scene()
    bodies = M.scene_from_groups(scene, path, {"left": soft, "right": hard}, velocity=(1.0, 0.0))
    assert [b.name for b in scene.bodies] == ["left", "right"]
    assert bodies["left"].material is soft and bodies["right"].material is hard
    np.testing.assert_array_equal(bodies["right"].velocity, [1.0, 0.0])
    assert bodies["right"].mesh.bounding_box() == (1.0, 0.0, 2.0, 1.0)   # file coordinates kept
    assert scene.node_count == 8 and scene.tri_count == 4

    # one material for every group
    both = M.scene_from_groups(fdem.Scene(), path, soft)
    assert all(b.material is soft for b in both.values())

    with pytest.raises(ValueError, match=r"no material for group\(s\) \['right'\].*groups: \['left', 'right'\]"):
        M.scene_from_groups(fdem.Scene(), path, {"left": soft})
    with pytest.raises(ValueError, match=r"material key\(s\) \['middle'\] are not groups of the file"):
        M.scene_from_groups(fdem.Scene(), path, {"left": soft, "right": hard, "middle": soft})
    with pytest.raises(ValueError, match=r"materials\['right'\] must be a Material"):
        M.scene_from_groups(fdem.Scene(), path, {"left": soft, "right": 3.0})
    with pytest.raises(ValueError, match=r"position= is not allowed"):
        M.scene_from_groups(fdem.Scene(), path, soft, position=(0.0, 0.0))


def test_pickled_mesh_stays_immutable():
    import pickle

    m = pickle.loads(pickle.dumps(M.rectangle(1.0, 1.0, 0.5)))
    assert m.triangle_count == 8 and m.area == pytest.approx(1.0)
    assert not m.points.flags.writeable and not m.triangles.flags.writeable and not m.areas.flags.writeable


# --------------------------------------------------------------------------- line groups (issue #11)
# the strip again, with two physical line groups: "bottom" (tag 1, the edges 0-1-2 along y = 0)
# and "dyke" (tag 3, the interface edge 1-4 at x = 1, shared by both surface groups)
LINE_BOTTOM = np.array([[0, 1], [1, 2]])
LINE_DYKE = np.array([[1, 4]])
FIELD_LINES = {**FIELD, "dyke": np.array([3, 1])}


def write_with_lines(path, fmt, binary=False, field_data=FIELD_LINES):
    # gmsh 4.1 assigns every node to one entity: nodes on curves to the curve (dim 1), the
    # node where the two curves meet to a geometry point (dim 0)
    dim_tags = np.array([[1, 1], [0, 1], [1, 1], [2, 1], [1, 2], [2, 2]])
    m = meshio.Mesh(np.c_[PTS, np.zeros(len(PTS))],
                    [("line", LINE_BOTTOM), ("line", LINE_DYKE), ("triangle", TRI_LEFT), ("triangle", TRI_RIGHT)],
                    point_data={"gmsh:dim_tags": dim_tags} if fmt == "gmsh" else {},
                    cell_data={"gmsh:physical": [np.array([1, 1]), np.array([3]), np.array([1, 1]), np.array([2, 2])],
                               "gmsh:geometrical": [np.array([1, 1]), np.array([2]), np.array([1, 1]), np.array([2, 2])]},
                    field_data=field_data)
    meshio.write(path, m, file_format=fmt, binary=binary)


def sorted_segments(s):
    """Segments as a canonical set: each segment's ends in lexicographic order, rows sorted."""
    seg = np.asarray(s)
    flip = (seg[:, 0, 0] > seg[:, 1, 0]) | ((seg[:, 0, 0] == seg[:, 1, 0]) & (seg[:, 0, 1] > seg[:, 1, 1]))
    seg = np.where(flip[:, None, None], seg[:, ::-1], seg)
    return seg[np.lexsort((seg[:, 1, 1], seg[:, 1, 0], seg[:, 0, 1], seg[:, 0, 0]))]


@pytest.mark.parametrize("fmt", ["gmsh22", "gmsh"], ids=["gmsh22", "gmsh41"])
@pytest.mark.parametrize("binary", [False, True], ids=["ascii", "binary"])
def test_load_groups_with_line_groups(tmp_path, fmt, binary):
    path = tmp_path / "strip_lines.msh"
    write_with_lines(path, fmt, binary)
    groups, lines = M.load_groups(path, lines=True)
    check_split(groups)                                     # the surfaces as before
    plain = M.load_groups(path)
    assert isinstance(plain, dict) and list(plain) == list(groups)   # lines=False: a dict of meshes
    assert list(plain.lines) == ["bottom", "dyke"]          # ... that also carries the line groups
    np.testing.assert_array_equal(plain.lines["dyke"].segments, lines["dyke"].segments)
    import pickle
    assert type(pickle.loads(pickle.dumps(plain))) is dict
    assert list(lines) == ["bottom", "dyke"]
    bottom, dyke = lines["bottom"], lines["dyke"]
    assert isinstance(bottom, M.Segments) and bottom.name == "bottom" and dyke.name == "dyke"
    np.testing.assert_array_equal(sorted_segments(bottom.segments), sorted_segments(PTS[LINE_BOTTOM]))
    np.testing.assert_array_equal(sorted_segments(dyke.segments), sorted_segments(PTS[LINE_DYKE]))
    assert bottom.length == 2.0 and dyke.length == 1.0
    # as edge selectors on the whole mesh: the dyke is the one interior edge 1-4
    whole = M.load(path)
    inner, _ = whole.interior_edges()
    sel = dyke.select_edges(whole.points, inner)
    assert sel.sum() == 1 and whole.edge_lengths(inner[sel]).sum() == 1.0
    assert bottom.select_edges(whole.points, whole.boundary_edges()).sum() == 2


@pytest.mark.parametrize("fmt", ["gmsh22", "gmsh"], ids=["gmsh22", "gmsh41"])
def test_load_tagged(tmp_path, fmt):
    path = tmp_path / "strip_lines.msh"
    write_with_lines(path, fmt)
    mesh, labels, lines = M.load_tagged(path)
    assert mesh.point_count == 6 and mesh.triangle_count == 4          # one body, shared nodes
    assert mesh.area == pytest.approx(2.0, rel=1e-14)
    assert labels.shape == (4,) and labels.tolist() == ["left", "left", "right", "right"]
    # each label covers its half of the strip
    cx = mesh.points[mesh.triangles].mean(axis=1)[:, 0]
    assert np.all((cx < 1.0) == (labels == "left"))
    assert list(lines) == ["bottom", "dyke"] and lines["dyke"].length == 1.0
    assert M.TriMesh.load_tagged is M.load_tagged and fdem.mesh.load_tagged is M.load_tagged


def test_unnamed_line_groups_and_int_labels(tmp_path):
    path = tmp_path / "unnamed.msh"
    write_with_lines(path, "gmsh22", field_data={})
    groups, lines = M.load_groups(path, lines=True)
    assert list(groups) == [1, 2] and list(lines) == [1, 3]
    assert lines[3].name == "3" and lines[3].length == 1.0
    mesh, labels, _ = M.load_tagged(path)
    assert labels.dtype == np.int64 and labels.tolist() == [1, 1, 2, 2]
    # a file without line cells has no line groups
    plain = tmp_path / "plain.msh"
    write_gmsh22(plain)
    _, lines_plain = M.load_groups(plain, lines=True)
    assert set(lines_plain) == {"bottom"}                   # write_gmsh22's line cells are tag 1
    vtu = tmp_path / "tri.vtu"
    meshio.write(vtu, meshio.Mesh(PTS, [("triangle", TRI_RIGHT)], cell_data={"region": [np.array([5, 5])]}))
    assert M.load_groups(vtu, lines=True)[1] == {}


def test_load_tagged_missing_tags(tmp_path):
    path = tmp_path / "plain.vtu"
    meshio.write(path, meshio.Mesh(PTS, [("triangle", TRI_RIGHT)]))
    with pytest.raises(ValueError, match=r"load_tagged: .*plain\.vtu.* has no cell tags"):
        M.load_tagged(path)
    tagged = tmp_path / "strip_lines.msh"
    write_with_lines(tagged, "gmsh22")
    with pytest.raises(ValueError, match=r"load_tagged: .* has no cell-data array 'material'"):
        M.load_tagged(tagged, key="material")
    with pytest.raises(ValueError, match=r"load_groups: .* has no cell-data array 'material'"):
        M.load_groups(tagged, key="material", lines=True)


def test_degenerate_line_group_named(tmp_path):
    path = tmp_path / "bad_line.msh"
    m = meshio.Mesh(np.c_[PTS, np.zeros(len(PTS))], [("line", np.array([[0, 1], [2, 2]])), ("triangle", TRI_RIGHT)],
                    cell_data={"gmsh:physical": [np.array([4, 4]), np.array([2, 2])],
                               "gmsh:geometrical": [np.array([1, 1]), np.array([2, 2])]},
                    field_data={"crack": np.array([4, 1])})
    meshio.write(path, m, file_format="gmsh22")
    with pytest.raises(ValueError, match=r"line group 'crack' \(gmsh:physical = 4\): Segments: segment 1 has zero length"):
        M.load_groups(path, lines=True)
    assert list(M.load_groups(path)) == [2]                 # lines=False never reads the line cells

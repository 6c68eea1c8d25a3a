"""Tests for taichi_fdem.mesh: constructors, validation, topology, transforms, I/O."""
import math

import meshio
import numpy as np
import pytest

from taichi_fdem import mesh as M
from taichi_fdem.mesh import TriMesh


# --------------------------------------------------------------------------- shared checks
def shoelace(v):
    v = np.asarray(v, dtype=float)
    return 0.5 * abs(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))


def signed_areas(m):
    p = m.points[m.triangles]
    ab, ac = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    return 0.5 * (ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0])


def min_angle_deg(m):
    p = m.points[m.triangles]
    angles = []
    for k in range(3):
        a, b, c = p[:, k], p[:, (k + 1) % 3], p[:, (k + 2) % 3]
        u, v = b - a, c - a
        cos = (u * v).sum(1) / np.sqrt((u * u).sum(1) * (v * v).sum(1))
        angles.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return float(np.min(angles))


def check_valid(m, euler):
    """Generic invariants of a well-formed mesh."""
    assert m.points.dtype == np.float64 and m.points.shape[1] == 2
    assert m.triangles.dtype == np.int32 and m.triangles.shape[1] == 3
    sa = signed_areas(m)
    assert np.all(sa > 0), "all triangles must be counter-clockwise"
    np.testing.assert_allclose(sa, m.areas, rtol=1e-12)
    # every undirected edge in 1 (boundary) or 2 (interior) triangles, interior ones in
    # opposite directions
    t = m.triangles.astype(np.int64)
    d = np.stack([t, np.roll(t, -1, axis=1)], axis=2).reshape(-1, 2)
    s = np.sort(d, axis=1)
    keys, counts = np.unique(s[:, 0] * m.point_count + s[:, 1], return_counts=True)
    assert counts.max() <= 2
    assert len(np.unique(d[:, 0] * m.point_count + d[:, 1])) == len(d)
    assert len(keys) == len(m.edges())
    assert np.count_nonzero(counts == 1) == len(m.boundary_edges())
    # every point used, Euler characteristic
    assert np.array_equal(np.unique(m.triangles), np.arange(m.point_count))
    assert m.point_count - len(m.edges()) + m.triangle_count == euler
    # boundary edges form simple closed loops: each boundary node starts exactly one
    be = m.boundary_edges()
    assert np.array_equal(np.sort(be[:, 0]), np.sort(be[:, 1]))
    assert len(be) == len(np.unique(be[:, 0]))


# --------------------------------------------------------------------------- rectangle
@pytest.mark.parametrize("pattern,per_cell,extra_nodes", [("alternating", 2, 0), ("crossed", 4, 1), ("right", 2, 0)])
def test_rectangle_patterns(pattern, per_cell, extra_nodes):
    m = M.rectangle(2.0, 1.2, 0.1, pattern=pattern)
    nx, ny = 20, 12
    assert m.triangle_count == per_cell * nx * ny
    assert m.point_count == (nx + 1) * (ny + 1) + extra_nodes * nx * ny
    assert m.area == pytest.approx(2.4, rel=1e-14)
    check_valid(m, euler=1)
    assert min_angle_deg(m) == pytest.approx(45.0, abs=1e-9)
    np.testing.assert_allclose(m.centroid, [0.0, 0.0], atol=1e-15)
    assert m.bounding_box() == pytest.approx((-1.0, -0.6, 1.0, 0.6), abs=1e-15)
    assert len(m.boundary_nodes()) == 2 * (nx + ny)


def test_rectangle_default_is_alternating_and_unbiased():
    m = M.rectangle(1.0, 1.0, 0.25)
    assert m.triangle_count == 2 * 16
    # alternating diagonals: as many "/" as "\" diagonals
    e = m.edges()
    v = m.points[e[:, 1]] - m.points[e[:, 0]]
    diag = (np.abs(v[:, 0]) > 1e-12) & (np.abs(v[:, 1]) > 1e-12)
    slope = np.sign(v[diag, 0] * v[diag, 1])
    assert np.count_nonzero(slope > 0) == np.count_nonzero(slope < 0) == 8


def test_rectangle_origin_and_rounding():
    m = M.rectangle(1.0, 0.5, 0.3, origin=(2.0, -1.0))
    assert m.bounding_box() == pytest.approx((2.0, -1.0, 3.0, -0.5), abs=1e-15)
    assert m.triangle_count == 2 * 3 * 2  # round(3.33)=3, round(1.67)=2
    np.testing.assert_allclose(m.centroid, [2.5, -0.75], atol=1e-14)
    # h larger than the rectangle: a single cell
    assert M.rectangle(0.1, 0.1, 1.0).triangle_count == 2
    assert TriMesh.rectangle(1.0, 1.0, 0.5).triangle_count == 8  # static-method alias


@pytest.mark.parametrize("args", [(0.0, 1.0, 0.1), (1.0, -1.0, 0.1), (1.0, 1.0, 0.0), (1.0, 1.0, float("nan")),
                                  (float("inf"), 1.0, 0.1)])
def test_rectangle_bad_sizes(args):
    with pytest.raises(ValueError, match="rectangle"):
        M.rectangle(*args)


def test_rectangle_bad_pattern():
    with pytest.raises(ValueError, match="pattern"):
        M.rectangle(1.0, 1.0, 0.1, pattern="diagonal")


# --------------------------------------------------------------------------- disk
def inscribed_area(r, n):
    return 0.5 * n * r * r * math.sin(2 * math.pi / n)


@pytest.mark.parametrize("radius,h", [(0.05, 0.02), (1.0, 0.1), (1.0, 0.037), (0.3, 0.3), (0.3, 0.55)])
def test_disk(radius, h):
    c = np.array([0.7, -2.5])
    m = M.disk(radius, h, center=c)
    check_valid(m, euler=1)
    b = m.boundary_nodes()
    dist = np.hypot(*(m.points[b] - c).T)
    np.testing.assert_allclose(dist, radius, rtol=0, atol=1e-12)
    assert np.all(np.hypot(*(m.points - c).T) <= radius * (1 + 1e-12))
    assert m.area == pytest.approx(inscribed_area(radius, len(b)), rel=1e-12)
    if radius / h >= 2:
        assert m.area == pytest.approx(math.pi * radius ** 2, rel=0.05)
    np.testing.assert_allclose(m.centroid, c, atol=1e-12 * max(1, np.abs(c).max()))
    assert min_angle_deg(m) > 35.0
    if radius / h >= 1:
        assert m.mean_edge_length() == pytest.approx(h, rel=0.35)


def test_benchmark_disk_size():
    m = M.disk(0.05, 0.02)
    assert 20 <= m.triangle_count <= 40
    assert m.triangle_count == 32 and m.point_count == 25


def test_disk_quality_over_many_sizes():
    for ratio in np.linspace(0.5, 40.0, 60):
        m = M.disk(1.0, 1.0 / ratio)
        assert min_angle_deg(m) > 35.0, ratio


@pytest.mark.parametrize("radius,h", [(0.0, 0.1), (-1.0, 0.1), (1.0, 0.0), (1.0, float("nan")), (1.0, 2.5)])
def test_disk_bad_sizes(radius, h):
    with pytest.raises(ValueError, match="disk"):
        M.disk(radius, h)


# --------------------------------------------------------------------------- annulus
@pytest.mark.parametrize("ri,ro,h", [(0.5, 1.0, 0.1), (0.2, 0.3, 0.02), (0.3, 1.0, 0.25), (0.9, 1.0, 0.2)])
def test_annulus(ri, ro, h):
    c = np.array([-1.0, 3.0])
    m = M.annulus(ri, ro, h, center=c)
    check_valid(m, euler=0)
    b = m.boundary_nodes()
    r = np.hypot(*(m.points[b] - c).T)
    on_in, on_out = np.abs(r - ri) <= 1e-12, np.abs(r - ro) <= 1e-12
    assert np.all(on_in | on_out)
    assert m.area == pytest.approx(inscribed_area(ro, on_out.sum()) - inscribed_area(ri, on_in.sum()), rel=1e-12)
    assert m.area == pytest.approx(math.pi * (ro ** 2 - ri ** 2), rel=0.06)
    assert min_angle_deg(m) > 25.0
    # outer boundary counter-clockwise, inner (hole) clockwise: body on the left
    be = m.boundary_edges()
    p0, p1 = m.points[be[:, 0]] - c, m.points[be[:, 1]] - c
    turn = np.sign(p0[:, 0] * p1[:, 1] - p0[:, 1] * p1[:, 0])
    outer = np.abs(np.hypot(*p0.T) - ro) <= 1e-12
    assert np.all(turn[outer] > 0) and np.all(turn[~outer] < 0)


@pytest.mark.parametrize("ri,ro,h", [(1.0, 0.5, 0.1), (0.5, 0.5, 0.1), (0.0, 1.0, 0.1), (0.5, 1.0, 1.2),
                                     (0.5, 1.0, -0.1)])
def test_annulus_bad_sizes(ri, ro, h):
    with pytest.raises(ValueError, match="annulus"):
        M.annulus(ri, ro, h)


# --------------------------------------------------------------------------- polygon
SQUARE = [(0, 0), (1, 0), (1, 1), (0, 1)]
L_SHAPE = [(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]
STAR = [((1.0 if k % 2 == 0 else 0.45) * math.cos(k * math.pi / 5), (1.0 if k % 2 == 0 else 0.45) * math.sin(k * math.pi / 5))
        for k in range(10)]
COMB = [(0, 0), (5, 0), (5, 3), (4, 3), (4, 1), (3, 1), (3, 3), (2, 3), (2, 1), (1, 1), (1, 3), (0, 3)]
CIRCLE = [(math.cos(t), math.sin(t)) for t in np.linspace(0, 2 * math.pi, 48, endpoint=False)]


def on_polygon_boundary(points, v, tol=1e-9):
    v = np.asarray(v, dtype=float)
    a, b = v, np.roll(v, -1, axis=0)
    ab = b - a
    t = np.clip(((points[:, None] - a[None]) * ab[None]).sum(-1) / (ab * ab).sum(1)[None], 0, 1)
    d = points[:, None] - (a[None] + t[..., None] * ab[None])
    return np.sqrt((d * d).sum(-1)).min(axis=1) <= tol


@pytest.mark.parametrize("name,verts", [("square", SQUARE), ("L", L_SHAPE), ("star", STAR), ("comb", COMB),
                                        ("circle", CIRCLE)])
def test_polygon_vertices_only(name, verts):
    m = M.polygon(verts)
    assert m.triangle_count == len(verts) - 2
    assert m.point_count == len(verts)
    check_valid(m, euler=1)
    assert m.area == pytest.approx(shoelace(verts), rel=1e-12)


@pytest.mark.parametrize("name,verts,h,min_deg", [
    ("square", SQUARE, 0.1, 30.0), ("L", L_SHAPE, 0.1, 30.0), ("star", STAR, 0.05, 20.0),
    ("comb", COMB, 0.2, 25.0), ("circle", CIRCLE, 0.1, 20.0)])
def test_polygon_with_h(name, verts, h, min_deg):
    m = M.polygon(verts, h)
    check_valid(m, euler=1)
    assert m.area == pytest.approx(shoelace(verts), rel=1e-12)
    assert min_angle_deg(m) > min_deg
    # the mesh boundary is the polygon outline; every input vertex is a node
    assert np.all(on_polygon_boundary(m.points[m.boundary_nodes()], verts))
    for v in verts:
        assert np.min(np.hypot(*(m.points - v).T)) <= 1e-12
    interior = np.setdiff1d(np.arange(m.point_count), m.boundary_nodes())
    assert not np.any(on_polygon_boundary(m.points[interior], verts, tol=0.5 * h))
    assert m.mean_edge_length() == pytest.approx(h, rel=0.3)


def test_polygon_orientation_and_closing_vertex():
    cw = SQUARE[::-1]
    a, b = M.polygon(cw, 0.25), M.polygon(SQUARE, 0.25)
    check_valid(a, euler=1)
    assert a.area == pytest.approx(1.0, rel=1e-12) and a.triangle_count == b.triangle_count
    closed = M.polygon(L_SHAPE + [L_SHAPE[0]])
    assert closed.point_count == len(L_SHAPE) and closed.area == pytest.approx(3.0, rel=1e-12)


def test_polygon_collinear_vertices_and_thin_features():
    verts = [(0, 0), (0.5, 0), (1, 0), (1, 0.5), (1, 1), (0, 1)]  # collinear vertices kept as nodes
    m = M.polygon(verts)
    check_valid(m, euler=1)
    assert m.triangle_count == 4 and m.area == pytest.approx(1.0)
    thin = M.polygon([(0, 0), (10, 0), (10, 0.05), (0, 0.05)], 0.2)  # narrower than h
    check_valid(thin, euler=1)
    assert thin.area == pytest.approx(0.5, rel=1e-12)


def test_polygon_random_star_shaped_robustness():
    rng = np.random.default_rng(7)
    for trial in range(25):
        k = int(rng.integers(5, 30))
        theta = np.sort(rng.uniform(0, 2 * np.pi, k))
        if np.min(np.diff(np.r_[theta, theta[0] + 2 * np.pi])) < 1e-3:
            continue
        r = rng.uniform(0.3, 1.0, k)
        scale, offset = 10.0 ** rng.uniform(-3, 2), rng.uniform(-100, 100, 2)
        verts = np.stack([r * np.cos(theta), r * np.sin(theta)], axis=1) * scale + offset * scale
        m = M.polygon(verts, 0.08 * scale)
        check_valid(m, euler=1)
        assert m.area == pytest.approx(shoelace(verts), rel=1e-9)


@pytest.mark.parametrize("verts,match", [
    ([(0, 0), (1, 1), (1, 0), (0, 1)], "not simple"),          # bow-tie
    ([(0, 0), (2, 0), (2, 2), (1, -1), (0, 2)], "not simple"),  # edge crossing
    ([(0, 0), (1, 0)], "at least 3"),
    ([(0, 0), (1, 0), (2, 0)], "zero area"),
    ([(0, 0), (1, 0), (1, 0), (0, 1)], "coincide"),
    ([(0, 0), (1, 0), (float("nan"), 1)], "vertex 2"),
    ([(0, 0), (2, 0), (2, 1), (1, 0), (0, 1)], "not simple"),   # vertex touching an edge
    ([(0, 0), (2, 0), (1, 0), (1, 1)], "not simple"),           # spike folding back
])
def test_polygon_invalid(verts, match):
    with pytest.raises(ValueError, match=match):
        M.polygon(verts)


@pytest.mark.parametrize("h", [0.0, -0.1, float("nan")])
def test_polygon_bad_h(h):
    with pytest.raises(ValueError, match="h"):
        M.polygon(SQUARE, h)


def test_polygon_larger_mesh():
    m = M.polygon(COMB, 0.05)
    assert m.triangle_count > 5000
    check_valid(m, euler=1)
    assert m.area == pytest.approx(shoelace(COMB), rel=1e-12)


# --------------------------------------------------------------------------- TriMesh validation
PTS = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]


def test_clockwise_triangles_are_reoriented():
    m = TriMesh(PTS, [[0, 2, 1], [0, 3, 2]])  # both clockwise
    assert np.all(signed_areas(m) > 0)
    assert sorted(map(sorted, m.triangles.tolist())) == [[0, 1, 2], [0, 2, 3]]
    np.testing.assert_allclose(m.areas, [0.5, 0.5])
    assert m.area == pytest.approx(1.0)


def test_arrays_are_copied_and_read_only():
    p = np.array(PTS)
    t = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int64)
    m = TriMesh(p, t)
    assert not m.points.flags.writeable and not m.triangles.flags.writeable and not m.areas.flags.writeable
    assert m.points.flags.c_contiguous and m.triangles.dtype == np.int32
    p[0, 0] = 99.0
    assert m.points[0, 0] == 0.0
    with pytest.raises(ValueError):
        m.points[0, 0] = 1.0
    with pytest.raises(Exception):
        m.points = p  # frozen
    assert TriMesh(PTS, np.array([[0.0, 1.0, 2.0]])).triangle_count == 1  # integral floats accepted


def test_zero_area_triangle_is_named():
    pts = PTS + [(2.0, 0.0)]
    with pytest.raises(ValueError, match=r"triangle 2 has zero area \(nodes 0, 1, 4\)"):
        TriMesh(pts, [[0, 1, 2], [0, 2, 3], [0, 1, 4]])
    with pytest.raises(ValueError, match="triangle 0 has zero area"):  # near-zero area
        TriMesh([(0, 0), (1, 0), (0.5, 1e-14)], [[0, 1, 2]])


@pytest.mark.parametrize("pts,tri,match", [
    ([(0, 0), (1, float("nan")), (0, 1)], [[0, 1, 2]], "point 1 has a non-finite"),
    ([(0, 0), (1, 0), (0, float("inf"))], [[0, 1, 2]], "point 2"),
    (PTS, [[0, 1, 2], [0, 2, 4]], "triangle 1 has node indices"),
    (PTS, [[0, 1, 2], [-1, 2, 3]], "triangle 1 has node indices"),
    (PTS, [[0, 1, 2], [0, 2, 2]], "triangle 1 repeats a node"),
    (PTS, [[0, 1, 2], [0, 1, 2]], "triangles 0 and 1 .*overlap"),
    ([(0, 0), (1, 0), (0, 1), (0.2, 0.2)], [[0, 1, 2], [0, 1, 3]], "overlap"),
    (PTS, [[0, 1]], r"shape \(m, 3\)"),
    ([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [[0, 1, 2]], r"shape \(n, 2\)"),
    (np.zeros((0, 2)), np.zeros((0, 3), dtype=int), "empty"),
    (PTS, np.zeros((0, 3), dtype=int), "empty"),
    (PTS, [[0, 1, 2.5]], "non-integer"),
    (PTS, [[True, False, True]], "integer"),
])
def test_invalid_meshes(pts, tri, match):
    with pytest.raises(ValueError, match=match):
        TriMesh(pts, tri)


# --------------------------------------------------------------------------- measures, topology
def test_single_triangle_measures():
    m = TriMesh([(0, 0), (4, 0), (0, 3)], [[0, 1, 2]])
    assert m.area == pytest.approx(6.0)
    assert m.min_altitude() == pytest.approx(12.0 / 5.0)
    assert m.mean_edge_length() == pytest.approx(4.0)
    np.testing.assert_allclose(m.centroid, [4 / 3, 1.0])
    assert m.edges().tolist() == [[0, 1], [0, 2], [1, 2]]
    assert m.boundary_edges().tolist() == [[0, 1], [1, 2], [2, 0]]
    assert m.boundary_nodes().tolist() == [0, 1, 2]
    assert m.min_angle() == pytest.approx(math.atan2(3, 4))
    assert m.bounding_box() == (0.0, 0.0, 4.0, 3.0)
    assert "1 triangles" in repr(m)


def test_boundary_of_square_with_centre_node():
    pts = PTS + [(0.5, 0.5)]
    m = TriMesh(pts, [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    assert sorted(m.boundary_edges().tolist()) == [[0, 1], [1, 2], [2, 3], [3, 0]]
    assert m.boundary_nodes().tolist() == [0, 1, 2, 3]
    assert len(m.edges()) == 8
    assert m.min_altitude() == pytest.approx(0.5)  # 2 * 0.25 / longest edge 1


def test_transforms_preserve_areas():
    m = M.disk(1.0, 0.2)
    t = m.translated((3.0, -2.0))
    np.testing.assert_allclose(t.areas, m.areas, rtol=1e-12)
    np.testing.assert_allclose(t.centroid, m.centroid + [3.0, -2.0], atol=1e-12)
    assert np.array_equal(t.triangles, m.triangles)
    r = t.rotated(0.7)
    np.testing.assert_allclose(r.areas, m.areas, rtol=1e-12)
    np.testing.assert_allclose(r.centroid, t.centroid, atol=1e-12)  # about the centroid by default
    q = TriMesh([(1, 0), (2, 0), (1, 1)], [[0, 1, 2]]).rotated(math.pi / 2, about=(0, 0))
    np.testing.assert_allclose(q.points, [(0, 1), (0, 2), (-1, 1)], atol=1e-15)
    s = m.scaled(2.0)
    np.testing.assert_allclose(s.areas, 4 * m.areas, rtol=1e-12)
    np.testing.assert_allclose(s.points, 2 * m.points)
    s2 = m.scaled((2.0, 0.5), about=(1.0, 0.0))
    assert s2.area == pytest.approx(m.area)
    with pytest.raises(ValueError):
        m.scaled(-1.0)
    with pytest.raises(ValueError):
        m.translated((1.0, 2.0, 3.0))
    with pytest.raises(ValueError):
        m.rotated(float("nan"))


def test_compact_and_merge():
    m = TriMesh([(9, 9), (0, 0), (8, 8), (1, 0), (0, 1)], [[1, 3, 4]])
    c = m.compact()
    assert c.point_count == 3 and c.triangles.tolist() == [[0, 1, 2]]
    np.testing.assert_array_equal(c.points, [(0, 0), (1, 0), (0, 1)])
    assert c.compact() is c
    d = M.disk(0.05, 0.02)
    tiles = M.merge([d.translated((0.1 * i, 0.0)) for i in range(4)])
    assert tiles.point_count == 4 * d.point_count and tiles.triangle_count == 4 * d.triangle_count
    assert tiles.area == pytest.approx(4 * d.area)
    check_valid(tiles, euler=4)
    with pytest.raises(ValueError):
        M.merge([])


# --------------------------------------------------------------------------- load
def _gmsh_cell_data(n):
    return {"gmsh:physical": [np.ones(n, dtype=int)], "gmsh:geometrical": [np.ones(n, dtype=int)]}


@pytest.mark.parametrize("fmt,suffix", [("gmsh22", ".msh"), ("gmsh", ".msh"), ("vtu", ".vtu")])
def test_load_roundtrip(tmp_path, fmt, suffix):
    r = M.rectangle(2.0, 1.0, 0.25, origin=(1.0, 1.0))
    pts3 = np.c_[r.points, np.zeros(r.point_count)]
    cell_data = _gmsh_cell_data(r.triangle_count) if fmt.startswith("gmsh") else {}
    path = tmp_path / f"rect{suffix}"
    meshio.write(path, meshio.Mesh(pts3, [("triangle", r.triangles)], cell_data=cell_data), file_format=fmt)
    m = M.load(path)
    np.testing.assert_allclose(m.points, r.points, atol=1e-15)
    assert np.array_equal(m.triangles, r.triangles)
    assert m.area == pytest.approx(2.0)


def test_load_reorients_drops_unused_and_planar_z(tmp_path):
    r = M.rectangle(1.0, 1.0, 0.5)
    extra = np.array([[7.0, 7.0]])
    pts3 = np.c_[np.vstack([extra, r.points]), np.full(r.point_count + 1, 2.5)]  # plane z = 2.5
    # gmsh readers merge consecutive blocks of one type: keep the two triangle blocks apart
    cells = [("triangle", r.triangles[:4, ::-1] + 1), ("vertex", np.array([[0]])), ("line", np.array([[1, 2]])),
             ("triangle", r.triangles[4:] + 1)]
    path = tmp_path / "mixed.msh"
    meshio.write(path, meshio.Mesh(pts3, cells, cell_data={
        "gmsh:physical": [np.ones(len(c[1]), dtype=int) for c in cells],
        "gmsh:geometrical": [np.ones(len(c[1]), dtype=int) for c in cells]}), file_format="gmsh22")
    m = M.load(path)
    assert m.point_count == r.point_count and m.triangle_count == r.triangle_count
    assert np.all(signed_areas(m) > 0)
    assert m.area == pytest.approx(1.0)
    only_second = M.load(path, cell_block=3)
    assert only_second.triangle_count == r.triangle_count - 4
    with pytest.raises(ValueError, match="block 1 .* holds 'vertex' cells"):
        M.load(path, cell_block=1)
    with pytest.raises(ValueError, match="not a valid block index"):
        M.load(path, cell_block=9)


@pytest.mark.parametrize("kind,match", [
    ("3d", "3D mesh"), ("tetra", "3D mesh"), ("triangle6", "triangle6"), ("quad", "'quad' cells"),
    ("lines", "no triangle cells"), ("degenerate", "zero area")])
def test_load_refuses(tmp_path, kind, match):
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0, 0], [1, 0.5, 0]], dtype=float)
    cells = {
        "3d": [("triangle", np.array([[0, 1, 2]]))],
        "tetra": [("tetra", np.array([[0, 1, 2, 3]]))],
        "triangle6": [("triangle6", np.array([[0, 1, 2, 4, 5, 3]]))],
        "quad": [("triangle", np.array([[0, 1, 2]])), ("quad", np.array([[0, 1, 2, 3]]))],
        "lines": [("line", np.array([[0, 1], [1, 2]]))],
        "degenerate": [("triangle", np.array([[0, 4, 1]]))],
    }[kind]
    if kind == "3d":
        pts[2, 2] = 0.5
    path = tmp_path / f"{kind}.vtu"
    meshio.write(path, meshio.Mesh(pts, cells))
    with pytest.raises(ValueError, match=match) as info:
        M.load(path)
    assert path.name in str(info.value)  # the message names the file


def test_load_triangle6_gmsh(tmp_path):
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, 0, 0], [0.5, 0.5, 0], [0, 0.5, 0]], dtype=float)
    path = tmp_path / "quadratic.msh"
    meshio.write(path, meshio.Mesh(pts, [("triangle6", np.array([[0, 1, 2, 3, 4, 5]]))],
                                   cell_data=_gmsh_cell_data(1)), file_format="gmsh22")
    with pytest.raises(ValueError, match="quadratic.msh.*triangle6"):
        M.load(path)


def test_load_unreadable(tmp_path):
    path = tmp_path / "junk.msh"
    path.write_text("this is not a mesh\n")
    with pytest.raises(ValueError, match="junk.msh"):
        M.load(path)


@pytest.mark.parametrize("ratio", [0.5, 1.0, 2.5, 7.3, 10.0, 33.0])
def test_disk_symmetric_layout_is_mirror_exact(ratio):
    m = M.disk(1.0, 1.0 / ratio)
    check_valid(m, euler=1)
    local = m.points
    # every node's mirror images about both axes through the centre are nodes, bit for bit
    keys = {tuple(p) for p in local.tolist()}
    for sx, sy in ((-1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)):
        assert {tuple(p) for p in (local * (sx, sy)).tolist()} == keys
    # and so are the triangles (as sets of node positions)
    tris = {frozenset(map(tuple, local[t].tolist())) for t in m.triangles}
    mirrored = {frozenset(map(tuple, (local[t] * (-1.0, 1.0)).tolist())) for t in m.triangles}
    assert tris == mirrored
    # nodes on both axes at every ring: the lowest node lies on the vertical axis
    low = local[np.argmin(local[:, 1])]
    assert low[0] == 0.0 and low[1] == -1.0
    c = np.array([0.7, -2.5])
    moved = M.disk(1.0, 1.0 / ratio, center=c)
    np.testing.assert_allclose(moved.points, m.points + c, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(moved.triangles, m.triangles)


def test_disk_layouts_quality_and_errors():
    for ratio in np.linspace(0.5, 100.0, 40):
        for layout in ("symmetric", "spiral"):
            m = M.disk(1.0, 1.0 / ratio, layout=layout)
            assert min_angle_deg(m) > (37.0 if layout == "symmetric" else 35.0), (ratio, layout)
    assert M.disk(0.05, 0.02, layout="spiral").point_count == 25
    for bad in ("golden", None, 1):
        with pytest.raises(ValueError, match="layout"):
            M.disk(1.0, 0.1, layout=bad)
        with pytest.raises(ValueError, match="layout"):
            M.annulus(0.5, 1.0, 0.1, layout=bad)

"""Embedded lines (issue #11): mesh.Segments / mesh.Polyline, select_edges, TriMesh.interior_edges,
and polygon(..., lines=[...]) with the built-in and the gmsh engines.

The central check: for every embedded line, the mesh edges that ``select_edges`` picks have a
total length equal to the line's length (rel 1e-9), so the mesh edges follow the line exactly.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem import mesh as M
from taichi_fdem.mesh import Polyline, Segments, TriMesh

SQUARE = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]


def check_valid(m: TriMesh):
    p = m.points[m.triangles]
    twice = ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))
    assert np.all(twice > 0)
    v, e, f = m.point_count, len(m.edges()), m.triangle_count
    assert v - e + f == 1                                   # one simply connected body


def followed(m: TriMesh, line: Segments) -> float:
    """Total length [m] of the mesh edges lying along ``line``."""
    e = m.edges()
    return float(m.edge_lengths(e[line.select_edges(m.points, e)]).sum())


def check_lines(m: TriMesh, lines, area):
    check_valid(m)
    assert m.area == pytest.approx(area, rel=1e-12)
    for ln in lines:
        ln = ln if isinstance(ln, Segments) else Polyline(ln)
        assert followed(m, ln) == pytest.approx(ln.length, rel=1e-9)


def dfn(seed: int, count: int = 8):
    """``count`` random segments in the unit square, clipped to it (Liang-Barsky): some end
    on the boundary, some inside; they cross each other."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        c, th, length = rng.uniform(0, 1, 2), rng.uniform(0, math.pi), rng.uniform(0.5, 1.2)
        d = length * np.array([math.cos(th), math.sin(th)])
        p = c - 0.5 * d
        t0, t1 = 0.0, 1.0
        for k in range(2):
            for bound in (0.0, 1.0):
                if d[k] != 0.0:
                    t = (bound - p[k]) / d[k]
                    if (bound == 1.0) == (d[k] > 0):
                        t1 = min(t1, t)
                    else:
                        t0 = max(t0, t)
        out.append(Polyline([p + t0 * d, p + t1 * d], name=f"f{len(out)}"))
    return out


# --------------------------------------------------------------------------- Segments / Polyline
def test_segments_and_polyline_basics():
    s = Segments([[[0, 0], [3, 4]], [[1, 1], [1, 2]]], name="joints")
    assert len(s) == 2 and s.length == pytest.approx(6.0) and s.name == "joints"
    np.testing.assert_allclose(s.lengths, [5.0, 1.0])
    assert "2 segments" in repr(s) and "joints" in repr(s)
    with pytest.raises(ValueError):
        s.segments[0, 0, 0] = 9.0                            # read-only
    one = Segments([[0, 0], [1, 0]])                         # a single (2, 2) segment
    assert len(one) == 1 and one.name is None
    p = Polyline([(0, 0), (1, 0), (1, 1)])
    assert len(p) == 2 and p.length == pytest.approx(2.0) and not p.closed
    assert isinstance(p, Segments) and p.points.shape == (3, 2)
    c = Polyline([(0, 0), (1, 0), (1, 1), (0, 0)], closed=True)   # repeated closing point dropped
    assert len(c) == 3 and c.length == pytest.approx(2.0 + math.sqrt(2.0)) and c.closed
    assert fdem.mesh.Polyline is Polyline and fdem.mesh.Segments is Segments
    import pickle
    for obj in (s, c):
        back = pickle.loads(pickle.dumps(obj))
        assert type(back) is type(obj) and back.name == obj.name and len(back) == len(obj)
        np.testing.assert_array_equal(back.segments, obj.segments)
        assert not back.segments.flags.writeable
    assert pickle.loads(pickle.dumps(c)).closed


@pytest.mark.parametrize("make, match", [
    (lambda: Segments(np.zeros((0, 2, 2))), "no segments"),
    (lambda: Segments(np.zeros((3, 2))), r"shape \(k, 2, 2\)"),
    (lambda: Segments([[[0, 0], [1, 0]], [[2, 2], [2, 2]]]), "segment 1 has zero length"),
    (lambda: Segments([[[0, 0], [1, 0]], [[0, 0], [np.nan, 1]]]), "segment 1 has a non-finite"),
    (lambda: Polyline([(0, 0)]), "at least 2 points"),
    (lambda: Polyline([(0, 0), (1, 0)], closed=True), "at least 3 points"),
    (lambda: Polyline([(0, 0), (1, 0), (1, 0), (2, 0)]), "points 1 and 2 coincide"),
    (lambda: Polyline([(0, 0), (np.inf, 0)]), "point 1 is not finite"),
    (lambda: Segments([[0, 0], [1, 0]], name=3), "name must be a str"),
])
def test_segments_invalid(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def _select_reference(segs, points, edges, tol):
    """Brute force: loop over edges and segments."""
    out = []
    for i, j in edges:
        hit = False
        for a, b in segs:
            d = b - a
            ln = math.hypot(*d)
            u = d / ln
            ok = True
            for q in (points[i], points[j]):
                r = q - a
                along, across = r @ u, r[0] * u[1] - r[1] * u[0]
                ok &= abs(across) <= tol and -tol <= along <= ln + tol
            hit |= ok
        out.append(hit)
    return np.array(out)


def test_select_edges_matches_brute_force():
    m = M.rectangle(1.0, 1.0, 0.125, origin=(0, 0))
    segs = Segments([[[0.0, 0.0], [1.0, 1.0]],          # cells (i, i) are not flipped: diagonal edges
                     [[0.0, 0.5], [0.5, 0.5]],          # half a grid line
                     [[0.25, 0.0], [0.25, 1.0]],        # a full grid line
                     [[0.1, 0.1], [0.9, 0.3]]])         # crosses edges, follows none
    e = m.edges()
    sel = segs.select_edges(m.points, e)
    ref = _select_reference(segs.segments, m.points, e, 1e-6 * math.sqrt(2.0))
    np.testing.assert_array_equal(sel, ref)
    lengths = m.edge_lengths(e[sel])
    # grid lines 0.5 + 1.0, and the whole diagonal x = y
    assert float(lengths.sum()) == pytest.approx(1.5 + math.sqrt(2.0), rel=1e-12)
    # a line in the plane of no edges selects nothing; the tolerance is respected
    assert not Segments([[0.06, 0.0], [0.06, 1.0]]).select_edges(m.points, e).any()
    assert Segments([[0.2501, 0.0], [0.2501, 1.0]]).select_edges(m.points, e, tol=2e-4).sum() == 8
    # chunking: many segments at once give the same answer
    many = Segments(np.repeat(segs.segments, 300, axis=0))
    np.testing.assert_array_equal(many.select_edges(m.points, e), sel)


def test_select_edges_bad_input():
    s = Segments([[0, 0], [1, 0]])
    with pytest.raises(ValueError, match="out of range"):
        s.select_edges([(0, 0), (1, 0)], [[0, 2]])
    with pytest.raises(ValueError, match="integer array"):
        s.select_edges([(0, 0), (1, 0)], [[0.0, 1.0]])
    with pytest.raises(ValueError, match="tol"):
        s.select_edges([(0, 0), (1, 0)], [[0, 1]], tol=-1.0)
    assert s.select_edges([(0, 0), (1, 0)], np.zeros((0, 2), dtype=int)).shape == (0,)


# --------------------------------------------------------------------------- TriMesh edges
@pytest.mark.parametrize("mesh", [M.rectangle(1.0, 0.5, 0.1, pattern="crossed"), M.disk(1.0, 0.3)],
                         ids=["crossed", "disk"])
def test_interior_edges_brute_force(mesh):
    edges, tris = mesh.interior_edges()
    owners = {}
    for t, tri in enumerate(mesh.triangles.tolist()):
        for k in range(3):
            owners.setdefault((tri[k], tri[(k + 1) % 3]), []).append(t)
    ref = sorted((min(u, v), max(u, v)) for (u, v) in owners if (v, u) in owners and u < v)
    assert [tuple(e) for e in edges.tolist()] == ref
    for (i, j), (left, right) in zip(edges.tolist(), tris.tolist()):
        assert owners[(i, j)] == [left] and owners[(j, i)] == [right]
    assert len(edges) + len(mesh.boundary_edges()) == len(mesh.edges())
    mid = mesh.edge_midpoints(edges)
    np.testing.assert_allclose(mid, 0.5 * (mesh.points[edges[:, 0]] + mesh.points[edges[:, 1]]))
    assert mesh.edge_lengths().sum() == pytest.approx(mesh.mean_edge_length() * len(mesh.edges()))


# --------------------------------------------------------------------------- polygon with lines
@pytest.mark.parametrize("h", [None, 0.1, 0.037])
def test_square_with_diagonal(h):
    diag = Polyline([(0, 0), (1, 1)], name="fault")
    m = M.polygon(SQUARE, h, lines=[diag])
    check_lines(m, [diag], 1.0)
    # the diagonal cuts the square into two halves: the selected edges are interior edges
    inner, tris = m.interior_edges()
    sel = diag.select_edges(m.points, inner)
    c = m.points[m.triangles].mean(axis=1)
    left, right = c[tris[sel, 0]], c[tris[sel, 1]]
    assert np.all(np.sign(left[:, 1] - left[:, 0]) != np.sign(right[:, 1] - right[:, 0]))
    if h is not None:
        assert math.degrees(m.min_angle()) > 25.0
        assert m.mean_edge_length() == pytest.approx(h, rel=0.3)


def test_crack_tip_inside_and_boundary_node():
    crack = Polyline([(0.0, 0.3), (0.4, 0.55), (0.62, 0.5)])    # starts on the boundary, tip inside
    m = M.polygon(SQUARE, 0.05, lines=[crack])
    check_lines(m, [crack], 1.0)
    assert math.degrees(m.min_angle()) > 20.0
    # the boundary got a node where the crack starts; the tip is a node inside
    for p, on_boundary in (((0.0, 0.3), True), ((0.62, 0.5), False)):
        k = int(np.argmin(np.hypot(*(m.points - p).T)))
        assert np.hypot(*(m.points[k] - p)) <= 1e-15
        assert (k in m.boundary_nodes()) == on_boundary


def test_lines_as_arrays_segments_and_closed_polylines():
    loop = Polyline([(0.3, 0.3), (0.7, 0.3), (0.7, 0.7), (0.3, 0.7)], closed=True)   # an inclusion outline
    cross = np.array([(0.0, 0.5), (1.0, 0.5)])                                        # a plain array
    pair = Segments([[[0.5, 0.0], [0.5, 0.2]], [[0.5, 0.8], [0.5, 1.0]]])
    lines = [loop, cross, pair]
    m = M.polygon(SQUARE, 0.05, lines=lines)
    check_lines(m, lines, 1.0)
    assert math.degrees(m.min_angle()) > 25.0
    # h=None: only the arrangement nodes are triangulated
    coarse = M.polygon(SQUARE, None, lines=lines)
    check_lines(coarse, lines, 1.0)


def test_dfn_crossing_lines():
    lines = dfn(5)
    m = M.polygon(SQUARE, 0.05, lines=lines)
    check_lines(m, lines, 1.0)
    # the fracture network of seed 5: smallest angle between two lines or a line and the
    # boundary 16.47 deg, shortest piece 0.021 m = 0.42 h; the mesh's smallest angle is that
    # input angle (16.47 deg measured): the triangulation adds no worse angle
    assert math.degrees(m.min_angle()) > 16.0
    # every crossing of two lines is a node
    seg = np.array([ln.segments[0] for ln in lines])
    crossings = 0
    for i in range(len(seg)):
        for j in range(i + 1, len(seg)):
            (p, p2), (q, q2) = seg[i], seg[j]
            r, s = p2 - p, q2 - q
            den = r[0] * s[1] - r[1] * s[0]
            t = ((q - p)[0] * s[1] - (q - p)[1] * s[0]) / den
            u = ((q - p)[0] * r[1] - (q - p)[1] * r[0]) / den
            if 0 < t < 1 and 0 < u < 1:
                crossings += 1
                assert np.min(np.hypot(*(m.points - (p + t * r)).T)) < 1e-12
    assert crossings >= 5


@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4, 6, 7])
def test_dfn_robustness(seed):
    lines = dfn(seed)
    for h in (0.1, 0.04):
        check_lines(M.polygon(SQUARE, h, lines=lines), lines, 1.0)


def test_lines_in_a_nonconvex_polygon():
    comb = [(0, 0), (5, 0), (5, 3), (4, 3), (4, 1), (3, 1), (3, 3), (2, 3), (2, 1), (1, 1), (1, 3), (0, 3)]
    lines = [Polyline([(0, 0.5), (5, 0.5)]),                # crosses the whole comb, all five teeth above it
             Polyline([(0.5, 0.5), (0.5, 3.0)]),            # T-junction on the first line, ends on the top
             Polyline([(4, 1), (5, 3)])]                    # from a re-entrant corner to a corner
    m = M.polygon(comb, 0.2, lines=lines)
    check_lines(m, lines, 11.0)
    assert math.degrees(m.min_angle()) > 20.0


@pytest.mark.parametrize("lines, match", [
    ([Polyline([(0.5, 0.5), (1.5, 0.5)], name="f1")], r"line 0 \('f1'\) leaves the polygon: its point \(1.5, 0.5\)"),
    ([Polyline([(0.2, 0.2), (0.5, 0.5)]), Polyline([(0.5, 0.5), (1.2, 0.6), (0.9, 0.9)])],
     r"line 1 leaves the polygon: its point \(1.2, 0.6\)"),
    ([Polyline([(0.2, 0.2), (0.8, 0.8)]), Polyline([(0.5, 0.5), (0.9, 0.9)])], r"line 0 and line 1 overlap"),
    ([Polyline([(0.2, 0.0), (0.8, 0.0)])], r"line 0 runs along the polygon boundary \(edge 0\)"),
    ([[(0, 0)]], r"line 0: Polyline: an open polyline needs at least 2 points"),
    (Polyline([(0.2, 0.2), (0.8, 0.8)]), "wrap a single line in a list"),
])
def test_lines_invalid(lines, match):
    with pytest.raises(ValueError, match=match):
        M.polygon(SQUARE, 0.1, lines=lines)


def test_line_leaving_through_a_notch():
    # both end points inside the U-shaped polygon, the middle crosses the notch (outside)
    u = [(0, 0), (3, 0), (3, 2), (2, 2), (2, 1), (1, 1), (1, 2), (0, 2)]
    with pytest.raises(ValueError, match=r"line 0 leaves the polygon between \(1, 1.5\) and \(2, 1.5\)"):
        M.polygon(u, 0.2, lines=[Polyline([(0.5, 1.5), (2.5, 1.5)])])


def test_polygon_engine_argument():
    with pytest.raises(ValueError, match="unknown engine"):
        M.polygon(SQUARE, 0.1, engine="triangle")
    # without lines the built-in engine gives the same mesh as before lines existed
    a, b = M.polygon(SQUARE, 0.1), M.polygon(SQUARE, 0.1, lines=[])
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.triangles, b.triangles)


# --------------------------------------------------------------------------- gmsh engine (optional)
def _gmsh_or_skip():
    try:
        import gmsh
    except (ImportError, OSError) as exc:      # not installed, or its shared libraries missing
        pytest.skip(f"gmsh not usable here: {exc}")
    return gmsh


def test_gmsh_engine_follows_lines():
    gmsh = _gmsh_or_skip()
    lines = dfn(5) + [Polyline([(0.05, 0.05), (0.3, 0.12)], name="tip")]   # a crack with two tips inside
    m = M.polygon(SQUARE, 0.05, lines=lines, engine="gmsh")
    check_lines(m, lines, 1.0)
    assert not gmsh.isInitialized()                          # finalised after use
    # the smallest angle is the input's (16.47 deg between two lines, as with the built-in engine)
    assert math.degrees(m.min_angle()) > 16.0
    comb = [(0, 0), (5, 0), (5, 3), (4, 3), (4, 1), (3, 1), (3, 3), (2, 3), (2, 1), (1, 1), (1, 3), (0, 3)]
    teeth = [Polyline([(0, 0.5), (5, 0.5)]), Polyline([(0.5, 0.5), (0.5, 3.0)])]
    mc = M.polygon(comb, 0.2, lines=teeth, engine="gmsh")
    check_lines(mc, teeth, 11.0)
    plain = M.polygon(SQUARE, 0.1, engine="gmsh")            # no lines
    check_valid(plain)
    assert plain.area == pytest.approx(1.0, rel=1e-12) and math.degrees(plain.min_angle()) > 30.0


def test_gmsh_engine_keeps_a_session_it_did_not_open():
    gmsh = _gmsh_or_skip()
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("users_model")
        m = M.polygon(SQUARE, 0.2, lines=[Polyline([(0, 0), (1, 1)])], engine="gmsh")
        assert gmsh.isInitialized() and "users_model" in gmsh.model.list()
        assert "taichi_fdem_polygon" not in gmsh.model.list()
    finally:
        gmsh.finalize()
    check_lines(m, [Polyline([(0, 0), (1, 1)])], 1.0)


def test_gmsh_engine_errors():
    with pytest.raises(ValueError, match="needs a target edge length h"):
        M.polygon(SQUARE, None, engine="gmsh")
    # line checks happen before gmsh is called
    with pytest.raises(ValueError, match="leaves the polygon"):
        M.polygon(SQUARE, 0.1, lines=[[(0.5, 0.5), (2.0, 0.5)]], engine="gmsh")


def test_gmsh_engine_missing(monkeypatch):
    import sys
    monkeypatch.setitem(sys.modules, "gmsh", None)           # "import gmsh" raises ImportError
    with pytest.raises(ImportError, match=r'pip install "taichi-fdem\[mesh\]"'):
        M.polygon(SQUARE, 0.1, engine="gmsh")
    # "auto" falls back to the built-in engine when gmsh cannot be imported
    a, b = M.polygon(SQUARE, 0.1, engine="auto"), M.polygon(SQUARE, 0.1)
    np.testing.assert_array_equal(a.triangles, b.triangles)


def test_guide_fracture_lines_example_runs_as_written(capsys):
    """docs/guide/meshes.md "Fracture lines and pre-existing cracks": the example runs as written and the edges it
    selects add up to the fault's length sqrt(2) m."""
    import os
    import re
    readme = open(os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "docs", "guide", "meshes.md")).read()
    sec = readme[readme.index("## Fracture lines and pre-existing cracks"):]
    code = re.search(r"```python\n(.*?)```", sec, re.S).group(1)
    scope: dict = {}
    exec(compile(code, "docs/guide/meshes.md", "exec"), scope)
    out = capsys.readouterr().out
    count, length = re.search(r"(\d+) edges along the fault, ([0-9.]+) m", out).groups()
    assert float(length) == pytest.approx(math.sqrt(2.0), rel=1e-11)
    assert int(count) == int(scope["on_fault"].sum()) > 20
    # the crack's second segment (0.4, 0.55)-(0.62, 0.5) crosses the fault y = x at t = 0.15 / 0.27:
    # the crossing is a node of the mesh
    t = 0.15 / 0.27
    x = np.array([0.4 + 0.22 * t, 0.55 - 0.05 * t])
    assert np.min(np.hypot(*(scope["mesh"].points - x).T)) <= 1e-12


def test_nearly_coincident_points_are_merged():
    # two lines meeting at (0.5, 0.5) up to 1e-12 m, and a line ending 1e-12 m off the boundary
    lines = [Polyline([(0.2, 0.2), (0.5, 0.5)]), Polyline([(0.5 + 1e-12, 0.5), (0.8, 0.3)]),
             Polyline([(0.5, 0.5), (0.5, 1.0 - 1e-12)])]
    m = M.polygon(SQUARE, 0.1, lines=lines)
    check_lines(m, lines, 1.0)
    assert np.sum(np.hypot(*(m.points - (0.5, 0.5)).T) < 1e-9) == 1
    top = np.flatnonzero(np.hypot(*(m.points - (0.5, 1.0)).T) < 1e-9)
    assert len(top) == 1 and top[0] in m.boundary_nodes()

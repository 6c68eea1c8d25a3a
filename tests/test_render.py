"""Golden-image style tests of taichi_fdem.render (rasteriser, colour maps, video output)."""
import os

import imageio.v2 as imageio_v2
import imageio.v3 as iio
import numpy as np
import pytest
import taichi as ti

from taichi_fdem import backend, render

RED = np.array([255, 0, 0], np.uint8)
WHITE = np.array([255, 255, 255], np.uint8)
BLACK = np.array([0, 0, 0], np.uint8)

TRI_X = np.array([[0.1, 0.1], [0.9, 0.1], [0.1, 0.9]])
TRI_T = np.array([[0, 1, 2]])
TRI_C = np.array([[1.0, 0.0, 0.0]])


@pytest.fixture(scope="module", autouse=True)
def _taichi():
    backend.ensure_init()


def _is(img, rgb):
    return np.all(img == np.asarray(rgb, np.uint8), axis=-1)


def _expected_mask(x, w=100, h=100, view=(0.0, 1.0, 0.0, 1.0), tol=0.0):
    """Analytic pixel-centre-inside-triangle mask (float64, inclusive up to tol) for one triangle."""
    xmin, xmax, ymin, ymax = view
    cols = xmin + (np.arange(w) + 0.5) / w * (xmax - xmin)
    rows = ymax - (np.arange(h) + 0.5) / h * (ymax - ymin)
    X, Y = np.meshgrid(cols, rows)
    a, b, c = x
    def edge(p, q):
        return (q[0] - p[0]) * (Y - p[1]) - (q[1] - p[1]) * (X - p[0])
    e = np.stack([edge(a, b), edge(b, c), edge(c, a)])
    return np.all(e >= -tol, axis=0) | np.all(e <= tol, axis=0)


# ---------------------------------------------------------------------------------------------
# rasteriser
# ---------------------------------------------------------------------------------------------
def test_single_triangle_golden():
    r = render.RendererImage(100, 100, view=(0, 1, 0, 1), draw_edges=False)
    img = r.render(TRI_X, TRI_T, TRI_C)
    assert img.shape == (100, 100, 3) and img.dtype == np.uint8
    red = _is(img, RED)
    white = _is(img, WHITE)
    assert np.all(red | white)                       # nothing else without edges/supersampling
    # analytic area 0.32 of the view -> 3200 pixels
    assert abs(red.sum() - 3200) <= 0.02 * 3200
    # exact agreement with the analytic mask except possibly on the diagonal boundary
    mism = red != _expected_mask(TRI_X)
    assert mism.sum() <= 100
    # well inside / well outside; y up: the right angle (0.1, 0.1) is bottom-left
    assert red[85, 15] and red[89, 80] and red[15, 12]
    assert white[10, 15] and white[15, 85] and white[50, 95] and white[95, 50] and white[5, 5]
    # rows of the triangle: 10..89, columns 10..89
    rows = np.nonzero(red.any(axis=1))[0]
    cols = np.nonzero(red.any(axis=0))[0]
    assert rows.min() == 10 and rows.max() == 89 and cols.min() == 10 and cols.max() == 89
    # lower rows are wider (the base is at the bottom)
    assert red[88].sum() > red[11].sum() + 60


def test_y_axis_up():
    r = render.RendererImage(100, 100, view=(0, 1, 0, 1), draw_edges=False)
    x = np.array([[0.2, 0.05], [0.8, 0.05], [0.5, 0.4]])   # lower part of the world
    img = r.render(x, TRI_T, TRI_C)
    red = _is(img, RED)
    rows = np.nonzero(red.any(axis=1))[0]
    assert rows.min() >= 60 and rows.max() == 94
    assert red.sum() == pytest.approx(0.5 * 0.6 * 0.35 * 1e4, rel=0.03)
    # the apex (top) is narrow, the base (bottom) wide
    assert red[rows.max()].sum() > 50 and red[rows.min()].sum() < 5


def test_edges_drawn():
    ec = (0.0, 0.0, 0.0)
    r = render.RendererImage(100, 100, view=(0, 1, 0, 1), edge_color=ec, edge_width=2.0, draw_edges=True)
    img = r.render(TRI_X, TRI_T, TRI_C)
    black, red = _is(img, BLACK), _is(img, RED)
    # bottom edge y = 0.1 is pixel y = 90: row 89 (centre 0.5 px from it) is edge, row 87 fill
    assert black[89, 50] and red[87, 50]
    # left edge x = 0.1 is pixel x = 10
    assert black[50, 10] and red[50, 12]
    # hypotenuse: pixel (row 50, col 49) has its centre on x + y = 1
    assert black[50, 49]
    assert red[60, 30]                                 # interior stays fill colour
    # edge pixels lie within 1 px of an edge; their number is about perimeter * width
    mask = _expected_mask(TRI_X, tol=1e-6)
    assert np.all(mask[black])
    perim_px = (0.8 + 0.8 + 0.8 * np.sqrt(2)) * 100
    assert 0.7 * perim_px <= black.sum() <= 1.5 * perim_px
    # draw_edges=False or edge_width=0 -> no edge colour
    r2 = render.RendererImage(100, 100, view=(0, 1, 0, 1), edge_color=ec, edge_width=0.0)
    assert not _is(r2.render(TRI_X, TRI_T, TRI_C), BLACK).any()


def test_fit_view_contains_all_nodes():
    x = np.array([[0, 0], [1, 0], [0, 1], [20, 8], [21, 8], [20, 9]], float)
    t = np.array([[0, 1, 2], [3, 4, 5]])
    c = np.array([[1, 0, 0], [0, 0, 1]], float)
    r = render.RendererImage(160, 90, view="fit", draw_edges=False)
    img = r.render(x, t, c)
    assert _is(img, RED).sum() > 10 and _is(img, (0, 0, 255)).sum() > 10
    xmin, xmax, ymin, ymax = r.last_view
    assert xmin < 0 and xmax > 21 and ymin < 0 and ymax > 9
    # aspect preserved (square pixels)
    assert (xmax - xmin) / (ymax - ymin) == pytest.approx(160 / 90)
    # each triangle's centroid lands on its colour
    cent = np.array([x[:3].mean(0), x[3:].mean(0)])
    pix = np.floor(r.world_to_pixel(cent)).astype(int)
    assert np.all(img[pix[0, 1], pix[0, 0]] == (255, 0, 0))
    assert np.all(img[pix[1, 1], pix[1, 0]] == (0, 0, 255))
    # after the bodies move, the fit view follows
    img2 = r.render(x + np.array([100.0, -50.0]), t, c)
    assert r.last_view[0] > 90 and r.last_view[3] < -30
    np.testing.assert_array_equal(img, img2)


def test_fixed_view_letterbox():
    r = render.RendererImage(200, 100, view=(0, 1, 0, 1), draw_edges=False)
    img = r.render(TRI_X, TRI_T, TRI_C)
    xmin, xmax, ymin, ymax = r.last_view
    assert (ymin, ymax) == (0.0, 1.0) and xmin == pytest.approx(-0.5) and xmax == pytest.approx(1.5)
    red = _is(img, RED)
    assert abs(red.sum() - 0.32 * 100 * 100) <= 0.03 * 3200
    cols = np.nonzero(red.any(axis=0))[0]
    assert cols.min() == 60 and cols.max() == 139


def test_supersample_antialiasing():
    base = render.RendererImage(100, 100, view=(0, 1, 0, 1), draw_edges=False).render(TRI_X, TRI_T, TRI_C)
    r = render.RendererImage(100, 100, view=(0, 1, 0, 1), draw_edges=False, supersample=2)
    img = r.render(TRI_X, TRI_T, TRI_C)
    red, white = _is(img, RED), _is(img, WHITE)
    mixed = ~(red | white)
    assert mixed.sum() > 50                            # intermediate colours on the hypotenuse
    mix_px = img[mixed].astype(int)
    assert np.all(mix_px[:, 0] == 255) and np.all((mix_px[:, 1] > 0) & (mix_px[:, 1] < 255))
    coverage = (255 - img[:, :, 1].astype(float)).sum() / 255.0
    assert coverage == pytest.approx(3200, rel=0.02)
    assert abs(red.sum() + mixed.sum() - _is(base, RED).sum()) < 150
    # with edges, supersampling mixes edge and fill colours too
    r2 = render.RendererImage(100, 100, view=(0, 1, 0, 1), supersample=3, edge_color=(0, 0, 0))
    img2 = r2.render(TRI_X, TRI_T, TRI_C)
    assert np.any((img2[:, :, 0] > 0) & (img2[:, :, 0] < 255) & (img2[:, :, 1] == 0))


def test_numpy_and_ndarray_inputs_identical():
    rng = np.random.default_rng(0)
    # a strip of 2 x 6 quads split into triangles, slightly perturbed
    nx, ny = 7, 3
    gx, gy = np.meshgrid(np.linspace(0, 3, nx), np.linspace(0, 1, ny))
    x = np.stack([gx.ravel(), gy.ravel()], 1) + rng.normal(0, 0.02, (nx * ny, 2))
    tris = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            a, b, c, d = j * nx + i, j * nx + i + 1, (j + 1) * nx + i + 1, (j + 1) * nx + i
            tris += [[a, b, c], [a, c, d]]
    t = np.array(tris, np.int32)
    col = render.colormap(np.arange(len(t)), name="viridis")
    r = render.RendererImage(120, 60, supersample=2)
    img_np = r.render(x, t, col)

    real = backend.real_ti()
    x_nd = ti.ndarray(dtype=ti.types.vector(2, real), shape=(len(x),))
    x_nd.from_numpy(x.astype(backend.real_np()))
    t_nd = ti.ndarray(dtype=ti.types.vector(3, ti.i32), shape=(len(t),))
    t_nd.from_numpy(t)
    c_nd = ti.ndarray(dtype=ti.types.vector(3, ti.f32), shape=(len(t),))
    c_nd.from_numpy(col)
    img_nd = r.render(x_nd, t_nd, c_nd)
    np.testing.assert_array_equal(img_np, img_nd)
    assert len(np.unique(img_np.reshape(-1, 3), axis=0)) > 12

    # mixed inputs, and a second call reuses the internal buffers
    buf = r._img
    np.testing.assert_array_equal(r.render(x_nd, t, col), img_np)
    assert r._img is buf


def test_scene_size_changes_and_degenerate_input():
    r = render.RendererImage(64, 48)
    empty = r.render(np.zeros((0, 2)), np.zeros((0, 3), int), np.zeros((0, 3)))
    assert np.all(empty == 255)
    one = r.render(TRI_X, TRI_T, (0.0, 1.0, 0.0))        # single RGB triple broadcast
    assert _is(one, (0, 255, 0)).sum() > 100
    many_x = np.concatenate([TRI_X, TRI_X + 1.0])
    two = r.render(many_x, np.array([[0, 1, 2], [3, 4, 5]]), None)   # None -> grey
    grey = (two[..., 0] == two[..., 1]) & (two[..., 1] == two[..., 2]) & (np.abs(two[..., 0].astype(int) - 178) <= 1)
    assert grey.sum() > 100
    # a degenerate (zero-area) triangle draws nothing (no crash, no hang, no stray pixels): the
    # picture equals that of the valid triangle drawn alone
    _assert_draws_nothing(np.array([[0, 0], [1, 1], [2, 2]]))


def _assert_draws_nothing(bad_x):
    rr = render.RendererImage(64, 48, view=(-1, 3, -1, 3), draw_edges=False)
    alone = rr.render(TRI_X, TRI_T, TRI_C).copy()
    assert _is(alone, (255, 0, 0)).sum() > 20
    img = rr.render(np.concatenate([TRI_X, bad_x]), np.array([[0, 1, 2], [3, 4, 5]]), TRI_C[[0, 0]])
    assert img.shape == (48, 64, 3)
    np.testing.assert_array_equal(img, alone)


def test_triangle_with_a_nan_node_draws_nothing():
    """A triangle with a non-finite node (a blown-up simulation) must not paint anything."""
    _assert_draws_nothing(np.array([[np.nan, 0.0], [1, 0], [0, 1]]))


def test_argument_validation():
    with pytest.raises(ValueError, match="width"):
        render.RendererImage(width=0)
    with pytest.raises(ValueError, match="height"):
        render.RendererImage(height=10.5)
    with pytest.raises(ValueError, match="supersample"):
        render.RendererImage(supersample=5)
    with pytest.raises(ValueError, match="background"):
        render.RendererImage(background=(1.2, 0, 0))
    with pytest.raises(ValueError, match="edge_color"):
        render.RendererImage(edge_color=(0, 0))
    with pytest.raises(ValueError, match="view"):
        render.RendererImage(view=(0, 0, 0, 1))
    with pytest.raises(ValueError, match="view"):
        render.RendererImage(view="zoom")
    r = render.RendererImage(32, 32)
    with pytest.raises(ValueError, match="view"):
        r.set_view((1, 2, 3))
    r.set_view((0, 1, 0, 1))
    assert r.view == (0.0, 1.0, 0.0, 1.0)
    with pytest.raises(ValueError, match="tri_color"):
        r.render(TRI_X, TRI_T, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="node_x"):
        r.render(np.zeros((3, 3)), TRI_T, TRI_C)


# ---------------------------------------------------------------------------------------------
# colour maps
# ---------------------------------------------------------------------------------------------
def test_colormap_endpoints_and_luminance():
    pos, table = render.COLORMAPS["viridis"]
    c = render.colormap(np.array([-5.0, 0.0, 1.0, 7.0]), vmin=0.0, vmax=1.0)
    assert c.dtype == np.float32 and c.shape == (4, 3)
    np.testing.assert_allclose(c[0], table[0], atol=1e-6)     # clipped below
    np.testing.assert_allclose(c[1], table[0], atol=1e-6)     # vmin -> first colour
    np.testing.assert_allclose(c[2], table[-1], atol=1e-6)    # vmax -> last colour
    np.testing.assert_allclose(c[3], table[-1], atol=1e-6)
    np.testing.assert_allclose(c[1], (0.267004, 0.004874, 0.329415), atol=1e-6)
    np.testing.assert_allclose(c[2], (0.993248, 0.906157, 0.143936), atol=1e-6)
    # default vmin / vmax from the data; viridis luminance increases monotonically
    v = np.linspace(3.0, 4.0, 200)
    cm = render.colormap(v)
    lum = cm @ np.array([0.2126, 0.7152, 0.0722])
    assert np.all(np.diff(lum) > 0)
    assert 16 <= len(table) <= 64
    # NaN -> grey, shapes preserved, other maps
    assert render.colormap(np.array([[0.0, np.nan]]), 0, 1).shape == (1, 2, 3)
    np.testing.assert_allclose(render.colormap([0.5], 0, 1, name="gray")[0], 0.5, atol=1e-6)
    cw = render.colormap([0.0, 1.0], name="coolwarm")
    assert cw[0, 2] > cw[0, 0] and cw[1, 0] > cw[1, 2]
    with pytest.raises(ValueError):
        render.colormap([0.0], name="jet")


def test_body_colors():
    ids = np.array([0, 1, 2, 0, 1, 25])
    c = render.body_colors(ids)
    assert c.shape == (6, 3) and c.dtype == np.float32
    assert np.all((c >= 0) & (c <= 1))
    np.testing.assert_array_equal(c[0], c[3])
    assert not np.allclose(c[0], c[1]) and not np.allclose(c[1], c[2])
    n = len(render.body_colors(np.arange(100)))
    pal = np.unique(render.body_colors(np.arange(100)), axis=0)
    assert n == 100 and len(pal) >= 8                 # distinct palette, cycling


# ---------------------------------------------------------------------------------------------
# images and video
# ---------------------------------------------------------------------------------------------
def _frames(k, w=64, h=48):
    for i in range(k):
        f = np.full((h, w, 3), 255, np.uint8)
        f[:, : (i * 5) % w] = (200, 30, 30)
        f[10:30, 20:40] = (20, 20 * (i % 12), 220)
        yield f


def _mp4_frames(path):
    rd = imageio_v2.get_reader(str(path))
    try:
        return [np.asarray(f) for f in rd]
    finally:
        rd.close()


def test_video_mp4(tmp_path):
    path = tmp_path / "sub" / "out.mp4"
    with render.VideoWriter(path, fps=24) as vw:
        for f in _frames(12):
            vw.append(f)
        assert vw.frame_count == 12
    assert vw.closed
    vw.close()                                        # idempotent
    frames = _mp4_frames(path)
    assert len(frames) == 12 and frames[0].shape == (48, 64, 3)
    ref = list(_frames(12))
    assert np.abs(frames[7].astype(int) - ref[7]).mean() < 12   # lossy but close


def test_video_gif(tmp_path):
    path = tmp_path / "out.gif"
    with render.VideoWriter(path, fps=10) as vw:
        for f in _frames(12):
            vw.append(f)
    arr = iio.imread(path, index=None)
    assert arr.shape[0] == 12 and arr.shape[1:3] == (48, 64)
    ref = list(_frames(12))
    assert np.abs(arr[5][..., :3].astype(int) - ref[5]).mean() < 8
    with open(path, "rb") as fh:
        assert b"NETSCAPE2.0" in fh.read()            # looping gif


def test_video_png_dir_and_extra_png(tmp_path):
    d = tmp_path / "frames"
    with render.VideoWriter(str(d) + "/") as vw:
        for f in _frames(12):
            vw.append(f)
    files = sorted(os.listdir(d))
    assert len(files) == 12 and files[0] == "frame_00000.png" and files[-1] == "frame_00011.png"
    assert iio.imread(d / "frame_00003.png").shape == (48, 64, 3)
    np.testing.assert_array_equal(iio.imread(d / "frame_00003.png"), list(_frames(12))[3])
    # no suffix -> directory; png_dir copies the frames of a movie
    extra = tmp_path / "extra"
    with render.VideoWriter(tmp_path / "movie.mp4", png_dir=extra) as vw:
        for f in _frames(3):
            vw.append(f)
    assert sorted(os.listdir(extra)) == ["frame_00000.png", "frame_00001.png", "frame_00002.png"]
    with render.VideoWriter(tmp_path / "seq") as vw:
        vw.append(next(_frames(1)))
    assert os.listdir(tmp_path / "seq") == ["frame_00000.png"]


@pytest.mark.parametrize("exc", [RuntimeError, KeyboardInterrupt])
def test_video_interrupted_is_valid(tmp_path, exc):
    path = tmp_path / "crash.mp4"
    with pytest.raises(exc):
        with render.VideoWriter(path, fps=30) as vw:
            for i, f in enumerate(_frames(12)):
                if i == 5:
                    raise exc("simulated crash")
                vw.append(f)
    assert vw.closed and vw.frame_count == 5
    frames = _mp4_frames(path)
    assert len(frames) == 5 and frames[0].shape == (48, 64, 3)


def test_video_odd_size_and_errors(tmp_path):
    path = tmp_path / "odd.mp4"
    with render.VideoWriter(path) as vw:
        for f in _frames(4, w=65, h=47):
            vw.append(f)
        with pytest.raises(ValueError, match="size"):
            vw.append(np.zeros((48, 64, 3), np.uint8))
    frames = _mp4_frames(path)
    assert len(frames) == 4 and frames[0].shape == (48, 66, 3)   # padded to even size
    with pytest.raises(RuntimeError):
        vw.append(next(_frames(1, w=65, h=47)))
    with pytest.raises(ValueError, match="unsupported"):
        render.VideoWriter(tmp_path / "x.avi")
    with pytest.raises(ValueError, match="fps"):
        render.VideoWriter(tmp_path / "x.mp4", fps=0)


def test_save_png_and_annotate(tmp_path):
    img = render.RendererImage(80, 60, view=(0, 1, 0, 1)).render(TRI_X, TRI_T, TRI_C)
    p = tmp_path / "a" / "b.png"
    render.save_png(p, img)
    np.testing.assert_array_equal(iio.imread(p), img)
    render.save_png(tmp_path / "f.png", img.astype(np.float32) / 255.0)
    np.testing.assert_array_equal(iio.imread(tmp_path / "f.png"), img)
    ann = render.annotate(img, "t = 1.25 s  step 100", size=12)
    assert ann.shape == img.shape and ann.dtype == np.uint8
    changed = np.any(ann != img, axis=-1)
    assert changed[:20, :60].sum() > 20               # text at the top left
    assert not changed[30:, :].any()                   # nothing elsewhere


def test_no_recompilation_for_new_sizes():
    """ndarray kernels compile once per dtype, whatever the scene or image size."""
    kernels = [render._raster_kernel, render._to_pixels_kernel, render._bbox_kernel,
               render._clear_kernel, render._resolve_kernel, render._raster_u8_kernel, render._clear_u8_kernel]
    if not all(hasattr(getattr(k, "_primal", None), "compiled_kernels") for k in kernels):
        pytest.skip("Taichi internals changed")
    rng = np.random.default_rng(1)

    def scene(n, w, h, s):
        x = rng.random((3 * n, 2))
        t = np.arange(3 * n).reshape(n, 3)
        render.RendererImage(w, h, supersample=s).render(x, t, render.body_colors(np.arange(n)))

    scene(2, 20, 20, 2)  # warm-up: compiles for the current precision if not done yet
    before = [len(k._primal.compiled_kernels) for k in kernels]
    for n, (w, h, s) in zip((1, 7, 40), ((40, 30, 1), (90, 50, 2), (33, 71, 3))):
        scene(n, w, h, s)
    after = [len(k._primal.compiled_kernels) for k in kernels]
    assert after == before


# ---------------------------------------------------------------------------------------------
# render_sim: colour modes, colour bar, stamp, camera, video of a run
# ---------------------------------------------------------------------------------------------
import math  # noqa: E402

import taichi_fdem as fdem  # noqa: E402
from conftest import build_quiet, one_triangle  # noqa: E402

ROCK = dict(density=2700.0, young=1e8, poisson=0.25)


def _two_triangles_sim(v_a=(1.0, 0.0), v_b=(0.0, -3.0)):
    """Two separate single-triangle bodies (A at the left, B at the right), no gravity."""
    mat = fdem.Material(**ROCK)
    sc = fdem.Scene(gravity=(0.0, 0.0))
    a = sc.add_body(one_triangle([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), mat, name="A")
    b = sc.add_body(one_triangle([[2.0, 0.0], [3.0, 0.0], [2.0, 1.0]]), mat, name="B")
    sim = build_quiet(sc)
    sim.set_node_velocities(np.tile(v_a, (3, 1)), a)
    sim.set_node_velocities(np.tile(v_b, (3, 1)), b)
    return sim, a, b


def _pixel_at(r, img, xy):
    col, row = r.world_to_pixel(np.asarray(xy, float))[0]
    return img[int(row), int(col)]


def _close(rgb8, rgbf, tol=1):
    return np.abs(rgb8.astype(int) - np.round(np.asarray(rgbf) * 255).astype(int)).max() <= tol


def test_render_sim_speed_extremes_map_to_colormap_ends():
    sim, a, b = _two_triangles_sim()
    r = render.RendererImage(200, 100, color_by="speed", vmin=1.0, vmax=3.0, draw_edges=False, stamp=False)
    img = r.render_sim(sim)
    assert np.allclose(r.last_scalars, [1.0, 3.0]) and r.last_range == (1.0, 3.0)
    cen_a, cen_b = sim.node_positions(a).mean(0), sim.node_positions(b).mean(0)
    first, last = render.colormap(np.array([0.0, 1.0]), 0.0, 1.0)
    assert _close(_pixel_at(r, img, cen_a), first)
    assert _close(_pixel_at(r, img, cen_b), last)
    # a value in between maps to the matching interior colour; out-of-range values are clipped
    r.set_range(0.0, 4.0)
    img = r.render_sim(sim)
    assert _close(_pixel_at(r, img, cen_a), render.colormap(np.array([1.0]), 0.0, 4.0)[0])
    r.set_range(5.0, 6.0)
    img = r.render_sim(sim)
    assert _close(_pixel_at(r, img, cen_a), first) and _close(_pixel_at(r, img, cen_b), first)
    # automatic range: the current min / max
    r.set_range(None, None)
    img = r.render_sim(sim)
    assert r.last_range == pytest.approx((1.0, 3.0))
    assert _close(_pixel_at(r, img, cen_a), first) and _close(_pixel_at(r, img, cen_b), last)
    # the per-call override and the categorical modes
    img = r.render_sim(sim, color_by="body")
    assert _close(_pixel_at(r, img, cen_a), render.body_colors([0])[0])
    assert _close(_pixel_at(r, img, cen_b), render.body_colors([1])[0])
    img = r.render_sim(sim, color_by="material")   # one shared material
    assert _close(_pixel_at(r, img, cen_b), render.body_colors([0])[0])


def _hooke_finite(E, nu, plane, e):
    """Hand computation of the Cauchy stress (σxx, σyy) of docs/theory/elements.md §3.2 for the uniaxial stretch
    F = diag(1 + e, 1), from E and ν only: μ = E/(2(1+ν)), λ_Y = half the plane problem's Lamé λ."""
    mu = E / (2.0 * (1.0 + nu))
    lam_y = E * nu / (2.0 * (1.0 - nu * nu)) if plane == "stress" else E * nu / (2.0 * (1.0 + nu) * (1.0 - 2.0 * nu))
    J = 1.0 + e
    return mu / J * ((1.0 + e) ** 2 - 1.0) + lam_y * (J - 1.0 / J), lam_y * (J - 1.0 / J)


def _stretched(plane, e):
    mat = fdem.Material(**ROCK)
    sc = fdem.Scene(gravity=(0.0, 0.0), plane=plane)
    sc.add_body(fdem.mesh.rectangle(1.0, 0.5, h=0.1), mat)
    sim = sc.build()
    X = sim.node_positions()
    sim.state.node_x.from_numpy(X * np.array([1.0 + e, 1.0]))
    return sim, mat, X


def test_tri_scalars_uniaxial_stretch_analytic():
    """Plane stress, affine uniaxial stretch x' = (1 + e) x: the kernel's von Mises and principal
    stresses equal the values computed by hand from E and ν (docs/theory/elements.md §3.2); σ_zz = 0 in plane
    stress, so von Mises = √(σxx² − σxx σyy + σyy²)."""
    e = 0.01
    sim, mat, X = _stretched("stress", e)
    v = np.zeros_like(X)
    v[:, 1] = 0.5
    sim.set_node_velocities(v)
    r = render.RendererImage(64, 64)
    sxx, syy = _hooke_finite(mat.young, mat.poisson, "stress", e)
    vm_exact = math.sqrt(sxx * sxx - sxx * syy + syy * syy)
    vm = r.tri_scalars(sim, "von_mises")
    assert vm.shape == (sim.model.tri_count,)
    assert np.allclose(vm, vm_exact, rtol=1e-9)
    T = sim.stresses()
    assert np.allclose(T[:, 0, 0], sxx, rtol=1e-9) and np.allclose(T[:, 1, 1], syy, rtol=1e-9)
    assert np.abs(T[:, 0, 1]).max() < 1e-9 * sxx
    assert np.allclose(r.tri_scalars(sim, "max_principal"), sxx, rtol=1e-9)
    assert np.allclose(r.tri_scalars(sim, "min_principal"), syy, rtol=1e-9)
    assert np.allclose(r.tri_scalars(sim, "speed"), 0.5)
    # displacement of node i is (e X_i, 0): the triangle mean of |u| by hand
    disp = (e * np.abs(X[:, 0]))[sim.model.tri_nodes_np].mean(1)
    assert np.allclose(r.tri_scalars(sim, "displacement"), disp, rtol=1e-12)
    with pytest.raises(ValueError):
        r.tri_scalars(sim, "body")
    # a shear: principal stresses from the numpy stress tensor
    sim.state.node_x.from_numpy(X + np.stack([0.02 * X[:, 1], np.zeros(len(X))], axis=1))
    T = sim.stresses()
    w = np.linalg.eigvalsh(0.5 * (T + T.transpose(0, 2, 1)))
    assert np.allclose(r.tri_scalars(sim, "max_principal"), w[:, 1], rtol=1e-9, atol=1e-6 * np.abs(w).max())
    assert np.allclose(r.tri_scalars(sim, "min_principal"), w[:, 0], rtol=1e-9, atol=1e-6 * np.abs(w).max())


def test_von_mises_plane_strain_includes_sigma_zz(tmp_path):
    """Plane strain, small uniaxial strain ε (F = diag(1 + ε, 1)): Hooke gives σxx = (λ+2μ)ε,
    σyy = λε and σzz = ν(σxx + σyy) = λε, so von Mises = √(½[(σxx−σyy)² + (σyy−σzz)² +
    (σzz−σxx)²]) = 2με exactly, by hand from E and ν (the in-plane formula gives √7 με at ν = ¼).
    Checked in the renderer and in the VTU export."""
    from taichi_fdem.io.vtu import frame_fields
    eps = 1e-6
    sim, mat, _ = _stretched("strain", eps)
    mu = mat.young / (2.0 * (1.0 + mat.poisson))
    vm_exact = 2.0 * mu * eps
    r = render.RendererImage(64, 64)
    export_vm = frame_fields(sim)["cell_data"]["von_mises"]
    render_vm = r.tri_scalars(sim, "von_mises")
    assert np.allclose(export_vm, vm_exact, rtol=1e-4)
    assert np.allclose(render_vm, vm_exact, rtol=1e-4)



def test_colour_bar_drawn_with_colormap_ends():
    sim, a, b = _two_triangles_sim()
    kw = dict(width=240, height=160, color_by="speed", draw_edges=False, stamp=False)
    with_bar = render.RendererImage(**kw).render_sim(sim)
    no_bar = render.RendererImage(colorbar=False, **kw).render_sim(sim)
    first, last = (np.round(c * 255).astype(int) for c in render.colormap(np.array([0.0, 1.0]), 0.0, 1.0))
    strip = with_bar[:, -24:].reshape(-1, 3).astype(int)
    assert (np.abs(strip - first).max(axis=1) <= 1).sum() >= 3
    assert (np.abs(strip - last).max(axis=1) <= 1).sum() >= 3
    # top of the bar is the max colour, bottom the min colour
    cols = with_bar[:, -24:].astype(int)
    hits = (np.abs(cols - last).max(axis=2) <= 1).sum(0) + (np.abs(cols - first).max(axis=2) <= 1).sum(0)
    col = cols[:, int(np.argmax(hits))]
    rows_last = np.nonzero(np.abs(col - last).max(axis=1) <= 1)[0]
    rows_first = np.nonzero(np.abs(col - first).max(axis=1) <= 1)[0]
    assert rows_last.size and rows_first.size and rows_last.mean() < rows_first.mean()
    # without the bar the strip is background only; the bar is not drawn for categorical modes
    assert np.all(no_bar[:, -6:] == 255)
    body = render.RendererImage(**dict(kw, color_by="body")).render_sim(sim)
    assert np.all(body[:, -6:] == 255)
    # labels (dark text) next to the bar
    assert (with_bar[:, -90:-24].sum(axis=2) < 200).sum() > 10


def test_stamp_top_left():
    sim, a, b = _two_triangles_sim()
    kw = dict(width=240, height=160, color_by="body")
    on = render.RendererImage(stamp=True, **kw).render_sim(sim)
    off = render.RendererImage(stamp=False, **kw).render_sim(sim)
    diff = np.any(on != off, axis=2)
    assert diff[:20, :120].sum() > 20
    assert not diff[40:].any()          # only the top-left is touched
    sim.step(10)
    later = render.RendererImage(stamp=True, **kw)
    img2 = later.render_sim(sim)
    off2 = render.RendererImage(stamp=False, **kw).render_sim(sim)
    # the stamp text changes with time / step
    assert np.any((img2 != off2)[:20, :120]) and np.any(img2[:20, :120] != on[:20, :120])


def test_follow_camera_keeps_moving_body_centred():
    sim, a, b = _two_triangles_sim(v_a=(2.0, 1.0), v_b=(0.0, 0.0))
    r = render.RendererImage(200, 100, follow=a, follow_width=3.0, color_by="body", stamp=False)
    centres = []
    for _ in range(3):
        img = r.render_sim(sim)
        c = sim.node_positions(a).mean(0)
        col, row = r.world_to_pixel(c)[0]
        assert abs(col - 100) < 0.5 and abs(row - 50) < 0.5
        assert r.last_view[1] - r.last_view[0] == pytest.approx(3.0)
        assert _close(img[50, 100], render.body_colors([0])[0])
        centres.append(c)
        sim.step(2000)
    assert np.linalg.norm(centres[-1] - centres[0]) > 0.01     # the body did move
    # a body of another simulation is refused
    other, oa, _ = _two_triangles_sim()
    with pytest.raises(ValueError, match="follow"):
        render.RendererImage(64, 64, follow=oa).render_sim(sim)


def test_render_sim_options_validated():
    with pytest.raises(ValueError, match="color_by"):
        render.RendererImage(color_by="stress")
    with pytest.raises(ValueError, match="vmax"):
        render.RendererImage(vmin=2.0, vmax=1.0)
    with pytest.raises(ValueError):
        render.RendererImage(vmin=float("nan"))
    with pytest.raises(ValueError, match="follow_width"):
        render.RendererImage(follow_width=0.0)
    with pytest.raises(ValueError, match="cmap"):
        render.RendererImage(cmap="jet")


def test_run_video_von_mises_frame_count(tmp_path):
    mat = fdem.Material(**ROCK)
    sc = fdem.Scene(gravity=(0.0, -9.81))
    sc.add_body(fdem.mesh.disk(radius=0.05, h=0.02), mat, position=(0.0, 0.1))
    sc.add_body(fdem.mesh.rectangle(0.3, 0.04, h=0.02), mat, position=(0.0, 0.0), fixed=True)
    sim = sc.build()
    out = tmp_path / "x.mp4"
    steps, per_frame = 60, 15
    sim.run(steps * sim.dt, record=[fdem.Video(out, frame_dt=per_frame * sim.dt,
                                               renderer=render.RendererImage(160, 120, color_by="von_mises"))])
    frames = list(iio.imiter(out))
    assert len(frames) == 1 + steps // per_frame
    assert frames[0].shape == (120, 160, 3)
    assert sim.step_count == steps


def test_render_sim_no_recompilation():
    kernels = [render._tri_scalar_kernel, render._centroid_kernel, render._sim_scalar_kernel,
               render._raster_u8_kernel, render._bbox_kernel]
    if not all(hasattr(getattr(k, "_primal", None), "compiled_kernels") for k in kernels):
        pytest.skip("Taichi internals changed")
    sim, a, b = _two_triangles_sim()
    render.RendererImage(32, 32, color_by="speed", follow=a).render_sim(sim)
    before = [len(k._primal.compiled_kernels) for k in kernels]
    mat = fdem.Material(**ROCK)
    sc = fdem.Scene(gravity=(0.0, 0.0))
    d = sc.add_body(fdem.mesh.disk(radius=0.05, h=0.01), mat)
    sim2 = sc.build()
    for mode in ("von_mises", "displacement", "min_principal"):
        render.RendererImage(50, 40, color_by=mode, follow=d).render_sim(sim2)
    assert [len(k._primal.compiled_kernels) for k in kernels] == before


# ---------------------------------------------------------------------------------------------
# the optimised frame path gives the same pixels as the straightforward one
# ---------------------------------------------------------------------------------------------
def _overlay_reference(r, img, bar, layout, stamp):
    """The labels drawn directly: one full-frame RGBA layer composited over the frame."""
    from PIL import Image, ImageDraw

    font = r._get_font()
    if bar is not None:
        vmin, vmax, title = bar
        L = layout
        grad = render.colormap(np.linspace(1.0, 0.0, L["y1"] - L["y0"]), 0.0, 1.0, r.cmap)
        grad8 = np.clip(grad * 255.0 + 0.5, 0, 255).astype(np.uint8)
        img = np.array(img, copy=True)
        img[L["y0"]:L["y1"], L["x0"]:L["x1"]] = grad8[:, None, :]
    pil = Image.fromarray(img).convert("RGBA")
    layer = Image.new("RGBA", pil.size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(layer)

    def label(xy, text, anchor):
        l, t_, rr, b = draw.textbbox(xy, text, font=font, anchor=anchor)
        draw.rectangle((l - 2, t_ - 2, rr + 2, b + 2), fill=(255, 255, 255, 170))
        draw.text(xy, text, font=font, fill=(0, 0, 0, 255), anchor=anchor)

    if bar is not None:
        x0, x1, y0, y1 = L["x0"], L["x1"], L["y0"], L["y1"]
        draw.rectangle((x0 - 1, y0 - 1, x1, y1), outline=(0, 0, 0, 255))
        label((x0 - 4, y0), render._fmt(vmax), "ra")
        label((x0 - 4, y1), render._fmt(vmin), "rd")
        label((x1, max(0, y0 - 6)), title, "rd")
    if stamp is not None:
        label((4, 4), stamp, "la")
    out = np.array(Image.alpha_composite(pil, layer).convert("RGB"))
    if bar is not None:
        out[y0:y1, x0:x1] = grad8[:, None, :]
    return out


@pytest.mark.parametrize("size,text_size", [((960, 540), None), ((320, 200), None), ((64, 48), 12),
                                            ((200, 120), 30), ((33, 71), 4)])
def test_label_sprites_equal_direct_drawing(size, text_size):
    rng = np.random.default_rng(7)
    r = render.RendererImage(*size, text_size=text_size, cmap="coolwarm")
    layout = r._bar_layout()
    cases = [((0.0, 1.234e5, "von Mises stress [Pa]"), "t = 0.0123 s  step 4567"),
             ((-3.5e-7, 2.0, "speed |v| [m/s]"), None), (None, "t = 1 s  step 2"),
             ((0.0, 1.234e5, "von Mises stress [Pa]"), "t = 0.0124 s  step 4568")]
    for _ in range(2):       # the second pass draws from the sprite cache
        for bar, stamp in cases:
            frame = rng.integers(0, 256, (size[1], size[0], 3), dtype=np.uint8)
            expected = _overlay_reference(r, frame, bar, layout, stamp)
            got = r._overlay(frame.copy(), bar, layout, stamp)
            assert np.array_equal(got, expected), (bar, stamp)
    assert len(r._sprites) > 0


def _reference_frame(r, sim, mode):
    """render_sim's frame without labels through the float-image kernels and host colour map."""
    vals = r.tri_scalars(sim, mode)
    fin = np.isfinite(vals)
    vmin = r.vmin if r.vmin is not None else float(vals[fin].min())
    vmax = r.vmax if r.vmax is not None else float(vals[fin].max())
    cols = np.ascontiguousarray(render.colormap(vals, vmin, vmax, r.cmap))
    x = sim.state.node_x.to_numpy()
    view, scale = r._letterbox(r._world_box(sim.state.node_x), r._bar_layout()["reserve"] if r.colorbar else 0)
    img = ti.Vector.ndarray(3, ti.f32, shape=(r.height, r.width))
    out = ti.ndarray(ti.u8, shape=(r.height, r.width, 3))
    p = ti.Vector.ndarray(2, ti.f32, shape=(x.shape[0],))
    params = ti.ndarray(sim.state.node_x.dtype, shape=(3,))
    params.from_numpy(np.array([view[0], view[3], scale], dtype=x.dtype))
    c = ti.Vector.ndarray(3, ti.f32, shape=(cols.shape[0],))
    c.from_numpy(cols)
    render._clear_kernel(img, ti.Vector(r.background, dt=ti.f32))
    render._to_pixels_kernel(sim.state.node_x, params, p)
    render._raster_kernel(p, sim.model.tri_nodes, c, img, ti.Vector(r.edge_color, dt=ti.f32),
                          float(0.5 * r.edge_width), int(r.draw_edges and r.edge_width > 0))
    render._resolve_kernel(img, out, 1)
    return out.to_numpy(), (vmin, vmax)


@pytest.mark.parametrize("mode,rng", [("speed", None), ("von_mises", None), ("displacement", (0.0, 0.01)),
                                      ("min_principal", None)])
def test_fused_raster_equals_reference_pipeline(mode, rng):
    mat = fdem.Material(**ROCK)
    sc = fdem.Scene(gravity=(0.0, -9.81))
    sc.add_body(fdem.mesh.disk(radius=0.05, h=0.01), mat, velocity=(0.3, -0.2), angular_velocity=4.0)
    sc.add_body(fdem.mesh.rectangle(0.2, 0.02, 0.01), mat, position=(0.0, -0.07), fixed=True)
    sim = sc.build()
    sim.step(200)
    vmin, vmax = rng if rng is not None else (None, None)
    r = render.RendererImage(200, 120, color_by=mode, vmin=vmin, vmax=vmax, stamp=False, colorbar=False)
    img = r.render_sim(sim)
    ref, ref_range = _reference_frame(r, sim, mode)
    assert r.last_range == pytest.approx(ref_range, rel=0, abs=0)
    assert np.array_equal(img, ref)
    assert np.array_equal(r.last_scalars, r.tri_scalars(sim, mode))
    # the full frame (colour bar, stamp) equals the reference frame with labels drawn directly
    r2 = render.RendererImage(200, 120, color_by=mode, vmin=vmin, vmax=vmax)
    full = r2.render_sim(sim)
    ref2, (lo, hi) = _reference_frame(r2, sim, mode)
    stamp = f"t = {sim.time:.4g} s  step {sim.step_count}"
    expected = _overlay_reference(r2, ref2, (lo, hi, render.COLOR_MODES[mode][1]), r2._bar_layout(), stamp)
    assert np.array_equal(full, expected)


def test_annotate_crop_equals_full_frame_composite():
    from PIL import Image, ImageDraw, ImageFont

    rng = np.random.default_rng(3)
    for w, h in ((300, 120), (40, 20)):
        img = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
        for xy in ((4, 4), (8, h - 30), (-5, 3), (w - 10, h - 5), (3.5, 7.25)):
            for box in (True, False):
                got = render.annotate(img, "analytic s = 0.123 m", xy=xy, color=(200, 0, 0), size=14, box=box)
                font = ImageFont.load_default(size=14)
                pil = Image.fromarray(img).convert("RGBA")
                layer = Image.new("RGBA", pil.size, (0, 0, 0, 0))
                d = ImageDraw.Draw(layer)
                if box:
                    l, t, r, b = d.textbbox(xy, "analytic s = 0.123 m", font=font)
                    d.rectangle((l - 2, t - 2, r + 2, b + 2), fill=(255, 255, 255, 170))
                d.text(xy, "analytic s = 0.123 m", font=font, fill=(200, 0, 0, 255))
                assert np.array_equal(got, np.asarray(Image.alpha_composite(pil, layer).convert("RGB")))


def test_excavated_triangles_render_without_out_of_bounds_reads(tmp_path):
    """A simulation with removed triangles (their node indices −1 in the drawn list) renders in
    Taichi's debug mode, which bounds-checks every array access (a fresh process: the debug
    flag is fixed at init).  Fails if a raster kernel reads a node at index −1: in a release
    build such a read goes unnoticed."""
    import subprocess
    import sys
    import textwrap
    code = textwrap.dedent("""
        import numpy as np
        import taichi_fdem as fdem
        from taichi_fdem import render
        fdem.init()
        mat = fdem.Material(density=2500.0, young=1e8, poisson=0.25)
        scene = fdem.Scene()
        scene.add_body(fdem.mesh.rectangle(0.2, 0.1, 0.025), mat)
        sim = scene.build()
        n = sim.remove(where=lambda x, y: x < 0.05)
        assert n > 0
        r = render.RendererImage(width=64, height=32)
        img = r.render_sim(sim)
        assert img.shape == (32, 64, 3)
        r.color_by = "speed"
        r.render_sim(sim)
        print("ok", n)
        """)
    env = dict(os.environ, TAICHI_FDEM_DEBUG="1", TAICHI_FDEM_CACHE=str(tmp_path / "cache"))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600,
                         cwd=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    assert out.returncode == 0, out.stderr[-3000:]
    assert "ok" in out.stdout


# ---- the fluid-pressure colour mode -------------------------------------------------------------------
def _fluid_sim(p_left):
    """A fixed 0.4 m × 0.2 m block cut by a crack along y = 0 at the residual aperture, pressure
    p_left held at its left end and 0 at its right end (or no source: a dry crack)."""
    import taichi_fdem as fdem
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.4, 0.2, 0.05), fdem.Material(density=2700.0, young=10e9, poisson=0.25),
                   fixed=True, cracks=lambda x, y: np.abs(y) < 1e-9)
    scene.set_fluid(fdem.Fluid(), aperture_min=1e-4)
    if p_left is not None:
        scene.inject(lambda x, y: x < -0.2 + 1e-9, pressure=p_left)
        scene.inject(lambda x, y: x > 0.2 - 1e-9, pressure=0.0)
    sim = scene.build(strategy="serial")
    sim.step(10)
    return sim


def test_fluid_pressure_colours_the_network_by_its_pressure():
    """Every pixel on the crack takes the colour map of the pressure at its x, interpolated
    linearly between the network nodes' pressures (sim.fluid.pressures(), a field the engine
    computed, not a uniform one); a dry crack is drawn at the colour of 0 Pa; the solid away from
    the crack is the grey of SOLID_UNDER_FLUID in both."""
    from taichi_fdem.render.colors import SOLID_UNDER_FLUID
    P = 1e6
    kw = dict(view=(-0.2, 0.2, -0.1, 0.1), color_by="fluid_pressure", vmin=0.0, vmax=P, colorbar=False,
              stamp=False, draw_edges=False, crack_width=3.0)
    wet, dry = _fluid_sim(P), _fluid_sim(None)
    pos, p = wet.fluid.pressures()
    order = np.argsort(pos[:, 0])
    assert 0.2 * P < np.interp(0.0, pos[order, 0], p[order]) < 0.8 * P     # a graded field
    r = render.RendererImage(160, 80, **kw)
    img_wet, img_dry = r.render_sim(wet), r.render_sim(dry)
    xmin, xmax, ymin, ymax = r.last_view
    row = int((ymax - 0.0) / (ymax - ymin) * 80)             # the pixel row through y = 0
    cols = np.arange(4, 156)
    xc = xmin + (cols + 0.5) / 160 * (xmax - xmin)
    expect = np.round(render.colormap(np.interp(xc, pos[order, 0], p[order]), 0.0, P) * 255.0)
    for rr in (row - 1, row):                                # y = 0 lies on a pixel boundary
        assert np.abs(img_wet[rr, cols].astype(float) - expect).max() <= 2.0
        zero = np.round(render.colormap(np.zeros(1), 0.0, P)[0] * 255.0)
        assert np.abs(img_dry[rr, cols].astype(float) - zero).max() <= 1.0
    grey = np.round(np.asarray(SOLID_UNDER_FLUID) * 255.0)
    for img in (img_wet, img_dry):
        assert np.abs(img[row + 10, cols].astype(float) - grey).max() <= 1.0
    assert np.abs(img_wet[row, cols[:20]].astype(float) - img_dry[row, cols[:20]]).max() > 50


def test_fluid_pressure_mode_range_bar_and_errors():
    """The automatic range is that of the conducting nodes' pressures; a colour bar is drawn; a
    scene without a fluid and tri_scalars refuse the mode."""
    P = 1e6
    wet = _fluid_sim(P)
    r = render.RendererImage(96, 48, color_by="fluid_pressure")
    r.render_sim(wet)
    p = wet.fluid.pressures()[1]
    assert r.last_range == pytest.approx((p.min(), p.max()), rel=1e-12, abs=1e-9)
    assert r.last_range[1] == pytest.approx(P, rel=1e-9)
    import taichi_fdem as fdem
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.2, 0.2, 0.1), fdem.Material(density=2700.0, young=10e9, poisson=0.25))
    with pytest.raises(ValueError, match="needs a scene with a fluid"):
        r.render_sim(scene.build())
    with pytest.raises(ValueError, match="not the triangles"):
        r.tri_scalars(wet, "fluid_pressure")
    with pytest.raises(ValueError, match="color_by must be one of"):
        render.RendererImage(8, 8, color_by="pressure")

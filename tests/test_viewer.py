"""Live viewer (taichi_fdem.render.viewer): a real window under Xvfb, and the no-display fallback.

The window test runs the viewer in a subprocess (a crashing window system cannot take pytest
down) against a private Xvfb server; it is skipped, with the reason, when Xvfb is missing
(.ci/run installs it; the tests never install anything).
"""
import os
import select
import shutil
import subprocess
import sys
import textwrap
import time
import warnings

import imageio.v3 as iio
import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem.render import RendererImage
from taichi_fdem.render.viewer import Viewer, _from_gui, _to_gui

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _small_sim():
    rock = fdem.Material(density=2700.0, young=1e8, poisson=0.25)
    sc = fdem.Scene(gravity=(0.0, -9.81))
    sc.add_body(fdem.mesh.disk(radius=0.05, h=0.02), rock, position=(0.0, 0.2))
    return sc.build()


def _ensure_xvfb():
    """Path of Xvfb; pytest.skip with the reason when it is absent.  Tests never install
    packages: .ci/run installs xvfb (apt-get) before running the suite."""
    exe = shutil.which("Xvfb")
    if not exe:
        pytest.skip("Xvfb not on PATH (CI installs it in .ci/run: apt-get install xvfb)")
    return exe


@pytest.fixture
def xvfb():
    """A private Xvfb server; yields its DISPLAY string once the server accepts connections.

    Xvfb picks a free display itself and writes its number to ``-displayfd`` when it is ready
    (waiting only for the socket file raced the server's start: a window opened in between
    crashed, once in CI)."""
    exe = _ensure_xvfb()
    rfd, wfd = os.pipe()
    proc = subprocess.Popen([exe, "-displayfd", str(wfd), "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, pass_fds=(wfd,))
    os.close(wfd)
    num = b""
    deadline = time.monotonic() + 30.0
    while not num.endswith(b"\n") and time.monotonic() < deadline and proc.poll() is None:
        ready, _, _ = select.select([rfd], [], [], 0.5)
        if ready:
            chunk = os.read(rfd, 16)
            if not chunk:
                break
            num += chunk
    os.close(rfd)
    if not num.strip().isdigit():
        proc.kill()
        proc.wait()
        pytest.skip("Xvfb not available: the server did not report a display")
    try:
        yield f":{int(num)}"
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()


VIEWER_SCRIPT = textwrap.dedent("""
    import sys
    import numpy as np
    import taichi_fdem as fdem
    from PIL import ImageGrab
    from taichi_fdem.render import RendererImage, save_png
    from taichi_fdem.render.viewer import Viewer

    out = sys.argv[1]
    fdem.init(arch="cpu", precision="f64")
    rock = fdem.Material(density=2700.0, young=1e8, poisson=0.25)
    sc = fdem.Scene(gravity=(0.0, -9.81))
    sc.add_body(fdem.mesh.disk(radius=0.05, h=0.02), rock, position=(0.0, 0.2))
    sim = sc.build()
    ok, why = Viewer.available()
    print("available", ok, why, flush=True)
    grabs = []

    def grab(v):
        if v.frames == 3 and not grabs:
            grabs.append(np.asarray(ImageGrab.grab(xdisplay=sys.argv[2]).convert("RGB")))

    v = Viewer(sim, RendererImage(320, 240, color_by="speed"), steps_per_frame=20, readback=True)
    mode = v.run(max_frames=5, on_frame=grab)
    print("mode", mode, "frames", v.frames, "step", sim.step_count, flush=True)
    np.save(out + "/shot.npy", v.screenshot())
    np.save(out + "/window.npy", v.window_image())
    np.save(out + "/xgrab.npy", grabs[0])
""")


def test_viewer_window_under_xvfb(xvfb, tmp_path):
    script = tmp_path / "viewer_script.py"
    script.write_text(VIEWER_SCRIPT)
    env = dict(os.environ, DISPLAY=xvfb, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.run([sys.executable, str(script), str(tmp_path), xvfb], env=env, capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "available True" in p.stdout, p.stdout + p.stderr
    assert "mode window frames 5 step 80" in p.stdout, p.stdout + p.stderr
    shot = np.load(tmp_path / "shot.npy")
    window = np.load(tmp_path / "window.npy")
    xgrab = np.load(tmp_path / "xgrab.npy")
    assert shot.shape == (240, 320, 3) and window.shape == (240, 320, 3)
    # what the window canvas holds (read back from ti.GUI) is the rendered frame
    assert np.abs(window.astype(int) - shot.astype(int)).max() <= 1

    def colours(img):
        return len(np.unique(img.reshape(-1, 3), axis=0))

    assert colours(window) > 10
    # the real X screen: the 320x240 window is mapped somewhere on the 1024x768 root window and
    # is not blank (many colours, a large non-black area)
    assert xgrab.shape == (768, 1024, 3)
    assert colours(xgrab) > 10
    assert (xgrab.sum(axis=2) > 0).sum() > 0.5 * 320 * 240
    # and it contains the rendered frame: look for its white background and the viridis bar
    assert np.all(xgrab == 255, axis=2).sum() > 0.2 * 320 * 240


def test_no_display_fallback_writes_video(tmp_path, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    ok, why = Viewer.available()
    assert ok is False and "DISPLAY" in why
    sim = _small_sim()
    out = tmp_path / "viewer.mp4"
    v = Viewer(sim, RendererImage(160, 120, color_by="von_mises"), steps_per_frame=10, fallback_video=out)
    with pytest.warns(RuntimeWarning, match="rendering off-screen"):
        mode = v.run(max_frames=4)
    assert mode == "video" and v.mode == "video"
    assert v.frames == 4 and sim.step_count == 30      # initial frame + 3 stepped frames
    frames = np.stack(list(iio.imiter(out)))
    assert frames.shape[0] == 4 and frames.shape[1:3] == (120, 160)
    assert v.screenshot().shape == (120, 160, 3)
    assert v.window_image() is None


def test_fallback_duration_and_default_frames(tmp_path, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    sim = _small_sim()
    v = Viewer(sim, RendererImage(64, 48), steps_per_frame=5, fallback_video=tmp_path / "v.gif")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        v.run(duration=12 * sim.dt)          # 12 steps: 5 + 5 + 2 -> initial + 3 frames
    assert v.frames == 4 and sim.step_count == 12
    v2 = Viewer(sim, RendererImage(64, 48), steps_per_frame=1, fallback_video=tmp_path / "w.gif")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        v2.run(fallback_frames=3)
    assert v2.frames == 3


def test_gui_image_layout_and_colour_cycle():
    img = np.zeros((3, 4, 3), np.uint8)
    img[0, 0] = (255, 0, 0)        # top-left pixel
    g = _to_gui(img)
    assert g.shape == (4, 3, 3) and g.dtype == np.float32
    assert np.allclose(g[0, 2], (1.0, 0.0, 0.0))   # [x=0, y=top] with y up
    assert np.array_equal(_from_gui(np.concatenate([g, np.ones((4, 3, 1), np.float32)], axis=2)), img)
    sim = _small_sim()
    v = Viewer(sim, RendererImage(32, 32))
    from taichi_fdem.render import COLOR_MODES
    n = len(COLOR_MODES) - 3          # "fluid_pressure" needs a fluid, "bedding" a bedded material, "temperature" heat
    seen = [v.renderer.color_by] + [v.cycle_color() for _ in range(n)]
    assert seen[0] == seen[-1] == "body" and len(set(seen)) == n
    with pytest.raises(ValueError):
        Viewer(sim, steps_per_frame=0)

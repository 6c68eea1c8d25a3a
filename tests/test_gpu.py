"""The GPU code path on a Vulkan device (Mesa's software driver lavapipe in CI), against the
CPU parallel strategy on the same tiny scenes (tests/gpu_probe.py), in f32 and f64, and the
per-task storage-buffer budget of every kernel those runs compiled.

Marked ``gpu``: ``make test`` runs them in their own pytest invocation after the CPU suite.
Each device runs in a subprocess (Taichi is initialised once per process); without a Vulkan
device the tests skip, saying so.

Feature → test that runs it on Vulkan:
contact, friction, detection, fracture, crack events, fragments, energies, renderer kernels,
checkpoints → ``test_vulkan_runs_every_feature[*-impact]``; heterogeneity (Weibull strength),
joint sets, pre-existing cracks, loads and curves, absorbing boundaries, initial stress, local
damping, excavation → ``test_vulkan_runs_every_feature[*-rock]``; the fluid in the fracture
network (both its sources, the pressure forces, the flow substeps) →
``test_vulkan_runs_every_feature[*-fluid]``; the agreement with the CPU
→ ``test_vulkan_matches_cpu`` (with an exact checkpoint round trip); the renderer's frames
against the CPU's → ``test_vulkan_frames_match_cpu``; the portable log / exp / pow →
``test_fmath_on_vulkan``; strain energy at rest → ``test_pile_strain_energy_at_rest_vulkan``;
the buffer budget → ``test_storage_buffer_budget``; host writes of counters →
``test_host_write_waits_for_the_device``; ``benchmarks/gpu.py`` → ``test_gpu_benchmark_tiny``.
"""
import glob
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
import pytest

from test_fmath import BOUNDS, HERE, ROOT, run_probe

pytestmark = pytest.mark.gpu

#: Vulkan guarantees 4 storage buffers per shader stage; 32 is common on integrated and mobile
#: GPUs and MoltenVK, and Taichi does not check it (33 crashes the driver, 32 gives wrong
#: answers): every task must bind at most 31 (one binding stays free for Taichi's own buffers)
MAX_STORAGE_BUFFERS = 31
TOL = {"f64": 1e-10, "f32": 1e-5}        # positions [m]


def vulkan_reason():
    """None when a Vulkan device initialises here, else why not."""
    code = "import taichi as ti; ti.init(arch=ti.vulkan, log_level=ti.ERROR); import sys; " \
           "from taichi.lang import impl; sys.exit(0 if impl.current_cfg().arch == ti.vulkan else 3)"
    try:
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        return "initialising Vulkan timed out"
    if r.returncode != 0:
        return "no Vulkan device (install mesa-vulkan-drivers libvulkan1 for lavapipe): " + r.stderr[-200:]
    return None


@pytest.fixture(scope="module")
def vulkan():
    reason = vulkan_reason()
    if reason:
        pytest.skip(reason)
    return "vulkan"


_RUNS = {}


def probe(arch, precision):
    """tests/gpu_probe.py's result on ``arch``; the Vulkan runs use a fresh offline cache, whose
    compiled tasks :func:`task_buffer_counts` reads."""
    key = (arch, precision)
    if key not in _RUNS:
        cache = tempfile.mkdtemp(prefix="fdem_gpu_cache_")
        env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""),
                   TAICHI_FDEM_CACHE=cache)
        r = subprocess.run([sys.executable, os.path.join(HERE, "gpu_probe.py"), arch, precision],
                           capture_output=True, text=True, timeout=1200, env=env)
        assert r.returncode == 0, (arch, precision, r.stderr[-3000:])
        _RUNS[key] = (json.loads(r.stdout.strip().splitlines()[-1]), cache)
    return _RUNS[key]


def task_buffer_counts(cache_dir) -> dict:
    """{task name: storage buffers it binds} of every SPIR-V task in a Taichi offline cache
    (the ``buffer_binds`` of each task's attributes; the uniform argument buffer left out)."""
    out = {}
    dec = json.JSONDecoder()
    for f in glob.glob(os.path.join(cache_dir, "*.tic")):
        data = open(f, "rb").read().decode("latin-1")
        i = data.find('{"kernel_attribs"')
        while i >= 0:
            obj, end = dec.raw_decode(data, i)
            for t in obj["kernel_attribs"]["tasks_attribs"]:
                out[t["name"]] = sum(1 for b in t["buffer_binds"] if b["buffer"]["type"] != 2)
            i = data.find('{"kernel_attribs"', end)
    return out


@pytest.mark.parametrize("precision", ["f64", "f32"])
@pytest.mark.parametrize("case", ["impact", "rock", "fluid", "heat"])
def test_vulkan_runs_every_feature(vulkan, precision, case):
    """Every feature of the case runs on Vulkan: the run completes, every energy term of the
    CPU run is there and finite, the frame renders like the CPU's, the fragments are counted."""
    gpu = probe("vulkan", precision)[0][case]
    cpu = probe("cpu", precision)[0][case]
    assert set(gpu["energies"]) == set(cpu["energies"])
    assert all(np.isfinite(v) for v in gpu["energies"].values())
    assert gpu["image_shape"] == cpu["image_shape"] and abs(gpu["image_mean"] - cpu["image_mean"]) < 1.0
    assert gpu["fragments"] >= 1 and len(gpu["x"]) == len(cpu["x"])
    if case == "fluid":
        assert gpu["checkpoint_same"]
        assert np.allclose(gpu["injected"], cpu["injected"], rtol=1e-3)
    if case == "heat":
        assert gpu["checkpoint_same"] and gpu["checkpoint_state_same"]
        tol = {"f64": 1e-9, "f32": 1e-3}[precision]          # K, of temperatures near 200
        assert np.allclose(gpu["temperatures"], cpu["temperatures"], rtol=0.0, atol=tol)
        assert max(gpu["temperatures"]) > 21.0


@pytest.mark.parametrize("precision", ["f64", "f32"])
@pytest.mark.parametrize("case", ["impact", "rock"])
def test_vulkan_matches_cpu(vulkan, precision, case):
    """Same positions (1e-10 m f64, 1e-5 m f32), couples, broken joints and crack events, the
    same energy terms, and an exact checkpoint round trip."""
    gpu = probe("vulkan", precision)[0][case]
    cpu = probe("cpu", precision)[0][case]
    assert gpu["couples"] == cpu["couples"]
    assert gpu["broken"] == cpu["broken"] and gpu["event_joints"] == cpu["event_joints"]
    assert gpu["fragments"] == cpu["fragments"]
    dx = np.abs(np.array(gpu["x"]) - np.array(cpu["x"])).max()
    assert dx <= TOL[precision], dx
    assert gpu["checkpoint_same"] and gpu["checkpoint_state_same"]


#: f32 frames: the share of pixels that may differ from the CPU's.  The f32 positions agree to
#: ~3e-6 m and a pixel of these 96 × 64 frames spans ~3e-3 m, so only pixels whose centre lies
#: within ~1e-5 m of an edge, and triangles whose damage (f32 rounding of the run) sits at a
#: colour step, can change: a few in a thousand (5 of 6144 measured).  f64 frames are equal.
F32_PIXELS = 0.005


@pytest.mark.parametrize("precision", ["f64", "f32"])
@pytest.mark.parametrize("case", ["impact", "rock"])
def test_vulkan_frames_match_cpu(vulkan, precision, case):
    """The renderer's frames drawn on the device (body colours with the crack overlay, damage,
    and the supersampled speed of a velocity field set from the rest positions, the same on both
    devices) equal the CPU's: every pixel in f64, all but F32_PIXELS of them in f32."""
    gpu = probe("vulkan", precision)[0][case]
    cpu = probe("cpu", precision)[0][case]
    assert set(gpu["frames"]) == {"body_cracks", "damage", "speed_ss2"}
    for name, frame in gpu["frames"].items():
        a, b = np.array(frame, dtype=np.int64), np.array(cpu["frames"][name], dtype=np.int64)
        assert a.shape == b.shape == (64, 96, 3)
        differ = (a != b).any(axis=2).mean()
        assert differ <= (0.0 if precision == "f64" else F32_PIXELS), (name, differ)


def test_host_write_waits_for_the_device(vulkan):
    """An element written from the host after a fill still in flight is kept (Taichi's own
    element write lands before the fill on Vulkan and is lost: sim.model.host_write waits)."""
    code = ("import taichi as ti, taichi_fdem as fdem; fdem.init(arch='vulkan'); "
            "from taichi_fdem.sim.model import host_write; "
            "a = ti.ndarray(ti.i32, shape=8); a.fill(3); host_write(a, 5, 7); print(a.to_numpy().tolist())")
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, env=env)
    assert r.returncode == 0, r.stderr[-2000:]
    assert json.loads(r.stdout.strip().splitlines()[-1]) == [3, 3, 3, 3, 3, 7, 3, 3]


@pytest.mark.parametrize("precision", ["f64", "f32"])
def test_storage_buffer_budget(vulkan, precision):
    """No task compiled by the Vulkan runs binds more than 31 storage buffers."""
    _, cache = probe("vulkan", precision)
    counts = task_buffer_counts(cache)
    assert counts, "no compiled task found in the offline cache"
    worst = max(counts, key=counts.get)
    assert counts[worst] <= MAX_STORAGE_BUFFERS, (worst, counts[worst])


@pytest.mark.parametrize("precision", ["f64", "f32"])
def test_fmath_on_vulkan(vulkan, precision):
    err = run_probe("fmath_probe.py", "vulkan", precision)
    for name, bound in BOUNDS.items():
        assert err[name] <= bound, (name, err[name])


def test_pile_strain_energy_at_rest_vulkan(vulkan):
    """f32 on Vulkan: the pile at rest has a strain energy ≥ 0 and < 1e-5 J/m (f32 rounding of F)."""
    e32 = run_probe("pile_energy_probe.py", "vulkan", "f32")
    assert 0.0 <= e32["strain0"] < 1e-5


def test_arch_gpu_picks_vulkan_and_says_so(vulkan):
    """Without CUDA, arch="gpu" runs on Vulkan, prints which on stderr, and sim.info() names it."""
    code = ("import taichi_fdem as fdem; fdem.init(arch='gpu', precision='f32'); "
            "from taichi_fdem.verification import two_disks_scene; "
            "sim = two_disks_scene(strategy='auto')[0]; "
            "print(sim.info()['device'], sim.solver.strategy)")
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, env=env)
    assert r.returncode == 0, r.stderr[-2000:]
    picked = r.stderr.count("taichi_fdem: arch='gpu' runs on ")
    assert picked == 1
    device = r.stdout.strip().splitlines()[-1].split()
    assert device[0] in ("cuda", "vulkan", "metal") and device[1] == "parallel"


def test_gpu_benchmark_tiny(vulkan):
    """benchmarks/gpu.py --tiny runs both scenes on Vulkan and on the CPU (so that it cannot rot),
    reporting the compile time and the allocated arrays' bytes (no CUDA pool on Vulkan)."""
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    r = subprocess.run([sys.executable, os.path.join(ROOT, "benchmarks", "gpu.py"), "--tiny", "--arch", "vulkan",
                        "--precisions", "f32"], capture_output=True, text=True, timeout=1200, env=env)
    assert r.returncode == 0, r.stderr[-3000:]
    rows = [line.split() for line in r.stdout.splitlines() if "steps/s" in line]
    assert sorted((row[0], row[1]) for row in rows) == [("impact", "cpu"), ("impact", "vulkan"),
                                                         ("pile", "cpu"), ("pile", "vulkan")]
    for row in rows:     # compile time and the bytes of the allocated arrays, reported
        assert float(row[row.index("compile") + 1]) >= 0.0
        assert float(row[row.index("arrays") + 1]) > 0.0 and row[row.index("pool") + 1] == "-"

"""The one place where Taichi is initialised.

Everything in taichi_fdem that needs Taichi calls :func:`ensure_init`, which calls
:func:`init` with defaults the first time.  Call :func:`init` yourself, before building a
scene, to choose the architecture or the precision.
"""
from __future__ import annotations

import os

import numpy as np
import taichi as ti

_ARCHS = {"cpu": "cpu", "cuda": "cuda", "gpu": "gpu", "vulkan": "vulkan", "metal": "metal", "opengl": "opengl"}
_PRECISIONS = {"f64": (ti.f64, np.float64), "f32": (ti.f32, np.float32)}

_state = {"initialised": False, "arch": None, "precision": None, "generation": 0}

def taichi_header() -> str:
    """Taichi's start-up line, "[Taichi] version 1.7.4, linux, python 3.11.7", from public values.

    ``taichi_fdem`` imports Taichi without its banner (``taichi_fdem/__init__.py``); the command
    line prints this line when a command starts Taichi.
    """
    import platform
    version = ".".join(str(v) for v in ti.__version__)
    return f"[Taichi] version {version}, {platform.system().lower()}, python {platform.python_version()}"


def init(arch: str = "cpu", precision: str = "f64", offline_cache: bool = True, debug: bool | None = None,
         cpu_max_num_threads: int | None = None, fast_compile: bool | None = None,
         front_end_shortcuts: bool | None = None, device_memory_GB: float | None = None) -> None:
    """Initialise Taichi for taichi_fdem.

    Parameters
    ----------
    arch : "cpu" (default), "cuda", "gpu", "vulkan", "metal" or "opengl".  "gpu" takes the
        first of CUDA, Vulkan and Metal that initialises here and prints which on stderr (one
        line); :func:`arch` then names it.  An explicit GPU arch that does not initialise raises
        RuntimeError (Taichi itself would fall back to the CPU).  The CPU is tested in full, Vulkan
        on a software device (tests/test_gpu.py); CUDA, Metal and hardware Vulkan are untested.
    precision : "f64" (default) or "f32", the floating-point type of every real field.
    offline_cache : keep compiled kernels on disk so that a second run starts fast.
    debug : Taichi debug mode (bounds checks on every array access; slow).  None (default): on
        when the environment variable TAICHI_FDEM_DEBUG is "1" (for example
        ``TAICHI_FDEM_DEBUG=1 make test``).
    cpu_max_num_threads : threads of the CPU back end (default: the cores this process may use,
        :func:`usable_cores`: its affinity set and CPU quota).
    fast_compile : skip Taichi's advanced IR optimisations: a shorter cold start, slower steps
        (benchmarks/results.md).  Round-off differs from the default build, which can shift
        discrete events (the step at which two bodies separate); the accuracy benchmark uses the
        default.  The offline cache makes later starts fast either way.  None (default): on
        when the environment variable TAICHI_FDEM_FAST_COMPILE is "1".
    front_end_shortcuts : deprecated, has no effect (DeprecationWarning when given).
    device_memory_GB : memory [GB] Taichi pre-allocates on a CUDA device (Taichi's default
        otherwise: a fraction of the device memory).  None (default) leaves Taichi's default.

    Calling ``init`` again with the same settings does nothing (a notebook cell or a pasted
    example may call it twice).  With other settings it re-initialises Taichi: simulations built
    before become invalid.
    """
    if arch not in _ARCHS:
        raise ValueError(f"fdem.init: unknown arch {arch!r}; choose one of {sorted(_ARCHS)}")
    if precision not in _PRECISIONS:
        raise ValueError(f"fdem.init: unknown precision {precision!r}; choose 'f64' or 'f32'")
    if debug is None:
        debug = os.environ.get("TAICHI_FDEM_DEBUG", "") == "1"
    if front_end_shortcuts is not None:
        import warnings
        warnings.warn("fdem.init(front_end_shortcuts=...) is deprecated and has no effect", DeprecationWarning, stacklevel=2)
    kwargs = dict(arch=getattr(ti, _ARCHS[arch]), default_fp=_PRECISIONS[precision][0], default_ip=ti.i32,
                  offline_cache=offline_cache, debug=debug, log_level=os.environ.get("TI_LOG_LEVEL", ti.WARN),
                  # Taichi's CFG optimisation (store-to-load forwarding and dead-store elimination
                  # over the control-flow graph) is off: its compile time grows faster than the
                  # size of a kernel, and LLVM's own passes do the same work (same bits, same speed)
                  cfg_optimization=False)
    if cpu_max_num_threads is None:
        cpu_max_num_threads = usable_cores()
    if int(cpu_max_num_threads) < 1:
        raise ValueError(f"fdem.init: cpu_max_num_threads must be >= 1, got {cpu_max_num_threads!r}")
    kwargs["cpu_max_num_threads"] = int(cpu_max_num_threads)
    if device_memory_GB is not None:
        if not (float(device_memory_GB) > 0.0):
            raise ValueError(f"fdem.init: device_memory_GB must be > 0, got {device_memory_GB!r}")
        kwargs["device_memory_GB"] = float(device_memory_GB)
    if fast_compile is None:
        fast_compile = os.environ.get("TAICHI_FDEM_FAST_COMPILE", "") == "1"
    if fast_compile:
        kwargs["advanced_optimization"] = False
    cache_dir = os.environ.get("TAICHI_FDEM_CACHE")
    if cache_dir:
        kwargs["offline_cache_file_path"] = cache_dir
    if _state["initialised"] and _state.get("kwargs") == kwargs:
        return
    picked = _init_on(arch, kwargs)
    _state.update(initialised=True, arch=picked, precision=precision, kwargs=kwargs, generation=_state["generation"] + 1)


GPU_ORDER = ("cuda", "vulkan", "metal")


def _init_on(arch: str, kwargs: dict) -> str:
    """ti.init on ``arch`` ("gpu": the first of :data:`GPU_ORDER` that initialises); the arch
    name it runs on.  Taichi falls back to the CPU when an arch is unavailable: that raises."""
    import sys
    for cand in (GPU_ORDER if arch == "gpu" else (arch,)):
        ti.init(**dict(kwargs, arch=getattr(ti, _ARCHS[cand])))
        if ti.cfg.arch == getattr(ti, _ARCHS[cand]):
            if arch == "gpu":
                print(f"taichi_fdem: arch='gpu' runs on {cand}", file=sys.stderr)
            return cand
    tried = ", ".join(GPU_ORDER) if arch == "gpu" else arch
    raise RuntimeError(f"fdem.init(arch={arch!r}): no usable device (tried {tried}); Taichi fell back to the CPU. "
                       "Use arch='cpu', or install the device's driver (software Vulkan: mesa-vulkan-drivers)")


def ensure_init() -> None:
    """Initialise with defaults (CPU, f64) unless :func:`init` was already called."""
    if not _state["initialised"]:
        init()


def generation() -> int:
    """How many times :func:`init` has initialised Taichi in this process (0: not yet)."""
    return _state["generation"]


def check_generation(built: int) -> None:
    """Raise a clear error when Taichi was re-initialised (by :func:`init` with other settings)
    after a simulation was built at generation ``built``: its arrays were freed with the old
    Taichi program."""
    if built != _state["generation"]:
        raise RuntimeError("this simulation was built before fdem.init(...) re-initialised Taichi with other "
                           "settings, which freed its arrays; build it again (or load it from a checkpoint)")


def is_initialised() -> bool:
    return _state["initialised"]


def precision() -> str:
    """The active precision, "f64" or "f32" (initialising with defaults if needed)."""
    ensure_init()
    return _state["precision"]


def arch() -> str:
    """The arch Taichi runs on: "cpu", "cuda", "vulkan", "metal" or "opengl" (for "gpu", the one picked)."""
    ensure_init()
    return _state["arch"]


def usable_cores() -> int:
    """CPU cores this process may use: its affinity set (``taskset``, a cpuset: containers,
    Slurm jobs, CI runners) and its cgroup CPU quota (v2 ``cpu.max``, v1 ``cpu.cfs_quota_us``),
    whichever is smaller; at least 1."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    quota = cgroup_cpu_quota()
    if quota is not None:
        cores = min(cores, max(1, int(quota)))
    return max(1, cores)


def cgroup_cpu_quota(root: str = "/sys/fs/cgroup") -> float | None:
    """The CPU quota of this process's cgroup in cores (quota / period), None without one.
    Reads cgroup v2 (``<root>/cpu.max``: "max 100000" or "150000 100000") or v1
    (``<root>/cpu/cpu.cfs_quota_us`` and ``cpu.cfs_period_us``, −1: none)."""
    def read(path):
        try:
            with open(path) as f:
                return f.read().split()
        except OSError:
            return None
    v2 = read(os.path.join(root, "cpu.max"))
    if v2 and len(v2) == 2:
        return None if v2[0] == "max" else float(v2[0]) / float(v2[1])
    quota, period = read(os.path.join(root, "cpu", "cpu.cfs_quota_us")), read(os.path.join(root, "cpu", "cpu.cfs_period_us"))
    if quota and period and float(quota[0]) > 0:
        return float(quota[0]) / float(period[0])
    return None


def cpu_threads() -> int:
    """Threads of the CPU back end (Taichi's cpu_max_num_threads)."""
    ensure_init()
    return int(ti.cfg.cpu_max_num_threads)


def real_np():
    """NumPy dtype matching the active Taichi real type."""
    return _PRECISIONS[precision()][1]


def real_ti():
    return _PRECISIONS[precision()][0]

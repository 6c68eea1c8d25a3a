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

#: The Taichi version the front-end shortcuts (:func:`_memoise_front_end`) were written for and
#: checked against (tests/test_startup.py); under any other version they are not applied.
FRONT_END_TAICHI = (1, 7, 4)
#: Taichi internals the shortcuts replace while applied: (owner, attribute) -> the original.
_front_end_originals: dict = {}


def front_end_shortcuts() -> bool:
    """Whether the front-end shortcuts of :func:`init` are applied in this process."""
    return bool(_front_end_originals)


def _set_front_end_shortcuts(on: bool) -> None:
    """Apply (under Taichi :data:`FRONT_END_TAICHI` only) or remove the front-end shortcuts."""
    if on and not _front_end_originals and tuple(getattr(ti, "__version__", ())) == FRONT_END_TAICHI:
        _memoise_front_end()
    elif not on:
        for (owner, name), original in _front_end_originals.items():
            setattr(owner, name, original)
        _front_end_originals.clear()


def _patch(owner, name, value) -> None:
    _front_end_originals.setdefault((owner, name), getattr(owner, name))
    setattr(owner, name, value)


def _memoise_front_end() -> None:
    """Make Taichi's front end do its pure source bookkeeping once per function, not per use.

    Taichi 1.7 turns every kernel's Python AST into its IR at each process start, even when the
    offline cache then supplies the compiled kernel (the cache key comes from that IR), and it
    re-reads and re-parses the source of a ``ti.func`` each time a kernel inlines it
    (``inspect.getsourcelines``, then ``textwrap`` on every line), and formats for every AST
    node a message locating it in the source (``get_pos_info``, with ``textwrap``) for its error
    messages.  Our functions are inlined into many kernels, and twice into the team kernel, so
    the same ~7,000 messages were formatted ~40,000 times and the same sources read ~700 times:
    on the 1k pile about half of the first step of a warm start.  The memos return the same
    values (so the kernels and their cache keys do not change): the source of a function object
    by that object; a position message by everything it reads (the function, its file and
    line offset, the node's type and span, the line of a block statement's first statement).
    Applied by :func:`init` (``front_end_shortcuts``) under Taichi :data:`FRONT_END_TAICHI`
    only; does nothing if Taichi's internals differ from that version's.
    """
    import functools
    import sys
    import textwrap as _textwrap
    import types
    try:
        from taichi.lang import kernel_impl
        from taichi.lang.ast.ast_transformer_utils import ASTTransformerContext
    except ImportError:            # another Taichi layout: leave it alone
        return
    original = getattr(ASTTransformerContext, "get_pos_info", None)
    if (original is None or getattr(original, "_fdem_memo", False)
            or not all(hasattr(kernel_impl, n) for n in ("getsourcefile", "getsourcelines", "textwrap"))):
        return
    memo = {}

    def get_pos_info(self, node):
        body = getattr(node, "body", None)
        first = body[0].lineno if isinstance(body, list) and body and hasattr(body[0], "lineno") else None
        key = (self.file, self.func.func.__qualname__, self.lineno_offset, self.indent, type(node).__name__,
               node.lineno, node.col_offset, getattr(node, "end_lineno", None), getattr(node, "end_col_offset", None),
               first)
        msg = memo.get(key)
        if msg is None:
            msg = memo[key] = original(self, node)
        return msg

    get_pos_info._fdem_memo = True
    get_pos_info._fdem_original = original
    _patch(ASTTransformerContext, "get_pos_info", get_pos_info)
    sourcefile, sourcelines = kernel_impl.getsourcefile, kernel_impl.getsourcelines
    files, lines = {}, {}

    def getsourcefile(obj):
        if obj not in files:
            files[obj] = sourcefile(obj)
        return files[obj]

    def getsourcelines(obj):
        if obj not in lines:
            src, start = sourcelines(obj)
            lines[obj] = (tuple(src), start)
        src, start = lines[obj]
        return list(src), start

    _patch(kernel_impl, "getsourcefile", getsourcefile)
    _patch(kernel_impl, "getsourcelines", getsourcelines)
    # kernel_impl uses textwrap.fill on each source line and textwrap.dedent on the source
    _patch(kernel_impl, "textwrap", types.SimpleNamespace(fill=functools.lru_cache(maxsize=None)(_textwrap.fill),
                                                          dedent=functools.lru_cache(maxsize=None)(_textwrap.dedent)))
    # the position messages wrap each source line and its hint at 80 columns with a new
    # TextWrapper: the same lines and hints come back for every node on them (a pure function
    # of the text at that width)
    from taichi.lang.ast import ast_transformer_utils as _atu
    if getattr(_atu, "TextWrapper", None) is _textwrap.TextWrapper:
        wrapped = {}

        class _Wrapper(_textwrap.TextWrapper):
            def wrap(self, text):
                key = (self.width, text)
                lines = wrapped.get(key)
                if lines is None:
                    lines = wrapped[key] = tuple(super().wrap(text))
                return list(lines)

        _patch(_atu, "TextWrapper", _Wrapper)
    # Taichi asks at each @ti.func / @ti.kernel whether it decorates a method by reading the
    # source of the statement that runs the frame applying the decorator (a "class" line: that
    # frame is a class body), one frame further out, ~0.5 ms each.  A frame that is a module's
    # top level (where this package applies every decorator) is not a class body
    inside = getattr(kernel_impl, "_inside_class", None)
    if callable(inside) and not getattr(inside, "_fdem_memo", False):
        def _inside_class(level_of_class_stackframe):
            try:
                if sys._getframe(level_of_class_stackframe - 1).f_code.co_name == "<module>":
                    return False
            except ValueError:
                pass
            return inside(level_of_class_stackframe + 1)      # (one frame more: this one)

        _inside_class._fdem_memo = True
        _patch(kernel_impl, "_inside_class", _inside_class)


def taichi_header() -> str:
    """Taichi's one-line start-up banner ("[Taichi] version 1.7.4, llvm ..., python ...").

    ``taichi_fdem`` imports Taichi without it (``taichi_fdem/__init__.py``); the command line
    prints it when a command starts Taichi.
    """
    import contextlib
    import io
    from taichi._lib import utils
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        utils._print_taichi_header()
    return buf.getvalue().strip()


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
    fast_compile : skip Taichi's advanced IR optimisations.  The default build already leaves
        out the CFG optimisation, the part whose compile time grew fastest (same bits, same
        speed): on the 1k-triangle pile (benchmarks/pile.py) fast_compile starts cold in 2.9 s
        instead of 3.4 s and steps ~22 % slower.  The offline cache makes later starts fast
        either way.
        Round-off differs from the default build, which can shift discrete events (the step at
        which two bodies separate): the figures of the accuracy benchmark are measured with the
        default.  None (default): on when the environment variable TAICHI_FDEM_FAST_COMPILE is
        "1".
    front_end_shortcuts : memoise the pure source bookkeeping of Taichi's front end (source
        lookups, text wrapping, error-position messages; :func:`_memoise_front_end`), which
        roughly halves the first step of a warm start.  The memos return exactly Taichi's own
        answers (tests/test_startup.py), so the kernels and their cache keys are unchanged.
        They patch five Taichi internals for the process, so they are applied only here and
        only under the Taichi version they were written for (:data:`FRONT_END_TAICHI`); under
        any other version this setting does nothing.  False removes them again.  None
        (default): on unless the environment variable TAICHI_FDEM_FRONT_END_SHORTCUTS is "0".
        Importing taichi_fdem patches nothing.
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
    if front_end_shortcuts is None:
        front_end_shortcuts = os.environ.get("TAICHI_FDEM_FRONT_END_SHORTCUTS", "") != "0"
    _set_front_end_shortcuts(bool(front_end_shortcuts))
    kwargs = dict(arch=getattr(ti, _ARCHS[arch]), default_fp=_PRECISIONS[precision][0], default_ip=ti.i32,
                  offline_cache=offline_cache, debug=debug, log_level=os.environ.get("TI_LOG_LEVEL", ti.WARN),
                  # Taichi's CFG optimisation (store-to-load forwarding and dead-store elimination over
                  # the control-flow graph) grows faster than linearly with the size of a kernel: off,
                  # the 1k pile's cold start fell from 18.7 s to 3.9 s (serial) and from 36 s to 6.1 s
                  # (parallel, detection inside the team launch), and the steps ran as fast (within
                  # 3 %, the noise) to the same bits (LLVM's own passes do the same work)
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
    from taichi.lang import impl
    for cand in (GPU_ORDER if arch == "gpu" else (arch,)):
        ti.init(**dict(kwargs, arch=getattr(ti, _ARCHS[cand])))
        if impl.current_cfg().arch == getattr(ti, _ARCHS[cand]):
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
    from taichi.lang import impl
    return int(impl.current_cfg().cpu_max_num_threads)


def real_np():
    """NumPy dtype matching the active Taichi real type."""
    return _PRECISIONS[precision()][1]


def real_ti():
    return _PRECISIONS[precision()][0]

"""The ``taichi-fdem`` command line.

::

    taichi-fdem run SCENE.toml [--duration S] [--video PATH | --no-video] [--vtu DIR] [--from CHECKPOINT]
    taichi-fdem sweep SWEEP.toml [--workers N] [--output CSV] [--scheduler tcp://host:port] [--no-resume]
    taichi-fdem demo [NAME] [demo arguments ...]
    taichi-fdem info

Exit codes: 0 success, 2 bad input (the message on stderr names the file, key or argument;
no traceback), 1 the simulation failed (unstable run, a failing demo check, or points of a
sweep that did not succeed).  ``--traceback`` shows the Python traceback of a failure.
"""
from __future__ import annotations

import argparse
import importlib.util
import math
import os
import sys
import time

EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT = 0, 1, 2
# the documentation's scene-file reference (every key, its unit and default)
SCENEFILE_DOCS = "the Scene-file reference page of the documentation (docs/reference/scenefile.md)."


class _BadInput(Exception):
    """Bad input found by the CLI itself (exit code 2)."""


def _demos_dir() -> str | None:
    """The demos/ folder next to the package (a source checkout), or None."""
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    d = os.path.join(here, "demos")
    return d if os.path.isdir(d) else None


def _demo_names(folder: str) -> list[str]:
    return sorted(f[:-3] for f in os.listdir(folder) if f.endswith(".py") and not f.startswith("_"))


def _init(args) -> None:
    """Start Taichi for a command that steps or builds a simulation, with its version line on stderr.

    Importing the package prints no banner (``taichi_fdem/__init__.py``), so ``--help``,
    ``--version`` and bad arguments print only what they are about; the line appears here, once,
    when a command starts Taichi (with the arch Taichi chose, on stderr, so that stdout holds only
    the command's own output).  ``fdem.init`` starts it at log level warning (or ``TI_LOG_LEVEL``).
    """
    import contextlib
    import io
    from . import backend
    if not backend.is_initialised():
        said = io.StringIO()                 # Taichi's "[Taichi] Starting on arch=x64" line
        with contextlib.redirect_stdout(said):
            backend.init(arch=args.arch, precision=args.precision)
        arch = said.getvalue().strip().rpartition("arch=")[2]
        print(backend.taichi_header() + (f", arch {arch}" if arch else ""), file=sys.stderr)


def _fmt_energy(e: dict) -> str:
    """One line per term of ``total`` as it enters it (work done on the system with its minus sign),
    so that the printed terms add up to the printed total."""
    from .sim.energies import OPTIONAL_TERMS, TOTAL_TERMS
    lines = [f"    {('- ' if sign < 0 else '') + k:<16} {sign * float(e[k]):+.6e} J"
             for k, sign in TOTAL_TERMS + OPTIONAL_TERMS if k in e]
    lines.append(f"    {'total':<16} {float(e['total']):+.6e} J")
    return "\n".join(lines)


# ----------------------------------------------------------------------------------------------
def cmd_run(args) -> int:
    from .io import scenefile
    spec = scenefile.load(args.scene)
    if spec.lab:
        return _run_lab(spec, args)
    if args.duration is not None:
        if not (math.isfinite(args.duration) and args.duration >= 0):
            raise _BadInput(f"--duration must be a finite time >= 0 s, got {args.duration}")
        spec.solver["duration"] = args.duration
    if args.no_video:
        spec.output["video"] = None
    elif args.video:
        spec.output["video"] = args.video
    if args.vtu:
        if importlib.util.find_spec("taichi_fdem.io.vtu") is None:
            raise _BadInput("--vtu needs taichi_fdem.io.vtu, which this version does not have")
        spec.output["vtu"] = args.vtu
    _init(args)
    sim, settings = spec.build()
    if args.resume_from:
        from .io.checkpoint import CheckpointError
        from .sim.simulation import Simulation
        try:
            sim = Simulation.load(args.resume_from)
        except FileNotFoundError:
            raise _BadInput(f"--from: no checkpoint file {args.resume_from!r}") from None
        except CheckpointError as exc:
            raise _BadInput(f"--from: {exc}") from None
        print(f"resumed from {args.resume_from} at t = {sim.time:.6g} s (step {sim.step_count:,})")
    info = sim.info()
    print(f"{os.path.basename(args.scene)}: {len(sim.bodies)} bodies, {info['triangles']} triangles, "
          f"{info['nodes']} nodes; dt = {sim.dt:.4g} s (stable limit {sim.model.dt_limit:.4g} s), "
          f"{settings.duration:g} s simulated ({int(round(settings.duration / sim.dt)):,} steps), "
          f"strategy {info['strategy']}, {info['precision']}", flush=True)
    e0 = sim.energies()
    t0 = time.perf_counter()
    settings.run(sim, progress=False if args.no_progress else None)
    wall = time.perf_counter() - t0
    e1 = sim.energies()
    print(f"done: t = {sim.time:.6g} s, {sim.step_count:,} steps in {wall:.2f} s wall "
          f"({sim.step_count / max(wall, 1e-9):,.0f} steps/s), {sim.solver.couple_count} contact couples")
    print("  energies at the end:")
    print(_fmt_energy(e1))
    drift = e1["total"] - e0["total"]
    scale = max(abs(e0["kinetic"]) + abs(e0["strain"]) + abs(e0["gravity"]), 1e-300)
    print(f"  total energy change {drift:+.3e} J ({100 * drift / scale:+.3f} % of the initial |energy|)")
    for label, path in (("video", settings.video), ("VTU series", settings.vtu), ("checkpoint", settings.checkpoint),
                        ("crack events", getattr(settings, "crack_events", None))):
        if path:
            print(f"  wrote {label}: {path}")
    return EXIT_OK


def _run_lab(spec, args) -> int:
    """``taichi-fdem run`` of a scene file with a ``[lab]`` table: the test and its summary."""
    for flag, name in (("duration", "--duration"), ("video", "--video"), ("vtu", "--vtu"), ("resume_from", "--from")):
        if getattr(args, flag, None) is not None:
            raise _BadInput(f"{name} does not apply to a [lab] scene file (the test sets its own run)")
    _init(args)
    lab = spec.lab
    print(f"{os.path.basename(args.scene)}: lab test {lab['test']!r} of material {lab['material']!r}", flush=True)
    t0 = time.perf_counter()
    r = spec.run_lab()
    wall = time.perf_counter() - t0
    for k, v in r.summary.items():
        print(f"  {k:<18} {v:.6g}" if isinstance(v, float) else f"  {k:<18} {v}")
    print(f"done in {wall:.2f} s wall")
    if lab.get("csv"):
        print(f"  wrote curve: {lab['csv']}")
    return EXIT_OK


def cmd_sweep(args) -> int:
    from . import sweep as fsweep
    sw, opts = fsweep.load(args.sweep_file)
    if args.workers is not None:
        if args.workers < 1:
            raise _BadInput(f"--workers must be >= 1, got {args.workers}")
        opts["workers"] = args.workers
    if args.output:
        opts["output"] = args.output
    if args.scheduler:
        opts["scheduler"] = args.scheduler
    if args.no_resume:
        opts["resume"] = False
    where = f"Dask scheduler {opts['scheduler']}" if opts["scheduler"] else f"{opts['workers']} local worker processes"
    print(f"sweep {os.path.basename(args.sweep_file)}: {len(sw)} points on {where} -> {opts['output']}", flush=True)

    def report(row, done, total):
        params = ", ".join(f"{k}={row[k]}" for k in sw.param_cols)
        extra = f": {row['error'][:200]}" if row["status"] != "ok" else ""
        print(f"  [{done}/{total}] {params}: {row['status']} ({float(row['wall_s']):.1f} s){extra}", flush=True)

    rows = sw.run(workers=opts["workers"], output=opts["output"], resume=opts["resume"],
                  scheduler=opts["scheduler"], timeout=opts["timeout"], on_result=report)
    if sw.skipped:
        print(f"  {sw.skipped} points already done in {opts['output']} (resumed)")
    bad = [r for r in rows if r["status"] != "ok"]
    print(f"done: {len(rows) - len(bad)} ok, {len(bad)} not ok; table {opts['output']}")
    return EXIT_FAILURE if bad else EXIT_OK


def cmd_demo(args) -> int:
    folder = _demos_dir()
    if folder is None:
        raise _BadInput("the demos are not installed with the package: they are the demos/ folder of the "
                        "source repository (run taichi-fdem from a source checkout, or python demos/NAME.py)")
    names = _demo_names(folder)
    if not args.name:
        print("available demos (taichi-fdem demo NAME [--short] ...):")
        for n in names:
            doc = _first_doc_line(os.path.join(folder, n + ".py"))
            print(f"  {n:<16} {doc}")
        return EXIT_OK
    if args.name not in names:
        import difflib
        close = difflib.get_close_matches(args.name, names, n=1)
        raise _BadInput(f"no demo named {args.name!r}" + (f" (did you mean {close[0]!r}?)" if close else "")
                        + f"; available: {', '.join(names)}")
    if folder not in sys.path:
        sys.path.insert(0, folder)        # the demos import their shared module _common
    spec = importlib.util.spec_from_file_location(f"demo_{args.name}", os.path.join(folder, args.name + ".py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    if not hasattr(mod, "main"):
        raise _BadInput(f"demo {args.name!r} has no main()")
    try:
        mod.main(list(args.demo_args))
    except SystemExit as exc:            # the demo's own argparse (e.g. --help, a bad option)
        return exc.code if isinstance(exc.code, int) else (EXIT_OK if exc.code is None else EXIT_BAD_INPUT)
    except AssertionError as exc:
        print(f"taichi-fdem demo {args.name}: the physics check failed: {exc}", file=sys.stderr)
        return EXIT_FAILURE
    return EXIT_OK


def _first_doc_line(path: str) -> str:
    import ast
    try:
        with open(path, encoding="utf-8") as f:
            doc = ast.get_docstring(ast.parse(f.read())) or ""
    except (OSError, SyntaxError):
        return ""
    return doc.strip().splitlines()[0] if doc.strip() else ""


def cmd_info(args) -> int:
    import platform
    import taichi as ti
    from . import __version__, backend
    _init(args)
    threads = backend.usable_cores()
    optional = []
    for mod, extra in (("dask.distributed", "distributed"), ("matplotlib", "plot")):
        try:
            ok = importlib.util.find_spec(mod) is not None
        except ImportError:
            ok = False
        optional.append(f"{mod.split('.')[0]} {'yes' if ok else 'no (pip install taichi-fdem[' + extra + '])'}")
    demos = _demos_dir()
    print(f"taichi_fdem   {__version__}")
    print(f"taichi        {'.'.join(map(str, ti.__version__))}")
    print(f"python        {platform.python_version()} ({sys.executable})")
    print(f"arch          {backend.arch()}")
    print(f"precision     {backend.precision()}")
    print(f"cpu threads   {threads} usable of {os.cpu_count()}")
    print(f"optional      {', '.join(optional)}")
    print(f"demos         {demos if demos else 'not installed (source checkout only)'}")
    return EXIT_OK


# ----------------------------------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="taichi-fdem",
        description="2D combined finite-discrete element simulations on Taichi: run scene files, "
                    "parameter sweeps and demos.",
        epilog=f"Exit codes: 0 ok, 1 simulation failure, 2 bad input.  Scene and sweep file keys, units "
               f"and defaults: {SCENEFILE_DOCS}")
    from . import __version__
    ap.add_argument("--version", action="version", version=f"taichi-fdem {__version__}")
    ap.add_argument("--traceback", action="store_true", help="show Python tracebacks of failures")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--arch", default="cpu", choices=("cpu", "cuda", "gpu", "vulkan", "metal", "opengl"),
                        help="Taichi back end (default cpu; only cpu is tested)")
    common.add_argument("--precision", default="f64", choices=("f64", "f32"), help="real type (default f64)")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("run", parents=[common], help="run a scene file (TOML)",
                       description="Run a scene file: progress bar, video and VTU output as its [output] table "
                                   "says; prints a summary and the energy account.")
    p.add_argument("scene", metavar="SCENE.toml", help="the scene file")
    p.add_argument("--duration", type=float, help="simulated time [s] (overrides [solver] duration)")
    p.add_argument("--from", dest="resume_from", metavar="CHECKPOINT",
                   help="continue from a checkpoint (Simulation.save) instead of the scene's initial state; "
                        "the scene file still gives the outputs and the duration to run")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--video", help="video path (.mp4, .gif or a folder of PNGs; overrides [output] video)")
    g.add_argument("--no-video", action="store_true", help="write no video")
    p.add_argument("--vtu", help="folder of a VTU series (overrides [output] vtu)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("sweep", parents=[common], help="run a parameter sweep file (TOML)",
                       description="Run a sweep file ([sweep] scene, axes or points, metrics): one CSV row per "
                                   "point, appended as points complete; re-running resumes.")
    p.add_argument("sweep_file", metavar="SWEEP.toml", help="the sweep file")
    p.add_argument("--workers", type=int, help="local worker processes (overrides [sweep] workers)")
    p.add_argument("--output", help="CSV path (overrides [sweep] output)")
    p.add_argument("--scheduler", help="Dask scheduler address tcp://host:port (needs taichi-fdem[distributed])")
    p.add_argument("--no-resume", action="store_true", help="overwrite the CSV instead of resuming")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("demo", help="run a demo from the demos/ folder (no NAME: list them)",
                       description="Run demos/NAME.py (source checkout); further arguments go to the demo, "
                                   "e.g. taichi-fdem demo pile --short.")
    p.add_argument("name", nargs="?", metavar="NAME", help="demo name; omit to list the demos")
    p.add_argument("demo_args", nargs=argparse.REMAINDER, metavar="...", help="arguments of the demo")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("info", parents=[common], help="versions, Taichi arch, precision, CPU threads",
                       description="Print the versions of taichi_fdem, Taichi and Python, the Taichi arch and "
                                   "precision, the CPU threads and the optional extras installed.")
    p.set_defaults(func=cmd_info)
    return ap


def main(argv=None) -> int:
    """Entry point of the ``taichi-fdem`` console script; returns the exit code."""
    ap = build_parser()
    args = ap.parse_args(argv)
    if args.command is None:
        ap.print_help()
        return EXIT_BAD_INPUT
    from .io.scenefile import SceneFileError
    from .sim.simulation import SimulationError
    from .sweep import SweepError
    try:
        return args.func(args)
    except (SceneFileError, SweepError, _BadInput) as exc:
        print(f"taichi-fdem {args.command}: error: {exc}", file=sys.stderr)
        if args.traceback:
            raise
        return EXIT_BAD_INPUT
    except SimulationError as exc:
        print(f"taichi-fdem {args.command}: the simulation failed: {exc}", file=sys.stderr)
        if args.traceback:
            raise
        return EXIT_FAILURE
    except KeyboardInterrupt:
        print(f"taichi-fdem {args.command}: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 -- a clear message instead of a traceback; --traceback shows it
        print(f"taichi-fdem {args.command}: failed: {type(exc).__name__}: {exc} (--traceback for details)",
              file=sys.stderr)
        if args.traceback:
            raise
        return EXIT_FAILURE


if __name__ == "__main__":
    sys.exit(main())

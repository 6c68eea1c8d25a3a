"""Sweep files: :func:`load` reads a ``[sweep]`` TOML table (base scene file, axes or points,
metrics, run options) into a :class:`~taichi_fdem.sweep.Sweep`, with errors that name the file,
the line and the key.
"""
from __future__ import annotations

import os

from .metrics import registry_metrics
from .params import SweepError
from .runner import Sweep

__all__ = ["load"]


# ----------------------------------------------------------------------------------------------
# sweep files
# ----------------------------------------------------------------------------------------------
SWEEP_KEYS = ("scene", "output", "workers", "metrics", "duration", "scheduler", "timeout", "resume", "axes", "points")


def load(path) -> tuple[Sweep, dict]:
    """Read a sweep file; returns (Sweep, run options {output, workers, scheduler, timeout, resume}).

    Format (paths read are relative to the sweep file, the output to the working directory)::

        [sweep]
        scene = "pile_small.toml"           # the base scene file (required)
        output = "out/sweep.csv"            # [<sweep file name>.csv]
        workers = 2                         # local worker processes [2]
        metrics = ["time", "energies", "displacement:disk1"]   # names of METRICS [time, steps, energies]
        duration = 0.1                      # s [the scene's solver.duration]
        scheduler = "tcp://10.0.0.5:8786"   # a Dask scheduler [none: local processes]
        timeout = 600.0                     # s per point, local runs [none]
        resume = true                       # skip points already ok in the output [true]

        [sweep.axes]                        # a grid: dotted keys into the scene file
        "materials.rock.friction" = [0.2, 0.4, 0.6]
        "solver.safety" = [0.1, 0.2]

        # or, instead of [sweep.axes], an explicit list:
        # [[sweep.points]]
        # "materials.rock.friction" = 0.2
    """
    from ..io import scenefile, toml_check
    path = os.fspath(path)
    try:
        data, text = scenefile.read_toml(path)
    except scenefile.SceneFileError as exc:
        raise SweepError(str(exc)) from None
    ck = toml_check._Checker(path, text)
    top = [k for k in data if k != "sweep"]
    if top:
        raise SweepError(str(ck.error((top[0],), f"unknown table {top[0]!r}{toml_check._suggest(top[0], ['sweep'])}; "
                                      f"a sweep file has one [sweep] table", table=())))
    s = data.get("sweep")
    if not isinstance(s, dict):
        raise SweepError(f"{path}: no [sweep] table (scene = \"file.toml\", [sweep.axes] or [[sweep.points]], metrics, ...)")
    sp = ("sweep",)
    for key in s:
        if key not in SWEEP_KEYS:
            raise SweepError(str(ck.error(sp + (key,), f"unknown key {key!r}{toml_check._suggest(key, SWEEP_KEYS)}; "
                                          f"allowed keys: {', '.join(SWEEP_KEYS)}")))
    K = toml_check._Key
    try:
        v = {
            "scene": ck.value(s, "scene", K("str", required=True), sp),
            "output": ck.value(s, "output", K("str"), sp),
            "workers": ck.value(s, "workers", K("int", 2, lo=1), sp),
            "duration": ck.value(s, "duration", K("float", unit="s", lo=0.0), sp),
            "scheduler": ck.value(s, "scheduler", K("str"), sp),
            "timeout": ck.value(s, "timeout", K("float", unit="s", lo=0.0, lo_open=True), sp),
            "resume": ck.value(s, "resume", K("bool", True), sp),
        }
    except scenefile.SceneFileError as exc:
        raise SweepError(str(exc)) from None
    scene = v["scene"] if os.path.isabs(v["scene"]) else os.path.join(os.path.dirname(os.path.abspath(path)), v["scene"])
    if not os.path.isfile(scene):
        raise SweepError(str(ck.error(sp + ("scene",), f"scene file {v['scene']!r} not found (looked for {scene}; "
                                      f"paths are relative to the sweep file's folder)")))
    axes, points = _axes_or_points(ck, s, sp)
    metrics = s.get("metrics", ["time", "steps", "energies"])
    where_m = ck.where(sp + ("metrics",))
    try:
        spec = scenefile.load(scene)
    except scenefile.SceneFileError as exc:
        raise SweepError(f"{ck.where(sp + ('scene',))}: [sweep] scene: {exc}") from None
    metrics = registry_metrics(metrics, spec.body_names, where=f"{where_m}: [sweep] metrics")
    try:
        sweep = Sweep(scene, axes=axes, points=points, metrics=metrics, duration=v["duration"])
    except SweepError as exc:
        key = "axes" if axes is not None else "points"
        raise SweepError(f"{ck.where(sp + (key,))}: [sweep.{key}] {exc}") from None
    output = v["output"] or os.path.splitext(os.path.basename(path))[0] + ".csv"
    return sweep, {"output": output, "workers": v["workers"], "scheduler": v["scheduler"],
                   "timeout": v["timeout"], "resume": v["resume"]}


def _axes_or_points(ck, s: dict, sp: tuple):
    """(axes, None) from the ``[sweep.axes]`` table of the ``[sweep]`` table ``s``, or (None,
    points) from its ``[[sweep.points]]``; SweepError naming the file and line (checker ``ck``,
    table path ``sp``) unless there is exactly one of them, well formed."""
    if ("axes" in s) == ("points" in s):
        raise SweepError(str(ck.error(sp, "give exactly one of [sweep.axes] (a grid) or [[sweep.points]] (a list)",
                                      table=sp)))
    if "axes" in s:
        axes = s["axes"]
        if not isinstance(axes, dict) or not axes:
            raise SweepError(str(ck.error(sp + ("axes",), "[sweep.axes] must be a table of \"dotted.key\" = [values]")))
        for k, vals in axes.items():
            if not isinstance(vals, list) or not vals:
                raise SweepError(str(ck.error(sp + ("axes", k), f"axis {k!r} must be a non-empty list of values, "
                                              f"got {vals!r}", table=sp + ("axes",))))
        return axes, None
    points = s["points"]
    if not isinstance(points, list) or not points or not all(isinstance(p, dict) for p in points):
        raise SweepError(str(ck.error(sp + ("points",), "points must be an array of tables [[sweep.points]]")))
    return None, points

"""The tables that say how a scene runs: ``[checks]``, ``[solver]`` and ``[output]`` (the
recorders: video, VTU series, checkpoint, crack events, history)."""
from __future__ import annotations

from ..toml_check import SceneFileError
from .keys import CHECK_KEYS, OUTPUT_KEYS, SOLVER_KEYS


def _checks_table(ck, data: dict) -> dict:
    """The resolved ``[checks]`` table (defaults when absent)."""
    checks_t = ck.table(data.get("checks", {}), ("checks",), "energy, energy_tol, max_penetration, every")
    ck.keys(checks_t, CHECK_KEYS, ("checks",))
    return ck.values(checks_t, CHECK_KEYS, ("checks",))


def _solver_table(ck, data: dict) -> dict:
    """The resolved ``[solver]`` table; ``duration`` is required."""
    solver_t = ck.table(data.get("solver", {}), ("solver",), "duration, dt, safety, ...")
    ck.keys(solver_t, SOLVER_KEYS, ("solver",))
    if "duration" not in solver_t:
        raise SceneFileError(f"{ck.where(('solver',))}: [solver] missing required key 'duration' "
                             f"(simulated time of the run, s)")
    return ck.values(solver_t, SOLVER_KEYS, ("solver",))


def _output_table(ck, data: dict) -> dict:
    """The resolved ``[output]`` table; each key that needs another one (or a module) is checked."""
    output_t = ck.table(data.get("output", {}), ("output",), "video, fps, vtu, ...")
    ck.keys(output_t, OUTPUT_KEYS, ("output",))
    output = ck.values(output_t, OUTPUT_KEYS, ("output",))
    if output["vtu"] is not None:
        import importlib.util
        if importlib.util.find_spec("taichi_fdem.io.vtu") is None:
            raise ck.error(("output", "vtu"), "VTU output needs taichi_fdem.io.vtu, which this version does not have")
    if output["checkpoint"] is not None:
        from ...sim.simulation import Simulation
        if not hasattr(Simulation, "save"):
            raise ck.error(("output", "checkpoint"), "checkpoints need Simulation.save, which this version does not have")
    if "cracks" in output_t and output["cracks"] and output["video"] is None:
        raise ck.error(("output", "cracks"), "cracks = true draws the broken joints on the video: it needs video = \"...\"")
    if output["color_by"] == "fluid_pressure" and "fluid" not in data:
        raise ck.error(("output", "color_by"), "color_by = \"fluid_pressure\" colours the fluid in the fractures: "
                       "it needs a [fluid] table")
    if output["color_by"] == "temperature" and "temperature" not in data and not data.get("heat"):
        raise ck.error(("output", "color_by"), "color_by = \"temperature\" colours the temperatures: it needs a "
                       "[temperature] table or [[heat]] rows")
    if "history_every" in output_t and output["history"] is None:
        raise ck.error(("output", "history_every"), "history_every needs history = \"file.csv\"")
    if "vtu_every" in output_t and output["vtu"] is None:
        raise ck.error(("output", "vtu_every"), "vtu_every needs vtu = \"folder\"")
    return output

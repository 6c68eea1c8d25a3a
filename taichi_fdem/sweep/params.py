"""Sweep parameters and their CSV text: :class:`SweepError`, :func:`group_params` and the cell
codec that makes the same value always write the same text (so that resume can match points).
"""
from __future__ import annotations

import json
import math

__all__ = ["SweepError", "group_params", "STATUS_COLUMNS", "SOLVER_BUILD_KEYS"]


STATUS_COLUMNS = ("status", "error", "wall_s", "worker")
SOLVER_BUILD_KEYS = ("dt", "safety", "buffer", "strategy", "force_dt", "check_overlap")


class SweepError(ValueError):
    """A sweep definition (Python arguments or a sweep file) was refused; the message names it."""


# ----------------------------------------------------------------------------------------------
# parameters
# ----------------------------------------------------------------------------------------------
def group_params(params: dict) -> dict:
    """Split dotted keys by their prefix: {"material.friction": 0.3, "solver.safety": 0.1, "x": 1}
    → {"material": {"friction": 0.3}, "solver": {"safety": 0.1}, "": {"x": 1}}.

    The groups "material", "contact" and "solver" are always present (possibly empty).
    """
    out: dict = {"material": {}, "contact": {}, "solver": {}}
    for key, value in params.items():
        head, _, rest = key.partition(".")
        if rest:
            out.setdefault(head, {})[rest] = value
        else:
            out.setdefault("", {})[key] = value
    return out


def _plain(v):
    """NumPy scalars and arrays to plain Python values (for pickling and the CSV)."""
    if hasattr(v, "tolist") and not isinstance(v, (str, bytes)):
        return v.tolist()
    return v


def _cell(v) -> str:
    """The CSV text of a value: the same text for the same value, so that resume can match points."""
    v = _plain(v)
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, (int, str)):
        return str(v)
    return json.dumps(v)


def _parse_cell(s: str):
    """Inverse of :func:`_cell` where it can be (numbers back to int / float)."""
    if s == "":
        return None
    if s in ("true", "false"):
        return s == "true"
    for conv in (int, float):
        try:
            return conv(s)
        except ValueError:
            pass
    if s[:1] in "[{":
        try:
            return json.loads(s)
        except ValueError:
            pass
    return s


def _check_value(where: str, v) -> None:
    v = _plain(v)
    if isinstance(v, bool) or isinstance(v, (int, str)):
        return
    if isinstance(v, float):
        if not math.isfinite(v):
            raise SweepError(f"{where}: values must be finite, got {v!r}")
        return
    if isinstance(v, (list, tuple)) and all(isinstance(c, (int, float)) and not isinstance(c, bool) for c in v):
        return
    raise SweepError(f"{where}: a value must be a number, a string, a boolean or a list of numbers, got {v!r}")

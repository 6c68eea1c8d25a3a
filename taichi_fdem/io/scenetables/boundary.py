"""The tables that act on regions of the bodies: ``[[constraints]]``, ``[[loads]]``,
``[[initial_stress]]`` and ``[[excavate]]``, each checked into one resolved dict per table."""
from __future__ import annotations

from ..toml_check import _suggest
from .common import _array, _check_region, _known_body, _known_curve
from .keys import CONSTRAINT_KEYS, EXCAVATE_KEYS, INITIAL_STRESS_KEYS, LOAD_KEYS, LOAD_VALUE


def _constraint_tables(ck, data: dict, names, curves: dict) -> list:
    """One resolved dict per ``[[constraints]]``: a region and vx and/or vy."""
    cons_t = data.get("constraints", [])
    if not isinstance(cons_t, list):
        raise ck.error(("constraints",), "constraints must be an array of tables [[constraints]]", table=())
    constraints = []
    for k, ct in enumerate(cons_t):
        cp = ("constraints", k)
        ck.table(ct, cp, "a box selector and a velocity")
        ck.keys(ct, CONSTRAINT_KEYS, cp)
        c = ck.values(ct, CONSTRAINT_KEYS, cp)
        _check_region(ck, c, cp, "the region of nodes to constrain")
        if c["curve"] is not None:
            _known_curve(ck, curves, c["curve"], cp + ("curve",))
        if c["vx"] is None and c["vy"] is None:
            raise ck.error(cp, "give vx and/or vy [m/s] (an absent component stays free)", table=cp)
        if c["body"] is not None and c["body"] not in names:
            raise ck.error(cp + ("body",), f"unknown body {c['body']!r}{_suggest(c['body'], names)}")
        constraints.append(c)
    return constraints


def _load_tables(ck, data: dict, names, curves: dict) -> list:
    """One resolved dict per ``[[loads]]``: its kind with that kind's value, a region, a curve."""
    out = []
    for k, t in enumerate(_array(ck, data, "loads", "kind, its value and a region")):
        p = ("loads", k)
        ck.table(t, p, "a load")
        ck.keys(t, LOAD_KEYS, p)
        c = ck.values(t, LOAD_KEYS, p)
        need = LOAD_VALUE[c["kind"]]
        for v in ("pressure", "traction", "force"):
            if v != need and v in t:
                raise ck.error(p + (v,), f"a {c['kind']!r} load takes " + (f"{need!r}" if need else "no value")
                               + f", not {v!r}")
        if need is not None and c[need] is None:
            raise ck.error(p, f"a {c['kind']!r} load needs {need!r} [{LOAD_KEYS[need].unit}]", table=p)
        if c["kind"] == "absorbing" and c["curve"] is not None:
            raise ck.error(p + ("curve",), "an absorbing boundary takes no curve")
        _check_region(ck, c, p, "the region of the loaded nodes: an edge is loaded when both its nodes are in it")
        _known_body(ck, names, c, p)
        if c["curve"] is not None:
            _known_curve(ck, curves, c["curve"], p + ("curve",))
        out.append(c)
    return out


def _initial_stress_tables(ck, data: dict, names) -> list:
    """One resolved dict per ``[[initial_stress]]``."""
    out = []
    for k, t in enumerate(_array(ck, data, "initial_stress", "sxx, syy, sxy")):
        p = ("initial_stress", k)
        ck.table(t, p, "an initial stress")
        ck.keys(t, INITIAL_STRESS_KEYS, p)
        c = ck.values(t, INITIAL_STRESS_KEYS, p)
        if c["gradient"] is not None and len(c["gradient"]) not in (2, 3):
            raise ck.error(p + ("gradient",), f"gradient must be [dsxx/dy, dsyy/dy] or [dsxx/dy, dsyy/dy, dsxy/dy] "
                           f"[Pa/m], got {c['gradient']!r}")
        _known_body(ck, names, c, p)
        out.append(c)
    return out


def _excavate_tables(ck, data: dict, names) -> list:
    """One resolved dict per ``[[excavate]]``: a body and/or a region, the tables in order of time."""
    out = []
    for k, t in enumerate(_array(ck, data, "excavate", "time and the body and/or region removed")):
        p = ("excavate", k)
        ck.table(t, p, "an excavation")
        ck.keys(t, EXCAVATE_KEYS, p)
        c = ck.values(t, EXCAVATE_KEYS, p)
        has_region = _check_region(ck, c, p, "", required=False)
        if not has_region and c["body"] is None:
            raise ck.error(p, "give body and/or a region (xmin, ..., r_max) of triangle centroids to remove",
                           table=p)
        _known_body(ck, names, c, p)
        out.append(c)
    times = [c["time"] for c in out]
    if times != sorted(times):
        raise ck.error(("excavate", next(i for i in range(1, len(times)) if times[i] < times[i - 1]), "time"),
                       "[[excavate]] tables must come in order of time")
    return out


def _excavations_within(ck, excavations: list, duration: float) -> None:
    """Every ``[[excavate]]`` time is within the run's ``duration`` [s]."""
    for k, e in enumerate(excavations):
        if e["time"] > duration:
            raise ck.error(("excavate", k, "time"), f"time ({e['time']} s) is after the end of the run "
                           f"([solver] duration = {duration} s)")

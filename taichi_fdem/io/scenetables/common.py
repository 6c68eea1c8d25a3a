"""Values shared by several tables of a scene file: regions, edge selectors, joint-strength
spreads and references to named curves and bodies, checked with a
:class:`~taichi_fdem.io.toml_check._Checker` (``ck``) into resolved dicts; :func:`strength_of`
makes the ``strength=`` object of a resolved table.
"""
from __future__ import annotations

from ..toml_check import _Key, _suggest
from .keys import _BOUNDS, REGION_KEYS


def _check_region(ck, c: dict, path: tuple, what: str, required: bool = True) -> bool:
    """Check the region keys of the resolved table ``c``; True when it has a bound."""
    if all(c[k] is None for k in _BOUNDS):
        if c.get("center") is not None:
            raise ck.error(path + ("center",), "center needs r_min and/or r_max [m] (the ring about it)")
        if required:
            raise ck.error(path, f"give at least one of xmin, xmax, ymin, ymax, r_min, r_max [m] ({what})", table=path)
        return False
    for lo, hi in (("xmin", "xmax"), ("ymin", "ymax"), ("r_min", "r_max")):
        if c[lo] is not None and c[hi] is not None and c[lo] > c[hi]:
            raise ck.error(path + (lo,), f"{lo} ({c[lo]} m) must be <= {hi} ({c[hi]} m)")
    if c.get("center") is not None and c["r_min"] is None and c["r_max"] is None:
        raise ck.error(path + ("center",), "center needs r_min and/or r_max [m] (the ring about it)")
    return True


def region_of(c: dict):
    """The region keys of a resolved table (None where absent)."""
    return {k: c.get(k) for k in REGION_KEYS}


_EDGE_TABLE_KEYS = {**REGION_KEYS, "lines": _Key("polylines", unit="m"), "line_group": _Key("str")}


def _edge_table(ck, t, path: tuple, keys=None) -> dict:
    """A resolved edge table: exactly one of a region of edge midpoints, ``lines`` or ``line_group``."""
    keys = _EDGE_TABLE_KEYS if keys is None else keys
    ck.table(t, path, "a region (xmin, ..., r_max), lines = [[[x, y], ...], ...] or line_group = \"NAME\"")
    ck.keys(t, keys, path)
    v = ck.values(t, keys, path)
    other = [k for k in ("lines", "line_group") if v.get(k) is not None]
    has_region = _check_region(ck, v, path, "the region of edge midpoints", required=not other)
    if len(other) + has_region > 1:
        raise ck.error(path + (other[-1],), "give one of a region (xmin, ..., r_max), lines or line_group",
                       table=path)
    return v


def _edge_selector(ck, value, path: tuple):
    """``fracture``: true/false, "interfaces", a table (a region of edge midpoints or lines) or a list of
    "interfaces" and tables; returned checked (tables resolved)."""
    if isinstance(value, bool):
        return value
    if value == "interfaces":
        return value
    if isinstance(value, dict):
        return _edge_table(ck, value, path)
    if isinstance(value, list) and value and all(v == "interfaces" or isinstance(v, dict) for v in value):
        return [v if v == "interfaces" else _edge_table(ck, v, path + (i,)) for i, v in enumerate(value)]
    raise ck.error(path, f"{path[-1]} must be true, false, \"interfaces\", a table {{xmin = ..., r_max = ...}} or "
                   f"{{lines = [...]}}, or a list of these, got {value!r}")


def _cracks(ck, value, path: tuple):
    """``cracks``: polylines in the mesh's coordinates, or a region table (or a list of them) of
    edge midpoints in placed coordinates.  Returns (polylines or None, region list or None)."""
    if value is None:
        return None, None
    if isinstance(value, dict):
        value = [value]
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        keys = {**REGION_KEYS, "line_group": _Key("str")}
        return None, [_edge_table(ck, t, path + (i,) if len(value) > 1 else path, keys) for i, t in enumerate(value)]
    return ck.value({path[-1]: value}, path[-1], _Key("polylines", unit="m"), path[:-1]), None


def _strength_keys(ck, raw: dict, v: dict, path: tuple) -> None:
    """The joint-strength spread keys of a table: weibull_modulus or strength_cov, not both;
    strength_seed and strength_scale_energy need one of them, strength_floor needs strength_cov."""
    if v["weibull_modulus"] is not None and v["strength_cov"] is not None:
        raise ck.error(path + ("strength_cov",), "give either weibull_modulus or strength_cov, not both")
    for k in ("strength_seed", "strength_scale_energy"):
        if k in raw and v["weibull_modulus"] is None and v["strength_cov"] is None:
            raise ck.error(path + (k,), f"{k} needs weibull_modulus or strength_cov")
    if "strength_floor" in raw and v["strength_cov"] is None:
        raise ck.error(path + ("strength_floor",), "strength_floor is the truncation of strength_cov: it needs "
                       "strength_cov")


def strength_of(v: dict):
    """The ``strength=`` of the resolved body or joint-set table ``v`` (None without one)."""
    from ...discontinuity import NormalStrength, Weibull
    if v.get("weibull_modulus") is not None:
        return Weibull(v["weibull_modulus"], seed=v["strength_seed"],
                       scale_energy=v.get("strength_scale_energy") or False)
    if v.get("strength_cov") is not None:
        return NormalStrength(v["strength_cov"], seed=v["strength_seed"],
                              floor=v.get("strength_floor") or 0.05,
                              scale_energy=v.get("strength_scale_energy") or False)
    return None


def _known_curve(ck, curves: dict, name: str, path: tuple) -> None:
    """``name`` is a ``[curves.NAME]`` of the file."""
    if name not in curves:
        raise ck.error(path, f"unknown curve {name!r}{_suggest(name, curves)}; defined: "
                       f"{', '.join(curves) or 'none (add a [curves.NAME] table)'}")


def _array(ck, data: dict, key: str, what: str) -> list:
    """The array of tables ``[[key]]`` of ``data`` (empty when absent)."""
    t = data.get(key, [])
    if not isinstance(t, list):
        raise ck.error((key,), f"{key} must be an array of tables [[{key}]] ({what})", table=())
    return t


def _known_body(ck, names, c: dict, path: tuple) -> None:
    """The ``body`` of the resolved table ``c``, if any, is one of ``names``."""
    if c.get("body") is not None and c["body"] not in names:
        raise ck.error(path + ("body",), f"unknown body {c['body']!r}{_suggest(c['body'], names)}")


def _fmt(path: tuple) -> str:
    """A key path as dotted text."""
    return ".".join(str(p) for p in path)


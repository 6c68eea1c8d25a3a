"""The ``[materials.NAME]`` and ``[curves.NAME]`` tables of a scene file, checked into
:class:`~taichi_fdem.material.Material` objects and curve points."""
from __future__ import annotations

import re

from ..toml_check import SceneFileError, _suggest
from .keys import BEDDING_KEYS, CURVE_KEYS, MATERIAL_KEYS


def _material_tables(ck, data: dict) -> dict:
    """{name: Material} of the ``[materials.NAME]`` tables, in the file's order (a material
    ``like`` another starts from that one's values)."""
    from ...material import Material
    mats_t = ck.table(data.get("materials", {}), ("materials",), "one [materials.NAME] table per material")
    if not mats_t:
        raise SceneFileError(f"{ck.path}: no materials: add a [materials.NAME] table (density, young, poisson, ...)")
    materials = {}
    pending = dict(mats_t)
    while pending:                          # a material "like" another is made after it
        name = next((n for n, mt in pending.items() if not (isinstance(mt, dict) and mt.get("like") in pending)),
                    None)
        if name is None:
            name = next(iter(pending))
            raise ck.error(("materials", name, "like"), f"materials refer to each other in a loop through 'like': "
                           f"{', '.join(pending)}")
        mt = pending.pop(name)
        mp = ("materials", name)
        ck.table(mt, mp, "density, young, poisson, friction, ...")
        own = {k: v for k, v in mt.items() if k != "bedding"}
        ck.keys(own, MATERIAL_KEYS, mp)
        vals = {k: v for k, v in ck.values(own, MATERIAL_KEYS, mp).items() if v is not None}
        if "bedding" in mt:
            vals["bedding"] = _bedding_table(ck, mt["bedding"], mp + ("bedding",))
        like = vals.pop("like", None)
        try:
            if like is not None:
                if like not in materials:
                    raise ck.error(mp + ("like",), f"unknown material {like!r}{_suggest(like, mats_t)}; defined: "
                                   f"{', '.join(mats_t)}")
                vals = {k: v for k, v in vals.items() if k in mt}      # only the keys given replace the base's
                materials[name] = materials[like].with_(**vals, name=name)
            else:
                materials[name] = Material(**vals, name=name)
        except (ValueError, TypeError) as exc:
            bad = next((k for k in MATERIAL_KEYS if re.search(rf"\b{k}\b", str(exc)) and k in mt), None)
            raise ck.error(mp + ((bad,) if bad else ()), str(exc), table=mp) from None
    return {n: materials[n] for n in mats_t}      # in the file's order


def _bedding_table(ck, table, bp: tuple):
    """The :class:`~taichi_fdem.material.Bedding` of a ``[materials.NAME.bedding]`` sub-table."""
    from ...material import Bedding
    bt = ck.table(table, bp, "angle, young_normal, poisson_normal, shear_modulus, ...")
    ck.keys(bt, BEDDING_KEYS, bp)
    a = bt.get("angle")
    if a is not None and (isinstance(a, bool) or not isinstance(a, (int, float))):
        raise ck.error(bp + ("angle",), f"angle must be a number [°], got {a!r}: a bedding angle that varies with "
                       "position (a callable angle(x, y), a folded layer) cannot be written in a scene file; build "
                       "that scene in Python with fdem.Bedding(angle=f)")
    vals = {k: v for k, v in ck.values(bt, BEDDING_KEYS, bp).items() if v is not None}
    try:
        return Bedding(**vals)
    except (ValueError, TypeError) as exc:
        bad = next((k for k in BEDDING_KEYS if re.search(rf"\b{k}\b", str(exc)) and k in bt), None)
        raise ck.error(bp + ((bad,) if bad else ()), str(exc), table=bp) from None


def _curve_tables(ck, data: dict) -> dict:
    """{name: {"times": [...], "values": [...]}} of the ``[curves.NAME]`` tables (ramps resolved as
    ``Curve.ramp``)."""
    curves_t = ck.table(data.get("curves", {}), ("curves",), "one [curves.NAME] table per load curve")
    curves = {}
    for name, t in curves_t.items():
        cp = ("curves", name)
        ck.table(t, cp, "times and values, or ramp")
        ck.keys(t, CURVE_KEYS, cp)
        c = ck.values(t, CURVE_KEYS, cp)
        if c["ramp"] is not None:
            for k in ("times", "values"):
                if k in t:
                    raise ck.error(cp + (k,), "give either ramp (and start) or times and values, not both")
        else:
            if c["times"] is None or c["values"] is None:
                raise ck.error(cp, f"curve {name!r}: give times [s] and values, or ramp [s]", table=cp)
            if "start" in t:
                raise ck.error(cp + ("start",), "start goes with ramp (times and values give the whole curve)")
        from ...scene import Curve
        try:
            curve = Curve.ramp(c["ramp"], c["start"], name=name) if c["ramp"] is not None \
                else Curve(c["times"], c["values"], name=name)
        except ValueError as exc:
            raise ck.error(cp + ("times",), str(exc)) from None
        curves[name] = {"times": curve.times.tolist(), "values": curve.values.tolist()}
    return curves


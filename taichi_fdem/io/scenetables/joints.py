"""The ``[[joint_sets]]`` (also ``[[lab.joint_sets]]``) and ``[[interactions]]`` tables of a
scene file, each checked into one resolved dict per table."""
from __future__ import annotations

from ..toml_check import _suggest
from .common import _array, _check_region, _fmt, _known_body, _strength_keys
from .keys import INTERACTION_KEYS, JOINT_SET_KEYS


def _joint_set_tables(ck, data: dict, materials: dict, names) -> list:
    """One resolved dict per ``[[joint_sets]]``."""
    return _joint_set_list(ck, _array(ck, data, "joint_sets", "name, material and the edges"), ("joint_sets",),
                           materials, names, JOINT_SET_KEYS)


def _joint_set_list(ck, items, base: tuple, materials: dict, names, schema: dict) -> list:
    """One resolved dict per joint-set table of ``items`` (at ``base``, keys of ``schema``): a
    unique name, a material that can fracture, exactly one edge selector; ``names`` (None: no
    body key) are the bodies it may name."""
    if not isinstance(items, list):
        raise ck.error(base, f"{_fmt(base)} must be an array of tables [[{_fmt(base)}]]", table=())
    out, seen = [], set()
    for k, t in enumerate(items):
        p = base + (k,)
        ck.table(t, p, "a joint set")
        ck.keys(t, schema, p)
        c = ck.values(t, schema, p)
        if c["name"] in seen or c["name"] == "default":
            raise ck.error(p + ("name",), f"joint set name {c['name']!r} is used twice ('default' is the bodies' own)")
        seen.add(c["name"])
        if c["material"] not in materials:
            raise ck.error(p + ("material",), f"unknown material {c['material']!r}"
                           f"{_suggest(c['material'], materials)}; defined: {', '.join(materials)}")
        if not materials[c["material"]].can_fracture:
            raise ck.error(p + ("material",), f"a joint set's material needs tensile_strength and fracture_energy "
                           f"([materials.{c['material']}])")
        if names is not None:
            _known_body(ck, names, c, p)
        has_region = _check_region(ck, c, p, "", required=False)
        given = [w for w, on in (("interfaces", c["interfaces"]), ("lines", c["lines"] is not None),
                                 ("a region", has_region)) if on]
        if len(given) != 1:
            raise ck.error(p, "give exactly one edge selector: interfaces = true, lines = [[[x, y], ...], ...] or a "
                           f"region (xmin, ..., r_max) of edge midpoints; got {', '.join(given) or 'none'}", table=p)
        if "weibull_modulus" in schema:
            _strength_keys(ck, t, c, p)
        out.append(c)
    return out



def _interaction_tables(ck, data: dict, materials: dict) -> list:
    """One resolved dict per ``[[interactions]]``: two defined materials and at least one value."""
    out = []
    for k, t in enumerate(_array(ck, data, "interactions", "materials = [a, b] and the contact values")):
        p = ("interactions", k)
        ck.table(t, p, "a pair of materials and their contact properties")
        ck.keys(t, INTERACTION_KEYS, p)
        c = ck.values(t, INTERACTION_KEYS, p)
        if len(c["materials"]) != 2:
            raise ck.error(p + ("materials",), f"materials must name two materials [a, b], got {c['materials']!r}")
        for m in c["materials"]:
            if m not in materials:
                raise ck.error(p + ("materials",), f"unknown material {m!r}{_suggest(m, materials)}; defined: "
                               f"{', '.join(materials)}")
        if all(c[v] is None for v in ("friction", "penalty", "tangential_penalty", "contact_damping")):
            raise ck.error(p, "give at least one of friction, penalty, tangential_penalty, contact_damping", table=p)
        out.append(c)
    return out


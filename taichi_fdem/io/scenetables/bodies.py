"""The ``[[bodies]]`` tables of a scene file: each checked into a dict with every key resolved
(its material or material groups, its mesh keys by shape or file, its joints and cracks, its
motion)."""
from __future__ import annotations

import os

from ..toml_check import _suggest
from .common import _cracks, _edge_selector, _known_curve, _strength_keys
from .keys import _MESH_KEYS, BODY_KEYS, SHAPE_KEYS


def _body_tables(ck, data: dict, materials: dict, curves: dict, base_dir: str) -> tuple[list, set]:
    """(one resolved dict per ``[[bodies]]``, the set of body names).  Files the bodies read are
    looked for relative to ``base_dir``."""
    bodies_t = data.get("bodies", [])
    if not isinstance(bodies_t, list) or not bodies_t:
        raise ck.error(("bodies",), "no bodies: add at least one [[bodies]] table (material and a shape or file)",
                       table=())
    bodies, names = [], set()
    for i, bt in enumerate(bodies_t):
        bp = ("bodies", i)
        ck.table(bt, bp, "a body")
        ck.keys(bt, BODY_KEYS, bp)
        b = ck.values(bt, BODY_KEYS, bp)
        b["name"] = b["name"] or f"body{i}"
        if b["name"] in names:
            raise ck.error(bp + ("name",), f"body name {b['name']!r} is used twice; names must be unique")
        names.add(b["name"])
        _body_materials(ck, bt, b, bp, materials)
        _body_mesh(ck, bt, b, bp, base_dir)
        _body_joints(ck, bt, b, bp, materials)
        _body_motion(ck, b, bp, curves)
        bodies.append(b)
    return bodies, names


def _body_materials(ck, bt: dict, b: dict, bp: tuple, materials: dict) -> None:
    """``material`` or ``materials``: exactly one, naming defined materials."""
    if ("material" in bt) == ("materials" in bt):
        raise ck.error(bp, f"body {b['name']!r}: give exactly one of material = \"NAME\" or materials = "
                       f"{{label = \"NAME\", ...}} (material groups)", table=bp)
    for label, mname in ({"": b["material"]} if b["material"] is not None else b["materials"]).items():
        if mname not in materials:
            key = ("material",) if b["material"] is not None else ("materials",)
            raise ck.error(bp + key, f"unknown material {mname!r}{_suggest(mname, materials)}"
                           f"{' (group ' + repr(label) + ')' if label else ''}; defined: {', '.join(materials)}")


def _body_mesh(ck, bt: dict, b: dict, bp: tuple, base_dir: str) -> None:
    """The mesh keys: ``shape`` or ``file`` (sets ``b["shape"]``, "file" for a file), the keys of
    that shape, its material groups and sizes; a file's path made absolute."""
    if ("shape" in bt) == ("file" in bt):
        raise ck.error(bp, f"body {b['name']!r}: give exactly one of shape = \"disk\"|\"rectangle\"|\"annulus\"|"
                       f"\"polygon\"|\"grains\"|\"plate_with_hole\" or file = \"mesh.msh\"", table=bp)
    shape = b["shape"] or "file"
    b["shape"] = shape
    required, optional = SHAPE_KEYS[shape]
    for k in _MESH_KEYS & set(bt):
        if k not in required + optional:
            raise ck.error(bp + (k,), f"key {k!r} does not apply to {'a mesh file' if shape == 'file' else shape!r};"
                           f" its mesh keys are: {', '.join(required + optional)}")
    for k in required:
        if k not in bt:
            raise ck.error(bp + ((k,) if "shape" not in bt else ("shape",)),
                           f"body {b['name']!r}: {shape} needs {k!r}"
                           + (f" [{BODY_KEYS[k].unit}]" if BODY_KEYS[k].unit else ""), table=bp)
    if b["materials"] is not None:
        if shape == "grains" and b["minerals"] is None:
            raise ck.error(bp + ("materials",), "materials = {mineral = \"NAME\"} needs minerals = {name = "
                           "proportion, ...}; without minerals give one material = \"NAME\" for every grain")
        if shape == "grains" and set(b["materials"]) != set(b["minerals"]):
            raise ck.error(bp + ("materials",), f"materials must name one material for each mineral: minerals "
                           f"{sorted(b['minerals'])}, materials for {sorted(b['materials'])}")
        if shape == "file" and not b["groups"]:
            raise ck.error(bp + ("materials",), "materials = {label = \"NAME\"} maps the material groups of "
                           "the mesh file: it needs groups = true")
        if shape not in ("grains", "file"):
            raise ck.error(bp + ("materials",), f"a {shape!r} mesh has one material group: give material = "
                           f"\"NAME\" (materials = {{...}} is for grains and for mesh files with groups = true)")
    elif shape == "file" and b["groups"]:
        raise ck.error(bp + ("groups",), "groups = true needs materials = {label = \"NAME\", ...}, one "
                       "material per group of the file")
    if "group_key" in bt and not b["groups"] and b["group"] is None:
        raise ck.error(bp + ("group_key",), "group_key needs groups = true or group = \"NAME\"")
    if b["group"] is not None and (b["groups"] or "cell_block" in bt):
        raise ck.error(bp + ("group",), "group = \"NAME\" (one group of the file as the body) goes with "
                       "neither groups = true nor cell_block")
    if shape == "grains" and b["h"] >= b["grain_size"]:
        raise ck.error(bp + ("h",), f"h ({b['h']} m) must be smaller than grain_size ({b['grain_size']} m)")
    if shape == "grains" and b["outline"] == "disc" and b["width"] != b["height"]:
        raise ck.error(bp + ("height",), f"outline = \"disc\": width is the diameter and height must equal it "
                       f"(got {b['width']} and {b['height']} m)")
    if shape == "annulus" and b["r_inner"] >= b["r_outer"]:
        raise ck.error(bp + ("r_inner",), f"r_inner ({b['r_inner']} m) must be < r_outer ({b['r_outer']} m)")
    if shape == "file":
        f = b["file"] if os.path.isabs(b["file"]) else os.path.join(base_dir, b["file"])
        if not os.path.isfile(f):
            raise ck.error(bp + ("file",), f"mesh file {b['file']!r} not found (looked for {f}; paths are "
                           f"relative to the scene file's folder)")
        b["file"] = f


def _body_joints(ck, bt: dict, b: dict, bp: tuple, materials: dict) -> None:
    """The joint-strength spread, ``fracture`` and ``cracks`` (resolved in place); joints need
    materials that can fracture."""
    _strength_keys(ck, bt, b, bp)
    b["fracture"] = _edge_selector(ck, bt.get("fracture", False), bp + ("fracture",))
    b["cracks"], b["crack_regions"] = _cracks(ck, bt.get("cracks"), bp + ("cracks",))
    for key in ("fracture", "crack_regions"):
        v = b[key]
        if b["shape"] != "file" and any(isinstance(t, dict) and t.get("line_group") is not None
                                   for t in (v if isinstance(v, list) else [v])):
            raise ck.error(bp + ("fracture" if key == "fracture" else "cracks",), "line_group selects edges "
                           "along a line group of the body's mesh file: it needs file")
    mnames = [b["material"]] if b["material"] is not None else list(b["materials"].values())
    if b["fracture"] is not False or b["weibull_modulus"] is not None or b["strength_cov"] is not None:
        for mname in mnames:
            if not materials[mname].can_fracture:
                raise ck.error(bp + ("fracture",), f"body {b['name']!r}: joints need tensile_strength and "
                               f"fracture_energy in [materials.{mname}]")


def _body_motion(ck, b: dict, bp: tuple, curves: dict) -> None:
    """``velocity_curve`` needs ``prescribed_velocity``; ``fixed`` excludes it."""
    if b["velocity_curve"] is not None:
        _known_curve(ck, curves, b["velocity_curve"], bp + ("velocity_curve",))
        if b["prescribed_velocity"] is None:
            raise ck.error(bp + ("velocity_curve",), "velocity_curve multiplies prescribed_velocity: give "
                           "prescribed_velocity = [vx, vy]")
    if b["fixed"] and b["prescribed_velocity"] is not None:
        raise ck.error(bp + ("prescribed_velocity",), "give either fixed = true or prescribed_velocity, not both")

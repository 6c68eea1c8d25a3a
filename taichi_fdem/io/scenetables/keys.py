"""The key schemas of scene files: for every table, the keys it allows with their type, unit,
default and range (:class:`~taichi_fdem.io.toml_check._Key`), plus the mesh keys of each body
shape and the keys of each lab test.

These tables check a file when it is loaded and are the data of the generated scene-file
reference (``docs/_ext/scenefile_ref.py``); the meaning of each key is in the docstring of
:mod:`taichi_fdem.io.scenefile`.
"""
from __future__ import annotations

from ...engine.joints import HANDOVER_DAMAGE
from ..toml_check import _Key

_F = lambda **kw: _Key("float", **kw)
_POS = lambda unit, **kw: _Key("float", unit=unit, lo=0.0, lo_open=True, **kw)
# sanity bounds (SI): beyond them a value is a typo by orders of magnitude, and products of it
# overflow a float64 (lengths: taichi_fdem.mesh.MAX_LENGTH / MAX_COORDINATE)
_LEN, _COORD, _SPEED, _ACCEL = 1e6, 1e9, 1e5, 1e6

SCENE_KEYS = {
    "gravity": _Key("vec2", (0.0, -9.81), "m/s²", hi=_ACCEL),
    "plane": _Key("choice", "strain", choices=("strain", "stress")),
    "thickness": _POS("m", default=1.0, hi=_LEN),
}
MATERIAL_KEYS = {
    "density": _F(default=2700.0, unit="kg/m³"),
    "young": _F(default=30e9, unit="Pa"),
    "poisson": _F(default=0.25),
    "friction": _F(default=0.0),
    "damping": _F(default=0.0),
    "penalty": _F(unit="Pa"),
    "tangential_penalty": _F(unit="Pa"),
    "contact_damping": _F(default=0.0),
    "tensile_strength": _F(unit="Pa"),
    "fracture_energy": _F(unit="J/m²"),
    "cohesion": _F(unit="Pa"),
    "friction_angle": _F(unit="°"),
    "fracture_energy_shear": _F(unit="J/m²"),
    "joint_penalty": _F(unit="Pa"),
    "like": _Key("str"),
}
#: the ``[materials.NAME.bedding]`` sub-table: ``fdem.Bedding`` (a number angle only: a callable
#: angle(x, y) cannot be written in a file)
BEDDING_KEYS = {
    "angle": _F(unit="°", lo=-360.0, hi=360.0, required=True),
    "young_normal": _POS("Pa", required=True),
    "poisson_normal": _F(required=True),
    "shear_modulus": _POS("Pa", required=True),
    "tensile_strength": _POS("Pa"),
    "cohesion": _POS("Pa"),
    "friction_angle": _F(unit="°", lo=0.0, hi=90.0),
    "fracture_energy": _POS("J/m²"),
    "fracture_energy_shear": _POS("J/m²"),
    "expansion_normal": _F(unit="1/K"),
    "spacing": _POS("m", hi=_LEN),
}
BODY_KEYS = {
    "name": _Key("str"),
    "material": _Key("str"),
    "materials": _Key("names"),
    "shape": _Key("choice", choices=("disk", "rectangle", "annulus", "polygon", "grains", "plate_with_hole")),
    "file": _Key("str"),
    "cell_block": _Key("int", lo=0),
    "groups": _Key("bool", False),
    "group": _Key("str"),
    "group_key": _Key("str"),
    "radius": _POS("m"),
    "width": _POS("m"),
    "height": _POS("m"),
    "pattern": _Key("choice", "alternating", choices=("alternating", "crossed", "right")),
    "layout": _Key("choice", "symmetric", choices=("symmetric", "spiral")),
    "r_inner": _POS("m"),
    "r_outer": _POS("m"),
    "grain_size": _POS("m"),
    "seed": _Key("int", 0, lo=0),
    "minerals": _Key("weights"),
    "outline": _Key("choice", "rectangle", choices=("rectangle", "disc")),
    "relax": _Key("int", 3, lo=0, hi=1000),
    "vertices": _Key("vertices", unit="m"),
    "engine": _Key("choice", "builtin", choices=("builtin", "gmsh")),
    "h": _POS("m"),
    "position": _Key("vec2", unit="m", hi=_COORD),
    "velocity": _Key("vec2", (0.0, 0.0), "m/s", hi=_SPEED),
    "angular_velocity": _F(default=0.0, unit="rad/s", lo=-1e7, hi=1e7),
    "rotation": _F(default=0.0, unit="rad", lo=-1e6, hi=1e6),
    "fixed": _Key("bool", False),
    "prescribed_velocity": _Key("vec2", unit="m/s", hi=_SPEED),
    "velocity_curve": _Key("str"),
    "self_contact": _Key("bool", False),
    "fracture": _Key("edges", False),
    "cracks": _Key("cracks", unit="m"),
    "crack_friction": _Key("float", lo=0.0, hi=1e3),
    "weibull_modulus": _Key("float", lo=0.0, lo_open=True, hi=1e3),
    "strength_cov": _Key("float", lo=0.0, hi=10.0),
    "strength_seed": _Key("int", 0, lo=0),
    "strength_floor": _Key("float", 0.05, lo=0.0, lo_open=True, hi=0.999),
    "strength_scale_energy": _Key("bool", False),
}
#: mesh parameters of each built-in shape: (required, optional)
SHAPE_KEYS = {
    "disk": (("radius", "h"), ("layout",)),
    "rectangle": (("width", "height", "h"), ("pattern",)),
    "annulus": (("r_inner", "r_outer", "h"), ("layout",)),
    "polygon": (("vertices",), ("h", "engine")),
    "grains": (("width", "height", "grain_size", "h"), ("seed", "minerals", "outline", "relax")),
    "plate_with_hole": (("width", "height", "radius", "h"), ()),
    "file": (("file",), ("cell_block", "groups", "group", "group_key")),
}
_MESH_KEYS = {k for req, opt in SHAPE_KEYS.values() for k in req + opt}
#: a region of the plane (initial, placed coordinates): a box and/or a ring about a centre
REGION_KEYS = {
    "xmin": _F(unit="m"), "xmax": _F(unit="m"), "ymin": _F(unit="m"), "ymax": _F(unit="m"),
    "center": _Key("vec2", unit="m", hi=_COORD),
    "r_min": _F(unit="m", lo=0.0, hi=_COORD), "r_max": _F(unit="m", lo=0.0, hi=_COORD),
}
_BOUNDS = ("xmin", "xmax", "ymin", "ymax", "r_min", "r_max")
CONSTRAINT_KEYS = {
    **REGION_KEYS,
    "body": _Key("str"),
    "vx": _F(unit="m/s", lo=-_SPEED, hi=_SPEED), "vy": _F(unit="m/s", lo=-_SPEED, hi=_SPEED),
    "curve": _Key("str"),
}
CURVE_KEYS = {
    "times": _Key("floats", unit="s"),
    "values": _Key("floats"),
    "ramp": _POS("s", hi=1e9),
    "start": _F(default=0.0, unit="s", lo=-1e9, hi=1e9),
}
JOINT_SET_KEYS = {
    "name": _Key("str", required=True),
    "material": _Key("str", required=True),
    "body": _Key("str"),
    "interfaces": _Key("bool", False),
    "lines": _Key("polylines", unit="m"),
    **REGION_KEYS,
    "weibull_modulus": BODY_KEYS["weibull_modulus"],
    "strength_cov": BODY_KEYS["strength_cov"],
    "strength_seed": BODY_KEYS["strength_seed"],
    "strength_floor": BODY_KEYS["strength_floor"],
    "strength_scale_energy": BODY_KEYS["strength_scale_energy"],
}
#: a joint set of a lab test (``joint_sets=`` triples: no body, no strength spread)
LAB_JOINT_SET_KEYS = {k: v for k, v in JOINT_SET_KEYS.items() if k not in
                      ("body", "weibull_modulus", "strength_cov", "strength_seed", "strength_floor",
                       "strength_scale_energy")}
LOAD_KEYS = {
    "kind": _Key("choice", choices=("pressure", "traction", "force", "absorbing"), required=True),
    "pressure": _F(unit="Pa", lo=-1e15, hi=1e15),
    "traction": _Key("vec2", unit="Pa", hi=1e15),
    "force": _Key("vec2", unit="N/m", hi=1e15),
    "body": _Key("str"),
    "curve": _Key("str"),
    **REGION_KEYS,
}
#: the value key of each load kind
LOAD_VALUE = {"pressure": "pressure", "traction": "traction", "force": "force", "absorbing": None}
INITIAL_STRESS_KEYS = {
    "sxx": _F(unit="Pa", required=True, lo=-1e15, hi=1e15),
    "syy": _F(unit="Pa", required=True, lo=-1e15, hi=1e15),
    "sxy": _F(default=0.0, unit="Pa", lo=-1e15, hi=1e15),
    "body": _Key("str"),
    "gradient": _Key("floats", unit="Pa/m"),
    "y_ref": _F(default=0.0, unit="m", lo=-_COORD, hi=_COORD),
}
INTERACTION_KEYS = {
    "materials": _Key("strs", required=True),
    "friction": _F(lo=0.0, hi=1e6),
    "penalty": _POS("Pa", hi=1e16),
    "tangential_penalty": _POS("Pa", hi=1e16),
    "contact_damping": _F(lo=0.0, hi=1.0),
}
EXCAVATE_KEYS = {
    "time": _F(unit="s", lo=0.0, hi=1e9, required=True),
    "body": _Key("str"),
    **REGION_KEYS,
}
CHECK_KEYS = {
    "energy": _Key("bool", True),
    "energy_tol": _POS("", default=0.1, hi=1e6),
    "max_penetration": _F(default=0.5, lo=0.0, hi=1e6),
    "every": _Key("int", None, lo=1),
}
SOLVER_KEYS = {
    "duration": _F(unit="s", lo=0.0, hi=1e9, required=True),
    "dt": _POS("s"),
    "safety": _Key("float", 0.2, lo=0.0, lo_open=True, hi=1.0),
    "strategy": _Key("choice", "auto", choices=("auto", "serial", "parallel")),
    "buffer": _F(unit="m", lo=0.0, hi=_LEN),
    "force_dt": _Key("bool", False),
    "check_overlap": _Key("bool", True),
    "joined_pairs": _Key("choice", "joint", choices=("joint", "contact")),
    "handover_damage": _Key("float", HANDOVER_DAMAGE, lo=0.0, hi=1.0),
    "quasi_static": _Key("float", 0.0, lo=0.0, hi=0.999),
    "speed_limit": _POS("m/s", hi=1e9),
}
COLOR_BY = ("body", "material", "speed", "displacement", "von_mises", "max_principal", "min_principal", "damage",
            "fluid_pressure", "bedding", "temperature")
OUTPUT_KEYS = {
    "video": _Key("str"),
    "fps": _Key("int", 30, "1/s", lo=1, hi=1000),
    "frame_dt": _POS("s"),
    "color_by": _Key("choice", "body", choices=COLOR_BY),
    "width": _Key("int", 960, "px", lo=1, hi=16384),
    "height": _Key("int", 540, "px", lo=1, hi=16384),
    "cracks": _Key("bool", False),
    "crack_events": _Key("str"),
    "vtu": _Key("str"),
    "vtu_every": _Key("int", 1, lo=1),
    "checkpoint": _Key("str"),
    "history": _Key("str"),
    "history_every": _Key("int", None, lo=1),
}
LAB_KEYS = {
    "test": _Key("choice", choices=("ucs", "triaxial", "brazilian", "direct_shear"), required=True),
    "material": _Key("str"),
    "materials": _Key("names"),
    "width": _POS("m", hi=_LEN),
    "height": _POS("m", hi=_LEN),
    "diameter": _POS("m", hi=_LEN),
    "h": _POS("m", hi=_LEN, required=True),
    "confinement": _POS("Pa", hi=1e12),
    "normal_stress": _POS("Pa", hi=1e12),
    "rate_transits": _Key("float", 60.0, lo=0.0, lo_open=True, hi=1e6),
    "load_time": _Key("float", None, lo=0.0, lo_open=True, hi=1e6),
    "joint": _Key("bool", False),
    "samples": _Key("int", None, lo=10, hi=100000),
    "plane": _Key("choice", "strain", choices=("strain", "stress")),
    "check": _Key("choice", choices=("rate", "mesh", "both")),
    "quasi_static": _Key("float", None, lo=0.0, hi=0.999),
    "safety": _Key("float", None, lo=0.0, lo_open=True, hi=1.0),
    "settle_transits": _Key("float", None, lo=0.0, hi=1e6),
    "max_strain": _Key("float", None, lo=0.0, lo_open=True, hi=1.0),
    "stop_drop": _Key("float", None, lo=0.0, lo_open=True, hi=1.0),
    "handover_damage": _Key("float", None, lo=0.0, hi=1.0),
    "penalty_factor": _Key("float", None, lo=0.0, lo_open=True, hi=1e6),
    "joint_penalty_factor": _Key("float", None, lo=0.0, lo_open=True, hi=1e6),
    "alpha_deg": _Key("float", None, lo=0.0, hi=45.0),
    "max_time": _Key("float", None, lo=0.0, lo_open=True, hi=1e6),
    "displacement": _POS("m", hi=_LEN),
    "friction": _F(lo=0.0, hi=1e6),
    "lower_material": _Key("str"),
    "platen": _Key("str"),
    "fracture": _Key("bool"),
    "weibull_modulus": BODY_KEYS["weibull_modulus"],
    "strength_cov": BODY_KEYS["strength_cov"],
    "strength_seed": BODY_KEYS["strength_seed"],
    "history": _Key("str"),
    "grain_size": _POS("m", hi=_LEN),
    "grain_seed": _Key("int", 0, lo=0),
    "minerals": _Key("weights"),
    "relax": _Key("int", 3, lo=0, hi=1000),
    "joint_sets": _Key("joint_sets"),
    "csv": _Key("str"),
    "video": _Key("str"),
}
#: keys of each lab test: (required, optional) besides test, material, h, samples, plane, csv, video
_GRAINS = ("grain_size", "grain_seed", "minerals", "materials", "relax", "joint_sets")
_COMPRESSION = ("rate_transits", "check", "quasi_static", "safety", "settle_transits", "max_strain", "stop_drop",
                "handover_damage", "penalty_factor", "platen", "fracture", "history") + _GRAINS
LAB_TEST_KEYS = {
    "ucs": (("width", "height"), _COMPRESSION),
    "triaxial": (("width", "height", "confinement"), _COMPRESSION),
    "brazilian": (("diameter",), ("load_time", "check", "quasi_static", "safety", "alpha_deg", "max_time",
                                  "joint_penalty_factor", "platen", "weibull_modulus", "strength_cov",
                                  "strength_seed") + _GRAINS),
    "direct_shear": (("width", "height", "normal_stress"), ("rate_transits", "joint", "settle_transits", "safety",
                                                            "displacement", "friction", "lower_material")),
}
FLUID_KEYS = {
    "density": _POS("kg/m³", default=1000.0),
    "bulk_modulus": _POS("Pa", default=2.2e9),
    "viscosity": _POS("Pa·s", default=1e-3),
    "aperture_min": _POS("m", hi=_LEN, required=True),
    "aperture_max": _POS("m", hi=_LEN),
    "initial_pressure": _F(default=0.0, unit="Pa", lo=0.0),
    "conduct": _Key("choice", "broken", choices=("broken", "damaged")),
}
INJECT_KEYS = {
    **REGION_KEYS,
    "rate": _F(unit="m²/s", lo=0.0),
    "pressure": _F(unit="Pa", lo=0.0),
    "ramp": _POS("s"),
    "curve": _Key("str"),
}
TOP_KEYS = ("description", "scene", "materials", "curves", "bodies", "joint_sets", "interactions", "constraints",
            "loads", "initial_stress", "fluid", "inject", "excavate", "solver", "checks", "output", "lab")

#: the arrays of tables [[...]]
_ARRAY_TABLES = ("bodies", "joint_sets", "interactions", "constraints", "loads", "initial_stress", "inject", "excavate")

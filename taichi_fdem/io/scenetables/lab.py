"""The ``[lab]`` table of a scene file: a standard lab test of :mod:`taichi_fdem.lab` instead of
bodies, constraints, solver and output."""
from __future__ import annotations

from ..toml_check import _suggest
from .joints import _joint_set_list
from .keys import LAB_JOINT_SET_KEYS, LAB_KEYS, LAB_TEST_KEYS


def _lab_table(ck, data: dict, materials: dict) -> dict:
    """The checked ``[lab]`` table: the test's keys resolved, the others refused."""
    for other in ("bodies", "constraints", "fluid", "inject", "solver", "output", "joint_sets", "interactions",
                  "loads", "initial_stress", "excavate", "checks"):
        if other in data:
            raise ck.error((other,), f"a scene file with [lab] runs a standard test: it has no [{other}] "
                           "(the test builds its specimen, loading and run)", table=())
    lab_t = ck.table(data["lab"], ("lab",), "test, material, h, ...")
    ck.keys(lab_t, LAB_KEYS, ("lab",))
    if "test" not in lab_t:
        raise ck.error(("lab",), "[lab] needs 'test'", table=("lab",))
    if ("material" in lab_t) == ("materials" in lab_t):
        raise ck.error(("lab",), "[lab] needs exactly one of material = \"NAME\" or materials = {mineral = "
                       "\"NAME\", ...} (grains)", table=("lab",))
    lab = ck.values(lab_t, LAB_KEYS, ("lab",))
    for label, mname in ({"": lab["material"]} if lab["material"] is not None else lab["materials"]).items():
        if mname not in materials:
            key = ("material",) if lab["material"] is not None else ("materials",)
            raise ck.error(("lab",) + key, f"unknown material {mname!r}{_suggest(mname, materials)}"
                           f"{' (mineral ' + repr(label) + ')' if label else ''}; defined: {', '.join(materials)}")
    required, optional = LAB_TEST_KEYS[lab["test"]]
    specific = {k for req, opt in LAB_TEST_KEYS.values() for k in req + opt}
    for k in specific & set(lab_t):
        if k not in required + optional:
            raise ck.error(("lab", k), f"key {k!r} does not apply to the {lab['test']!r} test; its keys are: "
                           f"{', '.join(required + optional)}")
    for k in required:
        if k not in lab_t:
            raise ck.error(("lab",), f"the {lab['test']!r} test needs {k!r} [{LAB_KEYS[k].unit}]", table=("lab",))
    for k in ("lower_material", "platen"):
        if lab[k] is not None and lab[k] not in materials:
            raise ck.error(("lab", k), f"unknown material {lab[k]!r}{_suggest(lab[k], materials)}; defined: "
                           f"{', '.join(materials)}")
    if lab["weibull_modulus"] is not None and lab["strength_cov"] is not None:
        raise ck.error(("lab", "strength_cov"), "give either weibull_modulus or strength_cov, not both")
    if "strength_seed" in lab_t and lab["weibull_modulus"] is None and lab["strength_cov"] is None:
        raise ck.error(("lab", "strength_seed"), "strength_seed needs weibull_modulus or strength_cov")
    for k in ("grain_seed", "minerals", "relax", "materials"):
        if k in lab_t and lab["grain_size"] is None:
            raise ck.error(("lab", k), f"{k} belongs to a grain specimen: it needs grain_size [m]")
    if lab["materials"] is not None:
        if lab["minerals"] is None or set(lab["materials"]) != set(lab["minerals"]):
            raise ck.error(("lab", "materials"), "materials must name one material for each mineral of minerals = "
                           "{name = proportion, ...}")
    if lab["grain_size"] is not None and lab["h"] >= lab["grain_size"]:
        raise ck.error(("lab", "h"), f"h ({lab['h']} m) must be smaller than grain_size ({lab['grain_size']} m)")
    if lab["grain_size"] is not None and lab["check"] in ("mesh", "both"):
        raise ck.error(("lab", "check"), "check = \"mesh\" refines the test's own mesh: a grain specimen cannot be "
                       "refined here (use \"rate\")")
    if lab["bedding_angle"] is not None:
        names = [lab["material"]] if lab["material"] is not None else list(lab["materials"].values())
        if not any(getattr(materials[n], "bedding", None) is not None for n in names):
            raise ck.error(("lab", "bedding_angle"), "bedding_angle needs a material with a bedding "
                           f"([materials.{names[0]}.bedding])")
    if lab["joint_sets"] is not None:
        lab["joint_sets"] = _joint_set_list(ck, lab["joint_sets"], ("lab", "joint_sets"), materials, None,
                                            LAB_JOINT_SET_KEYS)
    if lab["test"] == "brazilian":
        for mname in ([lab["material"]] if lab["material"] is not None else lab["materials"].values()):
            if not materials[mname].can_fracture:
                key = "material" if lab["material"] is not None else "materials"
                raise ck.error(("lab", key), f"the brazilian test needs tensile_strength and fracture_energy in "
                               f"[materials.{mname}]")
    return {k: v for k, v in lab.items() if k in ("test", "material", "h", "samples", "plane", "csv", "video")
            or k in required + optional}


"""The ``[fluid]`` and ``[[inject]]`` tables of a scene file (the fluid of the fracture network
and its sources)."""
from __future__ import annotations

from .common import _check_region, _known_curve
from .keys import FLUID_KEYS, INJECT_KEYS


def _fluid_tables(ck, data: dict, curves: dict):
    """The checked ``[fluid]`` table (None without one) and ``[[inject]]`` list."""
    fluid = None
    if "fluid" in data:
        ft = ck.table(data["fluid"], ("fluid",), "density, bulk_modulus, viscosity, aperture_min, ...")
        ck.keys(ft, FLUID_KEYS, ("fluid",))
        if "aperture_min" not in ft:
            raise ck.error(("fluid",), "[fluid] needs aperture_min [m] (the residual hydraulic aperture)",
                           table=("fluid",))
        fluid = ck.values(ft, FLUID_KEYS, ("fluid",))
        if fluid["aperture_max"] is not None and fluid["aperture_max"] <= fluid["aperture_min"]:
            raise ck.error(("fluid", "aperture_max"), f"aperture_max ({fluid['aperture_max']} m) must be > "
                           f"aperture_min ({fluid['aperture_min']} m)")
        from ...material import Fluid
        try:
            Fluid(density=fluid["density"], bulk_modulus=fluid["bulk_modulus"], viscosity=fluid["viscosity"])
        except (ValueError, TypeError) as exc:
            raise ck.error(("fluid",), str(exc), table=("fluid",)) from None
    inj_t = data.get("inject", [])
    if not isinstance(inj_t, list):
        raise ck.error(("inject",), "inject must be an array of tables [[inject]]", table=())
    if inj_t and fluid is None:
        raise ck.error(("inject",), "[[inject]] needs a [fluid] table (the fluid of the fracture network)", table=())
    injections = []
    for k, it in enumerate(inj_t):
        ip = ("inject", k)
        ck.table(it, ip, "a box of network nodes and a rate or a pressure")
        ck.keys(it, INJECT_KEYS, ip)
        c = ck.values(it, INJECT_KEYS, ip)
        _check_region(ck, c, ip, "the region of network nodes")
        if c["ramp"] is not None and c["curve"] is not None:
            raise ck.error(ip + ("curve",), "give either ramp or curve, not both")
        if c["curve"] is not None:
            _known_curve(ck, curves, c["curve"], ip + ("curve",))
        if (c["rate"] is None) == (c["pressure"] is None):
            raise ck.error(ip, "give exactly one of rate [m²/s] or pressure [Pa]", table=ip)
        injections.append(c)
    return fluid, injections


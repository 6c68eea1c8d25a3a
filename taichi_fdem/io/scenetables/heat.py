"""The ``[temperature]`` and ``[[heat]]`` tables of a scene file (heat conduction:
``Scene.set_temperature``, ``Scene.heat``)."""
from __future__ import annotations

from .common import _check_region, _known_body, _known_curve
from .keys import HEAT_KEYS, TEMPERATURE_KEYS


def _heat_tables(ck, data: dict, names, curves: dict):
    """The checked ``[temperature]`` table (None without one) and ``[[heat]]`` list."""
    temperature = None
    if "temperature" in data:
        tt = ck.table(data["temperature"], ("temperature",), "initial [K or °C]")
        ck.keys(tt, TEMPERATURE_KEYS, ("temperature",))
        temperature = ck.values(tt, TEMPERATURE_KEYS, ("temperature",))
    rows = data.get("heat", [])
    if not isinstance(rows, list):
        raise ck.error(("heat",), "heat must be an array of tables [[heat]]", table=())
    out = []
    for k, t in enumerate(rows):
        p = ("heat", k)
        ck.table(t, p, "a region and a temperature or a flux")
        ck.keys(t, HEAT_KEYS, p)
        c = ck.values(t, HEAT_KEYS, p)
        _check_region(ck, c, p, "the region of the heated nodes: a flux enters through the edges with both nodes in it")
        _known_body(ck, names, c, p)
        if (c["temperature"] is None) == (c["flux"] is None):
            raise ck.error(p, "give exactly one of temperature [K] (held) or flux [W/m²] (into the body)", table=p)
        if c["ramp"] is not None and c["curve"] is not None:
            raise ck.error(p + ("curve",), "give either ramp or curve, not both")
        if c["curve"] is not None:
            _known_curve(ck, curves, c["curve"], p + ("curve",))
        out.append(c)
    return temperature, out

"""A view of a simulation: a group of related results answered from its model and state
(``sim.cracks``, ``sim.fluid``, ``sim.loads``)."""
from __future__ import annotations

__all__ = ["View"]


class View:
    """Results of one simulation (``self._sim``) under one name; read-only."""

    __slots__ = ("_sim", "_cache")

    def __init__(self, sim):
        object.__setattr__(self, "_sim", sim)
        object.__setattr__(self, "_cache", {})

    def __setattr__(self, name, value):
        raise AttributeError(f"sim.{type(self).__name__.lower()}: results are read-only (setting {name!r})")

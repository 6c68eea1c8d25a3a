"""The array groups of a step as one compile-time tuple, in the fixed order of the kernel
convention (docs/architecture.md, "Kernels and functions").

A ``@ti.func`` takes its entity index first, then the groups it reads in the order of
:class:`Groups`, then the compile-time features.  A function that drives a whole step (the
serial step loop, the team's workers) takes the groups as one :class:`Groups` tuple instead,
built inside the kernel with ``ti.static``: from the kernel's separate argpacks, or from one
argpack that holds every member (:func:`one_argpack`; a launch with the fluid's group or the
team's takes one argpack, as separate ones would pass Taichi's 64 argument leaves).
"""
from collections import namedtuple

#: The groups of :mod:`taichi_fdem.engine.groups` in the convention's order; a field a kernel does
#: not have is None (never read: the functions that read it are compiled only with its feature).
Groups = namedtuple("Groups", "nodes tris mats contact detect joints step asm fluid heat",
                    defaults=(None,) * 10)


def one_argpack(g) -> Groups:
    """Every group served by the one argpack ``g`` (its members carry their group's prefix, so
    ``G.nodes.node_x`` is ``g.node_x``)."""
    return Groups(*([g] * len(Groups._fields)))

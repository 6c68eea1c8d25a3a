"""Small Taichi constructors whose float type is resolved when a kernel compiles, and the
launcher of the kernels called often.

``ti.types.vector(2, float)`` made at import time would fix the type before :func:`fdem.init`
chooses the precision; these functions build values inside kernels with ``float`` = the
active default precision.
"""
import taichi as ti


@ti.func
def vec2(x, y):
    return ti.Vector([x, y], dt=float)


@ti.func
def vec3(x, y, z):
    return ti.Vector([x, y, z], dt=float)


@ti.func
def mat2_cols(c0, c1):
    """2×2 matrix with columns c0, c1."""
    return ti.Matrix([[c0[0], c1[0]], [c0[1], c1[1]]], dt=float)


@ti.func
def mat32_rows(r0, r1, r2):
    """3×2 matrix with rows r0, r1, r2."""
    return ti.Matrix([[r0[0], r0[1]], [r1[0], r1[1]], [r2[0], r2[1]]], dt=float)


def launch_cached(cache: dict, name: str, kernel, *args):
    """Launch ``kernel(*args)`` and return its result: Taichi's public call, which looks up the
    compiled variant from the arguments.  ``cache`` and ``name`` identify the launch site for
    the callers (``Simulation._launch_cached``); no Taichi state is kept in them.
    """
    return kernel(*args)

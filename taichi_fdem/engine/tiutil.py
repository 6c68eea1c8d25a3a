"""Small Taichi constructors whose float type is resolved when a kernel compiles, and a
launcher for kernels called once per step.

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


def _template_flags(prim, n):
    """For each of the n arguments of the Taichi kernel ``prim``: whether its value selects the
    compiled variant (a ``ti.template()`` parameter) rather than only its type."""
    from taichi.types.annotations import Template
    args = getattr(prim, "arguments", None)
    if args is None or len(args) != n:
        return (True,) * n
    return tuple(isinstance(a.annotation, Template) or a.annotation is Template for a in args)


def launch_cached(cache: dict, name: str, kernel, *args):
    """Launch ``kernel(*args)`` without Taichi's per-call lookup of the compiled variant.

    Taichi's ``Kernel.__call__`` derives the variant's key from the arguments at every call: for
    the parallel step's seven argpacks that is ~125 µs of a ~0.5 ms launch, and ~0.5-0.9 ms for
    the team launch (measured).  The key depends only on the argpacks' array types, on the
    template arguments' values and on the other arguments' types, so ``cache[name]`` keeps it
    while the same argpacks (identity), equal template arguments and scalars of the same types
    (the step count of a launch changes from call to call) come back; the caller empties
    ``cache`` when it rebuilds its argpacks.  Uses ``Kernel.ensure_compiled`` and
    ``Kernel.launch_kernel`` (Taichi 1.7); without them, the plain call.
    """
    hit = cache.get(name)
    if hit is None or len(hit[0]) != len(args) or not all(
            a is b or (not isinstance(a, ti.lang.argpack.ArgPack) and type(a) is type(b) and (not t or a == b))
            for a, b, t in zip(hit[0], args, hit[3])):
        prim = getattr(kernel, "_primal", None)
        if prim is None or not hasattr(prim, "launch_kernel") or not hasattr(prim, "ensure_compiled"):
            return kernel(*args)
        key = prim.ensure_compiled(*args)
        hit = (args, prim, prim.compiled_kernels[key], _template_flags(prim, len(args)))
        cache[name] = hit
    return hit[1].launch_kernel(hit[2], *args)

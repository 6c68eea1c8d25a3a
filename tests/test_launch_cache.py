"""engine.tiutil.launch_cached: the launcher of the kernels launched often (steps, detection)
gives what Taichi's plain call gives.  (No ``from __future__ import annotations`` here: Taichi
reads the kernel's annotations as types.)"""
import pytest
import taichi as ti

import taichi_fdem  # noqa: F401  (conftest initialises Taichi)


@ti.kernel
def _cached_probe(n: ti.i32, x: ti.f64, a: ti.types.ndarray(), double: ti.template()) -> ti.f64:
    s = ti.f64(0.0)
    for i in range(n):
        a[i] = x + i
        s += a[i]
    if ti.static(double):
        s *= 2.0
    return s


def test_launch_cached_follows_scalars_and_templates():
    """engine.tiutil.launch_cached follows the values of typed scalar arguments (the step count of
    a launch) and of template arguments: every call gives what the plain call gives."""
    from taichi_fdem.engine.tiutil import launch_cached
    a = ti.ndarray(ti.f64, shape=8)
    cache = {}
    for n, x, double in [(3, 1.0, False), (5, 1.0, False), (5, 2.5, False), (5, 2.5, True), (2, 0.5, True),
                         (4, 0.5, False)]:
        got = launch_cached(cache, "probe", _cached_probe, n, x, a, double)
        ref = _cached_probe(n, x, a, double)
        expect = (n * x + n * (n - 1) / 2) * (2.0 if double else 1.0)
        assert got == ref == pytest.approx(expect), (n, x, double)

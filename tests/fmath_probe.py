"""Error of taichi_fdem.engine.fmath against numpy, in ulp of the kernel precision.

Run as ``python tests/fmath_probe.py ARCH PRECISION``: prints one JSON object
{function: max ulp error} over the sample of each function's range.  A separate process, as
Taichi is initialised once per process (the test suite runs in f64 on the CPU).
"""
import json
import sys

import numpy as np
import taichi as ti

import taichi_fdem as fdem


def reference_g(d):
    """d − log(1 + d) in long double, by its series Σ (−d)ⁿ/n (n ≥ 2) where |d| < 0.05."""
    L = np.asarray(d, dtype=np.longdouble)
    out = L - np.log1p(L)
    small = np.abs(L) < 0.05
    s = np.zeros_like(L)
    term = L * L
    for n in range(2, 40):
        s += term / n * (1 if n % 2 == 0 else -1)
        term = term * L
    out[small] = s[small]
    return out


def samples(rng, n, f64):
    """{name: (x, reference)}: the ranges the engine uses, and wider for log."""
    big = 700.0 if f64 else 80.0
    wide = 20.0 if f64 else 4.0       # f32 exp: the engine's range (softening_z: [−3.3, 0])
    x_log = np.concatenate([np.exp(rng.uniform(-big, big, n)), 1.0 + rng.uniform(-0.3, 0.3, n)])
    x_exp = rng.uniform(-wide, wide, n)
    x_l1p = np.concatenate([rng.uniform(-0.9, 3.0, n), rng.uniform(-1e-3, 1e-3, n),
                            rng.uniform(-1e-7, 1e-7, n)])
    x_pow6 = rng.uniform(0.0, 1.0, n)
    x_pow = rng.uniform(0.5, 2.0, n)
    LD = np.longdouble
    return {"log": (x_log, lambda x: np.log(x.astype(LD))),
            "exp": (x_exp, lambda x: np.exp(x.astype(LD))),
            "log1p": (x_l1p, lambda x: np.log1p(x.astype(LD))),
            "log1p_minus": (x_l1p, reference_g),
            "ipow6": (x_pow6, lambda x: x.astype(LD) ** 6),
            "pow": (x_pow, lambda x: x.astype(LD) ** LD(2.5))}


def main(arch, precision):
    fdem.init(arch=arch, precision=precision)
    from taichi_fdem.engine import fmath
    dt = np.float64 if precision == "f64" else np.float32

    @ti.kernel
    def run(x: ti.types.ndarray(), out: ti.types.ndarray(), which: ti.i32):
        for i in range(x.shape[0]):
            v = x[i]
            if which == 0:
                out[i] = fmath.log(v)
            elif which == 1:
                out[i] = fmath.exp(v)
            elif which == 2:
                out[i] = fmath.log1p(v)
            elif which == 3:
                out[i] = fmath.log1p_minus(v)
            elif which == 4:
                out[i] = fmath.ipow(v, 6)
            else:
                out[i] = fmath.pow(v, 2.5)

    rng = np.random.default_rng(7)
    errors = {}
    for which, (name, (x, ref)) in enumerate(samples(rng, 20000, dt == np.float64).items()):
        x = x.astype(dt)
        out = np.zeros_like(x)
        run(x, out, which)
        r = ref(x)
        # ulp of the exact value in the kernel's precision (computed in long double: no flushing)
        e = np.floor(np.log2(np.abs(r).astype(np.longdouble)))
        ulp = np.exp2(e - (52 if dt == np.float64 else 23))
        errors[name] = float(np.max(np.abs(out.astype(np.longdouble) - r) / ulp))
    print(json.dumps(errors))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])

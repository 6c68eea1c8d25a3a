"""Portable transcendental functions for the engine's kernels, in either precision.

Taichi's SPIR-V back ends (Vulkan, Metal through MoltenVK, OpenGL) lower ``ti.log``,
``ti.exp`` and ``ti.pow`` to GLSL.std.450 instructions that exist in 32 bits only, so a kernel
using them does not compile in f64 there.  The functions below use only +, −, ×, ÷ and
comparisons, which every back end has in both precisions:

* :func:`log`: x = m·2ᵏ with m in [√½, √2) (exact scaling by powers of two), then
  log m = 2 atanh s, s = (m − 1)/(m + 1), ``|s|`` ≤ 0.1716, by its odd series in s.
* :func:`log1p_minus` (g(d) = d − log(1 + d), the part of log J that cancels in the strain
  energy): the same series, written so that nothing cancels for J near 1.
* :func:`exp`: x = k·ln 2 + r (Cody–Waite split of ln 2), ``|r|`` ≤ ½ ln 2, exp r by its Taylor
  series, times 2ᵏ built from exact powers of two.
* :func:`ipow`: xⁿ for a compile-time integer n, by repeated squaring.
* :func:`pow`: exp(y·log x) for x > 0.

The series lengths are fixed for the precision at compile time (``float`` is the default
precision chosen by :func:`taichi_fdem.init`).  Errors against numpy over the ranges the
engine uses: a few ulp in both precisions (tests/test_fmath.py).
"""
import math

import taichi as ti

# ln 2 = hi + lo with hi short enough that k·hi is exact for every exponent k of the precision
LN2_HI_64, LN2_LO_64 = 6.93147180369123816490e-01, 1.90821492927058770002e-10    # hi: 21 bits
LN2_HI_32, LN2_LO_32 = 0.693359375, -2.12194440054690582e-04                     # hi: 9 bits
SQRT_HALF = 0.70710678118654752440
# exact powers of two for range reduction: 2^(2^i), i = 9 … 0 (f64), 6 … 0 (f32)
_P64 = tuple(float(2 ** i) for i in (512, 256, 128, 64, 32, 16, 8, 4, 2, 1))
_P32 = tuple(float(2 ** i) for i in (64, 32, 16, 8, 4, 2, 1))
# 1/(2k+1), k = 1 … : the coefficients of 2 atanh s / (2s) − 1 in powers of s²
_ATANH = tuple(1.0 / (2 * k + 1) for k in range(1, 20))
# 1/k!, k = 0 … 15
_FACT = tuple(1.0 / math.factorial(k) for k in range(16))


def _f64() -> bool:
    """Whether kernels compile in double precision (the precision of ``float``)."""
    return ti.cfg.default_fp == ti.f64


def _ln2_hi() -> float:
    return LN2_HI_64 if _f64() else LN2_HI_32


def _ln2_lo() -> float:
    return LN2_LO_64 if _f64() else LN2_LO_32


def _n_atanh() -> int:
    """Terms of the atanh series in s² for |s| ≤ 0.1716 (s² ≤ 0.0295): error < ulp/4."""
    return 10 if _f64() else 5


def _n_atanh_wide() -> int:
    """Terms of the atanh series in s² for |s| ≤ 1/3 (s² ≤ 1/9): error < ulp/4."""
    return 18 if _f64() else 8


def _n_exp() -> int:
    """Degree of the Taylor series of exp r for |r| ≤ 0.3466."""
    return 15 if _f64() else 8


@ti.func
def log(x):
    """Natural logarithm of a normal x > 0 (the engine never calls it with x ≤ 0, subnormals or ∞)."""
    m = x
    k = 0.0
    for i in ti.static(range(len(_P64) if _f64() else len(_P32))):
        p = ti.static((_P64 if _f64() else _P32)[i])
        if m >= p:
            m *= ti.static(1.0 / p)
            k += ti.static(float(math.log2(p)))
        if m < ti.static(1.0 / p):
            m *= p
            k -= ti.static(float(math.log2(p)))
    # now 1 ≤ m < 2 (or [2^-1, 1) from the lower side): bring m into [√½, √2)
    if m >= ti.static(2.0 * SQRT_HALF):
        m *= 0.5
        k += 1.0
    if m < SQRT_HALF:
        m *= 2.0
        k -= 1.0
    f = m - 1.0                                    # exact (Sterbenz)
    s = f / (2.0 + f)
    hf = 0.5 * f * f
    # log m = 2 atanh s = f − hf + s (hf + R), R = 2s² (1/3 + s²/5 + …): f − hf carries most bits
    R = s * s * 2.0 * (ti.static(1.0 / 3.0) + _atanh_tail_rest(s * s, ti.static(_n_atanh())))
    return k * ti.static(_ln2_hi()) - ((hf - (s * (hf + R) + k * ti.static(_ln2_lo()))) - f)


@ti.func
def _atanh_tail_rest(s2, n: ti.template()):
    """Σ_{k=2}^{n} s^{2k-2}/(2k+1) = s²/5 + s⁴/7 + …, by Horner in s²."""
    p = 0.0
    for i in ti.static(range(n - 1, 0, -1)):
        p = p * s2 + ti.static(_ATANH[i])
    return p * s2


@ti.func
def log1p_minus(d):
    """g(d) = d − log(1 + d) ≥ 0 for d > −1, accurate in relative terms near d = 0 (g ≈ d²/2).

    With s = d/(2 + d): log(1 + d) = 2 atanh s, d − 2s = d·s, so
    g = d·s − 2s³ Σ_{k≥0} s^{2k}/(2k+3), no cancellation for ``|s|`` ≤ 1/3 (J in [0.5, 2]); beyond,
    d − log(1 + d) with the rounding of 1 + d corrected (g is then not small against d).
    """
    s = d / (2.0 + d)
    g = 0.0
    if ti.abs(s) <= ti.static(1.0 / 3.0):
        s2 = s * s
        g = d * s - 2.0 * s * s2 * (ti.static(1.0 / 3.0) + _atanh_tail_rest(s2, ti.static(_n_atanh_wide())))
    else:
        u = 1.0 + d
        g = d - (log(u) + (d - (u - 1.0)) / u)
    return g


@ti.func
def log1p(d):
    """log(1 + d) for d > −1, accurate near d = 0."""
    return d - log1p_minus(d)


@ti.func
def _pow2i(k):
    """2ᵏ for an integral float k in [−1022, 1023] (f64) / [−126, 127] (f32), exactly."""
    a = ti.abs(k)
    r = 1.0
    for i in ti.static(range(len(_P64) if _f64() else len(_P32))):
        p = ti.static((_P64 if _f64() else _P32)[i])
        e = ti.static(float(math.log2(p)))
        if a >= e:
            a -= e
            r *= p
    if k < 0.0:
        r = 1.0 / r
    return r


@ti.func
def exp(x):
    """eˣ; 0 below the smallest normal's logarithm and +∞ above the largest's."""
    lo = ti.static(-708.39 if _f64() else -87.33)
    hi = ti.static(709.78 if _f64() else 88.72)
    y = 0.0
    if x > hi:
        y = ti.math.inf
    elif x >= lo:
        k = ti.round(x * ti.static(1.0 / math.log(2.0)))
        # the low part multiplies a copy of k made through an integer: the fast-math
        # reassociation of the CPU back end would otherwise fold k·hi + k·lo into k·ln 2 and
        # lose the split.  In f32 it still regroups (x − k·hi) − k·lo, so the f32 error grows
        # as ~|x|/2 ulp: ≤ 3 ulp over |x| ≤ 4, the engine's range (softening_z)
        kl = ti.cast(ti.cast(k, ti.i32), float)
        r = (x - k * ti.static(_ln2_hi())) - kl * ti.static(_ln2_lo())
        p = 0.0
        for i in ti.static(range(_n_exp(), -1, -1)):
            p = p * r + ti.static(_FACT[i])
        # 2^k in two halves so that neither overflows near the ends of the range
        h = ti.floor(0.5 * k)
        y = p * _pow2i(h) * _pow2i(k - h)
    return y


@ti.func
def ipow(x, n: ti.template()):
    """xⁿ for a compile-time integer n ≥ 0, by repeated squaring (⌈log₂ n⌉ + popcount products)."""
    r = 1.0 + 0.0 * x
    b = x
    for i in ti.static(range(_nbits(n))):
        if ti.static(_bit(n, i)):
            r *= b
        if ti.static(_bit_above(n, i)):
            b *= b
    return r


def _nbits(n) -> int:
    if int(n) != n or n < 0:
        raise ValueError(f"fmath.ipow: the exponent must be an integer >= 0, not {n!r}")
    return max(int(n), 1).bit_length()


def _bit(n, i) -> bool:
    return bool((int(n) >> i) & 1)


def _bit_above(n, i) -> bool:
    return (int(n) >> (i + 1)) > 0


@ti.func
def pow(x, y):
    """xʸ for x > 0 (exp(y·log x): its relative error grows as ``|y log x|`` ulp)."""
    return exp(y * log(x))

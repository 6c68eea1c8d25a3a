"""Analytic references of fluid in fractures (docs/theory/hydro.md §14.2): Sneddon's pressurised
crack and the KGD hydraulic fracture in its toughness- and viscosity-dominated limits.

Pure numpy, SI units, per unit out-of-plane thickness.  The KGD solutions take ``rate`` as the
**total** injection rate Q0 into both wings [m²/s], so that ∫_{-ℓ}^{ℓ} w dx = Q0 t, and return
the half-length ℓ, the opening at the well w(0) and the net pressure at the well p(0) (the fluid
pressure less the confining stress across the fracture).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# Detournay 2004: K-vertex constants (exact); Adachi & Detournay 2002: M-vertex series
GAMMA_K0 = 2.0 / math.pi ** (2.0 / 3.0)
"""ℓ / L_k of the toughness-dominated KGD fracture, 2/π^(2/3) ≈ 0.9324."""
GAMMA_M0 = 0.6152
"""ℓ / L_m of the viscosity-dominated KGD fracture (Adachi & Detournay 2002)."""
_M_A = (1.61750, 0.39650, 1.00297e-2, 1.06179e-2, -2.97947e-3, -0.74268e-3, -1.34675e-3)
_M_B = 0.06858
_ALPHA = 2.0 / 3.0          # the viscous tip exponent of the M-vertex opening


def _positive(value, name: str, where: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{where}: {name} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0.0:
        raise ValueError(f"{where}: {name} must be finite and > 0, got {value!r}")
    return v


def _times(t, where: str) -> np.ndarray:
    arr = np.asarray(t, dtype=np.float64)
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0.0):
        raise ValueError(f"{where}: t must be finite and > 0 [s], got {t!r}")
    return arr


def plane_modulus(young: float, poisson: float, plane: str = "strain") -> float:
    """E' [Pa]: E/(1 − ν²) in plane strain, E in plane stress.

    young : Young's modulus E [Pa] (> 0); poisson : ν (−1 < ν < 0.5); plane : "strain" or "stress".
    """
    where = "plane_modulus"
    e = _positive(young, "young", where)
    try:
        nu = float(poisson)
    except (TypeError, ValueError):
        raise TypeError(f"{where}: poisson must be a number, got {poisson!r}") from None
    if not (-1.0 < nu < 0.5):
        raise ValueError(f"{where}: poisson must lie in (-1, 0.5), got {poisson!r}")
    if plane == "strain":
        return e / (1.0 - nu * nu)
    if plane == "stress":
        return e
    raise ValueError(f"{where}: plane must be 'strain' or 'stress', got {plane!r}")


def sneddon_opening(x, a: float, p: float, young: float, poisson: float, plane: str = "strain") -> np.ndarray:
    """Opening w(x) [m] (distance between the faces) of a crack of half-length ``a`` [m] along
    −a < x < a in an infinite plane, under a uniform internal pressure ``p`` [Pa] (Sneddon 1946):
    w = 4 p/E' √(a² − x²), zero for ``|x|`` ≥ a.  Same shape as ``x`` (any shape, m).

    The volume is 2π p a²/E' (:func:`sneddon_volume`), the stress intensity at the tips
    p √(π a) (:func:`pressurised_crack_stress_intensity`).
    """
    where = "sneddon_opening"
    a = _positive(a, "a", where)
    p = float(p)
    if not math.isfinite(p) or p < 0.0:
        raise ValueError(f"{where}: p must be finite and >= 0 [Pa] (a negative pressure closes the crack), got {p!r}")
    ep = plane_modulus(young, poisson, plane)
    x = np.asarray(x, dtype=np.float64)
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{where}: x must be finite [m]")
    return 4.0 * p / ep * np.sqrt(np.clip(a * a - x * x, 0.0, None))


def sneddon_volume(a: float, p: float, young: float, poisson: float, plane: str = "strain") -> float:
    """Volume per unit thickness [m²] of Sneddon's pressurised crack: ∫ w dx = 2π p a²/E'."""
    where = "sneddon_volume"
    a = _positive(a, "a", where)
    if not math.isfinite(float(p)) or float(p) < 0.0:
        raise ValueError(f"{where}: p must be finite and >= 0 [Pa], got {p!r}")
    return 2.0 * math.pi * float(p) * a * a / plane_modulus(young, poisson, plane)


def pressurised_crack_stress_intensity(a: float, p: float) -> float:
    """Mode-I stress intensity [Pa √m] at the tips of a crack of half-length ``a`` [m] under a
    uniform internal pressure ``p`` [Pa] in an infinite plane: K_I = p √(π a)."""
    return float(p) * math.sqrt(math.pi * _positive(a, "a", "pressurised_crack_stress_intensity"))


@dataclass(frozen=True)
class KGDSolution:
    """A KGD solution at the times ``t`` (array of the shape of the ``t`` given).

    half_length : ℓ(t) [m]; well_opening : w(0, t) [m]; well_pressure : net p(0, t) [Pa];
    regime : "toughness" or "viscosity"; plane_modulus : E' [Pa]; rate : Q0, total [m²/s].
    ``opening(x)`` gives the profile w(x, t) [m] (x broadcast against t).
    """
    t: np.ndarray
    half_length: np.ndarray
    well_opening: np.ndarray
    well_pressure: np.ndarray
    regime: str
    plane_modulus: float
    rate: float

    def opening(self, x) -> np.ndarray:
        """w(x, t) [m] at the positions ``x`` [m] (broadcast against ``t``), zero for ``|x|`` ≥ ℓ."""
        x = np.asarray(x, dtype=np.float64)
        xi = np.abs(x) / self.half_length
        inside = xi < 1.0
        shape = np.clip(xi, 0.0, 1.0)
        prof = _omega_k0(shape) if self.regime == "toughness" else _omega_m0(shape)
        return np.where(inside, self.well_opening * prof, 0.0)


def _omega_k0(xi: np.ndarray) -> np.ndarray:
    """The K-vertex opening normalised by its value at the well: √(1 − ξ²)."""
    return np.sqrt(np.clip(1.0 - xi * xi, 0.0, None))


def _gegenbauer(n: int, lam: float, x: np.ndarray) -> np.ndarray:
    """C_n^(λ)(x) by the three-term recurrence."""
    c0 = np.ones_like(x)
    if n == 0:
        return c0
    c1 = 2.0 * lam * x
    for k in range(2, n + 1):
        c0, c1 = c1, (2.0 * x * (k + lam - 1.0) * c1 - (k + 2.0 * lam - 2.0) * c0) / k
    return c1


def omega_m0_bar(xi) -> np.ndarray:
    """Ω̄_m0(ξ): the M-vertex opening w / (ε_m L_m γ_m0) at ξ = x/ℓ in [0, 1] (Adachi & Detournay
    2002, seven Gegenbauer terms plus the logarithmic term; docs/theory/hydro.md §14.2)."""
    xi = np.clip(np.abs(np.asarray(xi, dtype=np.float64)), 0.0, 1.0)
    s = np.sqrt(1.0 - xi * xi)
    # ln((1 − s)/(1 + s)) with 1 − s = ξ²/(1 + s), exact for small ξ; the term is 0 at ξ = 0
    with np.errstate(divide="ignore"):
        log_ratio = np.log(np.where(xi > 0.0, xi * xi, 1.0)) - 2.0 * np.log1p(s)
    out = _M_B * (4.0 * s + np.where(xi > 0.0, 2.0 * xi * xi * log_ratio, 0.0))
    base = (1.0 - xi * xi) ** _ALPHA
    for j, a_j in enumerate(_M_A):
        out = out + a_j * base * _gegenbauer(2 * j, _ALPHA - 0.5, xi)
    return out


def _pi_m0_well() -> float:
    """Π_m0(0), the M-vertex net pressure at the well in units of ε_m E': the elastic pressure of
    each term of :func:`omega_m0_bar` at ξ = 0 (Adachi & Detournay 2002)."""
    a = _ALPHA

    def beta(x, y):
        return math.gamma(x) * math.gamma(y) / math.gamma(x + y)

    total = _M_A[0] * a / (2.0 * math.pi) * beta(0.5, a) + 2.0 * _M_B
    for j in range(2, len(_M_A) + 1):
        pref = (2 * a - 1) * (2 * j - 1) / (4.0 * math.pi * (j - 1 + a)) * beta(0.5 - j, a + j)
        total += _M_A[j - 1] * pref * (-0.5)
    return total


OMEGA_M0_WELL = GAMMA_M0 * float(omega_m0_bar(0.0))
"""w(0) / (ε_m L_m) of the viscosity-dominated KGD fracture, ≈ 1.1232."""
PI_M0_WELL = _pi_m0_well()
"""p(0) / (ε_m E') of the viscosity-dominated KGD fracture, ≈ 0.5443."""


def _omega_m0(xi: np.ndarray) -> np.ndarray:
    return omega_m0_bar(xi) / float(omega_m0_bar(0.0))


def kgd_toughness(t, rate: float, young: float, poisson: float, toughness: float) -> KGDSolution:
    """The toughness-dominated (zero-viscosity) KGD fracture (docs/theory/hydro.md §14.2).

    t : time(s) since the start of injection [s] (> 0, any shape); rate : Q0, the total injection
    rate into both wings [m²/s]; young [Pa], poisson : the rock's E and ν (plane strain);
    toughness : K_Ic [Pa √m].  Uniform pressure, LEFM at the tips:
    ℓ = (E' Q0 t / (2 √π K_Ic))^(2/3) = γ_k0 (E' Q0 t / K')^(2/3), p = K_Ic/√(π ℓ),
    w(0) = 4 K_Ic √(ℓ/π)/E', profile w(0) √(1 − ξ²).
    """
    where = "kgd_toughness"
    t = _times(t, where)
    q0 = _positive(rate, "rate", where)
    kic = _positive(toughness, "toughness", where)
    ep = plane_modulus(young, poisson, "strain")
    kp = 4.0 * math.sqrt(2.0 / math.pi) * kic                       # K'
    lk = (ep * q0 * t / kp) ** (2.0 / 3.0)                          # L_k
    eps = (kp ** 4 / (ep ** 4 * q0 * t)) ** (1.0 / 3.0)             # ε_k
    return KGDSolution(t=t, half_length=GAMMA_K0 * lk, well_opening=eps * lk * math.pi ** (-1.0 / 3.0),
                       well_pressure=eps * ep * math.pi ** (1.0 / 3.0) / 8.0, regime="toughness",
                       plane_modulus=ep, rate=q0)


def kgd_viscosity(t, rate: float, young: float, poisson: float, viscosity: float) -> KGDSolution:
    """The viscosity-dominated (zero-toughness) KGD fracture (docs/theory/hydro.md §14.2).

    t : time(s) since the start of injection [s] (> 0, any shape); rate : Q0, the total injection
    rate into both wings [m²/s]; young [Pa], poisson : the rock's E and ν (plane strain);
    viscosity : μ [Pa s] (μ' = 12 μ).  ℓ = 0.6152 (E' Q0³ t⁴/μ')^(1/6),
    w(0) = 1.1232 (μ' Q0³ t²/E')^(1/6), p(0) = 0.5443 (μ' E'²/t)^(1/3) (Adachi & Detournay 2002);
    the profile is their seven-term series (:func:`omega_m0_bar`), good to about 1 %.
    """
    where = "kgd_viscosity"
    t = _times(t, where)
    q0 = _positive(rate, "rate", where)
    mup = 12.0 * _positive(viscosity, "viscosity", where)
    ep = plane_modulus(young, poisson, "strain")
    lm = (ep * q0 ** 3 * t ** 4 / mup) ** (1.0 / 6.0)              # L_m
    eps = (mup / (ep * t)) ** (1.0 / 3.0)                          # ε_m
    return KGDSolution(t=t, half_length=GAMMA_M0 * lm, well_opening=OMEGA_M0_WELL * eps * lm,
                       well_pressure=PI_M0_WELL * eps * ep, regime="viscosity", plane_modulus=ep, rate=q0)


def kgd_dimensionless_toughness(rate: float, young: float, poisson: float, toughness: float,
                                viscosity: float) -> float:
    """Detournay's 𝒦 = K' (E'³ μ' Q0)^(−1/4) of a KGD fracture (constant in time), with
    K' = 4 √(2/π) K_Ic, μ' = 12 μ, Q0 the total rate [m²/s]: viscosity-dominated for 𝒦 ≲ 1,
    toughness-dominated for 𝒦 ≳ 4 (Detournay 2004)."""
    where = "kgd_dimensionless_toughness"
    q0 = _positive(rate, "rate", where)
    kic = _positive(toughness, "toughness", where)
    mup = 12.0 * _positive(viscosity, "viscosity", where)
    ep = plane_modulus(young, poisson, "strain")
    return 4.0 * math.sqrt(2.0 / math.pi) * kic * (ep ** 3 * mup * q0) ** -0.25

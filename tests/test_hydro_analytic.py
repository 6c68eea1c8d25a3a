"""The analytic references of fluid-driven fracture (docs/theory/hydro.md §14.2) checked against
what they must satisfy: the injected volume, LEFM at the tips, elasticity between the returned
opening and pressure, the viscous tip asymptote, Griffith's energy balance and the scaling
exponents.  No engine involved."""
import math

import numpy as np
import pytest

from taichi_fdem.verification import hydro

E, NU = 10.0e9, 0.25
EP = E / (1 - NU * NU)
Q0, KIC, MU = 1.0e-4, 1.0e6, 1.0e-3


def _volume(sol):
    """∫_{-ℓ}^{ℓ} w dx of a KGD profile at its (scalar) time, by Gauss-Legendre in x = ℓ sin θ
    (smooth for the √ and the 2/3-power tips)."""
    u, wts = np.polynomial.legendre.leggauss(400)
    th = 0.25 * math.pi * (u + 1.0)                       # θ in (0, π/2)
    ell = float(sol.half_length)
    x = ell * np.sin(th)
    return 2.0 * float(np.sum(0.25 * math.pi * wts * sol.opening(x) * ell * np.cos(th)))


def _well_pressure_from_opening(opening, ell, ep):
    """The net pressure at x = 0 that the symmetric opening w(x) on (−ℓ, ℓ) needs in plane strain:
    p(0) = E'/(2π) ∫_0^ℓ (−w'(x)/x) dx = E'/(2π) [w(0)/ℓ + ∫_0^ℓ (w(0) − w(x))/x² dx]
    (the Hilbert-transform form of Sneddon's integral equation, integrated by parts)."""
    u, wts = np.polynomial.legendre.leggauss(600)
    s = 0.5 * (u + 1.0)                                   # x = ℓ s², clusters points at both ends
    s = s * s * (3.0 - 2.0 * s)
    ds = 0.5 * wts * 6.0 * (0.5 * (u + 1.0)) * (1.0 - 0.5 * (u + 1.0))
    x = ell * s
    w0 = float(opening(np.array(0.0)))
    integral = float(np.sum(ds * ell * (w0 - opening(x)) / x ** 2))
    return ep / (2.0 * math.pi) * (w0 / ell + integral)


# ---------------------------------------------------------------------------------------------
# Sneddon

def test_sneddon_opening_centre_volume_and_plane_stress():
    a, p = 0.5, 2.0e6
    w = hydro.sneddon_opening(np.array([0.0, 0.3, -0.3, 0.5, 0.7]), a, p, E, NU)
    assert w[0] == pytest.approx(4 * (1 - NU ** 2) * p * a / E, rel=1e-14)
    assert w[1] == pytest.approx(w[2]) and w[1] == pytest.approx(w[0] * 0.8, rel=1e-14)
    assert w[3] == 0.0 and w[4] == 0.0
    # plane stress: E' = E
    assert hydro.sneddon_opening(0.0, a, p, E, NU, plane="stress") == pytest.approx(4 * p * a / E)
    # the volume 2π p a²/E' is the integral of the profile
    th = np.linspace(-0.5 * math.pi, 0.5 * math.pi, 20001)
    vol = np.trapezoid(hydro.sneddon_opening(a * np.sin(th), a, p, E, NU) * a * np.cos(th), th)
    assert vol == pytest.approx(hydro.sneddon_volume(a, p, E, NU), rel=1e-7)
    # the opening and the pressure satisfy elasticity (the quadrature of the M-vertex check)
    p_back = _well_pressure_from_opening(lambda x: hydro.sneddon_opening(x, a, p, E, NU), a, EP)
    assert p_back == pytest.approx(p, rel=1e-4)


def test_sneddon_stress_intensity():
    assert hydro.pressurised_crack_stress_intensity(0.2, 3.0e6) == pytest.approx(3.0e6 * math.sqrt(math.pi * 0.2))


# ---------------------------------------------------------------------------------------------
# KGD, toughness-dominated

def test_kgd_toughness_stores_the_injected_volume_at_the_toughness():
    t = np.array([0.5, 3.0, 40.0])
    sol = hydro.kgd_toughness(t, Q0, E, NU, KIC)
    assert sol.regime == "toughness" and sol.half_length.shape == (3,)
    for k in range(3):
        one = hydro.kgd_toughness(t[k], Q0, E, NU, KIC)
        # volume: the Sneddon crack of the well pressure holds Q0 t
        assert _volume(one) == pytest.approx(Q0 * t[k], rel=1e-9)
        assert hydro.sneddon_volume(one.half_length, one.well_pressure, E, NU) == pytest.approx(Q0 * t[k], rel=1e-12)
        # uniform pressure: the opening is Sneddon's for that pressure
        x = np.linspace(-1.2, 1.2, 14) * float(one.half_length)
        np.testing.assert_allclose(one.opening(x), hydro.sneddon_opening(x, float(one.half_length),
                                   float(one.well_pressure), E, NU), rtol=1e-12, atol=1e-18)
    # LEFM at the tips: K_I = p √(π ℓ) = K_Ic
    np.testing.assert_allclose(sol.well_pressure * np.sqrt(np.pi * sol.half_length), KIC, rtol=1e-12)


def test_kgd_toughness_energy_balance_is_griffiths():
    """The work of injection ∫ p Q0 dt = strain energy p V/2 + fracture energy 2ℓ K_Ic²/E'."""
    tau = np.linspace(1e-3, 20.0 ** (1 / 3), 20001)      # t = τ³: p dt = 3 τ² p dτ is smooth
    sol = hydro.kgd_toughness(tau ** 3, Q0, E, NU, KIC)
    work = np.trapezoid(3 * tau ** 2 * sol.well_pressure * Q0, tau)
    strain = 0.5 * sol.well_pressure[-1] * Q0 * sol.t[-1]
    fracture = 2.0 * sol.half_length[-1] * KIC ** 2 / EP
    assert work == pytest.approx(strain + fracture, rel=1e-4)


def test_kgd_toughness_scalings():
    a = hydro.kgd_toughness([1.0, 8.0], Q0, E, NU, KIC)
    assert a.half_length[1] / a.half_length[0] == pytest.approx(8 ** (2 / 3))
    assert a.well_opening[1] / a.well_opening[0] == pytest.approx(8 ** (1 / 3))
    assert a.well_pressure[1] / a.well_pressure[0] == pytest.approx(8 ** (-1 / 3))
    b = hydro.kgd_toughness(1.0, Q0, E, NU, 8 * KIC)
    assert float(b.half_length) / a.half_length[0] == pytest.approx(8 ** (-2 / 3))
    # the LEFM form and Detournay's K-scaling agree: ℓ = (E' Q0 t / (2 √π K_Ic))^(2/3)
    assert a.half_length[0] == pytest.approx((EP * Q0 / (2 * math.sqrt(math.pi) * KIC)) ** (2 / 3), rel=1e-12)


# ---------------------------------------------------------------------------------------------
# KGD, viscosity-dominated

def test_kgd_viscosity_volume_balance_to_the_precision_of_the_series():
    """The seven-term series of Adachi & Detournay with γ_m0 = 0.6152 stores Q0 t to 0.5 %."""
    for t in (0.1, 10.0, 1.0e3):
        sol = hydro.kgd_viscosity(t, Q0, E, NU, MU)
        assert _volume(sol) == pytest.approx(Q0 * t, rel=5e-3)


def test_kgd_viscosity_pressure_is_the_elastic_response_of_the_opening():
    """The well pressure (closed forms of the series) equals the pressure that elasticity gives
    for the returned opening profile."""
    sol = hydro.kgd_viscosity(5.0, Q0, E, NU, MU)
    p = _well_pressure_from_opening(sol.opening, float(sol.half_length), EP)
    assert p == pytest.approx(float(sol.well_pressure), rel=1e-6)


def test_kgd_viscosity_tip_follows_the_viscous_asymptote():
    """w ≈ β_m (μ' ℓ̇/E')^(1/3) (ℓ − x)^(2/3), β_m = 2^(1/3) 3^(5/6) (Desroches et al. 1994), to 2 %."""
    t = 3.0
    sol = hydro.kgd_viscosity(t, Q0, E, NU, MU)
    ell = float(sol.half_length)
    v = 2.0 / 3.0 * ell / t
    beta = 2 ** (1 / 3) * 3 ** (5 / 6)
    for d in (1e-4, 1e-3):
        w = float(sol.opening(ell * (1 - d)))
        asym = beta * (12 * MU * v / EP) ** (1 / 3) * (ell * d) ** (2 / 3)
        assert w == pytest.approx(asym, rel=0.02)


def test_kgd_viscosity_scalings_and_constants():
    s = hydro.kgd_viscosity([1.0, 8.0], Q0, E, NU, MU)
    assert s.half_length[1] / s.half_length[0] == pytest.approx(8 ** (2 / 3))
    assert s.well_opening[1] / s.well_opening[0] == pytest.approx(8 ** (1 / 3))
    assert s.well_pressure[1] / s.well_pressure[0] == pytest.approx(8 ** (-1 / 3))
    m = hydro.kgd_viscosity(1.0, Q0, E, NU, 64 * MU)
    assert float(m.half_length) / s.half_length[0] == pytest.approx(64 ** (-1 / 6))
    mup = 12 * MU
    assert s.half_length[0] == pytest.approx(0.6152 * (EP * Q0 ** 3 / mup) ** (1 / 6), rel=1e-12)
    assert s.well_opening[0] == pytest.approx(1.1232 * (mup * Q0 ** 3 / EP) ** (1 / 6), rel=1e-4)
    assert s.well_pressure[0] == pytest.approx(0.5443 * (mup * EP ** 2) ** (1 / 3), rel=1e-4)
    # the profile is largest at the well and vanishes at the tip
    x = np.linspace(0, 1, 101) * s.half_length[0]
    w = hydro.kgd_viscosity(1.0, Q0, E, NU, MU).opening(x)
    assert np.all(np.diff(w) <= 0) and w[-1] == 0.0 and w[0] == pytest.approx(s.well_opening[0])


def test_dimensionless_toughness():
    """𝒦⁴ = K'^4/(E'³ μ' Q0) = 256/(3π²) K_Ic⁴/(μ Q0 E'³)."""
    k = hydro.kgd_dimensionless_toughness(Q0, E, NU, KIC, MU)
    assert k ** 4 == pytest.approx(256 / (3 * math.pi ** 2) * KIC ** 4 / (MU * Q0 * EP ** 3), rel=1e-12)
    assert hydro.kgd_dimensionless_toughness(Q0, E, NU, 4 * KIC, MU) == pytest.approx(4 * k)


# ---------------------------------------------------------------------------------------------
# bad input

@pytest.mark.parametrize("call, match", [
    (lambda: hydro.sneddon_opening(0.0, -1.0, 1e6, E, NU), "a must be"),
    (lambda: hydro.sneddon_opening(0.0, 1.0, -1e6, E, NU), "p must be"),
    (lambda: hydro.sneddon_opening(0.0, 1.0, 1e6, E, 0.5), "poisson"),
    (lambda: hydro.sneddon_opening(0.0, 1.0, 1e6, 0.0, NU), "young"),
    (lambda: hydro.sneddon_opening(0.0, 1.0, 1e6, E, NU, plane="3d"), "plane"),
    (lambda: hydro.sneddon_opening(np.nan, 1.0, 1e6, E, NU), "x must be finite"),
    (lambda: hydro.kgd_toughness(0.0, Q0, E, NU, KIC), "t must be"),
    (lambda: hydro.kgd_toughness([1.0, -1.0], Q0, E, NU, KIC), "t must be"),
    (lambda: hydro.kgd_toughness(1.0, 0.0, E, NU, KIC), "rate"),
    (lambda: hydro.kgd_toughness(1.0, Q0, E, NU, 0.0), "toughness"),
    (lambda: hydro.kgd_viscosity(1.0, Q0, E, NU, -1e-3), "viscosity"),
    (lambda: hydro.kgd_viscosity(1.0, math.inf, E, NU, MU), "rate"),
    (lambda: hydro.kgd_dimensionless_toughness(Q0, E, NU, KIC, 0.0), "viscosity"),
])
def test_bad_input_is_refused(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_non_numbers_are_refused():
    with pytest.raises(TypeError, match="rate must be a number"):
        hydro.kgd_viscosity(1.0, "fast", E, NU, MU)

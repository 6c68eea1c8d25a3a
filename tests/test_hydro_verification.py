"""Fluid in fractures against the analytic references (docs/theory/hydro.md §14.2), with the
engine: Sneddon's pressurised crack and the KGD hydraulic fracture in its toughness- and
viscosity-dominated regimes (taichi_fdem.verification.hydro_cases).  Tolerances are stated per
test with the measured errors; ``-s`` prints them."""
import numpy as np
import pytest

import taichi_fdem as fdem

pytestmark = pytest.mark.skipif(not hasattr(fdem, "Fluid"), reason="the fluid engine (fdem.Fluid) is not built")


def _show(name, r, keys):
    print(f"{name}: " + ", ".join(f"{k} = {r[k]:.4g}" for k in keys) + f"; {r['steps']} steps, {r['wall']:.1f} s")


def test_crack_plate_mesh_is_graded_and_follows_the_crack():
    from taichi_fdem.verification.hydro_cases import crack_plate_mesh
    m = crack_plate_mesh(1.0, 20.0, 1 / 8, 1.25)
    assert m.bounding_box() == pytest.approx((-10.0, -10.0, 10.0, 10.0))
    assert m.area == pytest.approx(400.0)
    x, y = m.points.T
    on_crack = (np.abs(y) < 1e-12) & (np.abs(x) <= 1.0 + 1e-12)
    assert on_crack.sum() == 17                               # h = a/8 along −a..a
    assert np.any((np.abs(x - 1.0) < 1e-12) & (np.abs(y) < 1e-12))
    # graded: far fewer triangles than a uniform mesh of the crack's cell size
    assert len(m.triangles) < 0.1 * 2 * (20 * 8) ** 2
    # symmetric about both axes
    pts = {(round(a, 9), round(b, 9)) for a, b in m.points}
    assert all((round(-a, 9), round(b, 9)) in pts and (round(a, 9), round(-b, 9)) in pts for a, b in pts)
    with pytest.raises(ValueError, match="no room"):
        crack_plate_mesh(1.0, 2.0, 0.1)


def test_sneddon_opening_at_the_centre_within_5_percent():
    """A crack of half-length a in a plate 20a wide, held at p by a pressure source on every node
    of the crack (``scene.inject(where=crack, pressure=p)``), settled: opening at the centre
    against 4(1 − ν²) p a/E.  Tolerance 5 %; measured −1.8 % at 16 cells per half-crack
    (the plate's finite width adds about +0.6 %, the CST mesh is slightly stiff)."""
    from taichi_fdem.verification.hydro_cases import case_sneddon
    r = case_sneddon(resolution=16, ratio=20.0, safety=0.4, strategy="serial")
    _show("sneddon", r, ("error", "opening", "opening_analytic"))
    assert r["opening"] < r["opening_analytic"]              # the mesh is stiff, not soft
    assert r["error"] < 0.05
    # the profile: within 6 % at x = a/2 and 10 % at 3a/4 (closer to the tip, fewer cells)
    assert r["opening_half"] == pytest.approx(r["opening_half_analytic"], rel=0.06)
    assert r["opening_3q"] == pytest.approx(r["opening_3q_analytic"], rel=0.10)


@pytest.mark.slow
def test_sneddon_converges_with_the_mesh():
    """32 cells per half-crack: the centre opening within 2 % (the finite plate's +0.6 % included);
    measured −0.67 %."""
    from taichi_fdem.verification.hydro_cases import case_sneddon
    r = case_sneddon(resolution=32, ratio=20.0, safety=0.4, strategy="serial")
    _show("sneddon 32", r, ("error", "opening", "opening_analytic"))
    assert r["error"] < 0.02


def _kgd(regime, **kw):
    from taichi_fdem.verification.hydro_cases import case_kgd
    r = case_kgd(regime, safety=0.4, samples=6, **kw)
    print(f"kgd {regime}: 𝒦 = {r['kappa']:.3g}, Q0 = {r['rate']:.4g} m²/s, μ = {r['viscosity']:.4g} Pa s, "
          f"K_Ic = {r['toughness']:.4g} Pa√m, ℓ_c = {r['cohesive_length']:.3g} m, h = {r['h']:.3g} m")
    for k in range(len(r["time"])):
        print(f"  t = {r['time'][k]:.4g} s: ℓ = {r['half_length'][k]:.4g} (broken {r['half_length_broken'][k]:.4g}, "
              f"wet {r['half_length_wet'][k]:.4g}) / {r['half_length_analytic'][k]:.4g} m, "
              f"w(0) = {r['well_opening'][k]:.4g} / {r['well_opening_analytic'][k]:.4g} m, "
              f"p(0) = {r['well_pressure'][k]:.4g} / {r['well_pressure_analytic'][k]:.4g} Pa"
              f"{'' if r['compared'][k] else '  (not compared)'}")
    _show(f"kgd {regime}", r, ("error_length", "error_opening", "error_pressure"))
    return r


def _exponent(t, y):
    """The least-squares slope of log y against log t."""
    return float(np.polyfit(np.log(t), np.log(y), 1)[0])


def test_kgd_toughness_dominated_short():
    """𝒦 = 6, a plate 10 m wide (5 × the joint path), 8 cells per metre, process zone 2 cells:
    length, well opening and well pressure against the K-vertex at the records with ℓ ≥ twice the
    seed.  Tolerances 8 %, 10 %, 15 %; measured 4.0 %, 4.6 %, 12 % (the pressure early on, when
    the fracture is 3 process zones long).  Growth ℓ ∝ t^(2/3) to ±0.1."""
    r = _kgd("toughness", resolution=8, ratio=5.0, aperture_min=3e-4)
    assert r["error_length"] < 0.08 and r["error_opening"] < 0.10 and r["error_pressure"] < 0.15
    use = r["compared"]
    assert _exponent(r["time"][use], r["half_length"][use]) == pytest.approx(2 / 3, abs=0.1)


@pytest.mark.slow
def test_kgd_toughness_dominated():
    """As the short test in a plate 20 m wide (10 × the path).  Tolerances 6 %, 8 %, 10 %;
    measured 4.0 %, 4.1 %, 8.3 %."""
    r = _kgd("toughness", resolution=8, ratio=10.0, aperture_min=3e-4)
    assert r["error_length"] < 0.06 and r["error_opening"] < 0.08 and r["error_pressure"] < 0.10


def test_kgd_viscosity_dominated_short():
    """𝒦 = 0.25 without confinement: the low-strength joints break far ahead of the fluid (a dry,
    open crack: the fluid lag that the M-vertex leaves out), so the length compared is the wet
    one (network nodes at more than 1 % of the well pressure).  Tolerances: wet length 25 %, well
    opening 12 %, well pressure 35 % (measured 21 %, 8.5 %, 33 %: the long dry crack is softer).
    The pressure is several times the K-vertex's of the same toughness: viscosity dominates."""
    from taichi_fdem.verification.hydro import kgd_toughness
    r = _kgd("viscosity", resolution=8, ratio=5.0, aperture_min=3e-4)
    use = r["compared"]
    wet = np.abs(r["half_length_wet"] - r["half_length_analytic"]) / r["half_length_analytic"]
    assert wet[use].max() < 0.25 and r["error_opening"] < 0.12 and r["error_pressure"] < 0.35
    k = kgd_toughness(r["time"], r["rate"], r["young"], r["poisson"], r["toughness"])
    assert np.all(r["well_pressure"][use] > 3.0 * k.well_pressure[use])


@pytest.mark.slow
def test_kgd_viscosity_dominated_confined():
    """𝒦 = 0.25 under a confining pressure σ0 = 5.3e7 Pa (about 5 × the net pressure) that closes
    the dry crack ahead of the fluid: equivalent LEFM length, well opening and net well pressure
    p − σ0 against the M-vertex.  Tolerances 8 %, 8 %, 15 %; measured 5.8 %, 5.4 %, 11 %."""
    r = _kgd("viscosity", resolution=8, ratio=5.0, aperture_min=3e-4, confinement=5.3e7, bulk_modulus=3e9)
    assert r["error_length"] < 0.08 and r["error_opening"] < 0.08 and r["error_pressure"] < 0.15

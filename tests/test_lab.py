"""fdem.lab: standard lab tests as functions (elastic moduli, BTS scaling, interface friction, envelopes)."""
import math
import warnings

import numpy as np
import pytest

import taichi_fdem as fdem

ROCK = dict(density=2600.0, young=20e9, poisson=0.2)


def test_elastic_ucs_returns_the_materials_E_and_nu(tmp_path):
    m = fdem.Material(**ROCK)
    r = fdem.lab.ucs(m, 0.05, 0.1, 0.0125, samples=40, rate_transits=30)
    assert abs(r.young / m.young - 1) < 0.02 and abs(r.poisson / m.poisson - 1) < 0.02, r
    # the plane-strain moduli the curve shows directly: E/(1 − ν²), ν/(1 − ν)
    assert abs(r.plane_modulus / (m.young / (1 - 0.04)) - 1) < 0.02
    assert r.kinetic_ratio < fdem.lab.MAX_KINETIC_RATIO
    path = r.to_csv(str(tmp_path / "ucs.csv"))
    data = np.genfromtxt(path, delimiter=",", names=True)
    assert np.allclose(data["axial_stress_Pa"], r.curve["axial_stress_Pa"], rtol=1e-6)
    assert math.isclose(data["axial_stress_Pa"].max(), r.peak_stress, rel_tol=1e-6)


def test_jointed_ucs_returns_the_materials_E_and_nu_at_the_defaults():
    """Joints on every edge (a fracturing specimen) at the default joint penalty: the tangent E
    and ν below 30 % of the peak within 3 % of the material's (the elastic continuum's)."""
    m = fdem.Material(**ROCK, tensile_strength=6e6, cohesion=20e6, friction_angle=35.0, fracture_energy=50.0)
    r = fdem.lab.ucs(m, 0.05, 0.1, 0.01)
    assert r.settings["joint_penalty_factor"] == fdem.lab.COMPRESSION_JOINT_PENALTY_FACTOR
    assert r.settings["joint_penalty_raised"]
    assert abs(r.young_initial / m.young - 1) < 0.03, r
    assert abs(r.poisson_initial / m.poisson - 1) < 0.03, r
    assert m.joint_penalty is None                                  # the user's Material is unchanged


def test_too_fast_loading_is_refused():
    with pytest.raises(ValueError, match="P-wave transits"):
        fdem.lab.ucs(fdem.Material(**ROCK), 0.05, 0.1, 0.0125, rate_transits=2)
    with pytest.raises(ValueError, match="confinement"):
        fdem.lab.triaxial(fdem.Material(**ROCK), 0.05, 0.1, 0.0125, -1e6)


def test_bts_is_proportional_to_ft_at_fixed_brittleness():
    """The Brazilian strength depends on f_t through dimensionless groups only: f_t/E (the strain
    at failure), the brittleness l_ch/D = E G_I/(f_t² D), c/f_t, φ, G_II/G_I, ν, p_f/E, the
    platens' E and penalty over the disc's E (10 and 3 by default), h/D, the cap angle, the
    damping β and the loading time in D/c_p transits.  Doubling f_t with E × 2 and G_I × 2
    (and c = 3 f_t) keeps every group fixed, so σ_t/f_t must not change: the BTS doubles.  It
    also checks that no absolute length, time or stress hides in the set-up (the density is
    kept, so c_p and every time scale change by √2).

    Doubling f_t alone (E fixed, G_I × 4 to keep l_ch) also doubles f_t/E, which a
    small-strain model would not feel; this one does, through the platen contact (the slow
    test below)."""
    peaks = []
    for ft, young, gi in ((4e6, 20e9, 30.0), (8e6, 40e9, 60.0)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            m = fdem.Material(**dict(ROCK, young=young), damping=1.0, tensile_strength=ft, fracture_energy=gi,
                              cohesion=3 * ft, friction_angle=35.0)
            r = fdem.lab.brazilian(m, 0.05, 0.05 / 10, load_time=30.0, samples=80)
        peaks.append(r.peak_stress)
        assert r.peaked and r.broken > 0, r
        assert 0.6 < r.centre_stress / ft < 1.4, r
    assert abs(peaks[1] / peaks[0] / 2.0 - 1.0) < 1e-6, peaks


@pytest.mark.slow
def test_bts_at_fixed_young_modulus_rises_with_ft_over_e():
    """f_t × 2 with E fixed and l_ch fixed (G_I × 4, c = 3 f_t), at the defaults and 20 elements
    across: f_t/E doubles too, and through the platen contact the BTS more than doubles, by
    at most a quarter more."""
    peaks = []
    for ft in (4e6, 8e6):
        r = fdem.lab.brazilian(_rock(ft, 20e9, 3.0, 35.0), 0.05, 0.05 / 20)
        assert r.peaked and r.central_fraction > 0.8, r
        peaks.append(r.peak_stress)
    assert 1.0 < peaks[1] / peaks[0] / 2.0 < 1.25, peaks


def _rock(ft, young, c_over_ft, phi, lch=9.375e-3, **kw):
    """A rock of tensile strength ft [Pa] with cohesion c_over_ft × ft and a characteristic
    length l_ch = E G_I / f_t² of ``lch`` [m] (G_I scaled with f_t² / E)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return fdem.Material(density=2600.0, young=young, poisson=0.2, tensile_strength=ft,
                             cohesion=c_over_ft * ft, friction_angle=phi, fracture_energy=lch * ft * ft / young, **kw)


def test_brazilian_chooses_and_reports_its_settings_without_changing_the_material():
    """The default call is quasi-static by itself: local damping on (α = 0.3), the joint penalty raised
    to JOINT_PENALTY_FACTOR × E on a copy of the material (the Material given keeps
    joint_penalty=None), everything reported in result.settings; check="rate" reruns at half
    the rate and reports the change of the peak (its size at the defaults: the slow test
    below)."""
    m = _rock(4e6, 20e9, 3.0, 35.0)
    before = repr(m)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        r = fdem.lab.brazilian(m, 0.05, 0.05 / 20)
    assert repr(m) == before and m.joint_penalty is None
    st = r.settings
    assert st["quasi_static"] == 0.3 and st["safety"] == 0.2 and st["load_time"] == 60.0
    assert st["joint_penalty_raised"] and st["joint_penalty"] == pytest.approx(fdem.lab.JOINT_PENALTY_FACTOR * 20e9)
    assert r.material.joint_penalty == pytest.approx(st["joint_penalty"])
    # the symmetric disc of 20 elements: 64 boundary nodes, the flats end at the one at 11.25°
    assert st["alpha_deg"] == pytest.approx(11.25) and st["loaded_arc_deg"] == pytest.approx(11.25)
    assert r.hondros == pytest.approx(fdem.verification.hondros_factor(11.25), rel=1e-12)
    assert st["mesh"] == "disk (symmetric)" and st["platen_penalty"] == pytest.approx(3 * 20e9)
    assert r.convergence == {}
    # the split starts in the centre, in tension, on the line of joints along the loaded diameter
    x, y = r.split_start
    assert abs(x) < 1e-6 and abs(y) < 0.05 / 6, r.split_start
    with pytest.raises(ValueError, match="check must be"):
        fdem.lab.brazilian(m, 0.05, 0.005, check="time")
    coarse = fdem.lab.brazilian(m, 0.05, 0.05 / 10, check="rate", samples=80)
    assert set(coarse.convergence) == {"rate"} and math.isfinite(coarse.convergence["rate"])
    # a joint penalty the material sets is kept
    mine = m.with_(joint_penalty=200e9)
    mats, pf, raised = fdem.lab.results.lab_materials(mine, 50.0, "t")
    assert mats is mine and pf == 200e9 and not raised


@pytest.mark.slow
def test_halving_the_loading_rate_changes_the_default_brazilian_strength_by_under_3_percent():
    r = fdem.lab.brazilian(_rock(4e6, 20e9, 3.0, 35.0), 0.05, 0.05 / 20, check="rate")
    assert abs(r.convergence["rate"]) < 0.03, r.convergence


# f_t [Pa], E [Pa], c / f_t, φ [°]: corners and edges of ordinary rock (f_t 2–20 MPa,
# E 5–80 GPa, c 2–5 f_t, φ 25–45°, f_t/E 1e-4 to 1e-3), l_ch = E G_I/f_t² = D/5.3, 20 elements
# across a 50 mm disc (benchmarks/results.md; docs/guide/lab.md "What the Brazilian strength
# measures" for discs of other sizes against l_ch)
BTS_CASES = [(4e6, 20e9, 3.0, 35.0), (20e6, 80e9, 2.0, 25.0), (2e6, 5e9, 3.0, 35.0)]
BTS_CASES_SLOW = [(2e6, 20e9, 2.0, 25.0), (2e6, 20e9, 5.0, 45.0), (5e6, 5e9, 3.0, 35.0), (20e6, 80e9, 5.0, 45.0),
                  (20e6, 20e9, 3.0, 35.0), (8e6, 20e9, 2.0, 45.0), (8e6, 20e9, 5.0, 25.0)]


def _bts_within_ten_percent(ft, young, c_over_ft, phi):
    r = fdem.lab.brazilian(_rock(ft, young, c_over_ft, phi), 0.05, 0.05 / 20)
    assert r.peaked and abs(r.centre_stress / ft - 1.0) < 0.10, r
    assert r.central_fraction > 1 / 3, r


@pytest.mark.parametrize("ft, young, c_over_ft, phi", BTS_CASES)
def test_brazilian_strength_is_the_tensile_strength_at_the_defaults(ft, young, c_over_ft, phi):
    """The default call, 20 elements across: BTS (the centre stress, the Hondros factor of the
    loaded arc included) within 10 % of f_t, the split along the loaded diameter."""
    _bts_within_ten_percent(ft, young, c_over_ft, phi)


@pytest.mark.slow
@pytest.mark.parametrize("ft, young, c_over_ft, phi", BTS_CASES_SLOW)
def test_brazilian_strength_is_the_tensile_strength_at_the_defaults_slow(ft, young, c_over_ft, phi):
    _bts_within_ten_percent(ft, young, c_over_ft, phi)


@pytest.mark.slow
def test_brazilian_disc_of_about_one_characteristic_length_splits_above_ft():
    """The size effect of a cohesive crack: with l_ch = D/1.3 the cohesive zone spans the disc's
    centre before the first joint breaks and the split's load is above f_t, and above that
    of the disc of l_ch = D/5.3; the split still starts in tension in the centre."""
    big = fdem.lab.brazilian(_rock(4e6, 20e9, 3.0, 35.0, lch=0.0375), 0.05, 0.05 / 20)
    small = fdem.lab.brazilian(_rock(4e6, 20e9, 3.0, 35.0), 0.05, 0.05 / 20)
    assert big.centre_stress / 4e6 > 1.10 and big.centre_stress > small.centre_stress * 1.05, (big, small)
    x, y = big.split_start
    assert abs(x) < 1e-6 and abs(y) < 0.05 / 6, big.split_start


def test_direct_shear_of_a_frictional_interface():
    m = fdem.Material(**ROCK, friction=0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        r = fdem.lab.direct_shear(m, 0.1, 0.05, 0.0125, 1e6, samples=40, rate_transits=30)
    assert abs(r.friction_residual / 0.5 - 1) < 0.02, r
    assert 0.5 * 0.98 < r.friction_peak < 0.5 * 1.1, r
    assert len(r.curve["dilation_m"]) == len(r.curve["shear_stress_Pa"])


def test_envelope_fits_recover_mohr_coulomb_and_hoek_brown():
    c, phi = 10e6, 35.0
    s3 = np.array([0.0, 2e6, 5e6, 10e6, 20e6])
    s = math.sin(math.radians(phi))
    k = (1 + s) / (1 - s)
    s1 = 2 * c * math.cos(math.radians(phi)) / (1 - s) + k * s3
    env = fdem.lab.fit_envelope(sigma3=s3, sigma1=s1)
    assert math.isclose(env.cohesion, c, rel_tol=1e-9) and math.isclose(env.friction_angle, phi, rel_tol=1e-9)
    sci, mi = 150e6, 25.0
    s1_hb = s3 + sci * np.sqrt(mi * s3 / sci + 1)
    hb = fdem.lab.fit_envelope(sigma3=s3, sigma1=s1_hb)
    assert math.isclose(hb.m_i, mi, rel_tol=1e-9) and math.isclose(hb.ucs_hb, sci, rel_tol=1e-9)
    assert hb.residual_hb < 1e-6 * sci
    # from result objects
    res = [fdem.lab.LabResult("triaxial", {}, dict(confinement=a, peak_stress=b)) for a, b in zip(s3, s1)]
    assert math.isclose(fdem.lab.fit_envelope(res).friction_angle, phi, rel_tol=1e-9)
    with pytest.raises(ValueError, match="distinct"):
        fdem.lab.fit_envelope(sigma3=[1e6, 1e6], sigma1=[5e6, 6e6])


def test_default_cohesion_warns_and_lowers_the_brazilian_strength():
    """The joints' default cohesion is c = f_t (φ = 30°), with a RuntimeWarning: the compressed
    joints at the platens then fail in shear before the disc splits, and the Brazilian peak
    falls well below f_t; with c = 3 f_t, φ = 35° (c ≈ 2–4 f_t is rock's range, UCS/BTS ≈
    10–20) the same disc splits in its centre near f_t (docs/guide/fracture.md, "Joint
    cohesion")."""
    kw = dict(ROCK, damping=1.0, tensile_strength=8e6, fracture_energy=30.0)
    with pytest.warns(RuntimeWarning, match="compressed joints fail in shear first"):
        default = fdem.Material(**kw)
    strong = fdem.Material(**kw, cohesion=24e6, friction_angle=35.0)
    out = []
    for m in (default, strong):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            out.append(fdem.lab.brazilian(m, 0.05, 0.05 / 20, load_time=30.0, samples=80))
    d, s = out
    assert d.peaked and s.peaked
    assert 0.8 < s.centre_stress / 8e6 < 1.3 and s.central_fraction > 0.5, s
    assert d.centre_stress < 0.8 * 8e6 and d.centre_stress < 0.7 * s.centre_stress, (d, s)


def test_direct_shear_of_a_cohesive_joint():
    """A cohesive joint on the shear plane (joint=True): the peak is its Mohr–Coulomb strength
    c + σn tan φ (μ = 0: the broken faces, and the intact joint's carried share, add no
    friction; measured 0.93 of it, the joint failing progressively from the box's ends), and
    once broken the faces slide at μ σn (measured 0.98 μ σn at μ = 0.5; 0.05 σn at μ = 0)."""
    kw = dict(ROCK, tensile_strength=1e6, fracture_energy=30.0, cohesion=2e6, friction_angle=30.0,
              fracture_energy_shear=2000.0)
    sn = 1e6
    peak = 2e6 + sn * math.tan(math.radians(30.0))
    out = {}
    for mu in (0.0, 0.5):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            out[mu] = fdem.lab.direct_shear(fdem.Material(**kw, friction=mu), 0.1, 0.05, 0.0125, sn, samples=60,
                                            rate_transits=30, joint=True)
    r0, r5 = out[0.0], out[0.5]
    assert r0.peak_mc == pytest.approx(peak, rel=1e-12)
    assert 0.85 < r0.peak_shear / peak < 1.05, r0
    assert r0.broken > 0 and r0.residual_shear < 0.1 * sn, r0
    assert r5.broken > 0 and abs(r5.residual_shear / (0.5 * sn) - 1) < 0.05, r5
    assert r5.peak_shear > r5.residual_shear * 3, r5
    with pytest.raises(ValueError, match="whole number of cells"):
        fdem.lab.direct_shear(fdem.Material(**kw), 0.1, 0.05, 0.0167, sn, joint=True)


def test_loading_arc_ends_the_flats_at_a_boundary_node():
    """With alpha_deg unset the caps are clipped at the boundary node nearest to 10°, so each
    flat ends at a node; the Hondros factor takes the half-arc the flats actually span."""
    from taichi_fdem.lab.tensile import loading_arc
    pts = fdem.mesh.disk(0.025, 0.0025).points          # 64 nodes on the circle, 5.625° apart
    assert loading_arc(pts, 0.025, None) == pytest.approx((11.25, 11.25), rel=1e-12)
    # clipped at 10°, the flats end at the nodes at ±5.625°
    assert loading_arc(pts, 0.025, 10.0) == pytest.approx((10.0, 5.625), rel=1e-12)
    with pytest.raises(ValueError, match="alpha_deg"):
        loading_arc(pts, 0.025, 75.0)


def test_mesh_check_of_a_compression_test_reruns_on_a_refined_mesh():
    """check="mesh" builds the default mesh again at h/2 (not the first run's mesh): the peak of
    an elastic specimen loaded to the same strain changes, by little."""
    r = fdem.lab.ucs(fdem.Material(**ROCK), 0.05, 0.1, 0.0125, samples=40, rate_transits=30, check="mesh")
    assert set(r.convergence) == {"mesh"}
    assert 0.0 < abs(r.convergence["mesh"]) < 0.02, r.convergence


def test_brazilian_warns_where_the_disc_cannot_measure_ft():
    """l_ch under 3 elements (the cohesive zone unresolved) and a disc under two l_ch (the size
    effect) are each warned of at the caller's line, ahead of any simulation."""
    def options(m):                                  # stands for lab.brazilian (one frame)
        return fdem.lab.tensile._brazilian_options(m, 0.05, 0.0025, None, None, None, None, None, 3.0)

    brittle = _rock(4e6, 20e9, 3.0, 35.0, lch=2.5e-3)                        # l_ch = h
    with pytest.warns(RuntimeWarning, match=r"l_ch = E G_I/f_t² = 2\.5 mm is under 3 elements") as rec:
        options(brittle)
    assert rec[0].filename == __file__
    with pytest.warns(RuntimeWarning, match="under two characteristic lengths"):
        options(_rock(4e6, 20e9, 3.0, 35.0, lch=0.03))                           # D < 2 l_ch
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        options(_rock(4e6, 20e9, 3.0, 35.0))                                     # l_ch = D / 5.3

"""Rock-mechanics verification (docs/theory/loads.md §12.6) through the public loads API, and quasi-static
settling (issue 12).  Tolerances are stated per test; the measured errors are printed (-s)."""
import math

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem.verification import rock


def _show(name, r, keys):
    print(f"{name}: " + ", ".join(f"{k} = {r[k]:.4g}" for k in keys) + f"; {r['steps']} steps, {r['wall']:.1f} s")


def test_plate_with_hole_mesh_is_graded_symmetric_and_exact():
    m = fdem.mesh.plate_with_hole(0.4, 0.2, 0.01, 0.001)
    assert m.bounding_box() == pytest.approx((-0.2, -0.1, 0.2, 0.1))
    assert m.area < 0.08 and m.area > 0.08 - math.pi * 1e-4 * 1.001
    assert math.degrees(m.min_angle()) > 25
    # rays on both axes and through the corners: the quarter cut along the axes is exact
    x, y = m.points.T
    assert np.any((np.abs(x) < 1e-12) & (np.abs(y - 0.01) < 1e-12))
    assert np.any((np.abs(x - 0.2) < 1e-12) & (np.abs(y - 0.1) < 1e-12))
    with pytest.raises(ValueError, match="does not fit"):
        fdem.mesh.plate_with_hole(0.02, 0.02, 0.01, 0.001)


def test_kirsch_hoop_stress_at_the_hole_within_5_percent():
    """Tolerance 5 % on 3σ (θ = 90°) and −σ (θ = 0); measured 0.9 % and 3.0 % at resolution 24
    (0.07 % and 0.7 % at the default 32, a slow test)."""
    r = rock.case_kirsch(resolution=24)
    _show("kirsch", r, ["hoop_top", "hoop_side", "error_top", "error_side", "field_rms"])
    assert r["error_top"] < 0.05 and r["error_side"] < 0.05
    assert r["field_rms"] < 0.02                      # the field off the wall (r > 2a), RMS / σ


def test_lame_cylinder_displacement_and_hoop_stress_within_2_percent():
    """Tolerance 2 % on u_r(a), u_r(b) and the ring-mean hoop stress; measured ~0.8 % (8 elements)."""
    r = rock.case_lame()
    _show("lame", r, ["u_inner", "u_inner_analytic", "error_u_inner", "error_u_outer", "hoop_ring_error"])
    assert r["error"] < 0.02


def test_uniaxial_compression_modulus_within_2_percent():
    """Tolerance 2 % on E/(1 − ν²) (plane strain); measured ~0.1 %.  Poisson's ratio 3 %."""
    r = rock.case_uniaxial()
    _show("uniaxial", r, ["modulus", "modulus_analytic", "error", "poisson_apparent", "error_poisson"])
    assert r["error"] < 0.02
    assert r["error_poisson"] < 0.03


@pytest.mark.slow
def test_kirsch_default_mesh_within_2_percent():
    r = rock.case_kirsch()
    assert r["error"] < 0.02


@pytest.mark.slow
def test_uniaxial_compression_modulus_plane_stress():
    r = rock.case_uniaxial(plane="stress")
    assert r["error"] < 0.02


@pytest.mark.slow
def test_triaxial_peaks_follow_mohr_coulomb_of_the_joints_within_10_percent():
    """Jointed specimen at σ3 = 0 and 0.1 MPa: peaks within 10 % of σ1 = σ3 N_φ + 2c√N_φ of the
    joints (c = 0.1 MPa, φ = 30°); see :func:`taichi_fdem.verification.rock.case_triaxial`."""
    r = rock.case_triaxial()
    print(f"triaxial: peaks {r['peaks']}, Mohr-Coulomb {r['peaks_mc']}, errors {r['errors']}, "
          f"fitted c = {r.get('fitted_cohesion', float('nan')):.4g} Pa, φ = {r.get('fitted_phi', float('nan')):.3g}°; "
          f"{r['steps']} steps, {r['wall']:.0f} s")
    assert r["error"] < 0.10
    assert r["peaks"][1] > r["peaks"][0]


def test_mohr_coulomb_formula():
    assert rock.mohr_coulomb_peak(0.0, 1.0, 30.0) == pytest.approx(2 * math.sqrt(3.0))
    assert rock.mohr_coulomb_peak(1.0, 0.0, 30.0) == pytest.approx(3.0)


def test_jointed_specimen_lattice_has_straight_60_degree_lines():
    m = rock.jointed_specimen_mesh(0.05, 0.1, 0.05 / 6)
    assert m.area == pytest.approx(0.005, rel=1e-12)
    e = m.edges()
    d = m.points[e[:, 1]] - m.points[e[:, 0]]
    ang = np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 180
    interior = ~np.isin(e, np.flatnonzero(np.abs(np.abs(m.points[:, 0]) - 0.025) < 1e-12)).any(axis=1)
    angles = np.round(ang[interior]).astype(int)
    assert set(np.unique(angles)) <= {0, 59, 60, 61, 119, 120, 121}

# the quasi-static scenarios (slope at μ = 1.2 tan θ, stack of blocks, cantilever) are in test_loads.py


def test_guide_loads_example_runs_as_written(tmp_path, monkeypatch, capsys):
    """The loads example of docs/guide/loads.md runs as written (fdem.init skipped: the test run has started Taichi)
    and prints a bore displacement within 2 % of Lamé's 93.75 µm."""
    import os
    import re
    readme = open(os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "docs", "guide", "loads.md")).read()
    sec = readme[readme.index("# Loads, boundaries and quasi-static runs"):]
    code = re.search(r"```python\n(.*?)```", sec, re.S).group(1).replace("fdem.init()\n", "")
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "docs/guide/loads.md", "exec"), {})
    out = capsys.readouterr().out
    u = float(re.search(r"u_r = ([0-9.]+) µm", out).group(1))
    assert u == pytest.approx(93.75, rel=0.02)
    assert (tmp_path / "out" / "lame.csv").is_file()


def test_unconfined_triaxial_peak_rises_with_a_later_handover():
    """The physics that ``Scene.build(handover_damage=...)`` changes (README, joined pairs): a
    damaged joint that still carries its pair keeps the pair's friction share μ|σ| in its shear
    strength, so the unconfined peak of the jointed specimen rises with the handover damage:
    1.04-1.05 × Mohr–Coulomb of the joints at 0 (the default, within the 10 % of the slow test),
    1.09-1.18 at 0.05.  The specimen's first failure is a symmetry break, so the figures move
    with round-off (measured, D_h = 0 / 0.01 / 0.05: 1.04 / 1.07 / 1.18 on an Intel host,
    1.053 / 1.040 / 1.085 on an AMD EPYC host, 1.050 / 1.086 / 1.177 there with Taichi's fast
    math off); at 0.01 the rise is within that spread, so only its bounds are held."""
    ratio = {}
    for dh in (0.0, 0.01, 0.05):
        r = rock.case_triaxial(confinements=(0.0,), handover_damage=dh)
        ratio[dh] = r["peaks"][0] / r["peaks_mc"][0]
    print(f"\nunconfined peak / Mohr-Coulomb by handover damage: {ratio}")
    assert abs(ratio[0.0] - 1.045) < 0.03
    assert 1.0 < ratio[0.01] < 1.12
    assert 1.06 < ratio[0.05] < 1.22
    assert ratio[0.05] > ratio[0.0] + 0.02

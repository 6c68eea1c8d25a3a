"""Verification suite (docs/verification.md §8): each case of taichi_fdem.verification at one affordable
setting, against its analytic reference with a stated tolerance.  The sweeps over mesh size,
time step, penalty and precision are in benchmarks/accuracy.py (docs/accuracy/)."""
import math

import pytest

from taichi_fdem import verification as V


@pytest.mark.parametrize("plane", ["strain", "stress"])
def test_p_wave_arrival(plane):
    """§8.3: a velocity step travels at c_p of the plane problem (rollers on the long edges);
    100 elements along the strip: within 2 %."""
    r = V.case_wave(resolution=100, plane=plane)
    assert r["error"] < 0.02, r


def test_bar_wave_arrival_with_free_edges():
    """§8.3, free lateral edges, plane stress: the bar speed √(E/ρ), within 3 %."""
    r = V.case_wave(resolution=100, plane="stress", lateral="free")
    assert r["error"] < 0.03, r


def test_two_bar_impact():
    """§8.4: contact duration 2ℓ/c and stress ρcv within 1 % (40 elements per bar), momentum
    exact, energy after separation within 0.5 %, velocities exchanged (e > 0.95)."""
    r = V.case_two_bars(resolution=40)
    assert r["separated"]
    assert r["duration_error"] < 0.01 and r["stress_error"] < 0.01, r
    assert r["energy_error"] < 0.005, r
    assert r["momentum_error"] < 1e-12, r
    assert 0.95 < r["restitution"] <= 1.0 + 1e-9, r


def test_hertz_cylinder_on_flat():
    """§8.5: half-width a and peak pressure p0 within 5 % with 10 elements across 2a, p = 100 E."""
    r = V.case_hertz(resolution=10, penalty_factor=100.0)
    assert r["elements_across"] >= 9.5
    assert r["a_error"] < 0.05 and r["p0_error"] < 0.05, r


def test_cantilever_tip_deflection():
    """§8.6: tip deflection within 3 % of Timoshenko's with 8 (crossed) elements through the depth."""
    r = V.case_cantilever(resolution=8, plane="stress")
    assert r["error"] < 0.03, r


def test_large_rigid_rotation_leaves_no_stress():
    """§8.6 objectivity: rigid rotations up to 180° give zero stress and force (round-off); a
    free spin only carries the centrifugal stress (≤ ρω²ℓ²/8, twice that while it rings up)."""
    r = V.case_rotation(resolution=4)
    assert r["error"] < 1e-12 and r["force_ratio"] < 1e-10, r
    assert r["spin_stress_ratio"] < 0.3, r


@pytest.mark.parametrize("theta_deg", [30.0, 10.0])
def test_block_on_incline(theta_deg):
    """§8.2, μ = 0.3: at 30° (tan θ > μ) the centroid slides x(t) = ½ g (sin θ − μ cos θ) t²
    (written out here) within 2 %; at 10° it sticks: creep below 0.1 % of a free slide ½ g sin θ t²."""
    r = V.case_incline(theta_deg=theta_deg)
    t = r["steps"] * r["dt"]
    th = math.radians(theta_deg)
    if theta_deg == 30.0:
        x_ref = 0.5 * 9.81 * (math.sin(th) - 0.3 * math.cos(th)) * t * t
        assert r["displacement"] == pytest.approx(x_ref, rel=0.02), r
    else:
        assert abs(r["displacement"]) < 1e-3 * 0.5 * 9.81 * math.sin(th) * t * t, r


def test_elastic_impact_of_two_disks():
    """§8.4: energy balance after separation within 1 %, momentum exact, restitution of the
    rigid motions between 0.9 and 1 (the rest is vibration)."""
    r = V.case_disks(resolution=3)
    assert r["error"] < 0.01, r
    assert r["momentum_error"] < 1e-12, r
    assert 0.9 < r["restitution"] <= 1.0, r


# the fracture cases (joint pull: verification.JointPair, direct tension) are tested in
# tests/test_fracture.py, the Brazilian disc in tests/test_demos.py (short) and test_fracture.py (full)


# ------------------------------------------------------------------------------------------------
# README figures (Accuracy and stability): the numbers the README quotes, at its precision
# ------------------------------------------------------------------------------------------------
def test_two_bar_penalty_and_safety_readme_figures():
    """README: in the two-bar impact (40 elements) the penalty 1·E gives 0.64 % (held to the
    README's last digit, ±0.005 percentage points); 10·E gives the smallest error of the three
    penalties and 100·E stays below 2 %; safety 0.4 is less accurate than the default 0.2.

    At 10·E and 100·E the interface nodes chatter and the measured error depends on round-off:
    10·E 0.48 / 0.34 / 0.063 %, 100·E 1.8 / 0.69 / 1.08 %, safety 0.4 2.3 / 2.38 / 0.86 % on an
    Intel host, on an AMD EPYC (Zen 1) host, and on that host with Taichi's fast math off (the
    README gives these ranges); 1·E is the same to 10 digits on all three."""
    errs = {p: V.case_two_bars(resolution=40, penalty_factor=p)["error"] for p in (1.0, 10.0, 100.0)}
    assert errs[1.0] == pytest.approx(0.0064, abs=5e-5), errs
    assert errs[10.0] < errs[1.0] and errs[10.0] < errs[100.0], errs
    assert errs[100.0] < 0.02, errs
    coarse = V.case_two_bars(resolution=40, safety=0.4)
    assert errs[10.0] < coarse["error"] < 0.03, (coarse, errs)


@pytest.mark.slow
def test_hertz_penalty_readme_figure():
    """README: for Hertz contact 10·E is as accurate as 100·E (2.3 % vs 2.4 %) at a third of the steps."""
    r10 = V.case_hertz(resolution=10, penalty_factor=10.0)
    r100 = V.case_hertz(resolution=10, penalty_factor=100.0)
    assert r10["error"] == pytest.approx(0.023, abs=5e-4) and r100["error"] == pytest.approx(0.024, abs=5e-4)
    assert r10["steps"] / r100["steps"] == pytest.approx(1.0 / math.sqrt(10.0), rel=0.05)   # ≈ a third


@pytest.mark.slow
def test_cantilever_converges_at_order_1_9_in_h():
    """README: the cantilever converges at 1.9 in h (theory 2 for CST displacements): the
    log-log slope of the error over 2, 4, 8, 16 elements through the depth, ±0.05."""
    import numpy as np
    res = [2, 4, 8, 16]
    errs = [V.case_cantilever(resolution=n)["error"] for n in res]
    slope = np.polyfit(np.log(1.0 / np.array(res, float)), np.log(errs), 1)[0]
    assert slope == pytest.approx(1.9, abs=0.05), (slope, errs)


F32_WAVE = """
import json, taichi_fdem as fdem
fdem.init(arch="cpu", precision="f32")
from taichi_fdem import verification as V
print(json.dumps({n: V.case_wave(resolution=n, precision="f32")["error"] for n in (100, 200, 400)}))
"""


@pytest.mark.slow
def test_f32_fails_small_strain_wave_at_200_elements():
    """README: f32 fails small-strain problems, wave error above 30 % at 200 elements and above
    100 % at 400 (the 10⁻⁴ strain increments reach the f32 round-off of the coordinates), while
    f64 holds 0.4 % at 200.  f32 needs its own process (fdem.init resets Taichi)."""
    import json
    import subprocess
    import sys
    p = subprocess.run([sys.executable, "-c", F32_WAVE], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr[-2000:]
    errs = {int(k): v for k, v in json.loads(p.stdout.strip().splitlines()[-1]).items()}
    assert errs[200] > 0.3 and errs[400] > 1.0, errs
    assert errs[100] < 0.03, errs                      # coarser meshes still work in f32
    assert V.case_wave(resolution=200)["error"] < 0.004

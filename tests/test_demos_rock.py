"""The rock-mechanics demos in short mode (demos/triaxial.py, demos/tunnel.py): they write their
video and CSV, and their returned numbers agree with references written out again here."""
import math
import os

import pytest

from conftest import load_demo as _load


def _run(name, tmp_path, *extra):
    out = tmp_path / f"{name}.mp4"
    r = _load(name).main(["--short", "--out", str(out), *extra])
    assert out.is_file() and out.stat().st_size > 0
    assert os.path.isfile(r["csv"]) and os.path.getsize(r["csv"]) > 0
    return r


def test_triaxial_short(tmp_path):
    """Peaks within 15 % of Mohr–Coulomb of the joints (c = 0.1 MPa, φ = 30°: σ1 = 3 σ3 + 2√3 c),
    the confined specimen stronger, the stress falling after the peak, and the pre-peak modulus
    between 0.8 and 1.0 × E/(1 − ν²) (intact joints add compliance, FDEM_SPEC §7.9)."""
    r = _run("triaxial", tmp_path)
    c = 1e5
    for s3, peak in zip(r["confinements"], r["peaks"]):
        assert peak == pytest.approx(3.0 * s3 + 2.0 * math.sqrt(3.0) * c, rel=0.15)
    assert r["peaks"][1] > r["peaks"][0] + 2.0 * 1e5           # N_φ = 3: +0.3 MPa for σ3 = 0.1 MPa
    assert all(f < 0.95 for f in r["final_over_peak"])
    E1 = r["young"] / (1 - r["poisson"] ** 2)
    assert all(0.8 * E1 < m < 1.0 * E1 for m in r["moduli"]), r["moduli"]
    assert all(b > 0 for b in r["broken"])


def test_tunnel_short(tmp_path):
    """No joint fails (damage > 0.5) while the in-situ stress is applied; after the excavation joints
    fail, most near the opening, and the sidewalls close by more than half the elastic Kirsch
    closure."""
    r = _run("tunnel", tmp_path)
    assert r["removed"] > 0
    assert r["damaged_before"] == 0 and r["damaged_after"] > 0
    assert r["fraction_near"] > 0.5
    assert r["closure"] > 0.5 * r["elastic_closure"] > 0

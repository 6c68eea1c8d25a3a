"""The rock-mechanics demos in short mode (demos/triaxial.py, demos/tunnel.py,
demos/slope.py, demos/dfn_compression.py): they write their
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
    between 0.8 and 1.0 × E/(1 − ν²) (intact joints add compliance, docs/theory/joints.md §7.9)."""
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


def test_slope_short(tmp_path):
    """A slope cut by two weak joint sets fails under gravity: the triangles that moved more than
    0.1 m all lie above the lowest J1 joint daylighting on the face (the only kinematically free
    mass), the rock below it stays within a few cm, the broken joints are on J1 and J2 (none of
    the strong joints of the intact rock), the streamed crack-event CSV lists every broken joint,
    and the energy balance closes to a small fraction of the gravity energy released."""
    from taichi_fdem.sim.cracks import read_crack_events
    r = _run("slope", tmp_path)
    assert r["moved_triangles"] >= 5
    assert r["moved_above_daylight"] > 0.95
    assert r["stable_displacement"] < 0.05 < 0.2 < r["max_displacement"]
    assert r["broken"] >= 5 and r["broken_on_sets"] > 0.8
    assert r["events_sets"]["J1"] > 0
    assert len(read_crack_events(r["cracks_csv"])["index"]) == r["broken"]
    assert r["released_gravity_J"] > 0 and r["energy_drift_over_released"] < 0.05


def test_dfn_compression_short(tmp_path):
    """A specimen cut by a seeded fracture network (8 fractures, crossings, tips inside) is weaker
    in uniaxial compression than the same mesh without the cracks, whose peak is near Mohr–Coulomb
    of the joints (2c cos φ/(1 − sin φ) = 0.346 MPa); the DFN specimen's stress rises
    monotonically to its peak and then drops; both curves are in the CSV."""
    import csv
    r = _run("dfn_compression", tmp_path)
    assert r["fractures"] == 8 and r["crossings"] >= 2
    assert r["peak_intact"] == pytest.approx(2 * math.sqrt(3.0) * 1e5, rel=0.15)
    assert r["peak_dfn"] < 0.9 * r["peak_intact"]
    assert r["prepeak_min_rise"] > 0
    assert r["final_over_peak_dfn"] < 0.8
    assert r["broken_dfn"] > 0
    with open(r["csv"]) as fh:
        rows = list(csv.DictReader(fh))
    assert {row["specimen"] for row in rows} == {"dfn", "intact"}
    peak = max(float(row["axial_stress_Pa"]) for row in rows if row["specimen"] == "dfn")
    assert peak == pytest.approx(r["peak_dfn"], rel=1e-5)

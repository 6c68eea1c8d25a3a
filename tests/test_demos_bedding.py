"""The bedded-rock demos in short mode (demos/brazilian_bedding.py, demos/tunnel_bedding.py): they
write their video and CSV, and their returned numbers agree with references written out again here
(the joints' strengths, the slip direction of a plane under the hoop stress, Kirsch's closure)."""
import csv
import math
import os

import numpy as np

from conftest import load_demo as _load

FT, FT_B = 6e6, 2e6          # demos/brazilian_bedding.py: f_t of the matrix's and the bedding's joints [Pa]


def _run(name, tmp_path):
    out = tmp_path / f"{name}.gif"
    r = _load(name).main(["--short", "--out", str(out)])
    assert out.is_file() and out.stat().st_size > 0
    import imageio.v3 as iio
    assert sum(1 for _ in iio.imiter(str(out))) >= 10
    assert os.path.isfile(r["csv"]) and os.path.getsize(r["csv"]) > 0
    return r


def _axial_mean(deg):
    z = np.exp(2j * np.radians(np.asarray(deg, dtype=float))).mean()
    return float(np.mod(np.degrees(np.angle(z)) / 2.0, 180.0))


def test_brazilian_bedding_short(tmp_path):
    """Across the bedding (β = 90°) the split crosses the layers at about the matrix's f_t (Hondros
    centre stress within 1.0–1.6 f_t: a disc of ~5 l_ch splits above f_t); along it (β = 0°) the disc
    splits on its central bedding plane (every broken joint vertical, at x = 0) above the bedding's f_t
    and below the matrix's; the strength rises from 30° to 60° to 90°; the CSV holds the table."""
    r = _run("brazilian_bedding", tmp_path)
    by = {row["beta"]: row for row in r["rows"]}
    assert sorted(by) == [0.0, 30.0, 60.0, 90.0]
    assert 1.0 < by[90.0]["centre_stress"] / FT < 1.6, by[90.0]
    assert FT_B < by[0.0]["centre_stress"] < 0.8 * FT, by[0.0]
    assert abs(by[0.0]["mean_direction"] - 90.0) < 1e-6 and by[0.0]["resultant"] > 0.999
    assert by[0.0]["on_bedding"] == 1.0
    assert by[30.0]["sigma_t"] < by[60.0]["sigma_t"] < by[90.0]["sigma_t"]
    with open(r["csv"]) as fh:
        rows = list(csv.DictReader(fh))
    assert [float(x["bedding_angle_deg"]) for x in rows] == [0.0, 30.0, 60.0, 90.0]
    for x in rows:
        assert float(x["sigma_t_Pa"]) == float(f"{by[float(x['bedding_angle_deg'])]['sigma_t']:.6g}")
        assert float(x["bedding_dip_deg"]) == 90.0 - float(x["bedding_angle_deg"])


def test_tunnel_bedding_short(tmp_path):
    """No joint fails before the excavation; the bedded mass fails more joints than the isotropic
    one and its sidewalls close more; the isotropic sidewalls close by 0.5–1.2 × Kirsch's elastic
    closure (written out here); the bedding-parallel failures in the CSV centre within 20° of the
    polar angle where the hoop stress loads the bedding most for slip (ψ = 45° − φ_b/2 from the
    tangent point, φ_b = 20°: −25°)."""
    r = _run("tunnel_bedding", tmp_path)
    assert r["damaged_before"] == 0
    assert r["failed"] > r["failed_isotropic"]
    assert r["closure"] > r["closure_isotropic"] > 0
    sv, sh, a, E, nu = 0.3e6, 0.15e6, 0.3, 100e6, 0.25
    G, K = E / (2 * (1 + nu)), sh / sv
    kirsch = 2 * sv * a / (4 * G) * ((1 + K) - (1 - K) * (3 - 4 * nu))
    assert 0.5 * kirsch < r["closure_isotropic"] < 1.2 * kirsch
    with open(r["csv"]) as fh:
        rows = [x for x in csv.DictReader(fh) if x["case"] == "bedded"]
    assert len(rows) == r["failed"]
    along = [float(x["polar_angle_deg"]) for x in rows if abs(float(x["direction_deg"]) - 30.0) < 10.0]
    assert len(along) >= 5
    pos = _axial_mean(along)
    pos = pos - 180.0 if pos > 90.0 else pos
    optimum = 30.0 + 90.0 - 180.0 + (45.0 - 20.0 / 2.0)
    assert abs(pos - optimum) < 20.0, (pos, optimum)
    assert not math.isnan(r["mean_direction"])

"""Acoustic emission: clustering of crack events, magnitudes, b-value."""
import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem.sim import ae


def _brute_force(t, x, y, wt, wd):
    """Connected components of the O(n²) proximity graph, by breadth-first search."""
    n = len(t)
    adj = (np.abs(t[:, None] - t[None]) <= wt) & ((x[:, None] - x[None]) ** 2 + (y[:, None] - y[None]) ** 2 <= wd * wd)
    comp = np.full(n, -1)
    c = 0
    for s in range(n):
        if comp[s] >= 0:
            continue
        stack = [s]
        comp[s] = c
        while stack:
            i = stack.pop()
            for j in np.nonzero(adj[i] & (comp < 0))[0]:
                comp[j] = c
                stack.append(j)
        c += 1
    return comp


def _same_partition(a, b):
    # a bijection between labels: every pair of events together in one is together in the other
    return np.array_equal(a[:, None] == a[None], b[:, None] == b[None])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_clustering_matches_brute_force(seed):
    rng = np.random.default_rng(seed)
    n = 400
    # bursts in space-time plus scattered background events
    centres = rng.random((25, 3))
    k = rng.integers(0, 25, n)
    t = centres[k, 0] + 0.01 * rng.standard_normal(n)
    x = centres[k, 1] + 0.02 * rng.standard_normal(n)
    y = centres[k, 2] + 0.02 * rng.standard_normal(n)
    t[:50], x[:50], y[:50] = rng.random(50), rng.random(50), rng.random(50)
    wt, wd = 0.01, 0.03
    got = ae.cluster_events(t, x, y, wt, wd)
    ref = _brute_force(t, x, y, wt, wd)
    assert _same_partition(got, ref)
    assert 1 < got.max() + 1 < n                    # a non-trivial clustering
    # ids in order of each AE event's first crack in time
    first = np.array([t[got == g].min() for g in range(got.max() + 1)])
    assert np.all(np.diff(first) >= 0)


def test_ae_event_properties():
    ev = {"time": np.array([0.0, 1e-6, 5.0, 5.0 + 1e-6]), "x": np.array([0.0, 1e-3, 0.0, 0.0]),
          "y": np.zeros(4), "energy": np.array([1.0, 3.0, 2.0, 0.0]),
          "mode": np.array(["I", "I", "II", "I+II"], dtype=object)}
    out = ae.ae_events(ev, window_time=1e-5, window_distance=2e-3)
    np.testing.assert_array_equal(out["cracks"], [2, 2])
    np.testing.assert_allclose(out["energy"], [4.0, 2.0])
    np.testing.assert_allclose(out["x"], [0.75e-3, 0.0])          # energy-weighted centroid
    np.testing.assert_allclose(out["moment"], out["energy"] / 5e-5)
    # Hanks & Kanamori with Kanamori's ratio = the Gutenberg-Richter energy relation
    np.testing.assert_allclose(out["magnitude"], (2 / 3) * (np.log10(out["energy"]) - 4.8), atol=0.01)
    assert list(out["mode"]) == ["tensile", "shear"]                # mean score 1.0 and 0.25


def test_b_value_recovers_gutenberg_richter():
    rng = np.random.default_rng(4)
    for b_true, dm in ((1.0, 0.0), (1.5, 0.0), (0.8, 0.1)):
        n = 20000
        # continuous magnitudes above 1.0; binned ones: continuous above 1.0 - dm/2, rounded to dm
        m = 1.0 - 0.5 * dm + rng.exponential(1.0 / (b_true * np.log(10)), n)
        mc = 1.0
        if dm:                                     # Utsu's correction for binned magnitudes
            m = np.round(m / dm) * dm
        b, sigma, used = ae.b_value(m, completeness=mc, bin_width=dm)
        assert used > 0.9 * n
        assert abs(b - b_true) < 4 * sigma, (b, b_true, sigma)
        assert sigma < 0.02 * b_true


def test_bad_input():
    with pytest.raises(ValueError, match="window_distance"):
        ae.cluster_events([0.0], [0.0], [0.0], 1.0, 0.0)
    with pytest.raises(ValueError, match="same length"):
        ae.cluster_events([0.0, 1.0], [0.0], [0.0], 1.0, 1.0)
    with pytest.raises(ValueError, match="at least 2"):
        ae.b_value([1.0])


def test_sim_ae_events_csv_and_vtu(tmp_path):
    import meshio
    mat = fdem.Material(density=100.0, young=1e6, poisson=0.25, tensile_strength=1e3, fracture_energy=1.0)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.1, 0.02, 0.01), mat, fracture=True, velocity=(0.0, 0.0))
    sim = scene.build()
    # pull the two halves apart: the joints across the middle break
    v = sim.state.node_v.to_numpy()
    x = sim.state.node_x.to_numpy()
    v[:, 0] = np.sign(x[:, 0]) * 2.0
    sim.state.node_v.from_numpy(v.astype(sim.state.node_v.to_numpy().dtype))
    sim.step(400)
    cr = sim.cracks.events()
    assert len(cr["time"]) > 0
    out = sim.cracks.ae_events()
    assert out["cracks"].sum() == len(cr["time"])
    np.testing.assert_allclose(out["energy"].sum(), cr["energy"].sum(), rtol=1e-12)
    p = sim.cracks.write_ae_events(tmp_path / "ae.csv")
    rows = open(p).read().splitlines()
    assert rows[0].split(",") == list(ae.AE_CSV_COLUMNS) and len(rows) == len(out["time"]) + 1
    q = fdem.export.write_ae_vtu(str(tmp_path / "ae.vtu"), out)
    m = meshio.read(q)
    assert len(m.points) == len(out["time"])
    np.testing.assert_allclose(m.point_data["energy"], out["energy"])

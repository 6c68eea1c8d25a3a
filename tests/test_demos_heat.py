"""The heat demos in short mode (demos/thermal_cracking.py, demos/heated_borehole.py): they write
their video and CSV, and their returned numbers agree with references written out again here
(the onset estimates from the demos' constants, the heat stored from the mesh, the radial
conduction by an independent 1D finite-difference solution)."""
import csv
import math
import os

import numpy as np
import pytest

from conftest import load_demo as _load


def _run(name, tmp_path):
    out = tmp_path / f"{name}.mp4"
    r = _load(name).main(["--short", "--out", str(out)])
    assert out.is_file() and out.stat().st_size > 0
    assert os.path.isfile(r["csv"]) and os.path.getsize(r["csv"]) > 0
    return r


def _rows(path):
    with open(path) as fh:
        return list(csv.DictReader(fh))


def test_thermal_cracking_short(tmp_path):
    """Grain-based granite heated uniformly from 20 to 320 °C: the first crack appears within a
    factor 2 of the mismatch estimates written out here (quartz 2.4e-5 against plagioclase
    0.7e-5 1/K, f_t = 6.46 MPa: E Δα ΔT = f_t with E = 70.05 GPa, and the plane-strain inclusion
    f_t (1/E_p + (1 − 2ν)/E_q)/Δα), the first ten on grain boundaries although those are under a
    third of the joints, the counts of the CSV non-decreasing and consistent, and the heat stored
    equal to ΔT × Σ ρ c A over the minerals of the mesh."""
    mod = _load("thermal_cracking")
    r = _run("thermal_cracking", tmp_path)
    ft, E, nu, dalpha = 6.46e6, 70.05e9, 0.236, 2.4e-5 - 0.7e-5
    simple = ft / (E * dalpha)                                          # 5.42 K
    inclusion = ft * (1.0 / E + (1.0 - 2.0 * nu) / (1.3 * E)) / dalpha  # 7.63 K
    assert r["onset_reference_dT"] == pytest.approx(inclusion, rel=1e-12)
    for ref in (simple, inclusion):
        assert 0.5 * ref <= r["first_crack_dT"] <= 2.0 * ref, (r["first_crack_dT"], ref)
    assert r["grain_boundary_joints"] < r["joints"] / 3
    assert r["first_on_grain_boundaries"] >= 0.8
    rows = _rows(r["csv"])
    a = np.array([[float(v) for v in row.values()] for row in rows])
    T, cracked, gb, intra, half, broken = a.T
    assert np.all(np.diff(T) > 0) and T[-1] == pytest.approx(320.0, abs=1e-6)
    assert np.all(np.diff(a[:, 1:], axis=0) >= 0)
    np.testing.assert_array_equal(cracked, gb + intra)
    assert np.all(broken <= half) and np.all(half <= cracked)
    assert cracked[T - 20.0 < 0.5 * inclusion].max() == 0
    assert cracked[-1] > 0.3 * r["joints"]
    # heat stored = ΔT Σ ρ c A (every node held at the final temperature; thickness 1 m)
    from taichi_fdem import mesh
    s = mod.SIZE[True]
    m, lab = mesh.voronoi_grains(s["width"], s["width"], s["grain"], s["h"], seed=mod.SEED, minerals=mod.MINERALS)
    c = {"quartz": 740.0, "plagioclase": 710.0, "k_feldspar": 700.0, "biotite": 770.0}
    rho_c_A = sum(2650.0 * c[k] * a_ for k, a_ in zip(lab.mineral, np.asarray(m.areas, float)))
    e = r["energies"]
    assert e["heat_stored"] == pytest.approx(300.0 * rho_c_A, rel=1e-9)
    assert e["heat_supplied"] == pytest.approx(e["heat_stored"], rel=1e-9)


def _radial_fd(r_out, t_out, a, kappa, wall, r_max, n=2000, steps=4000):
    """T − T₀ at radii ``r_out`` and time ``t_out`` of ∂T/∂t = κ (T'' + T'/r) on a < r < r_max,
    T(a, t) = wall(t), T(r_max) = 0, T = 0 at t = 0: Crank–Nicolson on a uniform grid (a
    brute-force reference independent of the demo's quadrature)."""
    from scipy.linalg import solve_banded
    r = np.linspace(a, r_max, n + 1)
    dr = r[1] - r[0]
    dt = t_out / steps
    ri = r[1:-1]
    lo = kappa * (1.0 / dr**2 - 1.0 / (2.0 * ri * dr))
    di = -2.0 * kappa / dr**2 * np.ones_like(ri)
    up = kappa * (1.0 / dr**2 + 1.0 / (2.0 * ri * dr))
    ab = np.zeros((3, n - 1))
    ab[0, 1:] = -0.5 * dt * up[:-1]
    ab[1] = 1.0 - 0.5 * dt * di
    ab[2, :-1] = -0.5 * dt * lo[1:]
    u = np.zeros(n + 1)
    for k in range(steps):
        u[0] = wall(k * dt)
        rhs = u[1:-1] + 0.5 * dt * (lo * u[:-2] + di * u[1:-1] + up * u[2:])
        u[0] = wall((k + 1) * dt)
        rhs[0] += 0.5 * dt * lo[0] * u[0]
        u[1:-1] = solve_banded((1, 1), ab, rhs)
    return np.interp(r_out, r, u)


def test_heated_borehole_short(tmp_path):
    """A well wall cooled from 200 to 60 °C (6 K first, elastic): the temperatures near the wall
    at the end agree with a 1D radial Crank–Nicolson solution written here within 6 % of the
    cooling (and the demo's Carslaw & Jaeger quadrature with it within 0.2 %); no joint damaged in
    the elastic stage, whose wall hoop stress E α ΔT/(1 − ν) stays under f_t; radial cracks at the
    wall, none beyond 3 √(κt), nine in ten or more where the rock cooled by over ΔT_c/2; the heat
    account of the history closes."""
    mod = _load("heated_borehole")
    r = _run("heated_borehole", tmp_path)
    E, nu, alpha, ft = 60e9, 0.25, 8e-6, 8e6
    assert r["crack_onset_dT"] == pytest.approx(ft * (1 - nu) / (E * alpha), rel=1e-12)   # 12.5 K
    assert E * alpha * mod.FIRST_COOLING / (1 - nu) < ft and r["damage_elastic"] == 0.0
    kappa = 3.0 * mod.TIME_SCALE / (2650.0 * 800.0)
    assert r["kappa"] == pytest.approx(kappa, rel=1e-12)
    t1, t = r["t1"], r["t_end"]
    prof = np.array([[float(v) for v in row.values()] for row in _rows(r["profile_csv"])])
    rad, T_sim, T_ref = prof.T
    cool = 200.0 - 60.0
    wall = lambda s: -mod.FIRST_COOLING if s <= t1 else -cool              # noqa: E731
    fd = 200.0 + _radial_fd(rad, t, mod.A, kappa, wall, mod.A + 12 * math.sqrt(kappa * t))
    assert np.max(np.abs(T_ref - fd)) < 0.002 * cool
    assert np.max(np.abs(T_sim - fd)) < 0.06 * cool
    assert r["wall_failed"] > 0 and r["broken"] > 0
    assert 0 < r["crack_depth"] < 3.0 * math.sqrt(kappa * t)
    assert r["failed_in_cooled_zone"] >= 0.9
    h = _rows(r["csv"])[-1]
    assert float(h["E_heat_supplied"]) == pytest.approx(float(h["E_heat_stored"]), rel=1e-6)
    assert float(h["E_heat_stored"]) < 0 and float(h["temperature_min"]) == pytest.approx(60.0, abs=1e-9)

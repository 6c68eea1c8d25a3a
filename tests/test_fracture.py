"""Cohesive joints and fracture (FDEM_SPEC §7, §8.3, §8.7, §8.8): analytic checks with tolerances.

Single joint (two triangles forming a unit square, one joint on the diagonal): every node has a
prescribed velocity, so the joint kinematics are exact and the measured tractions are compared
with the laws of §7.5–7.7 directly.  The other tests are dynamic (strip, Brazilian disc, wave
speed, impact) and loaded quasi-statically where a static reference is used.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem.mesh import TriMesh
from taichi_fdem.scene import explode_for_fracture

Z_INTEGRAL = 0.3863      # ∫₀¹ z(D) dD (§7.5)


# ------------------------------------------------------------------------------------------------
# single joint (§8.7)
# ------------------------------------------------------------------------------------------------
def _square():
    return TriMesh(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]), np.array([[0, 1, 2], [0, 2, 3]]))


class Pair:
    """Two triangles of a unit square with one joint; A's and B's nodes both prescribed (initially at rest)."""

    def __init__(self, **matkw):
        mesh = _square()
        ex, jn, jt = explode_for_fracture(mesh)
        assert len(jn) == 1
        a, b = int(jt[0, 0]), int(jt[0, 1])
        self.A, self.B = np.arange(3 * a, 3 * a + 3), np.arange(3 * b, 3 * b + 3)
        x0, x1, x2, x3 = ex.points[jn[0]]
        e = 0.5 * (x1 + x2 - x0 - x3)
        self.L = float(np.linalg.norm(e))
        self.e = e / self.L
        self.n = np.array([-self.e[1], self.e[0]])        # points into A (§7.2)
        kw = dict(density=1000.0, young=1e8, poisson=0.25, tensile_strength=1e6, fracture_energy=1e4)
        kw.update(matkw)
        self.mat = fdem.Material(**kw)
        self.ft, self.c, self.tanphi, self.gI, self.gII, self.pf = self.mat.joint_properties()
        scene = fdem.Scene(gravity=(0.0, 0.0))
        body = scene.add_body(mesh, self.mat, fracture=True)
        scene.fix_nodes(lambda x, y: np.isin(np.arange(len(x)), self.A), body=body, velocity=(0.0, 0.0))
        scene.fix_nodes(lambda x, y: np.isin(np.arange(len(x)), self.B), body=body, velocity=(0.0, 0.0))
        self.dt = 1e-4
        self.sim = scene.build(dt=self.dt)
        self.jn = self.sim.joint_nodes.to_numpy()[0]
        assert set(self.jn[:2]) <= set(self.A) and set(self.jn[2:]) <= set(self.B)
        self.vbc = self.sim.node_vbc.to_numpy()

    def move_A(self, velocity):
        self.vbc[self.A] = velocity
        self.sim.node_vbc.from_numpy(self.vbc)

    def gap(self):
        """Mean (opening, sliding) of the joint from the node positions (§7.2)."""
        x = self.sim.node_positions()
        d = 0.5 * ((x[self.jn[0]] - x[self.jn[3]]) + (x[self.jn[1]] - x[self.jn[2]]))
        return float(d @ self.n), float(d @ self.e)

    def traction(self):
        """(σ, τ) per unit length from the joint's nodal forces on A (contact subtracted)."""
        f = self.sim.forces() - self.sim.forces(contact_only=True)
        fa = f[self.A].sum(axis=0)
        return float(-(fa @ self.n) / self.L), float(-(fa @ self.e) / self.L)

    def drive(self, direction, comp, peak, span, fine=100, coarse=10):
        """Move A along ``direction`` at δ_peak/fine per step until the joint breaks.

        ``comp`` 0 measures opening and σ, 1 sliding and τ.

        Forces are sampled every step up to 1.3 δ_peak and every ``coarse`` steps after.
        Returns (displacement samples, traction samples, displacement at breakage).
        """
        inc = peak / fine
        self.move_A(direction * inc / self.dt)
        u0 = self.gap()[comp]
        t0 = self.sim.time
        us, ts = [0.0], [self.traction()[comp]]
        total = int(1.5 * (peak + span) / inc)
        done = 0
        while done < total and not self.sim.broken_joint_count:
            k = 1 if us[-1] < 1.3 * peak else coarse
            self.sim.step(k)
            done += k
            us.append(self.gap()[comp] - u0)
            ts.append(self.traction()[comp])
        assert self.sim.broken_joint_count == 1, "the joint did not break"
        t_break = float(self.sim.broken_joints()["time"][0])
        # the joint breaks inside a step: its recorded time is the start of that step (positions at
        # the start of the step are those evaluated)
        u_break = (t_break - t0) * inc / self.dt
        return np.array(us[:-1]), np.array(ts[:-1]), u_break


def _trapezoid(y, x):
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(x)))


def test_single_joint_pull_mode_I():
    p = Pair()
    dp = 2.0 * p.L * p.ft / p.pf          # §7.4
    dn = 3.0 * p.gI / p.ft                # Y-Geo softening span
    o, sig, o_break = p.drive(p.n, 0, dp, dn)
    i = int(np.argmax(sig))
    assert sig[i] == pytest.approx(p.ft, rel=0.01)
    assert o[i] == pytest.approx(dp, rel=0.02)
    # pre-peak branch of §7.6: σ = f_t (2r − r²), r = o/δ_p
    r = o[o <= dp] / dp
    assert np.allclose(sig[o <= dp], p.ft * (2 * r - r * r), rtol=1e-6, atol=1e-6 * p.ft)
    work = _trapezoid(sig, o)              # per unit length of joint
    w_ref = p.ft * (2 * dp / 3 + Z_INTEGRAL * dn)
    print(f"\npull: peak σ/f_t = {sig[i] / p.ft:.5f} at o/δ_p = {o[i] / dp:.4f}; breakage o/(δ_p+Δ_n) = "
          f"{o_break / (dp + dn):.5f}; work/ref = {work / w_ref:.5f}, energies/ref = "
          f"{p.sim.energies()['fracture'] / p.L / w_ref:.5f}")
    assert o_break == pytest.approx(dp + dn, rel=0.02)
    assert work == pytest.approx(w_ref, rel=0.02)
    e = p.sim.energies()
    assert e["fracture"] / p.L == pytest.approx(w_ref, rel=0.02)
    assert e["joints"] == 0.0
    bj = p.sim.broken_joints()
    assert list(bj["mode"]) == ["I"]
    assert np.allclose(bj["position"][0], [0.5, 0.5], atol=0.05)
    assert p.sim.joint_damage()[0] == 1.0
    assert np.all(p.sim.tri_damage() == 1.0)
    assert p.sim.fragment_count() == 2


def test_single_joint_shear_mode_II():
    p = Pair(fracture_energy_shear=1e4)
    sp = 2.0 * p.L * p.c / p.pf
    ds = 3.0 * p.gII / p.c
    s, tau, s_break = p.drive(p.e, 1, sp, ds)
    i = int(np.argmax(tau))
    assert tau[i] == pytest.approx(p.c, rel=0.01)
    assert s[i] == pytest.approx(sp, rel=0.02)
    w_ref = p.c * (2 * sp / 3 + Z_INTEGRAL * ds)
    print(f"\nshear: peak τ/c = {tau[i] / p.c:.5f} at s/s_p = {s[i] / sp:.4f}; breakage s/(s_p+Δ_s) = "
          f"{s_break / (sp + ds):.5f}; work/ref = {_trapezoid(tau, s) / w_ref:.5f}, energies/ref = "
          f"{p.sim.energies()['fracture'] / p.L / w_ref:.5f}")
    assert s_break == pytest.approx(sp + ds, rel=0.02)
    assert _trapezoid(tau, s) == pytest.approx(w_ref, rel=0.02)
    assert p.sim.energies()["fracture"] / p.L == pytest.approx(w_ref, rel=0.02)
    assert list(p.sim.broken_joints()["mode"]) == ["II"]


def test_single_joint_shear_mohr_coulomb_confinement():
    p = Pair(fracture_energy_shear=1e4, cohesion=0.6e6, friction_angle=35.0)
    # press A into B by a prescribed overlap: σ_n = p_f o / L < 0 (§7.6), in 100 steps
    overlap = 1e-3
    p.move_A(-p.n * overlap / (100 * p.dt))
    p.sim.step(100)
    p.move_A(np.zeros(2))
    o, _ = p.gap()
    assert o == pytest.approx(-overlap, rel=1e-9)
    sigma_n = p.pf * o / p.L
    sig_meas, _ = p.traction()
    assert sig_meas == pytest.approx(sigma_n, rel=1e-6)
    fs = p.c - sigma_n * p.tanphi                         # Mohr–Coulomb (§7.7)
    assert fs > 1.5 * p.c
    sp = 2.0 * p.L * fs / p.pf
    ds = 3.0 * p.gII / fs
    s, tau, s_break = p.drive(p.e, 1, sp, ds)
    i = int(np.argmax(tau))
    print(f"\nconfined shear: σ_n = {sigma_n:.4g} Pa, peak τ/(c − σ_n tan φ) = {tau[i] / fs:.5f} at s/s_p = "
          f"{s[i] / sp:.4f}; breakage s/(s_p+Δ_s) = {s_break / (sp + ds):.5f}")
    assert tau[i] == pytest.approx(fs, rel=0.03)
    assert s[i] == pytest.approx(sp, rel=0.02)
    assert s_break == pytest.approx(sp + ds, rel=0.02)
    assert list(p.sim.broken_joints()["mode"]) == ["II"]


# ------------------------------------------------------------------------------------------------
# direct tension of a jointed strip
# ------------------------------------------------------------------------------------------------
def test_direct_tension_strip_peak_stress():
    W, H, h = 1.0, 0.2, 0.1
    E, rho, ft = 1e8, 1000.0, 1e5
    mat = fdem.Material(density=rho, young=E, poisson=0.2, damping=0.7, tensile_strength=ft, fracture_energy=20.0)
    _, _, _, gI, _, pf = mat.joint_properties()
    assert 2 * h * ft / pf < 0.05 * 3 * gI / ft          # δ_p ≪ Δ_n
    scene = fdem.Scene(gravity=(0.0, 0.0), plane="stress")
    body = scene.add_body(fdem.mesh.rectangle(W, H, h, origin=(0.0, 0.0)), mat, fracture=True)
    c = mat.p_wave_speed("stress")
    # elongation at peak ≈ W f_t/E + (joints) ; reached after ~150 W/c: quasi-static
    u_peak = 1.2 * W * ft / E
    v = u_peak / (150.0 * W / c)
    tol = 1e-9
    scene.fix_nodes(lambda x, y: x < tol, body=body, velocity=(0.0, None))                 # roller
    scene.fix_nodes(lambda x, y: (x < tol) & (y < tol), body=body, velocity=(0.0, 0.0))    # pin
    scene.fix_nodes(lambda x, y: x > W - tol, body=body, velocity=(v, None))
    sim = scene.build()
    X = sim.node_positions()
    right = X[:, 0] > W - tol
    n_total = int(2.5 * u_peak / v / sim.dt)
    k = max(1, n_total // 400)
    stress = []
    while sim.step_count < n_total:
        sim.step(k)
        stress.append(-sim.forces()[right, 0].sum() / H)
        if sim.broken_joint_count and stress[-1] < 0.3 * max(stress):
            break
    stress = np.array(stress)
    peak = float(stress.max())
    print(f"\nstrip: peak stress / f_t = {peak / ft:.5f}; {sim.broken_joint_count} joints broken; "
          f"{sim.step_count} steps")
    assert peak == pytest.approx(ft, rel=0.02)
    assert sim.broken_joint_count >= 2
    assert sim.fragment_count() >= 2


# ------------------------------------------------------------------------------------------------
# elastic wave speed with intact joints everywhere (§8.3)
# ------------------------------------------------------------------------------------------------
def _arrival_time(fracture: bool, pf_factor: float = 10.0):
    ell, H, h = 2.0, 0.1, 0.025
    E, rho, v0 = 1e8, 1000.0, 0.01
    mat = fdem.Material(density=rho, young=E, poisson=0.0, tensile_strength=1e9, fracture_energy=1e9,
                        joint_penalty=pf_factor * E)
    scene = fdem.Scene(gravity=(0.0, 0.0), plane="stress")
    body = scene.add_body(fdem.mesh.rectangle(ell, H, h, origin=(0.0, 0.0)), mat, fracture=fracture)
    scene.fix_nodes(lambda x, y: x < 1e-9, body=body, velocity=(v0, None))   # velocity step at x = 0
    sim = scene.build(dt=2e-6)
    X = sim.node_positions()
    probe = np.abs(X[:, 0] - 0.75 * ell) < 1e-9
    assert probe.sum() >= 4
    t_prev, v_prev = 0.0, 0.0
    while sim.time < 2.0 * 0.75 * ell / math.sqrt(E / rho):
        sim.step(5)
        vp = float(sim.node_velocities()[probe, 0].mean())
        if vp >= 0.5 * v0:                                   # half-amplitude crossing, interpolated
            return t_prev + (sim.time - t_prev) * (0.5 * v0 - v_prev) / (vp - v_prev), 0.75 * ell
        t_prev, v_prev = sim.time, vp
    raise AssertionError("the pulse did not arrive")


def test_wave_speed_jointed_strip():
    t_plain, x = _arrival_time(False)
    t_joint, _ = _arrival_time(True)
    c0 = math.sqrt(1e8 / 1000.0)
    ratio = t_plain / t_joint                  # c_jointed / c_plain
    lo, hi = 1.0 / math.sqrt(1.0 + 3.0 / 10.0), 1.0 / math.sqrt(1.0 + 0.3 / 10.0)   # κ ∈ [0.3, 3], p_f = 10 E
    kappa = (1.0 / ratio ** 2 - 1.0) * 10.0
    print(f"\nwave: unjointed c/c0 = {x / t_plain / c0:.4f}; jointed/unjointed speed = {ratio:.4f} "
          f"(κ = {kappa:.2f}; bounds {lo:.4f}..{hi:.4f})")
    assert x / t_plain == pytest.approx(c0, rel=0.03)
    assert lo <= ratio <= hi
    assert ratio >= 0.9

"""Cohesive joints and fracture (docs/theory/joints.md §7, §8.3, §8.7, §8.8): analytic checks with tolerances.

Single joint (two triangles forming a unit square, one joint on the diagonal): every node has a
prescribed velocity, so the joint kinematics are exact and the measured tractions are compared
with the laws of §7.5–7.7 directly.  The other tests are dynamic (strip, Brazilian disc, wave
speed, impact) and loaded quasi-statically where a static reference is used.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem import verification as V
from taichi_fdem.mesh import TriMesh

Z_INTEGRAL = 0.3863      # ∫₀¹ z(D) dD (§7.5)


# ------------------------------------------------------------------------------------------------
# single joint (§8.7)
# ------------------------------------------------------------------------------------------------
def _square():
    return TriMesh(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]), np.array([[0, 1, 2], [0, 2, 3]]))


Pair = V.JointPair          # the single-joint scenario, shared with verification.case_joint_pull


def _trapezoid(y, x):
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(x)))


def test_single_joint_pull_mode_I():
    """README: f_t at δ_p, breakage at δ_p + Δ_n and the work f_t(2δ_p/3 + 0.3863 Δ_n) to < 0.1 %."""
    p = Pair()
    assert set(p.jn[:2]) <= set(p.A) and set(p.jn[2:]) <= set(p.B)
    dp = 2.0 * p.L * p.ft / p.pf          # §7.4
    dn = 3.0 * p.gI / p.ft                # Y-Geo softening span
    o, sig, o_break = p.drive(p.n, 0, dp, dn)
    i = int(np.argmax(sig))
    assert sig[i] == pytest.approx(p.ft, rel=1e-3)
    assert o[i] == pytest.approx(dp, rel=1e-3)
    # pre-peak branch of §7.6: σ = f_t (2r − r²), r = o/δ_p
    r = o[o <= dp] / dp
    assert np.allclose(sig[o <= dp], p.ft * (2 * r - r * r), rtol=1e-6, atol=1e-6 * p.ft)
    work = _trapezoid(sig, o)              # per unit length of joint
    w_ref = p.ft * (2 * dp / 3 + Z_INTEGRAL * dn)
    print(f"\npull: peak σ/f_t = {sig[i] / p.ft:.5f} at o/δ_p = {o[i] / dp:.4f}; breakage o/(δ_p+Δ_n) = "
          f"{o_break / (dp + dn):.5f}; work/ref = {work / w_ref:.5f}, energies/ref = "
          f"{p.sim.energies()['fracture'] / p.L / w_ref:.5f}")
    assert o_break == pytest.approx(dp + dn, rel=1e-3)
    assert work == pytest.approx(w_ref, rel=1e-3)
    e = p.sim.energies()
    assert e["fracture"] / p.L == pytest.approx(w_ref, rel=1e-3)
    assert e["joints"] == 0.0
    bj = p.sim.cracks.broken()
    assert list(bj["mode"]) == ["I"]
    assert np.allclose(bj["position"][0], [0.5, 0.5], atol=0.05)
    assert p.sim.cracks.joint_damage()[0] == 1.0
    assert np.all(p.sim.cracks.tri_damage() == 1.0)
    assert p.sim.cracks.fragment_count() == 2


def test_single_joint_shear_mode_II():
    p = Pair(fracture_energy_shear=1e4)
    sp = 2.0 * p.L * p.c / p.pf
    ds = 3.0 * p.gII / p.c
    s, tau, s_break = p.drive(p.e, 1, sp, ds)
    i = int(np.argmax(tau))
    assert tau[i] == pytest.approx(p.c, rel=1e-3)
    assert s[i] == pytest.approx(sp, rel=1e-3)
    w_ref = p.c * (2 * sp / 3 + Z_INTEGRAL * ds)
    print(f"\nshear: peak τ/c = {tau[i] / p.c:.5f} at s/s_p = {s[i] / sp:.4f}; breakage s/(s_p+Δ_s) = "
          f"{s_break / (sp + ds):.5f}; work/ref = {_trapezoid(tau, s) / w_ref:.5f}, energies/ref = "
          f"{p.sim.energies()['fracture'] / p.L / w_ref:.5f}")
    assert s_break == pytest.approx(sp + ds, rel=1e-3)
    assert _trapezoid(tau, s) == pytest.approx(w_ref, rel=1e-3)
    assert p.sim.energies()["fracture"] / p.L == pytest.approx(w_ref, rel=1e-3)
    assert list(p.sim.cracks.broken()["mode"]) == ["II"]


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
    assert tau[i] == pytest.approx(fs, rel=1e-3)
    assert s[i] == pytest.approx(sp, rel=1e-3)
    assert s_break == pytest.approx(sp + ds, rel=1e-3)
    assert list(p.sim.cracks.broken()["mode"]) == ["II"]


# ------------------------------------------------------------------------------------------------
# direct tension of a jointed strip
# ------------------------------------------------------------------------------------------------
def test_direct_tension_strip_peak_stress():
    """A fully jointed strip (1 × 0.2 m, 2 elements across) pulled quasi-statically: the peak
    stress equals f_t within 0.5 %, the README's figure 0.997 f_t to ±0.0005, and it breaks into
    pieces (taichi_fdem.verification.case_direct_tension)."""
    r = V.case_direct_tension(resolution=2)
    print(f"\nstrip: peak stress / f_t = {r['peak_over_ft']:.5f}; {r['broken_joints']} joints broken; "
          f"{r['steps']} steps")
    assert r["peak_over_ft"] == pytest.approx(1.0, rel=0.005)
    assert r["peak_over_ft"] == pytest.approx(0.997, abs=5e-4)
    assert r["broken_joints"] >= 2
    assert r["fragments"] >= 2


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
    """Intact joints add compliance in series with the elements: 1/E_eff = 1/E + κ/p_f, so
    (c/c_jointed)² − 1 = κ E/p_f halves when p_f doubles: the κ measured at 10·E and 20·E (0.66,
    0.80) agree within 25 % (the arrival times also carry the discrete dispersion, 1.4 % of c).
    README: at the default p_f = 10·E the jointed strip carries the wave at 0.97 (±0.005) of the
    unjointed speed; the unjointed speed is √(E/ρ) within 2 % (discrete dispersion)."""
    t_plain, x = _arrival_time(False)
    t_10, _ = _arrival_time(True, 10.0)
    t_20, _ = _arrival_time(True, 20.0)
    c0 = math.sqrt(1e8 / 1000.0)
    r10, r20 = t_plain / t_10, t_plain / t_20                # c_jointed / c_plain
    k10, k20 = (1.0 / r10 ** 2 - 1.0) * 10.0, (1.0 / r20 ** 2 - 1.0) * 20.0
    print(f"\nwave: unjointed c/c0 = {x / t_plain / c0:.4f}; jointed/unjointed speed = {r10:.4f} (p_f = 10 E), "
          f"{r20:.4f} (20 E); κ = {k10:.3f}, {k20:.3f}")
    assert x / t_plain == pytest.approx(c0, rel=0.02)
    assert r10 == pytest.approx(0.97, abs=0.005)
    assert r10 < r20 < 1.0
    assert k20 == pytest.approx(k10, rel=0.25)


# ------------------------------------------------------------------------------------------------
# Brazilian disc (§8.8) and a fragmenting impact: verification.brazilian_scene and
# fragment_plate_scene, run by the demos; tests/test_demos.py checks them (short mode in CI,
# full mode and the README figures under the slow marker)
# ------------------------------------------------------------------------------------------------


# ------------------------------------------------------------------------------------------------
# skip and validation
# ------------------------------------------------------------------------------------------------
def test_no_fracture_no_joint_kernel():
    mat = fdem.Material(density=1000.0, young=1e7, poisson=0.3)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.disk(0.1, 0.05), mat, position=(-0.11, 0.0), velocity=(1.0, 0.0))
    scene.add_body(fdem.mesh.disk(0.1, 0.05), mat, position=(0.11, 0.0))
    sim = scene.build(strategy="parallel")
    sim.step(20)
    sim.forces()
    sim.solver.profile(5)
    assert sim.model.fracture is False and sim.model.joint_count == 0
    assert "eval_joints" not in sim.solver.launches
    assert sim.solver.launches                                  # the parallel strategy counts its launches
    assert sim.model.joint_nodes.shape[0] == 1 and sim.state.joint_state.shape[0] == 1
    assert sim.cracks.broken_count == 0 and sim.cracks.fragment_count() == 2
    assert sim.energies()["fracture"] == 0.0 and sim.energies()["joints"] == 0.0
    assert np.all(sim.cracks.tri_damage() == 0.0)


def test_fracture_parameters_validated():
    scene = fdem.Scene()
    with pytest.raises(ValueError, match="tensile_strength.*fracture_energy"):
        scene.add_body(_square(), fdem.Material(), fracture=True)
    with pytest.raises(ValueError, match="tensile_strength.*fracture_energy"):
        scene.add_body(_square(), fdem.Material(tensile_strength=1e6), fracture=True)
    with pytest.raises(ValueError, match="fracture_energy"):
        fdem.Material(tensile_strength=1e6, fracture_energy=-1.0)
    soft = fdem.Material(young=1e8, tensile_strength=1e5, fracture_energy=1e3, joint_penalty=2e8)
    scene.add_body(_square(), soft, fracture=True)
    with pytest.warns(RuntimeWarning, match="joint_penalty"):
        scene.build()


def test_friction_energy_balance_while_fragmenting():
    """A jointed slab dropped on a floor at 3 m/s shatters with μ = 0.5 between its fragments.
    The friction force acts where its relative velocity is taken and its dissipation is booked as
    the plastic slip times the mean spring force over the increment (engine.contact): the energy
    account closes within 0.5 % (it drifted by −4.6 % with the force split like the normal force
    and the end-of-increment force, measured)."""
    rock = fdem.Material(density=2500.0, young=1e8, poisson=0.25, friction=0.5, tensile_strength=5e4,
                         fracture_energy=5.0)
    floor = fdem.Material(density=2500.0, young=1e8, friction=0.0)
    scene = fdem.Scene(gravity=(0.0, -9.81))
    scene.add_body(fdem.mesh.rectangle(1.0, 0.1, 0.1), floor, position=(0.0, -0.05), fixed=True)
    scene.add_body(fdem.mesh.polygon([(-0.2, 0.0), (0.2, 0.0), (0.2, 0.1), (-0.2, 0.1)], 0.025), rock,
                   position=(0.0, 0.1), velocity=(0.0, -3.0), fracture=True)
    sim = scene.build()
    e0 = sim.energies()["total"]
    sim.step(int(round(0.041 / sim.dt)))
    e = sim.energies()
    assert sim.cracks.broken_count > 40 and e["friction"] > 0.2 * abs(e0)      # it shattered, with friction
    assert abs(e["total"] - e0) < 5e-3 * abs(e0), e


# ------------------------------------------------------------------------------------------------
# broken joints need no re-detection (docs/theory/joints.md §7.10)
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("strategy", ["serial", "parallel"])
def test_overlapping_pairs_are_couples_after_breakage_without_redetection(strategy):
    """Joined neighbours stay couples and every triangle of a split body takes part in
    detection, so a joint that breaks needs no re-detection: after a fragmenting impact (joints
    broken between detections), every pair of triangles that overlaps now (brute force: clipped
    overlap area, pairs sharing no node) is in the couple list, and there are fewer detections
    than broken joints (one was forced at every break before)."""
    from conftest import couple_set, overlap_area
    sim, _ = V.fragment_plate_scene(h_plate=0.025, h_ball=0.02)
    sim = sim.scene.build(strategy=strategy)
    sim.run(0.003, progress=False)
    assert sim.cracks.broken_count >= 20
    assert sim.solver.detection_count < sim.cracks.broken_count
    x = sim.node_positions()
    tris = sim.model.tri_nodes_np
    P = x[tris]                                                   # (m, 3, 2)
    lo, hi = P.min(axis=1), P.max(axis=1)
    box = ((lo[:, None, 0] < hi[None, :, 0]) & (lo[None, :, 0] < hi[:, None, 0])
           & (lo[:, None, 1] < hi[None, :, 1]) & (lo[None, :, 1] < hi[:, None, 1]))
    a, b = np.nonzero(np.triu(box, 1))
    share = (tris[a][:, :, None] == tris[b][:, None, :]).any(axis=(1, 2))
    a, b = a[~share], b[~share]
    tol = 1e-12 * float(sim.model.tri_area0_np.mean())
    touching = {(int(i), int(j)) for i, j in zip(a, b) if overlap_area(P[i], P[j]) > tol}
    assert len(touching) >= 20                                    # fragments and joined faces pressing
    assert touching <= couple_set(sim)

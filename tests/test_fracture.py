"""Cohesive joints and fracture (FDEM_SPEC §7, §8.3, §8.7, §8.8): analytic checks with tolerances.

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
    """A fully jointed strip (1 × 0.2 m, 2 elements across) pulled quasi-statically: the peak
    stress equals f_t within 2 %, and it breaks into pieces (taichi_fdem.verification)."""
    from taichi_fdem import verification as V
    r = V.case_direct_tension(resolution=2)
    print(f"\nstrip: peak stress / f_t = {r['peak_over_ft']:.5f}; {r['broken_joints']} joints broken; "
          f"{r['steps']} steps")
    assert r["peak_over_ft"] == pytest.approx(1.0, rel=0.02)
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


# ------------------------------------------------------------------------------------------------
# Brazilian disc (§8.8)
# ------------------------------------------------------------------------------------------------
def brazilian_scene(D=0.1, elements=40, alpha_deg=10.0, load_time=60.0, damping=1.0):
    """A disc of diameter D (ring mesh, h = D/elements) with flattened caps of half-angle α
    (nodes clipped to |y| ≤ R cos α: the load spreads over ~2α instead of one node), between two
    stiff platens moving at ±v; v is chosen so that the expected platen approach at peak is
    covered in ``load_time`` × D/c_p.  Returns (sim, disk, top, bottom, v, material)."""
    R, h = 0.5 * D, D / elements
    mat = fdem.Material(density=2500.0, young=10e9, poisson=0.2, damping=damping, tensile_strength=5e6,
                        fracture_energy=50.0, cohesion=15e6, friction_angle=35.0, name="rock")
    platen = fdem.Material(density=2500.0, young=100e9, poisson=0.2, penalty=3 * mat.young, name="steel")
    d0 = fdem.mesh.disk(R, h)
    yc = R * math.cos(math.radians(alpha_deg))
    pts = d0.points.copy()
    pts[:, 1] = np.clip(pts[:, 1], -yc, yc)
    scene = fdem.Scene(gravity=(0.0, 0.0), plane="strain")
    disk = scene.add_body(TriMesh(pts, d0.triangles), mat, fracture=True, name="disc")
    cp = mat.p_wave_speed("strain")
    approach = 6e-4 * D / 0.1                  # nominal; the measured approach at peak is ≈ 0.28 mm, so the
    #                                            peak comes after ≈ 0.45 load_time (≈ 28 D/c_p at 60: test budget)
    v = 0.5 * approach / (load_time * D / cp)
    pm = fdem.mesh.rectangle(0.5 * D, 0.1 * D, D / 20)
    top = scene.add_body(pm, platen, position=(0.0, yc + 0.05 * D + 1e-9), prescribed_velocity=(0.0, -v), name="top")
    bot = scene.add_body(pm, platen, position=(0.0, -yc - 0.05 * D - 1e-9), prescribed_velocity=(0.0, v), name="bottom")
    sim = scene.build(safety=0.35)
    return sim, disk, top, bot, v, mat


def run_brazilian(sim, top, bot, v, D, load_time, cp, samples=200, callback=None):
    """Load with a ramp of the platen speed over 0.1 load_time D/c_p; sample P (per unit thickness,
    on the top platen) and the platen approach until the load has dropped below 30 % of its peak.
    Returns dict(t, P, approach, broken)."""
    t_load = load_time * D / cp
    n_total = int(1.3 * t_load / sim.dt)
    k = max(1, n_total // samples)
    vbc0 = sim.node_vbc.to_numpy()
    t_ramp = 0.1 * t_load
    y_top0, y_bot0 = sim.node_positions(top)[:, 1].mean(), sim.node_positions(bot)[:, 1].mean()
    out = {"t": [], "P": [], "approach": [], "broken": []}
    while sim.step_count < n_total:
        if sim.time < t_ramp + k * sim.dt:
            sim.node_vbc.from_numpy(vbc0 * min(1.0, (sim.time + 0.5 * k * sim.dt) / t_ramp))
        sim.step(k)
        P = float(sim.forces()[top.nodes, 1].sum())           # thickness 1: per unit thickness
        out["t"].append(sim.time)
        out["P"].append(P)
        out["approach"].append(float((y_top0 - sim.node_positions(top)[:, 1].mean())
                                     + (sim.node_positions(bot)[:, 1].mean() - y_bot0)))
        out["broken"].append(sim.broken_joint_count)
        if callback is not None:
            callback(sim)
        if out["broken"][-1] and P < 0.3 * max(out["P"]):
            break
    return {key: np.array(val) for key, val in out.items()}


def test_brazilian_disc():
    D, load_time = 0.1, 60.0
    sim, disk, top, bot, v, mat = brazilian_scene(D, 40, load_time=load_time)
    cp = mat.p_wave_speed("strain")
    r = run_brazilian(sim, top, bot, v, D, load_time, cp)
    i = int(np.argmax(r["P"]))
    sigma_t = 2.0 * r["P"][i] / (math.pi * D * 1.0)
    ratio = sigma_t / mat.tensile_strength
    alpha = math.radians(10.0)
    hondros = (math.sin(2 * alpha) - alpha) / alpha            # centre stress factor of a load spread over 2α
    bj = sim.broken_joints()
    j = min(i + 10, len(r["t"]) - 1)
    sel = bj["time"] <= r["t"][j]
    central = float(np.mean(np.abs(bj["position"][sel, 0]) < 0.15 * D)) if sel.any() else 0.0
    print(f"\nbrazilian: {sim.info()['triangles']} triangles, loading time to peak {r['t'][i] * cp / D:.0f} D/c_p; "
          f"σ_t/f_t = {ratio:.4f} (with the Hondros factor {hondros:.3f}: {ratio * hondros:.4f}); "
          f"{sel.sum()} joints broken by shortly after the peak, {central:.0%} with |x| < 0.15 D; "
          f"fragments {sim.fragment_count(disk)}")
    # The caps are flattened over ±α, so the analytic centre stress of this geometry is
    # 2P/(πDt) × (sin 2α − α)/α (Hondros); the peak load itself is sensitive to round-off (the
    # first joints to break decide the crack path): seen 1.107 and 1.162 for two builds.
    assert ratio * hondros == pytest.approx(1.0, rel=0.15)
    assert sel.sum() >= 5
    assert central >= 0.8


# ------------------------------------------------------------------------------------------------
# fracturing impact: energy balance and fragments
# ------------------------------------------------------------------------------------------------
def _components(n_tri, pairs):
    """Connected components of n_tri triangles linked by ``pairs`` (union-find, brute force)."""
    parent = list(range(n_tri))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a
    for a, b in pairs:
        ra, rb = find(int(a)), find(int(b))
        if ra != rb:
            parent[ra] = rb
    return len({find(a) for a in range(n_tri)})


def impact_scene(plate_h=0.02, speed=30.0):
    mat = fdem.Material(density=1000.0, young=1e8, poisson=0.25, tensile_strength=2e5, fracture_energy=20.0,
                        name="plate")
    proj = fdem.Material(density=3000.0, young=1e8, poisson=0.25, name="projectile")
    scene = fdem.Scene(gravity=(0.0, 0.0))
    plate = scene.add_body(fdem.mesh.rectangle(0.4, 0.1, plate_h), mat, fracture=True, name="plate")
    ball = scene.add_body(fdem.mesh.disk(0.03, 0.015), proj, position=(0.0, 0.085), velocity=(0.0, -speed),
                          name="projectile")
    return scene, plate, ball


def test_fracturing_impact_energy_and_fragments():
    scene, plate, ball = impact_scene()
    sim = scene.build()
    e0 = sim.energies()["total"]
    worst = 0.0
    for _ in range(30):
        sim.step(100)
        worst = max(worst, abs(sim.energies()["total"] - e0) / e0)
    e = sim.energies()
    nb = sim.broken_joint_count
    jt = sim._joint_tris_np
    intact = sim.joint_state.to_numpy()[: sim.joint_count] == 0
    plate_tris = np.arange(plate.triangles.start, plate.triangles.stop)
    ref = _components(sim.tri_count, jt[intact]) - (sim.tri_count - len(plate_tris))
    print(f"\nimpact: {nb} joints broken, fracture energy {e['fracture']:.4g} J of {e0:.4g} J; worst |ΔE|/E0 = "
          f"{worst:.4%}; fragments of the plate {sim.fragment_count(plate)} (brute force {ref})")
    assert nb >= 5
    assert e["fracture"] > 0
    assert worst < 0.02
    assert sim.fragment_count(plate) == ref
    assert sim.fragment_count() == ref + 1


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
    sim.profile(5)
    assert sim.fracture is False and sim.joint_count == 0
    assert "eval_joints" not in sim.launches
    assert sim.launches                                  # the parallel strategy counts its launches
    assert sim.joint_nodes.shape[0] == 1 and sim.joint_state.shape[0] == 1
    assert sim.broken_joint_count == 0 and sim.fragment_count() == 2
    assert sim.energies()["fracture"] == 0.0 and sim.energies()["joints"] == 0.0
    assert np.all(sim.tri_damage() == 0.0)


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

"""Initial stress carried by intact cohesive joints (docs/theory/joints.md §7.11, docs/theory/loads.md §12.4).

A prestressed joint starts at the point (o⁰, s⁰) of its own law that carries σ⁰·n̂, so a jointed
body under an in-situ stress starts in equilibrium, and a joint loaded further fails when its
total traction reaches its strength.  Each test checks a conservation law or the joint law.
"""
import math

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem.mesh import TriMesh

E, RHO, NU = 1.0e7, 1000.0, 0.25
FT = 3e5


def _mat(**kw):
    kw = dict(density=RHO, young=E, poisson=NU, tensile_strength=FT, cohesion=2 * FT, fracture_energy=200.0, **kw)
    return fdem.Material(**kw)


def _block(stress, fracture=True, self_contact=True, extra=None):
    """A 0.4 × 0.2 m block (every interior edge a joint) under the initial stress (σxx, σyy, σxy)
    with the matching boundary tractions σ·n (``extra`` (σxx, σxy) added on the right side)."""
    sxx, syy, sxy = stress
    sc = fdem.Scene(gravity=(0.0, 0.0))
    sc.add_body(fdem.mesh.rectangle(0.4, 0.2, 0.05), _mat(), fracture=fracture, self_contact=self_contact)
    sc.initial_stress(sxx, syy, sxy)
    if extra is None:
        sc.apply_traction(lambda x, y: x > 0.199, (sxx, sxy))
    else:
        sc.apply_traction(lambda x, y: x > 0.199, (sxx, sxy))
        sc.apply_traction(lambda x, y: x > 0.199, extra[0], curve=extra[1])
    sc.apply_traction(lambda x, y: x < -0.199, (-sxx, -sxy))
    sc.apply_traction(lambda x, y: y > 0.099, (sxy, syy))
    sc.apply_traction(lambda x, y: y < -0.099, (-sxy, -syy))
    return sc


@pytest.mark.parametrize("stress", [(-1e5, -2e5, 3e4), (1e5, 5e4, -3e4)], ids=["compressive", "tensile"])
def test_jointed_block_under_anisotropic_initial_stress_stays_at_rest(stress):
    sim = _block(stress).build()
    assert sim.model.joint_count > 50 and sim.model.joint_prestress
    sim.step(2000)
    e = sim.energies()
    scale = max(abs(s) for s in stress) ** 2 / E * 0.08          # σ²/E × area [J per m]
    print(f"\nat rest: kinetic/scale = {e['kinetic'] / scale:.2e}, max |u| = "
          f"{np.abs(sim.node_displacements()).max():.2e} m, max damage {sim.cracks.joint_damage().max()}")
    assert e["kinetic"] < 1e-18 * scale, e["kinetic"]
    assert np.abs(sim.node_displacements()).max() < 1e-12 * 0.2
    assert sim.cracks.joint_damage().max() == 0.0 and sim.cracks.broken_count == 0
    # the same stresses as the intact body, which needs no joints to carry them
    ref = _block(stress, fracture=False).build()
    ref.step(200)
    np.testing.assert_allclose(sim.stresses(), ref.stresses(), rtol=0, atol=1e-9 * scale / 0.08 * E)
    S = np.array([[stress[0], stress[2]], [stress[2], stress[1]]])
    np.testing.assert_allclose(sim.stresses(), np.broadcast_to(S, sim.stresses().shape), rtol=1e-9)


def test_without_joint_traction_the_jointed_block_would_move():
    """The initial traction is what balances the node copies: a block whose joints carry half of it moves."""
    sim = _block((-1e5, -2e5, 3e4)).build()
    prop = sim.model.joint_prop.to_numpy()
    prop[:, 8:] *= 0.5
    sim.model.joint_prop.from_numpy(prop)
    sim.step(200)
    assert sim.energies()["kinetic"] > 1e-9 * 1e10 / E * 0.08


def test_lithostatic_gradient_with_joints_is_balanced_exactly():
    """σ(y) linear in depth, gravity and rollers: the joints carry σ⁰(x)·n̂ at their own points."""
    g = 9.81
    sc = fdem.Scene(gravity=(0.0, -g), plane="strain")
    sc.add_body(fdem.mesh.rectangle(0.2, 0.4, 0.05, origin=(0.0, -0.4)), _mat(), fracture=True)
    k0 = NU / (1 - NU)
    sc.initial_stress(0.0, 0.0, gradient=(k0 * RHO * g, RHO * g), y_ref=0.0)
    sc.fix_nodes(lambda x, y: y < -0.399, velocity=(None, 0.0))
    sc.fix_nodes(lambda x, y: (x < 1e-9) | (x > 0.2 - 1e-9), velocity=(0.0, None))
    sim = sc.build()
    sim.step(2000)
    u_free = RHO * g * 0.4 ** 2 / (2 * E)             # settlement of the column loaded by gravity alone
    print(f"\nlithostatic: max |u| / u_free = {np.abs(sim.node_displacements()).max() / u_free:.2e}")
    assert np.abs(sim.node_displacements()).max() < 1e-9 * u_free
    assert sim.cracks.joint_damage().max() == 0.0


def test_energy_balance_closes_under_boundary_loading():
    """Prestressed jointed block, then a ramped extra traction on one side: total stays constant."""
    ramp = fdem.Curve([0.0, 0.01, 1.0], [0.0, 1.0, 1.0])
    sim = _block((-1e5, -2e5, 3e4), extra=((-5e4, 2e4), ramp)).build()
    sim.run(0.015)
    e = sim.energies()
    print(f"\nenergy: total/load_work = {e['total'] / e['load_work']:.2e}, joints {e['joints']:.3e} J")
    assert e["load_work"] > 0 and abs(e["joints"]) > 0
    assert sim.cracks.joint_damage().max() == 0.0
    assert abs(e["total"]) < 1e-3 * e["load_work"], (e["total"], e["load_work"])


def test_initial_stress_at_joint_strength_is_refused():
    sc = _block((1.01 * FT, 0.0, 0.0))
    with pytest.raises(ValueError, match="reaches its strength"):
        sc.build()


# ------------------------------------------------------------------------------------------------
# one joint with exact kinematics (every node prescribed, as tests/test_fracture.py)
# ------------------------------------------------------------------------------------------------
class _PrestressedPair:
    """Two triangles of a unit square, one joint on the diagonal, every node prescribed, under an
    initial stress (σxx, σyy, σxy)."""

    def __init__(self, stress):
        sq = TriMesh(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]), np.array([[0, 1, 2], [0, 2, 3]]))
        self.mat = fdem.Material(density=1000.0, young=1e8, poisson=0.25, tensile_strength=1e6, cohesion=2e6,
                                 fracture_energy=1e4)
        self.ft, self.c, self.tanphi, self.gI, self.gII, self.pf = self.mat.joint_properties()
        sc = fdem.Scene(gravity=(0.0, 0.0))
        body = sc.add_body(sq, self.mat, fracture=True)
        sc.fix_nodes(lambda x, y: np.ones(len(x), bool), body=body, velocity=(0.0, 0.0))
        sc.initial_stress(*stress)
        self.dt = 1e-4
        self.sim = sc.build(dt=self.dt, force_dt=True)
        jn = self.sim.model.joint_nodes.to_numpy()[0]
        jt = self.sim.model.joint_tris_np[0]
        self.jn = jn
        tri = self.sim.model.tri_nodes_np
        self.A = tri[jt[0]]
        x = self.sim.node_positions()
        e = 0.5 * (x[jn[1]] + x[jn[2]] - x[jn[0]] - x[jn[3]])
        self.L = float(np.linalg.norm(e))
        self.e = e / self.L
        self.n = np.array([-self.e[1], self.e[0]])        # into A
        self.vbc = self.sim.state.node_vbc.to_numpy()

    def traction(self):
        """(σ, τ) [Pa] of the joint from its forces on A (A's own forces sum to zero)."""
        fa = self.sim.forces()[self.A].sum(axis=0)
        return float(-(fa @ self.n) / self.L), float(-(fa @ self.e) / self.L)

    def drive(self, direction, inc, steps, until=None):
        """Move A by ``inc`` [m] per step along ``direction``: the tractions (steps, 2) after each
        of ``steps`` steps; with ``until`` [m], then on to that displacement or breakage, and the
        displacement at breakage (None if it did not break)."""
        self.vbc[self.A] = direction * inc / self.dt
        self.sim.state.node_vbc.from_numpy(self.vbc)
        t0 = self.sim.time
        out = []
        for _ in range(steps):
            self.sim.step(1)
            out.append(self.traction())
        if until is None:
            return np.array(out), None
        self.sim.step(int(until / inc) - steps)
        if not self.sim.cracks.broken_count:
            return np.array(out), None
        # positions at the start of the step of breakage are the ones evaluated (tests/test_fracture.py)
        return np.array(out), (float(self.sim.cracks.broken()["time"][0]) - t0) * inc / self.dt


def test_joint_in_initial_tension_fails_at_its_strength():
    """σ⁰ = 0.8 f_t on the joint: at rest it carries σ⁰; pulled open, the total traction peaks at
    f_t (not f_t + σ⁰) after the remaining opening δ_p − o⁰, o⁰ = δ_p (1 − √(1 − 0.8)), and the
    joint breaks when the total opening reaches δ_p + Δ_n."""
    s0 = 0.8e6
    p = _PrestressedPair((s0, s0, 0.0))             # isotropic: σ⁰·n̂ = σ⁰ n̂ on any joint
    p.sim.step(1)
    sig, tau = p.traction()
    assert sig == pytest.approx(s0, rel=1e-9) and abs(tau) < 1e-9 * s0
    assert p.sim.cracks.joint_damage().max() == 0.0
    dp = 2.0 * p.L * p.ft / p.pf
    dn = 3.0 * p.gI / p.ft
    o0 = dp * (1.0 - math.sqrt(1.0 - s0 / p.ft))
    inc = dp / 200
    t, u_break = p.drive(p.n, inc, 250, until=1.5 * (dp + dn))
    i = int(np.argmax(t[:, 0]))
    print(f"\ntension: peak/f_t = {t[i, 0] / p.ft:.5f} after {(i + 1) * inc / (dp - o0):.4f} (δ_p − o⁰), "
          f"break after {u_break / (dp + dn - o0):.5f} (δ_p + Δ_n − o⁰)")
    assert t[i, 0] == pytest.approx(p.ft, rel=1e-3)
    assert (i + 1) * inc == pytest.approx(dp - o0, rel=0.02)
    assert u_break == pytest.approx(dp + dn - o0, rel=1e-3)


def test_compressed_joint_gains_mohr_coulomb_shear_strength():
    """σ⁰ = −1 MPa on the joint: the shear peak is c − σ⁰ tan φ, the initial traction counted."""
    s0 = -1e6
    p = _PrestressedPair((s0, s0, 0.0))
    p.sim.step(1)
    assert p.traction()[0] == pytest.approx(s0, rel=1e-9)
    fs = p.c - s0 * p.tanphi
    sp = 2.0 * p.L * fs / p.pf
    t, _ = p.drive(p.e, sp / 100, 150)
    print(f"\nshear: peak / (c − σ⁰ tan φ) = {t[:, 1].max() / fs:.5f}")
    assert t[:, 1].max() == pytest.approx(fs, rel=1e-3)
    assert np.allclose(t[:, 0], s0, rtol=1e-9)              # sliding along ê leaves σ alone


def test_serial_and_parallel_agree():
    runs = {}
    for strategy in ("serial", "parallel"):
        ramp = fdem.Curve([0.0, 0.005, 1.0], [0.0, 1.0, 1.0])
        sim = _block((1e5, 5e4, -3e4), extra=((2.5e5, 0.0), ramp)).build(strategy=strategy)
        sim.run(0.01)
        runs[strategy] = (sim.node_positions(), sim.cracks.joint_damage(), sim.cracks.broken_count)
    print(f"\nserial vs parallel: max |Δx| = {np.abs(runs['serial'][0] - runs['parallel'][0]).max():.2e} m, "
          f"max damage {runs['serial'][1].max():.3f}, {runs['serial'][2]} broken")
    assert runs["serial"][1].max() > 0 and runs["serial"][2] == runs["parallel"][2]
    np.testing.assert_allclose(runs["serial"][0], runs["parallel"][0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(runs["serial"][1], runs["parallel"][1], rtol=0, atol=1e-9)

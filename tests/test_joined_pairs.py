"""Pairs of triangles joined along an edge by an intact joint (docs/theory/joints.md §7.10, issue 10).

Until the joint's damage exceeds ``handover_damage`` (or it breaks), contact is not evaluated
for the pair and the joint carries the contact's share of the compression, 3p(1/h_A + 1/h_B)
per unit overlap (``engine.joints.carried_share``); then it hands the energy of that share over
to contact.  The scene: a unit square of two triangles with a joint on the diagonal, every node
of the square prescribed (exact kinematics), and one free triangle far away in the same body
(so that the body is not fully fixed and its pairs are contact couples).  References: the same
pair built with ``joined_pairs="contact"`` (the joint's own law plus the contact kernel), and
the energy account.
"""
from __future__ import annotations

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem.engine.groups import DAMAGED, EDGE_FREE, INTACT
from taichi_fdem.engine.joints import HANDOVER_DAMAGE
from taichi_fdem.mesh import TriMesh

DT = 1e-4


class Square:
    def __init__(self, carried=True, handover_damage=HANDOVER_DAMAGE, **matkw):
        pts = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [5.0, 5.0], [6.0, 5.0], [5.0, 6.0]])
        mesh = TriMesh(pts, np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6]]))
        kw = dict(density=1000.0, young=1e8, poisson=0.25, tensile_strength=1e6, fracture_energy=1e4)
        kw.update(matkw)
        self.mat = fdem.Material(**kw)
        scene = fdem.Scene(gravity=(0.0, 0.0))
        body = scene.add_body(mesh, self.mat, fracture=True)
        scene.fix_nodes(lambda x, y: x < 2.0, body=body, velocity=(0.0, 0.0))
        self.sim = scene.build(dt=DT, force_dt=True, joined_pairs="joint" if carried else "contact",
                               handover_damage=handover_damage)
        jt = self.sim.model.joint_tris.to_numpy()[0]
        tn = self.sim.model.tri_nodes.to_numpy()
        self.A = tn[jt[0]]
        jn = self.sim.model.joint_nodes.to_numpy()[0]
        x = self.sim.node_positions()
        e = 0.5 * (x[jn[1]] + x[jn[2]] - x[jn[0]] - x[jn[3]])
        self.L = float(np.linalg.norm(e))
        self.e = e / self.L
        self.n = np.array([-self.e[1], self.e[0]])          # points into A
        self.tri_a = int(jt[0])
        self.vbc = self.sim.state.node_vbc.to_numpy()

    def move_A(self, velocity):
        self.vbc[self.A] = velocity
        self.sim.state.node_vbc.from_numpy(self.vbc)

    def compress(self, overlap, steps=100):
        self.move_A(-self.n * overlap / (steps * DT))
        self.sim.step(steps)
        self.move_A(np.zeros(2))

    def normal_force(self, contact_only=False):
        return float(self.sim.forces(contact_only=contact_only)[self.A].sum(axis=0) @ self.n)


def test_initial_bits_mark_the_joint_edge_only():
    s = Square()
    v = s.sim.state.tri_intact.to_numpy()
    assert np.all(v & INTACT) and not np.any(v & DAMAGED)
    free = [sum(bool(x & (EDGE_FREE << e)) for e in range(3)) for x in v]
    assert free == [2, 2, 3]          # one joint edge (the diagonal) in each half of the square


def test_carried_compression_matches_contact_force_and_energy():
    """The joint carrying the pair gives the normal force and the stored energy of the joint plus
    the contact kernel within 0.5 %; the contact share is most of it (the check can fail)."""
    c, r = Square(True), Square(False)
    c.compress(1e-3, steps=2000)       # the joints' work is a path integral: error ~ 1 / steps
    r.compress(1e-3, steps=2000)
    fc, fr, frc = c.normal_force(), r.normal_force(), r.normal_force(contact_only=True)
    print(f"\ncarried normal force {fc:.6g} N/m; joint + contact {fr:.6g} (contact {frc:.6g})")
    assert c.normal_force(contact_only=True) == 0.0               # contact not evaluated
    assert abs(frc) > 0.5 * abs(fr)
    assert fc == pytest.approx(fr, rel=5e-3)
    ec, er = c.sim.energies(), r.sim.energies()
    print(f"stored: carried {ec['joints']:.6g} J, joint + contact {er['joints'] + er['contact']:.6g} J")
    assert ec["contact"] == 0.0
    assert ec["joints"] == pytest.approx(er["joints"] + er["contact"], rel=5e-3)


@pytest.mark.parametrize("handover", [0.0, 0.05, 0.2])
def test_handover_keeps_the_energy(handover):
    """Compress, then shear until the joint's damage exceeds ``handover_damage``: contact takes
    the pair over with the energy the joint carried (the account changes by < 1 % of the
    contact energy handed over), not before (the damage then is above the threshold, and was
    at most it at the step before), and the pair's contact force then acts."""
    s = Square(cohesion=0.5e6, fracture_energy_shear=1e4, handover_damage=handover)
    s.compress(1e-3)
    s.move_A(s.e * 2e-5 / DT)
    totals, contact, dmax = [s.sim.energies()["total"]], [], [0.0]
    for _ in range(3000):
        s.sim.step(1)
        e = s.sim.energies()
        totals.append(e["total"])
        contact.append(e["contact"])
        dmax.append(float(s.sim.state.joint_dmax.to_numpy()[0].max()))
        if s.sim.state.tri_intact.to_numpy()[s.tri_a] & DAMAGED:
            break
    else:
        pytest.fail("the joint did not damage")
    jumps = np.abs(np.diff(totals))
    handed = contact[-1]
    print(f"\nhandover after {len(contact)} steps: contact energy {handed:.6g} J; change of the energy "
          f"account over that step {jumps[-1]:.3g} J (largest before {jumps[:-1].max():.3g} J)")
    assert contact[-2] == 0.0 and handed > 0.1 * s.sim.energies()["joints"]
    assert jumps[-1] < 0.01 * handed
    assert dmax[-2] <= handover < dmax[-1] and s.sim.cracks.broken_count == 0
    s.sim.step(1)                                     # from now on contact acts on the pair
    assert s.normal_force(contact_only=True) != 0.0


def test_joined_pairs_contact_mode_and_bad_value():
    s = Square(carried=False)
    v = s.sim.state.tri_intact.to_numpy()
    assert np.all(v & (7 * EDGE_FREE) == 7 * EDGE_FREE)          # no edge carried
    with pytest.raises(ValueError, match="joined_pairs"):
        fdem.Scene().build(joined_pairs="none")
    for bad in (-0.1, 1.5, float("nan"), "0.1", True):
        with pytest.raises(ValueError, match="handover_damage"):
            fdem.Scene().build(handover_damage=bad)


def test_carried_pair_shear_strength_includes_the_contact_friction_share():
    """Mohr–Coulomb of a carried joint: c − σ_j tan φ − μ σ_x, σ_j = p_f o / L its own normal
    stress and σ_x = 3p(1/h_A + 1/h_B) o the carried share (on which contact friction μ acted
    before): the peak shear traction to 0.1 %."""
    s = Square(cohesion=0.5e6, friction_angle=30.0, fracture_energy_shear=1e4, friction=0.5)
    ft, c, tanphi, gI, gII, pf = s.mat.joint_properties()
    overlap = 1e-3
    s.compress(overlap, steps=200)
    o = -overlap
    sig_j = pf * o / s.L
    sig_x = 3.0 * s.mat.contact_penalty * 2.0 * (2.0 / s.L) * o          # h = L/2 on both sides
    fs = c - sig_j * tanphi - 0.5 * sig_x
    sp = 2.0 * s.L * fs / pf
    s.move_A(s.e * (sp / 200) / DT)
    tau = []
    for _ in range(400):
        s.sim.step(1)
        if s.sim.state.tri_intact.to_numpy()[s.tri_a] & DAMAGED:
            break
        tau.append(abs(s.sim.forces()[s.A].sum(axis=0) @ s.e) / s.L)
    print(f"\npeak τ / (c − σ_j tanφ − μ σ_x) = {max(tau) / fs:.6f} (c − σ_j tanφ alone: {(c - sig_j * tanphi) / fs:.3f})")
    assert max(tau) == pytest.approx(fs, rel=1e-3)


def _bonded_reference(sim, pairs):
    """Which of ``pairs`` are bonded, in numpy and plain Python, written out again from the rule
    (docs/theory/joints.md §7.10): an edge pair while the joint on its shared edge carries it (the
    tri_intact bits, which the test checks against the joints' damage); a corner pair while its two triangles are connected around their shared
    original node by joints that are undamaged (not broken, no damage at any point) or edges
    left uncut, found by a walk over all of them (brute force, no fan ranks)."""
    bits = sim.state.tri_intact.to_numpy()
    org = sim.model.tri_origin.to_numpy()
    md = sim.model
    jt = md.joint_tris_np
    state = sim.state.joint_state.to_numpy()[: len(jt)]
    dmax = sim.state.joint_dmax.to_numpy()[: len(jt)]
    intact_joint = (state == 0) & (dmax.max(axis=1) <= 0.0)
    tn = md.tri_nodes.to_numpy()
    links = {}                                   # (original node, triangle) -> triangles linked
    tied = [(a, b) for (a, b), ok in zip(jt, intact_joint) if ok]
    # an edge a partly jointed body did not cut (two nodes shared) ties for good
    bonded = np.nonzero(bits >= INTACT)[0]
    by_node = {}
    for t in bonded:
        for n in tn[t]:
            by_node.setdefault(n, []).append(t)
    tied += [(a, b) for ts in by_node.values() for a in ts for b in ts
             if a < b and len(set(tn[a]) & set(tn[b])) == 2]
    for a, b in tied:
        if bits[a] < INTACT or bits[b] < INTACT:
            continue
        for v in set(org[a]) & set(org[b]):
            links.setdefault((v, a), []).append(b)
            links.setdefault((v, b), []).append(a)
    out = []
    for a, b in pairs:
        va, vb = int(bits[a]), int(bits[b])
        common = set(org[a]) & set(org[b])
        if va < INTACT or vb < INTACT:
            out.append(False)
        elif len(common) == 1:
            v = next(iter(common))
            seen, todo = {a}, [a]
            while todo:
                for t in links.get((v, todo.pop()), []):
                    if t not in seen:
                        seen.add(t)
                        todo.append(t)
            out.append(b in seen)
        else:
            ea = (list(org[a]).index(next(iter(set(org[a]) - common))) + 1) % 3
            eb = (list(org[b]).index(next(iter(set(org[b]) - common))) + 1) % 3
            out.append(not (va & (EDGE_FREE << ea)) and not (vb & (EDGE_FREE << eb)))
    return np.array(out, bool)


@pytest.mark.parametrize("mode,handover", [("joint", 0.05), ("joint", 0.0), ("contact", 0.0)])
def test_neighbour_pairs_are_every_shared_node_pair_and_follow_the_bonds(mode, handover):
    """The neighbour pairs (the first couples, never detected) are exactly the pairs of bonded
    triangles that share an original node (brute force over all pairs), none of them is also
    detected, and through a fragmenting impact tri_nb_on marks exactly those no longer bonded
    (the rule, evaluated again by brute force: edge pairs from the bits, corner pairs by a walk
    over the undamaged joints around their shared node), for both ways of treating joined
    pairs."""
    from taichi_fdem.verification import fragment_plate_scene
    sim, _ = fragment_plate_scene(h_plate=0.025, h_ball=0.02, friction=0.5)
    sim = sim.scene.build(strategy="serial", joined_pairs=mode, handover_damage=handover)
    md = sim.model
    org = md.tri_origin.to_numpy()
    bonded0 = np.nonzero(sim.state.tri_intact.to_numpy() >= INTACT)[0]
    expected = {(int(a), int(b)) for i, a in enumerate(bonded0) for b in bonded0[i + 1:]
                if set(org[a]) & set(org[b])}
    M = md.nb_count
    assert M == len(expected) > 100
    cp = sim.couples()
    assert {(int(a), int(b)) for a, b in cp[:M]} == expected
    assert not {(int(min(a, b)), int(max(a, b))) for a, b in cp[M:]} & expected
    seen_on = 0
    for _ in range(4):
        sim.step(150)
        on = sim.state.tri_nb_on.to_numpy()[:M].astype(bool)
        np.testing.assert_array_equal(on, ~_bonded_reference(sim, cp[:M]))
        seen_on = int(on.sum())
    assert sim.cracks.broken_count > 0 and seen_on > 0
    bits = sim.state.tri_intact.to_numpy()
    jt = md.joint_tris_np
    dmax = sim.state.joint_dmax.to_numpy()[: len(jt)].max(1)
    damaged = (sim.state.joint_state.to_numpy()[: len(jt)] != 0) | (dmax > handover)
    assert damaged.any()
    assert np.all(bits[jt[damaged]] & DAMAGED)
    # and only those: a bonded triangle is DAMAGED exactly when one of its joints handed over
    expected = np.zeros(len(bits), bool)
    expected[jt[damaged].ravel()] = True
    live = bits >= INTACT
    np.testing.assert_array_equal((bits[live] & DAMAGED) != 0, expected[live])
    if handover > 0.0:
        assert ((dmax > 0.0) & ~damaged).any()      # joints damaged below the threshold still tie


@pytest.mark.parametrize("handover", [0.0, 0.05])
def test_corner_pairs_switch_on_holding_almost_no_contact_energy(handover):
    """A corner pair is bonded until no chain of undamaged joints ties it around its shared node,
    and contact takes it over from then on with whatever overlap it has: the contact energy the
    corner pairs hold at the step they switch on (energy account with, less without, their
    flags) stays below 1e-4 of the impact energy through a fragmenting impact.  Edge pairs hand
    their carried energy over exactly (test_handover_keeps_the_energy).  Also when edge pairs
    are handed over later (``handover_damage``): the corner pairs are freed at a joint's first
    damage all the same (kept bonded until the handover at 0.05 they held 1.4e-3 of the impact
    energy in the full fragment_plate demo, measured)."""
    from taichi_fdem.verification import fragment_plate_scene
    sim, _ = fragment_plate_scene(h_plate=0.025, h_ball=0.02, friction=0.5)
    sim = sim.scene.build(handover_damage=handover)
    M = sim.model.nb_count
    org = sim.model.tri_origin.to_numpy()
    corner = np.array([len(set(org[a]) & set(org[b])) == 1 for a, b in sim.couples()[:M]])
    E0 = sim.energies()["total"]
    prev = sim.state.tri_nb_on.to_numpy()[:M].copy()
    held, switched = 0.0, 0
    for _ in range(600):
        sim.step(1)
        flags = sim.state.tri_nb_on.to_numpy()
        new = (flags[:M] != 0) & (prev == 0) & corner
        if new.any():
            with_new = sim.energies()["contact"]
            off = flags.copy()
            off[:M][new] = 0
            sim.state.tri_nb_on.from_numpy(off)
            held += with_new - sim.energies()["contact"]
            sim.state.tri_nb_on.from_numpy(flags)
            switched += int(new.sum())
        prev = flags[:M].copy()
    print(f"\n{switched} corner pairs switched on holding {held:.3g} J/m of contact energy "
          f"({held / E0:.2e} of E0 = {E0:.4g} J/m); {sim.cracks.broken_count} joints broken")
    assert switched > 20 and sim.cracks.broken_count > 0
    assert 0.0 <= held < 1e-4 * E0


@pytest.mark.parametrize("handover", [0.0, 0.05])
def test_fragmenting_impact_energy_balance_with_a_later_handover(handover):
    """The fragmenting impact of demos/fragment_plate.py (its full mesh, 1,357 triangles, and
    duration), handing joined pairs over at the first damage or at D = 0.05: the energy account
    (kinetic + strain + contact + joints + fracture + dissipated) stays within 0.1 % of the
    impact energy at 30 checks, with hundreds of joints broken."""
    from taichi_fdem.verification import fragment_plate_scene
    sim, _ = fragment_plate_scene(h_plate=0.008, h_ball=0.006, speed=30.0)
    sim = sim.scene.build(handover_damage=handover)
    e0 = sim.energies()["total"]
    worst = 0.0
    for _ in range(30):
        sim.run(0.012 / 30, progress=False)
        worst = max(worst, abs(sim.energies()["total"] - e0) / e0)
    jt = sim.model.joint_tris_np
    damaged = (sim.state.joint_dmax.to_numpy()[: len(jt)].max(1) > 0) & (sim.state.joint_state.to_numpy()[: len(jt)] == 0)
    print(f"\nhandover {handover}: worst energy error {worst:.2e}; {sim.cracks.broken_count} broken, "
          f"{int(damaged.sum())} damaged")
    assert sim.cracks.broken_count >= 400 and damaged.any()
    assert worst < 1e-3


def test_restart_with_a_later_handover_continues_exactly(tmp_path):
    """A checkpoint keeps ``handover_damage`` (its step_real slot and the build setting): a
    fragmenting impact restarted mid-run continues bit for bit, flags and bonds included."""
    from taichi_fdem.verification import fragment_plate_scene
    sim, _ = fragment_plate_scene(h_plate=0.025, h_ball=0.02, friction=0.5)
    a = sim.scene.build(handover_damage=0.05)
    a.step(400)
    a.save(tmp_path / "run.ckpt")
    a.step(300)
    b = fdem.Simulation.load(tmp_path / "run.ckpt")
    assert b.model.handover_damage == 0.05
    b.step(300)
    assert a.cracks.broken_count == b.cracks.broken_count > 0
    for name in ("node_x", "node_v", "tri_nb_on", "tri_intact", "joint_dmax", "couple_hist"):
        np.testing.assert_array_equal(getattr(a.state, name).to_numpy(), getattr(b.state, name).to_numpy(), name)


def test_corner_pairs_of_a_partly_jointed_body_follow_joints_and_uncut_edges():
    """In a plate with joints only in a band (the rest of its mesh continuous), the corner pairs'
    flags follow the same brute-force rule, where an uncut edge ties its two triangles for
    good, at the start and while the band is pulled apart."""
    from taichi_fdem.verification.discontinuities import band_plate_scene
    sim, _ = band_plate_scene()
    M = sim.model.nb_count
    pairs = sim.couples()[:M]
    tn = sim.model.tri_nodes.to_numpy()
    uncut = sum(len(set(tn[a]) & set(tn[b])) >= 2 for a, b in pairs)
    assert M > 100 and uncut > 0
    seen = 0
    for _ in range(3):
        on = sim.state.tri_nb_on.to_numpy()[:M].astype(bool)
        np.testing.assert_array_equal(on, ~_bonded_reference(sim, pairs))
        seen = max(seen, int(on.sum()))
        sim.step(2000)
    assert seen > 0


@pytest.mark.parametrize("strategy", ["serial", "parallel"])
def test_held_bit_marks_exactly_the_neighbour_pairs_holding_slip(tmp_path, strategy):
    """Contact reads the slip history of a neighbour pair that is apart only when its NB_HELD bit
    (in tri_nb_on) says it holds slip.  Through a fragmenting impact with friction the bit is set
    exactly where the pair's six slips are not all zero (a missed bit would leave a stale slip
    and its energy unbooked), only on pairs switched on, and a checkpoint restores it."""
    from taichi_fdem.engine.groups import NB_HELD
    from taichi_fdem.verification import fragment_plate_scene
    sim, _ = fragment_plate_scene(h_plate=0.02, h_ball=0.015, friction=0.5)
    sim = sim.scene.build(strategy=strategy)
    M = sim.model.nb_count
    seen_held = seen_released = 0
    before = None
    for _ in range(8):
        sim.step(150)
        flags = sim.state.tri_nb_on.to_numpy()[:M]
        hist = sim.state.couple_hist.to_numpy()[: 6 * M].reshape(M, 6)
        holds = np.any(hist != 0.0, axis=1)
        held = (flags & NB_HELD) != 0
        np.testing.assert_array_equal(held, holds)
        assert np.all(flags[held] & 1)
        if before is not None:
            seen_released += int(np.sum(before & ~held))
        seen_held = max(seen_held, int(held.sum()))
        before = held
    assert seen_held > 10 and seen_released > 0
    sim.save(tmp_path / "c")
    back = fdem.Simulation.load(tmp_path / "c")
    np.testing.assert_array_equal(back.state.tri_nb_on.to_numpy(), sim.state.tri_nb_on.to_numpy())

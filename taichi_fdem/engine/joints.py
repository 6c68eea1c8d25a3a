"""Cohesive joint elements: the combined single and smeared crack model (docs/theory/joints.md §7).

A 4-node joint (j0, j1, j2, j3) sits on an interior edge shared by triangles A and B of a
fracturing body: j0→j1 is A's copy of the edge in A's counter-clockwise order, j3 and j2 are
B's copies of the nodes coincident with j0 and j1 (§7.1).  Opening o and sliding s are
integrated by Simpson's rule at the two ends and the mid-point (§7.3); the normal stress
follows the pre-peak parabola and the z(D) softening curve (§7.5–7.6), the shear strength is
Mohr–Coulomb with a one-step lag stored per point (§7.7), damage is irreversible (the maximum
D is stored per point and unloading is linear towards the origin, the Y-Geo option of §7.8),
and the joint breaks for good when two of its three points have failed (§7.8).  A joint of a
prestressed body starts at the opening and slip of its law that carry the initial traction
σ⁰·n̂ (§7.11, :func:`taichi_fdem.sim.topology.prestress_offsets`).
"""
import taichi as ti

from . import fmath
from .groups import DT
from .groups import BROKEN, DAMAGED, EDGE_FREE, HANDOVER, INTACT, NB_PAIRS, TIME
from .tiutil import vec2

# Evans & Marathe softening fit (§7.5); Z_C an integer (z uses the integer power (1 − D)^Z_C)
Z_A, Z_B, Z_C = 0.63, 1.8, 6

#: default of ``Scene.build(handover_damage=...)``: the damage (at any of its three points) beyond
#: which a joint stops carrying its pair's compression and hands the pair over to contact
#: (:func:`handed_over`, docs/theory/joints.md §7.10): its first damage
HANDOVER_DAMAGE = 0.0

# failure modes recorded at breakage (§7.8)
MODE_I, MODE_II, MODE_I_II, MODE_MIXED = 1, 2, 3, 4
MODE_NAMES = {MODE_I: "I", MODE_II: "II", MODE_I_II: "I+II", MODE_MIXED: "mixed"}


@ti.func
def softening_z(D):
    """z(D): 1 at D = 0, 0 at D = 1, ∫₀¹ z dD = 0.3863 (§7.5)."""
    a = Z_A
    b = Z_B
    c = Z_C
    return (1.0 - ((a + b - 1.0) / (a + b)) * fmath.exp(D * (a + c * b) / ((a + b) * (1.0 - a - b)))) \
        * (a * (1.0 - D) + b * fmath.ipow(1.0 - D, ti.static(int(Z_C))))


@ti.func
def parabola(r):
    """Pre-peak hardening 2r − r² (r = displacement / displacement at peak)."""
    return 2.0 * r - r * r


#: columns of joint_prop that hold the initial offsets of a prestressed joint
#: (:func:`taichi_fdem.sim.topology.prestress_offsets`)
PRESTRESS_COL = 8


#: links (joints) of one fan tracked one bit each in an i32 mask (the sign bit unused)
FAN_BITS = 31
FAN_HEAD = 2           # tri_fans[0] = fans V, tri_fans[1] = joints J
FAN_ENTRY = 5          # (pair, arc 1, arc 2, A, B) per corner pair of a fan
FAN_JOINT = 3          # (fan code of end 0, of end 1, edge pair) per joint


@ti.func
def fan_mask_slot(v, step: ti.template()):
    """Index in tris.tri_nb_on of the link mask of fan v (after the neighbour pairs' flags)."""
    return step.step_int[NB_PAIRS] + v


@ti.func
def fan_joint_base(j, tris: ti.template()):
    """Where joint j's FAN_JOINT values start in tris.tri_fans (after the fans' entries)."""
    return tris.tri_fans[FAN_HEAD + tris.tri_fans[0]] + FAN_JOINT * j


@ti.func
def fan_code_bit(code):
    """(fan v, its mask bit) of a joint end's fan code v·32 + bit (code >= 0)."""
    return code >> 5, 1 << (code & 31)


@ti.func
def corner_bonded(m, arc1, arc2):
    """Is a corner pair with arcs arc1, arc2 of a fan whose mask is m still tied at its shared
    node by a chain of intact joints (:func:`taichi_fdem.sim.topology.fan_links`)?"""
    return (m & arc1) == 0 or (m & arc2) == 0


@ti.func
def switch_on_corners(v, m, tris: ti.template()):
    """Switch on (tri_nb_on = 1) every corner pair of fan v that the link mask m no longer
    bonds and that is not on yet, unless either triangle was removed."""
    k0 = tris.tri_fans[FAN_HEAD + v]
    for i in range((tris.tri_fans[FAN_HEAD + v + 1] - k0) // FAN_ENTRY):
        k = k0 + FAN_ENTRY * i
        if not corner_bonded(m, tris.tri_fans[k + 1], tris.tri_fans[k + 2]):
            if tris.tri_intact[tris.tri_fans[k + 3]] >= 0 and tris.tri_intact[tris.tri_fans[k + 4]] >= 0:
                if tris.tri_nb_on[tris.tri_fans[k]] == 0:     # (a pair already on keeps its NB_HELD bit)
                    tris.tri_nb_on[tris.tri_fans[k]] = 1


@ti.func
def switch_on_neighbours(j, a, b, edge_pair, tris: ti.template(), step: ti.template()):
    """Joint j, between triangles a and b, is damaged or broken: contact is evaluated from the
    next step on for the corner pairs that this cuts apart at the joint's two ends
    (:func:`taichi_fdem.sim.topology.fan_links`), and, with ``edge_pair`` (the joint has handed
    over, :func:`handed_over`), for the pair (a, b) itself, unless a triangle was removed.  The first time, the
    joint's bit goes into each end's fan mask with an atomic or, and the pairs are switched on
    from the mask that or returns, with the joint's bit; afterwards a read of the bit finds
    nothing to do.  Flags only ever go from 0 to 1 and the last joint of a step
    to set a bit in a fan sees every bit set before it, so the flags after the step do not
    depend on the order in which its joints do this (any thread count gives the same bits)."""
    if j < tris.tri_fans[1]:                 # no fans: a body without neighbour pairs
        base = fan_joint_base(j, tris)
        pe = tris.tri_fans[base + 2]
        if pe >= 0 and edge_pair:
            if tris.tri_nb_on[pe] == 0 and tris.tri_intact[a] >= 0 and tris.tri_intact[b] >= 0:
                tris.tri_nb_on[pe] = 1
        for end in ti.static(range(2)):
            code = tris.tri_fans[base + end]
            if code >= 0:
                v, bit = fan_code_bit(code)
                slot = fan_mask_slot(v, step)
                # only this joint sets this bit: once it is set, there is nothing left to do
                if (tris.tri_nb_on[slot] & bit) == 0:
                    m = ti.atomic_or(tris.tri_nb_on[slot], bit) | bit
                    switch_on_corners(v, m, tris)


@ti.func
def damaged_beyond(j, dh, joints: ti.template()):
    """Is joint j broken, or damaged beyond dh at one of its three points?"""
    dm = joints.joint_dmax[j]
    return joints.joint_state[j] != 0 or dm[0] > dh or dm[1] > dh or dm[2] > dh


@ti.func
def handed_over(j, joints: ti.template(), step: ti.template()):
    """Has joint j handed its pair over to contact: broken, or damaged beyond step_real[HANDOVER]
    (the ``handover_damage`` of ``Scene.build``) at one of its points?  Until then the joint
    carries the pair's compression (:func:`pair_carried`).  (The corner pairs around its ends
    are freed at its first damage, :func:`switch_on_neighbours`, so that no overlap builds
    between them while the joint still carries its pair.)"""
    return damaged_beyond(j, step.step_real[HANDOVER], joints)


@ti.func
def pair_carried(va, ea, vb, eb):
    """Is the pair of triangles A, B joined along their edges ea, eb by a joint that carries its
    compression alone (docs/theory/joints.md §7.10)?  va, vb: their ``tri_intact`` words.  True while both
    are bonded triangles of a fracturing body and the joint on that edge is undamaged; contact
    is not evaluated for such a pair (engine.contact.edge_pair_bonded), the joint adds the contact's
    share of the compression stiffness instead (:func:`carried_share`)."""
    return va >= INTACT and vb >= INTACT and (va & (EDGE_FREE << ea)) == 0 and (vb & (EDGE_FREE << eb)) == 0


@ti.func
def carried_share(j, L, joints: ti.template()):
    """(k_x, μ): the normal stiffness [Pa/m] that contact adds across joint j's edge of length L
    [m] when its two triangles overlap by a thin strip, and the pair's contact friction μ.  The
    potential φ = 3β of each triangle gives a traction 3 p o / h on each side, so
    k_x = 3 p (1/h_A + 1/h_B) = 3 p L (1/(2A_A) + 1/(2A_B)) with the rest areas; k_x / L and μ
    are per-joint constants, joint_prop[j][6] and [7] (taichi_fdem.sim.model); the contact kernel
    gives the same force and energy to the mesh's discretisation (tests/test_joined_pairs.py).  The carried
    joint also adds μ|σ_x| to its shear strength, as contact friction did on the pair's faces."""
    prop = joints.joint_prop[j]
    return prop[6] * L, prop[7]


@ti.func
def joint_frame(nd, nodes: ti.template()):
    """(L, ê, n̂, d0, d1, centre) of the joint with nodes nd (§7.2): its mean edge length [m], unit
    tangent and normal (n̂ points into A), the relative displacements d0 = x0 − x3 and
    d1 = x1 − x2 of its two node pairs [m], and the centre of its four nodes [m]."""
    x0, x1, x2, x3 = nodes.node_x[nd[0]], nodes.node_x[nd[1]], nodes.node_x[nd[2]], nodes.node_x[nd[3]]
    e = 0.5 * (x1 + x2 - x0 - x3)
    L = e.norm()
    eh = e / L
    return L, eh, vec2(-eh[1], eh[0]), x0 - x3, x1 - x2, 0.25 * (x0 + x1 + x2 + x3)


@ti.func
def carried_energy(kx, o0, om, o1, L):
    """Energy [J/m] held by the carried stiffness kx at the openings o0, om, o1 (ends and
    mid-point, negative in compression), by the joint's Simpson rule: (L/6) Σ w ½ kx min(o, 0)²."""
    c0 = ti.min(o0, 0.0)
    cm = ti.min(om, 0.0)
    c1 = ti.min(o1, 0.0)
    return (L / 6.0) * 0.5 * kx * (c0 * c0 + 4.0 * cm * cm + c1 * c1)


@ti.func
def joint_law(o, s, fs, dmax, zmax, ft, dp, dn, sp, ds):
    """The cohesive law at one integration point (§7.4–7.8), a pure function.

    o, s: the opening and slip the law sees [m]; fs: the point's shear strength [Pa]; dmax, zmax:
    its largest damage so far and z(dmax); ft: the tensile strength [Pa]; dp, dn: the opening at
    peak and the mode I softening span [m]; sp, ds: the slip at peak and the mode II softening
    span for fs [m].  Returns (σ, τ, D, dmax', zmax'): the normal stress [Pa] (tension
    positive; compression the linear penalty 2 f_t o / dp), the shear stress [Pa] (the sign of
    s), the damage D in [0, 1] (1: the point failed) and the updated damage history (unloading
    from a damaged state runs linearly towards the origin, §7.8)."""
    abss = ti.abs(s)
    D = 0.0
    if o > dp and abss > sp:
        D = ti.sqrt(((o - dp) / dn) ** 2 + ((abss - sp) / ds) ** 2)
    elif o > dp:
        D = (o - dp) / dn
    elif abss > sp:
        D = (abss - sp) / ds
    if D >= 1.0:
        D = 1.0
    z = 1.0                                   # z(0) = 1: no exp / pow while undamaged
    dmax_new = dmax
    zmax_new = zmax
    if D >= dmax:
        dmax_new = D
        if D > 0.0:
            z = softening_z(D)
        zmax_new = z
    else:
        z = zmax * (dp + D * dn) / (dp + dmax * dn)
    sigma = 0.0
    if o < 0.0:
        sigma = 2.0 * ft * o / dp             # compression: linear penalty p_f o / L
    elif o <= dp:
        sigma = parabola(o / dp) * z * ft
    else:
        sigma = z * ft
    tau = z * fs
    if abss <= sp:
        tau = parabola(abss / sp) * z * fs
    if s < 0.0:
        tau = -tau
    return sigma, tau, D, dmax_new, zmax_new


@ti.func
def joint_tractions(j, L, eh, nh, d0, d1, kx, mux, joints: ti.template()):
    """The tractions σ n̂ + τ ê [Pa] at joint j's three points (ends and mid-point, rows of a
    3×2 matrix) from the law (:func:`joint_law`) at the relative displacements d0, ½(d0 + d1),
    d1 of a joint of length L [m] and frame (ê, n̂); each point's damage history and its
    Mohr–Coulomb shear strength (lagged one step, §7.7) are updated in ``joints``.  kx [Pa/m],
    mux: the carried contact share (:func:`carried_share`, 0 unless carried), acting on the faces'
    overlap.  Returns (tractions, failed points, mean opening, mean slip) (the means as the law
    sees them, for the failure mode).

    When joint_prop has the PRESTRESS_COL offsets (a prestressed body, §7.11; a compile-time
    branch on the vector's width), the law, its damage and the failure mode see the faces'
    opening and slip plus the offsets (o⁰, s⁰) of each point; the carried share sees the faces'
    overlap alone."""
    dm = 0.5 * (d0 + d1)
    prop = joints.joint_prop[j]                   # (f_t, c, tan φ, G_I, G_II, p_f) of this joint
    ft, coh, tanphi, gI, gII, pf = prop[0], prop[1], prop[2], prop[3], prop[4], prop[5]
    dp = 2.0 * L * ft / pf                        # opening at peak (§7.4)
    dn = 3.0 * gI / ft                            # mode I softening span (Y-Geo)
    failed = 0
    dmax = joints.joint_dmax[j]
    zmax = joints.joint_zmax[j]                   # z(dmax), kept: no exp / pow while unloading
    fsv = joints.joint_fs[j]
    trac = ti.Matrix.zero(float, 3, 2)            # row p: traction σ n̂ + τ ê at point p [Pa]
    om = dm.dot(nh)
    sm = dm.dot(eh)
    if ti.static(prop.n > PRESTRESS_COL):         # a prestressed joint (compiled only then, §7.11)
        om += prop[PRESTRESS_COL + 2]
        sm += prop[PRESTRESS_COL + 3]
    dlist = [d0, dm, d1]
    for p in ti.static(range(3)):
        d = dlist[p]
        og = d.dot(nh)                            # the faces' opening; the law sees o = og + o⁰
        o = og
        s = d.dot(eh)
        if ti.static(prop.n > PRESTRESS_COL):
            o += prop[PRESTRESS_COL + 2 * p]
            s += prop[PRESTRESS_COL + 2 * p + 1]
        fs = fsv[p]
        sp = 2.0 * L * fs / pf                    # slip at peak
        ds = 3.0 * gII / fs                       # mode II softening span
        sigma, tau, D, dmax_p, zmax_p = joint_law(o, s, fs, dmax[p], zmax[p], ft, dp, dn, sp, ds)
        if D >= 1.0:
            failed += 1
        dmax[p] = dmax_p
        zmax[p] = zmax_p
        fsv[p] = ti.select(sigma > 0.0, coh, coh - sigma * tanphi)     # Mohr–Coulomb, lagged
        if og < 0.0:
            # the carried contact share (0 unless carried): its normal stress, and its
            # friction μ|σ_x| added to the shear strength, as contact friction gave before.
            # It acts on the faces' overlap og, as contact does once it takes the pair over
            sx = kx * og
            fsv[p] -= mux * sx
            sigma += sx
        t = sigma * nh + tau * eh
        trac[p, 0] = t[0]
        trac[p, 1] = t[1]
    joints.joint_dmax[j] = dmax
    joints.joint_zmax[j] = zmax
    joints.joint_fs[j] = fsv
    return trac, failed, om, sm


@ti.func
def break_joint(j, L, om, sm, centre, joints: ti.template(), step: ti.template()):
    """Joint j breaks for good (§7.8): its failure mode from the mean opening om and slip sm [m]
    (mode I when om passed the mode I span, mode II when sm passed the mode II span at the
    mid-point's shear strength, both, or mixed), the time and its centre [m] in joint_break, the
    count in step_int[BROKEN], and no more forces.  No re-detection is needed (§7.10): the pair
    is a neighbour pair, in the couple list for the whole run and evaluated since the joint's
    first damage."""
    prop = joints.joint_prop[j]
    ft, gI, gII, pf = prop[0], prop[3], prop[4], prop[5]
    dp = 2.0 * L * ft / pf
    dn = 3.0 * gI / ft
    fs_m = joints.joint_fs[j][1]
    mode = MODE_MIXED
    gI_done = om >= dp + dn
    sp_m = 2.0 * L * fs_m / pf
    gII_done = ti.abs(sm) >= sp_m + 3.0 * gII / fs_m
    if gI_done and gII_done:
        mode = MODE_I_II
    elif gI_done:
        mode = MODE_I
    elif gII_done:
        mode = MODE_II
    joints.joint_state[j] = mode                   # non-zero: broken, and how
    # (the fluid pressure, slot 3, is recorded by the fluid's phase of this step: −1 until then)
    joints.joint_break[j] = ti.Vector([step.step_real[TIME], centre[0], centre[1], -1.0], dt=float)
    ti.atomic_add(step.step_int[BROKEN], 1)
    joints.joint_g[j] = ti.Vector([0.0, 0.0, 0.0, 0.0], dt=float)


@ti.func
def joint_nodal_forces(j, nd, L, trac, nodes: ti.template(), joints: ti.template(), step: ti.template(),
                       scatter: ti.template()):
    """The nodal forces of joint j (nodes nd, length L [m]) from its point tractions ``trac``
    (:func:`joint_tractions`), by Simpson's rule with linear shape functions: g0 on the pair
    (j0, j3), g1 on (j1, j2), kept in joint_g (and added to node_f when ``scatter``); the half of
    their work over the step with the old velocities added to joint_work (the other half:
    :func:`add_joint_work`)."""
    # g_k = ∫ N_k t ds ≈ (L/6)(N_k(0) t0 + 4 N_k(½) tm + N_k(1) t1): end points L/6 and the
    # mid-point weight 4L/6 split ½–½ (L/3 on each pair; total L)
    t0 = vec2(trac[0, 0], trac[0, 1])
    tm = vec2(trac[1, 0], trac[1, 1])
    t1 = vec2(trac[2, 0], trac[2, 1])
    g0 = (L / 6.0) * (t0 + 2.0 * tm)          # on the pair (j0, j3)
    g1 = (L / 6.0) * (2.0 * tm + t1)          # on the pair (j1, j2)
    if ti.static(scatter):
        ti.atomic_add(nodes.node_f[nd[0]], -g0)
        ti.atomic_add(nodes.node_f[nd[1]], -g1)
        ti.atomic_add(nodes.node_f[nd[2]], g1)
        ti.atomic_add(nodes.node_f[nd[3]], g0)
    joints.joint_g[j] = ti.Vector([g0[0], g0[1], g1[0], g1[1]], dt=float)
    # work over the step, central estimate g·(x_{n+1} − x_{n−1})/2: the half with the old
    # velocities here, the half with the new ones in add_joint_work
    dv0 = nodes.node_v[nd[0]] - nodes.node_v[nd[3]]
    dv1 = nodes.node_v[nd[1]] - nodes.node_v[nd[2]]
    # (a plain read and write, not +=, which Taichi makes atomic in a parallel loop:
    # joint j is evaluated by one thread)
    joints.joint_work[j] = joints.joint_work[j] + 0.5 * (g0.dot(dv0) + g1.dot(dv1)) * step.step_real[DT]


@ti.func
def eval_joint(j, nodes: ti.template(), tris: ti.template(), mats: ti.template(), joints: ti.template(),
               step: ti.template(), scatter: ti.template()):
    """Forces of intact joint j (added to nodes.node_f when ``scatter``; always kept in
    joints.joint_g, which the parallel strategy gathers, and from which :func:`add_joint_work`
    books their work over the step); damage, shear strength and breakage updated.  A joint of a
    removed triangle (tri_intact < 0, an excavation) is skipped.  An undamaged joint of a bonded
    pair carries the contact's compression stiffness too (:func:`pair_carried`)."""
    jt0 = joints.joint_tris[j]
    if joints.joint_state[j] == 0 and tris.tri_intact[jt0[0]] >= 0 and tris.tri_intact[jt0[1]] >= 0:
        nd = joints.joint_nodes[j]
        L, eh, nh, d0, d1, centre = joint_frame(nd, nodes)      # nh points into A
        kx = 0.0
        mux = 0.0
        if pair_carried(tris.tri_intact[jt0[0]], jt0[2], tris.tri_intact[jt0[1]], jt0[3]):
            kx, mux = carried_share(j, L, joints)
        trac, failed, om, sm = joint_tractions(j, L, eh, nh, d0, d1, kx, mux, joints)
        if failed >= 2:
            break_joint(j, L, om, sm, centre, joints, step)
        else:
            joint_nodal_forces(j, nd, L, trac, nodes, joints, step, scatter)


@ti.func
def add_joint_work(j, nodes: ti.template(), tris: ti.template(), mats: ti.template(), joints: ti.template(),
                   step: ti.template()):
    """Second half of the work done on joint j over the step (see :func:`eval_joint`) [J/m].

    Also, at the end of the step: from the joint's first damage, contact is evaluated for the
    corner pairs it cuts apart at its ends; once it hands its pair over (:func:`handed_over`:
    broken, or damaged beyond ``handover_damage``), its two triangles are marked DAMAGED and the
    joint's edge EDGE_FREE in both (``tri_intact`` bits), and contact is evaluated for the pair
    itself from the next step on (:func:`switch_on_neighbours`).  Marking it here, after
    every force of the step, keeps the serial and parallel strategies identical.  If the joint
    carried the pair's compression (:func:`pair_carried`), the energy its carried stiffness
    holds at the new positions is taken off its work: contact, which takes over at the next
    step with the same overlap, holds it from then on (the handover, docs/theory/joints.md §7.10).
    """
    if damaged_beyond(j, 0.0, joints):
        jt = joints.joint_tris[j]
        over = handed_over(j, joints, step)
        nd = joints.joint_nodes[j]
        ea = jt[2]
        eb = jt[3]
        va = tris.tri_intact[jt[0]]
        vb = tris.tri_intact[jt[1]]
        bits_a = (EDGE_FREE << ea) | DAMAGED
        bits_b = (EDGE_FREE << eb) | DAMAGED
        # only this joint sets these two edge bits (others may set other bits meanwhile: atomics)
        set_a = over and va >= INTACT and (va & bits_a) != bits_a
        set_b = over and vb >= INTACT and (vb & bits_b) != bits_b
        if set_a or set_b:
            if va >= INTACT and vb >= INTACT and pair_carried(va, ea, vb, eb):
                # it carried the pair until now: hand the carried energy over to contact
                L, _, nh, d0, d1, _ = joint_frame(nd, nodes)
                kx, _ = carried_share(j, L, joints)
                joints.joint_work[j] = joints.joint_work[j] - carried_energy(
                    kx, d0.dot(nh), (0.5 * (d0 + d1)).dot(nh), d1.dot(nh), L)
            if set_a:
                ti.atomic_or(tris.tri_intact[jt[0]], bits_a)
            if set_b:
                ti.atomic_or(tris.tri_intact[jt[1]], bits_b)
        switch_on_neighbours(j, jt[0], jt[1], over, tris, step)
    g = joints.joint_g[j]
    if g[0] != 0.0 or g[1] != 0.0 or g[2] != 0.0 or g[3] != 0.0:
        nd = joints.joint_nodes[j]
        dv0 = nodes.node_v[nd[0]] - nodes.node_v[nd[3]]
        dv1 = nodes.node_v[nd[1]] - nodes.node_v[nd[2]]
        joints.joint_work[j] = joints.joint_work[j] + 0.5 * (g[0] * dv0[0] + g[1] * dv0[1] + g[2] * dv1[0]
                                                             + g[3] * dv1[1]) * step.step_real[DT]

"""Cohesive joint elements: the combined single and smeared crack model (FDEM_SPEC §7).

A 4-node joint (j0, j1, j2, j3) sits on an interior edge shared by triangles A and B of a
fracturing body: j0→j1 is A's copy of the edge in A's counter-clockwise order, j3 and j2 are
B's copies of the nodes coincident with j0 and j1 (§7.1).  Opening o and sliding s are
integrated by Simpson's rule at the two ends and the mid-point (§7.3); the normal stress
follows the pre-peak parabola and the z(D) softening curve (§7.5–7.6), the shear strength is
Mohr–Coulomb with a one-step lag stored per point (§7.7), damage is irreversible (the maximum
D is stored per point and unloading is linear towards the origin, the Y-Geo option of §7.8),
and the joint breaks for good when two of its three points have failed (§7.8).
"""
import numpy as np
import taichi as ti

from .groups import BROKEN, DAMAGED, EDGE_FREE, INTACT, TIME
from .tiutil import vec2

# Evans & Marathe softening fit (§7.5)
Z_A, Z_B, Z_C = 0.63, 1.8, 6.0

# failure modes recorded at breakage (§7.8)
MODE_I, MODE_II, MODE_I_II, MODE_MIXED = 1, 2, 3, 4
MODE_NAMES = {MODE_I: "I", MODE_II: "II", MODE_I_II: "I+II", MODE_MIXED: "mixed"}


@ti.func
def softening_z(D):
    """z(D): 1 at D = 0, 0 at D = 1, ∫₀¹ z dD = 0.3863 (§7.5)."""
    a = Z_A
    b = Z_B
    c = Z_C
    return (1.0 - ((a + b - 1.0) / (a + b)) * ti.exp(D * (a + c * b) / ((a + b) * (1.0 - a - b)))) \
        * (a * (1.0 - D) + b * ti.pow(1.0 - D, c))


@ti.func
def parabola(r):
    """Pre-peak hardening 2r − r² (r = displacement / displacement at peak)."""
    return 2.0 * r - r * r


def initial_intact(tri_nodes, joint_nodes, joint_tris, carries, fracturing) -> np.ndarray:
    """tri_intact at the start (:data:`INTACT`; numpy arrays in, one i32 per triangle out).

    A bonded triangle of a fracturing body (``fracturing``) is INTACT, with EDGE_FREE << e for
    each edge e that has no joint, or whose pair has no contact couple (``carries`` False: a body
    without self-contact, or with every node prescribed), so that its joint has no contact share
    to carry.  While two triangles are intact, the joint between them carries the pair and
    contact is not evaluated for it (:func:`pair_carried`).  0 for every other triangle.
    """
    has_joint = np.zeros((len(tri_nodes), 3), bool)
    for side, (p, q) in enumerate(((0, 1), (2, 3))):
        t = joint_tris[:, side]
        v = tri_nodes[t]
        lone = ~((v == joint_nodes[:, p:p + 1]) | (v == joint_nodes[:, q:q + 1]))     # the vertex off the joint
        has_joint[t, (np.argmax(lone, axis=1) + 1) % 3] = True
    has_joint &= np.asarray(carries, bool)[:, None]
    bits = ((EDGE_FREE << np.arange(3))[None, :] * ~has_joint).sum(axis=1)
    return np.where(fracturing, INTACT + bits, 0).astype(np.int32)


def neighbour_pairs(tri_origin, eligible) -> tuple[np.ndarray, np.ndarray]:
    """The neighbour pairs of a model and each triangle's list of them (numpy in and out).

    Neighbour pairs are the pairs (A < B) of ``eligible`` triangles (bonded triangles of a
    fracturing, self-contacting body) that share an original node: edge neighbours (two shared
    nodes) and corner neighbours (one).  They are the first M entries of the couple list for the
    whole run, never detected, and contact is evaluated for one only once it is no longer bonded
    (``tris.tri_nb_on``, :func:`switch_on_neighbours`), so that the many bonded pairs of an
    unbroken mesh cost nothing per step.

    Returns (pairs (M × 2, sorted), tri_nb): tri_nb[t] (t < T) is where triangle t's list starts
    in tri_nb and tri_nb[T] where the lists end; a list holds two entries per pair of the
    triangle, the other triangle and 2 p + (1 for an edge neighbour), p the pair's index.
    """
    tri_origin = np.asarray(tri_origin)
    T = len(tri_origin)
    t = np.nonzero(np.asarray(eligible, bool))[0]
    pairs = np.zeros((0, 2), np.int64)
    shared = np.zeros(0, np.int64)
    if len(t) > 1:
        node = tri_origin[t].ravel()
        tri = np.repeat(t, 3)
        order = np.lexsort((tri, node))
        node, tri = node[order], tri[order]
        found = []
        for d in range(1, len(node)):          # d-th next incidence of the same original node
            same = node[:-d] == node[d:]
            if not same.any():
                break
            found.append(np.stack([tri[:-d][same], tri[d:][same]], axis=1))
        if found:
            cand = np.sort(np.concatenate(found), axis=1).astype(np.int64)
            key, shared = np.unique(cand[:, 0] * T + cand[:, 1], return_counts=True)
            pairs = np.stack([key // T, key % T], axis=1)
    M = len(pairs)
    code = 2 * np.arange(M) + (shared >= 2)
    owner = np.concatenate([pairs[:, 0], pairs[:, 1]])
    other = np.concatenate([pairs[:, 1], pairs[:, 0]])
    codes = np.concatenate([code, code])
    order = np.argsort(owner, kind="stable")
    counts = np.bincount(owner, minlength=T)
    tri_nb = np.empty(T + 1 + 4 * M, np.int64)
    tri_nb[0] = T + 1
    tri_nb[1:T + 1] = T + 1 + 2 * np.cumsum(counts)
    tri_nb[T + 1::2] = other[order]
    tri_nb[T + 2::2] = codes[order]
    return pairs.astype(np.int32), tri_nb.astype(np.int32)


@ti.func
def switch_on_neighbours(a, b, tris: ti.template()):
    """Triangles a and b, joined by a joint that has just been damaged, are no longer bonded:
    evaluate contact from the next step on for their corner neighbour pairs and for the pair
    (a, b) itself (:func:`neighbour_pairs`), unless either triangle was removed.  Only ever
    sets flags to 1, so the order in which the joints of a step do it does not matter."""
    for side in ti.static(range(2)):
        t = a
        u = b
        if ti.static(side == 1):
            t = b
            u = a
        k0 = tris.tri_nb[t]
        n = (tris.tri_nb[t + 1] - k0) // 2
        if tris.tri_intact[t] < 0:
            n = 0
        for i in range(n):
            q = tris.tri_nb[k0 + 2 * i]
            code = tris.tri_nb[k0 + 2 * i + 1]
            if ((code & 1) == 0 or q == u) and tris.tri_intact[q] >= 0:
                tris.tri_nb_on[code >> 1] = 1


@ti.func
def edge_between(n, p, q):
    """Index e of the edge of a triangle with vertices n (a 3-vector of node or original-node
    numbers) whose ends are p and q: the edge opposite the vertex that is neither (edge e runs
    from vertex e to vertex e + 1)."""
    r = 2
    if n[0] != p and n[0] != q:
        r = 0
    elif n[1] != p and n[1] != q:
        r = 1
    return (r + 1) % 3


@ti.func
def pair_carried(va, ea, vb, eb):
    """Is the pair of triangles A, B joined along their edges ea, eb by a joint that carries its
    compression alone (FDEM_SPEC §7.10)?  va, vb: their ``tri_intact`` words.  True while both
    are bonded triangles of a fracturing body and the joint on that edge is undamaged; contact
    is not evaluated for such a pair (engine.contact.is_bonded), the joint adds the contact's
    share of the compression stiffness instead (:func:`carried_share`)."""
    return va >= INTACT and vb >= INTACT and (va & (EDGE_FREE << ea)) == 0 and (vb & (EDGE_FREE << eb)) == 0


@ti.func
def carried_share(A, B, L, tris: ti.template(), mats: ti.template()):
    """(k_x, μ): the normal stiffness [Pa/m] that contact adds across a joined edge of length L
    [m] when the two triangles overlap by a thin strip, and the pair's contact friction μ.  The
    potential φ = 3β of each triangle gives a traction 3 p o / h on each side, so
    k_x = 3 p (1/h_A + 1/h_B) = 3 p L (1/(2A_A) + 1/(2A_B)) with the rest areas
    (det F0⁻¹ = 1/(2A0)); measured against the contact kernel: within 0.3 % in force and energy
    (tests/test_joined_pairs.py).  The carried joint also adds μ|σ_x| to its shear strength, as
    contact friction did on the pair's faces."""
    prop = mats.mat_pair[tris.tri_mat[A], tris.tri_mat[B]]
    kx = 3.0 * prop[0] * L * (tris.tri_rest_inv[A].determinant() + tris.tri_rest_inv[B].determinant())
    return kx, prop[2]


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
def eval_joint(j, joints: ti.template(), tris: ti.template(), mats: ti.template(), nodes: ti.template(),
               step: ti.template(), scatter: ti.template()):
    """Forces of intact joint j (added to nodes.node_f when ``scatter``; always kept in
    joints.joint_g, which the parallel strategy gathers); damage, shear strength and breakage
    updated.

    A joint of a removed triangle (tri_intact < 0, an excavation) is skipped.

    The nodal forces g0 (on the pair j0/j3) and g1 (on j1/j2) are kept in joints.joint_g[j] so that
    :func:`add_joint_work` can book their work over the step with the new velocities.
    """
    jt0 = joints.joint_tris[j]
    if joints.joint_state[j] == 0 and tris.tri_intact[jt0[0]] >= 0 and tris.tri_intact[jt0[1]] >= 0:
        nd = joints.joint_nodes[j]
        L, eh, nh, d0, d1, centre = joint_frame(nd, nodes)      # nh points into A
        dm = 0.5 * (d0 + d1)
        # undamaged joint of a bonded pair: it carries the contact's compression stiffness too
        A = jt0[0]
        B = jt0[1]
        kx = 0.0
        mux = 0.0
        if pair_carried(tris.tri_intact[A], edge_between(tris.tri_nodes[A], nd[0], nd[1]),
                        tris.tri_intact[B], edge_between(tris.tri_nodes[B], nd[2], nd[3])):
            kx, mux = carried_share(A, B, L, tris, mats)
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
        dlist = [d0, dm, d1]
        for p in ti.static(range(3)):
            d = dlist[p]
            o = d.dot(nh)
            s = d.dot(eh)
            fs = fsv[p]
            sp = 2.0 * L * fs / pf                    # slip at peak
            ds = 3.0 * gII / fs                       # mode II softening span
            abss = ti.abs(s)
            D = 0.0
            if o > dp and abss > sp:
                D = ti.sqrt(((o - dp) / dn) ** 2 + ((abss - sp) / ds) ** 2)
            elif o > dp:
                D = (o - dp) / dn
            elif abss > sp:
                D = (abss - sp) / ds
            if D >= 1.0:
                failed += 1
                D = 1.0
            z = 1.0                                   # z(0) = 1: no exp / pow while undamaged
            if D >= dmax[p]:
                dmax[p] = D
                if D > 0.0:
                    z = softening_z(D)
                zmax[p] = z
            else:                                     # unloading from a damaged state (§7.8)
                z = zmax[p] * (dp + D * dn) / (dp + dmax[p] * dn)
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
            fsv[p] = ti.select(sigma > 0.0, coh, coh - sigma * tanphi)     # Mohr–Coulomb, lagged
            if o < 0.0:
                # the carried contact share (0 unless carried): its normal stress, and its
                # friction μ|σ_x| added to the shear strength, as contact friction gave before
                sx = kx * o
                fsv[p] -= mux * sx
                sigma += sx
            t = sigma * nh + tau * eh
            trac[p, 0] = t[0]
            trac[p, 1] = t[1]
        joints.joint_dmax[j] = dmax
        joints.joint_zmax[j] = zmax
        joints.joint_fs[j] = fsv
        if failed >= 2:
            # broken for good: record when, where and how (§7.8).  No re-detection is needed
            # (§7.10): the pair is a neighbour pair, in the couple list for the whole run and
            # evaluated since the joint's first damage (forcing a detection at every break made
            # ~340 of the 351 detections of benchmarks/fracture.py, measured)
            mode = MODE_MIXED
            gI_done = om >= dp + dn
            sp_m = 2.0 * L * fsv[1] / pf
            gII_done = ti.abs(sm) >= sp_m + 3.0 * gII / fsv[1]
            if gI_done and gII_done:
                mode = MODE_I_II
            elif gI_done:
                mode = MODE_I
            elif gII_done:
                mode = MODE_II
            joints.joint_state[j] = mode                   # non-zero: broken, and how
            joints.joint_break[j] = ti.Vector([step.step_real[TIME], centre[0], centre[1]], dt=float)
            ti.atomic_add(step.step_int[BROKEN], 1)
            joints.joint_g[j] = ti.Vector([0.0, 0.0, 0.0, 0.0], dt=float)
        else:
            # Simpson with linear shape functions: g_k = ∫ N_k t ds ≈ (L/6)(N_k(0) t0 + 4 N_k(½) tm + N_k(1) t1),
            # i.e. end points L/6 and the mid-point weight 4L/6 split ½–½ (L/3 on each pair; total L)
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
            joints.joint_work[j] = joints.joint_work[j] + 0.5 * (g0.dot(dv0) + g1.dot(dv1)) * step.step_dt[None]


@ti.func
def add_joint_work(j, joints: ti.template(), tris: ti.template(), mats: ti.template(), nodes: ti.template(),
                   step: ti.template()):
    """Second half of the work done on joint j over the step (see :func:`eval_joint`) [J/m].

    Also, at the end of the step: once the joint has any damage (or is broken), its two
    triangles are marked DAMAGED and the joint's edge EDGE_FREE in both (``tri_intact`` bits);
    from the next step on, contact is evaluated for the pair itself and for their couples with
    corner neighbours (:func:`taichi_fdem.engine.contact.is_bonded`).  Marking it here, after
    every force of the step, keeps the serial and parallel strategies identical.  If the joint
    carried the pair's compression (:func:`pair_carried`), the energy its carried stiffness
    holds at the new positions is taken off its work: contact, which takes over at the next
    step with the same overlap, holds it from then on (the handover, FDEM_SPEC §7.10).
    """
    dm = joints.joint_dmax[j]
    if joints.joint_state[j] != 0 or dm[0] > 0.0 or dm[1] > 0.0 or dm[2] > 0.0:
        jt = joints.joint_tris[j]
        nd = joints.joint_nodes[j]
        ea = edge_between(tris.tri_nodes[jt[0]], nd[0], nd[1])
        eb = edge_between(tris.tri_nodes[jt[1]], nd[2], nd[3])
        va = tris.tri_intact[jt[0]]
        vb = tris.tri_intact[jt[1]]
        bits_a = (EDGE_FREE << ea) | DAMAGED
        bits_b = (EDGE_FREE << eb) | DAMAGED
        # only this joint sets these two edge bits (others may set other bits meanwhile: atomics)
        set_a = va >= INTACT and (va & bits_a) != bits_a
        set_b = vb >= INTACT and (vb & bits_b) != bits_b
        if set_a or set_b:
            if va >= INTACT and vb >= INTACT and pair_carried(va, ea, vb, eb):
                # it carried the pair until now: hand the carried energy over to contact
                L, _, nh, d0, d1, _ = joint_frame(nd, nodes)
                kx, _ = carried_share(jt[0], jt[1], L, tris, mats)
                joints.joint_work[j] = joints.joint_work[j] - carried_energy(
                    kx, d0.dot(nh), (0.5 * (d0 + d1)).dot(nh), d1.dot(nh), L)
            if set_a:
                ti.atomic_or(tris.tri_intact[jt[0]], bits_a)
            if set_b:
                ti.atomic_or(tris.tri_intact[jt[1]], bits_b)
            switch_on_neighbours(jt[0], jt[1], tris)
    g = joints.joint_g[j]
    if g[0] != 0.0 or g[1] != 0.0 or g[2] != 0.0 or g[3] != 0.0:
        nd = joints.joint_nodes[j]
        dv0 = nodes.node_v[nd[0]] - nodes.node_v[nd[3]]
        dv1 = nodes.node_v[nd[1]] - nodes.node_v[nd[2]]
        joints.joint_work[j] = joints.joint_work[j] + 0.5 * (g[0] * dv0[0] + g[1] * dv0[1] + g[2] * dv1[0]
                                                             + g[3] * dv1[1]) * step.step_dt[None]

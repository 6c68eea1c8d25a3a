"""Narrow phase: the distributed potential contact force between two triangles.

Implements docs/theory/contact.md §2.3 (edge-by-edge discretisation of the book's eqs. 2.25–2.29) with
Coulomb friction (§5.1, dimensionally clean variant) and optional normal contact damping
(§5.2).  A couple (A, B) is resolved in two passes, contactor B against target A and then
contactor A against target B; every contactor edge is clipped against the target, loaded by
the target's piecewise-linear potential φ_T = 3 min_k β_k (integrated in closed form), and the
reaction goes to the target nodes through the target's affine shape functions evaluated at
the contactor nodes, so that force and moment are conserved to round-off.
"""
import taichi as ti

from .groups import DT, SWITCHES
from .groups import INTACT, NB_HELD, NB_PAIRS, SWITCH_CDAMPING, WORK_CDAMPING, WORK_FRICTION
from .joints import pair_carried
from .tiutil import mat32_rows, vec2, vec3


# Tolerance in barycentric space (values are O(1)), docs/theory/index.md §9.2.  Chosen per precision at
# compile time: the kernel cache is keyed by the default float type, so this stays consistent.
EPS = {"f64": 1e-10, "f32": 1e-6}


def _eps():
    from .. import backend
    return EPS[backend.precision()]


@ti.func
def perp(d):
    """(d_y, −d_x): outward normal of a CCW edge with direction d, ``|perp(d)| = |d|``."""
    return vec2(d[1], -d[0])


@ti.func
def barycentric(P, t0, t1, t2, inv2A):
    """β_k(P) = ((t_k − P)·m_k)/(2A), k = 0,1,2 (§2.2); β_k is the shape function of vertex k+2."""
    return vec3((t0 - P).dot(perp(t1 - t0)), (t1 - P).dot(perp(t2 - t1)), (t2 - P).dot(perp(t0 - t2))) * inv2A


@ti.func
def fmin(x, y):
    """min(x, y) as a select: one minsd on x86 (ti.min is IEEE minNum, which LLVM lowers to a
    compare, a min and a blend for its NaN rule; no NaN reaches here, the guards stop the run
    at the first non-finite value)."""
    return ti.select(x < y, x, y)


@ti.func
def fmax(x, y):
    """max(x, y) as a select (see :func:`fmin`)."""
    return ti.select(x > y, x, y)


@ti.func
def min3(v):
    return fmin(v[0], fmin(v[1], v[2]))


@ti.func
def edge_integrals(a, b, ci, cj, t0, t1, t2, inv2Ac):
    """Clip contactor edge ci→cj against the target and integrate its potential (§2.3.1, 1–6).

    a, b: target barycentrics of ci and cj.  Returns (Φ0, Φ1, s_min, s_max, s̄) with
    Φ0 = ∫ φ_T ds, Φ1 = ∫ s φ_T ds over s ∈ [0, 1]; Φ0 = 0 when there is no overlap.
    """
    eps = ti.static(_eps())
    Phi0 = 0.0
    Phi1 = 0.0
    smin = 0.0
    smax = 1.0
    sbar = 0.5
    # 2.ii first (it reuses a, b): both end points outside the same target edge (also rejects
    # shared edges); then 2.i: the target's vertices relative to the line of the edge
    reject = False
    for k in ti.static(range(3)):
        if a[k] < eps and b[k] < eps:
            reject = True
    if not reject:
        ne = perp(cj - ci)
        g0 = (ci - t0).dot(ne) * inv2Ac
        g1 = (ci - t1).dot(ne) * inv2Ac
        g2 = (ci - t2).dot(ne) * inv2Ac
        reject = (g0 > -eps and g1 > -eps and g2 > -eps) or (g0 < eps and g1 < eps and g2 < eps)
    if not reject:
        # 3. clipping to the target
        for k in ti.static(range(3)):
            if a[k] < 0.0 and b[k] > eps:
                smin = fmax(smin, a[k] / (a[k] - b[k]))
            if a[k] > eps and b[k] < 0.0:
                smax = fmin(smax, a[k] / (a[k] - b[k]))
        if smax > smin:
            # 4. breakpoints where the minimum switches (at most 2 inside the clipped span).  None
            # when one β is the least at both ends (two of three integrated edges in a pile): the
            # minimum of three lines is concave, so on the span it lies on or above its chord,
            # which is that β, and at or below that β, so it is that β all along.  (A runtime
            # loop: one copy of the search, skipped then.)
            d = b - a
            s1 = smax
            s2 = smax
            p0 = a + smin * d
            p3 = a + smax * d
            same = (p0[0] <= p0[1] and p0[0] <= p0[2] and p3[0] <= p3[1] and p3[0] <= p3[2]) or \
                   (p0[1] < p0[0] and p0[1] <= p0[2] and p3[1] < p3[0] and p3[1] <= p3[2]) or \
                   (p0[2] < p0[0] and p0[2] < p0[1] and p3[2] < p3[0] and p3[2] < p3[1])
            for kl in range(0 if same else 3):
                k = kl
                l = (kl + 1) % 3
                m = (kl + 2) % 3
                den = d[k] - d[l]
                if ti.abs(den) > eps:
                    s = (a[l] - a[k]) / den
                    if smin < s < smax and a[k] + s * d[k] < a[m] + s * d[m]:
                        if s < s1:
                            s2 = s1
                            s1 = s
                        elif s < s2:
                            s2 = s
            # 5–6. φ is linear between smin ≤ s1 ≤ s2 ≤ smax: exact closed-form integrals
            q0 = 3.0 * min3(p0)
            q1 = 3.0 * min3(a + s1 * d)
            q2 = 3.0 * min3(a + s2 * d)
            q3 = 3.0 * min3(p3)
            h0 = s1 - smin
            h1 = s2 - s1
            h2 = smax - s2
            Phi0 = 0.5 * (h0 * (q0 + q1) + h1 * (q1 + q2) + h2 * (q2 + q3))
            Phi1 = (h0 * (q0 * (2.0 * smin + s1) + q1 * (smin + 2.0 * s1))
                    + h1 * (q1 * (2.0 * s1 + s2) + q2 * (s1 + 2.0 * s2))
                    + h2 * (q2 * (2.0 * s2 + smax) + q3 * (s2 + 2.0 * smax))) / 6.0
            sbar = (smin + s1 + s2 + smax) * 0.25
    return Phi0, Phi1, smin, smax, sbar


@ti.func
def release_slip(hist: ti.template(), k, kt):
    """Reset the elastic slip of a contactor edge that left the target.  The energy its
    friction spring held, ½ k_t s², leaves the model with it; it is returned, to be booked as
    friction work so that the energy account stays closed."""
    s = hist[k]
    w = 0.0
    if s != 0.0:
        w = 0.5 * kt * s * s
        hist[k] = 0.0
    return w


@ti.func
def rel_velocity(s, a, b, W, ui, uj):
    """Target velocity minus contactor-edge velocity at the point P(s) = (1 − s) c_i + s c_j of
    edge i→j (§5.1 steps 1–2): a, b are the target barycentrics of c_i, c_j, W the target's node
    velocities (rows), ui, uj those of the edge's nodes [m/s]."""
    Nq = (1.0 - s) * a + s * b                    # β_k(P): shape function of vertex k+2
    vT = Nq[1] * vec2(W[0, 0], W[0, 1]) + Nq[2] * vec2(W[1, 0], W[1, 1]) + Nq[0] * vec2(W[2, 0], W[2, 1])
    return vT - ((1.0 - s) * ui + s * uj)


@ti.func
def edge_friction(i, a, b, W, ui, uj, te, L, sbar, Phi0, p, kt, mu, dt, hist: ti.template(), hslot, wf):
    """The friction force of contactor edge i (direction te, length L [m], potential integral
    Phi0) on its nodes i and i + 1 [N/m], and the friction work wf [J/m] plus what this slip
    dissipates: dimensionally clean elastic–plastic Coulomb friction (§5.1).  The relative
    velocity is taken at the representative point P(s̄) and the force acts there (split 1 − s̄,
    s̄ on the edge's nodes, and through the barycentrics a, b on the target), so that its power
    is exactly F_t v_rel·t̂.  ``hist[hslot + i]``: the edge's elastic slip [m], updated."""
    vrel = rel_velocity(sbar, a, b, W, ui, uj)
    that = te / L
    s_old = hist[hslot + i]
    slip = s_old + vrel.dot(that) * dt
    Ft = kt * slip
    Fcap = mu * p * Phi0 * L
    if ti.abs(Ft) > Fcap:
        Fs = ti.math.sign(Ft) * Fcap
        # dissipated: the plastic slip times the mean of the spring forces at the start and the
        # end of the increment (the central-difference work of the friction force less the
        # change of its spring's energy)
        wf += 0.5 * (kt * s_old + Fs) * (slip - Fs / kt)
        Ft = Fs
        slip = Fs / kt
    hist[hslot + i] = slip
    wi = 1.0 - sbar
    return (Ft * wi) * that, (Ft * (1.0 - wi)) * that, wf


@ti.func
def edge_damping(a, b, W, ui, uj, n, L, smin, smax, cn, dt, wc):
    """The normal viscous traction c_n ḋ on the clipped span [smin, smax] of a contactor edge
    (outward normal n, length L [m]), acting at (and its rate taken at) the span's mid-point
    (§5.2): the forces on the edge's two nodes [N/m], and the contact-damping work wc [J/m] plus
    this step's."""
    vrel = rel_velocity(0.5 * (smin + smax), a, b, W, ui, uj)
    nhat = n / L
    rate = -vrel.dot(nhat)                # penetration rate ḋ [m/s]
    span = (smax - smin) * L
    Fd = cn * rate * span
    wd = 1.0 - 0.5 * (smin + smax)
    wc += cn * rate * rate * span * dt
    return -(Fd * wd) * nhat, -(Fd * (1.0 - wd)) * nhat, wc


@ti.func
def contact_pass(C, U, T, W, inv2Ac, inv2At, p, kt, mu, cn, dt, hist: ti.template(), hslot, friction: ti.template(),
                 cdamping):
    """One pass: contactor triangle C against target triangle T (§2.3.2 CONTACT_PASS).

    C, T: 3×2 matrices of node positions (row r = node r) [m]; U, W: their node velocities
    [m/s] (used with friction or contact damping only); inv2Ac, inv2At: 1/(2A) of C and T
    [1/m²] (computed once per couple, for both passes).  Returns (gC, gT), the 3×2 nodal
    forces per unit thickness [N/m] on contactor and target, and the work dissipated over the
    step (friction, contact damping) [J/m] as a 2-vector.  ``hist[hslot + i]`` holds the elastic
    slip [m] of contactor edge i.
    """
    t0 = vec2(T[0, 0], T[0, 1])
    t1 = vec2(T[1, 0], T[1, 1])
    t2 = vec2(T[2, 0], T[2, 1])
    Bm = ti.Matrix.zero(float, 3, 3)          # row r: target barycentrics of contactor node r
    for r in ti.static(range(3)):
        br = barycentric(vec2(C[r, 0], C[r, 1]), t0, t1, t2, inv2At)
        Bm[r, 0], Bm[r, 1], Bm[r, 2] = br[0], br[1], br[2]
    gC = ti.Matrix.zero(float, 3, 2)
    wf = 0.0                                  # friction work [J/m]
    wc = 0.0                                  # contact-damping work [J/m]
    # the whole contactor outside one target edge line: no edge can touch (exact early out;
    # it is what most couples of a jointed mesh are, and fragments drifting apart)
    eps = ti.static(_eps())
    outside = False
    for k in ti.static(range(3)):
        if Bm[0, k] < eps and Bm[1, k] < eps and Bm[2, k] < eps:
            outside = True
    if outside:
        if ti.static(friction):
            for i in ti.static(range(3)):
                wf += release_slip(hist, hslot + i, kt)
    for i in range(0 if outside else 3):      # a runtime loop: one copy of the edge code
        j = (i + 1) % 3
        a = vec3(Bm[i, 0], Bm[i, 1], Bm[i, 2])
        b = vec3(Bm[j, 0], Bm[j, 1], Bm[j, 2])
        ci = vec2(C[i, 0], C[i, 1])
        cj = vec2(C[j, 0], C[j, 1])
        Phi0, Phi1, smin, smax, sbar = edge_integrals(a, b, ci, cj, t0, t1, t2, inv2Ac)
        if Phi0 > 0.0:
            te = cj - ci
            n = perp(te)                     # outward normal, |n| = L
            Fni = p * (Phi0 - Phi1)          # §2.3.1 step 7
            Fnj = p * Phi1
            gi = -Fni * n
            gj = -Fnj * n
            use_v = cdamping
            if ti.static(friction):
                use_v = 1
            if use_v != 0:
                ui = vec2(U[i, 0], U[i, 1])
                uj = vec2(U[j, 0], U[j, 1])
                L = te.norm()
                if ti.static(friction):
                    fi, fj, wf = edge_friction(i, a, b, W, ui, uj, te, L, sbar, Phi0, p, kt, mu, dt, hist, hslot, wf)
                    gi += fi
                    gj += fj
                if cdamping != 0:
                    di, dj, wc = edge_damping(a, b, W, ui, uj, n, L, smin, smax, cn, dt, wc)
                    gi += di
                    gj += dj
            gC[i, 0] += gi[0]
            gC[i, 1] += gi[1]
            gC[j, 0] += gj[0]
            gC[j, 1] += gj[1]
        else:
            if ti.static(friction):
                wf += release_slip(hist, hslot + i, kt)   # [Recommended] reset slip when the edge leaves
    # step 9: reaction on the target through N_q(c_r) = β_{q+1}(c_r)
    gT = ti.Matrix.zero(float, 3, 2)
    for q in ti.static(range(3)):
        for r in ti.static(range(3)):
            N = Bm[r, (q + 1) % 3]
            gT[q, 0] -= gC[r, 0] * N
            gT[q, 1] -= gC[r, 1] * N
    return gC, gT, vec2(wf, wc)


@ti.func
def boxes_overlap(a0, a1, a2, b0, b1, b2):
    """Cheap pre-check: do the axis-aligned boxes of the two triangles overlap?"""
    amin = fmin(a0, fmin(a1, a2))
    amax = fmax(a0, fmax(a1, a2))
    bmin = fmin(b0, fmin(b1, b2))
    bmax = fmax(b0, fmax(b1, b2))
    return amin[0] < bmax[0] and bmin[0] < amax[0] and amin[1] < bmax[1] and bmin[1] < amax[1]


@ti.func
def box_gap(a0, a1, a2, b0, b1, b2):
    """(gap, extent): the gap between the axis-aligned boxes of the two triangles along x or y
    [m], negative when the boxes overlap (:func:`boxes_overlap`), else a lower bound of the
    distance between the triangles; and the larger side of A's box [m]."""
    amin = fmin(a0, fmin(a1, a2))
    amax = fmax(a0, fmax(a1, a2))
    bmin = fmin(b0, fmin(b1, b2))
    bmax = fmax(b0, fmax(b1, b2))
    gap = fmax(fmax(bmin[0] - amax[0], amin[0] - bmax[0]), fmax(bmin[1] - amax[1], amin[1] - bmax[1]))
    return gap, fmax(amax[0] - amin[0], amax[1] - amin[1])


@ti.func
def separation_certificate(a0, a1, a2, b0, b1, b2, rel):
    """−1 when the two counter-clockwise triangles overlap; else, with g their gap along the
    outward normal of the first of their six edges (A's, then B's) on or beyond whose line the
    other lies (a lower bound of their distance) and m = rel·``|e|`` a rounding margin relative to
    that edge: g − m when g > 2m, else 0.  The separating-axis test over the six edge normals,
    complete for two triangles in 2D (signs of (p − t0)·perp(t1 − t0), no division): apart, no
    contactor edge of either pass has a positive potential integral (a triangle on or beyond an
    edge line of the other meets it at most on that line, where the potential is zero).  Only a
    certificate costs a square root and a division.
    (A runtime loop over the six edges: one copy of the code, which keeps compile time down.)"""
    cert = -1.0
    for q in range(6):
        if cert < 0.0:
            t0, t1, t2, p0, p1, p2 = a0, a1, a2, b0, b1, b2
            if q >= 3:
                t0, t1, t2, p0, p1, p2 = b0, b1, b2, a0, a1, a2
            k = q % 3
            e0, e1 = t0, t1
            if k == 1:
                e0, e1 = t1, t2
            elif k == 2:
                e0, e1 = t2, t0
            n = perp(e1 - e0)
            d0 = (p0 - e0).dot(n)
            d1 = (p1 - e0).dot(n)
            d2 = (p2 - e0).dot(n)
            if d0 >= 0.0 and d1 >= 0.0 and d2 >= 0.0:
                cert = 0.0
                dmin = fmin(d0, fmin(d1, d2))            # g |e|
                n2 = n.norm_sqr()                        # |e|²
                if dmin > 2.0 * rel * n2:
                    cert = (dmin - rel * n2) / ti.sqrt(n2)
    return cert


@ti.func
def couple_certificate(a0, a1, a2, b0, b1, b2):
    """(cert, hit) of two counter-clockwise triangles: ``hit`` when they overlap (their boxes
    overlap and no separating edge normal, :func:`separation_certificate`), and ``cert`` > 0
    when they lie apart by more than a rounding margin: a lower bound of their distance less
    that margin (the gap of their boxes along x or y, else along a separating edge normal).
    Margins far above the rounding of a gap, relative to the triangle's size."""
    rel = ti.static(_eps()) * 100.0
    gap, ext = box_gap(a0, a1, a2, b0, b1, b2)
    cert = gap - rel * ext
    hit = False
    if gap < 0.0:
        cert = separation_certificate(a0, a1, a2, b0, b1, b2, rel)
        hit = cert < 0.0
    return cert, hit


@ti.func
def certified_apart(c, dacc, contact: ti.template()):
    """Is couple c certified apart at this step (``contact.couple_skip``, :func:`couple_forces`)?"""
    return dacc < contact.couple_skip[c]


@ti.func
def shared_vertices(oa, ob):
    """(count, ra, rb) for two triangles with original nodes oa and ob: how many nodes they share,
    and the last vertex of each that the other does not have (−1: none)."""
    count = 0
    ra = -1
    hit_b = ti.Vector([0, 0, 0])
    for i in ti.static(range(3)):
        found = False
        for k in ti.static(range(3)):
            if oa[i] == ob[k]:
                found = True
                hit_b[k] = 1
        if found:
            count += 1
        else:
            ra = i
    rb = -1
    for k in ti.static(range(3)):
        if hit_b[k] == 0:
            rb = k
    return count, ra, rb


@ti.func
def edge_pair_bonded(A, B, tris: ti.template()):
    """Is the pair (A, B) of a fracturing body two edge neighbours (two original nodes in common)
    held by their undamaged joint, so that contact is not evaluated for it (docs/theory/joints.md §7.10)?
    Read from the ``tri_intact`` bits (set at the end of a step,
    :func:`taichi_fdem.engine.joints.add_joint_work`).  While the joint on the shared edge is
    undamaged (:func:`taichi_fdem.engine.joints.pair_carried`) it adds the contact's compression
    stiffness 3p(1/h_A + 1/h_B) to its own (:func:`taichi_fdem.engine.joints.carried_share`): a
    thin overlap strip along the edge gives the same force and energy as the contact kernel
    (tests/test_joined_pairs.py), and at the first damage the joint hands the energy that stiffness
    holds over to contact, which takes the pair from the next step on.  False for corner
    neighbours (one original node in common), whose rule is the fans'
    (:func:`taichi_fdem.sim.topology.fan_links`): bonded while a chain of undamaged joints
    around the shared node still ties them, so the overlap two corners can build meanwhile is
    bounded by the joints' elastic compression o ~ σL/p_f and the contact energy that appears at
    the handover is of order p·o³/h per pair (a corner overlap has area ~o² and depth ~o)."""
    bonded = False
    va = tris.tri_intact[A]
    vb = tris.tri_intact[B]
    if va >= INTACT and vb >= INTACT:
        shared, ra, rb = shared_vertices(tris.tri_origin[A], tris.tri_origin[B])
        if shared == 2:
            bonded = pair_carried(va, (ra + 1) % 3, vb, (rb + 1) % 3)
    return bonded


@ti.func
def neighbour_flag(c, tris: ti.template(), step: ti.template(), fracture: ti.template()):
    """(is couple c a neighbour pair, its tri_nb_on word): a neighbour pair (one of the first
    step_int[NB_PAIRS] couples, fracture only) is evaluated only once that word is not 0 (no
    longer bonded); NB_HELD in it says the pair holds friction slip."""
    nb_pair = False
    on = 0
    if ti.static(fracture):
        nb_pair = c < step.step_int[NB_PAIRS]
        if nb_pair:
            on = tris.tri_nb_on[c]
    return nb_pair, on


@ti.func
def couple_velocities(na, nb, use_v, nodes: ti.template()):
    """(VA, VB): the node velocities [m/s] of triangles A (nodes na) and B (nb) as rows of 3×2
    matrices, read only when ``use_v`` (friction or contact damping), else zero."""
    VA = ti.Matrix.zero(float, 3, 2)
    VB = ti.Matrix.zero(float, 3, 2)
    if use_v != 0:
        for r in ti.static(range(3)):
            va = nodes.node_v[na[r]]
            vb = nodes.node_v[nb[r]]
            VA[r, 0], VA[r, 1] = va[0], va[1]
            VB[r, 0], VB[r, 1] = vb[0], vb[1]
    return VA, VB


@ti.func
def touching_forces(c, A, B, na, nb, a0, a1, a2, b0, b1, b2, nodes: ti.template(), tris: ti.template(),
                    mats: ti.template(), contact: ti.template(), step: ti.template(), friction: ti.template()):
    """(gA, gB, work) of touching couple c, triangles A, B (nodes na, nb at a0..a2, b0..b2): the two
    passes of §2.3.2, contactor B on target A, then contactor A on target B (a runtime loop: one
    copy of the pass code, which keeps compile time down)."""
    gA = ti.Matrix.zero(float, 3, 2)
    gB = ti.Matrix.zero(float, 3, 2)
    work = vec2(0.0, 0.0)
    prop = mats.mat_pair[tris.tri_mat[A], tris.tri_mat[B]]      # (p, k_t, μ_f, c_n)
    cdamping = step.step_int[SWITCHES] & SWITCH_CDAMPING
    dt = step.step_real[DT]
    XA = mat32_rows(a0, a1, a2)
    XB = mat32_rows(b0, b1, b2)
    use_v = cdamping
    if ti.static(friction):
        use_v = 1
    VA, VB = couple_velocities(na, nb, use_v, nodes)
    inv2A = 1.0 / (a1 - a0).cross(a2 - a0)
    inv2B = 1.0 / (b1 - b0).cross(b2 - b0)
    for ps in range(2):
        C, U, T, W, iC, iT = XB, VB, XA, VA, inv2B, inv2A
        if ps == 1:
            C, U, T, W, iC, iT = XA, VA, XB, VB, inv2A, inv2B
        gC, gT, w = contact_pass(C, U, T, W, iC, iT, prop[0], prop[1], prop[2], prop[3], dt,
                                 contact.couple_hist, c * 6 + 3 * ps, friction, cdamping)
        work += w
        if ps == 0:
            gB += gC
            gA += gT
        else:
            gA += gC
            gB += gT
    return gA, gB, work


@ti.func
def mark_held(c, on, tris: ti.template(), contact: ti.template()):
    """A touching neighbour pair's NB_HELD bit in its tri_nb_on word ``on``: whether it holds
    slip, so that the steps it spends apart need not read its history (written only when it
    changes)."""
    held = 0
    for s in ti.static(range(6)):
        if contact.couple_hist[c * 6 + s] != 0.0:
            held = NB_HELD
    if (on & NB_HELD) != held:
        tris.tri_nb_on[c] = (on & ~NB_HELD) | held


@ti.func
def release_couple_slip(c, A, B, nb_pair, on, work, tris: ti.template(), mats: ti.template(),
                        contact: ti.template()):
    """A couple found apart drops its slip and books the energy its springs held into work[0]
    (:func:`release_slip`, as a pass whose contactor is out); returns the work.  Written only
    where non-zero (most couples are apart); a neighbour pair holds slip only with its NB_HELD
    bit, so its history is read only then."""
    if not nb_pair or (on & NB_HELD) != 0:
        held = False
        for s in ti.static(range(6)):
            if contact.couple_hist[c * 6 + s] != 0.0:
                held = True
        if held:
            kt = mats.mat_pair[tris.tri_mat[A], tris.tri_mat[B]][1]
            for s in range(6):          # a runtime loop: one copy of the code
                work[0] += release_slip(contact.couple_hist, c * 6 + s, kt)
        if nb_pair:
            tris.tri_nb_on[c] = on & ~NB_HELD
    return work


@ti.func
def couple_forces(c, dacc, nodes: ti.template(), tris: ti.template(), mats: ti.template(), contact: ti.template(),
                  step: ti.template(), friction: ti.template(), fracture: ti.template()):
    """Contact forces of couple c (both passes, §2.3.2 COUPLE): (gA, gB, hit, work); gA, gB are
    3×2 matrices whose row r is the force [N/m] on node r of triangle A, B.  ``hit`` is False,
    and the forces zero, for a neighbour pair still bonded by intact joints
    (:func:`edge_pair_bonded`, :func:`taichi_fdem.sim.topology.fan_links`; kept up to date in
    ``tris.tri_nb_on``; fracture only), for pairs whose boxes do not overlap (the common cheap
    case), for pairs that lie apart (:func:`separation_certificate`), and for couples certified
    apart (below).  ``work``: the work dissipated over the step by friction and contact damping
    [J/m], which the caller books in step_real[WORK_FRICTION], step_real[WORK_CDAMPING].

    Certificates of separation (docs/theory/contact.md §4.1's bound, per couple): ``dacc`` is
    step_real[DACC] at the start of the step, which grows by at least the largest relative
    displacement of any two nodes.  A couple found apart with a gap g (between the boxes along x
    or y, or along a separating edge normal, :func:`separation_certificate`) stays apart while
    dacc grows by less than g: its ``contact.couple_skip[c]`` is set to dacc + g (less a rounding
    margin), and until dacc reaches it the couple is skipped for the cost of one read.  Skipping
    changes no bit: such a couple gives no force, and it released its slip (and cleared its
    NB_HELD bit) when it was found apart.  Detection resets the certificates with dacc, and the
    host at every launch of steps (positions may have been set in between)."""
    A = contact.couple_a[c]
    B = contact.couple_b[c]
    na = tris.tri_nodes[A]
    nb = tris.tri_nodes[B]
    a0, a1, a2 = nodes.node_x[na[0]], nodes.node_x[na[1]], nodes.node_x[na[2]]
    b0, b1, b2 = nodes.node_x[nb[0]], nodes.node_x[nb[1]], nodes.node_x[nb[2]]
    gA = ti.Matrix.zero(float, 3, 2)
    gB = ti.Matrix.zero(float, 3, 2)
    work = vec2(0.0, 0.0)
    nb_pair, on = neighbour_flag(c, tris, step, fracture)
    bonded = nb_pair and on == 0
    skip = bonded
    if not skip:
        skip = certified_apart(c, dacc, contact)
    hit = False
    if not skip:
        cert, hit = couple_certificate(a0, a1, a2, b0, b1, b2)
        if cert > 0.0:
            # apart: certified while dacc grows by less than the gap less its margin (written
            # only then: neighbours apart by less are tested every step and write nothing)
            contact.couple_skip[c] = dacc + cert
    if hit:
        gA, gB, work = touching_forces(c, A, B, na, nb, a0, a1, a2, b0, b1, b2, nodes, tris, mats, contact, step,
                                       friction)
        if ti.static(friction and fracture):
            if nb_pair:
                mark_held(c, on, tris, contact)
    elif ti.static(friction):
        # a bonded pair never slipped (bonds only end); a certified couple released its slip
        # when it was found apart
        if not skip:
            work = release_couple_slip(c, A, B, nb_pair, on, work, tris, mats, contact)
    return gA, gB, hit, work


@ti.func
def book_contact_work(work, step: ti.template()):
    """Add a couple's dissipated work (friction, contact damping) [J/m] to the step counters."""
    if work[0] != 0.0:
        ti.atomic_add(step.step_real[WORK_FRICTION], work[0])
    if work[1] != 0.0:
        ti.atomic_add(step.step_real[WORK_CDAMPING], work[1])


@ti.func
def eval_couple(c, dacc, nodes: ti.template(), tris: ti.template(), mats: ti.template(), contact: ti.template(),
                step: ti.template(), friction: ti.template(), fracture: ti.template()):
    """Add the contact forces of couple c (:func:`couple_forces`) to nodes.node_f (nothing to add
    for the many couples whose boxes do not overlap)."""
    gA, gB, hit, work = couple_forces(c, dacc, nodes, tris, mats, contact, step, friction, fracture)
    book_contact_work(work, step)
    if hit:
        na = tris.tri_nodes[contact.couple_a[c]]
        nb = tris.tri_nodes[contact.couple_b[c]]
        for r in ti.static(range(3)):
            ti.atomic_add(nodes.node_f[na[r]], vec2(gA[r, 0], gA[r, 1]))
            ti.atomic_add(nodes.node_f[nb[r]], vec2(gB[r, 0], gB[r, 1]))

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
import taichi as ti

from .groups import BROKEN, TIME
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
        x0, x1, x2, x3 = nodes.node_x[nd[0]], nodes.node_x[nd[1]], nodes.node_x[nd[2]], nodes.node_x[nd[3]]
        e = 0.5 * (x1 + x2 - x0 - x3)
        L = e.norm()
        eh = e / L
        nh = vec2(-eh[1], eh[0])                     # points into A
        d0 = x0 - x3
        d1 = x1 - x2
        dm = 0.5 * (d0 + d1)
        prop = joints.joint_prop[j]                   # (f_t, c, tan φ, G_I, G_II, p_f) of this joint
        ft, coh, tanphi, gI, gII, pf = prop[0], prop[1], prop[2], prop[3], prop[4], prop[5]
        dp = 2.0 * L * ft / pf                        # opening at peak (§7.4)
        dn = 3.0 * gI / ft                            # mode I softening span (Y-Geo)
        failed = 0
        dmax = joints.joint_dmax[j]
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
            else:                                     # unloading from a damaged state (§7.8)
                z = softening_z(dmax[p]) * (dp + D * dn) / (dp + dmax[p] * dn)
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
            t = sigma * nh + tau * eh
            trac[p, 0] = t[0]
            trac[p, 1] = t[1]
        joints.joint_dmax[j] = dmax
        joints.joint_fs[j] = fsv
        if failed >= 2:
            # broken for good: record when, where and how (§7.8).  No re-detection is needed
            # (§7.10): every triangle of a split body takes part in detection and joined
            # neighbours stay couples, so the pair is in the couple list already (forcing one at
            # every break made ~340 of the 351 detections of benchmarks/fracture.py, measured)
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
            c = 0.25 * (x0 + x1 + x2 + x3)
            joints.joint_break[j] = ti.Vector([step.step_real[TIME], c[0], c[1]], dt=float)
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
def add_joint_work(j, joints: ti.template(), tris: ti.template(), nodes: ti.template(), step: ti.template()):
    """Second half of the work done on joint j over the step (see :func:`eval_joint`) [J/m].

    Also, at the end of the step: once the joint has any damage (or is broken), its two
    triangles stop being ``intact``; from the next step on, contact is evaluated for their
    couples with corner neighbours (:func:`taichi_fdem.engine.contact.is_bonded`).  Marking it
    here, after every force of the step, keeps the serial and parallel strategies identical.
    """
    dm = joints.joint_dmax[j]
    if joints.joint_state[j] != 0 or dm[0] > 0.0 or dm[1] > 0.0 or dm[2] > 0.0:
        jt = joints.joint_tris[j]
        for k in ti.static(range(2)):
            if tris.tri_intact[jt[k]] > 0:         # (< 0: removed by an excavation, stays so)
                tris.tri_intact[jt[k]] = 0
    g = joints.joint_g[j]
    if g[0] != 0.0 or g[1] != 0.0 or g[2] != 0.0 or g[3] != 0.0:
        nd = joints.joint_nodes[j]
        dv0 = nodes.node_v[nd[0]] - nodes.node_v[nd[3]]
        dv1 = nodes.node_v[nd[1]] - nodes.node_v[nd[2]]
        joints.joint_work[j] = joints.joint_work[j] + 0.5 * (g[0] * dv0[0] + g[1] * dv0[1] + g[2] * dv1[0]
                                                             + g[3] * dv1[1]) * step.step_dt[None]

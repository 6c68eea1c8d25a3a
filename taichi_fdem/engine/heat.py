"""Heat conduction on the triangle mesh (docs/theory/heat.md §16), as Taichi kernels.

Temperatures live on the nodes (``heat.heat_temp``); each node copy of a fracturing body is a
node of its own.  One heat step advances them by the explicit (forward Euler) update of the
lumped system C dT/dt = Q − K T over the heat step Δt_h (``heat.heat_real[H_DT]``):

    T_i ← T_i + Δt_h / C_i · (Q_i − Σ_e K_e[a, :] T_e − Σ_p G_p (T_i − T_p)),

the sums running over the node's own list of terms (``heat.heat_adj``, built once by
:func:`taichi_fdem.sim.heat.build_heat`), so that each node gathers its terms in a fixed order
and no float atomics are needed: every strategy gives the same bits.  A list entry is coded
``index · 4 + kind``:

* kind :data:`ADJ_TRI`: triangle e at its local node a, index ``3 e + a`` (the row a of the
  triangle's conduction matrix K_e, ``heat.heat_tri[e][0:6]``; none once the triangle is
  excavated, ``tris.tri_intact[e] < 0``);
* kind :data:`ADJ_JOINT`: joint j at its node p = 0..3, index ``4 j + p``; the facing copy is
  node 3 − p of the joint (j0 faces j3, j1 faces j2) and the conductance G_p is
  :func:`joint_conductance`;
* kind :data:`ADJ_FLUX`: a flux row r (the node takes q A(t) ℓ of it, ℓ half the edge length);
* kind :data:`ADJ_HELD`: a held-temperature row r (the node ends the step at
  T₀ + A(t)(T_r − T₀), the heat this takes booked in ``heat.heat_supply[i][1]``).

A(t) is the row's curve (``nodes.curve_points``) at the end of the heat step.

With contact (``contact``, the model's ``heat_contact``), triangles that touch without sharing
a joint conduct too (docs/theory/heat.md §16.4): :func:`heat_contacts` gives each touching
couple its conductance G_c and contact point at the start of a heat update, and lists the
couples on each triangle (``heat.heat_ct``, sorted by the partner triangle, so the order is the
same for every strategy); each heat step then sums, per triangle, the heat its contacts bring
to its nodes (``heat.heat_tri_q``), which the nodes gather with their triangle terms.
"""
import taichi as ti

from .contact import barycentric, boxes_overlap, edge_integrals
from .elastic import tri_strain_energy
from .groups import COUPLES, NB_PAIRS
from .groups import HeatGroup, HeatStepGroup, MaterialGroup, NodeGroup, StepGroup, TriGroup
from .loads import curve_value
from .tiutil import vec2, vec3

ADJ_TRI, ADJ_JOINT, ADJ_FLUX, ADJ_HELD = 0, 1, 2, 3
ROW_TEMPERATURE, ROW_FLUX = 0, 1

# slots of heat.heat_real and heat.heat_int (engine.arrays)
H_TIME, H_DT, H_SUB, H_EVERY, H_DT_CONTACT = 0, 1, 2, 3, 4
H_SINCE, H_UPDATES = 0, 1

#: conductance of an intact joint, and of a closed contact, per unit length, in units of k̄ / h̄
#: (k̄ the harmonic mean of the conductivities of the two triangles, h̄ the smaller of their
#: smallest altitudes): large against the elements' own, so that its thermal resistance is
#: about 1 % of theirs (docs/theory/heat.md §16.4)
JOINT_CONDUCTANCE_FACTOR = 100.0
#: overlap at which a broken joint or a contact conducts fully: in units of the joint's rest
#: length for a joint, of h̄ for a contact (docs/theory/heat.md §16.4)
CONTACT_OVERLAP_REF = 1.0e-3


@ti.func
def joint_conductance(j, end, nodes: ti.template(), joints: ti.template(), heat: ti.template()):
    """Conductance [W/(m·K)] between the facing node copies of joint j at its end ``end`` (0: j0
    and j3, 1: j1 and j2), docs/theory/heat.md §16.4: G₀ z of the end while the joint is intact (z the
    softening factor of its largest opening, 1 undamaged); once broken, G₀ min(1, δ / δ_c) for an
    overlap δ > 0 of the two copies normal to face A (δ_c = heat_joint[j][1]), 0 apart."""
    g = heat.heat_joint[j]
    G = 0.0
    if joints.joint_state[j] == 0:
        G = g[0] * joints.joint_zmax[j][2 * end]
    else:
        nd = joints.joint_nodes[j]
        a = nodes.node_x[nd[0]]
        t = nodes.node_x[nd[1]] - a
        L = t.norm()
        ia, ib = nd[0], nd[3]
        if end == 1:
            ia, ib = nd[1], nd[2]
        d = nodes.node_x[ib] - nodes.node_x[ia]
        opening = (d[0] * t[1] - d[1] * t[0]) / L           # along A's outward normal (t_y, −t_x) / L
        if opening < 0.0 and L > 0.0:
            G = g[0] * ti.min(1.0, -opening / g[1])
    return G


@ti.func
def node_rate(i, t, nodes: ti.template(), tris: ti.template(), joints: ti.template(), heat: ti.template(),
              contact: ti.template()):
    """(Q_i − (K T)_i [W/m], held row of node i or −1, flux part of Q_i [W/m]) at time t; with
    ``contact``, Q_i includes the heat the contacts of its triangles bring (heat_tri_q)."""
    Ti = heat.heat_temp[i]
    s = 0.0
    q = 0.0
    held = -1
    for k in range(heat.heat_adj[i], heat.heat_adj[i + 1]):
        code = heat.heat_adj[k]
        kind = code & 3
        idx = code >> 2
        if kind == ADJ_TRI:
            e = idx // 3
            if tris.tri_intact[e] >= 0:                     # (an excavated triangle conducts nothing)
                a = idx - 3 * e
                n = tris.tri_nodes[e]
                K = heat.heat_tri[e]
                # row a of the symmetric K_e stored as (00, 11, 22, 01, 12, 20)
                r0, r1, r2 = K[0], K[3], K[5]
                if a == 1:
                    r0, r1, r2 = K[3], K[1], K[4]
                elif a == 2:
                    r0, r1, r2 = K[5], K[4], K[2]
                s -= r0 * heat.heat_temp[n[0]] + r1 * heat.heat_temp[n[1]] + r2 * heat.heat_temp[n[2]]
                if ti.static(contact):
                    s += heat.heat_tri_q[e][a]
        elif kind == ADJ_JOINT:
            j = idx // 4
            p = idx - 4 * j
            end = 0
            if p == 1 or p == 2:
                end = 1
            other = joints.joint_nodes[j][3 - p]
            s -= joint_conductance(j, end, nodes, joints, heat) * (Ti - heat.heat_temp[other])
        elif kind == ADJ_FLUX:
            row = heat.heat_rows[idx]
            v = heat.heat_row_val[idx]
            q += v[0] * v[1] * curve_value(nodes.curve_points, row[3], row[4], t)
        else:
            held = idx
    return s + q, held, q


@ti.func
def heat_step(nodes: ti.template(), tris: ti.template(), joints: ti.template(), heat: ti.template(),
              contact: ti.template()):
    """One heat step of Δt_h = heat_real[H_DT] from heat_real[H_TIME] (module docstring): the new
    temperatures, the heat supplied per node, and the time advanced; with ``contact``, through
    the contacts :func:`heat_contacts` listed too."""
    if ti.static(contact):
        for e in range(tris.tri_nodes.shape[0]):
            heat.heat_tri_q[e] = contact_heat(e, tris, heat)
    for i in range(heat.heat_temp.shape[0]):
        dt = heat.heat_real[H_DT]
        t = heat.heat_real[H_TIME] + dt
        C = heat.heat_node[i][0]
        rate, held, q = node_rate(i, t, nodes, tris, joints, heat, contact)
        Tn = heat.heat_temp[i] + dt * rate / C
        sup = heat.heat_supply[i]
        sup[0] += dt * q
        if held >= 0:
            row = heat.heat_rows[held]
            T0 = heat.heat_node[i][1]
            Th = T0 + curve_value(nodes.curve_points, row[3], row[4], t) * (heat.heat_row_val[held][0] - T0)
            sup[1] += C * (Th - Tn)
            Tn = Th
        heat.heat_supply[i] = sup
        heat.heat_next[i] = Tn
    for i in range(heat.heat_temp.shape[0]):
        heat.heat_temp[i] = heat.heat_next[i]
    for _ in range(1):
        heat.heat_real[H_TIME] = heat.heat_real[H_TIME] + heat.heat_real[H_DT]


#: the most heat steps one launch of :func:`heat_substeps` runs
HEAT_STEPS_PER_LAUNCH = 8


@ti.kernel
def heat_substeps(h: HeatStepGroup, contact: ti.template(), k: ti.template()):
    """``k`` heat steps (:func:`heat_step`) in one launch, ``h`` serving as every group: the loops
    of each are the same parallel loops whatever ``k``, hence the same bits for any split of the
    steps into launches (k = 1, 2, 4, :data:`HEAT_STEPS_PER_LAUNCH`)."""
    for _ in ti.static(range(k)):
        heat_step(h, h, h, h, contact)


@ti.func
def tri_thermal_strain(e, heat: ti.template(), tris: ti.template()):
    """ε* = α*_e (T̄ − T̄₀) of triangle e (xx, yy, xy), T̄ the mean of its nodes' temperatures and
    T̄₀ of their initial ones, α*_e its effective expansion tensor (heat_tri[e][6:9])."""
    n = tris.tri_nodes[e]
    dT = (heat.heat_temp[n[0]] + heat.heat_temp[n[1]] + heat.heat_temp[n[2]]
          - heat.heat_node[n[0]][1] - heat.heat_node[n[1]][1] - heat.heat_node[n[2]][1]) / 3.0
    K = heat.heat_tri[e]
    return ti.Vector([K[6] * dT, K[7] * dT, K[8] * dT], dt=float)


@ti.kernel
def thermal_strain(nodes: NodeGroup, tris: TriGroup, mats: MaterialGroup, step: StepGroup, heat: HeatGroup,
                   feat: ti.template()):
    """Write each triangle's thermal strain ``tris.tri_thermal`` from the temperatures
    (:func:`tri_thermal_strain`) and add the change of its strain energy at the current geometry
    to ``heat.heat_tri_work`` (the thermal work, docs/theory/heat.md §16.6)."""
    for e in range(tris.tri_nodes.shape[0]):
        W0 = tri_strain_energy(e, nodes, tris, mats, step, feat)
        tris.tri_thermal[e] = tri_thermal_strain(e, heat, tris)
        W1 = tri_strain_energy(e, nodes, tris, mats, step, feat)
        heat.heat_tri_work[e] = heat.heat_tri_work[e] + (W1 - W0)


# ---- conduction through contacts (docs/theory/heat.md §16.4) -------------------------------------
@ti.func
def overlap_pass(c0, c1, c2, t0, t1, t2):
    """Contactor (c0, c1, c2) against target (t0, t1, t2): (ℓ, ∫φ_T dl, ∫x dl) over the parts of
    the contactor's edges inside the target (ℓ their length [m], φ_T the target's potential
    3 min β_k, x the position: ∫x dl / ℓ is their centroid)."""
    inv2At = 1.0 / (t1 - t0).cross(t2 - t0)
    inv2Ac = 1.0 / (c1 - c0).cross(c2 - c0)
    ell = 0.0
    phi = 0.0
    mid = vec2(0.0, 0.0)
    for i in ti.static(range(3)):
        ci = c0
        cj = c1
        if ti.static(i == 1):
            ci, cj = c1, c2
        if ti.static(i == 2):
            ci, cj = c2, c0
        a = barycentric(ci, t0, t1, t2, inv2At)
        b = barycentric(cj, t0, t1, t2, inv2At)
        Phi0, Phi1, smin, smax, sbar = edge_integrals(a, b, ci, cj, t0, t1, t2, inv2Ac)
        if Phi0 > 0.0:
            L = (cj - ci).norm()
            seg = (smax - smin) * L
            ell += seg
            phi += Phi0 * L
            mid += (ci + (cj - ci) * (0.5 * (smin + smax))) * seg
    return ell, phi, mid


@ti.func
def contact_weights(P, t0, t1, t2):
    """The weights of point P on the nodes of triangle (t0, t1, t2): its shape functions at P,
    clipped to [0, 1] and scaled to sum 1 (P may lie just outside)."""
    beta = barycentric(P, t0, t1, t2, 1.0 / (t1 - t0).cross(t2 - t0))
    w = vec3(ti.max(beta[1], 0.0), ti.max(beta[2], 0.0), ti.max(beta[0], 0.0))   # N_q = β_{q+1}
    s = w[0] + w[1] + w[2]
    if s > 0.0:
        w /= s
    else:
        w = vec3(1.0, 1.0, 1.0) / 3.0
    return w


@ti.func
def contact_conductance(A, B, nodes: ti.template(), tris: ti.template(), heat: ti.template()):
    """(G_c [W/(m·K)], weights on A's nodes, weights on B's nodes) of the couple of triangles A, B
    (docs/theory/heat.md §16.4): G_c = F k̄ ℓ / h̄ · min(1, δ / δ_c), with ℓ the contact length
    (the mean over the two passes of the contactor edges' length inside the target), δ = h̄ ψ̄ / 3
    the mean overlap from the mean potential ψ̄ along them, δ_c = r h̄, k̄ the harmonic mean of
    the two conductivities and h̄ the smaller of their smallest rest altitudes (F
    :data:`JOINT_CONDUCTANCE_FACTOR`, r :data:`CONTACT_OVERLAP_REF`); 0 apart.  The heat passes
    at the contact point, the centroid of those edge parts."""
    na = tris.tri_nodes[A]
    nb = tris.tri_nodes[B]
    a0, a1, a2 = nodes.node_x[na[0]], nodes.node_x[na[1]], nodes.node_x[na[2]]
    b0, b1, b2 = nodes.node_x[nb[0]], nodes.node_x[nb[1]], nodes.node_x[nb[2]]
    G = 0.0
    wA = vec3(0.0, 0.0, 0.0)
    wB = vec3(0.0, 0.0, 0.0)
    if boxes_overlap(a0, a1, a2, b0, b1, b2):
        l0, p0, m0 = overlap_pass(b0, b1, b2, a0, a1, a2)
        l1, p1, m1 = overlap_pass(a0, a1, a2, b0, b1, b2)
        ell = l0 + l1
        if ell > 0.0:
            kA, kB = heat.heat_tri[A][9], heat.heat_tri[B][9]
            kbar = 2.0 * kA * kB / (kA + kB)
            h = ti.min(heat.heat_tri[A][10], heat.heat_tri[B][10])
            psi = (p0 + p1) / ell                     # mean potential along the contact: 3 δ / h̄
            G = JOINT_CONDUCTANCE_FACTOR * kbar * (0.5 * ell) / h * ti.min(1.0, psi / (3.0 * CONTACT_OVERLAP_REF))
            P = (m0 + m1) / ell
            wA = contact_weights(P, a0, a1, a2)
            wB = contact_weights(P, b0, b1, b2)
    return G, wA, wB


@ti.func
def contact_entry(k, heat: ti.template()):
    """(couple c, side: 0 the list's triangle is the couple's first, 1 its second, the partner
    triangle) of entry k of a triangle's contact list."""
    code = heat.heat_ct[k]
    c = code >> 1
    side = code & 1
    pair = heat.heat_cpl_tri[c]
    partner = pair[1]
    if side == 1:
        partner = pair[0]
    return c, side, partner


@ti.func
def contact_heat(e, tris: ti.template(), heat: ti.template()):
    """The heat flow [W/m] the contacts of triangle e bring to each of its nodes:
    Σ_c G_c (T_partner(P_c) − T_e(P_c)) w_e,c, the temperatures interpolated at the contact point."""
    q = vec3(0.0, 0.0, 0.0)
    for k in range(heat.heat_ct[e], heat.heat_ct[e + 1]):
        c, side, partner = contact_entry(k, heat)
        v = heat.heat_cpl[c]
        wA = vec3(v[1], v[2], v[3])
        wB = vec3(v[4], v[5], v[6])
        n = tris.tri_nodes[e]
        m = tris.tri_nodes[partner]
        Te = vec3(heat.heat_temp[n[0]], heat.heat_temp[n[1]], heat.heat_temp[n[2]])
        Tp = vec3(heat.heat_temp[m[0]], heat.heat_temp[m[1]], heat.heat_temp[m[2]])
        we, wp = wA, wB
        if side == 1:
            we, wp = wB, wA
        flow = v[0] * ((wp[0] * Tp[0] + wp[1] * Tp[1] + wp[2] * Tp[2]) - (we[0] * Te[0] + we[1] * Te[1] + we[2] * Te[2]))
        q[0] += flow * we[0]
        q[1] += flow * we[1]
        q[2] += flow * we[2]
    return q


@ti.func
def sort_contacts(e, heat: ti.template()):
    """Triangle e's contact list in increasing partner triangle (insertion sort: a list holds a
    few), whatever order the parallel fill took its slots in."""
    lo = heat.heat_ct[e]
    for a in range(lo + 1, heat.heat_ct[e + 1]):
        code = heat.heat_ct[a]
        _, _, key = contact_entry(a, heat)
        b = a - 1
        while b >= lo:
            _, _, kb = contact_entry(b, heat)
            if kb > key:
                heat.heat_ct[b + 1] = heat.heat_ct[b]
                b -= 1
            else:
                break
        heat.heat_ct[b + 1] = code


@ti.func
def contact_row(i, tris: ti.template(), heat: ti.template()):
    """Σ_j abs(K_ij) of node i's contact terms: 2 G_c w_i,c over the contacts of its triangles."""
    row = 0.0
    for k in range(heat.heat_adj[i], heat.heat_adj[i + 1]):
        code = heat.heat_adj[k]
        if (code & 3) == ADJ_TRI:
            e = (code >> 2) // 3
            a = (code >> 2) - 3 * e
            for m in range(heat.heat_ct[e], heat.heat_ct[e + 1]):
                c, side, _ = contact_entry(m, heat)
                row += 2.0 * heat.heat_cpl[c][0] * heat.heat_cpl[c][1 + 3 * side + a]
    return row


@ti.func
def find_contacts(nodes: ti.template(), tris: ti.template(), contact: ti.template(), step: ti.template(),
                  heat: ti.template()):
    """The conducting contacts at the current positions (module docstring): each couple's
    conductance and contact point (:func:`contact_conductance`; none for the neighbour pairs,
    which conduct through their joints, nor for excavated triangles), each triangle's sorted
    list of the couples with G_c > 0 (heat_ct), and the stable heat step with them,
    min_i C_i / (Σ_j abs(K_ij) + contact terms), into heat_real[H_DT_CONTACT]."""
    E = tris.tri_nodes.shape[0]
    for e in range(E):
        heat.heat_ct[e] = 0
    for c in range(step.step_int[NB_PAIRS], step.step_int[COUPLES]):
        A, B = contact.couple_a[c], contact.couple_b[c]
        G, wA, wB = 0.0, vec3(0.0, 0.0, 0.0), vec3(0.0, 0.0, 0.0)
        if tris.tri_intact[A] >= 0 and tris.tri_intact[B] >= 0:
            G, wA, wB = contact_conductance(A, B, nodes, tris, heat)
        heat.heat_cpl[c] = ti.Vector([G, wA[0], wA[1], wA[2], wB[0], wB[1], wB[2]], dt=float)
        heat.heat_cpl_tri[c] = ti.Vector([A, B], dt=ti.i32)
        if G > 0.0:
            ti.atomic_add(heat.heat_ct[A], 1)
            ti.atomic_add(heat.heat_ct[B], 1)
    for _ in range(1):                        # counts to starts (serial), cursors
        s = 2 * E + 1
        for e in range(E):
            n = heat.heat_ct[e]
            heat.heat_ct[e] = s
            heat.heat_ct[E + 1 + e] = s
            s += n
        heat.heat_ct[E] = s
    for c in range(step.step_int[NB_PAIRS], step.step_int[COUPLES]):
        if heat.heat_cpl[c][0] > 0.0:
            pair = heat.heat_cpl_tri[c]
            heat.heat_ct[ti.atomic_add(heat.heat_ct[E + 1 + pair[0]], 1)] = 2 * c
            heat.heat_ct[ti.atomic_add(heat.heat_ct[E + 1 + pair[1]], 1)] = 2 * c + 1
    for e in range(E):
        sort_contacts(e, heat)
    for i in range(heat.heat_temp.shape[0]):
        row = heat.heat_node[i][2] + contact_row(i, tris, heat)
        heat.heat_next[i] = heat.heat_node[i][0] / row if row > 0.0 else -1.0
    for _ in range(1):                        # the smallest stable step (serial: a fixed order)
        dt = -1.0
        for i in range(heat.heat_temp.shape[0]):
            d = heat.heat_next[i]
            if d > 0.0 and (dt < 0.0 or d < dt):
                dt = d
        heat.heat_real[H_DT_CONTACT] = dt


@ti.kernel
def heat_contacts(h: HeatStepGroup):
    """The conducting contacts and the stable heat step with them (:func:`find_contacts`); ``h``
    serves as every group."""
    find_contacts(h, h, h, h, h)

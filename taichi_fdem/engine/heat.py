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
  triangle's conduction matrix K_e, ``heat.heat_tri[e][0:6]``);
* kind :data:`ADJ_JOINT`: joint j at its node p = 0..3, index ``4 j + p``; the facing copy is
  node 3 − p of the joint (j0 faces j3, j1 faces j2) and the conductance G_p is
  :func:`joint_conductance`;
* kind :data:`ADJ_FLUX`: a flux row r (the node takes q A(t) ℓ of it, ℓ half the edge length);
* kind :data:`ADJ_HELD`: a held-temperature row r (the node ends the step at
  T₀ + A(t)(T_r − T₀), the heat this takes booked in ``heat.heat_supply[i][1]``).

A(t) is the row's curve (``nodes.curve_points``) at the end of the heat step.
"""
import taichi as ti

from .elastic import tri_strain_energy
from .groups import HeatGroup, JointGroup, MaterialGroup, NodeGroup, StepGroup, TriGroup
from .loads import curve_value

ADJ_TRI, ADJ_JOINT, ADJ_FLUX, ADJ_HELD = 0, 1, 2, 3
ROW_TEMPERATURE, ROW_FLUX = 0, 1

# slots of heat.heat_real and heat.heat_int (engine.arrays)
H_TIME, H_DT, H_SUB, H_EVERY = 0, 1, 2, 3
H_SINCE, H_UPDATES = 0, 1


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
def node_rate(i, t, nodes: ti.template(), tris: ti.template(), joints: ti.template(), heat: ti.template()):
    """(Q_i − (K T)_i [W/m], held row of node i or −1, flux part of Q_i [W/m]) at time t."""
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


@ti.kernel
def heat_substep(nodes: NodeGroup, tris: TriGroup, joints: JointGroup, heat: HeatGroup):
    """One heat step of Δt_h = heat_real[H_DT] from heat_real[H_TIME] (module docstring): the new
    temperatures, the heat supplied per node, and the time advanced."""
    for i in range(heat.heat_temp.shape[0]):
        dt = heat.heat_real[H_DT]
        t = heat.heat_real[H_TIME] + dt
        C = heat.heat_node[i][0]
        rate, held, q = node_rate(i, t, nodes, tris, joints, heat)
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

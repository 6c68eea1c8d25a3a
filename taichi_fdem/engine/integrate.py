"""Explicit central-difference integration of the nodes (FDEM_SPEC §6.1), with prescribed
velocities, the instability checks and the re-detection trigger D_acc (§4.1)."""
import taichi as ti

from .groups import DACC, NONFINITE, SWITCH_BC, SWITCH_BC_WORK, TIME, VMAX, WORK_BOUNDARY
from .tiutil import vec2

CHUNK = 256   # nodes per chunk in reductions (one atomic per chunk, not per node)


@ti.func
def integrate_node(i, f, nodes: ti.template(), step: ti.template(), dt, g, bc, bc_work):
    """Central difference for node i under the total force f [N/m]: v += Δt (f/m + g),
    prescribed velocities, x += Δt v, node_f = 0.  Returns (|v|², constraint work [J/m], bad)
    where bad = i + 1 if the new state is not finite."""
    m = nodes.node_mass[i]
    v = nodes.node_v[i] + dt * (f / m + g)
    work = 0.0
    if bc != 0:
        free = nodes.node_free[i]
        vb = nodes.node_vbc[i]
        if bc_work != 0:
            # work of the constraint force R = m (v_b − v_free)/Δt over x_{n+1} − x_n = Δt v_b
            work = ((1.0 - free) * m * (vb - v)).dot(vb)
        v = free * v + (1.0 - free) * vb
    x = nodes.node_x[i] + dt * v
    nodes.node_v[i] = v
    nodes.node_x[i] = x
    nodes.node_f[i] = vec2(0.0, 0.0)
    s = v.norm_sqr()
    bad = 0
    if not (s < 1e200) or not (ti.abs(x[0]) < 1e200 and ti.abs(x[1]) < 1e200):
        bad = i + 1
    return s, work, bad


@ti.func
def _integrate_all(nodes: ti.template(), tris: ti.template(), joints: ti.template(), step: ti.template(),
                   asm: ti.template(), gathered: ti.template()):
    N = nodes.node_x.shape[0]
    dt = step.step_dt[None]
    g = step.step_gravity[None]
    bc = step.step_switches[None] & SWITCH_BC
    bc_work = step.step_switches[None] & SWITCH_BC_WORK
    for _ in range(1):
        step.step_real[VMAX] = 0.0
    for chunk in range((N + CHUNK - 1) // CHUNK):
        vmax2 = 0.0
        bad = 0
        work = 0.0
        for i in range(chunk * CHUNK, ti.min(N, chunk * CHUNK + CHUNK)):
            f = nodes.node_f[i]
            if ti.static(gathered):
                # the node's slots, in the sorted order of build_node_slots: a fixed summation order
                T = tris.tri_nodes.shape[0]
                for a in range(asm.asm_node_start[i], asm.asm_node_start[i + 1]):
                    f += _slot_force(asm.asm_node_slots[a], T, joints, asm)
            s, w, b = integrate_node(i, f, nodes, step, dt, g, bc, bc_work)
            work += w
            bad = ti.max(bad, b)
            vmax2 = ti.max(vmax2, s)
        ti.atomic_max(step.step_real[VMAX], ti.sqrt(vmax2))
        if bad > 0:
            ti.atomic_max(step.step_int[NONFINITE], bad)
        if bc_work != 0:
            ti.atomic_add(step.step_real[WORK_BOUNDARY], work)
    for _ in range(1):
        # re-detection trigger D_acc += 2 Δt v_max (§4.1)
        step.step_real[DACC] += 2.0 * dt * step.step_real[VMAX]
        step.step_real[TIME] += dt


@ti.func
def _slot_force(s, T, joints: ti.template(), asm: ti.template()):
    """The force [N/m] of node slot s: s >= 0 indexes asm_force (triangles, then couples);
    s < 0 is slot k = q % 4 of joint j = q // 4, q = −1 − s (forces −g0, −g1, +g1, +g0 on the
    joint's nodes j0..j3, §7.3)."""
    f = vec2(0.0, 0.0)
    if s >= 0:
        f = asm.asm_force[s]
    else:
        q = -1 - s
        gj = joints.joint_g[q // 4]
        k = q % 4
        if k == 0:
            f = vec2(-gj[0], -gj[1])
        elif k == 1:
            f = vec2(-gj[2], -gj[3])
        elif k == 2:
            f = vec2(gj[2], gj[3])
        else:
            f = vec2(gj[0], gj[1])
    return f


@ti.func
def integrate_nodes(nodes: ti.template(), step: ti.template()):
    """v += Δt (f/m + g); prescribed velocities; x += Δt v; f = 0; v_max, D_acc, time.

    A node speed above step.vlimit is read as instability (see :func:`taichi_fdem.engine.step.is_unstable`).
    """
    _integrate_all(nodes, nodes, nodes, step, nodes, False)


@ti.func
def integrate_nodes_gathered(nodes: ti.template(), tris: ti.template(), joints: ti.template(), step: ti.template(),
                             asm: ti.template()):
    """As :func:`integrate_nodes`, the force of each node being node_f plus the sum of its slots
    (parallel strategy, no atomic float add)."""
    _integrate_all(nodes, tris, joints, step, asm, True)

"""Explicit central-difference integration of the nodes (docs/theory/elements.md §6.1), with prescribed
velocities and their reactions (§12.3), the local (quasi-static) damping, the instability checks
and the re-detection trigger D_acc (§4.1).

Local non-viscous damping (Cundall 1987; the "local damping" of Itasca's PFC/UDEC/3DEC): with
the quasi-static option, each free component d of a node receives the extra force
``F_d = −α |F_d^unbal| sign(v_d)``, where F^unbal = f + m g is the unbalanced force and v the
velocity of the last half step.  It damps every mode alike (its strength is a fraction α of the
force that drives the motion, not a viscosity tied to a frequency) and vanishes for steady
motion (no unbalanced force), so a body at equilibrium or sliding steadily is not resisted; it
is meant for reaching static equilibrium, not for dynamics.  Its work is booked in
step_real[WORK_LOCAL].
"""
import taichi as ti

from .groups import (DACC, DT, GRAVITY_X, GRAVITY_Y, NONFINITE, QS_ALPHA, RANGE, SWITCH_BC, SWITCH_BC_WORK, SWITCHES,
                     TIME, VMAX, WORK_BOUNDARY, WORK_CDAMPING, WORK_FRICTION, WORK_LOCAL)
from .tiutil import vec2

CHUNK = 16    # nodes per chunk in reductions (one atomic per chunk, not per node); small enough that
              # the chunk loop has several of Taichi's 512-iteration CPU tasks, so that it runs in parallel


@ti.func
def gravity(step: ti.template()):
    """Gravity [m/s²], from its two slots of step_real (read it inside the loop that uses it: see
    :func:`integrate_nodes`)."""
    return ti.Vector([step.step_real[GRAVITY_X], step.step_real[GRAVITY_Y]])


@ti.func
def _sign(x):
    s = 0.0
    if x > 0.0:
        s = 1.0
    elif x < 0.0:
        s = -1.0
    return s


@ti.func
def integrate_node(i, f, nodes: ti.template(), dt, g, bc, bc_work, alpha, local_damping: ti.template()):
    """Central difference for node i under the total force f [N/m]: v += Δt (f/m + g), the local
    damping (compile time ``local_damping``, coefficient α), prescribed velocities and their
    reaction R = (1 − free)(m (v_b − v)/Δt − f − m g) in nodes.node_react[i] (§12.3),
    x += Δt v, node_f = 0.  Returns (``|v|²``, constraint work, local-damping work [J/m], bad) where
    bad = i + 1 if the new state is not finite."""
    m = nodes.node_mass[i]
    v = nodes.node_v[i] + dt * (f / m + g)
    local = 0.0
    if ti.static(local_damping):
        v0 = nodes.node_v[i]
        F = f + m * g
        fd = -alpha * vec2(ti.abs(F[0]) * _sign(v0[0]), ti.abs(F[1]) * _sign(v0[1]))
        if bc != 0:
            fd *= nodes.node_free[i]          # prescribed components are not damped
        v += (dt / m) * fd
        local = -dt * fd.dot(v)
    work = 0.0
    if bc != 0:
        free = nodes.node_free[i]
        # a free node (free = (1, 1), most of them) has no reaction and keeps v: its node_react
        # stays the zero it starts with (free components are never prescribed later; removal
        # only fixes orphan nodes), and a branch skips the constraint's loads, stores and division
        if free[0] < 1.0 or free[1] < 1.0:
            vb = nodes.node_vbc[i]
            nodes.node_react[i] = (1.0 - free) * (m * (vb - nodes.node_v[i]) / dt - f - m * g)
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
    return s, work, local, bad


@ti.func
def _slot_force(s, joints: ti.template(), asm: ti.template()):
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
def asm_blocks(N, asm: ti.template()):
    """Blocks of the block assembly (:func:`taichi_fdem.engine.step.phase_blocks`) in a scene of N
    nodes.  Block 0 adds its forces into node_f; asm_force holds a copy of the nodal forces for
    each further block, block-major (two blocks share no cache line but at their ends), then two
    entries per block for its dissipated contact work (friction, contact damping) [J/m], one for
    even and one for odd steps (a team books a step's work while the next step's forces write
    the other): (blocks − 1) N + 2 blocks entries."""
    return (asm.asm_force.shape[0] + N) // (N + 2)


@ti.func
def block_work_slot(N, nblk, b, p):
    """The asm_force entry of block b's dissipated contact work in a step of parity p (see
    :func:`asm_blocks`)."""
    return (nblk - 1) * N + p * nblk + b


@ti.func
def book_block_work(N, nblk, asm: ti.template(), step: ti.template(), p):
    """Add the blocks' dissipated contact work (friction, contact damping) [J/m] of a step of
    parity p to the step counters in block order, and reset each block's entry."""
    for b in range(nblk):
        k = block_work_slot(N, nblk, b, p)
        w = asm.asm_force[k]
        step.step_real[WORK_FRICTION] += w[0]
        step.step_real[WORK_CDAMPING] += w[1]
        asm.asm_force[k] = vec2(0.0, 0.0)


@ti.func
def integrate_span(lo, hi, nodes: ti.template(), joints: ti.template(), asm: ti.template(), step: ti.template(), dt,
                   g, bc, bc_work, alpha, gathered: ti.template(), local_damping: ti.template()):
    """Integrate nodes lo..hi-1 (:func:`integrate_node`), each under node_f plus (``gathered``
    1) its slots or (2) its block copies, which are reset.  Returns the span's (max ``|v|²``,
    largest bad index + 1, constraint work, local-damping work)."""
    N = nodes.node_x.shape[0]
    vmax2 = 0.0
    bad = 0
    work = 0.0
    local = 0.0
    f_lo = 0
    f_hi = 0
    if ti.static(gathered == 2):
        # node_f holds block 0's sum (then the loads); add the other blocks' copies in block
        # order, each over the nodes its items can write (its range, step_int[RANGE + 2b],
        # engine.blocks.block_node_ranges), each entry reset for the next step.  Two blocks
        # (the default): block 1's copy is added in the integration loop below, the same sum
        # without a pass of its own that stores node_f and loads it again
        nblk = asm_blocks(N, asm)
        if nblk == 2:
            f_lo = ti.max(lo, step.step_int[RANGE + 2])
            f_hi = ti.min(hi, step.step_int[RANGE + 3])
        else:
            for b in range(1, nblk):
                for i in range(ti.max(lo, step.step_int[RANGE + 2 * b]), ti.min(hi, step.step_int[RANGE + 2 * b + 1])):
                    k = (b - 1) * N + i
                    nodes.node_f[i] = nodes.node_f[i] + asm.asm_force[k]
                    asm.asm_force[k] = vec2(0.0, 0.0)
    for i in range(lo, hi):
        f = nodes.node_f[i]
        if ti.static(gathered == 2):
            if i >= f_lo and i < f_hi:
                f = f + asm.asm_force[i]
                asm.asm_force[i] = vec2(0.0, 0.0)
        if ti.static(gathered == 1):
            # the node's slots, in the sorted order of build_node_slots: a fixed summation order
            for a in range(asm.asm_node_start[i], asm.asm_node_start[i + 1]):
                f += _slot_force(asm.asm_node_slots[a], joints, asm)
        s, w, lw, bd = integrate_node(i, f, nodes, dt, g, bc, bc_work, alpha, local_damping)
        work += w
        local += lw
        bad = ti.max(bad, bd)
        vmax2 = ti.max(vmax2, s)
    return vmax2, bad, work, local


@ti.func
def _integrate_all(nodes: ti.template(), joints: ti.template(), step: ti.template(), asm: ti.template(),
                   gathered: ti.template(), local_damping: ti.template()):
    """gathered: 0 = node_f only (serial), 1 = plus the node's slots, 2 = plus its block copies."""
    N = nodes.node_x.shape[0]
    dt = step.step_real[DT]
    bc = step.step_int[SWITCHES] & SWITCH_BC
    bc_work = step.step_int[SWITCHES] & SWITCH_BC_WORK
    alpha = 0.0
    if ti.static(local_damping):
        alpha = step.step_real[QS_ALPHA]
    ti.loop_config(serialize=True)   # a serial task: one thread, no parallel-loop launch
    for _ in range(1):
        step.step_real[VMAX] = 0.0
    for chunk in range((N + CHUNK - 1) // CHUNK):
        # g is read in the loop, not before it: a vector set outside a loop and read inside one
        # is a global temporary, which Taichi 1.7 places unaligned, and SPIR-V (Vulkan) stores an
        # f64 vector at an offset of 4 mod 8 four bytes lower, over its neighbour (the loop's
        # end in a scene with a fluid; tests/test_gpu.py, fluid-f64)
        g = gravity(step)
        vmax2, bad, work, local = integrate_span(chunk * CHUNK, ti.min(N, chunk * CHUNK + CHUNK), nodes, joints, asm,
                                                 step, dt, g, bc, bc_work, alpha, gathered, local_damping)
        ti.atomic_max(step.step_real[VMAX], ti.sqrt(vmax2))
        if bad > 0:
            ti.atomic_max(step.step_int[NONFINITE], bad)
        if bc_work != 0:
            ti.atomic_add(step.step_real[WORK_BOUNDARY], work)
        if ti.static(local_damping):
            ti.atomic_add(step.step_real[WORK_LOCAL], local)
    ti.loop_config(serialize=True)   # a serial task: one thread, no parallel-loop launch
    for _ in range(1):
        if ti.static(gathered == 2):
            # the blocks' dissipated contact work, in block order (engine.step.phase_blocks)
            nblk = asm_blocks(N, asm)
            book_block_work(N, nblk, asm, step, 0)
        # re-detection trigger D_acc += 2 Δt v_max (§4.1)
        step.step_real[DACC] += 2.0 * dt * step.step_real[VMAX]
        step.step_real[TIME] += dt


@ti.func
def integrate_nodes(nodes: ti.template(), step: ti.template(), local_damping: ti.template()):
    """v += Δt (f/m + g); local damping; prescribed velocities and reactions; x += Δt v; f = 0;
    v_max, D_acc, time (:func:`integrate_node` per node).

    A node speed above step.step_real[VLIMIT] is read as instability (see :func:`taichi_fdem.engine.step.is_unstable`).
    """
    _integrate_all(nodes, nodes, step, nodes, 0, local_damping)


@ti.func
def integrate_nodes_gathered(nodes: ti.template(), joints: ti.template(), step: ti.template(), asm: ti.template(),
                             blocks: ti.template(), local_damping: ti.template()):
    """As :func:`integrate_nodes`, the force of each node being node_f plus the sum of its slots
    (``blocks`` False) or of its block copies (``blocks`` True): parallel strategy, no atomic
    float add."""
    if ti.static(blocks):
        _integrate_all(nodes, joints, step, asm, 2, local_damping)
    else:
        _integrate_all(nodes, joints, step, asm, 1, local_damping)

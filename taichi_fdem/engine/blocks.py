"""The block assembly of the parallel strategy on the CPU (docs/theory/elements.md §6.1); the team of worker
threads that runs it many steps per launch is :mod:`taichi_fdem.engine.team`.

Each of a fixed number of blocks takes a contiguous range of the triangles and of the joints (by
count) and of the couples (by estimated cost, :func:`rebalance_couples`) and adds their nodal
forces into its own copy of the nodal forces (:func:`block_forces`); every node then adds the
copies in block order and integrates.  The ranges depend on the state only, never on the thread
count, so the sums, and the results, are the same bits for any number of threads.
"""
import taichi as ti

from .contact import couple_certificate, couple_forces, neighbour_flag
from .elastic import tri_forces
from .groups import DT
from .groups import (COST_BONDED, COST_BROKEN, COST_CERTIFIED, COST_JOINT, COST_JOINT_DAMAGED, COST_SEPARATED,
                     COST_TOUCHING, COST_TRI, MAX_FORCE_BLOCKS, RANGE, SPLIT, TEAM_CHUNK, VMAX, COUPLES)
from .integrate import block_work_slot
from .joints import eval_joint
from .loads import LOAD_FORCE, LOAD_VELOCITY
from .tiutil import vec2


@ti.func
def item_counts(tris: ti.template(), joints: ti.template(), step: ti.template(), feat: ti.template()):
    """(triangles, joints, couples) whose forces a step evaluates (0 for a feature ``feat`` lacks)."""
    T = tris.tri_nodes.shape[0]
    J = 0
    C = 0
    if ti.static(feat.fracture):
        J = joints.joint_nodes.shape[0]
    if ti.static(feat.contact):
        C = step.step_int[COUPLES]
    return T, J, C


class Target:
    """Where a block adds its items' nodal forces (a compile-time choice, :func:`add_block_force`):
    ``NODE_F`` block 0, into nodes.node_f; ``FIRST_COPY`` block 1, into its copy at offset 0 of
    asm_force; ``COPY`` any other block, into its copy at a runtime offset (:func:`integrate.asm_blocks`)."""
    NODE_F = 0
    FIRST_COPY = 1
    COPY = 2


@ti.func
def add_block_force(n, base, f, nodes: ti.template(), asm: ti.template(), target: ti.template()):
    """Add f to node n's force in the block's :class:`Target`: node_f, asm_force[n] (the first
    copy) or asm_force[base + n]."""
    if ti.static(target == Target.FIRST_COPY):
        asm.asm_force[n] = asm.asm_force[n] + f
    elif ti.static(target == Target.COPY):
        asm.asm_force[base + n] = asm.asm_force[base + n] + f
    else:
        nodes.node_f[n] = nodes.node_f[n] + f


@ti.func
def couple_cost(c, growth, nodes: ti.template(), tris: ti.template(), contact: ti.template(), step: ti.template(),
                fracture: ti.template()):
    """The estimated cost of couple c per step (engine.groups.COST_*): a bonded neighbour pair;
    apart by more than the rounding margin (:func:`contact.couple_certificate`: skipped until
    D_acc, growing by ``growth`` per step, passes its gap); apart by less; or touching.  A
    function of the positions alone, so that the ranges do not depend on how steps were launched."""
    cost = COST_BONDED
    nb_pair, on = neighbour_flag(c, tris, step, fracture)
    if not nb_pair or on != 0:
        na = tris.tri_nodes[contact.couple_a[c]]
        nb = tris.tri_nodes[contact.couple_b[c]]
        cert, hit = couple_certificate(nodes.node_x[na[0]], nodes.node_x[na[1]], nodes.node_x[na[2]],
                                       nodes.node_x[nb[0]], nodes.node_x[nb[1]], nodes.node_x[nb[2]])
        if hit:
            cost = COST_TOUCHING
        elif cert <= 0.0:
            cost = COST_SEPARATED
        else:
            # tested again every cert / growth steps
            cost = COST_CERTIFIED + ti.cast(COST_SEPARATED * ti.min(1.0, growth / cert), ti.i32)
    return cost


@ti.func
def joint_cost(j, joints: ti.template()):
    """The estimated cost of joint j per step (engine.groups.COST_*): intact, damaged or broken."""
    cost = COST_BROKEN
    if joints.joint_state[j] == 0:
        cost = COST_JOINT
        dm = joints.joint_dmax[j]
        if dm[0] > 0.0 or dm[1] > 0.0 or dm[2] > 0.0:
            cost = COST_JOINT_DAMAGED
    return cost


@ti.func
def block_fixed_cost(b, nblk, T, J, joints: ti.template(), fracture: ti.template()):
    """The estimated cost of block b's triangles and joints (its ranges by count)."""
    cost = ti.cast(((b + 1) * T // nblk - b * T // nblk) * COST_TRI, ti.i64)
    if ti.static(fracture):
        for j in range(b * J // nblk, (b + 1) * J // nblk):
            cost += joint_cost(j, joints)
    return cost


@ti.func
def rebalance_couples(nblk, C, nodes: ti.template(), tris: ti.template(), contact: ti.template(),
                      joints: ti.template(), step: ti.template(), fracture: ti.template()):
    """Split the C couples into nblk contiguous ranges whose blocks' estimated costs (triangles and
    joints, :func:`block_fixed_cost`; couples, :func:`couple_cost`) come out about equal:
    step_int[SPLIT + b] is block b's first couple (SPLIT + nblk and the unused slots hold C).
    Serial, two passes over the couples, every REBALANCE_STEPS steps and after each
    detection.  A function of the state only: the same sums for any thread count, and a restart
    from a checkpoint bit-identical."""
    T = tris.tri_nodes.shape[0]
    J = 0
    if ti.static(fracture):
        J = joints.joint_nodes.shape[0]
    growth = 2.0 * step.step_real[DT] * step.step_real[VMAX]       # D_acc's growth per step (§4.1)
    total = ti.cast(T * COST_TRI, ti.i64)
    if ti.static(fracture):
        for j in range(J):
            total += joint_cost(j, joints)
    for c in range(C):
        total += couple_cost(c, growth, nodes, tris, contact, step, fracture)
    acc = block_fixed_cost(0, nblk, T, J, joints, fracture)      # blocks before b, couples before c
    b = 1
    step.step_int[SPLIT] = 0
    for c in range(C):
        while b < nblk and acc * nblk >= b * total:
            step.step_int[SPLIT + b] = c
            acc += block_fixed_cost(b, nblk, T, J, joints, fracture)
            b += 1
        acc += couple_cost(c, growth, nodes, tris, contact, step, fracture)
    while b <= MAX_FORCE_BLOCKS:
        step.step_int[SPLIT + b] = C
        b += 1


@ti.func
def couple_range(b, nblk, C, step: ti.template()):
    """Block b's couples, [lo, hi) (:func:`rebalance_couples`; clamped to the C couples, so that
    the blocks always share them out exactly, whatever the bounds)."""
    lo = 0
    hi = C
    if b > 0:
        lo = ti.min(ti.max(step.step_int[SPLIT + b], 0), C)
    if b < nblk - 1:
        hi = ti.min(ti.max(step.step_int[SPLIT + b + 1], 0), C)
    return lo, hi


@ti.func
def chunk_count(N):
    """Node chunks of the team's integration (:mod:`taichi_fdem.engine.team`, stage INTEG): the
    nodes cut evenly into chunks of at most TEAM_CHUNK; a function of N alone."""
    return (N + TEAM_CHUNK - 1) // TEAM_CHUNK


@ti.func
def chunk_nodes(c, nch, N):
    """The nodes [lo, hi) of chunk c of nch (:func:`chunk_count`)."""
    return c * N // nch, (c + 1) * N // nch


@ti.func
def _grow(n, lo, hi):
    """A block's node range [lo, hi) grown by node n."""
    return ti.min(lo, n), ti.max(hi, n + 1)


@ti.func
def block_node_ranges(nblk, T, J, C, nodes: ti.template(), tris: ti.template(), contact: ti.template(),
                      joints: ti.template(), step: ti.template(), feat: ti.template()):
    """step_int[RANGE + 2b], [RANGE + 2b + 1] = [lo, hi): the nodes block b's items can write
    (its triangles, joints and couples; for block 0 the loads' nodes too), over which the gather
    adds its copy (:func:`integrate.integrate_span`).  Serial, one pass over the items, with the
    couple ranges and after a restore."""
    for b in range(nblk):
        lo = 2147483647
        hi = 0
        for e in range(b * T // nblk, (b + 1) * T // nblk):
            n = tris.tri_nodes[e]
            for r in ti.static(range(3)):
                lo, hi = _grow(n[r], lo, hi)
        if ti.static(feat.fracture):
            for j in range(b * J // nblk, (b + 1) * J // nblk):
                nd = joints.joint_nodes[j]
                for r in ti.static(range(4)):
                    lo, hi = _grow(nd[r], lo, hi)
        if ti.static(feat.contact):
            lo_c, hi_c = couple_range(b, nblk, C, step)
            for c in range(lo_c, hi_c):
                na = tris.tri_nodes[contact.couple_a[c]]
                nb = tris.tri_nodes[contact.couple_b[c]]
                for r in ti.static(range(3)):
                    lo, hi = _grow(na[r], lo, hi)
                    lo, hi = _grow(nb[r], lo, hi)
        if ti.static(feat.loads):
            if b == 0:
                for k in range(nodes.load_nodes.shape[0]):
                    ld = nodes.load_nodes[k]
                    lo, hi = _grow(ld[1], lo, hi)
                    if ld[0] != LOAD_FORCE and ld[0] != LOAD_VELOCITY:     # a segment's second node
                        lo, hi = _grow(ld[2], lo, hi)
        step.step_int[RANGE + 2 * b] = ti.min(lo, hi)
        step.step_int[RANGE + 2 * b + 1] = hi


@ti.func
def rebalance_blocks(nblk, T, J, C, nodes: ti.template(), tris: ti.template(), contact: ti.template(),
                     joints: ti.template(), step: ti.template(), feat: ti.template()):
    """The blocks' couple ranges (with contact, :func:`rebalance_couples`) and their node ranges
    (:func:`block_node_ranges`), anew."""
    if ti.static(feat.contact):
        rebalance_couples(nblk, C, nodes, tris, contact, joints, step, feat.fracture)
    block_node_ranges(nblk, T, J, C, nodes, tris, contact, joints, step, feat)


@ti.func
def block_forces(b, nblk, T, J, C, dacc, p, nodes: ti.template(), tris: ti.template(), mats: ti.template(),
                 contact: ti.template(), joints: ti.template(), step: ti.template(), asm: ti.template(),
                 feat: ti.template()):
    """Block b's share of :func:`taichi_fdem.engine.step.phase_blocks`: the triangles and joints of
    its range by count and the couples of its range by cost (:func:`couple_range`), added into
    its copy of the nodal forces; its contact work to asm_force for a step of parity p
    (:func:`integrate.block_work_slot`).  ``dacc``: step_real[DACC] at the start of the step.
    Compiled for block 0 (:attr:`Target.NODE_F`), block 1 (:attr:`Target.FIRST_COPY`: a constant
    offset) and, with more than two blocks (``feat.many_blocks``), the others (:attr:`Target.COPY`)."""
    if b == 0:
        block_items(b, nblk, T, J, C, dacc, p, nodes, tris, mats, contact, joints, step, asm, feat, Target.NODE_F)
    elif ti.static(not feat.many_blocks):
        block_items(b, nblk, T, J, C, dacc, p, nodes, tris, mats, contact, joints, step, asm, feat, Target.FIRST_COPY)
    elif b == 1:
        block_items(b, nblk, T, J, C, dacc, p, nodes, tris, mats, contact, joints, step, asm, feat, Target.FIRST_COPY)
    else:
        block_items(b, nblk, T, J, C, dacc, p, nodes, tris, mats, contact, joints, step, asm, feat, Target.COPY)


@ti.func
def block_items(b, nblk, T, J, C, dacc, p, nodes: ti.template(), tris: ti.template(), mats: ti.template(),
                contact: ti.template(), joints: ti.template(), step: ti.template(), asm: ti.template(),
                feat: ti.template(), target: ti.template()):
    """:func:`block_forces` for block b, adding into its :class:`Target` at the nodes of its range
    (:func:`block_node_ranges`)."""
    N = nodes.node_x.shape[0]
    base = (b - 1) * N
    for e in range(b * T // nblk, (b + 1) * T // nblk):
        f0, f1, f2 = tri_forces(e, nodes, tris, mats, step, feat)
        n = tris.tri_nodes[e]
        add_block_force(n[0], base, f0, nodes, asm, target)
        add_block_force(n[1], base, f1, nodes, asm, target)
        add_block_force(n[2], base, f2, nodes, asm, target)
    if ti.static(feat.fracture):
        for j in range(b * J // nblk, (b + 1) * J // nblk):
            if joints.joint_state[j] == 0:
                eval_joint(j, nodes, tris, mats, joints, step, False)
                gj = joints.joint_g[j]
                nd = joints.joint_nodes[j]
                g0 = vec2(gj[0], gj[1])
                g1 = vec2(gj[2], gj[3])
                add_block_force(nd[0], base, -g0, nodes, asm, target)
                add_block_force(nd[1], base, -g1, nodes, asm, target)
                add_block_force(nd[2], base, g1, nodes, asm, target)
                add_block_force(nd[3], base, g0, nodes, asm, target)
    if ti.static(feat.contact):
        bwork = vec2(0.0, 0.0)
        lo_c, hi_c = couple_range(b, nblk, C, step)
        for c in range(lo_c, hi_c):
            gA, gB, hit, work = couple_forces(c, dacc, nodes, tris, mats, contact, step, feat.friction, feat.fracture)
            bwork += work
            if hit:
                na = tris.tri_nodes[contact.couple_a[c]]
                nb = tris.tri_nodes[contact.couple_b[c]]
                for r in ti.static(range(3)):
                    add_block_force(na[r], base, vec2(gA[r, 0], gA[r, 1]), nodes, asm, target)
                    add_block_force(nb[r], base, vec2(gB[r, 0], gB[r, 1]), nodes, asm, target)
        asm.asm_force[block_work_slot(N, nblk, b, p)] = bwork

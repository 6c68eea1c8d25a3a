"""The block assembly of the parallel strategy on the CPU (FDEM_SPEC §6.1), and the team of
worker threads that runs it many steps per launch (:func:`taichi_fdem.engine.step.run_steps_blocks`).

Each of a fixed number of blocks takes a contiguous range of the triangles and of the joints (by
count) and of the couples (by estimated cost, :func:`rebalance_couples`) and adds their nodal
forces into its own copy of the nodal forces (:func:`block_forces`); every node then adds the
copies in block order and integrates.  The ranges depend on the state only, never on the thread
count, so the sums, and the results, are the same bits for any number of threads.
"""
import taichi as ti

from .contact import couple_certificate, couple_forces, neighbour_flag
from .detection import phase_detect_count, phase_detect_fill
from .elastic import tri_forces
from .groups import (COST_BONDED, COST_BROKEN, COST_CERTIFIED, COST_JOINT, COST_JOINT_DAMAGED, COST_SEPARATED,
                     COST_TOUCHING, COST_TRI, COUPLES, DACC, DUE_BIT, FOUND, INVERTED, MAX_FORCE_BLOCKS, NONFINITE,
                     QS_ALPHA, RANGE, REBALANCE, REBALANCE_STEPS, SPLIT, SWITCH_BC, SWITCH_BC_WORK, SYNC_LINE, TIME,
                     UNSTABLE_BIT, VMAX, WORK_BOUNDARY, WORK_LOCAL)
from .integrate import asm_blocks, block_work_slot, book_block_work, integrate_span
from .joints import add_joint_work, eval_joint
from .loads import apply_load, book_load
from .tiutil import vec2


@ti.func
def item_counts(tris: ti.template(), joints: ti.template(), step: ti.template(), contact: ti.template(),
                fracture: ti.template()):
    """(triangles, joints, couples) whose forces a step evaluates (0 for an absent feature)."""
    T = tris.tri_nodes.shape[0]
    J = 0
    C = 0
    if ti.static(fracture):
        J = joints.joint_nodes.shape[0]
    if ti.static(contact):
        C = step.step_int[COUPLES]
    return T, J, C


@ti.func
def add_block_force(nodes: ti.template(), asm: ti.template(), base, n, f, copy: ti.template()):
    """Add f to node n's force: into node_f (block 0, ``copy`` False), or into the block's copy
    of the nodal forces at asm_force[base + n] (``copy`` True, base = (b − 1) N; see
    :func:`integrate.asm_blocks`); a plain read and write (one thread runs a block)."""
    if ti.static(copy):
        asm.asm_force[base + n] = asm.asm_force[base + n] + f
    else:
        nodes.node_f[n] = nodes.node_f[n] + f


@ti.func
def couple_cost(c, growth, nodes: ti.template(), tris: ti.template(), con: ti.template(), step: ti.template(),
                fracture: ti.template()):
    """The estimated cost of couple c per step at the current positions (engine.groups.COST_*):
    a bonded neighbour pair; apart by more than the rounding margin
    (:func:`contact.couple_certificate`), so that its certificate of separation skips it until
    D_acc, growing by ``growth`` per step, passes its gap (then it is tested again); apart by less
    (tested every step); or touching.  A function of the state alone (not of the certificates
    themselves, which a restart or a launch drops: the ranges, and so the sums, would depend on
    how the steps were launched)."""
    cost = COST_BONDED
    nb_pair, on = neighbour_flag(c, tris, step, fracture)
    if not nb_pair or on != 0:
        na = tris.tri_nodes[con.couple_a[c]]
        nb = tris.tri_nodes[con.couple_b[c]]
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
    """The estimated cost of joint j per step (engine.groups.COST_*): intact (undamaged or
    damaged), or broken (skipped for one read)."""
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
def rebalance_couples(nblk, C, nodes: ti.template(), tris: ti.template(), con: ti.template(),
                      joints: ti.template(), step: ti.template(), fracture: ti.template()):
    """Split the C couples into nblk contiguous ranges so that the blocks' estimated costs,
    their triangles and joints (:func:`block_fixed_cost`) and their couples (:func:`couple_cost`),
    come out about equal at the current positions: step_int[SPLIT + b] is the first couple of
    block b (SPLIT + nblk and the unused slots hold C): the first couple at which the cost of the
    blocks before b and of the couples before it reaches b / nblk of the total.  Serial, two
    passes over the couples and the joints (~25 ns per couple); run every REBALANCE_STEPS steps
    and after each detection.  A function of the state only, which keeps the sums the same for
    any thread count, and, the bounds being part of the state, a restart from a checkpoint
    bit-identical."""
    T = tris.tri_nodes.shape[0]
    J = 0
    if ti.static(fracture):
        J = joints.joint_nodes.shape[0]
    growth = 2.0 * step.step_dt[None] * step.step_real[VMAX]       # D_acc's growth per step (§4.1)
    total = ti.cast(T * COST_TRI, ti.i64)
    if ti.static(fracture):
        for j in range(J):
            total += joint_cost(j, joints)
    for c in range(C):
        total += couple_cost(c, growth, nodes, tris, con, step, fracture)
    acc = block_fixed_cost(0, nblk, T, J, joints, fracture)      # blocks before b, couples before c
    b = 1
    step.step_int[SPLIT] = 0
    for c in range(C):
        while b < nblk and acc * nblk >= b * total:
            step.step_int[SPLIT + b] = c
            acc += block_fixed_cost(b, nblk, T, J, joints, fracture)
            b += 1
        acc += couple_cost(c, growth, nodes, tris, con, step, fracture)
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
def block_node_ranges(nblk, T, J, C, tris: ti.template(), con: ti.template(), joints: ti.template(),
                      step: ti.template(), contact: ti.template(), fracture: ti.template()):
    """step_int[RANGE + 2b], [RANGE + 2b + 1] = [lo, hi): the nodes that block b > 0's items can
    write into its copy of the nodal forces, the nodes of its triangles, of its joints and of
    every couple of its range (:func:`couple_range`; touching or not), which the gather adds
    (:func:`integrate.integrate_span`).  Serial, one pass over the items of blocks 1 .. nblk − 1;
    run with the couple ranges (:func:`rebalance_blocks`, every REBALANCE_STEPS steps and after
    each detection), a function of the state.  (Before, each block tracked the nodes it wrote in
    its force loop: a loop-carried min and max per item, which made the block with a copy the
    slower one; benchmarks/README.md, twentieth session.)"""
    for b in range(1, nblk):
        lo = 2147483647
        hi = 0
        for e in range(b * T // nblk, (b + 1) * T // nblk):
            n = tris.tri_nodes[e]
            lo = ti.min(lo, ti.min(n[0], ti.min(n[1], n[2])))
            hi = ti.max(hi, ti.max(n[0], ti.max(n[1], n[2])) + 1)
        if ti.static(fracture):
            for j in range(b * J // nblk, (b + 1) * J // nblk):
                nd = joints.joint_nodes[j]
                lo = ti.min(lo, ti.min(ti.min(nd[0], nd[1]), ti.min(nd[2], nd[3])))
                hi = ti.max(hi, ti.max(ti.max(nd[0], nd[1]), ti.max(nd[2], nd[3])) + 1)
        if ti.static(contact):
            lo_c, hi_c = couple_range(b, nblk, C, step)
            for c in range(lo_c, hi_c):
                na = tris.tri_nodes[con.couple_a[c]]
                nb = tris.tri_nodes[con.couple_b[c]]
                lo = ti.min(lo, ti.min(ti.min(na[0], ti.min(na[1], na[2])), ti.min(nb[0], ti.min(nb[1], nb[2]))))
                hi = ti.max(hi, ti.max(ti.max(na[0], ti.max(na[1], na[2])), ti.max(nb[0], ti.max(nb[1], nb[2]))) + 1)
        step.step_int[RANGE + 2 * b] = ti.min(lo, hi)
        step.step_int[RANGE + 2 * b + 1] = hi


@ti.func
def rebalance_blocks(nblk, T, J, C, nodes: ti.template(), tris: ti.template(), con: ti.template(),
                     joints: ti.template(), step: ti.template(), contact: ti.template(), fracture: ti.template()):
    """The blocks' couple ranges (with contact, :func:`rebalance_couples`) and their node ranges
    (:func:`block_node_ranges`), anew."""
    if ti.static(contact):
        rebalance_couples(nblk, C, nodes, tris, con, joints, step, fracture)
    block_node_ranges(nblk, T, J, C, tris, con, joints, step, contact, fracture)


@ti.func
def block_forces(b, nblk, T, J, C, dacc, nodes: ti.template(), tris: ti.template(), mats: ti.template(),
                 con: ti.template(), joints: ti.template(), step: ti.template(), asm: ti.template(),
                 contact: ti.template(), friction: ti.template(), fracture: ti.template()):
    """Block b's share of :func:`taichi_fdem.engine.step.phase_blocks`: the triangles and the joints of its contiguous
    range by count, and the couples of its range by cost (:func:`couple_range`), added into its
    copy of the nodal forces; its contact work to its entry of asm_force.  The gather adds a
    block's copy over the nodes its items can write (:func:`block_node_ranges`).
    ``dacc``: step_real[DACC] at the start of the step (:func:`contact.couple_forces`).
    Compiled twice, for block 0 (into node_f) and for the others (into a copy): a branch on the
    block in every addition made the pile 5-7 % slower (benchmarks/README.md, nineteenth session)."""
    if b == 0:
        _block_items(b, nblk, T, J, C, dacc, nodes, tris, mats, con, joints, step, asm, contact, friction, fracture,
                     False)
    else:
        _block_items(b, nblk, T, J, C, dacc, nodes, tris, mats, con, joints, step, asm, contact, friction, fracture,
                     True)


@ti.func
def _block_items(b, nblk, T, J, C, dacc, nodes: ti.template(), tris: ti.template(), mats: ti.template(),
                 con: ti.template(), joints: ti.template(), step: ti.template(), asm: ti.template(),
                 contact: ti.template(), friction: ti.template(), fracture: ti.template(), copy: ti.template()):
    """:func:`block_forces` for block b, adding into node_f (``copy`` False, block 0) or into
    its copy (``copy`` True) at the nodes of its range (:func:`block_node_ranges`)."""
    N = nodes.node_x.shape[0]
    base = (b - 1) * N
    for e in range(b * T // nblk, (b + 1) * T // nblk):
        f0, f1, f2 = tri_forces(e, nodes, tris, mats, step)
        n = tris.tri_nodes[e]
        add_block_force(nodes, asm, base, n[0], f0, copy)
        add_block_force(nodes, asm, base, n[1], f1, copy)
        add_block_force(nodes, asm, base, n[2], f2, copy)
    if ti.static(fracture):
        for j in range(b * J // nblk, (b + 1) * J // nblk):
            if joints.joint_state[j] == 0:
                eval_joint(j, joints, tris, mats, nodes, step, False)
                gj = joints.joint_g[j]
                nd = joints.joint_nodes[j]
                g0 = vec2(gj[0], gj[1])
                g1 = vec2(gj[2], gj[3])
                add_block_force(nodes, asm, base, nd[0], -g0, copy)
                add_block_force(nodes, asm, base, nd[1], -g1, copy)
                add_block_force(nodes, asm, base, nd[2], g1, copy)
                add_block_force(nodes, asm, base, nd[3], g0, copy)
    if ti.static(contact):
        bwork = vec2(0.0, 0.0)
        lo_c, hi_c = couple_range(b, nblk, C, step)
        for c in range(lo_c, hi_c):
            gA, gB, hit, work = couple_forces(c, dacc, nodes, tris, mats, con, step, friction, fracture)
            bwork += work
            if hit:
                na = tris.tri_nodes[con.couple_a[c]]
                nb = tris.tri_nodes[con.couple_b[c]]
                for r in ti.static(range(3)):
                    add_block_force(nodes, asm, base, na[r], vec2(gA[r, 0], gA[r, 1]), copy)
                    add_block_force(nodes, asm, base, nb[r], vec2(gB[r, 0], gB[r, 1]), copy)
        asm.asm_force[block_work_slot(N, nblk, b)] = bwork


@ti.func
def claim(asm: ti.template(), b, ticket):
    """Take block b (none if b < 0) for the phase of a team launch numbered ``ticket`` (increasing
    within the launch): True for exactly one worker (an atomic max on the block's claim slot,
    whose old value is below the ticket only for the first)."""
    ok = False
    if b >= 0:          # (a nested test: Taichi's ``and`` evaluates both operands)
        ok = ti.atomic_max(asm.asm_sync[sync_claim(b)], ticket) < ticket
    return ok


@ti.func
def nth_block(k, w, nwork, nblk, tail):
    """The k-th block that worker w tries in a phase (k = 0 .. nblk − 1; −1: none), and the new
    ``tail``: first its own blocks w, w + nwork, ... (the same every step, so that their data stay
    in its core's caches), then the others' from the last down (``tail`` starts at nblk − 1),
    which a worker that finished early takes over from a slower one (:func:`claim`).  Block 0 is
    worker 0's alone: its runner adds the loads after its forces, and worker 0 books the loads'
    work of the step before (phase 3 of :func:`team_worker`; no barrier in between)."""
    m = (nblk - 1 - w) // nwork + 1              # worker w's own blocks
    b = w + k * nwork
    if k >= m:
        while tail >= 0 and tail % nwork == w:
            tail -= 1
        b = tail
        tail -= 1
        if b == 0:
            b = -1
    return b, tail


@ti.func
def team_barrier(asm: ti.template(), w, target):
    """Wait until every worker has passed this barrier: asm_sync[0] counts arrivals over the
    launch, and the n-th barrier of ``nwork`` workers is passed at n · nwork.  Arrival is an
    atomic add (x86 atomics are full fences, so what a worker wrote before arriving is seen by
    every worker after it); the wait reads the counter with plain loads, which leave its cache
    line shared while the workers wait (atomic reads took it from core to core at every try),
    and an atomic on the worker's own line of asm_sync (:func:`sync_own`) keeps the load inside
    the loop."""
    ti.atomic_add(asm.asm_sync[0], 1)
    while asm.asm_sync[0] < target:
        ti.atomic_or(asm.asm_sync[sync_own(w)], 0)


@ti.func
def sync_bad(b):
    """asm_sync slot of block b's "bad" flag (non-finite value): a cache line of its own."""
    return SYNC_LINE * (1 + b)


@ti.func
def sync_claim(b):
    """asm_sync slot of block b's claim (:func:`claim`): on block b's line."""
    return SYNC_LINE * (1 + b) + 2


@ti.func
def sync_own(w):
    """asm_sync slot that worker w spins on while it waits at a barrier (on block w's line)."""
    return SYNC_LINE * (1 + w) + 1


@ti.func
def team_worker(w, nwork, nsteps, detect_in, nodes: ti.template(), tris: ti.template(), mats: ti.template(),
                con: ti.template(), det: ti.template(), joints: ti.template(), step: ti.template(),
                asm: ti.template(), feat: ti.template()):
    """Worker w of :func:`taichi_fdem.engine.step.run_steps_blocks`: up to ``nsteps`` steps of the parallel strategy for
    blocks w, w + nwork, ..., in step with the other workers through two barriers per step (three with fracture).
    Every block's work and partial sums are the same whoever runs it, and the partials are
    combined in block order: the results do not depend on nwork.  ``detect_in`` != 0: when
    contact detection is due, worker 0 runs it (the serial broad phase of
    :func:`taichi_fdem.engine.step.detect_serial`, the same couples) while the others wait at a
    barrier, and the launch goes on; 0: the launch ends when detection is due (the host runs
    the parallel broad phase of a large scene)."""
    N = nodes.node_x.shape[0]
    nblk = asm_blocks(N, asm)
    T, J, C = item_counts(tris, joints, step, feat.contact, feat.fracture)
    dt = step.step_dt[None]
    g = step.step_gravity[None]
    bc = step.step_switches[None] & SWITCH_BC
    bc_work = step.step_switches[None] & SWITCH_BC_WORK
    alpha = 0.0
    if ti.static(feat.local_damping):
        alpha = step.step_real[QS_ALPHA]
    # the counters every worker follows, read before the first barrier (worker 0 writes them
    # after the second) and updated identically by every worker
    dacc = step.step_real[DACC]
    time = step.step_real[TIME]
    nonfinite = step.step_int[NONFINITE]
    rebal = step.step_int[REBALANCE]
    nbar = 0
    done = 0
    code = 0
    while done < nsteps:
        if ti.static(feat.contact):
            # 0a. contact detection when due, by worker 0 (small scenes: see the docstring); a
            # couple buffer too small ends the launch before the step (the host grows it)
            if detect_in != 0 and dacc >= step.step_buffer[None]:
                if w == 0:
                    phase_detect_count(nodes, tris, det, con, step)
                    if step.step_int[FOUND] <= con.couple_a.shape[0]:
                        phase_detect_fill(tris, det, con, step, feat.friction)
                nbar += 1
                team_barrier(asm, w, nbar * nwork)
                if step.step_int[FOUND] > con.couple_a.shape[0]:
                    code = 1
                    break
                C = step.step_int[COUPLES]
                dacc = 0.0
                rebal = 0                       # new couples: split anew (as the fill asks)
        # 0b. when due, worker 0 splits the couples anew and sets the blocks' node ranges (as
        # engine.step.phase_blocks does)
        if rebal <= 0:
            if w == 0:
                rebalance_blocks(nblk, T, J, C, nodes, tris, con, joints, step, feat.contact, feat.fracture)
            nbar += 1
            team_barrier(asm, w, nbar * nwork)
            rebal = REBALANCE_STEPS
        rebal -= 1
        # 1. forces: each block's items into its copy (and the loads into node_f after block 0,
        # by the worker that ran it, as in engine.step.step_parallel)
        tail = nblk - 1
        for k in range(nblk):
            b, tail = nth_block(k, w, nwork, nblk, tail)
            if claim(asm, b, nbar + 1):
                block_forces(b, nblk, T, J, C, dacc, nodes, tris, mats, con, joints, step, asm, feat.contact,
                             feat.friction, feat.fracture)
                if ti.static(feat.loads):
                    if b == 0:
                        for q in range(nodes.load_nodes.shape[0]):
                            apply_load(q, time, dt, nodes, step)
        nbar += 1
        team_barrier(asm, w, nbar * nwork)
        # 2. gather and integrate each block's share of the nodes; its maxima and work to its partials.
        # What the forces wrote for the step's end (an inverted triangle, the blocks' contact work)
        # is read here, before the next step's forces can write it again (without a fracture
        # there is no barrier between this step's end and the next step's forces)
        inverted = step.step_int[INVERTED]
        if w == 0:
            book_block_work(N, nblk, asm, step)
        tail = nblk - 1
        for k in range(nblk):
            b, tail = nth_block(k, w, nwork, nblk, tail)
            if claim(asm, b, nbar + 1):
                vmax2, bad, work, local = integrate_span(b * N // nblk, (b + 1) * N // nblk, nodes, joints, asm, step,
                                                         dt, g, bc, bc_work, alpha, 2, feat.local_damping)
                asm.asm_part[3 * b] = vmax2
                asm.asm_part[3 * b + 1] = work
                asm.asm_part[3 * b + 2] = local
                asm.asm_sync[sync_bad(b)] = bad
        nbar += 1
        team_barrier(asm, w, nbar * nwork)
        # 3. the step's counters, from the partials in block order (the same in every worker);
        # worker 0 stores them.  Then the joints' work and the end of intact bonds.
        vm2 = 0.0
        for q in range(nblk):
            vm2 = ti.max(vm2, asm.asm_part[3 * q])
            nonfinite = ti.max(nonfinite, asm.asm_sync[sync_bad(q)])
        vmax = ti.sqrt(vm2)
        dacc += 2.0 * dt * vmax
        time += dt
        if w == 0:
            step.step_real[VMAX] = vmax
            step.step_int[NONFINITE] = nonfinite
            for q in range(nblk):
                if bc_work != 0:
                    step.step_real[WORK_BOUNDARY] += asm.asm_part[3 * q + 1]
                if ti.static(feat.local_damping):
                    step.step_real[WORK_LOCAL] += asm.asm_part[3 * q + 2]
            step.step_real[DACC] = dacc
            step.step_real[TIME] = time
            step.step_int[REBALANCE] = rebal
            if ti.static(feat.loads):
                for k in range(nodes.load_nodes.shape[0]):
                    book_load(k, dt, nodes, step)
        done += 1
        code = 0
        if ti.static(feat.contact):
            if detect_in == 0 and dacc >= step.step_buffer[None]:
                code |= 1
        if nonfinite != 0 or inverted != 0 or vmax > step.step_vlimit[None]:
            code |= 2
        if ti.static(feat.fracture):
            # the joints' work and the end of intact bonds, which the next step's forces read:
            # a third barrier (a scene without fracture needs none: the next step's forces
            # write nothing that a worker still reads here)
            tail = nblk - 1
            for k in range(nblk):
                b, tail = nth_block(k, w, nwork, nblk, tail)
                if claim(asm, b, nbar + 1):
                    for j in range(b * J // nblk, (b + 1) * J // nblk):
                        add_joint_work(j, joints, tris, mats, nodes, step)
            nbar += 1
            team_barrier(asm, w, nbar * nwork)
        if code != 0:
            break
    if ti.static(not feat.fracture):
        nbar += 1
        team_barrier(asm, w, nbar * nwork)     # every worker has read the partials cleared below
    if w == 0:
        asm.asm_sync[1] = done + ti.select(code >= 2, UNSTABLE_BIT, 0) + ti.select(code & 1, DUE_BIT, 0)
        # every worker read the partials before the last barrier: clear them, so that the scratch
        # does not depend on how the steps were launched (a restart compares it)
        for q in range(nblk):
            asm.asm_sync[sync_bad(q)] = 0
            asm.asm_sync[sync_claim(q)] = 0
            for r in ti.static(range(3)):
                asm.asm_part[3 * q + r] = 0.0

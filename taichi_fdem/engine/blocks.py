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
                     QS_ALPHA, RANGE, REBALANCE, REBALANCE_STEPS, SPLIT, SWITCH_BC, SWITCH_BC_WORK, SYNC_LINE,
                     TEAM_CHUNK, TIME, UNSTABLE_BIT, VMAX, WORK_BOUNDARY, WORK_LOCAL)
from .integrate import asm_blocks, block_work_slot, book_block_work, integrate_span
from .joints import add_joint_work, eval_joint
from .loads import LOAD_FORCE, LOAD_VELOCITY, apply_load, book_load
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
    :func:`integrate.asm_blocks`), or at asm_force[n] (``copy`` 2: block 1, base 0 known when
    compiled); a plain read and write (one thread runs a block)."""
    if ti.static(copy == 2):
        asm.asm_force[n] = asm.asm_force[n] + f
    elif ti.static(copy):
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
def block_node_ranges(nblk, T, J, C, nodes: ti.template(), tris: ti.template(), con: ti.template(),
                      joints: ti.template(), step: ti.template(), contact: ti.template(), fracture: ti.template(),
                      loads: ti.template()):
    """step_int[RANGE + 2b], [RANGE + 2b + 1] = [lo, hi): the nodes that block b's items can
    write (block 0 into node_f, b > 0 into its copy of the nodal forces): the nodes of its
    triangles, of its joints and of every couple of its range (:func:`couple_range`; touching or
    not), and for block 0 the nodes of the loads (its runner adds them).  The gather adds each
    copy over its range (:func:`integrate.integrate_span`), and a chunk of the team's
    integration waits for the blocks whose ranges meet it (:func:`integrate_chunk`).  Serial,
    one pass over the items; run with the couple ranges (:func:`rebalance_blocks`, every
    REBALANCE_STEPS steps and after each detection), a function of the state.  (Before the
    twentieth session each block tracked the nodes it wrote in its force loop: a loop-carried
    min and max per item, which made the block with a copy the slower one; benchmarks/README.md.)"""
    for b in range(nblk):
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
        if ti.static(loads):
            if b == 0:
                for k in range(nodes.load_nodes.shape[0]):
                    ld = nodes.load_nodes[k]
                    lo = ti.min(lo, ld[1])
                    hi = ti.max(hi, ld[1] + 1)
                    if ld[0] != LOAD_FORCE and ld[0] != LOAD_VELOCITY:     # a segment's second node
                        lo = ti.min(lo, ld[2])
                        hi = ti.max(hi, ld[2] + 1)
        step.step_int[RANGE + 2 * b] = ti.min(lo, hi)
        step.step_int[RANGE + 2 * b + 1] = hi


@ti.func
def rebalance_blocks(nblk, T, J, C, nodes: ti.template(), tris: ti.template(), con: ti.template(),
                     joints: ti.template(), step: ti.template(), contact: ti.template(), fracture: ti.template(),
                     loads: ti.template()):
    """The blocks' couple ranges (with contact, :func:`rebalance_couples`) and their node ranges
    (:func:`block_node_ranges`), anew."""
    if ti.static(contact):
        rebalance_couples(nblk, C, nodes, tris, con, joints, step, fracture)
    block_node_ranges(nblk, T, J, C, nodes, tris, con, joints, step, contact, fracture, loads)


@ti.func
def block_forces(b, nblk, T, J, C, dacc, p, nodes: ti.template(), tris: ti.template(), mats: ti.template(),
                 con: ti.template(), joints: ti.template(), step: ti.template(), asm: ti.template(),
                 contact: ti.template(), friction: ti.template(), fracture: ti.template(), many: ti.template()):
    """Block b's share of :func:`taichi_fdem.engine.step.phase_blocks`: the triangles and the joints of its contiguous
    range by count, and the couples of its range by cost (:func:`couple_range`), added into its
    copy of the nodal forces; its contact work to its entry of asm_force for a step of parity p
    (:func:`integrate.block_work_slot`).  The gather adds a
    block's copy over the nodes its items can write (:func:`block_node_ranges`).
    ``dacc``: step_real[DACC] at the start of the step (:func:`contact.couple_forces`).
    Compiled for block 0 (into node_f), block 1 (into the first copy, at offset 0) and, with
    more than two blocks (``many``), the others (into a copy at a runtime offset): a branch on
    the block in every addition made the pile 5-7 % slower (benchmarks/README.md, nineteenth
    session), and the runtime offset of block 1's copy made the 100k pile 1.12x slower on two
    workers (twenty-first session)."""
    if b == 0:
        _block_items(b, nblk, T, J, C, dacc, p, nodes, tris, mats, con, joints, step, asm, contact, friction,
                     fracture, False)
    elif ti.static(not many):
        _block_items(b, nblk, T, J, C, dacc, p, nodes, tris, mats, con, joints, step, asm, contact, friction,
                     fracture, 2)
    elif b == 1:
        _block_items(b, nblk, T, J, C, dacc, p, nodes, tris, mats, con, joints, step, asm, contact, friction,
                     fracture, 2)
    else:
        _block_items(b, nblk, T, J, C, dacc, p, nodes, tris, mats, con, joints, step, asm, contact, friction,
                     fracture, True)


@ti.func
def _block_items(b, nblk, T, J, C, dacc, p, nodes: ti.template(), tris: ti.template(), mats: ti.template(),
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
        asm.asm_force[block_work_slot(N, nblk, b, p)] = bwork


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
def sync_claim(b):
    """asm_sync slot of block b's claim (:func:`claim`): on block b's line."""
    return SYNC_LINE * (1 + b) + 2


@ti.func
def sync_own(w):
    """asm_sync slot that worker w spins on while it waits (on block w's line)."""
    return SYNC_LINE * (1 + w) + 1


@ti.func
def sync_inverted(b, p):
    """asm_sync slot of block b's copy of step_int[INVERTED] after its forces of a step of parity p."""
    return SYNC_LINE * (1 + b) + 4 + p


@ti.func
def sync_bad(w, p):
    """asm_sync slot of worker w's largest non-finite flag over its chunks of a step of parity p."""
    return SYNC_LINE * (1 + w) + 6 + p


@ti.func
def sync_done(nblk, b):
    """asm_sync slot of block b's "done" flag: the ticket of the last force phase in which block
    b has added all its forces (:func:`integrate_chunk`); a cache line of its own."""
    return SYNC_LINE * (1 + nblk + b)


@ti.func
def sync_chunk(nblk, c):
    """asm_sync slot of node chunk c's claim (:func:`team_chunks`), after the flags' lines."""
    return SYNC_LINE * (1 + 2 * nblk) + c


@ti.func
def part_vmax(w, p):
    """asm_part slot of worker w's largest |v|² over its chunks of a step of parity p (a line
    apart)."""
    return 8 * (2 * w + p)


@ti.func
def part_chunk(nblk, nch, c, p):
    """asm_part slots (2) of chunk c's constraint and local-damping work in a step of parity p."""
    return 16 * nblk + 2 * (p * nch + c)


@ti.func
def wait_flag(asm: ti.template(), w, slot, ticket):
    """Wait until asm_sync[slot] >= ticket (plain loads, as in :func:`team_barrier`), then fence:
    what its writer stored before raising it is read after."""
    while asm.asm_sync[slot] < ticket:
        ti.atomic_or(asm.asm_sync[sync_own(w)], 0)
    ti.atomic_or(asm.asm_sync[sync_own(w)], 0)


@ti.func
def chunk_count(nblk, N):
    """Node chunks of the team's integration: nblk segments of the nodes by count (as the
    blocks' triangles), each cut into the same number of chunks of at most TEAM_CHUNK nodes."""
    return nblk * ((N // nblk + TEAM_CHUNK) // TEAM_CHUNK)


@ti.func
def chunk_nodes(c, nblk, nch, N):
    """The nodes [lo, hi) of chunk c of nch (:func:`chunk_count`): chunk i of segment s =
    c // (nch / nblk), the segment's nodes cut evenly."""
    m = nch // nblk
    s = c // m
    i = c % m
    s_lo = s * N // nblk
    s_len = (s + 1) * N // nblk - s_lo
    return s_lo + i * s_len // m, s_lo + (i + 1) * s_len // m


@ti.func
def integrate_chunk(c, p, w, ticket, nblk, nch, N, nodes: ti.template(), joints: ti.template(), asm: ti.template(),
                    step: ti.template(), dt, g, bc, bc_work, alpha, local_damping: ti.template()):
    """Gather and integrate node chunk c (:func:`chunk_nodes`) of a step of parity p, once the
    blocks that can write its nodes have added their forces (every block whose node range
    meets the chunk, :func:`block_node_ranges`); its work terms to its
    partials (when booked).  Returns its largest |v|² and non-finite flag
    (:func:`integrate.integrate_span`)."""
    lo, hi = chunk_nodes(c, nblk, nch, N)
    for b in range(nblk):
        b_lo = step.step_int[RANGE + 2 * b]
        b_hi = step.step_int[RANGE + 2 * b + 1]
        # (block 0's range empty: a checkpoint written before its range was kept; wait for it)
        if (b_lo < hi and b_hi > lo) or (b == 0 and b_lo >= b_hi):
            wait_flag(asm, w, sync_done(nblk, b), ticket)
    vmax2, bad, work, local = integrate_span(lo, hi, nodes, joints, asm, step, dt, g, bc, bc_work, alpha, 2,
                                             local_damping)
    k = part_chunk(nblk, nch, c, p)
    if bc_work != 0:
        asm.asm_part[k] = work
    if ti.static(local_damping):
        asm.asm_part[k + 1] = local
    return vmax2, bad


@ti.func
def team_chunks(w, nwork, p, ticket, nblk, N, nodes: ti.template(), joints: ti.template(), asm: ti.template(),
                step: ti.template(), dt, g, bc, bc_work, alpha, local_damping: ti.template()):
    """Phase 2 of :func:`team_worker`: gather and integrate the nodes in chunks of at most
    TEAM_CHUNK (:func:`chunk_nodes`, :func:`integrate_chunk`), each as soon as the blocks that
    write its nodes are done, by whichever worker claims it (an atomic max of the ticket on its claim slot).  The chunks
    make nblk contiguous segments: worker w takes the chunks of its own segments w, w + nwork,
    ... from the end away from its neighbours (the nodes no other block writes come first, so a
    worker whose blocks finish early integrates them while the others still add forces), then
    the other segments' chunks from the other end, until it meets a claimed chunk (their owner
    has claimed every chunk from its end to that one).  No barrier between the forces and the
    integration.  A chunk's sums are the same whoever runs it; the worker's largest |v|² and
    non-finite flag (maxima: exact in any order) go to its slots of parity p."""
    nch = chunk_count(nblk, N)
    vm2 = 0.0
    bad = 0
    for k in range(2):
        # k = 0: worker w's own segments; k = 1: the others', from the last down
        s = w
        if k == 1:
            s = nblk - 1
        while s >= 0 and s < nblk:
            if (k == 0) or (s % nwork != w):
                c0 = s * (nch // nblk)
                c1 = c0 + nch // nblk
                up = (s % 2 == 0) == (k == 0)
                for i in range(c1 - c0):
                    c = c0 + i
                    if not up:
                        c = c1 - 1 - i
                    if ti.atomic_max(asm.asm_sync[sync_chunk(nblk, c)], ticket) >= ticket:
                        break
                    v2, bd = integrate_chunk(c, p, w, ticket, nblk, nch, N, nodes, joints, asm, step, dt, g, bc,
                                             bc_work, alpha, local_damping)
                    vm2 = ti.max(vm2, v2)
                    bad = ti.max(bad, bd)
            if k == 0:
                s += nwork
            else:
                s -= 1
    asm.asm_part[part_vmax(w, p)] = vm2
    asm.asm_sync[sync_bad(w, p)] = bad


@ti.func
def team_worker(w, nwork, nsteps, detect_in, nodes: ti.template(), tris: ti.template(), mats: ti.template(),
                con: ti.template(), det: ti.template(), joints: ti.template(), step: ti.template(),
                asm: ti.template(), feat: ti.template()):
    """Worker w of :func:`taichi_fdem.engine.step.run_steps_blocks`: up to ``nsteps`` steps of the
    parallel strategy for blocks w, w + nwork, ..., in step with the other workers through one
    barrier per step (two with fracture): a node chunk is integrated once the blocks that write
    its nodes have raised their "done" flags (:func:`team_chunks`).  Before the twenty-first
    session a barrier also separated the forces from the integration, and the nodes were
    integrated in nblk fixed shares.  Every block's and every chunk's work and partial sums are
    the same whoever runs it, and the partials are combined in chunk and block order: the
    results do not depend on nwork.  ``detect_in`` != 0: when
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
    # after it) and updated identically by every worker
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
                rebalance_blocks(nblk, T, J, C, nodes, tris, con, joints, step, feat.contact, feat.fracture,
                                 feat.loads)
            nbar += 1
            team_barrier(asm, w, nbar * nwork)
            rebal = REBALANCE_STEPS
        rebal -= 1
        # 1. forces: each block's items into its copy (and the loads into node_f after block 0,
        # by the worker that ran it, as in engine.step.step_parallel); then the block's copy of the
        # inverted-triangle flag and its "done" flag (an atomic: a fence after its forces)
        p = done % 2                          # the step's parity: its partials and contact work
        ticket = nbar + 1
        tail = nblk - 1
        for k in range(nblk):
            b, tail = nth_block(k, w, nwork, nblk, tail)
            if claim(asm, b, ticket):
                block_forces(b, nblk, T, J, C, dacc, p, nodes, tris, mats, con, joints, step, asm, feat.contact,
                             feat.friction, feat.fracture, feat.many_blocks)
                if ti.static(feat.loads):
                    if b == 0:
                        for q in range(nodes.load_nodes.shape[0]):
                            apply_load(q, time, dt, nodes, step)
                asm.asm_sync[sync_inverted(b, p)] = step.step_int[INVERTED]
                ti.atomic_max(asm.asm_sync[sync_done(nblk, b)], ticket)
        # 2. gather and integrate the nodes chunk by chunk, each once the blocks that write it are
        # done (no barrier in between); each chunk's maxima and work to its partials of parity p
        team_chunks(w, nwork, p, ticket, nblk, N, nodes, joints, asm, step, dt, g, bc, bc_work, alpha,
                    feat.local_damping)
        nbar += 1
        team_barrier(asm, w, nbar * nwork)
        # 3. the step's counters, from the partials in chunk and block order (the same in every
        # worker; what the next step writes goes to the other parity's slots); worker 0 stores
        # them.  Then the joints' work and the end of intact bonds.  A triangle that inverted in
        # this step is in the copy of its own block's runner, made after its forces: whether any
        # did does not depend on which block finished first
        vm2 = 0.0
        for q in range(nwork):
            vm2 = ti.max(vm2, asm.asm_part[part_vmax(q, p)])
            nonfinite = ti.max(nonfinite, asm.asm_sync[sync_bad(q, p)])
        inverted = 0
        for q in range(nblk):
            inverted = ti.max(inverted, asm.asm_sync[sync_inverted(q, p)])
        vmax = ti.sqrt(vm2)
        dacc += 2.0 * dt * vmax
        time += dt
        if w == 0:
            book_block_work(N, nblk, asm, step, p)
            step.step_real[VMAX] = vmax
            step.step_int[NONFINITE] = nonfinite
            nch = chunk_count(nblk, N)
            for c in range(nch):
                if bc_work != 0:
                    step.step_real[WORK_BOUNDARY] += asm.asm_part[part_chunk(nblk, nch, c, p)]
                if ti.static(feat.local_damping):
                    step.step_real[WORK_LOCAL] += asm.asm_part[part_chunk(nblk, nch, c, p) + 1]
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
            # a second barrier (a scene without fracture needs none: the next step's forces
            # write nothing that a worker still reads here, the parity-p slots aside)
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
        for k in range(SYNC_LINE, asm.asm_sync.shape[0]):
            asm.asm_sync[k] = 0
        for k in range(asm.asm_part.shape[0]):
            asm.asm_part[k] = 0.0

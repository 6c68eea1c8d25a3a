"""The team of worker threads that runs the block assembly of the parallel strategy many steps
per launch (:func:`taichi_fdem.engine.step.run_steps_blocks`, FDEM_SPEC §6.1).

Each worker runs its own blocks' forces (:mod:`taichi_fdem.engine.blocks`), then the gather and
integration of chunks of the nodes, each as soon as the blocks that write it are done
(:func:`team_chunks`); one barrier per step (two with fracture) on an atomic counter, contact
detection inside the launch split between the workers (:func:`team_detect`).  Every block's
and chunk's work and partial sums are the same whoever runs them, so the results are the same
bits for any number of workers.
"""
import taichi as ti

from .blocks import (block_forces, chunk_count, chunk_nodes, chunk_skip, item_counts,  # noqa: F401 (re-exported)
                     rebalance_blocks, sync_chunk)
from .detection import (bin_circle, bucket_starts, count_prefix, detected, fill_partners, keep_old_couple,
                        keep_old_start, prepare_circle, scan_partners, sort_bucket)
from .groups import (COUPLES, DACC, DUE_BIT, FOUND, INVERTED, NONFINITE, QS_ALPHA, REBALANCE,
                     REBALANCE_STEPS, RMAX, SWITCH_BC, SWITCH_BC_WORK, SYNC_LINE, TIME, UNSTABLE_BIT, VMAX,
                     WORK_BOUNDARY, WORK_LOCAL)
from .integrate import asm_blocks, book_block_work, integrate_span
from .joints import add_joint_work
from .loads import apply_load, book_load


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
def integrate_chunk(c, p, w, ticket, nblk, nch, N, vm2, bad, nodes: ti.template(), joints: ti.template(),
                    asm: ti.template(), step: ti.template(), dt, g, bc, bc_work, alpha, local_damping: ti.template()):
    """Gather and integrate node chunk c (:func:`chunk_nodes`) of a step of parity p, once the
    blocks that can write its nodes have added their forces (every block but those that
    :func:`blocks.chunk_skip` knows write none of its nodes); its work terms to its
    partials (when booked).  Returns the worker's largest |v|² and non-finite flag so far,
    ``vm2`` and ``bad`` with the chunk's (:func:`integrate.integrate_span`)."""
    lo, hi = chunk_nodes(c, nblk, nch, N)
    skip = chunk_skip(c, nblk, nch, asm)
    for b in range(nblk):
        if ((skip >> b) & 1) == 0:
            wait_flag(asm, w, sync_done(nblk, b), ticket)
    vmax2, chunk_bad, work, local = integrate_span(lo, hi, nodes, joints, asm, step, dt, g, bc, bc_work, alpha,
                                                   2, local_damping)
    k = part_chunk(nblk, nch, c, p)
    if bc_work != 0:
        asm.asm_part[k] = work
    if ti.static(local_damping):
        asm.asm_part[k + 1] = local
    return ti.max(vm2, vmax2), ti.max(bad, chunk_bad)


@ti.func
def chunk_ready(c, nblk, nch, ticket, asm: ti.template()):
    """Have the blocks that may write chunk c's nodes all added their forces (no wait)?"""
    skip = chunk_skip(c, nblk, nch, asm)
    ready = True
    for b in range(nblk):
        if ((skip >> b) & 1) == 0 and asm.asm_sync[sync_done(nblk, b)] < ticket:
            ready = False
    return ready


@ti.func
def team_chunks(w, nwork, p, ticket, nblk, N, nodes: ti.template(), joints: ti.template(), asm: ti.template(),
                step: ti.template(), dt, g, bc, bc_work, alpha, local_damping: ti.template()):
    """Phase 2 of :func:`team_worker`: gather and integrate the nodes in chunks of at most
    TEAM_CHUNK (:func:`blocks.chunk_nodes`, :func:`integrate_chunk`), each once the blocks that
    write its nodes are done, by whichever worker claims it (an atomic max of the ticket on its
    claim slot).  The chunks make nblk contiguous segments.  Worker w takes the chunks of its own
    segments w, w + nwork, ... from the end away from its neighbours, skipping those whose
    blocks are not done yet (it integrates the nodes the other blocks do not write while they
    still add forces), then the skipped ones, waiting for their blocks (it stops at a chunk
    another worker claimed: that one came from the other end, past every chunk beyond); then
    every chunk of the other segments not claimed yet, from the other end.  No barrier between
    the forces and the integration.  A chunk's sums are the same whoever runs it; the worker's
    largest |v|² and non-finite flag (maxima: exact in any order) go to its slots of parity p."""
    nch = chunk_count(nblk, N)
    m = nch // nblk
    vm2 = 0.0
    bad = 0
    for k in range(2):
        # k = 0: worker w's own segments; k = 1: the others', from the last down
        s = w
        if k == 1:
            s = nblk - 1
        while s >= 0 and s < nblk:
            if (k == 0) or (s % nwork != w):
                up = (s % 2 == 0) == (k == 0)
                first = m                        # the own chunks skipped (in walking order)
                last = -1
                for i in range(m):
                    c = s * m + i
                    if not up:
                        c = s * m + m - 1 - i
                    go = True
                    if k == 0:
                        if not chunk_ready(c, nblk, nch, ticket, asm):
                            first = ti.min(first, i)
                            last = i
                            go = False
                    elif asm.asm_sync[sync_chunk(nblk, c)] >= ticket:       # claimed (a plain read)
                        go = False
                    if go:
                        if ti.atomic_max(asm.asm_sync[sync_chunk(nblk, c)], ticket) >= ticket:
                            if k == 0:
                                break
                        else:
                            vm2, bad = integrate_chunk(c, p, w, ticket, nblk, nch, N, vm2, bad, nodes, joints, asm,
                                                       step, dt, g, bc, bc_work, alpha, local_damping)
                for i in range(first, last + 1):
                    c = s * m + i
                    if not up:
                        c = s * m + m - 1 - i
                    if asm.asm_sync[sync_chunk(nblk, c)] < ticket:          # (a plain read first)
                        if ti.atomic_max(asm.asm_sync[sync_chunk(nblk, c)], ticket) < ticket:
                            vm2, bad = integrate_chunk(c, p, w, ticket, nblk, nch, N, vm2, bad, nodes, joints, asm,
                                                       step, dt, g, bc, bc_work, alpha, local_damping)
            if k == 0:
                s += nwork
            else:
                s -= 1
    asm.asm_part[part_vmax(w, p)] = vm2
    asm.asm_sync[sync_bad(w, p)] = bad


@ti.func
def _share(w, nwork, n):
    """Worker w's share [lo, hi) of n items."""
    return w * n // nwork, (w + 1) * n // nwork


@ti.func
def team_detect(w, nwork, nbar, nodes: ti.template(), tris: ti.template(), det: ti.template(), con: ti.template(),
                step: ti.template(), asm: ti.template(), friction: ti.template()):
    """Contact detection inside a team launch (the broad phase of :mod:`taichi_fdem.engine.detection`),
    each loop over the contact triangles, the hashed buckets and the old couples shared out
    between the workers, separated by barriers; the two prefix sums (bucket starts, couple
    counts) by worker 0.  The same couples in the same order as the serial broad phase (each
    bucket is sorted by triangle after the binning), so the same bits.  Returns the barriers'
    count and whether the couples fit the buffer (if not, nothing is written: the launch ends
    and the host grows the buffer and detects again).  (Before the twenty-first session worker 0
    ran the whole detection while the others waited.)"""
    K = det.contact_tri.shape[0]
    H = det.det_bucket.shape[0]
    k0, k1 = _share(w, nwork, K)
    h0, h1 = _share(w, nwork, H)
    if w == 0:
        step.step_real[RMAX] = 0.0
    nbar += 1
    team_barrier(asm, w, nbar * nwork)
    for k in range(k0, k1):                  # bounding circles; r_max (an atomic max: exact)
        prepare_circle(k, det, tris, nodes, step)
    for h in range(h0, h1):
        det.det_bucket[h] = ti.Vector([0, 0])
    nbar += 1
    team_barrier(asm, w, nbar * nwork)
    for k in range(k0, k1):                  # counting sort: counts and slots
        bin_circle(k, det, step)
    nbar += 1
    team_barrier(asm, w, nbar * nwork)
    if w == 0:
        bucket_starts(det)
    nbar += 1
    team_barrier(asm, w, nbar * nwork)
    for k in range(k0, k1):
        bn = det.det_sort[k]
        det.det_sort[det.det_bucket[bn[0]][0] + bn[1]][2] = k
    nbar += 1
    team_barrier(asm, w, nbar * nwork)
    for h in range(h0, h1):
        sort_bucket(h, det)
    nbar += 1
    team_barrier(asm, w, nbar * nwork)
    for k in range(k0, k1):
        det.det_cnew[k] = scan_partners(k, True, det, con, tris, step, 0, False)
    nbar += 1
    team_barrier(asm, w, nbar * nwork)
    if w == 0:
        count_prefix(det, step)
    nbar += 1
    team_barrier(asm, w, nbar * nwork)
    fits = step.step_int[FOUND] <= con.couple_a.shape[0]
    if fits:
        if ti.static(friction):
            # the previous couples and their slip history, kept before the fill overwrites them
            j0, j1 = _share(w, nwork, K + 1)
            for k in range(j0, j1):
                keep_old_start(k, det)
            c0, c1 = _share(w, nwork, step.step_int[COUPLES])
            for c in range(c0, c1):
                keep_old_couple(c, det, con)
            nbar += 1
            team_barrier(asm, w, nbar * nwork)
        for k in range(k0, k1):
            fill_partners(k, det, con, tris, step, friction)
        c0, c1 = _share(w, nwork, det.det_cnew[K])
        for c in range(c0, c1):
            con.couple_skip[c] = 0.0          # no certificate of separation (dacc restarts at 0)
        if w == 0:
            detected(step)
        nbar += 1
        team_barrier(asm, w, nbar * nwork)
    return nbar, fits


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
    results do not depend on nwork.  ``detect_in`` != 0: when contact detection is due, the
    team runs it (:func:`team_detect`, the same couples as the serial broad phase of
    :func:`taichi_fdem.engine.step.detect_serial`) and the launch goes on; 0: the launch ends
    when detection is due (the host runs the parallel broad phase of a large scene)."""
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
            # 0a. contact detection when due, by the team (small scenes: see the docstring); a
            # couple buffer too small ends the launch before the step (the host grows it)
            if detect_in != 0 and dacc >= step.step_buffer[None]:
                nbar, fits = team_detect(w, nwork, nbar, nodes, tris, det, con, step, asm, feat.friction)
                if not fits:
                    code = 1
                    break
                C = step.step_int[COUPLES]
                dacc = 0.0
                rebal = 0                       # new couples: split anew (as the fill asks)
        # 0b. when due, worker 0 splits the couples anew and sets the blocks' node ranges (as
        # engine.step.phase_blocks does)
        if rebal <= 0:
            if w == 0:
                rebalance_blocks(nblk, T, J, C, nodes, tris, con, joints, step, asm, feat.contact, feat.fracture,
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
        for k in range(SYNC_LINE, sync_chunk(nblk, chunk_count(nblk, N))):     # (not the chunks' masks)
            asm.asm_sync[k] = 0
        for k in range(asm.asm_part.shape[0]):
            asm.asm_part[k] = 0.0

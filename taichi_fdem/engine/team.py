"""The team launch of the block assembly on the CPU (:func:`taichi_fdem.engine.step.run_steps_blocks`,
docs/theory/elements.md §6.1): many steps per launch, run by a team of worker threads.

A step is a sequence of **stages**, each a set of independent **units**: PRE (detection when
due, the couple split: 1 unit), FORCE (block b's forces: one unit per block), INTEG (gather and
integrate node chunk c: one per chunk), JWORK (block b's joints' work: one per block).  A worker
claims a unit with an atomic max of the stage's ticket on the unit's claim slot, so each unit
runs once and its results do not depend on who ran it; the worker that completes a stage's last
unit ends the stage (the step's counters, from the chunks' partials in chunk order) and
publishes the next.  So the bits are the same for any number of workers, and no worker waits
for work nobody has started: if the runtime runs the workers one after the other, the first
does everything.

Every wait is bounded (``spin_max`` tries): past it a worker raises the abort flag, the others
finish their stage, and the launch returns with ``ABORT_BIT`` at a stage boundary, which the
host resumes with one worker (the same bits).  Every synchronising access is an i32 atomic
read-modify-write, which Taichi's LLVM back end emits sequentially consistent: what a worker
wrote before completing a unit is visible to every worker that reads the stage counter after
it, on any architecture.
"""
import taichi as ti

from .blocks import block_forces, chunk_count, chunk_nodes, item_counts, rebalance_blocks
from .detection import phase_detect_count, phase_detect_fill
from .groups import (BUFFER, COUPLES, DACC, DT, FOUND, INVERTED, NONFINITE, QS_ALPHA, REBALANCE, REBALANCE_STEPS,
                     SWITCH_BC, SWITCH_BC_WORK, SWITCHES, SYNC_LINE, TIME, VLIMIT, VMAX, WORK_BOUNDARY, WORK_LOCAL)
from .integrate import asm_blocks, book_block_work, gravity, integrate_span
from .joints import add_joint_work
from .loads import apply_load, book_load

# the stages of a step
PRE, FORCE, INTEG, JWORK, END = 0, 1, 2, 3, 4

# asm_sync slots: line 0 the stage word and what it publishes, line 1 the completion count,
# then one claim slot per unit, then each chunk's non-finite flag
SYNC_STAGE = 0          # KINDS · (stages begun) + the stage's kind; only grows: the claims' ticket
KINDS = 8
SYNC_ABORT = 2          # a worker waited past the bound
SYNC_STEPS = 3          # steps completed since the first launch of this batch
SYNC_START = 4          # SYNC_STEPS when this launch began
SYNC_CODE = 5           # bit 0: detection due (or a couple buffer too small); bit 1: unstable
SYNC_DONE = SYNC_LINE   # units of the current stage completed
SYNC_CLAIM = 2 * SYNC_LINE


@ti.func
def sync_get(asm: ti.template(), k):
    """An atomic read of asm_sync[k] (a read-modify-write: sequentially consistent)."""
    return ti.atomic_add(asm.asm_sync[k], 0)


@ti.func
def stage_units(kind, nblk, nch):
    """Units of a stage."""
    n = 1
    if kind == FORCE or kind == JWORK:
        n = nblk
    elif kind == INTEG:
        n = nch
    return n


@ti.func
def unit_of(kind, k, w, nwork, n):
    """The k-th unit worker w tries in a stage of n units: first its own share (blocks w, w + 1,
    ...; chunks from w · n / nwork), so that a block's or chunk's data tend to stay in one core's
    cache, then the rest in order."""
    first = w
    if kind == INTEG:
        first = w * n // nwork
    return (first + k) % n


@ti.func
def step_start(detect_in, step: ti.template(), feat: ti.template()):
    """The first stage of a step: PRE when contact detection is due inside the launch or the
    couples are to be split anew, FORCE otherwise."""
    kind = FORCE
    if step.step_int[REBALANCE] <= 0:
        kind = PRE
    if ti.static(feat.contact):
        if detect_in != 0 and step.step_real[DACC] >= step.step_real[BUFFER]:
            kind = PRE
    return kind


@ti.func
def run_pre(nblk, T, J, C, detect_in, G: ti.template(), feat: ti.template()):
    """Stage PRE: contact detection when due (the serial broad phase of
    :func:`taichi_fdem.engine.step.detect_serial`: the same couples in the same order; a buffer
    too small sets code bit 0 and writes nothing), then the couple split when due."""
    fits = True
    couples = C
    if ti.static(feat.contact):
        if detect_in != 0 and G.step.step_real[DACC] >= G.step.step_real[BUFFER]:
            phase_detect_count(G.nodes, G.tris, G.contact, G.detect, G.step)
            if G.step.step_int[FOUND] <= G.contact.couple_a.shape[0]:
                phase_detect_fill(G.tris, G.contact, G.detect, G.step, feat.friction)
                couples = G.step.step_int[COUPLES]
            else:
                fits = False
                G.asm.asm_sync[SYNC_CODE] |= 1
    if fits and G.step.step_int[REBALANCE] <= 0:
        rebalance_blocks(nblk, T, J, couples, G.nodes, G.tris, G.contact, G.joints, G.step, feat)
        G.step.step_int[REBALANCE] = REBALANCE_STEPS


@ti.func
def run_integ(u, nblk, nch, nodes: ti.template(), joints: ti.template(), step: ti.template(), asm: ti.template(),
              feat: ti.template()):
    """Stage INTEG, unit u: node chunk u's gather and integration, its maxima and work terms to
    its partials (asm_part) and its non-finite flag to its slot of asm_sync."""
    alpha = 0.0
    if ti.static(feat.local_damping):
        alpha = step.step_real[QS_ALPHA]
    lo, hi = chunk_nodes(u, nch, nodes.node_x.shape[0])
    vmax2, bad, work, local = integrate_span(lo, hi, nodes, joints, asm, step, step.step_real[DT],
                                             gravity(step), step.step_int[SWITCHES] & SWITCH_BC,
                                             step.step_int[SWITCHES] & SWITCH_BC_WORK, alpha, 2,
                                             feat.local_damping)
    asm.asm_part[3 * u] = vmax2
    asm.asm_part[3 * u + 1] = work
    asm.asm_part[3 * u + 2] = local
    asm.asm_sync[SYNC_CLAIM + ti.max(nblk, nch) + u] = bad


@ti.func
def run_unit(kind, u, nblk, nch, detect_in, G: ti.template(), feat: ti.template()):
    """Unit u of a stage (module docstring) on the groups ``G``.  PRE: :func:`run_pre`.  FORCE:
    block u's forces, and the loads after block 0's.  INTEG: :func:`run_integ`.  JWORK: the
    work of block u's joints and the end of their intact bonds."""
    T, J, C = item_counts(G.tris, G.joints, G.step, feat)
    if kind == PRE:
        run_pre(nblk, T, J, C, detect_in, G, feat)
    elif kind == FORCE:
        block_forces(u, nblk, T, J, C, G.step.step_real[DACC], 0, G.nodes, G.tris, G.mats, G.contact, G.joints,
                     G.step, G.asm, feat)
        if ti.static(feat.loads):
            if u == 0:
                for q in range(G.nodes.load_nodes.shape[0]):
                    apply_load(q, G.step.step_real[TIME], G.step.step_real[DT], G.nodes, G.step)
    elif kind == INTEG:
        run_integ(u, nblk, nch, G.nodes, G.joints, G.step, G.asm, feat)
    else:
        for j in range(u * J // nblk, (u + 1) * J // nblk):
            add_joint_work(j, G.nodes, G.tris, G.mats, G.joints, G.step)


@ti.func
def end_step(nsteps, detect_in, step: ti.template(), asm: ti.template(), feat: ti.template()):
    """The stage after a completed step: END when the launch's steps are done or its code is
    set, else the next step's first stage."""
    kind = END
    if asm.asm_sync[SYNC_CODE] == 0 and asm.asm_sync[SYNC_STEPS] - asm.asm_sync[SYNC_START] < nsteps:
        kind = step_start(detect_in, step, feat)
    return kind


@ti.func
def end_integ(nblk, nch, detect_in, nodes: ti.template(), step: ti.template(), asm: ti.template(),
              feat: ti.template()):
    """What ends stage INTEG: the step's counters from the chunks' partials in chunk order (the
    same for any team), the blocks' contact work and the loads' work booked, time and D_acc
    advanced, and the code set (bit 0 detection due, bit 1 unstable)."""
    N = nodes.node_x.shape[0]
    dt = step.step_real[DT]
    bc_work = step.step_int[SWITCHES] & SWITCH_BC_WORK
    vm2 = 0.0
    bad = step.step_int[NONFINITE]
    for c in range(nch):
        vm2 = ti.max(vm2, asm.asm_part[3 * c])
        bad = ti.max(bad, asm.asm_sync[SYNC_CLAIM + ti.max(nblk, nch) + c])
        if bc_work != 0:
            step.step_real[WORK_BOUNDARY] += asm.asm_part[3 * c + 1]
        if ti.static(feat.local_damping):
            step.step_real[WORK_LOCAL] += asm.asm_part[3 * c + 2]
    vmax = ti.sqrt(vm2)
    book_block_work(N, nblk, asm, step, 0)
    if ti.static(feat.loads):
        for k in range(nodes.load_nodes.shape[0]):
            book_load(k, dt, nodes, step)
    step.step_real[VMAX] = vmax
    step.step_int[NONFINITE] = bad
    step.step_real[DACC] += 2.0 * dt * vmax
    step.step_real[TIME] += dt
    step.step_int[REBALANCE] -= 1
    asm.asm_sync[SYNC_STEPS] += 1
    if ti.static(feat.contact):
        if detect_in == 0 and step.step_real[DACC] >= step.step_real[BUFFER]:
            asm.asm_sync[SYNC_CODE] |= 1
    if bad != 0 or step.step_int[INVERTED] != 0 or vmax > step.step_real[VLIMIT]:
        asm.asm_sync[SYNC_CODE] |= 2


@ti.func
def end_stage(kind, nblk, nch, nsteps, flags, nodes: ti.template(), step: ti.template(), asm: ti.template(),
              feat: ti.template()):
    """Run by the worker that completed the stage's last unit: what ends the stage, then the next
    stage published (the completion count reset, then the stage word advanced to the next kind).
    ``flags`` bit 2: raise the abort flag too (the launch stops after this stage: a test of
    the resumption)."""
    detect_in = flags & 1
    nxt = END
    if kind == PRE:
        if asm.asm_sync[SYNC_CODE] == 0:
            nxt = FORCE
    elif kind == FORCE:
        nxt = INTEG
    elif kind == INTEG:
        end_integ(nblk, nch, detect_in, nodes, step, asm, feat)
        nxt = JWORK
        if ti.static(not feat.fracture):
            nxt = end_step(nsteps, detect_in, step, asm, feat)
    else:
        nxt = end_step(nsteps, detect_in, step, asm, feat)
    if flags & 4:
        ti.atomic_max(asm.asm_sync[SYNC_ABORT], 1)
    asm.asm_sync[SYNC_DONE] = 0
    ti.atomic_add(asm.asm_sync[SYNC_STAGE], KINDS + nxt - kind)


@ti.func
def team_worker(w, nwork, nsteps, flags, spin_max, G: ti.template(), feat: ti.template()):
    """Worker w of a team of ``nwork``: claim and run units of the current stage (first its own
    share, :func:`unit_of`), the last one of a stage also ending it (:func:`end_stage`); when
    nothing is left to claim, wait at most ``spin_max`` tries for the stage to end, else raise
    the abort flag.  Leaves at END or when the abort flag is up (after an abort the others
    finish the stage they are in: a launch always stops at a stage boundary).  ``flags``: as
    :func:`taichi_fdem.engine.step.run_steps_blocks`; ``G``: the groups
    (:class:`~taichi_fdem.engine.bundle.Groups`)."""
    detect_in = flags & 1
    N = G.nodes.node_x.shape[0]
    nblk = asm_blocks(N, G.asm)
    nch = chunk_count(N)
    while True:
        stage = sync_get(G.asm, SYNC_STAGE)
        kind = stage % KINDS
        if kind == END or sync_get(G.asm, SYNC_ABORT) != 0:
            break
        n = stage_units(kind, nblk, nch)
        ticket = stage + 1
        for k in range(n):
            u = unit_of(kind, k, w, nwork, n)
            if ti.atomic_max(G.asm.asm_sync[SYNC_CLAIM + u], ticket) < ticket:
                run_unit(kind, u, nblk, nch, detect_in, G, feat)
                if ti.atomic_add(G.asm.asm_sync[SYNC_DONE], 1) == n - 1:
                    end_stage(kind, nblk, nch, nsteps, flags, G.nodes, G.step, G.asm, feat)
        tries = 0
        while sync_get(G.asm, SYNC_STAGE) == stage:
            tries += 1
            if tries >= spin_max:
                ti.atomic_max(G.asm.asm_sync[SYNC_ABORT], 1)
                break


@ti.func
def team_begin(resume, detect_in, step: ti.template(), asm: ti.template(), feat: ti.template()):
    """Before the workers start (a serial task): a fresh launch starts a step; a resumed one
    (after an abort) lowers the flag and carries on from the stage the team left."""
    if resume == 0:
        asm.asm_sync[SYNC_STAGE] = step_start(detect_in, step, feat)
    asm.asm_sync[SYNC_ABORT] = 0
    asm.asm_sync[SYNC_START] = asm.asm_sync[SYNC_STEPS]


@ti.func
def team_end(asm: ti.template(), unstable_bit, due_bit, abort_bit, timeout_bit):
    """After the workers (a serial task): the launch's result, the steps it completed plus
    ``unstable_bit`` / ``due_bit`` from the code, ``abort_bit`` when it stopped between two units
    (the host resumes it) and ``timeout_bit`` when a wait ran past its bound.  A finished batch
    clears the team's slots, so that the scratch does not depend on how the steps were launched
    (a restart compares it)."""
    code = asm.asm_sync[SYNC_CODE]
    ret = asm.asm_sync[SYNC_STEPS] - asm.asm_sync[SYNC_START]
    if code & 2:
        ret += unstable_bit
    if code & 1:
        ret += due_bit
    if asm.asm_sync[SYNC_ABORT] != 0:
        ret += timeout_bit
    if asm.asm_sync[SYNC_STAGE] % KINDS != END:
        ret += abort_bit
    else:
        for k in range(asm.asm_sync.shape[0]):
            asm.asm_sync[k] = 0
        for k in range(asm.asm_part.shape[0]):
            asm.asm_part[k] = 0.0
    return ret

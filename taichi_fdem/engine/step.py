"""The time step as Taichi kernels (docs/theory/index.md §1.2, §6.1), in two execution strategies.

A step is a list of phases, each a ``@ti.func`` made of loops over one kind of entity:

1. contact detection, when due (count, then fill: ``detection.phase_detect_count``,
   ``detection.phase_detect_fill``);
2. elastic forces of the triangles (:func:`phase_elastic`);
3. cohesive joint forces, fracture only (:func:`phase_joints`);
4. contact forces of the couples (:func:`phase_contact`);
5. applied loads, absorbing boundaries and curve-driven prescribed velocities, scenes with
   loads only (:func:`phase_loads`);
6. the fluid in the fracture network, a coupled sub-step: apertures, pressures, the pressure
   forces on the faces and the flow over the step, scenes with a fluid only
   (:func:`phase_fluid`, :mod:`taichi_fdem.engine.fluid`);
7. integration of the nodes (:func:`phase_integrate`), with the local (quasi-static) damping
   when asked;
8. the second half of the joints', the loads' and the fluid's work, and the end of intact bonds
   (:func:`phase_joint_work`, :func:`phase_load_work`, :func:`phase_fluid_work`).

The maths of each phase is one function per entity (``elastic.tri_forces``,
``joints.eval_joint``, ``contact.couple_forces``, ``integrate.integrate_node``) shared by
both strategies:

* **serial**: one launch of :func:`run_steps_serial` runs up to thousands of steps in a
  serialised loop (:func:`serial_steps`), detection included; forces are added to ``node_f``
  directly.
* **parallel**: no atomic float add on the forces.  (a) Forces: on the CPU, the **block
  assembly** (:func:`phase_blocks`, :mod:`taichi_fdem.engine.blocks`): each of a fixed number
  of blocks takes a contiguous range of the triangles, joints and couples, block 0 adding into
  ``node_f`` and every other block into its own copy of the nodal forces; on GPUs the **slot
  assembly** (:func:`phase_slots`): every triangle, joint and couple writes its nodal forces
  into its own slots.  (b) Every node adds its block copies in block order, or sums its slots
  through a sorted list (rebuilt at each detection by :func:`build_node_slots`), and
  integrates (:func:`phase_gather_integrate`).  (c) The joints' work.  On the CPU,
  :func:`run_steps_blocks` runs up to thousands of such steps in one launch, executed by a team
  of worker threads (:mod:`taichi_fdem.engine.team`); otherwise :func:`step_parallel` runs one
  step per launch in parallel loops.  Sums run in a fixed order, so results are bit-identical
  from run to run and for any thread count.

Kernels take the array groups of :mod:`taichi_fdem.engine.groups` in the order of
:class:`taichi_fdem.engine.bundle.Groups`.  A scene with a fluid runs the same step functions
with the fluid's group: :func:`run_steps_serial_fluid` and :func:`step_parallel_fluid` differ
from :func:`run_steps_serial` and :func:`step_parallel` only in how their groups are passed (one
argpack holding every member: separate ones would pass Taichi's 64 argument leaves).
``contact``, ``friction``, ``fracture``, ``loads``, ``local_damping`` (the quasi-static option),
``fluid``, ``bedding`` and ``heat`` are compile-time switches, passed together as one :class:`Features` tuple (absent
features are not compiled); damping, contact damping and prescribed velocities are runtime
switches in the step group.
"""
from collections import namedtuple

import taichi as ti

from .blocks import block_forces, block_node_ranges, item_counts, rebalance_blocks
from .bundle import Groups, one_argpack
from .contact import book_contact_work, couple_forces, eval_couple
from .detection import phase_detect_count, phase_detect_fill
from .elastic import eval_tri_elastic, tri_forces
from .fluid import book_fluid_work, fluid_step
from .groups import BUFFER, VLIMIT
from .groups import (ABORT_BIT, BLOCK_STRIDE, COUPLES, DACC, DETECTIONS, DUE_BIT, TIMEOUT_BIT, FOUND, INVERTED, NB_PAIRS, NONFINITE,  # noqa: F401
                     REBALANCE, REBALANCE_STEPS, RMAX, UNSTABLE_BIT, VMAX, AssemblyGroup, ContactGroup, DetectGroup,
                     FluidGroup, JointGroup, MaterialGroup, NodeGroup, SerialFluidGroup, StepGroup, TeamGroup, TriGroup)
from .integrate import asm_blocks, integrate_nodes, integrate_nodes_gathered
from .joints import add_joint_work, eval_joint
from .loads import apply_loads, book_load_work
from .team import team_begin, team_end, team_worker
from .tiutil import vec2


#: The compile-time feature switches of a step kernel, passed as one ``ti.template()`` (Taichi
#: keys a tuple template by its values): a scene without contact, friction, fracture, loads or
#: the quasi-static damping compiles none of their code.  ``many_blocks``: the block assembly
#: has more than two blocks (blocks 2, 3, ... add into their copies at a runtime offset, a third
#: compiled variant of the block loop that two blocks do not need).  ``fluid``: the scene has a
#: fluid in its fracture network (the step's phase 6).  ``bedding``: some material is
#: transversely isotropic (engine.elastic.cauchy_aniso); ``heat``: the triangles take the thermal
#: strains of tri_thermal (engine.elastic.tri_forces).
Features = namedtuple("Features", "contact friction fracture loads local_damping many_blocks fluid bedding heat",
                      defaults=(False, False, False, False))

__all__ = ["UNSTABLE_BIT", "DUE_BIT", "ABORT_BIT", "TIMEOUT_BIT", "Features", "detect_count", "detect_fill", "build_node_slots", "step_parallel",
           "run_steps_blocks", "run_steps_serial", "run_steps_serial_fluid", "step_parallel_fluid", "eval_elastic", "eval_joints", "eval_contact", "eval_loads",
           "integrate", "book_joint_work", "book_loads_work", "refresh_blocks"]


# ---------------------------------------------------------------------------------------------
# phases
# ---------------------------------------------------------------------------------------------
@ti.func
def phase_elastic(nodes: ti.template(), tris: ti.template(), mats: ti.template(), step: ti.template(),
                  feat: ti.template()):
    for e in range(tris.tri_nodes.shape[0]):
        eval_tri_elastic(e, nodes, tris, mats, step, feat)


@ti.func
def phase_joints(nodes: ti.template(), tris: ti.template(), mats: ti.template(), joints: ti.template(),
                 step: ti.template()):
    for j in range(joints.joint_nodes.shape[0]):
        eval_joint(j, nodes, tris, mats, joints, step, True)


@ti.func
def phase_joint_work(nodes: ti.template(), tris: ti.template(), mats: ti.template(), joints: ti.template(),
                     step: ti.template()):
    for j in range(joints.joint_nodes.shape[0]):
        add_joint_work(j, nodes, tris, mats, joints, step)


@ti.func
def phase_contact(nodes: ti.template(), tris: ti.template(), mats: ti.template(), contact: ti.template(),
                  step: ti.template(), friction: ti.template(), fracture: ti.template()):
    dacc = step.step_real[DACC]
    for c in range(step.step_int[COUPLES]):
        eval_couple(c, dacc, nodes, tris, mats, contact, step, friction, fracture)


@ti.func
def phase_loads(nodes: ti.template(), step: ti.template()):
    apply_loads(nodes, step)


@ti.func
def phase_load_work(nodes: ti.template(), step: ti.template()):
    book_load_work(nodes, step)


@ti.func
def phase_fluid(nodes: ti.template(), joints: ti.template(), step: ti.template(), fluid: ti.template()):
    fluid_step(nodes, joints, step, fluid)


@ti.func
def phase_fluid_work(nodes: ti.template(), step: ti.template(), fluid: ti.template()):
    book_fluid_work(nodes, step, fluid)


@ti.func
def phase_integrate(nodes: ti.template(), step: ti.template(), local_damping: ti.template()):
    integrate_nodes(nodes, step, local_damping)


@ti.func
def is_unstable(step: ti.template()):
    """A non-finite value, an inverted element, or a node faster than step.step_real[VLIMIT]."""
    return (step.step_int[NONFINITE] != 0 or step.step_int[INVERTED] != 0
            or step.step_real[VMAX] > step.step_real[VLIMIT])


@ti.func
def status_code(step: ti.template()):
    """bit 0: contact detection is due; bit 1: the step produced a non-finite value, an inverted
    element or a speed above the limit."""
    code = 0
    if step.step_real[DACC] >= step.step_real[BUFFER]:
        code |= 1
    if is_unstable(step):
        code |= 2
    return code


@ti.func
def phases_forces_integrate(nodes: ti.template(), tris: ti.template(), mats: ti.template(), contact: ti.template(),
                            joints: ti.template(), step: ti.template(), fluid: ti.template(), feat: ti.template()):
    """Phases 2–8 of a step (``fluid``: the fluid group, read only with ``feat.fluid``)."""
    phase_elastic(nodes, tris, mats, step, feat)
    if ti.static(feat.fracture):
        phase_joints(nodes, tris, mats, joints, step)
    if ti.static(feat.contact):
        phase_contact(nodes, tris, mats, contact, step, feat.friction, feat.fracture)
    if ti.static(feat.loads):
        phase_loads(nodes, step)
    if ti.static(feat.fluid):
        phase_fluid(nodes, joints, step, fluid)
    phase_integrate(nodes, step, feat.local_damping)
    if ti.static(feat.fracture):
        phase_joint_work(nodes, tris, mats, joints, step)
    if ti.static(feat.loads):
        phase_load_work(nodes, step)
    if ti.static(feat.fluid):
        phase_fluid_work(nodes, step, fluid)


@ti.func
def phase_slots(nodes: ti.template(), tris: ti.template(), mats: ti.template(), contact: ti.template(),
                joints: ti.template(), step: ti.template(), asm: ti.template(), feat: ti.template()):
    """Phases 2–4 of the parallel strategy as parallel loops over the triangles, the joints and
    the couples: each writes its nodal forces into its own slots (triangle t: asm_force[3t + r];
    couple c: asm_force[3T + 6c + r], rows of A then B; joint j: joint_g[j]), never adding to a
    node.  One loop (one GPU task) per entity, so that no task binds the arrays of all three
    (Vulkan binds at most 31 storage buffers per stage)."""
    T, J, C = item_counts(tris, joints, step, feat)
    for e in range(T):
        f0, f1, f2 = tri_forces(e, nodes, tris, mats, step, feat)
        asm.asm_force[3 * e] = f0
        asm.asm_force[3 * e + 1] = f1
        asm.asm_force[3 * e + 2] = f2
    if ti.static(feat.fracture):
        for j in range(J):
            eval_joint(j, nodes, tris, mats, joints, step, False)
    if ti.static(feat.contact):
        dacc = step.step_real[DACC]
        for c in range(C):
            gA, gB, hit, work = couple_forces(c, dacc, nodes, tris, mats, contact, step, feat.friction,
                                              feat.fracture)
            book_contact_work(work, step)
            base = 3 * T + 6 * c
            for r in ti.static(range(3)):
                asm.asm_force[base + r] = vec2(gA[r, 0], gA[r, 1])
                asm.asm_force[base + 3 + r] = vec2(gB[r, 0], gB[r, 1])


@ti.func
def phase_blocks(nodes: ti.template(), tris: ti.template(), mats: ti.template(), contact: ti.template(),
                 joints: ti.template(), step: ti.template(), asm: ti.template(), feat: ti.template()):
    """Phases 2–4 of the parallel strategy on the CPU, as one parallel loop over the blocks
    (:func:`asm_blocks`).  Block b takes a contiguous range of the triangles, of the joints and
    of the couples (:func:`block_forces`) and adds their forces into its own copy of the nodal
    forces in item order, without atomics (block 0 into node_f, block b > 0 into
    asm_force[(b − 1) N + n]); its dissipated contact work goes to its own entry
    (:func:`integrate.block_work_slot`).  The gather adds the copies to node_f in block order, so
    the result does not depend on the thread count."""
    T, J, C = item_counts(tris, joints, step, feat)
    nblk = asm_blocks(nodes.node_x.shape[0], asm)
    dacc = step.step_real[DACC]
    ti.loop_config(serialize=True)   # a serial task: a parallel loop of one iteration costs a task start
    for _ in range(1):
        if step.step_int[REBALANCE] <= 0:
            rebalance_blocks(nblk, T, J, C, nodes, tris, contact, joints, step, feat)
            step.step_int[REBALANCE] = REBALANCE_STEPS
        step.step_int[REBALANCE] -= 1
    # Taichi 1.7's CPU range-for hands each thread tasks of at least 512 iterations (its adaptive
    # block_dim; loop_config(block_dim) is overridden), so a loop of a few iterations would
    # run on one thread: the loop has BLOCK_STRIDE iterations per block and the first of each
    # does the block's work, which puts every block in its own task
    for t in range(nblk * BLOCK_STRIDE):
        if t % BLOCK_STRIDE == 0:
            block_forces(t // BLOCK_STRIDE, nblk, T, J, C, dacc, 0, nodes, tris, mats, contact, joints, step, asm,
                         feat)


@ti.func
def phase_gather_integrate(nodes: ti.template(), joints: ti.template(), step: ti.template(), asm: ti.template(),
                           blocks: ti.template(), local_damping: ti.template()):
    """Phase 7 of the parallel strategy: each node sums its slots in list order (or its block
    copies in block order), then integrates."""
    integrate_nodes_gathered(nodes, joints, step, asm, blocks, local_damping)


@ti.func
def phases_parallel(nodes: ti.template(), tris: ti.template(), mats: ti.template(), contact: ti.template(),
                    joints: ti.template(), step: ti.template(), asm: ti.template(), fluid: ti.template(),
                    feat: ti.template(), blocks: ti.template()):
    """Phases 2–8 of a step in the parallel strategy (no atomic float add on the element, joint
    and couple forces; the few load entries are added to node_f in one serial loop, the fluid's
    pressure forces by a loop over the nodes they act on).  ``blocks``: the block assembly (CPU)
    instead of the slots (GPU); ``fluid``: the fluid group, read only with ``feat.fluid``."""
    if ti.static(blocks):
        phase_blocks(nodes, tris, mats, contact, joints, step, asm, feat)
    else:
        phase_slots(nodes, tris, mats, contact, joints, step, asm, feat)
    if ti.static(feat.loads):
        phase_loads(nodes, step)
    if ti.static(feat.fluid):
        phase_fluid(nodes, joints, step, fluid)
    phase_gather_integrate(nodes, joints, step, asm, blocks, feat.local_damping)
    if ti.static(feat.fracture):
        phase_joint_work(nodes, tris, mats, joints, step)
    if ti.static(feat.loads):
        phase_load_work(nodes, step)
    if ti.static(feat.fluid):
        phase_fluid_work(nodes, step, fluid)


@ti.func
def serial_steps(nsteps, G: ti.template(), feat: ti.template()):
    """Up to ``nsteps`` whole steps, detection included, in one serial loop over the groups
    ``G`` (:class:`~taichi_fdem.engine.bundle.Groups`).  Stops early, before the step that needs
    it, when the couple buffer is too small (the count needed is left in step_int[FOUND]), and
    after a step that produced a non-finite value, an inverted element or a speed above the
    limit.  Returns the number of steps done, plus ``UNSTABLE_BIT`` when the state is unstable."""
    done = 0
    ti.loop_config(serialize=True)
    for _ in range(nsteps):
        stop = 0
        if ti.static(feat.contact):
            if G.step.step_real[DACC] >= G.step.step_real[BUFFER]:
                phase_detect_count(G.nodes, G.tris, G.contact, G.detect, G.step)
                if G.step.step_int[FOUND] > G.contact.couple_a.shape[0]:
                    stop = 1                    # the host grows the buffer to step_int[FOUND]
                else:
                    phase_detect_fill(G.tris, G.contact, G.detect, G.step, feat.friction)
        if stop == 0:
            phases_forces_integrate(G.nodes, G.tris, G.mats, G.contact, G.joints, G.step, G.fluid, feat)
            done += 1
            if is_unstable(G.step):
                stop = 1
        if stop != 0:
            break
    return done + ti.select(status_code(G.step) >= 2, UNSTABLE_BIT, 0)


# ---------------------------------------------------------------------------------------------
# kernels
# ---------------------------------------------------------------------------------------------
@ti.kernel
def detect_count(nodes: NodeGroup, tris: TriGroup, contact: ContactGroup, detect: DetectGroup,
                 step: StepGroup) -> ti.i32:
    """Parallel broad phase, first half; returns the number of couples found."""
    phase_detect_count(nodes, tris, contact, detect, step)
    return step.step_int[FOUND]


@ti.kernel
def detect_fill(tris: TriGroup, contact: ContactGroup, detect: DetectGroup, step: StepGroup, friction: ti.template()):
    """Parallel broad phase, second half: write the couples."""
    phase_detect_fill(tris, contact, detect, step, friction)


@ti.kernel
def detect_serial(nodes: NodeGroup, tris: TriGroup, contact: ContactGroup, detect: DetectGroup, step: StepGroup,
                  friction: ti.template()) -> ti.i32:
    """The whole broad phase in one serial task (small scenes, where the parallel kernels' many
    loop starts cost more than a serial pass).  The same couple list as :func:`detect_count` +
    :func:`detect_fill`.  Writes the couples only when they fit; returns the number found (the
    host grows the buffer and calls again)."""
    ti.loop_config(serialize=True)
    for _ in range(1):
        phase_detect_count(nodes, tris, contact, detect, step)
        if step.step_int[FOUND] <= contact.couple_a.shape[0]:
            phase_detect_fill(tris, contact, detect, step, friction)
    return step.step_int[FOUND]


@ti.kernel
def build_node_slots(tris: TriGroup, contact: ContactGroup, joints: JointGroup, step: StepGroup, asm: AssemblyGroup,
                     feat: ti.template()):
    """Each node's list of force slots (parallel strategy), sorted: rebuilt after every detection.

    Counting sort by node (integer atomics only), then each node's short list sorted by slot, so
    the gather sums in the same order whatever the thread count.
    """
    N = asm.asm_node_start.shape[0] - 1
    T = tris.tri_nodes.shape[0]
    for i in range(N + 1):
        asm.asm_node_start[i] = 0
    for e in range(T):
        n = tris.tri_nodes[e]
        for r in ti.static(range(3)):
            ti.atomic_add(asm.asm_node_start[n[r] + 1], 1)
    if ti.static(feat.fracture):
        for j in range(joints.joint_nodes.shape[0]):
            n = joints.joint_nodes[j]
            for r in ti.static(range(4)):
                ti.atomic_add(asm.asm_node_start[n[r] + 1], 1)
    if ti.static(feat.contact):
        for c in range(step.step_int[COUPLES]):
            na = tris.tri_nodes[contact.couple_a[c]]
            nb = tris.tri_nodes[contact.couple_b[c]]
            for r in ti.static(range(3)):
                ti.atomic_add(asm.asm_node_start[na[r] + 1], 1)
                ti.atomic_add(asm.asm_node_start[nb[r] + 1], 1)
    ti.loop_config(serialize=True)   # a serial task
    for _ in range(1):
        for i in range(1, N + 1):
            asm.asm_node_start[i] += asm.asm_node_start[i - 1]           # asm.asm_node_start[i]: first slot of node i
    for e in range(T):
        n = tris.tri_nodes[e]
        for r in ti.static(range(3)):
            asm.asm_node_slots[ti.atomic_add(asm.asm_node_start[n[r]], 1)] = 3 * e + r
    if ti.static(feat.fracture):
        for j in range(joints.joint_nodes.shape[0]):
            n = joints.joint_nodes[j]
            for r in ti.static(range(4)):
                asm.asm_node_slots[ti.atomic_add(asm.asm_node_start[n[r]], 1)] = -1 - (4 * j + r)
    if ti.static(feat.contact):
        for c in range(step.step_int[COUPLES]):
            na = tris.tri_nodes[contact.couple_a[c]]
            nb = tris.tri_nodes[contact.couple_b[c]]
            base = 3 * T + 6 * c
            for r in ti.static(range(3)):
                asm.asm_node_slots[ti.atomic_add(asm.asm_node_start[na[r]], 1)] = base + r
                asm.asm_node_slots[ti.atomic_add(asm.asm_node_start[nb[r]], 1)] = base + 3 + r
    ti.loop_config(serialize=True)   # a serial task
    for _ in range(1):
        for i0 in range(N):                    # asm.asm_node_start[i] now ends node i: shift back
            i = N - i0
            asm.asm_node_start[i] = asm.asm_node_start[i - 1]
        asm.asm_node_start[0] = 0
    for i in range(N):
        lo = asm.asm_node_start[i]
        hi = asm.asm_node_start[i + 1]
        for a in range(lo + 1, hi):            # insertion sort: lists are short
            key = asm.asm_node_slots[a]
            b = a - 1
            while b >= lo:
                if asm.asm_node_slots[b] > key:
                    asm.asm_node_slots[b + 1] = asm.asm_node_slots[b]
                    b -= 1
                else:
                    break
            asm.asm_node_slots[b + 1] = key


@ti.kernel
def step_parallel(nodes: NodeGroup, tris: TriGroup, mats: MaterialGroup, contact: ContactGroup, joints: JointGroup,
                  step: StepGroup, asm: AssemblyGroup, feat: ti.template(), blocks: ti.template()) -> ti.i32:
    """One step in parallel loops without atomic float adds on the element, joint and couple
    forces.  ``feat``: the compile-time :class:`Features`; ``blocks``: block assembly (CPU)
    rather than slots (GPU).  Returns :func:`status_code`."""
    phases_parallel(nodes, tris, mats, contact, joints, step, asm, None, feat, blocks)
    return status_code(step)


@ti.kernel
def step_parallel_fluid(nodes: NodeGroup, tris: TriGroup, mats: MaterialGroup, contact: ContactGroup,
                        joints: JointGroup, step: StepGroup, asm: AssemblyGroup, fluid: FluidGroup,
                        feat: ti.template(), blocks: ti.template()) -> ti.i32:
    """:func:`step_parallel` with the fluid's group (``feat.fluid``)."""
    phases_parallel(nodes, tris, mats, contact, joints, step, asm, fluid, feat, blocks)
    return status_code(step)


@ti.kernel
def refresh_blocks(nodes: NodeGroup, tris: TriGroup, contact: ContactGroup, joints: JointGroup, step: StepGroup,
                   asm: AssemblyGroup, feat: ti.template()):
    """The blocks' node ranges (``blocks.block_node_ranges``) from the couples and their split,
    after a restore or on a new scratch: what the last recomputation of the couple ranges set
    (they change only with the couples and the split)."""
    ti.loop_config(serialize=True)   # a serial task
    for _ in range(1):
        T, J, C = item_counts(tris, joints, step, feat)
        nblk = asm_blocks(nodes.node_x.shape[0], asm)
        block_node_ranges(nblk, T, J, C, nodes, tris, contact, joints, step, feat)


@ti.kernel
def run_steps_blocks(nsteps: ti.i32, nwork: ti.i32, flags: ti.i32, spin_max: ti.i32, g: TeamGroup,
                     feat: ti.template()) -> ti.i32:
    """Up to ``nsteps`` steps of the parallel strategy with the block assembly in one launch, run
    by a team of ``nwork`` workers (:mod:`taichi_fdem.engine.team`); no launch and no
    parallel-loop start per step.  ``g``: every group's members in one argpack
    (:func:`~taichi_fdem.engine.bundle.one_argpack`).  ``flags`` bit 0 (detect inside): contact
    detection, when due, runs inside the launch (the serial broad phase, as
    :func:`detect_serial`); else the launch stops after a step that makes detection due.  Bit 1
    (resume): carry on a launch that returned with ``ABORT_BIT``.  Bit 2: stop after each stage,
    as if a wait had timed out (a test of the resumption).  A wait longer than ``spin_max``
    tries aborts the launch.  Stops after a step that is unstable, and before a detection whose
    couples do not fit the buffer.  Returns the steps done, plus ``UNSTABLE_BIT`` if unstable,
    ``DUE_BIT`` if the host must detect, ``ABORT_BIT`` if the host must resume and
    ``TIMEOUT_BIT`` if a wait ran past its bound.  The same bits as :func:`step_parallel` for
    any ``nwork``."""
    G = ti.static(one_argpack(g))
    detect_in = flags & 1
    ti.loop_config(serialize=True)   # a serial task
    for _ in range(1):
        team_begin(flags & 2, detect_in, G.step, G.asm, feat)
    # BLOCK_STRIDE iterations per worker put each worker in a task of its own (see phase_blocks);
    # whether the tasks run at once does not matter (engine.team)
    for t in range(nwork * BLOCK_STRIDE):
        if t % BLOCK_STRIDE == 0:
            team_worker(t // BLOCK_STRIDE, nwork, nsteps, flags, spin_max, G, feat)
    ret = 0
    ti.loop_config(serialize=True)
    for _ in range(1):
        ret = team_end(G.asm, UNSTABLE_BIT, DUE_BIT, ABORT_BIT, TIMEOUT_BIT)
    return ret


@ti.kernel
def run_steps_serial(nsteps: ti.i32, nodes: NodeGroup, tris: TriGroup, mats: MaterialGroup, contact: ContactGroup,
                     detect: DetectGroup, joints: JointGroup, step: StepGroup, feat: ti.template()) -> ti.i32:
    """Up to ``nsteps`` whole steps, detection included, in one serial loop (:func:`serial_steps`)."""
    return serial_steps(nsteps, ti.static(Groups(nodes, tris, mats, contact, detect, joints, step)), feat)


@ti.kernel
def run_steps_serial_fluid(nsteps: ti.i32, g: SerialFluidGroup, feat: ti.template()) -> ti.i32:
    """:func:`run_steps_serial` with the fluid's group (``feat.fluid``): every group in the one
    argpack ``g`` (engine.groups.SERIAL_FLUID_MEMBERS)."""
    return serial_steps(nsteps, ti.static(one_argpack(g)), feat)


# ---------------------------------------------------------------------------------------------
# single-phase kernels: force evaluation without a step, and per-phase profiling
# ---------------------------------------------------------------------------------------------
@ti.kernel
def eval_elastic(nodes: NodeGroup, tris: TriGroup, mats: MaterialGroup, step: StepGroup, feat: ti.template()):
    phase_elastic(nodes, tris, mats, step, feat)


@ti.kernel
def eval_joints(nodes: NodeGroup, tris: TriGroup, mats: MaterialGroup, joints: JointGroup, step: StepGroup):
    phase_joints(nodes, tris, mats, joints, step)


@ti.kernel
def eval_contact(nodes: NodeGroup, tris: TriGroup, mats: MaterialGroup, contact: ContactGroup, step: StepGroup,
                 friction: ti.template(), fracture: ti.template()):
    phase_contact(nodes, tris, mats, contact, step, friction, fracture)


@ti.kernel
def integrate(nodes: NodeGroup, step: StepGroup, local_damping: ti.template()) -> ti.i32:
    phase_integrate(nodes, step, local_damping)
    return status_code(step)


@ti.kernel
def eval_loads(nodes: NodeGroup, step: StepGroup):
    phase_loads(nodes, step)


@ti.kernel
def book_loads_work(nodes: NodeGroup, step: StepGroup):
    phase_load_work(nodes, step)


@ti.kernel
def book_joint_work(nodes: NodeGroup, tris: TriGroup, mats: MaterialGroup, joints: JointGroup, step: StepGroup):
    phase_joint_work(nodes, tris, mats, joints, step)

"""The time step as Taichi kernels (FDEM_SPEC §1.2, §6.1), in two execution strategies.

A step is a list of phases, each a ``@ti.func`` made of loops over one kind of entity:

1. contact detection, when due (count, then fill: :func:`phase_detect_count`,
   :func:`phase_detect_fill`);
2. elastic forces of the triangles (:func:`phase_elastic`);
3. cohesive joint forces, fracture only (:func:`phase_joints`);
4. contact forces of the couples (:func:`phase_contact`);
5. applied loads, absorbing boundaries and curve-driven prescribed velocities, scenes with
   loads only (:func:`phase_loads`);
6. integration of the nodes (:func:`phase_integrate`), with the local (quasi-static) damping
   when asked;
7. the second half of the joints' and the loads' work (:func:`phase_joint_work`,
   :func:`phase_load_work`).

Called at the top level of a kernel a phase's loops are parallel; called inside the serialised
step loop of :func:`run_steps_serial` they run serially.  So one body of maths serves both
strategies:

* **parallel** (large scenes, GPUs): one launch per step runs the force phases and the
  integration as parallel loops; detection runs in two launches when the buffer is used up.
* **serial** (small scenes, bound by launch overhead): one launch runs up to thousands of steps
  in a serial loop, detection included.

Every kernel takes the array groups of :mod:`taichi_fdem.engine.groups`.  ``contact``,
``friction``, ``fracture``, ``loads`` and ``local_damping`` (the quasi-static option) are
compile-time switches (absent features are not compiled);
damping, contact damping and prescribed velocities are runtime switches in the step group.
"""
import taichi as ti

from .contact import eval_couple
from .detection import bin_circle, prepare_circle, scan_partners
from .elastic import eval_tri_elastic
from .groups import (COUPLES, DACC, DETECTIONS, FOUND, INVERTED, NONFINITE, RMAX, VMAX, ContactGroup, JointGroup,
                     MaterialGroup, NodeGroup, StepGroup, TriGroup)
from .integrate import integrate_nodes
from .joints import add_joint_work, eval_joint
from .loads import apply_loads, book_load_work

UNSTABLE_BIT = 1 << 24   # added to run_steps_serial's return value (steps per launch < 2^24)

__all__ = ["UNSTABLE_BIT", "detect_count", "detect_fill", "step_parallel", "run_steps_serial",
           "eval_elastic", "eval_joints", "eval_contact", "eval_loads", "integrate", "book_joint_work",
           "book_loads_work"]


# ---------------------------------------------------------------------------------------------
# phases
# ---------------------------------------------------------------------------------------------
@ti.func
def phase_detect_count(nodes: ti.template(), tris: ti.template(), con: ti.template(), step: ti.template()):
    """Bounding circles, counting sort and couple count; con.det_cnew = exclusive prefix of counts."""
    K = con.contact_tri.shape[0]
    H = con.det_bucket.shape[0]
    for _ in range(1):
        step.step_real[RMAX] = 0.0
    for k in range(K):
        prepare_circle(k, con, tris, nodes, step)
    for h in range(H):
        con.det_bucket[h] = ti.Vector([0, 0])
    for k in range(K):
        bin_circle(k, con, step)
    for _ in range(1):
        s = 0
        for h in range(H):
            con.det_bucket[h][0] = s
            s += con.det_bucket[h][1]
    for k in range(K):
        bn = con.det_bin[k]
        con.det_sorted_k[con.det_bucket[bn[0]][0] + bn[1]] = k
    for k in range(K):
        con.det_cnew[k] = scan_partners(k, True, con, tris, step, 0, False)
    for _ in range(1):
        s = 0
        for k in range(K):              # counts -> exclusive prefix, in place
            n = con.det_cnew[k]
            con.det_cnew[k] = s
            s += n
        con.det_cnew[K] = s
        step.step_int[FOUND] = s


@ti.func
def phase_detect_fill(tris: ti.template(), con: ti.template(), step: ti.template(), friction: ti.template()):
    """Write the couples counted by :func:`phase_detect_count` (capacity already checked)."""
    K = con.contact_tri.shape[0]
    if ti.static(friction):
        # keep the previous couples and their slip history to carry it over (§4.1, §9.4)
        for k in range(K + 1):
            con.det_old_start[k] = con.couple_start[k]
            con.couple_start[k] = con.det_cnew[k]
        for c in range(step.step_int[COUPLES]):
            con.det_old_b[c] = con.couple_b[c]
            for q in ti.static(range(6)):
                con.det_old_hist[6 * c + q] = con.couple_hist[6 * c + q]
    for k in range(K):
        scan_partners(k, False, con, tris, step, con.det_cnew[k], friction)
    for _ in range(1):
        step.step_int[COUPLES] = step.step_int[FOUND]
        step.step_int[DETECTIONS] += 1
        step.step_real[DACC] = 0.0


@ti.func
def phase_elastic(nodes: ti.template(), tris: ti.template(), mats: ti.template(), step: ti.template()):
    for e in range(tris.tri_nodes.shape[0]):
        eval_tri_elastic(e, nodes, tris, mats, step)


@ti.func
def phase_joints(nodes: ti.template(), tris: ti.template(), mats: ti.template(), joints: ti.template(),
                 step: ti.template()):
    for j in range(joints.joint_nodes.shape[0]):
        eval_joint(j, joints, tris, mats, nodes, step)


@ti.func
def phase_joint_work(nodes: ti.template(), joints: ti.template(), step: ti.template()):
    for j in range(joints.joint_nodes.shape[0]):
        add_joint_work(j, joints, nodes, step)


@ti.func
def phase_contact(nodes: ti.template(), tris: ti.template(), mats: ti.template(), con: ti.template(),
                  step: ti.template(), friction: ti.template(), fracture: ti.template()):
    for c in range(step.step_int[COUPLES]):
        eval_couple(c, nodes, tris, mats, con, step, friction, fracture)


@ti.func
def phase_loads(nodes: ti.template(), step: ti.template()):
    apply_loads(nodes, step)


@ti.func
def phase_load_work(nodes: ti.template(), step: ti.template()):
    book_load_work(nodes, step)


@ti.func
def phase_integrate(nodes: ti.template(), step: ti.template(), local_damping: ti.template()):
    integrate_nodes(nodes, step, local_damping)


@ti.func
def is_unstable(step: ti.template()):
    """A non-finite value, an inverted element, or a node faster than step.step_vlimit."""
    return step.step_int[NONFINITE] != 0 or step.step_int[INVERTED] != 0 or step.step_real[VMAX] > step.step_vlimit[None]


@ti.func
def status_code(step: ti.template()):
    """bit 0: contact detection is due; bit 1: the step produced a non-finite value, an inverted
    element or a speed above the limit."""
    code = 0
    if step.step_real[DACC] >= step.step_buffer[None]:
        code |= 1
    if is_unstable(step):
        code |= 2
    return code


@ti.func
def phases_forces_integrate(nodes: ti.template(), tris: ti.template(), mats: ti.template(), con: ti.template(),
                            joints: ti.template(), step: ti.template(), contact: ti.template(),
                            friction: ti.template(), fracture: ti.template(), loads: ti.template(),
                            local_damping: ti.template()):
    """Phases 2–7 of a step."""
    phase_elastic(nodes, tris, mats, step)
    if ti.static(fracture):
        phase_joints(nodes, tris, mats, joints, step)
    if ti.static(contact):
        phase_contact(nodes, tris, mats, con, step, friction, fracture)
    if ti.static(loads):
        phase_loads(nodes, step)
    phase_integrate(nodes, step, local_damping)
    if ti.static(fracture):
        phase_joint_work(nodes, joints, step)
    if ti.static(loads):
        phase_load_work(nodes, step)


# ---------------------------------------------------------------------------------------------
# kernels
# ---------------------------------------------------------------------------------------------
@ti.kernel
def detect_count(nodes: NodeGroup, tris: TriGroup, con: ContactGroup, step: StepGroup) -> ti.i32:
    """Parallel broad phase, first half; returns the number of couples found."""
    phase_detect_count(nodes, tris, con, step)
    return step.step_int[FOUND]


@ti.kernel
def detect_fill(tris: TriGroup, con: ContactGroup, step: StepGroup, friction: ti.template()):
    """Parallel broad phase, second half: write the couples."""
    phase_detect_fill(tris, con, step, friction)


@ti.kernel
def step_parallel(nodes: NodeGroup, tris: TriGroup, mats: MaterialGroup, con: ContactGroup, joints: JointGroup,
                  step: StepGroup, contact: ti.template(), friction: ti.template(),
                  fracture: ti.template(), loads: ti.template(), local_damping: ti.template()) -> ti.i32:
    """One step, each phase a parallel loop.  Returns :func:`status_code`."""
    phases_forces_integrate(nodes, tris, mats, con, joints, step, contact, friction, fracture, loads, local_damping)
    return status_code(step)


@ti.kernel
def run_steps_serial(nsteps: ti.i32, nodes: NodeGroup, tris: TriGroup, mats: MaterialGroup, con: ContactGroup,
                     joints: JointGroup, step: StepGroup, contact: ti.template(), friction: ti.template(),
                     fracture: ti.template(), loads: ti.template(), local_damping: ti.template()) -> ti.i32:
    """Up to ``nsteps`` whole steps, detection included, in one serial loop (small scenes).

    Stops early, before the step that needs it, when the couple buffer is too small (the
    count needed is left in step_int[FOUND]; grow and call again), and after a step that produced a
    non-finite value, an inverted element or a speed above the limit.  Returns the number of
    steps done, plus ``UNSTABLE_BIT`` when the state is unstable (so the host needs no extra read).
    """
    done = 0
    ti.loop_config(serialize=True)
    for _ in range(nsteps):
        stop = 0
        if ti.static(contact):
            if step.step_real[DACC] >= step.step_buffer[None]:
                phase_detect_count(nodes, tris, con, step)
                if step.step_int[FOUND] > con.couple_a.shape[0]:
                    stop = 1                    # the host grows the buffer to step_int[FOUND]
                else:
                    phase_detect_fill(tris, con, step, friction)
        if stop == 0:
            phases_forces_integrate(nodes, tris, mats, con, joints, step, contact, friction, fracture, loads,
                                    local_damping)
            done += 1
            if is_unstable(step):
                stop = 1
        if stop != 0:
            break
    return done + ti.select(status_code(step) >= 2, UNSTABLE_BIT, 0)


# ---------------------------------------------------------------------------------------------
# single-phase kernels: force evaluation without a step, and per-phase profiling
# ---------------------------------------------------------------------------------------------
@ti.kernel
def eval_elastic(nodes: NodeGroup, tris: TriGroup, mats: MaterialGroup, step: StepGroup):
    phase_elastic(nodes, tris, mats, step)


@ti.kernel
def eval_joints(nodes: NodeGroup, tris: TriGroup, mats: MaterialGroup, joints: JointGroup, step: StepGroup):
    phase_joints(nodes, tris, mats, joints, step)


@ti.kernel
def eval_contact(nodes: NodeGroup, tris: TriGroup, mats: MaterialGroup, con: ContactGroup, step: StepGroup,
                 friction: ti.template(), fracture: ti.template()):
    phase_contact(nodes, tris, mats, con, step, friction, fracture)


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
def book_joint_work(nodes: NodeGroup, joints: JointGroup, step: StepGroup):
    phase_joint_work(nodes, joints, step)

"""The time step as Taichi kernels (FDEM_SPEC §1.2, §6.1), in two execution strategies.

Every phase is a ``@ti.func`` made of loops.  Called at the top level of a kernel its loops are
parallel; called inside the serialised step loop of :func:`run_steps_serial` they run serially.
So one body of maths serves both strategies:

* **parallel** (large scenes): one launch per step runs elastic forces, contact forces and the
  integration as three parallel loops; detection runs in two launches when the buffer is used up.
* **serial** (small scenes, bound by launch overhead): one launch runs up to thousands of steps
  in a serial loop, detection included.

Scalar slots shared between host and kernels are in :mod:`taichi_fdem.slots`.
"""
import taichi as ti

from ._tiutil import vec2

from .contact import eval_couple
from .detection import bin_circle, prepare_circle, scan_partners
from .elastic import eval_tri_elastic
from .joints import add_joint_work, eval_joint


from .slots import *  # noqa: F401,F403  (slot indices shared with the host)
from .slots import (A_BOUNDARY, R_TIME, I_COUPLES, I_DETECTIONS, I_FOUND, I_INVERTED, I_NONFINITE, I_OVERFLOW,
                    I_SPEED, R_BUFFER, R_CELL, R_DACC, R_DT, R_GX, R_GY, R_RMAX, R_VLIMIT, R_VMAX)

UNSTABLE_BIT = 1 << 24   # added to run_steps_serial's return value (steps per launch < 2^24)
CHUNK = 256   # nodes per chunk in reductions (one atomic per chunk, not per node)



# ---------------------------------------------------------------------------------------------
# phases
# ---------------------------------------------------------------------------------------------
@ti.func
def phase_detect_count(ctri: ti.template(), tri_nodes: ti.template(), node_x: ti.template(), tri_body: ti.template(), body_flags: ti.template(), cen: ti.template(), rad: ti.template(), bucket_of: ti.template(), slot: ti.template(),
                       bucket_count: ti.template(), bucket_start: ti.template(), sorted_k: ti.template(), ccount: ti.template(), cnew: ti.template(), sim_real: ti.template(), sim_int: ti.template()):
    """Bounding circles, counting sort and couple count; cnew = exclusive prefix of counts."""
    K = ctri.shape[0]
    H = bucket_count.shape[0]
    for _ in range(1):
        sim_real[R_RMAX] = 0.0
    for k in range(K):
        prepare_circle(k, ctri, tri_nodes, node_x, cen, rad, sim_real)
    for _ in range(1):
        sim_real[R_CELL] = 2.0 * sim_real[R_RMAX] + sim_real[R_BUFFER]
    for h in range(H):
        bucket_count[h] = 0
    for k in range(K):
        bin_circle(k, cen, sim_real, bucket_of, slot, bucket_count)
    for _ in range(1):
        s = 0
        for h in range(H):
            bucket_start[h] = s
            s += bucket_count[h]
    for k in range(K):
        sorted_k[bucket_start[bucket_of[k]] + slot[k]] = k
    for k in range(K):
        ccount[k] = scan_partners(k, True, ctri, cen, rad, sim_real, bucket_count, bucket_start, sorted_k,
                                  tri_nodes, tri_body, body_flags, 0, ctri, ctri, cnew, ctri, rad, rad, False)
    for _ in range(1):
        s = 0
        for k in range(K):
            cnew[k] = s
            s += ccount[k]
        cnew[K] = s
        sim_int[I_FOUND] = s


@ti.func
def phase_detect_fill(ctri: ti.template(), tri_nodes: ti.template(), tri_body: ti.template(), body_flags: ti.template(), cen: ti.template(), rad: ti.template(), bucket_count: ti.template(), bucket_start: ti.template(), sorted_k: ti.template(),
                      cnew: ti.template(), cstart: ti.template(), couple_a: ti.template(), couple_b: ti.template(), couple_hist: ti.template(), old_start: ti.template(), old_b: ti.template(), old_hist: ti.template(),
                      sim_real: ti.template(), sim_int: ti.template(), friction: ti.template()):
    """Write the couples counted by :func:`phase_detect_count` (capacity already checked)."""
    K = ctri.shape[0]
    if ti.static(friction):
        # keep the previous couples and their slip history to carry it over (§4.1, §9.4)
        for k in range(K + 1):
            old_start[k] = cstart[k]
            cstart[k] = cnew[k]
        for c in range(sim_int[I_COUPLES]):
            old_b[c] = couple_b[c]
            for q in ti.static(range(6)):
                old_hist[6 * c + q] = couple_hist[6 * c + q]
    for k in range(K):
        scan_partners(k, False, ctri, cen, rad, sim_real, bucket_count, bucket_start, sorted_k,
                      tri_nodes, tri_body, body_flags, cnew[k], couple_a, couple_b,
                      old_start, old_b, old_hist, couple_hist, friction)
    for _ in range(1):
        sim_int[I_COUPLES] = sim_int[I_FOUND]
        sim_int[I_DETECTIONS] += 1
        sim_real[R_DACC] = 0.0


@ti.func
def phase_elastic(node_x: ti.template(), node_v: ti.template(), node_f: ti.template(), tri_nodes: ti.template(), tri_rest_inv: ti.template(), tri_mat: ti.template(), mat_mu: ti.template(), mat_lam: ti.template(), tri_visc: ti.template(),
                  tri_diss: ti.template(), sim_real: ti.template(), sim_int: ti.template(), damping):
    dt = sim_real[R_DT]
    for e in range(tri_nodes.shape[0]):
        eval_tri_elastic(e, node_x, node_v, node_f, tri_nodes, tri_rest_inv, tri_mat, mat_mu, mat_lam,
                         tri_visc, tri_diss, sim_int, dt, damping)


@ti.func
def phase_joints(joint_nodes: ti.template(), joint_mat: ti.template(), joint_state: ti.template(),
                 joint_dmax: ti.template(), joint_fs: ti.template(), joint_work: ti.template(),
                 joint_break: ti.template(), joint_mode: ti.template(), mat_joint: ti.template(),
                 joint_g: ti.template(), node_x: ti.template(), node_v: ti.template(), node_f: ti.template(),
                 sim_real: ti.template(), sim_int: ti.template()):
    for j in range(joint_nodes.shape[0]):
        eval_joint(j, joint_nodes, joint_mat, joint_state, joint_dmax, joint_fs, joint_work, joint_break,
                   joint_mode, mat_joint, joint_g, node_x, node_v, node_f, sim_real, sim_int)


@ti.func
def phase_joint_work(joint_nodes: ti.template(), joint_g: ti.template(), joint_work: ti.template(),
                     node_v: ti.template(), sim_real: ti.template()):
    for j in range(joint_nodes.shape[0]):
        add_joint_work(j, joint_nodes, joint_g, joint_work, node_v, sim_real)


@ti.func
def phase_contact(couple_a: ti.template(), couple_b: ti.template(), node_x: ti.template(), node_v: ti.template(), node_f: ti.template(), tri_nodes: ti.template(), tri_mat: ti.template(), pair_prop: ti.template(), couple_hist: ti.template(),
                  acc: ti.template(), sim_real: ti.template(), sim_int: ti.template(), friction: ti.template(), cdamping):
    dt = sim_real[R_DT]
    for c in range(sim_int[I_COUPLES]):
        eval_couple(c, couple_a, couple_b, node_x, node_v, node_f, tri_nodes, tri_mat, pair_prop,
                    couple_hist, acc, dt, friction, cdamping)


@ti.func
def phase_integrate(node_x: ti.template(), node_v: ti.template(), node_f: ti.template(), node_mass: ti.template(), node_free: ti.template(), node_vbc: ti.template(), acc: ti.template(), sim_real: ti.template(), sim_int: ti.template(),
                    bc, bc_work):
    """Central difference (§6.1): v += Δt (f/m + g); prescribed velocities; x += Δt v; f = 0."""
    N = node_x.shape[0]
    dt = sim_real[R_DT]
    g = vec2(sim_real[R_GX], sim_real[R_GY])
    for _ in range(1):
        sim_real[R_VMAX] = 0.0
    for chunk in range((N + CHUNK - 1) // CHUNK):
        vmax2 = 0.0
        bad = 0
        work = 0.0
        for i in range(chunk * CHUNK, ti.min(N, chunk * CHUNK + CHUNK)):
            m = node_mass[i]
            v = node_v[i] + dt * (node_f[i] / m + g)
            if bc != 0:
                free = node_free[i]
                vb = node_vbc[i]
                if bc_work != 0:
                    # work of the constraint force R = m (v_b − v_free)/Δt over x_{n+1} − x_n = Δt v_b
                    work += ((1.0 - free) * m * (vb - v)).dot(vb)
                v = free * v + (1.0 - free) * vb
            x = node_x[i] + dt * v
            node_v[i] = v
            node_x[i] = x
            node_f[i] = vec2(0.0, 0.0)
            s = v.norm_sqr()
            if not (s < 1e200) or not (ti.abs(x[0]) < 1e200 and ti.abs(x[1]) < 1e200):
                bad = i + 1
            vmax2 = ti.max(vmax2, s)
        ti.atomic_max(sim_real[R_VMAX], ti.sqrt(vmax2))
        if bad > 0:
            ti.atomic_max(sim_int[I_NONFINITE], bad)
        if bc_work != 0:
            ti.atomic_add(acc[A_BOUNDARY], work)
    for _ in range(1):
        # re-detection trigger D_acc += 2 Δt v_max (§4.1)
        sim_real[R_DACC] += 2.0 * dt * sim_real[R_VMAX]
        sim_real[R_TIME] += dt
        if sim_real[R_VMAX] > sim_real[R_VLIMIT]:
            sim_int[I_SPEED] = 1


@ti.func
def status_code(sim_real: ti.template(), sim_int: ti.template()):
    """bit 0: contact detection is due; bit 1: the step produced a non-finite value or an inverted element."""
    code = 0
    if sim_real[R_DACC] >= sim_real[R_BUFFER]:
        code |= 1
    if sim_int[I_NONFINITE] != 0 or sim_int[I_INVERTED] != 0 or sim_int[I_SPEED] != 0:
        code |= 2
    return code


# ---------------------------------------------------------------------------------------------
# kernels
# ---------------------------------------------------------------------------------------------
@ti.kernel
def detect_count(ctri: ti.types.ndarray(), tri_nodes: ti.types.ndarray(), node_x: ti.types.ndarray(),
                 tri_body: ti.types.ndarray(), body_flags: ti.types.ndarray(), cen: ti.types.ndarray(),
                 rad: ti.types.ndarray(), bucket_of: ti.types.ndarray(), slot: ti.types.ndarray(),
                 bucket_count: ti.types.ndarray(), bucket_start: ti.types.ndarray(),
                 sorted_k: ti.types.ndarray(), ccount: ti.types.ndarray(), cnew: ti.types.ndarray(),
                 sim_real: ti.types.ndarray(), sim_int: ti.types.ndarray()) -> ti.i32:
    """Parallel broad phase, first half; returns the number of couples found."""
    phase_detect_count(ctri, tri_nodes, node_x, tri_body, body_flags, cen, rad, bucket_of, slot,
                       bucket_count, bucket_start, sorted_k, ccount, cnew, sim_real, sim_int)
    return sim_int[I_FOUND]


@ti.kernel
def detect_fill(ctri: ti.types.ndarray(), tri_nodes: ti.types.ndarray(), tri_body: ti.types.ndarray(),
                body_flags: ti.types.ndarray(), cen: ti.types.ndarray(), rad: ti.types.ndarray(),
                bucket_count: ti.types.ndarray(), bucket_start: ti.types.ndarray(), sorted_k: ti.types.ndarray(),
                cnew: ti.types.ndarray(), cstart: ti.types.ndarray(), couple_a: ti.types.ndarray(),
                couple_b: ti.types.ndarray(), couple_hist: ti.types.ndarray(), old_start: ti.types.ndarray(),
                old_b: ti.types.ndarray(), old_hist: ti.types.ndarray(), sim_real: ti.types.ndarray(),
                sim_int: ti.types.ndarray(), friction: ti.template()):
    """Parallel broad phase, second half: write the couples."""
    phase_detect_fill(ctri, tri_nodes, tri_body, body_flags, cen, rad, bucket_count, bucket_start, sorted_k,
                      cnew, cstart, couple_a, couple_b, couple_hist, old_start, old_b, old_hist,
                      sim_real, sim_int, friction)


@ti.kernel
def step_parallel(node_x: ti.types.ndarray(), node_v: ti.types.ndarray(), node_f: ti.types.ndarray(),
                  node_mass: ti.types.ndarray(), node_free: ti.types.ndarray(), node_vbc: ti.types.ndarray(),
                  tri_nodes: ti.types.ndarray(), tri_rest_inv: ti.types.ndarray(), tri_mat: ti.types.ndarray(),
                  mat_mu: ti.types.ndarray(), mat_lam: ti.types.ndarray(), tri_visc: ti.types.ndarray(),
                  tri_diss: ti.types.ndarray(), couple_a: ti.types.ndarray(), couple_b: ti.types.ndarray(),
                  pair_prop: ti.types.ndarray(), couple_hist: ti.types.ndarray(), acc: ti.types.ndarray(),
                  sim_real: ti.types.ndarray(), sim_int: ti.types.ndarray(),
                  joint_nodes: ti.types.ndarray(), joint_mat: ti.types.ndarray(), joint_state: ti.types.ndarray(), joint_dmax: ti.types.ndarray(),
                  joint_fs: ti.types.ndarray(), joint_work: ti.types.ndarray(), joint_break: ti.types.ndarray(), joint_mode: ti.types.ndarray(),
                  mat_joint: ti.types.ndarray(),
                  joint_g: ti.types.ndarray(),
                  contact: ti.template(), damping: ti.i32, friction: ti.template(),
                  cdamping: ti.i32, bc: ti.i32, bc_work: ti.i32,
                  fracture: ti.template()) -> ti.i32:
    """One step, each phase a parallel loop.  Returns :func:`status_code`."""
    phase_elastic(node_x, node_v, node_f, tri_nodes, tri_rest_inv, tri_mat, mat_mu, mat_lam, tri_visc,
                  tri_diss, sim_real, sim_int, damping)
    if ti.static(fracture):
        phase_joints(joint_nodes, joint_mat, joint_state, joint_dmax, joint_fs, joint_work, joint_break,
                     joint_mode, mat_joint, joint_g, node_x, node_v, node_f, sim_real, sim_int)
    if ti.static(contact):
        phase_contact(couple_a, couple_b, node_x, node_v, node_f, tri_nodes, tri_mat, pair_prop, couple_hist,
                      acc, sim_real, sim_int, friction, cdamping)
    phase_integrate(node_x, node_v, node_f, node_mass, node_free, node_vbc, acc, sim_real, sim_int, bc, bc_work)
    if ti.static(fracture):
        phase_joint_work(joint_nodes, joint_g, joint_work, node_v, sim_real)
    return status_code(sim_real, sim_int)


@ti.kernel
def run_steps_serial(nsteps: ti.i32, node_x: ti.types.ndarray(), node_v: ti.types.ndarray(),
                     node_f: ti.types.ndarray(), node_mass: ti.types.ndarray(), node_free: ti.types.ndarray(),
                     node_vbc: ti.types.ndarray(), tri_nodes: ti.types.ndarray(), tri_rest_inv: ti.types.ndarray(),
                     tri_mat: ti.types.ndarray(), mat_mu: ti.types.ndarray(), mat_lam: ti.types.ndarray(),
                     tri_visc: ti.types.ndarray(), tri_diss: ti.types.ndarray(), tri_body: ti.types.ndarray(),
                     body_flags: ti.types.ndarray(), ctri: ti.types.ndarray(), cen: ti.types.ndarray(),
                     rad: ti.types.ndarray(), bucket_of: ti.types.ndarray(), slot: ti.types.ndarray(),
                     bucket_count: ti.types.ndarray(), bucket_start: ti.types.ndarray(),
                     sorted_k: ti.types.ndarray(), ccount: ti.types.ndarray(), cnew: ti.types.ndarray(),
                     cstart: ti.types.ndarray(), couple_a: ti.types.ndarray(), couple_b: ti.types.ndarray(),
                     couple_hist: ti.types.ndarray(), old_start: ti.types.ndarray(), old_b: ti.types.ndarray(),
                     old_hist: ti.types.ndarray(), pair_prop: ti.types.ndarray(), acc: ti.types.ndarray(),
                     sim_real: ti.types.ndarray(), sim_int: ti.types.ndarray(),
                     joint_nodes: ti.types.ndarray(), joint_mat: ti.types.ndarray(), joint_state: ti.types.ndarray(), joint_dmax: ti.types.ndarray(),
                  joint_fs: ti.types.ndarray(), joint_work: ti.types.ndarray(), joint_break: ti.types.ndarray(), joint_mode: ti.types.ndarray(),
                  mat_joint: ti.types.ndarray(),
                  joint_g: ti.types.ndarray(),
                     contact: ti.template(), damping: ti.i32, friction: ti.template(),
                     cdamping: ti.i32, bc: ti.i32, bc_work: ti.i32,
                     fracture: ti.template()) -> ti.i32:
    """Up to ``nsteps`` whole steps, detection included, in one serial loop (small scenes).

    Stops early, before the step that needs it, when the couple buffer is too small (the
    count is left in sim_int[I_OVERFLOW]; grow and call again), and after a step that
    produced a non-finite value or an inverted element.  Returns the number of steps done, plus
    ``UNSTABLE_BIT`` when the state is unstable (so the host needs no extra read to know).
    """
    done = 0
    ti.loop_config(serialize=True)
    for _ in range(nsteps):
        stop = 0
        if ti.static(contact):
            if sim_real[R_DACC] >= sim_real[R_BUFFER]:
                phase_detect_count(ctri, tri_nodes, node_x, tri_body, body_flags, cen, rad, bucket_of, slot,
                                   bucket_count, bucket_start, sorted_k, ccount, cnew, sim_real, sim_int)
                if sim_int[I_FOUND] > couple_a.shape[0]:
                    sim_int[I_OVERFLOW] = sim_int[I_FOUND]
                    stop = 1
                else:
                    phase_detect_fill(ctri, tri_nodes, tri_body, body_flags, cen, rad, bucket_count,
                                      bucket_start, sorted_k, cnew, cstart, couple_a, couple_b, couple_hist,
                                      old_start, old_b, old_hist, sim_real, sim_int, friction)
        if stop == 0:
            phase_elastic(node_x, node_v, node_f, tri_nodes, tri_rest_inv, tri_mat, mat_mu, mat_lam, tri_visc,
                          tri_diss, sim_real, sim_int, damping)
            if ti.static(fracture):
                phase_joints(joint_nodes, joint_mat, joint_state, joint_dmax, joint_fs, joint_work, joint_break,
                             joint_mode, mat_joint, joint_g, node_x, node_v, node_f, sim_real, sim_int)
            if ti.static(contact):
                phase_contact(couple_a, couple_b, node_x, node_v, node_f, tri_nodes, tri_mat, pair_prop,
                              couple_hist, acc, sim_real, sim_int, friction, cdamping)
            phase_integrate(node_x, node_v, node_f, node_mass, node_free, node_vbc, acc, sim_real, sim_int,
                            bc, bc_work)
            if ti.static(fracture):
                phase_joint_work(joint_nodes, joint_g, joint_work, node_v, sim_real)
            done += 1
            if sim_int[I_NONFINITE] != 0 or sim_int[I_INVERTED] != 0 or sim_int[I_SPEED] != 0:
                stop = 1
        if stop != 0:
            break
    # steps done, plus UNSTABLE_BIT when the last step left a non-finite / inverted / too-fast state
    return done + ti.select(status_code(sim_real, sim_int) >= 2, UNSTABLE_BIT, 0)


# ---------------------------------------------------------------------------------------------
# single-phase kernels: force evaluation without a step, and per-phase profiling
# ---------------------------------------------------------------------------------------------
@ti.kernel
def eval_elastic(node_x: ti.types.ndarray(), node_v: ti.types.ndarray(), node_f: ti.types.ndarray(),
                 tri_nodes: ti.types.ndarray(), tri_rest_inv: ti.types.ndarray(), tri_mat: ti.types.ndarray(),
                 mat_mu: ti.types.ndarray(), mat_lam: ti.types.ndarray(), tri_visc: ti.types.ndarray(),
                 tri_diss: ti.types.ndarray(), sim_real: ti.types.ndarray(), sim_int: ti.types.ndarray(),
                 damping: ti.i32):
    phase_elastic(node_x, node_v, node_f, tri_nodes, tri_rest_inv, tri_mat, mat_mu, mat_lam, tri_visc,
                  tri_diss, sim_real, sim_int, damping)


@ti.kernel
def eval_joints(joint_nodes: ti.types.ndarray(), joint_mat: ti.types.ndarray(), joint_state: ti.types.ndarray(), joint_dmax: ti.types.ndarray(),
                joint_fs: ti.types.ndarray(), joint_work: ti.types.ndarray(), joint_break: ti.types.ndarray(), joint_mode: ti.types.ndarray(),
                mat_joint: ti.types.ndarray(),
                  joint_g: ti.types.ndarray(),
                node_x: ti.types.ndarray(), node_v: ti.types.ndarray(), node_f: ti.types.ndarray(), sim_real: ti.types.ndarray(), sim_int: ti.types.ndarray()):
    phase_joints(joint_nodes, joint_mat, joint_state, joint_dmax, joint_fs, joint_work, joint_break,
                 joint_mode, mat_joint, joint_g, node_x, node_v, node_f, sim_real, sim_int)


@ti.kernel
def eval_contact(couple_a: ti.types.ndarray(), couple_b: ti.types.ndarray(), node_x: ti.types.ndarray(),
                 node_v: ti.types.ndarray(), node_f: ti.types.ndarray(), tri_nodes: ti.types.ndarray(),
                 tri_mat: ti.types.ndarray(), pair_prop: ti.types.ndarray(), couple_hist: ti.types.ndarray(),
                 acc: ti.types.ndarray(), sim_real: ti.types.ndarray(), sim_int: ti.types.ndarray(),
                 friction: ti.template(), cdamping: ti.i32):
    phase_contact(couple_a, couple_b, node_x, node_v, node_f, tri_nodes, tri_mat, pair_prop, couple_hist,
                  acc, sim_real, sim_int, friction, cdamping)


@ti.kernel
def integrate(node_x: ti.types.ndarray(), node_v: ti.types.ndarray(), node_f: ti.types.ndarray(),
              node_mass: ti.types.ndarray(), node_free: ti.types.ndarray(), node_vbc: ti.types.ndarray(),
              acc: ti.types.ndarray(), sim_real: ti.types.ndarray(), sim_int: ti.types.ndarray(),
              bc: ti.i32, bc_work: ti.i32) -> ti.i32:
    phase_integrate(node_x, node_v, node_f, node_mass, node_free, node_vbc, acc, sim_real, sim_int, bc, bc_work)
    return status_code(sim_real, sim_int)


@ti.kernel
def book_joint_work(joint_nodes: ti.types.ndarray(), joint_g: ti.types.ndarray(), joint_work: ti.types.ndarray(),
                    node_v: ti.types.ndarray(), sim_real: ti.types.ndarray()):
    phase_joint_work(joint_nodes, joint_g, joint_work, node_v, sim_real)

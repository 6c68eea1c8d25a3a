"""State that is derived from other state, re-derived after a restore or an excavation.

During a run the step keeps these up to date itself; these kernels recompute them from what
they are derived from when the state was replaced (checkpoint load, last good state) or
changed by the host (an excavation), with the same functions as the step, so that a restart
is bit-identical.
"""
import taichi as ti

from .contact import edge_pair_bonded, shared_vertices
from .groups import NB_HELD, NB_PAIRS, ContactGroup, JointGroup, StepGroup, TriGroup
from .joints import (FAN_ENTRY, FAN_HEAD, damaged_beyond, fan_code_bit, fan_joint_base, fan_mask_slot, softening_z,
                     switch_on_corners)


@ti.func
def joint_cut(j, joints: ti.template(), tris: ti.template()):
    """Does joint j no longer tie the corner pairs around its ends: damaged or broken (the event
    on which :func:`taichi_fdem.engine.joints.add_joint_work` switches them on), or a triangle
    removed (its forces are skipped from then on)?  (Edge pairs follow the tri_intact bits.)"""
    jt = joints.joint_tris[j]
    return damaged_beyond(j, 0.0, joints) or tris.tri_intact[jt[0]] < 0 or tris.tri_intact[jt[1]] < 0


@ti.kernel
def refresh_neighbours(tris: TriGroup, contact: ContactGroup, joints: JointGroup, step: StepGroup):
    """tris.tri_nb_on from the joints and the tri_intact bits: each fan's link mask (its missing
    links, and the links whose joint is cut, :func:`joint_cut`), then 1 for a neighbour pair no
    longer bonded (:func:`taichi_fdem.engine.contact.edge_pair_bonded`,
    :func:`taichi_fdem.engine.joints.corner_bonded`), 0 for a bonded one (contact skips its
    forces) or one with a removed triangle; NB_HELD added where a pair holds friction slip.  At build, at a restore and after an excavation;
    during a run the joints keep it up to date
    (:func:`taichi_fdem.engine.joints.switch_on_neighbours`)."""
    V = tris.tri_fans[0]
    for v in range(V):
        tris.tri_nb_on[fan_mask_slot(v, step)] = tris.tri_fans[FAN_HEAD + V + 1 + v]
    for j in range(tris.tri_fans[1]):
        if joint_cut(j, joints, tris):
            base = fan_joint_base(j, tris)
            for end in ti.static(range(2)):
                code = tris.tri_fans[base + end]
                if code >= 0:
                    v, bit = fan_code_bit(code)
                    ti.atomic_or(tris.tri_nb_on[fan_mask_slot(v, step)], bit)
    for p in range(step.step_int[NB_PAIRS]):
        A = contact.couple_a[p]
        B = contact.couple_b[p]
        shared, _, _ = shared_vertices(tris.tri_origin[A], tris.tri_origin[B])
        if shared != 1:                      # corner pairs: below, from their fan
            on = 0
            if tris.tri_intact[A] >= 0 and tris.tri_intact[B] >= 0 and not edge_pair_bonded(A, B, tris):
                on = 1
            tris.tri_nb_on[p] = on
    for v in range(V):
        k0 = tris.tri_fans[FAN_HEAD + v]
        for i in range((tris.tri_fans[FAN_HEAD + v + 1] - k0) // FAN_ENTRY):
            tris.tri_nb_on[tris.tri_fans[k0 + FAN_ENTRY * i]] = 0
        switch_on_corners(v, tris.tri_nb_on[fan_mask_slot(v, step)], tris)
    # the NB_HELD bit of the pairs that hold friction slip (engine.contact.couple_forces)
    if contact.couple_hist.shape[0] >= 6 * step.step_int[NB_PAIRS]:
        for p in range(step.step_int[NB_PAIRS]):
            if tris.tri_nb_on[p] != 0:
                for s in ti.static(range(6)):
                    if contact.couple_hist[6 * p + s] != 0.0:
                        tris.tri_nb_on[p] |= NB_HELD


@ti.kernel
def refresh_joint_z(joints: JointGroup):
    """joints.joint_zmax = z(joint_dmax) (:func:`taichi_fdem.engine.joints.softening_z`, 1 where
    undamaged), the values the step keeps: after a restore (older checkpoints lack them)."""
    for j in range(joints.joint_dmax.shape[0]):
        dmax = joints.joint_dmax[j]
        z = ti.Vector([1.0, 1.0, 1.0], dt=float)
        for p in ti.static(range(3)):
            if dmax[p] > 0.0:
                z[p] = softening_z(dmax[p])
        joints.joint_zmax[j] = z

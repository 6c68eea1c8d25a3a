"""State that is derived from other state, re-derived after a restore or an excavation.

During a run the step keeps these up to date itself; these kernels recompute them from what
they are derived from when the state was replaced (checkpoint load, last good state) or
changed by the host (an excavation), with the same functions as the step, so that a restart
is bit-identical.
"""
import taichi as ti

from .contact import is_bonded
from .groups import NB_PAIRS, ContactGroup, JointGroup, StepGroup, TriGroup
from .joints import softening_z


@ti.kernel
def refresh_neighbours(tris: TriGroup, con: ContactGroup, step: StepGroup):
    """tris.tri_nb_on from the tri_intact bits: 1 for a neighbour pair no longer bonded
    (:func:`taichi_fdem.engine.contact.is_bonded`), 0 for a bonded one or one with a removed
    triangle.  At build, at a restore and after an excavation; during a run the joints keep it
    up to date (:func:`taichi_fdem.engine.joints.switch_on_neighbours`)."""
    for p in range(step.step_int[NB_PAIRS]):
        A = con.couple_a[p]
        B = con.couple_b[p]
        on = 0
        if tris.tri_intact[A] >= 0 and tris.tri_intact[B] >= 0 and not is_bonded(A, B, tris):
            on = 1
        tris.tri_nb_on[p] = on


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

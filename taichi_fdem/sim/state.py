"""The state and the scratch of a simulation, and the argpacks the kernels take.

:func:`allocate_state` gives the initial :class:`~taichi_fdem.sim.model.State` of a
:class:`~taichi_fdem.sim.model.Model` (positions, velocities, the joints' and triangles' evolving
arrays, the couple buffer with the neighbour pairs first); :func:`allocate_scratch` the work
arrays of detection and of the parallel assembly; :func:`pack_groups` the argpacks of
:mod:`taichi_fdem.engine.groups` drawn from all three.  Element types and shapes are the
declared ones (:mod:`taichi_fdem.engine.arrays`), evaluated at :func:`state_sizes` and
:func:`scratch_sizes`.
"""
from __future__ import annotations

import numpy as np

from ..engine.arrays import SCRATCH, STATE
from ..engine.groups import (ASSEMBLY_MEMBERS, DACC_FORCE, FORCE_BLOCKS, GROUPS, HEAT_STEP_MEMBERS,
                             SERIAL_FLUID_MEMBERS, SWITCH_BC, SWITCH_BC_WORK, SWITCH_CDAMPING, SWITCH_DAMPING,
                             SWITCH_PRESTRESS, TEAM_CHUNK, TEAM_MEMBERS, HeatStepGroup, SerialFluidGroup, TeamGroup)
from .arrays import allocate
from .fluid import fluid_state_values
from .heat import heat_state_values
from .model import Model, Scratch, State


# -------------------------------------------------------------------------------------------------
# state and scratch
# -------------------------------------------------------------------------------------------------
def nb_on_size(md: Model) -> int:
    """Length of ``state.tri_nb_on``: a flag per neighbour pair, then a link mask per fan."""
    return max(md.nb_count + md.fan_count, 1)


def state_sizes(md: Model, st: State) -> dict:
    """The size symbols of the state's declared shapes: the model's and the couple capacity C."""
    return {**md.sizes, "C": st.couple_max}


def allocate_state(md: Model) -> State:
    """The initial :class:`State` of a model: rest positions, initial velocities, and a couple
    list holding only the neighbour pairs (:func:`install_neighbour_pairs`; detection is due).
    Every declared state array (engine.arrays) not given a value here starts at zero."""
    st = State()
    K = md.ctri_count if md.contact else 1
    st.couple_max = md.nb_count + 2 * K + 64 if md.contact else 1
    allocate(st, STATE, state_sizes(md, st), {
        "node_x": md.node_rest, "node_v": md.node_velocity0,
        "node_vbc": md.node_vbc0 if md.has_bc else np.zeros((1, 2)),
        "tri_intact": md.tri_intact0_np,                # (tri_nb_on: set by Simulation, refresh_neighbours)
        "joint_zmax": np.ones((md.sizes["J"], 3)),      # z(dmax), z(0) = 1
        "joint_fs": md.joint_fs0, **fluid_state_values(md), **heat_state_values(md)})
    install_neighbour_pairs(md, st)
    set_parameters(md, st)
    c = st.counters
    if md.contact:
        c.dacc = DACC_FORCE                             # detect at the first step
    return st


def set_parameters(md: Model, st: State) -> None:
    """Write the parameters the kernels read from the model into their slots of the state's
    ``step_real`` and ``step_int`` (engine.arrays.REAL_SLOTS, INT_SLOTS): time step, detection
    buffer, speed limit, gravity, the local damping's α, the handover damage and the feature
    switches (engine.groups.SWITCH_DAMPING, ...)."""
    c = st.counters
    c.dt = md.dt
    c.buffer = md.buffer
    c.vlimit = md.speed_limit
    c.gravity_x, c.gravity_y = md.gravity
    c.qs_alpha = md.qs_alpha
    c.handover = md.handover_damage
    c.switches = (SWITCH_DAMPING * md.damping + SWITCH_CDAMPING * md.contact_damping + SWITCH_BC * md.has_bc
                  + SWITCH_BC_WORK * md.has_bc_work + SWITCH_PRESTRESS * md.prestress)


def install_neighbour_pairs(md: Model, st: State) -> None:
    """Make the model's neighbour pairs the first couples of the state, with no slip history, and
    drop the other couples (a detection is due): at the start, and when a checkpoint written
    before neighbour pairs is loaded."""
    M = md.nb_count
    c = st.counters
    c.nb_pairs = M
    if not md.contact:
        return
    if st.couple_max < M + 64:
        grow_couples(md, st, M + 2 * md.ctri_count + 64)
    if M:
        a = st.couple_a.to_numpy()
        b = st.couple_b.to_numpy()
        a[:M], b[:M] = md.nb_pairs_np[:, 0], md.nb_pairs_np[:, 1]
        st.couple_a.from_numpy(a)
        st.couple_b.from_numpy(b)
        if md.friction:
            h = st.couple_hist.to_numpy()
            h[: 6 * M] = 0.0
            st.couple_hist.from_numpy(h)
    c.couples = M
    c.rebalance = 0
    c.dacc = DACC_FORCE


def grow_couples(md: Model, st: State, capacity: int) -> None:
    """(Re)allocate the couple buffer of ``st`` with room for ``capacity`` couples, keeping its
    content (couples and their friction history)."""
    keep = st.counters.couples
    values = {}
    if keep:
        for name, per in (("couple_a", 1), ("couple_b", 1)) + ((("couple_hist", 6),) if md.friction else ()):
            old = getattr(st, name).to_numpy()
            new = np.zeros(per * capacity, old.dtype)
            new[:per * keep] = old[:per * keep]
            values[name] = new
    st.couple_max = capacity
    allocate(st, STATE, state_sizes(md, st), values, names=("couple_a", "couple_b", "couple_hist"))


def scratch_sizes(md: Model, st: State, sw: Scratch) -> dict:
    """The size symbols of the scratch's declared shapes: the state's and the assembly's."""
    blocks, slots = sw.parallel and sw.blocks, sw.parallel and not sw.blocks
    team = sw.force_blocks if blocks else 0
    return {**state_sizes(md, st), "FB": sw.force_blocks, "blocks": blocks, "slots": slots, "T": team,
            "U": -(-md.node_count // TEAM_CHUNK) if team else 0}          # engine.blocks.chunk_count


def allocate_scratch(md: Model, st: State, parallel: bool = False, blocks: bool = True,
                     force_blocks: int = FORCE_BLOCKS) -> Scratch:
    """Detection work arrays sized for the model's contact triangles and the state's couple
    buffer, and (``parallel``) the assembly arrays of the parallel strategy: the block copies of
    the nodal forces (``blocks``, the CPU default) or the force slots and node lists; all zero."""
    sw = Scratch()
    sw.parallel = bool(parallel)
    sw.blocks = bool(blocks)
    sw.force_blocks = int(force_blocks)
    allocate(sw, SCRATCH, scratch_sizes(md, st, sw))
    return sw


def size_couple_scratch(md: Model, st: State, sw: Scratch) -> None:
    """Reallocate (zero) the scratch sized by the couple buffer: the certificates, the
    previous-couple copies that carry friction history over, and the assembly arrays."""
    allocate(sw, SCRATCH, scratch_sizes(md, st, sw), names=("couple_skip", "det_old_b", "det_old_hist", "heat_cpl", "heat_cpl_tri", "heat_ct"))
    size_assembly(md, st, sw)


def size_assembly(md: Model, st: State, sw: Scratch) -> None:
    """Reallocate (zero) the parallel strategy's assembly arrays (1-element placeholders otherwise).

    Blocks (``sw.blocks``): a copy of the nodal forces for each block but the first (which adds
    into node_f), block-major (asm_force[(b − 1) N + n]), then two entries per block for its
    dissipated contact work (even and odd steps); all zero between steps (the gather resets
    them); the barrier counter, the flags and the per-chunk partials of
    :func:`taichi_fdem.engine.step.run_steps_blocks` (asm_sync, asm_part).  Slots:
    one force slot per triangle node (3) and couple node (6), and the node lists (3 per
    triangle, 4 per joint, 6 per couple) with their starts.  Shapes: engine.arrays.
    """
    allocate(sw, SCRATCH, scratch_sizes(md, st, sw), names=ASSEMBLY_MEMBERS)


def pack_groups(md: Model, st: State, sw: Scratch) -> dict:
    """The argpacks the kernels take, {group name: ArgPack}, drawn from model, state and scratch,
    and "team": the one argpack of the team launch (engine.groups.TeamGroup).

    Build again after any array of the state is reallocated (the couple buffer grows).
    """
    packs, arrays = {}, {}
    for group, (ptype, names) in GROUPS.items():
        for name in names:
            arr = getattr(st, name, None)
            if arr is None:
                arr = getattr(md, name, None)
            if arr is None:
                arr = getattr(sw, name)
            arrays[name] = arr
        packs[group] = ptype(**{name: arrays[name] for name in names})
    packs["team"] = TeamGroup(**{name: arrays[name] for name in TEAM_MEMBERS})
    if getattr(md, "heat", False):
        packs["heat_step"] = HeatStepGroup(**{name: arrays[name] for name in HEAT_STEP_MEMBERS})
    if getattr(md, "fluid", False):
        for name in SERIAL_FLUID_MEMBERS:
            if name not in arrays:
                arrays[name] = getattr(sw, name)
        packs["serial_fluid"] = SerialFluidGroup(**{name: arrays[name] for name in SERIAL_FLUID_MEMBERS})
    return packs

"""The state and the scratch of a simulation, and the argpacks the kernels take.

:func:`allocate_state` gives the initial :class:`~taichi_fdem.sim.model.State` of a
:class:`~taichi_fdem.sim.model.Model` (positions, velocities, the joints' and triangles' evolving
arrays, the couple buffer with the neighbour pairs first); :func:`allocate_scratch` the work
arrays of detection and of the parallel assembly; :func:`pack_groups` the argpacks of
:mod:`taichi_fdem.engine.groups` drawn from all three.
"""
from __future__ import annotations

import numpy as np
import taichi as ti

from .. import backend
from ..engine.groups import (COUPLES, DACC, DACC_FORCE, DET_CAND, FORCE_BLOCKS, GROUPS, HANDOVER, INT_COUNTERS,
                            NB_PAIRS, QS_ALPHA, REAL_COUNTERS, REBALANCE, SERIAL_FLUID_MEMBERS, SYNC_LINE, TEAM_CHUNK,
                            TEAM_MEMBERS, SerialFluidGroup, TeamGroup)
from .fluid import allocate_fluid_state
from .model import Model, Scratch, State, _ndarray, _next_pow2, counter, set_counter


# -------------------------------------------------------------------------------------------------
# state and scratch
# -------------------------------------------------------------------------------------------------
def nb_on_size(md: Model) -> int:
    """Length of ``state.tri_nb_on``: a flag per neighbour pair, then a link mask per fan."""
    return max(md.nb_count + md.fan_count, 1)


def allocate_state(md: Model) -> State:
    """The initial :class:`State` of a model: rest positions, initial velocities, and a couple
    list holding only the neighbour pairs (:func:`install_neighbour_pairs`; detection is due)."""
    real, rti = backend.real_np(), backend.real_ti()
    st = State()
    v2 = lambda a: _ndarray(np.asarray(a, real), rti, vec=2)
    sc = lambda a: _ndarray(np.asarray(a, real), rti)
    i32 = lambda a: _ndarray(np.asarray(a, np.int32), ti.i32)
    st.node_x = v2(md.node_rest)
    st.node_v = v2(md.node_velocity0)
    st.node_f = v2(np.zeros_like(md.node_rest))
    st.node_vbc = v2(md.node_vbc0 if md.has_bc else np.zeros((1, 2)))
    st.node_react = v2(np.zeros_like(md.node_rest) if md.has_bc else np.zeros((1, 2)))
    st.load_force = _ndarray(np.zeros((max(md.load_count, 1), 4), real), rti, vec=4)
    st.tri_diss = sc(np.zeros(md.tri_count if md.damping else 1))
    st.tri_intact = i32(md.tri_intact0_np)
    st.tri_nb_on = i32(np.zeros(nb_on_size(md)))                 # set by Simulation (refresh_neighbours)
    nj = md.joint_nodes.shape[0]
    st.joint_state = i32(np.zeros(nj))
    st.joint_dmax = _ndarray(np.zeros((nj, 3), real), rti, vec=3)
    st.joint_zmax = _ndarray(np.ones((nj, 3), real), rti, vec=3)              # z(dmax), z(0) = 1
    st.joint_fs = _ndarray(md.joint_fs0.astype(real), rti, vec=3)
    st.joint_work = sc(np.zeros(nj))
    st.joint_break = _ndarray(np.zeros((nj, 4), real), rti, vec=4)
    st.joint_g = _ndarray(np.zeros((nj, 4), real), rti, vec=4)
    K = md.ctri_count if md.contact else 1
    st.couple_start = i32(np.zeros(K + 1 if md.friction else 1))
    st.couple_max = 0
    st.step_real = ti.ndarray(rti, shape=REAL_COUNTERS)          # slots: engine.groups.TIME, ...
    st.step_real.fill(0)
    st.step_int = ti.ndarray(ti.i32, shape=INT_COUNTERS)         # slots: engine.groups.COUPLES, ...
    st.step_int.fill(0)
    allocate_fluid_state(md, st)
    grow_couples(md, st, md.nb_count + 2 * K + 64 if md.contact else 1)
    install_neighbour_pairs(md, st)
    set_counter(st.step_real, QS_ALPHA, md.qs_alpha)
    set_counter(st.step_real, HANDOVER, md.handover_damage)
    if md.contact:
        set_counter(st.step_real, DACC, DACC_FORCE)                   # detect at the first step
    return st


def install_neighbour_pairs(md: Model, st: State) -> None:
    """Make the model's neighbour pairs the first couples of the state, with no slip history, and
    drop the other couples (a detection is due): at the start, and when a checkpoint written
    before neighbour pairs is loaded."""
    M = md.nb_count
    set_counter(st.step_int, NB_PAIRS, M)
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
    set_counter(st.step_int, COUPLES, M)
    set_counter(st.step_int, REBALANCE, 0)
    set_counter(st.step_real, DACC, DACC_FORCE)


def grow_couples(md: Model, st: State, capacity: int) -> None:
    """(Re)allocate the couple buffer of ``st`` with room for ``capacity`` couples, keeping its
    content (couples and their friction history)."""
    rti = backend.real_ti()
    keep = counter(st.step_int, COUPLES) if st.couple_max else 0
    old = None
    if keep:
        old = (st.couple_a.to_numpy()[:keep], st.couple_b.to_numpy()[:keep],
               st.couple_hist.to_numpy()[:6 * keep] if md.friction else None)
    st.couple_a = ti.ndarray(ti.i32, shape=capacity)
    st.couple_b = ti.ndarray(ti.i32, shape=capacity)
    hcap = 6 * capacity if md.friction else 1
    st.couple_hist = ti.ndarray(rti, shape=hcap)
    if old is not None:
        a = np.zeros(capacity, np.int32); a[:keep] = old[0]; st.couple_a.from_numpy(a)
        b = np.zeros(capacity, np.int32); b[:keep] = old[1]; st.couple_b.from_numpy(b)
        if md.friction:
            h = np.zeros(hcap, backend.real_np()); h[:6 * keep] = old[2]; st.couple_hist.from_numpy(h)
    st.couple_max = capacity


def allocate_scratch(md: Model, st: State, parallel: bool = False, blocks: bool = True,
                     force_blocks: int = FORCE_BLOCKS) -> Scratch:
    """Detection work arrays sized for the model's contact triangles and the state's couple
    buffer, and (``parallel``) the assembly arrays of the parallel strategy: the block copies of
    the nodal forces (``blocks``, the CPU default) or the force slots and node lists."""
    rti = backend.real_ti()
    sw = Scratch()
    sw.parallel = bool(parallel)
    sw.blocks = bool(blocks)
    sw.force_blocks = int(force_blocks)
    K = md.ctri_count if md.contact else 1
    H = _next_pow2(2 * K) if md.contact else 1
    sw.det_bound = ti.Vector.ndarray(13, rti, shape=K)   # circle (c, r), box (lo, hi), vertices
    sw.det_sort = ti.Vector.ndarray(3, ti.i32, shape=K)
    sw.det_bucket = ti.Vector.ndarray(2, ti.i32, shape=H)
    # det_cnew: the K + 1 counts, then DET_CAND partners per contact triangle (engine.detection.cand_slot)
    for name, n in (("cnew", K + 1 + DET_CAND * K), ("old_start", K + 1 if md.friction else 1)):
        setattr(sw, "det_" + name, ti.ndarray(ti.i32, shape=n))
    size_couple_scratch(md, st, sw)
    return sw


def size_couple_scratch(md: Model, st: State, sw: Scratch) -> None:
    """Scratch sized by the couple buffer: the previous-couple copies that carry friction history
    over, and the assembly arrays (:func:`size_assembly`)."""
    cap = st.couple_max
    sw.couple_skip = ti.ndarray(backend.real_ti(), shape=cap if md.contact else 1)   # no certificates
    sw.couple_skip.fill(0)
    sw.det_old_b = ti.ndarray(ti.i32, shape=cap if md.friction else 1)
    sw.det_old_hist = ti.ndarray(backend.real_ti(), shape=6 * cap if md.friction else 1)
    size_assembly(md, st, sw)


def size_assembly(md: Model, st: State, sw: Scratch) -> None:
    """The parallel strategy's assembly arrays (1-element placeholders otherwise).

    Blocks (``sw.blocks``): a copy of the nodal forces for each block but the first (which adds
    into node_f), block-major (asm_force[(b − 1) N + n]), then two entries per block for its
    dissipated contact work (even and odd steps); all zero between steps (the gather resets
    them); the barrier counter, the flags and the per-chunk partials of
    :func:`taichi_fdem.engine.step.run_steps_blocks` (asm_sync, asm_part).  Slots:
    one force slot per triangle node (3) and couple node (6), and the node lists (3 per
    triangle, 4 per joint, 6 per couple) with their starts.
    """
    rti = backend.real_ti()
    N = md.node_count
    if sw.parallel and sw.blocks:
        sw.asm_force = ti.Vector.ndarray(2, rti, shape=(sw.force_blocks - 1) * N + 2 * sw.force_blocks)
        sw.asm_node_slots = ti.ndarray(ti.i32, shape=1)
        sw.asm_node_start = ti.ndarray(ti.i32, shape=1)
    elif sw.parallel:
        ncap = st.couple_max if md.contact else 0
        sw.asm_force = ti.Vector.ndarray(2, rti, shape=3 * md.tri_count + 6 * ncap)
        sw.asm_node_slots = ti.ndarray(ti.i32, shape=3 * md.tri_count + 4 * md.joint_count + 6 * ncap)
        sw.asm_node_start = ti.ndarray(ti.i32, shape=N + 1)
    else:
        sw.asm_force = ti.Vector.ndarray(2, rti, shape=1)
        sw.asm_node_slots = ti.ndarray(ti.i32, shape=1)
        sw.asm_node_start = ti.ndarray(ti.i32, shape=1)
    team = sw.force_blocks if sw.parallel and sw.blocks else 0
    chunks = -(-N // TEAM_CHUNK) if team else 0                  # engine.blocks.chunk_count
    # engine.team: two lines of counters, a claim slot per unit (blocks or chunks), each chunk's
    # non-finite flag; each chunk's largest |v|², constraint and local-damping work
    sw.asm_sync = ti.ndarray(ti.i32, shape=2 * SYNC_LINE + max(team, chunks) + chunks)
    sw.asm_sync.fill(0)
    sw.asm_part = ti.ndarray(rti, shape=max(1, 3 * chunks))


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
    if getattr(md, "fluid", False):
        for name in SERIAL_FLUID_MEMBERS:
            if name not in arrays:
                arrays[name] = getattr(sw, name)
        packs["serial_fluid"] = SerialFluidGroup(**{name: arrays[name] for name in SERIAL_FLUID_MEMBERS})
    return packs

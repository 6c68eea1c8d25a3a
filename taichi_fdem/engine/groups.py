"""The arrays of a simulation, grouped by concern, as Taichi argpacks.

A kernel takes a handful of groups instead of sixty arrays and reads ``nodes.node_x[i]``,
``tris.tri_rest_inv[e]``, ``step.step_real[DT]``.  The members of each group, their element types,
shapes and units are declared once in :mod:`taichi_fdem.engine.arrays` (the table of
docs/reference/arrays.md is generated from it); the member tuples below are generated from those
declarations, in declaration order.  A member has the name of its array in the model, the state
or the scratch (prefix-first): Taichi flattens argpack members into one namespace per kernel, so
names are unique across groups.  Every member is a Taichi ndarray (no recompilation per scene
size; the element type follows the precision chosen by ``fdem.init``); the scalars (counters
and the parameters the host sets) are named slots of ``step_real`` and ``step_int``, read and
written as ``step.step_real[DT]``.

Budget.  Taichi 1.7 allows at most 64 argument leaves per kernel launch, and every ndarray in
an argpack is one leaf (plus one per argpack).  The serial step kernel takes every group but the
assembly's: :data:`LEAVES_SERIAL` counts its leaves.  Arrays of one entity and type that are
always used together are therefore merged into a vector (circle = centre + radius, bucket = first
+ count), a quantity that can be derived is not stored (A0 from F0⁻¹), and the counters the
kernels keep and the parameters the host sets are two short arrays with named slots
(:data:`taichi_fdem.engine.arrays.REAL_SLOTS`, :data:`~taichi_fdem.engine.arrays.INT_SLOTS`).
Every step kernel keeps :data:`LEAVES_FREE` leaves free for new arrays (checked at import).
"""
import taichi as ti

from .arrays import (DET_CAND, GROUP_ORDER, INT_COUNTERS, INT_SLOTS, MAX_FORCE_BLOCKS,  # noqa: F401 (exported)
                     REAL_COUNTERS, REAL_SLOTS, SYNC_LINE, members, slot_numbers)

_nd = ti.types.ndarray()


def _group(*names):
    return ti.types.argpack(**{n: _nd for n in names})


# the members of each group (engine.arrays.ARRAYS, in declaration order)
NODE_MEMBERS = members("nodes")
TRI_MEMBERS = members("tris")
MAT_MEMBERS = members("mats")
CONTACT_MEMBERS = members("contact")
DETECT_MEMBERS = members("detect")
ASSEMBLY_MEMBERS = members("asm")
JOINT_MEMBERS = members("joints")
STEP_MEMBERS = members("step")
STEP_COUNTERS = ("step_real", "step_int")
FLUID_MEMBERS = members("fluid")
HEAT_MEMBERS = members("heat")

NodeGroup = _group(*NODE_MEMBERS)
TriGroup = _group(*TRI_MEMBERS)
MaterialGroup = _group(*MAT_MEMBERS)
ContactGroup = _group(*CONTACT_MEMBERS)
DetectGroup = _group(*DETECT_MEMBERS)
AssemblyGroup = _group(*ASSEMBLY_MEMBERS)
JointGroup = _group(*JOINT_MEMBERS)
StepGroup = _group(*STEP_MEMBERS)
FluidGroup = _group(*FLUID_MEMBERS)
HeatGroup = _group(*HEAT_MEMBERS)

# group -> (argpack type, member names), in the order of engine.arrays.GROUP_ORDER
GROUPS = {"nodes": (NodeGroup, NODE_MEMBERS), "tris": (TriGroup, TRI_MEMBERS), "mats": (MaterialGroup, MAT_MEMBERS),
          "contact": (ContactGroup, CONTACT_MEMBERS), "detect": (DetectGroup, DETECT_MEMBERS),
          "joints": (JointGroup, JOINT_MEMBERS), "step": (StepGroup, STEP_MEMBERS),
          "asm": (AssemblyGroup, ASSEMBLY_MEMBERS), "fluid": (FluidGroup, FLUID_MEMBERS),
          "heat": (HeatGroup, HEAT_MEMBERS)}
assert tuple(GROUPS) == GROUP_ORDER, (tuple(GROUPS), GROUP_ORDER)

# The serial step of a scene with a fluid (engine.step.run_steps_serial_fluid) takes every group
# of the serial step and the fluid's as ONE argpack, as the team launch does: eight argpacks
# would pass Taichi's 64 leaves (LEAVES_SERIAL_FLUID)
SERIAL_FLUID_MEMBERS = (NODE_MEMBERS + TRI_MEMBERS + MAT_MEMBERS + CONTACT_MEMBERS + DETECT_MEMBERS + JOINT_MEMBERS
                        + STEP_MEMBERS + FLUID_MEMBERS)
SerialFluidGroup = _group(*SERIAL_FLUID_MEMBERS)

# The heat's kernels (engine.heat: the heat steps and the contacts' conductances) take the few
# arrays of the other groups they read and the heat group as ONE argpack, passed as each group:
# a launch's cost grows with its arrays, and the heat steps are launched often
HEAT_STEP_MEMBERS = ("node_x", "curve_points", "tri_nodes", "tri_intact", "couple_a", "couple_b", "joint_nodes",
                     "joint_state", "joint_zmax", "step_int") + HEAT_MEMBERS
HeatStepGroup = _group(*HEAT_STEP_MEMBERS)

# The team launch of the parallel strategy (engine.step.run_steps_blocks) takes every group but
# the slot lists of the assembly, detection included, as ONE argpack: seven argpacks would cost
# seven leaves more than the 64 Taichi allows (LEAVES_TEAM).  Its members keep their names, so
# the kernel passes the one argpack as each group of the phases.
TEAM_MEMBERS = (NODE_MEMBERS + TRI_MEMBERS + MAT_MEMBERS + CONTACT_MEMBERS + DETECT_MEMBERS + JOINT_MEMBERS
                + STEP_MEMBERS + tuple(n for n in ASSEMBLY_MEMBERS if n not in ("asm_node_start", "asm_node_slots")))
TeamGroup = _group(*TEAM_MEMBERS)

# Block assembly of the parallel strategy on the CPU (docs/theory/elements.md §6.1; see engine.step): the items
# are split into a fixed number of blocks, each a contiguous range (triangles, joints and nodes by
# count, couples by estimated cost: engine.blocks.rebalance_couples), and each block adds its forces
# into its own copy of the nodal forces.  Contiguous ranges keep a block's nodes in its core's
# cache.  The number of blocks is a property of the simulation (``sim.solver.force_blocks``,
# FORCE_BLOCKS by default), not the thread count, and the couple ranges a function of the state, so
# that the sums, and the results, are the same bits for any number of threads; at most that many
# threads share the force work.  (DET_CAND, MAX_FORCE_BLOCKS and SYNC_LINE: engine.arrays.)
FORCE_BLOCKS = 2
REBALANCE_STEPS = 512     # steps between two recomputations of the couple ranges (and after a detection): a
                          # serial pass over the couples while the other workers wait
# estimated costs per step, in ns on one thread, for the blocks' couple ranges
# (engine.blocks.rebalance_couples): a couple bonded or skipped by its certificate of separation,
# plus, for a certified one, the share of steps its certificate runs out (D_acc's growth per step
# over its gap) times a separation test; a touching couple; a triangle's elastic forces; an intact,
# a damaged and a broken joint
COST_BONDED = 4
COST_CERTIFIED = 4
COST_SEPARATED = 25
COST_TOUCHING = 200
COST_TRI = 15
COST_JOINT = 55
COST_JOINT_DAMAGED = 75
COST_BROKEN = 2
BLOCK_STRIDE = 1024       # loop iterations per block (see engine.step.phase_blocks)
UNSTABLE_BIT = 1 << 24   # added to engine.step.run_steps_serial's return value (steps per launch < 2^24)
DUE_BIT = 1 << 25        # added to engine.step.run_steps_blocks' return value: contact detection is due
ABORT_BIT = 1 << 26      # ... the launch stopped between two units (a wait ran past its bound): resume it
TIMEOUT_BIT = 1 << 27    # ... a wait of the launch ran past its bound
TEAM_CHUNK = 256          # nodes per chunk of the team's gather and integration (engine.team, stage INTEG);
                          # a chunk's partial sums are the chunk's, whoever ran it

# tris.tri_intact of a triangle of a fracturing body (docs/theory/joints.md §7.10; engine.joints.pair_carried):
# INTACT | (EDGE_FREE << e for every edge e without a joint that carries its pair) | (DAMAGED once
# any of its joints has handed its pair over to contact: damage above step_real[HANDOVER], or
# broken); 0: a triangle that is not bonded (other bodies, or at a pre-existing crack); −1: removed
# by an excavation.  The bits are set at the end of a step (add_joint_work) and only ever set, so
# every item of a step reads the same values.
INTACT = 1
EDGE_FREE = 2             # EDGE_FREE << e, e = 0, 1, 2: edge e (nodes e, e + 1) has no carrying joint
DAMAGED = 16
# tris.tri_nb_on[p] of neighbour pair p: 0 bonded (contact skips it), else 1 | (NB_HELD while the
# pair holds friction slip in couple_hist, engine.contact.couple_forces)
NB_HELD = 2

# Stored in step.dacc to force a contact detection at the next step.
DACC_FORCE = 1e30

# bits of step.step_int[SWITCHES]: runtime feature switches
SWITCH_DAMPING = 1        # viscous damping of the triangles
SWITCH_CDAMPING = 2       # normal contact damping
SWITCH_BC = 4             # prescribed velocities
SWITCH_BC_WORK = 8        # non-zero prescribed velocities (their work is booked)
SWITCH_PRESTRESS = 16     # initial stress of the triangles (tri_prestress, docs/theory/loads.md §12.4)

# The slots of the counters step_real and step_int (declared with their units in
# engine.arrays.REAL_SLOTS / INT_SLOTS; the host reads them by name, sim.arrays.Counters).
(TIME, DACC, RMAX, VMAX, WORK_FRICTION, WORK_CDAMPING, WORK_BOUNDARY, WORK_LOAD, WORK_LOCAL, WORK_ABSORB, QS_ALPHA,
 HANDOVER, DT, BUFFER, VLIMIT, GRAVITY_X, GRAVITY_Y) = slot_numbers(
    REAL_SLOTS, "TIME", "DACC", "RMAX", "VMAX", "WORK_FRICTION", "WORK_CDAMPING", "WORK_BOUNDARY", "WORK_LOAD",
    "WORK_LOCAL", "WORK_ABSORB", "QS_ALPHA", "HANDOVER", "DT", "BUFFER", "VLIMIT", "GRAVITY_X", "GRAVITY_Y")
(COUPLES, FOUND, NONFINITE, INVERTED, DETECTIONS, BROKEN, NB_PAIRS, REBALANCE, SPLIT, RANGE, SWITCHES) = slot_numbers(
    INT_SLOTS, "COUPLES", "FOUND", "NONFINITE", "INVERTED", "DETECTIONS", "BROKEN", "NB_PAIRS", "REBALANCE", "SPLIT",
    "RANGE", "SWITCHES")


def _leaves(*groups):
    return sum(1 + len(m) for m in groups)


# argument leaves of the serial step kernel (nsteps + 7 argpacks + their members) and of the
# parallel step kernel (6 argpacks, no detection scratch, plus the assembly slots); at most 64
LEAVES_SERIAL = 1 + _leaves(NODE_MEMBERS, TRI_MEMBERS, MAT_MEMBERS, CONTACT_MEMBERS, DETECT_MEMBERS, JOINT_MEMBERS,
                            STEP_MEMBERS)
LEAVES_PARALLEL = _leaves(NODE_MEMBERS, TRI_MEMBERS, MAT_MEMBERS, CONTACT_MEMBERS, JOINT_MEMBERS, STEP_MEMBERS,
                          ASSEMBLY_MEMBERS)
# the team launch: nsteps, nwork, flags, spin_max and one argpack
LEAVES_TEAM = 4 + _leaves(TEAM_MEMBERS)
# with a fluid: the serial step (nsteps and one argpack), the parallel step (its groups + the fluid's)
LEAVES_SERIAL_FLUID = 1 + _leaves(SERIAL_FLUID_MEMBERS)
LEAVES_PARALLEL_FLUID = LEAVES_PARALLEL + _leaves(FLUID_MEMBERS)
# every step kernel keeps LEAVES_FREE of Taichi's 64 leaves free, room for the arrays of new physics
LEAVES_MAX = 64
LEAVES_FREE = 3
LEAVES = {"serial": LEAVES_SERIAL, "parallel": LEAVES_PARALLEL, "team": LEAVES_TEAM,
          "serial_fluid": LEAVES_SERIAL_FLUID, "parallel_fluid": LEAVES_PARALLEL_FLUID}
assert all(n <= LEAVES_MAX - LEAVES_FREE for n in LEAVES.values()), LEAVES

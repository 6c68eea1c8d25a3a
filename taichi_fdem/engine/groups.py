"""The arrays of a simulation, grouped by concern, as Taichi argpacks.

A kernel takes a handful of groups instead of fifty arrays and reads ``nodes.node_x[i]``,
``tris.tri_rest_inv[e]``, ``step.step_dt[None]``: a member has the name of its array in the model,
the state or the scratch (prefix-first, as in the table below with the prefix left out).  Every member is a Taichi ndarray (no recompilation
per scene size; the element type follows the precision chosen by ``fdem.init``); scalars are
0-d ndarrays, read and written as ``step.time[None]``.

=========  ====================================================================================
group      members
=========  ====================================================================================
nodes      x [m], v [m/s], f [N/m] (vec2); mass [kg/m]; free (vec2: 1 free, 0 prescribed per
           component); vbc (vec2, prescribed velocity [m/s]); react (vec2: force [N/m] the velocity
           constraints exerted at the last step, docs/theory/loads.md §12.3); the load table (§12.1–12.2,
           12.5): load_nodes (5 i32: kind, node i, node j or component, curve start, curve
           count), load_vals (vec4: the load's values, see :mod:`taichi_fdem.engine.loads`),
           load_force (vec4: forces on i and j at the last step [N/m]); curve_points (vec2:
           (t [s], amplitude) of every curve, concatenated)
tris       nodes (vec3 i32); rest_inv (2×2, F0⁻¹ [1/m]; A0 = ½ / det F0⁻¹); mat, body (i32);
           visc (viscous coefficient k_s [Pa·s]); diss (damping work [J/m]); origin (vec3 i32: the
           nodes before a fracturing body was exploded, globally numbered: mesh neighbours share
           one); intact (bits, see :data:`INTACT`: a bonded triangle of a fracturing body, which of
           its edges carry no undamaged joint, whether any of its joints is damaged; 0 for the
           other triangles; −1 once the triangle is removed by an excavation); prestress (vec3:
           initial 2nd Piola–Kirchhoff stress S⁰ = (xx, yy, xy) [Pa], §12.4); fans (i32: the fans of
           the original nodes, engine.joints.fan_links); nb_on (i32 per neighbour pair: 1 once
           it is no longer bonded, so that contact is evaluated for it; then one i32 per fan:
           the mask of its missing and damaged links)
mats       mu, lam (Lamé μ, λ_Y [Pa]); pair ((M, M) vec4: penalty p [Pa], tangential penalty
           k_t [Pa/m], friction μ, normal damping c_n)
contact    the couples: a, b (triangles), hist (6 slip values per couple [m]); the first
           step_int[NB_PAIRS] are the neighbour pairs (engine.joints.neighbour_pairs); scratch:
           skip (per couple: the value of step_real[DACC] up to which it is certified apart [m],
           engine.contact.couple_forces)
detect     ctri (contact triangles), body_flags (bit 0 self-contact, bit 1 fully fixed), start
           (first couple of each ctri); scratch: bound (13 reals: bounding-circle centre [m],
           radius [m], box (lo, hi) [m], the three vertices [m]), sort (ivec3 per contact triangle k: hashed cell of k, slot of k in it, and the k at
           sorted position k), bucket (ivec2: first, count), cnew (counts, then their exclusive
           prefix; cnew[K] = couples found), old_start, old_b, old_hist (the previous couples)
asm        the parallel strategy's assembly (no atomics).  Slots: force (vec2: 3 per triangle, then
           6 per couple [N/m]), node_start (N+1) and node_slots (each node's slots, sorted).
           Blocks: force (a copy of the nodal forces per block, then each block's contact work);
           sync (i32: the barrier counter, the result, each block's non-finite flag) and part
           (3 per block: max ``|v|²``, constraint work, local-damping work) of run_steps_blocks
joints     nodes (vec4 i32), tris (ivec2: triangles A, B), prop (vec6: f_t, c, tan φ, G_I, G_II, p_f
           of each joint, §13.2–13.3); state (0 intact, else the failure mode at breakage), dmax
           (vec3), zmax (vec3: the softening factor z(dmax), kept so that an unloading joint needs
           no exp), fs (vec3 [Pa]), work [J/m], brk (vec3: time, x, y), g (vec4: nodal forces [N/m])
step       parameters set by the host: dt [s], gravity (vec2 [m/s²]), buffer [m], vlimit [m/s],
           switches (runtime feature bits, :data:`SWITCH_DAMPING` ...: one compiled variant);
           counters kept by the kernels: real (time [s], dacc [m], rmax [m], vmax [m/s], work
           terms [J/m]; slots :data:`TIME`, :data:`DACC`, ...) and int (couples, found, nonfinite,
           inverted, detections, broken, neighbour pairs; slots :data:`COUPLES`, ...)
fluid      the fluid in the fracture network (:mod:`taichi_fdem.engine.fluid`): edge (vec8 i32:
           node copies, fluid nodes, joint), edge_val (vec8: aperture, length, conductance,
           flux, face forces), node_val (vec4: content, volume, pressure, rate), index (the
           header and index lists), real (parameters, counters, sources)
=========  ====================================================================================

Adding an array: declare it in the group below and allocate it in
:func:`taichi_fdem.sim.model.build_model` (model arrays) or :func:`taichi_fdem.sim.state.allocate_state`
(state arrays).  Nothing else lists it: the kernels receive the group, checkpoints and
last-good-state snapshots walk the state.

Budget.  Taichi 1.7 allows at most 64 argument leaves per kernel launch, and every ndarray in
an argpack is one leaf (plus one per argpack).  The serial step kernel takes every group:
:data:`LEAVES_SERIAL` counts its leaves.  Arrays of one entity and type that are always used
together are therefore merged into a vector (circle = centre + radius, bucket = first + count),
a quantity that can be derived is not stored (A0 from F0⁻¹), and the counters the kernels keep
are two short arrays with named slots.
"""
import taichi as ti

_nd = ti.types.ndarray()


def _group(*names):
    return ti.types.argpack(**{n: _nd for n in names})


NODE_MEMBERS = ("node_x", "node_v", "node_f", "node_mass", "node_free", "node_vbc", "node_react", "load_nodes",
                "load_vals", "load_force", "curve_points")
TRI_MEMBERS = ("tri_nodes", "tri_rest_inv", "tri_mat", "tri_body", "tri_visc", "tri_diss", "tri_origin",
               "tri_intact", "tri_prestress", "tri_fans", "tri_nb_on")
MAT_MEMBERS = ("mat_mu", "mat_lam", "mat_pair")
CONTACT_MEMBERS = ("couple_a", "couple_b", "couple_hist", "couple_skip")
DETECT_MEMBERS = ("contact_tri", "body_flags", "couple_start", "det_bound", "det_sort", "det_bucket", "det_cnew",
                  "det_old_start", "det_old_b", "det_old_hist")
ASSEMBLY_MEMBERS = ("asm_force", "asm_node_start", "asm_node_slots", "asm_sync", "asm_part")
JOINT_MEMBERS = ("joint_nodes", "joint_tris", "joint_prop", "joint_state", "joint_dmax", "joint_zmax", "joint_fs",
                 "joint_work", "joint_break", "joint_g")
STEP_PARAMS = ("step_dt", "step_gravity", "step_buffer", "step_vlimit", "step_switches")
STEP_COUNTERS = ("step_real", "step_int")
STEP_MEMBERS = STEP_PARAMS + STEP_COUNTERS
# the fluid in the fracture network (engine.fluid): edges, their values, the fluid nodes' values,
# the index lists and the parameters, counters and sources
FLUID_MEMBERS = ("fluid_edge", "fluid_edge_val", "fluid_node_val", "fluid_index", "fluid_real")

NodeGroup = _group(*NODE_MEMBERS)
TriGroup = _group(*TRI_MEMBERS)
MaterialGroup = _group(*MAT_MEMBERS)
ContactGroup = _group(*CONTACT_MEMBERS)
DetectGroup = _group(*DETECT_MEMBERS)
AssemblyGroup = _group(*ASSEMBLY_MEMBERS)
JointGroup = _group(*JOINT_MEMBERS)
StepGroup = _group(*STEP_MEMBERS)
FluidGroup = _group(*FLUID_MEMBERS)

# group -> (argpack type, member names).  Members carry the names of the arrays in the model,
# the state or the scratch (prefix-first: node_x, tri_nodes, couple_a, step_dt): Taichi flattens
# argpack members into one namespace per kernel, so they must be unique across groups.
GROUPS = {"nodes": (NodeGroup, NODE_MEMBERS), "tris": (TriGroup, TRI_MEMBERS), "mats": (MaterialGroup, MAT_MEMBERS),
          "contact": (ContactGroup, CONTACT_MEMBERS), "detect": (DetectGroup, DETECT_MEMBERS),
          "joints": (JointGroup, JOINT_MEMBERS), "step": (StepGroup, STEP_MEMBERS),
          "asm": (AssemblyGroup, ASSEMBLY_MEMBERS), "fluid": (FluidGroup, FLUID_MEMBERS)}

# The serial step of a scene with a fluid (engine.step.run_steps_serial_fluid) takes every group
# of the serial step and the fluid's as ONE argpack, as the team launch does: eight argpacks
# would pass Taichi's 64 leaves (LEAVES_SERIAL_FLUID)
SERIAL_FLUID_MEMBERS = (NODE_MEMBERS + TRI_MEMBERS + MAT_MEMBERS + CONTACT_MEMBERS + DETECT_MEMBERS + JOINT_MEMBERS
                        + STEP_MEMBERS + FLUID_MEMBERS)
SerialFluidGroup = _group(*SERIAL_FLUID_MEMBERS)

# The team launch of the parallel strategy (engine.step.run_steps_blocks) takes every group but
# the slot lists of the assembly, detection included, as ONE argpack: seven argpacks would cost
# seven leaves more than the 64 Taichi allows (LEAVES_TEAM).  Its members keep their names, so
# the kernel passes the one argpack as each group of the phases.
TEAM_MEMBERS = (NODE_MEMBERS + TRI_MEMBERS + MAT_MEMBERS + CONTACT_MEMBERS + DETECT_MEMBERS + JOINT_MEMBERS
                + STEP_MEMBERS + ("asm_force", "asm_sync", "asm_part"))
TeamGroup = _group(*TEAM_MEMBERS)

# Block assembly of the parallel strategy on the CPU (docs/theory/elements.md §6.1; see engine.step): the items
# are split into a fixed number of blocks, each a contiguous range (triangles, joints and nodes by
# count, couples by estimated cost: engine.blocks.rebalance_couples), and each block adds its forces
# into its own copy of the nodal forces.  Contiguous ranges keep a block's nodes in its core's
# cache (dealing granules of 512 items round-robin, as before, made every core read and write
# every node each step: 1.2× slower on the 1k pile, 1.06× on the 100k pile on 2 threads).  The
# number of blocks is a property of the simulation (``sim.solver.force_blocks``, FORCE_BLOCKS by
# default), not the thread count, and the couple ranges a function of the state, so that the
# sums, and the results, are the same bits for any number of threads; at most that many threads
# share the force work.
FORCE_BLOCKS = 2
DET_CAND = 8              # partners of a contact triangle the count scan keeps for the fill (engine.detection,
                          # in det_cnew after its K + 1 counts: a new array would pass Taichi's 64 arguments)
MAX_FORCE_BLOCKS = 64     # the couple ranges' bounds live in step_int[SPLIT + b], b = 0..blocks
REBALANCE_STEPS = 512     # steps between two recomputations of the couple ranges (and after a detection): a
                          # serial pass (~50 ns per couple) while the other workers wait; 512 rather than 128
                          # is 1.03-1.08x faster on the 10k pile, 1.02x on the fracturing plate, the same at
                          # 1k and 100k (2 workers, one process)
# estimated costs per step, ~ns on one thread, for the blocks' couple ranges
# (engine.blocks.rebalance_couples), measured in the block loop: a couple bonded or skipped by its
# certificate of separation ~4 (3.5 in a resting 10k pile, 4-5 in the 10k plate after the impact),
# plus, for a certified one, the share of steps its certificate runs out (D_acc's growth per step
# over its gap) times a test (~25); touching 160 (pile) to 210 (plate); a triangle's elastic forces
# 10-18; an intact joint 55, damaged 75, broken 2.  The old weights (1 bonded, 10 boxes apart, 28
# apart, 300 touching) ignored the certificates, which skip most apart couples: they gave the 10k
# pile's two blocks 7 % apart on average (14 % after 9,000 steps), these 3 %
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
SYNC_LINE = 16            # i32 slots per cache line: the team's counters in asm_sync are a line apart
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

# bits of step.switches: runtime feature switches
SWITCH_DAMPING = 1        # viscous damping of the triangles
SWITCH_CDAMPING = 2       # normal contact damping
SWITCH_BC = 4             # prescribed velocities
SWITCH_BC_WORK = 8        # non-zero prescribed velocities (their work is booked)
SWITCH_PRESTRESS = 16     # initial stress of the triangles (tri_prestress, docs/theory/loads.md §12.4)

# Counters kept by the kernels: two short 1-d arrays, step_real and step_int, whose slots are
# named here.  (Taichi has no struct ndarrays; one 0-d ndarray per counter would spend the
# argument budget below; and 0-d vector ndarrays hit a Taichi 1.7.4 compiler assertion,
# scalarize_store_stmt, when a kernel reads a component as a loop bound and later writes it.)
# step_real [SI units]:
TIME = 0            # simulated time [s]
DACC = 1            # accumulated 2 Δt v_max since the last detection [m] (§4.1)
RMAX = 2            # largest bounding-circle radius at the last detection [m]
VMAX = 3            # largest node speed of the last step [m/s]
WORK_FRICTION = 4   # work dissipated by friction slip [J/m]
WORK_CDAMPING = 5   # work dissipated by normal contact damping [J/m]
WORK_BOUNDARY = 6   # work done on the system by prescribed velocities [J/m]
WORK_LOAD = 7       # work done on the system by applied loads (pressure, traction, force) [J/m]
WORK_LOCAL = 8      # work dissipated by the local (quasi-static) damping [J/m]
WORK_ABSORB = 9     # work dissipated by absorbing boundaries [J/m]
QS_ALPHA = 10       # a parameter, set by the host: coefficient α of the local damping
HANDOVER = 11       # a parameter, set by the host: damage at which contact takes over a joined pair
REAL_COUNTERS = 12  # length of step_real
# step_int:
COUPLES = 0         # couples in the list
FOUND = 1           # couples found by the last count pass (also det_cnew[K])
NONFINITE = 2       # 1 + a node whose position or velocity is not finite (0: none)
INVERTED = 3        # 1 + a triangle with non-positive area (0: none)
DETECTIONS = 4      # detections run
BROKEN = 5          # joints broken so far
NB_PAIRS = 6        # neighbour pairs M: the first M couples, never detected (engine.joints.neighbour_pairs)
REBALANCE = 7       # steps until the block assembly recomputes its couple ranges (≤ 0: at the next step)
SPLIT = 8           # SPLIT + b, b = 0..blocks: first couple of block b of the block assembly (the last: the count)
RANGE = SPLIT + MAX_FORCE_BLOCKS + 1    # RANGE + 2b, RANGE + 2b + 1: the nodes [lo, hi) that block b's items
                                        # can write (engine.blocks.block_node_ranges), which the gather adds
INT_COUNTERS = RANGE + 2 * MAX_FORCE_BLOCKS    # length of step_int

def _leaves(*groups):
    return sum(1 + len(m) for m in groups)


# argument leaves of the serial step kernel (nsteps + 7 argpacks + their members) and of the
# parallel step kernel (6 argpacks, no detection scratch, plus the assembly slots); at most 64
LEAVES_SERIAL = 1 + _leaves(NODE_MEMBERS, TRI_MEMBERS, MAT_MEMBERS, CONTACT_MEMBERS, DETECT_MEMBERS, JOINT_MEMBERS,
                            STEP_MEMBERS)
LEAVES_PARALLEL = _leaves(NODE_MEMBERS, TRI_MEMBERS, MAT_MEMBERS, CONTACT_MEMBERS, JOINT_MEMBERS, STEP_MEMBERS,
                          ASSEMBLY_MEMBERS)
# the team launch: nsteps, nwork, detect_in and one argpack
LEAVES_TEAM = 3 + _leaves(TEAM_MEMBERS)
# with a fluid: the serial step (nsteps and one argpack), the parallel step (its groups + the fluid's)
LEAVES_SERIAL_FLUID = 1 + _leaves(SERIAL_FLUID_MEMBERS)
LEAVES_PARALLEL_FLUID = LEAVES_PARALLEL + _leaves(FLUID_MEMBERS)
assert LEAVES_SERIAL <= 64 and LEAVES_PARALLEL <= 64 and LEAVES_TEAM <= 64, (LEAVES_SERIAL, LEAVES_PARALLEL,
                                                                             LEAVES_TEAM)
assert LEAVES_SERIAL_FLUID <= 64 and LEAVES_PARALLEL_FLUID <= 64, (LEAVES_SERIAL_FLUID, LEAVES_PARALLEL_FLUID)

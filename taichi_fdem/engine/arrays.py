"""The data model: one declaration per array of a simulation, and of the counter slots.

Every Taichi array the kernels take, and every NumPy array the build keeps, is one
:class:`Array` in :data:`ARRAYS`: its name, argpack group, role, element type, shape, unit and
meaning.  Everything that lists arrays is generated from it:

* the argpack member tuples of :mod:`taichi_fdem.engine.groups` (:func:`members`; member order
  is declaration order);
* the allocation of the model, the state and the scratch (:func:`taichi_fdem.sim.arrays.allocate`
  evaluates the declared shape and element type at the scene's sizes);
* the arrays checkpoints and last-good-state snapshots save (the ``state`` role,
  :func:`declared`);
* the array table of the documentation (:func:`taichi_fdem.sim.arrays.markdown`, docs/reference/arrays.md).

Adding an array is one entry here and its values where the physics computes them (the value
handed to the allocator in :func:`taichi_fdem.sim.model.build_model` for a model array; a state
or scratch array starts at zero unless :func:`taichi_fdem.sim.state.allocate_state` gives it a
value).  Every array of a group costs one argument leaf in each launch that takes the group:
Taichi 1.7 allows 64 (:data:`taichi_fdem.engine.groups.LEAVES_SERIAL` and the other counts there,
checked at import against 64 − :data:`~taichi_fdem.engine.groups.LEAVES_FREE`: every step kernel
keeps a few leaves free), so a kernel that reaches that bound takes new data as columns of an
existing vector array.

Roles: ``model`` (computed once by the build, constant through a run), ``state`` (changed by
the steps; saved by checkpoints), ``scratch`` (work arrays, never saved), ``host`` (NumPy
results of the build, kept by the model for the host).

Element types: ``real`` is the precision chosen by ``fdem.init`` (f64 or f32); ``i32``,
``f64``, ``bool`` fixed; ``vecK`` a K-vector per entry, ``matK`` a K×K matrix (K may be an
expression, in parentheses).  Shapes are tuples of expressions over the sizes of
:data:`SIZES` (Python syntax: ``N if bc else 1`` is a one-row placeholder for a scene without
prescribed velocities).  Units are SI; "-" marks counts, indices, flags and bit sets.

Counters.  The counters the kernels keep are two short arrays, ``step_real`` and ``step_int``,
whose slots are declared in :data:`REAL_SLOTS` and :data:`INT_SLOTS` (Taichi has no struct
ndarrays, one 0-d ndarray per counter would spend the 64-leaf argument budget of a launch, and
0-d vector ndarrays hit a Taichi 1.7.4 compiler assertion, scalarize_store_stmt, when a kernel
reads a component as a loop bound and later writes it).  The kernels index them with the
compile-time constants of :mod:`taichi_fdem.engine.groups` (``TIME``, ``COUPLES``, ...), the host
reads them by name through :class:`taichi_fdem.sim.arrays.Counters` (``state.counters.couples``);
both are generated from the slot declarations.  The parameters the host sets for the kernels (time
step, detection buffer, speed limit, gravity, the local damping's α, the handover damage, the
feature switches) are slots of the same two arrays (written by
:func:`taichi_fdem.sim.state.set_parameters`, the ``sim.dt`` setter and the excavation), not 0-d
arrays of their own: each array of a group is one argument leaf of every launch that takes it.
"""
from __future__ import annotations

import re
from typing import NamedTuple

__all__ = ["Array", "Slot", "ARRAYS", "SIZES", "GROUP_ORDER", "ROLES", "REAL_SLOTS", "INT_SLOTS", "REAL_COUNTERS",
           "INT_COUNTERS", "DET_CAND", "SYNC_LINE", "MAX_FORCE_BLOCKS", "members", "declared", "slot_numbers",
           "element", "symbols"]

MODEL, STATE, SCRATCH, HOST = "model", "state", "scratch", "host"
ROLES = (MODEL, STATE, SCRATCH, HOST)

#: the argpack groups, in the order of :data:`taichi_fdem.engine.groups.GROUPS`
GROUP_ORDER = ("nodes", "tris", "mats", "contact", "detect", "joints", "step", "asm", "fluid", "heat")

DET_CAND = 8              # partners of a contact triangle the count scan keeps for the fill (engine.detection,
                          # in det_cnew after its K + 1 counts: a new array would pass Taichi's 64 arguments)
MAX_FORCE_BLOCKS = 64     # the couple ranges' bounds live in step_int[SPLIT + b], b = 0..blocks
SYNC_LINE = 16            # i32 slots per cache line: the team's counters in asm_sync are a line apart

#: the symbols of the declared shapes: sizes of the scene and switches of its features
SIZES = {
    "N": "nodes",
    "E": "triangles",
    "M": "materials",
    "B": "bodies",
    "G": "node groups with prescribed velocities (fixed or prescribed bodies, fix_nodes calls)",
    "L": "load rows (1 without loads)",
    "P": "points of the amplitude curves (1 without curves)",
    "K": "contact triangles (1 without contact)",
    "H": "hashed cells of detection: the power of two ≥ 2 K, at least 16 (1 without contact)",
    "J": "joints (1 without fracture)",
    "NB": "bonded neighbour pairs",
    "V": "fans: one per original node number (0 without neighbour pairs)",
    "F": "length of the fan table (sim.topology.fan_links)",
    "C": "capacity of the couple buffer (State.couple_max)",
    "Q": "fracture-network edges (1 without a fluid)",
    "W": "fracture-network nodes (1 without a fluid)",
    "NC": "(network node, node copy) pairs (0 without a fluid)",
    "I": "length of the network's header and index lists (engine.fluid)",
    "R": "length of the fluid's parameters, counters and sources (engine.fluid)",
    "HA": "length of the heat conduction's node lists (engine.heat; 1 without heat)",
    "HR": "heat boundary rows: held temperatures and fluxes (1 without)",
    "FB": "force blocks of the parallel strategy (sim.solver.force_blocks)",
    "T": "team workers: FB with the team, else 0",
    "U": "node chunks of the team's gather (engine.groups.TEAM_CHUNK nodes each; 0 without the team)",
    "REAL_COUNTERS": "slots of step_real (REAL_SLOTS)",
    "INT_COUNTERS": "slots of step_int (INT_SLOTS)",
    "DET_CAND": f"partners per contact triangle kept by the count scan ({DET_CAND})",
    "SYNC_LINE": f"i32 slots per cache line ({SYNC_LINE})",
    "bc": "switch: some node component has a prescribed velocity",
    "damping": "switch: some material has viscous damping",
    "prestress": "switch: the scene has an initial stress",
    "joint_prestress": "switch: some joint starts under a non-zero initial traction",
    "contact": "switch: the scene has contact",
    "friction": "switch: some contact pair has friction",
    "fracture": "switch: the scene has joints",
    "fluid": "switch: the scene has a fluid in its fracture network",
    "bedding": "switch: some material has a bedding (transversely isotropic elasticity)",
    "heat": "switch: the scene conducts heat (scene.set_temperature or scene.heat): temperatures and thermal strains",
    "heat_contact": "switch: the scene conducts heat and has contact: contacts conduct (engine.heat)",
    "blocks": "switch: the parallel strategy with force blocks (the CPU default)",
    "slots": "switch: the parallel strategy with force slots",
}


class Array(NamedTuple):
    """One declared array (see the module docstring)."""
    name: str        # the attribute of Model / State / Scratch and the argpack member (prefix-first)
    group: str       # argpack group (:data:`GROUP_ORDER`); "" for host arrays
    role: str        # model, state, scratch or host
    dtype: str       # element type: "real", "i32 vec3", "real mat2", "real vec(14 if joint_prestress else 8)"
    shape: tuple     # dimension expressions over SIZES; () a 0-d array
    unit: str        # SI unit(s), "-" for none
    doc: str         # what the array holds


def _a(name, group, role, dtype, shape, unit, doc):
    return Array(name, group, role, dtype, tuple(shape), unit, doc)


# In group order, members in argpack order (the kernels' argument layout follows it).
ARRAYS: tuple = (
    # ---- nodes ------------------------------------------------------------------------------
    _a("node_x", "nodes", STATE, "real vec2", ["N"], "m", "node positions"),
    _a("node_v", "nodes", STATE, "real vec2", ["N"], "m/s", "node velocities"),
    _a("node_f", "nodes", STATE, "real vec2", ["N"], "N/m", "nodal forces of the last step (per unit thickness)"),
    _a("node_mass", "nodes", MODEL, "real", ["N"], "kg/m", "lumped nodal mass per unit thickness"),
    _a("node_free", "nodes", MODEL, "real vec2", ["N if bc else 1"], "-",
       "1 for a free component, 0 for a prescribed one"),
    _a("node_vbc", "nodes", STATE, "real vec2", ["N if bc else 1"], "m/s", "prescribed velocities now"),
    _a("node_react", "nodes", STATE, "real vec2", ["N if bc else 1"], "N/m",
       "force the velocity constraints exerted at the last step (docs/theory/loads.md §12.3)"),
    _a("load_nodes", "nodes", MODEL, "i32 vec5", ["L"], "-",
       "load rows (docs/theory/loads.md §12.1–12.2, 12.5): kind, node i, node j or component, curve start, "
       "curve count"),
    _a("load_vals", "nodes", MODEL, "real vec4", ["L"], "Pa or N/m",
       "the load rows' values (engine.loads)"),
    _a("load_force", "nodes", STATE, "real vec4", ["L"], "N/m", "forces of the load rows on i and j at the last step"),
    _a("curve_points", "nodes", MODEL, "real vec2", ["P"], "s, -",
       "the amplitude curves' points (time, factor), concatenated"),
    # ---- triangles --------------------------------------------------------------------------
    _a("tri_nodes", "tris", MODEL, "i32 vec3", ["E"], "-", "node indices of each triangle (counter-clockwise)"),
    _a("tri_rest_inv", "tris", MODEL, "real mat2", ["E"], "1/m",
       "inverse F0⁻¹ of the rest edge matrix (A0 = ½ / det F0⁻¹)"),
    _a("tri_mat", "tris", MODEL, "i32", ["E"], "-", "material index of each triangle"),
    _a("tri_body", "tris", MODEL, "i32", ["E"], "-", "body index of each triangle"),
    _a("tri_visc", "tris", MODEL, "real", ["E if damping else 1"], "Pa·s·m",
       "viscous damping coefficient of each triangle (docs/theory/contact.md §2.3)"),
    _a("tri_diss", "tris", STATE, "real", ["E if damping else 1"], "J/m",
       "energy dissipated by each triangle's damping"),
    _a("tri_origin", "tris", MODEL, "i32 vec3", ["E"], "-",
       "the original (unsplit) nodes of each triangle, numbered apart per body: mesh neighbours share one"),
    _a("tri_intact", "tris", STATE, "i32", ["E"], "-",
       "bits (engine.groups.INTACT, EDGE_FREE << e, DAMAGED) of a bonded triangle of a fracturing body; 0 other "
       "triangles; −1 once removed by an excavation"),
    _a("tri_prestress", "tris", MODEL, "real vec3", ["E if prestress else 1"], "Pa",
       "initial 2nd Piola–Kirchhoff stress S⁰ = (xx, yy, xy) (docs/theory/loads.md §12.4)"),
    _a("tri_fans", "tris", MODEL, "i32", ["F"], "-",
       "the fans of the original nodes: header, fan starts, missing-link masks, corner pairs, joint links "
       "(sim.topology.fan_links)"),
    _a("tri_bedding", "tris", MODEL, "real vec2", ["E if bedding else 1"], "-",
       "cos and sin of the bedding angle of each triangle; (0, 0) for a triangle of an isotropic material "
       "(docs/theory/anisotropy.md)"),
    _a("tri_thermal", "tris", STATE, "real vec3", ["E if heat else 1"], "-",
       "effective 2D thermal strain ε* = (xx, yy, xy) of each triangle in the global frame; its thermal stretch "
       "is F_th = I + ε* (docs/theory/anisotropy.md)"),
    _a("tri_nb_on", "tris", STATE, "i32", ["max(NB + V, 1)"], "-",
       "per neighbour pair: 0 bonded, else 1 | NB_HELD while it holds friction slip; then per fan: the mask of its "
       "missing and damaged links"),
    # ---- materials --------------------------------------------------------------------------
    _a("mat_lame", "mats", MODEL, "real vec2", ["M"], "Pa",
       "Lamé shear modulus μ and λ (plane strain or stress) of each material"),
    _a("mat_aniso", "mats", MODEL, "real vec4", ["M if bedding else 1"], "Pa",
       "C11, C22, C12, C66 of the plane problem in the bedding frame (engineering shear) of each material; "
       "isotropic materials of a bedded scene: their isotropic stiffness (docs/theory/anisotropy.md)"),
    _a("mat_pair", "mats", MODEL, "real vec4", ["M", "M"], "Pa, Pa/m, -, Pa·s/m",
       "contact penalty p, tangential penalty k_t, friction coefficient μ, normal damping c_n of each pair"),
    # ---- contact couples --------------------------------------------------------------------
    _a("couple_a", "contact", STATE, "i32", ["C"], "-",
       "first triangle of each couple (the first step_int[NB_PAIRS] are the neighbour pairs)"),
    _a("couple_b", "contact", STATE, "i32", ["C"], "-", "second triangle of each couple"),
    _a("couple_hist", "contact", STATE, "real", ["6 * C if friction else 1"], "m",
       "tangential slip history of the couples (6 slots each)"),
    _a("couple_skip", "contact", SCRATCH, "real", ["C if contact else 1"], "m",
       "certificate of separation: the step_real[DACC] up to which the couple is apart (engine.contact)"),
    # ---- detection --------------------------------------------------------------------------
    _a("contact_tri", "detect", MODEL, "i32", ["K"], "-", "the triangles that take part in contact"),
    _a("body_flags", "detect", MODEL, "i32", ["B"], "-", "bits per body: 1 self-contact, 2 fully fixed"),
    _a("couple_start", "detect", STATE, "i32", ["K + 1 if friction else 1"], "-",
       "first couple of each contact triangle (friction history)"),
    _a("det_bound", "detect", SCRATCH, "real vec13", ["K"], "m",
       "bounding-circle centre and radius, box (lo, hi), the three vertices of each contact triangle"),
    _a("det_sort", "detect", SCRATCH, "i32 vec3", ["K"], "-",
       "hashed cell of contact triangle k, slot of k in it, the k at sorted position k"),
    _a("det_bucket", "detect", SCRATCH, "i32 vec2", ["H"], "-", "first and count of each hashed cell"),
    _a("det_cnew", "detect", SCRATCH, "i32", ["K + 1 + DET_CAND * K"], "-",
       "couple counts, then their exclusive prefix (det_cnew[K] = couples found); then DET_CAND partners per "
       "contact triangle"),
    _a("det_old_start", "detect", SCRATCH, "i32", ["K + 1 if friction else 1"], "-",
       "couple_start of the previous couples"),
    _a("det_old_b", "detect", SCRATCH, "i32", ["C if friction else 1"], "-", "couple_b of the previous couples"),
    _a("det_old_hist", "detect", SCRATCH, "real", ["6 * C if friction else 1"], "m",
       "couple_hist of the previous couples"),
    # ---- joints -----------------------------------------------------------------------------
    _a("joint_nodes", "joints", MODEL, "i32 vec4", ["J"], "-", "the four nodes of each joint (two per face)"),
    _a("joint_tris", "joints", MODEL, "i32 vec4", ["J"], "-",
       "the joint's triangles A, B and the index of its edge in each"),
    _a("joint_prop", "joints", MODEL, "real vec(14 if joint_prestress else 8)", ["J"], "Pa, J/m², Pa/m, -, m",
       "f_t, c, tan φ, G_I, G_II, p_f (docs/theory/discontinuities.md §13.2–13.3), then k_x / L and μ of the "
       "contact share it carries (docs/theory/joints.md §7.10); prestressed joints: the initial offsets (o⁰, s⁰) of "
       "the three points (§7.11)"),
    _a("joint_state", "joints", STATE, "i32", ["J"], "-", "0 intact, else the failure mode at breakage"),
    _a("joint_dmax", "joints", STATE, "real vec3", ["J"], "m", "largest opening and slip reached at each point"),
    _a("joint_zmax", "joints", STATE, "real vec3", ["J"], "-", "softening factor z at the largest opening"),
    _a("joint_fs", "joints", STATE, "real vec3", ["J"], "Pa", "shear strength at the three integration points"),
    _a("joint_work", "joints", STATE, "real", ["J"], "J/m", "work done on each joint"),
    _a("joint_break", "joints", STATE, "real vec4", ["J"], "s, m, m, Pa",
       "time, position and fluid pressure of each joint's break (pressure −1: none recorded)"),
    _a("joint_g", "joints", STATE, "real vec4", ["J"], "J/m²", "energy released per mode"),
    # ---- step -------------------------------------------------------------------------------
    _a("step_real", "step", STATE, "real", ["REAL_COUNTERS"], "s, m, m/s, J/m, m/s², -",
       "real counters and the parameters the host sets (REAL_SLOTS)"),
    _a("step_int", "step", STATE, "i32", ["INT_COUNTERS"], "-",
       "integer counters and the feature switches (INT_SLOTS)"),
    # ---- parallel assembly ------------------------------------------------------------------
    _a("asm_force", "asm", SCRATCH, "real vec2",
       ["(FB - 1) * N + 2 * FB if blocks else (3 * E + 6 * (C if contact else 0) if slots else 1)"], "N/m, J/m",
       "blocks: a copy of the nodal forces per block but the first, then each block's contact work; slots: 3 "
       "force slots per triangle, 6 per couple"),
    _a("asm_node_start", "asm", SCRATCH, "i32", ["N + 1 if slots else 1"], "-", "first slot of each node"),
    _a("asm_node_slots", "asm", SCRATCH, "i32",
       ["3 * E + 4 * (J if fracture else 0) + 6 * (C if contact else 0) if slots else 1"], "-",
       "each node's force slots, sorted"),
    _a("asm_sync", "asm", SCRATCH, "i32", ["2 * SYNC_LINE + max(T, U) + U"], "-",
       "the team's counters (two cache lines), a claim slot per unit, each chunk's non-finite flag"),
    _a("asm_part", "asm", SCRATCH, "real", ["max(1, 3 * U)"], "m²/s², J/m",
       "each chunk's largest |v|², constraint work and local-damping work"),
    # ---- fluid ------------------------------------------------------------------------------
    _a("fluid_edge", "fluid", MODEL, "i32 vec8", ["Q"], "-",
       "fracture-network edges: node copies, fluid nodes, joint (engine.fluid)"),
    _a("fluid_edge_val", "fluid", STATE, "real vec8", ["Q"], "m, m, m³/(Pa·s), m²/s, N/m",
       "per network edge: aperture, length, conductance, flux, face forces"),
    _a("fluid_node_val", "fluid", STATE, "real vec4", ["W"], "m², m², Pa, 1/s",
       "per network node: fluid content, volume, pressure, K ΣC/V"),
    _a("fluid_index", "fluid", MODEL, "i32", ["I"], "-", "the network's header and index lists (engine.fluid)"),
    _a("fluid_real", "fluid", STATE, "real", ["R"], "Pa, Pa·s, m, J/m, m²/s, m²",
       "the fluid's parameters, counters and sources (engine.fluid: F_K, ...)"),
    # ---- heat conduction (engine.heat, docs/theory/heat.md) ----------------------------------
    _a("heat_temp", "heat", STATE, "real", ["N if heat else 1"], "K", "temperature of each node"),
    _a("heat_node", "heat", MODEL, "real vec3", ["N if heat else 1"], "J/(m·K), K, W/(m·K)",
       "lumped heat capacity C_i = Σ ρ c A/3, initial (stress-free) temperature, and Σ_j abs(K_ij) of the "
       "triangles and joints (the stable heat step's bound) of each node"),
    _a("heat_supply", "heat", STATE, "real vec2", ["N if heat else 1"], "J/m",
       "heat supplied to each node so far: through fluxes, through its held temperature"),
    _a("heat_next", "heat", SCRATCH, "real", ["N if heat else 1"], "K", "the temperatures of the next heat step"),
    _a("heat_tri", "heat", MODEL, "real vec11", ["E if heat else 1"], "W/(m·K), 1/K, W/(m·K), m",
       "conduction matrix K_e (00, 11, 22, 01, 12, 20) of each triangle, its effective expansion tensor "
       "(xx, yy, xy) per kelvin, its conductivity k and its smallest rest altitude h"),
    _a("heat_tri_work", "heat", STATE, "real", ["E if heat else 1"], "J/m",
       "thermal work on each triangle: the change of its strain energy as its thermal strain changed"),
    _a("heat_adj", "heat", MODEL, "i32", ["N + 1 + HA if heat else 1"], "-",
       "each node's list of conduction terms: N + 1 starts, then the coded entries (engine.heat)"),
    _a("heat_joint", "heat", MODEL, "real vec2", ["J if heat else 1"], "W/(m·K), m",
       "conductance G₀ of an intact joint between each pair of facing node copies, and the overlap at which a "
       "broken joint's conductance is G₀ (docs/theory/heat.md)"),
    _a("heat_rows", "heat", MODEL, "i32 vec5", ["HR"], "-",
       "heat boundary rows: kind (0 held temperature, 1 flux), node i, node j, curve start, curve count"),
    _a("heat_row_val", "heat", MODEL, "real vec2", ["HR"], "K or W/m², m",
       "the rows' values: held temperature or flux, and the length each node of a flux edge takes"),
    _a("heat_real", "heat", STATE, "real", ["5"], "s, s, -, -, s",
       "time of the last heat update, heat step, sub-steps per update, mechanical steps per update, stable heat "
       "step with the contacts of the last update"),
    _a("heat_cpl", "heat", SCRATCH, "real vec7", ["C if heat_contact else 1"], "W/(m·K), -",
       "contact conductance G of each couple and the weights of its contact point on the nodes of its two "
       "triangles (engine.heat.contact_conductance)"),
    _a("heat_cpl_tri", "heat", SCRATCH, "i32 vec2", ["C if heat_contact else 1"], "-",
       "the two triangles of each couple, as the heat's contact lists read them"),
    _a("heat_ct", "heat", SCRATCH, "i32", ["2 * E + 1 + 2 * C if heat_contact else 1"], "-",
       "each triangle's list of conducting contacts: E + 1 starts, E cursors, then the entries 2 c + side"),
    _a("heat_tri_q", "heat", SCRATCH, "real vec3", ["E if heat_contact else 1"], "W/m",
       "heat flowing through contacts into each triangle's nodes over the current heat step"),
    _a("heat_int", "heat", STATE, "i32", ["2"], "-", "mechanical steps since the last heat update, heat updates"),
    # ---- host arrays of the model (NumPy) ---------------------------------------------------
    _a("node_rest", "", HOST, "f64", ["N", "2"], "m", "rest (initial) node positions X"),
    _a("node_mass_np", "", HOST, "f64", ["N"], "kg/m", "node_mass on the host"),
    _a("node_mass_full", "", HOST, "f64", ["N"], "kg/m", "lumped nodal mass of the whole mesh, before any excavation"),
    _a("node_velocity0", "", HOST, "f64", ["N", "2"], "m/s", "initial node velocities"),
    _a("node_vbc0", "", HOST, "f64", ["N", "2"], "m/s", "prescribed velocities at t = 0"),
    _a("bc_group_masks", "", HOST, "bool", ["G", "N"], "-", "nodes of each prescribed group"),
    _a("tri_nodes_np", "", HOST, "i32", ["E", "3"], "-", "tri_nodes on the host"),
    _a("tri_body_np", "", HOST, "i32", ["E"], "-", "tri_body on the host"),
    _a("tri_mat_np", "", HOST, "i32", ["E"], "-", "tri_mat on the host"),
    _a("tri_area0_np", "", HOST, "f64", ["E"], "m²", "rest area of each triangle"),
    _a("tri_fracturing", "", HOST, "bool", ["E"], "-", "whether a triangle is bonded in a fracturing body"),
    _a("tri_intact0_np", "", HOST, "i32", ["E"], "-", "initial tri_intact bits"),
    _a("tri_bedding_np", "", HOST, "f64", ["E if bedding else 0"], "°",
       "bedding angle of each triangle (its material's Bedding.angle at the rest centroid)"),
    _a("tri_prestress_np", "", HOST, "f64", ["E if prestress else 0", "3"], "Pa",
       "initial stress (xx, yy, xy) of each triangle at its centroid"),
    _a("joint_tris_np", "", HOST, "i32", ["J if fracture else 0", "2"], "-", "the two triangles of each joint"),
    _a("joint_prop_np", "", HOST, "f64", ["J if fracture else 0", "6"], "Pa, Pa, -, J/m², J/m², Pa",
       "f_t, c, tan φ, G_I, G_II, p_f of each joint"),
    _a("joint_set_np", "", HOST, "i32", ["J if fracture else 0"], "-", "joint set index of each joint"),
    _a("joint_len0_np", "", HOST, "f64", ["J if fracture else 0"], "m", "rest length of each joint"),
    _a("joint_fs0", "", HOST, "f64", ["J", "3"], "Pa",
       "initial shear strength at the three points: c, or c − σ⁰ tan φ under an initial compression σ⁰"),
    _a("nb_pairs_np", "", HOST, "i32", ["NB", "2"], "-", "bonded neighbour triangle pairs (A < B)"),
    _a("fluid_real0", "", HOST, "f64", ["R"], "Pa, Pa·s, m, m²/s", "the fluid's parameters and sources at the start"),
    _a("fluid_content0", "", HOST, "f64", ["W"], "m²", "initial fluid content of each network node"),
    _a("fluid_node_rest", "", HOST, "f64", ["W if fluid else 0", "2"], "m", "initial positions of the network nodes"),
    _a("fluid_copies", "", HOST, "i32", ["NC", "2"], "-",
       "(network node, node copy) pairs of the network's edge faces"),
)


class Slot(NamedTuple):
    """One counter: ``name`` is the kernels' constant (engine.groups), its lower case the host's
    attribute (:class:`taichi_fdem.sim.arrays.Counters`); ``count`` > 1 a run of slots."""
    name: str
    unit: str
    doc: str
    count: int = 1


#: the slots of step_real, in order
REAL_SLOTS = (
    Slot("TIME", "s", "simulated time"),
    Slot("DACC", "m", "accumulated 2 Δt v_max since the last detection (docs/theory/contact.md §4.1)"),
    Slot("RMAX", "m", "largest bounding-circle radius at the last detection"),
    Slot("VMAX", "m/s", "largest node speed of the last step"),
    Slot("WORK_FRICTION", "J/m", "work dissipated by friction slip"),
    Slot("WORK_CDAMPING", "J/m", "work dissipated by normal contact damping"),
    Slot("WORK_BOUNDARY", "J/m", "work done on the system by prescribed velocities"),
    Slot("WORK_LOAD", "J/m", "work done on the system by applied loads (pressure, traction, force)"),
    Slot("WORK_LOCAL", "J/m", "work dissipated by the local (quasi-static) damping"),
    Slot("WORK_ABSORB", "J/m", "work dissipated by absorbing boundaries"),
    Slot("QS_ALPHA", "-", "a parameter set by the host: coefficient α of the local damping"),
    Slot("HANDOVER", "-", "a parameter set by the host: damage at which contact takes over a joined pair"),
    Slot("DT", "s", "a parameter set by the host: the time step the kernels integrate with (Simulation.dt)"),
    Slot("BUFFER", "m", "a parameter set by the host: the detection buffer"),
    Slot("VLIMIT", "m/s", "a parameter set by the host: node speed above which a step stops (speed_limit)"),
    Slot("GRAVITY_X", "m/s²", "a parameter set by the host: gravity, x"),
    Slot("GRAVITY_Y", "m/s²", "a parameter set by the host: gravity, y"),
)

#: the slots of step_int, in order
INT_SLOTS = (
    Slot("COUPLES", "-", "couples in the list"),
    Slot("FOUND", "-", "couples found by the last count pass (also det_cnew[K])"),
    Slot("NONFINITE", "-", "1 + a node whose position or velocity is not finite (0: none)"),
    Slot("INVERTED", "-", "1 + a triangle with non-positive area (0: none)"),
    Slot("DETECTIONS", "-", "detections run"),
    Slot("BROKEN", "-", "joints broken so far"),
    Slot("NB_PAIRS", "-", "neighbour pairs M: the first M couples, never detected"),
    Slot("REBALANCE", "-", "steps until the block assembly recomputes its couple ranges (≤ 0: at the next step)"),
    Slot("SPLIT", "-", "SPLIT + b, b = 0..blocks: first couple of block b of the block assembly (the last: the count)",
         MAX_FORCE_BLOCKS + 1),
    Slot("RANGE", "-", "RANGE + 2b, RANGE + 2b + 1: the nodes [lo, hi) that block b's items can write "
                       "(engine.blocks.block_node_ranges)", 2 * MAX_FORCE_BLOCKS),
    Slot("SWITCHES", "-", "a parameter set by the host: runtime feature bits (engine.groups.SWITCH_DAMPING, ...)"),
)


def slot_numbers(slots, *names) -> tuple:
    """The first slot of each of ``names`` (every declared slot of ``slots``, in order: a slot
    declared but not named, or named but not declared, raises)."""
    if tuple(names) != tuple(s.name for s in slots):
        raise ValueError(f"slot names {names} do not match the declared slots {tuple(s.name for s in slots)}")
    out, k = [], 0
    for s in slots:
        out.append(k)
        k += s.count
    return tuple(out)


REAL_COUNTERS = sum(s.count for s in REAL_SLOTS)      # length of step_real
INT_COUNTERS = sum(s.count for s in INT_SLOTS)        # length of step_int


def members(group: str) -> tuple:
    """The argpack members of ``group``, in declaration order."""
    if group not in GROUP_ORDER:
        raise ValueError(f"unknown group {group!r}; the groups are {GROUP_ORDER}")
    return tuple(a.name for a in ARRAYS if a.group == group)


def declared(role: str) -> dict:
    """{name: :class:`Array`} of every array of ``role``, in declaration order."""
    if role not in ROLES:
        raise ValueError(f"unknown role {role!r}; the roles are {ROLES}")
    return {a.name: a for a in ARRAYS if a.role == role}


_ELEMENT = re.compile(r"^(real|i32|f64|bool)(?: (vec|mat)(\d+|\(.+\)))?$")


def element(dtype: str) -> tuple:
    """(base type, kind "scalar" / "vector" / "matrix", width expression or None) of a declared
    element type."""
    m = _ELEMENT.match(dtype)
    if m is None:
        raise ValueError(f"element type {dtype!r} is not of the form 'real|i32|f64|bool [vecK|matK]'")
    base, kind, width = m.groups()
    return base, {None: "scalar", "vec": "vector", "mat": "matrix"}[kind], width


_NAME = re.compile(r"[A-Za-z_][A-Za-z_0-9]*")


def symbols(spec: Array) -> set:
    """The size symbols a declaration's shape and element type use."""
    words = set()
    for text in spec.shape + ((element(spec.dtype)[2] or ""),):
        words |= set(_NAME.findall(text))
    return words - {"if", "else", "max", "min"}


def _check() -> None:
    names = [a.name for a in ARRAYS]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise ValueError(f"arrays declared twice: {sorted(dup)}")
    for a in ARRAYS:
        element(a.dtype)
        if a.role not in ROLES or (a.group not in GROUP_ORDER if a.role != HOST else a.group):
            raise ValueError(f"array {a.name}: role {a.role!r} / group {a.group!r}")
        unknown = symbols(a) - set(SIZES)
        if unknown:
            raise ValueError(f"array {a.name}: undeclared size symbols {sorted(unknown)} (engine.arrays.SIZES)")
        if not (a.unit and a.doc):
            raise ValueError(f"array {a.name}: no unit or description")


_check()

"""The declared arrays of :class:`~taichi_fdem.sim.model.Model` and
:class:`~taichi_fdem.sim.model.State`: name, shape, element type and unit of each.

Shapes use N nodes, E triangles, M materials, B bodies, K contact triangles, J joint slots,
L load rows, P curve points, F fan entries, G fix_nodes groups, nb bonded neighbour pairs, C
couple capacity (``State.couple_max``), Q fracture-network edges, W network nodes, I and R the
lengths of the network's index list and of its parameters and sources (engine.fluid); an array a scene does not use has one placeholder row
(``N|1``: N when the feature is present).  ``real`` is the precision chosen at :func:`taichi_fdem.init` (f64 or f32);
``vecK`` a K-vector per row.  Units are SI; "-" marks counts, indices, flags and bit sets.
Every Taichi array a Model or State holds is declared here and every declared one is allocated
at build (tests/test_simulation_api.py); checkpoints and the last good state save exactly the
State's declared arrays (:meth:`State.ndarrays <taichi_fdem.sim.model._Arrays.ndarrays>`).
"""
from __future__ import annotations

from typing import NamedTuple

__all__ = ["ArraySpec", "MODEL_ARRAYS", "MODEL_HOST_ARRAYS", "STATE_ARRAYS"]


class ArraySpec(NamedTuple):
    """One declared array: ``name``, ``shape`` (symbols above), ``dtype`` (element type),
    ``unit`` (SI, "-" for none) and ``doc``."""
    name: str
    shape: str
    dtype: str
    unit: str
    doc: str


def _specs(rows) -> dict:
    return {r[0]: ArraySpec(*r) for r in rows}


#: Taichi arrays of the Model (computed once at build; read by the kernels, never written).
MODEL_ARRAYS = _specs([
    ("node_mass", "(N,)", "real", "kg/m", "lumped nodal mass per unit thickness"),
    ("node_free", "(N|1,)", "real vec2", "-", "1 for a free component, 0 for a prescribed one"),
    ("tri_nodes", "(E,)", "i32 vec3", "-", "node indices of each triangle (counter-clockwise)"),
    ("tri_rest_inv", "(E,)", "real mat2", "1/m", "inverse of the rest edge matrix (F = x-edges · this)"),
    ("tri_mat", "(E,)", "i32", "-", "material index of each triangle"),
    ("tri_body", "(E,)", "i32", "-", "body index of each triangle"),
    ("tri_visc", "(E|1,)", "real", "Pa·s·m", "viscous damping coefficient of each triangle (docs/theory/contact.md §2.3)"),
    ("tri_origin", "(E,)", "i32 vec3", "-", "the original (unsplit) nodes of each triangle, numbered apart per body"),
    ("tri_prestress", "(E|1,)", "real vec3", "Pa", "initial stress (σxx, σyy, σxy)"),
    ("tri_fans", "(F,)", "i32", "-", "the triangles around each node (offsets, then lists) for the neighbour links"),
    ("mat_mu", "(M,)", "real", "Pa", "Lamé shear modulus μ of each material"),
    ("mat_lam", "(M,)", "real", "Pa", "Lamé λ of each material (plane strain or stress)"),
    ("mat_pair", "(M, M)", "real vec4", "Pa, Pa, -, Pa·s/m", "contact penalty, tangential penalty, friction "
                                                       "coefficient, contact damping coefficient of each pair"),
    ("body_flags", "(B,)", "i32", "-", "bit set per body (fixed, prescribed, contact)"),
    ("contact_tri", "(K|1,)", "i32", "-", "the triangles that take part in contact"),
    ("joint_nodes", "(J|1,)", "i32 vec4", "-", "the four nodes of each joint (two per face)"),
    ("joint_tris", "(J|1,)", "i32 vec4", "-", "the two triangles of each joint and their edges"),
    ("joint_prop", "(J|1,)", "real vec8 | vec14", "Pa, J/m², Pa/m, -, m", "joint strengths, fracture energies, "
                                                             "penalties, friction; prestressed joints: the "
                                                             "initial offsets (o⁰, s⁰) of the three points"),
    ("load_nodes", "(L|1,)", "i32 vec5", "-", "load rows: kind, nodes, curve"),
    ("load_vals", "(L|1,)", "real vec4", "Pa or N/m", "load row values"),
    ("curve_points", "(P|1,)", "real vec2", "s, -", "the amplitude curves' points (time, factor)"),
    ("step_dt", "()", "real", "s", "the time step the kernels integrate with (Simulation.dt)"),
    ("step_gravity", "()", "real vec2", "m/s²", "gravity"),
    ("step_buffer", "()", "real", "m", "detection buffer"),
    ("step_vlimit", "()", "real", "m/s", "node speed above which a step stops (speed_limit)"),
    ("step_switches", "()", "i32", "-", "runtime switches (damping, prescribed velocities, ...)"),
    ("fluid_edge", "(Q|1,)", "i32 vec8", "-", "fracture-network edges: node copies, fluid nodes, joint (engine.fluid)"),
    ("fluid_index", "(I,)", "i32", "-", "the network's header and index lists (engine.fluid)"),
])

#: NumPy arrays of the Model (host copies and build results).
MODEL_HOST_ARRAYS = _specs([
    ("node_rest", "(N, 2)", "f64", "m", "rest (initial) node positions X"),
    ("node_mass_np", "(N,)", "f64", "kg/m", "node_mass on the host"),
    ("node_velocity0", "(N, 2)", "f64", "m/s", "initial node velocities"),
    ("node_vbc0", "(N, 2)", "f64", "m/s", "prescribed velocities at t = 0"),
    ("bc_group_masks", "(G, N)", "bool", "-", "nodes of each fix_nodes group"),
    ("tri_nodes_np", "(E, 3)", "i32", "-", "tri_nodes on the host"),
    ("tri_body_np", "(E,)", "i32", "-", "tri_body on the host"),
    ("tri_mat_np", "(E,)", "i32", "-", "tri_mat on the host"),
    ("tri_area0_np", "(E,)", "f64", "m²", "rest area of each triangle"),
    ("tri_fracturing", "(E,)", "bool", "-", "whether a triangle belongs to a fracturing body"),
    ("tri_intact0_np", "(E,)", "i32", "-", "initial tri_intact bits"),
    ("joint_tris_np", "(J, 2)", "i32", "-", "the two triangles of each joint"),
    ("joint_prop_np", "(J, 6)", "f64", "Pa, J/m², -", "the joints' material properties"),
    ("joint_set_np", "(J,)", "i32", "-", "joint set index of each joint"),
    ("joint_len0_np", "(J,)", "f64", "m", "rest length of each joint"),
    ("joint_fs0", "(J|1, 3)", "f64", "Pa", "initial shear strength of each joint (three points): c, or "
                                           "c − σ⁰ tan φ under an initial compression σ⁰"),
    ("nb_pairs_np", "(nb, 2)", "i32", "-", "bonded neighbour triangle pairs"),
    ("fluid_real0", "(R,)", "f64", "Pa, Pa·s, m, m²/s", "the fluid's parameters and sources at the start"),
    ("fluid_content0", "(W|1,)", "f64", "m²", "initial fluid content of each network node"),
    ("fluid_node_rest", "(W, 2)", "f64", "m", "initial positions of the network nodes"),
    ("fluid_copies", "(k, 2)", "i32", "-", "(network node, node copy) pairs of the network's edge faces"),
])

#: Taichi arrays of the State (what a step changes; all saved by checkpoints).
STATE_ARRAYS = _specs([
    ("node_x", "(N,)", "real vec2", "m", "node positions"),
    ("node_v", "(N,)", "real vec2", "m/s", "node velocities"),
    ("node_f", "(N,)", "real vec2", "N/m", "nodal forces of the last step (per unit thickness)"),
    ("node_vbc", "(N|1,)", "real vec2", "m/s", "prescribed velocities now"),
    ("node_react", "(N|1,)", "real vec2", "N/m", "reactions at prescribed components"),
    ("load_force", "(L|1,)", "real vec4", "N/m", "forces of the load rows at the last step"),
    ("tri_diss", "(E|1,)", "real", "J/m", "energy dissipated by each triangle's damping"),
    ("tri_intact", "(E,)", "i32", "-", "bits: intact, damaged, edges free, removed (< 0)"),
    ("tri_nb_on", "(nb|1,)", "i32", "-", "whether each neighbour link is still bonded"),
    ("joint_state", "(J|1,)", "i32", "-", "intact / damaged / broken per joint"),
    ("joint_dmax", "(J|1,)", "real vec3", "m", "largest opening and slip reached"),
    ("joint_zmax", "(J|1,)", "real vec3", "-", "softening factor at the largest opening"),
    ("joint_fs", "(J|1,)", "real vec3", "Pa", "shear strength of each joint (three integration points)"),
    ("joint_work", "(J|1,)", "real", "J/m", "work done on each joint"),
    ("joint_break", "(J|1,)", "real vec4", "s, m, m, Pa", "time, position and fluid pressure of each joint's break "
     "(pressure −1: none recorded)"),
    ("joint_g", "(J|1,)", "real vec4", "J/m²", "energy released per mode"),
    ("couple_start", "(K+1|1,)", "i32", "-", "first couple of each contact triangle (friction history)"),
    ("couple_a", "(C,)", "i32", "-", "first triangle of each contact couple"),
    ("couple_b", "(C,)", "i32", "-", "second triangle of each contact couple"),
    ("couple_hist", "(6C|1,)", "real", "m", "tangential slip history of the couples (6 slots each, with friction)"),
    ("step_real", "(REAL_COUNTERS,)", "real", "s, J/m, m", "real counters (engine.groups: TIME, DACC, energies)"),
    ("step_int", "(INT_COUNTERS,)", "i32", "-", "integer counters (engine.groups: COUPLES, FOUND, ...)"),
    ("fluid_edge_val", "(Q|1,)", "real vec8", "m, m, m³/(Pa·s), m²/s, N/m", "per network edge: aperture, length, "
                                                                          "conductance, flux, face forces"),
    ("fluid_node_val", "(W|1,)", "real vec4", "m², m², Pa, 1/s", "per network node: fluid content, volume, pressure, "
                                                               "K ΣC/V"),
    ("fluid_real", "(R,)", "real", "Pa, Pa·s, m, J/m, m²/s, m²", "the fluid's parameters, counters and sources "
                                                                "(engine.fluid: F_K, ...)"),
])

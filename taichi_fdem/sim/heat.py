"""Heat conduction at build time: capacities, conduction matrices, the nodes' lists of terms, the
boundary rows and the stable heat step (docs/theory/heat.md §16), and the heat's results.

:func:`build_heat` turns the scene's temperatures (``scene.set_temperature``, ``scene.heat``)
and the materials' thermal fields (``conductivity``, ``heat_capacity``, ``expansion``) into
the arrays of the ``heat`` group (:mod:`taichi_fdem.engine.arrays`); the kernels are in
:mod:`taichi_fdem.engine.heat`, the sub-solver that runs them between mechanical steps is
:class:`taichi_fdem.sim.solver.HeatCoupling`.
"""
from __future__ import annotations

import math

import numpy as np

from ..engine.heat import (ADJ_FLUX, ADJ_HELD, ADJ_JOINT, ADJ_TRI, CONTACT_OVERLAP_REF, JOINT_CONDUCTANCE_FACTOR,
                           ROW_FLUX, ROW_TEMPERATURE)
from .selection import select

__all__ = ["build_heat", "heat_state_values", "JOINT_CONDUCTANCE_FACTOR", "CONTACT_OVERLAP_REF",
           "effective_expansion"]

def _thermal_fields(materials, where: str) -> tuple:
    """(conductivity, heat capacity, expansion) per material; ValueError naming a material
    without conductivity or heat capacity."""
    k, c, a = [], [], []
    for m in materials:
        kc = getattr(m, "conductivity", None)
        cc = getattr(m, "heat_capacity", None)
        if kc is None or cc is None:
            raise ValueError(f"{where}: the scene conducts heat but material {m.name or m!r} has no "
                             f"{'conductivity' if kc is None else 'heat_capacity'}; give every material of a heated "
                             "scene conductivity= [W/(m·K)] and heat_capacity= [J/(kg·K)]")
        k.append(float(kc))
        c.append(float(cc))
        a.append(float(getattr(m, "expansion", 0.0) or 0.0))
    return np.array(k), np.array(c), np.array(a)


def effective_expansion(materials, plane: str) -> np.ndarray:
    """(M, 2): the effective 2D expansion (a₁*, a₂*) [1/K] of each material along and across its
    bedding (docs/theory/heat.md §16.5, :meth:`Material.thermal_expansion_2d
    <taichi_fdem.material.Material.thermal_expansion_2d>`): α(1 + ν) in plane strain, α in plane
    stress for an isotropic material."""
    return np.array([m.thermal_expansion_2d(plane) for m in materials], dtype=np.float64).reshape(-1, 2)


def _conduction_matrices(X, tris, kt) -> np.ndarray:
    """(E, 6): K_e (00, 11, 22, 01, 12, 20) = k A ∇N_a·∇N_b of the linear triangles on the rest
    geometry [W/(m·K)] (docs/theory/heat.md §16.2)."""
    x, y = X[tris, 0], X[tris, 1]
    b = np.stack([y[:, 1] - y[:, 2], y[:, 2] - y[:, 0], y[:, 0] - y[:, 1]], axis=1)
    c = np.stack([x[:, 2] - x[:, 1], x[:, 0] - x[:, 2], x[:, 1] - x[:, 0]], axis=1)
    area = 0.5 * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0])
    f = kt / (4.0 * area)
    kab = lambda a, bb: f * (b[:, a] * b[:, bb] + c[:, a] * c[:, bb])  # noqa: E731
    return np.stack([kab(0, 0), kab(1, 1), kab(2, 2), kab(0, 1), kab(1, 2), kab(2, 0)], axis=1)


def _expansion_tensors(md, scene, materials, tri_mat) -> np.ndarray:
    """(E, 3): the effective expansion tensor R diag(a₁*, a₂*) Rᵀ (xx, yy, xy) [1/K] of each
    triangle, R the rotation to its bedding angle (``tri_bedding_np`` [°] when the model has one)."""
    a = effective_expansion(materials, scene.plane)[tri_mat]
    bedding = getattr(md, "tri_bedding_np", None)
    if bedding is None or len(bedding) != len(a):
        return np.stack([a[:, 0], a[:, 1], np.zeros(len(a))], axis=1)
    cs, sn = np.cos(np.radians(bedding)), np.sin(np.radians(bedding))
    return np.stack([a[:, 0] * cs * cs + a[:, 1] * sn * sn, a[:, 0] * sn * sn + a[:, 1] * cs * cs,
                     (a[:, 0] - a[:, 1]) * cs * sn], axis=1)


def _initial_temperature(scene, X) -> np.ndarray:
    spec = getattr(scene, "_temperature", None)
    value = 0.0 if spec is None else spec
    if callable(value):
        T = np.asarray(value(X[:, 0].copy(), X[:, 1].copy()), dtype=np.float64)
        if T.shape == ():
            T = np.full(len(X), float(T))
        if T.shape != (len(X),):
            raise ValueError(f"Scene.set_temperature: initial(x, y) must return a number or an array of shape "
                             f"({len(X)},), got shape {T.shape}")
    else:
        T = np.full(len(X), float(value))
    if not np.all(np.isfinite(T)):
        raise ValueError("Scene.set_temperature: the initial temperature is not finite")
    return T


def _heat_rows(scene, bodies, X, curves, boundary_edges) -> tuple:
    """(rows (R, 5) i32, values (R, 2)) of the scene's held temperatures and fluxes
    (engine.heat: kind, node i, node j, curve start, curve count; value, length share);
    ``boundary_edges(body)``: (local triangle, local edge) of its boundary edges."""
    rows, vals = [], []
    for k, spec in enumerate(getattr(scene, "_heat", [])):
        held = spec.temperature is not None
        picked = select(spec.where, spec.body, bodies, X, f"Scene.heat #{k}", None if held else boundary_edges)
        c = curves.add(spec.curve)
        for _, ni, nj, _ in picked:
            if held:
                rows += [(ROW_TEMPERATURE, int(i), -1, c) for i in ni]
                vals += [(spec.temperature, 0.0)] * len(ni)
                continue
            for i, j in zip(ni, nj):
                rows.append((ROW_FLUX, int(i), int(j), c))
                vals.append((spec.flux, 0.5 * float(np.linalg.norm(X[j] - X[i]))))
    return rows, vals


def _row_table(rows, vals, curves) -> tuple:
    slices = curves.slices
    table = np.zeros((max(len(rows), 1), 5), np.int32)
    val = np.zeros((max(len(rows), 1), 2))
    for r, (kind, i, j, c) in enumerate(rows):
        c0, cn = slices[c] if c >= 0 else (0, 0)
        table[r] = (kind, i, j, c0, cn)
        val[r] = vals[r]
    return table, val


def _node_lists(N, tris, joint_nodes, rows) -> np.ndarray:
    """heat_adj: N + 1 starts (offset by N + 1), then each node's coded entries in a fixed order
    (triangles, joints, flux rows, its held row: the last one naming it)."""
    node, code = [tris.ravel()], [(np.arange(3 * len(tris)) * 4 + ADJ_TRI)]
    if len(joint_nodes):
        node.append(joint_nodes.ravel())
        code.append(np.arange(4 * len(joint_nodes)) * 4 + ADJ_JOINT)
    held = {}
    for r, (kind, i, j, _) in enumerate(rows):
        if kind == ROW_FLUX:
            node.append(np.array([i, j]))
            code.append(np.array([r * 4 + ADJ_FLUX] * 2))
        else:
            held[i] = r
    if held:
        node.append(np.array(list(held.keys())))
        code.append(np.array([r * 4 + ADJ_HELD for r in held.values()]))
    node, code = np.concatenate(node), np.concatenate(code)
    order = np.argsort(node, kind="stable")
    starts = np.zeros(N + 1, np.int64)
    starts[1:] = np.cumsum(np.bincount(node, minlength=N))
    return np.concatenate([starts + N + 1, code[order]]).astype(np.int32)


def _joint_conductance(md, kt, altitude, joint_nodes, joint_tris, joint_len) -> np.ndarray:
    """(J, 2): G₀ = F k̄ (L/2) / h̄ per facing pair and the reference overlap δ_c = r L
    (docs/theory/heat.md §16.4; F :data:`JOINT_CONDUCTANCE_FACTOR`, r :data:`CONTACT_OVERLAP_REF`)."""
    if not md.fracture:
        return np.zeros((1, 2))
    J = md.joint_count
    ta, tb = joint_tris[:J, 0], joint_tris[:J, 1]
    kbar = 2.0 * kt[ta] * kt[tb] / np.maximum(kt[ta] + kt[tb], 1e-300)
    h = np.minimum(altitude[ta], altitude[tb])
    L = joint_len[:J]
    return np.stack([JOINT_CONDUCTANCE_FACTOR * kbar * 0.5 * L / h, CONTACT_OVERLAP_REF * L], axis=1)


def build_heat(md, scene, X, tris, materials, tri_mat, area0, altitude, joints, curves, boundary_edges) -> dict:
    """The model values of the heat group (engine.arrays) and the model's heat attributes:
    ``md.heat`` (the scene conducts heat), ``md.dt_heat`` (the stable heat step [s],
    docs/theory/heat.md §16.3), ``md.heat_row_count``, ``md.heat_adj_count``, ``md.heat_temp0``
    (initial temperatures (N,) [K]), ``md.heat_capacity_np`` (C_i (N,) [J/(m·K)]),
    ``md.heat_conductivity_np`` (k per triangle (E,) [W/(m·K)]).  Placeholders without heat.
    ``boundary_edges(body)``: (local triangle, local edge) of the body's boundary edges."""
    joint_nodes, joint_tris, joint_len = joints
    md.heat = bool(getattr(scene, "_temperature", None) is not None or getattr(scene, "_heat", []))
    md.heat_row_count, md.heat_adj_count, md.dt_heat = 0, 0, math.inf
    if not md.heat:
        return {"heat_node": np.zeros((1, 3)), "heat_tri": np.zeros((1, 11)), "heat_adj": np.zeros(1, np.int32),
                "heat_joint": np.zeros((1, 2)), "heat_rows": np.zeros((1, 5), np.int32),
                "heat_row_val": np.zeros((1, 2))}
    N = len(X)
    k, c, _ = _thermal_fields(materials, "Scene.heat")
    rho = np.array([m.density for m in materials])
    kt = k[tri_mat]
    cap = np.zeros(N)
    np.add.at(cap, tris.ravel(), np.repeat((rho * c)[tri_mat] * area0 / 3.0, 3))
    if np.any(cap <= 0):
        raise ValueError("Scene.heat: every node needs a positive heat capacity (density × heat_capacity > 0)")
    T0 = _initial_temperature(scene, X)
    Ke = _conduction_matrices(X, tris, kt)
    G = _joint_conductance(md, kt, altitude, joint_nodes, joint_tris, joint_len)
    rows, vals = _heat_rows(scene, md.bodies, X, curves, boundary_edges)
    md.heat_rows_list = rows
    md.heat_temp0, md.heat_capacity_np, md.heat_conductivity_np = T0, cap, kt
    row = _row_sums(N, tris, Ke, joint_nodes[: md.joint_count] if md.fracture else None, G)
    ok = row > 0
    md.dt_heat = float(np.min(cap[ok] / row[ok])) if np.any(ok) else math.inf
    adj = _node_lists(N, tris, joint_nodes[: md.joint_count] if md.fracture else np.zeros((0, 4), np.int32), rows)
    md.heat_adj_count = len(adj) - N - 1
    md.heat_row_count = len(rows)
    table, val = _row_table(rows, vals, curves)
    return {"heat_node": np.stack([cap, T0, row], axis=1),
            "heat_tri": np.concatenate([Ke, _expansion_tensors(md, scene, materials, tri_mat), kt[:, None],
                                        altitude[:, None]], axis=1),
            "heat_adj": adj, "heat_joint": G, "heat_rows": table, "heat_row_val": val}


def _row_sums(N, tris, Ke, joint_nodes, G) -> np.ndarray:
    """Σ_j abs(K_ij) of each node over its triangles and joints (joints at G₀): the stable heat
    step is Δt_h = min_i C_i / Σ_j abs(K_ij) (Gershgorin, docs/theory/heat.md §16.3)."""
    row = np.zeros(N)
    full = np.abs(np.stack([Ke[:, 0], Ke[:, 3], Ke[:, 5], Ke[:, 3], Ke[:, 1], Ke[:, 4], Ke[:, 5], Ke[:, 4],
                            Ke[:, 2]], axis=1)).reshape(-1, 3, 3).sum(axis=2)
    np.add.at(row, tris.ravel(), full.ravel())
    if joint_nodes is not None and len(joint_nodes):
        g = np.repeat(2.0 * G[: len(joint_nodes), 0], 4)       # |G| on the diagonal and off it
        np.add.at(row, joint_nodes.ravel(), g)
    return row


def heat_state_values(md) -> dict:
    """The heat group's initial state: the initial temperatures."""
    if not getattr(md, "heat", False):
        return {}
    return {"heat_temp": md.heat_temp0}


# ---- results ------------------------------------------------------------------------------------
def temperatures(sim) -> np.ndarray:
    """Temperature of each node (N,) [K or °C, the scale of the scene's temperatures]."""
    if not getattr(sim.model, "heat", False):
        raise ValueError("sim.temperatures(): the scene conducts no heat (use scene.set_temperature or scene.heat)")
    return sim.state.heat_temp.to_numpy().astype(np.float64)


def heat_flow(sim) -> np.ndarray:
    """Heat flux density q = −k ∇T of each triangle (E, 2) [W/m²], ∇T of its linear temperature
    field on the rest geometry (docs/theory/heat.md §16.2)."""
    T = temperatures(sim)
    md = sim.model
    X, tris = md.node_rest, md.tri_nodes_np
    x, y = X[tris, 0], X[tris, 1]
    b = np.stack([y[:, 1] - y[:, 2], y[:, 2] - y[:, 0], y[:, 0] - y[:, 1]], axis=1)
    c = np.stack([x[:, 2] - x[:, 1], x[:, 0] - x[:, 2], x[:, 1] - x[:, 0]], axis=1)
    two_a = b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0]
    Te = T[tris]
    grad = np.stack([(b * Te).sum(axis=1), (c * Te).sum(axis=1)], axis=1) / two_a[:, None]
    return -md.heat_conductivity_np[:, None] * grad


def heat_account(sim) -> dict:
    """The heat account [J] (× the thickness): ``heat_flux_in`` (through fluxes),
    ``heat_held_in`` (through held temperatures; negative when they take heat out),
    ``heat_supplied`` (their sum), ``heat_stored`` (Σ C_i (T_i − T_i0)), and the mechanical
    ``thermal_work`` (the change of the strain energy as the thermal strains changed)."""
    st, md = sim.state, sim.model
    t = sim.thickness
    sup = st.heat_supply.to_numpy().astype(np.float64)
    T = st.heat_temp.to_numpy().astype(np.float64)
    flux_in, held_in = float(sup[:, 0].sum()) * t, float(sup[:, 1].sum()) * t
    return {"heat_flux_in": flux_in, "heat_held_in": held_in, "heat_supplied": flux_in + held_in,
            "heat_stored": float(np.sum(md.heat_capacity_np * (T - md.heat_temp0))) * t,
            "thermal_work": float(st.heat_tri_work.to_numpy().astype(np.float64).sum()) * t}


def heat_history(sim, row: dict) -> None:
    """The history columns of the heat: temperature min / max / mean [K] (the mean weighted by
    the nodes' heat capacities)."""
    T = temperatures(sim)
    C = sim.model.heat_capacity_np
    row["temperature_min"] = float(T.min())
    row["temperature_max"] = float(T.max())
    row["temperature_mean"] = float(np.sum(C * T) / np.sum(C))

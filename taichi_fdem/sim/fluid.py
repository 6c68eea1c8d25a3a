"""The fluid in the fracture network, host side (docs/theory/fluid.md): the network of a scene
fixed at build, its arrays, its time-step limit, and the fluid results of a simulation.

The network (:func:`build_network`): the candidate edges are every crack edge
(``add_body(cracks=)``) and every joint of a fracturing body; the fluid nodes are the original
(unsplit) mesh vertices at their ends, one per vertex however many edges meet there.  Which
edges conduct is decided per step by the kernels (:mod:`taichi_fdem.engine.fluid`).  The scene
is read duck-typed (``scene._fluid``, ``scene._injections``): this module does not import the
scene builder that sits above it.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from .. import backend
from ..engine.fluid import (F_AMAX, F_AMIN, F_BAD, F_DAMAGED, F_HEAD, F_K, F_MU, F_WORK, HEADER, H_G_NODE, H_G_START,
                            H_NE_START, H_NF, H_NG, H_NS, H_SRC, SRC_PRESSURE, SRC_RATE, SRC_STRIDE, BAD_SUBSTEPS)
from .views import View

__all__ = ["FluidNetwork", "build_network", "fluid_stiffness_step", "install_fluid", "FluidResults"]

#: aperture_max when none is given [m]
NO_APERTURE_MAX = 1e30


@dataclass
class FluidNetwork:
    """The candidate edges of a scene's fracture network (numpy, global numbering).

    ``edges`` (E, 8) i32: a0, a1, b1, b0 (node copies), u, v (fluid nodes), joint (−1: crack
    edge), 0; ``node_rest`` (F, 2) initial fluid-node positions [m]; ``crack`` (E,) bool.
    """
    edges: np.ndarray
    node_rest: np.ndarray
    crack: np.ndarray

    @property
    def edge_count(self) -> int:
        return len(self.edges)

    @property
    def node_count(self) -> int:
        return len(self.node_rest)


def _face_nodes(b, tA, kA, tB, kB) -> np.ndarray:
    """(k, 4) node copies (A's u, A's v, B's v, B's u) of interior edges in b's split mesh."""
    tri = np.asarray(b.mesh.triangles, np.int64)
    return np.stack([tri[tA, kA], tri[tA, (kA + 1) % 3], tri[tB, kB], tri[tB, (kB + 1) % 3]], axis=1)


def build_network(bodies) -> FluidNetwork:
    """The candidate edges of ``bodies`` (cracks first, then joints, body by body)."""
    rows, crack_flags, keys, pos = [], [], {}, []
    joint_base = 0
    for b in bodies:
        has_joints = bool(b.fracture and b.joint_count)
        if (b.crack_count or has_joints) and b.edge_table is not None and b.source_mesh is not None:
            u, v, tA, kA, tB, kB = (np.asarray(a, np.int64) for a in b.edge_table)
            faces = _face_nodes(b, tA, kA, tB, kB)
            pick = [np.nonzero(np.asarray(b.crack_mask, bool))[0]] if b.crack_count else []
            joint_of = []
            if has_joints:
                where = {tuple(r): k for k, r in enumerate(faces.tolist())}
                idx = np.array([where[tuple(r)] for r in np.asarray(b.joint_nodes).tolist()], np.int64)
                pick.append(idx)
                joint_of = joint_base + np.arange(b.joint_count)
            for part, edges in enumerate(pick):
                is_crack = bool(b.crack_count) and part == 0
                for n, e in enumerate(edges):
                    ends = []
                    for vert in (u[e], v[e]):
                        key = (b.index, int(vert))
                        if key not in keys:
                            keys[key] = len(pos)
                            pos.append(b.source_mesh.points[vert])
                        ends.append(keys[key])
                    j = -1 if is_crack else int(joint_of[n])
                    rows.append([*(faces[e] + b.node_start), ends[0], ends[1], j, 0])
                    crack_flags.append(is_crack)
        if has_joints:
            joint_base += b.joint_count
    return FluidNetwork(np.asarray(rows, np.int32).reshape(-1, 8), np.asarray(pos, np.float64).reshape(-1, 2),
                        np.asarray(crack_flags, bool))


def fluid_stiffness_step(net: FluidNetwork, X, mass, moving_node, bulk_modulus: float, aperture_min: float) -> float:
    """The time step [s] set by the fluid's stiffness in the narrowest channels: a face node of
    mass m on an edge of length L holds a spring of at most K L / a_min (K/w per unit area, the
    stiffness of a filled channel at w = a_min); 2 √(m a_min / (K L)), the smallest over the
    edges with a node that moves (inf without)."""
    if not net.edge_count:
        return math.inf
    e = net.edges
    L = np.linalg.norm(0.5 * (X[e[:, 1]] + X[e[:, 2]] - X[e[:, 0]] - X[e[:, 3]]), axis=1)
    m = mass[e[:, :4]].min(axis=1)
    use = moving_node[e[:, :4]].any(axis=1) & (L > 0)
    if not use.any():
        return math.inf
    return float(np.min(2.0 * np.sqrt(m[use] * aperture_min / (bulk_modulus * L[use]))))


def _csr(n: int, owner: np.ndarray, entry: np.ndarray, base: int):
    """(starts (n + 1) as absolute offsets from ``base``, entries sorted by owner then value)."""
    order = np.lexsort((entry, owner))
    counts = np.bincount(owner, minlength=n)
    starts = base + np.concatenate([[0], np.cumsum(counts)])
    return starts, entry[order]


def _no_fluid(md) -> dict:
    """One-row placeholders of the fluid arrays (a scene without a fluid); returns the values
    of the model's fluid arrays."""
    md.fluid_real0 = np.zeros(F_HEAD)
    md.fluid_content0 = np.zeros(1)
    md.fluid_node_rest = np.zeros((0, 2))
    md.fluid_copies = np.zeros((0, 2), np.int32)
    md.fluid_edge_count = md.fluid_node_count = 0
    md.fluid_sources = []
    return {"fluid_edge": np.zeros((1, 8), np.int32), "fluid_index": np.zeros(HEADER, np.int32)}


def _fluid_sources(net: FluidNetwork, injections, curves):
    """(rows, nodes_of) of the scene's injections: per source (kind, curve, value) and the
    network nodes it feeds, selected on their initial positions (a selection of no node is an
    error; one of no crack node warns, as nothing enters until a joint there conducts)."""
    F, e = net.node_count, net.edges
    rows, nodes_of = [], []
    for k, inj in enumerate(injections):
        sel = np.asarray(inj.where(net.node_rest[:, 0].copy(), net.node_rest[:, 1].copy()), dtype=bool)
        if sel.shape != (F,):
            raise ValueError(f"Scene.inject #{k}: where(x, y) must return a boolean array of shape ({F},) "
                             "(the network nodes' initial coordinates)")
        if not sel.any():
            raise ValueError(f"Scene.inject #{k}: the predicate selects no node of the fracture network "
                             f"({F} nodes on cracks and joints; initial coordinates)")
        wet = np.zeros(F, bool)
        wet[e[net.crack, 4]] = wet[e[net.crack, 5]] = True
        if not wet[sel].any():
            warnings.warn(f"Scene.inject #{k}: none of its {int(sel.sum())} network node(s) is on a crack edge: "
                          "nothing enters until a joint at one of them conducts (start from a crack, "
                          "add_body(cracks=))", RuntimeWarning, stacklevel=6)
        c = curves.add(inj.curve)
        rows.append((SRC_RATE if inj.rate is not None else SRC_PRESSURE, c,
                     float(inj.rate if inj.rate is not None else inj.pressure)))
        nodes_of.append(np.nonzero(sel)[0])
    return rows, nodes_of


def _fluid_index(net: FluidNetwork, rows, nodes_of, slices) -> np.ndarray:
    """The fluid's index lists in one i32 array (engine.fluid): the header, each fluid node's
    edges, the solid nodes that receive pressure forces with their entries, and the sources'
    table with their nodes."""
    E, F, e = net.edge_count, net.node_count, net.edges
    S = len(rows)
    ne_owner = np.concatenate([e[:, 4], e[:, 5]]).astype(np.int64)
    ne_entry = np.concatenate([np.arange(E), -1 - np.arange(E)]).astype(np.int64)
    solid = e[:, :4].reshape(-1).astype(np.int64)
    recv, recv_inv = np.unique(solid, return_inverse=True)
    G = len(recv)
    off_ne = HEADER
    ne_list_at = off_ne + F + 1
    ne_start, ne_list = _csr(F, ne_owner, ne_entry, ne_list_at)
    off_gnode = ne_list_at + len(ne_list)
    off_gstart = off_gnode + G
    g_list_at = off_gstart + G + 1
    g_start, g_list = _csr(G, recv_inv.astype(np.int64), np.arange(4 * E, dtype=np.int64), g_list_at)
    off_src = g_list_at + len(g_list)
    src_nodes_at = off_src + 4 * (S + 1)
    src_table = np.zeros(4 * (S + 1), np.int64)
    at = src_nodes_at
    for s, (kind, c, _) in enumerate(rows):
        c0, cn = slices[c] if c >= 0 else (0, 0)
        src_table[4 * s: 4 * s + 4] = (kind, c0, cn, at)
        at += len(nodes_of[s])
    src_table[4 * S + 3] = at
    header = np.zeros(HEADER, np.int64)
    header[[H_NF, H_NG, H_NS, H_NE_START, H_G_NODE, H_G_START, H_SRC]] = (F, G, S, off_ne, off_gnode, off_gstart,
                                                                         off_src)
    index = np.concatenate([header, ne_start, ne_list, recv, g_start, g_list, src_table]
                           + [n.astype(np.int64) for n in nodes_of])
    assert index.max() < 2**31
    return index


def _fluid_contents(md, net: FluidNetwork, spec, r) -> np.ndarray:
    """The initial fluid content of every fluid node: ``initial_pressure`` in the edges that
    conduct at the start (the crack edges, at the aperture of the rest mesh, clamped to the
    apertures' bounds r[F_AMIN], r[F_AMAX])."""
    X, e = md.node_rest, net.edges
    d = 0.5 * (X[e[:, 1]] + X[e[:, 2]] - X[e[:, 0]] - X[e[:, 3]])
    L = np.linalg.norm(d, axis=1)
    n = np.stack([d[:, 1], -d[:, 0]], axis=1) / np.maximum(L, 1e-300)[:, None]
    w = 0.5 * (((X[e[:, 3]] - X[e[:, 0]]) * n).sum(axis=1) + ((X[e[:, 2]] - X[e[:, 1]]) * n).sum(axis=1))
    w = np.clip(w, spec.aperture_min, r[F_AMAX]) * net.crack
    V = np.zeros(net.node_count)
    np.add.at(V, e[:, 4], 0.5 * L * w)
    np.add.at(V, e[:, 5], 0.5 * L * w)
    return V * (1.0 + spec.initial_pressure / spec.fluid.bulk_modulus)


def install_fluid(md, scene, net: FluidNetwork, curves) -> dict:
    """The fluid of the model (``md.fluid`` False: one-row placeholders): sources selected on
    the fluid nodes' initial positions, the index lists, the parameters and the initial contents
    (:func:`_fluid_contents`).  Returns the values of the model's fluid arrays
    ({"fluid_edge": (Q, 8), "fluid_index": (I,)}, engine.arrays)."""
    spec = getattr(scene, "_fluid", None)
    injections = list(getattr(scene, "_injections", []))
    md.fluid = spec is not None
    if not md.fluid:
        return _no_fluid(md)
    if not net.edge_count:
        raise ValueError("Scene.set_fluid: the scene has no fracture network: no body has cracks (add_body(cracks=)) "
                         "or joints (add_body(fracture=))")
    E, F = net.edge_count, net.node_count
    e = net.edges
    rows, nodes_of = _fluid_sources(net, injections, curves)
    index = _fluid_index(net, rows, nodes_of, curves.slices)
    # parameters and initial contents
    fluid, K = spec.fluid, spec.fluid.bulk_modulus
    r = np.zeros(F_HEAD + SRC_STRIDE * len(rows))
    r[F_K], r[F_MU], r[F_AMIN] = K, fluid.viscosity, spec.aperture_min
    r[F_AMAX] = NO_APERTURE_MAX if spec.aperture_max is None else spec.aperture_max
    r[F_DAMAGED] = 1.0 if spec.conduct == "damaged" else 0.0
    for s, (_, _, value) in enumerate(rows):
        r[F_HEAD + SRC_STRIDE * s] = value
    md.fluid_real0 = r
    md.fluid_content0 = _fluid_contents(md, net, spec, r)
    md.fluid_edge_count, md.fluid_node_count = E, F
    md.fluid_sources = [{"kind": "rate" if k == SRC_RATE else "pressure", "nodes": nodes_of[s], "value": val}
                        for s, (k, _, val) in enumerate(rows)]
    md.fluid_node_rest = net.node_rest
    md.fluid_spec = spec
    # (fluid node, node copy) pairs: a fluid node's current position is the mean of its copies
    md.fluid_copies = np.unique(np.stack([np.concatenate([e[:, 4], e[:, 4], e[:, 5], e[:, 5]]),
                                          np.concatenate([e[:, 0], e[:, 3], e[:, 1], e[:, 2]])], axis=1),
                                axis=0).astype(np.int32)
    return {"fluid_edge": e.astype(np.int32), "fluid_index": index.astype(np.int32)}


def fluid_state_values(md) -> dict:
    """The initial values of the state's fluid arrays: node values (the initial contents) and
    the parameters, counters and sources (the edge values start at zero)."""
    nv = np.zeros((max(md.fluid_node_count, 1), 4), backend.real_np())
    if md.fluid:
        nv[:, 0] = md.fluid_content0
    return {"fluid_node_val": nv, "fluid_real": md.fluid_real0.astype(backend.real_np())}


def fluid_failure(sim) -> str | None:
    """Why the fluid stopped the run (None: it did not)."""
    if not getattr(sim.model, "fluid", False):
        return None
    bad = int(sim.state.fluid_real[F_BAD])
    if bad == 0:
        return None
    if bad == BAD_SUBSTEPS:
        return ("the fluid flow needs more than 65536 substeps per step (K Σ C / V too large: wide apertures "
                "or a low viscosity); use a smaller dt, an aperture_max or a larger viscosity")
    return "non-finite fluid content or pressure in the fracture network"


class FluidResults(View):
    """``sim.fluid``: the fluid results of a simulation.  Volumes and rates are per unit
    thickness (m², m²/s), as ``scene.inject`` takes them."""

    def _fluid_check(self, what: str) -> None:
        if not getattr(self._sim.model, "fluid", False):
            raise ValueError(f"{what}: the scene has no fluid (scene.set_fluid)")

    def _fluid_real(self) -> np.ndarray:
        return self._sim.state.fluid_real.to_numpy().astype(np.float64)

    def injection_rates(self) -> np.ndarray:
        """(S,) the volume rate [m²/s per unit thickness] into the network of each
        ``scene.inject`` call, in order, over the last step: positive into the network, negative
        out (a pressure source acting as a drain).  Zeros before the first step."""
        self._fluid_check("sim.fluid.injection_rates")
        S = len(self._sim.model.fluid_sources)
        return self._fluid_real()[F_HEAD + 1: F_HEAD + SRC_STRIDE * S: SRC_STRIDE][:S].copy()

    def injected_volumes(self) -> np.ndarray:
        """(S,) the volume [m² per unit thickness, at the reference density] each source has put
        into the network so far (negative: taken out)."""
        self._fluid_check("sim.fluid.injected_volumes")
        S = len(self._sim.model.fluid_sources)
        return self._fluid_real()[F_HEAD + 2: F_HEAD + SRC_STRIDE * S: SRC_STRIDE][:S].copy()

    def injection_pressure(self) -> float:
        """The pressure [Pa] at the first source: the mean over its nodes that conduct (0 while
        none does)."""
        self._fluid_check("sim.fluid.injection_pressure")
        if not self._sim.model.fluid_sources:
            raise ValueError("injection_pressure: the scene has no source (scene.inject)")
        nv = self._sim.state.fluid_node_val.to_numpy().astype(np.float64)
        nodes = self._sim.model.fluid_sources[0]["nodes"]
        on = nv[nodes, 1] > 0
        return float(nv[nodes[on], 2].mean()) if on.any() else 0.0

    def pressures(self):
        """(positions (F, 2) [m], pressures (F,) [Pa]) of the network's nodes: a node's position
        is the mean of the current positions of its face-node copies; pressures at the end of
        the last step (0 on nodes no conducting edge reaches)."""
        self._fluid_check("sim.fluid.pressures")
        md = self._sim.model
        x = self._sim.state.node_x.to_numpy().astype(np.float64)
        F = md.fluid_node_count
        pos = np.zeros((F, 2))
        cnt = np.zeros(F)
        np.add.at(pos, md.fluid_copies[:, 0], x[md.fluid_copies[:, 1]])
        np.add.at(cnt, md.fluid_copies[:, 0], 1.0)
        p = self._sim.state.fluid_node_val.to_numpy().astype(np.float64)[:F, 2]
        return pos / cnt[:, None], p

    def node_pressures(self) -> np.ndarray:
        """(N,) the fluid pressure [Pa] on every node of the mesh: on a face node of a network
        edge, the pressure of its network node (the copies of one vertex agree); 0 elsewhere."""
        self._fluid_check("sim.fluid.node_pressures")
        md = self._sim.model
        p = self._sim.state.fluid_node_val.to_numpy().astype(np.float64)[:, 2]
        out = np.zeros(md.node_count)
        out[md.fluid_copies[:, 1]] = p[md.fluid_copies[:, 0]]
        return out

    def volume(self) -> float:
        """The fluid stored in the network [m² per unit thickness, at the reference density]."""
        self._fluid_check("sim.fluid.volume")
        return float(self._sim.state.fluid_node_val.to_numpy().astype(np.float64)[: self._sim.model.fluid_node_count, 0].sum())

    def work(self) -> float:
        """The work done by the fluid pressure on the solid so far [J] (× the thickness)."""
        self._fluid_check("sim.fluid.work")
        return float(self._fluid_real()[F_WORK]) * self._sim.thickness

    def _fluid_history(self, row: dict) -> None:
        """The fluid's history columns: injection pressure [Pa], injected volume (net, all sources),
        stored volume [m² per unit thickness] and each source's rate [m²/s]."""
        row["fluid_injection_pressure"] = self.injection_pressure() if self._sim.model.fluid_sources else 0.0
        row["fluid_injected_volume"] = float(self.injected_volumes().sum())
        row["fluid_stored_volume"] = self.volume()
        for k, q in enumerate(self.injection_rates()):
            row[f"fluid_rate_{k}"] = float(q)

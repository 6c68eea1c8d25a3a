"""Scene → model and state: everything ``build()`` computes once, and the arrays a step changes.

In the spirit of Warp/Newton's builder → model → state:

* :class:`Model` — what is computed once from the scene: topology, rest shapes, masses,
  material and pair tables, boundary-condition masks, feature flags, the time step and the
  step parameters.  A model never changes while the simulation runs.
* :class:`State` — what a step changes: positions, velocities, forces, the couple list and its
  friction history, joint state, dissipation, counters.  Checkpoints and last-good-state
  snapshots save the state generically (every ndarray in it), and rebuild the model.
* :class:`Scratch` — work arrays of contact detection, rewritten at every detection.

:mod:`taichi_fdem.sim.state` allocates the state and the scratch of a model, and bundles model,
state and scratch into the argpacks of :mod:`taichi_fdem.engine.groups` that the kernels take.

The scene is read duck-typed (bodies, constraints, interactions, gravity, plane, thickness):
this module does not import the scene builder that sits above it.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import taichi as ti

from . import fluid as fluid_net, heat, timestep
from .arrays import Counters, allocate, check_host, counter, host_write, set_counter
from ..engine.arrays import MODEL, SCRATCH, STATE, declared
from .topology import bonds
from .selection import select
from ..engine.joints import HANDOVER_DAMAGE
from ..engine.loads import LOAD_ABSORB, LOAD_FORCE, LOAD_PRESSURE, LOAD_TRACTION, LOAD_VELOCITY

__all__ = ["Model", "State", "Scratch", "build_model", "counter", "set_counter", "host_write"]


def _next_pow2(n: int) -> int:
    return 1 << max(4, int(math.ceil(math.log2(max(n, 1)))))


class _Arrays:
    """A bag of named arrays; its Taichi arrays are the ones declared with its :attr:`ROLE` in
    :data:`taichi_fdem.engine.arrays.ARRAYS`."""

    ROLE = ""

    def ndarrays(self) -> dict:
        """The Taichi arrays, by name, in declared order: exactly the declared ones (TypeError
        when the object holds an undeclared Taichi array or lacks a declared one)."""
        names = declared(self.ROLE)
        held = {k for k, v in vars(self).items() if isinstance(v, ti.Ndarray)}
        if held != set(names):
            raise TypeError(f"{type(self).__name__}: Taichi arrays not declared {sorted(held - set(names))}, "
                            f"declared but not allocated {sorted(set(names) - held)} "
                            "(taichi_fdem/engine/arrays.py)")
        return {k: getattr(self, k) for k in names}


class Model(_Arrays):
    """What :meth:`Scene.build` computes once (see the module docstring).

    Counts: ``node_count``, ``tri_count``, ``joint_count``, ``ctri_count`` (contact
    triangles).  Flags: ``contact``, ``friction``, ``contact_damping``, ``damping``,
    ``fracture``, ``has_bc``, ``has_bc_work``, ``force_dt``.  Time steps [s]: ``dt``,
    ``dt_estimate``, ``dt_limit``, ``dt_elastic``, ``dt_contact``, ``dt_joint``; ``dashpot_rate``
    [1/s] (absorbing boundaries: stable while dashpot_rate · dt < 1).  ``buffer`` [m],
    ``speed_limit`` [m/s].  ``sizes``: the values of the size symbols of
    :data:`taichi_fdem.engine.arrays.SIZES` the arrays were allocated at.  Arrays: the Taichi ones
    in :data:`~taichi_fdem.sim.arrays.MODEL_ARRAYS`, the NumPy ones in
    :data:`~taichi_fdem.sim.arrays.MODEL_HOST_ARRAYS` (docs/reference/arrays.md).
    """
    ROLE = MODEL


class State(_Arrays):
    """What a step changes (see the module docstring): the Taichi arrays declared in
    :data:`~taichi_fdem.sim.arrays.STATE_ARRAYS`, every one saved by checkpoints, and
    ``couple_max``, the capacity of the couple buffer.  :attr:`counters` reads and writes the
    counters of ``step_real`` / ``step_int`` by name."""
    ROLE = STATE

    @property
    def counters(self) -> Counters:
        """The counters by name (:class:`taichi_fdem.sim.arrays.Counters`): ``state.counters.couples``."""
        return Counters(self)


class Scratch(_Arrays):
    """Work arrays of detection and of the parallel assembly (never saved): the Taichi arrays
    declared in :data:`~taichi_fdem.sim.arrays.SCRATCH_ARRAYS`."""
    ROLE = SCRATCH


def build_model(scene, dt=None, safety=0.2, force_dt=False, buffer=None, speed_limit=None,
                quasi_static: float = 0.0, joined_pairs: str = "joint",
                handover_damage: float | None = None) -> Model:
    """Compute the :class:`Model` of ``scene`` (validating the time step against its limit);
    ``handover_damage`` None: :data:`taichi_fdem.engine.joints.HANDOVER_DAMAGE`."""
    md = _new_model(scene, safety, joined_pairs, handover_damage)
    bodies = list(scene.bodies)
    md.bodies = bodies

    # ---- nodes and triangles -----------------------------------------------------------------
    X, tris, tri_body, materials, tri_mat, V = _nodes_and_triangles(md, bodies)
    area0, rest_inv, rho, mass, edge_len, altitude = _rest_shapes(md, X, tris, materials, tri_mat)

    # ---- boundary conditions -----------------------------------------------------------------
    curves = _Curves()
    free, vbc_raw, body_flags, vcurve, groups = _boundary_conditions(scene, bodies, X, curves)
    V = _prescribe_velocities(md, free, vbc_raw, vcurve, groups, curves, V)

    # ---- materials and pair table --------------------------------------------------------------
    pair = _pair_table(scene, materials)

    # ---- joints (docs/theory/joints.md §7, §13): per-joint properties and joint sets ------------------------
    joint_nodes, joint_tris, joint_prop, joint_len = _joint_table(md, scene, bodies, X, materials, tri_mat)

    # ---- contact participation ---------------------------------------------------------------
    ctri, used_pairs = _contact_triangles(md, bodies, pair, tri_mat)
    betas = np.array([m.damping for m in materials])
    md.damping = bool(np.any(betas > 0))
    beta_t = betas[tri_mat]

    # ---- stable time step (docs/theory/elements.md §6.2) ------------------------------------------------------
    net = _time_step(md, scene, dt, safety, force_dt, X, tris, free, materials, tri_mat, pair, used_pairs, mass,
                     (area0, altitude, beta_t, ctri), (joint_tris, joint_prop, joint_len))

    _buffer_and_speed_limit(md, scene, buffer, speed_limit, edge_len[ctri], materials, V)

    # ---- loads, curves, initial stress, local damping (docs/theory/loads.md §12) --------------------------
    load_nodes, load_vals, md.dashpot_rate = _load_table(scene, bodies, X, mass, md.dt, curves, free, vbc_raw, vcurve)
    md.load_count = len(load_nodes)
    fluid_values = fluid_net.install_fluid(md, scene, net, curves)   # (its curves join the table first)
    aniso_values = _anisotropy(md, scene, materials, X, tris, tri_mat)     # (md.tri_bedding_np: heat's expansion)
    heat_values = heat.build_heat(md, scene, X, tris, materials, tri_mat, area0, altitude,
                                  (joint_nodes, joint_tris, joint_len), curves, _boundary_edges)
    md.loads = md.load_count > 0
    md.curves = curves.list
    md.curve_slices = curves.slices
    prestress = _prestress(scene, tri_body, X, tris)
    md.prestress = prestress is not None
    md.qs_alpha = float(quasi_static)
    md.local_damping = md.qs_alpha > 0.0

    # ---- the bonds of the fracturing bodies (sim.topology) -------------------------------------
    md.ctri_count = len(ctri) if md.contact else 0
    md.tri_prestress_np = prestress if md.prestress else np.zeros((0, 3))
    sn_tau = _joint_prestress(scene, X, joint_nodes[: md.joint_count], tri_body[joint_tris[: md.joint_count, 0]]) \
        if md.fracture and md.prestress else None
    origin, joint_tris4, joint_cols, fans = bonds(md, X, tris, tri_mat, area0, pair, body_flags, tri_body, ctri,
                                                  (joint_nodes, joint_tris, joint_prop, joint_len), sn_tau)

    md.gravity = (float(scene.gravity[0]), float(scene.gravity[1]))     # m/s² (state.set_parameters)

    # ---- the Taichi arrays of the model (engine.arrays; one-row placeholders for unused features)
    values = {
        "node_mass": mass, "node_free": free if md.has_bc else np.ones((1, 2)),
        "load_nodes": load_nodes if md.loads else np.zeros((1, 5)),
        "load_vals": load_vals if md.loads else np.zeros((1, 4)), "curve_points": curves.points(),
        "tri_nodes": tris, "tri_rest_inv": rest_inv, "tri_mat": tri_mat, "tri_body": tri_body,
        "tri_visc": _tri_viscosity(materials, tri_mat, area0, beta_t, rho) if md.damping else np.zeros(1),
        "tri_origin": origin, "tri_prestress": prestress if md.prestress else np.zeros((1, 3)), "tri_fans": fans,
        "mat_lame": [(m.shear_modulus, m.lambda_y(scene.plane)) for m in materials],
        **aniso_values,
        "mat_pair": pair, "contact_tri": ctri if md.contact else np.zeros(1), "body_flags": body_flags,
        "joint_nodes": joint_nodes, "joint_tris": joint_tris4, "joint_prop": np.concatenate(joint_cols, axis=1),
        **fluid_values, **heat_values}
    md.sizes = _model_sizes(md, values, len(materials), len(groups))
    allocate(md, MODEL, md.sizes, values)
    check_host(md, md.sizes)
    return md


def _new_model(scene, safety, joined_pairs, handover_damage) -> Model:
    """An empty :class:`Model` after the checks of the build's arguments."""
    if handover_damage is None:
        handover_damage = HANDOVER_DAMAGE
    if joined_pairs not in ("joint", "contact"):
        raise ValueError(f"Scene.build: joined_pairs must be 'joint' or 'contact', got {joined_pairs!r}")
    if isinstance(handover_damage, bool) or not isinstance(handover_damage, (int, float, np.integer, np.floating)) \
            or not 0.0 <= float(handover_damage) <= 1.0:
        raise ValueError(f"Scene.build: handover_damage must be a number from 0 to 1 (the joint damage at which "
                         f"contact takes over a joined pair), got {handover_damage!r}")
    if not scene.bodies:
        raise ValueError("Scene.build: the scene has no bodies; add one with scene.add_body(...)")
    if not (0.0 < float(safety) <= 1.0):
        raise ValueError(f"Scene.build: safety must be in (0, 1], got {safety}")
    md = Model()
    md.joined_pairs = joined_pairs
    md.handover_damage = float(handover_damage)
    return md


def _buffer_and_speed_limit(md, scene, buffer, speed_limit, contact_edges, materials, V) -> None:
    """Set ``md.buffer`` [m] (None: a quarter of the contact triangles' mean edge length) and
    ``md.speed_limit`` [m/s] (None: twice the largest P-wave speed, at least ten times the
    largest initial speed)."""
    if buffer is None:
        buffer = 0.25 * float(contact_edges.mean()) if len(contact_edges) else 0.0
    buffer = float(buffer)
    if not (math.isfinite(buffer) and buffer >= 0):
        raise ValueError(f"Scene.build: buffer must be a finite length >= 0 m, got {buffer}")
    md.buffer = buffer
    if speed_limit is None:
        speed_limit = 2.0 * max(m.p_wave_speed(scene.plane) for m in materials)
        speed_limit = max(speed_limit, 10.0 * float(np.abs(V).max(initial=0.0)))
    md.speed_limit = float(speed_limit)
    if not (md.speed_limit > 0):
        raise ValueError(f"Scene.build: speed_limit must be > 0 m/s, got {speed_limit}")


def _nodes_and_triangles(md, bodies):
    """(rest positions X (N, 2), triangles (E, 3), body and material of each triangle, the
    materials, initial velocities (N, 2)) of the bodies; sets the model's counts and host copies."""
    X = np.concatenate([b.mesh.points for b in bodies]).astype(np.float64)
    tris = np.concatenate([b.mesh.triangles + b.node_start for b in bodies]).astype(np.int32)
    tri_body = np.concatenate([np.full(b.mesh.triangle_count, b.index, np.int32) for b in bodies])
    materials, mat_index = [], {}
    for b in bodies:
        for mt in _body_materials(b):
            if id(mt) not in mat_index:
                mat_index[id(mt)] = len(materials)
                materials.append(mt)
    md.materials = materials
    tri_mat = np.concatenate([np.array([mat_index[id(mt)] for mt in _body_materials(b)], np.int32)[_tri_material(b)]
                              for b in bodies])
    md.node_count, md.tri_count = len(X), len(tris)
    md.node_rest, md.tri_nodes_np, md.tri_body_np, md.tri_mat_np = X, tris, tri_body, tri_mat
    V = np.zeros_like(X)
    for b in bodies:
        r = X[b.nodes] - b.mesh.centroid
        V[b.nodes] = b.velocity + b.angular_velocity * np.stack([-r[:, 1], r[:, 0]], axis=1)
    return X, tris, tri_body, materials, tri_mat, V


def _rest_shapes(md, X, tris, materials, tri_mat):
    """(rest area (E,) [m²], F0⁻¹ (E, 2, 2) [1/m], density (E,) [kg/m³], lumped nodal mass (N,)
    [kg/m], edge lengths (E, 3) [m], smallest altitude (E,) [m]) of the triangles."""
    x0, x1, x2 = X[tris[:, 0]], X[tris[:, 1]], X[tris[:, 2]]
    F0 = np.stack([x1 - x0, x2 - x0], axis=2)          # columns: edges 0→1, 0→2
    area0 = 0.5 * np.linalg.det(F0)
    rest_inv = np.linalg.inv(F0)
    rho = np.array([m.density for m in materials])[tri_mat]
    mass = np.zeros(len(X))
    np.add.at(mass, tris.ravel(), np.repeat(rho * area0 / 3.0, 3))
    md.node_mass_np, md.node_mass_full, md.tri_area0_np = mass, mass.copy(), area0
    edge_len = np.stack([np.linalg.norm(x1 - x0, axis=1), np.linalg.norm(x2 - x1, axis=1),
                         np.linalg.norm(x0 - x2, axis=1)], axis=1)
    altitude = 2.0 * area0 / edge_len.max(axis=1)       # smallest altitude of each triangle
    return area0, rest_inv, rho, mass, edge_len, altitude


def _time_step(md, scene, dt, safety, force_dt, X, tris, free, materials, tri_mat, pair, used_pairs, mass, tri,
               joints):
    """Set the model's stable time-step estimates and its time step ``md.dt`` (validating ``dt``
    against the limit, docs/theory/elements.md §6.2); returns the fluid's fracture network (None
    without a fluid)."""
    area0, altitude, beta_t, ctri = tri
    joint_tris, joint_prop, joint_len = joints
    bodies = md.bodies
    moving = ~np.all(free[tris].reshape(len(tris), 6) == 0.0, axis=1)
    rho_all = np.array([m.density for m in materials])
    cp = np.array([m.p_wave_speed(scene.plane) for m in materials])[tri_mat]
    pmax = _touching_penalty(bodies, tri_mat, moving, pair) if md.contact else 0.0
    rho_min = min(m.density for m in materials)
    xi_max = used_pairs[..., 3].max() / (4.0 * math.sqrt(pmax * rho_min)) if md.contact_damping and pmax > 0 else 0.0
    if md.fracture:
        # the node mass a joint moves is set by its triangles' size: the smaller of their
        # smallest altitudes, at most the joint length
        h_j = np.minimum(np.minimum(altitude[joint_tris[:, 0]], altitude[joint_tris[:, 1]]), joint_len)
        j_rho = np.minimum(rho_all[tri_mat[joint_tris[:, 0]]], rho_all[tri_mat[joint_tris[:, 1]]])
        j_pf = joint_prop[:, 5]
    else:
        h_j = j_rho = j_pf = np.zeros(0)
    fspec = getattr(scene, "_fluid", None)
    net = fluid_net.build_network(bodies) if fspec is not None else None
    dt_fluid = fluid_net.fluid_stiffness_step(net, X, mass, np.any(free != 0.0, axis=1), fspec.fluid.bulk_modulus,
                                              fspec.aperture_min) if fspec is not None else math.inf
    steps = timestep.estimate_time_steps(
        altitude=altitude, area0=area0, cp=cp, beta=beta_t, moving=moving,
        contact_altitude=altitude[ctri] if md.contact else np.zeros(0), contact_penalty=pmax, rho_min=rho_min,
        xi_max=xi_max, joint_h=h_j, joint_rho=j_rho, joint_penalty=j_pf, fluid_step=dt_fluid)
    md.dt_fluid = steps["fluid"]
    md.dt_elastic, md.dt_contact, md.dt_joint = steps["elastic"], steps["contact"], steps["joint"]
    md.dt_estimate, md.dt_limit = steps["estimate"], steps["limit"]
    md.dt = timestep.choose_time_step(steps, dt, safety, force_dt)
    md.force_dt = bool(force_dt)
    return net


def _joint_table(md, scene, bodies, X, materials, tri_mat):
    """(joint_nodes (J, 4), joint_tris (J, 2), joint_prop (J, 6), rest lengths (J,)) of the
    fracturing bodies (one zero row without joints); sets the model's joint flags, counts and
    host arrays and warns about soft or slender joint parameters (§7.9)."""
    jn, jt, jp, js = [], [], [], []
    for b in bodies:
        if b.fracture and b.joint_count:
            jn.append(b.joint_nodes + b.node_start)
            jt.append(b.joint_tris + b.tri_start)
            jp.append(_joint_prop(b))
            js.append(np.asarray(b.joint_set if b.joint_set is not None else np.zeros(b.joint_count), np.int32))
    md.fracture = bool(jn)
    joint_nodes = np.concatenate(jn).astype(np.int32) if jn else np.zeros((1, 4), np.int32)
    joint_tris = np.concatenate(jt).astype(np.int32) if jt else np.zeros((1, 2), np.int32)
    joint_prop = np.concatenate(jp) if jp else np.zeros((1, 6))
    md.joint_count = len(joint_nodes) if md.fracture else 0
    md.joint_tris_np = joint_tris[: md.joint_count]
    md.joint_prop_np = joint_prop[: md.joint_count]
    md.joint_set_np = np.concatenate(js) if js else np.zeros(0, np.int32)
    md.joint_set_names = list(getattr(scene, "joint_set_names", ["default"]))
    joint_len = np.linalg.norm(X[joint_nodes[:, 1]] - X[joint_nodes[:, 0]], axis=1)
    md.joint_len0_np = joint_len[: md.joint_count]
    if md.fracture:
        _warn_joint_parameters(md.joint_set_names, md.joint_set_np, joint_prop, joint_len,
                               np.array([m.young for m in materials])[tri_mat[joint_tris[:, 0]]])
    return joint_nodes, joint_tris, joint_prop, joint_len


def _contact_triangles(md, bodies, pair, tri_mat):
    """(the triangles that take part in contact, the pair table of the materials that meet);
    sets ``md.contact``, ``md.friction`` and ``md.contact_damping``."""
    contact = len(bodies) >= 2 or any(b.self_contact for b in bodies)
    ctri = []
    if contact:
        for b in bodies:
            t = np.arange(b.tri_start, b.tri_start + b.mesh.triangle_count, dtype=np.int32)
            if not b.self_contact:
                # only triangles that touch the surface can meet another body
                on_surface = np.zeros(b.mesh.point_count, bool)
                on_surface[b.mesh.boundary_nodes()] = True
                t = t[on_surface[b.mesh.triangles].any(axis=1)]
            ctri.append(t)
    ctri = np.concatenate(ctri) if ctri else np.zeros(0, np.int32)
    md.contact = contact and len(ctri) > 1
    used_pairs = pair[np.ix_(np.unique(tri_mat), np.unique(tri_mat))] if md.contact else pair[:0, :0]
    md.friction = bool(md.contact and np.any(used_pairs[..., 2] > 0))
    md.contact_damping = bool(md.contact and np.any(used_pairs[..., 3] > 0))
    return ctri, used_pairs


def _model_sizes(md, values: dict, materials: int, groups: int) -> dict:
    """The size symbols of engine.arrays.SIZES that the model fixes, and its feature switches."""
    K = md.ctri_count if md.contact else 1
    return {"N": md.node_count, "E": md.tri_count, "M": materials, "B": len(md.bodies), "G": groups,
            "L": max(md.load_count, 1), "P": len(values["curve_points"]), "K": K,
            "H": _next_pow2(2 * K) if md.contact else 1, "J": len(values["joint_nodes"]), "NB": md.nb_count,
            "V": md.fan_count, "F": len(values["tri_fans"]), "Q": max(md.fluid_edge_count, 1),
            "W": max(md.fluid_node_count, 1), "NC": len(md.fluid_copies), "I": len(values["fluid_index"]),
            "R": len(md.fluid_real0), "bc": md.has_bc, "damping": md.damping, "prestress": md.prestress,
            "joint_prestress": md.joint_prestress, "contact": md.contact, "friction": md.friction,
            "fracture": md.fracture, "fluid": md.fluid, "bedding": md.bedding, "heat": md.heat,
            "heat_contact": md.heat and md.contact,
            "HA": max(md.heat_adj_count, 1), "HR": max(md.heat_row_count, 1)}


def _anisotropy(md, scene, materials, X, tris, tri_mat) -> dict:
    """Set ``md.bedding`` (some material has a :class:`~taichi_fdem.material.Bedding`); the values of ``tri_bedding`` (cos, sin of each
    triangle's bedding angle, the angle evaluated at its rest centroid) and ``mat_aniso``
    (C11, C22, C12, C66 of each material in its bedding frame), docs/theory/anisotropy.md.
    Triangles of isotropic materials hold (0, 0) in ``tri_bedding`` (engine.elastic.is_bedded)."""
    md.bedding = any(m.bedding is not None for m in materials)
    if not md.bedding:
        md.tri_bedding_np = np.zeros(0)
        return {"tri_bedding": np.array([[1.0, 0.0]]), "mat_aniso": np.zeros((1, 4))}
    centroid = X[tris].mean(axis=1)
    angle = np.zeros(len(tris))
    bedded = np.zeros(len(tris), bool)
    for k, m in enumerate(materials):
        sel = tri_mat == k
        if m.bedding is not None and sel.any():
            angle[sel] = m.bedding.angles(centroid[sel, 0], centroid[sel, 1])
            bedded |= sel
    md.tri_bedding_np = angle
    rad = np.radians(angle)
    return {"tri_bedding": np.stack([np.cos(rad), np.sin(rad)], axis=1) * bedded[:, None],
            "mat_aniso": np.array([m.stiffness_2d(scene.plane) for m in materials])}


def _tri_viscosity(materials, tri_mat, area0, beta_t, rho) -> np.ndarray:
    """The viscous damping coefficient of each triangle [Pa·s·m] (docs/theory/contact.md §2.3); a
    bedded material is rated with the larger of its moduli E1, E2."""
    E = np.array([m.young if m.bedding is None else max(m.young, m.bedding.young_normal)
                  for m in materials])[tri_mat]
    h = np.sqrt(4.0 * area0 / math.sqrt(3.0))       # edge of the equilateral of equal area
    return 2.0 * h * beta_t * np.sqrt(E * rho)


def _boundary_conditions(scene, bodies, X, curves):
    """(free (n, 2), prescribed velocity (n, 2) before curves, body_flags (bodies,), velocity
    curve of each node component (n, 2; −1: none), groups [(label, node mask)]) from the scene."""
    free = np.ones_like(X)
    vbc = np.zeros_like(X)
    vcurve = np.full(X.shape, -1, np.int64)
    body_flags = np.zeros(len(bodies), np.int32)
    groups = []
    for b in bodies:
        if b.fixed or b.prescribed_velocity is not None:
            free[b.nodes] = 0.0
            vbc[b.nodes] = 0.0 if b.fixed else b.prescribed_velocity
            vcurve[b.nodes] = curves.add(getattr(b, "velocity_curve", None))
            mask = np.zeros(len(X), bool)
            mask[b.nodes] = True
            groups.append((b.name, mask))
        if b.self_contact:
            body_flags[b.index] |= 1
    for k, con in enumerate(scene._constraints):
        sel = np.asarray(con.where(X[:, 0].copy(), X[:, 1].copy()), dtype=bool)
        if sel.shape != (len(X),):
            raise ValueError(f"Scene.fix_nodes #{k}: where(x, y) must return a boolean array of shape ({len(X)},)")
        if con.body is not None:
            mask = np.zeros(len(X), bool)
            mask[con.body.nodes] = True
            sel &= mask
        if not sel.any():
            raise ValueError(f"Scene.fix_nodes #{k}: the predicate selects no node")
        c = curves.add(getattr(con, "curve", None))
        for comp, v in enumerate(con.velocity):
            if v is not None:
                free[sel, comp] = 0.0
                vbc[sel, comp] = v
                vcurve[sel, comp] = c
        groups.append((f"fix{k}", sel))
    for b in bodies:
        if np.all(free[b.nodes] == 0.0) and np.all(vbc[b.nodes] == 0.0):
            body_flags[b.index] |= 2
    return free, vbc, body_flags, vcurve, groups


def _prescribe_velocities(md, free, vbc, vcurve, groups, curves, V) -> np.ndarray:
    """The initial node velocities (n, 2): ``V`` with every held component (``free`` 0) set to its
    prescribed velocity ``vbc`` times its curve at t = 0.  Sets the model's reaction groups
    (``bc_group_labels``, ``bc_group_masks``), ``has_bc``, ``has_bc_work``, ``node_velocity0`` and
    ``node_vbc0`` (the prescribed velocities at t = 0)."""
    md.bc_group_labels = [g[0] for g in groups]          # reactions recorded by the history
    md.bc_group_masks = np.array([g[1] for g in groups], bool).reshape(len(groups), len(V))
    md.has_bc = bool(np.any(free == 0.0))
    md.has_bc_work = bool(np.any((free == 0.0) & (vbc != 0.0)))
    vbc = vbc * curves.at(vcurve, 0.0)          # curve-driven velocities start at A(0)
    V = np.where(free == 0.0, vbc, V)
    md.node_velocity0, md.node_vbc0 = V, vbc
    return V


class _Curves:
    """The load curves of a scene, numbered in order of first use, and their table."""

    def __init__(self):
        self.list, self._index = [], {}

    def add(self, curve) -> int:
        if curve is None:
            return -1
        if id(curve) not in self._index:
            self._index[id(curve)] = len(self.list)
            self.list.append(curve)
        return self._index[id(curve)]

    @property
    def slices(self) -> list:
        """(start, count) of each curve in :meth:`points`."""
        out, start = [], 0
        for c in self.list:
            out.append((start, len(c.times)))
            start += len(c.times)
        return out

    def points(self) -> np.ndarray:
        if not self.list:
            return np.zeros((1, 2))
        return np.concatenate([np.stack([c.times, c.values], axis=1) for c in self.list])

    def at(self, index: np.ndarray, t: float) -> np.ndarray:
        """Amplitude of curve ``index`` (−1: none, amplitude 1) at time t, elementwise."""
        out = np.ones(np.shape(index))
        for k, c in enumerate(self.list):
            out[index == k] = float(np.interp(t, c.times, c.values))
        return out


def _boundary_edges(b):
    """(t, k) of the boundary edges of body b: local triangle t, local edge k (nodes k → k+1);
    a fracturing body's edges are judged on its unexploded mesh."""
    tri = b.origin_triangles if (b.fracture and b.origin_triangles is not None) else b.mesh.triangles
    tri = np.asarray(tri, np.int64)
    u = tri.ravel()
    v = tri[:, [1, 2, 0]].ravel()
    key = np.minimum(u, v) * (int(tri.max()) + 1) + np.maximum(u, v)
    _, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    e = np.nonzero(cnt[inv] == 1)[0]
    return e // 3, e % 3


def _load_table(scene, bodies, X, mass, dt, curves, free, vbc_raw, vcurve):
    """(load_nodes (L, 5) i32, load_vals (L, 4), dashpot rate [1/s]): the load table of
    :mod:`taichi_fdem.engine.loads`, and max over nodes of Σ ρ c_p L/2 / m of the absorbing
    boundaries' dashpots (0 without), stable while rate · Δt < 1 (docs/theory/loads.md §12.5)."""
    rows, vals = [], []
    kinds = {"pressure": LOAD_PRESSURE, "traction": LOAD_TRACTION, "force": LOAD_FORCE, "absorbing": LOAD_ABSORB}
    slices = None
    dash = np.zeros(len(X))                     # Σ ρ c_p L/2 of the dashpots at each node
    for k, ld in enumerate(getattr(scene, "_loads", [])):
        what = f"Scene.{'absorbing_boundary' if ld.kind == 'absorbing' else 'apply_' + ld.kind} #{k}"
        kind = kinds[ld.kind]
        picked = select(ld.where, ld.body, bodies, X, what, None if kind == LOAD_FORCE else _boundary_edges)
        c = curves.add(ld.curve)
        n0 = len(rows)
        for b, ni, nj, t in picked:
            if kind == LOAD_FORCE:
                rows += [(kind, int(i), -1, c) for i in ni]
                vals += [(ld.value[0], ld.value[1], 0.0, 0.0)] * len(ni)
                continue
            L0 = np.linalg.norm(X[nj] - X[ni], axis=1)
            bmats, tmat = _body_materials(b), _tri_material(b)
            for i, j, l0, te in zip(ni, nj, L0, t):
                rows.append((kind, int(i), int(j), c))
                if kind == LOAD_PRESSURE:
                    vals.append((ld.value[0], 0.0, 0.0, 0.0))
                elif kind == LOAD_TRACTION:
                    vals.append((0.5 * l0 * ld.value[0], 0.5 * l0 * ld.value[1], 0.0, 0.0))
                else:
                    m = bmats[tmat[te]]
                    zp = m.density * m.p_wave_speed(scene.plane)
                    vals.append((zp, math.sqrt(m.shear_modulus * m.density), 0.0, 0.0))
                    dash[i] += 0.5 * zp * l0
                    dash[j] += 0.5 * zp * l0
        if not np.all(np.isfinite(vals[n0:])):
            raise ValueError(f"{what}: the load is not finite")
    md_dash = float(np.max(dash / mass)) if np.any(dash > 0) else 0.0
    if np.any(dash > 0):
        ratio = float(np.max(dash * dt / mass))
        if ratio >= 1.0:
            raise ValueError(f"absorbing_boundary: the dashpots are unstable at this time step (ρ c_p L/2 · Δt / m = "
                             f"{ratio:.3g} >= 1, docs/theory/loads.md §12.5); use a smaller dt or safety")
    # prescribed velocities that follow a curve (one row per node component)
    for i, comp in zip(*np.nonzero((free == 0.0) & (vcurve >= 0))):
        rows.append((LOAD_VELOCITY, int(i), int(comp), int(vcurve[i, comp])))
        vals.append((vbc_raw[i, comp], 0.0, 0.0, 0.0))
    slices = curves.slices
    table = np.zeros((len(rows), 5), np.int32)
    for r, (kind, i, j, c) in enumerate(rows):
        c0, cn = slices[c] if c >= 0 else (0, 0)
        table[r] = (kind, i, j, c0, cn)
    return table, np.asarray(vals, np.float64).reshape(-1, 4), md_dash


def _stress_at(scene, body, y):
    """(n, 3) initial stress (xx, yy, xy) [Pa] at n points of the bodies ``body`` (n,) at the
    heights ``y`` (n,) [m], or None without one (§12.4: a later call overrides on its bodies)."""
    specs = getattr(scene, "_initial_stress", [])
    if not specs:
        return None
    out = np.zeros((len(y), 3))
    for sp in specs:
        sel = np.ones(len(y), bool) if sp.body is None else (body == sp.body.index)
        out[sel] = sp.stress + (y[sel, None] - sp.y_ref) * sp.gradient
    return out


def _prestress(scene, tri_body, X, tris):
    """(m, 3) initial stress (xx, yy, xy) of each triangle [Pa], at its centroid, or None (§12.4)."""
    return _stress_at(scene, tri_body, X[tris].mean(axis=1)[:, 1])


def _joint_prestress(scene, X, joint_nodes, joint_body):
    """(σ⁰, τ⁰), each (J, 3): the normal and shear traction σ⁰·n̂ of the initial stress at the
    three points of each joint (end j0, mid-point, end j1) in its rest frame (n̂ into triangle A,
    ê from j0 to j1) [Pa], or None (docs/theory/joints.md §7.11)."""
    x0, x1 = X[joint_nodes[:, 0]], X[joint_nodes[:, 1]]
    if not len(x0):
        return None
    pts = np.stack([x0, 0.5 * (x0 + x1), x1], axis=1)                          # (J, 3, 2)
    st = _stress_at(scene, np.repeat(joint_body, 3), pts[..., 1].ravel())
    if st is None:
        return None
    st = st.reshape(-1, 3, 3)
    e = x1 - x0
    e = e / np.linalg.norm(e, axis=1, keepdims=True)
    n = np.stack([-e[:, 1], e[:, 0]], axis=1)
    tx = st[..., 0] * n[:, None, 0] + st[..., 2] * n[:, None, 1]               # σ⁰·n̂
    ty = st[..., 2] * n[:, None, 0] + st[..., 1] * n[:, None, 1]
    return tx * n[:, None, 0] + ty * n[:, None, 1], tx * e[:, None, 0] + ty * e[:, None, 1]


def _touching_penalty(bodies, tri_mat, moving, pair) -> float:
    """The largest contact penalty (normal or tangential) [Pa] of the material pairs that can
    touch and move: a couple takes its pair's penalty (by default the smaller of the two), so a
    stiff material sets the contact step only where it meets itself.  Pairs counted: the
    materials of two different bodies of which at least one has a node that is not prescribed,
    and a body's materials against each other only when it has self-contact (docs/theory/elements.md §6.2).
    Two platens of one steel, both prescribed, never set the limit."""
    mats, free = [], []
    for b in bodies:
        sl = slice(b.tri_start, b.tri_start + b.mesh.triangle_count)
        mats.append(np.unique(tri_mat[sl]))
        free.append(bool(np.any(moving[sl])))
    best = 0.0
    for i in range(len(bodies)):
        for j in range(i, len(bodies)):
            if not (free[i] or free[j]) or (i == j and not bodies[i].self_contact):
                continue
            sub = pair[np.ix_(mats[i], mats[j])]
            if sub.size:
                best = max(best, float(sub[..., 0:2].max()))
    return best


def _pair_table(scene, materials) -> np.ndarray:
    """(M, M, 4) contact properties of each material pair: penalty p [Pa], tangential penalty
    k_t [Pa/m], friction μ, normal damping c_n = 4 ξ √(p ρ) (smaller of the two materials'
    values unless ``scene.set_interaction`` overrides them)."""
    M = len(materials)
    pair = np.zeros((M, M, 4))
    # crack-face materials (add_body(crack_friction=)): contact as their parent material, but
    # with the crack's friction against their own body's crack faces and parent material
    parent, family = {}, {}
    for b in getattr(scene, "bodies", []):
        for clone, par in (getattr(b, "crack_clones", None) or []):
            parent[id(clone)] = par
            family[id(clone)] = (b.index, clone.friction, id(par))
    for i, a0 in enumerate(materials):
        for j, b0 in enumerate(materials):
            a, b = parent.get(id(a0), a0), parent.get(id(b0), b0)
            ov = dict(scene._interactions.get((id(a), id(b)), {}))
            fa, fb = family.get(id(a0)), family.get(id(b0))
            if fa is not None and (fb is None and id(b0) == fa[2] or fb is not None and fb[0] == fa[0]):
                ov["friction"] = fa[1]
            elif fb is not None and fa is None and id(a0) == fb[2]:
                ov["friction"] = fb[1]
            p = ov.get("penalty", min(a.contact_penalty, b.contact_penalty))
            kt = ov.get("tangential_penalty", min(a.contact_tangential_penalty, b.contact_tangential_penalty))
            mu = ov.get("friction", min(a.friction, b.friction))
            xi = ov.get("contact_damping", min(a.contact_damping, b.contact_damping))
            pair[i, j] = (p, kt, mu, 4.0 * xi * math.sqrt(p * min(a.density, b.density)))
    return pair


def _warn_joint_parameters(set_names, joint_set, joint_prop, joint_len, young) -> None:
    """Warn once per joint set about a soft joint penalty or a large pre-peak opening (§7.9)."""
    for k in np.unique(joint_set):
        rows = joint_set == k
        label = f"joint set {set_names[k] if k < len(set_names) else k!r}"
        ft, c, tanphi, gI, gII, pf = joint_prop[rows].min(axis=0)
        E = float(young[rows].max())
        pf = float(joint_prop[rows, 5].min())
        if pf < 10.0 * E:
            warnings.warn(f"{label}: joint_penalty = {pf / E:.3g}·E; intact joints "
                          f"make a jointed body about {100 * E / pf:.0f} % softer than E "
                          "(docs/theory/joints.md §7.9: use ≥ 10·E)", RuntimeWarning, stacklevel=5)
        ftr, gIr = joint_prop[rows, 0], joint_prop[rows, 3]
        ratio = (2.0 * joint_len[rows] * ftr / joint_prop[rows, 5]) / (3.0 * gIr / ftr)
        if ratio.max() > 0.2:
            i = int(np.argmax(ratio))
            warnings.warn(f"{label}: the opening at peak δ_p = 2 L f_t/p_f = "
                          f"{2.0 * joint_len[rows][i] * ftr[i] / joint_prop[rows, 5][i]:.3g} m "
                          f"is not small against the softening span 3 G_I/f_t = {3 * gIr[i] / ftr[i]:.3g} m; "
                          "the pre-peak branch will dominate the fracture energy (raise joint_penalty or "
                          "G_I, docs/theory/joints.md §7.9)", RuntimeWarning, stacklevel=5)


def _body_materials(b) -> list:
    return b.materials if getattr(b, "materials", None) else [b.material]


def _tri_material(b) -> np.ndarray:
    tm = getattr(b, "tri_material", None)
    return np.zeros(b.mesh.triangle_count, np.int32) if tm is None else np.asarray(tm, np.int32)


def _joint_prop(b) -> np.ndarray:
    jp = getattr(b, "joint_prop", None)
    if jp is None or len(jp) != b.joint_count:
        jp = np.tile(np.asarray(b.material.joint_properties(), float), (b.joint_count, 1))
    return np.asarray(jp, np.float64)

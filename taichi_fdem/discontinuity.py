"""Discontinuities and heterogeneity of a body (docs/theory/discontinuities.md §13): where its cohesive joints and
pre-existing cracks go, the joint properties of each joint (joint sets, interfaces) and their
statistical spread.

A body keeps its unsplit mesh (``body.source_mesh``) and the interior edges selected for
joints and cracks (boolean masks over :func:`~taichi_fdem.mesh.split.interior_edge_table`, so a
scene stays picklable); :func:`split_body` turns them into the split mesh, the joints and their
per-joint properties whenever a selection changes.

Strength distributions (§13.3), one draw per joint from a seeded generator:

* :class:`Weibull` ``(modulus, seed)``: s = s̄ (−ln U)^{1/m} / Γ(1 + 1/m), U uniform in (0, 1];
* :class:`NormalStrength` ``(cov, seed)``: s = s̄ (1 + v Z), truncated at ``floor`` · s̄.

The factor multiplies the joint's tensile strength f_t and cohesion c (one factor per joint: a
weak joint is weak in tension and in shear); the fracture energies G_I, G_II stay fixed unless
``scale_energy=True`` (then they scale with the same factor).

Strength of the bedding (docs/theory/anisotropy.md, "Strength of the bedding"): a material with a
``Bedding`` gives each of its joints f_t, c, φ, G_I, G_II interpolated between the bedding's
values (a joint parallel to the bedding) and the material's (a joint at θ ≥ θ_w to it) by the
weight w(θ) = max(0, 1 − θ/θ_w) of the angle θ between the joint's rest direction and the bedding
(:func:`bedding_weight`, :func:`bedding_strength`); the statistical factor then multiplies.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from .material import Material, check_finite
from .mesh.split import split_mesh

__all__ = ["Weibull", "NormalStrength", "split_body", "bedding_weight", "bedding_strength", "bedding_planes",
           "BEDDING_WINDOW"]

#: Default angular window θ_w [degrees] of the strength of the bedding: a joint at θ ≥ θ_w to the
#: bedding keeps the material's strength, one parallel to it (θ = 0) has the bedding's, linearly
#: in between (``Bedding(strength_window=...)`` sets it per material).
BEDDING_WINDOW = 15.0


@dataclass(frozen=True)
class Weibull:
    """Weibull-distributed joint strength with modulus ``modulus`` (m > 0) and mean 1 × the
    material's value; ``seed`` makes the draws reproducible (docs/theory/discontinuities.md §13.3)."""

    modulus: float
    seed: int = 0
    scale_energy: bool = False

    def __post_init__(self):
        m = check_finite("modulus", self.modulus, "Weibull")
        if m <= 0:
            raise ValueError(f"Weibull: modulus must be > 0, got {self.modulus}")
        if int(self.seed) != self.seed:
            raise ValueError(f"Weibull: seed must be an integer, got {self.seed!r}")

    def factors(self, n: int, rng: np.random.Generator) -> np.ndarray:
        u = 1.0 - rng.random(n)                     # uniform in (0, 1]
        return (-np.log(u)) ** (1.0 / self.modulus) / math.gamma(1.0 + 1.0 / self.modulus)


@dataclass(frozen=True)
class NormalStrength:
    """Normally distributed joint strength: mean 1 × the material's value, coefficient of
    variation ``cov``, truncated below at ``floor`` (docs/theory/discontinuities.md §13.3)."""

    cov: float
    seed: int = 0
    floor: float = 0.05
    scale_energy: bool = False

    def __post_init__(self):
        v = check_finite("cov", self.cov, "NormalStrength")
        f = check_finite("floor", self.floor, "NormalStrength")
        if v < 0:
            raise ValueError(f"NormalStrength: cov must be >= 0, got {self.cov}")
        if not 0 < f < 1:
            raise ValueError(f"NormalStrength: floor must be in (0, 1), got {self.floor}")
        if int(self.seed) != self.seed:
            raise ValueError(f"NormalStrength: seed must be an integer, got {self.seed!r}")

    def factors(self, n: int, rng: np.random.Generator) -> np.ndarray:
        return np.maximum(1.0 + self.cov * rng.standard_normal(n), self.floor)


def check_strength(strength, where: str):
    if strength is not None and not isinstance(strength, (Weibull, NormalStrength)):
        raise TypeError(f"{where}: strength must be taichi_fdem.Weibull(...), taichi_fdem.NormalStrength(...) "
                        f"or None, got {type(strength).__name__}")
    return strength


@dataclass
class JointSet:
    """A named set of joints with its own properties (``scene.add_joint_set``)."""

    name: str
    material: Material
    strength: object = None


def _apply_strength(prop: np.ndarray, rows: np.ndarray, strength, seed_key) -> None:
    if strength is None or not rows.any():
        return
    rng = np.random.default_rng([int(strength.seed)] + list(seed_key))
    f = strength.factors(int(rows.sum()), rng)
    prop[rows, 0] *= f                             # f_t
    prop[rows, 1] *= f                             # c
    if strength.scale_energy:
        prop[rows, 3] *= f                         # G_I
        prop[rows, 4] *= f                         # G_II


def bedding_weight(theta_deg, window_deg: float = BEDDING_WINDOW) -> np.ndarray:
    """The weight w(θ) = max(0, 1 − θ/θ_w) of the bedding's strength in a joint at θ [degrees, 0..90]
    to the bedding (docs/theory/anisotropy.md, "Strength of the bedding"): 1 parallel to it, 0 from
    the window θ_w [degrees] on; monotone in between."""
    theta = np.abs(np.asarray(theta_deg, dtype=np.float64))
    return np.clip(1.0 - theta / float(window_deg), 0.0, 1.0)


def _bedding_values(bedding, prop: np.ndarray) -> tuple:
    """(material's, bedding's) joint parameters (f_t, c, φ [°], G_I, G_II), each (n, 5), of the rows
    ``prop`` (n, 6): a parameter the Bedding leaves None is the material's (it is isotropic)."""
    base = np.column_stack([prop[:, 0], prop[:, 1], np.degrees(np.arctan(prop[:, 2])), prop[:, 3], prop[:, 4]])
    out = base.copy()
    for col, key in enumerate(("tensile_strength", "cohesion", "friction_angle", "fracture_energy",
                               "fracture_energy_shear")):
        v = getattr(bedding, key, None)
        if v is not None:
            out[:, col] = float(v)
    return base, out


def bedding_strength(prop: np.ndarray, bedding, theta_deg) -> np.ndarray:
    """Joint properties (n, 6) (f_t, c, tan φ, G_I, G_II, p_f, the columns of
    ``Material.joint_properties``) of joints at ``theta_deg`` (n,) [degrees] to ``bedding``: each of
    f_t, c, φ, G_I, G_II is s = s_m + (s_b − s_m) w(θ) (:func:`bedding_weight` with the bedding's
    ``strength_window``), s_m the material's value in ``prop``, s_b the bedding's; p_f is kept."""
    prop = np.asarray(prop, dtype=np.float64)
    w = bedding_weight(theta_deg, _window(bedding))[:, None]
    base, bed = _bedding_values(bedding, prop)
    mixed = base + (bed - base) * w
    out = prop.copy()
    out[:, [0, 1, 3, 4]] = mixed[:, [0, 1, 3, 4]]
    out[:, 2] = np.tan(np.radians(mixed[:, 2]))
    return out


def _window(bedding) -> float:
    w = getattr(bedding, "strength_window", None)
    return BEDDING_WINDOW if w is None else float(w)


def bedding_angles(bedding, centroids: np.ndarray) -> np.ndarray:
    """The bedding's dip [degrees from the x axis] at each of ``centroids`` (m, 2) [m]: its
    ``angle``, a number or a callable f(x, y) of the placed coordinates."""
    c = np.asarray(centroids, dtype=np.float64)
    a = bedding.angle
    if callable(a):
        v = np.broadcast_to(np.asarray(a(c[:, 0], c[:, 1]), dtype=np.float64), (len(c),))
        if not np.isfinite(v).all():
            raise ValueError("Bedding: angle(x, y) returned a non-finite value")
        return np.array(v)
    return np.full(len(c), float(a))


def joint_bedding_theta(points, u, v, angle_a, angle_b) -> np.ndarray:
    """The angle θ [degrees, 0..90] between the joints from ``points[u]`` to ``points[v]`` and the
    bedding, whose dip [degrees] in the joints' two triangles is ``angle_a``, ``angle_b`` (their
    mean direction, as lines: the mean of the doubled angles)."""
    d = np.asarray(points, np.float64)[v] - np.asarray(points, np.float64)[u]
    a2 = np.radians(2.0 * np.asarray(angle_a, np.float64))
    b2 = np.radians(2.0 * np.asarray(angle_b, np.float64))
    half = 0.5 * np.arctan2(np.sin(a2) + np.sin(b2), np.cos(a2) + np.cos(b2))
    t = np.column_stack([np.cos(half), np.sin(half)])
    c = np.abs((d * t).sum(1)) / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-300)
    return np.degrees(np.arccos(np.clip(c, 0.0, 1.0)))


def _apply_bedding(prop: np.ndarray, rows: np.ndarray, body, mt) -> None:
    """Rows ``rows`` of ``prop`` (joints of material ``mt``) by their angle to ``mt``'s bedding."""
    bedding = getattr(mt, "bedding", None)
    if bedding is None or not rows.any():
        return
    src = body.source_mesh
    u, v, tA, _, tB, _ = body.edge_table
    pts = np.asarray(src.points, np.float64)
    cent = pts[np.asarray(src.triangles)].mean(axis=1)
    ta, tb = tA[rows], tB[rows]
    ang = bedding_angles(bedding, cent[np.concatenate([ta, tb])])
    theta = joint_bedding_theta(pts, u[rows], v[rows], ang[: len(ta)], ang[len(ta):])
    prop[rows] = bedding_strength(prop[rows], bedding, theta)


def _spaced_bedding(body, where: str):
    """(material, Bedding) of ``body``'s bedding with a ``spacing``, or None.  ValueError when
    its material groups have different spaced beddings or the angle is not a constant."""
    mats = body.materials[: body.group_count]
    beds = [getattr(mt, "bedding", None) for mt in mats]
    spaced = [(mt, b) for mt, b in zip(mats, beds) if b is not None and getattr(b, "spacing", None) is not None]
    if not spaced:
        return None
    if len(mats) > 1 and any(b != spaced[0][1] for b in beds):
        raise ValueError(f"{where}: Bedding(spacing=...) on a body of several material groups needs the same "
                         "Bedding in every group; give the planes with Scene.add_joint_set and "
                         "fdem.mesh.bedding_lines instead")
    mt, bed = spaced[0]
    if callable(bed.angle):
        raise ValueError(f"{where}: Bedding(spacing=...) needs a constant angle (planes of a varying dip are "
                         "not straight): give the planes with Scene.add_joint_set instead")
    return mt, bed


def bedding_planes(body, where: str):
    """The weak bedding planes of ``body`` (docs/guide/anisotropy.md, "Weak bedding planes"):
    (lines, material) with the planes' :class:`~taichi_fdem.mesh.Segments` through the body
    (:func:`~taichi_fdem.mesh.bedding_lines` at the bedding's angle and ``spacing``, one through
    the origin) and a copy of the body's material whose joint parameters are the bedding's
    (:func:`bedding_strength` at θ = 0); None when its material has no ``Bedding(spacing=...)``
    or no plane crosses the body.  ValueError when the mesh's edges do not follow the planes."""
    found = _spaced_bedding(body, where)
    if found is None:
        return None
    mt, bed = found
    from .mesh.bedding import bedding_lines
    lines = bedding_lines(body.source_mesh, float(bed.angle), float(bed.spacing))
    if lines is None:
        return None
    mask = resolve(body, lines, where)
    pts = np.asarray(body.source_mesh.points, np.float64)
    u, v = body.edge_table[0], body.edge_table[1]
    covered = float(np.hypot(*(pts[v[mask]] - pts[u[mask]]).T).sum())
    if covered < (1.0 - 1e-6) * lines.length:
        raise ValueError(f"{where}: the mesh's edges do not follow the bedding planes (Bedding(spacing="
                         f"{bed.spacing!r})): {covered:.4g} m of {lines.length:.4g} m of planes lie along mesh edges; "
                         "mesh the body with them: fdem.mesh.polygon(outline, h, lines=[fdem.mesh.bedding_lines("
                         f"outline, {bed.angle!r}, {bed.spacing!r})])")
    b = bedding_strength(np.array([mt.joint_properties()], np.float64), bed, np.zeros(1))[0]
    changes = dict(tensile_strength=float(b[0]), cohesion=float(b[1]), friction_angle=math.degrees(math.atan(b[2])),
                   fracture_energy=float(b[3]), fracture_energy_shear=float(b[4]),
                   name=f"{mt.name or 'material'} (bedding)")
    if hasattr(mt, "bedding"):
        changes["bedding"] = None
    return lines, mt.with_(**changes)


def _material_label(body, mt, group: int) -> str:
    """The material of group ``group`` as the user named it: its ``name``, its group label of
    ``add_body(..., groups=)``, or (a single unnamed material) its repr."""
    if mt.name:
        return f"material {mt.name!r}"
    labels = getattr(body, "group_labels", None)
    if labels is not None:
        return f"the material of group {labels[group]!r}"
    return f"the body's material {mt!r}"


def _joint_properties(body, joints, set_of_edge, joint_sets: list, where: str) -> np.ndarray:
    """The joint properties (e, 6) of every interior edge of ``body`` (rows of the edges that are
    no joint stay 0): the body's own joints (``set_of_edge`` 0) take the weaker material of their
    two triangles (lower tensile strength), by their angle to its bedding where it has one, the joints of set k ≥ 1 the material of
    ``joint_sets[k − 1]``; each set's strength distribution then spreads them.  ValueError when
    an own joint's material cannot fracture."""
    u, _, tA, _, tB, _ = body.edge_table
    mats = body.materials[: body.group_count]
    groups = body.tri_group
    prop = np.zeros((len(u), 6))
    own = joints & (set_of_edge == 0)
    if own.any():
        ft = np.array([mt.tensile_strength if mt.can_fracture else np.inf for mt in mats])
        ga, gb = groups[tA], groups[tB]
        weaker = np.where(ft[ga] <= ft[gb], ga, gb)
        for g in np.unique(weaker[own]):
            mt = mats[g]
            if not mt.can_fracture:
                raise ValueError(f"{where}: joints need tensile_strength [Pa] and fracture_energy [J/m²] on "
                                 f"{_material_label(body, mt, int(g))}")
            prop[own & (weaker == g)] = mt.joint_properties()
            _apply_bedding(prop, own & (weaker == g), body, mt)
    for k, js in enumerate(joint_sets, start=1):
        rows = joints & (set_of_edge == k)
        if rows.any():
            prop[rows] = js.material.joint_properties()
    _apply_strength(prop, own, body.strength, (body.index, 0))
    for k, js in enumerate(joint_sets, start=1):
        _apply_strength(prop, joints & (set_of_edge == k), js.strength, (body.index, k))
    return prop


def _crack_face_materials(body, crack, tri_material) -> None:
    """Reset ``body``'s materials to its material groups, then, when the body has a
    ``crack_friction`` and cracks (``crack``, a mask over its interior edges), append one copy
    per material group of the crack faces with that friction (``body.crack_clones``: (copy,
    original) pairs) and give it to the triangles along a crack in ``tri_material`` (m,)."""
    del body.materials[body.group_count:]
    body.crack_clones = []
    if body.crack_friction is None or not crack.any():
        return
    _, _, tA, _, tB, _ = body.edge_table
    mats = body.materials[: body.group_count]
    groups = body.tri_group
    face = np.zeros(body.source_mesh.triangle_count, bool)
    face[tA[crack]] = True
    face[tB[crack]] = True
    # one crack-face material per material group, with the crack's friction
    clone_of = {}
    for g in np.unique(groups[face]):
        clone_of[int(g)] = len(body.materials)
        clone = mats[g].with_(friction=body.crack_friction)
        body.materials.append(clone)
        body.crack_clones.append((clone, mats[g]))
    lut = np.arange(len(body.materials), dtype=np.int32)
    for g, c in clone_of.items():
        lut[g] = c
    tri_material[face] = lut[groups[face]]


def split_body(body, joint_sets: list, where: str) -> None:
    """(Re)compute ``body``'s split mesh, joints and per-joint properties from its selections.

    Sets ``mesh``, ``origin_triangles``, ``joint_nodes``, ``joint_tris``, ``joint_prop`` (k, 6),
    ``joint_set`` (k,), ``tri_bonded`` (m,), ``tri_material`` (crack faces get the crack
    material when ``crack_friction`` is given), ``fracture`` (has joints) and ``self_contact``.
    """
    src = body.source_mesh
    table = body.edge_table
    u, v = table[0], table[1]
    groups = body.tri_group
    joint_mask = body.fracture_mask.copy()
    set_of_edge = np.zeros(len(u), np.int32)              # 0: the body's own joints ("default")
    for set_index, mask in body.joint_set_masks:
        joint_mask |= mask
        set_of_edge[mask] = set_index
    crack = body.crack_mask
    joint_mask &= ~crack                                  # a crack edge carries no joint
    cut = joint_mask | crack
    body.crack_count = int(crack.sum())
    m = src.triangle_count
    tri_material = groups.astype(np.int32).copy()
    if not cut.any():
        body.mesh, body.origin_triangles = src, None
        body.joint_nodes = body.joint_tris = None
        body.joint_prop, body.joint_set = np.zeros((0, 6)), np.zeros(0, np.int32)
        body.tri_bonded = np.zeros(m, bool)
        body.fracture = False
        body.tri_material = tri_material
        del body.materials[body.group_count:]
        body.crack_clones = []
        body.self_contact = body.self_contact_requested
        return
    mesh, origin, split, jn, jt = split_mesh(src, cut, table)
    joints = joint_mask & split
    unsplit = int((joint_mask & ~split).sum())
    if unsplit:
        warnings.warn(f"{where}: {unsplit} selected joint edge(s) are not split (both their ends are tips "
                      f"inside the body) and carry no joint", RuntimeWarning, stacklevel=4)
    prop = _joint_properties(body, joints, set_of_edge, joint_sets, where)
    # a crack is damage from the start: triangles at a crack node are never "bonded" (contact
    # with their corner neighbours is evaluated from the first step, sim.topology.fan_links)
    crack_nodes = np.zeros(src.point_count, bool)
    crack_nodes[u[crack]] = True
    crack_nodes[v[crack]] = True
    bonded = ~crack_nodes[np.asarray(src.triangles)].any(axis=1)
    _crack_face_materials(body, crack, tri_material)
    body.mesh = mesh
    body.origin_triangles = origin
    body.joint_nodes = jn[joints]
    body.joint_tris = jt[joints]
    body.joint_prop = prop[joints]
    body.joint_set = set_of_edge[joints]
    body.tri_bonded = bonded
    body.tri_material = tri_material
    body.fracture = bool(joints.any())
    body.self_contact = True


def resolve(body, selector, where: str) -> np.ndarray:
    """Mask over ``body``'s interior edges selected by ``selector`` (see mesh.split)."""
    from .mesh.split import select_interior_edges
    return select_interior_edges(body.source_mesh, selector, where, body.edge_table, body.tri_group)

"""The records a scene is made of: :class:`Body`, :class:`Curve` (load curves), and the
boundary conditions, loads, initial stress, fluid and heat that :class:`~taichi_fdem.scene.Scene`
collects until :meth:`~taichi_fdem.scene.Scene.build`, with the argument checks they share.

:mod:`taichi_fdem.scene` re-exports every name of this module: checkpoints written by earlier
versions pickle these classes under ``taichi_fdem.scene``.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from .material import Fluid, Material, check_finite
from .mesh import TriMesh
from .mesh.split import explode

__all__ = ["Body", "Curve", "QUASI_STATIC_ALPHA", "quasi_static_alpha", "explode_for_fracture"]


def _vec2(value, name: str, where: str) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=np.float64).reshape(2)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: {name} must be a pair of numbers (x, y), got {value!r}") from None
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{where}: {name} must be finite, got {value!r}")
    return v


def _finite(value, name: str, where: str) -> float:
    return check_finite(name, value, where)


#: coefficient α of the local damping of ``build(quasi_static=True)`` (Itasca's default 0.7)
QUASI_STATIC_ALPHA = 0.7


def quasi_static_alpha(value) -> float:
    """α of ``build(quasi_static=value)``: 0 (off) for False/None, 0.7 for True, else in (0, 1)."""
    if value is None or value is False:
        return 0.0
    if value is True:
        return QUASI_STATIC_ALPHA
    a = _finite(value, "quasi_static", "Scene.build")
    if not (0.0 <= a < 1.0):
        raise ValueError(f"Scene.build: quasi_static must be True, False or a coefficient in (0, 1), got {value!r}")
    return a


@dataclass
class Body:
    """A body of a scene: a handle to pass to the Simulation's per-body accessors.

    ``nodes`` and ``triangles`` are the index ranges of the body in the global arrays.
    ``mesh`` is the mesh the solver uses (split along joints and cracks); ``source_mesh`` the
    placed mesh before splitting.  ``materials`` lists the body's materials (several with
    ``add_body(..., groups=)``), ``tri_material`` the index of each triangle's.
    """

    index: int
    name: str
    mesh: TriMesh              # placed (translated / rotated) mesh, split along joints and cracks, in m
    material: Material
    velocity: np.ndarray       # (2,) initial translation velocity [m/s]
    angular_velocity: float    # initial spin about the centroid [rad/s]
    fixed: bool = False
    prescribed_velocity: Optional[np.ndarray] = None
    self_contact: bool = False
    node_start: int = 0
    tri_start: int = 0
    fracture: bool = False     # the body has cohesive joints
    joint_nodes: Optional[np.ndarray] = None   # (k, 4) local node indices (j0, j1, j2, j3), §7.1
    joint_tris: Optional[np.ndarray] = None    # (k, 2) local triangles (A, B) of each joint
    origin_triangles: Optional[np.ndarray] = None  # (m, 3) node indices of source_mesh (when split)
    velocity_curve: Optional["Curve"] = None   # multiplies prescribed_velocity
    # ---- discontinuities (docs/theory/discontinuities.md §13; filled by taichi_fdem.discontinuity.split_body) ----
    source_mesh: Optional[TriMesh] = None
    materials: Optional[list] = None           # the body's materials (groups, then crack faces)
    group_count: int = 1
    tri_group: Optional[np.ndarray] = None     # (m,) material group of each triangle
    tri_material: Optional[np.ndarray] = None  # (m,) index into materials
    group_labels: Optional[list] = None
    edge_table: Optional[tuple] = None         # interior edges of source_mesh (mesh.split)
    fracture_mask: Optional[np.ndarray] = None
    crack_mask: Optional[np.ndarray] = None
    joint_set_masks: Optional[list] = None     # [(joint-set index, edge mask)]
    joint_prop: Optional[np.ndarray] = None    # (k, 6) f_t, c, tan φ, G_I, G_II, p_f per joint
    joint_set: Optional[np.ndarray] = None     # (k,) joint-set index (0: the body's own joints)
    tri_bonded: Optional[np.ndarray] = None    # (m,) starts intact (no crack node)
    crack_friction: Optional[float] = None
    crack_count: int = 0
    crack_clones: Optional[list] = None        # [(crack-face material, parent material)]
    strength: object = None
    self_contact_requested: bool = False

    @property
    def nodes(self) -> slice:
        return slice(self.node_start, self.node_start + self.mesh.point_count)

    @property
    def triangles(self) -> slice:
        return slice(self.tri_start, self.tri_start + self.mesh.triangle_count)

    @property
    def joint_count(self) -> int:
        return 0 if self.joint_nodes is None else len(self.joint_nodes)

    def __setstate__(self, state):
        # checkpoints written before discontinuities (format 2) lack the new fields
        self.__dict__.update(state)
        for f in dataclasses.fields(self):
            if f.name not in self.__dict__:
                self.__dict__[f.name] = f.default
        if self.materials is None:
            self.materials = [self.material]
        if self.tri_material is None:
            self.tri_material = np.zeros(self.mesh.triangle_count, np.int32)
        if self.tri_bonded is None:
            self.tri_bonded = np.full(self.mesh.triangle_count, bool(self.fracture))
        if self.joint_prop is None and self.fracture:
            self.joint_prop = np.tile(np.asarray(self.material.joint_properties(), float), (len(self.joint_nodes), 1))
            self.joint_set = np.zeros(len(self.joint_nodes), np.int32)

    def __repr__(self):
        extra = ""
        if self.fracture:
            extra += f", joints={self.joint_count}"
        if self.crack_count:
            extra += f", crack edges={self.crack_count}"
        return (f"Body({self.index}, {self.name!r}, nodes={self.mesh.point_count}, "
                f"triangles={self.mesh.triangle_count}{extra}{', fixed' if self.fixed else ''})")


def explode_for_fracture(mesh: TriMesh):
    """Private nodes per triangle and a 4-node joint on every interior edge (docs/theory/joints.md §7.1).

    Returns (exploded mesh, joint_nodes (k, 4), joint_tris (k, 2)): triangle t of the exploded
    mesh has nodes 3t, 3t+1, 3t+2 (copies of the original, same order); for an interior edge
    u→v of triangle A (its counter-clockwise order) shared with B, the joint is
    (A's u, A's v, B's v, B's u).  The special case of :func:`taichi_fdem.mesh.split.split_mesh`
    with every interior edge selected.
    """
    return explode(mesh)


class Curve:
    """A load curve: a piecewise-linear, dimensionless amplitude A(t), constant past its ends.

    ``Curve(times, values)``: times [s] strictly increasing, values dimensionless, both finite
    and of equal length (at least one point).  A curve multiplies loads
    (``scene.apply_pressure(..., curve=)`` and the like) and prescribed velocities
    (``fix_nodes(..., curve=)``, ``add_body(..., velocity_curve=)``); the kernels evaluate it
    every step (forces at t_n, prescribed velocities at t_n + Δt/2).  ``curve(t)`` evaluates it
    on the host (``numpy.interp``).  ``Curve.ramp(t_ramp)`` rises linearly from 0 to 1 over
    ``t_ramp`` seconds and holds.
    """

    def __init__(self, times, values, name: str | None = None):
        try:
            t = np.asarray(times, dtype=np.float64).reshape(-1)
            v = np.asarray(values, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            raise ValueError(f"Curve: times and values must be sequences of numbers, got {times!r}, {values!r}") \
                from None
        if len(t) == 0 or len(t) != len(v):
            raise ValueError(f"Curve: times and values must have the same length >= 1, got {len(t)} and {len(v)}")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
            raise ValueError("Curve: times and values must be finite")
        if np.any(np.diff(t) <= 0):
            raise ValueError(f"Curve: times must be strictly increasing (sorted, no repeats), got {t.tolist()}")
        self.times, self.values = t, v
        self.name = name

    @classmethod
    def ramp(cls, t_ramp: float, t_start: float = 0.0, name: str | None = None) -> "Curve":
        """0 until ``t_start``, rising linearly to 1 over ``t_ramp`` seconds, then 1."""
        t_ramp = _finite(t_ramp, "t_ramp", "Curve.ramp")
        if t_ramp <= 0:
            raise ValueError(f"Curve.ramp: t_ramp must be > 0 s, got {t_ramp}")
        t0 = _finite(t_start, "t_start", "Curve.ramp")
        return cls([t0, t0 + t_ramp], [0.0, 1.0], name=name)

    def __call__(self, t):
        return np.interp(t, self.times, self.values)

    def __eq__(self, other):
        return (isinstance(other, Curve) and self.name == other.name and np.array_equal(self.times, other.times)
                and np.array_equal(self.values, other.values))

    __hash__ = object.__hash__

    def __repr__(self):
        return f"Curve({len(self.times)} points, t = {self.times[0]:g}…{self.times[-1]:g} s)"


def _curve(curve, where: str):
    if curve is not None and not isinstance(curve, Curve):
        raise TypeError(f"{where}: curve must be a taichi_fdem.Curve or None, got {type(curve).__name__}")
    return curve


def _body_motion(velocity, angular_velocity, fixed, prescribed_velocity, velocity_curve, where: str):
    """(initial velocity (2,) [m/s], initial spin [rad/s], prescribed velocity (2,) [m/s] or None)
    of :meth:`Scene.add_body`'s arguments; ValueError (TypeError for a curve that is not a
    :class:`Curve`) naming a wrong one, a body both fixed and prescribed, or a velocity curve
    without a prescribed velocity."""
    v = _vec2(velocity, "velocity", where)
    w = _finite(angular_velocity, "angular_velocity", where)
    pv = None
    if prescribed_velocity is not None:
        if fixed:
            raise ValueError(f"{where}: give either fixed=True or prescribed_velocity, not both")
        pv = _vec2(prescribed_velocity, "prescribed_velocity", where)
    if _curve(velocity_curve, where) is not None and pv is None:
        raise ValueError(f"{where}: velocity_curve needs a prescribed_velocity to multiply")
    return v, w, pv


@dataclass
class _NodeConstraint:
    where: Callable
    body: Optional[Body]
    velocity: tuple
    curve: Optional[Curve] = None


@dataclass
class _Load:
    """A load of the scene (``kind``: "pressure", "traction", "force" or "absorbing"); ``where``
    selects nodes on their initial coordinates (an edge when both its nodes are selected)."""
    kind: str
    where: Callable
    body: Optional[Body]
    value: np.ndarray
    curve: Optional[Curve] = None


@dataclass
class _InitialStress:
    body: Optional[Body]
    stress: np.ndarray          # (σxx, σyy, σxy) at y = y_ref [Pa]
    gradient: np.ndarray        # d(σxx, σyy, σxy)/dy [Pa/m]
    y_ref: float


@dataclass
class _FluidSpec:
    """The fluid of a scene (:meth:`Scene.set_fluid`)."""
    fluid: Fluid
    aperture_min: float
    aperture_max: Optional[float]
    initial_pressure: float
    conduct: str


@dataclass
class _HeatSpec:
    """A thermal boundary condition of the scene (:meth:`Scene.heat`): exactly one of
    temperature [K] and flux [W/m²]."""
    where: Callable
    body: Optional[Body]
    temperature: Optional[float]
    flux: Optional[float]
    curve: Optional[Curve] = None


@dataclass
class _Injection:
    """A source of the fracture network (:meth:`Scene.inject`): exactly one of rate, pressure."""
    where: Callable
    rate: Optional[float]
    pressure: Optional[float]
    curve: object = None

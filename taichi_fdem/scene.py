"""Scene description: bodies (mesh + material + placement), boundary conditions, settings.

The builder layer, on top of the simulation: a scene is pure Python and NumPy data, and
:meth:`Scene.build` turns it into a :class:`~taichi_fdem.simulation.Simulation` (which computes
the model, :mod:`taichi_fdem.model`, the one place where arrays are allocated).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from .material import Material, check_finite
from .mesh import TriMesh
from .simulation import Simulation


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


@dataclass
class Body:
    """A body of a scene: a handle to pass to the Simulation's per-body accessors.

    ``nodes`` and ``triangles`` are the index ranges of the body in the global arrays.
    """

    index: int
    name: str
    mesh: TriMesh              # placed (translated / rotated) mesh, positions in m
    material: Material
    velocity: np.ndarray       # (2,) initial translation velocity [m/s]
    angular_velocity: float    # initial spin about the centroid [rad/s]
    fixed: bool = False
    prescribed_velocity: Optional[np.ndarray] = None
    self_contact: bool = False
    node_start: int = 0
    tri_start: int = 0
    fracture: bool = False
    joint_nodes: Optional[np.ndarray] = None   # (k, 4) local node indices (j0, j1, j2, j3), §7.1
    joint_tris: Optional[np.ndarray] = None    # (k, 2) local triangles (A, B) of each joint
    origin_triangles: Optional[np.ndarray] = None  # (m, 3) node indices before explode_for_fracture

    @property
    def nodes(self) -> slice:
        return slice(self.node_start, self.node_start + self.mesh.point_count)

    @property
    def triangles(self) -> slice:
        return slice(self.tri_start, self.tri_start + self.mesh.triangle_count)

    def __repr__(self):
        return (f"Body({self.index}, {self.name!r}, nodes={self.mesh.point_count}, "
                f"triangles={self.mesh.triangle_count}{', fixed' if self.fixed else ''})")


def explode_for_fracture(mesh: TriMesh):
    """Private nodes per triangle and a 4-node joint on every interior edge (FDEM_SPEC §7.1).

    Returns (exploded mesh, joint_nodes (k, 4), joint_tris (k, 2)): triangle t of the exploded
    mesh has nodes 3t, 3t+1, 3t+2 (copies of the original, same order); for an interior edge
    u→v of triangle A (its counter-clockwise order) shared with B, the joint is
    (A's u, A's v, B's v, B's u).
    """
    tri = mesh.triangles.astype(np.int64)
    m = len(tri)
    points = mesh.points[tri].reshape(-1, 2)
    exploded = TriMesh(points, np.arange(3 * m, dtype=np.int64).reshape(m, 3))
    t = np.repeat(np.arange(m), 3)
    k = np.tile(np.arange(3), m)
    u = tri[t, k]
    v = tri[t, (k + 1) % 3]
    key = np.minimum(u, v) * (tri.max() + 1) + np.maximum(u, v)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    first = np.nonzero(ks[:-1] == ks[1:])[0]        # interior edges: two consecutive entries
    ia, ib = order[first], order[first + 1]
    tA, kA, tB, kB = t[ia], k[ia], t[ib], k[ib]
    j0 = 3 * tA + kA
    j1 = 3 * tA + (kA + 1) % 3
    j2 = 3 * tB + kB                                 # B runs v→u: its local k_B is v
    j3 = 3 * tB + (kB + 1) % 3
    joint_nodes = np.stack([j0, j1, j2, j3], axis=1).astype(np.int32)
    joint_tris = np.stack([tA, tB], axis=1).astype(np.int32)
    return exploded, joint_nodes, joint_tris


@dataclass
class _NodeConstraint:
    where: Callable
    body: Optional[Body]
    velocity: tuple


class Scene:
    """A 2D FDEM scene.

    Parameters
    ----------
    gravity : (g_x, g_y) [m/s²], default (0, −9.81).
    plane : "strain" (default) or "stress": the plane problem the triangles model.
    thickness : out-of-plane thickness t [m] (default 1).  The solver works per unit
        thickness; masses, forces and energies reported by the Simulation are multiplied by t.
    """

    def __init__(self, gravity=(0.0, -9.81), plane: str = "strain", thickness: float = 1.0):
        self.gravity = _vec2(gravity, "gravity", "Scene")
        if plane not in ("strain", "stress"):
            raise ValueError(f"Scene: plane must be 'strain' or 'stress', got {plane!r}")
        self.plane = plane
        self.thickness = _finite(thickness, "thickness", "Scene")
        if self.thickness <= 0:
            raise ValueError(f"Scene: thickness must be > 0 m, got {thickness}")
        self.bodies: list[Body] = []
        self._constraints: list[_NodeConstraint] = []
        self._interactions: dict = {}
        self._node_count = 0
        self._tri_count = 0

    # ------------------------------------------------------------------------------------------
    def add_body(self, mesh: TriMesh, material: Material, position=None, velocity=(0.0, 0.0),
                 angular_velocity: float = 0.0, rotation: float = 0.0, fixed: bool = False,
                 prescribed_velocity=None, self_contact: bool = False, fracture: bool = False,
                 name: str | None = None) -> Body:
        """Add a deformable body.

        Parameters
        ----------
        mesh : :class:`~taichi_fdem.mesh.TriMesh` (coordinates in m).
        material : :class:`~taichi_fdem.material.Material`.
        position : where the mesh's (area) centroid is placed [m]; None keeps the mesh's coordinates.
        velocity : initial velocity [m/s]; angular_velocity : initial spin about the centroid [rad/s].
        rotation : rotation [rad, counter-clockwise] applied about the centroid before placing.
        fixed : every node held at zero velocity (walls, floors).
        prescribed_velocity : (v_x, v_y) [m/s]: every node moves at this velocity (platens).
        self_contact : let the body's own non-adjacent triangles contact each other (folding).
        fracture : the body may crack: every triangle gets private nodes and every interior edge
            a cohesive joint (FDEM_SPEC §7.1); needs ``material.tensile_strength`` and
            ``material.fracture_energy``.  Implies self-contact (fragments touch each other).
        """
        where = f"Scene.add_body({name or 'body ' + str(len(self.bodies))})"
        if not isinstance(mesh, TriMesh):
            raise TypeError(f"{where}: mesh must be a taichi_fdem.mesh.TriMesh, got {type(mesh).__name__}")
        if not isinstance(material, Material):
            raise TypeError(f"{where}: material must be a taichi_fdem.Material, got {type(material).__name__}")
        rotation = _finite(rotation, "rotation", where)
        if rotation != 0.0:
            mesh = mesh.rotated(rotation)
        if position is not None:
            mesh = mesh.translated(_vec2(position, "position", where) - mesh.centroid)
        v = _vec2(velocity, "velocity", where)
        w = _finite(angular_velocity, "angular_velocity", where)
        pv = None
        if prescribed_velocity is not None:
            if fixed:
                raise ValueError(f"{where}: give either fixed=True or prescribed_velocity, not both")
            pv = _vec2(prescribed_velocity, "prescribed_velocity", where)
        joint_nodes = joint_tris = origin = None
        if fracture:
            material.joint_properties()            # validates the fracture parameters early
            origin = np.asarray(mesh.triangles, dtype=np.int32).copy()
            mesh, joint_nodes, joint_tris = explode_for_fracture(mesh)
            self_contact = True
        body = Body(index=len(self.bodies), name=name or f"body{len(self.bodies)}", mesh=mesh,
                    material=material, velocity=v, angular_velocity=w, fixed=bool(fixed),
                    prescribed_velocity=pv, self_contact=bool(self_contact),
                    node_start=self._node_count, tri_start=self._tri_count, fracture=bool(fracture),
                    joint_nodes=joint_nodes, joint_tris=joint_tris, origin_triangles=origin)
        self.bodies.append(body)
        self._node_count += mesh.point_count
        self._tri_count += mesh.triangle_count
        return body

    def fix_nodes(self, where: Callable, body: Body | None = None, velocity=(0.0, 0.0)) -> None:
        """Prescribe the velocity of the nodes selected by a predicate on their initial position.

        ``where(x, y)`` receives arrays of initial coordinates [m] and returns a boolean array.
        ``velocity`` = (v_x, v_y) [m/s]; a component given as None stays free (a roller).
        Restricted to ``body`` when given.  At build, a predicate that selects no node is an error.
        """
        if not callable(where):
            raise TypeError("Scene.fix_nodes: where must be a callable where(x, y) -> bool array")
        if body is not None and (not isinstance(body, Body) or body not in self.bodies):
            raise ValueError("Scene.fix_nodes: body must be a Body of this scene")
        try:
            vel = tuple(None if c is None else float(c) for c in velocity)
        except (TypeError, ValueError):
            raise ValueError(f"Scene.fix_nodes: velocity must be (v_x, v_y) with numbers or None, got {velocity!r}") from None
        if len(vel) != 2 or any(c is not None and not math.isfinite(c) for c in vel):
            raise ValueError(f"Scene.fix_nodes: velocity must be two finite numbers or None, got {velocity!r}")
        if vel == (None, None):
            raise ValueError("Scene.fix_nodes: velocity (None, None) constrains nothing")
        self._constraints.append(_NodeConstraint(where, body, vel))

    def set_interaction(self, material_a: Material, material_b: Material, *, friction: float | None = None,
                        penalty: float | None = None, tangential_penalty: float | None = None,
                        contact_damping: float | None = None) -> None:
        """Override the contact properties of the pair (material_a, material_b).

        By default a couple uses the smaller penalty of its two materials (as Y2D), the smaller
        friction coefficient, the smaller tangential penalty and the smaller damping ratio.
        """
        props = {}
        for key, value, lo, hi in (("friction", friction, 0.0, math.inf), ("penalty", penalty, 0.0, math.inf),
                                   ("tangential_penalty", tangential_penalty, 0.0, math.inf),
                                   ("contact_damping", contact_damping, 0.0, 1.0)):
            if value is None:
                continue
            v = _finite(value, key, "Scene.set_interaction")
            if not (lo <= v <= hi) or (key in ("penalty", "tangential_penalty") and v <= 0):
                raise ValueError(f"Scene.set_interaction: {key}={value} is out of range")
            props[key] = v
        self._interactions[(id(material_a), id(material_b))] = props
        self._interactions[(id(material_b), id(material_a))] = props

    # ------------------------------------------------------------------------------------------
    @property
    def node_count(self) -> int:
        return self._node_count

    @property
    def tri_count(self) -> int:
        return self._tri_count

    def build(self, dt: float | None = None, safety: float = 0.2, force_dt: bool = False,
              buffer: float | None = None, strategy: str = "auto", check_overlap: bool = True,
              speed_limit: float | None = None):
        """Allocate everything and return a ready :class:`~taichi_fdem.simulation.Simulation`.

        Parameters
        ----------
        dt : time step [s].  None (default): ``safety`` × the book's estimate ``sim.dt_estimate``
            (FDEM_SPEC §6.2: elements h/c_p with damping, contact h√(ρ/p), joints L√(ρ/p_f)).
            A dt above the stable limit ``sim.dt_limit`` (the same with contact and joint terms
            × 0.4 and damping rated on the element size, as measured in the stress tests) raises
            ValueError unless ``force_dt=True``.
        safety : fraction of the estimate used when dt is None (default 0.2, which keeps a margin
            of ≥ 2 on the measured limit; at most dt_limit/dt_estimate unless force_dt).
        buffer : contact buffer b [m] (§4.1); default ¼ of the mean edge length of the
            contact triangles.
        strategy : "auto", "serial" (one launch runs many steps: small scenes) or "parallel"
            (one launch per step, parallel loops: large scenes).
        check_overlap : warn when bodies overlap at the start.
        speed_limit : a node speed [m/s] above which the run stops as unstable (default: 2× the
            largest P-wave speed of the materials, or 10× the fastest initial speed if larger).
        """
        return Simulation(self, dt=dt, safety=safety, force_dt=force_dt, buffer=buffer, strategy=strategy,
                          check_overlap=check_overlap, speed_limit=speed_limit)

"""Scene description: bodies (mesh + material + placement), boundary conditions, settings.

The builder layer, on top of the simulation: a scene is pure Python and NumPy data, and
:meth:`Scene.build` turns it into a :class:`~taichi_fdem.sim.simulation.Simulation` (which computes
the model, :mod:`taichi_fdem.sim.model`, the one place where arrays are allocated).
"""
from __future__ import annotations

import math
from typing import Callable, Optional

import numpy as np

from .material import Fluid, Material, check_finite
from .discontinuity import JointSet, bedding_planes, check_strength, resolve, split_body
from .mesh import TriMesh
from .mesh.split import interior_edge_table
from .engine.joints import HANDOVER_DAMAGE
from .sim.simulation import Simulation
# The records of a scene (records.py), importable from here as well: checkpoints of earlier
# versions pickle them under this module's name.
from .records import (QUASI_STATIC_ALPHA, Body, Curve, _body_motion, _curve, _finite, _FluidSpec,  # noqa: F401
                      _HeatSpec, _InitialStress, _Injection, _Load, _NodeConstraint, _vec2, explode_for_fracture,
                      quasi_static_alpha)


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
        self._loads: list[_Load] = []
        self._initial_stress: list[_InitialStress] = []
        self._fluid: Optional[_FluidSpec] = None
        self._injections: list[_Injection] = []
        self._temperature = None
        self._heat: list[_HeatSpec] = []
        self.joint_sets: list[JointSet] = []
        self._node_count = 0
        self._tri_count = 0

    # ------------------------------------------------------------------------------------------
    def add_body(self, mesh: TriMesh, material, position=None, velocity=(0.0, 0.0),
                 angular_velocity: float = 0.0, rotation: float = 0.0, fixed: bool = False,
                 prescribed_velocity=None, self_contact: bool = False, fracture=False,
                 name: str | None = None, velocity_curve: Curve | None = None, cracks=None,
                 crack_friction: float | None = None, strength=None, groups=None) -> Body:
        """Add a deformable body.

        Parameters
        ----------
        mesh : :class:`~taichi_fdem.mesh.TriMesh` (coordinates in m).
        material : :class:`~taichi_fdem.material.Material`; or, with ``groups``, a dict mapping
            each material-group label to its Material (one body of several materials: a dyke,
            grains).
        groups : (m,) label of each triangle's material group (e.g. the ``labels`` of
            :func:`taichi_fdem.mesh.load_tagged`), with ``material`` a dict of those labels.
        position : where the mesh's (area) centroid is placed [m]; None keeps the mesh's coordinates.
        velocity : initial velocity [m/s]; angular_velocity : initial spin about the centroid [rad/s].
        rotation : rotation [rad, counter-clockwise] applied about the centroid before placing.
        fixed : every node held at zero velocity (walls, floors).
        prescribed_velocity : (v_x, v_y) [m/s]: every node moves at this velocity (platens).
        velocity_curve : a :class:`~taichi_fdem.records.Curve` that multiplies
            ``prescribed_velocity`` (a ramp, a cycle); its reaction is ``sim.reaction(body)``.
        self_contact : let the body's own non-adjacent triangles contact each other (folding).
        fracture : where the body may crack: cohesive joints (docs/theory/joints.md §7) go on the selected
            interior edges, and the mesh is split there only (§13.1).  An edge selector:
            ``True`` (every interior edge: every triangle gets private nodes, §7.1),
            ``False`` (none), a callable ``where(x, y)`` evaluated at the interior-edge
            midpoints (placed coordinates [m]), an (k, 2) integer array of node pairs of
            ``mesh`` (an edge group), a :class:`~taichi_fdem.mesh.Polyline` or line group
            (edges lying along it), ``"interfaces"`` (edges between material groups) or a list
            of these (their union).  Needs ``tensile_strength`` and ``fracture_energy`` on the
            material; the joint of an interface takes the weaker material (lower f_t).
            Implies self-contact (fragments touch each other).
        cracks : pre-existing open discontinuities along the selected interior edges (same
            selectors): the mesh is split there with no joint, so the two faces interact only by
            contact and friction (§2, §5).  A crack ending inside the body keeps one shared node at
            its tip.  Implies self-contact.
        crack_friction : friction coefficient of the crack faces (default: the material's
            ``friction``).  The triangles along a crack get a copy of their material with this
            friction; their contacts with each other and with their own material use it,
            with other materials the usual pair rule.
        strength : ``fdem.Weibull(m, seed=)`` or ``fdem.NormalStrength(cov, seed=)``: a per-joint
            random factor on the tensile strength and cohesion of this body's joints (§13.3).
            A material's ``Bedding``: its joints' strength by their angle to it, weak planes (docs/guide/anisotropy.md).
        """
        where = f"Scene.add_body({name or 'body ' + str(len(self.bodies))})"
        if not isinstance(mesh, TriMesh):
            raise TypeError(f"{where}: mesh must be a taichi_fdem.mesh.TriMesh, got {type(mesh).__name__}")
        materials, tri_group, labels = self._material_groups(material, groups, mesh, where)
        rotation = _finite(rotation, "rotation", where)
        if rotation != 0.0:
            mesh = mesh.rotated(rotation)
        if position is not None:
            mesh = mesh.translated(_vec2(position, "position", where) - mesh.centroid)
        v, w, pv = _body_motion(velocity, angular_velocity, fixed, prescribed_velocity, velocity_curve, where)
        if crack_friction is not None:
            crack_friction = _finite(crack_friction, "crack_friction", where)
            if crack_friction < 0:
                raise ValueError(f"{where}: crack_friction must be >= 0, got {crack_friction}")
        body = Body(index=len(self.bodies), name=name or f"body{len(self.bodies)}", mesh=mesh,
                    material=materials[0], velocity=v, angular_velocity=w, fixed=bool(fixed),
                    prescribed_velocity=pv, self_contact=bool(self_contact),
                    node_start=self._node_count, tri_start=self._tri_count,
                    velocity_curve=velocity_curve, source_mesh=mesh, materials=list(materials),
                    group_count=len(materials), tri_group=tri_group, group_labels=labels,
                    edge_table=interior_edge_table(mesh.triangles), crack_friction=crack_friction,
                    strength=check_strength(strength, where), self_contact_requested=bool(self_contact),
                    joint_set_masks=[])
        body.fracture_mask = resolve(body, fracture, f"{where}: fracture")
        body.crack_mask = resolve(body, cracks, f"{where}: cracks")
        if cracks is not None and cracks is not False and not body.crack_mask.any():
            raise ValueError(f"{where}: cracks= selects no interior edge of the mesh (a Polyline must run "
                             f"along mesh edges: build the mesh with fdem.mesh.polygon(..., lines=[...]))")
        if fracture is not True and fracture is not False and fracture is not None and not body.fracture_mask.any():
            raise ValueError(f"{where}: fracture= selects no interior edge of the mesh")
        split_body(body, self.joint_sets, where)
        self.bodies.append(body)
        self._add_bedding_planes(body, where)
        return body

    def _add_bedding_planes(self, body, where: str) -> None:
        """Renumber the bodies, then add the weak bedding planes of ``body``'s ``Bedding(spacing=s)``: the
        mesh's edges along the planes every ``s`` [m] (one through the origin; ValueError when the mesh has no
        edges there) become a joint set "bedding" (or "bedding (<body name>)" after the first) with exactly
        the bedding's strength, spread by the body's ``strength`` (discontinuity.bedding_planes)."""
        self._renumber()
        planes = bedding_planes(body, where)
        if planes is None:
            return
        lines, material = planes
        name = "bedding" if "bedding" not in self.joint_set_names else f"bedding ({body.name})"
        self.add_joint_set(name, lines, material, body=body, strength=body.strength)

    def _material_groups(self, material, groups, mesh, where):
        """(materials, tri_group (m,) int32, labels) of add_body's material / groups."""
        m = mesh.triangle_count
        if groups is None:
            if not isinstance(material, Material):
                raise TypeError(f"{where}: material must be a taichi_fdem.Material (or a dict of Materials with "
                                f"groups=), got {type(material).__name__}")
            return [material], np.zeros(m, np.int32), None
        g = np.asarray(groups)
        if g.shape != (m,):
            raise ValueError(f"{where}: groups must give one label per triangle ({m},), got shape {g.shape}")
        if not isinstance(material, dict):
            raise TypeError(f"{where}: with groups=, material must be a dict mapping each group label to a Material")
        try:
            uniq, tri_group = np.unique(g, return_inverse=True)
        except TypeError:
            raise ValueError(f"{where}: groups labels must be all numbers or all strings") from None
        labels = uniq.tolist()
        missing = [lb for lb in labels if lb not in material]
        if missing:
            raise ValueError(f"{where}: no material for group(s) {missing} (material has {list(material)})")
        for lb in labels:
            if not isinstance(material[lb], Material):
                raise TypeError(f"{where}: material[{lb!r}] must be a Material, got {type(material[lb]).__name__}")
        return [material[lb] for lb in labels], np.asarray(tri_group, np.int32), labels

    def _renumber(self) -> None:
        """Node and triangle offsets of every body (splitting changes node counts)."""
        n = t = 0
        for b in self.bodies:
            b.node_start, b.tri_start = n, t
            n += b.mesh.point_count
            t += b.mesh.triangle_count
        self._node_count, self._tri_count = n, t

    @property
    def joint_set_names(self) -> list:
        """Names of the joint sets: index 0 is "default" (each body's own joints from ``fracture=``)."""
        return ["default"] + [js.name for js in self.joint_sets]

    def add_joint_set(self, name: str, selector, material: Material, body: Body | None = None,
                      strength=None) -> None:
        """A set of joints with its own properties (docs/theory/discontinuities.md §13.2).

        Cohesive joints go on the interior edges that ``selector`` picks (any edge selector of
        :meth:`add_body`'s ``fracture``: a callable ``where(x, y)`` on edge midpoints, node
        pairs, a :class:`~taichi_fdem.mesh.Polyline` or line group, ``"interfaces"`` (grain
        boundaries, the contact of a dyke), a list), in ``body`` or in every body.  Their
        properties come from ``material`` (its ``tensile_strength``, ``cohesion``,
        ``friction_angle``, ``fracture_energy``, ``fracture_energy_shear``, ``joint_penalty``;
        its elastic constants are not used); ``strength`` spreads them (:class:`Weibull`,
        :class:`NormalStrength`).  Joints already there (``fracture=``, an earlier set) take
        the new set's properties; crack edges stay cracks.  The mesh is split along the new
        joints.  Selecting no edge at all is an error.
        """
        where = f"Scene.add_joint_set({name!r})"
        if not isinstance(name, str) or not name:
            raise ValueError(f"{where}: name must be a non-empty string")
        if name in self.joint_set_names:
            raise ValueError(f"{where}: a joint set named {name!r} exists already")
        if not isinstance(material, Material):
            raise TypeError(f"{where}: material must be a taichi_fdem.Material, got {type(material).__name__}")
        material.joint_properties()                       # validates the fracture parameters now
        if body is not None and (not isinstance(body, Body) or body not in self.bodies):
            raise ValueError(f"{where}: body must be a Body of this scene")
        js = JointSet(name, material, check_strength(strength, where))
        index = len(self.joint_sets) + 1
        hits = []
        for b in ([body] if body is not None else self.bodies):
            mask = resolve(b, selector, where)
            if mask.any():
                hits.append((b, mask))
        if not hits:
            raise ValueError(f"{where}: the selector picks no interior edge of "
                             f"{'body ' + repr(body.name) if body is not None else 'any body'}")
        self.joint_sets.append(js)
        for b, mask in hits:
            b.joint_set_masks.append((index, mask))
            split_body(b, self.joint_sets, where)
        self._renumber()

    def fix_nodes(self, where: Callable, body: Body | None = None, velocity=(0.0, 0.0),
                  curve: Curve | None = None) -> None:
        """Prescribe the velocity of the nodes selected by a predicate on their initial position.

        ``where(x, y)`` receives arrays of initial coordinates [m] and returns a boolean array.
        ``velocity`` = (v_x, v_y) [m/s]; a component given as None stays free (a roller).
        ``curve``: a :class:`~taichi_fdem.records.Curve` multiplying the velocity.
        Restricted to ``body`` when given.  At build, a predicate that selects no node is an error.
        The force the constraint exerts is ``sim.reaction(where=..., body=...)``.
        """
        _curve(curve, "Scene.fix_nodes")
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
        self._constraints.append(_NodeConstraint(where, body, vel, curve))

    # ---- loads, initial stress and absorbing boundaries (docs/theory/loads.md §12) ------------------------
    def _selector(self, where, body, name: str) -> None:
        if not callable(where):
            raise TypeError(f"Scene.{name}: where must be a callable where(x, y) -> bool array (initial coordinates)")
        if body is not None and (not isinstance(body, Body) or body not in self.bodies):
            raise ValueError(f"Scene.{name}: body must be a Body of this scene")

    def apply_pressure(self, where: Callable, pressure: float, body: Body | None = None,
                       curve: Curve | None = None) -> None:
        """A normal pressure [Pa] on the boundary edges whose two nodes satisfy ``where(x, y)``
        (initial coordinates), restricted to ``body`` when given.

        Positive pushes into the body.  It follows the deformed edge (a follower load): at each
        step the edge i→j of current length L and outward normal n̂ gets f_i = f_j = −A(t) p L n̂/2
        (consistent nodal forces, docs/theory/loads.md §12.1), A the ``curve`` (1 without).  Its work is
        booked in ``sim.energies()["load_work"]``.  Selecting no boundary edge is an error at build.
        """
        self._selector(where, body, "apply_pressure")
        p = _finite(pressure, "pressure", "Scene.apply_pressure")
        self._loads.append(_Load("pressure", where, body, np.array([p]), _curve(curve, "Scene.apply_pressure")))

    def apply_traction(self, where: Callable, traction, body: Body | None = None,
                       curve: Curve | None = None) -> None:
        """A traction (t_x, t_y) [Pa] of fixed direction on the selected boundary edges (a dead load:
        f_i = f_j = A(t) t⃗ L0/2 with L0 the initial edge length, docs/theory/loads.md §12.2).  Selection as
        :meth:`apply_pressure`."""
        self._selector(where, body, "apply_traction")
        t = _vec2(traction, "traction", "Scene.apply_traction")
        self._loads.append(_Load("traction", where, body, t, _curve(curve, "Scene.apply_traction")))

    def apply_force(self, where: Callable, force, body: Body | None = None, curve: Curve | None = None) -> None:
        """A force (F_x, F_y) [N per metre of thickness] at each node selected by ``where(x, y)``
        (initial coordinates), times the ``curve``.  Selecting no node is an error at build."""
        self._selector(where, body, "apply_force")
        f = _vec2(force, "force", "Scene.apply_force")
        self._loads.append(_Load("force", where, body, f, _curve(curve, "Scene.apply_force")))

    def absorbing_boundary(self, where: Callable, body: Body | None = None) -> None:
        """Viscous (Lysmer–Kuhlemeyer) absorbing boundary on the selected boundary edges.

        Dashpots of the edge's material: traction −ρ c_p (v·n̂) n̂ − ρ c_s (v·ŝ) ŝ (c_p the P-wave
        speed of the plane problem, c_s = √(μ/ρ)), lumped L/2 per node (docs/theory/loads.md §12.5).  Exact
        for plane waves at normal incidence.  The work they absorb is booked in
        ``sim.energies()["absorbed"]``.  Selection as :meth:`apply_pressure`.
        """
        self._selector(where, body, "absorbing_boundary")
        self._loads.append(_Load("absorbing", where, body, np.zeros(0)))

    def initial_stress(self, sxx: float, syy: float, sxy: float = 0.0, body: Body | None = None,
                       gradient=None, y_ref: float = 0.0) -> None:
        """An initial (in-situ) stress [Pa, tension positive] of the triangles of ``body`` (all
        bodies when None), carried by the undeformed mesh (docs/theory/loads.md §12.4).

        ``gradient`` = (dσxx/dy, dσyy/dy[, dσxy/dy]) [Pa/m]: the stress then varies linearly with
        height, σ(y) = σ + (y − y_ref)·gradient at each triangle's initial centroid (e.g. a
        lithostatic σyy = ρ g (y − y_surface) has gradient (k ρ g, ρ g) with y_ref = y_surface
        and σ = 0).  The prestress is held as a constant second Piola–Kirchhoff stress S⁰, so
        the Cauchy stress is T_el(F) + F S⁰ Fᵀ / J (objective under rotation).  A balanced start
        needs matching boundary tractions (:meth:`apply_traction`, :meth:`apply_pressure`) or
        rollers; then nothing moves.  A later call overrides earlier ones on the bodies it
        names.

        Fracturing bodies (``fracture=``, joint sets) start at rest too: each intact joint
        carries σ⁰·n̂ at its ends and mid-point, as an initial opening and slip below the peak
        of its own law, which turn with the joint (docs/theory/joints.md §7.11).  The initial
        state damages no joint; the strength counts the initial traction (a joint in initial
        tension σ⁰ fails when its total normal traction reaches f_t, a compressed one has the
        shear strength c − σ⁰ tan φ); a broken joint carries nothing.  ``build()`` raises
        ValueError if the initial traction of a joint point reaches its tensile or shear
        strength.
        """
        where = "Scene.initial_stress"
        if body is not None and (not isinstance(body, Body) or body not in self.bodies):
            raise ValueError(f"{where}: body must be a Body of this scene")
        st = np.array([_finite(sxx, "sxx", where), _finite(syy, "syy", where), _finite(sxy, "sxy", where)])
        g = np.zeros(3)
        if gradient is not None:
            try:
                gv = np.asarray(gradient, dtype=np.float64).reshape(-1)
            except (TypeError, ValueError):
                raise ValueError(f"{where}: gradient must be (dsxx/dy, dsyy/dy[, dsxy/dy]), got {gradient!r}") \
                    from None
            if len(gv) not in (2, 3) or not np.all(np.isfinite(gv)):
                raise ValueError(f"{where}: gradient must be 2 or 3 finite numbers [Pa/m], got {gradient!r}")
            g[: len(gv)] = gv
        self._initial_stress.append(_InitialStress(body, st, g, _finite(y_ref, "y_ref", where)))

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

    def set_fluid(self, fluid: Fluid, aperture_min: float, aperture_max: float | None = None,
                  initial_pressure: float = 0.0, conduct: str = "broken") -> None:
        """Fill the fracture network with a compressible fluid that flows by the cubic law and
        pushes on the fracture faces (hydro-mechanical coupling, :mod:`taichi_fdem.engine.fluid`).

        The network: every pre-existing crack edge (``add_body(cracks=)``) and every joint of a
        fracturing body (``add_body(fracture=)``, ``add_joint_set``) once it conducts.  Fluid
        is stored at the network's nodes, the original mesh vertices on those edges (one node
        where several edges meet), and flows along the edges, q = −w³/(12 μ) ∂p/∂s [m²/s per
        unit thickness].  The hydraulic aperture w is the mean normal opening of an edge's two
        faces, clamped to [aperture_min, aperture_max]; the pressure follows dp = K dV/V from
        the fluid's mass and the node's volume Σ L w / 2, and acts on both faces of every
        conducting edge as a follower pressure.  Edges that start to conduct take their fluid
        from their neighbours (mass is kept).  The network is closed: fluid leaves it only
        through pressure sources (no leak-off into the rock matrix, no outflow where a crack
        meets the body's surface).

        Parameters
        ----------
        fluid : :class:`~taichi_fdem.material.Fluid` (ρ, K, μ).
        aperture_min : residual hydraulic aperture a_min [m], > 0: the aperture of closed or
            compressed faces (it also sets the fluid's stiffness K/a_min per unit area in the
            stable time step).
        aperture_max : largest hydraulic aperture [m] (None: no bound), > aperture_min.
        initial_pressure : pressure [Pa], >= 0, of the fluid in the edges that conduct at the
            start (the crack edges, at the aperture of the rest mesh).
        conduct : which joints conduct: "broken" (default; a joint conducts once it has broken,
            docs/theory/joints.md §7.8) or "damaged" (also once it has softened past its peak
            strength: any stored damage D > 0 at one of its points, §7.5).

        A later call replaces the fluid; the sources (:meth:`inject`) stay.  The scene must
        have cracks or joints (checked at build).  Scenes with a fluid run the parallel
        strategy one step per launch (no team launch).
        """
        where = "Scene.set_fluid"
        if not isinstance(fluid, Fluid):
            raise TypeError(f"{where}: fluid must be a taichi_fdem.Fluid, got {type(fluid).__name__}")
        amin = check_finite("aperture_min", aperture_min, where)
        if amin <= 0:
            raise ValueError(f"{where}: aperture_min must be > 0 m, got {aperture_min}")
        amax = None
        if aperture_max is not None:
            amax = check_finite("aperture_max", aperture_max, where)
            if amax <= amin:
                raise ValueError(f"{where}: aperture_max must be > aperture_min = {amin:g} m, got {aperture_max}")
        p0 = check_finite("initial_pressure", initial_pressure, where)
        if p0 < 0:
            raise ValueError(f"{where}: initial_pressure must be >= 0 Pa, got {initial_pressure}")
        if conduct not in ("broken", "damaged"):
            raise ValueError(f"{where}: conduct must be 'broken' or 'damaged', got {conduct!r}")
        self._fluid = _FluidSpec(fluid, amin, amax, p0, conduct)

    def inject(self, where: Callable, rate: float | None = None, pressure: float | None = None,
               curve: Curve | None = None) -> None:
        """A source of the fracture network on the network nodes selected by ``where(x, y)``
        (their initial coordinates [m]): a crack's centre, a notch, a borehole wall.

        Give exactly one of ``rate``, a volume rate [m²/s per unit thickness], >= 0, into the
        network, shared equally among the selected nodes that conduct (nothing enters while
        none does), or ``pressure``, a pressure [Pa], >= 0, prescribed on the selected nodes
        that conduct (the fluid it adds or takes out, as a source or a drain, is its rate).
        ``curve`` is a :class:`~taichi_fdem.records.Curve` multiplying the rate or the pressure.

        Several calls make several sources, reported in order by ``sim.fluid.injection_rates()``
        (positive into the network); ``sim.fluid.injection_pressure()`` is the pressure at the first.
        Needs :meth:`set_fluid` first.  A predicate that selects no network node is an error at
        build.
        """
        what = "Scene.inject"
        if self._fluid is None:
            raise ValueError(f"{what}: the scene has no fluid; call scene.set_fluid(...) first")
        if not callable(where):
            raise TypeError(f"{what}: where must be a callable where(x, y) -> bool array (initial coordinates)")
        if (rate is None) == (pressure is None):
            raise ValueError(f"{what}: give exactly one of rate [m²/s] or pressure [Pa], got "
                             f"rate={rate!r}, pressure={pressure!r}")
        if rate is not None:
            rate = check_finite("rate", rate, what)
            if rate < 0:
                raise ValueError(f"{what}: rate must be >= 0 m²/s (a drain is a pressure source), got {rate}")
        if pressure is not None:
            pressure = check_finite("pressure", pressure, what)
            if pressure < 0:
                raise ValueError(f"{what}: pressure must be >= 0 Pa, got {pressure}")
        self._injections.append(_Injection(where, rate, pressure, self._check_curve(curve, what)))

    # ---- heat (docs/guide/heat.md, docs/theory/heat.md) ---------------------------------------
    def set_temperature(self, initial) -> None:
        """The initial temperature of every node: a number, or a callable ``initial(x, y)`` of the
        initial coordinates [m] returning a number or an array of one temperature per node.

        Any consistent scale (°C or K): only differences enter the physics.  The initial
        temperature is the stress-free one (thermal strain α(T − T₀)).  Calling it makes the
        scene conduct heat (as :meth:`heat` does); without a call the initial temperature is 0.
        """
        if not callable(initial):
            initial = _finite(initial, "initial", "Scene.set_temperature")
        self._temperature = initial

    def heat(self, where: Callable, body: Body | None = None, temperature: float | None = None,
             flux: float | None = None, curve: Curve | None = None) -> None:
        """A thermal boundary condition on the nodes selected by ``where(x, y)`` (initial
        coordinates, a boolean array), restricted to ``body`` when given; exactly one of:

        * ``temperature`` [K or °C]: the selected nodes are held at T₀ + A(t)(temperature − T₀),
          T₀ a node's initial temperature and A(t) the ``curve`` (1 without one: held at
          ``temperature`` from the start);
        * ``flux`` [W/m²]: a heat flux A(t)·flux into the body through the selected boundary
          edges (both nodes selected), q L/2 to each node of an edge of rest length L.

        A node held by several calls takes the last one.  The heat supplied is booked in
        ``sim.energies()`` (``heat_supplied``); selecting nothing is an error at build.
        """
        self._selector(where, body, "heat")
        if (temperature is None) == (flux is None):
            raise ValueError("Scene.heat: give exactly one of temperature= (a held temperature) and flux= "
                             "(a heat flux [W/m²] into the body)")
        t = None if temperature is None else _finite(temperature, "temperature", "Scene.heat")
        q = None if flux is None else _finite(flux, "flux", "Scene.heat")
        self._heat.append(_HeatSpec(where, body, t, q, _curve(curve, "Scene.heat")))

    @staticmethod
    def _check_curve(curve, where: str):
        return _curve(curve, where)

    # ------------------------------------------------------------------------------------------
    @property
    def node_count(self) -> int:
        return self._node_count

    @property
    def tri_count(self) -> int:
        return self._tri_count

    def build(self, dt: float | None = None, safety: float = 0.2, force_dt: bool = False,
              buffer: float | None = None, strategy: str = "auto", check_overlap: bool = True,
              speed_limit: float | None = None, quasi_static=False, joined_pairs: str = "joint",
              handover_damage: float = HANDOVER_DAMAGE):
        """Allocate everything and return a ready :class:`~taichi_fdem.sim.simulation.Simulation`.

        Parameters
        ----------
        dt : time step [s].  None (default): ``safety`` × the book's estimate ``sim.model.dt_estimate``
            (docs/theory/elements.md §6.2: elements h/c_p with damping, contact h√(ρ/p), joints L√(ρ/p_f)).
            A dt above the stable limit ``sim.model.dt_limit`` (the same with contact and joint terms
            × 0.4 and damping rated on the element size: :mod:`taichi_fdem.sim.timestep`,
            docs/stability.md) raises ValueError unless ``force_dt=True``.
        safety : fraction of the estimate used when dt is None (default 0.2, a margin of ≥ 2
            below the stable limit; at most dt_limit/dt_estimate unless force_dt).
        buffer : contact buffer b [m] (§4.1); default ¼ of the mean edge length of the
            contact triangles.
        strategy : "auto", "serial" (one launch runs many steps on one core: small scenes) or
            "parallel" (forces summed without atomics by several threads: larger scenes, GPUs).
            "auto" (default) is parallel on GPUs, and on the CPU when it has at least 2 threads
            and the scene at least ``AUTO_PARALLEL_ITEMS`` (600) triangles + joints +
            contact couples; serial otherwise (:mod:`taichi_fdem.sim.simulation`).
        check_overlap : warn when bodies overlap at the start.
        speed_limit : a node speed [m/s] above which the run stops as unstable (default: 2× the
            largest P-wave speed of the materials, or 10× the fastest initial speed if larger).
        quasi_static : False (default), True or a coefficient α in (0, 1).  Turns on Cundall's
            local non-viscous damping for reaching static equilibrium: every free node component
            gets −α ``|F|`` sign(v), F the unbalanced force (:mod:`taichi_fdem.engine.integrate`).
            True uses α = 0.7 (:data:`~taichi_fdem.records.QUASI_STATIC_ALPHA`, Itasca's default
            for static problems).  It damps all modes alike and does not resist steady motion; its work is
            booked in ``sim.energies()["local_damping"]``.  Not for impacts or waves.
        joined_pairs : how two triangles of a fracturing body joined along an edge by an
            undamaged joint resist overlap (docs/theory/joints.md §7.10).  "joint" (default): the joint
            carries the contact's share of the compression, 3p(1/h_A + 1/h_B) per unit overlap,
            and of the frictional strength, μ|σ|; contact is not evaluated for the pair until
            the joint hands that share and its energy over to contact (``handover_damage``,
            :func:`taichi_fdem.engine.contact.edge_pair_bonded`): fewer contact couples to
            evaluate once an impact compresses a jointed body (docs/performance.md).
            "contact": contact is evaluated for
            such pairs from the start, alongside the joint's own compression law, as in Y2D.
        handover_damage : with ``joined_pairs="joint"``, the damage D in [0, 1] (at any of the
            joint's three integration points, docs/theory/joints.md §7.5) beyond which the joint hands its
            pair over to contact (a broken joint always has).  Default 0: at the first damage.
            A speed option for impacts: most joints an impact damages stay below a few per
            cent, and each one carried longer is a pair contact does not evaluate
            (docs/performance.md).  It changes the response of damaged joints: the carried
            friction share μ|σ| stays in the joint's shear strength instead of contact
            friction, which raises the unconfined peak of ``verification.rock.case_triaxial``
            above Mohr–Coulomb of the joints (docs/performance.md).  The corner pairs around a
            joint are freed at its first damage whatever the value.
        """
        return Simulation(self, dt=dt, safety=safety, force_dt=force_dt, buffer=buffer, strategy=strategy,
                          check_overlap=check_overlap, speed_limit=speed_limit,
                          quasi_static=quasi_static_alpha(quasi_static), joined_pairs=joined_pairs,
                          handover_damage=handover_damage)

"""Specimens and platens of the compression tests (:mod:`taichi_fdem.lab.compressive`, and the
verification cases of :mod:`taichi_fdem.verification.rock` that run them)."""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from .. import mesh
from ..material import Material
from ..mesh import TriMesh
from ..scene import Curve, Scene


def check_joint_sets(joint_sets, where: str) -> list:
    """``joint_sets`` of a lab test -- an iterable of (name, selector, Material) -- as a list of
    triples; anything else raises ValueError naming the entry."""
    out = []
    for k, js in enumerate(joint_sets or ()):
        if not (isinstance(js, (tuple, list)) and len(js) == 3 and isinstance(js[2], Material)):
            raise ValueError(f"{where}: joint_sets[{k}] must be a (name, selector, Material) triple, got {js!r}")
        out.append(tuple(js))
    return out


def platen_scene(specimen_mesh: TriMesh, material: Material, platen_material: Material | None = None,
                 plane: str = "strain", fracture: bool = False, strain_rate: float = 0.1,
                 t_ramp: float = 0.0, gravity=(0.0, 0.0), groups=None, joint_sets=()):
    """A specimen (its mesh centred on the origin) between two platens driven towards each other.

    The platens (as wide as 1.6 × the specimen, 1/10 of its height thick) have prescribed
    velocities ±v with v = ``strain_rate`` × H/2 [m/s] (nominal axial strain rate [1/s]), started
    by a linear ``Curve`` ramp over ``t_ramp`` seconds.  Contact between specimen and platens
    uses ``platen_material`` (default: the specimen's material with no friction and no bedding:
    frictionless platens, a uniform uniaxial stress).  ``material`` may be a dict of Materials with ``groups``
    (one label per triangle).  ``joint_sets``: (name, selector, Material) triples added to the
    specimen with :meth:`Scene.add_joint_set` (e.g. ``("grain_boundaries", "interfaces", weak)``).
    Returns (scene, specimen, top platen, bottom platen).
    """
    x0, y0, x1, y1 = specimen_mesh.bounding_box()
    W, H = x1 - x0, y1 - y0
    mats = list(material.values()) if isinstance(material, dict) else [material]
    pm = platen_material
    if pm is None:                   # the specimen's material, frictionless, isotropic (no bedding)
        pm = mats[0].with_(friction=0.0, name="platen")
        if getattr(pm, "bedding", None) is not None:
            pm = pm.with_(bedding=None)
    scene = Scene(gravity=gravity, plane=plane)
    spec = scene.add_body(specimen_mesh, material, fracture=fracture, name="specimen", groups=groups)
    for name, selector, m in check_joint_sets(joint_sets, "lab"):
        scene.add_joint_set(name, selector, m, body=spec)
    v = strain_rate * 0.5 * H
    t = 0.1 * H
    curve = Curve.ramp(t_ramp) if t_ramp > 0 else None
    pmesh = mesh.rectangle(1.6 * W, t, t / 2)
    top = scene.add_body(pmesh, pm, position=(0.5 * (x0 + x1), y1 + 0.5 * t), prescribed_velocity=(0.0, -v),
                         velocity_curve=curve, name="top")
    bot = scene.add_body(pmesh, pm, position=(0.5 * (x0 + x1), y0 - 0.5 * t), prescribed_velocity=(0.0, v),
                         velocity_curve=curve, name="bottom")
    for m in mats:
        scene.set_interaction(m, pm, friction=pm.friction)
    return scene, spec, top, bot


def axial_record(sim, spec, top, bot, H: float, W: float):
    """(axial strain from the specimen's end faces, axial stress = mean platen reaction / W)
    [–, Pa], compression positive; the lateral strain from the side faces' mean x displacement."""
    X = sim.model.node_rest[spec.nodes]
    u = sim.node_displacements(spec)
    y0, y1 = X[:, 1].min(), X[:, 1].max()
    x0, x1 = X[:, 0].min(), X[:, 0].max()
    tol = 1e-6 * H
    eps = -(u[X[:, 1] >= y1 - tol, 1].mean() - u[X[:, 1] <= y0 + tol, 1].mean()) / H
    lat = (u[X[:, 0] >= x1 - tol, 0].mean() - u[X[:, 0] <= x0 + tol, 0].mean()) / W
    f = 0.5 * (sim.reaction(bot)[1] - sim.reaction(top)[1])
    return float(eps), float(f / W), float(lat)


def mohr_coulomb_peak(sigma3: float, cohesion: float, phi_deg: float) -> float:
    """σ1 at failure [Pa, compression positive] of Mohr–Coulomb with c, φ at confinement σ3
    (docs/theory/loads.md §12.6): σ1 = σ3 (1 + sin φ)/(1 − sin φ) + 2 c cos φ/(1 − sin φ)."""
    s = math.sin(math.radians(phi_deg))
    return sigma3 * (1 + s) / (1 - s) + 2 * cohesion * math.cos(math.radians(phi_deg)) / (1 - s)


def jaeger_peak(sigma3: float, cohesion: float, phi_deg: float, beta_deg: float) -> float:
    """σ1 at slip [Pa, compression positive] on a plane of weakness of cohesion c [Pa] and friction
    angle φ [degrees] whose normal makes β [degrees] with σ1, at confinement σ3 (Jaeger 1960;
    docs/theory/anisotropy.md, "Jaeger's plane of weakness"):
    σ1 − σ3 = 2 (c + σ3 tan φ) / ((1 − tan φ cot β) sin 2β); inf where the plane cannot slip
    (β ≤ φ or β ≥ 90°)."""
    b = math.radians(beta_deg % 180.0)
    if b > 0.5 * math.pi:
        b = math.pi - b                                # a plane's normal is a line: β and 180° − β alike
    t = math.tan(math.radians(phi_deg))
    if b <= 0.0 or b >= 0.5 * math.pi - 1e-12:
        return math.inf
    k = (1.0 - t / math.tan(b)) * math.sin(2.0 * b)
    return math.inf if k <= 0.0 else sigma3 + 2.0 * (cohesion + sigma3 * t) / k


def jointed_specimen_mesh(width: float, height: float, h: float) -> TriMesh:
    """A ``width`` × ``height`` rectangle (centred on the origin) meshed on a triangular lattice:
    rows of nodes ``h``·√3/2 apart (adjusted to fit the height), every other row shifted by half
    a cell, each row ending on the two sides.  The edges (the joints of a ``fracture=True`` body)
    run at 0° and about ±60° to the x axis, straight from side to side; only half cells at the
    sides break the pattern."""
    nx = max(1, int(round(width / h)))
    ny = max(1, int(round(height / (h * math.sqrt(3.0) / 2.0))))
    dx, dy = width / nx, height / ny
    X, Y = 0.5 * width, 0.5 * height
    rows, pts = [], []
    for j in range(ny + 1):
        xs = -X + dx * np.arange(nx + 1) if j % 2 == 0 else np.concatenate([[-X], -X + dx * (np.arange(nx) + 0.5), [X]])
        rows.append(np.arange(len(pts), len(pts) + len(xs)))
        pts.extend((x, -Y + dy * j) for x in xs)
    pts = np.array(pts)
    tris = []
    for j in range(ny):
        a, b = list(rows[j]), list(rows[j + 1])
        i = k = 0
        while i < len(a) - 1 or k < len(b) - 1:
            # advance along the row whose next node lies further left (a CCW triangle either way)
            if k == len(b) - 1 or (i < len(a) - 1 and pts[a[i + 1], 0] <= pts[b[k + 1], 0]):
                tris.append((a[i], a[i + 1], b[k]))
                i += 1
            else:
                tris.append((a[i], b[k + 1], b[k]))
                k += 1
    return TriMesh(pts, np.array(tris, dtype=np.int32))


def bedded_material(material, bedding_angle, where: str):
    """``material`` (a Material or a dict of them) with its bedding turned so that the bedding
    planes make ``bedding_angle`` [degrees] with the loading direction (the y axis): 0 loads
    parallel to the bedding, 90 across it (Tavallali & Vervoort 2010), i.e. a dip of
    90° − ``bedding_angle`` from the x axis.  None returns ``material`` unchanged.  ValueError when
    the angle is not a finite number or no material has a ``Bedding``."""
    if bedding_angle is None:
        return material
    if isinstance(bedding_angle, bool) or not (isinstance(bedding_angle, (int, float)) and math.isfinite(bedding_angle)):
        raise ValueError(f"{where}: bedding_angle must be a finite angle [degrees] or None, got {bedding_angle!r}")
    mats = list(material.values()) if isinstance(material, dict) else [material]
    if not any(getattr(m, "bedding", None) is not None for m in mats):
        raise ValueError(f"{where}: bedding_angle={bedding_angle!r} needs a material with a bedding: "
                         "fdem.Material(..., bedding=fdem.Bedding(...))")
    dip = 90.0 - float(bedding_angle)

    def turn(m):
        b = getattr(m, "bedding", None)
        return m if b is None else m.with_(bedding=dataclasses.replace(b, angle=dip))
    return {k: turn(m) for k, m in material.items()} if isinstance(material, dict) else turn(material)


def spaced_bedding(material):
    """The first ``Bedding`` with a ``spacing`` among ``material`` (a Material or a dict), or None."""
    mats = list(material.values()) if isinstance(material, dict) else [material]
    for m in mats:
        b = getattr(m, "bedding", None)
        if b is not None and getattr(b, "spacing", None) is not None:
            return b
    return None


def _with_planes(vertices: np.ndarray, h: float, bedding, fixed=None) -> TriMesh:
    """The polygon ``vertices`` meshed at ``h`` with the bedding planes of ``bedding`` (its angle
    and spacing, one plane through the origin) as embedded lines.  The points where the planes meet
    the outline become vertices of it, and the vertices not ``fixed`` (default: all fixed) closer
    than h/2 to one of them are dropped, so that no boundary piece is much shorter than h (no
    sliver triangles where a plane meets the boundary)."""
    if callable(bedding.angle):
        raise ValueError("lab: Bedding(spacing=...) needs a constant angle (or give bedding_angle=)")
    angle, spacing = float(bedding.angle), float(bedding.spacing)
    lines = mesh.bedding_lines(vertices, angle, spacing)
    if lines is None:
        return mesh.polygon(vertices, h)
    v = np.asarray(vertices, np.float64)
    fixed = np.ones(len(v), bool) if fixed is None else np.asarray(fixed, bool)
    ends = lines.segments.reshape(-1, 2)
    tol = 1e-9 * float(np.ptp(v, axis=0).max())
    out = []
    for i in range(len(v)):
        a, b = v[i], v[(i + 1) % len(v)]
        if fixed[i] or np.hypot(*(ends - a).T).min() >= 0.5 * h:
            out.append(a)
        d = b - a
        s = (ends - a) @ d / (d @ d)
        off = np.abs((ends[:, 0] - a[0]) * d[1] - (ends[:, 1] - a[1]) * d[0]) / math.sqrt(d @ d)
        on = (off <= tol) & (s * math.sqrt(d @ d) > tol) & ((1.0 - s) * math.sqrt(d @ d) > tol)
        out.extend(ends[on][np.argsort(s[on])])
    outline = np.array(out)
    return mesh.polygon(outline, h, lines=[mesh.bedding_lines(outline, angle, spacing)])


def bedded_rectangle(width: float, height: float, h: float, bedding) -> TriMesh:
    """A ``width`` × ``height`` specimen centred on the origin, meshed at ``h`` with its bedding
    planes (``bedding.spacing`` apart at ``bedding.angle``, one through the centre) as mesh edges."""
    X, Y = 0.5 * width, 0.5 * height
    return _with_planes(np.array([[-X, -Y], [X, -Y], [X, Y], [-X, Y]]), h, bedding)


def bedded_disc(radius: float, h: float, alpha_deg: float, bedding) -> TriMesh:
    """A disc of ``radius`` centred on the origin with its caps flat over ±``alpha_deg`` from the
    y axis (abs(y) ≤ R cos α, boundary nodes at about ``h`` on the arcs, one at each end of a flat),
    meshed at ``h`` with its bedding planes as mesh edges (the Brazilian disc of a spaced bedding)."""
    a = math.radians(alpha_deg)
    span = math.pi - 2.0 * a                                   # each side arc, from −(90° − α) to 90° − α
    n = max(2, int(math.ceil(span * radius / h)))
    t = -0.5 * span + span * np.arange(n + 1) / n
    right = np.column_stack([radius * np.cos(t), radius * np.sin(t)])
    fixed = np.zeros(n + 1, bool)
    fixed[[0, -1]] = True                                      # the ends of the flats stay
    return _with_planes(np.concatenate([right, -right]), h, bedding, np.concatenate([fixed, fixed]))

"""Direct shear of an interface between two blocks (a shear box, docs/theory/contact.md §5.1), or
of a cohesive joint between them (docs/theory/joints.md §7)."""
from __future__ import annotations

import math
import time as _time
import warnings
from types import SimpleNamespace

import numpy as np

from .. import mesh as _mesh
from ..scene import Curve, Scene
from ..sim.recorders import Checks
from .compressive import _first, _positive, video_frames
from .results import LabResult, check_rate, warn_kinetic


def direct_shear(material, width: float, height: float, h: float, normal_stress: float, *,
                 lower_material=None, friction: float | None = None, displacement: float | None = None,
                 rate_transits: float = 60.0, settle_transits: float = 10.0, samples: int = 100,
                 safety: float = 0.2, plane: str = "strain", joint: bool = False,
                 video: str | None = None) -> LabResult:
    """Direct shear of the interface between two ``width`` × ``height``/2 [m] blocks (mesh size
    ``h`` [m]) under a normal stress ``normal_stress`` = σn [Pa, compression positive].

    The upper block (``material``) carries a dead traction (0, −σn) on its top edge, ramped over
    ``settle_transits`` P-wave transits of the height, and its top edge is held against
    horizontal motion; the lower block (``lower_material``, default the same) is then driven
    horizontally (speed ramped over the first tenth) by ``displacement`` (default 5 % of the
    width) in ``rate_transits`` transits.  The interface is the contact between the blocks:
    its friction coefficient is ``friction`` (default: the smaller of the two materials').
    Shear stress τ = the horizontal force on the held top edge / width; dilation = the mean
    vertical displacement of the top edge (opening positive).

    ``joint=True``: the two blocks are one body of ``material`` (``lower_material`` is not
    used) whose edges along the shear plane y = 0 are cohesive joints (``fracture=`` that
    line; ``height``/2 must be a whole number of cells of ``h``).  The intact joint holds
    up to its Mohr–Coulomb strength c + σn tan φ (summary ``peak_mc``), then softens over the
    mode II span 3 G_II/(c + σn tan φ) and breaks; the broken faces slide with the contact
    friction μ (``friction``, default the material's): ``residual_shear`` ≈ μ σn.  A joint
    softer than the box (G_II small against the slip differences along it) fails
    progressively below ``peak_mc``.  With μ > 0 the peak exceeds c + σn tan φ: the intact
    joint adds μ × the compression of its carried contact share to its shear strength
    (docs/theory/joints.md §7.10), and the contact of its faces takes friction from its first
    damage (docs/guide/lab.md gives the peak of one box at μ = 0 and μ = 0.5).

    Curve columns: time_s, shear_displacement_m, shear_stress_Pa, normal_stress_Pa,
    dilation_m.  Summary: peak_shear [Pa], residual_shear [Pa] (mean over the last fifth),
    normal_stress [Pa], friction_peak = peak_shear/σn, friction_residual, dilation [m],
    kinetic_ratio (upper block, at half the peak), with ``joint``: peak_mc [Pa], broken
    (joints broken).
    """
    o = _shear_loading(material, width, height, h, normal_stress, lower_material, friction, displacement,
                       rate_transits, settle_transits, plane)
    upper, lower = _shear_boxes(o, height, h, normal_stress, friction, joint)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="bodies overlap", category=RuntimeWarning)
        sim = o.scene.build(safety=safety, quasi_static=True)
    rec, kin, wall = _shear_run(o, sim, upper, lower, height, normal_stress, samples, joint, video)
    summary, curve = _shear_measure(o, sim, rec, kin, normal_stress, joint, wall)
    return LabResult("direct_shear", curve, summary, sim=sim, bodies=(upper, lower), material=material)


def _shear_loading(material, width, height, h, normal_stress, lower_material, friction, displacement,
                   rate_transits, settle_transits, plane) -> SimpleNamespace:
    """The checked arguments of :func:`direct_shear` and the loading chosen from the material: first, low
    (the lower block's Material), W, Hb (block height [m]), d_max (shear displacement [m]), scene (empty),
    transit (H/c_p [s]), t1 (end of the normal load's ramp [s]), t_shear [s], v (shear speed [m/s]), tol [m],
    shear_curve, mu (the interface's friction), peak_mc (NaN)."""
    first = _first(material)
    _positive("lab.direct_shear", width=width, height=height, h=h)
    if not (math.isfinite(normal_stress) and normal_stress > 0):
        raise ValueError(f"lab.direct_shear: normal_stress must be > 0 Pa (compression positive), got {normal_stress}")
    check_rate(rate_transits, "lab.direct_shear")
    low = lower_material or first
    W, Hb = width, 0.5 * height
    d_max = 0.05 * W if displacement is None else float(displacement)
    scene = Scene(gravity=(0.0, 0.0), plane=plane)
    cp = first.p_wave_speed(plane)
    transit = height / cp
    t1 = settle_transits * transit
    t_shear = rate_transits * transit
    v = d_max / (0.95 * t_shear)
    shear_curve = Curve([0.0, t1, t1 + 0.1 * t_shear], [0.0, 0.0, 1.0], name="shear")
    mu = friction if friction is not None else min(first.friction, low.friction)
    return SimpleNamespace(first=first, low=low, W=W, Hb=Hb, d_max=d_max, scene=scene, transit=transit, t1=t1,
                           t_shear=t_shear, v=v, tol=1e-6 * W, shear_curve=shear_curve, mu=mu, peak_mc=math.nan)


def _shear_boxes(o, height, h, normal_stress, friction, joint):
    """(upper, lower) bodies added to ``o.scene``: two blocks in contact, or with ``joint`` one block jointed
    along y = 0 (sets ``o.mu``, ``o.peak_mc``); the lower one driven at ``o.v``, the upper one's top edge
    held horizontally under the ramped normal traction."""
    scene, first, low, W, Hb, tol, v = o.scene, o.first, o.low, o.W, o.Hb, o.tol, o.v
    if joint:
        if not first.can_fracture:
            raise ValueError("lab.direct_shear(joint=True): the material needs tensile_strength [Pa] and "
                             "fracture_energy [J/m²] (and cohesion, friction_angle) for its joints")
        box = _mesh.rectangle(W, height, h, origin=(-0.5 * W, -Hb))
        if np.count_nonzero(np.abs(box.points[:, 1]) < tol) < 2:
            raise ValueError(f"lab.direct_shear(joint=True): no row of mesh nodes on the shear plane y = 0: "
                             f"height/2 = {Hb:g} m must be a whole number of cells of h = {h:g} m")
        jm = first if friction is None else first.with_(friction=friction)
        ft, c, tanphi = jm.joint_properties()[:3]
        o.peak_mc = c + normal_stress * tanphi
        upper = scene.add_body(box, jm, name="box", fracture=lambda x, y: np.abs(y) < tol)
        lower = upper
        scene.fix_nodes(lambda x, y: y < -tol, body=upper, velocity=(v, 0.0), curve=o.shear_curve)
        o.mu = jm.friction
    else:
        lower = scene.add_body(_mesh.rectangle(W, Hb, h, origin=(-0.5 * W, -Hb)), low, name="lower",
                               prescribed_velocity=(v, 0.0), velocity_curve=o.shear_curve)
        upper = scene.add_body(_mesh.rectangle(W, Hb, h, origin=(-0.5 * W, 0.0)), first, name="upper")
        if friction is not None:
            scene.set_interaction(first, low, friction=friction)
    scene.fix_nodes(lambda x, y: y >= Hb - tol, body=upper, velocity=(0.0, None))
    scene.apply_traction(lambda x, y: y >= Hb - tol, (0.0, -normal_stress), body=upper,
                         curve=Curve.ramp(o.t1, name="normal"))
    return upper, lower


def _shear_run(o, sim, upper, lower, height, normal_stress, samples, joint, video):
    """Run the shear box in ``samples`` steps: (rec, kin, wall), rec the (time, shear displacement, τ, σn,
    dilation) per sample, kin the upper block's kinetic/strain energy per sample, wall [s]."""
    W, Hb, tol, t1 = o.W, o.Hb, o.tol, o.t1
    rest_up = sim.model.node_rest[upper.nodes]
    top = rest_up[:, 1] >= Hb - tol
    # the nodes of each block (the one body of a joint: above / below the shear plane)
    up_sel = rest_up[:, 1] > tol if joint else np.ones(len(rest_up), bool)
    low_sel = rest_up[:, 1] < -tol if joint else np.ones(len(sim.model.node_rest[lower.nodes]), bool)
    held = lambda x, y: y >= Hb - tol

    def upper_kinetic():
        m = sim.node_masses(upper)[up_sel]
        vv = sim.node_velocities(upper)[up_sel]
        return float(0.5 * (m * (vv * vv).sum(axis=1)).sum())
    writer, draw = video_frames(video, (-0.8 * W, 0.8 * W, -0.7 * height, 0.7 * height), (400, 320))
    rec, kin = [], []
    x_low0 = sim.node_positions(lower)[low_sel, 0].mean()
    t0 = _time.perf_counter()
    try:
        for _ in range(samples):
            sim.run((t1 + o.t_shear) / samples, checks=Checks(energy=False))
            tau = abs(float(sim.reaction(upper, where=held)[0])) / W
            dil = float(sim.node_displacements(upper)[top, 1].mean())
            d = float(sim.node_positions(lower)[low_sel, 0].mean() - x_low0)
            sn = normal_stress * min(1.0, sim.time / t1) if t1 > 0 else normal_stress
            rec.append((sim.time, d, tau, sn, dil))
            en = sim.energies()
            kin.append(upper_kinetic() / max(en["strain"], 1e-300))
            if draw is not None:
                draw(sim)
    finally:
        if writer is not None:
            writer.close()
    return rec, kin, _time.perf_counter() - t0


def _shear_measure(o, sim, rec, kin, normal_stress, joint, wall):
    """(summary, curve) of :func:`direct_shear` from its samples: the peak and residual (last fifth) shear
    stress, the dilation, the kinetic ratio at half the peak (warns above ``MAX_KINETIC_RATIO``)."""
    t, d, tau, sn, dil = (np.array(c) for c in zip(*rec))
    shear = t > o.t1
    k = int(np.argmax(np.where(shear, tau, -np.inf)))
    tail = np.flatnonzero(shear)[-max(1, shear.sum() // 5):]
    half = int(np.argmin(np.where(shear[: k + 1], np.abs(tau[: k + 1] - 0.5 * tau[k]), np.inf)))
    kinetic_ratio = float(kin[half])
    warn_kinetic(kinetic_ratio, "lab.direct_shear", stacklevel=4)
    summary = dict(peak_shear=float(tau[k]), residual_shear=float(tau[tail].mean()),
                   normal_stress=float(normal_stress), friction_peak=float(tau[k] / normal_stress),
                   friction_residual=float(tau[tail].mean() / normal_stress), friction=float(o.mu),
                   dilation=float(dil[-1] - dil[np.flatnonzero(shear)[0]]), kinetic_ratio=kinetic_ratio,
                   wall=wall, steps=sim.step_count, dt=sim.dt)
    if joint:
        summary.update(peak_mc=float(o.peak_mc), broken=sim.cracks.broken_count)
    curve = dict(time_s=t, shear_displacement_m=d, shear_stress_Pa=tau, normal_stress_Pa=sn, dilation_m=dil)
    return summary, curve

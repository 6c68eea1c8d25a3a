"""Direct shear of an interface between two blocks (a shear box, docs/theory/contact.md §5.1)."""
from __future__ import annotations

import math
import time as _time
import warnings

import numpy as np

from .. import mesh as _mesh
from ..scene import Curve, Scene
from .compressive import _first, _positive, video_frames
from .results import LabResult, check_rate, specimen_kinetic, warn_kinetic


def direct_shear(material, width: float, height: float, h: float, normal_stress: float, *,
                 lower_material=None, friction: float | None = None, displacement: float | None = None,
                 rate_transits: float = 60.0, settle_transits: float = 10.0, samples: int = 100,
                 safety: float = 0.2, plane: str = "strain", video: str | None = None) -> LabResult:
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

    Curve columns: time_s, shear_displacement_m, shear_stress_Pa, normal_stress_Pa,
    dilation_m.  Summary: peak_shear [Pa], residual_shear [Pa] (mean over the last fifth),
    normal_stress [Pa], friction_peak = peak_shear/σn, friction_residual, dilation [m],
    kinetic_ratio (upper block, at half the peak).
    """
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
    tol = 1e-6 * W
    lower = scene.add_body(_mesh.rectangle(W, Hb, h, origin=(-0.5 * W, -Hb)), low, name="lower",
                           prescribed_velocity=(v, 0.0),
                           velocity_curve=Curve([0.0, t1, t1 + 0.1 * t_shear], [0.0, 0.0, 1.0], name="shear"))
    upper = scene.add_body(_mesh.rectangle(W, Hb, h, origin=(-0.5 * W, 0.0)), first, name="upper")
    scene.fix_nodes(lambda x, y: y >= Hb - tol, body=upper, velocity=(0.0, None))
    scene.apply_traction(lambda x, y: y >= Hb - tol, (0.0, -normal_stress), body=upper,
                         curve=Curve.ramp(t1, name="normal"))
    if friction is not None:
        scene.set_interaction(first, low, friction=friction)
    mu = friction if friction is not None else min(first.friction, low.friction)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="bodies overlap", category=RuntimeWarning)
        sim = scene.build(safety=safety, quasi_static=True)
    top = sim.model.node_rest[upper.nodes][:, 1] >= Hb - tol
    writer, draw = video_frames(video, (-0.8 * W, 0.8 * W, -0.7 * height, 0.7 * height), (400, 320))
    rec, kin = [], []
    x_low0 = sim.node_positions(lower)[:, 0].mean()
    t0 = _time.perf_counter()
    try:
        for _ in range(samples):
            sim.run((t1 + t_shear) / samples, check_energy=False)
            tau = abs(float(sim.reaction(upper)[0])) / W
            dil = float(sim.node_displacements(upper)[top, 1].mean())
            d = float(sim.node_positions(lower)[:, 0].mean() - x_low0)
            sn = normal_stress * min(1.0, sim.time / t1) if t1 > 0 else normal_stress
            rec.append((sim.time, d, tau, sn, dil))
            en = sim.energies()
            kin.append(specimen_kinetic(sim, upper) / max(en["strain"], 1e-300))
            if draw is not None:
                draw(sim)
    finally:
        if writer is not None:
            writer.close()
    wall = _time.perf_counter() - t0
    t, d, tau, sn, dil = (np.array(c) for c in zip(*rec))
    shear = t > t1
    k = int(np.argmax(np.where(shear, tau, -np.inf)))
    tail = np.flatnonzero(shear)[-max(1, shear.sum() // 5):]
    half = int(np.argmin(np.where(shear[: k + 1], np.abs(tau[: k + 1] - 0.5 * tau[k]), np.inf)))
    kinetic_ratio = float(kin[half])
    warn_kinetic(kinetic_ratio, "lab.direct_shear")
    summary = dict(peak_shear=float(tau[k]), residual_shear=float(tau[tail].mean()),
                   normal_stress=float(normal_stress), friction_peak=float(tau[k] / normal_stress),
                   friction_residual=float(tau[tail].mean() / normal_stress), friction=float(mu),
                   dilation=float(dil[-1] - dil[np.flatnonzero(shear)[0]]), kinetic_ratio=kinetic_ratio,
                   wall=wall, steps=sim.step_count, dt=sim.dt)
    curve = dict(time_s=t, shear_displacement_m=d, shear_stress_Pa=tau, normal_stress_Pa=sn, dilation_m=dil)
    return LabResult("direct_shear", curve, summary, sim=sim, bodies=(upper, lower), material=material)

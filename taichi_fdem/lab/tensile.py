"""The Brazilian (indirect tensile) test of a disc between flat platens on flattened caps (docs/verification.md §8.8)."""
from __future__ import annotations

import math
import time as _time
import warnings
from types import SimpleNamespace

import numpy as np

from .. import mesh as _mesh
from ..verification.fracture import brazilian_load, brazilian_result, brazilian_scene, hondros_factor
from .compressive import _first, _positive, video_frames
from ..scene import quasi_static_alpha
from .results import (JOINT_PENALTY_FACTOR, LabResult, check_keyword, check_rate, convergence, lab_materials,
                      specimen_kinetic, warn_kinetic)
from .specimens import bedded_disc, bedded_material, check_joint_sets, spaced_bedding


#: Defaults of :func:`brazilian` (each a keyword): the loading to the expected peak lasts
#: LOAD_TIME D/c_p, at SAFETY × the time-step estimate, with local damping of coefficient
#: LOCAL_DAMPING (``quasi_static=``).  The local damping resists the opening of the softening
#: joints as it resists any motion, so the split's load falls towards its quasi-static value
#: as the loading slows and as α falls (docs/guide/lab.md, "The loading rate").
LOAD_TIME = 60.0
SAFETY = 0.2
LOCAL_DAMPING = 0.3
#: The split: the peak is the largest load up to SPLIT_WINDOW × D/c_p after the first joint of
#: the central third (``|x|``, ``|y|`` < D/6) broke in tension; the halves of a split disc of high
#: cohesion can carry the platens further, as two columns, and the load rises again.
SPLIT_WINDOW = 2.0
#: Half-angle [°] of the loading arc of :func:`brazilian` when ``alpha_deg`` is not given: the
#: flats end at the disc's boundary node nearest to it (ISRM's curved jaws load about ±10°).
LOADING_ARC_DEG = 10.0


def _boundary_angles(points, radius: float):
    """Angles [°] from the +y axis of the mesh nodes on the circle of ``radius`` (upper half)."""
    r = np.hypot(points[:, 0], points[:, 1])
    top = (r >= radius * (1.0 - 1e-9)) & (points[:, 1] > 0.0)
    return np.degrees(np.arctan2(np.abs(points[top, 0]), points[top, 1]))


def loading_arc(points, radius: float, alpha_deg: float | None):
    """(clip angle α [°], loaded half-arc [°]) of a disc mesh (``points`` centred on the origin).

    The caps are clipped to ``|y|`` ≤ R cos α.  With ``alpha_deg`` None, α is the angle of the
    boundary node nearest to :data:`LOADING_ARC_DEG`, so that each flat ends at a node.  The
    loaded half-arc is asin(w / 2R) of the flats' mean width w (the nodes clipped onto them):
    the arc of the Hondros factor."""
    if alpha_deg is None:
        ang = _boundary_angles(points, radius)
        ang = ang[ang > 1e-6]
        alpha_deg = float(ang[np.argmin(np.abs(ang - LOADING_ARC_DEG))]) if len(ang) else LOADING_ARC_DEG
    if not (math.isfinite(alpha_deg) and 0.0 < alpha_deg < 60.0):
        raise ValueError(f"lab.brazilian: alpha_deg must be in (0, 60) degrees, got {alpha_deg!r}")
    yc = radius * math.cos(math.radians(alpha_deg))
    widths = []
    for sign in (1.0, -1.0):
        on = sign * points[:, 1] >= yc - 1e-9 * radius
        widths.append(np.ptp(points[on, 0]) if on.sum() > 1 else 0.0)
    half = 0.25 * (widths[0] + widths[1])
    return float(alpha_deg), math.degrees(math.asin(min(1.0, half / radius)))


def brazilian(material, diameter: float, h: float, *, alpha_deg: float | None = None, load_time: float | None = None,
              samples: int = 240, safety: float | None = None, platen=None, strength=None, groups=None, mesh=None,
              plane: str = "strain", max_time: float = 3.0, joint_sets=(), video: str | None = None,
              quasi_static=None, joint_penalty_factor=None, check=None, bedding_angle=None, frame=None) -> LabResult:
    """Brazilian test of a disc of ``diameter`` D [m], mesh size ``h`` [m], every interior edge
    a cohesive joint, between two platens closing at ±v.

    Quasi-static settings, chosen from the material and the disc unless given (all reported
    in ``result.settings``): ``quasi_static`` local non-viscous damping (default
    :data:`LOCAL_DAMPING` α = 0.3; True: α = 0.7, see :meth:`Scene.build
    <taichi_fdem.scene.Scene.build>`; False turns it off and leaves only the material's own
    ``damping``); ``load_time`` (default ``LOAD_TIME`` = 60 D/c_p to the expected peak);
    ``safety`` of the time step (default ``SAFETY`` = 0.2 of the estimate: at 0.35 the platen
    contact gains energy, the disc rings and splits early); the joint penalty
    ``joint_penalty_factor`` × E where the material leaves ``joint_penalty`` unset (default
    :data:`~taichi_fdem.lab.results.JOINT_PENALTY_FACTOR` = 50; at the Material default of
    10 E the joints' tractions scatter about the elastic field and the disc splits early).
    The material given is never changed: the test builds on a copy (``result.material``).

    The disc (``mesh`` None): :func:`mesh.disk <taichi_fdem.mesh.disk>`'s symmetric layout,
    which has a straight line of joints along the loaded diameter, the path of the split a
    Brazilian test measures (docs/guide/lab.md, "What the Brazilian strength measures"):
    through a mesh without one (``layout="spiral"``) the split must zig-zag along joints
    inclined to the diameter, which the disc's centre (σ_yy ≈ −3 σ_xx) loads in compression
    and shear, and the peak then measures c, φ and the friction of the sliding faces as much
    as f_t.

    Platen contact (ISRM's loading arc): the disc's caps are flattened to ``|y|`` ≤ R cos α
    so the load spreads over a few elements: on a round disc the point load crushes the joints
    under the platen first and the test splits at about half the strength.  ``alpha_deg``
    None: α is the angle of the boundary node nearest to :data:`LOADING_ARC_DEG` (10°, the arc
    ISRM's curved jaws load), so each flat ends at a node.  The centre stress of a load spread
    over a half-arc θ is (sin 2θ − θ)/θ times 2P/(πD) (Hondros; 0.95 at 11.25°), θ the half-arc
    the flats actually span (``settings["loaded_arc_deg"]``): ``.peak_stress`` is the standard
    σ_t = 2P/(πDt) [Pa] (t = 1: loads per unit thickness), ``.centre_stress`` that times the
    Hondros factor (the one to compare with f_t).  The load P is the platens' work over a
    window of D/c_p divided by their approach (filters contact chatter and ringing).

    ``check``: None, "rate", "mesh" or "both": rerun at half the loading rate (``load_time`` ×
    2) and/or half ``h`` with the same settings, and put the relative change of
    ``centre_stress`` in ``result.convergence`` (e.g. ``{"rate": -0.027}``).

    ``material``: a Material or a dict of Materials with ``groups`` (labels per triangle of
    ``mesh``, a disc centred on the origin).  ``joint_sets``: (name, selector, Material) triples
    added with :meth:`Scene.add_joint_set` (e.g. ``[("grain_boundaries", "interfaces", weak)]``).
    ``platen``: the platens' Material (default: 10 × stiffer, penalty 3 × the disc's E).
    ``load_time`` below ``MIN_TRANSITS`` is refused.  The peak is the split's load: the
    largest load up to :data:`SPLIT_WINDOW` (2) D/c_p after the first joint of the central third
    (``|x|``, ``|y|`` < D/6) broke in tension, where the test stops (``peaked`` True; the halves
    of a disc of high cohesion carry the platens further as two columns, and the load can rise
    again); without a central split, when the load has dropped below 30 % of its peak
    (``peaked`` True), or after
    ``max_time`` × the loading time (``peaked`` False, with a RuntimeWarning: the peak is then
    the last load reached, not the strength).

    ``bedding_angle`` [°]: bedding to loaded diameter, 0 parallel, 90 across; ``frame(sim)`` runs at each sample.

    Similarity: the result depends on the dimensionless groups f_t/E, l_ch/D = E G_I/(f_t² D),
    c/f_t, φ, G_II/G_I, ν, p_f/E, the platens' E and penalty over the disc's E, h/D, α, β and
    ``load_time``; with all of them fixed, ``.peak_stress`` is proportional to f_t
    (tests/test_lab.py checks it to 1e-6).  A disc of only a few l_ch splits above f_t: the
    cohesive zone spans the centre before the first joint breaks (the size effect of a
    cohesive crack, docs/guide/lab.md).

    Curve columns: time_s, approach_m, load_N_per_m (filtered), load_instantaneous_N_per_m,
    broken_joints.  Summary: peak_stress [Pa], centre_stress [Pa], peak_load [N/m], hondros,
    central_fraction (share of the joints broken by shortly after the peak within ``|x|`` < 0.15 D:
    where the split runs), split_start ((x, y) [m] of the first joint broken in tension, mode
    I: where the split starts; NaN if none), broken, fragments, kinetic_ratio, peaked, bedding_angle.
    """
    o = _brazilian_options(material, diameter, h, check, load_time, safety, quasi_static, joint_penalty_factor,
                           max_time, bedding_angle)
    sim, bodies, p = _brazilian_specimen(o, diameter, h, alpha_deg, strength, platen, groups, mesh, plane, joint_sets)
    run = _brazilian_run(sim, bodies, p, diameter, samples, max_time, video, frame)
    result = _brazilian_result(o, sim, bodies, p, run, diameter, max_time, mesh)
    result.convergence = _brazilian_check(result, material, diameter, h, o.reruns, dict(   # {} without reruns
        alpha_deg=alpha_deg, load_time=o.load_time, samples=samples, safety=o.safety, platen=platen, strength=strength,
        groups=groups, mesh=mesh, plane=plane, max_time=max_time, joint_sets=joint_sets, quasi_static=o.quasi_static,
        joint_penalty_factor=o.factor, bedding_angle=bedding_angle))
    return result


def _warn_size(first, diameter: float, h: float) -> None:
    """Warn where the disc measures more than f_t (D < 2 l_ch: the size effect of a cohesive
    crack) or where the mesh does not resolve the cohesive zone (l_ch < 3 h: the split comes
    early); l_ch = E G_I / f_t² (docs/guide/lab.md, "What the Brazilian strength measures")."""
    lch = first.young * first.fracture_energy / first.tensile_strength ** 2
    if lch < 3.0 * h:
        warnings.warn(f"lab.brazilian: the characteristic length l_ch = E G_I/f_t² = {lch * 1e3:.3g} mm is under "
                      f"3 elements (h = {h * 1e3:.3g} mm): the mesh does not resolve the cohesive zone and the "
                      f"Brazilian strength comes out below f_t; use h <= l_ch/3 = {lch / 3 * 1e3:.3g} mm "
                      "(docs/guide/lab.md)", RuntimeWarning, stacklevel=4)
    elif diameter < 2.0 * lch:
        warnings.warn(f"lab.brazilian: the disc (D = {diameter * 1e3:.3g} mm) is under two characteristic lengths "
                      f"l_ch = E G_I/f_t² = {lch * 1e3:.3g} mm: the size effect of a cohesive crack makes its "
                      "Brazilian strength exceed f_t (docs/guide/lab.md)", RuntimeWarning, stacklevel=4)


def _brazilian_options(material, diameter, h, check, load_time, safety, quasi_static, joint_penalty_factor,
                       max_time, bedding_angle=None) -> SimpleNamespace:
    """The checked arguments and the settings of :func:`brazilian` chosen from the material: first (the
    material's first Material), reruns, load_time, safety, quasi_static, factor, mat (the copy the test
    builds on, its bedding turned to ``bedding_angle``), pf (joint penalty [Pa/m]), raised, elements (cells
    across the diameter), bedding_angle (NaN without)."""
    _first(material)
    material = bedded_material(material, bedding_angle, "lab.brazilian")
    first = _first(material)
    _positive("lab.brazilian", diameter=diameter, h=h)
    if not first.can_fracture:
        raise ValueError("lab.brazilian: the disc's material needs tensile_strength [Pa] and fracture_energy [J/m²]")
    reruns = check_keyword(check, "lab.brazilian")
    load_time = LOAD_TIME if load_time is None else load_time
    safety = SAFETY if safety is None else safety
    quasi_static = LOCAL_DAMPING if quasi_static is None else quasi_static
    factor = JOINT_PENALTY_FACTOR if joint_penalty_factor is None else joint_penalty_factor
    check_rate(load_time, "lab.brazilian")
    if not (math.isfinite(max_time) and max_time >= 1.0):
        raise ValueError(f"lab.brazilian: max_time must be >= 1 (loading times), got {max_time!r}")
    mat, pf, raised = lab_materials(material, factor, "lab.brazilian")
    _warn_size(first, diameter, h)
    return SimpleNamespace(first=first, reruns=reruns, load_time=load_time, safety=safety, quasi_static=quasi_static,
                           factor=factor, mat=mat, pf=pf, raised=raised,
                           elements=max(2, int(round(diameter / h))),
                           bedding_angle=math.nan if bedding_angle is None else float(bedding_angle))


def _brazilian_specimen(o, diameter, h, alpha_deg, strength, platen, groups, mesh, plane, joint_sets):
    """(sim, bodies, p) of the built disc between its platens (:func:`brazilian_scene`); sets ``o.alpha_deg``,
    ``o.arc_deg`` (:func:`loading_arc`) and ``o.build`` (wall time [s] of the build)."""
    t0 = _time.perf_counter()
    spaced = spaced_bedding(o.mat)
    if mesh is None and spaced is not None:
        disc = bedded_disc(0.5 * diameter, h, LOADING_ARC_DEG if alpha_deg is None else alpha_deg, spaced)
        o.mesh_kind = "disc along the bedding planes"
    else:
        disc = _mesh.disk(0.5 * diameter, h) if mesh is None else mesh
        o.mesh_kind = "given" if mesh is not None else "disk (symmetric)"
    o.alpha_deg, o.arc_deg = loading_arc(np.asarray(disc.points, dtype=np.float64), 0.5 * diameter, alpha_deg)
    sim, bodies, p = brazilian_scene(elements=o.elements, load_time=o.load_time, D=diameter, alpha_deg=o.alpha_deg,
                                     safety=o.safety, strength=strength, material=o.mat, platen=platen,
                                     groups=groups, disc_mesh=disc, plane=plane,
                                     joint_sets=check_joint_sets(joint_sets, "lab.brazilian"),
                                     quasi_static=o.quasi_static)
    o.build = _time.perf_counter() - t0
    return sim, bodies, p


def _brazilian_run(sim, bodies, p, diameter, samples, max_time, video, user_frame=None):
    """Load the disc (:func:`brazilian_load`) until the split's window has passed: (rec, kin, split, wall) with
    kin the disc's kinetic/strain energy per sample, split [time of the first central tension break] (empty
    without one) and wall the run's wall time [s]."""
    writer, draw = video_frames(video, (-0.75 * diameter, 0.75 * diameter, -0.75 * diameter, 0.75 * diameter),
                                (320, 320))
    kin = []

    def frame(s):
        en = s.energies()
        kin.append(specimen_kinetic(s, bodies[0]) / max(en["strain"], 1e-300))
        if draw is not None:
            draw(s)
        if user_frame is not None:
            user_frame(s)
    split = []                       # the time of the first central tension break
    window = SPLIT_WINDOW * diameter / p["cp"]

    def stop(rec):
        if not split and rec["broken"][-1]:
            bj = sim.cracks.broken()
            x, y = bj["position"][:, 0], bj["position"][:, 1]
            hit = np.flatnonzero((np.asarray(bj["mode"]) == "I") & (np.abs(x) < diameter / 6)
                                 & (np.abs(y) < diameter / 6))
            if len(hit):
                split.append(float(bj["time"][hit[0]]))
        return bool(split) and rec["t_P"][-1] > split[0] + window
    t0 = _time.perf_counter()
    try:
        rec = brazilian_load(sim, bodies, p, samples=samples, frame=frame, duration=max_time, stop=stop)
    finally:
        if writer is not None:
            writer.close()
    return rec, kin, split, _time.perf_counter() - t0


def _brazilian_result(o, sim, bodies, p, run, diameter, max_time, mesh) -> LabResult:
    """The :class:`LabResult` of :func:`brazilian` from its run: the split's peak load, the stresses, the
    split's start, the kinetic ratio (warns), ``peaked`` (warns when False) and the settings."""
    rec, kin, split, wall = run
    out = brazilian_result(sim, bodies, rec, p)
    if split:                        # the split's load: the largest up to the window after the central break
        last = int(np.searchsorted(rec["t_P"], split[0] + SPLIT_WINDOW * diameter / p["cp"], side="right"))
        split.append(max(1, last))
    i = int(rec["P"][: split[1]].argmax()) if split else int(rec["P"].argmax())
    half = int(abs(rec["P"][: i + 1] - 0.5 * rec["P"][i]).argmin())
    kinetic_ratio = float(kin[max(0, half - 1)]) if kin else math.nan
    warn_kinetic(kinetic_ratio, "lab.brazilian", stacklevel=4)
    peaked = bool(split) or bool(rec["broken"][-1] > 0 and rec["P"][-1] < 0.3 * rec["P"].max())
    if not peaked:
        warnings.warn(f"lab.brazilian: the load had not dropped after {max_time:g} loading times: the peak is the "
                      "last load reached, not the strength (raise max_time)", RuntimeWarning, stacklevel=3)
    if split:
        out["P_max_N_per_m"] = float(rec["P"][i])
    sigma = 2.0 * out["P_max_N_per_m"] / (math.pi * diameter)
    hf = hondros_factor(o.arc_deg)
    bj = sim.cracks.broken()
    tension = np.flatnonzero(np.asarray(bj["mode"]) == "I")
    start = tuple(float(v) for v in bj["position"][tension[0]]) if len(tension) else (math.nan, math.nan)
    summary = dict(peak_stress=sigma, centre_stress=sigma * hf, peak_load=out["P_max_N_per_m"], hondros=hf,
                   central_fraction=out["central_fraction"], split_start=start, broken=out["broken_total"],
                   fragments=out["fragments"],
                   kinetic_ratio=kinetic_ratio, peaked=peaked, load_time=float(o.load_time), elements=o.elements,
                   wall=wall, build=o.build, steps=sim.step_count, dt=sim.dt, platen_speed=p["v"],
                   bedding_angle=o.bedding_angle)
    pm, first, pf = p["platen"], o.first, o.pf
    settings = dict(quasi_static=quasi_static_alpha(o.quasi_static), damping=float(first.damping),
                    load_time=float(o.load_time), platen_speed=float(p["v"]), safety=float(o.safety),
                    dt=float(sim.dt), joint_penalty=pf, joint_penalty_factor=pf / first.young,
                    joint_penalty_raised=o.raised, platen_young=float(pm.young),
                    platen_penalty=float(pm.contact_penalty), platen_friction=float(pm.friction),
                    alpha_deg=float(o.alpha_deg), loaded_arc_deg=o.arc_deg,
                    mesh=o.mesh_kind, elements=o.elements, bedding_angle=o.bedding_angle)
    curve = dict(time_s=rec["t_P"], approach_m=rec["approach_P"], load_N_per_m=rec["P"],
                 load_instantaneous_N_per_m=rec["P_inst"], broken_joints=rec["broken"])
    return LabResult("brazilian", curve, summary, sim=sim, bodies=bodies, material=o.mat, settings=settings)


def _brazilian_check(result, material, diameter, h, reruns, kw) -> dict:
    """``result.convergence`` of ``check=``: :func:`brazilian` rerun with the keywords ``kw`` at twice the
    loading time ("rate") and/or half ``h`` ("mesh", refused for a given mesh)."""
    if kw["mesh"] is not None and "mesh" in reruns:
        raise ValueError("lab.brazilian: check='mesh' needs the default mesh (mesh=None): a given mesh "
                         "cannot be refined here")
    runs = {}
    if "rate" in reruns:
        runs["rate"] = brazilian(material, diameter, h, **dict(kw, load_time=2.0 * kw["load_time"]))
    if "mesh" in reruns:
        runs["mesh"] = brazilian(material, diameter, 0.5 * h, **kw)
    return convergence(result, runs, key="centre_stress")

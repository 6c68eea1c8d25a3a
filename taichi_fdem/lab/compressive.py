"""Compression tests between frictionless platens: unconfined (UCS) and triaxial (docs/theory/loads.md §12.6)."""
from __future__ import annotations

import math
import time as _time
import warnings
from types import SimpleNamespace

import numpy as np

from .. import mesh as _mesh
from ..material import Material
from ..scene import Curve
from ..sim.recorders import Checks, History
from .specimens import (axial_record, bedded_material, bedded_rectangle, check_joint_sets, jaeger_peak,
                        jointed_specimen_mesh, mohr_coulomb_peak, platen_scene, spaced_bedding)
from ..scene import quasi_static_alpha
from .results import (COMPRESSION_JOINT_PENALTY_FACTOR, LabResult, check_keyword, check_rate, convergence, elastic_constants,
                      lab_materials, specimen_kinetic, warn_kinetic)


def _first(material):
    if isinstance(material, dict):
        if not material or not all(isinstance(m, Material) for m in material.values()):
            raise TypeError("lab: material must be a Material or a non-empty dict of Materials")
        return next(iter(material.values()))
    if not isinstance(material, Material):
        raise TypeError(f"lab: material must be a Material or a dict of Materials, got {type(material).__name__}")
    return material


def _positive(where, **values):
    for k, v in values.items():
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"{where}: {k} must be a positive length [m], got {v!r}")


def video_frames(video, view, size=(320, 480)):
    """(writer, frame(sim)) for ``video=`` of the lab tests: frames coloured by joint damage; (None, None) without a path."""
    if not video:
        return None, None
    from ..render import RendererImage, VideoWriter
    renderer = RendererImage(*size, view=view, color_by="damage", vmin=0.0, vmax=1.0)
    writer = VideoWriter(video, fps=15)
    return writer, lambda sim: writer.append(renderer.render_sim(sim))


def compression(material, width: float, height: float, h: float, confinement: float = 0.0, *,
                plane: str = "strain", fracture=None, mesh=None, groups=None, platen=None,
                rate_transits: float = 60.0, settle_transits: float | None = None,
                max_strain: float | None = None, samples: int = 150, stop_drop: float = 0.8,
                safety: float = 0.2, quasi_static=True, handover_damage: float | None = None,
                penalty_factor: float | None = None, video: str | None = None, history: str | None = None,
                frame=None, joint_sets=(), check=None, bedding_angle: float | None = None,
                test: str = "triaxial") -> LabResult:
    """A compression test of a ``width`` × ``height`` [m] specimen (mesh size ``h`` [m]) between
    frictionless platens, confined by a pressure ``confinement`` = σ3 [Pa] on its sides.

    Phase 1 (``settle_transits`` P-wave transits H/c_p, default 10 when σ3 > 0, else 0): σ3 is
    ramped with the platens still.  Phase 2: the platens close (their speed ramped over 5
    transits) at a nominal strain rate that reaches the expected peak strain in
    ``rate_transits`` transits, until ``max_strain`` or until the axial stress has dropped below
    ``stop_drop`` × its peak.  The expected peak: Mohr–Coulomb of the joints' c, φ over E/2
    (the joints' compliance) with fracture, or Jaeger's slip on the weak bedding planes of a
    spaced bedding where lower; without fracture, ``max_strain`` (default 1e-3) / 2.5.

    ``material``: a Material, or a dict of Materials with ``groups`` (one label per triangle of
    ``mesh``).  ``fracture``: passed to ``Scene.add_body`` (default: True when the material
    can fracture).  ``joint_sets``: (name, selector, Material) triples added with
    :meth:`Scene.add_joint_set`, e.g. ``[("grain_boundaries", "interfaces", weak)]`` on a
    :func:`~taichi_fdem.mesh.voronoi_grains` specimen.  ``mesh``: the specimen's TriMesh centred on the origin (default: the
    triangular lattice of ``verification.jointed_specimen_mesh`` with fracture, else
    ``mesh.rectangle``).  The joint penalty, where the material leaves it unset, is
    ``penalty_factor`` × E (default
    :data:`~taichi_fdem.lab.results.COMPRESSION_JOINT_PENALTY_FACTOR` = 200: the jointed
    specimen's E and ν then match the material's to 3 % below 30 % of the peak; the material
    given is not changed, the test builds on a copy).  What the test chose (local damping α, loading rate,
    time-step safety, joint penalty and whether it was raised above the Material default,
    platens) is in ``result.settings``.

    ``check``: None, "rate", "mesh" or "both": rerun at half the loading rate
    (``rate_transits`` × 2) and/or half ``h`` with the same settings, and put the relative
    change of ``peak_stress`` in ``result.convergence``.

    ``bedding_angle`` [degrees]: the angle between the bedding planes and the loading direction
    (the y axis, σ1): 0 loads parallel to the bedding, 90 across it (the convention of Tavallali
    & Vervoort 2010); the material's ``Bedding`` is turned to a dip of 90° − ``bedding_angle``
    from the x axis (ValueError without a Bedding).  With ``Bedding(spacing=s)`` the default
    mesh follows the bedding planes every ``s`` (one through the centre; docs/guide/anisotropy.md).
    Jaeger's angle β between σ1 and the planes' normal is 90° − ``bedding_angle``.

    Quasi-static: ``rate_transits`` < ``lab.results.MIN_TRANSITS`` raises ValueError; the
    specimen's kinetic/strain energy at half the peak is in the summary (``kinetic_ratio``) and
    warns above ``MAX_KINETIC_RATIO``.

    Returns a :class:`LabResult` with curve columns time_s, axial_strain, axial_stress_Pa,
    lateral_strain (compression positive; stress = the platens' mean reaction / width) and
    summary peak_stress [Pa], peak_strain, young [Pa], poisson (tangent at 50 % of the peak,
    corrected for the plane condition, see :func:`~taichi_fdem.lab.results.elastic_constants`),
    young_initial, poisson_initial (the same over 5–30 % of the peak),
    plane_modulus E', plane_poisson ν', confinement, peak_mc (joints' Mohr–Coulomb), peak_jaeger
    (slip on the weak bedding planes, :func:`~taichi_fdem.lab.specimens.jaeger_peak`; NaN without a
    spaced bedding), broken, bedding_angle (NaN without).
    """
    o = _compression_options(material, width, height, h, confinement, fracture, mesh, rate_transits,
                             penalty_factor, check, f"lab.{test}", bedding_angle)
    _compression_loading(o, height, confinement, plane, max_strain, settle_transits, rate_transits)
    spec, top, bot, sim = _compression_specimen(o, width, confinement, plane, platen, groups, joint_sets, safety,
                                                quasi_static, handover_damage)
    rec, kin, wall = _compression_run(o, sim, spec, top, bot, width, height, confinement, samples, stop_drop,
                                      history, frame, video)
    summary, curve = _compression_measure(o, sim, rec, kin, confinement, plane, rate_transits, wall)
    summary["bedding_angle"] = math.nan if bedding_angle is None else float(bedding_angle)
    first, pf = o.first, o.pf
    settings = dict(quasi_static=quasi_static_alpha(quasi_static), damping=float(first.damping),
                    rate_transits=float(rate_transits), strain_rate=float(o.rate), safety=float(safety),
                    dt=float(sim.dt), joint_penalty=pf,
                    joint_penalty_factor=pf / first.young if o.fracture else math.nan,
                    joint_penalty_raised=o.raised, platen_friction=float(top.material.friction),
                    platen_penalty=float(top.material.contact_penalty), settle_transits=float(o.settle))
    result = LabResult(test, curve, summary, sim=sim, bodies=(spec, top, bot), material=o.material,
                       settings=settings)
    if o.reruns:
        # the mesh given (None: the rerun at h/2 builds its own default mesh)
        kw = dict(plane=plane, fracture=o.fracture, mesh=mesh, groups=groups, platen=platen,
                  rate_transits=rate_transits, settle_transits=settle_transits, max_strain=o.max_strain,
                  samples=samples, stop_drop=stop_drop, safety=safety, quasi_static=quasi_static,
                  handover_damage=handover_damage, penalty_factor=o.factor, joint_sets=joint_sets,
                  bedding_angle=bedding_angle, test=test)
        runs = {}
        if "rate" in o.reruns:
            runs["rate"] = compression(material, width, height, h, confinement,
                                       **dict(kw, rate_transits=2 * rate_transits))
        if "mesh" in o.reruns:
            runs["mesh"] = compression(material, width, height, 0.5 * h, confinement, **kw)
        result.convergence = convergence(result, runs)
    return result


def _compression_options(material, width, height, h, confinement, fracture, mesh, rate_transits, penalty_factor,
                         check, where, bedding_angle=None) -> SimpleNamespace:
    """The checked arguments of :func:`compression` and the specimen's materials: where, reruns, fracture,
    factor, material (the copy the test builds on, its bedding turned to ``bedding_angle``), first (its
    first Material), pf (joint penalty [Pa/m], NaN without fracture), raised, mesh (the given one or the
    default specimen: along the bedding planes of a spaced bedding)."""
    _first(material)
    material = bedded_material(material, bedding_angle, where)
    first = _first(material)
    _positive(where, width=width, height=height, h=h)
    if not (math.isfinite(confinement) and confinement >= 0):
        raise ValueError(f"{where}: confinement must be a pressure >= 0 Pa (compression positive), got {confinement}")
    check_rate(rate_transits, where)
    reruns = check_keyword(check, where)
    if reruns and mesh is not None and "mesh" in reruns:
        raise ValueError(f"{where}: check='mesh' needs the default mesh (mesh=None): a given mesh cannot be refined here")
    fracture = first.can_fracture if fracture is None else fracture
    factor = COMPRESSION_JOINT_PENALTY_FACTOR if penalty_factor is None else penalty_factor
    pf, raised = math.nan, False
    if fracture:
        material, pf, raised = lab_materials(material, factor, where)
        first = _first(material)
    spaced = spaced_bedding(material)
    if mesh is None and spaced is not None:
        mesh = bedded_rectangle(width, height, h, spaced)
    elif mesh is None:
        mesh = jointed_specimen_mesh(width, height, h) if fracture else _mesh.rectangle(width, height, h)
    return SimpleNamespace(where=where, reruns=reruns, fracture=fracture, factor=factor, material=material,
                           first=first, pf=pf, raised=raised, mesh=mesh)


def _planes_properties(material, bedding) -> tuple:
    """The joint properties (f_t, c, tan φ, G_I, G_II, p_f) of ``material``'s weak bedding planes."""
    from ..discontinuity import bedding_strength
    return tuple(bedding_strength(np.array([material.joint_properties()]), bedding, np.zeros(1))[0])


def _compression_loading(o, height, confinement, plane, max_strain, settle_transits, rate_transits):
    """The loading chosen from the material and the specimen, set on ``o``: transit (H/c_p [s]), peak_mc
    (joints' Mohr–Coulomb peak [Pa], NaN without fracture), peak_jaeger (slip on the weak bedding planes
    of a spaced bedding, :func:`jaeger_peak`, NaN without; the expected peak is the lower of the two),
    eps_peak (expected peak strain), max_strain,
    settle (transits), t1 (end of the confinement's settling [s]), rate (nominal strain rate [1/s])."""
    first = o.first
    cp = first.p_wave_speed(plane)
    o.transit = height / cp
    o.peak_jaeger = math.nan
    if o.fracture:
        c = first.cohesion if first.cohesion is not None else first.tensile_strength
        o.peak_mc = mohr_coulomb_peak(confinement, c, first.friction_angle)
        expected = o.peak_mc
        bed = spaced_bedding(o.material)
        if bed is not None and not callable(bed.angle):      # slip on the weak planes (σ1 along y)
            _, cw, tw, _, _, _ = _planes_properties(first, bed)
            o.peak_jaeger = jaeger_peak(confinement, cw, math.degrees(math.atan(tw)), float(bed.angle))
            expected = min(expected, o.peak_jaeger)
        o.eps_peak = expected / (0.5 * first.young)
        o.max_strain = 2.5 * o.eps_peak if max_strain is None else max_strain
    else:
        o.peak_mc = math.nan
        o.max_strain = 1e-3 if max_strain is None else max_strain
        o.eps_peak = o.max_strain / 2.5
    o.settle = (10.0 if confinement > 0 else 0.0) if settle_transits is None else settle_transits
    o.t1 = o.settle * o.transit
    o.rate = o.eps_peak / (rate_transits * o.transit)


def _compression_specimen(o, width, confinement, plane, platen, groups, joint_sets, safety, quasi_static,
                          handover_damage):
    """(spec, top, bot, sim): the specimen between its platens (speed ramped over 5 transits after
    the settling), the confining pressure ramped on its sides, built; sets ``o.build`` (wall time [s])."""
    W, t1, transit = width, o.t1, o.transit
    start = Curve([0.0, t1, t1 + 5 * transit], [0.0, 0.0, 1.0], name="platens") if t1 > 0 else \
        Curve([0.0, 5 * transit], [0.0, 1.0], name="platens")
    scene, spec, top, bot = platen_scene(o.mesh, o.material, platen_material=platen, plane=plane,
                                         fracture=o.fracture, strain_rate=o.rate, groups=groups,
                                         joint_sets=check_joint_sets(joint_sets, o.where))
    top.velocity_curve = start
    bot.velocity_curve = start
    if confinement > 0:
        tol = 1e-6 * W
        scene.apply_pressure(lambda x, y: np.abs(x) >= 0.5 * W - tol, confinement, body=spec,
                             curve=Curve.ramp(max(t1, transit), name="confinement"))
    t0 = _time.perf_counter()
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="bodies overlap", category=RuntimeWarning)
        sim = scene.build(safety=safety, quasi_static=quasi_static, handover_damage=handover_damage)
    o.build = _time.perf_counter() - t0
    return spec, top, bot, sim


def _compression_run(o, sim, spec, top, bot, width, height, confinement, samples, stop_drop, history, frame,
                     video):
    """Load the specimen in ``samples`` steps until ``o.max_strain`` or the drop below ``stop_drop`` × the
    peak: (rec, kin, wall), rec the (axial strain, axial stress, lateral strain, time) per sample, kin the
    specimen's kinetic/strain energy per sample, wall the run's wall time [s]."""
    W, H, t1, transit = width, height, o.t1, o.transit
    writer, draw = video_frames(video, (-0.9 * W, 0.9 * W, -0.68 * H, 0.68 * H))
    duration = t1 + 5 * transit + o.max_strain / o.rate
    rec, kin = [], []
    t0 = _time.perf_counter()
    try:
        for _ in range(samples):
            # a specimen at rest has contact-energy round-off the energy guard would call growth:
            # check once the platens move (or the confinement works)
            sim.run(duration / samples, record=[History(history)] if history else [],
                    checks=Checks(energy=confinement > 0 or sim.time > t1 + 5 * transit))
            rec.append(axial_record(sim, spec, top, bot, H, W) + (sim.time,))
            en = sim.energies()
            kin.append(specimen_kinetic(sim, spec) / max(en["strain"], 1e-300))
            if frame is not None:
                frame(sim, rec[-1])
            if draw is not None:
                draw(sim)
            s = [r[1] for r in rec]
            if sim.time > t1 and s[-1] < stop_drop * max(s):
                break
    finally:
        if writer is not None:
            writer.close()
    return rec, kin, _time.perf_counter() - t0


def _compression_measure(o, sim, rec, kin, confinement, plane, rate_transits, wall):
    """(summary, curve) of :func:`compression` from its samples: the peak, the tangent elastic constants
    (warns when too few samples), the kinetic ratio at half the peak (warns above ``MAX_KINETIC_RATIO``)."""
    eps, sig, lat, times = (np.array(c) for c in zip(*rec))
    k = int(np.argmax(sig))
    young = poisson = e_p = nu_p = math.nan
    try:
        young, poisson, e_p, nu_p = elastic_constants(eps, sig, lat, plane)
    except ValueError as err:
        warnings.warn(f"{o.where}: {err}", RuntimeWarning, stacklevel=3)
    young0 = poisson0 = math.nan
    try:
        young0, poisson0, _, _ = elastic_constants(eps, sig, lat, plane, level=0.175, band=0.125)
    except ValueError:
        pass
    half = int(np.argmin(np.abs(sig[: k + 1] - 0.5 * sig[k])))
    kinetic_ratio = float(kin[half])
    warn_kinetic(kinetic_ratio, o.where, stacklevel=4)
    summary = dict(peak_stress=float(sig[k]), peak_strain=float(eps[k]), young=young, poisson=poisson,
                   young_initial=young0, poisson_initial=poisson0, plane_modulus=e_p, plane_poisson=nu_p,
                   confinement=float(confinement), peak_mc=o.peak_mc, peak_jaeger=o.peak_jaeger,
                   broken=sim.cracks.broken_count,
                   kinetic_ratio=kinetic_ratio, rate_transits=float(rate_transits), strain_rate=float(o.rate),
                   wall=wall, build=o.build, steps=sim.step_count, dt=sim.dt)
    curve = dict(time_s=times, axial_strain=eps, axial_stress_Pa=sig, lateral_strain=lat)
    return summary, curve


def ucs(material, width: float, height: float, h: float, **kw) -> LabResult:
    """Unconfined compression (UCS) of a ``width`` × ``height`` [m] specimen, mesh size ``h`` [m].

    ``.peak_stress`` [Pa] (the UCS, or the largest stress reached), ``.young`` [Pa] and
    ``.poisson`` (tangent at 50 % of the peak, lateral over axial strain, corrected for the
    plane condition: plane strain by default, E' = E/(1 − ν²), ν' = ν/(1 − ν)), ``.curve``.
    An elastic specimen (no fracture) returns its material's E and ν.  ``bedding_angle``
    [degrees]: the angle between the bedding planes and the loading direction (0: loading
    parallel to the bedding, 90: across it; needs a material with a ``Bedding``), reported in
    ``.bedding_angle``.  Keywords: see :func:`compression`.
    """
    return compression(material, width, height, h, 0.0, test="ucs", **kw)


def triaxial(material, width: float, height: float, h: float, confinement: float, **kw) -> LabResult:
    """Triaxial (biaxial, in 2D) compression at a lateral pressure ``confinement`` = σ3 [Pa] of a
    ``width`` × ``height`` [m] specimen, mesh size ``h`` [m].  Summary as :func:`ucs`, plus
    ``.confinement``.  Feed a list of results to :func:`~taichi_fdem.lab.fit_envelope`.
    ``bedding_angle`` [degrees]: the angle between the bedding planes and σ1 (0: loading parallel
    to the bedding, 90: across it; needs a material with a ``Bedding``; Jaeger's β = 90° − it).
    Keywords: see :func:`compression`."""
    return compression(material, width, height, h, confinement, test="triaxial", **kw)

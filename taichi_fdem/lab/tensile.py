"""The Brazilian (indirect tensile) test of a disc between flat platens on flattened caps (docs/verification.md §8.8)."""
from __future__ import annotations

import math
import time as _time
import warnings

from ..verification.fracture import brazilian_load, brazilian_result, brazilian_scene, hondros_factor
from .compressive import _first, _positive, video_frames
from ..scene import quasi_static_alpha
from .results import (JOINT_PENALTY_FACTOR, LabResult, check_keyword, check_rate, convergence, lab_materials,
                      specimen_kinetic, warn_kinetic)
from .specimens import check_joint_sets


#: Defaults of :func:`brazilian` (each a keyword): the loading to the expected peak lasts
#: LOAD_TIME D/c_p, at SAFETY × the time-step estimate, with local damping (α = 0.7).
LOAD_TIME = 15.0
SAFETY = 0.2


def brazilian(material, diameter: float, h: float, *, alpha_deg: float = 10.0, load_time: float | None = None,
              samples: int = 240, safety: float | None = None, platen=None, strength=None, groups=None, mesh=None,
              plane: str = "strain", max_time: float = 3.0, joint_sets=(), video: str | None = None,
              quasi_static=None, joint_penalty_factor: float | None = None, check=None) -> LabResult:
    """Brazilian test of a disc of ``diameter`` D [m], mesh size ``h`` [m], every interior edge
    a cohesive joint, between two platens closing at ±v.

    Quasi-static settings, chosen from the material and the disc unless given (all reported
    in ``result.settings``): ``quasi_static`` local non-viscous damping (True: α = 0.7, see
    :meth:`Scene.build <taichi_fdem.scene.Scene.build>`; False turns it off and leaves only
    the material's own ``damping``); ``load_time`` (default ``LOAD_TIME`` = 15 D/c_p to the
    expected peak); ``safety`` of the time step (default ``SAFETY`` = 0.2 of the estimate: at
    0.35 the platen contact gains energy, the disc rings and splits early); the joint penalty
    ``joint_penalty_factor`` × E where the material leaves ``joint_penalty`` unset (default
    :data:`~taichi_fdem.lab.results.JOINT_PENALTY_FACTOR` = 50; at the Material default of
    10 E the joints' tractions scatter about the elastic field and the disc splits early).
    The material given is never changed: the test builds on a copy (``result.material``).

    Platen contact (ISRM's loading arc): the disc's caps are flattened over ±``alpha_deg``
    (10° by default, the arc ISRM's curved jaws load) so the load spreads over a few
    elements: on a round disc the point load crushes the joints under the platen first and the
    test splits at about half the strength.  The centre stress of a load spread over 2α is
    (sin 2α − α)/α times 2P/(πD) (Hondros; 0.96 at ±10°): ``.peak_stress`` is the standard
    σ_t = 2P/(πDt) [Pa] (t = 1: loads per unit thickness), ``.centre_stress`` that times the
    Hondros factor (the one to compare with f_t).  The load P is the platens' work over a
    window of D/c_p divided by their approach (filters contact chatter and ringing).

    ``check``: None, "rate", "mesh" or "both": rerun at half the loading rate (``load_time`` ×
    2) and/or half ``h`` with the same settings, and put the relative change of
    ``peak_stress`` in ``result.convergence`` (e.g. ``{"rate": 0.004}``).

    ``material``: a Material or a dict of Materials with ``groups`` (labels per triangle of
    ``mesh``, a disc centred on the origin).  ``joint_sets``: (name, selector, Material) triples
    added with :meth:`Scene.add_joint_set` (e.g. ``[("grain_boundaries", "interfaces", weak)]``).
    ``platen``: the platens' Material (default: 10 × stiffer, penalty 3 × the disc's E).
    ``load_time`` below ``MIN_TRANSITS`` is refused.  The test stops when the load has dropped
    below 30 % of its peak (``peaked`` True), or after ``max_time`` × the loading time
    (``peaked`` False, with a RuntimeWarning: the peak is then the last load reached, not the
    strength).

    Similarity: the result depends on the dimensionless groups f_t/E, l_ch/D = E G_I/(f_t² D),
    c/f_t, φ, G_II/G_I, ν, p_f/E, the platens' E and penalty over the disc's E, h/D, α, β and
    ``load_time``; with all of them fixed, ``.peak_stress`` is proportional to f_t
    (tests/test_lab.py checks it to 1e-6).  A disc of only a few l_ch splits above f_t (the
    size effect of a cohesive crack).

    Curve columns: time_s, approach_m, load_N_per_m (filtered), load_instantaneous_N_per_m,
    broken_joints.  Summary: peak_stress [Pa], centre_stress [Pa], peak_load [N/m], hondros,
    central_fraction (share of the joints broken by shortly after the peak within ``|x|`` < 0.15 D:
    where the split starts), broken, fragments, kinetic_ratio, peaked.
    """
    first = _first(material)
    _positive("lab.brazilian", diameter=diameter, h=h)
    if not first.can_fracture:
        raise ValueError("lab.brazilian: the disc's material needs tensile_strength [Pa] and fracture_energy [J/m²]")
    reruns = check_keyword(check, "lab.brazilian")
    load_time = LOAD_TIME if load_time is None else load_time
    safety = SAFETY if safety is None else safety
    quasi_static = True if quasi_static is None else quasi_static
    factor = JOINT_PENALTY_FACTOR if joint_penalty_factor is None else joint_penalty_factor
    check_rate(load_time, "lab.brazilian")
    if not (math.isfinite(max_time) and max_time >= 1.0):
        raise ValueError(f"lab.brazilian: max_time must be >= 1 (loading times), got {max_time!r}")
    mat, pf, raised = lab_materials(material, factor, "lab.brazilian")
    elements = max(2, int(round(diameter / h)))
    t0 = _time.perf_counter()
    sim, bodies, p = brazilian_scene(elements=elements, load_time=load_time, D=diameter, alpha_deg=alpha_deg,
                                     safety=safety, strength=strength, material=mat, platen=platen,
                                     groups=groups, disc_mesh=mesh, plane=plane,
                                     joint_sets=check_joint_sets(joint_sets, "lab.brazilian"),
                                     quasi_static=quasi_static)
    build = _time.perf_counter() - t0
    writer, draw = video_frames(video, (-0.75 * diameter, 0.75 * diameter, -0.75 * diameter, 0.75 * diameter),
                                (320, 320))
    kin = []

    def frame(s):
        en = s.energies()
        kin.append(specimen_kinetic(s, bodies[0]) / max(en["strain"], 1e-300))
        if draw is not None:
            draw(s)
    t0 = _time.perf_counter()
    try:
        rec = brazilian_load(sim, bodies, p, samples=samples, frame=frame, duration=max_time)
    finally:
        if writer is not None:
            writer.close()
    wall = _time.perf_counter() - t0
    out = brazilian_result(sim, bodies, rec, p)
    i = int(out["_peak_index"]) if "_peak_index" in out else int(rec["P"].argmax())
    half = int(abs(rec["P"][: i + 1] - 0.5 * rec["P"][i]).argmin())
    kinetic_ratio = float(kin[max(0, half - 1)]) if kin else math.nan
    warn_kinetic(kinetic_ratio, "lab.brazilian")
    peaked = bool(rec["broken"][-1] > 0 and rec["P"][-1] < 0.3 * rec["P"].max())
    if not peaked:
        warnings.warn(f"lab.brazilian: the load had not dropped after {max_time:g} loading times: the peak is the "
                      "last load reached, not the strength (raise max_time)", RuntimeWarning, stacklevel=2)
    sigma = 2.0 * out["P_max_N_per_m"] / (math.pi * diameter)
    hf = hondros_factor(alpha_deg)
    summary = dict(peak_stress=sigma, centre_stress=sigma * hf, peak_load=out["P_max_N_per_m"], hondros=hf,
                   central_fraction=out["central_fraction"], broken=out["broken_total"], fragments=out["fragments"],
                   kinetic_ratio=kinetic_ratio, peaked=peaked, load_time=float(load_time), elements=elements, wall=wall,
                   build=build, steps=sim.step_count, dt=sim.dt, platen_speed=p["v"])
    pm = p["platen"]
    settings = dict(quasi_static=quasi_static_alpha(quasi_static), damping=float(first.damping),
                    load_time=float(load_time), platen_speed=float(p["v"]), safety=float(safety), dt=float(sim.dt),
                    joint_penalty=pf, joint_penalty_factor=pf / first.young, joint_penalty_raised=raised,
                    platen_young=float(pm.young), platen_penalty=float(pm.contact_penalty),
                    platen_friction=float(pm.friction), alpha_deg=float(alpha_deg), elements=elements)
    curve = dict(time_s=rec["t_P"], approach_m=rec["approach_P"], load_N_per_m=rec["P"],
                 load_instantaneous_N_per_m=rec["P_inst"], broken_joints=rec["broken"])
    result = LabResult("brazilian", curve, summary, sim=sim, bodies=bodies, material=mat, settings=settings)
    if reruns:
        kw = dict(alpha_deg=alpha_deg, load_time=load_time, samples=samples, safety=safety, platen=platen,
                  strength=strength, groups=groups, mesh=mesh, plane=plane, max_time=max_time,
                  joint_sets=joint_sets, quasi_static=quasi_static, joint_penalty_factor=factor)
        if mesh is not None and "mesh" in reruns:
            raise ValueError("lab.brazilian: check='mesh' needs the default mesh (mesh=None): a given mesh "
                             "cannot be refined here")
        runs = {}
        if "rate" in reruns:
            runs["rate"] = brazilian(material, diameter, h, **dict(kw, load_time=2.0 * load_time))
        if "mesh" in reruns:
            runs["mesh"] = brazilian(material, diameter, 0.5 * h, **kw)
        result.convergence = convergence(result, runs)
    return result

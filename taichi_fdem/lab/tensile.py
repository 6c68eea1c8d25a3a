"""The Brazilian (indirect tensile) test of a disc between flat platens (docs/verification.md §8.8)."""
from __future__ import annotations

import math
import time as _time

from ..verification.fracture import brazilian_load, brazilian_result, brazilian_scene, hondros_factor
from .compressive import _first, _positive, video_frames
from .results import LabResult, check_rate, specimen_kinetic, warn_kinetic


def brazilian(material, diameter: float, h: float, *, alpha_deg: float = 10.0, load_time: float = 100.0,
              samples: int = 240, safety: float = 0.35, platen=None, strength=None, groups=None, mesh=None,
              plane: str = "strain", video: str | None = None) -> LabResult:
    """Brazilian test of a disc of ``diameter`` D [m], mesh size ``h`` [m], every interior edge
    a cohesive joint, between two platens closing at ±v.

    Platen contact: the disc's caps are flattened over ±``alpha_deg`` (10° by default) so the
    load spreads over a few elements: on a round disc the point load crushes the joints under
    the platen first and the test splits at about half the strength.  The centre stress of a
    load spread over 2α is (sin 2α − α)/α times 2P/(πD) (Hondros; 0.96 at ±10°): ``.peak_stress``
    is the standard σ_t = 2P/(πDt) [Pa] (t = 1: loads per unit thickness), ``.centre_stress``
    that times the Hondros factor (the one to compare with f_t).  The load P is the platens'
    work over a window of D/c_p divided by their approach (filters contact chatter and ringing).

    ``material``: a Material or a dict of Materials with ``groups`` (labels per triangle of
    ``mesh``, a disc centred on the origin).  ``platen``: the platens' Material (default:
    10 × stiffer, penalty 3 × the disc's E).  ``load_time``: the loading to the expected peak
    (approach 5.6 D f_t/E) lasts this many D/c_p; below ``MIN_TRANSITS`` it is refused.  The test
    stops when the load has dropped below 30 % of its peak.

    Curve columns: time_s, approach_m, load_N_per_m (filtered), load_instantaneous_N_per_m,
    broken_joints.  Summary: peak_stress [Pa], centre_stress [Pa], peak_load [N/m], hondros,
    central_fraction (share of the joints broken by shortly after the peak within ``|x|`` < 0.15 D),
    broken, fragments, kinetic_ratio.
    """
    first = _first(material)
    _positive("lab.brazilian", diameter=diameter, h=h)
    if not first.can_fracture:
        raise ValueError("lab.brazilian: the disc's material needs tensile_strength [Pa] and fracture_energy [J/m²]")
    check_rate(load_time, "lab.brazilian")
    elements = max(2, int(round(diameter / h)))
    t0 = _time.perf_counter()
    sim, bodies, p = brazilian_scene(elements=elements, load_time=load_time, D=diameter, alpha_deg=alpha_deg,
                                     safety=safety, strength=strength, material=material, platen=platen,
                                     groups=groups, disc_mesh=mesh, plane=plane)
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
        rec = brazilian_load(sim, bodies, p, samples=samples, frame=frame)
    finally:
        if writer is not None:
            writer.close()
    wall = _time.perf_counter() - t0
    out = brazilian_result(sim, bodies, rec, p)
    i = int(out["_peak_index"]) if "_peak_index" in out else int(rec["P"].argmax())
    half = int(abs(rec["P"][: i + 1] - 0.5 * rec["P"][i]).argmin())
    kinetic_ratio = float(kin[max(0, half - 1)]) if kin else math.nan
    warn_kinetic(kinetic_ratio, "lab.brazilian")
    sigma = 2.0 * out["P_max_N_per_m"] / (math.pi * diameter)
    hf = hondros_factor(alpha_deg)
    summary = dict(peak_stress=sigma, centre_stress=sigma * hf, peak_load=out["P_max_N_per_m"], hondros=hf,
                   central_fraction=out["central_fraction"], broken=out["broken_total"], fragments=out["fragments"],
                   kinetic_ratio=kinetic_ratio, load_time=float(load_time), elements=elements, wall=wall,
                   build=build, steps=sim.step_count, dt=sim.dt, platen_speed=p["v"])
    curve = dict(time_s=rec["t_P"], approach_m=rec["approach_P"], load_N_per_m=rec["P"],
                 load_instantaneous_N_per_m=rec["P_inst"], broken_joints=rec["broken"])
    return LabResult("brazilian", curve, summary, sim=sim, bodies=bodies, material=material)

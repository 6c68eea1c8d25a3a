"""Verification cases of loads and rock mechanics (docs/theory/loads.md §12.6): Kirsch, Lamé, uniaxial
compression between platens, triaxial strength of a jointed specimen.

All of them load through the public API (``apply_traction`` / ``apply_pressure``, prescribed
platen velocities with ``Curve`` ramps, ``sim.reaction``) and settle with
``build(quasi_static=True)`` (local non-viscous damping) where a static answer is wanted.
"""
from __future__ import annotations

import math
import time as _time

import numpy as np

from .. import mesh
from ..material import Material
from ..mesh import TriMesh
from ..scene import Curve, Scene
from ._common import E, NU, RHO, _build, _precision, _result
from ..lab.specimens import axial_record, jointed_specimen_mesh, mohr_coulomb_peak, platen_scene  # noqa: F401



def _settle(sim, chunk: int, max_steps: int) -> None:
    """Step ``sim`` in chunks until its kinetic energy is below 1e-8 of its strain energy (a
    quasi-static answer) or ``max_steps`` steps have run."""
    while sim.step_count < max_steps:
        sim.step(chunk)
        en = sim.energies()
        if en["kinetic"] <= 1e-8 * en["strain"]:
            break

def _polar_stress(sim, body=None):
    """(r, θ, σ_rr, σ_θθ, σ_rθ) at the triangles' initial centroids about the origin."""
    T = sim.stresses(body)
    tri = sim.model.tri_nodes_np if body is None else sim.model.tri_nodes_np[body.triangles]
    c = sim.model.node_rest[tri].mean(axis=1)
    r = np.hypot(c[:, 0], c[:, 1])
    th = np.arctan2(c[:, 1], c[:, 0])
    co, si = np.cos(th), np.sin(th)
    sxx, syy, sxy = T[:, 0, 0], T[:, 1, 1], T[:, 0, 1]
    srr = sxx * co * co + syy * si * si + 2 * sxy * si * co
    stt = sxx * si * si + syy * co * co - 2 * sxy * si * co
    srt = (syy - sxx) * si * co + sxy * (co * co - si * si)
    return r, th, srr, stt, srt


def _wall_value(r, th, values, a, theta0, dtheta, layers):
    """A stress at the wall r = a, θ = θ0: a least-squares fit v = c0 + c1 (r − a) + c2 (θ − θ0)²
    to the triangles within ``dtheta`` of θ0 and ``layers`` cells of the wall, evaluated at
    (a, θ0) (CST stresses are constant per triangle; their centroids lie off the wall)."""
    dth = np.angle(np.exp(1j * (th - theta0)))
    sel = (np.abs(dth) <= dtheta) & (r <= a + layers)
    A = np.stack([np.ones(sel.sum()), r[sel] - a, dth[sel] ** 2], axis=1)
    coef, *_ = np.linalg.lstsq(A, values[sel], rcond=None)
    return float(coef[0]), int(sel.sum())


def kirsch_hoop(sigma: float, a: float, r, theta):
    """Kirsch's hoop stress σ_θθ(r, θ) [Pa] around a hole of radius a in an infinite plate under
    uniaxial σ along x (docs/theory/loads.md §12.6): at the wall 3σ at θ = 90°, −σ at θ = 0."""
    q = (a / np.asarray(r)) ** 2
    return 0.5 * sigma * (1 + q) - 0.5 * sigma * (1 + 3 * q * q) * np.cos(2 * np.asarray(theta))


def case_kirsch(resolution: int = 32, safety: float = 0.2, penalty_factor: float = 10.0, precision: str = "f64",
                ratio: float = 40.0, sigma: float = 1.0e5, plane: str = "strain", max_steps: int = 200_000) -> dict:
    """Kirsch: a square plate (width ``ratio`` × the hole radius a = 0.01 m) with a central hole,
    pulled by a uniaxial traction σ along x (docs/theory/loads.md §12.6).  A quarter is modelled (rollers on
    the symmetry axes), meshed by :func:`~taichi_fdem.mesh.plate_with_hole`; ``resolution`` cells
    along the quarter of the hole (cells ~ π a / (2 resolution) at the wall, graded outwards).

    The traction (σ, 0) on the right edge is ramped over 4 transit times of a P-wave across the
    plate with ``quasi_static=True`` and held until the kinetic energy has fallen below 1e-8 of
    the strain energy.  The hoop stress at the wall is recovered from the triangles of the first
    few cells (a least-squares fit in r and θ, extrapolated to r = a) at θ = 90° (analytic 3σ)
    and θ = 0 (−σ).  The plate's finite width raises both by about (1 + 1.2 (2a/W)²) (Howland):
    at W = 40a, +0.08 %, inside the tolerance; it is not corrected.
    error = the larger relative error of the two.
    """
    _precision(precision)
    a = 0.01
    W = ratio * a
    h_hole = 0.5 * math.pi * a / resolution
    full = mesh.plate_with_hole(W, W, a, h_hole)
    cen = full.points[full.triangles].mean(axis=1)
    quarter = TriMesh(full.points, full.triangles[(cen[:, 0] > 0) & (cen[:, 1] > 0)]).compact()
    mat = Material(density=RHO, young=E, poisson=NU)
    scene = Scene(gravity=(0.0, 0.0), plane=plane)
    body = scene.add_body(quarter, mat, name="plate")
    tol = 1e-9 * W
    scene.fix_nodes(lambda x, y: np.abs(x) <= tol, velocity=(0.0, None))
    scene.fix_nodes(lambda x, y: np.abs(y) <= tol, velocity=(None, 0.0))
    cp = mat.p_wave_speed(plane)
    t_ramp = 4.0 * W / cp
    scene.apply_traction(lambda x, y: x >= 0.5 * W - tol, (sigma, 0.0), curve=Curve.ramp(t_ramp))
    sim, build = _build(scene, safety, quasi_static=True)
    t0 = _time.perf_counter()
    sim.run(t_ramp)
    chunk = max(1, int(0.5 * W / cp / sim.dt))
    _settle(sim, chunk, max_steps)
    wall = _time.perf_counter() - t0
    r, th, srr, stt, srt = _polar_stress(sim, body)
    dr = h_hole                                      # first cells are about h_hole deep
    top, n_top = _wall_value(r, th, stt, a, 0.5 * math.pi, 2.5 * h_hole / a, 3 * dr)
    side, n_side = _wall_value(r, th, stt, a, 0.0, 2.5 * h_hole / a, 3 * dr)
    e_top = abs(top - 3 * sigma) / (3 * sigma)
    e_side = abs(side + sigma) / sigma
    # the stress field away from the wall (r > 2a, inside the quarter disc of radius W/4)
    far = (r > 2 * a) & (r < 0.25 * W)
    field = float(np.sqrt(np.mean((stt[far] - kirsch_hoop(sigma, a, r[far], th[far])) ** 2)) / sigma)
    return _result(sim, wall, build, error=max(e_top, e_side), hoop_top=top, hoop_side=side,
                   hoop_top_analytic=3 * sigma, hoop_side_analytic=-sigma, error_top=e_top, error_side=e_side,
                   field_rms=field, h_hole=h_hole, samples=(n_top, n_side))


def lame(p: float, a: float, b: float, r, plane: str = "strain", young: float = E, poisson: float = NU):
    """Lamé's thick cylinder a < r < b under internal pressure p (docs/theory/loads.md §12.6):
    (σ_rr, σ_θθ, u_r) at r [Pa, Pa, m]; u_r of plane strain or plane stress (σ_zz free)."""
    r = np.asarray(r, dtype=np.float64)
    k = p * a * a / (b * b - a * a)
    srr = k * (1 - b * b / (r * r))
    stt = k * (1 + b * b / (r * r))
    Ee, nue = (young, poisson) if plane == "stress" else (young / (1 - poisson ** 2), poisson / (1 - poisson))
    u = k / Ee * ((1 - nue) * r + (1 + nue) * b * b / r)
    return srr, stt, u


def case_lame(resolution: int = 8, safety: float = 0.2, penalty_factor: float = 10.0, precision: str = "f64",
              p: float = 1.0e5, ratio: float = 2.0, plane: str = "strain", max_steps: int = 200_000) -> dict:
    """Lamé: a thick-walled cylinder (inner radius a = 0.05 m, outer ``ratio`` a) under an internal
    pressure p (``apply_pressure`` on the bore, ramped, ``quasi_static=True``), docs/theory/loads.md §12.6.
    ``resolution`` elements through the wall (:func:`~taichi_fdem.mesh.annulus`).  The body is
    free: the pressure is self-balanced, nothing else holds it.

    Checked: the mean radial displacement of the bore and of the outer surface against u_r(a),
    u_r(b) (the inscribed polygons of the mesh are ~0.1 % smaller than the circles: not
    corrected), and the area-weighted mean hoop stress of each of the ``resolution`` rings of
    triangles against the analytic mean over the ring (the worst ring, relative to σ_θθ(a)).
    error = the largest of the three.
    """
    _precision(precision)
    a = 0.05
    b = ratio * a
    h = (b - a) / resolution
    mat = Material(density=RHO, young=E, poisson=NU)
    scene = Scene(gravity=(0.0, 0.0), plane=plane)
    body = scene.add_body(mesh.annulus(a, b, h), mat, name="cylinder")
    cp = mat.p_wave_speed(plane)
    t_ramp = 4.0 * 2 * b / cp
    scene.apply_pressure(lambda x, y: np.hypot(x, y) <= a * (1 + 1e-6), p, curve=Curve.ramp(t_ramp))
    sim, build = _build(scene, safety, quasi_static=True)
    t0 = _time.perf_counter()
    sim.run(t_ramp)
    chunk = max(1, int(b / cp / sim.dt))
    sim.step(4 * chunk)
    _settle(sim, chunk, max_steps)
    wall = _time.perf_counter() - t0
    X = sim.model.node_rest[body.nodes]
    R = np.hypot(X[:, 0], X[:, 1])
    u = sim.node_displacements(body)
    ur = (u * X).sum(1) / R
    inner, outer = R <= a * (1 + 1e-6), R >= b * (1 - 1e-6)
    _, _, ua_th = lame(p, a, b, a, plane)
    _, _, ub_th = lame(p, a, b, b, plane)
    ua, ub = float(ur[inner].mean()), float(ur[outer].mean())
    r, th, srr, stt, srt = _polar_stress(sim, body)
    area = body.mesh.areas
    _, stt_a, _ = lame(p, a, b, a, plane)
    # area-weighted mean hoop stress of each ring of triangles against the analytic mean
    # k [ (r2² − r1²)/2 + b² ln(r2/r1) ] / ((r2² − r1²)/2) over the ring
    edges = np.linspace(a, b, resolution + 1)
    band = np.clip(np.searchsorted(edges, r) - 1, 0, resolution - 1)
    k = p * a * a / (b * b - a * a)
    worst = 0.0
    for i in range(resolution):
        s = band == i
        r1, r2 = edges[i], edges[i + 1]
        half = 0.5 * (r2 * r2 - r1 * r1)
        mean_th = k * (half + b * b * math.log(r2 / r1)) / half
        worst = max(worst, abs(float((stt[s] * area[s]).sum() / area[s].sum()) - mean_th) / stt_a)
    e_a, e_b = abs(ua - ua_th) / ua_th, abs(ub - ub_th) / ub_th
    return _result(sim, wall, build, error=max(e_a, e_b, worst), u_inner=ua, u_inner_analytic=float(ua_th),
                   u_outer=ub, u_outer_analytic=float(ub_th), error_u_inner=float(e_a), error_u_outer=float(e_b),
                   hoop_ring_error=worst, h=h)


# ------------------------------------------------------------------------------------------------
# compression between platens
# ------------------------------------------------------------------------------------------------
def case_uniaxial(resolution: int = 8, safety: float = 0.2, penalty_factor: float = 10.0, precision: str = "f64",
                  plane: str = "strain", strain: float = 1e-3) -> dict:
    """Uniaxial compression of an elastic specimen (0.05 × 0.1 m) between frictionless platens
    (docs/theory/loads.md §12.6): the modulus from the stress–strain curve against E/(1 − ν²) (plane
    strain) or E (plane stress), and Poisson's ratio from the lateral strain against ν/(1 − ν)
    (plane strain) or ν.

    ``resolution`` elements across the width.  The platens close at a nominal strain rate such
    that the loading to ``strain`` lasts 100 P-wave transits of the specimen (ramped over the
    first 10 %); ``quasi_static=True``.  Stress = the platens' mean reaction / width; strain =
    the relative displacement of the specimen's end faces / height (as a pair of axial gauges:
    the platen travel also holds the contact penetration, ~p⁻¹ of the load).  The modulus is the
    least-squares slope of stress against strain over the second half of the loading.
    error = ``|E_measured − E_analytic|`` / E_analytic.
    """
    _precision(precision)
    W, H = 0.05, 0.1
    mat = Material(density=RHO, young=E, poisson=NU, penalty=penalty_factor * E)
    cp = mat.p_wave_speed(plane)
    T = 100.0 * H / cp
    rate = strain / (0.95 * T)
    scene, spec, top, bot = platen_scene(mesh.rectangle(W, H, W / resolution), mat, plane=plane,
                                         strain_rate=rate, t_ramp=0.1 * T)
    sim, build = _build(scene, safety, quasi_static=True)
    t0 = _time.perf_counter()
    n = 60
    rec = []
    for i in range(n):
        sim.run(T / n)
        rec.append(axial_record(sim, spec, top, bot, H, W))
    wall = _time.perf_counter() - t0
    eps, sig, lat = (np.array(c) for c in zip(*rec))
    half = slice(n // 2, n)
    slope = float(np.polyfit(eps[half], sig[half], 1)[0])
    nu_m = float(np.polyfit(eps[half], lat[half], 1)[0])
    E_th = E / (1 - NU ** 2) if plane == "strain" else E
    nu_th = NU / (1 - NU) if plane == "strain" else NU
    err = abs(slope - E_th) / E_th
    return _result(sim, wall, build, error=err, modulus=slope, modulus_analytic=E_th, poisson_apparent=nu_m,
                   poisson_analytic=nu_th, error_poisson=abs(nu_m - nu_th) / nu_th, peak_strain=float(eps[-1]),
                   peak_stress=float(sig[-1]))


# ------------------------------------------------------------------------------------------------
# triaxial strength of a jointed specimen
# ------------------------------------------------------------------------------------------------
#: the jointed rock of the triaxial case and demos: E = 100 MPa, joints c = f_t = 0.1 MPa, φ = 30°
TRIAXIAL_MATERIAL = dict(density=RHO, young=E, poisson=NU, friction=0.5, tensile_strength=1e5, cohesion=1e5,
                         friction_angle=30.0, fracture_energy=20.0, fracture_energy_shear=100.0)


def triaxial_test(sigma3: float, resolution: int = 6, safety: float = 0.2, material: dict | None = None,
                  strain_rate_transits: float = 60.0, max_strain: float | None = None, samples: int = 150,
                  stop_drop: float = 0.8,
                  video: str | None = None, history: str | None = None, frame=None, quasi_static=True,
                  penalty_factor: float = 10.0, handover_damage: float | None = None):
    """Run one triaxial (σ3 > 0) or unconfined (σ3 = 0) compression of a jointed specimen
    0.05 × 0.1 m (``resolution`` elements across its width, ``fracture=True``).

    Phase 1: the confining pressure σ3 [Pa, compression positive] on the two sides is ramped
    over 10 P-wave transits with the platens still.  Phase 2: the frictionless platens close at
    a nominal strain rate that reaches the Mohr–Coulomb peak strain in ``strain_rate_transits``
    transits, until ``max_strain`` (default 2.5 × the peak strain of Mohr–Coulomb) or until the
    axial stress has dropped below ``stop_drop`` × its peak.  ``frame(sim, record)`` is called at each of
    the ``samples`` records (for videos).  Returns a dict: strain, stress, lateral strain arrays
    (compression positive; stress = the platens' mean reaction / width), the peak, the MC peak,
    the simulation and its bodies; ``lab``: the :class:`~taichi_fdem.lab.LabResult` of
    :func:`taichi_fdem.lab.compression`, which runs the test (one copy of the set-up).
    """
    from ..lab.compressive import compression
    mp = dict(TRIAXIAL_MATERIAL if material is None else material)
    mp.setdefault("joint_penalty", penalty_factor * mp["young"])
    W, H = 0.05, 0.1
    r = compression(Material(**mp), W, H, W / resolution, sigma3, fracture=True, rate_transits=strain_rate_transits,
                    settle_transits=10.0, max_strain=max_strain, samples=samples, stop_drop=stop_drop, safety=safety,
                    quasi_static=quasi_static, handover_damage=handover_damage, video=video, history=history,
                    frame=frame, test="triaxial" if sigma3 > 0 else "ucs")
    c = r.curve
    return dict(sim=r.sim, bodies=r.bodies, strain=c["axial_strain"], stress=c["axial_stress_Pa"],
                lateral=c["lateral_strain"], time=c["time_s"], peak=r.peak_stress, peak_strain=r.peak_strain,
                peak_mc=r.peak_mc, sigma3=sigma3, wall=r.wall, build=r.build, broken=r.broken, material=r.material,
                lab=r)


def case_triaxial(resolution: int = 6, safety: float = 0.2, penalty_factor: float = 10.0, precision: str = "f64",
                  confinements=(0.0, 1e5), handover_damage: float | None = None) -> dict:
    """Peak strength of a jointed specimen (``fracture=True``, joints with c = 0.1 MPa, φ = 30°,
    f_t = c) under confinements σ3 (0 and 0.1 MPa by default), against Mohr–Coulomb of the
    joints' c and φ (docs/theory/loads.md §12.6):

        σ1 = σ3 (1 + sin φ)/(1 − sin φ) + 2 c cos φ/(1 − sin φ)

    Reading of the theory.  A joint fails in shear when ``|τ|`` = c − σ_n tan φ on its plane
    (docs/theory/joints.md §7.7, compression negative).  Under a uniform stress (σ1 axial, σ3 lateral) the
    plane that reaches this first is inclined at 45° + φ/2 to the σ3 direction, and there the
    condition is exactly the formula above.  The specimen is meshed on a hexagonal lattice whose
    edges (the joints) run at 0° and ±60°: for φ = 30° the ±60° lattice lines *are* the critical
    planes, continuous through the specimen, so the peak should follow the formula.  (A mesh
    without joints at that angle would be stronger: only at 45°, σ1 = σ3 (1 + tan φ)/(1 − tan φ)
    + 2c/(1 − tan φ), +35 % at φ = 30°.)  The joints' shear softening (G_II = 100 J/m²) is slow
    against the slip at peak, so the failing plane carries its peak strength while it is fully
    mobilised; the platens are frictionless (uniform stress).  Not modelled by the formula: the
    joint compliance, the irregular cells along the specimen's edges, the stress the joints'
    tensile cut-off allows; tolerance 10 %.

    ``handover_damage``: ``Scene.build``'s, None its default (a damaged joint that carries its pair keeps the
    pair's friction share in its shear strength, which raises the unconfined peak).  Returns the
    peaks, the MC peaks, the fitted (c, φ) of the specimen from the two peaks, and error = the
    largest relative error of the peaks.
    """
    _precision(precision)
    peaks, mcs, walls, steps, builds = [], [], 0.0, 0, 0.0
    sim = None
    for s3 in confinements:
        r = triaxial_test(s3, resolution=resolution, safety=safety, penalty_factor=penalty_factor,
                          handover_damage=handover_damage)
        peaks.append(r["peak"])
        mcs.append(r["peak_mc"])
        walls += r["wall"]
        builds += r["build"]
        steps += r["sim"].step_count
        sim = r["sim"]
    errs = [abs(p - m) / m for p, m in zip(peaks, mcs)]
    fit = {}
    if len(confinements) >= 2:
        slope, icpt = np.polyfit(confinements, peaks, 1)      # σ1 = N σ3 + 2 c √N
        if slope > 1:
            fit = dict(fitted_phi=math.degrees(math.asin((slope - 1) / (slope + 1))),
                       fitted_cohesion=icpt / (2 * math.sqrt(slope)))
    out = _result(sim, walls, builds, error=max(errs), peaks=peaks, peaks_mc=mcs, errors=errs,
                  confinements=list(confinements), **fit)
    out["steps"] = steps
    return out

"""Verification cases of fluid in fractures with the engine (docs/theory/hydro.md §14.2): Sneddon's
pressurised crack and the KGD hydraulic fracture, against :mod:`.hydro`.

The plates are meshed by :func:`crack_plate_mesh`, a tensor-product mesh graded away from the
crack line: cells of size h along the crack and next to it, growing geometrically towards the
edges of a plate many crack lengths wide, so that the far boundary costs few triangles.
"""
from __future__ import annotations

import math
import time as _time

import numpy as np

from .. import material as _material
from ..material import Material
from ..mesh import TriMesh
from ..scene import Curve, Scene
from ._common import _build, _precision, _result
from .hydro import GAMMA_M0, PI_M0_WELL, kgd_toughness, kgd_viscosity, plane_modulus, sneddon_opening


def _graded_axis(inner: float, outer: float, h: float, growth: float) -> np.ndarray:
    """Node coordinates on [0, outer]: spacing h up to ``inner``, then growing by ``growth`` per
    cell up to ``outer`` (the last cell stretched or merged to end there)."""
    n = max(1, int(round(inner / h)))
    xs = list(np.linspace(0.0, inner, n + 1)) if inner > 0 else [0.0]
    step = inner / n if inner > 0 else h
    while xs[-1] < outer - 1e-12 * outer:
        step *= growth
        xs.append(xs[-1] + step)
    if len(xs) > 2 and xs[-1] - outer > 0.5 * (xs[-1] - xs[-2]):
        xs.pop()
    xs[-1] = outer
    return np.asarray(xs)


def crack_plate_mesh(a: float, width: float, h: float, growth: float = 1.2, band: float | None = None) -> TriMesh:
    """A square plate of side ``width`` [m] centred on the origin, meshed for a crack along the x
    axis from −a to a: mesh lines at y = 0 and at x = ±a, cells h × h [m] over ``|x|`` ≤ a + band and
    ``|y|`` ≤ band (``band`` default 2h), growing by ``growth`` per cell outside.  Each cell is split
    along the diagonal that points away from the origin (the mesh is symmetric about both axes).

    The crack edges are the mesh edges on y = 0 with ``|x|`` ≤ a: select them with
    ``lambda x, y: (abs(y) < tol) & (abs(x) < a + tol)``.
    """
    where = "crack_plate_mesh"
    for name, v in (("a", a), ("width", width), ("h", h)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"{where}: {name} must be finite and > 0 [m], got {v!r}")
    if not (width > 2 * a + 4 * h):
        raise ValueError(f"{where}: width = {width} m leaves no room around the crack 2a = {2 * a} m")
    if not (1.0 <= growth <= 2.0):
        raise ValueError(f"{where}: growth must lie in [1, 2], got {growth!r}")
    band = 2.0 * h if band is None else float(band)
    na = max(1, int(round(a / h)))
    xa = np.linspace(0.0, a, na + 1)
    xo = a + _graded_axis(band, 0.5 * width - a, h, growth)[1:]
    xs = np.concatenate([xa, xo])
    ys = _graded_axis(band, 0.5 * width, h, growth)
    xs = np.concatenate([-xs[:0:-1], xs])
    ys = np.concatenate([-ys[:0:-1], ys])
    nx, ny = len(xs) - 1, len(ys) - 1
    gx, gy = np.meshgrid(xs, ys)
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
    i, j = np.meshgrid(np.arange(nx), np.arange(ny))
    i, j = i.ravel(), j.ravel()
    n00 = j * (nx + 1) + i
    n10, n01, n11 = n00 + 1, n00 + nx + 1, n00 + nx + 2
    cx, cy = 0.5 * (xs[i] + xs[i + 1]), 0.5 * (ys[j] + ys[j + 1])
    flip = (cx * cy) < 0.0               # diagonal n10-n01 in the 2nd and 4th quadrants
    t1 = np.where(flip[:, None], np.stack([n00, n10, n01], 1), np.stack([n00, n10, n11], 1))
    t2 = np.where(flip[:, None], np.stack([n10, n11, n01], 1), np.stack([n00, n11, n01], 1))
    return TriMesh(pts, np.stack([t1, t2], axis=1).reshape(-1, 3))


def _settle(sim, chunk: int, max_steps: int, tol: float = 1e-8) -> None:
    """Step in chunks until the kinetic energy is below ``tol`` of the strain energy."""
    while sim.step_count < max_steps:
        sim.step(chunk)
        en = sim.energies()
        if en["kinetic"] <= tol * max(en["strain"], 1e-300):
            break


def _opening_at(sim, body, x0: float, tol: float) -> float:
    """The normal opening [m] of the crack (y = 0) at x = x0: the y-displacement of the upper
    face's copy of the node there minus the lower face's."""
    X = sim.model.node_rest[body.nodes]
    u = sim.node_displacements(body)
    at = (np.abs(X[:, 0] - x0) < tol) & (np.abs(X[:, 1]) < tol)
    uy = u[at, 1]
    return float(uy.max() - uy.min())


def case_sneddon(resolution: int = 16, safety: float = 0.2, penalty_factor: float = 10.0, precision: str = "f64",
                 ratio: float = 20.0, p: float = 1.0e6, growth: float = 1.25, load: str = "fluid",
                 settle: float = 1e-6, strategy: str = "auto", max_steps: int = 200_000) -> dict:
    """Sneddon: a crack of half-length a = 1 m in a square plate ``ratio`` × a wide (free edges),
    opened by a uniform pressure p, settled quasi-statically (docs/theory/hydro.md §14.2).
    ``resolution`` cells along the half-crack (h = a/resolution; :func:`crack_plate_mesh`,
    graded by ``growth``).  ``load="fluid"``: the crack (``cracks=``) is the flow network and
    ``scene.inject(where=crack, pressure=p)`` holds p on every node of it; ``load="pressure"``:
    ``apply_pressure`` on the crack faces (the same follower load without the fluid).
    ``strategy`` goes to ``Scene.build``.

    The pressure is ramped over 4 P-wave transits of the plate with ``quasi_static=True`` and
    held until the kinetic energy is below ``settle`` times the strain energy.  Checked: the opening at
    the centre against 4 p a/E' (plane strain).  The finite plate opens the crack more than the
    infinite plane: about +0.6 % at ratio 20 (Tada's strip), not corrected.
    error = ``|w(0) − 4pa/E'|`` / (4pa/E').
    """
    _precision(precision)
    a, h = 1.0, 1.0 / resolution
    young, nu = 1.0e10, 0.25
    mat = Material(density=2500.0, young=young, poisson=nu, penalty=penalty_factor * young)
    tol = 1e-6 * h
    crack = lambda x, y: (np.abs(y) < tol) & (np.abs(x) < a + tol)   # noqa: E731
    scene = Scene(gravity=(0.0, 0.0), plane="strain")
    body = scene.add_body(crack_plate_mesh(a, ratio * a, h, growth), mat, name="plate", cracks=crack)
    cp = mat.p_wave_speed("strain")
    t_ramp = 4.0 * ratio * a / cp
    if load == "fluid":
        # every node is held at p: the fluid's stiffness plays no part, a compliant one keeps the step
        scene.set_fluid(_material.Fluid(density=1000.0, bulk_modulus=5.0e6, viscosity=1e-3), aperture_min=1e-5)
        scene.inject(crack, pressure=p, curve=Curve.ramp(t_ramp))
    elif load == "pressure":
        scene.apply_pressure(crack, p, curve=Curve.ramp(t_ramp))
    else:
        raise ValueError(f"case_sneddon: load must be 'fluid' or 'pressure', got {load!r}")
    sim, build = _build(scene, safety, quasi_static=True, strategy=strategy)
    t0 = _time.perf_counter()
    sim.run(t_ramp)
    chunk = max(1, int(ratio * a / cp / sim.dt))
    _settle(sim, chunk, max_steps, settle)
    wall = _time.perf_counter() - t0
    w0 = _opening_at(sim, body, 0.0, tol)
    w_th = float(sneddon_opening(0.0, a, p, young, nu))
    xs = np.array([0.5, 0.75]) * a
    w_mid = [_opening_at(sim, body, float(x), tol) for x in xs]
    return _result(sim, wall, build, error=abs(w0 - w_th) / w_th, opening=w0, opening_analytic=w_th,
                   opening_half=w_mid[0], opening_half_analytic=float(sneddon_opening(xs[0], a, p, young, nu)),
                   opening_3q=w_mid[1], opening_3q_analytic=float(sneddon_opening(xs[1], a, p, young, nu)),
                   h=h, plane_modulus=plane_modulus(young, nu))


# ------------------------------------------------------------------------------------------------
# KGD: a fracture driven along a line of joints by a constant injection rate
# ------------------------------------------------------------------------------------------------
_Z_AREA = 0.3863          # ∫_0^1 z(D) dD of the softening curve (docs/theory/joints.md §7.5)


def joint_fracture_energy(tensile_strength: float, fracture_energy: float, length: float,
                          joint_penalty: float) -> float:
    """The work per unit area [J/m²] that opens a joint of length ``length`` [m] fully in mode I,
    f_t (2 δ_p/3 + 0.3863 Δ_n) with δ_p = 2 L f_t/p_f, Δ_n = max(2 δ_p, 3 G_I/f_t)
    (docs/theory/joints.md §7.9): the fracture energy of the equivalent LEFM crack."""
    ft = float(tensile_strength)
    dp = 2.0 * length * ft / joint_penalty
    return ft * (2.0 * dp / 3.0 + _Z_AREA * max(2.0 * dp, 3.0 * fracture_energy / ft))


def _fracture_energy_for(g_eff: float, ft: float, length: float, joint_penalty: float) -> float:
    """G_I whose joint of length L takes ``g_eff`` to open fully (the inverse of
    :func:`joint_fracture_energy` on its softening-dominated branch)."""
    dp = 2.0 * length * ft / joint_penalty
    gi = (g_eff / ft - 2.0 * dp / 3.0) * ft / (3.0 * _Z_AREA)
    if 3.0 * gi / ft < 2.0 * dp:
        raise ValueError(f"kgd: the joints' pre-peak opening dominates (δ_p = {dp:g} m); raise joint_penalty")
    return gi


def kgd_scene(regime: str = "toughness", resolution: int = 16, ratio: float = 10.0, kappa: float | None = None,
              seed: float = 0.25, path: float = 2.0, length_end: float = 1.5, transits: float = 10.0,
              strain: float = 1.0e-3, process_cells: float = 2.0, bulk_modulus: float = 1.0e9,
              aperture_min: float = 1.0e-4, conduct: str = "damaged", confinement: float = 0.0,
              penalty_factor: float = 10.0):
    """The KGD scene (docs/theory/hydro.md §14.2): a plate ``ratio`` × ``path`` wide (free edges,
    plane strain, E = 10 GPa, ν = 0.25), a pre-existing crack ``|x|`` ≤ ``seed`` on y = 0, cohesive
    joints along y = 0 out to ``|x|`` = ``path`` [m], and a rate source at the centre node (the well).
    Cells h = 1/``resolution`` m along the path (:func:`crack_plate_mesh`).

    The material and fluid are chosen for the ``regime``'s vertex solution to reach the
    half-length ``length_end`` [m] after ``transits`` P-wave transits of the plate, with a net
    pressure of about ``strain`` × E' there:

    * "toughness": K_Ic = strain E' √π (p = strain E' at ℓ = 1 m), Q0 from the stored volume at
      ``length_end``, μ from Detournay's 𝒦 = ``kappa`` (default 6);
    * "viscosity": μ' and Q0 from the M-vertex ℓ and p(0) at the end, K_Ic from 𝒦 = ``kappa``
      (default 0.25).

    The joints' tensile strength puts ``process_cells`` cells in the cohesive length
    ℓ_c = E' G/f_t² = (K_Ic/f_t)², and their G_I is set so that the work to open a joint fully
    (:func:`joint_fracture_energy`) is K_Ic²/E'.  ``conduct="damaged"`` (default) lets the fluid
    into the joints past their peak, so that it reaches the process zone as it reaches the tip of
    the LEFM crack of the solution (no lag).  ``confinement`` σ0 [Pa]: a pressure on the plate's
    outer edges, ramped over 2 transits before the injection starts (info["start"]); it closes
    the dry part of the fracture ahead of the fluid, and the net pressure is p − σ0.
    ``penalty_factor``: the contact penalty of the crack faces in units of E.
    Returns (scene, body, info dict with the parameters: rate, viscosity, toughness,
    plane_modulus, duration, kappa, h, ...).
    """
    where = "kgd_scene"
    if regime not in ("toughness", "viscosity"):
        raise ValueError(f"{where}: regime must be 'toughness' or 'viscosity', got {regime!r}")
    young, nu, rho = 1.0e10, 0.25, 2500.0
    h = 1.0 / resolution
    ep = plane_modulus(young, nu)
    width = ratio * path
    mat0 = Material(density=rho, young=young, poisson=nu)
    cp = mat0.p_wave_speed("strain")
    duration = transits * width / cp
    if regime == "toughness":
        kappa = 6.0 if kappa is None else float(kappa)
        kic = strain * ep * math.sqrt(math.pi)
        q0 = 2.0 * math.sqrt(math.pi) * kic * length_end ** 1.5 / ep / duration
        kp = 4.0 * math.sqrt(2.0 / math.pi) * kic
        mu = kp ** 4 / (ep ** 3 * q0 * kappa ** 4) / 12.0
    else:
        kappa = 0.25 if kappa is None else float(kappa)
        mup = (strain * ep / PI_M0_WELL) ** 3 * duration / ep ** 2
        q0 = ((length_end / GAMMA_M0) ** 6 * mup / (ep * duration ** 4)) ** (1.0 / 3.0)
        mu = mup / 12.0
        kic = kappa * (ep ** 3 * mup * q0) ** 0.25 / (4.0 * math.sqrt(2.0 / math.pi))
    ft = kic / math.sqrt(process_cells * h)
    pf = 10.0 * young
    gi = _fracture_energy_for(kic * kic / ep, ft, h, pf)
    mat = Material(density=rho, young=young, poisson=nu, tensile_strength=ft, cohesion=3.0 * ft,
                   fracture_energy=gi, joint_penalty=pf, penalty=penalty_factor * young)
    tol = 1e-6 * h
    on_line = lambda x, y: np.abs(y) < tol                                           # noqa: E731
    crack = lambda x, y: on_line(x, y) & (np.abs(x) < seed + tol)                  # noqa: E731
    joints = lambda x, y: on_line(x, y) & (np.abs(x) > seed + tol) & (np.abs(x) < path + tol)  # noqa: E731
    scene = Scene(gravity=(0.0, 0.0), plane="strain")
    body = scene.add_body(crack_plate_mesh(path, width, h, 1.25), mat, name="plate", cracks=crack, fracture=joints)
    fluid = _material.Fluid(density=1000.0, bulk_modulus=bulk_modulus, viscosity=mu)
    scene.set_fluid(fluid, aperture_min=aperture_min, conduct=conduct)
    start, curve = 0.0, None
    if confinement > 0.0:
        start = 2.0 * width / cp
        outer = lambda x, y: (np.abs(x) > 0.5 * width - tol) | (np.abs(y) > 0.5 * width - tol)  # noqa: E731
        scene.apply_pressure(outer, confinement, curve=Curve.ramp(start))
        curve = Curve([0.0, start, start * (1 + 1e-9)], [0.0, 0.0, 1.0])
    scene.inject(lambda x, y: (np.abs(x) < tol) & (np.abs(y) < tol), rate=q0, curve=curve)
    info = {"rate": q0, "viscosity": mu, "toughness": kic, "plane_modulus": ep, "young": young, "poisson": nu,
            "duration": duration, "kappa": kappa, "h": h, "seed": seed, "tensile_strength": ft,
            "fracture_energy": gi, "cohesive_length": (kic / ft) ** 2, "regime": regime, "tol": tol,
            "start": start, "confinement": float(confinement)}
    return scene, body, info


def _half_lengths(sim, seed: float, confinement: float = 0.0) -> tuple:
    """Half-lengths [m] of the fracture: (broken, equivalent LEFM, wet).  *broken*: the seed and
    half the initial length of the broken joints (both wings); *equivalent LEFM*: that plus half
    of the softening joints' half (Irwin: the LEFM tip lies about halfway into the cohesive zone);
    *wet*: the largest ``|x|`` of the network nodes at a net pressure (less ``confinement``) above
    1 % of the well's."""
    d = sim.cracks.joint_damage()
    length = sim.cracks._joint_consts()["length"] if len(d) else np.zeros(0)
    broken = float(length[d >= 1.0].sum())
    soft = float(length[(d > 0.0) & (d < 1.0)].sum())
    pos, p = sim.fluid.pressures()
    wet = p - confinement > 0.01 * max(float(sim.fluid.injection_pressure()) - confinement, 1e-300)
    x_wet = float(np.abs(pos[wet, 0]).max()) if wet.any() else 0.0
    return seed + 0.5 * broken, seed + 0.5 * broken + 0.25 * soft, x_wet


def case_kgd(regime: str = "toughness", resolution: int = 16, safety: float = 0.2, penalty_factor: float = 10.0,
             precision: str = "f64", samples: int = 8, strategy: str = "serial", quasi_static=True,
             **scene_kw) -> dict:
    """KGD (docs/theory/hydro.md §14.2), the scene of :func:`kgd_scene`, run for its duration with
    ``samples`` records of the half-length ℓ of the equivalent LEFM crack (the seed, half the
    broken joints' length and a quarter of the softening ones': the LEFM tip lies about halfway
    into the cohesive zone),
    the opening at the well and the well pressure, each against the ``regime``'s vertex solution
    (:func:`~taichi_fdem.verification.hydro.kgd_toughness` or
    :func:`~taichi_fdem.verification.hydro.kgd_viscosity`) at the same time.

    The relative errors are taken over the records with an analytic ℓ of at least twice the seed
    (the fracture has then at least doubled its seed); ``error`` is the largest of the three.
    The result also holds the broken and the wet half-lengths (network nodes at a net pressure
    above 1 % of the well's) of each record.
    ``scene_kw`` go to :func:`kgd_scene`.
    """
    _precision(precision)
    scene, body, info = kgd_scene(regime, resolution, penalty_factor=penalty_factor, **scene_kw)
    sim, build = _build(scene, safety, quasi_static=quasi_static, strategy=strategy)
    t0 = _time.perf_counter()
    ref = kgd_toughness if regime == "toughness" else kgd_viscosity
    param = info["toughness"] if regime == "toughness" else info["viscosity"]
    rows = []
    if info["start"] > 0.0:
        sim.run(info["start"])
    w_start = _opening_at(sim, body, 0.0, info["tol"])
    for k in range(1, samples + 1):
        sim.run(info["start"] + info["duration"] * k / samples - sim.time)
        lb, ll, lw = _half_lengths(sim, info["seed"], info["confinement"])
        rows.append((sim.time - info["start"], ll, _opening_at(sim, body, 0.0, info["tol"]) - w_start,
                     float(sim.fluid.injection_pressure()) - info["confinement"], lb, lw))
    wall = _time.perf_counter() - t0
    rec = np.array(rows)
    sol = ref(rec[:, 0], info["rate"], info["young"], info["poisson"], param)
    use = sol.half_length >= 2.0 * info["seed"]
    err = {}
    for name, col, th in (("length", 1, sol.half_length), ("opening", 2, sol.well_opening),
                          ("pressure", 3, sol.well_pressure)):
        rel = np.abs(rec[:, col] - th) / th
        err[name] = float(rel[use].max()) if use.any() else math.nan
    return _result(sim, wall, build, error=max(err.values()), error_length=err["length"],
                   error_opening=err["opening"], error_pressure=err["pressure"], time=rec[:, 0],
                   half_length=rec[:, 1], well_opening=rec[:, 2], well_pressure=rec[:, 3],
                   half_length_analytic=sol.half_length, well_opening_analytic=sol.well_opening,
                   well_pressure_analytic=sol.well_pressure, half_length_broken=rec[:, 4],
                   half_length_wet=rec[:, 5], compared=use, **info)

"""Verification cases of elasticity, waves, contact and friction (docs/verification.md §8.1–8.6)."""
from __future__ import annotations

import math
import time as _time

import numpy as np

from .. import mesh
from ..material import Material
from ..scene import Scene
from ._common import E, NU, RHO, _build, _centroid_velocity, _crossing, _precision, _result


def case_wave(resolution: int = 100, safety: float = 0.2, penalty_factor: float = 10.0, precision: str = "f64",
              plane: str = "strain", lateral: str = "roller") -> dict:
    """Arrival of a velocity step travelling along a strip (docs/verification.md §8.3).

    Strip of length ℓ = 1 m and height 2h, h = ℓ/``resolution``.  The left end is driven at the
    constant velocity v0 = 10⁻⁴ c from t = 0 (a step in particle velocity).  ``lateral="roller"``
    holds every node's vertical velocity at zero, so the wave is exactly one-dimensional and
    travels at the P-wave speed of the plane problem, c = √((λ+2μ)/ρ) (plane strain) or
    √(E/(ρ(1−ν²))) (plane stress).  ``lateral="free"`` leaves the long edges free: the bar
    speed √(E/ρ) (plane stress) or √(E/(ρ(1−ν²))) (plane strain) for wavelengths ≫ the height.

    Measurement: the mean horizontal velocity of the node column at x1 = 0.25 ℓ and at
    x2 = 0.65 ℓ is sampled; the arrival time at a station is when it first reaches v0/2 (the
    middle of the front, which moves at c even though the discrete front spreads and rings),
    interpolated between samples.  c_measured = (x2 − x1)/(t2 − t1): the difference cancels the
    start-up delay at the driven end.  The far end reflects only after the front has passed x2.
    """
    _precision(precision)
    mat = Material(density=RHO, young=E, poisson=NU)
    L, N = 1.0, int(resolution)
    h = L / N
    if lateral == "roller":
        c = mat.p_wave_speed(plane)
    elif lateral == "free":
        c = math.sqrt(E / RHO) if plane == "stress" else math.sqrt(E / (RHO * (1 - NU ** 2)))
    else:
        raise ValueError(f"case_wave: lateral must be 'roller' or 'free', got {lateral!r}")
    v0 = 1e-4 * c
    scene = Scene(gravity=(0.0, 0.0), plane=plane)
    scene.add_body(mesh.rectangle(L, 2 * h, h, origin=(0.0, 0.0)), mat)
    if lateral == "roller":
        scene.fix_nodes(lambda x, y: np.ones_like(x, bool), velocity=(None, 0.0))
    scene.fix_nodes(lambda x, y: x <= 1e-9 * L, velocity=(v0, None))
    sim, build = _build(scene, safety)
    X = sim.model.node_rest
    cols = []
    for xs in (0.25 * L, 0.65 * L):
        xc = h * round(xs / h)
        cols.append((xc, np.flatnonzero(np.abs(X[:, 0] - xc) < 1e-6 * h)))
    total = int(math.ceil(0.85 * L / c / sim.dt))
    k = max(1, total // 200)
    ts, vs = [0.0], [[0.0, 0.0]]
    t0 = _time.perf_counter()
    while sim.step_count < total:
        sim.step(k)
        v = sim.node_velocities()[:, 0]
        ts.append(sim.time)
        vs.append([v[idx].mean() for _, idx in cols])
    wall = _time.perf_counter() - t0
    vs = np.array(vs)
    # velocities are stored at half steps: v_{n-1/2} belongs to t − Δt/2
    ts = np.array(ts) - 0.5 * sim.dt
    t1, t2 = _crossing(ts, vs[:, 0], 0.5 * v0), _crossing(ts, vs[:, 1], 0.5 * v0)
    c_meas = (cols[1][0] - cols[0][0]) / (t2 - t1)
    err = abs(c_meas - c) / c if math.isfinite(c_meas) else math.inf
    return _result(sim, wall, build, error=err, c_measured=c_meas, c_analytic=c, h=h, plane=plane,
                   lateral=lateral)


# ------------------------------------------------------------------------------------------------
# §8.4 two-bar impact
# ------------------------------------------------------------------------------------------------
def case_two_bars(resolution: int = 40, safety: float = 0.2, penalty_factor: float = 10.0,
                  precision: str = "f64", plane: str = "strain") -> dict:
    """Two equal bars (length ℓ = 0.5 m, height 2h, h = ℓ/``resolution``) meet at ±v (docs/verification.md §8.4).

    Every node's vertical velocity is held at zero (rollers), so the bars are one-dimensional
    with wave speed c = the P-wave speed of the plane problem.  Theory: the contact lasts 2ℓ/c,
    the contact stress is ρ c v, the bars exchange velocities (restitution 1), momentum is
    exact and the energy after separation equals the initial kinetic energy.

    Measurement: the momentum of bar A, sampled ~400 times.  The interface nodes of a penalty
    contact chatter (the nodal contact force jumps between 0 and several times ρcvA), but the
    momentum transferred is smooth: in theory p_A falls linearly from Mv to −Mv while the bars
    touch.  With t₊, t₋ the times p_A crosses +Mv/2 and −Mv/2: duration = 2 (t₋ − t₊), mean
    contact force = Mv/(t₋ − t₊), stress = force / height.
    ``error`` = the largest of the relative errors of duration, stress and energy after separation.
    """
    _precision(precision)
    mat = Material(density=RHO, young=E, poisson=NU, penalty=penalty_factor * E)
    c = mat.p_wave_speed(plane)
    L, N = 0.5, int(resolution)
    h = L / N
    H = 2 * h
    v = 1e-3 * c
    gap = 0.05 * h
    scene = Scene(gravity=(0.0, 0.0), plane=plane)
    a = scene.add_body(mesh.rectangle(L, H, h, origin=(-L - 0.5 * gap, 0.0)), mat, velocity=(v, 0.0))
    b = scene.add_body(mesh.rectangle(L, H, h, origin=(0.5 * gap, 0.0)), mat, velocity=(-v, 0.0))
    scene.fix_nodes(lambda x, y: np.ones_like(x, bool), velocity=(None, 0.0))
    sim, build = _build(scene, safety)
    e0 = sim.energies()
    M = sim.node_masses(a).sum()
    t_contact = 2 * L / c
    t_end = gap / (2 * v) + 1.4 * t_contact
    total = int(math.ceil(t_end / sim.dt))
    k = max(1, total // 400)
    ts, ps = [0.0], [M * v]
    worst_p = 0.0
    ma, m = sim.node_masses(a), sim.node_masses()
    t0 = _time.perf_counter()
    while sim.step_count < total:
        sim.step(k)
        vel = sim.node_velocities()
        ts.append(sim.time - 0.5 * sim.dt)                  # velocities belong to the half step
        ps.append((ma * vel[a.nodes, 0]).sum())
        worst_p = max(worst_p, abs((m * vel[:, 0]).sum()) / (2 * M * v))
    wall = _time.perf_counter() - t0
    ts, ps = np.array(ts), np.array(ps)
    t_plus = _crossing(ts, -ps, -0.5 * M * v)
    t_minus = _crossing(ts, -ps, 0.5 * M * v)
    duration = 2 * (t_minus - t_plus)
    stress = M * v / (t_minus - t_plus) / H
    e = sim.energies()
    energy_err = abs(e["kinetic"] + e["strain"] + e["contact"] - e0["total"]) / e0["total"]
    va, vb = _centroid_velocity(sim, a)[0], _centroid_velocity(sim, b)[0]
    restitution = -(vb - va) / (-v - v)
    err_d = abs(duration - t_contact) / t_contact
    err_s = abs(stress - RHO * c * v) / (RHO * c * v)
    error = max(err_d, err_s, energy_err) if math.isfinite(duration) else math.inf
    return _result(sim, wall, build, error=error, duration=duration, duration_analytic=t_contact,
                   duration_error=err_d, stress=stress, stress_analytic=RHO * c * v, stress_error=err_s,
                   energy_error=energy_err, momentum_error=worst_p, restitution=restitution,
                   separated=bool(e["contact"] == 0.0), h=h)


# ------------------------------------------------------------------------------------------------
# §8.5 Hertz contact of a cylinder on a flat
# ------------------------------------------------------------------------------------------------
def case_hertz(resolution: int = 10, safety: float = 0.2, penalty_factor: float = 100.0,
               precision: str = "f64", a_over_r: float = 0.05, load_time: float = 15.0) -> dict:
    """Elastic cylinder (radius R = 1 m) pressed on a rigid flat, plane strain (docs/verification.md §8.5).

    Only the lower cap of the cylinder is modelled (half-width 5a, height 5a, with a the
    expected contact half-width = ``a_over_r`` R): the contact half-width and pressure depend
    only on the local curvature and E* = E/(1−ν²) (rigid flat), and the cap is much larger
    than a.  Mesh size h = 2a/``resolution`` (``resolution`` elements across the contact).  The
    top of the cap is pushed down quasi-statically (velocity ∝ sin², over ``load_time`` × the
    wave transit time of the cap, then held for a third of it) with element damping β = 0.7.

    Measurement from the contact forces on the flat's nodes (``forces(contact_only=True)``):
    P = their sum; a = 2√(Σ f x²/Σ f) (for the Hertz pressure p0√(1−x²/a²) the second moment is
    a²/4); p0 = the least-squares amplitude of the nodal pressures (force / node spacing)
    against √(1−x²/a²).  Compared with a = √(4PR/(πE*)), p0 = √(PE*/(πR)) for the measured P.
    ``error`` = max of the two relative errors.
    """
    _precision(precision)
    R = 1.0
    a_exp = a_over_r * R
    h = 2 * a_exp / resolution
    w, Hc = 5 * a_exp, 5 * a_exp
    mat = Material(density=RHO, young=E, poisson=NU, damping=0.7, penalty=penalty_factor * E)
    Estar = E / (1 - NU ** 2)
    alpha = math.asin(w / R)
    n_arc = max(8, int(math.ceil(2 * alpha * R / h)))
    ang = -0.5 * math.pi + np.linspace(-alpha, alpha, n_arc + 1)
    gap = 0.02 * h
    arc = np.stack([R * np.cos(ang), R + gap + R * np.sin(ang)], axis=1)
    top = gap + Hc
    verts = np.vstack([arc, [[w, top], [-w, top]]])
    cap_mesh = mesh.polygon(verts, h)
    flat_w = 2.4 * w
    scene = Scene(gravity=(0.0, 0.0), plane="strain")
    flat = scene.add_body(mesh.rectangle(flat_w, 2 * h, h, origin=(-0.5 * flat_w, -2 * h)), mat, fixed=True)
    cap = scene.add_body(cap_mesh, mat)
    scene.fix_nodes(lambda x, y: y >= top - 1e-9, body=cap, velocity=(0.0, 0.0))
    sim, build = _build(scene, safety)
    # approach needed for a ≈ a_exp (2D: the approach depends on the whole body; this estimate
    # only sets the load level, the check uses the measured load)
    P_exp = math.pi * Estar * a_exp ** 2 / (4 * R)
    delta = 0.5 * (P_exp / (math.pi * Estar) * (2 * math.log(4 * R / a_exp) - 1) + P_exp * Hc / (E * 2 * w)) + gap
    c = mat.p_wave_speed("strain")
    T = load_time * Hc / c
    vmax = 2 * delta / T                                  # ∫ vmax sin²(πt/T) dt = vmax T/2 = δ
    X = sim.model.node_rest
    top_nodes = np.flatnonzero((X[:, 1] >= top - 1e-9) & (np.arange(len(X)) >= cap.node_start))
    vbc = sim.state.node_vbc.to_numpy()
    total = int(math.ceil(T * 4.0 / 3.0 / sim.dt))
    k = max(1, min(200, total // 300))
    t0 = _time.perf_counter()
    while sim.step_count < total:
        t = sim.time + 0.5 * k * sim.dt
        vbc[top_nodes, 1] = -vmax * math.sin(math.pi * t / T) ** 2 if t < T else 0.0
        sim.state.node_vbc.from_numpy(vbc)
        sim.step(k)
    f = sim.forces(contact_only=True)
    wall = _time.perf_counter() - t0
    fy = f[flat.nodes, 1]
    xf = sim.node_positions(flat)
    P = -fy.sum()
    surf = np.abs(xf[:, 1]) < 1e-6 * h
    fs, xs = -fy[surf], xf[surf, 0]
    xc = (fs * xs).sum() / fs.sum()
    a_meas = 2.0 * math.sqrt(max((fs * (xs - xc) ** 2).sum() / fs.sum(), 0.0))
    spacing = flat_w / round(flat_w / h)
    p_nodes = fs / spacing
    s = np.sqrt(np.clip(1 - ((xs - xc) / a_meas) ** 2, 0, None)) if a_meas > 0 else np.zeros_like(xs)
    p0_meas = float((p_nodes * s).sum() / max((s * s).sum(), 1e-300))
    a_th = math.sqrt(4 * P * R / (math.pi * Estar)) if P > 0 else math.nan
    p0_th = math.sqrt(P * Estar / (math.pi * R)) if P > 0 else math.nan
    ea, ep = abs(a_meas - a_th) / a_th, abs(p0_meas - p0_th) / p0_th
    return _result(sim, wall, build, error=max(ea, ep), a=a_meas, a_analytic=a_th, a_error=ea, p0=p0_meas,
                   p0_analytic=p0_th, p0_error=ep, load=P, elements_across=2 * a_th / h, h=h)


# ------------------------------------------------------------------------------------------------
# §8.6 cantilever and rigid rotation
# ------------------------------------------------------------------------------------------------
def cantilever_deflection(P: float, length: float, depth: float, plane: str = "stress") -> float:
    """Tip deflection [m] of a cantilever under a tip load P [N per m thickness] (§8.6, Timoshenko, κ = 5/6)."""
    Ee, nue = (E, NU) if plane == "stress" else (E / (1 - NU ** 2), NU / (1 - NU))
    G = Ee / (2 * (1 + nue))
    I = depth ** 3 / 12
    return P * length ** 3 / (3 * Ee * I) + P * length / (5.0 / 6.0 * G * depth)


def case_cantilever(resolution: int = 8, safety: float = 0.2, penalty_factor: float = 10.0,
                    precision: str = "f64", plane: str = "stress", slenderness: float = 10.0,
                    pattern: str = "crossed") -> dict:
    """Cantilever (depth d = 0.1 m, length ``slenderness`` d) with a tip load (docs/verification.md §8.6).

    ``resolution`` elements (cells) through the depth.  The root nodes are clamped.  The load is
    applied by displacement control: the tip nodes' vertical velocity is prescribed (their
    horizontal motion is free) so that the tip moves smoothly (velocity ∝ sin²) to
    δ = 10⁻³ ℓ over three periods of the beam's lowest mode with the tip held (clamped–pinned,
    ω = 15.42 √(EI/(ρAℓ⁴))), then is held for two periods; element damping β = 0.5.
    The tip load P is the reaction on the tip nodes (``forces()``), averaged over the hold.
    error = ``|δ − δ_theory(P)|``/δ with δ_theory = Pℓ³/(3EI) + Pℓ/(κGd) (plane strain: E/(1−ν²),
    ν/(1−ν)).  CST elements are stiff in bending: the error falls with the resolution.
    """
    _precision(precision)
    d = 0.1
    L = slenderness * d
    h = d / resolution
    mat = Material(density=RHO, young=E, poisson=NU, damping=0.5)
    scene = Scene(gravity=(0.0, 0.0), plane=plane)
    scene.add_body(mesh.rectangle(L, d, h, origin=(0.0, -0.5 * d), pattern=pattern), mat)
    scene.fix_nodes(lambda x, y: x <= 1e-9, velocity=(0.0, 0.0))
    scene.fix_nodes(lambda x, y: x >= L - 1e-9, velocity=(None, 0.0))
    sim, build = _build(scene, safety)
    X = sim.model.node_rest
    tip = np.flatnonzero(X[:, 0] >= L - 1e-9)
    Ee = E if plane == "stress" else E / (1 - NU ** 2)
    omega = 15.42 * math.sqrt(Ee * d ** 3 / 12 / (RHO * d * L ** 4))
    period = 2 * math.pi / omega
    T = 3 * period
    delta = 1e-3 * L
    vmax = 2 * delta / T
    vbc = sim.state.node_vbc.to_numpy()
    total = int(math.ceil((T + 2 * period) / sim.dt))
    k = max(1, min(500, int(period / sim.dt / 40)))
    Ps = []
    t0 = _time.perf_counter()
    while sim.step_count < total:
        t = sim.time + 0.5 * k * sim.dt
        vbc[tip, 1] = vmax * math.sin(math.pi * t / T) ** 2 if t < T else 0.0
        sim.state.node_vbc.from_numpy(vbc)
        sim.step(k)
        if sim.time > T:
            Ps.append(-sim.forces()[tip, 1].sum())      # the beam pulls the tip nodes back
    wall = _time.perf_counter() - t0
    tip_disp = float(sim.node_displacements()[tip, 1].mean())
    P = float(np.mean(Ps))
    d_th = cantilever_deflection(P, L, d, plane)
    err = abs(tip_disp - d_th) / tip_disp
    return _result(sim, wall, build, error=err, deflection=tip_disp, deflection_analytic=d_th, load=P, h=h,
                   plane=plane)


def case_rotation(resolution: int = 8, safety: float = 0.2, penalty_factor: float = 10.0, precision: str = "f64",
                  angles=(0.3, 1.0, math.pi / 2, 2.5, math.pi)) -> dict:
    """Objectivity: the cantilever's mesh rigidly rotated by large angles carries no stress (§8.6).

    The nodes are placed at R(θ)X + t for each angle and the elastic stresses and nodal forces
    are evaluated.  ``error`` = max ``|σ|`` / E (round-off: ~1e-16 in f64, ~1e-7 in f32).  Then the
    beam spins freely at ω for a quarter turn: the stress must be the centrifugal one only
    (bounded by ρ ω² ℓ², reported as ``spin_stress_ratio`` = max|σ| / (ρ ω² ℓ²)).
    """
    _precision(precision)
    d = 0.1
    L = 10 * d
    mat = Material(density=RHO, young=E, poisson=NU)
    scene = Scene(gravity=(0.0, 0.0))
    scene.add_body(mesh.rectangle(L, d, d / resolution, origin=(0.0, -0.5 * d)), mat)
    sim, build = _build(scene, safety)
    X = sim.model.node_rest
    worst = worst_f = 0.0
    t0 = _time.perf_counter()
    real = sim.state.node_x.to_numpy().dtype
    for th in angles:
        Rm = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
        sim.state.node_x.from_numpy((X @ Rm.T + np.array([0.3, -0.2])).astype(real))
        worst = max(worst, float(np.abs(sim.stresses()).max()) / E)
        worst_f = max(worst_f, float(np.abs(sim.forces()).max()) / (E * d / resolution))
    sim.state.node_x.from_numpy(X.astype(real))
    omega = 0.02 * mat.p_wave_speed("strain") / L
    c = X.mean(0)
    r = X - c
    sim.set_node_velocities(omega * np.stack([-r[:, 1], r[:, 0]], axis=1))
    sim.step(int(round(0.5 * math.pi / omega / sim.dt)))
    spin = float(np.abs(sim.stresses()).max()) / (RHO * omega ** 2 * L ** 2)
    wall = _time.perf_counter() - t0
    return _result(sim, wall, build, error=worst, force_ratio=worst_f, spin_stress_ratio=spin)


# ------------------------------------------------------------------------------------------------
# §8.2 block on an incline
# ------------------------------------------------------------------------------------------------
def case_incline(resolution: int = 2, safety: float = 0.2, penalty_factor: float = 10.0, precision: str = "f64",
                 theta_deg: float = 30.0, friction: float = 0.3, duration: float = 0.1) -> dict:
    """A 0.1 × 0.05 m block on a fixed floor, gravity tilted by θ (docs/verification.md §8.2).

    Mesh size h = 0.05 m / ``resolution``; μ = ``friction``; element damping β = 0.2 and contact
    damping ξ = 0.5 remove the penalty contact's vibrations.  If tan θ > μ the block slides with
    a = g (sin θ − μ cos θ): error = ``|x − ½ a t²|`` / (½ a t²) of the centroid after ``duration``.
    If tan θ ≤ μ it sticks: error = ``|x|`` / (½ g sin θ t²) (the elastic creep, relative to a free slide).
    """
    _precision(precision)
    g = 9.81
    th = math.radians(theta_deg)
    mat = Material(density=RHO, young=1e7, poisson=NU, friction=friction, damping=0.2, contact_damping=0.5,
                   penalty=penalty_factor * 1e7)
    h = 0.05 / resolution
    scene = Scene(gravity=(g * math.sin(th), -g * math.cos(th)))
    scene.add_body(mesh.rectangle(0.6, 0.05, h, origin=(-0.1, -0.05)), mat, fixed=True)
    block = scene.add_body(mesh.rectangle(0.1, 0.05, h, origin=(-0.05, 0.0)), mat)
    sim, build = _build(scene, safety)
    m = sim.node_masses(block)
    x0 = (m * sim.node_positions(block)[:, 0]).sum() / m.sum()
    t0 = _time.perf_counter()
    sim.step(int(round(duration / sim.dt)))
    wall = _time.perf_counter() - t0
    x = (m * sim.node_positions(block)[:, 0]).sum() / m.sum() - x0
    t = sim.time
    if math.tan(th) > friction:
        acc = g * (math.sin(th) - friction * math.cos(th))
        ref = 0.5 * acc * t * t
        err = abs(x - ref) / ref
        slides = True
    else:
        ref = 0.0
        err = abs(x) / (0.5 * g * math.sin(th) * t * t)
        slides = False
    return _result(sim, wall, build, error=err, displacement=x, displacement_analytic=ref, slides=slides,
                   theta_deg=theta_deg)


# ------------------------------------------------------------------------------------------------
# two disks (one scene shared by case_disks, demos/two_disks.py, stability.scenario_disks, tests)
# ------------------------------------------------------------------------------------------------
def two_disks_scene(radius: float = 0.05, h: float | None = None, velocity_a=(2.0, 0.0), velocity_b=(-2.0, 0.0),
                    offset: float = 0.0, gap: float = 0.006, material: dict | None = None, mirror: bool = True,
                    names=("A", "B"), layout: str = "spiral", **build_kw):
    """Two equal elastic disks (``radius``, mesh size ``h``, default radius/3), centres 2·radius
    + ``gap`` apart along x and ±``offset`` in y (A below, left), with initial velocities
    ``velocity_a``, ``velocity_b``; no gravity.  ``mirror``: B is A's mesh mirrored about the y
    axis, so a head-on impact is mirror-symmetric and the contact force exactly along x (the
    meshed disks are polygons).  ``material``: Material keywords (default E = 10 MPa,
    ρ = 1000 kg/m³, ν = 0.25, penalty 10·E).  ``layout``: of :func:`~taichi_fdem.mesh.disk`
    (the scene of the verification and stability tables: ``"spiral"``).  Returns (sim, a, b);
    ``build_kw`` go to build()."""
    kw = dict(density=1000.0, young=1e7, poisson=NU)
    kw.update(material or {})
    kw.setdefault("penalty", 10.0 * kw["young"])
    mat = Material(**kw)
    dm = mesh.disk(radius, radius / 3 if h is None else h, layout=layout)
    dmb = mesh.TriMesh(dm.points * np.array([-1.0, 1.0]), dm.triangles) if mirror else dm
    scene = Scene(gravity=(0.0, 0.0))
    a = scene.add_body(dm, mat, position=(-radius - 0.5 * gap, -offset), velocity=tuple(velocity_a), name=names[0])
    b = scene.add_body(dmb, mat, position=(radius + 0.5 * gap, offset), velocity=tuple(velocity_b), name=names[1])
    sim, _ = _build(scene, build_kw.pop("safety", 0.2), **build_kw)
    return sim, a, b


# ------------------------------------------------------------------------------------------------
# §8.4 elastic impact of two disks
# ------------------------------------------------------------------------------------------------
def case_disks(resolution: int = 3, safety: float = 0.2, penalty_factor: float = 10.0, precision: str = "f64",
               speed: float = 2.0) -> dict:
    """Head-on impact of two equal elastic disks (R = 5 cm, h = R/``resolution``) at ±``speed`` (§8.4).

    E = 10 MPa, ρ = 1000 kg/m³ (c_p ≈ 110 m/s).  After separation: the energy balance
    (kinetic + strain + contact vs the initial kinetic energy) is the error; the coefficient
    of restitution of the rigid motions e = −(v_b' − v_a')/(v_b − v_a) (< 1: vibration energy
    stays in the disks), the share of energy in vibration and the momentum error are reported.
    """
    _precision(precision)
    R = 0.05
    t_b = _time.perf_counter()
    sim, a, b = two_disks_scene(R, R / resolution, (speed, 0.0), (-speed, 0.0),
                                material=dict(penalty=penalty_factor * 1e7), safety=safety)
    build = _time.perf_counter() - t_b
    e0 = sim.energies()["total"]
    M = sim.node_masses(a).sum()
    t0 = _time.perf_counter()
    touched, worst_p = False, 0.0
    # the contact lasts a few R/c; run until the disks are apart again and moving away
    while True:
        sim.step(50)
        e = sim.energies()
        touched |= e["contact"] > 0
        p = (sim.node_masses()[:, None] * sim.node_velocities()).sum(0)
        worst_p = max(worst_p, float(np.abs(p).max()) / (M * speed))
        if (touched and e["contact"] == 0.0) or sim.time > 0.05:
            break
    sim.step(200)
    wall = _time.perf_counter() - t0
    e = sim.energies()
    va, vb = _centroid_velocity(sim, a)[0], _centroid_velocity(sim, b)[0]
    restitution = -(vb - va) / (-2 * speed)
    rigid = 0.5 * (sim.node_masses(a).sum() * va ** 2 + sim.node_masses(b).sum() * vb ** 2)
    err = abs(e["kinetic"] + e["strain"] + e["contact"] - e0) / e0
    return _result(sim, wall, build, error=err, restitution=restitution, vibration_share=1 - rigid / e0,
                   momentum_error=worst_p, energy_before=e0, energy_after=e["total"], velocity_a=va,
                   velocity_b=vb, separated=bool(e["contact"] == 0.0))


# ------------------------------------------------------------------------------------------------
# §8.7 single-joint pull (mode I) and direct tension of a jointed strip (fracture)
# ------------------------------------------------------------------------------------------------

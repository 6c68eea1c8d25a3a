"""Fracture verification cases and shared fracture scenes: joint pull, direct tension, Brazilian disc, fragmenting plate (docs/verification.md §8.7–8.8)."""
from __future__ import annotations

import math
import time as _time

import numpy as np

from .. import mesh
from ..material import Material
from ..scene import Scene
from ._common import _build, _precision, _result


class JointPair:
    """Two triangles of a unit square with one cohesive joint on the diagonal (§8.7); the nodes of
    both triangles (A, B) are prescribed (initially at rest), so the joint kinematics are exact.
    Shared by :func:`case_joint_pull` and tests/test_fracture.py."""

    def __init__(self, **matkw):
        from ..scene import explode_for_fracture
        sq = mesh.TriMesh(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]), np.array([[0, 1, 2], [0, 2, 3]]))
        ex, jn, jt = explode_for_fracture(sq)
        a, b = int(jt[0, 0]), int(jt[0, 1])
        self.A, self.B = np.arange(3 * a, 3 * a + 3), np.arange(3 * b, 3 * b + 3)
        x0, x1, x2, x3 = ex.points[jn[0]]
        e = 0.5 * (x1 + x2 - x0 - x3)
        self.L = float(np.linalg.norm(e))
        self.e = e / self.L
        self.n = np.array([-self.e[1], self.e[0]])        # points into A (§7.2)
        kw = dict(density=1000.0, young=1e8, poisson=0.25, tensile_strength=1e6, fracture_energy=1e4)
        kw.update(matkw)
        self.mat = Material(**kw)
        self.ft, self.c, self.tanphi, self.gI, self.gII, self.pf = self.mat.joint_properties()
        scene = Scene(gravity=(0.0, 0.0))
        body = scene.add_body(sq, self.mat, fracture=True)
        scene.fix_nodes(lambda x, y: np.isin(np.arange(len(x)), self.A), body=body, velocity=(0.0, 0.0))
        scene.fix_nodes(lambda x, y: np.isin(np.arange(len(x)), self.B), body=body, velocity=(0.0, 0.0))
        self.dt = 1e-4
        # every node is prescribed: no stability limit applies
        self.sim = scene.build(dt=self.dt, force_dt=True)
        self.jn = self.sim.model.joint_nodes.to_numpy()[0]
        self.vbc = self.sim.state.node_vbc.to_numpy()

    def move_A(self, velocity):
        self.vbc[self.A] = velocity
        self.sim.state.node_vbc.from_numpy(self.vbc)

    def gap(self):
        """Mean (opening, sliding) of the joint from the node positions (§7.2)."""
        x = self.sim.node_positions()
        d = 0.5 * ((x[self.jn[0]] - x[self.jn[3]]) + (x[self.jn[1]] - x[self.jn[2]]))
        return float(d @ self.n), float(d @ self.e)

    def traction(self):
        """(σ, τ) per unit length from the joint's nodal forces on A (contact subtracted)."""
        f = self.sim.forces() - self.sim.forces(contact_only=True)
        fa = f[self.A].sum(axis=0)
        return float(-(fa @ self.n) / self.L), float(-(fa @ self.e) / self.L)

    def drive(self, direction, comp, peak, span, fine=100, coarse=10):
        """Move A along ``direction`` at δ_peak/fine per step until the joint breaks.

        ``comp`` 0 measures opening and σ, 1 sliding and τ.

        Forces are sampled every step up to 1.3 δ_peak and every ``coarse`` steps after.
        Returns (displacement samples, traction samples, displacement at breakage).
        """
        inc = peak / fine
        self.move_A(direction * inc / self.dt)
        u0 = self.gap()[comp]
        t0 = self.sim.time
        us, ts = [0.0], [self.traction()[comp]]
        total = int(1.5 * (peak + span) / inc)
        done = 0
        while done < total and not self.sim.cracks.broken_count:
            k = 1 if us[-1] < 1.3 * peak else coarse
            self.sim.step(k)
            done += k
            us.append(self.gap()[comp] - u0)
            ts.append(self.traction()[comp])
        if self.sim.cracks.broken_count != 1:
            raise RuntimeError("JointPair.drive: the joint did not break")
        t_break = float(self.sim.cracks.broken()["time"][0])
        # the joint breaks inside a step: its recorded time is the start of that step (positions at
        # the start of the step are those evaluated)
        u_break = (t_break - t0) * inc / self.dt
        return np.array(us[:-1]), np.array(ts[:-1]), u_break


def case_joint_pull(resolution: int = 100, safety: float = 0.2, penalty_factor: float = 10.0,
                    precision: str = "f64", **kw) -> dict:
    """Mode I pull of one joint between the two triangles of a unit square (§8.7, :class:`JointPair`).

    A moves along n̂ by δ_p/``resolution`` per step (the time step only scales time: nothing is
    integrated freely, so ``safety`` is not used).  ``penalty_factor`` = p_f/E.  Error: the
    largest relative error of the peak stress (f_t), the opening at breakage (δ_p + Δ_n) and the
    work per unit length f_t(2δ_p/3 + 0.3863 Δ_n).
    """
    _precision(precision)
    t_start = _time.perf_counter()
    p = JointPair(joint_penalty=penalty_factor * 1e8)
    build = _time.perf_counter() - t_start
    dp = 2.0 * p.L * p.ft / p.pf
    dn = 3.0 * p.gI / p.ft
    o, s, o_break = p.drive(p.n, 0, dp, dn, fine=resolution)
    work = float(np.sum(0.5 * (s[1:] + s[:-1]) * np.diff(o)))
    w_ref = p.ft * (2.0 * dp / 3.0 + 0.3863 * dn)
    errs = (abs(s.max() / p.ft - 1), abs(o_break / (dp + dn) - 1), abs(work / w_ref - 1))
    return _result(p.sim, _time.perf_counter() - t_start, build, error=max(errs), peak_error=errs[0],
                   break_error=errs[1], work_error=errs[2])


def case_direct_tension(resolution: int = 2, safety: float = 0.2, penalty_factor: float = 10.0,
                        precision: str = "f64", **kw) -> dict:
    """Direct tension of a fully jointed strip (1 × 0.2 m, plane stress), quasi-static pull.

    ``resolution`` = elements across the height; ``penalty_factor`` = p_f/E.  Error: peak
    stress (reaction / height) against f_t.
    """
    _precision(precision)
    t_start = _time.perf_counter()
    W, H = 1.0, 0.2
    h = H / resolution
    E, rho, ft = 1e8, 1000.0, 1e5
    mat = Material(density=rho, young=E, poisson=0.2, damping=0.7, tensile_strength=ft, fracture_energy=20.0,
                   joint_penalty=penalty_factor * E)
    scene = Scene(gravity=(0.0, 0.0), plane="stress")
    body = scene.add_body(mesh.rectangle(W, H, h, origin=(0.0, 0.0)), mat, fracture=True)
    c = mat.p_wave_speed("stress")
    u_peak = 1.2 * W * ft / E
    v = u_peak / (150.0 * W / c)
    tol = 1e-9
    scene.fix_nodes(lambda x, y: x < tol, body=body, velocity=(0.0, None))
    scene.fix_nodes(lambda x, y: (x < tol) & (y < tol), body=body, velocity=(0.0, 0.0))
    scene.fix_nodes(lambda x, y: x > W - tol, body=body, velocity=(v, None))
    sim, build = _build(scene, safety)
    right = sim.node_positions()[:, 0] > W - tol
    n_total = int(2.5 * u_peak / v / sim.dt)
    k = max(1, n_total // 400)
    stress = []
    while sim.step_count < n_total:
        sim.step(k)
        stress.append(-sim.forces()[right, 0].sum() / H)
        if sim.cracks.broken_count and stress[-1] < 0.3 * max(stress):
            break
    peak = float(max(stress))
    return _result(sim, _time.perf_counter() - t_start, build, error=abs(peak / ft - 1), peak_over_ft=peak / ft,
                   broken_joints=sim.cracks.broken_count, fragments=sim.cracks.fragment_count())


# ------------------------------------------------------------------------------------------------
# §8.8 Brazilian disc (shared by demos/brazilian.py, tests/test_fracture.py and benchmarks)
# ------------------------------------------------------------------------------------------------
BRAZILIAN_MATERIAL = dict(density=2500.0, young=10e9, poisson=0.2, damping=1.0, tensile_strength=5e6,
                          fracture_energy=50.0, cohesion=15e6, friction_angle=35.0)


def hondros_factor(alpha_deg: float) -> float:
    """Centre tensile stress of a disc loaded over an arc 2α, in units of 2P/(πD) (Hondros):
    (sin 2α − α)/α."""
    a = math.radians(alpha_deg)
    return (math.sin(2 * a) - a) / a


def brazilian_scene(elements: int = 40, load_time: float = 100.0, D: float = 0.1, alpha_deg: float = 10.0,
                    safety: float = 0.35, strength=None, material=None, platen=None, groups=None,
                    disc_mesh=None, plane: str = "strain", joint_sets=(), quasi_static=False):
    """A jointed rock disc (diameter D, h = D/``elements``, every interior edge a cohesive joint)
    between two stiff platens (docs/verification.md §8.8).

    The disc's caps are flattened over ±``alpha_deg`` (nodes clipped to ``|y|`` ≤ R cos α) so the
    load spreads over a few elements instead of one node.  The platens approach each other at
    ±v, v chosen so that the approach at the expected peak (5.6 D f_t/E, ≈ 0.28 mm for D = 0.1 m)
    takes ``load_time`` × D/c_p.  ``strength``: a joint-strength distribution (``fdem.Weibull``,
    ``fdem.NormalStrength``) for a heterogeneous disc.  ``material``: the disc's Material (default
    ``BRAZILIAN_MATERIAL``) or a dict of Materials with ``groups`` (one label per triangle of
    ``disc_mesh``, a disc of diameter D centred on the origin; default ``mesh.disk(..., layout="spiral")``);
    ``platen``: the platens' Material (default: E = 10 × the disc's, contact penalty 3 × the
    disc's E); ``joint_sets``: (name, selector, Material) triples added to the disc with
    :meth:`Scene.add_joint_set`; ``quasi_static``: passed to :meth:`Scene.build` (local
    non-viscous damping of the disc and platens).  The platen speed scales with the expected
    approach at the peak, 5.6 D f_t/E (0.28 mm for D = 0.1 m, f_t/E = 5e-4).  Returns (sim, (disc, top, bottom), params)
    with params = dict(v, load_time, cp, D, alpha_deg, mat, elements).
    """
    from ..mesh import TriMesh
    R, h = 0.5 * D, D / elements
    if material is None:
        mat = Material(**BRAZILIAN_MATERIAL, name="rock")
    else:
        mat = material
    first = next(iter(mat.values())) if isinstance(mat, dict) else mat
    stiff = max(m.young for m in mat.values()) if isinstance(mat, dict) else mat.young
    if platen is None:
        platen = Material(density=first.density, young=10 * stiff, poisson=0.2, penalty=3 * stiff, name="steel")
    # the spiral layout: no straight line of edges through the centre for the split to follow
    d0 = mesh.disk(R, h, layout="spiral") if disc_mesh is None else disc_mesh
    yc = R * math.cos(math.radians(alpha_deg))
    pts = d0.points.copy()
    pts[:, 1] = np.clip(pts[:, 1], -yc, yc)
    scene = Scene(gravity=(0.0, 0.0), plane=plane)
    disk = scene.add_body(TriMesh(pts, d0.triangles), mat, fracture=True, name="disc", strength=strength,
                          groups=groups)
    for name, selector, m in joint_sets:
        scene.add_joint_set(name, selector, m, body=disk)
    cp = first.p_wave_speed(plane)
    ft = first.tensile_strength if first.tensile_strength is not None else 0.5 * first.young * 1e-3
    v = 0.5 * 5.6 * D * ft / first.young / (load_time * D / cp)
    pm = mesh.rectangle(0.5 * D, 0.1 * D, D / 20)
    top = scene.add_body(pm, platen, position=(0.0, yc + 0.05 * D + 1e-9), prescribed_velocity=(0.0, -v), name="top")
    bot = scene.add_body(pm, platen, position=(0.0, -yc - 0.05 * D - 1e-9), prescribed_velocity=(0.0, v),
                         name="bottom")
    sim = scene.build(safety=safety, quasi_static=quasi_static)
    return sim, (disk, top, bot), dict(v=v, ft=ft, platen=platen, load_time=load_time, cp=cp, D=D, alpha_deg=alpha_deg, mat=mat,
                                       elements=elements)


def brazilian_load(sim, bodies, p, samples: int = 240, frame=None, window: float = 1.0,
                   duration: float = 1.3, stop=None) -> dict:
    """Load the disc of :func:`brazilian_scene` until the load falls below 30 % of its peak, or
    for at most ``duration`` × the loading time (``p["load_time"]`` × D/c_p).

    The platen speed is ramped up over the first tenth of the loading time.  Every sample
    records the time, the instantaneous load on the top platen ``P_inst`` (sum of the forces on
    its nodes, per unit thickness), the platen ``approach``, the broken-joint count and the
    boundary work W of the prescribed platens.  The load reported, ``P``, is the platen load
    averaged over the last ``window`` × D/c_p: ΔW / Δapproach (the work the platens did over
    that window divided by their relative displacement), which removes the contact chatter
    and the disc's ringing (periods of 0.3–0.9 D/c_p); ``t_P`` and ``approach_P`` are the
    window's middle, where a linearly rising load equals that average.  ``frame(sim)`` is called
    after every sample; ``stop(rec)`` too (the record so far, lists), and a true return ends the
    loading.  Returns the record as arrays.
    """
    disk, top, bot = bodies
    D, cp = p["D"], p["cp"]
    t_load = p["load_time"] * D / cp
    n_total = int(duration * t_load / sim.dt)
    k = max(1, int(1.3 * t_load / sim.dt) // samples)
    vbc0 = sim.state.node_vbc.to_numpy()
    t_ramp = 0.1 * t_load
    yt0, yb0 = sim.node_positions(top)[:, 1].mean(), sim.node_positions(bot)[:, 1].mean()
    rec = {"t": [0.0], "P_inst": [0.0], "approach": [0.0], "broken": [0], "work": [sim.energies()["boundary_work"]],
           "P": [0.0], "t_P": [0.0], "approach_P": [0.0]}
    t_win = window * D / cp
    while sim.step_count < n_total:
        if sim.time < t_ramp + k * sim.dt:
            sim.state.node_vbc.from_numpy(vbc0 * min(1.0, (sim.time + 0.5 * k * sim.dt) / t_ramp))
        sim.step(k)
        rec["t"].append(sim.time)
        rec["P_inst"].append(float(sim.forces()[top.nodes, 1].sum()))
        rec["approach"].append(float((yt0 - sim.node_positions(top)[:, 1].mean())
                                     + (sim.node_positions(bot)[:, 1].mean() - yb0)))
        rec["broken"].append(sim.cracks.broken_count)
        rec["work"].append(sim.energies()["boundary_work"] / sim.scene.thickness)
        # window average: the first sample at least t_win back
        i0 = int(np.searchsorted(rec["t"], sim.time - t_win, side="right")) - 1
        i0 = max(0, min(i0, len(rec["t"]) - 2))
        da = rec["approach"][-1] - rec["approach"][i0]
        rec["P"].append((rec["work"][-1] - rec["work"][i0]) / da if da > 0 else 0.0)
        rec["t_P"].append(0.5 * (rec["t"][-1] + rec["t"][i0]))              # the window's middle
        rec["approach_P"].append(0.5 * (rec["approach"][-1] + rec["approach"][i0]))
        if frame is not None:
            frame(sim)
        if rec["broken"][-1] and rec["P"][-1] < 0.3 * max(rec["P"]):
            break
        if stop is not None and stop(rec):
            break
    return {key: np.array(val) for key, val in rec.items()}


def brazilian_result(sim, bodies, rec, p) -> dict:
    """Numbers of a Brazilian run: the peak of the filtered load, σ_t = 2 P_max/(πD) in units of
    f_t (and × the Hondros factor of the flattened caps), and where the joints broken by shortly
    after the peak lie (``central_fraction``: share within ``|x|`` < 0.15 D of the loaded diameter)."""
    disk = bodies[0]
    D, ft = p["D"], p.get("ft", getattr(p["mat"], "tensile_strength", None))
    i = int(np.argmax(rec["P"]))
    ratio = 2.0 * rec["P"][i] / (math.pi * D) / ft
    bj = sim.cracks.broken()
    j = min(i + 10, len(rec["t"]) - 1)
    sel = bj["time"] <= rec["t"][j]
    central = float(np.mean(np.abs(bj["position"][sel, 0]) < 0.15 * D)) if sel.any() else 0.0
    # ringing left in the filtered record before the peak: largest relative drop of P between
    # consecutive samples while loading up (a smooth rising curve has none)
    P = rec["P"][: i + 1]
    drops = (P[:-1] - P[1:]) / rec["P"][i]
    hf = hondros_factor(p["alpha_deg"])
    return {"P_max_N_per_m": float(rec["P"][i]), "P_inst_max_N_per_m": float(rec["P_inst"].max()),
            "sigma_t_over_ft": float(ratio), "sigma_t_hondros_over_ft": float(ratio * hf), "hondros": hf,
            "loading_time_to_peak_D_over_cp": float(rec["t_P"][i] * p["cp"] / D),
            "approach_at_peak_m": float(rec["approach_P"][i]),
            "max_drop_before_peak": float(max(0.0, drops.max())) if len(drops) else 0.0,
            "broken_after_peak": int(sel.sum()), "central_fraction": central,
            "broken_total": sim.cracks.broken_count, "fragments": sim.cracks.fragment_count(disk),
            "triangles": sim.model.tri_count, "joints": sim.model.joint_count}


def case_brazilian(resolution: int = 40, safety: float = 0.35, penalty_factor: float = 10.0,
                   precision: str = "f64", load_time: float = 100.0, samples: int = 240) -> dict:
    """Brazilian disc (§8.8): ``resolution`` elements across the diameter.  ``error`` =
    ``|σ_t × Hondros factor / f_t − 1|`` from the peak of the filtered platen load."""
    _precision(precision)
    t_start = _time.perf_counter()
    sim, bodies, p = brazilian_scene(elements=resolution, load_time=load_time, safety=safety)
    build = _time.perf_counter() - t_start
    rec = brazilian_load(sim, bodies, p, samples=samples)
    out = brazilian_result(sim, bodies, rec, p)
    out["record"] = rec
    return _result(sim, _time.perf_counter() - t_start, build, error=abs(out["sigma_t_hondros_over_ft"] - 1.0),
                   **out)


# ------------------------------------------------------------------------------------------------
# a projectile fragmenting a jointed plate (shared by demos/fragment_plate.py and the tests)
# ------------------------------------------------------------------------------------------------
def fragment_plate_scene(h_plate: float = 0.02, h_ball: float = 0.015, speed: float = 30.0,
                         friction: float = 0.0):
    """A free brittle plate (0.4 × 0.1 m, every interior edge a cohesive joint, mesh size
    ``h_plate``) hit in its middle by a stiff disc (R = 3 cm, mesh size ``h_ball``, the
    ``"spiral"`` layout of :func:`~taichi_fdem.mesh.disk`, the scene of the fracture benchmark)
    at ``speed`` [m/s], no gravity; Coulomb ``friction`` on every contact.  Returns
    (sim, (plate, ball))."""
    plate_mat = Material(density=1000.0, young=1e8, poisson=0.25, tensile_strength=2e5, fracture_energy=20.0,
                         friction=friction, name="brittle")
    proj_mat = Material(density=3000.0, young=1e8, poisson=0.25, friction=friction, name="projectile")
    scene = Scene(gravity=(0.0, 0.0))
    plate = scene.add_body(mesh.rectangle(0.4, 0.1, h_plate), plate_mat, fracture=True, name="plate")
    ball = scene.add_body(mesh.disk(0.03, h_ball, layout="spiral"), proj_mat, position=(0.0, 0.085), velocity=(0.0, -speed),
                          name="projectile")
    return scene.build(), (plate, ball)

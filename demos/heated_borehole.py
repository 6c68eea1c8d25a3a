"""A geothermal well wall cooled by injected water: thermal tension cracks (docs/theory/heat.md §16).

    python demos/heated_borehole.py          # writes out/heated_borehole.mp4, _profile.csv, _history.csv
    python demos/heated_borehole.py --short  # a coarser, shorter version (used by tests/test_demos_heat.py)

A borehole of radius a = 0.1 m in a block of granite (1 × 1 m; 0.6 × 0.6 m with ``--short``) at
the reservoir temperature T₀ = 200 °C (stress-free), meshed by ``fdem.mesh.plate_with_hole``
(fine at the wall, coarser outwards), every interior edge a cohesive joint (``fracture=True``:
f_t = 8 MPa, c = 30 MPa, φ = 35°, G_I = 50 J/m²); E = 60 GPa, ν = 0.25, ρ = 2650 kg/m³,
c = 800 J/(kg·K), α = 8e-6 1/K, plane strain; the outer edges on rollers.  The wall is held
at T₀ − 6 K from t = 0 (an elastic first stage: below ΔT_c), then, from t₁, at T_w = 60 °C, the
temperature of the injected water (``scene.heat(wall, temperature=60, curve=...)``); the rock
cools by conduction from the wall.

Time scaling: the conductivity is k = S × 3 W/(m·K) with S = ``TIME_SCALE`` (2 × 10⁶), so that
the cooled depth √(κt) (κ = k/(ρc)) reaches half the borehole radius (0.8 of it in the full
run) within a few thousand mechanical steps, tens of P-wave transits of the cooled zone (a
quasi-static mechanical response): one simulated second stands for S seconds of the real rock.
The thermal stresses depend on E, ν, α and the temperature field only, so the scaling changes
the time axis and nothing else.

The cooled rock contracts; at the free wall of a long cylinder in plane strain the hoop stress
is σ_θ = E α (T₀ − T) / (1 − ν) (tension), so radial cracks open at the wall once the cooling
exceeds ΔT_c = f_t (1 − ν) / (E α) and grow into the cooled zone.  The video shows the
temperature (left) and the joint damage (right), broken joints in red.  ``check``: at the end
of the elastic stage no joint is damaged and the nodes' temperatures within 3 √(κt) of the
wall agree with the radial conduction from a cylinder whose surface is held at its temperature
in an infinite medium (Carslaw & Jaeger 1959, §13.5, eq. 8, evaluated by quadrature) within
6 % of the wall's cooling; cracks open at the wall; of the joints damaged over 0.5, at least 90 % lie
where the rock has cooled by more than ΔT_c / 2 (the tips of the radial cracks run ahead into
less cooled rock) and all within 3 √(κt) of the wall.  The profile at the end (the two steps superposed) goes
to ``NAME_profile.csv`` (and, with matplotlib, ``NAME_profile.png``), the history with the heat
account to ``NAME_history.csv``.
"""
from __future__ import annotations

import csv
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "heated_borehole"
A = 0.1                               # borehole radius [m]
T0, TW = 200.0, 60.0                  # reservoir and wall temperature [°C]
TIME_SCALE = 2e6                      # conductivity multiplier (simulated time × S = real time)
ROCK = dict(density=2650.0, young=60e9, poisson=0.25, tensile_strength=8e6, cohesion=30e6, friction_angle=35.0,
            fracture_energy=50.0, conductivity=3.0 * TIME_SCALE, heat_capacity=800.0, expansion=8e-6)
FIRST_COOLING = 6.0                   # K: the wall's cooling in the elastic first stage (below ΔT_c)
# block size L [m], element size at the wall h [m], the cooled depths √(κt) [m] at the end of the
# elastic stage and at the end, the samples (video frames) of the two stages
SIZE = {True: dict(L=0.6, h=0.025, depths=(0.03, 0.05), samples=(4, 16)),
        False: dict(L=1.0, h=0.0125, depths=(0.04, 0.08), samples=(10, 50))}
EULER_GAMMA = 0.5772156649015329
PROFILE_TOL = 0.06                    # of the wall's cooling


def diffusivity() -> float:
    """κ = k / (ρ c) [m²/s] of the scaled rock."""
    return ROCK["conductivity"] / (ROCK["density"] * ROCK["heat_capacity"])


def crack_onset() -> float:
    """ΔT_c [K]: the cooling at which the hoop stress E α ΔT / (1 − ν) of the wall reaches f_t."""
    return ROCK["tensile_strength"] * (1.0 - ROCK["poisson"]) / (ROCK["young"] * ROCK["expansion"])


def radial_conduction(r, t: float, a: float = A, kappa: float | None = None):
    """(T − T₀)/(T_w − T₀) at radii ``r`` ≥ a [m] and time t [s] around a cylinder of radius a
    whose surface is held at T_w from t = 0 in an infinite medium at T₀ (Carslaw & Jaeger 1959,
    §13.5, eq. 8):

        v/V = 1 + (2/π) ∫₀^∞ exp(−κu²t) [J₀(ur)Y₀(ua) − Y₀(ur)J₀(ua)] / [J₀²(ua) + Y₀²(ua)] du/u,

    integrated over s = ln(ua) with ``scipy.integrate.quad`` down to s = −40 and analytically
    below (the small-argument forms of J₀ and Y₀)."""
    import numpy as np
    from scipy import integrate, special
    kappa = diffusivity() if kappa is None else kappa
    tau = kappa * t / (a * a)

    def one(rho):
        if rho <= 1.0:
            return 1.0

        def f(s):
            x = math.exp(s)
            num = special.j0(x * rho) * special.y0(x) - special.y0(x * rho) * special.j0(x)
            return math.exp(-tau * x * x) * num / (special.j0(x) ** 2 + special.y0(x) ** 2)
        lo, hi = -40.0, 0.5 * math.log(50.0 / tau)      # exp(−τx²) < e⁻⁵⁰ beyond hi
        val, _ = integrate.quad(f, lo, hi, limit=400)
        # below lo (x → 0): J₀ → 1, Y₀ → (2/π)(ln(x/2) + γ), f → −(π/2) ln ρ / (s + γ − ln 2)²
        val -= 0.5 * math.pi * math.log(rho) / abs(lo + EULER_GAMMA - math.log(2.0))
        return 1.0 + 2.0 / math.pi * val
    return np.array([one(float(x) / a) for x in np.atleast_1d(r)])


def wall_curve(t1: float):
    """The wall's held-temperature amplitude: ``FIRST_COOLING`` / (T₀ − T_w) until t1 [s], then 1
    (reached over t1 / 1000)."""
    import taichi_fdem as fdem
    f = FIRST_COOLING / (T0 - TW)
    return fdem.Curve([0.0, t1, 1.001 * t1], [f, f, 1.0], name="wall")


def build(short: bool):
    import numpy as np
    import taichi_fdem as fdem
    s = SIZE[short]
    rock = fdem.Material(**ROCK, joint_penalty=10 * ROCK["young"], name="granite")
    scene = fdem.Scene(gravity=(0.0, 0.0))
    L = s["L"]
    body = scene.add_body(fdem.mesh.plate_with_hole(L, L, A, s["h"]), rock, fracture=True, name="rock")
    tol = 1e-6
    scene.fix_nodes(lambda x, y: np.abs(x) > 0.5 * L - tol, body=body, velocity=(0.0, None))
    scene.fix_nodes(lambda x, y: np.abs(y) > 0.5 * L - tol, body=body, velocity=(None, 0.0))
    t1, t_end = (d * d / diffusivity() for d in s["depths"])
    scene.set_temperature(T0)
    scene.heat(lambda x, y: np.hypot(x, y) < A * (1 + 1e-6), body=body, temperature=TW, curve=wall_curve(t1))
    sim = scene.build(quasi_static=True)
    return sim, t1, t_end


def reference(r, t: float, t1: float):
    """T [°C] of the two-step wall history (``FIRST_COOLING`` from 0, the rest from t1) by
    superposition of :func:`radial_conduction`."""
    v = FIRST_COOLING * radial_conduction(r, t)
    if t > t1:
        v = v + (T0 - TW - FIRST_COOLING) * radial_conduction(r, t - t1)
    return T0 - v


def profile_error(sim, t1: float):
    """(max |T − T_ref| / (T₀ − T_w) over the nodes within 3 √(κt) of the wall at the heat's time
    t, the radii, the simulated and the reference temperatures of those nodes)."""
    import numpy as np
    t = sim.solver.heat.time
    X = np.asarray(sim.model.node_rest)
    r = np.hypot(X[:, 0], X[:, 1])
    near = (r > A * (1 + 1e-6)) & (r < A + 3.0 * math.sqrt(diffusivity() * t))
    T = sim.temperatures()[near]
    ref = reference(r[near], t, t1)
    scale = FIRST_COOLING if t <= t1 else T0 - TW
    return float(np.max(np.abs(T - ref)) / scale), r[near], T, ref


def plot_profile(r, T, ref, t: float, path: str) -> bool:
    """The nodes' temperatures against the radial conduction reference at time t [s]; False
    without matplotlib."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    import numpy as np
    order = np.argsort(r)
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    ax.plot(1e3 * (r[order] - A), ref[order], "k-", label="Carslaw & Jaeger §13.5 (two steps superposed)")
    ax.plot(1e3 * (r - A), T, "o", ms=3, mfc="none", label="nodes of the simulation")
    ax.set_xlabel("distance from the wall [mm]")
    ax.set_ylabel("temperature [°C]")
    depth = 1e3 * math.sqrt(diffusivity() * t)
    ax.set_title(f"cooled well wall: temperature at t = {t:.3g} s (√(κt) = {depth:.0f} mm)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return True


def joint_fields(sim):
    """(radius of each joint's midpoint [m], its mean node temperature, its damage)."""
    import numpy as np
    jn = sim.model.joint_nodes.to_numpy()[: sim.model.joint_count].astype(np.int64)     # the only body's joints
    X = np.asarray(sim.model.node_rest)[jn].mean(axis=1)
    return np.hypot(X[:, 0], X[:, 1]), sim.temperatures()[jn].mean(axis=1), sim.cracks.joint_damage()


def main(argv=None) -> dict:
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], argv)
    clock = _common.Timer()
    _common.init(args.precision)
    import numpy as np
    import taichi_fdem as fdem
    from taichi_fdem.render import RendererImage, VideoWriter

    s = SIZE[args.short]
    sim, t1, t_end = build(args.short)
    kappa, dtc = diffusivity(), crack_onset()
    print(f"{NAME}: {sim.model.tri_count} triangles, {sim.model.joint_count} joints, dt = {sim.dt:.3g} s, "
          f"heat step {sim.model.dt_heat:.3g} s; κ = {kappa:.3g} m²/s (× {TIME_SCALE:g}); the wall cooled by "
          f"{FIRST_COOLING:.0f} K until {t1:.3g} s (√(κt) = {math.sqrt(kappa * t1) * 1e3:.0f} mm), "
          f"then to {TW:.0f} °C "
          f"until {t_end:.3g} s (√(κt) = {math.sqrt(kappa * t_end) * 1e3:.0f} mm); crack onset ΔT_c = {dtc:.1f} K",
          flush=True)
    size = (320, 240) if args.short else (640, 480)
    view = (-3.2 * A, 3.2 * A, -3.2 * A, 3.2 * A)
    r_T = RendererImage(*size, view=view, color_by="temperature", vmin=TW, vmax=T0, cmap="coolwarm",
                        colorbar=True, stamp=not args.short)
    r_D = RendererImage(*size, view=view, color_by="damage", vmin=0.0, vmax=1.0, cracks=True, colorbar=True,
                        stamp=False)
    base = os.path.splitext(os.path.abspath(args.out))[0]
    os.makedirs(os.path.dirname(base), exist_ok=True)
    hist_path = base + "_history.csv"
    if os.path.exists(hist_path):
        os.remove(hist_path)
    rows = []
    every = max(1, round(t_end / sim.dt / 200))          # about 200 history rows over the whole run
    with VideoWriter(args.out, fps=6 if args.short else 15) as video:
        for k, (n, t_a, t_b) in enumerate(((s["samples"][0], 0.0, t1), (s["samples"][1], t1, t_end))):
            for _ in range(n):
                sim.run((t_b - t_a) / n, record=[fdem.History(hist_path, every=every)])
                rj, Tj, D = joint_fields(sim)
                rows.append((sim.time, int((D > 0).sum()), int((D > 0.5).sum()), sim.cracks.broken_count))
                video.append(np.concatenate([r_T.render_sim(sim), r_D.render_sim(sim)], axis=1))
            if k == 0:
                err_el = profile_error(sim, t1)[0]
                damage_el = float(sim.cracks.joint_damage().max())
    rj, Tj, D = joint_fields(sim)
    failed = D > 0.5
    cooled = (T0 - Tj) > 0.5 * dtc
    err_end, rr, Tn, ref = profile_error(sim, t1)
    prof_path = base + "_profile.csv"
    order = np.argsort(rr)
    with open(prof_path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["radius_m", "temperature_C", "reference_C"])
        for i in order.tolist():
            w.writerow([f"{rr[i]:.6g}", f"{Tn[i]:.6g}", f"{ref[i]:.6g}"])
    png = base + "_profile.png"
    if not plot_profile(rr, Tn, ref, sim.solver.heat.time, png):
        png = None
    out = dict(t1=t1, profile_png=png, profile_error_elastic=err_el, damage_elastic=damage_el,
               profile_error_end=err_end,
               t_end=sim.solver.heat.time, kappa=kappa, crack_onset_dT=dtc, damaged=int((D > 0).sum()),
               failed=int(failed.sum()), broken=sim.cracks.broken_count,
               failed_in_cooled_zone=float(np.mean(cooled[failed])) if failed.any() else 0.0,
               crack_depth=float(rj[failed].max() - A) if failed.any() else 0.0,
               wall_failed=int((failed & (rj < A + 1.5 * s["h"])).sum()),
               cooled_depth=float(math.sqrt(kappa * sim.solver.heat.time)), rows=rows, csv=hist_path,
               profile_csv=prof_path, video=os.path.abspath(args.out), triangles=sim.model.tri_count,
               steps=sim.step_count, wall_s=clock(), energies=sim.energies())
    print(f"  temperature within 3√(κt) of the wall against Carslaw & Jaeger §13.5: max error {100 * err_el:.1f} % "
          f"of the cooling at {t1:.3g} s (elastic: largest joint damage {damage_el:.2g}), {100 * err_end:.1f} % at "
          f"the end (two steps superposed)")
    print(f"  {out['damaged']} joints damaged, {out['failed']} over 0.5 ({out['wall_failed']} at the wall), "
          f"{out['broken']} broken; the deepest {out['crack_depth'] * 1e3:.0f} mm from the wall (√(κt) = "
          f"{out['cooled_depth'] * 1e3:.0f} mm); {100 * out['failed_in_cooled_zone']:.0f} % where the rock cooled by "
          f"more than ΔT_c/2")
    assert damage_el == 0.0, f"joints damaged in the elastic stage ({damage_el:.3g})"
    assert err_el < PROFILE_TOL, f"temperature profile off the radial conduction reference by {err_el:.1%}"
    assert out["wall_failed"] > 0, "no crack at the wall"
    assert out["failed_in_cooled_zone"] >= 0.9, "cracks outside the cooled zone"
    assert out["crack_depth"] < 3.0 * out["cooled_depth"], "cracks beyond the cooled zone"
    print(f"  wrote {args.out}, {hist_path} and {prof_path}; {out['wall_s']:.1f} s wall time")
    return out


if __name__ == "__main__":
    main()

"""Thermal cracking of a grain-based granite heated slowly to several hundred °C (docs/theory/heat.md §16.5).

    python demos/thermal_cracking.py          # 15 mm specimen to 500 °C -> out/thermal_cracking.mp4, _cracks.csv, .png
    python demos/thermal_cracking.py --short  # 10 mm specimen to 320 °C (used by tests/test_demos_heat.py)

A free square specimen of Voronoi grains (``fdem.mesh.voronoi_grains``, seed 1) of quartz,
plagioclase, K-feldspar and biotite (35 / 30 / 25 / 10 % of the area), the grain-based granite
of ``demos/calibrate_granite.py`` at its calibrated micro-parameters (grain modulus E_g = 70 GPa,
ν = 0.236; quartz 1.3, feldspars 1.0, biotite 0.5 × E_g; grain-boundary joints f_t = 6.46 MPa,
c = 78 MPa, φ = 35°, G_I = 20 J/m², the joints inside the grains twice as strong; plane strain).
Linear expansion coefficients α [1/K]: quartz 2.4e-5 (its mean up to 500 °C: quartz expands
anisotropically, about 1.4e-5 along a and 0.8e-5 along c at room temperature, and faster
towards the α–β transition at 573 °C: 1.365e-5 and 0.750e-5 at 25 °C in the review of
Kosinski et al. 1992, "Thermoelasticity in quartz", ESA SP-340, 397),
plagioclase 0.7e-5, the mean linear expansion of an An30 plagioclase (that of a granite) from the
volume expansion over 25–660 °C measured by Tribaudino et al. (2010, "Thermal expansion of
plagioclase feldspars", Contrib. Mineral. Petrol. 160, 899–908: 0.55e-5 for anorthite to 0.97e-5
for albite), K-feldspar 0.8e-5, biotite 1.2e-5, after the mineral data compiled by Skinner
(1966, "Thermal expansion", in S.P. Clark (ed.), Handbook of Physical Constants, Geol. Soc. Am.
Memoir 97, 75–96). Fredrich & Wong (1986, "Micromechanics of thermally induced cracking in
three crustal rocks", J. Geophys. Res. 91(B12), 12743–12764) analyse the thermal cracking of
granite from such mismatches.
Conductivities 7.7, 2.3, 2.3, 2.0 W/(m·K) (Clauser & Huenges 1995, "Thermal conductivity of
rocks and minerals", AGU Reference Shelf 3, 105–126) and heat capacities 700–770 J/(kg·K),
typical of silicate minerals at room temperature (they set the heat stored, not the stresses).

Heating: every node is held at a uniform temperature ramped by a ``fdem.Curve`` from 20 °C
(stress-free) to the final temperature (``scene.heat(everywhere, temperature=..., curve=ramp)``),
over 100 (short) or 200 P-wave transits of the specimen with ``quasi_static=True``: the stresses
are those of the grains' expansion mismatch alone, with no thermal gradient and no conduction
time scale.  A crack is a joint whose stress has reached its strength (damage D > 0, softening
begun); broken joints (D = 1) are counted too.

Analytic reference of the onset: a quartz grain (α_q, E_q) in plagioclase (α_p, E_p), as a
circular inclusion in plane strain (the Lamé solution of a thick cylinder, Timoshenko & Goodier 1970, ch. 4),
presses on its neighbours with p = (α_q − α_p) ΔT / (1/E_p + (1 − 2ν)/E_q), the hoop stress of the
matrix at the interface being +p; the first cracks are expected where p reaches the
grain-boundary f_t, at ΔT_c = f_t (1/E_p + (1 − 2ν)/E_q) / (α_q − α_p).  Output: the video
coloured by joint damage with broken joints in red, the crack count against temperature to
``NAME_cracks.csv`` and, with matplotlib, ``NAME_cracks.png``.  ``check``: no crack below
ΔT_c / 2, the first crack within a factor 2 of ΔT_c, the first cracks on grain boundaries (at
least 80 % of the first 10), the count non-decreasing with T and growing.
"""
from __future__ import annotations

import csv
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "thermal_cracking"
MINERALS = {"quartz": 0.35, "plagioclase": 0.30, "k_feldspar": 0.25, "biotite": 0.10}
STIFFNESS = {"quartz": 1.3, "plagioclase": 1.0, "k_feldspar": 1.0, "biotite": 0.5}       # × E_g
EXPANSION = {"quartz": 2.4e-5, "plagioclase": 0.7e-5, "k_feldspar": 0.8e-5, "biotite": 1.2e-5}  # 1/K
CONDUCTIVITY = {"quartz": 7.7, "plagioclase": 2.3, "k_feldspar": 2.3, "biotite": 2.0}      # W/(m·K)
HEAT_CAPACITY = {"quartz": 740.0, "plagioclase": 710.0, "k_feldspar": 700.0, "biotite": 770.0}  # J/(kg·K)
DENSITY = 2650.0                     # kg/m³
GRAIN = {"young": 70.05e9, "poisson": 0.236, "tensile_strength": 6.46e6, "cohesion": 78.0e6}
PHI, G_I, INTRA, PENALTY = 35.0, 20.0, 2.0, 13.0      # °, J/m², intra-grain × boundary, × E_g
T0 = 20.0                                              # °C, stress-free
SIZE = {True: dict(width=0.01, grain=0.0025, h=0.001, T1=320.0, transits=100.0, samples=100, frames=25),
        False: dict(width=0.015, grain=0.002, h=0.00075, T1=500.0, transits=200.0, samples=200, frames=80)}
SLOW = (0.4, 40.0)                   # the first 40 K of the heating take 40 % of its time
FIRST = 10                           # the first cracks checked to lie on grain boundaries
SEED = 1


def materials():
    """({mineral: Material}, grain-boundary Material)."""
    import taichi_fdem as fdem
    E, ft, c = GRAIN["young"], GRAIN["tensile_strength"], GRAIN["cohesion"]
    common = dict(density=DENSITY, poisson=GRAIN["poisson"], friction_angle=PHI, joint_penalty=PENALTY * E)
    by = {k: fdem.Material(young=f * E, tensile_strength=INTRA * ft, cohesion=INTRA * c, fracture_energy=INTRA * G_I,
                           conductivity=CONDUCTIVITY[k], heat_capacity=HEAT_CAPACITY[k], expansion=EXPANSION[k],
                           name=k, **common) for k, f in STIFFNESS.items()}
    boundary = fdem.Material(young=E, tensile_strength=ft, cohesion=c, fracture_energy=G_I, name="boundary", **common)
    return by, boundary


def onset_reference() -> float:
    """ΔT_c [K]: the temperature rise at which the mismatch pressure of a quartz grain in
    plagioclase (plane-strain circular inclusion) reaches the grain-boundary f_t."""
    E = GRAIN["young"]
    Eq, Ep, nu = STIFFNESS["quartz"] * E, STIFFNESS["plagioclase"] * E, GRAIN["poisson"]
    dalpha = EXPANSION["quartz"] - EXPANSION["plagioclase"]
    return GRAIN["tensile_strength"] * (1.0 / Ep + (1.0 - 2.0 * nu) / Eq) / dalpha


def build(short: bool):
    import numpy as np
    import taichi_fdem as fdem
    from taichi_fdem import mesh
    s = SIZE[short]
    m, lab = mesh.voronoi_grains(s["width"], s["width"], s["grain"], s["h"], seed=SEED, minerals=MINERALS)
    by, boundary = materials()
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(m, lab.materials(by), groups=lab, fracture=True, name="granite")
    scene.add_joint_set("grain_boundaries", "interfaces", boundary)
    t_ramp = s["transits"] * s["width"] / by["quartz"].p_wave_speed("strain")
    scene.set_temperature(T0)
    f, dT = SLOW
    ramp = fdem.Curve([0.0, f * t_ramp, t_ramp], [0.0, dT / (s["T1"] - T0), 1.0], name="heating")
    scene.heat(lambda x, y: np.ones_like(x, bool), temperature=s["T1"], curve=ramp)
    sim = scene.build(quasi_static=True)
    return sim, lab, t_ramp


def write_csv(path: str, rows: list) -> str:
    cols = ["temperature_C", "cracked", "cracked_grain_boundary", "cracked_intra_grain", "damage_over_half", "broken"]
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in rows:
            w.writerow([f"{r[0]:.3f}", *r[1:]])
    return path


def plot(rows: list, dtc: float, path: str) -> bool:
    """Crack counts against temperature; False without matplotlib."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    import numpy as np
    a = np.array(rows, float)
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    ax.plot(a[:, 0], a[:, 1], "-", label="cracked joints (D > 0)")
    ax.plot(a[:, 0], a[:, 2], "--", label="on grain boundaries")
    ax.plot(a[:, 0], a[:, 3], ":", label="inside grains")
    ax.plot(a[:, 0], a[:, 5], "-", lw=2, label="broken joints")
    ax.axvline(T0 + dtc, color="k", lw=0.8, ls="-.", label=f"onset estimate T₀ + ΔT_c = {T0 + dtc:.0f} °C")
    ax.set_xlabel("temperature [°C]")
    ax.set_ylabel("joints")
    ax.set_title("thermal cracking of a grain-based granite")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return True


def check(rows: list, onset: dict, gb, dtc: float) -> dict:
    """The checks of the module docstring; returns the numbers they use."""
    import numpy as np
    a = np.array(rows, float)
    cracked = a[:, 1]
    first_T = float(a[np.argmax(cracked > 0), 0]) if cracked.max() > 0 else float("nan")
    idx = sorted(onset, key=lambda j: (onset[j], j))
    first = idx[:FIRST]
    frac = float(np.mean(gb[first])) if first else 0.0
    r = dict(first_crack_C=first_T, first_crack_dT=first_T - T0, onset_reference_dT=dtc,
             first_on_grain_boundaries=frac, monotonic=bool(np.all(np.diff(a[:, 1:], axis=0) >= 0)))
    assert cracked.max() > 0, "no crack"
    assert 0.5 * dtc <= first_T - T0 <= 2.0 * dtc, (first_T - T0, dtc)
    assert frac >= 0.8, f"first cracks on grain boundaries: {frac:.0%}"
    assert r["monotonic"] and cracked[-1] > cracked[np.argmax(cracked > 0)], "the crack count does not grow"
    return r


def main(argv=None) -> dict:
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], argv)
    clock = _common.Timer()
    _common.init(args.precision)
    import numpy as np
    from taichi_fdem.render import RendererImage, VideoWriter

    s = SIZE[args.short]
    sim, lab, t_ramp = build(args.short)
    md = sim.model
    gb = np.asarray(md.joint_set_np)[: md.joint_count] == md.joint_set_names.index("grain_boundaries")
    dtc = onset_reference()
    print(f"  built in {clock():.1f} s")
    print(f"{NAME}: {sim.model.tri_count} triangles, {lab.grain_count} grains, {sim.model.joint_count} joints "
          f"({int(gb.sum())} on grain boundaries), dt = {sim.dt:.3g} s; heating {T0:.0f} -> {s['T1']:.0f} °C over "
          f"{t_ramp:.3g} s; onset estimate ΔT_c = {dtc:.1f} K", flush=True)
    half = 0.5 * s["width"] * 1.05
    size = (320, 320) if args.short else (720, 720)
    renderer = RendererImage(*size, view=(-half, half, -half, half), color_by="damage", vmin=0.0, vmax=1.0,
                             cracks=True, colorbar=not args.short, stamp=not args.short)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    rows, onset = [], {}
    every = max(1, s["samples"] // s["frames"])
    with VideoWriter(args.out, fps=10 if args.short else 30) as video:
        for k in range(s["samples"]):
            sim.run(t_ramp / s["samples"])
            T = float(sim.temperatures().mean())
            D = sim.cracks.joint_damage()
            for j in np.nonzero(D > 0)[0].tolist():          # loop over the cracked joints, per sample
                onset.setdefault(j, T)
            c = D > 0
            rows.append((T, int(c.sum()), int((c & gb).sum()), int((c & ~gb).sum()), int((D > 0.5).sum()),
                         sim.cracks.broken_count))
            if k % every == every - 1 or k == s["samples"] - 1:
                video.append(renderer.render_sim(sim))
    base = os.path.splitext(os.path.abspath(args.out))[0]
    csv_path = write_csv(base + "_cracks.csv", rows)
    png = base + "_cracks.png"
    if not plot(rows, dtc, png):
        png = None
    r = check(rows, onset, gb, dtc)
    print("\n| T [°C] | cracked | on grain boundaries | inside grains | D > 0.5 | broken |")
    print("|---:|---:|---:|---:|---:|---:|")
    for row in rows[:: max(1, len(rows) // 12)] + [rows[-1]]:
        print(f"| {row[0]:.0f} | " + " | ".join(str(v) for v in row[1:]) + " |")
    print(f"\n  first crack at {r['first_crack_C']:.1f} °C (ΔT = {r['first_crack_dT']:.1f} K, estimate {dtc:.1f} K); "
          f"{r['first_on_grain_boundaries']:.0%} of the first {FIRST} on grain boundaries "
          f"({gb.mean():.0%} of the joints); {rows[-1][1]} cracked, {rows[-1][5]} broken at {rows[-1][0]:.0f} °C")
    out = dict(r, rows=rows, csv=csv_path, png=png, video=os.path.abspath(args.out), triangles=sim.model.tri_count,
               joints=int(sim.model.joint_count), grain_boundary_joints=int(gb.sum()), final_C=rows[-1][0],
               cracked=rows[-1][1], broken=rows[-1][5], steps=sim.step_count, energies=sim.energies(), wall_s=clock())
    print(f"  wrote {args.out}, {csv_path}" + (f" and {png}" if png else " (no plot: matplotlib is not installed)")
          + f"; {out['wall_s']:.1f} s wall time")
    return out


if __name__ == "__main__":
    main()

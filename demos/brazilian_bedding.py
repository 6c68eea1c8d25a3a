"""Brazilian tests of a bedded (shale-like) rock across bedding angles (docs/guide/anisotropy.md).

    python demos/brazilian_bedding.py            # writes out/brazilian_bedding.mp4 and out/brazilian_bedding.csv
    python demos/brazilian_bedding.py --short    # a quick, coarser version (used by tests/test_demos_bedding.py)

A series of ``fdem.lab.brazilian`` discs (D = 50 mm, every interior edge a cohesive joint) of a
transversely isotropic rock with weak bedding planes, after the laboratory series of Tavallali &
Vervoort (2010): the bedding angle β between the bedding planes and the loading direction runs
0°, 30°, 60°, 90° (the full mode adds 15°, 45° and 75° on a twice finer disc).  The rock:
E1 = 20 GPa along the bedding, E2 = 10 GPa across it (E1/E2 = 2), ν1 = 0.2, ν21 = 0.15,
G2 = 4 GPa; the matrix's joints f_t = 6 MPa, c = 18 MPa, φ = 35°; the bedding's f_t = 2 MPa and
c = 6 MPa (1/3 of the matrix's), φ = 30°, both with the characteristic length l_ch = E1 G_I/f_t²
= 9.4 mm; weak bedding planes every D/4 (D/8 in the full mode), one through the centre.

For each angle: the indirect tensile strength σ_t = 2 P_max/(π D) (printed as a table and written
to out/brazilian_bedding.csv with the number of broken joints, their share on the bedding planes,
the share running within 10° of the bedding and their mean direction) and the crack pattern.
Loading parallel to the bedding (β = 0°) the disc splits along its central bedding plane, above the
bedding's f_t (a disc of a few l_ch splits above f_t, docs/guide/lab.md) and well below the matrix's;
loading across it (β = 90°) the disc is the strongest and its cracks cross the layers (on the finer
disc of the full mode the joints under the platens fail first, in shear, then the bedding next to
them slips); in between, the cracks run along the bedding.  Also reported: the mean direction of
the first broken joints (the first quarter, at least 4).  The video shows the discs side by side, coloured by joint damage, the
broken joints in red, the bedding planes hatched in white.

``check``: σ_t(90°) > 1.5 σ_t(0°); at β = 0° and 30° the broken joints' mean direction lies within
10° of the bedding and most of them (over half) run within 10° of it (on the weak bedding planes
or on matrix joints parallel to them, weakened by their angle to the bedding); at β = 90° less than
half of them do (the failure does not follow the bedding).
"""
from __future__ import annotations

import csv
import math
import os
import sys
import tempfile
import warnings

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "brazilian_bedding"
D = 0.05                                   # disc diameter [m]
E1, E2, NU1, NU21, G2 = 20e9, 10e9, 0.2, 0.15, 4e9
FT, C, PHI = 6e6, 18e6, 35.0               # matrix joints
FT_B, C_B, PHI_B = 2e6, 6e6, 30.0          # bedding joints
LCH = 9.375e-3                             # l_ch = E1 G_I / f_t² [m] of both
ANGLES_SHORT = (0.0, 30.0, 60.0, 90.0)
ANGLES_FULL = (0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0)
VIEW = (-0.6 * D, 0.6 * D, -0.6 * D, 0.6 * D)      # the drawn box [m]
CRACK = (0.85, 0.1, 0.1)                           # colour of the broken joints


def material(spacing: float):
    """The bedded rock (bedding dip set by lab.brazilian's ``bedding_angle``)."""
    import taichi_fdem as fdem
    bed = fdem.Bedding(90.0, young_normal=E2, poisson_normal=NU21, shear_modulus=G2,
                       tensile_strength=FT_B, cohesion=C_B, friction_angle=PHI_B,
                       fracture_energy=LCH * FT_B ** 2 / E1, fracture_energy_shear=10 * LCH * FT_B ** 2 / E1,
                       spacing=spacing)
    return fdem.Material(density=2500.0, young=E1, poisson=NU1, tensile_strength=FT, cohesion=C,
                         friction_angle=PHI, fracture_energy=LCH * FT ** 2 / E1,
                         fracture_energy_shear=10 * LCH * FT ** 2 / E1, bedding=bed)


def joint_geometry(sim):
    """(direction [° from x, 0..180), set name) of every joint of the scene, in the model's order."""
    import numpy as np
    X = sim.model.node_rest
    jn = np.concatenate([b.joint_nodes + b.node_start for b in sim.scene.bodies if b.fracture and b.joint_count])
    d = X[jn[:, 1]] - X[jn[:, 0]]
    direction = np.mod(np.degrees(np.arctan2(d[:, 1], d[:, 0])), 180.0)
    names = np.asarray(sim.model.joint_set_names, dtype=object)[sim.model.joint_set_np]
    return direction, names


def mean_direction(deg):
    """Mean direction [°, 0..180) of lines at ``deg`` (the mean of the doubled angles) and its
    resultant length (1: all parallel, 0: spread evenly)."""
    import numpy as np
    z = np.exp(2j * np.radians(np.asarray(deg, dtype=float))).mean()
    return float(np.mod(np.degrees(np.angle(z)) / 2.0, 180.0)), float(abs(z))


def line_gap(a, b) -> float:
    """Angle [°, 0..90] between two lines at ``a`` and ``b`` degrees."""
    g = abs(a - b) % 180.0
    return min(g, 180.0 - g)


def run_angle(mat, beta, h, load_time, frames_dir, size, every):
    """lab.brazilian at bedding angle ``beta``, every ``every``-th sample drawn to ``frames_dir``
    (PNG, ``size`` pixels square, coloured by joint damage, the broken joints in red): a row of the
    table (dict)."""
    import numpy as np
    import taichi_fdem as fdem
    from taichi_fdem.render import RendererImage
    from taichi_fdem.render.video import save_png
    renderer = RendererImage(size, size, view=VIEW, color_by="damage", vmin=0.0, vmax=1.0, colorbar=False,
                             stamp=False, cracks=True, crack_color=CRACK, crack_width=2.0)
    os.makedirs(frames_dir, exist_ok=True)
    count = [0]

    def frame(sim):
        if count[0] % every == 0:
            save_png(os.path.join(frames_dir, f"frame_{count[0]:05d}.png"), renderer.render_sim(sim))
        count[0] += 1
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RuntimeWarning)
        r = fdem.lab.brazilian(mat, D, h, load_time=load_time, samples=60 if every == 1 else 120, bedding_angle=beta,
                               frame=frame)
    save_png(os.path.join(frames_dir, f"frame_{count[0]:05d}.png"), renderer.render_sim(r.sim))
    dip = 90.0 - beta
    idx = np.asarray(r.sim.cracks.broken()["index"], dtype=int)
    direction, names = joint_geometry(r.sim)
    md, resultant = mean_direction(direction[idx]) if len(idx) else (math.nan, 0.0)
    load = np.asarray(r.curve["load_N_per_m"])
    return dict(beta=beta, dip=dip, sigma_t=r.peak_stress, centre_stress=r.centre_stress, peaked=r.peaked,
                broken=len(idx), on_bedding=float(np.mean(names[idx] == "bedding")) if len(idx) else 0.0,
                along_bedding=float(np.mean([line_gap(a, dip) < 10.0 for a in direction[idx]])) if len(idx) else 0.0,
                mean_direction=md, resultant=resultant,
                gap_to_bedding=line_gap(md, dip) if len(idx) else math.nan,
                first_direction=mean_direction(direction[idx[: max(4, len(idx) // 4)]])[0] if len(idx) else math.nan,
                final_over_peak=float(load[-1] / load.max()), steps=r.summary["steps"],
                triangles=r.sim.model.tri_count, warnings=[str(w.message) for w in caught])


def compose(rows, dirs, spacing, view, out_path, fps, max_frames):
    """The discs side by side, each advancing through its own frames; a label per disc."""
    import imageio.v3 as iio
    import numpy as np
    from taichi_fdem.render import VideoWriter
    from taichi_fdem.render.labels import annotate
    stacks = [sorted(os.path.join(d, f) for f in os.listdir(d) if f.endswith(".png")) for d in dirs]
    n = min(max_frames, max(len(s) for s in stacks))
    with VideoWriter(out_path, fps=fps) as video:
        for i in range(n + 3):
            panels = []
            for row, files in zip(rows, stacks):
                k = min(len(files) - 1, round(min(i, n - 1) * (len(files) - 1) / max(1, n - 1)))
                img = _common.hatch_bedding(iio.imread(files[k])[..., :3], row["dip"], spacing, view, keep=CRACK,
                                            inside=lambda x, y: x * x + y * y < 0.25 * D * D)
                text = f"beta = {row['beta']:.0f} deg"
                if i >= n - 1:
                    text += f"  {row['sigma_t'] / 1e6:.1f} MPa"
                panels.append(annotate(img, text))
            video.append(np.concatenate(panels, axis=1))
    return n + 3


def check(rows) -> None:
    """Strength ratio across/along the bedding and the crack directions (module docstring)."""
    by = {r["beta"]: r for r in rows}
    ratio = by[90.0]["sigma_t"] / by[0.0]["sigma_t"]
    assert ratio > 1.5, f"σ_t(90°)/σ_t(0°) = {ratio:.2f}: loading across the bedding is not clearly stronger"
    for beta in (0.0, 30.0):
        r = by[beta]
        assert r["broken"] > 0 and r["gap_to_bedding"] < 10.0, \
            f"β = {beta:.0f}°: broken joints' mean direction {r['mean_direction']:.0f}° is not the bedding's " \
            f"{r['dip']:.0f}°"
        assert r["along_bedding"] > 0.5, \
            f"β = {beta:.0f}°: only {r['along_bedding']:.0%} of the broken joints run along the bedding"
    r = by[90.0]
    assert r["broken"] > 0 and r["along_bedding"] < 0.5, \
        f"β = 90°: {r['along_bedding']:.0%} of the broken joints run along the bedding"


def write_csv(path, rows) -> None:
    keys = ("beta", "dip", "sigma_t", "centre_stress", "peaked", "broken", "on_bedding", "along_bedding",
            "mean_direction",
            "resultant", "gap_to_bedding", "first_direction", "final_over_peak", "triangles", "steps")
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["bedding_angle_deg", "bedding_dip_deg", "sigma_t_Pa", "centre_stress_Pa", "peaked",
                    "broken_joints", "broken_on_bedding_planes_fraction", "broken_along_bedding_fraction",
                    "broken_mean_direction_deg",
                    "direction_resultant", "direction_gap_to_bedding_deg", "first_broken_mean_direction_deg",
                    "final_over_peak_load",
                    "triangles", "steps"])
        for r in rows:
            w.writerow([r[k] if isinstance(r[k], (bool, int)) else f"{r[k]:.6g}" for k in keys])


def main(argv=None) -> dict:
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], argv)
    clock = _common.Timer()
    _common.init(args.precision)
    angles = ANGLES_SHORT if args.short else ANGLES_FULL
    h = D / (8 if args.short else 16)
    spacing = D / (4 if args.short else 8)
    load_time = 20.0 if args.short else 40.0
    mat = material(spacing)
    print(f"{NAME}: D = {D * 1e3:.0f} mm, h = {h * 1e3:.2f} mm, bedding planes every {spacing * 1e3:.2f} mm, "
          f"E1/E2 = {E1 / E2:.1f}, f_t {FT / 1e6:.0f} / {FT_B / 1e6:.0f} MPa (matrix / bedding)")
    rows, dirs = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for beta in angles:
            dirs.append(os.path.join(tmp, f"beta{beta:03.0f}"))
            rows.append(run_angle(mat, beta, h, load_time, dirs[-1], 180 if args.short else 360,
                                  1 if args.short else 2))
            r = rows[-1]
            print(f"  β = {beta:4.0f}°: σ_t = {r['sigma_t'] / 1e6:5.2f} MPa, {r['broken']:3d} broken joints "
                  f"({r['on_bedding']:.0%} on the bedding planes, {r['along_bedding']:.0%} along the bedding), "
                  f"mean direction {r['mean_direction']:5.1f}° "
                  f"(bedding {r['dip']:.0f}°), {r['triangles']} triangles", flush=True)
        os.makedirs(os.path.dirname(os.path.abspath(args.out)) or ".", exist_ok=True)
        frames = compose(rows, dirs, spacing, VIEW, args.out, fps=10 if args.short else 15,
                         max_frames=30 if args.short else 120)
    csv_path = os.path.join(os.path.dirname(os.path.abspath(args.out)), f"{NAME}.csv")
    write_csv(csv_path, rows)
    print("  β [°]   σ_t [MPa]   σ_t/σ_t(90°)   broken   on bedding   mean direction [°]   bedding dip [°]")
    s90 = next(r["sigma_t"] for r in rows if r["beta"] == 90.0)
    for r in rows:
        print(f"  {r['beta']:5.0f}   {r['sigma_t'] / 1e6:9.2f}   {r['sigma_t'] / s90:12.2f}   {r['broken']:6d}"
              f"   {r['on_bedding']:10.0%}   {r['mean_direction']:18.1f}   {r['dip']:15.0f}")
    check(rows)
    result = dict(rows=rows, angles=list(angles), sigma_t=[r["sigma_t"] for r in rows], h=h, spacing=spacing,
                  ft=FT, ft_bedding=FT_B, csv=csv_path, video=os.path.abspath(args.out), frames=frames,
                  wall_s=clock())
    print(f"  wrote {args.out} and {csv_path}; {result['wall_s']:.1f} s wall time")
    return result


if __name__ == "__main__":
    main()
    sys.exit(0)

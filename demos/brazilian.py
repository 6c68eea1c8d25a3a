"""Brazilian disc test: a jointed rock disc split between two stiff platens (docs/verification.md §8.8).

    python demos/brazilian.py            # writes out/brazilian.mp4 and out/brazilian_load.csv
    python demos/brazilian.py --short    # a quick, coarser version (used by tests/test_demos.py)

Every interior edge of the disc is a cohesive joint (``fracture=True``).  The platens move
towards each other (speed ramped up over the first tenth of the loading); the load P on the top
platen (per unit thickness) and the platen approach are recorded, printed as a table and written
to out/brazilian_load.csv.  The load is the platen reaction averaged over a sliding window of
D/c_p (the platens' boundary work over the window divided by their approach), which removes
the contact chatter and ringing of the instantaneous force (also written).  The indirect
tensile strength σ_t = 2 P_max/(π D t) is compared with the joints' tensile strength f_t, and
the crack must run along the loaded diameter.  The disc's
caps are flattened over ±10° so the load spreads over a few elements (with a point load the
joints under the platens crush first); the centre stress of a load spread over 2α is
(sin 2α − α)/α ≈ 0.96 times 2P/(πD) (Hondros): ``check`` asserts σ_t × 0.96 within 20 % of
f_t.  The scene and loading are taichi_fdem.verification.brazilian_scene / brazilian_load (one
copy shared with the tests).  The video is coloured by joint damage.
"""
from __future__ import annotations

import csv
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "brazilian"


def build(short: bool):
    """The scene of taichi_fdem.verification.brazilian_scene (one copy, shared with the tests)."""
    from taichi_fdem import verification as V
    return V.brazilian_scene(elements=24 if short else 40, load_time=20.0 if short else 100.0)


def check(sim, bodies, rec, p) -> dict:
    """σ_t × Hondros factor within 20 % of f_t at the peak of the filtered load, and a central split."""
    from taichi_fdem import verification as V
    out = V.brazilian_result(sim, bodies, rec, p)
    ratio = out["sigma_t_hondros_over_ft"]
    assert abs(ratio - 1.0) < 0.2, f"σ_t/f_t × Hondros = {ratio:.3f} is not within 20 % of 1"
    assert out["broken_after_peak"] >= 3 and out["central_fraction"] >= 0.8, \
        f"no central split: {out['central_fraction']:.0%} of {out['broken_after_peak']} broken joints central"
    return out


def main(argv=None) -> dict:
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], argv)
    clock = _common.Timer()
    _common.init(args.precision)
    from taichi_fdem import verification as V
    from taichi_fdem.render import RendererImage, VideoWriter

    sim, bodies, p = build(args.short)
    info = sim.info()
    print(f"{NAME}: {info['triangles']} triangles, {info['joints']} joints, dt = {info['dt']:.3g} s, "
          f"loading time {p['load_time']:.0f} D/c_p, platen speed {p['v']:.3g} m/s")
    size = (320, 320) if args.short else (720, 720)
    D = p["D"]
    view = (-0.75 * D, 0.75 * D, -0.75 * D, 0.75 * D)
    renderer = RendererImage(*size, view=view, color_by="damage", vmin=0.0, vmax=1.0,
                             colorbar=not args.short, stamp=not args.short)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)) or ".", exist_ok=True)
    every = 4 if args.short else 1
    count = [0]
    with VideoWriter(args.out, fps=15 if args.short else 30) as video:
        def frame(s):
            count[0] += 1
            if count[0] % every == 0:
                video.append(renderer.render_sim(s))
        rec = V.brazilian_load(sim, bodies, p, samples=120 if args.short else 240, frame=frame)
        for _ in range(3):
            video.append(renderer.render_sim(sim))
    csv_path = os.path.join(os.path.dirname(os.path.abspath(args.out)), "brazilian_load.csv")
    with open(csv_path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time_s", "platen_approach_m", "load_instantaneous_N_per_m", "broken_joints",
                    "window_mid_time_s", "window_mid_approach_m", "load_filtered_N_per_m"])
        for row in zip(rec["t"], rec["approach"], rec["P_inst"], rec["broken"], rec["t_P"], rec["approach_P"], rec["P"]):
            w.writerow([f"{row[0]:.6g}", f"{row[1]:.6g}", f"{row[2]:.6g}", int(row[3]), f"{row[4]:.6g}",
                        f"{row[5]:.6g}", f"{row[6]:.6g}"])
    print("  approach [mm]   load P [kN/m] (window mean over D/c_p)   instantaneous   broken joints")
    for i in range(0, len(rec["t"]), max(1, len(rec["t"]) // 20)):
        print(f"  {1e3 * rec['approach_P'][i]:12.4f}   {1e-3 * rec['P'][i]:13.2f}   {1e-3 * rec['P_inst'][i]:32.2f}"
              f"   {rec['broken'][i]:13d}")
    result = check(sim, bodies, rec, p)
    result["video"] = os.path.abspath(args.out)
    result["csv"] = csv_path
    result["wall_s"] = clock()
    result["steps"] = sim.step_count
    print(f"  peak load {1e-3 * result['P_max_N_per_m']:.1f} kN/m after {result['loading_time_to_peak_D_over_cp']:.0f} D/c_p: "
          f"σ_t = 2P/(πD) = {result['sigma_t_over_ft']:.3f} f_t (× Hondros {result['hondros']:.3f}: "
          f"{result['sigma_t_hondros_over_ft']:.3f} f_t); {result['central_fraction']:.0%} of the "
          f"{result['broken_after_peak']} joints broken by shortly after the peak lie within |x| < 0.15 D; "
          f"{result['fragments']} fragments")
    print(f"  wrote {args.out} and {csv_path}; {result['wall_s']:.1f} s wall time")
    return result


if __name__ == "__main__":
    main()
    sys.exit(0)

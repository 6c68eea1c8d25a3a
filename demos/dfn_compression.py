"""Uniaxial compression of a rock specimen cut by a discrete fracture network (docs/theory/discontinuities.md §13.1).

    python demos/dfn_compression.py            # writes out/dfn_compression.mp4, out/dfn_compression_curves.csv
    python demos/dfn_compression.py --short    # a quick, coarser version (used by tests/test_demos_rock.py)

A 0.05 × 0.1 m specimen holds a seeded random network of 8 straight fractures (lengths 12–30 mm,
random orientations; at least two crossings, no near-misses: drawn again until the network
meets these rules), meshed with ``fdem.mesh.polygon(..., lines=...)`` so that mesh edges follow
the fractures.  The fractures are pre-existing open cracks (``cracks=``: contact and friction
only, μ = 0.3) and every other interior edge is a cohesive joint (``fracture=True``; the brittle
rock of demos/triaxial.py: c = f_t = 0.1 MPa, φ = 30°, G_I = 2, G_II = 10 J/m²), so new cracks can
grow from the fracture tips.  Two frictionless platens close at a constant nominal strain rate
(``quasi_static=True``) until the axial stress has dropped well below its peak.  The same mesh
without the cracks (the fracture lines are then ordinary cohesive joints) is loaded the same way
for comparison.

Written: the stress–strain curves of both specimens (stress = the platens' mean reaction /
width, strain from the specimen's end faces) to CSV, the crack events of the DFN specimen, and a
video coloured by joint damage with the broken joints in red (DFN specimen, then the intact one).
Printed: both peaks and their ratio (``check``: the DFN specimen is the weaker one), and where
the first new cracks start: the fraction of the first 10 broken joints within 1.5 h of a
fracture tip and of a fracture, next to the same fractions over all the specimen's joints
(what cracks starting anywhere would give).  The pre-existing cracks are not joints, so the
video shows them only where they open.
"""
from __future__ import annotations

import csv
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "dfn_compression"
W, H = 0.05, 0.1
N_FRACTURES = 8
FIRST = 10                      # the first broken joints examined for their distance to the tips


def _seg_cross(a0, a1, b0, b1):
    """(crosses, t along a, s along b, |sin angle|) of two segments."""
    import numpy as np
    da, db = a1 - a0, b1 - b0
    den = da[0] * db[1] - da[1] * db[0]
    la, lb = np.linalg.norm(da), np.linalg.norm(db)
    if abs(den) < 1e-14:
        return False, 0.0, 0.0, 0.0
    r = b0 - a0
    t = (r[0] * db[1] - r[1] * db[0]) / den
    s = (r[0] * da[1] - r[1] * da[0]) / den
    return (0.0 < t < 1.0 and 0.0 < s < 1.0), t, s, abs(den) / (la * lb)


def _point_seg_dist(p, a, b):
    import numpy as np
    d = b - a
    t = min(1.0, max(0.0, float((p - a) @ d / (d @ d))))
    return float(np.linalg.norm(p - (a + t * d)))


def fracture_network(seed: int = 7, count: int = N_FRACTURES, clearance: float = 0.004):
    """A seeded random DFN inside the specimen: ``count`` segments (2, 2) [m], centred on the
    origin, each at least ``clearance`` from the specimen's sides.  Drawn one after the other:
    a candidate is dropped unless each of its crossings with the segments already placed is at
    more than 25° and more than ``clearance`` from both segments' ends, and no end point comes
    within ``clearance`` of a segment it does not cross (near-misses would give tiny elements).
    The whole network is drawn again until at least two pairs cross."""
    import numpy as np
    rng = np.random.default_rng(seed)
    lim = np.array([0.5 * W - clearance, 0.5 * H - clearance])

    def admissible(seg, placed):
        crossings = 0
        for other in placed:
            x, t, s, sin = _seg_cross(seg[0], seg[1], other[0], other[1])
            if x:
                crossings += 1
                la, lb = np.linalg.norm(seg[1] - seg[0]), np.linalg.norm(other[1] - other[0])
                if sin < math.sin(math.radians(25.0)) or min(t, 1 - t) * la < clearance \
                        or min(s, 1 - s) * lb < clearance:
                    return None
            elif min([_point_seg_dist(p, other[0], other[1]) for p in seg]
                     + [_point_seg_dist(p, seg[0], seg[1]) for p in other]) < clearance:
                return None
        return crossings

    for _ in range(1000):                      # networks
        placed, crossings = [], 0
        for _ in range(200 * count):           # candidate segments, each added if admissible
            c = rng.uniform(-lim, lim)
            L = rng.uniform(0.012, 0.030)
            th = rng.uniform(0.0, math.pi)
            d = 0.5 * L * np.array([math.cos(th), math.sin(th)])
            seg = np.array([c - d, c + d])
            if (np.abs(seg) > lim).any():
                continue
            k = admissible(seg, placed)
            if k is not None:
                placed.append(seg)
                crossings += k
                if len(placed) == count:
                    break
        if len(placed) == count and crossings >= 2:
            return np.array(placed), crossings
    raise RuntimeError("no admissible fracture network found")


def specimen(h: float, seed: int = 7):
    """(mesh, fracture Polylines, tips (k, 2), crossings) of the specimen centred on the origin."""
    import taichi_fdem as fdem
    segs, crossings = fracture_network(seed)
    lines = [fdem.mesh.Polyline(s, name=f"F{i}") for i, s in enumerate(segs)]
    rect = [(-0.5 * W, -0.5 * H), (0.5 * W, -0.5 * H), (0.5 * W, 0.5 * H), (-0.5 * W, 0.5 * H)]
    mesh = fdem.mesh.polygon(rect, h, lines=lines)
    tips = segs.reshape(-1, 2)                 # every end lies inside the specimen (clearance)
    return mesh, lines, tips, crossings


def material():
    from taichi_fdem.verification import TRIAXIAL_MATERIAL
    return dict(TRIAXIAL_MATERIAL, fracture_energy=2.0, fracture_energy_shear=10.0)


def compress(mesh, lines, short: bool, frame=None, crack_path=None):
    """Load ``mesh`` (cracked along ``lines`` unless None) between frictionless platens until the
    stress has dropped below 0.6 × its peak (or 3 × the Mohr–Coulomb peak strain of E/2)."""
    import numpy as np
    import taichi_fdem as fdem
    from taichi_fdem.verification.rock import axial_record, mohr_coulomb_peak
    mp = material()
    mp.setdefault("joint_penalty", 10.0 * mp["young"])
    mat = fdem.Material(**mp)
    pm = mat.with_(friction=0.0, name="platen")
    scene = fdem.Scene(gravity=(0.0, 0.0))
    spec = scene.add_body(mesh, mat, fracture=True, cracks=lines, crack_friction=0.3 if lines else None,
                          name="specimen")
    cp = mat.p_wave_speed("strain")
    transit = H / cp
    peak_mc = mohr_coulomb_peak(0.0, mat.cohesion, mat.friction_angle)
    eps_peak = peak_mc / (0.5 * mat.young)
    rate = eps_peak / ((30.0 if short else 40.0) * transit)
    v = rate * 0.5 * H
    t = 0.1 * H
    start = fdem.Curve.ramp(5 * transit, name="platens")
    pmesh = fdem.mesh.rectangle(1.6 * W, t, t / 2)
    top = scene.add_body(pmesh, pm, position=(0.0, 0.5 * (H + t)), prescribed_velocity=(0.0, -v),
                         velocity_curve=start, name="top")
    bot = scene.add_body(pmesh, pm, position=(0.0, -0.5 * (H + t)), prescribed_velocity=(0.0, v),
                         velocity_curve=start, name="bottom")
    scene.set_interaction(mat, pm, friction=0.0)
    # (the crack faces' copy of the rock, μ = 0.3, contacts the platens as the rock does: μ = 0)
    sim = scene.build(quasi_static=True)
    duration = 5 * transit + 3.0 * eps_peak / rate
    samples = 60 if short else 150
    rec = []
    for _ in range(samples):
        sim.run(duration / samples, record=[fdem.CrackEvents(crack_path)] if crack_path else [],
                checks=fdem.Checks(energy=sim.time > 5 * transit))
        rec.append(axial_record(sim, spec, top, bot, H, W) + (sim.time,))
        if frame is not None:
            frame(sim)
        s = [r[1] for r in rec]
        if s[-1] < 0.6 * max(s) and len(s) > 5:
            break
    eps, sig, lat, times = (np.array(c) for c in zip(*rec))
    k = int(np.argmax(sig))
    return dict(sim=sim, spec=spec, strain=eps, stress=sig, lateral=lat, time=times, peak=float(sig[k]),
                peak_strain=float(eps[k]), peak_mc=peak_mc, broken=sim.cracks.broken_count)


def main(argv=None) -> dict:
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], argv)
    clock = _common.Timer()
    _common.init(args.precision)
    import numpy as np
    from taichi_fdem.render import RendererImage, VideoWriter

    h = 0.005 if args.short else 0.0035
    mesh, lines, tips, crossings = specimen(h)
    print(f"{NAME}: {mesh.triangle_count} triangles (h = {h * 1e3:g} mm), {len(lines)} fractures "
          f"({sum(float(np.linalg.norm(l.points[1] - l.points[0])) for l in lines) * 1e3:.0f} mm), "
          f"{crossings} crossings, {len(tips)} tips")
    out_dir = os.path.dirname(os.path.abspath(args.out))
    os.makedirs(out_dir, exist_ok=True)
    cracks_path = os.path.join(out_dir, f"{NAME}_cracks.csv")
    if os.path.exists(cracks_path):
        os.remove(cracks_path)
    size = (240, 360) if args.short else (480, 720)
    renderer = RendererImage(*size, view=(-0.045, 0.045, -0.068, 0.068), color_by="damage", vmin=0.0, vmax=1.0,
                             colorbar=not args.short, stamp=not args.short, cracks=True)
    results = {}
    with VideoWriter(args.out, fps=15 if args.short else 30) as video:
        for label, ls, path in (("dfn", lines, cracks_path), ("intact", None, None)):
            count = [0]

            def frame(sim):
                count[0] += 1
                if count[0] % (3 if args.short else 1) == 0:
                    video.append(renderer.render_sim(sim))
            r = compress(mesh, ls, args.short, frame=frame, crack_path=path)
            for _ in range(5):
                video.append(renderer.render_sim(r["sim"]))
            results[label] = r
            print(f"  {label}: peak {r['peak'] / 1e6:.4f} MPa at ε = {r['peak_strain']:.4f} (Mohr–Coulomb of the "
                  f"joints {r['peak_mc'] / 1e6:.4f} MPa); {r['broken']} joints broken, {r['sim'].step_count} steps")
    csv_path = os.path.join(out_dir, f"{NAME}_curves.csv")
    with open(csv_path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["specimen", "time_s", "axial_strain", "axial_stress_Pa", "lateral_strain"])
        for label, r in results.items():
            for row in zip(r["time"], r["strain"], r["stress"], r["lateral"]):
                w.writerow([label] + [f"{v:.6g}" for v in row])

    # where the first new cracks start: distance of the first broken joints to the nearest
    # fracture tip and to the nearest fracture, against the same for every joint of the specimen
    # (what cracks starting anywhere would give)
    dfn = results["dfn"]
    sim = dfn["sim"]
    ev = sim.cracks.events()
    pts = np.column_stack([ev["x"], ev["y"]])[:FIRST]
    jn = dfn["spec"].joint_nodes
    every = sim.model.node_rest[dfn["spec"].nodes][jn].mean(axis=1)
    segs = np.array([l.points for l in lines])
    d_tip = lambda q: np.linalg.norm(q[:, None, :] - tips[None, :, :], axis=2).min(axis=1)
    d_line = lambda q: np.array([min(_point_seg_dist(p, a, b) for a, b in segs) for p in q])
    r = 1.5 * h
    near_tip = float(np.mean(d_tip(pts) < r))
    near_tip_all = float(np.mean(d_tip(every) < r))
    near_line = float(np.mean(d_line(pts) < r))
    near_line_all = float(np.mean(d_line(every) < r))
    k = int(np.argmax(dfn["stress"]))
    rise = np.diff(dfn["stress"][:k + 1])
    out = dict(triangles=mesh.triangle_count, fractures=len(lines), crossings=crossings, tips=len(tips), h=h,
               peak_dfn=dfn["peak"], peak_intact=results["intact"]["peak"],
               peak_ratio=dfn["peak"] / results["intact"]["peak"], peak_mc=dfn["peak_mc"],
               broken_dfn=dfn["broken"], broken_intact=results["intact"]["broken"],
               first_near_tips=near_tip, all_near_tips=near_tip_all, first_near_lines=near_line,
               all_near_lines=near_line_all, first_tip_distances_over_h=(d_tip(pts) / h).tolist(),
               final_over_peak_dfn=float(dfn["stress"][-1] / dfn["peak"]),
               prepeak_min_rise=float(rise.min() / dfn["peak"]) if len(rise) else 0.0,
               csv=csv_path, cracks_csv=cracks_path, video=os.path.abspath(args.out), results=results,
               wall_s=clock())
    print(f"  DFN peak / intact peak = {out['peak_ratio']:.3f}; of the first {len(pts)} broken joints "
          f"{near_tip:.0%} lie within 1.5 h = {r * 1e3:g} mm of a fracture tip (of all joints: {near_tip_all:.0%}) "
          f"and {near_line:.0%} within 1.5 h of a fracture (of all joints: {near_line_all:.0%}); the first one "
          f"{out['first_tip_distances_over_h'][0] if len(pts) else float('nan'):.2f} h from a tip")
    assert out["peak_ratio"] < 1.0, "the specimen with the fracture network is not weaker than the intact one"
    print(f"  wrote {args.out}, {csv_path} and {cracks_path}; {out['wall_s']:.1f} s wall time")
    return out


if __name__ == "__main__":
    main()

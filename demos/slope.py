"""A jointed rock slope failing under gravity along two joint sets (docs/theory/discontinuities.md §13.1–13.2).

    python demos/slope.py            # writes out/slope.mp4, out/slope_history.csv, out/slope_cracks.csv
    python demos/slope.py --short    # a quick, coarser version (used by tests/test_demos_rock.py)

A 10 m high rock slope (face at 65°, a 24 m long base) is meshed with ``fdem.mesh.polygon(...,
lines=...)`` so that mesh edges follow two persistent joint sets, clipped to the slope profile
here with NumPy: J1 dipping 40° out of the face (it daylights on the face) and J2 dipping 78°
into the slope.  The intact rock is jointed everywhere (``fracture=True``) with strong joints
(f_t = 0.5 MPa, c = 1 MPa, φ = 35°: the gravity stresses stay below 0.3 MPa); the two sets get
weak joints with ``scene.add_joint_set`` (J1: f_t = 1 kPa, c = 2 kPa, φ = 15°; J2: f_t = 2 kPa,
c = 5 kPa, φ = 30°).  The faces of a broken joint slide with the rock's friction μ = 0.4
(21.8°), below the 40° dip of J1.  The base is fixed,
the back of the slope is on rollers; gravity acts from t = 0, with ``quasi_static=True`` (local
damping: the slope comes to rest where it is stable).

The wedge above the J1 joints that daylight on the face loses its cohesion and slides out along
J1, broken up along J2; the rock behind and below stays.  The video is coloured by displacement
with the broken joints drawn in red; crack events (``run(crack_events=...)``) and the history
go to CSV.  ``check``: the blocks that moved (displacement > 0.1 m) lie above the lowest J1
joint that daylights on the face; the broken joints are mostly on J1 / J2; the energy balance
closes to a small fraction of the gravity energy released.
"""
from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "slope"
H, W = 10.0, 24.0                       # slope height, base length [m]
FACE, DIP1, DIP2 = 65.0, 40.0, 78.0     # face angle, J1 dip (out of the face), J2 dip (into the slope) [°]
S1, S2 = 2.5, 3.0                       # joint spacings (normal to the joints) [m]
MOVED = 0.1                             # displacement of a "moved" triangle [m]
SIZE = {True: dict(h=1.2, duration=1.2, frames=12),     # element size [m], simulated time [s], video frames
        False: dict(h=0.8, duration=3.0, frames=90)}


def profile():
    """The slope's vertices (counter-clockwise): base, toe, face up to the crest, crest, back."""
    import numpy as np
    xc = W - H / math.tan(math.radians(FACE))
    return np.array([(0.0, 0.0), (W, 0.0), (xc, H), (0.0, H)])


def clip_line(point, direction, poly):
    """The parts inside ``poly`` (k, 2) of the infinite line through ``point`` along
    ``direction``: a list of (2, 2) segments.  The line's crossings with every polygon edge
    (parameters t along the line), sorted; the pieces between consecutive crossings whose
    midpoint is inside the polygon are kept."""
    import numpy as np
    p = np.asarray(point, float)
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    a = poly
    b = np.roll(poly, -1, axis=0)
    e = b - a
    den = d[0] * e[:, 1] - d[1] * e[:, 0]                       # cross(d, e)
    ok = np.abs(den) > 1e-12
    r = a - p
    t = np.where(ok, (r[:, 0] * e[:, 1] - r[:, 1] * e[:, 0]) / np.where(ok, den, 1.0), np.nan)   # along the line
    s = np.where(ok, (r[:, 0] * d[1] - r[:, 1] * d[0]) / np.where(ok, den, 1.0), np.nan)         # along the edge
    hit = ok & (s >= -1e-12) & (s <= 1 + 1e-12)
    ts = np.unique(np.round(t[hit], 12))
    out = []
    for t0, t1 in zip(ts[:-1], ts[1:]):
        mid = p + 0.5 * (t0 + t1) * d
        if inside(mid, poly) and t1 - t0 > 1e-9:
            out.append(np.array([p + t0 * d, p + t1 * d]))
    return out


def inside(q, poly) -> bool:
    """Point-in-polygon by ray casting."""
    import numpy as np
    x, y = q
    xa, ya = poly[:, 0], poly[:, 1]
    nxt = np.roll(poly, -1, axis=0)
    xb, yb = nxt[:, 0], nxt[:, 1]
    cross = ((ya > y) != (yb > y)) & (x < xa + (y - ya) * (xb - xa) / (yb - ya + 1e-300))
    return bool(cross.sum() % 2)


def joint_family(dip_deg, toward, spacing, offset, poly):
    """Parallel lines dipping ``dip_deg`` toward +x (``toward`` = +1) or −x (−1), ``spacing``
    apart (normal distance), clipped to ``poly``: a list of (2, 2) segments."""
    import numpy as np
    th = math.radians(dip_deg)
    d = np.array([toward * math.cos(th), -math.sin(th)])        # down-dip direction
    n = np.array([-d[1], d[0]])                                 # unit normal
    c = poly.mean(axis=0)
    reach = np.abs((poly - c) @ n).max()
    segs = []
    for k in range(-int(reach / spacing) - 2, int(reach / spacing) + 3):
        segs += clip_line(c + (k * spacing + offset) * n, d, poly)
    return [s for s in segs if np.linalg.norm(s[1] - s[0]) > 0.3]


def daylight_lines(j1, poly):
    """The J1 segments with one end on the face (daylighting), as (2, 2) arrays."""
    import numpy as np
    a, b = poly[1], poly[2]
    t = (b - a) / np.linalg.norm(b - a)
    out = []
    for s in j1:
        for q in s:
            r = q - a
            if abs(r[0] * t[1] - r[1] * t[0]) < 1e-6 and 1e-6 < r @ t < np.linalg.norm(b - a) - 1e-6:
                out.append(s)
                break
    return out


def above(pts, seg) -> "np.ndarray":
    """True for the points above the infinite line through ``seg``."""
    (xa, ya), (xb, yb) = seg
    return pts[:, 1] > ya + (pts[:, 0] - xa) * (yb - ya) / (xb - xa)


def special_points(j1, j2, poly):
    """The points the mesh must have: polygon vertices, line ends, J1 × J2 crossings."""
    import numpy as np
    pts = [poly] + [s for s in j1 + j2]
    for a in j1:
        for b in j2:
            da, db = a[1] - a[0], b[1] - b[0]
            den = da[0] * db[1] - da[1] * db[0]
            r = b[0] - a[0]
            t = (r[0] * db[1] - r[1] * db[0]) / den
            u = (r[0] * da[1] - r[1] * da[0]) / den
            if 0 <= t <= 1 and 0 <= u <= 1:
                pts.append((a[0] + t * da)[None])
    return np.concatenate(pts)


def joint_sets(poly):
    """J1 and J2 (lists of (2, 2) segments), their offsets chosen on a fixed grid so that no two
    special points (:func:`special_points`) are close: the mesh then has no tiny elements,
    which would make the time step tiny."""
    import numpy as np
    best = None
    for o1 in np.linspace(0.0, S1, 10, endpoint=False):
        for o2 in np.linspace(0.0, S2, 10, endpoint=False):
            j1 = joint_family(DIP1, +1, S1, o1, poly)
            j2 = joint_family(DIP2, -1, S2, o2, poly)
            p = special_points(j1, j2, poly)
            d = np.linalg.norm(p[:, None] - p[None], axis=2)
            d = d[np.triu_indices(len(p), 1)].min()
            if best is None or d > best[0]:
                best = (d, j1, j2)
    return best[1], best[2], best[0]


def build(short: bool):
    import numpy as np
    import taichi_fdem as fdem
    poly = profile()
    j1, j2, gap = joint_sets(poly)
    h = SIZE[short]["h"]
    lines = [fdem.mesh.Polyline(s, name=f"J1_{i}") for i, s in enumerate(j1)] + \
            [fdem.mesh.Polyline(s, name=f"J2_{i}") for i, s in enumerate(j2)]
    mesh = fdem.mesh.polygon(poly, h, lines=lines)
    rock = fdem.Material(density=2600.0, young=2.5e8, poisson=0.25, friction=0.4,
                         tensile_strength=5e5, cohesion=1e6, friction_angle=35.0,
                         fracture_energy=500.0, fracture_energy_shear=2500.0, name="rock")
    bedding = rock.with_(tensile_strength=1e3, cohesion=2e3, friction_angle=15.0,
                         fracture_energy=1.0, fracture_energy_shear=5.0, name="J1")
    cross = rock.with_(tensile_strength=2e3, cohesion=5e3, friction_angle=30.0,
                       fracture_energy=1.0, fracture_energy_shear=5.0, name="J2")
    scene = fdem.Scene(gravity=(0.0, -9.81))
    body = scene.add_body(mesh, rock, fracture=True, name="slope")
    scene.add_joint_set("J1", lines[:len(j1)], bedding)
    scene.add_joint_set("J2", lines[len(j1):], cross)
    tol = 1e-6
    scene.fix_nodes(lambda x, y: y < tol)                                   # the base
    scene.fix_nodes(lambda x, y: (x < tol) & (y > tol), velocity=(0.0, None))   # rollers at the back
    # joined_pairs="contact": contact is evaluated between the faces of intact joints too.  Its
    # friction springs stiffen those faces in shear, and the wedge's release depends on it: with
    # the default "joint" (the joints carry the contact's share of compression and strength,
    # not that stiffness) the joints spread their damage wider and the wedge stays on its
    # partly damaged joints (2 s on the short mesh: 3 triangles moved, 15 joints broken, instead of 34 and
    # 21; measured)
    sim = scene.build(quasi_static=True, joined_pairs="contact")
    return sim, body, dict(poly=poly, j1=j1, j2=j2, h=h, mesh=mesh, gap=gap)


def main(argv=None) -> dict:
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], argv)
    clock = _common.Timer()
    _common.init(args.precision)
    import taichi_fdem as fdem
    import numpy as np
    from taichi_fdem.render import RendererImage, VideoWriter

    sim, body, p = build(args.short)
    print(f"{NAME}: {sim.model.tri_count} triangles, {sim.model.joint_count} joints "
          f"({len(p['j1'])} J1 and {len(p['j2'])} J2 lines), dt = {sim.dt:.3g} s")
    out_dir = os.path.dirname(os.path.abspath(args.out))
    os.makedirs(out_dir, exist_ok=True)
    csv_path = os.path.join(out_dir, f"{NAME}_history.csv")
    cracks_path = os.path.join(out_dir, f"{NAME}_cracks.csv")
    for f in (csv_path, cracks_path):
        if os.path.exists(f):
            os.remove(f)
    size = (480, 240) if args.short else (1280, 640)
    renderer = RendererImage(*size, view=(-1.0, W + 9.0, -1.0, H + 3.0), color_by="displacement",
                             vmin=0.0, vmax=1.0 if args.short else 2.0, colorbar=not args.short, stamp=not args.short,
                             cracks=True, edge_width=0.5)
    e0 = sim.energies()
    duration, frames = SIZE[args.short]["duration"], SIZE[args.short]["frames"]
    every = max(1, round(duration / sim.dt / 200))                 # about 200 history rows over the run
    with VideoWriter(args.out, fps=10 if args.short else 30) as video:
        video.append(renderer.render_sim(sim))
        for _ in range(frames):
            sim.run(duration / frames, record=[fdem.History(csv_path, every=every), fdem.CrackEvents(cracks_path)])
            video.append(renderer.render_sim(sim))
    e1 = sim.energies()
    released = e0["gravity"] - e1["gravity"]
    drift = abs(e1["total"] - e0["total"]) / released if released > 0 else float("inf")

    # where things moved: triangle displacement at the rest centroid
    tri = body.mesh.triangles
    X = sim.model.node_rest[body.nodes]
    u = np.linalg.norm(sim.node_displacements(body), axis=1)
    cen = X[tri].mean(axis=1)
    u_tri = u[tri].mean(axis=1)
    moved = u_tri > MOVED
    day = daylight_lines(p["j1"], p["poly"])
    lowest = min(day, key=lambda s: max(s[:, 1].min(), 0.0) + s[:, 1].max())    # nearest the toe
    above_day = above(cen, lowest)
    frac_above = float(above_day[moved].mean()) if moved.any() else 0.0
    ev = sim.cracks.events()
    on_sets = float(np.isin(ev["set"], ["J1", "J2"]).mean()) if len(ev["set"]) else 0.0
    out = dict(triangles=sim.model.tri_count, joints=sim.model.joint_count, broken=int(len(ev["set"])),
               broken_on_sets=on_sets, moved_triangles=int(moved.sum()), moved_above_daylight=frac_above,
               max_displacement=float(u.max()), stable_displacement=float(u_tri[~above_day].max()),
               released_gravity_J=float(released), energy_drift_over_released=float(drift),
               steps=sim.step_count, video=os.path.abspath(args.out), csv=csv_path, cracks_csv=cracks_path,
               events_sets={s: int((ev["set"] == s).sum()) for s in ("default", "J1", "J2")},
               wall_s=clock(), sim=sim)
    print(f"  {out['moved_triangles']} triangles moved > {MOVED} m ({frac_above:.0%} above the lowest daylighting J1 "
          f"joint); max displacement {u.max():.2f} m, below that joint {out['stable_displacement'] * 1e3:.1f} mm")
    print(f"  {out['broken']} joints broken: {out['events_sets']} ({on_sets:.0%} on J1/J2)")
    print(f"  gravity energy released {released / 1e3:.1f} kJ/m; energy balance drift {drift:.2%} of it; "
          f"{sim.step_count} steps")
    assert moved.any() and frac_above > 0.95, "the moving blocks are not above the daylighting J1 joints"
    assert on_sets > 0.8, "the broken joints are not mostly on the joint sets"
    assert drift < 0.05, "the energy balance does not close"
    print(f"  wrote {args.out}, {csv_path} and {cracks_path}; {out['wall_s']:.1f} s wall time")
    return out


if __name__ == "__main__":
    main()

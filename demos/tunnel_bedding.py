"""A tunnel excavated in a bedded rock mass with weak bedding planes (docs/guide/anisotropy.md).

    python demos/tunnel_bedding.py            # writes out/tunnel_bedding.mp4 and out/tunnel_bedding.csv
    python demos/tunnel_bedding.py --short    # a quick, coarser version (used by tests/test_demos_bedding.py)

A scaled model of a tunnel in a clay shale (Opalinus-Clay-like: stiffer along the bedding, weak
bedding planes), set up as demos/tunnel.py: a 2 × 2 m block, every interior edge a cohesive joint,
brought to an in-situ stress σv = 0.3 MPa, σh = 0.15 MPa by boundary pressures (rollers on the left
and bottom edges), settled with ``quasi_static=True``, then a circular tunnel of radius 0.3 m is
excavated at once by ``sim.remove``.  The rock is transversely isotropic, its bedding dipping 30°:
E1 = 100 MPa along the bedding, E2 = 50 MPa across it (E1/E2 = 2), ν1 = 0.25, ν21 = 0.15,
G2 = 25 MPa.  The matrix's joints: f_t = 0.2 MPa, c = 0.3 MPa, φ = 30° (an unconfined strength
2c cos φ/(1 − sin φ) = 1.04 MPa, above the elastic hoop stress 3σv − σh = 0.75 MPa at the sidewalls);
the bedding's: f_t = 0.07 MPa, c = 0.1 MPa (1/3 of the matrix's), φ = 20°, and weak bedding planes
every 0.2 m (0.12 m in the full mode), one through the tunnel's axis, meshed as edges.

The same excavation in an isotropic rock of the matrix's elasticity and strength (same mesh) is
the comparison.  Printed and returned: the joints that failed (damage > 0.5 or broken), their share
on the bedding planes, their mean direction (the mean of the doubled angles) against the bedding's
dip, where they lie around the tunnel (polar angle from the x axis, as an axis: modulo 180°), and the
sidewall closure of both cases; the failed joints are written to out/tunnel_bedding.csv.  The video
(bedded case) is coloured by joint damage, the broken joints in red, the bedding planes hatched in
white.

Where the bedding slips: at the wall the only stress is the hoop stress σθ, largest at the sidewalls
(polar angle 0°/180°).  A plane at ψ to σθ carries τ = ½ σθ sin 2ψ; the bedding (dip 30°) meets the
wall at ψ = 60° at the sidewall, at ψ = 0° where the wall is tangent to it (polar angle −60°), and at
ψ between the two in the arc from the sidewall towards that tangent point, where its shear is
largest (ψ = 45° − φ/2 = 35° at −25°).  On the other side of the sidewall ψ grows past 60°.

``check``: no joint fails before the excavation; the bedded mass fails at least twice as many joints
as the isotropic one, and of the failures it adds (at least 5) over half, and over 1.5 times the share
of all joints between 1 and 3 radii, run along the bedding (within 10°), with a mean direction
within 10° of the dip; the bedding-parallel failures centre (as an axis) between the tangent point
(−60°) and 10° past the sidewall; most failures lie within 3 radii of the axis.
"""
from __future__ import annotations

import csv
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "tunnel_bedding"
L, A = 2.0, 0.3                       # block size, tunnel radius [m]
SV, SH = 0.3e6, 0.15e6                # in-situ stress [Pa, compression positive]
DIP = 30.0                            # bedding dip [° from the x axis]
E1, E2, NU1, NU21, G2 = 100e6, 50e6, 0.25, 0.15, 25e6
MATRIX = dict(density=2400.0, young=E1, poisson=NU1, friction=0.5, tensile_strength=0.2e6, cohesion=0.3e6,
              friction_angle=30.0, fracture_energy=10.0, fracture_energy_shear=50.0)
BEDDING = dict(tensile_strength=0.07e6, cohesion=0.1e6, friction_angle=20.0, fracture_energy=3.0,
               fracture_energy_shear=15.0)
CRACK = (0.85, 0.1, 0.1)              # colour of the broken joints
VIEW = (-1.05, 1.05, -1.05, 1.05)
# element size h and bedding-plane spacing [m], joint penalty [× E1], the in-situ ramp, the settling
# after it and the run after the excavation [P-wave transits of the block], video frames
SIZE = {True: dict(h=0.12, spacing=0.2, penalty=30, ramp=4, settle=2, after=6, frames=20),
        False: dict(h=0.06, spacing=0.12, penalty=10, ramp=10, settle=5, after=40, frames=60)}


def build(short: bool, bedded: bool):
    """(sim, rock, p) of the stressed block before the excavation; ``bedded`` False: the isotropic
    rock of the matrix's elasticity and strength on the same mesh."""
    import numpy as np
    import taichi_fdem as fdem
    s = SIZE[short]
    h, spacing = s["h"], s["spacing"]
    bed = fdem.Bedding(DIP, young_normal=E2, poisson_normal=NU21, shear_modulus=G2, spacing=spacing, **BEDDING)
    mat = fdem.Material(**dict(MATRIX, joint_penalty=s["penalty"] * E1), bedding=bed if bedded else None)
    X = 0.5 * L
    outline = np.array([[-X, -X], [X, -X], [X, X], [-X, X]])
    mesh = fdem.mesh.polygon(outline, h, lines=[fdem.mesh.bedding_lines(outline, DIP, spacing)])
    scene = fdem.Scene(gravity=(0.0, 0.0))
    rock = scene.add_body(mesh, mat, fracture=True, name="rock")
    tol = 1e-6
    cp = mat.p_wave_speed("strain")
    t_ramp = s["ramp"] * L / cp
    ramp = fdem.Curve.ramp(t_ramp, name="in_situ")
    scene.fix_nodes(lambda x, y: x < -X + tol, body=rock, velocity=(0.0, None))
    scene.fix_nodes(lambda x, y: y < -X + tol, body=rock, velocity=(None, 0.0))
    scene.apply_pressure(lambda x, y: y > X - tol, SV, body=rock, curve=ramp)
    scene.apply_pressure(lambda x, y: x > X - tol, SH, body=rock, curve=ramp)
    sim = scene.build(quasi_static=True)
    return sim, rock, dict(t_ramp=t_ramp, transit=L / cp, h=h, spacing=spacing, material=mat)


def sidewalls(sim, rock):
    """Horizontal closure [m] of the two sidewall points (x = ±A, y = 0) of the tunnel."""
    return _common.sidewall_closure(sim, rock, A)


def axial_mean(deg):
    """Mean [°, 0..180) of axes at ``deg`` (the mean of the doubled angles) and its resultant (0..1)."""
    import numpy as np
    z = np.exp(2j * np.radians(np.asarray(deg, dtype=float))).mean()
    return float(np.mod(np.degrees(np.angle(z)) / 2.0, 180.0)), float(abs(z))


def line_gap(a, b) -> float:
    """Angle [°, 0..90] between two axes at ``a`` and ``b`` degrees."""
    g = abs(a - b) % 180.0
    return min(g, 180.0 - g)


def failed_joints(sim, rock) -> dict:
    """The joints of ``rock`` with damage > 0.5 (or broken): midpoints, directions, sets, statistics."""
    import numpy as np
    D = sim.cracks.joint_damage()
    jn = rock.joint_nodes
    X = sim.model.node_rest[rock.nodes]
    mid = X[jn].mean(axis=1)
    d = X[jn[:, 1]] - X[jn[:, 0]]
    direction = np.mod(np.degrees(np.arctan2(d[:, 1], d[:, 0])), 180.0)
    names = np.asarray(sim.model.joint_set_names, dtype=object)[sim.model.joint_set_np]
    f = np.flatnonzero(D > 0.5)
    out = dict(index=f, mid=mid[f], direction=direction[f], set=names[f], damage=D[f], count=len(f))
    if len(f):
        out["mean_direction"], out["resultant"] = axial_mean(direction[f])
        out["mean_position"], _ = axial_mean(np.degrees(np.arctan2(mid[f, 1], mid[f, 0])))
        out["on_bedding"] = float(np.mean(names[f] == "bedding"))
        out["near"] = float(np.mean(np.hypot(mid[f, 0], mid[f, 1]) < 3 * A))
    else:
        out.update(mean_direction=math.nan, resultant=0.0, mean_position=math.nan, on_bedding=0.0, near=0.0)
    return out


def excavate(sim, rock, p, short, draw=None) -> dict:
    """Settle, excavate, relax: the numbers of one case; ``draw(sim)`` called at each frame."""
    import numpy as np
    s = SIZE[short]
    frames = s["frames"]
    t_settle = p["t_ramp"] + s["settle"] * p["transit"]
    for _ in range(frames // 2):
        sim.run(t_settle / (frames // 2))
        if draw is not None:
            draw(sim)
    damaged_before = int((sim.cracks.joint_damage() > 0.5).sum())
    u0 = sidewalls(sim, rock)
    removed = sim.remove(where=lambda x, y: x * x + y * y < A * A)
    t_after = s["after"] * p["transit"]
    for _ in range(frames):
        sim.run(t_after / frames)
        if draw is not None:
            draw(sim)
    X = sim.model.node_rest[rock.nodes]
    d = X[rock.joint_nodes[:, 1]] - X[rock.joint_nodes[:, 0]]
    return dict(damaged_before=damaged_before, removed=removed, closure=sidewalls(sim, rock) - u0,
                broken=sim.cracks.broken_count, failed=failed_joints(sim, rock), steps=sim.step_count,
                joint_mid=X[rock.joint_nodes].mean(axis=1),
                joint_direction=np.mod(np.degrees(np.arctan2(d[:, 1], d[:, 0])), 180.0))


def write_csv(path, cases) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["case", "joint", "x_m", "y_m", "polar_angle_deg", "direction_deg", "joint_set", "damage"])
        for name, c in cases.items():
            f = c["failed"]
            for j, m, a, s, dmg in zip(f["index"], f["mid"], f["direction"], f["set"], f["damage"]):
                w.writerow([name, int(j), f"{m[0]:.6g}", f"{m[1]:.6g}",
                            f"{math.degrees(math.atan2(m[1], m[0])) % 360.0:.2f}", f"{a:.2f}", s, f"{dmg:.4f}"])


def bedding_effect(bed, iso) -> dict:
    """What the bedding adds: the joints failed in the bedded mass and not in the isotropic one
    (same mesh, same joint order), their share along the bedding (within 10° of the dip) and mean
    direction; ``baseline_along``, the share along the bedding of all joints between 1 and 3 radii
    from the axis (what failures at random would give); the bedding-parallel failures' mean polar
    position (as an axis) measured from the sidewall axis (0°/180°), in (−90°, 90°]."""
    import numpy as np
    fb, fi = bed["failed"], iso["failed"]
    r = np.hypot(bed["joint_mid"][:, 0], bed["joint_mid"][:, 1])
    ring = (r > A) & (r < 3 * A)
    baseline = float(np.mean([line_gap(a, DIP) < 10.0 for a in bed["joint_direction"][ring]]))
    extra = ~np.isin(fb["index"], fi["index"])
    along = np.array([line_gap(a, DIP) < 10.0 for a in fb["direction"]], dtype=bool)
    out = dict(extra=int(extra.sum()), extra_along=float(along[extra].mean()) if extra.any() else 0.0,
               extra_direction=axial_mean(fb["direction"][extra])[0] if extra.any() else math.nan,
               along=int(along.sum()), baseline_along=baseline, position_from_sidewall=math.nan)
    if along.any():
        pos = axial_mean(np.degrees(np.arctan2(fb["mid"][along, 1], fb["mid"][along, 0])))[0]
        out["position_from_sidewall"] = pos - 180.0 if pos > 90.0 else pos
    return out


def check(bed, iso, effect) -> None:
    """The assertions of the module docstring."""
    f = bed["failed"]
    assert bed["damaged_before"] == 0 and iso["damaged_before"] == 0, "joints failed before the excavation"
    assert f["count"] >= 2 * iso["failed"]["count"] and effect["extra"] >= 5, \
        f"the bedded mass failed {f['count']} joints, the isotropic one {iso['failed']['count']}"
    assert effect["extra_along"] > max(0.5, 1.5 * effect["baseline_along"]), \
        f"only {effect['extra_along']:.0%} of the added failures along the bedding (of all joints near the " \
        f"tunnel: {effect['baseline_along']:.0%})"
    gap = line_gap(effect["extra_direction"], DIP)
    assert gap < 10.0, \
        f"the added failures' mean direction {effect['extra_direction']:.1f}° is {gap:.1f}° off the bedding"
    tangent = DIP + 90.0 - 180.0
    assert tangent < effect["position_from_sidewall"] < 10.0, \
        f"the bedding-parallel failures centre {effect['position_from_sidewall']:.0f}° from the sidewall, not " \
        f"between it and the point where the wall is tangent to the bedding ({tangent:.0f}°)"
    assert f["near"] > 0.8, f"only {f['near']:.0%} of the failed joints within 3 radii of the tunnel"


def main(argv=None) -> dict:
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], argv)
    clock = _common.Timer()
    _common.init(args.precision)
    from taichi_fdem.render import RendererImage, VideoWriter
    size = (320, 320) if args.short else (720, 720)
    renderer = RendererImage(*size, view=VIEW, color_by="damage", vmin=0.0, vmax=1.0, colorbar=not args.short,
                             stamp=not args.short, cracks=True, crack_color=CRACK, crack_width=2.0)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)) or ".", exist_ok=True)
    cases = {}
    sim, rock, p = build(args.short, bedded=True)
    print(f"{NAME}: {sim.model.tri_count} triangles, {sim.model.joint_count} joints, dt = {sim.dt:.3g} s, "
          f"bedding dip {DIP:.0f}°, planes every {p['spacing']} m")
    with VideoWriter(args.out, fps=10 if args.short else 30) as video:
        def draw(s):
            img = renderer.render_sim(s)
            if not renderer.colorbar:
                img = _common.hatch_bedding(img, DIP, p["spacing"], VIEW, keep=CRACK, inside=lambda x, y: (
                    (abs(x) < 0.5 * L) & (abs(y) < 0.5 * L) & (x * x + y * y >= A * A)))
            video.append(img)
        cases["bedded"] = excavate(sim, rock, p, args.short, draw)
    sim, rock, p_iso = build(args.short, bedded=False)
    cases["isotropic"] = excavate(sim, rock, p_iso, args.short)
    csv_path = os.path.join(os.path.dirname(os.path.abspath(args.out)), f"{NAME}.csv")
    write_csv(csv_path, cases)
    mat = p_iso["material"]
    G = mat.young / (2 * (1 + mat.poisson))
    K = SH / SV
    elastic_closure = 2 * SV * A / (4 * G) * ((1 + K) - (1 - K) * (3 - 4 * mat.poisson))
    for name, c in cases.items():
        f = c["failed"]
        print(f"  {name:9s}: excavated {c['removed']} triangles; {f['count']} joints failed (damage > 0.5), "
              f"{c['broken']} broken; {f['on_bedding']:.0%} on the bedding planes, {f['near']:.0%} within 3 radii; "
              f"mean direction {f['mean_direction']:.1f}° (resultant {f['resultant']:.2f}; bedding {DIP:.0f}°), "
              f"mean polar position {f['mean_position']:.0f}° (mod 180); sidewall closure {c['closure'] * 1e3:.3f} mm")
    print(f"  isotropic elastic (Kirsch) sidewall closure {elastic_closure * 1e3:.3f} mm")
    effect = bedding_effect(cases["bedded"], cases["isotropic"])
    print(f"  the bedding adds {effect['extra']} failed joints, {effect['extra_along']:.0%} of them within 10° of the "
          f"bedding (of all joints near the tunnel: {effect['baseline_along']:.0%}), mean direction "
          f"{effect['extra_direction']:.1f}°; the {effect['along']} bedding-parallel failures "
          f"centre {effect['position_from_sidewall']:.0f}° from the sidewall axis (the wall is tangent to the bedding "
          f"at {DIP + 90.0 - 180.0:.0f}°)")
    check(cases["bedded"], cases["isotropic"], effect)
    fb = cases["bedded"]["failed"]
    out = dict(cases=cases, effect=effect, failed=fb["count"], failed_isotropic=cases["isotropic"]["failed"]["count"],
               mean_direction=fb["mean_direction"], resultant=fb["resultant"], on_bedding=fb["on_bedding"],
               near=fb["near"], mean_position=fb["mean_position"], dip=DIP,
               damaged_before=cases["bedded"]["damaged_before"], closure=cases["bedded"]["closure"],
               closure_isotropic=cases["isotropic"]["closure"], elastic_closure=elastic_closure,
               failed_positions=[math.degrees(math.atan2(m[1], m[0])) % 360.0 for m in fb["mid"]],
               failed_directions=[float(a) for a in fb["direction"]],
               video=os.path.abspath(args.out), csv=csv_path, wall_s=clock())
    print(f"  wrote {args.out} and {csv_path}; {out['wall_s']:.1f} s wall time")
    return out


if __name__ == "__main__":
    main()
    sys.exit(0)

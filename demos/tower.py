"""A tower of blocks on a floor, knocked over by a fast heavy disk (gravity, friction).

    python demos/tower.py            # writes out/tower.mp4
    python demos/tower.py --short    # a quick version (used by tests/test_demos_gallery.py)
    python demos/tower.py --still docs/gallery/tower.png   # also save a mid-run frame

Deformable 0.2 x 0.1 m blocks (six rows, two blocks wide, brick bond: the odd rows are
shifted by half a block, with half blocks at the ends; 15 bodies) stand on a fixed floor, placed exactly touching, under gravity with
Coulomb friction mu = 0.5.  A dense disk flies in horizontally at V = 10 m/s and hits the
upper part of the tower, which topples.  ``check`` verifies that

* the tower stood still before the impact (every block slower than 1 % of V);
* horizontal momentum of projectile + blocks just after the collision equals the projectile's
  before, within 5 % (only the floor's friction, bounded by mu x weight x time, acts on them);
* the upper blocks moved (centroid displacement > half a block height in short mode, and in
  the full run the blocks struck fell by more than a block height);
* the energy account (kinetic + strain + contact + gravity + dissipated by friction and
  damping) never grew by more than 2 % of the initial kinetic + potential energy scale.
"""
from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "tower"
G = 9.81
BW, BH = 0.2, 0.1        # block width, height [m]
COLS, ROWS = 2, 6
H = 0.05                 # mesh size [m]
V = 10.0                 # projectile speed [m/s]
R = 0.05                 # projectile radius [m]
FLOOR = (-1.4, 2.6)      # floor extent in x [m]
FLOOR_T = 0.05           # floor thickness [m]
BLOCK = dict(density=800.0, young=2.0e7, poisson=0.3, friction=0.5, damping=0.02, contact_damping=0.2)
BALL = dict(density=2500.0, young=2.0e7, poisson=0.3, friction=0.5, damping=0.02, contact_damping=0.2)
PENALTY = 5.0            # contact penalty = PENALTY x E


def build(short: bool):
    import taichi_fdem as fdem
    wood = fdem.Material(**BLOCK, penalty=PENALTY * BLOCK["young"], name="wood")
    steel = fdem.Material(**BALL, penalty=PENALTY * BALL["young"], name="ball")
    scene = fdem.Scene(gravity=(0.0, -G))
    floor = scene.add_body(fdem.mesh.rectangle(FLOOR[1] - FLOOR[0], FLOOR_T, FLOOR_T), wood,
                           position=(0.5 * (FLOOR[0] + FLOOR[1]), -0.5 * FLOOR_T), fixed=True, name="floor")
    block_mesh = fdem.mesh.rectangle(BW, BH, H)
    half_mesh = fdem.mesh.rectangle(0.5 * BW, BH, H)
    blocks = []
    for j in range(ROWS):
        y = (j + 0.5) * BH
        if j % 2 == 0:            # two full blocks
            xs = [(-0.5 * BW, block_mesh), (0.5 * BW, block_mesh)]
        else:                     # brick bond: half, full, half
            xs = [(-0.75 * BW, half_mesh), (0.0, block_mesh), (0.75 * BW, half_mesh)]
        for x, m in xs:
            blocks.append(scene.add_body(m, wood, position=(x, y), name=f"block r{j}"))
    gap = 0.2 if short else 0.8                  # distance flown before the hit [m]
    t_hit = gap / V
    y_hit = 4.5 * BH                             # aim at the middle of row 4
    # start higher by the drop under gravity during the flight
    ball = scene.add_body(fdem.mesh.disk(R, 0.5 * R), steel,
                          position=(-COLS * 0.5 * BW - R - gap, y_hit + 0.5 * G * t_hit ** 2),
                          velocity=(V, -G * t_hit), name="ball")
    sim = scene.build()
    duration = t_hit + (0.05 if short else 0.9)
    return sim, floor, blocks, ball, t_hit, duration


def free_state(sim, bodies):
    """Total mass, momentum and per-body centroids of the given bodies."""
    kin = [sim.body_motion(b) for b in bodies]
    return sum(k.mass for k in kin), sum(k.momentum for k in kin), np.array([k.center for k in kin])


class Monitor:
    """Samples energy, speeds and momentum at every frame."""

    def __init__(self, sim, blocks, ball, t_hit):
        self.blocks, self.ball, self.t_hit = blocks, ball, t_hit
        self.times, self.total, self.kinetic = [], [], []
        self.max_block_speed_before = 0.0
        self.px_after = None            # (time, P_x) sampled once shortly after the impact
        self.impulse = np.zeros(2)      # impulse of the floor on the bodies over the window [N s]
        self.window = (t_hit - 0.002, t_hit + 0.015)
        self.p_start = None             # momentum of projectile + blocks at the window start
        self.floor = None
        _, p, self.c0 = free_state(sim, blocks)
        self.px0 = float(sim.body_motion(ball).momentum[0])
        m = sim.node_masses()
        free = np.zeros(sim.model.node_count, bool)
        for b in blocks:
            free[b.nodes] = True
        self.pe0 = float(G * np.sum(m[free] * sim.node_positions()[free][:, 1]))
        self.still = None
        self(sim)

    def floor_force(self, sim):
        """Contact force of the floor on the other bodies [N] (minus the force on the floor's nodes)."""
        # sim.forces() restores the friction slip history and the dissipation accumulators, so
        # the diagnostic does not perturb the run
        f = sim.forces(contact_only=True)[self.floor.nodes].sum(axis=0)
        return -f

    def advance(self, sim, n):
        """Step n steps; inside the impact window, in chunks of 5 steps integrating the floor force."""
        t0, t1 = self.window
        end = sim.step_count + n
        while sim.step_count < end:
            if not (t0 <= sim.time < t1):
                k = end - sim.step_count
                if sim.time < t0:
                    k = min(k, max(1, int(np.ceil((t0 - sim.time) / sim.dt))))
                sim.step(k)
                continue
            if self.p_start is None:
                _, p, _ = free_state(sim, self.blocks + [self.ball])
                self.p_start = (sim.time, p.copy())
            f0 = self.floor_force(sim)
            k = min(5, end - sim.step_count)
            sim.step(k)
            self.impulse += 0.5 * (f0 + self.floor_force(sim)) * k * sim.dt
            if sim.time >= t1 and self.px_after is None:
                _, p, _ = free_state(sim, self.blocks + [self.ball])
                self.px_after = (sim.time, p.copy())

    def __call__(self, sim):
        x = sim.node_positions()
        if not np.all(np.isfinite(x)):
            raise AssertionError(f"non-finite node positions at t = {sim.time:.4g} s")
        e = sim.energies()
        self.times.append(sim.time)
        self.total.append(e["total"])
        self.kinetic.append(e["kinetic"])
        t = sim.time
        # the ball's front reaches the tower at t_hit; stress waves need ~ BW / c ~ 1 ms more
        if t < self.t_hit - 0.002:
            v = max(float(np.linalg.norm(sim.node_velocities(b), axis=1).max()) for b in self.blocks)
            self.max_block_speed_before = max(self.max_block_speed_before, v)
        if self.px_after is None and t >= self.window[1]:
            _, p, _ = free_state(sim, self.blocks + [self.ball])
            self.px_after = (t, p.copy())
        if self.still is not None:
            self.still(sim)


def check(sim, blocks, ball, mon: Monitor, full: bool) -> dict:
    _, _, c1 = free_state(sim, blocks)
    disp = np.linalg.norm(c1 - mon.c0, axis=1)
    drop = mon.c0[:, 1] - c1[:, 1]
    struck = mon.c0[:, 1] > 3.0 * BH                 # rows 3-5: the upper part of the tower
    ke0 = 0.5 * float(sim.node_masses(ball).sum()) * V * V
    scale = ke0 + mon.pe0
    total = np.array(mon.total)
    rise = float((total - total[0]).max())
    t_after, p_after = mon.px_after
    t_before, p_before = mon.p_start
    M = sum(float(sim.node_masses(b).sum()) for b in blocks + [ball])
    predicted = p_before + mon.impulse + np.array([0.0, -G * M * (t_after - t_before)])
    p0 = abs(mon.px0)
    dp_rel = float(np.linalg.norm(p_after - predicted) / p0)     # momentum balance with the floor's impulse
    px_after = float(p_after[0])
    ratio_x = px_after / mon.px0                                   # x momentum kept by projectile + blocks
    out = {"blocks": len(blocks), "triangles": sim.model.tri_count, "steps": sim.step_count, "time": sim.time,
           "max_block_speed_before_mps": mon.max_block_speed_before,
           "momentum_x_before": mon.px0, "momentum_x_after": px_after, "momentum_time_s": t_after,
           "momentum_balance_rel_error": dp_rel, "momentum_x_kept": ratio_x,
           "floor_impulse_Ns": mon.impulse.tolist(),
           "momentum_x_before_window": float(p_before[0]),
           "upper_disp_min_m": float(disp[struck].min()), "upper_disp_mean_m": float(disp[struck].mean()),
           "upper_drop_mean_m": float(drop[struck].mean()),
           "energy_scale_J": scale, "energy_rise_max_frac": rise / scale,
           "dissipated_J": float(sum(sim.energies()[k] for k in ("friction", "damping", "contact_damping")))}
    assert mon.max_block_speed_before < 0.01 * V, (
        f"the tower did not stand still before the impact: a block moved at {mon.max_block_speed_before:.3g} m/s")
    assert abs(p_before[0] - mon.px0) < 1e-3 * p0, "momentum changed before the impact"
    assert dp_rel < 0.05, (f"momentum change through the impact not explained by the floor's reaction: "
                           f"before {p_before}, floor impulse {mon.impulse}, after {p_after} (error "
                           f"{100 * dp_rel:.2f} % of the projectile's momentum)")
    assert ratio_x > 0.8, f"projectile + blocks lost too much horizontal momentum ({ratio_x:.3f} kept)"
    assert rise <= 0.02 * scale, f"the total energy grew by {rise:.4g} J = {100 * rise / scale:.2f} % of {scale:.4g} J"
    assert disp[struck].mean() > 0.5 * BH, f"the upper blocks barely moved ({disp[struck].mean():.3g} m)"
    if full:
        assert drop[struck].mean() > BH, f"the upper blocks did not fall (mean drop {drop[struck].mean():.3g} m)"
    return out


def main(argv=None) -> dict:
    import argparse
    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("--still", default=None)
    extra, rest = ap.parse_known_args(argv if argv is not None else sys.argv[1:])
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], rest)
    clock = _common.Timer()
    _common.init(args.precision)
    from taichi_fdem.render import RendererImage, VideoWriter, save_png

    sim, floor, blocks, ball, t_hit, duration = build(args.short)
    info = sim.info()
    print(f"{NAME}: {len(blocks)} blocks + ball + floor, {info['triangles']} triangles, dt = {info['dt']:.3g} s, "
          f"{duration:.3g} s simulated ({int(round(duration / sim.dt)):,} steps), strategy {info['strategy']}",
          flush=True)
    frames = 12 if args.short else 180                # 6 s of video at 30 fps
    size = (320, 180) if args.short else (960, 540)
    view = (-1.2, 2.5, -0.1, 2.0) if not args.short else (-0.6, 0.8, -0.1, 0.7)
    renderer = RendererImage(*size, view=view, color_by="body", stamp=not args.short,
                             draw_edges=not args.short, edge_width=0.5)
    mon = Monitor(sim, blocks, ball, t_hit)
    if extra.still:
        t_still = t_hit + (0.03 if args.short else 0.3)
        saved = []

        def still(s):
            if not saved and s.time >= t_still:
                save_png(extra.still, renderer.render_sim(s))
                saved.append(s.time)
        mon.still = still
    mon.floor = floor
    total = int(round(duration / sim.dt))
    per_frame = max(1, int(round(duration / frames / sim.dt)))
    with VideoWriter(args.out, fps=30) as writer:
        writer.append(renderer.render_sim(sim))
        while sim.step_count < total:
            mon.advance(sim, min(per_frame, total - sim.step_count))
            writer.append(renderer.render_sim(sim))
            mon(sim)
    result = check(sim, blocks, ball, mon, full=not args.short)
    result.update(video=os.path.abspath(args.out), wall_s=clock())
    print(f"  before the impact the blocks moved at most {result['max_block_speed_before_mps']:.2e} m/s")
    print(f"  horizontal momentum {result['momentum_x_before']:.4g} -> {result['momentum_x_after']:.4g} kg m/s "
          f"at t = {result['momentum_time_s']:.3g} s; floor impulse {_common.fmt_vec(result['floor_impulse_Ns'])} N s "
          f"explains the change to {100 * result['momentum_balance_rel_error']:.2f} % of the projectile's momentum")
    print(f"  upper blocks moved {result['upper_disp_mean_m']:.3g} m on average (dropped "
          f"{result['upper_drop_mean_m']:.3g} m); energy rose at most {100 * result['energy_rise_max_frac']:.2f} % "
          f"of {result['energy_scale_J']:.4g} J; {result['dissipated_J']:.4g} J dissipated")
    print(f"  wrote {args.out}; {result['wall_s']:.1f} s wall time")
    return result


if __name__ == "__main__":
    main()
    sys.exit(0)

"""A few hundred deformable disks and stones poured into a box: they fall, bounce and settle.

    python demos/pile.py            # writes out/pile.mp4 (the default demo of `make demo`)
    python demos/pile.py --short    # a quick version (used by tests/test_demos.py)

Disks of five sizes and irregular convex stones (``fdem.mesh.polygon``), each a deformable
body of ~20-50 triangles, start in a loose jittered column inside a box of three fixed walls
and fall under gravity; Coulomb friction, contact damping and a little viscous damping of the
elements let the pile come to rest.  ``check`` verifies at the end that nothing left the box,
that the run stayed stable, that the energy account (kinetic + strain + contact + gravity +
everything dissipated) never grew by more than a few % of the potential energy, and that the
pile settled (final kinetic energy a small fraction of the potential energy released).
"""
from __future__ import annotations

import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common  # noqa: E402

NAME = "pile"
G = 9.81
# soft rock-like material (a softer E means a longer stable time step: the demo runs in ~1 min)
MATERIAL = dict(density=2500.0, young=5.0e6, poisson=0.25, friction=0.5, damping=0.05,
                contact_damping=0.2)
PENALTY = 1.0            # contact penalty = PENALTY x E (the package default is 10 E)
RADII = (0.025, 0.03, 0.035, 0.04, 0.045)   # disk radii [m]
WALL = 0.04              # wall thickness [m]


def _stone(rng, r):
    """A random stone: 6-8 vertices at jittered angles and radii 0.8-1.1 r (star-shaped, simple)."""
    k = int(rng.integers(6, 9))
    ang = (np.arange(k) + rng.uniform(-0.25, 0.25, k)) * (2 * np.pi / k) + rng.uniform(0, 2 * np.pi)
    rad = r * rng.uniform(0.8, 1.1, k)
    return np.stack([rad * np.cos(ang), rad * np.sin(ang)], axis=1)


def build(short: bool, seed: int = 3):
    import taichi_fdem as fdem
    rng = np.random.default_rng(seed)
    mat = fdem.Material(**MATERIAL, penalty=PENALTY * MATERIAL["young"], name="rock")
    scene = fdem.Scene(gravity=(0.0, -G))
    if short:
        cols, rows, width = 5, 3, 0.5
    else:
        cols, rows, width = 14, 18, 1.4
    cell = width / cols                              # one body per cell of the initial column
    height = rows * cell + 0.1                       # wall height
    box = {"xmin": 0.0, "xmax": width, "ymin": 0.0, "ymax": height}
    walls = [
        scene.add_body(fdem.mesh.rectangle(width + 2 * WALL, WALL, 0.5 * WALL), mat,
                       position=(0.5 * width, -0.5 * WALL), fixed=True, name="floor"),
        scene.add_body(fdem.mesh.rectangle(WALL, height, 0.5 * WALL), mat,
                       position=(-0.5 * WALL, 0.5 * height), fixed=True, name="left wall"),
        scene.add_body(fdem.mesh.rectangle(WALL, height, 0.5 * WALL), mat,
                       position=(width + 0.5 * WALL, 0.5 * height), fixed=True, name="right wall"),
    ]
    disks = {r: fdem.mesh.disk(r, 0.45 * r) for r in RADII}
    stones = [fdem.mesh.polygon(_stone(rng, r), h=0.5 * r)
              for r in rng.uniform(RADII[1], RADII[-1], 10)]
    bodies = []
    for j in range(rows):
        for i in range(cols):
            if rng.random() < 0.15:
                mesh = stones[int(rng.integers(len(stones)))]
            else:
                mesh = disks[RADII[int(rng.integers(len(RADII)))]]
            ext = float(np.linalg.norm(mesh.points - mesh.centroid, axis=1).max())   # any rotation
            slack = max(0.0, 0.5 * cell - ext - 0.002)
            pos = ((i + 0.5) * cell + rng.uniform(-slack, slack),
                   (j + 0.5) * cell + 0.02 + rng.uniform(-slack, slack))
            vel = (rng.normal(0.0, 0.3), rng.normal(-0.5, 0.3))
            bodies.append(scene.add_body(mesh, mat, position=pos, velocity=vel,
                                         angular_velocity=rng.normal(0.0, 2.0),
                                         rotation=rng.uniform(0, 2 * np.pi)))
    sim = scene.build()
    duration = 0.08 if short else 0.9
    return sim, walls, bodies, box, duration


class Monitor:
    """Records the energy account and the worst node excursion at every frame."""

    def __init__(self, sim, bodies, box):
        self.sim, self.bodies, self.box = sim, bodies, box
        free = np.zeros(sim.model.node_count, bool)
        for b in bodies:
            free[b.nodes] = True
        self.free = free
        self.mass = sim.node_masses()[free]
        self.times, self.total, self.kinetic, self.potential, self.dissipated = [], [], [], [], []
        self.max_excursion = 0.0
        self.sample(sim)

    def potential_energy(self, x) -> float:
        """m g y of the moving bodies above the floor [J]."""
        return float(G * np.sum(self.mass * (x[:, 1] - self.box["ymin"])))

    def excursion(self, x) -> float:
        """How far [m] the farthest node is outside the box (negative: all inside)."""
        b = self.box
        return float(max((b["xmin"] - x[:, 0]).max(), (x[:, 0] - b["xmax"]).max(), (b["ymin"] - x[:, 1]).max()))

    def sample(self, sim):
        x = sim.node_positions()[self.free]
        if not np.all(np.isfinite(x)):
            raise AssertionError(f"non-finite node positions at t = {sim.time:.4g} s")
        e = sim.energies()
        self.times.append(sim.time)
        self.total.append(e["total"])
        self.kinetic.append(e["kinetic"])
        self.potential.append(self.potential_energy(x))
        self.dissipated.append(e["damping"] + e["friction"] + e["contact_damping"])
        self.max_excursion = max(self.max_excursion, self.excursion(x))

    __call__ = sample


def check(sim, bodies, box, monitor: Monitor | None = None, settled: bool = True) -> dict:
    """Physics checks of the pile; asserts and returns the numbers.

    * containment: every node of the moving bodies stays inside the box (tolerance 1 % of the
      box width, for contact penetration), at the end and at every recorded frame;
    * stability: finite positions, no inverted element (the run would have raised);
    * energy: kinetic + strain + contact + gravity + dissipated never exceeds its initial
      value by more than 3 % of the initial potential energy;
    * settling (``settled=True``): final kinetic energy < 1 % of the potential energy released.
    """
    mon = monitor or Monitor(sim, bodies, box)
    if monitor is not None:
        mon.sample(sim)
    tol = 0.01 * (box["xmax"] - box["xmin"])
    x = sim.node_positions()[mon.free]
    final_excursion = mon.excursion(x)
    pe0 = mon.potential[0]
    total = np.array(mon.total)
    rise = float((total - total[0]).max())
    released = pe0 - mon.potential[-1]
    ke_end = mon.kinetic[-1]
    out = {"bodies": len(bodies), "triangles": sim.model.tri_count, "steps": sim.step_count,
           "time": sim.time, "max_excursion_m": mon.max_excursion, "final_excursion_m": final_excursion,
           "potential_initial_J": pe0, "potential_released_J": released,
           "energy_rise_max_frac_pe0": rise / pe0, "energy_drift_end_frac_pe0": float(total[-1] - total[0]) / pe0,
           "kinetic_end_J": ke_end, "kinetic_end_frac_released": ke_end / released if released > 0 else float("nan"),
           "kinetic_max_J": float(max(mon.kinetic)), "dissipated_J": mon.dissipated[-1],
           "couples_end": sim.solver.couple_count, "samples": len(mon.times)}
    assert np.all(np.isfinite(x)), "non-finite node positions"
    assert mon.max_excursion <= tol, f"a node left the box by {mon.max_excursion:.3g} m (tolerance {tol:.3g} m)"
    assert rise <= 0.03 * pe0, (f"the total energy grew by {rise:.4g} J = {100 * rise / pe0:.2f} % of the "
                                f"initial potential energy {pe0:.4g} J")
    if settled:
        assert released > 0.1 * pe0, f"the pile did not fall: released {released:.4g} J of {pe0:.4g} J"
        assert ke_end < 0.01 * released, (f"not settled: kinetic energy {ke_end:.4g} J is "
                                          f"{100 * ke_end / released:.2f} % of the released {released:.4g} J")
    out["settled_checked"] = bool(settled)
    return out


def main(argv=None) -> dict:
    args = _common.parse_args(NAME, __doc__.split("\n\n")[0], argv)
    clock = _common.Timer()
    _common.init(args.precision)
    import taichi_fdem as fdem
    from taichi_fdem.render import RendererImage

    sim, walls, bodies, box, duration = build(args.short)
    t_build = clock()
    info = sim.info()
    n_steps = int(round(duration / sim.dt))
    print(f"{NAME}: {len(bodies)} bodies + 3 walls, {info['triangles']:,} triangles, {info['couples']:,} couples, "
          f"dt = {info['dt']:.3g} s, {duration:g} s simulated = {n_steps:,} steps, strategy {info['strategy']} "
          f"(built in {t_build:.1f} s)", flush=True)
    frames = 10 if args.short else 240                 # 8 s of video at 30 fps
    size = (240, 288) if args.short else (640, 768)
    m = 0.06 * (box["xmax"] - box["xmin"])
    view = (box["xmin"] - m, box["xmax"] + m, box["ymin"] - m, box["ymax"] + 2.5 * m)   # room for the time stamp
    renderer = RendererImage(*size, view=view, edge_width=0.5 if not args.short else 0.0,
                             draw_edges=not args.short, supersample=1)
    monitor = Monitor(sim, bodies, box)
    sim.run(duration, record=[fdem.Video(args.out, fps=30, frame_dt=duration / frames, renderer=renderer)],
            progress=None, callback=monitor)
    t_run = clock() - t_build
    result = check(sim, bodies, box, monitor, settled=not args.short)
    result.update(video=os.path.abspath(args.out), wall_s=clock(), build_s=t_build, run_s=t_run)
    print(f"  {result['steps']:,} steps in {t_run:.1f} s ({result['steps'] * sim.model.tri_count / t_run / 1e6:.1f} M "
          f"triangle-steps/s); nodes stayed inside the box (worst excursion {result['max_excursion_m']:+.2e} m)")
    print(f"  energy: potential {result['potential_initial_J']:.1f} J at start, {result['potential_released_J']:.1f} J "
          f"released; total energy rose at most {100 * result['energy_rise_max_frac_pe0']:.2f} % of it "
          f"(end drift {100 * result['energy_drift_end_frac_pe0']:+.2f} %); {result['dissipated_J']:.1f} J dissipated")
    print(f"  final kinetic energy {result['kinetic_end_J']:.3g} J = "
          f"{100 * result['kinetic_end_frac_released']:.2f} % of the released energy"
          + ("" if result["settled_checked"] else " (short run: settling not checked)"))
    print(f"  wrote {args.out}; {result['wall_s']:.1f} s wall time")
    return result


if __name__ == "__main__":
    main()
    sys.exit(0)

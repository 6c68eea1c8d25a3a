"""Numerical stability: a penetration diagnostic and the stress tests of issue 5.

* :func:`couple_penetrations` / :func:`max_couple_penetration`: how deep contact couples overlap
  (used by :meth:`Simulation.run`'s ``max_penetration`` check).
* :func:`stress_run`: run a built simulation and record stable / not, the cause, energy drift,
  maximum penetration and inverted elements.
* ``scenario_*``: scenes that push the solver (time step 0.25×–4× the limit, penalty 1–1000·E,
  fast impacts, sliver triangles, a node touched by many contacts, a dense pile, a fast spin).
  :func:`run_suite` runs them all; ``benchmarks/stability.py`` prints and stores the table.

Penetration measure: for a couple of triangles A, B with overlap area A_ov and mean edge length
L̄ of the two, the depth is d = A_ov / L̄ [m] (exact for a flat face pushed d deep along a whole
edge) and the fraction is d / L̄.  A fraction of 0.5 means the overlap covers about half a
triangle: the penalty no longer keeps the bodies apart.
"""

import math
import time as _time
import warnings

import numpy as np
import taichi as ti

from ..engine.diagnostics import couple_penetrations  # noqa: F401  (re-exported)
from ..sim.guards import max_couple_penetration  # noqa: F401  (re-exported)
from ..sim.recorders import Callback


# ------------------------------------------------------------------------------------------------
# stress runs
# ------------------------------------------------------------------------------------------------
def _classify(cause: str) -> str:
    for key, words in (("non-finite", ("non-finite", "not finite")), ("inverted", ("inverted",)),
                       ("speed", ("m/s, above",)), ("energy", ("energy",)), ("penetration", ("penetration",))):
        if any(w in cause for w in words):
            return key
    return "other"


def stress_run(sim, duration: float, samples: int = 100, **run_kw) -> dict:
    """Run ``sim`` for ``duration`` [s] with :meth:`Simulation.run`'s checks and record how it went.

    Returns {"stable", "cause" (None or the error's cause), "kind" (non-finite / inverted / speed /
    energy / penetration), "step", "time", "suggested_dt", "steps", "energy_drift" (largest
    ``|E_total − E_total(0)|`` / energy scale seen, the scale being the largest
    kinetic + strain + contact + dissipated energy), "max_penetration" (largest couple
    penetration fraction seen), "inverted" (an element with J ≤ 0 at the end or as the cause),
    "wall" [s]}.  ``run_kw`` go to ``run`` (``checks=fdem.Checks(...)``).
    """
    from ..sim.simulation import SimulationError
    e0 = sim.energies()
    rec = {"drift": 0.0, "scale": sim._energy_scale(e0), "pen": 0.0}

    def sample(s):
        e = s.energies()
        rec["scale"] = max(rec["scale"], s._energy_scale(e))
        rec["drift"] = max(rec["drift"], abs(e["total"] - e0["total"]))
        rec["pen"] = max(rec["pen"], max_couple_penetration(s)["fraction"])

    out = {"stable": True, "cause": None, "kind": None, "step": None, "time": None, "suggested_dt": None}
    t0 = _time.perf_counter()
    try:
        sim.run(duration, record=[Callback(sample, frame_dt=duration / samples)], progress=False, **run_kw)
    except SimulationError as err:
        out.update(stable=False, cause=err.cause, kind=_classify(err.cause), step=err.step, time=err.time,
                   suggested_dt=err.suggested_dt)
    out["wall"] = _time.perf_counter() - t0
    out["steps"] = sim.step_count
    out["energy_drift"] = rec["drift"] / rec["scale"] if rec["scale"] > 0 else 0.0
    out["max_penetration"] = rec["pen"]
    if out["stable"]:
        x = sim.node_positions()
        t = sim.model.tri_nodes_np
        u, w = x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]]
        a2 = u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]
        out["inverted"] = bool(np.any(a2 <= 0))
    else:
        out["inverted"] = out["kind"] == "inverted"
    return out


# ------------------------------------------------------------------------------------------------
# scenarios: each returns (simulation, duration [s], description)
# ------------------------------------------------------------------------------------------------
E_S, RHO_S, NU_S = 1.0e7, 1000.0, 0.25           # c_p ≈ 110 m/s (plane strain)


def _material(**kw):
    from ..material import Material
    return Material(density=RHO_S, young=E_S, poisson=NU_S, **kw)


def _build(scene, **kw):
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="bodies overlap", category=RuntimeWarning)
        return scene.build(**kw)


def scenario_disks(speed: float = 2.0, penalty_factor: float = 10.0, dt_factor: float | None = None,
                   offset: float = 0.02, friction: float = 0.0, resolution: int = 3, gap: float = 0.002):
    """Two elastic disks (R = 5 cm, 2·``gap`` apart) in an oblique impact at ±``speed`` [m/s];
    ``dt_factor`` × the estimated limit (None: the automatic step, safety 0.2; > 1 is forced)."""
    from . import two_disks_scene
    R = 0.05
    mat = dict(density=RHO_S, young=E_S, poisson=NU_S, penalty=penalty_factor * E_S, friction=friction)
    make = lambda **kw: two_disks_scene(R, R / resolution, (speed, 0.0), (-speed, 0.0), offset=offset, gap=2 * gap,
                                        material=mat, mirror=False, **kw)[0]
    probe = make()
    sim = probe if dt_factor is None else make(dt=dt_factor * probe.model.dt_limit, force_dt=dt_factor > 1)
    c_p = _material().p_wave_speed("strain")
    duration = 2 * gap / max(speed, 1e-9) + 8 * R / c_p + 0.3 * R / max(speed, 1e-9)
    return sim, duration, f"two disks, v = ±{speed:g} m/s, p = {penalty_factor:g}·E"


def scenario_bars(dt_factor: float | None = None, penalty_factor: float = 10.0, cells: int = 40):
    """Two bars (0.5 × 0.025 m, structured mesh, ``cells`` along) meeting face on face at ±v,
    v = 10⁻³ c_p: corner nodes of small lumped mass in contact on both sides.  ``dt_factor`` ×
    the estimated limit (None: automatic)."""
    from .. import mesh
    from ..scene import Scene
    mat = _material(penalty=penalty_factor * E_S)
    L = 0.5
    h = L / cells
    c = mat.p_wave_speed("strain")
    v = 1e-3 * c
    scene = Scene(gravity=(0.0, 0.0))
    gap = 0.05 * h
    scene.add_body(mesh.rectangle(L, 2 * h, h, origin=(-L - 0.5 * gap, 0.0)), mat, velocity=(v, 0.0))
    scene.add_body(mesh.rectangle(L, 2 * h, h, origin=(0.5 * gap, 0.0)), mat, velocity=(-v, 0.0))
    probe = _build(scene)
    sim = probe if dt_factor is None else _build(scene, dt=dt_factor * probe.model.dt_limit, force_dt=dt_factor > 1)
    return sim, 2.6 * L / c, "two bars face on face"


def scenario_sliver(aspect: float = 20.0, speed: float = 1.0):
    """A block meshed with sliver triangles (cells ``aspect`` times wider than tall) dropped at
    ``speed`` on a fixed floor under gravity."""
    from .. import mesh
    from ..scene import Scene
    mat = _material(friction=0.3)
    n = 4
    # n cells across, n·aspect rows of thin cells: a 0.1 m square whose cells are ``aspect``
    # times wider than tall
    rows = int(round(n * aspect))
    block = mesh.rectangle(0.1, 0.1 * rows / n, 0.1 / n, pattern="right").scaled((1.0, n / rows))
    scene = Scene(gravity=(0.0, -9.81))
    scene.add_body(mesh.rectangle(0.4, 0.05, 0.025, origin=(-0.2, -0.05)), mat, fixed=True)
    scene.add_body(block, mat, position=(0.0, 0.0505), velocity=(0.3 * speed, -speed), angular_velocity=2.0)
    sim = _build(scene)
    return sim, 0.05, f"sliver triangles, aspect {aspect:g}"


def scenario_fan(count: int = 32, speed: float = 1.0):
    """A wedge made of ``count`` thin triangles sharing its tip node, dropped tip first at
    ``speed`` on a fixed floor: one node in contact through many couples."""
    from .. import mesh
    from ..mesh import TriMesh
    from ..scene import Scene
    mat = _material()
    r = 0.08
    ang = np.radians(np.linspace(60.0, 120.0, count + 1))
    pts = np.vstack([[0.0, 0.0], np.stack([r * np.cos(ang), r * np.sin(ang)], axis=1)])
    tris = np.stack([np.zeros(count, int), np.arange(1, count + 1), np.arange(2, count + 2)], axis=1)
    fan = TriMesh(pts, tris)
    scene = Scene(gravity=(0.0, -9.81))
    scene.add_body(mesh.rectangle(0.3, 0.05, 0.02, origin=(-0.15, -0.05)), mat, fixed=True)
    scene.add_body(fan, mat, velocity=(0.0, -speed))          # placed as given: tip at the origin
    sim = _build(scene)
    return sim, 0.03, f"fan of {count} triangles, tip first at {speed:g} m/s"


def scenario_pile(count: int = 200, seed: int = 0, friction: float = 0.3, v_random: float = 0.5,
                  damping: float = 0.0):
    """``count`` disks (r = 2 cm, 32 triangles each) in a loose hexagonal packing inside a fixed
    box, falling under gravity with random velocities: a dense, settling pile (the ``"spiral"``
    disk layout, as in every scenario of the stability table)."""
    from .. import mesh
    from ..scene import Scene
    mat = _material(friction=friction, damping=damping)
    r = 0.02
    disk = mesh.disk(r, 0.4 * r, layout="spiral")
    cols = max(4, int(round(math.sqrt(count))))
    rows = int(math.ceil(count / cols))
    sx, sy = 2.05 * r, math.sqrt(3.0) * 1.025 * r
    width = cols * sx + r
    rng = np.random.default_rng(seed)
    scene = Scene(gravity=(0.0, -9.81))
    wall_h = rows * sy + 4 * r
    t = 0.5 * r
    scene.add_body(mesh.rectangle(width + 2 * t, t, t, origin=(-t, -t)), mat, fixed=True, name="floor")
    scene.add_body(mesh.rectangle(t, wall_h, t, origin=(-t, 0.0)), mat, fixed=True, name="left")
    scene.add_body(mesh.rectangle(t, wall_h, t, origin=(width, 0.0)), mat, fixed=True, name="right")
    k = 0
    for j in range(rows):
        for i in range(cols):
            if k == count:
                break
            x = r + 0.5 * r * (j % 2) + i * sx + 0.01 * r
            y = r + 0.01 * r + j * sy
            scene.add_body(disk, mat, position=(x, y), velocity=rng.normal(0.0, v_random, 2))
            k += 1
    sim = _build(scene)
    return sim, 0.05, f"pile of {count} disks ({sim.model.tri_count} triangles)"


def scenario_damped_block(dt_factor: float | None = None, damping: float = 0.5):
    """A 0.2 m block meshed with the "crossed" pattern (4 triangles per cell), viscous damping
    β = ``damping``, spinning freely: the element limit (h/c_p)(√(1+β²) − β) governs."""
    from .. import mesh
    from ..scene import Scene
    mat = _material(damping=damping)
    scene = Scene(gravity=(0.0, 0.0))
    omega = 0.1 * mat.p_wave_speed("strain") / 0.1
    scene.add_body(mesh.rectangle(0.2, 0.2, 0.025, pattern="crossed"), mat, angular_velocity=omega,
                   velocity=(0.5, 0.0))
    probe = _build(scene)
    sim = probe if dt_factor is None else _build(scene, dt=dt_factor * probe.model.dt_limit, force_dt=dt_factor > 1)
    return sim, 2 * math.pi / omega, f"damped crossed block, β = {damping:g}"


def scenario_spin(rim_fraction: float = 0.2):
    """A disk (R = 5 cm) spinning freely with rim speed ``rim_fraction`` × c_p, no gravity."""
    from .. import mesh
    from ..scene import Scene
    mat = _material()
    R = 0.05
    omega = rim_fraction * mat.p_wave_speed("strain") / R
    scene = Scene(gravity=(0.0, 0.0))
    scene.add_body(mesh.disk(R, R / 4, layout="spiral"), mat, angular_velocity=omega)
    sim = _build(scene)
    return sim, 4 * math.pi / omega, f"spinning disk, rim speed {rim_fraction:g} c_p"


def suite(quick: bool = True) -> list:
    """(group, parameter, builder) of every stress test; ``quick`` keeps the CI-sized versions."""
    items = []
    for f in (0.25, 0.5, 1.0, 2.0, 4.0):
        items.append(("time step", f"{f:g} × limit", lambda f=f: scenario_disks(dt_factor=f)))
    for p in (1.0, 10.0, 100.0, 1000.0):
        items.append(("penalty", f"{p:g}·E", lambda p=p: scenario_disks(penalty_factor=p)))
    items.append(("face-on-face contact", "bars, 10·E", lambda: scenario_bars()))
    for s in ((0.01, 0.05, 0.1, 0.2) if quick else (0.01, 0.05, 0.1, 0.2, 0.3, 0.5)):
        items.append(("impact speed", f"{s:g} c_p", lambda s=s: scenario_disks(speed=s * _material().p_wave_speed("strain"))))
    for a in ((10.0, 30.0) if quick else (10.0, 50.0, 200.0)):
        items.append(("sliver triangles", f"aspect {a:g}", lambda a=a: scenario_sliver(aspect=a)))
    for n in ((16, 64) if quick else (16, 64, 256)):
        items.append(("many contacts at a node", f"fan of {n}", lambda n=n: scenario_fan(count=n)))
    for n in ((100,) if quick else (300, 3000)):
        items.append(("dense pile", f"{n} disks", lambda n=n: scenario_pile(count=n)))
    for w in ((0.1, 0.5) if quick else (0.1, 0.3, 0.5, 0.8)):
        items.append(("fast spin", f"rim {w:g} c_p", lambda w=w: scenario_spin(rim_fraction=w)))
    return items


def run_suite(quick: bool = True, log=print) -> list:
    """Run :func:`suite` and return one record per test (see :func:`stress_run`) with its
    group, parameter, description, dt / dt_limit and triangle count."""
    rows = []
    for group, param, make in suite(quick):
        sim, duration, desc = make()
        r = stress_run(sim, duration)
        r.update(group=group, parameter=param, description=desc, dt_ratio=sim.dt / sim.model.dt_limit,
                 triangles=sim.model.tri_count, duration=duration)
        rows.append(r)
        if log:
            log(f"{group:24s} {param:14s} {'stable' if r['stable'] else 'STOPPED: ' + r['kind']:22s} "
                f"drift {r['energy_drift']:.2e} pen {r['max_penetration']:.3f} steps {r['steps']} "
                f"wall {r['wall']:.1f}s")
    return rows

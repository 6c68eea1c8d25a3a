"""Verification of discontinuities and heterogeneity (docs/theory/discontinuities.md §13): sliding on a pre-existing
crack, fracture confined to a jointed band, a crack growing from a notch, and the scatter of
a heterogeneous Brazilian test.  Shared by tests/test_discontinuities.py and the docs."""
from __future__ import annotations

import math
import time as _time

import numpy as np

from .. import mesh
from ..material import Material
from ..scene import Scene
from ._common import _build, _precision, _result


def t_block_mesh(h: float, width: float = 0.6, block: float = 0.1) -> mesh.TriMesh:
    """One mesh of a base (``width`` × ``block``/2, x from −``block``, y from −``block``/2 to 0)
    and a ``block`` × ``block``/2 block standing on it (``|x|`` < ``block``/2, 0 < y < ``block``/2):
    a T-shaped region cut from a structured rectangle, so mesh edges run along y = 0."""
    r = mesh.rectangle(width, block, h, origin=(-block, -0.5 * block))
    c = r.points[r.triangles].mean(axis=1)
    keep = (c[:, 1] < 0.0) | (np.abs(c[:, 0]) < 0.5 * block)
    return mesh.TriMesh(r.points, r.triangles[keep]).compact()


def case_crack_slide(theta_deg: float = 30.0, friction: float = 0.3, duration: float = 0.1, resolution: int = 2,
                     crack_friction: float | None = None, safety: float = 0.2, precision: str = "f64") -> dict:
    """A block cut from its base by a pre-existing crack, inside ONE mesh (§13.1, §8.2).

    The T-shaped mesh of :func:`t_block_mesh` (block 0.1 × 0.05 m on a 0.6 × 0.05 m base, h =
    0.05 m / ``resolution``) is split along the block's base (y = 0, ``|x|`` ≤ 0.05) with
    ``add_body(cracks=...)``; the base's nodes below y = 0 are fixed and gravity is tilted by θ.
    The crack's faces meet by contact and friction only (μ = ``crack_friction`` if given, else
    the material's ``friction``).  If tan θ > μ the block slides with a = g (sin θ − μ cos θ):
    ``error`` = ``|x − ½ a t²|`` / (½ a t²) of its centroid after ``duration``; otherwise ``error``
    = ``|x|`` / (½ g sin θ t²) (creep relative to a free slide).
    """
    _precision(precision)
    g = 9.81
    th = math.radians(theta_deg)
    mat = Material(density=2000.0, young=1e7, poisson=0.25, friction=friction, damping=0.2, contact_damping=0.5,
                   penalty=1e8, name="rock")
    h = 0.05 / resolution
    scene = Scene(gravity=(g * math.sin(th), -g * math.cos(th)))
    body = scene.add_body(t_block_mesh(h), mat, cracks=lambda x, y: (np.abs(y) < 1e-9) & (np.abs(x) < 0.05 + 1e-9),
                          crack_friction=crack_friction, name="block+base")
    scene.fix_nodes(lambda x, y: y < -1e-9)
    sim, build = _build(scene, safety)
    X = sim.node_positions(body)
    tri = body.mesh.triangles
    blk = np.unique(tri[X[tri].mean(axis=1)[:, 1] > 0.0])       # the block's nodes (incl. its crack face)
    m = sim.node_masses(body)[blk]
    x0 = (m * X[blk, 0]).sum() / m.sum()
    t0 = _time.perf_counter()
    sim.step(int(round(duration / sim.dt)))
    wall = _time.perf_counter() - t0
    x = (m * sim.node_positions(body)[blk, 0]).sum() / m.sum() - x0
    t = sim.time
    mu = friction if crack_friction is None else crack_friction
    if math.tan(th) > mu:
        ref = 0.5 * g * (math.sin(th) - mu * math.cos(th)) * t * t
        err, slides = abs(x - ref) / ref, True
    else:
        ref, slides = 0.0, False
        err = abs(x) / (0.5 * g * math.sin(th) * t * t)
    return _result(sim, wall, build, error=err, displacement=x, displacement_analytic=ref, slides=slides,
                   theta_deg=theta_deg, crack_edges=body.crack_count)


def band_plate_scene(h: float = 0.01, band: float = 0.02, speed: float = 0.5):
    """A 0.2 × 0.1 m plate with cohesive joints only inside the band ``|y|`` < ``band`` (§13.1),
    its top and bottom rows pulled apart at ±``speed`` [m/s].  Returns (sim, plate)."""
    mat = Material(density=2000.0, young=1e8, poisson=0.25, tensile_strength=2e5, fracture_energy=10.0,
                   damping=0.1, name="rock")
    scene = Scene(gravity=(0.0, 0.0))
    plate = scene.add_body(mesh.rectangle(0.2, 0.1, h), mat, fracture=lambda x, y: np.abs(y) < band, name="plate")
    scene.fix_nodes(lambda x, y: y > 0.05 - 1e-9, velocity=(0.0, speed))
    scene.fix_nodes(lambda x, y: y < -0.05 + 1e-9, velocity=(0.0, -speed))
    return scene.build(), plate


def notched_beam_scene(h: float = 0.01, notch: float = 0.03, speed: float = 0.05, notched: bool = True):
    """Three-point bending of a jointed beam (0.4 × 0.1 m, every interior edge a joint) with a
    pre-existing vertical crack (``notch`` deep) at the middle of its bottom edge (§13.1).

    Supports: the bottom nodes at x = ±0.18 m fixed; load: the top nodes at ``|x|`` ≤ h move down
    at ``speed`` [m/s].  Returns (sim, beam, tip) with tip = (0, −0.05 + notch)."""
    mat = Material(density=2000.0, young=1e9, poisson=0.2, tensile_strength=1e6, fracture_energy=20.0,
                   damping=0.1, name="rock")
    scene = Scene(gravity=(0.0, 0.0))
    y_tip = -0.05 + notch
    cracks = (lambda x, y: (np.abs(x) < 1e-9) & (y < y_tip - 1e-9)) if notched else None
    beam = scene.add_body(mesh.rectangle(0.4, 0.1, h), mat, fracture=True, cracks=cracks, name="beam")
    scene.fix_nodes(lambda x, y: (np.abs(np.abs(x) - 0.18) < 1e-9) & (y < -0.05 + 1e-9))
    scene.fix_nodes(lambda x, y: (np.abs(x) < h + 1e-9) & (y > 0.05 - 1e-9), velocity=(0.0, -speed))
    return scene.build(), beam, np.array([0.0, y_tip])


def first_cracks(sim, count: int = 5, max_steps: int = 200000, chunk: int = 200) -> dict:
    """Step ``sim`` until ``count`` joints have broken; the first ones (broken_joints order)."""
    while sim.cracks.broken_count < count and sim.step_count < max_steps:
        sim.step(chunk)
    bj = sim.cracks.broken()
    return {k: v[:count] for k, v in bj.items()}


def heterogeneous_brazilian(seeds=(1, 2, 3, 4, 5), modulus: float = 6.0, elements: int = 20,
                            load_time: float = 40.0, samples: int = 120) -> dict:
    """Brazilian peak (§8.8) of a disc whose joint strengths are Weibull-distributed with modulus
    ``modulus`` (mean = the material's f_t, docs/theory/discontinuities.md §13.3), one run per seed.  Returns the
    peaks σ_t·Hondros / f_t per seed, their mean and standard deviation, and the homogeneous
    disc's value on the same mesh."""
    from ..discontinuity import Weibull
    from .fracture import brazilian_load, brazilian_result, brazilian_scene
    out = []
    for s in [None, *seeds]:
        sim, bodies, p = brazilian_scene(elements=elements, load_time=load_time,
                                         strength=None if s is None else Weibull(modulus, seed=s))
        rec = brazilian_load(sim, bodies, p, samples=samples)
        out.append(brazilian_result(sim, bodies, rec, p)["sigma_t_hondros_over_ft"])
    peaks = np.array(out[1:])
    return {"homogeneous": out[0], "peaks": peaks, "mean": float(peaks.mean()), "std": float(peaks.std(ddof=1)),
            "seeds": list(seeds), "modulus": modulus}

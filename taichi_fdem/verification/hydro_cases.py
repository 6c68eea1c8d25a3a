"""Verification cases of fluid in fractures with the engine (docs/theory/hydro.md §14.2): Sneddon's
pressurised crack and the KGD hydraulic fracture, against :mod:`.hydro`.

The plates are meshed by :func:`crack_plate_mesh`, a tensor-product mesh graded away from the
crack line: cells of size h along the crack and next to it, growing geometrically towards the
edges of a plate many crack lengths wide, so that the far boundary costs few triangles.
"""
from __future__ import annotations

import math
import time as _time

import numpy as np

from .. import material as _material
from ..material import Material
from ..mesh import TriMesh
from ..scene import Curve, Scene
from ._common import _build, _precision, _result
from .hydro import kgd_toughness, kgd_viscosity, plane_modulus, sneddon_opening


def _graded_axis(inner: float, outer: float, h: float, growth: float) -> np.ndarray:
    """Node coordinates on [0, outer]: spacing h up to ``inner``, then growing by ``growth`` per
    cell up to ``outer`` (the last cell stretched or merged to end there)."""
    n = max(1, int(round(inner / h)))
    xs = list(np.linspace(0.0, inner, n + 1)) if inner > 0 else [0.0]
    step = inner / n if inner > 0 else h
    while xs[-1] < outer - 1e-12 * outer:
        step *= growth
        xs.append(xs[-1] + step)
    if len(xs) > 2 and xs[-1] - outer > 0.5 * (xs[-1] - xs[-2]):
        xs.pop()
    xs[-1] = outer
    return np.asarray(xs)


def crack_plate_mesh(a: float, width: float, h: float, growth: float = 1.2, band: float | None = None) -> TriMesh:
    """A square plate of side ``width`` [m] centred on the origin, meshed for a crack along the x
    axis from −a to a: mesh lines at y = 0 and at x = ±a, cells h × h [m] over |x| ≤ a + band and
    |y| ≤ band (``band`` default 2h), growing by ``growth`` per cell outside.  Each cell is split
    along the diagonal that points away from the origin (the mesh is symmetric about both axes).

    The crack edges are the mesh edges on y = 0 with |x| ≤ a: select them with
    ``lambda x, y: (abs(y) < tol) & (abs(x) < a + tol)``.
    """
    where = "crack_plate_mesh"
    for name, v in (("a", a), ("width", width), ("h", h)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"{where}: {name} must be finite and > 0 [m], got {v!r}")
    if not (width > 2 * a + 4 * h):
        raise ValueError(f"{where}: width = {width} m leaves no room around the crack 2a = {2 * a} m")
    if not (1.0 <= growth <= 2.0):
        raise ValueError(f"{where}: growth must lie in [1, 2], got {growth!r}")
    band = 2.0 * h if band is None else float(band)
    na = max(1, int(round(a / h)))
    xa = np.linspace(0.0, a, na + 1)
    xo = a + _graded_axis(band, 0.5 * width - a, h, growth)[1:]
    xs = np.concatenate([xa, xo])
    ys = _graded_axis(band, 0.5 * width, h, growth)
    xs = np.concatenate([-xs[:0:-1], xs])
    ys = np.concatenate([-ys[:0:-1], ys])
    nx, ny = len(xs) - 1, len(ys) - 1
    gx, gy = np.meshgrid(xs, ys)
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
    i, j = np.meshgrid(np.arange(nx), np.arange(ny))
    i, j = i.ravel(), j.ravel()
    n00 = j * (nx + 1) + i
    n10, n01, n11 = n00 + 1, n00 + nx + 1, n00 + nx + 2
    cx, cy = 0.5 * (xs[i] + xs[i + 1]), 0.5 * (ys[j] + ys[j + 1])
    flip = (cx * cy) < 0.0               # diagonal n10-n01 in the 2nd and 4th quadrants
    t1 = np.where(flip[:, None], np.stack([n00, n10, n01], 1), np.stack([n00, n10, n11], 1))
    t2 = np.where(flip[:, None], np.stack([n10, n11, n01], 1), np.stack([n00, n11, n01], 1))
    return TriMesh(pts, np.stack([t1, t2], axis=1).reshape(-1, 3))


def _settle(sim, chunk: int, max_steps: int, tol: float = 1e-8) -> None:
    """Step in chunks until the kinetic energy is below ``tol`` of the strain energy."""
    while sim.step_count < max_steps:
        sim.step(chunk)
        en = sim.energies()
        if en["kinetic"] <= tol * max(en["strain"], 1e-300):
            break


def _opening_at(sim, body, x0: float, tol: float) -> float:
    """The normal opening [m] of the crack (y = 0) at x = x0: the y-displacement of the upper
    face's copy of the node there minus the lower face's."""
    X = sim.model.node_rest[body.nodes]
    u = sim.node_displacements(body)
    at = (np.abs(X[:, 0] - x0) < tol) & (np.abs(X[:, 1]) < tol)
    uy = u[at, 1]
    return float(uy.max() - uy.min())


def case_sneddon(resolution: int = 16, safety: float = 0.2, penalty_factor: float = 10.0, precision: str = "f64",
                 ratio: float = 20.0, p: float = 1.0e6, growth: float = 1.25, load: str = "fluid",
                 settle: float = 1e-6, max_steps: int = 200_000) -> dict:
    """Sneddon: a crack of half-length a = 1 m in a square plate ``ratio`` × a wide (free edges),
    opened by a uniform pressure p, settled quasi-statically (docs/theory/hydro.md §14.2).
    ``resolution`` cells along the half-crack (h = a/resolution; :func:`crack_plate_mesh`,
    graded by ``growth``).  ``load="fluid"``: the crack (``cracks=``) is the flow network and
    ``scene.inject(where=crack, pressure=p)`` holds p on every node of it; ``load="pressure"``:
    ``apply_pressure`` on the crack faces (the same follower load without the fluid).

    The pressure is ramped over 4 P-wave transits of the plate with ``quasi_static=True`` and
    held until the kinetic energy is below ``settle`` times the strain energy.  Checked: the opening at
    the centre against 4 p a/E' (plane strain).  The finite plate opens the crack more than the
    infinite plane: about +0.6 % at ratio 20 (Tada's strip), not corrected.
    error = |w(0) − 4pa/E'| / (4pa/E').
    """
    _precision(precision)
    a, h = 1.0, 1.0 / resolution
    young, nu = 1.0e10, 0.25
    mat = Material(density=2500.0, young=young, poisson=nu, penalty=penalty_factor * young)
    tol = 1e-6 * h
    crack = lambda x, y: (np.abs(y) < tol) & (np.abs(x) < a + tol)   # noqa: E731
    scene = Scene(gravity=(0.0, 0.0), plane="strain")
    body = scene.add_body(crack_plate_mesh(a, ratio * a, h, growth), mat, name="plate", cracks=crack)
    cp = mat.p_wave_speed("strain")
    t_ramp = 4.0 * ratio * a / cp
    if load == "fluid":
        scene.set_fluid(_material.Fluid(density=1000.0, bulk_modulus=1.0e8, viscosity=1e-3), aperture_min=1e-6)
        scene.inject(crack, pressure=p, curve=Curve.ramp(t_ramp))
    elif load == "pressure":
        scene.apply_pressure(crack, p, curve=Curve.ramp(t_ramp))
    else:
        raise ValueError(f"case_sneddon: load must be 'fluid' or 'pressure', got {load!r}")
    sim, build = _build(scene, safety, quasi_static=True)
    t0 = _time.perf_counter()
    sim.run(t_ramp)
    chunk = max(1, int(ratio * a / cp / sim.dt))
    _settle(sim, chunk, max_steps, settle)
    wall = _time.perf_counter() - t0
    w0 = _opening_at(sim, body, 0.0, tol)
    w_th = float(sneddon_opening(0.0, a, p, young, nu))
    xs = np.array([0.5, 0.75]) * a
    w_mid = [_opening_at(sim, body, float(x), tol) for x in xs]
    return _result(sim, wall, build, error=abs(w0 - w_th) / w_th, opening=w0, opening_analytic=w_th,
                   opening_half=w_mid[0], opening_half_analytic=float(sneddon_opening(xs[0], a, p, young, nu)),
                   opening_3q=w_mid[1], opening_3q_analytic=float(sneddon_opening(xs[1], a, p, young, nu)),
                   h=h, plane_modulus=plane_modulus(young, nu))

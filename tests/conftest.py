"""Shared fixtures and reference functions of the taichi_fdem verification suite.

Taichi is initialised once per test run (CPU, f64): ``fdem.init`` calls ``ti.init``, which
resets every Taichi object, so it must never be called again inside a test.

The functions below are independent NumPy re-implementations of the quantities the tests
check against (triangle geometry, polygon clipping, the Munjiza potential, brute-force
contact detection).  They are written from the theory pages (docs/theory/), not from the package code.
"""
from __future__ import annotations

import math
import os
import warnings

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem.mesh import TriMesh

# Taichi's offline cache keeps 100 MB of compiled kernels by default and evicts the least
# recently used quarter beyond that.  The suite's kernels (every feature set, both strategies,
# f32 and f64) can exceed that, and a run then recompiles what the previous one evicted: the
# suite raises the limit to 1 GiB (Taichi reads any ti.init setting from TI_<NAME>; a value set
# in the environment is kept, and the processes the tests start inherit it).
os.environ.setdefault("TI_OFFLINE_CACHE_MAX_SIZE_OF_FILES", str(1 << 30))


@pytest.fixture(scope="session", autouse=True)
def fdem_session():
    """Initialise Taichi once for the whole test run (CPU, double precision)."""
    fdem.init(arch="cpu", precision="f64")
    yield


# ------------------------------------------------------------------------------------------------
# meshes and scenes
# ------------------------------------------------------------------------------------------------
def one_triangle(points) -> TriMesh:
    """A TriMesh holding the single triangle ``points`` (3 × 2, any orientation)."""
    return TriMesh(np.asarray(points, dtype=np.float64).reshape(3, 2), np.array([[0, 1, 2]]))


def build_quiet(scene, **kwargs):
    """``scene.build(**kwargs)`` with the start-overlap RuntimeWarning silenced (intended overlaps)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="bodies overlap", category=RuntimeWarning)
        return scene.build(**kwargs)


def mass_centroid(sim, body):
    """(centroid position, centroid velocity) of a body, mass weighted."""
    m = sim.node_masses(body)
    M = m.sum()
    return (m[:, None] * sim.node_positions(body)).sum(0) / M, (m[:, None] * sim.node_velocities(body)).sum(0) / M


# ------------------------------------------------------------------------------------------------
# triangle geometry (docs/theory/index.md §0, §2.2)
# ------------------------------------------------------------------------------------------------
def cross2(a, b):
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def twice_area(T) -> float:
    T = np.asarray(T, dtype=np.float64)
    return float(cross2(T[1] - T[0], T[2] - T[0]))


def edge_normal(T, k):
    """Un-normalised outward normal m_k of edge k (node k → k+1) of a CCW triangle, |m_k| = edge length."""
    a, b = T[k], T[(k + 1) % 3]
    return np.array([b[1] - a[1], -(b[0] - a[0])])


def barycentric(P, T):
    """β_k(P) = ((t_k − P)·m_k)/(2A), k = 0, 1, 2 (last axis); β_k is the shape function of vertex k+2."""
    P = np.asarray(P, dtype=np.float64)
    A2 = twice_area(T)
    return np.stack([((T[k] - P) @ edge_normal(T, k)) / A2 for k in range(3)], axis=-1)


def shape_function_gradients(T):
    """(3, 2): ∇N_q of the linear shape functions of vertex q (N_q = β_{q+1}, ∇β_k = −m_k/(2A))."""
    A2 = twice_area(T)
    return np.array([-edge_normal(T, (q + 1) % 3) / A2 for q in range(3)])


def munjiza_potential(P, T):
    """φ_T(P) = 3 min_k β_k(P) inside T, 0 outside (§2.2)."""
    return 3.0 * np.maximum(0.0, barycentric(P, T).min(axis=-1))


def random_triangle(rng, center, size, min_angle_deg=20.0):
    """A random CCW triangle around ``center`` with circumradius ≈ ``size`` and no angle below min_angle_deg."""
    while True:
        ang = np.sort(rng.uniform(0.0, 2.0 * np.pi, 3))
        rad = size * rng.uniform(0.6, 1.0, 3)
        T = np.asarray(center, dtype=np.float64) + np.stack([rad * np.cos(ang), rad * np.sin(ang)], axis=1)
        if twice_area(T) <= 0:
            continue
        if min_angle(T) >= np.radians(min_angle_deg):
            return T


def min_angle(T) -> float:
    out = []
    for k in range(3):
        u = T[(k + 1) % 3] - T[k]
        v = T[(k + 2) % 3] - T[k]
        out.append(math.acos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1.0, 1.0)))
    return min(out)


# ------------------------------------------------------------------------------------------------
# polygon clipping and exact integrals of affine functions (independent of the package)
# ------------------------------------------------------------------------------------------------
def clip_convex(poly, T):
    """Sutherland–Hodgman: polygon ``poly`` (k × 2, CCW) clipped by the CCW convex polygon ``T``."""
    out = [np.asarray(p, dtype=np.float64) for p in poly]
    n = len(T)
    for k in range(n):
        a, b = np.asarray(T[k], float), np.asarray(T[(k + 1) % n], float)
        if not out:
            break
        src, out = out, []
        for i in range(len(src)):
            p, q = src[i], src[(i + 1) % len(src)]
            dp, dq = cross2(b - a, p - a), cross2(b - a, q - a)
            if dp >= 0:
                out.append(p)
            if (dp >= 0) != (dq >= 0):
                out.append(p + dp / (dp - dq) * (q - p))
    return np.array(out).reshape(-1, 2)


def polygon_area_centroid(poly):
    """(area, centroid) of a simple CCW polygon (area 0 and centroid nan when degenerate)."""
    if len(poly) < 3:
        return 0.0, np.full(2, np.nan)
    p, q = poly, np.roll(poly, -1, axis=0)
    cr = cross2(p, q)
    area = 0.5 * cr.sum()
    if area <= 0:
        return 0.0, np.full(2, np.nan)
    return float(area), ((p + q) * cr[:, None]).sum(0) / (6.0 * area)


def overlap_area(A, B) -> float:
    return polygon_area_centroid(clip_convex(A, B))[0]


def potential_integral(region, T) -> float:
    """∫_{region ∩ T} φ_T dA, exact: in the sub-triangle (t_k, t_k+1, centroid) φ_T = 3β_k is affine,
    so its integral over a convex piece is area × value at the piece's centroid."""
    g = np.mean(T, axis=0)
    total = 0.0
    for k in range(3):
        sub = np.array([T[k], T[(k + 1) % 3], g])
        area, c = polygon_area_centroid(clip_convex(region, sub))
        if area > 0:
            total += area * 3.0 * barycentric(c, T)[k]
    return total


# ------------------------------------------------------------------------------------------------
# brute-force reference of the narrow phase (docs/theory/contact.md §2.3.1 steps 7 and 9, quadrature)
# ------------------------------------------------------------------------------------------------
def reference_pass(C, T, p, nquad=40001):
    """Nodal forces (gC, gT), 3 × 2 each, of one contact pass (contactor C, target T) per unit
    thickness, with Φ0 = ∫φ_T ds and Φ1 = ∫ s φ_T ds computed by the composite trapezoidal rule on
    ``nquad`` points per contactor edge (brute force, no clipping or breakpoints)."""
    s = np.linspace(0.0, 1.0, nquad)
    w = np.full(nquad, 1.0 / (nquad - 1))
    w[0] = w[-1] = 0.5 / (nquad - 1)
    gC = np.zeros((3, 2))
    for i in range(3):
        j = (i + 1) % 3
        P = (1.0 - s)[:, None] * C[i] + s[:, None] * C[j]
        phi = munjiza_potential(P, T)
        Phi0 = (w * phi).sum()
        Phi1 = (w * s * phi).sum()
        n = edge_normal(C, i)
        gC[i] -= p * (Phi0 - Phi1) * n
        gC[j] -= p * Phi1 * n
    beta = barycentric(C, T)             # beta[r, k] = β_k(c_r)
    gT = np.zeros((3, 2))
    for q in range(3):
        gT[q] = -(gC * beta[:, (q + 1) % 3][:, None]).sum(0)
    return gC, gT


def reference_couple_forces(A, B, p, nquad=40001):
    """(fA, fB): both passes of a couple (§2.3.2 COUPLE)."""
    gB1, gA1 = reference_pass(B, A, p, nquad)
    gA2, gB2 = reference_pass(A, B, p, nquad)
    return gA1 + gA2, gB1 + gB2


# ------------------------------------------------------------------------------------------------
# brute-force broad phase (docs/theory/contact.md §4.1)
# ------------------------------------------------------------------------------------------------
def union_find_roots(n: int, pairs) -> np.ndarray:
    """Brute force: for each of n items linked by ``pairs``, the smallest item of its connected
    component (union-find)."""
    parent = list(range(n))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a
    for a, b in pairs:
        ra, rb = find(int(a)), find(int(b))
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    return np.array([find(a) for a in range(n)], dtype=np.int64)


def shared_node_pairs(tris, active=None):
    """Pairs of triangles (rows of ``tris``) that share a node, as (t, first triangle of the node);
    triangles with ``active`` False are left out."""
    owner, pairs = {}, []
    for t, nodes in enumerate(np.asarray(tris)):
        if active is not None and not active[t]:
            continue
        for n in nodes:
            n = int(n)
            if n in owner:
                pairs.append((t, owner[n]))
            else:
                owner[n] = t
    return pairs


def bounding_circles(x, tris):
    """Centroids (m × 2) and radii r = max_v |x_v − c| of the triangles ``tris`` at positions ``x``."""
    P = x[tris]
    c = P.mean(axis=1)
    r = np.sqrt(((P - c[:, None, :]) ** 2).sum(-1)).max(axis=1)
    return c, r


def beyond_edges(p, q, margin):
    """For triangles p, q (m × 3 × 2): does q lie more than ``margin`` beyond the line of an edge
    of p, on the side away from p's third vertex (a separating axis)?"""
    sep = np.zeros(len(p), dtype=bool)
    for e in range(3):
        a, b, c = p[:, e], p[:, (e + 1) % 3], p[:, (e + 2) % 3]
        n = np.stack([b[:, 1] - a[:, 1], a[:, 0] - b[:, 0]], -1)
        n = np.where((((c - a) * n).sum(-1) > 0)[:, None], -n, n)
        dmin = ((q - a[:, None, :]) * n[:, None, :]).sum(-1).min(axis=1)
        sep |= dmin > margin * np.linalg.norm(n, axis=1)
    return sep


def brute_force_couples(x, tris, candidates, tri_body, buffer, self_contact_bodies=(), fixed_bodies=(),
                        margin=None):
    """Set of sorted triangle pairs (a, b) among ``candidates`` with |c_a − c_b| < r_a + r_b + margin
    (default margin = buffer) whose bounding boxes are less than ``margin`` apart along both axes
    and neither of which lies more than ``margin`` beyond an edge line of the other, excluding pairs in the same body (unless self-contact), pairs of two fully fixed bodies and
    pairs sharing a node.  O(N²)."""
    margin = buffer if margin is None else margin
    cand = np.asarray(candidates)
    c, r = bounding_circles(x, tris[cand])
    d2 = ((c[:, None, :] - c[None, :, :]) ** 2).sum(-1)
    reach = r[:, None] + r[None, :] + margin
    close = d2 < reach * reach
    P = x[tris[cand]]
    lo, hi = P.min(axis=1), P.max(axis=1)
    for ax in range(2):
        close &= (lo[None, :, ax] < hi[:, None, ax] + margin) & (lo[:, None, ax] < hi[None, :, ax] + margin)
    iu = np.triu_indices(len(cand), 1)
    mask = close[iu]
    ia, ib = iu[0][mask], iu[1][mask]
    near = ~beyond_edges(P[ia], P[ib], margin) & ~beyond_edges(P[ib], P[ia], margin)
    ia, ib = ia[near], ib[near]
    ta, tb = cand[ia], cand[ib]
    bodies = np.asarray(tri_body)
    same = bodies[ta] == bodies[tb]
    if len(self_contact_bodies):
        same &= ~np.isin(bodies[ta], list(self_contact_bodies))
    share = (tris[ta][:, :, None] == tris[tb][:, None, :]).any(axis=(1, 2))
    both_fixed = np.isin(bodies[ta], list(fixed_bodies)) & np.isin(bodies[tb], list(fixed_bodies))
    keep = ~same & ~share & ~both_fixed
    return {(int(min(a, b)), int(max(a, b))) for a, b in zip(ta[keep], tb[keep])}


def couple_set(sim):
    """The simulation's couple list as a set of sorted pairs (and a check that it has no duplicates)."""
    cp = sim.couples()
    pairs = [(int(min(a, b)), int(max(a, b))) for a, b in cp]
    s = set(pairs)
    assert len(s) == len(pairs), "duplicate couples in the couple list"
    return s


DEMOS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "demos")


def load_demo(name):
    """The module demos/NAME.py (the demos import their shared module _common from demos/)."""
    import importlib.util
    import sys
    if DEMOS not in sys.path:
        sys.path.insert(0, DEMOS)
    spec = importlib.util.spec_from_file_location(f"demo_{name}", os.path.join(DEMOS, f"{name}.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod

"""Narrow phase: the distributed potential contact force (docs/theory/contact.md §2, §8.1).

Most tests lay out many independent triangle couples in one scene: every couple is two
one-triangle bodies that overlap, the couples sit on a grid 10 m apart so that each couple
interacts with nothing else.  ``sim.forces(contact_only=True)`` then gives the contact forces
of every couple in one launch.
"""
import math

import numpy as np
import pytest

import taichi_fdem as fdem
from conftest import (build_quiet, clip_convex, one_triangle, overlap_area, potential_integral,
                      random_triangle, reference_couple_forces, shape_function_gradients, twice_area)

E = 1.0e6
P = 1.0e7                     # penalty [Pa]
MAT = fdem.Material(density=1000.0, young=E, poisson=0.25, penalty=P)
SPACING = 10.0                # grid spacing of the couples [m]
N_PAIRS = 200


def random_pairs(seed, n):
    """n random overlapping CCW triangle pairs of size ~1 m, each about the origin.

    A few fixed special configurations come first: one triangle inside the other, a
    "star of David", a single vertex poking in, an edge crossing right through."""
    rng = np.random.default_rng(seed)
    base = np.array([[-0.6, -0.4], [0.7, -0.3], [0.1, 0.8]])
    g = base.mean(0)
    rot60 = np.array([[0.5, -math.sqrt(3) / 2], [math.sqrt(3) / 2, 0.5]])
    pairs = [
        (base, g + 0.4 * (base - g)),                                  # B strictly inside A
        (base, g + (base - g) @ rot60.T),                              # six-pointed star
        (base, np.array([[-0.5, 0.7], [0.6, 0.6], [0.1, 1.6]])),       # only a vertex of A inside B
        (base, np.array([[-1.0, 0.1], [1.2, 0.0], [1.0, 0.4]])),       # a long thin-ish band across
    ]
    while len(pairs) < n:
        A = random_triangle(rng, (0.0, 0.0), 0.7)
        B = random_triangle(rng, rng.uniform(-0.6, 0.6, 2), rng.uniform(0.3, 0.9))
        if overlap_area(A, B) > 0.02 * min(twice_area(A), twice_area(B)):
            pairs.append((A, B))
    assert all(overlap_area(A, B) > 0 for A, B in pairs)
    return pairs[:n]


def grid_offsets(n):
    side = int(math.ceil(math.sqrt(n)))
    return [SPACING * np.array([k % side, k // side], dtype=float) for k in range(n)]


def pair_scene(pairs, swap=False, material=MAT):
    """A scene with one couple per pair (bodies added B first when ``swap``); returns (scene, bodies)."""
    scene = fdem.Scene(gravity=(0.0, 0.0))
    bodies = []
    for (A, B), off in zip(pairs, grid_offsets(len(pairs))):
        if swap:
            bb = scene.add_body(one_triangle(B + off), material)
            ba = scene.add_body(one_triangle(A + off), material)
        else:
            ba = scene.add_body(one_triangle(A + off), material)
            bb = scene.add_body(one_triangle(B + off), material)
        bodies.append((ba, bb))
    return scene, bodies


@pytest.fixture(scope="module")
def pairs():
    return random_pairs(seed=20240611, n=N_PAIRS)


@pytest.fixture(scope="module")
def pair_sim(pairs):
    scene, bodies = pair_scene(pairs)
    with pytest.warns(RuntimeWarning, match="overlap"):
        sim = scene.build()
    return sim, bodies


def pair_forces(sim, bodies):
    """Per pair: (positions 6×2, contact forces 6×2) ordered A's nodes then B's nodes."""
    x = sim.node_positions()
    f = sim.forces(contact_only=True)
    out = []
    for ba, bb in bodies:
        idx = np.r_[np.arange(ba.node_start, ba.node_start + 3), np.arange(bb.node_start, bb.node_start + 3)]
        out.append((x[idx], f[idx]))
    return out


# ------------------------------------------------------------------------------------------------
def test_every_pair_is_one_couple(pair_sim):
    sim, bodies = pair_sim
    expected = {(ba.tri_start, bb.tri_start) for ba, bb in bodies}
    got = {tuple(sorted(map(int, c))) for c in sim.couples()}
    assert got == expected                       # exactly the N_PAIRS intended couples


def test_total_force_and_moment_vanish(pair_sim):
    """Σf = 0 and Σ x×f = 0 for each couple to round-off (§2.3.1 step 9, §8.1)."""
    sim, bodies = pair_sim
    worst_f = worst_m = 0.0
    for x, f in pair_forces(sim, bodies):
        scale = np.abs(f).max()
        assert scale > 0.0                       # every pair really is in contact
        c = x.mean(0)
        L = np.abs(x - c).max()
        worst_f = max(worst_f, np.abs(f.sum(0)).max() / scale)
        worst_m = max(worst_m, abs(np.sum((x - c)[:, 0] * f[:, 1] - (x - c)[:, 1] * f[:, 0])) / (scale * L))
    assert worst_f < 1e-12                       # |Σf| / max|f|
    assert worst_m < 1e-12                       # |Σ (x−c)×f| / (max|f| · size)


def test_forces_match_brute_force_quadrature(pair_sim, pairs):
    """The closed-form edge integrals Φ0, Φ1 (clipping + breakpoints) against a brute-force
    trapezoidal quadrature of φ_T along every contactor edge (§2.3.1, §8.1: 'Φ0 and Φ1 match
    brute-force quadrature'), through the full nodal force distribution of both passes."""
    sim, bodies = pair_sim
    worst = 0.0
    for k, (x, f) in enumerate(pair_forces(sim, bodies[:40])):
        fA, fB = reference_couple_forces(x[:3], x[3:], P, nquad=80001)
        ref = np.vstack([fA, fB])
        worst = max(worst, np.abs(f - ref).max() / np.abs(ref).max())
    assert worst < 1e-7                          # trapezoid error at the kinks of φ: ~1e-8 here


def test_swapping_contactor_and_target(pair_sim, pairs):
    """Adding the two bodies in the other order swaps the roles of the two passes: same forces."""
    sim, bodies = pair_sim
    scene2, bodies2 = pair_scene(pairs, swap=True)
    with pytest.warns(RuntimeWarning, match="overlap"):
        sim2 = scene2.build()
    # in the swapped scene B's triangle comes first: the couple's first triangle is B
    first = {int(a) for a, _ in sim2.couples()}
    assert first == {bb.tri_start for _, bb in bodies2}
    worst = 0.0
    for (x1, f1), (x2, f2) in zip(pair_forces(sim, bodies), pair_forces(sim2, bodies2)):
        assert np.array_equal(x1, x2)
        worst = max(worst, np.abs(f1 - f2).max() / np.abs(f1).max())
    assert worst < 1e-12                         # relative to max|f| of the pair


def test_translation_and_rotation_invariance(pair_sim):
    """A rigid motion of both triangles rotates the nodal forces with them (§8.1)."""
    sim, bodies = pair_sim
    x0 = sim.node_positions()
    before = pair_forces(sim, bodies)
    try:
        for theta, shift in ((0.0, (3.25, -7.5)), (0.7, (0.0, 0.0)), (2.0, (-1.5, 4.0)), (-math.pi / 2, (2.0, 1.0))):
            R = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
            sim.state.node_x.from_numpy(x0 @ R.T + np.asarray(shift))
            after = pair_forces(sim, bodies)
            worst = 0.0
            for (xa, fa), (xb, fb) in zip(before, after):
                assert np.allclose(xb, xa @ R.T + shift, rtol=0, atol=1e-12)
                worst = max(worst, np.abs(fb - fa @ R.T).max() / np.abs(fa).max())
                # |F| per node is invariant
                worst = max(worst, np.abs(np.linalg.norm(fb, axis=1) - np.linalg.norm(fa, axis=1)).max()
                            / np.abs(fa).max())
            assert worst < 1e-11, (theta, shift)   # relative; coordinates up to ~200 m
    finally:
        sim.state.node_x.from_numpy(x0)


def test_shared_edge_gives_no_force():
    """Triangles sharing an edge (coincident nodes, different bodies) push nothing (§2.3.3, §8.1)."""
    rng = np.random.default_rng(7)
    configs = [(np.array([[0, 0], [1, 0], [1, 1]], float), np.array([[0, 0], [1, 1], [0, 1]], float))]
    while len(configs) < 40:
        a, b = rng.uniform(-1, 1, (2, 2))
        if np.linalg.norm(b - a) < 0.5:
            continue
        t = (b - a) / np.linalg.norm(b - a)
        n = np.array([-t[1], t[0]])
        apex1 = a + rng.uniform(0.2, 0.8) * (b - a) + rng.uniform(0.3, 1.0) * n
        apex2 = a + rng.uniform(0.2, 0.8) * (b - a) - rng.uniform(0.3, 1.0) * n
        configs.append((np.array([a, b, apex1]), np.array([b, a, apex2])))
    scene, bodies = pair_scene(configs)
    sim = scene.build()                          # no overlap, so no warning either
    assert sim.solver.couple_count == len(configs)
    f = sim.forces(contact_only=True)
    L = 2.0                                      # triangle size [m]
    assert np.abs(f).max() < 1e-12 * P * L       # relative to the force scale p·L
    assert sim.energies()["contact"] < 1e-12 * P * L * L


def test_force_is_gradient_of_contact_energy():
    """Energy consistency of the edge integrals, by central differences of energies()["contact"].

    The contact energy is E = p∫_{A∩B}(φ_A + φ_B) dA.  For the triangle potential the nodal
    force equals −∂E/∂x exactly for the contactor role, while the target role (reaction by the
    affine shape functions, §2.3.1 step 9) differs by a term proportional to the target's own
    energy and area change:  −∂E/∂x_q = f_q − E_X ∇N_q^X  for node q of triangle X, with
    E_X = p∫_{A∩B} φ_X dA (derivation at the end of this file).  So:

    * along rigid motions of either triangle and along area-preserving node moves (a node moved
      parallel to its opposite edge) f = −∇E exactly;
    * for every nodal coordinate, −∂E/∂x_q = f_q − E_X ∇N_q^X, with E_X from an independent
      exact polygon integration.
    """
    for A, B in random_pairs(seed=99, n=10):
        # one couple per scene, near the origin: the energy diagnostic integrates moments in
        # absolute coordinates, so far-away couples would lose digits in the differences
        scene, ((ba, bb),) = pair_scene([(A, B)])
        sim = build_quiet(scene)
        x0 = sim.node_positions()
        f = sim.forces(contact_only=True)
        energy = lambda x: (sim.state.node_x.from_numpy(x), sim.energies()["contact"])[1]
        X = x0
        region = clip_convex(X[:3], X[3:])
        EA = P * potential_integral(region, X[:3])
        EB = P * potential_integral(region, X[3:])
        # independent check of the energy itself: p∫(φ_A + φ_B) dA by exact polygon integration
        assert energy(x0) == pytest.approx(EA + EB, rel=1e-10)
        corr = np.vstack([EA * shape_function_gradients(X[:3]), EB * shape_function_gradients(X[3:])])
        h = 1e-6

        def dE(direction):
            """Central difference of E along a 6×2 nodal direction (|direction| ~ 1 m)."""
            return (energy(x0 + h * direction) - energy(x0 - h * direction)) / (2 * h)

        # every coordinate: −∂E/∂x = f − E_X ∇N_X
        grad = np.zeros((6, 2))
        for r in range(6):
            for d in range(2):
                e = np.zeros((6, 2))
                e[r, d] = 1.0
                grad[r, d] = dE(e)
        scale = np.abs(grad).max()
        assert np.abs(-grad - (f - corr)).max() < 1e-7 * scale      # relative to max|∇E|

        # the plain identity f = −∇E along energy-consistent directions: rigid translations
        # and rotation of each triangle, and each node moved parallel to its opposite edge
        dirs = []
        for tri in (slice(0, 3), slice(3, 6)):
            for t in ((1.0, 0.0), (0.0, 1.0)):
                d = np.zeros((6, 2))
                d[tri] = t
                dirs.append(d)
            d = np.zeros((6, 2))
            r = X[tri] - X[tri].mean(0)
            d[tri] = np.stack([-r[:, 1], r[:, 0]], 1)
            dirs.append(d)
        for off in (0, 3):
            for q in range(3):
                a, b = X[off + (q + 1) % 3], X[off + (q + 2) % 3]
                d = np.zeros((6, 2))
                d[off + q] = (b - a) / np.linalg.norm(b - a)
                dirs.append(d)
        for d in dirs:
            assert -dE(d) == pytest.approx(float((f * d).sum()), abs=1e-7 * scale)


def test_shallow_penetration_traction():
    """A block pressed by a depth d ≪ h onto a flat: contact pressure ≈ 3pd/h per pass (§2.3.3).

    Both passes act: the block's bottom edge lies at depth d in the floor's top triangles
    (altitude h_f onto the top edge), the floor's top edge at depth d in the block's bottom
    triangles (altitude h_b), so the pressure is 3pd(1/h_f + 1/h_b)."""
    h_f, h_b = 0.1, 0.05
    width = 0.5
    d = 1e-5
    scene = fdem.Scene(gravity=(0.0, 0.0))
    floor = scene.add_body(fdem.mesh.rectangle(1.0, 0.2, h_f, pattern="right", origin=(-0.5, -0.2)), MAT)
    block = scene.add_body(fdem.mesh.rectangle(width, 0.1, h_b, pattern="right", origin=(-0.25, -d)), MAT)
    with pytest.warns(RuntimeWarning, match="overlap"):
        sim = scene.build()
    f = sim.forces(contact_only=True)
    Fy = f[block.nodes, 1].sum()
    expected = 3.0 * P * d * (1.0 / h_f + 1.0 / h_b) * width
    assert Fy == pytest.approx(expected, rel=0.01)            # corner effects are O(d/h)
    assert abs(f[block.nodes, 0].sum()) < 1e-6 * expected      # sideways forces cancel
    assert np.allclose(f[floor.nodes].sum(0), -f[block.nodes].sum(0), rtol=0, atol=1e-9 * expected)
    # and the energy of a uniform strip: p∫φ over the overlap strip of width d
    # (φ grows linearly from 0 to 3d/h across it): E = p·width·d·(3d/(2h_f) + 3d/(2h_b))
    assert sim.energies()["contact"] == pytest.approx(0.5 * expected * d, rel=0.01)


# Derivation of the corrected gradient identity used above (docs/theory/contact.md §2.1–2.3):
# E = E_A + E_B with E_X = p∫_{A∩B} φ_X dA.  Moving the nodes of the *other* triangle Y
# only moves the domain boundary lying on ∂Y, where the integrand φ_X is the contactor-pass
# load: −∂E_X/∂x_r(Y) = −p∫_{∂Y∩X} φ_X N_r n dΓ, the contactor force of that pass.  Moving
# the nodes of X itself changes φ_X: under the affine displacement δu of X the barycentric
# coordinates are transported, δφ_X = −∇φ_X·δu, so −δE_X = p∫ ∇φ_X·δu dA, whereas the
# reaction (affine shape functions of X at the contactor boundary, step 9) gives, by the
# divergence theorem, p∫ (∇φ_X·δu + φ_X div δu) dA.  The difference E_X div δu = E_X Σ_q ∇N_q·δx_q
# vanishes for rigid motions and area-preserving moves of X.

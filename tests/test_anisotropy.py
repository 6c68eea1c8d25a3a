"""Transversely isotropic elasticity (docs/theory/anisotropy.md): the five constants and their
bounds, the host maths of taichi_fdem.elasticity against closed forms and the isotropic limit,
the apparent Young's modulus of a bedded specimen under uniaxial load through the public API,
the thermal eigenstrain hook of the triangles, the energy balance of a bedded body, and the
strategies' agreement with bedding."""
from __future__ import annotations

import math

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem import elasticity

# a strongly anisotropic set (E1/E2 = 4) that satisfies the bounds
E1, NU1, E2, NU21, G2 = 40e6, 0.2, 10e6, 0.15, 6e6
BETAS = (0, 15, 30, 45, 60, 75, 90)


def _bedded(angle=30.0, **kw) -> fdem.Material:
    return fdem.Material(density=1000.0, young=E1, poisson=NU1,
                         bedding=fdem.Bedding(angle, E2, NU21, G2), **kw)


# ---- the constants ------------------------------------------------------------------------------
@pytest.mark.parametrize("change,bound", [
    (dict(young=-1.0), "young"),
    (dict(poisson=1.0), "-1 < nu1 < 1"),
    (dict(poisson=-1.0), "-1 < nu1 < 1"),
    (dict(poisson=0.3, bedding=fdem.Bedding(0.0, 1e6, 0.5, 6e6)), "1 - nu1 - 2 nu21^2 E1/E2 > 0"),
])
def test_impossible_constants_are_refused_naming_the_bound(change, bound):
    args = dict(density=1000.0, young=E1, poisson=NU1, bedding=fdem.Bedding(0.0, E2, NU21, G2))
    args.update(change)
    with pytest.raises(ValueError, match=re_escape(bound)):
        fdem.Material(**args)


def re_escape(text: str) -> str:
    import re
    return re.escape(text)


def test_bedding_fields_are_checked():
    for kw, word in ((dict(young_normal=0.0), "young_normal"), (dict(shear_modulus=-1.0), "shear_modulus"),
                     (dict(young_normal=float("nan")), "young_normal"), (dict(angle=float("inf")), "angle"),
                     (dict(tensile_strength=0.0), "tensile_strength"), (dict(spacing=-0.1), "spacing"),
                     (dict(friction_angle=95.0), "friction_angle"), (dict(cohesion=-2.0), "cohesion"),
                     (dict(fracture_energy=0.0), "fracture_energy"), (dict(expansion_normal=math.nan),
                                                                      "expansion_normal")):
        args = dict(angle=0.0, young_normal=E2, poisson_normal=NU21, shear_modulus=G2)
        args.update(kw)
        with pytest.raises(ValueError, match=word):
            fdem.Bedding(**args)
    with pytest.raises(TypeError, match="bedding"):
        fdem.Material(bedding="shale")
    for kw, word in ((dict(conductivity=0.0), "conductivity"), (dict(heat_capacity=-1.0), "heat_capacity"),
                     (dict(expansion=math.inf), "expansion")):
        with pytest.raises(ValueError, match=word):
            fdem.Material(**kw)


def test_the_positive_definite_bound_is_the_determinant_of_the_normal_block():
    """1 − ν1 − 2 ν21² E1/E2 > 0 exactly where the 3×3 normal compliance is positive definite."""
    rng = np.random.default_rng(1)
    for _ in range(400):
        e1, e2, g2 = 10 ** rng.uniform(6, 10, 3)
        nu1, nu21 = rng.uniform(-0.99, 0.99), rng.uniform(-1.5, 1.5)
        S = elasticity.compliance_3d(e1, nu1, e2, nu21, g2)
        pd = bool(np.all(np.linalg.eigvalsh(S) > 0))
        assert pd == all(ok for _, ok in elasticity.ti_bounds(e1, nu1, e2, nu21, g2))


def test_reciprocity_and_the_compliance_terms():
    S = elasticity.compliance_3d(E1, NU1, E2, NU21, G2)
    assert np.array_equal(S, S.T)
    assert S[0, 1] == pytest.approx(-NU21 / E2)
    nu12 = NU21 * E1 / E2                                 # the other ratio: ν12/E1 = ν21/E2
    assert -S[0, 1] * E1 == pytest.approx(nu12)
    C = np.linalg.inv(S)
    assert np.all(np.linalg.eigvalsh(C) > 0)


def test_isotropic_limit_of_every_host_function():
    E, nu, alpha = 30e9, 0.25, 1e-5
    iso = elasticity.isotropic_constants(E, nu)
    G = E / (2 * (1 + nu))
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    np.testing.assert_allclose(elasticity.stiffness_2d(*iso, "strain"), (lam + 2 * G, lam + 2 * G, lam, G),
                               rtol=1e-12)
    np.testing.assert_allclose(elasticity.stiffness_2d(*iso, "stress"),
                               (E / (1 - nu ** 2), E / (1 - nu ** 2), nu * E / (1 - nu ** 2), G), rtol=1e-12)
    for plane, M in (("strain", lam + 2 * G), ("stress", E / (1 - nu ** 2))):
        assert elasticity.p_wave_modulus(*elasticity.stiffness_2d(*iso, plane)) == pytest.approx(M, rel=1e-12)
        m = fdem.Material(density=2000.0, young=E, poisson=nu)
        assert m.p_wave_speed(plane) == pytest.approx(math.sqrt(M / 2000.0), rel=1e-12)
    np.testing.assert_allclose(elasticity.apparent_modulus(*iso, np.array(BETAS), "stress"), E, rtol=1e-12)
    np.testing.assert_allclose(elasticity.apparent_modulus(*iso, np.array(BETAS), "strain"), E / (1 - nu ** 2),
                               rtol=1e-12)
    np.testing.assert_allclose(elasticity.thermal_strain_2d(*iso, alpha, alpha, "strain"),
                               (alpha * (1 + nu),) * 2, rtol=1e-12)
    assert elasticity.thermal_strain_2d(*iso, alpha, alpha, "stress") == (alpha, alpha)
    # a Bedding with the isotropic constants is the isotropic material
    b = fdem.Material(young=E, poisson=nu, bedding=fdem.Bedding(17.0, E, nu, G))
    np.testing.assert_allclose(b.stiffness_2d("strain"), fdem.Material(young=E, poisson=nu).stiffness_2d("strain"),
                               rtol=1e-12)


def test_apparent_modulus_closed_form_is_the_rotated_compliance():
    """E(β) of the closed form is 1 / (Rᵀ S' R)₁₁ of the in-plane compliance rotated by β; the
    stiffest P-wave modulus is at least the largest of C11, C22."""
    for plane in ("stress", "strain"):
        C11, C22, C12, C66 = elasticity.stiffness_2d(E1, NU1, E2, NU21, G2, plane)
        C = np.array([[C11, C12, 0], [C12, C22, 0], [0, 0, C66]])
        Sv = np.linalg.inv(C)
        for beta in BETAS:
            c, s = math.cos(math.radians(beta)), math.sin(math.radians(beta))
            # a unit axial stress at β: its components in the bedding frame
            sig = np.array([c * c, s * s, c * s])
            eps = Sv @ sig
            axial = eps[0] * c * c + eps[1] * s * s + eps[2] * c * s
            assert elasticity.apparent_modulus(E1, NU1, E2, NU21, G2, beta, plane) == pytest.approx(1 / axial,
                                                                                                   rel=1e-12)
        assert elasticity.p_wave_modulus(C11, C22, C12, C66) >= max(C11, C22)


# ---- through the public API --------------------------------------------------------------------
W, H = 1.0, 0.5


def _uniaxial(beta: float, plane: str, steps: int = 3000) -> float:
    """Apparent modulus σ/ε_xx of a W × H specimen with its bedding at β: a traction σ along x on
    its right end, its left end on rollers (one corner pinned), free sides, quasi-static."""
    scene = fdem.Scene(plane=plane, gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(W, H, h=0.125, origin=(0.0, 0.0)), _bedded(beta))
    scene.fix_nodes(lambda x, y: x < 1e-9, velocity=(0.0, None))
    scene.fix_nodes(lambda x, y: (x < 1e-9) & (y < 1e-9), velocity=(None, 0.0))
    sig = 1e-4 * E2
    scene.apply_traction(lambda x, y: x > W - 1e-9, (sig, 0.0))
    sim = scene.build(quasi_static=True, strategy="serial", safety=0.5)
    sim.step(steps)
    right = sim.model.node_rest[:, 0] > W - 1e-9
    return sig / (sim.node_displacements()[right, 0].mean() / W)


@pytest.mark.parametrize("plane", ["stress", "strain"])
def test_apparent_youngs_modulus_under_uniaxial_load(plane):
    """E(β) of the bedded specimen, β = 0, 15, ..., 90°, within 2 % of the closed form (the
    field is homogeneous: the coarse mesh is exact, the rest is the finite strain of 1e-4)."""
    for beta in BETAS:
        want = elasticity.apparent_modulus(E1, NU1, E2, NU21, G2, beta, plane)
        got = _uniaxial(beta, plane)
        assert got == pytest.approx(want, rel=0.02), (plane, beta, got, want)
        assert got == pytest.approx(want, rel=1e-3), (plane, beta, got, want)


def test_a_folded_layer_has_the_callable_angle_at_each_centroid():
    fold = lambda x, y: 30.0 * np.sin(2 * np.pi * x) + 10.0 * y       # noqa: E731
    mat = _bedded(fold)
    iso = fdem.Material(density=1000.0, young=E1, poisson=NU1)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    body = scene.add_body(fdem.mesh.rectangle(1.0, 0.5, h=0.1, origin=(0.0, 0.0)), mat)
    other = scene.add_body(fdem.mesh.rectangle(0.2, 0.2, h=0.1, origin=(2.0, 0.0)), iso)
    sim = scene.build()
    X, t = sim.model.node_rest, sim.model.tri_nodes_np
    c = X[t].mean(axis=1)
    cs = sim.model.tri_bedding.to_numpy()
    got = np.degrees(np.arctan2(cs[body.triangles, 1], cs[body.triangles, 0]))
    np.testing.assert_allclose(got, fold(c[body.triangles, 0], c[body.triangles, 1]), atol=1e-9)
    np.testing.assert_allclose(sim.model.tri_bedding_np[body.triangles], fold(c[body.triangles, 0],
                                                                                c[body.triangles, 1]), atol=1e-12)
    assert np.all(cs[other.triangles] == 0.0)           # isotropic triangles: (0, 0)
    aniso = sim.model.mat_aniso.to_numpy()
    np.testing.assert_allclose(sorted(map(tuple, aniso)), sorted([mat.stiffness_2d("strain"),
                                                                   iso.stiffness_2d("strain")]), rtol=1e-12)
    with pytest.raises(ValueError, match="one angle per point"):
        bad = fdem.Scene()
        bad.add_body(fdem.mesh.rectangle(1.0, 0.5, h=0.25), _bedded(lambda x, y: [1.0, 2.0]))
        bad.build()


def test_the_time_step_follows_the_stiffest_direction():
    """A bedded material's P-wave speed is that of its stiffest direction: stiffer than along
    the bedding and than across it, and the build's estimate follows it."""
    mat = _bedded(0.0)
    for plane in ("stress", "strain"):
        C11, C22, C12, C66 = mat.stiffness_2d(plane)
        assert mat.p_wave_speed(plane) >= math.sqrt(max(C11, C22) / mat.density)
    def estimate(m):
        sc = fdem.Scene(gravity=(0.0, 0.0))
        sc.add_body(fdem.mesh.rectangle(1.0, 0.5, h=0.25), m)
        return sc.build().model.dt_elastic
    iso = fdem.Material(density=1000.0, young=E1, poisson=NU1)
    ratio = estimate(mat) / estimate(iso)
    assert ratio == pytest.approx(iso.p_wave_speed("strain") / mat.p_wave_speed("strain"), rel=1e-12)


# ---- the thermal eigenstrain hook --------------------------------------------------------------
def _plate(mat, plane, held: bool):
    scene = fdem.Scene(plane=plane, gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(1.0, 1.0, h=0.25, origin=(0.0, 0.0)), mat)
    scene.set_temperature(0.0)                  # a scene with heat: the triangles take a thermal strain
    if held:
        scene.fix_nodes(lambda x, y: np.ones_like(x, bool))
    return scene.build(strategy="serial", quasi_static=not held)


def _write_thermal(sim, eps):
    th = sim.state.tri_thermal.to_numpy()
    th[:] = eps
    sim.state.tri_thermal.from_numpy(th)


def test_a_held_plate_carries_minus_c_thermal_strain():
    """Isotropic plane strain, ε* = α(1 + ν)ΔT in both directions: σ = −E α ΔT/(1 − 2ν), from the
    kernels' nodal forces and from sim.stresses(); a bedded plate gives σ = −C:ε* in its frame."""
    E, nu, alpha, dT = 20e9, 0.25, 1e-5, 0.01
    mat = fdem.Material(density=2500.0, young=E, poisson=nu, expansion=alpha, conductivity=3.0, heat_capacity=800.0)
    sim = _plate(mat, "strain", held=True)
    assert sim.model.heat and sim.solver.features().heat
    a1, a2 = mat.thermal_expansion_2d("strain")
    _write_thermal(sim, (a1 * dT, a2 * dT, 0.0))
    want = -E * alpha * dT / (1 - 2 * nu)
    T = sim.stresses()
    np.testing.assert_allclose(T[:, 0, 0], want, rtol=1e-6)
    np.testing.assert_allclose(T[:, 1, 1], want, rtol=1e-6)
    np.testing.assert_allclose(T[:, 0, 1], 0.0, atol=1e-6 * abs(want))
    # the kernels: the internal forces on the nodes of the right edge sum to −σ_xx · H
    f = sim.forces() / sim.thickness
    right = sim.model.node_rest[:, 0] > 1.0 - 1e-9
    assert f[right, 0].sum() == pytest.approx(-want * 1.0, rel=1e-6)
    # bedded at 30°: σ in the bedding frame = −C (ε*₁, ε*₂, 0)
    bed = fdem.Material(density=2500.0, young=E1, poisson=NU1, expansion=alpha, conductivity=3.0, heat_capacity=800.0,
                        bedding=fdem.Bedding(30.0, E2, NU21, G2, expansion_normal=3 * alpha))
    sim = _plate(bed, "strain", held=True)
    a1, a2 = bed.thermal_expansion_2d("strain")
    c, s = math.cos(math.radians(30.0)), math.sin(math.radians(30.0))
    R = np.array([[c, s], [-s, c]])
    eb = np.diag([a1 * dT, a2 * dT])
    eg = R.T @ eb @ R                                      # ε* in the global frame
    _write_thermal(sim, (eg[0, 0], eg[1, 1], eg[0, 1]))
    C11, C22, C12, C66 = bed.stiffness_2d("strain")
    want_b = -np.array([C11 * eb[0, 0] + C12 * eb[1, 1], C12 * eb[0, 0] + C22 * eb[1, 1]])
    Tb = R @ sim.stresses() @ R.T
    scale = np.abs(want_b).max()
    np.testing.assert_allclose(Tb[:, 0, 0], want_b[0], rtol=1e-5)
    np.testing.assert_allclose(Tb[:, 1, 1], want_b[1], rtol=1e-5)
    np.testing.assert_allclose(Tb[:, 0, 1], 0.0, atol=1e-5 * scale)
    Tg = R.T @ np.diag(want_b) @ R
    assert f_right(sim) == pytest.approx(-Tg[0, 0], rel=1e-5)


def f_right(sim) -> float:
    f = sim.forces() / sim.thickness
    right = sim.model.node_rest[:, 0] > 1.0 - 1e-9
    return float(f[right, 0].sum())


@pytest.mark.parametrize("bedded", [False, True])
def test_a_free_plate_expands_by_the_thermal_strain_without_stress(bedded):
    """A free plate with a uniform ε* (isotropic: α ΔT; bedded: a sheared ε*) takes the strain ε*
    and no stress."""
    alpha, dT = 1e-5, 0.5
    if bedded:
        mat = fdem.Material(density=2500.0, young=E1, poisson=NU1, expansion=alpha, conductivity=3.0, heat_capacity=800.0,
                            bedding=fdem.Bedding(-20.0, E2, NU21, G2, expansion_normal=2 * alpha))
    else:
        mat = fdem.Material(density=2500.0, young=20e9, poisson=0.25, expansion=alpha, conductivity=3.0, heat_capacity=800.0)
    sim = _plate(mat, "stress", held=False)
    eps = np.array([[3e-6, 1e-6], [1e-6, -2e-6]]) if bedded else np.eye(2) * alpha * dT
    _write_thermal(sim, (eps[0, 0], eps[1, 1], eps[0, 1]))
    sim.step(3000)
    X = sim.model.node_rest
    u = sim.node_displacements()
    A = np.c_[X - X.mean(axis=0), np.ones(len(X))]
    grad = np.linalg.lstsq(A, u, rcond=None)[0][:2].T            # u ≈ G (X − X̄) + u0
    # the strain is ε* (a free body may turn rigidly: the local damping does not keep its spin)
    np.testing.assert_allclose(0.5 * (grad + grad.T), eps, atol=1e-4 * np.abs(eps).max())
    assert np.abs(sim.stresses()).max() <= 1e-4 * (E1 if bedded else 20e9) * np.abs(eps).max()


# ---- energy balance and strategies ---------------------------------------------------------------
def _bedded_scene(thermal: bool):
    fold = lambda x, y: 40.0 * np.sin(3.0 * x) - 25.0 * y          # noqa: E731
    mat = fdem.Material(density=1000.0, young=E1, poisson=NU1, expansion=1e-5 if thermal else 0.0, conductivity=3.0, heat_capacity=800.0,
                        bedding=fdem.Bedding(fold, E2, NU21, G2))
    scene = fdem.Scene(gravity=(0.0, -9.81))
    scene.add_body(fdem.mesh.rectangle(1.0, 0.4, h=0.1, origin=(0.0, 0.0)), mat)
    if thermal:
        scene.set_temperature(0.0)
    scene.fix_nodes(lambda x, y: x < 1e-9)
    scene.apply_traction(lambda x, y: x > 1.0 - 1e-9, (2e4, 1e4))
    return scene


@pytest.mark.parametrize("thermal", [False, True])
def test_energy_balance_of_a_bedded_body(thermal):
    """A bedded cantilever under a sudden end traction and gravity, no damping: the energy
    account's residual stays small against the strain energy (an inconsistent stress and energy
    would drift by O(1)); with a fixed non-uniform thermal strain as well."""
    sim = _bedded_scene(thermal).build(strategy="serial")
    if thermal:
        x = sim.model.node_rest[sim.model.tri_nodes_np].mean(axis=1)[:, 0]
        th = np.zeros((sim.model.tri_count, 3))
        th[:, 0], th[:, 1], th[:, 2] = 2e-3 * x, -1e-3 * x, 5e-4 * x
        sim.state.tri_thermal.from_numpy(th)
    e0 = sim.energies()["total"]
    peak = 0.0
    for _ in range(10):
        sim.step(200)
        e = sim.energies()
        peak = max(peak, e["strain"])
    assert peak > 0
    assert abs(e["total"] - e0) <= 2e-3 * peak, (e["total"] - e0, peak)


def test_serial_and_parallel_agree_bit_for_bit_with_bedding():
    """One force block adds the items in the serial order: the same bits as the serial strategy;
    two blocks agree to round-off."""
    scene = _bedded_scene(thermal=True)
    runs = {}
    for strategy, blocks in (("serial", None), ("parallel", 1), ("parallel", 2)):
        sim = scene.build(strategy=strategy)
        if blocks:
            sim.solver.assembly = "blocks"
            sim.solver.force_blocks = blocks
        th = np.zeros((sim.model.tri_count, 3))
        th[:, 0] = 1e-4
        sim.state.tri_thermal.from_numpy(th)
        sim.step(500)
        runs[(strategy, blocks)] = (sim.node_positions(), sim.node_velocities())
    for a, b in zip(runs[("serial", None)], runs[("parallel", 1)]):
        np.testing.assert_array_equal(a, b)
    x = runs[("serial", None)][0]
    assert np.abs(runs[("parallel", 2)][0] - x).max() <= 1e-12 * np.abs(x).max()


@pytest.mark.parametrize("thermal", [False, True])
def test_the_forces_are_the_gradient_of_the_strain_energy(thermal):
    """The kernels' nodal forces are −∂(Σ A0 W)/∂x of the energy account's strain energy, to a
    central difference's round-off, at a random deformation of a bedded body (folded bedding;
    with a non-uniform thermal strain: the split F = F_e F_th and the weight det F_th)."""
    sim = _bedded_scene(thermal).build(strategy="serial")
    if thermal:
        x = sim.model.node_rest[sim.model.tri_nodes_np].mean(axis=1)[:, 0]
        th = np.zeros((sim.model.tri_count, 3))
        th[:, 0], th[:, 1], th[:, 2] = 2e-3 * x, -1e-3 * x, 5e-4 * x
        sim.state.tri_thermal.from_numpy(th)
    rng = np.random.default_rng(0)
    x0 = sim.state.node_x.to_numpy() + 1e-3 * rng.standard_normal((sim.model.node_count, 2))
    sim.state.node_x.from_numpy(x0)
    f = sim.forces() / sim.thickness
    d, h = rng.standard_normal(x0.shape), 1e-7
    w = []
    for sign in (1.0, -1.0):
        sim.state.node_x.from_numpy(x0 + sign * h * d)
        w.append(sim.energies()["strain"] / sim.thickness)
    assert (w[0] - w[1]) / (2 * h) == pytest.approx(-(f * d).sum(), rel=1e-7)

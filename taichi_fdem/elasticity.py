"""Host maths of transversely isotropic (TI) elasticity (docs/theory/anisotropy.md), in NumPy.

Axes of a bedded material: 1 along the bedding in the model plane, 2 across the bedding (the
normal of the bedding planes), 3 out of the model plane.  The plane of isotropy is the bedding
plane, spanned by 1 and 3.  The five constants are

* E1, ν1: Young's modulus and Poisson's ratio in the bedding plane (``Material.young``,
  ``Material.poisson``);
* E2: Young's modulus across the bedding (``Bedding.young_normal``);
* ν21: the strain in the bedding plane per strain across it, under a stress across it
  (``Bedding.poisson_normal``, Amadei 1983's convention), so S₁₂ = −ν21/E2 and the other ratio
  ν12 = ν21 E1/E2 (reciprocity ν12/E1 = ν21/E2);
* G2: the shear modulus of planes normal to the bedding (``Bedding.shear_modulus``).

2D stiffnesses are in the bedding frame, Voigt order (11, 22, 12) with the engineering shear
strain γ₁₂ = 2ε₁₂: σ₁ = C11 ε₁ + C12 ε₂, σ₂ = C12 ε₁ + C22 ε₂, τ₁₂ = C66 γ₁₂.  An isotropic
material is the case E2 = E1, ν21 = ν1, G2 = E1/(2(1 + ν1)); every function here then gives the
isotropic values.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["ti_bounds", "check_ti", "compliance_3d", "stiffness_2d", "apparent_modulus", "p_wave_modulus",
           "thermal_strain_2d", "isotropic_constants", "cauchy_svk", "out_of_plane_stress"]

PLANES = ("strain", "stress")


def _plane(plane: str) -> str:
    if plane not in PLANES:
        raise ValueError(f"plane must be 'strain' or 'stress', got {plane!r}")
    return plane


def isotropic_constants(young: float, poisson: float) -> tuple:
    """(E1, ν1, E2, ν21, G2) of an isotropic material: (E, ν, E, ν, E/(2(1 + ν)))."""
    return young, poisson, young, poisson, young / (2.0 * (1.0 + poisson))


def ti_bounds(E1: float, nu1: float, E2: float, nu21: float, G2: float) -> list:
    """The positive-definiteness bounds of the five TI constants (Lempriere 1968), as
    (name, holds) pairs: E1 > 0, E2 > 0, G2 > 0, −1 < ν1 < 1 and
    1 − ν1 − 2 ν21² E1/E2 > 0 (the determinant of the 3×3 normal block of the compliance,
    det = (1 + ν1)(1 − ν1 − 2 ν21² E1/E2) / (E1² E2))."""
    ok_moduli = E1 > 0 and E2 > 0
    return [
        ("E1 > 0 (young)", E1 > 0),
        ("E2 > 0 (young_normal)", E2 > 0),
        ("G2 > 0 (shear_modulus)", G2 > 0),
        ("-1 < nu1 < 1 (poisson)", -1.0 < nu1 < 1.0),
        ("1 - nu1 - 2 nu21^2 E1/E2 > 0", ok_moduli and 1.0 - nu1 - 2.0 * nu21 * nu21 * E1 / E2 > 0.0),
    ]


def check_ti(E1: float, nu1: float, E2: float, nu21: float, G2: float, where: str = "Bedding") -> None:
    """ValueError naming the first violated bound of :func:`ti_bounds` and the values."""
    for name, holds in ti_bounds(E1, nu1, E2, nu21, G2):
        if not holds:
            raise ValueError(
                f"{where}: the transversely isotropic constants are not positive definite: the bound {name} is "
                f"violated with E1 = {E1:g} Pa, nu1 = {nu1:g}, E2 = {E2:g} Pa, nu21 = {nu21:g}, G2 = {G2:g} Pa"
                + (f" (1 - nu1 - 2 nu21^2 E1/E2 = {1.0 - nu1 - 2.0 * nu21 * nu21 * E1 / E2:g})"
                   if E1 > 0 and E2 > 0 else ""))


def compliance_3d(E1: float, nu1: float, E2: float, nu21: float, G2: float) -> np.ndarray:
    """The 6×6 compliance S [1/Pa] of the TI material in its axes (1 along the bedding, 2 across,
    3 out of plane), Voigt order (11, 22, 33, 23, 13, 12), engineering shears: ε = S σ."""
    S = np.zeros((6, 6))
    S[0, 0] = S[2, 2] = 1.0 / E1
    S[1, 1] = 1.0 / E2
    S[0, 1] = S[1, 0] = S[1, 2] = S[2, 1] = -nu21 / E2
    S[0, 2] = S[2, 0] = -nu1 / E1
    S[3, 3] = S[5, 5] = 1.0 / G2                    # planes normal to the bedding (23, 12)
    S[4, 4] = 2.0 * (1.0 + nu1) / E1                # the bedding plane (13)
    return S


def _reduced(S: np.ndarray, plane: str) -> np.ndarray:
    """The 2×2 in-plane normal compliance (11, 22): S_ij (plane stress) or
    S'_ij = S_ij − S_i3 S_j3 / S_33 (plane strain, ε₃₃ = 0)."""
    S2 = S[:2, :2].copy()
    if _plane(plane) == "strain":
        S2 -= np.outer(S[:2, 2], S[:2, 2]) / S[2, 2]
    return S2


def stiffness_2d(E1: float, nu1: float, E2: float, nu21: float, G2: float, plane: str) -> tuple:
    """(C11, C22, C12, C66) [Pa] of the plane problem in the bedding frame: the inverse of the
    in-plane compliance (plane stress) or the in-plane part of the inverse of the 3×3 normal
    block (plane strain); C66 = G2 in both."""
    S2 = _reduced(compliance_3d(E1, nu1, E2, nu21, G2), plane)
    C = np.linalg.inv(S2)
    return float(C[0, 0]), float(C[1, 1]), float(C[0, 1]), float(G2)


def apparent_modulus(E1: float, nu1: float, E2: float, nu21: float, G2: float, beta, plane: str):
    """Apparent Young's modulus E(β) [Pa] under a uniaxial stress at angle β [degrees] to the
    bedding: 1/E(β) = S'11 cos⁴β + S'22 sin⁴β + (2 S'12 + 1/G2) sin²β cos²β, with S' the
    in-plane compliance of :func:`_reduced` (plane stress: 1/E1, 1/E2, −ν21/E2, so
    1/E(β) = cos⁴β/E1 + sin⁴β/E2 + (1/G2 − 2ν21/E2) sin²β cos²β).  In plane strain it is the
    ratio of the axial stress to the axial strain with ε₃₃ = 0.  ``beta`` may be an array."""
    S2 = _reduced(compliance_3d(E1, nu1, E2, nu21, G2), plane)
    b = np.radians(np.asarray(beta, dtype=float))
    c2, s2 = np.cos(b) ** 2, np.sin(b) ** 2
    inv = S2[0, 0] * c2 * c2 + S2[1, 1] * s2 * s2 + (2.0 * S2[0, 1] + 1.0 / G2) * s2 * c2
    out = 1.0 / inv
    return float(out) if np.ndim(out) == 0 else out


def p_wave_modulus(C11: float, C22: float, C12: float, C66: float, samples: int = 3601) -> float:
    """The stiffest longitudinal (quasi-P) modulus [Pa] over the directions of the plane: the
    largest eigenvalue of the acoustic (Christoffel) tensor Γ_ik = C_ijkl n_j n_l over the unit
    vectors n (sampled every 180°/(samples − 1); the quasi-P speed is √(M/ρ)).  Isotropic: the
    P-wave modulus λ + 2μ of the plane problem."""
    th = np.linspace(0.0, math.pi, samples)
    c, s = np.cos(th), np.sin(th)
    g11 = C11 * c * c + C66 * s * s
    g22 = C66 * c * c + C22 * s * s
    g12 = (C12 + C66) * c * s
    lam = 0.5 * (g11 + g22) + np.sqrt(0.25 * (g11 - g22) ** 2 + g12 * g12)
    return float(lam.max())


def thermal_strain_2d(E1: float, nu1: float, E2: float, nu21: float, G2: float, alpha1: float, alpha2: float,
                      plane: str) -> tuple:
    """The effective thermal expansion (α1*, α2*) [1/K] of the plane problem in the bedding frame
    (α1 = α3 in the bedding plane, α2 across it): plane stress (α1, α2); plane strain, with
    ε₃₃ = 0, α_i* = α_i − S_i3 α3 / S_33 (= α_in + C2D⁻¹ C_i3 α3); isotropic: α(1 + ν)."""
    if _plane(plane) == "stress":
        return float(alpha1), float(alpha2)
    S = compliance_3d(E1, nu1, E2, nu21, G2)
    a = np.array([alpha1, alpha2]) - S[:2, 2] * alpha1 / S[2, 2]
    return float(a[0]), float(a[1])


def cauchy_svk(F, c, s, C) -> np.ndarray:
    """Cauchy stress σ = F S Fᵀ / det F [Pa] of the St Venant–Kirchhoff law in the bedding frame
    (docs/theory/anisotropy.md), vectorised: F (n, 2, 2); c, s (n,) the cosine and sine of the
    bedding angle; C (n, 4) = (C11, C22, C12, C66) in the bedding frame.  The host twin of
    ``engine.elastic.cauchy_aniso``."""
    F = np.asarray(F, dtype=np.float64)
    R = np.stack([np.stack([c, s], axis=1), np.stack([-s, c], axis=1)], axis=1)     # rows: bedding, normal
    Rt = R.transpose(0, 2, 1)
    E = 0.5 * (F.transpose(0, 2, 1) @ F - np.eye(2))
    Eb = R @ E @ Rt
    s11 = C[:, 0] * Eb[:, 0, 0] + C[:, 2] * Eb[:, 1, 1]
    s22 = C[:, 2] * Eb[:, 0, 0] + C[:, 1] * Eb[:, 1, 1]
    s12 = C[:, 3] * 2.0 * Eb[:, 0, 1]
    Sb = np.stack([np.stack([s11, s12], axis=1), np.stack([s12, s22], axis=1)], axis=1)
    S = Rt @ Sb @ R
    return F @ S @ F.transpose(0, 2, 1) / np.linalg.det(F)[:, None, None]


def out_of_plane_stress(T, cs, k) -> np.ndarray:
    """σ_zz [Pa] of plane strain (ε_zz = 0 in the linear law): k₁ σ₁ + k₂ σ₂, with σ₁, σ₂ the
    normal stresses along and across the bedding and (k₁, k₂) = (ν1, ν21 E1/E2)
    (``Material.out_of_plane_ratios``; isotropic: (ν, ν), so σ_zz = ν(σ_xx + σ_yy)).  T (n, 2, 2)
    Cauchy stresses; cs (n, 2) the cosine and sine of the bedding (rows (0, 0): along x); k (n, 2)."""
    T = np.asarray(T, dtype=np.float64)
    cs = np.asarray(cs, dtype=np.float64)
    off = np.all(cs == 0.0, axis=1)
    c = np.where(off, 1.0, cs[:, 0])
    s = np.where(off, 0.0, cs[:, 1])
    sxx, syy, sxy = T[:, 0, 0], T[:, 1, 1], 0.5 * (T[:, 0, 1] + T[:, 1, 0])
    s1 = c * c * sxx + 2.0 * c * s * sxy + s * s * syy
    s2 = s * s * sxx - 2.0 * c * s * sxy + c * c * syy
    return k[:, 0] * s1 + k[:, 1] * s2

"""Finite-strain constant-strain triangle (docs/theory/elements.md §3), as Taichi functions.

The functions work on one triangle and take the array groups they read
(:mod:`taichi_fdem.engine.groups`), so that the same maths runs inside a parallel kernel (large
scenes) and inside the serial many-step kernel (small scenes); see :mod:`taichi_fdem.engine.step`.
"""
import taichi as ti

from . import fmath
from .groups import DT, SWITCHES
from .groups import INVERTED, SWITCH_DAMPING, SWITCH_PRESTRESS
from .tiutil import mat2_cols, vec2



@ti.func
def deformation(x0, x1, x2, rest_inv):
    """F = Fx · F0⁻¹ and J = det F for a triangle with current nodes x0, x1, x2 (§3.1)."""
    Fx = mat2_cols(x1 - x0, x2 - x0)
    F = Fx @ rest_inv
    return Fx, F, F.determinant()


@ti.func
def cauchy_elastic(F, J, mu, lam):
    """Elastic Cauchy stress T = (μ/J)(B − I) + λ_Y (J − 1/J) I  [Pa] (§3.2)."""
    B = F @ F.transpose()
    I = ti.Matrix.identity(float, 2)
    return (mu / J) * (B - I) + lam * (J - 1.0 / J) * I


@ti.func
def strain_energy_density(F, J, mu, lam):
    """W per unit initial area [J/m³ · m = Pa]; the potential of :func:`cauchy_elastic` (§3.2).

    W = ½μ(tr C − 2) − μ ln J + λ(½J² − ln J − ½), evaluated without cancellation near F = I:
    with H = F − I, d = J − 1 = tr H + det H and g(d) = d − ln(1 + d) ≥ 0
    (:func:`taichi_fdem.engine.fmath.log1p_minus`),
    W = μ[½(H₀₀ − H₁₁)² + ½(H₀₁ + H₁₀)² + g(d)] + λ[½d² + g(d)], every term ≥ 0.  (J, the
    determinant of F, is not used: d from H keeps its small value exact.)
    """
    H = F - ti.Matrix.identity(float, 2)
    d = H[0, 0] + H[1, 1] + (H[0, 0] * H[1, 1] - H[0, 1] * H[1, 0])
    g = fmath.log1p_minus(d)
    return mu * (0.5 * (H[0, 0] - H[1, 1]) ** 2 + 0.5 * (H[0, 1] + H[1, 0]) ** 2 + g) + lam * (0.5 * d * d + g)


@ti.func
def green_strain(F):
    """E = ½(FᵀF − I) = ½(H + Hᵀ + HᵀH), H = F − I (no cancellation for small strains)."""
    H = F - ti.Matrix.identity(float, 2)
    return 0.5 * (H + H.transpose() + H.transpose() @ H)


@ti.func
def prestress_matrix(s):
    """The symmetric 2×2 matrix of a stress stored as (xx, yy, xy)."""
    return ti.Matrix([[s[0], s[2]], [s[2], s[1]]], dt=float)


@ti.func
def thermal_stretch(t):
    """F_th = I + ε* of a thermal strain stored as (xx, yy, xy) (docs/theory/anisotropy.md)."""
    return ti.Matrix([[1.0 + t[0], t[2]], [t[2], 1.0 + t[1]]], dt=float)


@ti.func
def bedding_rotation(c, s):
    """R, rows the bedding direction (c, s) and its normal (−s, c): a tensor A of the global frame
    is R A Rᵀ in the bedding frame."""
    return ti.Matrix([[c, s], [-s, c]], dt=float)


@ti.func
def pk2_aniso(F, c, s, C):
    """(S, E_b, S_b): the second Piola–Kirchhoff stress S [Pa] of the St Venant–Kirchhoff law of a
    transversely isotropic triangle (docs/theory/anisotropy.md), with the Green strain E_b and
    the stress S_b in the bedding frame (c, s: cosine and sine of the bedding angle;
    C = (C11, C22, C12, C66) in the bedding frame, engineering shear)."""
    R = bedding_rotation(c, s)
    Eb = R @ green_strain(F) @ R.transpose()
    s11 = C[0] * Eb[0, 0] + C[2] * Eb[1, 1]
    s22 = C[2] * Eb[0, 0] + C[1] * Eb[1, 1]
    s12 = C[3] * (2.0 * Eb[0, 1])
    Sb = ti.Matrix([[s11, s12], [s12, s22]], dt=float)
    return R.transpose() @ Sb @ R, Eb, Sb


@ti.func
def cauchy_aniso(F, J, c, s, C):
    """Cauchy stress σ = F S Fᵀ / J [Pa] of :func:`pk2_aniso`: objective, and the TI linear law at
    small strain."""
    S, Eb, Sb = pk2_aniso(F, c, s, C)
    return F @ S @ F.transpose() / J


@ti.func
def energy_aniso(F, c, s, C):
    """W = ½ E_b : C : E_b per unit (intermediate) area [Pa] of :func:`pk2_aniso`."""
    S, Eb, Sb = pk2_aniso(F, c, s, C)
    return 0.5 * (Sb[0, 0] * Eb[0, 0] + Sb[1, 1] * Eb[1, 1] + 2.0 * Sb[0, 1] * Eb[0, 1])


@ti.func
def is_bedded(b):
    """A triangle of a bedded material: its tri_bedding (cos, sin) is a unit vector; the triangles
    of isotropic materials hold (0, 0)."""
    return b[0] != 0.0 or b[1] != 0.0


@ti.func
def elastic_part(e, F, tris: ti.template(), feat: ti.template()):
    """(F_e, det F_th): the elastic part F_e = F F_th⁻¹ of the deformation and the thermal area
    ratio with ``feat.heat`` (F_th = I + ε*, ε* = tris.tri_thermal[e]), else (F, 1)."""
    Fe = F
    ratio = 1.0
    if ti.static(feat.heat):
        Fth = thermal_stretch(tris.tri_thermal[e])
        Fe = F @ Fth.inverse()
        ratio = Fth.determinant()
    return Fe, ratio


@ti.func
def elastic_stress(e, F, J, tris: ti.template(), mats: ti.template(), feat: ti.template()):
    """The elastic Cauchy stress of triangle e [Pa]: :func:`cauchy_elastic` of its material, or
    :func:`cauchy_aniso` for a bedded triangle (``feat.bedding``), of the elastic part F_e of F
    (``feat.heat``: F = F_e F_th, J_e = det F_e)."""
    m = tris.tri_mat[e]
    Fe, ratio = elastic_part(e, F, tris, feat)
    Je = J
    if ti.static(feat.heat):
        Je = Fe.determinant()
    T = ti.Matrix.zero(float, 2, 2)
    if ti.static(feat.bedding):
        b = tris.tri_bedding[e]
        if is_bedded(b):
            T = cauchy_aniso(Fe, Je, b[0], b[1], mats.mat_aniso[m])
        else:
            T = cauchy_elastic(Fe, Je, mats.mat_lame[m][0], mats.mat_lame[m][1])
    else:
        T = cauchy_elastic(Fe, Je, mats.mat_lame[m][0], mats.mat_lame[m][1])
    return T


@ti.func
def elastic_energy(e, F, J, tris: ti.template(), mats: ti.template(), feat: ti.template()):
    """W per unit initial area [Pa] of triangle e, the potential of :func:`elastic_stress`:
    det F_th · W(F_e)."""
    m = tris.tri_mat[e]
    Fe, ratio = elastic_part(e, F, tris, feat)
    Je = J
    if ti.static(feat.heat):
        Je = Fe.determinant()
    W = 0.0
    if ti.static(feat.bedding):
        b = tris.tri_bedding[e]
        if is_bedded(b):
            W = energy_aniso(Fe, b[0], b[1], mats.mat_aniso[m])
        else:
            W = strain_energy_density(Fe, Je, mats.mat_lame[m][0], mats.mat_lame[m][1])
    else:
        W = strain_energy_density(Fe, Je, mats.mat_lame[m][0], mats.mat_lame[m][1])
    if ti.static(feat.heat):
        W *= ratio
    return W


@ti.func
def tri_forces(e, nodes: ti.template(), tris: ti.template(), mats: ti.template(), step: ti.template(),
               feat: ti.template()):
    """The internal nodal forces (f0, f1, f2) [N/m] of triangle e (§3.5: f_i = ½ T n_i).

    A removed triangle (tris.tri_intact[e] < 0, an excavation) contributes nothing.  With the
    prestress switch, the initial stress adds (1/J) F S⁰ Fᵀ to T (§12.4: S⁰ a constant second
    Piola–Kirchhoff stress, so the undeformed triangle carries σ⁰ = S⁰ and the term is objective).

    With the damping switch on, the viscous stress k_s D is added and its dissipated work
    k_s (D:D) A Δt is accumulated in tris.tri_diss[e] [J/m].  A non-positive J flags
    step_int[INVERTED] (1 + triangle index) and gives zero forces.  The elastic stress is
    :func:`elastic_stress` (``feat``: the compile-time :class:`~taichi_fdem.engine.step.Features`;
    its ``bedding`` and ``heat`` select the transversely isotropic law and the thermal strains).
    """
    n = tris.tri_nodes[e]
    x0, x1, x2 = nodes.node_x[n[0]], nodes.node_x[n[1]], nodes.node_x[n[2]]
    Fx, F, J = deformation(x0, x1, x2, tris.tri_rest_inv[e])
    f0 = vec2(0.0, 0.0)
    f1 = vec2(0.0, 0.0)
    f2 = vec2(0.0, 0.0)
    if tris.tri_intact[e] < 0:
        pass
    elif J <= 0.0:
        ti.atomic_max(step.step_int[INVERTED], e + 1)
    else:
        T = elastic_stress(e, F, J, tris, mats, feat)
        if step.step_int[SWITCHES] & SWITCH_PRESTRESS:
            T += (F @ prestress_matrix(tris.tri_prestress[e]) @ F.transpose()) / J
        if step.step_int[SWITCHES] & SWITCH_DAMPING:        # a runtime switch: one compiled variant
            v0, v1, v2 = nodes.node_v[n[0]], nodes.node_v[n[1]], nodes.node_v[n[2]]
            Lx = mat2_cols(v1 - v0, v2 - v0)
            L = Lx @ Fx.inverse()
            D = 0.5 * (L + L.transpose())
            ks = tris.tri_visc[e]
            T += ks * D
            area = 0.5 * Fx.determinant()
            # a plain read and write (+= would be atomic in a parallel loop; one thread per triangle)
            tris.tri_diss[e] = tris.tri_diss[e] + ks * (D[0, 0] ** 2 + 2.0 * D[0, 1] ** 2 + D[1, 1] ** 2) * area * \
                step.step_real[DT]
        # n_i = (y_k − y_j, x_j − x_k), (i, j, k) cyclic: outward normal of the edge opposite i
        f0 = 0.5 * (T @ vec2(x2[1] - x1[1], x1[0] - x2[0]))
        f1 = 0.5 * (T @ vec2(x0[1] - x2[1], x2[0] - x0[0]))
        f2 = 0.5 * (T @ vec2(x1[1] - x0[1], x0[0] - x1[0]))
    return f0, f1, f2


@ti.func
def eval_tri_elastic(e, nodes: ti.template(), tris: ti.template(), mats: ti.template(), step: ti.template(),
                     feat: ti.template()):
    """Add the internal nodal forces of triangle e (:func:`tri_forces`) to nodes.node_f."""
    f0, f1, f2 = tri_forces(e, nodes, tris, mats, step, feat)
    n = tris.tri_nodes[e]
    ti.atomic_add(nodes.node_f[n[0]], f0)
    ti.atomic_add(nodes.node_f[n[1]], f1)
    ti.atomic_add(nodes.node_f[n[2]], f2)


@ti.func
def tri_strain_energy(e, nodes: ti.template(), tris: ti.template(), mats: ti.template(), step: ti.template(),
                      feat: ti.template()):
    """Strain energy A0·W of triangle e [J/m] (0 once removed; W: :func:`elastic_energy`); with an
    initial stress S⁰, plus its potential A0 S⁰:E, E = ½(FᵀF − I) the Green strain."""
    n = tris.tri_nodes[e]
    Fx, F, J = deformation(nodes.node_x[n[0]], nodes.node_x[n[1]], nodes.node_x[n[2]], tris.tri_rest_inv[e])
    W = 0.0
    if J > 0.0 and tris.tri_intact[e] >= 0:
        area0 = 0.5 / tris.tri_rest_inv[e].determinant()      # det F0⁻¹ = 1 / (2 A0)
        W = area0 * elastic_energy(e, F, J, tris, mats, feat)
        if step.step_int[SWITCHES] & SWITCH_PRESTRESS:
            S = prestress_matrix(tris.tri_prestress[e])
            E = green_strain(F)
            W += area0 * (S[0, 0] * E[0, 0] + S[1, 1] * E[1, 1] + 2.0 * S[0, 1] * E[0, 1])
    return W

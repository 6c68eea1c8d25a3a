"""Finite-strain constant-strain triangle (FDEM_SPEC §3), as Taichi functions.

The functions work on one triangle and take the arrays they read explicitly, so that the
same maths runs inside a parallel kernel (large scenes) and inside the serial many-step
kernel (small scenes); see :mod:`taichi_fdem.stepping`.
"""
import taichi as ti

from ._tiutil import mat2_cols, vec2



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
    """W per unit initial area [J/m³ · m = Pa]; the potential of :func:`cauchy_elastic` (§3.2)."""
    lnJ = ti.log(J)
    trC = F[0, 0] ** 2 + F[0, 1] ** 2 + F[1, 0] ** 2 + F[1, 1] ** 2
    return 0.5 * mu * (trC - 2.0) - mu * lnJ + lam * (0.5 * J * J - lnJ - 0.5)


@ti.func
def eval_tri_elastic(e, node_x: ti.template(), node_v: ti.template(), node_f: ti.template(), tri_nodes: ti.template(), tri_rest_inv: ti.template(), tri_mat: ti.template(), mat_mu: ti.template(), mat_lam: ti.template(),
                     tri_visc: ti.template(), tri_diss: ti.template(), sim_int: ti.template(), dt, damping):
    """Add the internal nodal forces of triangle e to node_f (§3.5: f_i += ½ T n_i).

    With ``damping`` the viscous stress k_s D is added and its dissipated work
    k_s (D:D) A Δt is accumulated in tri_diss[e] [J/m].  A non-positive J flags sim_int[4]
    (inverted element) and contributes no force.
    """
    n = tri_nodes[e]
    x0, x1, x2 = node_x[n[0]], node_x[n[1]], node_x[n[2]]
    Fx, F, J = deformation(x0, x1, x2, tri_rest_inv[e])
    if J <= 0.0:
        ti.atomic_max(sim_int[4], e + 1)
    else:
        m = tri_mat[e]
        T = cauchy_elastic(F, J, mat_mu[m], mat_lam[m])
        if damping != 0:                              # a runtime switch: one compiled variant
            v0, v1, v2 = node_v[n[0]], node_v[n[1]], node_v[n[2]]
            Lx = mat2_cols(v1 - v0, v2 - v0)
            L = Lx @ Fx.inverse()
            D = 0.5 * (L + L.transpose())
            ks = tri_visc[e]
            T += ks * D
            area = 0.5 * Fx.determinant()
            tri_diss[e] += ks * (D[0, 0] ** 2 + 2.0 * D[0, 1] ** 2 + D[1, 1] ** 2) * area * dt
        # n_i = (y_k − y_j, x_j − x_k), (i, j, k) cyclic: outward normal of the edge opposite i
        n0 = vec2(x2[1] - x1[1], x1[0] - x2[0])
        n1 = vec2(x0[1] - x2[1], x2[0] - x0[0])
        n2 = vec2(x1[1] - x0[1], x0[0] - x1[0])
        ti.atomic_add(node_f[n[0]], 0.5 * (T @ n0))
        ti.atomic_add(node_f[n[1]], 0.5 * (T @ n1))
        ti.atomic_add(node_f[n[2]], 0.5 * (T @ n2))


@ti.func
def tri_strain_energy(e, node_x: ti.template(), tri_nodes: ti.template(), tri_rest_inv: ti.template(), tri_area0: ti.template(), tri_mat: ti.template(), mat_mu: ti.template(), mat_lam: ti.template()):
    """Strain energy A0·W of triangle e [J/m]."""
    n = tri_nodes[e]
    Fx, F, J = deformation(node_x[n[0]], node_x[n[1]], node_x[n[2]], tri_rest_inv[e])
    W = 0.0
    if J > 0.0:
        m = tri_mat[e]
        W = tri_area0[e] * strain_energy_density(F, J, mat_mu[m], mat_lam[m])
    return W

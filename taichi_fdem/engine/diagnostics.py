"""Diagnostics kernels: energies, contact overlaps and penetration depths (not on the hot path)."""
import taichi as ti

from .groups import NB_PAIRS, SWITCH_DAMPING, SWITCHES, ContactGroup, MaterialGroup, NodeGroup, StepGroup, TriGroup
from .tiutil import vec2

from .contact import boxes_overlap
from .elastic import tri_strain_energy
from .integrate import gravity


MAXV = 10   # a triangle clipped by a triangle has at most 6 vertices


@ti.func
def clip_moments(c0, c1, c2, s0, s1, s2):
    """Area [m²] and first moment ∫x dA [m³] of triangle c ∩ triangle s (both CCW).

    Sutherland–Hodgman clipping of c by the three half-planes of s.
    """
    px = ti.Vector.zero(float, MAXV)
    py = ti.Vector.zero(float, MAXV)
    px[0], py[0], px[1], py[1], px[2], py[2] = c0[0], c0[1], c1[0], c1[1], c2[0], c2[1]
    n = 3
    S = [s0, s1, s2]
    for k in ti.static(range(3)):
        a = S[k]
        b = S[(k + 1) % 3]
        qx = ti.Vector.zero(float, MAXV)
        qy = ti.Vector.zero(float, MAXV)
        m = 0
        if n > 0:
            for i in range(n):
                j = (i + 1) % n
                pi = vec2(px[i], py[i])
                pj = vec2(px[j], py[j])
                di = (b - a).cross(pi - a)       # > 0: inside (left of the CCW edge)
                dj = (b - a).cross(pj - a)
                if di >= 0.0:
                    qx[m], qy[m] = pi[0], pi[1]
                    m += 1
                if (di >= 0.0) != (dj >= 0.0):
                    t = di / (di - dj)
                    q = pi + t * (pj - pi)
                    qx[m], qy[m] = q[0], q[1]
                    m += 1
        px, py, n = qx, qy, m
    area = 0.0
    mom = vec2(0.0, 0.0)
    if n >= 3:
        for i in range(n):
            j = (i + 1) % n
            cr = px[i] * py[j] - px[j] * py[i]
            area += 0.5 * cr
            mom += cr * vec2(px[i] + px[j], py[i] + py[j]) / 6.0
    return area, mom


@ti.func
def pass_potential(c0, c1, c2, t0, t1, t2):
    """∫_{C∩T} φ_T dA [m²] for the Munjiza potential φ_T = 3 min_k β_k of target T (§2.2)."""
    # work relative to the target's centroid: absolute coordinates far from the origin would
    # cost digits in the moments
    g = (t0 + t1 + t2) / 3.0
    inv2A = 1.0 / (t1 - t0).cross(t2 - t0)
    total = 0.0
    T = [t0 - g, t1 - g, t2 - g]
    d0 = c0 - g
    d1 = c1 - g
    d2 = c2 - g
    origin = vec2(0.0, 0.0)
    for k in ti.static(range(3)):
        a = T[k]
        b = T[(k + 1) % 3]
        # in the sub-triangle (a, b, centroid) the minimum is β_k, affine: β_k(P) = ((a − P)·m_k)/(2A)
        area, mom = clip_moments(d0, d1, d2, a, b, origin)
        mk = vec2(b[1] - a[1], -(b[0] - a[0]))
        total += 3.0 * (a.dot(mk) * area - mk.dot(mom)) * inv2A
    return total


@ti.kernel
def energy_terms(nodes: NodeGroup, tris: TriGroup, mats: MaterialGroup, contact: ContactGroup,
                 step: StepGroup, couple_count: ti.i32, out: ti.types.ndarray(), friction: ti.template(),
                 fracture: ti.template(), feat: ti.template()):
    """out = [kinetic, strain, contact (penalty + friction spring), gravity, damping dissipated], J/m.
    ``feat``: the step kernels' :class:`~taichi_fdem.engine.step.Features` (the strain energy's law).

    Neighbour pairs bonded by intact joints (``tri_nb_on`` 0: those whose forces contact skips,
    :func:`taichi_fdem.engine.contact.couple_forces`), and pairs with a removed triangle, carry
    no contact energy, as they carry no contact force.

    The sums run serially, in index order: the same bits for any number of threads (a parallel
    loop would add into ``out`` with atomics, in a different order at every call).
    """
    for i in range(5):
        out[i] = 0.0
    ti.loop_config(serialize=True)
    for i in range(nodes.node_x.shape[0]):
        g = gravity(step)       # read in the loop: no vector global temporary (engine.integrate)
        m = nodes.node_mass[i]
        out[0] += 0.5 * m * nodes.node_v[i].norm_sqr()
        out[3] -= m * g.dot(nodes.node_x[i])
    damp_on = step.step_int[SWITCHES] & SWITCH_DAMPING
    ti.loop_config(serialize=True)
    for e in range(tris.tri_nodes.shape[0]):
        out[1] += tri_strain_energy(e, nodes, tris, mats, step, feat)
        if damp_on != 0:
            out[4] += tris.tri_diss[e]
    ti.loop_config(serialize=True)
    for c in range(couple_count):
        A = contact.couple_a[c]
        B = contact.couple_b[c]
        na = tris.tri_nodes[A]
        nb = tris.tri_nodes[B]
        a0, a1, a2 = nodes.node_x[na[0]], nodes.node_x[na[1]], nodes.node_x[na[2]]
        b0, b1, b2 = nodes.node_x[nb[0]], nodes.node_x[nb[1]], nodes.node_x[nb[2]]
        prop = mats.mat_pair[tris.tri_mat[A], tris.tri_mat[B]]
        bonded = False
        if ti.static(fracture):
            bonded = (nb_skipped(c, tris.tri_nb_on, step.step_int[NB_PAIRS]) or tris.tri_intact[A] < 0
                      or tris.tri_intact[B] < 0)
        if not bonded and boxes_overlap(a0, a1, a2, b0, b1, b2):
            out[2] += prop[0] * (pass_potential(b0, b1, b2, a0, a1, a2) + pass_potential(a0, a1, a2, b0, b1, b2))
        if ti.static(friction):
            for q in ti.static(range(6)):
                out[2] += 0.5 * prop[1] * contact.couple_hist[6 * c + q] ** 2


@ti.func
def nb_skipped(c, nb_on: ti.template(), nb_count):
    """Couple c is a neighbour pair (c < nb_count) that contact skips (nb_on[c] = 0).  Nested:
    Taichi's ``and`` evaluates both sides, and nb_on holds only the neighbour pairs."""
    skip = False
    if c < nb_count:
        skip = nb_on[c] == 0
    return skip


@ti.kernel
def overlap_areas(node_x: ti.types.ndarray(), tri_nodes: ti.types.ndarray(), couple_a: ti.types.ndarray(),
                  couple_b: ti.types.ndarray(), couple_count: ti.i32, nb_on: ti.types.ndarray(), nb_count: ti.i32,
                  out: ti.types.ndarray()):
    """out[c] = overlap area [m²] of the two triangles of couple c (0 for a neighbour pair that
    contact skips: c < nb_count and nb_on[c] = 0)."""
    for c in range(couple_count):
        area = 0.0
        if not nb_skipped(c, nb_on, nb_count):
            na = tri_nodes[couple_a[c]]
            nb = tri_nodes[couple_b[c]]
            area, mom = clip_moments(node_x[na[0]], node_x[na[1]], node_x[na[2]],
                                     node_x[nb[0]], node_x[nb[1]], node_x[nb[2]])
        out[c] = area


@ti.kernel
def couple_penetrations(node_x: ti.types.ndarray(), tri_nodes: ti.types.ndarray(), couple_a: ti.types.ndarray(),
                        couple_b: ti.types.ndarray(), couple_count: ti.i32, nb_on: ti.types.ndarray(),
                        nb_count: ti.i32, depth: ti.types.ndarray(), fraction: ti.types.ndarray()):
    """depth[c] = overlap area / mean edge length [m], fraction[c] = depth / mean edge length, per couple.

    Penetration measure: for a couple of triangles A, B with overlap area A_ov and mean edge
    length L̄ of the two, d = A_ov / L̄ [m] (exact for a flat face pushed d deep along a whole
    edge) and the fraction is d / L̄; 0.5 means the overlap covers about half a triangle.  A
    neighbour pair that contact skips (c < nb_count and nb_on[c] = 0: bonded, or removed) has 0.
    """
    for c in range(couple_count):
        if nb_skipped(c, nb_on, nb_count):
            depth[c] = 0.0
            fraction[c] = 0.0
            continue
        na = tri_nodes[couple_a[c]]
        nb = tri_nodes[couple_b[c]]
        a0, a1, a2 = node_x[na[0]], node_x[na[1]], node_x[na[2]]
        b0, b1, b2 = node_x[nb[0]], node_x[nb[1]], node_x[nb[2]]
        # relative to one vertex: absolute coordinates far from the origin would cost digits
        o = a0
        area, mom = clip_moments(a0 - o, a1 - o, a2 - o, b0 - o, b1 - o, b2 - o)
        L = ((a1 - a0).norm() + (a2 - a1).norm() + (a0 - a2).norm()
             + (b1 - b0).norm() + (b2 - b1).norm() + (b0 - b2).norm()) / 6.0
        d = ti.max(area, 0.0) / L
        depth[c] = d
        fraction[c] = d / L

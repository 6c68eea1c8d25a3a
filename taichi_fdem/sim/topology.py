"""The bonds of the fracturing bodies, computed once by the build (NumPy in, NumPy out).

:func:`bonds` computes them all for the build; :func:`initial_intact` gives the initial
``tri_intact`` bits, :func:`neighbour_pairs` the bonded
neighbour pairs that open the couple list, :func:`fan_links` the fans of the original nodes for
the corner-pair rule, and :func:`prestress_offsets` the initial offsets of the joints of a
prestressed body (docs/theory/joints.md §7.10–7.11).  The kernels that read these tables are in
:mod:`taichi_fdem.engine.joints` (its FAN_* constants fix the fan table's layout).
"""
from __future__ import annotations

import numpy as np

from ..engine.groups import EDGE_FREE, INTACT
from ..engine.joints import FAN_BITS, FAN_ENTRY, FAN_HEAD, FAN_JOINT

__all__ = ["bonds", "origin_nodes", "edge_index", "initial_intact", "neighbour_pairs", "fan_links",
           "prestress_offsets"]


def initial_intact(tri_nodes, joint_nodes, joint_tris, carries, fracturing) -> np.ndarray:
    """tri_intact at the start (:data:`taichi_fdem.engine.groups.INTACT`; numpy arrays in, one i32 per triangle out).

    A bonded triangle of a fracturing body (``fracturing``) is INTACT, with EDGE_FREE << e for
    each edge e that has no joint, or whose pair has no contact couple (``carries`` False: a body
    without self-contact, or with every node prescribed), so that its joint has no contact share
    to carry.  While two triangles are intact, the joint between them carries the pair and
    contact is not evaluated for it (:func:`taichi_fdem.engine.joints.pair_carried`).  0 for every
    other triangle.
    """
    has_joint = np.zeros((len(tri_nodes), 3), bool)
    for side, (p, q) in enumerate(((0, 1), (2, 3))):
        t = joint_tris[:, side]
        v = tri_nodes[t]
        lone = ~((v == joint_nodes[:, p:p + 1]) | (v == joint_nodes[:, q:q + 1]))     # the vertex off the joint
        has_joint[t, (np.argmax(lone, axis=1) + 1) % 3] = True
    has_joint &= np.asarray(carries, bool)[:, None]
    bits = ((EDGE_FREE << np.arange(3))[None, :] * ~has_joint).sum(axis=1)
    return np.where(fracturing, INTACT + bits, 0).astype(np.int32)


def prestress_offsets(joint_prop, length, sigma0, tau0):
    """The initial offsets of prestressed joints (numpy in and out; docs/theory/joints.md §7.11).

    A joint that starts carrying the normal and shear tractions ``sigma0``, ``tau0`` [Pa] ((J, 3):
    at its end j0/j3, its mid-point and its end j1/j2; tension positive, τ along ê) starts at the
    point of its own law where the law gives them: the opening o⁰ and slip s⁰ [m] at which the
    undamaged law of §7.6–7.7 (the compression penalty, the pre-peak parabolas) returns
    (σ⁰, τ⁰), with the shear strength the Mohr–Coulomb value at σ⁰.  ``joint_prop`` (J, 6): f_t,
    c, tan φ, G_I, G_II, p_f; ``length`` (J,): rest length [m].  Returns (J, 6) offsets
    (o⁰, s⁰) per point, point by point, and (J, 3) the initial shear strength [Pa].  Raises
    ValueError when a point's traction reaches the joint's strength (σ⁰ ≥ f_t or ``|τ⁰|`` ≥ the
    shear strength): such a joint would be damaged by the initial state alone.
    """
    prop = np.asarray(joint_prop, np.float64)
    ft, c, tanphi, pf = prop[:, 0:1], prop[:, 1:2], prop[:, 2:3], prop[:, 5:6]
    L = np.asarray(length, np.float64)[:, None]
    sn, tau = np.asarray(sigma0, np.float64), np.asarray(tau0, np.float64)
    fs = np.where(sn > 0.0, c, c - sn * tanphi)
    bad = (sn >= ft) | (np.abs(tau) >= fs)
    if bad.any():
        j, p = np.argwhere(bad)[0]
        raise ValueError(f"Scene.initial_stress: the initial traction of joint {j} (point {p}: σ = {sn[j, p]:.4g} Pa, "
                         f"τ = {tau[j, p]:.4g} Pa) reaches its strength (f_t = {ft[j, 0]:.4g} Pa, shear "
                         f"strength {fs[j, p]:.4g} Pa): it would break under the initial state alone "
                         f"({int(bad.any(axis=1).sum())} joints do)")
    dp = 2.0 * L * ft / pf                    # opening and slip at peak (§7.4)
    sp = 2.0 * L * fs / pf
    # compression: σ = 2 f_t o / δ_p; tension: σ = f_t (2r − r²), r = o / δ_p, so
    # r = 1 − √(1 − x) = x / (1 + √(1 − x)), x = σ / f_t (the second form without cancellation)
    xn = np.maximum(sn, 0.0) / ft
    xs = np.abs(tau) / fs
    o = np.where(sn < 0.0, 0.5 * sn / ft * dp, dp * xn / (1.0 + np.sqrt(1.0 - xn)))
    s = np.sign(tau) * sp * xs / (1.0 + np.sqrt(1.0 - xs))
    return np.stack([o, s], axis=2).reshape(len(prop), 6), fs


def neighbour_pairs(tri_origin, eligible) -> np.ndarray:
    """The neighbour pairs of a model (numpy in and out): the pairs (A < B) of ``eligible``
    triangles (bonded triangles of a fracturing, self-contacting body) that share an original
    node: edge neighbours (two shared nodes) and corner neighbours (one), as an (M, 2) array
    sorted by (A, B).  They are the first M entries of the couple list for the whole run, never
    detected, and contact is evaluated for one only once it is no longer bonded
    (``tris.tri_nb_on``, :func:`taichi_fdem.engine.joints.switch_on_neighbours`), so that the many
    bonded pairs of an unbroken mesh cost nothing per step."""
    tri_origin = np.asarray(tri_origin)
    T = len(tri_origin)
    t = np.nonzero(np.asarray(eligible, bool))[0]
    pairs = np.zeros((0, 2), np.int64)
    if len(t) > 1:
        node = tri_origin[t].ravel()
        tri = np.repeat(t, 3)
        order = np.lexsort((tri, node))
        node, tri = node[order], tri[order]
        found = []
        for d in range(1, len(node)):          # d-th next incidence of the same original node
            same = node[:-d] == node[d:]
            if not same.any():
                break
            found.append(np.stack([tri[:-d][same], tri[d:][same]], axis=1))
        if found:
            cand = np.sort(np.concatenate(found), axis=1).astype(np.int64)
            key = np.unique(cand[:, 0] * T + cand[:, 1])
            pairs = np.stack([key // T, key % T], axis=1)
    return pairs.astype(np.int32)


def fan_links(tri_nodes, tri_origin, node_x, joint_nodes, joint_tris, pairs, eligible) -> np.ndarray:
    """The fans of the original nodes, for the corner-pair rule (numpy in, one i32 array out).

    The **fan** of an original node v is the cycle of the eligible triangles around v, in the
    order of the angle of their centroid about v (rest positions ``node_x``), and its **links**:
    link i joins the triangles of ranks i and i + 1 (mod n).  A link is a joint between the two
    (bit i of the fan's mask once the joint is damaged), an edge they still share (a body only
    partly jointed: never cut), or missing (no common edge through v, a pre-existing crack, the
    open side of a boundary node): missing links are set in the mask from the start.  A corner
    pair (A, B) at v, of ranks r_A < r_B, is bonded while one of its two arcs, the links
    r_A … r_B − 1 and the others, has no bit set: A and B are then still tied at v through a
    chain of intact joints.  A fan of more than FAN_BITS triangles sets every bit (its corner
    pairs are never bonded).

    Layout (offsets into the one array): [0] = V fans (original nodes), [1] = J joints;
    [FAN_HEAD, FAN_HEAD + V]: start of fan v's entries (V + 1 values); the next V values: fan
    v's mask of missing links; then FAN_ENTRY values per corner pair, grouped by fan (pair
    index p, arc 1, arc 2, A, B); from the end of the entries, FAN_JOINT values per joint
    (v·32 + bit of its first and second end, −1 if not a link of an eligible fan, and the index
    of its edge pair, −1 if none).
    """
    tri_nodes = np.asarray(tri_nodes)
    tri_origin = np.asarray(tri_origin)
    pairs = np.asarray(pairs, np.int64).reshape(-1, 2)
    eligible = np.asarray(eligible, bool)
    T = len(tri_origin)
    V = int(tri_origin.max()) + 1 if T else 0
    inc_v, inc_t, n_fan, first, rank = _fan_order(tri_nodes, tri_origin, node_x, eligible, V)
    rank_of = _rank_lookup(inc_v, inc_t, rank, T)
    small = n_fan <= FAN_BITS
    full = (np.int64(1) << np.minimum(n_fan, FAN_BITS)) - 1
    linked = np.zeros(V, np.int64)                    # links that are joints or shared edges
    _shared_edge_links(tri_nodes, inc_v, inc_t, n_fan, first, rank, small, linked)
    link = _joint_links(tri_nodes, tri_origin, joint_nodes, joint_tris, pairs, eligible, rank_of, n_fan, small,
                        linked)
    missing = np.where(small, full & ~linked, (np.int64(1) << FAN_BITS) - 1)
    ent, per_fan = _corner_pair_entries(tri_origin, pairs, rank_of, small, full, V)
    E0 = FAN_HEAD + 2 * V + 1
    starts = E0 + FAN_ENTRY * np.concatenate([[0], np.cumsum(per_fan)])
    out = np.concatenate([[V, len(joint_nodes)], starts, missing, ent.ravel(), link.ravel()])
    return out.astype(np.int32)


def _fan_order(tri_nodes, tri_origin, node_x, eligible, V):
    """The incidences (original node v, triangle t) of the ``eligible`` triangles, sorted by v and
    then by the angle of t's centroid about v (rest positions ``node_x``): (inc_v, inc_t, n_fan
    (V,) the size of each fan, first (V + 1,) where each fan's incidences start, rank: the rank
    of each incidence in its fan)."""
    t = np.nonzero(eligible)[0]
    inc_v = tri_origin[t].ravel().astype(np.int64)
    inc_t = np.repeat(t, 3)
    corner = node_x[tri_nodes[t]]                                     # (n, 3, 2)
    rel = np.repeat(corner.mean(axis=1), 3, axis=0) - corner.reshape(-1, 2)
    order = np.lexsort((np.arctan2(rel[:, 1], rel[:, 0]), inc_v))
    inc_v, inc_t = inc_v[order], inc_t[order]
    n_fan = np.bincount(inc_v, minlength=V)
    first = np.concatenate([[0], np.cumsum(n_fan)])                  # where each fan's ranks start
    rank = np.arange(len(inc_v)) - first[inc_v]
    return inc_v, inc_t, n_fan, first, rank


def _rank_lookup(inc_v, inc_t, rank, T):
    """``rank_of(v, tt)``: the rank of triangle tt in the fan of v, −1 where it is not in it
    (arrays in and out), for the incidences of :func:`_fan_order` over ``T`` triangles."""
    key = inc_v * max(T, 1) + inc_t
    ko = np.argsort(key, kind="stable")
    key_sorted, rank_sorted = key[ko], rank[ko]

    def rank_of(v, tt):
        """Rank of triangle tt in the fan of v (−1: not in it)."""
        k = np.asarray(v, np.int64) * max(T, 1) + tt
        if not len(key_sorted):
            return -np.ones(len(k), np.int64)
        i = np.minimum(np.searchsorted(key_sorted, k), len(key_sorted) - 1)
        return np.where(key_sorted[i] == k, rank_sorted[i], -1)

    return rank_of


def _shared_edge_links(tri_nodes, inc_v, inc_t, n_fan, first, rank, small, linked) -> None:
    """Set in ``linked`` (V,) the bit of every link of a fan of at most FAN_BITS triangles
    (``small``) whose two triangles still share an edge (two common nodes: not cut)."""
    nxt = np.where(rank == n_fan[inc_v] - 1, first[inc_v], np.arange(len(inc_v)) + 1)   # next rank, wrapping
    if len(inc_v):
        a_nodes, b_nodes = tri_nodes[inc_t], tri_nodes[inc_t[nxt]]
        same = (a_nodes[:, :, None] == b_nodes[:, None, :]).any(axis=2).sum(axis=1) >= 2
        same &= (inc_t != inc_t[nxt]) & small[inc_v]
        np.bitwise_or.at(linked, inc_v[same], np.int64(1) << rank[same])


def _joint_links(tri_nodes, tri_origin, joint_nodes, joint_tris, pairs, eligible, rank_of, n_fan, small,
                 linked) -> np.ndarray:
    """The (J, 3) link table of the joints: for each end, v·32 + bit of the link the joint is in
    the fan of that end's original node v (−1 when it is no link of an eligible fan of at most
    FAN_BITS triangles), and the index of the joint's triangle pair in ``pairs`` (−1: none).
    Sets the bits of those links in ``linked`` (V,)."""
    T = len(tri_origin)
    J = len(joint_nodes)
    link = -np.ones((J, 3), np.int64)
    if J:
        A = np.asarray(joint_tris)[:, 0]
        B = np.asarray(joint_tris)[:, 1]
        ok = eligible[A] & eligible[B]
        for end in range(2):
            r = np.argmax(tri_nodes[A] == np.asarray(joint_nodes)[:, end:end + 1], axis=1)
            v = tri_origin[A, r].astype(np.int64)
            ra, rb = rank_of(v, A), rank_of(v, B)
            n = np.maximum(n_fan[v], 1)
            bit = np.where((rb - ra) % n == 1, ra, np.where((ra - rb) % n == 1, rb, -1))
            good = ok & (ra >= 0) & (rb >= 0) & (bit >= 0) & small[v]
            link[:, end] = np.where(good, v * 32 + bit, -1)
            np.bitwise_or.at(linked, v[good], np.int64(1) << bit[good])
        if len(pairs):
            lo, hi = np.minimum(A, B).astype(np.int64), np.maximum(A, B).astype(np.int64)
            pk = pairs[:, 0] * max(T, 1) + pairs[:, 1]
            i = np.minimum(np.searchsorted(pk, lo * max(T, 1) + hi), len(pk) - 1)
            link[:, 2] = np.where(ok & (pk[i] == lo * max(T, 1) + hi), i, -1)
    return link


def _corner_pair_entries(tri_origin, pairs, rank_of, small, full, V):
    """The entries of the corner pairs (the pairs with exactly one original node v in common),
    grouped by fan: (P, FAN_ENTRY) rows (pair index, arc 1, arc 2, A, B), the two arcs of the
    fan of v between the ranks of A and B as link masks (every link of a fan of more than
    FAN_BITS triangles), and the number of entries of each fan (V,)."""
    oa, ob = tri_origin[pairs[:, 0]], tri_origin[pairs[:, 1]]
    eq = oa[:, :, None] == ob[:, None, :]
    pc = np.nonzero(eq.sum(axis=(1, 2)) == 1)[0]
    v = oa[pc, np.argmax(eq[pc].any(axis=2), axis=1)].astype(np.int64)
    ra, rb = rank_of(v, pairs[pc, 0]), rank_of(v, pairs[pc, 1])
    lo, hi = np.minimum(ra, rb), np.maximum(ra, rb)
    arc1 = np.where(small[v], (np.int64(1) << hi) - (np.int64(1) << lo), full[v])
    arc2 = np.where(small[v], full[v] ^ arc1, full[v])
    o = np.argsort(v, kind="stable")
    ent = np.stack([pc[o], arc1[o], arc2[o], pairs[pc[o], 0], pairs[pc[o], 1]], axis=1)
    return ent, np.bincount(v, minlength=V)


def bonds(md, X, tris, tri_mat, area0, pair, body_flags, tri_body, ctri, joints, sn_tau):
    """(original nodes (E, 3), the joints' triangles and edges (J, 4), the joint_prop columns,
    the fan table) of the fracturing bodies of the model ``md`` under construction
    (:func:`taichi_fdem.sim.model.build_model`), from the rest positions, triangles, rest areas,
    pair table (M, M, 4), body flags, contact triangles, the joints (nodes, triangles,
    properties, rest lengths) and ``sn_tau``, the initial normal and shear tractions (σ⁰, τ⁰) of
    the joints, each (J, 3) [Pa], or None.  Sets the model's bond host arrays (initial
    tri_intact, neighbour pairs, initial shear strengths), ``joint_prestress``, ``nb_count`` and
    ``fan_count``."""
    joint_nodes, joint_tris, joint_prop, joint_len = joints
    origin, md.tri_fracturing = origin_nodes(md.bodies, tris, len(X))
    # (A, B, e_A, e_B): the joint's triangles and the index of its edge in each (constant: the
    # joint nodes and the triangles' nodes never change), read by engine.joints.pair_carried
    edges = np.zeros((len(joint_tris), 2), np.int32)
    if md.fracture:
        edges[:, 0] = edge_index(tris[joint_tris[:, 0]], joint_nodes[:, 0], joint_nodes[:, 1])
        edges[:, 1] = edge_index(tris[joint_tris[:, 1]], joint_nodes[:, 2], joint_nodes[:, 3])
    # the per-joint constants of the share of contact a joint carries (docs/theory/joints.md §7.10,
    # engine.joints.carried_share): k_x / L = 3 p (1/(2A_A) + 1/(2A_B)) from the rest areas, and μ
    mA, mB = tri_mat[joint_tris[:, 0]], tri_mat[joint_tris[:, 1]]
    kx_per_len = 3.0 * pair[mA, mB, 0] * (0.5 / area0[joint_tris[:, 0]] + 0.5 / area0[joint_tris[:, 1]])
    carried = np.stack([kx_per_len, pair[mA, mB, 2]], axis=1) if md.fracture else np.zeros((len(joint_prop), 2))
    cols = [joint_prop, carried]
    md.joint_fs0 = np.repeat(joint_prop[:, 1:2], 3, axis=1)       # initial shear strength c [Pa]
    # prestressed joints start at the point of their law that carries σ⁰·n̂ (docs/theory/joints.md §7.11):
    # 6 more columns, the offsets, and only then (engine.joints.eval_joint compiles them by width)
    md.joint_prestress = sn_tau is not None and bool(np.any(sn_tau != 0.0))
    if md.joint_prestress:
        offsets, md.joint_fs0 = prestress_offsets(joint_prop, joint_len, sn_tau[0], sn_tau[1])
        cols.append(offsets)
    # the initial tri_intact bits.  A pair that would have no contact couple has no contact share
    # for its joint to carry: a body without self-contact, or whose every node is prescribed
    # (engine.detection.is_excluded)
    tflags = body_flags[tri_body]
    couples = ((tflags & 1) != 0) & ((tflags & 2) == 0) & md.contact
    md.tri_intact0_np = initial_intact(tris, joint_nodes[: md.joint_count], md.joint_tris_np,
                                       md.tri_fracturing & couples & (md.joined_pairs == "joint"), md.tri_fracturing)
    # the neighbour pairs: bonded triangles of such bodies that share an original node
    in_ctri = np.zeros(len(tris), bool)
    in_ctri[ctri] = md.contact
    eligible = md.tri_fracturing & couples & in_ctri
    md.nb_pairs_np = neighbour_pairs(origin, eligible)
    md.nb_count = len(md.nb_pairs_np)
    # the fans of the original nodes: which corner pairs are still tied by intact joints
    fans = fan_links(tris, origin, X, joint_nodes[: md.joint_count], md.joint_tris_np, md.nb_pairs_np, eligible) \
        if md.fracture and md.nb_count else np.zeros(FAN_HEAD + 1, np.int32)
    md.fan_count = int(fans[0])
    return origin, np.concatenate([joint_tris, edges], axis=1), cols, fans


def origin_nodes(bodies, tris, node_count):
    """(origin (E, 3): the original (unsplit) nodes of each triangle, numbered apart from every
    other body's; fracturing (E,): whether a triangle is bonded in a fracturing body)."""
    origin = tris.copy()
    fracturing = np.zeros(len(tris), bool)
    base = node_count
    for b in bodies:
        if b.origin_triangles is not None:
            origin[b.triangles] = b.origin_triangles + base
            base += int(b.origin_triangles.max()) + 1
        if b.fracture:
            fracturing[b.triangles] = b.tri_bonded if b.tri_bonded is not None else True
    return origin, fracturing


def edge_index(tri_nodes, p, q) -> np.ndarray:
    """For each row, the index e of the edge of the triangle tri_nodes (k, 3) whose ends are nodes p
    and q (edge e runs from vertex e to vertex e + 1): the edge opposite the vertex that is neither."""
    other = (tri_nodes != p[:, None]) & (tri_nodes != q[:, None])
    if not np.all(other.sum(axis=1) == 1):
        raise ValueError("internal error: a joint's nodes are not an edge of its triangle")
    return ((np.argmax(other, axis=1) + 1) % 3).astype(np.int32)

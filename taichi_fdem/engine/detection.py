"""Broad phase: contact couples by a hashed uniform grid with counting sort (docs/theory/contact.md §4).

Linear in the number of contact-participating triangles.  Each detection:

1. bounding circles (centroid c_e, radius r_e = max ``|x_v − c_e|``), boxes and vertices, and r_max;
2. cell size d = 2 r_max + b (b = buffer), so that any pair with ``|c_a − c_b|`` < r_a + r_b + b
   lies in the same or an adjacent cell; cells are hashed into a table of fixed size H ≥ 2K,
   so memory stays O(K) however sparse the scene is;
3. counting sort of the triangles by hashed cell;
4. for each triangle, scan the 9 neighbouring cells (a hashed bucket is visited once) for
   partners with a larger index, apply the couple criterion (circles within reach,
   ``|c_a − c_b|`` < r_a + r_b + b, boxes less than b apart along both axes, and no edge line of
   either triangle with the other more than b beyond it) and the exclusions (same
   non-self-contacting body, shared node, both on fully fixed bodies), count, prefix-sum, and
   fill.  Couples are grouped by their first triangle, which gives each triangle's old couples
   in O(1) for carrying friction history over from the previous detection.

The count is returned to the host before the fill: when it exceeds the buffer capacity the
caller grows the buffer and fills; no couple is ever dropped.
"""
import taichi as ti

from .groups import BUFFER
from .groups import COUPLES, DACC, DET_CAND, DETECTIONS, FOUND, INTACT, NB_PAIRS, REBALANCE, RMAX

from .tiutil import vec2



@ti.func
def cell_of(c, d):
    return ti.cast(ti.floor(c[0] / d), ti.i32), ti.cast(ti.floor(c[1] / d), ti.i32)


@ti.func
def hash_cell(ix, iy, H):
    return ((ix * 73856093) ^ (iy * 19349663)) & (H - 1)


@ti.func
def prepare_circle(k, detect: ti.template(), tris: ti.template(), nodes: ti.template(), step: ti.template()):
    """Bounding circle, box and vertices of contact triangle k, det_bound[k] = (c_x, c_y, r, x_min,
    y_min, x_max, y_max, x0, y0, x1, y1, x2, y2); the largest radius into step_real[RMAX]."""
    n = tris.tri_nodes[detect.contact_tri[k]]
    x0, x1, x2 = nodes.node_x[n[0]], nodes.node_x[n[1]], nodes.node_x[n[2]]
    c = (x0 + x1 + x2) / 3.0
    r = ti.sqrt(ti.max((x0 - c).norm_sqr(), ti.max((x1 - c).norm_sqr(), (x2 - c).norm_sqr())))
    lo = ti.min(x0, ti.min(x1, x2))
    hi = ti.max(x0, ti.max(x1, x2))
    detect.det_bound[k] = ti.Vector([c[0], c[1], r, lo[0], lo[1], hi[0], hi[1], x0[0], x0[1], x1[0], x1[1], x2[0],
                                  x2[1]], dt=float)
    ti.atomic_max(step.step_real[RMAX], r)


@ti.func
def cell_size(step: ti.template()):
    """d = 2 r_max + b: a pair within reach lies in the same or an adjacent cell."""
    return 2.0 * step.step_real[RMAX] + step.step_real[BUFFER]


@ti.func
def bin_circle(k, detect: ti.template(), step: ti.template()):
    """Hashed cell of contact triangle k and its slot in the cell (counting sort, pass 1)."""
    H = detect.det_bucket.shape[0]
    ck = detect.det_bound[k]
    ix, iy = cell_of(vec2(ck[0], ck[1]), cell_size(step))
    h = hash_cell(ix, iy, H)
    detect.det_sort[k][0] = h
    detect.det_sort[k][1] = ti.atomic_add(detect.det_bucket[h][1], 1)


@ti.func
def beyond_edges(p, q, margin):
    """Does triangle q (det_bound rows) lie more than ``margin`` beyond the line of an edge of
    triangle p, on the outer side?  Then the two are more than ``margin`` apart (a separating
    axis), whatever their orientation: the side is the one away from p's third vertex."""
    sep = False
    for e in ti.static(range(3)):
        ax, ay = p[7 + 2 * e], p[8 + 2 * e]
        bx, by = p[7 + 2 * ((e + 1) % 3)], p[8 + 2 * ((e + 1) % 3)]
        cx, cy = p[7 + 2 * ((e + 2) % 3)], p[8 + 2 * ((e + 2) % 3)]
        nx, ny = by - ay, ax - bx                        # a normal of edge a→b, |n| = |b − a|
        if (cx - ax) * nx + (cy - ay) * ny > 0.0:        # towards the third vertex: turn it round
            nx, ny = -nx, -ny
        dmin = (q[7] - ax) * nx + (q[8] - ay) * ny
        for v in ti.static(range(1, 3)):
            dmin = ti.min(dmin, (q[7 + 2 * v] - ax) * nx + (q[8 + 2 * v] - ay) * ny)
        if dmin * dmin > margin * margin * (nx * nx + ny * ny) and dmin > 0.0:
            sep = True
    return sep


@ti.func
def is_excluded(ta, tb, tris: ti.template(), detect: ti.template()):
    """Couples only between triangles that may touch (§2.3.3).

    body_flags[b] bit 0: self-contact allowed; bit 1: every node of the body is fixed.  A
    triangle removed by an excavation (tri_intact < 0) has no couples.
    Neighbour pairs (bonded triangles of a fracturing body that share an original node) are not
    detected: they are the first couples of the list for the whole run
    (:func:`taichi_fdem.sim.topology.neighbour_pairs`), evaluated once no longer bonded.
    """
    ba = tris.tri_body[ta]
    bb = tris.tri_body[tb]
    excluded = False
    if tris.tri_intact[ta] < 0 or tris.tri_intact[tb] < 0:      # removed by an excavation
        excluded = True
    elif ba == bb and (detect.body_flags[ba] & 1) == 0:
        excluded = True
    elif (detect.body_flags[ba] & 2) != 0 and (detect.body_flags[bb] & 2) != 0:
        excluded = True
    elif share_a_node(tris.tri_nodes[ta], tris.tri_nodes[tb]):
        excluded = True
    elif tris.tri_intact[ta] >= INTACT and tris.tri_intact[tb] >= INTACT:
        # a neighbour pair (two bonded triangles that share an original node): one of the
        # first couples for the whole run (sim.topology.neighbour_pairs)
        excluded = share_a_node(tris.tri_origin[ta], tris.tri_origin[tb])
    return excluded


@ti.func
def share_a_node(na, nb):
    """Do two triangles with vertices na, nb (3-vectors of node numbers) share one?"""
    shared = False
    for i in ti.static(range(3)):
        for j in ti.static(range(3)):
            if na[i] == nb[j]:
                shared = True
    return shared


@ti.func
def cand_slot(k, i, detect: ti.template()):
    """det_cnew slot of the i-th partner (i < DET_CAND) that the count scan of contact triangle k
    kept: after the K + 1 counts."""
    return detect.contact_tri.shape[0] + 1 + DET_CAND * k + i


@ti.func
def write_couple(k, c, ta, tb, detect: ti.template(), contact: ti.template(), friction: ti.template()):
    """Couple c = (ta, tb), found by contact triangle k; with friction, the slip history it had
    at the previous detection (none if it is new)."""
    contact.couple_a[c] = ta
    contact.couple_b[c] = tb
    if ti.static(friction):
        for q in ti.static(range(6)):
            contact.couple_hist[6 * c + q] = 0.0
        for co in range(detect.det_old_start[k], detect.det_old_start[k + 1]):
            if detect.det_old_b[co] == tb:
                for q in ti.static(range(6)):
                    contact.couple_hist[6 * c + q] = detect.det_old_hist[6 * co + q]


@ti.func
def scan_partners(k, count_only: ti.template(), detect: ti.template(), contact: ti.template(), tris: ti.template(),
                  step: ti.template(), out_start, friction: ti.template()):
    """Find the couples (k, k2), k2 > k, of contact triangle k.

    With count_only, returns their number and keeps the first DET_CAND partners k2 (:func:`cand_slot`)
    (in scan order, which the fill copies instead of scanning again: :func:`fill_partners`);
    otherwise writes them from out_start on (:func:`write_couple`).
    """
    H = detect.det_bucket.shape[0]
    d = cell_size(step)
    b = step.step_real[BUFFER]
    cc = detect.det_bound[k]
    ck = vec2(cc[0], cc[1])
    rk = cc[2]
    ta = detect.contact_tri[k]
    ix, iy = cell_of(ck, d)
    found = 0
    # runtime loops over the 9 cells (not unrolled): one copy of the scan in the compiled
    # kernel, which keeps the step kernels' compile time down (docs/architecture.md)
    for s in range(9):
        h = hash_cell(ix + (s % 3) - 1, iy + (s // 3) - 1, H)
        dup = False
        for s2 in range(s):              # a bucket shared by two of the 9 cells is scanned once
            if hash_cell(ix + (s2 % 3) - 1, iy + (s2 // 3) - 1, H) == h:
                dup = True
        if not dup:
            bk = detect.det_bucket[h]
            for m in range(bk[0], bk[0] + bk[1]):
                k2 = detect.det_sort[m][2]
                if k2 > k:
                    c2 = detect.det_bound[k2]
                    dc = vec2(c2[0], c2[1]) - ck
                    reach = rk + c2[2] + b
                    # circles within reach, boxes less than b apart, and no edge line of either
                    # with the other more than b beyond it: until the next detection (due when
                    # the nodes have moved by b relative to each other) a pair that fails any of
                    # these cannot touch.  The box and edge tests drop most of the pairs whose
                    # circles overlap but whose triangles stay apart (second neighbours in a
                    # mesh, the flanks of touching disks), which the contact pass would test at
                    # every step
                    near = (dc.norm_sqr() < reach * reach and c2[3] < cc[5] + b and cc[3] < c2[5] + b
                            and c2[4] < cc[6] + b and cc[4] < c2[6] + b)
                    for side in range(2 if near else 0):     # a runtime loop: one copy of the test
                        p, q = cc, c2
                        if side == 1:
                            p, q = c2, cc
                        if beyond_edges(p, q, b):
                            near = False
                    if near:
                        tb = detect.contact_tri[k2]
                        if not is_excluded(ta, tb, tris, detect):
                            if ti.static(count_only):
                                if found < DET_CAND:
                                    detect.det_cnew[cand_slot(k, found, detect)] = k2
                            else:
                                write_couple(k, out_start + found, ta, tb, detect, contact, friction)
                            found += 1
    return found


@ti.func
def fill_partners(k, detect: ti.template(), contact: ti.template(), tris: ti.template(), step: ti.template(),
                  friction: ti.template()):
    """Write the couples of contact triangle k from det_cnew[k] on: from the partners its count
    scan kept (:func:`cand_slot`), or, when it found more than DET_CAND, by scanning again (the same
    couples in the same order either way)."""
    lo = detect.det_cnew[k]
    n = detect.det_cnew[k + 1] - lo
    if n > DET_CAND:
        scan_partners(k, False, detect, contact, tris, step, lo, friction)
    else:
        ta = detect.contact_tri[k]
        for i in range(n):
            write_couple(k, lo + i, ta, detect.contact_tri[detect.det_cnew[cand_slot(k, i, detect)]], detect, contact, friction)


# ---------------------------------------------------------------------------------------------
# the broad phase as two phases of a step (engine.step, engine.team.team_worker)
# ---------------------------------------------------------------------------------------------
@ti.func
def bucket_starts(detect: ti.template()):
    """Each hashed bucket's first slot in det_sort: the exclusive prefix of its count (serial)."""
    s = 0
    for h in range(detect.det_bucket.shape[0]):
        detect.det_bucket[h][0] = s
        s += detect.det_bucket[h][1]


@ti.func
def sort_bucket(h, detect: ti.template()):
    """Bucket h's triangles in increasing k (insertion sort: a bucket holds a few): the order of a
    serial binning, whatever order a parallel one took its slots in, so that the couple list
    (and every sum over it) is the same for any thread count."""
    lo = detect.det_bucket[h][0]
    for a in range(lo + 1, lo + detect.det_bucket[h][1]):
        key = detect.det_sort[a][2]
        b = a - 1
        while b >= lo:
            if detect.det_sort[b][2] > key:
                detect.det_sort[b + 1][2] = detect.det_sort[b][2]
                b -= 1
            else:
                break
        detect.det_sort[b + 1][2] = key


@ti.func
def count_prefix(detect: ti.template(), step: ti.template()):
    """The couple counts det_cnew[k] to their exclusive prefix, after the neighbour pairs; the
    total to det_cnew[K] and step_int[FOUND] (serial)."""
    K = detect.contact_tri.shape[0]
    s = step.step_int[NB_PAIRS]
    for k in range(K):
        n = detect.det_cnew[k]
        detect.det_cnew[k] = s
        s += n
    detect.det_cnew[K] = s
    step.step_int[FOUND] = s


@ti.func
def keep_old_start(k, detect: ti.template()):
    """Contact triangle k's first couple at the previous detection (for friction's history), and
    its first couple now."""
    detect.det_old_start[k] = detect.couple_start[k]
    detect.couple_start[k] = detect.det_cnew[k]


@ti.func
def keep_old_couple(c, detect: ti.template(), contact: ti.template()):
    """Couple c's partner and slip history, kept for the fill to carry over (§4.1, §9.4)."""
    detect.det_old_b[c] = contact.couple_b[c]
    for q in ti.static(range(6)):
        detect.det_old_hist[6 * c + q] = contact.couple_hist[6 * c + q]


@ti.func
def detected(step: ti.template()):
    """The counters of a detection whose couples are written."""
    step.step_int[COUPLES] = step.step_int[FOUND]
    step.step_int[DETECTIONS] += 1
    step.step_int[REBALANCE] = 0        # new couples: the block assembly splits them anew
    step.step_real[DACC] = 0.0


@ti.func
def phase_detect_count(nodes: ti.template(), tris: ti.template(), contact: ti.template(), detect: ti.template(),
                       step: ti.template()):
    """Bounding circles, counting sort and couple count; detect.det_cnew = exclusive prefix of counts."""
    K = detect.contact_tri.shape[0]
    H = detect.det_bucket.shape[0]
    ti.loop_config(serialize=True)   # a serial task: one thread, no parallel-loop launch
    for _ in range(1):
        step.step_real[RMAX] = 0.0
    for k in range(K):
        prepare_circle(k, detect, tris, nodes, step)
    for h in range(H):
        detect.det_bucket[h] = ti.Vector([0, 0])
    for k in range(K):
        bin_circle(k, detect, step)
    ti.loop_config(serialize=True)   # a serial task: one thread, no parallel-loop launch
    for _ in range(1):
        bucket_starts(detect)
    for k in range(K):
        bn = detect.det_sort[k]
        detect.det_sort[detect.det_bucket[bn[0]][0] + bn[1]][2] = k
    for h in range(H):
        sort_bucket(h, detect)
    for k in range(K):
        detect.det_cnew[k] = scan_partners(k, True, detect, contact, tris, step, 0, False)
    ti.loop_config(serialize=True)   # a serial task: one thread, no parallel-loop launch
    for _ in range(1):
        count_prefix(detect, step)


@ti.func
def phase_detect_fill(tris: ti.template(), contact: ti.template(), detect: ti.template(), step: ti.template(),
                      friction: ti.template()):
    """Write the couples counted by :func:`phase_detect_count` (capacity already checked)."""
    K = detect.contact_tri.shape[0]
    if ti.static(friction):
        # keep the previous couples and their slip history to carry it over (§4.1, §9.4)
        for k in range(K + 1):
            keep_old_start(k, detect)
        for c in range(step.step_int[COUPLES]):
            keep_old_couple(c, detect, contact)
    for k in range(K):
        fill_partners(k, detect, contact, tris, step, friction)
    for c in range(detect.det_cnew[K]):
        contact.couple_skip[c] = 0.0          # no certificate of separation (dacc restarts at 0)
    ti.loop_config(serialize=True)   # a serial task: one thread, no parallel-loop launch
    for _ in range(1):
        detected(step)

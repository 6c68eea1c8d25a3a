"""The Taichi kernels of the off-screen renderer (module level; ndarray arguments only).

* :func:`_raster_u8_kernel` -- the supersample-1 frame in one launch: world -> pixel, colour
  (per-triangle RGB or a scalar through the colour map table) and the fill / edge test,
  written straight into a uint8 image;
* :func:`_to_pixels_kernel`, :func:`_clear_kernel`, :func:`_raster_kernel`,
  :func:`_resolve_kernel` -- the supersampled path through a float image, box-filtered down;
* :func:`_tri_scalar_kernel` / :func:`_sim_scalar_kernel` -- per-triangle colouring scalars
  (speed, displacement, von Mises and principal stresses), the latter with their finite range;
* :func:`_cracks_u8_kernel` -- the broken joints of a simulation as their two crack faces (crack
  overlay), one thread per joint, straight into a uint8 image;
* :func:`_fluid_u8_kernel` -- the conducting edges of the fluid network coloured by the fluid
  pressure (the ``"fluid_pressure"`` mode), one thread per edge, straight into a uint8 image;
* :func:`_bbox_kernel`, :func:`_centroid_kernel`, :func:`_clear_u8_kernel` -- bounding box, centroids, clearing;
* :func:`_drawn_tris_kernel`, :func:`_tri_damage_kernel`, :func:`_colormap_kernel` -- the
  triangles left by an excavation, the per-triangle damage and the colours of the scalars, from
  the simulation's device arrays (a frame copies only its image to the host).

All kernels take ``ti.types.ndarray()`` arguments, so a new scene or image size never causes
a recompilation (kernels are compiled once per dtype / dimensionality).
"""
import taichi as ti

from ..engine.elastic import cauchy_elastic, deformation

# Pixel coordinates are clamped to +-_PIX_LIMIT (also maps NaN to -_PIX_LIMIT) so that runaway
# nodes can never produce absurd loop bounds.
_PIX_LIMIT = 1.0e7

_vec3f = ti.types.vector(3, ti.f32)


# ----------------------------------------------------------------------------------------------
# Kernels (module level; ndarray arguments only)
# ----------------------------------------------------------------------------------------------
@ti.kernel
def _bbox_kernel(x: ti.types.ndarray(), out: ti.types.ndarray()):
    """out[0..3] = xmin, xmax, ymin, ymax of the vector ndarray x (n >= 1); out[4] = 1 when a
    coordinate is NaN (the box is then not usable).  A serial loop: cheaper than contended
    atomics for the node counts of a frame, and deterministic."""
    xmin = x[0][0]
    xmax = x[0][0]
    ymin = x[0][1]
    ymax = x[0][1]
    bad = 0
    ti.loop_config(serialize=True)
    for i in range(x.shape[0]):
        px = x[i][0]
        py = x[i][1]
        if px != px or py != py:
            bad = 1
        xmin = ti.min(xmin, px)
        xmax = ti.max(xmax, px)
        ymin = ti.min(ymin, py)
        ymax = ti.max(ymax, py)
    out[0] = xmin
    out[1] = xmax
    out[2] = ymin
    out[3] = ymax
    out[4] = bad


@ti.kernel
def _to_pixels_kernel(x: ti.types.ndarray(), params: ti.types.ndarray(), p: ti.types.ndarray()):
    """World -> (supersampled) pixel coordinates.  params = [x_left, y_top, pixels_per_metre].

    Pixel x grows to the right, pixel y grows downwards (row 0 is the top of the image).
    """
    for i in range(x.shape[0]):
        px = (x[i][0] - params[0]) * params[2]
        py = (params[1] - x[i][1]) * params[2]
        if not px > -_PIX_LIMIT:  # also catches NaN
            px = -_PIX_LIMIT
        if px > _PIX_LIMIT:
            px = _PIX_LIMIT
        if not py > -_PIX_LIMIT:
            py = -_PIX_LIMIT
        if py > _PIX_LIMIT:
            py = _PIX_LIMIT
        p[i] = ti.Vector([ti.cast(px, ti.f32), ti.cast(py, ti.f32)])


@ti.kernel
def _clear_kernel(img: ti.types.ndarray(), bg: _vec3f):
    for i, j in ti.ndrange(img.shape[0], img.shape[1]):
        img[i, j] = bg


@ti.func
def _drawable(x: ti.template(), ia, ib, ic, n):
    """Nodes ia, ib, ic all in [0, n) (a hidden triangle has -1) and finite.  The range test
    guards the reads: Taichi's ``and`` evaluates both sides, so the two tests are nested."""
    ok = False
    if 0 <= ia < n and 0 <= ib < n and 0 <= ic < n:
        ok = _finite_tri(x[ia], x[ib], x[ic])
    return ok


@ti.func
def _finite_tri(a, b, c):
    """All six coordinates finite: a triangle with a NaN / inf node (a blown-up run) is skipped,
    not clamped into a band of stray pixels."""
    ok = True
    for v in ti.static([a, b, c]):
        for k in ti.static(range(2)):
            if not (ti.abs(v[k]) < ti.math.inf):       # false for NaN too
                ok = False
    return ok


@ti.kernel
def _raster_kernel(p: ti.types.ndarray(), tri: ti.types.ndarray(), col: ti.types.ndarray(),
                   img: ti.types.ndarray(), edge_col: _vec3f, half_w: ti.f32, draw_edges: ti.i32):
    """Fill every triangle; one thread per triangle, serial loops over its pixel box."""
    H = img.shape[0]
    W = img.shape[1]
    n = p.shape[0]
    for t in range(tri.shape[0]):
        ia = tri[t][0]
        ib = tri[t][1]
        ic = tri[t][2]
        if _drawable(p, ia, ib, ic, n):
            a = p[ia]
            b = p[ib]
            c = p[ic]
            area2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
            if area2 != 0.0:
                sgn = 1.0 if area2 > 0.0 else -1.0
                # pixel (row r, column q) has its centre at (q + 0.5, r + 0.5)
                xlo = ti.min(a[0], b[0], c[0])
                xhi = ti.max(a[0], b[0], c[0])
                ylo = ti.min(a[1], b[1], c[1])
                yhi = ti.max(a[1], b[1], c[1])
                q0 = ti.cast(ti.max(ti.ceil(xlo - 0.5), 0.0), ti.i32)
                q1 = ti.cast(ti.min(ti.floor(xhi - 0.5), W - 1.0), ti.i32)
                r0 = ti.cast(ti.max(ti.ceil(ylo - 0.5), 0.0), ti.i32)
                r1 = ti.cast(ti.min(ti.floor(yhi - 0.5), H - 1.0), ti.i32)
                # inverse edge lengths: edge function / length = distance to the edge line
                inv_a = 1.0 / ti.max((c - b).norm(), 1e-12)
                inv_b = 1.0 / ti.max((a - c).norm(), 1e-12)
                inv_c = 1.0 / ti.max((b - a).norm(), 1e-12)
                fill = ti.Vector([col[t][0], col[t][1], col[t][2]], dt=ti.f32)
                for r in range(r0, r1 + 1):
                    yc = ti.cast(r, ti.f32) + 0.5
                    for q in range(q0, q1 + 1):
                        xc = ti.cast(q, ti.f32) + 0.5
                        wa = sgn * ((c[0] - b[0]) * (yc - b[1]) - (c[1] - b[1]) * (xc - b[0]))
                        wb = sgn * ((a[0] - c[0]) * (yc - c[1]) - (a[1] - c[1]) * (xc - c[0]))
                        wc = sgn * ((b[0] - a[0]) * (yc - a[1]) - (b[1] - a[1]) * (xc - a[0]))
                        if wa >= 0.0 and wb >= 0.0 and wc >= 0.0:
                            colour = fill
                            if draw_edges != 0:
                                d = ti.min(wa * inv_a, wb * inv_b, wc * inv_c)
                                if d < half_w:
                                    colour = edge_col
                            img[r, q] = colour


@ti.kernel
def _resolve_kernel(img: ti.types.ndarray(), out: ti.types.ndarray(), s: ti.i32):
    """Box-filter the (s*H, s*W) float image down to the (H, W, 3) uint8 image."""
    inv = ti.cast(1.0, ti.f32) / ti.cast(s * s, ti.f32)
    for i, j in ti.ndrange(out.shape[0], out.shape[1]):
        acc = ti.Vector([0.0, 0.0, 0.0], dt=ti.f32)
        for di, dj in ti.ndrange(s, s):
            acc += img[i * s + di, j * s + dj]
        acc *= inv
        for k in ti.static(range(3)):
            v = ti.min(ti.max(acc[k], 0.0), 1.0)
            out[i, j, k] = ti.cast(v * 255.0 + 0.5, ti.u8)


@ti.kernel
def _tri_scalar_kernel(x: ti.types.ndarray(), v: ti.types.ndarray(), x0: ti.types.ndarray(),
                       tri: ti.types.ndarray(), rest_inv: ti.types.ndarray(), tri_mat: ti.types.ndarray(),
                       mat_lame: ti.types.ndarray(), mode: ti.i32,
                       out: ti.types.ndarray()):
    """Per-triangle scalar for colouring, ``out[e]``:

    mode 0: speed, mean of |v| over the 3 nodes [m/s];  1: displacement, mean |x - X| [m];
    2: von Mises stress of the elastic Cauchy stress in plane stress (szz = 0) [Pa];  5: the same
    in plane strain, with szz = nu (sxx + syy), nu = lam_Y / (2 lam_Y + mu) the material's
    Poisson ratio [Pa];  3 / 4: max / min principal stress (in plane) [Pa].
    Stresses follow elastic.cauchy_elastic; an inverted triangle (J <= 0) gives NaN.
    """
    for e in range(tri.shape[0]):
        out[e] = _tri_scalar(x, v, x0, tri, rest_inv, tri_mat, mat_lame, mode, e)


@ti.func
def _tri_scalar(x: ti.template(), v: ti.template(), x0: ti.template(), tri: ti.template(),
                rest_inv: ti.template(), tri_mat: ti.template(), mat_lame: ti.template(), mode, e):
    """The colouring scalar of triangle e (see _tri_scalar_kernel)."""
    n = tri[e]
    val = 0.0
    if True:
        if mode == 0:
            val = (v[n[0]].norm() + v[n[1]].norm() + v[n[2]].norm()) / 3.0
        elif mode == 1:
            val = ((x[n[0]] - x0[n[0]]).norm() + (x[n[1]] - x0[n[1]]).norm()
                   + (x[n[2]] - x0[n[2]]).norm()) / 3.0
        else:
            Fx, F, J = deformation(x[n[0]], x[n[1]], x[n[2]], rest_inv[e])
            if J > 0.0:
                m = tri_mat[e]
                T = cauchy_elastic(F, J, mat_lame[m][0], mat_lame[m][1])
                sxx, syy, sxy = T[0, 0], T[1, 1], 0.5 * (T[0, 1] + T[1, 0])
                if mode == 2 or mode == 5:
                    szz = 0.0
                    if mode == 5:       # plane strain: the out-of-plane stress of Hooke's law
                        lam = mat_lame[m][1]
                        szz = lam / (2.0 * lam + mat_lame[m][0]) * (sxx + syy)
                    val = ti.sqrt(ti.max(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2)
                                         + 3.0 * sxy * sxy, 0.0))
                else:
                    c = 0.5 * (sxx + syy)
                    r = ti.sqrt(0.25 * (sxx - syy) ** 2 + sxy * sxy)
                    val = c + r if mode == 3 else c - r
            else:
                val = ti.math.nan
    return val


@ti.kernel
def _centroid_kernel(x: ti.types.ndarray(), start: ti.i32, end: ti.i32, out: ti.types.ndarray()):
    """out[0], out[1] = mean position [m] of nodes start..end-1; out[2] = count of finite nodes."""
    out[0] = 0.0
    out[1] = 0.0
    out[2] = 0.0
    for i in range(start, end):
        p = x[i]
        if p[0] == p[0] and p[1] == p[1]:
            out[0] += p[0]
            out[1] += p[1]
            out[2] += 1.0
    if out[2] > 0.0:
        out[0] /= out[2]
        out[1] /= out[2]


@ti.func
def _to_u8(c):
    """f32 RGB -> u8 exactly as _resolve_kernel does for supersample 1."""
    acc = ti.Vector([c[0], c[1], c[2]], dt=ti.f32)
    out = ti.Vector([0, 0, 0], dt=ti.u8)
    for k in ti.static(range(3)):
        v = ti.min(ti.max(acc[k], 0.0), 1.0)
        out[k] = ti.cast(v * 255.0 + 0.5, ti.u8)
    return out


@ti.kernel
def _clear_u8_kernel(img: ti.types.ndarray(), bg: _vec3f):
    """Fill an (H, W, 3) u8 image with the background (same conversion as the raster)."""
    for i, j in ti.ndrange(img.shape[0], img.shape[1]):
        c = _to_u8(bg)
        for k in ti.static(range(3)):
            img[i, j, k] = c[k]


@ti.kernel
def _sim_scalar_kernel(x: ti.types.ndarray(), v: ti.types.ndarray(), x0: ti.types.ndarray(),
                       tri: ti.types.ndarray(), rest_inv: ti.types.ndarray(), tri_mat: ti.types.ndarray(),
                       mat_lame: ti.types.ndarray(), mode: ti.i32,
                       scal: ti.types.ndarray(), info: ti.types.ndarray()):
    """Per-triangle scalars into scal (see _tri_scalar_kernel) and, in one launch, their finite
    range: info[0] = min, info[1] = max, info[2] = number of finite values."""
    for e in range(tri.shape[0]):
        scal[e] = _tri_scalar(x, v, x0, tri, rest_inv, tri_mat, mat_lame, mode, e)
    lo = 0.0
    hi = 0.0
    cnt = 0
    ti.loop_config(serialize=True)
    for e in range(tri.shape[0]):
        s = scal[e]
        if s == s and ti.abs(s) < ti.math.inf:
            if cnt == 0:
                lo = s
                hi = s
            lo = ti.min(lo, s)
            hi = ti.max(hi, s)
            cnt += 1
    info[0] = lo
    info[1] = hi
    info[2] = cnt


@ti.kernel
def _raster_u8_kernel(x: ti.types.ndarray(), tri: ti.types.ndarray(), col: ti.types.ndarray(),
                      scal: ti.types.ndarray(), use_scal: ti.i32, cpos: ti.types.ndarray(),
                      ctab: ti.types.ndarray(), params: ti.types.ndarray(), img: ti.types.ndarray(),
                      edge_col: _vec3f, half_w: ti.f32, draw_edges: ti.i32):
    """The supersample-1 frame in one launch: world -> pixel transform of each triangle's nodes
    (as _to_pixels_kernel), its colour (col[t], or scal[t] through the colour map table
    cpos/ctab exactly as :func:`colormap` does), and the fill / edge test of _raster_kernel,
    written straight into the (H, W, 3) u8 image (already holding the background).

    params = [x_left, y_top, pixels_per_metre, vmin, vmax] (in the dtype of x).
    """
    H = img.shape[0]
    W = img.shape[1]
    n = x.shape[0]
    K = cpos.shape[0]
    for t in range(tri.shape[0]):
        ia = tri[t][0]
        ib = tri[t][1]
        ic = tri[t][2]
        if _drawable(x, ia, ib, ic, n):
            pa = _pix(x[ia], params)
            pb = _pix(x[ib], params)
            pc = _pix(x[ic], params)
            fill = ti.Vector([0.0, 0.0, 0.0], dt=ti.f32)
            if use_scal != 0:
                fill = _cmap(scal[t], params[3], params[4], cpos, ctab, K)
            else:
                fill = ti.Vector([col[t][0], col[t][1], col[t][2]], dt=ti.f32)
            _fill_tri(pa, pb, pc, _to_u8(fill), _to_u8(edge_col), half_w, draw_edges, img, H, W)


@ti.func
def _pix(xi, params: ti.template()):
    px = (xi[0] - params[0]) * params[2]
    py = (params[1] - xi[1]) * params[2]
    if not px > -_PIX_LIMIT:  # also catches NaN
        px = -_PIX_LIMIT
    if px > _PIX_LIMIT:
        px = _PIX_LIMIT
    if not py > -_PIX_LIMIT:
        py = -_PIX_LIMIT
    if py > _PIX_LIMIT:
        py = _PIX_LIMIT
    return ti.Vector([ti.cast(px, ti.f32), ti.cast(py, ti.f32)])


@ti.func
def _cmap(val, vmin, vmax, cpos: ti.template(), ctab: ti.template(), K):
    """np.interp of the colour map table at clip((val - vmin) / (vmax - vmin), 0, 1) in the
    precision of val (f64 by default, as :func:`colormap`); NaN / inf -> grey."""
    out = ti.Vector([0.5, 0.5, 0.5], dt=ti.f32)   # _NAN_COLOR
    if val == val and ti.abs(val) < ti.math.inf:
        span = vmax - vmin
        t = val * 0.0
        if span > 0:
            t = ti.min(ti.max((val - vmin) / span, 0.0), 1.0)
        res = ti.Vector([val * 0.0, val * 0.0, val * 0.0])
        if t >= cpos[K - 1]:
            res = ti.Vector([ctab[K - 1, 0], ctab[K - 1, 1], ctab[K - 1, 2]])
        else:
            j = 0
            for k in range(1, K - 1):
                if cpos[k] <= t:
                    j = k
            for c in ti.static(range(3)):
                slope = (ctab[j + 1, c] - ctab[j, c]) / (cpos[j + 1] - cpos[j])
                res[c] = slope * (t - cpos[j]) + ctab[j, c]
        out = ti.Vector([ti.cast(res[0], ti.f32), ti.cast(res[1], ti.f32), ti.cast(res[2], ti.f32)])
    return out


@ti.func
def _fill_tri(a, b, c, fill8, edge8, half_w, draw_edges, img: ti.template(), H, W):
    area2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    if area2 != 0.0:
        sgn = 1.0 if area2 > 0.0 else -1.0
        xlo = ti.min(a[0], b[0], c[0])
        xhi = ti.max(a[0], b[0], c[0])
        ylo = ti.min(a[1], b[1], c[1])
        yhi = ti.max(a[1], b[1], c[1])
        q0 = ti.cast(ti.max(ti.ceil(xlo - 0.5), 0.0), ti.i32)
        q1 = ti.cast(ti.min(ti.floor(xhi - 0.5), W - 1.0), ti.i32)
        r0 = ti.cast(ti.max(ti.ceil(ylo - 0.5), 0.0), ti.i32)
        r1 = ti.cast(ti.min(ti.floor(yhi - 0.5), H - 1.0), ti.i32)
        inv_a = 1.0 / ti.max((c - b).norm(), 1e-12)
        inv_b = 1.0 / ti.max((a - c).norm(), 1e-12)
        inv_c = 1.0 / ti.max((b - a).norm(), 1e-12)
        for r in range(r0, r1 + 1):
            yc = ti.cast(r, ti.f32) + 0.5
            for q in range(q0, q1 + 1):
                xc = ti.cast(q, ti.f32) + 0.5
                wa = sgn * ((c[0] - b[0]) * (yc - b[1]) - (c[1] - b[1]) * (xc - b[0]))
                wb = sgn * ((a[0] - c[0]) * (yc - c[1]) - (a[1] - c[1]) * (xc - c[0]))
                wc = sgn * ((b[0] - a[0]) * (yc - a[1]) - (b[1] - a[1]) * (xc - a[0]))
                if wa >= 0.0 and wb >= 0.0 and wc >= 0.0:
                    colour = fill8
                    if draw_edges != 0:
                        d = ti.min(wa * inv_a, wb * inv_b, wc * inv_c)
                        if d < half_w:
                            colour = edge8
                    for k in ti.static(range(3)):
                        img[r, q, k] = colour[k]


@ti.kernel
def _cracks_u8_kernel(x: ti.types.ndarray(), jn: ti.types.ndarray(), js: ti.types.ndarray(), nj: ti.i32,
                      params: ti.types.ndarray(), img: ti.types.ndarray(), col: _vec3f, half_w: ti.f32):
    """Draw every broken joint j < nj (js[j] != 0) as its two crack faces, the segments
    x_j0 → x_j1 (triangle A's edge) and x_j3 → x_j2 (B's): the pixels of the (H, W, 3) u8 image
    whose centres lie within half_w pixels of either get colour col (the faces coincide while
    the crack is closed; once it opens each fragment shows its own cracked edge).
    params = [x_left, y_top, pixels_per_metre].  One thread per joint; segments with a
    non-finite end are skipped."""
    H = img.shape[0]
    W = img.shape[1]
    n = x.shape[0]
    c8 = _to_u8(col)
    for j in range(nj):
        nd = jn[j]
        if js[j] != 0 and 0 <= nd[0] < n and 0 <= nd[1] < n and 0 <= nd[2] < n and 0 <= nd[3] < n:
            for face in ti.static(range(2)):
                wa = x[nd[0]] if face == 0 else x[nd[3]]
                wb = x[nd[1]] if face == 0 else x[nd[2]]
                if _finite_tri(wa, wb, wb):
                    a = _pix(wa, params)
                    b = _pix(wb, params)
                    q0 = ti.cast(ti.max(ti.ceil(ti.min(a[0], b[0]) - half_w - 0.5), 0.0), ti.i32)
                    q1 = ti.cast(ti.min(ti.floor(ti.max(a[0], b[0]) + half_w - 0.5), W - 1.0), ti.i32)
                    r0 = ti.cast(ti.max(ti.ceil(ti.min(a[1], b[1]) - half_w - 0.5), 0.0), ti.i32)
                    r1 = ti.cast(ti.min(ti.floor(ti.max(a[1], b[1]) + half_w - 0.5), H - 1.0), ti.i32)
                    ab = b - a
                    l2 = ab.dot(ab)
                    for r in range(r0, r1 + 1):
                        for q in range(q0, q1 + 1):
                            pc = ti.Vector([ti.cast(q, ti.f32) + 0.5, ti.cast(r, ti.f32) + 0.5])
                            t = 0.0
                            if l2 > 0.0:
                                t = ti.min(ti.max((pc - a).dot(ab) / l2, 0.0), 1.0)
                            if (pc - (a + t * ab)).norm() <= half_w:
                                for k in ti.static(range(3)):
                                    img[r, q, k] = c8[k]


@ti.kernel
def _drawn_tris_kernel(tri: ti.types.ndarray(), intact: ti.types.ndarray(), out: ti.types.ndarray()):
    """out[t] = tri[t], or (−1, −1, −1) for a triangle removed by an excavation (intact[t] < 0),
    which the raster kernels skip: the simulation's own arrays, on the device."""
    for t in range(tri.shape[0]):
        v = tri[t]
        if intact[t] < 0:
            v = ti.Vector([-1, -1, -1], dt=ti.i32)
        out[t] = v


@ti.kernel
def _tri_damage_kernel(start: ti.types.ndarray(), joints: ti.types.ndarray(), dmax: ti.types.ndarray(),
                       state: ti.types.ndarray(), out: ti.types.ndarray()):
    """Per-triangle damage (as ``sim.cracks.tri_damage``): the largest damage of the triangle's
    joints joints[start[t]:start[t + 1]], a joint's damage being the largest of its dmax, 1 once
    broken (state != 0); 0 for a triangle without joints.  One thread per triangle, no atomics."""
    for t in range(out.shape[0]):
        d = out[t] * 0.0
        for q in range(start[t], start[t + 1]):
            j = joints[q]
            dj = ti.max(dmax[j][0], ti.max(dmax[j][1], dmax[j][2]))
            if state[j] != 0:
                dj = 1.0
            d = ti.max(d, dj)
        out[t] = d


@ti.kernel
def _colormap_kernel(scal: ti.types.ndarray(), rng: ti.types.ndarray(), cpos: ti.types.ndarray(),
                     ctab: ti.types.ndarray(), out: ti.types.ndarray()):
    """out[t] = the colour of scal[t] through the colour map table cpos / ctab over
    [rng[0], rng[1]] (:func:`_cmap`, as the supersample-1 raster colours its triangles)."""
    K = cpos.shape[0]
    for t in range(scal.shape[0]):
        out[t] = _cmap(scal[t], rng[0], rng[1], cpos, ctab, K)


@ti.func
def _in_tri(p, a, b, c):
    """1 if p lies in the triangle abc (either orientation, edges included; 0 if degenerate)."""
    w0 = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
    w1 = (c[0] - b[0]) * (p[1] - b[1]) - (c[1] - b[1]) * (p[0] - b[0])
    w2 = (a[0] - c[0]) * (p[1] - c[1]) - (a[1] - c[1]) * (p[0] - c[0])
    area2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    inside = 0
    if area2 != 0.0 and ((w0 >= 0.0 and w1 >= 0.0 and w2 >= 0.0) or (w0 <= 0.0 and w1 <= 0.0 and w2 <= 0.0)):
        inside = 1
    return inside


@ti.func
def _seg_dist(p, a, b):
    """Distance from p to the segment ab."""
    ab = b - a
    l2 = ab.dot(ab)
    t = 0.0
    if l2 > 0.0:
        t = ti.min(ti.max((p - a).dot(ab) / l2, 0.0), 1.0)
    return (p - (a + t * ab)).norm()


@ti.kernel
def _fluid_u8_kernel(x: ti.types.ndarray(), fe: ti.types.ndarray(), fev: ti.types.ndarray(),
                     fnv: ti.types.ndarray(), ne: ti.i32, cpos: ti.types.ndarray(), ctab: ti.types.ndarray(),
                     params: ti.types.ndarray(), img: ti.types.ndarray(), half_w: ti.f32):
    """Draw every conducting edge e < ne of the fluid network (fev[e][0] = aperture > 0) coloured
    by the fluid pressure: the pixels of the (H, W, 3) u8 image within half_w pixels of either
    face (a0 → a1 on triangle A, b0 → b1 on B) or inside the opening between them take the colour
    map (cpos/ctab, as :func:`colormap`) of the pressure interpolated linearly between the
    edge's fluid nodes u and v (fnv[u][2], fnv[v][2] [Pa]) along its mid-line.

    fe: the edges' (a0, a1, b1, b0, u, v, joint, 0); params = [x_left, y_top, pixels_per_metre,
    vmin, vmax].  One thread per edge; edges with a non-finite node are skipped."""
    H = img.shape[0]
    W = img.shape[1]
    n = x.shape[0]
    K = cpos.shape[0]
    for e in range(ne):
        en = fe[e]
        ok = False
        if 0 <= en[0] < n and 0 <= en[1] < n and 0 <= en[2] < n and 0 <= en[3] < n and fev[e][0] > 0.0:
            ok = _finite_tri(x[en[0]], x[en[1]], x[en[2]]) and _finite_tri(x[en[3]], x[en[3]], x[en[3]])
        if ok:
            a0 = _pix(x[en[0]], params)
            a1 = _pix(x[en[1]], params)
            b1 = _pix(x[en[2]], params)
            b0 = _pix(x[en[3]], params)
            pu = fnv[en[4]][2]
            pv = fnv[en[5]][2]
            m0 = 0.5 * (a0 + b0)
            mm = 0.5 * (a1 + b1) - m0
            l2 = mm.dot(mm)
            q0 = ti.cast(ti.max(ti.ceil(ti.min(a0[0], a1[0], b0[0], b1[0]) - half_w - 0.5), 0.0), ti.i32)
            q1 = ti.cast(ti.min(ti.floor(ti.max(a0[0], a1[0], b0[0], b1[0]) + half_w - 0.5), W - 1.0), ti.i32)
            r0 = ti.cast(ti.max(ti.ceil(ti.min(a0[1], a1[1], b0[1], b1[1]) - half_w - 0.5), 0.0), ti.i32)
            r1 = ti.cast(ti.min(ti.floor(ti.max(a0[1], a1[1], b0[1], b1[1]) + half_w - 0.5), H - 1.0), ti.i32)
            for r in range(r0, r1 + 1):
                for q in range(q0, q1 + 1):
                    pc = ti.Vector([ti.cast(q, ti.f32) + 0.5, ti.cast(r, ti.f32) + 0.5])
                    hit = _seg_dist(pc, a0, a1) <= half_w or _seg_dist(pc, b0, b1) <= half_w
                    if not hit:
                        hit = _in_tri(pc, a0, a1, b1) != 0 or _in_tri(pc, a0, b1, b0) != 0
                    if hit:
                        t = 0.0
                        if l2 > 0.0:
                            t = ti.min(ti.max((pc - m0).dot(mm) / l2, 0.0), 1.0)
                        c8 = _to_u8(_cmap(pu + t * (pv - pu), params[3], params[4], cpos, ctab, K))
                        for k in ti.static(range(3)):
                            img[r, q, k] = c8[k]

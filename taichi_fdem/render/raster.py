"""The off-screen rasteriser :class:`RendererImage`: draws the triangles of a 2D mesh, or a
simulation coloured by body, material, stress, speed, displacement or damage, into an RGB
image with the Taichi kernels of :mod:`~taichi_fdem.render.kernels` (no window, no OpenGL).

The simulation is only read, duck-typed (``node_x``, ``node_v``, ``tri_nodes``, ``tri_rest_inv``,
``tri_mat``, ``mat_lame``, ``bodies``, ``time``, ``step_count``, ...): this module does
not import :mod:`taichi_fdem.sim.simulation`.
"""
import math
import numbers
import weakref

import numpy as np
import taichi as ti

from taichi_fdem import backend
from taichi_fdem.elasticity import out_of_plane_stress

from ._util import (_check_color, _check_pos_int, _check_range, _check_real, _check_view, _is_ndarray,
                    _np_dtype, _to_np)
from .colors import COLOR_MODES, COLORMAPS, SOLID_UNDER_FLUID, _check_color_by, bedding_colors, body_colors, colormap
from .kernels import (_bbox_kernel, _centroid_kernel, _clear_kernel, _clear_u8_kernel, _colormap_kernel,
                      _cracks_u8_kernel, _drawn_tris_kernel, _fluid_u8_kernel, _raster_kernel, _raster_u8_kernel,
                      _resolve_kernel, _sim_scalar_kernel, _to_pixels_kernel, _tri_damage_kernel, _tri_scalar_kernel,
                      _vec3f)
from .labels import _Overlays

__all__ = ["RendererImage"]


def _tri_temperatures(sim) -> np.ndarray:
    """The mean of the nodes' temperatures of each triangle, (m,) (``color_by="temperature"``)."""
    if not getattr(sim.model, "heat", False):
        raise ValueError("color_by='temperature': the scene conducts no heat (scene.set_temperature, scene.heat)")
    return sim.temperatures()[sim.model.tri_nodes_np].mean(axis=1)


def _host_stress(kid, sim) -> bool:
    """Whether the stress scalars of mode kid come from ``sim.stresses()`` on the host: scenes with
    bedded triangles or thermal strains, whose laws the raster kernel does not hold."""
    md = getattr(sim, "model", None)
    return kid in (2, 3, 4, 5) and bool(getattr(md, "bedding", False) or getattr(md, "heat", False))


def _host_stress_scalars(sim, kid) -> np.ndarray:
    """The stress scalars of mode kid (see kernels._tri_scalar_kernel) from ``sim.stresses()``,
    σ_zz of plane strain from the triangles' laws (:func:`taichi_fdem.elasticity.out_of_plane_stress`);
    NaN for inverted triangles."""
    md = sim.model
    T = np.asarray(sim.stresses(), dtype=np.float64)
    sxx, syy, sxy = T[:, 0, 0], T[:, 1, 1], 0.5 * (T[:, 0, 1] + T[:, 1, 0])
    if kid in (2, 5):
        szz = np.zeros_like(sxx)
        if kid == 5:
            k = np.array([m.out_of_plane_ratios for m in md.materials])[np.asarray(md.tri_mat_np)]
            cs = md.tri_bedding.to_numpy() if md.bedding else np.zeros((md.tri_count, 2))
            szz = out_of_plane_stress(T, cs, k)
        val = np.sqrt(np.maximum(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2) + 3.0 * sxy * sxy, 0.0))
    else:
        c, r = 0.5 * (sxx + syy), np.sqrt(0.25 * (sxx - syy) ** 2 + sxy * sxy)
        val = c + r if kid == 3 else c - r
    x = sim.state.node_x.to_numpy().astype(np.float64)
    t = md.tri_nodes_np
    e1, e2 = x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]]
    val[e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] <= 0.0] = np.nan
    return val


def _plane_mode(kid, sim):
    """Kernel mode of a colour mode for this simulation: von Mises (2) becomes 5 in plane strain,
    where the out-of-plane stress σ_zz = ν(σ_xx + σ_yy) enters."""
    if kid == 2 and getattr(getattr(sim, "scene", None), "plane", "stress") == "strain":
        return 5
    return kid


class RendererImage(_Overlays):
    """Off-screen triangle rasteriser producing ``(height, width, 3)`` uint8 images.

    Parameters
    ----------
    width, height : int
        Image size in pixels.
    view : str or tuple of float
        ``"fit"`` (fit the bounding box of the nodes every frame, aspect preserved, with
        ``margin``) or a fixed world box ``(xmin, xmax, ymin, ymax)`` [m], which is expanded in
        one direction (letter-boxed) to match the image aspect ratio.
    background, edge_color : tuple of float
        RGB in [0, 1].
    edge_width : float
        Edge line width in output pixels (0 disables edges).
    draw_edges : bool
        Draw triangle edges.
    supersample : int
        1..4; rasterise at ``supersample`` times the resolution and box-filter down.
    margin : float
        Fraction of the larger bounding-box extent added on every side in ``"fit"`` mode.
    color_by : str
        What the colours of :meth:`render_sim` show: ``"body"`` (default; a palette colour per
        body), ``"material"``, or a scalar per triangle drawn with ``cmap`` (viridis):
        ``"speed"`` (mean ``|v|`` of the 3 nodes, m/s), ``"displacement"`` (mean ``|x - X|``
        of the 3 nodes, m), ``"von_mises"`` (von Mises of the in-plane elastic Cauchy stress,
        plane-stress form sqrt(sxx^2 - sxx syy + syy^2 + 3 sxy^2), Pa), ``"max_principal"`` /
        ``"min_principal"`` (principal stresses, Pa), ``"damage"`` (the largest damage of the
        triangle's joints, 0 to 1).  Scalars are computed by a Taichi kernel
        from the simulation's arrays; inverted triangles are grey.  ``"fluid_pressure"`` (scenes
        with a fluid, ``scene.set_fluid``): the solid in light grey and, over it, every
        conducting edge of the fracture network, its two faces ``crack_width`` pixels wide and
        the opening between them, coloured by the fluid pressure [Pa] (``cmap``, interpolated
        linearly between the edge's two network nodes); the automatic range is that of the
        conducting nodes' pressures.  ``"bedding"`` (scenes with a bedded material,
        ``fdem.Bedding``): a hue per bedding angle modulo 180° (0° red, 60° green, 120° blue;
        :func:`~taichi_fdem.render.colors.bedding_colors`), isotropic triangles grey.
        ``"temperature"`` (scenes with heat, ``scene.heat``): the mean of the triangle's nodes'
        temperatures (``sim.temperatures()``).
    vmin, vmax : float or None
        Colour range of the scalar modes, in the quantity's unit.  ``None`` (default)
        = automatic, the finite min / max of the current frame (so colours are not comparable
        between frames); give both for videos so that a colour means the same value in every
        frame.  Values outside are clipped to the ends of the colour map.
    cmap : str
        Colour map name (see :data:`COLORMAPS`), default ``"viridis"``.
    colorbar : bool
        Draw a vertical colour bar at the right of the image (scalar modes only) with
        its max / min labels and a title naming the quantity and its unit.  The view is
        shifted left so that the bar does not hide the mesh.
    stamp : bool
        Write ``t = 0.0123 s  step 4567`` at the top-left.
    follow : Body or None
        A :class:`~taichi_fdem.records.Body`; the camera is centred on the body's node
        centroid every frame and shows ``follow_width`` metres horizontally (overrides
        ``view``).
    follow_width : float or None
        Width of the followed view [m] (default: 4 x the body's initial extent).
    text_size : int or None
        Font height of the labels in pixels (default ~ height / 30, at least 10).
    cracks : bool
        Draw the broken joints (docs/theory/joints.md §7.8) on top of the triangles, each as
        its two crack faces x_j0 → x_j1 and x_j3 → x_j2 (one line while closed, the cracked
        edge of each fragment once open): the pixels whose centres lie within
        ``crack_width`` / 2 output pixels of them take ``crack_color``.  Drawn by a Taichi
        kernel, one thread per joint, at the output resolution.
    crack_color : tuple of float
        RGB in [0, 1] of the drawn cracks.
    crack_width : float
        Width of the drawn cracks in output pixels.

    Notes
    -----
    ``render(node_x, tri_nodes, tri_color)`` accepts Taichi vector ndarrays (as held by the
    simulation) or NumPy arrays of shape (n, 2), (m, 3) and (m, 3) (``tri_color`` may also be
    a single RGB triple, ``None`` for grey, or uint8 0..255).  The world y axis points up: row 0
    of the image is the top of the view.
    """

    def __init__(self, width=960, height=540, view="fit", background=(1.0, 1.0, 1.0),
                 edge_color=(0.1, 0.1, 0.1), edge_width=1.0, draw_edges=True, supersample=1,
                 margin=0.05, color_by="body", vmin=None, vmax=None, cmap="viridis",
                 colorbar=True, stamp=True, follow=None, follow_width=None, text_size=None,
                 cracks=False, crack_color=(1.0, 0.0, 0.0), crack_width=2.0):
        self.width = _check_pos_int("width", width)
        self.height = _check_pos_int("height", height)
        self.supersample = _check_pos_int("supersample", supersample, 1, 4)
        self.background = _check_color("background", background)
        self.edge_color = _check_color("edge_color", edge_color)
        self.edge_width = _check_real("edge_width", edge_width, 0.0, 1.0e4)
        self.draw_edges = bool(draw_edges)
        self.margin = _check_real("margin", margin, 0.0, 10.0)
        self.view = _check_view(view)
        self.last_view = None  # (xmin, xmax, ymin, ymax) of the last rendered, letter-boxed view
        self._img = None      # (s*H, s*W) vec3 f32 working image
        self._out = None      # (H, W, 3) u8 image
        self._img_key = None
        self._cache = {}      # name -> ndarray converted from NumPy input (reused when shape fits)
        self._small = {}      # (purpose, dtype) -> tiny ndarray (bbox, view params)
        self.color_by = _check_color_by(color_by)
        self.vmin, self.vmax = _check_range(vmin, vmax)
        if cmap not in COLORMAPS:
            raise ValueError(f"cmap must be one of {sorted(COLORMAPS)}, got {cmap!r}")
        self.cmap = cmap
        self.colorbar = bool(colorbar)
        self.stamp = bool(stamp)
        self.follow = follow
        self.follow_width = None if follow_width is None else _check_real("follow_width", follow_width, 0.0)
        if self.follow_width is not None and self.follow_width <= 0.0:
            raise ValueError(f"follow_width must be > 0 m, got {follow_width}")
        self.text_size = None if text_size is None else _check_pos_int("text_size", text_size, 4, 1000)
        if not isinstance(cracks, (bool, np.bool_)):
            raise ValueError(f"cracks must be True or False, got {cracks!r}")
        self.cracks = bool(cracks)
        self.crack_color = _check_color("crack_color", crack_color)
        self.crack_width = _check_real("crack_width", crack_width, 1.0, 100.0)
        self._last_scalars = None  # (m,) float64 per-triangle values of the last scalar frame
        self._last_scal_nd = None  # ... or the ndarray holding them (converted on access)
        self._sprites = {}         # (text, anchor, font px) -> label sprite (see _label_sprite)
        self._grad = {}            # (rows, cmap) -> colour-bar gradient (rows, 3) u8
        self._u8_frame = None      # ((H, W), (H, W, 3) u8 image on the device, supersample 1)
        self._np_small = {}        # purpose -> small NumPy array handed to kernels (no copies)
        self.last_range = None    # (vmin, vmax) used by the last scalar frame
        self._sim_ref = None      # weakref to the simulation whose constant arrays are cached
        self._sim_data = {}       # per-simulation constants: initial positions, category colours
        self._font = None

    @property
    def last_scalars(self):
        """(m,) float64 per-triangle values of the last scalar frame (None otherwise)."""
        if self._last_scalars is None and self._last_scal_nd is not None:
            self._last_scalars = self._last_scal_nd.to_numpy().astype(np.float64)
        return self._last_scalars

    @last_scalars.setter
    def last_scalars(self, value):
        self._last_scalars = value
        self._last_scal_nd = None

    # -- configuration ---------------------------------------------------------------------
    def set_view(self, view="fit", margin=None):
        """Switch to ``"fit"`` or to a fixed world box ``(xmin, xmax, ymin, ymax)``."""
        self.view = _check_view(view)
        if margin is not None:
            self.margin = _check_real("margin", margin, 0.0, 10.0)

    def set_range(self, vmin=None, vmax=None):
        """Colour range of the scalar modes (``None`` = automatic per frame)."""
        self.vmin, self.vmax = _check_range(vmin, vmax)

    def resize(self, width, height):
        self.width = _check_pos_int("width", width)
        self.height = _check_pos_int("height", height)

    # -- buffers -----------------------------------------------------------------------------
    def _buffers(self):
        s = self.supersample
        key = (self.width, self.height, s)
        if self._img_key != key:
            self._img = ti.ndarray(dtype=_vec3f, shape=(self.height * s, self.width * s))
            self._out = ti.ndarray(dtype=ti.u8, shape=(self.height, self.width, 3))
            self._img_key = key
        return self._img, self._out

    def _small_nd(self, purpose, dtype, size):
        key = (purpose, str(dtype))
        arr = self._small.get(key)
        if arr is None:
            arr = ti.ndarray(dtype=dtype, shape=(size,))
            self._small[key] = arr
        return arr

    def _from_numpy(self, name, a, ncomp, np_dtype, ti_dtype):
        arr = np.asarray(a)
        if arr.ndim == 1 and arr.size == 0:
            arr = arr.reshape(0, ncomp)
        if arr.ndim != 2 or arr.shape[1] != ncomp:
            raise ValueError(f"{name} must have shape (k, {ncomp}), got {arr.shape}")
        arr = np.ascontiguousarray(arr, dtype=np_dtype)
        k = arr.shape[0]
        if k == 0:
            return None  # Taichi has no empty ndarrays: callers treat None as "nothing"
        nd = self._cache.get(name)
        if nd is None or nd.shape != (k,) or nd.dtype != ti_dtype:
            nd = ti.ndarray(dtype=ti.types.vector(ncomp, ti_dtype), shape=(k,))
            self._cache[name] = nd
        nd.from_numpy(arr)
        return nd

    def _prepare(self, node_x, tri_nodes, tri_color):
        real_ti, real_np = backend.real_ti(), backend.real_np()
        # nodes
        if _is_ndarray(node_x) and getattr(node_x, "n", None) == 2 and len(node_x.shape) == 1:
            x_nd = node_x
        else:
            x_nd = self._from_numpy("node_x", _to_np(node_x), 2, real_np, real_ti)
        # triangles
        if _is_ndarray(tri_nodes) and getattr(tri_nodes, "n", None) == 3 and len(tri_nodes.shape) == 1:
            t_nd = tri_nodes
        else:
            t_np = np.asarray(_to_np(tri_nodes))
            if t_np.size and not np.issubdtype(t_np.dtype, np.integer):
                raise ValueError(f"tri_nodes must hold integers, got dtype {t_np.dtype}")
            t_nd = self._from_numpy("tri_nodes", t_np, 3, np.int32, ti.i32)
        m = 0 if t_nd is None else t_nd.shape[0]
        if m == 0:
            return x_nd, None, None
        # colours
        if _is_ndarray(tri_color) and getattr(tri_color, "n", None) == 3 and len(tri_color.shape) == 1:
            c_nd = tri_color
        else:
            if tri_color is None:
                c_np = np.full((m, 3), 0.7, np.float32)
            else:
                c_np = np.asarray(_to_np(tri_color))
                if c_np.dtype == np.uint8:
                    c_np = c_np.astype(np.float32) / 255.0
                if c_np.shape == (3,):
                    c_np = np.broadcast_to(c_np.astype(np.float32), (m, 3))
            c_nd = self._from_numpy("tri_color", c_np, 3, np.float32, ti.f32)
        if c_nd is None or c_nd.shape[0] != m:
            raise ValueError(f"tri_color has {0 if c_nd is None else c_nd.shape[0]} entries but there are {m} triangles")
        return x_nd, t_nd, c_nd

    # -- view ------------------------------------------------------------------------------
    def _world_box(self, x_nd):
        """World box to show (before letter-boxing)."""
        if self.view != "fit":
            return self.view
        if x_nd is None:
            return self.last_view if self.last_view is not None else (-1.0, 1.0, -1.0, 1.0)
        bb = self._np_small.get("bbox")
        if bb is None:
            bb = self._np_small["bbox"] = np.zeros(5, dtype=np.float64)
        _bbox_kernel(x_nd, bb)
        xmin, xmax, ymin, ymax = (float(v) for v in bb[:4])
        if bb[4] != 0.0 or not all(math.isfinite(v) for v in (xmin, xmax, ymin, ymax)):
            return self.last_view if self.last_view is not None else (-1.0, 1.0, -1.0, 1.0)
        ext = max(xmax - xmin, ymax - ymin)
        if ext <= 0.0:
            ext = max(abs(xmin), abs(ymin), 1.0) * 1e-3  # a single point: show a small box
        pad = self.margin * ext
        cx, cy = 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)
        hw = 0.5 * (xmax - xmin) + pad
        hh = 0.5 * (ymax - ymin) + pad
        if hw <= 0.0:  # nodes on a vertical line and no margin
            hw = 0.5 * ext
        if hh <= 0.0:
            hh = 0.5 * ext
        return (cx - hw, cx + hw, cy - hh, cy + hh)

    def _letterbox(self, box, reserve_right=0):
        """Fit ``box`` into the image minus ``reserve_right`` pixel columns at the right (kept
        for the colour bar); returns the full-image world box and the pixels per metre."""
        xmin, xmax, ymin, ymax = box
        bw, bh = xmax - xmin, ymax - ymin
        w_eff = max(1, self.width - int(reserve_right))
        scale = min(w_eff / bw, self.height / bh)  # output pixels per metre
        cx, cy = 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)
        left = cx - 0.5 * w_eff / scale
        hh = 0.5 * self.height / scale
        return (left, left + self.width / scale, cy - hh, cy + hh), scale

    def world_to_pixel(self, xy):
        """Map world points (k, 2) to continuous output-pixel coordinates (col, row) using the
        view of the last :meth:`render` call."""
        if self.last_view is None:
            raise RuntimeError("world_to_pixel: nothing rendered yet")
        xmin, xmax, ymin, ymax = self.last_view
        scale = self.width / (xmax - xmin)
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        return np.stack([(xy[:, 0] - xmin) * scale, (ymax - xy[:, 1]) * scale], axis=1)

    # -- drawing ---------------------------------------------------------------------------
    def render(self, node_x, tri_nodes, tri_color=None) -> np.ndarray:
        """Rasterise the mesh and return a new ``(height, width, 3)`` uint8 array."""
        backend.ensure_init()
        x_nd, t_nd, c_nd = self._prepare(node_x, tri_nodes, tri_color)
        return self._draw(x_nd, t_nd, c_nd, self._world_box(x_nd))

    def _u8_image(self):
        """The (H, W, 3) u8 image on the device (supersample 1), reused while the size holds."""
        key = (self.height, self.width)
        if self._u8_frame is None or self._u8_frame[0] != key:
            self._u8_frame = (key, ti.ndarray(dtype=ti.u8, shape=(self.height, self.width, 3)))
        return self._u8_frame[1]

    def _cmap_nd(self, name):
        """The colour map table (positions, RGB) as ndarrays of the real dtype, uploaded once."""
        real_ti, real_np = backend.real_ti(), backend.real_np()
        key = ("cmap", name, str(real_ti))
        tab = self._small.get(key)
        if tab is None:
            pos, rgb = COLORMAPS[name]
            cpos = ti.ndarray(dtype=real_ti, shape=(len(pos),))
            cpos.from_numpy(np.ascontiguousarray(pos, dtype=real_np))
            ctab = ti.ndarray(dtype=real_ti, shape=(len(pos), 3))
            ctab.from_numpy(np.ascontiguousarray(rgb, dtype=real_np))
            tab = self._small[key] = (cpos, ctab)
        return tab

    def _draw(self, x_nd, t_nd, c_nd, box, reserve_right=0, scal=None, rng=None, overlays=None) -> np.ndarray:
        """Rasterise; colours are c_nd, or (supersample 1 only) the scalars scal mapped through
        the colour map over rng = (vmin, vmax) inside the raster kernel; then ``overlays`` =
        (simulation, fluid range or None): its cracks (when ``cracks``) and its fluid network
        (:meth:`_draw_overlays`).  The image is drawn on the device and is the one array copied
        to the host."""
        s = self.supersample
        view, scale = self._letterbox(box, reserve_right)
        self.last_view = view
        if s == 1:  # one launch straight into a u8 image: no float image
            img = self._u8_image()
            _clear_u8_kernel(img, ti.Vector(self.background, dt=ti.f32))
            if x_nd is not None and t_nd is not None:
                vmin, vmax = rng if rng is not None else (0.0, 1.0)
                params = np.array([view[0], view[3], scale, vmin, vmax], dtype=_np_dtype(x_nd.dtype))
                cpos, ctab = self._cmap_nd(self.cmap)
                use_scal = int(scal is not None and rng is not None)
                if scal is None:
                    scal = self._small_nd("dummy_scal", backend.real_ti(), 1)
                if c_nd is None:
                    c_nd = self._small_nd("dummy_col", ti.types.vector(3, ti.f32), 1)
                draw = self.draw_edges and self.edge_width > 0.0
                _raster_u8_kernel(x_nd, t_nd, c_nd, scal, use_scal,
                                  cpos, ctab, params, img, ti.Vector(self.edge_color, dt=ti.f32),
                                  float(0.5 * self.edge_width), int(draw))
            self._draw_overlays(overlays, img)
            return img.to_numpy()
        img, out = self._buffers()

        _clear_kernel(img, ti.Vector(self.background, dt=ti.f32))
        if x_nd is not None and t_nd is not None:
            n = x_nd.shape[0]
            params = self._small_nd("params", x_nd.dtype, 3)
            params.from_numpy(np.array([view[0], view[3], scale * s], dtype=_np_dtype(x_nd.dtype)))
            pkey = "pixels"
            p_nd = self._cache.get(pkey)
            if p_nd is None or p_nd.shape != (n,):
                p_nd = ti.ndarray(dtype=ti.types.vector(2, ti.f32), shape=(n,))
                self._cache[pkey] = p_nd
            _to_pixels_kernel(x_nd, params, p_nd)
            draw = self.draw_edges and self.edge_width > 0.0
            _raster_kernel(p_nd, t_nd, c_nd, img, ti.Vector(self.edge_color, dt=ti.f32),
                           float(0.5 * self.edge_width * s), int(draw))
        _resolve_kernel(img, out, s)
        self._draw_overlays(overlays, out)
        return out.to_numpy()

    __call__ = render

    # -- simulations -----------------------------------------------------------------------
    def _sim_consts(self, sim):
        """Constant per-simulation data (converted once per simulation, not per frame)."""
        ref = self._sim_ref() if self._sim_ref is not None else None
        if ref is not sim:
            self._sim_ref = weakref.ref(sim)
            self._sim_data = {}
        return self._sim_data

    def tri_scalars(self, sim, color_by=None) -> np.ndarray:
        """The per-triangle scalar of a scalar colour mode, (m,) float64 in the mode's unit
        (m/s, m or Pa; NaN for inverted triangles), computed by a Taichi kernel."""
        mode = _check_color_by(self.color_by if color_by is None else color_by)
        kid = _plane_mode(COLOR_MODES[mode][0], sim)
        if kid is None or kid == -3:
            raise ValueError(f"tri_scalars: color_by={mode!r} is not a scalar mode")
        if kid == -2:
            raise ValueError("tri_scalars: 'fluid_pressure' colours the fracture network, not the triangles "
                             "(sim.fluid.pressures() gives the network's pressures)")
        if kid == -4:
            return _tri_temperatures(sim)
        if kid < 0:      # "damage"
            return np.asarray(sim.cracks.tri_damage(), dtype=np.float64)
        if _host_stress(kid, sim):
            return _host_stress_scalars(sim, kid)
        backend.ensure_init()
        consts = self._sim_consts(sim)
        x0 = self._rest_positions(sim, consts)
        out = consts.get("scalars")
        if out is None:
            out = ti.ndarray(dtype=sim.state.node_x.dtype, shape=(sim.model.tri_count,))
            consts["scalars"] = out
        _tri_scalar_kernel(sim.state.node_x, sim.state.node_v, x0, sim.model.tri_nodes, sim.model.tri_rest_inv, sim.model.tri_mat,
                           sim.model.mat_lame, int(kid), out)
        return out.to_numpy().astype(np.float64)

    @staticmethod
    def _rest_positions(sim, consts):
        """The simulation's rest positions X [m] as an ndarray, cached per simulation."""
        x0 = consts.get("x0")
        if x0 is None:
            x0 = ti.Vector.ndarray(2, sim.state.node_x.dtype, shape=(sim.model.node_count,))
            x0.from_numpy(np.ascontiguousarray(sim.model.node_rest, dtype=_np_dtype(sim.state.node_x.dtype)))
            consts["x0"] = x0
        return x0

    def _drawn_triangles(self, sim, consts):
        """The simulation's triangles, those removed by an excavation given index −1 (the raster
        kernels skip them), written on the device from ``state.tri_intact`` every frame."""
        intact = getattr(getattr(sim, "state", None), "tri_intact", None)
        if intact is None:
            return sim.model.tri_nodes
        nd = consts.get("drawn_triangles")
        if nd is None:
            nd = consts["drawn_triangles"] = ti.Vector.ndarray(3, ti.i32, shape=(sim.model.tri_count,))
        _drawn_tris_kernel(sim.model.tri_nodes, intact, nd)
        return nd

    @staticmethod
    def _joints_by_triangle(sim, consts):
        """Each triangle's joints as (start (m + 1,), joints) i32 ndarrays: the joints of triangle
        t are joints[start[t]:start[t + 1]] (constant per simulation, built once)."""
        tab = consts.get("joints_by_triangle")
        if tab is None:
            jt = np.asarray(sim.model.joint_tris_np, dtype=np.int64).reshape(-1, 2)
            tri_of = jt.reshape(-1)
            order = np.argsort(tri_of, kind="stable")
            counts = np.bincount(tri_of, minlength=sim.model.tri_count)
            start_np = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
            joints_np = (order // 2).astype(np.int32) if len(order) else np.zeros(1, np.int32)
            start = ti.ndarray(dtype=ti.i32, shape=(sim.model.tri_count + 1,))
            start.from_numpy(start_np)
            joints = ti.ndarray(dtype=ti.i32, shape=(len(joints_np),))
            joints.from_numpy(joints_np)
            tab = consts["joints_by_triangle"] = (start, joints)
        return tab

    def _frame_scalars(self, sim, kid):
        """Per-triangle scalars of mode id kid into a per-simulation ndarray (kept on the
        device) and their finite [min, max, count] in a small NumPy array."""
        consts = self._sim_consts(sim)
        x0 = self._rest_positions(sim, consts)
        scal = consts.get("frame_scalars")
        if scal is None:
            scal = consts["frame_scalars"] = ti.ndarray(dtype=sim.state.node_x.dtype, shape=(sim.model.tri_count,))
        info = self._np_small.get("range")
        if info is None:
            info = self._np_small["range"] = np.zeros(3, dtype=np.float64)
        if kid == -4:    # "temperature": the mean of the nodes' temperatures of each triangle
            t = _tri_temperatures(sim)
            scal.from_numpy(np.ascontiguousarray(t, dtype=_np_dtype(sim.state.node_x.dtype)))
            info[:] = (float(t.min()), float(t.max()), len(t))
            return scal, info
        if kid < 0:      # "damage": per-triangle joint damage (as sim.cracks.tri_damage()), fixed range [0, 1]
            if sim.model.fracture and sim.model.joint_count:
                start, joints = self._joints_by_triangle(sim, consts)
                _tri_damage_kernel(start, joints, sim.state.joint_dmax, sim.state.joint_state, scal)
            else:
                scal.fill(0)
            info[:] = (0.0, 1.0, sim.model.tri_count)
            return scal, info
        if _host_stress(kid, sim):
            vals = _host_stress_scalars(sim, kid)
            scal.from_numpy(vals.astype(_np_dtype(scal.dtype)))
            fin = vals[np.isfinite(vals)]
            info[:] = (fin.min(), fin.max(), len(fin)) if len(fin) else (0.0, 0.0, 0)
            return scal, info
        _sim_scalar_kernel(sim.state.node_x, sim.state.node_v, x0, sim.model.tri_nodes, sim.model.tri_rest_inv, sim.model.tri_mat,
                           sim.model.mat_lame, int(kid), scal, info)
        return scal, info

    def _follow_box(self, sim):
        body = self.follow
        if isinstance(body, numbers.Integral) and not isinstance(body, bool):
            body = sim.bodies[int(body)]
        if not any(b is body for b in sim.bodies):
            raise ValueError(f"render_sim: follow={self.follow!r} is not a body of this simulation")
        consts = self._sim_consts(sim)
        width = self.follow_width
        if width is None:
            pts = body.mesh.points
            width = 4.0 * max(float(np.ptp(pts[:, 0])), float(np.ptp(pts[:, 1])), 1e-12)
        c = self._small_nd("centroid", sim.state.node_x.dtype, 3)
        _centroid_kernel(sim.state.node_x, body.nodes.start, body.nodes.stop, c)
        cx, cy, cnt = (float(v) for v in c.to_numpy())
        if cnt <= 0 or not (math.isfinite(cx) and math.isfinite(cy)):
            if self.last_view is not None:
                return (self.last_view[0], self.last_view[1], self.last_view[2], self.last_view[3])
            cx, cy = (float(v) for v in body.mesh.centroid)
        consts["follow_centre"] = (cx, cy)
        hh = 0.5 * width * self.height / self.width
        return (cx - 0.5 * width, cx + 0.5 * width, cy - hh, cy + hh)

    def _draw_overlays(self, overlays, img) -> None:
        """Into the u8 image on the device: the cracks of the simulation (when ``cracks``), then
        its fluid network coloured by pressure (when a fluid range is given)."""
        if overlays is None:
            return
        sim, fluid_rng = overlays
        if self.cracks:
            self._draw_cracks(sim, img)
        if fluid_rng is not None:
            self._draw_fluid(sim, img, fluid_rng)

    def _draw_cracks(self, sim, img) -> None:
        """The crack overlay (see ``cracks``) into the u8 image, in the view of the last frame."""
        nj = int(sim.model.joint_count) if sim.model.fracture else 0
        if nj == 0:
            return
        xmin, xmax, _, ymax = self.last_view
        params = np.array([xmin, ymax, self.width / (xmax - xmin)], dtype=_np_dtype(sim.state.node_x.dtype))
        _cracks_u8_kernel(sim.state.node_x, sim.model.joint_nodes, sim.state.joint_state, nj, params, img,
                          ti.Vector(self.crack_color, dt=ti.f32), float(0.5 * self.crack_width))

    def _fluid_range(self, sim):
        """(vmin, vmax) [Pa] of the "fluid_pressure" mode: the renderer's, or the range of the
        pressures of the network nodes that conducting edges reach ((0, 1) while none)."""
        if not getattr(sim.model, "fluid", False):
            raise ValueError("render_sim: color_by='fluid_pressure' needs a scene with a fluid (scene.set_fluid)")
        nv = sim.state.fluid_node_val.to_numpy()[: sim.model.fluid_node_count]
        p = nv[nv[:, 1] > 0.0, 2].astype(np.float64)
        p = p[np.isfinite(p)]
        vmin, vmax = self.vmin, self.vmax
        if vmin is None:
            vmin = float(p.min()) if len(p) else 0.0
            if vmax is not None and vmin > vmax:
                vmin = vmax
        if vmax is None:
            vmax = float(p.max()) if len(p) else max(1.0, vmin)
            if vmax < vmin:
                vmax = vmin
        return vmin, vmax

    def _draw_fluid(self, sim, img, rng) -> None:
        """The fluid network coloured by pressure over rng = (vmin, vmax) into the u8 image, in
        the view of the last frame (see ``color_by="fluid_pressure"``)."""
        ne = int(sim.model.fluid_edge_count)
        if ne == 0:
            return
        xmin, xmax, _, ymax = self.last_view
        params = np.array([xmin, ymax, self.width / (xmax - xmin), rng[0], rng[1]],
                          dtype=_np_dtype(sim.state.node_x.dtype))
        cpos, ctab = self._cmap_nd(self.cmap)
        _fluid_u8_kernel(sim.state.node_x, sim.model.fluid_edge, sim.state.fluid_edge_val, sim.state.fluid_node_val,
                         ne, cpos, ctab, params, img, float(0.5 * self.crack_width))

    def render_sim(self, sim, color_by=None) -> np.ndarray:
        """Draw a :class:`~taichi_fdem.sim.simulation.Simulation`; returns ``(height, width, 3)`` uint8.

        ``color_by`` overrides the renderer's mode for this frame (see the class docstring
        for the modes, the colour range, colour bar, stamp and camera options).
        """
        backend.ensure_init()
        mode = _check_color_by(self.color_by if color_by is None else color_by)
        consts = self._sim_consts(sim)
        kid, title = COLOR_MODES[mode]
        bar = None
        fluid_rng = None
        if kid is None or kid in (-2, -3):
            key = "colors_" + mode
            colors = consts.get(key)
            if colors is None:
                if kid == -2:
                    cols = np.broadcast_to(np.asarray(SOLID_UNDER_FLUID, np.float32), (sim.model.tri_count, 3))
                elif kid == -3:
                    if not getattr(sim.model, "bedding", False):
                        raise ValueError("render_sim: color_by='bedding' needs a scene with a bedded material "
                                         "(fdem.Material(..., bedding=fdem.Bedding(...)))")
                    cols = bedding_colors(sim.model.tri_bedding)
                else:
                    cols = body_colors(sim.model.tri_body_np if mode == "body" else sim.model.tri_mat_np)
                colors = ti.Vector.ndarray(3, ti.f32, shape=(sim.model.tri_count,))
                colors.from_numpy(np.ascontiguousarray(cols, dtype=np.float32))
                consts[key] = colors
            c_nd = colors
            self.last_scalars = None
            self.last_range = None
            if kid == -2:
                fluid_rng = self.last_range = self._fluid_range(sim)
                if self.colorbar:
                    bar = (fluid_rng[0], fluid_rng[1], title)
            kid = None          # the triangles in one colour each
        else:
            # scalars and their finite range in one launch; nothing per-triangle leaves the device
            scal, info = self._frame_scalars(sim, _plane_mode(kid, sim))
            finite_any = info[2] > 0
            vmin, vmax = self.vmin, self.vmax
            if vmin is None:
                vmin = float(info[0]) if finite_any else 0.0
                if vmax is not None and vmin > vmax:
                    vmin = vmax
            if vmax is None:
                vmax = float(info[1]) if finite_any else 1.0
                if vmax < vmin:
                    vmax = vmin
            if self.supersample == 1:
                c_nd = None     # coloured inside the raster kernel
            else:
                c_nd = consts.get("scalar_colors")
                if c_nd is None:
                    c_nd = ti.Vector.ndarray(3, ti.f32, shape=(sim.model.tri_count,))
                    consts["scalar_colors"] = c_nd
                cpos, ctab = self._cmap_nd(self.cmap)
                _colormap_kernel(scal, np.array([vmin, vmax], dtype=_np_dtype(scal.dtype)), cpos, ctab, c_nd)
            self._last_scalars = None
            self._last_scal_nd = scal
            self.last_range = (vmin, vmax)
            if self.colorbar:
                bar = (vmin, vmax, title)
        if self.follow is not None:
            box = self._follow_box(sim)
        else:
            box = self._world_box(sim.state.node_x)
        layout = self._bar_layout() if bar is not None else None
        img = self._draw(sim.state.node_x, self._drawn_triangles(sim, consts), c_nd, box,
                         layout["reserve"] if layout else 0,
                         scal=None if kid is None else scal, rng=None if kid is None else (vmin, vmax),
                         overlays=(sim, fluid_rng))
        stamp = f"t = {sim.time:.4g} s  step {sim.step_count}" if self.stamp else None
        if bar is not None or stamp is not None:
            img = self._overlay(img, bar, layout, stamp)
        return img

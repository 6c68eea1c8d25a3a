"""Simulation: the built model (arrays allocated once), its state, and the stepping loop."""
from __future__ import annotations

import math
import sys
import time as _time
import warnings
from contextlib import nullcontext

import numpy as np
import taichi as ti

from . import backend, slots, stepping
from .diagnostics import energy_terms, overlap_areas
from .slots import (A_BOUNDARY, A_CDAMPING, A_FRICTION, I_COUPLES, I_DETECTIONS, I_INVERTED,
                       I_NONFINITE, I_OVERFLOW, I_SPEED, I_BROKEN, R_BIG, R_BUFFER, R_DACC, R_DT, R_GX, R_GY, R_VLIMIT, R_VMAX)

# Execution strategy.  Measured on the 2-core CPU (benchmarks/pile.py): the serial many-step
# kernel beats one-launch-per-step parallel loops at every size from 1k to 300k triangles,
# because parallel loops pay for f64 atomic scatter (CAS loops on x86) and launch overhead
# more than the second core gives back.  "auto" is therefore serial on the CPU and parallel
# on GPU back ends (untested: no GPU here).
CONTACT_LIMIT_FACTOR = 0.4      # stable contact / joint step = 0.4 × the book's h√(ρ/p) (measured)
SERIAL_MAX_STEPS = 2000          # at most this many steps per serial launch
SERIAL_TRI_STEPS = 2_000_000     # ~50 ms of work per serial launch: responsive progress and Ctrl-C


class SimulationError(RuntimeError):
    """The run became unstable or invalid; carries a diagnosis.

    Attributes: ``cause`` (short text), ``step``, ``time`` [s], ``suggested_dt`` [s].
    """

    def __init__(self, cause: str, step: int, time: float, suggested_dt: float, detail: str = ""):
        self.cause, self.step, self.time, self.suggested_dt = cause, step, time, suggested_dt
        msg = (f"simulation stopped at step {step} (t = {time:.6g} s): {cause}. {detail}"
               f" Suggested time step: {suggested_dt:.3g} s or smaller (build(dt=...) or a smaller safety).")
        super().__init__(msg)


def _ndarray(data: np.ndarray, dtype, vec: int | None = None, mat: tuple | None = None):
    """A Taichi ndarray holding ``data`` (shape (n,), (n, vec) or (n, *mat))."""
    data = np.ascontiguousarray(data)
    if vec is not None:
        arr = ti.Vector.ndarray(vec, dtype, shape=data.shape[:-1])
    elif mat is not None:
        arr = ti.Matrix.ndarray(mat[0], mat[1], dtype, shape=data.shape[:-2])
    else:
        arr = ti.ndarray(dtype, shape=data.shape)
    arr.from_numpy(data)
    return arr


def _next_pow2(n: int) -> int:
    return 1 << max(4, int(math.ceil(math.log2(max(n, 1)))))


class Simulation:
    """A built scene: Taichi arrays, the time step and the state.  Create with :meth:`Scene.build`.

    Units: SI.  Positions [m], velocities [m/s], masses [kg], energies [J] (the solver works per
    unit thickness; reported masses and energies are multiplied by the scene's thickness).
    """

    def __init__(self, scene, dt=None, safety=0.2, force_dt=False, buffer=None, strategy="auto",
                 check_overlap=True, speed_limit=None):
        backend.ensure_init()
        if not scene.bodies:
            raise ValueError("Scene.build: the scene has no bodies; add one with scene.add_body(...)")
        if not (0.0 < float(safety) <= 1.0):
            raise ValueError(f"Scene.build: safety must be in (0, 1], got {safety}")
        if strategy not in ("auto", "serial", "parallel"):
            raise ValueError(f"Scene.build: strategy must be 'auto', 'serial' or 'parallel', got {strategy!r}")
        self.scene = scene
        self.bodies = list(scene.bodies)
        self.thickness = scene.thickness
        real = backend.real_np()
        rti = backend.real_ti()
        self._real, self._rti = real, rti

        # ---- nodes and triangles ---------------------------------------------------------------
        X = np.concatenate([b.mesh.points for b in self.bodies]).astype(np.float64)
        tris = np.concatenate([b.mesh.triangles + b.node_start for b in self.bodies]).astype(np.int32)
        tri_body = np.concatenate([np.full(b.mesh.triangle_count, b.index, np.int32) for b in self.bodies])
        materials, mat_index = [], {}
        for b in self.bodies:
            if id(b.material) not in mat_index:
                mat_index[id(b.material)] = len(materials)
                materials.append(b.material)
        self.materials = materials
        tri_mat = np.concatenate([np.full(b.mesh.triangle_count, mat_index[id(b.material)], np.int32)
                                  for b in self.bodies])
        self.node_count, self.tri_count = len(X), len(tris)
        self._X = X
        self._tri_nodes_np = tris
        self._tri_body_np = tri_body
        self._tri_mat_np = tri_mat

        V = np.zeros_like(X)
        for b in self.bodies:
            sl = b.nodes
            c = b.mesh.centroid
            r = X[sl] - c
            V[sl] = b.velocity + b.angular_velocity * np.stack([-r[:, 1], r[:, 0]], axis=1)

        x0, x1, x2 = X[tris[:, 0]], X[tris[:, 1]], X[tris[:, 2]]
        F0 = np.stack([x1 - x0, x2 - x0], axis=2)          # columns: edges 0→1, 0→2
        area0 = 0.5 * np.linalg.det(F0)
        rest_inv = np.linalg.inv(F0)
        rho = np.array([m.density for m in materials])[tri_mat]
        mass = np.zeros(len(X))
        np.add.at(mass, tris.ravel(), np.repeat(rho * area0 / 3.0, 3))
        self._mass_np = mass
        edge_len = np.stack([np.linalg.norm(x1 - x0, axis=1), np.linalg.norm(x2 - x1, axis=1),
                             np.linalg.norm(x0 - x2, axis=1)], axis=1)
        altitude = 2.0 * area0 / edge_len.max(axis=1)       # smallest altitude of each triangle

        # ---- boundary conditions ---------------------------------------------------------------
        free = np.ones_like(X)
        vbc = np.zeros_like(X)
        body_flags = np.zeros(len(self.bodies), np.int32)
        for b in self.bodies:
            if b.fixed or b.prescribed_velocity is not None:
                free[b.nodes] = 0.0
                vbc[b.nodes] = 0.0 if b.fixed else b.prescribed_velocity
            if b.self_contact:
                body_flags[b.index] |= 1
        for k, con in enumerate(scene._constraints):
            sel = np.asarray(con.where(X[:, 0].copy(), X[:, 1].copy()), dtype=bool)
            if sel.shape != (len(X),):
                raise ValueError(f"Scene.fix_nodes #{k}: where(x, y) must return a boolean array of shape ({len(X)},)")
            if con.body is not None:
                mask = np.zeros(len(X), bool)
                mask[con.body.nodes] = True
                sel &= mask
            if not sel.any():
                raise ValueError(f"Scene.fix_nodes #{k}: the predicate selects no node")
            for comp, v in enumerate(con.velocity):
                if v is not None:
                    free[sel, comp] = 0.0
                    vbc[sel, comp] = v
        for b in self.bodies:
            if np.all(free[b.nodes] == 0.0) and np.all(vbc[b.nodes] == 0.0):
                body_flags[b.index] |= 2
        V = np.where(free == 0.0, vbc, V)
        self.has_bc = bool(np.any(free == 0.0))
        self.has_bc_work = bool(np.any((free == 0.0) & (vbc != 0.0)))

        # ---- materials and pair table ------------------------------------------------------------
        mat_mu = np.array([m.shear_modulus for m in materials])
        mat_lam = np.array([m.lambda_y(scene.plane) for m in materials])
        M = len(materials)
        pair = np.zeros((M, M, 4))
        for i, a in enumerate(materials):
            for j, b in enumerate(materials):
                p = min(a.contact_penalty, b.contact_penalty)
                kt = min(a.contact_tangential_penalty, b.contact_tangential_penalty)
                mu = min(a.friction, b.friction)
                xi = min(a.contact_damping, b.contact_damping)
                ov = scene._interactions.get((id(a), id(b)), {})
                p = ov.get("penalty", p)
                kt = ov.get("tangential_penalty", kt)
                mu = ov.get("friction", mu)
                xi = ov.get("contact_damping", xi)
                pair[i, j] = (p, kt, mu, 4.0 * xi * math.sqrt(p * min(a.density, b.density)))

        # ---- joints of fracturing bodies (FDEM_SPEC §7) -----------------------------------------------
        jn, jt, jm = [], [], []
        for b in self.bodies:
            if b.fracture and len(b.joint_nodes):
                jn.append(b.joint_nodes + b.node_start)
                jt.append(b.joint_tris + b.tri_start)
                jm.append(np.full(len(b.joint_nodes), mat_index[id(b.material)], np.int32))
        self.fracture = bool(jn)
        joint_nodes = np.concatenate(jn).astype(np.int32) if jn else np.zeros((1, 4), np.int32)
        joint_tris = np.concatenate(jt).astype(np.int32) if jt else np.zeros((1, 2), np.int32)
        joint_mat = np.concatenate(jm) if jm else np.zeros(1, np.int32)
        self.joint_count = len(joint_nodes) if self.fracture else 0
        self._joint_tris_np = joint_tris[: self.joint_count]
        mat_joint = np.zeros((M, 6))
        for i, mat in enumerate(materials):
            if mat.can_fracture:
                mat_joint[i] = mat.joint_properties()
        joint_len = np.linalg.norm(X[joint_nodes[:, 1]] - X[joint_nodes[:, 0]], axis=1)
        if self.fracture:
            for i in np.unique(joint_mat):
                mat = materials[i]
                ft, c, tanphi, gI, gII, pf = mat_joint[i]
                Lj = joint_len[joint_mat == i]
                if pf < 10.0 * mat.young:
                    warnings.warn(f"material {mat.name or i}: joint_penalty = {pf / mat.young:.3g}·E; intact joints "
                                  f"make a jointed body about {100 * mat.young / pf:.0f} % softer than E "
                                  "(FDEM_SPEC §7.9: use ≥ 10·E)", RuntimeWarning, stacklevel=4)
                dp_max = 2.0 * Lj.max() * ft / pf
                if dp_max > 0.2 * 3.0 * gI / ft:
                    warnings.warn(f"material {mat.name or i}: the opening at peak δ_p = 2 L f_t/p_f = {dp_max:.3g} m "
                                  f"is not small against the softening span 3 G_I/f_t = {3 * gI / ft:.3g} m; "
                                  "the pre-peak branch will dominate the fracture energy (raise joint_penalty or "
                                  "G_I, FDEM_SPEC §7.9)", RuntimeWarning, stacklevel=4)

        # ---- contact participation -------------------------------------------------------------
        self.contact = len(self.bodies) >= 2 or any(b.self_contact for b in self.bodies)
        ctri = []
        if self.contact:
            for b in self.bodies:
                t = np.arange(b.tri_start, b.tri_start + b.mesh.triangle_count, dtype=np.int32)
                if not b.self_contact:
                    # only triangles that touch the surface can meet another body
                    on_surface = np.zeros(b.mesh.point_count, bool)
                    on_surface[b.mesh.boundary_nodes()] = True
                    t = t[on_surface[b.mesh.triangles].any(axis=1)]
                ctri.append(t)
        ctri = np.concatenate(ctri) if ctri else np.zeros(0, np.int32)
        self.contact = self.contact and len(ctri) > 1
        used_pairs = pair[np.ix_(np.unique(tri_mat), np.unique(tri_mat))] if self.contact else pair[:0, :0]
        self.friction = bool(self.contact and np.any(used_pairs[..., 2] > 0))
        self.contact_damping = bool(self.contact and np.any(used_pairs[..., 3] > 0))
        betas = np.array([m.damping for m in materials])
        self.damping = bool(np.any(betas > 0))

        # ---- stable time step (FDEM_SPEC §6.2) ----------------------------------------------------
        moving = ~np.all(free[tris].reshape(len(tris), 6) == 0.0, axis=1)
        rho_all = np.array([m.density for m in materials])
        cp = np.array([m.p_wave_speed(scene.plane) for m in materials])[tri_mat]
        beta_t = betas[tri_mat]
        damp_factor = np.sqrt(1.0 + beta_t ** 2) - beta_t
        dt_el = np.min((altitude / cp * damp_factor)[moving]) if moving.any() else np.inf
        dt_c = np.inf
        if self.contact:
            pmax = used_pairs[..., 0:2].max()
            rho_min = min(m.density for m in materials)
            xi_max = used_pairs[..., 3].max() / (4.0 * math.sqrt(pmax * rho_min)) if self.contact_damping else 0.0
            dt_c = altitude[ctri].min() * math.sqrt(rho_min / pmax) * (math.sqrt(1 + xi_max ** 2) - xi_max)
        dt_j = np.inf
        if self.fracture:
            pf_j = mat_joint[joint_mat, 5]
            # the node mass a joint moves is set by its triangles' size: use their smallest
            # altitude, not the joint length (the length alone was optimistic on slender meshes)
            h_j = np.minimum(np.minimum(altitude[joint_tris[:, 0]], altitude[joint_tris[:, 1]]), joint_len)
            dt_j = float(np.min(h_j * np.sqrt(rho_all[joint_mat] / pf_j)))
        self.dt_joint = float(dt_j)
        self.dt_elastic, self.dt_contact = float(dt_el), float(dt_c)
        # The book's estimates (§6.2) set the default step; the stable limit used to refuse a
        # time step is tighter, by factors measured in the stress tests (docs/stability.md):
        # face-on-face contact of coarse meshes went unstable at 0.45 × h√(ρ/p) (a corner node
        # carries one triangle's mass and both passes push it), and viscous damping must be
        # rated with the element size that sets k_s (h_eq), not the smallest altitude.
        self.dt_estimate = float(min(dt_el, dt_c, dt_j))
        xi_eff = beta_t * np.sqrt(4.0 * area0 / math.sqrt(3.0)) / altitude
        dt_el_lim = np.min((altitude / cp * (np.sqrt(1.0 + xi_eff ** 2) - xi_eff))[moving]) if moving.any() else np.inf
        self.dt_limit = float(min(dt_el_lim, CONTACT_LIMIT_FACTOR * dt_c, CONTACT_LIMIT_FACTOR * dt_j))
        if not math.isfinite(self.dt_limit):
            self.dt_limit = self.dt_estimate = 1e-3   # nothing moves: any step is stable
        if dt is None:
            dt = float(safety) * self.dt_estimate
            if dt > self.dt_limit and not force_dt:
                raise ValueError(
                    f"Scene.build: safety = {safety} gives dt = {dt:.4g} s, above the stable limit "
                    f"{self.dt_limit:.4g} s; use safety <= {self.dt_limit / self.dt_estimate:.3g} "
                    "(or force_dt=True to run it anyway)")
        else:
            dt = float(dt)
            if not (math.isfinite(dt) and dt > 0):
                raise ValueError(f"Scene.build: dt must be a positive finite time step [s], got {dt}")
            if dt > self.dt_limit and not force_dt:
                raise ValueError(
                    f"Scene.build: dt = {dt:.4g} s is above the estimated stable limit {self.dt_limit:.4g} s "
                    f"(elements {self.dt_elastic:.4g} s, contact {CONTACT_LIMIT_FACTOR * self.dt_contact:.4g} s, "
                    f"joints {CONTACT_LIMIT_FACTOR * self.dt_joint:.4g} s); use dt <= {self.dt_limit:.4g} s "
                    f"(the default is {safety * self.dt_estimate:.4g} s), or force_dt=True to run it anyway")
        self.dt = dt

        if buffer is None:
            buffer = 0.25 * float(edge_len[ctri].mean()) if len(ctri) else 0.0
        buffer = float(buffer)
        if not (math.isfinite(buffer) and buffer >= 0):
            raise ValueError(f"Scene.build: buffer must be a finite length >= 0 m, got {buffer}")
        self.buffer = buffer

        if strategy == "auto":
            strategy = "serial" if backend.arch() == "cpu" else "parallel"
        self.strategy = strategy

        # ---- Taichi arrays (allocated once; dummies of size 1 for unused features) -----------------
        v2 = lambda a: _ndarray(np.asarray(a, real), rti, vec=2)
        sc = lambda a, dtype=None: _ndarray(np.asarray(a, real if dtype is None else dtype), rti if dtype is None else ti.i32)
        self.node_x = v2(X)
        self.node_v = v2(V)
        self.node_f = v2(np.zeros_like(X))
        self.node_mass = sc(mass)
        self.node_free = v2(free if self.has_bc else np.ones((1, 2)))
        self.node_vbc = v2(vbc if self.has_bc else np.zeros((1, 2)))
        self.tri_nodes = _ndarray(tris, ti.i32, vec=3)
        self.tri_rest_inv = _ndarray(rest_inv.astype(real), rti, mat=(2, 2))
        self.tri_area0 = sc(area0)
        self.tri_mat = sc(tri_mat, np.int32)
        self.tri_body = sc(tri_body, np.int32)
        self.body_flags = sc(body_flags, np.int32)
        self.mat_mu = sc(mat_mu)
        self.mat_lam = sc(mat_lam)
        if self.damping:
            E = np.array([m.young for m in materials])[tri_mat]
            h = np.sqrt(4.0 * area0 / math.sqrt(3.0))       # edge of the equilateral of equal area
            self.tri_visc = sc(2.0 * h * beta_t * np.sqrt(E * rho))
            self.tri_diss = sc(np.zeros(len(tris)))
        else:
            self.tri_visc = sc(np.zeros(1))
            self.tri_diss = sc(np.zeros(1))
        self.pair_prop = _ndarray(pair.astype(real), rti, vec=4)
        self.acc = sc(np.zeros(slots.ACC_SLOTS))
        sim_real = np.zeros(slots.REAL_SLOTS)
        sim_real[R_DT] = dt
        sim_real[R_GX], sim_real[R_GY] = scene.gravity
        sim_real[R_BUFFER] = buffer
        sim_real[R_DACC] = np.inf if self.contact else 0.0     # detect at the first step
        if speed_limit is None:
            speed_limit = 2.0 * max(m.p_wave_speed(scene.plane) for m in materials)
            speed_limit = max(speed_limit, 10.0 * float(np.abs(V).max(initial=0.0)))
        self.speed_limit = float(speed_limit)
        if not (self.speed_limit > 0):
            raise ValueError(f"Scene.build: speed_limit must be > 0 m/s, got {speed_limit}")
        sim_real[R_VLIMIT] = self.speed_limit
        sim_real[R_BIG] = 1e30
        self.sim_real = sc(sim_real)
        # joints (dummies of size 1 without fracture)
        self.joint_nodes = _ndarray(joint_nodes, ti.i32, vec=4)
        self.joint_mat = sc(joint_mat, np.int32)
        self.joint_state = sc(np.zeros(len(joint_nodes), np.int32), np.int32)
        self.joint_dmax = _ndarray(np.zeros((len(joint_nodes), 3), real), rti, vec=3)
        self.joint_fs = _ndarray(np.repeat(mat_joint[joint_mat, 1:2], 3, axis=1).astype(real), rti, vec=3)
        self.joint_work = sc(np.zeros(len(joint_nodes)))
        self.joint_break = _ndarray(np.zeros((len(joint_nodes), 3), real), rti, vec=3)
        self.joint_mode = sc(np.zeros(len(joint_nodes), np.int32), np.int32)
        self.mat_joint = _ndarray(mat_joint.astype(real), rti, vec=6)
        self.joint_g = _ndarray(np.zeros((len(joint_nodes), 4), real), rti, vec=4)
        self.sim_int = sc(np.zeros(slots.INT_SLOTS, np.int32), np.int32)
        K = len(ctri) if self.contact else 1
        self.ctri_count = K if self.contact else 0
        self.ctri = sc(ctri if self.contact else np.zeros(1, np.int32), np.int32)
        self.cen = v2(np.zeros((K, 2)))
        self.rad = sc(np.zeros(K))
        self.bucket_of = sc(np.zeros(K, np.int32), np.int32)
        self.slot = sc(np.zeros(K, np.int32), np.int32)
        H = _next_pow2(2 * K) if self.contact else 1
        self.bucket_count = sc(np.zeros(H, np.int32), np.int32)
        self.bucket_start = sc(np.zeros(H, np.int32), np.int32)
        self.sorted_k = sc(np.zeros(K, np.int32), np.int32)
        self.ccount = sc(np.zeros(K, np.int32), np.int32)
        self.cnew = sc(np.zeros(K + 1, np.int32), np.int32)
        self.cstart = sc(np.zeros(K + 1 if self.friction else 1, np.int32), np.int32)
        self.old_start = sc(np.zeros(K + 1 if self.friction else 1, np.int32), np.int32)
        self.couple_max = 0
        self._alloc_couples(2 * K + 64 if self.contact else 1)

        self.step_count = 0
        self.launches: dict[str, int] = {}
        self._energy_out = sc(np.zeros(8))
        self._stats = {"wall_steps": 0.0, "wall_detect": 0.0}
        if self.contact:
            self._detect()
            if check_overlap:
                self._warn_overlaps()

    # ------------------------------------------------------------------------------------------
    # allocation
    # ------------------------------------------------------------------------------------------
    def _alloc_couples(self, capacity: int) -> None:
        """(Re)allocate the couple buffer with room for ``capacity`` couples, keeping its content."""
        rti = self._rti
        keep = self.couple_count if self.couple_max else 0
        old = None
        if keep:
            old = (self.couple_a.to_numpy()[:keep], self.couple_b.to_numpy()[:keep],
                   self.couple_hist.to_numpy()[:6 * keep] if self.friction else None)
        self.couple_a = ti.ndarray(ti.i32, shape=capacity)
        self.couple_b = ti.ndarray(ti.i32, shape=capacity)
        hcap = 6 * capacity if self.friction else 1
        self.couple_hist = ti.ndarray(rti, shape=hcap)
        self.old_b = ti.ndarray(ti.i32, shape=capacity if self.friction else 1)
        self.old_hist = ti.ndarray(rti, shape=hcap)
        if old is not None:
            a = np.zeros(capacity, np.int32); a[:keep] = old[0]; self.couple_a.from_numpy(a)
            b = np.zeros(capacity, np.int32); b[:keep] = old[1]; self.couple_b.from_numpy(b)
            if self.friction:
                h = np.zeros(hcap, self._real); h[:6 * keep] = old[2]; self.couple_hist.from_numpy(h)
        self.couple_max = capacity

    def _launch(self, name, kernel, *args):
        self.launches[name] = self.launches.get(name, 0) + 1
        return kernel(*args)

    # ------------------------------------------------------------------------------------------
    # contact detection (parallel strategy, and at build)
    # ------------------------------------------------------------------------------------------
    def _detect(self) -> None:
        t0 = _time.perf_counter()
        found = self._launch("detect_count", stepping.detect_count, self.ctri, self.tri_nodes, self.node_x,
                             self.tri_body, self.body_flags, self.cen, self.rad, self.bucket_of, self.slot,
                             self.bucket_count, self.bucket_start, self.sorted_k, self.ccount, self.cnew,
                             self.sim_real, self.sim_int)
        if found > self.couple_max:
            self._alloc_couples(int(found * 1.5) + 64)
        self._launch("detect_fill", stepping.detect_fill, self.ctri, self.tri_nodes, self.tri_body,
                     self.body_flags, self.cen, self.rad, self.bucket_count, self.bucket_start, self.sorted_k,
                     self.cnew, self.cstart, self.couple_a, self.couple_b, self.couple_hist, self.old_start,
                     self.old_b, self.old_hist, self.sim_real, self.sim_int, self.friction)
        self._stats["wall_detect"] += _time.perf_counter() - t0

    def _warn_overlaps(self) -> None:
        n = self.couple_count
        if n == 0:
            return
        out = ti.ndarray(self._rti, shape=n)
        overlap_areas(self.node_x, self.tri_nodes, self.couple_a, self.couple_b, n, out)
        area = out.to_numpy()
        tol = 1e-9 * float(np.abs(self.tri_area0.to_numpy()).mean())
        bad = np.nonzero(area > tol)[0]
        if len(bad):
            a = self.couple_a.to_numpy()[bad]
            b = self.couple_b.to_numpy()[bad]
            pairs = sorted({tuple(sorted((int(self._tri_body_np[i]), int(self._tri_body_np[j]))))
                            for i, j in zip(a, b)})
            names = ", ".join(f"{self.bodies[i].name}–{self.bodies[j].name}" for i, j in pairs[:5])
            warnings.warn(f"bodies overlap at the start ({len(bad)} triangle pairs, total overlap "
                          f"{area[bad].sum():.3g} m²): {names}. Contact will push them apart violently.",
                          RuntimeWarning, stacklevel=4)

    # ------------------------------------------------------------------------------------------
    # stepping
    # ------------------------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated time [s]."""
        return self.step_count * self.dt

    @property
    def couple_count(self) -> int:
        """Number of contact couples in the current list."""
        return int(self.sim_int.to_numpy()[I_COUPLES]) if self.couple_max else 0

    @property
    def detection_count(self) -> int:
        """How many contact detections have run."""
        return int(self.sim_int.to_numpy()[I_DETECTIONS])

    def _flags(self):
        # contact, friction and fracture are compile-time switches (their code is large: absent
        # features are not compiled); damping, contact damping and prescribed velocities are
        # runtime switches (a branch each), which keeps the number of compiled variants small
        return (self.contact, int(self.damping), self.friction, int(self.contact_damping), int(self.has_bc),
                int(self.has_bc_work), self.fracture)

    def _joint_args(self):
        return (self.joint_nodes, self.joint_mat, self.joint_state, self.joint_dmax, self.joint_fs, self.joint_work,
                self.joint_break, self.joint_mode, self.mat_joint, self.joint_g)

    def step(self, n: int = 1) -> None:
        """Advance ``n`` time steps."""
        n = int(n)
        if n < 0:
            raise ValueError(f"step: n must be >= 0, got {n}")
        t0 = _time.perf_counter()
        if self.strategy == "serial":
            self._step_serial(n)
        else:
            self._step_parallel(n)
        self._stats["wall_steps"] += _time.perf_counter() - t0

    def _sync_detect_due(self) -> None:
        sr = self.sim_real.to_numpy()
        self._detect_due = bool(self.contact and sr[R_DACC] >= sr[R_BUFFER])

    def _step_parallel(self, n: int) -> None:
        flags = self._flags()
        self._sync_detect_due()
        for _ in range(n):
            if self.contact and self._detect_due:
                self._detect()
            code = self._launch("step_parallel", stepping.step_parallel, self.node_x, self.node_v, self.node_f,
                                self.node_mass, self.node_free, self.node_vbc, self.tri_nodes, self.tri_rest_inv,
                                self.tri_mat, self.mat_mu, self.mat_lam, self.tri_visc, self.tri_diss,
                                self.couple_a, self.couple_b, self.pair_prop, self.couple_hist, self.acc,
                                self.sim_real, self.sim_int, *self._joint_args(), *flags)
            self.step_count += 1
            self._detect_due = bool(code & 1)
            if code & 2:
                self._raise_unstable()

    _detect_due = False

    def _step_serial(self, n: int) -> None:
        flags = self._flags()
        per_launch = max(1, min(SERIAL_MAX_STEPS, SERIAL_TRI_STEPS // max(1, self.tri_count)))
        while n > 0:
            chunk = min(n, per_launch)
            done = self._launch("run_steps_serial", stepping.run_steps_serial, chunk, self.node_x, self.node_v,
                                self.node_f, self.node_mass, self.node_free, self.node_vbc, self.tri_nodes,
                                self.tri_rest_inv, self.tri_mat, self.mat_mu, self.mat_lam, self.tri_visc,
                                self.tri_diss, self.tri_body, self.body_flags, self.ctri, self.cen, self.rad,
                                self.bucket_of, self.slot, self.bucket_count, self.bucket_start, self.sorted_k,
                                self.ccount, self.cnew, self.cstart, self.couple_a, self.couple_b,
                                self.couple_hist, self.old_start, self.old_b, self.old_hist, self.pair_prop,
                                self.acc, self.sim_real, self.sim_int, *self._joint_args(), *flags)
            unstable = done >= stepping.UNSTABLE_BIT
            done &= stepping.UNSTABLE_BIT - 1
            self.step_count += done
            n -= done
            if unstable:
                self._raise_unstable()
            if done < chunk:
                si = self.sim_int.to_numpy()
                if si[I_OVERFLOW]:
                    self._alloc_couples(int(si[I_OVERFLOW] * 1.5) + 64)
                    si[I_OVERFLOW] = 0
                    self.sim_int.from_numpy(si)

    def _raise_unstable(self):
        si = self.sim_int.to_numpy()
        if si[I_NONFINITE]:
            cause = f"non-finite position or velocity at node {si[I_NONFINITE] - 1}"
        elif si[I_SPEED]:
            sr = self.sim_real.to_numpy()
            cause = (f"a node moved at {sr[R_VMAX]:.4g} m/s, above the bound {sr[R_VLIMIT]:.4g} m/s "
                     f"(speed_limit; default 2× the largest P-wave speed)")
        else:
            e = si[I_INVERTED] - 1
            cause = (f"inverted element: triangle {e} (body {self.bodies[self._tri_body_np[e]].name}) "
                     f"has non-positive area")
        raise SimulationError(cause, self.step_count, self.time, suggested_dt=0.5 * min(self.dt, self.dt_limit),
                              detail=f"Time step {self.dt:.3g} s, estimated limit {self.dt_limit:.3g} s.")


    # ---- run-time guards (issue 5): energy growth, penetration, last good state ------------------
    # Arrays that never change during a run (the model) or are scratch of one step/detection;
    # every other Taichi array of the simulation is state and is kept by _save_last_good, so
    # arrays added later (joints, ...) are kept without touching this list.
    _MODEL_ARRAYS = frozenset({
        "node_mass", "node_free", "tri_nodes", "tri_rest_inv", "tri_area0", "tri_mat", "tri_body", "body_flags",
        "mat_mu", "mat_lam", "tri_visc", "pair_prop", "ctri", "cen", "rad", "bucket_of", "slot", "bucket_count",
        "bucket_start", "sorted_k", "ccount", "cnew", "old_start", "old_b", "old_hist", "_energy_out",
        "joint_nodes", "joint_mat", "mat_joint"})
    _last_good = None

    def _state_array_names(self) -> list:
        from taichi.lang._ndarray import Ndarray
        return [k for k, v in vars(self).items() if isinstance(v, Ndarray) and k not in self._MODEL_ARRAYS]

    def _save_last_good(self) -> None:
        self._last_good = {"step_count": self.step_count,
                           "arrays": {k: getattr(self, k).to_numpy() for k in self._state_array_names()}}

    def restore_last_good(self) -> int:
        """Roll the state back to the last one that passed :meth:`run`'s checks; returns its step.

        After a :class:`SimulationError` raised inside :meth:`run`, this is the state at the
        last check before the failure (at most one chunk of steps earlier); it can then be
        inspected, rendered or saved.  RuntimeError if no run has recorded a state yet.
        """
        if self._last_good is None:
            raise RuntimeError("restore_last_good: no good state recorded yet (run() records one at its start "
                               "and after every check that passes)")
        for k, saved in self._last_good["arrays"].items():
            cur = getattr(self, k)
            if tuple(cur.shape) != saved.shape[:len(cur.shape)]:
                if saved.shape[0] < cur.shape[0]:          # the couple buffer has grown since: pad
                    pad = np.zeros((cur.shape[0],) + saved.shape[1:], saved.dtype)
                    pad[:saved.shape[0]] = saved
                    saved = pad
                else:
                    raise RuntimeError(f"restore_last_good: array {k} shrank since the saved state")
            cur.from_numpy(saved)
        self.step_count = self._last_good["step_count"]
        self._sync_detect_due()
        return self.step_count

    def _energy_scale(self, e: dict) -> float:
        return (e["kinetic"] + abs(e["strain"]) + abs(e["contact"]) + e["damping"] + e["friction"]
                + e["contact_damping"] + abs(e["boundary_work"]))

    def _guard_start(self, check_energy, energy_tol, max_penetration, check_every) -> dict:
        energy_tol = float(energy_tol)
        if not (math.isfinite(energy_tol) and energy_tol > 0):
            raise ValueError(f"run: energy_tol must be a positive fraction, got {energy_tol}")
        if max_penetration is not None:
            max_penetration = float(max_penetration)
            if not (math.isfinite(max_penetration) and max_penetration > 0):
                raise ValueError(f"run: max_penetration must be a positive fraction of the element size or None, "
                                 f"got {max_penetration}")
        auto = check_every is None
        check_every = 50 if auto else int(check_every)
        if check_every < 1:
            raise ValueError(f"run: check_every must be >= 1 step, got {check_every}")
        g = {"energy": bool(check_energy), "tol": energy_tol, "pen": max_penetration if self.contact else None,
             "every": check_every, "since": 0, "auto": auto, "step_wall": 0.0}
        if g["energy"]:
            e = self.energies()
            g["e0"], g["scale"] = e["total"], self._energy_scale(e)
            eps = 1e3 * float(np.finfo(self._real).eps)
            g["floor"] = eps * (abs(e["total"]) + abs(e["gravity"]) + g["scale"])
        self._save_last_good()
        return g

    def _guard_check(self, g: dict, steps: int, last: bool = False) -> None:
        g["since"] += steps
        if g["since"] < g["every"] and not last:
            return
        g["since"] = 0
        t_check = _time.perf_counter()
        limit_note = f"Time step {self.dt:.3g} s, estimated limit {self.dt_limit:.3g} s."
        suggested = 0.5 * min(self.dt, self.dt_limit)
        if g["energy"]:
            e = self.energies()
            total = e["total"]
            if not math.isfinite(total):
                raise SimulationError("the total energy is not finite", self.step_count, self.time, suggested,
                                      detail=limit_note)
            g["scale"] = max(g["scale"], self._energy_scale(e))
            rise = total - g["e0"]
            bound = g["tol"] * g["scale"] + g["floor"]
            if rise > bound:
                raise SimulationError(
                    f"energy growth: the total energy rose by {rise:.4g} J since the start of the run, above the "
                    f"bound {bound:.4g} J (energy_tol = {g['tol']:g} × the energy scale {g['scale']:.4g} J)",
                    self.step_count, self.time, suggested, detail=limit_note)
        if g["pen"] is not None and self.couple_count:
            from .stability import max_couple_penetration
            worst = max_couple_penetration(self)
            if worst["fraction"] > g["pen"]:
                ba, bb = (self.bodies[self._tri_body_np[t]].name for t in worst["triangles"])
                raise SimulationError(
                    f"penetration: triangles {worst['triangles'][0]} ({ba}) and {worst['triangles'][1]} ({bb}) "
                    f"overlap {worst['depth']:.4g} m deep, {worst['fraction']:.3g} × their element size, above "
                    f"max_penetration = {g['pen']:g}", self.step_count, self.time, suggested,
                    detail=limit_note + " Raise the contact penalty, or lower the impact speed or the time step.")
        self._save_last_good()
        if g["auto"] and g["step_wall"] > 0:
            # keep the checks near 10 % of the stepping time, but at least every 500 steps
            cost = _time.perf_counter() - t_check
            g["every"] = int(min(500, max(20, cost / (0.1 * g["step_wall"]))))

    def run(self, duration: float, video: str | None = None, fps: int = 30, frame_dt: float | None = None,
            renderer=None, png_dir: str | None = None, progress: bool | None = None, callback=None,
            check_energy: bool = True, energy_tol: float = 0.1, max_penetration: float | None = 0.5,
            check_every: int | None = None) -> None:
        """Advance by ``duration`` seconds of simulated time.

        Every step the kernels stop on non-finite values, inverted elements and node speeds above
        ``speed_limit``.  In addition, ``run`` checks after every chunk of steps (at least
        ``check_every`` steps; default: adaptive, as often as keeps the checks' cost near 10 % of
        the stepping time, between every 20 and every 500 steps):

        * ``check_energy``: the total energy of :meth:`energies` (which books the work of
          damping, friction and prescribed velocities) must not rise above its value at the start
          of the run by more than ``energy_tol`` × the energy scale (the largest
          kinetic + strain + contact + dissipated + |boundary work| seen so far);
        * ``max_penetration``: no contact couple may overlap by more than this fraction of its
          element size (overlap area / mean edge length, divided by the mean edge length;
          :func:`taichi_fdem.stability.couple_penetrations`); None switches the check off.

        A failed check raises :class:`SimulationError` (cause, step, time, suggested dt), like
        the per-step checks.  The state of the last check that passed (or of the start of the
        run) is kept: :meth:`restore_last_good` rolls back to it, e.g. to save it.

        Parameters
        ----------
        video : path of a video to write while running (.mp4, .gif, or a directory for PNGs).
            Frames are rendered every ``frame_dt`` seconds of simulated time (default: the run
            spread over 5 s of video at ``fps``), never every step, and streamed to the file.
        renderer : a :class:`~taichi_fdem.render.RendererImage` (default: fitted view, body colours).
        png_dir : also write every frame as PNG into this directory.
        progress : show a progress bar (default: when stdout is a terminal).
        callback : ``callback(sim)`` called after every frame interval (or chunk without video).
        """
        duration = float(duration)
        if not (math.isfinite(duration) and duration >= 0):
            raise ValueError(f"run: duration must be a finite time >= 0 s, got {duration}")
        total = int(round(duration / self.dt))
        if video is not None or callback is not None:
            if frame_dt is None:
                frame_dt = duration / max(1, 5 * fps) if video is not None else duration / 100
            per_frame = max(1, int(round(float(frame_dt) / self.dt)))
        else:
            per_frame = max(1, min(SERIAL_MAX_STEPS, SERIAL_TRI_STEPS // max(1, self.tri_count)))
        writer = None
        if video is not None:
            from .render import RendererImage, VideoWriter, body_colors
            renderer = renderer or RendererImage()
            writer = VideoWriter(video, fps=fps, png_dir=png_dir)
            if hasattr(renderer, "render_sim"):
                draw = lambda: writer.append(renderer.render_sim(self))
            else:
                colors = body_colors(self._tri_body_np)
                draw = lambda: writer.append(renderer.render(self.node_x, self.tri_nodes, colors))
        if progress is None:
            progress = sys.stdout.isatty()
        bar = None
        if progress:
            from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn
            bar = Progress(TextColumn("[bold]taichi_fdem[/]"), BarColumn(), TextColumn("t = {task.fields[t]} s"),
                           TextColumn("{task.percentage:>5.1f}%"), TimeRemainingColumn(), transient=True)
        with (writer if writer is not None else nullcontext()), (bar if bar is not None else nullcontext()):
            task = bar.add_task("run", total=total, t="0") if bar is not None else None
            if writer is not None:
                draw()
            done = 0
            guard = self._guard_start(check_energy, energy_tol, max_penetration, check_every)
            while done < total:
                k = min(per_frame, total - done)
                while k > 0:                       # checks on their own schedule inside a frame
                    j = min(k, max(1, guard["every"] - guard["since"]))
                    t_step = _time.perf_counter()
                    self.step(j)
                    guard["step_wall"] = (_time.perf_counter() - t_step) / j
                    k -= j
                    done += j
                    self._guard_check(guard, j, last=done >= total)
                if writer is not None:
                    draw()
                if callback is not None:
                    callback(self)
                if bar is not None:
                    bar.update(task, completed=done, t=f"{self.time:.4g}")

    def forces(self, contact_only: bool = False) -> np.ndarray:
        """Total nodal forces [N] at the current state (elastic + contact), without stepping.

        Shape (n, 2), multiplied by the thickness.  Gravity is not included.  The state is left
        untouched: the friction slip history and the dissipation accumulators are restored.
        """
        keep = [self.couple_hist, self.acc, self.tri_diss, self.sim_real, self.sim_int, self.joint_state,
                self.joint_dmax, self.joint_fs, self.joint_work, self.joint_break, self.joint_mode, self.joint_g]
        saved = [a.to_numpy() for a in keep]
        self.node_f.fill(0)
        if not contact_only:
            self._launch("eval_elastic", stepping.eval_elastic, self.node_x, self.node_v, self.node_f,
                         self.tri_nodes, self.tri_rest_inv, self.tri_mat, self.mat_mu, self.mat_lam,
                         self.tri_visc, self.tri_diss, self.sim_real, self.sim_int, self.damping)
            if self.fracture:
                self._launch("eval_joints", stepping.eval_joints, *self._joint_args(), self.node_x, self.node_v,
                             self.node_f, self.sim_real, self.sim_int)
        if self.contact:
            self._launch("eval_contact", stepping.eval_contact, self.couple_a, self.couple_b, self.node_x,
                         self.node_v, self.node_f, self.tri_nodes, self.tri_mat, self.pair_prop,
                         self.couple_hist, self.acc, self.sim_real, self.sim_int, self.friction,
                         self.contact_damping)
        f = self.node_f.to_numpy().astype(np.float64) * self.thickness
        self.node_f.fill(0)
        for a, v in zip(keep, saved):
            a.from_numpy(v)
        return f

    def profile(self, steps: int = 100) -> dict:
        """Run ``steps`` steps with one launch per phase and time each phase [s].

        Returns {"elastic", "detection", "contact", "integration", "total", "steps"}: wall
        seconds spent in each phase (the state advances exactly as with :meth:`step`).
        """
        flags = self._flags()
        t = {"elastic": 0.0, "joints": 0.0, "detection": 0.0, "contact": 0.0, "integration": 0.0}
        pc = _time.perf_counter
        self._sync_detect_due()
        for _ in range(int(steps)):
            if self.contact and self._detect_due:
                t0 = pc(); self._detect(); t["detection"] += pc() - t0
            t0 = pc()
            stepping.eval_elastic(self.node_x, self.node_v, self.node_f, self.tri_nodes, self.tri_rest_inv,
                                  self.tri_mat, self.mat_mu, self.mat_lam, self.tri_visc, self.tri_diss,
                                  self.sim_real, self.sim_int, self.damping)
            t1 = pc(); t["elastic"] += t1 - t0
            if self.fracture:
                stepping.eval_joints(*self._joint_args(), self.node_x, self.node_v, self.node_f, self.sim_real,
                                     self.sim_int)
                t0, t1 = t1, pc(); t["joints"] += t1 - t0
            if self.contact:
                stepping.eval_contact(self.couple_a, self.couple_b, self.node_x, self.node_v, self.node_f,
                                      self.tri_nodes, self.tri_mat, self.pair_prop, self.couple_hist, self.acc,
                                      self.sim_real, self.sim_int, self.friction, self.contact_damping)
            t2 = pc(); t["contact"] += t2 - t1
            code = stepping.integrate(self.node_x, self.node_v, self.node_f, self.node_mass, self.node_free,
                                      self.node_vbc, self.acc, self.sim_real, self.sim_int, flags[4], flags[5])
            if self.fracture:
                stepping.book_joint_work(self.joint_nodes, self.joint_g, self.joint_work, self.node_v, self.sim_real)
            t["integration"] += pc() - t2
            self.step_count += 1
            self._detect_due = bool(code & 1)
            if code & 2:
                self._raise_unstable()
        si = self.sim_int.to_numpy()
        if si[I_NONFINITE] or si[I_INVERTED] or si[I_SPEED]:
            self._raise_unstable()
        t["total"] = sum(t.values())
        t["steps"] = int(steps)
        return t

    # ------------------------------------------------------------------------------------------
    # results
    # ------------------------------------------------------------------------------------------
    def _body(self, body):
        if body is None:
            return slice(None)
        if isinstance(body, int):
            body = self.bodies[body]
        if body not in self.bodies:
            raise ValueError(f"{body!r} is not a body of this simulation")
        return body.nodes

    def node_positions(self, body=None) -> np.ndarray:
        """Node positions [m], shape (n, 2), of a body (or of all nodes)."""
        return self.node_x.to_numpy().astype(np.float64)[self._body(body)]

    def node_velocities(self, body=None) -> np.ndarray:
        """Node velocities [m/s] at the last half step, shape (n, 2)."""
        return self.node_v.to_numpy().astype(np.float64)[self._body(body)]

    def node_masses(self, body=None) -> np.ndarray:
        """Lumped node masses [kg] (ρ A0 t / 3 per triangle), shape (n,)."""
        return self._mass_np[self._body(body)] * self.thickness

    def node_displacements(self, body=None) -> np.ndarray:
        """x − X [m], shape (n, 2)."""
        return (self.node_x.to_numpy().astype(np.float64) - self._X)[self._body(body)]

    def set_node_velocities(self, v, body=None) -> None:
        """Overwrite node velocities [m/s] of a body (or all nodes)."""
        allv = self.node_v.to_numpy()
        allv[self._body(body)] = np.asarray(v, dtype=allv.dtype)
        self.node_v.from_numpy(allv)

    def stresses(self, body=None) -> np.ndarray:
        """Elastic Cauchy stress of each triangle [Pa], shape (m, 2, 2) (§3.2, without the viscous part)."""
        x = self.node_x.to_numpy().astype(np.float64)
        t = self._tri_nodes_np
        Fx = np.stack([x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]]], axis=2)
        F = Fx @ self.tri_rest_inv.to_numpy().astype(np.float64)
        J = np.linalg.det(F)
        mu = self.mat_mu.to_numpy()[self._tri_mat_np][:, None, None]
        lam = self.mat_lam.to_numpy()[self._tri_mat_np][:, None, None]
        I = np.eye(2)
        T = (mu / J[:, None, None]) * (F @ F.transpose(0, 2, 1) - I) + lam * (J - 1.0 / J)[:, None, None] * I
        if body is None:
            return T
        b = self.bodies[body] if isinstance(body, int) else body
        return T[b.triangles]

    def energies(self) -> dict:
        """Energy account [J] (per the scene thickness).

        kinetic, strain, contact (penalty potential p∫(φ_c + φ_t)dA plus friction springs),
        gravity (−Σ m g·x), damping / friction / contact_damping (work dissipated so far),
        boundary_work (work done on the system by prescribed velocities), joints (work done on
        intact joints: stored elastically, plus any damage so far) and fracture (work done on
        joints that have broken: dissipated in cracking), and
        total = kinetic + strain + contact + gravity + joints + dissipated − boundary_work, which
        is conserved up to the time-discretisation error.
        """
        energy_terms(self.node_x, self.node_v, self.node_mass, self.tri_nodes, self.tri_rest_inv, self.tri_area0,
                     self.tri_mat, self.mat_mu, self.mat_lam, self.tri_diss if self.damping else self.tri_area0,
                     self.couple_a, self.couple_b, self.pair_prop, self.couple_hist,
                     self.couple_count if self.contact else 0, float(self.scene.gravity[0]),
                     float(self.scene.gravity[1]), self._energy_out, self.friction)
        out = self._energy_out.to_numpy().astype(np.float64)
        acc = self.acc.to_numpy().astype(np.float64)
        t = self.thickness
        e = {"kinetic": out[0] * t, "strain": out[1] * t, "contact": out[2] * t, "gravity": out[3] * t,
             "damping": (out[4] if self.damping else 0.0) * t, "friction": acc[A_FRICTION] * t,
             "contact_damping": acc[A_CDAMPING] * t, "boundary_work": acc[A_BOUNDARY] * t}
        e["joints"] = e["fracture"] = 0.0
        if self.fracture:
            work = self.joint_work.to_numpy().astype(np.float64)
            broken = self.joint_state.to_numpy() != 0
            e["joints"] = float(work[~broken].sum()) * t
            e["fracture"] = float(work[broken].sum()) * t
        e["total"] = (e["kinetic"] + e["strain"] + e["contact"] + e["gravity"] + e["joints"] + e["damping"]
                      + e["friction"] + e["contact_damping"] + e["fracture"] - e["boundary_work"])
        return e

    # ------------------------------------------------------------------------------------------
    # fracture results
    # ------------------------------------------------------------------------------------------
    @property
    def broken_joint_count(self) -> int:
        """Number of joints broken so far."""
        return int(self.sim_int.to_numpy()[I_BROKEN]) if self.fracture else 0

    def broken_joints(self) -> dict:
        """The joints broken so far (FDEM_SPEC §7.8).

        Returns {"index": (k,) joint indices, "position": (k, 2) mean of the joint's 4 nodes at
        breakage [m], "time": (k,) [s], "mode": (k,) "I", "II", "I+II" or "mixed"}, in time order.
        """
        from .joints import MODE_NAMES
        if not self.fracture:
            return {"index": np.zeros(0, int), "position": np.zeros((0, 2)), "time": np.zeros(0),
                    "mode": np.zeros(0, dtype=object)}
        state = self.joint_state.to_numpy()
        idx = np.nonzero(state)[0]
        brk = self.joint_break.to_numpy().astype(np.float64)[idx]
        order = np.argsort(brk[:, 0], kind="stable")
        idx, brk = idx[order], brk[order]
        modes = self.joint_mode.to_numpy()[idx]
        return {"index": idx, "position": brk[:, 1:3], "time": brk[:, 0],
                "mode": np.array([MODE_NAMES.get(int(m), "?") for m in modes], dtype=object)}

    def joint_damage(self) -> np.ndarray:
        """Damage of each joint in [0, 1]: the largest stored D of its points, 1 when broken."""
        if not self.fracture:
            return np.zeros(0)
        d = self.joint_dmax.to_numpy().astype(np.float64).max(axis=1)
        d[self.joint_state.to_numpy() != 0] = 1.0
        return d[: self.joint_count]

    def tri_damage(self) -> np.ndarray:
        """Damage per triangle (m,): the largest damage of its joints (0 for bodies without joints)."""
        out = np.zeros(self.tri_count)
        if self.fracture:
            d = self.joint_damage()
            jt = self._joint_tris_np
            np.maximum.at(out, jt[:, 0], d)
            np.maximum.at(out, jt[:, 1], d)
        return out

    def fragment_count(self, body=None) -> int:
        """Number of fragments: triangles connected through intact joints (FDEM_SPEC §7.10).

        A body without fracture counts as one fragment.  With ``body``, only that body's.
        """
        labels = np.arange(self.tri_count)
        for b in self.bodies:
            if not b.fracture:
                labels[b.triangles] = b.tri_start
        if self.fracture:
            intact = self.joint_state.to_numpy()[: self.joint_count] == 0
            a, c = self._joint_tris_np[intact, 0], self._joint_tris_np[intact, 1]
            while True:                      # min-label propagation with pointer jumping
                lo = np.minimum(labels[a], labels[c])
                new = labels.copy()
                np.minimum.at(new, a, lo)
                np.minimum.at(new, c, lo)
                new = new[new]
                if np.array_equal(new, labels):
                    break
                labels = new
        if body is not None:
            b = self.bodies[body] if isinstance(body, int) else body
            labels = labels[b.triangles]
        return int(len(np.unique(labels)))

    def couples(self) -> np.ndarray:
        """Current couple list as (c, 2) triangle indices (first < second in detection order)."""
        n = self.couple_count
        return np.stack([self.couple_a.to_numpy()[:n], self.couple_b.to_numpy()[:n]], axis=1)

    def info(self) -> dict:
        """Sizes, features, time step and strategy of this simulation."""
        return {"nodes": self.node_count, "triangles": self.tri_count, "bodies": len(self.bodies),
                "contact_triangles": self.ctri_count, "couples": self.couple_count, "dt": self.dt,
                "dt_limit": self.dt_limit, "dt_estimate": self.dt_estimate, "dt_elastic": self.dt_elastic,
                "dt_contact": self.dt_contact,
                "strategy": self.strategy, "contact": self.contact, "friction": self.friction,
                "damping": self.damping, "contact_damping": self.contact_damping, "buffer": self.buffer,
                "fracture": self.fracture, "joints": self.joint_count, "dt_joint": self.dt_joint,
                "precision": backend.precision()}

    # ------------------------------------------------------------------------------------------
    # checkpoints (taichi_fdem.checkpoint)
    # ------------------------------------------------------------------------------------------
    def save(self, path) -> None:
        """Write a checkpoint of the whole state to ``path`` (one file, written atomically).

        Every Taichi and NumPy array attribute, every plain attribute (step count, dt, flags,
        capacities) and the scene are stored; :meth:`load` continues the run exactly.  See
        :mod:`taichi_fdem.checkpoint`.
        """
        from . import checkpoint
        checkpoint.save(self, path)

    @classmethod
    def load(cls, path) -> "Simulation":
        """A Simulation restored from a checkpoint written by :meth:`save`.

        Raises :class:`taichi_fdem.checkpoint.CheckpointError` (a ValueError) for a corrupt
        file, another format version or another precision.  Only load files you trust (the
        scene is unpickled).
        """
        from . import checkpoint
        return checkpoint.load(path)

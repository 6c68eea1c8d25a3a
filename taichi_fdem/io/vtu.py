"""Result export: a VTU series with a ParaView ``.pvd`` index, written as the run goes.

::

    sim.run(1.0, record=[VTU("out", frame_dt=0.01)])   # t = 0, every 0.01 s and the end

or, driven by hand::

    exporter = ExporterVtu("out", every=1)
    with exporter:
        exporter.write(sim)                       # the initial state, t = 0
        sim.run(1.0, callback=exporter.callback)

Each call to :meth:`ExporterVtu.write` writes one ``<prefix>_NNNNNN.vtu`` file (through meshio)
and then rewrites ``<prefix>.pvd``, the ParaView collection listing every frame written so far
with its simulated time.  Both are written to a temporary file first and moved into place with
:func:`os.replace`, so an interrupted run leaves a valid series of the frames completed.

Fields (SI units; the mesh points are the *current* node positions, z = 0):

point data
    ``displacement`` x − X [m] and ``velocity`` [m/s], 3 components (z = 0, so that ParaView
    treats them as vectors); ``body_id`` (int32); with a fluid in the fracture network
    (``scene.set_fluid``), ``fluid_pressure`` [Pa]: on the face nodes of the network's edges,
    the pressure of their network node (0 elsewhere; ``sim.fluid.node_pressures``); with heat
    (``scene.set_temperature``, ``scene.heat``), ``temperature`` (``sim.temperatures()``).
cell data
    ``stress``: elastic Cauchy stress [Pa] as 3 components (σ_xx, σ_yy, σ_xy), from
    :meth:`Simulation.stresses` (without the viscous part);
    ``von_mises`` [Pa]: √(½[(σ_xx−σ_yy)² + (σ_yy−σ_zz)² + (σ_zz−σ_xx)²] + 3 σ_xy²), with
    σ_zz = 0 in plane stress and σ_zz = ν(σ_xx + σ_yy) in plane strain (as the renderer; a bedded
    triangle: σ_zz = ν1 σ_1 + ν21 (E1/E2) σ_2 with σ_1, σ_2 the normal stresses along and across its
    bedding, docs/theory/anisotropy.md);
    ``strain``: Green–Lagrange strain E = ½(FᵀF − I) (dimensionless) as 3 tensor components (E_xx, E_yy, E_xy) — not engineering shear; it equals the small strain
    sym(∇u) to first order; ``body_id`` and ``material_id`` (int32); ``damage`` in [0, 1]
    (``sim.cracks.tri_damage()``: zeros for bodies without joints); in scenes with a bedded material
    (``fdem.Bedding``), ``bedding``: the current unit direction F a / |F a| of each triangle's
    bedding a = (cos θ, sin θ), 3 components (z = 0), zero for triangles of isotropic materials.
    Triangles removed by an excavation (``sim.remove``) are not written.

Cracks: :func:`write_cracks_vtu` writes the broken joints as a separate VTU file of line cells
(their current midlines) with the crack events' data (time, mode, energy, length, set).
"""
from __future__ import annotations

import os
import xml.etree.ElementTree as ET

import numpy as np

from ..sim.recorders import Recorder

__all__ = ["ExporterVtu", "VTU", "frame_fields", "write_cracks_vtu", "write_ae_vtu"]


def _to_numpy(a) -> np.ndarray:
    return np.asarray(a.to_numpy() if hasattr(a, "to_numpy") else a)


def _pad3(v: np.ndarray) -> np.ndarray:
    out = np.zeros((len(v), 3), dtype=np.float64)
    out[:, :2] = v
    return out


def _bedded_szz(sim, cs, sxx, syy, sxy, szz) -> np.ndarray:
    """σ_zz [Pa] of plane strain with the bedded triangles' law: ν1 σ_1 + ν21 (E1/E2) σ_2 (σ_1, σ_2
    the normal stresses along and across the bedding, ε_zz = 0 of the TI compliance)."""
    mats = sim.model.materials
    k = np.array([[m.poisson, m.bedding.poisson_normal * m.young / m.bedding.young_normal] if m.bedding else
                  [0.0, 0.0] for m in mats])[np.asarray(sim.model.tri_mat_np)]
    c, s = cs[:, 0], cs[:, 1]
    s1 = c * c * sxx + 2 * c * s * sxy + s * s * syy
    s2 = s * s * sxx - 2 * c * s * sxy + c * c * syy
    on = np.any(cs != 0.0, axis=1)
    return np.where(on, k[:, 0] * s1 + k[:, 1] * s2, szz)


def frame_fields(sim) -> dict:
    """The exported fields of the current state of ``sim`` as NumPy arrays (float64 / int32).

    Returns ``{"points": (n, 2) [m], "triangles": (m, 3), "point_data": {...}, "cell_data":
    {...}}`` with the 2-component vectors and tensors described in the module docstring
    (point vectors (n, 2), stress and strain (m, 3)).  Vectorised NumPy, no loop over nodes.
    """
    x = sim.node_positions()
    tris = np.asarray(sim.model.tri_nodes_np, dtype=np.int64)
    node_body = np.zeros(sim.model.node_count, dtype=np.int32)
    for b in sim.bodies:                       # one slice per body, not per node
        node_body[b.nodes] = b.index

    T = np.asarray(sim.stresses(), dtype=np.float64)
    sxx, syy, sxy = T[:, 0, 0], T[:, 1, 1], 0.5 * (T[:, 0, 1] + T[:, 1, 0])
    szz = np.zeros_like(sxx)
    scene = getattr(sim, "scene", None)
    bedding = getattr(sim.model, "bedding", False)
    cs = _to_numpy(sim.model.tri_bedding).astype(np.float64) if bedding else None
    if getattr(scene, "plane", "stress") == "strain":     # Hooke's out-of-plane stress σ_zz = ν(σ_xx + σ_yy)
        nu = np.array([m.poisson for m in sim.model.materials])[np.asarray(sim.model.tri_mat_np)]
        szz = nu * (sxx + syy)
        if bedding:
            szz = _bedded_szz(sim, cs, sxx, syy, sxy, szz)
    von_mises = np.sqrt(np.maximum(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2)
                                   + 3.0 * sxy * sxy, 0.0))

    # deformation gradient F = [x1 - x0, x2 - x0] · (rest edges)^-1, as in Simulation.stresses
    Fx = np.stack([x[tris[:, 1]] - x[tris[:, 0]], x[tris[:, 2]] - x[tris[:, 0]]], axis=2)
    F = Fx @ _to_numpy(sim.model.tri_rest_inv).astype(np.float64)
    E = 0.5 * (F.transpose(0, 2, 1) @ F - np.eye(2))

    damage = _to_numpy(sim.cracks.tri_damage()).astype(np.float64).reshape(-1)
    if damage.shape != (sim.model.tri_count,):
        raise ValueError(f"ExporterVtu: sim.cracks.tri_damage() has {damage.size} values for {sim.model.tri_count} "
                         f"triangles")

    cells = {"stress": np.stack([sxx, syy, sxy], axis=1), "von_mises": von_mises,
             "strain": np.stack([E[:, 0, 0], E[:, 1, 1], 0.5 * (E[:, 0, 1] + E[:, 1, 0])], axis=1),
             "body_id": np.asarray(sim.model.tri_body_np, dtype=np.int32),
             "material_id": np.asarray(sim.model.tri_mat_np, dtype=np.int32),
             "damage": damage}
    if bedding:                                # the current direction of the bedding, F a / |F a|
        d = (F @ cs[:, :, None])[:, :, 0]
        n = np.linalg.norm(d, axis=1)
        cells["bedding"] = _pad3(np.where(n[:, None] > 0, d / np.where(n > 0, n, 1.0)[:, None], 0.0))
    active = getattr(sim, "active_triangles", None)
    if callable(active):                       # triangles removed by an excavation are not written
        keep = np.asarray(active(), dtype=bool)
        if not keep.all():
            tris = tris[keep]
            cells = {k: v[keep] for k, v in cells.items()}
    point = {"displacement": sim.node_displacements(), "velocity": sim.node_velocities(), "body_id": node_body}
    if getattr(getattr(sim, "model", None), "fluid", False):
        point["fluid_pressure"] = sim.fluid.node_pressures()
    if getattr(getattr(sim, "model", None), "heat", False):
        point["temperature"] = sim.temperatures()
    return {"points": x, "triangles": tris, "point_data": point, "cell_data": cells}


def _read_pvd(path: str) -> list:
    """[(time [s], file name)] of the frames listed in a ``.pvd`` collection file."""
    try:
        root = ET.parse(path).getroot()
        coll = root.find("Collection")
        if root.tag != "VTKFile" or coll is None:
            raise ValueError("not a VTKFile collection")
        frames = [(float(d.get("timestep")), str(d.get("file"))) for d in coll.findall("DataSet")]
    except (ET.ParseError, ValueError, TypeError) as exc:
        raise ValueError(f"ExporterVtu: cannot resume from {path!r}: {exc}") from None
    return frames


class ExporterVtu:
    """Write a VTU series and its ParaView ``.pvd`` index while a simulation runs.

    Parameters
    ----------
    directory : output directory (created if missing).
    every : :meth:`callback` writes a frame on every ``every``-th call (default 1: every
        frame interval of :meth:`Simulation.run`).  :meth:`write` always writes.
    prefix : file names ``<prefix>_000000.vtu``, ``<prefix>_000001.vtu``, ... and
        ``<prefix>.pvd``.  A new exporter starts a new series: an existing ``<prefix>.pvd``
        in the directory is overwritten at the first frame.
    binary : write the VTU data arrays base64-encoded and zlib-compressed (default) or as
        ASCII text.
    resume : continue the series already in the directory (after a restart from a
        checkpoint): the existing ``<prefix>.pvd`` is read, and at the first :meth:`write`
        its frames at or after the simulation's time are dropped (the restarted run
        recomputes them) and numbering continues after the frames kept.  Without an index
        to resume, a new series starts.

    Usable as a context manager; the ``.pvd`` index is valid after every frame, whether or
    not the exporter is closed (closing only forbids further writes).
    """

    def __init__(self, directory, every: int = 1, prefix: str = "frame", binary: bool = True,
                 resume: bool = False):
        if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
            raise ValueError(f"ExporterVtu: every must be an integer >= 1, got {every!r}")
        if not isinstance(prefix, str) or not prefix or os.sep in prefix or (os.altsep and os.altsep in prefix):
            raise ValueError(f"ExporterVtu: prefix must be a non-empty file name without a path separator, "
                             f"got {prefix!r}")
        self.directory = os.fspath(directory)
        if os.path.exists(self.directory) and not os.path.isdir(self.directory):
            raise ValueError(f"ExporterVtu: directory {self.directory!r} exists and is not a directory")
        os.makedirs(self.directory, exist_ok=True)
        self.every = int(every)
        self.prefix = prefix
        self.binary = bool(binary)
        self.frames: list[tuple[float, str]] = []   # (time [s], file name) of every frame written
        self.calls = 0
        self.closed = False
        self._resumed = False
        if resume and os.path.exists(self.pvd_path):
            self.frames = _read_pvd(self.pvd_path)
            self._resumed = True

    @property
    def pvd_path(self) -> str:
        """Path of the ``.pvd`` collection file."""
        return os.path.join(self.directory, f"{self.prefix}.pvd")

    @property
    def frame_count(self) -> int:
        """Number of frames written."""
        return len(self.frames)

    def write(self, sim) -> str:
        """Write the current state of ``sim`` as the next frame; returns the ``.vtu`` path.

        The frame is stamped with ``sim.time`` [s] in the index.
        """
        import meshio

        if self.closed:
            raise ValueError(f"ExporterVtu: write() after close() ({self.pvd_path!r})")
        if self._resumed:        # drop the frames the restarted run is about to recompute
            self.frames = [(t, name) for t, name in self.frames if t < float(sim.time)]
            self._resumed = False
        f = frame_fields(sim)
        mesh = meshio.Mesh(
            _pad3(f["points"]), [("triangle", f["triangles"])],
            point_data={k: (_pad3(v) if v.ndim == 2 else v) for k, v in f["point_data"].items()},
            cell_data={k: [v] for k, v in f["cell_data"].items()})
        name = f"{self.prefix}_{len(self.frames):06d}.vtu"
        path = os.path.join(self.directory, name)
        tmp = path + ".tmp"
        try:
            meshio.write(tmp, mesh, file_format="vtu", binary=self.binary)
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.remove(tmp)
        self.frames.append((float(sim.time), name))
        self._write_pvd()
        return path

    def callback(self, sim) -> None:
        """``callback=`` of :meth:`Simulation.run`: writes a frame on every ``every``-th call."""
        self.calls += 1
        if self.calls % self.every == 0:
            self.write(sim)

    __call__ = callback

    def _write_pvd(self) -> None:
        root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
        coll = ET.SubElement(root, "Collection")
        for t, name in self.frames:
            ET.SubElement(coll, "DataSet", timestep=repr(t), group="", part="0", file=name)
        ET.indent(root)
        tmp = self.pvd_path + ".tmp"
        with open(tmp, "wb") as fh:
            ET.ElementTree(root).write(fh, encoding="utf-8", xml_declaration=True)
            fh.write(b"\n")
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, self.pvd_path)

    def close(self) -> None:
        """Stop writing (the series on disk is already complete)."""
        self.closed = True

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close()
        return False

    def __repr__(self):
        return f"ExporterVtu({self.directory!r}, every={self.every}, prefix={self.prefix!r}, frames={self.frame_count})"


class VTU(Recorder):
    """The VTU-series recorder of :meth:`Simulation.run`: ``sim.run(duration,
    record=[fdem.export.VTU("out/vtu", frame_dt=0.01)])`` writes the state at the start,
    every ``frame_dt`` seconds of simulated time (default: 100 frames over the run) and at the
    end through an :class:`ExporterVtu` (``directory``, ``prefix``, ``binary``, ``resume`` as
    there; :attr:`exporter` is it).  A recorder used for several runs continues one series
    without repeating the frame at the time where the last run ended."""

    def __init__(self, directory, frame_dt: float | None = None, prefix: str = "frame", binary: bool = True,
                 resume: bool = False):
        if frame_dt is not None and not (isinstance(frame_dt, (int, float, np.floating)) and not isinstance(frame_dt, bool)
                                         and np.isfinite(frame_dt) and frame_dt > 0):
            raise ValueError(f"VTU: frame_dt must be a positive time [s] or None, got {frame_dt!r}")
        self.exporter = ExporterVtu(directory, every=1, prefix=prefix, binary=binary, resume=resume)
        self.requested_dt = frame_dt
        self.frame_dt = frame_dt

    def open(self, sim, steps, duration):
        if self.requested_dt is None:
            self.frame_dt = duration / 100 if duration > 0 else sim.dt
        if not self.exporter.frames or self.exporter.frames[-1][0] != float(sim.time) or self.exporter._resumed:
            self.exporter.write(sim)

    def frame(self, sim, done):
        self.exporter.write(sim)


def write_cracks_vtu(path, sim, binary: bool = True) -> str:
    """Write the broken joints of ``sim`` as VTU polylines; returns the path.

    One ``line`` cell per broken joint, in the order of ``sim.cracks.events()``: from
    ½(x_j0 + x_j3) to ½(x_j1 + x_j2) at the current node positions (``sim.cracks.segments()``;
    two points per cell, z = 0).  Cell data: ``joint`` (int32, its index), ``time`` [s] of
    breakage, ``mode`` (int32: 1 = I, 2 = II, 3 = I+II, 4 = mixed), ``energy`` [J] released,
    ``length`` [m] (initial, L0) and ``set`` (int32 joint-set index).  With no broken joint the
    file holds an empty piece (0 points, 0 cells; VTK reads it, meshio cannot).  Written to a temporary file and moved into place.
    """
    import meshio

    path = os.fspath(path)
    if not path.endswith(".vtu"):
        raise ValueError(f"write_cracks_vtu: path must end with .vtu, got {path!r}")
    ev = sim.cracks.events()
    seg = np.asarray(sim.cracks.segments(), dtype=np.float64).reshape(-1, 4)
    k = len(seg)
    points = _pad3(seg.reshape(2 * k, 2))
    lines = np.arange(2 * k, dtype=np.int64).reshape(k, 2)
    data = {"joint": ev["index"].astype(np.int32), "time": ev["time"].astype(np.float64),
            "mode": ev["mode_id"].astype(np.int32), "energy": ev["energy"].astype(np.float64),
            "length": ev["length"].astype(np.float64), "set": ev["set_id"].astype(np.int32)}
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = path + ".tmp"
    try:
        if k:
            mesh = meshio.Mesh(points, [("line", lines)], cell_data={name: [v] for name, v in data.items()})
            meshio.write(tmp, mesh, file_format="vtu", binary=binary)
        else:                   # meshio writes no readable empty grid: an empty piece by hand
            with open(tmp, "w") as fh:
                fh.write(_EMPTY_VTU)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return path


def write_ae_vtu(path, ae: dict, binary: bool = True) -> str:
    """Write acoustic-emission events (``sim.cracks.ae_events()`` or :func:`taichi_fdem.sim.ae.ae_events`)
    as VTU points; returns the path.

    One ``vertex`` cell per AE event at its location (z = 0).  Cell and point data: ``time`` [s],
    ``end`` [s], ``energy`` [J], ``moment`` [N·m], ``magnitude`` (M_w), ``cracks`` (int32) and
    ``mode`` (int32: 1 = tensile, 2 = shear, 3 = mixed).  No event: an empty piece."""
    import meshio

    path = os.fspath(path)
    if not path.endswith(".vtu"):
        raise ValueError(f"write_ae_vtu: path must end with .vtu, got {path!r}")
    k = len(ae["time"])
    points = _pad3(np.stack([np.asarray(ae["x"], np.float64), np.asarray(ae["y"], np.float64)], axis=1).reshape(k, 2))
    codes = {"tensile": 1, "shear": 2, "mixed": 3}
    data = {"time": np.asarray(ae["time"], np.float64), "end": np.asarray(ae["end"], np.float64),
            "energy": np.asarray(ae["energy"], np.float64), "moment": np.asarray(ae["moment"], np.float64),
            "magnitude": np.asarray(ae["magnitude"], np.float64), "cracks": np.asarray(ae["cracks"], np.int32),
            "mode": np.array([codes[m] for m in np.asarray(ae["mode"]).tolist()], np.int32)}
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = path + ".tmp"
    try:
        if k:
            mesh = meshio.Mesh(points, [("vertex", np.arange(k, dtype=np.int64).reshape(k, 1))],
                               point_data=data, cell_data={name: [v] for name, v in data.items()})
            meshio.write(tmp, mesh, file_format="vtu", binary=binary)
        else:
            with open(tmp, "w") as fh:
                fh.write(_EMPTY_VTU)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return path


_EMPTY_VTU = """<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">
<UnstructuredGrid>
<Piece NumberOfPoints="0" NumberOfCells="0">
<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii"></DataArray></Points>
<Cells>
<DataArray type="Int64" Name="connectivity" format="ascii"></DataArray>
<DataArray type="Int64" Name="offsets" format="ascii"></DataArray>
<DataArray type="UInt8" Name="types" format="ascii"></DataArray>
</Cells>
</Piece>
</UnstructuredGrid>
</VTKFile>
"""

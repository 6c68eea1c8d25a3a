"""``polygon(..., engine="gmsh")``: a polygon with embedded lines meshed by gmsh (optional).

gmsh (https://gmsh.info, ``pip install "taichi-fdem[mesh]"``) is imported on first use only.
The planar graph built by :mod:`~taichi_fdem.mesh.arrangement` (outline split where lines meet
it, lines split at their crossings) is handed to gmsh's built-in ("geo") kernel: one point per
node with mesh size ``h``, the outline as a curve loop and plane surface, every line piece a
curve embedded in the surface (``gmsh.model.mesh.embed``), 2D meshing with linear triangles.
gmsh is initialised and finalised here (when it was not initialised already; then the model
is added and removed), with its terminal output off.
"""
from __future__ import annotations

import numpy as np

from .trimesh import TriMesh

__all__: list = []   # private: use polygon(..., engine="gmsh")

INSTALL_HINT = 'pip install "taichi-fdem[mesh]"'


def _import_gmsh():
    try:
        import gmsh
    except ImportError as exc:
        raise ImportError(f"polygon(engine='gmsh') needs the gmsh Python package ({exc}); "
                          f"install it with: {INSTALL_HINT}") from None
    return gmsh


def polygon_gmsh(v: np.ndarray, h: float | None, arr, where: str) -> TriMesh:
    """Mesh the counter-clockwise polygon ``v`` (k, 2) [m] and the arrangement ``arr`` (or None:
    no lines) with gmsh, target edge length ``h`` [m]."""
    if h is None:
        raise ValueError(f"{where}: engine='gmsh' needs a target edge length h")
    gmsh = _import_gmsh()
    if arr is None:
        nodes, ring, pieces = v, np.arange(len(v)), np.zeros((0, 2), dtype=np.int64)
    else:
        nodes, ring, pieces = arr.nodes, arr.ring, arr.pieces
    own = not gmsh.isInitialized()
    if own:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("taichi_fdem_polygon")
        geo = gmsh.model.geo
        # gmsh tags start at 1: node i is point i + 1
        for i, (x, y) in enumerate(nodes.tolist()):
            geo.addPoint(x, y, 0.0, h, i + 1)
        loop = [geo.addLine(int(a) + 1, int(b) + 1) for a, b in zip(ring, np.roll(ring, -1))]
        surface = geo.addPlaneSurface([geo.addCurveLoop(loop)])
        embedded = [geo.addLine(int(a) + 1, int(b) + 1) for a, b in pieces]
        geo.synchronize()
        if embedded:
            gmsh.model.mesh.embed(1, embedded, 2, surface)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.ElementOrder", 1)
        gmsh.model.mesh.generate(2)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, tri_nodes = gmsh.model.mesh.getElementsByType(2)       # 2 = 3-node triangle
    finally:
        if own:
            gmsh.finalize()
        else:
            gmsh.model.remove()
    tags = np.asarray(tags, dtype=np.int64)
    pts = np.asarray(coords, dtype=np.float64).reshape(-1, 3)[:, :2]
    index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    index[tags] = np.arange(len(tags))
    tri = index[np.asarray(tri_nodes, dtype=np.int64).reshape(-1, 3)]
    if len(tri) == 0 or (tri < 0).any():
        raise RuntimeError(f"{where}: gmsh returned no usable triangles")
    return TriMesh(pts, tri).compact()

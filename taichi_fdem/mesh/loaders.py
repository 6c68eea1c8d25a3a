"""Reading meshes from files with meshio: :func:`load` (one mesh), :func:`load_groups` (one mesh
per physical group / cell tag, and optionally the physical line groups as
:class:`~taichi_fdem.mesh.Segments`), :func:`load_tagged` (one mesh with a group label per
triangle, and the line groups) and :func:`scene_from_groups` (one body per group).

meshio is imported on first use only; the module does not import Taichi.
"""
from __future__ import annotations

import numpy as np

from .trimesh import TriMesh

__all__ = ["load", "load_groups", "load_tagged", "scene_from_groups", "GROUP_KEYS"]

# --------------------------------------------------------------------------- load / merge
_IGNORED_CELLS = {"vertex", "line", "line3", "line4", "line5", "line6"}
_VOLUME_CELLS = ("tetra", "hexahedron", "wedge", "pyramid")


def _topological_dimension(cell_type: str) -> int | None:
    if cell_type in _IGNORED_CELLS or cell_type.startswith("line"):
        return 1
    if cell_type.startswith(_VOLUME_CELLS):
        return 3
    if cell_type.startswith(("triangle", "quad", "polygon")):
        return 2
    try:
        from meshio._mesh import topological_dimension  # private, best effort
        return topological_dimension.get(cell_type)
    except Exception:  # pragma: no cover
        return None


def _read_planar(path, where: str):
    """``(name, meshio.Mesh, points (n, 2) float64)`` of a file meshio can read, the z
    coordinate dropped when constant; ValueError naming the file otherwise."""
    import meshio

    name = str(path)
    try:
        m = meshio.read(path)
    except OSError:
        raise
    except (meshio.ReadError, SystemExit, ValueError, IndexError, KeyError, UnicodeDecodeError) as exc:
        # meshio calls sys.exit(1) when no candidate reader accepts the file
        detail = f": {exc}" if str(exc) and not isinstance(exc, SystemExit) else ""
        raise ValueError(f"{where}: cannot read {name!r} as a mesh{detail}") from None
    pts = np.asarray(m.points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3) or len(pts) == 0:
        raise ValueError(f"{where}: {name!r} has no usable points (shape {pts.shape})")
    if pts.shape[1] == 3:
        z = pts[:, 2]
        extent = float(np.ptp(pts[:, :2], axis=0).max()) if len(pts) > 1 else 0.0
        if np.ptp(z) > 1e-10 * max(extent, 1e-300):
            raise ValueError(f"{where}: {name!r} is a 3D mesh (z varies from {z.min():g} to {z.max():g}); "
                             f"only planar meshes in the xy plane are supported")
        pts = pts[:, :2]
    return name, m, pts


def _triangle_block_indices(m, name: str, where: str) -> list[int]:
    """Indices of the linear "triangle" blocks of ``m``; points and lines are ignored, every
    other cell type (quadratic triangles, quads, polygons, volume cells) refused."""
    selected = []
    for k, block in enumerate(m.cells):
        dim = _topological_dimension(block.type)
        if block.type == "triangle":
            selected.append(k)
        elif block.type.startswith("triangle"):
            raise ValueError(f"{where}: {name!r} contains higher-order {block.type!r} cells (block {k}); "
                             f"only linear 3-node 'triangle' cells are supported (re-mesh with order 1)")
        elif dim == 3:
            raise ValueError(f"{where}: {name!r} is a 3D mesh (contains {block.type!r} cells)")
        elif dim == 2:
            raise ValueError(f"{where}: {name!r} contains {block.type!r} cells (block {k}); only 'triangle' "
                             f"cells are supported (mixed meshes are refused)")
    if not selected:
        raise ValueError(f"{where}: {name!r} contains no triangle cells "
                         f"(found: {sorted({b.type for b in m.cells}) or 'no cells'})")
    return selected


def _mesh_of(pts: np.ndarray, tri: np.ndarray, name: str, where: str) -> TriMesh:
    try:
        mesh = TriMesh(pts, tri)
    except ValueError as exc:
        raise ValueError(f"{where}: {name!r}: {exc}") from None
    return mesh.compact()


def load(path, cell_block: int | None = None) -> TriMesh:
    """Read a triangle mesh from any file meshio can read (gmsh ``.msh`` 2.2/4.1, ``.vtu``,
    ``.vtk``, ``.xdmf``, ...).

    The z coordinate is dropped when it is constant (a mesh drawn in a plane z = const);
    a genuinely 3D mesh is refused.  Point and line cells (gmsh boundary elements) are
    ignored; quadratic triangles ("triangle6"), quads, polygons or volume cells are
    refused, as is a file without triangles.  Clockwise triangles are reoriented,
    degenerate ones refused (see :class:`TriMesh`), and points no triangle uses (e.g.
    gmsh geometry points) dropped with :meth:`TriMesh.compact`.  Coordinates are taken
    as metres.  To split a file into one mesh per physical group, use :func:`load_groups`.

    Parameters
    ----------
    path : str or os.PathLike
        The mesh file.
    cell_block : int or None
        Index into meshio's ``mesh.cells`` of the one block to use (it must be a
        "triangle" block).  Default None concatenates every "triangle" block.

    Returns
    -------
    TriMesh
        The mesh, counter-clockwise triangles, unused points dropped.
    """
    name, m, pts = _read_planar(path, "load")
    blocks = list(m.cells)
    if cell_block is not None:
        if not isinstance(cell_block, (int, np.integer)) or not -len(blocks) <= cell_block < len(blocks):
            raise ValueError(f"load: cell_block={cell_block!r} is not a valid block index for {name!r} "
                             f"({len(blocks)} blocks: {[b.type for b in blocks]})")
        chosen = blocks[cell_block]
        if chosen.type != "triangle":
            raise ValueError(f"load: block {cell_block} of {name!r} holds {chosen.type!r} cells, not 'triangle'")
        selected = [chosen]
    else:
        selected = [blocks[k] for k in _triangle_block_indices(m, name, "load")]
    tri = np.concatenate([np.asarray(b.data, dtype=np.int64).reshape(-1, 3) for b in selected])
    return _mesh_of(pts, tri, name, "load")


#: cell-data keys tried, in order, by :func:`load_groups` when no ``key`` is given.
GROUP_KEYS = ("gmsh:physical", "cell_tags", "medit:ref", "tag", "tags", "region", "regions")


def _group_key(m, name: str, key, where: str) -> str:
    """The cell-data array holding the group tags (``key`` or the first of GROUP_KEYS)."""
    cell_data = dict(m.cell_data)
    if key is None:
        key = next((k for k in GROUP_KEYS if k in cell_data), None)
        if key is None:
            raise ValueError(f"{where}: {name!r} has no cell tags (none of the cell-data arrays "
                             f"{list(GROUP_KEYS)}; found {sorted(cell_data) or 'no cell data'}); "
                             f"give key=... or use load() for a single mesh")
    elif not isinstance(key, str):
        raise ValueError(f"{where}: key must be a cell-data name (str), got {key!r}")
    elif key not in cell_data:
        raise ValueError(f"{where}: {name!r} has no cell-data array {key!r} "
                         f"(found {sorted(cell_data) or 'no cell data'})")
    if len(cell_data[key]) != len(m.cells):
        # meshio's gmsh 4.1 reader lists tags only for the entities that have a physical group
        raise ValueError(f"{where}: {name!r}: cell data {key!r} covers {len(cell_data[key])} of {len(m.cells)} "
                         f"cell blocks; in gmsh, put every surface and curve in a physical group (or none of them)")
    return key


def _block_tags(m, k: int, count: int, key: str, name: str, where: str) -> np.ndarray:
    """The integer tags of cell block ``k`` (``count`` cells), int64 (count,)."""
    g = np.asarray(m.cell_data[key][k])
    if g.ndim == 2 and g.shape[1] == 1:
        g = g[:, 0]
    if g.shape != (count,):
        raise ValueError(f"{where}: {name!r}: cell data {key!r} of block {k} has shape {g.shape}, "
                         f"expected one tag per cell ({count},)")
    if g.dtype.kind == "f":
        if not (np.all(np.isfinite(g)) and np.all(g == np.round(g))):
            raise ValueError(f"{where}: {name!r}: cell data {key!r} of block {k} is not integer-valued")
    elif g.dtype.kind not in "iu":
        raise ValueError(f"{where}: {name!r}: cell data {key!r} of block {k} has dtype {g.dtype}, "
                         f"expected integer tags")
    return g.astype(np.int64)


def _group_names(m, dim: int) -> dict:
    """Names of the physical groups of dimension ``dim``: field_data[name] = [tag, dim] (gmsh)
    or [tag] (taken as any dimension)."""
    names = {}
    for group_name, fd in (m.field_data or {}).items():
        fd = np.asarray(fd).ravel()
        if fd.size == 0 or (fd.size >= 2 and int(fd[1]) != dim):
            continue
        names.setdefault(int(fd[0]), str(group_name))
    return names


def _triangle_tags(m, selected, key: str, name: str, where: str):
    """Concatenated triangles (t, 3) and their tags (t,) of the blocks ``selected``."""
    tris, tags = [], []
    for k in selected:
        t = np.asarray(m.cells[k].data, dtype=np.int64).reshape(-1, 3)
        tris.append(t)
        tags.append(_block_tags(m, k, len(t), key, name, where))
    return np.concatenate(tris), np.concatenate(tags)


def _line_groups(m, pts: np.ndarray, key: str, name: str, where: str) -> dict:
    """Physical line groups ("line" cells): group -> :class:`Segments` named after the group."""
    from .lines import Segments

    segs, tags = [], []
    for k, block in enumerate(m.cells):
        if block.type != "line":
            continue
        c = np.asarray(block.data, dtype=np.int64).reshape(-1, 2)
        segs.append(c)
        tags.append(_block_tags(m, k, len(c), key, name, where))
    if not segs:
        return {}
    seg, tag = np.concatenate(segs), np.concatenate(tags)
    names = _group_names(m, 1)
    out = {}
    for value in np.unique(tag).tolist():
        label = names.get(int(value), int(value))
        try:
            out[label] = Segments(pts[seg[tag == value]], name=str(label))
        except ValueError as exc:
            raise ValueError(f"{where}: {name!r}: line group {label!r} ({key} = {value}): {exc}") from None
    return out


def load_groups(path, key: str | None = None, lines: bool = False):
    """Read a triangle mesh and split it into one :class:`TriMesh` per physical group / cell tag.

    Parameters
    ----------
    path : str or os.PathLike, any file meshio reads (gmsh ``.msh`` 2.2 and 4.1, ``.vtu``, ...).
    key : name of the integer cell-data array holding the group tag of every cell.  Default:
        the first of :data:`GROUP_KEYS` present in the file (``"gmsh:physical"`` for gmsh
        files, i.e. the physical groups).
    lines : when True, also return the physical line groups (see below).

    Returns
    -------
    ``groups``, or ``(groups, line_groups)`` when ``lines=True``.  Without it, ``groups`` (a
    :class:`MeshGroups` dict) carries the line groups too, as ``groups.lines``.

    groups : dict mapping each group to its mesh, in increasing tag order.  A group is keyed
        by its name when the file names it (gmsh ``$PhysicalNames`` of dimension 2, meshio
        ``field_data``), otherwise by its integer tag.
    line_groups : dict mapping each physical line group (gmsh physical curves: "line" cells
        tagged by ``key``) to a :class:`~taichi_fdem.mesh.Segments` of its segments [m],
        named after the group (``$PhysicalNames`` of dimension 1), else keyed by the integer
        tag (and named ``str(tag)``); empty when the file has no line cells.  Use them as
        edge selectors (:meth:`Segments.select_edges`) on any mesh having those edges.

    Each group becomes a separate mesh with its own nodes: nodes on the interface of two
    groups are duplicated (each group compacted with :meth:`TriMesh.compact`), so groups
    added as bodies touch along the interface and interact by contact.  To keep the nodes
    shared (one body of several materials), use :func:`load_tagged`.  The checks of
    :func:`load` apply (planar mesh, linear triangles only, clockwise triangles
    reoriented, degenerate ones refused); point cells are ignored.  ValueError names the
    file and the key when the tags are missing or invalid.
    """
    where = "load_groups"
    name, m, pts = _read_planar(path, where)
    selected = _triangle_block_indices(m, name, where)
    key = _group_key(m, name, key, where)
    tri, tag = _triangle_tags(m, selected, key, name, where)
    names = _group_names(m, 2)
    out = {}
    for value in np.unique(tag).tolist():
        label = names.get(int(value), int(value))
        try:
            out[label] = _mesh_of(pts, tri[tag == value], name, where)
        except ValueError as exc:
            raise ValueError(f"{exc} (group {label!r}, {key} = {value})") from None
    if lines:
        return out, _line_groups(m, pts, key, name, where)
    return MeshGroups(out, lambda: _line_groups(m, pts, key, name, where))


class MeshGroups(dict):
    """The dict of :func:`load_groups` (group -> :class:`TriMesh`), which also carries the file's
    physical line groups as ``.lines`` (group -> :class:`~taichi_fdem.mesh.Segments`, read on
    first access; the same as ``load_groups(path, lines=True)[1]``)."""

    def __init__(self, groups: dict, read_lines):
        super().__init__(groups)
        self._read_lines = read_lines
        self._lines = None

    @property
    def lines(self) -> dict:
        if self._lines is None:
            self._lines = self._read_lines()
        return self._lines

    def __reduce__(self):                        # pickles as a plain dict
        return (dict, (dict(self),))


def load_tagged(path, key: str | None = None):
    """Read one triangle mesh with a group label per triangle, and its line groups.

    For one body made of several material groups (a dyke in a host rock, grains): unlike
    :func:`load_groups`, the nodes on the interfaces of groups stay shared.

    Parameters
    ----------
    path : any file meshio reads (gmsh ``.msh`` 2.2 and 4.1, ``.vtu``, ...).
    key : the integer cell-data array of the group tags (default: the first of
        :data:`GROUP_KEYS` present, ``"gmsh:physical"`` for gmsh files).

    Returns
    -------
    mesh : :class:`TriMesh`, all triangles of the file (as :func:`load`; triangle order
        kept, unused points dropped).
    labels : (m,) array, the group of each triangle of ``mesh``: the group name (object
        array of str) when the file names every group (``$PhysicalNames`` of dimension 2),
        else the integer tag (int64 array); with some groups named, an object array mixing
        names and integer tags.
    line_groups : dict, the physical line groups as :class:`~taichi_fdem.mesh.Segments`
        (see :func:`load_groups`).
    """
    where = "load_tagged"
    name, m, pts = _read_planar(path, where)
    selected = _triangle_block_indices(m, name, where)
    key = _group_key(m, name, key, where)
    tri, tag = _triangle_tags(m, selected, key, name, where)
    mesh = _mesh_of(pts, tri, name, where)
    names = _group_names(m, 2)
    values = np.unique(tag)
    if any(int(v) in names for v in values.tolist()):
        labels = np.empty(len(tag), dtype=object)
        for v in values.tolist():
            labels[tag == v] = names.get(int(v), int(v))
    else:
        labels = tag
    return mesh, labels, _line_groups(m, pts, key, name, where)


def scene_from_groups(scene, path, materials, key: str | None = None, **add_body_kwargs) -> dict:
    """Add one body per physical group of a mesh file to ``scene``.

    Parameters
    ----------
    scene : :class:`~taichi_fdem.scene.Scene`.
    path : mesh file, read with :func:`load_groups`.
    materials : a :class:`~taichi_fdem.material.Material` for every group, or a dict
        mapping each group (its name, or integer tag when unnamed) to a Material.  Every
        group of the file must have a material, and every key must be a group of the file.
    key : cell-data tag array (see :func:`load_groups`).
    **add_body_kwargs : passed to :meth:`Scene.add_body` for every body (e.g. ``velocity``,
        ``fixed``).  ``position`` and ``name`` are not allowed: bodies keep the file's
        coordinates [m] and are named after their group.

    Returns
    -------
    dict group -> :class:`~taichi_fdem.records.Body`, in increasing tag order.
    """
    from ..material import Material

    where = "scene_from_groups"
    for bad in ("position", "name"):
        if bad in add_body_kwargs:
            raise ValueError(f"{where}: {bad}= is not allowed (bodies keep the file's coordinates and are "
                             f"named after their group)")
    groups = load_groups(path, key=key)
    if isinstance(materials, Material):
        mats = {g: materials for g in groups}
    elif isinstance(materials, dict):
        missing = [g for g in groups if g not in materials]
        extra = [g for g in materials if g not in groups]
        if missing or extra:
            parts = []
            if missing:
                parts.append(f"no material for group(s) {missing}")
            if extra:
                parts.append(f"material key(s) {extra} are not groups of the file")
            raise ValueError(f"{where}: {str(path)!r}: {'; '.join(parts)} (groups: {list(groups)})")
        for g, mat in materials.items():
            if not isinstance(mat, Material):
                raise ValueError(f"{where}: materials[{g!r}] must be a Material, got {type(mat).__name__}")
        mats = materials
    else:
        raise ValueError(f"{where}: materials must be a Material or a dict group -> Material, "
                         f"got {type(materials).__name__}")
    return {g: scene.add_body(mesh, mats[g], name=str(g), **add_body_kwargs) for g, mesh in groups.items()}

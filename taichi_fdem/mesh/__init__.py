"""Two-dimensional triangle meshes: construction, loading and validation (pure NumPy).

A :class:`TriMesh` is an immutable pair of arrays

* ``points``    -- ``(n, 2)`` float64 node coordinates [m],
* ``triangles`` -- ``(m, 3)`` int32 node indices, every triangle counter-clockwise,

checked when it is created: finite coordinates, indices in range, no repeated node in a
triangle, no zero-area triangle, no two triangles overlapping across an edge.  Clockwise
triangles are silently reoriented.  Both arrays are read-only.

Named constructors (also available as static methods of :class:`TriMesh`)::

    rectangle(width, height, h, pattern="alternating", origin=None)
    disk(radius, h, center=(0, 0))
    annulus(r_inner, r_outer, h, center=(0, 0))
    polygon(vertices, h=None, lines=None, engine="builtin")   # lines: edges follow them
    plate_with_hole(width, height, radius, h_hole)   # graded O-grid around a central hole
    load(path, cell_block=None)          # any file meshio reads (gmsh .msh, .vtu, ...)
    load_groups(path, key=None, lines=False)  # one mesh per physical group (+ line groups)
    load_tagged(path, key=None)          # one mesh, a group label per triangle, line groups
    merge(meshes)                        # concatenate several meshes into one

Lines (fractures, joints, faults) are :class:`Segments` or :class:`Polyline`; they are
embedded in :func:`polygon` meshes and select mesh edges with :meth:`Segments.select_edges`.

``h`` is always the target element edge length [m].  The package does not import Taichi
and never loops in Python over the elements of an existing mesh; the generators
(:func:`disk`, :func:`annulus`, :func:`polygon`) use Python loops that are linear (rings)
or roughly ``O(n log n)`` (incremental Delaunay) in the number of nodes.

Modules (imports run downwards only, and never into the simulation, scene or renderer):

* :mod:`.trimesh` -- the :class:`TriMesh` class, :func:`merge`, shared argument checks;
* :mod:`.lines` -- :class:`Segments`, :class:`Polyline` (embedded lines, edge selectors);
* :mod:`.bedding` -- :func:`bedding_lines` (the traces of bedding planes through a region);
* :mod:`.arrangement` -- the planar graph of a polygon and its lines (private);
* :mod:`.triangulate` -- the constrained Delaunay triangulator used by :func:`polygon`;
* :mod:`.generators` -- :func:`rectangle`, :func:`disk`, :func:`annulus`, :func:`polygon`;
* :mod:`.gmsh_engine` -- ``polygon(..., engine="gmsh")`` (optional: ``pip install "taichi-fdem[mesh]"``);
* :mod:`.grains` -- :func:`voronoi_grains` (grain-based specimens; needs SciPy);
* :mod:`.loaders` -- :func:`load`, :func:`load_groups`, :func:`load_tagged`, :func:`scene_from_groups` (meshio).
"""
from __future__ import annotations

from .lines import Polyline, Segments
from .bedding import bedding_lines
from .generators import annulus, disk, plate_with_hole, polygon, rectangle
from .loaders import GROUP_KEYS, load, load_groups, load_tagged, scene_from_groups
from .grains import GrainLabels, voronoi_grains
from .trimesh import DEGENERACY_TOL, MAX_GENERATED_TRIANGLES, TriMesh, merge

__all__ = ["TriMesh", "rectangle", "disk", "annulus", "polygon", "plate_with_hole", "load", "load_groups", "load_tagged", "scene_from_groups",
           "merge", "Segments", "Polyline", "bedding_lines", "voronoi_grains", "GrainLabels"]

# Pickles (checkpoints hold the scene's meshes) name the class taichi_fdem.mesh.TriMesh, the
# name checkpoint files of every format version use for it.
TriMesh.__module__ = __name__

# named constructors, scikit-fem style: TriMesh.disk(...), TriMesh.load(...), ...
TriMesh.rectangle = staticmethod(rectangle)
TriMesh.disk = staticmethod(disk)
TriMesh.annulus = staticmethod(annulus)
TriMesh.polygon = staticmethod(polygon)
TriMesh.plate_with_hole = staticmethod(plate_with_hole)
TriMesh.load = staticmethod(load)
TriMesh.load_groups = staticmethod(load_groups)
TriMesh.load_tagged = staticmethod(load_tagged)
TriMesh.merge = staticmethod(merge)

"""Scene files: a whole simulation (materials, bodies, constraints, solver, output) in TOML.

::

    spec = fdem.scenefile.load("examples/two_disks.toml")     # every key checked
    sim, settings = spec.build()                                # a Simulation and how to run it
    settings.run(sim)                                           # duration, video, VTU, checkpoint

or from the command line: ``taichi-fdem run examples/two_disks.toml``.

The file is read with the standard library's :mod:`tomllib` (``tomli`` on Python 3.10).  Every
key is checked: an unknown key is refused with the file, the line, the table it is in and the
closest allowed key; a value of the wrong type, sign or range is refused naming its key.
Errors are :class:`SceneFileError` (a ``ValueError``).

This module holds the key schemas (the reference below, with the defaults), the dotted-key
overrides of sweeps and the loader that checks a file into a :class:`SceneSpec`.  The TOML
reader, the line locator and the key checker are in :mod:`.toml_check`; :class:`SceneSpec`
(which builds the scene) and :class:`RunSettings` (which runs it) are in :mod:`.scenespec`.
All of them are importable from here.

Paths: files the scene *reads* (``bodies.file``) are relative to the scene file's folder;
files it *writes* (``output.video``, ``output.vtu``, ``output.checkpoint``,
``output.crack_events``) are relative to
the working directory.

Reference (all values SI; "—" = dimensionless; defaults in brackets)
---------------------------------------------------------------------

``[scene]``

=============  ========  ====================================================================
key            unit      meaning [default]
=============  ========  ====================================================================
gravity        m/s²      [g_x, g_y] [[0.0, -9.81]]
plane          —         "strain" or "stress" ["strain"]
thickness      m         out-of-plane thickness, > 0 [1.0]
=============  ========  ====================================================================

``[materials.NAME]`` (one table per material; bodies refer to it by NAME)

=====================  ======  ===============================================================
density                kg/m³   > 0 [2700.0]
young                  Pa      Young's modulus E, > 0 [30e9]
poisson                —       Poisson's ratio, −1 < ν < 0.5 [0.25]
friction               —       Coulomb friction coefficient μ ≥ 0 [0.0]
damping                —       viscous damping β, fraction of critical, in [0, 1] [0.0]
penalty                Pa      normal contact penalty p > 0 [10 × young]
tangential_penalty     Pa      tangential (stick) friction stiffness > 0 [penalty]
contact_damping        —       normal contact damping ratio ξ in [0, 1] [0.0]
tensile_strength       Pa      joints: tensile strength f_t > 0 (needed by ``fracture``) [none]
fracture_energy        J/m²    joints: mode I fracture energy G_I > 0 (needed by ``fracture``) [none]
cohesion               Pa      joints: cohesion c [f_t]
friction_angle         °       joints: internal friction angle φ_i [30]
fracture_energy_shear  J/m²    joints: mode II fracture energy G_II [5 × G_I]
joint_penalty          Pa      joints: penalty p_f [10 × young]
like                   —       a NAME of ``[materials]`` whose values this one starts from: the keys
                               given replace them (``Material.with_``) [none]
=====================  ======  ===============================================================

``[curves.NAME]`` (a load curve ``fdem.Curve``, piecewise linear, constant past its ends)

================  ======  =================================================================
times             s       strictly increasing times of the points ``Curve(times, values)``
values            —       the amplitude at each time (as many as times)
ramp              s       or: a ramp from 0 to 1 over this time, then 1 (``Curve.ramp``)
start             s       with ramp: the time the ramp starts [0.0]
================  ======  =================================================================

``[[bodies]]`` (one table per body; the mesh is a ``shape`` or a ``file``)

=====================  ======  ==============================================================
name                   —       unique name, used by constraints and sweep metrics ["body<i>"]
material               —       a NAME of ``[materials]`` (give it or ``materials``)
materials              —       material groups: {label = "NAME", ...}: with ``shape = "grains"`` one
                               material per mineral of ``minerals``; with ``file`` and ``groups``
                               one per group of the file (``add_body(groups=)``) [none]
shape                  —       "disk", "rectangle", "annulus", "polygon", "grains" or "plate_with_hole"
                               (or give ``file``)
file                   —       mesh file read by ``fdem.mesh.load`` (gmsh .msh, .vtu, ...)
cell_block             —       with ``file``: index of the one triangle cell block to use [all]
groups                 —       with ``file``: read its material groups (``fdem.mesh.load_tagged``),
                               one material each by ``materials`` [false]
group                  —       with ``file``: only this group of the file (``fdem.mesh.load_groups``;
                               its name, or its integer tag), one body per group as
                               ``fdem.mesh.scene_from_groups`` [none]
group_key              —       with ``groups`` or ``group``: the cell-data array of the group tags
                               [gmsh:physical]
grain_size             m       grains: mean grain edge length d > h (``fdem.mesh.voronoi_grains``)
seed                   —       grains: seed of the random grains [0]
minerals               —       grains: {name = proportion, ...}, the minerals' area shares [none]
outline                —       grains: "rectangle" or "disc" (width = height = the diameter) ["rectangle"]
relax                  —       grains: Lloyd iterations of the seeds [3]
radius                 m       disk: radius, > 0; plate_with_hole: the central hole's radius
width, height          m       rectangle, grains, plate_with_hole: size, > 0
pattern                —       rectangle: "alternating", "crossed" or "right" ["alternating"]
r_inner, r_outer       m       annulus: radii, 0 < r_inner < r_outer
layout                 —       disk, annulus: "symmetric" or "spiral" (``fdem.mesh.disk``) ["symmetric"]
vertices               m       polygon: [[x, y], ...], a simple polygon
engine                 —       polygon: the mesher, "builtin" or "gmsh" (``fdem.mesh.polygon``) ["builtin"]
h                      m       target element edge length, > 0 (required for disk, rectangle,
                               annulus, grains; plate_with_hole: the edge at the hole, graded
                               outwards; polygon: [none: the vertices alone are triangulated])
position               m       [x, y] where the mesh's area centroid is placed [mesh as built:
                               shapes centred on (0, 0), files as read]
velocity               m/s     [v_x, v_y] initial velocity [[0, 0]]
angular_velocity       rad/s   initial spin about the centroid, counter-clockwise [0.0]
rotation               rad     rotation about the centroid before placing, counter-clockwise [0.0]
fixed                  —       every node held still (floors, walls) [false]
prescribed_velocity    m/s     [v_x, v_y] every node moves at this velocity (platens) [none]
velocity_curve         —       a NAME of ``[curves]`` multiplying prescribed_velocity [none]
self_contact           —       the body's own triangles can contact each other [false]
fracture               —       where cohesive joints go (docs/theory/joints.md §7): true (every
                               interior edge), false, "interfaces" (edges between material
                               groups, grain boundaries), a table of a region of edge midpoints
                               {xmin, xmax, ymin, ymax, center, r_min, r_max} (placed coordinates
                               [m], as ``[[constraints]]``), of lines = [[[x, y], ...], ...] (edges
                               along them, in the mesh's own coordinates, as cracks) or of
                               line_group = "NAME" (a physical line group of the body's mesh file,
                               ``fdem.mesh.load_groups(..., lines=True)``), or a list of these [false]
cracks                 m       pre-existing open cracks (the same selectors as fracture but
                               "interfaces"): a list of polylines [[[x, y], ...], ...]
                               in the mesh's own coordinates (moved with the body by position and
                               rotation); a ``polygon`` body is meshed with edges along them,
                               other meshes need edges there already; or a region table (or a list
                               of them) of edge midpoints in placed coordinates [none]
crack_friction         —       friction coefficient μ ≥ 0 of the crack faces [material's]
weibull_modulus        —       Weibull modulus m > 0 of the joint strength (docs/theory/discontinuities.md §13.3) [none]
strength_cov           —       or: coefficient of variation of a normal joint strength [none]
strength_seed          —       seed of the joint-strength draws, ≥ 0 [0]
strength_floor         —       strength_cov: truncation of the factor below (``floor``) [0.05]
strength_scale_energy  —       the fracture energies scale with the strength factor [false]
=====================  ======  ==============================================================

A *region* (``[[constraints]]``, ``[[loads]]``, ``[[inject]]``, ``[[excavate]]``, ``[[joint_sets]]``,
``fracture`` and ``cracks`` tables) selects the points (nodes, edge midpoints, triangle
centroids) inside the box ``xmin ≤ x ≤ xmax``, ``ymin ≤ y ≤ ymax`` and the ring ``r_min ≤
|(x, y) − center| ≤ r_max`` (all bounds inclusive, absent = unbounded), in the initial, placed
coordinates [m]: the ``where(x, y)`` of the Python API.  At least one bound is required.

``[[constraints]]`` (prescribe the velocity of the nodes inside a region, in the initial positions)

================  ======  =================================================================
xmin, xmax        m       box along x, inclusive [−∞, +∞]; at least one bound is required
ymin, ymax        m       box along y, inclusive [−∞, +∞]
center            m       [x, y] centre of the ring r_min, r_max [[0, 0]]
r_min, r_max      m       ring about center: distance bounds, inclusive [0, +∞]
body              —       restrict to the nodes of this body [all bodies]
vx, vy            m/s     prescribed velocity component; an absent component stays free
                          (a roller); at least one is required
curve             —       a NAME of ``[curves]`` multiplying the velocity [none]
================  ======  =================================================================

``[[joint_sets]]`` (joints with their own properties, ``Scene.add_joint_set``, after all bodies)

=====================  ======  ===============================================================
name                   —       the set's name (required; not "default")
material               —       a NAME of ``[materials]`` giving the joint properties (required)
body                   —       only in this body [every body]
interfaces             —       the edges between material groups (grain boundaries) [false]
lines                  m       or: edges along these polylines [[[x, y], ...], ...] (placed
                               coordinates) [none]
xmin, xmax             m       or: a region of edge midpoints (and ymin, ymax, center, r_min,
                               r_max as ``[[constraints]]``)
ymin, ymax             m       region of edge midpoints along y
center                 m       centre of the region's ring
r_min, r_max           m       the region's ring
weibull_modulus        —       Weibull modulus of the set's joint strength [none]
strength_cov           —       or: coefficient of variation of a normal joint strength [none]
strength_seed          —       seed of the strength draws [0]
strength_floor         —       strength_cov: truncation below [0.05]
strength_scale_energy  —       the fracture energies scale with the strength factor [false]
=====================  ======  ===============================================================

``[[interactions]]`` (contact properties of a pair of materials, ``Scene.set_interaction``)

==================  ======  ===============================================================
materials           —       the pair ["a", "b"] of ``[materials]`` NAMEs (required)
friction            —       friction coefficient of the pair [the smaller]
penalty             Pa      normal contact penalty of the pair [the smaller]
tangential_penalty  Pa      tangential penalty of the pair [the smaller]
contact_damping     —       normal contact damping ratio of the pair [the smaller]
==================  ======  ===============================================================

``[[loads]]`` (``Scene.apply_pressure``, ``apply_traction``, ``apply_force``, ``absorbing_boundary``)

================  ======  =================================================================
kind              —       "pressure", "traction", "force" or "absorbing" (required)
pressure          Pa      pressure: normal follower pressure, positive pushes in
traction          Pa      traction: [t_x, t_y] of fixed direction on the initial edges
force             N/m     force: [F_x, F_y] at each selected node, per metre of thickness
body              —       only on this body [all bodies]
curve             —       a NAME of ``[curves]`` multiplying the load [none]
xmin, xmax        m       region of the loaded nodes (and ymin, ymax, center, r_min, r_max)
ymin, ymax        m       region along y
center            m       centre of the region's ring
r_min, r_max      m       the region's ring
================  ======  =================================================================

``[[initial_stress]]`` (in-situ stress, ``Scene.initial_stress``, tension positive)

================  ======  =================================================================
sxx, syy          Pa      σxx, σyy at y_ref (required)
sxy               Pa      σxy at y_ref [0.0]
body              —       only this body [all bodies]
gradient          Pa/m    [dσxx/dy, dσyy/dy] or [dσxx/dy, dσyy/dy, dσxy/dy] [none]
y_ref             m       height of the given stress [0.0]
================  ======  =================================================================

``[[excavate]]`` (``Simulation.remove`` during the run, in order of time)

================  ======  =================================================================
time              s       when, from the start of the run (after round(time / dt) steps) (required)
body              —       remove this body's triangles (with a region: those in it) [none]
xmin, xmax        m       region of triangle centroids removed (and ymin, ymax, center,
                          r_min, r_max)
ymin, ymax        m       region along y
center            m       centre of the region's ring
r_min, r_max      m       the region's ring
================  ======  =================================================================

``[fluid]`` (optional: a fluid in the cracks and broken joints, ``Scene.set_fluid``)

================  ======  =================================================================
density           kg/m³   reference density ρ > 0 [1000.0]
bulk_modulus      Pa      bulk modulus K > 0 [2.2e9]
viscosity         Pa·s    dynamic viscosity μ > 0 [1e-3]
aperture_min      m       residual hydraulic aperture, > 0 (required)
aperture_max      m       largest hydraulic aperture, > aperture_min [none]
initial_pressure  Pa      pressure of the fluid in the cracks at the start, ≥ 0 [0.0]
conduct           —       "broken" or "damaged": which joints conduct ["broken"]
================  ======  =================================================================

``[[inject]]`` (a source of the fracture network, ``Scene.inject``; needs ``[fluid]``)

================  ======  =================================================================
xmin, xmax        m       region of network nodes (initial positions), inclusive [−∞, +∞]; at
ymin, ymax        m       least one bound is required
center            m       centre of the region's ring
r_min, r_max      m       the region's ring
rate              m²/s    volume rate per unit thickness ≥ 0, shared among the nodes [none]
pressure          Pa      or: prescribed pressure ≥ 0 (a source or a drain) [none]
ramp              s       the rate or pressure rises linearly from 0 over this time [none]
curve             —       or: a NAME of ``[curves]`` multiplying the rate or pressure [none]
================  ======  =================================================================

``[solver]``

===============  ======  ===================================================================
duration         s       simulated time of ``run``, ≥ 0 (required)
dt               s       time step, > 0 [safety × estimated stable limit]
safety           —       fraction of the stable limit when dt is not given, in (0, 1] [0.2]
strategy         —       "auto", "serial" or "parallel" ["auto"]
buffer           m       contact detection buffer, ≥ 0 [¼ mean edge of contact triangles]
force_dt         —       accept a dt above the estimated stable limit [false]
check_overlap    —       warn when bodies overlap at the start [true]
joined_pairs     —       "joint" or "contact": who resists the overlap of triangles joined by
                         an undamaged joint (``Scene.build(joined_pairs=...)``) ["joint"]
handover_damage  —       joint damage in [0, 1] at which contact takes over a joined pair
                         (``Scene.build(handover_damage=...)``) [0]
quasi_static     —       local non-viscous damping coefficient α in [0, 1) of
                         ``Scene.build(quasi_static=α)``; 0 = off, 0.7 = ``True`` [0]
speed_limit      m/s     node speed that stops the run as unstable [2 × the largest c_p]
===============  ======  ===================================================================

``[checks]`` (the run's checks, ``fdem.Checks``)

===============  ======  ===================================================================
energy           —       the total energy must not rise [true]
energy_tol       —       by more than this fraction of the energy scale [0.1]
max_penetration  —       largest contact overlap over the element size; 0 = not checked [0.5]
every            —       steps between checks [adaptive]
===============  ======  ===================================================================

``[output]`` (all optional)

=============  ======  ===================================================================
video          —       video written while running: .mp4, .gif or a folder of PNGs [none]
fps            1/s     frames per second of the video [30]
frame_dt       s       simulated time between frames [duration / (5 s × fps)]
color_by       —       "body", "material", "speed", "displacement", "von_mises",
                       "max_principal", "min_principal", "damage" or "fluid_pressure"
                       (needs ``[fluid]``) ["body"]
width, height  px      video frame size [960, 540]
cracks         —       draw the broken joints on the video frames [false]
crack_events   —       CSV file of crack events, appended as joints break [none]
vtu            —       folder of a VTU series with a .pvd index (needs taichi_fdem.io.vtu)
vtu_every      —       write one VTU file every this many frames [1]
checkpoint     —       file written at the end of the run (needs Simulation.save)
history        —       CSV of the energy/reaction history (``fdem.History``) [none]
history_every  —       steps between history rows (``fdem.History(every=...)``) [about 200 rows]
=============  ======  ===================================================================

``[lab]`` (a standard lab test instead of ``[[bodies]]``, ``[[constraints]]``, ``[solver]`` and
``[output]``: ``taichi-fdem run`` runs the test of ``fdem.lab`` and prints its summary)

====================  ======  ===================================================================
test                  —       "ucs", "triaxial", "brazilian" or "direct_shear" (required)
material              —       a NAME of ``[materials]`` (or ``materials`` for grains)
width, height         m       ucs, triaxial, direct_shear: specimen size, > 0
diameter              m       brazilian: disc diameter, > 0
h                     m       element size, > 0 (required)
confinement           Pa      triaxial: lateral pressure σ3, > 0
normal_stress         Pa      direct_shear: normal stress σn, > 0
rate_transits         —       ucs, triaxial, direct_shear: P-wave transits of the specimen to the
                              expected peak (``rate_transits=``) [60]
load_time             —       brazilian: D/c_p transits to the expected peak (``load_time=``) [the test's]
joint                 —       direct_shear: the shear plane is a cohesive joint of the material
                              (``joint=True``), not a contact between two blocks [false]
samples               —       recorded samples of the curve [the test's default]
plane                 —       "strain" or "stress" ["strain"]
check                 —       "rate", "mesh" or "both": rerun at half the rate and/or h (``check=``) [none]
quasi_static          —       local damping α of the specimen; 0 = off (``quasi_static=``) [the test's]
safety                —       time-step safety (``safety=``) [the test's]
settle_transits       —       triaxial, direct_shear: transits of the confinement ramp [the test's]
max_strain            —       ucs, triaxial: largest axial strain [the test's]
stop_drop             —       ucs, triaxial: stop below this fraction of the peak [0.8]
handover_damage       —       ucs, triaxial: ``Scene.build(handover_damage=)`` [the test's]
penalty_factor        —       ucs, triaxial: joint penalty / E where the material leaves it unset [200]
joint_penalty_factor  —       brazilian: joint penalty / E where the material leaves it unset [50]
alpha_deg             °       brazilian: half-angle of the flattened loading arc [10]
max_time              —       brazilian: longest run, in loading times [3]
displacement          m       direct_shear: shear displacement [5 % of the width]
friction              —       direct_shear: friction of the interface [the materials']
lower_material        —       direct_shear: a NAME of ``[materials]`` for the lower block [material]
platen                —       ucs, triaxial, brazilian: a NAME of ``[materials]`` for the platens [the test's]
fracture              —       ucs, triaxial: joints on every edge [when the material can fracture]
weibull_modulus       —       brazilian: Weibull modulus of the joint strength [none]
strength_cov          —       brazilian: or the coefficient of variation of a normal strength [none]
strength_seed         —       brazilian: seed of the strength draws [0]
history               —       ucs, triaxial: CSV of the run's energy history [none]
materials             —       grains: {mineral = "NAME", ...}, a material per mineral (instead of material)
grain_size            m       ucs, triaxial, brazilian: a grain specimen (``fdem.mesh.voronoi_grains``,
                              a disc for brazilian) of this mean grain size > h [none: the test's mesh]
grain_seed            —       grains: seed of the random grains [0]
minerals              —       grains: {name = proportion, ...} [none: one material for every grain]
relax                 —       grains: Lloyd iterations of the seeds [3]
joint_sets            —       [[lab.joint_sets]] tables (name, material and interfaces = true, lines or
                              a region, as ``[[joint_sets]]``): the test's ``joint_sets=`` [none]
csv                   —       CSV file of the test's curve (``LabResult.to_csv``) [none]
video                 —       video of the test coloured by joint damage [none]
====================  ======  ===================================================================

A top-level ``description`` string is allowed (free text).

Order: the scene is built as bodies, ``[[joint_sets]]``, ``[[interactions]]``,
``[[constraints]]``, ``[[loads]]``, ``[[initial_stress]]``, ``[fluid]`` and ``[[inject]]``
(each kind in the file's order), which is the order a Python script of the same scene uses
when it adds the joint sets after the bodies.

Sanity bounds (a value beyond them is refused as a typo; products of it would overflow):
lengths (sizes, radii, ``h``, ``thickness``, ``buffer``) within [1e-9, 1e6] m, coordinates
within ±1e9 m, gravity components within ±1e6 m/s², speeds within ±1e5 m/s, ``duration``
≤ 1e9 s, video frames ≤ 16384 px and ≤ 1000 fps; material values as
``taichi_fdem.material.BOUNDS`` (E ≤ 1e16 Pa, 1e-6 ≤ ρ ≤ 1e6 kg/m³, ...).
"""
from __future__ import annotations

import os
import re

from ..engine.joints import HANDOVER_DAMAGE
from .toml_check import SceneFileError, _Checker, _Key, _suggest, read_toml  # noqa: F401 (re-exported)
from .scenespec import RunSettings, SceneSpec, _BoxSelector  # noqa: F401 (re-exported; old pickles name it here)

__all__ = ["SceneFileError", "SceneSpec", "RunSettings", "load", "loads", "read_toml", "apply_overrides"]


# ----------------------------------------------------------------------------------------------
# key schemas
# ----------------------------------------------------------------------------------------------
_F = lambda **kw: _Key("float", **kw)
_POS = lambda unit, **kw: _Key("float", unit=unit, lo=0.0, lo_open=True, **kw)
# sanity bounds (SI): beyond them a value is a typo by orders of magnitude, and products of it
# overflow a float64 (lengths: taichi_fdem.mesh.MAX_LENGTH / MAX_COORDINATE)
_LEN, _COORD, _SPEED, _ACCEL = 1e6, 1e9, 1e5, 1e6

SCENE_KEYS = {
    "gravity": _Key("vec2", (0.0, -9.81), "m/s²", hi=_ACCEL),
    "plane": _Key("choice", "strain", choices=("strain", "stress")),
    "thickness": _POS("m", default=1.0, hi=_LEN),
}
MATERIAL_KEYS = {
    "density": _F(default=2700.0, unit="kg/m³"),
    "young": _F(default=30e9, unit="Pa"),
    "poisson": _F(default=0.25),
    "friction": _F(default=0.0),
    "damping": _F(default=0.0),
    "penalty": _F(unit="Pa"),
    "tangential_penalty": _F(unit="Pa"),
    "contact_damping": _F(default=0.0),
    "tensile_strength": _F(unit="Pa"),
    "fracture_energy": _F(unit="J/m²"),
    "cohesion": _F(unit="Pa"),
    "friction_angle": _F(unit="°"),
    "fracture_energy_shear": _F(unit="J/m²"),
    "joint_penalty": _F(unit="Pa"),
    "like": _Key("str"),
}
BODY_KEYS = {
    "name": _Key("str"),
    "material": _Key("str"),
    "materials": _Key("names"),
    "shape": _Key("choice", choices=("disk", "rectangle", "annulus", "polygon", "grains", "plate_with_hole")),
    "file": _Key("str"),
    "cell_block": _Key("int", lo=0),
    "groups": _Key("bool", False),
    "group": _Key("str"),
    "group_key": _Key("str"),
    "radius": _POS("m"),
    "width": _POS("m"),
    "height": _POS("m"),
    "pattern": _Key("choice", "alternating", choices=("alternating", "crossed", "right")),
    "layout": _Key("choice", "symmetric", choices=("symmetric", "spiral")),
    "r_inner": _POS("m"),
    "r_outer": _POS("m"),
    "grain_size": _POS("m"),
    "seed": _Key("int", 0, lo=0),
    "minerals": _Key("weights"),
    "outline": _Key("choice", "rectangle", choices=("rectangle", "disc")),
    "relax": _Key("int", 3, lo=0, hi=1000),
    "vertices": _Key("vertices", unit="m"),
    "engine": _Key("choice", "builtin", choices=("builtin", "gmsh")),
    "h": _POS("m"),
    "position": _Key("vec2", unit="m", hi=_COORD),
    "velocity": _Key("vec2", (0.0, 0.0), "m/s", hi=_SPEED),
    "angular_velocity": _F(default=0.0, unit="rad/s", lo=-1e7, hi=1e7),
    "rotation": _F(default=0.0, unit="rad", lo=-1e6, hi=1e6),
    "fixed": _Key("bool", False),
    "prescribed_velocity": _Key("vec2", unit="m/s", hi=_SPEED),
    "velocity_curve": _Key("str"),
    "self_contact": _Key("bool", False),
    "fracture": _Key("edges", False),
    "cracks": _Key("cracks", unit="m"),
    "crack_friction": _Key("float", lo=0.0, hi=1e3),
    "weibull_modulus": _Key("float", lo=0.0, lo_open=True, hi=1e3),
    "strength_cov": _Key("float", lo=0.0, hi=10.0),
    "strength_seed": _Key("int", 0, lo=0),
    "strength_floor": _Key("float", 0.05, lo=0.0, lo_open=True, hi=0.999),
    "strength_scale_energy": _Key("bool", False),
}
#: mesh parameters of each built-in shape: (required, optional)
SHAPE_KEYS = {
    "disk": (("radius", "h"), ("layout",)),
    "rectangle": (("width", "height", "h"), ("pattern",)),
    "annulus": (("r_inner", "r_outer", "h"), ("layout",)),
    "polygon": (("vertices",), ("h", "engine")),
    "grains": (("width", "height", "grain_size", "h"), ("seed", "minerals", "outline", "relax")),
    "plate_with_hole": (("width", "height", "radius", "h"), ()),
    "file": (("file",), ("cell_block", "groups", "group", "group_key")),
}
_MESH_KEYS = {k for req, opt in SHAPE_KEYS.values() for k in req + opt}
#: a region of the plane (initial, placed coordinates): a box and/or a ring about a centre
REGION_KEYS = {
    "xmin": _F(unit="m"), "xmax": _F(unit="m"), "ymin": _F(unit="m"), "ymax": _F(unit="m"),
    "center": _Key("vec2", unit="m", hi=_COORD),
    "r_min": _F(unit="m", lo=0.0, hi=_COORD), "r_max": _F(unit="m", lo=0.0, hi=_COORD),
}
_BOUNDS = ("xmin", "xmax", "ymin", "ymax", "r_min", "r_max")
CONSTRAINT_KEYS = {
    **REGION_KEYS,
    "body": _Key("str"),
    "vx": _F(unit="m/s", lo=-_SPEED, hi=_SPEED), "vy": _F(unit="m/s", lo=-_SPEED, hi=_SPEED),
    "curve": _Key("str"),
}
CURVE_KEYS = {
    "times": _Key("floats", unit="s"),
    "values": _Key("floats"),
    "ramp": _POS("s", hi=1e9),
    "start": _F(default=0.0, unit="s", lo=-1e9, hi=1e9),
}
JOINT_SET_KEYS = {
    "name": _Key("str", required=True),
    "material": _Key("str", required=True),
    "body": _Key("str"),
    "interfaces": _Key("bool", False),
    "lines": _Key("polylines", unit="m"),
    **REGION_KEYS,
    "weibull_modulus": BODY_KEYS["weibull_modulus"],
    "strength_cov": BODY_KEYS["strength_cov"],
    "strength_seed": BODY_KEYS["strength_seed"],
    "strength_floor": BODY_KEYS["strength_floor"],
    "strength_scale_energy": BODY_KEYS["strength_scale_energy"],
}
#: a joint set of a lab test (``joint_sets=`` triples: no body, no strength spread)
LAB_JOINT_SET_KEYS = {k: v for k, v in JOINT_SET_KEYS.items() if k not in
                      ("body", "weibull_modulus", "strength_cov", "strength_seed", "strength_floor",
                       "strength_scale_energy")}
LOAD_KEYS = {
    "kind": _Key("choice", choices=("pressure", "traction", "force", "absorbing"), required=True),
    "pressure": _F(unit="Pa", lo=-1e15, hi=1e15),
    "traction": _Key("vec2", unit="Pa", hi=1e15),
    "force": _Key("vec2", unit="N/m", hi=1e15),
    "body": _Key("str"),
    "curve": _Key("str"),
    **REGION_KEYS,
}
#: the value key of each load kind
LOAD_VALUE = {"pressure": "pressure", "traction": "traction", "force": "force", "absorbing": None}
INITIAL_STRESS_KEYS = {
    "sxx": _F(unit="Pa", required=True, lo=-1e15, hi=1e15),
    "syy": _F(unit="Pa", required=True, lo=-1e15, hi=1e15),
    "sxy": _F(default=0.0, unit="Pa", lo=-1e15, hi=1e15),
    "body": _Key("str"),
    "gradient": _Key("floats", unit="Pa/m"),
    "y_ref": _F(default=0.0, unit="m", lo=-_COORD, hi=_COORD),
}
INTERACTION_KEYS = {
    "materials": _Key("strs", required=True),
    "friction": _F(lo=0.0, hi=1e6),
    "penalty": _POS("Pa", hi=1e16),
    "tangential_penalty": _POS("Pa", hi=1e16),
    "contact_damping": _F(lo=0.0, hi=1.0),
}
EXCAVATE_KEYS = {
    "time": _F(unit="s", lo=0.0, hi=1e9, required=True),
    "body": _Key("str"),
    **REGION_KEYS,
}
CHECK_KEYS = {
    "energy": _Key("bool", True),
    "energy_tol": _POS("", default=0.1, hi=1e6),
    "max_penetration": _F(default=0.5, lo=0.0, hi=1e6),
    "every": _Key("int", None, lo=1),
}
SOLVER_KEYS = {
    "duration": _F(unit="s", lo=0.0, hi=1e9, required=True),
    "dt": _POS("s"),
    "safety": _Key("float", 0.2, lo=0.0, lo_open=True, hi=1.0),
    "strategy": _Key("choice", "auto", choices=("auto", "serial", "parallel")),
    "buffer": _F(unit="m", lo=0.0, hi=_LEN),
    "force_dt": _Key("bool", False),
    "check_overlap": _Key("bool", True),
    "joined_pairs": _Key("choice", "joint", choices=("joint", "contact")),
    "handover_damage": _Key("float", HANDOVER_DAMAGE, lo=0.0, hi=1.0),
    "quasi_static": _Key("float", 0.0, lo=0.0, hi=0.999),
    "speed_limit": _POS("m/s", hi=1e9),
}
COLOR_BY = ("body", "material", "speed", "displacement", "von_mises", "max_principal", "min_principal", "damage",
            "fluid_pressure")
OUTPUT_KEYS = {
    "video": _Key("str"),
    "fps": _Key("int", 30, "1/s", lo=1, hi=1000),
    "frame_dt": _POS("s"),
    "color_by": _Key("choice", "body", choices=COLOR_BY),
    "width": _Key("int", 960, "px", lo=1, hi=16384),
    "height": _Key("int", 540, "px", lo=1, hi=16384),
    "cracks": _Key("bool", False),
    "crack_events": _Key("str"),
    "vtu": _Key("str"),
    "vtu_every": _Key("int", 1, lo=1),
    "checkpoint": _Key("str"),
    "history": _Key("str"),
    "history_every": _Key("int", None, lo=1),
}
LAB_KEYS = {
    "test": _Key("choice", choices=("ucs", "triaxial", "brazilian", "direct_shear"), required=True),
    "material": _Key("str"),
    "materials": _Key("names"),
    "width": _POS("m", hi=_LEN),
    "height": _POS("m", hi=_LEN),
    "diameter": _POS("m", hi=_LEN),
    "h": _POS("m", hi=_LEN, required=True),
    "confinement": _POS("Pa", hi=1e12),
    "normal_stress": _POS("Pa", hi=1e12),
    "rate_transits": _Key("float", 60.0, lo=0.0, lo_open=True, hi=1e6),
    "load_time": _Key("float", None, lo=0.0, lo_open=True, hi=1e6),
    "joint": _Key("bool", False),
    "samples": _Key("int", None, lo=10, hi=100000),
    "plane": _Key("choice", "strain", choices=("strain", "stress")),
    "check": _Key("choice", choices=("rate", "mesh", "both")),
    "quasi_static": _Key("float", None, lo=0.0, hi=0.999),
    "safety": _Key("float", None, lo=0.0, lo_open=True, hi=1.0),
    "settle_transits": _Key("float", None, lo=0.0, hi=1e6),
    "max_strain": _Key("float", None, lo=0.0, lo_open=True, hi=1.0),
    "stop_drop": _Key("float", None, lo=0.0, lo_open=True, hi=1.0),
    "handover_damage": _Key("float", None, lo=0.0, hi=1.0),
    "penalty_factor": _Key("float", None, lo=0.0, lo_open=True, hi=1e6),
    "joint_penalty_factor": _Key("float", None, lo=0.0, lo_open=True, hi=1e6),
    "alpha_deg": _Key("float", None, lo=0.0, hi=45.0),
    "max_time": _Key("float", None, lo=0.0, lo_open=True, hi=1e6),
    "displacement": _POS("m", hi=_LEN),
    "friction": _F(lo=0.0, hi=1e6),
    "lower_material": _Key("str"),
    "platen": _Key("str"),
    "fracture": _Key("bool"),
    "weibull_modulus": BODY_KEYS["weibull_modulus"],
    "strength_cov": BODY_KEYS["strength_cov"],
    "strength_seed": BODY_KEYS["strength_seed"],
    "history": _Key("str"),
    "grain_size": _POS("m", hi=_LEN),
    "grain_seed": _Key("int", 0, lo=0),
    "minerals": _Key("weights"),
    "relax": _Key("int", 3, lo=0, hi=1000),
    "joint_sets": _Key("joint_sets"),
    "csv": _Key("str"),
    "video": _Key("str"),
}
#: keys of each lab test: (required, optional) besides test, material, h, samples, plane, csv, video
_GRAINS = ("grain_size", "grain_seed", "minerals", "materials", "relax", "joint_sets")
_COMPRESSION = ("rate_transits", "check", "quasi_static", "safety", "settle_transits", "max_strain", "stop_drop",
                "handover_damage", "penalty_factor", "platen", "fracture", "history") + _GRAINS
LAB_TEST_KEYS = {
    "ucs": (("width", "height"), _COMPRESSION),
    "triaxial": (("width", "height", "confinement"), _COMPRESSION),
    "brazilian": (("diameter",), ("load_time", "check", "quasi_static", "safety", "alpha_deg", "max_time",
                                  "joint_penalty_factor", "platen", "weibull_modulus", "strength_cov",
                                  "strength_seed") + _GRAINS),
    "direct_shear": (("width", "height", "normal_stress"), ("rate_transits", "joint", "settle_transits", "safety",
                                                            "displacement", "friction", "lower_material")),
}
FLUID_KEYS = {
    "density": _POS("kg/m³", default=1000.0),
    "bulk_modulus": _POS("Pa", default=2.2e9),
    "viscosity": _POS("Pa·s", default=1e-3),
    "aperture_min": _POS("m", hi=_LEN, required=True),
    "aperture_max": _POS("m", hi=_LEN),
    "initial_pressure": _F(default=0.0, unit="Pa", lo=0.0),
    "conduct": _Key("choice", "broken", choices=("broken", "damaged")),
}
INJECT_KEYS = {
    **REGION_KEYS,
    "rate": _F(unit="m²/s", lo=0.0),
    "pressure": _F(unit="Pa", lo=0.0),
    "ramp": _POS("s"),
    "curve": _Key("str"),
}
TOP_KEYS = ("description", "scene", "materials", "curves", "bodies", "joint_sets", "interactions", "constraints",
            "loads", "initial_stress", "fluid", "inject", "excavate", "solver", "checks", "output", "lab")

#: the arrays of tables [[...]]
_ARRAY_TABLES = ("bodies", "joint_sets", "interactions", "constraints", "loads", "initial_stress", "inject", "excavate")

# ----------------------------------------------------------------------------------------------
# overrides (sweeps)
# ----------------------------------------------------------------------------------------------
def apply_overrides(data: dict, overrides: dict, path: str = "scene file") -> dict:
    """Set dotted keys of a parsed scene file, e.g. ``{"materials.rock.friction": 0.3,
    "bodies.block.velocity": [1.0, 0.0], "solver.safety": 0.1}``.

    In ``bodies.X.key`` and ``constraints.X.key``, X is a body name or an index.  The tables
    on the way must exist; the last key may be new (it is checked like any key afterwards).
    Returns {path tuple: dotted name} of what was set (for error messages).
    """
    set_paths = {}
    for dotted, value in overrides.items():
        if not isinstance(dotted, str) or not dotted:
            raise SceneFileError(f"{path}: override key must be a dotted string, got {dotted!r}")
        parts = dotted.split(".")
        node, real = data, []
        for depth, part in enumerate(parts[:-1]):
            if isinstance(node, list):
                idx = None
                if part.isdigit() and int(part) < len(node):
                    idx = int(part)
                else:
                    names = [e.get("name", f"body{i}") if isinstance(e, dict) else None for i, e in enumerate(node)]
                    if part in names:
                        idx = names.index(part)
                if idx is None:
                    raise SceneFileError(f"{path}: override {dotted!r}: no element {part!r} in "
                                         f"[[{'.'.join(parts[:depth])}]]{_suggest(part, [n for n in names if n])} "
                                         f"(give a name or an index 0..{len(node) - 1})")
                node = node[idx]
                real.append(idx)
            elif isinstance(node, dict):
                if part not in node:
                    allowed = list(node) if depth else list(TOP_KEYS)
                    if depth == 0 and part in TOP_KEYS and part not in _ARRAY_TABLES + ("materials", "curves"):
                        node[part] = {}
                    else:
                        raise SceneFileError(f"{path}: override {dotted!r}: no table {'.'.join(parts[:depth + 1])!r}"
                                             f" in the scene{_suggest(part, allowed)}")
                node = node[part]
                real.append(part)
            else:
                raise SceneFileError(f"{path}: override {dotted!r}: {'.'.join(parts[:depth])!r} is not a table")
        if not isinstance(node, dict):
            raise SceneFileError(f"{path}: override {dotted!r}: {'.'.join(parts[:-1])!r} is not a table")
        node[parts[-1]] = value
        set_paths[tuple(real) + (parts[-1],)] = dotted
    return set_paths


# ----------------------------------------------------------------------------------------------
# loading
# ----------------------------------------------------------------------------------------------
def load(path, overrides: dict | None = None) -> SceneSpec:
    """Read and check a scene file; :class:`SceneFileError` names the file, line, table and key.

    ``overrides`` = {dotted key: value} replaces values of the file (see :func:`apply_overrides`),
    as parameter sweeps do.
    """
    path = os.fspath(path)
    data, text = read_toml(path)
    return loads(data, text, path, overrides)


def loads(data: dict, text: str = "", path: str = "<scene>", overrides: dict | None = None) -> SceneSpec:
    """Check already parsed TOML ``data`` (``text`` is used to find line numbers)."""
    import copy
    data = copy.deepcopy(data)
    overridden = apply_overrides(data, overrides, path) if overrides else {}
    ck = _Checker(path, text, overridden)
    base_dir = os.path.dirname(os.path.abspath(path)) if path != "<scene>" else os.getcwd()

    ck.keys(data, TOP_KEYS, ())
    description = data.get("description", "")
    if not isinstance(description, str):
        raise ck.error(("description",), f"description must be a string, got {description!r}")

    scene_t = ck.table(data.get("scene", {}), ("scene",), "gravity, plane, thickness")
    ck.keys(scene_t, SCENE_KEYS, ("scene",))
    scene = ck.values(scene_t, SCENE_KEYS, ("scene",))

    # materials
    from ..material import Material
    mats_t = ck.table(data.get("materials", {}), ("materials",), "one [materials.NAME] table per material")
    if not mats_t:
        raise SceneFileError(f"{path}: no materials: add a [materials.NAME] table (density, young, poisson, ...)")
    materials = {}
    pending = dict(mats_t)
    while pending:                          # a material "like" another is made after it
        name = next((n for n, mt in pending.items() if not (isinstance(mt, dict) and mt.get("like") in pending)),
                    None)
        if name is None:
            name = next(iter(pending))
            raise ck.error(("materials", name, "like"), f"materials refer to each other in a loop through 'like': "
                           f"{', '.join(pending)}")
        mt = pending.pop(name)
        mp = ("materials", name)
        ck.table(mt, mp, "density, young, poisson, friction, ...")
        ck.keys(mt, MATERIAL_KEYS, mp)
        vals = {k: v for k, v in ck.values(mt, MATERIAL_KEYS, mp).items() if v is not None}
        like = vals.pop("like", None)
        try:
            if like is not None:
                if like not in materials:
                    raise ck.error(mp + ("like",), f"unknown material {like!r}{_suggest(like, mats_t)}; defined: "
                                   f"{', '.join(mats_t)}")
                vals = {k: v for k, v in vals.items() if k in mt}      # only the keys given replace the base's
                materials[name] = materials[like].with_(**vals, name=name)
            else:
                materials[name] = Material(**vals, name=name)
        except (ValueError, TypeError) as exc:
            bad = next((k for k in MATERIAL_KEYS if re.search(rf"\b{k}\b", str(exc)) and k in mt), None)
            raise ck.error(mp + ((bad,) if bad else ()), str(exc), table=mp) from None

    materials = {n: materials[n] for n in mats_t}      # in the file's order
    curves = _curve_tables(ck, data)

    if "lab" in data:
        return SceneSpec(path=path, scene=scene, materials=materials, bodies=[], constraints=[], solver={},
                         output={}, description=description, lab=_lab_table(ck, data, materials), curves=curves,
                         _checker=ck)

    # bodies
    bodies_t = data.get("bodies", [])
    if not isinstance(bodies_t, list) or not bodies_t:
        raise ck.error(("bodies",), "no bodies: add at least one [[bodies]] table (material and a shape or file)",
                       table=())
    bodies, names = [], set()
    for i, bt in enumerate(bodies_t):
        bp = ("bodies", i)
        ck.table(bt, bp, "a body")
        ck.keys(bt, BODY_KEYS, bp)
        b = ck.values(bt, BODY_KEYS, bp)
        b["name"] = b["name"] or f"body{i}"
        if b["name"] in names:
            raise ck.error(bp + ("name",), f"body name {b['name']!r} is used twice; names must be unique")
        names.add(b["name"])
        if ("material" in bt) == ("materials" in bt):
            raise ck.error(bp, f"body {b['name']!r}: give exactly one of material = \"NAME\" or materials = "
                           f"{{label = \"NAME\", ...}} (material groups)", table=bp)
        for label, mname in ({"": b["material"]} if b["material"] is not None else b["materials"]).items():
            if mname not in materials:
                key = ("material",) if b["material"] is not None else ("materials",)
                raise ck.error(bp + key, f"unknown material {mname!r}{_suggest(mname, materials)}"
                               f"{' (group ' + repr(label) + ')' if label else ''}; defined: {', '.join(materials)}")
        if ("shape" in bt) == ("file" in bt):
            raise ck.error(bp, f"body {b['name']!r}: give exactly one of shape = \"disk\"|\"rectangle\"|\"annulus\"|"
                           f"\"polygon\"|\"grains\"|\"plate_with_hole\" or file = \"mesh.msh\"", table=bp)
        shape = b["shape"] or "file"
        b["shape"] = shape
        required, optional = SHAPE_KEYS[shape]
        for k in _MESH_KEYS & set(bt):
            if k not in required + optional:
                raise ck.error(bp + (k,), f"key {k!r} does not apply to {'a mesh file' if shape == 'file' else shape!r};"
                               f" its mesh keys are: {', '.join(required + optional)}")
        for k in required:
            if k not in bt:
                raise ck.error(bp + ((k,) if "shape" not in bt else ("shape",)),
                               f"body {b['name']!r}: {shape} needs {k!r}"
                               + (f" [{BODY_KEYS[k].unit}]" if BODY_KEYS[k].unit else ""), table=bp)
        if b["materials"] is not None:
            if shape == "grains" and b["minerals"] is None:
                raise ck.error(bp + ("materials",), "materials = {mineral = \"NAME\"} needs minerals = {name = "
                               "proportion, ...}; without minerals give one material = \"NAME\" for every grain")
            if shape == "grains" and set(b["materials"]) != set(b["minerals"]):
                raise ck.error(bp + ("materials",), f"materials must name one material for each mineral: minerals "
                               f"{sorted(b['minerals'])}, materials for {sorted(b['materials'])}")
            if shape == "file" and not b["groups"]:
                raise ck.error(bp + ("materials",), "materials = {label = \"NAME\"} maps the material groups of "
                               "the mesh file: it needs groups = true")
            if shape not in ("grains", "file"):
                raise ck.error(bp + ("materials",), f"a {shape!r} mesh has one material group: give material = "
                               f"\"NAME\" (materials = {{...}} is for grains and for mesh files with groups = true)")
        elif shape == "file" and b["groups"]:
            raise ck.error(bp + ("groups",), "groups = true needs materials = {label = \"NAME\", ...}, one "
                           "material per group of the file")
        if "group_key" in bt and not b["groups"] and b["group"] is None:
            raise ck.error(bp + ("group_key",), "group_key needs groups = true or group = \"NAME\"")
        if b["group"] is not None and (b["groups"] or "cell_block" in bt):
            raise ck.error(bp + ("group",), "group = \"NAME\" (one group of the file as the body) goes with "
                           "neither groups = true nor cell_block")
        if shape == "grains" and b["h"] >= b["grain_size"]:
            raise ck.error(bp + ("h",), f"h ({b['h']} m) must be smaller than grain_size ({b['grain_size']} m)")
        if shape == "grains" and b["outline"] == "disc" and b["width"] != b["height"]:
            raise ck.error(bp + ("height",), f"outline = \"disc\": width is the diameter and height must equal it "
                           f"(got {b['width']} and {b['height']} m)")
        if shape == "annulus" and b["r_inner"] >= b["r_outer"]:
            raise ck.error(bp + ("r_inner",), f"r_inner ({b['r_inner']} m) must be < r_outer ({b['r_outer']} m)")
        if shape == "file":
            f = b["file"] if os.path.isabs(b["file"]) else os.path.join(base_dir, b["file"])
            if not os.path.isfile(f):
                raise ck.error(bp + ("file",), f"mesh file {b['file']!r} not found (looked for {f}; paths are "
                               f"relative to the scene file's folder)")
            b["file"] = f
        _strength_keys(ck, bt, b, bp)
        b["fracture"] = _edge_selector(ck, bt.get("fracture", False), bp + ("fracture",))
        b["cracks"], b["crack_regions"] = _cracks(ck, bt.get("cracks"), bp + ("cracks",))
        for key in ("fracture", "crack_regions"):
            v = b[key]
            if shape != "file" and any(isinstance(t, dict) and t.get("line_group") is not None
                                       for t in (v if isinstance(v, list) else [v])):
                raise ck.error(bp + ("fracture" if key == "fracture" else "cracks",), "line_group selects edges "
                               "along a line group of the body's mesh file: it needs file")
        mnames = [b["material"]] if b["material"] is not None else list(b["materials"].values())
        if b["fracture"] is not False or b["weibull_modulus"] is not None or b["strength_cov"] is not None:
            for mname in mnames:
                if not materials[mname].can_fracture:
                    raise ck.error(bp + ("fracture",), f"body {b['name']!r}: joints need tensile_strength and "
                                   f"fracture_energy in [materials.{mname}]")
        if b["velocity_curve"] is not None:
            _known_curve(ck, curves, b["velocity_curve"], bp + ("velocity_curve",))
            if b["prescribed_velocity"] is None:
                raise ck.error(bp + ("velocity_curve",), "velocity_curve multiplies prescribed_velocity: give "
                               "prescribed_velocity = [vx, vy]")
        if b["fixed"] and b["prescribed_velocity"] is not None:
            raise ck.error(bp + ("prescribed_velocity",), "give either fixed = true or prescribed_velocity, not both")
        bodies.append(b)

    # constraints
    cons_t = data.get("constraints", [])
    if not isinstance(cons_t, list):
        raise ck.error(("constraints",), "constraints must be an array of tables [[constraints]]", table=())
    constraints = []
    for k, ct in enumerate(cons_t):
        cp = ("constraints", k)
        ck.table(ct, cp, "a box selector and a velocity")
        ck.keys(ct, CONSTRAINT_KEYS, cp)
        c = ck.values(ct, CONSTRAINT_KEYS, cp)
        _check_region(ck, c, cp, "the region of nodes to constrain")
        if c["curve"] is not None:
            _known_curve(ck, curves, c["curve"], cp + ("curve",))
        if c["vx"] is None and c["vy"] is None:
            raise ck.error(cp, "give vx and/or vy [m/s] (an absent component stays free)", table=cp)
        if c["body"] is not None and c["body"] not in names:
            raise ck.error(cp + ("body",), f"unknown body {c['body']!r}{_suggest(c['body'], names)}")
        constraints.append(c)

    fluid, injections = _fluid_tables(ck, data, curves)
    joint_sets = _joint_set_tables(ck, data, materials, names)
    interactions = _interaction_tables(ck, data, materials)
    loads = _load_tables(ck, data, names, curves)
    initial_stress = _initial_stress_tables(ck, data, names)
    excavations = _excavate_tables(ck, data, names)
    checks_t = ck.table(data.get("checks", {}), ("checks",), "energy, energy_tol, max_penetration, every")
    ck.keys(checks_t, CHECK_KEYS, ("checks",))
    checks = ck.values(checks_t, CHECK_KEYS, ("checks",))

    solver_t = ck.table(data.get("solver", {}), ("solver",), "duration, dt, safety, ...")
    ck.keys(solver_t, SOLVER_KEYS, ("solver",))
    if "duration" not in solver_t:
        raise SceneFileError(f"{ck.where(('solver',))}: [solver] missing required key 'duration' "
                             f"(simulated time of the run, s)")
    solver = ck.values(solver_t, SOLVER_KEYS, ("solver",))
    for k, e in enumerate(excavations):
        if e["time"] > solver["duration"]:
            raise ck.error(("excavate", k, "time"), f"time ({e['time']} s) is after the end of the run "
                           f"([solver] duration = {solver['duration']} s)")

    output_t = ck.table(data.get("output", {}), ("output",), "video, fps, vtu, ...")
    ck.keys(output_t, OUTPUT_KEYS, ("output",))
    output = ck.values(output_t, OUTPUT_KEYS, ("output",))
    if output["vtu"] is not None:
        import importlib.util
        if importlib.util.find_spec("taichi_fdem.io.vtu") is None:
            raise ck.error(("output", "vtu"), "VTU output needs taichi_fdem.io.vtu, which this version does not have")
    if output["checkpoint"] is not None:
        from ..sim.simulation import Simulation
        if not hasattr(Simulation, "save"):
            raise ck.error(("output", "checkpoint"), "checkpoints need Simulation.save, which this version does not have")
    if "cracks" in output_t and output["cracks"] and output["video"] is None:
        raise ck.error(("output", "cracks"), "cracks = true draws the broken joints on the video: it needs video = \"...\"")
    if output["color_by"] == "fluid_pressure" and "fluid" not in data:
        raise ck.error(("output", "color_by"), "color_by = \"fluid_pressure\" colours the fluid in the fractures: "
                       "it needs a [fluid] table")
    if "history_every" in output_t and output["history"] is None:
        raise ck.error(("output", "history_every"), "history_every needs history = \"file.csv\"")
    if "vtu_every" in output_t and output["vtu"] is None:
        raise ck.error(("output", "vtu_every"), "vtu_every needs vtu = \"folder\"")

    return SceneSpec(path=path, scene=scene, materials=materials, bodies=bodies, constraints=constraints,
                     solver=solver, output=output, description=description, fluid=fluid, injections=injections,
                     curves=curves, joint_sets=joint_sets, interactions=interactions, loads=loads,
                     initial_stress=initial_stress, excavations=excavations, checks=checks, _checker=ck)


def _lab_table(ck, data: dict, materials: dict) -> dict:
    """The checked ``[lab]`` table: the test's keys resolved, the others refused."""
    for other in ("bodies", "constraints", "fluid", "inject", "solver", "output", "joint_sets", "interactions",
                  "loads", "initial_stress", "excavate", "checks"):
        if other in data:
            raise ck.error((other,), f"a scene file with [lab] runs a standard test: it has no [{other}] "
                           "(the test builds its specimen, loading and run)", table=())
    lab_t = ck.table(data["lab"], ("lab",), "test, material, h, ...")
    ck.keys(lab_t, LAB_KEYS, ("lab",))
    if "test" not in lab_t:
        raise ck.error(("lab",), "[lab] needs 'test'", table=("lab",))
    if ("material" in lab_t) == ("materials" in lab_t):
        raise ck.error(("lab",), "[lab] needs exactly one of material = \"NAME\" or materials = {mineral = "
                       "\"NAME\", ...} (grains)", table=("lab",))
    lab = ck.values(lab_t, LAB_KEYS, ("lab",))
    for label, mname in ({"": lab["material"]} if lab["material"] is not None else lab["materials"]).items():
        if mname not in materials:
            key = ("material",) if lab["material"] is not None else ("materials",)
            raise ck.error(("lab",) + key, f"unknown material {mname!r}{_suggest(mname, materials)}"
                           f"{' (mineral ' + repr(label) + ')' if label else ''}; defined: {', '.join(materials)}")
    required, optional = LAB_TEST_KEYS[lab["test"]]
    specific = {k for req, opt in LAB_TEST_KEYS.values() for k in req + opt}
    for k in specific & set(lab_t):
        if k not in required + optional:
            raise ck.error(("lab", k), f"key {k!r} does not apply to the {lab['test']!r} test; its keys are: "
                           f"{', '.join(required + optional)}")
    for k in required:
        if k not in lab_t:
            raise ck.error(("lab",), f"the {lab['test']!r} test needs {k!r} [{LAB_KEYS[k].unit}]", table=("lab",))
    for k in ("lower_material", "platen"):
        if lab[k] is not None and lab[k] not in materials:
            raise ck.error(("lab", k), f"unknown material {lab[k]!r}{_suggest(lab[k], materials)}; defined: "
                           f"{', '.join(materials)}")
    if lab["weibull_modulus"] is not None and lab["strength_cov"] is not None:
        raise ck.error(("lab", "strength_cov"), "give either weibull_modulus or strength_cov, not both")
    if "strength_seed" in lab_t and lab["weibull_modulus"] is None and lab["strength_cov"] is None:
        raise ck.error(("lab", "strength_seed"), "strength_seed needs weibull_modulus or strength_cov")
    for k in ("grain_seed", "minerals", "relax", "materials"):
        if k in lab_t and lab["grain_size"] is None:
            raise ck.error(("lab", k), f"{k} belongs to a grain specimen: it needs grain_size [m]")
    if lab["materials"] is not None:
        if lab["minerals"] is None or set(lab["materials"]) != set(lab["minerals"]):
            raise ck.error(("lab", "materials"), "materials must name one material for each mineral of minerals = "
                           "{name = proportion, ...}")
    if lab["grain_size"] is not None and lab["h"] >= lab["grain_size"]:
        raise ck.error(("lab", "h"), f"h ({lab['h']} m) must be smaller than grain_size ({lab['grain_size']} m)")
    if lab["grain_size"] is not None and lab["check"] in ("mesh", "both"):
        raise ck.error(("lab", "check"), "check = \"mesh\" refines the test's own mesh: a grain specimen cannot be "
                       "refined here (use \"rate\")")
    if lab["joint_sets"] is not None:
        lab["joint_sets"] = _joint_set_list(ck, lab["joint_sets"], ("lab", "joint_sets"), materials, None,
                                            LAB_JOINT_SET_KEYS)
    if lab["test"] == "brazilian":
        for mname in ([lab["material"]] if lab["material"] is not None else lab["materials"].values()):
            if not materials[mname].can_fracture:
                key = "material" if lab["material"] is not None else "materials"
                raise ck.error(("lab", key), f"the brazilian test needs tensile_strength and fracture_energy in "
                               f"[materials.{mname}]")
    return {k: v for k, v in lab.items() if k in ("test", "material", "h", "samples", "plane", "csv", "video")
            or k in required + optional}


def _fluid_tables(ck, data: dict, curves: dict):
    """The checked ``[fluid]`` table (None without one) and ``[[inject]]`` list."""
    fluid = None
    if "fluid" in data:
        ft = ck.table(data["fluid"], ("fluid",), "density, bulk_modulus, viscosity, aperture_min, ...")
        ck.keys(ft, FLUID_KEYS, ("fluid",))
        if "aperture_min" not in ft:
            raise ck.error(("fluid",), "[fluid] needs aperture_min [m] (the residual hydraulic aperture)",
                           table=("fluid",))
        fluid = ck.values(ft, FLUID_KEYS, ("fluid",))
        if fluid["aperture_max"] is not None and fluid["aperture_max"] <= fluid["aperture_min"]:
            raise ck.error(("fluid", "aperture_max"), f"aperture_max ({fluid['aperture_max']} m) must be > "
                           f"aperture_min ({fluid['aperture_min']} m)")
        from ..material import Fluid
        try:
            Fluid(density=fluid["density"], bulk_modulus=fluid["bulk_modulus"], viscosity=fluid["viscosity"])
        except (ValueError, TypeError) as exc:
            raise ck.error(("fluid",), str(exc), table=("fluid",)) from None
    inj_t = data.get("inject", [])
    if not isinstance(inj_t, list):
        raise ck.error(("inject",), "inject must be an array of tables [[inject]]", table=())
    if inj_t and fluid is None:
        raise ck.error(("inject",), "[[inject]] needs a [fluid] table (the fluid of the fracture network)", table=())
    injections = []
    for k, it in enumerate(inj_t):
        ip = ("inject", k)
        ck.table(it, ip, "a box of network nodes and a rate or a pressure")
        ck.keys(it, INJECT_KEYS, ip)
        c = ck.values(it, INJECT_KEYS, ip)
        _check_region(ck, c, ip, "the region of network nodes")
        if c["ramp"] is not None and c["curve"] is not None:
            raise ck.error(ip + ("curve",), "give either ramp or curve, not both")
        if c["curve"] is not None:
            _known_curve(ck, curves, c["curve"], ip + ("curve",))
        if (c["rate"] is None) == (c["pressure"] is None):
            raise ck.error(ip, "give exactly one of rate [m²/s] or pressure [Pa]", table=ip)
        injections.append(c)
    return fluid, injections


# ----------------------------------------------------------------------------------------------
# regions, edge selectors, curves and the tables that use them
# ----------------------------------------------------------------------------------------------
def _check_region(ck, c: dict, path: tuple, what: str, required: bool = True) -> bool:
    """Check the region keys of the resolved table ``c``; True when it has a bound."""
    if all(c[k] is None for k in _BOUNDS):
        if c.get("center") is not None:
            raise ck.error(path + ("center",), "center needs r_min and/or r_max [m] (the ring about it)")
        if required:
            raise ck.error(path, f"give at least one of xmin, xmax, ymin, ymax, r_min, r_max [m] ({what})", table=path)
        return False
    for lo, hi in (("xmin", "xmax"), ("ymin", "ymax"), ("r_min", "r_max")):
        if c[lo] is not None and c[hi] is not None and c[lo] > c[hi]:
            raise ck.error(path + (lo,), f"{lo} ({c[lo]} m) must be <= {hi} ({c[hi]} m)")
    if c.get("center") is not None and c["r_min"] is None and c["r_max"] is None:
        raise ck.error(path + ("center",), "center needs r_min and/or r_max [m] (the ring about it)")
    return True


def region_of(c: dict):
    """The region keys of a resolved table (None where absent)."""
    return {k: c.get(k) for k in REGION_KEYS}


_EDGE_TABLE_KEYS = {**REGION_KEYS, "lines": _Key("polylines", unit="m"), "line_group": _Key("str")}


def _edge_table(ck, t, path: tuple, keys=None) -> dict:
    keys = _EDGE_TABLE_KEYS if keys is None else keys
    ck.table(t, path, "a region (xmin, ..., r_max), lines = [[[x, y], ...], ...] or line_group = \"NAME\"")
    ck.keys(t, keys, path)
    v = ck.values(t, keys, path)
    other = [k for k in ("lines", "line_group") if v.get(k) is not None]
    has_region = _check_region(ck, v, path, "the region of edge midpoints", required=not other)
    if len(other) + has_region > 1:
        raise ck.error(path + (other[-1],), "give one of a region (xmin, ..., r_max), lines or line_group",
                       table=path)
    return v


def _edge_selector(ck, value, path: tuple):
    """``fracture``: true/false, "interfaces", a table (a region of edge midpoints or lines) or a list of
    "interfaces" and tables; returned checked (tables resolved)."""
    if isinstance(value, bool):
        return value
    if value == "interfaces":
        return value
    if isinstance(value, dict):
        return _edge_table(ck, value, path)
    if isinstance(value, list) and value and all(v == "interfaces" or isinstance(v, dict) for v in value):
        return [v if v == "interfaces" else _edge_table(ck, v, path + (i,)) for i, v in enumerate(value)]
    raise ck.error(path, f"{path[-1]} must be true, false, \"interfaces\", a table {{xmin = ..., r_max = ...}} or "
                   f"{{lines = [...]}}, or a list of these, got {value!r}")


def _cracks(ck, value, path: tuple):
    """``cracks``: polylines in the mesh's coordinates, or a region table (or a list of them) of
    edge midpoints in placed coordinates.  Returns (polylines or None, region list or None)."""
    if value is None:
        return None, None
    if isinstance(value, dict):
        value = [value]
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        keys = {**REGION_KEYS, "line_group": _Key("str")}
        return None, [_edge_table(ck, t, path + (i,) if len(value) > 1 else path, keys) for i, t in enumerate(value)]
    return ck.value({path[-1]: value}, path[-1], _Key("polylines", unit="m"), path[:-1]), None


def _strength_keys(ck, raw: dict, v: dict, path: tuple) -> None:
    if v["weibull_modulus"] is not None and v["strength_cov"] is not None:
        raise ck.error(path + ("strength_cov",), "give either weibull_modulus or strength_cov, not both")
    for k in ("strength_seed", "strength_scale_energy"):
        if k in raw and v["weibull_modulus"] is None and v["strength_cov"] is None:
            raise ck.error(path + (k,), f"{k} needs weibull_modulus or strength_cov")
    if "strength_floor" in raw and v["strength_cov"] is None:
        raise ck.error(path + ("strength_floor",), "strength_floor is the truncation of strength_cov: it needs "
                       "strength_cov")


def strength_of(v: dict):
    """The ``strength=`` of the resolved body or joint-set table ``v`` (None without one)."""
    from ..discontinuity import NormalStrength, Weibull
    if v.get("weibull_modulus") is not None:
        return Weibull(v["weibull_modulus"], seed=v["strength_seed"],
                       scale_energy=v.get("strength_scale_energy") or False)
    if v.get("strength_cov") is not None:
        return NormalStrength(v["strength_cov"], seed=v["strength_seed"],
                              floor=v.get("strength_floor") or 0.05,
                              scale_energy=v.get("strength_scale_energy") or False)
    return None


def _known_curve(ck, curves: dict, name: str, path: tuple) -> None:
    if name not in curves:
        raise ck.error(path, f"unknown curve {name!r}{_suggest(name, curves)}; defined: "
                       f"{', '.join(curves) or 'none (add a [curves.NAME] table)'}")


def _curve_tables(ck, data: dict) -> dict:
    """{name: {"times": [...], "values": [...]}} of the ``[curves.NAME]`` tables (ramps resolved as
    ``Curve.ramp``)."""
    curves_t = ck.table(data.get("curves", {}), ("curves",), "one [curves.NAME] table per load curve")
    curves = {}
    for name, t in curves_t.items():
        cp = ("curves", name)
        ck.table(t, cp, "times and values, or ramp")
        ck.keys(t, CURVE_KEYS, cp)
        c = ck.values(t, CURVE_KEYS, cp)
        if c["ramp"] is not None:
            for k in ("times", "values"):
                if k in t:
                    raise ck.error(cp + (k,), "give either ramp (and start) or times and values, not both")
        else:
            if c["times"] is None or c["values"] is None:
                raise ck.error(cp, f"curve {name!r}: give times [s] and values, or ramp [s]", table=cp)
            if "start" in t:
                raise ck.error(cp + ("start",), "start goes with ramp (times and values give the whole curve)")
        from ..scene import Curve
        try:
            curve = Curve.ramp(c["ramp"], c["start"], name=name) if c["ramp"] is not None \
                else Curve(c["times"], c["values"], name=name)
        except ValueError as exc:
            raise ck.error(cp + ("times",), str(exc)) from None
        curves[name] = {"times": curve.times.tolist(), "values": curve.values.tolist()}
    return curves


def _array(ck, data: dict, key: str, what: str) -> list:
    t = data.get(key, [])
    if not isinstance(t, list):
        raise ck.error((key,), f"{key} must be an array of tables [[{key}]] ({what})", table=())
    return t


def _known_body(ck, names, c: dict, path: tuple) -> None:
    if c.get("body") is not None and c["body"] not in names:
        raise ck.error(path + ("body",), f"unknown body {c['body']!r}{_suggest(c['body'], names)}")


def _joint_set_tables(ck, data: dict, materials: dict, names) -> list:
    return _joint_set_list(ck, _array(ck, data, "joint_sets", "name, material and the edges"), ("joint_sets",),
                           materials, names, JOINT_SET_KEYS)


def _joint_set_list(ck, items, base: tuple, materials: dict, names, schema: dict) -> list:
    if not isinstance(items, list):
        raise ck.error(base, f"{_fmt(base)} must be an array of tables [[{_fmt(base)}]]", table=())
    out, seen = [], set()
    for k, t in enumerate(items):
        p = base + (k,)
        ck.table(t, p, "a joint set")
        ck.keys(t, schema, p)
        c = ck.values(t, schema, p)
        if c["name"] in seen or c["name"] == "default":
            raise ck.error(p + ("name",), f"joint set name {c['name']!r} is used twice ('default' is the bodies' own)")
        seen.add(c["name"])
        if c["material"] not in materials:
            raise ck.error(p + ("material",), f"unknown material {c['material']!r}"
                           f"{_suggest(c['material'], materials)}; defined: {', '.join(materials)}")
        if not materials[c["material"]].can_fracture:
            raise ck.error(p + ("material",), f"a joint set's material needs tensile_strength and fracture_energy "
                           f"([materials.{c['material']}])")
        if names is not None:
            _known_body(ck, names, c, p)
        has_region = _check_region(ck, c, p, "", required=False)
        given = [w for w, on in (("interfaces", c["interfaces"]), ("lines", c["lines"] is not None),
                                 ("a region", has_region)) if on]
        if len(given) != 1:
            raise ck.error(p, "give exactly one edge selector: interfaces = true, lines = [[[x, y], ...], ...] or a "
                           f"region (xmin, ..., r_max) of edge midpoints; got {', '.join(given) or 'none'}", table=p)
        if "weibull_modulus" in schema:
            _strength_keys(ck, t, c, p)
        out.append(c)
    return out


def _fmt(path: tuple) -> str:
    return ".".join(str(p) for p in path)


def _interaction_tables(ck, data: dict, materials: dict) -> list:
    out = []
    for k, t in enumerate(_array(ck, data, "interactions", "materials = [a, b] and the contact values")):
        p = ("interactions", k)
        ck.table(t, p, "a pair of materials and their contact properties")
        ck.keys(t, INTERACTION_KEYS, p)
        c = ck.values(t, INTERACTION_KEYS, p)
        if len(c["materials"]) != 2:
            raise ck.error(p + ("materials",), f"materials must name two materials [a, b], got {c['materials']!r}")
        for m in c["materials"]:
            if m not in materials:
                raise ck.error(p + ("materials",), f"unknown material {m!r}{_suggest(m, materials)}; defined: "
                               f"{', '.join(materials)}")
        if all(c[v] is None for v in ("friction", "penalty", "tangential_penalty", "contact_damping")):
            raise ck.error(p, "give at least one of friction, penalty, tangential_penalty, contact_damping", table=p)
        out.append(c)
    return out


def _load_tables(ck, data: dict, names, curves: dict) -> list:
    out = []
    for k, t in enumerate(_array(ck, data, "loads", "kind, its value and a region")):
        p = ("loads", k)
        ck.table(t, p, "a load")
        ck.keys(t, LOAD_KEYS, p)
        c = ck.values(t, LOAD_KEYS, p)
        need = LOAD_VALUE[c["kind"]]
        for v in ("pressure", "traction", "force"):
            if v != need and v in t:
                raise ck.error(p + (v,), f"a {c['kind']!r} load takes " + (f"{need!r}" if need else "no value")
                               + f", not {v!r}")
        if need is not None and c[need] is None:
            raise ck.error(p, f"a {c['kind']!r} load needs {need!r} [{LOAD_KEYS[need].unit}]", table=p)
        if c["kind"] == "absorbing" and c["curve"] is not None:
            raise ck.error(p + ("curve",), "an absorbing boundary takes no curve")
        _check_region(ck, c, p, "the region of the loaded nodes: an edge is loaded when both its nodes are in it")
        _known_body(ck, names, c, p)
        if c["curve"] is not None:
            _known_curve(ck, curves, c["curve"], p + ("curve",))
        out.append(c)
    return out


def _initial_stress_tables(ck, data: dict, names) -> list:
    out = []
    for k, t in enumerate(_array(ck, data, "initial_stress", "sxx, syy, sxy")):
        p = ("initial_stress", k)
        ck.table(t, p, "an initial stress")
        ck.keys(t, INITIAL_STRESS_KEYS, p)
        c = ck.values(t, INITIAL_STRESS_KEYS, p)
        if c["gradient"] is not None and len(c["gradient"]) not in (2, 3):
            raise ck.error(p + ("gradient",), f"gradient must be [dsxx/dy, dsyy/dy] or [dsxx/dy, dsyy/dy, dsxy/dy] "
                           f"[Pa/m], got {c['gradient']!r}")
        _known_body(ck, names, c, p)
        out.append(c)
    return out


def _excavate_tables(ck, data: dict, names) -> list:
    out = []
    for k, t in enumerate(_array(ck, data, "excavate", "time and the body and/or region removed")):
        p = ("excavate", k)
        ck.table(t, p, "an excavation")
        ck.keys(t, EXCAVATE_KEYS, p)
        c = ck.values(t, EXCAVATE_KEYS, p)
        has_region = _check_region(ck, c, p, "", required=False)
        if not has_region and c["body"] is None:
            raise ck.error(p, "give body and/or a region (xmin, ..., r_max) of triangle centroids to remove",
                           table=p)
        _known_body(ck, names, c, p)
        out.append(c)
    times = [c["time"] for c in out]
    if times != sorted(times):
        raise ck.error(("excavate", next(i for i in range(1, len(times)) if times[i] < times[i - 1]), "time"),
                       "[[excavate]] tables must come in order of time")
    return out

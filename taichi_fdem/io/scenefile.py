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

This module holds the loader that checks a file into a :class:`SceneSpec`, the dotted-key
overrides of sweeps and the meaning of every key (the reference below).  The key schemas
(type, unit, default, range) are in :mod:`.scenetables.keys`, the checks of each table in
the other modules of :mod:`.scenetables`, the TOML reader, the line locator and the key
checker in :mod:`.toml_check`; :class:`SceneSpec` (which builds the scene) and
:class:`RunSettings` (which runs it) are in :mod:`.scenespec`.  All of them are importable
from here.

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
conductivity           W/m/K   thermal conductivity k > 0 (heat conduction) [none]
heat_capacity          J/kg/K  specific heat capacity c > 0 (heat conduction) [none]
expansion              1/K     linear thermal expansion coefficient α [0.0]
like                   —       a NAME of ``[materials]`` whose values this one starts from: the keys
                               given replace them (``Material.with_``) [none]
=====================  ======  ===============================================================

A material may hold a ``bedding`` sub-table: transversely isotropic elasticity, ``young`` and
``poisson`` then being E1 and ν1 in the bedding plane (docs/guide/anisotropy.md).  A polygon body
of a material with a bedding ``spacing`` is meshed along its bedding planes
(``fdem.mesh.bedding_lines`` of its vertices), which become the joint set "bedding".

``[materials.NAME.bedding]`` (``fdem.Bedding``; a callable angle(x, y) needs the Python API)

=====================  ======  ===============================================================
angle                  °       dip of the bedding from the x axis, counter-clockwise
young_normal           Pa      E2, Young's modulus across the bedding, > 0
poisson_normal         —       ν21: strain in the bedding plane per strain across it, under a
                               stress across it (S₁₂ = −ν21/E2)
shear_modulus          Pa      G2, shear modulus of planes normal to the bedding, > 0
tensile_strength       Pa      f_t of joints parallel to the bedding [the material's]
cohesion               Pa      c of joints parallel to the bedding [the material's]
friction_angle         °       φ_i of joints parallel to the bedding [the material's]
fracture_energy        J/m²    G_I of joints parallel to the bedding [the material's]
fracture_energy_shear  J/m²    G_II of joints parallel to the bedding [the material's]
expansion_normal       1/K     thermal expansion across the bedding [the material's expansion]
spacing                m       distance between weak bedding planes, one through the origin: the
                               mesh's edges along them are the joint set "bedding" [none]
strength_window        °       θ_w: joints within θ_w of the bedding are weakened towards its
                               strength, linearly in the angle [15]
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

``[temperature]`` (the stress-free temperature of every node, ``Scene.set_temperature``)

================  ======  =================================================================
initial           K       initial temperature of every node (any consistent scale: °C or K); the
                          table, or a ``[[heat]]``, makes the scene conduct heat, and every
                          material then needs ``conductivity`` and ``heat_capacity`` [0.0]
================  ======  =================================================================

``[[heat]]`` (a held temperature or a heat flux, ``Scene.heat``: docs/guide/heat.md)

================  ======  =================================================================
xmin, xmax        m       region of the nodes (initial positions), inclusive [−∞, +∞]; at
ymin, ymax        m       least one bound is required
center            m       centre of the region's ring
r_min, r_max      m       the region's ring
body              —       restrict to this body (by name) [all bodies]
temperature       K       the nodes are held at T₀ + A(t)(temperature − T₀), T₀ their initial
                          temperature [none]
flux              W/m²    or: a heat flux into the body through the region's boundary edges [none]
ramp              s       A(t) rises linearly from 0 to 1 over this time [none: 1]
curve             —       or: a NAME of ``[curves]`` giving A(t) [none]
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
                       "max_principal", "min_principal", "damage", "fluid_pressure"
                       (needs ``[fluid]``), "bedding" (needs a bedded material) or
                       "temperature" (needs ``[temperature]`` or ``[[heat]]``) ["body"]
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
bedding_angle         °       ucs, triaxial, brazilian: angle between the bedding planes and the loading
                              direction, 0 = parallel, 90 = across (``bedding_angle=``; the material
                              needs a bedding) [none]
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
``[[constraints]]``, ``[[loads]]``, ``[[initial_stress]]``, ``[fluid]``, ``[[inject]]``, the
temperatures of ``[temperature]`` and ``[[heat]]`` (each kind in the file's order), which is
the order a Python script of the same scene uses when it adds the joint sets after the bodies.

Sanity bounds (a value beyond them is refused as a typo; products of it would overflow):
lengths (sizes, radii, ``h``, ``thickness``, ``buffer``) within [1e-9, 1e6] m, coordinates
within ±1e9 m, gravity components within ±1e6 m/s², speeds within ±1e5 m/s, ``duration``
≤ 1e9 s, video frames ≤ 16384 px and ≤ 1000 fps; material values as
``taichi_fdem.material.BOUNDS`` (E ≤ 1e16 Pa, 1e-6 ≤ ρ ≤ 1e6 kg/m³, ...).
"""
from __future__ import annotations

import os

from .toml_check import SceneFileError, _Checker, _Key, _suggest, read_toml  # noqa: F401 (re-exported)
from .scenespec import RunSettings, SceneSpec, _BoxSelector  # noqa: F401 (re-exported; old pickles name it here)
from .scenetables.keys import (  # noqa: F401 (re-exported: the schemas the reference is generated from)
    _ARRAY_TABLES, _BOUNDS, _MESH_KEYS, BODY_KEYS, CHECK_KEYS, COLOR_BY, CONSTRAINT_KEYS, CURVE_KEYS,
    EXCAVATE_KEYS, FLUID_KEYS, HEAT_KEYS, INITIAL_STRESS_KEYS, INJECT_KEYS, INTERACTION_KEYS, JOINT_SET_KEYS,
    LAB_JOINT_SET_KEYS, LAB_KEYS, LAB_TEST_KEYS, LOAD_KEYS, LOAD_VALUE, MATERIAL_KEYS, OUTPUT_KEYS, REGION_KEYS,
    SCENE_KEYS, SHAPE_KEYS, SOLVER_KEYS, TEMPERATURE_KEYS, TOP_KEYS, BEDDING_KEYS)
from .scenetables.common import region_of, strength_of  # noqa: F401 (re-exported)
from .scenetables.bodies import _body_tables
from .scenetables.boundary import (_constraint_tables, _excavate_tables, _excavations_within,
                                   _initial_stress_tables, _load_tables)
from .scenetables.fluid import _fluid_tables
from .scenetables.heat import _heat_tables
from .scenetables.joints import _interaction_tables, _joint_set_tables
from .scenetables.lab import _lab_table
from .scenetables.materials import _curve_tables, _material_tables
from .scenetables.run import _checks_table, _output_table, _solver_table

__all__ = ["SceneFileError", "SceneSpec", "RunSettings", "load", "loads", "read_toml", "apply_overrides"]


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
    """Check already parsed TOML ``data`` (``text`` is used to find line numbers).

    The tables are checked in the order scene, materials, curves, then either ``[lab]`` or
    bodies, constraints, fluid and injections, joint sets, interactions, loads, initial
    stresses, excavations, checks, solver and output: the first refused key is the one
    reported."""
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
    materials = _material_tables(ck, data)
    curves = _curve_tables(ck, data)
    if "lab" in data:
        return SceneSpec(path=path, scene=scene, materials=materials, bodies=[], constraints=[], solver={},
                         output={}, description=description, lab=_lab_table(ck, data, materials), curves=curves,
                         _checker=ck)

    bodies, names = _body_tables(ck, data, materials, curves, base_dir)
    constraints = _constraint_tables(ck, data, names, curves)
    fluid, injections = _fluid_tables(ck, data, curves)
    temperature, heat = _heat_tables(ck, data, names, curves)
    joint_sets = _joint_set_tables(ck, data, materials, names)
    interactions = _interaction_tables(ck, data, materials)
    loads = _load_tables(ck, data, names, curves)
    initial_stress = _initial_stress_tables(ck, data, names)
    excavations = _excavate_tables(ck, data, names)
    checks = _checks_table(ck, data)
    solver = _solver_table(ck, data)
    _excavations_within(ck, excavations, solver["duration"])
    output = _output_table(ck, data)
    return SceneSpec(path=path, scene=scene, materials=materials, bodies=bodies, constraints=constraints,
                     solver=solver, output=output, description=description, fluid=fluid, injections=injections,
                     temperature=temperature, heat=heat, curves=curves, joint_sets=joint_sets,
                     interactions=interactions, loads=loads, initial_stress=initial_stress, excavations=excavations, checks=checks, _checker=ck)

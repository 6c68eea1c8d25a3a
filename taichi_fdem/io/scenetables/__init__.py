"""The tables of a scene file (:mod:`taichi_fdem.io.scenefile`): their key schemas
(:mod:`.keys`) and the checks that turn each kind of table into resolved plain data, one module
per concept: materials and curves, bodies and their meshes, joint sets and interactions, the
region tables (constraints, loads, initial stress, excavation), the fluid, the lab test and
the run (checks, solver, output); :mod:`.common` holds the values several tables share."""

"""Input and output above the simulation: VTU series (:mod:`.vtu`), checkpoints
(:mod:`.checkpoint`) and TOML scene files (:mod:`.scenefile`).  Mesh files are read by
:mod:`taichi_fdem.mesh`."""

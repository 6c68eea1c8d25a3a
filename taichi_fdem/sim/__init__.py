"""The simulation layer: the model built from a scene, the state a step changes, the time
step, the driver (:class:`~taichi_fdem.sim.simulation.Simulation`) and what it reports
(results, cracks, energies, guards, excavation, profiling)."""

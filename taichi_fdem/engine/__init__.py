"""The kernel layer: Taichi functions and kernels by physics, and the step that runs them.

=================  =============================================================================
module             holds
=================  =============================================================================
``groups``         the argpack types: the simulation's arrays grouped by concern
``elastic``        finite-strain constant-strain triangle (docs/theory/elements.md §3)
``contact``        distributed potential contact force with friction and damping (§2, §5)
``detection``      broad phase: hashed grid, counting sort, couple criterion (§4)
``joints``         cohesive joints: softening, Mohr–Coulomb, breakage (§7)
``integrate``      central-difference integration, prescribed velocities, guards (§6)
``loads``          applied loads, absorbing boundaries, curve-driven velocities (§12)
``fluid``          the fluid in the fracture network, a sub-step coupled into the step
``bundle``         the groups of a step in the convention's order (one compile-time tuple)
``blocks``         the block assembly of the parallel strategy on the CPU
``team``           the team of worker threads that runs many parallel steps per launch
``step``           the phases of a step and the serial / parallel kernels built from them
``diagnostics``    energies, overlaps, penetrations (not on the hot path)
=================  =============================================================================

Nothing here imports the model, the simulation or any driver: the engine is the bottom layer
above Taichi (and :mod:`taichi_fdem.backend` for the precision).
"""

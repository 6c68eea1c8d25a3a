"""Strain energy of a small pile of disks at rest (benchmarks/pile.py's scene, no initial
velocity), at the start and after a few steps under gravity.

Run as ``python tests/pile_energy_probe.py ARCH PRECISION``: prints one JSON object with the
strain energy [J/m] at t = 0, after 200 steps (2 ms), the gravity potential then [J/m] and the
kinetic energy.  A separate process: Taichi is initialised once per process.
"""
import json
import os
import sys

import taichi_fdem as fdem

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))


def main(arch, precision):
    fdem.init(arch=arch, precision=precision)
    import pile
    scene, _ = pile.build_scene(fdem, 200, v_random=0.0)
    sim = scene.build(strategy="parallel")
    e0 = sim.energies()
    sim.step(200)
    e1 = sim.energies()
    print(json.dumps({"strain0": e0["strain"], "strain200": e1["strain"], "kinetic200": e1["kinetic"],
                      "gravity200": e1["gravity"], "triangles": sim.model.tri_count, "couples": sim.solver.couple_count, "device": arch}))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])

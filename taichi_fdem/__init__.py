"""taichi_fdem: the combined finite-discrete element method (FDEM) in 2D, on Taichi.

    import taichi_fdem as fdem
    fdem.init(arch="cpu", precision="f64")      # optional
    rock = fdem.Material(density=2700.0, young=30e9, poisson=0.25, friction=0.5)
    scene = fdem.Scene(gravity=(0.0, -9.81))
    disk = scene.add_body(fdem.mesh.disk(radius=0.05, h=0.01), rock, position=(0.0, 0.2))
    sim = scene.build()
    sim.run(duration=0.1)
"""
from . import checkpoint, export, mesh, render, scenefile, sweep
from .backend import init
from .material import Material
from .scene import Body, Scene
from .simulation import Simulation, SimulationError

__version__ = "0.1.0"
__all__ = ["init", "mesh", "render", "export", "checkpoint", "scenefile", "sweep", "Material", "Scene", "Body",
           "Simulation", "SimulationError", "__version__"]
# The live window (taichi_fdem.viewer.Viewer) is imported on demand: the core never opens a window.

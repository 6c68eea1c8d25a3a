"""taichi_fdem: the combined finite-discrete element method (FDEM) in 2D, on Taichi.

::

    import taichi_fdem as fdem
    fdem.init(arch="cpu", precision="f64")      # optional
    rock = fdem.Material(density=2700.0, young=30e9, poisson=0.25, friction=0.5)
    scene = fdem.Scene(gravity=(0.0, -9.81))
    disk = scene.add_body(fdem.mesh.disk(radius=0.05, h=0.01), rock, position=(0.0, 0.2))
    sim = scene.build()
    sim.run(duration=0.1)

Layers (imports run downwards only; see docs/architecture.md):

* bottom: :mod:`backend` (``fdem.init``), :mod:`material`, :mod:`mesh`;
* :mod:`engine`: Taichi kernels by physics and the step;
* :mod:`model` (scene → model + state, :mod:`timestep`), then the driver :mod:`simulation`
  (with :mod:`guards`, :mod:`energies`, :mod:`results`), then the builder :mod:`scene`;
* drivers on top: :mod:`render`, :mod:`io` (VTU, checkpoints, scene files), :mod:`viewer`,
  :mod:`cli`, :mod:`sweep`, :mod:`verification`, :mod:`stability`, :mod:`lab` (standard lab
  tests: ``fdem.lab.ucs``, ``brazilian``, ``triaxial``, ``direct_shear``, ``fit_envelope``).  They are imported on first
  use (``fdem.render``, ``fdem.sweep``, ...), so importing the core loads none of them.
"""
import importlib
import os as _os

# Taichi prints a version banner when it is imported; importing taichi_fdem (and so
# ``taichi-fdem --help``) stays silent, and the command line prints the banner when a command
# starts Taichi (``cli._init``).  The variable is restored, so child processes see it unchanged.
_banner = _os.environ.get("ENABLE_TAICHI_HEADER_PRINT")
_os.environ["ENABLE_TAICHI_HEADER_PRINT"] = "False"
try:
    import taichi as _ti  # noqa: F401
finally:
    if _banner is None:
        del _os.environ["ENABLE_TAICHI_HEADER_PRINT"]
    else:
        _os.environ["ENABLE_TAICHI_HEADER_PRINT"] = _banner

from . import mesh
from .backend import init
from .discontinuity import NormalStrength, Weibull
from .sim.guards import SimulationError
from .material import Bedding, Fluid, Material
from .scene import Body, Curve, Scene
from .sim.simulation import Simulation
from .sim.recorders import Callback, Checks, CrackEvents, History

__version__ = "0.1.0"
__all__ = ["init", "mesh", "render", "export", "checkpoint", "scenefile", "sweep", "lab", "Material", "Bedding", "Fluid", "Scene", "Body", "Curve",
           "Weibull", "NormalStrength", "Simulation", "SimulationError", "Video", "History", "CrackEvents", "Callback", "Checks",
           "calibrate", "__version__"]

# driver modules, loaded on first attribute access (PEP 562)
_LAZY = {"render": "taichi_fdem.render", "export": "taichi_fdem.io.vtu", "checkpoint": "taichi_fdem.io.checkpoint",
         "scenefile": "taichi_fdem.io.scenefile", "sweep": "taichi_fdem.sweep", "io": "taichi_fdem.io",
         "verification": "taichi_fdem.verification", "stability": "taichi_fdem.verification.stability",
         "viewer": "taichi_fdem.render.viewer", "cli": "taichi_fdem.cli", "lab": "taichi_fdem.lab"}


def __getattr__(name):
    if name == "calibrate":                      # fdem.calibrate(...): the function
        from .sweep.calibrate import calibrate
        globals()[name] = calibrate
        return calibrate
    if name == "Video":                          # the renderer's recorder (loads the renderer)
        from .render.recorder import Video
        globals()[name] = Video
        return Video
    if name in _LAZY:
        module = importlib.import_module(_LAZY[name])
        globals()[name] = module
        return module
    raise AttributeError(f"module 'taichi_fdem' has no attribute {name!r}")

"""Scene files: a whole simulation (materials, bodies, constraints, solver, output) in TOML.

    spec = fdem.scenefile.load("examples/two_disks.toml")     # every key checked
    sim, settings = spec.build()                                # a Simulation and how to run it
    settings.run(sim)                                           # duration, video, VTU, checkpoint

or from the command line: ``taichi-fdem run examples/two_disks.toml``.

The file is read with the standard library's :mod:`tomllib` (``tomli`` on Python 3.10).  Every
key is checked: an unknown key is refused with the file, the line, the table it is in and the
closest allowed key; a value of the wrong type, sign or range is refused naming its key.
Errors are :class:`SceneFileError` (a ``ValueError``).

Paths: files the scene *reads* (``bodies.file``) are relative to the scene file's folder;
files it *writes* (``output.video``, ``output.vtu``, ``output.checkpoint``) are relative to
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

==================  ======  ===============================================================
density             kg/m³   > 0 [2700.0]
young               Pa      Young's modulus E, > 0 [30e9]
poisson             —       Poisson's ratio, −1 < ν < 0.5 [0.25]
friction            —       Coulomb friction coefficient μ ≥ 0 [0.0]
damping             —       viscous damping β, fraction of critical, in [0, 1] [0.0]
penalty             Pa      normal contact penalty p > 0 [10 × young]
tangential_penalty  Pa      tangential (stick) friction stiffness > 0 [penalty]
contact_damping     —       normal contact damping ratio ξ in [0, 1] [0.0]
==================  ======  ===============================================================

``[[bodies]]`` (one table per body; the mesh is a ``shape`` or a ``file``)

===================  ======  ==============================================================
name                 —       unique name, used by constraints and sweep metrics ["body<i>"]
material             —       a NAME of ``[materials]`` (required)
shape                —       "disk", "rectangle", "annulus" or "polygon" (or give ``file``)
file                 —       mesh file read by ``fdem.mesh.load`` (gmsh .msh, .vtu, ...)
cell_block           —       with ``file``: index of the one triangle cell block to use [all]
radius               m       disk: radius, > 0
width, height        m       rectangle: size, > 0
pattern              —       rectangle: "alternating", "crossed" or "right" ["alternating"]
r_inner, r_outer     m       annulus: radii, 0 < r_inner < r_outer
vertices             m       polygon: [[x, y], ...], a simple polygon
h                    m       target element edge length, > 0 (required for disk, rectangle,
                             annulus; polygon: [none: the vertices alone are triangulated])
position             m       [x, y] where the mesh's area centroid is placed [mesh as built:
                             shapes centred on (0, 0), files as read]
velocity             m/s     [v_x, v_y] initial velocity [[0, 0]]
angular_velocity     rad/s   initial spin about the centroid, counter-clockwise [0.0]
rotation             rad     rotation about the centroid before placing, counter-clockwise [0.0]
fixed                —       every node held still (floors, walls) [false]
prescribed_velocity  m/s     [v_x, v_y] every node moves at this velocity (platens) [none]
self_contact         —       the body's own triangles can contact each other [false]
===================  ======  ==============================================================

``[[constraints]]`` (prescribe the velocity of the nodes inside a box, in the initial positions)

================  ======  =================================================================
xmin, xmax        m       box along x, inclusive [−∞, +∞]; at least one bound is required
ymin, ymax        m       box along y, inclusive [−∞, +∞]
body              —       restrict to the nodes of this body [all bodies]
vx, vy            m/s     prescribed velocity component; an absent component stays free
                          (a roller); at least one is required
================  ======  =================================================================

``[solver]``

=============  ======  ===================================================================
duration       s       simulated time of ``run``, ≥ 0 (required)
dt             s       time step, > 0 [safety × estimated stable limit]
safety         —       fraction of the stable limit when dt is not given, in (0, 1] [0.2]
strategy       —       "auto", "serial" or "parallel" ["auto"]
buffer         m       contact detection buffer, ≥ 0 [¼ mean edge of contact triangles]
force_dt       —       accept a dt above the estimated stable limit [false]
check_overlap  —       warn when bodies overlap at the start [true]
=============  ======  ===================================================================

``[output]`` (all optional)

=============  ======  ===================================================================
video          —       video written while running: .mp4, .gif or a folder of PNGs [none]
fps            1/s     frames per second of the video [30]
frame_dt       s       simulated time between frames [duration / (5 s × fps)]
color_by       —       "body", "material", "speed", "displacement", "von_mises",
                       "max_principal" or "min_principal" ["body"]
width, height  px      video frame size [960, 540]
vtu            —       folder of a VTU series with a .pvd index (needs taichi_fdem.io.vtu)
vtu_every      —       write one VTU file every this many frames [1]
checkpoint     —       file written at the end of the run (needs Simulation.save)
=============  ======  ===================================================================

A top-level ``description`` string is allowed (free text).
"""
from __future__ import annotations

import difflib
import math
import os
import re
import sys
from dataclasses import dataclass, field
from typing import Any

__all__ = ["SceneFileError", "SceneSpec", "RunSettings", "load", "loads", "read_toml", "apply_overrides"]


class SceneFileError(ValueError):
    """A scene or sweep file was refused.  The message names the file, the line (when it can
    be found), the table and the key."""


# ----------------------------------------------------------------------------------------------
# TOML reading
# ----------------------------------------------------------------------------------------------
def _tomllib():
    if sys.version_info >= (3, 11):
        import tomllib
        return tomllib
    try:
        import tomli as tomllib       # Python 3.10
    except ImportError:
        raise SceneFileError("reading TOML files on Python 3.10 needs the 'tomli' package: pip install tomli") from None
    return tomllib


def read_toml(path) -> tuple[dict, str]:
    """(data, text) of a TOML file; SceneFileError naming the file (and the line) when it cannot be read."""
    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            raw = f.read()
    except FileNotFoundError:
        raise SceneFileError(f"{path}: no such file") from None
    except OSError as exc:
        raise SceneFileError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SceneFileError(f"{path}: not UTF-8 text ({exc})") from None
    tomllib = _tomllib()
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"\(at line (\d+), column (\d+)\)", str(exc))
        where = f"{path}:{m.group(1)}" if m else path
        raise SceneFileError(f"{where}: not valid TOML: {exc}") from None
    return data, text


# ----------------------------------------------------------------------------------------------
# locating keys in the text (tomllib gives no positions)
# ----------------------------------------------------------------------------------------------
_HEADER_ARRAY = re.compile(r"^\s*\[\[\s*(.+?)\s*\]\]\s*(#.*)?$")
_HEADER_TABLE = re.compile(r"^\s*\[\s*([^\[\]]+?)\s*\]\s*(#.*)?$")
_KEY_LINE = re.compile(r"""^\s*((?:"[^"]*"|'[^']*'|[A-Za-z0-9_\-]+)(?:\s*\.\s*(?:"[^"]*"|'[^']*'|[A-Za-z0-9_\-]+))*)\s*=""")
_KEY_PART = re.compile(r"""\s*("([^"]*)"|'([^']*)'|([A-Za-z0-9_\-]+))\s*(?:\.|$)""")


def _split_key(s: str) -> tuple:
    parts = []
    for m in _KEY_PART.finditer(s):
        part = m.group(2) if m.group(2) is not None else (m.group(3) if m.group(3) is not None else m.group(4))
        if part is None:
            break
        parts.append(part)
    return tuple(parts)


class _Locator:
    """Maps a path (tuple of table names, array indices and the key) to its line in the file text."""

    def __init__(self, text: str):
        self.keys: dict[tuple, int] = {}
        self.headers: dict[tuple, int] = {}
        counts: dict[tuple, int] = {}
        current: tuple = ()
        for lineno, line in enumerate(text.splitlines(), start=1):
            m = _HEADER_ARRAY.match(line)
            if m:
                name = _split_key(m.group(1))
                # an array-of-tables header inside a parent array element: index within that element
                k = counts.get(name, 0)
                counts[name] = k + 1
                current = name + (k,)
                self.headers.setdefault(current, lineno)
                continue
            m = _HEADER_TABLE.match(line)
            if m:
                current = _split_key(m.group(1))
                self.headers.setdefault(current, lineno)
                continue
            m = _KEY_LINE.match(line)
            if m:
                self.keys.setdefault(current + _split_key(m.group(1)), lineno)

    def line(self, path: tuple) -> int | None:
        path = tuple(path)
        if path in self.keys:
            return self.keys[path]
        if path in self.headers:
            return self.headers[path]
        # a table defined implicitly by its first dotted key or sub-table
        for p, n in sorted(list(self.keys.items()) + list(self.headers.items()), key=lambda kv: kv[1]):
            if p[:len(path)] == path:
                return n
        return None


def _fmt_path(path: tuple) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (("." if out else "") + p)
    return out


# ----------------------------------------------------------------------------------------------
# key schemas
# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Key:
    kind: str              # float, int, bool, str, vec2, vertices, choice
    default: Any = None
    unit: str = ""
    lo: float | None = None          # inclusive lower bound
    lo_open: bool = False            # lower bound exclusive
    hi: float | None = None
    choices: tuple = ()
    required: bool = False


_F = lambda **kw: _Key("float", **kw)
_POS = lambda unit, **kw: _Key("float", unit=unit, lo=0.0, lo_open=True, **kw)

SCENE_KEYS = {
    "gravity": _Key("vec2", (0.0, -9.81), "m/s²"),
    "plane": _Key("choice", "strain", choices=("strain", "stress")),
    "thickness": _POS("m", default=1.0),
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
}
BODY_KEYS = {
    "name": _Key("str"),
    "material": _Key("str", required=True),
    "shape": _Key("choice", choices=("disk", "rectangle", "annulus", "polygon")),
    "file": _Key("str"),
    "cell_block": _Key("int", lo=0),
    "radius": _POS("m"),
    "width": _POS("m"),
    "height": _POS("m"),
    "pattern": _Key("choice", "alternating", choices=("alternating", "crossed", "right")),
    "r_inner": _POS("m"),
    "r_outer": _POS("m"),
    "vertices": _Key("vertices", unit="m"),
    "h": _POS("m"),
    "position": _Key("vec2", unit="m"),
    "velocity": _Key("vec2", (0.0, 0.0), "m/s"),
    "angular_velocity": _F(default=0.0, unit="rad/s"),
    "rotation": _F(default=0.0, unit="rad"),
    "fixed": _Key("bool", False),
    "prescribed_velocity": _Key("vec2", unit="m/s"),
    "self_contact": _Key("bool", False),
}
#: mesh parameters of each built-in shape: (required, optional)
SHAPE_KEYS = {
    "disk": (("radius", "h"), ()),
    "rectangle": (("width", "height", "h"), ("pattern",)),
    "annulus": (("r_inner", "r_outer", "h"), ()),
    "polygon": (("vertices",), ("h",)),
    "file": (("file",), ("cell_block",)),
}
_MESH_KEYS = {k for req, opt in SHAPE_KEYS.values() for k in req + opt}
CONSTRAINT_KEYS = {
    "xmin": _F(unit="m"), "xmax": _F(unit="m"), "ymin": _F(unit="m"), "ymax": _F(unit="m"),
    "body": _Key("str"),
    "vx": _F(unit="m/s"), "vy": _F(unit="m/s"),
}
SOLVER_KEYS = {
    "duration": _F(unit="s", lo=0.0, required=True),
    "dt": _POS("s"),
    "safety": _Key("float", 0.2, lo=0.0, lo_open=True, hi=1.0),
    "strategy": _Key("choice", "auto", choices=("auto", "serial", "parallel")),
    "buffer": _F(unit="m", lo=0.0),
    "force_dt": _Key("bool", False),
    "check_overlap": _Key("bool", True),
}
COLOR_BY = ("body", "material", "speed", "displacement", "von_mises", "max_principal", "min_principal")
OUTPUT_KEYS = {
    "video": _Key("str"),
    "fps": _Key("int", 30, "1/s", lo=1),
    "frame_dt": _POS("s"),
    "color_by": _Key("choice", "body", choices=COLOR_BY),
    "width": _Key("int", 960, "px", lo=1),
    "height": _Key("int", 540, "px", lo=1),
    "vtu": _Key("str"),
    "vtu_every": _Key("int", 1, lo=1),
    "checkpoint": _Key("str"),
}
TOP_KEYS = ("description", "scene", "materials", "bodies", "constraints", "solver", "output")


# ----------------------------------------------------------------------------------------------
# the checker
# ----------------------------------------------------------------------------------------------
def _suggest(word: str, allowed) -> str:
    close = difflib.get_close_matches(str(word), [str(a) for a in allowed], n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


class _Checker:
    def __init__(self, path: str, text: str, overridden: dict | None = None):
        self.path = path
        self.loc = _Locator(text)
        self.overridden = overridden or {}      # path tuple -> dotted override name

    def where(self, path: tuple) -> str:
        for n in range(len(path), 0, -1):
            if tuple(path[:n]) in self.overridden:
                return f"{self.path} (override {self.overridden[tuple(path[:n])]!r})"
        line = self.loc.line(path)
        return f"{self.path}:{line}" if line else self.path

    def error(self, path: tuple, message: str, table: tuple | None = None) -> SceneFileError:
        table = path[:-1] if table is None else table
        label = f"[{_fmt_path(table)}] " if table else ""
        return SceneFileError(f"{self.where(path)}: {label}{message}")

    def table(self, value, path: tuple, what: str) -> dict:
        if not isinstance(value, dict):
            raise self.error(path, f"{_fmt_path(path)!r} must be a table ({what}), got {type(value).__name__} {value!r}",
                             table=())
        return value

    def keys(self, table: dict, schema, path: tuple, allowed=None) -> None:
        allowed = list(schema) if allowed is None else list(allowed)
        for key in table:
            if key not in allowed:
                raise self.error(path + (key,), f"unknown key {key!r}{_suggest(key, allowed)}; allowed keys: "
                                 f"{', '.join(allowed)}")

    def value(self, table: dict, key: str, spec: _Key, path: tuple):
        kp = path + (key,)
        if key not in table:
            if spec.required:
                raise self.error(kp, f"missing required key {key!r}" + (f" [{spec.unit}]" if spec.unit else ""))
            return spec.default
        v = table[key]
        unit = f" [{spec.unit}]" if spec.unit else ""
        if spec.kind == "float":
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise self.error(kp, f"{key} must be a number{unit}, got {v!r}")
            v = float(v)
            if not math.isfinite(v):
                raise self.error(kp, f"{key} must be finite{unit}, got {v!r}")
        elif spec.kind == "int":
            if isinstance(v, bool) or not isinstance(v, int):
                raise self.error(kp, f"{key} must be an integer{unit}, got {v!r}")
        elif spec.kind == "bool":
            if not isinstance(v, bool):
                raise self.error(kp, f"{key} must be true or false, got {v!r}")
        elif spec.kind == "str":
            if not isinstance(v, str) or not v:
                raise self.error(kp, f"{key} must be a non-empty string, got {v!r}")
        elif spec.kind == "choice":
            if v not in spec.choices:
                raise self.error(kp, f"{key} must be one of {', '.join(map(repr, spec.choices))}, got {v!r}"
                                 f"{_suggest(v, spec.choices) if isinstance(v, str) else ''}")
        elif spec.kind == "vec2":
            if (not isinstance(v, list) or len(v) != 2
                    or any(isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c) for c in v)):
                raise self.error(kp, f"{key} must be a pair of finite numbers [x, y]{unit}, got {v!r}")
            v = (float(v[0]), float(v[1]))
        elif spec.kind == "vertices":
            ok = isinstance(v, list) and len(v) >= 3 and all(
                isinstance(p, list) and len(p) == 2 and all(
                    not isinstance(c, bool) and isinstance(c, (int, float)) and math.isfinite(c) for c in p) for p in v)
            if not ok:
                raise self.error(kp, f"{key} must be a list of at least 3 points [[x, y], ...]{unit}, got {v!r}")
            v = [(float(p[0]), float(p[1])) for p in v]
        if spec.kind in ("float", "int"):
            if spec.lo is not None and (v < spec.lo or (spec.lo_open and v == spec.lo)):
                raise self.error(kp, f"{key} must be {'>' if spec.lo_open else '>='} {spec.lo:g}{unit}, got {v!r}")
            if spec.hi is not None and v > spec.hi:
                raise self.error(kp, f"{key} must be <= {spec.hi:g}{unit}, got {v!r}")
        return v

    def values(self, table: dict, schema: dict, path: tuple, only=None) -> dict:
        return {k: self.value(table, k, schema[k], path) for k in (schema if only is None else only)}


# ----------------------------------------------------------------------------------------------
# the validated scene
# ----------------------------------------------------------------------------------------------
@dataclass
class RunSettings:
    """How to run a built scene: the ``[solver] duration`` and the ``[output]`` table (SI units).

    ``run(sim)`` advances the simulation by ``duration`` seconds writing the video, the VTU
    series and the checkpoint that the file asks for.
    """

    duration: float
    video: str | None = None
    fps: int = 30
    frame_dt: float | None = None
    color_by: str = "body"
    width: int = 960
    height: int = 540
    vtu: str | None = None
    vtu_every: int = 1
    checkpoint: str | None = None

    def run(self, sim, progress: bool | None = None, duration: float | None = None) -> None:
        """Run ``sim`` for ``duration`` [s] (default: the file's) with the configured outputs."""
        duration = self.duration if duration is None else float(duration)
        renderer = None
        if self.video:
            from ..render import RendererImage
            renderer = RendererImage(self.width, self.height, color_by=self.color_by)
            folder = os.path.dirname(os.path.abspath(self.video))
            os.makedirs(folder, exist_ok=True)
        exporter = None
        if self.vtu:
            from .vtu import ExporterVtu           # checked to exist by load()
            exporter = ExporterVtu(self.vtu, every=self.vtu_every)
            exporter.write(sim)                       # the initial state
        try:
            sim.run(duration, video=self.video or None, fps=self.fps, frame_dt=self.frame_dt, renderer=renderer,
                    progress=progress, callback=exporter.callback if exporter is not None else None)
        finally:
            if exporter is not None:
                exporter.close()
        if self.checkpoint:
            folder = os.path.dirname(os.path.abspath(self.checkpoint))
            os.makedirs(folder, exist_ok=True)
            sim.save(self.checkpoint)


@dataclass
class SceneSpec:
    """A checked scene file.  Plain data (no meshes built, no Taichi): cheap to create and to pickle.

    Attributes
    ----------
    path : the file it was read from.
    scene : ``gravity`` [m/s²], ``plane``, ``thickness`` [m].
    materials : {name: :class:`~taichi_fdem.material.Material`}.
    bodies : one dict per ``[[bodies]]`` with every key resolved (defaults filled in).
    constraints : one dict per ``[[constraints]]``.
    solver : the ``[solver]`` table (``duration`` [s], ``dt`` [s] or None, ``safety``, ...).
    output : the ``[output]`` table.
    """

    path: str
    scene: dict
    materials: dict
    bodies: list
    constraints: list
    solver: dict
    output: dict
    description: str = ""
    _checker: Any = field(default=None, repr=False)

    @property
    def body_names(self) -> list[str]:
        return [b["name"] for b in self.bodies]

    def _body_error(self, i: int, key: str, message: str) -> SceneFileError:
        if self._checker is None:
            return SceneFileError(f"{self.path}: [bodies[{i}]] {key}: {message}")
        return self._checker.error(("bodies", i, key), message)

    def build_mesh(self, i: int):
        """The :class:`~taichi_fdem.mesh.TriMesh` of body ``i`` (generated, or read from its file)."""
        from .. import mesh
        b = self.bodies[i]
        shape = b["shape"]
        try:
            if shape == "file":
                return mesh.load(b["file"], cell_block=b["cell_block"])
            if shape == "disk":
                return mesh.disk(b["radius"], b["h"])
            if shape == "rectangle":
                return mesh.rectangle(b["width"], b["height"], b["h"], pattern=b["pattern"])
            if shape == "annulus":
                return mesh.annulus(b["r_inner"], b["r_outer"], b["h"])
            return mesh.polygon(b["vertices"], h=b["h"])
        except (ValueError, TypeError, OSError) as exc:
            raise self._body_error(i, "file" if shape == "file" else "shape",
                                   f"body {b['name']!r}: cannot make its {shape} mesh: {exc}") from None

    def build_scene(self):
        """(:class:`~taichi_fdem.scene.Scene`, {body name: Body}) with bodies and constraints added."""
        import numpy as np
        from ..scene import Scene
        scene = Scene(gravity=self.scene["gravity"], plane=self.scene["plane"], thickness=self.scene["thickness"])
        bodies = {}
        for i, b in enumerate(self.bodies):
            m = self.build_mesh(i)
            try:
                bodies[b["name"]] = scene.add_body(
                    m, self.materials[b["material"]], position=b["position"], velocity=b["velocity"],
                    angular_velocity=b["angular_velocity"], rotation=b["rotation"], fixed=b["fixed"],
                    prescribed_velocity=b["prescribed_velocity"], self_contact=b["self_contact"], name=b["name"])
            except (ValueError, TypeError) as exc:
                raise self._body_error(i, "name", str(exc)) from None
        for k, c in enumerate(self.constraints):
            box = (c["xmin"], c["xmax"], c["ymin"], c["ymax"])
            where = _BoxSelector(*box)
            body = bodies[c["body"]] if c["body"] else None
            pts = body.mesh.points if body is not None else np.concatenate([b.mesh.points for b in scene.bodies])
            if not where(pts[:, 0], pts[:, 1]).any():
                msg = "the box selects no node (bounds are in the initial, placed positions, metres)"
                raise (self._checker.error(("constraints", k), msg, table=("constraints", k)) if self._checker
                       else SceneFileError(f"{self.path}: [constraints[{k}]] {msg}"))
            scene.fix_nodes(where, body=body, velocity=(c["vx"], c["vy"]))
        return scene, bodies

    def build(self):
        """(:class:`~taichi_fdem.simulation.Simulation`, :class:`RunSettings`)."""
        scene, _ = self.build_scene()
        s = self.solver
        try:
            sim = scene.build(dt=s["dt"], safety=s["safety"], force_dt=s["force_dt"], buffer=s["buffer"],
                              strategy=s["strategy"], check_overlap=s["check_overlap"])
        except ValueError as exc:
            key = "dt" if "dt" in str(exc) else "solver"
            where = self._checker.where(("solver", key)) if self._checker else self.path
            raise SceneFileError(f"{where}: [solver] {exc}") from None
        return sim, self.run_settings()

    def run_settings(self) -> RunSettings:
        o = self.output
        return RunSettings(duration=self.solver["duration"], video=o["video"], fps=o["fps"], frame_dt=o["frame_dt"],
                           color_by=o["color_by"], width=o["width"], height=o["height"], vtu=o["vtu"],
                           vtu_every=o["vtu_every"], checkpoint=o["checkpoint"])

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_checker"] = None
        return state


class _BoxSelector:
    """Picklable predicate ``xmin <= x <= xmax and ymin <= y <= ymax`` (None = unbounded) [m]."""

    def __init__(self, xmin, xmax, ymin, ymax):
        self.box = (xmin, xmax, ymin, ymax)

    def __call__(self, x, y):
        import numpy as np
        xmin, xmax, ymin, ymax = (v if v is not None else s * np.inf for v, s in zip(self.box, (-1, 1, -1, 1)))
        return (x >= xmin) & (x <= xmax) & (y >= ymin) & (y <= ymax)


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
                    if depth == 0 and part in TOP_KEYS and part not in ("bodies", "constraints", "materials"):
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
    for name, mt in mats_t.items():
        mp = ("materials", name)
        ck.table(mt, mp, "density, young, poisson, friction, ...")
        ck.keys(mt, MATERIAL_KEYS, mp)
        vals = ck.values(mt, MATERIAL_KEYS, mp)
        try:
            materials[name] = Material(**vals, name=name)
        except (ValueError, TypeError) as exc:
            bad = next((k for k in MATERIAL_KEYS if re.search(rf"\b{k}\b", str(exc)) and k in mt), None)
            raise ck.error(mp + ((bad,) if bad else ()), str(exc), table=mp) from None

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
        if b["material"] not in materials:
            raise ck.error(bp + ("material",), f"unknown material {b['material']!r}"
                           f"{_suggest(b['material'], materials)}; defined: {', '.join(materials)}")
        if ("shape" in bt) == ("file" in bt):
            raise ck.error(bp, f"body {b['name']!r}: give exactly one of shape = \"disk\"|\"rectangle\"|\"annulus\"|"
                           f"\"polygon\" or file = \"mesh.msh\"", table=bp)
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
        if shape == "annulus" and b["r_inner"] >= b["r_outer"]:
            raise ck.error(bp + ("r_inner",), f"r_inner ({b['r_inner']} m) must be < r_outer ({b['r_outer']} m)")
        if shape == "file":
            f = b["file"] if os.path.isabs(b["file"]) else os.path.join(base_dir, b["file"])
            if not os.path.isfile(f):
                raise ck.error(bp + ("file",), f"mesh file {b['file']!r} not found (looked for {f}; paths are "
                               f"relative to the scene file's folder)")
            b["file"] = f
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
        if all(c[b] is None for b in ("xmin", "xmax", "ymin", "ymax")):
            raise ck.error(cp, "give at least one of xmin, xmax, ymin, ymax [m] (the box of nodes to constrain)",
                           table=cp)
        for lo, hi in (("xmin", "xmax"), ("ymin", "ymax")):
            if c[lo] is not None and c[hi] is not None and c[lo] > c[hi]:
                raise ck.error(cp + (lo,), f"{lo} ({c[lo]} m) must be <= {hi} ({c[hi]} m)")
        if c["vx"] is None and c["vy"] is None:
            raise ck.error(cp, "give vx and/or vy [m/s] (an absent component stays free)", table=cp)
        if c["body"] is not None and c["body"] not in names:
            raise ck.error(cp + ("body",), f"unknown body {c['body']!r}{_suggest(c['body'], names)}")
        constraints.append(c)

    solver_t = ck.table(data.get("solver", {}), ("solver",), "duration, dt, safety, ...")
    ck.keys(solver_t, SOLVER_KEYS, ("solver",))
    if "duration" not in solver_t:
        raise SceneFileError(f"{ck.where(('solver',))}: [solver] missing required key 'duration' "
                             f"(simulated time of the run, s)")
    solver = ck.values(solver_t, SOLVER_KEYS, ("solver",))

    output_t = ck.table(data.get("output", {}), ("output",), "video, fps, vtu, ...")
    ck.keys(output_t, OUTPUT_KEYS, ("output",))
    output = ck.values(output_t, OUTPUT_KEYS, ("output",))
    if output["vtu"] is not None:
        import importlib.util
        if importlib.util.find_spec("taichi_fdem.io.vtu") is None:
            raise ck.error(("output", "vtu"), "VTU output needs taichi_fdem.io.vtu, which this version does not have")
    if output["checkpoint"] is not None:
        from ..simulation import Simulation
        if not hasattr(Simulation, "save"):
            raise ck.error(("output", "checkpoint"), "checkpoints need Simulation.save, which this version does not have")
    if "vtu_every" in output_t and output["vtu"] is None:
        raise ck.error(("output", "vtu_every"), "vtu_every needs vtu = \"folder\"")

    return SceneSpec(path=path, scene=scene, materials=materials, bodies=bodies, constraints=constraints,
                     solver=solver, output=output, description=description, _checker=ck)

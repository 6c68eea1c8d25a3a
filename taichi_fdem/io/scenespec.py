"""A checked scene file (:class:`SceneSpec`) and how to build and run it (:class:`RunSettings`).

:func:`taichi_fdem.io.scenefile.load` makes a :class:`SceneSpec`: plain data, cheap to pickle.
:meth:`SceneSpec.build` turns it into a :class:`~taichi_fdem.sim.simulation.Simulation` (meshes
generated or read, bodies and box constraints added) and :meth:`RunSettings.run` runs it with
the video, VTU series and checkpoint that the file's ``[output]`` asks for.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

from .toml_check import SceneFileError

__all__ = ["SceneSpec", "RunSettings"]


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
    cracks: bool = False
    crack_events: str | None = None
    vtu: str | None = None
    vtu_every: int = 1
    checkpoint: str | None = None
    history: str | None = None
    history_every: int | None = None

    def run(self, sim, progress: bool | None = None, duration: float | None = None) -> None:
        """Run ``sim`` for ``duration`` [s] (default: the file's) with the configured outputs."""
        duration = self.duration if duration is None else float(duration)
        from ..sim.recorders import CrackEvents, History
        record = []
        # frames every frame_dt (default: the video's, or 100 over the run); VTU every vtu_every-th
        frame_dt = self.frame_dt or (duration / max(1, 5 * self.fps) if self.video else duration / 100)
        if self.video:
            from ..render import RendererImage
            from ..render.recorder import Video
            renderer = RendererImage(self.width, self.height, color_by=self.color_by, cracks=self.cracks)
            folder = os.path.dirname(os.path.abspath(self.video))
            os.makedirs(folder, exist_ok=True)
            record.append(Video(self.video, fps=self.fps, frame_dt=frame_dt or None, renderer=renderer))
        if self.vtu:
            from .vtu import VTU                   # checked to exist by load()
            record.append(VTU(self.vtu, frame_dt=(frame_dt * self.vtu_every) or None))
        if self.crack_events:
            record.append(CrackEvents(self.crack_events))
        if self.history:
            record.append(History(self.history, every=self.history_every))
        sim.run(duration, record=record, progress=progress)
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
    lab : the ``[lab]`` table (a standard test, :meth:`run_lab`), or None; a lab file has no
        bodies, constraints, solver or output.
    fluid : the ``[fluid]`` table (None without one); injections : one dict per ``[[inject]]``.
    """

    path: str
    scene: dict
    materials: dict
    bodies: list
    constraints: list
    solver: dict
    output: dict
    description: str = ""
    lab: dict | None = None
    fluid: dict | None = None
    injections: list = field(default_factory=list)
    _checker: Any = field(default=None, repr=False)

    def run_lab(self):
        """Run the ``[lab]`` test of the file with :mod:`taichi_fdem.lab` (and write its ``csv``);
        returns the :class:`~taichi_fdem.lab.LabResult`.  ValueError when the file has no [lab]."""
        if not self.lab:
            raise ValueError(f"{self.path}: no [lab] table: build() and run it as a scene")
        from .. import lab as _lab
        p = dict(self.lab)
        test, mat, h, csv = p.pop("test"), self.materials[p.pop("material")], p.pop("h"), p.pop("csv", None)
        kw = {k: v for k, v in p.items() if v is not None}
        if test == "brazilian":
            r = _lab.brazilian(mat, kw.pop("diameter"), h, **kw)
        elif test == "ucs":
            r = _lab.ucs(mat, kw.pop("width"), kw.pop("height"), h, **kw)
        elif test == "triaxial":
            r = _lab.triaxial(mat, kw.pop("width"), kw.pop("height"), h, kw.pop("confinement"), **kw)
        else:
            r = _lab.direct_shear(mat, kw.pop("width"), kw.pop("height"), h, kw.pop("normal_stress"), **kw)
        if csv:
            folder = os.path.dirname(os.path.abspath(csv))
            os.makedirs(folder, exist_ok=True)
            r.to_csv(csv)
        return r

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
                return mesh.disk(b["radius"], b["h"], layout=b["layout"])
            if shape == "rectangle":
                return mesh.rectangle(b["width"], b["height"], b["h"], pattern=b["pattern"])
            if shape == "annulus":
                return mesh.annulus(b["r_inner"], b["r_outer"], b["h"], layout=b["layout"])
            lines = [mesh.Polyline(line) for line in b["cracks"]] if b.get("cracks") else None
            return mesh.polygon(b["vertices"], h=b["h"], lines=lines)
        except (ValueError, TypeError, OSError) as exc:
            raise self._body_error(i, "file" if shape == "file" else "shape",
                                   f"body {b['name']!r}: cannot make its {shape} mesh: {exc}") from None

    def build_scene(self):
        """(:class:`~taichi_fdem.scene.Scene`, {body name: Body}) with bodies and constraints added."""
        import numpy as np
        from .. import mesh as _mesh
        from ..discontinuity import NormalStrength, Weibull
        from ..scene import Scene
        scene = Scene(gravity=self.scene["gravity"], plane=self.scene["plane"], thickness=self.scene["thickness"])
        bodies = {}
        for i, b in enumerate(self.bodies):
            m = self.build_mesh(i)
            strength = None
            if b.get("weibull_modulus") is not None:
                strength = Weibull(b["weibull_modulus"], seed=b["strength_seed"])
            elif b.get("strength_cov") is not None:
                strength = NormalStrength(b["strength_cov"], seed=b["strength_seed"])
            cracks = None
            if b.get("cracks"):
                # given in the mesh's own coordinates: move them with the body (rotation about the
                # centroid, then the centroid to position), as add_body moves the mesh
                c0 = m.centroid
                ca, sa = np.cos(b["rotation"]), np.sin(b["rotation"])
                rot = np.array([[ca, -sa], [sa, ca]])
                shift = (np.asarray(b["position"]) - c0) if b["position"] is not None else np.zeros(2)
                cracks = [_mesh.Polyline((np.asarray(line) - c0) @ rot.T + c0 + shift) for line in b["cracks"]]
            try:
                bodies[b["name"]] = scene.add_body(
                    m, self.materials[b["material"]], position=b["position"], velocity=b["velocity"],
                    angular_velocity=b["angular_velocity"], rotation=b["rotation"], fixed=b["fixed"],
                    prescribed_velocity=b["prescribed_velocity"], self_contact=b["self_contact"], name=b["name"],
                    fracture=b.get("fracture", False), cracks=cracks, crack_friction=b.get("crack_friction"),
                    strength=strength)
            except (ValueError, TypeError) as exc:
                key = "cracks" if "crack" in str(exc) else "fracture" if "joint" in str(exc) else "name"
                raise self._body_error(i, key, str(exc)) from None
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
        fl = getattr(self, "fluid", None)
        if fl is not None:
            from ..material import Fluid
            from ..scene import Curve
            scene.set_fluid(Fluid(density=fl["density"], bulk_modulus=fl["bulk_modulus"], viscosity=fl["viscosity"]),
                            aperture_min=fl["aperture_min"], aperture_max=fl["aperture_max"],
                            initial_pressure=fl["initial_pressure"], conduct=fl["conduct"])
            for c in getattr(self, "injections", []):
                scene.inject(_BoxSelector(c["xmin"], c["xmax"], c["ymin"], c["ymax"]), rate=c["rate"],
                             pressure=c["pressure"], curve=Curve.ramp(c["ramp"]) if c["ramp"] is not None else None)
        return scene, bodies

    def build(self):
        """(:class:`~taichi_fdem.sim.simulation.Simulation`, :class:`RunSettings`)."""
        if self.lab:
            raise ValueError(f"{self.path}: a [lab] file runs a standard test: use run_lab() (taichi-fdem run)")
        scene, _ = self.build_scene()
        s = self.solver
        try:
            sim = scene.build(dt=s["dt"], safety=s["safety"], force_dt=s["force_dt"], buffer=s["buffer"],
                              strategy=s["strategy"], check_overlap=s["check_overlap"],
                              joined_pairs=s["joined_pairs"], handover_damage=s["handover_damage"],
                              quasi_static=s["quasi_static"] or False)
        except ValueError as exc:
            if "Scene.inject" in str(exc) or "Scene.set_fluid" in str(exc):
                table = "inject" if "inject" in str(exc) else "fluid"
                where = self._checker.where((table,)) if self._checker else self.path
                raise SceneFileError(f"{where}: [{table}] {exc}") from None
            key = "dt" if "dt" in str(exc) else "solver"
            where = self._checker.where(("solver", key)) if self._checker else self.path
            raise SceneFileError(f"{where}: [solver] {exc}") from None
        return sim, self.run_settings()

    def run_settings(self) -> RunSettings:
        o = self.output
        return RunSettings(duration=self.solver["duration"], video=o["video"], fps=o["fps"], frame_dt=o["frame_dt"],
                           color_by=o["color_by"], width=o["width"], height=o["height"], cracks=o["cracks"],
                           crack_events=o["crack_events"], vtu=o["vtu"],
                           vtu_every=o["vtu_every"], checkpoint=o["checkpoint"], history=o["history"],
                           history_every=o["history_every"])

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

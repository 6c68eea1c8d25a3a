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

from .scenetables.common import strength_of
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
    checks: dict | None = None
    excavations: list = field(default_factory=list)

    def run(self, sim, progress: bool | None = None, duration: float | None = None) -> None:
        """Run ``sim`` for ``duration`` [s] (default: the file's) with the configured outputs, the
        ``[checks]`` and the ``[[excavate]]`` removals.

        An excavation at ``time`` happens after step ``round(time / dt)`` of the simulation, as
        ``sim.run(time); sim.remove(...)`` does from the start; one due before this run's first
        step (a run resumed from a checkpoint written after it) has been done already, one due
        after its last step is not done (RuntimeWarning)."""
        duration = self.duration if duration is None else float(duration)
        from ..sim.recorders import Checks, CrackEvents, History
        record = []
        pending = []
        total = int(round(duration / sim.dt))
        for e in self.excavations:
            at = int(round(e["time"] / sim.dt)) - sim.step_count
            if at < 0 or (at == 0 and sim.step_count > 0):
                continue                        # done by the run that wrote the checkpoint
            if at == 0:
                _excavate(sim, e)
            elif at > total:
                import warnings
                warnings.warn(f"[[excavate]] at {e['time']:g} s is after the end of this run "
                              f"(t = {sim.time + total * sim.dt:g} s): not done", RuntimeWarning, stacklevel=2)
            else:
                pending.append((at, e))
        if pending:
            record.append(_excavations(pending))
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
        checks = None
        if self.checks is not None:
            c = self.checks
            checks = Checks(energy=c["energy"], energy_tol=c["energy_tol"],
                            max_penetration=c["max_penetration"] or None, every=c["every"])
        sim.run(duration, record=record, progress=progress, checks=checks)
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
    temperature : the ``[temperature]`` table (None without one); heat : one dict per ``[[heat]]``.
    curves : {name: {"times", "values"}} of ``[curves.NAME]``; joint_sets, interactions, loads,
        initial_stress, excavations : one dict per ``[[joint_sets]]``, ``[[interactions]]``,
        ``[[loads]]``, ``[[initial_stress]]``, ``[[excavate]]``; checks : the ``[checks]`` table.
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
    temperature: dict | None = None
    heat: list = field(default_factory=list)
    curves: dict = field(default_factory=dict)
    joint_sets: list = field(default_factory=list)
    interactions: list = field(default_factory=list)
    loads: list = field(default_factory=list)
    initial_stress: list = field(default_factory=list)
    excavations: list = field(default_factory=list)
    checks: dict | None = None
    _checker: Any = field(default=None, repr=False)

    def curve(self, name: str | None):
        """The :class:`~taichi_fdem.records.Curve` of ``[curves.NAME]`` (None for None)."""
        if name is None:
            return None
        from ..scene import Curve
        made = self.__dict__.setdefault("_made_curves", {})
        if name not in made:                # one Curve per name: the uses of a name share it
            c = self.curves[name]
            made[name] = Curve(c["times"], c["values"], name=name)
        return made[name]

    def run_lab(self):
        """Run the ``[lab]`` test of the file with :mod:`taichi_fdem.lab` (and write its ``csv``);
        returns the :class:`~taichi_fdem.lab.LabResult`.  ValueError when the file has no [lab]."""
        if not self.lab:
            raise ValueError(f"{self.path}: no [lab] table: build() and run it as a scene")
        from .. import lab as _lab
        p = dict(self.lab)
        test, h, csv = p.pop("test"), p.pop("h"), p.pop("csv", None)
        mname, mnames = p.pop("material", None), p.pop("materials", None)
        grain = {k: p.pop(k, None) for k in ("grain_size", "grain_seed", "minerals", "relax")}
        joint_sets = p.pop("joint_sets", None)
        kw = {k: v for k, v in p.items() if v is not None}
        mat = self.materials[mname] if mname is not None else None
        if grain["grain_size"] is not None:
            from .. import mesh as _mesh
            width, height = (kw["diameter"], kw["diameter"]) if test == "brazilian" else (kw["width"], kw["height"])
            m, labels = _mesh.voronoi_grains(width, height, grain["grain_size"], h, seed=grain["grain_seed"],
                                             minerals=grain["minerals"], relax=grain["relax"],
                                             shape="disc" if test == "brazilian" else "rectangle")
            import numpy as np
            mat = labels.materials({k: self.materials[n] for k, n in mnames.items()}) if mnames is not None \
                else {g: mat for g in np.unique(np.asarray(labels)).tolist()}
            kw.update(mesh=m, groups=labels)
        if joint_sets:
            from .. import mesh as _mesh
            kw["joint_sets"] = [(j["name"], "interfaces" if j["interfaces"] else
                                 [_mesh.Polyline(line) for line in j["lines"]] if j["lines"] is not None
                                 else _Region(**_region(j)), self.materials[j["material"]]) for j in joint_sets]
        for k in ("platen", "lower_material"):
            if k in kw:
                kw[k] = self.materials[kw[k]]
        if "quasi_static" in kw:
            kw["quasi_static"] = kw["quasi_static"] or False
        strength = strength_of(p)
        for k in ("weibull_modulus", "strength_cov", "strength_seed"):
            kw.pop(k, None)
        if strength is not None:
            kw["strength"] = strength
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
                if b.get("groups"):
                    return mesh.load_tagged(b["file"], key=b.get("group_key"))[:2]
                if b.get("group") is not None:
                    groups = mesh.load_groups(b["file"], key=b.get("group_key"))
                    by_text = {str(g): g for g in groups}
                    if b["group"] not in by_text:
                        raise ValueError(f"no group {b['group']!r} in the file; its groups: "
                                         f"{', '.join(by_text)}")
                    return groups[by_text[b["group"]]]
                return mesh.load(b["file"], cell_block=b["cell_block"])
            if shape == "plate_with_hole":
                return mesh.plate_with_hole(b["width"], b["height"], b["radius"], b["h"])
            if shape == "grains":
                return mesh.voronoi_grains(b["width"], b["height"], b["grain_size"], b["h"], seed=b["seed"],
                                           minerals=b["minerals"], shape=b["outline"], relax=b["relax"])
            if shape == "disk":
                return mesh.disk(b["radius"], b["h"], layout=b["layout"])
            if shape == "rectangle":
                return mesh.rectangle(b["width"], b["height"], b["h"], pattern=b["pattern"])
            if shape == "annulus":
                return mesh.annulus(b["r_inner"], b["r_outer"], b["h"], layout=b["layout"])
            lines = [mesh.Polyline(line) for line in (b.get("cracks") or []) + _fracture_lines(b)]
            lines += self._bedding_planes(b)
            return mesh.polygon(b["vertices"], h=b["h"], lines=lines or None, engine=b.get("engine") or "builtin")
        except (ValueError, TypeError, OSError) as exc:
            raise self._body_error(i, "file" if shape == "file" else "shape",
                                   f"body {b['name']!r}: cannot make its {shape} mesh: {exc}") from None

    def _bedding_planes(self, b) -> list:
        """[the bedding planes through a polygon body] when its material has ``Bedding(spacing=...)``
        (``fdem.mesh.bedding_lines`` of its vertices: the mesh follows them), else []."""
        from .. import mesh
        bed = getattr(self.materials.get(b.get("material")), "bedding", None) if b.get("material") else None
        if bed is None or bed.spacing is None:
            return []
        planes = mesh.bedding_lines(b["vertices"], bed.angle, bed.spacing)
        return [] if planes is None else [planes]

    def _error(self, path: tuple, message: str) -> SceneFileError:
        if self._checker is None:
            return SceneFileError(f"{self.path}: [{path[0]}[{path[1]}]] {message}")
        return self._checker.error(path, message, table=path[:2])

    def build_scene(self):
        """(:class:`~taichi_fdem.scene.Scene`, {body name: Body}): bodies, joint sets, contact
        interactions, constraints, loads, initial stresses, the fluid and its sources, the
        temperatures added, in that order (each kind in the file's order)."""
        from ..scene import Scene
        scene = Scene(gravity=self.scene["gravity"], plane=self.scene["plane"], thickness=self.scene["thickness"])
        self.__dict__["_made_curves"] = {}
        bodies = {b["name"]: self._add_body(scene, i) for i, b in enumerate(self.bodies)}
        self._add_joint_sets(scene, bodies)
        for c in self.interactions:
            a, b = (self.materials[n] for n in c["materials"])
            scene.set_interaction(a, b, friction=c["friction"], penalty=c["penalty"],
                                  tangential_penalty=c["tangential_penalty"], contact_damping=c["contact_damping"])
        self._add_boundary(scene, bodies)
        self._add_fluid(scene)
        self._add_heat(scene, bodies)
        return scene, bodies

    def _add_body(self, scene, i: int):
        """Add body ``i`` to ``scene`` (its mesh built, its polylines placed with it); returns the Body."""
        import numpy as np
        from .. import mesh as _mesh
        b = self.bodies[i]
        built = self.build_mesh(i)
        m, labels = built if isinstance(built, tuple) else (built, None)
        if b.get("materials") is not None or b["shape"] == "grains":
            material, groups = self._group_materials(i, labels), labels
        else:
            material, groups = self.materials[b["material"]], None
        # polylines are given in the mesh's own coordinates: move them with the body (rotation
        # about the centroid, then the centroid to position), as add_body moves the mesh
        c0 = m.centroid
        ca, sa = np.cos(b["rotation"]), np.sin(b["rotation"])
        rot = np.array([[ca, -sa], [sa, ca]])
        shift = (np.asarray(b["position"]) - c0) if b["position"] is not None else np.zeros(2)
        moved = b["position"] is not None or b["rotation"] != 0.0
        move = (lambda p: (np.asarray(p) - c0) @ rot.T + c0 + shift) if moved else np.asarray  # noqa: E731
        line_groups = self._line_groups(i)
        place = lambda line: _mesh.Polyline(move(line))  # noqa: E731
        place_group = lambda name: _mesh.Segments(  # noqa: E731
            move(line_groups(name).segments.reshape(-1, 2)).reshape(-1, 2, 2), name=name)
        cracks = None
        if b.get("cracks"):
            cracks = [place(line) for line in b["cracks"]]
        elif b.get("crack_regions"):
            cracks = [_edges(r, place, place_group) for r in b["crack_regions"]]
        try:
            return scene.add_body(
                m, material, position=b["position"], velocity=b["velocity"],
                angular_velocity=b["angular_velocity"], rotation=b["rotation"], fixed=b["fixed"],
                prescribed_velocity=b["prescribed_velocity"], self_contact=b["self_contact"], name=b["name"],
                fracture=_edges(b.get("fracture", False), place, place_group), cracks=cracks,
                crack_friction=b.get("crack_friction"), strength=strength_of(b), groups=groups,
                velocity_curve=self.curve(b.get("velocity_curve")))
        except (ValueError, TypeError) as exc:
            key = "cracks" if "crack" in str(exc) else "fracture" if "joint" in str(exc) or "fracture" in str(exc) \
                else "name"
            raise self._body_error(i, key, str(exc)) from None

    def _add_joint_sets(self, scene, bodies: dict) -> None:
        """Add the ``[[joint_sets]]`` (after all bodies)."""
        from .. import mesh as _mesh
        for k, j in enumerate(self.joint_sets):
            if j["interfaces"]:
                selector = "interfaces"
            elif j["lines"] is not None:
                selector = [_mesh.Polyline(line) for line in j["lines"]]
            else:
                selector = _Region(**_region(j))
            try:
                scene.add_joint_set(j["name"], selector, self.materials[j["material"]],
                                    body=bodies[j["body"]] if j["body"] else None, strength=strength_of(j))
            except (ValueError, TypeError) as exc:
                raise self._error(("joint_sets", k), str(exc)) from None

    def _add_boundary(self, scene, bodies: dict) -> None:
        """Add the ``[[constraints]]``, ``[[loads]]`` and ``[[initial_stress]]``; a region that
        selects no node is refused."""
        for k, c in enumerate(self.constraints):
            where = _Region(**_region(c))
            body = bodies[c["body"]] if c["body"] else None
            self._selects(scene, where, body, ("constraints", k), "node")
            scene.fix_nodes(where, body=body, velocity=(c["vx"], c["vy"]), curve=self.curve(c.get("curve")))
        for k, c in enumerate(self.loads):
            where = _Region(**_region(c))
            body = bodies[c["body"]] if c["body"] else None
            self._selects(scene, where, body, ("loads", k), "node")
            if c["kind"] == "pressure":
                scene.apply_pressure(where, c["pressure"], body=body, curve=self.curve(c["curve"]))
            elif c["kind"] == "traction":
                scene.apply_traction(where, c["traction"], body=body, curve=self.curve(c["curve"]))
            elif c["kind"] == "force":
                scene.apply_force(where, c["force"], body=body, curve=self.curve(c["curve"]))
            else:
                scene.absorbing_boundary(where, body=body)
        for c in self.initial_stress:
            scene.initial_stress(c["sxx"], c["syy"], c["sxy"], body=bodies[c["body"]] if c["body"] else None,
                                 gradient=c["gradient"], y_ref=c["y_ref"])

    def _add_fluid(self, scene) -> None:
        """Set the ``[fluid]`` and add its ``[[inject]]`` sources (nothing without a fluid)."""
        fl = getattr(self, "fluid", None)
        if fl is not None:
            from ..material import Fluid
            from ..scene import Curve
            scene.set_fluid(Fluid(density=fl["density"], bulk_modulus=fl["bulk_modulus"], viscosity=fl["viscosity"]),
                            aperture_min=fl["aperture_min"], aperture_max=fl["aperture_max"],
                            initial_pressure=fl["initial_pressure"], conduct=fl["conduct"])
            for c in getattr(self, "injections", []):
                curve = Curve.ramp(c["ramp"]) if c["ramp"] is not None else self.curve(c.get("curve"))
                scene.inject(_Region(**_region(c)), rate=c["rate"], pressure=c["pressure"], curve=curve)

    def _add_heat(self, scene, bodies: dict) -> None:
        """Set the ``[temperature]`` and add the ``[[heat]]`` rows (nothing without them)."""
        from ..scene import Curve
        t = getattr(self, "temperature", None)
        if t is not None:
            scene.set_temperature(t["initial"])
        for k, c in enumerate(getattr(self, "heat", [])):
            where = _Region(**_region(c))
            body = bodies[c["body"]] if c["body"] else None
            self._selects(scene, where, body, ("heat", k), "node")
            curve = Curve.ramp(c["ramp"]) if c["ramp"] is not None else self.curve(c.get("curve"))
            scene.heat(where, body=body, temperature=c["temperature"], flux=c["flux"], curve=curve)

    def _line_groups(self, i: int):
        """``get(name)``: the Segments of the physical line group ``name`` of body ``i``'s mesh
        file (read when first asked for)."""
        b, cache = self.bodies[i], {}

        def get(name):
            from .. import mesh as _mesh
            if "groups" not in cache:
                try:
                    cache["groups"] = _mesh.load_groups(b["file"], key=b.get("group_key"), lines=True)[1]
                except (ValueError, OSError) as exc:
                    raise self._body_error(i, "fracture", f"body {b['name']!r}: cannot read the line groups of "
                                           f"its mesh file: {exc}") from None
            by_text = {str(g): g for g in cache["groups"]}
            if name not in by_text:
                raise self._body_error(i, "fracture", f"body {b['name']!r}: no line group {name!r} in its mesh "
                                       f"file; its line groups: {', '.join(by_text) or 'none'}")
            return cache["groups"][by_text[name]]
        return get

    def _group_materials(self, i: int, labels):
        """The ``material`` dict of add_body(groups=labels) for body ``i`` (grains or a tagged file)."""
        import numpy as np
        b = self.bodies[i]
        if b["shape"] == "grains":
            if b.get("materials") is None:
                mat = self.materials[b["material"]]
                return {g: mat for g in np.unique(np.asarray(labels)).tolist()}
            return labels.materials({mineral: self.materials[n] for mineral, n in b["materials"].items()})
        present = np.unique(np.asarray(labels)).tolist()
        by_text = {str(lb): lb for lb in present}
        out = {}
        for label, name in b["materials"].items():
            if label not in by_text:
                raise self._body_error(i, "materials", f"body {b['name']!r}: the mesh file has no group {label!r}; "
                                       f"its groups: {', '.join(map(str, present))}")
            out[by_text[label]] = self.materials[name]
        missing = [lb for lb in present if str(lb) not in b["materials"]]
        if missing:
            raise self._body_error(i, "materials", f"body {b['name']!r}: no material for group(s) "
                                   f"{', '.join(map(str, missing))} of the mesh file")
        return out

    def _selects(self, scene, where, body, path: tuple, what: str) -> None:
        import numpy as np
        pts = body.mesh.points if body is not None else np.concatenate([b.mesh.points for b in scene.bodies])
        if not where(pts[:, 0], pts[:, 1]).any():
            kind = "box" if where.ring == (None, None) else "region"
            raise self._error(path, f"the {kind} selects no {what} (bounds are in the initial, placed positions, "
                              f"metres)")

    def build(self):
        """(:class:`~taichi_fdem.sim.simulation.Simulation`, :class:`RunSettings`).  The
        ``[[excavate]]`` removals happen in :meth:`RunSettings.run`."""
        if self.lab:
            raise ValueError(f"{self.path}: a [lab] file runs a standard test: use run_lab() (taichi-fdem run)")
        scene, _ = self.build_scene()
        s = self.solver
        try:
            sim = scene.build(dt=s["dt"], safety=s["safety"], force_dt=s["force_dt"], buffer=s["buffer"],
                              strategy=s["strategy"], check_overlap=s["check_overlap"],
                              joined_pairs=s["joined_pairs"], handover_damage=s["handover_damage"],
                              quasi_static=s["quasi_static"] or False, speed_limit=s.get("speed_limit"))
        except ValueError as exc:
            for table, tag in (("loads", "apply_"), ("loads", "absorbing"), ("initial_stress", "initial")):
                if tag in str(exc) and getattr(self, table, None):
                    where = self._checker.where((table,)) if self._checker else self.path
                    raise SceneFileError(f"{where}: [{table}] {exc}") from None
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
                           history_every=o["history_every"], checks=getattr(self, "checks", None),
                           excavations=[dict(e) for e in getattr(self, "excavations", [])])

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_checker"] = None
        state.pop("_made_curves", None)
        return state


class _BoxSelector:
    """Picklable predicate ``xmin <= x <= xmax and ymin <= y <= ymax`` (None = unbounded) [m]."""

    def __init__(self, xmin, xmax, ymin, ymax):
        self.box = (xmin, xmax, ymin, ymax)

    def __call__(self, x, y):
        import numpy as np
        xmin, xmax, ymin, ymax = (v if v is not None else s * np.inf for v, s in zip(self.box, (-1, 1, -1, 1)))
        return (x >= xmin) & (x <= xmax) & (y >= ymin) & (y <= ymax)


class _Region:
    """Picklable predicate of a region [m]: the box ``xmin <= x <= xmax``, ``ymin <= y <= ymax``
    and the ring ``r_min <= |(x, y) − center| <= r_max`` (None = unbounded; center (0, 0))."""

    def __init__(self, xmin=None, xmax=None, ymin=None, ymax=None, center=None, r_min=None, r_max=None):
        self.box = (xmin, xmax, ymin, ymax)
        self.center = (0.0, 0.0) if center is None else tuple(center)
        self.ring = (r_min, r_max)

    def __call__(self, x, y):
        import numpy as np
        xmin, xmax, ymin, ymax = (v if v is not None else s * np.inf for v, s in zip(self.box, (-1, 1, -1, 1)))
        sel = (x >= xmin) & (x <= xmax) & (y >= ymin) & (y <= ymax)
        r_min, r_max = self.ring
        if r_min is not None or r_max is not None:
            r = np.hypot(x - self.center[0], y - self.center[1])
            if r_min is not None:
                sel = sel & (r >= r_min)
            if r_max is not None:
                sel = sel & (r <= r_max)
        return sel


def _region(c: dict) -> dict:
    return {k: c.get(k) for k in ("xmin", "xmax", "ymin", "ymax", "center", "r_min", "r_max")}


def _fracture_lines(b: dict) -> list:
    """The polylines of a body's ``fracture`` tables (mesh coordinates)."""
    f = b.get("fracture")
    tables = f if isinstance(f, list) else [f]
    return [line for t in tables if isinstance(t, dict) and t.get("lines") for line in t["lines"]]


def _edges(value, place, place_group):
    """add_body's ``fracture=`` (or ``cracks=``) of a checked value (tables made selectors)."""
    if isinstance(value, list):
        return [_edges(v, place, place_group) for v in value]
    if isinstance(value, dict):
        if value.get("lines"):
            return [place(line) for line in value["lines"]]
        if value.get("line_group") is not None:
            return place_group(value["line_group"])
        return _Region(**_region(value))
    return value


def _excavate(sim, e: dict) -> None:
    where = None
    if any(e.get(k) is not None for k in ("xmin", "xmax", "ymin", "ymax", "r_min", "r_max")):
        where = _Region(**_region(e))
    body = None
    if e.get("body") is not None:
        body = next(b for b in sim.bodies if b.name == e["body"])
    sim.remove(body=body, where=where)


def _excavations(pending: list):
    """A recorder that removes the triangles of each ``(steps, [[excavate]])`` of ``pending``
    after that many steps of the run (its rows fall on those steps)."""
    from ..sim.recorders import Recorder

    class _Excavations(Recorder):
        def __init__(self):
            self.at = [a for a, _ in pending]
            self.excavations = [e for _, e in pending]

        def open(self, sim, steps, duration):
            import math
            self.done = [False] * len(self.at)
            g = 0
            for a in self.at:
                g = math.gcd(g, a)
            self.every = max(1, g)

        def row(self, sim, done):
            for k, (a, e) in enumerate(zip(self.at, self.excavations)):
                if not self.done[k] and done >= a:
                    self.done[k] = True
                    _excavate(sim, e)

    return _Excavations()

"""Checkpoints: the whole state of a :class:`~taichi_fdem.sim.simulation.Simulation` in one file.

::

    sim.save("run.ckpt")                          # or checkpoint.save(sim, path)
    sim = fdem.Simulation.load("run.ckpt")        # or checkpoint.load(path)

A restarted run continues exactly as the uninterrupted run would (bit for bit with the serial
strategy).  The model (topology, rest shapes, masses, tables: what ``build()`` computes) is not
stored but rebuilt from the scene; the file holds

* the state — exactly the arrays declared with the role ``state`` in
  :data:`taichi_fdem.engine.arrays.ARRAYS` (:data:`taichi_fdem.sim.arrays.STATE_ARRAYS`: nodes,
  couples and their friction history, joint state, dissipation, counters, the fluid), by name,
  with its kind (scalar / vector / matrix), element dtype and shape, plus the state's plain
  attributes (the couple capacity); an array declared for the state is saved without being
  listed here;
* every other attribute of the simulation (step count, strategy, launch counts, last good
  state, and anything a user hung on it), pickled, Taichi ndarrays inside tuples, lists and
  dicts included as NumPy data, and the build settings (time step, buffer, speed limit);
* the :class:`~taichi_fdem.scene.Scene` (meshes, materials, bodies, settings), pickled, with
  each ``fix_nodes`` and load predicate replaced by the node mask it selected, and each callable
  bedding angle by the angles it gave at the triangles' centroids, so that lambdas need not be
  picklable (curves are plain data).

:func:`load` rebuilds the scene with the saved time step, strategy, buffer and speed limit
(``force_dt=True``, no overlap check), then overwrites every saved state array — re-allocating
those whose saved shape differs, e.g. a couple buffer that grew.

The file is a NumPy ``.npz`` archive (whatever its name), written to ``path + ".tmp"`` and
moved over ``path`` with :func:`os.replace` only once complete, so a crash while saving never
leaves a corrupt file as the latest checkpoint.  It records a format version and the
floating-point precision; loading under another precision (``fdem.init(precision=...)``)
is refused.

Loading unpickles Python objects from the file: only load checkpoints you trust.
"""
from __future__ import annotations

import copy
import dataclasses
import json
import os
import pickle

import numpy as np
import taichi as ti

from .. import backend
from ..engine.arrays import STATE, declared
from ..engine.groups import DAMAGED, EDGE_FREE, INT_COUNTERS, INTACT, REAL_COUNTERS, REBALANCE
from ..sim.arrays import allocate
from ..sim.state import install_neighbour_pairs, nb_on_size, set_parameters, state_sizes

__all__ = ["save", "load", "CheckpointError", "FORMAT", "FORMAT_VERSION"]

FORMAT = "taichi_fdem.checkpoint"
#: Incremented when the layout of the file changes incompatibly.
FORMAT_VERSION = 2

# attributes of the simulation rebuilt by load() rather than stored: the scene (stored on its
# own), what build() derives from it, the state (stored array by array) and the argpacks
_REBUILT = frozenset({"scene", "bodies", "thickness", "model", "state", "scratch", "_scratch", "_packs", "_groups",
                      "solver", "cracks", "fluid", "loads",
                      "_launch_cache", "_teams"})     # (the team's timings belong to this process)


class CheckpointError(ValueError):
    """A checkpoint file that cannot be loaded (corrupt, foreign, another version or precision)."""


class _NodeMask:
    """A picklable stand-in for a ``fix_nodes`` predicate: the node mask it selected at build."""

    def __init__(self, mask: np.ndarray):
        self.mask = np.asarray(mask, dtype=bool)

    def __call__(self, x, y):
        if np.shape(x) != self.mask.shape:
            raise ValueError(f"checkpoint: a fix_nodes selection restored from a checkpoint holds "
                             f"{self.mask.size} nodes, the scene now has {np.size(x)}")
        return self.mask.copy()


class _NodeValues:
    """A picklable stand-in for a callable initial temperature (``scene.set_temperature(f)``): the
    values it gave at the nodes' initial positions at build."""

    def __init__(self, values: np.ndarray):
        self.values = np.asarray(values, dtype=np.float64)

    def __call__(self, x, y):
        if np.shape(x) != self.values.shape:
            raise ValueError(f"checkpoint: an initial temperature restored from a checkpoint holds "
                             f"{self.values.size} nodes, the scene now has {np.size(x)}")
        return self.values.copy()


class _BeddingAngles:
    """A picklable stand-in for a callable bedding angle (``Bedding(angle=f)``): the angles [°] it
    gave at the triangles' centroids at build, looked up by the centroid."""

    def __init__(self, xy: np.ndarray, angles: np.ndarray):
        self.table = {(float(x), float(y)): float(a) for (x, y), a in zip(np.asarray(xy), np.asarray(angles))}

    def __call__(self, x, y):
        try:
            return np.array([self.table[(float(a), float(b))] for a, b in zip(np.ravel(x), np.ravel(y))])
        except KeyError:
            raise ValueError("checkpoint: a bedding angle restored from a checkpoint is known at the centroids of "
                             "the saved scene's triangles only") from None


def _fixed_bedding(sim) -> dict:
    """{id(material): a copy whose callable bedding angle is a :class:`_BeddingAngles`}."""
    import warnings
    md = sim.model
    out = {}
    centroid = md.node_rest[md.tri_nodes_np].mean(axis=1)
    for k, m in enumerate(md.materials):
        bed = getattr(m, "bedding", None)
        if bed is None or not callable(bed.angle) or isinstance(bed.angle, _BeddingAngles):
            continue
        sel = md.tri_mat_np == k
        with warnings.catch_warnings():         # its warnings were given when it was made
            warnings.simplefilter("ignore")
            out[id(m)] = m.with_(bedding=bed.with_(angle=_BeddingAngles(centroid[sel], md.tri_bedding_np[sel])))
    return out


def _substitute_materials(bodies, subst: dict) -> list:
    """Copies of the bodies with their materials replaced by ``subst`` (by id)."""
    out = []
    for b in bodies:
        b2 = copy.copy(b)
        b2.material = subst.get(id(b.material), b.material)
        if getattr(b, "materials", None):
            b2.materials = [subst.get(id(m), m) for m in b.materials]
        out.append(b2)
    return out


def _ndarray_meta(arr) -> dict:
    from taichi.lang.matrix import MatrixNdarray, VectorNdarray

    if isinstance(arr, MatrixNdarray):
        kind, elem = "matrix", [int(arr.n), int(arr.m)]
    elif isinstance(arr, VectorNdarray):
        kind, elem = "vector", [int(arr.n)]
    else:
        kind, elem = "scalar", []
    return {"kind": kind, "elem": elem, "dtype": str(arr.dtype), "shape": [int(s) for s in arr.shape]}


def _alloc(meta: dict):
    dtype = getattr(ti, meta["dtype"])
    shape = tuple(meta["shape"])
    if meta["kind"] == "matrix":
        return ti.Matrix.ndarray(meta["elem"][0], meta["elem"][1], dtype, shape=shape)
    if meta["kind"] == "vector":
        return ti.Vector.ndarray(meta["elem"][0], dtype, shape=shape)
    return ti.ndarray(dtype, shape=shape)


class _PackedNdarray:
    """A Taichi ndarray found inside a container attribute (tuple, list, dict), as NumPy data."""

    def __init__(self, arr):
        self.meta = _ndarray_meta(arr)
        self.data = arr.to_numpy()

    def unpack(self):
        arr = _alloc(self.meta)
        arr.from_numpy(np.array(self.data, order="C"))
        return arr


def _pack(value):
    """``value`` with every Taichi ndarray inside (plain) tuples, lists and dicts replaced by a
    picklable :class:`_PackedNdarray` (e.g. a cache of scratch buffers)."""
    if isinstance(value, ti.Ndarray):
        return _PackedNdarray(value)
    if type(value) in (tuple, list):
        return type(value)(_pack(v) for v in value)
    if type(value) is dict:
        return {k: _pack(v) for k, v in value.items()}
    return value


def _unpack(value):
    if isinstance(value, _PackedNdarray):
        return value.unpack()
    if type(value) in (tuple, list):
        return type(value)(_unpack(v) for v in value)
    if type(value) is dict:
        return {k: _unpack(v) for k, v in value.items()}
    return value


def _scene_bundle(sim) -> dict:
    """The scene of ``sim`` in a picklable form (a shallow copy; the user's scene is untouched)."""
    from ..scene import _Load, _NodeConstraint

    scene = copy.copy(sim.scene)
    scene.bodies = list(sim.bodies)
    scene._node_count, scene._tri_count = sim.model.node_count, sim.model.tri_count
    X = np.asarray(sim.model.node_rest, dtype=np.float64)
    constraints = []
    for k, con in enumerate(sim.scene._constraints):
        # the predicate is evaluated on the initial positions, exactly as at build
        mask = np.asarray(con.where(X[:, 0].copy(), X[:, 1].copy()), dtype=bool)
        constraints.append(_NodeConstraint(_NodeMask(mask), con.body, con.velocity, getattr(con, "curve", None)))
    scene._constraints = constraints
    loads = []
    for ld in getattr(sim.scene, "_loads", []):       # load selections likewise become node masks
        mask = np.asarray(ld.where(X[:, 0].copy(), X[:, 1].copy()), dtype=bool)
        loads.append(_Load(ld.kind, _NodeMask(mask), ld.body, ld.value, ld.curve))
    scene._loads = loads
    # heat: the selections of scene.heat become node masks, a callable initial temperature its values
    scene._heat = [dataclasses.replace(h, where=_NodeMask(np.asarray(h.where(X[:, 0].copy(), X[:, 1].copy()),
                                                                      dtype=bool)))
                   for h in getattr(sim.scene, "_heat", [])]
    if callable(getattr(sim.scene, "_temperature", None)):
        scene._temperature = _NodeValues(np.broadcast_to(np.asarray(
            sim.scene._temperature(X[:, 0].copy(), X[:, 1].copy()), dtype=np.float64), (len(X),)).copy())
    if getattr(sim.model, "fluid", False):             # sources: masks over the network's nodes
        Xf = sim.model.fluid_node_rest
        scene._injections = [dataclasses.replace(inj, where=_NodeMask(np.asarray(
            inj.where(Xf[:, 0].copy(), Xf[:, 1].copy()), dtype=bool))) for inj in sim.scene._injections]
    # a callable bedding angle becomes the table of the angles it gave (a lambda is not picklable)
    subst = _fixed_bedding(sim)
    if subst:
        scene.bodies = _substitute_materials(scene.bodies, subst)
    # interactions are keyed by id(material): store the material objects themselves
    by_id = {}
    for b in sim.bodies:
        for m in (getattr(b, "materials", None) or [b.material]):
            by_id[id(m)] = subst.get(id(m), m)
    interactions = [(by_id[a], by_id[b], dict(props)) for (a, b), props in sim.scene._interactions.items()
                    if a in by_id and b in by_id]
    scene._interactions = {}
    return {"scene": scene, "interactions": interactions}


def save(sim, path) -> None:
    """Write the state of ``sim`` and its scene to ``path`` atomically (see the module docstring).

    Raises TypeError naming the attribute when a plain attribute of the state cannot be stored.
    """
    path = os.fspath(path)
    arrays: dict[str, np.ndarray] = {}
    nd_meta: dict[str, dict] = {}
    state_plain: dict = {}
    for name, value in sim.state.ndarrays().items():        # exactly the declared state arrays
        nd_meta[name] = _ndarray_meta(value)
        arrays["nd." + name] = value.to_numpy()
    for name, value in vars(sim.state).items():
        if isinstance(value, ti.Ndarray):
            continue
        elif isinstance(value, np.ndarray):
            arrays["np." + name] = value
        else:
            try:
                pickle.dumps(value)
            except Exception as exc:
                raise TypeError(f"Simulation.save: state attribute {name!r} ({type(value).__name__}) cannot be "
                                f"stored in a checkpoint: {exc}") from None
            state_plain[name] = value
    driver: dict = {}
    for name, value in vars(sim).items():         # step count, strategy, counters, and anything a user added
        if name in _REBUILT:
            continue
        if not isinstance(value, ti.Ndarray) and type(value).__module__.split(".")[0] == "taichi":
            raise TypeError(f"Simulation.save: attribute {name!r} is a Taichi {type(value).__name__}; "
                            f"only Taichi ndarrays can be checkpointed")
        value = _pack(value)
        try:
            pickle.dumps(value)
        except Exception as exc:
            raise TypeError(f"Simulation.save: attribute {name!r} ({type(value).__name__}) cannot be "
                            f"stored in a checkpoint: {exc}") from None
        driver[name] = value
    md = sim.model
    plain = {"driver": driver, "state": state_plain,
             "build": {"dt": md.dt, "force_dt": md.force_dt, "buffer": md.buffer, "speed_limit": md.speed_limit,
                       "quasi_static": getattr(md, "qs_alpha", 0.0), "joined_pairs": md.joined_pairs,
                       "handover_damage": md.handover_damage}}
    try:
        scene_bytes = pickle.dumps(_scene_bundle(sim), protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as exc:
        raise TypeError(f"Simulation.save: the scene cannot be stored in a checkpoint: {exc}") from None
    from .. import __version__

    meta = {"format": FORMAT, "version": FORMAT_VERSION, "package_version": __version__,
            "precision": backend.precision(), "ndarrays": nd_meta, "step_count": int(sim.step_count),
            "time": float(sim.time)}
    arrays["meta"] = np.array(json.dumps(meta))
    arrays["scene"] = np.frombuffer(scene_bytes, dtype=np.uint8)
    arrays["plain"] = np.frombuffer(pickle.dumps(plain, protocol=pickle.HIGHEST_PROTOCOL), dtype=np.uint8)

    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise FileNotFoundError(f"Simulation.save: directory {directory!r} does not exist")
    tmp = path + ".tmp"
    try:
        with open(tmp, "wb") as fh:      # a file object: savez must not append ".npz" to the name
            np.savez(fh, **arrays)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    try:                                 # make the rename itself durable (POSIX)
        dfd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)
    except OSError:
        pass


def _read(path: str) -> dict:
    import zipfile

    try:
        z = np.load(path, allow_pickle=False)
        if not hasattr(z, "files"):
            raise CheckpointError(f"Simulation.load: {path!r} is a single NumPy array, not a "
                                  f"taichi_fdem checkpoint")
        with z:
            data = {k: z[k] for k in z.files}
    except (FileNotFoundError, IsADirectoryError, PermissionError):
        raise
    except CheckpointError:
        raise
    except (zipfile.BadZipFile, ValueError, OSError, EOFError, KeyError, RuntimeError) as exc:
        raise CheckpointError(f"Simulation.load: {path!r} is not a readable taichi_fdem checkpoint "
                              f"(corrupt or truncated file: {type(exc).__name__}: {exc})") from None
    missing = [k for k in ("meta", "scene", "plain") if k not in data]
    if missing:
        raise CheckpointError(f"Simulation.load: {path!r} is not a taichi_fdem checkpoint "
                              f"(missing {', '.join(missing)})")
    try:
        meta = json.loads(str(data["meta"]))
    except ValueError as exc:
        raise CheckpointError(f"Simulation.load: {path!r}: unreadable metadata ({exc})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise CheckpointError(f"Simulation.load: {path!r} is not a taichi_fdem checkpoint")
    version = meta.get("version")
    if version != FORMAT_VERSION:
        raise CheckpointError(f"Simulation.load: {path!r} has checkpoint format version {version!r}; this "
                              f"taichi_fdem reads version {FORMAT_VERSION} "
                              f"(the file was written by taichi_fdem {meta.get('package_version', '?')})")
    data["meta"] = meta
    return data


def load(path):
    """Rebuild the :class:`~taichi_fdem.sim.simulation.Simulation` saved in ``path`` by :func:`save`.

    Raises
    ------
    FileNotFoundError
        No such file.
    CheckpointError (a ValueError)
        The file is corrupt or truncated, not a checkpoint, of another format version, or was
        written under another floating-point precision than the active one.
    """
    path = os.fspath(path)
    data = _read(path)
    meta = data["meta"]
    active = backend.precision()
    if meta.get("precision") != active:
        raise CheckpointError(f"Simulation.load: {path!r} was written with precision {meta.get('precision')!r} "
                              f"but taichi_fdem runs in {active!r}; call fdem.init(precision="
                              f"{meta.get('precision')!r}) before loading")
    scene, build, driver, state_plain = _unbundle(path, data)
    strategy = driver.get("_strategy", driver.get("strategy", "auto"))
    sim = scene.build(dt=build["dt"], force_dt=True, strategy=strategy,
                      buffer=build["buffer"], speed_limit=build["speed_limit"], check_overlap=False,
                      quasi_static=build.get("quasi_static", 0.0) or False,
                      joined_pairs=build.get("joined_pairs", "contact"),     # (older checkpoints: "contact",
                      handover_damage=build.get("handover_damage", 0.0))     # and the handover at first damage)
    sim.model.force_dt = bool(build.get("force_dt", False))    # (built with force_dt: the saved dt is kept)
    st = sim.state
    for name, value in state_plain.items():
        setattr(st, name, value)
    _restore_arrays(path, data, st)
    _upgrade_state(sim, build)
    for name, value in driver.items():
        setattr(sim, name, _unpack(value))
    sim._after_restore()
    return sim


def _unbundle(path: str, data: dict):
    """(scene, build settings, driver attributes, plain state attributes) of the checkpoint
    ``data`` read from ``path``, the scene's interactions keyed by its materials again;
    CheckpointError when they cannot be unpickled."""
    try:
        bundle = pickle.loads(data["scene"].tobytes())
        plain = pickle.loads(data["plain"].tobytes())
        scene = bundle["scene"]
        scene._interactions = {}
        for a, b, props in bundle["interactions"]:
            scene._interactions[(id(a), id(b))] = props
        return scene, plain["build"], plain["driver"], plain["state"]
    except Exception as exc:
        raise CheckpointError(f"Simulation.load: {path!r}: the saved scene or settings cannot be read "
                              f"({type(exc).__name__}: {exc})") from None


def _restore_arrays(path: str, data: dict, st) -> None:
    """Overwrite the arrays of the state ``st`` with those of the checkpoint ``data`` (read from
    ``path``): every saved Taichi array, re-allocated when its saved kind, dtype or shape differs,
    and every saved NumPy array.  CheckpointError for a saved array the state does not declare,
    missing data, or data that does not fit."""
    meta = data["meta"]
    undeclared = sorted(set(meta["ndarrays"]) - set(declared(STATE)))
    if undeclared:
        raise CheckpointError(f"Simulation.load: {path!r} holds state arrays this taichi_fdem does not declare: "
                              f"{', '.join(undeclared)}")
    for name, m in meta["ndarrays"].items():
        key = "nd." + name
        if key not in data:
            raise CheckpointError(f"Simulation.load: {path!r} lacks the data of array {name!r}")
        values = data[key]
        current = getattr(st, name, None)
        if not (isinstance(current, ti.Ndarray) and _ndarray_meta(current) == m):
            current = _alloc(m)              # e.g. a couple buffer that grew during the run
            setattr(st, name, current)
        try:
            current.from_numpy(np.array(values, order="C"))
        except Exception as exc:
            raise CheckpointError(f"Simulation.load: {path!r}: array {name!r} ({m}) cannot be restored "
                                  f"from data of shape {values.shape} ({exc})") from None
    for key, values in data.items():
        if key.startswith("np."):
            setattr(st, key[3:], values)


def _upgrade_state(sim, build: dict) -> None:
    """Bring the restored state of ``sim`` written by an older layout to the current one: the
    tri_intact bits of the joined pairs, the counters and parameter slots, the fans' link masks and
    the neighbour pairs, each when the checkpoint (its ``build`` settings or array shapes) predates it."""
    st = sim.state
    if "joined_pairs" not in build and sim.model.fracture:
        # a checkpoint from before the tri_intact bits (1 intact, 0 damaged): no edge carried,
        # and a damaged triangle of a fracturing body is bonded to nothing
        v = st.tri_intact.to_numpy()
        frac = sim.model.tri_fracturing
        v = np.where(v >= 1, v | (7 * EDGE_FREE), np.where(frac & (v == 0), INTACT | (7 * EDGE_FREE) | DAMAGED, v))
        st.tri_intact.from_numpy(v.astype(np.int32))
    old_params = st.step_int.shape[0] < INT_COUNTERS or st.step_real.shape[0] < REAL_COUNTERS
    if st.step_int.shape[0] < INT_COUNTERS:
        # a checkpoint from before the block assembly's couple ranges or node ranges (computed anew
        # at the next step), or before the switches' slot
        ints = np.zeros(INT_COUNTERS, np.int32)
        ints[: st.step_int.shape[0]] = st.step_int.to_numpy()
        ints[REBALANCE] = 0
        allocate(st, STATE, state_sizes(sim.model, st), {"step_int": ints}, names=("step_int",))
    if st.step_real.shape[0] < REAL_COUNTERS:
        # a checkpoint from before the parameter slots of step_real
        reals = np.zeros(REAL_COUNTERS, st.step_real.to_numpy().dtype)
        reals[: st.step_real.shape[0]] = st.step_real.to_numpy()
        allocate(st, STATE, state_sizes(sim.model, st), {"step_real": reals}, names=("step_real",))
    if old_params:
        # the parameter slots the checkpoint lacks: from the rebuilt model (the saved time step, buffer
        # and speed limit)
        set_parameters(sim.model, st)
    if st.tri_nb_on.shape[0] != nb_on_size(sim.model):
        # a checkpoint from before the fans' link masks: re-derived by the restore
        allocate(st, STATE, state_sizes(sim.model, st), names=("tri_nb_on",))
    if sim.model.nb_count and st.counters.nb_pairs != sim.model.nb_count:
        # a checkpoint from before neighbour pairs: they become the first couples again and the
        # others are detected anew (the slip history of the saved couples is not carried over)
        install_neighbour_pairs(sim.model, st)

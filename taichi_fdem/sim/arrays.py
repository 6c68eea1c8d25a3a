"""The declared arrays of :class:`~taichi_fdem.sim.model.Model`, :class:`~taichi_fdem.sim.model.State`
and :class:`~taichi_fdem.sim.model.Scratch`, their allocation, and the named counters.

The declarations are :data:`taichi_fdem.engine.arrays.ARRAYS` (name, group, role, element type,
shape, unit); this module reads them by role (:data:`MODEL_ARRAYS`, :data:`MODEL_HOST_ARRAYS`,
:data:`STATE_ARRAYS`, :data:`SCRATCH_ARRAYS`), allocates them at the scene's sizes
(:func:`allocate`), checks the host arrays against them (:func:`check_host`), renders their table
for the documentation (:func:`markdown`) and gives the counters of ``step_real`` / ``step_int``
names (:class:`Counters`).  Every Taichi array a Model, State or Scratch holds is declared and
every declared one is allocated with its declared element type and shape
(tests/test_arrays.py); checkpoints and the last good state save exactly the declared state
arrays (:meth:`State.ndarrays <taichi_fdem.sim.model._Arrays.ndarrays>`).
"""
from __future__ import annotations

import numpy as np
import taichi as ti

from .. import backend
from ..engine import arrays as decl
from ..engine.arrays import (DET_CAND, GROUP_ORDER, HOST, INT_COUNTERS, INT_SLOTS, MODEL, REAL_COUNTERS, REAL_SLOTS,
                             SCRATCH, SIZES, STATE, SYNC_LINE, Array, declared, element)

__all__ = ["ArraySpec", "MODEL_ARRAYS", "MODEL_HOST_ARRAYS", "STATE_ARRAYS", "SCRATCH_ARRAYS", "allocate",
           "check_host", "shape_of", "element_shape", "markdown", "Counters",
           "host_write", "counter", "set_counter"]

ArraySpec = Array

#: Taichi arrays of the Model (computed once at build; read by the kernels, never written).
MODEL_ARRAYS = declared(MODEL)
#: NumPy arrays of the Model (host copies and build results).
MODEL_HOST_ARRAYS = declared(HOST)
#: Taichi arrays of the State (what a step changes; all saved by checkpoints).
STATE_ARRAYS = declared(STATE)
#: Taichi arrays of the Scratch (work arrays of detection and of the parallel assembly; never saved).
SCRATCH_ARRAYS = declared(SCRATCH)

_CONSTANTS = {"REAL_COUNTERS": REAL_COUNTERS, "INT_COUNTERS": INT_COUNTERS, "DET_CAND": DET_CAND,
              "SYNC_LINE": SYNC_LINE}


def _eval(text: str, sizes: dict, what: str) -> int:
    ns = {"__builtins__": {}, "max": max, "min": min, **_CONSTANTS, **sizes}
    try:
        value = eval(text, ns)      # noqa: S307 (expressions of engine.arrays, over the size symbols)
    except NameError as exc:
        raise KeyError(f"{what}: size {exc.name!r} of {text!r} not given (sizes: {sorted(sizes)})") from None
    return int(value)


def shape_of(spec: Array, sizes: dict) -> tuple:
    """The shape of a declared array at ``sizes`` ({symbol of engine.arrays.SIZES: value})."""
    return tuple(_eval(d, sizes, spec.name) for d in spec.shape)


def element_shape(spec: Array, sizes: dict) -> tuple:
    """The shape of one element of a declared array: () scalar, (K,) vector, (K, K) matrix."""
    _, kind, width = element(spec.dtype)
    if kind == "scalar":
        return ()
    k = _eval(width, sizes, spec.name)
    return (k,) if kind == "vector" else (k, k)


def _dtypes(base: str):
    """(Taichi, NumPy) type of a declared base type."""
    if base == "real":
        return backend.real_ti(), backend.real_np()
    return {"i32": (ti.i32, np.int32), "f64": (ti.f64, np.float64), "bool": (None, np.bool_)}[base]


def host_write(arr, key, value) -> None:
    """``arr[key] = value`` from the host, after the kernels already launched have finished.

    Taichi's element write from Python does not wait for the device: on Vulkan it lands before a
    kernel still in flight (a ``fill`` or a step) runs, which then overwrites or adds to it.
    Every host write of an ndarray element goes through here (reads and ``from_numpy`` are
    ordered with the launches already)."""
    ti.sync()
    arr[key] = value


def counter(arr, k: int):
    """Counter k of State.step_real / step_int, as a Python number (by name: :class:`Counters`)."""
    v = arr[k]
    return int(v) if arr.dtype in (ti.i32, ti.i64) else float(v)


def set_counter(arr, k: int, value) -> None:
    """Set counter k of State.step_real / step_int (:func:`host_write`)."""
    host_write(arr, k, value)


def allocate(obj, role: str, sizes: dict, values: dict | None = None, names=None) -> None:
    """Set on ``obj`` a new Taichi ndarray for every declared array of ``role`` (or only ``names``),
    of the declared element type and shape at ``sizes``, holding ``values[name]`` (NumPy data of
    exactly that shape, or the value of a 0-d array), or zeros when no value is given.  A model
    array must be given its value.  The declarations are read at each call (engine.arrays.ARRAYS)."""
    values = values or {}
    table = declared(role)
    unknown = set(values) - set(table)
    if unknown:
        raise KeyError(f"allocate: {sorted(unknown)} are not declared {role} arrays (engine.arrays.ARRAYS)")
    for name in (table if names is None else names):
        spec = table[name]
        shape, elem = shape_of(spec, sizes), element_shape(spec, sizes)
        tdt, ndt = _dtypes(element(spec.dtype)[0])
        if len(elem) == 1:
            arr = ti.Vector.ndarray(elem[0], tdt, shape=shape)
        elif len(elem) == 2:
            arr = ti.Matrix.ndarray(elem[0], elem[1], tdt, shape=shape)
        else:
            arr = ti.ndarray(tdt, shape=shape)
        if name in values:
            if shape == ():
                host_write(arr, None, values[name])
            else:
                data = np.ascontiguousarray(values[name], dtype=ndt)
                if data.shape != shape + elem:
                    raise ValueError(f"internal error: array {name} holds values of shape {data.shape}, declared "
                                     f"{shape + elem} ({spec.dtype} {spec.shape}, engine.arrays)")
                arr.from_numpy(data)
        elif role == MODEL:
            raise ValueError(f"internal error: model array {name} is declared but given no value")
        setattr(obj, name, arr)


def check_host(md, sizes: dict) -> None:
    """Raise when a declared host array of ``md`` is missing or not of its declared type and shape."""
    for name, spec in declared(HOST).items():
        arr = getattr(md, name, None)
        if not isinstance(arr, np.ndarray):
            raise ValueError(f"internal error: host array {name} is declared but not built")
        want = shape_of(spec, sizes)
        ndt = _dtypes(element(spec.dtype)[0])[1]
        if arr.shape != want or arr.dtype != ndt:
            raise ValueError(f"internal error: host array {name} is {arr.dtype} {arr.shape}, declared "
                             f"{np.dtype(ndt)} {want}")


# -------------------------------------------------------------------------------------------------
# counters
# -------------------------------------------------------------------------------------------------
class Counters:
    """The counters of a state by name: ``state.counters.couples``, ``state.counters.time = 0.0``.

    One attribute per slot of :data:`taichi_fdem.engine.arrays.REAL_SLOTS` (from ``step_real``,
    a float) and :data:`~taichi_fdem.engine.arrays.INT_SLOTS` (from ``step_int``, an int), its
    name in lower case; a run of slots (``split``, ``range``) reads as a NumPy array.  Reads and
    writes go through :func:`taichi_fdem.sim.model.counter` / :func:`~taichi_fdem.sim.model.set_counter`.
    """
    __slots__ = ("_state",)

    def __init__(self, state):
        self._state = state

    def __repr__(self) -> str:
        return "Counters(" + ", ".join(f"{s.name.lower()}={getattr(self, s.name.lower())!r}"
                                       for s in REAL_SLOTS + INT_SLOTS if s.count == 1) + ")"


def _counter_property(array: str, first: int, slot) -> property:
    if slot.count > 1:
        def get(self):
            return getattr(self._state, array).to_numpy()[first:first + slot.count]
        return property(get, doc=f"{slot.doc} [{slot.unit}] ({array}[{first}:{first + slot.count}])")

    def get(self):
        return counter(getattr(self._state, array), first)

    def put(self, value):
        set_counter(getattr(self._state, array), first, value)
    return property(get, put, doc=f"{slot.doc} [{slot.unit}] ({array}[{slot.name}])")


def _install_counters() -> None:
    for array, slots in (("step_real", REAL_SLOTS), ("step_int", INT_SLOTS)):
        k = 0
        for s in slots:
            setattr(Counters, s.name.lower(), _counter_property(array, k, s))
            k += s.count


_install_counters()


# -------------------------------------------------------------------------------------------------
# the documentation's table
# -------------------------------------------------------------------------------------------------
def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def markdown() -> str:
    """The array table of docs/reference/arrays.md, generated from the declarations."""
    out = ["(array-table)=", "# Arrays", "",
           "Generated from `taichi_fdem/engine/arrays.py` (`python docs/_ext/array_table.py` writes this page;",
           "`make docs` too): every array of a simulation, one declaration each, from which the argpack groups",
           "of `engine/groups.py`, the allocation of model, state and scratch, the checkpoint list and this",
           "table are generated.", "",
           "Roles: **model** computed once by the build, constant through a run; **state** changed by the",
           "steps, saved by checkpoints; **scratch** work arrays, never saved; **host** NumPy results of",
           "the build kept by the model. `real` is the precision chosen by `fdem.init` (f64 or f32); `vecK` a",
           "K-vector per entry, `matK` a K×K matrix. Shapes are expressions over the sizes below.", ""]
    for group in GROUP_ORDER + ("",):
        rows = [a for a in decl.ARRAYS if a.group == group]
        out += [f"## {'Host arrays of the model' if not group else 'Group `' + group + '`'}", "",
                "| array | role | element | shape | unit | meaning |", "|---|---|---|---|---|---|"]
        for a in rows:
            shape = "(" + ", ".join(a.shape) + ("," if len(a.shape) == 1 else "") + ")"
            out.append(f"| `{a.name}` | {a.role} | `{_cell(a.dtype)}` | `{_cell(shape)}` | {_cell(a.unit)} | "
                       f"{_cell(a.doc)} |")
        out.append("")
    out += ["## Sizes", "", "| symbol | meaning |", "|---|---|"]
    out += [f"| `{k}` | {_cell(v)} |" for k, v in SIZES.items()]
    out.append("")
    for array, slots in (("step_real", REAL_SLOTS), ("step_int", INT_SLOTS)):
        out += [f"## Counters of `{array}`", "",
                "| slot | constant | host name | unit | meaning |", "|---|---|---|---|---|"]
        k = 0
        for s in slots:
            where = str(k) if s.count == 1 else f"{k}–{k + s.count - 1}"
            out.append(f"| {where} | `{s.name}` | `counters.{s.name.lower()}` | {_cell(s.unit)} | {_cell(s.doc)} |")
            k += s.count
        out.append("")
    return "\n".join(out)

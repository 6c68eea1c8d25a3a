"""Checked TOML: reading a file, finding the line of a key, checking keys and values.

The machinery under scene files (:mod:`.scenefile`) and sweep files (:mod:`taichi_fdem.sweep`):

* :func:`read_toml` reads a file with :mod:`tomllib` (``tomli`` on Python 3.10);
* :class:`_Locator` maps a key path to its line (tomllib gives no positions);
* :class:`_Key` describes one allowed key (kind, default, unit, bounds, choices);
* :class:`_Checker` refuses unknown keys (suggesting the closest allowed one) and values of
  the wrong type, sign or range, with :class:`SceneFileError` messages that name the file, the
  line, the table and the key.

Nothing here knows what a scene is.
"""
from __future__ import annotations

import difflib
import math
import os
import re
import sys
from dataclasses import dataclass
from typing import Any

__all__ = ["SceneFileError", "read_toml"]


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
# key specifications
# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Key:
    kind: str              # float, int, bool, str, vec2, vertices, polylines, choice, floats (a list of
    #                        numbers), strs (a list of strings), names ({label: str}), weights ({name: > 0});
    #                        any other kind is passed through for the caller to check
    default: Any = None
    unit: str = ""
    lo: float | None = None          # inclusive lower bound
    lo_open: bool = False            # lower bound exclusive
    hi: float | None = None          # inclusive upper bound (vec2: of each component's magnitude)
    choices: tuple = ()
    required: bool = False


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
        line = None
        for n in range(len(path), 0, -1):        # a key of an inline table: the line of the table
            line = self.loc.line(tuple(path[:n]))
            if line:
                break
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
            if spec.hi is not None and max(abs(v[0]), abs(v[1])) > spec.hi:
                raise self.error(kp, f"{key} components must be within ±{spec.hi:g}{unit}, got {list(v)!r}")
        elif spec.kind == "vertices":
            ok = isinstance(v, list) and len(v) >= 3 and all(
                isinstance(p, list) and len(p) == 2 and all(
                    not isinstance(c, bool) and isinstance(c, (int, float)) and math.isfinite(c) for c in p) for p in v)
            if not ok:
                raise self.error(kp, f"{key} must be a list of at least 3 points [[x, y], ...]{unit}, got {v!r}")
            v = [(float(p[0]), float(p[1])) for p in v]
        elif spec.kind == "polylines":
            ok = isinstance(v, list) and len(v) >= 1 and all(
                isinstance(line, list) and len(line) >= 2 and all(
                    isinstance(p, list) and len(p) == 2 and all(
                        not isinstance(c, bool) and isinstance(c, (int, float)) and math.isfinite(c) for c in p)
                    for p in line) for line in v)
            if not ok:
                raise self.error(kp, f"{key} must be a list of polylines [[[x, y], [x, y], ...], ...] of at least "
                                 f"2 points each{unit}, got {v!r}")
            v = [[(float(p[0]), float(p[1])) for p in line] for line in v]
        elif spec.kind == "floats":
            if (not isinstance(v, list) or not v
                    or any(isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c) for c in v)):
                raise self.error(kp, f"{key} must be a list of finite numbers{unit}, got {v!r}")
            v = [float(c) for c in v]
        elif spec.kind == "strs":
            if not isinstance(v, list) or not v or any(not isinstance(c, str) or not c for c in v):
                raise self.error(kp, f"{key} must be a list of non-empty strings, got {v!r}")
        elif spec.kind == "names":
            if (not isinstance(v, dict) or not v
                    or any(not isinstance(c, str) or not c for c in v.values())):
                raise self.error(kp, f"{key} must be a table {{label = \"name\", ...}}, got {v!r}")
        elif spec.kind == "weights":
            if (not isinstance(v, dict) or not v
                    or any(isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c) or c <= 0
                           for c in v.values())):
                raise self.error(kp, f"{key} must be a table {{name = proportion, ...}} of positive numbers, got {v!r}")
            v = {k: float(c) for k, c in v.items()}
        if spec.kind in ("float", "int"):
            if spec.lo is not None and (v < spec.lo or (spec.lo_open and v == spec.lo)):
                raise self.error(kp, f"{key} must be {'>' if spec.lo_open else '>='} {spec.lo:g}{unit}, got {v!r}")
            if spec.hi is not None and v > spec.hi:
                raise self.error(kp, f"{key} must be <= {spec.hi:g}{unit}, got {v!r}")
        return v

    def values(self, table: dict, schema: dict, path: tuple, only=None) -> dict:
        return {k: self.value(table, k, schema[k], path) for k in (schema if only is None else only)}


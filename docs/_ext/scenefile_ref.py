"""Sphinx extension: writes ``reference/scenefile.md`` from the schemas that check scene files.

The tables come from the key schemas of :mod:`taichi_fdem.io.scenefile` (type, unit, default,
range, required) and the meaning of each key from the reference tables of that module's
docstring.  A schema key without a meaning there stops the build, so the page cannot fall
behind the loader.
"""
from __future__ import annotations

from _pages import write_if_changed

import os
import re

SECTIONS = (  # (title, schema attribute, docstring header)
    ("[scene]", "SCENE_KEYS", "``[scene]``"),
    ("[materials.NAME]", "MATERIAL_KEYS", "``[materials.NAME]``"),
    ("[materials.NAME.bedding]", "BEDDING_KEYS", "``[materials.NAME.bedding]``"),
    ("[curves.NAME]", "CURVE_KEYS", "``[curves.NAME]``"),
    ("[[bodies]]", "BODY_KEYS", "``[[bodies]]``"),
    ("[[joint_sets]]", "JOINT_SET_KEYS", "``[[joint_sets]]``"),
    ("[[interactions]]", "INTERACTION_KEYS", "``[[interactions]]``"),
    ("[[constraints]]", "CONSTRAINT_KEYS", "``[[constraints]]``"),
    ("[[loads]]", "LOAD_KEYS", "``[[loads]]``"),
    ("[[initial_stress]]", "INITIAL_STRESS_KEYS", "``[[initial_stress]]``"),
    ("[fluid]", "FLUID_KEYS", "``[fluid]``"),
    ("[[inject]]", "INJECT_KEYS", "``[[inject]]``"),
    ("[temperature]", "TEMPERATURE_KEYS", "``[temperature]``"),
    ("[[heat]]", "HEAT_KEYS", "``[[heat]]``"),
    ("[[excavate]]", "EXCAVATE_KEYS", "``[[excavate]]``"),
    ("[solver]", "SOLVER_KEYS", "``[solver]``"),
    ("[checks]", "CHECK_KEYS", "``[checks]``"),
    ("[output]", "OUTPUT_KEYS", "``[output]``"),
    ("[lab]", "LAB_KEYS", "``[lab]``"),
)
_ROW = re.compile(r"^([^\s,]+(?:, [^\s,]+)*)\s+(\S+)\s{2,}(.*)$")


def meanings(doc: str) -> dict:
    """{docstring header: {key: meaning}} parsed from the module docstring's reference tables."""
    out, current, last = {}, None, None
    for line in doc.splitlines():
        s = line.rstrip()
        if s.startswith("``[") and s.split()[0] in {h for _, _, h in SECTIONS}:
            current, last = s.split()[0], None
            out[current] = {}
            continue
        if current is None or not s or s.startswith("="):
            continue
        if s.startswith(" "):
            if last is not None:
                for k in last:
                    out[current][k] += " " + s.strip()
            continue
        m = _ROW.match(s)
        if not m or m.group(1) == "key":
            if not m and not s.startswith("key"):
                current = None if not s.startswith("``[") else current
            continue
        last = [k.strip() for k in m.group(1).split(",")]
        for k in last:
            out[current][k] = m.group(3).strip()
    return out


def _fmt_num(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, (tuple, list)):
        return "[" + ", ".join(_fmt_num(x) for x in v) + "]"
    if isinstance(v, str):
        return f'"{v}"'
    return str(v)


def _range(k) -> str:
    if k.choices:
        return " / ".join(f'"{c}"' for c in k.choices)
    lo = "" if k.lo is None else (f"> {_fmt_num(k.lo)}" if k.lo_open else f"≥ {_fmt_num(k.lo)}")
    hi = "" if k.hi is None else f"≤ {_fmt_num(k.hi)}"
    if k.kind == "vec2" and k.hi is not None:
        hi = f"each |component| ≤ {_fmt_num(k.hi)}"
    return ", ".join(x for x in (lo, hi) if x)


def _cell(s: str) -> str:
    return s.replace("|", "\\|")


def render() -> str:
    """The Markdown text of the scene-file reference page."""
    from taichi_fdem.io import scenefile as sf
    from taichi_fdem.material import BOUNDS
    mean = meanings(sf.__doc__)
    lines = [
        "(scenefile-reference)=",
        "# Scene-file reference",
        "",
        "This page is generated at build time from the key schemas of `taichi_fdem.io.scenefile`,",
        "the same tables that check a file when it is loaded. All values are SI. *Default* is the",
        "value used when the key is absent (— : none, or computed as the meaning says).",
        "An unknown key, a wrong type or a value out of range is refused with the file, the line",
        "and the key (see {doc}`../guide/troubleshooting`).",
        "",
        "Top-level keys and tables: " + ", ".join(f"`{k}`" for k in sf.TOP_KEYS) + ".",
        "",
    ]
    missing = []
    for title, attr, header in SECTIONS:
        schema = getattr(sf, attr)
        lines += [f"## `{title}`", "", "| key | type | unit | default | allowed | meaning |",
                  "|---|---|---|---|---|---|"]
        for name, k in schema.items():
            text = mean.get(header, {}).get(name)
            if text is None:
                missing.append(f"{title} {name}")
                text = ""
            default = "**required**" if k.required else ("—" if k.default is None else _fmt_num(k.default))
            lines.append(f"| `{name}` | {k.kind} | {k.unit or '—'} | {_cell(default)} | {_cell(_range(k))} "
                         f"| {_cell(text)} |")
        lines.append("")
        if attr == "BODY_KEYS":
            lines += ["Mesh keys by `shape` (required; optional):", "", "| shape | required | optional |",
                      "|---|---|---|"]
            for shape, (req, opt) in sf.SHAPE_KEYS.items():
                label = "`file` (no shape)" if shape == "file" else f'`"{shape}"`'
                lines.append(f"| {label} | {', '.join(req)} | {', '.join(opt) or '—'} |")
            lines.append("")
        if attr == "MATERIAL_KEYS":
            lines += ["Material values are also bounded by `taichi_fdem.material.BOUNDS`:", "",
                      "| quantity [unit] | lower | upper |", "|---|---|---|"]
            for q, (lo, hi, unit) in BOUNDS.items():
                lines.append(f"| `{q}` [{unit or '—'}] | {_fmt_num(lo)} | {_fmt_num(hi)} |")
            lines.append("")
    if missing:
        raise RuntimeError("scene-file keys with no meaning in taichi_fdem.io.scenefile's docstring: "
                           + ", ".join(missing))
    lines += ["A top-level `description` string is free text.", "",
              "Sweeps override any key by its dotted path (`materials.rock.friction`, `bodies.0.velocity`,",
              "...), see {doc}`../guide/sweeps`.", ""]
    return "\n".join(lines)


def _write(app) -> None:
    path = os.path.join(app.srcdir, "reference", "scenefile.md")
    write_if_changed(path, render())


def setup(app):
    app.connect("builder-inited", _write)
    return {"version": "1", "parallel_read_safe": True}

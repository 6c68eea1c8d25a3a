"""Sphinx extension: writes ``gallery_items.md``, one section per demo of ``demos/``.

Each section has the demo's one-line description (the first paragraph of its docstring), its
still ``gallery/NAME.png`` and its GIF ``gallery/NAME.gif`` when ``make gallery`` has made them.
"""
from __future__ import annotations

from _pages import write_if_changed

import ast
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def render(srcdir: str) -> str:
    demos = os.path.join(ROOT, "demos")
    lines = []
    for f in sorted(os.listdir(demos)):
        if not f.endswith(".py") or f.startswith("_"):
            continue
        name = f[:-3]
        doc = ast.get_docstring(ast.parse(open(os.path.join(demos, f), encoding="utf-8").read())) or ""
        first = " ".join(doc.split("\n\n")[0].split())
        lines += [f"## `{name}`", "", first, "", f"`python demos/{f}` (short: `--short`)", ""]
        shown = False
        for ext, label in (("png", "still"), ("gif", "animation")):
            if os.path.exists(os.path.join(srcdir, "gallery", f"{name}.{ext}")):
                lines += [f"![{name} {label}](gallery/{name}.{ext})", ""]
                shown = True
        if not shown:
            lines += ["(this demo writes a CSV table, not a video)" if name == "sweep_friction"
                      else "(no picture in this build: `make gallery` makes it)", ""]
    return "\n".join(lines)


def _write(app) -> None:
    path = os.path.join(app.srcdir, "gallery_items.md")
    write_if_changed(path, render(app.srcdir))


def setup(app):
    app.connect("builder-inited", _write)
    return {"version": "1", "parallel_read_safe": True}

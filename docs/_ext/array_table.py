"""Sphinx extension: writes ``reference/arrays.md``, the table of every declared array and counter,
from the declarations of ``taichi_fdem/engine/arrays.py`` (:func:`taichi_fdem.sim.arrays.markdown`).

The page is also kept in the repository; ``python docs/_ext/array_table.py`` rewrites it, and
tests/test_arrays.py checks that it is the generated one.
"""
from __future__ import annotations

import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
PAGE = os.path.join(ROOT, "docs", "reference", "arrays.md")


def render() -> str:
    if ROOT not in sys.path:
        sys.path.insert(0, ROOT)
    from taichi_fdem.sim.arrays import markdown
    return markdown()


def _write(app) -> None:
    from _pages import write_if_changed
    write_if_changed(os.path.join(app.srcdir, "reference", "arrays.md"), render())


def setup(app):
    app.connect("builder-inited", _write)
    return {"version": "1", "parallel_read_safe": True}


if __name__ == "__main__":
    sys.path.insert(0, HERE)
    from _pages import write_if_changed
    write_if_changed(PAGE, render())
    print(f"wrote {os.path.relpath(PAGE, ROOT)}")

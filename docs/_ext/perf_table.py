"""Sphinx extension: writes ``performance_table.md``, the latest benchmark tables, from
``benchmarks/results.json`` through ``benchmarks/report.py`` (the generator of
``benchmarks/results.md`` and of the README's table), so that the three show the same figures.
"""
from __future__ import annotations

from _pages import write_if_changed

import json
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BENCH = os.path.join(ROOT, "benchmarks")


def render() -> str:
    """The Markdown text of the tables: host, commands, the pile, the plate, the README's table."""
    if BENCH not in sys.path:
        sys.path.insert(0, BENCH)
    import report
    with open(report.JSON_PATH, encoding="utf-8") as fh:
        data = json.load(fh)
    return "\n".join([
        f"Host: {data['host']}; measured {data['date']}. On a shared host the same run varies by",
        "10–20 %.", "",
        "### Pile of disks", "", f"`{data['pile_command']}`", "",
        "Steps/s over the timed run, M triangle-steps/s in brackets, the best of its windows in square",
        "brackets.", "", report.pile_table(data["pile"]), "",
        "Start-up to the first step of the 1k pile (empty / reused offline kernel cache): "
        + "; ".join(f"{k}: cold {v['cold_s']:.1f} s, warm {v['warm_s']:.1f} s"
                    for k, v in data.get("startup", {}).items()) + ".", "",
        "### Plate impact", "", f"`{data['plate_command']}`", "", "M triangle-steps/s.", "",
        report.plate_table(data["plate"]), "",
        "### The README's table", "", report.readme_table(data), ""])


def _write(app) -> None:
    write_if_changed(os.path.join(app.srcdir, "performance_table.md"), render())


def setup(app):
    app.connect("builder-inited", _write)
    return {"version": "1", "parallel_read_safe": True}

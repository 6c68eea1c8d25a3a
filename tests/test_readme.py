"""The README's Python code runs as written, and what its text says about the results holds."""
from __future__ import annotations

import os
import re

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def python_blocks(path: str) -> list[str]:
    """The ```python blocks of a Markdown file, in order."""
    with open(os.path.join(ROOT, path), encoding="utf-8") as fh:
        return re.findall(r"```python\n(.*?)```", fh.read(), re.S)


def test_the_readme_has_one_example_of_at_most_15_lines():
    blocks = python_blocks("README.md")
    assert len(blocks) == 1
    assert len(blocks[0].strip().splitlines()) <= 15


def test_the_readme_is_a_front_page():
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as fh:
        assert len(fh.read().splitlines()) <= 250


def test_readme_example_runs_as_written(tmp_path, monkeypatch, capsys):
    """The example runs (fdem.init with the settings the test run has: it does nothing), writes
    its video, the disk bounces off the floor, and the comment on energies() names
    keys it returns."""
    (code,) = python_blocks("README.md")
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    exec(compile(code, "README.md", "exec"), scope)
    assert (tmp_path / "out" / "readme.mp4").stat().st_size > 0
    sim = scope["sim"]
    assert sim.time == pytest.approx(0.02, abs=2 * sim.dt)
    e = sim.energies()
    comment = code.split("print(sim.energies())")[1].splitlines()[0]
    named = [k.strip() for k in comment.split(":", 1)[1].split(",") if k.strip() not in ("...", "")]
    assert named and set(named) <= set(e), (named, sorted(e))
    # the README's list of the energy account is the whole account
    from taichi_fdem.sim.energies import TOTAL_TERMS
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as fh:
        text = " ".join(fh.read().split())
    listed = re.search(r"`sim.energies\(\)` holds every term of the energy account \(([^)]*)\)", text).group(1)
    assert {k.strip() for k in listed.split(",")} == {k for k, _ in TOTAL_TERMS}
    # the disk (released 0.01 m above the floor at 1 m/s down) has bounced off the floor: it moves
    # up again, and its centre is above the floor's top (y = 0) by at least its radius, 0.05 m
    disk = scope["disk"]
    assert sim.node_velocities(disk).mean(axis=0)[1] > 0.0
    assert sim.node_positions(disk).mean(axis=0)[1] > 0.05


def test_readme_links_point_at_files_of_the_repository():
    """Every relative link and image of the README and of benchmarks/README.md names a file or
    folder that exists."""
    bad = []
    for path in ("README.md", "benchmarks/README.md"):
        with open(os.path.join(ROOT, path), encoding="utf-8") as fh:
            text = fh.read()
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"[a-z]+://", target) or target.startswith("#"):
                continue
            if not os.path.exists(os.path.join(ROOT, os.path.dirname(path), target.split("#")[0])):
                bad.append(f"{path}: {target}")
    assert not bad, bad

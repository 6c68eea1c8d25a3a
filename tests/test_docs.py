"""The documentation stays true: its Python code blocks run, its internal links resolve, the
design-note map covers every citation in the code, and the scene-file reference covers every
key of the loader's schemas.

The site itself is built with warnings as errors by ``make docs`` (which CI runs); these tests
need no Sphinx.
"""
import os
import re
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOCS = os.path.join(ROOT, "docs")
sys.path.insert(0, os.path.join(DOCS, "_ext"))

_FENCE = re.compile(r"^```python[^\n]*\n(.*?)^```\s*$", re.S | re.M)
_GENERATED = {"reference/scenefile.md", "reference/errors.md", "gallery_items.md", "performance_table.md"}


def _pages():
    out = []
    for folder, dirs, files in os.walk(DOCS):
        dirs[:] = [d for d in dirs if not d.startswith("_")]
        out += [os.path.relpath(os.path.join(folder, f), DOCS).replace(os.sep, "/") for f in files if f.endswith(".md")]
    return sorted(p for p in out if p not in _GENERATED)


def _read(page):
    return open(os.path.join(DOCS, page), encoding="utf-8").read()


PAGES_WITH_CODE = [p for p in _pages() if _FENCE.search(_read(p))]


def test_some_pages_have_code():
    """The pages whose examples are executed below (a guard against a fence pattern that matches nothing)."""
    assert {"getting_started.md", "guide/meshes.md", "guide/outputs.md"} <= set(PAGES_WITH_CODE)


@pytest.mark.parametrize("page", PAGES_WITH_CODE)
def test_code_blocks_run(page, tmp_path):
    """All ```python blocks of a page run in order in one fresh interpreter (as a reader would
    paste them), from an empty working directory, and exit cleanly."""
    code = "\n\n".join(m.group(1) for m in _FENCE.finditer(_read(page)))
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=600)
    assert p.returncode == 0, f"{page}: code blocks failed\n{p.stdout[-2000:]}\n{p.stderr[-4000:]}"


def _targets():
    """Every document (without suffix) and every MyST label of the site."""
    docs = {p[:-3] for p in _pages()} | {p[:-3] for p in _GENERATED} | {"api/index"}
    labels = set()
    for p in _pages():
        labels |= set(re.findall(r"^\(([A-Za-z0-9_-]+)\)=\s*$", _read(p), re.M))
    labels |= {"scenefile-reference", "error-list"}
    return docs, labels


def test_internal_links_resolve():
    """{doc}, {ref} and relative Markdown links and images of every page point at something that exists."""
    docs, labels = _targets()
    bad = []
    for page in _pages():
        text, here = _read(page), os.path.dirname(page)
        for target in re.findall(r"\{doc\}`(?:[^`<]*<)?([^`>]+)>?`", text):
            path = os.path.normpath(os.path.join(here, target)).replace(os.sep, "/") if not target.startswith("/") \
                else target[1:]
            if path not in docs:
                bad.append(f"{page}: {{doc}} {target}")
        for target in re.findall(r"\{ref\}`(?:[^`<]*<)?([^`>]+)>?`", text):
            if target not in labels:
                bad.append(f"{page}: {{ref}} {target}")
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"[a-z]+://", target) or target.startswith("#"):
                continue
            if not os.path.exists(os.path.join(DOCS, here, target.split("#")[0])):
                bad.append(f"{page}: link {target}")
    assert not bad, "broken internal links:\n" + "\n".join(bad)


def test_theory_citations_point_at_the_pages_that_hold_them():
    """Every ``docs/<page>.md §N.M`` cited in the package and the tests names a page with a
    section labelled ``(spec-N-M)=`` (or, for a subsection, its parent section), and
    docs/theory/spec_map.txt is the map those labels give."""
    import spec_labels
    labelled = spec_labels.labels()
    cited, bad = 0, []
    for folder in ("taichi_fdem", "tests"):
        for base, _, files in os.walk(os.path.join(ROOT, folder)):
            for f in files:
                if f.endswith(".py"):
                    text = open(os.path.join(base, f), encoding="utf-8").read()
                    for page, sec in re.findall(r"docs/([\w/]+)\.md §([0-9]+(?:\.[0-9]+)*)", text):
                        cited += 1
                        parts = sec.split(".")
                        holders = {labelled.get(".".join(parts[:k])) for k in range(len(parts), 0, -1)}
                        if page not in holders:
                            bad.append(f"{f}: docs/{page}.md §{sec}")
    assert cited > 50 and not bad, "citations of sections their page does not hold:\n" + "\n".join(bad)
    assert open(os.path.join(DOCS, "theory", "spec_map.txt"), encoding="utf-8").read() == spec_labels.spec_map_text()


def test_scenefile_reference_lists_every_key():
    """The generated reference has a row for every key of every schema of the loader, with its default."""
    import scenefile_ref
    from taichi_fdem.io import scenefile as sf
    text = scenefile_ref.render()
    sections = {part.split("`")[0]: part for part in text.split("\n## `")[1:]}
    for title, attr, _ in scenefile_ref.SECTIONS:
        for name in getattr(sf, attr):
            assert f"| `{name}` |" in sections[title], (title, name)
    assert "| `duration` | float | s | **required** |" in text
    assert '| `plane` | choice | — | "strain" |' in text


def test_error_list_has_the_loader_messages():
    """The generated list of error messages holds the scene checker's unknown-key message."""
    import error_list
    msgs = error_list.messages()
    flat = [m for rows in msgs.values() for _, m in rows]
    assert len(flat) > 100
    assert any("unknown key" in m for m in flat)


_SHELL_FENCE = re.compile(r"^```(?:bash|sh|text|console)[^\n]*\n(.*?)^```\s*$", re.S | re.M)


def _shell_lines():
    """(page, command) of every line of the shell blocks of the docs pages and the README."""
    out = []
    for page in _pages() + ["../README.md", "../benchmarks/README.md"]:
        for block in _SHELL_FENCE.findall(_read(page)):
            for line in block.splitlines():
                cmd = line.split(" #")[0].strip()
                if cmd:
                    out.append((page, cmd))
    return out


def test_shell_blocks_name_commands_that_exist():
    """The commands of the shell blocks (which need a shell, a network or minutes, so they are
    not run here) are what the repository has: every ``taichi-fdem`` line parses with the
    command line's own parser and the files it names exist, every ``make`` target is in the
    Makefile, every ``pip install`` extra is in pyproject.toml, every script run exists."""
    import contextlib
    import io
    import shlex
    try:
        import tomllib
    except ModuleNotFoundError:          # Python 3.10
        import tomli as tomllib
    from taichi_fdem import cli
    makefile = open(os.path.join(ROOT, "Makefile"), encoding="utf-8").read()
    targets = set(re.findall(r"^([a-z][\w-]*):", makefile, re.M))
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as fh:
        extras = set(tomllib.load(fh)["project"]["optional-dependencies"])
    demos = {f[:-3] for f in os.listdir(os.path.join(ROOT, "demos")) if f.endswith(".py")}
    lines, bad, checked = _shell_lines(), [], 0
    for page, cmd in lines:
        words = shlex.split(cmd)
        if words[0] == "taichi-fdem":
            checked += 1
            try:
                with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
                    args = cli.build_parser().parse_args(words[1:])
            except SystemExit as exc:
                if exc.code != 0:
                    bad.append(f"{page}: {cmd}: refused by the parser")
                continue
            for attr in ("scene", "sweep_file"):
                path = getattr(args, attr, None)
                if path and "SCENE" not in path and "SWEEP" not in path and not os.path.exists(os.path.join(ROOT, path)):
                    bad.append(f"{page}: {cmd}: no file {path}")
            if getattr(args, "command", None) == "demo" and args.name and args.name not in demos:
                bad.append(f"{page}: {cmd}: no demo {args.name}")
        elif words[0] == "make":
            checked += 1
            bad += [f"{page}: {cmd}: no make target {t}" for t in words[1:] if t not in targets]
        elif words[:3] == ["pip", "install", "-e"]:
            checked += 1
            m = re.match(r"\.\[([\w,]+)\]", words[3])
            bad += [f"{page}: {cmd}: no extra {e}" for e in (m.group(1).split(",") if m else []) if e not in extras]
        elif words[0].endswith("python") and len(words) > 1 and words[1].endswith(".py"):
            checked += 1
            if not os.path.exists(os.path.join(ROOT, words[1])):
                bad.append(f"{page}: {cmd}: no script {words[1]}")
    assert checked >= 10 and not bad, "shell lines naming what does not exist:\n" + "\n".join(bad)


def test_gallery_has_a_still_and_a_small_gif_of_every_demo():
    """``make gallery`` output is in the repository for every demo that writes a video: a PNG
    still and a GIF animation, each under 1 MB (the gallery page shows them all)."""
    sys.path.insert(0, DOCS)
    import make_gallery
    names = make_gallery.demo_names()
    assert {"triaxial", "slope", "dfn_compression", "tunnel"} <= set(names)
    for name in names:
        for ext in ("png", "gif"):
            path = os.path.join(DOCS, "gallery", f"{name}.{ext}")
            assert os.path.isfile(path), path
            assert os.path.getsize(path) < 1_000_000, (path, os.path.getsize(path))

"""The repository's text describes the software, not its development (ground rule 5).

Every tracked text file (``git ls-files``) is read line by line for diary words: "session",
"before the ...th", "helper", runs of "earlier hosts".  History goes in git and in
CHANGELOG.md.  One test per file, so that a failure names the file and its lines.

``ALLOWED`` lists the legitimate uses by name (pytest's ``scope="session"``, gmsh's session).
"""
from __future__ import annotations

import os
import re
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# "before the <ordinal>" is a diary phrase unless it is the first, second or third of something
# or counts steps, frames or other items of a run
DIARY = re.compile(r"session|\bbefore the (?!(?:first|second|third)\b)[a-z-]+(?:th|st|nd|rd)\b"
                   r"(?! (?:step|frame|window|chunk|detection|launch)s?\b)"
                   r"|\bhelpers?\b|\bearlier hosts?\b", re.I)

# legitimate uses, removed from a line before it is searched
ALLOWED = (
    'scope="session"',                     # pytest fixture scope
    "fdem_session",                        # the conftest fixture that initialises Taichi once per run
    "keeps_a_session_it_did_not_open",     # gmsh's own initialize/finalize session, a gmsh term
)

# files that are checked elsewhere or that quote the words on purpose
EXEMPT = {
    "CHANGELOG.md",                        # history belongs there
    "tests/test_docs_text.py",             # this file names the words
}

# being rewritten by other work: remove each entry once the file is clean

TEXT_SUFFIXES = (".py", ".md", ".rst", ".txt", ".toml", ".cfg", ".ini", ".yml", ".yaml", ".csv", ".json")
TEXT_NAMES = ("Makefile", "LICENSE", "run")


def tracked_text_files() -> list[str]:
    """The tracked text files of the repository (paths relative to its root)."""
    try:
        out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return []
    files = [f for f in out.splitlines() if f.endswith(TEXT_SUFFIXES) or os.path.basename(f) in TEXT_NAMES]
    return sorted(f for f in files if os.path.isfile(os.path.join(ROOT, f)) and f not in EXEMPT)


def diary_lines(path: str) -> list[str]:
    """``"line: text"`` of each line of ``path`` with a diary word outside ``ALLOWED``."""
    with open(os.path.join(ROOT, path), encoding="utf-8", errors="replace") as fh:
        lines = fh.read().splitlines()
    hits = []
    for i, line in enumerate(lines, start=1):
        text = line
        for ok in ALLOWED:
            text = text.replace(ok, "")
        if DIARY.search(text):
            hits.append(f"{i}: {line.strip()[:120]}")
    return hits


FILES = tracked_text_files()


@pytest.mark.skipif(not FILES, reason="not a git checkout")
@pytest.mark.parametrize("path", FILES)
def test_no_development_diary_in(path):
    hits = diary_lines(path)
    assert not hits, f"{path} narrates the development:\n" + "\n".join(hits)


def test_the_diary_pattern_catches_what_it_should():
    """The pattern finds the diary phrases and lets the allowed uses through."""
    for bad in ("the twenty-third session", "before the eighteenth session", "before the twenty-first, one", "this session's runs",
                "the helper's measurement", "runs of earlier hosts"):
        assert DIARY.search(bad), bad
    for ok in ('@pytest.fixture(scope="session", autouse=True)', "def fdem_session():",
               "a threshold before the fifth step", "compiled before the first size"):
        text = ok
        for a in ALLOWED:
            text = text.replace(a, "")
        assert not DIARY.search(text), ok



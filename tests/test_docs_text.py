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




# ---- figures of past runs in the package's docstrings and comments -----------------------------
# Docstrings and comments of taichi_fdem/ state contracts (what, units, theory section), not
# what a run once measured: figures go to benchmarks/results.json (benchmarks/results.md) and
# docs/performance.md.  Each pattern is a way a past run gets quoted; physics numbers (units,
# defaults, tolerances, "the measured load" of a verification case) do not match.
PAST_RUN = re.compile("|".join((
    # "(measured)", "0.28 mm, measured", "measured on the 1k pile", "as measured in the stress tests"
    r"\bmeasured\s*[);:,]|\bas measured\b",
    r"\bmeasured\s+(?:on|in|at|by|against|over|with|here|there)\b",
    # speed ratios: "0.73×", "1.2× slower", "1.02x on the plate", "at 0.87×"
    r"\d(?:\.\d+)?\s?[×x]\s*(?:faster|slower|quicker|the speed|on (?:the|a)\b)",
    r"\bat \d+(?:\.\d+)?\s?×", r"\d\.\d+\s?×\s*(?:[,;:)]|$|and\b|of\b)",
    # "3 % faster", "5 % of the contact phase", "lost 4.6 % of its energy"
    r"\d\s?%\s+(?:faster|slower|quicker|cheaper|more expensive)",
    r"\d\s?%\s+of (?:a|the|its) [\w-]+ (?:phase|start|run|launch|energy)\b",
    # benchmark scenes and rates: "the 100k pile", "10k-triangle plate", "5.20 M triangle-steps/s"
    r"\b\d+(?:\.\d+)?\s?(?-i:[kM])[ -]?(?:pile|plate|triangles?\b|tri\b|triangle-steps)",
    r"\bsteps/s\b",
    # what a run did: "ran the 100k pile", "took 42 s", "went unstable at", "on 2 threads"
    r"\bran (?:at|the|in|its|on|as)\b", r"\b(?:lost|took|fell|rose|dropped) (?:from |about |~)?\d",
    r"\bwent \w+ at\b", r"\bon (?:\d+|two|four) (?:threads|workers|cores)\b",
    # wall-time figures: "~75 µs", "~0.5-0.9 ms", "42 s of a 53 s cold start"
    r"~\s?\d+(?:\.\d+)?(?:\s?[-–]\s?\d+(?:\.\d+)?)?\s?(?:ms|µs|us)\b",
    r"\d\s?s\b[^.]*\b(?:cold|warm) start|\b(?:cold|warm) start[^.]*\b\d+(?:\.\d+)?\s?s\b",
    # how the code came to be
    r"\bthe old (?:weights|code|version|kernel|layout|scheme|default|way|implementation|one)s?\b",
    r"\bpreviously\b|\bformerly\b|\bas before\b|\bwas dropped\b|\bbefore the split\b",
)), re.I)

PKG = os.path.join(ROOT, "taichi_fdem")


def prose_lines(source: str) -> dict[int, str]:
    """{line number: text} of the docstrings (every string statement) and comments of Python
    ``source``."""
    import ast
    import io
    import tokenize
    lines = source.splitlines()
    out = {}
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
            for i in range(node.lineno, node.end_lineno + 1):
                out[i] = lines[i - 1]
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            out[tok.start[0]] = tok.string
    return out


def past_run_lines(path: str) -> list[str]:
    """``"path:line: text"`` of each docstring or comment line of ``path`` that quotes a past run
    (:data:`PAST_RUN`)."""
    with open(path, encoding="utf-8") as fh:
        prose = prose_lines(fh.read())
    rel = os.path.relpath(path, ROOT)
    return [f"{rel}:{i}: {text.strip()[:140]}" for i, text in sorted(prose.items()) if PAST_RUN.search(text)]


def package_files() -> list[str]:
    return sorted(os.path.join(dp, f) for dp, _, fs in os.walk(PKG) for f in fs if f.endswith(".py"))


def test_package_docstrings_quote_no_past_runs():
    hits = [h for path in package_files() for h in past_run_lines(path)]
    assert not hits, "docstrings and comments quoting past runs (state the contract; figures go to " \
                     "benchmarks/results.json or docs/performance.md):\n" + "\n".join(hits)


def test_the_past_run_checker_catches_a_planted_docstring(tmp_path):
    """A module whose docstrings and comments quote past runs is caught line by line; the same
    module stating contracts with physics numbers passes."""
    planted = tmp_path / "planted.py"
    planted.write_text('''"""Block forces.

Without the ranges 8 blocks ran the 100k pile at 0.6× (one worker).
"""


def f(x):
    """The friction work (it was dropped unbooked: 1.3 J of a 425 J impact, measured)."""
    # a serial task: a 1-iteration parallel loop costs ~75 µs
    # 1.3-3.3 % faster on the 10k pile
    # the old weights (1 bonded, 10 boxes apart) were ignored
    # unrolled: 42 s of a 1k pile's 53 s cold start
    return x  # 1.03-1.08x faster on 2 threads
''')
    hits = past_run_lines(str(planted))
    assert [int(h.split(":")[1]) for h in hits] == [3, 8, 9, 10, 11, 12, 13], hits
    clean = tmp_path / "clean.py"
    clean.write_text('''"""Contact forces (docs/theory/contact.md §4.2).

The penalty p [Pa] defaults to 10 × young; the time step is safety × the estimate, 0.2 by
default, and the stable limit is 0.4 × h√(ρ/p).  A 2×2 matrix per triangle.
"""


def g(sim):
    """Load the disc until the load falls below 30 % of its peak, at most 5 s; the measured
    load P gives a = √(4PR/(πE*)), within 1 % of the analytic value (tests/test_hertz.py)."""
    # dt = 1e-6 s, duration 0.1 s; a 5 % tolerance; E_measured against E_analytic
    return sim
''')
    assert past_run_lines(str(clean)) == []

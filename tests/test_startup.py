"""The front-end memos of ``backend._memoise_front_end`` (start-up time) change no value Taichi
sees, and patch nothing unless ``fdem.init`` applies them (the test process's init does, under
Taichi ``backend.FRONT_END_TAICHI``)."""
import ast
import inspect
import os
import subprocess
import sys
import textwrap

import pytest
import taichi as ti

import taichi_fdem as fdem  # noqa: F401
from taichi_fdem import backend
from taichi.lang import kernel_impl
from taichi.lang.ast.ast_transformer_utils import ASTTransformerContext

from taichi_fdem.engine import contact, team

pytestmark = pytest.mark.skipif(tuple(ti.__version__) != backend.FRONT_END_TAICHI
                                or os.environ.get("TAICHI_FDEM_FRONT_END_SHORTCUTS") == "0",
                                reason="the front-end shortcuts are off (another Taichi, or switched off)")


def _nodes(tree):
    return [n for n in ast.walk(tree) if isinstance(n, (ast.stmt, ast.expr))]


def test_position_messages_are_the_ones_taichi_formats():
    """For every statement and expression of two large ti.funcs, each transformed twice (a
    fresh tree and context each time, as when a function is inlined twice), the memoised
    ``get_pos_info`` returns exactly the message of Taichi's own, which it wraps: the messages
    end up in the kernels' debug info and so in their offline-cache keys."""
    memo = ASTTransformerContext.get_pos_info
    assert getattr(memo, "_fdem_memo", False), "the memo is not installed"
    original = memo._fdem_original
    checked = 0
    for func in (team.team_worker, contact.couple_forces, team.team_worker, contact.couple_forces):
        tree, ctx = kernel_impl._get_tree_and_ctx(func.func, is_kernel=False)
        nodes = _nodes(tree)
        assert len(nodes) > 100
        for node in nodes:
            assert memo(ctx, node) == original(ctx, node)
            checked += 1
    assert checked > 1000


def test_source_lines_and_text_are_the_ones_inspect_gives():
    """The memoised source lookups return what inspect and textwrap return, every time, as
    lists the caller may change."""
    f = contact.couple_forces.func.func
    a, start = kernel_impl.getsourcelines(f)
    a.append("changed by the caller")
    b, start2 = kernel_impl.getsourcelines(f)
    ref, start_ref = inspect.getsourcelines(f)
    assert b == ref and start == start2 == start_ref
    assert kernel_impl.getsourcefile(f) == inspect.getsourcefile(f)
    for line in ref:
        assert kernel_impl.textwrap.fill(line, tabsize=4, width=9999) == textwrap.fill(line, tabsize=4, width=9999)
    text = "\n".join(ref)
    assert kernel_impl.textwrap.dedent(text) == textwrap.dedent(text)


def test_wrapped_lines_are_the_ones_textwrap_gives():
    """The position messages' memoised line wrapper returns what a fresh TextWrapper returns,
    every time, as lists the caller may change."""
    from taichi.lang.ast import ast_transformer_utils as atu
    assert atu.TextWrapper is not textwrap.TextWrapper, "the memoised wrapper is not installed"
    ref = textwrap.TextWrapper(width=80)
    lines = inspect.getsourcelines(contact.couple_forces.func.func)[0] + ["x" * 200, "  a b  " * 30, "", "\t y"]
    for line in lines:
        for text in (line, " " * 8 + "^" * 90, " " * 3):
            got = atu.TextWrapper(width=80).wrap(text)
            got.append("changed by the caller")
            assert atu.TextWrapper(width=80).wrap(text) == ref.wrap(text)
    assert atu.TextWrapper(width=20).wrap("a " * 40) == textwrap.TextWrapper(width=20).wrap("a " * 40)


def test_module_functions_and_methods_are_told_apart():
    """The shortcut of ``_inside_class`` (a decorator applied at a module's top level is not in
    a class body) leaves Taichi's answer as it was: this package's functions are plain
    functions, and a data-oriented class's kernel and function are still methods."""
    import taichi as ti
    assert getattr(kernel_impl._inside_class, "_fdem_memo", False), "the shortcut is not installed"
    assert not contact.couple_forces.func.classfunc and not team.team_worker.func.classfunc

    @ti.data_oriented
    class Counter:
        @ti.kernel
        def total(self) -> ti.i32:
            return self.two() + 1

        @ti.func
        def two(self):
            return 2

    assert Counter().total() == 3


_PROBE = """
import sys, textwrap
from taichi.lang import kernel_impl
from taichi.lang.ast import ast_transformer_utils as atu
def internals():
    return (atu.ASTTransformerContext.get_pos_info, kernel_impl.getsourcefile, kernel_impl.getsourcelines,
            kernel_impl.textwrap, kernel_impl._inside_class, atu.TextWrapper)
before = internals()
assert kernel_impl.textwrap is textwrap and atu.TextWrapper is textwrap.TextWrapper
import taichi_fdem as fdem
from taichi_fdem import backend
print("import", sum(a is not b for a, b in zip(internals(), before)), backend.front_end_shortcuts())
fdem.init(arch="cpu", front_end_shortcuts=sys.argv[1] == "1")
print("init", sum(a is not b for a, b in zip(internals(), before)), backend.front_end_shortcuts())
fdem.init(arch="cpu", front_end_shortcuts=False)
print("off", sum(a is not b for a, b in zip(internals(), before)), backend.front_end_shortcuts())
"""


def _probe(switch: str, env: dict | None = None) -> list[str]:
    environ = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path), **(env or {}))
    out = subprocess.run([sys.executable, "-c", _PROBE, switch], capture_output=True, text=True, env=environ,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    return [line for line in out.stdout.splitlines() if line.split()[0] in ("import", "init", "off")]


def test_import_patches_nothing_and_init_applies_or_removes_the_shortcuts():
    """In a fresh process: importing taichi_fdem leaves all six patched names of Taichi as they
    were; ``init(front_end_shortcuts=True)`` replaces them (six of six under the checked Taichi
    version); ``init(front_end_shortcuts=False)`` puts Taichi's own back."""
    assert _probe("1") == ["import 0 False", "init 6 True", "off 0 False"]


def test_switched_off_init_patches_nothing():
    """``init(front_end_shortcuts=False)``, and the environment switch
    TAICHI_FDEM_FRONT_END_SHORTCUTS=0 with the default, patch nothing."""
    assert _probe("0") == ["import 0 False", "init 0 False", "off 0 False"]
    probe = _PROBE.replace('front_end_shortcuts=sys.argv[1] == "1"', "")
    environ = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path), TAICHI_FDEM_FRONT_END_SHORTCUTS="0")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=environ, timeout=120)
    assert out.returncode == 0, out.stderr
    assert [ln for ln in out.stdout.splitlines() if ln.startswith(("import", "init"))] == ["import 0 False",
                                                                                          "init 0 False"]


def test_other_taichi_versions_get_no_shortcuts(monkeypatch):
    """Under a Taichi version other than the one the shortcuts were checked against,
    applying them does nothing."""
    backend._set_front_end_shortcuts(False)
    try:
        monkeypatch.setattr(backend, "FRONT_END_TAICHI", (1, 7, 99))
        backend._set_front_end_shortcuts(True)
        assert not backend.front_end_shortcuts()
        assert kernel_impl.textwrap is textwrap and ASTTransformerContext.get_pos_info.__name__ == "get_pos_info"
        assert not getattr(ASTTransformerContext.get_pos_info, "_fdem_memo", False)
    finally:
        monkeypatch.undo()
        backend._set_front_end_shortcuts(True)
    assert backend.front_end_shortcuts()

"""The front-end memos of ``backend._memoise_front_end`` (start-up time) change no value Taichi sees."""
import ast
import inspect
import textwrap

import taichi_fdem as fdem  # noqa: F401  (installs the memos)
from taichi.lang import kernel_impl
from taichi.lang.ast.ast_transformer_utils import ASTTransformerContext

from taichi_fdem.engine import contact, team


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

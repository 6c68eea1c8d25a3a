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

"""Sphinx extension: writes ``reference/errors.md``, every error message the package raises.

The messages are read from the ``raise`` statements of the source (their f-string parts shown
as ``…``), grouped by module, so the list follows the code.
"""
from __future__ import annotations

from _pages import write_if_changed

import ast
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PACKAGE = os.path.join(ROOT, "taichi_fdem")


def _text(node) -> str | None:
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    if isinstance(node, ast.JoinedStr):
        return "".join(v.value if isinstance(v, ast.Constant) else "…" for v in node.values)
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Mod)):
        left, right = _text(node.left), _text(node.right)
        if left is not None:
            return left + ("…" if right is None else right)
    return None


def messages() -> dict:
    """{module: [(exception name, message), ...]} of every raise with a literal message."""
    out = {}
    for folder, _, files in sorted(os.walk(PACKAGE)):
        for name in sorted(files):
            if not name.endswith(".py"):
                continue
            path = os.path.join(folder, name)
            tree = ast.parse(open(path, encoding="utf-8").read(), path)
            mod = os.path.relpath(path, ROOT)[:-3].replace(os.sep, ".").removesuffix(".__init__")
            rows = []
            for node in ast.walk(tree):
                if not (isinstance(node, ast.Raise) and isinstance(node.exc, ast.Call) and node.exc.args):
                    continue
                f = node.exc.func
                exc = f.id if isinstance(f, ast.Name) else (f.attr if isinstance(f, ast.Attribute) else None)
                if exc == "error":          # _Checker.error(path, message) -> SceneFileError
                    exc = "SceneFileError"
                msg = next((t for t in map(_text, node.exc.args) if t), None)
                if exc and msg:
                    rows.append((node.lineno, exc, " ".join(msg.split())))
            if rows:
                out[mod] = [(e, m) for _, e, m in sorted(rows)]
    return out


def render() -> str:
    lines = ["(error-list)=", "# Every error message", "",
             "Generated at build time from the `raise` statements of the package (`…` stands for a",
             "value filled in when the error is raised). What to do about the common ones is in",
             "{doc}`../guide/troubleshooting`.", ""]
    total = 0
    for mod, rows in messages().items():
        lines += [f"## `{mod}`", ""]
        for exc, msg in rows:
            msg = msg.replace("`", "'")
            lines.append(f"- **{exc}**: `` {msg} ``")
            total += 1
        lines.append("")
    lines.insert(6, f"{total} messages in {len(messages())} modules.")
    lines.insert(7, "")
    return "\n".join(lines)


def _write(app) -> None:
    path = os.path.join(app.srcdir, "reference", "errors.md")
    write_if_changed(path, render())


def setup(app):
    app.connect("builder-inited", _write)
    return {"version": "1", "parallel_read_safe": True}

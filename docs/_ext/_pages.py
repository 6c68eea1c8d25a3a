"""What the documentation's extensions share: writing a generated page."""
from __future__ import annotations

import os


def write_if_changed(path: str, text: str) -> None:
    """Write ``text`` to ``path`` (its folder made) unless the file already holds it, so that
    Sphinx does not rebuild an unchanged page."""
    old = open(path, encoding="utf-8").read() if os.path.exists(path) else None
    if old != text:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)

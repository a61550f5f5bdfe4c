"""A griffe extension for the documentation site (mkdocs.yml): doctests in docstrings as code blocks.

The docstrings keep their examples as bare ``>>>`` lines, which doctest runs; Markdown would read them as
text (a ``[...]`` result as a link). This fences each run of example lines (a ``>>>`` line, its ``...``
continuations and the output up to a blank line) as ``pycon``, at its indentation. Source: stackdsl's own.
"""

from __future__ import annotations

import re
from typing import Any

import griffe

_EXAMPLE = re.compile(r"^(?P<indent>[ \t]*)>>> ")


def fence(text: str) -> str:
    """``text`` with every run of doctest lines fenced as ``pycon``."""
    out: list[str] = []
    lines = text.split("\n")
    i = 0
    while i < len(lines):
        match = _EXAMPLE.match(lines[i])
        if not match:
            out.append(lines[i])
            i += 1
            continue
        indent = match.group("indent")
        block = []
        while i < len(lines) and lines[i].strip():
            block.append(lines[i])
            i += 1
        if out and out[-1].strip():
            out.append("")
        out += [f"{indent}```pycon", *block, f"{indent}```"]
    return "\n".join(out)


class DoctestFences(griffe.Extension):
    """Fence the doctests of every docstring griffe loads."""

    def on_instance(self, *, node: Any, obj: griffe.Object, agent: Any, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = fence(obj.docstring.value)

"""A condition of a scenario's ``require:`` as a field of the language: the text as written,
parsed when the file is read so that a syntax error points at it
(:mod:`stackdsl.lang.expressions`; the names it reads are checked by the compiler,
:mod:`stackdsl.compile.require`).

Source: stackdsl's own.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import AfterValidator, Field

from .expressions import MAX_CONDITION, parse


def _condition(text: str) -> str:
    parse(text)
    return text


Requirement = Annotated[
    str,
    Field(min_length=1, max_length=MAX_CONDITION, examples=["overhang >= 10 mm"]),
    AfterValidator(_condition),
]
"""One condition: its text, checked against the grammar of :mod:`stackdsl.lang.expressions`."""

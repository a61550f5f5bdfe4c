"""Plain data read from YAML to a validated :class:`~stackdsl.lang.schema.Scenario`, its
problems as one :class:`~stackdsl.lang.errors.ScenarioError`, each at its node.

Source: stackdsl's own (errors at file:line:col), after Tavern.
"""

from __future__ import annotations

import os
import typing
from pathlib import Path
from typing import Any

import pydantic
import pydantic_core
import yaml
from pydantic import ValidationError

from .errors import NO_FILE, FieldPath, ScenarioError, SourceMap
from .schema import Scenario
from .validation_errors import first_error

#: Where PyYAML and pydantic live: an exception raised there is the input's, not a bug of ours.
LIBRARIES = tuple(str(Path(m.__file__).parent) + os.sep for m in (yaml, pydantic, pydantic_core) if m.__file__)


#: What a key of ``expect`` left empty is told to give, where the run's examples would mislead.
_EXAMPLES = {
    "p_stands": "a bound on P(stands), '>= 0.9', or P(stands) with a tolerance, '0.67 ± 0.1'",
    "collapse": "a level, 'collapse: 9±1', or in a sweep a statistic, '{mean: 7 ± 0.5}'",
    "cells": "a list of {where, p_stands or collapse}",
}


def validate(
    data: Any, source: SourceMap, relocate: typing.Callable[[FieldPath], FieldPath | None] | None = None, note: str = ""
) -> Scenario:
    """A :class:`Scenario` from plain ``data`` read from ``source``.

    Args:
        relocate: gives, for a field path, the node to blame instead (a distribution or a grid
            value that put the value there), or None to keep it.
        note: put before the message of an error at a relocated field ("sample 3 draws 61 mm").

    Raises:
        ScenarioError: the first problem at its node, the others after it (at most 10 in all).
    """
    structure = data.get("structure") if isinstance(data, dict) else None
    if isinstance(structure, dict) and "parts" in structure:  # the models' field, not a key of a file (as the schema says)
        raise source.error(
            ("structure", "parts"),
            "a file writes its parts as the structure itself: 'structure:' then the list (- {name: left, tower: ...}) "
            "or the map (left: {tower: ...}); 'parts' is the Python models' field (Structure(parts=...))",
            at_key=True,
        )
    expect = data.get("expect") if isinstance(data, dict) else None
    if isinstance(expect, dict):
        empty = [key for key, value in expect.items() if value is None]
        if empty:  # 'stands:' with nothing after it read as no expectation, and passed on nothing measured
            example = _EXAMPLES.get(empty[0], "as 'stands: true' or 'toppled: all'")
            raise source.error(("expect", empty[0]), f"no value: give one ({example}), or leave the key out")
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as exc:
        raise first_error(exc, source, relocate, note) from None
    except Exception as exc:
        if not raised_in_library(exc):
            raise  # a bug of ours (a validator): not to be dressed up as the user's error
        raise ScenarioError(f"cannot validate this file ({type(exc).__name__} in pydantic: {exc})", file=source.file) from None
    update: dict[str, Any] = {}
    if scenario.name is None and source.file != NO_FILE:  # a file's stem; text of no file keeps None, as a built one
        update["name"] = Path(source.file).stem
    if at := source.locations(("expect",)):  # each verdict then points at the line of its expectation
        update["expect"] = scenario.expect.located(at)
    if update:
        scenario = scenario.model_copy(update=update)
    scenario._source = source
    return scenario


def raised_in_library(exc: BaseException) -> bool:
    """Whether ``exc`` was raised inside PyYAML or pydantic (not in stackdsl's own code)."""
    tb = exc.__traceback__
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    return tb is not None and tb.tb_frame.f_code.co_filename.startswith(LIBRARIES)

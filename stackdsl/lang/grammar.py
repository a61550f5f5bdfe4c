"""The grammar shared by the scenario validators and the JSON Schema of scenario files.

The regular expressions here mean the same in Python and in ECMA-262 (the regex dialect of
JSON Schema and of editors): no ``\\d``, ``\\s`` or named groups. Scalars are read as YAML
writes them: an integer is ``5`` or ``5.0``, not ``"5"`` or ``true``; a flag is ``true`` or
``false``, not ``1``.

Source: stackdsl's own.

>>> import re
>>> re.fullmatch(COLLAPSE, "9 +- 1").groups(), re.fullmatch(COLLAPSE, "0.±1.0").groups()
(('9', '1'), ('0', '1'))
>>> re.fullmatch(PLUS_MINUS, ".5 ± 5.").groups(), re.fullmatch(BOUND, ">= .9").groups()
(('.5', '5.'), ('>=', '.9'))
>>> whole(5.0), as_int(True)
(5, None)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Any

from pydantic import AfterValidator, BeforeValidator, Field, GetJsonSchemaHandler, TypeAdapter
from pydantic.json_schema import JsonSchemaValue
from pydantic_core import CoreSchema

from .spelling import spelled
from .units import UNSIGNED, WHITESPACE

# Regular expressions shared by the validators and the JSON Schema, written to mean the same in
# Python and ECMA-262 (see stackdsl.lang.units). The JSON Schema narrows numbers to their ranges.
SPACE = f"{WHITESPACE}*"
LEVEL_NUMBER = "0*(?:[1-9][0-9]{0,2}|1000)"  # 1 to MAX_LEVELS
TOLERANCE_NUMBER = "0*(?:[0-9]{1,3}|1000)"  # 0 to MAX_LEVELS
_POINT = "(?:\\.0*)?"  # a whole number may end in a point: "9.", "9.0" (as YAML's 9.0 is the integer 9)
# "9", "9±1", "9 +- 1", "9 +/- 1", "9.±1."
COLLAPSE = f"{SPACE}([0-9]+){_POINT}{SPACE}(?:(?:±|\\+-|\\+/-){SPACE}([0-9]+){_POINT})?{SPACE}"
LEVEL_RANGE = f"{SPACE}([0-9]+){SPACE}(?:(?:-|\\.\\.){SPACE}([0-9]+))?{SPACE}"  # "5", "1-11", "1..11"
AFTER_LEVEL = f"{SPACE}after{WHITESPACE}+level{WHITESPACE}+([0-9]+){SPACE}"  # "after level 13"
AFTER_PREVIOUS = f"{SPACE}after{WHITESPACE}+the{WHITESPACE}+previous{WHITESPACE}+action{SPACE}"  # an action's only
_DECIMAL = f"({UNSIGNED})"  # the language's one number: "0.5", ".5", "5.", "5e-1"
# "7 ± 0.5", "7 +- .5", "7" (± 0): a sweep's statistic; a run's level takes whole numbers only (COLLAPSE)
PLUS_MINUS = f"{SPACE}{_DECIMAL}{SPACE}(?:(?:±|\\+-|\\+/-){SPACE}{_DECIMAL})?{SPACE}"
BOUND = f"{SPACE}(>=|<=|>|<){SPACE}{_DECIMAL}{SPACE}"  # ">= 0.9", ">= .9"
# ">= 1", "< 5.": a bound on a whole number (toppled bricks), as BOUND with a whole number
COUNT_BOUND = f"{SPACE}(?:>=|<=|>|<){SPACE}[0-9]+{_POINT}{SPACE}"
BODY_ID = r"^[A-Za-z_](?:[A-Za-z0-9_.-]{0,38}[A-Za-z0-9_-])?$"
"""A body's own id (a brick placed by hand, a projectile, a pusher): a letter or '_' first, since
``expect`` reads a digit first as a level ('3', '007', '1e3') and a '.' or '-' as nothing it
names; not ending in '.', which ``expect`` reads as the start of ids ('left.'); 40 at most."""
GROUND = "ground"
"""The id of the ground in the timeline and the brick graph: no body may have it."""


def _not_ground(value: str) -> str:
    if value.lower() == GROUND:  # 'Ground' too: "at rest on Ground" reads as the ground
        raise ValueError(f"{value!r} names the ground (what a brick rests on in the timeline and the graph): give another id")
    return value


MERGE_KEY = "<<"
"""YAML's merge key, which the loader refuses as a key: no name written as a key may be it."""


def _not_merge_key(value: str) -> str:
    if value == MERGE_KEY:
        raise ValueError(
            f"{MERGE_KEY!r} is YAML's merge key, which a scenario file may not have as a key: a name written as a key "
            "(a material's, a brick type's, a grid field's) cannot be it; give another name"
        )
    return value


Key = Annotated[str, AfterValidator(_not_merge_key)]
"""A name a file writes as a mapping's key (a material, a brick type, a grid field): not :data:`MERGE_KEY`,
so that what the models accept, :meth:`Scenario.to_yaml` writes and the loader reads back."""

BodyId = Annotated[str, Field(pattern=BODY_ID, json_schema_extra={"not": {"const": GROUND}}), AfterValidator(_not_ground)]
"""A body's own id: :data:`BODY_ID`, and not :data:`GROUND`."""


def json_pattern(regex: str, *numbers: str) -> str:
    """``regex`` anchored, its groups ``([0-9]+)`` narrowed to ``numbers`` in order."""
    first, *rest = regex.split("([0-9]+)")
    return "^" + first + "".join(f"(?:{number}){part}" for number, part in zip(numbers, rest, strict=True)) + "$"


def whole(value: Any) -> Any:
    """An integer as YAML writes it, ``5`` or ``5.0``; not ``"5"`` or ``true``."""
    if isinstance(value, (bool, str)):
        raise ValueError(f"expected a whole number{'' if isinstance(value, bool) else ', not text'}, got {spelled(value)}")
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def as_int(value: Any) -> int | None:
    """``value`` as an int if it is an integer (``5`` or ``5.0``, not ``true``), else None."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    if isinstance(value, float):
        return int(value) if value.is_integer() else None
    return value


# An integer field: Annotated[int, Field(ge=..., le=...), WHOLE], the bounds before WHOLE so that they reach the
# JSON Schema ({"type": "integer"}, which takes 5.0 too).
WHOLE = BeforeValidator(whole)


@dataclass(frozen=True, eq=False)
class AlsoAccepts:
    """JSON Schema of a type whose BeforeValidator takes more than the type: the type's own schema,
    or any of ``forms`` (JSON Schemas, or types whose schema pydantic derives)."""

    forms: tuple[Any, ...]
    description: str

    def __get_pydantic_json_schema__(self, core_schema: CoreSchema, handler: GetJsonSchemaHandler) -> JsonSchemaValue:
        own = handler(core_schema)
        branches = own["anyOf"] if set(own) == {"anyOf"} else [own]
        forms = [form if isinstance(form, dict) else TypeAdapter(form).json_schema() for form in self.forms]
        return {"anyOf": [*branches, *forms], "description": self.description}


def given(*names: str) -> dict[str, Any]:
    """JSON Schema: the fields ``names`` are present and not null."""
    return {"required": list(names), "properties": {name: {"not": {"type": "null"}} for name in names}}


def absent(*names: str) -> dict[str, Any]:
    """JSON Schema: the fields ``names`` are absent or null."""
    return {"properties": {name: {"type": "null"} for name in names}}


def flag(value: Any) -> Any:
    """``true`` or ``false`` only (pydantic's lax mode would take 1 for true)."""
    if not isinstance(value, bool):
        raise ValueError(f"expected true or false, got {spelled(value)}")
    return value

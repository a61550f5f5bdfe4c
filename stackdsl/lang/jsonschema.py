"""The JSON Schema (Draft 2020-12) of scenario files, for editors and ``stackdsl schema``.

It accepts what the loader accepts, except for what JSON Schema cannot say, where it is
wider: a quantity string's unit dimension and bounds other than its sign (pint converts
the unit: ``"120 parsec"`` passes where a spacing is at most 10 m), names of brick types and
materials, the number of bricks of a tower, descending level ranges ("5-3"), levels both in
``stays`` and ``may_fall``, a drop gap not below the collapse threshold (which may come from
a brick type), NaN (JSON has none, and every comparison with it is false), and numbers beyond
a double (``1e999``). Numeric bounds (sides from 3 mm to 10 m, positions within 1 km...) are
``minimum``/``maximum`` of the number. Every key has a description and an example
(:mod:`stackdsl.lang.schema_docs`). Two copies are shipped: ``schema/scenario.schema.json``,
which the repository's scenarios name by a relative path, and ``stackdsl/scenario.schema.json``
inside the package, whose absolute path ``stackdsl schema --path`` prints for a file anywhere
(``stackdsl schema --write`` regenerates both).

Source: stackdsl's own.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

from .schema import FORMAT_VERSION, Scenario
from .schema_docs import documented
from .schema_parts import structure_json_schema
from .units import Sign, quantity_pattern

#: The schema's identifier: stable for format 1, URL-shaped, and no address to fetch (the
#: ``.invalid`` top-level domain never resolves, RFC 2606): editors are pointed at the file,
#: :data:`PACKAGED` (``stackdsl schema --path``), which is the installed version's own.
SCHEMA_ID = "https://stackdsl.invalid/schema/scenario/1.json"
#: The file name of the schema shipped inside the package (``importlib.resources``).
PACKAGED = "scenario.schema.json"
SCHEMA_DIALECT = "https://json-schema.org/draft/2020-12/schema"

_QUANTITY_STRINGS: dict[str, Sign] = {"Quantity": "any", "NonNegativeQuantity": "non-negative", "PositiveQuantity": "positive"}
_QUANTITY_STRING_DESCRIPTION = (
    "a number, an optional '/ number' and a unit ('120 mm', '1/240 s', '3 m/s'); the unit must be of the field's "
    "kind (a length, a time...), which the loader checks"
)


def _key(node: Any) -> str:
    return json.dumps(node, sort_keys=True)


def _refer(node: Any, refs: dict[str, dict[str, str]]) -> Any:
    """``node`` with every subschema found in ``refs`` (by :func:`_key`) replaced by its ``$ref``."""
    if isinstance(node, dict):
        if _key(node) in refs:
            return refs[_key(node)]
        return {key: _refer(value, refs) for key, value in node.items()}
    if isinstance(node, list):
        return [_refer(value, refs) for value in node]
    return node


#: What a number of the scene may be written as instead (stackdsl.lang.distributions).
DISTRIBUTION: dict[str, Any] = {
    "type": "object",
    "description": "a random value: {uniform: [low, high]}, {normal: {mean, sd, clip: [low, high]}} or {choice: [...]}, "
    "drawn once a sample, or a layer or a brick ('per', on a tower's shift and yaw_jitter)",
    "oneOf": [{"required": ["uniform"]}, {"required": ["normal"]}, {"required": ["choice"]}],
    "properties": {
        "uniform": {"type": "array", "minItems": 2, "maxItems": 2, "items": {"type": ["number", "string"]}},
        "normal": {
            "type": "object",
            "required": ["mean", "sd"],
            "additionalProperties": False,
            "properties": {
                "mean": {"type": ["number", "string"]},
                "sd": {"type": ["number", "string"]},
                "clip": {"type": "array", "minItems": 2, "maxItems": 2, "items": {"type": ["number", "string"]}},
            },
        },
        "choice": {"type": "array", "minItems": 1, "maxItems": 1000, "items": {"type": ["number", "string"]}},
        "per": {"enum": ["sample", "layer", "brick"]},
    },
    "additionalProperties": False,
}
#: Models and top-level fields whose numbers are not the scene's: no distribution there.
_NOT_RANDOM = {"Expect", "CollapseLevel", "CollapseStatistic", "Within", "Quantile", "Probability", "Sweep"}
_NOT_RANDOM_FIELDS = {"stackdsl", "seed"}


def _numeric(node: Any) -> bool:
    """A subschema that takes a number (alone or among other forms)."""
    if not isinstance(node, dict):
        return False
    return node.get("type") in ("number", "integer") or any(_numeric(n) for n in node.get("anyOf", []))


def _random(node: Any) -> Any:
    """``node`` with every field or list item that takes a number also taking a distribution."""
    if isinstance(node, list):
        return [_random(n) for n in node]
    if not isinstance(node, dict):
        return node
    out = {}
    for key, value in node.items():
        if key == "properties":
            value = {name: _or_random(v) if name not in _NOT_RANDOM_FIELDS else v for name, v in value.items()}
        elif key in ("prefixItems",):
            value = [_or_random(v) for v in value]
        elif key == "items":
            value = _or_random(value)
        out[key] = _random(value) if key not in ("properties", "prefixItems", "items") else value
    return out


def _or_random(node: Any) -> Any:
    """``node``, or a distribution in its place if it takes a number (its title, description and
    default kept outside, where editors show them)."""
    if not _numeric(node):
        return _random(node)
    meta = {k: node[k] for k in ("title", "description", "default", "examples") if k in node}
    inner = {k: v for k, v in node.items() if k not in meta}
    return {"anyOf": [_random(inner), {"$ref": "#/$defs/Distribution"}], **meta}


def json_schema() -> dict[str, Any]:
    """The JSON Schema (Draft 2020-12) of a scenario file, for editors and ``stackdsl schema``.

    It is pydantic's schema of :class:`Scenario` with what the validators also accept
    (quantities with units, the short forms of ``collapse``, ``shift``, levels and ``at``, and
    a distribution wherever the scene takes a number)
    and the rules between fields that JSON Schema can say; where it cannot (see the module
    docstring), it accepts more than the loader. Source: stackdsl's own.
    """
    schema = Scenario.model_json_schema()
    structure_json_schema(schema)  # a structure is one layout, or a list or map of parts
    schema.pop("title", None)
    schema.pop("description", None)
    # the quantity strings' grammar once each, not at every field
    strings = {name: {"type": "string", "pattern": quantity_pattern(sign)} for name, sign in _QUANTITY_STRINGS.items()}
    schema = _refer(schema, {_key(value): {"$ref": f"#/$defs/{name}"} for name, value in strings.items()})
    schema["$defs"].update({name: {**value, "description": _QUANTITY_STRING_DESCRIPTION} for name, value in strings.items()})
    # a distribution wherever the scene takes a number
    schema["$defs"] = {name: value if name in _NOT_RANDOM else _random(value) for name, value in schema["$defs"].items()}
    schema["properties"] = {
        name: value if name in _NOT_RANDOM_FIELDS else _or_random(value) for name, value in schema["properties"].items()
    }
    schema["$defs"]["Distribution"] = copy.deepcopy(DISTRIBUTION)
    # an expectation written with no value ('stands:') is refused: the file would pass on nothing
    for value in schema["$defs"]["Expect"]["properties"].values():
        if "anyOf" in value:
            value["anyOf"] = [v for v in value["anyOf"] if v != {"type": "null"}]
    documented(schema)  # a description and an example for every key
    return {
        "$schema": SCHEMA_DIALECT,
        "$id": SCHEMA_ID,
        "title": "Scenario",
        "description": (
            f"A stackdsl scenario file (format 'stackdsl: {FORMAT_VERSION}'): KAPLA bricks stacked in pybullet and what "
            "must hold. Lengths, times and speeds are numbers in SI units or strings with a unit ('120 mm', '1 s', "
            "'3 m/s'); angles are degrees. The loader also checks what this schema cannot: the dimension of a unit, "
            "names of brick types and materials, and a few rules between fields."
        ),
        **schema,
    }


def packaged_path() -> Path:
    """The absolute path of the schema file installed with the package (:data:`PACKAGED`), for
    a ``# yaml-language-server: $schema=PATH`` line in a scenario file anywhere."""
    from importlib.resources import files

    return Path(str(files("stackdsl") / PACKAGED)).resolve()


def schema_text() -> str:
    """The schema as the shipped files hold it: JSON indented by 2, a newline at the end."""
    return json.dumps(json_schema(), indent=2) + "\n"

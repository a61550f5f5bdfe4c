"""The scenario language, version 1: pydantic models of a validated scenario file.

Units: every length, time and speed may be written with a unit ("120 mm", "1 s",
"3 m/s"); bare numbers are SI; angles are degrees. Unknown keys are rejected. The
built-in material ``pine`` and brick type ``kapla`` (120 x 24 x 8 mm, 460 kg/m^3,
friction coefficient 0.5) can be used without being declared.

:func:`json_schema` is the JSON Schema (Draft 2020-12) of scenario files for editors. It
accepts what the loader accepts, except for what JSON Schema cannot say, where it is
wider: a quantity string's unit dimension and bounds other than its sign (pint converts
the unit), names of brick types and materials, the number of bricks of a tower,
descending level ranges ("5-3"), levels both in ``stays`` and ``may_fall``, and numbers
beyond a double (``.inf``, ``1e999``). Scalars are read as YAML writes them: an integer
field takes ``5`` or ``5.0`` but not ``"5"`` or ``true``, a number field no string, a
flag only ``true``/``false`` (pydantic's lax mode would read ``"5"``, ``true`` and ``1``).

Source: stackdsl's own (docs/design.md, words); report 3.2 and chapter 4.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    GetJsonSchemaHandler,
    PrivateAttr,
    StrictBool,
    StrictFloat,
    TypeAdapter,
    WithJsonSchema,
    model_validator,
)
from pydantic.json_schema import JsonSchemaValue
from pydantic_core import CoreSchema

from ._errors import SourceMap
from ._units import WHITESPACE, Angle, AngularSpeed, Density, Length, Sign, Speed, Time, quantity_pattern, time

FORMAT_VERSION = 1
MAX_BRICKS = 5000
MAX_LEVELS = 1000
MAX_SIMULATED_TIME = 3600.0  # s
MIN_DIRECTION = 1e-6  # the largest component of an impact's direction is at least this

SCHEMA_ID = "urn:stackdsl:scenario:1"
SCHEMA_DIALECT = "https://json-schema.org/draft/2020-12/schema"

# Regular expressions shared by the validators and the JSON Schema, written to mean the same in
# Python and ECMA-262 (see stackdsl._units). The JSON Schema narrows numbers to their ranges.
_SPACE = f"{WHITESPACE}*"
_LEVEL_NUMBER = "0*(?:[1-9][0-9]{0,2}|1000)"  # 1 to MAX_LEVELS
_TOLERANCE_NUMBER = "0*(?:[0-9]{1,3}|1000)"  # 0 to MAX_LEVELS
_COLLAPSE = f"{_SPACE}([0-9]+){_SPACE}(?:(?:±|\\+-|\\+/-){_SPACE}([0-9]+))?{_SPACE}"  # "9", "9±1", "9 +- 1", "9 +/- 1"
_LEVEL_RANGE = f"{_SPACE}([0-9]+){_SPACE}(?:(?:-|\\.\\.){_SPACE}([0-9]+))?{_SPACE}"  # "5", "1-11", "1..11"
_AFTER_LEVEL = f"{_SPACE}after{WHITESPACE}+level{WHITESPACE}+([0-9]+){_SPACE}"  # "after level 13"


def _json_pattern(regex: str, *numbers: str) -> str:
    """``regex`` anchored, its groups ``([0-9]+)`` narrowed to ``numbers`` in order."""
    first, *rest = regex.split("([0-9]+)")
    return "^" + first + "".join(f"(?:{number}){part}" for number, part in zip(numbers, rest, strict=True)) + "$"


def _whole(value: Any) -> Any:
    """An integer as YAML writes it, ``5`` or ``5.0``; not ``"5"`` or ``true``."""
    if isinstance(value, (bool, str)):
        raise ValueError(f"expected a valid integer, not {'true or false' if isinstance(value, bool) else 'text'}, got {value!r}")
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def _as_int(value: Any) -> int | None:
    """``value`` as an int if it is an integer (``5`` or ``5.0``, not ``true``), else None."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    if isinstance(value, float):
        return int(value) if value.is_integer() else None
    return value


# An integer field: Annotated[int, Field(ge=..., le=...), _WHOLE], the bounds before _WHOLE so that they reach the
# JSON Schema ({"type": "integer"}, which takes 5.0 too).
_WHOLE = BeforeValidator(_whole)


Number = Annotated[StrictFloat, Field(allow_inf_nan=False)]  # a YAML number, not a string or a flag
PositiveLength = Annotated[Length, Field(gt=0)]
NonNegativeLength = Annotated[Length, Field(ge=0)]
Vector2 = tuple[Length, Length]
Vector3 = tuple[Length, Length, Length]


@dataclass(frozen=True, eq=False)
class _AlsoAccepts:
    """JSON Schema of a type whose BeforeValidator takes more than the type: the type's own schema,
    or any of ``forms`` (JSON Schemas, or types whose schema pydantic derives)."""

    forms: tuple[Any, ...]
    description: str

    def __get_pydantic_json_schema__(self, core_schema: CoreSchema, handler: GetJsonSchemaHandler) -> JsonSchemaValue:
        own = handler(core_schema)
        branches = own["anyOf"] if set(own) == {"anyOf"} else [own]
        forms = [form if isinstance(form, dict) else TypeAdapter(form).json_schema() for form in self.forms]
        return {"anyOf": [*branches, *forms], "description": self.description}


def _given(*names: str) -> dict[str, Any]:
    """JSON Schema: the fields ``names`` are present and not null."""
    return {"required": list(names), "properties": {name: {"not": {"type": "null"}} for name in names}}


def _absent(*names: str) -> dict[str, Any]:
    """JSON Schema: the fields ``names`` are absent or null."""
    return {"properties": {name: {"type": "null"} for name in names}}


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Material(_Model):
    """A material: density, static friction coefficient and restitution of a pair of its bodies."""

    density: Annotated[Density, Field(gt=0)] = 460.0
    friction: Annotated[Number, Field(ge=0, le=10)] = 0.5
    restitution: Annotated[Number, Field(ge=0, le=1)] = 0.0


class BrickType(_Model):
    """A box-shaped brick: ``size`` is length, width, height (the KAPLA default 120 x 24 x 8 mm)."""

    size: tuple[PositiveLength, PositiveLength, PositiveLength] = (0.12, 0.024, 0.008)
    material: str = "pine"


BUILTIN_MATERIALS = {"pine": Material()}
BUILTIN_BRICKS = {"kapla": BrickType()}


def _shift(value: Any) -> Any:
    """A per-layer shift: one length (along x) or an (x, y) pair."""
    return value if isinstance(value, (list, tuple)) else (value, 0.0)


Shift = Annotated[Vector2, BeforeValidator(_shift), _AlsoAccepts((Length,), "one length (along x) or an (x, y) pair")]


class Tower(_Model):
    """A layered tower: ``bricks_per_layer`` parallel bricks ``spacing`` apart (centre to
    centre), each layer turned by ``turn`` degrees and moved by ``shift`` from the one below.

    Two bricks a layer turned 90 deg is the report's 4 stack; a shift makes it a slant tower.
    """

    brick: str = "kapla"
    levels: Annotated[int, Field(ge=1, le=MAX_LEVELS), _WHOLE]
    bricks_per_layer: Annotated[int, Field(ge=1, le=50), _WHOLE] = 2
    spacing: NonNegativeLength = 0.096
    turn: Angle = 90.0
    shift: Shift = (0.0, 0.0)
    origin: Vector2 = (0.0, 0.0)
    yaw: Angle = 0.0


class BrickPlacement(_Model):
    """One brick placed by hand: centre position ``at``, yaw/pitch/roll in degrees.

    ``fixed: true`` makes it part of the environment (a wall, a ramp): it is in the world
    from the start, immovable, and not part of the structure. ``together: true`` places
    it at the same moment as the brick before it (the two bricks of a V).
    """

    id: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]{1,40}$")] | None = None
    brick: str = "kapla"
    at: Vector3
    yaw: Angle = 0.0
    pitch: Angle = 0.0
    roll: Angle = 0.0
    level: Annotated[int, Field(ge=1, le=MAX_LEVELS), _WHOLE] | None = None
    fixed: StrictBool = False
    together: StrictBool = False


class CardHouse(_Model):
    """A card house: rows of inverted V's (two bricks leaning on each other at ``angle``
    degrees from vertical), a flat brick across the peaks of every two neighbouring V's,
    a V on every flat brick, up to a single V: a pyramid with ``levels`` V's at its base.
    ``spacing`` is the distance between neighbouring peaks (default: the V's width + 2 mm).
    """

    brick: str = "kapla"
    levels: Annotated[int, Field(ge=1, le=50), _WHOLE]
    angle: Annotated[Angle, Field(gt=0, lt=60)] = 20.0
    spacing: PositiveLength | None = None
    origin: Vector2 = (0.0, 0.0)


class Structure(_Model):
    """What is built: a ``tower``, a ``card_house`` or a list of ``bricks`` (exactly one)."""

    model_config = ConfigDict(json_schema_extra={"oneOf": [_given("tower"), _given("card_house"), _given("bricks")]})

    tower: Tower | None = None
    card_house: CardHouse | None = None
    bricks: Annotated[list[BrickPlacement], Field(min_length=1, max_length=MAX_BRICKS)] | None = Field(
        default=None,
        json_schema_extra={
            # the first brick is not 'together' (with no brick before it); some brick is not 'fixed'
            "prefixItems": [{"not": {"required": ["together"], "properties": {"together": {"const": True}}}}],
            "contains": {"not": {"required": ["fixed"], "properties": {"fixed": {"const": True}}}},
        },
    )

    @model_validator(mode="after")
    def _one_layout(self) -> Structure:
        if sum(x is not None for x in (self.tower, self.card_house, self.bricks)) != 1:
            raise ValueError("give exactly one of 'tower', 'card_house' or 'bricks'")
        if self.bricks is not None:
            if self.bricks[0].together:
                raise ValueError("the first brick has no brick before it to be placed 'together' with")
            if all(b.fixed for b in self.bricks):
                raise ValueError("every brick is fixed: there is nothing to build")
        return self


class Timing(_Model):
    """One placement every ``interval``; ``settle`` after the last action; bricks are
    placed at rest ``drop_gap`` above their pose, at most ``placement_error`` off it
    horizontally (drawn from the scenario's seed)."""

    interval: Annotated[Time, Field(gt=0, le=60)] = 1.0
    settle: Annotated[Time, Field(ge=0, le=600)] = 2.0
    drop_gap: Annotated[Length, Field(ge=0, le=0.05)] = 0.0005
    placement_error: Annotated[Length, Field(ge=0, le=0.01)] = 0.0


class AfterLevel(_Model):
    """The moment one interval after the last brick of ``level`` was placed."""

    after_level: Annotated[int, Field(ge=1, le=MAX_LEVELS), _WHOLE]


def _when(value: Any) -> Any:
    """``"after level 13"`` -> :class:`AfterLevel`; anything else must be a time >= 0."""
    if isinstance(value, (AfterLevel, dict)):
        return value
    if isinstance(value, str):
        match = re.fullmatch(_AFTER_LEVEL, value)
        if match:
            if not 1 <= int(match[1]) <= MAX_LEVELS:
                raise ValueError(f"expected a level from 1 to {MAX_LEVELS}, got {value!r}")
            return AfterLevel(after_level=int(match[1]))
    try:
        seconds = time(value)
    except ValueError:
        raise ValueError(f"expected a time such as '14 s' or 'after level N', got {value!r}") from None
    if seconds < 0:
        raise ValueError(f"expected a time >= 0, got {value!r}")
    return seconds


When = Annotated[
    AfterLevel | Annotated[float, Field(ge=0)],
    BeforeValidator(_when),
    _AlsoAccepts(
        (
            {"type": "string", "pattern": quantity_pattern("non-negative")},
            {"type": "string", "pattern": _json_pattern(_AFTER_LEVEL, _LEVEL_NUMBER)},
        ),
        "a time >= 0 ('14 s'), 'after level N' or {after_level: N}",
    ),
]

SIDES = {"+x": (-1.0, 0.0, 0.0), "-x": (1.0, 0.0, 0.0), "+y": (0.0, -1.0, 0.0), "-y": (0.0, 1.0, 0.0)}


class Target(_Model):
    """Where an impact hits: the middle of a ``level``'s outer face on ``side``, or a ``point``."""

    model_config = ConfigDict(
        json_schema_extra={
            "oneOf": [{**_given("level", "side"), **_absent("point")}, {**_given("point"), **_absent("level", "side")}]
        }
    )

    level: Annotated[int, Field(ge=1, le=MAX_LEVELS), _WHOLE] | None = None
    side: Literal["+x", "-x", "+y", "-y"] | None = None
    point: Vector3 | None = None

    @model_validator(mode="after")
    def _one_target(self) -> Target:
        if self.point is None and (self.level is None or self.side is None):
            raise ValueError("give 'level' and 'side', or a 'point'")
        if self.point is not None and (self.level is not None or self.side is not None):
            raise ValueError("give 'level' and 'side', or a 'point', not both")
        return self


class Impact(_Model):
    """A projectile brick thrown at ``speed`` so that it reaches ``target`` ``distance``
    after launch; it flies along ``direction`` (default: into the target's side) with its
    long axis along the flight."""

    model_config = ConfigDict(json_schema_extra={"anyOf": [_given("direction"), {"properties": {"target": _given("side")}}]})

    id: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]{1,40}$")] | None = None
    projectile: str = "kapla"
    target: Target
    speed: Annotated[Speed, Field(gt=0, le=100)]
    direction: tuple[Number, Number, Number] | None = Field(
        default=None,
        json_schema_extra={
            "not": {"type": "array", "items": {"exclusiveMinimum": -MIN_DIRECTION, "exclusiveMaximum": MIN_DIRECTION}}
        },
    )
    at: When
    distance: Annotated[Length, Field(gt=0, le=1)] = 0.05

    @model_validator(mode="after")
    def _direction(self) -> Impact:
        if self.direction is None and self.target.side is None:
            raise ValueError("a 'point' target needs a 'direction'")
        if self.direction is not None and all(abs(c) < MIN_DIRECTION for c in self.direction):
            raise ValueError(f"'direction' must not be zero: give it a component of at least {MIN_DIRECTION:g}")
        return self


MAX_TIMESTEP = 0.010  # s


def _timestep(value: float) -> float:
    if value > MAX_TIMESTEP + 1e-12:
        raise ValueError(
            f"a timestep of {value * 1000:.3g} ms is too long for KAPLA bricks: at most 10 ms (1/100 s). "
            "Beyond it stackdsl's answers change (measured: at 1/60 s a thrown brick no longer knocks a "
            "brick off, at 1/30 s every brick falls as it lands); from 1/100 s to 1/2000 s they do not"
        )
    return value


class Engine(_Model):
    """The physics engine: ``mode`` (raw, tuned, extension) picks the defaults of the rest.
    ``timestep`` is at most 10 ms: the capability scenarios give the same answers from
    1/100 s to 1/2000 s and different ones beyond (docs/results.md, hard cases)."""

    mode: Literal["raw", "tuned", "extension"] = "extension"
    timestep: Annotated[Time, Field(ge=1e-5), AfterValidator(_timestep)] | None = Field(
        default=None, json_schema_extra={"maximum": MAX_TIMESTEP + 1e-12}
    )
    solver_iterations: Annotated[int, Field(ge=1, le=10000), _WHOLE] | None = None
    friction_anchors: StrictBool | None = None
    maximal_coordinates: StrictBool | None = None
    ccd: StrictBool | None = None


class Stability(_Model):
    """The stability extension: its ``model`` (``report``: the report's rules;
    ``equilibrium``: rigid-block equilibrium) and thresholds (report 3.3.2); defaults in
    :mod:`stability`."""

    model: Literal["report", "equilibrium"] = "report"
    rest_speed: Annotated[Speed, Field(gt=0)] | None = None
    rest_angular_speed: Annotated[AngularSpeed, Field(gt=0)] | None = None
    rest_duration: Annotated[Time, Field(ge=0, le=10)] | None = None


class CollapseLevel(_Model):
    """Expected collapse level with a tolerance in levels."""

    level: Annotated[int, Field(ge=1, le=MAX_LEVELS), _WHOLE]
    tolerance: Annotated[int, Field(ge=0, le=MAX_LEVELS), _WHOLE] = 0


def _collapse(value: Any) -> Any:
    """``9``, ``"9±1"``, ``"9 +- 1"`` or ``{level: 9, tolerance: 1}``."""
    number = _as_int(value)
    if number is not None:
        return {"level": number}
    if isinstance(value, str):
        match = re.fullmatch(_COLLAPSE, value)
        if not match:
            raise ValueError(f"expected a level such as '9±1', '9 +- 1' or 9, got {value!r}")
        return {"level": int(match[1]), "tolerance": int(match[2] or 0)}
    return value


def _levels(value: Any) -> Any:
    """Levels: ``5``, ``"1-11"``, or a list of those; returned as a sorted tuple."""
    items = value if isinstance(value, list) else [value]
    levels: set[int] = set()
    for item in items:
        number = _as_int(item)
        match = re.fullmatch(_LEVEL_RANGE, item) if isinstance(item, str) else None
        if number is not None:
            first = last = number
        elif match:
            first, last = int(match[1]), int(match[2] or match[1])
        else:
            first, last = 0, -1  # refused below
        if not 1 <= first <= last <= MAX_LEVELS:
            raise ValueError(f"expected levels from 1 to {MAX_LEVELS} such as 5, '1-11' or a list of those, got {item!r}")
        levels.update(range(first, last + 1))
    return tuple(sorted(levels))


_LEVEL_ITEM = {
    "anyOf": [
        {"type": "integer", "minimum": 1, "maximum": MAX_LEVELS},
        # a range's end below its start ("5-3") is refused by the loader only
        {"type": "string", "pattern": _json_pattern(_LEVEL_RANGE, _LEVEL_NUMBER, _LEVEL_NUMBER)},
    ]
}
Levels = Annotated[
    tuple[int, ...],
    BeforeValidator(_levels),
    WithJsonSchema(
        {"anyOf": [_LEVEL_ITEM, {"type": "array", "items": _LEVEL_ITEM}], "description": "levels: 5, '1-11', or a list of those"}
    ),
]


def _flag(value: Any) -> Any:
    """``true`` or ``false`` only (pydantic's lax mode would take 1 for true)."""
    if not isinstance(value, bool):
        raise ValueError(f"expected true or false, got {value!r}")
    return value


class Expect(_Model):
    """What must hold: a ``collapse`` level, or that the structure ``stands``; after an
    impact, the levels that ``stay`` in place and the levels that ``may_fall``."""

    model_config = ConfigDict(json_schema_extra={"not": _given("collapse", "stands")})

    collapse: (
        Annotated[
            CollapseLevel,
            BeforeValidator(_collapse),
            _AlsoAccepts(
                (
                    {"type": "integer", "minimum": 1, "maximum": MAX_LEVELS},
                    {"type": "string", "pattern": _json_pattern(_COLLAPSE, _LEVEL_NUMBER, _TOLERANCE_NUMBER)},
                ),
                "the level expected to collapse: 9, '9±1', '9 +- 1' or {level: 9, tolerance: 1}",
            ),
        ]
        | None
    ) = None
    stands: Annotated[Literal[True], BeforeValidator(_flag)] | None = None
    stays: Levels | None = None
    may_fall: Levels | None = None

    @model_validator(mode="after")
    def _consistent(self) -> Expect:
        if self.collapse is not None and self.stands:
            raise ValueError("a structure cannot both collapse and stand: give one of 'collapse' or 'stands'")
        # JSON Schema cannot compare two lists of ranges: the schema leaves this to the loader
        if self.stays and self.may_fall and set(self.stays) & set(self.may_fall):
            raise ValueError("a level cannot both stay and fall: 'stays' and 'may_fall' overlap")
        return self


class Ground(_Model):
    """The ground plane at height 0."""

    material: str = "pine"


class Scenario(_Model):
    """A validated scenario file (format ``stackdsl: 1``).

    Use :func:`stackdsl.load_scenario` to read one from YAML; it keeps where each field
    came from, so later stages (the compiler) can point errors at the file.
    """

    stackdsl: Annotated[Literal[1], BeforeValidator(_whole)]
    name: Annotated[str, Field(min_length=1, max_length=200)] | None = None
    description: str = ""
    seed: Annotated[int, Field(ge=0), _WHOLE] = 0
    materials: dict[str, Material] = {}
    brick_types: dict[str, BrickType] = {}
    ground: Ground = Ground()
    structure: Structure
    timing: Timing = Timing()
    impacts: Annotated[list[Impact], Field(max_length=100)] = []
    engine: Engine = Engine()
    stability: Stability = Stability()
    collapse_threshold: PositiveLength | None = None
    expect: Expect = Expect()
    # checks before simulating that this scene silences: "floating" lets bricks be placed resting on nothing
    allow: list[Literal["floating"]] = []

    _source: SourceMap = PrivateAttr(default_factory=lambda: SourceMap("<scenario>"))

    @property
    def source(self) -> SourceMap:
        """Where the fields came from (:class:`SourceMap`)."""
        return self._source

    def material(self, name: str) -> Material:
        """A declared or built-in material. Raises KeyError for an unknown name."""
        return {**BUILTIN_MATERIALS, **self.materials}[name]

    def brick_type(self, name: str) -> BrickType:
        """A declared or built-in brick type. Raises KeyError for an unknown name."""
        return {**BUILTIN_BRICKS, **self.brick_types}[name]


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


def json_schema() -> dict[str, Any]:
    """The JSON Schema (Draft 2020-12) of a scenario file, for editors and ``stackdsl schema``.

    It is pydantic's schema of :class:`Scenario` with what the validators also accept
    (quantities with units, the short forms of ``collapse``, ``shift``, levels and ``at``)
    and the rules between fields that JSON Schema can say; where it cannot (see the module
    docstring), it accepts more than the loader. Source: stackdsl's own.
    """
    schema = Scenario.model_json_schema()
    schema.pop("title", None)
    schema.pop("description", None)
    # the quantity strings' grammar once each, not at every field
    strings = {name: {"type": "string", "pattern": quantity_pattern(sign)} for name, sign in _QUANTITY_STRINGS.items()}
    schema = _refer(schema, {_key(value): {"$ref": f"#/$defs/{name}"} for name, value in strings.items()})
    schema["$defs"].update({name: {**value, "description": _QUANTITY_STRING_DESCRIPTION} for name, value in strings.items()})
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


def reference_errors(s: Scenario) -> list[tuple[tuple, str]]:
    """Names that point nowhere: (field path, message) for each, in file order."""
    bricks = {**BUILTIN_BRICKS, **s.brick_types}
    materials = {**BUILTIN_MATERIALS, **s.materials}
    problems: list[tuple[tuple, str]] = []

    def brick(path: tuple, name: str) -> None:
        if name not in bricks:
            problems.append((path, f"unknown brick type {name!r}; known: {', '.join(sorted(bricks))}"))

    for name, bt in s.brick_types.items():
        if bt.material not in materials:
            problems.append(
                (("brick_types", name, "material"), f"unknown material {bt.material!r}; known: {', '.join(sorted(materials))}")
            )
    if s.ground.material not in materials:
        problems.append(
            (("ground", "material"), f"unknown material {s.ground.material!r}; known: {', '.join(sorted(materials))}")
        )
    if s.structure.tower:
        brick(("structure", "tower", "brick"), s.structure.tower.brick)
    if s.structure.card_house:
        brick(("structure", "card_house", "brick"), s.structure.card_house.brick)
    for i, b in enumerate(s.structure.bricks or []):
        brick(("structure", "bricks", i, "brick"), b.brick)
    ids = [b.id for b in s.structure.bricks or [] if b.id] + [imp.id for imp in s.impacts if imp.id]
    for i, b in enumerate(s.structure.bricks or []):
        if b.id and ids.count(b.id) > 1:
            problems.append((("structure", "bricks", i, "id"), f"brick id {b.id!r} is used more than once"))
    for i, imp in enumerate(s.impacts):
        brick(("impacts", i, "projectile"), imp.projectile)
    n_bricks = s.structure.tower.levels * s.structure.tower.bricks_per_layer if s.structure.tower else 0
    if n_bricks > MAX_BRICKS:
        problems.append((("structure", "tower", "levels"), f"the tower has {n_bricks} bricks; at most {MAX_BRICKS} are allowed"))
    return problems

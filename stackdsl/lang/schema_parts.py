"""Composed scenes: a ``structure`` written as a list (or a map) of named parts.

Each part is one layout (a generator: ``tower``, ``card_house``, ``wall``, ``pyramid``,
``dominoes``; or a ``bricks`` list) with its own ``origin`` and ``yaw``, and ``on``: the parts
or the brick it rests on. Written as a list, each part has a ``name``; as a map, the key is its
name::

    structure:
      - {name: left, tower: {levels: 5, origin: [-60 mm, 0]}}
      - {name: right, tower: {levels: 5, origin: [60 mm, 0]}}
      - {name: deck, on: [left, right], bricks: [{at: [0, 0, 4 mm]}]}

The single-layout form (``structure: {tower: ...}``) is unchanged; :class:`Structure`
(:mod:`stackdsl.lang.schema`) reads both and keeps the parts in its ``parts`` field, a list or a
map as written. The bricks of the parts are placed part after part
(:mod:`stackdsl.compile.parts`).

Source: stackdsl's own.
"""

from __future__ import annotations

import difflib
import re
from typing import Annotated, Any

from pydantic import BeforeValidator, ConfigDict, Discriminator, Field, StrictBool, Tag, WithJsonSchema, model_validator

from .bounds import MAX_BRICKS, BoundedAngle, StrictModel, Vector2
from .errors import FieldPath
from .grammar import given
from .schema_generators import Dominoes, Pyramid, Wall
from .schema_layouts import BrickPlacement, CardHouse, Tower
from .spelling import spelled

#: The layouts a structure or a part is made of, in the order they are looked for.
LAYOUTS = ("tower", "card_house", "bricks", "wall", "pyramid", "dominoes")
#: Most parts a structure may have.
MAX_PARTS = 100
NAME = r"^[A-Za-z_][A-Za-z0-9_-]{0,39}$"
"""A part's name: a letter or '_', then letters, digits, '_' and '-' (no '.', which joins it to
its bricks' ids); not a digit first, which ``expect`` would read as a level ('2', '1-2')."""
#: Names a part may not have: they would read as a single layout's key or as a part's own field.
RESERVED = frozenset(LAYOUTS) | {"parts", "name", "on", "origin", "yaw", "interleave"}

ON = r"^[A-Za-z0-9_.-]{1,100}$"
"""What a part is on: a part's name, or a brick's id (``left.L05.2``)."""

PartName = Annotated[str, Field(pattern=NAME)]
_ON_SCHEMA = {
    "anyOf": [
        {"type": "string", "pattern": ON},
        {"type": "array", "minItems": 1, "maxItems": 100, "items": {"type": "string", "pattern": NAME}},
    ]
}


def _on(value: Any) -> Any:
    """``on``: a part's name or a brick's id, or a list of parts' names (checked here, so that an
    error names the field, not a branch of the union)."""
    if isinstance(value, str):
        if not re.match(ON, value) or value.endswith("\n"):
            raise ValueError(f"expected a part's name or a brick's id (letters, digits, '_', '-', '.'), got {spelled(value)}")
        return value
    if isinstance(value, list) and value and len(value) <= MAX_PARTS:
        for name in value:
            if not isinstance(name, str) or not re.match(NAME, name) or name.endswith("\n"):
                raise ValueError(f"a list of 'on' names parts (letters, digits, '_', '-'), got {spelled(name)}")
        return value
    raise ValueError(f"expected a part's name, a brick's id or a list of parts' names (1 to {MAX_PARTS}), got {spelled(value)}")


class Part(StrictModel):
    """One named part of a composed structure: exactly one layout, placed at ``origin`` (added to
    the layout's own) and turned by ``yaw`` about it; ``on`` lifts it onto other parts (its first
    level rests on their top, and its levels count on from theirs; its origin is then the middle
    of theirs unless given) or onto a brick (by id, such as ``left.L05.2``; its origin is then
    that brick's centre unless given). Fixed bricks are supports too (a part of them alone, a
    fixed table, has their highest top, level 0), but a part of fixed bricks alone rests on
    nothing and takes no ``on``."""

    model_config = ConfigDict(json_schema_extra={"oneOf": [given(name) for name in LAYOUTS]})

    name: PartName | None = Field(
        default=None, description="the part's name, the prefix of its bricks' ids ('left' gives left.L01.1)", examples=["left"]
    )
    on: Annotated[str | list[str], BeforeValidator(_on), WithJsonSchema(_ON_SCHEMA)] | None = Field(
        default=None,
        description="what it rests on: a part written before it, a list of them (their highest top), or a brick's id "
        "(a fixed one too); its first level rests on that top. A part's fixed bricks are its top only when it has no "
        "other; a part of fixed bricks alone takes no 'on'",
        examples=["left", ["left", "right"], "left.L05.2"],
    )
    origin: Vector2 | None = Field(
        default=None,
        description="where the part's own origin stands, [x, y] (default [0, 0]; on parts, the middle of their origins; on a brick, its centre)",
        examples=[["-60 mm", 0]],
    )
    yaw: BoundedAngle = Field(default=0.0, description="degrees the whole part is turned about its origin", examples=[90])
    interleave: StrictBool = Field(
        default=False,
        description="placed level by level with the part before it (and the parts interleaved with that one), "
        "instead of after it: both towers of a bridge rise together",
        examples=[True],
    )
    tower: Tower | None = Field(default=None, description="a layered tower", examples=[{"levels": 5}])
    card_house: CardHouse | None = Field(default=None, description="a card house", examples=[{"levels": 2}])
    bricks: Annotated[list[BrickPlacement], Field(min_length=1, max_length=MAX_BRICKS)] | None = Field(
        default=None,
        description="bricks placed by hand; 'at' is from the part's origin, its z from the top it rests on",
        examples=[[{"at": [0, 0, "4 mm"]}]],
    )
    wall: Wall | None = Field(
        default=None, description="a wall in running bond", examples=[{"courses": 4, "bricks_per_course": 3}]
    )
    pyramid: Pyramid | None = Field(default=None, description="a stepped pyramid", examples=[{"base": 4}])
    dominoes: Dominoes | None = Field(default=None, description="a row of dominoes", examples=[{"count": 30}])

    @model_validator(mode="after")
    def _one_layout(self) -> Part:
        given = [name for name in LAYOUTS if getattr(self, name) is not None]
        if len(given) != 1:
            raise ValueError(f"a part is exactly one of {', '.join(LAYOUTS)}" + (f"; got {', '.join(given)}" if given else ""))
        if self.name in RESERVED:
            raise ValueError(f"{self.name!r} is a key of the structure; give the part another name")
        return self

    @property
    def kind(self) -> str:
        """Which layout it is (one of :data:`LAYOUTS`)."""
        return next(name for name in LAYOUTS if getattr(self, name) is not None)

    @property
    def layout(self) -> Any:
        """Its layout: a generator's model, or the list of bricks."""
        return getattr(self, self.kind)


def _form(value: Any) -> str:
    return "map" if isinstance(value, dict) else "list"


#: The parts as written: a list (each with a name) or a map (name: part).
Parts = Annotated[
    Annotated[list[Part], Tag("list"), Field(min_length=1, max_length=MAX_PARTS)]
    | Annotated[dict[Annotated[str, Field(pattern=NAME)], Part], Tag("map"), Field(min_length=1, max_length=MAX_PARTS)],
    Discriminator(_form),
]


def as_parts(value: Any) -> Any:
    """A structure written as a list or a map of parts, as ``{"parts": ...}``; anything else as is.
    A map is one of parts when none of its keys is a layout or ``parts``, and some part names a
    layout or no key is a layout's misspelling (``towr``: the typo is reported as one); or when a
    layout's key holds a part (``tower: {tower: ...}``: a part named after a layout, refused as
    such by :func:`check_parts`)."""
    if isinstance(value, list):
        return {"parts": value}
    if isinstance(value, dict) and any(
        k in LAYOUTS and isinstance(v, dict) and any(x in v for x in LAYOUTS) for k, v in value.items()
    ):  # a layout's key whose value is itself a part ('tower: {tower: ...}'): a part named after a layout
        return {"parts": value}
    if isinstance(value, dict) and value and not any(k in value for k in (*LAYOUTS, "parts")):
        some_layout = any(isinstance(v, dict) and any(k in v for k in LAYOUTS) for v in value.values())
        typo = any(difflib.get_close_matches(str(k), LAYOUTS, n=1) for k in value)
        if some_layout or not typo:
            return {"parts": value}
    return value


def named_parts(parts: list[Part] | dict[str, Part]) -> list[tuple[str, FieldPath, Part]]:
    """Each part's name, field path as written (``("structure", 0)`` or ``("structure", "left")``)
    and model, in order."""
    if isinstance(parts, dict):
        return [(name, ("structure", name), part) for name, part in parts.items()]
    return [(part.name or "", ("structure", i), part) for i, part in enumerate(parts)]


def check_parts(parts: list[Part] | dict[str, Part]) -> list[tuple[FieldPath, str]]:
    """The rules between parts: (field path as written, message) for each broken one.
    Names are given (a list's), unique and not reserved; ``on`` names a part before it, or a
    brick id (``PART.ID``) of one; the first brick placed is not 'together'; some brick is not fixed."""
    problems: list[tuple[FieldPath, str]] = []
    seen: list[str] = []
    for name, loc, part in named_parts(parts):
        problems += _name_problems(parts, name, loc, part, seen)
        problems += _on_problems(parts, name, loc, part, seen)
        if part.interleave and part.on:
            problems.append(
                (
                    loc + ("interleave",),
                    "a part 'on' another is built on its top, after it: it cannot also go up level by level beside the "
                    "part before (give 'on' or 'interleave')",
                )
            )
        seen.append(name)
    return problems + _first_part_problems(parts)


def _name_problems(
    parts: list[Part] | dict[str, Part], name: str, loc: FieldPath, part: Part, seen: list[str]
) -> list[tuple[FieldPath, str]]:
    """The problems of a part's name (``name``, the part at ``loc``): a map's part that gives
    another ``name`` than its key; a list's that gives none; a reserved name; one of the parts
    before it (``seen``)."""
    problems: list[tuple[FieldPath, str]] = []
    if isinstance(parts, dict) and part.name is not None and part.name != name:
        problems.append((loc + ("name",), f"the part's name is its key, {name!r}; leave 'name' out"))
    if not name:
        problems.append((loc, "a part in a list needs a 'name' (or write the parts as a map, name: part)"))
    elif name in RESERVED:
        problems.append((loc, f"{name!r} is a key of the structure; give the part another name"))
    elif name in seen:
        problems.append((loc + ("name",), f"there is already a part named {name!r}"))
    return problems


def _on_problems(
    parts: list[Part] | dict[str, Part], name: str, loc: FieldPath, part: Part, seen: list[str]
) -> list[tuple[FieldPath, str]]:
    """The problems of a part's ``on`` (the part ``name`` at ``loc``): each name in it must be a
    part written before it (``seen``), not itself nor a later one; a brick (``PART.ID``) is given
    alone, not in a list. A list's problems are at the name in it."""
    problems: list[tuple[FieldPath, str]] = []
    targets = [((), part.on)] if isinstance(part.on, str) else [((j,), t) for j, t in enumerate(part.on or [])]
    for at, target in targets:
        head = target.split(".", 1)[0]
        if head == name:
            problems.append((loc + ("on", *at), f"{target!r} names this part itself: a part rests on parts written before it"))
        elif head not in seen:
            later = head in (n for n, _, _ in named_parts(parts))
            why = (
                "it is written after this one: a part rests on parts written before it"
                if later
                else f"there is no part {head!r}" + (f"; the parts before this one: {', '.join(seen)}" if seen else "")
            )
            problems.append((loc + ("on", *at), f"{target!r} names no part before this one: {why}"))
        elif target != head and isinstance(part.on, list):
            problems.append((loc + ("on", *at), f"{target!r}: a list of 'on' names parts; a brick is given alone"))
    return problems


def _first_part_problems(parts: list[Part] | dict[str, Part]) -> list[tuple[FieldPath, str]]:
    """The problems of the structure as a whole: its first part cannot interleave, nor its first
    brick be placed 'together'; some brick must not be fixed."""
    problems: list[tuple[FieldPath, str]] = []
    if named_parts(parts)[0][2].interleave:
        problems.append((named_parts(parts)[0][1] + ("interleave",), "the first part has no part before it to interleave with"))
    first = named_parts(parts)[0][2]
    if first.bricks is not None and first.bricks[0].together:
        first_path = named_parts(parts)[0][1]
        problems.append(
            (first_path + ("bricks", 0, "together"), "the first brick has no brick before it to be placed 'together' with")
        )
    if all(p.bricks is not None and all(b.fixed for b in p.bricks) for _, _, p in named_parts(parts)):
        problems.append((("structure",), "every brick is fixed: there is nothing to build"))
    return problems


def structure_json_schema(schema: dict[str, Any]) -> None:
    """Rewrite pydantic's JSON Schema of a scenario (in place) so that ``structure`` reads as it is
    written: one layout, a list of named parts, or a map of them (``parts`` is the models' own
    field, not a key of the file)."""
    defs = schema["$defs"]
    parts = defs["Structure"]["properties"].pop("parts")["anyOf"][0]["oneOf"]
    listed, mapped = (next(p for p in parts if p["type"] == kind) for kind in ("array", "object"))
    listed["items"] = {"allOf": [listed["items"]], "required": ["name"]}
    listed["description"] = "named parts, placed in order: each one layout with its own origin, yaw and 'on'"
    listed["examples"] = [[{"name": "left", "tower": {"levels": 4}}, {"name": "top", "on": "left", "pyramid": {"base": 2}}]]
    pattern = mapped.pop("patternProperties")
    mapped["propertyNames"] = {"pattern": NAME, "not": {"enum": sorted(RESERVED)}}
    mapped["additionalProperties"] = {"allOf": [next(iter(pattern.values()))], "not": {"required": ["name"]}}
    mapped["description"] = "named parts as a map (name: part), placed in order"
    mapped["examples"] = [{"left": {"tower": {"levels": 4}}, "top": {"on": "left", "pyramid": {"base": 2}}}]
    single = {"$ref": "#/$defs/Structure"}
    schema["properties"]["structure"] = {"anyOf": [single, listed, mapped]}  # described with every key (schema_docs)

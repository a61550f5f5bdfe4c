"""A structure's bricks, of one layout or composed of named parts, where the scene puts them.

A part's bricks are generated in its layout's own frame (:mod:`stackdsl.compile.layouts`,
:mod:`stackdsl.compile.generators`), then turned by the part's ``yaw`` about its origin, moved
to its ``origin`` and lifted onto what it rests on:

* ``on: PART`` (or a list of parts, written before it): the part's z = 0 is the highest top of
  their bricks, its levels count on from their highest level, and its origin is theirs (the
  middle of theirs, for a list) unless given; a part's fixed bricks count only when it has no
  other (a fixed table: its top, level 0 as the ground's);
* ``on: PART.ID`` (a brick of such a part, a fixed one too): z = 0 is that brick's top, levels
  count on from its level (0 for a fixed brick), and the origin is the brick's centre unless given;
* a part of fixed bricks alone has no ``on``: a fixture rests on nothing;
* nothing: the ground, level 1 its first.

So levels count from the ground across parts: a card house on a 5-level tower starts at
level 6. Bricks keep their order, part after part (a part with ``interleave: true`` is placed level by
level with the part before it instead, each level in part order); each id is prefixed by its part's name
(``left.L05.2``).

Source: stackdsl's own.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from stability import Box

from ..lang.bounds import MAX_BRICKS
from ..lang.errors import FieldPath
from ..lang.schema import Scenario
from ..lang.schema_parts import Part, check_parts, named_parts
from .generators import dominoes, pyramid, wall
from .layouts import LaidBrick, by_hand, card_house, tower, wrap
from .program import PartSummary


def generate(scenario: Scenario, kind: str, model: Any, path: FieldPath) -> list[LaidBrick]:
    """The bricks of one layout ``model`` of ``kind`` (a :data:`~stackdsl.lang.schema_parts.LAYOUTS`
    name) written at ``path``, in its own frame, each with ``source`` set to the field that made it."""
    if kind == "bricks":
        return by_hand(scenario, model, path)
    if kind == "tower":
        return tower(scenario, model, path)
    makers: dict[str, Callable[[Scenario, Any, FieldPath], list[LaidBrick]]] = {
        "card_house": card_house,
        "wall": wall,
        "pyramid": pyramid,
        "dominoes": dominoes,
    }
    return makers[kind](scenario, model, path)


def arrange(scenario: Scenario) -> list[LaidBrick]:
    """The structure's bricks (fixtures included) in placement order, with levels and ids.

    Raises:
        ScenarioError: a generator's own check fails, ``on`` names a part not before it or a brick
            that is not there, parts are unnamed or named alike, or the parts have more than
            :data:`~stackdsl.lang.bounds.MAX_BRICKS` bricks together.
    """
    structure = scenario.structure
    if structure.parts is None:
        kind = structure.layout_name
        assert kind is not None
        return generate(scenario, kind, getattr(structure, kind), ("structure", kind))
    problems = check_parts(structure.parts)  # refused when validated; here for a scenario made without (model_construct)
    if problems:
        raise scenario.source.error(*problems[0], more=len(problems) - 1)
    bricks: list[LaidBrick] = []
    tops: dict[str, tuple[float, int]] = {}  # part -> (top height, m; highest level)
    origins: dict[str, tuple[float, float]] = {}  # part -> where its origin stands
    placed: dict[str, LaidBrick] = {}
    groups: list[int] = []  # each part's group: its own index, or its group's when interleaved
    counts: list[int] = []
    for name, path, part in named_parts(structure.parts):
        local = generate(scenario, part.kind, part.layout, path + (part.kind,))
        if part.on is not None and local and all(b.fixed for b in local):
            raise scenario.source.error(
                path + ("on",),
                "the part's bricks are all fixed: a fixture is there from the start and rests on nothing, so it "
                "is not put on anything; leave out 'on' and give each brick its height from the ground in 'at' "
                "(and the part an origin [x, y] if it is to stand elsewhere)",
            )
        base, level, origin = _support(scenario, part, path, tops, placed, origins)
        origins[name] = origin
        moved = _moved(local, name, origin, part.yaw, base, level)
        # what a part put on this one rests on: its standing bricks, or its fixtures when it has
        # nothing else (a fixed table: level 0, as the ground)
        standing = [b for b in moved if not b.fixed] or moved
        tops[name] = (max((_top(scenario, b) for b in standing), default=base), max((b.level for b in standing), default=level))
        placed.update((b.id, b) for b in moved)
        bricks += moved
        if len(bricks) > MAX_BRICKS:
            raise scenario.source.error(
                path, f"the parts up to this one have {len(bricks)} bricks; at most {MAX_BRICKS} are allowed"
            )
        groups.append(groups[-1] if part.interleave and groups else len(groups))
        counts.append(len(moved))
    return _interleaved(bricks, groups, counts)


def _interleaved(bricks: list[LaidBrick], groups: list[int], counts: list[int]) -> list[LaidBrick]:
    """``bricks`` (part after part, ``counts`` of them each) in placement order: the parts of one
    group (a part and those interleaved with it) level by level, each level in part order."""
    out: list[LaidBrick] = []
    start = 0
    for group in sorted(set(groups)):
        members = [i for i, g in enumerate(groups) if g == group]
        size = sum(counts[i] for i in members)
        chunk = bricks[start : start + size]
        part_of = [i for i in members for _ in range(counts[i])]
        order = sorted(range(size), key=lambda j: (chunk[j].level, part_of[j], j))
        out += [chunk[j] for j in order]
        start += size
    return out


def summaries(scenario: Scenario, bricks: list[LaidBrick]) -> tuple[PartSummary, ...]:
    """What ``stackdsl compile`` shows of each named part: its layout, support, ids and levels."""
    if scenario.structure.parts is None:
        return ()
    out = []
    for name, _, part in named_parts(scenario.structure.parts):
        own = [b for b in bricks if b.id.startswith(name + ".")]
        standing = [b.level for b in own if not b.fixed] or [0]
        on = "ground" if part.on is None else part.on if isinstance(part.on, str) else ", ".join(part.on)
        out.append(
            PartSummary(
                name=name,
                layout=part.kind,
                on=on,
                bricks=len(own),
                first=own[0].id,
                last=own[-1].id,
                levels=(min(standing), max(standing)),
            )
        )
    return tuple(out)


def _support(
    scenario: Scenario,
    part: Part,
    path: FieldPath,
    tops: dict[str, tuple[float, int]],
    placed: dict[str, LaidBrick],
    origins: dict[str, tuple[float, float]],
) -> tuple[float, int, tuple[float, float]]:
    """(height of the part's z = 0, m; the level below its first; its origin) from its ``on``:
    an origin not given is the ground's (0, 0), the middle of the ``on`` parts' origins, or the
    centre of the ``on`` brick."""
    origin = part.origin or (0.0, 0.0)
    if part.on is None:
        return 0.0, 0, origin
    if isinstance(part.on, str) and "." in part.on:
        brick = _on_brick(scenario, part.on, path, placed)
        centre = (float(brick.position[0]), float(brick.position[1]))
        return _top(scenario, brick), brick.level, part.origin or centre
    names = [part.on] if isinstance(part.on, str) else part.on
    top = max(tops[n][0] for n in names)
    _warn_below(scenario, path, names, top, tops)
    middle = (sum(origins[n][0] for n in names) / len(names), sum(origins[n][1] for n in names) / len(names))
    return top, max(tops[n][1] for n in names), part.origin or middle


def _on_brick(scenario: Scenario, on: str, path: FieldPath, placed: dict[str, LaidBrick]) -> LaidBrick:
    """The brick a part's ``on`` (at ``path``) names as ``PART.ID``, among those ``placed``.

    Raises:
        ScenarioError: at the part's ``on`` when that part has no such brick, naming its bricks.
    """
    brick = placed.get(on)
    if brick is None:
        head = on.split(".", 1)[0]
        ids = [i for i in placed if i.startswith(head + ".")]
        shown = f"{ids[0]} to {ids[-1]}" if len(ids) > 1 else ", ".join(ids) or "none"
        raise scenario.source.error(path + ("on",), f"part {head!r} has no brick {on!r}: its bricks are {shown}")
    return brick


def _warn_below(scenario: Scenario, path: FieldPath, names: list[str], top: float, tops: dict[str, tuple[float, int]]) -> None:
    """Warn (at the part's ``on``, ``path``) when some of its ``on`` parts (``names``) have their
    top more than :data:`GAP_WARNED` below the highest, ``top``: the part does not rest on them."""
    below = [n for n in names if top - tops[n][0] > GAP_WARNED]
    if below:
        lower = ", ".join(f"{n!r} ({(top - tops[n][0]) * 1000:.3g} mm lower)" for n in below)
        warnings.warn(
            scenario.source.warning(
                path + ("on",),
                f"the part is put on the highest top of its 'on' parts, so it does not reach {lower}: it rests on "
                f"{', '.join(repr(n) for n in names if n not in below)} alone",
            ),
            stacklevel=3,
        )


GAP_WARNED = 0.001
"""Metres below the highest of a part's ``on`` parts a named part's top may be before the part is
warned that it does not rest on it (a contact pad)."""


def _moved(
    local: list[LaidBrick], name: str, origin: tuple[float, float], yaw: float, base: float, level: int
) -> list[LaidBrick]:
    """``local`` turned by ``yaw`` degrees about z, moved to ``origin`` and up by ``base``, its levels
    raised by ``level`` (fixtures stay at level 0), its ids prefixed by ``name``."""
    c, s = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    shift = np.array([origin[0], origin[1], base])
    return [
        replace(
            b,
            id=f"{name}.{b.id}",
            level=b.level if b.fixed else b.level + level,
            position=turn @ b.position + shift,
            yaw=wrap(b.yaw + yaw),
        )
        for b in local
    ]


def _top(scenario: Scenario, brick: LaidBrick) -> float:
    """The height of a brick's highest corner, m."""
    box = Box(np.array(scenario.brick_type(brick.type).size) / 2, 1.0)
    return float(box.corners(brick.pose())[:, 2].max())


def layout_at(scenario: Scenario, path: FieldPath) -> Any:
    """The layout (a generator's model, or a bricks list) that made a brick whose ``source`` is
    ``path``: ``("structure", "tower")``, ``("structure", "left", "wall")``, ``("structure", 0,
    "bricks", 3)``..."""
    structure = scenario.structure
    if structure.parts is None:
        return getattr(structure, str(path[1]))
    part: Part = structure.parts[path[1]]  # type: ignore[index]
    return getattr(part, str(path[2]))


def part_path(path: FieldPath) -> FieldPath | None:
    """The part a brick's ``source`` is in (``("structure", "left")``), or None outside parts."""
    return path[:2] if len(path) >= 3 and path[2] in ("tower", "card_house", "bricks", "wall", "pyramid", "dominoes") else None

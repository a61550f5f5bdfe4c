"""Checks before simulating: mistakes the compiler can see in the placements themselves.

Every brick is tested where the program will put it (after the placement error), against
what exists at the moment it is placed: the ground plane (z = 0), the fixtures, and the
bricks placed before it at their target poses; bricks placed ``together`` exist together.

* **Overlap** (always an error): two bricks, a brick and a fixture, or a brick and the
  ground interpenetrate by more than :data:`OVERLAP_TOLERANCE`. pybullet would push them
  apart at the first step, and the scene would collapse for a reason that is no part of it.
* **Floating**: a brick rests on nothing when it is placed. It *rests on* a body when,
  lowered by :data:`REST_TOLERANCE`, it would sink into that body deeper than it already
  is, at a point below its centre: a contact from below within the tolerance. A brick
  only touching something sideways, or hanging by its top on another brick's corner,
  rests on nothing. Tower generators report this at their own fields (``spacing``,
  ``bricks_per_layer``, ``shift``). Dropping a brick from the air may be meant: a
  top-level ``allow: [floating]`` silences this check (the program lists those bricks).
* **Expectations about levels never built**: ``expect.stays`` and ``expect.may_fall``
  may only name built levels (1 to the highest placed); an expected ``collapse`` level
  L ± t is checkable when its range reaches a built level, L - t <= the highest level
  (``9±1`` on an 8-level tower is fine, ``7`` on a 3-level tower is not).
* **A sweep's statistics that can never pass**: a collapse level's ``mean`` or ``quantile``
  whose region lies wholly above the highest level any sample of a grid cell builds, and, when
  the samples draw, P(stands) ``>= 1`` or ``<= 0``, which no 95% interval decides
  (:func:`unreachable_statistics`, run once every cell's samples are compiled; the regions no
  structure reaches, below level 1 or holding no whole level, and P(stands) ``> 1`` or ``< 0``,
  are refused by the language itself).
* **Expectations that contradict each other**: ``stays`` keeping in place bricks a ``toppled``
  count needs. ``stays`` or ``moved`` naming a brick above the highest level an expected collapse
  allows (L + t) is warned of: building stops once the collapse is decided, so it is placed only
  if that takes longer than the placements after it.

The geometry (overlap depths, what a brick rests on) is :mod:`stackdsl.compile.overlap`.

Source: stackdsl's own.
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..lang.errors import MAX_SHOWN, FieldPath, format_path
from ..lang.expectations import (
    CellExpect,
    CollapseLevel,
    CollapseStatistic,
    Expect,
    bricks_of,
    closest,
    levels_of,
    selects,
    span,
)
from ..lang.expressions import parse
from ..lang.schema import Scenario
from ..lang.schema_sweep import MAX_SAMPLES
from .actions import pulled_out
from .overlap import GROUND, OVERLAP_TOLERANCE, REST_TOLERANCE, Body, inspect_bodies
from .parts import layout_at, part_path

FLOATING = "floating"
"""The ``allow`` entry that silences the floating check."""


@dataclass(frozen=True)
class _Problem:
    key: tuple[Any, ...]  # what is wrong, independent of where it is reported
    order: tuple[Any, ...]  # report order: overlaps first, then floating bricks in placement order, then expectations
    path: FieldPath
    message: str
    effect: str = ""  # what happens to the brick, for a message at timing.placement_error


def precheck(scenario: Scenario, bodies: Sequence[Body]) -> tuple[str, ...]:
    """Check the placements and expectations of a compiled scenario before anything runs.

    Args:
        scenario: the scenario (for its source map, generators, timing, ``allow`` and ``expect``).
        bodies: every brick and fixture in placement order (fixtures anywhere).

    Returns:
        The ids of the bricks that rest on nothing when placed and are allowed to
        (``allow: [floating]``), in placement order.

    Raises:
        ScenarioError: at the field to change, for the first problem in placement order
            (overlaps before floating bricks before expectations), with the others shown after
            it, up to :data:`~stackdsl.lang.errors.MAX_SHOWN` in all (a generator's bricks are one
            problem per kind); ``more`` counts the rest (past 1000 overlaps the search stops, so
            the count is then a lower bound).
    """
    overlaps, floating = inspect_bodies(bodies, [b.position for b in bodies])
    allowed = FLOATING in scenario.allow
    found: list[tuple[tuple[int, int, int], tuple[Any, ...], float]] = sorted(
        [((0, bodies[b].slot, b), ("overlap", b, s), d) for b, s, d in overlaps]
        + ([] if allowed else [((1, bodies[b].slot, b), ("floating", b), 0.0) for b in floating])
    )
    placed = {b.id: b.level for b in bodies if b.slot >= 0}
    expectations = _expectation_problems(scenario, max(b.level for b in bodies), list(placed), placed)
    if found:
        # a generator's bricks that miss for one reason are one problem: one per generator and kind,
        # each said at its first brick in placement order (at most MAX_SHOWN shown, the rest counted)
        problems: list[_Problem] = []
        causes: set[tuple[Any, ...]] = set()
        for _, key, depth in found:
            cause = (key[0], key[1] if _by_hand(bodies[key[1]].path) else bodies[key[1]].path)
            if cause in causes:
                continue
            causes.add(cause)
            if len(problems) >= MAX_SHOWN:
                continue
            if key[0] == "overlap":
                problem = _overlap_problem(scenario, bodies, key[1], key[2], depth)
            else:
                problem = _floating_problem(scenario, bodies, key[1], floating)
            if scenario.timing.placement_error > 0:
                problem = _blame_placement_error(scenario, bodies, problem, allowed)
            problems.append(problem)
        first, *rest = problems
        error = scenario.source.error(first.path, first.message).with_others(
            [scenario.source.error(e.path, e.message) for e in [*rest, *expectations]]
        )
        error.more += len(causes) - len(problems)  # past MAX_SHOWN: counted, not shown
        raise error
    if expectations:
        first, *rest = expectations
        raise scenario.source.error(first.path, first.message).with_others(
            [scenario.source.error(e.path, e.message) for e in rest]
        )
    warn_above_collapse(scenario, list(placed), placed)
    return tuple(bodies[i].id for i in floating)


# messages -------------------------------------------------------------------------


def _millimetres(metres: float) -> str:
    mm = metres * 1000
    return f"{mm:.1f}" if abs(mm) < 1e9 else f"{mm:.4g}"


def _mm(metres: float) -> str:
    return f"{_millimetres(metres)} mm"


def _at(position: Sequence[float]) -> str:
    return "(" + ", ".join(_millimetres(v) for v in position) + ") mm"


def _by_hand(path: FieldPath) -> bool:
    """Whether a brick's field is one of a bricks list (``("structure", "bricks", 3)``), not a generator."""
    return len(path) >= 2 and path[-2] == "bricks"


def _kind(path: FieldPath) -> str:
    """The layout that made a brick: ``bricks``, ``tower``, ``card_house``, ``wall``..."""
    return "bricks" if _by_hand(path) else str(path[-1])


def _name(body: Body) -> str:
    if _by_hand(body.path):
        return f"brick {body.id!r} ({format_path(body.path)})"
    return f"brick {body.id}"


def _overlap_problem(scenario: Scenario, bodies: Sequence[Body], b: int, s: int, depth: float) -> _Problem:
    brick = bodies[b]
    key, order = ("overlap", b, s), (0, brick.slot, b)
    into = "the ground" if s == GROUND else _name(bodies[s])
    effect = f"reaches {depth * 1000:.2f} mm into {into}"
    what = f"{_name(brick)} placed at {_at(brick.position)} {effect}"
    limit = f"bodies may touch, or overlap by at most {_mm(OVERLAP_TOLERANCE)} (pybullet would push them apart)"
    part = part_path(brick.path)
    if part is not None and s != GROUND and part_path(bodies[s].path) != part:
        return _Problem(key, order, _part_field(scenario, part), f"{what}; {limit}: move one of the parts apart", effect)
    if _by_hand(brick.path):
        fix = f"raise it by {depth * 1000:.2f} mm" if s == GROUND else "move one of them"
        return _Problem(key, order, brick.path + ("at",), f"{what}; {limit}: {fix}", effect)
    if _kind(brick.path) == "tower" and s != GROUND:
        t = layout_at(scenario, brick.path)
        width = float(scenario.brick_type(t.brick).size[1])
        turns = t.yaw_jitter if isinstance(t.yaw_jitter, list) else [t.yaw_jitter]
        if t.spacing >= width and any(turns):  # apart enough as laid: the turns put them into each other
            most = max(abs(float(a)) for a in turns)
            return _Problem(
                key,
                order,
                brick.path + ("yaw_jitter",),
                f"{what}: the bricks of a layer are {_mm(t.spacing)} apart centre to centre and {_mm(width)} wide, "
                f"and yaw_jitter turns them (up to {most:.3g} deg here): give a smaller turn or a wider spacing",
                effect,
            )
        return _Problem(
            key,
            order,
            brick.path + ("spacing",),
            f"{what}: the bricks of a layer are {_mm(t.spacing)} apart centre to centre and {_mm(width)} wide; "
            f"use a spacing of at least {_mm(width)}",
            effect,
        )
    return _Problem(key, order, _generator_field(scenario, brick.path), f"{what}; {limit}", effect)


def _floating_problem(scenario: Scenario, bodies: Sequence[Body], b: int, floating: list[int]) -> _Problem:
    brick = bodies[b]
    key, order = ("floating", b), (1, brick.slot, b)
    silence = f"or add 'allow: [{FLOATING}]' at the top level if it is meant to drop"
    effect = "rests on nothing"
    what = (
        f"{_name(brick)} rests on nothing when it is placed (t = {brick.time:g} s): no ground, fixture or brick "
        f"placed before it is within {_mm(REST_TOLERANCE)} below it"
    )
    part = part_path(brick.path)
    first = part is not None and brick.level == min(b.level for b in bodies if part_path(b.path) == part and b.slot >= 0)
    if part is not None and first and not _by_hand(brick.path):
        return _Problem(
            key, order, _part_field(scenario, part), f"{what}: the part's first level rests on nothing; {silence}", effect
        )
    if _by_hand(brick.path):
        return _Problem(
            key,
            order,
            brick.path + ("at",),
            f"{what} (its lowest point is {_mm(_lowest(brick))} above the ground); lower it onto what should hold it, "
            f"list it after that, {silence}",
            effect,
        )
    if _kind(brick.path) == "tower":
        path, message = _tower_floating(scenario, bodies, b, floating)
        return _Problem(key, order, path, f"{message}; {silence}", effect)
    return _Problem(key, order, _generator_field(scenario, brick.path), f"{what}; {silence}", effect)


def _lowest(body: Body) -> float:
    rotation = Rotation.from_euler("ZYX", [body.yaw, body.pitch, body.roll], degrees=True).as_matrix()
    return float(body.position[2] - np.abs(rotation[2]) @ np.array(body.half_extents))


def _tower_floating(scenario: Scenario, bodies: Sequence[Body], b: int, floating: list[int]) -> tuple[FieldPath, str]:
    """The field to change and the message for a tower whose bricks miss the layer below."""
    brick = bodies[b]
    t = layout_at(scenario, brick.path)
    length, width = (float(v) for v in scenario.brick_type(t.brick).size[:2])
    level = [bodies[i].id for i in floating if bodies[i].level == brick.level]
    head = f"level {brick.level} of the tower: {', '.join(level)} rest{'s' * (len(level) == 1)} on nothing when placed"
    square = abs(math.remainder(t.turn, 180.0)) == 90.0
    n = t.bricks_per_layer
    tower: FieldPath = brick.path
    if square and n > 1 and t.spacing >= (length + width) / (n - 1) - 1e-12:
        limit = (length + width) / (n - 1)
        outer = (n - 1) * t.spacing / 2
        most = max(1, math.ceil((length + width) / t.spacing - 1e-9))
        written = t.model_fields_set
        field = "bricks_per_layer" if "bricks_per_layer" in written and "spacing" not in written else "spacing"
        return tower + (field,), (
            f"{head}: with {n} bricks a layer {_mm(t.spacing)} apart, the outer ones are centred {_mm(outer)} "
            f"from the middle of their layer, so their near edge ({_mm(outer - width / 2)} out) is not inside "
            f"the {_mm(length / 2)} that the layer below reaches (half a brick's length); use a spacing below "
            f"{_mm(limit)} ((length + width) / (bricks_per_layer - 1)) and at least {_mm(width)} (the width), "
            f"or at most {most} brick{'s' * (most != 1)} a layer"
        )
    if t.shifts is not None and brick.level is not None and brick.level > 1:
        x, y = t.shifts[brick.level - 2]
        return tower + ("shifts", brick.level - 2), (
            f"{head}: it is moved ({_millimetres(x)}, {_millimetres(y)}) mm from the layer below, too far for its "
            f"bricks to reach it ({_layer(n, t.spacing, t.turn)}); use a smaller shift"
        )
    if any(abs(v) > 0 for v in t.shift):
        return tower + ("shift",), (
            f"{head}: each layer is moved ({_millimetres(t.shift[0])}, {_millimetres(t.shift[1])}) mm from the one "
            f"below, too far for its bricks to reach the layer below ({_layer(n, t.spacing, t.turn)}); use a smaller shift"
        )
    return tower + ("spacing",), (
        f"{head}: the layer below does not reach under them ({_layer(n, t.spacing, t.turn)}); bring the bricks "
        "of a layer closer together"
    )


def _layer(n: int, spacing: float, turn: float) -> str:
    """A tower's layer in words: its bricks, their spacing (none for one brick) and its turn."""
    apart = f", {_mm(spacing)} apart" if n > 1 else ""
    return f"{n} brick{'s' * (n != 1)} a layer{apart}, each layer turned {turn:g} deg"


def _generator_field(scenario: Scenario, path: FieldPath) -> FieldPath:
    """The field of a generator to change: a card house's spacing or angle (its own checks keep its
    bricks apart and on the peaks), a wall's or a pyramid's joint, a domino row's spacing or radius."""
    model = layout_at(scenario, path)
    kind = _kind(path)
    if kind == "card_house":
        return path + ("spacing" if model.spacing else "angle",)
    if kind == "dominoes":
        return path + ("radius" if model.radius is not None else "spacing",)
    return path + ("joint",)


def _part_field(scenario: Scenario, part: FieldPath) -> FieldPath:
    """The field that puts a part where it is: its ``origin`` if given, else its ``on``, else the part."""
    written = scenario.source.values
    for field in ("origin", "on"):
        if part + (field,) in written:
            return part + (field,)
    return part


def _blame_placement_error(scenario: Scenario, bodies: Sequence[Body], problem: _Problem, allowed: bool) -> _Problem:
    """A problem that the placement error made (the poses as written have none) is
    reported at ``timing.placement_error``."""
    overlaps, floating = inspect_bodies(bodies, [b.nominal for b in bodies])
    nominal = {("overlap", b, s) for b, s, _ in overlaps} | ({("floating", b) for b in floating} if not allowed else set())
    if problem.key in nominal:
        return problem
    brick = bodies[problem.key[1]]
    silence = f" (or add 'allow: [{FLOATING}]' at the top level)" if problem.key[0] == "floating" else ""
    message = (
        f"a placement error of up to {_mm(scenario.timing.placement_error)} (seed {scenario.seed}) moves "
        f"{_name(brick)} to {_at(brick.position)}, where it {problem.effect}; as written it does not: use a smaller "
        f"placement error or another seed{silence}"
    )
    return _Problem(problem.key, problem.order, ("timing", "placement_error"), message, problem.effect)


def _chosen(selection: Sequence[int | str] | None, ids: Sequence[str], level_of: Mapping[str, int]) -> dict[str, str]:
    """The brick ids a ``stays``/``moved``/``may_fall`` selection names, each with what names
    it (``level 2``, ``'a'``), in the order of ``ids``."""
    levels, selectors = set(levels_of(selection or ())), bricks_of(selection or ())
    out = {}
    for i in ids:
        if level_of.get(i) in levels:
            out[i] = f"level {level_of[i]}"
        else:
            hit = next((s for s in selectors if selects(s, i)), None)
            if hit is not None:
                out[i] = repr(hit)
    return out


def _expectation_problems(
    scenario: Scenario, top: int, ids: Sequence[str] = (), level_of: Mapping[str, int] | None = None
) -> list[_Problem]:
    """Expectations about levels above the highest level placed (``top``), about bricks that
    none of the structure's ``ids`` is, or that name one brick (its level in ``level_of``) as
    both staying and moving or falling, by level, id or part."""
    problems = _collapse_beyond(scenario.expect, top)
    for name in ("stays", "may_fall", "moved"):
        problems += _selection_problems(scenario.expect, name, top, ids)
    problems += _unplaceable(scenario, ids, level_of or {})
    problems += _stay_and_move(scenario.expect, ids, level_of or {})
    return problems


def _collapse_beyond(expect: Expect, top: int) -> list[_Problem]:
    """``expect.collapse`` at a level (with its tolerance) above the highest level placed, ``top``."""
    c = expect.collapse
    if not isinstance(c, CollapseLevel) or c.level - c.tolerance <= top:
        return []
    written = (
        f"collapse {c.level}±{c.tolerance} (levels {c.level - c.tolerance}-{c.level + c.tolerance})"
        if c.tolerance
        else f"collapse {c.level}"
    )
    return [
        _Problem(
            ("expect", "collapse"),
            (2, 0),
            ("expect", "collapse"),
            f"{written} can never be measured: the structure has {top} level{'s' * (top != 1)}, and the "
            f"collapse level is the highest level placed when a brick first moves; expect a level from 1 to "
            f"{top} (or a tolerance that reaches one), or 'stands: true'",
        )
    ]


def _selection_problems(expect: Expect, name: str, top: int, ids: Sequence[str]) -> list[_Problem]:
    """``expect.<name>`` (``stays``, ``may_fall``, ``moved``) naming bricks that none of the
    structure's ``ids`` is (at the first unknown name of a list), or levels above ``top``."""
    problems = []
    levels = levels_of(getattr(expect, name) or ())
    unknown = [s for s in bricks_of(getattr(expect, name) or ()) if not any(selects(s, i) for i in ids)]
    if unknown:
        written = getattr(expect, name)
        at = (list(written).index(unknown[0]),) if isinstance(written, (list, tuple)) else ()
        problems.append(
            _Problem(
                ("expect", name),
                (2, 3),
                ("expect", name, *at),  # at the first unknown name of a list
                f"{', '.join(repr(u) for u in unknown)} name{'s' * (len(unknown) == 1)} no brick of the structure: "
                f"give a brick id (such as {ids[0]!r})"
                + (f" or the start of ids (such as {ids[0].rsplit('.', 1)[0]!r}), up to a '.'" if "." in ids[0] else "")
                + closest(unknown[0], ids),
            )
        )
    beyond = [lv for lv in levels if lv > top]
    if beyond:
        problems.append(
            _Problem(
                ("expect", name),
                (2, 1 if name == "stays" else 2),
                ("expect", name),
                f"level{'s' * (len(beyond) != 1)} {span(beyond)} {'are' if len(beyond) != 1 else 'is'} never built: "
                f"the structure has {top} level{'s' * (top != 1)}; name levels from 1 to {top}",
            )
        )
    return problems


def _stay_and_move(expect: Expect, ids: Sequence[str], level_of: Mapping[str, int]) -> list[_Problem]:
    """Bricks (of ``ids``, each with its level in ``level_of``) that ``stays`` names and ``moved``
    or ``may_fall`` names too, by level, id or part: a brick cannot both stay and move."""
    problems = []
    stays = _chosen(expect.stays, ids, level_of)
    for name, verb in (("moved", "move"), ("may_fall", "fall")):
        both = [(i, why) for i, why in _chosen(getattr(expect, name), ids, level_of).items() if i in stays]
        if both:
            shown = ", ".join(i for i, _ in both[:3]) + (f" and {len(both) - 3} more" if len(both) > 3 else "")
            named = f"{'is' if len(both) == 1 else 'are'} named by both 'stays' ({stays[both[0][0]]}) and {name!r} ({both[0][1]})"
            problems.append(
                _Problem(("expect", name), (2, 4), ("expect", name), f"{shown} {named}: a brick cannot both stay and {verb}")
            )
    return problems


def _unplaceable(scenario: Scenario, ids: Sequence[str], level_of: Mapping[str, int]) -> list[_Problem]:
    """Expectations that contradict each other through the structure, so the file can never
    pass: ``stays`` keeping in place more bricks than ``toppled`` leaves standing (a brick tilted
    past its tipping angle has moved past the default collapse threshold, half its thinnest side),
    and ``toppled`` counting more bricks than the pulls leave in the scene."""
    t = scenario.expect.toppled
    if t is None:
        return []
    pulled = set(pulled_out(scenario))
    total = sum(i not in pulled for i in ids)  # what toppled counts: the bricks left in the scene
    least = t.allows(total)[0]
    written = t.text()
    if least > total and total < len(ids):  # beyond every brick is refused by the compiler already
        return [
            _Problem(
                ("expect", "toppled", "pulled"),
                (2, 6),
                ("expect", "toppled"),
                f"'toppled: {written}' needs at least {least} bricks to topple, and the scene keeps {total} of its "
                f"{len(ids)}: the actions pull the others out, and a pulled brick is not counted",
            )
        ]
    default, threshold = scenario._thinnest_half_side(), scenario.collapse_threshold
    if threshold is not None and (default is None or threshold > default):
        return []  # a threshold above the default: a toppled brick may have moved less than it
    staying = [i for i in _chosen(scenario.expect.stays, ids, level_of) if i not in pulled]
    if not staying or least <= total - len(staying):
        return []
    shown = ", ".join(staying[:3]) + (f" and {len(staying) - 3} more" if len(staying) > 3 else "")
    return [
        _Problem(
            ("expect", "stays", "toppled"),
            (2, 6),
            ("expect", "stays"),
            f"'toppled: {written}' needs at least {least} of the {total} bricks to topple, and 'stays' keeps "
            f"{len(staying)} of them in place ({shown}): a toppled brick has moved, so at most "
            f"{total - len(staying)} can topple; give fewer toppled, or name fewer bricks in 'stays'",
        )
    ]


def warn_above_collapse(scenario: Scenario, ids: Sequence[str], level_of: Mapping[str, int]) -> None:
    """Warn of ``stays`` or ``moved`` naming a brick above the highest level an expected collapse
    N±t can be at: building stops once the collapse is decided, so such a brick is placed only if
    deciding it takes longer than the placements after it (a slow push still under way); else it
    is never placed, neither stays nor moves, and the file fails. Not refused: such a file can pass.
    """
    c = scenario.expect.collapse
    if not isinstance(c, CollapseLevel):
        return
    highest = c.level + c.tolerance
    written = f"collapse {c.level}±{c.tolerance}" if c.tolerance else f"collapse {c.level}"
    for name in ("stays", "moved"):
        above = [(i, why) for i, why in _chosen(getattr(scenario.expect, name), ids, level_of).items() if level_of[i] > highest]
        if not above:
            continue
        shown = ", ".join(i for i, _ in above[:3]) + (f" and {len(above) - 3} more" if len(above) > 3 else "")
        levels = sorted({level_of[i] for i, _ in above})
        on = f"level {levels[0]} is" if len(levels) == 1 else f"levels {span(levels)} are"
        selectors = list(dict.fromkeys(why for i, why in above if not why.startswith("level") and why != repr(i)))
        said = shown + (f" (named by {', '.join(selectors)})" if selectors else "")
        warnings.warn(
            scenario.source.warning(
                ("expect", name),
                f"{said}: {on} above level {highest}, the highest the expected {written} can be at; building stops "
                f"once the collapse is decided, so {'it is' if len(above) == 1 else 'they are'} placed only if that "
                "takes longer than the placements after it (a slow push still under way), and a brick never placed "
                f"neither stays nor moves: in {name!r} name levels up to {highest}",
            ),
            stacklevel=3,
        )


def _statistics(expect: Expect, values: Mapping[str, float]) -> list[tuple[FieldPath, Expect | CellExpect]]:
    """The statistical expectations a grid cell of ``values`` is judged by, each with its field:
    the file's own, then each of ``expect.cells`` whose condition holds there."""
    out: list[tuple[FieldPath, Expect | CellExpect]] = [(("expect",), expect)]
    for i, cell in enumerate(expect.cells or []):
        if parse(cell.where).holds(values):
            out.append((("expect", "cells", i), cell))
    return out


def unreachable_statistics(
    scenario: Scenario, top: int | None, values: Mapping[str, float], cell: str = "", sampled: bool = True
) -> None:
    """Refuse a sweep's statistical expectation that no samples of a grid cell can pass:

    - a collapse level's mean or quantile whose region lies wholly above ``top``, the highest
      level any sample of the cell builds (a collapse level is the highest level placed when a
      brick first moves, so a mean or a quantile of it is at most ``top``, or "stands"; None:
      not known, and not judged);
    - with ``sampled`` (the samples draw: the verdict is a 95% confidence interval), P(stands)
      ``>= 1`` or ``<= 0``, or a P(stands) with no tolerance (``'0.5 ± 0'``): no finite number
      of samples gives an interval that lies at 1 (or 0), or at one value, so it is never PASS;
    - without ``sampled`` (every sample is one run), a P(stands) within a tolerance that holds
      neither 0 nor 1 (``'0.5 ± 0.2'``);
    - with ``sampled``, a P(stands) rule that even :data:`MAX_SAMPLES` samples cannot decide
      (``'>= 0.99999'``: 100000 standing give an interval reaching down to 0.99996).

    ``values``: the cell's grid values, which decide the ``expect.cells`` that apply; ``cell``:
    the cell in words (empty without a grid).

    Raises:
        ScenarioError: at the expectation's field (``expect.collapse.mean``,
            ``expect.collapse.quantile.level``, ``expect.p_stands``, or the same under
            ``expect.cells[i]``).
    """
    where = f" in grid cell {cell}" if cell else ""
    for path, expect in _statistics(scenario.expect, values):
        statistic = expect.collapse if isinstance(expect.collapse, CollapseStatistic) else None
        if statistic is not None and top is not None:
            _unreachable_level(scenario, path, statistic, top, where)
        if expect.p_stands is not None:
            _unreachable_p_stands(scenario, path, expect.p_stands, sampled, where if len(path) > 1 else "")


def _unreachable_level(scenario: Scenario, path: FieldPath, statistic: CollapseStatistic, top: int, where: str) -> None:
    """Refuse a collapse level's mean or quantile whose region lies wholly above ``top`` (the
    highest level a sample of the cell builds), at ``path`` (the expectation); ``where``: the cell
    in words."""
    region = statistic.region
    if region.target - region.tolerance <= top:
        return
    name = "mean" if statistic.mean is not None else "quantile"
    at = (*path, "collapse", "mean") if statistic.mean is not None else (*path, "collapse", "quantile", "level")
    raise scenario.source.error(
        at,
        f"{name} {region.target:g}±{region.tolerance:g} (levels {region.target - region.tolerance:g} to "
        f"{region.target + region.tolerance:g}) can never be measured{where}: the structure builds at most {top} "
        f"level{'s' * (top != 1)}, and the collapse level is the highest level placed when a brick first moves; "
        f"expect a {name} whose tolerance reaches a level from 1 to {top}",
    )


def _unreachable_p_stands(scenario: Scenario, path: FieldPath, p: Any, sampled: bool, where: str) -> None:
    """Refuse a P(stands) rule ``p`` at ``path`` that no samples can pass (:func:`unreachable_statistics`:
    a bound at 1 or 0, or no tolerance, when the samples draw; a tolerance that holds neither 0 nor 1
    when they do not; one even :data:`MAX_SAMPLES` samples cannot decide); ``where``: the cell in
    words, under ``expect.cells`` only."""
    at = (*path, "p_stands")
    if sampled and ((p.op == ">=" and p.bound >= 1) or (p.op == "<=" and p.bound <= 0)):
        every = p.op == ">="
        raise scenario.source.error(
            at,
            f"'{p.op} {p.bound:g}' can never pass{where}: the samples draw, so P(stands) is judged by its 95% "
            f"confidence interval, which reaches {'below 1' if every else 'above 0'} after any number of samples, "
            f"even when {'every' if every else 'no'} sample stood; give a bound {'below 1' if every else 'above 0'}, "
            f"such as '{p.op} {0.95 if every else 0.05:g}'",
        )
    if not sampled and p.op == "±" and p.bound - p.tolerance > 0.0 and p.bound + p.tolerance < 1.0:
        raise scenario.source.error(
            at,
            f"'{p.text()}' can never pass{where}: this sweep draws nothing, so each cell's "
            "samples are one run, and its P(stands) is 0 or 1 (it stands or not), which this holds neither of; "
            "expect '>= 0.5' (it stands) or '<= 0.5' (it falls), or draw something",
        )
    if sampled and p.op == "±" and p.tolerance == 0.0:
        raise scenario.source.error(
            at,
            f"'{p.text()}' can never pass{where}: the samples draw, so P(stands) is judged by "
            f"its 95% confidence interval, which never narrows to one value; give a tolerance, such as "
            f"'{p.bound:g} ± 0.05'",
        )
    if sampled and not _decidable(p):
        raise scenario.source.error(
            at,
            f"'{p.text()}' can never pass{where}: even {MAX_SAMPLES} samples, the most a "
            "sweep takes, give a 95% confidence interval of P(stands) wider than it allows; give it more room",
        )


def _decidable(p: Any) -> bool:
    """Whether some share of :data:`MAX_SAMPLES` samples standing gives a 95% Clopper-Pearson
    interval within what ``p`` (a ``p_stands`` rule) allows: the most samples a sweep takes,
    standing as the rule would have them at its ends and its middle (scipy's ``binomtest``).
    Asked of every grid cell a rule holds in: answered once a rule."""
    low, high = p.ends()
    return _decidable_between((low[0] if low else 0.0), (high[0] if high else 1.0))


@functools.lru_cache(maxsize=256)
def _decidable_between(lo: float, hi: float) -> bool:
    """:func:`_decidable` of the probabilities from ``lo`` to ``hi``."""
    from scipy.stats import binomtest

    if lo > hi:
        return False
    n = MAX_SAMPLES
    shares = (
        {round(lo * n), round(hi * n), round((lo + hi) / 2 * n)} | ({n} if hi >= 1.0 else set()) | ({0} if lo <= 0.0 else set())
    )
    for k in sorted(shares):
        interval = binomtest(k, n).proportion_ci(confidence_level=0.95, method="exact")
        if lo <= interval.low and interval.high <= hi:
            return True
    return False

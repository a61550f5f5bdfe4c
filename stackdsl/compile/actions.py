"""The actions of a hand and of the ground compiled to concrete motions: a pull (:class:`Remove`),
a push (:class:`Push`) and a shake (:class:`Shake`), each from its step to its end step.

Their times are read as an impact's: seconds, or ``after level N`` (one interval after that
level's last brick), and must be whole timesteps. A pull's default direction is the brick's own
length (+x), and its default distance that length plus :data:`CLEAR`; a push starts its
``gap`` before the target's surface (where the line along its direction through the point aimed
at enters the target brick, as placed: the run moves the path along the direction when the brick
has moved since, :mod:`stackdsl.runtime.actions`); a shake lasts whole periods (at least one) of
whole timesteps, its frequency fitted to them, so that the ground ends at rest where it started.
A shake may not overlap a placement or another action: while the
ground moves, the whole structure is simulated and nothing is frozen
(:mod:`stackdsl.runtime.actions`).

Source: stackdsl's own.
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Callable, Mapping, Sequence

import numpy as np
import shapely

from stability import Box, Pose

from ..engines.protocol import BrickSpec
from ..lang.errors import FieldPath, ScenarioError
from ..lang.expectations import bricks_of, levels_of, nearest, selects
from ..lang.schema import Scenario
from ..lang.schema_actions import AXES, MAX_TRAVEL, SAMPLES_A_PERIOD, Action, AfterPrevious
from ..lang.schema_actions import Push as WrittenPush
from ..lang.schema_impacts import AfterLevel
from .layouts import LaidBrick
from .overlap import touching
from .program import Kinematic, Place, Push, Remove, Shake

#: Metres a pulled brick travels beyond its own length by default: it clears what it lay between.
CLEAR = 0.010
#: Metres two pushers in the scene at once may reach into each other (contact, not overlap).
PUSHERS_APART = 0.0005
#: Metres a pusher must reach into a brick to push it (more than grazing a face it lies on).
REACHES = 1e-6

Steps = Callable[[FieldPath, float], int]
"""Seconds at a field -> whole timesteps, or a ScenarioError there (the compiler's)."""


def heading(direction: np.ndarray) -> tuple[float, float]:
    """Yaw and pitch in degrees of a box whose long axis points along unit ``direction`` (shape
    (3,)): a projectile's or a pusher's. Source: stackdsl's own.

    >>> heading(np.array([0.0, 1.0, 0.0]))
    (90.0, -0.0)
    """
    yaw = math.degrees(math.atan2(direction[1], direction[0]))
    return yaw, -math.degrees(math.asin(float(np.clip(direction[2], -1.0, 1.0))))


def compile_actions(
    scenario: Scenario,
    bricks: Sequence[LaidBrick],
    slots: np.ndarray,
    specs: dict[str, BrickSpec],
    places: Sequence[Place],
    dt: float,
    steps: Steps,
    fixtures: Sequence[str] = (),
    fixed: Sequence[LaidBrick] = (),
) -> list[Kinematic]:
    """The scenario's ``actions`` as motions, in the order written (an action that starts before
    one written above it is warned of: :func:`_in_time_order`).

    Args:
        scenario: the scenario (its actions, timing and source map).
        bricks, slots: the structure's bricks and their placement slots.
        specs: brick type -> its body.
        places: the placements (to refuse a shake while bricks are placed).
        dt: the timestep, s.
        steps: the compiler's conversion of seconds to whole timesteps.
        fixtures: the ids of the fixed bodies (a pull or a push of one is refused, saying so).
        fixed: the fixed bodies themselves (a push that drives its brick into one is refused:
            :func:`_room_ahead`).

    Raises:
        ScenarioError: at the field: a brick that is not in the structure or not placed before
            its pull or push, a brick pulled twice, pushed once its pull has started or pulled
            while a push at it lasts, a pusher's unknown brick type, a level never built, a time
            not on the timestep grid, a shake that overlaps a placement or another action, a
            pusher that would reach below the ground, that never touches what it is aimed at
            (:func:`_pushes_reach`), that would reach into another pusher, or that drives its
            brick into a fixed body with no room for it (:func:`_room_ahead`), a pull too short
            to take its brick clear of where it lay.
    """
    out: list[Kinematic] = []
    pulled: dict[str, tuple[int, float]] = {}  # brick -> the action that pulls it out, and when
    pushes = 0
    for i, action in enumerate(scenario.actions):
        path: FieldPath = ("actions", i, action.kind)
        start = _start(scenario, path, action, bricks, slots, out[-1] if out else None, dt)
        step = steps((*path, "at"), start)
        if action.remove is not None:
            _not_pulled(scenario, (*path, "brick"), action.remove.brick, pulled, "pull it out again")
            out.append(_remove(scenario, path, action, bricks, slots, specs, start, step, dt, set(pulled), fixtures))
            pulled[action.remove.brick] = (i, start)
        elif action.push is not None:
            target = action.push.target.brick
            if target is not None and start >= pulled.get(target, (0, math.inf))[1]:
                _not_pulled(scenario, (*path, "target", "brick"), target, pulled, "push it")
            pushes += 1
            out.append(_push(scenario, i, action, bricks, slots, specs, start, step, dt, fixtures, pushes))
        else:
            out.append(_shake(scenario, path, action, start, step, dt))
    for i, motion in enumerate(out):
        if isinstance(motion, Shake):
            _alone(scenario, i, motion, out, places)
    _not_pushed_while_pulled(scenario, out)
    _pushes_reach(scenario, out, bricks, slots, specs)
    _room_ahead(scenario, out, bricks, specs, fixed)
    _pushers_apart(scenario, out)
    _not_pressed_down(scenario, out, bricks, specs)
    _in_time_order(scenario, out)  # once nothing refuses the file: a refusal comes alone
    return out


def pulled_out(scenario: Scenario) -> dict[str, int]:
    """The bricks the scenario's actions pull out, each with the index of its pull. Source: stackdsl's own.

    >>> from stackdsl.lang.loader import parse_scenario
    >>> pulled_out(parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 2}}\\nactions: [{remove: {brick: L01.1, at: 3 s}}]"))
    {'L01.1': 0}
    """
    return {a.remove.brick: i for i, a in enumerate(scenario.actions) if a.remove is not None}


def check_measured(scenario: Scenario, levels: Mapping[str, int]) -> None:
    """A ScenarioError at ``expect.stays``, ``moved`` or ``may_fall`` when one of its levels or
    brick selectors names only bricks the actions pull out (``levels``: the structure's bricks,
    each with its level), and at ``toppled`` or ``stands`` when every brick is pulled out: a
    pulled brick leaves the scene, and nothing of it is measured."""
    pulled = pulled_out(scenario)
    if not pulled:
        return
    ids = list(levels)
    if ids and all(b in pulled for b in ids):  # nothing is left to judge
        _nothing_left(scenario)
    for name in ("stays", "may_fall", "moved"):
        _selection_measured(scenario, name, levels, pulled)


def warn_pushed_stands(scenario: Scenario, levels: Mapping[str, int], threshold: float) -> None:
    """Warn at ``expect.stands: true`` when a push moves a brick of the structure further than the
    collapse threshold (``threshold``, m: its distance less its gap): the pushed brick stays in
    the scene, moved, so the run is a collapse from its level and ``stands`` cannot hold (a new
    user's pushes all failed so, in every mode). What is meant is said by ``moved`` and ``stays``.
    Source: stackdsl's own."""
    if scenario.expect.stands is not True:
        return
    for a in scenario.actions:
        p = a.push
        if p is None or p.target.brick is None or p.target.brick not in levels or p.distance - p.gap <= threshold:
            continue
        warnings.warn(
            scenario.source.warning(
                ("expect", "stands"),
                f"the push moves {p.target.brick} {(p.distance - p.gap) * 1000:g} mm by hand, past the "
                f"{threshold * 1000:g} mm collapse threshold: it stays in the scene, moved, so the run collapses "
                f"from its level and 'stands' cannot hold; to judge the rest, expect moved: {p.target.brick} and "
                "stays: the levels and bricks that must not move",
            ),
            stacklevel=2,
        )
        return


def _nothing_left(scenario: Scenario) -> None:
    """Refuse ``expect.toppled`` or ``expect.stands`` when every brick of the structure is pulled
    out of the scene.

    Raises:
        ScenarioError: at the first of them the file gives.
    """
    for name in ("toppled", "stands"):
        if getattr(scenario.expect, name) is not None:
            raise scenario.source.error(
                ("expect", name),
                f"every brick of the structure is pulled out of the scene: '{name}' would judge nothing; expect "
                "something of bricks that stay in it",
            )


def _selection_measured(scenario: Scenario, name: str, levels: Mapping[str, int], pulled: dict[str, int]) -> None:
    """Refuse ``expect.<name>`` (``stays``, ``may_fall``, ``moved``) when one of its levels or brick
    selectors names only bricks the actions pull out (``pulled``: brick -> its pull's index).

    Raises:
        ScenarioError: at ``expect.<name>``, naming the level or selector and the pulls.
    """
    ids = list(levels)
    selection = getattr(scenario.expect, name) or ()
    named = [(f"level {lv} holds", [b for b in ids if levels[b] == lv]) for lv in levels_of(selection)]
    named += [(f"{s!r} names", [b for b in ids if selects(s, b)]) for s in bricks_of(selection)]
    for said, chosen in named:
        if chosen and all(b in pulled for b in chosen):
            pulls = ", ".join(dict.fromkeys(f"actions[{pulled[b]}]" for b in chosen))
            raise scenario.source.error(
                ("expect", name),
                f"{said} only {'a brick' if len(chosen) == 1 else 'bricks'} pulled out of the scene "
                f"({pulls}): nothing of {'it' if len(chosen) == 1 else 'them'} is measured; name bricks that stay in the scene",
            )


def _placed_before(scenario: Scenario, path: FieldPath, brick: str, slot: int, start: float, what: str) -> None:
    """A ScenarioError at ``path`` (an action's ``at``) when ``brick``, placed in ``slot``, is not
    placed before the ``what`` (a pull, a push) starts at ``start`` (s): a hand would reach for
    a brick not yet there (a push would move through the empty space where it is to go)."""
    placed = slot * scenario.timing.interval
    if placed >= start:
        raise scenario.source.error(path, f"{brick} is placed at {placed:g} s, not before the {what} starts at {start:g} s")


def _not_pulled(scenario: Scenario, path: FieldPath, brick: str, pulled: dict[str, tuple[int, float]], what: str) -> None:
    """A ScenarioError at ``path`` when ``brick`` has been pulled out of the scene already (by
    an earlier action of ``pulled``, brick -> (its index, its start in s))."""
    if brick in pulled:
        index, start = pulled[brick]
        raise scenario.source.error(
            path,
            f"{brick} is pulled out by actions[{index}] from {start:g} s, which takes it out of the scene: "
            f"nothing can {what} once the pull has started",
        )


def _start(
    scenario: Scenario,
    path: FieldPath,
    action: Action,
    bricks: Sequence[LaidBrick],
    slots: np.ndarray,
    previous: Kinematic | None,
    dt: float,
) -> float:
    """The action's start in seconds: its ``at`` (an impact's grammar), or one interval after
    the end of the ``previous`` action, up to the next whole timestep."""
    spec = action.remove or action.push or action.shake
    assert spec is not None, "an action is one of three"
    if isinstance(spec.at, AfterPrevious):
        if previous is None:
            raise scenario.source.error((*path, "at"), "the first action has no action before it: give a time or 'after level N'")
        return float(math.ceil((previous.end_time + scenario.timing.interval) / dt - 1e-6) * dt)
    if not isinstance(spec.at, AfterLevel):
        return float(spec.at)
    last = [int(k) for b, k in zip(bricks, slots) if b.level == spec.at.after_level]
    if not last:
        raise scenario.source.error((*path, "at"), not_built(spec.at.after_level, bricks))
    return float((last[-1] + 1) * scenario.timing.interval)


def not_built(level: int, bricks: Sequence[LaidBrick]) -> str:
    """Why ``level`` names no level of ``bricks``: how many levels the structure has, and which
    to write (a domino row, however long, is one level). Source: stackdsl's own."""
    top = max((b.level for b in bricks), default=0)
    if top == 1:
        return f"level {level} is not built: the structure has 1 level (every brick of it on level 1): write level 1"
    return f"level {level} is not built: the structure has {top} levels; name a level from 1 to {top}"


def _remove(
    scenario: Scenario,
    path: FieldPath,
    action: Action,
    bricks: Sequence[LaidBrick],
    slots: np.ndarray,
    specs: dict[str, BrickSpec],
    start: float,
    step: int,
    dt: float,
    gone: set[str],
    fixtures: Sequence[str] = (),
) -> Remove:
    """The pull of ``action`` (``gone``: the bricks pulled out before it, out of its way)."""
    r = action.remove
    assert r is not None
    found = [(b, int(k)) for b, k in zip(bricks, slots) if b.id == r.brick]
    if not found:
        raise scenario.source.error((*path, "brick"), _unknown(r.brick, bricks, fixtures, "pull"))
    brick, slot = found[0]
    _placed_before(scenario, (*path, "at"), r.brick, slot, start, "pull")
    spec = specs[brick.type]
    if r.direction is None:
        direction = brick.pose().rotation[:, 0]
    else:
        direction = np.array(AXES[r.direction] if isinstance(r.direction, str) else r.direction, dtype=float)
        direction /= np.linalg.norm(direction)
    if abs(direction[2]) > 1e-9:  # the hand drives the pulled brick's horizontal motion only
        where_z: FieldPath = (*path, "direction") if r.direction is not None else (*path, "brick")
        said = "the direction" if r.direction is not None else f"{r.brick}'s length, the default direction,"
        raise scenario.source.error(
            where_z,
            f"{said} has a vertical part ({direction[2]:+.3g}): a pull slides a brick out sideways, the hand "
            "driving it horizontally while it rests on what carries it; give a horizontal direction "
            "('+x', '-y', [1, 1, 0], ...)",
        )
    distance = r.distance if r.distance is not None else 2 * spec.half_extents[0] + CLEAR
    extent = footprint_extent(brick, spec, direction)
    if distance < extent - 1e-6:  # the hand lets go at the end: a brick still where it lay would vanish from there
        short: FieldPath = (*path, "distance") if r.distance is not None else (*path, "direction")
        raise scenario.source.error(
            short,
            f"a pull of {distance * 1000:.3g} mm leaves {r.brick} {(extent - distance) * 1000:.3g} mm short of clear of where "
            f"it lay (it spans {extent * 1000:.3g} mm along the pull), yet at the pull's end it is taken out of the scene, "
            f"from among what it lay between; give a distance of at least {math.ceil(extent * 1e4 - 1e-6) / 10:g} mm",
        )
    level = [b for b in bricks if b.level == brick.level and b.id not in gone]
    blocking = in_the_way(brick, spec, direction, distance, level, specs)
    if blocking:
        where: FieldPath = (*path, "direction") if r.direction is not None else (*path, "brick")
        warnings.warn(
            scenario.source.warning(
                where,
                f"the pull drives {r.brick} into {', '.join(blocking)} of its level, in its way; a pull along "
                f"the brick's own length (the default) slides it out between its neighbours",
            ),
            stacklevel=2,
        )
    span = max(1, math.ceil(distance / r.speed / dt - 1e-9))
    return Remove(
        step=step,
        time=start,
        id=r.brick,
        velocity=_vec(direction * r.speed),
        end_step=step + span,
        end_time=start + span * dt,
    )


def footprint_extent(brick: LaidBrick, spec: BrickSpec, direction: np.ndarray) -> float:
    """How far (m) ``brick``'s footprint (its box's corners seen from above, as
    :func:`in_the_way` sees them) reaches along horizontal unit ``direction``: the least pull
    that takes it clear of where it lay. Source: stackdsl's own.

    >>> from stackdsl.compile.compiler import _spec
    >>> from stackdsl.lang.loader import parse_scenario
    >>> kapla = _spec(parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 1}}"), "kapla")
    >>> brick = LaidBrick("b", 1, "kapla", np.array([0.0, 0.0, 0.004]), 0.0)
    >>> [round(footprint_extent(brick, kapla, np.array(d)), 4) for d in ([1.0, 0, 0], [0, -1.0, 0])]
    [0.12, 0.024]
    """
    xy = brick.corners(spec)[:, :2] @ direction[:2]
    return float(xy.max() - xy.min())


def in_the_way(
    brick: LaidBrick,
    spec: BrickSpec,
    direction: np.ndarray,
    distance: float,
    level: Sequence[LaidBrick],
    specs: dict[str, BrickSpec],
) -> list[str]:
    """The ids of the bricks of ``level`` that a pull of ``brick`` (``spec``) along unit
    ``direction`` for ``distance`` metres would drive it into: their footprints meet the area its
    own sweeps over (by more than 1 mm^2) and not its footprint where it lies. Source: stackdsl's own.

    >>> from stackdsl.compile.compiler import _spec
    >>> from stackdsl.lang.loader import parse_scenario
    >>> kapla = _spec(parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 1}}"), "kapla")
    >>> row = [LaidBrick(f"b{i}", 1, "kapla", np.array([0.0, 0.03 * i, 0.004]), 0.0) for i in range(3)]
    >>> in_the_way(row[0], kapla, np.array([0.0, 1.0, 0.0]), 0.13, row, {"kapla": kapla})
    ['b1', 'b2']
    >>> in_the_way(row[0], kapla, np.array([1.0, 0.0, 0.0]), 0.13, row, {"kapla": kapla})
    []
    """

    def corners(b: LaidBrick, s: BrickSpec) -> np.ndarray:
        xy: np.ndarray = b.corners(s)[:, :2]
        return xy

    start = corners(brick, spec)
    here = shapely.convex_hull(shapely.multipoints(start))
    swept = shapely.convex_hull(shapely.multipoints(np.vstack([start, start + direction[:2] * distance])))
    out = []
    for other in level:
        if other.id == brick.id:
            continue
        footprint = shapely.convex_hull(shapely.multipoints(corners(other, specs[other.type])))
        if footprint.intersection(swept).area > 1e-6 and footprint.intersection(here).area < 1e-6:
            out.append(other.id)
    return out


def _push(
    scenario: Scenario,
    index: int,
    action: Action,
    bricks: Sequence[LaidBrick],
    slots: np.ndarray,
    specs: dict[str, BrickSpec],
    start: float,
    step: int,
    dt: float,
    fixtures: Sequence[str] = (),
    number: int = 1,
) -> Push:
    """The push of ``action``, the ``number``-th push of the scenario (its pusher's default id
    is ``pusher<number>``)."""
    p = action.push
    assert p is not None
    path: FieldPath = ("actions", index, "push")
    direction = np.array(AXES[p.direction] if isinstance(p.direction, str) else p.direction, dtype=float)
    direction /= np.linalg.norm(direction)
    if p.target.brick is not None:
        found = [(b, int(k)) for b, k in zip(bricks, slots) if b.id == p.target.brick]
        if not found:
            raise scenario.source.error((*path, "target", "brick"), _unknown(p.target.brick, bricks, fixtures, "push"))
        brick, slot = found[0]
        _placed_before(scenario, (*path, "at"), brick.id, slot, start, "push")
        aim = brick.position + np.array(p.target.offset)
        surface = _entry(aim, direction, brick, specs[brick.type])
        target = f"{brick.id}"
    else:
        assert p.target.point is not None
        surface = np.array(p.target.point, dtype=float)
        x, y, z = (v * 1000 for v in surface)
        target = f"({x:.1f}, {y:.1f}, {z:.1f}) mm"
    try:
        spec = specs[p.pusher]
    except KeyError:
        raise scenario.source.error((*path, "pusher"), f"unknown brick type {p.pusher!r}") from None
    position = surface - direction * (p.gap + spec.half_extents[0])
    span = max(1, math.ceil(p.distance / p.speed / dt - 1e-9))
    yaw, pitch = heading(direction)
    _above_ground(scenario, path, position, direction, spec, yaw, pitch, p.speed * dt, span)
    return Push(
        step=step,
        time=start,
        id=p.id or f"pusher{number}",
        brick=spec,
        position=_vec(position),
        yaw=yaw,
        pitch=pitch,
        velocity=_vec(direction * p.speed),
        target=target,
        end_step=step + span,
        end_time=start + span * dt,
    )


def _written(scenario: Scenario, path: FieldPath, *names: str) -> FieldPath:
    """The first of ``path``'s fields ``names`` the scenario writes out, else the last of them."""
    return next(((*path, n) for n in names if (*path, n) in scenario.source.values), (*path, names[-1]))


def _mm(metres: float) -> str:
    """Metres as millimetres to 0.01 mm, as people write them.

    >>> _mm(10.0), _mm(0.0049999999), _mm(0.035001), _mm(0.12345)
    ('10000', '5', '35', '123.45')
    """
    return f"{round(metres * 1000, 2) + 0.0:g}"


def _first_touch(push: Push, direction: np.ndarray, bricks: Sequence[LaidBrick], specs: dict[str, BrickSpec]) -> np.ndarray:
    """How far (m) ``push``'s pusher moves along unit ``direction`` from where it starts before it
    reaches into each of ``bricks`` by :data:`REACHES` (``inf``: never; a pusher that only slides
    along a face it lies on never does), shape (len(bricks),)."""
    if not bricks:
        return np.zeros(0)
    pose = Pose.from_euler(push.position, push.yaw, push.pitch, 0.0)
    poses = [b.pose() for b in bricks]
    first, _ = touching(
        pose.position,
        pose.rotation,
        np.array(push.brick.half_extents),
        np.array([q.position for q in poses]),
        np.array([q.rotation for q in poses]),
        np.array([specs[b.type].half_extents for b in bricks]),
        direction,
        deeper=REACHES,
    )
    return first


def _pushes_reach(
    scenario: Scenario, motions: Sequence[Kinematic], bricks: Sequence[LaidBrick], slots: np.ndarray, specs: dict[str, BrickSpec]
) -> None:
    """Refuse a push that can never touch what it is aimed at: its pusher, moving ``distance``
    along its direction from where it starts, must touch its target brick (the boxes'
    separating-axis test, :func:`~stackdsl.compile.overlap.touching`), or, aimed at a point, a
    brick in the scene when it starts (placed before, not pulled out by then).

    Raises:
        ScenarioError: at the push's ``distance`` (else its ``gap``, else its ``target``) saying
            how far short the pusher stops; at its ``at`` when only bricks placed after it starts
            lie on its path; at its target when its path passes beside the brick it names, or
            meets no brick at all.

    Source: stackdsl's own.
    """
    interval = scenario.timing.interval
    gone = {m.id: m.end_step for m in motions if isinstance(m, Remove)}
    for i, push in enumerate(motions):
        if not isinstance(push, Push):
            continue
        p = scenario.actions[i].push
        assert p is not None
        path: FieldPath = ("actions", i, "push")
        direction = np.array(push.velocity) / np.linalg.norm(push.velocity)
        aimed = [b for b in bricks if p.target.brick in (None, b.id)]
        placed = [int(k) * interval < push.time for b, k in zip(bricks, slots) if p.target.brick in (None, b.id)]
        present = [b for b, there in zip(aimed, placed) if there and gone.get(b.id, push.step + 1) > push.step]
        first = _first_touch(push, direction, present, specs)
        if len(first) and np.isfinite(first.min()):
            _far_enough(scenario, path, p, present, first)
            continue
        later = [b for b, there in zip(aimed, placed) if not there]
        _placed_in_time(scenario, path, push, direction, later, bricks, slots, specs)
        named = aimed[0].corners(specs[aimed[0].type]) if p.target.brick is not None and aimed else None
        raise _misses(scenario, path, push, p, named)


def _far_enough(scenario: Scenario, path: FieldPath, p: WrittenPush, present: list[LaidBrick], first: np.ndarray) -> None:
    """Refuse a push (``p``, at ``path``) whose pusher stops before the nearest brick it meets
    (of ``present``, each first touched after ``first`` m along its direction).

    Raises:
        ScenarioError: at the push's ``distance`` (else its ``gap``, else its ``target``).
    """
    nearest = int(np.argmin(first))
    reach = float(first[nearest])
    if reach < p.distance - 1e-6:
        return
    named = present[nearest].id
    said = (
        f"reaches {named} only at the end of its travel, and pushes nothing"
        if reach - p.distance < 5e-7
        else f"stops {_mm(reach - p.distance)} mm short of {named}"
    )
    # a distance past what a hand may travel is no fix: the gap is (a new user's 'gap: 10 m' was
    # told to give a distance of more than 10000 mm, then refused it)
    fix = f"a distance of more than {_mm(reach)} mm, or a smaller gap" if reach < MAX_TRAVEL else "a smaller gap"
    if reach >= MAX_TRAVEL:
        fix += f" (a pusher moves at most {MAX_TRAVEL * 1000:g} mm)"
    raise scenario.source.error(
        _written(scenario, path, "distance", "gap", "target"),
        f"the pusher {said}: it starts {_mm(reach)} mm from {named} along its direction and moves "
        f"{_mm(p.distance)} mm; give {fix}",
    )


def _placed_in_time(
    scenario: Scenario,
    path: FieldPath,
    push: Push,
    direction: np.ndarray,
    later: list[LaidBrick],
    bricks: Sequence[LaidBrick],
    slots: np.ndarray,
    specs: dict[str, BrickSpec],
) -> None:
    """Refuse a push (at ``path``) whose pusher's path meets only bricks placed after it starts
    (``later``; ``bricks`` with their ``slots`` tell when each is placed).

    Raises:
        ScenarioError: at the push's ``at``, naming the first brick met and when it is placed.
    """
    interval = scenario.timing.interval
    met = [(float(t), b) for t, b in zip(_first_touch(push, direction, later, specs), later) if np.isfinite(t)]
    if met:
        _, brick = min(met, key=lambda m: m[0])
        when = next(int(k) * interval for b, k in zip(bricks, slots) if b is brick)
        raise scenario.source.error(
            (*path, "at"),
            f"the pusher's path meets only bricks placed after the push starts at {push.time:g} s ({brick.id} at "
            f"{when:g} s): it would move through empty space; start it once they are placed ('after level N')",
        )


def _misses(scenario: Scenario, path: FieldPath, push: Push, p: WrittenPush, target: np.ndarray | None) -> ScenarioError:
    """The error for a push (``p``, at ``path``) whose pusher's path meets no brick: at its
    ``direction`` when it is aimed at a brick's centre, else at its target's point or offset.
    ``target``: the corners of the brick it names (shape (8, 3), m), when it names one: the
    path passes above it, below it (every height it sweeps, from start to end), or beside it."""
    where: FieldPath = (*path, "target", "point") if p.target.point is not None else (*path, "target", "offset")
    if p.target.brick is not None and p.target.offset == (0.0, 0.0, 0.0):
        where = (*path, "direction")
    x, y, z = (v * 1000 for v in push.position)
    side = "beside"
    if target is not None:  # the heights the pusher's box sweeps over its whole path, against the brick's
        start = _pusher_corners(push, np.asarray(push.position, dtype=float))
        travel = np.asarray(push.velocity, dtype=float) * (push.end_time - push.time)
        low, high = min(start[:, 2].min(), start[:, 2].min() + travel[2]), max(start[:, 2].max(), start[:, 2].max() + travel[2])
        bottom, top = float(target[:, 2].min()), float(target[:, 2].max())
        side = "above" if low >= top - 1e-9 else "below" if high <= bottom + 1e-9 else side
    return scenario.source.error(
        where,
        f"the pusher's path, from ({x:.1f}, {y:.1f}, {z:.1f}) mm along the direction, "
        + (
            f"passes {side} {p.target.brick}: it never touches it; aim at a point of the brick (an offset within it)"
            if p.target.brick is not None
            else "meets no brick in the scene when it starts: aim it at a brick (target: {brick: ID, offset: [...]})"
        ),
    )


#: Metres a push may press its brick into a fixed body before it is refused: pybullet's
#: collision margin, within which the engines' contacts settle such a touch alike.
PRESSED = 0.001


def _room_ahead(
    scenario: Scenario,
    motions: Sequence[Kinematic],
    bricks: Sequence[LaidBrick],
    specs: dict[str, BrickSpec],
    fixed: Sequence[LaidBrick],
) -> None:
    """Refuse a push that drives its brick into a fixed body with no room for it: the brick,
    carried along the push's direction for as far as the pusher moves once it has touched it,
    would press into an immovable body (a wall, a post) by more than :data:`PRESSED`. What then
    happens is no physics two engines agree on (measured, a brick pushed 20 mm against a post
    2 mm ahead: pybullet's extension pushed it through the post, raw and tuned pybullet lifted it
    15 mm, MuJoCo threw it 105 mm back), so no verdict on it can be trusted.

    Raises:
        ScenarioError: at the push's ``distance``, with the room there is and the largest
            distance that leaves it.

    Source: stackdsl's own.
    """
    if not fixed:
        return
    boxes = [(f, specs[f.type]) for f in fixed]
    for i, push in enumerate(motions):
        p = scenario.actions[i].push
        if not isinstance(push, Push) or p is None or p.target.brick is None:
            continue
        brick = next((b for b in bricks if b.id == p.target.brick), None)
        if brick is not None:
            _room_for(scenario, i, push, p, brick, boxes, specs)


def _room_for(
    scenario: Scenario,
    i: int,
    push: Push,
    p: WrittenPush,
    brick: LaidBrick,
    boxes: list[tuple[LaidBrick, BrickSpec]],
    specs: dict[str, BrickSpec],
) -> None:
    """Refuse push ``i`` (``p`` as written) when the pusher carries its target ``brick`` along its
    direction into one of the fixed bodies (``boxes``, each with its body) by more than
    :data:`PRESSED` (see :func:`_room_ahead`).

    Raises:
        ScenarioError: at the push's ``distance``.
    """
    direction = np.array(push.velocity) / np.linalg.norm(push.velocity)
    reach = _first_touch(push, direction, [brick], specs)
    carried = p.distance - float(reach[0]) if len(reach) and np.isfinite(reach[0]) else 0.0
    if carried <= PRESSED:
        return
    pose = brick.pose()
    poses = [f.pose() for f, _ in boxes]
    room, _ = touching(
        pose.position,
        pose.rotation,
        np.array(specs[brick.type].half_extents),
        np.array([q.position for q in poses]),
        np.array([q.rotation for q in poses]),
        np.array([s.half_extents for _, s in boxes]),
        direction,
    )
    if not len(room) or not np.isfinite(room.min()) or carried - float(room.min()) <= PRESSED:
        return
    k = int(np.argmin(room))
    ahead = max(0.0, float(room[k]))
    raise scenario.source.error(
        _written(scenario, ("actions", i, "push"), "distance"),
        f"the push drives {brick.id} {_mm(carried - ahead)} mm into the fixed body {boxes[k][0].id}: it has "
        f"{_mm(ahead)} mm of room ahead and the pusher carries it {_mm(carried)} mm; the engines do not agree on a "
        "brick pressed into an immovable body (one pushes it through, one lifts it, one throws it back), so no "
        f"verdict on it holds: give a distance of at most {_mm(p.distance - carried + ahead)} mm, or move "
        f"{boxes[k][0].id}",
    )


def _pusher_corners(push: Push, position: np.ndarray) -> np.ndarray:
    """The eight corners (shape (8, 3), m) of ``push``'s pusher with its centre at ``position`` (m)."""
    corners: np.ndarray = Box(np.array(push.brick.half_extents), push.brick.mass).corners(
        Pose.from_euler(position, push.yaw, push.pitch)
    )
    return corners


#: The steepest a push may point down (the sine of 30 deg below the horizontal) before it is asked
#: whether it presses its brick into what carries it (:func:`_not_pressed_down`).
DOWNWARD = -0.5


def _not_pressed_down(
    scenario: Scenario, motions: Sequence[Kinematic], bricks: Sequence[LaidBrick], specs: dict[str, BrickSpec]
) -> None:
    """Refuse a push that points more than 30 deg down and, where its pusher meets its target, drives
    the target by more than :data:`PRESSED` into what carries it there: the bricks under it (their
    tops within 1 mm of its bottom) or the ground. A pusher on a path is never pushed back, so the
    engines have it go through what carries the brick (a new user's finger pressed 60 mm down on the
    top of a 6-level Jenga tower: MuJoCo passed it through four levels, nothing moving; pybullet
    threw the four levels up 30 mm), and the verdicts disagree. Pressed where nothing carries it
    (a free end over an edge), a brick turns away from the pusher, and the push is taken.

    Raises:
        ScenarioError: at the push's ``direction``.

    Source: stackdsl's own.
    """
    for i, push in enumerate(motions):
        p = scenario.actions[i].push
        if not isinstance(push, Push) or p is None or p.target.brick is None:
            continue
        direction = np.array(push.velocity) / np.linalg.norm(push.velocity)
        brick = next((b for b in bricks if b.id == p.target.brick), None)
        if brick is None or direction[2] > DOWNWARD:
            continue
        reach = _first_touch(push, direction, [brick], specs)
        if not len(reach) or not np.isfinite(reach[0]) or p.distance - float(reach[0]) <= PRESSED:
            continue
        pusher = _pusher_corners(push, np.array(push.position) + direction * float(reach[0]))
        target = brick.corners(specs[brick.type])
        shape = shapely.convex_hull(shapely.multipoints(target[:, :2]))
        met = shape.intersection(shapely.convex_hull(shapely.multipoints(pusher[:, :2])))
        where = met.centroid if not met.is_empty else shapely.Point(*pusher[:, :2].mean(axis=0))
        bottom = float(target[:, 2].min())
        carriers: list[str] = []
        pieces = [shape] if bottom <= 1e-3 else []  # on the ground: it carries all of it
        for other in bricks:
            if other.id == brick.id:
                continue
            corners = other.corners(specs[other.type])
            if abs(float(corners[:, 2].max()) - bottom) > 1e-3:
                continue
            under = shape.intersection(shapely.convex_hull(shapely.multipoints(corners[:, :2])))
            if not under.is_empty and under.area > 0.0:
                pieces.append(under)
                carriers.append(other.id)
        if pieces and shapely.convex_hull(shapely.union_all(pieces)).covers(where):
            said = ", ".join(carriers) if carriers else "the ground"
            raise scenario.source.error(
                _written(scenario, ("actions", i, "push"), "direction"),
                f"the push presses {brick.id} down ({direction[2]:+.3g} of its direction) onto what carries it where the "
                f"pusher meets it ({said}): a pusher on a path is never pushed back, so it would be driven through "
                "them, and the engines disagree on what follows (MuJoCo passes it through, pybullet throws the bricks "
                "up); press where nothing carries the brick (a free end over an edge, which turns), or push sideways",
            )


def _in_time_order(scenario: Scenario, motions: Sequence[Kinematic]) -> None:
    """Warn of an action that starts before one written above it: actions run by their times,
    not in the order written. A new user's pull at 12 s, written after one 'after level 10' (15 s,
    one brick every 0.5 s), ran first, while level 9 was being placed, and nothing said so. A
    warning, not a refusal: a file may list its actions in any order on purpose."""
    for i in range(1, len(motions)):
        first = max(range(i), key=lambda j: motions[j].time)  # the latest start written above it
        if motions[i].time < motions[first].time - 1e-9:
            action = scenario.actions[i]
            warnings.warn(
                scenario.source.warning(
                    ("actions", i, action.kind, "at"),
                    f"starts at {motions[i].time:g} s, before actions[{first}] ({motions[first].time:g} s), which is "
                    "written above it: actions run in the order of their times, not in the order written",
                ),
                stacklevel=3,
            )


def warn_during_build(
    scenario: Scenario, motions: Sequence[Kinematic], places: Sequence[Place], bricks: Sequence[LaidBrick]
) -> None:
    """Warn of a pull or a push given a time (not 'after level N') that starts while bricks are
    still to be placed: they land on what it moves. A new user pulled a pier's brick at 10 s, in
    a bridge built until 12.5 s: the deck was placed on the falling pier, and only the compiled
    timeline showed it. A warning, not a refusal: a hand may act on a structure half built.
    Source: stackdsl's own."""
    top = max((b.level for b in bricks), default=0)
    for i, motion in enumerate(motions):
        action = scenario.actions[i]
        spec = action.remove or action.push
        if spec is None or isinstance(spec.at, (AfterLevel, AfterPrevious)):
            continue
        later = [p for p in places if p.step > motion.step]
        if later:
            warnings.warn(
                scenario.source.warning(
                    ("actions", i, action.kind, "at"),
                    f"starts at {motion.time:g} s, while bricks are still placed (the last, {later[-1].id}, at "
                    f"{later[-1].time:g} s): they land on what it moves; to act on the built structure, write "
                    f"'after level {top}'",
                ),
                stacklevel=3,
            )


def _not_pushed_while_pulled(scenario: Scenario, motions: Sequence[Kinematic]) -> None:
    """Refuse a push at a brick once its pull has started, in whatever order the two are written
    (the same step included), and a pull that starts while a push at its brick lasts: a brick in
    the hand is not pushed, and a pushed brick is not taken by the hand. A ScenarioError at the
    push's ``target.brick``, or at the pull's ``at``."""
    pulls = {m.id: (j, m) for j, m in enumerate(motions) if isinstance(m, Remove)}
    for i, push in enumerate(motions):
        p = scenario.actions[i].push
        if not isinstance(push, Push) or p is None or p.target.brick not in pulls:
            continue
        j, pull = pulls[p.target.brick]
        if push.step >= pull.step:
            _not_pulled(scenario, ("actions", i, "push", "target", "brick"), pull.id, {pull.id: (j, pull.time)}, "push it")
        if push.end_step > pull.step:
            raise scenario.source.error(
                ("actions", j, "remove", "at"),
                f"{pull.id} is pushed by actions[{i}] ({push.id}) from {push.time:g} to {push.end_time:g} s: the hand cannot "
                f"pull it out at {pull.time:g} s while the push lasts; start the pull once the push is over",
            )


def _pushers_apart(scenario: Scenario, motions: Sequence[Kinematic]) -> None:
    """Refuse two pushers that would be in one place at once: while both are in the scene (each
    from its push's start to its end), the later written must not reach into the earlier by more
    than :data:`PUSHERS_APART` (their boxes' separating-axis test as they
    move, :func:`~stackdsl.compile.overlap.touching`). Kinematic pushers do not stop each other:
    one inside the other would run as one body, twice. Nor may two push one brick at once: a new
    user's two pushers, aimed at either end of a brick, each drove 30 mm into it and squeezed it
    50 mm (pybullet threw it; MuJoCo passed them through it). A ScenarioError at the later one's
    ``target``."""
    pushes = [(i, m) for i, m in enumerate(motions) if isinstance(m, Push)]
    for (i, a), (j, b) in itertools.combinations(pushes, 2):
        start, end = max(a.step, b.step), min(a.end_step, b.end_step)
        if start > end:
            continue
        t0 = max(a.time, b.time)
        where_a = np.array(a.position) + np.array(a.velocity) * (t0 - a.time)
        where_b = np.array(b.position) + np.array(b.velocity) * (t0 - b.time)
        pose_a = Pose.from_euler(where_a, a.yaw, a.pitch, 0.0)
        pose_b = Pose.from_euler(where_b, b.yaw, b.pitch, 0.0)
        first, _ = touching(
            pose_b.position,
            pose_b.rotation,
            np.array(b.brick.half_extents),
            pose_a.position[None],
            pose_a.rotation[None],
            np.array(a.brick.half_extents)[None],
            np.array(b.velocity) - np.array(a.velocity),
            deeper=PUSHERS_APART,
        )
        duration = min(a.end_time, b.end_time) - t0
        if first[0] <= duration + 1e-12:
            raise scenario.source.error(
                ("actions", j, "push", "target"),
                f"this push's pusher ({b.id}) would reach into actions[{i}]'s ({a.id}) at {t0 + float(first[0]):.4g} s, "
                "while both are in the scene: two pushers cannot be in one place at once; aim them apart, or start this "
                f"one after {a.end_time:g} s",
            )
        earlier, later = scenario.actions[i].push, scenario.actions[j].push
        if earlier and later and (brick := later.target.brick) is not None and brick == earlier.target.brick:
            raise scenario.source.error(
                ("actions", j, "push", "target", "brick"),
                f"{brick} is pushed by actions[{i}] too, from {a.time:g} to {a.end_time:g} s: one push at a brick at a "
                f"time (two pushers pressing it at once would squeeze it); start this one after {a.end_time:g} s "
                "('after the previous action')",
            )


def _above_ground(
    scenario: Scenario,
    path: FieldPath,
    position: np.ndarray,
    direction: np.ndarray,
    spec: BrickSpec,
    yaw: float,
    pitch: float,
    step: float,
    span: int,
) -> None:
    """Refuse a pusher (``spec``'s box turned by ``yaw`` and ``pitch``, degrees, its centre at
    ``position``, m) whose box reaches below the ground (z < 0, by more than 1 micrometre) where it
    starts or anywhere along its travel: ``span`` steps of ``step`` metres along unit ``direction``.
    A kinematic pusher is not stopped by the ground: driven down, it would go through the bricks
    and the ground alike and throw them about. A ScenarioError at the push's ``offset`` or
    ``point`` when it starts below, else at its ``distance`` (when written) or ``direction``,
    saying how far below and the longest distance that stays above. Source: stackdsl's own."""
    corners = Box(np.array(spec.half_extents), spec.mass).corners(Pose.from_euler(position, yaw, pitch))
    low = float(corners[:, 2].min())  # the box's lowest point where the pusher starts, m
    if low < -1e-6:
        p = scenario.actions[path[1]].push if isinstance(path[1], int) else None
        aimed = "point" if p is not None and p.target.point is not None else "offset"
        raise scenario.source.error(
            (*path, "target", aimed),
            f"the pusher would start {-low * 1000:.3g} mm below the ground (its box reaches z = {low * 1000:.3g} mm): "
            "a pusher moves through the ground, not on it; aim higher, or give a smaller pusher",
        )
    end = low + direction[2] * step * span
    if end >= -1e-6:
        return
    whole = math.floor(low / (-direction[2] * step) + 1e-9)  # steps that keep it above the ground
    allowed = math.floor(whole * step * 1e4) / 10  # mm, down to 0.1 mm: its whole steps stay within them
    where: FieldPath = (*path, "distance") if (*path, "distance") in scenario.source.values else (*path, "direction")
    raise scenario.source.error(
        where,
        f"the pusher would end {-end * 1000:.3g} mm below the ground (the direction goes down, {direction[2]:+.3g} of it "
        f"vertical, and the pusher's lowest point from z = {low * 1000:.3g} mm to {end * 1000:.3g} mm): a pusher moves through the "
        f"ground, not on it, and would drive the bricks into it; give a distance of at most {allowed:g} mm (it moves "
        f"in whole steps of {step * 1000:.3g} mm at this speed), or a direction that goes less steeply down",
    )


def _unknown(name: str, bricks: Sequence[LaidBrick], fixtures: Sequence[str], verb: str) -> str:
    """Why no brick of the structure is ``name``: a fixture (fixed: a hand cannot ``verb`` it), the
    start of several ids (a level 'L05', a part 'left', which name bricks in an expectation but
    not the one brick a hand takes), or none at all; with the structure's first bricks, and a
    hint that is a brick's id: a start of ids offered as 'did you mean' was refused again."""
    ids = [b.id for b in bricks]
    listed = ", ".join(ids[:3]) + (", ..." if len(ids) > 3 else "")
    if name in fixtures:
        return f"{name!r} is fixed (a fixture): a hand does not {verb} it; the structure's bricks: {listed}"
    named = [i for i in ids if selects(name, i)]
    if len(named) > 1:
        return f"{name!r} names {_span(named)}, not one: give the id of the one brick to {verb}, such as {named[0]!r}"
    near = named[0] if named else nearest(name, ids)
    if near is None:
        hint = ""
    elif near in ids:
        hint = f"; did you mean {near!r}?"
    else:
        hint = f"; did you mean a brick of {near!r} ({_span([i for i in ids if selects(near, i)])})?"
    return f"no brick of the structure is {name!r} (its bricks: {listed}){hint}"


def _span(ids: Sequence[str]) -> str:
    """``L05.1 to L05.3``, or the one id."""
    return ids[0] if len(ids) == 1 else f"the bricks {ids[0]} to {ids[-1]}"


def _vec(v: np.ndarray) -> tuple[float, float, float]:
    x, y, z = (float(c) for c in v)
    return x, y, z


def _entry(aim: np.ndarray, direction: np.ndarray, brick: LaidBrick, spec: BrickSpec) -> np.ndarray:
    """Where the line along ``direction`` through ``aim`` enters ``brick`` (its box, m), coming
    from behind; ``aim`` itself when it lies outside the box."""
    pose = brick.pose()
    rotation = pose.rotation
    local, d = rotation.T @ (aim - pose.position), rotation.T @ direction
    half = np.array(spec.half_extents)
    if np.any(np.abs(local) > half):
        return aim
    back = [
        ((local[i] + half[i]) / d[i]) if d[i] > 1e-12 else ((half[i] - local[i]) / -d[i]) for i in range(3) if abs(d[i]) > 1e-12
    ]
    return np.asarray(aim - direction * min(back))


def _shake(scenario: Scenario, path: FieldPath, action: Action, start: float, step: int, dt: float) -> Shake:
    """The shake of ``action`` from ``start`` (s, its ``step``) in steps of ``dt`` (s); a
    ScenarioError at its ``frequency`` when a step that long samples a period fewer than
    :data:`SAMPLES_A_PERIOD` times (the run's own timestep, not the default's)."""
    s = action.shake
    assert s is not None
    if s.frequency * dt * SAMPLES_A_PERIOD > 1 + 1e-9:
        highest = 1 / (SAMPLES_A_PERIOD * dt)
        raise scenario.source.error(
            (*path, "frequency"),
            f"expected a frequency from 0.1 to {highest:.4g} Hz at this run's timestep, got {s.frequency:g} Hz; faster, a "
            f"step of {step_text(dt)} samples a period {1 / (s.frequency * dt):.3g} times, fewer than {SAMPLES_A_PERIOD}: "
            f"give a lower frequency or a shorter engine.timestep (at most {1 / (SAMPLES_A_PERIOD * s.frequency) * 1000:.4g} ms)",
        )
    periods = max(1, s.whole_periods())
    span = max(1, round(periods / s.frequency / dt))
    # whole periods in whole steps: the frequency is fitted to them, so that the ground ends at rest
    # (the motion's offset and speed are 0 at its last step); at least as many steps a period as before
    fitted = periods / (span * dt)
    exact = abs(fitted - s.frequency) <= 1e-9 * s.frequency
    d = np.array(s.direction, dtype=float)
    d /= np.linalg.norm(d)
    return Shake(
        step=step,
        time=start,
        amplitude=s.amplitude,
        frequency=s.frequency if exact else fitted,
        written_frequency=None if exact else s.frequency,
        periods=periods,
        direction=(float(d[0]), float(d[1])),
        end_step=step + span,
        end_time=start + span * dt,
    )


def step_text(dt: float) -> str:
    """A timestep ``dt`` (s) as people write it: ``'1/240 s'``, ``'1 ms'``, ``'0.25 ms'``.
    Source: stackdsl's own.

    >>> step_text(1 / 240), step_text(0.001), step_text(0.00025)
    ('1/240 s', '1 ms', '0.25 ms')
    """
    ms = dt * 1000
    if abs(ms - round(ms, 4)) <= 1e-9 * ms:
        return f"{round(ms, 4):g} ms"
    per = 1 / dt
    if abs(per - round(per)) <= 1e-6 * per:
        return f"1/{round(per)} s"
    return f"{ms:.4g} ms"


def _alone(scenario: Scenario, index: int, shake: Shake, motions: Sequence[Kinematic], places: Sequence[Place]) -> None:
    """Refuse a shake that overlaps a placement or another action (at its ``at``)."""
    path: FieldPath = ("actions", index, "shake", "at")
    during = [p for p in places if shake.step <= p.step <= shake.end_step]
    if during:
        raise scenario.source.error(
            path,
            f"{during[0].id} is placed at {during[0].time:g} s, while the ground shakes ({shake.time:g} to "
            f"{shake.end_time:g} s): start the shake after the last placement ('after level N')",
        )
    for j, other in enumerate(motions):
        if other is not shake and other.step <= shake.end_step and shake.step <= other.end_step:
            raise scenario.source.error(
                path,
                f"actions[{j}] ({other.kind}, {other.time:g} to {other.end_time:g} s) overlaps this shake "
                f"({shake.time:g} to {shake.end_time:g} s): one at a time while the ground moves",
            )

"""A projectile or a pusher must start clear: above the ground and outside every body in the world.

The compiler puts a projectile ``distance`` before its target point, lifted by its fall.
A projectile too big for the scene, a direction that starts it under the ground or inside
the structure, or a target point below the ground would start it inside something; the
engine then pushes it out at once, and the run measures that, not an impact. Such an
impact is refused at the field to change.

Source: stackdsl's own.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from stability import Box, Pose

from ..engines.protocol import BrickSpec
from ..lang.errors import FieldPath
from ..lang.schema import Scenario
from ..lang.schema_impacts import Impact
from .overlap import penetration
from .program import Launch, Push

#: Metres a projectile may reach into the ground or a body at its start (contact, not overlap).
TOLERANCE = 0.0005
#: Metres between the poses at which a pusher's path through its target's place is looked at.
PATH_STEP = 0.001


def check_launch(
    scenario: Scenario, index: int, impact: Impact, launch: Launch, bodies: Sequence[tuple[str, BrickSpec, Pose]]
) -> None:
    """Refuse a projectile that starts below the ground or inside a body.

    Args:
        scenario: for its source map.
        index: the impact's index in ``impacts``.
        impact: the impact as written; launch: as compiled.
        bodies: (id, spec, pose) of every brick and fixture in the world at launch time.

    Raises:
        ScenarioError: at ``impacts[index]``'s ``target.point``, ``direction`` or
            ``projectile``, whichever the scenario gave (in that order of blame).
    """
    box = Box(np.array(launch.brick.half_extents), launch.brick.mass)
    pose = Pose.from_euler(launch.position, launch.yaw, launch.pitch, 0.0)
    lowest = float(box.corners(pose)[:, 2].min())
    if lowest < -TOLERANCE:
        raise scenario.source.error(_blame(impact, index), f"the projectile would start {-lowest * 1000:.1f} mm below the ground")
    inside = deepest(box, pose, bodies)
    if inside is not None:
        raise scenario.source.error(
            _blame(impact, index),
            f"the projectile would start {inside[1] * 1000:.1f} mm inside brick {inside[0]!r}; aim it from outside the structure",
        )


def check_pusher(scenario: Scenario, index: int, push: Push, bodies: Sequence[tuple[str, BrickSpec, Pose]]) -> None:
    """Refuse a pusher that enters inside a body: its box is put ``gap`` before the point it
    aims at, along its direction, and a long pusher (a whole brick, by default) reaches back into
    the bricks before its target (a new user's pusher aimed at the tenth domino started inside
    the eighth and ninth, which it woke by 'touching').

    Args:
        index: the action's index in ``actions``; push: as compiled.
        bodies: (id, spec, pose) of every brick and fixture in the world when the pusher enters.

    Raises:
        ScenarioError: at ``actions[index].push.pusher`` when the scenario names the pusher's
            brick type, else at the push.
    """
    box = Box(np.array(push.brick.half_extents), push.brick.mass)
    pose = Pose.from_euler(push.position, push.yaw, push.pitch, 0.0)
    inside = deepest(box, pose, bodies)
    if inside is None:
        return
    path = _pusher_field(scenario, index)
    hx, hy, hz = push.brick.half_extents
    face = Box(np.array([TOLERANCE, hy, hz]), push.brick.mass)  # its front face alone, as thin as the tolerance
    front = Pose(pose.position + pose.rotation[:, 0] * (hx - TOLERANCE), pose.orientation)
    across = f"the pusher ({push.brick.type}, {2 * hy * 1000:.0f} x {2 * hz * 1000:.0f} mm across its direction) would start"
    reaches = deepest(face, front, bodies) is not None  # its cross-section reaches in, not its length
    if reaches and inside[0] == push.target:  # its corner, into the brick it aims at
        raise scenario.source.error(path, f"{across} {_slanted(scenario, index, push, box, pose, inside[1], bodies)}")
    if reaches:  # beside the point it is aimed at
        raise scenario.source.error(
            path,
            f"{across} {inside[1] * 1000:.1f} mm inside brick {inside[0]!r} beside the point it is aimed at; aim it so that its "
            "face meets the target alone (an offset nearer the target's middle), or give a thinner pusher "
            f"(a brick type of brick_types){_slant(push, bodies)}{_across(push, bodies)}",
        )
    raise scenario.source.error(
        path,
        f"the pusher ({push.brick.type}, {2 * hx * 1000:.0f} mm long along its direction) would start {inside[1] * 1000:.1f} "
        f"mm inside brick {inside[0]!r}; give a shorter pusher (a brick type of brick_types) or aim it from outside the "
        "structure",
    )


def _slanted(
    scenario: Scenario, index: int, push: Push, box: Box, pose: Pose, depth: float, bodies: Sequence[tuple[str, BrickSpec, Pose]]
) -> str:
    """The words after "the pusher ... would start" for a pusher whose front reaches into the
    very brick it is aimed at: its direction meets that brick's face at a slant, so a corner of
    its face is there before the point aimed at (a new user's push at 30 deg to a brick's width,
    told to aim nearer the middle it was aimed at). The gap that starts it clear is found by backing it off along its direction,
    :data:`PATH_STEP` at a time (at most 10 times the pusher's length); the words say that gap."""
    action = scenario.actions[index].push
    gap = action.gap if action is not None else 0.0
    speed = float(np.linalg.norm(push.velocity))
    back = -np.asarray(push.velocity, dtype=float) / speed if speed > 0.0 else -pose.rotation[:, 0]
    hx = push.brick.half_extents[0]
    needed = next(
        (
            gap + k * PATH_STEP
            for k in range(1, int(20 * hx / PATH_STEP) + 1)
            if deepest(box, Pose(pose.position + back * k * PATH_STEP, pose.orientation), bodies) is None
        ),
        None,
    )
    more = f"a gap of at least {needed * 1000:.1f} mm (it is {gap * 1000:g} mm), " if needed is not None else ""
    return (
        f"{depth * 1000:.1f} mm inside {push.target!r}, the brick it is aimed at: its direction meets that brick's face at a "
        f"slant, so a corner of the pusher's face reaches the brick before the point aimed at; give {more}a pusher narrower "
        "across its direction (a brick type of brick_types), or a direction square to the face"
    )


def _slant(push: Push, bodies: Sequence[tuple[str, BrickSpec, Pose]]) -> str:
    """Words for a push whose direction is more than a degree from square to the face of its
    target brick it meets, which swings the pusher's side towards the bricks beside (a new
    user's finger aimed at a Jenga block's middle at 20 deg, told to aim nearer the middle): ""
    when the target is a point, or the push is square."""
    found = next(((spec, pose) for name, spec, pose in bodies if name == push.target), None)
    speed = float(np.linalg.norm(push.velocity))
    if found is None or speed == 0.0:
        return ""
    heading = np.asarray(push.velocity, dtype=float) / speed
    square = float(np.max(np.abs(found[1].rotation.T @ heading)))  # the cosine to the nearest face's normal
    off = float(np.degrees(np.arccos(min(1.0, square))))
    if off <= 1.0:
        return ""
    return f"; its direction is {off:.0f} deg from square to the face of {push.target!r} it meets: a square one keeps it there"


def _across(push: Push, bodies: Sequence[tuple[str, BrickSpec, Pose]]) -> str:
    """Words for a push that runs across its target brick's length, which a pusher meant to
    slide the brick out along its level meets side-on with its neighbours beside it (a new user's
    ``+x`` into a block of a level that lies along y): "" when the target is a point, or the push
    runs along the brick's length."""
    found = next(((spec, pose) for name, spec, pose in bodies if name == push.target), None)
    if found is None:
        return ""
    spec, pose = found
    length = pose.rotation[:, int(np.argmax(spec.half_extents))]
    along = np.array([length[0], length[1]])
    heading = np.array(push.velocity[:2], dtype=float)
    if float(np.linalg.norm(along)) < 0.5 or float(np.linalg.norm(heading)) == 0.0:
        return ""  # the brick stands on end, or the push is vertical: no level to slide along
    along, heading = along / np.linalg.norm(along), heading / np.linalg.norm(heading)
    if abs(float(along @ heading)) > 0.5:
        return ""
    axis = next((name for name, unit in (("x", (1.0, 0.0)), ("y", (0.0, 1.0))) if abs(float(along @ unit)) > 0.999), None)
    lies = f"along {axis}" if axis else f"along [{along[0]:.2f}, {along[1]:.2f}, 0]"
    return (
        f"; note that the push runs across {push.target!r}, whose length lies {lies}: to slide it out of its level, "
        f"push it {lies} (`stackdsl compile` shows how each level lies)"
    )


def warn_wide_pusher(scenario: Scenario, index: int, push: Push, bodies: Sequence[tuple[str, BrickSpec, Pose]]) -> None:
    """Warn of a pusher wider than the place of the brick it pushes: moving on into that place
    (a Jenga block's slot) as the brick leaves it, it would reach into the bricks around it (a
    new user's 10 mm finger, pushed into the 8 mm slot of a KAPLA block, drove the levels above
    and below and felled the tower in every mode). Each pose of its path, :data:`PATH_STEP`
    apart, whose front lies within the target's extent along the push is looked at; a warning,
    not an error: pushing two bricks at once may be meant.

    Args:
        index: the action's index in ``actions``; push: as compiled.
        bodies: (id, spec, pose) of every brick and fixture in the world when the pusher enters.
    """
    target = next(((i, s, p) for i, s, p in bodies if i == push.target), None)
    speed = float(np.linalg.norm(push.velocity))
    if target is None or speed <= 0.0:
        return  # a point pushed, or a pusher that does not move
    direction = np.asarray(push.velocity, dtype=float) / speed
    box = Box(np.array(push.brick.half_extents), push.brick.mass)
    pose = Pose.from_euler(push.position, push.yaw, push.pitch, 0.0)
    _, spec, where = target
    along = Box(np.array(spec.half_extents), spec.mass).corners(where) @ direction
    start = float(pose.position @ direction) + float(box.half_extents[0])  # its front, along the push
    travel = speed * (push.end_time - push.time)
    others = [b for b in bodies if b[0] != push.target]
    for s in np.arange(max(0.0, float(along.min()) - start), min(travel, float(along.max()) - start), PATH_STEP):
        inside = deepest(box, Pose(pose.position + direction * s, pose.orientation), others)
        if inside is None:
            continue
        _, hy, hz = push.brick.half_extents
        warnings.warn(
            scenario.source.warning(
                _pusher_field(scenario, index),
                f"the pusher ({push.brick.type}, {2 * hy * 1000:.0f} x {2 * hz * 1000:.0f} mm across its direction) "
                f"is wider than the place of {push.target} it moves into: {s * 1000:.0f} mm along its path it reaches "
                f"{inside[1] * 1000:.1f} mm into brick {inside[0]!r}, and will push it too; give a thinner pusher (a "
                "brick type of brick_types) or an offset that keeps it within the brick's face",
            ),
            stacklevel=2,
        )
        return


def deepest(box: Box, pose: Pose, bodies: Sequence[tuple[str, BrickSpec, Pose]]) -> tuple[str, float] | None:
    """The body ``box`` at ``pose`` reaches deepest into (id, metres), when deeper than
    :data:`TOLERANCE`; None otherwise."""
    if not bodies:
        return None
    centres = np.array([p.position for _, _, p in bodies])
    rotations = np.array([p.rotation for _, _, p in bodies])
    halves = np.array([s.half_extents for _, s, _ in bodies])
    n = len(bodies)
    depth = penetration(
        np.repeat(pose.position[None], n, axis=0),
        np.repeat(pose.rotation[None], n, axis=0),
        np.repeat(box.half_extents[None], n, axis=0),
        centres,
        rotations,
        halves,
    )
    worst = int(np.argmax(depth))
    return (bodies[worst][0], float(depth[worst])) if depth[worst] > TOLERANCE else None


def _pusher_field(scenario: Scenario, index: int) -> FieldPath:
    """The field a pusher's fault is told at: the push's ``pusher`` when the scenario names its
    brick type, else the push."""
    action = scenario.actions[index].push
    named = action is not None and "pusher" in action.model_fields_set
    return ("actions", index, "push", "pusher") if named else ("actions", index, "push")


def _blame(impact: Impact, index: int) -> FieldPath:
    path: FieldPath = ("impacts", index)
    if impact.target.point is not None:
        return (*path, "target", "point")
    if impact.direction is not None:
        return (*path, "direction")
    return (*path, "projectile")

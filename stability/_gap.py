"""What a moving body may have come near: its gap to other bodies, kept between steps.

A hand's body (a pulled or pushed brick) and a frozen ride (bricks merged into one body that
rides a pull) ask the engine each step for the bodies within a small distance of them
(:meth:`stability.Engine.near`): what a pulled brick touches wakes, and a ride ends when it
comes near what it did not touch when it began. Most steps find nothing. A body's gap to the
others is measured once within :data:`CLEAR` and kept with the poses it was measured at; until
the gap less how far any point of the body and of any moving other can have moved since
(:func:`stability._geometry.moved_at_most`) comes within the distance asked, nothing can be
within it and the engine is not asked. The engine's closest points decide whenever it is.

Source: stackdsl's own (the travel bound of :class:`stability._impact.Impacts`' frozen boxes,
here against the engine's own distances).
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass

from ._engine import ContactPoint
from ._geometry import moved_at_most
from ._graph import BrickState
from ._stack import Stack

#: Metres within which a body's gap to the others is measured: under half the reach within
#: which pybullet's world keeps the static bodies near a moving one out of its shelf (what is
#: shelved lies farther).
CLEAR = 0.01
#: Metres of round-off allowed the engine's distances.
GAP_SLACK = 1e-5

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


@dataclass(frozen=True)
class Gap:
    """A body's gap (m) to ``others`` (the collection asked of, by identity), as measured
    when it was at ``place`` turned by ``turn`` (m, a unit quaternion x, y, z, w), with the
    poses then of the others that moved (``moving``, id -> position and quaternion), and the
    stack's state that says which move (``state``: :func:`moving_state`).
    Source: stackdsl's own."""

    others: Collection[int]
    state: tuple[object, ...]
    place: Vec3
    turn: Quat
    moving: dict[int, tuple[Vec3, Quat]]
    gap: float


def moving_among(stack: Stack, others: Collection[int]) -> list[int]:
    """Those of ``others`` the engine may move: awake bricks and the riders of a ride (frozen,
    merged into a body the engine moves); not frozen bricks, not the ground (a shaken ground
    is asked of each step: :func:`near_within`), not a body taken out of the scene since
    ``others`` was gathered."""
    riding, bodies, still = stack.riding, stack.bodies, (BrickState.FROZEN, BrickState.GROUND)
    return [b for b in others if b in riding or ((rec := bodies.get(b)) is not None and rec.state not in still)]


def moving_state(stack: Stack) -> tuple[object, ...]:
    """What decides which bodies :func:`moving_among` finds: the frozen stack's version (freezes
    and wakes), the bodies registered and taken away, and the rides under way."""
    return (stack.version, stack.registrations, tuple(stack.rides))


def near_within(
    stack: Stack, body: int, span: float, others: Collection[int], distance: float, kept: Gap | None
) -> tuple[list[ContactPoint], Gap | None]:
    """The engine's contact points of ``body`` within ``distance`` m of ``others``
    (:meth:`stability.Engine.near`), or none when the kept gap proves there are none; and the
    gap to keep. ``span``: metres from the body's centre to its farthest point (a merged ride:
    from its first rider's).

    The engine is asked only when ``kept`` (of the same ``others`` and stack state, the ground
    at rest: the same moving bodies among them, found once a state, not each step) less the bound on how far the body and the farthest-moved
    moving other have moved since it was measured is within ``distance`` and
    :data:`GAP_SLACK`: the gap is then measured again within :data:`CLEAR`, and the engine
    asked within ``distance`` when something lies that near. Source: stackdsl's own (module
    docstring)."""
    engine = stack.engine
    place, turn = engine.pose_floats(body)
    state = moving_state(stack)
    if kept is not None and stack.admitting and kept.others is others and kept.state == state:
        farthest = 0.0
        for b, (was, turned_was) in kept.moving.items():
            there, turned = engine.pose_floats(b)
            farthest = max(farthest, moved_at_most(was, turned_was, there, turned, stack.bodies[b].box.half_diagonal))
        if kept.gap - moved_at_most(kept.place, kept.turn, place, turn, span) - farthest > distance + GAP_SLACK:
            return [], kept
    reach = max(CLEAR, distance)
    points = engine.near(body, reach, others)
    gap = min((c.distance for c in points), default=reach)
    moving = {b: engine.pose_floats(b) for b in moving_among(stack, others)}
    measured = Gap(others, state, place, turn, moving, gap)
    if reach == distance:
        return points, measured
    if gap > distance + GAP_SLACK:
        return [], measured
    return engine.near(body, distance, others), measured

"""The engine interface the stability extension drives, and a fake engine.

The extension needs five things from a physics engine: a body's pose, its velocity,
the contact points, and a way to freeze (immovable but colliding) and restore a body; and
one it may be refused, merging frozen bodies into one the engine moves (bricks riding a
dragged level).
Any object with them is an :class:`Engine`; this package knows no engine by name.
:class:`FakeEngine` holds them in plain attributes so that stability rules can be tested
on hand-built contact graphs without a simulation.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import numpy.typing as npt

from ._geometry import Pose


@dataclass(frozen=True)
class ContactPoint:
    """One contact point as seen from ``body`` (report Figure 3, ContactPoint).

    Attributes:
        body: the body this contact belongs to.
        other: the body it touches.
        position: shape (3,), metres, the point on ``other``'s surface.
        normal: shape (3,), unit, pointing from ``other`` into ``body``.
        normal_force: newtons (0 when the engine does not report it).
        distance: metres between the two surfaces along the normal (negative when they
            overlap; 0 for a contact the engine does not measure).

    Source: report 3.3.1, Figure 3.
    """

    body: int
    other: int
    position: np.ndarray
    normal: np.ndarray
    normal_force: float = 0.0
    distance: float = 0.0


class Engine(Protocol):
    """What the stability extension needs from a physics engine. Source: stackdsl's own.

    An engine whose :meth:`near` finds bodies by their geometry (every real one) may say so with
    a class attribute ``near_is_geometric = True``: the impact rule then asks it only when a
    frozen brick's box is within reach (a fake engine's ``near`` answers from contacts set by
    hand, wherever the bodies are).

    An engine that makes a contact between two bodies only once they overlap (pybullet's boxes,
    which only touch when a frozen brick, raised out of its supports, is woken) says so with a
    class attribute ``contacts_need_overlap = True``: a woken brick is then lowered back into what
    it rests on (:meth:`stability._stack.Stack.wake`).
    """

    @property
    def timestep(self) -> float:
        """Seconds of one physics step."""

    def pose(self, body: int) -> Pose:
        """Current pose of ``body``."""

    def poses_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """Positions (n, 3) in m and unit quaternions (x, y, z, w), (n, 4), of ``bodies``: the
        poses of several bodies in one call (the held bricks of a collapse mechanism, every step)."""

    def pose_floats(self, body: int) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
        """:meth:`pose` of ``body`` in floats: its position (m) and unit quaternion (x, y, z, w), with
        no array made (the impact rule reads the few fast bodies of a step so)."""

    def velocity(self, body: int) -> tuple[np.ndarray, np.ndarray]:
        """Linear (m/s) and angular (rad/s) velocity of ``body``, shape (3,) each."""

    def speeds(self, body: int) -> tuple[float, float]:
        """Linear speed (m/s) and angular speed (rad/s) of ``body``: the norms of
        :meth:`velocity`, which the rest test asks of every active brick at every step."""

    def contact_points(self, bodies: Collection[int] | None = None) -> list[ContactPoint]:
        """Every current contact point, once from each side; with ``bodies``, only those seen
        from one of them."""

    def near(self, body: int, distance: float, among: Collection[int] | None = None) -> list[ContactPoint]:
        """Closest points between ``body`` and every body within ``distance`` metres, seen from
        ``body``; with ``among``, only those of these bodies (the impact rule asks of the frozen ones)."""

    def set_frozen(self, body: int, frozen: bool, mass: float, at: Pose | None = None) -> None:
        """Freeze (immovable, still colliding, velocity zeroed) or restore ``body``; frozen or
        restored at the pose ``at`` when it is given, else where it is."""

    def merge(self, bodies: Sequence[int]) -> bool:
        """Make the frozen ``bodies`` one rigid body the engine moves (their masses, where they
        are, touching what they touch), or say False and change nothing (an engine that cannot).
        While merged, :meth:`pose`, :meth:`velocity` and :meth:`speeds` of each read its part of
        that body, a contact point on that body is seen from, and names, the one of
        ``bodies`` whose part it lies on, and :meth:`near` of any of them is of that body."""

    def unmerge(self, bodies: Sequence[int]) -> None:
        """End a :meth:`merge` of ``bodies``: each a frozen body of its own again, where its part
        of the merged body is; one restored (:meth:`set_frozen`) before the next step moves on
        with the velocity its part had, not from rest (a ride that ends on a shaken table is
        moving with it)."""


class ContactBook(dict[int, list[ContactPoint]]):
    """One step's contact points by the body they are seen from, read from ``engine`` for a
    body the first time it is looked up, and only for one of ``bodies`` (any other has none
    here); those of ``now`` are read at once.

    A settling heap has hundreds of contact points and a step's admissions read those of a few
    bricks. :meth:`fill` reads the rest: call it before freezing or waking a body, because
    pybullet then drops that body's contacts until its next step. Source: stackdsl's own.

    >>> eng = FakeEngine()
    >>> eng.touch(1, 0, [[0, 0, 0]], normal=[0, 0, 1])
    >>> book = ContactBook(eng, [0, 1])
    >>> [c.other for c in book[1]], sorted(book), book[2]
    ([0], [1], [])
    >>> book.fill(); sorted(book)
    [0, 1, 2]
    """

    def __init__(self, engine: Engine, bodies: Collection[int], now: Collection[int] = ()) -> None:
        super().__init__()
        self._engine, self._bodies = engine, frozenset(bodies)
        for body in now:
            self[body]

    def __missing__(self, body: int) -> list[ContactPoint]:
        points = self._engine.contact_points([body]) if body in self._bodies else []
        self[body] = points
        return points

    def fill(self) -> None:
        """Read the contact points of every body not looked up yet."""
        for body in self._bodies.difference(self):
            self[body]


@dataclass
class FakeEngine:
    """An in-memory :class:`Engine` for tests: set poses, velocities and contacts by hand.

    Attributes:
        poses: body -> :class:`Pose`.
        velocities: body -> (linear, angular); bodies not listed are at rest.
        contacts: the contact points, each given once from each side
            (use :meth:`touch` to add a pair).
        frozen: the bodies currently frozen.
        timestep: seconds of one step.
        mergeable: whether :meth:`merge` merges (False: it says it cannot, as an engine
            without compound bodies does).
        merged: the groups merged now.

    >>> eng = FakeEngine()
    >>> eng.touch(1, 0, [[0, 0, 0]], normal=[0, 0, 1])
    >>> [c.body for c in eng.contact_points()]
    [1, 0]
    """

    poses: dict[int, Pose] = field(default_factory=dict)
    velocities: dict[int, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    contacts: list[ContactPoint] = field(default_factory=list)
    frozen: set[int] = field(default_factory=set)
    timestep: float = 1 / 240
    mergeable: bool = False
    merged: list[tuple[int, ...]] = field(default_factory=list)

    def touch(
        self,
        body: int,
        other: int,
        points: npt.ArrayLike,
        normal: npt.ArrayLike,
        force: float = 0.0,
        distance: float = 0.0,
    ) -> None:
        """Add contact points between ``body`` and ``other``; ``normal`` points into ``body``;
        ``distance``: metres between them, negative where they overlap."""
        n = np.asarray(normal, dtype=float)
        n = n / np.linalg.norm(n)
        for p in np.asarray(points, dtype=float).reshape(-1, 3):
            self.contacts.append(ContactPoint(body, other, p, n, force, distance))
            self.contacts.append(ContactPoint(other, body, p, -n, force, distance))

    def pose(self, body: int) -> Pose:
        return self.poses[body]

    def pose_floats(self, body: int) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
        (x, y, z), (a, b, c, d) = self.poses[body].position.tolist(), self.poses[body].orientation.tolist()
        return (x, y, z), (a, b, c, d)

    def poses_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        poses = [self.poses[b] for b in bodies]
        return np.array([p.position for p in poses]).reshape(-1, 3), np.array([p.orientation for p in poses]).reshape(-1, 4)

    def velocity(self, body: int) -> tuple[np.ndarray, np.ndarray]:
        return self.velocities.get(body, (np.zeros(3), np.zeros(3)))

    def speeds(self, body: int) -> tuple[float, float]:
        lin, ang = self.velocity(body)
        return float(np.linalg.norm(lin)), float(np.linalg.norm(ang))

    def contact_points(self, bodies: Collection[int] | None = None) -> list[ContactPoint]:
        return [
            c
            for c in self.contacts
            if not (c.body in self.frozen and c.other in self.frozen) and (bodies is None or c.body in bodies)
        ]

    def near(self, body: int, distance: float, among: Collection[int] | None = None) -> list[ContactPoint]:
        """The fake has no distances: a body is near what it touches."""
        return [c for c in self.contacts if c.body == body and (among is None or c.other in among)]

    def set_frozen(self, body: int, frozen: bool, mass: float, at: Pose | None = None) -> None:
        self.velocities.pop(body, None)
        if at is not None:
            self.poses[body] = at
        (self.frozen.add if frozen else self.frozen.discard)(body)

    def merge(self, bodies: Sequence[int]) -> bool:
        if not self.mergeable or not set(bodies) <= self.frozen:
            return False
        self.merged.append(tuple(bodies))
        self.frozen.difference_update(bodies)  # they move, as one
        return True

    def unmerge(self, bodies: Sequence[int]) -> None:
        self.merged.remove(tuple(bodies))
        self.frozen.update(bodies)

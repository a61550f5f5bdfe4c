"""The engine interface the stability extension drives, with a real and a fake engine.

The extension needs five things from a physics engine: a body's pose, its velocity,
the contact points, and a way to freeze (immovable but colliding) and restore a body.
:class:`PyBulletEngine` provides them on any pybullet client; :class:`FakeEngine` holds
them in plain attributes so that stability rules can be tested on hand-built contact
graphs without a simulation.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

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
    """

    @property
    def timestep(self) -> float:
        """Seconds of one physics step."""

    def pose(self, body: int) -> Pose:
        """Current pose of ``body``."""

    def poses_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """Positions (n, 3) in m and unit quaternions (x, y, z, w), (n, 4), of ``bodies``: the
        poses of several bodies in one call (the held bricks of a collapse mechanism, every step)."""

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
        """Freeze (immovable, still colliding, velocity zeroed) or restore ``body``; frozen
        at the pose ``at`` when it is given, else where it is."""


class BoundCalls:
    """A pybullet client whose functions are each looked up once: a ``BulletClient`` builds a
    new ``functools.partial`` (and asks ``inspect`` whether the function is a built-in) on every
    attribute access, some 3 us, a third of the cost of a step's own call; a run of a 30-level
    tower asks for about 1500 of them. ``disconnect`` is looked up anew each time (a
    ``BulletClient`` forgets its id when asked for it). Source: stackdsl's own.

    >>> import types
    >>> calls = BoundCalls(types.SimpleNamespace(stepSimulation=lambda: "stepped"))
    >>> calls.stepSimulation(), "stepSimulation" in vars(calls)
    ('stepped', True)
    """

    def __init__(self, client: Any) -> None:
        self._raw = client

    def __getattr__(self, name: str) -> Any:
        attribute = getattr(self._raw, name)
        if name != "disconnect":
            self.__dict__[name] = attribute
        return attribute


class PyBulletEngine:
    """:class:`Engine` on a pybullet client.

    Args:
        client: a ``pybullet_utils.bullet_client.BulletClient`` or the ``pybullet``
            module itself (its default client).

    Freezing sets the mass to 0 after zeroing the velocities: a body made static while
    moving keeps its velocity in pybullet. Restoring the mass restores the inertia.
    pybullet reports no contacts between two static bodies, which is why the extension
    keeps its own contact graph. A subclass that gives bodies ids of its own overrides
    :meth:`_engine_id` and :meth:`_body_id`. Source: stackdsl's own, measured with
    pybullet 3.2.7.
    """

    near_is_geometric = True

    def __init__(self, client: Any) -> None:
        self._client = BoundCalls(client)
        # asked of every active brick at every step: bound once (a BulletClient builds a new
        # partial on each attribute access, a third of the cost of the call)
        self._get_velocity = client.getBaseVelocity
        self._get_pose = client.getBasePositionAndOrientation

    def _engine_id(self, body: int) -> int:
        """pybullet's id of ``body`` (here the same)."""
        return body

    def _body_id(self, engine_id: int) -> int:
        """The body pybullet calls ``engine_id`` (here the same)."""
        return engine_id

    @property
    def timestep(self) -> float:
        return float(self._client.getPhysicsEngineParameters()["fixedTimeStep"])

    def pose(self, body: int) -> Pose:
        pos, orn = self._get_pose(body)
        return Pose(np.array(pos), np.array(orn))

    def poses_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        states = [self._get_pose(b) for b in bodies]
        return np.array([p for p, _ in states]).reshape(-1, 3), np.array([q for _, q in states]).reshape(-1, 4)

    def velocity(self, body: int) -> tuple[np.ndarray, np.ndarray]:
        lin, ang = self._get_velocity(body)
        return np.array(lin), np.array(ang)

    def speeds(self, body: int) -> tuple[float, float]:
        lin, ang = self._get_velocity(body)
        return math.hypot(*lin), math.hypot(*ang)

    def contact_points(self, bodies: Collection[int] | None = None) -> list[ContactPoint]:
        name = self._body_id
        if bodies is not None:  # asked of each body: its side only
            return [
                ContactPoint(body, name(c[2]), np.array(c[6]), np.array(c[7]), float(c[9]), float(c[8]))
                for body in bodies
                for c in self._client.getContactPoints(bodyA=self._engine_id(body))
            ]
        points = []
        for c in self._client.getContactPoints():
            a, b = name(c[1]), name(c[2])
            normal_on_b = np.array(c[7])
            force, distance = float(c[9]), float(c[8])
            points.append(ContactPoint(a, b, np.array(c[6]), normal_on_b, force, distance))
            points.append(ContactPoint(b, a, np.array(c[5]), -normal_on_b, force, distance))
        return points

    def near(self, body: int, distance: float, among: Collection[int] | None = None) -> list[ContactPoint]:
        own = self._engine_id(body)
        low, high = self._client.getAABB(own)
        low, high = np.array(low) - distance, np.array(high) + distance
        found = self._client.getOverlappingObjects(low.tolist(), high.tolist()) or []
        others = sorted({self._body_id(b) for b, _ in found if b != own})
        if among is not None:
            others = [b for b in others if b in among]
        return [
            ContactPoint(body, other, np.array(c[6]), np.array(c[7]), float(c[9]), float(c[8]))
            for other in others
            for c in self._client.getClosestPoints(own, self._engine_id(other), distance)
        ]

    def set_frozen(self, body: int, frozen: bool, mass: float, at: Pose | None = None) -> None:
        own = self._engine_id(body)
        self._client.resetBaseVelocity(own, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
        if frozen and at is not None:
            self._client.resetBasePositionAndOrientation(own, at.position.tolist(), at.orientation.tolist())
        self._client.changeDynamics(own, -1, mass=0.0 if frozen else mass)


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
        if frozen and at is not None:
            self.poses[body] = at
        (self.frozen.add if frozen else self.frozen.discard)(body)

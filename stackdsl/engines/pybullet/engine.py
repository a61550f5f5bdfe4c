"""The stability extension's :class:`stability.Engine` on a pybullet client.

Source: stackdsl's own, measured with pybullet 3.2.7.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from typing import Any

import numpy as np

from stability import ContactPoint, Pose


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
    # two boxes that touch without overlapping have no contact point (Stack.wake lowers a woken brick)
    contacts_need_overlap = True

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

    def pose_floats(self, body: int) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
        (x, y, z), (a, b, c, d) = self._get_pose(body)
        return (x, y, z), (a, b, c, d)

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
        if at is not None:
            self._client.resetBasePositionAndOrientation(own, at.position.tolist(), at.orientation.tolist())
        self._client.changeDynamics(own, -1, mass=0.0 if frozen else mass)

"""A world without an engine, for testing the step loop: bodies keep their velocity.

Source: stackdsl's own (the fake backend of httpx's transports).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from stability import FakeEngine, Pose

from .protocol import BrickSpec, Vec3, World


@dataclass
class FakeWorld(FakeEngine, World):
    """:class:`stackdsl.engines.protocol.World` in memory. Each step moves every body with mass by
    its linear velocity (no gravity, no contacts, no rotation); a test sets velocities and
    contacts by hand (``velocities``, :meth:`FakeEngine.touch`).

    Attributes:
        masses: body -> kg (0: immovable).
        steps: steps taken; substeps: the current split.

    >>> from stackdsl.engines.protocol import BrickSpec
    >>> world = FakeWorld()
    >>> b = world.create(BrickSpec(type="kapla", half_extents=(0.06, 0.012, 0.004), mass=0.01, friction=0.5, restitution=0.0), Pose.from_euler([0, 0, 0.004]))
    >>> world.throw(b, (1.0, 0.0, 0.0), None); world.step()
    >>> round(float(world.pose(b).position[0]), 6) == round(world.timestep, 6)
    True
    """

    masses: dict[int, float] = field(default_factory=dict)
    steps: int = 0
    substeps: int = 1
    ground: int = 0
    ground_offset: Vec3 = (0.0, 0.0, 0.0)
    guided: set[int] = field(default_factory=set)

    def create(self, spec: BrickSpec, pose: Pose, mass: float | None = None, projectile: bool = False) -> int:
        body = len(self.masses) + 1  # 0 is the ground
        self.poses[body] = pose
        self.masses[body] = spec.mass if mass is None else mass
        return body

    def move(self, body: int, pose: Pose, mass: float) -> None:
        self.poses[body], self.masses[body] = pose, mass
        self.velocities.pop(body, None)
        self.guided.discard(body)

    def guide(self, body: int, pose: Pose, velocity: Vec3, hold: bool = True) -> None:
        self.poses[body] = pose
        self.velocities[body] = (np.array(velocity, dtype=float), np.zeros(3))
        self.guided.add(body)

    carries = True

    def carry(self, body: int, pose: Pose, velocity: Vec3) -> None:
        self.poses[body] = pose
        self.velocities[body] = (np.array(velocity, dtype=float), np.zeros(3))

    def move_ground(self, offset: Vec3, velocity: Vec3) -> None:
        self.ground_offset = offset

    def throw(self, body: int, velocity: Vec3, swept_radius: float | None) -> None:
        self.velocities[body] = (np.array(velocity, dtype=float), np.zeros(3))

    def step(self) -> None:
        for body, (lin, _) in list(self.velocities.items()):
            if self.masses.get(body, 0.0) > 0.0 and body not in self.frozen:
                p = self.poses[body]
                self.poses[body] = Pose(p.position + lin * self.timestep, p.orientation)
        self.steps += 1

    def set_substeps(self, substeps: int) -> None:
        self.substeps = substeps

    def poses_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        poses = [self.poses[b] for b in bodies]
        return np.array([p.position for p in poses]).reshape(-1, 3), np.array([p.orientation for p in poses]).reshape(-1, 4)

    def velocities_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        v = [self.velocity(b) for b in bodies]
        return np.array([lin for lin, _ in v]).reshape(-1, 3), np.array([ang for _, ang in v]).reshape(-1, 3)

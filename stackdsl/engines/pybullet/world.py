"""The world on pybullet: :class:`PyBulletWorld`, a :class:`~stackdsl.engines.protocol.World`
on a pybullet DIRECT client.

pybullet facts this adapter encodes (measured with pybullet 3.2.7):

* Bullet multiplies the two bodies' friction coefficients (and restitutions): each body
  gets the square root of its material's value, so a pair of one material has exactly
  the material's coefficient.
* Friction anchors stop a resting brick's creep; continuous collision detection needs a
  body in maximal coordinates.
* Bodies are created in program order, so that a run is bitwise repeatable.
* A body created right after one was removed gets the removed body's id.
* A step of a settling heap costs about half as much in rigid bodies (maximal coordinates)
  as in one-link multibodies (docs/results/collapse-phase.md).

Source: stackdsl's own (the world adapter of dm_control's composer).
"""

from __future__ import annotations

import ctypes
import math
import os
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import numpy as np

from stability import Pose, PyBulletEngine

from ..protocol import BrickSpec, Vec3, World
from .settings import PyBulletSettings


@contextmanager
def _quiet_c_output() -> Iterator[None]:
    """Silence C-level stdout and stderr (pybullet prints 'argv[0]=' and its build time)."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    os.dup2(devnull, 2)
    try:
        yield
    finally:
        ctypes.CDLL(None).fflush(None)  # C stdio may still hold what pybullet printed
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)


@contextmanager
def direct_client() -> Iterator[Any]:
    """A new pybullet DIRECT client (``BulletClient``), disconnected on exit."""
    with _quiet_c_output():
        import pybullet
        from pybullet_utils.bullet_client import BulletClient

        client = BulletClient(connection_mode=pybullet.DIRECT)
    try:
        yield client
    finally:
        client.disconnect()


@contextmanager
def pybullet_world(engine: PyBulletSettings, ground_friction: float, ground_restitution: float) -> Iterator[PyBulletWorld]:
    """A :class:`PyBulletWorld` on a new DIRECT client, disconnected on exit."""
    with direct_client() as client:
        yield PyBulletWorld(client, engine, ground_friction, ground_restitution)


class PyBulletWorld(PyBulletEngine, World):
    """:class:`World` on a pybullet client: gravity, timestep, solver iterations and the
    ground plane are set up at once; ``ground`` is the plane's body id.

    A body's velocity is read from pybullet once a step, however many ask (the rest test
    brick by brick, the substep control and the collapse monitor), and read again after
    anything that changes it (a step, a placement, a throw, a freeze or a wake).

    Args:
        client: a ``pybullet_utils.bullet_client.BulletClient``.
        engine: the run's engine settings.
        ground_friction, ground_restitution: of the ground's material.
    """

    def __init__(self, client: Any, engine: PyBulletSettings, ground_friction: float, ground_restitution: float) -> None:
        import pybullet

        super().__init__(client)
        self._p, self._engine = pybullet, engine
        self._velocities: dict[int, Any] = {}  # this step's pybullet velocities, by body
        self._read_velocity = client.getBaseVelocity
        self._get_velocity = self._velocity_now
        self._shapes: dict[Vec3, int] = {}  # half extents -> collision shape
        self._multibodies: dict[int, BrickSpec] = {}  # the bodies created in reduced coordinates
        self._substeps = 1
        client.setGravity(0.0, 0.0, -engine.gravity)
        client.setTimeStep(engine.timestep)
        client.setPhysicsEngineParameter(numSolverIterations=engine.solver_iterations)
        self.ground: int = client.createMultiBody(0.0, client.createCollisionShape(pybullet.GEOM_PLANE))
        self._material(self.ground, ground_friction, ground_restitution)

    @property
    def timestep(self) -> float:
        return self._engine.timestep

    rigid_debris = True

    def create(self, spec: BrickSpec, pose: Pose, mass: float | None = None, projectile: bool = False) -> int:
        """A body in maximal coordinates for a ``projectile`` (continuous collision detection
        needs one), else in the coordinates of the engine settings."""
        return self._create(spec, pose, mass, True if projectile else self._engine.maximal_coordinates)

    def _create(self, spec: BrickSpec, pose: Pose, mass: float | None, maximal: bool) -> int:
        key = spec.half_extents
        if key not in self._shapes:
            self._shapes[key] = self._client.createCollisionShape(self._p.GEOM_BOX, halfExtents=list(key))
        body: int = self._client.createMultiBody(
            baseMass=spec.mass if mass is None else mass,
            baseCollisionShapeIndex=self._shapes[key],
            basePosition=pose.position.tolist(),
            baseOrientation=pose.orientation.tolist(),
            useMaximalCoordinates=maximal,
        )
        self._material(body, spec.friction, spec.restitution)
        if not maximal:
            self._multibodies[body] = spec
        return body

    def make_rigid(self, bodies: Sequence[int]) -> list[int]:
        """Re-create in maximal coordinates (pybullet's rigid bodies) each of ``bodies`` that
        is a multibody pybullet moves (mass above 0), at the same pose and velocity, under the
        same id; returns the ids re-created.

        A step of a settling heap of rigid bodies costs pybullet about half what it costs in
        multibodies (docs/results/collapse-phase.md). pybullet gives a new body the id
        the last one removed had, which keeps every id the run holds valid.

        Raises:
            RuntimeError: pybullet gave a re-created body another id.
        """
        made = []
        for body in bodies:
            spec = self._multibodies.get(body)
            if spec is None:
                continue  # created rigid
            mass = float(self._client.getDynamicsInfo(body, -1)[0])
            if mass == 0.0:
                continue  # frozen or parked: pybullet does not move it
            (position, orientation), (linear, angular) = self._get_pose(body), self._read_velocity(body)
            self._client.removeBody(body)
            del self._multibodies[body]
            self._velocities.pop(body, None)
            again = self._create(spec, Pose(np.array(position), np.array(orientation)), mass, True)
            if again != body:
                raise RuntimeError(f"pybullet re-created body {body} as {again}")
            self._client.resetBaseVelocity(body, linear, angular)
            made.append(body)
        return made

    def _material(self, body: int, friction: float, restitution: float) -> None:
        self._client.changeDynamics(
            body,
            -1,
            lateralFriction=math.sqrt(friction),
            restitution=math.sqrt(restitution),
            frictionAnchor=int(self._engine.friction_anchors),
        )

    def _velocity_now(self, body: int) -> Any:
        """pybullet's (linear, angular) velocity of ``body`` this step, read once."""
        read = self._velocities.get(body)
        if read is None:
            read = self._velocities[body] = self._read_velocity(body)
        return read

    def set_frozen(self, body: int, frozen: bool, mass: float, at: Pose | None = None) -> None:
        self._velocities.pop(body, None)
        super().set_frozen(body, frozen, mass, at)

    def move(self, body: int, pose: Pose, mass: float) -> None:
        self._velocities.pop(body, None)
        self._client.resetBasePositionAndOrientation(body, pose.position.tolist(), pose.orientation.tolist())
        self._client.resetBaseVelocity(body, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])  # the pose alone keeps them
        self._client.changeDynamics(body, -1, mass=mass)

    def throw(self, body: int, velocity: Vec3, swept_radius: float | None) -> None:
        self._velocities.pop(body, None)
        if swept_radius is not None:
            self._client.changeDynamics(body, -1, ccdSweptSphereRadius=swept_radius)
        self._client.resetBaseVelocity(body, list(velocity), [0.0, 0.0, 0.0])

    def step(self) -> None:
        self._velocities.clear()
        self._client.stepSimulation()

    def set_substeps(self, substeps: int) -> None:
        if substeps != self._substeps:
            self._client.setPhysicsEngineParameter(numSubSteps=substeps if substeps > 1 else 0)
            self._substeps = substeps

    def poses_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        states = [self._get_pose(b) for b in bodies]
        return np.array([p for p, _ in states]).reshape(-1, 3), np.array([q for _, q in states]).reshape(-1, 4)

    def velocities_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        v = [self._get_velocity(b) for b in bodies]
        return np.array([lin for lin, _ in v]).reshape(-1, 3), np.array([ang for _, ang in v]).reshape(-1, 3)

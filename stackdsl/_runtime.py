"""Program -> Outcome: run a program in a pybullet DIRECT client, with or without the extension.

One client per run, closed in all cases. Bodies enter the engine when they are placed,
in program order, so creation order is a function of the scenario alone (pybullet is
bitwise repeatable only then). Bullet multiplies the two bodies' friction coefficients
(and restitutions): each body gets the square root of its material's value, so a pair
of one material has exactly the material's coefficient.

Collapse detection is the same in every mode: after the first structure brick leaves
its placed pose by more than the collapse threshold, nothing more is placed and the run
ends ``settle`` seconds later. In extension mode, while every brick is frozen nothing
can move, so the run jumps to the next action instead of stepping.

Two guards keep a run finite (the compiler's work budget refuses the scenarios that
would take too long before anything runs, :mod:`stackdsl._compiler`):

* a step is split into at most :data:`MAX_SUBSTEPS` substeps however fast a body moves
  (a ``substeps`` event says when the cap held);
* ``run_program(..., timeout=SECONDS)`` stops a run after that much wall time, cleanly:
  the outcome is built from what was simulated and :attr:`Outcome.stopped` says when.
  The clock is read once per :data:`CLOCK_EVERY` steps and at every action.

Source: stackdsl's own.
"""

from __future__ import annotations

import ctypes
import math
import os
import sys
import time as _time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from shapely.geometry import MultiPoint, Polygon

from stability import Box, Plane, Pose, PyBulletEngine, StabilityConfig, StabilityEvent, StabilityExtension

from ._outcome import Collapse, Event, Graph, Outcome
from ._program import MAX_SUBSTEPS, BrickSpec, Launch, Place, Program, Vec3

#: Steps between two readings of the wall clock when a run has a timeout.
CLOCK_EVERY = 16


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


@dataclass(frozen=True)
class RunOptions:
    """How much of a scene the runtime simulates; each switch shows its saving in ``stackdsl bench``.

    Attributes:
        jump: in extension mode, jump to the next action while every brick is frozen
            (nothing can move) instead of stepping.
        lazy_bodies: bodies enter the engine when they are placed; False creates every
            brick at the start, parked far away and immovable.
        needed_rules: run only the stability rules the compiler chose for the scene;
            False runs leaning and impacts always.
        per_event: run the stack-wide test when the stack changes; False every step.
        stop_at_collapse: place nothing after the first collapse and end ``settle`` later.

    Source: stackdsl's own (model only what a scene needs).
    """

    jump: bool = True
    lazy_bodies: bool = True
    needed_rules: bool = True
    per_event: bool = True
    stop_at_collapse: bool = True


def _rotations(quaternions: np.ndarray) -> np.ndarray:
    """Rotation matrices, shape (n, 3, 3), of unit quaternions (x, y, z, w), shape (n, 4)."""
    x, y, z, w = quaternions.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=1,
    )


def run_program(program: Program, options: RunOptions = RunOptions(), *, timeout: float | None = None) -> Outcome:
    """Run a compiled program and report what happened.

    Args:
        program: a compiled program.
        options: how much of the scene to simulate.
        timeout: seconds of wall time after which the run stops (checked every
            :data:`CLOCK_EVERY` steps and at every action); the outcome then covers the
            simulated time so far and :attr:`Outcome.stopped` says where it stopped.
            None: no limit.

    Raises:
        ValueError: a negative or not-a-number timeout.
        pybullet.error: the engine failed (not expected for a compiled program).
    """
    if timeout is not None and not timeout >= 0:
        raise ValueError(f"timeout must be a number of seconds >= 0 or None, not {timeout!r}")
    start = _time.perf_counter()
    with direct_client() as client:
        runner = _Runner(client, program, options)
        runner.deadline = None if timeout is None else start + timeout
        runner.timeout = timeout
        runner.execute()
        return runner.outcome(_time.perf_counter() - start)


class _Runner:
    """The state of one run: engine, extension, bodies, timeline, collapse."""

    def __init__(self, client: Any, program: Program, options: RunOptions) -> None:
        import pybullet

        self.p, self.client, self.program, self.options = pybullet, client, program, options
        # the calls made for every brick at every step, bound once (BulletClient builds a
        # new partial on each attribute access)
        self._state = partial(pybullet.getBasePositionAndOrientation, physicsClientId=client._client)
        self._velocity = partial(pybullet.getBaseVelocity, physicsClientId=client._client)
        # the bodies of the last displacements() call, with their corners' offsets and placed corners, (n, 8, 3) each
        self._stacked: tuple[tuple[int, ...], np.ndarray, np.ndarray] = ((), np.zeros((0, 8, 3)), np.zeros((0, 8, 3)))
        e = program.engine
        self.dt = e.timestep
        self.acting = e.mode == "extension"
        client.setGravity(0.0, 0.0, -e.gravity)
        client.setTimeStep(e.timestep)
        client.setPhysicsEngineParameter(numSolverIterations=e.solver_iterations)
        ground = client.createMultiBody(0.0, client.createCollisionShape(pybullet.GEOM_PLANE))
        self._material(ground, program.ground_friction, program.ground_restitution)
        rules = {r.name: r.on or not options.needed_rules for r in program.rules}
        settings: dict[str, Any] = dict(program.stability)  # the keys and types the schema allows
        config = StabilityConfig(**settings, leaning=rules["leaning"], impacts=rules["impacts"], per_event=options.per_event)
        self.ext = StabilityExtension(PyBulletEngine(client), config)
        self.ext.add_ground(ground, Plane(0.0), friction=program.ground_friction)
        self.shapes: dict[Vec3, int] = {}  # half extents -> collision shape
        for f in program.fixtures:
            body = self.create(f.brick, Pose.from_euler(f.position, f.yaw, f.pitch, f.roll), mass=0.0)
            self.ext.add_ground(body, Box(np.array(f.brick.half_extents), f.brick.mass), f.id, f.brick.friction)
        self.parked = {} if options.lazy_bodies else self._park()
        self.bodies: dict[str, int] = {}
        self.labels: dict[str, int] = {}
        self.projectiles: set[str] = set()
        self.levels: dict[str, int] = {}
        self.targets: dict[int, tuple[str, np.ndarray]] = {}  # body -> (id, placed position)
        self.corners: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # body -> (signed half extents (8, 3), placed corners)
        self.placed: dict[int, tuple[float, ...]] = {}  # body -> placed x, y, z, quaternion, half diagonal
        self.tops: dict[int, list[tuple[Polygon, int, float]]] = {}  # top height in 0.1 mm -> footprint, body, nominal z
        self.settled: dict[int, float] = {}  # frozen structure bricks -> displacement when frozen
        self.moving: set[int] = set()
        self.events: list[Event] = []
        self.collapse: Collapse | None = None
        self.collapse_graph: Graph | None = None
        self.drift = 0.0
        self.stop_step: int | None = None
        self.step = 0
        self.skipped = 0
        self.substeps = 1
        self.deadline: float | None = None  # perf_counter() seconds; None: no limit
        self.timeout: float | None = None
        self.stopped: str | None = None

    def _park(self) -> dict[str, int]:
        """Every brick and projectile created at the start, immovable and far away."""
        parked = {}
        for i, a in enumerate(a for a in self.program.actions if isinstance(a, (Place, Launch))):
            maximal = self.program.engine.ccd or None if isinstance(a, Launch) else None
            parked[a.id] = self.create(a.brick, Pose.from_euler([100.0 + 0.3 * i, 100.0, 1.0]), mass=0.0, maximal=maximal)
        return parked

    # lifecycle ----------------------------------------------------------------
    def execute(self) -> None:
        for action in self.program.actions:
            self.advance(action.step)
            if self.stopped is not None or self._out_of_time():
                return
            if self.stop_step is not None and self.options.stop_at_collapse:
                break
            if isinstance(action, Place):
                self.place(action)
            elif isinstance(action, Launch):
                self.launch(action)
                if self.acting:  # a fast projectile may reach its target within the first step
                    self._record(self.ext.update(action.time))
        if self.stop_step is not None:
            self.advance(min(self.stop_step, self.program.actions[-1].step))

    def _out_of_time(self) -> bool:
        """Past the deadline? Then record where the run stopped (:attr:`Outcome.stopped`)."""
        if self.deadline is None or _time.perf_counter() < self.deadline:
            return False
        self.stopped = (
            f"timeout after {self.timeout:g} s at t = {self.step * self.dt:.1f} s simulated (of {self.program.duration:g} s)"
        )
        return True

    def advance(self, target: int) -> None:
        """Step the engine up to ``target`` (or to the end of the settle time after a
        collapse), or until the deadline passes."""
        while self.step < self._limit(target):
            if self.deadline is not None and self.step % CLOCK_EVERY == 0 and self._out_of_time():
                return
            if self.acting and self.options.jump and self.ext.quiet:
                self.skipped += self._limit(target) - self.step
                self.step = self._limit(target)
                return
            if self.program.engine.ccd:
                self._substeps()
            self.client.stepSimulation()
            self.step += 1
            now = self.step * self.dt
            if self.acting:
                self._record(self.ext.update(now))
            if self.collapse is None:
                self.check_collapse(now)

    def _record(self, events: list[StabilityEvent]) -> None:
        for e in events:
            body = self.labels.get(e.label)
            if e.kind == "freeze" and body in self.targets:
                self.moving.discard(body)
                self.settled[body] = self.displacement(body)
            elif e.kind == "wake" and body in self.targets:
                self.moving.add(body)
                self.settled.pop(body, None)
            if e.kind != "impact" or e.source in self.projectiles:  # not every landing brick
                self.events.append(
                    Event(time=e.time, kind=e.kind, brick=e.label, level=self.levels.get(e.label), detail=e.reason)
                )

    def _substeps(self) -> None:
        """Split the step while something is fast, so that no body moves more than the
        collapse threshold (half a brick's thinnest side) in one substep, in at most
        :data:`MAX_SUBSTEPS` (a ``substeps`` event when the cap starts to hold: faster
        bodies then move further per substep, and the run's cost stays bounded).

        A brick thrown lengthwise at 5 m/s moves 21 mm in a 240 Hz step, more than the 8 mm
        it overlaps its target: pybullet then pushes it out up or down and it slips past;
        continuous collision detection does not help (its swept sphere is at the centre of
        mass, 60 mm behind the front). Only while fast bodies move: none, no cost.
        """
        fast = [self.bodies[name] for name in self.projectiles] + (sorted(self.moving) if self.acting else [])
        velocities = np.array([self._velocity(b)[0] for b in fast]).reshape(-1, 3)
        speed = float(np.sqrt((velocities**2).sum(axis=1).max())) if len(fast) else 0.0
        needed = max(1, math.ceil(speed * self.dt / self.program.collapse_threshold))
        substeps = min(needed, MAX_SUBSTEPS)
        if substeps == MAX_SUBSTEPS and self.substeps != MAX_SUBSTEPS:
            fastest = fast[int(np.argmax((velocities**2).sum(axis=1)))]
            name = next(n for n, b in self.bodies.items() if b == fastest)
            self.events.append(
                Event(
                    time=self.step * self.dt,
                    kind="substeps",
                    brick=name,
                    level=self.levels.get(name),
                    detail=f"{speed:.3g} m/s needs {needed} substeps; capped at {MAX_SUBSTEPS}",
                )
            )
        if substeps != self.substeps:
            self.client.setPhysicsEngineParameter(numSubSteps=substeps if substeps > 1 else 0)
            self.substeps = substeps

    def _limit(self, target: int) -> int:
        if self.stop_step is None or not self.options.stop_at_collapse:
            return target
        return min(target, self.stop_step)

    # actions ------------------------------------------------------------------
    def place(self, a: Place) -> None:
        """Put a brick at rest a drop gap above its pose, on what is actually below it.

        The bricks below may have sunk into each other (contact penetration, about 0.05 mm
        a level at 240 Hz): the brick is placed lower by the least they have sunk, as a
        person puts a brick on the stack in front of them, so that a tall tower's newest
        brick does not fall millimetres onto its supports.
        """
        box = Box(np.array(a.brick.half_extents), a.brick.mass)
        nominal = Pose.from_euler(a.position, a.yaw, a.pitch, a.roll)
        corners = box.corners(nominal)
        footprint = MultiPoint(corners[:, :2]).convex_hull
        sink = self._sink(float(corners[:, 2].min()), footprint)
        target = np.array(a.position) - [0.0, 0.0, sink]
        self.record_drift()
        body = self.enter(a.id, a.brick, Pose(target + [0.0, 0.0, a.drop], nominal.orientation))
        self.ext.add_brick(body, box, a.id, a.brick.friction)
        self.levels[a.id] = a.level
        self.targets[body] = (a.id, target)
        local = box.corners(Pose(np.zeros(3)))
        self.corners[body] = (local, box.corners(Pose(target, nominal.orientation)))
        self.placed[body] = (*target.tolist(), *nominal.orientation.tolist(), float(np.linalg.norm(box.half_extents)))
        self.tops.setdefault(round(float(corners[:, 2].max()) * 1e4), []).append((footprint, body, float(a.position[2])))
        self.moving.add(body)
        detail = f"on bricks that have sunk {sink * 1000:.2f} mm" if sink > 5e-5 else ""
        self.events.append(Event(time=a.time, kind="place", brick=a.id, level=a.level, detail=detail))

    def _sink(self, bottom: float, footprint: Polygon) -> float:
        """How far the placed bricks this one will rest on have sunk below their nominal poses (m)."""
        key = round(bottom * 1e4)
        below = [t for k in range(key - 10, key + 11) for t in self.tops.get(k, ())]  # within 1 mm
        sunk = [
            nominal_z - self.client.getBasePositionAndOrientation(body)[0][2]
            for area, body, nominal_z in below
            if area.intersection(footprint).area > 1e-8
        ]
        return max(0.0, min(sunk)) if sunk else 0.0

    def launch(self, a: Launch) -> None:
        """Throw a projectile; with ``ccd`` it gets continuous collision detection (a swept
        sphere of its half thickness, on a body in maximal coordinates)."""
        ccd = self.program.engine.ccd
        body = self.enter(a.id, a.brick, Pose.from_euler(a.position, a.yaw, a.pitch, 0.0), maximal=ccd or None)
        if ccd:
            self.client.changeDynamics(body, -1, ccdSweptSphereRadius=min(a.brick.half_extents))
        self.client.resetBaseVelocity(body, list(a.velocity), [0.0, 0.0, 0.0])
        self.ext.add_brick(body, Box(np.array(a.brick.half_extents), a.brick.mass), a.id, a.brick.friction)
        self.projectiles.add(a.id)
        speed = math.sqrt(sum(v * v for v in a.velocity))
        self.events.append(Event(time=a.time, kind="launch", brick=a.id, detail=f"{speed:.3g} m/s"))

    def enter(self, name: str, spec: BrickSpec, pose: Pose, maximal: bool | None = None) -> int:
        """The body for ``name`` in the engine at ``pose``: created now, or unparked."""
        if name in self.parked:
            body = self.parked[name]
            self.client.resetBasePositionAndOrientation(body, pose.position.tolist(), pose.orientation.tolist())
            self.client.changeDynamics(body, -1, mass=spec.mass)
        else:
            body = self.create(spec, pose, maximal=maximal)
        self.bodies[name] = self.labels[name] = body
        return body

    def create(self, spec: BrickSpec, pose: Pose, mass: float | None = None, maximal: bool | None = None) -> int:
        key = spec.half_extents
        if key not in self.shapes:
            self.shapes[key] = self.client.createCollisionShape(self.p.GEOM_BOX, halfExtents=list(key))
        body: int = self.client.createMultiBody(
            baseMass=spec.mass if mass is None else mass,
            baseCollisionShapeIndex=self.shapes[key],
            basePosition=pose.position.tolist(),
            baseOrientation=pose.orientation.tolist(),
            useMaximalCoordinates=self.program.engine.maximal_coordinates if maximal is None else maximal,
        )
        self._material(body, spec.friction, spec.restitution)
        return body

    def _material(self, body: int, friction: float, restitution: float) -> None:
        self.client.changeDynamics(
            body,
            -1,
            lateralFriction=math.sqrt(friction),
            restitution=math.sqrt(restitution),
            frictionAnchor=int(self.program.engine.friction_anchors),
        )

    # collapse -----------------------------------------------------------------
    def displacement(self, body: int) -> float:
        """Metres a structure brick is from its placed pose (see :meth:`displacements`)."""
        return float(self.displacements([body])[0])

    def displacements(self, bodies: list[int]) -> np.ndarray:
        """How far each brick's farthest-moved corner is from where it was placed, metres
        (a brick tipping in place counts, not only one whose centre moves); all bricks at
        once, since raw and tuned modes ask this of every brick at every step."""
        if not bodies:
            return np.zeros(0)
        states = [self._state(b) for b in bodies]
        rotations = _rotations(np.array([q for _, q in states]))
        if self._stacked[0] != tuple(bodies):
            self._stacked = (
                tuple(bodies),
                np.stack([self.corners[b][0] for b in bodies]),
                np.stack([self.corners[b][1] for b in bodies]),
            )
        _, local, placed = self._stacked
        now = np.array([p for p, _ in states])[:, None, :] + np.einsum("nij,nkj->nki", rotations, local)
        farthest: np.ndarray = np.sqrt(((now - placed) ** 2).sum(axis=2).max(axis=1))
        return farthest

    def _may_have_moved(self, body: int, threshold: float) -> bool:
        """Could a corner of ``body`` be more than ``threshold`` from where it was placed?
        A bound, in plain floats: the centre's displacement plus the most a corner can
        move in the rotation since placing, 2 r sin(angle / 2) for the half diagonal r
        (cos(angle / 2) = |q . q0| for unit quaternions)."""
        (x, y, z), (qx, qy, qz, qw) = self._state(body)
        x0, y0, z0, qx0, qy0, qz0, qw0, r = self.placed[body]
        cos_half = abs(qx * qx0 + qy * qy0 + qz * qz0 + qw * qw0)
        turn = 2.0 * r * math.sqrt(max(0.0, 1.0 - cos_half * cos_half))
        return math.sqrt((x - x0) ** 2 + (y - y0) ** 2 + (z - z0) ** 2) + turn > threshold

    def check_collapse(self, now: float) -> None:
        """Record the first structure brick that left its placed pose (the collapse level)."""
        threshold = self.program.collapse_threshold
        bodies = [b for b in sorted(self.moving) if self._may_have_moved(b, threshold)]
        for body, moved in zip(bodies, self.displacements(bodies)):
            if moved > threshold:
                brick = self.targets[body][0]
                level = max(self.levels.values())
                self.record_drift()
                self.collapse = Collapse(
                    level=level, time=now, brick=brick, brick_level=self.levels[brick], displacement=float(moved)
                )
                self.events.append(
                    Event(
                        time=now,
                        kind="collapse",
                        brick=brick,
                        level=self.levels[brick],
                        detail=f"moved {moved * 1000:.1f} mm; collapse level {level}",
                    )
                )
                self.collapse_graph = self.graph()
                self.stop_step = self.step + round(self.program.settle / self.dt)
                return

    def record_drift(self) -> None:
        """Track the largest displacement of the standing structure until the first collapse."""
        if self.collapse is None:
            now = [*self.displacements(sorted(self.moving)), *self.settled.values()]  # frozen bricks do not move
            self.drift = max([self.drift, *(d for d in now if d <= self.program.collapse_threshold)])

    def kinetic_energy(self, body: int) -> float:
        """Joules of a brick's linear and angular motion (its inertia as a uniform box)."""
        linear, angular = (np.array(v) for v in self.client.getBaseVelocity(body))
        mass, inertia = float(self.client.getDynamicsInfo(body, -1)[0]), np.array(self.client.getDynamicsInfo(body, -1)[2])
        rotation = np.reshape(self.client.getMatrixFromQuaternion(self.client.getBasePositionAndOrientation(body)[1]), (3, 3))
        local = rotation.T @ angular
        return 0.5 * mass * float(linear @ linear) + 0.5 * float(local @ (inertia * local))

    # results ------------------------------------------------------------------
    def graph(self) -> Graph:
        return Graph.from_stability(self.ext.graph(), self.levels)

    def outcome(self, wall_time: float) -> Outcome:
        self.record_drift()
        return Outcome(
            scenario=self.program.name,
            mode=self.program.engine.mode,
            collapse=self.collapse,
            events=tuple(self.events),
            final_graph=self.graph(),
            collapse_graph=self.collapse_graph,
            displacement={self.targets[b][0]: float(d) for b, d in zip(self.targets, self.displacements(list(self.targets)))},
            drift=self.drift,
            kinetic_energy=sum(map(self.kinetic_energy, self.targets)),
            levels_placed=max(self.levels.values(), default=0),
            bricks_placed=len(self.levels),
            simulated_time=self.step * self.dt,
            wall_time=wall_time,
            steps=self.step - self.skipped,
            steps_skipped=self.skipped,
            stopped=self.stopped,
        )

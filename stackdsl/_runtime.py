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

Source: DESIGN.md (collapse, modes, pybullet facts).
"""

from __future__ import annotations

import ctypes
import math
import os
import sys
import time as _time
from contextlib import contextmanager
from typing import Any, Iterator

import numpy as np

from stability import Box, BrickState, Plane, Pose, PyBulletEngine, StabilityConfig, StabilityExtension

from ._outcome import Collapse, Event, Graph, Outcome
from ._program import BrickSpec, Launch, Place, Program


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


def run_program(program: Program) -> Outcome:
    """Run a compiled program and report what happened.

    Raises:
        pybullet.error: the engine failed (not expected for a compiled program).
    """
    start = _time.perf_counter()
    with direct_client() as client:
        runner = _Runner(client, program)
        runner.execute()
        return runner.outcome(_time.perf_counter() - start)


class _Runner:
    """The state of one run: engine, extension, bodies, timeline, collapse."""

    def __init__(self, client: Any, program: Program) -> None:
        import pybullet

        self.p, self.client, self.program = pybullet, client, program
        e = program.engine
        self.dt = e.timestep
        self.acting = e.mode == "extension"
        client.setGravity(0.0, 0.0, -e.gravity)
        client.setTimeStep(e.timestep)
        client.setPhysicsEngineParameter(numSolverIterations=e.solver_iterations)
        ground = client.createMultiBody(0.0, client.createCollisionShape(pybullet.GEOM_PLANE))
        self._material(ground, program.ground_friction, program.ground_restitution)
        rules = {r.name: r.on for r in program.rules}
        config = StabilityConfig(**program.stability, leaning=rules["leaning"], impacts=rules["impacts"])
        self.ext = StabilityExtension(PyBulletEngine(client), config)
        self.ext.add_ground(ground, Plane(0.0), friction=program.ground_friction)
        self.shapes: dict[tuple, int] = {}
        for f in program.fixtures:
            body = self.create(f.brick, Pose.from_euler(f.position, f.yaw, f.pitch, f.roll), mass=0.0)
            self.ext.add_ground(body, Box(np.array(f.brick.half_extents), f.brick.mass), f.id, f.brick.friction)
        self.bodies: dict[str, int] = {}
        self.projectiles: set[str] = set()
        self.levels: dict[str, int] = {}
        self.targets: dict[int, tuple[str, np.ndarray]] = {}
        self.events: list[Event] = []
        self.collapse: Collapse | None = None
        self.collapse_graph: Graph | None = None
        self.stop_step: int | None = None
        self.step = 0
        self.skipped = 0

    # lifecycle ----------------------------------------------------------------
    def execute(self) -> None:
        for action in self.program.actions:
            self.advance(action.step)
            if self.stop_step is not None:
                break
            if isinstance(action, Place):
                self.place(action)
            elif isinstance(action, Launch):
                self.launch(action)
        if self.stop_step is not None:
            self.advance(min(self.stop_step, self.program.actions[-1].step))

    def advance(self, target: int) -> None:
        """Step the engine up to ``target`` (or to the end of the settle time after a collapse)."""
        while self.step < self._limit(target):
            if self.acting and self.ext.quiet:
                self.skipped += self._limit(target) - self.step
                self.step = self._limit(target)
                return
            self.client.stepSimulation()
            self.step += 1
            now = self.step * self.dt
            if self.acting:
                for e in self.ext.update(now):
                    if e.kind != "impact" or e.source in self.projectiles:  # not every landing brick
                        self.events.append(Event(time=e.time, kind=e.kind, brick=e.label, level=self.levels.get(e.label), detail=e.reason))
            if self.collapse is None:
                self.check_collapse(now)

    def _limit(self, target: int) -> int:
        return target if self.stop_step is None else min(target, self.stop_step)

    # actions ------------------------------------------------------------------
    def place(self, a: Place) -> None:
        pose = Pose.from_euler(np.array(a.position) + [0.0, 0.0, a.drop], a.yaw, a.pitch, a.roll)
        body = self.create(a.brick, pose)
        self.ext.add_brick(body, Box(np.array(a.brick.half_extents), a.brick.mass), a.id, a.brick.friction)
        self.bodies[a.id], self.levels[a.id] = body, a.level
        self.targets[body] = (a.id, np.array(a.position))
        self.events.append(Event(time=a.time, kind="place", brick=a.id, level=a.level))

    def launch(self, a: Launch) -> None:
        body = self.create(a.brick, Pose.from_euler(a.position, a.yaw, a.pitch, 0.0))
        self.client.resetBaseVelocity(body, list(a.velocity), [0.0, 0.0, 0.0])
        self.ext.add_brick(body, Box(np.array(a.brick.half_extents), a.brick.mass), a.id, a.brick.friction)
        self.bodies[a.id] = body
        self.projectiles.add(a.id)
        speed = math.sqrt(sum(v * v for v in a.velocity))
        self.events.append(Event(time=a.time, kind="launch", brick=a.id, detail=f"{speed:.3g} m/s"))

    def create(self, spec: BrickSpec, pose: Pose, mass: float | None = None) -> int:
        key = spec.half_extents
        if key not in self.shapes:
            self.shapes[key] = self.client.createCollisionShape(self.p.GEOM_BOX, halfExtents=list(key))
        body = self.client.createMultiBody(
            baseMass=spec.mass if mass is None else mass,
            baseCollisionShapeIndex=self.shapes[key],
            basePosition=pose.position.tolist(),
            baseOrientation=pose.orientation.tolist(),
            useMaximalCoordinates=self.program.engine.maximal_coordinates,
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
    def check_collapse(self, now: float) -> None:
        """Record the first structure brick that left its placed pose (DESIGN.md, collapse)."""
        threshold = self.program.collapse_threshold
        for body, (brick, target) in self.targets.items():
            if self.acting and self.ext.state(body) is BrickState.FROZEN:
                continue
            moved = float(np.linalg.norm(np.array(self.client.getBasePositionAndOrientation(body)[0]) - target))
            if moved > threshold:
                level = max(self.levels.values())
                self.collapse = Collapse(level=level, time=now, brick=brick, brick_level=self.levels[brick], displacement=moved)
                self.events.append(Event(time=now, kind="collapse", brick=brick, level=self.levels[brick], detail=f"moved {moved * 1000:.1f} mm; collapse level {level}"))
                self.collapse_graph = self.graph()
                self.stop_step = self.step + round(self.program.settle / self.dt)
                return

    # results ------------------------------------------------------------------
    def graph(self) -> Graph:
        return Graph.from_stability(self.ext.graph(), self.levels)

    def outcome(self, wall_time: float) -> Outcome:
        displacement = {
            brick: float(np.linalg.norm(np.array(self.client.getBasePositionAndOrientation(body)[0]) - target))
            for body, (brick, target) in self.targets.items()
        }
        return Outcome(
            scenario=self.program.name,
            mode=self.program.engine.mode,
            collapse=self.collapse,
            events=tuple(self.events),
            final_graph=self.graph(),
            collapse_graph=self.collapse_graph,
            displacement=displacement,
            levels_placed=max(self.levels.values(), default=0),
            bricks_placed=len(self.levels),
            simulated_time=self.step * self.dt,
            wall_time=wall_time,
            steps=self.step - self.skipped,
            steps_skipped=self.skipped,
        )

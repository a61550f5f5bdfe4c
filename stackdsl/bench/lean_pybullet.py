"""The lean pybullet peer: a scene run as a pybullet user would write it, for the bench to beat.

:func:`run_lean` takes a compiled :class:`stackdsl.compile.program.Program` (its bricks, their
placing times and poses, its pybullet settings) and runs it without stackdsl's step loop: a
DIRECT client of its own, a ground plane, each brick created as a box (``createMultiBody``)
when its time comes, and ``stepSimulation`` called in a plain loop. The collapse is watched as
every lean peer watches it (:class:`stackdsl.bench.lean.CollapseWatch`), from pybullet's own
base poses; the run stops when the collapse is decided (or ``settle`` seconds after it, placing
nothing more), or at the program's end.

Settings are the program's (``engine: {mode: raw}`` is raw pybullet: 240 Hz, 50 solver
iterations, multibodies): timestep, solver iterations, gravity, maximal coordinates and
friction anchors; each body's friction and restitution the square root of its material's, as
pybullet multiplies a pair's. A brick is placed at rest at its pose, lowered by pybullet's seat
(:attr:`stackdsl.engines.pybullet.settings.PyBulletSettings.SEAT`, 0.01 mm: placed at zero
distance the box collider finds two of the four corners of its contact patch at first, and a
brick near its support's edge tips): the gentlest placement a user can write. Not the scene's
drop gap, as the extension and the lean MuJoCo peer place: let go 0.5 mm above its pose, raw
pybullet fell at another level on 6 of the 16 bench scenes (a level closer to the closed form on
four, further on two), and a change made for a fair timing must not move a peer's levels.

Only placements are taken (the bench's scenes); a program that launches a projectile or has
fixed bodies raises ValueError. Units: SI. Source: stackdsl's own, on pybullet 3.2.7.

>>> from stackdsl import compile_scenario, parse_scenario
>>> text = "stackdsl: 1\\nstructure: {tower: {levels: 3}}\\nengine: {mode: raw}\\n"
>>> lean = run_lean(compile_scenario(parse_scenario(text, "t.yaml")))
>>> lean.level is None, lean.steps > 0, 0.0 < lean.engine <= lean.wall
(True, True, True)
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from stability import Pose

from ..compile.program import Launch, Program
from ..engines.pybullet.client import quiet_c_output
from ..engines.pybullet.settings import PyBulletSettings
from .lean import WATCH_RATE, CollapseWatch, LeanOutcome


def run_lean(program: Program, timeout: float = 600.0, settle: float | None = 0.0) -> LeanOutcome:
    """Run ``program`` in the lean loop (see the module's description) for at most
    ``timeout`` wall seconds (then the level so far is returned), going on ``settle`` seconds
    after a collapse is decided with nothing more placed (0: the run ends there; None: the
    program's settle time), as :func:`stackdsl.bench.lean_mujoco.run_lean` does.

    Raises:
        ValueError: the program's engine is not pybullet, or it has fixtures or launches.
    """
    with quiet_c_output():  # pybullet prints its build time when imported, and more when connecting
        import pybullet

    e = program.engine
    if not isinstance(e, PyBulletSettings):
        raise ValueError("the lean pybullet peer runs programs compiled for pybullet (engine: {backend: pybullet})")
    if program.fixtures or any(isinstance(a, Launch) for a in program.actions):
        raise ValueError("the lean pybullet peer runs placements only: no fixed bodies, no projectiles")
    started = time.perf_counter()
    with quiet_c_output():
        client = pybullet.connect(pybullet.DIRECT)
    try:
        after = program.settle if settle is None else settle
        return _run(pybullet, client, program, e, started, timeout, after)
    finally:
        pybullet.disconnect(client)


def _run(
    p: Any, client: int, program: Program, e: PyBulletSettings, started: float, timeout: float, settle: float
) -> LeanOutcome:
    """The loop of :func:`run_lean` on a connected ``client`` of the ``pybullet`` module ``p``."""
    kw = {"physicsClientId": client}
    p.setGravity(0.0, 0.0, -e.gravity, **kw)
    p.setTimeStep(e.timestep, **kw)
    p.setPhysicsEngineParameter(numSolverIterations=e.solver_iterations, **kw)
    plane = p.createMultiBody(0.0, p.createCollisionShape(p.GEOM_PLANE, **kw), **kw)
    ground = math.sqrt(program.ground_friction)
    p.changeDynamics(plane, -1, lateralFriction=ground, restitution=math.sqrt(program.ground_restitution), **kw)
    places = program.placements
    watch = CollapseWatch(np.array([a.brick.half_extents for a in places]), program.collapse_threshold)
    poses = [Pose.from_euler(a.position, a.yaw, a.pitch, a.roll) for a in places]  # as stackdsl places them
    shapes: dict[tuple[float, float, float], int] = {}
    bodies: list[int] = []
    every = max(1, round(1.0 / (WATCH_RATE * e.timestep)))
    step, engine, now = 0, 0.0, 0.0
    end, decided, decided_at = program.duration, False, 0.0  # once a collapse is decided: ``settle`` more
    while now < end - 1e-9 and time.perf_counter() - started < timeout:
        while not decided and len(bodies) < len(places) and places[len(bodies)].time <= now + 1e-9:
            a, k = places[len(bodies)], len(bodies)
            half = a.brick.half_extents
            if half not in shapes:
                shapes[half] = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(half), **kw)
            at = poses[k].position - [0.0, 0.0, e.SEAT]
            body = p.createMultiBody(
                a.brick.mass,
                shapes[half],
                basePosition=at.tolist(),
                baseOrientation=poses[k].orientation.tolist(),
                useMaximalCoordinates=e.maximal_coordinates,
                **kw,
            )
            p.changeDynamics(
                body,
                -1,
                lateralFriction=math.sqrt(a.brick.friction),
                restitution=math.sqrt(a.brick.restitution),
                frictionAnchor=int(e.friction_anchors),
                **kw,
            )
            bodies.append(body)
            watch.place(k, a.level, at, poses[k].rotation)
        tick = time.perf_counter()
        for _ in range(every):
            p.stepSimulation(**kw)
        engine += time.perf_counter() - tick
        step += every
        now = step * e.timestep
        if not decided and bodies:
            now_at = [p.getBasePositionAndOrientation(b, **kw) for b in bodies]
            if watch.look(now, np.array([q[0] for q in now_at]), Rotation.from_quat([q[1] for q in now_at]).as_matrix()):
                decided, decided_at, end = True, time.perf_counter(), min(end, now + settle)
    after = time.perf_counter() - decided_at if decided else 0.0
    return LeanOutcome(watch.level, time.perf_counter() - started, engine, now, step, after_collapse=after)

"""The lean MuJoCo peer: a scene run as a MuJoCo user would write it, for the bench to beat.

:func:`run_lean` takes a compiled :class:`stackdsl.compile.program.Program` (its bricks, their
placing times and poses, its MuJoCo settings) and runs it without stackdsl's step loop: one
MJCF model with every brick declared up front as a free body with a box geom, the bricks
not yet placed parked on the ground far away (where MuJoCo's own sleeping puts them to
sleep), ``mujoco.mj_step`` called in a plain loop, and a brick placed by writing its free
joint's position and velocity and calling ``mujoco.mj_forward`` (which wakes it). The
collapse is watched as every lean peer watches it (:class:`stackdsl.bench.lean.CollapseWatch`),
from MuJoCo's own body frames (``xpos``, ``xmat``); the run stops when the collapse is decided,
or at the program's end.

Settings are the program's (``engine: {backend: mujoco, mode: tuned, sleep_tolerance: 1e-3}``
is the peer at its best, :data:`stackdsl.bench.bench.LEAN_SLEEP_TOLERANCE`): timestep, solver
iterations, cone, impratio, integrator, contact softness and sleeping. A brick is let go at rest the scene's
drop gap (each placement's ``drop``, 0.5 mm by default) above its pose, as the scenario asks
and as the extension places it, and is watched against its pose. Placed exactly at its pose
instead, in contact, as this peer used to be, it falls at the same levels; on the upright
30-level 4 stack at sleep tolerance 1e-4 it took 10.5 to 18.5 s against 3.5 to 5.3 s with the
drop gap (three rounds in one process, load 3.3 to 4.6 on 2 cores; about 93 contacts a step
against 50), time the scenario does not ask of it. At 1e-3 the two placements cost about the
same there (1.9 to 2.5 s in contact, 2.0 to 6.0 s with the gap, the same rounds).

Only placements are taken (the bench's scenes); a program that launches a projectile or
has fixed bodies raises ValueError. Units: SI. Source: stackdsl's own, on MuJoCo 4.0's
Python bindings (``MjModel.from_xml_string``, ``mj_step``, ``mj_forward``).

>>> from stackdsl import compile_scenario, parse_scenario
>>> text = "stackdsl: 1\\nstructure: {tower: {levels: 3}}\\nengine: {backend: mujoco, mode: tuned}\\n"
>>> lean = run_lean(compile_scenario(parse_scenario(text, "t.yaml")))
>>> lean.level is None, lean.steps > 0, 0.0 < lean.engine <= lean.wall
(True, True, True)
"""

from __future__ import annotations

import time

import numpy as np

from stability import Pose

from ..compile.program import Launch, Place, Program
from ..engines.mujoco.settings import MuJoCoSettings
from .lean import WATCH_RATE, CollapseWatch, LeanOutcome

_PARK = np.array([5000.0, 5000.0])  # m: where the bricks not yet placed wait, on the ground
_SLOT = 0.5  # m between two of them


def mjcf(program: Program) -> str:
    """The MJCF of ``program``'s scene: the ground, and every brick a free body with a box
    geom of its size, mass and friction, parked on the ground far away.

    Raises:
        ValueError: the program's engine is not MuJoCo, or it has fixtures or launches.
    """
    e = program.engine
    if not isinstance(e, MuJoCoSettings):
        raise ValueError("the lean MuJoCo peer runs programs compiled for MuJoCo (engine: {backend: mujoco})")
    if program.fixtures or any(isinstance(a, Launch) for a in program.actions):
        raise ValueError("the lean MuJoCo peer runs placements only: no fixed bodies, no projectiles")
    cone = "elliptic" if e.elliptic_cones else "pyramidal"
    flags = '<flag sleep="enable"/>' if e.sleep_tolerance is not None else ""
    sleep = f' sleep_tolerance="{e.sleep_tolerance}"' if e.sleep_tolerance is not None else ""
    solref = f"{e.solref[0]} {e.solref[1]}"
    solimp = f"{e.solimp[0]} {e.solimp[1]} {e.solimp[2]} 0.5 2"
    bodies = []
    for k, p in enumerate(program.placements):
        hx, hy, hz = p.brick.half_extents
        x, y = _PARK + [_SLOT * k, 0.0]
        bodies.append(
            f'<body name="{p.id}" pos="{x} {y} {hz}"><freejoint/>'
            f'<geom type="box" size="{hx} {hy} {hz}" mass="{p.brick.mass}" friction="{p.brick.friction} 0.005 0.0001" '
            f'solref="{solref}" solimp="{solimp}"/></body>'
        )
    return (
        f'<mujoco><option timestep="{e.timestep}" iterations="{e.solver_iterations}" cone="{cone}" '
        f'impratio="{e.impratio}" integrator="{e.integrator}" gravity="0 0 {-e.gravity}"{sleep}>{flags}</option>'
        f'<worldbody><geom type="plane" size="0 0 1" friction="{program.ground_friction} 0.005 0.0001" '
        f'solref="{solref}" solimp="{solimp}"/>{"".join(bodies)}</worldbody></mujoco>'
    )


def run_lean(program: Program, timeout: float = 600.0) -> LeanOutcome:
    """Run ``program`` in the lean loop (see the module's description) for at most
    ``timeout`` wall seconds (then the level so far is returned).

    Raises:
        ValueError: as :func:`mjcf`.
    """
    import mujoco

    started = time.perf_counter()
    model = mujoco.MjModel.from_xml_string(mjcf(program))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    places = program.placements
    adr = np.array([model.jnt_qposadr[model.body_jntadr[model.body(p.id).id]] for p in places], dtype=int)
    dof = np.array([model.jnt_dofadr[model.body_jntadr[model.body(p.id).id]] for p in places], dtype=int)
    body = np.array([model.body(p.id).id for p in places], dtype=int)
    watch = CollapseWatch(np.array([p.brick.half_extents for p in places]), program.collapse_threshold)
    dt = model.opt.timestep
    every = max(1, round(1.0 / (WATCH_RATE * dt)))
    end = program.duration
    placed, steps, engine = 0, 0, 0.0
    while data.time < end - 1e-9 and time.perf_counter() - started < timeout:
        while placed < len(places) and places[placed].time <= data.time + 1e-9:
            p = places[placed]
            rest = np.asarray(p.position) - [0.0, 0.0, program.engine.SEAT]  # where it comes to rest
            data.qpos[adr[placed] : adr[placed] + 3] = rest + [0.0, 0.0, p.drop]  # let go the drop gap above
            data.qpos[adr[placed] + 3 : adr[placed] + 7] = _quat(p)
            data.qvel[dof[placed] : dof[placed] + 6] = 0.0
            mujoco.mj_forward(model, data)  # moving a body by hand and forwarding wakes it
            watch.place(placed, p.level, rest, data.xmat[body[placed]].reshape(3, 3))
            placed += 1
        tick = time.perf_counter()
        for _ in range(every):
            mujoco.mj_step(model, data)
        engine += time.perf_counter() - tick
        steps += every
        if watch.look(float(data.time), data.xpos[body[:placed]], data.xmat[body[:placed]].reshape(-1, 3, 3)):
            break
    return LeanOutcome(watch.level, time.perf_counter() - started, engine, float(data.time), steps)


def _quat(p: Place) -> np.ndarray:
    """``p``'s orientation as MuJoCo's (w, x, y, z) quaternion."""
    x, y, z, w = Pose.from_euler(p.position, p.yaw, p.pitch, p.roll).orientation
    return np.array([w, x, y, z])

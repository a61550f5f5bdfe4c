"""A timing harness that shares no code with ``stackdsl bench``: the extension against MuJoCo and
pybullet each driven by a loop written here, interleaved on the bench's scenes, to check that the
bench's ratios are not an artefact of its own machinery.

    python docs/results/independent_timing.py [ROUNDS] [FAMILY,...]

For each scene, in every round and in turn:

- **extension**: stackdsl's public API as a user calls it (``parse_scenario``,
  ``compile_scenario``, ``run_program``), the run ending where its collapse is decided;
- **MuJoCo**: a model built with ``mujoco.MjSpec`` (not the bench's MJCF text), tuned MuJoCo with its
  own sleeping (the settings of ``engine: {backend: mujoco, mode: tuned, sleep_tolerance: T}``),
  every brick a free body parked far away until its time, ``mj_step`` in a plain loop; run at both
  sleep tolerances the bench chose between, MuJoCo's default T = 1e-3 and 1e-4, so that the
  table shows on its own whether the looser one keeps the levels and what it saves;
- **pybullet**: pybullet at 240 Hz as a user writes it, each brick created at its time.

Both peers let a brick go at rest the scene's drop gap (``drop`` of each placement, 0.5 mm)
above its pose, as the extension does and as a user's own code would.

A peer's collapse is a placed brick with a corner that has left its place by more than the
scene's collapse threshold for 0.2 s; the level is the highest placed when that began. The peer
stops there, or at the scene's end. Each cell's median wall time over the rounds is kept; the
load average is printed before and after. The scene definitions (brick poses, times, sizes,
masses, friction) are read from the compiled program: the scene is the bench's, the driving is
not. Output: a markdown table (docs/results/speed-against-error.md, "An independent harness").
"""

from __future__ import annotations

import math
import os
import statistics
import sys
import time

import numpy as np
import pybullet
from scipy.spatial.transform import Rotation

import stackdsl
from stackdsl.bench.bench import scenes
from stackdsl.runtime.run import RunOptions

WINDOW = 0.2  # s a brick must stay displaced
WATCH = 1 / 60  # s between two looks at the bricks
SIGNS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)


def _scene_text(structure: str, engine: str) -> str:
    return f"stackdsl: 1\nstructure: {{{structure}}}\nengine: {{{engine}}}\n"


def _rotation(p: stackdsl.Place) -> Rotation:
    return Rotation.from_euler("ZYX", [p.yaw, p.pitch, p.roll], degrees=True)


def _targets(places: list[stackdsl.Place]) -> np.ndarray:
    """Each brick's corners where it is placed, shape (n, 8, 3)."""
    half = np.array([p.brick.half_extents for p in places])
    return _corners(half, np.array([p.position for p in places]), np.stack([_rotation(p).as_matrix() for p in places]))


def _corners(half: np.ndarray, centres: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """The corners of boxes of half extents ``half`` (n, 3) at ``centres`` (n, 3) turned by
    ``rotations`` (n, 3, 3): shape (n, 8, 3)."""
    local = SIGNS[None, :, :] * half[:, None, :]
    return centres[:, None, :] + np.einsum("nij,nkj->nki", rotations, local)


def _watch(
    corners: np.ndarray, targets: np.ndarray, threshold: float, state: dict[str, float | None], now: float, level: int
) -> bool:
    """Update the collapse watch; True when the collapse is decided."""
    moved = float(np.linalg.norm(corners - targets, axis=2).max()) if len(corners) else 0.0
    if moved > threshold:
        if state["since"] is None:
            state["since"], state["level"] = now, level
        elif now - state["since"] >= WINDOW - 1e-9:
            return True
    else:
        state["since"] = None
    return False


def run_mujoco(program: stackdsl.Program) -> tuple[int | None, float]:
    import mujoco

    started = time.perf_counter()
    e = program.engine
    spec = mujoco.MjSpec()
    spec.option.timestep = e.timestep
    spec.option.iterations = e.solver_iterations
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC if e.elliptic_cones else mujoco.mjtCone.mjCONE_PYRAMIDAL
    spec.option.impratio = e.impratio
    spec.option.gravity = [0.0, 0.0, -e.gravity]
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{e.integrator.upper()}")
    if e.sleep_tolerance is not None:
        spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
        spec.option.sleep_tolerance = e.sleep_tolerance
    solref, solimp = list(e.solref), [*e.solimp, 0.5, 2.0]
    ground = spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1])
    ground.friction, ground.solref, ground.solimp = [program.ground_friction, 0.005, 0.0001], solref, solimp
    places = program.placements
    for k, p in enumerate(places):
        body = spec.worldbody.add_body(name=p.id, pos=[1000.0 + 0.5 * k, 1000.0, p.brick.half_extents[2]])
        body.add_freejoint()
        g = body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=list(p.brick.half_extents), mass=p.brick.mass)
        g.friction, g.solref, g.solimp = [p.brick.friction, 0.005, 0.0001], solref, solimp
    model = spec.compile()
    data = mujoco.MjData(model)
    ids = [model.body(p.id).id for p in places]
    qpos = [model.jnt_qposadr[model.body_jntadr[i]] for i in ids]
    qvel = [model.jnt_dofadr[model.body_jntadr[i]] for i in ids]
    targets, half = _targets(places), np.array([p.brick.half_extents for p in places])
    every = max(1, round(WATCH / model.opt.timestep))
    state: dict[str, float | None] = {"since": None, "level": None}
    placed = level = 0
    while data.time < program.duration - 1e-9:
        while placed < len(places) and places[placed].time <= data.time + 1e-9:
            p = places[placed]
            x, y, z, w = _rotation(p).as_quat()
            x0, y0, z0 = p.position
            data.qpos[qpos[placed] : qpos[placed] + 7] = [x0, y0, z0 + p.drop, w, x, y, z]  # the drop gap above
            data.qvel[qvel[placed] : qvel[placed] + 6] = 0.0
            mujoco.mj_forward(model, data)
            level, placed = max(level, p.level), placed + 1
        for _ in range(every):
            mujoco.mj_step(model, data)
        corners = _corners(half[:placed], data.xpos[ids[:placed]], data.xmat[ids[:placed]].reshape(-1, 3, 3))
        if _watch(corners, targets[:placed], program.collapse_threshold, state, data.time, level):
            break
    decided = state["since"] is not None
    return (int(state["level"]) if decided and state["level"] is not None else None), time.perf_counter() - started


def run_pybullet(program: stackdsl.Program) -> tuple[int | None, float]:
    started = time.perf_counter()
    client = pybullet.connect(pybullet.DIRECT)
    try:
        dt = 1 / 240
        pybullet.setGravity(0, 0, -program.engine.gravity, physicsClientId=client)
        pybullet.setTimeStep(dt, physicsClientId=client)
        plane = pybullet.createMultiBody(
            0, pybullet.createCollisionShape(pybullet.GEOM_PLANE, physicsClientId=client), physicsClientId=client
        )
        pybullet.changeDynamics(plane, -1, lateralFriction=math.sqrt(program.ground_friction), physicsClientId=client)
        places = program.placements
        shapes: dict[tuple[float, ...], int] = {}
        bodies: list[int] = []
        targets, half_all = _targets(places), np.array([p.brick.half_extents for p in places])
        state: dict[str, float | None] = {"since": None, "level": None}
        every, now, level, step = max(1, round(WATCH / dt)), 0.0, 0, 0
        while now < program.duration - 1e-9:
            while len(bodies) < len(places) and places[len(bodies)].time <= now + 1e-9:
                p = places[len(bodies)]
                half = tuple(p.brick.half_extents)
                if half not in shapes:
                    shapes[half] = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half, physicsClientId=client)
                x, y, z = p.position
                b = pybullet.createMultiBody(
                    p.brick.mass,
                    shapes[half],
                    basePosition=[x, y, z + p.drop],
                    baseOrientation=_rotation(p).as_quat(),
                    physicsClientId=client,
                )
                pybullet.changeDynamics(b, -1, lateralFriction=math.sqrt(p.brick.friction), physicsClientId=client)
                bodies.append(b)
                level = max(level, p.level)
            pybullet.stepSimulation(physicsClientId=client)
            step += 1
            now = step * dt
            if step % every == 0 and bodies:
                poses = [pybullet.getBasePositionAndOrientation(b, physicsClientId=client) for b in bodies]
                rotations = Rotation.from_quat([q for _, q in poses]).as_matrix()
                corners = _corners(half_all[: len(bodies)], np.array([x for x, _ in poses]), rotations)
                if _watch(corners, targets[: len(bodies)], program.collapse_threshold, state, now, level):
                    break
        decided = state["since"] is not None
        return (int(state["level"]) if decided and state["level"] is not None else None), time.perf_counter() - started
    finally:
        pybullet.disconnect(client)


def run_extension(program: stackdsl.Program) -> tuple[int | None, float]:
    started = time.perf_counter()
    outcome = stackdsl.run_program(program, RunOptions(stop_at_collapse=True, settle=0.0))
    return (outcome.collapse.level if outcome.collapse else None), time.perf_counter() - started


RUNNERS = {
    "extension": ("mode: extension", run_extension),
    "MuJoCo 1e-3": ("backend: mujoco, mode: tuned, sleep_tolerance: 1e-3", run_mujoco),
    "MuJoCo 1e-4": ("backend: mujoco, mode: tuned, sleep_tolerance: 1e-4", run_mujoco),
    "pybullet 240 Hz": ("mode: raw", run_pybullet),
}


def main(rounds: int, families: list[str] | None) -> None:
    chosen = [s for s in scenes(upright=[30, 60]) if families is None or s.family in families]
    programs = {
        (s.family, s.parameter, name): stackdsl.compile_scenario(stackdsl.parse_scenario(_scene_text(s.structure, eng), "s.yaml"))
        for s in chosen
        for name, (eng, _) in RUNNERS.items()
    }
    for eng, run in RUNNERS.values():  # one-off costs of each driver
        run(stackdsl.compile_scenario(stackdsl.parse_scenario(_scene_text("tower: {levels: 2}", eng), "w.yaml")))
    print(f"load average before: {os.getloadavg()[0]:.2f}, {os.cpu_count()} cores, {rounds} rounds", flush=True)
    walls: dict[tuple[str, float, str], list[float]] = {k: [] for k in programs}
    levels: dict[tuple[str, float, str], int | None] = {}
    for _ in range(rounds):
        for s in chosen:
            for name, (_, run) in RUNNERS.items():
                key = (s.family, s.parameter, name)
                levels[key], wall = run(programs[key])
                walls[key].append(wall)
    print(f"load average after: {os.getloadavg()[0]:.2f}\n")
    names = list(RUNNERS)
    print(
        "| scene | closed form | "
        + " | ".join(f"{n}: level, wall" for n in names)
        + " | "
        + " | ".join(f"{n} / extension" for n in names[1:])
        + " |"
    )
    print("|---|---:|" + "---:|" * (2 * len(names) - 1))  # a cell per runner, a ratio per peer
    for s in chosen:
        med = {n: statistics.median(walls[(s.family, s.parameter, n)]) for n in names}
        cells = [f"{levels[(s.family, s.parameter, n)] or 'stands'}, {med[n]:.3f} s" for n in names]
        ratios = [f"{med[n] / med['extension']:.2f}" for n in names[1:]]
        print(f"| {s.family} {s.parameter:g} | {s.closed_form or 'stands'} | " + " | ".join(cells + ratios) + " |", flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3, sys.argv[2].split(",") if len(sys.argv) > 2 else None)

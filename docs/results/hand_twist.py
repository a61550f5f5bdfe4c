"""A side block of a Jenga level pulled and pushed out: how the level above turns on each MuJoCo setting.

Writes the scene of a 10-level Jenga tower (the blocks of scenarios/jenga_stands.yaml) whose side
block ``L05.1`` is taken out along its length at 40 mm/s, by a hand that pulls it out or by a
finger (20 x 10 x 10 mm) pushing its end 40 mm, its side flush with the middle block's face. Runs each
hand in each setting named and prints a row each: the largest turn about the vertical (deg) and
the largest move of a centre (mm) of the bricks of level 6 when the run ends, and, for the block a
hand moves, how it moved over its first 40 mm: the share of the steps it stood still along its path
(slower than 5 mm/s, stick and slip) and its fastest vertical speed (mm/s).

Settings: ``lean``, the lean MuJoCo peer of ``stackdsl bench`` (its own loop, MuJoCo's contact
everywhere); ``tuned``, tuned MuJoCo in stackdsl's loop; ``tuned-unlimited``, the same with the
friction of a pulled brick's slipping contacts left to MuJoCo
(``stackdsl.engines.mujoco.hands.PULL_SLIP_SPEED`` infinite); ``extension``, the extension on MuJoCo;
``fine``, raw pybullet at a 1/1920 s step (a minute or more a hand).

    python docs/results/hand_twist.py [SETTINGS]
    # e.g. python docs/results/hand_twist.py lean,tuned,tuned-unlimited,extension,fine

Output: docs/actions.md ("A push that slides a brick out from under others").
Source: stackdsl's own.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

TOWER = """stackdsl: 1
name: Jenga 10, side block L05.1 {how}
materials: {{maple: {{density: 700 kg/m^3, friction: 0.4}}}}
brick_types:
  jenga: {{size: [75 mm, 25 mm, 15 mm], material: maple}}
  finger: {{size: [20 mm, 10 mm, 10 mm], material: maple}}
ground: {{material: maple}}
{engine}structure:
  tower: {{levels: 10, bricks_per_layer: 3, spacing: 25.5 mm, turn: 90, brick: jenga}}
timing: {{interval: 0.5 s, settle: 1 s}}
actions:
  - {action}
expect:
  stands: true
"""
PULL = "remove: {brick: L05.1, at: after level 10, speed: 40 mm/s, direction: +x}"
PUSH = (
    "push: {target: {brick: L05.1, offset: [0, 8 mm, 0]}, direction: +x, speed: 40 mm/s, distance: 40 mm, "
    "at: after level 10, pusher: finger}"
)
ABOVE = ("L06.1", "L06.2", "L06.3")
MOVED = "L05.1"
STILL = 0.005  # m/s along the path: the block stands still
FINE = "engine: {timestep: 0.5208333333333334 ms}\n"


@dataclass
class Trace:
    """What the run showed: the level above's largest turn (deg) and move (mm) at the end; the
    moved block's steps, those it stood still, and its fastest vertical speed (m/s)."""

    turn: float = 0.0
    move: float = 0.0
    steps: int = 0
    still: int = 0
    lift: float = 0.0

    def look(self, along: float, up: float) -> None:
        """One step of the moved block: its speed along the path and up (m/s)."""
        self.steps += 1
        self.still += along < STILL
        self.lift = max(self.lift, abs(up))

    def end(self, start: dict[str, tuple[np.ndarray, Rotation]], now: dict[str, tuple[np.ndarray, Rotation]]) -> None:
        """The level above at the end against where it was when the hand began."""
        for b, (p0, r0) in start.items():
            p1, r1 = now[b]
            self.turn = max(self.turn, abs(float((r1 * r0.inv()).as_euler("zyx", degrees=True)[0])))
            self.move = max(self.move, float(np.linalg.norm(p1[:2] - p0[:2])) * 1000)


def scene(hand: str, fine: bool = False) -> str:
    """The scene's YAML with ``hand`` ("pull" or "push")."""
    action, how = (PULL, "pulled by hand") if hand == "pull" else (PUSH, "pushed by a finger")
    return TOWER.format(how=how, engine=FINE if fine else "", action=action)


def in_loop(hand: str, mode: str, backend: str, unlimited: bool = False) -> Trace:
    """Run the scene in stackdsl's loop (``mode`` on ``backend``) and trace it."""
    from stackdsl import compile_scenario, parse_scenario
    from stackdsl.compile.program import Push, Remove
    from stackdsl.engines.mujoco import hands
    from stackdsl.runtime.loop import StepLoop, Subscriber
    from stackdsl.runtime.run import run_in, world_for

    program = compile_scenario(parse_scenario(scene(hand, backend == "pybullet"), "twist.yaml"), mode=mode, backend=backend)
    start_time = next(a.time for a in program.actions if isinstance(a, (Remove, Push)))
    trace = Trace()

    class Watch(Subscriber):
        def __init__(self) -> None:
            self.start: dict[str, tuple[np.ndarray, Rotation]] = {}

        def poses(self, loop: StepLoop) -> dict[str, tuple[np.ndarray, Rotation]]:
            out = {}
            for b in ABOVE:
                p, q = loop.world.pose_floats(loop.structure.records[b].body)
                out[b] = (np.array(p), Rotation.from_quat(q))
            return out

        def after_step(self, loop: StepLoop) -> None:
            if loop.now < start_time:
                return
            if not self.start:
                self.start = self.poses(loop)
            if loop.now <= start_time + 1.0:  # the first 40 mm: the block is in the scene
                (vx, _, vz), _ = loop.world.velocity_floats(loop.structure.records[MOVED].body)
                trace.look(vx, vz)

        def at_end(self, loop: StepLoop) -> None:
            trace.end(self.start, self.poses(loop))

    kept = hands.PULL_SLIP_SPEED
    if unlimited:
        hands.PULL_SLIP_SPEED = math.inf
    try:
        with world_for(program) as world:
            run_in(world, program, subscribers=(Watch(),))
    finally:
        hands.PULL_SLIP_SPEED = kept
    return trace


def lean(hand: str) -> Trace:
    """Run the scene in the lean MuJoCo peer's loop (``stackdsl bench``'s) and trace it."""
    from stackdsl.bench.actions import program_for
    from stackdsl.bench.bench import LEAN_TOLERANCE
    from stackdsl.bench.lean_mujoco import FROM_TOP, _LeanRun
    from stackdsl.compile.program import Push, Remove

    program = program_for(scene(hand), "twist.yaml", "MuJoCo lean")
    start_time = next(a.time for a in program.actions if isinstance(a, (Remove, Push)))
    run = _LeanRun(program, LEAN_TOLERANCE, None, FROM_TOP)
    rows = {b: run.body[run.index[b]] for b in (*ABOVE, MOVED)}
    trace = Trace()
    start: dict[str, tuple[np.ndarray, Rotation]] = {}

    def poses() -> dict[str, tuple[np.ndarray, Rotation]]:
        d = run.data
        return {b: (d.xpos[rows[b]].copy(), Rotation.from_matrix(d.xmat[rows[b]].reshape(3, 3))) for b in ABOVE}

    while run.going():
        now = float(run.data.time)
        run.place_due(now)
        run.start_actions(now)
        if run.step():
            break
        t = float(run.data.time)
        if t >= start_time and not start:
            start = poses()
        if start_time <= t <= start_time + 1.0:
            v = run.data.qvel[run.dof[run.index[MOVED]] : run.dof[run.index[MOVED]] + 3]  # a free joint's: world frame
            trace.look(float(v[0]), float(v[2]))
    trace.end(start, poses())
    return trace


SETTINGS: dict[str, Callable[[str], Trace]] = {
    "lean": lean,
    "tuned": lambda hand: in_loop(hand, "tuned", "mujoco"),
    "tuned-unlimited": lambda hand: in_loop(hand, "tuned", "mujoco", unlimited=True),
    "extension": lambda hand: in_loop(hand, "extension", "mujoco"),
    "fine": lambda hand: in_loop(hand, "raw", "pybullet"),
}


def main(argv: list[str]) -> None:
    names = argv[1].split(",") if len(argv) > 1 else ["lean", "tuned", "tuned-unlimited", "extension"]
    print(
        "| hand | setting | level 6 turned (deg) | level 6 moved (mm) | block still (steps) | block's vertical speed (mm/s) | wall (s) |"
    )
    print("|---|---|---:|---:|---:|---:|---:|")
    for hand in ("pull", "push"):
        for name in names:
            tick = time.perf_counter()
            t = SETTINGS[name](hand)
            wall = time.perf_counter() - tick
            still = f"{t.still} of {t.steps}" if t.steps else "-"
            print(f"| {hand} | {name} | {t.turn:.2f} | {t.move:.1f} | {still} | {t.lift * 1000:.1f} | {wall:.1f} |", flush=True)


if __name__ == "__main__":
    main(sys.argv)

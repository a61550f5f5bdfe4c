"""How a stack shaken past its sliding threshold moves, per setting: as one body, or apart.

Runs one scenario file (a stack with one shake) in each setting named, one after the other in
this process, and prints a line each: the collapse, the wall time and the engine's, how far the
lowest brick slipped on the table by the end of the run (mm, along the shake and across it), the
Coulomb block's slip for the ground's friction coefficient
(:func:`stackdsl.bench.shake_models.coulomb_slip`), and how far the bricks end from where the
rigid motion that best fits all their centres would put them (mm: the largest and the median),
which is 0 for a stack that moved as one body.
Settings (those of ``docs/results/pull_freeze.py``):

* ``ext``: the extension on pybullet (a part that moves as one rigid body rides the table merged);
* ``ext-free``: the same with nothing merged (pybullet's world refuses ``merge``): every brick
  wakes and is simulated while the ground moves, as before the riding parts;
* ``ext-mj``: the extension on MuJoCo (a part that moves as one rigid body rides the table merged);
* ``ext-mj-free``: the same with nothing merged (MuJoCo's world refuses ``merge``), as before
  2026-11-29;
* ``tuned-pb``, ``raw-pb``: pybullet tuned (1 kHz, friction anchors, 150 solver iterations), raw;
* ``tuned-mj``: MuJoCo tuned, with its own sleeping at tolerance 1e-4;
* ``raw-1920``: pybullet raw at a 1/1920 s timestep.

    python docs/results/shake_parts.py FILE SETTING[,SETTING...]

Output: docs/results/shake-table.md, "A stack that slides as one body".
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pull_freeze import setting

from stability import pair_friction
from stackdsl import compile_scenario, parse_scenario
from stackdsl.bench.shake_models import coulomb_slip
from stackdsl.compile.program import Shake
from stackdsl.engines.mujoco.world import MuJoCoWorld
from stackdsl.engines.pybullet.world import PyBulletWorld
from stackdsl.runtime.loop import StepLoop, Subscriber
from stackdsl.runtime.run import outcome, run_in, world_for


class Start(Subscriber):
    """Where every structure brick is as the shake starts (m)."""

    def __init__(self, shake: Shake) -> None:
        self.shake, self.at = shake, dict[str, np.ndarray]()

    def after_step(self, loop: StepLoop) -> None:
        if not self.at and loop.now >= self.shake.time:
            self.at = {i: np.array(loop.world.pose_floats(r.body)[0]) for i, r in loop.structure.records.items()}


def main(path: str, names: list[str]) -> None:
    """Run ``path`` in each setting of ``names`` and print a line each."""
    base = open(path, encoding="utf-8").read()
    print(f"{path}: load average {os.getloadavg()[0]:.1f}", flush=True)
    for name in names:
        text, mode, backend, *_ = setting({"ext-free": "ext", "ext-mj-free": "ext-mj"}.get(name, name), base)
        program = compile_scenario(parse_scenario(text, path), mode, None, backend)
        shake = next(a for a in program.actions if isinstance(a, Shake))
        start = Start(shake)
        merge, mj_merge = PyBulletWorld.merge, MuJoCoWorld.merge
        if name in ("ext-free", "ext-mj-free"):
            PyBulletWorld.merge = lambda self, bodies: False  # type: ignore[method-assign]
            MuJoCoWorld.merge = lambda self, bodies: False  # type: ignore[method-assign]
        try:
            started = time.perf_counter()
            with world_for(program) as world:
                loop = run_in(world, program, subscribers=(start,))
                end = {i: np.array(loop.world.pose_floats(r.body)[0]) for i, r in loop.structure.records.items()}
            wall = time.perf_counter() - started
        finally:
            PyBulletWorld.merge = merge  # type: ignore[method-assign]
            MuJoCoWorld.merge = mj_merge  # type: ignore[method-assign]
        out = outcome(loop, wall)
        if not start.at:
            print(f"{name:9s} collapse {out.collapse.level if out.collapse else None} before the shake: not shaken", flush=True)
            continue
        moved = {i: end[i] - start.at[i] for i in start.at}
        lowest = min(start.at, key=lambda i: (round(float(start.at[i][2]), 4), i))
        along = np.array([shake.direction[0], shake.direction[1], 0.0], dtype=float)
        along /= np.linalg.norm(along)
        slip = moved[lowest]
        # how far each brick ends from where the stack, moved as one rigid body, would put it
        # (the best rigid motion of all the centres: scipy's Kabsch)
        ids = sorted(start.at)
        before = np.array([start.at[i] for i in ids])
        after = np.array([end[i] for i in ids])
        turn, _ = Rotation.align_vectors(after - after.mean(axis=0), before - before.mean(axis=0))
        rigid = turn.apply(before - before.mean(axis=0)) + after.mean(axis=0)
        apart = np.linalg.norm(after - rigid, axis=1) * 1000
        mu = pair_friction(loop.structure.records[lowest].spec.friction, program.ground_friction)
        closed, _ = coulomb_slip(shake.amplitude, shake.frequency, shake.periods, mu)
        collapse = f"collapse {out.collapse.level}" if out.collapse else "stands"
        print(
            f"{name:9s} {collapse:12s} wall {wall:6.2f} s  engine {loop.engine_time:6.2f} s  "
            f"{lowest} slipped {float(slip @ along) * 1000:6.2f} mm along, {float(np.linalg.norm(np.cross(along, slip))) * 1000:5.2f} across "
            f"(Coulomb {closed * 1000:.2f})  off one rigid motion: largest {apart.max():6.2f} mm, median {float(np.median(apart)):6.2f}",
            flush=True,
        )


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2].split(","))

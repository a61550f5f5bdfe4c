"""What keeping the bricks a pull slides between frozen changes: drag and wall time, per setting.

Runs one scenario file in each setting named, one after the other in this process (so that
both sides of a ratio run under the same load), and prints a line each: the collapse, the
largest distance (mm) a brick above ``LEVEL`` ended from where it was placed, the largest of
any standing brick (drift), the wall time of the run, the time in the engine's steps and the
steps taken. Settings:

* ``ext``: the extension on pybullet (a proved pull moves its brick alone: stability/_drag.py);
* ``ext-woken``: the same with every proof refused (the drag held to an impossible safety
  factor): what rests on a pulled brick and the blocks beside it wake, as before the proof;
* ``ext-untied``: the extension with a level tied by the one on it held to the safety of one
  brick alone (``stability._drag.TIE_SAFETY`` set to ``DRAG_SAFETY``): a side pull is stepped,
  a middle pull proved, as before the tied proof;
* ``ext-flat``: the extension with a pull's ride ended once its first rider tilts 0.5 deg or
  drops 1 mm, as before a ride was proved rigid as it moves (:func:`flat_ride`; stability/_ride.py);
* ``ext-free``: the extension on pybullet with nothing merged (pybullet's world refuses
  ``merge``): an unproved pull wakes everything above it, as before the riding group;
* ``ext-mj``: the extension on MuJoCo;
* ``ext-mj-free``: the extension on MuJoCo with nothing merged (MuJoCo's world refuses
  ``merge``), as before 2026-11-29;
* ``tuned-pb``, ``raw-pb``: pybullet tuned (1 kHz, friction anchors, 150 solver iterations), raw;
* ``tuned-mj``: MuJoCo tuned, with its own sleeping at tolerance 1e-4;
* ``raw-1920``, ``ext-1920``: pybullet raw, the extension, at a 1/1920 s timestep;
* ``ext-itN`` (``ext-it100``): the extension with N solver iterations a step (50 by default);
* ``ext-anchors``: the extension with pybullet's friction anchors (tuned mode's).

    python docs/results/pull_freeze.py FILE SETTING[,SETTING...] [LEVEL]
    # LEVEL: the pulled brick's level (default 5); the load average is printed first

Output: docs/results/actions-freeze.md.
"""

from __future__ import annotations

import os
import sys
import time

import stability._drag as drag
import stability._ride as ride
from stability import StabilityExtension
from stackdsl import compile_scenario, parse_scenario, run_program
from stackdsl.engines.mujoco.world import MuJoCoWorld
from stackdsl.engines.pybullet.world import PyBulletWorld

SAFETY = (drag.DRAG_SAFETY, drag.TIE_SAFETY)  # the extension's, before any setting changes them


def flat_ride(self: StabilityExtension, pulled: int, riders: tuple[int, ...], time: float, what: str) -> str | None:
    """The rule a pull's ride ended by before it was proved rigid as it moves: its first rider
    tilted :data:`stability._ride.RIDE_TILT` or dropped :data:`stability._ride.RIDE_DROP` from
    how it froze (``StabilityExtension._tilted`` in its place)."""
    stack = self._stack
    first = stack.bodies[riders[0]]
    assert first.frozen_pose is not None, "a rider is frozen"
    now = stack.engine.pose(first.body)
    tilt, _ = ride.tilt_of(now, first.frozen_pose)
    drop = float(first.frozen_pose.position[2] - now.position[2])
    if tilt > ride.RIDE_TILT:
        return f"{what} as one body until it tilted {tilt:.2f} deg"
    return f"{what} as one body until it dropped {drop * 1000:.2f} mm" if drop > ride.RIDE_DROP else None


def setting(name: str, text: str) -> tuple[str, str, str, float, float]:
    """The scenario text, mode, backend, drag safety factor and tied safety factor of a setting's name."""
    mode, backend, (safety, tie) = "extension", "pybullet", SAFETY
    engine = {
        "tuned-mj": "{backend: mujoco, sleep_tolerance: 0.0001}",
        "raw-1920": "{timestep: 1/1920 s}",
        "ext-1920": "{timestep: 1/1920 s}",
    }.get(name)
    if name == "ext-anchors":
        engine = "{friction_anchors: true}"
    if name.startswith("ext-it"):
        engine = f"{{solver_iterations: {int(name[6:])}}}"
    if engine is not None:
        text = text.replace("structure:", f"engine: {engine}\nstructure:", 1)
    if name == "ext-woken":
        safety, tie = 1e9, 1e9
    elif name == "ext-untied":
        tie = safety
    elif name in ("ext-free", "ext-mj-free"):
        mode = "extension-free"
    elif name in ("tuned-pb", "tuned-mj"):
        mode = "tuned"
    elif name in ("raw-pb", "raw-1920"):
        mode = "raw"
    if name in ("ext-mj", "ext-mj-free", "tuned-mj"):
        backend = "mujoco"
    return text, mode, backend, safety, tie


def main(path: str, names: list[str], level: int) -> None:
    """Run ``path`` in each setting of ``names`` and print a line each."""
    base = open(path, encoding="utf-8").read()
    print(f"{path}: load average {os.getloadavg()[0]:.1f}", flush=True)
    for name in names:
        text, mode, backend, safety, tie = setting(name, base)
        kept, drag.DRAG_SAFETY = drag.DRAG_SAFETY, safety
        kept_tie, drag.TIE_SAFETY = drag.TIE_SAFETY, tie
        merge, mj_merge, tilted = PyBulletWorld.merge, MuJoCoWorld.merge, StabilityExtension._tilted
        if name == "ext-flat":
            StabilityExtension._tilted = flat_ride  # type: ignore[method-assign]
        if mode == "extension-free":
            mode = "extension"
            PyBulletWorld.merge = lambda self, bodies: False  # type: ignore[method-assign]
            MuJoCoWorld.merge = lambda self, bodies: False  # type: ignore[method-assign]
        try:
            program = compile_scenario(parse_scenario(text, path), mode, None, backend)
            started = time.perf_counter()
            out = run_program(program)
            wall = time.perf_counter() - started
        finally:
            drag.DRAG_SAFETY, drag.TIE_SAFETY = kept, kept_tie
            PyBulletWorld.merge = merge  # type: ignore[method-assign]
            MuJoCoWorld.merge = mj_merge  # type: ignore[method-assign]
            StabilityExtension._tilted = tilted  # type: ignore[method-assign]
        above = {b: d for b, d in out.displacement.items() if b[:1] == "L" and int(b[1:3]) > level}
        brick, most = max(above.items(), key=lambda bd: bd[1]) if above else ("-", 0.0)
        collapse = out.collapse.level if out.collapse else None
        print(
            f"{name:9s} collapse {collapse}  above {most * 1000:5.2f} mm ({brick})  drift {out.drift * 1000:5.2f} mm  "
            f"wall {wall:6.2f} s  engine {out.engine_time:6.2f} s  {out.steps} steps",
            flush=True,
        )


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2].split(","), int(sys.argv[3]) if len(sys.argv) > 3 else 5)

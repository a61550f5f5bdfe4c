"""Load shares on a pulled brick's level, and the drag of what it carries, in the engines (no extension).

For each pull of a scenario file, run in each setting named, one after the other in this process:

* the load shares two steps before the pull starts: for each brick resting on the pulled brick's
  level, the normal force (N, the sum of its contact points' ``normal_force``) it puts on each brick
  of that level, that force's share of its total on the level (%), and each brick of the level's share
  of all the load on it; in brackets, the range of the pulled brick's share over the
  0.25 s before the pull, read every step;
* the drag: each brick above the pulled one, its horizontal displacement (mm) from two steps before
  the pull to the pull's end (along the pull and in all), and its rotation about the vertical (deg);
  in brackets, its horizontal creep without a pull, over the 0.4 s before (mm); and the time course:
  the largest of these displacements and the mean rotation after 1/8, 1/4, 1/2, 3/4 and all of the pull.

Settings (tuned mode: the engine alone, every brick simulated):

* ``tuned-pb``: pybullet tuned (1 ms, 150 solver iterations, friction anchors);
* ``tuned-pb-1920``: the same at a 1/1920 s timestep (``engine: {timestep: 1/1920 s}``, no substeps);
* ``tuned-mj``: MuJoCo tuned (2 ms, elliptic cones, impratio 10, implicitfast);
* ``tuned-mj-1920``: the same at a 1/1920 s timestep.

    python docs/results/pull_shares.py FILE SETTING[,SETTING...] [--tall]
    # --tall: the tower made 18 levels, and only a side block of level 10 (L10.3) pulled, after level 18
    # e.g. nice -n 10 python docs/results/pull_shares.py scenarios/jenga_stands.yaml tuned-pb,tuned-mj

A setting takes 20 s (MuJoCo, 2 ms) to 110 s (pybullet, 1/1920 s) of wall time for scenarios/jenga_stands.yaml
(36 bricks, 25.1 s simulated), and up to 110 s with ``--tall`` (54 bricks, 30.1 s), measured with nice -n 10
on a shared 2-core machine.
Source: stackdsl's own.
"""

from __future__ import annotations

import re
import sys
import time

import numpy as np
from scipy.spatial.transform import Rotation

from stackdsl import compile_scenario, parse_scenario, run_program
from stackdsl.compile.program import Remove
from stackdsl.runtime.loop import StepLoop, Subscriber

#: Steps before a pull at which the shares and the starting poses are read.
BEFORE = 2
#: Seconds before a pull over which the shares' range is read, every step.
WINDOW = 0.25
#: Seconds before a pull over which the bricks' creep without a pull is measured (it ends ``BEFORE`` steps before).
CREEP = 0.4
#: Parts of a pull at which the largest displacement of the bricks above it and their mean rotation are read.
PARTS = (0.125, 0.25, 0.5, 0.75)

SETTINGS = {  # name: (backend, engine section or None)
    "tuned-pb": ("pybullet", None),
    "tuned-pb-1920": ("pybullet", "{timestep: 1/1920 s}"),
    "tuned-mj": ("mujoco", None),
    "tuned-mj-1920": ("mujoco", "{timestep: 1/1920 s}"),
}

Poses = dict[str, tuple[np.ndarray, np.ndarray]]  # brick id: position (m), quaternion (x, y, z, w)
Forces = dict[tuple[str, str], float]  # (brick above, brick of the pulled level): N


class Watch(Subscriber):
    """Reads the contact forces on each pulled brick's level every step of the ``WINDOW`` before its
    pull (the last two steps before it), and the poses ``CREEP`` before it, two steps before it and at its end."""

    def __init__(self, pulls: list[Remove], dt: float) -> None:
        self.marks: dict[int, list[tuple[str, str]]] = {}
        self.reads: dict[int, str] = {}  # step: the pull whose level's forces are read then
        for p in pulls:
            during = [(p.step + round(f * (p.end_step - p.step)), f"{f:g}") for f in PARTS]
            for step, what in [
                (p.step - BEFORE - round(CREEP / dt), "creep"),
                (p.step - BEFORE, "before"),
                *during,
                (p.end_step, "end"),
            ]:
                self.marks.setdefault(step, []).append((p.id, what))
            self.reads |= {step: p.id for step in range(p.step - round(WINDOW / dt), p.step - BEFORE + 1)}
        self.poses: dict[tuple[str, str], Poses] = {}
        self.times: dict[tuple[str, str], float] = {}
        self.forces: dict[str, list[Forces]] = {p.id: [] for p in pulls}  # pull: every step's, the last at ``before``

    def after_step(self, loop: StepLoop) -> None:
        records = loop.structure.records
        for mark in self.marks.get(loop.step, []):
            self.times[mark] = loop.now
            self.poses[mark] = {}
            for brick, r in records.items():
                pose = loop.world.pose(r.body)
                self.poses[mark][brick] = (pose.position.copy(), pose.orientation.copy())
        pulled = self.reads.get(loop.step)
        if pulled is not None:
            ids = {r.body: brick for brick, r in records.items()}
            forces: Forces = {}
            for c in loop.world.contact_points():
                if c.body in ids and c.other in ids and level(ids[c.body]) == level(pulled) + 1 == level(ids[c.other]) + 1:
                    pair = (ids[c.body], ids[c.other])
                    forces[pair] = forces.get(pair, 0.0) + c.normal_force
            self.forces[pulled].append(forces)


def level(brick: str) -> int:
    """The level of a tower brick id such as ``L07.3``."""
    return int(brick[1:3])


def tall(text: str) -> str:
    """The scenario made 18 levels, with one pull: L10.3 after level 18, at the file's first pull's speed."""
    text = re.sub(r"levels: 12\b", "levels: 18", text, count=1)
    speed = re.search(r"speed: ([^}]+)}", text)
    assert speed is not None, "no pull speed in the file"
    actions = f"actions:\n  - remove: {{brick: L10.3, at: after level 18, speed: {speed.group(1)}}}\n"
    return re.sub(r"actions:\n(  - .*\n)+", actions, text, count=1)


def share(forces: Forces, above: str | None, pulled: str) -> float:
    """Percent of the load of ``above`` (None: of its whole level) on the level below that ``pulled`` carries."""
    on = {pair: f for pair, f in forces.items() if above is None or pair[0] == above}
    total = sum(on.values())
    return 100 * sum(f for (_, b), f in on.items() if b == pulled) / total if total else 0.0


def yaw(start: tuple[np.ndarray, np.ndarray], then: tuple[np.ndarray, np.ndarray]) -> float:
    """Degrees a brick turned about the vertical from pose ``start`` to pose ``then`` (position, quaternion)."""
    turn = Rotation.from_quat(then[1]) * Rotation.from_quat(start[1]).inv()
    return float(np.degrees(turn.as_euler("ZYX")[0]))


def report(watch: Watch, pull: Remove) -> None:
    """Print the shares and the drag of one pull."""
    pulled = level(pull.id)
    window = watch.forces[pull.id]
    forces = window[-1]
    before = watch.poses[(pull.id, "before")]
    below = sorted(b for b in before if level(b) == pulled)
    print(
        f"  pull {pull.id} at {pull.time:g} s: shares at t = {watch.times[(pull.id, 'before')]:.4f} s "
        f"[{pull.id}'s share over the {WINDOW:g} s before, every step: min-max]"
    )
    for above in sorted(b for b in before if level(b) == pulled + 1):
        on = {b: forces.get((above, b), 0.0) for b in below}
        total = sum(on.values())
        shares = ", ".join(f"{b} {on[b]:6.3f} N {100 * on[b] / total if total else 0:5.1f}%" for b in below)
        seen = [share(f, above, pull.id) for f in window]
        print(f"    {above} on level {pulled}: {shares}  (total {total:.3f} N)  [{min(seen):.1f}-{max(seen):.1f}%]")
    total = sum(forces.values())
    seen = [share(f, None, pull.id) for f in window]
    print(
        f"    the {total:.3f} N on level {pulled}: {', '.join(f'{b} {share(forces, None, b):.1f}%' for b in below)}  "
        f"[{min(seen):.1f}-{max(seen):.1f}%]"
    )
    creep, end = watch.poses[(pull.id, "creep")], watch.poses[(pull.id, "end")]
    along = np.asarray(pull.velocity) / np.linalg.norm(pull.velocity)
    print(
        f"  drag from t = {watch.times[(pull.id, 'before')]:.4f} s to the pull's end at {watch.times[(pull.id, 'end')]:.4f} s "
        f"[creep without a pull, the {CREEP:g} s before]:"
    )
    above = sorted(b for b in before if level(b) > pulled and b in end)
    course = []
    for part in [*(f"{f:g}" for f in PARTS), "end"]:
        then = watch.poses[(pull.id, part)]
        most = max(1000 * np.hypot(*(then[b][0] - before[b][0])[:2]) for b in above)
        course.append(
            f"{watch.times[(pull.id, part)] - pull.time:.3f} s: {most:.3f} mm {np.mean([yaw(before[b], then[b]) for b in above]):.3f} deg"
        )
    print(f"    the bricks above: largest horizontal displacement, mean rotation, after {'; '.join(course)}")
    for brick in above:
        moved = end[brick][0] - before[brick][0]
        crept = 1000 * np.hypot(*(before[brick][0] - creep[brick][0])[:2])
        print(
            f"    {brick}: along the pull {1000 * moved @ along:7.3f} mm, horizontal {1000 * np.hypot(*moved[:2]):7.3f} mm, "
            f"about the vertical {yaw(before[brick], end[brick]):7.3f} deg  [{crept:.3f} mm]"
        )


def main(path: str, names: list[str], make_tall: bool) -> None:
    """Run ``path`` in each setting of ``names`` and print its shares and drags."""
    base = open(path, encoding="utf-8").read()
    if make_tall:
        base = tall(base)
    for name in names:
        backend, engine = SETTINGS[name]
        text = base if engine is None else base.replace("structure:", f"engine: {engine}\nstructure:", 1)
        program = compile_scenario(parse_scenario(text, path), "tuned", None, backend)
        pulls = [a for a in program.actions if isinstance(a, Remove)]
        watch = Watch(pulls, program.engine.timestep)
        started = time.perf_counter()
        out = run_program(program, subscribers=(watch,))
        wall = time.perf_counter() - started
        collapse = out.collapse.level if out.collapse else None
        print(
            f"{name}: timestep {program.engine.timestep:.6g} s, collapse {collapse}, drift {out.drift * 1000:.2f} mm, "
            f"wall {wall:.1f} s, {out.steps} steps",
            flush=True,
        )
        for pull in pulls:
            report(watch, pull)
        sys.stdout.flush()


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2].split(","), "--tall" in sys.argv[3:])

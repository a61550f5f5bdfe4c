"""How fast a pull (``actions: remove``) the engines follow: three small KAPLA scenes pulled at a
range of speeds, on every engine and mode, each run twice, at the mode's own timestep and at a
quarter of it, with the compiler's limits off (past them).

* ``jenga``: a 4-level tower of 3 KAPLA bricks a level (25 mm apart, each level turned 90 deg);
  the middle brick of level 2 pulled along its length (the default distance, 130 mm). Coulomb
  friction says the level above stays put at any speed (its two other blocks hold it back), and
  the slower the pull the longer the drag lasts: a faster pull that drags more is not followed.
* ``across``: the same middle brick pulled 60 mm sideways, across the tower, into the side brick
  beside it (a pull whose path crosses a brick of its level): the pulled brick drives that brick
  as a pusher would.
* ``under``: a column of 5 KAPLA bricks lying flat on each other, the bottom one pulled 130 mm
  along its length from under the other four.

A cell gives, for the bricks left in the scene, the largest distance (mm) any ended from where
it was placed at the mode's own timestep / at a quarter of it, and in brackets how far the two
runs' ends differ
(the largest over the bricks: a result that depends on the step is not the scene's); ``thrown``
when a brick ends more than 0.5 m away, ``sunk`` when one ends more than 1 mm into the ground.

    python docs/results/pull_speed.py SCENE [SPEED ...] [BACKEND:MODE ...]
    # SCENE: jenga, across or under; SPEED in m/s (default: 0.1 to 10); default: every mode

Output: docs/results/limits.md, "Pulls".
"""

from __future__ import annotations

import sys
import warnings
from multiprocessing import Pool

from stackdsl import compile_scenario, parse_scenario, run_program
from stackdsl.engines.registry import settings_class

CELLS = [(b, m) for b in ("pybullet", "mujoco") for m in ("raw", "tuned", "extension")]
SPEEDS = (0.1, 0.5, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0)
TOWER = "structure:\n  tower: {levels: 4, bricks_per_layer: 3, spacing: 25 mm}\n"
COLUMN = "structure:\n  bricks:\n" + "".join(f"    - {{id: c{i}, at: [0, 0, {4 + 8 * i} mm]}}\n" for i in range(5))
SCENES = {
    "jenga": (TOWER, "brick: L02.2, at: after level 4"),
    "across": (TOWER, "brick: L02.2, at: after level 4, direction: +x, distance: 60 mm"),
    "under": (COLUMN, "brick: c0, at: 2 s, direction: +x, distance: 130 mm"),
}


def scene(name: str, speed: float, backend: str, mode: str, timestep: float) -> str:
    """Scenario text of ``name`` pulled at ``speed`` m/s in ``backend``'s ``mode`` at ``timestep`` s."""
    structure, pull = SCENES[name]
    return (
        f"stackdsl: 1\nengine: {{backend: {backend}, mode: {mode}, timestep: 1/{round(1 / timestep)} s}}\n"
        f"timing: {{interval: 0.2 s, settle: 1 s}}\n{structure}"
        f"actions:\n  - remove: {{{pull}, speed: {speed:g} m/s}}\n"
    )


def ends(text: str) -> dict[str, tuple[float, float, float]]:
    """Brick id -> where it ends (mm), for the bricks left in the scene, and ``"_drift"`` ->
    (the largest distance one ended from where it was placed, mm, 0, 0)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        outcome = run_program(compile_scenario(parse_scenario(text, "pull.yaml"), limits=False))
    out = {n.id: n.position_mm for n in outcome.final_graph.nodes if n.id != "ground" and n.id not in outcome.removed}
    kept = [d for k, d in outcome.displacement.items() if k not in outcome.removed]
    out["_drift"] = (1000 * max(kept, default=0.0), 0.0, 0.0)
    return out


def cell(job: tuple[str, float, str, str]) -> str:
    name, speed, backend, mode = job
    step = float(settings_class(backend).DEFAULTS[mode]["timestep"])  # type: ignore[arg-type]
    own, fine = ends(scene(name, speed, backend, mode, step)), ends(scene(name, speed, backend, mode, step / 4))
    drift, finer = own.pop("_drift")[0], fine.pop("_drift")[0]
    apart = max(sum((a - b) ** 2 for a, b in zip(own[k], fine[k])) ** 0.5 for k in own)
    text = f"{drift:.1f} / {finer:.1f} ({apart:.1f})"
    if any(sum(c * c for c in p[:2]) ** 0.5 > 500 for p in own.values()):
        text += " thrown"
    if any(p[2] < 3.0 for p in own.values()):
        text += " sunk"
    return text


def main(name: str, speeds: list[float], cells: list[tuple[str, str]]) -> None:
    jobs = [(name, s, b, m) for s in speeds for b, m in cells]
    with Pool(2) as pool:
        texts = pool.map(cell, jobs, chunksize=1)
    print(f"{name}: | pull | " + " | ".join(f"{b} {m}" for b, m in cells) + " |")
    print("|---:|" + "---:|" * len(cells))
    for i, s in enumerate(speeds):
        print(f"| {s:g} m/s | " + " | ".join(texts[i * len(cells) : (i + 1) * len(cells)]) + " |")


if __name__ == "__main__":
    chosen = [tuple(a.split(":")) for a in sys.argv[2:] if ":" in a]
    speeds = [float(a) for a in sys.argv[2:] if ":" not in a]
    main(sys.argv[1], speeds or list(SPEEDS), [(b, m) for b, m in chosen] or CELLS)

"""Friction anchors while a pull is stepped: on the pulled brick, on every body, or none.

The extension on pybullet gives the brick a hand pulls along a path friction anchors
(``frictionAnchor``; ``PyBulletWorld._anchor``); until 2026-11-29 it gave them to every body in
the world while a pull was stepped. This runs a Jenga tower (the structure of ``FILE``, everything
before its ``actions:``, optionally with another number of levels, density and friction) with one
block pulled once it is built, for each block and speed named, four ways: the extension as
shipped, the extension with anchors on every body while the pull is stepped (the old behaviour,
put back by wrapping ``PyBulletWorld._anchor``), the extension with none, and tuned pybullet
(anchors on at every step). A row each: the block, the speed, and for each stands or the
collapse level and the largest distance (mm) a brick above the pulled level ended from where it
was placed, ``U`` where the pull's proof failed (the engine stepped the bricks it slides between).

    python docs/results/pull_anchors.py FILE BLOCKS SPEEDS [LEVELS,DENSITY,FRICTION]
    # e.g. python docs/results/pull_anchors.py scenarios/jenga_stands.yaml L09.1,L10.1,L10.2,L11.1,L11.2 20,60
    # the same tower at 10 levels, 650 kg/m^3 and friction 0.45:
    # python docs/results/pull_anchors.py scenarios/jenga_stands.yaml L08.1,L09.1,L09.2,L09.3,L08.3 25,50 10,650,0.45

Output: docs/results/actions-freeze.md ("Friction anchors while a pull is stepped").
Source: stackdsl's own.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import Any

from stackdsl import compile_scenario, parse_scenario, run_program
from stackdsl.engines.pybullet.world import PyBulletWorld

SHIPPED = PyBulletWorld._anchor


def _every_body(self: Any, pulled: set[int]) -> None:
    """Anchors on every body while a pull is stepped, the mode's setting after (the old way)."""
    if bool(pulled) != bool(self._anchored):
        flag = int(bool(pulled) or self._engine.friction_anchors)
        for index in range(self._client.getNumBodies()):
            self._client.changeDynamics(self._client.getBodyUniqueId(index), -1, frictionAnchor=flag)
    self._anchored = set(pulled)


def _none(self: Any, pulled: set[int]) -> None:
    """No anchors: only what is pulled is kept track of."""
    self._anchored = set(pulled)


WAYS = {"shipped": SHIPPED, "every body": _every_body, "none": _none}


def run(text: str, mode: str, way: str, block: str) -> str:
    PyBulletWorld._anchor = WAYS[way]  # type: ignore[method-assign]
    outcome = run_program(compile_scenario(parse_scenario(text, "pull.yaml"), mode, None, "pybullet"))
    PyBulletWorld._anchor = SHIPPED  # type: ignore[method-assign]
    level = int(block[1:3])
    above = max(d for brick, d in outcome.displacement.items() if int(brick[1:3]) > level)
    unproved = any(
        e.brick == block and ("statics does not keep" in e.detail or "would not hold" in e.detail) for e in outcome.events
    )
    verdict = f"collapse {outcome.collapse.level}" if outcome.collapse else "stands"
    return f"{verdict} {above * 1000:.2f} mm{' U' if unproved else ''}"


def main(path: str, blocks: list[str], speeds: list[float], tower: str | None = None) -> None:
    head = Path(path).read_text().split("actions:")[0]
    if tower is not None:  # the tower's levels, its wood's density (kg/m^3) and friction coefficient
        levels, density, friction = tower.split(",")
        head = re.sub(r"levels: \d+", f"levels: {levels}", head)
        head = re.sub(r"density: [0-9.]+ kg/m\^3", f"density: {density} kg/m^3", head)
        head = re.sub(r"friction: [0-9.]+", f"friction: {friction}", head)
    found = re.search(r"levels: (\d+)", head)
    assert found is not None, f"{path}: no tower's levels"
    print("| block | speed (mm/s) | extension | anchors on every body | no anchors | tuned pybullet |")
    print("|---|---:|---|---|---|---|")
    for block in blocks:
        for speed in speeds:
            text = f"{head}actions:\n  - remove: {{brick: {block}, at: after level {found[1]}, speed: {speed:g} mm/s}}\n"
            cells = [run(text, "extension", way, block) for way in WAYS] + [run(text, "tuned", "shipped", block)]
            print(f"| {block} | {speed:g} | {' | '.join(cells)} |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2].split(","), [float(s) for s in sys.argv[3].split(",")], (sys.argv[4:] or [None])[0])

"""A stepped pull's contacts on pybullet: solver iterations and friction anchors while it is split.

While a pull or a push that drags bricks the engine moves is stepped, the extension on pybullet
splits each step into four substeps (``stackdsl.compile.program.PULL_STEP``), at its own 50 solver
iterations, with friction anchors on the pulled brick alone (``PyBulletWorld._anchor``). This runs
each scenario FILE with the extension on pybullet in each WAY, ``ITERATIONS-ANCHORS``: the solver
iterations while a step is split (50 is the extension's own), and the anchors then on the
``pulled`` brick alone (as shipped), on ``every`` body, or on ``none``; a row each, with the
verdict and the brick that ended farthest from its place, and the CPU time of the run.

    python docs/results/pull_contacts.py WAYS FILE...
    # e.g. python docs/results/pull_contacts.py 50-pulled,150-pulled,150-every,150-none WALL.yaml PULL.yaml
    # FILE@K: sample K of a sweep file, e.g. SWEEP.yaml@5 SWEEP.yaml@8

Output: docs/results/actions-freeze.md ("Tuned contacts while a pull is stepped: tried, not kept").
Source: stackdsl's own.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

from pull_anchors import _every_body, _none  # the other ways of friction anchors, run from this folder

from stackdsl import Scenario, compile_scenario, parse_scenario, run_program
from stackdsl.engines.pybullet.world import PyBulletWorld
from stackdsl.lang.loader import SourceMap, _read_yaml
from stackdsl.lang.sampling import Template

SPLIT, ANCHOR = PyBulletWorld._split_step, PyBulletWorld._anchor


def use(way: str) -> None:
    """Put ``way`` (``ITERATIONS-ANCHORS``) in place on :class:`PyBulletWorld`."""
    iterations, anchors = way.split("-")

    def split(self: Any) -> None:
        self._client.setPhysicsEngineParameter(numSolverIterations=int(iterations))
        SPLIT(self)
        self._client.setPhysicsEngineParameter(numSolverIterations=self._engine.solver_iterations)

    PyBulletWorld._split_step = split  # type: ignore[method-assign]
    PyBulletWorld._anchor = {"pulled": ANCHOR, "every": _every_body, "none": _none}[anchors]  # type: ignore[method-assign]


def scenario(path: str) -> Scenario:
    """The scenario of ``path``; of ``FILE@K``, sample K of FILE's sweep or random fields."""
    file, _, sample = path.partition("@")
    text = Path(file).read_text(encoding="utf-8")
    if not sample:
        return parse_scenario(text, file)
    source = SourceMap(file, tuple(text.splitlines()))
    template = Template.of(_read_yaml(text, source), source)
    assert template is not None, f"{file} draws nothing: no sample {sample}"
    return template.scenario(0, int(sample), checked=True)


def run(path: str) -> str:
    """The verdict, the farthest brick and the CPU time of ``path`` with the extension on pybullet."""
    program = compile_scenario(scenario(path), "extension", None, "pybullet")
    start = time.process_time()
    outcome = run_program(program)
    cpu = time.process_time() - start
    brick, far = max(outcome.displacement.items(), key=lambda item: item[1])
    verdict = f"collapse {outcome.collapse.level}" if outcome.collapse else "stands"
    return f"{verdict}, {brick} {far * 1000:.2f} mm, {cpu:.2f} s"


def main(ways: list[str], paths: list[str]) -> None:
    print(f"| file | {' | '.join(ways)} |")
    print(f"|---|{'---|' * len(ways)}")
    for path in paths:
        cells = []
        for way in ways:
            use(way)
            cells.append(run(path))
        print(f"| {Path(path).name} | {' | '.join(cells)} |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1].split(","), sys.argv[2:])

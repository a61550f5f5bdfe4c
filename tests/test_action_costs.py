"""docs/results/action_costs.py, the breakdown of an action scene's time, on a small pull."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import pytest

import stability
from stability._drag import PullProof

from .test_actions import JENGA_6

SCRIPT = Path(__file__).parent.parent / "docs" / "results" / "action_costs.py"

PULL = JENGA_6 + "actions:\n  - remove: {brick: L02.2, at: after level 6, speed: 40 mm/s}\nexpect: {stands: true}\n"
"""A 6-level Jenga tower whose middle block of level 2 is pulled (proved) once it is built (9 s)."""


@pytest.fixture(scope="module")
def costs() -> ModuleType:
    spec = importlib.util.spec_from_file_location("action_costs", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["action_costs"] = module  # dataclasses and the like look their module up
    spec.loader.exec_module(module)
    return module


def test_phases_add_up_parts_land_in_their_phase_and_are_put_back(costs: ModuleType, tmp_path: Path) -> None:
    scene = tmp_path / "pull.yaml"
    scene.write_text(PULL)
    before = (PullProof.check, stability.StabilityExtension.update)
    books, wall = costs.measure(str(scene), [9.0])  # the build ends by 9 s; the pull after it
    assert (PullProof.check, stability.StabilityExtension.update) == before  # unwrapped again
    walls = [b - a for a, b in zip(books.marks, books.marks[1:], strict=False)]
    assert len(walls) == 2 and sum(walls) == pytest.approx(wall, rel=1e-9)
    build, pull = (books.seconds["placing bricks"][k] for k in (0, 1))
    assert build > 0.0 and pull == 0.0  # every brick is placed before the cut
    checks = books.calls["-- its statics checks"]
    assert checks[1] >= 1  # the pull's proof is checked while the block slides
    assert books.calls["- landings of placed bricks"][0] >= 18  # each placed block is looked at as it lands
    assert books.calls["- admissions"][0] == 0  # and frozen where it landed: none waits for the admission tests
    assert sum(books.steps) == sum(books.calls["the engine's steps"])  # an update a step
    table = costs.table(books, wall)
    assert "| wall (ms) |" in table and "the engine's steps" in table and "- rides" not in table  # none: left out


def test_the_lean_peers_phases_add_up_and_its_step_is_put_back(costs: ModuleType, tmp_path: Path) -> None:
    pytest.importorskip("mujoco", reason="the lean peer runs MuJoCo: pip install -c constraints.txt '.[mujoco]'")
    from stackdsl.bench import lean_mujoco

    scene = tmp_path / "pull.yaml"
    scene.write_text(PULL)
    before = lean_mujoco._LeanRun.step
    walls = costs.peer(str(scene), [9.0])
    assert lean_mujoco._LeanRun.step is before  # unwrapped again
    assert len(walls) == 3 and walls[0] > 0.0 and walls[1] > 0.0  # the build, the pull, the whole run
    assert walls[0] + walls[1] == pytest.approx(walls[2], rel=1e-9)
    books, wall = costs.measure(str(scene), [9.0])
    table = costs.table(books, wall, walls)
    assert "| the lean MuJoCo peer's wall (ms) |" in table and "| peer / this |" in table

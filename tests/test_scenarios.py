"""The scenario library: every file holds in its own mode and matches its golden snapshot.

``pytest --snapshot-update`` rewrites ``golden/``; say in the commit why the new brick
graph or collapse level is right.
"""

from pathlib import Path

import pytest

from stackdsl import compile_scenario, evaluate, load_scenario, run_program

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = sorted((ROOT / "scenarios").glob("*.yaml"))


def test_the_library_holds_the_reports_capability_scenarios():
    assert {p.stem for p in SCENARIOS} >= {"four_stack", "slant_tower", "impact_top", "impact_level3"}


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_scenario(path, golden):
    scenario = load_scenario(path)
    program = compile_scenario(scenario)
    outcome = run_program(program)
    verdicts = evaluate(scenario.expect, outcome, program.collapse_threshold)
    assert verdicts, f"{path.name} expects nothing"
    assert [v for v in verdicts if not v.passed] == []
    assert outcome.golden() == golden


@pytest.mark.parametrize("path", [ROOT / "scenarios" / "slant_tower.yaml"], ids=["slant_tower"])
def test_raw_mode_runs_and_reports_what_pybullet_alone_does(path):
    scenario = load_scenario(path)
    outcome = run_program(compile_scenario(scenario, "raw"))
    assert outcome.mode == "raw" and outcome.steps_skipped == 0
    assert outcome.collapse is not None  # whatever level pybullet alone reaches, it is reported
    assert all(n.state in ("active", "ground") for n in outcome.final_graph.nodes)

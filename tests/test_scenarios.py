"""The scenario library in other modes and models than its own.

Each scenario file is also a test item of its own (collected by stackdsl's pytest plugin
from ``scenarios/``): it holds in its own mode and matches ``golden/scenarios/``.
``pytest --snapshot-update`` rewrites those; say in the commit why the new brick graph or
collapse level is right.
"""

from pathlib import Path

import pytest

from stackdsl import compile_scenario, evaluate, load_scenario, run_program

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = sorted((ROOT / "scenarios").glob("*.yaml"))


def test_the_library_holds_the_reports_capability_scenarios():
    assert {p.stem for p in SCENARIOS} >= {"four_stack", "slant_tower", "impact_top", "impact_level3"}


@pytest.mark.slow
@pytest.mark.parametrize("path", [ROOT / "scenarios" / "slant_tower.yaml"], ids=["slant_tower"])
def test_raw_mode_runs_and_reports_what_pybullet_alone_does(path):
    scenario = load_scenario(path)
    outcome = run_program(compile_scenario(scenario, "raw"))
    assert outcome.mode == "raw" and outcome.steps_skipped == 0
    assert outcome.collapse is not None  # whatever level pybullet alone reaches, it is reported
    assert all(n.state in ("active", "ground") for n in outcome.final_graph.nodes)


CAPABILITY = ["four_stack", "card_house", "slant_tower", "impact_top", "impact_level3"]


@pytest.mark.slow
@pytest.mark.parametrize("name", CAPABILITY)
def test_the_equilibrium_model_also_gives_the_capability_outcomes(name):
    scenario = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
    program = compile_scenario(scenario, model="equilibrium")
    outcome = run_program(program)
    assert [v for v in evaluate(scenario.expect, outcome, program.collapse_threshold) if not v.passed] == []


@pytest.mark.parametrize("name", ["fig13_loaded_vee", "fig14_leaning_on_upright"])
def test_the_report_model_brings_down_its_figures_13_and_14_when_the_push_freezes(name):
    """The report's own rules hold what falls (the leaning test takes the bricks leaned on as
    fixed). stackdsl's report model asks rigid-block equilibrium with friction where a freeze's
    loads reach a leaning brick: the mechanism wakes then, and the bricks fall, as with the
    equilibrium model, not only at the end-of-run check."""
    scenario = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
    assert scenario.stability.model == "equilibrium"
    program = compile_scenario(scenario, model="report")
    outcome = run_program(program)
    wakes = [e for e in outcome.events if e.kind == "wake" and "collapse mechanism" in e.detail]
    assert wakes and outcome.collapse is not None and wakes[0].time < outcome.collapse.time
    assert max(outcome.displacement.values()) > program.collapse_threshold  # it falls
    assert outcome.certificate is not None and outcome.certificate.kind == "mechanism"
    assert [v for v in evaluate(scenario.expect, outcome, program.collapse_threshold) if not v.passed] == []

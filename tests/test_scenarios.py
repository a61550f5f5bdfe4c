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


@pytest.mark.parametrize("path", [ROOT / "scenarios" / "slant_tower.yaml"], ids=["slant_tower"])
def test_raw_mode_runs_and_reports_what_pybullet_alone_does(path):
    scenario = load_scenario(path)
    outcome = run_program(compile_scenario(scenario, "raw"))
    assert outcome.mode == "raw" and outcome.steps_skipped == 0
    assert outcome.collapse is not None  # whatever level pybullet alone reaches, it is reported
    assert all(n.state in ("active", "ground") for n in outcome.final_graph.nodes)


CAPABILITY = ["four_stack", "card_house", "slant_tower", "impact_top", "impact_level3"]


@pytest.mark.parametrize("name", CAPABILITY)
def test_the_equilibrium_model_also_gives_the_capability_outcomes(name):
    scenario = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
    program = compile_scenario(scenario, model="equilibrium")
    outcome = run_program(program)
    assert [v for v in evaluate(scenario.expect, outcome, program.collapse_threshold) if not v.passed] == []


@pytest.mark.parametrize("name", ["fig13_loaded_vee", "fig14_leaning_on_upright"])
def test_the_report_model_is_wrong_on_its_figures_13_and_14_and_the_certificate_says_so(name):
    scenario = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
    assert scenario.stability.model == "equilibrium"
    program = compile_scenario(scenario, model="report")
    outcome = run_program(program)
    # the report's model holds what falls: it wakes nothing, and nothing moves ...
    assert not [e for e in outcome.events if e.kind == "wake"]
    assert max(outcome.displacement.values()) < program.collapse_threshold
    # ... but what it froze has no equilibrium, so the run cannot say it stands
    assert outcome.collapse is not None and outcome.certificate is not None
    assert outcome.certificate.kind == "no equilibrium" and outcome.certificate.bricks

"""The statics backend: rigid-block equilibrium of the placed bricks, no dynamics; its verdicts
against the closed forms and the engines' extension mode, and what it refuses."""

from pathlib import Path

import pytest

from stackdsl import ScenarioError, compile_scenario, load_scenario, parse_scenario, run_program
from stackdsl.cli.main import main
from stackdsl.verdicts.closed_form import log_cabin, single_file

from .test_oracle import harmonic

ROOT = Path(__file__).resolve().parents[1]


def statics(text: str):
    return run_program(compile_scenario(parse_scenario(text), backend="statics"))


def level(outcome) -> int | None:
    return None if outcome.collapse is None else outcome.collapse.level


@pytest.mark.parametrize("shift_mm", [13, 20])
def test_a_single_file_tower_collapses_at_the_closed_form_level(shift_mm):
    expected = single_file(shift_mm / 1000)
    tower = f"levels: {expected + 1}, bricks_per_layer: 1, turn: 0, shift: {shift_mm} mm"
    assert level(statics(f"stackdsl: 1\nstructure: {{tower: {{{tower}}}}}\n")) == expected


def test_a_log_cabin_collapses_at_the_closed_form_level():
    expected = log_cabin(0.011)
    tower = f"levels: {expected + 1}, spacing: 96 mm, shift: 11 mm"
    outcome = statics(f"stackdsl: 1\nstructure: {{tower: {{{tower}}}}}\n")
    assert level(outcome) == expected and outcome.backend == "statics"


@pytest.mark.parametrize("n", [4, 5])
def test_the_harmonic_stack_stands_below_its_critical_offsets_and_falls_above(n):
    stands = statics(harmonic(n, 0.99))
    assert level(stands) is None and stands.certificate is not None and stands.certificate.verdict == "stands"
    falls = statics(harmonic(n, 1.01))
    assert level(falls) is not None and falls.certificate is not None and falls.certificate.verdict == "collapse"


def test_an_outcome_of_statics_is_a_whole_one():
    outcome = statics("stackdsl: 1\nstructure: {tower: {levels: 3}}\n")
    assert outcome.collapse is None and outcome.levels_placed == 3 and outcome.bricks_placed == 6
    assert outcome.certificate is not None and outcome.certificate.kind == "equilibrium"
    assert outcome.certificate.margin_mm > 0
    edges = {(e.upper, e.support) for e in outcome.final_graph.edges}
    assert ("L01.1", "ground") in edges and ("L02.1", "L01.1") in edges
    assert max(outcome.displacement.values()) <= 0.001  # placed a drop gap above their poses, and left there


SMALL = [
    "hard/overhang_stands",
    "hard/overhang_falls",
    "hard/harmonic_098",
    "hard/harmonic_102",
    "hard/corner_on_corner",
    "vee_stands",
    "vee_slides",
    "lean_wall_stands",
    "lean_wall_slides",
    "fig14_leaning_on_upright",
]


@pytest.mark.parametrize("name", SMALL)
def test_statics_gives_the_extensions_verdict_on_a_shipped_static_scenario(name):
    scenario = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
    extension = run_program(compile_scenario(scenario))
    assert level(run_program(compile_scenario(scenario, backend="statics"))) == level(extension)


STATIC = sorted(
    p
    for p in (ROOT / "scenarios").rglob("*.yaml")
    if not any(word in p.read_text() for word in ("impacts:", "actions:", "drop_gap", "allow:"))
)


@pytest.mark.slow
@pytest.mark.parametrize("path", STATIC, ids=[p.stem for p in STATIC])
def test_statics_gives_the_extensions_verdict_on_every_shipped_static_scenario(path):
    scenario = load_scenario(path)
    extension = run_program(compile_scenario(scenario))
    assert level(run_program(compile_scenario(scenario, backend="statics"))) == level(extension)


BASE = "stackdsl: 1\nstructure: {tower: {levels: 2}}\n"


@pytest.mark.parametrize(
    "more, field, why",
    [
        ("impacts:\n  - {target: {level: 2, side: +y}, speed: 1 m/s, at: after level 2}\n", "impacts[0]", "a thrown brick"),
        ("actions:\n  - remove: {brick: L01.1, at: after level 2, speed: 20 mm/s}\n", "actions[0]", "a hand or a shake"),
        ("timing: {drop_gap: 2 mm}\n", "timing.drop_gap", "a brick dropped 2 mm"),
        ("allow: [floating]\n", "allow", "a floating brick"),
        ("expect: {toppled: 1}\n", "expect.toppled", "where bricks end"),
        ("expect: {still: {tilt: 0.02 deg}}\n", "expect.still", "the onset of motion"),
    ],
)
def test_a_scene_that_needs_motion_is_refused_at_its_field(more, field, why):
    scenario = parse_scenario(BASE + more)
    compile_scenario(scenario)  # an engine takes it
    with pytest.raises(ScenarioError) as caught:
        compile_scenario(scenario, backend="statics")
    assert caught.value.field == field and caught.value.line is not None and caught.value.line >= 3
    assert caught.value.message.startswith("statics places bricks and solves rigid-block equilibrium, without motion: " + why)


def test_the_command_refuses_a_moving_scene_on_statics_with_exit_2(tmp_path, capsys):
    path = tmp_path / "hit.yaml"
    path.write_text(BASE + "impacts:\n  - {target: {level: 2, side: +y}, speed: 1 m/s, at: after level 2}\n")
    assert main(["check", str(path), "--backend", "statics"]) == 2
    err = capsys.readouterr().err
    assert f"{path}:4:5: impacts[0]: statics places bricks" in err and "Traceback" not in err


def test_the_command_refuses_still_on_statics_with_exit_2_before_it_runs(tmp_path, capsys):
    # statics cannot see a tilt or slip begin: refused at the field, not failed as "no motion measured"
    path = tmp_path / "still.yaml"
    path.write_text(BASE + "expect:\n  still: {tilt: 0.02 deg}\n")
    assert main(["run", str(path), "--backend", "statics"]) == 2
    out, err = capsys.readouterr()
    assert f"{path}:4:10: expect.still: statics places bricks" in err and "onset of motion" in err
    assert "Traceback" not in err and "FAIL" not in out + err


def test_a_backend_without_dynamics_takes_the_short_path_not_the_step_loop(monkeypatch):
    import stackdsl.runtime.run as run

    def no_loop(*args, **kwargs):
        raise AssertionError("the step loop ran")

    monkeypatch.setattr(run, "run_in", no_loop)
    outcome = statics("stackdsl: 1\nstructure: {tower: {levels: 30}}\n")
    assert outcome.collapse is None and outcome.bricks_placed == 60 and outcome.steps == 0
    assert outcome.certificate is not None and "load path" in outcome.certificate.detail
    with pytest.raises(AssertionError, match="step loop"):  # an engine still steps
        run_program(compile_scenario(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 1}}\n")))


def test_a_collapse_without_dynamics_is_proved_by_no_equilibrium_and_places_nothing_after():
    expected = single_file(0.013)
    outcome = statics(
        f"stackdsl: 1\nstructure: {{tower: {{levels: {expected + 2}, bricks_per_layer: 1, turn: 0, shift: 13 mm}}}}\n"
    )
    assert outcome.collapse is not None and outcome.collapse.level == expected
    assert outcome.certificate is not None and outcome.certificate.kind == "no equilibrium" and outcome.certificate.bricks
    assert outcome.collapse.brick in outcome.certificate.bricks
    assert outcome.bricks_placed == expected and len(outcome.unplaced) == 2
    assert [e.kind for e in outcome.events].count("collapse") == 1 and outcome.collapse_graph == outcome.final_graph


@pytest.mark.parametrize("name", ["hard/overhang_falls", "hard/harmonic_098", "fig14_leaning_on_upright"])
def test_the_statics_world_in_the_step_loop_gives_the_short_paths_verdict(name):
    from stackdsl.runtime.loop import Subscriber

    program = compile_scenario(load_scenario(ROOT / "scenarios" / f"{name}.yaml"), backend="statics")
    short, looped = run_program(program), run_program(program, subscribers=(Subscriber(),))
    assert looped.steps > 0 and short.steps == 0  # a subscriber asks for the step loop
    assert level(looped) == level(short)

"""The compiler's passes (stackdsl.compile.compiler.PASSES), each on its own: what it finds and
what it refuses, on scenes small enough to compile in milliseconds."""

from __future__ import annotations

import numpy as np
import pytest

from stackdsl import End, Launch, Place, ScenarioError, compile_scenario, parse_scenario
from stackdsl.compile import compiler
from stackdsl.compile.compiler import PASSES, Asked, Compilation
from stackdsl.compile.program import Remove

TOWER = "stackdsl: 1\nstructure: {tower: {levels: 2}}\n"
JENGA = (
    "stackdsl: 1\nstructure: {tower: {levels: 3, bricks_per_layer: 3, spacing: 25 mm}}\n"
    "actions:\n  - remove: {brick: L02.2, at: after level 3, speed: 20 mm/s}\n"
)
THROW = "stackdsl: 1\nstructure: {tower: {levels: 3}}\nimpacts: [{id: %s, target: {level: 2, side: +y}, speed: 1 m/s, at: 6 s}]\n"


def until(text: str, last: str, **asked: object) -> Compilation:
    """The compilation of ``text`` after the passes up to and including the one named ``last``."""
    state = Compilation(parse_scenario(text, "p.yaml"), Asked(**asked))  # type: ignore[arg-type]
    for compiler_pass in PASSES:
        state = compiler_pass(state)
        if compiler_pass.__name__ == last:
            return state
    raise AssertionError(f"no pass {last}")


def test_the_passes_run_in_a_visible_order_and_make_what_compile_scenario_makes():
    names = [p.__name__ for p in PASSES]
    assert names == [
        "read",
        "draw",
        "choose_engine",
        "lay_out",
        "place",
        "act",
        "throw",
        "engine_limits",
        "check_hands",
        "schedule",
        "assemble",
        "work_budget",
        "check_placements",
        "late_warnings",
    ]
    assert all(p.__doc__ and p.__doc__.startswith(f"Pass {i + 1}: ") for i, p in enumerate(PASSES))
    assert until(JENGA, "late_warnings").built == compile_scenario(parse_scenario(JENGA, "p.yaml"))


def test_read_refuses_what_is_not_a_scenario_and_says_how_to_get_one():
    with pytest.raises(TypeError, match="load_scenario"):
        compiler.read(Compilation("tower.yaml"))  # type: ignore[arg-type]
    state = Compilation(parse_scenario(TOWER, "p.yaml"))
    assert compiler.read(state) is state


def test_draw_keeps_a_scene_without_require_and_draws_one_that_meets_it():
    state = until(TOWER, "draw")
    assert state.draws == 1
    random = (
        "stackdsl: 1\nstructure:\n  tower: {levels: 3, bricks_per_layer: 1, turn: 0, "
        "shift: {uniform: [-20 mm, 20 mm], per: layer}}\nrequire: ['overhang > 5 mm']\n"
    )
    drawn = until(random, "draw")
    assert drawn.draws >= 1
    shifts = np.array(drawn.scenario.structure.tower.shifts, dtype=float)  # type: ignore[union-attr]
    assert np.abs(np.diff(shifts[:, 0])).max() > 0.005 or np.abs(shifts[:, 0]).max() > 0.005


def test_choose_engine_takes_the_mode_asked_over_the_files():
    assert until(TOWER, "choose_engine").engine.mode == "extension"
    raw = until(TOWER, "choose_engine", mode="raw").engine
    assert (raw.mode, raw.timestep) == ("raw", pytest.approx(1 / 240))
    with pytest.raises(ValueError, match="unknown mode"):
        until(TOWER, "choose_engine", mode="gentle")
    with pytest.raises(RuntimeError, match="choose_engine"):
        _ = Compilation(parse_scenario(TOWER, "p.yaml")).engine


def test_lay_out_splits_bricks_from_fixtures_and_makes_each_types_body():
    state = until(
        "stackdsl: 1\nstructure:\n  bricks:\n    - {at: [0, 0, 4 mm]}\n    - {at: [0, 0, 300 mm], fixed: true}\n", "lay_out"
    )
    assert [b.id for b in state.bricks] == ["b001"] and [b.id for b in state.fixed] == ["fixed2"]
    assert list(state.specs) == ["kapla"] and state.specs["kapla"].half_extents == pytest.approx((0.06, 0.012, 0.004))


def test_place_puts_one_brick_a_slot_and_refuses_an_interval_off_the_grid():
    state = until(TOWER, "place")
    assert [(p.id, p.step, p.time) for p in state.placements] == [
        ("L01.1", 0, 0.0),
        ("L01.2", 240, 1.0),
        ("L02.1", 480, 2.0),
        ("L02.2", 720, 3.0),
    ]
    assert state.settle == 480
    with pytest.raises(ScenarioError) as err:
        until(TOWER + "timing: {interval: 0.301 s}\n", "place")
    assert err.value.field == "timing.interval"


def test_act_makes_the_pull():
    (pull,) = until(JENGA, "act").motions
    assert isinstance(pull, Remove) and pull.id == "L02.2" and pull.step == 9 * 240


def test_throw_aims_each_impact_and_present_leaves_out_the_pulled_brick():
    (launch,) = until(THROW % "hammer", "throw").launches
    assert isinstance(launch, Launch) and launch.id == "hammer" and launch.step == 6 * 240
    pulled = until(JENGA, "throw")
    before, after = pulled.present(9 * 240 - 1), pulled.present(pulled.motions[0].end_step)
    assert "L02.2" in [b[0] for b in before] and "L02.2" not in [b[0] for b in after]
    assert len(before) == 9


def test_engine_limits_refuses_a_brick_below_the_engines_floor_unless_asked_not_to():
    tiny = "stackdsl: 1\nbrick_types: {cube: {size: [2 mm, 2 mm, 2 mm]}}\nstructure: {tower: {levels: 2, bricks_per_layer: 1, brick: cube}}\n"
    with pytest.raises(ScenarioError) as err:
        until(tiny, "engine_limits")
    assert err.value.field.startswith("brick_types.cube.size") and "simulates faithfully" in err.value.message
    assert until(tiny, "engine_limits", limits=False).bricks


def test_check_hands_refuses_a_projectile_named_as_a_brick():
    with pytest.raises(ScenarioError) as err:
        until(THROW % "L01.1", "check_hands")
    assert err.value.field == "impacts[0].id" and "already names a brick of the structure" in err.value.message


def test_schedule_orders_the_actions_and_ends_settle_after_the_last():
    actions = until(JENGA, "schedule").actions
    assert [a.step for a in actions] == sorted(a.step for a in actions)
    pull = next(a for a in actions if isinstance(a, Remove))
    assert isinstance(actions[-1], End) and actions[-1].step == pull.end_step + 480
    with pytest.raises(ScenarioError, match="at most"):
        until(TOWER + "timing: {interval: 1000 s}\n", "schedule")


def test_assemble_makes_the_program_with_the_rules_this_scene_needs():
    program = until(THROW % "hammer", "assemble").built
    assert program.collapse_threshold == pytest.approx(0.004)
    assert {r.name: r.on for r in program.rules}["impacts"] and program.stability.impacts
    assert isinstance(program.actions[0], Place) and isinstance(program.actions[-1], End)


def test_work_budget_refuses_a_runaway_at_the_field_to_change():
    with pytest.raises(ScenarioError) as err:
        until("stackdsl: 1\nstructure: {tower: {levels: 30}}\nengine: {mode: raw, timestep: 1e-5 s}\n", "work_budget")
    assert err.value.field == "engine.timestep" and "would take too long" in err.value.message


def test_check_placements_notes_the_bricks_allowed_to_rest_on_nothing():
    floating = "stackdsl: 1\nstructure:\n  bricks:\n    - {at: [0, 0, 50 mm]}\nallow: [floating]\n"
    assert until(floating, "check_placements").built.floating == ("b001",)
    with pytest.raises(ScenarioError, match="nothing"):
        until(floating.replace("allow: [floating]\n", ""), "check_placements")

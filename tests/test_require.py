"""``require:``: conditions on a sample's draws, parsed by a small grammar (never Python's eval),
checked before simulating; a failing draw is drawn again from (seed, k, attempt). Its acceptance
rate on the random single-file stack is checked against the independent numpy Monte Carlo."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from stackdsl import compile_scenario
from stackdsl.bench.random_stack import collapse_level
from stackdsl.compile.require import accept, quantities
from stackdsl.lang.errors import ScenarioError
from stackdsl.lang.expressions import parse
from stackdsl.lang.loader import parse_scenario

STACK = """stackdsl: 1
structure:
  tower: {levels: 5, bricks_per_layer: 1, turn: 0, shift: {uniform: [-60 mm, 60 mm], per: layer}}
timing: {interval: 0.5 s}
"""


@pytest.mark.parametrize(
    "text, values, holds",
    [
        ("overhang >= 10 mm", {"overhang": 0.011}, True),
        ("overhang >= 10 mm", {"overhang": 0.009}, False),
        ("a < b < c", {"a": 1, "b": 2, "c": 2}, False),
        ("not (a < 1 or b > 2) and a + b * 2 == 5", {"a": 1, "b": 2}, True),
        ("abs(-x) > 0.5 deg and max(x, 1, 2) == 2", {"x": 1.0}, True),
        ("x < 0.5 rad", {"x": 28.0}, True),  # angles are degrees: 0.5 rad is 28.6
        ("t <= 1/240 s * 240", {"t": 1.0}, True),
        ("x > 1 / y", {"x": 1.0, "y": 0.0}, False),  # a division by zero: false
    ],
)
def test_conditions_hold_as_written(text, values, holds):
    assert parse(text).holds(values) is holds


@pytest.mark.parametrize(
    "text, where",
    [
        ("__import__('os').system('true') < 1", "character 12: cannot read"),
        ("x < ", "character 5"),
        ("x", "character 2"),
        ("x < 3 parsnips", "unknown unit"),
        ("x < 1 A", "'1 A': a condition's numbers are lengths, times, masses and angles"),
        ("x < 1e400 mm", "1e400 is not a finite number"),
        ("x < 1e400", "at character 5: 1e400 is not a finite number"),
        ("x < 1e308 km", "'1e308 km' is not a finite number in SI units"),
        ("(" * 60 + "x" + ")" * 60 + " < 1", "nested"),
        ("x < 1; y < 2", "character 6"),
        ("lambda: 1 < 2", "character 7"),
    ],
)
def test_anything_outside_the_grammar_is_refused_with_where(text, where):
    with pytest.raises(ValueError, match=where):
        parse(text)


def test_a_bad_condition_in_a_file_points_at_it():
    with pytest.raises(ScenarioError) as err:
        parse_scenario(STACK + "require:\n  - overhang >= 10 mm\n  - com_offset < < 3\n", "r.yaml")
    assert (err.value.line, err.value.column, err.value.field) == (7, 5, "require[1]")
    with pytest.raises(ScenarioError) as err:
        compile_scenario(parse_scenario(STACK + "require: [overhangs > 1 mm]\n", "r.yaml"))
    assert (err.value.line, err.value.field) == (5, "require[0]") and "unknown name 'overhangs'" in err.value.message


def test_fields_are_read_by_path_in_si_units():
    scenario = parse_scenario(STACK + "require: ['timing.interval == 500 ms and structure.tower.levels == 5']\n", "r.yaml")
    values = quantities(scenario)
    assert values["timing.interval"] == 0.5 and values["structure.tower.spacing"] == pytest.approx(0.096)
    assert values["levels"] == 5 and values["bricks"] == 5 and values["gap"] == math.inf
    assert accept(scenario)[1] == 1


def test_derived_quantities_of_a_known_scene():
    text = "stackdsl: 1\nstructure: {tower: {levels: 3, spacing: 60 mm, turn: 0, shift: [10 mm, 0]}}\n"
    values = quantities(parse_scenario(text, "q.yaml"))
    assert values["gap"] == pytest.approx(0.036)  # 60 mm apart, 24 mm wide
    assert values["overhang"] == pytest.approx(0.010) and values["max_overhang"] == pytest.approx(0.010)
    # on level 1, levels 2 and 3 together: their centre of mass 15 mm from level 1's centre
    assert values["com_offset"] == pytest.approx(0.015)


@pytest.mark.parametrize("spacing", ["0 mm", "24 mm", "10 mm"])
def test_the_gap_of_bricks_that_touch_or_overlap_is_zero(spacing):
    """Three bricks of a layer laid at one place (spacing 0) have no nearest other footprint for
    shapely's STRtree (it leaves out equal ones): the gap is 0, not an internal error, and the
    overlap is then refused where it is written."""
    text = f"stackdsl: 1\nstructure: {{tower: {{levels: 2, spacing: {spacing}}}}}\nrequire: ['gap > 1 mm']\n"
    scenario = parse_scenario(text, "g.yaml")
    assert quantities(scenario)["gap"] == 0.0
    with pytest.raises(ScenarioError) as err:
        compile_scenario(scenario)
    assert err.value.field in ("require[0]", "structure.tower.spacing"), err.value.field


@pytest.mark.slow
def test_the_acceptance_rate_is_the_chance_that_a_random_stack_stands_while_built():
    """5 bricks of a random walk stand while built with probability 1 - P(N = 3, 4, 5): the
    independent Monte Carlo (stackdsl.bench.random_stack, 10^7 stacks) gives 0.5841."""
    scenario = parse_scenario(STACK + "require: [com_offset < 60 mm]\nsweep: {samples: 400}\n", "r.yaml")
    template = scenario.template
    draws = 0
    for k in range(400):
        sample, n = accept(template.scenario(0, k))
        draws += n
        x = [0.0, *np.cumsum([s for s, _ in sample.structure.tower.shifts])]
        assert collapse_level(np.array(x)) is None  # the accepted stack stands at every stage
    expected = 1 - 0.1249 - 0.1494 - 0.1416
    assert stats.binomtest(400, draws, expected).pvalue > 0.001, (400, draws, 400 / draws)


def test_a_sample_is_a_function_of_the_seed_and_its_index():
    text = STACK + "require: [max_overhang < 30 mm]\nsweep: {samples: 8}\n"
    template = parse_scenario(text, "r.yaml").template
    forward = [accept(template.scenario(0, k)) for k in range(8)]
    backward = [accept(template.scenario(0, k)) for k in reversed(range(8))][::-1]
    assert [(s.structure.tower.shifts, n) for s, n in forward] == [(s.structure.tower.shifts, n) for s, n in backward]
    assert any(n > 1 for _, n in forward)
    # a sample its first draw meets is the sample drawn without 'require'
    plain = parse_scenario(STACK + "sweep: {samples: 8}\n", "r.yaml").template
    for k, (sample, n) in enumerate(forward):
        if n == 1:
            assert sample.structure.tower.shifts == plain.scenario(0, k).structure.tower.shifts
    # and the program says how many draws it took
    assert compile_scenario(template.scenario(0, next(k for k, (_, n) in enumerate(forward) if n > 1))).draws > 1


@pytest.mark.slow
def test_conditions_no_draw_meets_are_refused_after_the_cap():
    with pytest.raises(ScenarioError) as err:
        compile_scenario(parse_scenario(STACK + "require: [levels > 5 or overhang > 1 m]\n", "r.yaml"))
    assert err.value.field == "require[0]" and "none of 1000 draws" in err.value.message


@pytest.mark.slow
@pytest.mark.parametrize(
    "condition, says, not_said",
    [
        # the distributions limit it: com_offset reaches a few centimetres, a metre needs wider shifts
        ("com_offset > 1 m", "widen the distributions or the condition (com_offset was ", "never hold"),
        # a value no scene of the file reaches: levels is not drawn
        ("levels > 100", "it can never hold, whatever is drawn: levels is 5 in every draw", "widen"),
        # a field nothing draws, beside a derived quantity that is not the cause
        (
            "timing.interval > 5 s and com_offset < 50 mm",
            "never hold, whatever is drawn: timing.interval is 0.5 s in",
            "com_offset",
        ),
        # below what the quantity can be: a distance is never negative
        ("com_offset < -1 mm", "it can never hold, whatever is drawn: com_offset is never below 0; change", "widen"),
        (
            "max_overhang < 0 or levels == 6",
            "levels is 5 in every draw (no distribution changes it); max_overhang is never below 0",
            "widen",
        ),
    ],
)
def test_the_advice_for_a_condition_no_draw_meets_names_what_limits_it(condition, says, not_said):
    with pytest.raises(ScenarioError) as err:
        compile_scenario(parse_scenario(STACK + f"require: ['{condition}']\n", "r.yaml"))
    assert err.value.field == "require[0]" and "none of 1000 draws met every condition" in err.value.message
    assert says in err.value.message and not_said not in err.value.message.split("none of 1000 draws")[1]


def test_a_scene_that_is_not_random_and_fails_its_condition_is_refused():
    with pytest.raises(ScenarioError) as err:
        compile_scenario(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 3}}\nrequire: [levels > 3]\n", "r.yaml"))
    assert err.value.field == "require[0]" and "levels = 3" in err.value.message
    with pytest.raises(ScenarioError) as err:  # a length in the unit a file writes, not bare metres
        text = "stackdsl: 1\nstructure: {tower: {levels: 3, bricks_per_layer: 1, turn: 0, shift: 50 mm}}\n"
        compile_scenario(parse_scenario(text + "require: ['com_offset < 30 mm']\n", "r.yaml"))
    assert "com_offset = 75 mm" in err.value.message, err.value.message  # (50 + 100) / 2 over the first brick


def test_seed_replaces_the_files_seed():
    text = "stackdsl: 1\nseed: 1\nstructure: {tower: {levels: 3}}\ntiming: {placement_error: 2 mm}\n"
    one, nine = parse_scenario(text, "s.yaml"), parse_scenario(text, "s.yaml", seed=9)
    assert (one.seed, nine.seed) == (1, 9)
    poses = [[a.position for a in compile_scenario(s).placements] for s in (one, nine)]
    assert poses[0] != poses[1]
    random = parse_scenario(STACK + "seed: 4\n", "r.yaml", seed=5)
    assert random.template.seed == 5
    assert random.structure.tower.shifts == parse_scenario(STACK + "seed: 5\n", "r.yaml").structure.tower.shifts


def test_a_field_a_draw_lacks_fails_its_condition_and_is_drawn_again():
    text = (
        STACK.replace("levels: 5,", "levels: {choice: [2, 5]},")
        + "require: ['structure.tower.shifts.3.0 > -1']\nsweep: {samples: 6}\n"
    )
    template = parse_scenario(text, "r.yaml").template
    for k in range(6):
        sample, _ = accept(template.scenario(0, k))
        assert sample.structure.tower.levels == 5  # a 2-level draw has no fourth shift: redrawn
    assert not parse("x < 1").holds({})


@pytest.mark.parametrize(
    "condition, refused",
    [
        ("overhang < 3 s", "compares overhang (a length) with 3 s (a time)"),
        ("levels > 2 mm", "compares levels (a count) with 2 mm (a length)"),
        ("structure.tower.spacing + 1 s < 0.2", "adds structure.tower.spacing (a length) to 1 s (a time)"),
        ("max(gap, timing.interval) > 0", "takes the max of gap (a length) and timing.interval (a time)"),
        ("gap - 1 s > 0", "subtracts 1 s (a time) from gap (a length)"),
        ("overhang < 10 mm and levels >= 3", None),
        ("structure.tower.spacing > 0.5 * gap + 1 mm", None),
        ("com_offset / 1 mm < 2000 and timing.interval > 0.5 s", None),
        ("overhang < 0.01 and bricks * 1 mm < 1 m", None),
        ("overhang * 2 Hz * 2 Hz < 1 m", "compares overhang * 2 Hz * 2 Hz (an acceleration) with 1 m (a length)"),
        ("overhang / 1 s < 1 m", "compares overhang / 1 s (a speed) with 1 m (a length)"),
        ("overhang * 2 Hz * 2 Hz < 9.8 m/s^2 and overhang * overhang < 1 cm^2", None),
        ("overhang * overhang < 1 m", "compares overhang * overhang (an area) with 1 m (a length)"),
        ("overhang / timing.interval < 2 m/s and 1 / timing.interval < 2 Hz", None),
        ("overhang * 3 s < 1 m^2/s", "compares overhang * 3 s (a quantity in m s) with 1 m^2/s (a quantity in m^2/s)"),
    ],
)
def test_a_condition_mixing_kinds_of_quantity_is_refused_at_it(condition, refused):
    """A unit slip in a condition (a length against a time, a count against a length) is bad
    input at the condition, not a silent comparison of SI numbers; a bare number goes with
    anything, and a product or a quotient has the kind its factors make: a length times a rate
    twice is an acceleration, not the rate it was once called."""
    text = f"""stackdsl: 1
structure: {{tower: {{levels: 3, spacing: {{uniform: [90 mm, 100 mm]}}}}}}
timing: {{interval: 1 s}}
require: ["{condition}"]
"""
    scenario = parse_scenario(text, "kinds.yaml")
    if refused is None:
        accept(scenario)
        return
    with pytest.raises(ScenarioError) as err:
        accept(scenario)
    assert err.value.field == "require[0]" and err.value.line == 4 and refused in err.value.message


NEVER = """stackdsl: 1
structure: {tower: {levels: LEVELS, bricks_per_layer: 1, turn: 0, shift: {uniform: [-1 mm, 1 mm], per: layer}}}
timing: {interval: 0.1 s}
require: ['com_offset < 0.001 mm']
"""


def test_the_draws_stop_at_their_time_budget(monkeypatch):
    import stackdsl.compile.require as require_module

    clock = iter(range(10_000))  # a clock one second later at every reading: the draws, not the machine, decide
    monkeypatch.setattr(require_module, "perf_counter", lambda: float(next(clock)))
    scenario = parse_scenario(NEVER.replace("LEVELS", "5"), "n.yaml")
    with pytest.raises(ScenarioError) as err:
        accept(scenario, 5)
    assert err.value.field == "require[0]"
    assert (
        "sample 0: none of 6 draws met every condition in 7.0 s, stopped by --timeout 5 before the 1000 draws"
        in err.value.message
    )
    assert "6 failed this one; widen the distributions or the condition" in err.value.message
    with pytest.raises(ScenarioError) as err:  # with no --timeout (or a longer one), at most DRAW_TIME
        accept(scenario, 1000.0)
    assert f"none of {int(require_module.DRAW_TIME) + 1} draws" in err.value.message
    assert f"stopped by the {require_module.DRAW_TIME:g} s a sample's draws may take" in err.value.message
    # a budget ends the search, never changes what it finds
    monkeypatch.setattr(require_module, "perf_counter", lambda: 0.0)
    text = STACK + "require: [max_overhang < 30 mm]\nsweep: {samples: 4}\n"
    template = parse_scenario(text, "r.yaml").template
    assert all(accept(template.scenario(0, k), 0.0)[1] == accept(template.scenario(0, k))[1] for k in range(4))


@pytest.mark.slow
def test_check_timeout_bounds_the_draws_of_a_tall_random_stack(tmp_path, capsys):
    import time

    from stackdsl.cli.main import main

    (tmp_path / "n.yaml").write_text(NEVER.replace("LEVELS", "200"))
    started = time.perf_counter()
    assert main(["check", str(tmp_path / "n.yaml"), "-j", "1", "--timeout", "1"]) == 2
    assert time.perf_counter() - started < 15  # 1000 draws took 44 s
    err = capsys.readouterr().err
    assert "n.yaml:4:11: require[0]: sample 0: none of " in err and "stopped by --timeout 1 before the 1000 draws" in err


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 80), st.integers(0, 2**32 - 1))
def test_com_offsets_are_the_cumsums_of_each_level_bit_for_bit(n, seed):
    from stackdsl.compile import require as require_module

    rng = np.random.default_rng(seed)
    mass = rng.uniform(0.001, 1.0, n)
    moment = rng.normal(0, 0.1, (n, 2)) * mass[:, None]
    centres = rng.normal(0, 0.1, (n, 2))
    expected = []  # the sums as a cumsum from each level up (the definition, and what the draws were accepted by)
    for i in range(n - 1):
        com = np.cumsum(moment[i + 1 :], axis=0) / np.cumsum(mass[i + 1 :])[:, None]
        expected.append(float(np.linalg.norm(com - centres[i], axis=1).max()))
    assert require_module._com_offsets(mass, moment, centres) == expected

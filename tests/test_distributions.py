"""Distributions in scenario files and sweeps: what is drawn, from which seed, and where errors point."""

from __future__ import annotations

import numpy as np
import pytest

from stackdsl import ScenarioError, compile_scenario, parse_scenario
from stackdsl.lang.distributions import sample_seed

WALK = """stackdsl: 1
structure:
  tower:
    levels: 8
    bricks_per_layer: 1
    turn: 0
    shift: {uniform: [-60 mm, 60 mm], per: layer}
    yaw_jitter: {normal: {mean: 0, sd: 2, clip: [-3, 3]}, per: brick}
    spacing: {choice: [90 mm, 96 mm]}
sweep: {samples: 50}
"""


def template(text: str = WALK):
    scenario = parse_scenario(text, "t.yaml")
    assert scenario.template is not None
    return scenario.template


def test_sample_k_is_the_kth_child_of_the_seed_whoever_draws_it():
    t = template()
    first = [t.parameters(0, k) for k in range(10)]
    again = [t.parameters(0, k) for k in reversed(range(10))][::-1]  # another order, the same draws
    assert first == again
    assert len({str(p) for p in first}) == 10  # and they differ between samples
    assert sample_seed(7, 3).generate_state(2).tolist() == np.random.SeedSequence(7).spawn(4)[3].generate_state(2).tolist()
    other = template(WALK + "seed: 1\n")
    assert other.parameters(0, 0) != t.parameters(0, 0)


def test_per_layer_shift_is_a_random_walk_and_per_brick_yaw_a_jitter():
    t = template()
    for k in range(20):
        s = t.scenario(0, k)
        tower = s.structure.tower
        assert tower.shifts is not None and len(tower.shifts) == 7 and tower.shift == (0.0, 0.0)
        assert all(-0.06 <= x <= 0.06 and y == 0.0 for x, y in tower.shifts)
        assert isinstance(tower.yaw_jitter, list) and len(tower.yaw_jitter) == 8 and all(-3 <= j <= 3 for j in tower.yaw_jitter)
        program = compile_scenario(s)
        xs = [p.position[0] for p in program.placements]
        # each layer's centre is the one below plus its own shift: a walk, up to the placement error (0 here)
        assert np.allclose(np.diff(xs), [x for x, _ in tower.shifts])
        assert [p.yaw for p in program.placements] == pytest.approx(tower.yaw_jitter)
    # the draws are uniform over the range: their mean over many samples is near 0
    shifts = [x for k in range(50) for x, _ in t.scenario(0, k).structure.tower.shifts]
    assert abs(np.mean(shifts)) < 0.006 and max(shifts) > 0.05 and min(shifts) < -0.05


def test_a_distribution_draws_in_the_unit_written_and_the_field_checks_it():
    s = parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 2, spacing: {uniform: [9 cm, 10 cm]}}}\n", "t.yaml")
    t = s.template
    values = [t.parameters(0, k)["structure.tower.spacing [m]"] for k in range(20)]
    assert all(0.09 <= v <= 0.10 for v in values)  # in SI, the unit in the column's name
    assert all(0.09 <= t.scenario(0, k).structure.tower.spacing <= 0.10 for k in range(20))  # metres inside


@pytest.mark.parametrize(
    "field, low, high",
    [
        ("shift: {uniform: [0, 20 mm]}", 0.0, 0.02),
        ("shift: {uniform: [-2 cm, 0]}", -0.02, 0.0),
        ("shift: {normal: {mean: 0, sd: 5 mm, clip: [0, 10 mm]}}", 0.0, 0.01),
    ],
)
def test_a_bare_zero_in_a_distribution_is_zero_of_the_others_unit(field, low, high):
    """0 is 0 in any unit: ``[0, 20 mm]`` was refused ("the same kind of unit, or none: '20 mm'
    and 'no unit'"), where a new user writes it first. A bare number other than 0 among values
    with units still is (the test above)."""
    s = parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 2, bricks_per_layer: 1, turn: 0, {field}}}}}\n", "t.yaml")
    assert s.template is not None
    values = [s.template.parameters(0, k)["structure.tower.shift [m]"] for k in range(30)]
    assert all(low - 1e-12 <= v <= high + 1e-12 for v in values) and len(set(values)) > 1


def test_a_drawn_field_of_a_named_part_is_named_by_the_part_as_require_names_it():
    text = """stackdsl: 1
structure:
  - {name: left, tower: {levels: 2}}
  - {name: deck, on: left, bricks: [{at: [0, 0, 4 mm]}], origin: [{uniform: [-5 mm, 5 mm]}, 0]}
require: ["structure.deck.origin.0 > -4 mm"]
"""
    parameters = parse_scenario(text, "t.yaml").template.parameters(0, 0)
    assert list(parameters) == ["structure.deck.origin.0 [m]"]
    assert -0.004 < parameters["structure.deck.origin.0 [m]"] <= 0.005


_TOWER = "structure: {tower: {levels: 3}}\n"


@pytest.mark.parametrize(
    ("field", "message", "column"),
    [
        (
            "spacing: {uniform: [90 mm, 20 m]}",
            "a value this distribution can draw, '20000.0 mm': expected a length from 0 to 10 m",
            14,
        ),
        ("spacing: {uniform: [1 s, 2 s]}", "expected a length", 14),
        ("spacing: {uniform: [90 mm, 2]}", "same kind of unit, or none", 24),
        ("spacing: {uniform: [100 mm, 90 mm]}", "low '100 mm' is above high '90 mm'", 24),
        ("spacing: {uniform: [90 mm, 100 mm], per: layer}", "'per: layer' is not allowed here", 46),
        ("spacing: {normal: {mean: 96 mm, sd: -1 mm}}", "the standard deviation must be at least 0", 23),
        ("spacing: {uniform: [90 mm, 100 mm], pre: layer}", "unknown key 'pre'", 14),
        ("levels: {choice: [3, 2000]}", "a value this distribution can draw, 2000", 13),
        ("spacing: {unifrom: [90 mm, 100 mm]}", "unknown key 'unifrom'; did you mean the distribution 'uniform'?", 15),
        ("spacing: {Normal: {mean: 96 mm, sd: 1 mm}}", "did you mean the distribution 'normal'?", 15),
    ],
)
def test_a_bad_distribution_is_one_error_at_its_node(field, message, column):
    text = f"stackdsl: 1\nstructure:\n  tower:\n    levels: 3\n    {field}\n"
    if field.startswith("levels"):
        text = f"stackdsl: 1\nstructure:\n  tower:\n    {field}\n"
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, "t.yaml")
    error = info.value
    assert message in error.message and error.column == column and error.line == (4 if field.startswith("levels") else 5)


def test_a_normal_that_can_draw_past_its_fields_range_is_refused_before_any_sample():
    from stackdsl.lang.sampling import NORMAL_REACH

    def loaded(normal: str):
        return parse_scenario(
            f"stackdsl: 1\nstructure: {{tower: {{levels: 3}}}}\ntiming:\n  placement_error: {normal}\n", "t.yaml"
        )

    # unclipped, 2 sd from a bound of the field (0 to 10 mm): a sample would draw below 0 sooner or later
    with pytest.raises(ScenarioError) as info:
        loaded("{normal: {mean: 2 mm, sd: 1 mm}}")
    error = info.value
    assert (error.line, error.column, error.field) == (4, 20, "timing.placement_error")  # at the distribution
    low = 2 - NORMAL_REACH * 1
    assert f"with no clip (its mean - {NORMAL_REACH:g} sd), '{low!r} mm'" in error.message
    assert "expected a length from 0 to 10 mm" in error.message and "give the normal a clip" in error.message
    template = loaded("{normal: {mean: 2 mm, sd: 1 mm, clip: [0 mm, 4 mm]}}").template  # clipped inside: every draw is taken
    assert all(0 <= template.scenario(0, k).timing.placement_error <= 0.004 for k in range(200))
    loaded(f"{{normal: {{mean: 5 mm, sd: {4.9 / NORMAL_REACH!r} mm}}}}")  # within the reach of both bounds
    with pytest.raises(ScenarioError, match=r"a value this distribution can draw, '20.0 mm'"):
        loaded("{normal: {mean: 5 mm, sd: 1 mm, clip: [0 mm, 20 mm]}}")  # a clip is where it ends
    with pytest.raises(ScenarioError, match=r"its mean \+ 10 sd\), '14.0 mm'"):
        loaded("{normal: {mean: 9 mm, sd: 0.5 mm}}")


def test_a_drawn_value_only_the_compiler_refuses_is_bad_input_at_the_distribution(tmp_path, capsys, monkeypatch):
    import stackdsl.batch.sweep
    from stackdsl.cli.main import main

    # spacing below 24 mm overlaps the layer's two bricks: decided by the compiler, for a draw, not by the field
    text = "stackdsl: 1\nstructure:\n  tower: {levels: 2, spacing: {uniform: [20 mm, 100 mm]}}\ntiming: {settle: 0.2 s}\n"
    (tmp_path / "s.yaml").write_text(text + "sweep: {samples: 40}\nexpect: {p_stands: '>= 0.5'}\n")
    # the low end is compiled before any sample runs: refused at once, whatever the samples draw
    assert main(["sweep", str(tmp_path / "s.yaml"), "-j", "1", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "s.yaml:3:31: structure.tower.spacing: a value this distribution can draw, '20.08 mm', makes the scene refused" in err
    assert "use a spacing of at least" in err and "refused as bad input" not in err and not (tmp_path / "o").exists()
    # a refusal the bounds do not foresee is still said at the sample that draws it, and stops the sweep
    monkeypatch.setattr(stackdsl.batch.sweep, "compile_bounds", lambda *args, **kwargs: None)
    template = parse_scenario((tmp_path / "s.yaml").read_text(), "s.yaml").template
    refused = next(k for k in range(40) if template.scenario(0, k).structure.tower.spacing < 0.024)
    assert main(["sweep", str(tmp_path / "s.yaml"), "-j", "1", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert f"s.yaml:3:31: structure.tower.spacing: sample {refused}: brick L01.2" in err and "use a spacing of at least" in err
    assert f"sample {refused} refused as bad input; the sweep stopped there" in err and not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("text", "where", "message"),
    [
        ("sweep: {samples: 3}\nexpect:\n  p_stands: {choice: ['>= 0.5']}\n", "expect.p_stands", "cannot stand in 'expect'"),
        # a tolerance, a mark's reason or condition drawn at random: each sample judged by another rule
        ("golden: {tolerance: {position: {uniform: [1 mm, 2 mm]}}}\n", "golden.tolerance.position", "cannot stand in 'golden'"),
        ("xfail: {reason: {choice: [a, b]}}\n", "xfail.reason", "cannot stand in 'xfail'"),
        ("skip: {reason: x, when: {choice: ['backend == mujoco', 'mode == raw']}}\n", "skip.when", "cannot stand in 'skip'"),
        (
            "sweep: {samples: 2, grid: {timing.placement_eror: [0, 1 mm]}}\n",
            "sweep.grid.timing.placement_eror",
            "has no field 'placement_eror'",
        ),
        (
            "sweep: {samples: 2, grid: {timing.placement_error: [0, 50 mm]}}\n",
            "sweep.grid.timing.placement_error[1]",
            "the grid value '50 mm'",
        ),
        ("expect: {p_stands: '>= 0.9'}\n", "expect.p_stands", "a statistical expectation needs a sweep"),
        ("sweep: {samples: 2}\nexpect: {stands: true}\n", "expect.stands", "a sweep's expectations are statistics"),
        ("sweep: {samples: 2}\nexpect: {collapse: {mean: seven}}\n", "expect.collapse.mean", "such as 7 or '7 ± 0.5'"),
        ("sweep: {samples: 2}\nexpect: {collapse: {mean: 7.1}}\n", "expect.collapse.mean", "could never pass"),
        ("sweep: {samples: 100000, grid: {timing.interval: [0.5, 1, 2]}}\n", "sweep", "runs; at most 200000"),
    ],
)
def test_sweep_and_expectation_errors_point_at_the_field(text, where, message):
    with pytest.raises(ScenarioError) as info:
        parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 3}}\n" + text, "t.yaml")
    assert info.value.field == where and message in info.value.message


def test_a_grid_runs_every_combination_with_the_same_draws_in_each_cell():
    grid = "sweep:\n  samples: 5\n  grid: {timing.placement_error: [0, 2 mm], timing.interval: [0.5, 1]}\n"
    t = template(WALK.replace("sweep: {samples: 50}\n", grid))
    assert t.cells == 4 and [t.cell(c) for c in range(4)] == [
        {"timing.placement_error": 0, "timing.interval": 0.5},
        {"timing.placement_error": 0, "timing.interval": 1},
        {"timing.placement_error": "2 mm", "timing.interval": 0.5},
        {"timing.placement_error": "2 mm", "timing.interval": 1},
    ]
    # common random numbers: the random fields of sample k are the same in every cell
    shifts = [t.scenario(c, 3).structure.tower.shifts for c in range(4)]
    assert all(s == shifts[0] for s in shifts)
    assert t.scenario(2, 3).timing.placement_error == 0.002


def test_explicit_shifts_and_yaw_jitter_are_checked():
    ok = parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 3, shifts: [1 mm, [2 mm, 1 mm]], yaw_jitter: 1}}\n")
    assert ok.structure.tower.layer_shift(3) == pytest.approx((0.003, 0.001))
    for bad, message in [
        ("shifts: [1 mm]", "'shifts' has one shift a layer above the first: 2 for 3 levels, not 1"),
        ("shift: 1 mm, shifts: [1 mm, 2 mm]", "give 'shift' (every layer alike) or 'shifts' (one a layer), not both"),
        ("yaw_jitter: [1, 2]", "a 'yaw_jitter' list has one angle a brick: 6, not 2"),
    ]:
        with pytest.raises(ScenarioError, match=message.replace("(", r"\(").replace(")", r"\)")):
            parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 3, {bad}}}}}\n")


@pytest.mark.parametrize(
    ("text", "where", "what", "inside"),
    [
        ("structure: {choice: [2, 3]}\n", "structure", "the whole structure section", "structure.tower.levels"),
        ("structure: {tower: {choice: [2, 3]}}\n", "structure.tower", "a whole tower", "structure.tower.levels"),
        (_TOWER + "timing: {uniform: [1 s, 2 s]}\n", "timing", "the whole timing section", "timing.interval"),
        (_TOWER + "actions: [{choice: [1, 2]}]\n", "actions[0]", "a whole action", "actions[0].remove.at"),
        (_TOWER + "materials: {pine: {choice: [1, 2]}}\n", "materials.pine", "a whole material", "materials.pine.density"),
        (
            "structure: {left: {choice: [1, 2]}, right: {tower: {levels: 2}}}\n",
            "structure.left",
            "a whole part",
            "structure.left.origin",
        ),
        ("structure: {bricks: [{uniform: [0, 1]}]}\n", "structure.bricks[0]", "a whole brick", "structure.bricks[0].at"),
    ],
)
def test_a_distribution_standing_for_a_whole_section_is_refused_naming_a_field_inside(text, where, what, inside):
    """A distribution draws one field's value: in place of a section, an item or a list it drew a
    number and the error said the section expected a mapping, not where the distribution goes."""
    with pytest.raises(ScenarioError) as info:
        parse_scenario("stackdsl: 1\n" + text, "t.yaml")
    assert info.value.field == where and info.value.line == text.count("\n") + 1
    assert f"a distribution draws the value of one field, and {where} is {what}; put it on a field inside, such as {inside}" == (
        info.value.message
    )


def test_names_a_file_chooses_are_not_taken_for_distributions():
    text = (
        "stackdsl: 1\nmaterials: {normal: {density: 500 kg/m^3}, choise: {density: {uniform: [400 kg/m^3, 500 kg/m^3]}}}\n"
        "brick_types: {uniform: {size: [120 mm, 24 mm, 8 mm], material: normal}}\n"
        "structure: {tower: {levels: 2, brick: uniform}}\nsweep: {samples: 2}\n"
    )
    scenario = parse_scenario(text, "names.yaml")
    assert scenario.materials["normal"].density == 500.0 and set(scenario.template.parameters(0, 0)) == {
        "materials.choise.density [kg/m^3]"
    }


@pytest.mark.parametrize(
    "drawn",
    [
        "shift: {uniform: [-20 mm, 20 mm], per: layer}",
        "yaw_jitter: {uniform: [-2, 2], per: brick}",
        "yaw_jitter: {uniform: [-2, 2], per: layer}",
    ],
)
@pytest.mark.parametrize("levels", [[3, 4], [4, 2, 7]])
def test_a_grid_over_levels_sizes_each_cells_per_layer_and_per_brick_draws(drawn, levels):
    text = (
        f"stackdsl: 1\nstructure: {{tower: {{levels: 3, bricks_per_layer: 2, {drawn}}}}}\n"
        f"sweep: {{samples: 3, grid: {{structure.tower.levels: {levels}}}}}\n"
    )
    t = template(text)
    for c, n in enumerate(levels):
        for k in range(3):
            tower = t.scenario(c, k).structure.tower
            assert tower is not None and tower.levels == n
            if "shift" in drawn:
                assert tower.shifts is not None and len(tower.shifts) == n - 1
            else:
                assert isinstance(tower.yaw_jitter, list) and len(tower.yaw_jitter) == 2 * n
            compile_scenario(t.scenario(c, k))


def test_a_grid_value_no_list_of_the_file_fits_is_refused_at_that_value():
    text = (
        "stackdsl: 1\nstructure: {tower: {levels: 3, shifts: [1 mm, 2 mm], spacing: {uniform: [90 mm, 96 mm]}}}\n"
        "sweep: {samples: 2, grid: {structure.tower.levels: [3, 4]}}\n"
    )
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, "t.yaml")
    assert info.value.field == "sweep.grid.structure.tower.levels[1]"
    assert info.value.message.startswith("the grid value 4: 'shifts' has one shift a layer above the first")
    # the file's own error stays the file's, whatever the grid
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text.replace("[1 mm, 2 mm]", "[1 mm]"), "t.yaml")
    assert info.value.field == "structure.tower.shifts" and "the grid value" not in info.value.message


DOMINO_CHOICE = """stackdsl: 1
structure: {dominoes: {count: {choice: [3, 5]}, spacing: {uniform: [60 mm, 70 mm]}}}
actions:
  - push: {target: {brick: D05, offset: [0, 0, 45 mm]}, direction: [-1, 0, 0], at: after level 1}
sweep: {samples: 4}
expect: {p_stands: "<= 0.5"}
"""


@pytest.mark.parametrize("samples", ["4", "20"])
def test_a_choice_that_leaves_out_a_pushed_domino_is_refused_at_the_choice_before_anything_runs(tmp_path, capsys, samples):
    """Every choice is drawn once in so many samples: a count of 3 leaves out D05, which the push
    names. The sweep passed or failed with the samples' luck (4 draws of 5), or was refused
    mid-sweep at the push after samples had run, not at the choice."""
    from stackdsl.cli.main import main

    path = tmp_path / "s.yaml"
    path.write_text(DOMINO_CHOICE)
    t = template(DOMINO_CHOICE)
    assert all(t.drawn(0, k)["structure.dominoes.count"] == 5 for k in range(4))  # the draws that hid it
    for command in (["sweep", str(path), "-j", "1", "--samples", samples, "--out", str(tmp_path / "o")], ["check", str(path)]):
        assert main(command) == 2
        err = capsys.readouterr().err
        first = err.splitlines()[0]
        assert first.startswith(f"{path}:2:31: structure.dominoes.count: a choice this distribution can draw, 3, makes"), first
        assert "actions[0].push.target.brick (line 4): no brick of the structure is 'D05'" in first
        assert "refused as bad input" not in err and not (tmp_path / "o").exists()


def test_a_pinned_bound_keeps_the_other_draws_of_sample_0_and_a_bound_require_rejects_is_passed_over():
    from stackdsl.batch.sweep import compile_bounds

    t = template(DOMINO_CHOICE)
    count = next(d for d in t.distributions if d.label == "structure.dominoes.count")
    assert [(d.label, v) for d, v in t.bounds()] == [
        ("structure.dominoes.count", 3),
        ("structure.dominoes.count", 5),
        ("structure.dominoes.spacing", "60.01 mm"),
        ("structure.dominoes.spacing", "69.99 mm"),
    ]
    pinned = t.pinned(0, count, 3)
    assert pinned.structure.dominoes.count == 3
    assert pinned.structure.dominoes.spacing == t.scenario(0, 0).structure.dominoes.spacing  # the other draw is sample 0's
    with pytest.raises(ScenarioError, match="a choice this distribution can draw, 3"):
        compile_bounds(t)
    required = template(DOMINO_CHOICE.replace("sweep:", "require: ['structure.dominoes.count >= 4']\nsweep:"))
    compile_bounds(required)  # 3 is never run: its draws are drawn again


def test_a_sample_refused_at_a_field_no_distribution_draws_says_what_it_drew(tmp_path, capsys):
    from stackdsl.cli.main import main

    path = tmp_path / "s.yaml"
    path.write_text(DOMINO_CHOICE.replace("choice: [3, 5]", "choice: [5, 3]"))  # sample 0 draws 3 now
    assert main(["check", str(path)]) == 2
    first = capsys.readouterr().err.splitlines()[0]
    assert first.startswith(f"{path}:4:28: actions[0].push.target.brick: sample 0: no brick of the structure is 'D05'"), first
    assert first.endswith("(this sample drew structure.dominoes.count = 3, structure.dominoes.spacing = 63.16 mm)")


CARD_HOUSE_ERRORS = """\
stackdsl: 1
structure:
  b:
    card_house:
      levels: 1
sweep:
  samples: 200
  grid:
    timing.placement_error: [0, 2 mm]
"""
"""A card house's leaning bricks touch as written: 2 mm of placement error moves one into the
other in most samples, though not in sample 0 of that cell."""


def test_a_placement_error_that_moves_a_brick_into_another_is_refused_before_any_sample_runs(tmp_path, capsys, monkeypatch):
    """Each sample draws its placement offsets from its own seed: a sweep of 400 runs was refused
    20 s in, after the samples before the one that overlapped had run, and its first line of
    standard error was not the error."""
    import stackdsl.batch.sweep
    from stackdsl.cli.main import main

    t = template(CARD_HOUSE_ERRORS)
    compile_scenario(t.scenario(1, 0))  # sample 0 of the 2 mm cell is not refused: only a later one shows it

    def no_run(*args, **kwargs):
        raise AssertionError("a sample ran before the file was refused")

    monkeypatch.setattr(stackdsl.batch.sweep, "run_batch", no_run)
    path = tmp_path / "s.yaml"
    path.write_text(CARD_HOUSE_ERRORS)
    for command in (["sweep", str(path), "-j", "1", "--out", str(tmp_path / "o")], ["check", str(path), "-j", "1"]):
        assert main(command) == 2
        first = capsys.readouterr().err.splitlines()[0]
        assert first.startswith(f"{path}:9:33: sweep.grid.timing.placement_error[1]: the grid value '2 mm'"), first
        assert "placement error of up to 2.0 mm (seed " in first and not (tmp_path / "o").exists()


JITTER_OVERLAP = """\
stackdsl: 1
structure: {tower: {levels: 12, bricks_per_layer: 2, spacing: 30 mm, yaw_jitter: {uniform: [-3.4, 3.4], per: brick}}}
sweep: {samples: 150}
expect: {p_stands: ">= 0.5"}
"""
"""Each sample turns each brick by its own draw: sample 7's turn two bricks of a layer into each other."""


def test_check_stops_a_sweep_at_the_first_sample_refused_as_sweep_does(tmp_path, capsys, monkeypatch):
    """check ran all 150 samples (15.9 s) to refuse the file at sample 7; sweep stops there."""
    import stackdsl.batch.sweep
    from stackdsl.cli.main import main

    ran = []
    one = stackdsl.batch.sweep._one
    monkeypatch.setattr(stackdsl.batch.sweep, "_one", lambda *a, **k: ran.append(a[2]) or one(*a, **k))
    path = tmp_path / "j.yaml"
    path.write_text(JITTER_OVERLAP)
    assert main(["check", str(path), "-j", "1", "--timeout", "60"]) == 2
    captured = capsys.readouterr()
    assert "bad input in a sample" in captured.out and "budget ran out" not in captured.out
    refused = int(captured.err.split("sample ")[1].split(":")[0])
    assert ran == list(range(refused + 1)), ran
    # the turn, not the spacing (30 mm for bricks 24 mm wide), put them into each other: said at yaw_jitter
    assert f"{path}:2:82: structure.tower.yaw_jitter: sample {refused}:" in captured.err, captured.err

"""YAML -> Scenario: units, defaults, and errors that point at file:line:col."""

import textwrap

import pytest

from stackdsl import ScenarioError, load_scenario, parse_scenario
from stackdsl._units import angle, density, length, speed, time


def scenario(text: str):
    return parse_scenario(textwrap.dedent(text), "s.yaml")


def error(text: str) -> ScenarioError:
    with pytest.raises(ScenarioError) as info:
        scenario(text)
    return info.value


# units ------------------------------------------------------------------------
@pytest.mark.parametrize(
    "convert, text, si",
    [
        (length, "120 mm", 0.12),
        (length, "12 cm", 0.12),
        (length, 0.12, 0.12),
        (length, "1e3", 1000.0),  # PyYAML loads 1e3 as a string
        (time, "1/240 s", 1 / 240),
        (time, "250 ms", 0.25),
        (speed, "3 m/s", 3.0),
        (speed, "360 mm/s", 0.36),
        (density, "0.46 g/cm^3", 460.0),
        (angle, 90, 90.0),
        (angle, "0.5 rad", 28.64788975654116),
    ],
)
def test_quantities_convert_to_si(convert, text, si):
    assert convert(text) == pytest.approx(si)


@pytest.mark.parametrize("bad", ["3 s", True, "nan", "inf mm", "9**9**9 mm", "twelve", [1, 2], "12 furlong/s"])
def test_bad_lengths_are_rejected(bad):
    with pytest.raises(ValueError, match="expected a length"):
        length(bad)


# defaults and forms -----------------------------------------------------------
def test_defaults_are_kapla_pine_and_extension_mode():
    s = scenario(
        """
        stackdsl: 1
        structure: {tower: {levels: 3}}
        """
    )
    assert s.brick_type("kapla").size == (0.12, 0.024, 0.008)
    assert s.material("pine").density == 460.0 and s.material("pine").friction == 0.5
    assert s.engine.mode == "extension"
    assert s.timing.interval == 1.0
    assert s.name == "s"  # from the file name


@pytest.mark.parametrize(
    "written, level, tolerance",
    [("9±1", 9, 1), ("'9 +- 1'", 9, 1), ("9", 9, 0), ("{level: 9, tolerance: 2}", 9, 2), ("'12 ± 3'", 12, 3)],
)
def test_collapse_expectation_as_a_user_writes_it(written, level, tolerance):
    s = scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 3}}}}\nexpect: {{collapse: {written}}}\n")
    assert (s.expect.collapse.level, s.expect.collapse.tolerance) == (level, tolerance)


def test_levels_and_impact_times():
    s = scenario(
        """
        stackdsl: 1
        structure: {tower: {levels: 13}}
        impacts:
          - {target: {level: 13, side: +y}, speed: 1 m/s, at: after level 13}
          - {target: {point: [0, 0, 10 mm]}, direction: [1, 0, 0], speed: 2, at: 20 s}
        expect: {stays: ["1-11", 12], may_fall: 13}
        """
    )
    assert s.expect.stays == tuple(range(1, 13)) and s.expect.may_fall == (13,)
    assert s.impacts[0].at.after_level == 13 and s.impacts[1].at == 20.0
    assert s.impacts[1].target.point == (0.0, 0.0, 0.01)


def test_explicit_bricks():
    s = scenario(
        """
        stackdsl: 1
        structure:
          bricks:
            - {at: [0, 0, 4 mm]}
            - {id: top, at: [0, 0, 12 mm], yaw: 90, level: 2}
        """
    )
    assert s.structure.bricks[1].id == "top" and s.structure.bricks[1].yaw == 90.0


def test_load_scenario_reads_a_file(tmp_path):
    path = tmp_path / "tower.yaml"
    path.write_text("stackdsl: 1\nstructure: {tower: {levels: 2}}\n")
    assert load_scenario(path).structure.tower.levels == 2


# errors -------------------------------------------------------------------------
def test_typo_key_names_file_line_column_and_suggests():
    err = error(
        """\
        stackdsl: 1
        structure:
          tower:
            levels: 3
            bricks_per_layr: 2
        """
    )
    assert (err.file, err.line, err.column) == ("s.yaml", 5, 5)
    assert err.field == "structure.tower.bricks_per_layr"
    assert "unknown key 'bricks_per_layr'; did you mean 'bricks_per_layer'?" in err.message
    assert str(err).startswith("s.yaml:5:5: structure.tower.bricks_per_layr: unknown key")
    assert "    bricks_per_layr: 2" in str(err) and err.more == 0


def test_negative_size():
    err = error(
        """\
        stackdsl: 1
        brick_types:
          plank: {size: [120 mm, -24 mm, 8 mm]}
        structure: {tower: {levels: 3, brick: plank}}
        """
    )
    assert (err.line, err.column, err.field) == (3, 26, "brick_types.plank.size[1]")
    assert "expected a side from 3 mm to 10 m" in err.message and "-24 mm" in err.message


def test_string_where_a_number_belongs():
    err = error(
        """\
        stackdsl: 1
        structure:
          tower:
            levels: three
        """
    )
    assert (err.line, err.column, err.field) == (4, 13, "structure.tower.levels")
    assert "valid integer" in err.message


def test_wrong_unit():
    err = error("stackdsl: 1\nstructure: {tower: {levels: 3, spacing: 3 s}}\n")
    assert (err.line, err.field) == (2, "structure.tower.spacing")
    assert "expected a length such as '120 mm'" in err.message


@pytest.mark.parametrize(
    "text, line, field, words",
    [
        ("stackdsl: 1\nstructure:\n  tower: {levels: 3}\n  tower: {levels: 4}\n", 4, "structure.tower", "duplicate key 'tower'"),
        ("structure: {tower: {levels: 3}}\n", 1, "stackdsl", "'stackdsl: 1'"),
        ("stackdsl: 2\nstructure: {tower: {levels: 3}}\n", 1, "stackdsl", "should be 1"),
        ("stackdsl: 1\nstructure: {tower: {levels: 3, brick: oak}}\n", 2, "structure.tower.brick", "unknown brick type 'oak'"),
        ("stackdsl: 1\nstructure: {tower: {levels: 3}}\nexpect: {collapse: 9 pm 1}\n", 3, "expect.collapse", "'9±1'"),
        ("stackdsl: 1\nstructure: {tower: {levels: 3}, bricks: [{at: [0, 0, 0]}]}\n", 2, "structure", "exactly one"),
        ("stackdsl: 1\nstructure: {tower: {levels: 3}}\nexpect: {stands: true, collapse: 3}\n", 3, "expect", "cannot both"),
        ("stackdsl: 1\nstructure: {tower: {levels: 3, spacing: yes}}\n", 2, "structure.tower.spacing", "got True"),
        ("stackdsl: 1\nstructure: {tower: {levels: 3}}\n1: x\n", 3, "1", "keys must be names"),
        ("stackdsl: 1\nbase: &b {levels: 3}\nstructure: {tower: {<<: *b}}\n", 3, "structure.tower.<<", "merge keys"),
        (
            "stackdsl: 1\nstructure: {tower: {levels: 3}}\nimpacts: [{target: {level: 1, side: +x}, speed: 1, at: soon}]\n",
            3,
            "impacts[0].at",
            "after level N",
        ),
    ],
)
def test_one_clear_error_per_problem(text, line, field, words):
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, "s.yaml")
    err = info.value
    assert (err.line, err.field) == (line, field)
    assert words in err.message


def test_invalid_yaml():
    err = error("stackdsl: 1\nstructure: [\n  tower\n")
    assert err.line is not None and "not valid YAML" in err.message


def test_empty_file_and_top_level_list():
    assert "empty" in error("").message
    assert "mapping of fields" in error("- 1\n- 2\n").message


def test_alias_bomb_fails_fast():
    rows = ["a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    for prev, name in zip("abcdef", "bcdefg"):
        rows.append(f"{name}: &{name} [{', '.join(['*' + prev] * 10)}]")
    err = error("\n".join(rows) + "\n")
    assert "more than" in err.message


def test_missing_file_and_limits(tmp_path):
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenario(tmp_path / "nope.yaml")
    err = error("stackdsl: 1\nstructure: {tower: {levels: 2000}}\n")
    assert err.field == "structure.tower.levels" and "less than or equal to 1000" in err.message
    err = error("stackdsl: 1\nstructure: {tower: {levels: 1000, bricks_per_layer: 6}}\n")
    assert "at most 5000" in err.message

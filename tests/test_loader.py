"""YAML -> Scenario: units, defaults, and errors that point at file:line:col."""

import os
import random
import socket
import textwrap
from pathlib import Path

import pytest

from stackdsl import ScenarioError, ScenarioErrors, compile_scenario, load_scenario, parse_scenario
from stackdsl.batch import check as _check
from stackdsl.batch.check import discover
from stackdsl.cli import main as _cli
from stackdsl.compile import compiler as _compiler
from stackdsl.lang import loader as _loader
from stackdsl.lang import scenario_file as _scenario_file
from stackdsl.lang.loader import MAX_DEPTH
from stackdsl.lang.scenario_file import MAX_FILE_BYTES
from stackdsl.lang.units import angle, density, frequency, length, speed, time


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


@pytest.mark.parametrize(
    "written, message",
    [
        (
            "'11±0.5'",
            "'11±0.5' allows level 11 only: write 11; a fraction is for a sweep's statistics, such as collapse: {mean: '11 ± 0.5'}",
        ),
        ("'11 +- 1.5'", "allows levels 10 to 12, as '11±1' does: write that"),
        ("'10.5±1'", "allows levels 10 to 11, which no whole 'N±T' gives: write '10±1' or '11±1'"),
        ("10.5", "10.5 allows no whole level: write 10 or 11"),
        ("'10.5'", "'10.5' allows no whole level: write 10 or 11"),
    ],
)
def test_a_runs_collapse_level_is_whole_and_a_fraction_says_the_whole_form(written, message):
    """A run collapses at a whole level, so a fraction in a run's ``collapse`` is refused, with
    the whole form that allows the same levels (the same text in a sweep's mean is a fraction)."""
    with pytest.raises(ScenarioError) as info:
        scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 12}}}}\nexpect: {{collapse: {written}}}\n")
    e = info.value
    assert (e.field, e.line, e.column) == ("expect.collapse", 3, 20)
    assert e.message.startswith("expected a whole level with an optional whole tolerance, such as 9, '9±1' or '9 +- 1'")
    assert "a run collapses at a whole level" in e.message and message in e.message


def test_a_fraction_in_a_runs_collapse_mapping_is_refused_at_its_field_with_why():
    with pytest.raises(ScenarioError) as info:
        scenario("stackdsl: 1\nstructure: {tower: {levels: 12}}\nexpect: {collapse: {level: 11, tolerance: 0.5}}\n")
    assert (info.value.field, info.value.column) == ("expect.collapse.tolerance", 43)
    assert "a run collapses at a whole level, so a level and its tolerance are whole numbers" in info.value.message


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
    assert "expected a side from 1.5 mm to 10 m" in err.message and "-24 mm" in err.message


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
    assert err.message == "expected a whole number, not text, got 'three'"


@pytest.mark.parametrize(
    "written, hertz",
    [("2 Hz", 2.0), ("0.5 kHz", 500.0), ("120 rpm", 2.0), ("6.283185307 rad/s", 1.0), ("360 deg/s", 1.0), ("1 cycle/s", 1.0)],
)
def test_a_frequency_in_turns_per_time_is_turns_per_second(written, hertz):
    """pint counts a radian as 1, so '120 rpm' (4 pi rad/s) read as 12.6 Hz, a shake table's peak
    acceleration 39.5 times too high."""
    assert frequency(written) == pytest.approx(hertz, rel=1e-9)


def test_wrong_unit():
    err = error("stackdsl: 1\nstructure: {tower: {levels: 3, spacing: 3 s}}\n")
    assert (err.line, err.field) == (2, "structure.tower.spacing")
    assert "expected a length such as '120 mm'" in err.message


@pytest.mark.parametrize(
    "text, line, field, words",
    [
        ("stackdsl: 1\nstructure:\n  tower: {levels: 3}\n  tower: {levels: 4}\n", 4, "structure.tower", "duplicate key 'tower'"),
        ("structure: {tower: {levels: 3}}\n", 1, "stackdsl", "'stackdsl: 1'"),
        ("stackdsl: 2\nstructure: {tower: {levels: 3}}\n", 1, "stackdsl", "expected 1, got 2"),
        ("stackdsl: 1\nstructure: {tower: {levels: 3, brick: oak}}\n", 2, "structure.tower.brick", "unknown brick type 'oak'"),
        ("stackdsl: 1\nstructure: {tower: {levels: 3}}\nexpect: {collapse: 9 pm 1}\n", 3, "expect.collapse", "'9±1'"),
        ("stackdsl: 1\nstructure: {tower: {levels: 3}, bricks: [{at: [0, 0, 0]}]}\n", 2, "structure", "exactly one"),
        ("stackdsl: 1\nstructure: {tower: {levels: 3}}\nexpect: {stands: true, collapse: 3}\n", 3, "expect", "cannot both"),
        ("stackdsl: 1\nstructure: {tower: {levels: 3, spacing: yes}}\n", 2, "structure.tower.spacing", "got true"),
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


def test_an_unclosed_quote_or_bracket_is_shown_where_it_opens():
    # a new user's quote left open on line 2 read "7:1: found unexpected end of stream" of a
    # 6-line file, with no line shown; a bracket left open named only where parsing stopped
    quote = error('stackdsl: 1\nname: "unterminated\nstructure:\n  tower: {levels: 3}\n')
    assert (quote.line, quote.column) == (2, 7) and quote.source_line == 'name: "unterminated'
    assert "a quoted scalar that starts here and is still open at the file's end" in quote.message
    bracket = error("stackdsl: 1\nstructure:\n  tower: {levels: 3, shift: [1 mm,\n    spacing: 96 mm}\nexpect: {stands: true}\n")
    assert bracket.line == 4 and "while parsing a flow sequence that starts at 3:29" in bracket.message, bracket.message


def test_empty_file_and_top_level_list():
    assert "empty" in error("").message
    assert "mapping of fields" in error("- 1\n- 2\n").message


@pytest.mark.slow
def test_alias_bomb_fails_fast():
    rows = ["a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    for prev, name in zip("abcdef", "bcdefg"):
        rows.append(f"{name}: &{name} [{', '.join(['*' + prev] * 10)}]")
    err = error("\n".join(rows) + "\n")
    assert "more than" in err.message


def test_missing_file_and_limits(tmp_path):
    with pytest.raises(ScenarioError, match="no such file or folder"):
        load_scenario(tmp_path / "nope.yaml")
    err = error("stackdsl: 1\nstructure: {tower: {levels: 2000}}\n")
    assert err.field == "structure.tower.levels" and err.message == "expected 1000 or less, got 2000"
    err = error("stackdsl: 1\nstructure: {tower: {levels: 1000, bricks_per_layer: 6}}\n")
    assert "at most 5000" in err.message


# hostile input: every file ends in one ScenarioError at file:line:col ------------------
TAGS_REFUSED = "is not supported; a scenario holds only strings, numbers, true/false, null, lists and mappings"


def first_line(text: str) -> str:
    """The first line of the error ``text`` gives (file:line:col: field: message)."""
    return str(error(text)).splitlines()[0]


@pytest.mark.parametrize(
    "text, expected",
    [
        # 500 levels of flow nesting: the root mapping and 63 lists are allowed, the 64th list is not
        (
            "stackdsl: 1\nx: " + "[" * 500 + "]" * 500 + "\n",
            "s.yaml:2:67: lists and mappings are nested more than 64 levels deep",
        ),
        # block nesting, one level per line from line 3: line 66 holds the 64th list
        (
            "stackdsl: 1\nx:\n" + "".join("  " * i + "-\n" for i in range(1, 300)),
            "s.yaml:66:129: lists and mappings are nested more than 64 levels deep",
        ),
        ("stackdsl: 1\nx: &a [*a]\n", "s.yaml:2:8: the alias *a is inside the node it names (a recursive alias)"),
        ("stackdsl: 1\nx: &m {y: [1, {z: *m}]}\n", "s.yaml:2:19: the alias *m is inside the node it names (a recursive alias)"),
    ],
)
def test_nesting_is_bounded_and_recursive_aliases_are_refused(text, expected):
    assert first_line(text) == expected


def test_the_deepest_nesting_allowed_loads_as_data():
    depth = MAX_DEPTH - 1  # lists inside the root mapping
    err = error("stackdsl: 1\nx: " + "[" * depth + "]" * depth + "\n")
    assert str(err).splitlines()[0].startswith("s.yaml:2:1: x: unknown key 'x'")


def test_nesting_through_aliases_is_bounded_too():
    # each file-level nesting is within the limit; b expands a one level deeper than allowed
    depth = MAX_DEPTH - 1
    err = error(f"stackdsl: 1\na: &a {'[' * depth}1{']' * depth}\nb: [*a]\n")
    assert err.message == f"lists and mappings are nested more than {MAX_DEPTH} levels deep (through aliases)"
    assert err.field == "b" + "[0]" * depth  # b[0] is a's outermost list, this its innermost
    assert (err.line, err.column) == (3, 5)  # at the alias *a, which makes it deeper: its text is a's


@pytest.mark.parametrize(
    "text, expected",
    [
        ("stackdsl: 1\nstructure: {tower: {levels: 3}}\n\x0c\n", "s.yaml:3:1: U+000C FORM FEED is not allowed in YAML"),
        (
            "stackdsl: 1\nname: a\x00b\n",
            "s.yaml:2:8: U+0000 NULL is not allowed in YAML (is the file UTF-16, or not text at all?)",
        ),
        ('stackdsl: 1\nname: "a\x1bb"\n', "s.yaml:2:9: U+001B ESCAPE is not allowed in YAML"),
        ("stackdsl: 1\nname: a\ufffe\n", "s.yaml:2:8: U+FFFE (a noncharacter) is not allowed in YAML"),
        ("stackdsl: 1\nname: a\x7f\n", "s.yaml:2:8: U+007F DELETE is not allowed in YAML"),
        ("stackdsl: 1\nname: a\x9b\n", "s.yaml:2:8: U+009B (a C1 control character) is not allowed in YAML"),
        # lines are counted as an editor counts them: CR LF and CR each end one
        ("stackdsl: 1\r\nname: x\r\r  \x07\n", "s.yaml:4:3: U+0007 BELL is not allowed in YAML"),
        # NEL, LS and PS end a line to YAML 1.1 and to no editor: refused where they are
        (
            "stackdsl: 1\r\nname: x\r# a \x85\u2028  \x07\n",
            "s.yaml:3:5: U+0085 NEXT LINE (NEL) is not allowed: YAML 1.1, which stackdsl reads, takes it for a line "
            "break where an editor shows none; remove it, or write it as \\N in a double-quoted string",
        ),
        ('stackdsl: 1\nname: "a\u2028b"\n', "s.yaml:2:9: U+2028 LINE SEPARATOR is not allowed: YAML 1.1, which stackdsl reads,"),
        ("stackdsl: 1\n# \u2029\nname: x\n", "s.yaml:2:3: U+2029 PARAGRAPH SEPARATOR is not allowed: YAML 1.1, which"),
        ("stackdsl: 1\n\ufeffname: x\n", "s.yaml:2:1: U+FEFF (a byte order mark) is allowed only at the start of the file"),
        ('stackdsl: 1\nname: "a\\eb"\n', "s.yaml:2:7: name: U+001B ESCAPE, written as an escape, is not allowed in a value"),
        (
            'stackdsl: 1\nname: "\\ud800"\n',
            "s.yaml:2:7: name: U+D800 (a lone surrogate), written as an escape, is not allowed in a value",
        ),
    ],
)
def test_characters_yaml_does_not_allow_are_named_at_their_position(text, expected):
    err = error(text)
    assert str(err).splitlines()[0].startswith(expected)
    shown = str(err).splitlines()[1]
    assert shown.isprintable()  # the source line is shown without the control character itself


def test_tabs_and_newlines_written_as_escapes_are_kept():
    s = scenario('stackdsl: 1\ndescription: "a\\tb\\nc"\nstructure: {tower: {levels: 2}}\n')
    assert s.description == "a\tb\nc"


@pytest.mark.parametrize(
    "text, expected",
    [
        (
            "stackdsl: 1\nstructure: {tower: {levels: !!int abc}}\n",
            "s.yaml:2:29: structure.tower.levels: cannot read 'abc' as !!int (an integer)",
        ),
        (
            "stackdsl: 1\nstructure: {tower: {levels: !!int ''}}\n",
            "s.yaml:2:29: structure.tower.levels: cannot read '' as !!int (an integer)",
        ),
        ("stackdsl: 1\nengine: {ccd: !!bool maybe}\n", "s.yaml:2:15: engine.ccd: cannot read 'maybe' as !!bool (true or false)"),
        ("stackdsl: 1\nx: !!float abc\n", "s.yaml:2:4: x: cannot read 'abc' as !!float (a number)"),
        ("stackdsl: 1\nname: !!timestamp xyz\n", f"s.yaml:2:7: name: the YAML tag !!timestamp {TAGS_REFUSED}"),
        ("stackdsl: 1\nname: !!binary aGk=\n", f"s.yaml:2:7: name: the YAML tag !!binary {TAGS_REFUSED}"),
        ("stackdsl: 1\nx: !!set {a, b}\n", f"s.yaml:2:4: x: the YAML tag !!set {TAGS_REFUSED}"),
        ("stackdsl: 1\nx: !!omap [a: 1]\n", f"s.yaml:2:4: x: the YAML tag !!omap {TAGS_REFUSED}"),
        (
            "stackdsl: 1\nx: !!python/object/apply:os.system [ls]\n",
            f"s.yaml:2:4: x: the YAML tag !!python/object/apply:os.system {TAGS_REFUSED}",
        ),
        ("stackdsl: 1\nx: !brick plank\n", f"s.yaml:2:4: x: the YAML tag !brick {TAGS_REFUSED}"),
        ("stackdsl: 1\nx: !<tag:example.com,2000:x> 1\n", f"s.yaml:2:4: x: the YAML tag tag:example.com,2000:x {TAGS_REFUSED}"),
        (
            "%TAG !p! tag:yaml.org,2002:python/\n---\nstackdsl: 1\nx: !p!name:os {}\n",
            f"s.yaml:4:4: x: the YAML tag !!python/name:os {TAGS_REFUSED}",
        ),
        ("stackdsl: 1\nx: !!merge y\n", f"s.yaml:2:4: x: the YAML tag !!merge {TAGS_REFUSED}"),
        ("stackdsl: 1\n!!binary aGk=: 1\n", f"s.yaml:2:1: aGk=: the YAML tag !!binary {TAGS_REFUSED}"),
        ("stackdsl: 1\nx: !!str [1]\n", "s.yaml:2:4: x: the YAML tag !!str does not fit a list"),
        ("stackdsl: 1\nx: !!seq abc\n", "s.yaml:2:4: x: the YAML tag !!seq does not fit a scalar value"),
        ("stackdsl: 1\nx: !!map [1]\n", "s.yaml:2:4: x: the YAML tag !!map does not fit a list"),
        ("stackdsl: 1\n? [a]\n: 1\n", "s.yaml:2:3: ?: keys must be names, got a list"),
        (
            "stackdsl: 1\nstructure: {tower: {levels: " + "9" * 5000 + "}}\n",
            "s.yaml:2:29: structure.tower.levels: an integer written with 5000 digits is too large; a number must fit in a double",
        ),
        (  # YAML 1.1's base-60 integers: refused before PyYAML multiplies them out
            "stackdsl: 1\nx: 1" + ":1" * 100_000 + "\n",
            "s.yaml:2:4: x: an integer written with 200001 digits is too large; a number must fit in a double",
        ),
        (  # PyYAML fails inside its scanner with a ValueError: placed where it was reading
            'stackdsl: 1\nname: "ab\\U0011ffff"\n',
            "s.yaml:2:12: not valid YAML: ValueError: chr() arg not in range(0x110000)",
        ),
    ],
)
def test_tags_and_values_pyyaml_cannot_convert_are_errors_at_the_node(text, expected):
    assert first_line(text) == expected


@pytest.mark.parametrize("written", ["2024-01-01", "2001-13-45", "=", "<<"])
def test_dates_and_yaml_1_1_value_types_stay_strings(written):
    s = scenario(f"stackdsl: 1\nname: {written}\nstructure: {{tower: {{levels: 2}}}}\n")
    assert s.name == written


@pytest.mark.parametrize(("written", "value"), [("1e-4", 1e-4), ("2E-5", 2e-5), ("+1e-3", 1e-3), ("1_0e-5", 1e-4)])
def test_a_number_with_an_exponent_and_no_point_is_a_number(written, value):
    # PyYAML follows YAML 1.1, where 1e-4 is the string "1e-4"; YAML 1.2 and every user read a number
    s = scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\nengine: {{backend: mujoco, sleep_tolerance: {written}}}\n")
    assert s.engine.sleep_tolerance == pytest.approx(value, rel=1e-12)


def test_a_long_value_is_cut_in_the_message():
    err = error("stackdsl: 1\nname: " + "k" * 100_000 + "\nstructure: {tower: {levels: 2}}\n")
    assert (err.line, err.column, err.field) == (2, 7, "name")
    assert err.message.endswith("… (100002 characters)") and len(err.message) < 200
    shown = str(err).splitlines()[1]
    assert len(shown) < 140 and shown.endswith("…")


# files: what is read, and how ---------------------------------------------------------
@pytest.fixture
def nothing_opened(monkeypatch):
    """Makes opening any file fail the test: a refusal must come from os.stat alone."""

    def refuse(*args, **kwargs):
        raise AssertionError(f"opened {args[0]!r}")

    monkeypatch.setattr(os, "open", refuse)


def load_error(path) -> str:
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.line is None  # no position applies
    return str(info.value)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_is_refused_without_opening_it(tmp_path, nothing_opened):
    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)
    assert load_error(fifo) == f"{fifo}: not a regular file: a FIFO (named pipe)"
    with pytest.raises(ScenarioErrors) as info:
        discover([fifo])
    assert [str(e) for e in info.value.errors] == [f"{fifo}: not a regular file: a FIFO (named pipe)"]


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="no /dev/zero here")
def test_a_device_is_refused_without_opening_it(tmp_path, nothing_opened):
    assert load_error("/dev/zero") == "/dev/zero: not a regular file: a character device"
    with pytest.raises(ScenarioErrors) as info:
        discover(["/dev/zero"])
    assert str(info.value) == "/dev/zero: not a regular file: a character device"
    link = tmp_path / "zero.yaml"
    link.symlink_to("/dev/zero")
    assert load_error(link) == f"{link}: not a regular file: a character device"


@pytest.mark.skipif(not hasattr(socket, "AF_UNIX"), reason="no Unix sockets here")
def test_a_socket_and_a_folder_are_refused(tmp_path, nothing_opened):
    path = tmp_path / "s.yaml"
    if len(str(path)) > 100:
        pytest.skip("the temporary folder's path is too long for a socket")
    with socket.socket(socket.AF_UNIX) as sock:
        sock.bind(str(path))
        assert load_error(path) == f"{path}: not a regular file: a socket"
    assert load_error(tmp_path) == f"{tmp_path}: not a regular file: a folder"


def test_symlinks_to_files_are_followed_and_broken_ones_named(tmp_path):
    (tmp_path / "real.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: 2}}\n")
    (tmp_path / "link.yaml").symlink_to("real.yaml")
    assert load_scenario(tmp_path / "link.yaml").structure.tower.levels == 2
    (tmp_path / "broken.yaml").symlink_to("gone.yaml")
    assert load_error(tmp_path / "broken.yaml") == f"{tmp_path / 'broken.yaml'}: a broken symbolic link"
    assert load_error(tmp_path / "nope.yaml") == f"{tmp_path / 'nope.yaml'}: no such file or folder"


def test_the_size_cap_is_checked_before_reading(tmp_path, nothing_opened):
    big = tmp_path / "big.yaml"
    with big.open("wb") as f:  # sparse: no bytes written
        f.truncate(MAX_FILE_BYTES + 1)
    assert load_error(big) == f"{big}: the file is larger than {MAX_FILE_BYTES} bytes ({MAX_FILE_BYTES + 1} bytes)"


def test_a_file_that_grows_after_the_check_is_read_only_to_the_cap(tmp_path, monkeypatch):
    path = tmp_path / "grows.yaml"
    path.write_text("stackdsl: 1\n" + "# padding\n" * 20)
    monkeypatch.setattr(_loader, "file_problem", lambda _: None)  # as if the file grew after os.stat
    monkeypatch.setattr(_scenario_file, "MAX_FILE_BYTES", 64)
    reads = []
    real_fdopen = os.fdopen

    class Spy:
        """The opened file, recording how much is asked of each read."""

        def __init__(self, fd, mode):
            self.file = real_fdopen(fd, mode)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.file.close()

        def fileno(self):
            return self.file.fileno()

        def read(self, n=-1):
            reads.append(n)
            return self.file.read(n)

    monkeypatch.setattr(os, "fdopen", Spy)
    assert load_error(path) == f"{path}: the file is larger than 64 bytes"
    assert reads == [65]


@pytest.mark.parametrize(
    "data, expected",
    [
        (
            "stackdsl: 1\n".encode("utf-16"),
            "{}: the file is UTF-16 text (it starts with a UTF-16 byte order mark); save it as UTF-8",
        ),
        (
            "\ufeffstackdsl: 1\n".encode("utf-16-be"),
            "{}: the file is UTF-16 text (it starts with a UTF-16 byte order mark); save it as UTF-8",
        ),
        (
            "\ufeffstackdsl: 1\n".encode("utf-32-le"),
            "{}: the file is UTF-32 text (it starts with a UTF-32 byte order mark); save it as UTF-8",
        ),
        (
            "stackdsl: 1\n".encode("utf-16-le"),
            "{}:1:2: U+0000 NULL is not allowed in YAML (is the file UTF-16, or not text at all?)",
        ),
        (b"stackdsl: 1\nname: caf\xe9\n", "{}:2:10: the file is not UTF-8 text: byte 0xe9 (invalid continuation byte)"),
        (b"\xef\xbb\xbfstackdsl: 1\nname: \xff\n", "{}:2:7: the file is not UTF-8 text: byte 0xff (invalid start byte)"),
    ],
)
def test_encodings_other_than_utf8_are_named(tmp_path, data, expected):
    path = tmp_path / "e.yaml"
    path.write_bytes(data)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert str(info.value).splitlines()[0] == expected.format(path)


def test_a_utf8_byte_order_mark_is_accepted_and_not_counted(tmp_path):
    path = tmp_path / "bom.yaml"
    path.write_bytes(b"\xef\xbb\xbfstackdsl: 1\nstructure: {tower: {levels: 2}}\n")
    assert load_scenario(path).structure.tower.levels == 2
    path.write_bytes(b"\xef\xbb\xbfstackdsl: 1\nstructure: {tower: {levles: 2}}\n")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert (info.value.line, info.value.column) == (2, 21)
    assert info.value.source_line == "structure: {tower: {levles: 2}}"
    assert "\ufeff" not in str(parse_scenario("\ufeffstackdsl: 1\nstructure: {tower: {levels: 2}}\n", "b.yaml").name)


# the guard that turns library failures into errors hides no bug of ours ------------------
def test_an_exception_in_stackdsls_own_code_is_not_dressed_up(monkeypatch):
    def broken(*args, **kwargs):
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(_loader, "_plain", broken)
    with pytest.raises(ZeroDivisionError):
        parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 2}}\n", "s.yaml")
    monkeypatch.undo()
    monkeypatch.setattr(_loader.Scenario, "model_validate", broken)
    with pytest.raises(ZeroDivisionError):
        parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 2}}\n", "s.yaml")


# end to end: bad files stop the command before anything is compiled or simulated ----------
HOSTILE = {
    "deep": ("stackdsl: 1\nx: " + "[" * 500 + "]" * 500 + "\n", ":2:67: lists and mappings are nested"),
    "alias": ("stackdsl: 1\nx: &a [*a]\n", ":2:8: the alias *a"),
    "formfeed": ("stackdsl: 1\n\x0c\n", ":2:1: U+000C FORM FEED"),
    "tag": ("stackdsl: 1\nstructure: {tower: {levels: !!int abc}}\n", ":2:29: structure.tower.levels: cannot read"),
    "digits": ("stackdsl: 1\nstructure: {tower: {levels: " + "9" * 5000 + "}}\n", ":2:29: structure.tower.levels: an integer"),
}


@pytest.fixture
def never_compiled(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("compiled a bad file")

    monkeypatch.setattr(_check, "compile_scenario", refuse)
    monkeypatch.setattr(_compiler, "compile_scenario", refuse)


def test_check_and_compile_stop_at_bad_files(tmp_path, capsys, never_compiled):
    for name, (text, _) in HOSTILE.items():
        (tmp_path / f"{name}.yaml").write_text(text)
    assert _cli.main(["check", str(tmp_path), "-j", "1"]) == 2
    err = capsys.readouterr().err
    for name, (_, where) in HOSTILE.items():
        assert f"{tmp_path / name}.yaml{where}" in err
    assert "Traceback" not in err and "internal error" not in err
    for name, (_, where) in HOSTILE.items():
        assert _cli.main(["compile", str(tmp_path / f"{name}.yaml")]) == 2
        assert f"{name}.yaml{where}" in capsys.readouterr().err
    if Path("/dev/zero").exists():
        for command in ("check", "compile"):
            assert _cli.main([command, "/dev/zero"]) == 2
            assert "/dev/zero: not a regular file: a character device" in capsys.readouterr().err


def test_a_value_no_member_of_a_union_takes_is_one_error_at_the_field_as_written():
    """A pull's direction is a word or a list: 'up' is refused once, at the field the file wrote
    (not at pydantic's names for the union's members), saying both forms; [0, 0, 0], a list
    refused by the list form's own check, gives that check's reason alone."""
    head = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nactions:\n  - remove: {brick: L01.1, at: 3 s, direction: "
    with pytest.raises(ScenarioError) as err:
        parse_scenario(head + "up}\n", "d.yaml")
    e = err.value
    assert (e.field, e.line, e.column, e.others) == ("actions[0].remove.direction", 4, 48, ())
    assert e.message == "expected '+x', '-x', '+y' or '-y', or a list, got 'up'"
    with pytest.raises(ScenarioError) as err:
        parse_scenario(head + "[0, 0, 0]}\n", "d.yaml")
    assert err.value.field == "actions[0].remove.direction" and "must not be zero" in err.value.message
    assert err.value.others == ()


@pytest.mark.parametrize(
    "value, field, message",
    [
        ("{after_level: 0}", "actions[0].remove.at.after_level", "expected 1 or more, got 0"),
        ("{after: previous}", "actions[0].remove.at.after", "expected 'the previous action', got 'previous'"),
    ],
)
def test_a_mapping_is_judged_by_the_union_member_it_has_the_shape_of(value, field, message):
    """'at: {after_level: 0}' is a mapping of after_level: only the level's bound is said, not
    also that it is no number and has a key {after: ...} lacks (three errors for one mistake)."""
    text = f"stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\nactions:\n  - remove: {{brick: L01.1, at: {value}}}\n"
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "d.yaml")
    assert (err.value.field, err.value.message, err.value.others) == (field, message, ())


def test_a_list_too_short_is_one_error_at_the_list_saying_how_many_items():
    """'direction: [1, 0]' on a pull gave two errors: a word was expected, and
    'direction[2]: required field is missing', which reads as a key."""
    text = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nactions:\n  - remove: {brick: L01.1, at: 3 s, direction: [1]}\n"
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "d.yaml")
    e = err.value
    assert (e.field, e.line, e.column, e.others) == ("actions[0].remove.direction", 4, 48, ())
    assert e.message == "expected a list of 3 items, got [1]"


@pytest.mark.parametrize(
    "structure, field, message",
    [
        (
            "{tower: {levels: 2, origin: [0, 0, 0]}}",
            "structure.tower.origin",
            "expected a list of 2 items, got [0, 0, 0]",
        ),
        ("[]", "structure", "expected a list of at least 1 item, got []"),
    ],
)
def test_a_list_of_the_wrong_length_is_said_in_the_languages_words(structure, field, message):
    """Pydantic says 'Tuple should have at most 2 items after validation, not 3'; a YAML user
    wrote a list, and 'after validation' is pydantic's."""
    with pytest.raises(ScenarioError) as err:
        parse_scenario(f"stackdsl: 1\nstructure: {structure}\n", "d.yaml")
    assert (err.value.field, err.value.message) == (field, message)


def test_a_list_where_one_value_goes_is_said_to_be_a_list():
    text = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nactions: [{remove: {brick: [L02.1, L02.2], at: 3 s}}]\n"
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "d.yaml")
    assert err.value.message == "expected text, got a list: ['L02.1', 'L02.2']"


@pytest.mark.parametrize(
    "written, message",
    [
        ("stands:", "no value: give one (as 'stands: true' or 'toppled: all'), or leave the key out"),
        ("toppled:", "no value: give one (as 'stands: true' or 'toppled: all'), or leave the key out"),
        (
            "stands: false",
            "'stands: false' is no expectation: to expect a fall give 'collapse: N' (the level), or leave 'stands' out",
        ),
    ],
)
def test_an_expectation_with_no_value_or_stands_false_is_refused_at_it(written, message):
    """'stands:' with nothing after it read as no expectation, and the file passed on nothing
    measured; 'stands: false' said pydantic's 'Input should be True'."""
    with pytest.raises(ScenarioError) as err:
        parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\nexpect:\n  {written}\n", "e.yaml")
    assert (err.value.field, err.value.message) == (f"expect.{written.split(':')[0]}", message)


@pytest.mark.parametrize("written", ["true", "19.5"])
def test_a_toppled_count_that_is_no_whole_number_says_what_toppled_takes(written):
    """'toppled: true' said 'expected a mapping of count, tolerance', the long form's fields."""
    with pytest.raises(ScenarioError) as err:
        parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\nexpect: {{toppled: {written}}}\n", "t.yaml")
    assert err.value.field == "expect.toppled"
    assert err.value.message.startswith("expected a whole number of bricks such as 20, '20±1' or 'all'")


@pytest.mark.parametrize(
    "written, count, tolerance",
    [("'0.±1'", 0, 1), ("'2.±1'", 2, 1), ("'2.0 ± 1.'", 2, 1), ("'3.'", 3, 0), ("'007.00 +- 02.'", 7, 2)],
)
def test_a_whole_toppled_count_may_end_in_a_point(written, count, tolerance):
    """'0.±1' was refused as allowing '0 to 1 bricks, which no whole N±T gives', though '0±1'
    allows just that and 'toppled: 0.' is taken: '2.' is the whole number 2."""
    s = scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\nexpect: {{toppled: {written}}}\n")
    assert (s.expect.toppled.count, s.expect.toppled.tolerance) == (count, tolerance)


@pytest.mark.parametrize("written, level, tolerance", [("'9.±1'", 9, 1), ("'9.0 +- 1.'", 9, 1), ("'9.'", 9, 0)])
def test_a_whole_collapse_level_may_end_in_a_point(written, level, tolerance):
    s = scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 12}}}}\nexpect: {{collapse: {written}}}\n")
    assert (s.expect.collapse.level, s.expect.collapse.tolerance) == (level, tolerance)


@pytest.mark.parametrize(
    "key, written, message",
    [
        ("toppled", "'0.5±0.5'", "'0.5±0.5' allows 0 to 1 bricks, as '0±1' does: write that"),
        ("toppled", "'0.4±1'", "'0.4±1' allows 0 to 1 bricks, as '0±1' does: write that"),
        ("collapse", "'1.5±0.5'", "'1.5±0.5' allows levels 1 to 2, as '1±1' does: write that"),
        ("toppled", "'2.5±1'", "allows 2 to 3 bricks, which no whole 'N±T' gives: write '2±1' or '3±1'"),
    ],
)
def test_a_fraction_whose_range_starts_at_the_least_count_names_the_whole_form(key, written, message):
    """A range from 0 bricks (or level 1) is what 'N±T' with N at that floor gives, so the
    message does not call it impossible."""
    with pytest.raises(ScenarioError) as err:
        scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 12}}}}\nexpect: {{{key}: {written}}}\n")
    assert err.value.field == f"expect.{key}" and message in err.value.message


@pytest.mark.parametrize(
    "written, message",
    [
        ("-1", "expected a number of bricks from 0 to 5000 or 'all', got -1"),
        ("6000", "expected a number of bricks from 0 to 5000 or 'all', got 6000"),
        ("'9999±1'", "expected a number of bricks from 0 to 5000 or 'all', got '9999±1'"),
    ],
)
def test_a_toppled_count_out_of_range_is_refused_at_toppled_as_written(written, message):
    """'toppled: -1' was refused at 'expect.toppled.count', a field of the long form the file
    never wrote."""
    with pytest.raises(ScenarioError) as err:
        parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\nexpect: {{toppled: {written}}}\n", "t.yaml")
    assert (err.value.field, err.value.message) == ("expect.toppled", message)


@pytest.mark.parametrize(
    "written, op, count",
    [("'>= 1'", ">=", 1), ("'<= 3'", "<=", 3), ("'> 0'", ">", 0), ("'< 5'", "<", 5), ("' >=2. '", ">=", 2)],
)
def test_toppled_takes_a_bound_as_p_stands_does(written, op, count):
    s = scenario(f"stackdsl: 1\nstructure: {{dominoes: {{count: 16}}}}\nexpect: {{toppled: {written}}}\n")
    assert (s.expect.toppled.op, s.expect.toppled.count, s.expect.toppled.text()) == (op, count, f"{op} {count}")
    assert parse_scenario(s.to_yaml()) == s


@pytest.mark.parametrize(
    "written, message",
    [
        ("'< 0'", "'< 0' can never hold: a number of bricks is at least 0; write '<= 0' for no brick toppled"),
        ("'> 5000'", "'> 5000' can never hold: a number of bricks is at most 5000, the most bricks a scene has"),
        ("'>= 1.5'", "got '>= 1.5': bricks are counted whole, so it allows what '>= 2' does: write that"),
        ("'< 2.5'", "got '< 2.5': bricks are counted whole, so it allows what '< 3' does: write that"),
        ("'>= 6000'", "expected a number of bricks from 0 to 5000 or 'all', got '>= 6000'"),
        ("'=> 1'", "expected a number of bricks such as 20, '20±1', a bound such as '>= 1', or 'all', got '=> 1'"),
        ("{count: 2, tolerance: 1, op: '>='}", "a tolerance goes with '±' ('2 ± 1'), not with '>='"),
        ("{count: all, op: '>='}", "a bound is a number of bricks, not 'all'"),
    ],
)
def test_a_toppled_bound_no_count_meets_is_refused_as_p_stands_one_is(written, message):
    """As 'p_stands: > 1' is refused ('can never hold: a probability is at most 1'), at toppled."""
    with pytest.raises(ScenarioError) as err:
        parse_scenario(f"stackdsl: 1\nstructure: {{dominoes: {{count: 16}}}}\nexpect: {{toppled: {written}}}\n", "t.yaml")
    assert err.value.field == "expect.toppled" and message in err.value.message, err.value.message


def test_a_toppled_bound_is_checked_against_the_scene_and_stands():
    import warnings

    from stackdsl.lang.errors import ScenarioWarning

    head = "stackdsl: 1\nstructure: {dominoes: {count: 16}}\nexpect:\n  toppled: "
    with pytest.raises(ScenarioError, match="'>= 17' toppled can never be measured: the scene has 16 bricks"):
        compile_scenario(parse_scenario(head + "'>= 17'\n", "t.yaml"))
    with pytest.warns(ScenarioWarning, match="expect.toppled: <= 16 covers every count from 0 to the scene's 16 bricks"):
        compile_scenario(parse_scenario(head + "'<= 16'\n", "t.yaml"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", ScenarioWarning)
        compile_scenario(parse_scenario(head + "'>= 16'\n", "t.yaml"))
    with pytest.raises(ScenarioError, match="a toppled brick has moved, so the structure does not stand"):
        parse_scenario(head + "'> 0'\n  stands: true\n", "t.yaml")
    assert parse_scenario(head + "'< 1'\n  stands: true\n", "t.yaml").expect.stands


@pytest.mark.parametrize(
    "line, field, message",
    [
        ("expect: {stands_until: -1 s}", "expect.stands_until", "expected a time from 0 to 3600 s, got '-1 s'"),
        (
            "expect: {stands_until: 9999 s}",
            "expect.stands_until",
            "expected a time from 0 to 3600 s, got '9999 s'; a run lasts at most 3600 s",
        ),
        ("timing: {interval: 0}", "timing.interval", "expected a time above 0 and at most 60 s, got 0"),
        ("timing: {settle: 700 s}", "timing.settle", "expected a time from 0 to 600 s, got '700 s'"),
        ("stability: {rest_duration: 11 s}", "stability.rest_duration", "expected a time from 0 to 10 s, got '11 s'"),
        ("engine: {timestep: 0}", "engine.timestep", "expected a timestep of 0.01 ms or more and at most 10 ms (1/100 s), got 0"),
        (
            "impacts: [{target: {level: 1, side: +x}, speed: 1 m/s, at: 1 s, distance: 2 m}]",
            "impacts[0].distance",
            "expected a length above 0 and at most 1 m, got '2 m'",
        ),
        (
            "actions: [{push: {target: {brick: L01.1}, direction: [1, 0, 0], at: 3 s, gap: -1 mm}}]",
            "actions[0].push.gap",
            "expected a length from 0 to 10 m, got '-1 mm'",
        ),
    ],
)
def test_a_quantity_out_of_its_range_is_refused_with_its_unit(line, field, message):
    """'stands_until: 9999 s' said 'expected 3600 or less': pydantic's bound, without the unit the
    file wrote its value in."""
    with pytest.raises(ScenarioError) as err:
        parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\n{line}\n", "q.yaml")
    assert (err.value.field, err.value.message) == (field, message)


def test_every_bounded_quantity_says_its_range_with_its_unit():
    """A field of a unit (a time, a length...) bounded by pydantic's own ge/le is refused in
    pydantic's words, 'expected 3600 or less', without the unit: every one is bounded by
    stackdsl.lang.units.within, whose message says the range with its unit."""
    import types
    import typing

    import annotated_types
    from pydantic import BaseModel
    from pydantic.fields import FieldInfo

    from stackdsl.lang.models import Scenario

    def groups(annotation: object, found: list[list[object]], models: list[type[BaseModel]]) -> None:
        """Each Annotated's metadata in ``annotation`` (FieldInfo's own opened), and its models."""
        origin = typing.get_origin(annotation)
        if origin is typing.Annotated:
            base, *meta = typing.get_args(annotation)
            found.append([x for m in meta for x in ([m, *m.metadata] if isinstance(m, FieldInfo) else [m])])
            groups(base, found, models)
        elif origin in (typing.Union, types.UnionType, list, dict, tuple):
            for arg in typing.get_args(annotation):
                groups(arg, found, models)
        elif isinstance(annotation, type) and issubclass(annotation, BaseModel):
            models.append(annotation)

    def made_by(meta: list[object], name: str) -> bool:
        return any(
            getattr(getattr(m, "func", None), "__qualname__", "")
            == f"{name}.<locals>.{'convert' if name == '_kind' else 'check'}"
            for m in meta
        )

    bounds = (annotated_types.Ge, annotated_types.Gt, annotated_types.Le, annotated_types.Lt)
    unsaid, quantities, seen, todo = [], 0, set(), [Scenario]
    while todo:
        model = todo.pop()
        if model in seen:
            continue
        seen.add(model)
        for name, info in model.model_fields.items():
            found: list[list[object]] = [list(info.metadata)]
            groups(info.annotation, found, todo)
            for meta in found:
                if made_by(meta, "_kind") and any(isinstance(m, bounds) for m in meta):
                    quantities += 1
                    if not made_by(meta, "within"):
                        unsaid.append(f"{model.__name__}.{name}")
    assert quantities > 20 and unsaid == []


def test_a_fixed_length_list_and_a_shake_of_no_time_are_refused_in_plain_words():
    """A shake's direction is exactly two items: [1, 0, 0] was 'a list of at most 2 items' where
    [1] was 'a list of 2 items'; a shake of 0 s was told that 'a run lasts at most 3600 s'."""
    head = "stackdsl: 1\nstructure: {bricks: [{id: b, at: [0, 0, 4 mm]}]}\nactions:\n  - shake: "
    with pytest.raises(ScenarioError) as info:
        parse_scenario(head + "{amplitude: 1 mm, frequency: 5 Hz, duration: 1 s, at: 1 s, direction: [1, 0, 0]}\n", "s.yaml")
    assert "or a list of 2 items, got [1, 0, 0]" in str(info.value)  # (or a name: '+x', ...)
    with pytest.raises(ScenarioError) as info:
        parse_scenario(head + "{amplitude: 1 mm, frequency: 5 Hz, duration: 0 s, at: 1 s}\n", "s.yaml")
    assert str(info.value).splitlines()[0].endswith("got '0 s'; a shake that lasts no time moves nothing")


@pytest.mark.parametrize(
    "line, field, message",
    [
        ("structure: {tower: {levels: 2.5}}", "structure.tower.levels", "expected a whole number, got 2.5"),
        ("structure: {dominoes: {count: 0}}", "structure.dominoes.count", "expected 1 or more, got 0"),
        (
            "structure: {bricks: [{id: a, at: [0, 0, 4 mm], fixed: maybe}]}",
            "structure.bricks[0].fixed",
            "expected true or false, got 'maybe'",
        ),
        (
            "structure: {tower: {levels: 2}}\nactions: [{remove: {brick: 'a b', at: 1 s}}]",
            "actions[0].remove.brick",
            "expected a name of 1 to 40 ASCII letters, digits, '_', '.' or '-' (no spaces), got 'a b'",
        ),
        (
            "structure: {bricks: [{id: 'a b', at: [0, 0, 4 mm]}]}",
            "structure.bricks[0].id",
            "expected an id: an ASCII letter or '_' first (a digit first reads as a level in 'expect'), then ASCII letters, "
            "digits, '_', '.' or '-' (no spaces), not ending in '.' (the start of ids in 'expect'), 40 at most, got 'a b'",
        ),
        (
            "structure: {bricks: [{id: é, at: [0, 0, 4 mm]}]}",
            "structure.bricks[0].id",
            "expected an id: an ASCII letter or '_' first (a digit first reads as a level in 'expect'), then ASCII letters, "
            "digits, '_', '.' or '-' (no spaces), not ending in '.' (the start of ids in 'expect'), 40 at most, got 'é'; "
            "'é' is U+00E9, not ASCII",
        ),
        (
            "structure: [{name: lé, tower: {levels: 2}}]",
            "structure[0].name",
            "expected a part name: an ASCII letter or '_' first (a digit first reads as a level in 'expect'), then ASCII "
            "letters, digits, '_' or '-', 40 at most, got 'lé'; 'é' is U+00E9, not ASCII",
        ),
        (
            "name: yes\nstructure: {tower: {levels: 2}}",
            "name",
            "expected text, got true: YAML reads an unquoted yes, no, on, off, true or false as true or false; quote it",
        ),
    ],
)
def test_pydantics_type_words_are_said_in_the_languages(line, field, message):
    """'Input should be a valid integer, got a number with a fractional part, got 2.5' (got
    twice), 'String should match pattern ...', 'Input should be a valid boolean': pydantic's
    words; a YAML 'yes' read as true gets a hint to quote it."""
    with pytest.raises(ScenarioError) as err:
        parse_scenario(f"stackdsl: 1\n{line}\n", "w.yaml")
    assert (err.value.field, err.value.message) == (field, message)


@pytest.mark.parametrize(
    "layout, field, message",
    [
        ("pyramid: {base: 3, laid: 7}", "structure.pyramid.laid", "expected 'flat' or 'edge', got 7"),
        (
            "wall: {courses: 2, bricks_per_course: 4, laid: edgewise}",
            "structure.wall.laid",
            "expected 'flat' or 'edge', got 'edgewise'; did you mean 'edge'?",
        ),
        (
            "wall: {courses: 2, bricks_per_course: 4, laid: sideways}",
            "structure.wall.laid",
            "expected 'flat' or 'edge', got 'sideways'",
        ),
    ],
)
def test_a_value_none_of_its_choices_names_them_in_the_languages_words(layout, field, message):
    """'laid: 7' said pydantic's "Input should be 'flat' or 'edge'"; a text near a choice is
    asked about it."""
    with pytest.raises(ScenarioError) as err:
        parse_scenario(f"stackdsl: 1\nstructure:\n  {layout}\n", "c.yaml")
    assert (err.value.field, err.value.message) == (field, message)


def test_a_grid_value_is_refused_in_the_words_the_file_would_be():
    """A grid value below a field's bound said pydantic's 'Input should be greater than or equal
    to 1' where the same value in the file says 'expected 1 or more'."""
    text = "stackdsl: 1\nstructure:\n  wall: {courses: 2, bricks_per_course: 3}\nsweep:\n  samples: 1\n  grid:\n    structure.wall.courses: [2, 0]\n"
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "g.yaml")
    e = err.value
    assert (e.field, e.line, e.column) == ("sweep.grid.structure.wall.courses[1]", 7, 33)
    assert e.message == "the grid value 0: expected 1 or more, got 0"


def test_an_unknown_pusher_is_refused_with_the_known_brick_types():
    """'pusher: bulldozer' was refused by the compiler without the known types, where
    'wall.brick' lists them: both are now the schema's reference check."""
    text = (
        "stackdsl: 1\nbrick_types:\n  dozer: {size: [150 mm, 300 mm, 100 mm]}\nstructure: {tower: {levels: 4}}\n"
        "actions:\n  - push: {target: {brick: L04.1}, direction: [1, 0, 0], at: after level 4, pusher: bulldozer}\n"
    )
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "p.yaml")
    e = err.value
    assert (e.field, e.line, e.column) == ("actions[0].push.pusher", 6, 85)
    assert e.message == "unknown brick type 'bulldozer'; known: dozer, kapla"


@pytest.mark.parametrize(
    "structure, field, message",
    [
        ("pyramid: {base: .nan}", "structure.pyramid.base", "expected a whole number, got .nan (not finite)"),
        ("tower: {levels: -.inf}", "structure.tower.levels", "expected a whole number, got -.inf (not finite)"),
        ("wall: {courses: true, bricks_per_course: 4}", "structure.wall.courses", "expected a whole number, got true"),
        ("tower: {levels: null}", "structure.tower.levels", "expected a whole number, got null"),
        ("wall: {courses: 2, bricks_per_course: 4, joint: .nan}", "structure.wall.joint", "(not finite)"),
        ("tower: {levels: 2, origin: [0, .inf]}", "structure.tower.origin[1]", "got .inf (not finite)"),
    ],
)
def test_values_are_shown_as_yaml_writes_them(structure, field, message):
    """'base: .nan' said pydantic's 'Input should be a finite number, got nan' where a length says
    'got nan (not finite)'; 'courses: true' was shown as Python's True, 'null' as None."""
    with pytest.raises(ScenarioError) as err:
        parse_scenario(f"stackdsl: 1\nstructure:\n  {structure}\n", "v.yaml")
    assert err.value.field == field
    assert err.value.message.endswith(message) and "True" not in err.value.message and "None" not in err.value.message


def test_a_plain_number_not_finite_is_said_as_a_length_is():
    text = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nmaterials:\n  oak: {density: 700, friction: .inf, restitution: 0.3}\n"
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "m.yaml")
    assert (err.value.field, err.value.message) == ("materials.oak.friction", "expected a number, got .inf (not finite)")


@pytest.mark.parametrize(
    "at, field, message",
    [
        ("{after_level: 2, extra: 1}", "actions[0].remove.at.extra", "unknown key 'extra'; allowed: after_level"),
        ("{after: the previous action, x: 1}", "actions[0].remove.at.x", "unknown key 'x'; allowed: after"),
        ("{aftr_level: 2}", "actions[0].remove.at.aftr_level", "unknown key 'aftr_level'; did you mean 'after_level'?"),
    ],
)
def test_a_mapping_of_a_union_is_told_the_key_the_member_it_fits_best_lacks(at, field, message):
    """'at' is a time, {after_level: N} or {after: the previous action}: a level's mapping with a
    key too many was blamed for its valid key ('after_level': did you mean 'after'?), the words of
    the member it fits worst; a key no member has is told what any of them allows."""
    text = f"stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\nactions:\n  - remove: {{brick: L02.1, at: {at}}}\n"
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "at.yaml")
    assert (err.value.field, err.value.message) == (field, message)
    assert err.value.column == text.splitlines()[3].index(field.rsplit(".", 1)[1] + ":") + 1  # at the key itself


def test_an_error_inside_an_aliased_node_points_at_the_alias_not_the_anchor():
    """A part written once with an anchor and again with an alias: the second's error was said at
    the anchor's line (structure[0]'s), which is not where structure[1] is written."""
    err = error("stackdsl: 1\nstructure:\n  - &p {name: a, tower: {levels: 2}}\n  - *p\n")
    assert (err.field, err.line, err.column) == ("structure[1].name", 4, 5) and "already a part named 'a'" in err.message
    with pytest.raises(ScenarioError) as info:  # the compiler's error too: part b overlaps part a
        compile_scenario(parse_scenario("stackdsl: 1\nstructure:\n  a: &t {tower: {levels: 2}}\n  b: *t\n", "s.yaml"))
    assert (info.value.field, info.value.line, info.value.column) == ("structure.b", 4, 6)


def test_an_actions_fields_written_level_with_its_kind_are_told_to_indent():
    """`- push:` then `target:` at the same indent: pydantic sees an empty push and unknown keys;
    the message names the key they belong under."""
    text = (
        "stackdsl: 1\nstructure: {tower: {levels: 3}}\nactions:\n  - push:\n    target: {brick: L01.1}\n    at: after level 3\n"
    )
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(text)
    said = [line for line in str(caught.value).splitlines() if "unknown key" in line]
    assert len(said) == 2 and all("is a field of 'push': indent it under 'push:'" in m for m in said), said
    with pytest.raises(ScenarioError) as one:  # a typo still gets its 'did you mean'
        parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 3}}\nactions:\n  - psh: {target: {brick: L01.1}}\n")
    assert "did you mean 'push'" in one.value.message and "indent" not in one.value.message


# numbers: one grammar in every form that reads one ------------------------------------------
SWEEP = "stackdsl: 1\nstructure: {tower: {levels: 8}}\nsweep: {samples: 4}\nexpect: {%s}\n"


@pytest.mark.parametrize(
    "written, plain",
    [
        ("collapse: {mean: '3 ± .5'}", "collapse: {mean: '3 ± 0.5'}"),
        ("collapse: {mean: '.5 ± 3'}", "collapse: {mean: '0.5 ± 3'}"),
        ("collapse: {mean: '3. +- 1.'}", "collapse: {mean: '3 +- 1'}"),
        ("collapse: {mean: '35e-1 +/- 5E-1'}", "collapse: {mean: '3.5 ± 0.5'}"),
        ("collapse: {quantile: {q: .5, level: '3 ± .5'}}", "collapse: {quantile: {q: 0.5, level: '3 ± 0.5'}}"),
        ("collapse: {quantile: {q: 0.5, level: '3.'}}", "collapse: {quantile: {q: 0.5, level: '3'}}"),
        ("p_stands: '>= .9'", "p_stands: '>= 0.9'"),
        ("p_stands: '<= 1.'", "p_stands: '<= 1'"),
        ("p_stands: '> .05'", "p_stands: '> 0.05'"),
        ("p_stands: '.5 ± .2'", "p_stands: '0.5 ± 0.2'"),
        ("p_stands: '5e-1 ± 2e-1'", "p_stands: '0.5 ± 0.2'"),
    ],
)
def test_a_statistic_reads_a_number_with_a_leading_or_trailing_point_as_python_does(written, plain):
    """'3 ± .5' and '.5 ± .2' were refused as bad input where '3 ± 0.5' was taken; a quantity
    ('.5 mm') and a condition ('x < .5') read them."""
    assert scenario(SWEEP % written).expect == scenario(SWEEP % plain).expect


JUNK_NUMBERS = [".", "..5", "5..", ".5.", "1e", "1e+", "e5", "1.2.3", "- 1", "0x1"]


@pytest.mark.parametrize("junk", JUNK_NUMBERS)
@pytest.mark.parametrize(
    "form, field, message",
    [
        ("collapse: {mean: '3 ± %s'}", "expect.collapse.mean", "expected a level, alone (± 0) or with a tolerance"),
        ("collapse: {mean: '%s ± 1'}", "expect.collapse.mean", "expected a level, alone (± 0) or with a tolerance"),
        ("p_stands: '>= %s'", "expect.p_stands", "expected a comparison with a probability such as '>= 0.9'"),
        ("p_stands: '%s ± 0.1'", "expect.p_stands", "expected a comparison with a probability such as '>= 0.9'"),
    ],
)
def test_a_number_that_is_no_number_is_refused_as_any_junk_is(junk, form, field, message):
    err = error(SWEEP % (form % junk))
    assert (err.line, err.field) == (4, field) and err.message.startswith(message), err.message


@pytest.mark.parametrize(
    "written, says",
    [
        ("'9 ± .5'", "'9 ± .5' allows level 9 only: write 9"),
        ("'.5'", "'.5' allows no whole level: write 1"),
        ("'9. ± 1.5'", "'9. ± 1.5' allows levels 8 to 10, as '9±1' does: write that"),
    ],
)
def test_a_runs_collapse_of_a_leading_point_fraction_gets_the_whole_level_advice(written, says):
    err = error(f"stackdsl: 1\nstructure: {{tower: {{levels: 12}}}}\nexpect: {{collapse: {written}}}\n")
    assert err.field == "expect.collapse" and says in err.message, err.message


@pytest.mark.parametrize("key", ["collapse", "toppled"])
@pytest.mark.parametrize("written", ["1e999 ± 1", "3 ± 1e999", "9" * 400 + ".5"])
def test_a_whole_count_beyond_a_double_is_refused_cleanly(key, written):
    """A fraction beyond a double ('1e999 ± 1') raised OverflowError (a traceback, exit 3)
    while the whole-level advice was worked out."""
    err = error(f"stackdsl: 1\nstructure: {{tower: {{levels: 12}}}}\nexpect: {{{key}: '{written}'}}\n")
    assert err.field == f"expect.{key}" and err.message.endswith("(not finite)"), err.message


def test_every_grammar_reads_the_same_numbers():
    """A quantity, a tolerance, a bound and a condition share one number pattern (units.UNSIGNED)."""
    import re

    from stackdsl.lang.expressions import parse
    from stackdsl.lang.grammar import BOUND, PLUS_MINUS
    from stackdsl.lang.units import UNSIGNED

    signed = ("- 1", "e5")  # in a condition, a negated number and a name
    forms = ["5", "05", "5.", ".5", "0.5", "5e1", ".5e-1", "5.E+2", *(j for j in JUNK_NUMBERS if j not in signed), "", "5e1234"]
    for form in forms:
        number = re.fullmatch(UNSIGNED, form) is not None
        assert number == (form in ("5", "05", "5.", ".5", "0.5", "5e1", ".5e-1", "5.E+2")), form
        assert (re.fullmatch(PLUS_MINUS, f"{form} ± {form}") is not None) == number, form
        assert (re.fullmatch(BOUND, f">= {form}") is not None) == number, form
        try:
            parse(f"x < {form}")
            read = True
        except ValueError:
            read = False
        assert read == number, form
        try:
            length(f"{form} mm")
            measured = True
        except ValueError:
            measured = False
        assert measured == number, form


@pytest.mark.parametrize("depth", [65, 300, 600, 5000])
def test_plain_data_nested_too_deep_is_the_nesting_error_at_any_depth(depth):
    # 300 deep gave the nesting error, 600 deep a bare RecursionError
    data: dict = {"stackdsl": 1, "structure": {"tower": {"levels": 2}}}
    inner = data
    for _ in range(depth):
        inner["description"] = {}
        inner = inner["description"]
    with pytest.raises(ScenarioError, match="nested more than 64 levels deep"):
        parse_scenario(data, "d.yaml")


def test_plain_data_that_holds_itself_is_the_nesting_error():
    data: dict = {"stackdsl": 1, "structure": {"tower": {"levels": 2}}}
    data["structure"]["tower"]["shift"] = data
    with pytest.raises(ScenarioError, match="nested more than 64 levels deep"):
        parse_scenario(data)


@pytest.mark.parametrize("block", ["sweep:", "sweep: null", "sweep: ~"])
def test_an_empty_sweep_block_is_refused_not_read_as_no_sweep(block):
    with pytest.raises(ScenarioError) as err:
        parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\n{block}\n", "e.yaml")
    assert (err.value.field, err.value.line) == ("sweep", 3) and "empty sweep block" in err.value.message


@pytest.mark.parametrize(
    "line, field",
    [("skip: {reason: ''}\n", "skip.reason"), ("name: ''\n", "name"), ("xfail: {reason: ''}\n", "xfail.reason")],
)
def test_an_empty_text_is_said_in_the_languages_words(line, field):
    # 'skip: {reason: ""}' said pydantic's "String should have at least 1 character"
    with pytest.raises(ScenarioError) as err:
        parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\n{line}", "e.yaml")
    assert (err.value.field, err.value.message) == (field, "expected some text, got ''")


@pytest.mark.parametrize(
    "expect",
    ["{collapse: 'ONES'}", "{collapse: '2 ± ONES'}", "{stays: ['ONES']}", "{toppled: 'ONES'}", "{moved: 'ONES-2'}"],
)
def test_a_whole_number_of_thousands_of_digits_is_too_large_in_stackdsls_words(expect):
    # Python refuses to read a decimal string of over 4300 digits, and its words named
    # sys.set_int_max_str_digits()
    text = "stackdsl: 1\nstructure: {tower: {levels: 3}}\nexpect: " + expect.replace("ONES", "1" * 5000) + "\n"
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "big.yaml")
    assert err.value.message == "a whole number written with 5000 digits is too large", err.value.message


def test_a_value_of_300000_characters_is_cut_in_the_error_not_echoed():
    text = "stackdsl: 1\nstructure: {tower: {levels: 3, spacing: '96 " + "x" * 300_000 + "'}}\n"
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "long.yaml")
    said = str(err.value)
    assert len(said) < 2000 and "(300001 characters)" in said and said.startswith("long.yaml:2:41: structure.tower.spacing:")


def test_a_mean_beyond_a_double_says_what_was_written_not_inf():
    text = (
        "stackdsl: 1\nstructure: {tower: {levels: 3, bricks_per_layer: 1, turn: 0, shift: {uniform: [0, 5 mm]}}}\n"
        "sweep: {samples: 3}\nexpect: {collapse: {mean: '" + "1" * 5000 + "'}}\n"
    )
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "m.yaml")
    assert "(not finite)" in err.value.message and "got '1111" in err.value.message and ".inf" not in err.value.message


@pytest.mark.parametrize(
    "text, field",
    [
        (
            "structure: {tower: {levels: 2}}\nbrick_types: {finger: {size: [20 mm, 10 mm, 10 mm]}}\n"
            "actions: [{push: {target: {brick: L02.1}, direction: +x, at: 3 s, pusher: {size: [20 mm, 10 mm, 10 mm]}}}]",
            "actions[0].push.pusher",
        ),
        ("structure: {tower: {levels: 2, brick: {size: [20 mm, 10 mm, 10 mm]}}}", "structure.tower.brick"),
        ("structure: {pyramid: {base: 2, brick: {size: [20 mm, 10 mm, 10 mm]}}}", "structure.pyramid.brick"),
    ],
)
def test_a_size_written_where_a_brick_types_name_goes_says_where_sizes_go(text, field):
    """A new user wrote `pusher: {size: [...]}` and read "expected text, got a mapping": a field
    that names a brick type says so, and where a size goes."""
    with pytest.raises(ScenarioError) as err:
        parse_scenario(f"stackdsl: 1\n{text}\n", "d.yaml")
    assert err.value.field == field
    assert err.value.message.startswith("expected the name of a brick type (kapla, or a name under brick_types:")
    assert err.value.message.endswith("got a mapping")


# libyaml's parser and PyYAML's read alike ---------------------------------------


def _composed(kind, text: str):
    """What composing ``text`` with loader class ``kind`` gives: the plain data with every
    recorded position, or the error's words; "refused" for a YAML error or a failure libyaml
    leaves to PyYAML's parser to read again."""
    source = _loader.SourceMap("f.yaml", tuple(text.splitlines()))
    try:
        data = _loader._compose(kind, text, source)
    except ScenarioError as exc:
        return ("error", str(exc))
    except (_loader.yaml.YAMLError, _loader._Refused):
        return ("refused",)
    return ("read", repr(data), sorted(source.values.items(), key=repr), sorted(source.keys.items(), key=repr))


def _texts(folders: tuple[str, ...], mutations: int, seed: int) -> list[str]:
    """Every YAML file under 20 kB in the repository's ``folders``, and ``mutations`` of them,
    each with one to four random edits of YAML's syntax."""
    root = Path(__file__).resolve().parent.parent
    files = [p for d in folders for p in sorted((root / d).rglob("*.yaml"))]
    texts = [t for p in files if len(t := p.read_text(encoding="utf-8", errors="replace")) < 20000]  # the big ones: slow
    pieces = [":", " ", "{", "}", "[", "]", ",", '"', "'", "&a ", "*a", "|", ">", "#", "- ", "\n", "\n  ", "---\n",
              "\\", "\\u12", "~", "1e5", "on", "é", "\r", "\r\n", "\u2028", "😀", ": ", "{a: [b, {c: d}]}", "<<: "]  # fmt: skip
    rng = random.Random(seed)
    for _ in range(mutations):
        text = rng.choice(texts)
        for _ in range(rng.randint(1, 4)):
            i = rng.randrange(len(text) + 1)
            if rng.random() < 0.6:
                text = text[:i] + rng.choice(pieces) + text[i:]
            else:
                text = text[:i] + text[i + rng.randint(1, 5) :]
        texts.append(text)
    return texts


@pytest.mark.skipif(_loader._FAST is None, reason="PyYAML was built without libyaml: its Python parser reads alone")
@pytest.mark.parametrize(
    "folders, mutations",
    [
        (("scenarios", "sweeps"), 250),
        # the hostile corpus and the docs' scenes too: 16446 texts of three seeds agreed when this was written
        pytest.param(("scenarios", "sweeps", "tests", "docs"), 3000, marks=pytest.mark.slow),
    ],
)
def test_libyaml_reads_every_text_it_is_given_as_pyyamls_parser_does(folders, mutations):
    """A text libyaml's events compose is read as PyYAML's own parser reads it: the same data,
    every field at the same line and column, or the same error; one it refuses is read again by
    PyYAML's parser (tabs, "?", tags and U+FEFF always are)."""
    texts = [t for t in _texts(folders, mutations, seed=1) if not _loader._PYYAML_ONLY.search(t)]
    assert len(texts) > mutations / 2
    read = refused = 0
    for text in texts:
        fast = _composed(_loader._FAST, text)
        if fast == ("refused",):
            refused += 1
            continue
        assert fast == _composed(_loader._Loader, text), text
        read += fast[0] == "read"
    assert read > mutations / 10 and refused > mutations / 20, (read, refused)  # both sides of the mutations are tried


@pytest.mark.skipif(_loader._FAST is None, reason="PyYAML was built without libyaml: its Python parser reads alone")
def test_a_plain_file_is_read_by_libyaml_and_one_it_refuses_by_pyyaml(monkeypatch):
    composed = []
    original = _loader._compose
    monkeypatch.setattr(_loader, "_compose", lambda kind, *a: composed.append(kind) or original(kind, *a))
    scenario("stackdsl: 1\nstructure: {tower: {levels: 2}}\n")
    assert composed == [_loader._FAST]
    composed.clear()
    assert str(error('stackdsl: 1\nname: "ab\\U0011ffff"\n')).startswith("s.yaml:2:12: not valid YAML: ValueError: chr()")
    assert composed == [_loader._FAST, _loader._Loader]
    composed.clear()
    scenario("stackdsl: 1\nname: does it stand?\nstructure: {tower: {levels: 2}}\n")
    assert composed == [_loader._Loader]

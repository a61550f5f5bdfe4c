"""The stackdsl command: check's rows, failure details, JSON, JUnit XML, selection, exit
codes; compile, run, schema, compare, bench; the fan-out that runs scenarios."""

import argparse
import inspect
import io
import json
import os
import pickle
import re
import signal
import subprocess
import sys
import tempfile
import time
import types
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from stackdsl import _entry, compile_scenario, parse_scenario, run_program
from stackdsl.batch import check as _check
from stackdsl.batch import check_sweep as _check_sweep
from stackdsl.batch import judge as _judge
from stackdsl.batch import sweep as _sweep
from stackdsl.bench.bench import DEFAULT_SETTINGS
from stackdsl.cli import bench as _cli_bench
from stackdsl.cli import check as _cli_check
from stackdsl.cli import main as _cli
from stackdsl.cli.main import main
from stackdsl.cli.progress import Lines, is_live
from stackdsl.compile import compiler as _compiler
from stackdsl.lang import jsonschema as _jsonschema
from stackdsl.verdicts.expect import explain

ROOT = Path(__file__).resolve().parents[1]
PASSING = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nexpect: {stands: true}\n"
FAILING = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nexpect: {collapse: 2}\n"
BAD = "stackdsl: 1\nstructure:\n  tower: {levels: 2, spacng: 96 mm}\n"
# A brick whose centre of mass lies 0.5 mm beyond the edge of the one below: it tips over.
TIPS = "stackdsl: 1\nstructure:\n  bricks:\n    - {id: base, at: [0, 0, 4 mm]}\n    - {id: top, at: [60.5 mm, 0, 12 mm]}\n"
NAMED = "stackdsl: 1\nname: Leaning Tower\nstructure: {tower: {levels: 1}}\nexpect: {stands: true}\n"


def write(folder: Path, **files: str) -> Path:
    for name, text in files.items():
        (folder / f"{name}.yaml").write_text(text)
    return folder


def stackdsl_command(*args: str, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "stackdsl", *args], capture_output=True, text=True, check=False, **kwargs)


# check: the table, and rows as each scenario finishes


def test_check_passing_folder_exits_0_with_a_table(tmp_path, capsys):
    assert main(["check", str(write(tmp_path, a=PASSING, b=PASSING)), "-j", "1"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split() == ["scenario", "engine", "mode", "simulated", "wall", "expected", "measured"]
    assert [line.split()[0] for line in out[1:3]] == ["PASS", "PASS"]
    assert "pybullet extension" in out[1] and out[1].rstrip().endswith("s  stands             stands")
    assert out[-1].startswith("2 scenarios: 2 passed, 0 failed")


def test_check_prints_each_row_before_the_next_scenario_runs(tmp_path, capsys, monkeypatch):
    printed_before_each_run = []

    def spy(program, *args):
        printed_before_each_run.append(capsys.readouterr().out)
        return run_program(program, *args)

    monkeypatch.setattr(_judge, "run_program", spy)
    assert main(["check", str(write(tmp_path, a=PASSING, b=FAILING)), "-j", "1"]) == 1
    first, second = printed_before_each_run
    assert "a.yaml" not in first and "PASS" in second and "a.yaml" in second and "b.yaml" not in second


def test_check_failing_expectation_exits_1_and_says_what_moved(tmp_path, capsys):
    assert main(["check", str(write(tmp_path, a=PASSING, b=FAILING)), "-j", "1", "--mode", "raw"]) == 1
    out = capsys.readouterr().out.splitlines()
    fail = next(i for i, line in enumerate(out) if line.startswith("FAIL"))
    assert "b.yaml" in out[fail] and "collapse 2" in out[fail]
    at, stood, more = out[fail + 1], out[fail + 4], out[fail + 5]  # the expectation, its line and caret, why
    assert at == f"      {tmp_path / 'b.yaml'}:3:10: expect.collapse: expected collapse 2, measured stands"
    assert stood.startswith("      stood: the largest displacement") and " mm, brick L0" in stood and "(level " in stood
    assert more == f"      more: stackdsl run {tmp_path / 'b.yaml'} --mode raw"
    assert out[-1].startswith("2 scenarios: 1 passed, 1 failed")


def test_explain_names_the_brick_distance_time_and_level():
    collapse = parse_scenario(TIPS + "expect: {stands: true}\n")
    program = compile_scenario(collapse)
    outcome = run_program(program)
    c = outcome.collapse
    assert c is not None and c.brick == "top"
    (line,) = explain(collapse.expect, outcome, program.collapse_threshold)
    assert (
        line == f"collapsed: brick top (level 2) moved past 4.0 mm at t={c.time:.2f} s, with 2 levels placed "
        f"({c.displacement * 1000:.1f} mm by t={c.decided:.2f} s, when the collapse was decided)"
    )

    stays = parse_scenario(TIPS + "expect: {stays: 1-2}\n")
    (line,) = explain(stays.expect, outcome, program.collapse_threshold)
    moved = outcome.displacement["top"] * 1000
    assert moved > 4 and line.startswith(f"moved: brick top (level 2) moved {moved:.1f} mm by the end")

    assert explain(parse_scenario(TIPS + "expect: {collapse: 2}\n").expect, outcome, program.collapse_threshold) == []


def test_explain_a_collapse_expected_but_stood_gives_the_largest_displacement():
    scenario = parse_scenario(FAILING)
    program = compile_scenario(scenario)
    outcome = run_program(program)
    brick, largest = max(outcome.displacement.items(), key=lambda item: item[1])
    (line,) = explain(scenario.expect, outcome, program.collapse_threshold)
    assert line.startswith("stood: the largest displacement at the end (t=5.00 s) was ")
    assert f"brick {brick} (level {brick[2]})" in line and "4.0 mm" in line
    assert f"{largest * 1000:.2g} mm" in line


def test_check_results_carry_their_explanation_and_pickle(tmp_path):
    (r,) = _check.check([write(tmp_path, b=FAILING)], jobs=1)
    assert not r.passed and r.explanation and r.explanation[0].startswith("stood:")
    assert pickle.loads(pickle.dumps(r)) == r


# check: bad input, selection, exit first, machine-readable output


def test_check_bad_file_exits_2_and_simulates_nothing(tmp_path, capsys, monkeypatch):
    def no_simulation(*args, **kwargs):
        raise AssertionError("simulated although a file was bad")

    monkeypatch.setattr(_judge, "run_program", no_simulation)
    assert main(["check", str(write(tmp_path, a=PASSING, z=BAD)), "-j", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("^") == 1
    assert f"{tmp_path / 'z.yaml'}:3:22: structure.tower.spacng: unknown key 'spacng'; did you mean 'spacing'?" in err


def test_check_missing_path_exits_2(tmp_path, capsys):
    assert main(["check", str(tmp_path / "nowhere")]) == 2
    assert "no such file or folder" in capsys.readouterr().err


def test_check_mode_override(tmp_path, capsys):
    assert main(["check", str(write(tmp_path, a=PASSING)), "--mode", "raw", "-j", "1"]) in (0, 1)
    assert " raw " in capsys.readouterr().out


def test_k_selects_by_path_or_name_case_insensitively(tmp_path, capsys):
    folder = write(tmp_path, a=PASSING, b=FAILING, tower=NAMED)
    assert main(["check", str(folder), "-k", "A.YAML", "-j", "1"]) == 0
    out = capsys.readouterr().out
    assert "a.yaml" in out and "b.yaml" not in out and out.splitlines()[-1].startswith("1 scenarios")
    assert main(["check", str(folder), "-k", "leaning", "-j", "1"]) == 0
    out = capsys.readouterr().out
    assert "tower.yaml" in out and "a.yaml" not in out


def test_k_selecting_nothing_is_bad_input(tmp_path, capsys):
    assert main(["check", str(write(tmp_path, a=PASSING)), "-k", "nothing-like-it"]) == 2
    assert "no scenario's path or name matches 'nothing-like-it'" in capsys.readouterr().err


def test_k_rule_is_in_the_help(capsys):
    with pytest.raises(SystemExit):
        main(["check", "--help"])
    shown = " ".join(capsys.readouterr().out.split())
    assert "only the scenarios EXPR selects, as pytest's -k: words joined by and, or, not and parentheses" in shown
    assert "when the file's path or the scenario's name contains it, ignoring case" in shown
    assert "give -k again for more: a scenario runs when any of them selects it" in shown


def test_exitfirst_stops_after_the_first_failure(tmp_path, capsys, monkeypatch):
    runs = []
    monkeypatch.setattr(_judge, "run_program", lambda program, *a: runs.append(program.name) or run_program(program, *a))
    folder = write(tmp_path, a=FAILING, b=PASSING, c=PASSING)
    assert main(["check", str(folder), "-x", "-j", "1", "--junit-xml", str(tmp_path / "junit.xml")]) == 1
    out = capsys.readouterr().out.splitlines()
    assert len(runs) == 1 and sum(line.startswith(("PASS", "FAIL")) for line in out) == 1
    assert out[-1].startswith("3 scenarios: 0 passed, 1 failed, 2 not run: stopped after the first failure")
    suite = ET.parse(tmp_path / "junit.xml").getroot().find("testsuite")
    assert suite.get("skipped") == "2" and len(suite.findall("testcase/skipped")) == 2


def test_json_is_one_document_of_every_result(tmp_path, capsys):
    assert main(["check", str(write(tmp_path, a=PASSING, b=FAILING)), "-j", "1", "--json"]) == 1
    doc = json.loads(capsys.readouterr().out)  # nothing else on stdout
    assert doc["summary"] == {**doc["summary"], "total": 2, "passed": 1, "failed": 1, "not_run": 0}
    by_file = {Path(r["file"]).name: r for r in doc["results"]}
    assert by_file["a.yaml"]["passed"] and by_file["a.yaml"]["explanation"] == []
    b = by_file["b.yaml"]
    assert not b["passed"] and b["verdicts"][0]["expected"] == "collapse 2" and b["explanation"][0].startswith("stood:")
    assert b["command"] == f"stackdsl run {tmp_path / 'b.yaml'}" and b["collapse_level"] is None
    assert by_file["a.yaml"]["certificate"].startswith("stands, equilibrium")  # every verdict's proof


def test_junit_xml_has_a_testcase_per_scenario_and_the_failure_text(tmp_path, capsys):
    path = tmp_path / "out" / "junit.xml"
    path.parent.mkdir()
    assert main(["check", str(write(tmp_path, a=PASSING, b=FAILING)), "-j", "1", "--junit-xml", str(path)]) == 1
    root = ET.parse(path).getroot()
    suite = root.find("testsuite")
    assert root.tag == "testsuites" and (suite.get("tests"), suite.get("failures")) == ("2", "1")
    cases = {Path(c.get("name")).name: c for c in suite.findall("testcase")}
    assert cases["a.yaml"].find("failure") is None and cases["a.yaml"].get("classname") == "stackdsl.pybullet.extension"
    failure = cases["b.yaml"].find("failure")
    assert failure.get("message") == f"{tmp_path / 'b.yaml'}:3:10: expected collapse 2, measured stands"
    assert failure.text.startswith(f"{tmp_path / 'b.yaml'}:3:10: expect.collapse: expected collapse 2, measured stands\n")
    assert "\nstood:" in failure.text and failure.text.endswith(f"more: stackdsl run {tmp_path / 'b.yaml'}")


def test_every_rerun_command_carries_the_options_that_change_the_result(tmp_path, capsys, monkeypatch):
    """check's text, --json and JUnit, and compare --json, name the command that runs a scenario
    again as it ran: --seed, --mode, --model, --backend, --timeout (the report and sweep: below)."""
    monkeypatch.chdir(tmp_path)
    write(tmp_path, b=FAILING)
    options = ["--seed", "4", "--mode", "extension", "--model", "equilibrium", "--backend", "pybullet", "--timeout", "50"]
    again = "stackdsl run b.yaml --mode extension --model equilibrium --backend pybullet --seed 4 --timeout 50"
    assert main(["check", "b.yaml", "-j", "1", *options, "--junit-xml", "j.xml"]) == 1
    assert f"      more: {again}" in capsys.readouterr().out.splitlines()
    assert ET.parse("j.xml").getroot().find("testsuite/testcase/failure").text.endswith(f"more: {again}")
    assert main(["check", "b.yaml", "-j", "1", *options, "--json"]) == 1
    assert json.loads(capsys.readouterr().out)["results"][0]["command"] == again
    assert main(["compare", "b.yaml", "-j", "1", "--modes", "extension", *options[:2], "--json"]) == 1
    assert json.loads(capsys.readouterr().out)["results"][0]["command"] == "stackdsl run b.yaml --mode extension --seed 4"


@pytest.mark.slow
def test_the_reports_and_sweeps_rerun_commands_carry_the_options_that_change_the_result(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path, b=FAILING)
    assert main(["check", "b.yaml", "-j", "1", "--seed", "4", "--mode", "raw", "--report", "r"]) == 1
    assert "<code>stackdsl run b.yaml --mode raw --seed 4</code>" in Path("r/index.html").read_text()
    # a sample stopped by its --timeout: sweep names the run of that sample (on tuned pybullet, whose
    # 1 ms steps outlast 0.01 s: in extension mode the sample finished inside it on a fast machine)
    write(tmp_path, walk=RANDOM.replace("timing:", "engine: {mode: tuned}\ntiming:"))
    assert main(["sweep", "walk.yaml", "--samples", "1", "-j", "1", "--seed", "4", "--timeout", "0.01", "--out", "s"]) == 1
    assert "more: stackdsl run walk.yaml --seed 4 --sample 0 --timeout 0.01" in capsys.readouterr().out.splitlines()


# levels 1-2 stay and level 3 does too: 'moved' and 'toppled' fail, 'stays' holds
THREE_EXPECTED = """stackdsl: 1
structure: {tower: {levels: 3}}
expect:
  stays: 1-2
  moved: 3
  toppled: "2 +- 1"
"""


def test_each_failed_expectation_points_at_its_line_in_check_json_junit_and_run(tmp_path, capsys, monkeypatch):
    """As a parse error does: file:line:col of the expectation's key, the field, then the line
    and a caret under it; the held one ('stays') is not shown."""
    monkeypatch.chdir(tmp_path)
    Path("t.yaml").write_text(THREE_EXPECTED)
    moved = "t.yaml:5:3: expect.moved: expected level 3 moved, measured L03.1, L03.2 stayed"
    toppled = "t.yaml:6:3: expect.toppled: expected 2±1 toppled, measured 0 of 6 toppled"
    assert main(["check", "t.yaml", "-j", "1", "--junit-xml", "j.xml"]) == 1
    out = capsys.readouterr().out.splitlines()
    at = out.index(f"      {moved}")
    assert out[at + 1 : at + 6] == [
        " " * 12 + "moved: 3",
        " " * 12 + "^",
        f"      {toppled}",
        " " * 12 + 'toppled: "2 +- 1"',
        " " * 12 + "^",
    ]
    assert not any("expect.stays" in line for line in out)
    failure = ET.parse("j.xml").getroot().find("testsuite/testcase/failure")
    assert failure.get("message").startswith("t.yaml:5:3: expected ")
    assert failure.text.startswith(f"{moved}\n      moved: 3\n      ^\n{toppled}\n")
    assert main(["check", "t.yaml", "-j", "1", "--json"]) == 1
    verdicts = json.loads(capsys.readouterr().out)["results"][0]["verdicts"]
    assert [(v["name"], v["passed"], v["at"]) for v in verdicts] == [
        ("stays", True, {"file": "t.yaml", "line": 4, "column": 3, "source_line": "  stays: 1-2"}),
        ("moved", False, {"file": "t.yaml", "line": 5, "column": 3, "source_line": "  moved: 3"}),
        ("toppled", False, {"file": "t.yaml", "line": 6, "column": 3, "source_line": '  toppled: "2 +- 1"'}),
    ]
    assert main(["run", "t.yaml"]) == 1
    out = capsys.readouterr().out.splitlines()
    assert (
        f"FAIL  {moved}" in out
        and f"FAIL  {toppled}" in out
        and "PASS  expected levels 1-2 stay, measured levels 1-2 stayed" in out
    )


def test_run_prints_what_held_first_and_why_a_failure_failed_right_under_it(tmp_path, capsys):
    """`stands` is judged before `stays`: run printed the failed `stands`, then the `stays` that
    held, then why `stands` failed, which a new user read as the PASS's. What held comes first now,
    and the lines saying why follow the failures."""
    assert main(["run", str(write(tmp_path, t=TIPS + "expect: {stands: true, stays: base}\n") / "t.yaml")]) == 1
    out = capsys.readouterr().out.splitlines()
    verdicts = [i for i, line in enumerate(out) if line.startswith(("PASS  ", "FAIL  "))]
    assert [out[i][:4] for i in verdicts] == ["PASS", "FAIL"], out
    assert all(line.startswith("      ") for line in out[verdicts[-1] + 1 :]), out[verdicts[-1] :]
    assert any(line.strip().startswith("collapsed: brick top") for line in out[verdicts[-1] + 1 :]), out


def test_an_expectation_built_in_python_has_no_place_and_says_its_verdict_alone():
    from stackdsl.lang.expectations import Expect
    from stackdsl.verdicts.expect import evaluate, located_lines

    scenario = parse_scenario(FAILING)  # text of no file: its lines are still its own
    program = compile_scenario(scenario)
    outcome = run_program(program)
    (read,) = evaluate(scenario.expect, outcome, program.collapse_threshold)
    assert str(read.at) == "<scenario>:3:10" and read.lines()[1:] == ["    expect: {collapse: 2}", "             ^"]
    (built,) = evaluate(Expect(collapse=2), outcome, program.collapse_threshold)
    assert built.at is None and built.lines() == ["expected collapse 2, measured stands"] and located_lines([built]) == []


@pytest.mark.parametrize(
    "threshold, error, said",
    [
        (-1.0, ValueError, "threshold must be a finite number of metres above 0"),
        (0.0, ValueError, "threshold must be a finite number of metres above 0"),
        (float("nan"), ValueError, "threshold must be a finite number of metres above 0"),
        (float("inf"), ValueError, "threshold must be a finite number of metres above 0"),
        (40, ValueError, "threshold is in metres: 40 m is more than any brick is long (10 m); for 40 mm, give 0.04"),
        ("0.004", TypeError, "threshold must be a number of metres, not '0.004'"),
        (True, TypeError, "threshold must be a number of metres, not True"),
    ],
)
def test_evaluate_refuses_a_threshold_no_scenario_could_have(threshold, error, said):
    # -1 passed "levels 1-2 stay" while saying every brick had moved (measured text and verdict
    # disagreed); NaN passed everything
    from stackdsl import FakeWorld, outcome, run_in
    from stackdsl.verdicts.expect import evaluate

    scenario = parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 2}}\nexpect: {stays: 1-2}\n")
    program = compile_scenario(scenario)
    ran = outcome(run_in(FakeWorld(timestep=program.engine.timestep), program), 0.0)
    assert [v.passed for v in evaluate(scenario.expect, ran, program.collapse_threshold)] == [True]
    with pytest.raises(error, match=re.escape(said)):
        evaluate(scenario.expect, ran, threshold)


def test_junit_xml_into_a_missing_folder_is_bad_input(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(_judge, "run_program", lambda *a: pytest.fail("simulated before the output was known to be writable"))
    assert main(["check", str(write(tmp_path, a=PASSING)), "--junit-xml", str(tmp_path / "no" / "junit.xml")]) == 2
    assert "no such folder for the JUnit XML file" in capsys.readouterr().err


# options and exit statuses


@pytest.mark.slow
@pytest.mark.parametrize("bad", ["", "--mode sideways", "-j 0", "-j 100000", "-j two", "-j 1.5"])
def test_usage_errors_exit_2(bad, tmp_path, capsys):
    with pytest.raises(SystemExit) as info:
        main(["check", str(tmp_path), *bad.split()] if bad else [])
    assert info.value.code == 2


def test_jobs_accepts_auto_and_one_to_the_cores(monkeypatch):
    from stackdsl.batch import address

    cores = address.cores()
    monkeypatch.setattr(address, "_running_others", lambda: 0)  # an idle machine: auto is every core
    assert _cli.jobs_type("auto") == cores and _cli.jobs_type(str(cores)) == cores and _cli.jobs_type("1") == 1


def test_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    from importlib.metadata import version

    assert capsys.readouterr().out.strip() == f"stackdsl {version('stackdsl')}"


@pytest.mark.slow
@pytest.mark.parametrize("command", [[], ["check"], ["compare"], ["run"], ["compile"], ["schema"], ["bench"]])
def test_exit_statuses_are_in_the_help(command, capsys):
    with pytest.raises(SystemExit):
        main([*command, "--help"])
    out = capsys.readouterr().out
    assert "exit status:" in out and "2    bad input" in out and "3    internal error" in out
    assert ("1    an expectation failed" in out) == (command in ([], ["check"], ["compare"], ["run"]))


@pytest.mark.parametrize(
    ("command", "one"),
    [
        (["search"], "1    a counterexample found (the expectation fails), no threshold found"),
        (["sweep"], "1    an expectation failed or was inconclusive"),
        (["compile"], None),
    ],
)
def test_each_command_says_its_own_exit_status_1(command, one, capsys):
    """The epilogs were the shared text with its 0 and 1 lines replaced; once the shared 1 line
    was reworded the replacements matched nothing, and search, sweep and compile said what check
    says of exit 1 (compile, which never exits 1, among them). Each is now built from its own
    words."""
    with pytest.raises(SystemExit):
        main([*command, "--help"])
    out = capsys.readouterr().out
    assert "exit status:" in out and "a run ended undecided (INCONCLUSIVE" not in out
    assert (one in out) if one is not None else ("\n  1    " not in out.split("exit status:")[1])


def test_run_json_help_says_a_failed_expectation_exits_1(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    assert "With --json too, the exit status is 1 when an expectation failed" in capsys.readouterr().out


def test_run_json_exits_1_on_a_failed_expectation(tmp_path, capsys):
    assert main(["run", str(write(tmp_path, b=FAILING) / "b.yaml"), "--json"]) == 1
    doc = json.loads(capsys.readouterr().out)
    assert doc["collapse"] is None and doc["certificate"]["verdict"] == "stands"
    assert [(v["name"], v["passed"]) for v in doc["verdicts"]] == [("collapse", False)]  # beside the proof


def test_an_exception_in_a_run_is_its_rows_internal_error_and_exit_3(tmp_path, capsys, monkeypatch):
    def broken(*args, **kwargs):
        raise RuntimeError("wheels came off\nsecond line")

    monkeypatch.setattr(_judge, "run_program", broken)
    monkeypatch.delenv("STACKDSL_TRACEBACK", raising=False)
    folder = write(tmp_path, a=PASSING)
    assert main(["check", str(folder), "-j", "1"]) == 3
    captured = capsys.readouterr()
    fail = next(line for line in captured.out.splitlines() if line.startswith("FAIL"))
    assert "a.yaml" in fail and "stands" in fail and "internal error: RuntimeError: wheels came off" in fail
    assert f"      more: stackdsl --debug run {folder / 'a.yaml'}" in captured.out.splitlines()
    assert "1 scenarios: 0 passed, 1 failed (1 of them internal error)" in captured.out
    assert captured.err.splitlines() == [
        f"stackdsl: internal error: RuntimeError: wheels came off in {folder / 'a.yaml'} (extension)"
        " (run with --debug for the traceback)"
    ]
    for debug in (["--debug", "check"], ["check", "--debug"]):
        assert main([*debug, str(folder), "-j", "1"]) == 3
        err = capsys.readouterr().err
        assert "Traceback (most recent call last)" in err and 'raise RuntimeError("wheels came off' in err
        assert err.splitlines()[-1].endswith("wheels came off in " + str(folder / "a.yaml") + " (extension)")
    monkeypatch.setenv("STACKDSL_TRACEBACK", "1")
    assert main(["check", str(folder), "-j", "1"]) == 3
    assert "Traceback (most recent call last)" in capsys.readouterr().err


def test_an_internal_error_reading_one_file_of_a_folder_is_its_row_and_the_others_run(tmp_path, capsys, monkeypatch):
    folder = write(tmp_path, a=PASSING, b=PASSING, c=PASSING)
    compile_scenario = _check.compile_scenario

    def broken_on_b(scenario, *args, **kwargs):
        if scenario.name == "b":
            raise TypeError("list indices must be integers or slices, not str")
        return compile_scenario(scenario, *args, **kwargs)

    monkeypatch.setattr(_check, "compile_scenario", broken_on_b)
    monkeypatch.delenv("STACKDSL_TRACEBACK", raising=False)
    assert main(["check", str(folder), "-j", "1"]) == 3
    captured = capsys.readouterr()
    rows = [line for line in captured.out.splitlines() if line[:4] in ("PASS", "FAIL")]
    verdicts = {Path(row.split()[1]).name: row for row in rows}  # in the order they finished
    assert {n: row[:4] for n, row in verdicts.items()} == {"a.yaml": "PASS", "b.yaml": "FAIL", "c.yaml": "PASS"}
    assert verdicts["b.yaml"].endswith("internal error: TypeError: list indices must be integers or slices, not str")
    (line,) = captured.err.splitlines()
    assert line == (
        "stackdsl: internal error: TypeError: list indices must be integers or slices, not str"
        f" in {folder / 'b.yaml'} (extension) (run with --debug for the traceback)"
    )


# A 2-level sweep that draws nothing: two runs of a fraction of a second
SWEEP = (
    "stackdsl: 1\nstructure: {tower: {levels: 2, bricks_per_layer: 1, turn: 0}}\n"
    "sweep: {samples: 1, grid: {structure.tower.shift: [0 mm, 10 mm]}}\nexpect: {p_stands: '>= 0.9'}\n"
)


def _broken_for(module, name, file):
    """``module.name`` replaced by one that raises for the file named ``file`` only (found in its
    arguments: a path, a scenario or program named after its file, a sweep's template by its
    source) and is itself for the others."""
    real = getattr(module, name)

    def named(value):
        source = getattr(getattr(value, "source", None), "file", None)
        text = str(source or getattr(value, "name", value))
        return text == file or text.endswith(f"{file}.yaml")

    def broken(*args, **kwargs):
        if any(named(a) for a in args):
            raise KeyError("wheels")
        return real(*args, **kwargs)

    return broken


# where one file's internal error is met: reading it, compiling it, running it, a sweep's batch,
# judging a sweep's samples
INJECTED = {
    "load": (_check, "load_scenario"),
    "compile": (_check, "compile_scenario"),
    "run": (_check_sweep, "judge"),
    "batch": (_check_sweep, "run_batch"),
    "verdicts": (_check, "sweep_result"),
}


@pytest.mark.slow
@pytest.mark.parametrize("where", list(INJECTED))
def test_an_internal_error_in_one_file_is_its_row_and_every_other_file_is_reported(tmp_path, capsys, monkeypatch, where):
    module, name = INJECTED[where]
    sweep = where in ("batch", "verdicts")
    folder = write(tmp_path, a=PASSING, b=SWEEP if sweep else PASSING, c=FAILING, d=SWEEP)
    monkeypatch.setattr(module, name, _broken_for(module, name, "b"))
    monkeypatch.delenv("STACKDSL_TRACEBACK", raising=False)
    paths = [str(folder / f"{n}.yaml") for n in "abcd"]
    junit, report = tmp_path / "j.xml", tmp_path / "report"
    assert main(["check", *paths, "-j", "1", "--junit-xml", str(junit)]) == 3
    captured = capsys.readouterr()
    rows = {Path(line.split()[1]).stem: line for line in captured.out.splitlines() if line[:4] in ("PASS", "FAIL")}
    assert sorted(rows) == list("abcd")
    assert rows["a"].startswith("PASS") and rows["c"].startswith("FAIL") and rows["d"].startswith("PASS")
    assert rows["b"].startswith("FAIL") and rows["b"].endswith("internal error: KeyError: 'wheels'")
    if sweep:  # a sweep's statistics, not "(nothing)", as what it expected
        assert "P(stands) >= 0.9" in rows["b"]
    assert "4 scenarios: 2 passed, 2 failed (1 of them internal error)" in captured.out
    (line,) = [x for x in captured.err.splitlines() if ": a sweep of " not in x]  # each sweep's runs, said up front
    assert line.startswith("stackdsl: internal error: KeyError: 'wheels' in ") and "b.yaml" in line and "--debug" in line
    suite = ET.parse(junit).getroot().find("testsuite")
    assert (suite.get("tests"), suite.get("errors"), suite.get("failures")) == ("4", "1", "1")
    (error,) = suite.findall("testcase/error")
    assert "Traceback" in error.text and "KeyError: 'wheels'" in error.text
    # JSON, the HTML report, and the traceback with --debug
    assert main(["--debug", "check", *paths, "-j", "1", "--json", "--report", str(report)]) == 3
    captured = capsys.readouterr()
    document = json.loads(captured.out)
    assert document["summary"] == {**document["summary"], "total": 4, "passed": 2, "failed": 2, "errors": 1}
    assert [Path(r["file"]).stem for r in document["results"]] == list("abcd")  # file order
    assert document["results"][1]["error"] == "internal error: KeyError: 'wheels'"
    assert "Traceback (most recent call last)" in captured.err and "KeyError: 'wheels'" in captured.err
    page = (report / "index.html").read_text()
    assert all(f"{n}.yaml" in page for n in "abcd") and "internal error: KeyError" in page


def test_an_internal_error_in_one_file_is_its_cells_in_compare(tmp_path, capsys, monkeypatch):
    folder = write(tmp_path, a=PASSING, b=PASSING)
    monkeypatch.setattr(_check, "load_scenario", _broken_for(_check, "load_scenario", "b"))
    monkeypatch.delenv("STACKDSL_TRACEBACK", raising=False)
    assert main(["compare", str(folder), "-j", "1", "--modes", "raw,extension"]) == 3
    out = capsys.readouterr().out
    a, b = out.split("\na: stands\n")[1].split("\nb: ")
    assert a.count("PASS stands") == 2 and b.count("FAIL internal error") == 2, out


@pytest.mark.parametrize("command", ["compile", "run", "schema", "bench", "compare"])
def test_an_internal_error_in_any_command_is_one_line_and_exit_3(command, tmp_path, capsys, monkeypatch):
    def broken(*args, **kwargs):
        raise KeyError("wheels")

    monkeypatch.delenv("STACKDSL_TRACEBACK", raising=False)
    for module, name in [
        (_compiler, "compile_scenario"),
        (_judge, "run_program"),
        (_jsonschema, "json_schema"),
        (_cli_bench, "run_matrix"),
    ]:
        monkeypatch.setattr(module, name, broken)
    path = write(tmp_path, a=PASSING) / "a.yaml"
    args = {"schema": [], "bench": ["--quick", "--out", str(tmp_path)], "compare": [str(path), "-j", "1"]}.get(
        command, [str(path)]
    )
    assert main([command, *args]) == 3
    err = capsys.readouterr().err
    # compare's progress (a line per finished cell) goes to stderr off a terminal
    (line,) = [x for x in err.splitlines() if not x.startswith("[")]
    assert (
        "Traceback" not in err
        and line.startswith("stackdsl: internal error: KeyError: 'wheels'")
        and line.endswith(" (run with --debug for the traceback)")
    )
    assert main(["--debug", command, *args]) == 3
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err and err.splitlines()[-1].startswith("stackdsl: internal error: KeyError")


def test_ctrl_c_that_a_c_extension_reports_as_its_own_error_is_an_interrupt(tmp_path, capsys, monkeypatch):
    # Ctrl-C during a C extension's import comes out of it as an ImportError, not as
    # KeyboardInterrupt: under load, a real `check` interrupted 0.3 s in exited 3, a "bug"
    def importing(*args, **kwargs):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)
        except KeyboardInterrupt:
            pass
        raise ImportError("initialization of _pybullet raised unreported exception")

    monkeypatch.setattr(_compiler, "compile_scenario", importing)
    assert main(["run", str(write(tmp_path, a=PASSING) / "a.yaml")]) == 130
    assert capsys.readouterr().err == "stackdsl: interrupted\n"
    monkeypatch.setattr(_compiler, "compile_scenario", lambda *a, **k: (_ for _ in ()).throw(ImportError("no wheel")))
    assert main(["run", str(tmp_path / "a.yaml")]) == 3  # without Ctrl-C it is the bug it looks like


def test_an_internal_error_is_an_error_in_json_and_junit(tmp_path, capsys, monkeypatch):
    def broken(*args, **kwargs):
        raise RuntimeError("wheels came off")

    monkeypatch.setattr(_judge, "run_program", broken)
    folder = write(tmp_path, a=PASSING)
    assert main(["check", str(folder), "-j", "1", "--json", "--junit-xml", str(tmp_path / "j.xml")]) == 3
    document = json.loads(capsys.readouterr().out)
    assert document["summary"]["errors"] == 1 and document["summary"]["failed"] == 1
    (result,) = document["results"]
    assert result["error"] == "internal error: RuntimeError: wheels came off" and result["stopped"] is None
    suite = ET.parse(tmp_path / "j.xml").getroot().find("testsuite")
    assert suite.get("errors") == "1" and suite.get("failures") == "0"
    error = suite.find("testcase/error")
    assert error.get("message") == result["error"] and "Traceback" in error.text


@pytest.mark.slow
def test_timeout_is_passed_to_every_run_and_validated(tmp_path, capsys, monkeypatch):
    seen = []

    def timed(program, options=None, *, timeout=None):
        seen.append(timeout)
        return run_program(program)

    monkeypatch.setattr(_judge, "run_program", timed)
    path = write(tmp_path, a=PASSING) / "a.yaml"
    assert main(["check", str(path), "-j", "1", "--timeout", "7.5"]) == 0
    assert main(["run", str(path), "--timeout", "8"]) == 0
    assert main(["compare", str(path), "-j", "1", "--modes", "raw", "--timeout", "9"]) == 0
    assert main(["check", str(path), "-j", "1"]) == 0
    assert seen == [7.5, 8.0, 9.0, _check.TIMEOUT]
    for bad in ["0", "-1", "soon", "inf"]:
        with pytest.raises(SystemExit) as info:
            main(["check", str(path), "--timeout", bad])
        assert info.value.code == 2


def test_a_run_stopped_by_its_timeout_fails_and_says_when(tmp_path, capsys, monkeypatch):
    class Stopped:
        """An outcome as the runtime returns it when its wall-clock limit stopped the run."""

        def __init__(self, outcome):
            self._outcome = outcome
            self.stopped = "timeout after 42 s at t = 5.0 s simulated (of 7 s)"

        def __getattr__(self, name):
            return getattr(self._outcome, name)

    def timed(program, options=None, *, timeout=None):
        return Stopped(run_program(program))

    monkeypatch.setattr(_judge, "run_program", timed)
    path = write(tmp_path, a=PASSING) / "a.yaml"
    assert main(["check", str(path), "-j", "1", "--timeout", "42"]) == 1
    out = capsys.readouterr().out
    fail = next(line for line in out.splitlines() if line.startswith("FAIL"))
    assert "timeout after 42 s at t = 5.0 s simulated" in fail
    assert main(["run", str(path), "--timeout", "42"]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert any(x.startswith("FAIL  ") and x.endswith("timeout after 42 s at t = 5.0 s simulated (of 7 s)") for x in lines)
    assert lines[-1].strip() == "the rest of the run was not simulated: a longer --timeout (now 42 s) lets it finish"


@pytest.mark.slow
@pytest.mark.skipif("timeout" not in inspect.signature(run_program).parameters, reason="the runtime takes no timeout")
def test_a_short_timeout_stops_the_run_here_and_in_a_worker(tmp_path, capsys):
    slow = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nengine: {mode: raw, timestep: 0.1 ms}\ntiming: {settle: 600 s}\n"
    folder = write(tmp_path, a=slow, b=slow)
    for jobs in ("1", str(min(2, os.cpu_count() or 1))):
        assert main(["check", str(folder), "-j", jobs, "--timeout", "0.5"]) == 1
        rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith(("PASS", "FAIL"))]
        assert len(rows) == 2 and all(r.startswith("FAIL") and "timeout after 0.5 s at t = " in r for r in rows)


def test_ctrl_c_exits_130_without_a_traceback(tmp_path, capsys, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(_judge, "run_program", interrupted)
    assert main(["check", str(write(tmp_path, a=PASSING)), "-j", "1"]) == 130
    assert capsys.readouterr().err == "stackdsl: interrupted\n"


def test_ctrl_c_that_lands_in_a_finalizer_still_ends_the_command(tmp_path, capsys, monkeypatch):
    # Python runs a signal's handler between bytecodes, also inside an object's finalizer; the
    # KeyboardInterrupt it raises there is "unraisable", and the command went on to its end.
    class Finalized:
        def __del__(self) -> None:
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(10_000):  # the handler runs here, inside the finalizer
                pass

    def running(*args, **kwargs):
        Finalized()
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline:
            time.sleep(0.01)
        pytest.fail("Ctrl-C was lost in a finalizer: the run went on")

    monkeypatch.setattr(_judge, "run_program", running)
    assert main(["check", str(write(tmp_path, a=PASSING)), "-j", "1"]) == 130
    assert capsys.readouterr().err == "stackdsl: interrupted\n"


def test_ctrl_c_while_the_command_loads_exits_130_without_a_traceback(capsys, monkeypatch):
    class Loading(types.ModuleType):
        def __getattr__(self, name):
            os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C in the middle of the import
            return lambda: 0

    monkeypatch.setitem(sys.modules, "stackdsl.cli.main", Loading("stackdsl.cli.main"))
    assert _entry.main() == 130
    assert capsys.readouterr().err == "stackdsl: interrupted\n"


@pytest.mark.slow
@pytest.mark.parametrize("delay", [0.3, 0.6, 1.5])
def test_ctrl_c_at_any_moment_of_a_real_command_exits_130(delay, tmp_path):
    # loading the modules takes about 0.7 s, the run 60 s of raw pybullet at 0.1 ms
    slow = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nengine: {mode: raw, timestep: 0.1 ms}\ntiming: {settle: 60 s}\n"
    process = subprocess.Popen(
        [str(Path(sys.executable).parent / "stackdsl"), "check", str(write(tmp_path, slow=slow)), "-j", "1"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "CI": "true"},
    )
    time.sleep(delay)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130 and err == "stackdsl: interrupted\n"


@pytest.mark.slow
@pytest.mark.parametrize("command", ["compile", "run", "check"])
def test_a_closed_pipe_ends_quietly(command, tmp_path):
    # The reader is gone before the command writes anything: its first write meets a
    # closed pipe.
    path = write(tmp_path, a=PASSING) / "a.yaml"
    args = [sys.executable, "-m", "stackdsl", command, str(path)] + (["-j", "1"] if command == "check" else [])
    process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    process.stdout.close()
    err = process.stderr.read()
    assert process.wait() == 141 and err == ""


@pytest.mark.slow
def test_console_script_output_has_no_engine_chatter(tmp_path):
    done = stackdsl_command("check", str(write(tmp_path, a=PASSING)), "-j", "1")
    assert done.returncode == 0, done.stderr
    assert "argv[0]" not in done.stdout + done.stderr and "build time" not in done.stdout + done.stderr


# progress: plain lines off a terminal, a live line on one


def test_progress_is_live_only_on_a_terminal_outside_ci(monkeypatch):
    class Terminal(io.StringIO):
        def isatty(self):
            return True

    monkeypatch.delenv("CI", raising=False)
    monkeypatch.setenv("TERM", "xterm")
    assert is_live(Terminal()) and not is_live(io.StringIO())
    monkeypatch.setenv("CI", "true")
    assert not is_live(Terminal())


def test_live_progress_prints_rows_above_a_progress_line():
    out = io.StringIO()
    with Lines(2, "check", file=out, live=True) as lines:
        lines.line("PASS  first row")
        lines.advance()
        lines.line("PASS  second row")
        lines.advance()
    text = out.getvalue()
    assert "PASS  first row" in text and "PASS  second row" in text
    assert "\x1b[" in text and "2/2" in text  # terminal control codes, and the count


def test_plain_progress_is_just_the_lines():
    out = io.StringIO()
    with Lines(1, "check", file=out, live=False) as lines:
        lines.line("PASS  a row")
        lines.advance()
    assert out.getvalue() == "PASS  a row\n"


def test_check_on_a_terminal_shows_the_rows_and_a_progress_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(_cli_check, "is_live", lambda stream: True)
    assert main(["check", str(write(tmp_path, a=PASSING, b=FAILING)), "-j", "1"]) == 1
    out = capsys.readouterr().out
    assert "\x1b[" in out and "2/2" in out and "a.yaml" in out and "      more: stackdsl run" in out
    assert "\x1b[2K2 scenarios: 1 passed, 1 failed (" in out.splitlines()[-1]  # once the progress line is erased


# the fan-out


def test_estimate_grows_with_bricks_and_engine_work():
    def program(levels: int, mode: str):
        return compile_scenario(
            parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: {levels}}}}}\nengine: {{mode: {mode}}}")
        )

    assert program(2, "extension").wall_estimate < program(20, "extension").wall_estimate
    assert program(2, "raw").wall_estimate < program(20, "raw").wall_estimate < program(20, "tuned").wall_estimate


def test_jobs_below_one_is_an_error(tmp_path):
    with pytest.raises(ValueError, match="at least 1"):
        _check.check([write(tmp_path, a=PASSING)], jobs=0)


# compile, run, schema


def test_compile_prints_the_program(tmp_path, capsys):
    assert main(["compile", str(write(tmp_path, a=PASSING) / "a.yaml")]) == 0
    out = capsys.readouterr().out
    assert "place  L01.1" in out and out.rstrip().endswith("end")
    assert main(["compile", str(tmp_path / "a.yaml"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["engine"]["mode"] == "extension"


@pytest.mark.slow
def test_compile_and_run_json_print_whole_step_times_without_float_noise(tmp_path, capsys):
    """Three intervals of 0.7 s sum to 2.0999999999999996 s in floats: the JSON says 2.1, as the
    text does, while the program itself keeps the times it computed (what it runs is unchanged)."""
    (tmp_path / "t.yaml").write_text(
        "stackdsl: 1\nstructure: {tower: {levels: 4}}\ntiming: {interval: 0.7 s}\n"
        "actions: [{remove: {brick: L04.1, at: after level 4}}]\nexpect: {stays: 1-3}\n"
    )
    program = compile_scenario(parse_scenario((tmp_path / "t.yaml").read_text(), "t.yaml"))
    noisy = [a.time for a in program.actions if a.time != round(a.time, 9)]
    assert noisy, "the scene no longer makes float noise: pick another interval"
    assert main(["compile", str(tmp_path / "t.yaml"), "--json"]) == 0
    actions = json.loads(capsys.readouterr().out)["actions"]
    dt = program.engine.timestep
    for a in actions:  # each a whole number of steps of 0.7 s / 168: a decimal of at most 9 places
        assert a["time"] == round(a["step"] * dt, 9), a
        if "end_time" in a:
            assert a["end_time"] == round(a["end_step"] * dt, 9), a
    assert main(["run", str(tmp_path / "t.yaml"), "--json"]) == 0
    events = json.loads(capsys.readouterr().out)["events"]
    placed = [e["time"] for e in events if e["kind"] == "place"]
    assert placed == [round(a["step"] * dt, 9) for a in actions if a["kind"] == "place"]


def test_run_prints_the_timeline(tmp_path, capsys):
    assert main(["run", str(write(tmp_path, a=PASSING) / "a.yaml")]) == 0
    out = capsys.readouterr().out
    assert "freeze   L01.1" in out and "PASS  expected stands" in out


def test_schema_prints_the_json_schema_of_a_scenario(capsys):
    from stackdsl.lang.jsonschema import json_schema

    assert main(["schema"]) == 0
    out = capsys.readouterr().out
    assert out == json.dumps(json_schema(), indent=2) + "\n"
    assert "structure" in json.loads(out)["required"]


# compare


def test_compare_prints_a_block_per_scenario_and_a_row_per_mode(tmp_path, capsys):
    assert main(["compare", str(write(tmp_path, a=PASSING, b=FAILING)), "--modes", "raw,extension", "-j", "1"]) == 1  # b fails
    captured = capsys.readouterr()
    out = captured.out.splitlines()
    assert out[0] == "scenario: what it expects" and out[1].split() == ["engine", "mode", "result", "wall"]
    assert out[2] == "a: stands" and out[3].split()[:4] == ["pybullet", "raw", "PASS", "stands"]
    assert out[4].split()[:4] == ["pybullet", "extension", "PASS", "stands"]
    assert out[5] == "b: collapse 2" and [line.split()[2] for line in out[6:8]] == ["FAIL", "FAIL"]
    assert out[-1].startswith("2 scenarios x 2 modes")
    progress = captured.err.splitlines()  # a line per finished cell, off stdout
    assert [line.split()[0] for line in progress] == ["[1/4]", "[2/4]", "[3/4]", "[4/4]"]
    assert "a pybullet raw: PASS stands" in captured.err


def test_compare_refuses_a_sweep_past_its_budget_as_bad_input(tmp_path, capsys):
    """A sweep whose runs cannot end within --timeout is bad input in every mode (exit 2, the
    sweep's field named), not a refused cell of an otherwise passing table."""
    sweep = (
        "stackdsl: 1\nstructure: {tower: {levels: 3, bricks_per_layer: 1, turn: 0,"
        " shift: {uniform: [-10 mm, 10 mm], per: layer}}}\nsweep: {samples: 2000}\n"
    )
    (tmp_path / "s.yaml").write_text(sweep)
    code = main(["compare", str(tmp_path / "s.yaml"), "--modes", "raw,extension", "--timeout", "2", "-j", "1"])
    captured = capsys.readouterr()
    assert code == 2, captured
    assert "sweep.samples" in captured.err and "this sweep makes 2000 runs" in captured.err
    assert "refused (why" not in captured.out + captured.err


DOMINOES = """stackdsl: 1
brick_types: {finger: {size: [20 mm, 10 mm, 10 mm]}}
structure:
  bricks:
    - {id: d01, at: [0 mm, 0, 60 mm], pitch: 90, level: 1}
    - {id: d02, at: [40 mm, 0, 60 mm], pitch: 90, level: 1}
    - {id: d03, at: [80 mm, 0, 60 mm], pitch: 90, level: 1}
timing: {settle: 1 s}
actions:
  - push: {target: {brick: d01, offset: [0, 0, 45 mm]}, direction: [1, 0, 0], speed: 0.2 m/s, distance: 15 mm, at: after level 1, pusher: finger}
expect:
  toppled: all
"""


def test_compare_shows_the_toppled_count_in_every_mode(tmp_path, capsys):
    folder = write(tmp_path, row=DOMINOES)
    assert main(["compare", str(folder), "--modes", "raw,extension", "-j", "1"]) == 0
    captured = capsys.readouterr()
    raw, extension = captured.out.splitlines()[3:5]
    # as check says, with the domino that fell first: cells that agree on the level may not on where it began
    assert "PASS collapse 1 from d01, 3 of 3 toppled" in raw and "PASS collapse 1 from d01, 3 of 3 toppled" in extension
    assert raw.index("PASS") == extension.index("PASS")  # the columns still line up
    assert "raw: PASS collapse 1 from d01, 3 of 3 toppled" in captured.err  # the line a finished cell prints too
    assert main(["check", str(folder), "--mode", "raw", "-j", "1"]) == 0
    assert "3 of 3 toppled" in capsys.readouterr().out


RANDOM = """stackdsl: 1
seed: 7
structure:
  tower: {levels: 6, bricks_per_layer: 1, turn: 0, shift: {uniform: [-60 mm, 60 mm], per: layer}}
timing: {settle: 0.2 s}
sweep: {samples: 4}
"""


def test_run_on_a_sweep_file_says_which_sample_it_runs_and_runs_the_one_asked(tmp_path, capsys):
    path = write(tmp_path, walk=RANDOM) / "walk.yaml"
    template = parse_scenario(RANDOM, "walk.yaml").template

    def events(scenario) -> list[tuple[float, str, str, str]]:
        outcome = run_program(compile_scenario(scenario))
        return [(e.time, e.kind, e.brick, e.detail) for e in outcome.events]

    def ran(*extra: str) -> tuple[list[tuple[float, str, str, str]], str]:
        assert main(["run", str(path), "--json", *extra]) in (0, 1)
        captured = capsys.readouterr()
        return [(e["time"], e["kind"], e["brick"], e["detail"]) for e in json.loads(captured.out)["events"]], captured.err

    first, said = ran()
    own = template.scenario(0, 0).seed  # a new user took the sweep's seed for the sample's own
    assert f"running sample 0 of 4 (the sweep's seed 7, this sample's {own}: samples.csv's seed column); `stackdsl sweep`" in said
    assert first == events(template.scenario(0, 0)) and own != 7
    fourth, said = ran("--sample", "3")  # sample 2 stands as sample 0 does, to the same events
    assert f"running sample 3 of 4 (the sweep's seed 7, this sample's {template.scenario(0, 3).seed}:" in said
    assert fourth == events(template.scenario(0, 3)) and fourth != first
    assert main(["run", str(path), "--sample", "100000"]) == 2  # sample 4 is one 'sweep --samples 5' runs
    assert "--sample: a sweep draws samples 0 to 99999 at most (this one 0 to 3), not 100000" in capsys.readouterr().err
    assert main(["run", str(write(tmp_path, plain=PASSING) / "plain.yaml"), "--sample", "1"]) == 2
    assert "no sweep and no random field" in capsys.readouterr().err
    assert main(["run", str(tmp_path / "plain.yaml")]) == 0 and "running sample" not in capsys.readouterr().err


def test_compile_on_a_sweep_file_says_which_sample_it_shows_and_shows_the_one_asked(tmp_path, capsys):
    path = write(tmp_path, walk=RANDOM) / "walk.yaml"
    template = parse_scenario(RANDOM, "walk.yaml").template

    def shown(*extra: str) -> tuple[list[list[float]], str]:
        assert main(["compile", str(path), "--json", *extra]) == 0
        captured = capsys.readouterr()
        return [a["position"] for a in json.loads(captured.out)["actions"] if a["kind"] == "place"], captured.err

    first, said = shown()
    assert "stackdsl compile: showing sample 0 of 4 (the sweep's seed 7, this sample's " in said
    assert first == [list(a.position) for a in compile_scenario(template.scenario(0, 0)).placements]
    third, said = shown("--sample", "2")
    assert "showing sample 2 of 4" in said and "--sample K shows another" in said
    assert third == [list(a.position) for a in compile_scenario(template.scenario(0, 2)).placements] and third != first
    assert main(["compile", str(path), "--cell", "1"]) == 2
    assert "--cell: the sweep's grid has cells 0 to 0, not 1" in capsys.readouterr().err


def test_compare_json_and_k(tmp_path, capsys):
    folder = write(tmp_path, a=PASSING, b=FAILING)
    assert main(["compare", str(folder), "--modes", "raw,extension", "-j", "1", "-k", "b.yaml", "--json"]) == 1
    doc = json.loads(capsys.readouterr().out)
    assert sorted((Path(r["file"]).name, r["mode"]) for r in doc["results"]) == [("b.yaml", "extension"), ("b.yaml", "raw")]
    assert doc["command"] == "compare" and doc["summary"]["failed"] == 2


def test_compare_json_lists_its_results_in_the_tables_order_not_as_they_finished(tmp_path, capsys, monkeypatch):
    import stackdsl.cli.check as cli_check

    folder = write(tmp_path, a=PASSING, b=FAILING)
    finishing = cli_check.run_checks

    def backwards(*args, **kwargs):  # the last run to finish first, as parallel workers may
        return reversed(list(finishing(*args, **kwargs)))

    monkeypatch.setattr(cli_check, "run_checks", backwards)
    assert main(["compare", str(folder), "--modes", "raw,extension", "-j", "1", "--json"]) == 1
    doc = json.loads(capsys.readouterr().out)
    order = [(Path(r["file"]).name, r["mode"]) for r in doc["results"]]
    assert order == [("a.yaml", "raw"), ("a.yaml", "extension"), ("b.yaml", "raw"), ("b.yaml", "extension")]


def test_compare_says_what_failed_besides_the_level_and_keeps_its_columns(tmp_path, capsys, monkeypatch):
    """A collapse at the level expected can still fail its 'stays': the row says what moved; a long
    measured text wraps under itself, and every line fits the width (100 piped, COLUMNS when narrower)."""
    text = (
        "stackdsl: 1\nstructure: {tower: {levels: 12, bricks_per_layer: 1, turn: 0, shift: 13 mm}}\n"
        "expect: {collapse: 10±1, stays: 1-9}\n"
    )
    folder = write(tmp_path, slant=text, tower=PASSING)
    monkeypatch.setenv("COLUMNS", "60")
    assert main(["compare", str(folder), "--modes", "extension", "-j", "1"]) == 1
    out = capsys.readouterr().out.splitlines()
    at = out.index("slant: collapse 10±1, levels 1-9 stay")
    row, more = out[at + 1], out[at + 2]
    assert "FAIL collapse 10 from L" in row and more.strip().endswith("moved") and more.startswith(" " * 27)
    assert max(len(line) for line in out) <= 60, out
    # the wall times of every row in line, however long a measured text
    assert len({r.rstrip().rindex(" s") for r in out if r.startswith("  pybullet")}) == 1, out


def test_compare_unknown_mode_exits_2(tmp_path, capsys):
    assert main(["compare", str(write(tmp_path, a=PASSING)), "--modes", "raw,sideways"]) == 2
    assert "unknown mode sideways" in capsys.readouterr().err


def test_compare_keeps_file_order_whatever_order_runs_finish(tmp_path):
    modes = ("extension", "raw")
    prepared = _check.prepare(_check.discover([write(tmp_path, b=PASSING, a=FAILING)]), modes=modes)
    finished = list(_check.run_checks(prepared, jobs=1))[::-1]  # as if the last had finished first
    seen = []
    table = _check.tabulate(prepared, modes, finished, seen.append)
    assert seen == finished and [Path(f).name for f in table] == ["a.yaml", "b.yaml"]
    assert all(list(row) == list(modes) for row in table.values())
    assert table[str(tmp_path / "a.yaml")]["raw"].mode == "raw"


# bench


def test_bench_writes_outside_the_repository_by_default():
    import stat

    from stackdsl.cli.args import output_folder

    assert _cli._parser().parse_args(["bench"]).out is None
    out = output_folder(None, "stackdsl-bench-").resolve()
    try:
        assert out.is_relative_to(Path(tempfile.gettempdir()).resolve()) and not out.is_relative_to(ROOT)
        assert out.name.startswith("stackdsl-bench-") and stat.S_IMODE(out.stat().st_mode) == 0o700
        assert output_folder(None, "stackdsl-bench-") != out  # a new one each time
    finally:
        out.rmdir()


def test_bench_runs_one_cell_at_a_time_unless_told_otherwise():
    """Two cells at once on two cores slow each other unevenly (the extension's 3.5 mm cabin by 37%
    beside a tuned cell, raw's by 14%), which skews the ratios the bench exists for."""
    assert _cli._parser().parse_args(["bench"]).jobs == 1


def test_bench_help_names_the_command_that_regenerates_the_figures(capsys):
    with pytest.raises(SystemExit):
        main(["bench", "--help"])
    assert "stackdsl bench --out docs/bench" in capsys.readouterr().out


@pytest.mark.parametrize("heights", ["10,x", "0", "2000"])
def test_bench_refuses_bad_upright_heights_before_running(heights, capsys):
    assert main(["bench", "--upright", heights]) == 2
    err = capsys.readouterr().err
    assert "--upright" in err and "Traceback" not in err


@pytest.mark.parametrize("seconds", ["-1", "nan", "1e9"])
def test_bench_refuses_a_bad_after_collapse_time_before_running(seconds, capsys):
    assert main(["bench", "--after-collapse", seconds]) == 2
    err = capsys.readouterr().err
    assert "--after-collapse" in err and "Traceback" not in err


@pytest.mark.parametrize(
    ("argv", "where", "says"),
    [
        (["--settings", ""], "--settings", "give at least one setting"),
        (["--settings", ","], "--settings", "give at least one setting"),
        (["--settings", "tuned,warp"], "--settings", "unknown setting 'warp'"),
        (["--families", "nope"], "--families", "unknown scene family 'nope'; known: slant log cabin, single file, upright"),
        (["--families", " , "], "--families", "give at least one scene family"),
        (["--families", "upright", "--upright", ""], "--upright", "no scene to run"),
        (["--repeats", "0"], "--repeats", "at least 1, not 0"),
        (["--repeats", "-1"], "--repeats", "at least 1, not -1"),
        (["--repeat-below", "nan"], "--repeat-below", "0 or more"),
        (["--repeat-below", "-1"], "--repeat-below", "0 or more"),
        (["--out", "{file}"], "{file}", "this is a file, not a folder"),
        (["--out", "{file}/sub"], "{file}/sub", "cannot write in this folder: Not a directory"),
        (["--out", "/proc/stackdsl-bench"], "/proc/stackdsl-bench", "cannot write in this folder"),
    ],
)
@pytest.mark.parametrize("quick", [[], ["--quick"]], ids=["full", "quick"])
def test_bench_refuses_bad_options_before_any_cell_runs(argv, where, says, quick, tmp_path, capsys, monkeypatch):
    import stackdsl.cli.bench as bench

    def never(*args, **kwargs):
        raise AssertionError("a cell ran")

    monkeypatch.setattr(bench, "run_matrix", never)
    file = tmp_path / "a.txt"
    file.write_text("x")
    argv = [a.replace("{file}", str(file)) for a in argv]
    if quick and argv[:2] == ["--families", "upright"]:
        return  # --quick runs its one scene whatever the families
    assert main(["bench", *quick, *argv]) == 2
    captured = capsys.readouterr()
    (line,) = captured.err.strip().splitlines()
    assert line.startswith(where.replace("{file}", str(file)) + ": ") and says in line, line
    assert captured.out == "" and file.read_text() == "x"


@pytest.mark.parametrize(
    ("argv", "where", "says"),
    [
        (["--sizes", ""], "--sizes", "bricks per tower from 1 to 2000"),
        (["--sizes", ","], "--sizes", "bricks per tower from 1 to 2000"),
        (["--sizes", "-5"], "--sizes", "not '-5'"),
        (["--sizes", "0,10"], "--sizes", "not '0,10'"),
        (["--sizes", "100000000"], "--sizes", "bricks per tower from 1 to 2000 (a 4 stack of 1000 levels)"),
        (["--sizes", "ten"], "--sizes", "whole numbers of bricks"),
        (["--sizes", "2", "--repeats", "0"], "--repeats", "at least 1"),
    ],
)
def test_bench_solve_refuses_bad_sizes_and_repeats_as_its_options(argv, where, says, capsys, monkeypatch):
    import stackdsl.bench.cost as cost

    monkeypatch.setattr(cost, "solve_times", lambda *a: (_ for _ in ()).throw(AssertionError("a tower was solved")))
    assert main(["bench", "solve", *argv]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"{where}: ") and says in line and "<scenario>" not in line, line


def test_bench_verdicts_refuses_an_output_folder_it_cannot_write_before_running(tmp_path, capsys):
    (tmp_path / "a.txt").write_text("x")
    for out, says in ((tmp_path / "a.txt", "this is a file, not a folder"), (tmp_path / "a.txt" / "sub", "Not a directory")):
        assert main(["bench", "verdicts", "--count", "1", "--engines", "pybullet", "--out", str(out)]) == 2
        captured = capsys.readouterr()
        (line,) = captured.err.strip().splitlines()
        assert line.startswith(f"{out}: ") and says in line and captured.out == ""


def test_a_slant_scene_ends_where_its_collapse_is_decided_unless_told_to_settle():
    """The bench's slant cells stop at the decision, as the lean peer does; the scene's settle
    time can still be asked for. The level is the same either way."""
    from stackdsl.bench.bench import Scene, program_for
    from stackdsl.runtime.run import RunOptions, run_program

    scene = Scene("single file", 13, 12, "tower: {levels: 12, bricks_per_layer: 1, turn: 0, shift: 13 mm}", 10)
    program = program_for(scene, "extension report")
    decided = run_program(program, RunOptions(stop_at_collapse=True, settle=0.0))
    settled = run_program(program, RunOptions(stop_at_collapse=True))
    assert decided.collapse is not None and settled.collapse is not None
    assert decided.collapse.level == settled.collapse.level == 10
    assert decided.simulated_time == pytest.approx(decided.collapse.time, abs=program.engine.timestep)
    assert settled.simulated_time == pytest.approx(settled.collapse.time + program.settle, abs=program.engine.timestep)
    assert _cli._parser().parse_args(["bench"]).after_collapse == 0.0


def test_bench_upright_heights_pick_the_towers():
    from stackdsl.bench.bench import scenes

    upright = [s.levels for s in scenes(upright=(10, 60)) if s.family == "upright"]
    assert upright == [10, 60]


@pytest.mark.slow
def test_bench_quick_smoke_writes_every_output(tmp_path, capsys):
    # One small cell per setting, in worker processes: the command cannot rot.
    assert main(["bench", "--quick", "--out", str(tmp_path), "-j", "2"]) == 0
    names = {p.name for p in tmp_path.iterdir()}
    assert names == {"bench.csv", "bench.md", "wall_vs_error.png", "wall_vs_height.png"}
    rows = (tmp_path / "bench.csv").read_text().splitlines()
    n = len(DEFAULT_SETTINGS)
    assert rows[0].startswith("setting,family,parameter") and len(rows) == 1 + n
    assert {r.split(",")[0] for r in rows[1:]} == set(DEFAULT_SETTINGS)  # both backends, every default setting
    out = capsys.readouterr().out
    assert (
        "extension report" in out and "MuJoCo extension" in out and f"[{n}/{n}]" in out and f"wrote {tmp_path.resolve()}" in out
    )


@pytest.mark.slow
def test_bench_measures_each_fast_cell_once_a_round_and_a_slow_one_once():
    from stackdsl.bench.bench import Scene, run_matrix

    tiny = Scene("upright", 2, 2, "tower: {levels: 2}", None)
    seen = []
    cells = run_matrix(["raw 240 Hz", "extension report"], [tiny], repeats=3, repeat_below=30.0, jobs=2, progress=seen.append)
    assert [c.setting for c in cells] == ["raw 240 Hz", "extension report"] and len(seen) == 2
    for cell in cells:
        walls = [float(w) for w in cell.walls.split()]
        assert len(walls) == 3 and walls == sorted(walls) and cell.wall == pytest.approx(walls[1], abs=1e-3)
    (once,) = run_matrix(["raw 240 Hz"], [tiny], repeats=3, repeat_below=0.0, jobs=1)
    assert len(once.walls.split()) == 1


def test_json_and_junit_list_results_in_file_order_whatever_finishes_first(tmp_path, capsys):
    slow = "stackdsl: 1\nstructure: {tower: {levels: 6}}\nexpect: {stands: true}\n"
    quick = "stackdsl: 1\nstructure: {tower: {levels: 1}}\ntiming: {settle: 0.1 s}\nexpect: {stands: true}\n"
    folder = write(tmp_path, a_slow=slow, b_quick=quick, c_quick=quick)
    assert main(["check", str(folder), "-j", "2", "--json", "--junit-xml", str(tmp_path / "j.xml")]) == 0
    files = [Path(r["file"]).name for r in json.loads(capsys.readouterr().out)["results"]]
    assert files == ["a_slow.yaml", "b_quick.yaml", "c_quick.yaml"]
    cases = [c.get("name") for c in ET.parse(tmp_path / "j.xml").getroot().iter("testcase")]
    assert [Path(c).name for c in cases] == files


def test_bench_targets_print_as_sentences():
    from stackdsl.bench.out import PeerRatio
    from stackdsl.cli.bench import _targets

    lines = _targets(
        {
            "slant errors": {"raw 240 Hz": [-3, 0]},
            "30-level speed-up, raw 240 Hz / extension": 130.4,
            "peer": [PeerRatio("MuJoCo extension", "MuJoCo tuned sleeping", {30: (7.04, 0, 0)}, 1.26, 3.1)],
            "exponents": {"tuned": 1.571},
        }
    )
    assert lines == [
        "slant error, raw 240 Hz: -3, +0 levels",
        "30-level 4 stack: raw 240 Hz takes 130 times the extension's wall time",
        "30-level 4 stack: MuJoCo tuned sleeping takes 7.0 times MuJoCo extension's wall time (errors +0, +0)",
        "slant scenes: MuJoCo tuned sleeping takes at least 1.3 times MuJoCo extension's wall time (geometric mean 3.1)",
        "exponent of wall time in bricks, tuned: 1.57",
    ]


def test_bench_phase_table_splits_each_collapsing_scenes_wall_time():
    from stackdsl.bench.bench import Cell
    from stackdsl.bench.out import phase_lines

    slant = Cell("raw 240 Hz", "single file", 9, 1, 14, 8, -6, 0.0, 2.0, "", 1.5, 0.25, 1.0, 1.0, 1.0, 1, 0)
    upright = Cell("raw 240 Hz", "upright", 30, 1, None, None, 0, 0.0, 9.0, "", 8.0, 0.0, 1.0, 1.0, 1.0, 1, 0)
    lines = phase_lines([slant, upright])
    assert lines[0] == "| scene | raw 240 Hz |" and lines[2] == "| single file, 9 mm | 2.00: 1.50, 0.25 |"
    assert len(lines) == 5  # header, rule, one scene (the standing tower is left out), blank, legend
    assert phase_lines([upright]) == []


def test_bench_peer_ratios_divide_the_peers_wall_by_the_extensions_on_the_same_scene():
    from stackdsl.bench.bench import Cell
    from stackdsl.bench.out import peer_lines, peer_ratios

    def cell(setting, family, parameter, wall, error=0):
        return Cell(setting, family, parameter, 1, None, None, error, 0.0, wall, "", wall / 2, 0.0, 1.0, 1.0, 1.0, 1, 0)

    cells = [
        cell("MuJoCo extension", "upright", 30, 2.0),
        cell("MuJoCo tuned sleeping", "upright", 30, 10.0, error=-1),
        cell("MuJoCo extension", "slant log cabin", 9, 4.0),
        cell("MuJoCo tuned sleeping", "slant log cabin", 9, 2.0),
        cell("MuJoCo extension", "single file", 9, 1.0),
        cell("MuJoCo tuned sleeping", "single file", 9, 8.0),
        cell("extension report", "upright", 60, 1.0),  # no peer on this scene: no row
    ]
    [r] = peer_ratios(cells)
    assert (r.extension, r.peer) == ("MuJoCo extension", "MuJoCo tuned sleeping")
    assert r.upright == {30: (5.0, 0, -1)} and r.slant_least == 0.5 and r.slant_mean == pytest.approx(2.0)
    assert peer_lines([r])[2] == "| MuJoCo extension | MuJoCo tuned sleeping | 5.0 (errors +0, -1) |  | 0.5 | 2.0 |"


def test_bench_ratios_come_from_the_medians_and_again_from_each_cells_fastest_round():
    from stackdsl.bench.bench import Cell
    from stackdsl.bench.out import fastest, ratios

    def cell(setting, walls):
        runs = sorted(walls)
        median = runs[len(runs) // 2]
        return Cell(
            setting,
            "single file",
            9,
            1,
            14,
            14,
            0,
            0.0,
            median,
            " ".join(f"{w:.3f}" for w in walls),  # in the order run: the fastest need not be first
            0.1,
            0.0,
            1.0,
            1.0,
            1.0,
            1,
            0,
        )

    cells = [cell("extension report", [0.2, 0.4, 0.1]), cell("raw 240 Hz", [0.3, 0.25, 0.35])]
    median = ratios(cells)
    assert median[2] == "| single file, 9 mm | 0.20 s | 1.50 |"  # 0.30 / 0.20
    assert median[3] == "| single file: geometric mean | | 1.50 |"
    assert ratios(cells, wall=fastest)[2] == "| single file, 9 mm | 0.10 s | 2.50 |"  # 0.25 / 0.10


@pytest.mark.parametrize(
    "argv, where",
    [
        (["render", "scenarios/vee_stands.yaml", "-o", "/tmp/" + "x" * 300 + ".png"], "File name too long"),
        (
            ["check", "scenarios/vee_stands.yaml", "-j", "1", "--junit-xml", "/sys/x.xml"],
            "/sys/x.xml: --junit-xml: Permission denied",
        ),
        (["run", "scenarios/vee_stands.yaml", "--record", "/proc/x.npz"], "/proc/x.npz: --record: No such file or directory"),
    ],
    ids=["name too long", "a folder kept by the system", "a folder that takes no file"],
)
def test_a_path_the_system_refuses_is_bad_input_in_one_line_not_a_bug(argv, where, capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    assert main(argv) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("stackdsl: ") and line.endswith(where) and "internal error" not in line


def test_output_to_a_full_disk_is_bad_input(capsys, monkeypatch):
    with open("/dev/full", "w") as full:
        monkeypatch.setattr(sys, "stdout", full)
        assert main(["schema"]) == 2
    assert capsys.readouterr().err.strip() == "stackdsl: No space left on device"


def test_an_os_error_that_is_not_a_refused_path_is_still_a_bug(capsys, monkeypatch):
    import errno

    def broken(*args, **kwargs):
        raise OSError(errno.EBADMSG, "Bad message")

    monkeypatch.setattr(_jsonschema, "json_schema", broken)
    assert main(["schema"]) == 3
    assert capsys.readouterr().err.startswith("stackdsl: internal error: OSError: [Errno 74] Bad message")


def test_a_closed_standard_output_is_exit_141_as_a_closed_pipe():
    for argv in (["schema"], ["check", str(ROOT / "scenarios" / "vee_stands.yaml"), "-j", "1"]):
        done = subprocess.run(
            [sys.executable, "-m", "stackdsl", *argv],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=lambda: os.close(1),
        )
        assert done.returncode == 141 and done.stderr == "", argv


@pytest.mark.slow
@pytest.mark.parametrize(
    "argv", [["run"], ["check", "-j", "1"], ["check", "-j", "2"]], ids=["run", "check here", "check in workers"]
)
def test_a_closed_standard_error_runs_as_with_it_open(argv, tmp_path):
    # `2>&-`: Python's sys.stderr is None, and descriptor 2 free for the next file opened
    files = [str(p) for p in (ROOT / "scenarios" / "vee_stands.yaml", ROOT / "scenarios" / "slant_tower.yaml")]
    done = subprocess.run(
        [sys.executable, "-m", "stackdsl", argv[0], *files[: 1 if argv[0] == "run" else 2], *argv[1:]],
        stdout=subprocess.PIPE,
        stdin=subprocess.DEVNULL,
        text=True,
        preexec_fn=lambda: os.close(2),
        check=False,
    )
    assert done.returncode == 0, done.stdout
    assert "internal error" not in done.stdout and "Traceback" not in done.stdout
    assert "PASS" in done.stdout and "FAIL" not in done.stdout


def test_the_engines_chatter_is_silenced_with_standard_error_closed():
    code = (
        "import os, sys\n"
        "from stackdsl.engines.pybullet.client import quiet_c_output\n"
        "os.close(2); sys.stderr = None\n"
        "with quiet_c_output():\n"
        "    os.write(2, b'unseen')\n"
        "try:\n"
        "    os.fstat(2)\n"
        "except OSError:\n"
        "    print('closed again')\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert done.returncode == 0 and done.stdout == "closed again\n", done.stderr


@pytest.mark.slow  # 7-22 s: in .ci/nightly's slow part
@pytest.mark.parametrize("closed", ["stdout", "stderr"])
def test_a_pipe_closed_while_errors_are_said_is_exit_141(closed, tmp_path):
    # thousands of bad files: their errors fill the pipe long after its reader is gone
    for i in range(3000):
        (tmp_path / f"s{i}.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: 0}}\n")
    process = subprocess.Popen(
        [sys.executable, "-m", "stackdsl", "check", str(tmp_path)],
        stdout=subprocess.PIPE if closed == "stdout" else subprocess.DEVNULL,
        stderr=subprocess.STDOUT if closed == "stdout" else subprocess.PIPE,
    )
    pipe = process.stdout if closed == "stdout" else process.stderr
    assert pipe.readline().endswith(b"structure.tower.levels: expected 1 or more, got 0\n")
    pipe.close()
    assert process.wait(timeout=120) == 141


def test_a_compare_cell_says_why_a_run_stopped():
    """A run that stopped was labelled 'timeout' whatever stopped it: MuJoCo blowing up read as
    a time limit."""
    from stackdsl.cli.check import _cell
    from stackdsl.verdicts.check_result import CheckResult

    def stopped(why: str) -> str:
        return _cell(CheckResult("a.yaml", "a", "tuned", "report", (), None, 1, 1.0, 0.1, stopped=why))

    assert stopped("timeout after 100 s at t = 3.0 s simulated (of 5 s)") == "timeout"
    assert stopped("MuJoCo's simulation became unstable at t = 1.030 s: nothing after it is physics") == "unstable"


def test_a_compare_cell_says_the_bricks_that_moved_as_the_file_expects():
    """A new user's push that slid one block out of a Jenga tower read 'PASS collapse 12' in every
    row: which brick moved was shown only in a row that failed."""
    from stackdsl.cli.check import _cell
    from stackdsl.verdicts.check_result import CheckResult
    from stackdsl.verdicts.expect import Verdict

    moved = Verdict(name="moved", passed=True, expected="brick L06.2 moved", measured="brick L06.2 moved")
    stayed = Verdict(name="stays", passed=True, expected="levels 1-5 stay", measured="levels 1-5 stayed")
    r = CheckResult("a.yaml", "a", "extension", "report", (moved, stayed), 12, 12, 8.0, 1.0)
    assert _cell(r) == "collapse 12, brick L06.2 moved"


def test_a_compare_cell_says_how_near_a_collapse_came_to_standing():
    """A new user's pull read "FAIL collapse 9" on the extension where three other cells stood;
    its brick had been dragged 4.5 mm against a 4 mm threshold, which only `run` said. A cell
    decided less than 1 mm past its limit (the run's signed margin) says so, as a stand says how
    far it moved; one decided far past it does not, nor one whose brick ended far from its place
    (a brick knocked off a single file, decided as its centre of mass crossed the edge under it,
    0.5 mm past; it lay on the ground)."""
    from dataclasses import replace

    from stackdsl.cli.check import _cell
    from stackdsl.verdicts.check_result import CheckResult

    fell = CheckResult("a.yaml", "a", "extension", "report", (), 9, 9, 30.0, 1.0, first_moved="L03.1", first_moved_level=3)
    near = replace(fell, margin=-0.0005, first_moved_ended=0.0044, threshold=0.004)
    assert _cell(near) == "collapse 9 from L03.1, which ended 4.4 mm from its place, 0.5 mm past its limit, a near tie"
    assert _cell(replace(near, first_moved_ended=0.0047)).endswith(
        "ended 4.7 mm from its place, 0.7 mm past its limit, a near tie"
    )
    assert (
        _cell(replace(near, first_moved_ended=0.0105)) == "collapse 9 from L03.1, which ended 10.5 mm from its place"
    )  # dragged
    assert _cell(replace(near, first_moved_ended=0.1873)) == "collapse 9 from L03.1"  # knocked off: it fell
    assert _cell(replace(near, margin=-0.19)) == "collapse 9 from L03.1, which ended 4.4 mm from its place"
    assert _cell(replace(near, margin=None)) == "collapse 9 from L03.1, which ended 4.4 mm from its place"
    # statics' collapse at the end: its margin is no distance, and its brick moved 0.95 mm
    statics = replace(near, margin=-0.0, first_moved_ended=0.00095, certificate="collapse, no equilibrium: 0.000328 N")
    assert statics.kind == "no equilibrium"
    assert _cell(statics) == "collapse 9 from L03.1, which ended 0.95 mm from its place, no equilibrium at the end, a near tie"
    assert _cell(fell) == "collapse 9 from L03.1"  # a result that does not know where it ended
    # within 0.05 mm of the threshold, to the micrometre, as check's lines say it: never "ended 4.0 mm" of a 4 mm limit
    assert _cell(replace(near, first_moved_ended=0.00403)).startswith("collapse 9 from L03.1, which ended 4.030 mm from")


def test_a_compare_cell_of_a_run_that_ended_still_moving_says_undecided_not_stands():
    """A new user's card house, shaken in tuned pybullet, lay 90 mm from its place and still moved
    at 794 mm/s when the run ended: the cell read 'INCONCLUSIVE stands'. No collapse was decided,
    and none could be: the cell says so."""
    from stackdsl.cli.check import _cell
    from stackdsl.verdicts.check_result import CheckResult
    from stackdsl.verdicts.expect import Verdict

    undecided = Verdict(
        name="stands", passed=False, expected="stands", measured="undecided: 7 bricks still move", inconclusive=True
    )
    r = CheckResult("a.yaml", "a", "tuned", "report", (undecided,), None, 3, 8.0, 1.0)
    assert r.verdict == "INCONCLUSIVE" and _cell(r) == "undecided: still moving at the end"
    held = Verdict(name="stands", passed=True, expected="stands", measured="stands")
    assert _cell(CheckResult("a.yaml", "a", "tuned", "report", (held,), None, 3, 8.0, 1.0)) == "stands"


def test_compare_says_under_its_table_how_to_let_a_timed_out_cell_finish(tmp_path, capsys):
    """A cell its --timeout stopped shows 'FAIL timeout' and fails compare (exit 1, as check fails
    a run that did not finish); a new user read it as an expectation that failed. Under the
    table it now says what stopped it, that nothing was judged, and that a longer --timeout lets
    it finish. The cell is tuned pybullet on 12 levels, 1.5 to 3 s of work: raw pybullet's 8
    levels, 0.3 s since the collapse monitor works in floats, could finish within the budget."""
    slow = "stackdsl: 1\nstructure: {tower: {levels: 12, bricks_per_layer: 1, turn: 0}}\nexpect: {stands: true}\n"
    folder = write(tmp_path, slow=slow)
    assert main(["compare", str(folder), "--modes", "tuned", "-j", "1", "--timeout", "0.3"]) == 1
    out = capsys.readouterr().out
    assert "FAIL timeout" in out and "slow pybullet tuned: timeout after 0.3 s at t = " in out, out
    assert "nothing was judged: a longer --timeout lets it finish" in " ".join(out.split()), out


def test_a_folder_with_a_bad_file_runs_none_and_says_so_last(tmp_path, capsys):
    """check DIR reads every file before it runs any: with one bad file none runs (exit 2), each
    bad file's error is said, and a last line says how many were refused and that none ran (a
    new user saw four errors and wondered where the three good files' results were)."""
    (tmp_path / "good.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: 2}}\n")
    (tmp_path / "bad.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: 0}}\n")
    (tmp_path / "also_good.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: 1}}\n")
    assert main(["check", str(tmp_path)]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert lines[0].startswith(f"{tmp_path / 'bad.yaml'}:2:")
    assert lines[-1] == "1 of 3 files refused; none was run (check the good ones by name to run them)"
    assert "passed" not in captured.out
    # --json the same: no results, so no document (as no JUnit file or report), the errors on stderr
    assert main(["check", str(tmp_path), "--json"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.strip().splitlines()[-1].startswith("1 of 3 files refused; none was run")


def test_a_missing_file_for_render_or_replay_says_so_in_the_oss_words(tmp_path, capsys):
    """'[Errno 2] No such file or directory: ...' and 'not a readable golden snapshot' for a file
    that is not there: both now start '<path>: No such file or directory', exit 2."""
    missing = tmp_path / "nothing.npz"
    assert main(["render", str(missing), "-o", str(tmp_path / "x.png")]) == 2
    assert capsys.readouterr().err.strip() == f"{missing}: No such file or directory"
    golden = tmp_path / "nothing.json"
    assert main(["replay", "scenarios/vee_stands.yaml", "-o", str(tmp_path / "r"), "--golden", str(golden)]) == 2
    assert capsys.readouterr().err.strip() == f"{golden}: No such file or directory: no golden snapshot to show beside the run"


def test_run_and_compare_say_why_a_chain_cut_off_by_the_runs_end_failed(tmp_path, capsys):
    """check says 'still moving ... a longer timing.settle' under a domino chain the run's end
    cut off; run printed only the FAIL line and compare only its cell."""
    from stackdsl.cli.main import main

    scene = tmp_path / "row.yaml"
    scene.write_text(
        "stackdsl: 1\nstructure: {dominoes: {count: 12, spacing: 60 mm}}\ntiming: {interval: 0.05 s, settle: 0.3 s}\n"
        "actions:\n  - push: {target: {brick: D01, offset: [0, 0, 45 mm]}, direction: [1, 0, 0], speed: 0.2 m/s,"
        " distance: 15 mm, at: after level 1}\nexpect: {toppled: all}\n"
    )
    assert main(["run", str(scene)]) == 1
    out = capsys.readouterr().out
    assert "expect.toppled: expected all toppled" in out and "still moving: the run ended at" in out
    assert main(["compare", str(tmp_path), "--modes", "extension", "-j", "1"]) == 1
    out = capsys.readouterr().out
    assert "row pybullet extension: still moving: the run ended at" in out


def test_a_broken_link_in_a_folder_is_an_error_not_skipped(tmp_path, capsys):
    """A folder's broken links and link loops named *.yaml were passed over (exit 0); given by
    name they were refused. Both are refused now, each named."""
    write(tmp_path, a=PASSING)
    (tmp_path / "gone.yaml").symlink_to(tmp_path / "missing.yaml")
    (tmp_path / "loop.yaml").symlink_to("loop.yaml")
    assert main(["check", str(tmp_path), "-j", "1"]) == 2
    err = capsys.readouterr().err
    assert "gone.yaml: a broken symbolic link" in err and "loop.yaml: cannot read the file" in err, err


@pytest.mark.slow
@pytest.mark.parametrize("seed", ["\uff15", "\u0665", "5.0", "-1", "9" * 41])
def test_a_seed_is_written_in_the_digits_0_to_9(tmp_path, capsys, seed):
    """int() reads fullwidth and Arabic-Indic digits ('５' was taken as 5), which a file's seed may not have."""
    with pytest.raises(SystemExit) as exit_:
        main(["check", str(write(tmp_path, a=PASSING)), "--seed", seed])
    assert exit_.value.code == 2
    assert "--seed" in capsys.readouterr().err


def test_check_takes_one_path_as_well_as_a_list(tmp_path):
    """stackdsl.check('a.yaml') went through the text letter by letter ('a: no such file')."""
    file = write(tmp_path, a=PASSING) / "a.yaml"
    for given in (str(file), file, [file]):
        results = list(_check.check(given, jobs=1))
        assert [r.file for r in results] == [str(file)], results


def test_the_check_function_yields_a_result_for_a_file_an_internal_error_met(tmp_path, monkeypatch):
    from stackdsl import check

    folder = write(tmp_path, a=PASSING, b=PASSING)
    monkeypatch.setattr(_check, "compile_scenario", _broken_for(_check, "compile_scenario", "b"))
    results = {Path(r.file).stem: r for r in check(folder, jobs=1)}
    assert results["a"].passed and not results["b"].passed
    assert results["b"].error == "internal error: KeyError: 'wheels'" and "Traceback" in results["b"].traceback
    assert [r.file for r in check(folder, jobs=1, pattern="a.yaml")] == [
        results["a"].file
    ]  # -k leaves it out as it does its runs


def test_a_file_named_twice_runs_once(tmp_path, capsys, monkeypatch):
    write(tmp_path, a=PASSING)
    (tmp_path / "d").mkdir()
    write(tmp_path / "d", b=PASSING)
    (tmp_path / "link.yaml").symlink_to("a.yaml")
    monkeypatch.chdir(tmp_path)
    assert main(["check", "a.yaml", "./a.yaml", "link.yaml", "d", "d/b.yaml", "d/../d/b.yaml", "-j", "1", "--json"]) == 0
    results = json.loads(capsys.readouterr().out)["results"]
    assert [r["file"] for r in results] == ["a.yaml", "d/b.yaml"]


def test_an_empty_folder_says_which_files_a_folder_is_searched_for(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("")
    assert main(["check", str(tmp_path)]) == 2
    assert capsys.readouterr().err.strip() == f"{tmp_path}: no scenario files (*.yaml, *.yml) in this folder"
    (tmp_path / "a.yml").write_text(PASSING)
    assert main(["check", str(tmp_path), "-j", "1"]) == 0  # as it says: *.yml is read too
    assert "a.yml" in capsys.readouterr().out


@pytest.mark.parametrize("command", ["check", "run", "compile", "compare"])
def test_a_trajectory_given_as_a_scenario_is_named_so(command, tmp_path, capsys):
    import numpy as np

    trajectory = tmp_path / "tr.npz"
    np.savez(trajectory, times=np.zeros(3))  # a zip archive, as a trajectory file is
    assert main([command, str(trajectory)]) == 2
    assert capsys.readouterr().err.strip() == (
        f"{trajectory}: this is a trajectory file (.npz), not a scenario: "
        "stackdsl render, animate, graph, replay, view and export read it"
    )
    with trajectory.open("ab") as f:  # over the size a scenario may have: named by its name alone
        f.truncate(2 << 20)
    assert main([command, str(trajectory)]) == 2
    assert "this is a trajectory file (.npz), not a scenario" in capsys.readouterr().err
    named = tmp_path / "tr.yaml"
    named.write_bytes(trajectory.read_bytes()[:1000])  # misnamed: named by its first bytes
    assert main([command, str(named)]) == 2
    assert "this is a zip archive, not a scenario" in capsys.readouterr().err


def test_the_measured_column_says_each_fact_once():
    """A failed 'stays: 1-12' measured "levels 4-8 moved; levels 10-12 never placed", and the
    row said "levels 4-8 moved, levels 4-8 moved; levels 10-12 never placed"."""
    from stackdsl.verdicts.check_result import CheckResult
    from stackdsl.verdicts.expect import Verdict

    stays = Verdict(
        name="stays", passed=False, expected="levels 1-12 stay", measured="levels 4-8 moved; levels 10-12 never placed"
    )
    r = CheckResult(
        "a.yaml",
        "a",
        "raw",
        "report",
        (stays,),
        9,
        9,
        1.0,
        0.1,
        first_moved="L06.2",
        first_moved_level=6,
        moved_levels=(4, 5, 6, 7, 8),
    )
    assert r.measured == "collapse 9 from L06.2 (level 6), levels 4-8 moved, levels 10-12 never placed"


def test_the_measured_column_names_levels_moved_once():
    """'stays: 1-8' measured "levels 3-8 moved" of a run whose description says "levels 3-9
    moved": the row said both."""
    from stackdsl.verdicts.check_result import CheckResult
    from stackdsl.verdicts.expect import Verdict

    stays = Verdict(name="stays", passed=False, expected="levels 1-8 stay", measured="levels 3-8 moved")
    moved = Verdict(name="moved", passed=True, expected="level 3 moved", measured="level 3 moved")
    r = CheckResult(
        "a.yaml",
        "a",
        "raw",
        "report",
        (stays, moved),
        9,
        9,
        1.0,
        0.1,
        first_moved="L09.1",
        first_moved_level=9,
        moved_levels=tuple(range(3, 10)),
    )
    assert r.measured == "collapse 9 from L09.1 (level 9), levels 3-9 moved"
    other = Verdict(name="stays", passed=False, expected="levels 1-12 stay", measured="levels 2, 4 moved")  # not all said
    r = CheckResult(
        "a.yaml", "a", "raw", "report", (other,), 9, 9, 1.0, 0.1, first_moved="L04.1", first_moved_level=4, moved_levels=(4,)
    )
    assert r.measured.endswith("level 4 moved, levels 2, 4 moved")


def test_every_shipped_scenario_whose_run_raises_is_its_own_row_and_the_check_goes_on(tmp_path, capsys, monkeypatch):
    """An engine that fails every run (MuJoCo 3.3.7 without sleeping did) costs each run its row,
    never the check: a result without an outcome once read ``levels_placed`` of an empty one, so
    the 14th row (the first whose file expects ``stays``) took the whole check down."""

    def broken(*args, **kwargs):
        raise AttributeError("type object 'mjtEnableBit' has no attribute 'mjENBL_SLEEP'")

    monkeypatch.setattr(_judge, "run_program", broken)
    monkeypatch.delenv("STACKDSL_TRACEBACK", raising=False)
    shipped = Path(__file__).parent.parent / "scenarios"
    files = sorted(p.relative_to(shipped).as_posix() for p in shipped.rglob("*.yaml"))
    assert main(["check", str(shipped), "-j", "1"]) == 3
    captured = capsys.readouterr()
    rows = [line for line in captured.out.splitlines() if line[:4] in ("PASS", "FAIL")]
    assert len(rows) == len(files) and all(row.startswith("FAIL") and row.endswith("'mjENBL_SLEEP'") for row in rows)
    assert f"{len(files)} scenarios: 0 passed, {len(files)} failed ({len(files)} of them internal errors)" in captured.out
    (line,) = captured.err.splitlines()
    assert line.startswith("stackdsl: internal error: AttributeError: ") and f"(and {len(files) - 1} more)" in line
    assert main(["check", str(shipped), "-j", "1", "--json"]) == 3
    results = json.loads(capsys.readouterr().out)["results"]
    assert sorted(Path(r["file"]).relative_to(shipped).as_posix() for r in results) == files
    assert all(r["error"].startswith("internal error: AttributeError") and r["verdicts"] for r in results)
    # compare: every cell of every file, those expecting `stays` and `moved` among them
    hard = shipped / "hard"
    assert main(["compare", str(hard), "-j", "1", "--modes", "raw,extension"]) == 3
    out = capsys.readouterr().out.splitlines()
    cells = [line for line in out if "FAIL internal error" in line or "refused (why: below the table)" in line]
    assert len(cells) == 2 * len(list(hard.glob("*.yaml"))) and not any("PASS" in line for line in out)  # a row a cell
    # sweep: every sample's run raises, every cell is still reported
    monkeypatch.setattr(_sweep, "run_program", broken)
    folder = write(tmp_path, s=SWEEP)
    assert main(["sweep", str(folder / "s.yaml"), "-j", "1", "--out", str(tmp_path / "out")]) == 3
    out = capsys.readouterr().out
    assert out.count("did not finish: internal error: AttributeError") == 2 and "cell 1: " in out


@pytest.mark.parametrize("odd", ["\n", "\r", "\t", "\x1b", "\u2028", "\x85"])
def test_a_control_character_in_a_path_is_escaped_so_each_error_stays_one_line(odd, tmp_path, capsys, monkeypatch):
    # a newline in a path was printed raw: the one-line error spanned two
    monkeypatch.chdir(tmp_path)
    folder = f"d{odd}ir"
    (tmp_path / folder).mkdir()
    (tmp_path / folder / "t.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: -2}}\n")
    escaped = repr(odd)[1:-1]
    assert main(["check", f"{folder}/t.yaml"]) == 2
    head = capsys.readouterr().err.splitlines()[0]
    assert head.startswith(f"d{escaped}ir/t.yaml:2:29: structure.tower.levels:")
    assert main(["check", f"{folder}/missing.yaml"]) == 2
    looked = f"looked for in {tmp_path}"  # a relative path: the folder it was looked for in
    assert capsys.readouterr().err.strip() == f"d{escaped}ir/missing.yaml: no such file or folder ({looked})"
    assert main(["render", f"{folder}/t.yaml", "-o", f"no{odd}where/a.png"]) == 2
    assert f"no{escaped}where/a.png" in capsys.readouterr().err


def test_a_check_of_a_folder_starts_its_workers_before_it_loads(monkeypatch, tmp_path):
    """``stackdsl check`` of a folder, or of two files or more, with more than one job starts
    its workers first (stackdsl._entry.spare_workers), and decides ``-j auto`` once; one file,
    one job or another command starts none and keeps its arguments."""
    from stackdsl.batch import address, pool

    started: list[int] = []
    monkeypatch.setattr(pool, "start_spares", lambda count, load: started.append(count))
    monkeypatch.setattr(address, "free_cores", lambda: 2)
    monkeypatch.setattr(address, "cores", lambda: 2)
    folder = str(tmp_path)
    cases = [
        (["check", folder], ["check", "--jobs", "2", folder], [1]),
        (["--debug", "check", "-j", "auto", folder], ["--debug", "check", "--jobs", "2", folder], [1]),
        (["check", "-j2", "a.yaml", "b.yml"], ["check", "-j2", "a.yaml", "b.yml"], [1]),
        (["check", "--jobs=8", folder], ["check", "--jobs=8", folder], []),  # more than the cores: refused, nothing started
        (["check", "a.yaml"], ["check", "a.yaml"], []),
        (["check", "-j", "2", "--report", folder, "a.yaml"], ["check", "-j", "2", "--report", folder, "a.yaml"], []),
        (["check", "--json", folder], ["check", "--jobs", "2", "--json", folder], [1]),
        (["check", "-j", "1", folder], ["check", "-j", "1", folder], []),
        (["run", folder], ["run", folder], []),
    ]
    for args, expected, spares in cases:
        started.clear()
        assert _entry.spare_workers(list(args)) == expected, args
        assert started == spares, args


def test_every_command_and_subcommand_help_opens_with_what_it_does(capsys):
    from stackdsl.cli.main import _parser

    def commands(parser, path):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, command in action.choices.items():
                    yield [*path, name], command
                    yield from commands(command, [*path, name])

    found = list(commands(_parser(), []))
    assert {"run", "check"} <= {p[0] for p, _ in found} and ["bench", "folder"] in [p for p, _ in found]
    assert [p for p, command in found if not command.description] == []
    with pytest.raises(SystemExit):
        main(["bench", "folder", "--help"])
    assert "with -j 1 and -j auto" in capsys.readouterr().out.split("positional arguments")[0]


@pytest.mark.parametrize("command", ["check", "compare"])
def test_an_empty_path_is_refused_not_read_as_the_current_folder(command, tmp_path, monkeypatch, capsys):
    # Path("") is "."; an unset $DIR in a script ran every scenario of the folder it was in
    write(tmp_path, a=PASSING)
    monkeypatch.chdir(tmp_path)
    assert main([command, ""]) == 2
    captured = capsys.readouterr()
    assert captured.err.splitlines()[0] == "'': an empty path: give a scenario file or a folder"
    assert "a.yaml" not in captured.out


@pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning")
@pytest.mark.parametrize("value", ["1e10", "inf", "1e400"])
def test_a_huge_progress_interval_is_capped_not_a_traceback(value, tmp_path, monkeypatch, capsys):
    # the progress thread's wait overflowed (OverflowError: timestamp out of range), a traceback
    from stackdsl.cli.progress import LONGEST, progress_seconds

    monkeypatch.setenv("STACKDSL_PROGRESS_SECONDS", value)
    assert progress_seconds() == LONGEST
    assert main(["check", "-j", "1", str(write(tmp_path, a=PASSING) / "a.yaml")]) == 0
    assert "Traceback" not in capsys.readouterr().err


def test_compares_cell_says_how_far_a_standing_brick_moved_from_1_mm():
    """A new user could not tell from compare's table a pull that dragged the top level 7.1 mm,
    0.4 mm under its threshold, from one that moved nothing: a stand's cell now says its
    largest move from 1 mm on."""
    from stackdsl.cli.check import _cell
    from stackdsl.verdicts.check_result import CheckResult, Verdict

    held = Verdict(name="stands", passed=True, expected="stands", measured="stands")

    def cell(drift: float, level: int | None = None) -> str:
        return _cell(
            CheckResult(
                file="t.yaml",
                scenario="t",
                mode="extension",
                model="report",
                verdicts=(held,),
                collapse_level=level,
                levels_placed=10,
                simulated_time=5.0,
                wall_time=1.0,
                drift=drift,
            )
        )

    assert cell(0.00708) == "stands, moved 7.1 mm at most"
    assert cell(0.0009) == "stands"
    assert cell(0.00708, 10) == "collapse 10"  # a collapse's drift is of the bricks that stood: not said

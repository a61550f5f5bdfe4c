"""pytest's habits in stackdsl: a scenario's ``skip`` and ``xfail`` marks (the language, check,
compare, the HTML report, JUnit XML, pytest), and an undecided sweep as INCONCLUSIVE."""

import json
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import pint  # noqa: F401  (imported before pytester's in-process runs: see test_pytest_plugin.py)
import pytest

from stackdsl import ScenarioError, parse_scenario
from stackdsl.batch.htmlreport import write_report
from stackdsl.batch.report import failure_lines, junit_xml, row, summary
from stackdsl.cli.main import main
from stackdsl.lang.jsonschema import json_schema
from stackdsl.lang.schema_marks import condition_holds
from stackdsl.verdicts.check_result import CheckResult
from stackdsl.verdicts.expect import Verdict

pytest_plugins = ["pytester"]

# one level, a short settle: a run of a few hundredths of a second
STANDS = "stackdsl: 1\nstructure: {tower: {levels: 1}}\ntiming: {settle: 0.2 s}\nexpect: {stands: true}\n"
WRONG = STANDS.replace("{stands: true}", "{collapse: 1}")


def write(folder: Path, **files: str) -> Path:
    for name, text in files.items():
        (folder / f"{name}.yaml").write_text(text)
    return folder


# the language --------------------------------------------------------------------------------


def refusal(text: str) -> str:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(STANDS + text, "s.yaml")
    return str(info.value).splitlines()[0]


def test_marks_read_with_a_reason_and_a_condition_on_the_run():
    s = parse_scenario(
        STANDS + "skip: {reason: not here, when: backend == mujoco}\nxfail: {reason: raw drops it, strict: true}\n"
    )
    assert (s.skip.reason, s.skip.when, s.xfail.reason, s.xfail.when, s.xfail.strict) == (
        "not here",
        "backend == mujoco",
        "raw drops it",
        None,
        True,
    )
    assert s.skip.applies("mujoco", "extension", "report") and not s.skip.applies("pybullet", "extension", "report")
    assert s.xfail.applies("pybullet", "raw", "equilibrium")  # no condition: every run
    assert parse_scenario(s.to_yaml()) == s


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("skip:", "s.yaml:5:6: skip: no value: give {reason: 'why'}"),
        ("skip: true", "s.yaml:5:7: skip: give a reason, and a condition if the mark is for some runs only"),
        ("skip: {when: mode == raw}", "s.yaml:5:7: skip.reason: required field is missing"),
        ('xfail: {reason: "a\\nb"}', "s.yaml:5:17: xfail.reason: a reason is one line of text"),
        ("xfail: {reason: x, strict: 2}", "s.yaml:5:28: xfail.strict:"),
        ("skip: {reason: x, why: y}", "s.yaml:5:19: skip.why: unknown key 'why'"),
        ("skip: {reason: x, when: backend == raw}", "s.yaml:5:25: skip.when: 'raw' is a mode, not a backend"),
        ("skip: {reason: x, when: engine == mujoco}", "s.yaml:5:25: skip.when: 'engine' is not a word a mark's"),
        ("skip: {reason: x, when: mode < raw}", "s.yaml:5:25: skip.when: compares with '<'"),
        ("skip: {reason: x, when: mode == 2}", "s.yaml:5:25: skip.when: a mark's condition compares words, not numbers"),
        ("xfail: {reason: x, when: mode == model}", "s.yaml:5:26: xfail.when: compares mode with model"),
        ("xfail: {reason: x, when: mode == raw and}", "s.yaml:5:26: xfail.when: at character 16"),
    ],
)
def test_a_bad_mark_is_refused_at_its_field(text, said):
    assert refusal(text).startswith(said)


def test_the_schema_takes_the_marks_as_the_loader_does():
    import jsonschema
    import yaml

    validator = jsonschema.Draft202012Validator(json_schema())
    base = yaml.safe_load(STANDS)
    good = [{"skip": {"reason": "x", "when": "backend == mujoco"}}, {"xfail": {"reason": "x", "strict": False}}]
    bad = [{"skip": None}, {"skip": True}, {"skip": {}}, {"xfail": {"reason": "a\nb"}}, {"xfail": {"reason": " "}}]
    bad += [{"skip": {"reason": "x", "strict": True}}, {"xfail": {"reason": "x", "strict": "yes please"}}]
    for extra in good:
        assert validator.is_valid({**base, **extra}), extra
        parse_scenario(yaml.safe_dump({**base, **extra}))
    for extra in bad:
        assert not validator.is_valid({**base, **extra}), extra
        with pytest.raises(ScenarioError):
            parse_scenario(yaml.safe_dump({**base, **extra}))


@pytest.mark.parametrize(
    ("when", "runs"),
    [
        ("backend == mujoco", {("mujoco", m, e) for m in ("raw", "extension") for e in ("report", "equilibrium")}),
        ("mode != extension and not model == equilibrium", {("pybullet", "raw", "report"), ("mujoco", "raw", "report")}),
        ("(mode == raw or mode == tuned) and backend == pybullet", {("pybullet", "raw", e) for e in ("report", "equilibrium")}),
    ],
)
def test_a_condition_holds_on_the_runs_it_names(when, runs):
    every = {(b, m, e) for b in ("pybullet", "mujoco") for m in ("raw", "extension") for e in ("report", "equilibrium")}
    assert {run for run in every if condition_holds(when, *run)} == runs


# check ---------------------------------------------------------------------------------------


def test_check_skips_and_expects_failures_as_the_marks_say(tmp_path, capsys):
    folder = write(
        tmp_path,
        a_skipped=STANDS + "skip: {reason: not on this engine, when: backend == pybullet}\n",
        b_mujoco_only=STANDS + "skip: {reason: only on pybullet, when: backend == mujoco}\n",
        c_xfail=WRONG + "xfail: {reason: 'it stands, you know'}\n",
        d_xpass=STANDS + "xfail: {reason: it might fall}\n",
    )
    junit = tmp_path / "j.xml"
    assert main(["check", str(folder), "-j", "1", "--junit-xml", str(junit)]) == 0  # an xfail that fails is fine
    out = capsys.readouterr().out.splitlines()
    skipped = next(line for line in out if "a_skipped.yaml" in line)
    assert skipped.startswith("SKIP  ") and skipped.endswith("skipped: not on this engine")  # the reason on its row
    assert next(line for line in out if "b_mujoco_only.yaml" in line).startswith("PASS  ")
    assert next(line for line in out if "c_xfail.yaml" in line).startswith("XFAIL ")
    assert "      xfail: it stands, you know" in out
    assert next(line for line in out if "d_xpass.yaml" in line).startswith("XPASS ")
    assert out[-1].startswith("4 scenarios: 1 passed, 0 failed, 1 skipped, 1 xfailed, 1 xpassed")
    suite = ET.parse(junit).getroot().find("testsuite")
    assert (suite.get("tests"), suite.get("failures"), suite.get("skipped")) == ("4", "0", "2")
    cases = {Path(c.get("name")).stem: c for c in suite.iter("testcase")}
    assert cases["a_skipped"].find("skipped").attrib == {"type": "stackdsl.skip", "message": "not on this engine"}
    assert cases["c_xfail"].find("skipped").attrib == {"type": "stackdsl.xfail", "message": "it stands, you know"}
    assert list(cases["d_xpass"]) == [] and list(cases["b_mujoco_only"]) == []  # passed, as pytest writes an XPASS


# a 2 mm side: MuJoCo's bricks may be this thin, pybullet's not (the compiler refuses it there)
THIN = """stackdsl: 1
brick_types: {thin: {size: [20 mm, 2 mm, 2 mm]}}
structure: {bricks: [{at: [0, 0, 1 mm], brick: thin}]}
engine: {backend: mujoco}
"""


def test_a_skipped_run_is_not_compiled(tmp_path, capsys):
    from stackdsl import compile_scenario

    with pytest.raises(ScenarioError, match="below what pybullet simulates faithfully"):
        compile_scenario(parse_scenario(THIN), backend="pybullet")
    folder = write(tmp_path, thin=THIN + "skip: {reason: thinner than pybullet takes, when: backend == pybullet}\n")
    assert main(["check", str(folder), "-j", "1", "--backend", "pybullet", "--json"]) == 0
    (result,) = json.loads(capsys.readouterr().out)["results"]
    assert (result["verdict"], result["skipped"], result["backend"]) == ("SKIP", "thinner than pybullet takes", "pybullet")
    assert result["passed"] is False and result["wall_time"] == 0.0


def test_a_strict_xpass_fails_the_check(tmp_path, capsys):
    folder = write(tmp_path, strict=STANDS + "xfail: {reason: it might fall, strict: true}\n")
    assert main(["check", str(folder), "-j", "1", "--json"]) == 1
    doc = json.loads(capsys.readouterr().out)
    (strict,) = doc["results"]
    assert (strict["verdict"], strict["passed"], strict["xfail"]) == ("XPASS", True, {"reason": "it might fall", "strict": True})
    assert (doc["summary"]["failed"], doc["summary"]["xpassed"]) == (1, 0)


def test_compare_says_each_cells_mark(tmp_path, capsys):
    folder = write(tmp_path, raw_fails=WRONG + "xfail: {reason: raw is wrong here, when: mode == raw}\n")
    assert main(["compare", str(folder), "--modes", "raw,extension", "-j", "1"]) == 1  # extension fails, unmarked
    out = capsys.readouterr().out
    lines = out.splitlines()
    block = lines.index("raw_fails: collapse 1")  # compare's block of the scenario: a row a mode
    assert [line.split()[:4] for line in lines[block + 1 : block + 3]] == [
        ["pybullet", "raw", "XFAIL", "stands"],
        ["pybullet", "extension", "FAIL", "stands"],
    ]
    assert "raw_fails: XFAIL in raw: raw is wrong here" in out


# INCONCLUSIVE --------------------------------------------------------------------------------

# two samples that stand: P(stands) is 1, but its 95% interval [0.16, 1] cannot say it is >= 0.5
UNDECIDED = """stackdsl: 1
structure: {tower: {levels: 1}}
timing: {settle: 0.2 s, placement_error: {uniform: [0, 1 mm]}}
sweep: {samples: 2}
expect: {p_stands: ">= 0.5"}
"""


def test_an_undecided_sweep_is_inconclusive_not_fail_and_exits_1(tmp_path, capsys):
    folder = write(tmp_path, undecided=UNDECIDED)
    junit = tmp_path / "j.xml"
    assert main(["check", str(folder), "-j", "1", "--junit-xml", str(junit)]) == 1
    out = capsys.readouterr().out.splitlines()
    assert out[1].startswith("INCONCLUSIVE ") and "undecided.yaml" in out[1]
    assert out[-1].startswith("1 scenarios: 0 passed, 0 failed, 1 inconclusive")
    (failure,) = ET.parse(junit).getroot().iter("failure")
    assert failure.get("type") == "INCONCLUSIVE" and ": INCONCLUSIVE: expected P(stands) >= 0.5" in failure.get("message")
    # with an xfail mark, an undecided sweep is an expected failure
    (tmp_path / "undecided.yaml").write_text(UNDECIDED + "xfail: {reason: too few samples to decide}\n")
    assert main(["check", str(folder), "-j", "1"]) == 0
    assert capsys.readouterr().out.splitlines()[1].startswith("XFAIL ")


def result(**fields) -> CheckResult:
    base = {"file": "s.yaml", "scenario": "s", "mode": "extension", "model": "report", "verdicts": ()}
    return CheckResult(**{**base, "collapse_level": None, "levels_placed": 1, "simulated_time": 1.0, "wall_time": 0.1, **fields})


def test_each_verdict_and_whether_it_holds():
    passed = Verdict(name="stands", passed=True, expected="stands", measured="stands")
    failed = Verdict(name="stands", passed=False, expected="stands", measured="collapse 1")
    undecided = Verdict(name="statistic", passed=False, expected="P(stands) >= 0.5", measured="?", inconclusive=True)
    cases = [
        (result(verdicts=(passed,)), "PASS", True),
        (result(verdicts=(failed,)), "FAIL", False),
        (result(verdicts=(passed, undecided)), "INCONCLUSIVE", False),
        (result(verdicts=(failed, undecided)), "FAIL", False),
        (result(skipped="why"), "SKIP", True),
        (result(verdicts=(failed,), xfail="why"), "XFAIL", True),
        (result(verdicts=(undecided,), xfail="why"), "XFAIL", True),
        (result(verdicts=(passed,), xfail="why"), "XPASS", True),
        (result(verdicts=(passed,), xfail="why", strict=True), "XPASS", False),
        (result(verdicts=(passed,), xfail="why", stopped="timeout after 1 s"), "FAIL", False),
        (result(verdicts=(passed,), xfail="why", error="internal error: KeyError"), "FAIL", False),
    ]
    assert [(r.verdict, r.held) for r, _, _ in cases] == [(v, h) for _, v, h in cases]
    assert not result(skipped="why").passed  # nothing ran


def test_the_html_report_says_each_verdict_with_its_reason(tmp_path):
    undecided = Verdict(name="statistic", passed=False, expected="P(stands) >= 0.5", measured="?", inconclusive=True)
    results = [
        result(file="a.yaml", verdicts=(undecided,), sweep="P(stands) 1.00, n=2"),
        result(file="b.yaml", skipped="not on MuJoCo"),
        result(file="c.yaml", verdicts=(undecided,), xfail="too few samples", sweep="n=2"),
    ]
    page = write_report(results, tmp_path, total=3, wall=1.0, commands=["stackdsl sweep a.yaml"] * 3).read_text()
    assert '<span class="verdict inconclusive">INCONCLUSIVE</span>' in page and ">FAIL<" not in page
    assert '<span class="verdict skip">SKIP</span>' in page and "not on MuJoCo" in page
    assert '<span class="verdict xfail">XFAIL</span>' in page and "too few samples" in page
    assert page.index('id="failed"') < page.index('id="xfail"') < page.index('id="skipped"')
    assert "3 scenarios: 0 passed, 0 failed, 1 inconclusive, 1 skipped, 1 xfailed" in page


def test_an_expectation_longer_than_its_column_is_set_apart_from_the_measured_text():
    long = Verdict(name="collapse", passed=True, expected="collapse 3±1, brick L02.1 moved", measured="collapse 3")
    assert row(result(verdicts=(long,))).endswith("collapse 3±1, brick L02.1 moved | stands")
    short = Verdict(name="stands", passed=True, expected="stands", measured="stands")
    assert row(result(verdicts=(short,))).endswith("stands" + " " * 13 + "stands")


def test_rows_and_junit_of_marked_results(tmp_path):
    strict = result(verdicts=(Verdict(name="stands", passed=True, expected="stands", measured="stands"),), xfail="w", strict=True)
    assert row(strict).startswith("XPASS s.yaml")
    assert failure_lines(strict, "stackdsl run s.yaml")[0].strip().startswith("[XPASS(strict)] w: every expectation held")
    assert summary([strict], 1, 1.0).startswith("1 scenarios: 0 passed, 1 failed (")
    junit_xml([strict], ["stackdsl run s.yaml"], [], 1.0, tmp_path / "j.xml")
    (failure,) = ET.parse(tmp_path / "j.xml").getroot().iter("failure")
    assert (failure.get("type"), failure.get("message")) == ("XPASS", "[XPASS(strict)] w")
    assert replace(strict, strict=False).held


# pytest --------------------------------------------------------------------------------------


def test_pytest_skips_xfails_and_says_why_without_r(pytester, monkeypatch):
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)  # the inner run is no xdist worker
    pytester.makefile(".toml", pyproject="[tool.pytest.ini_options]\nstackdsl_paths = ['scenarios']\n")
    folder = pytester.mkdir("scenarios")
    write(
        folder,
        skipped=STANDS + "skip: {reason: not on pybullet, when: backend == pybullet}\n",
        xfailed=WRONG + "xfail: {reason: it stands}\n",
        xpassed=STANDS + "xfail: {reason: it may fall}\n",
        strict=STANDS + "xfail: {reason: it may fall, strict: true}\n",
        unmarked=STANDS + "xfail: {reason: raw only, when: mode == raw}\n",
    )
    result = pytester.runpytest("--snapshot-update", "-p", "no:cacheprovider", "--junit-xml=j.xml")
    result.assert_outcomes(passed=1, skipped=1, xfailed=1, xpassed=1, failed=1)
    out = result.stdout.str()
    summary_lines = out[out.index("scenarios skipped or expected to fail, and why") :].splitlines()
    assert "SKIPPED scenarios/skipped.yaml:5: not on pybullet" in summary_lines  # the file and line of its skip
    assert "XFAIL scenarios/xfailed.yaml::xfailed - it stands" in summary_lines
    assert "FAILED scenarios/strict.yaml::strict - [XPASS(strict)] it may fall" in out
    cases = {c.get("name"): c for c in ET.parse(pytester.path / "j.xml").getroot().iter("testcase")}
    assert cases["skipped"].find("skipped").get("type") == "pytest.skip"
    assert cases["xfailed"].find("skipped").attrib == {"type": "pytest.xfail", "message": "it stands"}
    goldens = sorted(p.stem for p in (pytester.path / "golden" / "scenarios").glob("*.json"))
    assert goldens == ["strict", "unmarked", "xpassed"]  # none for what was skipped or failed
    # -rs: pytest says the skip itself, once
    again = pytester.runpytest("-p", "no:cacheprovider", "-rs", "scenarios/skipped.yaml").stdout.str()
    assert "SKIPPED [1] scenarios/skipped.yaml:5: not on pybullet" in again and "and why" not in again

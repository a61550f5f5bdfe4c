"""pytest's habits in stackdsl: a scenario's ``skip`` and ``xfail`` marks."""

from pathlib import Path

import pint  # noqa: F401  (imported before pytester's in-process runs: see test_pytest_plugin.py)
import pytest

from stackdsl import ScenarioError, parse_scenario
from stackdsl.lang.jsonschema import json_schema
from stackdsl.lang.schema_marks import condition_holds

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

"""Scenario files as pytest items: collection, expectations, golden snapshots, pytest's own flags.

Each test builds a small project of its own (pyproject.toml, scenarios/, golden/) and runs
pytest in it, as a user would.
"""

import importlib.util
import json
import os
import re
import shlex
import stat
import xml.etree.ElementTree as ET

# pint (stackdsl reads units with it) imports importlib_metadata and toolz, which put finders on
# sys.meta_path. Imported for the first time inside one of pytester's in-process runs, they are
# unloaded after it while their finders stay, and the next run can read no package's metadata
# (PackageNotFoundError: pluggy). Imported here, they stay loaded for every run.
import pint  # noqa: F401
import pytest

pytest_plugins = ["pytester"]

TWO_BRICKS = """\
stackdsl: 1
structure:
  bricks:
    - {{id: base, at: [0, 0, 4 mm]}}
    - {{id: top, at: [{x}, 0, 12 mm], yaw: 90}}
timing: {{settle: 0.5 s}}
expect: {{stands: true}}
"""
TOWER = "stackdsl: 1\nstructure: {tower: {levels: 2}}\ntiming: {settle: 0.5 s}\nexpect: {stands: true}\n"


@pytest.fixture
def project(pytester, monkeypatch):
    # the inner run is not an xdist worker even when this one is (``pytest -n 2``): syrupy reads
    # the variable and would leave its report to a controller that the inner run does not have
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)
    pytester.makefile(".toml", pyproject="[tool.pytest.ini_options]\nstackdsl_paths = ['scenarios']\n")
    pytester.mkdir("scenarios")
    return pytester


def write(pytester, name: str, text: str) -> None:
    (pytester.path / "scenarios" / f"{name}.yaml").write_text(text)


def test_each_scenario_file_is_one_item_named_after_it(project):
    write(project, "two", TWO_BRICKS.format(x="0 mm"))
    write(project, "tower", TOWER)
    (project.path / "notes.yaml").write_text("not: a scenario\n")  # outside the scenario folders
    result = project.runpytest("--collect-only", "-q")
    assert sorted(line for line in result.outlines if "::" in line) == [
        "scenarios/tower.yaml::tower",
        "scenarios/two.yaml::two",
    ]


def test_k_matches_a_scenarios_name_and_its_path_as_check_does(project):
    # a new user's -k tips (of "name: my overhang that tips") and -k scenarios/tower deselected
    # everything: pytest matched the file's stem alone
    write(project, "over", "stackdsl: 1\nname: 'my overhang that tips'\n" + TOWER.split("\n", 1)[1])
    write(project, "tower", TOWER)
    picked = {
        k: sorted(line.split("::")[1] for line in project.runpytest("--collect-only", "-q", "-k", k).outlines if "::" in line)
        for k in ("tips", "scenarios/tow", "my and not tower", "tower")
    }
    assert picked == {"tips": ["over"], "scenarios/tow": ["tower"], "my and not tower": ["over"], "tower": ["tower"]}


def test_golden_written_on_update_then_matched(project):
    write(project, "two", TWO_BRICKS.format(x="0 mm"))
    project.runpytest("--snapshot-update").assert_outcomes(passed=1)
    stored = project.path / "golden" / "scenarios" / "two.json"
    data = json.loads(stored.read_text())
    assert set(data["final_graph"]) == {"base", "top"}
    assert data["final_graph"]["top"]["rests_on"] == {"base": pytest.approx(data["final_graph"]["top"]["rests_on"]["base"])}
    assert [line.strip()[:7] for line in stored.read_text().splitlines() if '"state"' in line] == ['"base":', '"top": ']
    project.runpytest().assert_outcomes(passed=1)


def test_a_moved_brick_is_named_in_the_failure(project):
    write(project, "two", TWO_BRICKS.format(x="0 mm"))
    project.runpytest("--snapshot-update").assert_outcomes(passed=1)
    write(project, "two", TWO_BRICKS.format(x="5 mm"))
    result = project.runpytest()
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    said = out[out.index("outside tolerance, worst first (stored -> this run):") :].splitlines()
    assert said[1] == "  final_graph top: moved by 5.0 mm in x (tolerance 1 mm), its centre of mass above with it"
    assert said[2].startswith("  final_graph base: centre of mass above moved by 2.5 mm in x")  # the load on it moved
    assert said[3].startswith("tolerances: position 1 mm, angle 0.955 deg")
    assert "\x1b[" not in out  # plain text, also in JUnit XML
    assert "the snapshot's diff:" not in out  # only what is outside its tolerance


def test_within_tolerance_a_golden_matches_and_is_not_rewritten(project):
    """A golden whose positions differ from this run's by less than the tolerance matches, and
    --snapshot-update leaves it as it is; beyond the tolerance it fails, and the update rewrites it."""
    write(project, "two", TWO_BRICKS.format(x="0 mm"))
    project.runpytest("--snapshot-update").assert_outcomes(passed=1)
    stored = project.path / "golden" / "scenarios" / "two.json"
    data = json.loads(stored.read_text())
    data["final_graph"]["top"]["position_mm"][0] += 0.6  # as another machine might settle it
    data["final_graph"]["base"]["mass_above_g"] += 0.5
    nudged = json.dumps(data)
    stored.write_text(nudged)
    result = project.runpytest("--snapshot-update")
    result.assert_outcomes(passed=1)
    assert stored.read_text() == nudged
    data["final_graph"]["top"]["position_mm"][0] += 2.0
    stored.write_text(json.dumps(data))
    result = project.runpytest()
    result.assert_outcomes(failed=1)
    assert "final_graph top: moved by -2.6 mm in x (tolerance 1 mm)" in result.stdout.str()
    project.runpytest("--snapshot-update").assert_outcomes(passed=1)
    assert json.loads(stored.read_text())["final_graph"]["top"]["position_mm"][0] == pytest.approx(0.0, abs=0.1)


def test_a_project_and_a_scenario_widen_their_tolerances(project):
    write(project, "two", TWO_BRICKS.format(x="0 mm"))
    project.runpytest("--snapshot-update").assert_outcomes(passed=1)
    write(project, "two", TWO_BRICKS.format(x="3 mm"))
    project.runpytest().assert_outcomes(failed=1)
    pyproject = project.path / "pyproject.toml"
    pyproject.write_text(pyproject.read_text() + '\n[tool.stackdsl.golden.tolerance]\nposition = "4 mm"\n')
    project.runpytest().assert_outcomes(passed=1)
    write(project, "two", TWO_BRICKS.format(x="3 mm") + "golden: {tolerance: {position: 2 mm}}\n")
    result = project.runpytest()
    result.assert_outcomes(failed=1)  # the scenario's own, narrower, wins
    assert "(tolerance 2 mm)" in result.stdout.str()
    pyproject.write_text(pyproject.read_text().replace('"4 mm"', '"4 kg"'))
    result = project.runpytest()
    result.assert_outcomes(failed=1)
    assert "pyproject.toml: tool.stackdsl.golden.tolerance.position: expected a length" in result.stdout.str()


def test_a_golden_written_on_a_near_tie_says_so(project):
    write(project, "tie", TWO_BRICKS.format(x="59.5 mm").replace("yaw: 90", "yaw: 0"))
    result = project.runpytest("--snapshot-update")
    result.assert_outcomes(passed=1)
    out = result.stdout.str()
    assert "stackdsl: golden snapshots written on a near tie" in out
    said = "golden/scenarios/tie.json: stands with a margin of 0.{} mm, under pybullet's 1 mm contact margin"
    assert said.format(4) in out or said.format(5) in out, out  # 0.5 mm inside, rounded down
    result = project.runpytest()  # compared, not written: nothing to say
    assert "near tie" not in result.stdout.str()


def test_a_failed_expectation_fails_the_item_with_the_verdict(project):
    write(project, "tower", TOWER.replace("{stands: true}", "{collapse: 2}"))
    result = project.runpytest("--snapshot-update")
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    # at the line of the expectation, which it shows with a caret, as a parse error does
    assert "scenarios/tower.yaml:4:10: expect.collapse: expected collapse 2, measured stands" in out
    assert "    expect: {collapse: 2}\n             ^" in out
    assert "stackdsl run scenarios/tower.yaml" in result.stdout.str()
    assert not (project.path / "golden" / "scenarios" / "tower.json").exists()


def test_a_bad_file_fails_with_file_line_col_and_no_traceback(project):
    write(project, "bad", "stackdsl: 1\nstructure:\n  tower: {levles: 2}\n")
    result = project.runpytest()
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    assert "bad.yaml:3:11: structure.tower.levles: unknown key 'levles'; did you mean 'levels'?" in out
    assert "Traceback" not in out and "def _scenario_test" not in out
    failure = out[out.index("FAILURES") : out.index("short test summary")]  # (CI=true repeats it in the summary)
    assert failure.count("unknown key 'levles'") == 1  # once, with no exception chain
    assert "During handling" not in failure and str(project.path) not in failure  # named as the user wrote it


@pytest.mark.slow
def test_k_x_lf_and_junit_xml_work_on_scenario_items(project):
    write(project, "good", TOWER)
    write(project, "wrong", TOWER.replace("{stands: true}", "{collapse: 2}"))
    project.runpytest("--snapshot-update", "-k", "good").assert_outcomes(passed=1, deselected=1)
    project.runpytest("-x").assert_outcomes(passed=1, failed=1)  # good runs first, wrong stops the run
    project.runpytest("--lf").assert_outcomes(failed=1)  # only the failed one runs again
    project.runpytest("--junit-xml=report.xml")
    cases = ET.parse(project.path / "report.xml").getroot().iter("testcase")
    assert {c.get("name"): c.find("failure") is not None for c in cases} == {"good": False, "wrong": True}


def test_other_configured_folders_are_collected(pytester):
    pytester.makefile(".toml", pyproject="[tool.pytest.ini_options]\nstackdsl_paths = ['lab/stacks']\n")
    (pytester.path / "lab" / "stacks").mkdir(parents=True)
    (pytester.path / "scenarios").mkdir()
    (pytester.path / "lab" / "stacks" / "t.yaml").write_text(TOWER)
    (pytester.path / "scenarios" / "ignored.yaml").write_text(TOWER)
    result = pytester.runpytest("--snapshot-update")
    result.assert_outcomes(passed=1)
    assert (pytester.path / "golden" / "lab" / "stacks" / "t.json").is_file()


def test_a_project_that_names_no_folder_keeps_its_own_yaml_out(pytester, monkeypatch):
    """A project that merely has stackdsl installed, with a ``scenarios/`` folder of its own
    YAML: by default only files that say they are stackdsl's (``stackdsl:``) are collected; a
    folder the project names has every file collected (a broken scenario fails, not hides)."""
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)
    (pytester.path / "scenarios").mkdir()
    (pytester.path / "scenarios" / "config.yaml").write_text("a: 1\n")
    (pytester.path / "scenarios" / "tower.yaml").write_text("\ufeff" + TOWER)  # a byte-order mark too
    pytester.makepyfile(test_a="def test_a():\n    assert True\n")
    result = pytester.runpytest("--collect-only", "-q")
    assert sorted(line for line in result.outlines if "::" in line) == ["scenarios/tower.yaml::tower", "test_a.py::test_a"]
    named = pytester.runpytest("--collect-only", "-q", "-o", "stackdsl_paths=scenarios")
    assert "scenarios/config.yaml::config" in named.outlines


def test_without_syrupy_a_scenario_item_names_the_extra(project, monkeypatch):
    from stackdsl import pytest_plugin

    monkeypatch.setattr(pytest_plugin, "SnapshotAssertion", None)
    write(project, "tower", TOWER)
    result = project.runpytest("-p", "no:syrupy")  # as if it were not installed
    result.assert_outcomes(failed=1)
    assert any("pip install 'stackdsl[pytest]'" in line for line in result.outlines)
    assert not any("fixture 'snapshot' not found" in line for line in result.outlines)


@pytest.mark.slow
def test_xdist_runs_scenario_items(project):
    pytest.importorskip("xdist")
    for name in ("a", "b"):
        write(project, name, TOWER)
    project.runpytest("--snapshot-update").assert_outcomes(passed=2)
    project.runpytest("-n", "2").assert_outcomes(passed=2)


def test_a_golden_left_by_a_removed_scenario_is_named(project):
    write(project, "kept", TOWER)
    write(project, "gone", TOWER)
    project.runpytest("--snapshot-update").assert_outcomes(passed=2)
    (project.path / "scenarios" / "gone.yaml").unlink()
    result = project.runpytest()
    result.assert_outcomes(passed=1)
    assert "golden/scenarios/gone.json (its scenario file is gone" in result.stdout.str()
    assert "kept.json" not in result.stdout.str()


def test_the_golden_fixture_keeps_same_named_tests_of_two_files_apart(pytester):
    pytester.makefile(".toml", pyproject="[tool.pytest.ini_options]\n")
    for name, value in (("test_g", 1), ("test_h", 2)):
        pytester.makepyfile(**{name: f"def test_mine(golden):\n    assert golden == {{'value': {value}}}\n"})
    pytester.runpytest("--snapshot-update").assert_outcomes(passed=2)
    assert json.loads((pytester.path / "golden" / "test_g" / "test_mine.json").read_text()) == {"value": 1}
    assert json.loads((pytester.path / "golden" / "test_h" / "test_mine.json").read_text()) == {"value": 2}
    result = pytester.runpytest()
    result.assert_outcomes(passed=2)
    assert "Can not relate" not in result.stdout.str()


@pytest.mark.slow
def test_the_golden_fixture_says_what_changed_by_key_before_the_diff(pytester):
    pytester.makefile(".toml", pyproject="[tool.pytest.ini_options]\n")
    test = "def test_mine(golden):\n    assert golden == {'a': 1.0, 'b': {'c': [1, 2], 'd': %r}}\n"
    pytester.makepyfile(test_g=test % "x")
    pytester.runpytest("--snapshot-update").assert_outcomes(passed=1)
    pytester.makepyfile(test_g=test % "y")
    result = pytester.runpytest()
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    assert (
        "what changed (stored -> this run):" in out
        and 'b.d: "x" -> "y"' in out
        and "a:" not in out.split("the snapshot's diff")[0].split("what changed")[1]
    )


def test_an_interrupted_golden_update_leaves_the_old_file_whole(tmp_path, monkeypatch):
    from syrupy.data import Snapshot, SnapshotCollection

    from stackdsl.pytest_plugin import ScenarioSnapshotExtension

    stored = tmp_path / "golden" / "two.json"

    def update(text: str) -> None:
        collection = SnapshotCollection(location=str(stored))
        collection.add(Snapshot(name="two", data=text))
        ScenarioSnapshotExtension.write_snapshot_collection(snapshot_collection=collection)

    update("old\n")

    def killed(src, dst):  # the update fails between writing the new file and renaming it
        raise OSError("interrupted")

    monkeypatch.setattr("stackdsl.pytest_plugin._rename", killed)
    with pytest.raises(OSError):
        update("new\n")
    assert stored.read_text() == "old\n"  # the old snapshot, whole
    assert [p.name for p in stored.parent.iterdir()] == ["two.json"]  # no temporary file left
    monkeypatch.undo()
    update("new\n")
    assert stored.read_text() == "new\n"


@pytest.mark.slow
def test_a_failed_scenario_keeps_its_pictures_when_asked(project):
    write(project, "tower", TOWER.replace("{stands: true}", "{collapse: 2}"))
    write(project, "fine", TOWER)
    result = project.runpytest("--snapshot-update", "--stackdsl-pictures", "only-on-failure")
    result.assert_outcomes(failed=1, passed=1)
    kept = project.path / "test-results" / "scenarios-tower"
    assert (
        "pictures: test-results/scenarios-tower/ (trajectory.npz, picture.png, graph.png, clip.gif, replay.html)"
        in result.stdout.str()
    )
    assert sorted(p.name for p in kept.iterdir()) == ["clip.gif", "graph.png", "picture.png", "replay.html", "trajectory.npz"]
    assert all((kept / name).stat().st_size > 0 for name in ("clip.gif", "graph.png", "picture.png", "replay.html"))
    assert not (project.path / "test-results" / "scenarios-fine").exists()  # it passed


@pytest.mark.slow
def test_pictures_for_every_scenario_and_none_by_default(project):
    write(project, "fine", TOWER)
    project.runpytest("--snapshot-update").assert_outcomes(passed=1)
    assert not (project.path / "test-results").exists()  # off: nothing recorded, nothing written
    write(project, "tower", TOWER.replace("{stands: true}", "{collapse: 2}"))
    result = project.runpytest("--stackdsl-pictures", "on", "--stackdsl-output", "seen")
    result.assert_outcomes(failed=1, passed=1)
    assert (project.path / "seen" / "scenarios-fine" / "picture.png").is_file()
    assert (project.path / "seen" / "scenarios-tower" / "picture.png").is_file()
    result = project.runpytest()
    assert "pictures:" not in result.stdout.str()


SWEEP = """\
stackdsl: 1
structure:
  tower:
    levels: 8
    bricks_per_layer: 1
    turn: 0
    shift: {{uniform: [-60 mm, 60 mm], per: layer}}
timing: {{settle: 0.2 s}}
sweep: {{samples: 12}}
expect:
  p_stands: '{bound}'
"""


@pytest.mark.slow
def test_a_sweep_file_is_one_item_decided_by_its_interval_with_every_sample_in_its_golden(project):
    write(project, "walk", SWEEP.format(bound="<= 0.95"))
    project.runpytest("--snapshot-update").assert_outcomes(passed=1)
    stored = json.loads((project.path / "golden" / "scenarios" / "walk.json").read_text())
    assert stored["samples"] == 12 and len(stored["cell 0"]["collapse_levels"]) == 12
    project.runpytest().assert_outcomes(passed=1)
    write(project, "walk", SWEEP.format(bound=">= 0.99"))  # far more stand than that can allow: FAIL
    result = project.runpytest()
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    assert (
        "scenarios/walk.yaml:11:3: expect.p_stands: FAIL: expected P(stands) >= 0.99" in out
        and "more: stackdsl sweep scenarios/walk.yaml" in out
    )
    write(project, "walk", SWEEP.format(bound="<= 0.95").replace("samples: 12}", "samples: 11}"))  # passes, other samples
    out = project.runpytest().stdout.str()
    assert "scenarios/walk.yaml: the samples differ from golden/scenarios/walk.json" in out


def test_a_golden_that_is_a_folder_fails_its_item_in_one_line(project):
    write(project, "tower", TOWER)
    (project.path / "golden" / "scenarios" / "tower.json").mkdir(parents=True)
    result = project.runpytest("-p", "no:cacheprovider")
    result.assert_outcomes(failed=1)
    text = result.stdout.str()
    assert "golden/scenarios/tower.json is a folder, not a golden snapshot: remove it" in text
    assert "Traceback" not in text and "IsADirectoryError" not in text


def test_an_output_folder_that_cannot_be_written_is_one_line_in_the_failure(project):
    write(project, "tower", TOWER.replace("expect: {stands: true}", "expect: {collapse: {level: 1}}"))
    result = project.runpytest("-p", "no:cacheprovider", "--stackdsl-pictures=only-on-failure", "--stackdsl-output=/dev/full")
    result.assert_outcomes(failed=1)
    text = result.stdout.str()
    assert "pictures: cannot write them to /dev/full" in text
    assert "Traceback" not in text and "NotADirectoryError" not in text and "FileExistsError" not in text


def test_pictures_on_that_cannot_be_written_fail_a_passing_item(project):
    # '--stackdsl-pictures on --stackdsl-output /dev/full' passed and silently wrote no pictures
    write(project, "tower", TOWER)
    project.runpytest("-p", "no:cacheprovider", "--snapshot-update").assert_outcomes(passed=1)
    result = project.runpytest("-p", "no:cacheprovider", "--stackdsl-pictures=on", "--stackdsl-output=/dev/full")
    result.assert_outcomes(failed=1)
    text = result.stdout.str()
    assert "pictures: cannot write them to /dev/full" in text and "Traceback" not in text


@pytest.mark.slow
def test_a_missing_golden_says_to_run_with_snapshot_update(project):
    write(project, "tower", TOWER)
    result = project.runpytest()
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    # the file as typed where pytest ran, as an expectation failure names it
    assert "scenarios/tower.yaml: no golden yet (golden/scenarios/tower.json): run with --snapshot-update to write it" in out
    assert re.search(r"write it \(pytest .*--snapshot-update\)", out)  # this run's command, with the option
    assert "differs" not in out
    project.runpytest("--snapshot-update-new-only").assert_outcomes(passed=1)  # writes it, as --snapshot-update does
    project.runpytest().assert_outcomes(passed=1)


def test_a_changed_golden_says_how_to_accept_the_change(project):
    write(project, "two", TWO_BRICKS.format(x="0 mm"))
    project.runpytest("--snapshot-update").assert_outcomes(passed=1)
    write(project, "two", TWO_BRICKS.format(x="5 mm"))
    result = project.runpytest()
    assert "scenarios/two.yaml: the outcome differs from golden/scenarios/two.json" in result.stdout.str()
    assert "if the change is meant: rerun with --snapshot-update" in result.stdout.str()


@pytest.mark.slow
def test_a_folder_outside_the_configured_ones_gets_a_collection_hint(project):
    (project.path / "mine").mkdir()
    (project.path / "mine" / "tower.yaml").write_text(TOWER)
    (project.path / "mine" / "notes.yaml").write_text("not: a scenario\n")  # not counted
    result = project.runpytest("mine/")
    assert result.ret == pytest.ExitCode.NO_TESTS_COLLECTED
    out = result.stdout.str()
    assert "mine/ holds 1 scenario file, and pytest collects them only below stackdsl_paths (now: scenarios)" in out
    assert "run: pytest mine/ -o stackdsl_paths=mine" in out
    (project.path / "mine" / "notes.yaml").unlink()  # it would be collected, and fail, as a scenario
    missing = project.runpytest("mine/", "-o", "stackdsl_paths=mine").stdout.str()
    assert re.search(r"\(pytest mine/ -o stackdsl_paths=mine .*--snapshot-update\)", missing)  # the whole command
    project.runpytest("mine/", "-o", "stackdsl_paths=mine", "--snapshot-update").assert_outcomes(passed=1)
    assert "not collected" not in project.runpytest("mine/", "-o", "stackdsl_paths=mine").stdout.str()


def test_no_collection_hint_when_the_scenarios_are_collected(project):
    write(project, "tower", TOWER)
    assert "not collected" not in project.runpytest("scenarios/", "--collect-only").stdout.str()


@pytest.mark.slow  # 3-5 s: in .ci/nightly's slow part
def test_no_collection_hint_for_a_folder_whose_tests_are_collected(project):
    (project.path / "checks").mkdir()
    (project.path / "checks" / "test_x.py").write_text("def test_x():\n    pass\n")
    (project.path / "checks" / "data.yaml").write_text(TOWER)  # a scenario file beside Python tests
    result = project.runpytest("checks/")
    result.assert_outcomes(passed=1)
    assert "not collected" not in result.stdout.str()
    if importlib.util.find_spec("xdist") is not None:  # the items are the workers'; their reports say where they ran
        result = project.runpytest("checks/", "-n", "2")
        result.assert_outcomes(passed=1)
        assert "not collected" not in result.stdout.str()


def suggested_run(result) -> list[str]:
    """The arguments of the command the collection hint suggests (``run: pytest ...``)."""
    (line,) = [x for x in result.outlines if x.startswith("run: pytest ")]
    return shlex.split(line.removeprefix("run: pytest "))


@pytest.mark.slow  # pytest runs of its own, 13-28 s: in .ci/nightly's slow part
def test_items_run_from_any_folder_and_the_hint_gives_a_command_that_works_there(pytester, monkeypatch):
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)
    (pytester.path / "elsewhere").mkdir()
    (pytester.path / "s").mkdir()
    (pytester.path / "s" / "t.yaml").write_text(TOWER)
    stored = pytester.path / "s" / "golden" / "t.json"  # no pyproject.toml above: beside the file
    cases = [("elsewhere", "../s"), ("elsewhere", str(pytester.path / "s")), ("s", ".")]
    for cwd, target in cases:
        monkeypatch.chdir(pytester.path / cwd)  # not the rootdir (but for "s", where it is)
        hint = pytester.runpytest("-p", "no:cacheprovider", target)
        assert hint.ret == pytest.ExitCode.NO_TESTS_COLLECTED
        args = suggested_run(hint)
        assert target in args
        pytester.runpytest("-p", "no:cacheprovider", *args, "--snapshot-update").assert_outcomes(passed=1)
        assert stored.is_file()
        result = pytester.runpytest("-p", "no:cacheprovider", *args)
        result.assert_outcomes(passed=1)
        assert "no such file" not in result.stdout.str()
        stored.unlink()
    monkeypatch.chdir(pytester.path / "elsewhere")
    (pytester.path / "s" / "t.yaml").write_text(TOWER.replace("{stands: true}", "{collapse: 2}"))
    (pytester.path / "s" / "bad.yaml").write_text("stackdsl: 1\nstructure:\n  tower: {levles: 2}\n")
    result = pytester.runpytest("-p", "no:cacheprovider", "../s", "-o", "stackdsl_paths=s")
    result.assert_outcomes(failed=2)
    out = result.stdout.str()  # each file named as the user types it from here
    assert "../s/bad.yaml:3:11: structure.tower.levles: unknown key 'levles'" in out
    assert "more: stackdsl run ../s/t.yaml" in out


@pytest.mark.slow  # pytest runs of its own, 13-28 s: in .ci/nightly's slow part
def test_a_failing_item_keeps_its_golden_through_snapshot_update(project):
    for name in ("two", "tower", "fine", "gone"):
        write(project, name, TWO_BRICKS.format(x="0 mm") if name == "two" else TOWER)
    project.runpytest("--snapshot-update").assert_outcomes(passed=4)
    folder = project.path / "golden" / "scenarios"
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    # the brick moved (the outcome differs from the golden) and the expectation fails
    write(project, "two", TWO_BRICKS.format(x="5 mm").replace("{stands: true}", "{collapse: 2}"))
    write(project, "tower", "stackdsl: 1\nstructure:\n  tower: {levles: 2}\n")  # a bad file
    for args in ([], ["--snapshot-update"], ["--snapshot-update", "-x"], ["--snapshot-update", "--ignore=scenarios/fine.yaml"]):
        result = project.runpytest(*args)
        out = result.stdout.str()
        assert result.parseoutcomes()["failed"] >= 1
        assert "unused" not in out and "Deleted" not in out, args
        assert {p.name: p.read_bytes() for p in folder.iterdir()} == before, args  # not deleted, not rewritten
    assert "golden/scenarios/two.json left as it was" in out
    # a golden whose scenario file is gone is the one that goes
    (project.path / "scenarios" / "gone.yaml").unlink()
    result = project.runpytest("--snapshot-update")
    assert "Deleted gone (golden/scenarios/gone.json)" in result.stdout.str()
    assert sorted(p.name for p in folder.iterdir()) == ["fine.json", "tower.json", "two.json"]


def test_a_crashed_item_keeps_its_golden_through_snapshot_update(project):
    write(project, "tower", TOWER)
    project.runpytest("--snapshot-update").assert_outcomes(passed=1)
    stored = project.path / "golden" / "scenarios" / "tower.json"
    text = stored.read_text()
    project.makeconftest(
        "import pytest\n"
        "@pytest.fixture(autouse=True)\n"
        "def crash(monkeypatch):\n"
        "    def run_program(program):\n"
        "        raise RuntimeError('a bug')\n"
        "    monkeypatch.setattr('stackdsl.pytest_plugin.run_program', run_program)\n"
    )
    result = project.runpytest("--snapshot-update")
    result.assert_outcomes(failed=1)
    assert "RuntimeError: a bug" in result.stdout.str() and "Deleted" not in result.stdout.str()
    assert stored.read_text() == text


@pytest.mark.slow  # pytest runs of its own, 13-28 s: in .ci/nightly's slow part
def test_failing_items_keep_their_goldens_under_xdist(project):
    pytest.importorskip("xdist")
    for name in ("a", "b", "c"):
        write(project, name, TOWER)
    project.runpytest("--snapshot-update").assert_outcomes(passed=3)
    folder = project.path / "golden" / "scenarios"
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    write(project, "a", TOWER.replace("{stands: true}", "{collapse: 2}"))
    write(project, "b", "stackdsl: 1\nstructure: {tower: {levles: 2}}\n")
    result = project.runpytest("-n", "2", "--snapshot-update")
    result.assert_outcomes(passed=1, failed=2)
    assert "Deleted" not in result.stdout.str()
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before


#: Goldens that cannot be snapshots, each under the scenario of that name, and what its failure says.
DAMAGED = {
    "bytes": (bytes(range(256)) * 8, "golden/scenarios/bytes.json is not a golden snapshot: not UTF-8 text (byte 0x80"),
    "deep": (b"[" * 100_000 + b"]" * 100_000, "golden/scenarios/deep.json is not a golden snapshot: JSON nested too deep"),
    "deeper": (b'{"a": ' + b"[" * 500 + b"]" * 500 + b"}", "golden/scenarios/deeper.json is not a golden snapshot: JSON nested"),
    "conflict": (
        b'{\n<<<<<<< HEAD\n  "scenario": "x"\n}\n',
        "golden/scenarios/conflict.json is not a golden snapshot: not JSON (line 2,",
    ),
    "array": (b"[]\n", "golden/scenarios/array.json is not a golden snapshot: its JSON is an array, not an object"),
    "fifo": (None, "golden/scenarios/fifo.json is a FIFO, not a golden snapshot: remove it"),
}


@pytest.mark.slow  # pytest runs of its own, 13-28 s: in .ci/nightly's slow part
def test_a_damaged_golden_fails_its_item_in_one_line_and_is_never_replaced(project):
    folder = project.path / "golden" / "scenarios"
    folder.mkdir(parents=True)
    for name, (data, _) in DAMAGED.items():
        write(project, name, TOWER)
        if data is None:
            os.mkfifo(folder / f"{name}.json")  # opened for reading, it would block until a writer comes
        else:
            (folder / f"{name}.json").write_bytes(data)
    (project.path / "scenarios" / "sub").mkdir()
    (project.path / "scenarios" / "sub" / "under.yaml").write_text(TOWER)
    (folder / "sub").write_text("a file where the folder of sub/'s goldens goes\n")
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    for args in ([], ["--snapshot-update"]):
        result = project.runpytest_subprocess("-p", "no:cacheprovider", "-n", "0", *args, timeout=120)
        result.assert_outcomes(failed=len(DAMAGED) + 1)
        out = result.stdout.str()
        for name, (_, said) in DAMAGED.items():
            (line,) = [x for x in result.outlines if x.startswith(f"scenarios/{name}.yaml: ")]  # one line, the file as typed
            assert said in line, (name, line)
        assert (
            "scenarios/sub/under.yaml: golden/scenarios/sub/under.json cannot be a golden snapshot: golden/scenarios/sub is a file"
            in out
        )
        assert "Traceback" not in out and "Error" not in out and "def " not in out, out  # no exception, no source
        assert "no golden yet" not in out and "differs" not in out
        assert {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()} == before, args  # none replaced
        assert stat.S_ISFIFO((folder / "fifo.json").stat().st_mode)


def test_a_golden_folder_that_is_a_file_is_one_line_under_snapshot_update(project):
    write(project, "tower", TOWER)
    (project.path / "golden").write_text("not a folder\n")
    result = project.runpytest("-p", "no:cacheprovider", "--snapshot-update")
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    assert "tower.yaml: golden/scenarios/tower.json cannot be a golden snapshot: golden is a file, not a folder" in out
    assert "Traceback" not in out and "NotADirectoryError" not in out and "differs" not in out
    assert (project.path / "golden").read_text() == "not a folder\n"


@pytest.mark.slow  # pytest runs of its own, 13-28 s: in .ci/nightly's slow part
def test_the_golden_fixture_says_a_damaged_golden_in_one_line_and_never_blocks_on_a_fifo(pytester, monkeypatch):
    """A FIFO, bytes that are not UTF-8, a folder: one line naming the golden, never syrupy's
    traceback, never a hang, never written over or deleted; a test's second assertion
    (``name.1.json``) too."""
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)
    pytester.makefile(".toml", pyproject="[tool.pytest.ini_options]\n")
    pytester.makepyfile(
        test_g="def test_mine(golden):\n    assert golden == {'value': 1}\n\n"
        "def test_two(golden):\n    assert golden == [1]\n    assert golden == [2]\n"
    )
    folder = pytester.path / "golden" / "test_g"
    pytester.runpytest_subprocess("-p", "no:cacheprovider", "-n", "0", "--snapshot-update").assert_outcomes(passed=2)
    names = ["test_mine.json", "test_two.1.json", "test_two.json"]
    assert sorted(p.name for p in folder.iterdir()) == names
    damages = {
        "fifo": ("test_mine.json", "golden/test_g/test_mine.json is a FIFO, not a golden snapshot: remove it"),
        "bytes": ("test_two.1.json", "golden/test_g/test_two.1.json is not a golden snapshot: not UTF-8 text (byte 0xff"),
        "folder": ("test_mine.json", "golden/test_g/test_mine.json is a folder, not a golden snapshot: remove it"),
    }
    for damage, (name, said) in damages.items():
        stored = folder / name
        stored.unlink()
        if damage == "fifo":
            os.mkfifo(stored)
        elif damage == "bytes":
            stored.write_bytes(b"\xff[1]\n")
        else:
            stored.mkdir()
        for args in ([], ["--snapshot-update"]):
            result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-n", "0", *args, timeout=120)
            result.assert_outcomes(passed=1, failed=1)
            out = result.stdout.str()
            (line,) = [line for line in result.outlines if said in line and line.startswith("E ")]  # one line
            assert line.startswith("E       assert golden/"), (damage, args, line)
            assert "Deleted" not in out and sorted(p.name for p in folder.iterdir()) == names, (damage, args)
            assert "Traceback" not in out and "assertion.py" not in out and "BadGolden" not in out, out
            assert stat.S_ISFIFO(stored.stat().st_mode) if damage == "fifo" else True  # not written over
            assert stored.read_bytes() == b"\xff[1]\n" if damage == "bytes" else True
        stored.rmdir() if damage == "folder" else stored.unlink()
        pytester.runpytest_subprocess("-p", "no:cacheprovider", "-n", "0", "--snapshot-update").assert_outcomes(passed=2)


@pytest.mark.slow  # pytest runs of its own, 13-28 s: in .ci/nightly's slow part
def test_goldens_moved_by_a_new_pyproject_are_named_where_they_are(pytester, monkeypatch):
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)
    (pytester.path / "s").mkdir()
    (pytester.path / "s" / "t.yaml").write_text(TOWER)
    args = ("-p", "no:cacheprovider", "s/", "-o", "stackdsl_paths=s")
    pytester.runpytest(*args, "--snapshot-update").assert_outcomes(passed=1)
    beside = pytester.path / "s" / "golden" / "t.json"  # no pyproject.toml above: beside the file
    assert beside.is_file()
    hint = pytester.runpytest("-p", "no:cacheprovider", "s/").stdout.str()
    assert 'for good, in pyproject.toml: [tool.pytest.ini_options] stackdsl_paths = ["s"]' in hint
    assert "a new pyproject.toml also moves where their goldens go" in hint
    assert "s/golden/t.json -> golden/s/t.json; move the 1 golden written so far" in hint
    pytester.makefile(".toml", pyproject='[tool.pytest.ini_options]\nstackdsl_paths = ["s"]\n')  # as the hint says
    moved = pytester.path / "golden" / "s" / "t.json"
    for more in ([], ["--snapshot-update"]):
        result = pytester.runpytest(*args, *more)
        result.assert_outcomes(failed=1)
        out = result.stdout.str()
        assert "s/t.yaml: no golden at golden/s/t.json, but s/golden/t.json is one for this scenario" in out
        assert "move it to golden/s/t.json" in out and "no golden yet" not in out
        assert not moved.exists()  # no second golden written beside the reviewed one
    moved.parent.mkdir(parents=True)
    beside.rename(moved)
    pytester.runpytest(*args).assert_outcomes(passed=1)
    (pytester.path / "pyproject.toml").unlink()  # and back: the golden is looked for beside the file again
    result = pytester.runpytest(*args)
    result.assert_outcomes(failed=1)
    assert "no golden at s/golden/t.json, but golden/s/t.json is one for this scenario (with no pyproject.toml" in (
        result.stdout.str()
    )


def test_the_golden_fixture_names_goldens_a_new_pyproject_moved(pytester, monkeypatch):
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)
    (pytester.path / "t").mkdir()
    (pytester.path / "t" / "test_g.py").write_text("def test_mine(golden):\n    assert golden == {'value': 1}\n")
    pytester.runpytest("-p", "no:cacheprovider", "t/", "--snapshot-update").assert_outcomes(passed=1)
    assert (pytester.path / "t" / "golden" / "test_g" / "test_mine.json").is_file()
    pytester.makefile(".toml", pyproject="[tool.pytest.ini_options]\n")
    result = pytester.runpytest("-p", "no:cacheprovider", "t/", "--snapshot-update")
    result.assert_outcomes(errors=1)
    assert "t/test_g.py: no goldens at golden/t/test_g/, but t/golden/test_g/ holds this test file's" in result.stdout.str()
    assert not (pytester.path / "golden" / "t").exists()


def test_snapshot_update_deletes_no_file_that_is_not_a_golden(project):
    write(project, "tower", TOWER)
    folder = project.path / "golden" / "scenarios"
    folder.mkdir(parents=True)
    notes = {"README.md": "how these goldens were reviewed\n", "gone": "not a golden: no .json\n"}
    for name, text in notes.items():
        (folder / name).write_text(text)
    result = project.runpytest("-p", "no:cacheprovider", "--snapshot-update")
    result.assert_outcomes(passed=1)
    assert "Deleted" not in result.stdout.str() and "unused" not in result.stdout.str()
    assert {name: (folder / name).read_text() for name in notes} == notes


@pytest.mark.slow
def test_without_syrupy_the_snapshot_update_the_docs_give_names_the_extra(tmp_path):
    """``pytest --snapshot-update`` (the README's and the "no golden yet" message's command) was
    pytest's "unrecognized arguments" without syrupy; it runs, and the item names the extra."""
    import subprocess
    import sys

    project, missing = tmp_path / "project", tmp_path / "missing" / "syrupy"
    (project / "scenarios").mkdir(parents=True)
    (project / "scenarios" / "tower.yaml").write_text(TOWER)
    (project / "pyproject.toml").write_text("[tool.pytest.ini_options]\n")
    missing.mkdir(parents=True)
    (missing / "__init__.py").write_text("raise ImportError('syrupy is not installed')\n")  # found first, on PYTHONPATH
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_XDIST_WORKER"}
    env["PYTHONPATH"] = str(missing.parent)
    argv = [
        sys.executable,
        "-m",
        "pytest",
        "-p",
        "no:syrupy",
        "-p",
        "no:xdist",
        "-p",
        "no:cacheprovider",
        "-q",
        "--snapshot-update",
    ]
    done = subprocess.run(argv, cwd=project, capture_output=True, text=True, env=env)
    assert "unrecognized arguments" not in done.stderr, done.stderr
    assert "pip install 'stackdsl[pytest]'" in done.stdout and "1 failed" in done.stdout, done.stdout[-2000:]

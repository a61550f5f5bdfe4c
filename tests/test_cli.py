"""The stackdsl command: check's table and exit codes, compile, run, schema."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from stackdsl import _check
from stackdsl._cli import main

PASSING = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nexpect: {stands: true}\n"
FAILING = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nexpect: {collapse: 2}\n"
BAD = "stackdsl: 1\nstructure:\n  tower: {levels: 2, spacng: 96 mm}\n"


def write(folder: Path, **files: str) -> Path:
    for name, text in files.items():
        (folder / f"{name}.yaml").write_text(text)
    return folder


def test_check_passing_folder_exits_0_with_a_table(tmp_path, capsys):
    assert main(["check", str(write(tmp_path, a=PASSING, b=PASSING)), "-j", "1"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:3] == ["scenario", "mode", "expected"]
    assert [line.split()[0] for line in out[1:3]] == ["PASS", "PASS"]
    assert "extension  stands" in out[1] and out[1].rstrip().endswith(" s")
    assert out[-1].startswith("2 scenarios: 2 passed, 0 failed")


def test_check_failing_expectation_exits_1(tmp_path, capsys):
    assert main(["check", str(write(tmp_path, a=PASSING, b=FAILING)), "-j", "1"]) == 1
    out = capsys.readouterr().out
    assert "FAIL" in out and "collapse 2" in out and "1 failed" in out


def test_check_bad_file_exits_2_and_simulates_nothing(tmp_path, capsys, monkeypatch):
    def no_simulation(*args, **kwargs):
        raise AssertionError("simulated although a file was bad")

    monkeypatch.setattr(_check, "run_program", no_simulation)
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


def test_check_runs_in_worker_processes(tmp_path):
    results = list(_check.check([write(tmp_path, a=PASSING, b=FAILING)], jobs=2))
    assert [(Path(r.file).name, r.passed) for r in results] == [("a.yaml", True), ("b.yaml", False)]


def test_compile_prints_the_program(tmp_path, capsys):
    assert main(["compile", str(write(tmp_path, a=PASSING) / "a.yaml")]) == 0
    out = capsys.readouterr().out
    assert "place  L01.1" in out and out.rstrip().endswith("end")
    assert main(["compile", str(tmp_path / "a.yaml"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["engine"]["mode"] == "extension"


def test_run_prints_the_timeline(tmp_path, capsys):
    assert main(["run", str(write(tmp_path, a=PASSING) / "a.yaml")]) == 0
    out = capsys.readouterr().out
    assert "freeze   L01.1" in out and "PASS  expected stands" in out


def test_schema_is_json_schema_of_a_scenario(capsys):
    assert main(["schema"]) == 0
    schema = json.loads(capsys.readouterr().out)
    assert schema["title"] == "Scenario" and "structure" in schema["required"]


def test_console_script_output_has_no_engine_chatter(tmp_path):
    path = write(tmp_path, a=PASSING)
    done = subprocess.run(
        [sys.executable, "-m", "stackdsl", "check", str(path), "-j", "1"], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    assert "argv[0]" not in done.stdout + done.stderr and "build time" not in done.stdout + done.stderr


@pytest.mark.parametrize("bad", ["", "--mode sideways"])
def test_usage_errors_exit_2(bad, capsys):
    with pytest.raises(SystemExit) as info:
        main(["check", *bad.split()] if bad else [])
    assert info.value.code == 2


def test_compare_prints_one_row_per_scenario_and_a_column_per_mode(tmp_path, capsys):
    assert main(["compare", str(write(tmp_path, a=PASSING, b=FAILING)), "--modes", "raw,extension", "-j", "1"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split() == ["scenario", "expected", "raw", "extension"]
    assert out[1].split()[:4] == ["a", "stands", "PASS", "stands"] and out[1].count("PASS") == 2
    assert out[2].startswith("b ") and out[2].count("FAIL") == 2
    assert out[-1].startswith("2 scenarios x 2 modes")


def test_compare_unknown_mode_exits_2(tmp_path, capsys):
    assert main(["compare", str(write(tmp_path, a=PASSING)), "--modes", "raw,sideways"]) == 2
    assert "unknown mode sideways" in capsys.readouterr().err


def test_bench_quick_smoke_writes_every_output(tmp_path, capsys):
    # One small cell per setting, in worker processes: the command cannot rot.
    assert main(["bench", "--quick", "--out", str(tmp_path), "-j", "2"]) == 0
    names = {p.name for p in tmp_path.iterdir()}
    assert names == {"bench.csv", "bench.md", "wall_vs_error.png", "wall_vs_height.png"}
    rows = (tmp_path / "bench.csv").read_text().splitlines()
    assert rows[0].startswith("setting,family,parameter") and len(rows) == 1 + 5
    assert "extension report" in capsys.readouterr().out

"""Every output option of every command checked the same way before anything runs
(stackdsl.cli.outputs): not an input, not another output, not empty, not a FIFO or a device,
in a folder that takes a new file; and the goldens read by default not FIFOs."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from stackdsl.cli.main import main
from stackdsl.cli.outputs import Input, Output, check_outputs, same_place

STANDS = "stackdsl: 1\nname: small tower\nstructure: {tower: {levels: 2}}\ntiming: {settle: 0.2 s}\nexpect: {stands: true}\n"
SWEEP = (
    "stackdsl: 1\nstructure:\n  tower: {levels: 3, bricks_per_layer: 1, turn: 0, shift: {uniform: [-10 mm, 10 mm], per: layer}}\n"
    "timing: {settle: 0.2 s}\nsweep: {samples: 2}\n"
)


@pytest.fixture
def project(tmp_path, monkeypatch):
    """A project (a pyproject.toml) with scenarios/t.yaml, its golden, and s.yaml (a sweep); the
    current folder. Nothing may be simulated."""
    (tmp_path / "pyproject.toml").write_text("")
    (tmp_path / "scenarios").mkdir()
    (tmp_path / "scenarios" / "t.yaml").write_text(STANDS)
    (tmp_path / "s.yaml").write_text(SWEEP)
    (tmp_path / "golden" / "scenarios").mkdir(parents=True)
    (tmp_path / "golden" / "scenarios" / "t.json").write_text("{}")
    monkeypatch.chdir(tmp_path)

    def never(*a, **k):
        raise AssertionError("simulated")

    for where in ("stackdsl.runtime.recorder.run_program", "stackdsl.batch.judge.run_program", "stackdsl.batch.sweep.run_sweep"):
        monkeypatch.setattr(where, never)
    return tmp_path


def status_of(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as exc:  # argparse's usage errors
        return int(exc.code)


def refused(argv: list[str], capsys) -> str:
    """stderr of ``argv``, which must exit 2 with one line."""
    assert status_of(argv) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    return err.strip()


@pytest.mark.parametrize(
    ("argv", "victim", "words"),
    [
        (["check", "scenarios/t.yaml", "--junit-xml", "scenarios/t.yaml"], "scenarios/t.yaml", "--junit-xml: this is a scenario"),
        (["check", "scenarios", "--junit-xml", "./scenarios/../scenarios/t.yaml"], "scenarios/t.yaml", "this is a scenario"),
        (
            ["check", "scenarios/t.yaml", "--junit-xml", "golden/scenarios/t.json"],
            "golden/scenarios/t.json",
            "this is the golden",
        ),
        (
            ["export", "scenarios/t.yaml", "--urdf", "scenarios/t.yaml"],
            "scenarios/t.yaml",
            "--urdf: this is the file being exported",
        ),
        (["replay", "scenarios/t.yaml", "-o", "golden", "--golden", "golden/replay.html"], "golden/replay.html", "the golden"),
    ],
    ids=["junit onto the scenario", "junit onto a file of the folder", "junit onto the golden", "export", "replay"],
)
def test_an_output_onto_an_input_is_refused_and_the_input_left_alone(project, capsys, argv, victim, words):
    if victim.endswith("replay.html"):
        brick = {"position_mm": [0, 0, 7.5], "quaternion_xyzw": [0, 0, 0, 1]}
        (project / victim).write_text(json.dumps({"final_graph": {"L01.1": brick}}))  # a golden snapshot, oddly named
    before = (project / victim).read_bytes()
    assert words in refused(argv, capsys)
    assert (project / victim).read_bytes() == before


def test_two_outputs_of_one_file_are_refused(project, capsys):
    err = refused(["export", "scenarios/t.yaml", "--mjcf", "same.xml", "--urdf", "./same.xml"], capsys)
    assert err == "./same.xml: --urdf: --mjcf writes there too: give each output its own path"
    assert not (project / "same.xml").exists()
    # a file output on a folder output's path, or on a file it writes in it
    for junit, folder in (("r", False), ("r/index.html", True)):
        if folder:
            (project / "r").mkdir()
        err = refused(["check", "scenarios/t.yaml", "--junit-xml", junit, "--report", "r"], capsys)
        assert err == "r: --report: --junit-xml writes there too: give each output its own path"
        assert (project / "r").exists() == folder and not (project / "r" / "index.html").exists()


@pytest.mark.parametrize(
    "argv",
    [
        ["run", "scenarios/t.yaml", "--record", ""],
        ["check", "scenarios/t.yaml", "--junit-xml", ""],
        ["check", "scenarios/t.yaml", "--report", " "],
        ["render", "scenarios/t.yaml", "-o", ""],
        ["animate", "scenarios/t.yaml", "-o", ""],
        ["graph", "scenarios/t.yaml", "-o", ""],
        ["replay", "scenarios/t.yaml", "-o", ""],
        ["replay", "scenarios/t.yaml", "-o", "r", "--golden", ""],
        ["export", "scenarios/t.yaml", "--mjcf", ""],
        ["export", "scenarios/t.yaml", "--mjcf", "a.xml", "--urdf", ""],
        ["sweep", "s.yaml", "--out", ""],
    ],
    ids=lambda argv: f"{argv[0]} {argv[-2]}",
)
def test_an_empty_path_is_refused_naming_its_option(project, capsys, argv):
    assert refused(argv, capsys).startswith(f"{argv[-2]}: the path is empty: give ")
    assert sorted(p.name for p in project.iterdir()) == ["golden", "pyproject.toml", "s.yaml", "scenarios"]


@pytest.mark.parametrize(
    "argv",
    [
        ["check", "scenarios/t.yaml", "--junit-xml", "/proc/x.xml"],
        ["check", "scenarios/t.yaml", "--report", "/proc/stackdsl-report"],
        ["run", "scenarios/t.yaml", "--record", "/proc/x.npz"],
        ["render", "scenarios/t.yaml", "-o", "/proc/x.png"],
        ["animate", "scenarios/t.yaml", "-o", "/proc/x.gif"],
        ["graph", "scenarios/t.yaml", "-o", "/proc/x.png"],
        ["replay", "scenarios/t.yaml", "-o", "/proc/stackdsl-replay"],
        ["export", "scenarios/t.yaml", "--mjcf", "/proc/x.xml"],
        ["sweep", "s.yaml", "--out", "/proc/stackdsl-sweep"],
        ["render", "scenarios/t.yaml", "-o", "x" * 300 + ".png"],
        ["replay", "scenarios/t.yaml", "-o", "r/" + "x" * 300],
    ],
    ids=lambda argv: f"{argv[0]} {argv[-2]} {argv[-1][:12]}",
)
def test_an_output_the_system_refuses_is_said_before_anything_runs(project, capsys, argv):
    err = refused(argv, capsys)
    reason = "File name too long" if "xxxx" in argv[-1] else "No such file or directory"
    assert err == f"stackdsl: {argv[-1]}: {argv[-2]}: {reason}"  # the path, then the option that gave it
    assert sorted(p.name for p in project.iterdir()) == ["golden", "pyproject.toml", "s.yaml", "scenarios"]


# FIFOs: a command that opened one would block for ever, so each case runs as its own process


def _fifo(path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    os.mkfifo(path)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("argv", "fifo", "words"),
    [
        (["run", "scenarios/t.yaml", "--record", "f.npz"], "f.npz", "f.npz: --record: not a regular file: a FIFO"),
        (["export", "scenarios/t.yaml", "--mjcf", "f.yaml"], "f.yaml", "f.yaml: --mjcf: not a regular file: a FIFO"),
        (["check", "scenarios/t.yaml", "--junit-xml", "f.xml"], "f.xml", "f.xml: --junit-xml: not a regular file: a FIFO"),
        (["render", "scenarios/t.yaml", "-o", "f.png"], "f.png", "f.png: -o: not a regular file: a FIFO"),
        (["animate", "scenarios/t.yaml", "-o", "f.gif"], "f.gif", "f.gif: -o: not a regular file: a FIFO"),
        (["graph", "scenarios/t.yaml", "-o", "f.png"], "f.png", "f.png: -o: not a regular file: a FIFO"),
        (["export", "scenarios/t.yaml", "--urdf", "/dev/null"], "", "/dev/null: --urdf: not a regular file: a character device"),
        (["replay", "scenarios/t.yaml", "-o", "r"], "r/replay.html", "r: -o: replay.html in it is a FIFO"),
        (["check", "scenarios/t.yaml", "--report", "r"], "r/index.html", "r: --report: index.html in it is a FIFO"),
        (["check", "scenarios/t.yaml", "--report", "r"], "r/t/clip.gif", "--report: clip.gif in it is a FIFO"),
        (["sweep", "s.yaml", "--out", "o"], "o/samples.csv", "o: --out: samples.csv in it is a FIFO"),
        (["sweep", "s.yaml", "--out", "o"], "o", "o: --out: the sweep's output goes to a folder, and this is a FIFO"),
        (["replay", "scenarios/t.yaml", "-o", "r"], "golden/scenarios/t.json", "golden/scenarios/t.json: not a regular file"),
        (["check", "scenarios/t.yaml", "--report", "r"], "golden/scenarios/t.json", "golden/scenarios/t.json: not a regular"),
    ],
    ids=[
        "record",
        "mjcf",
        "junit",
        "render",
        "animate",
        "graph",
        "a device",
        "replay folder",
        "report folder",
        "report run folder",
        "sweep folder",
        "sweep out",
        "replay golden",
        "report golden",
    ],
)
def test_a_fifo_where_a_command_writes_or_reads_a_golden_is_refused_without_blocking(tmp_path, argv, fifo, words):
    (tmp_path / "pyproject.toml").write_text("")
    (tmp_path / "scenarios").mkdir()
    (tmp_path / "scenarios" / "t.yaml").write_text(STANDS)
    (tmp_path / "s.yaml").write_text(SWEEP)
    if fifo:
        if fifo.startswith("golden"):
            (tmp_path / "golden" / "scenarios").mkdir(parents=True)
        _fifo(tmp_path / fifo)
    done = subprocess.run(
        [sys.executable, "-m", "stackdsl", *argv, "--timeout", "20"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        stdin=subprocess.DEVNULL,
        timeout=60,  # a safety net: refused, it takes a second
        check=False,
    )
    assert done.returncode == 2, done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert words in line, line
    assert "simulated" not in done.stdout and "PASS" not in done.stdout  # refused before anything ran


def test_same_place_is_one_file_by_any_name_existing_or_not(tmp_path):
    (tmp_path / "a.txt").write_text("x")
    os.link(tmp_path / "a.txt", tmp_path / "hard.txt")
    (tmp_path / "soft.txt").symlink_to("a.txt")
    assert same_place(tmp_path / "a.txt", tmp_path / "hard.txt") and same_place(tmp_path / "soft.txt", tmp_path / "a.txt")
    assert same_place(tmp_path / "new.xml", tmp_path / "." / "new.xml")
    assert not same_place(tmp_path / "new.xml", tmp_path / "a.txt")


def test_checking_outputs_leaves_nothing_behind(tmp_path):
    out = tmp_path / "deep" / "er" / "report"
    paths = check_outputs(
        [Output("--junit-xml", str(tmp_path / "j.xml"), "the JUnit XML file"), Output("--report", str(out), "the report", True)],
        [Input(tmp_path / "missing.yaml", "a scenario")],
    )
    assert paths == [tmp_path / "j.xml", out] and list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_a_sweep_into_the_folder_of_an_earlier_one_says_it_replaces_its_files(tmp_path, capsys):
    (tmp_path / "s.yaml").write_text(SWEEP)
    out = tmp_path / "o"
    argv = ["sweep", str(tmp_path / "s.yaml"), "--out", str(out), "-j", "1"]
    assert main(argv) == 0
    assert "replacing" not in capsys.readouterr().out.splitlines()[0]
    (out / "samples.csv").write_text("an earlier sweep's\n")
    assert main(argv) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.endswith(
        f"writing to {out} (replacing samples.csv, samples.jsonl, samples.parquet, histogram.png of an earlier sweep there)"
    )
    assert (out / "samples.csv").read_text().startswith("cell,")


@pytest.mark.slow
def test_a_sweep_over_an_earlier_grid_sweep_leaves_none_of_its_files_and_nothing_else_is_touched(tmp_path, capsys):
    grid = SWEEP.replace("sweep: {samples: 2}", "sweep: {samples: 2, grid: {timing.drop_gap: [0.5 mm, 1 mm, 2 mm]}}")
    (tmp_path / "grid.yaml").write_text(grid)
    (tmp_path / "one.yaml").write_text(SWEEP)
    out = tmp_path / "o"
    assert main(["sweep", str(tmp_path / "grid.yaml"), "--out", str(out), "-j", "1"]) == 0
    capsys.readouterr()
    grid_files = {p.name for p in out.iterdir()}
    assert {"histogram_0.png", "histogram_2.png", "grid_p_stands.png", "grid_mean.png"} <= grid_files
    (out / "notes.txt").write_text("mine")  # the user's own, and names no sweep writes
    (out / "histogram_99.png").write_text("mine too")
    (out / "histogram_1.png").unlink()
    (out / "histogram_1.png").mkdir()  # a folder of a sweep file's name is not a file of an earlier sweep
    assert main(["sweep", str(tmp_path / "one.yaml"), "--out", str(out), "-j", "1"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert {p.name for p in out.iterdir()} == {
        *("samples.csv", "samples.jsonl", "samples.parquet", "histogram.png"),
        *("notes.txt", "histogram_99.png", "histogram_1.png"),
    }
    for name in sorted(grid_files - {"histogram_1.png"}):
        assert name in first  # said as replaced, and it is: gone, or written anew
    assert (out / "notes.txt").read_text() == "mine" and (out / "histogram_1.png").is_dir()

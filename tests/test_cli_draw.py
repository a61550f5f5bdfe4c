"""The commands that keep or draw a run: run --record, render, animate, graph, bench record."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageSequence

from stackdsl.cli import main as _cli
from stackdsl.cli.main import main
from stackdsl.runtime.trajectory import load_trajectory

ROOT = Path(__file__).resolve().parents[1]

STANDS = "stackdsl: 1\nname: small tower\nstructure: {tower: {levels: 2}}\nexpect: {stands: true}\n"
TIPS = "stackdsl: 1\nstructure:\n  bricks:\n    - {id: base, at: [0, 0, 4 mm]}\n    - {id: top, at: [60.5 mm, 0, 12 mm]}\n"


@pytest.fixture
def files(tmp_path):
    (tmp_path / "stands.yaml").write_text(STANDS)
    (tmp_path / "tips.yaml").write_text(TIPS)
    return tmp_path


def pixels(path) -> np.ndarray:
    with Image.open(path) as image:
        return np.asarray(image.convert("RGB"))


def test_run_record_writes_a_trajectory_that_loads_and_keeps_the_verdict(files, capsys):
    out = files / "run.npz"
    assert main(["run", str(files / "stands.yaml"), "--record", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "PASS  expected stands" in printed and f"wrote {out}: " in printed
    trajectory = load_trajectory(out)
    assert trajectory.ids.tolist() == ["L01.1", "L01.2", "L02.1", "L02.2"]
    assert trajectory.meta["file"] == str(files / "stands.yaml") and trajectory.meta["rate"] == 30
    assert [e.kind for e in trajectory.events].count("place") == 4
    # a lower rate takes fewer frames; the JSON outcome stays alone on stdout
    slow = files / "slow.npz"
    assert main(["run", str(files / "tips.yaml"), "--record", str(slow), "--rate", "5", "--json"]) == 0
    captured = capsys.readouterr()
    assert captured.out.lstrip().startswith("{") and "wrote" in captured.err
    main(["run", str(files / "tips.yaml"), "--record", str(out)])
    assert len(load_trajectory(slow).times) < len(load_trajectory(out).times)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--record", "{tmp}/missing/run.npz"], "no such folder for the trajectory file"),
        (["--record", "{tmp}/run.npz", "--rate", "0"], "not a number of frames a second above 0"),
    ],
)
def test_run_record_bad_options_simulate_nothing(files, capsys, monkeypatch, args, message):
    def never(*a, **k):
        raise AssertionError("simulated")

    monkeypatch.setattr("stackdsl.runtime.recorder.run_program", never)
    argv = ["run", str(files / "stands.yaml"), *(a.replace("{tmp}", str(files)) for a in args)]
    try:
        status = main(argv)
    except SystemExit as exc:  # argparse's usage errors
        status = exc.code
    assert status == 2
    assert message in capsys.readouterr().err


def test_render_from_a_scenario_or_its_trajectory_is_the_same_picture(files, capsys):
    direct, replayed, npz = files / "a.png", files / "b.png", files / "tips.npz"
    assert main(["render", str(files / "tips.yaml"), "-o", str(direct)]) == 0
    assert main(["run", str(files / "tips.yaml"), "--record", str(npz)]) == 0
    assert main(["render", str(npz), "-o", str(replayed)]) == 0
    assert "wrote" in capsys.readouterr().out
    first, second = pixels(direct), pixels(replayed)
    assert first.shape == (600, 800, 3) and np.array_equal(first, second)  # pybullet repeats a run bitwise


def test_render_at_a_time_and_a_size(files):
    out = files / "x.png"
    assert main(["render", str(files / "stands.yaml"), "--at", "1.5", "--size", "320x240", "-o", str(out)]) == 0
    assert pixels(out).shape == (240, 320, 3)
    assert main(["render", str(files / "stands.yaml"), "--at", "end", "-o", str(out)]) == 0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--at", "collapse"], "did not collapse"),
        (["--at", "99"], "outside the run"),
        (["--size", "big"], "is not WIDTHxHEIGHT"),
        (["--size", "8x8"], "64 to 4096 pixels"),
        (["-o", "{tmp}/x.jpg"], "the output must end in .png"),
        (["-o", "{tmp}/missing/x.png"], "-o: no such folder for the picture"),
        (["--at", "soon"], "is not 'collapse', 'end' or a number of seconds"),
    ],
)
def test_render_refuses_bad_requests_with_exit_2(files, capsys, args, message):
    argv = ["render", str(files / "stands.yaml"), "-o", str(files / "x.png")]
    argv += [a.replace("{tmp}", str(files)) for a in args]
    try:
        status = main(argv)
    except SystemExit as exc:
        status = exc.code
    assert status == 2
    assert message in capsys.readouterr().err
    assert not (files / "x.png").exists()


def test_a_file_that_is_not_a_trajectory_and_mode_on_a_trajectory_are_bad_input(files, capsys):
    (files / "junk.npz").write_bytes(b"junk")
    assert main(["render", str(files / "junk.npz"), "-o", str(files / "x.png")]) == 2
    assert "not a stackdsl trajectory" in capsys.readouterr().err
    main(["run", str(files / "stands.yaml"), "--record", str(files / "t.npz")])
    assert main(["render", str(files / "t.npz"), "--mode", "raw", "-o", str(files / "x.png")]) == 2
    assert "--mode, --model and --backend apply to a scenario" in capsys.readouterr().err


def test_animate_writes_a_gif_and_an_mp4(files, capsys):
    gif, mp4 = files / "x.gif", files / "x.mp4"
    assert main(["animate", str(files / "tips.yaml"), "-o", str(gif), "--size", "160x120"]) == 0
    with Image.open(gif) as image:
        assert image.n_frames > 10 and image.size == (160, 120)
        played = sum(image.info["duration"] for _ in ImageSequence.Iterator(image)) / 1000
    # the clip's length as said is the file's, its last picture's hold included
    said = re.search(r"frames, ([0-9.]+) s at", capsys.readouterr().out)
    assert said is not None and float(said.group(1)) == pytest.approx(played, abs=0.06)
    assert main(["animate", str(files / "tips.yaml"), "-o", str(mp4), "--size", "160x120"]) == 0
    assert mp4.read_bytes()[4:8] == b"ftyp"  # an MP4 container


@pytest.mark.parametrize(("args", "message"), [(["-o", "{tmp}/x.avi"], ".gif or .mp4"), (["--fps", "60"], "at most 50")])
def test_animate_refuses_bad_requests_with_exit_2(files, capsys, args, message):
    argv = ["animate", str(files / "tips.yaml"), "-o", str(files / "x.gif"), *(a.replace("{tmp}", str(files)) for a in args)]
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_graph_plots_the_collapse_by_default_and_refuses_a_collapse_that_did_not_happen(files, capsys):
    out = files / "g.png"
    assert main(["graph", str(files / "tips.yaml"), "-o", str(out)]) == 0
    assert pixels(out).shape[0] > 300
    assert main(["graph", str(files / "stands.yaml"), "--at", "collapse", "-o", str(out)]) == 2
    assert "nothing collapsed in this run" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.parametrize("command", ["render", "animate", "graph"])
def test_drawing_commands_have_exit_statuses_in_their_help(command, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    out = capsys.readouterr().out
    assert "exit status:" in out and "2    bad input" in out and "a trajectory file (.npz)" in out


@pytest.mark.slow
def test_bench_record_times_recording_off_and_on_alternately(files, capsys):
    assert main(["bench", "record", str(files / "stands.yaml"), "--repeats", "2"]) == 0
    versions, *lines = capsys.readouterr().out.splitlines()
    assert versions.startswith("engines: pybullet ")
    assert lines[0].endswith("2 runs each, alternating, in one process")
    rows = {line.split("  ")[0]: line for line in lines[2:]}
    assert set(rows) == {"recording off", "recording at 30 Hz while moving", "recording every step while moving"}
    assert " 1.000 " in rows["recording off"]
    assert main(["bench", "record", str(files / "stands.yaml"), "--repeats", "0"]) == 2


def test_the_drawing_modules_load_only_when_a_drawing_command_runs():
    import subprocess
    import sys

    code = "import sys, stackdsl.cli.main; print(sorted({'stackdsl.draw.render', 'stackdsl.draw.animate', 'stackdsl.draw.graphplot'} & set(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
    assert _cli.main  # the command module itself loads


@pytest.mark.slow  # 8-10 s: in .ci/nightly's slow part
def test_bench_record_before_times_another_install_and_this_one_alternately(files, capsys):
    import sys

    assert (
        main(["bench", "record", str(files / "stands.yaml"), "--repeats", "1", "--before", sys.executable, "--rounds", "2"]) == 0
    )
    out = capsys.readouterr().out
    assert "check in-process, 2 runs each, alternating rounds" in out
    assert f"before ({sys.executable}): median" in out and "after (this stackdsl, recording off): median" in out
    assert "ratio after / before: " in out


# careless input, as a new user gave it: each one line, exit 2 (1 for a run stopped by its timeout)


def status_of(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as exc:  # argparse's usage errors
        return int(exc.code)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["render", "{tmp}/stands.yaml", "-o", "{tmp}/dir.png"], "this is a folder: give the file to write"),
        (["render", "{tmp}/notes.json", "-o", "{tmp}/x.png"], "give a scenario (.yaml, .yml) or a trajectory file (.npz)"),
        (["render", "{tmp}/stands.yaml", "-o", "{tmp}/x.png", "--size", "16x16"], "each side must be 64 to 4096 pixels"),
        (["animate", "{tmp}/stands.yaml", "-o", "{tmp}/x.mp4", "--fps", "1e-3"], "is not from 1 to 120 frames a second"),
        (["run", "{tmp}/stands.yaml", "--record", "{tmp}/x.json"], "a trajectory file must end in .npz"),
        (["run", "{tmp}/stands.yaml", "--rate", "5"], "--rate is the recording's: give --record OUT.npz too"),
        (["check", "{tmp}/stands.yaml", "--report", ""], "give the folder for the report"),
        (["check", "{tmp}/stands.yaml", "--report", "{tmp}/stands.yaml/sub"], "cannot write the report there"),
        (["bench", "record", "{tmp}/stands.yaml", "--before", "{tmp}/no-python"], "cannot run it: no such file or directory"),
        (["bench", "record", "{tmp}/stands.yaml", "--before", "{tmp}/dir.png"], "cannot run it: a folder, not a program"),
        (["bench", "record", "{tmp}/stands.yaml", "--rounds", "3"], "--rounds is the comparison's"),
    ],
)
def test_careless_input_is_one_line_and_exit_2_before_anything_runs(files, capsys, monkeypatch, argv, message):
    def never(*a, **k):
        raise AssertionError("simulated")

    monkeypatch.setattr("stackdsl.runtime.recorder.run_program", never)
    monkeypatch.setattr("stackdsl.bench.record.run_program", never)
    monkeypatch.setattr("stackdsl.batch.judge.run_program", never)
    (files / "notes.json").write_text("{}")
    (files / "dir.png").mkdir()
    assert status_of([a.replace("{tmp}", str(files)) for a in argv]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err


def test_a_usage_error_is_one_line_naming_the_option_and_the_help(capsys):
    assert status_of(["check", "x", "-j", "0"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("stackdsl check: error: argument -j/--jobs: 0 is not from 1") and line.endswith(
        "(see: stackdsl check --help)"
    )


def test_a_damaged_or_foreign_trajectory_file_is_bad_input(files, capsys):
    main(["run", str(files / "tips.yaml"), "--record", str(files / "t.npz")])
    whole = (files / "t.npz").read_bytes()
    (files / "cut.npz").write_bytes(whole[: len(whole) // 2])
    assert main(["render", str(files / "cut.npz"), "-o", str(files / "x.png")]) == 2
    assert "not a stackdsl trajectory, or a damaged one" in capsys.readouterr().err
    np.save(files / "obj.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    (files / "obj.npz").write_bytes((files / "obj.npy").read_bytes())
    assert main(["graph", str(files / "obj.npz"), "-o", str(files / "x.png")]) == 2
    assert "it is not a whole .npz archive" in capsys.readouterr().err


def test_a_drawing_of_a_run_stopped_by_its_timeout_is_written_and_exits_1(files, capsys):
    out = files / "x.png"
    # tuned pybullet (1 ms steps, 150 iterations): seconds of work; a 20-level tower in extension
    # mode finished inside the 0.05 s on a fast machine
    tall = "stackdsl: 1\nstructure: {tower: {levels: 20}}\nengine: {mode: tuned}\n"
    (files / "tall.yaml").write_text(tall)
    assert main(["render", str(files / "tall.yaml"), "-o", str(out), "--timeout", "0.05"]) == 1
    assert out.is_file() and "the run was stopped early: timeout after 0.05 s" in capsys.readouterr().err


def test_report_folder_names_stay_short_and_distinct():
    from stackdsl.draw.artefacts import MAX_NAME, folder_name

    long_a, long_b = "x" * 200 + "/a.yaml", "x" * 200 + "/b.yaml"
    a, b = folder_name(long_a), folder_name(long_b)
    assert len(a) <= MAX_NAME and len(b) <= MAX_NAME and a != b and a.endswith(folder_name(long_a)[-8:])


@pytest.mark.slow
def test_an_earlier_reports_folders_go_and_a_persons_folders_stay(files, capsys):
    report = files / "report"
    main(["check", str(files / "stands.yaml"), str(files / "tips.yaml"), "-j", "1", "--report", str(report)])
    (report / "mine").mkdir()
    (report / "mine" / "notes.txt").write_text("keep me")
    capsys.readouterr()
    main(["check", str(files / "stands.yaml"), "-j", "1", "--report", str(report)])
    assert "removed 1 folders of an earlier report" in capsys.readouterr().out
    assert sorted(p.name for p in report.iterdir()) == ["index.html", "mine", "stands"]


def test_a_clip_too_large_to_draw_is_refused_before_anything_runs(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("stackdsl.runtime.recorder.record_program", lambda *a, **k: pytest.fail("simulated"))
    assert (
        main(
            [
                "animate",
                str(ROOT / "scenarios" / "vee_stands.yaml"),
                "--size",
                "2800x2800",
                "--fps",
                "120",
                "-o",
                str(tmp_path / "x.mp4"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert err.startswith("--size: 600 frames of 2800 x 2800 pixels are") and "at most 1.5e+09" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_timeout_covers_drawing_and_a_clip_cut_short_leaves_no_file(tmp_path, capsys, monkeypatch):
    import time

    from stackdsl.draw import animate as clips

    slow = clips.Scene.render

    def render(self, frame):
        time.sleep(0.05)
        return slow(self, frame)

    monkeypatch.setattr(clips.Scene, "render", render)
    out = tmp_path / "slow.gif"
    assert main(["animate", str(ROOT / "scenarios" / "slant_tower.yaml"), "--timeout", "2", "-o", str(out)]) == 1
    assert "drawing the clip passed --timeout" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []  # neither the clip nor a part of it


def test_an_output_is_written_whole_or_not_at_all(tmp_path):
    from stackdsl.util.files import written

    target = tmp_path / "report.html"
    target.write_text("the old one")
    with pytest.raises(RuntimeError), written(target) as part:
        part.write_text("half of the new one")
        raise RuntimeError("killed half-way")
    assert target.read_text() == "the old one" and [p.name for p in tmp_path.iterdir()] == ["report.html"]
    with written(target) as part:
        part.write_text("the new one")
    assert target.read_text() == "the new one" and [p.name for p in tmp_path.iterdir()] == ["report.html"]


def test_an_output_that_is_a_fifo_or_a_device_is_refused_never_opened_or_replaced(tmp_path):
    import os
    import stat

    from stackdsl.util.files import NotRegularFile, written

    fifo = tmp_path / "pipe.xml"
    os.mkfifo(fifo)  # opened for writing, it would block until something reads it
    for taken in (fifo, Path("/dev/null")):
        with pytest.raises(NotRegularFile) as error, written(taken):
            pytest.fail("written")
        assert error.value.filename == str(taken) and "not a regular file" in error.value.strerror
    assert stat.S_ISFIFO(fifo.stat().st_mode) and [p.name for p in tmp_path.iterdir()] == ["pipe.xml"]
    with pytest.raises(OSError) as error, written(tmp_path / "no" / "such.png") as part:
        part.write_text("x")
    assert error.value.filename == str(tmp_path / "no" / "such.png")


def _greedy(module: str, name: str, argv: list[str]) -> subprocess.CompletedProcess[str]:
    """Run ``stackdsl`` with ``argv`` in a fresh process whose ``module.name`` asks for 12 GiB
    (reserved, never touched; the machine itself would grant it)."""
    code = (
        "import sys, numpy as np\n"
        f"import {module} as greedy_module\n"
        "def greedy(*args, **kwargs):\n"
        "    np.empty(12 * 2**30, dtype=np.uint8)\n"
        f"greedy_module.{name} = greedy\n"
        f"sys.argv = ['stackdsl', *{argv!r}]\n"
        "from stackdsl._entry import main\n"
        "sys.exit(main())\n"
    )
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)


@pytest.mark.slow
def test_a_drawing_command_runs_under_the_workers_memory_limit_and_says_so_when_hit(tmp_path):
    """The main process of a drawing command gets the address-space limit ``check``'s workers
    have: asking for 12 GiB is refused there, with one clear line."""
    scene = str(ROOT / "scenarios" / "vee_stands.yaml")
    done = _greedy("stackdsl.draw.render", "picture", ["render", scene, "-o", str(tmp_path / "x.png")])
    assert done.returncode == 3, done.stderr
    assert done.stderr.strip() == (
        "stackdsl: out of memory: this command may use 4 GiB of address space "
        "(give a smaller --size, fewer frames, or a smaller file)"
    )


@pytest.mark.slow
def test_a_run_out_of_memory_asks_for_a_smaller_scene_not_a_smaller_drawing():
    """``run`` has no --size and draws no frames: its out-of-memory line asks for a smaller scene
    (a new user was told to "give a smaller --size, fewer frames" by a run)."""
    done = _greedy("stackdsl.runtime.run", "run_in", ["run", str(ROOT / "scenarios" / "vee_stands.yaml")])
    assert done.returncode == 3, done.stderr
    assert done.stderr.strip().endswith("GiB of address space (give a smaller scene)"), done.stderr


@pytest.mark.slow
@pytest.mark.parametrize("at", ["0", "-0", "0.0", "0 s", "1e-400"])
def test_at_zero_is_the_start_of_the_run_not_its_end(files, capsys, at):
    record = files / "stands.npz"
    assert main(["run", str(files / "stands.yaml"), "--record", str(record)]) == 0
    capsys.readouterr()
    assert main(["render", str(record), "--at", at, "-o", str(files / "a.png")]) == 0
    assert "the run at t = 0.00 s" in capsys.readouterr().out
    assert main(["export", str(record), "--at", at, "--mjcf", str(files / "a.xml")]) == 0
    assert "at t = 0.000 s" in capsys.readouterr().out
    assert main(["render", str(record), "-o", str(files / "b.png")]) == 0  # not given: the end
    assert "the run at end, t = " in capsys.readouterr().out


@pytest.mark.parametrize(
    ("command", "where", "out"), [("render", "render.picture", "a.png"), ("animate", "animate.animate", "a.gif")]
)
def test_a_failure_of_the_drawing_is_not_blamed_on_an_option(files, capsys, monkeypatch, command, where, out):
    record = files / "stands.npz"
    assert main(["run", str(files / "stands.yaml"), "--record", str(record)]) == 0
    capsys.readouterr()

    def fails(*args, **kwargs):
        raise ValueError("File or stream is not seekable.")

    monkeypatch.setattr(f"stackdsl.draw.{where}", fails)
    # of a trajectory file: its numbers, bad input at the file
    assert main([command, str(record), "-o", str(files / out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"{record}: this trajectory cannot be drawn: File or stream is not seekable."
    # of a run made here: a bug, not bad input at --at or --fps
    assert main([command, str(files / "stands.yaml"), "-o", str(files / out)]) == 3
    err = capsys.readouterr().err
    assert "internal error: ValueError: File or stream is not seekable." in err and "--at" not in err and "--fps" not in err


def test_a_gif_too_fast_is_refused_before_anything_runs(files, capsys, monkeypatch):
    def never(*a, **k):
        raise AssertionError("simulated")

    monkeypatch.setattr("stackdsl.runtime.recorder.run_program", never)
    assert main(["animate", str(files / "stands.yaml"), "-o", str(files / "a.gif"), "--fps", "51"]) == 2
    assert capsys.readouterr().err.strip() == "--fps: a GIF plays at most 50 frames a second, not 51"


def _full_disk_ffmpeg(monkeypatch):
    """ffmpeg on a full disk: the frames go in, the file gets its media data, and writing its
    trailer (the movie header, ``moov``) fails; ffmpeg exits and imageio-ffmpeg says nothing."""
    import imageio_ffmpeg

    def write_frames(path, size, **kwargs):
        with open(path, "wb") as f:
            f.write((12).to_bytes(4, "big") + b"ftypisom" + (16).to_bytes(4, "big") + b"mdat" + b"\0" * 8)
        while True:
            yield

    monkeypatch.setattr(imageio_ffmpeg, "write_frames", write_frames)


@pytest.mark.parametrize(("free", "why"), [(0, "No space left on device"), (10 << 30, "ffmpeg could not write the whole clip")])
def test_an_mp4_ffmpeg_could_not_finish_is_exit_2_naming_the_file(files, capsys, monkeypatch, free, why):
    """ffmpeg failed writing the clip's trailer on a full disk ("moov atom not found" after), and
    animate said "wrote ..." and exited 0."""
    pytest.importorskip("imageio_ffmpeg")
    import shutil

    record = files / "stands.npz"
    assert main(["run", str(files / "stands.yaml"), "--record", str(record)]) == 0
    capsys.readouterr()
    _full_disk_ffmpeg(monkeypatch)
    monkeypatch.setattr(shutil, "disk_usage", lambda path: shutil._ntuple_diskusage(10 << 30, 10 << 30, free))
    out = files / "a.mp4"
    assert main(["animate", str(record), "-o", str(out), "--size", "64x64"]) == 2
    said = capsys.readouterr()
    assert "wrote" not in said.out and said.err == f"stackdsl: {out}: {why}\n"
    assert sorted(p.name for p in files.iterdir()) == ["stands.npz", "stands.yaml", "tips.yaml"]  # no clip, no part left


def test_a_graph_on_a_full_disk_names_the_file_and_leaves_none(files, capsys, monkeypatch):
    import errno

    from matplotlib.figure import Figure

    def savefig(self, path, **kwargs):
        open(path, "wb").close()  # the file made, nothing written into it
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Figure, "savefig", savefig)
    out = files / "g.png"
    assert main(["graph", str(files / "stands.yaml"), "-o", str(out)]) == 2
    assert capsys.readouterr().err == f"stackdsl: {out}: No space left on device\n"
    assert sorted(p.name for p in files.iterdir()) == ["stands.yaml", "tips.yaml"]


def test_the_default_moment_is_the_one_the_expectations_judge(files, capsys, monkeypatch):
    """A domino row expecting 'toppled' was drawn at its collapse, its first domino tipping: the
    picture, the replay's opening frame and a report's picture now show what the expectations
    judge (the end for final positions, the collapse for a collapse level); --at still chooses."""
    import dataclasses

    from stackdsl.draw import animate, artefacts, graphplot, render, replay

    seen: list[object] = []
    for expect, at in (("{moved: [top]}", "end"), ("{collapse: 2}", "collapse")):
        scene = files / f"{at}.yaml"
        scene.write_text(TIPS + f"expect: {expect}\n")
        record = files / f"{at}.npz"
        assert main(["run", str(scene), "--record", str(record)]) == 0
        trajectory = load_trajectory(record)
        assert trajectory.collapse_time is not None and trajectory.shown_at == at
        assert replay.replay_data(trajectory)["opening"] == at
        capsys.readouterr()
        assert main(["render", str(record), "-o", str(files / "x.png")]) == 0
        assert f"the run at {at}, " in capsys.readouterr().out
        seen.clear()
        with monkeypatch.context() as m:  # what a report's (and the pytest plugin's) picture is drawn at
            m.setattr(render, "picture", lambda t, when, path, **k: seen.append(when))
            for module, name in ((animate, "animate"), (graphplot, "plot_graph"), (replay, "write_replay")):
                m.setattr(module, name, lambda *a, **k: None)  # only the picture's moment is looked at
            artefacts.draw_run(trajectory, files / f"report-{at}")
        assert seen == [at]
    assert main(["render", str(files / "end.npz"), "--at", "collapse", "-o", str(files / "x.png")]) == 0
    assert "the run at collapse, " in capsys.readouterr().out
    odd = dataclasses.replace(load_trajectory(files / "end.npz"), meta={**trajectory.meta, "judged_at": "later"})
    odd.save(files / "odd.npz")
    with pytest.raises(ValueError, match="judged_at is neither 'collapse' nor 'end'"):
        load_trajectory(files / "odd.npz")


def test_an_unknown_matplotlib_backend_in_the_environment_is_bad_input(tmp_path):
    # MPLBACKEND=nonsense made render exit 3 (matplotlib's ValueError): it is the user's environment
    import os
    import subprocess
    import sys

    (tmp_path / "t.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: 2}}\ntiming: {settle: 0.2 s}\n")
    env = {**os.environ, "MPLBACKEND": "nonsense"}
    env.pop("STACKDSL_TRACEBACK", None)
    done = subprocess.run(
        [sys.executable, "-m", "stackdsl", "render", "t.yaml", "-o", "a.png"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith("MPLBACKEND: 'nonsense' in the environment is not a backend matplotlib knows")
    assert "Traceback" not in done.stderr and not (tmp_path / "a.png").exists()


@pytest.mark.parametrize("command, out", [("render", "a.png"), ("animate", "a.gif")])
def test_a_picture_of_more_pixels_than_fit_in_memory_is_refused(command, out, tmp_path, capsys, monkeypatch):
    # render --size 4096x4096 peaked at 2047 MiB; 8 million pixels at most keeps it under 1.5 GB
    monkeypatch.setattr("stackdsl.runtime.recorder.record_program", lambda *a, **k: pytest.fail("simulated"))
    scenario = str(ROOT / "scenarios" / "vee_stands.yaml")
    assert main([command, scenario, "--size", "4096x4096", "-o", str(tmp_path / out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("--size: 4096x4096: 16.8 million pixels; a picture may have at most 8 million") and "\n" not in err
    assert list(tmp_path.iterdir()) == []

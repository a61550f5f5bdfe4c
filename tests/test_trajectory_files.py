"""Trajectory files (.npz) are checked as scenario files are: a bad one is one line naming the
file and what is wrong, exit 2, before anything is drawn; never a blame on --at, never a huge
allocation."""

from __future__ import annotations

import io
import json
import os
import zipfile
from pathlib import Path

import numpy as np
import pytest

from stackdsl import compile_scenario, parse_scenario
from stackdsl.cli.main import main
from stackdsl.runtime.recorder import record_program
from stackdsl.runtime.trajectory import MAX_TRAJECTORY_BYTES, load_trajectory


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("trajectory") / "good.npz"
    record_program(compile_scenario(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 1}}\ntiming: {settle: 0.5 s}")))[
        1
    ].save(path)
    return path


def arrays_of(path: Path) -> dict[str, np.ndarray]:
    with np.load(path) as data:
        return {name: data[name] for name in data.files}


def rewrite(good: Path, target: Path, **changes: object) -> Path:
    arrays = arrays_of(good)
    for name, value in changes.items():
        if value is None:
            arrays.pop(name)
        else:
            arrays[name] = value  # type: ignore[assignment]
    np.savez(target, **arrays)
    return target


def rewrite_compressed(good: Path, target: Path, **changes: np.ndarray) -> Path:
    """As :func:`rewrite`, compressed: a small file whose arrays are large once read."""
    np.savez_compressed(target, **{**arrays_of(good), **changes})
    return target


def header_without(good: Path, key: str) -> np.ndarray:
    header = json.loads(str(arrays_of(good)["header"]))
    header.pop(key)
    return np.array(json.dumps(header))


def header_with(good: Path, key: str, value: object) -> np.ndarray:
    header = json.loads(str(arrays_of(good)["header"]))
    header[key] = value
    return np.array(json.dumps(header))


def huge_claim(good: Path, target: Path) -> Path:
    """A member whose .npy header claims a 21.8 TiB array over a few bytes of data."""
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(buffer, {"descr": "<f8", "fortran_order": False, "shape": (3_000_000_000_000,)})
    with zipfile.ZipFile(good) as source, zipfile.ZipFile(target, "w") as out:
        for info in source.infolist():
            data = buffer.getvalue() + b"\0" * 64 if info.filename == "times.npy" else source.read(info)
            out.writestr(info.filename, data)
    return target


CASES = {
    "no meta": (lambda g, t: rewrite(g, t, header=header_without(g, "meta")), "its header has no meta record"),
    "another scenario's arrays": (
        lambda g, t: rewrite(g, t, row_position=np.zeros((3, 3))),
        "its 'row_position' array has 3 rows, the others",
    ),
    "wrong columns": (
        lambda g, t: rewrite(g, t, half_extents=np.ones((len(arrays_of(g)["ids"]), 2))),
        "its 'half_extents' array has 2 columns, not 3",
    ),
    "NaN positions": (
        lambda g, t: rewrite(g, t, row_position=np.full_like(arrays_of(g)["row_position"], np.nan)),
        "its 'row_position' array holds NaN or infinite values",
    ),
    "a body that is not there": (
        lambda g, t: rewrite(g, t, row_body=arrays_of(g)["row_body"] + 99),
        "its 'row_body' array points outside",
    ),
    "text in a number array": (
        lambda g, t: rewrite(g, t, times=np.array(["a"] * len(arrays_of(g)["times"]))),
        "its 'times' array holds <U1 values",
    ),
    "a missing array": (lambda g, t: rewrite(g, t, row_state=None), "it has no 'row_state' array"),
    "another run's ground offset": (
        lambda g, t: rewrite(g, t, ground_offset=np.zeros((len(arrays_of(g)["times"]) + 2, 3))),
        "its 'ground_offset' array has",
    ),
    "an infinite ground offset": (
        lambda g, t: rewrite(g, t, ground_offset=np.full((len(arrays_of(g)["times"]), 3), np.inf)),
        "its 'ground_offset' array holds NaN or infinite values",
    ),
    "zero quaternions": (
        lambda g, t: rewrite(g, t, row_orientation=np.zeros_like(arrays_of(g)["row_orientation"])),
        "its 'row_orientation' array holds a quaternion of length 0 (row 0), not a unit one",
    ),
    "a huge quaternion": (
        lambda g, t: rewrite(g, t, row_orientation=np.tile([0.0, 0.0, 0.0, 1e308], (len(arrays_of(g)["row_body"]), 1))),
        "its 'row_orientation' array holds a quaternion of length 1e+308",
    ),
    "positions at 1e300 m": (
        lambda g, t: rewrite(g, t, row_position=np.full_like(arrays_of(g)["row_position"], 1e300)),
        "its 'row_position' array holds a coordinate of 1e+300 m, beyond 1000 km from the origin",
    ),
    "a position just beyond the bound": (
        lambda g, t: rewrite(g, t, row_position=arrays_of(g)["row_position"] + [0.0, -1.0001e6, 0.0]),
        "beyond 1000 km from the origin",
    ),
    "a ground offset 1e9 m away": (
        lambda g, t: rewrite(g, t, ground_offset=np.full((len(arrays_of(g)["times"]), 3), 1e9)),
        "its 'ground_offset' array holds a coordinate of 1e+09 m",
    ),
    "a 2 km brick": (
        lambda g, t: rewrite(g, t, half_extents=np.full_like(arrays_of(g)["half_extents"], 1000.0)),
        "its 'half_extents' array holds 1e+03 m, beyond a brick's",
    ),
    "two bricks of one id": (
        lambda g, t: rewrite(g, t, ids=np.array(["L01.1"] * len(arrays_of(g)["ids"]))),
        "two bodies have the id 'L01.1'",
    ),
    "a fixture of a brick's id": (
        lambda g, t: rewrite(
            g,
            t,
            fixture_ids=np.array(["L01.2"]),
            fixture_half_extents=np.full((1, 3), 0.01),
            fixture_positions=np.array([[1.0, 0.0, 0.01]]),
            fixture_orientations=np.array([[0.0, 0.0, 0.0, 1.0]]),
        ),
        "two bodies have the id 'L01.2'",
    ),
    "a brick named as the ground": (
        lambda g, t: rewrite(g, t, ids=np.array(["ground", *arrays_of(g)["ids"][1:]])),
        "a body has the ground's id 'ground'",
    ),
    "an id with a quote and a tag": (
        lambda g, t: rewrite(g, t, ids=np.array(['a"</script>', *arrays_of(g)["ids"][1:]])),
        "not letters, digits, '_', '.' and '-'",
    ),
    "an empty id": (lambda g, t: rewrite(g, t, ids=np.array(["", *arrays_of(g)["ids"][1:]])), "a body's id is ''"),
    "a header nested 100000 deep": (
        lambda g, t: rewrite(g, t, header=np.array("[" * 100_000 + "]" * 100_000)),
        "its header record is nested too deeply",
    ),
    "an event at NaN s": (
        lambda g, t: rewrite(g, t, header=header_with(g, "events", [{"time": float("nan"), "kind": "place", "brick": "L01.1"}])),
        "an event's time is NaN or infinite",
    ),
    "21.8 TiB claimed": (huge_claim, "times.npy claims 24000000000000 bytes but holds"),
    "65 MiB on disk": (lambda g, t: (t.write_bytes(b""), os.truncate(t, 65 << 20), t)[2], "it is larger than 64 MiB (65 MiB)"),
    "65 MiB of zeros, compressed": (
        lambda g, t: rewrite_compressed(g, t, row_state=np.zeros(65 << 20, dtype=np.int8)),
        "its arrays take more than 64 MiB once read",
    ),
    "a text file": (lambda g, t: (t.write_text("hello\n" * 10), t)[1], "it is not a whole .npz archive"),
}


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_a_bad_trajectory_file_is_one_line_naming_it(case, good, tmp_path, capsys):
    make, what = CASES[case]
    bad = make(good, tmp_path / "bad.npz")
    with pytest.raises(ValueError, match="not a stackdsl trajectory") as error:
        load_trajectory(bad)
    assert what in str(error.value) and "\n" not in str(error.value)
    assert main(["render", str(bad), "-o", str(tmp_path / "x.png")]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"{bad}: ") and what in line and "--at" not in line
    assert not (tmp_path / "x.png").exists()
    for argv in (["export", str(bad), "--mjcf", str(tmp_path / "x.xml"), "--urdf", str(tmp_path / "x.urdf")],):
        assert main(argv) == 2
        (line,) = capsys.readouterr().err.strip().splitlines()
        assert line.startswith(f"{bad}: ") and what in line
    assert not (tmp_path / "x.xml").exists() and not (tmp_path / "x.urdf").exists()


def test_a_good_trajectory_still_reads_and_the_cap_is_far_above_a_real_run(good):
    trajectory = load_trajectory(good)
    assert len(trajectory.times) > 1 and good.stat().st_size * 100 < MAX_TRAJECTORY_BYTES


def test_a_file_written_before_the_ground_offset_was_recorded_reads_as_a_still_ground(good, tmp_path, capsys):
    """A trajectory saved by an earlier stackdsl has no ground_offset: it loads, draws and
    replays, its fixtures at rest at every frame."""
    old = rewrite(good, tmp_path / "old.npz", ground_offset=None)
    assert "ground_offset" not in arrays_of(old)
    trajectory = load_trajectory(old)
    assert trajectory.ground_offset.shape == (len(trajectory.times), 3) and not trajectory.ground_offset.any()
    assert not trajectory.frame(-1).ground_offset.any()
    assert main(["render", str(old), "-o", str(tmp_path / "old.png")]) == 0
    assert main(["replay", str(old), "-o", str(tmp_path / "replay")]) == 0
    assert (tmp_path / "old.png").exists() and (tmp_path / "replay" / "replay.html").exists()

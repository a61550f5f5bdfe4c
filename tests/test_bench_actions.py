"""The actions bench: the lean MuJoCo peer driving the hands (a pull, a push, a shake table), its
verdicts against a scene's expectations, the cells timed alike, the folder's check and the sweep
of Jenga pulls against the peer."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

from stackdsl.bench.actions import (
    Cell,
    Run,
    Scene,
    action_scenes,
    domino_row,
    format_cells,
    peer_verdicts,
    program_for,
    run_cells,
    tiny_scenes,
)
from stackdsl.bench.lean import LeanOutcome, tipped
from stackdsl.bench.lean_mujoco import _sink, mjcf, run_lean
from stackdsl.lang.loader import parse_scenario

ROOT = Path(__file__).resolve().parent.parent


def tiny(name: str) -> Scene:
    return next(s for s in tiny_scenes() if s.name == name)


def test_the_family_is_the_shipped_scenes_and_those_written_like_them():
    scenes = action_scenes(ROOT / "scenarios")
    assert [s.name for s in scenes] == [
        "Jenga 12 stands",
        "Jenga 12 falls",
        "Jenga 18 stands",
        "Jenga 18 falls",
        "Jenga 12 push",
        "30 dominoes",
        "120 dominoes",
        "shake below",
        "shake above",
    ]
    taller = parse_scenario(scenes[2].text, "t.yaml")
    assert taller.structure.tower.levels == 18 and taller.expect.stands
    falls = parse_scenario(scenes[3].text, "t.yaml")  # it falls once all 18 levels are placed, not at 12
    assert falls.structure.tower.levels == 18 and "18" in str(falls.expect.collapse)
    push = parse_scenario(scenes[4].text, "p.yaml")  # a finger slides the middle block of level 5 out
    assert [a.push.target.brick for a in push.actions] == ["L05.2"] and push.expect.moved is not None
    row = parse_scenario(domino_row(120), "row.yaml")
    assert len(row.structure.bricks) == 120 and row.expect.toppled.count == "all"


def test_the_peers_mjcf_has_the_hands_and_the_table():
    pushed = mjcf(program_for(tiny("4 dominoes").text, "t.yaml", "MuJoCo lean"))
    assert pushed.count("<freejoint/>") == 5 and 'gravcomp="1"' in pushed  # 4 dominoes and the finger
    shaken = mjcf(program_for(tiny("tiny shake").text, "t.yaml", "MuJoCo lean"), tolerance=1e-10)
    assert 'name="table"' in shaken and shaken.count('type="slide"') == 2 and 'tolerance="1e-10"' in shaken


def test_the_peers_ground_has_the_pair_friction_of_a_scene_of_two_materials():
    """Pine bricks (0.5) on an ice ground: MuJoCo's own rule takes the larger friction of two
    geoms, so the peer's stack stood where the scene's pair (the geometric mean, as stackdsl's
    engines have it) slides; its ground now carries the pair's coefficient, first by priority.
    A scene of one material keeps the ground as it was."""
    text = """stackdsl: 1
engine: {backend: mujoco}
materials:
  pine: {density: 500 kg/m^3, friction: 0.5}
  ice: {density: 900 kg/m^3, friction: 0.05}
brick_types: {b: {size: [120 mm, 24 mm, 8 mm], material: pine}}
ground: {material: ice}
structure: {tower: {levels: 2, bricks_per_layer: 2, spacing: 96 mm, turn: 90, brick: b}}
"""
    two = mjcf(program_for(text, "t.yaml", "MuJoCo lean"))
    pair = math.sqrt(0.5 * 0.05)
    assert f'friction="{pair} 0.005 0.0001" priority="1"' in two
    one = mjcf(program_for(text.replace("material: ice}", "material: pine}"), "t.yaml", "MuJoCo lean"))
    assert 'friction="0.5 0.005 0.0001" solref' in one and "priority" not in one


def test_the_peers_bricks_of_two_materials_touch_with_their_pair_friction():
    """An ice brick lying on a pine one, the table shaken at 3.16 m/s^2: the pair slips at 2.19
    (sqrt(0.5 * 0.1) g). MuJoCo's own rule took the larger coefficient (0.5), and the peer's top
    brick stood where the extension and both tuned engines slid it 132 to 139 mm off the end.
    Each two bodies of different materials now touch as an explicit pair of the geometric mean,
    their own contact excluded; with the table and the plane under it too."""
    text = """stackdsl: 1
engine: {backend: mujoco}
materials: {ice: {density: 460 kg/m^3, friction: 0.1}}
brick_types: {icy: {size: [120 mm, 24 mm, 8 mm], material: ice}}
structure:
  bricks:
    - {id: base, at: [0, 0, 4 mm]}
    - {id: top, at: [40 mm, 0, 12 mm], brick: icy}
actions:
  - shake: {amplitude: 80 mm, frequency: 1 Hz, duration: 4 s, direction: [1, 0], at: after level 2}
"""
    program = program_for(text, "t.yaml", "MuJoCo lean")
    said = mjcf(program)
    pair = math.sqrt(0.5 * 0.1)
    assert f'<pair geom1="g base" geom2="g top" friction="{pair} {pair} ' in said
    assert '<exclude body1="base" body2="top"/>' in said and '<exclude body1="table" body2="top"/>' in said
    assert '<exclude body1="table" body2="base"/>' not in said  # of the ground's own coefficient
    slid = run_lean(program, settle=None)
    assert slid.moved["top"] > 0.1 and slid.moved["base"] < 0.001, slid.moved
    assert "<contact>" not in mjcf(program_for(text.replace("brick: icy", "brick: kapla"), "t.yaml", "MuJoCo lean"))


def test_the_peer_pushes_a_row_over_and_pulls_a_block_out():
    row = program_for(tiny("4 dominoes").text, "t.yaml", "MuJoCo lean")
    pushed = run_lean(row, settle=None)
    assert len(pushed.toppled) == 4 and pushed.level == 1
    assert peer_verdicts(parse_scenario(tiny("4 dominoes").text, "t.yaml").expect, row, pushed) == (True, "4 of 4 toppled")
    both = tiny("4 dominoes").text.replace("  toppled: all", "  collapse: 1\n  toppled: all")  # it asks both
    said = peer_verdicts(parse_scenario(both, "t.yaml").expect, row, pushed)
    assert said[0] and said[1].startswith("collapse at level 1") and said[1].endswith("; 4 of 4 toppled"), said
    jenga = program_for(tiny("tiny Jenga").text, "t.yaml", "MuJoCo lean")
    pulled = run_lean(jenga, settle=None)
    assert pulled.removed == ("L02.1",) and "L02.1" not in pulled.moved  # out of the scene, not judged
    assert len(pulled.moved) == 14


def test_the_shake_table_carries_the_stack_and_comes_back():
    shake = program_for(tiny("tiny shake").text, "t.yaml", "MuJoCo lean")
    lean = run_lean(shake, settle=None)
    assert lean.level is None and max(lean.moved.values()) < shake.collapse_threshold
    assert lean.simulated == pytest.approx(shake.duration, abs=0.02)


def test_a_brick_is_let_go_above_the_actual_top_of_what_it_rests_on():
    low = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 0.0, 0.008]])
    high = np.array([[0.12, 0.024, 0.008], [0.62, 0.024, 0.008], [0.12, 0.024, 0.016]])
    tops = np.array([0.0075, 0.0060])  # the first has sunk 0.5 mm; the second is not under the third
    assert _sink(2, low, high, tops, set()) == pytest.approx(0.0005)
    assert _sink(2, low, high, tops, {0}) == 0.0  # pulled out: nothing under it
    assert _sink(0, low, high, tops, set()) == 0.0


def test_tipped_is_past_the_tipping_angle():
    half = np.array([[0.004, 0.012, 0.06]] * 2)  # a domino on end
    up, fallen = np.eye(3), np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    assert tipped(half, np.stack([up, up]), np.stack([up, fallen])).tolist() == [False, True]


def test_the_peers_verdicts_follow_the_expectations():
    text = "stackdsl: 1\nstructure: {tower: {levels: 3}}\nexpect: {collapse: 3, stays: 1-2}\n"
    program = program_for(text, "t.yaml", "MuJoCo lean")
    expect = parse_scenario(text, "t.yaml").expect
    ids = [p.id for p in program.placements]
    still = {b: 0.0 for b in ids}
    fell = LeanOutcome(3, 1.0, 0.5, 3.0, 100, moved={**still, ids[-1]: 0.05})
    assert peer_verdicts(expect, program, fell) == (True, f"collapse at level 3 ({ids[-1]} ended 50.0 mm from its place)")
    early = LeanOutcome(2, 1.0, 0.5, 3.0, 100, moved={**still, ids[0]: 0.05})
    passed, words = peer_verdicts(expect, program, early)
    assert not passed and "collapse: collapse at level 2 (" in words and "stays: 1 brick of level 1 moved" in words
    # a stand says how far it came from 1 mm, as compare's cell does
    stood = parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 3}}\nexpect: {stands: true}\n", "s.yaml").expect
    crept = LeanOutcome(None, 1.0, 0.5, 3.0, 100, moved={**still, ids[-1]: 0.0022})
    assert peer_verdicts(stood, program, crept) == (True, "stands, moved 2.2 mm at most")
    assert peer_verdicts(stood, program, LeanOutcome(None, 1.0, 0.5, 3.0, 100, moved=still)) == (True, "stands")


def test_the_table_marks_a_side_that_disagrees_and_says_how_it_was_timed():
    cells = [
        Cell("s", "extension", 0.5, (0.4, 0.5, 0.6), True, "stands", True),
        Cell("s", "MuJoCo lean", 5.0, (5.0, 5.0, 5.1), False, "stands: collapse at level 3", True),
    ]
    table = format_cells(cells, 3)
    assert "| s | extension | PASS: stands | 0.50 | 0.40 0.50 0.60 | 10.0 |" in table
    assert "FAIL (disagrees with the expectation): stands: collapse at level 3" in table
    assert "3 run(s) in rounds, each in a fresh process" in table
    # a new user had to infer what the last column is: it is said under the table
    assert "peer / this: the MuJoCo lean peer's median wall time over the row's (above 1" in table


def test_the_table_ends_with_each_sides_overall_ratio():
    from stackdsl.bench.actions import overall

    cells = [
        Cell("long", "extension", 2.0, (2.0,), True, "stands", True),
        Cell("long", "MuJoCo lean", 8.0, (8.0,), True, "stands", True),
        Cell("short", "extension", 1.0, (1.0,), False, "stands: collapse at level 2", True),
        Cell("short", "MuJoCo lean", 1.0, (1.0,), True, "stands", True),
        Cell("refused", "extension", 0.0, (0.0,), None, "too fast", True),
    ]
    # summed: 9 s over 3 s; the rows' 4x and 1x: 2x their geometric mean
    assert overall(cells) == [
        "overall, extension: 9.00 s of the peer's over 3.00 s = 3.0x summed, 2.0x the geometric mean of 2 rows; 1 of 2 PASS",
        "overall, MuJoCo lean: 2 of 2 PASS",
    ]
    assert overall(cells)[0] in format_cells(cells, 1)
    # a row the peer could not run (a projectile) is counted apart: a new user read "9 of 9 PASS"
    # above a check that said "9 passed, 1 failed"
    cells.append(Cell("thrown", "extension", 0.5, (0.5,), False, "stays: levels 4-9 moved", True))
    cells.append(Cell("thrown", "MuJoCo lean", 0.0, (0.0,), None, "no projectiles", True))
    assert overall(cells)[0].endswith("1 of 2 PASS (and 0 of 1 PASS where the peer did not run)")


def test_the_cheaper_peer_runs_on_pyramidal_cones_and_gets_its_own_ratios():
    """An independent reviewer's MuJoCo peer on pyramidal cones stood where the tuned peer fell and
    ran twice as fast: the bench now runs that peer too, and gives every side's ratio against it."""
    from stackdsl.bench.actions import CHEAP_PEER, program_for

    text = tiny("tiny Jenga").text
    tuned, cheap = (program_for(text, "t.yaml", side).engine for side in ("MuJoCo lean", CHEAP_PEER))
    assert tuned.elliptic_cones and tuned.impratio == 10.0 and tuned.sleep_tolerance == 1e-4
    assert not cheap.elliptic_cones and cheap.impratio == 1.0 and cheap.sleep_tolerance == 1e-3
    assert cheap.model_copy(update={"elliptic_cones": True, "impratio": 10.0, "sleep_tolerance": 1e-4}) == tuned
    cells = [
        Cell("s", "extension", 0.5, (0.5,), True, "stands", True),
        Cell("s", "MuJoCo lean", 5.0, (5.0,), True, "stands", True),
        Cell("s", CHEAP_PEER, 2.0, (2.0,), True, "stands", True),
    ]
    table = format_cells(cells, 1)
    assert "| s | extension | PASS: stands | 0.50 | 0.50 | 10.0 |" in table  # the column: the tuned peer's
    assert f"against the {CHEAP_PEER} peer:\n  overall, extension: 2.00 s of the peer's over 0.50 s = 4.0x summed" in table


def test_a_cell_runs_in_a_fresh_process_on_each_side():
    seen: list[Run] = []
    cells = run_cells([tiny("4 dominoes")], ["extension", "MuJoCo lean"], repeats=1, jobs=2, progress=seen.append)
    assert len(seen) == 2 and [c.side for c in cells] == ["extension", "MuJoCo lean"]
    assert all(c.passed and c.wall > 0 and len(c.walls) == 1 for c in cells), cells
    assert [c.verdict for c in cells] == ["4 of 4 toppled"] * 2  # both sides say a count alike


def test_the_pulls_table_judges_each_side_against_the_sweeps_expectation():
    from stackdsl.bench.pulls import Side, format_sides, template

    t, expect = template(ROOT / "sweeps/jenga_pulls.yaml", samples=40)
    stood = (None,) * 40  # P(stands) >= 0.9 passes
    fell = (None,) * 26 + (12,) * 14  # 26 of 40 stood: it fails
    sides = [Side("extension", 10.0, stood + fell), Side("MuJoCo lean", 50.0, fell + fell)]
    table = format_sides(sides, t, expect, jobs=1, cells=2)
    assert "| extension | 10.0 | 8.00 | 66 of 80 | 1 / 1 / 0 | 5.0 |" in table
    assert "| MuJoCo lean | 50.0 | 1.60 | 52 of 80 | 0 / 2 / 0 |  |" in table
    assert f"extension, {t.label(1)}: FAIL, P(stands) >= 0.9 expected" in table
    assert f"MuJoCo lean, {t.label(0)}: FAIL" in table and "alike on 66 of 80 samples" in table
    cheap = Side("MuJoCo lean pyramidal", 25.0, stood + stood)  # a cheaper peer: its ratio and agreement too
    table = format_sides([*sides, cheap], t, expect, jobs=1, cells=2)
    assert "| MuJoCo lean pyramidal | 25.0 | 3.20 | 80 of 80 | 2 / 0 / 0 | 2.0 |" in table
    assert "MuJoCo lean pyramidal / extension: 2.5" in table
    assert "extension and MuJoCo lean: stands or falls alike on 66 of 80 samples" in table
    assert "extension and MuJoCo lean pyramidal: stands or falls alike on 66 of 80 samples" in table
    few = format_sides([Side("extension", 1.0, (None, None))], template(ROOT / "sweeps/jenga_pulls.yaml", 2)[0], expect, 1, 1)
    assert "| 0 / 0 / 1 |" in few and "INCONCLUSIVE" in few and "samples would decide it" in few


@pytest.mark.slow
def test_the_cli_runs_the_quick_family_and_the_pulls(tmp_path, capsys, monkeypatch):
    from stackdsl.cli.main import main

    monkeypatch.chdir(ROOT)
    assert main(["bench", "actions", "--quick", "--repeats", "1", "--sides", "extension,MuJoCo lean"]) == 0
    out = capsys.readouterr().out
    rows = [line for line in out.splitlines() if line.startswith("| tiny") or line.startswith("| 4 dominoes")]
    assert len(rows) == 6 and all("| PASS" in r or "| FAIL (disagrees" in r for r in rows)
    assert sum("| extension | PASS" in r for r in rows) == 3  # the reference meets every expectation
    assert "fresh process" in out and "load average" in out
    sweep = tmp_path / "pulls.yaml"
    sweep.write_text(
        (ROOT / "sweeps/jenga_pulls.yaml")
        .read_text()
        .replace("levels: 12", "levels: 4")
        .replace("level 12", "level 4")
        .replace("L05.2", "L02.2"),
        encoding="utf-8",
    )
    text = sweep.read_text()
    sweep.write_text(text[: text.index("  grid:")] + "expect:\n  p_stands: '>= 0.9'\n", encoding="utf-8")
    assert main(["bench", "pulls", str(sweep), "--samples", "2"]) == 0
    out = capsys.readouterr().out
    assert "| extension |" in out and "| MuJoCo lean |" in out and "alike on" in out
    assert "judged against the file's P(stands) >= 0.9" in out


@pytest.mark.slow
def test_the_folder_bench_times_the_check(tmp_path):
    from stackdsl.bench.actions import check_times

    (tmp_path / "t.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: 2}}\nexpect: {stands: true}\n", encoding="utf-8")
    (one, auto) = check_times(tmp_path, ("1", "auto"), repeats=1)
    assert one.exit_code == auto.exit_code == 0 and one.wall > 0 and auto.jobs == "auto"
    assert one.summary.startswith("1 scenarios: 1 passed")


def test_a_folder_check_that_refuses_its_input_says_why_under_the_table(tmp_path):
    """A new user's folder with refused files read exit code 2 and an empty last line, over a time
    that measured the refusal: the refusal's words (on stderr) are shown, and a note says so."""
    from stackdsl.bench.actions import check_times, format_check_times

    (tmp_path / "bad.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: -2}}\n", encoding="utf-8")
    (one,) = check_times(tmp_path, ("1",), repeats=1)
    assert one.exit_code == 2 and one.summary, one
    table = format_check_times([one], tmp_path, 1)
    assert "exit code 2: check refused bad input" in table and one.summary.replace("|", "/") in table


def test_a_folder_s_warnings_are_said_once_under_its_check_and_not_by_each_cell(tmp_path, recwarn):
    """A scene that warns (two pulls written out of the order of their times) was reported by
    every run of every cell in Python's words, the compiler's source line included: the check's
    warning is said once under its table, in stackdsl's words, and a cell's run says none."""
    from stackdsl.bench.actions import Scene, check_times, format_check_times, run_cell

    text = (
        "stackdsl: 1\nstructure: {tower: {levels: 2, bricks_per_layer: 3, spacing: 25 mm}}\ntiming: {interval: 0.5 s}\n"
        "actions:\n  - remove: {brick: L02.1, at: 5 s, speed: 60 mm/s}\n  - remove: {brick: L02.3, at: 4 s, speed: 60 mm/s}\n"
    )
    (tmp_path / "late.yaml").write_text(text, encoding="utf-8")
    (check,) = check_times(tmp_path, ("1",), repeats=1)
    (said,) = check.warnings
    assert said.startswith(f"{tmp_path / 'late.yaml'}:6:32: warning: actions[1].remove.at: starts at 4 s")
    table = format_check_times([check, check], tmp_path, 1)  # two runs that said it: said once
    assert table.count(said) == 1 and table.index(said) > table.index("| 1 |")
    run = run_cell(Scene("late.yaml", text, str(tmp_path / "late.yaml")), "extension")
    assert run.passed and not [w for w in recwarn if "remove.at" in str(w.message)]


def test_the_scenes_run_in_the_order_given(monkeypatch, capsys):
    import stackdsl.bench.actions as actions
    from stackdsl.cli.main import main

    asked: list[str] = []

    def record(scenes, sides, repeats, jobs, progress):
        asked.extend(s.name for s in scenes)
        return []

    monkeypatch.setattr(actions, "run_cells", record)
    monkeypatch.chdir(ROOT)
    assert main(["bench", "actions", "--scenes", "shake above,Jenga 12 stands", "--sides", "extension"]) == 0
    assert asked == ["shake above", "Jenga 12 stands"]


def test_the_folder_bench_runs_each_scene_on_the_sides_given(tmp_path, monkeypatch, capsys):
    """A new user on MuJoCo could not bench a folder on the extension there: the cells were the
    file's own settings and the lean peer only. ``--sides`` names them, the first the row the
    summary sums; an unknown one is refused before anything runs."""
    import stackdsl.bench.actions as actions
    from stackdsl.cli.main import main

    (tmp_path / "t.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: 2}}\n", encoding="utf-8")
    asked: list[tuple[str, ...]] = []

    def record(scenes, sides, repeats, jobs, progress):
        asked.append(tuple(sides))
        return []

    monkeypatch.setattr(actions, "run_cells", record)
    monkeypatch.setattr(actions, "check_times", lambda folder, jobs, repeats: [])
    monkeypatch.setattr(actions, "format_check_times", lambda times, folder, count: "")
    assert main(["bench", "folder", str(tmp_path), "--sides", "MuJoCo extension,MuJoCo lean"]) == 0
    assert main(["bench", "folder", str(tmp_path)]) == 0
    assert asked == [("MuJoCo extension", "MuJoCo lean"), ("file's own settings", "MuJoCo lean")]
    assert "on MuJoCo extension" in capsys.readouterr().out
    assert main(["bench", "folder", str(tmp_path), "--sides", "tuned"]) == 2
    assert "--sides: unknown side 'tuned'" in capsys.readouterr().err
    # a side whose engine is not installed is refused before anything runs, as `bench actions` does
    # (a new user without the MuJoCo extra got the lean peer's cells refused one by one, and exit 0)
    monkeypatch.setitem(sys.modules, "mujoco", None)
    assert main(["bench", "folder", str(tmp_path), "--sides", "extension,MuJoCo lean"]) == 2
    assert "--sides: " in capsys.readouterr().err and asked == [
        ("MuJoCo extension", "MuJoCo lean"),
        ("file's own settings", "MuJoCo lean"),
    ]
    assert main(["bench", "folder", str(tmp_path), "--sides", "extension,MuJoCo lean", "--no-cells"]) == 0


@pytest.mark.parametrize(
    ("argv", "told"),
    [
        (["bench", "--sides", "extension", "--families", "upright"], "this table takes --settings, of: raw 240 Hz"),
        (["bench", "folder", "scenarios", "--settings", "extension report"], "this command takes --sides, of: file's own"),
        (["bench", "actions", "--settings", "extension report"], "this command takes --sides, of: extension,"),
    ],
)
def test_the_other_bench_commands_option_names_the_one_taken_here(argv, told, capsys):
    """A new user gave ``bench`` (the speed-against-error table) the ``--sides`` of ``bench
    actions``, and argparse read 'extension' as a benchmark's name ("invalid choice"); and gave
    ``bench folder`` the table's ``--settings``. Each is a usage error that names the option this
    command takes, and its values; nothing runs."""
    from stackdsl.cli.main import main

    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "is not an option of this command" in err and told in err


def test_a_benchmark_named_after_out_writes_its_tables_there(tmp_path, monkeypatch, capsys):
    """New users gave ``stackdsl bench --out DIR folder``: it printed its tables and wrote
    nothing, and said nothing of it. The tables now go there too, and the command says where."""
    import stackdsl.bench.actions as actions
    from stackdsl.cli.main import main

    (tmp_path / "t.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: 2}}\n", encoding="utf-8")
    monkeypatch.setattr(actions, "run_cells", lambda *args: [])
    monkeypatch.setattr(actions, "check_times", lambda folder, jobs, repeats: [])
    monkeypatch.setattr(actions, "format_check_times", lambda times, folder, count: "the check's table")
    out = tmp_path / "out"
    assert main(["bench", "--out", str(out), "folder", str(tmp_path), "--no-cells"]) == 0
    printed = capsys.readouterr().out
    written = (out / "bench-folder.txt").read_text(encoding="utf-8")
    assert "the check's table" in written and written in printed
    assert printed.rstrip().endswith(f"wrote {(out / 'bench-folder.txt').resolve()}")
    assert main(["bench", "folder", str(tmp_path), "--no-cells"]) == 0  # no --out: nothing written
    assert sorted(p.name for p in out.iterdir()) == ["bench-folder.txt"]
    after = tmp_path / "after"  # a new user wrote it after the benchmark's name: refused until now
    assert main(["bench", "folder", str(tmp_path), "--no-cells", "--out", str(after)]) == 0
    assert (after / "bench-folder.txt").read_text(encoding="utf-8") == written

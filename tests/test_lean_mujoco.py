"""The lean MuJoCo peer of the bench: MuJoCo's own loop on a stackdsl program, its answers
against the closed forms, and what it refuses."""

from __future__ import annotations

import pytest

from stackdsl import compile_scenario, parse_scenario
from stackdsl.verdicts.closed_form import single_file

pytest.importorskip("mujoco")

from stackdsl.bench.bench import DEFAULT_SETTINGS, LEAN_SLEEP_TOLERANCE, SETTINGS, Scene, measure, program_for
from stackdsl.bench.lean_mujoco import mjcf, run_lean
from stackdsl.runtime.run import RunOptions

PEER = f"engine: {{backend: mujoco, mode: tuned, sleep_tolerance: {LEAN_SLEEP_TOLERANCE}}}"


def program(structure: str, engine: str = PEER):
    return compile_scenario(parse_scenario(f"stackdsl: 1\nstructure: {{{structure}}}\n{engine}\n", "lean.yaml"))


@pytest.mark.parametrize("shift_mm", [9, 13])
def test_the_lean_peer_finds_the_single_file_stacks_closed_form(shift_mm):
    n = single_file(shift_mm / 1000)
    lean = run_lean(program(f"tower: {{levels: {n + 2}, bricks_per_layer: 1, turn: 0, shift: {shift_mm} mm}}"))
    assert lean.level == n
    assert lean.simulated < n + 2  # it stops once the collapse is decided, not at the program's end
    assert 0 < lean.engine < lean.wall and lean.steps > 0


def test_a_standing_tower_stands_to_the_end_and_sleeps():
    p = program("tower: {levels: 6}")
    lean = run_lean(p)
    assert lean.level is None and lean.simulated == pytest.approx(p.duration, abs=0.05)


def test_the_lean_peer_takes_mujoco_programs_without_fixtures_or_throws():
    with pytest.raises(ValueError, match="compiled for MuJoCo"):
        mjcf(program("tower: {levels: 2}", ""))
    thrown = "engine: {backend: mujoco}\nimpacts: [{id: h, projectile: kapla, target: {level: 2, side: +y}, speed: 1 m/s, at: after level 2}]"
    with pytest.raises(ValueError, match="no fixed bodies, no projectiles"):
        mjcf(program("tower: {levels: 2}", thrown))
    xml = mjcf(program("tower: {levels: 2}"))
    assert xml.count("<freejoint/>") == 4 and 'sleep="enable"' in xml and 'cone="elliptic"' in xml


@pytest.mark.slow
def test_the_bench_measures_the_lean_peer_as_a_cell():
    assert SETTINGS["MuJoCo lean"].lean
    n = single_file(0.011)
    scene = Scene("single file", 11, n + 2, f"tower: {{levels: {n + 2}, bricks_per_layer: 1, turn: 0, shift: 11 mm}}", n)
    cell = measure(scene, "MuJoCo lean", RunOptions(stop_at_collapse=True))
    assert cell.error == 0 and cell.collapse_level == n and cell.setting == "MuJoCo lean"
    assert 0 < cell.engine <= cell.wall and cell.bricks == n + 2


def test_the_lean_peer_lets_a_brick_go_the_scenes_drop_gap_above_its_pose(monkeypatch):
    import mujoco

    p = program("tower: {levels: 1}")
    first = p.placements[0]
    assert first.drop > 0
    seen = []
    forward = mujoco.mj_forward

    def watched(model, data):
        forward(model, data)
        seen.append(data.qpos[:3].copy())  # the first brick's free joint: its place after each forward

    monkeypatch.setattr(mujoco, "mj_forward", watched)
    run_lean(p)
    placed = seen[1]  # the first forward is the model's; the second places the first brick
    assert placed == pytest.approx([first.position[0], first.position[1], first.position[2] + first.drop], abs=1e-9)


@pytest.mark.parametrize("shift_mm", [11, 13])
def test_the_peers_sleep_tolerance_is_mujocos_default_and_keeps_the_level_of_the_tighter_one(shift_mm):
    n = single_file(shift_mm / 1000)
    scene = Scene(
        "single file", shift_mm, n + 2, f"tower: {{levels: {n + 2}, bricks_per_layer: 1, turn: 0, shift: {shift_mm} mm}}", n
    )
    chosen, tighter = program_for(scene, "MuJoCo lean"), program_for(scene, "MuJoCo lean 1e-4")
    assert chosen.engine.sleep_tolerance == LEAN_SLEEP_TOLERANCE == 1e-3  # MuJoCo's own default
    assert tighter.engine.sleep_tolerance == 1e-4
    assert run_lean(chosen).level == run_lean(tighter).level == n


def test_the_bench_runs_the_tighter_tolerance_only_when_asked():
    assert "MuJoCo lean" in DEFAULT_SETTINGS and "MuJoCo lean 1e-4" in SETTINGS
    assert "MuJoCo lean 1e-4" not in DEFAULT_SETTINGS

"""The lean pybullet peer of the bench (pybullet's own loop on a stackdsl program), and the
collapse watch every lean peer shares."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from stackdsl import compile_scenario, parse_scenario
from stackdsl.bench.bench import SETTINGS, Scene, measure
from stackdsl.bench.lean import CollapseWatch
from stackdsl.bench.lean_pybullet import run_lean as run_pybullet
from stackdsl.runtime.run import RunOptions, run_program
from stackdsl.verdicts.closed_form import single_file


def program(structure: str, engine: str = "engine: {mode: raw}"):
    return compile_scenario(parse_scenario(f"stackdsl: 1\nstructure: {{{structure}}}\n{engine}\n", "lean.yaml"))


def test_a_standing_tower_stands_to_the_end():
    p = program("tower: {levels: 3}")
    lean = run_pybullet(p)
    assert lean.level is None and lean.simulated == pytest.approx(p.duration, abs=0.02)
    assert 0 < lean.engine < lean.wall and lean.steps == pytest.approx(p.duration * 240, abs=16)


@pytest.mark.slow
@pytest.mark.parametrize("shift_mm", [9, 13])
def test_the_lean_loop_falls_where_raw_pybullet_in_stackdsls_loop_falls(shift_mm):
    # the same engine and settings: the peer's own loop must not change the answer by more than a level
    n = single_file(shift_mm / 1000)
    p = program(f"tower: {{levels: {n + 2}, bricks_per_layer: 1, turn: 0, shift: {shift_mm} mm}}")
    lean = run_pybullet(p)
    ours = run_program(p, RunOptions(stop_at_collapse=True, settle=0.0))
    assert ours.collapse is not None and lean.level is not None
    assert abs(lean.level - ours.collapse.level) <= 1, (lean.level, ours.collapse.level)
    assert lean.simulated < p.duration - 1.0  # it stopped once the collapse was decided


def test_the_lean_peers_settle_after_a_collapse_when_told_as_stackdsl_does():
    # the bench's --after-collapse times every side alike: each peer goes on that long, placing nothing
    from stackdsl.bench.lean_mujoco import run_lean as run_mujoco

    n = single_file(0.013)  # built 6 levels past its collapse: the peers stop placing at the decision
    structure = f"tower: {{levels: {n + 6}, bricks_per_layer: 1, turn: 0, shift: 13 mm}}"
    for run, engine in ((run_pybullet, "engine: {mode: raw}"), (run_mujoco, "engine: {backend: mujoco}")):
        p = program(structure, engine)
        stopped, settled = run(p), run(p, settle=1.5)  # past the next placement (one a second)
        assert stopped.level is not None and settled.level == stopped.level, (engine, stopped.level, settled.level)
        assert settled.simulated == pytest.approx(stopped.simulated + 1.5, abs=0.05), engine
        assert stopped.after_collapse < 0.001 < settled.after_collapse < settled.wall, engine
        assert settled.steps > stopped.steps
    assert 0 < len(settled.moved) < n + 6  # the MuJoCo peer's bricks never placed are left out


def test_the_lean_pybullet_peer_takes_pybullet_placements_only():
    with pytest.raises(ValueError, match="compiled for pybullet"):
        run_pybullet(program("tower: {levels: 2}", "engine: {backend: mujoco}"))
    thrown = "impacts: [{id: h, projectile: kapla, target: {level: 2, side: +y}, speed: 1 m/s, at: after level 2}]"
    with pytest.raises(ValueError, match="placements only"):
        run_pybullet(program("tower: {levels: 2}", thrown))


@pytest.mark.slow
def test_the_bench_measures_the_lean_pybullet_peer_as_a_cell():
    assert SETTINGS["pybullet lean"].lean and SETTINGS["pybullet lean"].mode == "raw"
    assert (SETTINGS["pybullet lean"].backend, SETTINGS["MuJoCo lean"].backend) == ("pybullet", "mujoco")
    scene = Scene("upright", 2, 2, "tower: {levels: 2}", None)
    cell = measure(scene, "pybullet lean", RunOptions())
    assert cell.setting == "pybullet lean" and cell.collapse_level is None and cell.error == 0
    assert 0 < cell.engine <= cell.wall and cell.bricks == 4 and cell.steps > 0


HALF = np.array([[0.06, 0.012, 0.004]])


def test_a_brick_that_rocks_back_within_the_window_has_not_collapsed():
    watch = CollapseWatch(HALF, threshold=0.004)
    watch.place(0, level=3, position=np.zeros(3), rotation=np.eye(3))
    tilted = Rotation.from_euler("x", 30, degrees=True).as_matrix()[None]  # corners 4+ mm away
    assert not watch.look(0.10, np.zeros((1, 3)), tilted) and watch.level == 3
    assert not watch.look(0.25, np.zeros((1, 3)), np.eye(3)[None]) and watch.level is None  # back in place
    assert not watch.look(0.40, np.zeros((1, 3)), tilted)  # displaced again: a new window starts
    assert watch.look(0.60, np.zeros((1, 3)), tilted) and watch.level == 3


def test_the_collapse_level_is_the_highest_placed_when_it_began():
    watch = CollapseWatch(np.repeat(HALF, 3, axis=0), threshold=0.004)
    identity = np.repeat(np.eye(3)[None], 3, axis=0)
    for k in range(2):
        watch.place(k, level=k + 1, position=np.array([0.0, 0.0, 0.004 + 0.008 * k]), rotation=np.eye(3))
    at = np.array([[0.0, 0.0, 0.004], [0.02, 0.0, 0.012], [0.0, 0.0, 0.02]])  # the second slid 20 mm
    assert not watch.look(1.0, at, identity) and watch.level == 2
    watch.place(2, level=3, position=at[2], rotation=np.eye(3))  # placed on while it slides
    assert watch.look(1.3, at, identity) and watch.level == 2

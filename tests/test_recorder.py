"""The recorder and the trajectory file: frames, states, rate, and a faithful round trip."""

from __future__ import annotations

import re
import zipfile

import numpy as np
import pytest

from stackdsl import compile_scenario, load_scenario, parse_scenario, run_program
from stackdsl.cli.main import main
from stackdsl.compile.program import Shake
from stackdsl.engines.fake import FakeWorld
from stackdsl.runtime import recorder as recorder_module
from stackdsl.runtime import trajectory as trajectory_module
from stackdsl.runtime.loop import Subscriber
from stackdsl.runtime.recorder import Recorder, record_program
from stackdsl.runtime.run import outcome, run_in
from stackdsl.runtime.trajectory import (
    ABSENT,
    ACTIVE,
    FALLEN,
    FRAME_BYTES,
    FROZEN,
    POSITION_TOLERANCE,
    ROW_BYTES,
    STATES,
    WOKEN,
    TrajectoryTooLarge,
    load_trajectory,
)

OVERHANG = "scenarios/hard/overhang_falls.yaml"  # the top brick tips off at level 2
TOWER = "stackdsl: 1\nstructure: {tower: {levels: 3}}\n"


def recorded(path_or_text: str, mode: str | None = None, rate: float = 30.0):
    scenario = load_scenario(path_or_text) if path_or_text.endswith(".yaml") else parse_scenario(path_or_text)
    program = compile_scenario(scenario, mode)
    return (program, *record_program(program, rate))


def test_recording_changes_nothing_of_the_outcome():
    program = compile_scenario(load_scenario(OVERHANG))
    plain = run_program(program)
    _, with_recorder, _ = recorded(OVERHANG)
    assert with_recorder.collapse == plain.collapse and with_recorder.collapse is not None
    assert with_recorder.final_graph == plain.final_graph
    assert with_recorder.events == plain.events


def test_a_brick_is_absent_before_it_is_placed_and_recorded_where_it_was_placed():
    program, _, trajectory = recorded(TOWER)
    for k, a in enumerate(program.placements):
        i = trajectory.ids.tolist().index(a.id)
        if k:  # (the first frame is the first placement)
            before = trajectory.at(a.time - 1e-3)
            assert before.states[i] == ABSENT and np.isnan(before.positions[i]).all()
        at = trajectory.at(a.time)
        assert at.states[i] != ABSENT
        # placed at rest a drop gap above its pose (less what the bricks below have sunk)
        assert at.positions[i] == pytest.approx(np.array(a.position) + [0, 0, a.drop], abs=2e-4)
    assert trajectory.times[0] == pytest.approx(program.placements[0].time)


def test_the_last_frame_is_the_engines_end_state_within_the_row_tolerance():
    _, result, trajectory = recorded(TOWER)
    end = trajectory.frame(-1)
    assert end.time == pytest.approx(result.simulated_time)
    assert [STATES[s] for s in end.states] == ["frozen"] * 6
    final = {n.id: np.array(n.position_mm) / 1000 for n in result.final_graph.nodes}
    for i, brick in enumerate(trajectory.ids):
        assert np.linalg.norm(end.positions[i] - final[str(brick)]) < POSITION_TOLERANCE + 1e-4  # the graph rounds to 0.1 mm


def test_frames_follow_the_rate_while_something_moves_and_stop_when_all_rests():
    _, _, fast = recorded(OVERHANG, rate=30.0)
    _, _, slow = recorded(OVERHANG, rate=5.0)
    assert len(slow.times) < len(fast.times)
    gaps = np.diff(fast.times)
    assert gaps.min() >= 0
    # the top brick tips off its edge from its placement until it lies within 0.05 mm of
    # where it ends (about a quarter of a second): frames come at least every 1/30 s then
    top = list(fast.ids).index("top")
    where = np.array([f.positions[top] for f in fast.frames()])
    placed = ~np.isnan(where[:, 0])
    resting = placed & (np.linalg.norm(where - where[-1], axis=1) < 5e-5)
    rests_at = fast.times[resting & (fast.times > fast.collapse_time)][0]
    falling = placed & (fast.times <= rests_at)
    assert falling.sum() >= 6
    assert np.diff(fast.times[falling]).max() <= 1 / 30 + 1e-9
    # a standing tower: a few frames a brick (placed, landing, frozen), no frame while all is frozen
    program, _, tower = recorded(TOWER)
    waits = np.diff(tower.times)
    assert waits.max() > 0.5  # the quiet wait for the next placement has no frame
    assert len(tower.times) < 15 * len(program.placements)


def test_states_active_frozen_woken_fallen():
    _, _, trajectory = recorded(OVERHANG)
    top = trajectory.ids.tolist().index("top")
    codes = {int(f.states[top]) for f in trajectory.frames()}
    assert {ACTIVE, FALLEN} <= codes
    assert trajectory.frame(-1).states[top] == FALLEN
    assert trajectory.at(trajectory.collapse_time - 0.5).states[top] != FALLEN
    base = trajectory.ids.tolist().index("base")
    assert trajectory.frame(-1).states[base] == FROZEN
    # the slant tower's top part is woken before it falls: a brick frozen, then woken, is WOKEN
    _, _, slant = recorded("scenarios/slant_tower.yaml")
    seen = {int(s) for f in slant.frames() for s in f.states}
    assert {FROZEN, WOKEN, FALLEN} <= seen


def test_raw_mode_records_active_bricks_and_only_while_they_move():
    _, _, trajectory = recorded(TOWER, mode="raw")
    assert set(trajectory.frame(-1).states.tolist()) == {ACTIVE}
    assert np.diff(trajectory.times).max() > 0.5  # pybullet alone comes to rest between placements too


def test_a_trajectory_file_round_trip_is_exact(tmp_path):
    _, _, trajectory = recorded(OVERHANG)
    path = tmp_path / "run.npz"
    trajectory.save(path)
    loaded = load_trajectory(path)
    for name in (
        "ids",
        "levels",
        "half_extents",
        "times",
        "row_frame",
        "row_body",
        "row_position",
        "row_orientation",
        "row_state",
        "ground_offset",
    ):
        assert np.array_equal(getattr(loaded, name), getattr(trajectory, name)), name
    assert loaded.events == trajectory.events and loaded.graphs == trajectory.graphs and loaded.meta == trajectory.meta
    # a plain numpy archive: no pickles
    with np.load(path, allow_pickle=False) as data:
        assert data["ids"].tolist() == ["base", "top"]


def test_a_file_that_is_not_a_trajectory_is_refused(tmp_path):
    other = tmp_path / "other.npz"
    np.savez(other, x=np.zeros(3))
    with pytest.raises(ValueError, match="not a stackdsl trajectory"):
        load_trajectory(other)
    text = tmp_path / "text.npz"
    text.write_text("hello")
    with pytest.raises(ValueError, match="not a stackdsl trajectory"):
        load_trajectory(text)


@pytest.mark.parametrize("rate", [0, -1, float("nan"), float("inf")])
def test_a_bad_rate_is_refused(rate):
    with pytest.raises(ValueError, match="recording rate"):
        Recorder(compile_scenario(parse_scenario(TOWER)), rate)


def test_frames_in_a_fake_world_take_rows_only_for_what_moved():
    # raw mode on the fake world: nothing moves unless pushed, so after the placements the
    # trajectory has one row per brick, and a pushed brick gets a row each sampled step
    program = compile_scenario(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 1}}\nengine: {mode: raw}\n"))
    recorder = Recorder(program, rate=1 / (4 * program.engine.timestep))  # a sample every 4 steps

    class Push(Subscriber):
        def on_place(self, loop, record):
            if record.id == "L01.2":
                loop.world.throw(record.body, (0.01, 0.0, 0.0), None)  # 10 mm/s: above the rest speed

    loop = run_in(FakeWorld(timestep=program.engine.timestep), program, subscribers=(Push(), recorder))
    trajectory = recorder.trajectory(outcome(loop, 0.0))
    still, pushed = (trajectory.row_body == 0).sum(), (trajectory.row_body == 1).sum()
    assert still == 1  # placed, never moved
    moving_steps = loop.step - program.placements[1].step
    # a row at each sample, plus its placement, the collapse (an event: a frame of its own) and the end
    assert pushed == pytest.approx(moving_steps / recorder.every + 3, abs=1)
    placed = program.placements[1]
    assert trajectory.frame(-1).positions[1][0] == pytest.approx(
        placed.position[0] + 0.01 * (trajectory.end - placed.time), abs=1e-6
    )


# An oak post that tips over on a shake of 30 mm at 2 Hz (simulated: the extension cannot
# prove it stands), and a KAPLA bolted to the table 0.3 m away.
SHAKEN_FIXTURE = """stackdsl: 1
materials: {oak: {density: 700 kg/m^3, friction: 0.6}}
brick_types: {post: {size: [30 mm, 30 mm, 90 mm], material: oak}}
ground: {material: oak}
structure:
  bricks:
    - {id: post, at: [0, 0, 45 mm], brick: post}
    - {id: bolted, at: [300 mm, 0, 4 mm], fixed: true}
timing: {settle: 0.5 s}
actions:
  - shake: {amplitude: 30 mm, frequency: 2 Hz, duration: 1 s, at: 1 s, direction: [0.6, 0.8]}
"""


class FixtureWatch(Subscriber):
    """Where the engine has the fixtures at every frame the recorder (a subscriber before this
    one) takes in ``after_step``: the truth a recorded frame must show."""

    def __init__(self, recorder: Recorder) -> None:
        self.recorder, self.seen, self.frames = recorder, {}, 0

    def after_step(self, loop) -> None:
        from stackdsl.runtime.subscribers import Stability

        frames = len(self.recorder._times)
        if frames != self.frames:  # the recorder took a frame in this step's after_step
            stability = next(s for s in loop.subscribers if isinstance(s, Stability))
            self.seen[frames - 1] = np.array([loop.world.pose(body).position for body, _ in stability.fixtures])
        self.frames = frames


@pytest.mark.parametrize("mode", ["extension", "raw"])
def test_fixtures_are_recorded_moving_with_a_shakes_ground(mode, tmp_path):
    """A fixture is bolted to the shake table, yet a trajectory stored it once: a replay, a clip
    or a picture drew it standing still while the table and the bricks moved. Each frame keeps
    the ground's offset; the fixture's position at a frame is its rest plus it, where the engine had it."""
    program = compile_scenario(parse_scenario(SHAKEN_FIXTURE), mode)
    recorder = Recorder(program)
    watch = FixtureWatch(recorder)
    result = run_program(program, subscribers=(recorder, watch))
    trajectory = recorder.trajectory(result)
    shake = next(a for a in program.actions if isinstance(a, Shake))
    rest = trajectory.fixture_positions.copy()
    assert rest.tolist() == [[0.3, 0.0, 0.004]]
    during = [k for k, t in enumerate(trajectory.times) if shake.time + 0.1 < t < shake.time + 0.9]
    assert len(during) > 10
    for k in during:
        offset = np.array(shake.at(trajectory.times[k])[0])
        assert np.allclose(trajectory.ground_offset[k], offset, atol=1e-12)
        assert np.allclose(trajectory.fixture_positions_at(k), rest + offset, atol=1e-12)
        assert np.allclose(trajectory.frame(k).ground_offset, offset, atol=1e-12)
        if k in watch.seen:  # where the engine had it (0.07 mm apart: the table moves within a step)
            assert np.allclose(trajectory.fixture_positions_at(k), watch.seen[k], atol=2e-4), (k, watch.seen[k])
    assert sum(k in watch.seen for k in during) > 5
    farthest = max(float(np.linalg.norm(trajectory.ground_offset[k])) for k in during)
    assert farthest == pytest.approx(0.06, abs=0.005)  # A (1 - cos 2 pi f t) reaches 2 A
    before = [k for k, t in enumerate(trajectory.times) if t < shake.time]
    after = [k for k, t in enumerate(trajectory.times) if t > shake.end_time + 0.05]
    assert before and after and not trajectory.ground_offset[before + after].any()
    assert np.array_equal(trajectory.fixture_positions_at(-1), rest)  # fixed again where it was
    # the frames a clip draws carry it too, and a saved file keeps it
    frames = list(trajectory.frames(during[:3]))
    assert all(np.array_equal(f.ground_offset, trajectory.ground_offset[f.index]) for f in frames)
    trajectory.save(tmp_path / "shaken.npz")
    assert np.array_equal(load_trajectory(tmp_path / "shaken.npz").ground_offset, trajectory.ground_offset)


def test_a_time_asked_for_gets_a_frame_at_its_step_even_in_a_quiet_wait():
    program = compile_scenario(parse_scenario(TOWER))
    dt = program.engine.timestep
    _, plain = record_program(program)
    quiet = float(program.placements[1].time) - 0.05  # nothing moves: the loop jumps over it
    moving = 0.5 * (plain.times[1] + plain.times[2])  # the first brick lands: frames every 1/30 s
    _, asked = record_program(program, at=(quiet, moving))
    for t in (quiet, moving):
        assert 0 <= t - asked.at(t).time < dt  # the last step at or before it, not a frame up to 1/30 s earlier
    # the wait: a frame with no row, the scene as the last frame left it
    shown, before = asked.at(quiet), plain.at(quiet)
    assert np.array_equal(np.isnan(shown.positions), np.isnan(before.positions))
    assert np.allclose(np.nan_to_num(shown.positions), np.nan_to_num(before.positions), atol=2 * POSITION_TOLERANCE)
    assert shown.state_names == before.state_names
    assert len(asked.times) <= len(plain.times) + 2


def test_a_projectile_that_froze_is_recorded_frozen():
    """A thrown brick that came to rest is frozen by the extension (a freeze event) and stays
    so in the outcome's graph: the trajectory said "active" from its launch to the end."""
    _, outcome, trajectory = recorded("scenarios/impact_level3.yaml")
    freezes = [e.time for e in outcome.events if e.kind == "freeze" and e.brick == "hammer"]
    assert freezes, "the hammer comes to rest and is frozen"
    hammer = trajectory.ids.tolist().index("hammer")
    assert trajectory.frame(-1).states[hammer] == FROZEN
    assert trajectory.at(freezes[-1] - 0.2).states[hammer] == ACTIVE


@pytest.mark.slow
def test_a_brick_pulled_out_and_let_go_of_has_no_pose():
    """A brick a hand pulls out of the tower and lets go of leaves the scene: the engine parks
    it kilometres away, where a frame put it (-4999.5, -5000, 100 m), so that a reader's
    minimum over the positions was -5 km. Absent, it has NaN for a pose, as before it entered."""
    text = """stackdsl: 1
structure: {tower: {levels: 3, bricks_per_layer: 3, spacing: 40 mm}}
actions:
  - remove: {brick: L02.2, at: after level 3, speed: 40 mm/s}
timing: {settle: 1 s}
"""
    _, outcome, trajectory = recorded(text)
    assert "L02.2" in outcome.removed
    pulled = trajectory.ids.tolist().index("L02.2")
    last = trajectory.frame(-1)
    assert last.states[pulled] == ABSENT and np.isnan(last.positions[pulled]).all()
    assert np.isnan(list(trajectory.frames())[-1].positions[pulled]).all()
    others = np.delete(np.arange(len(trajectory.ids)), pulled)
    assert np.abs(last.positions[others]).max() < 1.0  # every other body within a metre


def test_a_pull_carried_over_steps_is_recorded_at_the_rate_along_its_path():
    """The hand carries a brick pulled under its proof over the steps its proof covers (the
    loop's glide): the recording still has a frame at its rate while the brick slides, each the
    brick's place on its straight path then, and recording changes nothing of the run."""
    text = """stackdsl: 1
structure: {tower: {levels: 5, bricks_per_layer: 3, spacing: 40 mm}}
actions:
  - remove: {brick: L02.2, at: after level 5, speed: 40 mm/s}
timing: {settle: 1 s}
"""
    program, outcome, trajectory = recorded(text, rate=30.0)
    assert outcome.steps_skipped > 0 and outcome.events == run_program(program).events
    pulled = trajectory.ids.tolist().index("L02.2")
    start = next(e.time for e in outcome.events if e.kind == "remove")
    end = next(e.time for e in outcome.events if e.kind == "release")
    seen = [(f.time, f.positions[pulled]) for f in trajectory.frames() if start <= f.time < end]
    times = np.array([t for t, _ in seen])
    assert len(seen) > 0.8 * 30 * (end - start) and np.diff(times).max() < 1.5 / 30, np.diff(times).max()
    way = np.array([p for _, p in seen])
    moved = np.linalg.norm(np.diff(way[:, :2], axis=0), axis=1)
    assert moved.max() < 2.5 * 0.04 / 30, moved.max()  # a frame's way, 1.3 mm at 40 mm/s, never a glide's
    # a time asked for inside a glide (an export's, a picture's) is the brick's place on its path then
    asks = [start + 0.3 + 0.0173 * k for k in range(12)]
    _, slow = record_program(program, 1.0, at=asks)
    for t in asks:
        frame = slow.frame(int(np.searchsorted(slow.times, t + 1e-9, side="right")) - 1)  # the last at or before t
        assert abs(frame.time - t) < program.engine.timestep
        placed = next(f.positions[pulled] for f in slow.frames() if f.time >= start)
        along = np.linalg.norm(frame.positions[pulled][:2] - placed[:2])
        assert abs(along - 0.04 * (t - start)) < 0.0005, (t, along)


def test_a_time_outside_the_run_or_not_a_number_is_refused_by_name():
    # at(-1) was the frame at t = 0, at(nan) the last frame and at("2") a TypeError about
    # concatenating a str and a float
    program = compile_scenario(parse_scenario(TOWER))
    recorder = Recorder(program)
    loop = run_in(FakeWorld(timestep=program.engine.timestep), program, subscribers=(recorder,))
    trajectory = recorder.trajectory(outcome(loop, 0.0))
    for time, error, said in (
        (-1.0, ValueError, "time must be a finite number of seconds from 0 (the run's start), not -1.0"),
        (float("nan"), ValueError, "time must be a finite number of seconds from 0 (the run's start), not nan"),
        (float("inf"), ValueError, "time must be a finite number of seconds from 0 (the run's start), not inf"),
        ("2", TypeError, "time must be a number of seconds into the run, not '2'"),
        (None, TypeError, "time must be a number of seconds into the run, not None"),
    ):
        for ask in (trajectory.at, trajectory.frame_index):
            with pytest.raises(error, match=re.escape(said)):
                ask(time)
    # within the run: the last frame at or before; after its end, the last frame
    assert trajectory.at(0.0).index == 0 and trajectory.at(np.float64(2.0)).time <= 2.0
    assert trajectory.at(trajectory.end + 10.0).index == len(trajectory.times) - 1


def test_what_a_trajectory_counts_is_what_its_reader_adds_up(tmp_path):
    """The bytes the recorder holds a recording to are the reader's: the members' sizes in the file."""
    _, _, trajectory = recorded(OVERHANG, rate=240.0)
    trajectory.save(tmp_path / "t.npz")
    with zipfile.ZipFile(tmp_path / "t.npz") as archive:
        assert sum(i.file_size for i in archive.infolist()) == trajectory.stored_size


def test_a_recording_past_what_a_trajectory_file_may_hold_ends_the_run_and_writes_nothing(monkeypatch, tmp_path, capsys):
    """The recorder and the reader share one limit: a run whose recording would pass it is refused
    (exit 2, at --record) when it passes, not written for replay and render to refuse."""
    _, _, whole = recorded(OVERHANG, rate=240.0)
    rows = len(whole.times) * FRAME_BYTES + len(whole.row_frame) * ROW_BYTES  # what the recorder counts as it goes
    monkeypatch.setattr(recorder_module, "MAX_TRAJECTORY_BYTES", rows // 2)  # passed halfway through the run's frames
    monkeypatch.setattr(trajectory_module, "MAX_TRAJECTORY_BYTES", rows // 2)
    with pytest.raises(
        TrajectoryTooLarge, match=r"passed the 0 MiB a trajectory file may hold at t = [\d.]+ s simulated"
    ) as caught:
        recorded(OVERHANG, rate=240.0)
    when = float(re.search(r"t = ([\d.]+) s", str(caught.value)).group(1))
    assert 0 < when < whole.end  # it ends the run when it passes the limit, not after
    monkeypatch.setattr(recorder_module, "MAX_TRAJECTORY_BYTES", whole.stored_size - 1)  # the header tips it over
    with pytest.raises(TrajectoryTooLarge, match="with its events and brick graphs"):
        recorded(OVERHANG, rate=240.0)
    with pytest.raises(TrajectoryTooLarge):
        whole.save(tmp_path / "whole.npz")  # what the reader would refuse is not written either
    assert not list(tmp_path.iterdir())
    assert main(["run", OVERHANG, "--record", str(tmp_path / "out.npz"), "--rate", "240"]) == 2
    err = capsys.readouterr().err
    assert "--record" in err and "nothing was written: give a lower --rate than 240" in err and "Traceback" not in err
    assert not list(tmp_path.iterdir())

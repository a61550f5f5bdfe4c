"""Pictures and clips of a recorded run: state colours, framing, times, files."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from PIL import Image

from stability import Box, Pose
from stackdsl import compile_scenario, parse_scenario
from stackdsl.draw.animate import KEY_EVENTS, animate, speed_text, timeline
from stackdsl.draw.camera import placed_corners
from stackdsl.draw.render import COLLAPSE_DELAY, COLOURS, Scene, picture, render, resolve_time, scale_bar
from stackdsl.runtime.recorder import record_program
from stackdsl.runtime.trajectory import FALLEN, STATES, Trajectory

TOWER = "stackdsl: 1\nstructure: {tower: {levels: 2}}\n"
THROW = TOWER + "impacts: [{id: hammer, target: {level: 2, side: +y}, speed: 1 m/s, at: after level 2}]\n"
BRICK_COLOURS = [COLOURS[k] for k in (*STATES[1:], "projectile")]


@pytest.fixture(scope="module")
def tower() -> Trajectory:
    """A 2-level 4 stack, every brick frozen at the end (5 s)."""
    return record_program(compile_scenario(parse_scenario(TOWER)))[1]


@pytest.fixture(scope="module")
def throw() -> Trajectory:
    """The same tower hit at the top by a brick thrown at 1 m/s."""
    return record_program(compile_scenario(parse_scenario(THROW)))[1]


def collapsed(trajectory: Trajectory, time: float) -> Trajectory:
    """``trajectory`` as if it had collapsed at ``time`` seconds."""
    collapse = {"level": 2, "time": time, "brick": "L02.1", "brick_level": 2, "displacement": 0.005}
    return dataclasses.replace(trajectory, meta={**trajectory.meta, "collapse": collapse})


def share(image: np.ndarray, colour: tuple[float, float, float]) -> float:
    """The fraction of pixels of ``colour``'s hue: same proportions of red, green and blue
    (lighting scales all three alike)."""
    rgb = image.reshape(-1, 3).astype(float) + 1e-9
    chroma = rgb / rgb.sum(axis=1, keepdims=True)
    target = np.array(colour) / sum(colour)
    bright = rgb.sum(axis=1) > 60  # dark outline pixels have too few levels left to judge
    return float((bright & (np.abs(chroma - target).max(axis=1) < 0.025)).mean())


def test_frozen_bricks_are_drawn_in_the_frozen_colour_where_they_stand(tower: Trajectory) -> None:
    end = tower.frame(-1)
    assert [STATES[s] for s in end.states] == ["frozen"] * 4
    with Scene(tower, 320, 240) as scene:
        image = scene.render(end)
        tops = end.positions[tower.levels == 2] + [0.0, 0.0, 0.004]  # the middle of each top face
        pixels = np.round(scene.camera.pixels(tops)).astype(int)
    assert share(image, COLOURS["frozen"]) > 0.05
    for colour in ("active", "woken", "fallen", "projectile"):
        assert share(image, COLOURS[colour]) == 0.0, colour
    for column, row in pixels:
        assert share(image[row : row + 1, column : column + 1], COLOURS["frozen"]) == 1.0


def test_fallen_and_active_bricks_get_their_own_colours(tower: Trajectory) -> None:
    fallen = dataclasses.replace(tower, row_state=np.full_like(tower.row_state, FALLEN))
    image = render(fallen, fallen.end, 320, 240)
    assert share(image, COLOURS["fallen"]) > 0.05 and share(image, COLOURS["frozen"]) == 0.0
    first = render(tower, tower.times[0], 320, 240)  # one brick, just placed: active, the rest absent (not drawn)
    assert share(first, COLOURS["active"]) > 0.003 and share(first, COLOURS["frozen"]) == 0.0
    assert share(first, COLOURS["active"]) < share(render(tower, tower.end, 320, 240), COLOURS["frozen"]) / 2


@pytest.mark.parametrize("size", [(160, 120), (400, 100), (100, 300)])
def test_the_framing_keeps_every_placed_brick_inside_the_picture(tower: Trajectory, size: tuple[int, int]) -> None:
    width, height = size
    with Scene(tower, width, height) as scene:
        image = scene.render(tower.frame(-1))
        corners = scene.camera.pixels(placed_corners(tower))
    assert (corners >= 0).all() and (corners[:, 0] <= width).all() and (corners[:, 1] <= height).all()
    border = np.concatenate([image[0], image[-1], image[:, 0], image[:, -1]])[None]
    assert all(share(border, colour) == 0.0 for colour in BRICK_COLOURS)
    assert share(image, COLOURS["frozen"]) > 0.02


def test_resolve_time_accepts_end_collapse_and_seconds(tower: Trajectory) -> None:
    assert resolve_time(tower, "end") == tower.end == pytest.approx(5.0)
    assert resolve_time(tower, 1.5) == 1.5 and resolve_time(tower, 0) == 0.0
    assert resolve_time(tower, "2.25") == resolve_time(tower, "2.25 s") == 2.25
    assert resolve_time(collapsed(tower, 3.0), "collapse") == pytest.approx(3.0 + COLLAPSE_DELAY)
    assert resolve_time(collapsed(tower, tower.end - 0.01), "collapse") == tower.end  # clamped to the end


@pytest.mark.parametrize("at", ["collapse", -0.5, 6.5, "soon", "", float("nan"), True, None])
def test_resolve_time_refuses_what_names_no_time_of_the_run(tower: Trajectory, at: object) -> None:
    with pytest.raises(ValueError) as error:
        resolve_time(tower, at)  # type: ignore[arg-type]
    assert "\n" not in str(error.value)


def test_scale_bar_is_a_round_length_at_most_a_fifth_of_the_width() -> None:
    assert scale_bar(1000.0, 800) == (0.1, "100 mm")  # 160 px = 160 mm available
    assert scale_bar(5000.0, 800) == (0.02, "20 mm")  # 32 mm
    assert scale_bar(3000.0, 800) == pytest.approx((0.05, "50 mm"))  # 53 mm
    assert scale_bar(100.0, 800) == (1.0, "1 m")


def test_picture_writes_a_png_of_the_asked_size(tower: Trajectory, tmp_path) -> None:
    path = tmp_path / "tower.png"
    assert picture(tower, "end", path, width=320, height=240) == tower.end
    with Image.open(path) as image:
        assert image.format == "PNG" and image.size == (320, 240)
        assert share(np.asarray(image.convert("RGB")), COLOURS["frozen"]) > 0.03
    with pytest.raises(ValueError, match="collapse"):
        picture(tower, "collapse", tmp_path / "none.png")
    with pytest.raises(ValueError, match=r"\.png"):
        picture(tower, "end", tmp_path / "tower.jpg")
    assert not (tmp_path / "none.png").exists() and not (tmp_path / "tower.jpg").exists()


def test_a_clip_plays_in_real_time_while_bricks_move_and_shortens_the_waits() -> None:
    # the second brick placed 70 mm along the first topples off it (one that lands at rest is frozen at once)
    text = "stackdsl: 1\nstructure: {tower: {levels: 3, bricks_per_layer: 1, turn: 0, shift: 70 mm}}\n"
    tower = record_program(compile_scenario(parse_scenario(text)))[1]
    plan = timeline(tower, fps=30.0)
    assert plan.times[0] == tower.times[0] and plan.times[-1] == pytest.approx(tower.end)
    assert (np.diff(plan.times) > 0).all() and (np.diff(plan.frames) >= 0).all()
    assert plan.frames[-1] == len(tower.times) - 1
    assert (plan.speeds >= 1.0 - 1e-9).all() and (plan.speeds == 1.0).any() and plan.speeds.max() > 5
    live = (plan.speeds[:-1] == 1.0) & (plan.speeds[1:] == 1.0)
    steps = np.diff(plan.times)[live]  # real time: a frame each 1/30 s, and a key frame (the collapse) between
    assert live.any() and np.median(steps) == pytest.approx(1 / 30) and (steps <= 1 / 30 + 1e-9).all(), steps
    assert len(plan.frames) < tower.end * 30 / 3  # four waits of about a second, cut short
    for event in (e for e in tower.events if e.kind == "place"):  # each placement starts a burst: drawn as it is
        assert tower.frame_index(event.time) in plan.frames
    short = timeline(tower, fps=30.0, max_frames=8)
    assert 2 <= len(short.frames) <= 8 and short.times[-1] == pytest.approx(tower.end) and short.speeds.min() > 1.0


def test_a_clip_shows_the_throw_in_real_time(throw: Trajectory) -> None:
    launch = next(e for e in throw.events if e.kind == "launch")
    plan = timeline(throw, fps=30.0)
    for event in (e for e in throw.events if e.kind in KEY_EVENTS):
        assert throw.frame_index(event.time) in plan.frames, event
    flight = (plan.times >= launch.time) & (plan.times <= launch.time + 0.1)
    assert flight.sum() >= 3 and (plan.speeds[flight] == 1.0).all()
    assert [speed_text(s) for s in (1.0, 2.54, 9.4, 28.3)] == ["x1", "x2.5", "x9.4", "x28"]


def test_a_gif_has_a_frame_for_each_frame_of_the_timeline(throw: Trajectory, tmp_path) -> None:
    path = tmp_path / "throw.gif"
    plan = animate(throw, path, fps=20.0, width=160, height=120, max_frames=40)
    assert len(plan.frames) == len(timeline(throw, 20.0, 40).frames) <= 40
    with Image.open(path) as clip:
        assert clip.format == "GIF" and clip.size == (160, 120) and clip.n_frames == len(plan.frames)
        clip.seek(clip.n_frames - 1)
        assert share(np.asarray(clip.convert("RGB")), COLOURS["projectile"]) > 0.0  # the thrown brick, at rest


def test_an_mp4_is_written_and_other_suffixes_are_refused(tower: Trajectory, tmp_path) -> None:
    path = tmp_path / "tower.mp4"
    animate(tower, path, fps=10.0, width=161, height=121, max_frames=20)  # odd sides are padded
    data = path.read_bytes()
    assert len(data) > 1000 and data[4:8] == b"ftyp"
    for name, fps in (("tower.avi", 10.0), ("tower", 10.0), ("tower.gif", 60.0)):
        with pytest.raises(ValueError) as error:
            animate(tower, tmp_path / name, fps=fps)
        assert "\n" not in str(error.value) and not (tmp_path / name).exists()
    with pytest.raises(ValueError, match="16 x 16"):
        animate(tower, tmp_path / "tiny.mp4", width=8, height=8)
    assert not (tmp_path / "tiny.mp4").exists()


def test_a_fixture_is_drawn_where_a_shake_has_carried_it() -> None:
    """A fixture is bolted to the shake table: a picture (and each frame of a clip) drew it at
    rest while the table moved it 60 mm. It is drawn at its rest plus the frame's ground offset."""
    text = (
        "stackdsl: 1\nstructure:\n  bricks:\n    - {id: a, at: [0, 0, 4 mm]}\n    - {id: bolted, at: [200 mm, 0, 4 mm], fixed: true}\n"
        "timing: {settle: 0.2 s}\nactions: [{shake: {amplitude: 30 mm, frequency: 1 Hz, duration: 1 s, at: 1 s, direction: [0, 1]}}]\n"
    )
    trajectory = record_program(compile_scenario(parse_scenario(text), "raw"))[1]
    k = int(np.argmax(np.linalg.norm(trajectory.ground_offset, axis=1)))  # the table at its farthest
    frame = trajectory.frame(k)
    assert frame.ground_offset[1] == pytest.approx(0.06, abs=0.003)
    top = [0.0, 0.0, 0.004]  # the middle of the fixture's top face
    with Scene(trajectory, 480, 360) as scene:
        carried = scene.render(frame)
        still = scene.render(dataclasses.replace(frame, ground_offset=np.zeros(3)))
        moved, rest = (
            np.round(scene.camera.pixels(np.array([p]))).astype(int)[0]
            for p in trajectory.fixture_positions + top + [frame.ground_offset, np.zeros(3)]
        )
    brightness = {
        name: float(image[row, column].astype(float).mean())
        for name, image, (column, row) in (("moved", carried, moved), ("rest", carried, rest), ("still", still, rest))
    }
    # the fixture's grey (0.5) against the ground's (0.88) under the same light on a top face
    assert brightness["moved"] < 0.7 * brightness["rest"], brightness
    assert brightness["still"] < 0.7 * brightness["rest"], brightness  # where it was drawn before


def test_the_camera_frames_a_fixture_as_far_as_a_shake_carries_it() -> None:
    """The camera was framed on the fixtures at rest: a post 150 mm beside a shaken tower, the
    ground 63.5 mm off its rest, left the picture mid-stroke. Framed on both ends of the stroke,
    every corner of the fixture lies within the picture at every frame."""
    text = (
        "stackdsl: 1\nstructure:\n  bricks:\n    - {id: a, at: [0, 0, 4 mm]}\n    - {id: bolted, at: [250 mm, 0, 4 mm], fixed: true}\n"
        "timing: {settle: 0.2 s}\nactions: [{shake: {amplitude: 70 mm, frequency: 1 Hz, duration: 1 s, at: 1 s, direction: [1, 0]}}]\n"
    )
    trajectory = record_program(compile_scenario(parse_scenario(text), "raw"))[1]
    assert np.abs(trajectory.ground_offset[:, 0]).max() > 0.12
    with Scene(trajectory, 480, 360) as scene:
        for k in range(len(trajectory.times)):
            corners = Box(trajectory.fixture_half_extents[0], 1.0).corners(
                Pose(trajectory.fixture_positions_at(k)[0], trajectory.fixture_orientations[0])
            )
            pixels = scene.camera.pixels(corners)
            assert (pixels >= -0.5).all() and (pixels[:, 0] <= 480.5).all() and (pixels[:, 1] <= 360.5).all(), k


def test_a_clip_of_a_short_run_ends_where_the_run_does() -> None:
    """A single brick settled for 0.05 s: the clip drew 0 and 0.033 s at 30 frames a second,
    never the end the README promises."""
    text = "stackdsl: 1\nstructure: {bricks: [{id: a, at: [10 mm, 20 mm, 4 mm], yaw: 15}]}\ntiming: {settle: 0.05 s}\n"
    trajectory = record_program(compile_scenario(parse_scenario(text)))[1]
    assert trajectory.end == pytest.approx(0.05)
    plan = timeline(trajectory, fps=30.0)
    assert plan.times[-1] == pytest.approx(trajectory.end) and plan.frames[-1] == len(trajectory.times) - 1
    assert (np.diff(plan.times) > 0).all()

"""Scenario -> Program: expansion, schedule, timestep checks, impacts."""

import math
import re
import warnings

import numpy as np
import pytest

from stackdsl import End, Launch, Place, ScenarioError, compile_scenario, format_program, parse_scenario
from stackdsl.lang.errors import ScenarioWarning


def program(text: str, mode=None):
    return compile_scenario(parse_scenario(text, "c.yaml"), mode)


def test_four_stack_expands_layer_by_layer():
    p = program("stackdsl: 1\nstructure: {tower: {levels: 3}}\n")
    places = p.placements
    assert [a.id for a in places] == ["L01.1", "L01.2", "L02.1", "L02.2", "L03.1", "L03.2"]
    assert [a.level for a in places] == [1, 1, 2, 2, 3, 3]
    # level 1 along x at y = -48, +48; level 2 turned 90 deg at x = +48, -48
    assert np.allclose(
        [a.position for a in places[:4]], [[0, -0.048, 0.004], [0, 0.048, 0.004], [0.048, 0, 0.012], [-0.048, 0, 0.012]]
    )
    assert [a.yaw for a in places[:4]] == [0.0, 0.0, 90.0, 90.0]
    assert [a.time for a in places] == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
    assert [a.step for a in places] == [0, 240, 480, 720, 960, 1200]
    assert isinstance(p.actions[-1], End) and p.actions[-1].time == 7.0  # last + 2 s settle
    assert p.levels == 3 and p.collapse_threshold == pytest.approx(0.004)


def test_slant_tower_moves_every_layer():
    p = program("stackdsl: 1\nstructure: {tower: {levels: 4, spacing: 70 mm, shift: 12.9 mm}}\n")
    centres = [np.mean([a.position for a in p.placements if a.level == lv], axis=0) for lv in range(1, 5)]
    assert [c[0] for c in centres] == pytest.approx([0.0, 0.0129, 0.0258, 0.0387])


def test_brick_mass_and_material_from_the_type():
    p = program("stackdsl: 1\nstructure: {tower: {levels: 1, bricks_per_layer: 1}}\n")
    brick = p.placements[0].brick
    assert brick.mass == pytest.approx(0.12 * 0.024 * 0.008 * 460)
    assert brick.friction == 0.5 and brick.half_extents == pytest.approx((0.06, 0.012, 0.004))


def test_explicit_bricks_get_levels_from_height():
    p = program(
        "stackdsl: 1\nstructure:\n  bricks:\n"
        "    - {at: [0, 0, 4 mm]}\n    - {at: [0, 0, 12 mm], yaw: 90}\n    - {at: [0.2, 0, 4 mm]}\n"
        "    - {at: [0, 0, 20 mm], level: 7}\n"
    )
    assert [(a.id, a.level) for a in p.placements] == [("b001", 1), ("b002", 2), ("b003", 1), ("b004", 7)]


@pytest.mark.parametrize("mode, dt, iterations", [("raw", 1 / 240, 50), ("tuned", 1 / 1000, 150), ("extension", 1 / 240, 50)])
def test_mode_picks_engine_defaults(mode, dt, iterations):
    e = program("stackdsl: 1\nstructure: {tower: {levels: 1}}\n", mode).engine
    assert (e.mode, e.timestep, e.solver_iterations) == (mode, pytest.approx(dt), iterations)


def test_explicit_engine_settings_win_over_mode_defaults():
    e = program(
        "stackdsl: 1\nstructure: {tower: {levels: 1}}\nengine: {mode: raw, timestep: 2 ms, solver_iterations: 80}\n"
    ).engine
    assert (e.timestep, e.solver_iterations) == (0.002, 80)


def test_times_must_be_whole_timesteps():
    with pytest.raises(ScenarioError) as info:
        program("stackdsl: 1\nstructure: {tower: {levels: 2}}\ntiming: {interval: 0.301 s}\n")
    err = info.value
    assert (err.line, err.field) == (3, "timing.interval")
    assert "not a whole number of timesteps" in err.message and "0.3 s" in err.message
    # the same interval is fine at 1 ms
    program("stackdsl: 1\nstructure: {tower: {levels: 2}}\ntiming: {interval: 0.301 s}\nengine: {timestep: 1 ms}\n")


def test_a_time_off_the_grid_of_a_step_the_file_did_not_write_says_whose_step_it_is():
    """0.25 s runs on pybullet (60 steps of 1/240 s) and was refused on MuJoCo's extension with
    "0.25 s is not a whole number of timesteps (4 ms)", a step the file never wrote: the
    message names the engine and mode it comes from; a step the file writes is its own."""
    text = "stackdsl: 1\nstructure: {tower: {levels: 2}}\ntiming: {interval: 0.25 s}\nengine: {backend: mujoco}\n"
    with pytest.raises(ScenarioError) as info:
        program(text)
    assert info.value.field == "timing.interval"
    assert "(4 ms, mujoco's in extension mode); use a multiple such as 0.248 s" in info.value.message
    with pytest.raises(ScenarioError) as info:
        program(text.replace("backend: mujoco", "timestep: 3 ms"))
    assert "0.25 s is not a whole number of timesteps (3 ms); use a multiple such as 0.249 s" in info.value.message
    assert "every engine" not in info.value.message  # 3 ms does not divide 0.1 s


def test_a_time_off_one_engines_grid_is_offered_one_on_every_engines():
    """A new user's 0.05 s interval was refused on MuJoCo's extension (4 ms) with "use a multiple
    such as 0.048 s", which pybullet's (1/240 s) then refused with "such as 0.05 s": neither
    suggestion ran in `compare`. The message now also offers the nearest multiple of 0.1 s, a whole
    number of every engine's and mode's default timestep, and that one runs on each."""
    from stackdsl.compile.compiler import BACKEND_DEFAULTS, COMMON_STEP

    assert COMMON_STEP == pytest.approx(0.1)
    text = "stackdsl: 1\nstructure: {tower: {levels: 2}}\ntiming: {interval: 0.05 s}\nengine: {backend: mujoco}\n"
    with pytest.raises(ScenarioError) as info:
        program(text)
    assert "such as 0.048 s, or 0.1 s, a whole number of steps on every engine and mode" in info.value.message
    for backend, modes in BACKEND_DEFAULTS.items():
        for mode in modes:
            compile_scenario(parse_scenario(text.replace("0.05 s", "0.1 s"), "t.yaml"), mode, None, backend)


def test_a_time_near_one_on_every_grid_is_offered_it_once():
    """9.0001 s is nearest 9 s on pybullet's grid and on every engine's: a new user read "use a
    multiple such as 9 s, or 9 s"."""
    text = "stackdsl: 1\nstructure: {tower: {levels: 2}}\ntiming: {interval: 9.0001 s}\n"
    with pytest.raises(ScenarioError) as info:
        program(text)
    assert "use a multiple such as 9 s, a whole number of steps on every engine and mode" in info.value.message
    assert "9 s, or 9 s" not in info.value.message


@pytest.mark.parametrize(
    ("tail", "field", "where", "write"),
    [
        ("timing: {interval: 0.35 s}\n", "timing.settle", (4, 1), "write settle: 2.002 s"),  # at the timing: key
        ("timing:\n  settle: 2.002 s\n", "timing.interval", (4, 1), "write interval: 1.001 s"),
        ("", "timing.interval", (3, 20), "write interval: 1.001 s"),  # no timing: at the timestep
    ],
)
def test_a_default_time_off_a_timestep_the_file_chose_says_it_is_the_default(tail, field, where, write):
    """The defaults (interval 1 s, settle 2 s) are no whole number of 7 ms steps: the error names
    the default and what to write, at a line the file wrote, not at a field it never wrote."""
    with pytest.raises(ScenarioError) as info:
        program("stackdsl: 1\nstructure: {tower: {levels: 2}}\nengine: {timestep: 7 ms}\n" + tail)
    err = info.value
    assert (err.field, (err.line, err.column)) == (field, where), str(err)
    assert err.message.startswith("the default ") and err.message.endswith(write), err.message


def test_a_duration_shorter_than_one_timestep_is_refused_not_rounded_to_nothing():
    # 1 ns is within rounding of 0 steps: every brick would be placed at once
    with pytest.raises(ScenarioError) as info:
        program("stackdsl: 1\nstructure: {tower: {levels: 2}}\ntiming: {interval: 0.000000001 s}\n")
    assert info.value.field == "timing.interval" and "0.00416667 s" in info.value.message


def test_impact_after_a_level_is_aimed_to_arrive_at_the_target():
    p = program(
        "stackdsl: 1\nstructure: {tower: {levels: 13}}\n"
        "impacts: [{target: {level: 13, side: +y}, speed: 1 m/s, at: after level 13, distance: 50 mm}]\n"
    )
    launch = next(a for a in p.actions if isinstance(a, Launch))
    assert launch.time == pytest.approx(26.0)  # one interval after the 26th placement (t = 25 s)
    assert launch.target == pytest.approx((0.0, 0.06, 0.1))  # middle of the outer face of level 13
    assert launch.velocity == pytest.approx((0.0, -1.0, 0.0))
    # Ballistic flight: the front face (half a length ahead) reaches the target in 50 ms, having
    # fallen as the engine steps it: at 1 m/s a 240 Hz step is split in two (4.2 mm a step against
    # the 4 mm threshold), and each substep h falls g h / 2 times the flight more than g t^2 / 2
    t = launch.arrival - launch.time
    assert t == pytest.approx(0.05)
    h = 1 / 240 / 2
    fall = 0.5 * 9.81 * t * t + 0.5 * 9.81 * h * t
    front = np.array(launch.position) + np.array(launch.velocity) * t + [0, -0.06, -fall]
    assert front == pytest.approx(launch.target, abs=1e-9)
    assert launch.yaw == pytest.approx(-90.0)


def test_an_impact_on_a_side_hits_the_middle_of_the_levels_outer_face():
    """The middle of a course's face is its middle brick; a layer whose bricks show their ends on
    that side is hit on the end nearest the middle; two bricks side by side, on the first."""

    def targets(structure: str, *sides: tuple[int, str]) -> list[tuple[float, float, float]]:
        impacts = ", ".join(
            f"{{target: {{level: {lv}, side: '{side}'}}, speed: 1 m/s, at: after level {lv}}}" for lv, side in sides
        )
        program = compile_scenario(parse_scenario(f"stackdsl: 1\nstructure: {{{structure}}}\nimpacts: [{impacts}]\n", "i.yaml"))
        return [tuple(round(v * 1000, 3) + 0.0 for v in a.target) for a in program.actions if isinstance(a, Launch)]

    wall = "wall: {courses: 3, bricks_per_course: 5}"  # five 120 mm bricks along x, their middle at x = 0
    assert targets(wall, (1, "-y"), (3, "+y")) == [(0.0, -12.0, 4.0), (0.0, 12.0, 20.0)]
    three = "tower: {levels: 2, bricks_per_layer: 3, spacing: 25 mm}"  # level 1 along x at y = -25, 0, 25
    assert targets(three, (1, "+x"), (2, "-y")) == [(60.0, 0.0, 4.0), (0.0, -60.0, 12.0)]
    two = "tower: {levels: 1}"  # two bricks along x at y = -48 and 48: equally near the middle
    ((x, y, _),) = targets(two, (1, "+x"))
    assert x == 60.0 and abs(y) == 48.0


def test_an_impact_on_a_side_is_aimed_among_the_bricks_left_when_it_arrives():
    """A brick pulled out before the projectile arrives is out of the scene: the face is the
    outermost of those left; a pull that starts after the arrival changes nothing."""

    def target(pulls: str, at: str) -> tuple[float, ...]:
        text = (
            "stackdsl: 1\nstructure: {tower: {levels: 4, bricks_per_layer: 2}}\n"  # level 4 along y at x = -48, 48
            f"actions: [{pulls}]\nimpacts: [{{target: {{level: 4, side: -x}}, speed: 1 m/s, at: {at}}}]\n"
        )
        (launch,) = [a for a in program(text).actions if isinstance(a, Launch)]
        return tuple(round(v * 1000, 3) + 0.0 for v in launch.target)

    pull = "{remove: {brick: L04.1, at: after level 4}}"
    assert target(pull, "16 s") == (36.0, 0.0, 28.0)  # L04.2's -x face: L04.1 left the scene at 8 s
    assert target(pull, "after level 4") == (36.0, 0.0, 28.0)  # its pull starts as the projectile flies
    later = "{remove: {brick: L04.1, at: 20 s}}"
    assert target(later, "16 s") == (-60.0, 0.0, 28.0)  # L04.1 is still there when it arrives
    with pytest.raises(ScenarioError) as info:
        target(f"{pull}, {{remove: {{brick: L04.2, at: 12 s}}}}", "16 s")
    assert info.value.field == "impacts[0].target.level"
    assert "L04.1 by actions[0] from 8 s, L04.2 by actions[1] from 12 s" in str(info.value)


def test_an_impact_on_a_side_is_aimed_among_the_bricks_placed_when_it_is_thrown():
    """A brick placed after the throw is not there to aim at: a course of three (L03.1 to L03.3 at
    y = 40, 0, -40 mm, placed at 6, 7 and 8 s) was hit on its middle brick, L03.2, even when only
    L03.1 was there; thrown before any of its bricks is placed, the throw is refused at its ``at``."""

    def aimed(at: str) -> tuple[tuple[str, ...], float]:
        text = (
            "stackdsl: 1\nstructure: {tower: {levels: 3, bricks_per_layer: 3, spacing: 40 mm}}\n"
            f"impacts: [{{target: {{level: 3, side: +x}}, speed: 1 m/s, at: {at}}}]\n"
        )
        (launch,) = [a for a in program(text).actions if isinstance(a, Launch)]
        return launch.aim, round(launch.target[1] * 1000, 3) + 0.0

    assert aimed("after level 3") == (("L03.2", "L03.1", "L03.3"), 0.0)
    assert aimed("6 s") == (("L03.1",), 40.0)
    assert aimed("7 s") == (("L03.1", "L03.2"), 40.0)  # equally near the middle of the two: the first
    for at in ("5.5 s", "after level 1"):
        with pytest.raises(ScenarioError) as info:
            aimed(at)
        assert info.value.field == "impacts[0].at", info.value
        assert "before level 3 is built: its first brick, L03.1, is placed at 6 s" in info.value.message


def test_impact_on_a_missing_level_is_an_error():
    with pytest.raises(ScenarioError) as info:
        program("stackdsl: 1\nstructure: {tower: {levels: 3}}\nimpacts: [{target: {level: 5, side: +x}, speed: 1, at: 10 s}]\n")
    assert info.value.field == "impacts[0].target.level"


@pytest.mark.parametrize(("direction", "refused"), [("[0, 1, 0]", True), ("[1, 0, 0]", True), ("[0.3, -1, -0.2]", False)])
def test_a_throw_at_a_side_must_fly_into_it(direction, refused):
    # a new user's throw at the +y side flying +y started inside the tower and "hit" L06.1 from within
    text = (
        "stackdsl: 1\nstructure: {tower: {levels: 6}}\n"
        f"impacts: [{{target: {{level: 6, side: +y}}, direction: {direction}, speed: 1 m/s, at: after level 6}}]\n"
    )
    if not refused:
        assert next(a for a in program(text).actions if isinstance(a, Launch)).velocity[1] < 0.0
        return
    with pytest.raises(ScenarioError) as info:
        program(text)
    assert info.value.field == "impacts[0].direction"
    assert (
        f"a throw at the +y side must fly into it, and {direction} does not: give a direction with a -y part"
        in info.value.message
    )


def test_a_slow_throw_says_the_speed_it_arrives_at():
    # docs/language.md: 0.3 m/s from 50 mm is launched 136 mm above and arrives at 1.6 m/s; compile
    # and run said only the 0.3 m/s it was thrown at
    p = program(
        "stackdsl: 1\nstructure: {tower: {levels: 6}}\n"
        "impacts: [{target: {level: 6, side: +y}, speed: 0.3 m/s, at: after level 6, distance: 50 mm}]\n"
    )
    launch = next(a for a in p.actions if isinstance(a, Launch))
    assert launch.arrival_speed() == pytest.approx(math.hypot(0.3, 9.81 * 0.05 / 0.3))
    assert "0.3 m/s aimed at (48.0, 60.0, 44.0) mm, arriving t=12.167 s at 1.66 m/s" in format_program(p)


def test_placement_error_is_seeded():
    text = "stackdsl: 1\nseed: 7\nstructure: {tower: {levels: 2}}\ntiming: {placement_error: 1 mm}\n"
    a, b = program(text), program(text)
    other = program(text.replace("seed: 7", "seed: 8"))
    assert [x.position for x in a.placements] == [x.position for x in b.placements]
    assert [x.position for x in a.placements] != [x.position for x in other.placements]
    exact = program("stackdsl: 1\nstructure: {tower: {levels: 2}}\n")
    offsets = np.array([x.position for x in a.placements]) - np.array([x.position for x in exact.placements])
    assert np.abs(offsets[:, :2]).max() <= 0.001 and np.abs(offsets[:, 2]).max() == 0


def test_run_length_is_limited():
    with pytest.raises(ScenarioError, match="at most 3600 s"):
        program("stackdsl: 1\nstructure: {tower: {levels: 100}}\ntiming: {interval: 20 s}\n")


TWO = "stackdsl: 1\nstructure: {tower: {levels: 2}}\n"


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ("actions: [{remove: {brick: L01.2, at: 1e308 s}}]", "actions[0].remove.at"),
        ("actions: [{push: {target: {brick: L02.1}, direction: [0, 1, 0], at: 1e308}}]", "actions[0].push.at"),
        ("actions: [{shake: {amplitude: 1 mm, frequency: 2 Hz, duration: 1 s, at: 1e307 s}}]", "actions[0].shake.at"),
        ("impacts: [{target: {level: 2, side: +x}, speed: 1, at: 8e305}]", "impacts[0].at"),
        ("actions: [{remove: {brick: L01.2, at: {uniform: [5 s, 1e308 s]}}}]", "actions[0].remove.at"),
        ("actions: [{remove: {brick: L01.2, at: 1e300 s}}]", "actions[0].remove.at"),
    ],
)
def test_a_time_too_large_to_count_in_steps_is_refused_at_its_key(body, field):
    # 1e306 s and more is infinitely many steps of 4.167 ms: once an OverflowError, exit 3
    with pytest.raises(ScenarioError) as info:
        program(TWO + body + "\n")
    assert (info.value.line, info.value.field) == (3, field)
    assert re.search(r"the run would last at least [\d.]+e\+30\d s; at most 3600 s are simulated", info.value.message)


def test_a_grid_time_too_large_to_count_in_steps_is_refused_at_the_grid_value(tmp_path, capsys):
    from stackdsl.cli.main import main

    path = tmp_path / "g.yaml"
    path.write_text(
        TWO + "actions: [{remove: {brick: L01.2, at: 7 s}}]\n"
        "sweep: {samples: 2, grid: {actions.0.remove.at: [7 s, 1e308 s]}}\nexpect: {p_stands: '>= 0.5'}\n"
    )
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "g.yaml:4:55: sweep.grid.actions.0.remove.at[1]:" in err and "the run would last at least 1e+308 s" in err
    assert "internal error" not in err


def test_format_program_lists_every_action():
    p = program(
        "stackdsl: 1\nstructure: {tower: {levels: 2}}\nimpacts: [{target: {level: 2, side: +x}, speed: 1, at: after level 2}]\n"
    )
    text = format_program(p)
    assert text.count("place  L0") == 4 and text.count("launch ") == 1 and text.rstrip().endswith("end")
    assert "mode extension, timestep 4.167 ms" in text
    assert not any(isinstance(a, Place) and math.isnan(a.time) for a in p.actions)


def test_card_house_geometry():
    # V's lean 20 deg: their feet are on the ground, the inner top corners meet at the
    # peak, the flat bricks lie on the peaks' top corners.
    from stability import Box, Pose

    p = program("stackdsl: 1\nstructure: {card_house: {levels: 2, angle: 20}}\n")
    places = p.placements
    assert [a.id for a in places] == ["V1.1a", "V1.1b", "V1.2a", "V1.2b", "F2.1", "V3.1a", "V3.1b"]
    assert [a.level for a in places] == [1, 1, 1, 1, 2, 3, 3]
    assert [a.time for a in places] == [0.0, 0.0, 1.0, 1.0, 2.0, 3.0, 3.0]  # a V's bricks together
    box = Box(np.array([0.06, 0.012, 0.004]), 1.0)
    corners = {a.id: box.corners(Pose.from_euler(a.position, a.yaw, a.pitch, a.roll)) for a in places}
    for v in ("V1.1", "V1.2"):
        assert corners[v + "a"][:, 2].min() == pytest.approx(0.0, abs=1e-9)
        top_a, top_b = corners[v + "a"], corners[v + "b"]
        gap = np.linalg.norm(top_a[:, None, :] - top_b[None, :, :], axis=2).min()
        assert gap == pytest.approx(0.0, abs=1e-9)  # the two bricks touch at the peak
    peak_height = max(corners["V1.1a"][:, 2])
    assert corners["F2.1"][:, 2].min() == pytest.approx(peak_height)
    assert corners["V3.1a"][:, 2].min() == pytest.approx(peak_height + 0.008)


def test_card_house_spacing_errors():
    with pytest.raises(ScenarioError, match="need peaks between 120 and 135"):
        program("stackdsl: 1\nstructure: {card_house: {levels: 2, spacing: 100 mm}}\n")
    with pytest.raises(ScenarioError, match="would collide"):
        program("stackdsl: 1\nstructure: {card_house: {levels: 2, angle: 40, spacing: 125 mm}}\n")
    assert program("stackdsl: 1\nstructure: {card_house: {levels: 1, angle: 40}}\n").levels == 1


def test_fixed_bricks_are_fixtures_and_together_shares_a_slot():
    p = program(
        "stackdsl: 1\nstructure:\n  bricks:\n"
        "    - {id: wall, at: [0.1, 0, 0.05], pitch: 90, fixed: true}\n"
        "    - {at: [0, 0, 4 mm]}\n    - {at: [0, 0.05, 4 mm], together: true}\n    - {at: [0, 0, 12 mm], yaw: 90}\n"
    )
    assert [f.id for f in p.fixtures] == ["wall"]
    assert [(a.id, a.level, a.time) for a in p.placements] == [("b002", 1, 0.0), ("b003", 1, 0.0), ("b004", 2, 1.0)]
    with pytest.raises(ScenarioError, match="first brick"):
        program("stackdsl: 1\nstructure: {bricks: [{at: [0, 0, 0.004], together: true}]}\n")


def test_rules_follow_the_scene():
    def rules(text):
        return {r.name: r.on for r in program(text).rules}

    tower = {"basic": True, "leaning": False, "impacts": False, "rigid": True}
    assert rules("stackdsl: 1\nstructure: {tower: {levels: 2}}\n") == tower
    assert rules("stackdsl: 1\nstructure: {card_house: {levels: 1}}\n")["leaning"]
    thrown = (
        "stackdsl: 1\nstructure: {tower: {levels: 2}}\nimpacts: [{target: {level: 2, side: +x}, speed: 1, at: after level 2}]\n"
    )
    assert rules(thrown)["impacts"] and rules(thrown)["leaning"] and rules(thrown)["rigid"]
    assert not rules(thrown + "expect: {stays: 1}\n")["rigid"] and not rules(thrown + "expect: {may_fall: 2}\n")["rigid"]
    text = format_program(program("stackdsl: 1\nstructure: {card_house: {levels: 1}}\n"))
    assert "rule leaning  on   bricks placed tilted: V1.1a, V1.1b" in text and "rule impacts  off  nothing is thrown" in text
    row = format_program(program("stackdsl: 1\nstructure: {dominoes: {count: 3}}\n"))  # face down, not tilted
    assert "rule leaning  on   bricks placed on an edge or an end: D01, D02, D03" in row
    assert "rule rigid    off  expect.stays is judged after a collapse" in format_program(
        program(thrown + "expect: {stays: 1}\n")
    )


def test_compile_scenario_names_the_type_it_takes_and_how_to_get_one(tmp_path):
    # a file name was "'str' object has no attribute 'brick_types'"
    from stackdsl import load_scenario

    path = tmp_path / "t.yaml"
    path.write_text("stackdsl: 1\nstructure: {tower: {levels: 2}}\n")
    for given, kind in ((str(path), "str"), (path, type(path).__name__)):
        with pytest.raises(TypeError, match=rf"compile_scenario takes a Scenario, not {kind}: .*load_scenario\(path\)"):
            compile_scenario(given)  # type: ignore[arg-type]
    compiled = compile_scenario(load_scenario(path))
    with pytest.raises(TypeError, match=r"not Program: this one is compiled already: run it with run_program"):
        compile_scenario(compiled)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("engine", "asked", "field", "line"),
    [
        ("  backend: mujoco\n  sleep_tolerance: 1.0e-4\n", "pybullet", "sleep_tolerance", 5),
        ("  friction_anchors: true\n  maximal_coordinates: false\n", "mujoco", "friction_anchors", 4),
    ],
)
def test_a_setting_of_the_files_own_engine_left_out_under_another_backend_is_warned_of(engine, asked, field, line):
    text = f"stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\nengine:\n{engine}"
    scenario = parse_scenario(text, "engines.yaml")
    with pytest.warns(ScenarioWarning) as caught:
        program = compile_scenario(scenario, backend=asked)
    said = [str(w.message) for w in caught]
    assert program.engine.backend == asked and not hasattr(program.engine, field)
    assert said[0].startswith(f"engines.yaml:{line}:") and f"engine.{field}: " in said[0], said
    assert ("maximal_coordinates" in " ".join(said)) == (asked == "mujoco")  # each one the run leaves out
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # on the file's own engine, nothing is left out
        compile_scenario(scenario)
        compile_scenario(scenario, backend=scenario.engine.backend)

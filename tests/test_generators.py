"""The wall, pyramid and domino generators: their geometry against closed forms, and that the
wall and the pyramid stand with every brick frozen by the stability extension; a domino's
tipping angle, atan(t / h), against pybullet."""

from __future__ import annotations

import itertools
import math
import warnings

import numpy as np
import pytest

from stackdsl import compile_scenario, run_program
from stackdsl.compile.generators import tipping_angle
from stackdsl.compile.parts import arrange
from stackdsl.lang.errors import ScenarioError, ScenarioWarning
from stackdsl.lang.loader import parse_scenario

L, W, H = 0.12, 0.024, 0.008  # a KAPLA brick, m


def bricks(structure: str):
    return arrange(parse_scenario(f"stackdsl: 1\nstructure: {structure}\n", "g.yaml"))


# wall ------------------------------------------------------------------------------


@pytest.mark.parametrize("n, joint", [(1, 0.0), (4, 0.0), (5, 0.002)])
def test_a_wall_alternates_whole_courses_and_courses_closed_by_half_bricks(n, joint):
    wall = bricks(f"{{wall: {{courses: 4, bricks_per_course: {n}, joint: {joint}}}}}")
    pitch = L + joint
    for course in range(1, 5):
        row = sorted((b for b in wall if b.level == course), key=lambda b: b.position[0])
        assert all(math.isclose(b.position[2], (course - 0.5) * H) for b in row)
        xs = [b.position[0] for b in row]
        if course % 2:
            assert [b.type for b in row] == ["kapla"] * n
            assert np.allclose(xs, [(k - (n - 1) / 2) * pitch for k in range(n)])
        else:  # whole bricks over the joints of the course below, a half brick at each end
            assert [b.type for b in row] == ["kapla/2"] + ["kapla"] * (n - 1) + ["kapla/2"]
            assert np.allclose(xs[1:-1], [(k - (n - 2) / 2) * pitch for k in range(n - 1)])
            # the ends are straight: each closer's outer face is flush with the course below (the
            # joint beside it is j / 2), and it lies wholly on the end brick under it
            odd_end = (n * L + (n - 1) * joint) / 2
            assert math.isclose(xs[-1] + L / 4, odd_end, abs_tol=1e-12)
            assert math.isclose(xs[0] - L / 4, -odd_end, abs_tol=1e-12)
    assert [b.id for b in wall if b.level == 2][:2] == ["L02.1", "L02.2"]


def test_a_wall_on_edge_is_as_high_as_a_brick_is_wide_and_turns_with_its_yaw():
    wall = bricks("{wall: {courses: 2, bricks_per_course: 2, laid: edge, yaw: 90, origin: [1, 2]}}")
    assert {round(b.roll) for b in wall} == {90} and {round(b.yaw) for b in wall} == {90}
    assert np.allclose(sorted({round(b.position[2], 6) for b in wall}), [W / 2, 1.5 * W])
    assert np.allclose([b.position[0] for b in wall], 1.0)  # along y now
    assert math.isclose(float(np.mean([b.position[1] for b in wall if b.level == 1])), 2.0)


def test_half_bricks_are_half_as_long():
    scenario = parse_scenario("stackdsl: 1\nstructure: {wall: {courses: 2, bricks_per_course: 2}}\n", "w.yaml")
    assert scenario.brick_type("kapla/2").size == (L / 2, W, H)
    with pytest.raises(KeyError):
        scenario.brick_type("oak/2")


# pyramid ---------------------------------------------------------------------------


def test_a_pyramid_has_one_brick_fewer_a_course_each_over_a_joint_below():
    pyramid = bricks("{pyramid: {base: 5, joint: 2 mm}}")
    counts = [sum(b.level == c for b in pyramid) for c in range(1, 6)]
    assert counts == [5, 4, 3, 2, 1]
    for c in range(2, 6):
        below = sorted(b.position[0] for b in pyramid if b.level == c - 1)
        joints = [(a + b) / 2 for a, b in itertools.pairwise(below)]
        assert np.allclose(sorted(b.position[0] for b in pyramid if b.level == c), joints)
    assert len(bricks("{pyramid: {base: 5, levels: 2}}")) == 9


def test_a_pyramid_is_no_higher_than_its_base_is_wide():
    with pytest.raises(ScenarioError, match="at most 3 levels"):
        bricks("{pyramid: {base: 3, levels: 4}}")


@pytest.mark.slow
@pytest.mark.parametrize(
    "structure",
    [
        "{wall: {courses: 6, bricks_per_course: 4, joint: 1 mm}}",
        "{wall: {courses: 3, bricks_per_course: 3, laid: edge}}",
        "{pyramid: {base: 5}}",
    ],
)
def test_walls_and_pyramids_stand_and_the_extension_freezes_every_brick(structure):
    scenario = parse_scenario(f"stackdsl: 1\nstructure: {structure}\nexpect: {{stands: true}}\n", "s.yaml")
    program = compile_scenario(scenario)
    outcome = run_program(program)
    assert outcome.collapse is None
    states = {node.id: node.state for node in outcome.final_graph.nodes if node.id != "ground"}
    assert len(states) == len(program.placements)
    assert set(states.values()) == {"frozen"}, states
    assert outcome.certificate is not None and outcome.certificate.verdict == "stands"


# dominoes --------------------------------------------------------------------------


def test_a_straight_row_of_dominoes_is_spaced_as_given():
    row = bricks("{dominoes: {count: 30, spacing: 50 mm, yaw: 30, origin: [0.1, 0]}}")
    assert len(row) == 30 and row[0].id == "D01" and row[-1].id == "D30"
    centres = np.array([b.position for b in row])
    steps = np.diff(centres[:, :2], axis=0)
    assert np.allclose(np.linalg.norm(steps, axis=1), 0.05)
    assert np.allclose(steps / 0.05, [math.cos(math.radians(30)), math.sin(math.radians(30))])
    assert np.allclose(centres[:, 2], L / 2)  # on end: the length vertical
    assert {(round(b.yaw, 6), b.pitch) for b in row} == {(30.0, 90.0)}
    assert bricks("{dominoes: {count: 2}}")[1].position[0] == pytest.approx(L / 2)  # default spacing


@pytest.mark.parametrize("radius", [0.3, -0.3])
def test_an_arc_of_dominoes_lies_on_its_circle_spaced_along_it(radius):
    row = bricks(f"{{dominoes: {{count: 12, spacing: 60 mm, radius: {radius}}}}}")
    xy = np.array([b.position[:2] for b in row])
    centre = np.array([0.0, radius])  # the first at the origin heading along x: the centre on its left (right if negative)
    assert np.allclose(np.linalg.norm(xy - centre, axis=1), abs(radius))
    chords = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    assert np.allclose(chords, 2 * abs(radius) * math.sin(0.06 / (2 * abs(radius))))  # arc length 60 mm
    # each faces along the arc: its heading is the tangent there
    for b, (x, y) in zip(row, xy - centre):
        tangent = math.degrees(math.atan2(x, -y)) if radius > 0 else math.degrees(math.atan2(-x, y))
        assert math.isclose(math.remainder(b.yaw - tangent, 360.0), 0.0, abs_tol=1e-9)


def test_an_arc_of_dominoes_that_runs_round_past_its_start_is_warned_of():
    # a new user's 22 slats 120 mm apart on a 400 mm radius: D22 stood 0.7 mm in front of D01
    # (6.7 mm centre to centre), the row ran into its own start, and nothing said so
    row = "stackdsl: 1\nbrick_types: {{slat: {{size: [150 mm, 25 mm, 6 mm]}}}}\nstructure: {{dominoes: {{count: {}, spacing: 120 mm, radius: 400 mm, brick: slat}}}}\n"
    with pytest.warns(
        ScenarioWarning, match=r"arc.yaml:3:\d+: warning: structure\.dominoes\.count: .*D22 comes back to D01, its centre 6\.7 mm"
    ):
        compile_scenario(parse_scenario(row.format(22), "arc.yaml"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        compile_scenario(parse_scenario(row.format(21), "arc.yaml"))  # 2400 mm of a 2513 mm round: short of D01


def test_dominoes_that_would_overlap_are_refused_at_their_spacing():
    with pytest.raises(ScenarioError) as err:
        bricks("{dominoes: {count: 3, spacing: 7 mm}}")
    assert err.value.field == "structure.dominoes.spacing" and err.value.line == 2
    assert "above 8 mm" in err.value.message


def test_the_tipping_angle_is_atan_of_thickness_over_height():
    assert tipping_angle(H, L) == pytest.approx(math.atan(8 / 120))  # 3.81 deg for a KAPLA domino
    assert math.degrees(tipping_angle(1.0, 1.0)) == pytest.approx(45.0)


@pytest.mark.parametrize("past", [-2.0, 2.0])
def test_a_domino_tilted_on_its_edge_falls_back_below_its_tipping_angle_and_over_above_it(past):
    """pybullet alone, one domino resting on its front bottom edge at the tipping angle -+ 2 deg."""
    tilt = math.degrees(tipping_angle(H, L)) + past
    a = math.radians(tilt)
    pivot_x = H / 2
    x = pivot_x - H / 2 * math.cos(a) + L / 2 * math.sin(a)
    z = H / 2 * math.sin(a) + L / 2 * math.cos(a)
    text = (
        "stackdsl: 1\nengine: {mode: raw}\ntiming: {drop_gap: 0, settle: 2 s}\n"
        f"structure: {{bricks: [{{id: d, at: [{x}, 0, {z + 1e-5}], pitch: {90 + tilt}}}]}}\n"
    )
    outcome = run_program(compile_scenario(parse_scenario(text, "tip.yaml")))
    (node,) = [n for n in outcome.final_graph.nodes if n.id == "d"]
    if past < 0:  # back upright, on its end
        assert node.position_mm[2] == pytest.approx(60.0, abs=0.5)
    else:  # over onto its face
        assert node.position_mm[2] == pytest.approx(4.0, abs=0.5)


def test_a_domino_on_end_reads_back_the_yaw_it_was_placed_at():
    """On end, yaw and roll are one angle (gimbal lock): the outcome gives it as the yaw, roll 0."""
    scenario = parse_scenario(
        "stackdsl: 1\nstructure: {dominoes: {count: 6, radius: 300 mm}}\ntiming: {interval: 0.5 s}\n", "d.yaml"
    )
    program = compile_scenario(scenario)
    nodes = {n.id: n for n in run_program(program).final_graph.nodes}
    for place in program.placements:
        yaw, pitch, roll = nodes[place.id].yaw_pitch_roll_deg
        assert pitch == pytest.approx(90.0, abs=0.2) and roll == 0.0  # a graph keeps 3 quaternion decimals
        assert math.remainder(yaw - place.yaw, 360.0) == pytest.approx(0.0, abs=0.2)


def test_a_domino_row_is_frozen_behind_the_chain_while_its_front_still_falls():
    """The extension: each fallen domino leans on the next up to the chain's front; the part
    behind that has settled is frozen while the front falls (stability._debris), not when the
    last domino lands, and every domino still topples."""
    from stackdsl.bench.dominoes import domino_row

    program = compile_scenario(parse_scenario(domino_row(20, "extension report"), "d.yaml"))
    outcome = run_program(program)
    assert len(outcome.toppled) == 20
    woken = {e.brick: e.time for e in outcome.events if e.kind == "wake"}
    refrozen = [e.time for e in outcome.events if e.kind == "freeze" and e.brick == "d001" and e.time > woken["d001"]]
    assert refrozen and refrozen[0] < woken["d020"]  # the first is frozen again before the chain reaches the last


def test_the_domino_bench_does_not_count_dominoes_an_engine_threw_out_of_the_row():
    """A run whose engine blew up is no row that fell: MuJoCo resets it, every body back to its
    model pose far from the row and lying flat, which a toppled count alone takes for a fallen row."""
    from stackdsl.bench.dominoes import DominoCost, domino_cost, domino_row, format_dominoes, row_count

    fell = domino_cost(4, "raw 240 Hz")
    assert (fell.toppled, fell.left) == (4, 0)
    outcome = run_program(compile_scenario(parse_scenario(domino_row(4, "raw 240 Hz"), "d.yaml")))
    assert row_count(outcome) == (4, 0)
    thrown = outcome.model_copy(update={"displacement": {**outcome.displacement, "d002": 2.0}})
    assert row_count(thrown) == (3, 1)
    blown = outcome.model_copy(update={"stopped": "MuJoCo's simulation became unstable at t = 0.9 s"})
    assert row_count(blown) == (0, 4)
    table = format_dominoes(
        [DominoCost("raw", 4, 0.05, 4, 10), DominoCost("y", 4, 0.02, 0, 10, left=4), DominoCost("x", 4, 0.1, 4, 10)]
    )
    assert table.splitlines()[3].endswith("| blew up |") and table.splitlines()[4].endswith("| 2.00 |")

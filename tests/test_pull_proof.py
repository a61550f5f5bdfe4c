"""A pull that keeps the frozen bricks it slides between frozen (stability._drag): the drag proof
and what it does to a run."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation
from shapely.geometry import box

from stability import ContactArea
from stability._drag import DRAG_SAFETY, Dragged, held_by_program, held_in_line, held_together
from stackdsl import compile_scenario, parse_scenario, run_program

G = 9.81
UP = np.array([0.0, 0.0, 1.0])


def patch(x: float, y: float, half: float = 0.0125) -> ContactArea:
    return ContactArea(box(x - half, y - half, x + half, y + half), 0.0, UP, True)


def level_on(ys: list[float], mass: float, mu: float, drag: float, at_y: float) -> bool:
    """A brick lying across blocks at ``ys`` (equal shares of ``mass``), dragged along x at y = ``at_y``."""
    supports = {i: patch(0.0, y) for i, y in enumerate(ys)}
    loads = {i: (mass / len(ys), np.array([0.0, y, 0.0])) for i, y in enumerate(ys)}
    return held_together(
        {-1: Dragged(supports, loads, dict.fromkeys(supports, mu), np.array([drag, 0.0]), np.array([0.0, at_y]))}, G
    )


@pytest.mark.parametrize(("factor", "held"), [(0.95, True), (1.05, False)])
def test_a_drag_through_the_supports_centre_is_held_up_to_their_friction(factor, held):
    mass, mu = 0.3, 0.4
    assert level_on([-0.025, 0.025], mass, mu, factor * mu * mass * G, 0.0) is held


def test_a_middle_pull_is_held_with_the_safety_and_a_side_pull_is_not_for_the_twist():
    """A Jenga level on three blocks, a third of its weight on each: pulled from the middle, the
    two side blocks hold its drag twice over; pulled from a side, the drag acts 25 mm off the
    centre line and the two blocks left (each of which could hold it alone by force) cannot
    hold the twist as well (docs/actions.md: a near tie by point contacts)."""
    mass, mu = 0.3, 0.4
    drag = mu * mass / 3 * G
    assert level_on([-0.025, 0.025], 2 * mass / 3, mu, DRAG_SAFETY * drag, 0.0)
    assert not level_on([-0.025, 0.0], 2 * mass / 3, mu, drag, 0.025)


JENGA = """stackdsl: 1
materials: {maple: {density: 700 kg/m^3, friction: 0.4}}
brick_types: {jenga: {size: [75 mm, 25 mm, 15 mm], material: maple}}
ground: {material: maple}
structure: {tower: {levels: 5, bricks_per_layer: 3, spacing: 25.5 mm, turn: 90, brick: jenga}}
timing: {interval: 0.2 s, settle: 0.5 s}
actions:
  - remove: {brick: BRICK, at: after level 5, speed: 40 mm/s}
expect: {stands: true}
"""


@pytest.mark.parametrize(
    ("brick", "alone"),
    [
        ("L02.2", True),
        pytest.param("L02.3", True, marks=pytest.mark.slow),
        ("L03.3", False),  # 0.7 s: the words of a pull statics leaves to the engine, in every run of the tests
        pytest.param("L04.3", False, marks=pytest.mark.slow),
    ],
)
def test_a_proved_pull_moves_its_brick_alone_and_a_high_side_pull_wakes_the_level_it_drags(brick, alone):
    """The middle block of level 2 slides out of a frozen 5-level tower: statics holds the levels
    without it and against its drag, and nothing else wakes. A side block's drag twists the level
    above beyond what the two blocks left hold one by one; tied into one by levels 4 and 5 resting
    on them, they hold it (stability._drag.TIE_SAFETY), and nothing wakes either. A side block of
    level 3 drags level 4, which only the top level ties (a tie that carries nothing is not
    taken), and one of level 4 drags the top level, which nothing ties: that level wakes."""
    outcome = run_program(compile_scenario(parse_scenario(JENGA.replace("BRICK", brick), "pull.yaml")))
    pull = next(e.time for e in outcome.events if e.kind == "remove")
    woken = {e.brick for e in outcome.events if e.kind == "wake" and e.time >= pull} - {brick}
    assert (woken == set()) is alone, woken
    assert outcome.collapse is None or not alone
    (said,) = [e.detail for e in outcome.events if e.kind == "wake" and e.brick == brick and e.time >= pull]
    if alone:
        assert said.endswith("the bricks it slides between stay frozen: statics holds them without it and against its drag")
    else:  # the timeline says why statics left them to the engine
        assert "; statics does not keep the bricks it slides between frozen: " in said
    if brick == "L03.3":
        assert said.endswith(
            "L05.1, which ties the bricks it drags, carries nothing: a top level's tie, the lightest, is left to the engine"
        )  # the bricks under it wake: only a pull that fells what it carries keeps them (unmoved_below)
    if not alone:
        dragged = int(brick[1:3]) + 1
        assert {f"L{dragged:02d}.1", f"L{dragged:02d}.2", f"L{dragged:02d}.3"} <= woken


def test_a_proved_pull_glides_over_the_steps_its_proof_covers_with_the_same_result(monkeypatch):
    """The middle block of level 2 slides out under its proof: the hand carries it along its path
    over the steps nothing else moves in (Actions.glide, StabilityExtension.glides), and the run
    steps under half of what it steps without the glides, with the same timeline but for the
    times of the pulled brick's fall (once past its last support's edge it tilts on its way out,
    and leaves the scene a little sooner or later) and every other brick where it was."""
    from stackdsl.runtime.actions import Actions

    def run():
        return run_program(compile_scenario(parse_scenario(JENGA.replace("BRICK", "L02.2"), "pull.yaml")))

    glided = run()
    monkeypatch.setattr(Actions, "glide", lambda self, loop, limit: 0)
    stepped = run()
    assert glided.steps < stepped.steps / 2, (glided.steps, stepped.steps)
    assert glided.steps + glided.steps_skipped == stepped.steps + stepped.steps_skipped
    assert [(e.kind, e.brick) for e in glided.events] == [(e.kind, e.brick) for e in stepped.events]
    released = [next(e.time for e in o.events if e.kind == "release") for o in (glided, stepped)]
    assert abs(released[0] - released[1]) < 0.25, released
    assert glided.collapse is None and stepped.collapse is None
    for brick, moved in stepped.displacement.items():
        assert abs(glided.displacement[brick] - moved) < 1e-4, brick


@pytest.mark.parametrize("distance", [26, 100])
def test_a_pull_across_a_brick_and_on_over_the_ground_glides_too(distance):
    """An end brick of a flat pyramid's base slides out across its length under its proof, and on
    over the bare ground. Across, a quarter of its 120 mm wide overlap goes every 1.5 mm or so, no
    more than the brick lags its hand's path by a few steps: a glide as long as the room less
    that lag is still one the proof covers (Actions.glide). Past where it lay, the overlaps it was
    proved on are gone, but the ground plane carries it on (StabilityExtension.glides). The run
    steps under half of the pull's own steps, and the pyramid stands."""
    speed = 0.01
    text = f"""stackdsl: 1
name: pull across
structure: {{pyramid: {{base: 5}}}}
timing: {{interval: 0.5 s}}
actions:
  - remove: {{brick: L01.1, direction: +y, at: after level 5, speed: {speed * 1000:g} mm/s, distance: {distance} mm}}
"""
    program = compile_scenario(parse_scenario(text, "across.yaml"))
    outcome = run_program(program)
    pull_steps = distance / 1000 / speed / program.engine.timestep
    assert outcome.steps < pull_steps / 2, (outcome.steps, pull_steps)
    assert outcome.collapse is None


def test_a_brick_glided_along_the_ground_stays_on_it_level():
    """A lone brick pulled 100 mm across the bare ground at 5 mm/s glides most of the way, and
    lies on the ground as a stepped one does: after each carry the engine finds its contacts
    before the next step (a pose reset drops them), where it fell free for a step, 0.13 mm down
    and 0.12 deg over, after every 5 mm glide."""
    from stability._geometry import turn_between
    from stackdsl.runtime.loop import StepLoop, Subscriber

    text = """stackdsl: 1
name: a lone brick pulled across the ground
structure:
  bricks:
    - {at: [0, 0, 4 mm], id: a}
    - {at: [0, -60 mm, 4 mm], id: b}
timing: {interval: 0.5 s, settle: 0.5 s}
actions:
  - remove: {brick: a, at: 1.5 s, speed: 5 mm/s, direction: +y, distance: 100 mm}
"""

    class Watch(Subscriber):
        def __init__(self) -> None:
            self.poses: list = []

        def after_step(self, loop: StepLoop) -> None:
            record = loop.structure.records.get("a")
            if record is not None and loop.now > 1.5:
                self.poses.append(loop.world.pose(record.body))

    program = compile_scenario(parse_scenario(text, "ground.yaml"))
    watch = Watch()
    outcome = run_program(program, subscribers=(watch,))
    pulled = [p for p in watch.poses if p.position[2] < 1.0]  # before it is taken out of the scene
    assert outcome.steps < 0.1 / 0.005 / program.engine.timestep / 4, outcome.steps  # it glided
    lay = pulled[0]
    assert min(p.position[2] for p in pulled) > lay.position[2] - 2e-5
    assert max(turn_between(lay.orientation, p.orientation) for p in pulled) < 0.001


def level_over_three_blocks():
    """A fake world: three blocks on the ground along x, 30 mm apart, and one block across them."""
    from stability import Box, FakeEngine, Plane, Pose, StabilityExtension

    eng = FakeEngine()
    ext = StabilityExtension(eng)
    ext.add_ground(0, Plane(0.0))
    along, across = np.array([0.0375, 0.0125, 0.0075]), np.array([0.0125, 0.0375, 0.0075])
    for body, y in ((1, -0.03), (2, 0.0), (3, 0.03)):
        eng.poses[body] = Pose(np.array([0.0, y, 0.0075]))
        ext.add_brick(body, Box(along, 0.0098), f"b{body}", friction=0.4)
        eng.touch(body, 0, [[x, y + dy, 0.0] for x in (-0.0375, 0.0375) for dy in (-0.0125, 0.0125)], normal=[0, 0, 1])
    eng.poses[4] = Pose(np.array([0.0, 0.0, 0.0225]))
    ext.add_brick(4, Box(across, 0.0098), "top", friction=0.4)
    for body, y in ((1, -0.03), (2, 0.0), (3, 0.03)):
        eng.touch(4, body, [[x, y + dy, 0.015] for x in (-0.0125, 0.0125) for dy in (-0.0125, 0.0125)], normal=[0, 0, 1])
    for t in (0.0, 0.1, 0.2, 0.3):
        ext.update(t)
    assert {ext.state(b).value for b in (1, 2, 3, 4)} == {"frozen"}
    return eng, ext


def test_a_proved_pull_keeps_the_level_frozen_then_leaves_it_on_the_other_blocks():
    # the level pressed onto the three blocks by the blocks above it: with nothing above, its
    # centre of mass over the middle block, an engine may put all of its weight there (refused)
    eng, ext = levels_over_three_blocks(False)
    events = ext.guide(2, 0.4, "pulled", 0.04, (0.04, 0.0, 0.0))
    assert [(e.label, e.kind) for e in events] == [("b2", "wake")] and not ext.drags(2)
    ext.update(0.5)
    assert ext.state(4).value == "frozen" and ext.state(1).value == ext.state(3).value == "frozen"
    eng.contacts = [c for c in eng.contacts if 2 not in (c.body, c.other)]  # the hand took it away
    ext.forget(2)
    ext.update(0.6)
    assert ext.state(4).value == "frozen"
    assert ext.certificate().stands


def test_a_pull_whose_proof_is_lost_wakes_what_it_kept_frozen_as_an_unproved_pull_does():
    """Something else wakes the level a proved pull kept frozen: the blocks beside the pulled one,
    which carry that level, wake too (their load changes), as they do when a pull is not proved."""
    _, ext = levels_over_three_blocks(False)
    ext.guide(2, 0.4, "pulled", 0.04, (0.04, 0.0, 0.0))
    ext.wake(4, 0.45, "a blow")
    events = ext.update(0.5)
    assert {e.label for e in events if e.kind == "wake"} >= {"b1", "b3"} and ext.drags(2)


def levels_over_three_blocks(mergeable):
    """:func:`level_over_three_blocks` with three more blocks stacked on the one across (5 on 4,
    6 on 5, 7 on 6)."""
    from stability import Box, Pose

    eng, ext = level_over_three_blocks()
    eng.mergeable = mergeable
    across = np.array([0.0125, 0.0375, 0.0075])
    for body, below in ((5, 4), (6, 5), (7, 6)):
        z = 0.0225 + 0.015 * (body - 4)
        eng.poses[body] = Pose(np.array([0.0, 0.0, z]))
        ext.add_brick(body, Box(across, 0.0098), f"up{body}", friction=0.4)
        eng.touch(body, below, [[x, y, z - 0.0075] for x in (-0.0125, 0.0125) for y in (-0.0375, 0.0375)], normal=[0, 0, 1])
    for t in (0.4, 0.5, 0.6, 0.7):
        ext.update(t)
    assert {ext.state(b).value for b in range(1, 8)} == {"frozen"}
    return eng, ext


def test_what_rests_on_the_bricks_a_pull_drags_rides_them_as_one_body_until_the_pull_ends():
    """A hand moves block 2 without a proof: the block across it (4) wakes, with the blocks
    beside that carry it (1, 3) and the block that rests on it (5: free, its friction ties what
    the pull drags, as a free brick's does); the two above 5 stay frozen, merged into one body in
    the engine, and wake when the pull ends. An engine that cannot merge wakes them all at once."""
    eng, ext = levels_over_three_blocks(mergeable=True)
    woken = {e.label for e in ext.guide(2, 0.8, "pushed", 0.04) if e.kind == "wake"}
    assert woken == {"b1", "b2", "b3", "top", "up5"}
    assert eng.merged == [(6, 7)] and ext.state(6).value == ext.state(7).value == "frozen"
    ext.update(0.85)
    assert eng.merged == [(6, 7)]
    eng.contacts = [c for c in eng.contacts if 2 not in (c.body, c.other)]
    ext.forget(2)
    events = ext.update(0.9)
    rode = {e.label: e.reason for e in events if e.kind == "wake"}
    assert set(rode) == {"up6", "up7"} and "rode the pull of b2 as one body until it ended" in rode["up6"]
    assert eng.merged == [] and ext.state(6).value == "active"
    eng, ext = levels_over_three_blocks(mergeable=False)
    woken = {e.label for e in ext.guide(2, 0.8, "pushed", 0.04) if e.kind == "wake"}
    assert woken == {"b1", "b2", "b3", "top", "up5", "up6", "up7"} and eng.merged == []


def test_two_stacks_on_a_moved_block_do_not_ride_it_as_one_body():
    """The block a hand moves carries the level of :func:`levels_over_three_blocks` and, apart
    from it, a column of three small blocks (8 on 2, 9 on 8, 10 on 9, 11 on 10): what would
    ride (6 and 7 over the level, 10 and 11 over the column) is two pieces, which one body would
    hold together across the air. Nothing rides, and everything above wakes."""
    from stability import Box, Pose

    eng, ext = levels_over_three_blocks(mergeable=True)
    half = np.array([0.0075, 0.0075, 0.0075])
    for body, below in ((8, 2), (9, 8), (10, 9), (11, 10)):
        z = 0.0225 + 0.015 * (body - 8)
        eng.poses[body] = Pose(np.array([0.03, 0.0, z]))
        ext.add_brick(body, Box(half, 0.0034), f"col{body}", friction=0.4)
        corners = [[0.03 + dx, dy, z - 0.0075] for dx in (-0.0075, 0.0075) for dy in (-0.0075, 0.0075)]
        eng.touch(body, below, corners, normal=[0, 0, 1])
    for t in (0.8, 0.9, 1.0, 1.1):
        ext.update(t)
    assert {ext.state(b).value for b in range(1, 12)} == {"frozen"}
    woken = {e.label for e in ext.guide(2, 1.2, "pushed", 0.04) if e.kind == "wake"}
    assert eng.merged == [] and {"up6", "up7", "col10", "col11"} <= woken


def level_left_on_two_blocks(apart=False):
    """A fake world: two blocks on the ground along x, at y = -30 and +30 mm (the middle one of a
    Jenga level taken), a block across them and three stacked on it (5 on 4, 6 on 5, 7 on 6),
    all frozen; merging allowed. With ``apart``, a fourth stacked on block 1 beside the level,
    touching nothing else (8)."""
    from stability import Box, FakeEngine, Plane, Pose, StabilityExtension

    eng = FakeEngine()
    eng.mergeable = True
    ext = StabilityExtension(eng)
    ext.add_ground(0, Plane(0.0))
    along, across = np.array([0.0375, 0.0125, 0.0075]), np.array([0.0125, 0.0375, 0.0075])
    for body, y in ((1, -0.03), (3, 0.03)):
        eng.poses[body] = Pose(np.array([0.0, y, 0.0075]))
        ext.add_brick(body, Box(along, 0.0098), f"b{body}", friction=0.4)
        eng.touch(body, 0, [[x, y + dy, 0.0] for x in (-0.0375, 0.0375) for dy in (-0.0125, 0.0125)], normal=[0, 0, 1])
    for body in (4, 5, 6, 7):
        z = 0.0225 + 0.015 * (body - 4)
        eng.poses[body] = Pose(np.array([0.0, 0.0, z]))
        ext.add_brick(body, Box(across, 0.0098), f"up{body}", friction=0.4)
    for body, y in ((1, -0.03), (3, 0.03)):
        eng.touch(4, body, [[x, y + dy, 0.015] for x in (-0.0125, 0.0125) for dy in (-0.0125, 0.0125)], normal=[0, 0, 1])
    for body in (5, 6, 7):
        z = 0.015 * (body - 3)
        eng.touch(body, body - 1, [[x, y, z] for x in (-0.0125, 0.0125) for y in (-0.0375, 0.0375)], normal=[0, 0, 1])
    if apart:
        eng.poses[8] = Pose(np.array([0.03, -0.03, 0.0225]))
        ext.add_brick(8, Box(np.array([0.0075, 0.0075, 0.0075]), 0.0034), "apart", friction=0.4)
        eng.touch(
            8, 1, [[0.03 + dx, -0.03 + dy, 0.015] for dx in (-0.0075, 0.0075) for dy in (-0.0075, 0.0075)], normal=[0, 0, 1]
        )
    for t in (0.0, 0.1, 0.2, 0.3):
        ext.update(t)
    assert {ext.state(b).value for b in eng.poses} == {"frozen"}
    return eng, ext


def test_a_pull_that_fells_what_it_carries_lets_all_of_it_ride_as_one_body():
    """Block 1 pulled out from under a level left on it and block 3: without it, the level and
    the three above lie on block 3 alone, their centre of mass 30 mm off its middle, and statics
    says they fall. The level rides the pull with the three above, one body in the engine (the
    drag of a side block on a level left on it and one other is a Coulomb tie, which no free
    brick decides better); only the pulled block and the one beside wake. A brick on block 1
    apart from the level would be merged with it across the air: then only what rests on the
    level rides it, as when a pull is not proved for another reason."""
    eng, ext = level_left_on_two_blocks()
    events = ext.guide(1, 0.4, "pulled", 0.04, (0.04, 0.0, 0.0))
    (said,) = [e.reason for e in events if e.kind == "wake" and e.label == "b1"]
    assert "the frozen stack does not stand without it" in said
    assert {e.label for e in events if e.kind == "wake"} == {"b1", "b3"}
    assert {e.label for e in events if e.kind == "ride"} == {"up4", "up5", "up6", "up7"}
    assert eng.merged == [(4, 5, 6, 7)]
    eng, ext = level_left_on_two_blocks(apart=True)
    events = ext.guide(1, 0.4, "pulled", 0.04, (0.04, 0.0, 0.0))
    assert {e.label for e in events if e.kind == "ride"} == {"up6", "up7"} and eng.merged == [(6, 7)]
    assert {"up4", "up5", "apart"} <= {e.label for e in events if e.kind == "wake"}


def test_a_ride_ends_for_all_when_one_rider_wakes_or_it_falls_freely():
    """A blow that wakes one rider wakes them all; a ride whose support is pulled from under it
    falls freely (its first rider gains 0.49 m/s downwards in 0.05 s): it feels no gravity, and
    ends."""
    eng, ext = levels_over_three_blocks(mergeable=True)
    ext.guide(2, 0.8, "pushed", 0.04)
    woken = {w.label for w in ext.wake(7, 0.85, "a blow")}
    assert woken == {"up6", "up7"} and eng.merged == []
    eng, ext = levels_over_three_blocks(mergeable=True)
    ext.guide(2, 0.8, "pushed", 0.04)
    assert not [e for e in ext.update(0.85) if e.kind == "wake"]
    eng.velocities[6] = (np.array([0.0, 0.0, -0.4905]), np.zeros(3))
    rode = {e.label: e.reason for e in ext.update(0.9) if e.kind == "wake"}
    assert set(rode) == {"up6", "up7"} and "its bricks feel gravity tilted 90 deg" in rode["up6"]


def tilted(eng, degrees, about="x"):
    """Turn the ride's first rider (6) about its centre by ``degrees`` about ``about``: the
    fake engine's merged body moves no other part, and the ride is read from its first rider."""
    from scipy.spatial.transform import Rotation

    from stability import Pose

    eng.poses[6] = Pose(eng.poses[6].position, Rotation.from_euler(about, degrees, degrees=True).as_quat())


def test_a_tilted_ride_rides_on_while_its_bricks_are_proved_to_hold_tilted_and_ends_when_they_slide():
    """Up to RIDE_TILT nothing is asked; past it the riders are proved rigid under gravity tilted
    twice as far (or, failing that, 0.5 deg further), and ride on; friction 0.4 holds a level to
    21.8 deg (tan 0.4), 19.1 deg over the proof's 30 deg cone, and at 25 deg the top rider slides
    on the one under it: the ride ends, every rider woken, with why."""
    eng, ext = levels_over_three_blocks(mergeable=True)
    ext.guide(2, 0.8, "pushed", 0.04)
    tilted(eng, 0.4)
    assert not [e for e in ext.update(0.85) if e.kind == "wake"]  # under RIDE_TILT
    for t, degrees in ((0.9, 0.6), (0.95, 5.0), (1.0, 10.0), (1.05, 18.0)):
        tilted(eng, degrees)
        assert not [e for e in ext.update(t) if e.kind == "wake"], degrees
        assert eng.merged == [(6, 7)]
    tilted(eng, 25.0)
    rode = {e.label: e.reason for e in ext.update(1.1) if e.kind == "wake"}
    assert set(rode) == {"up6", "up7"} and eng.merged == []
    assert "until it tilted 25.00 deg" in rode["up6"] and "up7 slides on up6" in rode["up6"]


def test_a_tilted_ride_feels_its_acceleration_as_tilted_gravity():
    """A ride tilted 1 deg whose first rider's velocity changes by 0.6 m/s across in 0.1 s
    (6 m/s^2: gravity felt tilted 31 deg) is not held by friction 0.4: it ends; the same ride
    moving steadily rides on."""
    eng, ext = levels_over_three_blocks(mergeable=True)
    ext.guide(2, 0.8, "pushed", 0.04)
    tilted(eng, 1.0)
    assert not [e for e in ext.update(0.85) if e.kind == "wake"]
    eng.velocities[6] = (np.array([0.0, 0.01, 0.0]), np.zeros(3))
    assert not [e for e in ext.update(0.9) if e.kind == "wake"]  # a steady 10 mm/s over 0.05 s
    eng.velocities[6] = (np.array([0.0, 0.61, 0.0]), np.zeros(3))
    rode = {e.label: e.reason for e in ext.update(1.0) if e.kind == "wake"}
    assert set(rode) == {"up6", "up7"} and "slides" in rode["up6"]


def test_a_ride_turned_about_the_vertical_asks_friction_for_its_swirl():
    """A side pull twists what rides it: spun up to 0.5 rad/s about the vertical in 0.05 s
    (10 rad/s^2; its farthest corner 39.5 mm across from its first rider's centre: alpha times
    that over g is 0.04 of friction's 0.4) it rides on; spun up to 3 rad/s in 0.05 s (60 rad/s^2:
    0.24, and 0.06 for the tilt its spin adds) too (a bound twice the ride's reach from its centre
    of mass asked 0.49 and ended it); spun up to 6 rad/s (120 rad/s^2: 0.48) its bricks would
    slide on each other, and it ends."""
    for spin, ends in ((0.5, False), (3.0, False), (6.0, True)):
        eng, ext = levels_over_three_blocks(mergeable=True)
        ext.guide(2, 0.8, "pushed", 0.04)
        assert not [e for e in ext.update(0.85) if e.kind == "wake"]
        eng.velocities[6] = (np.zeros(3), np.array([0.0, 0.0, spin]))
        rode = {e.label: e.reason for e in ext.update(0.9) if e.kind == "wake"}
        assert bool(rode) is ends, spin
        assert not ends or ("slides" in rode["up6"] and "more for its twist" in rode["up6"])


def test_a_ride_whose_motion_is_not_finite_ends():
    eng, ext = levels_over_three_blocks(mergeable=True)
    ext.guide(2, 0.8, "pushed", 0.04)
    assert not [e for e in ext.update(0.85) if e.kind == "wake"]
    eng.velocities[6] = (np.array([np.nan, 0.0, 0.0]), np.zeros(3))
    rode = {e.label: e.reason for e in ext.update(0.9) if e.kind == "wake"}
    assert set(rode) == {"up6", "up7"} and "no longer finite" in rode["up6"]


def test_a_tilted_ride_ends_when_it_comes_near_a_body_it_did_not_touch():
    """The ride's gap to what it did not touch is measured (10 mm clear: the fake engine finds
    nothing near it) and the engine is not asked again while the ride cannot have come within
    1.5 mm of anything (it has not moved); once it has moved 9 mm towards block 3 it is asked,
    finds block 3 within 1.5 mm, and the ride ends."""
    from stability import ContactPoint, Pose

    eng, ext = levels_over_three_blocks(mergeable=True)
    ext.guide(2, 0.8, "pushed", 0.04)
    tilted(eng, 1.0)
    asked, near = [], eng.near
    eng.near = lambda body, distance, among=None: asked.append(body) or near(body, distance, among)
    assert not [e for e in ext.update(0.85) if e.kind == "wake"]
    assert asked.count(6) == 2  # what it touched when it began, and its gap to the rest
    eng.contacts.append(ContactPoint(6, 3, np.array([0.0, 0.03, 0.05]), np.array([0.0, 0.0, 1.0]), 0.0, 0.001))
    assert not [e for e in ext.update(0.9) if e.kind == "wake"]
    assert asked.count(6) == 2  # not moved: nothing can have come within reach
    eng.poses[6] = Pose(eng.poses[6].position + np.array([0.0, 0.009, 0.0]), eng.poses[6].orientation)
    rode = {e.label: e.reason for e in ext.update(0.95) if e.kind == "wake"}
    assert set(rode) == {"up6", "up7"} and "it came within 1.5 mm of b3" in rode["up6"]


def test_a_body_taken_away_leaves_the_kept_gap_of_a_guided_body_sound():
    """The pulled block's kept gap (stability._gap) is measured against the bodies it may touch,
    a moving brick among them; that brick taken out of the scene, the gap is measured anew."""
    from stability import Box, Pose

    eng, ext = levels_over_three_blocks(mergeable=True)
    eng.poses[9] = Pose(np.array([0.3, 0.0, 0.0075]))
    eng.velocities[9] = (np.array([0.1, 0.0, 0.0]), np.zeros(3))
    ext.add_brick(9, Box(np.array([0.0125, 0.0375, 0.0075]), 0.0098), "loose", friction=0.4)
    ext.guide(2, 0.8, "pushed", 0.04)
    asked, near = [], eng.near
    eng.near = lambda body, distance, among=None: asked.append((body, among)) or near(body, distance, among)
    ext.update(0.85)
    assert any(body == 2 and among is not None and 9 in among for body, among in asked)
    ext.forget(9)
    asked.clear()
    ext.update(0.9)  # 9 gone from the stack: no longer read as moving, and the gap measured again
    assert any(body == 2 for body, _ in asked)


@pytest.mark.slow
def test_the_kept_gaps_find_what_the_engine_finds_asked_each_step(monkeypatch):
    """A KAPLA 4 stack of 10 levels whose L04.1 is pulled at 100 mm/s: levels 5 to 10 ride it
    and come within 1.5 mm of L03.1. At every step the kept gaps of the pulled brick and of the
    ride (stability._gap) answer what the engine answers when asked there and then, and the
    engine was asked for the ride's at under a fifth of them (the pulled brick's, at most: it
    slides on the bricks of level 3)."""
    import stability._extension as extension
    from stability._gap import near_within

    calls, asked, found = [], [], []

    def checked(stack, body, span, others, distance, kept):
        engine, near = stack.engine, stack.engine.near
        engine.near = lambda *a: asked.append(a) or near(*a)  # the world's own, counted
        try:
            points, gap = near_within(stack, body, span, others, distance, kept)
        finally:
            del engine.near
        exact = stack.engine.near(body, distance, others)
        assert sorted(c.other for c in points) == sorted(c.other for c in exact)
        calls.append((span, body))
        found.extend(points)
        return points, gap

    monkeypatch.setattr(extension, "near_within", checked)
    scene = """stackdsl: 1
structure: {tower: {levels: 10, bricks_per_layer: 2, spacing: 96 mm, turn: 90}}
timing: {interval: 0.2 s, settle: 0.5 s}
actions:
  - remove: {brick: L04.1, at: after level 10, speed: 100 mm/s}
"""
    outcome = run_program(compile_scenario(parse_scenario(scene, "kapla.yaml")))
    ride = max(calls)[1]  # the ride spans more than a brick
    rides = [body for _, body in calls].count(ride)
    assert found and rides > 100 and [a[0] for a in asked].count(ride) < rides / 5
    # L03.1 or L03.2: the tower is symmetric about the pull, and which of the two the ride nears
    # first is decided by round-off (OpenBLAS's AVX-512 kernels say L03.2, its Haswell ones L03.1)
    assert any(re.search(r"came within 1\.5 mm of L03\.[12]\b", e.detail) for e in outcome.events if e.kind == "wake")


def test_a_level_stack_that_stands_on_no_vertical_forces_without_the_pulled_block_is_refused_at_once(monkeypatch):
    """Where every contact is level, the frozen stack must stand without the pulled block on
    vertical forces alone; where it does not, the proof is refused without the program with
    friction (0.7 s for an 18-level tower that a side pull fells). The block across the level
    is left on the block at one side, with the blocks on it, their centre of mass 17.5 mm past
    that block's edge."""
    import stability._drag as drag
    from stability._drag import PullProof

    eng, ext = levels_over_three_blocks(False)
    ext.guide(2, 0.4, "pulled", 0.04, (0.04, 0.0, 0.0))
    eng.contacts = [c for c in eng.contacts if 2 not in (c.body, c.other)]  # the middle block taken away
    ext.forget(2)
    ext.update(0.5)
    assert {ext.state(b).value for b in (1, 3, 4)} == {"frozen"}

    def no_friction_program(*args, **kwargs):
        raise AssertionError("the program with friction was solved")

    monkeypatch.setattr(drag, "solve_equilibrium", no_friction_program)
    stack = ext._stack
    proof = PullProof(stack, 1, np.array([0.04, 0.0, 0.0]), stack.engine.near(1, 0.001))
    assert proof.why is not None and "vertical forces alone" in proof.why
    assert PullProof(stack, 3, np.array([0.04, 0.0, 0.0]), stack.engine.near(3, 0.001)).why == proof.why


def jenga_levels(levels):
    """A fake world: ``levels`` Jenga levels of three 75 x 25 x 15 mm blocks 25 mm apart, each
    level turned 90 degrees from the one under it (bodies 1-3 the first, 4-6 the second...)."""
    from stability import Box, FakeEngine, Plane, Pose, StabilityExtension

    eng = FakeEngine()
    ext = StabilityExtension(eng)
    ext.add_ground(0, Plane(0.0))
    along, across = np.array([0.0375, 0.0125, 0.0075]), np.array([0.0125, 0.0375, 0.0075])
    lines = (-0.025, 0.0, 0.025)
    for level in range(levels):
        z = 0.0075 + 0.015 * level
        for i, line in enumerate(lines):
            body = 3 * level + i + 1
            centre = [0.0, line, z] if level % 2 == 0 else [line, 0.0, z]
            eng.poses[body] = Pose(np.array(centre))
            ext.add_brick(body, Box(along if level % 2 == 0 else across, 0.0275), f"L{level + 1}.{i + 1}", friction=0.4)
            if level == 0:
                eng.touch(body, 0, [[x, line + dy, 0.0] for x in (-0.0375, 0.0375) for dy in (-0.0125, 0.0125)], normal=[0, 0, 1])
                continue
            for other in lines:
                below = 3 * (level - 1) + lines.index(other) + 1
                x, y = (other, line) if level % 2 == 0 else (line, other)
                square = [[x + dx, y + dy, z - 0.0075] for dx in (-0.0125, 0.0125) for dy in (-0.0125, 0.0125)]
                eng.touch(body, below, square, normal=[0, 0, 1])
    for t in (0.0, 0.1, 0.2, 0.3):
        ext.update(t)
    assert {ext.state(b).value for b in range(1, 3 * levels + 1)} == {"frozen"}
    return eng, ext


@pytest.mark.parametrize(("levels", "proved"), [(2, False), (3, False), (4, True), (6, True)])
def test_a_side_pull_is_proved_only_when_the_levels_above_tie_the_level_it_drags(levels, proved):
    """A side block of the first level pulled along its length drags the three blocks of the
    second off their centre line: each alone on the two blocks left holds 0.89 times that drag
    at equal shares, under the 1.5 asked (DRAG_SAFETY). A third level resting on them ties them
    into one, which holds it 1.13 times, but as the top level it carries nothing and is not
    taken as a tie; a third with a fourth on it ties them 1.15 times, over TIE_SAFETY."""
    from stability._drag import TIE_SAFETY, PullProof

    assert 1.0 < TIE_SAFETY < 1.14
    _, ext = jenga_levels(levels)
    stack = ext._stack
    proof = PullProof(stack, 3, np.array([0.04, 0.0, 0.0]), stack.engine.near(3, 0.001))
    assert (proof.why is None) is proved, proof.why
    assert (proof.kept >= {4, 5, 6}) is proved


@pytest.mark.parametrize(("levels", "refused"), [(2, "nothing rests on"), (4, None)])
def test_a_middle_pull_under_the_top_level_is_not_proved_for_the_share_an_engine_may_put_on_it(levels, refused):
    """The middle block of the first level pulled: at equal shares the two side blocks hold the
    drag on each block of the second level 2 times over. With nothing resting on those (the top
    level), each lies on the middle block alone as well, its centre of mass over it: an engine's
    compliant contacts may put all of its weight there, and then nothing holds the drag (a KAPLA
    top level was dragged off by both tuned engines where such a proof kept it)."""
    from stability._drag import PullProof

    _, ext = jenga_levels(levels)
    stack = ext._stack
    proof = PullProof(stack, 2, np.array([0.04, 0.0, 0.0]), stack.engine.near(2, 0.001))
    if refused is None:
        assert proof.why is None
    else:
        assert proof.why is not None and refused in proof.why, proof.why


def test_a_tie_passes_on_no_more_than_its_friction():
    """Two blocks on fixed pads, 100 mm apart, a third lying across both: a drag on one block is
    held by its own pad's friction (up to ``mu`` times its load) and, through the tie's friction
    on it (up to ``mu`` times the tie's share), by the other block's pad: 1.5 times what the
    block alone holds, no more."""
    from shapely.geometry import box as rectangle

    def pad(x):
        return ContactArea(rectangle(x - 0.01, -0.01, x + 0.01, 0.01), 0.0, np.array([0.0, 0.0, 1.0]), True)

    mu, g, kg = 0.5, 9.81, 1.0  # each block and the tie weigh 2 kg; the tie puts 1 kg on each block

    def bricks(drag):
        return {
            1: Dragged(
                {0: pad(-0.05)},
                {0: (2 * kg, np.array([-0.05, 0.0, 0.0]))},
                {0: mu},
                np.array([drag, 0.0]),
                np.array([-0.05, 0.0]),
            ),
            2: Dragged({0: pad(0.05)}, {0: (2 * kg, np.array([0.05, 0.0, 0.0]))}, {0: mu}, np.zeros(2), np.array([0.05, 0.0])),
            3: Dragged(
                {1: pad(-0.05), 2: pad(0.05)},
                {1: (kg, np.array([-0.05, 0.0, 0.0])), 2: (kg, np.array([0.05, 0.0, 0.0]))},
                {1: mu, 2: mu},
                np.zeros(2),
                np.zeros(2),
            ),
        }

    alone = mu * 2 * kg * g
    assert held_together(bricks(1.45 * alone), g) and not held_together(bricks(1.55 * alone), g)
    assert held_together({1: bricks(0.95 * alone)[1]}, g) and not held_together({1: bricks(1.05 * alone)[1]}, g)


STUCK = """
import json, sys
import numpy as np
from shapely.geometry import Polygon
from stability import ContactArea
from stability._drag import Dragged, held_together
UP = np.array([0.0, 0.0, 1.0])
bricks = {
    int(b): Dragged(
        {int(s): ContactArea(Polygon(c), 0.0, UP, True) for s, c in d["supports"].items()},
        {int(s): (m, np.array(p)) for s, (m, p) in d["loads"].items()},
        {int(s): f for s, f in d["friction"].items()},
        np.array(d["drag"]),
        np.array(d["at"]),
    )
    for b, d in json.load(open(sys.argv[1])).items()
}
print(held_together(bricks, 9.81))
"""
"""Asks the program of tests/stuck_tied_program.json: the tied program of a new user's side pull
(8 levels of beech blocks, 90 x 30 x 18 mm, friction 0.3, 30.5 mm apart; L06.1 of a beech of
friction 0.34 pulled at 25 mm/s), its dragged level's three blocks along y, 0.0776 N each, and
the level above that ties them, as the proof asked it, every float as it was. HiGHS cycled on
it for minutes (SIGTERM unheard, memory growing). A tie on top is no longer taken, so that pull
no longer asks it; a program like it may still come."""


def test_a_stuck_tied_program_is_not_held_after_its_iterations():
    """A program the solver cannot settle counts as not held once it has taken ITERATIONS (the
    pull is then stepped, as an unproved one is), instead of hanging the run; in a child
    process, so that a solver stuck in C fails the test instead of hanging it."""
    import subprocess
    import sys
    from pathlib import Path

    try:
        program = str(Path(__file__).with_name("stuck_tied_program.json"))
        done = subprocess.run([sys.executable, "-c", STUCK, program], capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        pytest.fail("the tied program did not come back within 60 s")
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "False"


def _pads(xs: list[float], ys: list[float]) -> tuple[dict[int, ContactArea], list[np.ndarray]]:
    """Square pads of 25 mm centred at (x, y), bodies 10, 11, ..., and a load point inside each."""
    areas = {10 + i: patch(x, y) for i, (x, y) in enumerate(zip(xs, ys, strict=True))}
    return areas, [np.array([x, y, 0.0]) for x, y in zip(xs, ys, strict=True)]


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@example(
    xs=[0.0, 0.0], ys=[-0.0255, 0.0255, 0.0], shifts=[0.0] * 6, masses=[0.1, 0.1, 0.0], mu=0.4, drag=(0.5, 0.0), at=(0.0, 0.0)
)
@given(
    xs=st.lists(st.floats(-0.05, 0.05), min_size=1, max_size=3),
    ys=st.lists(st.floats(-0.05, 0.05), min_size=3, max_size=3),
    shifts=st.lists(st.floats(-0.012, 0.012), min_size=6, max_size=6),
    masses=st.lists(st.floats(0.0, 1.0), min_size=3, max_size=3),
    mu=st.floats(0.1, 0.9),
    drag=st.tuples(st.floats(-8.0, 8.0), st.floats(-8.0, 8.0)),
    at=st.tuples(st.floats(-0.06, 0.06), st.floats(-0.06, 0.06)),
)
def test_what_is_held_in_line_the_friction_program_holds_too(xs, ys, shifts, masses, mu, drag, at):
    """The forces ``held_in_line`` finds are a solution of ``held_together``'s program: whenever it
    says held, the program (asked alone) says so too. Random pads, loads anywhere on them (and
    one off its pad now and then), drags anywhere."""
    areas, points = _pads(xs, ys[: len(xs)])
    loads = {
        b: (m, p + np.array([shifts[2 * i], shifts[2 * i + 1], 0.0]))
        for i, ((b, _), p, m) in enumerate(zip(areas.items(), points, masses, strict=False))
    }
    bricks = {1: Dragged(areas, loads, dict.fromkeys(areas, mu), np.array(drag), np.array(at))}
    if held_in_line(bricks, G):
        assert held_by_program(bricks, G)


def test_a_middle_pull_is_held_in_line_without_the_program_and_a_side_pull_asks_it(monkeypatch):
    """A Jenga block on three others, equal shares, dragged from the middle one (half of the drag
    on each side block, 0.75 of the friction of its share at the safety): held with no linear
    program; dragged from a side one, its drag twists it, and the program decides (not held)."""
    mass, mu = 0.3, 0.4
    ys = [-0.0255, 0.0, 0.0255]
    areas, points = _pads([0.0, 0.0, 0.0], ys)
    loads = {b: (mass / 3, p) for b, p in zip(areas, points, strict=True)}

    def dragged(pulled: int) -> dict[int, Dragged]:
        others = {b: a for b, a in areas.items() if b != pulled}
        drag = np.array([DRAG_SAFETY * mu * mass / 3 * G, 0.0])
        return {
            1: Dragged(others, {b: loads[b] for b in others}, dict.fromkeys(others, mu), drag, np.array([0.0, ys[pulled - 10]]))
        }

    def no_program(*_args, **_kwargs):
        raise AssertionError("the linear program was asked")

    monkeypatch.setattr("stability._drag.solve", no_program)
    assert held_in_line(dragged(11), G) and held_together(dragged(11), G)
    assert not held_in_line(dragged(12), G)
    with pytest.raises(AssertionError, match="the linear program was asked"):
        held_together(dragged(12), G)


def test_a_look_left_out_by_the_travel_bound_would_have_found_nothing_changed():
    """PullProof.unchanged skips finding a pulled block's overlaps when its travel and turn since
    they were last found cannot have shrunk one by SHRINK of its proved area: along a pull of the
    middle block of a 4-level Jenga tower, with a little turn and sideways drift, every position it
    skips finds no overlap changed by that much, and it skips some."""
    from stability._drag import SHRINK, PullProof, footprint
    from stability._geometry import Pose

    _, ext = jenga_levels(4)
    stack = ext._stack
    proof = PullProof(stack, 2, np.array([0.04, 0.0, 0.0]), stack.engine.near(2, 0.001))
    assert proof.why is None
    start = stack.pose(stack.bodies[2])
    half = stack.bodies[2].box.half_extents
    areas = proof.overlaps(footprint(half, start))
    skipped = 0
    for step in range(1, 160):  # 0.5 mm a look, 80 mm in all, turning 2e-6 rad a look about z and drifting in y
        turn = Rotation.from_euler("z", 2e-6 * step) * Rotation.from_quat(start.orientation)
        pose = Pose(start.position + np.array([0.0005 * step, 2e-6 * step, 0.0]), turn.as_quat())
        if proof.unchanged(areas, pose):
            skipped += 1
            now = proof.overlaps(footprint(half, pose))  # found without remembering them: as a skipped look would
            assert not any(now[a] <= areas[a] - SHRINK * proof.area[a] or (areas[a] > 0 and now[a] == 0) for a in now)
            continue
        now = proof.overlaps(footprint(half, pose), pose)
        areas = areas | {a: now[a] for a in now if now[a] <= areas[a] - SHRINK * proof.area[a]}
    assert 20 < skipped < 140, skipped  # it skips some looks, and looks again


def test_the_room_of_a_glide_is_a_way_the_travel_bound_still_skips():
    """PullProof.room: the way along the pull that unchanged's bound still covers. At every look of
    a pull of the middle block of a 4-level Jenga tower (drifting and turning a little), a pose
    that far on (less a hair) is one unchanged skips, and the room shrinks to nothing as the
    brick nears the point where a look is due."""
    from stability._drag import PullProof, footprint
    from stability._geometry import Pose

    _, ext = jenga_levels(4)
    stack = ext._stack
    proof = PullProof(stack, 2, np.array([0.04, 0.0, 0.0]), stack.engine.near(2, 0.001))
    start = stack.pose(stack.bodies[2])
    half = stack.bodies[2].box.half_extents
    areas = proof.overlaps(footprint(half, start), start)
    rooms = []
    for step in range(1, 160):
        turn = Rotation.from_euler("z", 2e-6 * step) * Rotation.from_quat(start.orientation)
        pose = Pose(start.position + np.array([0.0005 * step, 2e-6 * step, 0.0]), turn.as_quat())
        room = proof.room(areas, pose)
        rooms.append(room)
        if room > 0.0:
            on = Pose(pose.position + np.array([0.999 * room, 0.0, 0.0]), pose.orientation)
            assert proof.unchanged(areas, on), (step, room)
        if not proof.unchanged(areas, pose):
            assert room == 0.0
            now = proof.overlaps(footprint(half, pose), pose)
            areas = areas | {a: now[a] for a in now if now[a] <= areas[a] - 0.25 * proof.area[a]}
    assert max(rooms) > 0.004 and rooms.count(0.0) > 5, rooms


def test_a_glide_goes_as_far_as_a_stepped_pull_goes_without_a_look():
    """PullProof.unlooked: the way a stepped pull goes before moved() says yes and the overlaps
    are looked at. A pose that far on (less a hair) is one moved() says no to, a pose past it one
    it says yes to: a glide that far asks no less of the overlaps than the steps it skips."""
    from stability._drag import LOOK, PullProof

    _, ext = jenga_levels(4)
    stack = ext._stack
    proof = PullProof(stack, 2, np.array([0.04, 0.0, 0.0]), stack.engine.near(2, 0.001))
    start = stack.pose(stack.bodies[2]).position
    assert proof.unlooked(start) == 0.0  # never looked: nothing to go by
    assert proof.moved(start)
    for way in (0.0, 0.0001, 0.0003, 0.00049):
        assert proof.unlooked(start + [way, 0.0, 0.0]) == pytest.approx(LOOK - way)
    far = proof.unlooked(start + [0.0001, 0.0, 0.0])
    assert not proof.moved(start + [0.0001 + 0.999 * far, 0.0, 0.0])
    assert proof.unlooked(start + [0.0001 + 1.001 * far, 0.0, 0.0]) == 0.0
    assert proof.moved(start + [0.0001 + 1.001 * far, 0.0, 0.0])


@pytest.mark.parametrize(("toward", "proved"), [(0.0, True), (0.005, True), (0.05, False)])
def test_a_pull_heading_into_the_block_beside_it_keeps_nothing_frozen(toward, proved):
    """A block beside the pulled one, touching it, is kept frozen only while the pull runs along
    it: one written 2.9 deg into it (``direction: [0.05, 1, 0]``) was proved, kept it frozen,
    and went 2.2 mm into it. Headed into it by more than TOWARD, it lies in the pull's way."""
    from stability._drag import TOWARD, PullProof

    assert 0.005 < TOWARD < 0.05
    eng, ext = jenga_levels(4)
    stack = ext._stack
    for side, y in ((1, -0.0125), (3, 0.0125)):  # the middle block of level 1 touches both side blocks
        eng.touch(2, side, [[x, y, z] for x in (-0.0375, 0.0375) for z in (0.0, 0.015)], normal=[0, -np.sign(y), 0])
    way = np.array([0.04, 0.04 * toward, 0.0])  # along its length, turned toward block 3 (+y)
    proof = PullProof(stack, 2, way, stack.engine.near(2, 0.001))
    assert (proof.why is None) is proved, proof.why
    if not proved:
        assert proof.why == "L1.3 lies in its way"
    else:
        assert {1, 3} <= proof.kept


KAPLA_PULL = """stackdsl: 1
name: a KAPLA 4 stack felled by a pull from under level 5
GROUND
structure: {tower: {levels: 10, bricks_per_layer: 2, spacing: 96 mm, turn: 90}}
actions:
  - remove: {brick: L04.1, at: after level 10, speed: 30 mm/s}
expect: {collapse: 10, stays: 1-3}
"""


def test_a_pull_that_fells_the_tower_keeps_the_bricks_under_it_that_its_friction_cannot_drag():
    """The pulled brick slides on L03.1 and L03.2 while the tower above it falls: its friction on
    them is at most their pair's coefficient times its load on them, which their supports carry
    too, with the same coefficient: they stay frozen (both engines tuned agree on MuJoCo; tuned
    pybullet dragged L03.2 27.6 mm, as the extension did when it woke them)."""
    outcome = run_program(compile_scenario(parse_scenario(KAPLA_PULL.replace("GROUND\n", ""), "kapla_pull.yaml")))
    pulled = next(e for e in outcome.events if e.kind == "wake" and e.brick == "L04.1")
    assert "L03.1, L03.2 under it stay frozen" in pulled.detail
    assert not any(e.kind == "wake" and e.brick in ("L03.1", "L03.2") and "L04.1" in e.detail for e in outcome.events)
    assert outcome.collapse is not None and outcome.collapse.level == 10
    assert max(outcome.displacement[b] for b in ("L03.1", "L03.2")) < 0.004


def test_a_brick_under_a_pull_on_a_slicker_support_than_the_pull_wakes():
    """On a ground slicker than the bricks, the frozen stack under the pulled brick could slide on
    it under a load the pull's friction drags: nothing under the pull is kept."""
    slick = "materials: {ice: {density: 900 kg/m^3, friction: 0.1}}\nground: {material: ice}\n"
    outcome = run_program(compile_scenario(parse_scenario(KAPLA_PULL.replace("GROUND\n", slick), "kapla_pull.yaml")))
    pulled = next(e for e in outcome.events if e.kind == "wake" and e.brick == "L04.1")
    assert "under it stay frozen" not in pulled.detail
    woken = {e.brick for e in outcome.events if e.kind == "wake" and "carries L04.1, which a hand moves" in e.detail}
    assert woken == {"L03.1", "L03.2"}


def jenga_tower(levels):
    """A fake Jenga tower of ``levels`` levels of three 75 x 25 x 15 mm blocks 25.5 mm apart,
    each level across the one under it, frozen; the middle block of level 2 is body 5."""
    from stability import Box, FakeEngine, Plane, Pose, StabilityExtension

    eng = FakeEngine()
    eng.mergeable = True
    ext = StabilityExtension(eng)
    ext.add_ground(0, Plane(0.0))
    along, across = np.array([0.0375, 0.0125, 0.0075]), np.array([0.0125, 0.0375, 0.0075])
    body, below = 0, []
    for k in range(levels):
        here = []
        for i, s in enumerate((-0.0255, 0.0, 0.0255)):
            body += 1
            centre = np.array([0.0, s, 0.0075 + 0.015 * k]) if k % 2 == 0 else np.array([s, 0.0, 0.0075 + 0.015 * k])
            eng.poses[body] = Pose(centre)
            ext.add_brick(body, Box(along if k % 2 == 0 else across, 0.0098), f"L{k + 1:02d}.{i + 1}", friction=0.4)
            if k == 0:
                eng.touch(body, 0, [[x, s + d, 0.0] for x in (-0.0375, 0.0375) for d in (-0.0125, 0.0125)], normal=[0, 0, 1])
            for other, at in below:
                x, y = (centre[0], at[1]) if k % 2 == 1 else (at[0], centre[1])
                square = [[x + dx, y + dy, 0.015 * k] for dx in (-0.0125, 0.0125) for dy in (-0.0125, 0.0125)]
                eng.touch(body, other, square, normal=[0, 0, 1])
            here.append((body, centre))
        below = here
    for t in (0.0, 0.1, 0.2, 0.3):
        ext.update(t)
    assert {ext.state(b).value for b in range(1, body + 1)} == {"frozen"}
    return eng, ext


@pytest.mark.parametrize(
    ("levels", "degrees", "rides"), [(14, 10.0, True), (14, 15.0, True), (14, 19.0, False), (24, 14.0, False)]
)
def test_a_tilted_ride_of_levels_that_cross_is_proved_tied_not_brick_by_brick(levels, degrees, rides):
    """The middle block of level 2 pushed, levels 5 up ride it (levels 3 and 4 wake: they rest
    on it). Tilted 10 or 15 deg across its blocks, the report's tipping test fails level 6's side
    block alone (the 67.5 mm of levels it carries over its 25 mm width), but the levels above
    tie it to its neighbours: by rigid-block equilibrium the riders stand up to their friction,
    0.4 (19 deg over the proof's cone, where level 6 slides), and the ride goes on. Levels 5 to
    24 tied are a block 300 mm tall on 76.5 mm, which tips past 14 deg: tilted 14 deg the ride
    ends, its bricks proved to stand up to 12 deg (within an eighth of the most, in every
    direction)."""
    from scipy.spatial.transform import Rotation

    from stability import Pose

    eng, ext = jenga_tower(levels)
    ext.guide(5, 0.4, "pushed", 0.04)
    (riders,) = eng.merged
    assert len(riders) == 3 * (levels - 4)
    assert not [e for e in ext.update(0.45) if e.kind == "wake"]
    first = riders[0]
    eng.poses[first] = Pose(eng.poses[first].position, Rotation.from_euler("y", degrees, degrees=True).as_quat())
    rode = {e.label: e.reason for e in ext.update(0.5) if e.kind == "wake"}
    assert (not rode) is rides, rode
    if degrees == 19.0:
        assert "L06.1 slides on L05.1" in rode["L05.1"]
    elif not rides:
        assert "L06.1 tips" in rode["L05.1"] and "tied to each other by the levels they cross" in rode["L05.1"]
        proved = float(rode["L05.1"].split("proved to stand up to ")[1].split(" deg")[0])
        assert 10.0 < proved < 14.0


@pytest.mark.parametrize("degrees", [0.0, 20.0, 40.0])
def test_a_ride_s_swirl_bounds_the_twist_at_its_farthest_corner_and_not_far_beyond(degrees):
    """The swirl of stability._ride.felt_gravity, times the gravity felt, is at least the
    horizontal acceleration that a turn about the vertical gives the farthest corner of a column
    of two bricks from its first brick's centre, the column tilted by 0, 20 or 40 deg, and at most
    1.5 times it: the farthest corner across as they froze, and what their height turns across."""
    from scipy.spatial.transform import Rotation

    from stability import Box, Pose
    from stability._ride import RideLimit, arms_of, felt_gravity

    brick = Box(np.array([0.0125, 0.0375, 0.0075]), 0.0098)
    low, high = Pose(np.array([0.0, 0.0, 0.0075])), Pose(np.array([0.0, 0.0, 0.0225]))
    span, across, rise = arms_of(low, [(brick, low), (brick, high)])
    limit = RideLimit(0.5, np.zeros(2), 0.0, frozenset(), span, across, rise, np.zeros(3), np.zeros(3), 0.0)
    turn = Rotation.from_euler("x", degrees, degrees=True)
    now = Pose(low.position, turn.as_quat())
    alpha = 10.0  # rad/s^2 about the vertical, over the window
    _, _, swirl = felt_gravity(limit, now, low, np.zeros(3), np.array([0.0, 0.0, alpha * 0.05]), 0.05, 9.81)
    corners = np.concatenate([brick.corners(low), brick.corners(high)]) - low.position
    farthest = alpha * float(np.hypot(*turn.apply(corners)[:, :2].T).max())
    assert farthest <= swirl * 9.81 <= 1.5 * farthest


def test_the_stability_model_s_margin_asks_tied_riders_to_stand_that_far_inside_their_contacts():
    """Levels 5 to 24 of the fake tower riding a push are proved tied to a tilt that their
    300 mm height over 76.5 mm of contacts limits; asked to stand 5 mm inside each contact's area
    (the report's tipping test's margin), they are proved to less, and still to some."""
    from dataclasses import replace

    from stability._ride import tied_tilt

    eng, ext = jenga_tower(24)
    ext.guide(5, 0.4, "pushed", 0.04)
    (riders,) = eng.merged
    whole = tied_tilt(ext._stack, riders)
    ext._stack.config = replace(ext._stack.config, com_margin=0.005)
    assert 0.0 < tied_tilt(ext._stack, riders) < whole

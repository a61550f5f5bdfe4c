"""A stack on a shaken ground that moves as one rigid body: it rides the ground merged.

A rigid stack on a base accelerating horizontally is moved by the base's friction alone: it
accelerates by at most mu_0 g and slides on the base beyond that. A block standing on such a
sliding stack is pushed by at most that acceleration, so it tips only when b / h < mu_0 (half-width
b along the shake, centre of mass h above its contact), and slips only when its own contact's
friction coefficient is under the ground's. The extension proves a part rigid by rigid-block
equilibrium under gravity tilted by mu_0 g (:func:`stability._shake.sliding_parts`), and then the
engine moves it as one body: its slip on the base must follow the closed form of a rigid block on
a harmonically moving base with Coulomb friction (Shenton 1996, slide mode), and its bricks must
keep their places in it.

The closed form of the slip is :func:`stackdsl.bench.shake_models.coulomb_slip`'s.
"""

from __future__ import annotations

import numpy as np
import pytest

from stability import Box, FakeEngine, Plane, Pose, StabilityExtension
from stackdsl import compile_scenario, parse_scenario
from stackdsl.bench.shake_models import coulomb_slip
from stackdsl.runtime.run import run_in, world_for

G = 9.81
MU = 0.5


def two_blocks(
    half_top: tuple[float, float, float], mu_top: float = MU, half_base: tuple[float, float, float] = (0.05, 0.05, 0.005)
) -> tuple[FakeEngine, StabilityExtension]:
    """A block of half extents ``half_base`` (wide and flat by default) on the ground and a block
    of half extents ``half_top`` on it, both frozen; ``mu_top``: the top block's friction
    coefficient."""
    eng = FakeEngine()
    eng.mergeable = True
    ext = StabilityExtension(eng)
    ext.add_ground(0, Plane(0.0), friction=MU)
    base = np.array(half_base)
    bx, by, _ = half_base
    eng.poses[1] = Pose(np.array([0.0, 0.0, base[2]]))
    ext.add_brick(1, Box(base, 0.05), "base", friction=MU)
    eng.touch(1, 0, [[-bx, -by, 0], [bx, -by, 0], [bx, by, 0], [-bx, by, 0]], normal=[0, 0, 1])
    hx, hy, hz = half_top
    eng.poses[2] = Pose(np.array([0.0, 0.0, 2 * base[2] + hz]))
    ext.add_brick(2, Box(np.array(half_top), 0.01), "top", friction=mu_top)
    z = 2 * base[2]
    eng.touch(2, 1, [[-hx, -hy, z], [hx, -hy, z], [hx, hy, z], [-hx, hy, z]], normal=[0, 0, 1])
    ext.update(0.0)
    ext.update(0.1)
    assert ext.state(1).value == "frozen" and ext.state(2).value == "frozen"
    return eng, ext


@pytest.mark.parametrize(("ratio", "rides"), [(1.1, True), (0.9, False)])
def test_a_block_on_a_sliding_base_tips_only_below_the_ground_friction(ratio, rides):
    """b / h = ratio x mu_0; the ground shakes at 1.4 mu_0 g (the stack slides): it rides as one
    body when the top block cannot tip under mu_0 g, and is simulated when it can."""
    h = 0.02  # the top block's centre of mass above its contact
    eng, ext = two_blocks((ratio * MU * h, 0.01, h))
    assert ext.withstands((1.4 * MU * G, 0.0)) is not None  # as it stands, it does not withstand the shake
    events = ext.shake((1.4 * MU * G, 0.0), 0, 1.0, "the ground shakes")
    kinds = {e.label: e.kind for e in events}
    if rides:
        assert kinds == {"base": "ride", "top": "ride"}
        assert eng.merged == [(1, 2)] and not ext.quiet  # a ride under way moves them
        # the words say that it slides, and at what the ground's friction accelerates what it carries
        assert f"sliding on ground, whose friction accelerates it by at most {MU * G:.3g} m/s^2" in events[0].reason
    else:
        assert kinds == {"base": "wake", "top": "wake"}, events
        assert "rigid-block equilibrium fails" in events[0].reason and not eng.merged


def test_a_column_that_tips_over_as_one_block_is_simulated():
    """Two 20 mm-wide blocks, 80 mm tall together: under mu_0 g their centre of mass, 40 mm up,
    acts 20 mm aside, at the footing's edge and past it (the part's own test, before the program)."""
    _, ext = two_blocks((0.01, 0.01, 0.02), half_base=(0.01, 0.01, 0.02))
    events = ext.shake((0.8 * G, 0.0), 0, 1.0, "the ground shakes")
    assert {e.kind for e in events} == {"wake"} and "tips over as one block" in events[0].reason


def test_a_block_of_less_friction_than_the_ground_slips_and_is_simulated():
    """The ground's pair is 0.5, the top block's contact only 0.3: under 0.5 g it slips."""
    _, ext = two_blocks((0.02, 0.01, 0.005), mu_top=0.18)  # pair with the base: sqrt(0.18 x 0.5) = 0.3
    events = ext.shake((0.8 * G, 0.0), 0, 1.0, "the ground shakes")
    assert {e.kind for e in events} == {"wake"} and "would move" in events[0].reason


def test_a_ride_ends_near_another_body_and_when_it_rests_on_a_still_ground():
    eng, ext = two_blocks((0.02, 0.01, 0.005))
    ext.admitting = False  # the ground moves
    ext.shake((0.8 * G, 0.0), 0, 1.0, "the ground shakes")
    eng.velocities[1] = (np.array([0.2, 0.0, 0.0]), np.zeros(3))
    assert ext.update(1.01) == [] and eng.merged  # moving, on a moving ground: it rides on
    eng.poses[3] = Pose(np.array([0.2, 0.0, 0.005]))
    ext.add_brick(3, Box(np.array([0.01, 0.01, 0.005]), 0.01), "other")
    eng.touch(1, 3, [[0.05, 0.0, 0.005]], normal=[-1, 0, 0])
    woken = ext.update(1.02)
    assert not eng.merged and {e.label for e in woken if e.kind == "wake"} >= {"base", "top"}
    assert "came within" in next(e.reason for e in woken if e.label == "base")
    eng2, ext2 = two_blocks((0.02, 0.01, 0.005))
    ext2.admitting = False
    ext2.shake((0.8 * G, 0.0), 0, 1.0, "the ground shakes")
    ext2.admitting = True  # the ground has stopped, and the part is at rest
    woken = ext2.update(3.0)
    assert not eng2.merged and "came to rest" in next(e.reason for e in woken if e.label == "base")


def test_a_ride_at_rest_on_a_still_ground_is_frozen_again_where_it_lies():
    """Its bricks stay frozen, each on what it lay on, the areas moved with them (not woken: the
    engine would start them cold); the first freeze's area of the top block is its area moved."""
    eng, ext = two_blocks((0.02, 0.01, 0.005))
    ext.admitting = False
    ext.shake((0.8 * G, 0.0), 0, 1.0, "the ground shakes")
    shift = np.array([0.03, -0.01, 0.0])
    before = {b: ext._stack.bodies[b].rests_on[s].polygon.centroid for b, s in ((1, 0), (2, 1))}
    for body in (1, 2):
        eng.poses[body] = Pose(eng.poses[body].position + shift)
    ext.admitting = True
    events = ext.update(3.0)
    assert [(e.kind, e.label) for e in events] == [("freeze", "base"), ("freeze", "top")], events
    assert "came to rest: frozen again where it lies, on ground" in events[0].reason
    assert not eng.merged and eng.frozen >= {1, 2}
    for body, support in ((1, 0), (2, 1)):
        rec = ext._stack.bodies[body]
        assert rec.frozen_pose is not None and np.allclose(rec.frozen_pose.position, eng.poses[body].position)
        moved = rec.rests_on[support].polygon.centroid
        assert (moved.x - before[body].x, moved.y - before[body].y) == pytest.approx((0.03, -0.01), abs=1e-12)
    assert ext.update(3.1) == []  # and it stands there


def test_a_ride_that_came_to_rest_apart_wakes():
    """A top block no longer face to face on the base (lifted 3 mm in the engine) is not frozen
    again where it lies: the ride's bricks wake, as a ride's end wakes them."""
    eng, ext = two_blocks((0.02, 0.01, 0.005))
    ext.admitting = False
    ext.shake((0.8 * G, 0.0), 0, 1.0, "the ground shakes")
    eng.poses[2] = Pose(eng.poses[2].position + [0.0, 0.0, 0.003])
    ext.admitting = True
    events = ext.update(3.0)
    assert {e.label: e.kind for e in events if e.label in ("base", "top")} == {"base": "wake", "top": "wake"}, events


def test_a_single_file_that_rode_a_shake_stands_where_it_came_to_rest():
    """15 KAPLA bricks on end to end along the shake, a = 0.64 g over friction 0.5: the file slides
    as one body and, the ground stopped, stands 1.4 mm from its place, as tuned pybullet (1.7 mm)
    and tuned MuJoCo (3.6 mm) keep it. Woken at rest, pybullet started the column cold: it sank
    0.3 mm a joint, buckled across the shake and fell."""
    text = """stackdsl: 1
structure: {tower: {levels: 15, bricks_per_layer: 1, turn: 0}}
actions:
  - shake: {amplitude: 10 mm, frequency: 4 Hz, duration: 1 s, direction: [1, 0], at: after level 15}
expect: {stands: true}
"""
    program = compile_scenario(parse_scenario(text, "file15.yaml"))
    with world_for(program) as world:
        loop = run_in(world, program)
    settled = [e for e in loop.events if e.kind == "freeze" and "frozen again where it lies" in e.detail]
    assert len(settled) == 15, [str(e) for e in loop.events if e.time > 15.0]
    assert not any(e.kind == "collapse" for e in loop.events)


def _rode_whole(text: str, apart: float) -> np.ndarray:
    """Run the scenario ``text``: every brick rode the shaken ground, and their horizontal
    shifts from where they were placed (shape (bricks, 2), m) agree within ``apart`` metres (one
    rigid body); returns the shifts."""
    program = compile_scenario(parse_scenario(text, "slide.yaml"))
    with world_for(program) as world:
        loop = run_in(world, program)
        records = loop.structure.records
        moved = {rid: np.array(loop.world.pose_floats(r.body)[0]) - r.pose.position for rid, r in records.items()}
    rides = [e for e in loop.events if e.kind == "ride"]
    assert {e.brick for e in rides} == set(records), [e.detail for e in loop.events if e.kind == "wake"][:1]
    shifts = np.array([m[:2] for m in moved.values()])
    assert np.ptp(shifts, axis=0).max() < apart, shifts  # one rigid body: every brick moved alike
    return shifts


@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
def test_a_four_stack_slides_as_one_body_by_the_closed_form(backend):
    """A 2-level 4 stack on a ground shaken at 0.71 g (mu 0.5): it rides as one body, its four
    bricks keep their places in it, and it slips on the ground as a rigid block does, on both
    engines (MuJoCo's merged body slid 9.6 mm, the closed form 9.5)."""
    text = f"""stackdsl: 1
engine: {{backend: {backend}}}
structure:
  tower: {{levels: 2, bricks_per_layer: 2, spacing: 96 mm, turn: 90}}
timing: {{settle: 1 s}}
actions:
  - shake: {{amplitude: 44 mm, frequency: 2 Hz, duration: 2 s, direction: [1, 0], at: after level 2}}
"""
    shifts = _rode_whole(text, 0.0002)
    expected, _ = coulomb_slip(0.044, 2.0, 4, 0.5, dt=1e-4)  # 9.5 mm
    assert abs(abs(shifts[0, 0]) - abs(expected)) < 0.15 * abs(expected), (shifts[0, 0], expected)
    assert abs(shifts[0, 1]) < 0.001


@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
def test_a_stack_on_a_ground_of_another_material_slides_by_their_pair(backend):
    """Bricks of friction 0.5 on a ground of 0.3 (pair 0.39), shaken at 0.48 g: the stack slides
    as one body by the Coulomb block of the pair's coefficient. On MuJoCo the pair is an explicit
    contact pair, which collides whatever a geom's collision bits: the merged bricks' own bodies,
    left where they froze, held the table still (0.00 mm) until they were put out of the way."""
    text = f"""stackdsl: 1
engine: {{backend: {backend}}}
materials:
  pine: {{density: 500 kg/m^3, friction: 0.5}}
  slick: {{density: 500 kg/m^3, friction: 0.3}}
brick_types: {{b: {{size: [120 mm, 24 mm, 8 mm], material: pine}}}}
ground: {{material: slick}}
structure:
  tower: {{levels: 3, bricks_per_layer: 2, spacing: 96 mm, turn: 90, brick: b}}
timing: {{settle: 1 s}}
actions:
  - shake: {{amplitude: 30 mm, frequency: 2 Hz, duration: 2 s, direction: [1, 0], at: after level 3}}
"""
    shifts = _rode_whole(text, 0.0005)
    expected, _ = coulomb_slip(0.03, 2.0, 4, float(np.sqrt(0.5 * 0.3)), dt=1e-4)  # 2.95 mm
    assert abs(abs(shifts[0, 0]) - abs(expected)) < 0.15 * abs(expected), (shifts[0, 0], expected)


def test_the_graph_of_a_ride_is_where_the_part_is_carried():
    """Its bricks are drawn where the engine carried them, with their centre of mass above
    carried alike, on the supports they froze with."""
    eng, ext = two_blocks((0.02, 0.01, 0.005))
    still = {n.label: n for n in ext.graph().nodes}
    ext.shake((0.8 * G, 0.0), 0, 1.0, "the ground shakes")
    shift = np.array([0.007, -0.002, 0.0])
    for body in (1, 2):
        eng.poses[body] = Pose(eng.poses[body].position + shift)
    graph = ext.graph()
    moved = {n.label: n for n in graph.nodes}
    for label in ("base", "top"):
        assert np.allclose(moved[label].pose.position, still[label].pose.position + shift)
        assert np.allclose(moved[label].com_above, still[label].com_above + shift)
    assert {(e.upper, e.support) for e in graph.edges} == {("base", "ground"), ("top", "base")}


def test_a_ride_the_ground_carries_says_so():
    """A 10-level 4 stack shaken at 3.95 m/s^2 (under mu g, 4.9): the report's check fails (a brick
    tips on its own 24 mm contact), equilibrium holds it, and the ground carries it, sliding not."""
    text = """stackdsl: 1
structure:
  tower: {levels: 10, bricks_per_layer: 2, spacing: 96 mm, turn: 90}
timing: {settle: 1 s}
actions:
  - shake: {amplitude: 25 mm, frequency: 2 Hz, duration: 1 s, direction: [1, 0], at: after level 10}
"""
    program = compile_scenario(parse_scenario(text, "carried.yaml"))
    with world_for(program) as world:
        loop = run_in(world, program)
    rides = [e for e in loop.events if e.kind == "ride"]
    assert len(rides) == 20
    assert "moves as one rigid body of 20 bricks, carried by ground at 3.95 m/s^2" in rides[0].detail
    # the others say whose ride they are in, not the same long reason 19 times over (a new user's
    # 4 stack printed it 12 times)
    assert {e.detail for e in rides[1:]} == {f"moves with {rides[0].brick}, one rigid body of 20 bricks"}

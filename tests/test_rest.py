"""The rest test: the report's for placed bricks, the windowed one for fallen bricks."""

import numpy as np
import pytest

from stability import Box, BrickState, FakeEngine, Plane, Pose, StabilityConfig, StabilityExtension
from stability._areas import by_body
from stability._rest import JITTER, RestClock, still

CONFIG = StabilityConfig()
DT = 1 / 240
ZERO = np.zeros(3)
KAPLA = Box(np.array([0.06, 0.012, 0.004]), 0.0106)


def run(clock: RestClock, speeds: list[float], creep: float = 0.0) -> list[bool]:
    """Tick ``clock`` once a step with these linear speeds (m/s, along x) while the brick's
    pose creeps at ``creep`` m/s; what it says at each step."""
    out = []
    for i, v in enumerate(speeds):
        pose = Pose(np.array([creep * i * DT, 0.0, 0.004]))
        out.append(clock.tick(abs(v), 0.0, lambda p=pose: p, i * DT, CONFIG))
    return out


def test_a_placed_brick_is_at_rest_only_under_the_thresholds_for_the_whole_duration():
    steps = round(CONFIG.rest_duration / DT)
    calm = run(RestClock(), [0.004] * (steps + 1))
    assert calm[-1] and not calm[steps - 1]  # rested once a full rest duration has passed
    jitter = run(RestClock(), [0.02 if i % 2 else 0.004 for i in range(10 * steps)])
    assert not any(jitter)  # one step above the threshold starts it again


def test_a_fallen_brick_that_jitters_in_place_is_at_rest_after_one_window():
    steps = round(CONFIG.rest_duration / DT)
    said = run(RestClock(fallen=True), [0.02 if i % 2 else -0.02 for i in range(3 * steps)])
    assert said.index(True) == steps and all(said[steps:])


@pytest.mark.parametrize("creep, rests", [(0.004, True), (0.006, False)])
def test_a_fallen_brick_rests_only_when_its_mean_speed_is_under_the_threshold(creep, rests):
    said = run(RestClock(fallen=True), [creep] * 60, creep=creep)
    assert any(said) is rests


def test_a_fallen_brick_faster_than_the_jitter_cap_starts_again():
    steps = round(CONFIG.rest_duration / DT)
    speeds = [0.0] * (steps - 2) + [1.01 * JITTER * CONFIG.rest_speed] + [0.0] * (steps + 1)
    said = run(RestClock(fallen=True), speeds)
    assert not any(said[: 2 * steps - 2]) and said[-1]


def test_still_compares_distance_and_angle():
    start = Pose(np.zeros(3))
    assert still(start, Pose.from_euler([0.0002, 0, 0]), 0.00025, 0.0025)
    assert not still(start, Pose.from_euler([0.0003, 0, 0]), 0.00025, 0.0025)
    assert not still(start, Pose.from_euler([0, 0, 0], roll=0.2), 0.00025, 0.0025)  # 3.5 mrad


def woken_brick(debris: bool) -> tuple[StabilityExtension, FakeEngine]:
    """A brick frozen on the ground and woken again, jittering at 20 mm/s in place."""
    engine = FakeEngine()
    ext = StabilityExtension(engine, StabilityConfig(debris=debris))
    ext.add_ground(0, Plane(0.0))
    engine.poses[1] = Pose(np.array([0.0, 0.0, 0.004]))
    ext.add_brick(1, KAPLA, "b1")
    engine.touch(1, 0, [[-0.06, -0.012, 0], [0.06, 0.012, 0]], normal=[0, 0, 1])
    ext.update(0.0)
    ext.update(0.1)
    assert ext.state(1) is BrickState.FROZEN
    ext.wake(1, 0.2, "test")
    return ext, engine


@pytest.mark.parametrize("debris", [True, False])
def test_a_woken_brick_is_judged_by_the_window_only_with_the_debris_rule(debris):
    ext, engine = woken_brick(debris)
    for i in range(48):
        engine.velocities[1] = (np.array([0.02 if i % 2 else -0.02, 0.0, 0.0]), ZERO)
        ext.update(0.2 + i * DT)
    assert (ext.state(1) is BrickState.FROZEN) is debris


def test_a_pile_is_frozen_raised_out_of_its_supports_and_its_members():
    """Two fallen bricks crosswise on the ground, each sunk 0.3 mm into what it rests on (a pile
    pressed together by its weight): the lower one is raised 0.3 mm, the upper one 0.6 mm, so
    that frozen they no longer overlap."""
    engine = FakeEngine()
    ext = StabilityExtension(engine, StabilityConfig(leaning=False))
    ext.add_ground(0, Plane(0.0))
    engine.frozen.add(0)
    sink = 0.0003
    for body, z, yaw in ((1, 0.004 - sink, 0.0), (2, 0.012 - 2 * sink, 90.0)):
        engine.poses[body] = Pose.from_euler([0.0, 0.0, z], yaw=yaw)
        ext.add_brick(body, KAPLA, f"b{body}")
    engine.touch(1, 0, [[-0.06, -0.012, 0], [0.06, 0.012, 0], [-0.06, 0.012, 0]], normal=[0, 0, 1], distance=-sink)
    top = 0.008 - sink
    engine.touch(2, 1, [[-0.012, -0.012, top], [0.012, 0.012, top], [-0.012, 0.012, top]], normal=[0, 0, 1], distance=-sink)
    stack = ext._stack
    group = [stack.bodies[1], stack.bodies[2]]
    plan = {1: ({0: None}, None), 2: ({1: None}, None)}
    contacts = by_body(engine.contact_points())
    lifts = ext._admission.lifts(group, plan, contacts)  # type: ignore[arg-type]
    assert lifts[1] == pytest.approx(sink, abs=1e-6)
    assert lifts[2] == pytest.approx(2 * sink, abs=1e-6)

"""What the collapse monitor measures each step (stackdsl.runtime.bricks.Structure.measure), held to
its definition on a world without an engine."""

from __future__ import annotations

import numpy as np
import pytest

from stability import Pose
from stackdsl.engines.fake import FakeWorld
from stackdsl.engines.protocol import BrickSpec
from stackdsl.runtime.bricks import FEW, BrickRecord, Structure

KAPLA = BrickSpec(type="kapla", half_extents=(0.06, 0.012, 0.004), mass=0.0106, friction=0.5, restitution=0.0)
THRESHOLD = 0.004


def _structure(bricks: int) -> tuple[FakeWorld, Structure]:
    """``bricks`` bricks side by side, each moved as its index says: b0 slid 10 mm, b1 turned 5 deg
    in place, b2 slid 3 mm (within the threshold), b3 lifted 6 mm, the others where they were placed."""
    world = FakeWorld()
    structure = Structure(world)
    for i in range(bricks):
        pose = Pose(np.array([0.0, 0.05 * i, 0.004]))
        body = world.create(KAPLA, pose)
        structure.add(BrickRecord(f"b{i}", body, KAPLA, 1, pose, pose))
        moved = {
            0: Pose(np.array([0.01, 0.05 * i, 0.004])),
            1: Pose.from_euler([0.0, 0.05 * i, 0.004], yaw=5.0),
            2: Pose(np.array([0.003, 0.05 * i, 0.004])),
            3: Pose(np.array([0.0, 0.05 * i, 0.010])),
        }.get(i)
        if moved is not None:
            world.poses[body] = moved
    return world, structure


@pytest.mark.parametrize("bricks", [3, 10, FEW + 8])  # in floats, and past FEW in numpy
@pytest.mark.parametrize(
    "pending, frozen",
    [((), ()), (("b2",), ()), (("b5", "b2"), ("b5",)), (("b9", "b8", "b7", "b6", "b5", "b2"), ("b9", "b5"))],
)
def test_the_pending_bricks_and_every_moving_one_past_the_threshold_are_measured(bricks, pending, frozen):
    _, structure = _structure(bricks)
    pending = tuple(i for i in pending if i in structure.records)
    for i in frozen:
        if i in structure.records:
            structure.set_moving(structure.records[i], False)
    watched, moved = structure.measure(dict.fromkeys(pending), THRESHOLD)
    assert [r.order for r in watched] == sorted(r.order for r in watched)  # in the order placed
    exact = {r.id: structure.displacement(r) for r in structure.placed}
    for r, d in zip(watched, moved.tolist()):
        assert d == pytest.approx(exact[r.id], abs=1e-12)
    past = {r.id for r in structure.placed if r.moving and exact[r.id] > THRESHOLD}
    measured = {r.id for r, d in zip(watched, moved.tolist()) if r.id in pending or d > THRESHOLD}
    assert measured == past | set(pending)
    assert past == {"b0", "b1", "b3"} & set(structure.records)  # the slid, the turned and the lifted brick


@pytest.mark.parametrize("bricks", [3, FEW + 8])  # in floats, and past FEW in numpy
def test_the_monitor_reads_a_brick_at_rest_when_both_its_speeds_are_within_the_rest_thresholds(bricks):
    """The collapse monitor's rest test of displaced bricks (``CollapseMonitor._resting``): a
    frozen brick rests; a moving one while its speed is at most the rest speed and its spin at
    most the rest spin, the thresholds themselves included, in floats for a few bricks and in
    numpy for more, the same answers."""
    from types import SimpleNamespace

    from stackdsl.runtime.collapse import CollapseMonitor

    world, structure = _structure(bricks)
    monitor = CollapseMonitor(THRESHOLD, 1.0, lambda loop: None, lambda deadline: None, lambda brick: None)  # type: ignore[arg-type,return-value]
    speed, spin = 0.005, 0.05
    rng = np.random.default_rng(3)
    records = structure.placed
    structure.set_moving(records[0], False)
    expected = [True]
    for r in records[1:]:
        towards, about = rng.normal(size=3), rng.normal(size=3)
        linear = towards / np.linalg.norm(towards) * speed * (1.01 if r.order % 3 == 2 else 0.99)
        angular = about / np.linalg.norm(about) * spin * (1.01 if r.order % 3 == 0 else 0.99)
        if r.order == 1:
            linear, angular = np.array([speed, 0.0, 0.0]), np.array([0.0, 0.0, -spin])  # on both thresholds
        world.velocities[r.body] = (linear, angular)
        expected.append(bool(np.linalg.norm(linear) <= speed and np.linalg.norm(angular) <= spin))
    assert monitor._resting(SimpleNamespace(world=world), records) == expected
    assert True in expected[1:] and False in expected

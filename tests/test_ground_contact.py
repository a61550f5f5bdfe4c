"""A brick woken where it rested on pybullet's ground plane meets it as a box whose top is the
plane: at every corner of its face at once. pybullet meets a plane at one contact point
in a body's first step and builds the rest up only as the body rocks; a domino woken 1.5 steps
before the next one struck it turned on that point, and the chain veered off its line and
stopped (a row 127 mm apart: 5 of 20 toppled, where raw pybullet topples all 20)."""

from __future__ import annotations

import pytest

from stability import Pose
from stackdsl import compile_scenario, parse_scenario, run_program
from stackdsl.compile.compiler import _spec
from stackdsl.engines.pybullet.settings import PyBulletSettings
from stackdsl.engines.pybullet.world import pybullet_world

SETTINGS = PyBulletSettings(mode="extension", timestep=1 / 240, solver_iterations=50)
ON_END = Pose.from_euler([0.0, 0.0, 0.06], pitch=90.0)  # a KAPLA brick on its 24 x 8 mm end


def _spec_of():
    return _spec(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 1}}\n"), "kapla")


def _ground_points(world, body):
    return [c for c in world.contact_points([body]) if c.other == world.ground]


def test_a_brick_new_on_the_plane_meets_it_at_one_or_two_points():
    # the engine fact the rule answers: re-measure it when pybullet changes
    spec = _spec_of()
    with pybullet_world(SETTINGS, 0.5, 0.0, shelve=False) as world:
        body = world.create(spec, ON_END)
        world.step()
        first = len(_ground_points(world, body))
        for _ in range(4):
            world.step()
        assert first == 1 and len(_ground_points(world, body)) <= 2


def test_a_woken_brick_meets_the_ground_at_every_corner_at_once():
    spec = _spec_of()
    with pybullet_world(SETTINGS, 0.5, 0.0, shelve=False) as world:
        body = world.create(spec, ON_END)
        world.step()
        world.set_frozen(body, True, spec.mass)
        world.step()
        assert _ground_points(world, body) == []  # two static bodies: no contact
        world.set_frozen(body, False, spec.mass)
        world.step()
        points = _ground_points(world, body)
        assert len(points) == 4 and all(p.position[2] == pytest.approx(0.0, abs=1e-4) for p in points)
        for _ in range(60):
            world.step()
        assert world.pose(body).position.tolist() == pytest.approx(ON_END.position.tolist(), abs=1e-4)  # stands
        (remade,) = world.make_debris([body])  # made again in maximal coordinates: still a body that was static
        world.step()
        assert remade == body and len(_ground_points(world, body)) == 4


def test_a_brick_woken_above_the_ground_lands_on_the_plane_as_any_body_does():
    spec = _spec_of()
    with pybullet_world(SETTINGS, 0.5, 0.0, shelve=False) as world:
        body = world.create(spec, Pose.from_euler([0.0, 0.0, 0.03]), mass=0.0)  # held 26 mm up
        world.set_frozen(body, False, spec.mass)
        landed = []
        for _ in range(40):
            world.step()
            if points := _ground_points(world, body):
                landed.append(len(points))
        assert landed and landed[0] <= 2  # the plane's first contact, not the box's four


def _row(spacing_mm: int, mode: str) -> str:
    bricks = "\n".join(f"    - {{id: d{i:02d}, at: [{i * spacing_mm} mm, 0, 60 mm], pitch: 90, level: 1}}" for i in range(20))
    return f"""stackdsl: 1
brick_types: {{finger: {{size: [20 mm, 10 mm, 10 mm]}}}}
structure:
  bricks:
{bricks}
engine: {{mode: {mode}}}
timing: {{interval: 0.1 s, settle: 6 s}}
actions:
  - push: {{target: {{brick: d00, offset: [0, 0, 45 mm]}}, direction: [1, 0, 0], speed: 0.2 m/s, distance: 15 mm, at: after level 1, pusher: finger}}
"""


@pytest.mark.parametrize("spacing", [127, 128])
def test_a_row_at_the_edge_of_its_reach_topples_whole_as_the_engine_alone_does(spacing):
    # a domino reaches the next one 1 to 2 mm past its back face: each woken one must fall on its line
    toppled = {
        mode: len(run_program(compile_scenario(parse_scenario(_row(spacing, mode), "row.yaml"))).toppled)
        for mode in ("raw", "extension")
    }
    assert toppled == {"raw": 20, "extension": 20}

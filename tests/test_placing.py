"""stability.Placing: rigid-block equilibrium of boxes placed one at a time, by load paths kept
from one placement to the next (all steps at once, or brick by brick) and the equilibrium
program where they fail; checked against the program itself."""

import numpy as np
import pytest

from stability import Box, PlacedBox, Placing, Pose, RigidBlock, solve_equilibrium

BRICK = np.array([0.06, 0.012, 0.004])
MASS = 0.0106


def brick(key: int, x: float, y: float, level: int, yaw: float = 0.0) -> PlacedBox:
    return PlacedBox(key, Box(BRICK, MASS), Pose.from_euler([x, y, 0.004 + 0.008 * level], yaw=yaw), 0.5)


def tower(levels: int, shift: float = 0.0) -> list[list[PlacedBox]]:
    """Two bricks a level, crosswise, 96 mm apart, each level moved ``shift`` m along x."""
    steps, key = [], 1
    for level in range(levels):
        x0 = shift * level
        for side in (-0.048, 0.048):
            if level % 2 == 0:
                steps.append([brick(key, x0, side, level)])
            else:
                steps.append([brick(key, x0 + side, 0.0, level, yaw=90.0)])
            key += 1
    return steps


def program_stands(placing: Placing) -> bool:
    blocks = {k: RigidBlock(MASS, placing.boxes[k].pose.position) for k in placing.free}
    return solve_equilibrium(blocks, placing.polygons).stands


def test_fixed_shares_prove_every_step_of_a_straight_tower_at_once():
    steps = tower(100)
    proved, slack = Placing(0, 0.5).proved_steps(steps)
    assert proved == len(steps) == 200
    assert 0.011 < slack <= 0.012  # a brick over its supports' centres, 12 mm from their edges


def test_a_slanted_tower_is_proved_up_to_where_it_stops_standing_and_falls_there():
    steps = tower(12, shift=0.011)  # the top of a level past its base's edge: it falls
    proved, _ = Placing(0, 0.5).proved_steps(steps)
    assert 0 < proved < len(steps)
    placing = Placing(0, 0.5)
    placing.put([b for step in steps[:proved] for b in step])
    assert program_stands(placing)
    for step in steps[proved:]:  # brick by brick: it falls at the step the program says so
        if not placing.place(step).stands:
            break
    else:
        raise AssertionError("the slanted tower stood")
    assert not program_stands(placing)


@pytest.mark.parametrize("seed", range(6))
def test_placing_says_what_the_program_says_after_every_step(seed):
    rng = np.random.default_rng(seed)
    shifts = rng.uniform(-0.02, 0.02, size=6)
    placing = Placing(0, 0.5)
    for level in range(len(shifts)):  # a single file, each brick shifted on the one below
        x = float(shifts[: level + 1].sum())
        found = placing.place([brick(level + 1, x, 0.0, level)])
        assert found.stands == program_stands(placing)
        if found.method == "load paths":
            assert found.stands and placing.proved and placing.slack > 0
        if not found.stands:
            break


def test_a_box_is_placed_once():
    placing = Placing(0, 0.5)
    placing.place([brick(1, 0.0, 0.0, 0)])
    with pytest.raises(ValueError, match="there already"):
        placing.place([brick(1, 0.0, 0.0, 1)])
    assert placing.free == [1]

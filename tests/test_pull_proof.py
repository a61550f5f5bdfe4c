"""A pull that keeps the frozen bricks it slides between frozen (stability._drag): the drag proof
and what it does to a run."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import box

from stability import ContactArea
from stability._drag import DRAG_SAFETY, drag_held
from stackdsl import compile_scenario, parse_scenario, run_program

G = 9.81
UP = np.array([0.0, 0.0, 1.0])


def patch(x: float, y: float, half: float = 0.0125) -> ContactArea:
    return ContactArea(box(x - half, y - half, x + half, y + half), 0.0, UP, True)


def level_on(ys: list[float], mass: float, mu: float, drag: float, at_y: float) -> bool:
    """A brick lying across blocks at ``ys`` (equal shares of ``mass``), dragged along x at y = ``at_y``."""
    supports = {i: patch(0.0, y) for i, y in enumerate(ys)}
    loads = {i: (mass / len(ys), np.array([0.0, y, 0.0])) for i, y in enumerate(ys)}
    return drag_held(supports, loads, dict.fromkeys(supports, mu), np.array([drag, 0.0]), np.array([0.0, at_y]), G)


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
structure: {tower: {levels: 4, bricks_per_layer: 3, spacing: 25.5 mm, turn: 90, brick: jenga}}
timing: {interval: 0.2 s, settle: 0.5 s}
actions:
  - remove: {brick: BRICK, at: after level 4, speed: 40 mm/s}
expect: {stands: true}
"""


@pytest.mark.parametrize(("brick", "alone"), [("L02.2", True), pytest.param("L02.3", False, marks=pytest.mark.slow)])
def test_a_proved_pull_moves_its_brick_alone_and_a_side_pull_wakes_the_level_it_drags(brick, alone):
    """The middle block of level 2 slides out of a frozen tower: statics holds the levels without
    it and against its drag, and nothing else wakes; a side block's drag twists the level above
    beyond what the two blocks left hold, and that level wakes with what it carries (under two
    levels only, the engine drags it past the collapse threshold: a near tie, docs/actions.md)."""
    outcome = run_program(compile_scenario(parse_scenario(JENGA.replace("BRICK", brick), "pull.yaml")))
    pull = next(e.time for e in outcome.events if e.kind == "remove")
    woken = {e.brick for e in outcome.events if e.kind == "wake" and e.time >= pull} - {brick}
    assert (woken == set()) is alone, woken
    assert outcome.collapse is None or not alone
    if not alone:
        assert {"L03.1", "L03.2", "L03.3"} <= woken

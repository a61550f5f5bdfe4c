"""The collapse proofs' words, each kind's module on its own (stackdsl.runtime.support's "off its
support", stackdsl.runtime.end_proofs' stand), without an engine."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from stability import Box, Certificate, Plane, Pose
from stackdsl.runtime.end_proofs import names_and, stand_words
from stackdsl.runtime.support import SupportPolygon, _Measured, _tips_words

KAPLA = Box(np.array([0.06, 0.012, 0.004]), 0.0106)


def test_a_stand_by_load_paths_and_by_the_program_in_words():
    paths = Certificate(True, 0.0, 0.01, (), 3, (), 2, "load paths", 0.73)
    assert (
        stand_words(paths, {})
        == "each of 3 bricks frozen over its load path to the ground, needing 73% of each friction coefficient"
    )
    one = Certificate(True, 0.0, 0.01, (), 1, (), 1, "load paths", 0.0)
    assert stand_words(one, {}) == "the brick frozen over its load path to the ground"
    program = Certificate(True, 0.0, 0.01, (), 2, ("a",), 1, "program", 0.0)
    ties = {"L05.1": "near tie: its centre of mass 0.56 mm inside", "L06.1": "x"}
    assert stand_words(program, ties) == (
        "the equilibrium program balances 2 bricks on 1 contact; statics on the placed geometry decided "
        "L05.1's landing (its centre of mass 0.56 mm inside) and 1 more near ties, not the engine"
    )


@pytest.mark.parametrize("names, said", [(["B"], "B"), (["B", "C"], "B and C"), (["B", "C", "D"], "B, C and D")])
def test_names_are_listed_with_and(names, said):
    assert names_and(names) == said


def test_a_part_that_tips_is_said_with_what_it_carries_and_how_far_out_it_was_placed():
    on_ground = SupportPolygon(KAPLA, Pose(np.array([0.0, 0.0, 0.004])), [(None, Plane(0.0), None)])
    on_brick = SupportPolygon(KAPLA, Pose(np.array([0.0, 0.0, 0.012])), [(1, KAPLA, Pose(np.array([0.0, 0.0, 0.004])))])
    a, b = SimpleNamespace(id="a"), SimpleNamespace(id="b")
    assert _tips_words([a], [a], [on_ground], 0.0021, 0.0) == (
        "a's centre of mass lies 2.1 mm beyond the edge of the face it stood on the ground with"
    )
    assert _tips_words([a, b], [a], [on_brick], 0.003, 0.0015) == (
        "the centre of mass of a with b on it lies 3.0 mm outside the support polygon a was placed on (1.5 mm as they were placed)"
    )


def test_the_quick_margin_test_agrees_with_the_exact_distance_on_either_side_of_the_edge():
    # a brick crossed at 30 deg over another, 20 mm off its centre: its support polygon is a
    # parallelogram; the side-line test must say what the exact distance says about a margin
    rng = np.random.default_rng(5)
    base = Pose(np.array([0.0, 0.0, 0.004]))
    top = Pose.from_euler(np.array([0.02, 0.0, 0.012]), 30.0, 0.0, 0.0)
    support = SupportPolygon(KAPLA, top, [(1, KAPLA, base)])
    least = 1e-4
    for com in rng.uniform([-0.08, -0.05, 0.0], [0.08, 0.05, 0.0], (400, 3)):
        assert support.placed_margin_above(com, least) == (support.placed_margin_of(com) >= least)


def _turned(pose: Pose, rng: np.random.Generator, shift: float, angle: float) -> Pose:
    """``pose`` moved by up to ``shift`` m and turned by up to ``angle`` degrees about a random axis."""
    axis = rng.normal(size=3)
    turn = Rotation.from_rotvec(axis / np.linalg.norm(axis) * np.radians(rng.uniform(0.0, angle)))
    quaternion = (turn * Rotation.from_quat(pose.orientation)).as_quat()
    return Pose(pose.position + rng.uniform(-shift, shift, 3), quaternion)


@pytest.mark.parametrize("crossed", [0.0, 30.0])
def test_the_bound_on_a_margins_change_holds_whatever_the_bricks_do(crossed):
    # the collapse monitor asks a moving brick's margin again only once the bound says it may have
    # come within OFF_SUPPORT of its edge: the bound must never be less than the change
    rng = np.random.default_rng(11)
    base = Pose(np.array([0.0, 0.0, 0.004]))
    top = Pose.from_euler(np.array([0.03, 0.0, 0.012]), crossed, 0.0, 0.0)
    on_brick = SupportPolygon(KAPLA, top, [(1, KAPLA, base)])
    on_ground = SupportPolygon(KAPLA, base, [(None, Plane(0.0), None)])
    for _ in range(300):
        then = (_turned(top, rng, 0.01, 5.0), _turned(base, rng, 0.01, 5.0))
        now = (_turned(then[0], rng, 0.004, 3.0), _turned(then[1], rng, 0.004, 3.0))
        kept = _Measured((2, 1), np.array([p.position for p in then]), np.array([p.orientation for p in then]), (0.0,) * 3, 0.0)
        positions, quaternions = np.array([p.position for p in now]), np.array([p.orientation for p in now])
        moved = kept.moved(positions, quaternions, 1, 0, [(1, float(np.linalg.norm(on_brick.pieces[0][1], axis=1).max()))])
        change = on_brick.margin_now(now[0].position, {1: now[1]}) - on_brick.margin_now(then[0].position, {1: then[1]})
        assert abs(change) <= moved + 1e-12
        alone = kept.moved(positions, quaternions, 1, 0, [(0, KAPLA.half_diagonal)])  # on the ground: its own face
        change = on_ground.base_margin(now[0]) - on_ground.base_margin(then[0])
        assert abs(change) <= alone + 1e-12

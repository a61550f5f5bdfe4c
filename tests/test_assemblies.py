"""Random assemblies: drawn reproducibly, accepted by the language, judged with a margin
(the verdicts benchmark itself: tests/test_bench_verdicts.py)."""

from __future__ import annotations

import numpy as np
import pytest

from stackdsl import compile_scenario, parse_scenario
from stackdsl.verdicts.assemblies import MAX_MARGIN, RESOLUTION, assembly, judge


def rng(k: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(5, spawn_key=(k,)))


@pytest.mark.slow
def test_assemblies_are_reproducible_valid_and_varied():
    texts = [assembly(rng(k), f"a{k}") for k in range(12)]
    assert texts == [assembly(rng(k), f"a{k}") for k in range(12)]
    programs = [compile_scenario(parse_scenario(t, f"a{k}.yaml")) for k, t in enumerate(texts)]
    sizes = [len(p.placements) for p in programs]
    levels = [max(a.level for a in p.placements) for p in programs]
    assert all(3 <= n <= 12 for n in sizes) and all(2 <= n <= 4 for n in levels), (sizes, levels)
    assert len(set(sizes)) > 2 and len(set(texts)) == 12
    judged = [judge(p) for p in programs]
    assert {j.collapse_level is None for j in judged} == {True, False}  # some stand, some fall


def overhang(inside_mm: float) -> str:
    return f"stackdsl: 1\nstructure:\n  bricks:\n    - {{at: [0, 0, 4 mm]}}\n    - {{at: [{60 - inside_mm} mm, 0, 12 mm]}}\n"


@pytest.mark.slow
@pytest.mark.parametrize("inside", [0.5, 3.0, 7.0])
def test_the_margin_is_how_far_the_centre_of_mass_can_move(inside):
    # the top brick's centre of mass `inside` mm inside the lower brick's end: moving every
    # centre of mass that far along +x tips it; the bottom brick holds far longer
    j = judge(compile_scenario(parse_scenario(overhang(inside))))
    assert j.collapse_level is None
    assert j.margin == pytest.approx(inside / 1000, abs=2 * RESOLUTION)


@pytest.mark.slow
def test_a_collapsing_assembly_has_the_margin_that_would_make_it_stand():
    j = judge(compile_scenario(parse_scenario(overhang(-2.0))))  # 2 mm past the edge
    assert j.collapse_level == 2 and j.margin == pytest.approx(0.002, abs=2 * RESOLUTION)
    assert judge(compile_scenario(parse_scenario(overhang(30.0)))).margin <= MAX_MARGIN


def _ladder(angle: float, yaw: float = 0.0) -> str:
    from stackdsl.verdicts.assemblies import Brick, Leaner, _yaml

    return _yaml([Brick(-0.4, 0.0, 1, 0.0)], "ladder", Leaner(0.0, 0.0, yaw, angle))


@pytest.mark.slow
@pytest.mark.parametrize("yaw", [0.0, 22.5, 200.0])
def test_a_brick_leaning_on_a_wall_stands_above_the_ladder_angle(yaw):
    """A ladder with its feet at the bottom edges of its end faces: friction mu_g on the
    ground and mu_w on the wall hold it while (L/2 cos t - h/2 sin t)(1 + mu_g mu_w) <=
    mu_g L (sin t + mu_w cos t), h its thickness; the oracle must say the same to 0.5 deg,
    whichever way the wall faces (its friction pyramid turned toward the wall)."""
    from stability import pair_friction
    from stackdsl.verdicts.assemblies import HEIGHT, LENGTH

    program = compile_scenario(parse_scenario(_ladder(45.0)))
    leaner, wall = program.placements[-1], program.fixtures[0]
    mu_g = pair_friction(leaner.brick.friction, program.ground_friction)
    mu_w = pair_friction(leaner.brick.friction, wall.brick.friction)

    def holds(t: float) -> bool:
        lhs = (LENGTH / 2 * np.cos(t) - HEIGHT / 2 * np.sin(t)) * (1 + mu_g * mu_w)
        return bool(lhs <= mu_g * LENGTH * (np.sin(t) + mu_w * np.cos(t)))

    low, high = np.radians(5.0), np.radians(85.0)
    while high - low > 1e-6:
        mid = (low + high) / 2
        low, high = (low, mid) if holds(mid) else (mid, high)
    critical = np.degrees(high)
    assert 30 < critical < 45
    for angle, stands in ((critical + 0.5, True), (critical - 0.5, False)):
        assert (judge(compile_scenario(parse_scenario(_ladder(angle, yaw)))).collapse_level is None) is stands


@pytest.mark.slow
def test_some_assemblies_lean_on_a_wall():
    texts = [assembly(rng(k), f"a{k}") for k in range(30)]
    leaning = [t for t in texts if "fixed: true" in t]
    assert 8 <= len(leaning) <= 22  # LEANING = 0.5
    program = compile_scenario(parse_scenario(leaning[0]))
    assert program.placements[-1].pitch != 0.0 and judge(program).margin > 0


@pytest.mark.slow
def test_some_leaning_bricks_stand_on_a_step_brick_the_oracle_sees():
    """A step brick lies across the leaning brick's foot on the ground, placed just before it:
    the oracle's contacts are the foot's two corners on the step's top face, the top edge's two
    on the wall, the step's face on the ground; and the leaning brick touches nothing else."""
    from stackdsl.verdicts.oracle import structure

    programs = [compile_scenario(parse_scenario(assembly(rng(k), f"a{k}"))) for k in range(30)]
    stepped = [
        p
        for p in programs
        if p.fixtures and p.placements[-2].level == 1 and abs((p.placements[-2].yaw - p.placements[-1].yaw) % 180 - 90) < 1e-6
    ]
    assert 3 <= len(stepped) <= 14, len(stepped)  # STEP = 0.5 of the leaning half
    for p in stepped:
        leaner, step = p.placements[-1].id, p.placements[-2].id
        _, contacts = structure(list(p.placements), p.fixtures, p.ground_friction)
        touching = {(c.body, c.other): len(c.points) for c in contacts if {leaner, step} & {c.body, c.other}}
        assert touching == {(step, "ground"): 4, (leaner, "wall"): 2, (leaner, step): 2}, touching


@pytest.mark.slow  # 3-5 s: in .ci/nightly's slow part
def test_a_margin_is_found_where_the_verdict_first_flips_not_at_the_far_end():
    # a ladder 0.3 deg below its limit slides: moving every centre of mass a fraction of a
    # millimetre toward the wall holds it, but 20 mm on the flat brick beside it (lying across
    # that direction) falls off its own footprint, and the verdict is "collapse" again there
    from stackdsl.verdicts.assemblies import Brick, Leaner, _yaml

    def ladder(angle: float) -> str:
        return _yaml([Brick(-0.4, 0.0, 1, 90.0)], "ladder", Leaner(0.0, 0.0, 0.0, angle))

    low, high = 30.0, 45.0
    while high - low > 0.01:  # the oracle's own ladder limit
        mid = (low + high) / 2
        stands = judge(compile_scenario(parse_scenario(ladder(mid)))).collapse_level is None
        low, high = (low, mid) if stands else (mid, high)
    j = judge(compile_scenario(parse_scenario(ladder(high - 0.3))))
    assert j.collapse_level is not None and j.margin < 0.001


@pytest.mark.slow
def test_a_support_narrower_than_the_margin_is_the_margin():
    # the top brick's centre of mass lies 3 mm past b1's end, and its far end lies 0.4 mm onto
    # b2: statics holds it as a bridge, but a move of 0.4 mm takes b2's support away
    text = "stackdsl: 1\nstructure:\n  bricks:\n"
    for name, x, z in (("b1", 0.0, 4), ("b2", 182.6, 4), ("top", 63.0, 12)):
        text += f"    - {{id: {name}, at: [{x} mm, 0, {z} mm]}}\n"
    j = judge(compile_scenario(parse_scenario(text)))
    assert j.collapse_level is None and j.margin == pytest.approx(0.0004, abs=RESOLUTION / 2)


def test_a_stand_that_needs_all_its_friction_is_a_friction_tie_and_a_flat_stack_is_not():
    # assembly 18 of seed 4242: b06 leans on the ground and a wall at 35 deg, held by all of its
    # friction; the margin (centres of mass moved together) is 0.5 mm and says nothing of that
    from stackdsl.verdicts.assemblies import FRICTION_TIE

    text = assembly(np.random.default_rng(np.random.SeedSequence(4242, spawn_key=(18,))), "a")
    leaning = judge(compile_scenario(parse_scenario(text)))
    assert leaning.collapse_level is None and leaning.friction >= FRICTION_TIE and leaning.friction_tie
    flat = "stackdsl: 1\nstructure:\n  bricks:\n    - {id: a, at: [0, 0, 4 mm]}\n    - {id: b, at: [30 mm, 0, 12 mm]}\n"
    stack = judge(compile_scenario(parse_scenario(flat)))
    assert stack.friction == 0.0 and not stack.friction_tie

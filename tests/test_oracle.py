"""The equilibrium oracle on placed poses, and the collapse mechanism, against closed forms."""

import pytest

from stability import _equilibrium, solve_equilibrium
from stability._equilibrium import GRAVITY, _solve_vertical
from stackdsl import compile_scenario, parse_scenario
from stackdsl.bench.cost import solve_times
from stackdsl.verdicts.oracle import equilibrium_collapse, structure

L = 0.12


def harmonic(n: int, factor: float) -> str:
    """n bricks off the edge (x = 0) of a fixed table, each reaching factor * L / (2k) beyond
    the one below it (k = 1 at the top): the harmonic stack, critical at factor 1."""
    offsets = [factor * L / (2 * k) for k in range(n, 0, -1)]  # bottom brick first
    edge, rows = 0.0, []
    for i, off in enumerate(offsets):
        edge += off  # the right end of this brick
        rows.append(f"    - {{at: [{edge - L / 2:.6f}, 0, {0.1 + 0.004 + 0.008 * i:.6f}], level: {i + 1}}}")
    table = "    - {id: table, brick: table, at: [-0.15, 0, 0.05], fixed: true}"
    return (
        "stackdsl: 1\nbrick_types: {table: {size: [300 mm, 100 mm, 100 mm]}}\nstructure:\n  bricks:\n"
        + table
        + "\n"
        + "\n".join(rows)
        + "\n"
    )


@pytest.mark.parametrize("n", [5, 6])
def test_harmonic_stack_stands_below_its_critical_offsets_and_falls_above(n):
    assert equilibrium_collapse(compile_scenario(parse_scenario(harmonic(n, 0.99)))).collapse_level is None
    result = equilibrium_collapse(compile_scenario(parse_scenario(harmonic(n, 1.01))))
    assert result.collapse_level is not None


def tower(levels: int, spacing_mm: float, shift_mm: float):
    return compile_scenario(
        parse_scenario(
            f"stackdsl: 1\nstructure: {{tower: {{levels: {levels}, spacing: {spacing_mm} mm, shift: {shift_mm} mm}}}}\n"
        )
    )


@pytest.mark.slow
@pytest.mark.parametrize("spacing, shift, level", [(70, 12.9, 9), (96, 8, 15)])
def test_slant_towers_collapse_where_the_closed_form_says(spacing, shift, level):
    # closed forms: 1 + ceil((d + 24) / s) for spacing d < 96; ceil(120 / s) at 96 (stackdsl's own)
    assert equilibrium_collapse(tower(level + 2, spacing, shift)).collapse_level == level


def test_upright_tower_stands():
    result = equilibrium_collapse(tower(10, 96, 0))
    assert result.collapse_level is None and result.bricks_standing == 20


def test_the_collapse_mechanism_is_the_block_that_tips():
    # The slant tower with the first brick of level 9: levels 3 to 9 tip over level 2's
    # edge as one block, both level-3 bricks included; levels 1 and 2 stay.
    program = tower(9, 70, 12.9)
    blocks, contacts = structure(program.placements[:17], program.fixtures, program.ground_friction)
    result = solve_equilibrium(blocks, contacts)
    moving = {b for b, v in result.mechanism.items() if v > 1e-4}
    assert not result.stands
    assert moving == {p.id for p in program.placements[4:17]}


def test_the_oracle_refuses_tilted_bricks_that_touch_each_other():
    # (an upright brick, an axis vertical, is fine: its ends are level)
    with pytest.raises(ValueError, match="tilted and touch"):
        equilibrium_collapse(compile_scenario(parse_scenario("stackdsl: 1\nstructure: {card_house: {levels: 1}}\n")))


def test_solve_time_benchmark_runs():
    (row,) = solve_times((10,), repeats=1)
    assert row.bricks == 10 and row.contacts == 18 and 0 < row.median < 1.0 and 0 < row.full < 1.0


@pytest.mark.slow
@pytest.mark.parametrize(
    "spacing, shift, bricks", [(96, 8, 29), (96, 8, 30), (70, 12.9, 16), (70, 12.9, 17), (96, 0, 40), (96, 13, 4)]
)
def test_the_vertical_program_agrees_with_the_full_one(spacing, shift, bricks):
    program = tower(bricks // 2 + 1, spacing, shift)
    blocks, contacts = structure(program.placements[:bricks], program.fixtures, program.ground_friction)
    assert solve_equilibrium(blocks, contacts).stands == solve_equilibrium(blocks, contacts, quick=False).stands


@pytest.mark.slow
@pytest.mark.parametrize("bricks", [29, 30])
def test_the_vertical_program_gives_way_to_the_full_one_past_its_budget(monkeypatch, bricks):
    # With no iterations to spend, the vertical program decides nothing, and the full
    # program still gives the closed form's answer on either side of the collapse.
    program = tower(bricks // 2 + 1, 96, 8)
    blocks, contacts = structure(program.placements[:bricks], program.fixtures, program.ground_friction)
    expected = solve_equilibrium(blocks, contacts, quick=False).stands
    assert _solve_vertical(blocks, contacts, GRAVITY) is not None or not expected
    monkeypatch.setattr(_equilibrium, "VERTICAL_PIVOTS", 0.001)  # one iteration
    assert _solve_vertical(blocks, contacts, GRAVITY) is None
    assert solve_equilibrium(blocks, contacts).stands == expected

"""The benchmark's closed-form collapse levels against rigid-block equilibrium of the placed poses."""

import pytest

from stackdsl import compile_scenario, parse_scenario
from stackdsl.verdicts.closed_form import log_cabin, single_file
from stackdsl.verdicts.oracle import equilibrium_collapse


def oracle(structure: str) -> int | None:
    return equilibrium_collapse(
        compile_scenario(parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{{structure}}}}}\n"))
    ).collapse_level


@pytest.mark.slow
@pytest.mark.parametrize("shift_mm", [8, 10, 11, 13, 14])
def test_log_cabin_closed_form_is_the_equilibrium_answer(shift_mm):
    expected = log_cabin(shift_mm / 1000)
    assert oracle(f"levels: {expected + 1}, spacing: 96 mm, shift: {shift_mm} mm") == expected


@pytest.mark.slow
@pytest.mark.parametrize("shift_mm", [7, 9, 11, 13, 20])
def test_single_file_closed_form_is_the_equilibrium_answer(shift_mm):
    expected = single_file(shift_mm / 1000)
    assert oracle(f"levels: {expected + 1}, bricks_per_layer: 1, turn: 0, shift: {shift_mm} mm") == expected


def test_no_collapse_without_a_shift():
    with pytest.raises(ValueError):
        log_cabin(0.0, limit=50)
    with pytest.raises(ValueError):
        single_file(0.0)

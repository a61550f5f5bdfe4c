"""The signed margin of a run's verdict (Outcome.margin) on a closed form: a single-file stack
of n KAPLA bricks, each layer shifted s along the brick, tips where the centre of mass of the
n - 1 bricks above the first lies over its end, s n / 2 = 60 mm: s* = 120 mm / n. The margin is
60 mm - s n / 2 on both sides of s*, so it tends to 0 from above as s rises to s* and from below
as s falls to it."""

import pytest

from stackdsl import compile_scenario, parse_scenario, run_program
from stackdsl.runtime.collapse import signed_margin

LEVELS = 5
CRITICAL = 0.120 / LEVELS  # metres: 24 mm


def margin(shift: float, backend: str = "pybullet", levels: int = LEVELS) -> tuple[bool, float | None]:
    text = (
        f"stackdsl: 1\nstructure: {{tower: {{levels: {levels}, bricks_per_layer: 1, turn: 0, "
        f"shift: [{shift * 1000!r} mm, 0 mm]}}}}\ntiming: {{interval: 0.5 s, settle: 1 s}}\n"
        f"engine: {{backend: {backend}}}\n"
    )
    outcome = run_program(compile_scenario(parse_scenario(text)))
    return outcome.collapse is None, outcome.margin


@pytest.mark.parametrize(
    ("levels", "offset"),
    [(3, 0.08e-3), pytest.param(LEVELS, 0.4e-3, marks=pytest.mark.slow), pytest.param(LEVELS, 0.08e-3, marks=pytest.mark.slow)],
)
def test_margin_is_continuous_across_the_critical_shift(levels, offset):
    critical = 0.120 / levels
    below, above = margin(critical - offset, levels=levels), margin(critical + offset, levels=levels)
    assert below[0] and not above[0]  # stands below s*, collapses above it
    expected = offset * levels / 2  # the closed form's distance from the tipping edge
    assert below[1] is not None and above[1] is not None
    assert below[1] == pytest.approx(expected, abs=0.05e-3)
    assert above[1] == pytest.approx(-expected, abs=0.05e-3)


@pytest.mark.slow
def test_margin_is_continuous_on_mujoco_too():
    pytest.importorskip("mujoco")
    offset = 0.2e-3
    below, above = margin(CRITICAL - offset, "mujoco"), margin(CRITICAL + offset, "mujoco")
    assert below[0] and not above[0]
    assert below[1] == pytest.approx(offset * LEVELS / 2, abs=0.05e-3)
    assert above[1] == pytest.approx(-offset * LEVELS / 2, abs=0.05e-3)


def test_a_collapse_placed_inside_its_support_reports_the_proofs_distance():
    assert signed_margin(0.003, 0.0021) == -0.0021  # knocked over: how far past its limit the proof was
    assert signed_margin(-0.0046, 0.01) == -0.0046  # placed 4.6 mm outside: statics' own distance
    assert signed_margin(float("inf"), -1.0) == 0.0  # nothing past a limit: at it

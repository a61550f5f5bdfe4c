"""The independent Monte Carlo of the random single-file stack (stackdsl.bench.random_stack): the
stability condition on hand-made stacks, the vectorised walk against the scalar reference,
known probabilities, and the mean collapse level against the 10^6-sample figure."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackdsl.bench import random_stack as _random_stack
from stackdsl.bench.random_stack import (
    LENGTH,
    collapse_level,
    collapse_levels,
    interface_margins,
    levels_of_walks,
    mean_collapse_level,
    stands,
)

#: Mean collapse level from 10^6 samples, default_rng(20240601): 7.1123, 95 % CI [7.1049, 7.1197]
#: (10^7 samples: 7.1134 [7.1110, 7.1157]).
MEAN_1E6 = 7.1123


def test_two_bricks_stand_while_the_top_centre_is_over_the_lower_brick():
    assert stands([0.0, 0.059])
    assert not stands([0.0, 0.061])
    assert stands([0.0, -0.059]) and not stands([0.0, -0.061])
    assert collapse_level([0.0, 0.059]) is None
    assert collapse_level([0.0, 0.061]) == 2
    assert stands([0.3]) and stands([])


def test_a_centre_of_mass_exactly_on_the_edge_collapses():
    assert not stands([0.0, 0.5], length=1.0)  # strict: on the edge is not within
    assert stands([0.0, 0.4999], length=1.0)


def test_three_bricks_failing_at_the_lowest_interface():
    x = [0.0, 0.05, 0.1]  # each brick on the one below is fine; bricks 2 and 3 together (mean 0.075) overhang brick 1
    assert stands(x[:2])
    margins = interface_margins(x)
    assert margins[0] == pytest.approx(0.06 - 0.075)
    assert margins[1] == pytest.approx(0.06 - 0.05)
    assert collapse_level(x) == 3


def test_interface_margins_are_the_mean_of_the_bricks_above():
    x = np.array([0.01, -0.02, 0.03, 0.0, 0.05])
    expected = [LENGTH / 2 - abs(x[j + 1 :].mean() - x[j]) for j in range(len(x) - 1)]
    assert interface_margins(x) == pytest.approx(expected)


@pytest.mark.parametrize("factor, standing", [(0.99, True), (1.01, False)])
def test_harmonic_stack(factor: float, standing: bool):
    # The classic harmonic stack (Paterson & Zwick, Amer. Math. Monthly 2009): the k-th brick from the top overhangs the
    # one below by L/(2k); every interface is then exactly critical. A little less stands, a little more does not.
    n = 12
    shifts = [factor * LENGTH / (2 * k) for k in range(n - 1, 0, -1)]  # bottom interface first
    x = np.concatenate([[0.0], np.cumsum(shifts)])
    assert stands(x) is standing
    assert np.all(np.abs(interface_margins(x)) < 0.011 * LENGTH / 2)


def test_the_vectorised_walks_agree_with_the_scalar_reference():
    rng = np.random.default_rng(3)
    x = np.cumsum(np.concatenate([np.zeros((1000, 1)), rng.uniform(-0.06, 0.06, (1000, 11))], axis=1), axis=1)
    expected = [collapse_level(row) or 0 for row in x]
    assert levels_of_walks(x).tolist() == expected
    assert 20 < expected.count(0) < 200  # P(N > 12) ~ 0.07: some walks stood all 12 bricks, most did not


def test_levels_are_reproducible_and_never_below_three():
    a = collapse_levels(20000, np.random.default_rng(11))
    b = collapse_levels(20000, np.random.default_rng(11))
    assert a.dtype == np.int64 and a.shape == (20000,)
    assert np.array_equal(a, b)
    assert a.min() >= 3  # brick 2 always lands over brick 1
    assert collapse_levels(0, np.random.default_rng(0)).shape == (0,)


def test_p_three_is_one_eighth():
    # |u + v/2| >= 1/2 for u, v ~ U(-1/2, 1/2): probability 1/8 (module docstring).
    n = 100_000
    levels = collapse_levels(n, np.random.default_rng(5))
    p = float(np.mean(levels == 3))
    assert abs(p - 0.125) < 4 * math.sqrt(0.125 * 0.875 / n)


def test_mean_of_1e5_samples_lies_within_its_interval_of_the_1e6_figure():
    _, low, high = mean_collapse_level(100_000, seed=2)
    assert low < MEAN_1E6 < high
    assert high - low < 0.06  # s ~ 3.76: half-width ~ 1.96 * 3.76 / sqrt(1e5) = 0.023


def test_stacks_longer_than_one_draw_are_extended(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setattr(_random_stack, "_WIDTH", 4)  # draw 4 bricks at a time: most stacks need extending
    levels = collapse_levels(50_000, np.random.default_rng(9))
    assert levels.min() >= 3 and levels.max() > 8
    sem = levels.std(ddof=1) / math.sqrt(len(levels))
    assert abs(levels.mean() - MEAN_1E6) < 4 * sem
    assert abs(np.mean(levels == 3) - 0.125) < 4 * math.sqrt(0.125 * 0.875 / len(levels))


def test_errors():
    with pytest.raises(RuntimeError, match="max_levels=4"):
        collapse_levels(1000, np.random.default_rng(0), max_levels=4)
    with pytest.raises(ValueError):
        collapse_levels(-1, np.random.default_rng(0))
    with pytest.raises(ValueError):
        collapse_levels(10, np.random.default_rng(0), max_levels=1)
    with pytest.raises(ValueError):
        mean_collapse_level(1, seed=0)
    with pytest.raises(ValueError):
        levels_of_walks(np.zeros(3))

"""Statistical verdicts (stackdsl.verdicts.stats): the intervals against scipy and known cases, their
coverage, the PASS/FAIL/INCONCLUSIVE rule on constructed data, and samples_to_decide against
what more samples actually do."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from stackdsl.verdicts.stats import (
    MeanWithin,
    ProportionBound,
    ProportionWithin,
    QuantileWithin,
    decide,
    format_level,
    mean_interval,
    proportion_interval,
    quantile_interval,
    summary,
)


def normal_levels(rng: np.random.Generator, mean: float, sd: float, n: int) -> list[int]:
    return [int(v) for v in np.clip(np.rint(rng.normal(mean, sd, n)), 1, None)]


# --- intervals ---------------------------------------------------------------------------


def test_t_interval_of_a_normal_sample_covers_its_mean():
    x = np.random.default_rng(0).normal(7.0, 2.0, 400)
    low, high = mean_interval(x.tolist())
    assert low < 7.0 < high
    half = stats.t.ppf(0.975, 399) * x.std(ddof=1) / math.sqrt(400)
    assert (low, high) == pytest.approx((x.mean() - half, x.mean() + half))


@pytest.mark.slow
def test_t_interval_coverage_is_95_percent():
    rng = np.random.default_rng(1)
    trials, hits = 3000, 0
    for _ in range(trials):
        low, high = mean_interval(rng.normal(3.0, 1.5, 8).tolist()) or (math.nan, math.nan)
        hits += low < 3.0 < high
    assert abs(hits / trials - 0.95) < 4 * math.sqrt(0.95 * 0.05 / trials)  # within 4 sigma (0.016)


def test_t_interval_degenerate_cases():
    assert mean_interval([]) is None and mean_interval([5]) is None
    assert mean_interval([7, 7, 7]) == (7.0, 7.0)
    with pytest.raises(ValueError):
        mean_interval([1, 2], confidence=1.0)


@pytest.mark.parametrize("k, n", [(0, 1), (0, 20), (3, 10), (50, 100), (199, 200), (200, 200)])
def test_clopper_pearson_against_scipy_and_the_beta_quantiles(k: int, n: int):
    low, high = proportion_interval(k, n)
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=0.95, method="exact")
    assert (low, high) == (ci.low, ci.high)
    # Clopper & Pearson (1934) by their beta-quantile form
    assert low == pytest.approx(0.0 if k == 0 else stats.beta.ppf(0.025, k, n - k + 1), abs=1e-12)
    assert high == pytest.approx(1.0 if k == n else stats.beta.ppf(0.975, k + 1, n - k), abs=1e-12)


def test_proportion_interval_errors():
    for k, n in [(0, 0), (3, 2), (-1, 5)]:
        with pytest.raises(ValueError):
            proportion_interval(k, n)


def test_quantile_interval_is_the_binomial_order_statistic_interval():
    x = np.arange(1.0, 101.0)  # order statistics are their own ranks
    estimate, low, high = quantile_interval(x.tolist(), 0.5)
    assert estimate == 50.0
    # ranks l, u with P(l <= B < u) >= 0.95 for B ~ Binom(100, 1/2): the classic [40, 61]
    assert (low, high) == (40.0, 61.0)
    b = stats.binom(100, 0.5)
    assert b.cdf(60) - b.cdf(39) >= 0.95


@pytest.mark.slow
def test_quantile_interval_coverage_and_standing_samples():
    # For n = 40 and q = 1/2 the interval is [x_(14), x_(27)]: it covers a continuous law's median
    # with probability P(14 <= B <= 26), B ~ Binom(40, 1/2), which is 0.9615.
    b = stats.binom(40, 0.5)
    exact = b.cdf(26) - b.cdf(13)
    assert exact == pytest.approx(0.9615, abs=1e-4)
    rng = np.random.default_rng(2)
    trials, hits = 600, 0
    for _ in range(trials):
        _, low, high = quantile_interval(rng.exponential(1.0, 40).tolist(), 0.5)
        hits += low <= math.log(2) <= high
    assert abs(hits / trials - exact) < 4 * math.sqrt(exact * (1 - exact) / trials)
    assert quantile_interval([3.0, math.inf, math.inf, math.inf], 0.5) == (math.inf, -math.inf, math.inf)
    assert quantile_interval([math.inf] * 50, 0.5)[0:2] == (math.inf, math.inf)


# --- verdicts -----------------------------------------------------------------------------


def test_mean_verdicts():
    around7 = [6, 7, 8] * 40 + [None] * 3
    v = decide(MeanWithin(7, 0.5), around7)
    assert (v.outcome, v.estimate, v.n, v.samples_to_decide) == ("PASS", 7.0, 120, None)
    assert v.expected == "mean 7±0.5"
    assert v.measured.startswith("mean 7.00 [6.85, 7.15], n=120 collapsed, 3 stood")
    assert decide(MeanWithin(9, 0.5), around7).outcome == "FAIL"
    v = decide(MeanWithin(7.5, 0.5), around7)  # the interval straddles 7.0
    assert v.outcome == "INCONCLUSIVE" and v.samples_to_decide is None  # the estimate is on the edge
    assert decide(MeanWithin(7, 0.5), [None] * 5).outcome == "INCONCLUSIVE"
    single = decide(MeanWithin(7, 0.5), [7, None])
    assert (single.outcome, single.estimate, single.interval) == ("INCONCLUSIVE", 7.0, None)


def test_proportion_verdicts():
    stood, collapsed = [None] * 190, [5] * 10  # 0.95, CP [0.910, 0.976]
    assert decide(ProportionBound(">=", 0.9), stood + collapsed).outcome == "PASS"
    assert decide(ProportionBound("<", 0.9), stood + collapsed).outcome == "FAIL"
    assert decide(ProportionBound(">", 0.99), stood + collapsed).outcome == "FAIL"
    v = decide(ProportionBound(">=", 0.95), stood + collapsed)
    assert v.outcome == "INCONCLUSIVE" and v.samples_to_decide is None  # exactly on the bound
    v = decide(ProportionBound(">=", 0.9), [None] * 20)  # CP low 0.832
    assert v.outcome == "INCONCLUSIVE"
    assert v.samples_to_decide == math.ceil(math.log(0.025) / math.log(0.9))  # 0.025^(1/m) >= 0.9: m = 36
    assert v.measured == "P(stands) 1.000 [0.832, 1.000], 20/20 stood"
    assert decide(ProportionBound(">=", 0.9), []).outcome == "INCONCLUSIVE"


def test_a_probability_within_a_tolerance_is_judged_by_its_interval():
    """``p_stands: "0.67 ± 0.1"``: PASS when the Clopper-Pearson interval lies in [0.57, 0.77],
    FAIL when it lies wholly outside, else INCONCLUSIVE with the samples that would decide it."""
    two_thirds = [None, None, 5] * 200  # 400 of 600 stood: CP [0.628, 0.704]
    assert proportion_interval(400, 600) == pytest.approx((0.628, 0.704), abs=0.001)
    assert decide(ProportionWithin(0.67, 0.1), two_thirds).outcome == "PASS"
    assert decide(ProportionWithin(0.4, 0.1), two_thirds).outcome == "FAIL"  # [0.3, 0.5]
    assert decide(ProportionWithin(0.67, 0.01), two_thirds).outcome == "INCONCLUSIVE"  # the interval is wider
    few = decide(ProportionWithin(0.67, 0.1), [None, None, 5] * 10)  # 20 of 30: CP [0.472, 0.827]
    assert few.outcome == "INCONCLUSIVE" and few.expected == "P(stands) 0.67±0.1"
    m = few.samples_to_decide

    def inside(m: int) -> bool:  # the interval at the same share, 2/3 of m (a projection: k need not be whole)
        k = 2 / 3 * m
        return stats.beta.ppf(0.025, k, m - k + 1) >= 0.57 and stats.beta.ppf(0.975, k + 1, m - k) <= 0.77

    assert m is not None and inside(m) and not inside(m - 1)
    assert decide(ProportionWithin(0.95, 0.1), [None] * 100).outcome == "PASS"  # [0.85, 1]: the interval reaches 1
    exact = decide(ProportionWithin(0.5, 0.0), [None, 3], exact=True)
    assert exact.outcome == "PASS" and exact.interval == (0.5, 0.5)
    assert decide(ProportionWithin(0.2, 0.1), [None, 3], exact=True).outcome == "FAIL"
    with pytest.raises(ValueError, match="target"):
        ProportionWithin(1.2, 0.1)
    with pytest.raises(ValueError, match="tolerance"):
        ProportionWithin(0.5, -0.1)


def test_quantile_verdicts():
    levels = [5, 6, 7, 8, 9] * 60 + [None] * 5
    v = decide(QuantileWithin(0.5, 7, 1), levels)
    assert (v.outcome, v.estimate, v.expected) == ("PASS", 7.0, "median 7±1")
    assert decide(QuantileWithin(0.5, 10, 1), levels).outcome == "FAIL"
    high = decide(QuantileWithin(0.99, 9, 0.5), levels)  # the 99 % quantile "stands": interval reaches +inf
    assert high.outcome == "INCONCLUSIVE" and high.interval is not None and high.interval[1] == math.inf
    assert "stands]" in high.measured and high.expected == "99% quantile 9±0.5"
    mostly_standing = [None] * 90 + [4] * 10
    v = decide(QuantileWithin(0.5, 30, 5), mostly_standing)
    assert (v.outcome, v.estimate, v.interval) == ("FAIL", math.inf, (math.inf, math.inf))
    # an end below every sample is the lowest level, not -inf: a new user read "median 1 [-inf,
    # stands]" of a single brick that collapsed at 1 in two of four samples
    v = decide(QuantileWithin(0.5, 1, 0), [1, 1, None, None])
    assert v.outcome == "INCONCLUSIVE" and v.interval == (1.0, math.inf), v
    assert v.measured == "median 1 [1, stands], n=4, 2 stood"
    assert decide(QuantileWithin(0.2, 1, 0), [1] * 30).outcome == "PASS"  # low end no sample gives: still 1


def test_samples_to_decide_for_a_mean_narrows_the_interval_to_the_gap():
    ratios, checked = [], 0
    for seed in range(30):
        rng = np.random.default_rng(seed)
        v = decide(MeanWithin(7, 0.5), normal_levels(rng, 7.3, 1.5, 40))
        if v.outcome != "INCONCLUSIVE" or v.samples_to_decide is None or v.estimate is None:
            continue
        d = min(abs(v.estimate - 6.5), abs(7.5 - v.estimate))
        ci = mean_interval(normal_levels(rng, 7.3, 1.5, v.samples_to_decide))
        assert ci is not None
        ratios.append((ci[1] - ci[0]) / 2 / d)
        checked += 1
    assert checked >= 20
    assert 0.9 < float(np.median(ratios)) < 1.1  # the new half-width is the gap that was missing
    assert max(ratios) < 1.4


def test_samples_to_decide_decides_on_the_same_data_repeated():
    base = [6, 7, 7, 8, 9, 7, 6, 8]  # mean 7.25 against 7±0.5: the gap is 0.25
    v = decide(MeanWithin(7, 0.5), base)
    assert v.outcome == "INCONCLUSIVE" and v.samples_to_decide is not None
    m = v.samples_to_decide
    assert decide(MeanWithin(7, 0.5), (base * m)[:m]).outcome == "PASS"
    assert decide(MeanWithin(7, 0.5), (base * m)[: m // 2]).outcome == "INCONCLUSIVE"
    # with half the samples standing, twice as many samples are needed
    w = decide(MeanWithin(7, 0.5), [x for b in base for x in (b, None)])
    assert w.samples_to_decide is not None and abs(w.samples_to_decide - 2 * m) <= 2
    q = decide(QuantileWithin(0.5, 7, 0.5), [5, 6, 7, 8, 9] * 6)  # F = 0.4 below, 0.6 up to the edge
    assert q.outcome == "INCONCLUSIVE" and q.samples_to_decide is not None
    assert 80 < q.samples_to_decide < 130  # normal approximation: 1.96^2 * 0.25 / 0.1^2 = 96
    k = -(-q.samples_to_decide // 5) * 5
    assert decide(QuantileWithin(0.5, 7, 0.5), [5, 6, 7, 8, 9] * (k // 5)).outcome == "PASS"


def test_samples_to_decide_for_a_proportion():
    ratios = []
    for seed in range(30):
        rng = np.random.default_rng(seed)
        levels = [None if rng.random() < 0.93 else 4 for _ in range(40)]
        v = decide(ProportionBound(">=", 0.85), levels)
        if v.outcome != "INCONCLUSIVE" or v.samples_to_decide is None or v.estimate is None or v.estimate <= 0.85:
            continue
        m, p = v.samples_to_decide, v.estimate
        k = int((rng.random(m) < p).sum())
        low, _ = proportion_interval(k, m)
        ratios.append((k / m - low) / (p - 0.85))
    assert len(ratios) >= 15
    assert 0.85 < float(np.median(ratios)) < 1.15
    # p = 0.95 against 0.9: the normal approximation says 1.96^2 * 0.95 * 0.05 / 0.05^2 = 73 samples, but the
    # exact interval's lower arm is longer near 1 (at 69/73 it reaches 0.866): 142 samples.
    v = decide(ProportionBound(">=", 0.9), [None] * 38 + [3] * 2)
    assert v.samples_to_decide == 142
    assert proportion_interval(135, 142)[0] >= 0.9 > proportion_interval(95, 100)[0]


def test_bad_input():
    for bad in (0, -3, 2.5, True, "7"):
        with pytest.raises(ValueError):
            decide(MeanWithin(7, 1), [5, bad])  # type: ignore[list-item]
    with pytest.raises(ValueError):
        MeanWithin(7, -1)
    with pytest.raises(ValueError):
        MeanWithin(math.nan, 1)
    with pytest.raises(ValueError):
        ProportionBound("==", 0.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError):
        ProportionBound(">=", 1.5)
    with pytest.raises(ValueError):
        QuantileWithin(1.0, 7, 1)
    with pytest.raises(ValueError):
        decide(MeanWithin(7, 1), [5, 6], confidence=0)
    with pytest.raises(TypeError):
        decide("mean", [5])  # type: ignore[arg-type]


# --- summary ------------------------------------------------------------------------------


def test_summary():
    s = summary([3, 4, 4, 9, None, None], levels_built=30)
    assert (s.n, s.collapsed, s.stood) == (6, 4, 2)
    assert s.histogram == {3: 1, 4: 2, 9: 1}
    assert s.mean == 5.0 and s.mean_interval is not None and s.mean_interval[0] < 5 < s.mean_interval[1]
    assert s.quantiles == {0.05: 3.0, 0.25: 4.0, 0.5: 4.0, 0.75: math.inf, 0.95: math.inf}
    assert s.p_stands == pytest.approx(1 / 3) and s.p_stands_interval == proportion_interval(2, 6)
    text = s.text()
    assert "2 stood (30 levels)" in text and "75% stands" in text and "histogram 3:1 4:2 9:1" in text


def test_summary_degenerate():
    empty = summary([])
    assert (empty.n, empty.mean, empty.p_stands, empty.quantiles, empty.histogram) == (0, None, None, {}, {})
    assert empty.text() == "n=0: 0 collapsed, 0 stood"
    standing = summary([None] * 4)
    assert standing.mean is None and standing.p_stands == 1.0 and set(standing.quantiles.values()) == {math.inf}
    one = summary([7] * 5)
    assert one.mean_interval == (7.0, 7.0) and one.p_stands_interval == proportion_interval(0, 5)
    assert [format_level(v) for v in (math.inf, -math.inf, 3.0, 3.25)] == ["stands", "-inf", "3", "3.25"]


def test_the_mean_interval_shown_stays_within_the_levels_a_collapse_can_have():
    from stackdsl.verdicts.stats import mean_interval, summary

    levels = [1, 2, 29]
    assert mean_interval(levels)[0] < 1 and mean_interval(levels)[1] > 30  # the t interval alone
    shown = summary(levels, levels_built=30).mean_interval
    assert shown[0] == 1.0 and shown[1] == 30.0
    assert "95% CI [1.00, 30.00] (of the 3 that collapsed)" in summary(levels, levels_built=30).text()

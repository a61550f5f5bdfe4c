"""Statistical verdicts over one cell's Monte-Carlo samples, decided by confidence intervals.

A cell's samples are a sequence of collapse levels: an ``int`` (>= 1, the level at which the
structure collapsed) or ``None`` (the structure stood, every level built). Three statistics:

- the **mean collapse level** over the samples that collapsed. Standing samples are
  excluded (they have no collapse level) and their count is reported beside the mean.
  Interval: Student's t, ``mean ± t_{n-1}·s/√n`` (:func:`scipy.stats.t`; Student 1908).
- **P(stands)**, the fraction of samples that stood. Interval: exact Clopper-Pearson
  (Clopper & Pearson 1934) by ``scipy.stats.binomtest(k, n).proportion_ci(method="exact")``.
  Chosen over Wilson (1927) because its coverage is at least the nominal level for every n
  and p (Wilson's dips below it for some p), so a PASS is never claimed on an interval that
  is too narrow, and it behaves at k = 0 and k = n, where a well-built structure sits.
- a **quantile q** of the collapse level, standing samples counting as +inf (above every
  level) so that a quantile can be "stands". Estimate: the order statistic x_(⌈nq⌉)
  (``numpy.quantile(method="inverted_cdf")``). Interval: distribution-free, from order
  statistics and the binomial distribution of the count below the quantile
  (``scipy.stats.quantile_test(x, p=q).confidence_interval``; Thompson, Ann. Math. Statist.
  7 (1936) 122-128; Conover, *Practical Nonparametric Statistics*, 3rd ed. 1999). An end no
  order statistic can give is unbounded: +inf above ("stands"), and below the lowest level a
  collapse can have, 1 (-inf in :func:`~stackdsl.verdicts.intervals.quantile_interval`, which
  knows nothing of levels).

Collapsed samples all at one level give a zero-width t interval: the verdict then takes
them at their word, however few (two samples at 7 PASS ``mean 7±0.5``).

Verdict rule (stackdsl's own): PASS when the whole interval lies inside the expectation's
region, FAIL when the whole interval lies outside it, INCONCLUSIVE otherwise (also when there
is no interval). The region of a tolerance is closed, [target - tol, target + tol]; so is that
of ``>=``/``<=``; ``>``/``<`` give open regions.

>>> decide(MeanWithin(7, 0.5), [7, 7, 8, 6, 7, 7, None] * 10).outcome
'PASS'
>>> decide(ProportionBound(">=", 0.9), [None] * 40).measured
'P(stands) 1.000 [0.912, 1.000], 40/40 stood'

Source: the interval methods as cited above (through scipy, :mod:`stackdsl.verdicts.intervals`); the
verdict rule and the ``samples_to_decide`` projection are stackdsl's own.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from .intervals import check_confidence, mean_interval, proportion_interval, quantile_interval, scipy_stats

Outcome = Literal["PASS", "FAIL", "INCONCLUSIVE"]
Op = Literal[">=", "<=", ">", "<"]
#: The lowest level a collapse can have: a quantile's interval ends no lower.
LOWEST_LEVEL = 1.0
#: The quantiles a :class:`CellSummary` reports.
SUMMARY_QUANTILES = (0.05, 0.25, 0.5, 0.75, 0.95)
#: ``samples_to_decide`` looks no further than this many samples (None beyond).
MAX_SAMPLES = 10**9


@dataclass(frozen=True)
class MeanWithin:
    """Expectation ``mean: 7 ± 0.5``: the mean collapse level (collapsed samples only) lies in
    [target - tolerance, target + tolerance]. Levels, no units. Raises ValueError on a
    non-finite target or a negative or non-finite tolerance. Source: stackdsl's own."""

    target: float
    tolerance: float

    def __post_init__(self) -> None:
        _check_target(self.target, self.tolerance)


@dataclass(frozen=True)
class ProportionBound:
    """Expectation ``p_stands: ">= 0.9"``: the probability that the structure stands satisfies
    ``op bound``. Raises ValueError on an unknown op or a bound outside [0, 1].
    Source: stackdsl's own."""

    op: Op
    bound: float

    def __post_init__(self) -> None:
        if self.op not in (">=", "<=", ">", "<"):
            raise ValueError(f"op must be one of >=, <=, >, <; got {self.op!r}")
        if not 0.0 <= self.bound <= 1.0:
            raise ValueError(f"bound must lie in [0, 1], got {self.bound}")


@dataclass(frozen=True)
class ProportionWithin:
    """Expectation ``p_stands: "0.67 ± 0.1"``: the probability that the structure stands lies in
    [target - tolerance, target + tolerance] (ends included, cut to [0, 1]). Raises ValueError
    on a target outside [0, 1] or a negative or non-finite tolerance. Source: stackdsl's own."""

    target: float
    tolerance: float

    def __post_init__(self) -> None:
        if not 0.0 <= self.target <= 1.0:
            raise ValueError(f"target must lie in [0, 1], got {self.target}")
        if not (math.isfinite(self.tolerance) and self.tolerance >= 0.0):
            raise ValueError(f"tolerance must be a finite number >= 0, got {self.tolerance}")

    @property
    def region(self) -> tuple[float, float]:
        """The accepted probabilities' ends, within [0, 1]."""
        return max(0.0, self.target - self.tolerance), min(1.0, self.target + self.tolerance)


@dataclass(frozen=True)
class QuantileWithin:
    """Expectation ``quantile q of the collapse level within target ± tolerance`` (q = 0.5: the
    median), standing samples counting as +inf. Raises ValueError unless 0 < q < 1, on a
    non-finite target, or a negative or non-finite tolerance. Source: stackdsl's own."""

    q: float
    target: float
    tolerance: float

    def __post_init__(self) -> None:
        if not 0.0 < self.q < 1.0:
            raise ValueError(f"q must lie in (0, 1), got {self.q}")
        _check_target(self.target, self.tolerance)


Expectation = MeanWithin | ProportionBound | ProportionWithin | QuantileWithin


@dataclass(frozen=True)
class StatVerdict:
    """The verdict of one statistical expectation on one cell.

    Attributes:
        outcome: "PASS", "FAIL" or "INCONCLUSIVE" (rule: module docstring).
        estimate: the statistic's point estimate (a level, a probability; +inf for a quantile
            that stands), or None when there is none (no collapse for a mean, no samples).
        interval: (low, high) at the confidence asked, or None when there is none.
        n: samples used (collapsed samples for a mean, every sample otherwise).
        expected, measured: short texts, e.g. "mean 7±0.5" and
            "mean 6.82 [6.61, 7.03], n=197 collapsed, 3 stood".
        samples_to_decide: for INCONCLUSIVE only, the estimated total number of samples (all
            of the cell's samples, standing ones included; not the number to add) at which the
            interval would decide (see :func:`decide`); None otherwise or when no estimate is
            possible.
        field: the expectation's field under ``expect`` (``"collapse"``, ``"cells[1].p_stands"``),
            which says where the file wrote it; empty when not known.
    """

    outcome: Outcome
    estimate: float | None
    interval: tuple[float, float] | None
    n: int
    expected: str
    measured: str
    samples_to_decide: int | None = None
    field: str = ""


@dataclass(frozen=True)
class CellSummary:
    """What one cell's samples show (:func:`summary`).

    Attributes:
        n, collapsed, stood: sample counts (n = collapsed + stood).
        levels_built: levels a standing sample built, if known.
        mean, mean_interval: mean collapse level over collapsed samples and its t interval
            (None with no collapse; no interval with fewer than 2).
        quantiles: q -> level for q in :data:`SUMMARY_QUANTILES`, +inf meaning "stands"
            (empty with no samples).
        p_stands, p_stands_interval: fraction that stood and its Clopper-Pearson interval
            (None with no samples).
        histogram: collapse level -> count, ascending, levels with no count left out.
        confidence: the intervals' confidence level.
    """

    n: int
    collapsed: int
    stood: int
    levels_built: int | None
    mean: float | None
    mean_interval: tuple[float, float] | None
    quantiles: dict[float, float]
    p_stands: float | None
    p_stands_interval: tuple[float, float] | None
    histogram: dict[int, int]
    confidence: float = 0.95
    exact: bool = False

    def text(self) -> str:
        """The summary as a few lines of text, quantiles of +inf written "stands".

        >>> print(summary([3, 4, 4, None], levels_built=10).text())
        n=4: 3 collapsed, 1 stood (10 levels)
        mean collapse level 3.67, 95% CI [2.23, 5.10] (of the 3 that collapsed)
        quantiles 5% 3, 25% 3, 50% 4, 75% 4, 95% stands
        P(stands) 0.250 [0.006, 0.806]
        histogram 3:1 4:2
        """
        built = f" ({self.levels_built} levels)" if self.levels_built is not None else ""
        lines = [f"n={self.n}: {self.collapsed} collapsed, {self.stood} stood{built}"]
        if self.mean is not None:
            span = _span(self.mean_interval, ".2f")
            level = "exact" if self.exact else f"{100 * self.confidence:g}% CI {span}"
            lines.append(f"mean collapse level {self.mean:.2f}, {level} (of the {self.collapsed} that collapsed)")
        if self.quantiles:
            lines.append("quantiles " + ", ".join(f"{100 * q:g}% {format_level(v)}" for q, v in self.quantiles.items()))
        if self.p_stands is not None:
            span = (
                "exact (nothing is drawn: every sample is the same run)" if self.exact else _span(self.p_stands_interval, ".3f")
            )
            lines.append(f"P(stands) {self.p_stands:.3f} {span}")
        if self.histogram:
            lines.append("histogram " + " ".join(f"{level}:{count}" for level, count in self.histogram.items()))
        return "\n".join(lines)


def format_level(value: float) -> str:
    """A level as text: "stands" for +inf, "-inf" for -inf, an integer without decimals,
    else two decimals. Source: stackdsl's own.

    >>> format_level(math.inf), format_level(7.0), format_level(6.5)
    ('stands', '7', '6.50')
    """
    if math.isinf(value):
        return "stands" if value > 0 else "-inf"
    return f"{value:.0f}" if float(value).is_integer() else f"{value:.2f}"


def decide(
    expectation: Expectation, levels: Sequence[int | None], confidence: float = 0.95, *, exact: bool = False
) -> StatVerdict:
    """Decide ``expectation`` on one cell's samples (``levels``: collapse level or None).

    PASS/FAIL/INCONCLUSIVE by the module's rule. For INCONCLUSIVE, ``samples_to_decide``
    projects the current estimate and spread to m samples and returns the smallest m (total
    samples, at least n + 1) at which the same interval method would decide. In closed form
    this is about
      - mean: m_c = (t·s / d)² collapsed samples, d the distance from the mean to the nearest
        edge of the region, scaled by n / n_collapsed to total samples;
      - P(stands): m = z²·p̂(1 - p̂) / d², d = |p̂ - bound| (normal approximation); the search
        uses the exact interval itself, its beta quantiles (Clopper & Pearson 1934) taken at
        k = p̂·m successes, so p̂ = 0 or 1 also gets an answer, and near 0 or 1, where the exact
        interval is skewed, it asks for more than the approximation (p̂ = 0.95 against 0.9:
        142, not 73);
      - quantile: m = z²·q(1 - q) / d², d the gap between q and the empirical CDF at the
        nearest edge of the region (the order-statistic ranks move by z√(mq(1-q))).
    It is None when the estimate sits exactly on an edge (d = 0), without an estimate or
    spread (fewer than 2 collapsed samples for a mean), or beyond :data:`MAX_SAMPLES`.

    ``exact``: the samples are one run repeated (the sweep draws nothing: no distribution, no
    placement error), so the statistic is known without sampling error: its interval is the
    point itself, and it is PASS or FAIL from a single sample (a mean expected of a cell whose
    run stands is FAIL: it has no collapse level); INCONCLUSIVE only without samples.

    Raises ValueError on a level that is not None or an int >= 1, or a confidence outside
    (0, 1). Source: stackdsl's own (rule and projection); intervals as in the module docstring.

    >>> v = decide(QuantileWithin(0.5, 7, 1), [6, 7, 7, 8] * 5 + [None])
    >>> v.outcome, v.estimate, v.interval, v.expected
    ('PASS', 7.0, (7.0, 8.0), 'median 7±1')
    """
    check_confidence(confidence)
    if exact:
        return _decide_exact(expectation, levels)
    collapsed = _collapsed(levels)
    if isinstance(expectation, MeanWithin):
        return _decide_mean(expectation, collapsed, len(levels), confidence)
    if isinstance(expectation, (ProportionBound, ProportionWithin)):
        return _decide_proportion(expectation, len(levels) - len(collapsed), len(levels), confidence)
    if isinstance(expectation, QuantileWithin):
        return _decide_quantile(expectation, collapsed, len(levels), confidence)
    raise TypeError(f"not an expectation: {expectation!r}")


def _decide_exact(expectation: Expectation, levels: Sequence[int | None]) -> StatVerdict:
    """:func:`decide` on samples that are one run repeated: the statistic is computed from
    ``levels`` as :func:`decide` computes it, and its interval is the point itself. A mean
    expected of samples that all stood is FAIL: the run stands, so it has no collapse level to
    be near the target (with sampling this is INCONCLUSIVE, since another sample may collapse)."""
    collapsed = _collapsed(levels)
    n, stood = len(levels), len(levels) - len(collapsed)
    expected = expected_text(expectation)
    if n == 0:
        return StatVerdict("INCONCLUSIVE", None, None, 0, expected, "no samples")
    drawn = " (nothing is drawn)"
    if isinstance(expectation, (ProportionBound, ProportionWithin)):
        p = stood / n
        outcome = _judge_proportion((p, p), expectation)
        return StatVerdict(outcome, p, (p, p), n, expected, f"P(stands) {p:.3f} exact, {stood}/{n} stood{drawn}")
    a, b = expectation.target - expectation.tolerance, expectation.target + expectation.tolerance
    if isinstance(expectation, MeanWithin):
        if not collapsed:
            return StatVerdict("FAIL", None, None, 0, expected, f"no collapse: it stands, {stood}/{n} stood{drawn}")
        mean = float(np.mean(collapsed))
        measured = f"mean {mean:.2f} exact, n={len(collapsed)} collapsed, {stood} stood{drawn}"
        return StatVerdict(_judge_region((mean, mean), a, b), mean, (mean, mean), len(collapsed), expected, measured)
    if isinstance(expectation, QuantileWithin):
        values = [float(v) for v in collapsed] + [math.inf] * stood
        q = float(np.quantile(values, expectation.q, method="inverted_cdf"))
        measured = f"{_quantile_name(expectation.q)} {format_level(q)} exact, n={n}, {stood} stood{drawn}"
        return StatVerdict(_judge_region((q, q), a, b), q, (q, q), n, expected, measured)
    raise TypeError(f"not an expectation: {expectation!r}")


def expected_text(expectation: Expectation) -> str:
    """The expectation as a verdict's ``expected`` text: ``"mean 7±0.5"``, ``"median 7±1"``,
    ``"P(stands) >= 0.9"``."""
    if isinstance(expectation, ProportionBound):
        return f"P(stands) {expectation.op} {expectation.bound:g}"
    if isinstance(expectation, ProportionWithin):
        return f"P(stands) {expectation.target:g}±{expectation.tolerance:g}"
    if isinstance(expectation, MeanWithin):
        return f"mean {expectation.target:g}±{expectation.tolerance:g}"
    if isinstance(expectation, QuantileWithin):
        return f"{_quantile_name(expectation.q)} {expectation.target:g}±{expectation.tolerance:g}"
    raise TypeError(f"not an expectation: {expectation!r}")


def _quantile_name(q: float) -> str:
    return "median" if q == 0.5 else f"{100 * q:g}% quantile"


def summary(
    levels: Sequence[int | None], levels_built: int | None = None, confidence: float = 0.95, *, exact: bool = False
) -> CellSummary:
    """Summarise one cell: counts, mean + t interval (collapsed only), quantiles (standing as
    +inf), P(stands) + Clopper-Pearson interval, histogram. Empty input gives zero counts and
    None/empty statistics. ``exact``: the samples are one run repeated (as in :func:`decide`),
    the intervals are the estimates themselves. Raises ValueError as :func:`decide`. Source: as
    the module docstring.

    >>> s = summary([7, 7, 8, None])
    >>> s.histogram, s.quantiles[0.5], s.p_stands
    ({7: 2, 8: 1}, 7.0, 0.25)
    """
    check_confidence(confidence)
    collapsed = _collapsed(levels)
    n, stood = len(levels), len(levels) - len(collapsed)
    values = [float(v) for v in collapsed] + [math.inf] * stood
    quantiles = {q: float(np.quantile(values, q, method="inverted_cdf")) for q in SUMMARY_QUANTILES} if n else {}
    mean = float(np.mean(collapsed)) if collapsed else None
    p_stands = stood / n if n else None
    return CellSummary(
        n=n,
        collapsed=len(collapsed),
        stood=stood,
        levels_built=levels_built,
        mean=mean,
        mean_interval=(mean, mean)
        if exact and mean is not None
        else _feasible(mean_interval(collapsed, confidence), levels_built),
        quantiles=quantiles,
        p_stands=p_stands,
        p_stands_interval=(p_stands, p_stands)
        if exact and p_stands is not None
        else proportion_interval(stood, n, confidence)
        if n
        else None,
        histogram=dict(sorted(Counter(collapsed).items())),
        confidence=confidence,
        exact=exact,
    )


def _feasible(interval: tuple[float, float] | None, levels_built: int | None) -> tuple[float, float] | None:
    """The interval within the levels a collapse can have, 1 to ``levels_built``: the mean lies
    there, so the intersection covers it as often as the interval does."""
    if interval is None:
        return None
    return (max(interval[0], 1.0), min(interval[1], float(levels_built)) if levels_built else interval[1])


def _decide_mean(e: MeanWithin, collapsed: list[int], n: int, c: float) -> StatVerdict:
    expected = expected_text(e)
    stood = n - len(collapsed)
    if not collapsed:
        return StatVerdict("INCONCLUSIVE", None, None, 0, expected, f"no collapse, {stood} stood" if n else "no samples")
    mean, ci = float(np.mean(collapsed)), mean_interval(collapsed, c)
    measured = f"mean {mean:.2f} {_span(ci, '.2f')}, n={len(collapsed)} collapsed, {stood} stood"
    outcome = _judge_region(ci, e.target - e.tolerance, e.target + e.tolerance)
    if outcome != "INCONCLUSIVE" or ci is None:
        return StatVerdict(outcome, mean, ci, len(collapsed), expected, measured)
    a, b = e.target - e.tolerance, e.target + e.tolerance
    d = min(mean - a, b - mean) if a <= mean <= b else max(a - mean, mean - b)  # to the nearest edge
    s = float(np.std(collapsed, ddof=1))

    def narrow(m: int) -> bool:
        return bool(scipy_stats().t.ppf((1 + c) / 2, m - 1) * s / math.sqrt(m) < d)

    m = _first(narrow, len(collapsed)) if d > 0 else None
    total = None if m is None else max(math.ceil(m * n / len(collapsed) - 1e-9), n + 1)  # standing samples too
    return StatVerdict(outcome, mean, ci, len(collapsed), expected, measured, total)


def _decide_proportion(e: ProportionBound | ProportionWithin, stood: int, n: int, c: float) -> StatVerdict:
    expected = expected_text(e)
    if n == 0:
        return StatVerdict("INCONCLUSIVE", None, None, 0, expected, "no samples")
    p, ci = stood / n, proportion_interval(stood, n, c)
    measured = f"P(stands) {p:.3f} {_span(ci, '.3f')}, {stood}/{n} stood"
    outcome = _judge_proportion(ci, e)
    if outcome != "INCONCLUSIVE":
        return StatVerdict(outcome, p, ci, n, expected, measured)

    def decides(m: int) -> bool:  # Clopper-Pearson's beta quantiles, continued to k = p·m successes
        a = (1 - c) / 2
        low = 0.0 if p == 0 else float(scipy_stats().beta.ppf(a, p * m, m - p * m + 1))
        high = 1.0 if p == 1 else float(scipy_stats().beta.ppf(1 - a, p * m + 1, m - p * m))
        return _judge_proportion((low, high), e) != "INCONCLUSIVE"

    edges = (e.bound,) if isinstance(e, ProportionBound) else e.region
    m = _first(decides, n) if p not in edges else None
    return StatVerdict(outcome, p, ci, n, expected, measured, m)


def _judge_proportion(ci: tuple[float, float], e: ProportionBound | ProportionWithin) -> Outcome:
    """The verdict of a bound (:func:`_judge_bound`) or of a closed region (:func:`_judge_region`)."""
    if isinstance(e, ProportionBound):
        return _judge_bound(ci, e.op, e.bound)
    return _judge_region(ci, *e.region)


def _decide_quantile(e: QuantileWithin, collapsed: list[int], n: int, c: float) -> StatVerdict:
    name, expected = _quantile_name(e.q), expected_text(e)
    if n == 0:
        return StatVerdict("INCONCLUSIVE", None, None, 0, expected, "no samples")
    stood = n - len(collapsed)
    estimate, low, high = quantile_interval([float(v) for v in collapsed] + [math.inf] * stood, e.q, c)
    low = max(low, LOWEST_LEVEL)  # an end below every order statistic: still no collapse is below level 1
    measured = f"{name} {format_level(estimate)} [{format_level(low)}, {format_level(high)}], n={n}, {stood} stood"
    a, b = e.target - e.tolerance, e.target + e.tolerance
    outcome = _judge_region((low, high), a, b)
    if outcome != "INCONCLUSIVE":
        return StatVerdict(outcome, estimate, (low, high), n, expected, measured)
    below_a = sum(v < a for v in collapsed) / n  # empirical CDF just below a
    upto_b = sum(v <= b for v in collapsed) / n  # empirical CDF at b

    def decides(m: int) -> bool:
        bd = scipy_stats().binom(m, e.q)
        lo_i, hi_i = int(bd.ppf((1 - c) / 2)) - 1, int(bd.isf((1 - c) / 2))  # as quantile_test's interval
        lo_v = LOWEST_LEVEL if lo_i < 0 else _projected(below_a * m, upto_b * m, lo_i, a, b)
        hi_v = math.inf if hi_i >= m else _projected(below_a * m, upto_b * m, hi_i, a, b)
        return _judge_region((lo_v, hi_v), a, b) != "INCONCLUSIVE"

    return StatVerdict(outcome, estimate, (low, high), n, expected, measured, _first(decides, n))


def _projected(below_a: float, upto_b: float, index: int, a: float, b: float) -> float:
    """Where the order statistic of 0-based ``index`` falls, relative to [a, b], in m samples
    of which ``below_a`` lie below a and ``upto_b`` at or below b (expected counts, not rounded):
    a value below a, in [a, b], or above b (the verdict only compares it with a and b)."""
    if index < below_a:
        return a - 1.0
    return (a + b) / 2 if index < upto_b else b + 1.0


def _judge_region(ci: tuple[float, float] | None, a: float, b: float) -> Outcome:
    if ci is None:
        return "INCONCLUSIVE"
    low, high = ci
    if a <= low and high <= b:
        return "PASS"
    return "FAIL" if high < a or low > b else "INCONCLUSIVE"


def _judge_bound(ci: tuple[float, float], op: Op, bound: float) -> Outcome:
    low, high = ci
    passed, failed = {
        ">=": (low >= bound, high < bound),
        ">": (low > bound, high <= bound),
        "<=": (high <= bound, low > bound),
        "<": (high < bound, low >= bound),
    }[op]
    return "PASS" if passed else "FAIL" if failed else "INCONCLUSIVE"


def _first(decides: Callable[[int], bool], n: int) -> int | None:
    """Smallest m > n with decides(m), by doubling then bisection (decides(n) is taken as false);
    None beyond MAX_SAMPLES."""
    low, high = n, max(n + 1, 2 * n)
    while not decides(high):
        if high >= MAX_SAMPLES:
            return None
        low, high = high, min(2 * high, MAX_SAMPLES)
    while high - low > 1:
        mid = (low + high) // 2
        low, high = (low, mid) if decides(mid) else (mid, high)
    return high


def _span(ci: tuple[float, float] | None, spec: str) -> str:
    return "(no interval)" if ci is None else f"[{ci[0]:{spec}}, {ci[1]:{spec}}]"


def _collapsed(levels: Sequence[int | None]) -> list[int]:
    out: list[int] = []
    for v in levels:
        if v is None:
            continue
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"a level must be None or an int >= 1, got {v!r}")
        out.append(int(v))
    return out


def _check_target(target: float, tolerance: float) -> None:
    if not (math.isfinite(target) and math.isfinite(tolerance) and tolerance >= 0):
        raise ValueError(f"need a finite target and a finite tolerance >= 0, got {target} ± {tolerance}")

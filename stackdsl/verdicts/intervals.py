"""Confidence intervals of a mean, a proportion and a quantile, through scipy.

The statistical verdicts of :mod:`stackdsl.verdicts.stats` are decided on them. Sources: Student
(1908) for the mean; Clopper & Pearson (1934) for a proportion; Thompson (1936) and Conover,
*Practical Nonparametric Statistics* (1999), for a quantile.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np


def scipy_stats() -> Any:
    """scipy.stats, imported on first use (a third of a second): a plain check never needs it."""
    from scipy import stats

    return stats


def mean_interval(values: Sequence[float], confidence: float = 0.95) -> tuple[float, float] | None:
    """Student-t confidence interval of the mean of ``values`` (any unit; the interval's):
    mean ± t_{n-1, (1+c)/2} · s / √n, s the sample standard deviation (ddof 1). None with
    fewer than 2 values; (mean, mean) when all values are equal (s = 0). Raises ValueError on
    a confidence outside (0, 1). Source: Student (1908), the quantile by ``scipy.stats.t.ppf``.

    >>> [round(v, 3) for v in mean_interval([6, 7, 8])]
    [4.516, 9.484]
    """
    check_confidence(confidence)
    x = np.asarray(values, dtype=float)
    if x.size < 2:
        return None
    mean, sem = float(x.mean()), float(x.std(ddof=1)) / math.sqrt(x.size)
    half = float(scipy_stats().t.ppf((1 + confidence) / 2, x.size - 1)) * sem
    return (mean - half, mean + half)


def proportion_interval(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper & Pearson 1934) confidence interval of a proportion, k successes of n.
    Raises ValueError unless 0 <= k <= n and n >= 1, or on a confidence outside (0, 1).
    Source: ``scipy.stats.binomtest(k, n).proportion_ci(method="exact")``.

    >>> [round(v, 4) for v in proportion_interval(0, 10)]
    [0.0, 0.3085]
    """
    check_confidence(confidence)
    if not (n >= 1 and 0 <= k <= n):
        raise ValueError(f"need 0 <= k <= n and n >= 1, got k={k}, n={n}")
    ci = scipy_stats().binomtest(k, n).proportion_ci(confidence_level=confidence, method="exact")
    return (float(ci.low), float(ci.high))


def quantile_interval(values: Sequence[float], q: float, confidence: float = 0.95) -> tuple[float, float, float]:
    """(estimate, low, high) of the q quantile of ``values`` (+inf allowed: a standing sample).

    The estimate is the order statistic x_(⌈nq⌉); the interval is the distribution-free
    order-statistic interval of ``scipy.stats.quantile_test(x, p=q).confidence_interval``
    (Thompson 1936; Conover 1999), an end it cannot give being -inf (low) or +inf (high). Raises
    ValueError with no values, unless 0 < q < 1, or on a confidence outside (0, 1).

    >>> quantile_interval([5, 6, 7, 8, 9, 10, 11, 12, math.inf, math.inf], 0.5)
    (9.0, 6.0, inf)
    """
    check_confidence(confidence)
    x = np.asarray(values, dtype=float)
    if x.size == 0:
        raise ValueError("no values")
    if not 0.0 < q < 1.0:
        raise ValueError(f"q must lie in (0, 1), got {q}")
    ci = scipy_stats().quantile_test(x, p=q).confidence_interval(confidence)
    low = -math.inf if math.isnan(ci.low) else float(ci.low)
    high = math.inf if math.isnan(ci.high) else float(ci.high)
    return (float(np.quantile(x, q, method="inverted_cdf")), low, high)


def check_confidence(confidence: float) -> None:
    """Raises ValueError on a confidence outside (0, 1)."""
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}")

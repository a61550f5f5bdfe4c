"""Outcome + expectations -> verdicts.

Source: stackdsl's own (docs/design.md, words: collapse level).
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict

from ._outcome import Outcome
from ._schema import Expect


class Verdict(BaseModel):
    """One expectation checked: what was expected, what was measured, and whether it held."""

    model_config = ConfigDict(frozen=True)

    name: str
    passed: bool
    expected: str
    measured: str


def evaluate(expect: Expect, outcome: Outcome, threshold: float) -> list[Verdict]:
    """Check ``outcome`` against ``expect``; ``threshold`` (m) is how far a brick that
    stays in place may move. ``may_fall`` levels are not checked. An empty list means
    nothing was expected.
    """
    verdicts = []
    measured = describe(outcome.collapse.level if outcome.collapse else None)
    if expect.collapse is not None:
        c = expect.collapse
        passed = outcome.collapse is not None and abs(outcome.collapse.level - c.level) <= c.tolerance
        expected = f"collapse {c.level}" + (f"±{c.tolerance}" if c.tolerance else "")
        verdicts.append(Verdict(name="collapse", passed=passed, expected=expected, measured=measured))
    if expect.stands:
        verdicts.append(Verdict(name="stands", passed=outcome.collapse is None, expected="stands", measured=measured))
    if expect.stays:
        moved = _moved_levels(outcome, threshold)
        bad = sorted(set(expect.stays) & moved)
        verdicts.append(
            Verdict(
                name="stays",
                passed=not bad,
                expected=f"levels {_span(expect.stays)} stay",
                measured=f"levels {_span(bad)} moved" if bad else f"levels {_span(expect.stays)} stayed",
            )
        )
    return verdicts


def _moved_levels(outcome: Outcome, threshold: float) -> set[int]:
    levels = {n.id: n.level for n in outcome.final_graph.nodes}
    return {levels[b] for b, d in outcome.displacement.items() if d > threshold and levels.get(b) is not None}


def describe(collapse_level: int | None) -> str:
    """``'collapse 9'`` or ``'stands'``.

    >>> describe(9), describe(None)
    ('collapse 9', 'stands')
    """
    return "stands" if collapse_level is None else f"collapse {collapse_level}"


def _span(levels) -> str:
    """``(1, 2, 3, 7)`` -> ``'1-3, 7'``."""
    levels = sorted(levels)
    parts, start = [], None
    for i, lv in enumerate(levels):
        if start is None:
            start = lv
        if i + 1 == len(levels) or levels[i + 1] != lv + 1:
            parts.append(f"{start}" if start == lv else f"{start}-{lv}")
            start = None
    return ", ".join(parts)

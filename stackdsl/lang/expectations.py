"""The ``expect`` section of a scenario: what must hold after one run (a collapse level, that
the structure stands, the levels that stay or may fall after an impact) or over a sweep's
samples (a collapse level's mean or quantile, P(stands)).

Source: stackdsl's own (docs/design.md, words).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import Annotated, Any, Literal

from pydantic import (
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    WithJsonSchema,
    model_validator,
)

from .bounds import MAX_LEVELS, StrictModel
from .grammar import (
    BOUND,
    COLLAPSE,
    LEVEL_NUMBER,
    LEVEL_RANGE,
    PLUS_MINUS,
    TOLERANCE_NUMBER,
    WHOLE,
    AlsoAccepts,
    as_int,
    flag,
    given,
    json_pattern,
)


class CollapseLevel(StrictModel):
    """Expected collapse level with a tolerance in levels."""

    level: Annotated[int, Field(ge=1, le=MAX_LEVELS), WHOLE]
    tolerance: Annotated[int, Field(ge=0, le=MAX_LEVELS), WHOLE] = 0


def _collapse(value: Any) -> Any:
    """``9``, ``"9±1"``, ``"9 +- 1"`` or ``{level: 9, tolerance: 1}``."""
    number = as_int(value)
    if number is not None:
        return {"level": number}
    if isinstance(value, str):
        match = re.fullmatch(COLLAPSE, value)
        if not match:
            raise ValueError(f"expected a level such as '9±1', '9 +- 1' or 9, got {value!r}")
        return {"level": int(match[1]), "tolerance": int(match[2] or 0)}
    return value


def _levels(value: Any) -> Any:
    """Levels: ``5``, ``"1-11"``, or a list of those; returned as a sorted tuple."""
    items = value if isinstance(value, list) else [value]
    levels: set[int] = set()
    for item in items:
        number = as_int(item)
        match = re.fullmatch(LEVEL_RANGE, item) if isinstance(item, str) else None
        if number is not None:
            first = last = number
        elif match:
            first, last = int(match[1]), int(match[2] or match[1])
        else:
            first, last = 0, -1  # refused below
        if not 1 <= first <= last <= MAX_LEVELS:
            raise ValueError(f"expected levels from 1 to {MAX_LEVELS} such as 5, '1-11' or a list of those, got {item!r}")
        levels.update(range(first, last + 1))
    return tuple(sorted(levels))


_LEVEL_ITEM = {
    "anyOf": [
        {"type": "integer", "minimum": 1, "maximum": MAX_LEVELS},
        # a range's end below its start ("5-3") is refused by the loader only
        {"type": "string", "pattern": json_pattern(LEVEL_RANGE, LEVEL_NUMBER, LEVEL_NUMBER)},
    ]
}
Levels = Annotated[
    tuple[int, ...],
    BeforeValidator(_levels),
    WithJsonSchema(
        {"anyOf": [_LEVEL_ITEM, {"type": "array", "items": _LEVEL_ITEM}], "description": "levels: 5, '1-11', or a list of those"}
    ),
]


def _plus_minus(value: Any) -> Any:
    """``"7 ± 0.5"`` (or ``+-``, ``+/-``) -> ``{"target": 7.0, "tolerance": 0.5}``."""
    match = re.fullmatch(PLUS_MINUS, value) if isinstance(value, str) else None
    if match:
        return {"target": float(match[1]), "tolerance": float(match[2])}
    if isinstance(value, dict):
        return value
    raise ValueError(f"expected a level and a tolerance such as '7 ± 0.5', got {value!r}")


class Within(StrictModel):
    """A number of levels within a tolerance: written ``"7 ± 0.5"``."""

    target: Annotated[float, Field(ge=0, le=MAX_LEVELS)]
    tolerance: Annotated[float, Field(gt=0, le=MAX_LEVELS)]


PlusMinus = Annotated[
    Within,
    BeforeValidator(_plus_minus),
    AlsoAccepts(({"type": "string", "pattern": f"^{PLUS_MINUS}$"},), "a level and a tolerance: '7 ± 0.5'"),
]


class Quantile(StrictModel):
    """The ``q`` quantile of the collapse level (0 < q < 1; 0.5: the median) within ``level``."""

    q: Annotated[float, Field(gt=0, lt=1)]
    level: PlusMinus


class CollapseStatistic(StrictModel):
    """A sweep's collapse level as a statistic: its ``mean`` over the samples that collapsed, or
    a ``quantile`` (standing samples count as above every level), each within a tolerance."""

    model_config = ConfigDict(json_schema_extra={"oneOf": [given("mean"), given("quantile")]})

    mean: PlusMinus | None = None
    quantile: Quantile | None = None

    @model_validator(mode="after")
    def _one(self) -> CollapseStatistic:
        if (self.mean is None) == (self.quantile is None):
            raise ValueError("give one of 'mean' ('7 ± 0.5') or 'quantile' ({q: 0.5, level: '7 ± 1'})")
        return self


def _bound(value: Any) -> Any:
    """``">= 0.9"`` -> ``{"op": ">=", "bound": 0.9}``."""
    if isinstance(value, str):
        match = re.fullmatch(BOUND, value)
        if not match:
            raise ValueError(f"expected a comparison with a probability such as '>= 0.9', got {value!r}")
        return {"op": match[1], "bound": float(match[2])}
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        raise ValueError(
            f"expected a comparison with a probability, got the bare number {value!r}: "
            f"write '>= {value}' (P(stands) at least {value}) or '<= {value}'"
        )
    return value


class Probability(StrictModel):
    """A bound on a probability: written ``">= 0.9"`` (also ``<=``, ``>``, ``<``)."""

    op: Literal[">=", "<=", ">", "<"]
    bound: Annotated[float, Field(ge=0, le=1)]


def _collapse_form(value: Any) -> str:
    """Which form ``expect.collapse`` is written in: a sweep's ``statistic`` or a run's ``level``."""
    if isinstance(value, CollapseStatistic) or (isinstance(value, dict) and {"mean", "quantile"} & set(value)):
        return "statistic"
    return "level"


class Expect(StrictModel):
    """What must hold: a ``collapse`` level, or that the structure ``stands``; after an
    impact, the levels that ``stay`` in place and the levels that ``may_fall``. A sweep's
    expectations are statistics over its samples instead: ``collapse: {mean: '7 ± 0.5'}``,
    ``collapse: {quantile: {q: 0.5, level: '7 ± 1'}}`` and ``p_stands: '>= 0.9'``, each decided
    by its 95% confidence interval."""

    model_config = ConfigDict(json_schema_extra={"not": given("collapse", "stands")})

    collapse: (
        Annotated[
            Annotated[
                CollapseLevel,
                BeforeValidator(_collapse),
                AlsoAccepts(
                    (
                        {"type": "integer", "minimum": 1, "maximum": MAX_LEVELS},
                        {"type": "string", "pattern": json_pattern(COLLAPSE, LEVEL_NUMBER, TOLERANCE_NUMBER)},
                    ),
                    "the level expected to collapse: 9, '9±1', '9 +- 1' or {level: 9, tolerance: 1}",
                ),
                Tag("level"),
            ]
            | Annotated[CollapseStatistic, Tag("statistic")],
            Discriminator(_collapse_form),
        ]
        | None
    ) = None
    stands: Annotated[Literal[True], BeforeValidator(flag)] | None = None
    stays: Levels | None = None
    may_fall: Levels | None = None
    p_stands: (
        Annotated[
            Probability,
            BeforeValidator(_bound),
            AlsoAccepts(({"type": "string", "pattern": f"^{BOUND}$"},), "a bound on P(stands): '>= 0.9'"),
        ]
        | None
    ) = None

    @property
    def statistical(self) -> bool:
        """Expectations about a sweep's statistics (``collapse: {mean...}``, ``p_stands``)."""
        return isinstance(self.collapse, CollapseStatistic) or self.p_stands is not None

    @property
    def per_run(self) -> bool:
        """Expectations about one run (a collapse level, ``stands``, ``stays``)."""
        return isinstance(self.collapse, CollapseLevel) or bool(self.stands) or self.stays is not None

    @model_validator(mode="after")
    def _consistent(self) -> Expect:
        if self.collapse is not None and self.stands:
            raise ValueError("a structure cannot both collapse and stand: give one of 'collapse' or 'stands'")
        # JSON Schema cannot compare two lists of ranges: the schema leaves this to the loader
        if self.stays and self.may_fall and set(self.stays) & set(self.may_fall):
            raise ValueError("a level cannot both stay and fall: 'stays' and 'may_fall' overlap")
        return self


def span(levels: Iterable[int]) -> str:
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

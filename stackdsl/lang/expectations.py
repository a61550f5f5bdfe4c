"""The ``expect`` section of a scenario: what must hold after one run (a collapse level, that
the structure stands, the levels that stay or may fall after an impact) or over a sweep's
samples (a collapse level's mean or quantile, P(stands)).

Source: stackdsl's own (docs/design.md, words).
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    PrivateAttr,
    Tag,
    WithJsonSchema,
    model_validator,
)

from .bounds import MAX_BRICKS, MAX_LEVELS, MAX_SIMULATED_TIME, StrictModel
from .errors import Location
from .grammar import (
    BOUND,
    COLLAPSE,
    COUNT_BOUND,
    LEVEL_NUMBER,
    LEVEL_RANGE,
    PLUS_MINUS,
    SPACE,
    TOLERANCE_NUMBER,
    WHOLE,
    AlsoAccepts,
    as_int,
    flag,
    given,
    json_pattern,
    whole,
)
from .schema_require import Requirement
from .spelling import spelled
from .units import Angle, Length, Time, angle, length, time, within

if TYPE_CHECKING:  # to mypy a float; to pydantic a time within a run's longest
    StandsUntil = float
    StillTilt = float
    StillSlip = float
else:
    StandsUntil = within(Time, time, 0.0, MAX_SIMULATED_TIME, "a time from 0 to 3600 s", ("", "a run lasts at most 3600 s"))
    StillTilt = within(Angle, angle, 0.0, 90.0, "an angle above 0 and at most 90 degrees", above=True)
    StillSlip = within(Length, length, 0.0, 1.0, "a length above 0 and at most 1 m", above=True)


_RUN_LEVEL = "a run collapses at a whole level"
_STATISTIC_HINT = "a fraction is for a sweep's statistics, such as collapse: {{mean: '{0}'}}"


def _whole_level(value: Any) -> Any:
    """A collapse level or its tolerance in ``{level, tolerance}``: whole, as :func:`whole`, a
    fraction refused with why."""
    if isinstance(value, float) and math.isfinite(value) and not value.is_integer():
        raise ValueError(
            f"expected a whole number, got {spelled(value)}: {_RUN_LEVEL}, so a level and its tolerance are whole "
            f"numbers; {_STATISTIC_HINT.format('7 ± 0.5')}"
        )
    return whole(value)


WHOLE_LEVEL = BeforeValidator(_whole_level)


class Still(StrictModel):
    """The structure keeps still through the run: no structure brick ever tilts more than
    ``tilt`` (degrees) from the orientation it was placed with, nor does the centre of its base
    slip more than ``slip`` (metres) on the ground, a shaken table's offset taken off
    (:class:`stackdsl.runtime.motion.PeakMotion`). A block that "does not rock" or "does not
    slide" on a shake table: the onset of motion, well below a collapse. Source: stackdsl's own."""

    tilt: Annotated[
        StillTilt | None,
        Field(description="the largest tilt any brick may reach during the run", examples=["0.2 deg"]),
    ] = None
    slip: Annotated[
        StillSlip | None,
        Field(description="the largest slip of any brick's base on the ground during the run", examples=["0.1 mm"]),
    ] = None

    @model_validator(mode="after")
    def _some(self) -> Still:
        if self.tilt is None and self.slip is None:
            raise ValueError("give the largest 'tilt', the largest 'slip' or both")
        return self

    def margin(self, tilt: float, slip: float) -> float:
        """The signed distance of a run's largest ``tilt`` (rad) and ``slip`` (m) to these bounds,
        as a share of each bound, the nearer one: ``min(1 - tilt / bound, 1 - slip / bound)``,
        positive while both keep within, negative past one; continuous in the motion.

        >>> Still(tilt=1.0).margin(math.radians(0.5), 0.0)
        0.5
        """
        shares = ([1 - tilt / math.radians(self.tilt)] if self.tilt is not None else []) + (
            [1 - slip / self.slip] if self.slip is not None else []
        )
        return min(shares)

    def text(self) -> str:
        """``"tilts at most 0.2 deg, slips at most 0.1 mm"``."""
        return ", ".join(
            ([f"tilts at most {self.tilt:g} deg"] if self.tilt is not None else [])
            + ([f"slips at most {self.slip * 1000:g} mm"] if self.slip is not None else [])
        )


class CollapseLevel(StrictModel):
    """Expected collapse level with a tolerance in levels."""

    level: Annotated[int, Field(ge=1, le=MAX_LEVELS), WHOLE_LEVEL]
    tolerance: Annotated[int, Field(ge=0, le=MAX_LEVELS), WHOLE_LEVEL] = 0


def digits_value(digits: str) -> int:
    """The whole number ``digits`` (a regular expression's group of digits) spells.

    Raises:
        ValueError: over 18 digits, said so (Python's own words for one of over 4300 digits
            named ``sys.set_int_max_str_digits``; a level, a count or a tolerance that long is
            out of every range anyway).

    >>> digits_value("0012"), digits_value("9" * 18) > 0
    (12, True)
    """
    if len(digits) > 18:
        raise ValueError(f"a whole number written with {len(digits)} digits is too large")
    return int(digits)


def _collapse(value: Any) -> Any:
    """``9``, ``"9±1"``, ``"9 +- 1"`` or ``{level: 9, tolerance: 1}``: whole numbers, since a run
    collapses at a whole level; a fraction (``"11±0.5"``, ``10.5``) is refused with the whole form
    that allows the same levels, when there is one."""
    number = as_int(value)
    if number is not None:
        return {"level": number}
    fraction = None
    if isinstance(value, float) and not (math.isfinite(value) and value >= 0):
        raise ValueError(f"expected a level such as 9, '9±1' or '9 +- 1', got {spelled(value)}")
    if isinstance(value, float):
        fraction = (value, 0.0)
    elif isinstance(value, str):
        match = re.fullmatch(COLLAPSE, value)
        if match:
            return {"level": digits_value(match[1]), "tolerance": digits_value(match[2] or "0")}
        decimal = re.fullmatch(PLUS_MINUS, value)
        if not decimal:
            raise ValueError(f"expected a level such as 9, '9±1' or '9 +- 1', got {spelled(value)}")
        fraction = (float(decimal[1]), float(decimal[2] or 0))
        if not all(map(math.isfinite, fraction)):  # '1e999 ± 1': beyond a double, no level
            raise ValueError(f"expected a level such as 9, '9±1' or '9 +- 1', got {spelled(value)} (not finite)")
    if fraction is not None:
        target, tolerance = fraction
        raise ValueError(
            f"expected a whole level with an optional whole tolerance, such as 9, '9±1' or '9 +- 1', got "
            f"{spelled(value)}: {_RUN_LEVEL}, so {_same_levels(value, target, tolerance)}"
            + (f"; {_STATISTIC_HINT.format(f'{target:g} ± {tolerance or 0.5:g}')}" if target >= 1 else "")
        )
    return value


def _same_levels(value: Any, target: float, tolerance: float, unit: str = "level") -> str:
    """What a fractional ``target ± tolerance`` allows of whole levels (or of bricks, ``unit``
    ``"brick"``, counted from 0), and the whole form that allows the same, if any.

    >>> _same_levels("11±0.5", 11, 0.5), _same_levels("10.5", 10.5, 0)
    ("'11±0.5' allows level 11 only: write 11", "'10.5' allows no whole level: write 10 or 11")
    >>> _same_levels("10.5±1", 10.5, 1)
    "'10.5±1' allows levels 10 to 11, which no whole 'N±T' gives: write '10±1' or '11±1'"
    >>> _same_levels("3±1.5", 3, 1.5, "brick")
    "'3±1.5' allows 2 to 4 bricks, as '3±1' does: write that"
    >>> _same_levels("0.5±0.5", 0.5, 0.5, "brick"), _same_levels("1.5±0.5", 1.5, 0.5)
    ("'0.5±0.5' allows 0 to 1 bricks, as '0±1' does: write that", "'1.5±0.5' allows levels 1 to 2, as '1±1' does: write that")
    """
    bricks = unit == "brick"
    low, high = max(math.ceil(target - tolerance - 1e-9), 0 if bricks else 1), math.floor(target + tolerance + 1e-9)

    def named(first: int, last: int) -> str:
        if bricks:
            return f"{first} bricks" if first == last else f"{first} to {last} bricks"
        return f"level {first}" if first == last else f"levels {first} to {last}"

    said = spelled(value)
    least = 0 if bricks else 1
    if low > high:
        nearest = " or ".join(str(n) for n in sorted({max(math.floor(target), least), max(math.ceil(target), least)}))
        return f"{said} allows no whole {'count' if bricks else 'level'}: write {nearest}"
    if (low + high) % 2 and low == least:  # 'N±T' counts from the least there is: '0±1' is 0 to 1 bricks
        return f"{said} allows {named(low, high)}, as '{low}±{high - low}' does: write that"
    if (low + high) % 2:
        return f"{said} allows {named(low, high)}, which no whole 'N±T' gives: write '{low}±1' or '{high}±1'"
    middle, half = (low + high) // 2, (high - low) // 2
    if half == 0:
        return f"{said} allows {named(middle, middle)} only: write {middle}"
    return f"{said} allows {named(low, high)}, as '{middle}±{half}' does: write that"


SELECTOR = "[A-Za-z_][A-Za-z0-9_.-]{0,40}"
"""A brick id or the start of ids: ``L05.2`` (that brick), ``L05`` (``L05.1``, ``L05.2``...),
``left.`` (every brick of part ``left``)."""


def _levels(value: Any) -> Any:
    """Levels: ``5``, ``"1-11"``, bricks: ``"L05.2"``, ``"L05"``, ``"left."``, or a list of those;
    returned as a tuple, the levels sorted first, then the bricks in the order given."""
    items = value if isinstance(value, list) else [value]
    levels: set[int] = set()
    bricks: list[str] = []
    for item in items:
        number = as_int(item)
        match = re.fullmatch(LEVEL_RANGE, item) if isinstance(item, str) else None
        if number is not None:
            first = last = number
        elif match:
            first, last = digits_value(match[1]), digits_value(match[2] or match[1])
        elif isinstance(item, str) and re.fullmatch(f"{SPACE}{SELECTOR}{SPACE}", item):
            if item.strip() not in bricks:
                bricks.append(item.strip())
            continue
        else:
            first, last = 0, -1  # refused below
        if 1 <= last < first <= MAX_LEVELS:
            raise ValueError(f"the range {spelled(item)} runs backwards: write it from the lower level, '{last}-{first}'")
        if not 1 <= first <= last <= MAX_LEVELS:
            raise ValueError(
                f"expected levels from 1 to {MAX_LEVELS} such as 5, '1-11', bricks such as 'L05.2', 'L05' or 'left.', "
                f"or a list of those, got {spelled(item)}"
            )
        levels.update(range(first, last + 1))
    return (*sorted(levels), *bricks)


def selects(selector: str, brick: str) -> bool:
    """Does ``selector`` (a brick id or the start of ids, :data:`SELECTOR`) name ``brick``?

    >>> [selects("L05", b) for b in ("L05.1", "L050.1", "L05")], selects("left.", "left.L01.1")
    ([True, False, True], True)
    """
    return brick == selector or brick.startswith(selector if selector.endswith(".") else selector + ".")


def closest(selector: str, ids: Sequence[str]) -> str:
    """``; did you mean 'L01'?``: the id, or start of ids up to a '.', of ``ids`` nearest to
    ``selector`` (a level written without its zeros, a part's prefix left out), or nothing.
    Source: stackdsl's own.

    >>> closest("L1", ["L01.1", "L12.1"]), closest("L02.1", ["west.L02.1"])
    ("; did you mean 'L01'?", "; did you mean 'west.L02.1'?")
    """
    near = nearest(selector, ids)
    return f"; did you mean {near!r}?" if near is not None else ""


def nearest(selector: str, ids: Sequence[str]) -> str | None:
    """The id, or start of ids up to a '.', of ``ids`` nearest to ``selector``, or None
    (:func:`closest`). Source: stackdsl's own.

    >>> nearest("L5", ["L05.1", "L05.2"]), nearest("X", ["L05.1"])
    ('L05', None)
    """
    starts = list(dict.fromkeys(i.rsplit(".", k)[0] for i in ids for k in range(i.count(".") + 1)))
    tails: dict[str, str] = {}
    for start in starts:  # each start, and each without its part's name ('L01.1' for 'left.L01.1'), the first kept
        tails.setdefault(start, start)
        if "." in start:
            tails.setdefault(start.split(".", 1)[1], start)

    def numbers(text: str) -> str:
        return re.sub(r"\d+", lambda m: m.group().lstrip("0") or "0", text)  # str(int(...)), of any length

    same = [t for t in tails if numbers(t) == numbers(selector)]
    close = same or difflib.get_close_matches(selector, list(tails), n=1, cutoff=0.6)
    return tails[close[0]] if close else None


def levels_of(selection: Iterable[int | str]) -> tuple[int, ...]:
    """The levels of a ``stays``/``moved``/``may_fall`` selection."""
    return tuple(s for s in selection if isinstance(s, int))


def bricks_of(selection: Iterable[int | str]) -> tuple[str, ...]:
    """The brick ids and id starts of a ``stays``/``moved``/``may_fall`` selection."""
    return tuple(s for s in selection if isinstance(s, str))


_LEVEL_ITEM = {
    "anyOf": [
        {"type": "integer", "minimum": 1, "maximum": MAX_LEVELS},
        # a range's end below its start ("5-3") is refused by the loader only
        {"type": "string", "pattern": json_pattern(LEVEL_RANGE, LEVEL_NUMBER, LEVEL_NUMBER)},
    ]
}
_LEVEL_ITEM = {"anyOf": [*_LEVEL_ITEM["anyOf"], {"type": "string", "pattern": f"^{SPACE}{SELECTOR}{SPACE}$"}]}
Levels = Annotated[
    tuple[int | str, ...],
    BeforeValidator(_levels),
    WithJsonSchema(
        {
            "anyOf": [_LEVEL_ITEM, {"type": "array", "items": _LEVEL_ITEM}],
            "description": "levels (5, '1-11') or bricks (an id 'L05.2', or the start of ids: 'L05', 'left.'), or a list of those",
            "examples": ["1-12", ["L05", "L06.1"]],
        }
    ),
]


#: What ``toppled`` takes, said when it gets something else.
_TOPPLED_FORMS = "20, '20±1', a bound such as '>= 1', or 'all'"


def _toppled(value: Any) -> Any:
    """``20``, ``"all"``, ``"20±1"``, a bound ``">= 1"`` (also ``<=``, ``>``, ``<``: as
    ``p_stands`` writes one, of whole bricks) or ``{count: 20, tolerance: 1}``. The first four
    are checked here, so that an error names ``toppled`` as written, not a ``count`` it does not
    have."""
    number = as_int(value)
    if number is not None:
        _bricks(number, value)
        return {"count": number}
    if value == "all":
        return {"count": "all"}
    if isinstance(value, str) and (bound := re.fullmatch(BOUND, value)):
        op, count = bound[1], float(bound[2])
        if not math.isfinite(count):  # '>= 1e999': beyond a double, no count
            raise ValueError(f"expected a number of bricks such as {_TOPPLED_FORMS}, got {spelled(value)} (not finite)")
        if not count.is_integer():  # '>= 1.5' allows what '>= 2' does
            same = (math.ceil if op in (">=", "<") else math.floor)(count)
            raise ValueError(
                f"expected a bound on a whole number of bricks such as '>= 1', got {spelled(value)}: bricks are counted "
                f"whole, so it allows what '{op} {same}' does: write that"
            )
        _bricks(int(count), value)
        return {"op": op, "count": int(count)}
    if isinstance(value, str):
        match = re.fullmatch(COLLAPSE, value)
        decimal = re.fullmatch(PLUS_MINUS, value)
        if not match and decimal:
            target, tolerance = float(decimal[1]), float(decimal[2] or 0)
            if not (math.isfinite(target) and math.isfinite(tolerance)):  # '1e999': beyond a double, no count
                raise ValueError(f"expected a number of bricks such as 20, '20±1' or 'all', got {spelled(value)} (not finite)")
            raise ValueError(
                f"expected a whole number of bricks such as 20, '20±1' or 'all', got {spelled(value)}: bricks are "
                f"counted whole, so {_same_levels(value, target, tolerance, 'brick')}"
            )
        if not match:
            hint = "; did you mean 'all'?" if value.strip().lower() == "all" else ""
            raise ValueError(f"expected a number of bricks such as {_TOPPLED_FORMS}, got {spelled(value)}{hint}")
        _bricks(digits_value(match[1]), value)
        _bricks(digits_value(match[2] or "0"), value)
        return {"count": digits_value(match[1]), "tolerance": digits_value(match[2] or "0")}
    if not isinstance(value, dict):  # true, 19.5: a mapping's fields would be the wrong thing to name
        raise ValueError(f"expected a whole number of bricks such as 20, '20±1' or 'all', got {spelled(value)}")
    return value


def _bricks(number: int, value: Any) -> None:
    """Refuse a number of toppled bricks (or a tolerance of one) out of the range :class:`Toppled` allows."""
    if not 0 <= number <= MAX_BRICKS:
        raise ValueError(f"expected a number of bricks from 0 to {MAX_BRICKS} or 'all', got {spelled(value)}")


class Toppled(StrictModel):
    """How many structure bricks toppled: ``count`` (or ``"all"``) within ``tolerance``, or
    (``op`` ``>=``, ``<=``, ``>``, ``<``) at least, at most, more than or fewer than ``count``; a
    bound no count meets (``'< 0'``, ``'> 5000'``) is refused, as ``p_stands``' is."""

    count: Annotated[int, Field(ge=0, le=MAX_BRICKS), WHOLE] | Literal["all"]
    tolerance: Annotated[int, Field(ge=0, le=MAX_BRICKS), WHOLE] = 0
    op: Literal["±", ">=", "<=", ">", "<"] = "±"

    @model_validator(mode="after")
    def _reachable(self) -> Toppled:
        if self.op == "±":
            return self
        if self.count == "all":
            raise ValueError(f"a bound is a number of bricks, not 'all': write 'all' alone, or '{self.op} 20'")
        if self.tolerance:
            raise ValueError(f"a tolerance goes with '±' ('{self.count} ± {self.tolerance}'), not with '{self.op}'")
        if (self.op == ">" and self.count >= MAX_BRICKS) or (self.op == "<" and self.count <= 0):
            end = f"at most {MAX_BRICKS}, the most bricks a scene has" if self.op == ">" else "at least 0"
            instead = "'all' for every brick toppled" if self.op == ">" else "'<= 0' for no brick toppled"
            raise ValueError(f"'{self.op} {self.count}' can never hold: a number of bricks is {end}; write {instead}")
        return self

    def allows(self, total: int) -> tuple[int, int]:
        """(the fewest, the most) toppled bricks this allows of a scene of ``total`` bricks (those
        left in it): ``all`` is ``total``; a bound reaches 0 or ``total`` on its open side.

        >>> [Toppled(count=c, tolerance=t, op=o).allows(10) for c, t, o in ((3, 1, "±"), ("all", 0, "±"), (2, 0, ">"), (2, 0, "<"))]
        [(2, 4), (10, 10), (3, 10), (0, 1)]
        """
        if self.count == "all" or self.op == "±":
            target = total if self.count == "all" else self.count
            return max(0, target - self.tolerance), target + self.tolerance
        return {
            ">=": (self.count, total),
            ">": (self.count + 1, total),
            "<=": (0, self.count),
            "<": (0, self.count - 1),
        }[self.op]

    def text(self) -> str:
        """As a file writes it: ``"20"``, ``"20±1"``, ``"all"``, ``">= 1"``."""
        if self.op != "±":
            return f"{self.op} {self.count}"
        return f"{self.count}" + (f"±{self.tolerance}" if self.tolerance else "")


def _plus_minus(value: Any) -> Any:
    """``"7 ± 0.5"`` (or ``+-``, ``+/-``) -> ``{"target": 7.0, "tolerance": 0.5}``; a level
    alone, ``7`` or ``"7"``, is within ± 0, as a run's ``collapse: 7`` is."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
        return {"target": value, "tolerance": 0.0}
    match = re.fullmatch(PLUS_MINUS, value) if isinstance(value, str) else None
    if match:
        target, tolerance = float(match[1]), float(match[2] or 0)
        if not (math.isfinite(target) and math.isfinite(tolerance)):  # '1e999', 5000 digits: beyond a double, no level
            raise ValueError(f"expected a level such as 7 or '7 ± 0.5', got {spelled(value, 60)} (not finite)")
        return {"target": target, "tolerance": tolerance}
    if isinstance(value, dict):
        return value
    raise ValueError(f"expected a level, alone (± 0) or with a tolerance, such as 7 or '7 ± 0.5', got {spelled(value)}")


class Within(StrictModel):
    """A number of levels within a tolerance: written ``"7 ± 0.5"``, or ``7`` for ± 0."""

    target: Annotated[float, Field(ge=0, le=MAX_LEVELS)]
    tolerance: Annotated[float, Field(ge=0, le=MAX_LEVELS)] = 0.0

    def levels(self) -> tuple[int, int] | None:
        """The first and last whole collapse level (1 or more) within the tolerance, or None."""
        low = max(math.ceil(self.target - self.tolerance - 1e-9), 1)
        high = math.floor(self.target + self.tolerance + 1e-9)
        return (low, high) if low <= high else None

    def text(self) -> str:
        """As a file writes it: ``"7 ± 0.5"``."""
        return f"{self.target:g} ± {self.tolerance:g}"


PlusMinus = Annotated[
    Within,
    BeforeValidator(_plus_minus),
    AlsoAccepts(
        ({"type": "number", "minimum": 0, "maximum": MAX_LEVELS}, {"type": "string", "pattern": f"^{PLUS_MINUS}$"}),
        "a level with a tolerance, '7 ± 0.5', or alone for ± 0: 7",
    ),
]


def _whole_quantile(level: Within) -> Within:
    """A quantile's ``level``: one that holds a whole level, since a quantile of collapse levels
    is one sample's level (else the expectation could never pass)."""
    if level.levels() is None:
        raise ValueError(
            f"a quantile of collapse levels is one sample's level, a whole number from 1, and '{level.text()}' holds "
            f"none, so it could never pass: write a whole level such as {max(round(level.target), 1)}, or a "
            "tolerance that reaches one"
        )
    return level


def _reachable_mean(mean: Within) -> Within:
    """A sweep's ``mean``: within ± 0 only of a whole level (an interval of no width comes only from
    samples that all collapse at one level), and reaching level 1 at least."""
    if mean.tolerance == 0 and mean.levels() is None:
        raise ValueError(
            f"a mean within ± 0 passes only when every sample that collapses does so at that level, a whole number "
            f"from 1, so '{mean.text()}' could never pass: write a whole level such as {max(round(mean.target), 1)}, "
            f"or the tolerance the mean may be off by, such as '{mean.target:g} ± 0.5'"
        )
    if mean.target + mean.tolerance < 1:
        raise ValueError(f"collapse levels start at 1, so a mean of '{mean.text()}' could never pass: give a level from 1")
    return mean


class Quantile(StrictModel):
    """The ``q`` quantile of the collapse level (0 < q < 1; 0.5: the median) within ``level``."""

    q: Annotated[float, Field(gt=0, lt=1)]
    level: Annotated[PlusMinus, AfterValidator(_whole_quantile)]


class CollapseStatistic(StrictModel):
    """A sweep's collapse level as a statistic: its ``mean`` over the samples that collapsed, or
    a ``quantile`` (standing samples count as above every level), each within a tolerance (a
    level alone: ± 0)."""

    model_config = ConfigDict(json_schema_extra={"oneOf": [given("mean"), given("quantile")]})

    mean: Annotated[PlusMinus, AfterValidator(_reachable_mean)] | None = None
    quantile: Quantile | None = None

    @model_validator(mode="after")
    def _one(self) -> CollapseStatistic:
        if (self.mean is None) == (self.quantile is None):
            raise ValueError("give one of 'mean' ('7 ± 0.5') or 'quantile' ({q: 0.5, level: '7 ± 1'})")
        return self

    @property
    def region(self) -> Within:
        """The tolerance of the statistic given."""
        chosen = self.mean if self.mean is not None else self.quantile.level if self.quantile is not None else None
        assert chosen is not None
        return chosen


def _bound(value: Any) -> Any:
    """``">= 0.9"`` -> ``{"op": ">=", "bound": 0.9}``; ``"0.67 ± 0.1"`` -> ``{"op": "±",
    "bound": 0.67, "tolerance": 0.1}``."""
    if isinstance(value, str):
        match = re.fullmatch(BOUND, value)
        if match:
            return {"op": match[1], "bound": float(match[2])}
        within = re.fullmatch(PLUS_MINUS, value)
        if within and within[2] is not None:
            if float(within[1]) > 1 or float(within[2]) > 1:
                raise ValueError(f"{spelled(value)}: a probability and its tolerance are from 0 to 1")
            return {"op": "±", "bound": float(within[1]), "tolerance": float(within[2])}
        hint = f"; for P(stands) of about {within[1]}, give a tolerance: '{within[1]} ± 0.05'" if within else ""
        raise ValueError(
            f"expected a comparison with a probability such as '>= 0.9', or a probability with a tolerance such as "
            f"'0.67 ± 0.1', got {spelled(value)}{hint}"
        )
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        raise ValueError(
            f"expected a comparison with a probability, got the bare number {value!r}: "
            f"write '>= {value}' (P(stands) at least {value}), '<= {value}', or '{value} ± 0.05'"
        )
    return value


class Probability(StrictModel):
    """A bound on a probability: written ``">= 0.9"`` (also ``<=``, ``>``, ``<``), or a
    probability within a tolerance, ``"0.67 ± 0.1"`` (op ``±``: from 0.57 to 0.77, ends
    included); one no probability meets (``'> 1'``, ``'< 0'``, ``'1.2 ± 0.1'``) is refused."""

    op: Literal[">=", "<=", ">", "<", "±"]
    bound: Annotated[float, Field(ge=0, le=1)]
    tolerance: Annotated[float, Field(ge=0, le=1)] = 0.0

    @model_validator(mode="after")
    def _reachable(self) -> Probability:
        if self.op != "±" and self.tolerance:
            raise ValueError(f"a tolerance goes with '±' ('{self.bound:g} ± {self.tolerance:g}'), not with '{self.op}'")
        if (self.op == ">" and self.bound >= 1) or (self.op == "<" and self.bound <= 0):
            end = "at most 1" if self.op == ">" else "at least 0"
            raise ValueError(
                f"'{self.op} {self.bound:g}' can never hold: a probability is {end}; "
                f"write '{'>=' if self.op == '>' else '<='} {self.bound:g}' for {'every' if self.op == '>' else 'no'} sample standing"
            )
        return self

    def text(self) -> str:
        """As a file writes it: ``">= 0.9"``, ``"0.67 ± 0.1"``."""
        return f"{self.bound:g} ± {self.tolerance:g}" if self.op == "±" else f"{self.op} {self.bound:g}"

    def ends(self) -> tuple[tuple[float, bool] | None, tuple[float, bool] | None]:
        """(the least probability it allows, whether that end is open) and the same of the
        greatest; None for no end short of 0 or 1 (``'>= 0.9'`` has no upper one)."""
        if self.op == "±":
            return (max(0.0, self.bound - self.tolerance), False), (min(1.0, self.bound + self.tolerance), False)
        if self.op in (">=", ">"):
            return (self.bound, self.op == ">"), None
        return None, (self.bound, self.op == "<")


PStands = Annotated[
    Probability,
    BeforeValidator(_bound),
    AlsoAccepts(
        ({"type": "string", "pattern": f"^{BOUND}$"}, {"type": "string", "pattern": f"^{PLUS_MINUS}$"}),
        "a bound on P(stands), '>= 0.9', or P(stands) with a tolerance, '0.67 ± 0.1'",
    ),
]
"""``p_stands``: a bound on P(stands), written ``'>= 0.9'``, or P(stands) within a tolerance,
``'0.67 ± 0.1'``, in a sweep's expectations and a cell's."""


def _collapse_form(value: Any) -> str:
    """Which form ``expect.collapse`` is written in: a sweep's ``statistic`` or a run's ``level``."""
    if isinstance(value, CollapseStatistic) or (isinstance(value, dict) and {"mean", "quantile"} & set(value)):
        return "statistic"
    return "level"


class CellExpect(StrictModel):
    """A sweep's statistical expectations for the grid cells where ``where`` holds: a condition
    (:mod:`stackdsl.lang.expressions`) on the grid's fields by their keys, in SI
    (``"actions.0.shake.amplitude < 20 mm"``). Source: stackdsl's own."""

    model_config = ConfigDict(json_schema_extra={"anyOf": [given("collapse"), given("p_stands")]})

    where: Annotated[
        Requirement,
        Field(
            description="the cells these expectations are for: a condition on the grid's fields, named by their keys",
            examples=["actions.0.shake.amplitude <= 18 mm"],
        ),
    ]
    collapse: CollapseStatistic | None = Field(
        default=None,
        description="the collapse level's mean or quantile in those cells",
        examples=[{"mean": "7 ± 0.5"}],
    )
    p_stands: PStands | None = Field(
        default=None, description="a bound on P(stands) in those cells", examples=[">= 0.9", "<= 0.1"]
    )

    @model_validator(mode="after")
    def _something(self) -> CellExpect:
        if self.collapse is None and self.p_stands is None:
            raise ValueError("give what these cells must show: p_stands ('>= 0.9') or collapse ({mean: '7 ± 0.5'})")
        return self


def _stands(value: Any) -> Any:
    """``stands: true`` only: ``false`` expects nothing a run can measure but a fall, which
    ``collapse`` says."""
    if flag(value) is False:
        raise ValueError(
            "'stands: false' is no expectation: to expect a fall give 'collapse: N' (the level), or leave 'stands' out"
        )
    return value


class Expect(StrictModel):
    """What must hold: a ``collapse`` level, or that the structure ``stands``; after an
    impact or an action, the levels or bricks that ``stay`` in place, that ``moved`` and that
    ``may_fall``, and how many bricks ``toppled``. A sweep's
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
    stands: Annotated[Literal[True], BeforeValidator(_stands)] | None = None
    stands_until: Annotated[
        StandsUntil | None,
        Field(
            description="a time the structure must stand until: no collapse before it (a Jenga tower that stands "
            "through its first pulls, whatever a later one does)",
            examples=["35 s"],
        ),
    ] = None
    stays: Levels | None = None
    may_fall: Levels | None = None
    moved: Annotated[
        Levels | None,
        Field(
            description="levels or bricks each of whose bricks must end farther than the collapse threshold from where "
            "it was placed",
            examples=[["L01"], "3-4"],
        ),
    ] = None
    toppled: Annotated[
        Annotated[
            Toppled,
            BeforeValidator(_toppled),
            AlsoAccepts(
                (
                    {"type": "integer", "minimum": 0, "maximum": 5000},
                    {"type": "string", "pattern": f"^(?:all|{COLLAPSE}|{COUNT_BOUND})$"},
                ),
                "how many bricks topple: 20, '20±1', a bound '>= 1' or 'all'",
            ),
        ]
        | None,
        Field(
            description="how many structure bricks end tilted past their tipping angle (a domino fallen over): a "
            "number, 'N±T', a bound ('>= 1', '<= 3', '> 0', '< 5') or 'all'",
            examples=[30, "all", "20 +- 1", ">= 1"],
        ),
    ] = None
    still: Annotated[
        Still | None,
        Field(
            description="the structure keeps still through the run: no brick tilts more than 'tilt' nor slips more than "
            "'slip' on the ground (a shaken table's offset taken off) at any step; the onset of rocking or sliding",
            examples=[{"tilt": "0.2 deg"}, {"slip": "0.1 mm"}],
        ),
    ] = None
    p_stands: PStands | None = None

    cells: Annotated[
        list[CellExpect] | None,
        Field(
            min_length=1,
            max_length=50,
            description="a sweep's statistical expectations for some grid cells only, each list item for the cells "
            "where its condition holds: stands below a threshold, falls above it",
            examples=[
                [
                    {"where": "actions.0.shake.amplitude <= 18 mm", "p_stands": ">= 0.9"},
                    {"where": "actions.0.shake.amplitude >= 26 mm", "p_stands": "<= 0.1"},
                ]
            ],
        ),
    ] = None

    #: Where each expectation was written (:meth:`at`); set when a file is read.
    _at: dict[str, Location] = PrivateAttr(default_factory=dict)

    def at(self, name: str) -> Location | None:
        """Where the expectation ``name`` (a field: ``"collapse"``, ``"cells[0].p_stands"``) was
        written, at its key: None for expectations built in Python, not read from a file."""
        return self._at.get(name)

    def __eq__(self, other: object) -> bool:
        """The same expectations: where they were written (:meth:`at`) is not compared, as a
        :class:`stackdsl.lang.schema.Scenario`'s source is not."""
        if not isinstance(other, Expect):
            return NotImplemented
        return self.__dict__ == other.__dict__

    __hash__ = StrictModel.__hash__

    def located(self, at: dict[str, Location]) -> Expect:
        """These expectations, knowing where each was written (``at``: name -> location, as
        :meth:`stackdsl.lang.errors.SourceMap.locations` gives them)."""
        located = self.model_copy()
        located._at = dict(at)
        return located

    @property
    def statistical(self) -> bool:
        """Expectations about a sweep's statistics (``collapse: {mean...}``, ``p_stands``, ``cells``)."""
        return isinstance(self.collapse, CollapseStatistic) or self.p_stands is not None or self.cells is not None

    @property
    def per_run(self) -> bool:
        """Expectations about one run (a collapse level, ``stands``, ``stays``)."""
        return (
            isinstance(self.collapse, CollapseLevel)
            or bool(self.stands)
            or self.stands_until is not None
            or self.stays is not None
            or self.moved is not None
            or self.toppled is not None
            or self.still is not None
        )

    @property
    def judged_at(self) -> Literal["collapse", "end"]:
        """The moment of a run these expectations judge, which a picture of it shows by default:
        ``"end"`` when they judge final positions alone (``toppled``, ``stays``, ``moved``: a
        domino row's picture is the row fallen, not its first domino tipping), else
        ``"collapse"`` (a collapse level, ``stands``, ``stands_until``, or nothing: the collapse
        when there is one, else the end). Source: stackdsl's own.

        >>> Expect.model_validate({"toppled": "all"}).judged_at, Expect.model_validate({"collapse": 9, "stays": "1-5"}).judged_at
        ('end', 'collapse')
        """
        if isinstance(self.collapse, CollapseLevel) or self.stands or self.stands_until is not None:
            return "collapse"
        if self.toppled is not None or self.stays is not None or self.moved is not None:
            return "end"
        return "collapse"

    @model_validator(mode="after")
    def _consistent(self) -> Expect:
        if self.collapse is not None and self.stands:
            raise ValueError("a structure cannot both collapse and stand: give one of 'collapse' or 'stands'")
        if self.stands and self.stands_until is not None:
            raise ValueError("'stands' is until the end already: give 'stands_until' only when it may fall after that time")
        # JSON Schema cannot compare two lists of ranges: the schema leaves this to the loader
        if self.stays and self.may_fall and set(self.stays) & set(self.may_fall):
            raise ValueError("a level cannot both stay and fall: 'stays' and 'may_fall' overlap")
        if self.stays and self.moved and set(self.stays) & set(self.moved):
            raise ValueError("a level or brick cannot both stay and move: 'stays' and 'moved' overlap")
        if self.stands and self.moved:
            raise ValueError(
                "a brick that ends moved is a collapse, so the structure does not stand: give 'stands' or 'moved', or "
                "'stands_until' for a time it must stand until"
            )
        if self.stands and self.toppled is not None:
            t = self.toppled
            if t.count == "all" or t.allows(MAX_BRICKS)[0] > 0:
                raise ValueError(
                    "a toppled brick has moved, so the structure does not stand: give 'stands' or 'toppled', or "
                    "'stays' for the bricks that must not move"
                )
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

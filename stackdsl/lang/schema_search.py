"""The scenario language's searches: where the verdict changes along one field (``threshold``),
or draws that break the file's expectation (``counterexample``), as a pydantic model of
:mod:`stackdsl.lang.schema`. ``stackdsl search FILE`` runs it (:mod:`stackdsl.batch.search`);
``run``, ``check`` and ``sweep`` leave it aside.

Source: stackdsl's own (docs/searches.md).
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BeforeValidator, Field, model_validator

from .bounds import StrictModel
from .grammar import WHOLE, Key
from .units import in_unit, split_quantity

_ENDS = "both ends of between and the tolerance"

#: Runs a search may take at most.
MAX_SEARCH_RUNS = 10_000


class Threshold(StrictModel):
    """The value of one field (``field``, named as a sweep's grid key names it) where the verdict
    changes between the two ends of ``between`` (numbers or quantities of the field's kind, the
    lower first), found to within ``tolerance`` (the same kind; default a hundredth of the
    interval) in at most ``runs`` runs, both ends included."""

    field: Key
    between: Annotated[list[Any], Field(min_length=2, max_length=2)]
    tolerance: Any = None
    runs: Annotated[int, Field(ge=3, le=MAX_SEARCH_RUNS), WHOLE] = 40

    @property
    def unit(self) -> str:
        """The unit ``between`` is written in (``""``: bare numbers)."""
        return split_quantity(self.between[0])[1]

    @property
    def ends(self) -> tuple[float, float]:
        """``between`` as numbers of :attr:`unit`."""
        return in_unit(self.between[0], self.unit, of=_ENDS), in_unit(self.between[1], self.unit, of=_ENDS)

    @property
    def step(self) -> float:
        """``tolerance`` as a number of :attr:`unit`."""
        low, high = self.ends
        return (high - low) / 100 if self.tolerance is None else in_unit(self.tolerance, self.unit, of=_ENDS)

    @model_validator(mode="after")
    def _an_interval(self) -> Threshold:
        try:
            low, high = self.ends
        except ValueError as exc:
            raise ValueError(f"between: {exc}") from None
        if not low < high:
            raise ValueError(
                f"between: the lower end first, and below the upper: {self.between[0]} is not below {self.between[1]}"
            )
        try:
            step = self.step
        except ValueError as exc:
            raise ValueError(f"tolerance: {exc} (it is of the kind of between's {self.between[0]})") from None
        if not 0 < step < high - low:
            raise ValueError(f"tolerance: above 0 and below the interval's width, {high - low:g} {self.unit}".rstrip())
        return self


class Counterexample(StrictModel):
    """Draws of the file's distributions (those drawn once a sample) that break its expectation
    (a collapse where it expects the structure to stand, a stand where it expects a collapse),
    searched in at most ``runs`` runs minimising the signed margin; the first ``find`` found are
    each shrunk towards the distributions' centres in at most ``shrink`` runs more."""

    runs: Annotated[int, Field(ge=1, le=MAX_SEARCH_RUNS), WHOLE] = 200
    find: Annotated[int, Field(ge=1, le=100), WHOLE] = 1
    shrink: Annotated[int, Field(ge=0, le=1000), WHOLE] = 40


class Search(StrictModel):
    """One search: ``threshold`` or ``counterexample`` (docs/searches.md)."""

    threshold: Threshold | None = None
    counterexample: Counterexample | None = None

    @model_validator(mode="after")
    def _one(self) -> Search:
        if (self.threshold is None) == (self.counterexample is None):
            raise ValueError("give one of threshold: {field, between, tolerance} or counterexample: {runs}")
        return self


def _given(value: Any) -> Any:
    """An empty ``search:`` block is refused, not read as no search."""
    if value is None:
        raise ValueError("an empty search block: give threshold: {field, between} or counterexample: {runs}")
    return value


def _no_null(schema: dict[str, Any]) -> None:
    schema["anyOf"] = [s for s in schema.get("anyOf", []) if s != {"type": "null"}]
    schema.pop("default", None)


#: The scenario's ``search`` field: a search, or none when the key is left out.
SearchField = Annotated[Search | None, BeforeValidator(_given), Field(json_schema_extra=_no_null)]

"""The scenario language's sweeps: many runs of one scenario, its random fields drawn per
sample over a grid of field values, as a pydantic model of :mod:`stackdsl.lang.schema`.

Source: stackdsl's own (docs/design.md, words).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Annotated, Any

from pydantic import AfterValidator, BeforeValidator, Field, model_validator

from .bounds import StrictModel
from .grammar import WHOLE, Key

MAX_SAMPLES = 100_000
MAX_CELLS = 1000
MAX_SWEEP_RUNS = 200_000


def grid_name(key: str) -> str:
    """A grid key as a field path with dots, the way a condition names it: ``actions[0].shake.amplitude``
    and ``actions.0.shake.amplitude`` are both ``actions.0.shake.amplitude``."""
    return re.sub(r"\[\s*(\d+)\s*\]", r".\1", key.strip())


#: The checks a grid key must pass, each giving why the key names no field of the scene (one
#: line) or None. The loader's own (:func:`stackdsl.lang.sampling.grid_key_problem`) is added by
#: :mod:`stackdsl.lang.sampling` as it loads: it walks the whole scenario's models, which import
#: this module, so it cannot be imported here (:mod:`stackdsl.lang.models`, the builder's
#: module, imports it). Without it the Python builder took ``grid: {L01.1: [...]}`` and wrote a
#: file the loader refused.
GRID_KEY_CHECKS: list[Callable[[str], str | None]] = []


def _names_a_field(key: str) -> str:
    """A grid key must name a field of the scene, as the loader requires (:data:`GRID_KEY_CHECKS`).

    Raises:
        ValueError: the first check's reason, which pydantic reports at the key.
    """
    for check in GRID_KEY_CHECKS:
        problem = check(key)
        if problem:
            raise ValueError(problem)
    return key


#: A grid key: a field path of the scene.
GridKey = Annotated[Key, AfterValidator(_names_a_field)]


class Sweep(StrictModel):
    """Many runs of one scenario: ``samples`` draws of its random fields (sample k seeded by the
    k-th child of the scenario's seed), for each cell of ``grid``: field paths (``timing.placement_error``)
    each with a list of values, run as their product; every cell's sample k has the same seed."""

    samples: Annotated[int, Field(ge=1, le=MAX_SAMPLES), WHOLE] = 1
    grid: Annotated[dict[GridKey, Annotated[list[Any], Field(min_length=1, max_length=100)]], Field(max_length=4)] = {}

    @property
    def cells(self) -> int:
        """How many parameter combinations the grid makes (1 without a grid)."""
        count = 1
        for values in self.grid.values():
            count *= len(values)
        return count

    @model_validator(mode="after")
    def _bounded(self) -> Sweep:
        if self.cells > MAX_CELLS:
            raise ValueError(f"the grid makes {self.cells} cells; at most {MAX_CELLS}")
        if self.cells * self.samples > MAX_SWEEP_RUNS:
            raise ValueError(
                f"{self.cells} cells x {self.samples} samples is {self.cells * self.samples} runs; at most {MAX_SWEEP_RUNS}"
            )
        return self


def _given(value: Any) -> Any:
    """An empty ``sweep:`` block is refused, not read as no sweep (it was, silently)."""
    if value is None:
        raise ValueError("an empty sweep block: give {samples: N} (and a grid), or leave the key out for one run")
    return value


def _no_null(schema: dict[str, Any]) -> None:
    """The schema refuses an empty sweep block too."""
    schema["anyOf"] = [s for s in schema.get("anyOf", []) if s != {"type": "null"}]
    schema.pop("default", None)


#: The scenario's ``sweep`` field: a sweep, or none when the key is left out.
SweepField = Annotated[Sweep | None, BeforeValidator(_given), Field(json_schema_extra=_no_null)]

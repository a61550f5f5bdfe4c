"""The scenario language's impacts: what is thrown, at what, and when ("14 s" or "after
level 13"), as pydantic models of :mod:`stackdsl.lang.schema`.

Source: stackdsl's own (docs/design.md, words).
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import AfterValidator, BeforeValidator, ConfigDict, Field, model_validator

from .bounds import MAX_LEVELS, MIN_DIRECTION, Component, ImpactSpeed, StrictModel, Vector3
from .grammar import AFTER_LEVEL, LEVEL_NUMBER, WHOLE, AlsoAccepts, BodyId, absent, given, json_pattern
from .spelling import spelled
from .units import Length, length, quantity_pattern, time, within


class AfterLevel(StrictModel):
    """The moment one interval after the last brick of ``level`` was placed."""

    one_value = True  # a grid may give it whole

    after_level: Annotated[int, Field(ge=1, le=MAX_LEVELS), WHOLE]


def _when(value: Any) -> Any:
    """``"after level 13"`` -> :class:`AfterLevel`; anything else must be a time >= 0."""
    if isinstance(value, (AfterLevel, dict)):
        return value
    if isinstance(value, str):
        match = re.fullmatch(AFTER_LEVEL, value)
        if match:
            if not 1 <= int(match[1]) <= MAX_LEVELS:
                raise ValueError(f"expected a level from 1 to {MAX_LEVELS}, got {spelled(value)}")
            return AfterLevel(after_level=int(match[1]))
    try:
        seconds = time(value)
    except ValueError:
        raise ValueError(f"expected a time such as '14 s' or 'after level N', got {spelled(value)}") from None
    if seconds < 0:
        raise ValueError(f"expected a time >= 0, got {spelled(value)}")
    return seconds


When = Annotated[
    AfterLevel | Annotated[float, Field(ge=0)],
    BeforeValidator(_when),
    AlsoAccepts(
        (
            {"type": "string", "pattern": quantity_pattern("non-negative")},
            {"type": "string", "pattern": json_pattern(AFTER_LEVEL, LEVEL_NUMBER)},
        ),
        "a time >= 0 ('14 s'), 'after level N' or {after_level: N}",
    ),
]

SIDES = {"+x": (-1.0, 0.0, 0.0), "-x": (1.0, 0.0, 0.0), "+y": (0.0, -1.0, 0.0), "-y": (0.0, 1.0, 0.0)}


class Target(StrictModel):
    """Where an impact hits: the middle of a ``level``'s outer face on ``side``, or a ``point``."""

    one_value = True  # a grid may give it whole

    model_config = ConfigDict(
        json_schema_extra={
            "oneOf": [{**given("level", "side"), **absent("point")}, {**given("point"), **absent("level", "side")}]
        }
    )

    level: Annotated[int, Field(ge=1, le=MAX_LEVELS), WHOLE] | None = None
    side: Literal["+x", "-x", "+y", "-y"] | None = None
    point: Vector3 | None = None

    @model_validator(mode="after")
    def _one_target(self) -> Target:
        if self.point is None and (self.level is None or self.side is None):
            raise ValueError("give 'level' and 'side', or a 'point'")
        if self.point is not None and (self.level is not None or self.side is not None):
            raise ValueError("give 'level' and 'side', or a 'point', not both")
        return self


def _nonzero(direction: tuple[float, float, float]) -> tuple[float, float, float]:
    """An impact's direction with a component of at least :data:`MIN_DIRECTION` in size."""
    if all(abs(c) < MIN_DIRECTION for c in direction):
        raise ValueError(f"'direction' must not be zero: give it a component of at least {MIN_DIRECTION:g}")
    return direction


if TYPE_CHECKING:  # to mypy a float; to pydantic a length with its bounds
    LaunchDistance = float
else:
    LaunchDistance = within(Length, length, 0.0, 1.0, "a length above 0 and at most 1 m", above=True)


class Impact(StrictModel):
    """A projectile brick thrown at ``speed`` (0.1 to 100 m/s) so that it reaches ``target``
    ``distance`` after launch; it flies along ``direction`` (default: into the target's side)
    with its long axis along the flight. The direction need not be a unit vector: its
    components are finite, each at most 1e6 in size, and one is at least 1e-6."""

    model_config = ConfigDict(json_schema_extra={"anyOf": [given("direction"), {"properties": {"target": given("side")}}]})

    id: BodyId | None = None
    projectile: str = "kapla"
    target: Target
    speed: ImpactSpeed
    direction: Annotated[tuple[Component, Component, Component], AfterValidator(_nonzero)] | None = Field(
        default=None,
        json_schema_extra={
            "not": {"type": "array", "items": {"exclusiveMinimum": -MIN_DIRECTION, "exclusiveMaximum": MIN_DIRECTION}}
        },
    )
    at: When
    distance: LaunchDistance = 0.05

    @model_validator(mode="after")
    def _direction(self) -> Impact:
        if self.direction is None and self.target.side is None:
            raise ValueError("a 'point' target needs a 'direction'")
        return self

"""The layouts of the scenario language's first version: a layered ``tower``, a ``card_house``
and ``bricks`` placed by hand (pydantic models; their bricks are :mod:`stackdsl.compile.layouts`').
The generators of the richer scenes are :mod:`stackdsl.lang.schema_generators`'.

Source: stackdsl's own; report chapter 4 (the 4 stack, the slant tower, the card house).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any

from pydantic import BeforeValidator, Field, StrictBool, ValidationInfo, field_validator

from .bounds import (
    MAX_BRICKS,
    MAX_LEVELS,
    BoundedAngle,
    Offset,
    PeakSpacing,
    Spacing,
    StrictModel,
    Vector2,
    Vector3,
)
from .grammar import WHOLE, AlsoAccepts, BodyId
from .units import Angle, angle, within

_BRICK = Field(description="the brick type (built in: kapla, 120 x 24 x 8 mm)", examples=["kapla"])

if TYPE_CHECKING:  # to mypy a float; to pydantic an angle with its bounds
    LeanAngle = float
else:
    LeanAngle = within(Angle, angle, 0.0, 60.0, "an angle above 0 and below 60 degrees", above=True, below=True)


def _shift(value: Any) -> Any:
    """A per-layer shift: one length (along x) or an (x, y) pair."""
    return value if isinstance(value, (list, tuple)) else (value, 0.0)


Shift = Annotated[
    tuple[Offset, Offset],
    BeforeValidator(_shift),
    AlsoAccepts((Offset,), "one length (along x) or an (x, y) pair, each within 10 m"),
]


class Tower(StrictModel):
    """A layered tower: ``bricks_per_layer`` parallel bricks ``spacing`` apart (centre to
    centre), each layer turned by ``turn`` degrees and moved by ``shift`` from the one below.

    Two bricks a layer turned 90 deg is the report's 4 stack; a shift makes it a slant tower.
    ``shifts`` gives each layer above the first its own shift from the layer below (a random
    walk when drawn ``per: layer``); ``yaw_jitter`` turns each brick by that many degrees
    more (one number for all, or one a brick), its position unchanged.
    ``turn`` and ``yaw`` are degrees within +-3600 (ten turns, :data:`MAX_ANGLE`; not folded);
    ``spacing`` and each part of ``shift`` at most 10 m (no brick is longer), ``origin`` within 1 km.
    """

    brick: Annotated[str, _BRICK] = "kapla"
    levels: Annotated[int, Field(ge=1, le=MAX_LEVELS), WHOLE]
    bricks_per_layer: Annotated[int, Field(ge=1, le=50), WHOLE] = 2
    spacing: Spacing = 0.096
    turn: BoundedAngle = 90.0
    shift: Shift = (0.0, 0.0)
    shifts: Annotated[list[Shift], Field(max_length=MAX_LEVELS - 1)] | None = None
    origin: Vector2 = (0.0, 0.0)
    yaw: BoundedAngle = 0.0
    yaw_jitter: BoundedAngle | Annotated[list[BoundedAngle], Field(max_length=MAX_BRICKS)] = 0.0

    @field_validator("shifts")
    @classmethod
    def _per_layer(cls, shifts: list[Shift] | None, info: ValidationInfo) -> list[Shift] | None:
        """At the list itself: the levels and the shift are read before it."""
        if shifts is None or "levels" not in info.data:
            return shifts
        if any(info.data.get("shift", (0.0, 0.0))):
            raise ValueError("give 'shift' (every layer alike) or 'shifts' (one a layer), not both")
        levels = info.data["levels"]
        if len(shifts) != levels - 1:
            raise ValueError(
                f"'shifts' has one shift a layer above the first: {levels - 1} for {levels} levels, not {len(shifts)}"
            )
        return shifts

    @field_validator("yaw_jitter")
    @classmethod
    def _per_brick(cls, jitter: float | list[float], info: ValidationInfo) -> float | list[float]:
        """At the list itself: the levels and the bricks a layer are read before it."""
        if isinstance(jitter, list) and "levels" in info.data and "bricks_per_layer" in info.data:
            bricks = info.data["levels"] * info.data["bricks_per_layer"]
            if len(jitter) != bricks:
                raise ValueError(f"a 'yaw_jitter' list has one angle a brick: {bricks}, not {len(jitter)}")
        return jitter

    def layer_shift(self, level: int) -> tuple[float, float]:
        """Where level ``level``'s centre is from ``origin``, m: the sum of the shifts below it."""
        return self.layer_shifts()[level - 1]

    def layer_shifts(self) -> list[tuple[float, float]]:
        """:meth:`layer_shift` of every level, level 1 first, m: one running sum (each level's
        is the sum of the shifts below it, added from the bottom up), not a sum a level."""
        if self.shifts is None:
            return [((level - 1) * self.shift[0], (level - 1) * self.shift[1]) for level in range(1, self.levels + 1)]
        out: list[tuple[float, float]] = [(0, 0)]  # as sum() of nothing: 0
        x: float = 0
        y: float = 0
        for dx, dy in self.shifts[: self.levels - 1]:
            x, y = x + dx, y + dy
            out.append((x, y))
        return out

    def jitter(self, index: int) -> float:
        """Degrees added to brick ``index``'s yaw (bricks counted from 0, level 1 first)."""
        return self.yaw_jitter[index] if isinstance(self.yaw_jitter, list) else self.yaw_jitter


class BrickPlacement(StrictModel):
    """One brick placed by hand: centre position ``at`` (each coordinate within 1 km), yaw/pitch/roll
    in degrees within +-3600 (ten turns, :data:`MAX_ANGLE`; not folded).

    ``fixed: true`` makes it part of the environment (a wall, a ramp): it is in the world
    from the start, immovable, and not part of the structure. ``together: true`` places
    it at the same moment as the brick before it (the two bricks of a V).
    """

    id: BodyId | None = None
    brick: Annotated[str, _BRICK] = "kapla"
    at: Vector3
    yaw: BoundedAngle = 0.0
    pitch: BoundedAngle = 0.0
    roll: BoundedAngle = 0.0
    level: Annotated[int, Field(ge=1, le=MAX_LEVELS), WHOLE] | None = None
    fixed: StrictBool = False
    together: StrictBool = False


class CardHouse(StrictModel):
    """A card house: rows of inverted V's (two bricks leaning on each other at ``angle``
    degrees from vertical), a flat brick across the peaks of every two neighbouring V's,
    a V on every flat brick, up to a single V: a pyramid with ``levels`` V's at its base.
    ``spacing`` is the distance between neighbouring peaks (default: the V's width + 2 mm), at most
    10 m; ``angle`` is in degrees, above 0 and below 60.
    """

    brick: Annotated[str, _BRICK] = "kapla"
    levels: Annotated[int, Field(ge=1, le=50), WHOLE]
    angle: LeanAngle = 20.0
    spacing: PeakSpacing | None = None
    origin: Vector2 = (0.0, 0.0)

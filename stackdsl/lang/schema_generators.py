"""The generators of the richer scenes: a ``wall`` in running bond, a stepped ``pyramid`` and a
row of ``dominoes`` (bricks on end, in a line or along an arc).

Each is a pydantic model of the scenario language, a sibling of the tower and the card house
(:mod:`stackdsl.lang.schema`); the bricks themselves are :mod:`stackdsl.compile.generators`'.
Every field carries a description and an example for the JSON Schema.

Source: stackdsl's own.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, field_validator, model_validator

from .bounds import MAX_BRICKS, MAX_LEVELS, BoundedAngle, Coordinate, PeakSpacing, Spacing, StrictModel, Vector2
from .grammar import WHOLE

HALF = "/2"
"""A brick type's name followed by this is the same brick cut to half its length (a wall's closers)."""

Laid = Literal["flat", "edge"]

_BRICK = Field(description="the brick type of every brick (built in: kapla, 120 x 24 x 8 mm)", examples=["kapla"])
_ORIGIN = Field(description="where its middle stands on the ground ([x, y]; lengths)", examples=[[0.0, "60 mm"]])
_YAW = Field(description="degrees the whole of it is turned about the vertical (0: along x)", examples=[90])
_LAID = Field(
    description="how each brick lies: 'flat' (on its widest face, a course is as high as the brick's height) or "
    "'edge' (on its long narrow side, a course is as high as its width)",
    examples=["edge"],
)
_JOINT = Field(description="the gap between neighbouring bricks of a course, end to end (a length)", examples=["1 mm"])


class Wall(StrictModel):
    """A wall of ``courses`` in running bond: odd courses have ``bricks_per_course`` bricks end to
    end, ``joint`` apart; even courses one brick fewer, each centred over a joint of the course
    below, with a half brick (the closer, brick type ``NAME/2``) at each end so that the wall's
    ends are straight. Course C is level C, ids ``L01.1``... along the wall (closers included).
    """

    brick: Annotated[str, _BRICK] = "kapla"
    courses: Annotated[
        int, Field(ge=1, le=MAX_LEVELS, description="courses (levels) of bricks, one on another", examples=[6]), WHOLE
    ]
    bricks_per_course: Annotated[
        int,
        Field(ge=1, le=200, description="whole bricks in the first (and every odd) course, end to end", examples=[5]),
        WHOLE,
    ]
    laid: Annotated[Laid, _LAID] = "flat"
    joint: Annotated[Spacing, _JOINT] = 0.0
    origin: Annotated[Vector2, _ORIGIN] = (0.0, 0.0)
    yaw: Annotated[BoundedAngle, _YAW] = 0.0

    @model_validator(mode="after")
    def _bricks(self) -> Wall:
        if self.courses * (self.bricks_per_course + 1) > MAX_BRICKS:
            raise ValueError(f"the wall has over {MAX_BRICKS} bricks; at most {MAX_BRICKS} are allowed")
        return self


class Pyramid(StrictModel):
    """A stepped pyramid: ``base`` bricks end to end, ``joint`` apart, on the ground; each course
    above has one brick fewer, each centred over a joint of the course below, up to ``levels``
    courses (default: up to a single brick). Course C is level C, ids ``L01.1``...
    """

    brick: Annotated[str, _BRICK] = "kapla"
    base: Annotated[int, Field(ge=1, le=200, description="bricks in the bottom course", examples=[5]), WHOLE]
    levels: Annotated[int, Field(ge=1, le=200), WHOLE] | None = Field(
        default=None, description="courses built (at most 'base'; default: up to a single brick)", examples=[3]
    )
    laid: Annotated[Laid, _LAID] = "flat"
    joint: Annotated[Spacing, _JOINT] = 0.0
    origin: Annotated[Vector2, _ORIGIN] = (0.0, 0.0)
    yaw: Annotated[BoundedAngle, _YAW] = 0.0

    @model_validator(mode="after")
    def _levels(self) -> Pyramid:
        if self.levels is not None and self.levels > self.base:
            raise ValueError(f"a pyramid with {self.base} bricks at the base has at most {self.base} levels, not {self.levels}")
        bricks = self.courses * self.base - self.courses * (self.courses - 1) // 2
        if bricks > MAX_BRICKS:
            raise ValueError(f"the pyramid has {bricks} bricks; at most {MAX_BRICKS} are allowed")
        return self

    @property
    def courses(self) -> int:
        """Courses built."""
        return self.levels or self.base


class Dominoes(StrictModel):
    """A row of ``count`` dominoes: bricks standing on end (their length vertical), their widest
    faces across the row, ``spacing`` apart centre to centre. The first stands at ``origin`` and
    the row runs along ``yaw``; with a ``radius`` it follows a circular arc of that radius,
    turning left (counter-clockwise seen from above) for a positive radius, right for a negative
    one, ``spacing`` then measured along the arc and each domino facing along the arc. All are
    level 1; ids ``D01``... (``D001``... from 100).
    """

    brick: Annotated[str, _BRICK] = "kapla"
    count: Annotated[int, Field(ge=1, le=MAX_BRICKS, description="dominoes in the row", examples=[30]), WHOLE]
    spacing: PeakSpacing | None = Field(
        default=None, description="centre to centre along the row (default: half a brick's length)", examples=["60 mm"]
    )
    origin: Annotated[Vector2, Field(description="where the first domino stands ([x, y])", examples=[[0, 0]])] = (0.0, 0.0)
    yaw: Annotated[BoundedAngle, Field(description="degrees from x of the row's direction at the first domino", examples=[0])] = (
        0.0
    )
    radius: Coordinate | None = Field(
        default=None,
        description="an arc of this radius instead of a line: positive turns left, negative right",
        examples=["400 mm"],
    )

    @field_validator("radius")
    @classmethod
    def _radius(cls, radius: float | None) -> float | None:
        if radius is not None and radius == 0:
            raise ValueError("an arc's radius is not 0: leave 'radius' out for a straight row")
        return radius

"""The limits of the scenario language: every number a scenario gives is finite and within a
physical range, and each refusal says the range and why (the constants below): brick sides
from 1.5 mm to 10 m; positions within 1 km; angles within ten turns; densities, speeds and
thresholds within what a brick can be; a collapse threshold from 1 mm. These hold for every
engine; each engine's own, narrower limits (the smallest side, the fastest projectile, the
largest mass ratio it simulates faithfully) are checked by the compiler against the engine a
run uses (:mod:`stackdsl.compile.limits`). Also the strict base of every scenario model
(unknown keys refused, values frozen).

Source: stackdsl's own.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any, ClassVar

import yaml
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StrictFloat,
)

from .units import (
    Angle,
    AngularSpeed,
    Density,
    Length,
    Speed,
    angle,
    angular_speed,
    density,
    length,
    real,
    speed,
    within,
)

MAX_BRICKS = 5000
MAX_LEVELS = 1000
MAX_SIMULATED_TIME = 3600.0  # s
MIN_DIRECTION = 1e-6  # the largest component of an impact's direction is at least this
# Each component of an impact's direction is at most this in size: only the direction counts, and within
# this its length (at most 1.8e6) and its square are finite doubles (at 1e308 the norm overflows to inf).
MAX_DIRECTION = 1e6
# Angles (yaw, pitch, roll, turn) are degrees within +-10 turns: one turn reaches every pose; a larger
# angle is a mistake, and a huge one (1e308) makes a tower's layer angles infinite. Not folded: an angle
# given is the angle used.
MAX_ANGLE = 3600.0
# Brick sides, m. The floor is the lowest of the engines' own (engines' Limits.min_side, measured by
# `stackdsl bench limits`: MuJoCo's 1.5 mm; pybullet's is 3 mm); below it the default 0.5 mm drop gap is not
# below half a side. The ceiling is the largest moving body Bullet is made for ("the size of a truck", its
# wiki's Scaling The World).
MIN_SIDE = 0.0015
MAX_SIDE = 10.0
# Positions (at, point, origin), m. Scenes are room-sized; the bound keeps every position a double holds to
# far below a micrometre (1e-13 m at 1 km) and every brick's footprint a polygon shapely can build (at 1e15 m
# a double's step is 0.125 m, more than a brick, and the footprint degenerates). A tower's own offsets
# (shift, spacing) are at most MAX_SIDE, so its bricks stay within 1 km + 1000 x 10 m + 25 x 10 m.
MAX_COORDINATE = 1000.0
MIN_DENSITY = 1.0  # kg/m^3, about air's
MAX_DENSITY = 100_000.0  # kg/m^3, over four times osmium's (22590), the densest element
MIN_IMPACT_SPEED = 0.1  # m/s: slower, a throw is a drop (over the longest distance, 1 m, it falls 490 m)
MAX_IMPACT_SPEED = 100.0  # m/s
# Rest thresholds of the extension: bricks at rest in pybullet (MuJoCo's are stiller) move at about 0.08 mm/s (median, a 5-level
# tower at 1/240 s): below 1 mm/s a resting brick may never count as at rest; above 1 m/s a falling one does.
MIN_REST_SPEED, MAX_REST_SPEED = 0.001, 1.0  # m/s
MIN_REST_ANGULAR_SPEED, MAX_REST_ANGULAR_SPEED = 0.01, 10.0  # rad/s
# Collapse threshold, m: one step of free fall at the longest timestep (10 ms) moves a brick g dt^2 = 0.98 mm
# before contact holds it, so a smaller threshold sees every landing brick displaced; it also bounds the runtime's
# substeps (a thrown brick moves at most the threshold in a substep: at 100 m/s and 1/240 s, 417 substeps).
MIN_COLLAPSE_THRESHOLD = 0.001
# m: dropped from higher, a brick lands as a blow (1 m/s from 50 mm). A scenario's gap is also below its collapse
# threshold (Scenario's own check), which is the bound that counts unless the threshold is set above 50 mm.
MAX_DROP_GAP = 0.05
MAX_PLACEMENT_ERROR = 0.01  # m


Number = Annotated[StrictFloat, Field(allow_inf_nan=False)]  # a YAML number, not a string or a flag
if TYPE_CHECKING:  # to mypy, the bounded numbers are floats; to pydantic, the quantities below
    Coordinate = float
    Side = float
    Offset = float
    Spacing = float
    PeakSpacing = float
    BoundedAngle = float
    BoundedDensity = float
    ImpactSpeed = float
    Component = float
    RestSpeed = float
    RestAngularSpeed = float
    CollapseThreshold = float
    DropGap = float
    PlacementError = float
else:
    Coordinate = within(
        Length,
        length,
        -MAX_COORDINATE,
        MAX_COORDINATE,
        "a coordinate from -1 km to 1 km (-1000 to 1000 m)",
        "scenes are room-sized, and far out a double cannot place a brick (at 1e15 m its step is 0.125 m)",
    )
    Side = within(
        Length,
        length,
        MIN_SIDE,
        MAX_SIDE,
        "a side from 1.5 mm to 10 m",
        (
            "a smaller brick is below what any engine here simulates faithfully (MuJoCo's floor is 1.5 mm, "
            "pybullet's 3 mm), and a brick's 0.5 mm drop gap is not below half its side",
            "Bullet is made for moving bodies up to about 10 m",
        ),
    )
    Offset = within(
        Length,
        length,
        -MAX_SIDE,
        MAX_SIDE,
        "a length from -10 m to 10 m",
        "no brick is longer: a layer moved further rests on nothing",
    )
    Spacing = within(
        Length, length, 0.0, MAX_SIDE, "a length from 0 to 10 m", "no brick is longer: bricks further apart rest on nothing"
    )
    PeakSpacing = within(Length, length, 0.0, MAX_SIDE, "a length above 0 and at most 10 m", "no brick is longer", above=True)
    BoundedAngle = within(
        Angle,
        angle,
        -MAX_ANGLE,
        MAX_ANGLE,
        "an angle from -3600 to 3600 degrees (ten turns)",
        "one turn reaches every orientation",
    )
    BoundedDensity = within(
        Density,
        density,
        MIN_DENSITY,
        MAX_DENSITY,
        "a density from 1 to 100000 kg/m^3",
        "from about air's to over four times osmium's, the densest element",
    )
    ImpactSpeed = within(
        Speed,
        speed,
        MIN_IMPACT_SPEED,
        MAX_IMPACT_SPEED,
        "a speed from 0.1 to 100 m/s",
        (
            "slower, a throw is a drop (over 1 m it falls 490 m on its way)",
            "faster, it moves more than a brick's 8 mm thickness in one substep (64 a 1/240 s step at most) "
            "and would pass through the bricks it hits",
        ),
    )
    Component = within(
        Number,
        real,
        -MAX_DIRECTION,
        MAX_DIRECTION,
        "a direction component from -1e6 to 1e6",
        "only the direction counts; within this its length is a finite double",
    )
    RestSpeed = within(
        Speed,
        speed,
        MIN_REST_SPEED,
        MAX_REST_SPEED,
        "a speed from 1 mm/s to 1 m/s",
        (
            "bricks at rest in pybullet move at about 0.1 mm/s (in MuJoCo less): below 1 mm/s a brick at rest may "
            "never count as at rest",
            "a brick moving this fast is not at rest",
        ),
    )
    RestAngularSpeed = within(
        AngularSpeed,
        angular_speed,
        MIN_REST_ANGULAR_SPEED,
        MAX_REST_ANGULAR_SPEED,
        "an angular speed from 0.01 to 10 rad/s",
        ("bricks at rest in the engines are not quite still", "a brick turning this fast is not at rest"),
    )
    CollapseThreshold = within(
        Length,
        length,
        MIN_COLLAPSE_THRESHOLD,
        MAX_SIDE,
        "a length from 1 mm to 10 m",
        (
            "one step of free fall at the longest timestep (10 ms) moves a brick 0.98 mm before contact holds it, "
            "so a smaller threshold sees every landing brick displaced",
            "no brick is longer",
        ),
    )
    DropGap = within(
        Length,
        length,
        0.0,
        MAX_DROP_GAP,
        "a length from 0 to 50 mm, and below the collapse threshold (by default half the thinnest brick side, 4 mm for KAPLA)",
        "dropped from higher, a brick lands at about 1 m/s: a blow, not a placement",
    )
    PlacementError = within(
        Length,
        length,
        0.0,
        MAX_PLACEMENT_ERROR,
        "a length from 0 to 10 mm",
        "a placement error is a careful hand's, millimetres at most; an offset meant is part of the structure",
    )

Vector2 = tuple[Coordinate, Coordinate]
Vector3 = tuple[Coordinate, Coordinate, Coordinate]


class StrictModel(BaseModel):
    """A part of a scenario: unknown keys are refused and values are frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    #: Whether a file writes the model as one value that happens to be a mapping (an impact's or a
    #: push's target, the moment ``{after_level: 3}``), which a sweep's grid may give whole; any
    #: other model is a section of fields (``timing``, an action, a part), and a grid key or a
    #: distribution names one field of it (:func:`stackdsl.lang.field_kinds.whole_of`).
    one_value: ClassVar[bool] = False


#: What no text of a scenario may hold: PyYAML's test of a printable character, the loader's rule
#: for a value written as an escape (stackdsl.lang.loader) and the builder's (:class:`StrictModel`).
NOT_IN_A_VALUE = yaml.reader.Reader.NON_PRINTABLE


def unprintable(value: Any) -> tuple[tuple[str | int, ...], str] | None:
    """The first character of :data:`NOT_IN_A_VALUE` in ``value`` (a text, or texts inside models,
    lists, tuples and mappings, keys too): (the field path to it inside ``value``, the character),
    or None. Source: stackdsl's own."""
    if isinstance(value, str):
        bad = NOT_IN_A_VALUE.search(value)
        return None if bad is None else ((), bad.group())
    items: Any = ()
    if isinstance(value, BaseModel):
        items = value.__dict__.items()
    elif isinstance(value, dict):
        for key in value:
            if isinstance(key, str) and NOT_IN_A_VALUE.search(key):
                return ((), NOT_IN_A_VALUE.search(key).group())  # type: ignore[union-attr]
        items = value.items()
    elif isinstance(value, list | tuple):
        items = enumerate(value)
    for key, item in items:
        found = unprintable(item)
        if found is not None:
            return ((key, *found[0]), found[1])
    return None

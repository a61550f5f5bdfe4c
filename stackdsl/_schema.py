"""The scenario language, version 1: pydantic models of a validated scenario file.

Units: every length, time and speed may be written with a unit ("120 mm", "1 s",
"3 m/s"); bare numbers are SI; angles are degrees. Unknown keys are rejected. The
built-in material ``pine`` and brick type ``kapla`` (120 x 24 x 8 mm, 460 kg/m^3,
friction coefficient 0.5) can be used without being declared.

Integers, numbers and flags are read as YAML writes them (see :mod:`stackdsl._grammar`);
:mod:`stackdsl._jsonschema` gives the JSON Schema of these models for editors.

Every number is finite and within a physical range, each refusal saying the range and
why (the constants below): brick sides from 3 mm (measured: smaller bricks jitter more
than half their side on the ground at 1/240 s) to 10 m; positions within 1 km; angles
within ten turns; densities, speeds and thresholds within what a brick and pybullet
can be; a collapse threshold from 1 mm, and a drop gap below it.

Source: stackdsl's own (docs/design.md, words); report 3.2 and chapter 4.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    PrivateAttr,
    StrictBool,
    StrictFloat,
    Tag,
    ValidationError,
    WithJsonSchema,
    model_validator,
)
from pydantic_core import InitErrorDetails, PydanticCustomError

from ._errors import SourceMap
from ._grammar import (
    AFTER_LEVEL,
    BOUND,
    COLLAPSE,
    LEVEL_NUMBER,
    LEVEL_RANGE,
    PLUS_MINUS,
    TOLERANCE_NUMBER,
    WHOLE,
    AlsoAccepts,
    absent,
    as_int,
    flag,
    given,
    json_pattern,
    whole,
)
from ._units import (
    Angle,
    AngularSpeed,
    Density,
    Length,
    Speed,
    Time,
    angle,
    angular_speed,
    density,
    length,
    quantity_pattern,
    real,
    speed,
    time,
    within,
)

FORMAT_VERSION = 1
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
# Brick sides, m. The floor is measured (stackdsl.run_program, one brick on the ground, raw and extension
# modes at their 1/240 s timestep, the default drop gap): cubes of 1, 1.5, 2.5 mm move 0.77, 1.3, 1.26 mm as
# they land and settle (contact penetration and its correction), more than half their side, which reads as a
# collapse; cubes from 2.75 mm (and flatter bricks from 2 mm) stay within half their side. The ceiling is the
# largest moving body Bullet is made for ("the size of a truck", its wiki's Scaling The World).
MIN_SIDE = 0.003
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
# Rest thresholds of the extension: bricks at rest in pybullet move at about 0.08 mm/s (median, a 5-level
# tower at 1/240 s): below 1 mm/s a resting brick may never count as at rest; above 1 m/s a falling one does.
MIN_REST_SPEED, MAX_REST_SPEED = 0.001, 1.0  # m/s
MIN_REST_ANGULAR_SPEED, MAX_REST_ANGULAR_SPEED = 0.01, 10.0  # rad/s
# Collapse threshold, m: one step of free fall at the longest timestep (10 ms) moves a brick g dt^2 = 0.98 mm
# before contact holds it, so a smaller threshold sees every landing brick displaced; it also bounds the runtime's
# substeps (a thrown brick moves at most the threshold in a substep: at 100 m/s and 1/240 s, 417 substeps).
MIN_COLLAPSE_THRESHOLD = 0.001


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
        "a side from 3 mm to 10 m",
        (
            "a smaller brick is below what pybullet resolves at 1/240 s: resting on the ground it moves 0.8 to 1.3 mm "
            "as it lands (measured on 1 to 2.5 mm cubes), more than half its side",
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
        "slower, a throw is a drop (over 1 m it falls 490 m on its way)",
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
            "bricks at rest in pybullet move at about 0.1 mm/s: below 1 mm/s a brick at rest may never count as at rest",
            "a brick moving this fast is not at rest",
        ),
    )
    RestAngularSpeed = within(
        AngularSpeed,
        angular_speed,
        MIN_REST_ANGULAR_SPEED,
        MAX_REST_ANGULAR_SPEED,
        "an angular speed from 0.01 to 10 rad/s",
        ("bricks at rest in pybullet are not quite still", "a brick turning this fast is not at rest"),
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

Vector2 = tuple[Coordinate, Coordinate]
Vector3 = tuple[Coordinate, Coordinate, Coordinate]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Material(_Model):
    """A material: density, static friction coefficient and restitution of a pair of its bodies."""

    density: BoundedDensity = 460.0
    friction: Annotated[Number, Field(ge=0, le=10)] = 0.5
    restitution: Annotated[Number, Field(ge=0, le=1)] = 0.0


class BrickType(_Model):
    """A box-shaped brick: ``size`` is length, width, height (the KAPLA default 120 x 24 x 8 mm),
    each from 3 mm (:data:`MIN_SIDE`, measured: below it pybullet does not hold a brick still on
    the ground at 1/240 s) to 10 m."""

    size: tuple[Side, Side, Side] = (0.12, 0.024, 0.008)
    material: str = "pine"


BUILTIN_MATERIALS = {"pine": Material()}
BUILTIN_BRICKS = {"kapla": BrickType()}


def _shift(value: Any) -> Any:
    """A per-layer shift: one length (along x) or an (x, y) pair."""
    return value if isinstance(value, (list, tuple)) else (value, 0.0)


Shift = Annotated[
    tuple[Offset, Offset],
    BeforeValidator(_shift),
    AlsoAccepts((Offset,), "one length (along x) or an (x, y) pair, each within 10 m"),
]


class Tower(_Model):
    """A layered tower: ``bricks_per_layer`` parallel bricks ``spacing`` apart (centre to
    centre), each layer turned by ``turn`` degrees and moved by ``shift`` from the one below.

    Two bricks a layer turned 90 deg is the report's 4 stack; a shift makes it a slant tower.
    ``shifts`` gives each layer above the first its own shift from the layer below (a random
    walk when drawn ``per: layer``); ``yaw_jitter`` turns each brick by that many degrees
    more (one number for all, or one a brick), its position unchanged.
    ``turn`` and ``yaw`` are degrees within +-3600 (ten turns, :data:`MAX_ANGLE`; not folded);
    ``spacing`` and each part of ``shift`` at most 10 m (no brick is longer), ``origin`` within 1 km.
    """

    brick: str = "kapla"
    levels: Annotated[int, Field(ge=1, le=MAX_LEVELS), WHOLE]
    bricks_per_layer: Annotated[int, Field(ge=1, le=50), WHOLE] = 2
    spacing: Spacing = 0.096
    turn: BoundedAngle = 90.0
    shift: Shift = (0.0, 0.0)
    shifts: Annotated[list[Shift], Field(max_length=MAX_LEVELS - 1)] | None = None
    origin: Vector2 = (0.0, 0.0)
    yaw: BoundedAngle = 0.0
    yaw_jitter: BoundedAngle | Annotated[list[BoundedAngle], Field(max_length=MAX_BRICKS)] = 0.0

    @model_validator(mode="after")
    def _per_layer_and_brick(self) -> Tower:
        if self.shifts is not None:
            if any(self.shift):
                raise ValueError("give 'shift' (every layer alike) or 'shifts' (one a layer), not both")
            if len(self.shifts) != self.levels - 1:
                raise ValueError(
                    f"'shifts' has one shift a layer above the first: {self.levels - 1} for {self.levels} levels, not {len(self.shifts)}"
                )
        if isinstance(self.yaw_jitter, list) and len(self.yaw_jitter) != self.levels * self.bricks_per_layer:
            bricks = self.levels * self.bricks_per_layer
            raise ValueError(f"a 'yaw_jitter' list has one angle a brick: {bricks}, not {len(self.yaw_jitter)}")
        return self

    def layer_shift(self, level: int) -> tuple[float, float]:
        """Where level ``level``'s centre is from ``origin``, m: the sum of the shifts below it."""
        if self.shifts is None:
            return (level - 1) * self.shift[0], (level - 1) * self.shift[1]
        below = self.shifts[: level - 1]
        return sum(x for x, _ in below), sum(y for _, y in below)

    def jitter(self, index: int) -> float:
        """Degrees added to brick ``index``'s yaw (bricks counted from 0, level 1 first)."""
        return self.yaw_jitter[index] if isinstance(self.yaw_jitter, list) else self.yaw_jitter


class BrickPlacement(_Model):
    """One brick placed by hand: centre position ``at`` (each coordinate within 1 km), yaw/pitch/roll
    in degrees within +-3600 (ten turns, :data:`MAX_ANGLE`; not folded).

    ``fixed: true`` makes it part of the environment (a wall, a ramp): it is in the world
    from the start, immovable, and not part of the structure. ``together: true`` places
    it at the same moment as the brick before it (the two bricks of a V).
    """

    id: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]{1,40}$")] | None = None
    brick: str = "kapla"
    at: Vector3
    yaw: BoundedAngle = 0.0
    pitch: BoundedAngle = 0.0
    roll: BoundedAngle = 0.0
    level: Annotated[int, Field(ge=1, le=MAX_LEVELS), WHOLE] | None = None
    fixed: StrictBool = False
    together: StrictBool = False


class CardHouse(_Model):
    """A card house: rows of inverted V's (two bricks leaning on each other at ``angle``
    degrees from vertical), a flat brick across the peaks of every two neighbouring V's,
    a V on every flat brick, up to a single V: a pyramid with ``levels`` V's at its base.
    ``spacing`` is the distance between neighbouring peaks (default: the V's width + 2 mm), at most
    10 m; ``angle`` is in degrees, above 0 and below 60.
    """

    brick: str = "kapla"
    levels: Annotated[int, Field(ge=1, le=50), WHOLE]
    angle: Annotated[Angle, Field(gt=0, lt=60)] = 20.0
    spacing: PeakSpacing | None = None
    origin: Vector2 = (0.0, 0.0)


class Structure(_Model):
    """What is built: a ``tower``, a ``card_house`` or a list of ``bricks`` (exactly one)."""

    model_config = ConfigDict(json_schema_extra={"oneOf": [given("tower"), given("card_house"), given("bricks")]})

    tower: Tower | None = None
    card_house: CardHouse | None = None
    bricks: Annotated[list[BrickPlacement], Field(min_length=1, max_length=MAX_BRICKS)] | None = Field(
        default=None,
        json_schema_extra={
            # the first brick is not 'together' (with no brick before it); some brick is not 'fixed'
            "prefixItems": [{"not": {"required": ["together"], "properties": {"together": {"const": True}}}}],
            "contains": {"not": {"required": ["fixed"], "properties": {"fixed": {"const": True}}}},
        },
    )

    @model_validator(mode="after")
    def _one_layout(self) -> Structure:
        if sum(x is not None for x in (self.tower, self.card_house, self.bricks)) != 1:
            raise ValueError("give exactly one of 'tower', 'card_house' or 'bricks'")
        if self.bricks is not None:
            if self.bricks[0].together:
                raise ValueError("the first brick has no brick before it to be placed 'together' with")
            if all(b.fixed for b in self.bricks):
                raise ValueError("every brick is fixed: there is nothing to build")
        return self


class Timing(_Model):
    """One placement every ``interval``; ``settle`` after the last action; bricks are
    placed at rest ``drop_gap`` above their pose, at most ``placement_error`` off it
    horizontally (drawn from the scenario's seed)."""

    interval: Annotated[Time, Field(gt=0, le=60)] = 1.0
    settle: Annotated[Time, Field(ge=0, le=600)] = 2.0
    drop_gap: Annotated[Length, Field(ge=0, le=0.05)] = 0.0005
    placement_error: Annotated[Length, Field(ge=0, le=0.01)] = 0.0


class AfterLevel(_Model):
    """The moment one interval after the last brick of ``level`` was placed."""

    after_level: Annotated[int, Field(ge=1, le=MAX_LEVELS), WHOLE]


def _when(value: Any) -> Any:
    """``"after level 13"`` -> :class:`AfterLevel`; anything else must be a time >= 0."""
    if isinstance(value, (AfterLevel, dict)):
        return value
    if isinstance(value, str):
        match = re.fullmatch(AFTER_LEVEL, value)
        if match:
            if not 1 <= int(match[1]) <= MAX_LEVELS:
                raise ValueError(f"expected a level from 1 to {MAX_LEVELS}, got {value!r}")
            return AfterLevel(after_level=int(match[1]))
    try:
        seconds = time(value)
    except ValueError:
        raise ValueError(f"expected a time such as '14 s' or 'after level N', got {value!r}") from None
    if seconds < 0:
        raise ValueError(f"expected a time >= 0, got {value!r}")
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


class Target(_Model):
    """Where an impact hits: the middle of a ``level``'s outer face on ``side``, or a ``point``."""

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


class Impact(_Model):
    """A projectile brick thrown at ``speed`` (0.1 to 100 m/s) so that it reaches ``target``
    ``distance`` after launch; it flies along ``direction`` (default: into the target's side)
    with its long axis along the flight. The direction need not be a unit vector: its
    components are finite, each at most 1e6 in size, and one is at least 1e-6."""

    model_config = ConfigDict(json_schema_extra={"anyOf": [given("direction"), {"properties": {"target": given("side")}}]})

    id: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]{1,40}$")] | None = None
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
    distance: Annotated[Length, Field(gt=0, le=1)] = 0.05

    @model_validator(mode="after")
    def _direction(self) -> Impact:
        if self.direction is None and self.target.side is None:
            raise ValueError("a 'point' target needs a 'direction'")
        return self


MAX_TIMESTEP = 0.010  # s


def _timestep(value: float) -> float:
    if value > MAX_TIMESTEP + 1e-12:
        raise ValueError(
            f"a timestep of {value * 1000:.3g} ms is too long for KAPLA bricks: at most 10 ms (1/100 s). "
            "Beyond it stackdsl's answers change (measured: at 1/60 s a thrown brick no longer knocks a "
            "brick off, at 1/30 s every brick falls as it lands); from 1/100 s to 1/2000 s they do not"
        )
    return value


#: Engine fields that only one backend has.
BACKEND_FIELDS = {"pybullet": ("friction_anchors", "maximal_coordinates"), "mujoco": ("sleep_tolerance",)}


class Engine(_Model):
    """The physics engine: ``backend`` (pybullet, mujoco) and ``mode`` (raw, tuned,
    extension) pick the defaults of the rest. ``timestep`` is at most 10 ms: the capability
    scenarios give the same answers from 1/100 s to 1/2000 s and different ones beyond
    (docs/results.md, hard cases). ``friction_anchors`` and ``maximal_coordinates`` are
    pybullet's; ``sleep_tolerance`` turns MuJoCo's own sleeping on (a body sleeps below this
    speed, MuJoCo's units)."""

    backend: Literal["pybullet", "mujoco"] = "pybullet"
    mode: Literal["raw", "tuned", "extension"] = "extension"
    timestep: Annotated[Time, Field(ge=1e-5), AfterValidator(_timestep)] | None = Field(
        default=None, json_schema_extra={"maximum": MAX_TIMESTEP + 1e-12}
    )
    solver_iterations: Annotated[int, Field(ge=1, le=10000), WHOLE] | None = None
    friction_anchors: StrictBool | None = None
    maximal_coordinates: StrictBool | None = None
    ccd: StrictBool | None = None
    sleep_tolerance: Annotated[Number, Field(gt=0, le=1)] | None = None

    @model_validator(mode="after")
    def _one_backend(self) -> Engine:
        for backend, fields in BACKEND_FIELDS.items():
            given = [f for f in fields if getattr(self, f) is not None]
            if given and self.backend != backend:
                raise ValueError(f"{given[0]} is a {backend} setting; this engine's backend is {self.backend}")
        return self


class Stability(_Model):
    """The stability extension: its ``model`` (``report``: the report's rules;
    ``equilibrium``: rigid-block equilibrium) and thresholds (report 3.3.2); defaults in
    :mod:`stability`. ``rest_speed`` is from 1 mm/s to 1 m/s and ``rest_angular_speed`` from
    0.01 to 10 rad/s: bricks at rest in pybullet are not quite still (:data:`MIN_REST_SPEED`)."""

    model: Literal["report", "equilibrium"] = "report"
    rest_speed: RestSpeed | None = None
    rest_angular_speed: RestAngularSpeed | None = None
    rest_duration: Annotated[Time, Field(ge=0, le=10)] | None = None


class CollapseLevel(_Model):
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


class Within(_Model):
    """A number of levels within a tolerance: written ``"7 ± 0.5"``."""

    target: Annotated[float, Field(ge=0, le=MAX_LEVELS)]
    tolerance: Annotated[float, Field(gt=0, le=MAX_LEVELS)]


PlusMinus = Annotated[
    Within,
    BeforeValidator(_plus_minus),
    AlsoAccepts(({"type": "string", "pattern": f"^{PLUS_MINUS}$"},), "a level and a tolerance: '7 ± 0.5'"),
]


class Quantile(_Model):
    """The ``q`` quantile of the collapse level (0 < q < 1; 0.5: the median) within ``level``."""

    q: Annotated[float, Field(gt=0, lt=1)]
    level: PlusMinus


class CollapseStatistic(_Model):
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
    return value


class Probability(_Model):
    """A bound on a probability: written ``">= 0.9"`` (also ``<=``, ``>``, ``<``)."""

    op: Literal[">=", "<=", ">", "<"]
    bound: Annotated[float, Field(ge=0, le=1)]


def _collapse_form(value: Any) -> str:
    """Which form ``expect.collapse`` is written in: a sweep's ``statistic`` or a run's ``level``."""
    if isinstance(value, CollapseStatistic) or (isinstance(value, dict) and {"mean", "quantile"} & set(value)):
        return "statistic"
    return "level"


class Expect(_Model):
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


MAX_SAMPLES = 100_000
MAX_CELLS = 1000
MAX_SWEEP_RUNS = 200_000


class Sweep(_Model):
    """Many runs of one scenario: ``samples`` draws of its random fields (sample k seeded by the
    k-th child of the scenario's seed), for each cell of ``grid``: field paths (``timing.placement_error``)
    each with a list of values, run as their product; every cell's sample k has the same seed."""

    samples: Annotated[int, Field(ge=1, le=MAX_SAMPLES), WHOLE] = 1
    grid: Annotated[dict[str, Annotated[list[Any], Field(min_length=1, max_length=100)]], Field(max_length=4)] = {}

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


class Ground(_Model):
    """The ground plane at height 0."""

    material: str = "pine"


class Scenario(_Model):
    """A validated scenario file (format ``stackdsl: 1``).

    Use :func:`stackdsl.load_scenario` to read one from YAML; it keeps where each field
    came from, so later stages (the compiler) can point errors at the file.
    """

    stackdsl: Annotated[Literal[1], BeforeValidator(whole)]
    name: Annotated[str, Field(min_length=1, max_length=200)] | None = None
    description: str = ""
    seed: Annotated[int, Field(ge=0), WHOLE] = 0
    materials: dict[str, Material] = {}
    brick_types: dict[str, BrickType] = {}
    ground: Ground = Ground()
    structure: Structure
    timing: Timing = Timing()
    impacts: Annotated[list[Impact], Field(max_length=100)] = []
    engine: Engine = Engine()
    stability: Stability = Stability()
    collapse_threshold: CollapseThreshold | None = None
    expect: Expect = Expect()
    # checks before simulating that this scene silences: "floating" lets bricks be placed resting on nothing
    allow: list[Literal["floating"]] = []
    sweep: Sweep | None = None

    @model_validator(mode="after")
    def _expectations_fit_the_sweep(self) -> Scenario:
        """A sweep's expectations are statistics; one run's are not."""
        if self.sweep is None and self.expect.statistical:
            field = "p_stands" if self.expect.p_stands is not None else "collapse"
            self._refuse(("expect", field), "a statistical expectation needs a sweep: add 'sweep: {samples: N}'")
        if self.sweep is not None and self.expect.per_run:
            field = next(f for f in ("collapse", "stands", "stays") if getattr(self.expect, f) is not None)
            self._refuse(
                ("expect", field),
                "a sweep's expectations are statistics over its samples: collapse: {mean: '7 ± 0.5'}, "
                "collapse: {quantile: {q: 0.5, level: '7 ± 1'}} or p_stands: '>= 0.9'",
            )
        return self

    def _refuse(self, loc: tuple[str, ...], message: str) -> None:
        error = InitErrorDetails(type=PydanticCustomError("value_error", message), loc=loc, input=None)
        raise ValidationError.from_exception_data(type(self).__name__, [error])

    _source: SourceMap = PrivateAttr(default_factory=lambda: SourceMap("<scenario>"))
    _template: Any = PrivateAttr(default=None)  # a stackdsl._sampling.Template when the file is random or a sweep
    _sample: tuple[int, int] = PrivateAttr(default=(0, 0))  # this one's (grid cell, sample)

    @model_validator(mode="after")
    def _drop_gap_below_threshold(self) -> Scenario:
        """A brick is placed ``timing.drop_gap`` above its pose, displaced by the gap until it lands:
        the gap must be below the collapse threshold, so that every brick starts within it and a
        fall from the gap is never taken for a brick that moved (stackdsl's own rule)."""
        threshold = self.collapse_threshold or self._thinnest_half_side()
        gap = self.timing.drop_gap
        if threshold is None or gap < threshold:
            return self
        own = "the collapse threshold" if self.collapse_threshold else "the collapse threshold (half the thinnest brick side)"
        message = (
            f"a drop gap of {gap * 1000:g} mm is not below {own}, {threshold * 1000:g} mm: a brick is placed this far "
            "above its pose and counts as moved until it lands, so the first brick would read as a collapse; "
            f"give a drop gap below {threshold * 1000:g} mm"
        )
        # the default gap (0.5 mm) is below every threshold (at least 1 mm): the gap was given
        loc = ("timing", "drop_gap")
        error = InitErrorDetails(type=PydanticCustomError("value_error", message), loc=loc, input=gap)
        raise ValidationError.from_exception_data(type(self).__name__, [error])

    def _thinnest_half_side(self) -> float | None:
        """Half the thinnest side of the structure's bricks (not fixtures), the default collapse
        threshold, m; None if they name no brick type known yet (the loader reports the name)."""
        layout = self.structure.tower or self.structure.card_house
        names = {layout.brick} if layout else {b.brick for b in self.structure.bricks or [] if not b.fixed}
        types = {**BUILTIN_BRICKS, **self.brick_types}
        sides = [min(types[n].size) for n in names if n in types]
        return min(sides) / 2 if sides and len(sides) == len(names) else None

    @property
    def source(self) -> SourceMap:
        """Where the fields came from (:class:`SourceMap`)."""
        return self._source

    @property
    def template(self) -> Any:
        """The file's :class:`stackdsl._sampling.Template` when it has random fields or a sweep
        (this scenario is then one of its samples: :attr:`sample`), else None."""
        return self._template

    @property
    def sample(self) -> tuple[int, int]:
        """(grid cell, sample index) of this scenario in its file's sweep; (0, 0) otherwise."""
        return self._sample

    def material(self, name: str) -> Material:
        """A declared or built-in material. Raises KeyError for an unknown name."""
        return {**BUILTIN_MATERIALS, **self.materials}[name]

    def brick_type(self, name: str) -> BrickType:
        """A declared or built-in brick type. Raises KeyError for an unknown name."""
        return {**BUILTIN_BRICKS, **self.brick_types}[name]

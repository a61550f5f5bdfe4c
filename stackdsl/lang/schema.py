"""The scenario language, version 1: pydantic models of a validated scenario file.

Units: every length, time and speed may be written with a unit ("120 mm", "1 s",
"3 m/s"); bare numbers are SI; angles are degrees. Unknown keys are rejected. The
built-in material ``pine`` and brick type ``kapla`` (120 x 24 x 8 mm, 460 kg/m^3,
friction coefficient 0.5) can be used without being declared.

Integers, numbers and flags are read as YAML writes them (see :mod:`stackdsl.lang.grammar`);
:mod:`stackdsl.lang.jsonschema` gives the JSON Schema of these models for editors.

Every number is finite and within a physical range (:mod:`stackdsl.lang.bounds`), and a drop
gap is below the collapse threshold; the expectations are :mod:`stackdsl.lang.expectations`'.

Source: stackdsl's own (docs/design.md, words); report 3.2 and chapter 4.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BeforeValidator,
    ConfigDict,
    Field,
    PrivateAttr,
    StrictBool,
    ValidationError,
    model_validator,
)
from pydantic_core import InitErrorDetails, PydanticCustomError

from .bounds import (
    MAX_BRICKS,
    MAX_LEVELS,
    BoundedAngle,
    BoundedDensity,
    CollapseThreshold,
    DropGap,
    Number,
    Offset,
    PeakSpacing,
    PlacementError,
    RestAngularSpeed,
    RestSpeed,
    Side,
    Spacing,
    StrictModel,
    Vector2,
    Vector3,
)
from .errors import SourceMap
from .expectations import Expect
from .grammar import (
    WHOLE,
    AlsoAccepts,
    given,
    whole,
)
from .schema_impacts import Impact
from .schema_sweep import Sweep
from .units import (
    Angle,
    Time,
)

FORMAT_VERSION = 1


class Material(StrictModel):
    """A material: density, static friction coefficient and restitution of a pair of its bodies."""

    density: BoundedDensity = 460.0
    friction: Annotated[Number, Field(ge=0, le=10)] = 0.5
    restitution: Annotated[Number, Field(ge=0, le=1)] = 0.0


class BrickType(StrictModel):
    """A box-shaped brick: ``size`` is length, width, height (the KAPLA default 120 x 24 x 8 mm),
    each from 1.5 mm (:data:`MIN_SIDE`, the smallest any engine simulates faithfully; each
    engine's own floor is checked by the compiler, :mod:`stackdsl.compile.limits`) to 10 m."""

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


class BrickPlacement(StrictModel):
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


class CardHouse(StrictModel):
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


class Structure(StrictModel):
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


class Timing(StrictModel):
    """One placement every ``interval``; ``settle`` after the last action; bricks are
    placed at rest ``drop_gap`` above their pose, at most ``placement_error`` off it
    horizontally (drawn from the scenario's seed)."""

    interval: Annotated[Time, Field(gt=0, le=60)] = 1.0
    settle: Annotated[Time, Field(ge=0, le=600)] = 2.0
    drop_gap: DropGap = 0.0005
    placement_error: PlacementError = 0.0


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


class Engine(StrictModel):
    """The physics engine: ``backend`` (pybullet, mujoco) and ``mode`` (raw, tuned,
    extension) pick the defaults of the rest. ``timestep`` is at most 10 ms: the capability
    scenarios give the same answers from 1/100 s to 1/2000 s and different ones beyond
    (docs/results/hard-cases.md). ``friction_anchors`` and ``maximal_coordinates`` are
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


class Stability(StrictModel):
    """The stability extension: its ``model`` (``report``: the report's rules;
    ``equilibrium``: rigid-block equilibrium) and thresholds (report 3.3.2); defaults in
    :mod:`stability`. ``rest_speed`` is from 1 mm/s to 1 m/s and ``rest_angular_speed`` from
    0.01 to 10 rad/s: bricks at rest in the engines are not quite still (:data:`MIN_REST_SPEED`)."""

    model: Literal["report", "equilibrium"] = "report"
    rest_speed: RestSpeed | None = None
    rest_angular_speed: RestAngularSpeed | None = None
    rest_duration: Annotated[Time, Field(ge=0, le=10)] | None = None


class Ground(StrictModel):
    """The ground plane at height 0."""

    material: str = "pine"


class Scenario(StrictModel):
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
    _template: Any = PrivateAttr(default=None)  # a stackdsl.lang.sampling.Template when the file is random or a sweep
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
        # the default gap (0.5 mm) is below every threshold (at least 0.75 mm): the gap was given
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
        """The file's :class:`stackdsl.lang.sampling.Template` when it has random fields or a sweep
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

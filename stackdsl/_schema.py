"""The scenario language, version 1: pydantic models of a validated scenario file.

Units: every length, time and speed may be written with a unit ("120 mm", "1 s",
"3 m/s"); bare numbers are SI; angles are degrees. Unknown keys are rejected. The
built-in material ``pine`` and brick type ``kapla`` (120 x 24 x 8 mm, 460 kg/m^3,
friction coefficient 0.5) can be used without being declared.

Source: stackdsl's own (docs/design.md, words); report 3.2 and chapter 4.
"""

from __future__ import annotations

import re
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field, PrivateAttr, WithJsonSchema, model_validator

from ._errors import SourceMap
from ._units import Angle, AngularSpeed, Density, Length, Speed, Time, time

FORMAT_VERSION = 1
MAX_BRICKS = 5000
MAX_LEVELS = 1000
MAX_SIMULATED_TIME = 3600.0  # s

PositiveLength = Annotated[Length, Field(gt=0)]
NonNegativeLength = Annotated[Length, Field(ge=0)]
Vector2 = tuple[Length, Length]
Vector3 = tuple[Length, Length, Length]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Material(_Model):
    """A material: density, static friction coefficient and restitution of a pair of its bodies."""

    density: Annotated[Density, Field(gt=0)] = 460.0
    friction: Annotated[float, Field(ge=0, le=10)] = 0.5
    restitution: Annotated[float, Field(ge=0, le=1)] = 0.0


class BrickType(_Model):
    """A box-shaped brick: ``size`` is length, width, height (the KAPLA default 120 x 24 x 8 mm)."""

    size: tuple[PositiveLength, PositiveLength, PositiveLength] = (0.12, 0.024, 0.008)
    material: str = "pine"


BUILTIN_MATERIALS = {"pine": Material()}
BUILTIN_BRICKS = {"kapla": BrickType()}


def _shift(value: Any) -> Any:
    """A per-layer shift: one length (along x) or an (x, y) pair."""
    return value if isinstance(value, (list, tuple)) else (value, 0.0)


class Tower(_Model):
    """A layered tower: ``bricks_per_layer`` parallel bricks ``spacing`` apart (centre to
    centre), each layer turned by ``turn`` degrees and moved by ``shift`` from the one below.

    Two bricks a layer turned 90 deg is the report's 4 stack; a shift makes it a slant tower.
    """

    brick: str = "kapla"
    levels: Annotated[int, Field(ge=1, le=MAX_LEVELS)]
    bricks_per_layer: Annotated[int, Field(ge=1, le=50)] = 2
    spacing: NonNegativeLength = 0.096
    turn: Angle = 90.0
    shift: Annotated[Vector2, BeforeValidator(_shift)] = (0.0, 0.0)
    origin: Vector2 = (0.0, 0.0)
    yaw: Angle = 0.0


class BrickPlacement(_Model):
    """One brick placed by hand: centre position ``at``, yaw/pitch/roll in degrees.

    ``fixed: true`` makes it part of the environment (a wall, a ramp): it is in the world
    from the start, immovable, and not part of the structure. ``together: true`` places
    it at the same moment as the brick before it (the two bricks of a V).
    """

    id: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]{1,40}$")] | None = None
    brick: str = "kapla"
    at: Vector3
    yaw: Angle = 0.0
    pitch: Angle = 0.0
    roll: Angle = 0.0
    level: Annotated[int, Field(ge=1, le=MAX_LEVELS)] | None = None
    fixed: bool = False
    together: bool = False


class CardHouse(_Model):
    """A card house: rows of inverted V's (two bricks leaning on each other at ``angle``
    degrees from vertical), a flat brick across the peaks of every two neighbouring V's,
    a V on every flat brick, up to a single V: a pyramid with ``levels`` V's at its base.
    ``spacing`` is the distance between neighbouring peaks (default: the V's width + 2 mm).
    """

    brick: str = "kapla"
    levels: Annotated[int, Field(ge=1, le=50)]
    angle: Annotated[Angle, Field(gt=0, lt=60)] = 20.0
    spacing: Annotated[Length, Field(gt=0)] | None = None
    origin: Vector2 = (0.0, 0.0)


class Structure(_Model):
    """What is built: a ``tower``, a ``card_house`` or a list of ``bricks`` (exactly one)."""

    tower: Tower | None = None
    card_house: CardHouse | None = None
    bricks: Annotated[list[BrickPlacement], Field(min_length=1, max_length=MAX_BRICKS)] | None = None

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

    after_level: Annotated[int, Field(ge=1, le=MAX_LEVELS)]


def _when(value: Any) -> Any:
    """``"after level 13"`` -> :class:`AfterLevel`; anything else must be a time >= 0."""
    if isinstance(value, (AfterLevel, dict)):
        return value
    if isinstance(value, str):
        match = re.fullmatch(r"\s*after\s+level\s+(\d+)\s*", value)
        if match:
            return AfterLevel(after_level=int(match[1]))
    try:
        seconds = time(value)
    except ValueError:
        raise ValueError(f"expected a time such as '14 s' or 'after level N', got {value!r}") from None
    if seconds < 0:
        raise ValueError(f"expected a time >= 0, got {value!r}")
    return seconds


When = Annotated[
    AfterLevel | float,
    BeforeValidator(_when),
    WithJsonSchema({"anyOf": [{"type": "number"}, {"type": "string"}], "description": "a time ('14 s') or 'after level N'"}),
]

SIDES = {"+x": (-1.0, 0.0, 0.0), "-x": (1.0, 0.0, 0.0), "+y": (0.0, -1.0, 0.0), "-y": (0.0, 1.0, 0.0)}


class Target(_Model):
    """Where an impact hits: the middle of a ``level``'s outer face on ``side``, or a ``point``."""

    level: Annotated[int, Field(ge=1, le=MAX_LEVELS)] | None = None
    side: Literal["+x", "-x", "+y", "-y"] | None = None
    point: Vector3 | None = None

    @model_validator(mode="after")
    def _one_target(self) -> Target:
        if self.point is None and (self.level is None or self.side is None):
            raise ValueError("give 'level' and 'side', or a 'point'")
        if self.point is not None and (self.level is not None or self.side is not None):
            raise ValueError("give 'level' and 'side', or a 'point', not both")
        return self


class Impact(_Model):
    """A projectile brick thrown at ``speed`` so that it reaches ``target`` ``distance``
    after launch; it flies along ``direction`` (default: into the target's side) with its
    long axis along the flight."""

    id: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]{1,40}$")] | None = None
    projectile: str = "kapla"
    target: Target
    speed: Annotated[Speed, Field(gt=0, le=100)]
    direction: tuple[float, float, float] | None = None
    at: When
    distance: Annotated[Length, Field(gt=0, le=1)] = 0.05

    @model_validator(mode="after")
    def _direction(self) -> Impact:
        if self.direction is None and self.target.side is None:
            raise ValueError("a 'point' target needs a 'direction'")
        if self.direction is not None and sum(c * c for c in self.direction) < 1e-12:
            raise ValueError("'direction' must not be zero")
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


class Engine(_Model):
    """The physics engine: ``mode`` (raw, tuned, extension) picks the defaults of the rest.
    ``timestep`` is at most 10 ms: the capability scenarios give the same answers from
    1/100 s to 1/2000 s and different ones beyond (docs/results.md, hard cases)."""

    mode: Literal["raw", "tuned", "extension"] = "extension"
    timestep: Annotated[Time, Field(ge=1e-5), AfterValidator(_timestep)] | None = None
    solver_iterations: Annotated[int, Field(ge=1, le=10000)] | None = None
    friction_anchors: bool | None = None
    maximal_coordinates: bool | None = None
    ccd: bool | None = None


class Stability(_Model):
    """The stability extension: its ``model`` (``report``: the report's rules;
    ``equilibrium``: rigid-block equilibrium) and thresholds (report 3.3.2); defaults in
    :mod:`stability`."""

    model: Literal["report", "equilibrium"] = "report"
    rest_speed: Annotated[Speed, Field(gt=0)] | None = None
    rest_angular_speed: Annotated[AngularSpeed, Field(gt=0)] | None = None
    rest_duration: Annotated[Time, Field(ge=0, le=10)] | None = None


class CollapseLevel(_Model):
    """Expected collapse level with a tolerance in levels."""

    level: Annotated[int, Field(ge=1, le=MAX_LEVELS)]
    tolerance: Annotated[int, Field(ge=0, le=MAX_LEVELS)] = 0


def _collapse(value: Any) -> Any:
    """``9``, ``"9±1"``, ``"9 +- 1"`` or ``{level: 9, tolerance: 1}``."""
    if isinstance(value, int) and not isinstance(value, bool):
        return {"level": value}
    if isinstance(value, str):
        match = re.fullmatch(r"\s*(\d+)\s*(?:(?:±|\+-|\+/-)\s*(\d+))?\s*", value)
        if not match:
            raise ValueError(f"expected a level such as '9±1', '9 +- 1' or 9, got {value!r}")
        return {"level": int(match[1]), "tolerance": int(match[2] or 0)}
    return value


def _levels(value: Any) -> Any:
    """Levels: ``5``, ``"1-11"``, or a list of those; returned as a sorted tuple."""
    items = value if isinstance(value, list) else [value]
    levels: set[int] = set()
    for item in items:
        if isinstance(item, int) and not isinstance(item, bool):
            levels.add(item)
            continue
        match = re.fullmatch(r"\s*(\d+)\s*(?:(?:-|\.\.)\s*(\d+))?\s*", item) if isinstance(item, str) else None
        if not match or int(match[2] or match[1]) < int(match[1]) or int(match[2] or match[1]) > MAX_LEVELS:
            raise ValueError(f"expected levels such as 5, '1-11' or a list of those, got {item!r}")
        levels.update(range(int(match[1]), int(match[2] or match[1]) + 1))
    return tuple(sorted(levels))


Levels = Annotated[
    tuple[Annotated[int, Field(ge=1)], ...],
    BeforeValidator(_levels),
    WithJsonSchema({"description": "levels: 5, '1-11', or a list of those"}),
]


class Expect(_Model):
    """What must hold: a ``collapse`` level, or that the structure ``stands``; after an
    impact, the levels that ``stay`` in place and the levels that ``may_fall``."""

    collapse: Annotated[CollapseLevel, BeforeValidator(_collapse)] | None = None
    stands: Literal[True] | None = None
    stays: Levels | None = None
    may_fall: Levels | None = None

    @model_validator(mode="after")
    def _consistent(self) -> Expect:
        if self.collapse is not None and self.stands:
            raise ValueError("a structure cannot both collapse and stand: give one of 'collapse' or 'stands'")
        if self.stays and self.may_fall and set(self.stays) & set(self.may_fall):
            raise ValueError("a level cannot both stay and fall: 'stays' and 'may_fall' overlap")
        return self


class Ground(_Model):
    """The ground plane at height 0."""

    material: str = "pine"


class Scenario(_Model):
    """A validated scenario file (format ``stackdsl: 1``).

    Use :func:`stackdsl.load_scenario` to read one from YAML; it keeps where each field
    came from, so later stages (the compiler) can point errors at the file.
    """

    stackdsl: Literal[1]
    name: Annotated[str, Field(min_length=1, max_length=200)] | None = None
    description: str = ""
    seed: Annotated[int, Field(ge=0)] = 0
    materials: dict[str, Material] = {}
    brick_types: dict[str, BrickType] = {}
    ground: Ground = Ground()
    structure: Structure
    timing: Timing = Timing()
    impacts: Annotated[list[Impact], Field(max_length=100)] = []
    engine: Engine = Engine()
    stability: Stability = Stability()
    collapse_threshold: Annotated[Length, Field(gt=0)] | None = None
    expect: Expect = Expect()

    _source: SourceMap = PrivateAttr(default_factory=lambda: SourceMap("<scenario>"))

    @property
    def source(self) -> SourceMap:
        """Where the fields came from (:class:`SourceMap`)."""
        return self._source

    def material(self, name: str) -> Material:
        """A declared or built-in material. Raises KeyError for an unknown name."""
        return {**BUILTIN_MATERIALS, **self.materials}[name]

    def brick_type(self, name: str) -> BrickType:
        """A declared or built-in brick type. Raises KeyError for an unknown name."""
        return {**BUILTIN_BRICKS, **self.brick_types}[name]


def reference_errors(s: Scenario) -> list[tuple[tuple, str]]:
    """Names that point nowhere: (field path, message) for each, in file order."""
    bricks = {**BUILTIN_BRICKS, **s.brick_types}
    materials = {**BUILTIN_MATERIALS, **s.materials}
    problems: list[tuple[tuple, str]] = []

    def brick(path: tuple, name: str) -> None:
        if name not in bricks:
            problems.append((path, f"unknown brick type {name!r}; known: {', '.join(sorted(bricks))}"))

    for name, bt in s.brick_types.items():
        if bt.material not in materials:
            problems.append(
                (("brick_types", name, "material"), f"unknown material {bt.material!r}; known: {', '.join(sorted(materials))}")
            )
    if s.ground.material not in materials:
        problems.append(
            (("ground", "material"), f"unknown material {s.ground.material!r}; known: {', '.join(sorted(materials))}")
        )
    if s.structure.tower:
        brick(("structure", "tower", "brick"), s.structure.tower.brick)
    if s.structure.card_house:
        brick(("structure", "card_house", "brick"), s.structure.card_house.brick)
    for i, b in enumerate(s.structure.bricks or []):
        brick(("structure", "bricks", i, "brick"), b.brick)
    ids = [b.id for b in s.structure.bricks or [] if b.id] + [imp.id for imp in s.impacts if imp.id]
    for i, b in enumerate(s.structure.bricks or []):
        if b.id and ids.count(b.id) > 1:
            problems.append((("structure", "bricks", i, "id"), f"brick id {b.id!r} is used more than once"))
    for i, imp in enumerate(s.impacts):
        brick(("impacts", i, "projectile"), imp.projectile)
    n_bricks = s.structure.tower.levels * s.structure.tower.bricks_per_layer if s.structure.tower else 0
    if n_bricks > MAX_BRICKS:
        problems.append((("structure", "tower", "levels"), f"the tower has {n_bricks} bricks; at most {MAX_BRICKS} are allowed"))
    return problems

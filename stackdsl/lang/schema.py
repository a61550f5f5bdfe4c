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

from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import (
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
    BoundedDensity,
    CollapseThreshold,
    DropGap,
    Number,
    PlacementError,
    RestAngularSpeed,
    RestSpeed,
    Side,
    StrictModel,
    unprintable,
)
from .errors import NO_FILE, FieldPath, SourceMap
from .expectations import Expect
from .expressions import parse
from .grammar import (
    WHOLE,
    Key,
    given,
    whole,
)
from .scenario_file import character_name
from .schema_actions import Action
from .schema_generators import HALF, Dominoes, Pyramid, Wall
from .schema_golden import Golden
from .schema_impacts import Impact
from .schema_layouts import BrickPlacement, CardHouse, Tower
from .schema_marks import SkipMark, XFailMark
from .schema_parts import LAYOUTS, RESERVED, Parts, as_parts, check_parts, named_parts
from .schema_require import Requirement
from .schema_search import SearchField
from .schema_sweep import SweepField, grid_name
from .unit_slips import metres_written
from .units import (
    Time,
    time,
    within,
)
from .yaml_out import yaml_text

FORMAT_VERSION = 1
#: pydantic's error type of a problem :func:`reference_errors` finds (each one said on its own,
#: where a union's members' refusals of one node are merged into one).
REFERENCE_ERROR = "reference_error"


class Material(StrictModel):
    """A material: density, friction coefficient and restitution of a pair of its bodies."""

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


class Structure(StrictModel):
    """What is built: exactly one layout (a ``tower``, a ``card_house``, a list of ``bricks``, a
    ``wall``, a ``pyramid`` or ``dominoes``), or ``parts``: a list or map of named parts, each
    one layout (:mod:`stackdsl.lang.schema_parts`; written as the structure itself, a list or a map)."""

    model_config = ConfigDict(json_schema_extra={"oneOf": [given(name) for name in LAYOUTS]})

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
    wall: Annotated[
        Wall | None, Field(description="a wall in running bond", examples=[{"courses": 4, "bricks_per_course": 3}])
    ] = None
    pyramid: Annotated[Pyramid | None, Field(description="a stepped pyramid", examples=[{"base": 4}])] = None
    dominoes: Annotated[Dominoes | None, Field(description="a row of dominoes", examples=[{"count": 30}])] = None
    parts: Parts | None = None

    _as_parts = model_validator(mode="before")(as_parts)

    @model_validator(mode="after")
    def _one_layout(self) -> Structure:
        if sum(getattr(self, name) is not None for name in (*LAYOUTS, "parts")) != 1:
            raise ValueError(f"give exactly one of {', '.join(repr(n) for n in LAYOUTS)}, or a list of parts")
        if isinstance(self.parts, dict) and RESERVED & set(self.parts):
            raise ValueError(f"{sorted(RESERVED & set(self.parts))[0]!r} is a key of the structure; give the part another name")
        if self.bricks is not None:
            if self.bricks[0].together:
                raise ValueError("the first brick has no brick before it to be placed 'together' with")
            if all(b.fixed for b in self.bricks):
                raise ValueError("every brick is fixed: there is nothing to build")
        return self

    @property
    def layout_name(self) -> str | None:
        """The single layout's name (one of :data:`LAYOUTS`), or None for parts."""
        return next((name for name in LAYOUTS if getattr(self, name) is not None), None)

    def brick_names(self) -> set[str]:
        """The brick types of the structure's bricks (not fixtures)."""
        layouts = (
            [p.layout for _, _, p in named_parts(self.parts)]
            if self.parts is not None
            else [getattr(self, self.layout_name or "")]
        )
        names: set[str] = set()
        for layout in layouts:
            names |= {b.brick for b in layout if not b.fixed} if isinstance(layout, list) else {layout.brick}
        return names


MAX_TIMESTEP = 0.010  # s

if TYPE_CHECKING:  # to mypy, the bounded times are floats; to pydantic, quantities with their bounds
    Interval = float
    Settle = float
    Timestep = float
    RestDuration = float
else:
    Interval = within(Time, time, 0.0, 60.0, "a time above 0 and at most 60 s", above=True)
    Settle = within(Time, time, 0.0, 600.0, "a time from 0 to 600 s")
    Timestep = within(
        Time,
        time,
        1e-5,
        MAX_TIMESTEP + 1e-12,  # '1/100 s' and '10 ms' as pint converts them
        "a timestep of 0.01 ms or more and at most 10 ms (1/100 s)",
        (
            "",
            "beyond 10 ms stackdsl's answers change for KAPLA bricks (measured: at 1/60 s a thrown brick no longer "
            "knocks a brick off, at 1/30 s every brick falls as it lands); from 1/100 s to 1/2000 s they do not "
            "(raw pybullet's own do above 5 ms)",
        ),
    )
    RestDuration = within(Time, time, 0.0, 10.0, "a time from 0 to 10 s")


class Timing(StrictModel):
    """One placement every ``interval``; ``settle`` after the last action; bricks are
    placed at rest ``drop_gap`` above their pose (below the collapse threshold, and at most
    50 mm), at most ``placement_error`` off it horizontally (drawn from the scenario's seed)."""

    interval: Interval = 1.0
    settle: Settle = 2.0
    drop_gap: DropGap = 0.0005
    placement_error: PlacementError = 0.0


#: Engine fields that only one backend has.
BACKEND_FIELDS = {"pybullet": ("friction_anchors", "maximal_coordinates"), "mujoco": ("sleep_tolerance",)}


class Engine(StrictModel):
    """The physics engine: ``backend`` (pybullet, mujoco) and ``mode`` (raw, tuned,
    extension) pick the defaults of the rest. ``timestep`` is at most 10 ms: in tuned and
    extension mode, and in raw MuJoCo, the capability scenarios give the same answers from
    1/100 s to 1/2000 s and different ones beyond (docs/results/hard-cases.md); raw pybullet
    drifts above 5 ms (a single-file slant tower that falls at level 7 falls at 6 at 1/192 s and
    at 4 at 10 ms). ``friction_anchors`` and ``maximal_coordinates`` are
    pybullet's; ``sleep_tolerance`` turns MuJoCo's own sleeping on (a body sleeps below this
    speed, MuJoCo's units)."""

    backend: Literal["pybullet", "mujoco"] = "pybullet"
    mode: Literal["raw", "tuned", "extension"] = "extension"
    timestep: Timestep | None = None
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
    rest_duration: RestDuration | None = None


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
    materials: dict[Key, Material] = {}
    brick_types: dict[Key, BrickType] = {}
    ground: Ground = Ground()
    structure: Structure
    timing: Timing = Timing()
    impacts: Annotated[list[Impact], Field(max_length=100)] = []
    actions: Annotated[
        list[Action],
        Field(
            max_length=100,
            description="what a hand or the ground does, each at a time like an impact's: remove (pull a brick out), "
            "push (a pusher at a constant speed), shake (the ground as a shake table)",
            examples=[[{"remove": {"brick": "L05.2", "at": "after level 12", "speed": "20 mm/s"}}]],
        ),
    ] = []
    engine: Engine = Engine()
    stability: Stability = Stability()
    collapse_threshold: CollapseThreshold | None = None
    expect: Expect = Expect()
    # checks before simulating that this scene silences: "floating" lets bricks be placed resting on nothing
    allow: list[Literal["floating"]] = []
    golden: Annotated[
        Golden,
        Field(
            description="how closely the golden snapshot must be matched: tolerance of its measured fields "
            "(position, angle, mass, area, load_share, margin, friction_share, level)",
            examples=[{"tolerance": {"position": "2 mm", "angle": 2}}],
        ),
    ] = Golden()
    sweep: SweepField = None
    search: SearchField = None
    require: Annotated[list[Requirement], Field(max_length=50)] = Field(
        default=[],
        description="conditions a sample's draws must meet before it runs (else it is drawn again): fields of the "
        "scene by path and overhang, max_overhang, com_offset, gap, levels, bricks; numbers with units; "
        "comparisons, and, or, not",
        examples=[["overhang >= 10 mm", "com_offset < 50 mm and gap > 1 mm"]],
    )
    # pytest's marks: skip and xfail, each with a reason and a condition on the run (stackdsl.lang.schema_marks)
    skip: SkipMark = None
    xfail: XFailMark = None

    @model_validator(mode="after")
    def _text_a_file_can_hold(self) -> Scenario:
        """Every text of the scenario (a value, a key, in any section) holds only characters a YAML
        value may hold: the loader's rule (:data:`stackdsl.lang.bounds.NOT_IN_A_VALUE`), so that a
        scenario built in Python writes (:meth:`to_yaml`) a file the loader reads back:
        ``Scenario(name="a\\x00b")`` is refused, naming the field and the character."""
        found = unprintable(self)
        if found is not None:
            where, ch = found
            self._refuse(where, f"{character_name(ch)} is not allowed in a value: a scenario file cannot hold it")
        return self

    @model_validator(mode="after")
    def _expectations_fit_the_sweep(self) -> Scenario:
        """A sweep's expectations are statistics; one run's are not."""
        if self.sweep is None and self.expect.statistical:
            field = next(f for f in ("p_stands", "cells", "collapse") if getattr(self.expect, f) is not None)
            self._refuse(("expect", field), "a statistical expectation needs a sweep: add 'sweep: {samples: N}'")
        if self.sweep is not None and self.expect.per_run:
            field = next(
                f
                for f in ("collapse", "stands", "stands_until", "stays", "moved", "toppled")
                if getattr(self.expect, f) is not None
            )
            self._refuse(
                ("expect", field),
                "a sweep's expectations are statistics over its samples: collapse: {mean: '7 ± 0.5'}, "
                "collapse: {quantile: {q: 0.5, level: '7 ± 1'}}, p_stands: '>= 0.9', or the same for some grid cells: "
                "cells: [{where: 'timing.placement_error < 2 mm', p_stands: '>= 0.9'}]",
            )
        if self.sweep is not None and self.expect.cells is not None:
            keys = {grid_name(key) for key in self.sweep.grid}
            for i, cell in enumerate(self.expect.cells):
                unknown = [name for name in parse(cell.where).names if name not in keys]
                if unknown:
                    self._refuse(
                        ("expect", "cells", i, "where"),
                        f"{unknown[0]!r} is not a field of the grid; a cell's condition reads the grid's fields by "
                        f"their keys: {', '.join(sorted(keys)) or 'this sweep has no grid'}",
                    )
        return self

    def _refuse(self, loc: tuple[str | int, ...], message: str) -> None:
        error = InitErrorDetails(type=PydanticCustomError("value_error", message), loc=loc, input=None)
        raise ValidationError.from_exception_data(type(self).__name__, [error])

    _source: SourceMap = PrivateAttr(default_factory=lambda: SourceMap(NO_FILE))
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
        names = self.structure.brick_names()
        types = {**BUILTIN_BRICKS, **self.brick_types}
        sides = [min(types[n].size) for n in names if n in types]
        return min(sides) / 2 if sides and len(sides) == len(names) else None

    @model_validator(mode="after")
    def _references_resolve(self) -> Scenario:
        """The checks the schema cannot make (:func:`reference_errors`: names that point nowhere,
        the rules between parts), after the others: a scenario built in Python is refused here, at
        the field a file's error names (``structure.1.on``), as its file would be."""
        problems = reference_errors(self)
        if problems:
            errors = [
                InitErrorDetails(type=PydanticCustomError(REFERENCE_ERROR, m), loc=p, input=_written_at(self, p))
                for p, m in problems
            ]
            raise ValidationError.from_exception_data(type(self).__name__, errors)
        return self

    @property
    def source(self) -> SourceMap:
        """Where the fields came from (:class:`SourceMap`)."""
        return self._source

    def __eq__(self, other: object) -> bool:
        """The same scenario: the same fields and, for a sample of a random file or a sweep, the
        same file data (:class:`~stackdsl.lang.sampling.Template`) and the same (cell, sample).
        Where the fields were written (:attr:`source`: the file's name, lines and positions) is
        not compared, so ``parse_scenario(s.to_yaml()) == s`` (pydantic's own equality compares
        the private attributes too, and a built scenario and its YAML read back differed there)."""
        if not isinstance(other, Scenario):
            return NotImplemented
        return self.__dict__ == other.__dict__ and self._sample == other._sample and self._template == other._template

    @property
    def template(self) -> Any:
        """The file's :class:`stackdsl.lang.sampling.Template` when it has random fields or a sweep
        (this scenario is then one of its samples: :attr:`sample`), else None."""
        return self._template

    @property
    def sample(self) -> tuple[int, int]:
        """(grid cell, sample index) of this scenario in its file's sweep; (0, 0) otherwise."""
        return self._sample

    def to_yaml(self) -> str:
        """This scenario as a YAML file that reads back to it (:mod:`stackdsl.lang.yaml_out`): SI
        numbers, fields at their defaults left out, parts as written; a scenario of a random file
        or a sweep as that file's data, distributions and all."""
        if self.template is not None:
            return yaml_text(dict(self.template.data))
        data = self.model_dump(mode="json", exclude_defaults=True)
        if "parts" in data.get("structure", {}):
            data["structure"] = data["structure"]["parts"]
        return yaml_text(metres_written(data))

    def material(self, name: str) -> Material:
        """A declared or built-in material. Raises KeyError for an unknown name."""
        return {**BUILTIN_MATERIALS, **self.materials}[name]

    def brick_type(self, name: str) -> BrickType:
        """A declared or built-in brick type, or ``NAME/2``: brick type NAME cut to half its length
        (a wall's closers). Raises KeyError for an unknown name."""
        types = {**BUILTIN_BRICKS, **self.brick_types}
        if name not in types and name.endswith(HALF) and name.removesuffix(HALF) in types:
            whole = types[name.removesuffix(HALF)]
            return whole.model_copy(update={"size": (whole.size[0] / 2, *whole.size[1:])})
        return types[name]


def reference_errors(s: Scenario) -> list[tuple[FieldPath, str]]:
    """Names that point nowhere: (field path, message) for each, in file order."""
    bricks = {**BUILTIN_BRICKS, **s.brick_types}
    problems = _declaration_errors(s)

    def brick(path: FieldPath, name: str) -> None:
        if name not in bricks:
            problems.append((path, f"unknown brick type {name!r}; known: {', '.join(sorted(bricks))}"))

    structure = s.structure
    layouts: list[tuple[FieldPath, Any]] = (
        [(path + (part.kind,), part.layout) for _, path, part in named_parts(structure.parts)]
        if structure.parts is not None
        else [(("structure", structure.layout_name or ""), getattr(structure, structure.layout_name or ""))]
    )
    if structure.parts is not None:
        problems += check_parts(structure.parts)
    impact_ids = [imp.id for imp in s.impacts if imp.id]
    for where, layout in layouts:
        if not isinstance(layout, list):
            brick(where + ("brick",), layout.brick)
            continue
        for i, b in enumerate(layout):
            brick(where + (i, "brick"), b.brick)
        problems += _duplicate_ids(where, layout, impact_ids)
    for i, imp in enumerate(s.impacts):
        brick(("impacts", i, "projectile"), imp.projectile)
    for i, action in enumerate(s.actions):
        if action.push is not None:
            brick(("actions", i, "push", "pusher"), action.push.pusher)
    n_bricks = s.structure.tower.levels * s.structure.tower.bricks_per_layer if s.structure.tower else 0
    if n_bricks > MAX_BRICKS:
        problems.append((("structure", "tower", "levels"), f"the tower has {n_bricks} bricks; at most {MAX_BRICKS} are allowed"))
    return problems


def _declaration_errors(s: Scenario) -> list[tuple[FieldPath, str]]:
    """The problems of the file's declarations, in file order: a brick type named as the wall's
    half of one (``NAME/2``), a brick type's or the ground's unknown material."""
    materials = {**BUILTIN_MATERIALS, **s.materials}
    problems: list[tuple[FieldPath, str]] = []
    for name, bt in s.brick_types.items():
        if name.endswith(HALF):  # the wall's half of a type: its length halved, derived, never given
            problems.append(
                (
                    ("brick_types", name),
                    f"a name ending {HALF!r} is the wall's half of a brick type ({name.removesuffix(HALF)!r} halved): "
                    "give this type another name",
                )
            )
        if bt.material not in materials:
            problems.append(
                (("brick_types", name, "material"), f"unknown material {bt.material!r}; known: {', '.join(sorted(materials))}")
            )
    if s.ground.material not in materials:
        problems.append(
            (("ground", "material"), f"unknown material {s.ground.material!r}; known: {', '.join(sorted(materials))}")
        )
    return problems


def _duplicate_ids(where: FieldPath, layout: list[Any], impact_ids: list[str]) -> list[tuple[FieldPath, str]]:
    """A problem at each brick of ``layout`` (a list of placed bricks at ``where``) whose id another
    brick of it or an impact (``impact_ids``) also has; a part's ids are prefixed by its name, so
    unique among parts."""
    ids = [b.id for b in layout if b.id] + impact_ids
    return [
        (where + (i, "id"), f"brick id {b.id!r} is used more than once")
        for i, b in enumerate(layout)
        if b.id and ids.count(b.id) > 1
    ]


def _written_at(scenario: Scenario, path: FieldPath) -> Any:
    """The value at ``path``, a field as a file writes it (``("structure", 1, "on")``: a part's
    ``on``, the parts written as the structure itself); None when there is none."""
    value: Any = scenario
    for seg in path:
        if isinstance(value, Structure) and value.parts is not None:
            value = value.parts
        if isinstance(value, list):
            value = value[seg] if isinstance(seg, int) and 0 <= seg < len(value) else None
        elif isinstance(value, dict):
            value = value.get(seg)
        else:
            value = getattr(value, str(seg), None)
    return value

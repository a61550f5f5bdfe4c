"""The scenario language's actions besides placing and throwing: pull a brick out (``remove``),
push with a pusher (``push``) and shake the ground (``shake``), each at a time like an impact's
("14 s" or "after level 13"), as pydantic models of :mod:`stackdsl.lang.schema`.

```yaml
actions:
  - remove: {brick: L05.2, at: after level 12, speed: 20 mm/s}
  - push: {target: {brick: d01, offset: [0, 0, 40 mm]}, direction: [1, 0, 0], speed: 0.1 m/s, distance: 30 mm, at: 1 s}
  - shake: {amplitude: 2 mm, frequency: 3 Hz, direction: [1, 0], duration: 2 s, at: after level 4}
```

Source: stackdsl's own (docs/design.md, "Actions").
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import AfterValidator, BeforeValidator, ConfigDict, Field, field_validator, model_validator

from .bounds import MAX_SIDE, Component, StrictModel, Vector3
from .grammar import AFTER_LEVEL, AFTER_PREVIOUS, LEVEL_NUMBER, AlsoAccepts, BodyId, given, json_pattern
from .schema_impacts import AfterLevel, _nonzero, _when
from .spelling import spelled
from .units import Frequency, Length, Speed, Time, frequency, length, quantity_pattern, speed, time, within

ID = r"^[A-Za-z0-9_.-]{1,40}$"


class AfterPrevious(StrictModel):
    """The moment one interval (``timing.interval``) after the action written before this one
    has ended: a pull once its brick is out, a push once its pusher stops, a shake once the
    ground is still. Source: stackdsl's own."""

    one_value = True  # a grid may give it whole

    after: Literal["the previous action"]


def _action_when(value: Any) -> Any:
    """An impact's time, or ``"after the previous action"`` -> :class:`AfterPrevious`."""
    if isinstance(value, str) and re.fullmatch(AFTER_PREVIOUS, value):
        return AfterPrevious(after="the previous action")
    try:
        return _when(value)
    except ValueError as exc:
        if not str(exc).startswith("expected a time such as"):
            raise  # a level out of range, or a negative time: said as such
        raise ValueError(
            f"expected a time such as '14 s', 'after level N' or 'after the previous action', got {spelled(value)}"
        ) from None


ActionWhen = Annotated[
    AfterPrevious | AfterLevel | Annotated[float, Field(ge=0)],
    BeforeValidator(_action_when),
    AlsoAccepts(
        (
            {"type": "string", "pattern": quantity_pattern("non-negative")},
            {"type": "string", "pattern": json_pattern(AFTER_LEVEL, LEVEL_NUMBER)},
            {"type": "string", "pattern": f"^{AFTER_PREVIOUS}$"},
        ),
        "a time >= 0 ('14 s'), 'after level N' or 'after the previous action' (one interval after it ends)",
    ),
]

#: Steps of the physics a shake's period must span at least; the compiler checks a frequency
#: against the run's own timestep (at the default 1/240 s, at most 48 Hz).
SAMPLES_A_PERIOD = 5
#: Hz, the fastest shake at any timestep: 5 samples a period at the shortest, 0.01 ms.
MAX_SHAKE_FREQUENCY = 20000.0
#: Metres a hand's path (a pull's or a push's distance) may be at most: it moves within the scene.
MAX_TRAVEL = 1.0

if TYPE_CHECKING:
    GuideSpeed = float
    Travel = float
    Amplitude = float
    ShakeFrequency = float
    ShakeDuration = float
    PusherGap = float
else:
    GuideSpeed = within(
        Speed,
        speed,
        0.001,
        10.0,
        "a speed from 1 mm/s to 10 m/s",
        ("slower, a pull of a brick's length outlasts any run", "faster, a hand is a projectile: use an impact"),
    )
    Travel = within(
        Length, length, 0.0, MAX_TRAVEL, "a length above 0 and at most 1 m", "a hand moves within the scene", above=True
    )
    Amplitude = within(
        Length, length, 0.0, 0.1, "a length above 0 and at most 100 mm", "shake tables move within 100 mm", above=True
    )
    ShakeFrequency = within(
        Frequency,
        frequency,
        0.1,
        MAX_SHAKE_FREQUENCY,
        "a frequency of 0.1 Hz or more that the run's timestep samples 5 times a period (48 Hz at the default "
        "1/240 s, 20 kHz at the shortest, 0.01 ms)",
        ("slower, a shake is a slow slide", "faster, the shortest timestep, 0.01 ms, samples a period fewer than 5 times"),
    )
    ShakeDuration = within(
        Time,
        time,
        0.0,
        600.0,
        "a time above 0 and at most 600 s",
        ("a shake that lasts no time moves nothing", "a run lasts at most 3600 s"),
        above=True,
    )

    PusherGap = within(Length, length, 0.0, MAX_SIDE, "a length from 0 to 10 m")

Direction = Annotated[tuple[Component, Component, Component], AfterValidator(_nonzero)]
AXES = {"+x": (1.0, 0.0, 0.0), "-x": (-1.0, 0.0, 0.0), "+y": (0.0, 1.0, 0.0), "-y": (0.0, -1.0, 0.0)}


class Remove(StrictModel):
    """Pull a structure brick out, as a hand does in Jenga: a kinematic gripper takes ``brick`` at
    ``at`` and moves it along ``direction`` at a constant ``speed`` for ``distance``, then takes it
    out of the scene. What rests on it feels the pull through friction."""

    brick: Annotated[str, Field(pattern=ID, description="the id of the brick to pull out", examples=["L05.2"])]
    at: Annotated[
        ActionWhen, Field(description="when the pull starts", examples=["after level 12", "14 s", "after the previous action"])
    ]
    direction: Annotated[
        Literal["+x", "-x", "+y", "-y"] | Direction | None,
        Field(
            description="the pull's direction in the world, horizontal ('+x', '-x', '+y', '-y' or [x, y, 0], "
            "any length): the hand slides the brick out sideways; default: along the brick's own length (its +x), "
            "which must then be horizontal",
            examples=["+x", [0, 1, 0]],
        ),
    ] = None
    speed: Annotated[
        GuideSpeed,
        Field(
            description="how fast the hand pulls: at most 10 m/s, and no faster than the run's engine follows a pulled "
            "brick in its mode (docs/results/limits.md, 'Pulls')",
            examples=["20 mm/s"],
        ),
    ] = 0.02
    distance: Annotated[
        Travel | None,
        Field(
            description="how far the hand pulls, at least the brick's extent along the pull (it is then clear of where "
            "it lay); default: the brick's length plus 10 mm (it clears the bricks it lay between)",
            examples=["130 mm"],
        ),
    ] = None


class PushTarget(StrictModel):
    """What a pusher aims at: a ``brick`` (its centre, moved by ``offset``) or a ``point``."""

    one_value = True  # a grid may give it whole

    model_config = ConfigDict(json_schema_extra={"oneOf": [given("brick"), given("point")]})

    brick: Annotated[str, Field(pattern=ID)] | None = Field(
        default=None, description="the id of the brick pushed", examples=["d01"]
    )
    offset: Annotated[
        Vector3,
        Field(description="from the brick's centre to the point aimed at, in the world's axes", examples=[[0, 0, "40 mm"]]),
    ] = (0.0, 0.0, 0.0)
    point: Annotated[Vector3 | None, Field(description="a point aimed at, in the world", examples=[[0, 0, "50 mm"]])] = None

    @model_validator(mode="after")
    def _one(self) -> PushTarget:
        if (self.brick is None) == (self.point is None):
            raise ValueError("give a 'brick' (and an 'offset') or a 'point', one of them")
        if self.point is not None and self.offset != (0.0, 0.0, 0.0):
            raise ValueError("an 'offset' moves a brick's centre: give it with 'brick', not with 'point'")
        return self


class Push(StrictModel):
    """A pusher (a box of ``pusher``, a brick type) enters ``gap`` before the target's surface and
    moves at a constant ``speed`` along ``direction`` for ``distance``, long axis first, then is
    withdrawn: a robot's finger, a bulldozer's blade."""

    target: Annotated[PushTarget, Field(description="what is pushed: {brick: ID, offset} or {point: [x, y, z]}")]
    direction: Annotated[
        Literal["+x", "-x", "+y", "-y"] | Direction,
        Field(description="the push's direction ('+x', '-x', '+y', '-y' or [x, y, z], any length)", examples=["+x", [1, 0, 0]]),
    ]
    at: Annotated[ActionWhen, Field(description="when the pusher enters and starts to move", examples=["1 s", "after level 3"])]
    speed: Annotated[
        GuideSpeed,
        Field(
            description="how fast the pusher moves: at most 10 m/s, and no faster than the run's engine follows "
            "a pushed brick in its mode (docs/results/limits.md)",
            examples=["0.1 m/s"],
        ),
    ] = 0.05
    distance: Annotated[Travel, Field(description="how far the pusher moves", examples=["30 mm"])] = 0.03
    gap: Annotated[
        PusherGap, Field(description="from the pusher's front to the target's surface at the start", examples=["5 mm"])
    ] = 0.005
    pusher: Annotated[str, Field(description="the pusher's brick type (its size)", examples=["kapla", "finger"])] = "kapla"
    id: BodyId | None = Field(
        default=None,
        description="the pusher's id in the timeline; by default pusher1, pusher2, ... in the order the pushes are written",
        examples=["finger"],
    )


class Shake(StrictModel):
    """The ground moves as a shake table: along ``direction`` by ``amplitude (1 - cos(2 pi f t))``
    for ``duration`` (rounded to whole periods, at least one, that fill whole timesteps: the
    frequency is fitted to them), starting and ending at rest where it started. Its peak
    acceleration is ``amplitude (2 pi frequency)^2``."""

    amplitude: Annotated[
        Amplitude,
        Field(
            description="half the table's stroke: above 0, at most 100 mm, and the table's peak acceleration "
            "(amplitude x (2 pi frequency)^2) at most 9.81 m/s^2, what the engines follow (docs/results/shake-table.md)",
            examples=["2 mm"],
        ),
    ]
    frequency: Annotated[
        ShakeFrequency,
        Field(
            description="periods a second, from 0.1 Hz to what the timestep samples 5 times a period "
            "(48 Hz at 1/240 s, 200 Hz at 1 ms; rpm or rad/s are turned into Hz)",
            examples=["3 Hz"],
        ),
    ]
    duration: Annotated[
        ShakeDuration, Field(description="how long it shakes, rounded to whole periods: above 0, at most 600 s", examples=["2 s"])
    ]
    at: Annotated[ActionWhen, Field(description="when the shake starts", examples=["after level 4", "5 s"])]
    direction: Annotated[
        Literal["+x", "-x", "+y", "-y"] | tuple[Component, Component],
        AfterValidator(lambda d: AXES[d][:2] if isinstance(d, str) else _nonzero((*d, 0.0))[:2]),
        Field(
            description="the horizontal direction of the motion ('+x', '-x', '+y', '-y' or [x, y], any length)",
            examples=["+y", [1, 0]],
        ),
    ] = (1.0, 0.0)

    def whole_periods(self) -> int:
        """The whole periods the shake lasts: its duration times its frequency, half a period
        rounded up (0.5 s at 1 Hz is one period, 2.5 s three), as the refusal below says; Python's
        ``round`` rounds a half to the even number, and made 0.5 s at 1 Hz none and 2.5 s two.

        >>> Shake(amplitude=0.01, frequency=1.0, duration=2.5, at=1.0).whole_periods()
        3
        """
        return math.floor(self.duration * self.frequency + 0.5 + 1e-9)

    @model_validator(mode="after")
    def _a_period_at_least(self) -> Shake:
        periods = self.duration * self.frequency
        if self.whole_periods() < 1:  # it would round to none, and be made one: 0.1 s at 2 Hz lasted 0.5 s
            raise ValueError(
                f"a shake lasts whole periods: {self.duration:g} s at {self.frequency:g} Hz is {periods:.2g} of a period, "
                f"which rounds to none; give at least half a period ({0.5 / self.frequency:g} s, made one, "
                f"{1 / self.frequency:g} s long), or a higher frequency"
            )
        return self


class Action(StrictModel):
    """One action: exactly one of ``remove``, ``push`` or ``shake``."""

    model_config = ConfigDict(json_schema_extra={"oneOf": [given("remove"), given("push"), given("shake")]})

    remove: Annotated[Remove | None, Field(description="a mapping of brick, at, direction, speed and distance")] = None
    push: Annotated[Push | None, Field(description="a mapping of target, direction, at, speed, distance, pusher, gap and id")] = (
        None
    )
    shake: Annotated[Shake | None, Field(description="a mapping of amplitude, frequency, direction, duration and at")] = None

    @field_validator("remove", "push", "shake", mode="before")
    @classmethod
    def _written(cls, value: Any) -> Any:
        """A kind written with nothing after it (``- remove:``) is refused at its key, not as an
        action of no kind."""
        if value is None:
            raise ValueError("expected a mapping of its fields, got nothing (null)")
        return value

    @model_validator(mode="after")
    def _one(self) -> Action:
        given_ = [k for k in ("remove", "push", "shake") if getattr(self, k) is not None]
        if len(given_) != 1:
            raise ValueError(f"an action is one of 'remove', 'push' or 'shake', got {', '.join(given_) or 'none'}")
        return self

    @property
    def kind(self) -> str:
        """``"remove"``, ``"push"`` or ``"shake"``."""
        return "remove" if self.remove else "push" if self.push else "shake"

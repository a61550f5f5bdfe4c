"""The Program: a scenario compiled to time-ordered concrete actions, no generators left.

Everything here is SI (metres, seconds, kilograms, m/s), angles in degrees. Every
action carries the physics step it happens at; its time is that step times the timestep.

The work of a run (:func:`estimate_work`, :attr:`Program.work`) is counted in
*body-steps*: one body in the engine for one physics step (or substep). A moving body
counts ``max(1, solver_iterations / 50)`` a step, a resting one (a fixture, a brick the
extension froze) 1, and every step 1 more for the runtime's own loop:

* raw and tuned modes step every body every step: each brick from when it is placed
  to the end of the run, moving;
* extension mode steps only while something is active and jumps over the rest: after
  each placement, for the brick's fall from the drop gap plus :data:`SETTLING` plus the
  rest duration (a group placed ``together``: that many times its size), with every
  brick placed before it in the engine, resting; the equilibrium model adds
  :data:`EQUILIBRIUM_SOLVE` x (frozen bricks)^3 each time a brick freezes;
* a projectile: from its launch to :data:`IMPACT_WINDOW` after its arrival every body
  counts as moving, and during its flight in as many substeps as its speed needs
  (continuous collision detection on: speed x timestep / collapse threshold, at most
  :data:`MAX_SUBSTEPS`);
* a pull, a push or a shake: every body placed by then moving for its duration (the pusher too),
  in the substeps the runtime splits its steps into (a pull with the extension on pybullet in
  steps of :data:`PULL_STEP`; a hand as fast as a thrown brick as one is).

:func:`Work.seconds` turns the three parts into a wall time with constants measured on a
2-core machine (a guess good to a factor of about two: contacts, collapses and the load
of the machine change it).

Source: stackdsl's own (docs/design.md, data flow; the work budget).
"""

from __future__ import annotations

import itertools
import math
import os
from collections.abc import Callable
from typing import Annotated, Any, Literal, NamedTuple

from pydantic import BaseModel, ConfigDict, Field, PlainSerializer

from stability import StabilityConfig

from ..engines.protocol import BrickSpec, Vec3
from ..engines.registry import backend
from ..engines.settings import AnySettings


def clean_seconds(seconds: float) -> float:
    """``seconds`` without float noise: the shortest decimal of at most 12 figures within 4 units
    in the last place of it, else ``seconds`` itself. Three intervals of 0.7 s sum to 2.0999999999999996 s, which a
    reader means as 2.1; a time with no short decimal near it (14 steps of 1/240 s) is kept.
    Source: stackdsl's own.

    >>> clean_seconds(3 * 0.7), clean_seconds(14 / 240), clean_seconds(0.0)
    (2.1, 0.058333333333333334, 0.0)
    """
    if seconds == 0 or not math.isfinite(seconds):
        return seconds
    for digits in range(1, 13):
        short = float(f"{seconds:.{digits}g}")
        if abs(short - seconds) <= 4 * math.ulp(seconds):
            return short
    return seconds


Seconds = Annotated[float, PlainSerializer(clean_seconds, return_type=float, when_used="json")]
"""A time in seconds, written to JSON without float noise (:func:`clean_seconds`); in Python the
value is as computed, so what the run does does not change."""


#: A physics step is split into at most this many substeps, however fast a body moves
#: (:mod:`stackdsl.runtime.run`).
MAX_SUBSTEPS = 64
PULL_STEP = 1 / 960
"""Seconds, the longest substep while a hand pulls a brick out with the extension acting
(:attr:`stackdsl.runtime.subscribers.Substeps.floor`): the pulled brick's friction drags what
rests on it, and a finer step follows that friction more closely. pybullet's world steps the
substeps one call each, the pulled brick driven before each
(:meth:`stackdsl.engines.pybullet.world.PyBulletWorld.step`), so that a split pull ends as the
scene stepped at 1/960 s throughout (docs/actions.md, "Pull"). On pybullet only: MuJoCo's
guided brick, its velocity set once a step, slips under what it carries when the step is
split. Source: stackdsl's own."""
#: Solver iterations of a reference body-step (pybullet's default, raw mode's).
REFERENCE_ITERATIONS = 50
#: Seconds a brick placed in extension mode stays active besides its fall and the rest
#: duration, bouncing and settling (measured: 15 to 18 steps of 1/240 s a brick of a tower).
SETTLING = 0.02
#: Seconds after a projectile's arrival during which every body counts as moving.
IMPACT_WINDOW = 1.0
#: Body-steps per frozen brick cubed of the equilibrium model's solve each time a brick
#: freezes (a linear program over every frozen brick; fitted on 4 stacks: 200 bricks 4.8 s,
#: 500 bricks over 150 s of CPU, against 0.7 and 7 s with the report's model).
EQUILIBRIUM_SOLVE = 0.006
#: Wall seconds a run costs besides its steps (a pybullet client, the bodies, the graph).
SECONDS_PER_RUN = 0.02
#: Wall seconds of the runtime's loop per step (measured, see :class:`Work`).
SECONDS_PER_STEP = 2e-5
#: Wall seconds per body-step of a moving body (measured on towers in raw and tuned mode:
#: 1.7e-5 standing, 3.9e-5 collapsing).
SECONDS_PER_MOVING = 3e-5
#: Wall seconds per body-step of a resting body in extension mode (measured on towers of
#: 200 to 2000 bricks; most of it is the stack-wide test each time a brick freezes).
SECONDS_PER_RESTING = 2.3e-6


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Place(_Frozen):
    """Put brick ``id`` of ``level`` into the world at rest, ``drop`` metres above its pose."""

    kind: Literal["place"] = "place"
    step: int
    time: Seconds
    id: str
    level: int
    brick: BrickSpec
    position: Vec3
    yaw: float
    pitch: float
    roll: float
    drop: float


class Launch(_Frozen):
    """Throw projectile ``id`` from ``position`` with ``velocity``; it reaches ``target`` at ``arrival``.

    A throw at a level's side also names its ``aim``: the brick whose face ``target`` is the middle
    of, as placed, then the level's other bricks there to aim at, and the outward normal of the
    ``face`` hit. The run moves the throw by as much as that face has moved when it is thrown
    (:mod:`stackdsl.runtime.aim`); a throw at a point has neither.
    """

    kind: Literal["launch"] = "launch"
    step: int
    time: Seconds
    id: str
    brick: BrickSpec
    position: Vec3
    yaw: float
    pitch: float
    velocity: Vec3
    target: Vec3
    arrival: Seconds
    aim: tuple[str, ...] = ()
    face: Vec3 | None = None

    def arrival_speed(self, gravity: float = 9.81) -> float:
        """m/s the projectile moves at when it reaches ``target``: its ``velocity`` with what
        ``gravity`` (m/s^2) added in its flight from ``time`` to ``arrival`` (a slow throw arrives
        faster and steeper than it was thrown)."""
        vx, vy, vz = self.velocity
        return math.sqrt(vx * vx + vy * vy + (vz - gravity * (self.arrival - self.time)) ** 2)


class Fixture(_Frozen):
    """An immovable environment body (a wall, a ramp), in the world from the start."""

    id: str
    brick: BrickSpec
    position: Vec3
    yaw: float
    pitch: float
    roll: float


class PartSummary(_Frozen):
    """One named part of a composed structure, as placed: its layout, what it rests on
    (``"ground"``, parts' names or a brick's id), its bricks (the first and last ids, how many,
    fixtures included) and the levels they take."""

    name: str
    layout: str
    on: str
    bricks: int
    first: str
    last: str
    levels: tuple[int, int]


class Rule(_Frozen):
    """A rule of the extension mode and whether this scene runs it, with why: the stability
    extension's ``basic``, ``leaning`` and ``impacts`` rules, ``rigid``, fallen bricks
    settling as cheaper bodies once a collapse is decided
    (:class:`stackdsl.runtime.subscribers.CheapDebris`), ``guided``, bodies moved by a hand (a
    pulled brick, a pusher) waking what they carry and touch, and ``shake``, the frozen stack
    checked under the ground's peak acceleration (:mod:`stackdsl.runtime.actions`)."""

    name: Literal["basic", "leaning", "impacts", "rigid", "guided", "shake"]
    on: bool
    reason: str


class Remove(_Frozen):
    """Pull structure brick ``id`` out at ``velocity`` (m/s) from ``step`` until ``end_step``, a
    kinematic gripper; then the hand takes it out of the scene. Source: stackdsl's own."""

    kind: Literal["remove"] = "remove"
    step: int
    time: Seconds
    id: str
    velocity: Vec3
    end_step: int
    end_time: Seconds


class Push(_Frozen):
    """A pusher ``id``, a box of ``brick``, enters at ``position`` (turned ``yaw``, ``pitch``)
    and moves at ``velocity`` (m/s) until ``end_step``, into ``target`` (a brick id or a point,
    as words); then it is withdrawn. Source: stackdsl's own."""

    kind: Literal["push"] = "push"
    step: int
    time: Seconds
    id: str
    brick: BrickSpec
    position: Vec3
    yaw: float
    pitch: float
    velocity: Vec3
    target: str
    end_step: int
    end_time: Seconds


class Shake(_Frozen):
    """The ground moves horizontally along unit ``direction`` (x, y) by
    ``amplitude * (1 - cos(2 pi frequency (t - time)))`` (m) from ``step`` to ``end_step``:
    ``periods`` whole periods in whole steps, starting and ending at rest where it started (the
    frequency is the one written, fitted so that the periods fill the steps exactly; the written
    one is ``written_frequency`` when they differ). Its peak acceleration is
    ``amplitude * (2 pi frequency)^2``. Source: stackdsl's own."""

    kind: Literal["shake"] = "shake"
    step: int
    time: Seconds
    amplitude: float
    frequency: float
    periods: int = 1
    written_frequency: float | None = None
    direction: tuple[float, float]
    end_step: int
    end_time: Seconds

    @property
    def peak_acceleration(self) -> float:
        """m/s^2, the ground's largest acceleration: A (2 pi f)^2."""
        return self.amplitude * (2 * math.pi * self.frequency) ** 2

    def at(self, t: float) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The ground's offset (m) and velocity (m/s) at ``t`` seconds (0 outside the shake)."""
        if not self.time <= t <= self.end_time:
            return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        w = 2 * math.pi * self.frequency
        x = self.amplitude * (1 - math.cos(w * (t - self.time)))
        v = self.amplitude * w * math.sin(w * (t - self.time))
        dx, dy = self.direction
        return (x * dx, x * dy, 0.0), (v * dx, v * dy, 0.0)


Kinematic = Remove | Push | Shake
"""The actions that move something kinematically for a while (:mod:`stackdsl.runtime.actions`)."""


class End(_Frozen):
    """The run ends."""

    kind: Literal["end"] = "end"
    step: int
    time: Seconds


Action = Annotated[Place | Launch | Remove | Push | Shake | End, Field(discriminator="kind")]


class Program(_Frozen):
    """A compiled scenario.

    Attributes:
        name: the scenario's name.
        engine: the engine's settings (:mod:`stackdsl.engines.settings`).
        ground_friction, ground_restitution: of the ground plane's material.
        stability: the stability extension's settings, fully resolved: the scenario's,
            the engine's gravity, and the rules this scene needs (``leaning``, ``impacts``).
        rules: the extension mode's rules this scene needs (model only what a scene needs).
        fixtures: environment bodies, created first.
        collapse_threshold: metres a structure brick may leave its placed pose.
        settle: seconds the run goes on after the first collapse.
        actions: time-ordered; the last one is :class:`End`.
        floating: ids of the bricks placed resting on nothing, which the scenario allows
            (``allow: [floating]``); they drop when placed.
        draws: how many draws of a random scene its sample took to meet ``require:`` (1 without).
        parts: the named parts of a composed structure, in order (none for a single layout).
        judged_at: the moment the scenario's expectations judge
            (:attr:`stackdsl.lang.expectations.Expect.judged_at`): ``"end"`` (final positions),
            or ``"collapse"`` (the collapse when there is one, else the end); pictures, replays
            and exports show it unless told another.
        watch_motion: the run measures the structure's largest tilt and slip
            (:class:`stackdsl.runtime.motion.PeakMotion`): the expectation ``still:`` judges them.
    """

    name: str
    engine: AnySettings
    ground_friction: float
    ground_restitution: float
    stability: StabilityConfig
    rules: tuple[Rule, ...]
    fixtures: tuple[Fixture, ...] = ()
    collapse_threshold: float
    settle: Seconds
    actions: tuple[Action, ...]
    floating: tuple[str, ...] = ()
    draws: int = 1
    parts: tuple[PartSummary, ...] = ()
    judged_at: Literal["collapse", "end"] = "collapse"
    watch_motion: bool = False

    @property
    def placements(self) -> list[Place]:
        """The :class:`Place` actions, in order."""
        return [a for a in self.actions if isinstance(a, Place)]

    @property
    def kinematic(self) -> list[Kinematic]:
        """The :class:`Remove`, :class:`Push` and :class:`Shake` actions, in order."""
        return [a for a in self.actions if isinstance(a, (Remove, Push, Shake))]

    @property
    def shakes(self) -> bool:
        """Whether the ground moves (a :class:`Shake`): the world is made with a movable ground."""
        return any(isinstance(a, Shake) for a in self.actions)

    @property
    def levels(self) -> int:
        """The highest level placed."""
        return max((a.level for a in self.placements), default=0)

    @property
    def duration(self) -> float:
        """Simulated seconds until :class:`End`."""
        return self.actions[-1].time

    @property
    def work(self) -> float:
        """Body-steps the run is estimated to take (:func:`estimate_work`; the compiler's
        budget, :data:`stackdsl.compile.compiler.MAX_WORK`, bounds it)."""
        return estimate_work(self).total

    @property
    def wall_estimate(self) -> float:
        """Seconds of wall time the run is estimated to take (:meth:`Work.seconds`)."""
        return estimate_work(self).seconds


def require_program(value: object, caller: str) -> Program:
    """``value``, a compiled :class:`Program`, for the public function ``caller`` (its name,
    for the message).

    Raises:
        TypeError: ``value`` is not a Program; the message says how to get one from what it is
            (a Scenario: ``compile_scenario``; a file name: ``load_scenario`` first).
    """
    if isinstance(value, Program):
        return value
    kind = type(value).__name__
    if kind == "Scenario":
        how = "compile it first: compile_scenario(scenario)"
    elif isinstance(value, (str, os.PathLike)):
        how = "read the file with load_scenario(path), then compile_scenario(scenario)"
    else:
        how = "compile_scenario(load_scenario(path)) makes one"
    raise TypeError(f"{caller} takes a compiled Program, not {kind}: {how}")


class Work(NamedTuple):
    """The estimated work of a run, in body-steps (see the module's docstring).

    Attributes:
        steps: physics steps and substeps the engine takes (jumps left out).
        moving: body-steps of moving bodies, weighted by solver iterations.
        resting: body-steps of resting bodies (fixtures, frozen bricks).
    """

    steps: float
    moving: float
    resting: float

    @property
    def total(self) -> float:
        """Body-steps: the runtime's loop counts one a step."""
        return self.steps + self.moving + self.resting

    @property
    def seconds(self) -> float:
        """Estimated wall seconds on the machine the constants were measured on (2 cores,
        shared): :data:`SECONDS_PER_RUN` and :data:`SECONDS_PER_STEP`,
        :data:`SECONDS_PER_MOVING` and :data:`SECONDS_PER_RESTING` per part."""
        parts = self.steps * SECONDS_PER_STEP + self.moving * SECONDS_PER_MOVING + self.resting * SECONDS_PER_RESTING
        return SECONDS_PER_RUN + parts


def estimate_work(program: Program) -> Work:
    """The work of running ``program`` (see the module's docstring): an upper bound for a
    structure that stands, in the order of magnitude of the real cost otherwise.

    In raw and tuned modes a collapse ends the run early, so the estimate is an upper
    bound; in extension mode the bricks a collapse wakes move for ``settle`` seconds
    (not counted: a run's timeout bounds it). Source: stackdsl's own.
    """
    e = program.engine
    weight = max(1.0, e.solver_iterations / REFERENCE_ITERATIONS)
    entries = [a for a in program.actions if isinstance(a, (Place, Launch))]
    work = _entry_work(program, entries, weight)
    work = _guided_work(program, entries, weight, work)
    return _flight_work(program, entries, weight, work)


def _entry_work(program: Program, entries: list[Place | Launch], weight: float) -> Work:
    """The work of the bricks placed and thrown (``entries``; ``weight``: the solver iterations'
    factor) and of the fixtures: in raw and tuned modes every body steps to the end; in extension
    mode a brick moves only while it falls and settles after its placement, and the bricks at rest
    are counted once each while others move (plus the equilibrium model's solve)."""
    e = program.engine
    dt = e.timestep
    end = program.actions[-1].step
    fixtures = len(program.fixtures)
    if e.mode != "extension":
        return Work(float(end), weight * sum(end - a.step for a in entries), float(fixtures * end))
    rest = program.stability.rest_duration
    drop = max((a.drop for a in program.placements), default=0.0)
    active = math.ceil((math.sqrt(2 * drop / e.gravity) + SETTLING + rest) / dt)
    slots: dict[int, int] = {}
    for a in program.placements:
        slots[a.step] = slots.get(a.step, 0) + 1
    marks = sorted({*slots, *(a.step for a in entries), end})
    steps = moving = resting = 0.0
    present = fixtures
    solve = EQUILIBRIUM_SOLVE if program.stability.model == "equilibrium" else 0.0
    for step, following in itertools.pairwise(marks):
        placed = slots.get(step, 0)
        stepped = min(following - step, active * placed)
        steps += stepped
        moving += stepped * weight * placed
        resting += stepped * present + solve * placed * present**3
        present += placed
    return Work(steps, moving, resting)


def _guided_work(program: Program, entries: list[Place | Launch], weight: float, work: Work) -> Work:
    """``work`` plus that of the substeps a hand's path (a pull, a push) or a shake needs: every
    body moving while it lasts, in extension mode too (raw and tuned: the extra substeps only)."""
    e = program.engine
    steps, moving, resting = work
    fixtures = len(program.fixtures)
    for motion in (
        a for a in program.actions if isinstance(a, (Remove, Push, Shake))
    ):  # every body moving, in extension mode too, in the substeps a hand's path needs
        span = motion.end_step - motion.step
        present = sum(a.step <= motion.step for a in entries) + (1 if isinstance(motion, Push) else 0)
        substeps = _guided_substeps(program, motion)
        if e.mode == "extension":
            steps += span * substeps
            moving += span * substeps * weight * present
        else:  # raw, tuned: every step counted above, the extra substeps here
            steps += span * (substeps - 1)
            moving += span * (substeps - 1) * weight * (present - isinstance(motion, Push))
            moving += span * substeps * weight * isinstance(motion, Push)
            resting += span * (substeps - 1) * fixtures
    return Work(steps, moving, resting)


def _flight_work(program: Program, entries: list[Place | Launch], weight: float, work: Work) -> Work:
    """``work`` plus that of each throw's flight and impact: its substeps (continuous collision
    detection on), and in extension mode every body stepped through the flight and the impact's
    window (raw, tuned: counted already)."""
    e = program.engine
    dt = e.timestep
    end = program.actions[-1].step
    fixtures = len(program.fixtures)
    steps, moving, resting = work
    for launch in (a for a in entries if isinstance(a, Launch)):
        speed = math.sqrt(sum(v * v for v in launch.velocity))
        substeps = min(MAX_SUBSTEPS, max(1, math.ceil(speed * dt / program.collapse_threshold))) if e.ccd else 1
        flight = max(1, math.ceil((launch.arrival - launch.time) / dt))
        after = max(0, min(end, math.ceil((launch.arrival + IMPACT_WINDOW) / dt)) - launch.step - flight)
        extra = (substeps - 1) * flight + (0 if e.mode != "extension" else flight + after)  # raw, tuned: counted above
        steps += extra
        moving += extra * weight * sum(a.step <= launch.step for a in entries)
        resting += extra * fixtures
    return Work(steps, moving, resting)


def _guided_substeps(program: Program, motion: Remove | Push | Shake) -> int:
    """The substeps of a step while ``motion`` lasts, as the runtime splits them: a pull in
    steps of at most :data:`PULL_STEP` (the extension acting on pybullet), a hand's path in
    substeps in which it moves at most the collapse threshold (continuous collision detection
    on), at most :data:`MAX_SUBSTEPS`; 1 for a shake."""
    if isinstance(motion, Shake):
        return 1
    e = program.engine
    pull = isinstance(motion, Remove) and e.mode == "extension" and backend(e.backend).split_pulls
    split = math.ceil(e.timestep / PULL_STEP - 1e-9) if pull else 1
    speed = math.sqrt(sum(v * v for v in motion.velocity))
    fast = math.ceil(speed * e.timestep / program.collapse_threshold - 1e-9) if e.ccd else 1
    return min(MAX_SUBSTEPS, max(split, fast, 1))


def _mm(metres: float) -> float:
    """Millimetres to one decimal as printed, without a sign on zero (-0.0 mm reads as a mistake)."""
    return round(metres * 1000, 1) + 0.0


def _threshold_source(program: Program) -> str:
    """Where a default collapse threshold comes from, when it is half the thinnest side of a
    brick type of the scene (a part of thinner bricks lowers it for every part)."""
    if len({p.brick.type for p in program.placements}) < 2:
        return ""
    half, kind = min((min(p.brick.half_extents), p.brick.type) for p in program.placements)
    return f" (half the thinnest side, of {kind})" if half == program.collapse_threshold else ""


def format_program(program: Program) -> str:
    """The program as text, one line per action (what ``stackdsl compile`` prints)."""
    e = program.engine
    lines = [
        f"program {program.name}: {e.backend}, mode {e.mode}, timestep {e.timestep * 1000:.4g} ms, "
        f"{e.solver_iterations} solver iterations, {e.details()}",
        f"  {len(program.placements)} brick{'' if len(program.placements) == 1 else 's'} in {program.levels} "
        f"level{'' if program.levels == 1 else 's'}, collapse threshold "
        f"{program.collapse_threshold * 1000:.3g} mm{_threshold_source(program)}, {program.duration:.2f} s simulated",
        f"  estimated work {program.work:.2g} body-steps, about {program.wall_estimate:.2g} s of wall time",
    ]
    if e.mode == "extension":
        lines.append(f"  stability model {program.stability.model}")
        lines += [f"  rule {r.name:<8} {'on ' if r.on else 'off'}  {r.reason}" for r in program.rules]
    for p in program.parts:
        low, high = p.levels
        levels = f"level {low}" if low == high else f"levels {low}-{high}"
        lines.append(
            f"  part   {p.name:<10} {p.layout:<10} on {p.on}: {p.bricks} brick{'s' * (p.bricks != 1)}, {p.first} to {p.last}, {levels}"
        )
    if program.draws > 1:
        lines.append(f"  require: the sample met its conditions at draw {program.draws}")
    if program.floating:
        lines.append(f"  resting on nothing when placed, allowed (allow: [floating]): {', '.join(program.floating)}")
    for f in program.fixtures:
        x, y, z = (_mm(v) for v in f.position)
        lines.append(
            f"  fixed  {f.id:<10} at ({x:.1f}, {y:.1f}, {z:.1f}) mm  yaw {f.yaw:.1f}  pitch {f.pitch:.1f}  roll {f.roll:.1f}  {f.brick.type}"
        )
    for a in program.actions:
        head = f"  t={a.time:9.3f} s  step {a.step:>8}  "
        line = _ACTION_LINES.get(type(a))
        lines.append(head + (line(a) if line is not None else "end"))
    return "\n".join(lines)


def _place_line(a: Place) -> str:
    """A placement as ``stackdsl compile`` prints it (after its time and step)."""
    x, y, z = (_mm(v) for v in a.position)
    return (
        f"place  {a.id:<10} level {a.level:>3}  at ({x:8.1f}, {y:8.1f}, {z:7.1f}) mm  "
        f"yaw {a.yaw:6.1f}  pitch {a.pitch:5.1f}  roll {a.roll:5.1f}  {a.brick.type}"
    )


def _launch_line(a: Launch) -> str:
    """A throw as ``stackdsl compile`` prints it."""
    x, y, z = (_mm(v) for v in a.target)
    speed = sum(v * v for v in a.velocity) ** 0.5
    return (
        f"launch {a.id:<10} {speed:.3g} m/s aimed at ({x:.1f}, {y:.1f}, {z:.1f}) mm, arriving t={a.arrival:.3f} s at "
        f"{a.arrival_speed():.3g} m/s  {a.brick.type}"
    )


def speed_words(metres_a_second: float) -> str:
    """A speed as a scenario writes it: ``40 mm/s`` under 1 m/s (as pulls and pushes are
    written), else ``1.5 m/s`` (``1e+03 mm/s`` read as an error). Source: stackdsl's own.

    >>> speed_words(0.04), speed_words(1.0), speed_words(0.1234)
    ('40 mm/s', '1 m/s', '123 mm/s')
    """
    if metres_a_second < 1.0:
        return f"{metres_a_second * 1000:.3g} mm/s"
    return f"{metres_a_second:.3g} m/s"


def _remove_line(a: Remove) -> str:
    """A pull as ``stackdsl compile`` prints it."""
    speed = math.sqrt(sum(v * v for v in a.velocity))
    direction = ", ".join(f"{round(v / speed, 9) + 0.0:.3g}" for v in a.velocity)
    return f"remove {a.id:<10} pulled along ({direction}) at {speed_words(speed)} until t={a.end_time:.3f} s"


def _push_line(a: Push) -> str:
    """A push as ``stackdsl compile`` prints it."""
    x, y, z = (v * 1000 for v in a.position)
    speed = math.sqrt(sum(v * v for v in a.velocity))
    return (
        f"push   {a.id:<10} from ({x:.1f}, {y:.1f}, {z:.1f}) mm at {speed_words(speed)} into {a.target} "
        f"until t={a.end_time:.3f} s  {a.brick.type}"
    )


def _shake_line(a: Shake) -> str:
    """A shake of the ground as ``stackdsl compile`` prints it."""
    fitted = (
        ""
        if a.written_frequency is None
        else f" ({a.written_frequency:g} Hz fitted to {a.periods} period{'s' * (a.periods != 1)} in {a.end_step - a.step} steps)"
    )
    return (
        f"shake  ground     {a.amplitude * 1000:.3g} mm at {a.frequency:.4g} Hz{fitted} along "
        f"({a.direction[0]:.3g}, {a.direction[1]:.3g}) until t={a.end_time:.3f} s, peak acceleration "
        f"{a.peak_acceleration:.3g} m/s^2"
    )


#: How :func:`format_program` prints each kind of action after its time and step ("end" for the end).
_ACTION_LINES: dict[type, Callable[[Any], str]] = {
    Place: _place_line,
    Launch: _launch_line,
    Remove: _remove_line,
    Push: _push_line,
    Shake: _shake_line,
}

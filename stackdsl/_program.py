"""The Program: a scenario compiled to time-ordered concrete actions, no generators left.

Everything here is SI (metres, seconds, kilograms, m/s), angles in degrees. Every
action carries the physics step it happens at; its time is that step times the timestep.

Source: stackdsl's own (docs/design.md, data flow).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

Vec3 = tuple[float, float, float]


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class BrickSpec(_Frozen):
    """A brick's body: half extents (m), mass (kg), material friction coefficient and restitution."""

    type: str
    half_extents: Vec3
    mass: float
    friction: float
    restitution: float


class Place(_Frozen):
    """Put brick ``id`` of ``level`` into the world at rest, ``drop`` metres above its pose."""

    kind: Literal["place"] = "place"
    step: int
    time: float
    id: str
    level: int
    brick: BrickSpec
    position: Vec3
    yaw: float
    pitch: float
    roll: float
    drop: float


class Launch(_Frozen):
    """Throw projectile ``id`` from ``position`` with ``velocity``; it reaches ``target`` at ``arrival``."""

    kind: Literal["launch"] = "launch"
    step: int
    time: float
    id: str
    brick: BrickSpec
    position: Vec3
    yaw: float
    pitch: float
    velocity: Vec3
    target: Vec3
    arrival: float


class Fixture(_Frozen):
    """An immovable environment body (a wall, a ramp), in the world from the start."""

    id: str
    brick: BrickSpec
    position: Vec3
    yaw: float
    pitch: float
    roll: float


class Rule(_Frozen):
    """A rule of the stability extension and whether this scene runs it, with why."""

    name: Literal["basic", "leaning", "impacts"]
    on: bool
    reason: str


class End(_Frozen):
    """The run ends."""

    kind: Literal["end"] = "end"
    step: int
    time: float


Action = Annotated[Place | Launch | End, Field(discriminator="kind")]


class EngineSettings(_Frozen):
    """pybullet settings of one run (see :data:`stackdsl._compiler.MODE_DEFAULTS`)."""

    mode: Literal["raw", "tuned", "extension"]
    timestep: float
    solver_iterations: int
    friction_anchors: bool
    maximal_coordinates: bool
    ccd: bool = False
    gravity: float = 9.81


class Program(_Frozen):
    """A compiled scenario.

    Attributes:
        name: the scenario's name.
        engine: pybullet settings.
        ground_friction, ground_restitution: of the ground plane's material.
        stability: keyword arguments of :class:`stability.StabilityConfig` set by the scenario.
        rules: the extension's rules this scene needs (model only what a scene needs).
        fixtures: environment bodies, created first.
        collapse_threshold: metres a structure brick may leave its placed pose.
        settle: seconds the run goes on after the first collapse.
        actions: time-ordered; the last one is :class:`End`.
        floating: ids of the bricks placed resting on nothing, which the scenario allows
            (``allow: [floating]``); they drop when placed.
    """

    name: str
    engine: EngineSettings
    ground_friction: float
    ground_restitution: float
    stability: dict[str, float | str]
    rules: tuple[Rule, ...]
    fixtures: tuple[Fixture, ...] = ()
    collapse_threshold: float
    settle: float
    actions: tuple[Action, ...]
    floating: tuple[str, ...] = ()

    @property
    def placements(self) -> list[Place]:
        """The :class:`Place` actions, in order."""
        return [a for a in self.actions if isinstance(a, Place)]

    @property
    def levels(self) -> int:
        """The highest level placed."""
        return max((a.level for a in self.placements), default=0)

    @property
    def duration(self) -> float:
        """Simulated seconds until :class:`End`."""
        return self.actions[-1].time


def format_program(program: Program) -> str:
    """The program as text, one line per action (what ``stackdsl compile`` prints)."""
    e = program.engine
    lines = [
        f"program {program.name}: mode {e.mode}, timestep {e.timestep * 1000:.4g} ms, "
        f"{e.solver_iterations} solver iterations, friction anchors {'on' if e.friction_anchors else 'off'}, "
        f"maximal coordinates {'on' if e.maximal_coordinates else 'off'}, "
        f"continuous collision detection for thrown bricks {'on' if e.ccd else 'off'}",
        f"  {len(program.placements)} bricks in {program.levels} levels, collapse threshold "
        f"{program.collapse_threshold * 1000:.3g} mm, {program.duration:g} s simulated",
    ]
    if e.mode == "extension":
        lines.append(f"  stability model {program.stability.get('model', 'report')}")
        lines += [f"  rule {r.name:<8} {'on ' if r.on else 'off'}  {r.reason}" for r in program.rules]
    if program.floating:
        lines.append(f"  resting on nothing when placed, allowed (allow: [floating]): {', '.join(program.floating)}")
    for f in program.fixtures:
        x, y, z = (v * 1000 for v in f.position)
        lines.append(
            f"  fixed  {f.id:<10} at ({x:.1f}, {y:.1f}, {z:.1f}) mm  yaw {f.yaw:.1f}  pitch {f.pitch:.1f}  roll {f.roll:.1f}  {f.brick.type}"
        )
    for a in program.actions:
        head = f"  t={a.time:9.3f} s  step {a.step:>8}  "
        if isinstance(a, Place):
            x, y, z = (v * 1000 for v in a.position)
            lines.append(
                f"{head}place  {a.id:<10} level {a.level:>3}  at ({x:8.1f}, {y:8.1f}, {z:7.1f}) mm  "
                f"yaw {a.yaw:6.1f}  pitch {a.pitch:5.1f}  roll {a.roll:5.1f}  {a.brick.type}"
            )
        elif isinstance(a, Launch):
            x, y, z = (v * 1000 for v in a.target)
            speed = sum(v * v for v in a.velocity) ** 0.5
            lines.append(
                f"{head}launch {a.id:<10} {speed:.3g} m/s at ({x:.1f}, {y:.1f}, {z:.1f}) mm, "
                f"arriving t={a.arrival:.3f} s  {a.brick.type}"
            )
        else:
            lines.append(f"{head}end")
    return "\n".join(lines)

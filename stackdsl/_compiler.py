"""Scenario -> Program: expand generators, schedule placements and impacts, check times.

Every action time must be a whole number of timesteps (as dm_control's composer checks
control timesteps): an interval of 0.301 s at 1/240 s is an error pointing at the file,
not a silently rounded schedule.

Source: stackdsl's own; the tower generator builds the report's 4 stack and slant tower
(chapter 4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from stability import Box, Pose

from ._program import BrickSpec, End, EngineSettings, Launch, Place, Program
from ._schema import MAX_SIMULATED_TIME, SIDES, AfterLevel, Impact, Scenario

#: Engine defaults per mode. ``raw`` is pybullet's own (240 Hz, 50 iterations);
#: ``tuned`` is the most accurate setting measured for small bricks (DESIGN.md:
#: maximal coordinates, 1 ms, 150 iterations, friction anchors); ``extension`` is the
#: report's set-up, the stability extension on the unmodified engine.
MODE_DEFAULTS = {
    "raw": dict(timestep=1 / 240, solver_iterations=50, friction_anchors=False, maximal_coordinates=False),
    "tuned": dict(timestep=1 / 1000, solver_iterations=150, friction_anchors=True, maximal_coordinates=True),
    "extension": dict(timestep=1 / 240, solver_iterations=50, friction_anchors=False, maximal_coordinates=False),
}
GRAVITY = 9.81
_LEVEL_TOLERANCE = 0.001  # m: bricks whose bottoms are this close share a level


@dataclass(frozen=True)
class _Brick:
    id: str
    level: int
    type: str
    position: np.ndarray
    yaw: float
    pitch: float = 0.0
    roll: float = 0.0


def compile_scenario(scenario: Scenario, mode: str | None = None) -> Program:
    """Compile a scenario into a :class:`Program`.

    Args:
        scenario: a validated scenario.
        mode: ``"raw"``, ``"tuned"`` or ``"extension"`` to override the scenario's mode;
            the mode picks the engine defaults the scenario does not set.

    Raises:
        ScenarioError: an action time is not a whole number of timesteps, an impact
            names a level that is not built, or the run would exceed the time limit.
    """
    engine = _engine(scenario, mode)
    bricks = _structure(scenario)
    interval, dt = scenario.timing.interval, engine.timestep
    per_brick = _steps(scenario, ("timing", "interval"), interval, dt)
    settle = _steps(scenario, ("timing", "settle"), scenario.timing.settle, dt)
    specs = {name: _spec(scenario, name) for name in {b.type for b in bricks} | {i.projectile for i in scenario.impacts}}
    actions: list = [
        Place(
            step=i * per_brick,
            time=i * interval,
            id=b.id,
            level=b.level,
            brick=specs[b.type],
            position=tuple(b.position),
            yaw=b.yaw,
            pitch=b.pitch,
            roll=b.roll,
            drop=scenario.timing.drop_gap,
        )
        for i, b in enumerate(bricks)
    ]
    actions += [_launch(scenario, i, imp, bricks, specs[imp.projectile], dt) for i, imp in enumerate(scenario.impacts)]
    actions.sort(key=lambda a: (a.step, a.kind != "place"))
    end = actions[-1].time + scenario.timing.settle
    if end > MAX_SIMULATED_TIME:
        raise scenario.source.error(("timing",), f"the run would last {end:.0f} s; at most {MAX_SIMULATED_TIME:.0f} s are simulated")
    actions.append(End(step=actions[-1].step + settle, time=end))
    ground = scenario.material(scenario.ground.material)
    return Program(
        name=scenario.name or "scenario",
        engine=engine,
        ground_friction=ground.friction,
        ground_restitution=ground.restitution,
        stability=scenario.stability.model_dump(exclude_none=True),
        collapse_threshold=scenario.collapse_threshold or min(min(s.half_extents) for s in specs.values()),
        settle=scenario.timing.settle,
        actions=tuple(actions),
    )


def _engine(scenario: Scenario, mode: str | None) -> EngineSettings:
    chosen = mode or scenario.engine.mode
    if chosen not in MODE_DEFAULTS:
        raise ValueError(f"unknown mode {chosen!r}; known: {', '.join(MODE_DEFAULTS)}")
    given = scenario.engine.model_dump(exclude_none=True, exclude={"mode"})
    return EngineSettings(mode=chosen, gravity=GRAVITY, **{**MODE_DEFAULTS[chosen], **given})


def _steps(scenario: Scenario, path: tuple, seconds: float, dt: float) -> int:
    """``seconds`` as a whole number of timesteps, or a ScenarioError at ``path``."""
    steps = seconds / dt
    if abs(steps - round(steps)) > 1e-6 * max(1.0, steps):
        raise scenario.source.error(
            path,
            f"{seconds:g} s is not a whole number of timesteps ({dt * 1000:.4g} ms); "
            f"use a multiple such as {max(1, round(steps)) * dt:.6g} s",
        )
    return round(steps)


def _spec(scenario: Scenario, name: str) -> BrickSpec:
    bt = scenario.brick_type(name)
    mat = scenario.material(bt.material)
    size = np.array(bt.size)
    return BrickSpec(
        type=name,
        half_extents=tuple(size / 2),
        mass=float(np.prod(size) * mat.density),
        friction=mat.friction,
        restitution=mat.restitution,
    )


def _structure(scenario: Scenario) -> list[_Brick]:
    """The structure's bricks in placement order, with levels and placement errors applied."""
    structure = scenario.structure
    bricks = _tower(scenario) if structure.tower else _explicit(scenario)
    error = scenario.timing.placement_error
    if error > 0:
        rng = np.random.default_rng(np.random.SeedSequence(scenario.seed))
        offsets = rng.uniform(-error, error, size=(len(bricks), 2))
        bricks = [_Brick(b.id, b.level, b.type, b.position + [dx, dy, 0.0], b.yaw, b.pitch, b.roll) for b, (dx, dy) in zip(bricks, offsets)]
    return bricks


def _tower(scenario: Scenario) -> list[_Brick]:
    """The tower generator: layer L turned (L-1) x turn, centred at origin + (L-1) x shift."""
    t = scenario.structure.tower
    height = scenario.brick_type(t.brick).size[2]
    bricks = []
    for level in range(1, t.levels + 1):
        yaw = t.yaw + (level - 1) * t.turn
        across = np.array([-math.sin(math.radians(yaw)), math.cos(math.radians(yaw))])
        centre = np.array(t.origin) + (level - 1) * np.array(t.shift)
        for k in range(t.bricks_per_layer):
            xy = centre + (k - (t.bricks_per_layer - 1) / 2) * t.spacing * across
            position = np.array([xy[0], xy[1], (level - 0.5) * height])
            bricks.append(_Brick(f"L{level:02d}.{k + 1}", level, t.brick, position, _wrap(yaw)))
    return bricks


def _explicit(scenario: Scenario) -> list[_Brick]:
    """Bricks placed by hand; a missing level is the rank of the brick's bottom height."""
    placed = scenario.structure.bricks
    bottoms = [
        float(Box(np.array(scenario.brick_type(b.brick).size) / 2, 1.0).corners(Pose.from_euler(b.at, b.yaw, b.pitch, b.roll))[:, 2].min())
        for b in placed
    ]
    heights: list[float] = []
    for z in sorted(bottoms):
        if not heights or z - heights[-1] > _LEVEL_TOLERANCE:
            heights.append(z)
    return [
        _Brick(
            b.id or f"b{i + 1:03d}",
            b.level or 1 + sum(h < z - _LEVEL_TOLERANCE for h in heights),
            b.brick,
            np.array(b.at, dtype=float),
            b.yaw,
            b.pitch,
            b.roll,
        )
        for i, (b, z) in enumerate(zip(placed, bottoms))
    ]


def _launch(scenario: Scenario, index: int, impact: Impact, bricks: list[_Brick], spec: BrickSpec, dt: float) -> Launch:
    """A projectile aimed so that, falling under gravity, it reaches the target point."""
    path = ("impacts", index)
    direction = np.array(impact.direction if impact.direction else SIDES[impact.target.side], dtype=float)
    direction /= np.linalg.norm(direction)
    target = np.array(impact.target.point) if impact.target.point else _face_point(scenario, index, impact, bricks)
    if isinstance(impact.at, AfterLevel):
        last = [i for i, b in enumerate(bricks) if b.level == impact.at.after_level]
        if not last:
            raise scenario.source.error(path + ("at",), f"level {impact.at.after_level} is not built")
        launch_time = (last[-1] + 1) * scenario.timing.interval
    else:
        launch_time = impact.at
    step = _steps(scenario, path + ("at",), launch_time, dt)
    flight = impact.distance / impact.speed
    start = target - direction * (impact.distance + spec.half_extents[0])
    start[2] += 0.5 * GRAVITY * flight**2
    yaw = math.degrees(math.atan2(direction[1], direction[0]))
    pitch = -math.degrees(math.asin(np.clip(direction[2], -1.0, 1.0)))
    return Launch(
        step=step,
        time=launch_time,
        id=impact.id or f"impact{index + 1}",
        brick=spec,
        position=tuple(start),
        yaw=yaw,
        pitch=pitch,
        velocity=tuple(direction * impact.speed),
        target=tuple(target),
        arrival=launch_time + flight,
    )


def _face_point(scenario: Scenario, index: int, impact: Impact, bricks: list[_Brick]) -> np.ndarray:
    """Middle of the outer face, on the target side, of the level's outermost brick."""
    level = [b for b in bricks if b.level == impact.target.level]
    if not level:
        raise scenario.source.error(("impacts", index, "target", "level"), f"level {impact.target.level} is not built")
    outward = -np.array(SIDES[impact.target.side])
    best, best_reach, best_face = None, -math.inf, None
    for b in level:
        box = Box(np.array(scenario.brick_type(b.type).size) / 2, 1.0)
        corners, _ = box.face(Pose.from_euler(b.position, b.yaw, b.pitch, b.roll), outward)
        reach = float((corners @ outward).max())
        if reach > best_reach + 1e-9:
            best, best_reach, best_face = b, reach, corners
    return best_face.mean(axis=0)


def _wrap(angle: float) -> float:
    """An angle in degrees wrapped to (-180, 180]."""
    wrapped = math.fmod(angle + 180.0, 360.0)
    return (wrapped + 360.0 if wrapped <= 0 else wrapped) - 180.0

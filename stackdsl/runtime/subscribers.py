"""The step loop's subscribers: the stability extension, the substep control and the rigid
debris (the collapse monitor is :mod:`stackdsl.runtime.collapse`).

Source: stackdsl's own; the extension is the report's method (:mod:`stability`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from stability import Box, Plane, Pose, StabilityConfig, StabilityEvent, StabilityExtension

from ..compile.program import MAX_SUBSTEPS, Program
from ..engines.protocol import World
from .bricks import BrickRecord
from .loop import StepLoop, Subscriber
from .outcome import Event, Graph


class Stability(Subscriber):
    """The stability extension on the world: every brick is registered with it (its brick
    graph is the run's in every mode); with ``acting`` it freezes and wakes them.

    A brick's record follows the extension: frozen, it stops ``moving`` and keeps how far
    it had moved (``settled``); woken, it moves again.
    """

    def __init__(self, world: World, program: Program, config: StabilityConfig, acting: bool) -> None:
        self.extension = StabilityExtension(world, config)
        self.acting = acting
        self.mechanisms: dict[str, tuple[float, str]] = {}  # brick id -> when and why a proved mechanism woke it
        self.near_ties: dict[str, str] = {}  # brick id -> why statics, not the engine, decided its landing
        self.extension.add_ground(world.ground, Plane(0.0), friction=program.ground_friction)
        self.fixtures: list[tuple[int, Pose]] = []  # each fixture's body and its pose on the unmoved ground
        for f in program.fixtures:
            pose = Pose.from_euler(f.position, f.yaw, f.pitch, f.roll)
            body = world.create(f.brick, pose, mass=0.0)
            self.extension.add_ground(body, Box(np.array(f.brick.half_extents), f.brick.mass), f.id, f.brick.friction)
            self.fixtures.append((body, pose))

    @property
    def quiet(self) -> bool:
        return self.acting and self.extension.quiet  # without the extension anything may move

    def on_place(self, loop: StepLoop, record: BrickRecord) -> None:
        # a placed brick is frozen once it has landed at rest on what is frozen; one whose centre
        # of mass lands within the engine's contact margin of its support's edge is decided by
        # statics on its placed geometry (stability's near ties)
        near_tie = loop.program.engine.contact_margin if self.acting else 0.0
        self.extension.add_brick(record.body, record.box, record.id, record.spec.friction, near_tie=near_tie, placed=self.acting)

    def on_launch(self, loop: StepLoop, record: BrickRecord) -> None:
        self.extension.add_brick(record.body, record.box, record.id, record.spec.friction)
        if self.acting:  # a fast projectile may reach its target within the first step
            self.follow(loop, self.extension.update(loop.events[-1].time))

    def after_step(self, loop: StepLoop) -> None:
        if self.acting and (events := self.extension.update(loop.now)):
            self.follow(loop, events)

    def follow(self, loop: StepLoop, events: list[StabilityEvent]) -> None:
        """Update the records of frozen and woken bricks; put the events in the timeline
        (impacts only of projectiles, not of every landing brick). The bricks of a ride that
        tipped over as it woke (``falling``: the top of a Jenga tower tipping off its last
        block) are made debris in the engine (:meth:`stackdsl.engines.protocol.World.make_debris`:
        pybullet's rigid bodies, about half the cost a step of a falling column of 40)."""
        records = loop.structure.records
        falling = [r.body for e in events if e.falling and (r := records.get(e.label)) is not None]
        if falling:
            loop.world.make_debris(falling)
        for e in events:
            record = records.get(e.label)
            if e.kind == "wake" and e.proved:
                self.mechanisms[e.label] = (e.time, e.reason)
            elif e.kind == "freeze":
                self.mechanisms.pop(e.label, None)
                if e.proved:  # a near tie statics decided on the placed geometry
                    self.near_ties[e.label] = e.reason
            if record is not None and record.structure and e.kind in ("freeze", "wake", "ride"):
                loop.structure.set_moving(record, e.kind != "freeze")  # a rider moves in the world
                record.was_frozen = True
                loop.structure.settle(record)
            elif record is not None and e.kind in ("freeze", "wake", "ride"):  # a projectile, or a brick pulled out
                record.moving = e.kind != "freeze"
            source = records.get(e.source)
            if e.kind != "impact" or (source is not None and not source.structure):
                level = record.level if record is not None else None
                loop.events.append(Event(time=e.time, kind=e.kind, brick=e.label, level=level, detail=e.reason))

    def proved(self, brick: str) -> tuple[str, tuple[str, ...]] | None:
        """The proved collapse mechanism ``brick`` was woken in and has not been frozen since, in
        words, with every brick it woke then (in the order they entered); None when there is none."""
        if brick not in self.mechanisms:
            return None
        time, reason = self.mechanisms[brick]
        bricks = tuple(b for b, (t, _) in self.mechanisms.items() if t == time)
        return f"a collapse mechanism proved at {time:.3f} s ({reason})", bricks

    def graph(self, loop: StepLoop) -> Graph:
        """The brick graph now, with how far each structure brick is from where it was placed."""
        placed = loop.structure.placed
        displaced = {r.id: float(d) for r, d in zip(placed, loop.structure.displacements(placed))}
        return Graph.from_stability(self.extension.graph(), loop.structure.levels, displaced)


class SoftLanding(Subscriber):
    """A placed brick is let go of once it has arrived, as a hand that lowers a brick onto the
    stack and opens: at the first step after it began to fall at which something has slowed its
    fall (its downward speed grew by less than half of what gravity adds in a step) or it has
    come down to its resting height (within :data:`ARRIVED`), its velocities are set to zero,
    once. A brick placed in contact never falls and is left alone.

    A brick falling freely is lowered onto its resting height: the step that would take it there
    or past it ends there instead (its speed set for that), and at rest there it is watched as
    if placed so. Falling straight down from rest it has the placed pose's x, y and orientation,
    so every drop gap ends as the gap of 0 begins, a few steps later, and lands as that one
    does. Dropped 2 mm onto two supports, one of them reached by 0.46 mm only, a brick passed
    that edge in the step of its impact (0.8 mm a step at 0.2 m/s) and slid off it on pybullet;
    lowered, it stays. Dropped freely, a brick whose centre of mass lies 1 mm inside its
    support's edge landed 1 mm from above with enough spin on pybullet to slide off: a slanted
    log cabin whose closed-form level is 10 fell at level 4 with a 1 mm gap and at 10 with the
    others. Same in every mode, so modes compare. A brick watched longer than :data:`WATCH` is
    forgotten.

    While it sets a brick down, the hand says so (``hand``, called after each step with the
    bodies still falling to their place: :meth:`stability.StabilityExtension.lowering`): the
    fall it stops is no blow on what the brick lands on.

    Source: stackdsl's own (docs/design.md, placement independence).
    """

    ARRIVED = 1e-4
    """Metres above its resting height at which a falling brick has arrived."""

    WATCH = 0.25
    """Seconds after its placement a brick is watched."""

    FALLING = 1e-3
    """m/s downward from which a brick has begun to fall."""

    def __init__(self, gravity: float, hand: Callable[[set[int]], None] | None = None) -> None:
        self.gravity, self.hand = gravity, hand
        self.falling: dict[str, tuple[BrickRecord, float, float | None]] = {}  # id -> (record, placed, last vz)
        self.lowered: set[str] = set()  # lowered onto their resting heights in this step
        self.setting_down: set[int] = set()  # the bodies of those falling to their place, as last told to ``hand``

    @property
    def quiet(self) -> bool:
        return not self.falling

    def on_place(self, loop: StepLoop, record: BrickRecord) -> None:
        self.falling[record.id] = (record, loop.events[-1].time, None)

    def before_step(self, loop: StepLoop) -> None:
        if not self.falling:
            return
        world, dt = loop.world, loop.dt
        fall = self.gravity * dt
        for record, _, last in self.falling.values():  # one or two bricks: one at a time, in floats
            if not record.moving:
                continue
            step = (fall - (last or 0.0)) * dt  # metres it falls in this step, freely (placed at rest: 0 m/s)
            above = world.pose_floats(record.body)[0][2] - record.placed_xyz[2]
            if self.ARRIVED < above <= step + self.ARRIVED:
                world.throw(record.body, (0.0, 0.0, fall - above / dt), None)
                self.lowered.add(record.id)

    def after_step(self, loop: StepLoop) -> None:
        if not self.falling:
            if self.setting_down:
                self._tell(set())
            return
        slowed = 0.5 * self.gravity * loop.dt
        world, now, lowered = loop.world, loop.now, self.lowered
        setting_down = set()
        for record, placed, last in list(self.falling.values()):
            if lowered and record.id in lowered:  # at rest where it is to lie, as if placed there now
                lowered.discard(record.id)
                world.throw(record.body, (0.0, 0.0, 0.0), None)
                self.falling[record.id] = (record, now, None)
                continue
            vz = world.velocity_floats(record.body)[0][2]
            fell = last is not None or vz < -self.FALLING
            arrived = fell and (
                (last is not None and vz > last - slowed)
                or world.pose_floats(record.body)[0][2] <= record.placed_xyz[2] + self.ARRIVED
            )
            if arrived and record.moving:
                world.throw(record.body, (0.0, 0.0, 0.0), None)
            if arrived or not record.moving or now - placed > self.WATCH:
                del self.falling[record.id]
            elif fell:
                self.falling[record.id] = (record, placed, vz)
                setting_down.add(record.body)
        if setting_down != self.setting_down:
            self._tell(setting_down)

    def _tell(self, bodies: set[int]) -> None:
        """Tell the hand's listener which bodies it is setting down now."""
        self.setting_down = bodies
        if self.hand is not None:
            self.hand(bodies)


class Substeps(Subscriber):
    """Split a step while something is fast, so that no body moves more than the collapse
    threshold (half a brick's thinnest side) in one substep, in at most
    :data:`MAX_SUBSTEPS` (a ``substeps`` event when the cap starts to hold: faster bodies
    then move further per substep, and the run's cost stays bounded).

    A brick thrown lengthwise at 5 m/s moves 21 mm in a 240 Hz step, more than the 8 mm it
    overlaps its target: pybullet then pushes it out up or down and it slips past;
    continuous collision detection does not help (its swept sphere is at the centre of
    mass, 60 mm behind the front). Only while fast bodies move: none, no cost.

    Args:
        threshold: metres a body may move in one substep.
        bricks_too: watch the moving structure bricks as well as the projectiles.
    """

    def __init__(self, threshold: float, bricks_too: bool) -> None:
        self.threshold, self.bricks_too = threshold, bricks_too
        self.substeps = 1
        self.floor = 1  # at least this many (a hand pulling a brick: see PULL_STEP)
        self._told: int | None = None  # what the world was last told (set_substeps)

    def before_step(self, loop: StepLoop) -> None:
        structure, speeds = loop.structure, loop.world.speeds
        speed, fastest = 0.0, None  # the first of the fastest (max's own choice), asked every step
        for records in (structure.projectiles, structure.moving.values() if self.bricks_too else ()):
            for r in records:
                s = speeds(r.body)[0]
                if fastest is None or s > speed:
                    speed, fastest = s, r
        needed = max(self.floor, math.ceil(speed * loop.dt / self.threshold))
        substeps = min(needed, MAX_SUBSTEPS)
        if substeps == MAX_SUBSTEPS and self.substeps != MAX_SUBSTEPS and fastest is not None:
            detail = f"{speed:.3g} m/s needs {needed} substeps; capped at {MAX_SUBSTEPS}"
            loop.events.append(Event(time=loop.now, kind="substeps", brick=fastest.id, level=fastest.level, detail=detail))
        self.substeps = substeps
        if substeps != self._told:  # the world keeps what it was told last
            self._told = substeps
            loop.world.set_substeps(substeps)


class CheapDebris(Subscriber):
    """Once the run only settles after a collapse (nothing more is placed or thrown, the
    collapse level is decided), the bricks the engine moves become cheaper to step, once, on
    the step the collapse is decided (:meth:`stackdsl.engines.protocol.World.make_debris`:
    rigid bodies on pybullet, about half the cost a step; MuJoCo's default impratio on MuJoCo);
    bricks frozen then stay as they are.

    Args:
        make_debris: makes the given bodies cheaper to step; returns those it made so.

    Source: stackdsl's own (docs/design.md, modes; measured in docs/results/collapse-phase.md).
    """

    def __init__(self, make_debris: Callable[[Sequence[int]], list[int]]) -> None:
        self.make_debris = make_debris
        self.made: list[int] | None = None  # the bodies made cheaper, once it has happened

    def after_step(self, loop: StepLoop) -> None:
        if self.made is None and loop.stop_step is not None and loop.stop_at_collapse:
            self.made = self.make_debris([r.body for r in loop.structure.moving.values()])

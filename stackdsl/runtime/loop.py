"""The step loop: a program's actions carried out in a world, with named hooks.

:class:`StepLoop` steps the world to each action, puts bricks in (placements) and throws
projectiles (launches), and calls its subscribers at named moments:

* ``before_step`` and ``after_step``, around every physics step taken;
* ``on_place`` and ``on_launch``, when a brick or a projectile has entered the world;
* ``on_action``, when a pull, a push or a shake starts (:mod:`stackdsl.runtime.actions`
  carries them out);
* ``on_glide``, when a subscriber has carried what it moves over steps without the engine
  (:meth:`Subscriber.glide`);
* ``at_end``, once, when the run ends (at its end, at a collapse's settle time or at the
  wall-clock deadline).

The stability extension, the collapse monitor, the substep control and the recorder are
subscribers (:mod:`stackdsl.runtime.subscribers`, :mod:`stackdsl.runtime.recorder`). While every
subscriber is quiet (nothing can move until the next action) the loop jumps to that
action instead of stepping; a subscriber that can glide skips the steps it carries its
bodies over.

Source: stackdsl's own (the step loop of dm_control's composer, with its lifecycle hooks).
"""

from __future__ import annotations

import time as _time
from collections.abc import Sequence

import numpy as np

from stability import Box, Pose

from ..compile.program import End, Kinematic, Launch, Place, Program, Push, Remove, Shake
from ..engines.protocol import BrickSpec, EngineUnstable, World
from .aim import aim
from .bricks import BrickRecord, Structure, footprint
from .outcome import Event

#: Steps between two readings of the wall clock when a run has a deadline.
CLOCK_EVERY = 16


class Subscriber:
    """Something attached to the step loop; every hook does nothing unless overridden.

    The loop binds only the hooks a subscriber overrides (as dm_control's composer does): a
    subscriber that only watches the end of a run costs nothing on each step, and one that
    does not override :attr:`quiet` never keeps the loop from jumping.

    >>> class Counter(Subscriber):
    ...     steps = 0
    ...     def after_step(self, loop):
    ...         self.steps += 1
    >>> overrides(Counter(), "after_step"), overrides(Counter(), "before_step"), overrides(Counter(), "quiet")
    (True, False, False)
    """

    @property
    def quiet(self) -> bool:
        """Nothing this subscriber watches can move before the next action."""
        return True

    def glide(self, loop: StepLoop, limit: int) -> int:
        """Carry what this subscriber moves over steps nobody needs stepped, from ``loop.step``
        on, and return how many (0: none; at most ``limit - loop.step - 1``, so that the
        step ``limit - 1`` is stepped). The loop counts them as :attr:`StepLoop.skipped` and
        steps on from there."""
        return 0

    @property
    def under_way(self) -> bool:
        """An action this subscriber carries out is under way (a hand or the ground moves):
        a run that a collapse ends lets it finish first."""
        return False

    def before_step(self, loop: StepLoop) -> None:
        """Before each physics step."""

    def after_step(self, loop: StepLoop) -> None:
        """After each physics step; ``loop.now`` is the time reached."""

    def on_place(self, loop: StepLoop, record: BrickRecord) -> None:
        """A brick was placed (its ``place`` event is in the timeline)."""

    def on_launch(self, loop: StepLoop, record: BrickRecord) -> None:
        """A projectile was thrown (its ``launch`` event is in the timeline)."""

    def on_action(self, loop: StepLoop, action: Kinematic) -> None:
        """A pull, a push or a shake starts now."""

    def on_glide(self, loop: StepLoop, steps: int) -> None:
        """A subscriber carried what it moves over the last ``steps`` steps without the engine
        (:meth:`glide`); ``loop.step`` is where it went, nothing stepped there yet."""

    def at_end(self, loop: StepLoop) -> None:
        """The run ended."""


HOOKS = ("before_step", "after_step", "on_place", "on_launch", "on_action", "on_glide", "at_end")
"""The step loop's lifecycle hooks, in the order they can first be called."""


def overrides(subscriber: object, name: str) -> bool:
    """Whether ``subscriber``'s class defines hook (or property) ``name`` other than
    :class:`Subscriber`'s do-nothing default; an object that is not a Subscriber counts as
    overriding every hook it has. Source: stackdsl's own."""
    default = getattr(Subscriber, name)
    return getattr(type(subscriber), name, default) is not default or (
        not isinstance(subscriber, Subscriber) and hasattr(subscriber, name)
    )


class StepLoop:
    """One run of ``program`` in ``world``.

    Args:
        world: the engine adapter.
        program: what to do.
        subscribers: called at each hook they override (:func:`overrides`), in this order.
        jump: jump to the next action while every subscriber is quiet, and let a subscriber
            that can glide (:meth:`Subscriber.glide`) carry its bodies over the steps it needs
            no engine for.
        stop_at_collapse: once :meth:`stop_after` was called, place nothing more and end
            then; a shake, a push or a pull under way then (:attr:`Subscriber.under_way`), or an
            action timed before the first placement this cancels, still runs, and the run
            then ends as long after it (a push, pull or shake: after its end) as
            :meth:`stop_after` was told. An action timed after a cancelled placement was
            timed on a stack never finished: it is not run (:attr:`not_run`).
        lazy_bodies: bodies enter the world when placed; False creates every brick and
            projectile first, immovable and far away, and moves it in when placed.
        timeout: seconds of wall time after which the run stops, counted from ``started``
            (``time.perf_counter()`` seconds; None: now), or None for no limit.

    Attributes:
        structure: the bricks in the world; events: the timeline; step: steps reached;
        skipped: steps jumped over; stopped: why the run stopped early, or None;
        not_run: the actions a collapse left undone, in a few words each;
        engine_time: wall seconds spent in the engine's steps; stop_clock: the wall clock
        (``time.perf_counter()`` seconds) when :meth:`stop_after` was called, or None.
    """

    def __init__(
        self,
        world: World,
        program: Program,
        subscribers: Sequence[Subscriber] = (),
        *,
        jump: bool = True,
        stop_at_collapse: bool = True,
        lazy_bodies: bool = True,
        timeout: float | None = None,
        started: float | None = None,
    ) -> None:
        self.world, self.program, self.subscribers = world, program, tuple(subscribers)
        bound = {h: tuple(getattr(s, h) for s in self.subscribers if overrides(s, h)) for h in HOOKS}
        self._before_step, self._after_step = bound["before_step"], bound["after_step"]
        self._on_place, self._on_launch, self._at_end = bound["on_place"], bound["on_launch"], bound["at_end"]
        self._on_action, self._on_glide = bound["on_action"], bound["on_glide"]
        self._watchers = tuple(s for s in self.subscribers if overrides(s, "quiet"))
        self._hands = tuple(s for s in self.subscribers if overrides(s, "under_way"))
        self._gliders = tuple(s for s in self.subscribers if overrides(s, "glide")) if jump else ()
        self.jump, self.stop_at_collapse, self.timeout = jump, stop_at_collapse, timeout
        self.deadline = None if timeout is None else (_time.perf_counter() if started is None else started) + timeout
        self.dt = program.engine.timestep
        self.structure = Structure(world)
        self.events: list[Event] = []
        self.step = 0
        self.skipped = 0
        self.engine_time = 0.0
        self.stop_clock: float | None = None
        self.stop_step: int | None = None
        self._settle_steps = 0
        self._busy = 0  # the step the thrown bodies have reached their targets (see _ends)
        self.stopped: str | None = None
        self.not_run: tuple[str, ...] = ()
        self._parked = {} if lazy_bodies else self._park()

    @property
    def now(self) -> float:
        """Seconds simulated."""
        return self.step * self.dt

    def stop_after(self, seconds: float) -> None:
        """End the run ``seconds`` from now (a collapse's settle time), placing nothing more; an
        action under way (what a subscriber says is, :attr:`Subscriber.under_way`: a shake, a
        push or a pull; a thrown body still in flight) first runs to its end, and the run ends ``seconds``
        after that."""
        self._settle_steps = round(seconds / self.dt)
        self.stop_step = max(self.step, self._busy) + self._settle_steps
        self.stop_clock = _time.perf_counter()

    def _park(self) -> dict[str, int]:
        parked = {}
        for i, a in enumerate(a for a in self.program.actions if isinstance(a, (Place, Launch))):
            projectile = self.program.engine.ccd and isinstance(a, Launch)
            parked[a.id] = self.world.create(
                a.brick, Pose.from_euler([100.0 + 0.3 * i, 100.0, 1.0]), mass=0.0, projectile=projectile
            )
        return parked

    # lifecycle ----------------------------------------------------------------
    def run(self) -> None:
        """Carry out every action, then call ``at_end``."""
        self._actions()
        for hook in self._at_end:
            hook(self)

    def _actions(self) -> None:
        cut = False  # a placement the collapse cancelled: what is timed after it was timed on a stack never finished
        for action in self.program.actions:
            self.advance(action.step)
            if self.stopped is not None or self._out_of_time():
                return
            if self.stop_step is not None and self.stop_at_collapse:
                if isinstance(action, End):
                    break
                if isinstance(action, Place) or cut:
                    cut = True
                    self.not_run += () if isinstance(action, Place) else (_said(action),)
                    continue
                self.stop_step = max(self.stop_step, action.step)  # the collapse's settling may end before it
                self.advance(action.step)
                if self.stopped is not None:
                    return
                self.stop_step = max(self.stop_step, self._ends(action) + self._settle_steps)
            if isinstance(action, Launch):
                self._busy = max(self._busy, self._ends(action))
            if isinstance(action, Place):
                self.place(action)
            elif isinstance(action, Launch):
                self.launch(action)
            elif isinstance(action, (Remove, Push, Shake)):
                for on_action in self._on_action:
                    on_action(self, action)
        if self.stop_step is not None:
            self.advance(min(self.stop_step, self.program.actions[-1].step))

    def _ends(self, action: Launch | Remove | Push | Shake) -> int:
        """The step an action is over: a thrown body's arrival at its target, a motion's end."""
        if isinstance(action, Launch):
            return max(action.step, round(action.arrival / self.dt))
        return action.end_step

    def _out_of_time(self) -> bool:
        """Past the deadline? Then record where the run stopped."""
        if self.deadline is None or _time.perf_counter() < self.deadline:
            return False
        self.time_out()
        return True

    def time_out(self, doing: str = "") -> None:
        """Record that the run stopped at its deadline, ``doing`` what (words), now: a subscriber
        whose own work ran out of the run's time says so (the statics of a standing structure's
        proof)."""
        at = f"t = {self.now:.1f} s simulated (of {self.program.duration:g} s)"
        self.stopped = f"timeout after {float(f'{self.timeout:.3g}'):g} s " + (f"{doing}, at {at}" if doing else f"at {at}")

    def _limit(self, target: int) -> int:
        if self.stop_step is None or not self.stop_at_collapse:
            return target
        return min(target, self.stop_step)

    def advance(self, target: int) -> None:
        """Step the world up to step ``target`` (or the stop step), or until the deadline."""
        before, after, watchers, hands = self._before_step, self._after_step, self._watchers, self._hands
        step, clock, jump, gliders = self.world.step, _time.perf_counter, self.jump, self._gliders
        while self.step < self._limit(target):
            if self.deadline is not None and self.step % CLOCK_EVERY == 0 and self._out_of_time():
                return
            for glider in gliders:
                glided = glider.glide(self, self._limit(target))
                if glided:
                    self.step += glided
                    self.skipped += glided
                    for on_glide in self._on_glide:
                        on_glide(self, glided)
                    if self.deadline is not None and self._out_of_time():
                        return
                    break
            if jump:
                for watcher in watchers:
                    if not watcher.quiet:
                        break
                else:  # every subscriber is quiet
                    self.skipped += self._limit(target) - self.step
                    self.step = self._limit(target)
                    return
            for hook in before:
                hook(self)
            started = clock()
            try:
                step()
            except EngineUnstable as unstable:
                self.stopped = str(unstable)
                return
            self.engine_time += clock() - started
            self.step += 1
            for hook in after:
                hook(self)
            if self.stop_step is not None and hands and any(s.under_way for s in hands):
                self.stop_step = max(self.stop_step, self.step + self._settle_steps)  # it finishes, then the run settles

    # actions ------------------------------------------------------------------
    def place(self, a: Place) -> BrickRecord:
        """Put a brick at rest a drop gap above its pose, on what is actually below it.

        The bricks below may have sunk into each other (contact penetration, about 0.05 mm
        a level at 240 Hz): the brick is placed lower by the least they have sunk, as a
        person puts a brick on the stack in front of them, so that a tall tower's newest
        brick does not fall millimetres onto its supports. The sink is reported in the
        ``place`` event and kept in the brick's record. The brick's pose is also lowered by
        its engine's seat (:attr:`~stackdsl.engines.protocol.EngineSettings.SEAT`), about as
        deep as a brick at rest sinks there, so that it meets its whole contact patch at once.
        """
        nominal = Pose.from_euler(a.position, a.yaw, a.pitch, a.roll)
        corners = Box(np.array(a.brick.half_extents), a.brick.mass).corners(nominal)
        shape = footprint(corners)  # lowered straight down: the placed footprint too
        below = self.structure.under(float(corners[:, 2].min()), shape)
        sink = self.structure.sink(below)
        target = Pose(nominal.position - [0.0, 0.0, sink + self.program.engine.SEAT], nominal.orientation)
        body = self._enter(a.id, a.brick, Pose(target.position + [0.0, 0.0, a.drop], nominal.orientation))
        record = BrickRecord(a.id, body, a.brick, a.level, target, nominal, below=tuple(below), shape=shape)
        self.structure.add(record)
        detail = f"on bricks that have sunk {sink * 1000:.2f} mm" if sink > 5e-5 else ""
        self.events.append(Event(time=a.time, kind="place", brick=a.id, level=a.level, detail=detail))
        for on_place in self._on_place:
            on_place(self, record)
        return record

    def launch(self, a: Launch) -> BrickRecord | None:
        """Throw a projectile; with ``ccd`` it gets continuous collision detection (a swept
        sphere of its half thickness, on the kind of body its engine needs for that). A throw at a
        level's side is aimed at its brick as it lies now (:func:`stackdsl.runtime.aim.aim`); one
        that cannot be is not thrown (None), and its ``launch`` line says why."""
        ccd = self.program.engine.ccd
        speed = float(np.linalg.norm(a.velocity))
        pose, said = aim(a, self.structure, self.world, self.program.fixtures)
        if pose is None:
            self.events.append(Event(time=a.time, kind="launch", brick=a.id, detail=f"{speed:.3g} m/s ({said})"))
            return None
        body = self._enter(a.id, a.brick, pose, projectile=ccd)
        self.world.throw(body, a.velocity, min(a.brick.half_extents) if ccd else None)
        record = BrickRecord(a.id, body, a.brick, None, pose, pose)
        self.structure.add(record)
        arriving = f"{speed:.3g} m/s, arriving at {a.arrival_speed(self.program.engine.gravity):.3g} m/s"
        detail = f"{arriving} ({said})" if said else arriving
        self.events.append(Event(time=a.time, kind="launch", brick=a.id, detail=detail))
        for on_launch in self._on_launch:
            on_launch(self, record)
        return record

    def _enter(self, name: str, spec: BrickSpec, pose: Pose, projectile: bool = False) -> int:
        """The body for ``name`` in the world at ``pose``: created now, or unparked."""
        if name in self._parked:
            body = self._parked[name]
            self.world.move(body, pose, spec.mass)
            return body
        return self.world.create(spec, pose, projectile=projectile)


def _said(action: Launch | Remove | Push | Shake) -> str:
    """An action in a few words, for the list of those a collapse left undone (timed after a
    placement the collapse cancelled)."""
    if isinstance(action, Launch):
        return f"impact {action.id} at {action.time:.2f} s"
    if isinstance(action, Remove):
        return f"remove {action.id} at {action.time:.2f} s"
    if isinstance(action, Push):
        return f"push {action.id} into {action.target} at {action.time:.2f} s"
    return f"shake at {action.time:.2f} s"

"""The collapse monitor: the first structure brick that stays moved.

A structure brick is *displaced* when its farthest-moved corner is more than the collapse
threshold from where it was placed. A displaced brick has *collapsed* when the displacement
persists:

- it is moving away: its corner is more than twice the threshold from where it was placed; or
- it comes to rest displaced: its speeds stay under the rest thresholds for the rest duration
  (or the stability extension freezes it) while it is displaced; or
- the run ends while it is displaced.

A brick that rocks past the threshold on landing and returns within it has not collapsed (its
landing is not a collapse); a brick that tips over, slides off or is knocked away has. The
collapse is dated from the moment the brick was first displaced, and its level is the highest
level placed then: bricks placed while the monitor waits to tell a rock from a fall do not
raise the level. The definition is the same in every mode.

Source: stackdsl's own (the report declares a collapse when a brick falls off the stack,
without a threshold).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from ._bricks import BrickRecord
from ._loop import StepLoop, Subscriber
from ._outcome import Collapse, Event, Graph

#: A displaced brick farther than this many thresholds from where it was placed is moving away.
AWAY = 2.0


@dataclass
class _Displaced:
    """A brick past the threshold, not yet known to stay so: since when (s), the level
    placed then, the farthest it went (m), and since when it has been at rest (s, or None)."""

    since: float
    level: int
    farthest: float
    graph: Graph
    resting_since: float | None = None


class CollapseMonitor(Subscriber):
    """The first collapse (see the module's description).

    At the collapse the monitor records it, keeps the brick graph of the moment the brick was
    first displaced and asks the loop to end ``settle`` seconds later. Until then it tracks the
    drift, the largest displacement within the threshold of a standing brick, seen before each
    placement.

    Args:
        threshold: metres (the program's collapse threshold).
        settle: seconds the run goes on after the collapse is decided.
        graph: the brick graph now.
        rest_speed, rest_angular_speed: m/s and rad/s under which a brick is at rest.
        rest_duration: seconds a displaced brick must stay at rest to have come to rest.
    """

    def __init__(
        self,
        threshold: float,
        settle: float,
        graph: Callable[[StepLoop], Graph],
        rest_speed: float = 0.005,
        rest_angular_speed: float = 0.05,
        rest_duration: float = 0.05,
    ) -> None:
        self.threshold, self.settle, self._graph = threshold, settle, graph
        self._rest = (rest_speed, rest_angular_speed, rest_duration)
        self.collapse: Collapse | None = None
        self.collapse_graph: Graph | None = None
        self.drift = 0.0
        self._displaced: dict[str, _Displaced] = {}

    @property
    def quiet(self) -> bool:
        """Not while a displaced brick is yet to be told rocking from falling."""
        return not self._displaced

    def on_place(self, loop: StepLoop, record: BrickRecord) -> None:
        self.record_drift(loop, exclude=record)

    def at_end(self, loop: StepLoop) -> None:
        if self.collapse is None and self._displaced:
            self._decide(loop, displaced_at_end=True)
        self.record_drift(loop)

    def after_step(self, loop: StepLoop) -> None:
        if self.collapse is None:
            self._decide(loop)

    def _decide(self, loop: StepLoop, displaced_at_end: bool = False) -> None:
        structure = loop.structure
        watched = [structure.records[i] for i in self._displaced if not structure.records[i].moving]
        moving = list(structure.moving.values())
        watched += [r for r in moving if r.id in self._displaced]
        watched += [r for r in structure.may_have_moved(moving, self.threshold) if r.id not in self._displaced]
        watched.sort(key=lambda r: r.order)
        moved = structure.displacements(watched)
        for record, distance in zip(watched, moved):
            if distance <= self.threshold:
                self._displaced.pop(record.id, None)  # within the threshold, or rocked and came back
        displaced = [(r, float(d)) for r, d in zip(watched, moved) if d > self.threshold]
        resting = self._resting(loop, [r for r, _ in displaced])
        for (record, distance), rests in zip(displaced, resting):
            state = self._displaced.get(record.id)
            if state is None:
                level = max(structure.levels.values())
                # the graph of the moment the first pending brick was displaced serves the others
                # (a collapse is dated at the earliest of them; one graph a brick cost 85 ms each
                # for the 50 bricks of a falling tower)
                pending = [d for d in self._displaced.values() if d.level == level]
                graph = min(pending, key=lambda d: d.since).graph if pending else self._graph(loop)
                state = self._displaced[record.id] = _Displaced(loop.now, level, distance, graph)
            state.farthest = max(state.farthest, distance)
            if not rests:
                state.resting_since = None
            elif state.resting_since is None:
                state.resting_since = loop.now
            rested = state.resting_since is not None and loop.now - state.resting_since >= self._rest[2] - 1e-9
            if displaced_at_end or not record.moving or rested or distance > AWAY * self.threshold:
                self._collapsed(loop, record, distance)
                return

    def _resting(self, loop: StepLoop, records: list[BrickRecord]) -> list[bool]:
        """Whether each brick's speeds are under the rest thresholds now (a frozen one's are)."""
        moving = [r for r in records if r.moving]
        if not moving:
            return [True] * len(records)
        lin, ang = loop.world.velocities_of([r.body for r in moving])
        slow = iter(((lin**2).sum(axis=1) <= self._rest[0] ** 2) & ((ang**2).sum(axis=1) <= self._rest[1] ** 2))
        return [bool(next(slow)) if r.moving else True for r in records]

    def _collapsed(self, loop: StepLoop, record: BrickRecord, moved: float) -> None:
        """``record`` stays moved: the collapse began when the first of the bricks displaced now
        was displaced; that brick is the one named."""
        first_id = min(self._displaced, key=lambda i: self._displaced[i].since)
        first, state = loop.structure.records[first_id], self._displaced[first_id]
        assert first.level is not None
        self.record_drift(loop)
        farthest = moved if first is record else state.farthest
        self.collapse = Collapse(
            level=state.level, time=state.since, brick=first.id, brick_level=first.level, displacement=farthest, decided=loop.now
        )
        detail = f"moved {farthest * 1000:.1f} mm; collapse level {state.level}"
        loop.events.append(Event(time=state.since, kind="collapse", brick=first.id, level=first.level, detail=detail))
        loop.events.sort(key=lambda e: e.time)
        self.collapse_graph = state.graph
        self._displaced.clear()
        loop.stop_after(self.settle)

    def record_drift(self, loop: StepLoop, exclude: BrickRecord | None = None) -> None:
        """Track the largest displacement of the standing structure until the first collapse."""
        if self.collapse is not None:
            return
        structure = loop.structure
        moving = [r for r in structure.moving.values() if r is not exclude]
        now = [*structure.displacements(moving), *(r.settled for r in structure.placed if r.settled is not None)]
        self.drift = max([self.drift, *(float(d) for d in now if d <= self.threshold)])

"""The collapse monitor: the first structure brick that stays moved, and the proof of it.

A structure brick is *displaced* when its farthest-moved corner is more than the collapse
threshold from where it was placed. A displaced brick has *collapsed* when physics says it
stays so:

- it comes to rest displaced: its speeds stay under the rest thresholds for the rest
  duration (or the stability extension freezes it) while it is displaced; or
- it cannot come back: its centre of mass, with the bricks it carries, has left the support
  polygon it was placed on (the overlaps of its bottom face with what it rested on, carried
  along with those supports as they move), so their weight turns it on away from its place and
  only a push could bring it back (where a brick it carries lies on others too, the centre of
  mass of all the bricks connected to it by where they were placed, standing in one plane,
  against the convex hull of their bottom bricks' polygons); or it moves in a collapse
  mechanism that statics proved (the stability extension's equilibrium model: rigid-block
  equilibrium, or a part turning out about an edge); or
- the run ends while it is displaced.

How far a brick has moved is no proof by itself: a brick whose centre of mass lies 1.5 mm
inside its support's edge can rock on landing until its far end is 8 mm up, and comes back.
A brick that tips over, slides off or is knocked away has collapsed. The collapse is dated
from the moment the brick was first displaced, and its level is the highest level placed
then: bricks placed while the monitor waits to tell a rock from a fall do not raise the level.
The brick that passed the threshold first is named with its own level (the first moved: where
a blow began the collapse, which can lie below the collapse level). The definition is the same
in every mode.

When the run ends without a collapse, the monitor asks for the certificate of the structure
as it stands (:meth:`stability.StabilityExtension.certificate`): rigid-block equilibrium of
every brick where it is. A structure with no equilibrium has not stood: that is a collapse
too, proved by its mechanism.

The proofs by kind: "displaced at the end", "at rest displaced" and "mechanism" are the
monitor's own (:meth:`CollapseMonitor._proof`); "off its support" is
:mod:`stackdsl.runtime.support`'s; "still moving", "equilibrium" and "no equilibrium", at the end
of a run that decided no collapse, :mod:`stackdsl.runtime.end_proofs`'.

Source: stackdsl's own (the report declares a collapse when a brick falls off the stack,
without a threshold).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Collection
from collections.abc import Set as AbstractSet
from dataclasses import dataclass

import numpy as np

from stability import Certificate as Equilibrium
from stability import OutOfTime

from .actions import Actions
from .bricks import FEW, BrickRecord
from .end_proofs import MotionWindow, named, stand_words
from .loop import StepLoop, Subscriber
from .outcome import Certificate, Collapse, Event, Graph, ProofKind
from .support import EXACT_TIE, OffSupport, PlacedLoad


@dataclass
class _Displaced:
    """A brick past the threshold, not yet known to stay so: since when (s), the level
    placed then, the farthest it went (m), the brick graph then and the step it was built at
    the end of, and since when it has been at rest (s, or None)."""

    since: float
    level: int
    farthest: float
    graph: tuple[Graph, int]
    resting_since: float | None = None


def signed_margin(placed: float, past: float) -> float:
    """A collapse's signed margin, metres (negative; :attr:`stackdsl.Outcome.margin`): ``placed``,
    the least margin of a part as it was placed (:meth:`OffSupport.least_placed_margin`), when it is
    negative (statics alone fells the structure, by that much: continuous with a stand's
    certificate margin across the boundary); else minus ``past``, how far the deciding proof went
    past its limit when it decided (the centre of mass outside its support polygon, or a brick
    past the collapse threshold), at most 0. Source: stackdsl's own.

    >>> signed_margin(-0.0046, 0.002), signed_margin(0.012, 0.0015), signed_margin(float("inf"), 0.0)
    (-0.0046, -0.0015, -0.0)
    """
    if placed < 0.0:
        return placed
    return -max(0.0, past)


class CollapseMonitor(Subscriber):
    """The first collapse (see the module's description), and the certificate of the verdict.

    At the collapse the monitor records it with its proof, keeps the brick graph of the moment
    the brick was first displaced and asks the loop to end ``settle`` seconds later. Until then
    it tracks the drift, the largest displacement within the threshold of a standing brick,
    seen before each placement.

    Args:
        threshold: metres (the program's collapse threshold).
        settle: seconds the run goes on after the collapse is decided.
        graph: the brick graph now.
        certify: rigid-block equilibrium of the bricks where they are now, its programs solved
            by the deadline given (``time.perf_counter`` seconds, None: no limit), else
            :class:`stability.OutOfTime`.
        proved: brick id -> the collapse mechanism statics proved it moves in (in words, and
            the bricks it moves), or None.
        rest_speed, rest_angular_speed: m/s and rad/s under which a brick is at rest.
        rest_duration: seconds a displaced brick must stay at rest to have come to rest.

    Attributes:
        collapse: the first collapse, or None; collapse_graph: the graph when it began;
        graph_step: the step at whose end the collapse graph was built (None before a collapse);
        passed: how many times, before the collapse was decided, a brick was found past the
        threshold (the collapse is dated at one of these steps: a recorder keeps a frame at each);
        certificate: how the verdict was proved (None until the collapse or the end, and
        when the run stopped early); drift: metres; certify_time: wall seconds the
        equilibrium certificate of a standing structure took; margin: the verdict's signed
        margin, metres (:func:`signed_margin`; None until the verdict, and when undecided).
    """

    def __init__(
        self,
        threshold: float,
        settle: float,
        graph: Callable[[StepLoop], Graph],
        certify: Callable[[float | None], Equilibrium],
        proved: Callable[[str], tuple[str, tuple[str, ...]] | None],
        rest_speed: float = 0.005,
        rest_angular_speed: float = 0.05,
        rest_duration: float = 0.05,
        near_ties: Callable[[], dict[str, str]] = dict,
    ) -> None:
        self.threshold, self.settle, self._graph = threshold, settle, graph
        self._near_ties = near_ties
        self._window = MotionWindow(rest_speed, rest_angular_speed, rest_duration)
        self._certify, self._proved = certify, proved
        self._rest = self._window.rest
        self.collapse: Collapse | None = None
        self.collapse_graph: Graph | None = None
        self.graph_step: int | None = None
        self.passed = 0
        self.certificate: Certificate | None = None
        self.drift = 0.0
        self.certify_time = 0.0
        self.margin: float | None = None
        self._displaced: dict[str, _Displaced] = {}
        #: the support polygons and the proof "off its support" (:mod:`stackdsl.runtime.support`)
        self.off_support = OffSupport()

    @property
    def quiet(self) -> bool:
        """Not while a displaced brick is yet to be told rocking from falling."""
        return not self._displaced

    @property
    def past_threshold(self) -> bool:
        """A structure brick is past the collapse threshold now, or a collapse was decided: the
        collapse, if it comes, is dated already and its level fixed (:meth:`_track`)."""
        return self.past_threshold_besides(())

    def past_threshold_besides(self, moved_by_hand: Collection[str]) -> bool:
        """:attr:`past_threshold`, the bricks of ``moved_by_hand`` (ids) left out: a brick a pusher
        drives is displaced by the hand, and its drag on what it carries still decides."""
        return self.collapse is not None or any(i not in moved_by_hand for i in self._displaced)

    def on_place(self, loop: StepLoop, record: BrickRecord) -> None:
        self.record_drift(loop, exclude=record)
        self.off_support.place(loop, record)

    def at_end(self, loop: StepLoop) -> None:
        self.off_support.weigh(loop)
        moving, said = self._window.still_moving(loop) if self.collapse is None else (set(), "")
        if self.collapse is None and self._displaced:
            self._decide(loop, displaced_at_end=True, in_flight=moving)
        self.record_drift(loop)
        if self.collapse is not None or loop.stopped is not None:
            return
        if (off := self.off_support.placed_off) is not None:  # the engine held what statics fells
            self._placed_off(loop, off)
            return
        if moving:  # no static argument on a pose in flight: the run was too short to tell
            records = loop.structure.records
            ties = "".join(dict.fromkeys(self._near_tie(loop, records[i]) for i in sorted(moving) if i in records))  # why slow
            ties = ties or self._load_tie(loop)
            self.certificate = Certificate(verdict="undecided", kind="still moving", detail=said + ties, bricks=())
            return
        started = time.perf_counter()
        try:
            certificate = self._certify(loop.deadline)
        except OutOfTime:  # the run's budget holds for statics too: stopped, as a run out of time is
            loop.time_out("proving that it stands")
            return
        finally:
            self.certify_time = time.perf_counter() - started
        if certificate.stands:
            margin = max(0.0, float(certificate.margin) - self._settling(loop))
            self.certificate = Certificate(
                verdict="stands",
                kind="equilibrium",
                detail=stand_words(certificate, self._near_ties()) + self._load_tie(loop, "; "),
                margin_mm=math.floor(round(margin * 10_000, 6)) / 10 + 0.0,  # down: never above it
                friction_share=math.ceil(round(certificate.friction * 100, 6)) / 100,
            )
            self.margin = margin
            return
        records, placed = loop.structure.records, loop.structure.placed
        bricks = [records[i] for i in certificate.mechanism if i in records and records[i].level is not None]
        if not bricks:  # only projectiles move in it: the structure stands on what holds it
            self.certificate = Certificate(
                verdict="stands", kind="equilibrium", detail="the structure's bricks balance", bricks=()
            )
            self.margin = float(certificate.margin) if math.isfinite(certificate.margin) else None
            return
        first, moved = named(bricks, loop.structure.displacements(bricks))
        level = max(loop.structure.levels.values())
        detail = f"no equilibrium at the end: {certificate.tension:.3g} N of tension needed"
        self._record(
            loop,
            first,
            level,
            loop.now,
            moved,
            loop.now,
            Certificate(verdict="collapse", kind="no equilibrium", detail=detail, bricks=certificate.mechanism),
            None,
        )
        self.margin = signed_margin(self.off_support.least_placed_margin(loop, placed), 0.0)

    def after_step(self, loop: StepLoop) -> None:
        self.off_support.weigh(loop)
        if self.collapse is None and (self._displaced or loop.structure.moving):  # else nothing can have moved
            self._window.watch(loop)
            self._decide(loop)

    def _decide(self, loop: StepLoop, displaced_at_end: bool = False, in_flight: AbstractSet[str] = frozenset()) -> None:
        """Decide whether a displaced brick has collapsed (the module docstring's proofs, in the
        order of :meth:`_proof`); with ``displaced_at_end``, the run's end decides for a displaced
        brick that is not ``in_flight`` (still moving:
        :meth:`stackdsl.runtime.end_proofs.MotionWindow.still_moving`)."""
        watched, moved = loop.structure.measure(self._displaced, self.threshold)
        if not watched:  # nothing displaced, nothing near the threshold: the usual step
            return
        pending, threshold = self._displaced, self.threshold
        displaced: list[tuple[BrickRecord, float]] = []
        for record, distance in zip(watched, moved.tolist()):
            if distance > threshold:
                displaced.append((record, distance))
            elif distance <= threshold:
                pending.pop(record.id, None)  # within the threshold, or rocked and came back
        resting = self._resting(loop, [r for r, _ in displaced])
        # while a hand drags (a pull, a push) or the ground shakes, nothing is decided: a brick at
        # rest on what a hand moves has not come to rest where it stays, and a static argument
        # (its centre of mass off its support, a mechanism) holds on a still base only: a slender
        # block rocked 13.5 deg on a shake table, past its tipping angle, and came back
        hands_busy = any(isinstance(s, Actions) and not s.quiet for s in loop.subscribers) and not displaced_at_end
        now = loop.now
        for (record, distance), rests in zip(displaced, resting):
            state = pending.get(record.id)
            if state is None:
                state = self._track(loop, record, distance)
            elif distance > state.farthest:
                state.farthest = distance
            if not rests:
                state.resting_since = None
            elif state.resting_since is None:
                state.resting_since = now
            if hands_busy:
                continue
            if displaced_at_end and record.id in in_flight:  # in flight at the end: at_end says it still moves
                continue
            rested = state.resting_since is not None and now - state.resting_since >= self._rest[2] - 1e-9
            proof = self._proof(loop, record, distance, rested, displaced_at_end)
            if proof is not None:
                self._collapsed(loop, record, distance, proof)
                return

    def _track(self, loop: StepLoop, record: BrickRecord, distance: float) -> _Displaced:
        """Note that ``record``, not displaced before, is ``distance`` metres from its place, past
        the threshold: dated now, with the level placed now and the brick graph now. The caller
        keeps its farthest displacement and since when it rests (:meth:`_decide`)."""
        level = max(loop.structure.levels.values())
        # the graph of the moment the first pending brick was displaced serves the others
        # (a collapse is dated at the earliest of them; one graph a brick cost 85 ms each
        # for the 50 bricks of a falling tower)
        pending = [d for d in self._displaced.values() if d.level == level]
        graph = min(pending, key=lambda d: d.since).graph if pending else (self._graph(loop), loop.step)
        state = self._displaced[record.id] = _Displaced(loop.now, level, distance, graph)
        self.passed += 1
        return state

    def _proof(
        self, loop: StepLoop, record: BrickRecord, distance: float, rested: bool, displaced_at_end: bool
    ) -> tuple[ProofKind, str, tuple[str, ...]] | None:
        """The first proof that displaced ``record`` (``distance`` metres from its place) stays
        moved, or None: displaced when the run ends; at rest displaced (frozen, or ``rested``);
        moving in a mechanism statics proved; off its support (:mod:`stackdsl.runtime.support`)."""
        if displaced_at_end:
            return ("displaced at the end", f"{record.id} was {distance * 1000:.1f} mm from its place when the run ended", ())
        if not record.moving or rested:
            return ("at rest displaced", f"{record.id} came to rest {distance * 1000:.1f} mm from its place", ())
        if (mechanism := self._proved(record.id)) is not None:
            return ("mechanism", f"{record.id} moves in {mechanism[0]}", mechanism[1])
        return self.off_support.proof(loop, record)

    def _near_tie(self, loop: StepLoop, record: BrickRecord) -> str:
        """A note for a brick placed with its centre of mass inside its support polygon's edge
        by less than the engine's contact margin (:attr:`EngineSettings.contact_margin`: statics
        says it stands, and the engine's contact points may tip it), or within :data:`EXACT_TIE`
        of the edge either way (an exact tie, which statics cannot tell either); else, the first
        part placed so (a brick with the load it carries, :attr:`OffSupport.ties`: two bricks
        together 1.5 um past the edge of the one under them); "" otherwise."""
        support = self.off_support.supports.get(record.id)
        margin = math.inf if support is None else support.placed_margin
        engine = loop.program.engine
        within = f"within {engine.NAME}'s {engine.contact_margin * 1000:g} mm contact margin"
        if abs(margin) < EXACT_TIE:
            side = "inside" if margin >= 0 else "outside"
            return f" (placed {abs(margin) * 1000:.2f} mm {side} its support's edge: an exact tie, {within})"
        if 0.0 <= margin < engine.contact_margin:
            return f" (placed {margin * 1000:.2f} mm inside its support's edge: a near tie, {within})"
        return self._load_tie(loop)

    def _load_tie(self, loop: StepLoop, lead: str = " (") -> str:
        """The first part of several bricks placed on an exact tie (:attr:`OffSupport.ties`: two
        bricks together 1.5 um past the edge of the one under them), in words led by ``lead``
        (closed by ")" after " ("), or ""."""
        load = next((t for t in self.off_support.ties if t.bricks > 1), None)
        if load is None:
            return ""
        engine = loop.program.engine
        said = f"{load.words()}: an exact tie, within {engine.NAME}'s {engine.contact_margin * 1000:g} mm contact margin"
        return f"{lead}{said}{')' if lead == ' (' else ''}"

    def _settling(self, loop: StepLoop) -> float:
        """Metres: how far apart the engine's contacts settled the placed structure bricks from
        where they were placed, of those whose centres moved under :data:`EXACT_TIE` (MuJoCo's
        landed a brick 15 um further onto its support than placed): the diagonal of the box
        around their horizontal moves, no less than any two bricks' moves differ by. The
        equilibrium margin is measured where the engine holds the bricks; a part's centre of
        mass and the edge under it move by an average of its bricks' moves and by its support's,
        so the margin moves by at most this, and a stand's margin less this bounds the placed
        geometry's too (a brick that moved further has moved for a reason, and the margin is
        of where it stands; a settled stack that slid as one loses nothing)."""
        placed = [r for r in loop.structure.placed if r.level is not None]
        if len(placed) < 2:
            return 0.0
        positions, _ = loop.world.poses_of([r.body for r in placed])
        now = positions - np.asarray(loop.structure.offset)
        moves = now[:, :2] - np.array([r.pose.position[:2] for r in placed])
        settled = moves[np.hypot(moves[:, 0], moves[:, 1]) < EXACT_TIE]
        return float(np.hypot(*np.ptp(settled, axis=0))) if len(settled) > 1 else 0.0

    def _placed_off(self, loop: StepLoop, off: PlacedLoad) -> None:
        """Record the collapse exact statics on the placed geometry proves and the engine's
        contacts did not show (:attr:`OffSupport.placed_off`): a part placed with its centre of
        mass outside its support polygon falls at the level placed then (MuJoCo's soft contacts
        held a brick placed 0.265 mm past the edge of the one under it for its whole settle)."""
        records = loop.structure.records
        first = records[off.brick]
        tie = ": an exact tie" if abs(off.margin) < EXACT_TIE else ""
        detail = f"{off.words()}{tie}: statics on the placed geometry decided, not the engine, whose contacts held it"
        certificate = Certificate(verdict="collapse", kind="off its support", detail=detail, bricks=(off.brick,))
        (moved,) = loop.structure.displacements([first])
        self._record(loop, first, off.level, off.time, float(moved), loop.now, certificate, None)
        self.margin = off.margin

    def _resting(self, loop: StepLoop, records: list[BrickRecord]) -> list[bool]:
        """Whether each brick's speeds are under the rest thresholds now (a frozen one's are)."""
        moving = [r for r in records if r.moving]
        if not moving:
            return [True] * len(records)
        speed, spin = self._rest[0] ** 2, self._rest[1] ** 2
        if len(moving) <= FEW:  # in floats, the squares summed in numpy's order: numpy's fixed costs are most of it
            slow = []
            for r in moving:
                (vx, vy, vz), (wx, wy, wz) = loop.world.velocity_floats(r.body)
                slow.append(vx * vx + vy * vy + vz * vz <= speed and wx * wx + wy * wy + wz * wz <= spin)
        else:
            lin, ang = loop.world.velocities_of([r.body for r in moving])
            slow = (((lin**2).sum(axis=1) <= speed) & ((ang**2).sum(axis=1) <= spin)).tolist()
        if len(moving) == len(records):
            return slow
        each = iter(slow)
        return [next(each) if r.moving else True for r in records]

    def _collapsed(
        self, loop: StepLoop, record: BrickRecord, moved: float, proof: tuple[ProofKind, str, tuple[str, ...]]
    ) -> None:
        """``record`` stays moved: the collapse began when the first of the bricks displaced now
        was displaced; that brick is the one named. The bricks involved: those displaced now,
        and those of the proved mechanism."""
        first_id = min(self._displaced, key=lambda i: self._displaced[i].since)
        first, state = loop.structure.records[first_id], self._displaced[first_id]
        if (off := self.off_support.placed_off) is not None and off.level < state.level:
            self._placed_off(loop, off)  # statics felled it a level before the engine let it go
            return
        farthest = moved if first is record else state.farthest
        kind, detail, moved_too = proof
        by = None if first is record else detail  # the timeline's line says what decided it, of another brick
        if first is not record:  # the collapse is named after the brick that moved first
            detail += f" ({first.id} moved first; this proof decided the collapse)"
        detail += self._near_tie(loop, first)  # a tie the engine's contacts decided: said
        records = loop.structure.records
        bricks = tuple(sorted({*self._displaced, *(b for b in moved_too if b in records)}, key=lambda i: records[i].order))
        certificate = Certificate(verdict="collapse", kind=kind, detail=detail, bricks=bricks)
        past = self.off_support.proved_out if kind == "off its support" else moved - self.threshold
        self.margin = signed_margin(self.off_support.least_placed_margin(loop, loop.structure.placed), past)
        self._record(loop, first, state.level, state.since, farthest, loop.now, certificate, state.graph, by)

    def _record(
        self,
        loop: StepLoop,
        first: BrickRecord,
        level: int,
        since: float,
        farthest: float,
        decided: float,
        proof: Certificate,
        graph: tuple[Graph, int] | None,
        by: str | None = None,
    ) -> None:
        """Record the collapse of ``first`` (the brick named), proved by ``proof``; ``by``, the
        proof's words when it is of another brick (the timeline's line then says them)."""
        assert first.level is not None
        self.record_drift(loop)
        self.collapse = Collapse(
            level=level, time=since, brick=first.id, brick_level=first.level, displacement=farthest, decided=decided
        )
        self.certificate = proof
        detail = f"moved {farthest * 1000:.1f} mm by t={decided:.2f} s, when it was decided; collapse level {level}; {proof.kind}"
        if by is not None:
            detail += f": {by}"
        if proof.kind == "no equilibrium":
            detail = f"collapse level {level}; {proof.detail}"
        loop.events.append(Event(time=since, kind="collapse", brick=first.id, level=first.level, detail=detail))
        loop.events.sort(key=lambda e: e.time)
        self.collapse_graph, self.graph_step = graph if graph is not None else (self._graph(loop), loop.step)
        self._displaced.clear()
        loop.stop_after(self.settle)

    def record_drift(self, loop: StepLoop, exclude: BrickRecord | None = None) -> None:
        """Track the largest displacement of the standing structure until the first collapse:
        of the moving bricks now, and of the frozen ones as they froze. A frozen brick's is
        looked at once, after it froze (the drift is a running maximum), not at every placement
        (a tower of 1000 bricks read 500 000 of them)."""
        structure = loop.structure
        fresh, structure.newly_settled = structure.newly_settled, []
        if self.collapse is not None:
            return
        moving = [r for r in structure.moving.values() if r is not exclude]
        now = [*structure.displacements(moving), *(r.settled for r in fresh if r.settled is not None)]
        self.drift = max([self.drift, *(float(d) for d in now if d <= self.threshold)])

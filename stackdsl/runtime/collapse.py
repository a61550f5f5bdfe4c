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

Source: stackdsl's own (the report declares a collapse when a brick falls off the stack,
without a threshold).
"""

from __future__ import annotations

import heapq
import math
import time
from collections.abc import Callable, Sequence
from collections.abc import Set as AbstractSet
from dataclasses import dataclass

import numpy as np
import shapely
from shapely import contains_xy, convex_hull
from shapely.geometry import Point
from shapely.geometry.base import BaseGeometry

from stability import JITTER, Box, Plane, Pose, face_overlap, hull_xy, still
from stability import Certificate as Equilibrium

from ..compile.program import Fixture
from .actions import Actions
from .bricks import BrickRecord, footprint
from .loop import StepLoop, Subscriber
from .outcome import Certificate, Collapse, Event, Graph, ProofKind

#: Metres: the bottom face of a placed brick and the top face of what it rests on lie within this.
FACE_GAP = 0.001


#: Metres a displaced brick's centre of mass must lie outside the support polygon it was placed on
#: for that to prove a collapse: a brick pushed 35 mm along its supports came to rest with its
#: centre of mass 0.04 mm past the polygon's edge, which proved nothing. A brick that tips is past
#: this within a step or two.
OFF_SUPPORT = 0.0005

#: Metres from its support polygon's edge within which a placed brick is an exact tie: statics
#: itself cannot tell where the engine's floats put it (a collapse of such a brick says so).
EXACT_TIE = 1e-4

#: Metres further out than it was placed that a brick placed with its centre of mass outside its
#: support polygon must go for that to prove a collapse: an overhang placed 1.5 mm out is 0.27 mm
#: further when a corner has moved the threshold's 4 mm; one end of a flat arch, held by its
#: partner, sags without going further out.
FURTHER_OFF = 0.0001


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


@dataclass
class _Group:
    """Bricks that tip as one (:meth:`CollapseMonitor._group`): all of them in the order placed,
    their bottom bricks (on the ground or a fixed body, in one plane), and how far (m) their
    centre of mass lay outside the convex hull of those bricks' polygons as placed (0 inside)."""

    bricks: list[BrickRecord]
    bottoms: list[BrickRecord]
    placed_out: float


@dataclass
class SupportPolygon:
    """Where a brick was placed to rest: the overlap of its bottom face with each body under it,
    each kept in the frame of that body so that it moves with it. Found when first asked
    (only a displaced brick is), from the poses at placing.

    Args:
        box, pose: the brick and its placed pose.
        below: (body or None for a fixed one, shape, pose at placing or None for the ground)
            of each body it may rest on.

    Source: stackdsl's own (the support polygon of report 3.3.3, from the placed poses).
    """

    box: Box
    pose: Pose
    below: list[tuple[int | None, Box | Plane, Pose | None]]
    _pieces: tuple[tuple[int | None, np.ndarray], ...] | None = None
    _placed_margin: float | None = None
    _on_planes: int = 0  # how many of the pieces lie on the ground (a plane)

    @property
    def pieces(self) -> tuple[tuple[int | None, np.ndarray], ...]:
        """(support body or None for a fixed one, the overlap's vertices shape (k, 3), metres: in
        the support's frame, in the world for a fixed one) for each body whose top face lies
        within :data:`FACE_GAP` of the brick's bottom face; none for a tilted brick."""
        if self._pieces is None:
            pieces = []
            for body, shape, where in self.below:
                area = face_overlap(self.box, self.pose, shape, where, FACE_GAP)
                if area is None or area.area <= 0.0:
                    continue
                corners = area.corners()
                if body is not None and where is not None:
                    corners = (corners - where.position) @ where.rotation  # into the support's frame
                pieces.append((body, corners))
                self._on_planes += isinstance(shape, Plane)
            self._pieces = tuple(pieces)
        return self._pieces

    @property
    def on_the_ground_alone(self) -> bool:
        """Whether the brick was placed on the ground and on nothing else."""
        return bool(self.pieces) and self._on_planes == len(self.pieces)

    def beyond_its_base(self, pose: Pose, com: np.ndarray | None = None) -> float:
        """Metres the brick's centre of mass, at ``pose`` now, lies horizontally beyond the edge
        of the face it was placed on (that face as it is now, seen from above); 0 over it. On the
        ground, which reaches everywhere, this is what leaving its support means: a post that
        tips past the edge of its foot has, one that slides along the ground has not. ``com``:
        another centre of mass to measure (shape (3,): of the brick with what it carries)."""
        placed = self.box.corners(self.pose)
        face = np.argsort(placed[:, 2])[:4]  # the four lowest corners as placed: the face it stood on
        now = self.box.corners(pose)[face]
        hull = hull_xy(now[:, :2])
        point = pose.position if com is None else com
        x, y = float(point[0]), float(point[1])
        return 0.0 if contains_xy(hull, x, y) else float(hull.distance(Point(x, y)))

    @property
    def placed_outside(self) -> float:
        """Metres the brick's centre of mass lay outside the polygon as it was placed (0 inside).
        A brick placed so either tips at once (an overhang), its centre of mass going further
        out, or is held by something else (one end of a flat arch by its partner), where lying
        outside proves nothing: only how much further out it went counts."""
        return max(0.0, -self.placed_margin)

    @property
    def placed_margin(self) -> float:
        """Metres the brick's centre of mass lay inside the polygon's edge as it was placed
        (negative: outside it; inf with no polygon, a tilted brick)."""
        if self._placed_margin is None:
            self._placed_margin = self.placed_margin_of(self.pose.position)
        return self._placed_margin

    def placed_margin_of(self, com: np.ndarray) -> float:
        """:attr:`placed_margin` of another centre of mass ``com`` (shape (3,), in the world as
        placed: of the brick with the bricks it carries)."""
        return _signed_margin(self.placed_hull(), com)

    def _hull(
        self, poses: dict[int, Pose], offset: tuple[float, float, float] = (0.0, 0.0, 0.0), gone: AbstractSet[int] = frozenset()
    ) -> BaseGeometry | None:
        """The polygon (shapely, horizontal) with its supports at ``poses`` (body -> pose, in the
        world; the ground ``offset`` m from where it started), leaving out the pieces on the
        bodies ``gone``; None without a piece."""
        pieces = [(b, c) for b, c in self.pieces if b not in gone]
        if not pieces:
            return None
        points = [c if b is None else c @ poses[b].rotation.T + poses[b].position - offset for b, c in pieces]
        return hull_xy(np.vstack(points)[:, :2])

    def placed_hull(self) -> BaseGeometry | None:
        """The polygon as the brick was placed (shapely, horizontal; None without a piece)."""
        return self._hull({body: pose for body, _, pose in self.below if body is not None and pose is not None})

    def region(
        self,
        pose: Pose,
        poses: dict[int, Pose],
        offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
        gone: AbstractSet[int] = frozenset(),
    ) -> BaseGeometry | None:
        """What the brick stands on now, seen from above (shapely; None without a piece): on the
        ground alone, the face it stood on with the brick at ``pose`` (in the ground's frame), as
        :meth:`beyond_its_base` measures; else the polygon, as :meth:`outside` measures."""
        if self.on_the_ground_alone:
            placed = self.box.corners(self.pose)
            face = np.argsort(placed[:, 2])[:4]
            return hull_xy(self.box.corners(pose)[face][:, :2])
        return self._hull(poses, offset, gone)

    def outside(
        self,
        com: np.ndarray,
        poses: dict[int, Pose],
        offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
        gone: AbstractSet[int] = frozenset(),
    ) -> float:
        """Metres the horizontal projection of ``com`` (shape (3,), in the ground's frame) lies
        outside the polygon, the supports at ``poses`` (body -> pose now, in the world; the
        ground ``offset`` m from where it started, as a shake table moves it), leaving out the
        pieces on the bodies ``gone`` (pulled out of the scene); 0 inside, and when there are no
        pieces."""
        hull = self._hull(poses, offset, gone)
        x, y = float(com[0]), float(com[1])
        if hull is None or contains_xy(hull, x, y):
            return 0.0
        return float(hull.distance(Point(x, y)))


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
        certify: rigid-block equilibrium of the bricks where they are now.
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
        equilibrium certificate of a standing structure took.
    """

    def __init__(
        self,
        threshold: float,
        settle: float,
        graph: Callable[[StepLoop], Graph],
        certify: Callable[[], Equilibrium],
        proved: Callable[[str], tuple[str, tuple[str, ...]] | None],
        rest_speed: float = 0.005,
        rest_angular_speed: float = 0.05,
        rest_duration: float = 0.05,
        near_ties: Callable[[], dict[str, str]] = dict,
    ) -> None:
        self.threshold, self.settle, self._graph = threshold, settle, graph
        self._near_ties = near_ties
        # where the moving bricks were, once a rest duration (:meth:`_watch`): (time, id -> pose)
        self._window: tuple[tuple[float, dict[str, Pose]], ...] = ()
        self._certify, self._proved = certify, proved
        self._rest = (rest_speed, rest_angular_speed, rest_duration)
        self.collapse: Collapse | None = None
        self.collapse_graph: Graph | None = None
        self.graph_step: int | None = None
        self.passed = 0
        self.certificate: Certificate | None = None
        self.drift = 0.0
        self.certify_time = 0.0
        self._displaced: dict[str, _Displaced] = {}
        self._supports: dict[str, SupportPolygon] = {}
        self._carries: dict[str, list[str]] = {}  # brick id -> the ids of the bricks placed on it
        self._parts: dict[str, tuple[tuple[int, int], list[BrickRecord]]] = {}  # :meth:`_part`, and when
        self._placed: dict[tuple[tuple[str, ...], tuple[str, ...]], float] = {}  # :meth:`_placed_out`
        self._groups: dict[str, tuple[tuple[int, int], _Group | None]] = {}  # :meth:`_group`, and when
        self._helds: dict[tuple[str, ...], tuple[tuple[int, int], bool]] = {}  # :meth:`_held`, and when

    @property
    def quiet(self) -> bool:
        """Not while a displaced brick is yet to be told rocking from falling."""
        return not self._displaced

    def on_place(self, loop: StepLoop, record: BrickRecord) -> None:
        self.record_drift(loop, exclude=record)
        others = record.below
        positions, quaternions = loop.world.poses_of([r.body for r in others]) if others else (np.zeros((0, 3)),) * 2
        below: list[tuple[int | None, Box | Plane, Pose | None]] = [(None, Plane(0.0), None)]
        below += [(None, Box(np.array(f.brick.half_extents), f.brick.mass), _fixture_pose(f)) for f in loop.program.fixtures]
        below += [(r.body, r.box, Pose(p, q)) for r, p, q in zip(others, positions, quaternions)]
        self._supports[record.id] = SupportPolygon(record.box, record.pose, below)
        for r in others:
            self._carries.setdefault(r.id, []).append(record.id)

    def at_end(self, loop: StepLoop) -> None:
        moving, said = self._still_moving(loop) if self.collapse is None else (set(), "")
        if self.collapse is None and self._displaced:
            self._decide(loop, displaced_at_end=True, in_flight=moving)
        self.record_drift(loop)
        if self.collapse is not None or loop.stopped is not None:
            return
        if moving:  # no static argument on a pose in flight: the run was too short to tell
            records = loop.structure.records
            ties = "".join(self._near_tie(loop, records[i]) for i in sorted(moving) if i in records)  # why it is slow
            self.certificate = Certificate(verdict="undecided", kind="still moving", detail=said + ties, bricks=())
            return
        started = time.perf_counter()
        certificate = self._certify()
        self.certify_time = time.perf_counter() - started
        if certificate.stands:
            self.certificate = Certificate(
                verdict="stands",
                kind="equilibrium",
                detail=(
                    (
                        f"each of {certificate.bricks} bricks frozen over its load path to the ground"
                        if certificate.bricks != 1
                        else "the brick frozen over its load path to the ground"
                    )
                    + _friction(certificate.friction)
                    if certificate.method == "load paths"
                    else f"the equilibrium program balances {_count(certificate.bricks, 'brick')} on "
                    f"{_count(certificate.contacts, 'contact')}{_friction(certificate.friction)}"
                )
                + _statics(self._near_ties()),
                margin_mm=math.floor(round(certificate.margin * 10_000, 6)) / 10 + 0.0,  # down: never above it
                friction_share=math.ceil(round(certificate.friction * 100, 6)) / 100,
            )
            return
        records = loop.structure.records
        bricks = [records[i] for i in certificate.mechanism if i in records and records[i].level is not None]
        if not bricks:  # only projectiles move in it: the structure stands on what holds it
            self.certificate = Certificate(
                verdict="stands", kind="equilibrium", detail="the structure's bricks balance", bricks=()
            )
            return
        first, moved = _named(bricks, loop.structure.displacements(bricks))
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

    def after_step(self, loop: StepLoop) -> None:
        if self.collapse is None and (self._displaced or loop.structure.moving):  # else nothing can have moved
            self._watch(loop)
            self._decide(loop)

    def _decide(self, loop: StepLoop, displaced_at_end: bool = False, in_flight: AbstractSet[str] = frozenset()) -> None:
        """Decide whether a displaced brick has collapsed (the module docstring's proofs); with
        ``displaced_at_end``, the run's end decides for a displaced brick that is not
        ``in_flight`` (still moving: :meth:`_still_moving`)."""
        structure = loop.structure
        moving = list(structure.moving.values())
        if not self._displaced:  # the usual step: only what may have moved is looked at
            watched = structure.may_have_moved(moving, self.threshold)
        else:
            watched = [structure.records[i] for i in self._displaced if not structure.records[i].moving]
            watched += [r for r in moving if r.id in self._displaced]
            watched += [r for r in structure.may_have_moved(moving, self.threshold) if r.id not in self._displaced]
        if not watched:  # nothing displaced, nothing near the threshold: the usual step
            return
        watched.sort(key=lambda r: r.order)
        moved = structure.displacements(watched)
        for record, distance in zip(watched, moved):
            if distance <= self.threshold:
                self._displaced.pop(record.id, None)  # within the threshold, or rocked and came back
        displaced = [(r, float(d)) for r, d in zip(watched, moved) if d > self.threshold]
        resting = self._resting(loop, [r for r, _ in displaced])
        # while a hand drags (a pull, a push) or the ground shakes, nothing is decided: a brick at
        # rest on what a hand moves has not come to rest where it stays, and a static argument
        # (its centre of mass off its support, a mechanism) holds on a still base only: a slender
        # block rocked 13.5 deg on a shake table, past its tipping angle, and came back
        hands_busy = any(isinstance(s, Actions) and not s.quiet for s in loop.subscribers) and not displaced_at_end
        for (record, distance), rests in zip(displaced, resting):
            state = self._displaced.get(record.id)
            if state is None:
                level = max(structure.levels.values())
                # the graph of the moment the first pending brick was displaced serves the others
                # (a collapse is dated at the earliest of them; one graph a brick cost 85 ms each
                # for the 50 bricks of a falling tower)
                pending = [d for d in self._displaced.values() if d.level == level]
                graph = min(pending, key=lambda d: d.since).graph if pending else (self._graph(loop), loop.step)
                state = self._displaced[record.id] = _Displaced(loop.now, level, distance, graph)
                self.passed += 1
            state.farthest = max(state.farthest, distance)
            if not rests:
                state.resting_since = None
            elif state.resting_since is None:
                state.resting_since = loop.now
            rested = state.resting_since is not None and loop.now - state.resting_since >= self._rest[2] - 1e-9
            proof: tuple[ProofKind, str, tuple[str, ...]] | None = None
            if hands_busy:
                continue
            if displaced_at_end and record.id in in_flight:  # in flight at the end: at_end says it still moves
                continue
            if displaced_at_end:
                proof = (
                    "displaced at the end",
                    f"{record.id} was {distance * 1000:.1f} mm from its place when the run ended",
                    (),
                )
            elif not record.moving or rested:
                proof = (
                    "at rest displaced",
                    f"{record.id} came to rest {distance * 1000:.1f} mm from its place",
                    (),
                )
            elif (mechanism := self._proved(record.id)) is not None:
                proof = ("mechanism", f"{record.id} moves in {mechanism[0]}", mechanism[1])
            elif (off := self._off_support(loop, record)) is not None:
                proof = off
            if proof is not None:
                self._collapsed(loop, record, distance, proof)
                return

    def _near_tie(self, loop: StepLoop, record: BrickRecord) -> str:
        """A note for a brick placed with its centre of mass inside its support polygon's edge
        by less than the engine's contact margin (:attr:`EngineSettings.contact_margin`: statics
        says it stands, and the engine's contact points may tip it), or within :data:`EXACT_TIE`
        of the edge either way (an exact tie, which statics cannot tell either); "" otherwise."""
        support = self._supports.get(record.id)
        margin = math.inf if support is None else support.placed_margin
        engine = loop.program.engine
        within = f"within {engine.NAME}'s {engine.contact_margin * 1000:g} mm contact margin"
        if abs(margin) < EXACT_TIE:
            side = "inside" if margin >= 0 else "outside"
            return f" (placed {abs(margin) * 1000:.2f} mm {side} its support's edge: an exact tie, {within})"
        if not 0.0 <= margin < engine.contact_margin:
            return ""
        return f" (placed {margin * 1000:.2f} mm inside its support's edge: a near tie, {within})"

    def _part(self, loop: StepLoop, record: BrickRecord) -> list[BrickRecord]:
        """``record`` and the bricks it carries: those placed on it, or on it and on bricks it
        carries, and on nothing else (a counterweight on a cantilever's back end, the bricks of
        a harmonic stack above it), in the order they were placed. They tip with it."""
        records, removed = loop.structure.records, {r.id for r in loop.structure.removed}
        key = (len(records), len(removed))  # a part changes only when a brick is placed or taken out
        if (known := self._parts.get(record.id)) is not None and known[0] == key:
            return known[1]
        part, bodies = [record], {record.body}
        heap = [(records[i].order, i) for i in self._carries.get(record.id, ())]
        heapq.heapify(heap)
        seen = {i for _, i in heap}
        while heap:  # in the order placed: what a candidate rests on is decided before it
            _, i = heapq.heappop(heap)
            r = records[i]
            support = self._supports.get(i)
            if r.level is None or i in removed or support is None or not support.pieces:
                continue
            if not all(b is not None and b in bodies for b, _ in support.pieces):
                continue
            part.append(r)
            bodies.add(r.body)
            for j in self._carries.get(i, ()):
                if j not in seen:
                    seen.add(j)
                    heapq.heappush(heap, (records[j].order, j))
        self._parts[record.id] = (key, part)
        return part

    def _held(self, loop: StepLoop, part: list[BrickRecord]) -> bool:
        """Whether something other than what ``part`` was placed on touched it as placed: a
        brick placed on it and on something else (it holds the part down), one beside it (one
        end of a flat arch, held by its partner), one on top of it that was not placed on it (its
        bottom face on a brick's top face, their footprints overlapping: a fixed bar over a
        counterweight, which the part cannot lift to tip), or one under it that is no face of its
        polygon (:meth:`_on_an_edge`), a fixed body included. Found once for each part each
        time a brick is placed or taken out: it looks at every brick for each of the part's, and
        a group may be a whole tower."""
        records, removed = loop.structure.records, {r.id for r in loop.structure.removed}
        key, names = (len(records), len(removed)), tuple(r.id for r in part)
        if (known := self._helds.get(names)) is not None and known[0] == key:
            return known[1]
        held = self._touched(loop, part, removed)
        self._helds[names] = (key, held)
        return held

    def _touched(self, loop: StepLoop, part: list[BrickRecord], removed: AbstractSet[str]) -> bool:
        """:meth:`_held`, found."""
        ids = {r.id for r in part}
        if any(j not in ids and j not in removed for r in part for j in self._carries.get(r.id, ())):
            return True
        if any(self._on_an_edge(loop, r, removed) for r in part):
            return True
        others = [r for r in loop.structure.records.values() if r.level is not None and r.id not in ids and r.id not in removed]
        shapes = [(r.footprint, r.corners) for r in others]
        for f in loop.program.fixtures:
            corners = Box(np.array(f.brick.half_extents), f.brick.mass).corners(_fixture_pose(f))
            shapes.append((footprint(corners), corners))
        if not shapes:
            return False
        lows = np.array([c[:, 2].min() for _, c in shapes])
        highs = np.array([c[:, 2].max() for _, c in shapes])
        for r in part:
            low, high = float(r.corners[:, 2].min()), float(r.corners[:, 2].max())
            beside = (np.minimum(highs, high) - np.maximum(lows, low)) > FACE_GAP  # at its height, not under or on it
            if beside.any():
                near = shapely.distance([shapes[k][0] for k in np.flatnonzero(beside)], r.footprint)
                if (near <= FACE_GAP).any():
                    return True
            above = np.abs(lows - high) <= FACE_GAP  # lying on its top face: the part must lift it to tip
            if above.any():
                overlaps = shapely.area(shapely.intersection([shapes[k][0] for k in np.flatnonzero(above)], r.footprint))
                if (overlaps > 1e-8).any():  # as :meth:`Structure.under` finds what a brick rests on
                    return True
        return False

    def _on_an_edge(self, loop: StepLoop, record: BrickRecord, removed: AbstractSet[str]) -> bool:
        """Whether ``record`` was placed touching something under it that is no piece of its
        support polygon: a brick it was placed on (its top within 1 mm) or a fixed body (its top
        within :data:`FACE_GAP` of the brick's bottom, their footprints overlapping) that meets
        its bottom face with no face of its own (the top corner of a leaning brick, a tilted
        fixed body's edge). What holds the brick up there is not in its polygon."""
        support = self._supports.get(record.id)
        if support is None:
            return False
        bodies = {b for b, _ in support.pieces}
        if any(r.body not in bodies and r.id not in removed and r.level is not None for r in record.below):
            return True
        bottom = float(record.corners[:, 2].min())
        for f in loop.program.fixtures:
            box, pose = Box(np.array(f.brick.half_extents), f.brick.mass), _fixture_pose(f)
            corners = box.corners(pose)
            if abs(float(corners[:, 2].max()) - bottom) > FACE_GAP:
                continue
            if shapely.area(shapely.intersection(footprint(corners), record.footprint)) <= 1e-8:
                continue
            area = face_overlap(record.box, record.pose, box, pose, FACE_GAP)
            if area is None or area.area <= 0.0:
                return True
        return False

    def _group(self, loop: StepLoop, record: BrickRecord) -> _Group | None:
        """What tips with ``record`` when it is one of several bricks that hold one another
        (two cantilevers side by side on a table with a counterweight across their back ends;
        or with a counterweight along each and a brick across those): the bricks connected to
        it by where they were placed, both ways (the bricks lying on one of them, the bricks
        one of them lies on), until none is left out. Its bottom bricks are those lying on what
        is not in it (the ground, a fixed body), each on that alone. None (no group) when its
        bottom bricks stand in more than one plane (friction at two heights can hold a group
        whose centre of mass is past the hull of its supports), a brick of it lies both on a
        brick of it and on what is not, or on a brick taken out, or tilted (what it lies on is
        unknown). Every brick connected so has the same group: it is found once for them all."""
        records, removed = loop.structure.records, {r.id for r in loop.structure.removed}
        key = (len(records), len(removed))  # a group changes only when a brick is placed or taken out
        if (known := self._groups.get(record.id)) is not None and known[0] == key:
            return known[1]
        members, group = self._grow(loop, record, removed)
        for i in members:
            self._groups[i] = (key, group)
        return group

    def _grow(self, loop: StepLoop, record: BrickRecord, removed: AbstractSet[str]) -> tuple[list[str], _Group | None]:
        """:meth:`_group`, found: the ids of the bricks connected to ``record``, and their group
        or None. What holds a group up pushes at its bottom bricks' supports alone, all in one
        plane, so its centre of mass outside the convex hull of those cannot balance, whatever
        its bricks do to one another."""
        records, structure = loop.structure.records, loop.structure
        members, todo = {record.id: record}, [record]
        bottoms: list[BrickRecord] = []
        whole = True  # no brick of it lies on what makes its weight another's
        while todo:
            r = todo.pop()
            support = self._supports.get(r.id)
            if support is None or not support.pieces or self._on_an_edge(loop, r, removed):
                whole = False  # tilted, or on a tilted brick's edge: what holds it up is unknown
            else:
                outside = inside = False
                for body, _ in support.pieces:
                    if body is None:
                        outside = True  # the ground or a fixed body
                        continue
                    under = structure.by_body(body)
                    if under is None or under.level is None or under.id in removed:
                        whole = False  # a brick taken out, or what is not the structure's
                        continue
                    inside = True
                    if under.id not in members:
                        members[under.id] = under
                        todo.append(under)
                if outside and inside:
                    whole = False  # on a brick of the group and on what is not: at two heights
                elif outside:
                    bottoms.append(r)
            for i in self._carries.get(r.id, ()):
                carried = records[i]
                if i not in members and i not in removed and carried.level is not None:
                    members[i] = carried
                    todo.append(carried)
        if not whole or not bottoms:
            return list(members), None
        lows = [float(r.corners[:, 2].min()) for r in bottoms]
        if max(lows) - min(lows) > FACE_GAP:
            return list(members), None  # its bottom bricks stand in two planes
        part = sorted(members.values(), key=lambda r: r.order)
        bottoms.sort(key=lambda r: r.order)
        return list(members), _Group(part, bottoms, self._placed_out(part, bottoms))

    def _off_support(self, loop: StepLoop, record: BrickRecord) -> tuple[ProofKind, str, tuple[str, ...]] | None:
        """The proof that ``record`` has collapsed because the centre of mass of what tips with
        it has left the support polygon it was placed on, or None: first of itself and the
        bricks it carries (:meth:`_part`), then of the group of the bricks connected to it by
        where they were placed (:meth:`_group`), against the polygons of the group's bottom
        bricks together. Placed with that centre of mass already outside, the part either tips
        at once or something else holds it: only how much further out it went counts, and
        nothing at all when something other than its supports touched it as placed
        (:meth:`_held`)."""
        support = self._supports.get(record.id)
        if support is None or not support.pieces:
            return None
        # pulled out and taken away: it supports nothing; a brick the hand still pulls is still
        # there, its piece carried along with it (a polygon larger than the overlap left: a
        # centre of mass outside it is outside that overlap too)
        in_hand = {g.record.body for s in loop.subscribers if isinstance(s, Actions) for g in s.guided}
        gone = {r.body for r in loop.structure.removed} - in_hand
        if gone and all(b in gone for b, _ in support.pieces):
            return None
        part = self._part(loop, record)
        proof = self._tips(loop, part, [record], gone)
        # the group is looked at only where the part's own proof may never come: the part, or the
        # group, placed with its centre of mass outside (a cantilever whose counterweight lies on
        # it and on the one beside it); elsewhere it costs every step of a falling tower's bricks
        if (
            proof is None
            and (group := self._group(loop, record)) is not None
            and len(group.bricks) > len(part)
            and (self._placed_out(part, [record]) > 0.0 or group.placed_out > 0.0)
        ):
            proof = self._tips(loop, group.bricks, group.bottoms, gone)
        if proof is None:
            return None
        return ("off its support", proof[0], tuple(r.id for r in proof[1] if r is not record))

    def _tips(
        self, loop: StepLoop, part: list[BrickRecord], bottoms: list[BrickRecord], gone: AbstractSet[int]
    ) -> tuple[str, list[BrickRecord]] | None:
        """The words of the proof that ``part`` (its bottom bricks ``bottoms`` first, then the
        bricks they carry) tips, its centre of mass off the polygons its ``bottoms`` were placed
        on (a convex hull of them all), and the bricks it names; None when it does not."""
        supports = [self._supports[r.id] for r in bottoms]
        if any(not s.pieces or (gone and all(b in gone for b, _ in s.pieces)) for s in supports):
            return None
        masses = np.array([r.box.mass for r in part])
        under = list(dict.fromkeys(b for s in supports for b, _ in s.pieces if b is not None))
        positions, quaternions = loop.world.poses_of([*(r.body for r in part), *under])
        poses = {b: Pose(p, q) for b, p, q in zip(under, positions[len(part) :], quaternions[len(part) :])}
        offset = np.asarray(loop.structure.offset)
        com = masses @ positions[: len(part)] / masses.sum() - offset
        index = {r.id: k for k, r in enumerate(part)}
        if len(bottoms) == 1:
            k = index[bottoms[0].id]
            if supports[0].on_the_ground_alone:  # the ground is everywhere: off the face it stood on, or not
                out = supports[0].beyond_its_base(Pose(positions[k] - offset, quaternions[k]), com)
            else:
                out = supports[0].outside(com, poses, loop.structure.offset, gone)
        else:
            regions = [
                s.region(Pose(positions[index[r.id]] - offset, quaternions[index[r.id]]), poses, loop.structure.offset, gone)
                for r, s in zip(bottoms, supports)
            ]
            hull = convex_hull(shapely.union_all([g for g in regions if g is not None]))
            out = max(0.0, -_signed_margin(hull, com))
        if out <= OFF_SUPPORT:
            return None
        placed = self._placed_out(part, bottoms)
        if placed > 0.0 and (out - placed <= FURTHER_OFF or self._held(loop, part)):
            return None
        names = _and([r.id for r in bottoms])
        carried = [r.id for r in part if r not in bottoms]
        ground = all(s.on_the_ground_alone for s in supports)
        one = len(bottoms) == 1
        if one and not carried:
            whose, it = f"{names}'s centre of mass", "it"
        else:
            whose = f"the centre of mass of {names}" + (f" with {_and(carried)} on {'it' if one else 'them'}" if carried else "")
            it = names
        if ground:
            where = (
                f"beyond the edge of the face {it} stood on the ground with"
                if one
                else f"beyond the edges of the faces {it} stood on the ground with"
            )
        else:
            where = f"outside the support polygon {it} {'was' if one else 'were'} placed on"
        as_placed = f" ({placed * 1000:.1f} mm as {'they were' if len(part) > 1 else 'it was'} placed)" if placed > 0.0 else ""
        return f"{whose} lies {out * 1000:.1f} mm {where}{as_placed}", part

    def _placed_out(self, part: list[BrickRecord], bottoms: list[BrickRecord]) -> float:
        """Metres the centre of mass of ``part`` lay outside the polygons its ``bottoms`` were
        placed on (a convex hull of them all) as they were placed; 0 inside."""
        key = (tuple(r.id for r in part), tuple(r.id for r in bottoms))
        if (known := self._placed.get(key)) is not None:
            return known
        supports = [self._supports[r.id] for r in bottoms]
        if len(part) == 1:
            placed = supports[0].placed_outside
        else:
            masses = np.array([r.box.mass for r in part])
            com = masses @ np.array([r.pose.position for r in part]) / masses.sum()
            if len(bottoms) == 1:
                placed = max(0.0, -supports[0].placed_margin_of(com))
            else:
                hulls = [h for s in supports if (h := s.placed_hull()) is not None]
                placed = max(0.0, -_signed_margin(convex_hull(shapely.union_all(hulls)) if hulls else None, com))
        self._placed[key] = placed
        return placed

    def _watch(self, loop: StepLoop) -> None:
        """Every rest duration, where the structure's moving bricks are (two such moments kept):
        at the end, a brick that moved farther since than its speeds at rest allow still moves."""
        if self._window and loop.now - self._window[-1][0] < self._rest[2] - 1e-9:
            return
        records = [r for r in loop.structure.placed if r.moving]
        positions, quaternions = loop.world.poses_of([r.body for r in records]) if records else (np.zeros((0, 3)),) * 2
        poses = {r.id: Pose(p, q) for r, p, q in zip(records, positions, quaternions)}
        self._window = (*self._window[-1:], (loop.now, poses))

    def _still_moving(self, loop: StepLoop) -> tuple[set[str], str]:
        """The structure bricks that still move at the end of a run that decided no collapse, and
        that in words with the hint to settle longer (none, ``""``): faster now than
        :data:`stability.JITTER` times the rest thresholds, or moved farther or turned more over
        the last rest duration or more than a brick under the thresholds could, the windowed rest
        test of fallen bricks (:mod:`stability._rest`); a brick that jitters in place (raw
        pybullet spins one at 0.4 rad/s, back and forth) does not."""
        records = [r for r in loop.structure.placed if r.moving]
        if not records:
            return set(), ""
        lin, ang = loop.world.velocities_of([r.body for r in records])
        speed, spin = np.sqrt((lin**2).sum(axis=1)), np.sqrt((ang**2).sum(axis=1))
        rest_speed, rest_spin, _ = self._rest
        then = next((w for w in self._window if loop.now - w[0] >= self._rest[2] - 1e-9), None)
        positions, quaternions = loop.world.poses_of([r.body for r in records])
        fast = []
        for i, r in enumerate(records):
            if speed[i] <= rest_speed and spin[i] <= rest_spin:
                continue
            before = then[1].get(r.id) if then is not None else None
            span = loop.now - then[0] if then is not None else 0.0
            if speed[i] > JITTER * rest_speed or spin[i] > JITTER * rest_spin or before is None:
                fast.append(i)
            elif not still(before, Pose(positions[i], quaternions[i]), rest_speed * span, rest_spin * span):
                fast.append(i)
        if not fast:
            return set(), ""
        worst = max(fast, key=lambda i: (speed[i] / self._rest[0], spin[i] / self._rest[1]))
        names = [records[i].id for i in fast]
        who = _and(names) if len(names) <= 3 else f"{', '.join(names[:3])} and {len(names) - 3} more"
        return {records[i].id for i in fast}, (
            f"{who} still {'moves' if len(names) == 1 else 'move'} at the end (up to {speed[worst] * 1000:.3g} mm/s, "
            f"{spin[worst]:.3g} rad/s; at rest is under {self._rest[0] * 1000:g} mm/s and {self._rest[1]:g} rad/s): "
            f"settle longer (timing.settle, {loop.program.settle:g} s now)"
        )

    def _resting(self, loop: StepLoop, records: list[BrickRecord]) -> list[bool]:
        """Whether each brick's speeds are under the rest thresholds now (a frozen one's are)."""
        moving = [r for r in records if r.moving]
        if not moving:
            return [True] * len(records)
        lin, ang = loop.world.velocities_of([r.body for r in moving])
        slow = iter(((lin**2).sum(axis=1) <= self._rest[0] ** 2) & ((ang**2).sum(axis=1) <= self._rest[1] ** 2))
        return [bool(next(slow)) if r.moving else True for r in records]

    def _collapsed(
        self, loop: StepLoop, record: BrickRecord, moved: float, proof: tuple[ProofKind, str, tuple[str, ...]]
    ) -> None:
        """``record`` stays moved: the collapse began when the first of the bricks displaced now
        was displaced; that brick is the one named. The bricks involved: those displaced now,
        and those of the proved mechanism."""
        first_id = min(self._displaced, key=lambda i: self._displaced[i].since)
        first, state = loop.structure.records[first_id], self._displaced[first_id]
        farthest = moved if first is record else state.farthest
        kind, detail, moved_too = proof
        if first is not record:  # the collapse is named after the brick that moved first
            detail += f" ({first.id} moved first; this proof decided the collapse)"
        detail += self._near_tie(loop, first)  # a tie the engine's contacts decided: said
        records = loop.structure.records
        bricks = tuple(sorted({*self._displaced, *(b for b in moved_too if b in records)}, key=lambda i: records[i].order))
        certificate = Certificate(verdict="collapse", kind=kind, detail=detail, bricks=bricks)
        self._record(loop, first, state.level, state.since, farthest, loop.now, certificate, state.graph)

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
    ) -> None:
        """Record the collapse of ``first`` (the brick named), proved by ``proof``."""
        assert first.level is not None
        self.record_drift(loop)
        self.collapse = Collapse(
            level=level, time=since, brick=first.id, brick_level=first.level, displacement=farthest, decided=decided
        )
        self.certificate = proof
        detail = f"moved {farthest * 1000:.1f} mm by t={decided:.2f} s; collapse level {level}; {proof.kind}"
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


def _fixture_pose(f: Fixture) -> Pose:
    return Pose.from_euler(f.position, f.yaw, f.pitch, f.roll)


def _signed_margin(hull: BaseGeometry | None, com: np.ndarray) -> float:
    """Metres the horizontal projection of ``com`` lies inside ``hull``'s edge (negative:
    outside it; inf with no hull)."""
    if hull is None:
        return math.inf
    x, y = float(com[0]), float(com[1])
    inside = contains_xy(hull, x, y)
    edge = hull.exterior if inside and hasattr(hull, "exterior") else hull
    return float(edge.distance(Point(x, y))) * (1.0 if inside else -1.0)


def _and(names: Sequence[str]) -> str:
    """``"B"``, ``"B and C"``, ``"B, C and D"``."""
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"


def _count(n: int, noun: str) -> str:
    """``"1 brick"``, ``"3 bricks"``."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _statics(near_ties: dict[str, str]) -> str:
    """Which bricks' landings statics decided, for a stand's words: ``"; statics on the placed
    geometry decided L05.1's landing (its centre of mass 0.56 mm inside its support's edge,
    within the engine's 1 mm contact margin), not the engine"``; nothing when none."""
    if not near_ties:
        return ""
    first, why = next(iter(near_ties.items()))
    said = why.split(": ", 1)[-1]
    more = f" and {len(near_ties) - 1} more near ties" if len(near_ties) > 1 else ""
    return f"; statics on the placed geometry decided {first}'s landing ({said}){more}, not the engine"


def _friction(share: float) -> str:
    """What a stand asks of friction (:attr:`stability.Certificate.friction`: the program's least
    share, or what the load paths' vertical forces need on supports out of level), for its
    certificate's words: ``", needing 73% of each friction coefficient"``; nothing when vertical
    forces on level faces hold it."""
    if share <= 0.0:
        return ""
    return f", needing {math.ceil(share * 100)}% of each friction coefficient"


def _named(bricks: Sequence[BrickRecord], moved: Sequence[float] | np.ndarray) -> tuple[BrickRecord, float]:
    """The brick a collapse with no equilibrium at the end names, of the structure's ``bricks`` in
    its mechanism (each ``moved`` so far, m), and how far it moved: the one that moved most (to the
    micrometre: where the part that does not stand has started to go), of equals the lowest level,
    then the first placed. None passed the threshold (else the collapse would have been decided
    before the end), so no brick is the first moved; a brick of the mechanism carried along, or
    woken with it, has moved less than the one that gives way. Source: stackdsl's own.

    >>> from types import SimpleNamespace as B
    >>> left, right = B(id="kl", level=2, order=2), B(id="kr", level=2, order=3)
    >>> [(b.id, d) for b, d in [_named([left, right], [0.0, 0.0011]), _named([left, right], [0.0, 0.0])]]
    [('kr', 0.0011), ('kl', 0.0)]
    """
    best = min(range(len(bricks)), key=lambda i: (-round(float(moved[i]), 6), bricks[i].level, bricks[i].order))
    return bricks[best], float(moved[best])

"""The proof "off its support": a displaced brick's centre of mass, with what tips with it, has
left the support polygon it was placed on (the module :mod:`stackdsl.runtime.collapse`'s second
proof).

A brick's support polygon is the overlap of its bottom face with each body under it as placed,
carried along with those bodies as they move (:class:`SupportPolygon`). What tips with a brick is
its *part*, the bricks placed on it and on nothing else, or, where a brick it carries lies on
others too, its *group*, the bricks connected to it by where they were placed, standing in one
plane, against the convex hull of their bottom bricks' polygons (:class:`OffSupport`). Placed
with that centre of mass already outside, only how much further out it went counts, and nothing
at all when something other than its supports touched it as placed.

Source: stackdsl's own (the support polygon of report 3.3.3, from the placed poses).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Set as AbstractSet
from dataclasses import dataclass

import numpy as np
import shapely
from shapely import contains_xy, convex_hull
from shapely.geometry import Point
from shapely.geometry.base import BaseGeometry

from stability import Box, Plane, Pose, face_overlap, hull_xy

from ..compile.program import Fixture
from .actions import Actions
from .bricks import BrickRecord, footprint
from .catch import caught
from .end_proofs import names_and
from .loop import StepLoop
from .outcome import ProofKind

#: Metres: the bottom face of a placed brick and the top face of what it rests on lie within this.
FACE_GAP = 0.001


#: Metres a displaced brick's centre of mass must lie outside the support polygon it was placed on
#: for that to prove a collapse: a brick pushed 35 mm along its supports came to rest with its
#: centre of mass 0.04 mm past the polygon's edge, which proved nothing. A brick that tips is past
#: this within a step or two.
OFF_SUPPORT = 0.0005


#: Metres from its support polygon's edge within which a part's placed centre of mass is an exact
#: tie: statics itself cannot tell where the engine's floats put it (a verdict on one says so). The
#: bricks under a part are where the engine has them when it is placed: MuJoCo's soft contacts
#: have moved a stack's edges by 10 to 20 um by then, pybullet's by a few.
EXACT_TIE = 1e-4


#: Metres further out than it was placed that a brick placed with its centre of mass outside its
#: support polygon must go for that to prove a collapse: an overhang placed 1.5 mm out is 0.27 mm
#: further when a corner has moved the threshold's 4 mm; one end of a flat arch, held by its
#: partner, sags without going further out.
FURTHER_OFF = 0.0001


@dataclass
class Group:
    """Bricks that tip as one (:meth:`OffSupport._group`): all of them in the order placed,
    their bottom bricks (on the ground or a fixed body, in one plane), and how far (m) their
    centre of mass lay outside the convex hull of those bricks' polygons as placed (0 inside)."""

    bricks: list[BrickRecord]
    bottoms: list[BrickRecord]
    placed_out: float


@dataclass(frozen=True)
class PlacedLoad:
    """A part (a brick and the bricks it carries, :meth:`OffSupport._part`) against the support
    polygon its bottom brick was placed on, as placed, just after a brick was placed on it.

    Attributes:
        brick: the part's bottom brick; placed: the brick just placed (the part's top);
        bricks: how many bricks the part holds; level: the highest level placed then;
        time: seconds, when it was placed; margin: metres its centre of mass lay inside the
        polygon's edge (negative: outside).
    """

    brick: str
    placed: str
    bricks: int
    level: int
    time: float
    margin: float

    def words(self) -> str:
        """``"b03 with the 2 bricks it carries placed 0.002 mm outside its support's edge when b05
        was placed"``."""
        carried = self.bricks - 1
        who = self.brick if not carried else f"{self.brick} with the {carried} brick{'s' if carried > 1 else ''} it carries"
        side = "inside" if self.margin >= 0 else "outside"
        when = "" if self.placed == self.brick else f" when {self.placed} was placed"
        return f"{who} placed {abs(self.margin) * 1000:.3f} mm {side} its support's edge{when}"


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
    _placed_hull: tuple[BaseGeometry | None] | None = None
    _sides: tuple[np.ndarray, np.ndarray] | None = None  # the placed hull's inward unit normals and offsets
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
        return max(0.0, -self.base_margin(pose, com))

    def base_margin(self, pose: Pose, com: np.ndarray | None = None) -> float:
        """Metres :meth:`beyond_its_base`'s centre of mass lies inside the face's edge (negative:
        beyond it)."""
        placed = self.box.corners(self.pose)
        face = np.argsort(placed[:, 2])[:4]  # the four lowest corners as placed: the face it stood on
        now = self.box.corners(pose)[face]
        return signed_margin(hull_xy(now[:, :2]), pose.position if com is None else com)

    @property
    def reaches(self) -> tuple[tuple[int | None, float], ...]:
        """(support body or None for a fixed one, metres from that body's centre to the farthest
        corner of its piece) for each piece: how far a turn of the body moves the piece's corners
        at most (2 r sin(angle / 2) for a turn by angle)."""
        return tuple((b, float(np.linalg.norm(c, axis=1).max())) for b, c in self.pieces)

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
        return signed_margin(self.placed_hull(), com)

    def placed_margin_above(self, com: np.ndarray, least: float) -> bool:
        """Whether :meth:`placed_margin_of` ``com`` is at least ``least`` metres, told cheaply:
        inside a convex polygon the distance to its edge is the least distance to the lines of
        its sides, and outside some side's line is crossed (a bound, exact where it answers)."""
        if self._sides is None:
            hull = self.placed_hull()
            if hull is None or not hasattr(hull, "exterior"):
                return self.placed_margin_of(com) >= least
            ring = np.asarray(hull.exterior.coords)[:, :2]
            ring = ring if hull.exterior.is_ccw else ring[::-1]
            edges = np.diff(ring, axis=0)
            inward = np.column_stack([-edges[:, 1], edges[:, 0]]) / np.linalg.norm(edges, axis=1)[:, None]
            self._sides = (inward, np.einsum("ij,ij->i", inward, ring[:-1]))
        inward, offsets = self._sides
        return bool((inward @ np.asarray(com[:2], dtype=float) - offsets).min() >= least)

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
        if self._placed_hull is None:
            self._placed_hull = (self._hull({b: pose for b, _, pose in self.below if b is not None and pose is not None}),)
        return self._placed_hull[0]

    def region(
        self,
        pose: Pose,
        poses: dict[int, Pose],
        offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
        gone: AbstractSet[int] = frozenset(),
    ) -> BaseGeometry | None:
        """What the brick stands on now, seen from above (shapely; None without a piece): on the
        ground alone, the face it stood on with the brick at ``pose`` (in the ground's frame), as
        :meth:`beyond_its_base` measures; else the polygon, as :meth:`margin_now` measures."""
        if self.on_the_ground_alone:
            placed = self.box.corners(self.pose)
            face = np.argsort(placed[:, 2])[:4]
            return hull_xy(self.box.corners(pose)[face][:, :2])
        return self._hull(poses, offset, gone)

    def margin_now(
        self,
        com: np.ndarray,
        poses: dict[int, Pose],
        offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
        gone: AbstractSet[int] = frozenset(),
    ) -> float:
        """Metres the horizontal projection of ``com`` (shape (3,), in the ground's frame) lies
        inside the polygon's edge (negative: outside it; inf with no pieces), the supports at
        ``poses`` (body -> pose now, in the world; the ground ``offset`` m from where it started,
        as a shake table moves it), leaving out the pieces on the bodies ``gone`` (pulled out of
        the scene)."""
        return signed_margin(self._hull(poses, offset, gone), com)


class OffSupport:
    """The support polygons of the placed bricks and the proof that one has left its own
    (:meth:`proof`; the module's description). What it finds of a part, a group or what held it
    as placed is kept until a brick is placed or taken out.

    Attributes:
        supports: brick id -> the support polygon it was placed on.
        carries: brick id -> the ids of the bricks placed on it.
        ties: the parts placed with their centre of mass within :data:`EXACT_TIE` of their
            polygon's edge, either way, as each brick was placed (:meth:`weigh`).
        placed_off: the first part placed with its centre of mass more than :data:`EXACT_TIE`
            outside its polygon and held by nothing else, and not caught since, or None: exact
            statics on the placed geometry says it falls there, whether or not the engine's
            contacts hold it (:attr:`offs`: each such part).
        caught: each part placed off its support that bricks placed on it caught in time
            (:func:`stackdsl.runtime.catch.caught`).
    """

    def __init__(self) -> None:
        self.supports: dict[str, SupportPolygon] = {}
        self.carries: dict[str, list[str]] = {}
        self._parts: dict[str, tuple[tuple[int, int], list[BrickRecord]]] = {}  # :meth:`_part`, and when
        self._placed: dict[tuple[tuple[str, ...], tuple[str, ...]], float] = {}  # :meth:`_placed_out`
        self._groups: dict[str, tuple[tuple[int, int], Group | None]] = {}  # :meth:`_group`, and when
        self._helds: dict[tuple[str, ...], tuple[tuple[int, int], bool]] = {}  # :meth:`_held`, and when
        #: metres the centre of mass of what tipped lay outside its support when :meth:`proof` last proved a collapse
        self.proved_out = 0.0
        self.ties: list[PlacedLoad] = []
        self.offs: list[PlacedLoad] = []  # in the order found
        self.caught: list[PlacedLoad] = []
        self._within: dict[str, tuple[str, ...]] = {}  # brick id -> the bottom bricks of the parts it is in, itself first
        self._loads: dict[str, tuple[int, float, np.ndarray]] = {}  # brick id -> its part's bricks, mass, mass moment
        self._pending: list[str] = []  # placed, not yet weighed
        # (part ids, bottom ids, gone) -> what _outside measured last: the bound of how far it can have moved since
        self._measured: dict[tuple[tuple[str, ...], tuple[str, ...], frozenset[int]], _Measured] = {}

    @property
    def placed_off(self) -> PlacedLoad | None:
        """The first of :attr:`offs`, or None."""
        return self.offs[0] if self.offs else None

    def place(self, loop: StepLoop, record: BrickRecord) -> None:
        """Note the support polygon ``record`` is placed on: the ground, the fixtures and the
        bricks under it (:attr:`BrickRecord.below`) where they are now."""
        others = record.below
        positions, quaternions = loop.world.poses_of([r.body for r in others]) if others else (np.zeros((0, 3)),) * 2
        below: list[tuple[int | None, Box | Plane, Pose | None]] = [(None, Plane(0.0), None)]
        below += [(None, Box(np.array(f.brick.half_extents), f.brick.mass), fixture_pose(f)) for f in loop.program.fixtures]
        below += [(r.body, r.box, Pose(p, q)) for r, p, q in zip(others, positions, quaternions)]
        self.supports[record.id] = SupportPolygon(record.box, record.pose, below)
        for r in others:
            self.carries.setdefault(r.id, []).append(record.id)
        if record.level is not None:
            self._load(record, {r.body: r.id for r in others})

    def _load(self, record: BrickRecord, ids: dict[int, str]) -> None:
        """Add ``record`` (placed on the bricks ``ids``, body -> id) to the load of every part it
        is in: its own, and those of the bricks every one of its supports is in the part of (the
        membership :meth:`_part` finds, kept as bricks are placed). Weighed after the step
        (:meth:`weigh`), when every brick placed at the same moment is in."""
        under = [b for b, _ in self.supports[record.id].pieces]
        within: set[str] = set()
        if under and all(b is not None and b in ids for b in under):
            within = set.intersection(*(set(self._within.get(ids[b], ())) for b in under if b is not None))
        self._within[record.id] = (record.id, *sorted(within))
        mass = record.box.mass
        moment = mass * np.asarray(record.pose.position, dtype=float)
        for bottom in self._within[record.id]:
            count, m, first = self._loads.get(bottom, (0, 0.0, np.zeros(3)))
            self._loads[bottom] = (count + 1, m + mass, first + moment)
        self._pending.append(record.id)

    def weigh(self, loop: StepLoop) -> None:
        """Each part a brick placed since the last call is in, against its polygon as placed
        (:class:`PlacedLoad`): its exact ties are kept (:attr:`ties`), and the first part placed
        outside that nothing else holds (:attr:`placed_off`). A brick taken out since stops it:
        the loads are of placed bricks only."""
        if not self._pending:
            return
        pending, self._pending = self._pending, []
        if loop.structure.removed:
            return
        records = loop.structure.records
        if self.offs:
            self._catch(loop, pending)
        level = max(loop.structure.levels.values(), default=0)
        top: dict[str, str] = {}
        for brick in pending:
            for bottom in self._within[brick]:
                top[bottom] = brick  # the last placed of the part's new bricks names the moment
        for bottom, placed in sorted(top.items(), key=lambda t: records[t[0]].order):
            support = self.supports[bottom]
            if not support.pieces:
                continue
            count, mass, moment = self._loads[bottom]
            if support.placed_margin_above(moment / mass, EXACT_TIE):
                continue  # neither a tie nor outside: the usual part
            margin = support.placed_margin_of(moment / mass)
            load = PlacedLoad(bottom, placed, count, level, loop.now, margin)
            if abs(margin) < EXACT_TIE:
                self.ties.append(load)
            if (
                margin <= -EXACT_TIE
                and all(off.brick != bottom for off in self.offs)
                and all(c.brick != bottom for c in self.caught)  # its load misses what caught it
                and not self._held(loop, self._part(loop, records[bottom]))
            ):
                self.offs.append(load)

    def _catch(self, loop: StepLoop, pending: list[str]) -> None:
        """Each part placed off its support (:attr:`offs`) that the bricks ``pending`` (ids, just
        placed) were placed on, bringing its centre of mass inside: caught when they came in
        time (:func:`stackdsl.runtime.catch.caught`), and then no longer off. A brick placed on
        the part as the bricks under it were placed (:attr:`BrickRecord.below`) counts though
        the part has turned under it since: a cantilever tipping 1.5 deg when its counterweight
        landed on it, which no face of it met flat."""
        records = loop.structure.records
        for off in list(self.offs):
            part = self._part(loop, records[off.brick])
            ids = {r.id for r in part}
            on = [records[b] for b in pending if b in ids or (records[b].below and all(u.id in ids for u in records[b].below))]
            if not on:
                continue
            after = [*part, *(r for r in on if r.id not in ids)]  # the part as flagged first, in the order placed
            masses = np.array([r.box.mass for r in after])
            com = masses @ np.array([r.pose.position for r in after]) / masses.sum()
            support = self.supports[off.brick]
            hull = support.placed_hull()
            if hull is None or support.placed_margin_of(com) < EXACT_TIE:
                continue
            bricks = [(r.box, r.pose) for r in after]
            height = float(records[off.brick].corners[:, 2].min())
            program, late = loop.program, loop.now - off.time
            if caught(bricks[: off.bricks], bricks, hull, height, late, program.collapse_threshold, program.engine.gravity):
                self.offs.remove(off)
                self.caught.append(off)

    def proof(self, loop: StepLoop, record: BrickRecord) -> tuple[ProofKind, str, tuple[str, ...]] | None:
        """The proof that ``record`` has collapsed because the centre of mass of what tips with
        it has left the support polygon it was placed on, or None: first of itself and the
        bricks it carries (:meth:`_part`), then of the group of the bricks connected to it by
        where they were placed (:meth:`_group`), against the polygons of the group's bottom
        bricks together. Placed with that centre of mass already outside, the part either tips
        at once or something else holds it: only how much further out it went counts, and
        nothing at all when something other than its supports touched it as placed
        (:meth:`_held`)."""
        support = self.supports.get(record.id)
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
        supports = [self.supports[r.id] for r in bottoms]
        if any(not s.pieces or (gone and all(b in gone for b, _ in s.pieces)) for s in supports):
            return None
        out = self._outside(loop, part, bottoms, gone)
        if out <= OFF_SUPPORT:
            return None
        placed = self._placed_out(part, bottoms)
        if placed > 0.0 and (out - placed <= FURTHER_OFF or self._held(loop, part)):
            return None
        self.proved_out = out
        return _tips_words(part, bottoms, supports, out, placed), part

    def least_placed_margin(self, loop: StepLoop, records: list[BrickRecord]) -> float:
        """Metres the centre of mass of each of ``records`` with the bricks it carries (its part,
        :meth:`_part`) lay inside the support polygon it was placed on, as placed, the least of
        them (negative: outside; inf when none has a polygon, or every one outside is held by
        something else, :meth:`_held`). A part placed outside is past statics' limit by that
        much: what a collapse's signed margin reports (:attr:`stackdsl.Outcome.margin`)."""
        least = math.inf
        for record in records:
            support = self.supports.get(record.id)
            if support is None or not support.pieces:
                continue
            part = self._part(loop, record)
            masses = np.array([r.box.mass for r in part])
            com = masses @ np.array([r.pose.position for r in part]) / masses.sum()
            margin = support.placed_margin_of(com)
            if margin < 0.0 and self._held(loop, part):
                continue
            least = min(least, margin)
        return least

    def _outside(self, loop: StepLoop, part: list[BrickRecord], bottoms: list[BrickRecord], gone: AbstractSet[int]) -> float:
        """Metres the centre of mass of ``part`` lies outside what its ``bottoms`` stand on now
        (0 inside): one bottom brick's polygon (on the ground alone, the face it stood on: the
        ground is everywhere), or the convex hull of several's, the pieces on the bodies ``gone``
        left out (:meth:`_margin`). Asked each step of a displaced brick that moves, it is measured
        again only once the bricks can have moved it to within :data:`OFF_SUPPORT` of its edge
        since it was last measured (:meth:`_Measured.moved`); until then an upper bound, at most
        :data:`OFF_SUPPORT`, is returned: a single file pushed along at its base asked it 84 times
        and measured it 6 (a third of the collapse monitor's time before)."""
        supports = [self.supports[r.id] for r in bottoms]
        under = list(dict.fromkeys(b for s in supports for b, _ in s.pieces if b is not None))
        bodies = (*(r.body for r in part), *under)
        positions, quaternions = loop.world.poses_of(list(bodies))
        index = {r.id: k for k, r in enumerate(part)}
        key = (tuple(r.id for r in part), tuple(r.id for r in bottoms), frozenset(gone))
        kept = self._measured.get(key)
        if kept is not None and kept.bodies == bodies and kept.offset == loop.structure.offset:
            moved = kept.moved(positions, quaternions, len(part), index[bottoms[0].id], self._corners(bottoms, supports, bodies))
            if kept.margin - moved >= -OFF_SUPPORT:  # no closer to the edge than it can have come since: not out
                return max(0.0, moved - kept.margin)
        margin = self._margin(loop, part, bottoms, supports, positions, quaternions, index, gone)
        self._measured[key] = _Measured(bodies, positions.copy(), quaternions.copy(), loop.structure.offset, margin)
        return max(0.0, -margin)

    def _margin(
        self,
        loop: StepLoop,
        part: list[BrickRecord],
        bottoms: list[BrickRecord],
        supports: list[SupportPolygon],
        positions: np.ndarray,
        quaternions: np.ndarray,
        index: dict[str, int],
        gone: AbstractSet[int],
    ) -> float:
        """Metres the centre of mass of ``part`` lies inside what its ``bottoms`` stand on now
        (:meth:`_outside`; negative: outside), the part's bodies and then those under them at
        ``positions`` and ``quaternions``."""
        under = list(dict.fromkeys(b for s in supports for b, _ in s.pieces if b is not None))
        poses = {b: Pose(p, q) for b, p, q in zip(under, positions[len(part) :], quaternions[len(part) :])}
        masses = np.array([r.box.mass for r in part])
        offset = np.asarray(loop.structure.offset)
        com = masses @ positions[: len(part)] / masses.sum() - offset
        if len(bottoms) == 1:
            k = index[bottoms[0].id]
            if supports[0].on_the_ground_alone:  # the ground is everywhere: off the face it stood on, or not
                return supports[0].base_margin(Pose(positions[k] - offset, quaternions[k]), com)
            return supports[0].margin_now(com, poses, loop.structure.offset, gone)
        regions = [
            s.region(Pose(positions[index[r.id]] - offset, quaternions[index[r.id]]), poses, loop.structure.offset, gone)
            for r, s in zip(bottoms, supports)
        ]
        return signed_margin(convex_hull(shapely.union_all([g for g in regions if g is not None])), com)

    @staticmethod
    def _corners(
        bottoms: list[BrickRecord], supports: list[SupportPolygon], bodies: tuple[int, ...]
    ) -> list[tuple[int | None, float]]:
        """What carries the corners of the polygons :meth:`_margin` measures: (the row of
        ``bodies`` that carries them, or None for a fixed one; metres from that body's centre to
        the farthest of them)."""
        row = {b: k for k, b in enumerate(bodies)}
        carried: list[tuple[int | None, float]] = []
        for r, s in zip(bottoms, supports):
            if s.on_the_ground_alone:  # the face it stood on: its own corners
                carried.append((row[r.body], r.half_diagonal))
            else:
                carried += [(None if b is None else row[b], reach) for b, reach in s.reaches]
        return carried

    def _placed_out(self, part: list[BrickRecord], bottoms: list[BrickRecord]) -> float:
        """Metres the centre of mass of ``part`` lay outside the polygons its ``bottoms`` were
        placed on (a convex hull of them all) as they were placed; 0 inside."""
        key = (tuple(r.id for r in part), tuple(r.id for r in bottoms))
        if (known := self._placed.get(key)) is not None:
            return known
        supports = [self.supports[r.id] for r in bottoms]
        if len(part) == 1:
            placed = supports[0].placed_outside
        else:
            masses = np.array([r.box.mass for r in part])
            com = masses @ np.array([r.pose.position for r in part]) / masses.sum()
            if len(bottoms) == 1:
                placed = max(0.0, -supports[0].placed_margin_of(com))
            else:
                hulls = [h for s in supports if (h := s.placed_hull()) is not None]
                placed = max(0.0, -signed_margin(convex_hull(shapely.union_all(hulls)) if hulls else None, com))
        self._placed[key] = placed
        return placed

    def _part(self, loop: StepLoop, record: BrickRecord) -> list[BrickRecord]:
        """``record`` and the bricks it carries: those placed on it, or on it and on bricks it
        carries, and on nothing else (a counterweight on a cantilever's back end, the bricks of
        a harmonic stack above it), in the order they were placed. They tip with it."""
        records, removed = loop.structure.records, {r.id for r in loop.structure.removed}
        key = (len(records), len(removed))  # a part changes only when a brick is placed or taken out
        if (known := self._parts.get(record.id)) is not None and known[0] == key:
            return known[1]
        part, bodies = [record], {record.body}
        heap = [(records[i].order, i) for i in self.carries.get(record.id, ())]
        heapq.heapify(heap)
        seen = {i for _, i in heap}
        while heap:  # in the order placed: what a candidate rests on is decided before it
            _, i = heapq.heappop(heap)
            r = records[i]
            support = self.supports.get(i)
            if r.level is None or i in removed or support is None or not support.pieces:
                continue
            if not all(b is not None and b in bodies for b, _ in support.pieces):
                continue
            part.append(r)
            bodies.add(r.body)
            for j in self.carries.get(i, ()):
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
        if any(j not in ids and j not in removed for r in part for j in self.carries.get(r.id, ())):
            return True
        if any(self._on_an_edge(loop, r, removed) for r in part):
            return True
        others = [r for r in loop.structure.records.values() if r.level is not None and r.id not in ids and r.id not in removed]
        shapes = [(r.footprint, r.corners) for r in others]
        for f in loop.program.fixtures:
            corners = Box(np.array(f.brick.half_extents), f.brick.mass).corners(fixture_pose(f))
            shapes.append((footprint(corners), corners))
        if not shapes:
            return False
        return _beside_or_on(part, shapes)

    def _on_an_edge(self, loop: StepLoop, record: BrickRecord, removed: AbstractSet[str]) -> bool:
        """Whether ``record`` was placed touching something under it that is no piece of its
        support polygon: a brick it was placed on (its top within 1 mm) or a fixed body (its top
        within :data:`FACE_GAP` of the brick's bottom, their footprints overlapping) that meets
        its bottom face with no face of its own (the top corner of a leaning brick, a tilted
        fixed body's edge). What holds the brick up there is not in its polygon."""
        support = self.supports.get(record.id)
        if support is None:
            return False
        bodies = {b for b, _ in support.pieces}
        if any(r.body not in bodies and r.id not in removed and r.level is not None for r in record.below):
            return True
        bottom = float(record.corners[:, 2].min())
        for f in loop.program.fixtures:
            box, pose = Box(np.array(f.brick.half_extents), f.brick.mass), fixture_pose(f)
            corners = box.corners(pose)
            if abs(float(corners[:, 2].max()) - bottom) > FACE_GAP:
                continue
            if shapely.area(shapely.intersection(footprint(corners), record.footprint)) <= 1e-8:
                continue
            area = face_overlap(record.box, record.pose, box, pose, FACE_GAP)
            if area is None or area.area <= 0.0:
                return True
        return False

    def _group(self, loop: StepLoop, record: BrickRecord) -> Group | None:
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

    def _grow(self, loop: StepLoop, record: BrickRecord, removed: AbstractSet[str]) -> tuple[list[str], Group | None]:
        """:meth:`_group`, found: the ids of the bricks connected to ``record``, and their group
        or None. What holds a group up pushes at its bottom bricks' supports alone, all in one
        plane, so its centre of mass outside the convex hull of those cannot balance, whatever
        its bricks do to one another."""
        records = loop.structure.records
        members, todo = {record.id: record}, [record]
        bottoms: list[BrickRecord] = []
        whole = True  # no brick of it lies on what makes its weight another's
        while todo:
            r = todo.pop()
            support = self.supports.get(r.id)
            if support is None or not support.pieces or self._on_an_edge(loop, r, removed):
                whole = False  # tilted, or on a tilted brick's edge: what holds it up is unknown
            else:
                outside, under, lost = _under(loop, support, removed)
                whole = whole and not lost
                for brick in under:
                    if brick.id not in members:
                        members[brick.id] = brick
                        todo.append(brick)
                if outside and under:
                    whole = False  # on a brick of the group and on what is not: at two heights
                elif outside:
                    bottoms.append(r)
            for i in self.carries.get(r.id, ()):
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
        return list(members), Group(part, bottoms, self._placed_out(part, bottoms))


def fixture_pose(f: Fixture) -> Pose:
    return Pose.from_euler(f.position, f.yaw, f.pitch, f.roll)


@dataclass(frozen=True)
class _Measured:
    """What :meth:`OffSupport._outside` measured of a part last: its bodies (the part's, then
    those under it), their positions (shape (n, 3), m) and quaternions (shape (n, 4)) then, the
    ground's offset, and the margin of its centre of mass inside its polygon (m; negative:
    outside)."""

    bodies: tuple[int, ...]
    positions: np.ndarray
    quaternions: np.ndarray
    offset: tuple[float, float, float]
    margin: float

    def moved(
        self, positions: np.ndarray, quaternions: np.ndarray, bricks: int, reference: int, corners: list[tuple[int | None, float]]
    ) -> float:
        """Metres the margin can have changed since, the bodies now at ``positions`` and
        ``quaternions``: the part's centre of mass (a mean of its first ``bricks`` bodies'
        centres) moved at most as far as the farthest of those centres, and the polygon's
        corners each as far as their body's centre and turn move them (2 r sin(angle / 2) for
        ``corners``' r; a fixed one not at all), all against the body in row ``reference``: the
        margin is a distance between the two, which moving both alike leaves alone, and a point's
        margin in a convex polygon changes by no more than its corners move. Source: stackdsl's own."""
        shift = positions - self.positions
        relative = np.sqrt(((shift - shift[reference]) ** 2).sum(axis=1))
        half_turn = np.sqrt(1.0 - np.minimum(1.0, np.abs((quaternions * self.quaternions).sum(axis=1))) ** 2)
        still = float(np.sqrt((shift[reference] ** 2).sum()))
        corner = max(
            (still if row is None else float(relative[row]) + 2.0 * reach * float(half_turn[row]) for row, reach in corners),
            default=0.0,
        )
        return float(relative[:bricks].max()) + corner


def signed_margin(hull: BaseGeometry | None, com: np.ndarray) -> float:
    """Metres the horizontal projection of ``com`` lies inside ``hull``'s edge (negative:
    outside it; inf with no hull)."""
    if hull is None:
        return math.inf
    x, y = float(com[0]), float(com[1])
    inside = contains_xy(hull, x, y)
    edge = hull.exterior if inside and hasattr(hull, "exterior") else hull
    return float(edge.distance(Point(x, y))) * (1.0 if inside else -1.0)


def _tips_words(
    part: list[BrickRecord], bottoms: list[BrickRecord], supports: list[SupportPolygon], out: float, placed: float
) -> str:
    """The proof that ``part`` tips, in words: whose centre of mass (its ``bottoms``', with what
    they carry) lies ``out`` metres beyond the face it stood on the ground with, or outside the
    polygon it was placed on (``supports``: of the bottoms), and ``placed`` metres out as placed
    when it was (0: inside)."""
    names = names_and([r.id for r in bottoms])
    carried = [r.id for r in part if r not in bottoms]
    ground = all(s.on_the_ground_alone for s in supports)
    one = len(bottoms) == 1
    if one and not carried:
        whose, it = f"{names}'s centre of mass", "it"
    else:
        whose = f"the centre of mass of {names}" + (f" with {names_and(carried)} on {'it' if one else 'them'}" if carried else "")
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
    return f"{whose} lies {out * 1000:.1f} mm {where}{as_placed}"


def _beside_or_on(part: list[BrickRecord], shapes: list[tuple[BaseGeometry, np.ndarray]]) -> bool:
    """Whether a body of ``shapes`` (footprint, corners shape (8, 3), m) touches a brick of
    ``part`` beside it, at its height (within :data:`FACE_GAP`), or lies on its top face, their
    footprints overlapping (the part must lift it to tip)."""
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


def _under(loop: StepLoop, support: SupportPolygon, removed: AbstractSet[str]) -> tuple[bool, list[BrickRecord], bool]:
    """What the pieces of ``support`` lie on: whether one is the ground or a fixed body, the
    structure's bricks under the others, and whether one lies on a brick taken out (of the ids
    ``removed``) or on what is not the structure's."""
    outside, lost = False, False
    under: list[BrickRecord] = []
    for body, _ in support.pieces:
        if body is None:
            outside = True  # the ground or a fixed body
            continue
        brick = loop.structure.by_body(body)
        if brick is None or brick.level is None or brick.id in removed:
            lost = True  # a brick taken out, or what is not the structure's
            continue
        under.append(brick)
    return outside, under, lost

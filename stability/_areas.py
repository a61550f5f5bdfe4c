"""Contact areas (report 3.3.3, 3.4.2): what a brick rests on and how it touches its neighbours.

From the engine's contact points of a brick, grouped by the body they touch: the exact face
overlap where the brick lies face to face on a body, else the points padded into an area
(3.3.3); the main contact area is the hull of a brick's areas. For a leaning brick each
contact becomes a polygon in its contact plane, with the pair's friction coefficient (3.4.2).
Source: report 3.3.3 and 3.4.2.
"""

from __future__ import annotations

import itertools
import math
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from collections.abc import Set as AbstractSet
from dataclasses import dataclass

import numpy as np

from ._engine import ContactPoint
from ._equilibrium import ContactPolygon
from ._geometry import (
    Box,
    ContactArea,
    Faces,
    Plane,
    Pose,
    _mean,
    combined_hull,
    contains,
    face_overlap,
    padded_hull,
    touching_feature,
)
from ._graph import BrickState
from ._leaning import lean_polygon_padded, pair_friction
from ._stack import Record, Stack

Contacts = dict[int, list[ContactPoint]]
"""Contact points by the body they are seen from."""

FACES = 64
"""Face overlaps kept (:meth:`ContactAreas._face`), and boxes' faces (:meth:`ContactAreas._made`);
all of either are forgotten when there are this many."""

HELD_KEPT = 4096
"""Answers of :meth:`ContactAreas.holds` kept (one per area); all are forgotten when there are this many."""


@dataclass(frozen=True)
class Boxes:
    """The bodies :meth:`ContactAreas.lying_on` looks among: ``rank`` (body -> registration
    index), the ``planes``, and the boxed ``records`` with their ``table`` of bounding boxes,
    shape (n, 6): top z, x min, x max, y min, y max (m) and the least half extent (m)."""

    rank: dict[int, int]
    planes: list[Record]
    records: list[Record]
    table: np.ndarray


class ContactAreas:
    """The contact areas and polygons of the bricks of ``stack``, from their contact points.

    Args:
        stack: the registered bodies (their shapes, states and poses).

    Source: report 3.3.3 and 3.4.2; the support angle and the face gap are stackdsl's own.
    """

    def __init__(self, stack: Stack) -> None:
        self.stack = stack
        self._faces: dict[tuple[float, ...], ContactArea | None] = {}  # the last face overlaps, by their bodies and poses
        self._found: Faces = {}  # the boxes' faces face_overlap found, by half extents and pose
        self._still: tuple[tuple[int, int], Boxes] | None = None  # the frozen and environment boxes, of a stack version
        # of the registered bodies (by :attr:`Stack.registrations`): rank, planes, boxed records
        self._registered: tuple[int, dict[int, int], list[Record], list[Record]] | None = None
        # each frozen brick's row of the boxes' table, by the pose it froze at (the same object while frozen)
        self._rows: dict[int, tuple[Pose, tuple[float, float, float, float, float, float] | None]] = {}
        self._held: dict[
            int, tuple[ContactArea, float, float, bool]
        ] = {}  # id of an area -> it, the last point asked, the answer
        self.config = stack.config
        self.support_cos = math.cos(math.radians(self.config.support_angle))

    def supports(
        self, rec: Record, contacts: Iterable[ContactPoint], stack_only: bool, pose: Pose | None = None
    ) -> dict[int, ContactArea]:
        """Contact areas of the bodies ``rec`` rests on (a contact normal within the support
        angle of straight up), keyed by body, in registration order; active bricks only when
        not ``stack_only`` and lower than ``rec``. ``pose``: ``rec``'s, the engine's when None."""
        grouped: dict[int, list[ContactPoint]] = defaultdict(list)
        bodies, engine = self.stack.bodies, self.stack.engine
        pose = pose if pose is not None else engine.pose(rec.body)
        my_z = pose.position[2]
        for c in contacts:
            other = bodies.get(c.other)
            if other is None or c.normal[2] < self.support_cos or rec.body in other.rests_on:
                continue  # a brick frozen resting on ``rec`` (on a settled pile's edge) is a load
            if c.distance > self.config.contact_pad:
                continue  # an engine's point across a gap (pybullet's reach 20 mm): a rocking brick's lifted side
            if other.state is BrickState.ACTIVE and (stack_only or engine.pose(other.body).position[2] >= my_z):
                continue
            grouped[c.other].append(c)
        return {o: self._contact_area(rec, pose, bodies[o], grouped[o]) for o in self.stack.ordered(grouped)}

    def carrying(self, rec: Record, contacts: Iterable[ContactPoint]) -> dict[int, ContactArea]:
        """What carries ``rec``, an active brick at rest, where it is: the frozen bricks and
        environment bodies it lies on face to face (:meth:`lying_on`) and, when none of its
        contacts is within the support angle, every frozen or environment body whose contact
        pushes it up, as the debris rule would freeze it (:meth:`Admission.plan
        <stability._admission.Admission.plan>`): a brick on a face steeper than 45 deg, whose
        bottom face is then a side, or on an edge. Source: stackdsl's own."""
        pose = self.stack.engine.pose(rec.body)
        found = self.lying_on(rec, pose)
        grouped: dict[int, list[ContactPoint]] = defaultdict(list)
        for c in contacts:
            other = self.stack.bodies.get(c.other)
            if other is None or c.distance > self.config.contact_pad:
                continue
            if c.normal[2] >= self.support_cos:
                return found  # it rests within the angle: what it lies on is found from the faces
            if other.state is not BrickState.ACTIVE and rec.body not in other.rests_on and c.other not in found:
                grouped[c.other].append(c)
        pushing = {o: pts for o, pts in grouped.items() if float(np.mean([c.normal[2] for c in pts])) > 0.0}
        found.update((o, self._contact_area(rec, pose, self.stack.bodies[o], pts)) for o, pts in pushing.items())
        return {o: found[o] for o in self.stack.ordered(found)}

    def face_to_face(self, rec: Record, other: Record) -> ContactArea | None:
        """The exact area through which ``rec`` lies face to face on ``other``, or None
        (:func:`stability._geometry.face_overlap`)."""
        return self._face(rec, self.stack.engine.pose(rec.body), other)

    def _face(self, rec: Record, pose: Pose, other: Record) -> ContactArea | None:
        """:func:`stability._geometry.face_overlap` of ``rec`` at ``pose`` on ``other`` where it
        is, found once for the same bodies at the same poses: an admission asks it for its
        contact polygons and again for how far to raise the brick."""
        other_pose = None if isinstance(other.shape, Plane) else self.stack.pose(other)
        key = (rec.body, other.body, *pose.position.tolist(), *pose.orientation.tolist())
        if other_pose is not None:
            key += (*other_pose.position.tolist(), *other_pose.orientation.tolist())
        if key in self._faces:
            return self._faces[key]
        if len(self._faces) >= FACES:
            self._faces.clear()
        area = self._faces[key] = face_overlap(rec.box, pose, other.shape, other_pose, self.config.face_gap, self._made())
        return area

    def _made(self) -> Faces:
        """The boxes' faces found so far (:func:`stability._geometry.face_overlap`); all are
        forgotten when there are :data:`FACES`."""
        if len(self._found) >= FACES:
            self._found.clear()
        return self._found

    def _contact_area(self, rec: Record, pose: Pose, other: Record, points: list[ContactPoint]) -> ContactArea:
        exact = self._face(rec, pose, other)
        if exact is not None:
            return exact
        xyz = np.array([c.position for c in points])
        polygon = padded_hull(xyz[:, :2], self.config.contact_pad)
        return ContactArea(polygon, float(xyz[:, 2].mean()), mean_normal(points), exact=False)

    def polygons(
        self,
        rec: Record,
        touching: dict[int, list[ContactPoint]],
        skip: AbstractSet[int] = frozenset(),
        known: dict[int, ContactArea] | None = None,
        pose: Pose | None = None,
    ) -> list[ContactPolygon[int]]:
        """One contact polygon per touched body (report 3.4.2): the exact face overlap where
        ``rec`` lies face to face on it, else the contact points padded across the normal.
        ``known``: contact areas already found for some of these bodies (from :meth:`supports`).
        ``pose``: ``rec``'s, the engine's when None. The certificate takes these with the
        shapes' corner, edge or face instead of the padding (:meth:`shaped`)."""
        out = []
        pose = pose if pose is not None else self.stack.engine.pose(rec.body)
        known = known or {}
        for other, points in touching.items():
            if other in skip:
                continue
            o = self.stack.bodies[other]
            friction = pair_friction(rec.friction, o.friction)
            if other in known:
                exact = known[other] if known[other].exact else None
            else:
                exact = self._face(rec, pose, o)
            if exact is not None:
                out.append(ContactPolygon(rec.body, other, exact.corners(), exact.normal, friction))
                continue
            normal = mean_normal(points)
            own = np.array([c.position for c in points])
            polygon, padded = lean_polygon_padded(own, normal, self.config.contact_pad)
            out.append(ContactPolygon(rec.body, other, polygon, normal, friction, own if padded else None))
        return out

    def shaped(self, contacts: Sequence[ContactPolygon[int]]) -> list[ContactPolygon[int]]:
        """``contacts`` with each padded one (one or two engine points, or points in a line, padded
        across the normal: ``core`` set) replaced by where the two bodies' shapes meet at their
        poses now (:func:`stability._geometry.touching_feature`, within the face gap), with its
        points: a face where it has area, else the bare edge or corner. An engine may show an
        edge's contact as one point; and padding lets a contact carry a moment a real edge cannot
        (an inverted V at 28 deg, tan 0.53 against friction 0.5, stood on its feet's 2 mm strips).
        Where the shapes show no contact (or exact areas are off: a face gap <= 0), the padded
        one is kept. Source: stackdsl's own."""
        gap, out = self.config.face_gap, []
        for c in contacts:
            if c.core is None or gap <= 0.0:
                out.append(c)
                continue
            rec, other = self.stack.bodies[c.body], self.stack.bodies[c.other]
            normal = np.asarray(c.normal, dtype=float)
            other_pose = None if isinstance(other.shape, Plane) else self.stack.pose(other)
            found = touching_feature(rec.box, self.stack.pose(rec), other.shape, other_pose, normal, gap)
            if found is None:
                out.append(c)
                continue
            both = np.vstack([np.asarray(c.core, dtype=float), found])
            polygon, padded = lean_polygon_padded(both, normal, self.config.contact_pad)
            out.append(ContactPolygon(c.body, c.other, both if padded else polygon, normal, c.friction))
        return out

    def boxes(self, active: bool = False) -> Boxes:
        """The bounding boxes :meth:`lying_on` looks among: of the frozen bricks and environment
        boxes (kept until the stack or its registered bodies change) and, with ``active``, of
        the active bricks where they are now (found anew: pass them to each :meth:`lying_on` of
        the same moment, as the brick graph and the certificate do for every active brick)."""
        stack = self.stack
        key = (stack.version, stack.registrations)
        if self._still is None or self._still[0] != key:
            if self._registered is None or self._registered[0] != stack.registrations:
                rank = {body: i for i, body in enumerate(stack.bodies)}
                planes = [r for r in stack.bodies.values() if isinstance(r.shape, Plane)]
                boxed = [r for r in stack.bodies.values() if not isinstance(r.shape, Plane)]
                self._registered = (stack.registrations, rank, planes, boxed)
            _, rank, planes, boxed = self._registered
            still = [r for r in boxed if r.state is not BrickState.ACTIVE]
            rows, kept = self._rows, []
            for r in still:  # a frozen brick's row as it froze (:meth:`_extent`), without a call for each
                row, pose = rows.get(r.body), r.frozen_pose
                kept.append(row[1] if row is not None and row[0] is pose and row[1] is not None else self._extent(r))
            flat = np.fromiter(itertools.chain.from_iterable(kept), float, 6 * len(kept))
            self._still = (key, Boxes(rank, planes, still, flat.reshape(-1, 6)))
        boxes = self._still[1]
        if not active or not stack.active:
            return boxes
        moving = [r for r in stack.active.values() if not isinstance(r.shape, Plane)]
        table = np.array([self._extent(r) for r in moving]).reshape(-1, 6)
        return Boxes(boxes.rank, boxes.planes, boxes.records + moving, np.vstack([boxes.table, table]))

    def _extent(self, other: Record) -> tuple[float, float, float, float, float, float]:
        """Top z, x min, x max, y min, y max of ``other``'s box where it is (m; remembered for a
        frozen brick and, found once, for an environment box), and how far its top face reaches
        below that top (:func:`face_span`)."""
        extent, box = other.extent, other.box
        pose = self.stack.pose(other)
        if other.frozen_pose is not None:  # frozen: its row, found once for the pose it froze at
            row = self._rows.get(other.body)
            if row is None or row[0] is not pose:
                row = self._rows[other.body] = (pose, (*extent, face_span(box, pose)) if extent is not None else None)
            if row[1] is not None:
                return row[1]
        if extent is None:  # an environment box (still: found once), or an active brick
            c = box.corners(pose)
            low, high = c.min(axis=0), c.max(axis=0)
            extent = (float(high[2]), float(low[0]), float(high[0]), float(low[1]), float(high[1]))
            if other.state is BrickState.GROUND:
                other.extent = extent
        return (*extent, face_span(box, pose))

    def lying_on(self, rec: Record, pose: Pose, active: bool = False, boxes: Boxes | None = None) -> dict[int, ContactArea]:
        """The frozen bricks and environment bodies (and with ``active`` the active bricks too)
        ``rec`` lies on face to face at ``pose`` (its bottom face within the face gap of their
        top faces), with the exact contact areas (:func:`stability._geometry.face_overlap`), in
        registration order. From the poses alone: no contact point is read. ``boxes``: those of
        :meth:`boxes` for the same ``active``, found once for the bricks of one moment.

        The bodies whose boxes cannot meet ``rec``'s bottom face are left out all at once (one
        comparison of arrays), so that asking it of each brick of a heap of 2000 costs what the
        face overlaps cost: a loop over every body for each brick took 20 s for the brick graph
        of a fallen 500-level tower. Two faces that touch within the gap share a height within
        it, so the heights ``rec``'s bottom face spans (from its lowest corner up by
        :func:`face_span`) must come within the gap of those the other's top face spans: a face
        tilted with the one it lies on reaches below that one's top corner by the tilt (a brick
        of a column on a 32 deg ramp by 11 mm). Source: stackdsl's own."""
        gap = self.config.face_gap
        corners = rec.box.corners(pose)
        bottom = float(corners[:, 2].min())
        reach = bottom + face_span(rec.box, pose)  # the highest corner of its bottom face
        x0, y0 = corners[:, :2].min(axis=0)
        x1, y1 = corners[:, :2].max(axis=0)
        boxes = boxes if boxes is not None else self.boxes(active)
        t = boxes.table
        near = np.flatnonzero(
            (bottom <= t[:, 0] + gap)
            & (reach >= t[:, 0] - t[:, 5] - gap)
            & (t[:, 1] < x1)
            & (t[:, 2] > x0)
            & (t[:, 3] < y1)
            & (t[:, 4] > y0)
        )
        found = [*boxes.planes, *(boxes.records[i] for i in near.tolist())]
        found.sort(key=lambda r: boxes.rank[r.body])
        out = {}
        for other in found:
            if other is rec or other.body not in boxes.rank:
                continue
            area = self._face(rec, pose, other)  # found once: the admission tests ask it too
            if area is not None and area.area > 0.0:
                out[other.body] = area
        return out

    def holds(self, main: ContactArea, point: Sequence[float] | np.ndarray) -> bool:
        """Centre of mass ``point`` over the main contact area ``main`` (by ``com_margin`` when it is set).
        The last answer for each area is kept: the stack test asks it of every frozen brick at
        every change of the stack, most of them with the same area and centre of mass as before."""
        x, y = float(point[0]), float(point[1])
        kept = self._held.get(id(main))
        if kept is not None and kept[0] is main and kept[1] == x and kept[2] == y:
            return kept[3]
        if self.config.com_margin > 0:
            held = contains(main.polygon, (x, y), self.config.com_margin)
        else:
            held = main.holds(x, y)
        if len(self._held) >= HELD_KEPT:
            self._held.clear()
        self._held[id(main)] = (main, x, y, held)
        return held

    def around(self, rec: Record, contacts: Contacts) -> dict[int, list[ContactPoint]]:
        """Every registered body ``rec`` touches, with the contact points, in registration order."""
        grouped: dict[int, list[ContactPoint]] = defaultdict(list)
        for c in contacts[rec.body]:
            if c.other in self.stack.bodies:
                grouped[c.other].append(c)
        return {o: grouped[o] for o in self.stack.ordered(grouped)}

    def neighbours(self, rec: Record, contacts: Contacts) -> set[int]:
        """The registered bodies ``rec`` touches, in no order (:meth:`around` without the points)."""
        bodies = self.stack.bodies
        return {c.other for c in contacts[rec.body] if c.other in bodies}

    def touching(self, rec: Record, contacts: Contacts) -> dict[int, list[ContactPoint]]:
        """Registered bodies ``rec`` touches, with the contact points, in registration order.

        An active brick lying on ``rec`` (its contact normal within the support angle of
        straight down) is left out: it is a load, not a support (report 3.3.1 drops
        contacts between two unstable bricks); the stack test counts it once it is frozen.
        """
        bodies = self.stack.bodies
        return {
            o: pts
            for o, pts in self.around(rec, contacts).items()
            if not (bodies[o].state is BrickState.ACTIVE and np.mean([c.normal[2] for c in pts]) < -self.support_cos)
        }


def face_span(box: Box, pose: Pose) -> float:
    """Metres between the lowest and the highest corner of ``box``'s top face at ``pose`` (and of
    its bottom face: the same), the face whose normal is nearest to vertical. 0 for a level
    brick; a 24 mm face tilted 32 deg spans 12.7 mm.

    >>> brick = Box(np.array([0.06, 0.012, 0.004]), 0.0106)
    >>> face_span(brick, Pose.from_euler([0, 0, 0.004])), round(face_span(brick, Pose.from_euler([0, 0, 0], roll=-32)) * 1e3, 1)
    (0.0, 12.7)
    """
    row: list[float] = pose.rotation[2].tolist()  # floats: asked of every box
    half: list[float] = box.half_extents.tolist()
    a, b, c = (abs(v) for v in row)
    ha, hb, hc = half
    reach = (a * ha, b * hb, c * hc)  # each axis's half reach in z
    up = 0 if a >= b and a >= c else 1 if b >= c else 2  # the axis nearest vertical: the faces' normal
    return 2.0 * (reach[0] + reach[1] + reach[2] - reach[up])


#: Length below which the mean of a contact's unit normals is taken to cancel out (:func:`mean_normal`).
CANCELLED = 1e-6


def mean_normal(points: Sequence[ContactPoint]) -> np.ndarray:
    """The unit normal of a contact of one or more engine points (shape (3,)): the mean of theirs,
    or, where they cancel out (points on opposite sides: a body a blow drove into another, which
    the engine pushes out both ways), the deepest point's. The mean of such normals was zero, and
    a contact polygon built on it had no points: an internal error where the run should go on
    (a 3-level tower struck 100 times at its base). Source: stackdsl's own.

    >>> from stability._engine import ContactPoint
    >>> up, down = np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0])
    >>> at = np.zeros(3)
    >>> mean_normal([ContactPoint(1, 2, at, up, distance=-0.001), ContactPoint(1, 2, at, down, distance=-0.003)]).tolist()
    [0.0, 0.0, -1.0]
    """
    normal: np.ndarray = np.mean([c.normal for c in points], axis=0)
    length = float(np.linalg.norm(normal))
    if length > CANCELLED:
        return normal / length
    deepest = min(points, key=lambda c: c.distance)
    return np.asarray(deepest.normal, dtype=float) / float(np.linalg.norm(deepest.normal))


def main_area(areas: dict[int, ContactArea]) -> ContactArea:
    """The main contact area (report 3.3.3): the hull of the individual ones, at the lowest height."""
    return ContactArea(
        combined_hull(list(areas.values())), min(a.height for a in areas.values()), np.array([0.0, 0.0, 1.0]), False
    )


def horizontal(contact: ContactPolygon[int], pad: float, flip: bool = False) -> ContactArea:
    """The horizontal projection of a leaning contact, for the graph and the wake cascade;
    ``flip``: seen from ``contact.other`` (its normal reversed)."""
    points = np.asarray(contact.points)
    normal = -contact.normal if flip else contact.normal
    return ContactArea(padded_hull(points[:, :2], pad), float(points[:, 2].mean()), normal, exact=False)


def overlap(points: Iterable[ContactPoint], supports: Mapping[int, ContactArea], up: float) -> float:
    """Metres a brick at rest has sunk into its supports, 0 when it has not: the mean over
    them, a support face to face by the depth of its exact area, the others together by the
    mean depth, straight down, of the brick's contact points with them that overlap.
    ``points``: the brick's contact points; ``supports``: the areas it rests on, by body;
    ``up``: the least vertical component of a support's normal.

    An engine's contacts are soft: a brick at rest overlaps what it rests on by a fraction
    of a millimetre (0.01 to 0.13 mm for a KAPLA brick on pybullet at 240 Hz). Frozen there,
    the overlaps of a tall tower add up, unevenly, and a brick placed across two supports
    sunk to different depths rocks before it rests. The stack freezes a brick raised by
    this much, so that a frozen tower keeps its heights. The faces give the depth exactly:
    pybullet's contact distances overstate it by several per cent (0.098 mm for 0.091 mm),
    which raised a 250-level tower 0.4 mm. Source: stackdsl's own.

    >>> import numpy as np
    >>> from shapely.geometry import box
    >>> up = np.array([0.0, 0.0, 1.0])
    >>> down = [ContactPoint(1, 0, np.zeros(3), up, distance=d) for d in (-1e-4, -3e-4, 1e-5)]
    >>> round(overlap(down, {0: ContactArea(box(0, 0, 1, 1), 0.0, up, exact=False)}, 0.9) * 1e3, 3)
    0.2
    >>> round(overlap(down, {0: ContactArea(box(0, 0, 1, 1), 0.0, up, exact=True, depth=5e-5)}, 0.9) * 1e3, 3)
    0.05
    """
    depths = [a.depth for a in supports.values() if a.exact]
    loose = [
        -c.distance / c.normal[2]
        for c in points
        if c.other in supports and not supports[c.other].exact and c.normal[2] >= up and c.distance < 0
    ]
    if loose:
        depths.append(float(_mean(loose)))
    return max(0.0, float(_mean(depths))) if depths else 0.0  # numpy's means, bit for bit, without its arrays


def by_body(points: Iterable[ContactPoint]) -> Contacts:
    """Contact points grouped by the body they are seen from."""
    grouped: dict[int, list[ContactPoint]] = defaultdict(list)
    for c in points:
        grouped[c.body].append(c)
    return grouped

"""The bricks of a run: one record per brick in the world, and the structure they form.

A :class:`BrickRecord` owns everything the run knows of one brick: its body, its level,
where it was placed, whether it moves. :class:`Structure` holds the records and answers
the questions asked of all of them at once: how far each has moved from where it was
placed, and how far the bricks under a new one have sunk.

Source: stackdsl's own.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Collection, Mapping
from dataclasses import InitVar, dataclass, field

import numpy as np
import shapely
from scipy.spatial.transform import Rotation
from shapely.geometry import Polygon

from stability import Box, Pose, hull_xy, kinetic_energy

from ..engines.protocol import BrickSpec, World


@dataclass
class BrickRecord:
    """One brick (or projectile) in the world.

    Attributes:
        id: the scenario's id; body: the engine's.
        spec: size, mass and material; box: the same as a :class:`stability.Box`.
        level: the structure level, None for a projectile.
        pose: the placed pose (a projectile: its launch pose).
        nominal: its pose in the scenario; a brick is placed lower by as much as the
            bricks below it have sunk (:attr:`sink`).
        moving: simulated by the engine (not frozen by the stability extension).
        was_frozen: the stability extension has frozen it at least once (moving again: woken).
        settled: metres it had moved when last frozen (frozen bricks do not move), or None.
        corners: shape (8, 3), the placed corners in the world, m.
        footprint: the placed horizontal footprint (``shape``: the same, found already).
        below: the structure bricks it was placed on (:meth:`Structure.under`), in the order
            they entered.
        order: its place in the order bricks entered the world (set by :class:`Structure`).
    """

    id: str
    body: int
    spec: BrickSpec
    level: int | None
    pose: Pose
    nominal: Pose
    moving: bool = True
    was_frozen: bool = False
    settled: float | None = None
    order: int = -1
    below: tuple[BrickRecord, ...] = ()
    shape: InitVar[Polygon | None] = None
    box: Box = field(init=False)
    corners: np.ndarray = field(init=False)
    footprint: Polygon = field(init=False)

    def __post_init__(self, shape: Polygon | None) -> None:
        self.box = Box(np.array(self.spec.half_extents), self.spec.mass)
        self.corners = self.box.corners(self.pose)
        self.footprint = footprint(self.corners) if shape is None else shape

    @property
    def structure(self) -> bool:
        """Part of the structure (placed, with a level), not a projectile."""
        return self.level is not None

    @property
    def sink(self) -> float:
        """Metres it was placed below its pose in the scenario."""
        return float(self.nominal.position[2] - self.pose.position[2])

    @property
    def top(self) -> float:
        """Metres, the height of its highest corner in the scenario."""
        return float(self.box.corners(self.nominal)[:, 2].max())

    @functools.cached_property
    def placed_xyz(self) -> tuple[float, float, float]:
        """Metres, where its centre was placed, as floats."""
        x, y, z = self.pose.position.tolist()
        return x, y, z

    @functools.cached_property
    def placed_xyzw(self) -> tuple[float, float, float, float]:
        """The orientation it was placed with, a unit quaternion (x, y, z, w), as floats."""
        x, y, z, w = self.pose.orientation.tolist()
        return x, y, z, w

    @functools.cached_property
    def corner_rows(self) -> tuple[tuple[float, float, float, float, float, float], ...]:
        """Each of its eight corners (the order of :attr:`corners`) as six floats, m: where it
        lies in the brick's own frame, then where it was placed (:meth:`Structure.displacement`
        reads them every step, one flat row a corner)."""
        x, y, z = self.spec.half_extents
        placed = self.corners.tolist()
        return tuple((a, b, c, px, py, pz) for (a, b, c), (px, py, pz) in zip(_local_corners((x, y, z)), placed, strict=True))

    @functools.cached_property
    def half_diagonal(self) -> float:
        """Metres from the centre to a corner."""
        x, y, z = self.spec.half_extents
        return _half_diagonal((x, y, z))


@functools.lru_cache(maxsize=256)
def _local_corners(half_extents: tuple[float, float, float]) -> tuple[tuple[float, float, float], ...]:
    """The eight corners in its own frame of a brick of ``half_extents`` (m), as floats in the
    order of :attr:`BrickRecord.corners` (:attr:`BrickRecord.corner_rows`), found once for each
    size: a run places many bricks of a few sizes, and each brick asked its own (20 us)."""
    box = Box(np.array(half_extents), 1.0)
    return tuple((a, b, c) for a, b, c in box.corners(Pose(np.zeros(3))).tolist())


@functools.lru_cache(maxsize=256)
def _half_diagonal(half_extents: tuple[float, float, float]) -> float:
    """:attr:`BrickRecord.half_diagonal` of a brick of ``half_extents`` (m), found once for each size."""
    return float(np.linalg.norm(np.array(half_extents)))


def _matrix(
    orientation: tuple[float, float, float, float],
) -> tuple[float, float, float, float, float, float, float, float, float]:
    """The rotation matrix of unit quaternion ``orientation`` (x, y, z, w), row by row, in
    floats (:attr:`stability.Pose.rotation`'s formula: the per-step measures ask it of every
    moving brick)."""
    qx, qy, qz, qw = orientation
    n = 2.0 / (qx * qx + qy * qy + qz * qz + qw * qw)
    return (
        *(1 - n * (qy * qy + qz * qz), n * (qx * qy - qz * qw), n * (qx * qz + qy * qw)),
        *(n * (qx * qy + qz * qw), 1 - n * (qx * qx + qz * qz), n * (qy * qz - qx * qw)),
        *(n * (qx * qz - qy * qw), n * (qy * qz + qx * qw), 1 - n * (qx * qx + qy * qy)),
    )


Poses = tuple[np.ndarray, np.ndarray]
"""Bricks' poses, one row a brick: positions (n, 3), m, and unit quaternions (x, y, z, w), (n, 4)."""


_NONE = np.zeros(0)
_NONE.flags.writeable = False


def _order(r: BrickRecord) -> int:
    """Where ``r`` entered the world, to sort by."""
    return r.order


Extent = tuple[float, float, float, float, float]
"""A footprint's bounding box (min x, min y, max x, max y, m) and the area the box has beyond
the footprint (m^2)."""


def extent(shape: Polygon) -> Extent:
    """:data:`Extent` of a footprint (shapely, horizontal). Source: stackdsl's own."""
    x0, y0, x1, y1 = shape.bounds
    return x0, y0, x1, y1, (x1 - x0) * (y1 - y0) - shape.area


def footprint(corners: np.ndarray) -> Polygon:
    """The horizontal footprint of a brick's corners (shape (8, 3), m): their convex hull in x, y."""
    hull: Polygon = hull_xy(corners[:, :2])
    return hull


FEW = 12
"""Up to this many bricks, :meth:`Structure.measure`, :meth:`Structure.displacements` and the
collapse monitor's rest test work in floats, brick by brick (numpy's fixed costs, some 60 us a
step for the poses, the rotations and the corners, are more than a dozen bricks' floats now that
a merged body's bricks are read at once: 5 bricks riding a shaken ground, 166 to 111 ms a run)."""

BOUND_SLACK = 1e-9
"""Metres added to :meth:`Structure._within`'s bound, far above its rounding: a ride measured that
far inside the threshold is measured exactly."""

OVERLAP = 1e-8
"""Square metres two footprints must share for a brick to rest on the other (:meth:`Structure.under`)."""

SURE = 1e-12
"""Square metres, far above the rounding of an area of a few square centimetres, by which
:meth:`Structure.under`'s bounds of an overlap must clear :data:`OVERLAP` to decide it."""


class Structure:
    """The records of a run, by id and by body, in the order they entered.

    Args:
        world: where the bodies are.
    """

    def __init__(self, world: World) -> None:
        self.world = world
        self.records: dict[str, BrickRecord] = {}
        self.placed: list[BrickRecord] = []  # the structure bricks, in the order they were placed
        self.moving: dict[str, BrickRecord] = {}  # the structure bricks the engine simulates, by id
        self.projectiles: list[BrickRecord] = []
        self.removed: list[BrickRecord] = []  # pulled out of the structure by a hand
        self.newly_settled: list[BrickRecord] = []  # bricks whose ``settled`` was written since the drift last looked
        # metres the ground has moved from where it started (a shake table): displacements are the ground's frame's
        self.offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._by_body: dict[int, BrickRecord] = {}
        self._tops: dict[int, list[BrickRecord]] = {}  # top height in 0.1 mm -> bricks
        self._extents: dict[str, Extent] = {}  # structure brick id -> its footprint's extent
        self._cached: tuple[tuple[int, ...], np.ndarray, np.ndarray] = ((), np.zeros((0, 8, 3)), np.zeros((0, 8, 3)))
        # the placed positions, orientations and half diagonals of the bricks last bounded
        self._placed: tuple[tuple[int, ...], np.ndarray, np.ndarray, np.ndarray] = ((), *(np.zeros(0),) * 3)
        # merged body -> the bodies of it measured, the inverse of the first's rotation matrix
        # then, their corners then from the first's centre (n * 8, 3, m), where they were placed (n * 8, 3, m),
        # and the farthest of those corners from the first's centre (m)
        self._merged: dict[int, tuple[tuple[int, ...], np.ndarray, np.ndarray, np.ndarray, float]] = {}
        # merged body -> the bodies of it last measured, the first's centre (in the ground's frame, m) and
        # quaternion (x, y, z, w) then, and the farthest any of them was from where it was placed (m)
        self._measured: dict[
            int, tuple[tuple[int, ...], tuple[float, float, float], tuple[float, float, float, float], float]
        ] = {}
        # what :meth:`measure` last read, in the order placed, and the rows of the pending bricks
        self._layout: tuple[tuple[tuple[str, ...], ...], list[BrickRecord], list[int]] = ((), [], [])

    def add(self, record: BrickRecord) -> None:
        """Register a brick that entered the world."""
        record.order = len(self.records)
        self.records[record.id] = record
        self._by_body[record.body] = record
        (self.placed if record.structure else self.projectiles).append(record)
        if record.structure:
            self._tops.setdefault(round(record.top * 1e4), []).append(record)
            self._extents[record.id] = extent(record.footprint)
            self.set_moving(record, record.moving)

    def settle(self, record: BrickRecord) -> None:
        """Write how far a structure brick had moved as it froze (None as it woke), and note it
        for the drift (:meth:`stackdsl.runtime.collapse.CollapseMonitor.record_drift`)."""
        record.settled = None if record.moving else self.displacement(record)
        self.newly_settled.append(record)

    def set_moving(self, record: BrickRecord, moving: bool) -> None:
        """Mark a brick frozen (``moving`` False) or simulated by the engine again."""
        record.moving = moving
        if not record.structure:
            return
        if moving:
            self.moving[record.id] = record
        else:
            self.moving.pop(record.id, None)

    def detach(self, record: BrickRecord) -> None:
        """Take a structure brick out of the structure (a hand pulls it out): it is no longer
        watched for a collapse nor counted in displacements; it keeps its record (by id, by body)."""
        self.placed.remove(record)
        self.moving.pop(record.id, None)
        self._tops[round(record.top * 1e4)].remove(record)
        record.level = None
        self.removed.append(record)

    def toppled(self) -> list[BrickRecord]:
        """The structure bricks tilted past their tipping angle: their axis that was vertical when
        placed has turned further than the angle at which the centre of mass passes over the
        nearer edge of the placed footprint, atan(least horizontal half-extent / vertical
        half-extent), both as placed. Source: stackdsl's own (a block tips over an edge of its
        base once its centre of mass is past it: Meriam & Kraige, Statics, ch. 6)."""
        records = self.placed
        if not records:
            return []
        _, quaternions = self.world.poses_of([r.body for r in records])
        now = Rotation.from_quat(quaternions).as_matrix()
        out = []
        for r, rotation in zip(records, now):
            placed = r.pose.rotation
            half = np.abs(placed) @ np.array(r.box.half_extents)  # the placed box's half extents in the world
            tip = math.atan2(min(half[0], half[1]), half[2])
            up = placed.T @ np.array([0.0, 0.0, 1.0])  # the brick's own axis that was vertical
            tilt = math.acos(max(-1.0, min(1.0, float((rotation @ up)[2]))))
            if tilt > tip:
                out.append(r)
        return out

    def by_body(self, body: int) -> BrickRecord | None:
        """The record of an engine body, or None (the ground, a fixture)."""
        return self._by_body.get(body)

    @property
    def levels(self) -> dict[str, int]:
        """Structure brick id -> level."""
        return {r.id: r.level for r in self.placed if r.level is not None}

    def under(self, bottom: float, footprint: Polygon) -> list[BrickRecord]:
        """The placed bricks whose tops in the scenario lie within 1 mm of ``bottom`` (m) and
        whose footprints overlap ``footprint`` by more than :data:`OVERLAP`: those a brick placed
        there rests on. The overlap lies within the overlap of the two bounding boxes, and
        misses it by at most what each box has beyond its footprint (:func:`extent`): where those
        bounds decide, by :data:`SURE`, GEOS's intersection (some 70 000 instructions a pair) is
        not asked; bricks turned by 0 or 90 degrees have footprints that fill their boxes."""
        key = round(bottom * 1e4)
        below = [r for k in range(key - 10, key + 11) for r in self._tops.get(k, ())]  # within 1 mm
        if not below:
            return []
        x0, y0, x1, y1, spare = extent(footprint)
        rests: list[bool | None] = []
        for r in below:
            a0, b0, a1, b1, more = self._extents[r.id]
            boxes = max(0.0, min(x1, a1) - max(x0, a0)) * max(0.0, min(y1, b1) - max(y0, b0))
            if boxes - spare - more > OVERLAP + SURE:
                rests.append(True)
            else:
                rests.append(False if boxes < OVERLAP - SURE else None)
        unsure = [r for r, rest in zip(below, rests) if rest is None]
        if unsure:
            overlaps = iter(shapely.area(shapely.intersection([r.footprint for r in unsure], footprint)).tolist())
            rests = [next(overlaps) > OVERLAP if rest is None else rest for rest in rests]
        return [r for r, rest in zip(below, rests) if rest]

    def sink(self, below: list[BrickRecord]) -> float:
        """How far the placed bricks a new brick will rest on (``below``, :meth:`under`) have
        sunk below their heights in the scenario (m): the least of them, 0 for none."""
        if not below:
            return 0.0
        positions, _ = self.world.poses_of([r.body for r in below])
        return max(0.0, min(float(r.nominal.position[2]) - float(z) for r, z in zip(below, positions[:, 2])))

    def displacements(self, records: list[BrickRecord], poses: Poses | None = None) -> np.ndarray:
        """How far each brick's farthest-moved corner is from where it was placed, m, in the
        ground's frame (:attr:`offset`, moved by a shake table) (a
        brick tipping in place counts, not only one whose centre moves); all at once, as
        raw and tuned modes ask it of every brick at every step, from ``poses`` when read
        already (:meth:`poses`, one row a brick). Up to :data:`FEW` bricks, brick by brick in
        floats (:meth:`displacement`)."""
        if not records:
            return np.zeros(0)
        if len(records) <= FEW:
            return np.array([self.displacement(r) for r in records])
        if poses is None and (groups := self.world.merged_groups()):
            return self._merged_displacements(records, groups)
        bodies = tuple(r.body for r in records)
        positions, quaternions = self.poses(records) if poses is None else poses
        if self._cached[0] != bodies:
            self._cached = (
                bodies,
                np.stack([r.box.corners(Pose(np.zeros(3))) for r in records]),
                np.stack([r.corners for r in records]),
            )
        _, local, placed = self._cached
        now = positions[:, None, :] + np.einsum("nij,nkj->nki", Rotation.from_quat(quaternions).as_matrix(), local)
        farthest: np.ndarray = np.sqrt(((now - placed) ** 2).sum(axis=2).max(axis=1))
        return farthest

    def _merged_displacements(self, records: list[BrickRecord], groups: Mapping[int, tuple[int, ...]]) -> np.ndarray:
        """:meth:`displacements` of ``records``, those of them that one merged body moves
        (``groups``, :meth:`World.merged_groups <stackdsl.engines.protocol.World.merged_groups>`)
        from its one pose: their corners, read in the world once a merge, move with the first
        one's pose as one rigid body (a Jenga tower's top of 21 bricks rides a pull as one: a
        product for all, not 21 poses turned). The others as :meth:`displacements` measures them."""
        rows = {r.body: i for i, r in enumerate(records)}
        out = np.zeros(len(records))
        alone = set(range(len(records)))
        for key, parts in groups.items():
            mine = [rows[b] for b in parts if b in rows]
            if len(mine) < 2:
                continue
            alone.difference_update(mine)
            out[mine] = self._rigidly([records[i] for i in mine], key)
        if alone:
            rest = sorted(alone)
            out[rest] = self.displacements(
                [records[i] for i in rest], None if len(rest) <= FEW else self.poses([records[i] for i in rest])
            )
        return out

    def _rigidly(self, records: list[BrickRecord], key: int) -> np.ndarray:
        """How far each of ``records``, parts of the merged body ``key``, is from where it was
        placed (:meth:`displacements`), m: their corners where they were when first asked of this
        merge, turned and moved as the first of them has since (``x -> M x + t``)."""
        bodies = tuple(r.body for r in records)
        kept = self._merged.get(key)
        if kept is None or kept[0] != bodies:
            positions, quaternions = self.world.poses_of(list(bodies))
            local = np.stack([r.box.corners(Pose(np.zeros(3))) for r in records])
            matrices = Rotation.from_quat(quaternions).as_matrix()
            corners = (positions[:, None, :] + np.einsum("nij,nkj->nki", matrices, local)).reshape(-1, 3)
            placed = np.concatenate([r.corners for r in records])
            arms = corners - positions[0]
            reach = float(np.sqrt(np.einsum("ij,ij->i", arms, arms).max()))
            kept = self._merged[key] = (bodies, matrices[0].T.copy(), arms, placed, reach)
            for old in [k for k in self._merged if k not in self.world.merged_groups()]:
                del self._merged[old]
                self._measured.pop(old, None)
        _, turned, arms, placed, _ = kept
        (x, y, z), orientation = self.world.pose_floats(bodies[0])
        ox, oy, oz = self.offset
        now = arms @ (np.array(_matrix(orientation)).reshape(3, 3) @ turned).T  # each corner from the first's centre
        now -= placed
        now += (x - ox, y - oy, z - oz)
        farthest: np.ndarray = np.sqrt(np.einsum("ij,ij->i", now, now).reshape(len(bodies), -1).max(axis=1))
        self._measured[key] = (bodies, (x - ox, y - oy, z - oz), orientation, float(farthest.max()))
        return farthest

    def _within(self, key: int, parts: list[BrickRecord], threshold: float) -> bool:
        """Whether no corner of ``parts``, the bricks the merged body ``key`` moves, can be more
        than ``threshold`` m from where it was placed: bounded from their farthest when
        :meth:`_rigidly` last measured them, plus the most any corner can have moved since as one
        rigid body (its first part's travel, and the chord its turn sweeps at the farthest corner
        from that part's centre, 2 r sin(angle / 2)). False when they were not measured so.
        Source: stackdsl's own."""
        kept, last = self._merged.get(key), self._measured.get(key)
        if kept is None or last is None or last[0] != kept[0] or len(parts) != len(kept[0]):
            return False
        _, (x0, y0, z0), (ax, ay, az, aw), farthest = last
        (x, y, z), (qx, qy, qz, qw) = self.world.pose_floats(parts[0].body)
        ox, oy, oz = self.offset
        moved = math.sqrt((x - ox - x0) ** 2 + (y - oy - y0) ** 2 + (z - oz - z0) ** 2)
        cos_half = min(1.0, abs(qx * ax + qy * ay + qz * az + qw * aw))
        return farthest + moved + 2.0 * kept[4] * math.sqrt(1.0 - cos_half**2) + BOUND_SLACK <= threshold

    def poses(self, records: list[BrickRecord]) -> Poses:
        """:data:`Poses` of ``records`` now, in the ground's frame (:attr:`offset`)."""
        positions, quaternions = self.world.poses_of([r.body for r in records])
        return positions - self.offset, quaternions

    def measure(self, pending: Collection[str], threshold: float) -> tuple[list[BrickRecord], np.ndarray]:
        """The structure bricks a collapse monitor measures now, in the order placed, and how far
        each has moved (shape (n,), m, :meth:`displacements`): those of ``pending`` (ids, moving
        or frozen), every moving one whose corner is more than ``threshold`` m from where it was
        placed, and maybe moving ones within it that the bound could not rule out. One read of
        the poses serves all. With more than :data:`FEW` moving bricks and more than :data:`FEW`
        pending, the displacements of all at once; else the others' bound first (:meth:`bounds`,
        in floats up to :data:`FEW` moving bricks: it is never less than the displacement), then
        the displacements of the bricks it leaves.

        The bricks that one merged body moves in the engine (a ride, :meth:`World.merged_groups
        <stackdsl.engines.protocol.World.merged_groups>`) are measured all at once from its one
        pose (:meth:`_rigidly`), not brick by brick: the twelve bricks of a single file riding a
        shaken ground cost the monitor a pose each a step, a fifth of the run. Source: stackdsl's own."""
        riding = self._riding()
        if not riding:
            return self._measure(pending, threshold, self.moving)
        ridden = {r.id for parts in riding.values() for r in parts}
        rest = {i: r for i, r in self.moving.items() if i not in ridden}
        watched, moved = self._measure([i for i in pending if i not in ridden], threshold, rest)
        found = list(zip(watched, moved.tolist(), strict=True))
        for key, parts in riding.items():
            if not any(r.id in pending for r in parts) and self._within(key, parts, threshold):
                continue  # the usual step of a ride: a bound from one pose
            rigid = zip(parts, self._rigidly(parts, key).tolist(), strict=True)
            found += [(r, d) for r, d in rigid if d > threshold or r.id in pending]
        if not found:
            return [], _NONE
        found.sort(key=lambda pair: _order(pair[0]))
        return [r for r, _ in found], np.array([d for _, d in found])

    def _riding(self) -> dict[int, list[BrickRecord]]:
        """The moving bricks a merged body moves, two or more, by its key, in the order of its parts."""
        groups = self.world.merged_groups() if len(self.moving) > 1 else None
        if not groups:
            return {}
        by_body = {r.body: r for r in self.moving.values()}
        riding = {key: [by_body[b] for b in parts if b in by_body] for key, parts in groups.items()}
        return {key: parts for key, parts in riding.items() if len(parts) > 1}

    def _measure(
        self, pending: Collection[str], threshold: float, moving: Mapping[str, BrickRecord]
    ) -> tuple[list[BrickRecord], np.ndarray]:
        """:meth:`measure` of the moving bricks ``moving`` (by id), none of them riding."""
        records = self.records
        frozen = [r for r in map(records.__getitem__, pending) if not r.moving]
        if len(moving) <= FEW:  # in floats: numpy's fixed costs are most of it for a few bricks
            watched = [r for r in moving.values() if r.id in pending or self._bound(r) > threshold]
            if frozen or len(watched) > 1:
                watched = sorted(frozen + watched, key=_order)
            return watched, self.displacements(watched) if watched else _NONE
        key = (tuple(pending), tuple(r.id for r in frozen), tuple(moving))
        if self._layout[0] != key:  # the same bricks step after step: sorted once
            read = sorted(frozen + list(moving.values()), key=_order)
            self._layout = (key, read, [i for i, r in enumerate(read) if r.id in pending])
        _, read, rows = self._layout
        if len(rows) > FEW:  # measured whatever the bound says: one pass over all
            moved = self.displacements(read)
            keep = [i for i, d in enumerate(moved.tolist()) if d > threshold or read[i].id in pending]
            return [read[i] for i in keep], moved[keep]
        positions, quaternions = self.poses(read)
        if not rows:  # the usual step: only what may have moved is measured
            bound = self.bounds(read, (positions, quaternions))
            rows = [i for i, b in enumerate(bound.tolist()) if b > threshold]
        else:
            others = [i for i, r in enumerate(read) if r.id not in pending]
            if others:
                bound = self.bounds([read[i] for i in others], (positions[others], quaternions[others]))
                rows = sorted(rows + [i for i, b in zip(others, bound.tolist()) if b > threshold])
        if not rows:
            return [], _NONE
        watched = [read[i] for i in rows]
        if len(watched) <= FEW:
            return watched, self.displacements(watched)
        return watched, self.displacements(watched, (positions[rows], quaternions[rows]))

    def bounds(self, records: list[BrickRecord], poses: Poses) -> np.ndarray:
        """For each brick, shape (n,), m, the most its farthest-moved corner can be from where it
        was placed (its pose now: ``poses``, one row a brick): the centre's displacement plus the
        most a corner can move in the rotation since placing, 2 r sin(angle / 2) for the half
        diagonal r (cos(angle / 2) = |q . q0| for unit quaternions). Source: stackdsl's own."""
        positions, quaternions = poses
        bodies = tuple(r.body for r in records)
        if self._placed[0] != bodies:  # the same bricks step after step: read their placing once
            placed = np.array([r.pose.position for r in records])
            placed_q = np.array([r.pose.orientation for r in records])
            self._placed = (bodies, placed, placed_q, np.array([r.half_diagonal for r in records]))
        _, placed, placed_q, radius = self._placed
        cos_half = np.minimum(1.0, np.abs((quaternions * placed_q).sum(axis=1)))
        bound: np.ndarray = np.linalg.norm(positions - placed, axis=1) + 2.0 * radius * np.sqrt(1.0 - cos_half**2)
        return bound

    def displacement(self, r: BrickRecord) -> float:
        """How far the farthest-moved corner of ``r`` is from where it was placed, m, in floats:
        the corners rotated by the quaternion's matrix (:attr:`stability.Pose.rotation`'s formula)."""
        (x, y, z), orientation = self.world.pose_floats(r.body)
        ox, oy, oz = self.offset
        x, y, z = x - ox, y - oy, z - oz
        m00, m01, m02, m10, m11, m12, m20, m21, m22 = _matrix(orientation)
        farthest = 0.0
        for a, b, c, px, py, pz in r.corner_rows:  # flat rows and a comparison, not max(): a third faster
            dx = x + m00 * a + m01 * b + m02 * c - px
            dy = y + m10 * a + m11 * b + m12 * c - py
            dz = z + m20 * a + m21 * b + m22 * c - pz
            moved = dx * dx + dy * dy + dz * dz
            if moved > farthest:
                farthest = moved
        return math.sqrt(farthest)

    def _bound(self, r: BrickRecord) -> float:
        """:meth:`bounds` for one brick, in floats."""
        (x, y, z), (qx, qy, qz, qw) = self.world.pose_floats(r.body)
        ox, oy, oz = self.offset
        px, py, pz = r.placed_xyz[0] + ox, r.placed_xyz[1] + oy, r.placed_xyz[2] + oz
        ax, ay, az, aw = r.placed_xyzw
        cos_half = min(1.0, abs(qx * ax + qy * ay + qz * az + qw * aw))
        return math.sqrt((x - px) ** 2 + (y - py) ** 2 + (z - pz) ** 2) + 2.0 * r.half_diagonal * math.sqrt(1.0 - cos_half**2)

    def kinetic_energy(self) -> float:
        """Joules of the structure's bricks: linear (report 3.6.2) and rotational motion, each
        brick's inertia that of a uniform box."""
        records = self.placed
        if not records:
            return 0.0
        linear, angular = self.world.velocities_of([r.body for r in records])
        _, quaternions = self.world.poses_of([r.body for r in records])
        local = np.einsum("nji,nj->ni", Rotation.from_quat(quaternions).as_matrix(), angular)
        total = 0.0
        for r, v, w in zip(records, linear, local):
            a, b, c = (2 * h for h in r.box.half_extents)
            inertia = r.spec.mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
            total += kinetic_energy(r.spec.mass, float(np.linalg.norm(v))) + 0.5 * float(w @ (inertia * w))
        return total

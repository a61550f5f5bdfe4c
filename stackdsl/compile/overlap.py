"""Where placed bricks overlap and what they rest on: the geometry of the checks before simulating.

Overlap depths are found by the separating-axis test on each pair of boxes
(15 axes: 3 face normals of each box and the 9 cross products of their edges), which for
convex polyhedra gives the exact penetration depth. Resting contacts between boxes that
both have an axis vertical (lying flat, on a side or on an end) are decided by the same
test on the lowered box; for a contact involving a tilted box the same test is followed by
where the boxes meet: the centroid of their intersection (a convex polytope, scipy's
``HalfspaceIntersection``) must lie below the brick's centre. No engine is involved. Candidate
pairs come from a sweep over axis-aligned bounding boxes, so a tall tower costs little.

Source: stackdsl's own; the separating-axis test is the standard one for oriented boxes
(Gottschalk, Lin and Manocha, "OBBTree", SIGGRAPH 1996).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog
from scipy.spatial import HalfspaceIntersection, QhullError
from scipy.spatial.transform import Rotation

from ..lang.errors import FieldPath

REST_TOLERANCE = 0.001
"""Metres: a brick rests on a body when lowered this far it would sink into it (from below its centre)."""
OVERLAP_TOLERANCE = 0.0001
"""Metres: bodies may interpenetrate this deep where placed (rounding of hand-written poses); deeper is an error."""
ROUNDING = 1e-9
"""Metres: an overlap of the tolerance as written (24 mm - 23.9 mm is 0.10000000000000142 mm in doubles) is within
it. A nanometre: far below any placement a file writes, far above a double's rounding of a position within 1 km
(a step of 1.1e-13 m there) carried through a separating-axis test."""
_EPS = 1e-6  # m: deeper by less than this is no deeper (numerical noise of the distance queries)
_VERTICAL = 1.0 - 1e-12  # |cosine| of an axis with z above which the axis counts as vertical
_CHUNK = 100_000  # candidate pairs tested at once (bounds memory on hostile files)
_MAX_FOUND = 1000  # overlaps after which the search stops (a file that bad needs no exact count)
GROUND = -1
"""The index that stands for the ground plane in :func:`inspect_bodies`'s overlaps."""


@dataclass(frozen=True)
class Body:
    """One brick or fixture as the program will place it.

    Attributes:
        id: the brick's id.
        half_extents: metres, along the brick's own x, y, z.
        position: metres, the centre the program uses (placement error applied).
        nominal: metres, the centre as written or generated (no placement error).
        yaw, pitch, roll: degrees (:meth:`stability.Pose.from_euler`).
        slot: placement slot (bricks placed ``together`` share one), -1 for a fixture.
        time: seconds, when it is placed (0 for a fixture).
        level: the brick's level (0 for a fixture).
        path: the scenario field that made it: ``("structure", "bricks", i)``,
            ``("structure", "tower")`` or ``("structure", "card_house")``.
    """

    id: str
    half_extents: tuple[float, float, float]
    position: tuple[float, float, float]
    nominal: tuple[float, float, float]
    yaw: float
    pitch: float
    roll: float
    slot: int
    time: float
    level: int
    path: FieldPath


def inspect_bodies(
    bodies: Sequence[Body], positions: Sequence[tuple[float, float, float]]
) -> tuple[list[tuple[int, int, float]], list[int]]:
    """The overlaps and the floating bricks of ``bodies`` placed at ``positions`` (metres,
    one centre each), each tested against what exists when it is placed.

    Returns:
        The overlaps deeper than :data:`OVERLAP_TOLERANCE`, as ``(index of the later body,
        index of the other or GROUND, depth in metres)`` (at most 1000), and the indices of
        the bricks that rest on nothing when placed, in placement order.
    """
    n = len(bodies)
    centre = np.array(positions, dtype=float).reshape(n, 3)
    half = np.array([b.half_extents for b in bodies], dtype=float).reshape(n, 3)
    rotation = Rotation.from_euler("ZYX", [[b.yaw, b.pitch, b.roll] for b in bodies], degrees=True)
    axes = rotation.as_matrix().reshape(n, 3, 3)  # column k: the body's axis k in the world
    slot = np.array([b.slot for b in bodies])
    brick = slot >= 0
    reach = np.abs(axes) @ half[:, :, None]
    low, high = centre - reach[:, :, 0], centre + reach[:, :, 0]
    prism = (np.abs(axes[:, 2, :]) > _VERTICAL).any(axis=1)

    overlaps: list[tuple[int, int, float]] = []
    bottom = low[:, 2]
    for i in np.flatnonzero(brick & (bottom < -(OVERLAP_TOLERANCE + ROUNDING))):
        overlaps.append((int(i), GROUND, float(-bottom[i])))
    grounded = brick & (bottom < REST_TOLERANCE - _EPS)

    near_a, near_b, near_depth = [], [], []
    for a, b in _candidates(low, high, REST_TOLERANCE):
        keep = brick[a] | brick[b]  # two fixtures may overlap: neither moves
        a, b = a[keep], b[keep]
        depth = penetration(centre[a], axes[a], half[a], centre[b], axes[b], half[b])
        near = depth > -REST_TOLERANCE  # the separating-axis bound: farther pairs cannot touch
        near_a.append(a[near])
        near_b.append(b[near])
        near_depth.append(depth[near])
        deep = np.flatnonzero(depth > OVERLAP_TOLERANCE + ROUNDING)
        for a_, b_, d in zip(a[deep], b[deep], depth[deep]):
            later, other = (a_, b_) if (slot[a_], a_) > (slot[b_], b_) else (b_, a_)
            overlaps.append((int(later), int(other), float(d)))
        if len(overlaps) > _MAX_FOUND:
            return overlaps, []  # a file this bad needs no list of floating bricks
    pa, pb, depth0 = (np.concatenate(x) if x else np.zeros(0) for x in (near_a, near_b, near_depth))
    pa, pb = pa.astype(int), pb.astype(int)

    # directed candidate supports: (brick, support) where the support exists when the brick is placed
    up = np.concatenate([pa, pb])
    down = np.concatenate([pb, pa])
    before = np.concatenate([depth0, depth0])
    ok = brick[up] & (slot[down] <= slot[up])
    up, down, before = up[ok], down[ok], before[ok]
    exact = prism[up] & prism[down]
    lowered = centre[up[exact]] - [0.0, 0.0, REST_TOLERANCE]
    after = penetration(lowered, axes[up[exact]], half[up[exact]], centre[down[exact]], axes[down[exact]], half[down[exact]])
    rests = after > np.maximum(before[exact], 0.0) + _EPS
    supports = list(zip(up[exact][rests].tolist(), down[exact][rests].tolist()))
    tilted = ~exact
    if tilted.any():
        supports += _tilted_supports(up[tilted], down[tilted], centre, half, axes)

    return overlaps, _floating(slot, grounded, supports)


def _floating(slot: np.ndarray, grounded: np.ndarray, supports: list[tuple[int, int]]) -> list[int]:
    """Bricks resting on nothing: not on the ground, a fixture or an earlier brick, nor on a
    brick of their own slot that rests on something (bricks placed together hold each other)."""
    held = grounded.copy()
    holds: dict[int, list[int]] = {}  # brick -> the bricks of its own slot resting on it
    for b, s in supports:
        if slot[s] < slot[b]:
            held[b] = True
        else:
            holds.setdefault(s, []).append(b)
    reached = [int(i) for i in np.flatnonzero(held)]
    while reached:
        for b in holds.get(reached.pop(), ()):
            if not held[b]:
                held[b] = True
                reached.append(b)
    order = sorted(np.flatnonzero((slot >= 0) & ~held), key=lambda i: (slot[i], i))
    return [int(i) for i in order]


def _candidates(low: np.ndarray, high: np.ndarray, gap: float) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Index pairs ``(a, b)`` whose bounding boxes come within ``gap`` of each other, in
    chunks: sweep and prune along the axis on which the bodies spread most."""
    n = len(low)
    axis = int(np.argmax(high.max(axis=0) - low.min(axis=0))) if n else 0
    order = np.argsort(low[:, axis], kind="stable")
    start = low[order, axis]
    end = np.searchsorted(start, high[order, axis] + gap, side="right")
    counts = np.maximum(end - np.arange(n) - 1, 0)
    total = np.cumsum(counts)
    cuts = np.searchsorted(total, np.arange(_CHUNK, int(total[-1]) if n else 0, _CHUNK), side="right")
    bounds = np.unique(np.concatenate([[0], cuts, [n]]))
    for first, last in itertools.pairwise(bounds):
        rows = np.repeat(np.arange(first, last), counts[first:last])
        steps = np.arange(len(rows)) - np.repeat(np.cumsum(counts[first:last]) - counts[first:last], counts[first:last])
        a, b = order[rows], order[rows + 1 + steps]
        close = ((low[a] <= high[b] + gap) & (low[b] <= high[a] + gap)).all(axis=1)
        yield a[close], b[close]


def penetration(ca: np.ndarray, ra: np.ndarray, ha: np.ndarray, cb: np.ndarray, rb: np.ndarray, hb: np.ndarray) -> np.ndarray:
    """Penetration depth of box pairs by the separating-axis test.

    Args:
        ca, cb: centres, shape (m, 3); ra, rb: rotation matrices, shape (m, 3, 3);
        ha, hb: half extents, shape (m, 3); metres.

    Returns:
        Shape (m,): the depth (m) when the boxes interpenetrate (exact: the shortest
        translation that separates them), else minus a lower bound of their distance.
    """
    if not len(ca):
        return np.zeros(0)
    crosses = np.cross(ra[:, :, :, None], rb[:, :, None, :], axis=1).reshape(len(ca), 3, 9)
    normals = np.concatenate([ra, rb, crosses], axis=2)  # (m, 3, 15): the candidate axes as columns
    length = np.sqrt((normals * normals).sum(axis=1))
    valid = length > 1e-6  # parallel edges give no axis
    normals = normals / np.where(valid, length, 1.0)[:, None, :]
    radius_a = (np.abs(np.swapaxes(ra, 1, 2) @ normals) * ha[:, :, None]).sum(axis=1)
    radius_b = (np.abs(np.swapaxes(rb, 1, 2) @ normals) * hb[:, :, None]).sum(axis=1)
    apart = np.abs(((cb - ca)[:, :, None] * normals).sum(axis=1))
    return np.asarray(np.where(valid, radius_a + radius_b - apart, np.inf).min(axis=1))


def _tilted_supports(
    up: np.ndarray, down: np.ndarray, centre: np.ndarray, half: np.ndarray, axes: np.ndarray
) -> list[tuple[int, int]]:
    """The pairs ``(brick, support)`` among the candidates where the brick rests on the
    support: lowered by the rest tolerance, the brick sinks deeper into the support
    (:func:`penetration`), and the two boxes then overlap below the brick's centre (the
    centroid of their intersection, a convex polytope, is lower than the centre).

    Args:
        up, down: shape (m,), indices of the brick and its candidate support.
        centre, half: shape (n, 3), metres; axes: shape (n, 3, 3), each body's axes as columns.
    """
    lowered = centre[up] - [0.0, 0.0, REST_TOLERANCE]
    before = penetration(centre[up], axes[up], half[up], centre[down], axes[down], half[down])
    after = penetration(lowered, axes[up], half[up], centre[down], axes[down], half[down])
    found = []
    for k in np.flatnonzero((after > _EPS) & (after > np.maximum(before, 0.0) + _EPS)):
        b, s = int(up[k]), int(down[k])
        middle = _overlap_centroid(lowered[k], axes[b], half[b], centre[s], axes[s], half[s])
        if middle is not None and middle[2] < lowered[k][2]:
            found.append((b, s))
    return found


def _box_halfspaces(centre: np.ndarray, axes: np.ndarray, half: np.ndarray) -> np.ndarray:
    """A box as 6 half-spaces ``[n, d]`` with ``n . x + d <= 0`` (scipy's convention)."""
    normals = np.concatenate([axes.T, -axes.T])  # (6, 3): outward face normals
    offsets = np.concatenate([half, half])
    return np.column_stack([normals, -(normals @ centre) - offsets])


def _overlap_centroid(
    ca: np.ndarray, ra: np.ndarray, ha: np.ndarray, cb: np.ndarray, rb: np.ndarray, hb: np.ndarray
) -> np.ndarray | None:
    """The centroid of the vertices of the intersection of two boxes (metres, shape (3,)), or
    None when they do not overlap with some thickness. The interior point scipy's
    ``HalfspaceIntersection`` needs is the centre of the largest ball inside both boxes
    (``linprog``, HiGHS)."""
    spaces = np.concatenate([_box_halfspaces(ca, ra, ha), _box_halfspaces(cb, rb, hb)])
    normals, offsets = spaces[:, :3], spaces[:, 3]
    norm = np.linalg.norm(normals, axis=1)
    # maximise r subject to n . x + r |n| <= -d
    ball = linprog([0.0, 0.0, 0.0, -1.0], A_ub=np.column_stack([normals, norm]), b_ub=-offsets, bounds=[(None, None)] * 4)
    if ball.status != 0 or ball.x[3] < 1e-9:
        return None
    try:
        vertices = HalfspaceIntersection(spaces, ball.x[:3]).intersections
    except QhullError:
        return None
    return np.asarray(vertices.mean(axis=0))


def touching(
    ca: np.ndarray,
    ra: np.ndarray,
    ha: np.ndarray,
    cb: np.ndarray,
    rb: np.ndarray,
    hb: np.ndarray,
    velocity: np.ndarray,
    deeper: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """When a box moving in a straight line touches each of some boxes at rest: the separating-axis
    test of :func:`penetration` with box ``a`` at ``ca + t * velocity``, exact for two boxes.

    Args:
        ca: shape (3,), box a's centre at t = 0; ra: its rotation (3, 3); ha: its half extents (3,).
        cb, rb, hb: the boxes at rest, shapes (m, 3), (m, 3, 3), (m, 3).
        velocity: shape (3,), how far box a moves per unit of t (a unit direction: t in metres).
        deeper: metres the boxes must interpenetrate to count (0: touching counts).

    Returns:
        Two arrays of shape (m,): the first and the last t >= 0 at which box a meets each box
        (``inf`` and ``-inf`` for one it never meets; the last is ``inf`` for one it never leaves).

    Source: stackdsl's own; the separating-axis test of moving boxes (Eberly, "Dynamic collision
    detection using oriented bounding boxes", Geometric Tools, 2002).

    >>> I, h = np.eye(3), np.array([0.06, 0.012, 0.004])
    >>> first, last = touching(np.array([-0.2, 0.0, 0.004]), I, h, np.array([[0.0, 0.0, 0.004]]), I[None], h[None], np.array([1.0, 0.0, 0.0]))
    >>> round(float(first[0]), 6), round(float(last[0]), 6)
    (0.08, 0.32)
    >>> touching(np.array([-0.2, 0.03, 0.004]), I, h, np.array([[0.0, 0.0, 0.004]]), I[None], h[None], np.array([1.0, 0.0, 0.0]))[0]
    array([inf])
    """
    m = len(cb)
    if not m:
        return np.zeros(0), np.zeros(0)
    ra_m = np.repeat(np.asarray(ra, dtype=float)[None], m, axis=0)
    crosses = np.cross(ra_m[:, :, :, None], rb[:, :, None, :], axis=1).reshape(m, 3, 9)
    normals = np.concatenate([ra_m, rb, crosses], axis=2)  # (m, 3, 15)
    length = np.sqrt((normals * normals).sum(axis=1))
    valid = length > 1e-6
    normals = normals / np.where(valid, length, 1.0)[:, None, :]
    radius = (np.abs(np.swapaxes(ra_m, 1, 2) @ normals) * np.asarray(ha, dtype=float)[None, :, None]).sum(axis=1)
    radius = radius + (np.abs(np.swapaxes(rb, 1, 2) @ normals) * hb[:, :, None]).sum(axis=1) - deeper
    apart = ((cb - np.asarray(ca, dtype=float)[None])[:, :, None] * normals).sum(axis=1)  # s(0), (m, 15)
    speed = (np.asarray(velocity, dtype=float)[None, :, None] * normals).sum(axis=1)  # s(t) = s(0) - t * speed
    moving = np.abs(speed) > 1e-12
    with np.errstate(divide="ignore", invalid="ignore"):
        one, two = (apart - radius) / speed, (apart + radius) / speed
    still_in = np.abs(apart) <= radius
    low = np.where(moving, np.minimum(one, two), np.where(still_in, -np.inf, np.inf))
    high = np.where(moving, np.maximum(one, two), np.where(still_in, np.inf, -np.inf))
    low, high = np.where(valid, low, -np.inf), np.where(valid, high, np.inf)
    first = np.maximum(low.max(axis=1), 0.0)
    last = high.min(axis=1)
    met = first <= last
    return np.where(met, first, np.inf), np.where(met, last, -np.inf)

"""A cheap proof that a stack falls: a part of it that can turn about an edge of its footing.

Livesley's kinematic theorem, one rigid mechanism at a time. Take a part of the stack and turn it
as one block about a horizontal axis along an edge of the convex hull of the contacts that hold
it (its footing), a little outside it. If its centre of mass goes down and every holding contact
opens (each point's velocity relative to the body across it lies in the dual of the friction
cone: separating at least ``mu`` times as fast as it slides), then the weight does positive
virtual work while every compressive, friction-bounded contact force does none or positive
work, so no such forces hold the part: it falls, and the linear program of
:mod:`stability._equilibrium` (whose friction pyramid lies inside the cone) would find the same.
The part is then a collapse mechanism.

The parts tried, from the lowest: each layer of blocks (centres of mass within :data:`LAYER` of
each other) with everything above it, and each block of a layer with everything above that
layer (one brick of a log cabin's level turning out from under the levels above, while its
sibling stays). The first that falls is returned. Source: stackdsl's own, after Livesley
(1978); the report's centre-of-mass-above test (report 3.3.5) is the single-file case of it.
"""

from __future__ import annotations

from collections.abc import Hashable, Iterator, Mapping, Sequence
from typing import TypeVar

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from ._equilibrium import ContactPolygon, RigidBlock, _vertices

BodyKey = TypeVar("BodyKey", bound=Hashable)

LAYER = 1e-3
"""Metres: blocks whose centres of mass are this close in height form one layer (a KAPLA brick is 8 mm thick)."""

CLEARANCE = 1e-5
"""Metres the centre of mass must pass beyond the axis, against rounding."""


def falling_part(blocks: Mapping[BodyKey, RigidBlock], contacts: Sequence[ContactPolygon[BodyKey]]) -> frozenset[BodyKey] | None:
    """The lowest part of the stack that provably falls, or None when no part tried does.

    Args:
        blocks: the free blocks by key (mass kg, centre of mass shape (3,) m); every other key
            a contact names is a support (it does not move).
        contacts: the contact polygons (``body`` rests on ``other``; points shape (k, 3), m;
            normal shape (3,) from ``other`` into ``body``; friction coefficient).

    Returns:
        The blocks of a collapse mechanism (they turn together); None when none of the parts
        tried falls (the stack may still fall: the equilibrium program decides).

    Raises:
        ValueError: a contact has no point.

    >>> import numpy as np
    >>> up = np.array([0, 0, 1.0])
    >>> def face(x0, x1, z):  # a contact polygon 24 mm wide
    ...     return np.array([[x0, -0.012, z], [x1, -0.012, z], [x1, 0.012, z], [x0, 0.012, z]])
    >>> bricks = {"low": RigidBlock(0.01, np.array([0, 0, 0.004])), "high": RigidBlock(0.01, np.array([0.07, 0, 0.012]))}
    >>> contacts = [ContactPolygon("low", "ground", face(-0.06, 0.06, 0), up, 0.5),
    ...             ContactPolygon("high", "low", face(0.01, 0.06, 0.008), up, 0.5)]
    >>> falling_part(bricks, contacts)
    frozenset({'high'})
    """
    keys = sorted(blocks, key=lambda k: float(blocks[k].com[2]))
    if not keys or not contacts:
        return None
    index = {k: i for i, k in enumerate(keys)}
    mass = np.array([blocks[k].mass for k in keys])
    com = np.array([np.asarray(blocks[k].com, dtype=float) for k in keys])
    points, owner = _vertices(contacts)
    normals = np.array([np.asarray(c.normal, dtype=float) / np.linalg.norm(c.normal) for c in contacts])[owner]
    friction = np.array([c.friction for c in contacts])[owner]
    body = np.array([index.get(c.body, -1) for c in contacts])[owner]
    other = np.array([index.get(c.other, -1) for c in contacts])[owner]
    for part in _parts(com[:, 2]):
        inside = np.append(part, False)  # a support (index -1) is never in the part
        holding = inside[body] != inside[other]
        if not holding.any():
            continue  # held by nothing: the caller's other tests see to it
        sign = np.where(inside[body[holding]], 1.0, -1.0)  # body's velocity minus other's
        centre = mass[part] @ com[part] / mass[part].sum()
        if _turns_out(centre, points[holding], normals[holding], friction[holding], sign):
            return frozenset(keys[i] for i in np.flatnonzero(part))
    return None


def _parts(heights: np.ndarray) -> Iterator[np.ndarray]:
    """Masks of the parts to try over blocks sorted by ``heights`` (m), lowest first: a layer
    with all above it, then each of its blocks with all above."""
    count = len(heights)
    starts = [i for i in range(count) if i == 0 or heights[i] - heights[i - 1] > LAYER]
    for first, end in zip(starts, [*starts[1:], count]):
        part = np.arange(count) >= first
        yield part
        if end - first > 1:
            for key in range(first, end):
                one = part.copy()
                one[first:end] = False
                one[key] = True
                yield one


def _turns_out(centre: np.ndarray, points: np.ndarray, normals: np.ndarray, friction: np.ndarray, sign: np.ndarray) -> bool:
    """Can a part with centre of mass ``centre`` (shape (3,), m) turn as one block about an edge
    of its footing, going down, while every contact point that holds it (``points`` shape (P, 3),
    m; unit ``normals`` (P, 3); ``friction`` (P,); ``sign`` (P,): +1 where the part is the
    contact's body, -1 where it is the other) opens?"""
    if _well_inside(centre[:2], points[:, :2]):
        return False
    for start, outward in _edges(points[:, :2]):
        reach = (centre[:2] - start) @ outward  # how far the centre of mass lies beyond the edge
        if reach <= CLEARANCE:
            continue
        inside = (start - points[:, :2]) @ outward  # >= 0: every point is on the footing's side
        for height in np.unique(np.round(points[inside < LAYER, 2], 4)):
            offset = max(0.0, float(np.max(friction * np.abs(points[:, 2] - height) - inside))) + 1e-7
            if reach - offset > CLEARANCE and _opens(points, normals, friction, sign, start, outward, offset, height):
                return True
    return False


def _well_inside(centre: np.ndarray, xy: np.ndarray) -> bool:
    """Is ``centre`` (shape (2,), m) inside the octagon of the points of ``xy`` (shape (P, 2))
    farthest along eight directions, by more than :data:`CLEARANCE`? That octagon lies in the
    hull, so then no edge of the hull has the centre beyond it (a quick test before the hull)."""
    corners = xy[np.argmax(xy @ _DIRECTIONS.T, axis=0)]  # counter-clockwise, some repeated
    sides = np.roll(corners, -1, axis=0) - corners
    length = np.linalg.norm(sides, axis=1)
    kept = length > 0
    if np.count_nonzero(kept) < 3:
        return False
    cross = sides[kept, 0] * (centre[1] - corners[kept, 1]) - sides[kept, 1] * (centre[0] - corners[kept, 0])
    return bool(np.all(cross > CLEARANCE * length[kept]))


_DIRECTIONS = np.array([[np.cos(a), np.sin(a)] for a in np.arange(8) * np.pi / 4])


def _edges(xy: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The edges of the convex hull of ``xy`` (shape (P, 2), m) as (a point of it, unit outward normal)."""
    try:
        hull = ConvexHull(xy)
    except (QhullError, ValueError):  # collinear or too few points: the segment's two sides
        reach = np.linalg.norm(xy - xy[0], axis=1)
        if reach.max() == 0:
            return []
        along = (xy[np.argmax(reach)] - xy[0]) / reach.max()
        normal = np.array([-along[1], along[0]])
        return [(xy[0], normal), (xy[0], -normal)]
    corners = xy[hull.vertices]  # counter-clockwise
    sides = np.roll(corners, -1, axis=0) - corners
    outward = np.column_stack([sides[:, 1], -sides[:, 0]]) / np.linalg.norm(sides, axis=1)[:, None]
    return list(zip(corners, outward))


def _opens(
    points: np.ndarray,
    normals: np.ndarray,
    friction: np.ndarray,
    sign: np.ndarray,
    start: np.ndarray,
    outward: np.ndarray,
    offset: float,
    height: float,
) -> bool:
    """Turning about the horizontal axis ``offset`` m beyond the edge through ``start`` (its
    outward normal ``outward``) at ``height`` m, outside down: does every point open, its
    relative velocity within the dual friction cone (normal part >= mu x tangential part)?"""
    axis = np.array([-outward[1], outward[0], 0.0])  # z x outward: points inside the edge rise
    pivot = np.array([*(start + offset * outward), height])
    velocity = sign[:, None] * np.cross(axis, points - pivot)
    normal_part = np.einsum("pd,pd->p", velocity, normals)
    sliding = np.linalg.norm(velocity - normal_part[:, None] * normals, axis=1)
    return bool(np.all(normal_part >= friction * sliding - 1e-12))

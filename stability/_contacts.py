"""Contact polygons of boxes at their poses, for rigid-block equilibrium without an engine.

Two boxes that lie face to face (within ``gap``) touch over the exact overlap of their faces
(:func:`stability.face_overlap`); a tilted box touches the ground and the faces of other boxes
with those of its corners that lie within ``gap`` of them (the corners on one body make one
polygon, on the largest face of that body they lie on: corners along its edge lie on two, and
a contact on each would widen the friction cone). Two tilted boxes that touch (the cards of an
inverted V) touch once: with the corners of the one whose corners lie on the other's face, the
first of them by key when both do (a contact each way would widen the cone too: an inverted V
past its friction angle stood). An edge of one tilted box against an edge of another makes no
contact here.

Source: stackdsl's own (as the oracle of stackdsl's verdicts finds them from a program's poses).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ._equilibrium import ContactPolygon
from ._geometry import Box, Plane, Pose, face_overlap
from ._leaning import pair_friction

#: A level box: one of its axes within 0.5 degrees of the vertical.
LEVEL = float(np.cos(np.radians(0.5)))
#: A box's axes lie along the world's when each entry of its rotation is within this of 0 or 1.
ALIGNED = 1e-9


@dataclass(frozen=True)
class PlacedBox:
    """A box at its pose: its key, shape (half extents in m, mass in kg), pose and material's
    friction coefficient."""

    key: int
    box: Box
    pose: Pose
    friction: float

    @cached_property
    def level(self) -> bool:
        """Whether one of its axes is vertical (its top and bottom faces are level)."""
        return bool(np.abs(self.pose.rotation[2]).max() >= LEVEL)

    @cached_property
    def aligned(self) -> tuple[float, float, float, float, float, float] | None:
        """Its bounds (x, y, z low, then high; m) when its axes lie along the world's (to
        :data:`ALIGNED`), else None: then its faces are the bounds' and meet in rectangles."""
        rotation = np.abs(self.pose.rotation)
        if not np.all((rotation < ALIGNED) | (rotation > 1.0 - ALIGNED)):
            return None
        half = rotation @ self.box.half_extents
        low, high = self.pose.position - half, self.pose.position + half
        return (*(float(v) for v in low), *(float(v) for v in high))  # type: ignore[return-value]


def contacts_of(
    body: PlacedBox, others: Sequence[PlacedBox], ground: int | None, ground_friction: float, gap: float
) -> list[ContactPolygon[int]]:
    """The contact polygons of ``body`` with the ground (key ``ground``, the plane z = 0; None:
    not asked) and ``others``, each with the normal into ``body``, lying on them (face to face)
    or with its corners on their faces (module docstring); ``gap``: metres.
    """
    if not body.level:
        return _corners(body, others, ground, ground_friction, gap)
    out = []
    mine = body.aligned
    if ground is not None:
        if mine is not None:  # a footprint on the plane z = 0
            on = _rectangle(mine, (mine[0], mine[1], 0.0, mine[3], mine[4], 0.0), gap)
            if on is not None:
                out.append(_polygon(body.key, ground, on, _UP, pair_friction(body.friction, ground_friction)))
        else:
            on_ground = face_overlap(body.box, body.pose, Plane(0.0), None, gap)
            if on_ground is not None and on_ground.area > 1e-9:
                friction = pair_friction(body.friction, ground_friction)
                out.append(_polygon(body.key, ground, on_ground.corners(), on_ground.normal, friction))
    for other in others:
        if not other.level:
            continue
        theirs = other.aligned
        if mine is not None and theirs is not None:  # two rectangles: what face_overlap finds, in floats
            on = _rectangle(mine, theirs, gap)
            if on is not None:
                out.append(_polygon(body.key, other.key, on, _UP, pair_friction(body.friction, other.friction)))
            continue
        area = face_overlap(body.box, body.pose, other.box, other.pose, gap)
        if area is not None and area.area > 1e-9:
            out.append(_polygon(body.key, other.key, area.corners(), area.normal, pair_friction(body.friction, other.friction)))
    return out


_UP = np.array([0.0, 0.0, 1.0])


def _rectangle(upper: tuple[float, ...], lower: tuple[float, ...], gap: float) -> np.ndarray | None:
    """Where the bottom face of box bounds ``upper`` lies on the top face of ``lower`` (bounds:
    x, y, z low, then high; m), within ``gap`` of it: the overlap's corners (4, 3) at the lower
    face's height, counter-clockwise from its lowest x and y; None when they do not touch so or
    overlap by 1e-9 m^2 or less (as :func:`stability.face_overlap` on two level faces)."""
    if abs(lower[5] - upper[2]) > gap:
        return None
    x0, y0, x1, y1 = max(upper[0], lower[0]), max(upper[1], lower[1]), min(upper[3], lower[3]), min(upper[4], lower[4])
    if x1 <= x0 or y1 <= y0 or (x1 - x0) * (y1 - y0) <= 1e-9:
        return None
    z = lower[5]
    return np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]])


def _polygon(body: int, other: int, points: np.ndarray, normal: np.ndarray, friction: float) -> ContactPolygon[int]:
    return ContactPolygon(body, other, np.asarray(points, dtype=float), np.asarray(normal, dtype=float), friction)


def _corners(
    body: PlacedBox, others: Sequence[PlacedBox], ground: int | None, ground_friction: float, gap: float
) -> list[ContactPolygon[int]]:
    """A tilted box's corners within ``gap`` of the ground, and of each face of another box
    (inside that face), one polygon per body touched."""
    corners = body.box.corners(body.pose)
    out = []
    low = corners[corners[:, 2] < gap]
    if len(low) and ground is not None:
        out.append(_polygon(body.key, ground, low, np.array([0.0, 0.0, 1.0]), pair_friction(body.friction, ground_friction)))
    for other in others:
        if not other.level and other.key < body.key and _on_faces(other.box.corners(other.pose), body, gap):
            continue  # the pair touches once: with the first one's corners
        faces = _on_faces(corners, other, gap)
        if faces:  # corners along an edge lie on two faces (and an end on three): the largest is touched
            on, normal, _ = max(faces, key=lambda f: f[2])
            out.append(_polygon(body.key, other.key, corners[on], normal, pair_friction(body.friction, other.friction)))
    return out


def _on_faces(corners: np.ndarray, other: PlacedBox, gap: float) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """For each face of ``other`` that some of ``corners`` (shape (8, 3), m) lie on (within
    ``gap``, inside the face): which corners (a mask), the face's outward normal and its area (m^2)."""
    local = (corners - other.pose.position) @ other.pose.rotation  # the corners in the other's frame
    half = other.box.half_extents
    inside = (np.abs(local) <= half + gap).all(axis=1)
    found = []
    for axis in range(3):
        for sign in (1.0, -1.0):
            on = (np.abs(local[:, axis] - sign * half[axis]) < gap) & inside
            if on.any():
                area = 4.0 * float(np.prod(np.delete(half, axis)))
                found.append((on, sign * other.pose.rotation[:, axis], area))
    return found

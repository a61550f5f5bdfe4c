"""A part placed off its support, caught in time by a brick placed on it (stackdsl's own).

A part (a brick and the bricks it carries) placed with its centre of mass ``d`` metres outside
its support polygon tips about the polygon's edge nearest that centre of mass. From rest, turned
by ``theta`` about that edge, with its centre of mass ``h`` above the edge and ``I`` its moment of
inertia about it, ``I theta'' = M g (d cos theta + h sin theta) <= M g (d + h theta)`` for
``theta >= 0``, so (:func:`tipped`)

    theta(t)  <= (d / h) (cosh(w t) - 1),    theta'(t) <= (d / h) w sinh(w t),    w^2 = M g h / I

(``h`` -> 0: ``d M g t^2 / (2 I)`` and ``d M g t / I``): bounds, as the real part turns slower.

A brick placed on the part ``t`` seconds later that brings the centre of mass of the part with it
inside the edge catches the part (:func:`caught`) when the part had not turned its farthest corner
the collapse threshold by then, even at that bound, and the spin left once the brick is on it
(the angular momentum about the edge kept, the brick brought at rest) cannot lift the new centre
of mass as high as it must go for that corner to move the threshold. The new part, turned back by
its weight, then stands where it was placed, as the engine's contacts hold it.

A counterweight set on a cantilever 0.1 s after it was placed 1 mm past its support's edge
catches it (a KAPLA brick turns about 2.3 deg by then, its far end 2.5 mm down of the 4 mm
threshold); 0.3 s after, or with the cantilever 0.2 mm out and the next brick 1 s later (a single
file stack), it does not.

>>> import numpy as np
>>> from shapely.geometry import box as rectangle
>>> from stability import Box, Pose
>>> kapla = Box(np.array([0.06, 0.012, 0.004]), 0.0106)
>>> under = rectangle(-0.06, -0.012, 0.06, 0.012)  # the top of the brick it lies on, z 8 mm
>>> arm = [(kapla, Pose(np.array([0.061, 0.0, 0.012])))]
>>> weight = (kapla, Pose(np.array([0.03, 0.0, 0.020])))
>>> caught(arm, [*arm, weight], under, 0.008, 0.1, 0.004, 9.81), caught(arm, [*arm, weight], under, 0.008, 0.3, 0.004, 9.81)
(True, False)

Source: stackdsl's own (rigid rotation about a support edge; report 3.3.3's support polygon).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from shapely.geometry import Point
from shapely.geometry.base import BaseGeometry
from shapely.ops import nearest_points

from stability import Box, Pose


@dataclass(frozen=True)
class Edge:
    """The edge a part tips over: a point of it ``at`` (shape (3,), m, at the height of the face
    the part was placed on), its direction ``along`` (shape (3,), horizontal unit) and the
    horizontal unit vector ``out`` away from the polygon (the way the part tips)."""

    at: np.ndarray
    along: np.ndarray
    out: np.ndarray


def edge_of(hull: BaseGeometry, com: np.ndarray, height: float) -> Edge | None:
    """The edge of the support polygon ``hull`` (shapely, horizontal, m) that a centre of mass
    ``com`` (shape (3,), m) outside it tips over, the face it rests on at ``height`` m; None when
    ``com`` is not outside it."""
    point = Point(float(com[0]), float(com[1]))
    if hull.is_empty or hull.contains(point):
        return None
    _, near = nearest_points(point, hull)
    out = np.array([point.x - near.x, point.y - near.y, 0.0])
    length = float(np.linalg.norm(out))
    if length <= 0.0:
        return None
    out /= length
    return Edge(np.array([near.x, near.y, height]), np.array([-out[1], out[0], 0.0]), out)


@dataclass(frozen=True)
class About:
    """A part about an edge: its mass ``mass`` (kg), moment of inertia ``inertia`` (kg m^2) about
    the edge, its centre of mass ``out`` m beyond the edge (negative: inside) and ``up`` m above
    it, and ``reach`` (m), the farthest a corner of it lies from the edge's line."""

    mass: float
    inertia: float
    out: float
    up: float
    reach: float


def about(bricks: Sequence[tuple[Box, Pose]], edge: Edge) -> About:
    """``bricks`` (each a box and its pose, as placed) as one rigid part about ``edge``
    (:class:`About`). Raises ValueError for no bricks."""
    if not bricks:
        raise ValueError("a part about an edge needs at least one brick")
    mass = inertia = reach = 0.0
    moment = np.zeros(3)
    for box, pose in bricks:
        a, b, c = (float(v) for v in box.half_extents)
        local = np.diag([b * b + c * c, a * a + c * c, a * a + b * b]) * box.mass / 3.0
        u = pose.rotation.T @ edge.along
        arm = np.asarray(pose.position, dtype=float) - edge.at
        across = arm - float(arm @ edge.along) * edge.along
        inertia += float(u @ local @ u) + box.mass * float(across @ across)
        mass += box.mass
        moment += box.mass * np.asarray(pose.position, dtype=float)
        corners = box.corners(pose) - edge.at
        corners -= np.outer(corners @ edge.along, edge.along)
        reach = max(reach, float(np.linalg.norm(corners, axis=1).max()))
    com = moment / mass - edge.at
    return About(mass, inertia, float(com @ edge.out), float(com[2]), reach)


def tipped(part: About, t: float, gravity: float) -> tuple[float, float]:
    """Upper bounds on the angle (rad) and angular speed (rad/s) ``part``, placed at rest with
    its centre of mass outside its edge (``part.out`` > 0), has turned about it ``t`` s later
    (the module's description), at ``gravity`` m/s^2."""
    torque = part.mass * gravity / part.inertia  # 1 / (m s^2) per metre of lever
    if part.up <= 1e-9:
        return 0.5 * part.out * torque * t * t, part.out * torque * t
    w = math.sqrt(torque * part.up)
    ratio = part.out / part.up
    return ratio * (math.cosh(w * t) - 1.0), ratio * w * math.sinh(w * t)


def caught(
    before: Sequence[tuple[Box, Pose]],
    after: Sequence[tuple[Box, Pose]],
    hull: BaseGeometry,
    height: float,
    t: float,
    threshold: float,
    gravity: float,
) -> bool:
    """Whether the part ``before`` (each brick's box and placed pose), placed with its centre of
    mass outside its support polygon ``hull`` (shapely, horizontal, m; the face it rests on at
    ``height`` m), is caught by the bricks that make it ``after`` (the same part with the bricks
    placed on it since), placed ``t`` s later: the module's description, with ``threshold`` (m)
    the collapse threshold and ``gravity`` m/s^2. False for a part ``before`` not outside."""
    mass = sum(box.mass for box, _ in before)
    com = np.sum([box.mass * np.asarray(pose.position, dtype=float) for box, pose in before], axis=0) / mass
    edge = edge_of(hull, com, height)
    if edge is None:
        return False
    first, then = about(before, edge), about(after, edge)
    if then.out >= 0.0:
        return False  # still outside (or on the edge): nothing caught
    reach = max(first.reach, then.reach)
    limit = 2.0 * math.asin(min(1.0, threshold / (2.0 * reach)))  # the turn that moves the farthest corner the threshold
    angle, spin = tipped(first, t, gravity)
    if angle >= limit:
        return False
    spin *= first.inertia / then.inertia  # the new bricks brought in at rest: angular momentum about the edge kept

    def height_at(turn: float) -> float:  # of the new centre of mass above the edge, turned outward by ``turn``
        return -then.out * math.sin(turn) + then.up * math.cos(turn)

    top = math.atan2(-then.out, then.up)  # where that centre of mass is over the edge
    if top <= angle:
        return False
    rise = height_at(min(top, limit)) - height_at(angle)
    return 0.5 * then.inertia * spin * spin < then.mass * gravity * rise

"""Leaning bricks (report 3.4): contact polygons across the contact normal, friction, balance.

The report tests a brick touching two bodies, at least one of them in the stack or
the ground: a pivot on the lowest contact, the torque of gravity about it (eq. 4),
the force that torque induces at the other contact, its normal part by projection on
the contact normal, Coulomb friction (eq. 12) and the force left for the pivot
(eq. 13); stable when friction can hold the sliding force at both contacts.

stackdsl solves exactly these balances, but asks whether *any* admissible split
exists, as a small rigid-block equilibrium program (:mod:`stability._equilibrium`),
instead of fixing one split in advance: the report's split fully mobilises friction at
the upper contact and lets the pivot take the rest, which declares a ladder on
mu = 0.5 stable at every angle (the false positives of its Figures 13-14), while the
closed forms are tan(theta) <= 2 mu1 / (1 - mu1 mu2) for a ladder and
tan(theta) <= 2 mu for a thin inverted V. Two bricks that lean on each other (a V) are
balanced together: tested one at a time, each would see the other as a fixed wall and
stand up to the ladder limit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import shapely

from ._equilibrium import GRAVITY, BodyKey, ContactPolygon, RigidBlock, is_level, solve_equilibrium
from ._geometry import needs_padding, padded_hull
from ._load_path import load_path, proven, support_piece


def pair_friction(a: float, b: float) -> float:
    """Friction coefficient of a pair of bodies with coefficients ``a`` and ``b``.

    Bullet multiplies the two bodies' values; stackdsl gives each body the square root
    of its material's coefficient, so a pair has the geometric mean (a pair of one
    material: exactly that material's coefficient). Source: stackdsl's own.

    Raises:
        ValueError: ``a`` or ``b`` is not a finite coefficient >= 0.

    >>> pair_friction(0.5, 0.5)
    0.5
    """
    if not (0.0 <= a < math.inf and 0.0 <= b < math.inf):
        raise ValueError(f"pair_friction takes two finite friction coefficients >= 0, not a={a!r}, b={b!r}")
    return math.sqrt(a * b)


def lean_polygon(points: np.ndarray, normal: np.ndarray, pad: float) -> np.ndarray:
    """ContactPolygon polygon in the plane across ``normal``, padded when it has no area (3.4.2).

    Args:
        points: shape (k, 3), metres, the engine's contact points of one pair.
        normal: shape (3,), unit.
        pad: metres, half-width of the padding (as :func:`padded_hull`).

    Returns:
        shape (m, 3), metres, the polygon's vertices.
    """
    return lean_polygon_padded(points, normal, pad)[0]


def lean_polygon_padded(points: np.ndarray, normal: np.ndarray, pad: float) -> tuple[np.ndarray, bool]:
    """:func:`lean_polygon`, and whether it was padded (the points had no area). Source: report 3.4.2."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    # the tangents as numpy's cross products compute them (the same products and differences,
    # in floats: a numpy call costs more than the arithmetic on three components)
    nx, ny, nz = (float(v) for v in np.asarray(normal, dtype=float).reshape(3))
    ex, ey, ez = (1.0, 0.0, 0.0) if abs(nx) < 0.9 else (0.0, 1.0, 0.0)
    t1 = np.array([ny * ez - nz * ey, nz * ex - nx * ez, nx * ey - ny * ex])
    t1 /= np.linalg.norm(t1)
    ax, ay, az = t1.tolist()
    t2 = np.array([ny * az - nz * ay, nz * ax - nx * az, nx * ay - ny * ax])
    origin = points.mean(axis=0)
    uv = np.column_stack([(points - origin) @ t1, (points - origin) @ t2])
    ring = shapely.get_coordinates(padded_hull(uv, pad))[:-1]  # the exterior's: a hull has no hole
    polygon: np.ndarray = origin + ring[:, :1] * t1 + ring[:, 1:] * t2
    return polygon, needs_padding(shapely.convex_hull(shapely.multipoints(uv)), pad)


def leaning_stands(
    members: Mapping[BodyKey, tuple[np.ndarray, float]], contacts: Sequence[ContactPolygon[BodyKey]], gravity: float = GRAVITY
) -> bool:
    """Can friction hold a leaning brick, or two leaning on each other, where they are?

    Args:
        members: brick -> (centre of mass shape (3,) in metres, mass in kg).
        contacts: every contact of the members, the one between two members once.
        gravity: m/s^2.

    Returns:
        True when the members balance (report 3.4.3, solved as :func:`stability.solve_equilibrium`).
        A single brick whose centre of mass lies over the hull of its level contacts stands
        without a program: vertical forces at their vertices hold it (:mod:`stability._load_path`).
    """
    if len(members) == 1:
        ((com, _),) = members.values()
        level = [support_piece(c.points, None, ground=True) for c in contacts if is_level(c)]
        if proven(com, load_path([p for p in level if p is not None])):
            return True
    return solve_equilibrium({m: RigidBlock(mass, com) for m, (com, mass) in members.items()}, contacts, gravity=gravity).stands

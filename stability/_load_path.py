"""Two sufficient tests of rigid-block equilibrium, far cheaper than its program: load paths
to the ground (one freeze's cost), and the report's propagated loads checked as forces.

A frozen brick ``b`` has a *load path* ``P(b)``: the part of its support through which
any vertical load on it can be passed down to the ground by compressive vertical forces.
It is the convex hull of the pieces of its level support contacts that lie over its
supports' own load paths (the whole contact for the ground or a fixed body):

    P(b) = hull( U_s  C(b, s) ∩ P(s) )

``b`` is *proven* when its centre of mass lies over ``P(b)``. When every frozen brick is
proven, the stack stands: by induction from the top, each brick's resultant load (its
weight at its centre of mass, and the forces of the bricks on it, which they put at points
of ``C(a, b) ∩ P(b)``) lies over ``P(b)`` because ``P(b)`` is convex, so it splits into
compressive forces at points of the pieces ``C(b, s) ∩ P(s)``, which lie over the
supports' load paths in turn. Vertical forces on a contact tilted by less than the
friction pyramid's reach are held by friction (:func:`stability.is_level`). These forces
are a solution of the equilibrium program of :mod:`stability._equilibrium` with zero
tension, so it would say the same (Livesley's lower-bound theorem: any statically
admissible set of forces proves that the blocks stand).

``P(b)`` depends only on ``b``'s own contacts and its supports' paths, all fixed once
``b`` freezes, so the test is made once per freeze. It is sufficient, not necessary: a
slanted tower whose upper bricks reach beyond the lower bricks' paths is balanced by the
weights above them, which only the full program sees. The extension solves the full
program whenever some frozen brick is not proven.

The second test reads the loads of the report's propagation (report 3.3.5-3.3.6,
:func:`stability._load.propagate_fast`) as forces: each brick passes its share of the load
above to each support at a point of the contact. When every share pushes down (>= 0) at a
point inside the hull of the level contact polygons between the brick and that support
(:func:`share_region`), and the shares of every brick sum to its load above with their
resultant under its centre of mass above, those forces balance every brick, so the stack
stands (:func:`loads_balance`). It holds a slanted tower whose upper bricks reach beyond the lower
bricks' paths, since it carries each brick's load with the weights above it, and it costs one
pass down the stack. When it fails (a share clipped to its contact, or a lever outside its
supports), only the program can tell.

Source: stackdsl's own, from the lower-bound theorem of limit analysis for rigid blocks
(Livesley, "Limit analysis of structures formed from rigid blocks", 1978).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from ._geometry import hull_of_union, hull_xy

MARGIN = 1e-5
"""Metres a share's point must lie inside its contact (:func:`loads_balance`), so that a point on
the edge, where the program's own tolerances decide, is left to the program."""

BALANCE = 1e-9
"""Relative error allowed in a brick's balance of shares (:func:`loads_balance`): rounding only."""

Loads = Mapping[int, tuple[tuple[float, float, float], float, Sequence[tuple[int, float, float, float]]]]
"""The report's propagated loads: brick -> (centre of mass above (m), mass above (kg), shares
as (support, kg, x, y)), as :func:`stability._load.propagate_fast` returns them."""


def load_path(pieces: Sequence[BaseGeometry]) -> BaseGeometry | None:
    """The convex hull of the pieces (shapely geometries, metres, horizontal projection),
    or None when there is none or all are empty."""
    kept = [p for p in pieces if not p.is_empty]
    if not kept:
        return None
    return hull_of_union(kept)


def support_piece(
    contact_points: np.ndarray, support_path: BaseGeometry | None, ground: bool, hull: BaseGeometry | None = None
) -> BaseGeometry | None:
    """The piece of a level support contact that lies over the support's load path.

    Args:
        contact_points: shape (k, 3) or (k, 2), metres, the contact polygon's vertices.
        support_path: the support's load path (:func:`load_path`); ignored for the ground.
        ground: the support is the ground or a fixed body: the whole contact is usable.
        hull: the convex hull of the vertices' horizontal projection (shapely), when it is
            known already; else found from ``contact_points``.

    Returns:
        The piece (shapely, horizontal projection), or None when nothing of it is usable
        (an unproven support, or no overlap).
    """
    if hull is None:
        hull = hull_xy(np.asarray(contact_points, dtype=float)[:, :2])
    if ground:
        return hull
    if support_path is None:
        return None
    piece = hull.intersection(support_path)
    return None if piece.is_empty else piece


def proven(com: Sequence[float] | np.ndarray, path: BaseGeometry | None) -> bool:
    """Does the centre of mass (shape (3,) or (2,), metres) lie over the load path (its edge
    included)?

    >>> from shapely.geometry import box
    >>> proven([0.0, 0.0, 0.004], box(-0.06, -0.012, 0.06, 0.012)), proven([0.07, 0.0], box(-0.06, -0.012, 0.06, 0.012))
    (True, False)
    """
    if path is None:
        return False
    # a point is covered where it meets the path: the same exact predicate, without making a Point
    return bool(shapely.intersects_xy(path, float(com[0]), float(com[1])))


def share_region(contact_points: Sequence[np.ndarray]) -> BaseGeometry | None:
    """Where a brick may push down on one support: the convex hull of its level contact
    polygons with it (each shape (k, 3), metres; horizontal projection), shrunk by
    :data:`MARGIN`. None when nothing is left (a contact thinner than twice the margin).

    >>> import numpy as np
    >>> region = share_region([np.array([[0, 0, 0], [0.02, 0, 0], [0.02, 0.024, 0], [0, 0.024, 0]])])
    >>> round(region.area * 1e6, 1)  # mm^2: 19.98 x 23.98
    479.1
    """
    hull = shapely.convex_hull(shapely.multipoints(np.vstack([np.asarray(p, dtype=float)[:, :2] for p in contact_points])))
    region = hull.buffer(-MARGIN)
    return None if region.is_empty else region


def loads_balance(loads: Loads, regions: Mapping[int, Mapping[int, BaseGeometry]]) -> bool:
    """Are the report's propagated loads a set of compressive vertical forces that balances
    every brick (module docstring)? Then the bricks stand.

    Args:
        loads: the propagated loads of every free brick (:data:`Loads`).
        regions: brick -> support -> :func:`share_region` of their level contacts; a support
            missing here takes no share.

    >>> import numpy as np
    >>> from shapely.geometry import box
    >>> on_ground = {1: {0: box(-0.06, -0.012, 0.06, 0.012)}}  # brick 1 on body 0
    >>> loads_balance({1: ((0.01, 0.0, 0.004), 0.01, [(0, 0.01, 0.01, 0.0)])}, on_ground)
    True
    >>> loads_balance({1: ((0.07, 0.0, 0.004), 0.01, [(0, 0.01, 0.06, 0.0)])}, on_ground)  # clipped to the edge
    False
    """
    for brick, ((x, y, _), mass, shares) in loads.items():
        supports = regions.get(brick, {})
        total = moment_x = moment_y = 0.0
        for support, m, px, py in shares:
            if m == 0.0:
                continue
            region = supports.get(support)
            if m < 0.0 or region is None or not shapely.contains_xy(region, px, py):
                return False
            total, moment_x, moment_y = total + m, moment_x + m * px, moment_y + m * py
        tolerance = BALANCE * mass
        if abs(total - mass) > tolerance or math.hypot(moment_x - mass * x, moment_y - mass * y) > tolerance:
            return False
    return True

"""Load paths to the ground: a sufficient test of rigid-block equilibrium that costs one
freeze, not the whole stack.

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

Source: stackdsl's own, from the lower-bound theorem of limit analysis for rigid blocks
(Livesley, "Limit analysis of structures formed from rigid blocks", 1978).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from shapely import MultiPoint, Point, unary_union
from shapely.geometry.base import BaseGeometry


def load_path(pieces: Sequence[BaseGeometry]) -> BaseGeometry | None:
    """The convex hull of the pieces (shapely geometries, metres, horizontal projection),
    or None when there is none or all are empty."""
    kept = [p for p in pieces if not p.is_empty]
    if not kept:
        return None
    return unary_union(kept).convex_hull


def support_piece(contact_points: np.ndarray, support_path: BaseGeometry | None, ground: bool) -> BaseGeometry | None:
    """The piece of a level support contact that lies over the support's load path.

    Args:
        contact_points: shape (k, 3) or (k, 2), metres, the contact polygon's vertices.
        support_path: the support's load path (:func:`load_path`); ignored for the ground.
        ground: the support is the ground or a fixed body: the whole contact is usable.

    Returns:
        The piece (shapely, horizontal projection), or None when nothing of it is usable
        (an unproven support, or no overlap).
    """
    hull = MultiPoint(np.asarray(contact_points, dtype=float)[:, :2].tolist()).convex_hull
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
    return bool(path.covers(Point(float(com[0]), float(com[1]))))

"""The margin of a standing structure: how far every centre of mass can move together,
horizontally, in any direction, before no contact forces balance the blocks.

Moving every block's centre of mass by one horizontal vector ``d`` changes only the torque
rows of the equilibrium program (:mod:`stability._equilibrium`), by ``d x (0, 0, -weight)``
for each block, so the rows are affine in ``d``: the shifts for which the program has a
solution are the projection onto ``d`` of the polyhedron ``{(forces, d)}``, a convex polygon
``S``, which holds 0 when the blocks stand as they are. The margin is the distance from 0 to
the edge of ``S``: the radius of the largest disc about 0 inside it, the least over every
direction of how far the centres of mass can go that way. A search along a few directions
gives only an upper bound of it: a support polygon whose corner points the weak way (a
brick on a square turned 45 deg) reads its corner's distance, ``sqrt(2)`` times the edge's.

One program finds the polygon's edge along a direction ``u``: the largest ``t`` for which
``t u`` balances (the shift is then one more unknown, a column ``t``). Every point found lies
on the edge, so the hull of the points found lies inside ``S``, and the distance from 0 to the
hull's nearest edge is a *lower* bound of the margin; the distance of every point found is an
*upper* bound. The search starts along x and y (+x first: whether the blocks stand at all) and
then asks along the outward normal of the hull's nearest edge: when that edge lies on an edge
of ``S``, the point found is the foot of the perpendicular from 0 and the two bounds meet (the
margin is exact); otherwise the new point moves the hull out there. The answer is the lower
bound, once the upper one is within :data:`MARGIN_TOLERANCE` of it: never more than the
margin, and at most the tolerance less. A brick on a rectangle needs four to ten programs.

Where the level contacts hold the blocks the vertical-force program on them alone is searched
(ten times smaller; its shifts are some of the full program's: a contact left out, a brick's
side against its neighbour's, only adds forces), and then one program with friction, on
the blocks whose rows bind the weakest direction (the dual solution names them; every other
body a support: a relaxation, so it bounds the whole program's reach from above), says
whether friction reaches further that way. Only when it does is the full program's polygon
searched, from the points already found (which it holds too): two posts braced by a plank's
friction on their tops.

Source: stackdsl's own, on the equilibrium program of Livesley (1978) and Whiting et al.
(2009); bounding a convex set between the hull of points on its edge and what they say of it
is the sandwich method (Rote, "The convergence rate of the sandwich algorithm for
approximating convex functions", Computing 48, 1992).
"""

from __future__ import annotations

from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import shapely
from scipy import sparse
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient

from ._equilibrium import (
    GRAVITY,
    BodyKey,
    ContactPolygon,
    RigidBlock,
    _balance,
    _cat,
    _ends,
    _generators,
    _vertices,
    is_level,
    upward,
)
from ._lp import OPTIMAL, LinearProgram, Solution

MARGIN_TOLERANCE = 1e-4
"""Metres: the margin is found to within this, from below (the search stops when its upper
bound is this close to its lower bound, which it reports)."""

MARGIN_PROGRAMS = 40
"""Programs the search may solve; beyond them the lower bound found so far is the answer (a
margin never more than the true one, but maybe further below it than the tolerance)."""

_SCALE = 0.1  # metres: lever arms in units of 10 cm, as the equilibrium program's rows
#: The first directions asked: +x (whether the blocks stand at all), -x, +y and -y.
FIRST = (np.array([1.0, 0.0]), np.array([-1.0, 0.0]), np.array([0.0, 1.0]), np.array([0.0, -1.0]))


def equilibrium_margin(
    blocks: Mapping[BodyKey, RigidBlock],
    contacts: Sequence[ContactPolygon[BodyKey]],
    *,
    limit: float = 0.02,
    sides: int = 8,
    gravity: float = GRAVITY,
    tolerance: float = MARGIN_TOLERANCE,
) -> float | None:
    """How far every centre of mass can move together, horizontally and in any direction,
    before no compressive, friction-bounded contact forces balance the blocks (the program of
    :func:`stability.solve_equilibrium`, its friction pyramid of ``sides`` sides, no tension):
    metres, at most ``limit``; never more than the true distance and at most ``tolerance``
    less than it (module docstring). None when the blocks do not stand as they are (then
    :func:`stability.solve_equilibrium` gives the mechanism).

    The vertical-force program (:func:`stability.solve_equilibrium`'s quick test) on the level
    contacts alone is searched first: its shifts are some of the full program's (a contact
    that is not level, a brick's side against its neighbour's, only adds forces), so its
    margin is a lower bound; the full program along its weakest direction, on the blocks that
    direction binds, then bounds the full margin from above, and only when the two are further
    apart than ``tolerance`` is the full program's polygon searched, from the points already
    found. Source: stackdsl's own, on the program of Livesley (1978) and Whiting et al. (2009).

    Raises:
        ValueError: a contact has no point, ``limit`` <= 0, ``tolerance`` <= 0 or ``sides`` < 3.
            (A negative friction coefficient or mass is refused where the contact or the block
            is made: :class:`ContactPolygon`, :class:`RigidBlock`.)

    >>> import numpy as np
    >>> ground = ContactPolygon("brick", "ground", np.array([[-0.06, -0.012, 0], [0.06, -0.012, 0],
    ...     [0.06, 0.012, 0], [-0.06, 0.012, 0]]), np.array([0, 0, 1.0]), 0.5)
    >>> round(equilibrium_margin({"brick": RigidBlock(0.0106, np.array([0, 0, 0.004]))}, [ground]) * 1000, 3)  # mm
    12.0
    >>> equilibrium_margin({"brick": RigidBlock(0.0106, np.array([0.07, 0, 0.004]))}, [ground]) is None
    True
    >>> square = ContactPolygon("brick", "post", np.array([[0.01, 0, 0], [0, 0.01, 0], [-0.01, 0, 0],
    ...     [0, -0.01, 0]]), np.array([0, 0, 1.0]), 0.5)  # a square post turned 45 deg
    >>> round(equilibrium_margin({"brick": RigidBlock(0.0106, np.array([0, 0, 0.004]))}, [square]) * 1000, 2)
    7.07
    """
    if not limit > 0 or not tolerance > 0:
        raise ValueError(f"equilibrium_margin needs a positive limit and tolerance, not {limit!r} and {tolerance!r}")
    if sides < 3:
        raise ValueError(f"sides: the friction pyramid needs at least 3 sides, not {sides!r}")
    if not blocks:
        return limit
    if not contacts:
        return None
    level = [c for c in map(upward, contacts) if is_level(c, sides)]
    if level:
        vertical = _ShiftProgram.of(blocks, level, sides, gravity, level=True, limit=limit)
        search = _Search.start(vertical, tolerance)
        if search is not None:
            search.run(MARGIN_PROGRAMS)
            if search.upper - search.lower > tolerance:  # out of programs: the lower bound stands
                return search.lower
            # the full program's reach along the weakest side, on the blocks that side holds
            held = vertical.binding(search.normal)
            part = {k: b for k, b in blocks.items() if k in held} or dict(blocks)
            near = [c for c in contacts if c.body in part or c.other in part]
            bound = _ShiftProgram.of(part, near, sides, gravity, level=False, limit=limit)
            upper = bound.reach(search.normal)
            if upper is not None and upper - search.lower <= tolerance:
                return search.lower
            full = (
                bound
                if len(part) == len(blocks)
                else _ShiftProgram.of(blocks, contacts, sides, gravity, level=False, limit=limit)
            )
            # friction may hold more than vertical forces: on from the points found, which it holds too
            search = _Search(full, tolerance, search.points, limit if upper is None else upper)
            search.ask(search.normal)
            search.run(MARGIN_PROGRAMS)
            return search.lower
    full = _ShiftProgram.of(blocks, contacts, sides, gravity, level=False, limit=limit)
    search = _Search.start(full, tolerance)
    if search is None:
        return None
    search.run(MARGIN_PROGRAMS)
    return search.lower


@dataclass(frozen=True)
class _ShiftProgram:
    """The equilibrium program with the common shift ``d`` of every centre of mass as two more
    unknowns: ``a x + shift d = rhs``, ``0 <= x <= upper``, ``-limit <= d <= limit`` (metres)."""

    a: sparse.csr_matrix
    shift: np.ndarray  # (rows, 2): the torque rows' change per metre of d_x and of d_y
    rhs: np.ndarray
    upper: np.ndarray  # per force column: 0 for a tension (none allowed), else inf
    limit: float
    keys: tuple[Hashable, ...]  # the blocks, in the order of their rows
    _program: list[LinearProgram] = field(default_factory=list, compare=False, repr=False)  # HiGHS's, once made

    @classmethod
    def of(
        cls,
        blocks: Mapping[BodyKey, RigidBlock],
        contacts: Sequence[ContactPolygon[BodyKey]],
        sides: int,
        gravity: float,
        *,
        level: bool,
        limit: float,
    ) -> _ShiftProgram:
        """The vertical-force program (``level``: three rows a block, one force a vertex) or
        the full one (six rows a block, the pyramid's edges and a tension a vertex)."""
        keys = list(blocks)
        index = {k: i for i, k in enumerate(keys)}
        weight = max(b.mass for b in blocks.values()) * gravity or 1.0
        points, owner = _vertices(contacts)
        if level:
            rows: list[np.ndarray] = []
            cols: list[np.ndarray] = []
            vals: list[np.ndarray] = []
            for side, block, com in _ends(contacts, blocks, index, owner):
                free = np.flatnonzero(block >= 0)
                lever = (points[free] - com[free]) / _SCALE
                rows += [3 * block[free], 3 * block[free] + 1, 3 * block[free] + 2]
                cols += [free] * 3
                vals += [np.full(len(free), side), side * lever[:, 1], -side * lever[:, 0]]  # Fz, Mx = y Fz, My = -x Fz
            a = sparse.csr_matrix((_cat(vals), (_cat(rows), _cat(cols))), shape=(3 * len(keys), len(owner)))
            per_block, vertical, torque_x = 3, 0, 1
            upper = np.full(a.shape[1], np.inf)
        else:
            generators = _generators(contacts, blocks, sides, points, owner)
            a = _balance(contacts, blocks, index, generators, points, owner)
            per_block, vertical, torque_x = 6, 2, 3
            upper = np.where(np.arange(a.shape[1]) % (1 + sides) == 0, 0.0, np.inf)  # no tension
        rhs = np.zeros(per_block * len(keys))
        shift = np.zeros((per_block * len(keys), 2))
        for key, b in blocks.items():
            row = per_block * index[key]
            rhs[row + vertical] = b.mass * gravity / weight
            # the weight moved by d turns about the old centre of mass by d x (0, 0, -W) =
            # W (-d_y, d_x, 0), which the contact forces must balance: they carry W (d_y, -d_x)
            load = b.mass * gravity / weight / _SCALE
            shift[row + torque_x, 1] = -load
            shift[row + torque_x + 1, 0] = load
        return cls(a, shift, rhs, upper, limit, tuple(keys))

    def _reach(self, direction: np.ndarray) -> Solution | None:
        """The program that moves every centre of mass by ``t direction`` (unit, shape (2,))
        and maximises ``t``, from 0 to ``limit`` (one column more); None when it has no
        solution (not even at 0: the blocks do not stand). One HiGHS program serves every
        direction: only the column ``t`` changes, and each solve starts from the last basis
        (:class:`stability._lp.LinearProgram`)."""
        column = self.shift @ np.asarray(direction, dtype=float)
        n = self.a.shape[1]
        if not self._program:
            cost = np.zeros(n + 1)
            cost[-1] = -1.0
            a = sparse.hstack([self.a, sparse.csr_matrix(column[:, None])])
            self._program.append(LinearProgram(cost, a, self.rhs, upper=np.append(self.upper, self.limit)))
        else:
            rows = np.flatnonzero(self.shift.any(axis=1))
            self._program[0].set_column(n, rows, column[rows])
        result = self._program[0].solve()
        return result if result.status == OPTIMAL else None

    def reach(self, direction: np.ndarray) -> float | None:
        """Metres, how far every centre of mass can move together along the unit ``direction``
        (shape (2,)) and be balanced, at most ``limit``: the polygon of shifts' edge that way;
        None when the blocks do not stand as they are."""
        result = self._reach(direction)
        return None if result is None else min(float(result.x[-1]), self.limit)

    def binding(self, direction: np.ndarray) -> list[Hashable]:
        """The blocks whose rows bind the reach along the unit ``direction``: those with a dual
        value (the program's marginals) above 1e-9 of the largest; every block when HiGHS
        finds no answer. The full program on them alone, every other body a support (a
        relaxation: its shifts hold the whole program's), bounds the reach from above, and
        that bound is the same reach when friction adds nothing: the dual solution, zero on the
        other blocks' rows, still proves it (Livesley's mechanism, in the shift's terms)."""
        result = self._reach(direction)
        if result is None:
            return list(self.keys)
        duals = np.abs(result.eq_duals).reshape(len(self.keys), -1).max(axis=1)
        top = float(duals.max(initial=0.0))
        return [k for k, y in zip(self.keys, duals.tolist(), strict=True) if not top > 0 or y > 1e-9 * top]


class _Search:
    """The sandwich of the polygon of shifts about 0 (module docstring): ``points`` found on
    its edge (their hull inside it), ``lower`` the distance from 0 to the hull's nearest edge,
    whose outward normal is ``normal``, and ``upper`` the least distance of a point found (both
    metres)."""

    def __init__(self, program: _ShiftProgram, tolerance: float, points: list[np.ndarray], upper: float) -> None:
        self.program, self.tolerance, self.points, self.upper = program, tolerance, list(points), upper
        self.asked = 0
        self.lower, self.normal = 0.0, np.array([1.0, 0.0])
        self._hull()

    @classmethod
    def start(cls, program: _ShiftProgram, tolerance: float) -> _Search | None:
        """The search from the reaches along :data:`FIRST`; None when the blocks do not stand as
        they are (the first program says so, and no other is solved)."""
        search = cls(program, tolerance, [], program.limit)
        for direction in FIRST:
            if not search.ask(direction) and not search.points:
                return None
        return search

    def ask(self, direction: np.ndarray) -> bool:
        """Add the edge's point along the unit ``direction`` (False: HiGHS found none)."""
        self.asked += 1
        found = self.program.reach(direction)
        if found is None:
            return False
        self.points.append(found * np.asarray(direction, dtype=float))
        self.upper = min(self.upper, found)
        self._hull()
        return True

    def run(self, budget: int) -> None:
        """Ask along the nearest edge's normal until the bounds meet (or ``budget`` programs,
        counting those asked already)."""
        while self.upper - self.lower > self.tolerance and self.asked < budget:
            if not self.ask(self.normal):  # HiGHS's failure: the lower bound found so far stands
                return

    def _hull(self) -> None:
        """The hull's nearest edge to 0: its distance (``lower``, 0 when 0 is not inside) and
        outward unit normal (``normal``)."""
        if not self.points:
            return
        hull = shapely.convex_hull(shapely.multipoints(np.array(self.points, dtype=float)))
        if isinstance(hull, Polygon):
            ring = np.asarray(orient(hull, 1.0).exterior.coords, dtype=float)  # counter-clockwise
        else:  # a segment (both its sides) or a point (no side: the bounds have met at 0)
            line = np.asarray(hull.coords, dtype=float)
            ring = np.vstack([line, line[::-1]]) if len(line) > 1 else line
        edges = np.diff(ring, axis=0)
        lengths = np.hypot(edges[:, 0], edges[:, 1])
        keep = lengths > 0
        if not keep.any():
            self.lower = 0.0
            return
        normals = np.column_stack([edges[keep, 1], -edges[keep, 0]]) / lengths[keep, None]  # outward
        offsets = np.einsum("ij,ij->i", normals, ring[:-1][keep])
        nearest = int(np.argmin(offsets))
        self.lower = max(0.0, float(offsets[nearest]))
        self.normal = normals[nearest]

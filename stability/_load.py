"""Centre of mass above and mass above, propagated down the brick graph (report 3.3.5-3.3.6).

Every brick carries its own weight plus a share of every brick resting on it. The
share a brick A passes to one of its supports b follows the report:

* A rests on b alone: all of A's mass above, at A's centre of mass above
  (single branch, equations 1 and 2);
* A rests on exactly two supports: the torque split of equations 3 to 11, wherever A's centre
  of mass above lies between the two points where the shares act;
* A's centre of mass above lies beyond those points (or, with more than two supports, where
  no shares of them balance it) and over one support's individual contact area: that support
  carries everything, the others nothing (merging branching, first case). The report applies
  this case wherever the centre lies over one area; stackdsl only where no split balances, so
  that the shares are continuous in the placement (a centre over a joint between two supports
  puts half on each, whichever side of the joint the engine left it: docs/design.md);
* A rests on more than two: equal shares (merging branching, second case), or, where equal
  shares cannot balance A's centre of mass above at points of the contact areas, the
  shares nearest to equal that do (stackdsl's own: :func:`split_load`).

Departure from the report (see docs/design.md, where the code departs from the report): equation 10 adds the equivalent
mass at A's centre of mass above. Taken literally every lower brick of a 4 stack fails
at level 2 (A's centre lies between its two supports, outside each of them). stackdsl
applies each merging share at a point of the A-b contact area, chosen so that the
shares' resultant passes through A's centre of mass above (:func:`split_load`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Iterable, Mapping
from dataclasses import dataclass
from graphlib import CycleError

import numpy as np
from shapely.geometry import Point
from shapely.ops import nearest_points

from ._geometry import ContactArea
from ._lp import OPTIMAL, solve


@dataclass(frozen=True)
class LoadNode:
    """A brick as the load propagation sees it.

    Attributes:
        mass: kilograms.
        com: shape (3,), metres, the brick's own centre of mass.
        supports: support body -> contact area through which this brick rests on it.
            Supports that are not nodes themselves (the ground) take load but pass none.

    Source: report Figure 3 (restOn, SingleContactArea).
    """

    mass: float
    com: np.ndarray
    supports: Mapping[int, ContactArea]


@dataclass(frozen=True)
class Load:
    """Result for one brick (report Figure 3: COMAbove, massAbove).

    Attributes:
        com_above: shape (3,), metres, centre of mass of the brick and its share of
            everything above it.
        mass_above: kilograms, the brick's mass plus the equivalent mass it carries.
        shares: support body -> fraction (0..1) of ``mass_above`` passed to it.
    """

    com_above: np.ndarray
    mass_above: float
    shares: dict[int, float]


def propagate(nodes: Mapping[int, LoadNode], memo: Splits | None = None) -> dict[int, Load]:
    """Compute ``com_above``/``mass_above`` of every node, top of the stack first.

    Args:
        nodes: body -> :class:`LoadNode`. ``supports`` must form no cycle.
        memo: the splits of an earlier call, kept by the caller (:func:`propagate_fast`'s):
            the same answer, bit for bit, with only the loads that changed split again.

    Returns:
        body -> :class:`Load`.

    Raises:
        graphlib.CycleError: when bricks rest on each other in a cycle.

    Source: report 3.3.5 (equations 1-2) and 3.3.6 (equations 3-11).

    >>> import numpy as np
    >>> from shapely.geometry import box
    >>> from stability import ContactArea
    >>> ground = ContactArea(box(-0.06, -0.012, 0.06, 0.012), 0.0, np.array([0, 0, 1.0]), True)
    >>> on_a = ContactArea(box(-0.06, -0.012, 0.06, 0.012), 0.008, np.array([0, 0, 1.0]), True)
    >>> loads = propagate({1: LoadNode(0.01, np.array([0, 0, 0.004]), {0: ground}),
    ...                    2: LoadNode(0.01, np.array([0.03, 0, 0.012]), {1: on_a})})
    >>> round(loads[1].mass_above, 3), round(float(loads[1].com_above[0]), 3)
    (0.02, 0.015)
    """
    return {
        b: Load(np.array(com), mass, {s: m / mass for s, m, _, _ in shares})
        for b, (com, mass, shares) in propagate_fast(nodes, memo).items()
    }


Shares = list[tuple[int, float, float, float]]
"""How a brick's load divides among its supports: (support, equivalent mass in kg, x, y in m) each."""

Splits = dict[int, tuple[LoadNode, float, float, float, Shares]]
"""The last split of each brick's load (:func:`propagate_fast`'s ``memo``): body -> (its node,
the x, y (m) and mass (kg) of its load above, the shares)."""


Loads = dict[int, tuple[tuple[float, float, float], float, Shares]]
""":func:`propagate_fast`'s answer: body -> ((x, y, z) of the centre of mass above in m, mass
above in kg, its shares)."""


def propagate_fast(nodes: Mapping[int, LoadNode], memo: Splits | None = None) -> Loads:
    """:func:`propagate` in plain floats, for the extension's stack test at every freeze.

    ``memo``: the splits of an earlier call, kept by the caller and updated here: a brick whose
    node is the same object and whose load above is the same, to the bit, as in the memo keeps
    its shares (the split is a function of these alone), so that a stack test after a change
    far from most of the stack splits only the loads that changed. A node's supports must not
    change in place while it is in the memo. The shares' lists may be shared between calls:
    read them only.

    Returns:
        body -> ((x, y, z) of the centre of mass above in m, mass above in kg, shares as
        a list of (support, equivalent mass in kg, x, y)).
    """
    # what each brick carries, summed: mass and its moments about the origin (x, y, z)
    carried: dict[int, list[float]] = {b: [0.0, 0.0, 0.0, 0.0] for b in nodes}
    loads = {}
    for b in _top_down(nodes):
        load = loads[b] = _carrying(b, nodes[b], carried[b], memo)
        _pass_down(load, carried)
    return loads


def _carrying(b: int, node: LoadNode, c: list[float], memo: Splits | None) -> tuple[tuple[float, float, float], float, Shares]:
    """The load of brick ``b`` (its ``node``) with what it carries (``c``: mass, and its moments
    about the origin, summed), and its split among its supports, from ``memo`` when the same."""
    m0 = node.mass
    x0, y0, z0 = node.com.tolist()
    mass = m0 + c[0]
    x, y, z = (m0 * x0 + c[1]) / mass, (m0 * y0 + c[2]) / mass, (m0 * z0 + c[3]) / mass  # eq. 1-2
    kept = memo.get(b) if memo is not None else None
    if kept is not None and kept[0] is node and kept[1] == x and kept[2] == y and kept[3] == mass:
        shares = kept[4]
    else:
        shares = _split(x, y, mass, node.supports)
        if memo is not None:
            memo[b] = (node, x, y, mass, shares)
    return (x, y, z), mass, shares


def _pass_down(load: tuple[tuple[float, float, float], float, Shares], carried: dict[int, list[float]]) -> None:
    """Add a brick's shares (its ``load``'s) to what each of its supports in ``carried`` carries."""
    z = load[0][2]
    for s, m, px, py in load[2]:
        if s in carried and m:
            t = carried[s]
            t[0] += m
            t[1] += m * px
            t[2] += m * py
            t[3] += m * z


def propagate_part(
    nodes: Mapping[int, LoadNode],
    part: Collection[int],
    kept: Loads,
    uppers: Callable[[int], Iterable[int]],
    position: Callable[[int], int],
    memo: Splits | None = None,
) -> Loads | None:
    """:func:`propagate_fast` of the bricks of ``part`` alone, the loads of every other brick
    being ``kept``: those of an earlier call, which nothing has changed since (no brick above
    them, nor their own node). ``part`` must hold every node under one it holds (the bricks a
    change can reach down the supports); the loads of the others pass into it through their
    kept shares.

    Args:
        nodes: body -> :class:`LoadNode` of at least every brick of ``part``.
        part: the bricks whose loads to find.
        kept: body -> load of the bricks outside ``part`` that rest on one of it.
        uppers: the bricks whose nodes rest on a brick of ``part`` (a superset does: the others
            are left out), in any order.
        position: a brick's place in the order of :func:`propagate_fast`'s ``nodes`` (a brick
            after its supports), so that each load is summed in the order a full call sums it.
        memo: as :func:`propagate_fast`'s.

    Returns:
        body -> load of each brick of ``part``, as :func:`propagate_fast` gives it; None when
        a brick resting on one of ``part`` has no kept load, or when the bricks of ``part`` do
        not come after their supports in ``position``'s order (then :func:`propagate_fast`
        of every node is the answer).

    Source: report 3.3.5-3.3.6, as :func:`propagate_fast`; propagating only what changed is
    stackdsl's own.
    """
    outside: set[int] = set()
    for s in part:
        for a in uppers(s):
            if a not in part and a in nodes and s in nodes[a].supports:
                if a not in kept:
                    return None
                outside.add(a)
    carried: dict[int, list[float]] = {b: [0.0, 0.0, 0.0, 0.0] for b in part}
    loads: Loads = {}
    for b in sorted((*part, *outside), key=position, reverse=True):  # the reverse of the nodes' order, as propagate_fast
        if b in outside:
            _pass_down(kept[b], carried)
            continue
        node = nodes[b]
        if any(s in loads for s in node.supports):
            return None  # a support found before it (after it in the nodes' order): propagate_fast sorts such nodes
        load = loads[b] = _carrying(b, node, carried[b], memo)
        _pass_down(load, carried)
    return loads


def _top_down(nodes: Mapping[int, LoadNode]) -> list[int]:
    """The nodes, each after every node resting on it. When every node comes after its
    supports already (the order bricks are frozen in), that order reversed; otherwise a
    topological sort."""
    seen: set[int] = set()
    for b, node in nodes.items():
        if any(s in nodes and s not in seen for s in node.supports):
            break
        seen.add(b)
    else:
        return list(nodes)[::-1]
    above: dict[int, list[int]] = {b: [] for b in nodes}
    for a, node in nodes.items():
        for s in node.supports:
            if s in above:
                above[s].append(a)
    return _static_order(above)


def _static_order(above: dict[int, list[int]]) -> list[int]:
    """``list(graphlib.TopologicalSorter(above).static_order())``, node for node (``above``: each
    node's predecessors, the bricks resting on it), without its search for a cycle before the
    sort: a cycle shows as nodes never ready. The same order, so that the loads are summed in
    the same order, bit for bit; at 120 dominoes the search was a third of the sort's cost.
    Raises graphlib.CycleError for a cycle. Source: Python's graphlib (Kahn's algorithm)."""
    waiting: dict[int, int] = {}  # node -> predecessors not yet passed out, in graphlib's order of nodes
    successors: dict[int, list[int]] = {}
    for node, predecessors in above.items():
        waiting[node] = waiting.get(node, 0) + len(predecessors)
        successors.setdefault(node, [])
        for p in predecessors:
            waiting.setdefault(p, 0)
            successors.setdefault(p, []).append(node)
    ready = [n for n, k in waiting.items() if k == 0]
    order: list[int] = []
    while ready:
        order += ready
        after: list[int] = []
        for n in ready:
            for s in successors[n]:
                waiting[s] -= 1
                if waiting[s] == 0:
                    after.append(s)
        ready = after
    if len(order) < len(waiting):
        raise CycleError("nodes are in a cycle")
    return order


def split_load(
    com_above: np.ndarray, mass_above: float, supports: Mapping[int, ContactArea]
) -> dict[int, tuple[float, np.ndarray]]:
    """How a brick's load divides among its supports (report 3.3.6).

    The shares' points of application are chosen so that their resultant passes
    through ``com_above``: for two supports both contact-area centres are moved by the
    same offset, perpendicular to the line joining them, until the centre of mass lies
    on that line (the lever rule of equations 3-9 then acts along it); for more than two
    all centres are moved by the offset that puts their mean under the centre of mass.
    A point outside its contact area is brought back to the area's nearest point: a
    contact pushes only where the bodies touch (this matters only for a brick that is
    failing itself, whose centre of mass above has left its support).
    (stackdsl's own choice: the report's equation 10 puts every share at the centre of
    mass, which fails a 4 stack at level 2; centres alone lose the overturning moment,
    so a slanted tower never fails.)

    Args:
        com_above: shape (3,), metres.
        mass_above: kilograms.
        supports: support body -> contact area (convex).

    Returns:
        support body -> ``(equivalent mass in kg, point of application shape (3,))``;
        the point lies over the contact area, at the height of ``com_above`` (so that
        the centre of mass above keeps the true height of the load, report 3.6.2).
    """
    shares = _split(float(com_above[0]), float(com_above[1]), mass_above, supports)
    return {s: (m, np.array([px, py, float(com_above[2])])) for s, m, px, py in shares}


def _split(x: float, y: float, mass: float, supports: Mapping[int, ContactArea]) -> Shares:
    """:func:`split_load` in plain floats: (support, mass, x, y) for each support."""
    if not supports:
        return []
    if len(supports) == 1:
        ((s, area),) = supports.items()
        return [(s, mass, *_inside(area, x, y))]
    centres = [a.centre_xy for a in supports.values()]
    if len(supports) == 2:
        (ax, ay), (bx, by) = centres
        ux, uy, rx, ry = bx - ax, by - ay, x - ax, y - ay
        joining2 = ux * ux + uy * uy
        # two areas with one centre (two bricks crossed at the same centre): no line joins them,
        # both centres move by the offset that puts them under the centre of mass
        along = 0.0 if joining2 <= 1e-24 else (rx * ux + ry * uy) / joining2
        dx, dy = rx - along * ux, ry - along * uy
    else:
        dx = x - sum(c[0] for c in centres) / len(centres)
        dy = y - sum(c[1] for c in centres) / len(centres)
    points = [_inside(a, cx + dx, cy + dy) for a, (cx, cy) in zip(supports.values(), centres)]
    if len(supports) > 2:
        fractions = _balanced(points, x, y)
        if fractions is None:
            # no shares of the points balance the load: all of it on the support under it, or
            # equal shares (report 3.3.6) for a failing brick, whose centre of mass is over none
            return _all_on_one(x, y, mass, supports, points) or [(s, mass / len(points), *p) for s, p in zip(supports, points)]
        return [(s, mass * f, *p) for s, f, p in zip(supports, fractions, points)]
    (s1, s2), (p1, p2) = tuple(supports), points
    ux, uy = p2[0] - p1[0], p2[1] - p1[1]
    length2 = ux * ux + uy * uy
    # the lever rule along the line joining the two points, the centre of mass taken where it
    # projects onto it: shares that sum to the mass even where a point was brought back into its
    # area. The shares are continuous in the placement: a brick whose centre lies over a joint
    # between two supports puts half on each whichever side of it the engine left it.
    t = 0.5 if length2 <= 1e-24 else ((x - p1[0]) * ux + (y - p1[1]) * uy) / length2
    if 0.0 <= t <= 1.0:
        return [(s1, mass * (1.0 - t), *p1), (s2, mass * t, *p2)]
    # beyond both points: on the support under it, or all on the nearer (a failing brick)
    nearer = 0.0 if t < 0.0 else 1.0
    return _all_on_one(x, y, mass, supports, points) or [(s1, mass * (1.0 - nearer), *p1), (s2, mass * nearer, *p2)]


def _all_on_one(
    x: float, y: float, mass: float, supports: Mapping[int, ContactArea], points: list[tuple[float, float]]
) -> list[tuple[int, float, float, float]] | None:
    """The whole load at the centre of mass (x, y), on the support whose area lies under it
    (report 3.3.6, merging branching, first case; the nearest point's where several do); None
    where no area does.
    """
    over = [i for i, area in enumerate(supports.values()) if area.holds(x, y, strict=False)]
    if not over:
        return None
    chosen = min(over, key=lambda i: math.hypot(points[i][0] - x, points[i][1] - y))
    return [(s, mass, x, y) if i == chosen else (s, 0.0, *p) for i, (s, p) in enumerate(zip(supports, points))]


def _balanced(points: list[tuple[float, float]], x: float, y: float) -> list[float] | None:
    """Fractions of a load at (x, y) for more than two supports at ``points``: equal (report
    3.3.6) when their mean lies under the load, as it does unless a point was brought back into
    its area; else the fractions nearest to equal (least total change, HiGHS) whose resultant
    passes through (x, y), so that the shares balance the load's moment. A plank on three piers
    with its load 28.6 mm from the middle one read a third each, whose resultant lay 20 mm from
    it. None when no shares balance it (the load outside the points' hull).
    Source: report 3.3.6 for the equal shares; stackdsl's own otherwise."""
    n = len(points)
    mx, my = sum(p[0] for p in points) / n, sum(p[1] for p in points) / n
    equal = [1.0 / n] * n
    if math.hypot(mx - x, my - y) <= 1e-9:
        return equal
    px, py = [p[0] for p in points], [p[1] for p in points]
    # the change from equal shares as u - v (u, v >= 0): sums to 0, moves the resultant from
    # the mean of the points to (x, y), leaves no share below 0; least sum of |change|
    a_eq = np.array([[1.0] * n + [-1.0] * n, px + [-v for v in px], py + [-v for v in py]])
    a_ub = np.hstack([-np.eye(n), np.eye(n)])
    result = solve(np.ones(2 * n), a_eq, np.array([0.0, x - mx, y - my]), a_ub=a_ub, b_ub=np.array(equal))
    if result.status != OPTIMAL:
        return None
    change = result.x[:n] - result.x[n:]
    return [max(0.0, 1.0 / n + float(c)) for c in change]


def _inside(area: ContactArea, x: float, y: float) -> tuple[float, float]:
    """(x, y) if it lies over ``area``, else the nearest point of the area."""
    if area.holds(x, y, strict=False):
        return x, y
    _, nearest = nearest_points(Point(x, y), area.polygon)
    return nearest.x, nearest.y


def _lever(x: float, y: float, mass: float, at: tuple[float, float], pivot: tuple[float, float]) -> float:
    """:func:`torque_split` in plain floats."""
    lever = math.hypot(at[0] - pivot[0], at[1] - pivot[1])
    if lever <= 1e-12:
        return 0.5 * mass
    return min(max(mass * math.hypot(x - pivot[0], y - pivot[1]) / lever, 0.0), mass)


def torque_split(com_above: np.ndarray, mass_above: float, at: np.ndarray, pivot: np.ndarray) -> float:
    """Equivalent mass carried at ``at`` when the load turns about ``pivot`` (eq. 3-9).

    Gravity turns the load about a pivot on the *other* support: torque =
    (COM_above - pivot) x m g (eq. 4). The force that balances it at this support's
    point is |torque| / (|at - pivot| sin theta) (eq. 6), theta the angle between that
    lever and gravity, and the equivalent mass is |force| / |g| (eq. 9). With gravity
    vertical, |r x m g| = m |g| |r_h| and |r| sin theta = |r_h| (r_h the horizontal part
    of r), so g cancels and this is the lever rule, computed so. The report takes as pivot
    the other support's contact point closest to the centre of mass and measures to the
    centre of this support's area; stackdsl takes the points through which the two shares
    pass (:func:`split_load`), which is the same for point contacts and keeps the two shares
    summing to the load. Clipped to [0, mass_above].

    Args:
        com_above: shape (3,), metres.
        mass_above: kilograms.
        at: shape (3,), metres.
        pivot: shape (3,), metres.

    Returns:
        kilograms.

    >>> import numpy as np
    >>> round(torque_split(np.array([0.25, 0, 0.1]), 1.0, np.array([1.0, 0, 0]), np.zeros(3)), 3)
    0.25
    """
    # |r| sin(theta) of eq. 6 is |at - pivot| horizontally; |torque| / (m g) of eq. 4 is
    # |com - pivot| horizontally; their ratio times the mass is eq. 9.
    return _lever(float(com_above[0]), float(com_above[1]), mass_above, (at[0], at[1]), (pivot[0], pivot[1]))

"""Centre of mass above and mass above, propagated down the brick graph (report 3.3.5-3.3.6).

Every brick carries its own weight plus a share of every brick resting on it. The
share a brick A passes to one of its supports b follows the report:

* A rests on b alone: all of A's mass above, at A's centre of mass above
  (single branch, equations 1 and 2);
* A rests on several supports and its centre of mass above lies over one support's
  individual contact area: that support carries everything, the others nothing
  (merging branching, first case);
* A rests on exactly two supports: the torque split of equations 3 to 11;
* A rests on more than two: equal shares (merging branching, second case).

Departure from the report (see README, design notes): equation 10 adds the equivalent
mass at A's centre of mass above. Taken literally every lower brick of a 4 stack fails
at level 2 (A's centre lies between its two supports, outside each of them). stackdsl
applies each merging share at a point of the A-b contact area, chosen so that the
shares' resultant passes through A's centre of mass above (:func:`split_load`).
"""

from __future__ import annotations

from dataclasses import dataclass
from graphlib import TopologicalSorter
from typing import Mapping

import numpy as np

from shapely.geometry import Point
from shapely.ops import nearest_points

from ._geometry import ContactArea, contains


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


def propagate(nodes: Mapping[int, LoadNode]) -> dict[int, Load]:
    """Compute ``com_above``/``mass_above`` of every node, top of the stack first.

    Args:
        nodes: body -> :class:`LoadNode`. ``supports`` must form no cycle.

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
    above: dict[int, list[int]] = {b: [] for b in nodes}
    for a, node in nodes.items():
        for s in node.supports:
            if s in above:
                above[s].append(a)
    carried: dict[int, list[tuple[float, np.ndarray]]] = {b: [] for b in nodes}
    loads: dict[int, Load] = {}
    for b in TopologicalSorter(above).static_order():
        node = nodes[b]
        mass = node.mass + sum(m for m, _ in carried[b])
        moment = node.mass * node.com + sum((m * p for m, p in carried[b]), np.zeros(3))
        com_above = moment / mass
        split = split_load(com_above, mass, node.supports)
        loads[b] = Load(com_above, mass, {s: m / mass for s, (m, _) in split.items()})
        for s, share in split.items():
            if s in carried:
                carried[s].append(share)
    return loads


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
        supports: support body -> contact area.

    Returns:
        support body -> ``(equivalent mass in kg, point of application shape (3,))``;
        the point lies over the contact area, at the height of ``com_above`` (so that
        the centre of mass above keeps the true height of the load, report 3.6.2).
    """
    split = _split(com_above, mass_above, supports)
    return {s: (m, np.array([p[0], p[1], com_above[2]])) for s, (m, p) in split.items()}


def _split(
    com_above: np.ndarray, mass_above: float, supports: Mapping[int, ContactArea]
) -> dict[int, tuple[float, np.ndarray]]:
    if not supports:
        return {}
    if len(supports) == 1:
        (s, area), = supports.items()
        return {s: (mass_above, _inside(area, com_above))}
    over = [s for s, area in supports.items() if contains(area.polygon, com_above)]
    if over:
        s = min(over, key=lambda k: np.linalg.norm(supports[k].centre[:2] - com_above[:2]))
        return {k: ((mass_above, com_above) if k == s else (0.0, supports[k].centre)) for k in supports}
    centres = np.array([a.centre for a in supports.values()])
    if len(supports) == 2:
        axis = centres[1, :2] - centres[0, :2]
        rel = com_above[:2] - centres[0, :2]
        offset = rel - axis * (rel @ axis) / (axis @ axis)
    else:
        offset = com_above[:2] - centres[:, :2].mean(axis=0)
    points = {
        s: _inside(area, centre + np.array([offset[0], offset[1], 0.0]))
        for (s, area), centre in zip(supports.items(), centres)
    }
    if len(supports) > 2:
        equal = mass_above / len(supports)
        return {s: (equal, points[s]) for s in supports}
    first, second = supports
    return {
        first: (torque_split(com_above, mass_above, points[first], points[second]), points[first]),
        second: (torque_split(com_above, mass_above, points[second], points[first]), points[second]),
    }


def _inside(area: ContactArea, point: np.ndarray) -> np.ndarray:
    """``point`` if it lies over ``area``, else the nearest point of the area."""
    if area.polygon.intersects(Point(point[0], point[1])):
        return point
    _, nearest = nearest_points(Point(point[0], point[1]), area.polygon)
    return np.array([nearest.x, nearest.y, point[2]])


def torque_split(com_above: np.ndarray, mass_above: float, at: np.ndarray, pivot: np.ndarray) -> float:
    """Equivalent mass carried at ``at`` when the load turns about ``pivot`` (eq. 3-9).

    Gravity turns the load about a pivot on the *other* support: torque =
    (COM_above - pivot) x m g (eq. 4). The force that balances it at this support's
    point is |torque| / (|at - pivot| sin theta) (eq. 6), theta the angle between that
    lever and gravity, and the equivalent mass is |force| / |g| (eq. 9). With gravity
    vertical, |r| sin theta is the horizontal length of r, so g cancels: this is the
    lever rule. The report takes as pivot the other support's contact point closest to
    the centre of mass and measures to the centre of this support's area; stackdsl takes
    the points through which the two shares pass (:func:`split_load`), which is the same
    for point contacts and keeps the two shares summing to the load. Clipped to
    [0, mass_above].

    Args:
        com_above, at, pivot: shape (3,), metres.
        mass_above: kilograms.

    Returns:
        kilograms.

    >>> import numpy as np
    >>> round(torque_split(np.array([0.25, 0, 0.1]), 1.0, np.array([1.0, 0, 0]), np.zeros(3)), 3)
    0.25
    """
    gravity = np.array([0.0, 0.0, -mass_above])  # m g with |g| = 1: it cancels in eq. 6-9
    torque = np.cross(com_above - pivot, gravity)  # eq. 4
    lever = at - pivot
    lever_h = np.linalg.norm(np.cross(lever, gravity)) / mass_above  # |r| sin(theta)
    if lever_h <= 1e-12:
        return 0.5 * mass_above
    force = np.linalg.norm(torque) / lever_h  # eq. 6
    return float(np.clip(force, 0.0, mass_above))  # eq. 9 with |g| = 1

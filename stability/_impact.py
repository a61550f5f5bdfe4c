"""Impacts (report 3.6): the impactor's kinetic energy against the hit part's potential energy.

A body moving faster than the rest threshold that is about to touch a frozen brick
either breaks it loose or not: if its kinetic energy exceeds the potential energy of
the hit brick and the stack above it, measured from the centre of the brick's main
contact area to its centre of mass above, that brick and everything above it wake and
the engine simulates the blow; otherwise the stack holds and the engine handles the
impactor alone (against immovable bricks). Threshold-based, as the report's.

The report's barrier is the energy to lift the part off its base. An upright part turns
over the edge of its base long before it is lifted: by default the barrier is the lesser of
the two (:func:`tipping_energy` about the edge of the part's support polygon that the blow
turns it over, :func:`_footprint`, ``StabilityConfig.impact_energy``), so that no blow that
topples a domino, a post or a column, or one straight down on a cantilever's tip, is held;
and the blow is passed down to what the hit brick rests on: the part each frozen brick under
it carries is weighed too, tipped over its polygon's edge (:meth:`Impacts._barrier`), so that
a blow on the top of a stack of flush bricks overhanging a table's edge topples the stack;
and where the report's barrier is nothing (a fallen brick lying tilted, its centre of mass
below the contact it rests on) the tipping energy is the barrier, so that a touch at 0.01 m/s does not wake a fallen domino row brick by brick. A body a hand
drives (one a pusher or a pulled brick touches) into the side of a frozen brick breaks it loose
whatever its own energy: the hand's weight is behind it (stackdsl's own).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np
import shapely
from shapely.geometry import Point, Polygon
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient
from shapely.ops import unary_union

from ._engine import ContactPoint
from ._equilibrium import GRAVITY
from ._geometry import Box, Pose, box_bounds, moved_at_most
from ._graph import BrickState
from ._stack import Record, StabilityEvent, Stack
from ._stack_test import StackTest


def kinetic_energy(mass: float, speed: float, angular_speed: float = 0.0, moment: float = 0.0) -> float:
    """Joules of a body of ``mass`` kg whose centre of mass moves at ``speed`` m/s, turning at
    ``angular_speed`` rad/s about an axis through it of moment of inertia at most ``moment``
    kg m^2 (report 3.6.2, with the turn's share by Koenig's theorem: a domino toppling about its
    foot brings a third more than its centre's speed gives). Raises ValueError on a mass that
    is not a finite number > 0.

    >>> kinetic_energy(0.0106, 1.0)
    0.0053
    """
    if not (math.isfinite(mass) and mass > 0.0):
        raise ValueError(f"mass must be a finite number of kg > 0, got {mass!r}")
    return 0.5 * mass * speed * speed + 0.5 * moment * angular_speed * angular_speed


def potential_energy(mass_above: float, com_above_z: float, base_z: float, gravity: float = GRAVITY) -> float:
    """Joules to lift the hit brick and the stack above it from its base (report 3.6.2).

    Args:
        mass_above: kg, the hit brick's mass above.
        com_above_z: m, height of its centre of mass above.
        base_z: m, height of the centre of its main contact area.
        gravity: m/s^2.
    """
    return mass_above * gravity * max(com_above_z - base_z, 0.0)


def tipping_energy(
    mass_above: float,
    com_above: np.ndarray,
    area: Polygon,
    base_z: float,
    heading: np.ndarray,
    gravity: float = GRAVITY,
    point: np.ndarray | None = None,
    edges: Edges | None = None,
) -> float:
    """Joules to tip the hit part over the edge of its contact ``area`` that a blow along
    ``heading`` struck at ``point`` turns it over: its centre of mass above, ``h`` over the base
    and ``d`` from that edge, rises from ``h`` to ``sqrt(d^2 + h^2)`` as the part turns about the
    edge until it is over it, and past that its weight turns it on. The energy barrier of a
    rocking block (Housner, "The behavior of inverted pendulum structures during earthquakes",
    Bull. Seismol. Soc. Am. 53(2), 1963): a domino needs a few microjoules, where lifting it
    needs millijoules.

    Which edge (stackdsl's own, :func:`_tipping_edge`): the blow's line meets the base's plane at
    a point ``Q`` (far off along the heading for a horizontal blow); a blow whose line passes
    outside the support polygon turns the part toward ``Q`` about the polygon's edge between its
    centre of mass and ``Q``, and one whose line meets the base inside the polygon turns it over
    no edge (it presses the part on its base). A horizontal blow turns it over the edge ahead of
    its centre of mass along the heading (a domino, a post); a vertical one on a cantilever's tip
    over the edge it sticks out past. ``d`` is the centre of mass's distance to that edge's line,
    across it (Housner's).

    Args:
        mass_above: kg; com_above: shape (3,), m; area: the main contact area's horizontal
            outline (shapely, m); base_z: m, its height; heading: shape (2,) or (3,), the blow's
            direction (a 2-vector is horizontal); gravity: m/s^2; point: shape (3,), m, where
            the blow lands on the part (None: level with the centre of mass, which for a
            horizontal blow changes nothing); edges: :func:`edges_of` ``area``, when found
            already.

    Returns the lifting energy (:func:`potential_energy`) when the blow turns the part over no
    edge of ``area`` (a blow straight down inside the polygon, one with no moment about the
    edges); a part whose centre of mass is outside ``area`` is not tipped over it (0 to go).
    """
    h = max(float(com_above[2]) - base_z, 0.0)
    lift = potential_energy(mass_above, float(com_above[2]), base_z, gravity)
    blow = np.zeros(3)
    blow[: len(heading)] = np.asarray(heading, dtype=float)[:3]
    struck = np.asarray(com_above if point is None else point, dtype=float)
    edge = _tipping_edge(np.asarray(com_above, dtype=float), area, base_z, blow, struck, edges)
    if edge is None:
        return lift
    return mass_above * gravity * (math.hypot(edge, h) - h)


Edges = list[tuple[np.ndarray, np.ndarray, np.ndarray]]
"""A convex polygon's edges, counterclockwise: a point of each (shape (2,), m), its direction
and its outward normal (unit, shape (2,) each)."""


def edges_of(area: Polygon) -> Edges:
    """The edges of the convex polygon ``area`` (:data:`Edges`), none shorter than 1e-12 m.
    Source: stackdsl's own.

    >>> from shapely.geometry import box
    >>> [tuple(float(v) + 0.0 for v in n) for _, _, n in edges_of(box(0.0, 0.0, 0.12, 0.024))]
    [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)]
    """
    ring = np.asarray(orient(area, 1.0).exterior.coords, dtype=float)[:, :2]
    edges: Edges = []
    for a, b in itertools.pairwise(ring):
        length = float(np.linalg.norm(b - a))
        if length < 1e-12:
            continue
        e = (b - a) / length
        edges.append((a, e, np.array([e[1], -e[0]])))  # outward: the ring runs counterclockwise
    return edges


def _tipping_edge(
    com: np.ndarray, area: Polygon, base_z: float, heading: np.ndarray, point: np.ndarray, edges: Edges | None = None
) -> float | None:
    """The distance (m) from the centre of mass ``com`` to the line of the edge of the convex
    polygon ``area`` (at height ``base_z``) that a blow along ``heading`` at ``point`` turns the
    part over, or None when it turns it over none (stackdsl's own).

    The blow's angular impulse about the foot of the centre of mass on the base plane,
    ``(point - foot) x heading``, leans the part toward ``w = r_z heading_xy - heading_z
    (point - com)_xy`` (``r_z`` the point's height over the base), which is the direction from
    the centre of mass to where the blow's line meets the base plane (ahead along the heading
    for a horizontal blow). The edge is the one the ray from the centre of mass along ``w``
    leaves the polygon by: of the edges whose outward normal has a part along ``w``, the least
    ``d / (w . n)`` (the least barrier measured along the lean; an edge nearly along the lean,
    whose moment a heading off by a hair would make positive, never wins). The part turns over
    it when the blow's moment about that edge's line, ``((point - a) x heading) . e`` with ``a``
    on the edge and ``e`` along it (counterclockwise, so that a positive turn lifts the inside),
    is positive: the blow's line passes outside the edge. None for a centre of mass outside
    ``area``, a degenerate ``area`` or no lean. ``edges``: :func:`edges_of` ``area``, when
    found already."""
    if not isinstance(area, Polygon) or area.is_empty or area.area <= 0.0:
        return None
    x, y = float(com[0]), float(com[1])
    if not area.contains(Point(x, y)):
        return None
    r_z = float(point[2]) - base_z
    lean = r_z * heading[:2] - heading[2] * (point[:2] - com[:2])
    norm = float(np.linalg.norm(lean))
    if norm < 1e-12:
        return None
    lean = lean / norm
    best: tuple[float, float, np.ndarray, np.ndarray] | None = None  # (along the lean, across, a, e)
    for a, e, n in edges_of(area) if edges is None else edges:
        facing = float(lean @ n)
        if facing <= 1e-12:
            continue
        across = float((a - com[:2]) @ n)
        along = across / facing
        if best is None or along < best[0]:
            best = (along, across, a, e)
    if best is None:
        return None
    _, across, a, e = best
    arm = np.array([point[0] - a[0], point[1] - a[1], r_z])
    moment = float(np.cross(arm, heading) @ np.array([e[0], e[1], 0.0]))
    if moment <= 1e-12:
        return None
    return max(across, 0.0)


def breaks_loose(kinetic: float, potential: float) -> bool:
    """True when the impact wakes the hit part: kinetic energy above potential (report 3.6.2)."""
    return kinetic > potential


CLEARANCE_SLACK = 1e-6
"""m: a body is taken to be within reach of a frozen brick's box when its kept gap, less how far
any point of it has moved since, is within this of the reach (:class:`_Clearances`): round-off in
the bound must not leave out a body the engine would find near."""


class _Clearances:
    """Which moving bodies come within reach of a frozen brick's bounding box
    (:meth:`Stack.frozen_gaps <stability._stack.Stack.frozen_gaps>`), measured anew only when
    they may.

    Each body's gap is kept with its pose when measured. While no box has joined the frozen
    boxes since (:meth:`Stack.frozen_boxes <stability._stack.Stack.frozen_boxes>`; a brick
    woken leaves its box out), no point of the body has moved farther than its centre's travel
    and its turn (radians) times its half diagonal, and its gap can have shrunk by no more: a
    body whose kept gap, less that, is still beyond its reach is not near, and costs no corners
    and no comparison with every frozen box. Nor is a body measured again whose kept gap, plus
    that, is still within its reach: it is near, unless the box it was near has gone (a wake),
    and the engine is asked, as it would be were it measured near (a brick pushed along the one
    under it is near it at every step of the push). In a row of 120 dominoes the fallen ones behind
    the chain's front creep, fast enough to be asked every step, and far from every frozen
    box: 126 of 13,451 asks found one near. A bound only: the engine's closest points decide
    (:meth:`Impacts.check`).

    Args:
        stack: the registered bodies and the frozen boxes.

    Source: stackdsl's own.
    """

    def __init__(self, stack: Stack) -> None:
        self.stack = stack
        # body -> its position (3) and quaternion (4) when measured, its gap (m), the boxes' generation
        # then, its half diagonal (m), and its record (a body forgotten and its id taken again is not it)
        self._kept: dict[int, tuple[Sequence[float], Sequence[float], float, int, float, Record]] = {}

    def near(self, bodies: list[Record], reaches: list[float]) -> list[bool]:
        """For each of ``bodies`` (active), whether some frozen brick's box may lie within its
        reach (m, one each) of the body's box."""
        stack = self.stack
        read = stack.engine.pose_floats
        places, turns = zip(*(read(rec.body) for rec in bodies), strict=True)
        generation = stack.box_generation
        kept, out, todo = self._kept, [True] * len(bodies), []
        for i, rec in enumerate(bodies):
            was = kept.get(rec.body)
            if was is not None and was[3] == generation and was[5] is rec:
                place, turn, gap, _, corner, _ = was
                moved = moved_at_most(place, turn, places[i], turns[i], corner)  # its round-off is far inside CLEARANCE_SLACK
                if gap - moved > reaches[i] + CLEARANCE_SLACK:
                    out[i] = False
                    continue
                if gap + moved < reaches[i]:  # near still, or a box it was near has gone: asked, as when near
                    continue
            todo.append(i)
        if todo:
            bounds = [box_bounds(bodies[i].box.half_extents, places[i], turns[i]) for i in todo]
            gaps, generation = stack.frozen_gaps(np.array([lo for lo, _ in bounds]), np.array([hi for _, hi in bounds]))
            for i, gap in zip(todo, gaps.tolist(), strict=True):
                kept[bodies[i].body] = (places[i], turns[i], gap, generation, bodies[i].box.half_diagonal, bodies[i])
                out[i] = gap <= reaches[i] + CLEARANCE_SLACK
        return out


class Impacts:
    """The impact rule of one extension: fast bodies about to touch a frozen brick.

    Args:
        stack: the registered bodies.
        tests: the stack-wide test (the loads the potential energy needs).

    Source: report 3.6; which body an impactor is about to hit is stackdsl's own.
    """

    def __init__(self, stack: Stack, tests: StackTest) -> None:
        self.stack, self.tests = stack, tests
        self._parts = _Parts(stack)
        self._clearances = _Clearances(stack)
        self._least: tuple[int, float] | None = None  # a stack version, and :meth:`_least_tip` then
        # struck brick -> a stack version, its record, and its part's support polygon then with its edges
        self._shapes: dict[int, tuple[int, Record, BaseGeometry | None, Edges | None]] = {}

    def check(
        self,
        active: list[Record],
        dt: float,
        time: float,
        driven: Mapping[int, np.ndarray | None] | None = None,
        speeds: Mapping[int, tuple[float, float]] | None = None,
        watch: float = 0.0,
    ) -> list[StabilityEvent]:
        """Each active body faster than the rest speed that will touch a frozen brick within
        1.5 steps of ``dt`` s (at its fastest point's speed, rotation included): wake that brick
        (with what is above it) when the blow breaks it loose, else an ``impact`` event: the
        stack held. A body of ``driven`` (one a hand touches, with the hand's velocity in m/s,
        shape (3,), or None) that the hand drives onto a side of the frozen brick (a contact
        normal farther than the support angle from vertical) faster than the rest speed breaks it
        loose: the hand's velocity along the normal, where the hand gave one (a block pushed out
        along its length between two others may wobble into them at 0.01 to 0.03 m/s, across
        the push: not driven into them), else the body's own at the contact. ``speeds``: each body's linear (m/s) and
        angular (rad/s) speed this step, as the engine gives them, when read already (every
        body of ``active``).

        A frozen brick that leans on the body, which :meth:`stability._stack.Stack.watch` follows
        (it wakes once a corner of the body has moved ``watch`` m), is left to the watch while
        no point of the body moves ``watch`` in a step: the watch wakes it a step later at most.
        A fallen domino lying on the next, which still creeps at 0.01 m/s, is touched already:
        asked as a blow, its lifting barrier was 0 (its support lies above its centre of mass),
        and the whole pile of 57 behind it woke, froze and woke again, 245 times in a row of 100
        dominoes 30 mm apart."""
        stack, config = self.stack, self.stack.config
        events: list[StabilityEvent] = []
        geometric = getattr(stack.engine, "near_is_geometric", False)
        fast = []
        lowered = stack.lowered
        for rec in active:
            if lowered and rec.body in lowered:  # a hand sets it down at rest: no blow
                continue
            # the speeds first (floats, read once a step for the rest test too): most active
            # bricks are slow or far from every frozen brick, and need no vector
            speed, angular_speed = stack.engine.speeds(rec.body) if speeds is None else speeds[rec.body]
            if speed <= config.rest_speed:
                rec.impacted.clear()
                continue
            # no point of the body moves faster than |v| + |w| r, r its box's half diagonal: a
            # toppling domino's top edge moves twice as fast as its centre of mass
            corner = rec.box.half_diagonal
            reach = (speed + angular_speed * corner) * dt * 1.5 + config.contact_pad
            fast.append((rec, speed, angular_speed, reach))
        watched = stack.watched
        window = dt * 1.5
        if geometric and fast:  # no frozen brick's box within reach of its own box: the engine is not asked
            near = self._clearances.near([rec for rec, *_ in fast], [reach for *_, reach in fast])
            fast = [f for f, n in zip(fast, near, strict=True) if n]
        # a riding brick is where the engine carried it, not where it froze: its ride's own rules
        # watch what touches it (stability.StabilityExtension._rides)
        struck = stack.frozen.keys() - stack.riding.keys() if stack.riding else stack.frozen.keys()
        for rec, speed, angular_speed, reach in fast:
            hits = stack.engine.near(rec.body, reach, struck)
            if not hits:
                continue
            slow = (reach - config.contact_pad) / 1.5 < watch  # no point of it moves `watch` in a step
            leaning = watched[rec.body][1] if slow and rec.body in watched else ()
            linear, angular = stack.engine.velocity(rec.body)
            heading = linear / float(np.linalg.norm(linear))
            pose = stack.engine.pose(rec.body)
            for hit in hits:
                other = stack.bodies.get(hit.other)
                if other is None or other.state is not BrickState.FROZEN or other.body in rec.impacted:
                    continue
                if other.body in leaning:  # the watch follows it (above)
                    continue
                if not _reaches(hit, linear, angular, pose.position, other.box, stack.pose(other), window, config.contact_pad):
                    continue
                rec.impacted.add(other.body)
                if driven and rec.body in driven and abs(float(hit.normal[2])) < math.cos(math.radians(config.support_angle)):
                    # a side of it, not what it rests on or carries (a brick under a pulled one settling)
                    hand = driven[rec.body]
                    along = linear + np.cross(angular, hit.position - pose.position) if hand is None else hand
                    closing = -float(np.dot(along, hit.normal))
                    if closing > config.rest_speed:  # into it, not along it (a brick riding on a pulled one)
                        detail = f"driven into it by a hand at {closing:.2f} m/s, through {rec.label}"
                        events += [replace(w.event, source=rec.label) for w in stack.wake(other.body, time, detail)]
                        continue
                kinetic = kinetic_energy(rec.box.mass, speed, angular_speed, rec.box.largest_moment)
                self.tests.refresh_loads()
                potential, moved = self._barrier(other, heading, hit.position, kinetic)
                # the turn's share, when most of it: a brick rolling at 0.21 m/s brought 9.8 mJ, which its
                # speed alone cannot (the bound takes its largest moment of inertia, whatever the axis)
                turning = f" and {angular_speed:.3g} rad/s" if kinetic > rec.box.mass * speed * speed else ""
                detail = f"impact of {rec.label} at {speed:.2f} m/s{turning}: {kinetic * 1000:.3g} mJ against {potential * 1000:.3g} mJ"
                if moved is not other:
                    detail = (
                        f"impact of {rec.label} at {speed:.2f} m/s{turning} on {other.label}: {kinetic * 1000:.3g} mJ against"
                        f" {potential * 1000:.3g} mJ to turn {moved.label} and what it carries over its edge"
                    )
                if breaks_loose(kinetic, potential):
                    events += [replace(w.event, source=rec.label) for w in stack.wake(moved.body, time, detail)]
                else:
                    events.append(StabilityEvent(time, "impact", other.label, f"held, {detail}", rec.label))
        return events

    def _barrier(self, struck: Record, heading: np.ndarray, point: np.ndarray, kinetic: float = math.inf) -> tuple[float, Record]:
        """The least energy (J) a blow along ``heading`` landing at ``point`` on the frozen brick
        ``struck`` must bring to move a part of the stack, and the brick whose part it moves.

        The struck brick's part (it and what rests on it) is lifted off its base or tipped over
        the edge of its support polygon (:func:`tipping_energy`, report 3.6's barrier or the
        lesser of the two). The blow is passed down to what the struck brick rests on: for every
        frozen brick below it through what each rests on, down to the ground or a fixed body,
        the part that brick carries (itself and everything resting on it, :class:`_Parts`) is
        tipped over the edge of its support polygon that the blow's line passes outside, if any
        (a part below is pressed on its base, not lifted, by a blow on a brick above: no lifting
        barrier there). Three KAPLAs lying flush on each other, overhanging a table's edge: a
        blow straight down on the top one's tip meets the brick under it inside, and lifting it
        is its barrier (1.66 mJ), but the three turn over the table's edge for 0.05 mJ. Each
        part is weighed whole (its bricks' masses at their centres), and one whose centre of
        mass lies outside its polygon is held by more than it and not tipped. A part below is
        weighed only where it could tip for less than the least barrier found and than
        ``kinetic`` (J, the blow's; its centre of mass nearer its polygon's edge than that
        allows): a blow held is reported against the struck part's barrier, as before. Which
        part, and the walk down, are stackdsl's own."""
        stack, config = self.stack, self.stack.config
        base = min(a.height for a in struck.rests_on.values())
        assert struck.com_above is not None, "the stack test sets it for every frozen brick"
        potential = potential_energy(struck.mass_above, struck.com_above[2], base, config.gravity)
        if config.impact_energy != "least":
            return potential, struck
        footprint, edges = self._shape(struck)
        com = np.asarray(struck.com_above)
        if footprint is not None and footprint.contains(Point(com[0], com[1])):  # else held by more than it
            tip = tipping_energy(struck.mass_above, com, footprint, base, heading, config.gravity, point, edges)
            potential = tip if potential <= 0.0 else min(potential, tip)
        least, moved = potential, struck
        todo = [s for s in struck.rests_on if self._carries(s)]
        if not todo or min(least, kinetic) <= self._least_tip():  # no part below, or none tips for less
            return least, moved
        blow = np.zeros(3)
        blow[: len(heading)] = np.asarray(heading, dtype=float)[:3]
        below: set[int] = set()
        while todo:  # every frozen brick under it, through what each rests on
            b = todo.pop()
            if b not in below:
                below.add(b)
                todo += [s for s in stack.bodies[b].rests_on if s not in below and self._carries(s)]
        lowers = sorted((stack.bodies[b] for b in below), key=_top, reverse=True)  # the upper first
        masses, centres, polygons, inside = self._parts.weigh([r.body for r in lowers])
        for i, lower in enumerate(lowers):
            polygon, mass, centre = polygons[i], float(masses[i]), centres[i]
            if not isinstance(polygon, Polygon) or inside[i] <= 0.0:  # no polygon, or held by more than it
                continue
            low = min(a.height for a in lower.rests_on.values())
            h = max(float(centre[2]) - low, 0.0)
            # only a centre of mass nearer than this to the polygon's edge tips for less than
            # the least barrier found: m g (sqrt(d^2 + h^2) - h) < E for d < sqrt(e^2 + 2 h e), e = E / (m g)
            e = min(least, kinetic) / (mass * config.gravity)
            if inside[i] >= math.sqrt(e * e + 2.0 * h * e):
                continue
            edge = _tipping_edge(centre, polygon, low, blow, np.asarray(point, dtype=float))
            if edge is None:  # pressed on its base
                continue
            tip = mass * config.gravity * (math.hypot(edge, h) - h)
            if tip < least and tip < kinetic:
                least, moved = tip, lower
        return least, moved

    def _shape(self, struck: Record) -> tuple[BaseGeometry | None, Edges | None]:
        """The support polygon of the part ``struck`` carries (:func:`_footprint`) and its edges
        (:func:`edges_of`, None for no polygon), found once a stack version: a brick jostled on
        a frozen one, faster than the rest speed at some steps and not at others, strikes it
        anew each time (the level under a pulled Jenga block, 200 times in a pull)."""
        stack = self.stack
        kept = self._shapes.get(struck.body)
        if kept is None or kept[0] != stack.version or kept[1] is not struck:
            footprint = _footprint(stack, struck)
            edges = edges_of(footprint) if isinstance(footprint, Polygon) and not footprint.is_empty else None
            kept = self._shapes[struck.body] = (stack.version, struck, footprint, edges)
        return kept[2], kept[3]

    def _least_tip(self) -> float:
        """Joules: less than any frozen brick's part (it and what rests on it, :class:`_Parts`)
        tips for over the edge of its support polygon, whatever the blow: ``m g (sqrt(d^2 + h^2)
        - h)``, ``d`` its centre of mass's distance inside the polygon's edge and ``h`` its height
        over its base, the least over the parts :meth:`_barrier` walks down to (a part held by
        more than it, or with no polygon, tips for none); found once a stack version. A blow of
        less energy than it, or on a part that is lifted or tipped for less, needs no part below
        weighed: the placing of each brick of a Jenga tower landed on three frozen ones with 0.016
        mJ, against parts that tip for 1.4 mJ and more. Source: stackdsl's own."""
        stack = self.stack
        if self._least is None or self._least[0] != stack.version:
            frozen = sorted((r for r in stack.frozen.values() if r.rests_on), key=_top, reverse=True)  # the upper first
            least = math.inf
            if frozen:
                masses, centres, polygons, inside = self._parts.weigh([r.body for r in frozen])
                for i, rec in enumerate(frozen):
                    if not isinstance(polygons[i], Polygon) or inside[i] <= 0.0:
                        continue
                    h = max(float(centres[i][2]) - min(a.height for a in rec.rests_on.values()), 0.0)
                    least = min(least, float(masses[i]) * stack.config.gravity * (math.hypot(float(inside[i]), h) - h))
            self._least = (stack.version, least)
        return self._least[1]

    def _carries(self, body: int) -> bool:
        """Is ``body`` a frozen brick (a part the blow may move), not the ground, a fixed body or
        an active brick?"""
        rec = self.stack.bodies.get(body)
        return rec is not None and rec.state is BrickState.FROZEN


CORNERS_KEPT = 20000
"""Contact polygons whose corners :class:`_Parts` keeps at most (then it forgets them all)."""


class _Parts:
    """The parts that frozen bricks carry (a brick, what rests on it and on those), each found
    once and taken whole into the parts under it: walking down a tower from the top, each
    level's part is built from the ones above it, its bricks a bit set, and its support
    pieces (the contacts by which its bricks rest on bricks outside it) from theirs; each
    brick, as frozen, gets a bit of its own. All parts under a struck brick are weighed at
    once (masses and centres of mass by one product with the bricks' masses and moments, the
    support polygons as the convex hulls of the pieces' corners, each hull kept for as long
    as the same pieces make it up). Measured on a 100-level 2-a-layer tower whose top is
    knocked off by a thrown KAPLA (443 blows weighed, most high on the tower): 1-3 ms a blow,
    the impact rule 1.3 s of the run against 0.76 s when only the struck part was weighed
    (stackdsl's own)."""

    def __init__(self, stack: Stack) -> None:
        self.stack, self.version = stack, stack.version
        self.bits: dict[int, tuple[object, int]] = {}  # body -> (its load node as frozen, its bit)
        self.count = 0  # bits given
        self.masses = np.zeros(64)  # kg, of each bit's brick
        self.moments = np.zeros((64, 3))  # kg m, each bit's brick's mass times its centre of mass
        self.corners: dict[int, tuple[BaseGeometry, np.ndarray]] = {}  # id -> (a contact polygon, its corners)
        self.hulls: dict[tuple[int, ...], tuple[list[BaseGeometry], BaseGeometry]] = {}  # pieces' ids -> (them, their hull)
        self.found: dict[int, tuple[int, list[tuple[int, BaseGeometry]]]] = {}  # this version's: (bricks, (support, piece))
        self.now: dict[int, int] = {}  # this version's: body -> its bit

    def _bit(self, body: int) -> int:
        """The bit of a frozen brick, as frozen now (0 for another body)."""
        bit = self.now.get(body)
        if bit is None:
            bit = self.now[body] = self._give(body)
        return bit

    def _give(self, body: int) -> int:
        rec = self.stack.bodies.get(body)
        if rec is None or rec.state is not BrickState.FROZEN:
            return 0
        node, bit = self.bits.get(body, (None, 0))
        if node is not rec.node:  # frozen since it was given one
            if self.count == len(self.masses):
                self.masses = np.concatenate([self.masses, np.zeros(self.count)])
                self.moments = np.concatenate([self.moments, np.zeros((self.count, 3))])
            bit, self.masses[self.count] = 1 << self.count, rec.box.mass
            self.moments[self.count] = rec.box.mass * self.stack.pose(rec).position
            self.bits[body], self.count = (rec.node, bit), self.count + 1
        return bit

    def _find(self, body: int) -> tuple[int, list[tuple[int, BaseGeometry]]]:
        if self.version != self.stack.version:
            self.found, self.now, self.version = {}, {}, self.stack.version
        if body in self.found:
            return self.found[body]
        bodies = self.stack.bodies
        members, todo, walked = self._bit(body), [body], {body}
        # each piece once: a piece on a body that is not frozen (a pulled or pushed brick that
        # frozen bricks are kept on) has no bit, is never inside a part, and came in once through
        # each brick of each level above it: 3^k copies k levels down (3.7 GB, a push at level 13)
        candidates = [(s, a.polygon) for s, a in bodies[body].rests_on.items()]
        while todo:
            for above in bodies[todo.pop()].objects_above:
                bit = self._bit(above)
                if members & bit or above in walked:
                    continue
                walked.add(above)
                if above in self.found:
                    inner, pieces = self.found[above]
                    members |= inner
                    candidates += pieces
                else:
                    members |= bit
                    candidates += [(s, a.polygon) for s, a in bodies[above].rests_on.items()]
                    todo.append(above)
        now, seen = self.now, set()
        outside = []
        for s, piece in candidates:
            if id(piece) not in seen and not members & (now[s] if s in now else self._bit(s)):
                seen.add(id(piece))
                outside.append((s, piece))
        self.found[body] = (members, outside)
        return self.found[body]

    def weigh(self, bodies: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The parts the frozen bricks ``bodies`` carry, all at once: their masses (kg, shape
        (n,)), centres of mass (m, shape (n, 3)), support polygons (shapely, None where a part
        rests on nothing) and how far each centre of mass lies inside its polygon (m, shape
        (n,); 0 or less: not inside)."""
        n = len(bodies)
        if n == 0:
            return np.zeros(0), np.zeros((0, 3)), np.full(0, None, dtype=object), np.zeros(0)
        found = [self._find(b) for b in bodies]  # upper first: each part from those above it
        count, width = self.count, (self.count + 7) // 8
        rows = np.frombuffer(b"".join(members.to_bytes(width, "little") for members, _ in found), dtype=np.uint8)
        mask = np.unpackbits(rows.reshape(n, width), axis=1, bitorder="little")[:, :count].astype(float)
        masses = mask @ self.masses[:count]
        centres = (mask @ self.moments[:count]) / masses[:, None]
        polygons = np.full(n, None, dtype=object)
        missing: list[tuple[int, tuple[int, ...], list[BaseGeometry]]] = []
        for i, (_, outside) in enumerate(found):
            pieces = [piece for _, piece in outside]
            key = tuple(sorted(id(piece) for piece in pieces))
            known = self.hulls.get(key)
            if known is not None:
                polygons[i] = known[1]
            elif pieces:
                missing.append((i, key, pieces))
        if missing:  # the hull of the pieces' corners: as their union's, at a fraction of the cost
            corners = [[self._corners(piece) for piece in pieces] for _, _, pieces in missing]
            index = np.repeat(np.arange(len(missing)), [sum(len(c) for c in part) for part in corners])
            flat = np.concatenate([c for part in corners for c in part])
            hulls = shapely.convex_hull(shapely.multipoints(flat, indices=index))
            if len(self.hulls) > CORNERS_KEPT:  # those of parts long gone go
                self.hulls.clear()
            for (i, key, pieces), hull in zip(missing, hulls, strict=True):
                polygons[i] = hull
                self.hulls[key] = (pieces, hull)  # the pieces kept: their ids stay theirs
        within = shapely.contains_xy(polygons, centres[:, 0], centres[:, 1])
        distance = shapely.distance(shapely.boundary(polygons), shapely.points(centres[:, :2]))
        inside = np.where(within, np.nan_to_num(distance, nan=0.0), 0.0)
        return masses, centres, polygons, inside

    def _corners(self, piece: BaseGeometry) -> np.ndarray:
        """A contact polygon's corners (shape (k, 2), m), kept while it is."""
        known = self.corners.get(id(piece))
        if known is None or known[0] is not piece:
            if len(self.corners) > CORNERS_KEPT:  # those of bricks long woken go
                self.corners.clear()
            known = (piece, shapely.get_coordinates(piece))
            self.corners[id(piece)] = known
        return known[1]


def _top(rec: Record) -> float:
    """The top of a frozen brick (m)."""
    return rec.extent[0] if rec.extent is not None else 0.0


def _footprint(stack: Stack, rec: Record) -> BaseGeometry | None:
    """The horizontal support polygon of the part ``rec`` carries (itself, what rests on it, and
    on those): the convex hull of every contact by which a brick of the part rests on a body
    outside it; None when it rests on nothing. A domino's is its foot; a trilithon post's
    reaches the other post, on which the lintel also lies (braced along the lintel, not across
    it); a tower level's spans the level, since the bricks above lie on its neighbour too
    (stackdsl's own)."""
    part, todo = {rec.body}, [rec.body]
    while todo:
        for above in stack.bodies[todo.pop()].objects_above:
            if above not in part:
                part.add(above)
                todo.append(above)
    pieces = [a.polygon for b in part for s, a in stack.bodies[b].rests_on.items() if s not in part]
    return unary_union(pieces).convex_hull if pieces else None


def _reaches(
    hit: ContactPoint,
    linear: np.ndarray,
    angular: np.ndarray,
    com: np.ndarray,
    box: Box,
    pose: Pose,
    window: float,
    pad: float,
) -> bool:
    """Does the impactor reach the brick of closest point ``hit`` (a ``box`` at ``pose``) within
    ``window`` seconds, or touch it already?

    The impactor's closest point lies ``hit.distance`` from ``hit.position`` along
    ``hit.normal`` (which points from the brick into the impactor) and moves at
    ``linear + angular x (point - com)``. It reaches the brick if its straight path over the
    window enters the box grown by ``pad`` (:meth:`Box.meets_path`). A toppling
    domino's top edge comes at the next domino's face down and forward, and reaches it though
    its centre of mass heads mostly down; a brick thrown past the top of a tower closes on the
    edge of the level below but passes above it; a body beside or below the path is near but
    not hit.

    Args:
        hit: a closest point seen from the impactor; linear: m/s, shape (3,); angular: rad/s,
            shape (3,); com: the impactor's centre of mass, m, shape (3,); box, pose: the
            brick's; window: s; pad: m.

    Source: stackdsl's own (report 3.6 judges the blow; when it lands is the engine's step).
    """
    if hit.distance <= pad:  # touching already
        return True
    point = hit.position + hit.normal * hit.distance
    return box.meets_path(pose, point, (linear + np.cross(angular, point - com)) * window, grow=pad)

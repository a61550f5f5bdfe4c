"""The stability extension: freeze what the graph proves stable, wake what it proves not.

The report's basic version (3.3.1-3.3.7) on top of any :class:`Engine`. Each physics
step the harness calls :meth:`StabilityExtension.update`; it

1. gathers contact points and drops those between two unstable (active) bricks
   (3.3.1; contacts with a moving body, impacts included, never support a brick);
2. builds contact areas per support and their convex hull, the main contact area (3.3.3);
3. admits a brick whose speeds have stayed under the rest threshold for the rest
   duration and whose centre of mass lies over its main contact area, and freezes it
   (3.3.4);
4. when the stack changed, propagates centre of mass above and mass above (3.3.5-3.3.6)
   and wakes every brick whose centre of mass above lies outside its main contact area,
   with everything resting on it (3.3.7).

Propagation and the stack-wide test run only when the stack changes (a freeze or a
wake), never on a step where nothing did. pybullet reports no contacts between two
frozen bodies, so the extension keeps the contact graph it had when it froze them.
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field
from typing import Iterable

import numpy as np
from shapely.geometry import Point, Polygon

from ._engine import ContactPoint, Engine
from ._geometry import Box, ContactArea, Plane, Pose, combined_hull, contains, face_overlap, padded_hull
from ._graph import BrickGraph, BrickState, GraphEdge, GraphNode
from ._load import LoadNode, propagate


@dataclass(frozen=True)
class StabilityConfig:
    """Thresholds of the stability extension (SI units).

    Attributes:
        rest_speed: m/s; a brick faster than this is not at rest (report 3.3.2).
        rest_angular_speed: rad/s; likewise for rotation (report 3.3.2).
        rest_duration: s; speeds must stay under both thresholds this long before a
            brick is admitted. The report tests one frame; a brick just woken is at rest
            for that frame and would be refrozen at once, so stackdsl asks for a duration
            (its own).
        contact_pad: m; half-width of the padding of one- and two-point contact areas
            (report 3.3.3).
        support_angle: degrees; a contact whose normal is within this angle of vertical
            is one the brick rests on (stackdsl's own).
        face_gap: m; two faces within this distance (and this flat) touch face to face,
            and their overlap is the exact contact area (stackdsl's own).
        com_margin: m; the centre of mass must lie this far inside the area (0: strictly
            inside; on the edge counts as unstable).
    """

    rest_speed: float = 0.005
    rest_angular_speed: float = 0.05
    rest_duration: float = 0.05
    contact_pad: float = 0.001
    support_angle: float = 30.0
    face_gap: float = 0.001
    com_margin: float = 0.0


@dataclass(frozen=True)
class StabilityEvent:
    """Something the extension did: ``kind`` is ``"freeze"`` or ``"wake"``; time in s."""

    time: float
    kind: str
    label: str
    reason: str


@dataclass
class _Body:
    """Per-body data of report Figure 3 (Brick): supports, main contact, loads, state."""

    body: int
    label: str
    shape: Box | Plane
    state: BrickState
    order: int
    rests_on: dict[int, ContactArea] = field(default_factory=dict)
    main_contact: Polygon | None = None
    objects_above: set[int] = field(default_factory=set)
    com_above: np.ndarray | None = None
    mass_above: float = 0.0
    rest_since: float | None = None
    frozen_pose: Pose | None = None


class StabilityExtension:
    """The report's stack stability system, attached to an :class:`Engine`.

    Register every body first (:meth:`add_ground`, :meth:`add_brick`), then call
    :meth:`update` once per physics step. :meth:`graph` reads the brick graph at any
    time, also when :meth:`update` is never called (the engine alone).

    Args:
        engine: the engine to drive.
        config: thresholds.

    Source: report 3.3 (basic version).

    >>> import numpy as np
    >>> from stability import Box, FakeEngine, Plane, Pose
    >>> eng = FakeEngine()
    >>> ext = StabilityExtension(eng)
    >>> ext.add_ground(0, Plane(0.0))
    >>> eng.poses[1] = Pose(np.array([0, 0, 0.004]))
    >>> ext.add_brick(1, Box(np.array([0.06, 0.012, 0.004]), 0.0106), "b1")
    >>> eng.touch(1, 0, [[-0.06, -0.012, 0], [0.06, 0.012, 0]], normal=[0, 0, 1])
    >>> [e.kind for e in ext.update(0.0) + ext.update(0.1)]
    ['freeze']
    """

    def __init__(self, engine: Engine, config: StabilityConfig | None = None) -> None:
        self._engine = engine
        self.config = config or StabilityConfig()
        self._bodies: dict[int, _Body] = {}
        self._support_cos = math.cos(math.radians(self.config.support_angle))

    # registration -------------------------------------------------------------
    def add_ground(self, body: int, shape: Box | Plane, label: str = "ground") -> None:
        """Register an environment body (ground flag of report Figure 3)."""
        self._add(_Body(body, label, shape, BrickState.GROUND, len(self._bodies)))

    def add_brick(self, body: int, box: Box, label: str) -> None:
        """Register a brick; it starts active (simulated by the engine)."""
        self._add(_Body(body, label, box, BrickState.ACTIVE, len(self._bodies)))

    def _add(self, rec: _Body) -> None:
        if rec.body in self._bodies:
            raise ValueError(f"body {rec.body} is registered already")
        self._bodies[rec.body] = rec

    # queries ------------------------------------------------------------------
    def state(self, body: int) -> BrickState:
        """The state of a registered body. Raises KeyError for an unknown body."""
        return self._bodies[body].state

    @property
    def quiet(self) -> bool:
        """True when no registered brick is active: nothing can move until an action."""
        return all(r.state is not BrickState.ACTIVE for r in self._bodies.values())

    # the per-step hook --------------------------------------------------------
    def update(self, time: float) -> list[StabilityEvent]:
        """One step of the algorithm of report 3.3.1. ``time`` in seconds."""
        active = [r for r in self._bodies.values() if r.state is BrickState.ACTIVE]
        if not active:
            return []
        contacts = _by_body(self._engine.contact_points())
        events: list[StabilityEvent] = []
        for rec in active:
            if self._at_rest(rec, time):
                events += self._admit(rec, contacts.get(rec.body, []), time)
        if events:
            events += self._test_stack(time)
        return events

    def _at_rest(self, rec: _Body, time: float) -> bool:
        lin, ang = self._engine.velocity(rec.body)
        cfg = self.config
        if np.linalg.norm(lin) > cfg.rest_speed or np.linalg.norm(ang) > cfg.rest_angular_speed:
            rec.rest_since = None
            return False
        if rec.rest_since is None:
            rec.rest_since = time
        return time - rec.rest_since >= cfg.rest_duration - 1e-9

    def _admit(self, rec: _Body, contacts: list[ContactPoint], time: float) -> list[StabilityEvent]:
        """Single object stability (report 3.3.4): freeze when the COM is over the support."""
        supports = self._supports(rec, contacts, stack_only=True)
        if not supports:
            return []
        main = combined_hull(list(supports.values()))
        pose = self._engine.pose(rec.body)
        if not contains(main, pose.position[:2], self.config.com_margin):
            return []
        self._engine.set_frozen(rec.body, True, rec.shape.mass)
        rec.state, rec.rests_on, rec.main_contact = BrickState.FROZEN, supports, main
        rec.frozen_pose = self._engine.pose(rec.body)
        for s in supports:
            self._bodies[s].objects_above.add(rec.body)
        names = ", ".join(self._bodies[s].label for s in supports)
        return [StabilityEvent(time, "freeze", rec.label, f"at rest on {names}")]

    def _test_stack(self, time: float) -> list[StabilityEvent]:
        """Stack-wide test (report 3.3.1, 3.3.5) with the wake-up cascade (3.3.7).

        A brick whose centre of mass above lies outside its main contact area gives way:
        it and everything above it wake. Beyond the report: the woken bricks above it that
        also rest on other stack bricks now lean on those alone, so the test is repeated
        with their load on them (co-support re-test). Without it a tower whose two
        sibling bricks carry it together stays pinned by the sibling that did not fail
        first (measured on the slant tower, README design notes).
        """
        events: list[StabilityEvent] = []
        gave_way: set[int] = set()
        leaning: dict[int, LoadNode] = {}
        while True:
            nodes = {r.body: LoadNode(r.shape.mass, r.frozen_pose.position, r.rests_on) for r in self._frozen()}
            for body, node in leaning.items():
                kept = {s: a for s, a in node.supports.items() if s not in gave_way}
                if kept:
                    nodes[body] = LoadNode(node.mass, node.com, kept)
            loads = propagate(nodes)
            failing = []
            for rec in self._frozen():
                rec.com_above, rec.mass_above = loads[rec.body].com_above, loads[rec.body].mass_above
                if not contains(rec.main_contact, rec.com_above, self.config.com_margin):
                    failing.append(rec)
            if not failing:
                return events
            for rec in failing:
                if rec.state is not BrickState.FROZEN:  # woken already, resting on one that failed
                    continue
                out = rec.main_contact.exterior.distance(Point(rec.com_above[:2])) * 1000
                gave_way.add(rec.body)
                for woken, node, event in self._wake(rec.body, time, f"centre of mass above {out:.1f} mm outside its support"):
                    events.append(event)
                    if woken != rec.body:
                        leaning[woken] = node

    def _frozen(self) -> list[_Body]:
        return [r for r in self._bodies.values() if r.state is BrickState.FROZEN]

    # wake-up (report 3.3.7) ---------------------------------------------------
    def wake(self, body: int, time: float, reason: str) -> list[StabilityEvent]:
        """Return a frozen brick and everything resting on it to the engine (report 3.3.7).

        Returns the events, one per brick woken; nothing when ``body`` is not frozen.
        """
        return [event for _, _, event in self._wake(body, time, reason)]

    def _wake(self, body: int, time: float, reason: str) -> list[tuple[int, LoadNode, StabilityEvent]]:
        """Wake ``body`` and, recursively, what rests on it; each with its last load node."""
        rec = self._bodies[body]
        if rec.state is not BrickState.FROZEN:
            return []
        node = LoadNode(rec.shape.mass, rec.frozen_pose.position, rec.rests_on)
        self._engine.set_frozen(body, False, rec.shape.mass)
        rec.state, rec.rest_since, rec.frozen_pose = BrickState.ACTIVE, None, None
        for s in rec.rests_on:
            self._bodies[s].objects_above.discard(body)
        rec.rests_on, rec.main_contact, rec.com_above, rec.mass_above = {}, None, None, 0.0
        woken = [(body, node, StabilityEvent(time, "wake", rec.label, reason))]
        for above in sorted(rec.objects_above, key=lambda b: self._bodies[b].order):
            woken += self._wake(above, time, f"rests on {rec.label}")
        rec.objects_above = set()
        return woken

    # contact areas (report 3.3.3) ---------------------------------------------
    def _supports(self, rec: _Body, contacts: Iterable[ContactPoint], stack_only: bool) -> dict[int, ContactArea]:
        """Contact areas of the bodies ``rec`` rests on, keyed by body, in registration order."""
        grouped: dict[int, list[ContactPoint]] = defaultdict(list)
        my_z = self._engine.pose(rec.body).position[2]
        for c in contacts:
            other = self._bodies.get(c.other)
            if other is None or c.normal[2] < self._support_cos:
                continue
            if other.state is BrickState.ACTIVE and (stack_only or self._engine.pose(other.body).position[2] >= my_z):
                continue
            grouped[c.other].append(c)
        ordered = sorted(grouped, key=lambda b: self._bodies[b].order)
        return {o: self._contact_area(rec, self._bodies[o], grouped[o]) for o in ordered}

    def _contact_area(self, rec: _Body, other: _Body, points: list[ContactPoint]) -> ContactArea:
        other_pose = None if isinstance(other.shape, Plane) else self._pose(other)
        exact = face_overlap(rec.shape, self._engine.pose(rec.body), other.shape, other_pose, self.config.face_gap)
        if exact is not None:
            return exact
        xyz = np.array([c.position for c in points])
        normal = np.mean([c.normal for c in points], axis=0)
        polygon = padded_hull(xyz[:, :2], self.config.contact_pad)
        return ContactArea(polygon, float(xyz[:, 2].mean()), normal / np.linalg.norm(normal), exact=False)

    def _pose(self, rec: _Body) -> Pose:
        return rec.frozen_pose if rec.frozen_pose is not None else self._engine.pose(rec.body)

    # the brick graph ----------------------------------------------------------
    def graph(self) -> BrickGraph:
        """The brick graph now: frozen bricks as remembered, active ones from live contacts.

        Loads are propagated over every brick, frozen or not, so the graph is the same
        kind of object with the extension acting or not (the engine alone).
        """
        contacts = _by_body(self._engine.contact_points())
        bricks = [r for r in self._bodies.values() if r.state is not BrickState.GROUND]
        supports = {
            r.body: r.rests_on if r.state is BrickState.FROZEN else self._supports(r, contacts.get(r.body, []), False)
            for r in bricks
        }
        nodes = {r.body: LoadNode(r.shape.mass, self._pose(r).position, supports[r.body]) for r in bricks}
        loads = propagate(nodes)
        graph_nodes, edges = [], []
        for rec in self._bodies.values():
            pose = self._pose(rec) if not isinstance(rec.shape, Plane) else Pose(np.array([0.0, 0.0, rec.shape.height]))
            load = loads.get(rec.body)
            com = load.com_above if load else pose.position
            graph_nodes.append(GraphNode(rec.label, rec.state, pose, com, load.mass_above if load else 0.0))
            for s, area in supports.get(rec.body, {}).items():
                edges.append(GraphEdge(rec.label, self._bodies[s].label, area.area, load.shares[s], area.exact))
        return BrickGraph(tuple(graph_nodes), tuple(edges))


def _by_body(points: Iterable[ContactPoint]) -> dict[int, list[ContactPoint]]:
    grouped: dict[int, list[ContactPoint]] = defaultdict(list)
    for c in points:
        grouped[c.body].append(c)
    return grouped

"""The stack-wide test: which frozen bricks give way when the stack changes (report 3.3.5-3.3.7).

With the report's model, centre of mass above and mass above are propagated down the frozen
stack and a brick whose centre of mass above lies outside its main contact area wakes with
everything above it; with the equilibrium model, the frozen stack is solved by rigid-block
equilibrium and the bricks of its collapse mechanism wake. Source: report 3.3.5-3.3.7;
the equilibrium model is Livesley (1978) and Whiting et al. (2009).
"""

from __future__ import annotations

from collections.abc import Set as AbstractSet
from graphlib import CycleError

import numpy as np
import shapely
from shapely.geometry import MultiPoint, Point
from shapely.geometry.base import BaseGeometry

from ._areas import ContactAreas, main_area
from ._cut import falling_part
from ._equilibrium import ContactPolygon, RigidBlock, connected_part, is_level, solve_equilibrium
from ._geometry import ContactArea, Pose, padded_hull
from ._graph import BrickState
from ._leaning import pair_friction
from ._load import LoadNode, propagate_fast
from ._load_path import load_path, loads_balance, proven, support_piece
from ._stack import Attempt, Record, StabilityEvent, Stack


class StackTest:
    """The stack-wide test of one extension's configured model.

    Args:
        stack: the registered bodies.
        areas: their contact areas (whether a centre of mass is over one).

    Source: report 3.3.5-3.3.7.
    """

    def __init__(self, stack: Stack, areas: ContactAreas) -> None:
        self.stack, self.areas = stack, areas

    def run(self, time: float) -> list[StabilityEvent]:
        """The stack-wide test of the configured model at ``time`` s; returns the wake events."""
        if self.stack.config.model == "report":
            return self._report(time)  # it computes the loads on the way
        return self._equilibrium(time)

    def carry(self, rec: Record, pose: Pose, areas: dict[int, ContactArea], time: float) -> list[StabilityEvent]:
        """Can the frozen stack carry ``rec``, an active brick lying at ``pose`` on the frozen
        bricks and the ground of ``areas`` (body -> exact contact area)? The bricks that give
        way under its load wake; returns their events.

        A frozen brick is immovable in the engine: the weight of an active brick lying on it
        would otherwise be carried unchecked until that brick freezes (if it ever does). Only a
        brick that would stand where it lies on rigid supports is a load: one that will tip or
        slide off loads the stack for a moment only, and the engine and the collapse monitor
        follow it. With the report's model its load is propagated with the frozen stack's
        (report 3.3.5-3.3.7); with the equilibrium model it is a free block of the stack's
        program, after the load paths (:mod:`stability._load_path`) and the turning parts
        (:mod:`stability._cut`), as in the stack-wide test. Source: stackdsl's own.
        """
        stack = self.stack
        frozen = {r.body: r for r in stack.in_order()}
        if not any(b in frozen for b in areas):
            return []
        mass, com = rec.box.mass, pose.position
        if stack.config.model == "report":
            if not self.areas.holds(main_area(areas), com):
                return []
            nodes = stack.nodes(frozen.values())
            nodes[rec.body] = LoadNode(mass, com, areas)
            try:
                loads = propagate_fast(nodes, stack.splits)
            except CycleError:
                return []
            failing = []
            for r in frozen.values():
                assert r.main_contact is not None, "a frozen brick has a main contact area"
                load = loads[r.body]
                if not r.held_by_pile() and not r.held_as(load) and not self.areas.holds(r.main_contact, load[0]):
                    failing.append(r)
            events: list[StabilityEvent] = []
            for r in failing:
                if r.state is not BrickState.FROZEN:  # woken already, resting on one that failed
                    continue
                assert r.main_contact is not None, "a frozen brick has a main contact area"
                out = outside_support(r, loads[r.body][0], stack.config.contact_pad) * 1000
                reason = f"centre of mass above {out:.1f} mm outside its support with {rec.label} on the stack"
                events += [w.event for w in stack.wake(r.body, time, reason)]
            return events + (self.run(time) if events else [])
        polygons = [
            ContactPolygon(
                rec.body, other, area.corners(), area.normal, pair_friction(rec.friction, stack.bodies[other].friction)
            )
            for other, area in areas.items()
        ]
        pieces = [
            support_piece(c.points, stack.bodies[c.other].load_path, stack.bodies[c.other].state is BrickState.GROUND)
            for c in polygons
            if is_level(c)
        ]
        if not stack.unproven and proven(com, load_path([p for p in pieces if p is not None])):
            return []  # every brick, the new one too, passes its load down a path: the stack stands
        block = RigidBlock(mass, com)
        if not solve_equilibrium({rec.body: block}, polygons, gravity=stack.config.gravity).stands:
            return []  # it will not stay where it lies
        contacts = stack.frozen_contacts(frozen) + polygons
        blocks = {b: RigidBlock(r.box.mass, stack.pose(r).position) for b, r in frozen.items()} | {rec.body: block}
        blocks, contacts = connected_part(blocks, contacts, {rec.body})  # the part it would load
        moving = set(falling_part(blocks, contacts) or ()) if stack.config.gravity > 0 else set()
        if not moving:
            result = solve_equilibrium(blocks, contacts, gravity=stack.config.gravity)
            if result.stands:
                return []
            moving = result.moving()
        events = []
        reason = f"it moves in the collapse mechanism (rigid-block equilibrium) with {rec.label} on the stack"
        for b in stack.ordered(moving & frozen.keys()):
            events += [w.event for w in stack.wake(b, time, reason, moving)]
        return events + (self.run(time) if events else [])

    def refresh_loads(self) -> None:
        """com_above / mass_above of every frozen brick, when the stack changed since they were
        last propagated (the impact rule uses them)."""
        stack = self.stack
        if stack.loads_fresh:
            return
        loads = propagate_fast(stack.nodes(stack.in_order()), stack.splits)
        for rec in stack.in_order():
            rec.com_above, rec.mass_above = loads[rec.body][0], loads[rec.body][1]
        stack.loads_fresh = True

    def _equilibrium(self, time: float) -> list[StabilityEvent]:
        """Stack-wide test by rigid-block equilibrium (Livesley 1978; Whiting et al. 2009).

        All frozen bricks are free blocks, the ground and fixed bodies supports, and the
        contact polygons those remembered when each brick was frozen. When no set of
        compressive, friction-bounded forces balances them, the program's dual is a
        collapse mechanism: a virtual velocity for every brick (Livesley's kinematic
        theorem). The bricks that move in it, and everything resting on them, wake;
        bricks the mechanism leaves still stay frozen. That is the smallest set the
        solution shows must move: waking only the bricks whose contacts would need glue
        leaves their siblings frozen under a tipping block (the slant tower stayed pinned
        by one of its two level-3 bricks), waking everything discards what still stands.
        Solved only when the stack changes, and only when some frozen brick has no load path
        under its centre of mass and the report's propagated loads do not balance the stack
        either (:mod:`stability._load_path`): either is a solution of the program already, so
        the stack stands. Nor when a part of the stack provably turns out about an edge of its
        footing (:mod:`stability._cut`): that part is a collapse mechanism, and it wakes. Nor is
        it solved again for a debris pile that was solved with the whole frozen stack before it
        froze (:meth:`stability._debris.Debris.admit`).
        """
        stack = self.stack
        events: list[StabilityEvent] = []
        while True:
            frozen = {r.body: r for r in stack.in_order()}
            if not frozen or not stack.unproven or stack.standing_version == stack.version:
                return events
            polygons = stack.frozen_contacts(frozen)
            touched = {c.body for c in polygons} | {c.other for c in polygons}
            moving = {b for b in frozen if b not in touched}  # rests on nothing that stays
            if not moving:
                if self._balanced_by_loads():
                    return events
                blocks = {b: RigidBlock(r.box.mass, stack.pose(r).position) for b, r in frozen.items()}
                # the parts with a brick off its load path: every other part stands on its paths
                moving = self._mechanism(blocks, polygons, stack.unproven)
                if not moving:  # it stands, or only active bricks would move: the engine has them
                    return events
            for b in stack.ordered(moving):
                reason = "it moves in the collapse mechanism (rigid-block equilibrium)"
                events += [w.event for w in stack.wake(b, time, reason, moving)]

    def _mechanism(
        self, blocks: dict[int, RigidBlock], polygons: list[ContactPolygon[int]], around: AbstractSet[int]
    ) -> set[int]:
        """The frozen bricks that move in the collapse mechanism of the part of the frozen stack
        (``blocks`` on ``polygons``) that ``around`` belongs to, with the active bricks lying on it
        (:meth:`_resting_on`); empty when that part stands. A part that provably turns out about
        an edge of its footing (:func:`stability._cut.falling_part`) is the mechanism, and the
        program is solved only when there is none."""
        gravity = self.stack.config.gravity
        blocks, part = connected_part(blocks, polygons, around)
        resting, on = self._resting_on(blocks)
        blocks, part = blocks | resting, part + on
        moving = set(falling_part(blocks, part) or ()) if gravity > 0 else set()
        if not moving:
            result = solve_equilibrium(blocks, part, gravity=gravity)
            if result.stands:
                return set()
            moving = result.moving()
        return moving - resting.keys()

    def _leaning(self, time: float) -> list[StabilityEvent]:
        """The report model's test of the bricks frozen on a non-level load path since it last
        ran (:attr:`stability._stack.Stack.leaning`): rigid-block equilibrium with friction of
        their part of the frozen stack, as the equilibrium model's stack test asks it; the
        bricks of its collapse mechanism wake, with what rests on them.

        The report's load tree assumes unlimited friction, which is exact where every contact
        a load reaches is level and the loads vertical. A leaning brick pushes sideways on what
        it leans on (a plank on the top brick of a slick stack), and a brick laid on a leaning
        one (the flat across the two Vs of a card house) pushes its feet outwards; the leaning
        test holds the bricks leaned on as fixed, and the report's centre-of-mass test sees no
        sideways force. A brick frozen in such a place is kept frozen only when equilibrium
        holds its part; else the stack test's own mechanism wakes, when the push comes, and not
        after later loads on the bricks it pushed made the pose balance again (then even the
        end-of-run check said it stands). Stacks on level contacts never get here.
        Source: stackdsl's own (Livesley 1978, as :meth:`_equilibrium`).
        """
        stack = self.stack
        around, stack.leaning = stack.leaning, set()
        if stack.config.gravity <= 0:
            return []
        moving = self._mechanism(*self._frozen_problem(), around)
        reason = "it moves in the collapse mechanism (rigid-block equilibrium with friction)"
        return [w.event for b in stack.ordered(moving) for w in stack.wake(b, time, reason, moving)]

    def _frozen_problem(self) -> tuple[dict[int, RigidBlock], list[ContactPolygon[int]]]:
        """The frozen stack as free blocks, on the contact polygons remembered from the freezes
        (with each other, the ground and fixed bodies, and the watched bricks they lean on:
        :meth:`Stack.frozen_contacts`)."""
        stack = self.stack
        frozen = {r.body: r for r in stack.in_order()}
        blocks = {b: RigidBlock(r.box.mass, stack.pose(r).position) for b, r in frozen.items()}
        return blocks, stack.frozen_contacts(frozen)

    def _resting_on(self, part: dict[int, RigidBlock]) -> tuple[dict[int, RigidBlock], list[ContactPolygon[int]]]:
        """The active bricks lying face to face on a brick of ``part`` (not held by a hand) that
        would stand where they lie were their supports rigid, as free blocks, and their contact
        polygons. A frozen stack's statics without them could "prove" a collapse that their
        weight prevents: a balanced seesaw, frozen with one of its two loads while the other,
        placed with it, was still coming to rest, was woken again and again and its rocking
        taken for a collapse. Asked only when the rule fails a brick. Source: stackdsl's own."""
        stack = self.stack
        blocks: dict[int, RigidBlock] = {}
        polygons: list[ContactPolygon[int]] = []
        for rec in stack.active.values():
            if rec.body in stack.guided:
                continue
            pose = stack.engine.pose(rec.body)
            areas = self.areas.lying_on(rec, pose)
            if not any(other in part for other in areas):
                continue
            found = [
                ContactPolygon(rec.body, o, a.corners(), a.normal, pair_friction(rec.friction, stack.bodies[o].friction))
                for o, a in areas.items()
            ]
            block = RigidBlock(rec.box.mass, pose.position)
            if solve_equilibrium({rec.body: block}, found, gravity=stack.config.gravity).stands:
                blocks[rec.body] = block
                polygons += found
        return blocks, polygons

    def _balanced_by_loads(self) -> bool:
        """Do the report's loads, propagated down the frozen stack, balance it
        (:func:`stability._load_path.loads_balance`)? A cycle of supports has no such order: False."""
        frozen = self.stack.in_order()
        try:
            loads = propagate_fast(self.stack.nodes(frozen), self.stack.splits)
        except CycleError:
            return False
        return loads_balance(loads, {r.body: r.support_regions for r in frozen})

    def _part_passes(self) -> bool:
        """The report's test of the part of the frozen stack changed since the last test that
        every frozen brick passed (:meth:`stability._stack.Stack.changed_part`): its loads
        propagated alone (:func:`stability._load.propagate_part`), every other brick's kept. True
        when each brick of it passes (then so does the stack: every other brick carries what it
        carried then, and passed), and its loads are kept; False when one fails, or the part is
        over half the stack, or no loads are kept: the whole stack is then tested
        (:meth:`_report`), as before. In a row of 120 fallen dominoes each freeze propagated the
        loads of the whole row, where a domino's load reaches only what it leans on. Source:
        stackdsl's own."""
        stack = self.stack
        part = stack.changed_part()
        frozen = stack.frozen
        if part is None or 2 * len(part) > len(frozen):
            return False
        loads = stack.part_loads(part)
        if loads is None:
            return False
        for b, load in loads.items():
            rec = frozen[b]
            assert rec.main_contact is not None, "a frozen brick has a main contact area"
            if not (rec.held_by_pile() or rec.held_as(load) or self.areas.holds(rec.main_contact, load[0])):
                return False
        for b, load in loads.items():
            frozen[b].com_above, frozen[b].mass_above = load[0], load[1]
        stack.keep(loads, part=True)
        stack.loads_fresh = True
        return True

    def _undone(self, rec: Record) -> bool:
        """Is ``rec``'s freeze to be undone rather than the stack woken from it? When it was frozen
        in this very update and everything resting on it was frozen before, while it moved: the
        edge of a settled pile frozen leaning on it (:meth:`stability._stack.Stack.watch`). In a
        fallen domino row such a brick, frozen under the row leaning on it, failed the report's
        rule, and the row (43 bricks) woke with it, to freeze again. Undone, it stays active
        under the pile's edge as before it froze, and the engine goes on simulating it. A brick
        that bricks frozen in the same update rest on is not undone: they were frozen on it
        frozen. Asked only after rigid-block equilibrium of its part, which may hold it (then
        nothing is undone). Source: stackdsl's own."""
        stack = self.stack
        return (
            rec.body in stack.just_frozen
            and bool(rec.objects_above)
            and not any(b in stack.just_frozen for b in rec.objects_above)
        )

    def _report(self, time: float) -> list[StabilityEvent]:
        """Stack-wide test (report 3.3.1, 3.3.5) with the wake-up cascade (3.3.7).

        A brick whose centre of mass above lies outside its main contact area gives way
        (for a leaning brick the main contact area is the hull of all its contact areas,
        the other brick of a V included): it and everything above it wake.
        Beyond the report, twice. When the rule finds a failing brick, rigid-block equilibrium
        of its part of the frozen stack is asked first: when it stands, nothing wakes, and the
        rule does not ask again of that brick while its load is the same
        (:meth:`Record.held_as`). The report's load
        tree sends each load down its own supports only, so it fails a bridge or a counterweight
        that holds (a brick propped by a brick lying across it onto another support); woken,
        such bricks only sag, and on an engine's compliant contacts they sagged past the collapse
        threshold. When it does not stand, the bricks of a part that provably turns out about an
        edge (:func:`stability._cut.falling_part`) are marked as proved
        (:attr:`StabilityEvent.proved`). And the woken bricks above it
        that also rest on other stack bricks
        now lean on those alone, so the test is repeated with their load on them
        (co-support re-test). Without it a tower whose two sibling bricks carry it
        together stays pinned by the sibling that did not fail first (measured on the
        slant tower; docs/design.md, where the code departs from the report).

        Since equilibrium has the last word, nothing is propagated while every frozen brick
        lies over its load path (:mod:`stability._load_path`): the paths are a solution of
        its program, so the stack stands and nothing could wake. An upright tower then costs
        no propagation at all, where it cost one down the whole frozen stack at every freeze
        (docs/results/speed-against-error.md, "Cost against height"). The loads are then left
        stale (:meth:`refresh_loads` brings them up to date when the impact rule asks).
        """
        stack = self.stack
        events = self._leaning(time) if stack.leaning else []
        if stack.config.gravity > 0 and not stack.unproven:
            return events  # every brick over its load path: equilibrium stands (see above)
        if self._part_passes():
            return events
        gave_way: set[int] = set()
        leaning: dict[int, LoadNode] = {}
        proved: frozenset[int] | None = None
        while True:
            nodes = stack.nodes(stack.in_order())
            for body, node in leaning.items():
                kept = {s: a for s, a in node.supports.items() if s not in gave_way}
                if kept:
                    nodes[body] = LoadNode(node.mass, node.com, kept)
            loads = propagate_fast(nodes, stack.splits)
            failing = []
            for rec in stack.in_order():
                rec.com_above, rec.mass_above = loads[rec.body][0], loads[rec.body][1]
                assert rec.main_contact is not None, "a frozen brick has a main contact area"
                if rec.held_by_pile() or rec.held_as(loads[rec.body]):
                    continue
                if not self.areas.holds(rec.main_contact, rec.com_above):
                    failing.append(rec)
            if not failing:
                stack.loads_fresh = True
                stack.keep(None if leaning else loads)  # with woken bricks' loads in them, not the stack's
                return events
            if proved is None:  # before any of it wakes: what statics says of the stack as it stands
                # of the parts the failing bricks belong to: any other part is not in question,
                # with the active bricks lying on it, whose weight the rule does not see
                blocks, polygons = connected_part(*self._frozen_problem(), {r.body for r in failing})
                resting, on = self._resting_on(blocks)
                blocks, polygons = blocks | resting, polygons + on
                # a part that provably turns out is a proof that the stack does not stand: the
                # equilibrium program (milliseconds) is asked only when there is none
                proved = frozenset(falling_part(blocks, polygons) or ()) - resting.keys()
                if (
                    not proved
                    and stack.config.gravity > 0
                    and solve_equilibrium(blocks, polygons, gravity=stack.config.gravity).stands
                ):
                    stack.loads_fresh = True  # a bridge or a counterweight the rule cannot see: it stands
                    for rec in failing:  # under these loads: not asked again while they stay
                        rec.held = (loads[rec.body][1], *loads[rec.body][0])
                    stack.keep(None if leaning else loads)
                    return events
            undone = [r for r in failing if self._undone(r)]
            if undone:  # frozen this step under a pile's edge frozen on it while it moved, and statics
                # does not hold it: that freeze is undone, not the pile's (it leans on it as it did, watched)
                for rec in undone:
                    assert rec.main_contact is not None and rec.com_above is not None, "set above"
                    out = outside_support(rec, rec.com_above, stack.config.contact_pad) * 1000
                    reason = f"centre of mass above {out:.1f} mm outside its support: not frozen after all"
                    events += [w.event for w in stack.wake(rec.body, time, reason, alone=True)]
                    stack.watch(rec, set(rec.objects_above))
                    rec.failed = (Attempt(stack.version), time)  # asked again a rest duration on, or once the stack changes
                continue
            for rec in failing:
                if rec.state is not BrickState.FROZEN:  # woken already, resting on one that failed
                    continue
                gave_way.add(rec.body)
                assert rec.main_contact is not None and rec.com_above is not None, "set for every frozen brick above"
                out = outside_support(rec, rec.com_above, stack.config.contact_pad) * 1000
                for w in stack.wake(rec.body, time, f"centre of mass above {out:.1f} mm outside its support", proved):
                    events.append(w.event)
                    if w.body != rec.body:
                        leaning[w.body] = w.node


BARE_MATCH = 0.01
"""Fraction of the pad within which a padded point or segment, padded again, must give the area
back: the engine's points of one edge lie up to a micrometre off a line, and the pad of their
thin hull follows them (1.2 um for a brick resting on a block's edge)."""


def outside_support(rec: Record, com: np.ndarray | tuple[float, ...], pad: float) -> float:
    """Metres the horizontal projection of ``com`` lies outside ``rec``'s support, the said
    distance of a brick that gives way: to the hull of its support areas with the padding taken
    off again (the engine's one or two points of a corner or an edge, padded ``pad`` across to
    decide the stand, :func:`stability._geometry.padded_hull`), so that a centre of mass 3.1 mm
    past the edge a brick rests on is 3.1 mm out, not 2.1 mm past the padded one. A face lying
    on a face is exact already. The main contact area stands in when its areas do not make it
    up (a group frozen together). 0 over the support. Source: stackdsl's own."""
    assert rec.main_contact is not None, "a frozen brick has a main contact area"
    main = rec.main_contact.polygon
    areas = list(rec.rests_on.values())
    if not areas or shapely.union_all([a.polygon for a in areas]).convex_hull.hausdorff_distance(main) > 1e-9:
        areas = [rec.main_contact]
    hull = shapely.union_all([_bare(a, pad) for a in areas]).convex_hull
    point = Point(float(com[0]), float(com[1]))
    return 0.0 if hull.contains(point) else float(hull.distance(point))


def _bare(area: ContactArea, pad: float) -> BaseGeometry:
    """The contact ``area`` without its padding: the point or the segment that
    :func:`stability._geometry.padded_hull` padded to it (found by padding it again: within
    :data:`BARE_MATCH` of ``pad``), else the area itself.

    >>> from shapely.geometry import LineString
    >>> edge = padded_hull(np.array([[0.0, 0.0], [0.0, 0.024]]), 0.001)
    >>> _bare(ContactArea(edge, 0.0, np.array([0.0, 0.0, 1.0]), False), 0.001).equals(LineString([(0, 0), (0, 0.024)]))
    True
    >>> corner = padded_hull(np.array([[0.01, 0.0]]), 0.001)
    >>> _bare(ContactArea(corner, 0.0, np.array([0.0, 0.0, 1.0]), False), 0.001).distance(Point(0.01, 0.0)) < 1e-12
    True
    """
    polygon = area.polygon
    if area.exact or pad <= 0.0 or not hasattr(polygon, "exterior"):
        return polygon
    ring = np.asarray(polygon.exterior.coords)[:-1, :2]
    if len(ring) != 4:
        return polygon
    k = int(np.argmin(np.hypot(*(np.roll(ring, -1, axis=0) - ring).T)))  # a short side of a padded segment
    centre = ring.mean(axis=0, keepdims=True)
    ends = np.array([(ring[k] + ring[(k + 1) % 4]) / 2, (ring[(k + 2) % 4] + ring[(k + 3) % 4]) / 2])
    for points in (centre, ends):
        if padded_hull(points, pad).hausdorff_distance(polygon) < pad * BARE_MATCH:
            return MultiPoint(points).convex_hull
    return polygon

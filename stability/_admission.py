"""Admission: when a brick at rest is frozen (report 3.3.4, 3.4, 3.5).

The basic test freezes a brick whose centre of mass lies over its main contact area, unless
it rests on contacts at different heights (3.5); the leaning test freezes a brick that
touches two bodies, with a resting partner it leans on (the other brick of a V), when
friction holds them (3.4). Source: report 3.3.4, 3.4 and 3.5.
"""

from __future__ import annotations

import itertools
import math
from graphlib import CycleError, TopologicalSorter

import numpy as np

from ._areas import ContactAreas, Contacts, horizontal, main_area, overlap
from ._engine import ContactPoint
from ._equilibrium import LEVEL_TILT, ContactPolygon
from ._geometry import FACE_TILT, Box, ContactArea, Pose
from ._graph import BrickState
from ._leaning import leaning_stands, pair_friction
from ._stack import Record, StabilityEvent, Stack

#: Degrees: a brick tilted to its one support by more than faces lie face to face and less than
#: this is on one edge of it, rocking (:meth:`Admission._rocking`); more, and it leans.
ROCK_TILT = 10.0

Plan = dict[int, tuple[dict[int, ContactArea], ContactArea]]
"""How the members of a group are frozen: body -> (its supports, its main contact area)."""


class Admission:
    """The admission tests of one extension, on its stack and contact areas.

    Args:
        stack: the registered bodies.
        areas: their contact areas.

    Source: report 3.3.4, 3.4 and 3.5.
    """

    def __init__(self, stack: Stack, areas: ContactAreas) -> None:
        self.stack, self.areas, self.config = stack, areas, stack.config
        # the pose and supports :meth:`rocking` found last, with what they were found from
        self._rocked: tuple[Record, list[ContactPoint], tuple[int, int], Pose, dict[int, ContactArea]] | None = None

    def _supports(self, rec: Record, points: list[ContactPoint]) -> tuple[Pose, dict[int, ContactArea]]:
        """``rec``'s pose and its supports in the stack (:meth:`ContactAreas.supports`): those
        :meth:`rocking` found just before, when they were found from the same contact points
        (the step's), on the same stack, at the same pose, as each brick is asked first whether
        it rocks and then the basic test; else found anew."""
        stack, rocked = self.stack, self._rocked
        self._rocked = None
        pose = stack.engine.pose(rec.body)
        if (
            rocked is not None
            and rocked[0] is rec
            and rocked[1] is points
            and rocked[2] == (stack.version, stack.registrations)
            and rocked[3].position.tolist() == pose.position.tolist()
            and rocked[3].orientation.tolist() == pose.orientation.tolist()
        ):
            return rocked[3], rocked[4]
        return pose, self.areas.supports(rec, points, stack_only=True, pose=pose)

    def basic(self, rec: Record, contacts: Contacts, time: float) -> list[StabilityEvent]:
        """Single object stability (report 3.3.4): freeze when the COM is over the support."""
        areas, stack = self.areas, self.stack
        pose, supports = self._supports(rec, contacts[rec.body])  # one pose for every test: it stays until the freeze
        if not supports:
            return []
        heights = [a.height for a in supports.values()]
        if max(heights) - min(heights) > self.config.lean_height and not all(a.exact for a in supports.values()):
            return []  # report 3.5: contacts at different heights (not face to face on each): a leaning brick
        main = main_area(supports)
        position = pose.position
        if not areas.holds(main, position):
            return []
        held = {o: pts for o, pts in areas.touching(rec, contacts).items() if stack.bodies[o].state is not BrickState.ACTIVE}
        polygons = areas.polygons(rec, held, known=supports, pose=pose)
        if self.steep(rec, supports) and not leaning_stands({rec.body: (position, rec.box.mass)}, polygons, self.config.gravity):
            return []  # on a slope steeper than its friction angle, and nothing else holds it: it slides
        lift = overlap(contacts[rec.body], supports, areas.support_cos)
        stack.freeze(rec, supports, main, polygons, lift)
        names = ", ".join(stack.bodies[s].label for s in supports)
        return [StabilityEvent(time, "freeze", rec.label, f"at rest on {names}")]

    def rocking(self, rec: Record, contacts: Contacts) -> bool:
        """Whether ``rec``, a brick at rest by its speeds, lies on one support tilted to it
        (:meth:`_rocking`): at the turning point of a rock, not at rest on its support, so that no
        admission test (the basic, the leaning, the debris rule) is asked of it yet.

        Not when another body also presses up on it (an active brick it lies on, which the
        stack's supports leave out): propped on two bodies it is not rocking. A domino fallen
        7.7 deg onto the next one of a row 60 mm apart, still active, has the ground for its one
        stack support; called mid-rock every step, it was never handed to the debris rule, and
        the 50 dominoes of such a row stayed awake behind the front to the end (12,955
        refusals, 4.7 s, where the engine took 0.8 s).
        Source: stackdsl's own."""
        stack, points = self.stack, contacts[rec.body]
        pose = stack.engine.pose(rec.body)
        supports = self.areas.supports(rec, points, stack_only=True, pose=pose)
        self._rocked = (rec, points, (stack.version, stack.registrations), pose, supports)
        if not self._rocking(pose, supports):
            return False
        # propped: another body presses up on it, within the support angle, across no gap
        pad, support_cos, (support,) = stack.config.contact_pad, self.areas.support_cos, supports
        return not any(c.other != support and c.normal[2] >= support_cos and c.distance <= pad for c in points)

    def _rocking(self, pose: Pose, supports: dict[int, ContactArea]) -> bool:
        """Whether a brick on a single support lies tilted to it by more than faces that lie face
        to face may be (:data:`stability._geometry.FACE_TILT`, 0.5 deg) and less than
        :data:`ROCK_TILT`: its face almost on its support's face but touching it along an edge
        only, as a brick rocking on landing does at the still turning point of its rock (two
        bricks 0.6 and 0.8 mm inside their support's edge were frozen so, tilted 0.5 and 1.7 deg,
        at 0.13 deg in the last rest duration, and the later stack test on that pose put their
        centres of mass outside the support), or a brick woken by a shake or a blow does (a KAPLA
        brick on end rocked 11 deg by a shake was frozen 2.6 deg tilted on the ground, its top
        4.5 mm from its place, and called a collapse). At rest on its support is face to face: it is asked
        again once the engine has settled it, or it falls. Source: stackdsl's own."""
        if len(supports) != 1:
            return False  # on two supports a tilted brick can rest, bridging them
        ((body, area),) = supports.items()
        if area.exact:
            return False
        support = self.stack.bodies[body]
        if isinstance(support.shape, Box):  # its face nearest the horizontal: its top
            rotation = self.stack.pose(support).rotation
            up = rotation[:, int(np.argmax(np.abs(rotation[2])))]
        else:
            up = np.array([0.0, 0.0, 1.0])
        tilt = float(np.max(np.abs(pose.rotation.T @ up)))  # cosine of the angle between its face and the support's
        return math.cos(math.radians(ROCK_TILT)) < tilt < FACE_TILT

    def steep(self, rec: Record, supports: dict[int, ContactArea]) -> bool:
        """Whether a support of ``rec`` is tilted beyond its friction angle (tan tilt > mu of the
        pair). The basic test's vertical support forces are then outside that contact's friction
        cone, and only an equilibrium with friction (:func:`stability.leaning_stands`) can say
        whether the brick stays: a brick on a 17.5 deg ramp of friction 0.3 (16.7 deg) slides,
        one in a V-groove of two such ramps does not. With every support within its friction
        angle the vertical forces are admissible and the basic test is exact. A tilt under
        :data:`stability._equilibrium.LEVEL_TILT` is an engine's noise on a level face, never
        steep (friction 0 included). Source: stackdsl's own (Coulomb's law, report eq. 12, on
        the basic test of 3.3.4)."""
        bodies = self.stack.bodies
        return any(
            a.normal[2] * math.hypot(1.0, max(pair_friction(rec.friction, bodies[o].friction), LEVEL_TILT)) < 1.0
            for o, a in supports.items()
        )

    def leaning(self, rec: Record, contacts: Contacts, time: float, limit: int | None) -> list[StabilityEvent]:
        """Admit ``rec`` (with a resting partner it leans on, if any) when friction holds it.

        The report's leaning test (3.4): a brick touching two bodies (``limit``), at least
        one of them in the stack or the ground; with the equilibrium model any number of
        bodies (``limit`` None). The members are balanced by rigid-block equilibrium
        against what is frozen (:func:`stability.leaning_stands`).
        """
        group = self._group(rec, contacts, time, limit)
        if not group:
            return []
        areas = self.areas
        polygons = {
            m.body: areas.polygons(m, areas.touching(m, contacts), skip={g.body for g in group[:i]}) for i, m in enumerate(group)
        }
        members = {m.body: (self.stack.engine.pose(m.body).position, m.box.mass) for m in group}
        if not leaning_stands(members, [c for cs in polygons.values() for c in cs], self.config.gravity):
            return []
        return self.freeze_group(group, polygons, areas.touching(rec, contacts), contacts, time)

    def _group(self, rec: Record, contacts: Contacts, time: float, limit: int | None) -> list[Record]:
        """``rec`` and its partner, if it leans on one: an active brick at rest that touches
        ``rec`` and otherwise only the stack (the other brick of a V). Empty when ``rec``
        cannot be admitted this way."""
        bodies = self.stack.bodies
        touching = self.areas.touching(rec, contacts)
        if not self._leans(touching, limit):
            return []
        partners = [bodies[o] for o in touching if bodies[o].state is BrickState.ACTIVE]
        if not partners:
            return [rec]
        if len(partners) > 1:
            return []
        (partner,) = partners
        if not self.stack.rested(partner, time):
            return []  # what it touches is not asked: it still moves
        theirs = self.areas.touching(partner, contacts)
        if not (rec.body in theirs and self._leans(theirs, limit)):
            return []
        if any(bodies[o].state is BrickState.ACTIVE for o in theirs if o != rec.body):
            return []
        return [rec, partner]

    def _leans(self, touching: Contacts, limit: int | None) -> bool:
        """Two bodies (report 3.4.3; up to ``limit``, any number for None), at least one in
        the stack or the ground."""
        held = [o for o in touching if self.stack.bodies[o].state is not BrickState.ACTIVE]
        if limit is None:
            return bool(held)
        return 2 <= len(touching) <= limit and bool(held)

    def plan(self, group: list[Record], polygons: dict[int, list[ContactPolygon[int]]]) -> Plan:
        """How the members of a group would be frozen: each one's supports and main contact
        area, from its contacts in ``polygons`` (the one between two members under the later
        of them). A member lying only on other members rests on those lower than itself.

        A member that lies on nothing within the support angle (a domino fallen across its
        neighbours, a slanted tower's brick on the ones beside it, each contact steeper than
        the angle) rests on every body whose contact pushes it up: the equilibrium that
        admitted it held it on those contacts, and the brick graph shows what carries it,
        never a frozen brick resting on nothing. A contact pushes one of two members up and
        the other down, so they cannot rest on each other; should three or more rest on each
        other in a ring, each rests only on the members lower than itself (stackdsl's own,
        on the report's leaning contacts of 3.4.2)."""
        plan = self._plan(group, polygons, lower_only=False)
        members = {m.body for m in group}
        order = TopologicalSorter({b: [s for s in plan[b][0] if s in members] for b in members})
        try:
            order.prepare()
        except CycleError:
            return self._plan(group, polygons, lower_only=True)
        return plan

    def _plan(self, group: list[Record], polygons: dict[int, list[ContactPolygon[int]]], lower_only: bool) -> Plan:
        """:meth:`plan`; with ``lower_only``, a member rests on no member higher than itself."""
        members, plan = {m.body for m in group}, {}
        pad, up, engine = self.config.contact_pad, self.areas.support_cos, self.stack.engine
        for m in group:
            areas = {c.other: horizontal(c, pad) for c in polygons[m.body]}
            for g in group:  # the contacts with the other members, seen from this side
                if g is not m:
                    areas.update((g.body, horizontal(c, pad, flip=True)) for c in polygons[g.body] if c.other == m.body)
            # not a brick frozen resting on this one (it leaned on a settled pile's edge): a load
            supports = {o: a for o, a in areas.items() if o not in members and m.body not in self.stack.bodies[o].rests_on}
            resting = {o: a for o, a in supports.items() if a.normal[2] >= up}
            if not resting:  # on nothing within the angle: lower members within it, else what pushes it up
                z = engine.pose(m.body).position[2]
                lower = {o: a for o, a in areas.items() if o in members and engine.pose(o).position[2] < z}
                near = lower if lower_only else {o: a for o, a in areas.items() if o in members}
                pushing = {o: a for o, a in areas.items() if (o in supports or o in near) and a.normal[2] > 0.0}
                resting = {o: a for o, a in lower.items() if a.normal[2] >= up} or pushing or supports
            plan[m.body] = ({o: resting[o] for o in self.stack.ordered(resting)}, main_area(areas))
        return plan

    def freeze_group(
        self,
        group: list[Record],
        polygons: dict[int, list[ContactPolygon[int]]],
        touching: Contacts,
        contacts: Contacts,
        time: float,
        plan: Plan | None = None,
        pile: bool = False,
    ) -> list[StabilityEvent]:
        """Freeze the members of an admitted group (``group[0]`` the brick that asked) as
        ``plan`` says (:meth:`plan` when None), each raised out of what it rests on
        (:meth:`lifts`); the members wake together. ``touching``: what the brick that asked
        touches, or with ``pile`` (the debris rule's) what the whole group touches: then each
        event says so, two members as much as more (a pair's asker said "leaning on" bodies
        only its partner touched)."""
        rec, events = group[0], []
        plan = plan or self.plan(group, polygons)
        names = ", ".join(self.stack.bodies[o].label for o in touching if o != rec.body)
        lifts = self.lifts(group, plan, contacts)
        # a contact between two members is held under one of them (plan): the other names it too
        held_by: dict[int, list[int]] = {}
        for g in group:
            for other in dict.fromkeys(c.other for c in polygons[g.body]):
                held_by.setdefault(other, []).append(g.body)
        for m in group:
            resting, main = plan[m.body]
            self.stack.freeze(m, resting, main, polygons[m.body], lifts[m.body])
            # a partner names what it touches (its foot's support), and the brick that asked if it touches it
            asker = [rec.body] if m.body in touching else []
            held = [b for b in held_by.get(m.body, ()) if b != m.body]
            touched = dict.fromkeys([*(p.other for p in polygons[m.body] if p.other != rec.body), *held, *asker])
            on = names if m is rec else ", ".join(self.stack.bodies[o].label for o in touched)
            if len(group) > 2 or (pile and len(group) > 1):
                # the debris rule's (stability._debris): a brick still ringing, frozen with its pile, whose
                # motion as a whole is under the rest thresholds
                still = "at rest" if self.stack.rested(m, time) else "still creeping, in a pile at rest as a whole"
                together = f"{still}, one of {len(group)} touching bricks frozen together"
                reason = f"{together}; together they touch {on}" if m is rec else f"{together}, with {on}"
            else:
                reason = f"{'leaning on' if len(touching) > 1 else 'at rest on'} {on}"
            events.append(StabilityEvent(time, "freeze", m.label, reason))
        for a, b in itertools.pairwise(group):
            a.objects_above.add(b.body)
            b.objects_above.add(a.body)
        return events

    def lifts(self, group: list[Record], plan: Plan, contacts: Contacts) -> dict[int, float]:
        """Metres each member of a group is raised when frozen: out of its overlap with what it
        rests on (:func:`stability._areas.overlap`, from ``contacts``), plus the mean lift of
        the members among its supports, lowest member first. A pile at rest in the engine is
        pressed together by its own weight (0.2 to 0.5 mm between the levels of a column that
        fell back on itself); frozen so, its upper bricks would lie inside the lower ones.
        Source: stackdsl's own."""
        lifts: dict[int, float] = {}
        for m in sorted(group, key=lambda r: float(self.stack.engine.pose(r.body).position[2])):
            resting = plan[m.body][0]
            faces = {o: self.areas.face_to_face(m, self.stack.bodies[o]) or a for o, a in resting.items()}
            carried = [lifts.get(o, 0.0) for o in resting]
            own = overlap(contacts[m.body], faces, self.areas.support_cos)
            lifts[m.body] = own + (sum(carried) / len(carried) if carried else 0.0)
        return lifts

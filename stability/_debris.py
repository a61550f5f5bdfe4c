"""The debris rule: fallen bricks at rest are frozen again (stackdsl's own).

A brick the admission tests refuse is admitted with every resting brick it touches, and they
with theirs (the connected pile), when rigid-block equilibrium holds them all against what
is frozen (:func:`stability.leaning_stands`): bricks that fell and lie still, alone or leaning
on each other, then cost nothing. A pile is at rest as a whole when its kinetic energy is at
most what it would carry if every brick in it moved at the rest thresholds, and each of its
fallen bricks is within the instantaneous bounds of the windowed test of
:mod:`stability._rest` (:meth:`Debris._at_rest`): the bricks of a settling heap that ring on
for a few tenths of a second, each in turn, must not keep the whole heap in the engine.
When the whole pile does not stand, the bricks its collapse mechanism moves are left out and
the rest is tried again. That equilibrium, not the report's centre-of-mass test, then holds
the bricks that fell, until something else comes to rest on one of them; a pile that comes to
rest on bricks frozen with an earlier pile is solved and frozen with them as one pile.

A pile need not wait for every brick it touches. While bricks beyond it still move, the part
of it that has settled (each brick at rest by the windowed test, connected through bricks at
rest) is solved and frozen on its edge: the bricks at rest that touch one that is not stay
active, and the part leans on them as they are, as on fixed supports, only if it lies on them
(were an edge brick to lie on it, the two could later carry each other). The stack watches
each such edge brick (:meth:`stability._stack.Stack.watch`): once a corner of it has moved
:data:`stability._extension.WATCH` from where it was, what leans on it wakes. In a row of
dominoes each fallen domino leans on the next, which leans on the next, up to the chain's
front: the whole row waited for the last domino to land, and every domino it had reached was
simulated until then (at 120 dominoes, 144,000 brick-steps where about 20 move at a time).
Source: stackdsl's own, on the report's rigid-block reading of leaning (3.4).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable
from graphlib import CycleError
from typing import Literal

from ._admission import Admission, Plan
from ._areas import ContactAreas, Contacts
from ._equilibrium import ContactPolygon, Equilibrium, RigidBlock, connected_part, solve_equilibrium
from ._graph import BrickState
from ._leaning import leaning_stands
from ._load import LoadNode, Loads, propagate_fast
from ._stack import Record, StabilityEvent, Stack

MAX_PILE = 64
"""Most bricks the debris rule admits at once (one equilibrium program over all of them)."""

BACKOFF = 4
"""The most doublings of the wait of a pile refused again and again (:meth:`Debris._waiting`):
16 rest durations."""

MAX_TRIMS = 3
"""How many times a pile that does not stand is tried again without the bricks its collapse
mechanism moves."""

SETTLED: Literal["settled"] = "settled"
"""What :meth:`Debris._pile` found of a pile with a brick that still moves: the part that has
settled is asked for (:meth:`Debris._settled`)."""

Gathered = tuple[Record, ...] | Literal["settled"]
"""A pile found at rest (its bricks in registration order; none when it touches nothing frozen),
or :data:`SETTLED`."""


class Debris:
    """The debris rule of one extension.

    A refused pile is not solved again until the stack changes or one of its bricks moves
    faster than the rest thresholds: a pile that creeps below them is still the pile refused.

    Args:
        stack: the registered bodies.
        areas: their contact areas.
        admission: the admission tests (how a group is frozen).

    Source: stackdsl's own.
    """

    def __init__(self, stack: Stack, areas: ContactAreas, admission: Admission) -> None:
        self.stack, self.areas, self.admission = stack, areas, admission
        self._refused: tuple[int, set[tuple[tuple[int, float | None], ...]]] = (0, set())  # piles refused, at a version
        # each pile refused, by its bricks: how many times in a row, and when last (:meth:`_waiting`)
        self._backoff: dict[frozenset[int], tuple[int, float]] = {}
        self._edge: dict[int, Record] = {}  # the last pile's members that touch bricks that still move
        # what :meth:`_pile` and :meth:`_settled` found this step, on this stack, for each brick
        # of the piles they gathered (:meth:`_gathered`)
        self._found: tuple[
            tuple[float, int], Contacts | None, dict[int, Gathered], dict[int, tuple[list[Record], dict[int, Record]]]
        ] = ((-1.0, -1), None, {}, {})

    def admit(self, rec: Record, contacts: Contacts, time: float) -> list[StabilityEvent]:
        """Admit ``rec`` with its pile, or the part of it that stands (:meth:`_standing`), when
        rigid-block equilibrium holds it against what is frozen and, with the report model,
        the stack test would keep it frozen; nothing while a brick of the pile still moves or
        it touches nothing frozen. A refused pile is refused for every member: none of them
        asks again until something it depends on changes (:meth:`Stack.attempt`).

        With the report model the pile must also leave the frozen stack under it standing by
        the report's stack test, with the pile's loads on it. The members that fell are not
        tested by it while nothing else rests on them (:meth:`Record.held_by_pile`): a pile
        that rests on the stack and on the ground at once (a tower fallen against the floor)
        stands by friction, which the report's load tree cannot carry (it sends every load
        down to the stack), so the test would wake it at once and it would be frozen and
        woken again every rest duration.
        """
        stack, areas = self.stack, self.areas
        self._edge = {}
        group = self._pile(rec, contacts, time)
        edge = self._edge
        if self._refused[0] != stack.version:
            self._refused = (stack.version, set())
        key = tuple((m.body, m.clock.since) for m in group)
        members = frozenset(m.body for m in group)
        if not group or key in self._refused[1] or self._waiting(members, time):
            return []
        skip: set[int] = set()
        polygons = {}
        for m in group:
            polygons[m.body] = areas.polygons(m, areas.around(m, contacts), skip=skip)
            skip.add(m.body)
        whole = group
        with_stack = self._with_stack(group, polygons)
        earlier: list[Record] = []
        if with_stack is not None:
            group, polygons = with_stack
            plan = self.admission.plan(group, polygons)
        else:
            group, polygons, plan, earlier = self._admissible(group, polygons, self._earlier(group, contacts))
        if not group:
            self._refused[1].add(key)
            refusals = self._backoff[members][0] + 1 if members in self._backoff else 1
            self._backoff[members] = (refusals, time)
            for m in whole:
                m.failed = (stack.attempt(m, contacts, time), time)
            return []
        self._backoff.pop(members, None)
        inside = {m.body for m in group}
        held: Contacts = {
            o: []
            for m in group
            for o in areas.around(m, contacts)
            if o not in inside and (stack.bodies[o].state is not BrickState.ACTIVE or o in edge)
        }
        touching = {o: held[o] for o in stack.ordered(held)}
        events = self.admission.freeze_group(group, polygons, touching, contacts, time, plan, pile=True)
        for body, brick in edge.items():  # the frozen members lean on a brick that is still active: watched
            leaning = {m.body for m in group if body in areas.neighbours(m, contacts)}
            if leaning:
                stack.watch(brick, leaning)
        if with_stack is not None:
            stack.standing_version = stack.version  # the stack test's program, solved already
        pile = frozenset(inside | {r.body for r in earlier})
        for m in group:
            m.pile = pile if m.clock.fallen else frozenset()
        for a, b in itertools.pairwise([group[0], *earlier]):  # one pile: its bricks wake together
            a.objects_above.add(b.body)
            b.objects_above.add(a.body)
            b.pile = pile
            stack.touched(b.body)
        return events

    def _waiting(self, members: frozenset[int], time: float) -> bool:
        """Whether the pile of the bricks ``members``, refused ``k`` times in a row, is still
        waiting: the same bricks are asked again 2 ** (k - 1) rest durations after their last
        refusal (doubled at most :data:`BACKOFF` times: 16 rest durations), not every rest
        duration. A pile that creeps
        at the edge of its friction is refused again and again, each time by a program of its
        every contact: the 40 fallen bricks of a slant log cabin were refused 19 times in 1 s,
        0.3 s of programs each, where the engine steps them 0.1 s of time in 10 ms. Source:
        stackdsl's own (exponential backoff)."""
        if members not in self._backoff:
            return False
        refusals, when = self._backoff[members]
        wait = self.stack.config.rest_duration * 2.0 ** min(refusals - 1, BACKOFF)
        return time - when < wait - 1e-9

    def _with_stack(
        self, group: list[Record], polygons: dict[int, list[ContactPolygon[int]]]
    ) -> tuple[list[Record], dict[int, list[ContactPolygon[int]]]] | None:
        """With the equilibrium model, the part of a pile of two or more bricks that stands
        with every frozen brick a free block too, on the contacts remembered from their
        freezes, and its polygons. That is the program the stack test would solve once the
        pile is frozen, so one program does for both (:attr:`Stack.standing_version`). When
        the pile does not stand, the members its collapse mechanism moves are left out and the
        rest is tried again, as :meth:`_standing` does. None when the mechanism moves a frozen
        brick, or fewer than two members are left: then the pile is solved against the frozen
        bricks as supports (:meth:`_admissible`) and the stack test decides, as before. Tried
        only for a pile at least as large as the frozen stack, so that the program is at most
        twice the pile's own: a few bricks that come to rest on a large stack are refused and
        asked again many times, and each refusal would cost the program of the whole stack. A
        pile of one is left to :func:`stability.leaning_stands`, which needs no program while
        its centre of mass lies over its level contacts."""
        stack = self.stack
        if stack.config.model != "equilibrium" or len(group) < max(2, len(stack.frozen)):
            return None
        frozen = self._frozen_blocks()
        for _ in range(MAX_TRIMS + 1):
            blocks, contacts = self._with_frozen(group, polygons, frozen)
            result = solve_equilibrium(blocks, contacts, gravity=stack.config.gravity, decide=True)
            if result.stands:
                return group, polygons
            out = result.moving()
            if not out or any(b in frozen for b in out):
                return None
            group, polygons = _without(group, polygons, out)
            if len(group) < 2:
                return None
        return None

    def _admissible(
        self, group: list[Record], polygons: dict[int, list[ContactPolygon[int]]], earlier: list[Record]
    ) -> tuple[list[Record], dict[int, list[ContactPolygon[int]]], Plan, list[Record]]:
        """The part of ``group`` that may be frozen, its polygons, its plan, and the bricks of
        earlier piles it is frozen with (``earlier``, :meth:`_earlier`, or none): the
        report's test of the stack under it first (it costs far less than equilibrium),
        with ``earlier`` as stack bricks; when that fails, with ``earlier`` in the pile.
        An empty part when none may be frozen."""
        plan = self.admission.plan(group, polygons)
        for together in ([], earlier) if earlier else ([],):
            if not self._carried(group, polygons, plan, together):
                continue
            part, parts = self._standing(group, polygons, together)
            if not part:
                return [], {}, {}, []  # with ``earlier`` free too it would not stand either
            if len(part) == len(group):
                return part, parts, plan, together
            kept = self.admission.plan(part, parts)  # the trimmed part: its loads on the stack again
            if self._carried(part, parts, kept, together):
                return part, parts, kept, together
        return [], {}, {}, []

    def _earlier(self, group: list[Record], contacts: Contacts) -> list[Record]:
        """With the report model, the frozen bricks that ``group`` touches and that an earlier
        debris pile holds (:meth:`Record.held_by_pile`; a fallen brick frozen alone is a pile
        of one), with the rest of their piles, in registration order. When the report's test
        cannot hold them as stack bricks under ``group`` (a brick that fell onto its edge on
        the floor, under the heap of the rest of the tower), they are solved with ``group``
        as free blocks (:meth:`_together`) and the two become one pile. Empty with the
        equilibrium model, whose stack test solves every frozen brick anyway."""
        stack = self.stack
        if stack.config.model != "report":
            return []
        found: dict[int, Record] = {}
        for m in group:
            for o in self.areas.neighbours(m, contacts):
                held = stack.bodies[o]
                if held.state is BrickState.FROZEN and held.held_by_pile() and o not in found:
                    members = (stack.bodies[b] for b in held.pile)
                    found.update((r.body, r) for r in members if r.state is BrickState.FROZEN and r.held_by_pile())
        return sorted(found.values(), key=lambda r: r.order)

    def _standing(
        self, group: list[Record], polygons: dict[int, list[ContactPolygon[int]]], earlier: list[Record]
    ) -> tuple[list[Record], dict[int, list[ContactPolygon[int]]]]:
        """The part of ``group`` that rigid-block equilibrium holds against what is frozen, with
        its contact polygons (``polygons``: each member's, the one between two members once):
        the whole pile, or, when it does not stand, the pile without the bricks its collapse
        mechanism moves, tried again up to :data:`MAX_TRIMS` times. Empty when no part stands.
        With ``earlier`` (frozen bricks of earlier piles, :meth:`_earlier`), the part found
        must also stand with them as free blocks (:meth:`_together`).

        The bricks left out stay in the engine, on the part frozen, and are asked again: the
        top bricks of a fallen log cabin that lean on the pile by less friction than they need
        must not keep the 30 bricks under them in the engine."""
        gravity = self.stack.config.gravity
        for _ in range(MAX_TRIMS + 1):
            members = {m.body: (self.stack.engine.pose(m.body).position, m.box.mass) for m in group}
            contacts = [c for cs in polygons.values() for c in cs]
            if len(group) == 1 and not earlier:
                return (group, polygons) if leaning_stands(members, contacts, gravity) else ([], {})
            blocks = {b: RigidBlock(mass, com) for b, (com, mass) in members.items()}
            if earlier:
                result = self._together(blocks, contacts, earlier)
            else:
                result = solve_equilibrium(blocks, contacts, gravity=gravity, decide=True)
            if result.stands:
                return group, polygons
            out = result.moving() & members.keys()
            group, polygons = _without(group, polygons, out)
            if not (group and out):
                break
        return [], {}

    def _together(
        self, blocks: dict[int, RigidBlock], contacts: list[ContactPolygon[int]], earlier: list[Record]
    ) -> Equilibrium[int]:
        """Rigid-block equilibrium of ``blocks`` on ``contacts`` with the frozen bricks
        ``earlier`` as free blocks too, on the contacts remembered from when they, or the
        frozen bricks they touch, were frozen (two frozen bodies report no contacts)."""
        stack = self.stack
        together = dict(blocks)
        together.update((r.body, RigidBlock(r.box.mass, stack.pose(r).position)) for r in earlier)
        pile = {r.body for r in earlier}
        remembered = [
            c
            for r in stack.in_order()
            for c in r.contacts
            if (c.body in pile or c.other in pile) and stack.bodies[c.other].state is not BrickState.ACTIVE
        ]
        return solve_equilibrium(together, contacts + remembered, gravity=stack.config.gravity, decide=True)

    def _carried(
        self, group: list[Record], polygons: dict[int, list[ContactPolygon[int]]], plan: Plan, earlier: list[Record]
    ) -> bool:
        """Would the report's stack test keep the frozen stack under ``group`` frozen, with
        ``group`` frozen as ``plan`` says (on ``polygons``)? The members that fell, and the
        bricks of an earlier pile solved with them (``earlier``), are held by rigid-block
        equilibrium, which the test then leaves to them (:meth:`Record.held_by_pile`); a member
        never woken is tested as the report tests a placed brick.

        A frozen brick the rule fails is then asked of rigid-block equilibrium, as the stack
        test asks it (:meth:`stability._stack_test.StackTest.run`): its part of the frozen
        stack, with ``group`` as free blocks, must stand (:meth:`_held_with`). Without that, a
        fallen domino that equilibrium held leaning back on the one before it failed the rule
        once the pile beyond it froze and changed its load, and every later pile of the row
        was refused: 13 dominoes of a 20 row stayed in the engine, at rest, for 2 s.
        Always True with the equilibrium model (its stack test is the equilibrium that
        :func:`stability.leaning_stands` checks)."""
        stack = self.stack
        if stack.config.model != "report":
            return True
        trial = {m.body: LoadNode(m.box.mass, stack.engine.pose(m.body).position, plan[m.body][0]) for m in group}
        loaded = {s for m in group for s in plan[m.body][0]}  # they lose the exemption unless in the pile
        loads = self._part_loads(trial, loaded)
        if loads is not None:  # every other frozen brick carries what it did at the last stack test, and passed
            mains = {b: stack.frozen[b].main_contact for b in loads if b not in trial}
        else:
            frozen = stack.in_order()
            nodes = stack.nodes(frozen)
            mains = {r.body: r.main_contact for r in frozen}
            nodes.update(trial)
            try:
                loads = propagate_fast(nodes, stack.splits)
            except CycleError:  # the group and the stack would carry each other: not frozen so
                return False
        mains.update((m.body, plan[m.body][1]) for m in group)
        fallen = {m.body for m in group if m.clock.fallen} | {r.body for r in earlier}
        failing = {
            b
            for b, main in mains.items()
            if b not in fallen
            and (b in loaded or not stack.bodies[b].held_by_pile())
            and not stack.bodies[b].held_as(loads[b])
            and not (main is not None and self.areas.holds(main, loads[b][0]))
        }
        if not failing:
            return True
        if failing & trial.keys():  # a member never woken fails as a placed brick would
            return False
        return self._held_with(group, polygons, failing)

    def _held_with(self, group: list[Record], polygons: dict[int, list[ContactPolygon[int]]], failing: set[int]) -> bool:
        """Does rigid-block equilibrium hold the part of the frozen stack that the frozen bricks
        ``failing`` belong to, with ``group`` frozen too (free blocks on ``polygons``), on the
        contacts remembered from the freezes?"""
        blocks, contacts = self._with_frozen(group, polygons, self._frozen_blocks())
        part, on = connected_part(blocks, contacts, failing)
        return solve_equilibrium(part, on, gravity=self.stack.config.gravity, decide=True).stands

    def _frozen_blocks(self) -> dict[int, RigidBlock]:
        """Every frozen brick as a free block where it froze."""
        return {r.body: RigidBlock(r.box.mass, self.stack.pose(r).position) for r in self.stack.in_order()}

    def _with_frozen(
        self, group: list[Record], polygons: dict[int, list[ContactPolygon[int]]], frozen: dict[int, RigidBlock]
    ) -> tuple[dict[int, RigidBlock], list[ContactPolygon[int]]]:
        """The program of ``group`` (free blocks where they lie, on ``polygons``) with the
        ``frozen`` bricks as free blocks too, on the contacts remembered from their freezes."""
        blocks = {m.body: RigidBlock(m.box.mass, self.stack.engine.pose(m.body).position) for m in group}
        blocks.update(frozen)
        return blocks, [c for cs in polygons.values() for c in cs] + self.stack.frozen_contacts(blocks)

    def _part_loads(self, trial: dict[int, LoadNode], loaded: set[int]) -> Loads | None:
        """The loads of the bricks of ``trial`` (body -> its node were it frozen) and of the frozen
        bricks whose loads they, or the changes since the last stack test, reach
        (:meth:`Stack.changed_part`), propagated alone (:func:`stability._load.propagate_part`),
        the other frozen bricks' kept: None when no loads are kept, the part is over half the
        stack, or it must be propagated whole (a cycle, a brick after its supports)."""
        part = self.stack.changed_part(loaded)
        if part is None or 2 * (len(part) + len(trial)) > len(self.stack.frozen):
            return None
        return self.stack.part_loads(part, trial)

    def _gathered(
        self, contacts: Contacts, time: float
    ) -> tuple[dict[int, Gathered], dict[int, tuple[list[Record], dict[int, Record]]]]:
        """What :meth:`_pile` and :meth:`_settled` gathered at ``time`` on this stack and these
        ``contacts``, for every brick their searches reached: a pile, and the part of it that
        has settled, are the same from any of their bricks, and nothing they depend on (states,
        rest clocks, speeds, contacts) changes in a step but by a freeze or a wake, which
        changes the stack's version. A heap that settles asks for each of its resting bricks in
        turn: the 18-level Jenga tower's 39 fallen bricks were refused 114 times, each refusal
        searching the heap again."""
        key = (time, self.stack.version)
        if self._found[0] != key or self._found[1] is not contacts:  # the step's contacts, read once a step
            self._found = (key, contacts, {}, {})
        return self._found[2], self._found[3]

    def _pile(self, rec: Record, contacts: Contacts, time: float) -> list[Record]:
        """``rec`` and the active bricks connected to it by contacts, in registration order;
        empty when none of them touches a frozen brick or the ground. When one of them still
        moves, or the pile is not at rest as a whole (:meth:`_at_rest`), the part of it that
        has settled (:meth:`_settled`)."""
        piles, _ = self._gathered(contacts, time)
        found = piles.get(rec.body)
        if found is not None:
            return self._settled(rec, contacts, time) if found == SETTLED else list(found)
        pile, queue, held = {rec.body: rec}, [rec], False
        while queue:
            for other in self.areas.neighbours(queue.pop(), contacts):  # the pile is the same in any order
                o = self.stack.bodies[other]
                if o.state is not BrickState.ACTIVE:
                    held = True
                elif other not in pile:
                    if len(pile) >= MAX_PILE or o.clock.since is None or o.proved_at is not None:
                        piles.update(dict.fromkeys(pile, SETTLED))  # from any of them the search meets o
                        return self._settled(rec, contacts, time)
                    pile[other] = o
                    queue.append(o)
        if not held or not self._at_rest(pile.values(), time):
            piles.update(dict.fromkeys(pile, SETTLED if held else ()))
            return self._settled(rec, contacts, time) if held else []
        whole = sorted(pile.values(), key=lambda r: r.order)
        piles.update(dict.fromkeys(pile, tuple(whole)))
        return whole

    def _settled(self, rec: Record, contacts: Contacts, time: float) -> list[Record]:
        """The part of a pile that has settled while bricks beyond it still move: ``rec`` and the
        bricks at rest (:meth:`Stack.rested`) connected to it through bricks at rest, without those
        that touch a brick that is not (its edge, :attr:`_edge`: they stay active, and the rest
        leans on them as they are, watched, :meth:`Stack.watch`)."""
        stack = self.stack
        if not stack.rested(rec, time) or rec.proved_at is not None:
            return []
        _, parts = self._gathered(contacts, time)
        found = parts.get(rec.body)
        if found is None:
            pile, found = self._settled_part(rec, contacts, time)
            parts.update(dict.fromkeys(pile, found))  # the same part from any brick at rest in it
        inner, self._edge = found
        return list(inner)

    def _settled_part(
        self, rec: Record, contacts: Contacts, time: float
    ) -> tuple[list[int], tuple[list[Record], dict[int, Record]]]:
        """:meth:`_settled`'s search from ``rec`` (at rest): the bricks it reached, and the part
        found with its edge (none, and no edge, when no part may be frozen)."""
        stack = self.stack
        pile, queue, held = {rec.body: rec}, [rec], False
        edge: set[int] = set()
        nothing: tuple[list[Record], dict[int, Record]] = ([], {})
        while queue:
            m = queue.pop()
            for other in self.areas.neighbours(m, contacts):
                o = stack.bodies[other]
                if o.state is not BrickState.ACTIVE:
                    held = True
                elif other not in pile:
                    if o.body in stack.guided:
                        return list(pile), nothing
                    if not stack.rested(o, time) or o.proved_at is not None:
                        edge.add(m.body)
                        continue
                    if len(pile) >= MAX_PILE:
                        return list(pile), nothing
                    pile[other] = o
                    queue.append(o)
        inner = [r for b, r in pile.items() if b not in edge]
        if not held or not edge or not inner or not self._at_rest(pile.values(), time):
            return list(pile), nothing
        # the settled part only lies on its edge: were an edge brick to lie on it, or lean on it
        # sideways, it could later be frozen on the part, and the two would carry each other
        up = self.areas.support_cos
        if any(c.other in edge and c.normal[2] < up for m in inner for c in contacts[m.body]):
            return list(pile), nothing
        return list(pile), (sorted(inner, key=lambda r: r.order), {b: pile[b] for b in edge})

    def _at_rest(self, pile: Iterable[Record], time: float) -> bool:
        """Is a pile at rest as a whole? Each member is at rest (:meth:`Stack.rested`) or is a
        fallen brick that creeps: its rest clock runs (its speeds are within the windowed
        test's bounds, :data:`stability._rest.JITTER` times the thresholds) but it has not yet
        been still for a whole window. And the pile's kinetic energy is at most what it would
        carry if every member moved at the rest thresholds: its root-mean-square motion is
        under them. Spin counts about each brick's largest moment of inertia (an upper bound).
        """
        config = self.stack.config
        energy = allowed = 0.0
        for m in pile:
            if not (self.stack.rested(m, time) or (m.clock.fallen and m.clock.since is not None)):
                return False
            speed, angular_speed = self.stack.engine.speeds(m.body)
            a, b = sorted(m.box.half_extents)[1:]
            spin = (a * a + b * b) / 3  # the largest moment of inertia over the mass, m^2
            energy += m.box.mass * (speed**2 + spin * angular_speed**2)
            allowed += m.box.mass * (config.rest_speed**2 + spin * config.rest_angular_speed**2)
        return energy <= allowed


def _without(
    group: list[Record], polygons: dict[int, list[ContactPolygon[int]]], out: set[int]
) -> tuple[list[Record], dict[int, list[ContactPolygon[int]]]]:
    """``group`` and its contact polygons without the bricks ``out`` (a collapse mechanism's)."""
    kept = {b: [c for c in cs if c.other not in out] for b, cs in polygons.items() if b not in out}
    return [m for m in group if m.body not in out], kept

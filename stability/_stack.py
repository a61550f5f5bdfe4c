"""The registered bodies and the frozen stack: who is active, who is frozen and on what.

Each body's record holds what report Figure 3 keeps of a brick (its supports, main contact
area, the bricks above it, centre of mass above and mass above) with the contact polygons of
3.4. The stack freezes a body on the engine (recording what it rests on) and wakes it with
everything resting on it (3.3.7). Source: report 3.3.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable, Mapping, Sequence
from collections.abc import Set as AbstractSet
from dataclasses import dataclass, field
from typing import Literal, NamedTuple

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from ._config import StabilityConfig
from ._engine import ContactBook, ContactPoint, Engine
from ._equilibrium import ContactPolygon, is_level
from ._geometry import Box, ContactArea, Plane, Pose, combined_hull, moved_at_most
from ._graph import BrickState
from ._load import LoadNode, Loads, Splits, propagate_part
from ._load_path import load_path, proven, share_region, support_piece
from ._rest import RestClock

BOUND_SLACK = 1e-6
"""Metres under the watch's distance that a bound on how far a watched brick's corners moved
(:meth:`Stack.moved_away`) must lie to answer without the corners: far above the bound's
round-off (its turn's acos near 1 is off by some 1e-8 rad, times a half diagonal of 0.06 m), so
the answer is the corners' own."""

LONE_KEPT = 4096
"""Most lone bricks whose last change is kept between two changes of linked ones (:meth:`Stack.soon`);
past it every change counts, as any did before."""

HELD_SAME = 1e-9
"""kg and metres: a load within this of the one rigid-block equilibrium held a brick under is
that load (:meth:`Record.held_as`): frozen poses do not change, so the same bricks above give
the same numbers but for round-off."""

Extent = tuple[float, float, float, float, float]
"""A frozen brick's bounding box: top z, x min, x max, y min and y max (m)."""


@dataclass(frozen=True)
class StabilityEvent:
    """Something the extension did: ``kind`` is ``"freeze"``, ``"wake"``, ``"impact"``
    (an impact the stack held; every landing brick makes one) or ``"ride"`` (a frozen brick
    that moves with others as one rigid body on a shaken ground, until it wakes); time in s; ``source`` is
    the impactor of an impact or of the wake it caused; ``proved``: a wake of a brick that
    moves in a collapse mechanism statics proved (rigid-block equilibrium, or a part that
    turns out about an edge of its footing), not only one the report's rules suspect, or a
    freeze that statics on the placed geometry decided on a near tie (the engine's contact
    margin would have decided it by chance); ``falling``: a wake of a brick whose ride on a
    pulled or pushed brick tipped over (:meth:`stability.StabilityExtension._rides`): it falls
    with the ride's other bricks, and an engine may step it as debris, more cheaply."""

    time: float
    kind: Literal["freeze", "wake", "impact", "ride"]
    label: str
    reason: str
    source: str = ""
    proved: bool = False
    falling: bool = False


class Woken(NamedTuple):
    """A brick just woken, with the load node it had when frozen (a woken brick may still
    rest on the stack: the stack test reloads what it still rests on)."""

    body: int
    node: LoadNode
    event: StabilityEvent


class Attempt(NamedTuple):
    """What an admission of a brick depended on when it was refused (:meth:`Stack.attempt`): the
    stack's version, the brick's pose rounded (to 0.1 mm and 0.01 rad), and the bodies it touched,
    each with whether it was frozen or at rest then; ``around`` None when any change of the stack
    counts (a freeze undone by the stack test)."""

    version: int
    where: tuple[int, ...] = ()
    around: tuple[tuple[int, bool], ...] | None = None


class Ride(NamedTuple):
    """Frozen bricks merged into one body in the engine (:meth:`Stack.ride`), riding a pull, or
    a shaken ground they slide on or are carried by."""

    label: str  # the pulled brick's, or the ground's
    riders: tuple[int, ...]  # in the order they froze
    ground: int | None = None  # the shaken ground, for a ride of a shake


@dataclass
class Record:
    """Per-body data of report Figure 3 (Brick), with the leaning contacts of 3.4."""

    body: int
    label: str
    shape: Box | Plane
    state: BrickState
    order: int
    friction: float
    rests_on: dict[int, ContactArea] = field(default_factory=dict)
    main_contact: ContactArea | None = None
    contacts: list[ContactPolygon[int]] = field(default_factory=list)
    objects_above: set[int] = field(default_factory=set)
    com_above: tuple[float, float, float] | None = None
    mass_above: float = 0.0
    clock: RestClock = field(default_factory=RestClock)
    frozen_pose: Pose | None = None
    node: LoadNode | None = None
    impacted: set[int] = field(default_factory=set)
    load_path: BaseGeometry | None = None
    support_regions: dict[int, BaseGeometry] = field(default_factory=dict)  # where it may push on each support
    failed: tuple[Attempt, float] | None = None  # its last refusal: what it depended on, when
    extent: Extent | None = None  # frozen: top z, x min, x max, y min, y max (m)
    placed_at: float | None = None  # s: when the extension's update first saw it
    was_frozen: bool = False  # frozen at least once (a woken brick is the debris rule's)
    carried: tuple[float, tuple[int, ...]] | None = None  # its last load check (carry): when (s), and on what
    pile: frozenset[int] = frozenset()  # a fallen brick's debris pile (itself, frozen alone), which rigid-block equilibrium holds
    held: tuple[float, float, float, float] | None = None  # kg, m: its mass and centre of mass above when equilibrium held it
    proved_at: np.ndarray | None = (
        None  # corners (8, 3), m, where it was woken in a proved collapse mechanism: held active until it moves (RELEASE)
    )
    still_from: tuple[np.ndarray, float] = field(
        default_factory=lambda: (np.zeros((8, 3)), 0.0)
    )  # held: corners where, and since when (s), it has stayed within STILL
    still: bool = False  # held once and kept still by the engine: not held again
    leans: bool = False  # frozen, and its balance or that of a brick under it needs a non-level contact (_prove)
    near_tie: float = 0.0  # m: the engine's contact margin (StabilityExtension._landings)
    set_down: np.ndarray | None = None  # corners (8, 3), m, where a hand set it down (placed; StabilityExtension._landings)
    landing: bool = False  # placed or with a near tie, and not yet looked at landed (StabilityExtension._landings)
    landing_from: float | None = None  # s: when the extension first looked for its landing
    seq: int = 0  # frozen: its place in the order the frozen bricks froze in (Stack.frozen's)
    lift: float = 0.0  # m: how far it was raised out of its supports when it froze (Stack.freeze)
    lowered: tuple[float, float] = (-math.inf, 0.0)  # when it last woke (s), and how far it was lowered then (m)

    def held_by_pile(self) -> bool:
        """Fallen, frozen again with a debris pile that rigid-block equilibrium holds, and
        nothing else has come to rest on it since: the report's centre-of-mass test does not
        apply to it (stackdsl's own, :mod:`stability._debris`)."""
        return bool(self.pile) and self.objects_above <= self.pile

    def held_as(self, load: tuple[tuple[float, float, float], float, object]) -> bool:
        """Did rigid-block equilibrium hold this brick, failing the report's centre-of-mass test,
        under this very ``load`` (centre of mass above (m), mass above (kg), as
        :func:`stability._load.propagate_fast` gives it)? Then the test would ask again what
        the stack test answered (:meth:`stability._stack_test.StackTest.run`), and does not:
        what lies above it is what it was, and a change elsewhere that fails a brick asks
        equilibrium of the whole part again. A fallen domino that a fallen one leaned on
        before its pile froze failed at every freeze of the row, and its part (up to 98
        bricks) was solved each time (stackdsl's own)."""
        if self.held is None:
            return False
        (x, y, z), mass = load[0], load[1]
        return max(abs(a - b) for a, b in zip(self.held, (mass, x, y, z), strict=True)) <= HELD_SAME

    @property
    def box(self) -> Box:
        """The shape of a brick: only environment bodies may be planes. Raises TypeError for a plane."""
        if not isinstance(self.shape, Box):
            raise TypeError(f"{self.label} is a plane, not a brick")
        return self.shape


class Stack:
    """The registered bodies of one extension, with the frozen stack: the active ones, the
    frozen ones in the order they froze (each after its supports), and a version that counts
    the stack's changes (freezes and wakes). It freezes and wakes them on the engine.

    Args:
        engine: the engine the bodies live in.
        config: the extension's thresholds and rules.

    Source: report 3.3.1 (Figure 3) and 3.3.7; the load paths are stackdsl's own
    (:mod:`stability._load_path`).
    """

    def __init__(self, engine: Engine, config: StabilityConfig) -> None:
        self.engine, self.config = engine, config
        self.bodies: dict[int, Record] = {}
        self.active: dict[int, Record] = {}  # the active bricks, so that a step costs what moves
        self.frozen: dict[int, Record] = {}  # the frozen bricks in the order they froze: supports first
        self.unproven: set[int] = set()  # frozen bricks with no load path under their centre of mass
        # report model: unproven bricks frozen on a non-level load path since the stack test last
        # asked rigid-block equilibrium of them (_prove)
        self.leaning: set[int] = set()
        self.just_frozen: set[int] = set()  # frozen in the extension's update under way (StackTest undoes such a freeze alone)
        # the bricks woken at the time :attr:`_woken_at` (s), each with what it rested on (:meth:`_settled`)
        self._woken_at, self._woken = -math.inf, dict[int, frozenset[int]]()
        self.loads_fresh = True  # com_above / mass_above of every frozen brick are up to date
        self.version = 0  # counts the changes of the frozen stack (freezes and wakes)
        # the version after the last change of a brick that touched another brick, and the last
        # version at which each lone brick (touching the ground only) was frozen or woken since
        self.linked_version = 0
        self._lone: dict[int, int] = {}
        self.registrations = 0  # counts the bodies registered and unregistered (add, forget)
        self.standing_version: int | None = None  # a version whose whole frozen stack a program showed to stand
        self.holding = True  # bricks woken in a proved mechanism are held active (none while a heap settles)
        self.guided: set[int] = set()  # bodies an outside hand moves (a gripper, a pusher): never frozen
        self.lowered: frozenset[int] = frozenset()  # bricks a hand is setting down: their fall is no blow
        self.rides: dict[int, Ride] = {}  # pulled body (a shake's: first rider) -> the frozen bricks riding it, one body
        self.riding: dict[int, int] = {}  # each of those -> the ride's key
        # counts the times a box joined the frozen ones (a brick frozen, a ride ended: frozen_boxes)
        self.box_generation = 0
        self.hand_speed: dict[int, float] = {}  # m/s along a guided body's path, as the hand gave it
        self.hand_velocity: dict[int, np.ndarray] = {}  # m/s, shape (3,): a guided body's, as the hand gave it
        self.admitting = True  # False while the ground moves: nothing is frozen in the world's frame
        # the frozen bricks' boxes, of a stack version and its rides (frozen_boxes): a table
        self._boxes: tuple[tuple[int, tuple[int, ...]], np.ndarray] | None = None
        # active bricks that frozen bricks lean on: body -> (its pose then, the frozen bricks on it)
        self.watched: dict[int, tuple[Pose, set[int]]] = {}
        # body -> its watched pose, its corners there, and its position and quaternion in floats
        self._watched_corners: dict[int, tuple[Pose, np.ndarray, tuple[float, ...], tuple[float, ...]]] = {}
        self._contacts: ContactBook | None = None  # this step's, read in full before a change
        self.splits: Splits = {}  # the last split of each brick's load (propagate_fast's memo)
        # the loads of the last stack test that every frozen brick passed, and the bricks changed
        # since (frozen, or lost or gained a brick resting on them); None: no such loads (changed_part)
        self.kept: Loads = {}
        self.changed: set[int] | None = None
        self._seq = 0

    def add(self, rec: Record) -> None:
        """Register ``rec``. Raises ValueError for a body registered already."""
        if rec.body in self.bodies:
            raise ValueError(f"body {rec.body} is registered already")
        self.bodies[rec.body] = rec
        self.registrations += 1
        if rec.state is BrickState.ACTIVE:
            self.active[rec.body] = rec

    def frozen_boxes(self) -> tuple[np.ndarray, int]:
        """The frozen bricks' bounding boxes :meth:`frozen_gaps` measures against, as a table,
        shape (n, 5) (top z, x min, x max, y min, y max, m), found anew when the stack changes or
        a ride starts or ends; and their generation (:attr:`box_generation`), which counts the
        times a box joined them (a brick frozen, a ride ended): while it stays the same, the
        boxes are some of those of any earlier moment of the same generation, never one more.
        A caller that needs the generation alone reads the attribute, and no table is built for
        it: the impact rule's bound asks at every step (0.35% of the 120-domino row's instructions)."""
        key = (self.version, tuple(self.rides))
        if self._boxes is None or self._boxes[0] != key:
            rows = [r.extent for r in self.frozen.values() if r.extent is not None and r.body not in self.riding]
            self._boxes = (key, np.array(rows, dtype=float).reshape(-1, 5))
        return self._boxes[1], self.box_generation

    def frozen_gaps(self, lows: np.ndarray, highs: np.ndarray) -> tuple[np.ndarray, int]:
        """For each box (its lowest and highest corners, shapes (n, 3), m): how near the
        bounding box of the nearest frozen brick comes to it, shape (n,), m (inf when none is
        frozen), and the generation of the boxes it was measured against (:meth:`frozen_boxes`).
        A box is ``reach`` m from a frozen brick's box when, in each of x and y, their spans come
        within ``reach`` of each other, and that brick's top within ``reach`` of its bottom: the
        gap is the largest of those separations, and the box is within ``reach`` of some frozen
        brick when its gap is at most ``reach``. A bound, from the boxes found when they froze (their tops and
        horizontal extents; kept until the stack changes, or a ride starts or ends: a riding
        brick is where the engine carried it, and is left out), so that the impact rule asks
        the engine for closest points only near frozen bricks: in a domino row the fallen
        dominoes behind the chain's front are near none, and in a Jenga tower a moving block two
        levels over a frozen one is not near it (its box is 15 mm thick; a sphere of its half
        diagonal would reach 40 mm down). Every box of a step is measured at once.
        Source: stackdsl's own."""
        boxes, generation = self.frozen_boxes()
        lows, highs = np.asarray(lows, dtype=float).reshape(-1, 3), np.asarray(highs, dtype=float).reshape(-1, 3)
        if len(boxes) == 0:
            return np.full(len(lows), np.inf), generation
        gaps = np.maximum.reduce(
            [
                lows[:, 2:3] - boxes[:, 0],  # down from its bottom to the frozen top
                boxes[:, 1] - highs[:, 0:1],
                lows[:, 0:1] - boxes[:, 2],
                boxes[:, 3] - highs[:, 1:2],
                lows[:, 1:2] - boxes[:, 4],
            ]
        )
        nearest: np.ndarray = gaps.min(axis=1)
        return nearest, generation

    def frozen_contacts(self, blocks: Collection[int]) -> list[ContactPolygon[int]]:
        """The contact polygons remembered from the freezes of the frozen bricks, those with
        ``blocks`` (a program's free blocks), with the ground and fixed bodies, and with the
        watched active bricks they lean on as they are (:meth:`watch`). A pile frozen on its
        edge was solved on its watched bricks as on fixed supports, and wakes once one moves:
        a stack test that left them out found it falling at the step it froze, and woke it
        (in a row of 120 dominoes, 200 bricks woken and frozen again). Source: stackdsl's own."""
        ground = {b for b, r in self.bodies.items() if r.state is BrickState.GROUND}
        leant = {b: leaning for b, (_, leaning) in self.watched.items()}
        return [
            c
            for r in self.in_order()
            for c in r.contacts
            if c.other in blocks or c.other in ground or c.body in leant.get(c.other, ())
        ]

    def watch(self, rec: Record, leaning: set[int]) -> None:
        """Frozen bricks ``leaning`` (body ids) rest on ``rec``, an active brick at rest: remember
        where it is, so that they wake when it moves away (:meth:`moved_away`)."""
        pose, before = self.watched.get(rec.body, (self.engine.pose(rec.body), set()))
        self.watched[rec.body] = (pose, before | leaning)

    def moved_away(self, time: float, distance: float) -> list[Woken]:
        """Wake the frozen bricks that lean on a watched active brick once a corner of it is
        ``distance`` m from where it was when they froze, with what rests on them; stop watching
        a brick that has been frozen itself (it is then a support like any other)."""
        woken: list[Woken] = []
        for body, (pose, leaning) in list(self.watched.items()):
            rec = self.bodies.get(body)
            if rec is None or rec.state is not BrickState.ACTIVE:
                del self.watched[body]
                continue
            box = rec.box
            then = self._watched_corners.get(body)
            if then is None or then[0] is not pose:  # where it was watched from, found once
                then = self._watched_corners[body] = (
                    pose,
                    box.corners(pose),
                    tuple(pose.position.tolist()),
                    tuple(pose.orientation.tolist()),
                )
            # no corner moves farther than the centre's shift plus the turn's angle times the half
            # diagonal: most steps a watched brick creeps, and that bound answers without the corners
            if moved_at_most(then[2], then[3], *self.engine.pose_floats(body), box.half_diagonal) < distance - BOUND_SLACK:
                continue
            moved = float(np.linalg.norm(box.corners(self.engine.pose(body)) - then[1], axis=1).max())
            if moved < distance:
                continue
            del self.watched[body]
            for b in self.ordered(leaning):
                woken += self.wake(b, time, f"{rec.label}, which it leaned on, moved {moved * 1000:.1f} mm")
        return woken

    def ride(self, pulled: int, riders: Sequence[int], ground: int | None = None) -> bool:
        """Merge the frozen ``riders`` into one body in the engine, riding the pull of ``pulled``
        (:meth:`stability.StabilityExtension.guide`), or, with ``ground``, the shaken ground
        (:meth:`stability.StabilityExtension.shake`; ``pulled`` is then the first rider, which
        names the ride); False when the engine cannot merge them. They stay frozen here, at the
        poses they froze at, until :meth:`end_ride`."""
        if not self.engine.merge(riders):
            return False
        label = self.bodies[pulled if ground is None else ground].label
        self.rides[pulled] = Ride(label, tuple(riders), ground)
        self.riding.update(dict.fromkeys(riders, pulled))
        return True

    def end_ride(
        self, pulled: int, time: float, reason: str, proved: AbstractSet[int] = frozenset(), hold: bool = False
    ) -> list[Woken]:
        """End the ride of the bricks riding the pull of ``pulled``: each a body of its own in the
        engine again, where it rode to, and woken (the poses they froze at are no longer
        theirs), with ``reason``."""
        riders = self.unride(pulled)
        woken: list[Woken] = []
        for body in riders:
            woken += self.wake(body, time, reason, proved, hold)
        return woken

    def unride(self, pulled: int) -> tuple[int, ...]:
        """End the ride of the bricks riding the pull of ``pulled`` (or a shaken ground) in the
        engine only: each a static body of its own again, where it rode to; returns them, in the
        order they froze. They stay frozen here, with the books of where they froze, until the
        caller wakes each (:meth:`end_ride`) or freezes it again where it lies (:meth:`wake` of
        it ``alone``, then :meth:`freeze`)."""
        riders = self.rides.pop(pulled).riders
        for body in riders:
            del self.riding[body]
        self.box_generation += 1  # their boxes are the frozen ones' again
        if self._contacts is not None:
            self._contacts.fill()
        self.engine.unmerge(riders)
        return riders

    def forget(self, body: int) -> None:
        """Unregister ``body``, an active brick taken out of the scene (a pulled brick, a withdrawn
        pusher). Raises KeyError for an unknown body and ValueError for one that is not active."""
        rec = self.bodies[body]
        if rec.state is not BrickState.ACTIVE:
            raise ValueError(f"{rec.label} is {rec.state.value}: only an active body can be taken away")
        del self.bodies[body]
        self.registrations += 1
        lost = [other for other in self.frozen.values() if body in other.rests_on]
        if lost:  # a pulled brick they were kept frozen on (stability._drag)
            self._unsupport(lost, body)
        self.active.pop(body, None)
        self.unguide(body)
        for other in self.bodies.values():
            other.objects_above.discard(body)

    def unguide(self, body: int) -> None:
        """No hand moves ``body`` any more: it is not guided, and its hand's speed and velocity
        are forgotten (a pushed brick the push let go of, a body taken away)."""
        self.guided.discard(body)
        self.hand_speed.pop(body, None)
        self.hand_velocity.pop(body, None)

    def _unsupport(self, records: list[Record], body: int) -> None:
        """Take ``body``, taken out of the scene, from the supports of the frozen ``records``:
        they rest on the others (a proof held them on those: :class:`stability._drag.PullProof`).
        Their load paths, and those of every frozen brick above them, are found again."""
        above: set[int] = set()
        self.splits.clear()  # their nodes' supports change in place
        self.changed = None
        for rec in records:
            del rec.rests_on[body]
            rec.contacts = [c for c in rec.contacts if c.other != body]
            assert rec.frozen_pose is not None, "a frozen brick has a pose"
            if rec.rests_on:
                heights = [a.height for a in rec.rests_on.values()]
                rec.main_contact = ContactArea(
                    combined_hull(list(rec.rests_on.values())), min(heights), np.array([0.0, 0.0, 1.0]), False
                )
            rec.node = LoadNode(rec.box.mass, rec.frozen_pose.position, rec.rests_on)
            above.add(rec.body)
        todo = list(above)
        while todo:
            for a in self.bodies[todo.pop()].objects_above:
                if a not in above:
                    above.add(a)
                    todo.append(a)
        for rec in self.in_order():
            if rec.body in above:
                rec.held = None
                self.unproven.discard(rec.body)
                self.leaning.discard(rec.body)
                self._prove(rec)
        self.loads_fresh, self.version = False, self.version + 1
        self.linked_version, self._lone = self.version, {}

    def ordered(self, bodies: Iterable[int]) -> list[int]:
        """``bodies`` in registration order."""
        return sorted(bodies, key=lambda b: self.bodies[b].order)

    def pose(self, rec: Record) -> Pose:
        """Where ``rec`` is: as frozen, or the engine's pose."""
        return rec.frozen_pose if rec.frozen_pose is not None else self.engine.pose(rec.body)

    def nodes(self, bricks: Iterable[Record]) -> dict[int, LoadNode]:
        """The load node of each brick: as frozen, or where it is on what it rests on."""
        return {r.body: r.node or LoadNode(r.box.mass, self.pose(r).position, r.rests_on) for r in bricks}

    def touched(self, body: int) -> None:
        """Note that the load of ``body``, or whether it passes the stack test under it, may have
        changed since the loads were kept (:meth:`changed_part`): it froze, or a brick resting on it
        froze or woke, or what it rests on or the pile it is held in changed."""
        if self.changed is not None:
            self.changed.add(body)

    def keep(self, loads: Loads | None, part: bool = False) -> None:
        """Keep ``loads``, the loads of every frozen brick (with ``part``, of the bricks of
        :meth:`changed_part`, the others' kept already), each of which has just passed the stack
        test under them (:meth:`stability._stack_test.StackTest.run`); None: forget them."""
        if loads is None:
            self.kept, self.changed = {}, None
        elif part:
            self.kept.update(loads)
            self.changed = set()
        else:
            self.kept, self.changed = loads, set()

    def changed_part(self, seeds: Iterable[int] = ()) -> set[int] | None:
        """The frozen bricks whose loads may differ from the kept ones (:meth:`keep`): the bricks
        changed since (:meth:`touched`) and ``seeds``, with every frozen brick under them, down
        their supports (a brick's load reaches only those). None when no loads are kept. Every
        other frozen brick carries what it carried when the loads were kept, and passes the
        stack test as it did then. Source: stackdsl's own."""
        if self.changed is None:
            return None
        part: set[int] = set()
        todo = [*self.changed, *seeds]
        frozen = self.frozen
        while todo:
            b = todo.pop()
            if b not in part and b in frozen:
                part.add(b)
                todo += frozen[b].rests_on
        return part

    def part_loads(self, part: set[int], trial: Mapping[int, LoadNode] | None = None) -> Loads | None:
        """The loads of the frozen bricks of ``part`` (:meth:`changed_part`) and of ``trial`` (active
        bricks, body -> its node were it frozen, after every frozen brick), propagated alone with
        the kept loads (:meth:`keep`) of the bricks resting on them
        (:func:`stability._load.propagate_part`); None when it must be propagated whole."""
        frozen, trial = self.frozen, trial or {}
        places = {b: self._seq + 1 + i for i, b in enumerate(trial)}
        above = {a for b in (*part, *trial) for a in self.bodies[b].objects_above if a in frozen}
        nodes = self.nodes(frozen[b] for b in part | above)
        nodes.update(trial)
        return propagate_part(
            nodes,
            part | trial.keys(),
            self.kept,
            lambda b: self.bodies[b].objects_above,
            lambda b: places[b] if b in places else frozen[b].seq,
            self.splits,
        )

    def in_order(self) -> list[Record]:
        """The frozen bricks, in the order they froze (each after its supports)."""
        return list(self.frozen.values())

    def rested(self, rec: Record, time: float) -> bool:
        """Has ``rec`` been under the rest thresholds for the rest duration at ``time`` s?"""
        return rec.clock.rested(time, self.config)

    def attempt(self, rec: Record, contacts: dict[int, list[ContactPoint]], time: float) -> Attempt:
        """What an admission of ``rec`` depends on: the stack (its version), the brick's pose
        to 0.1 mm and 0.01 rad, and the bodies it touches with whether each is frozen or
        at rest. A brick refused once is not asked again until one of them changes."""
        pose = self.engine.pose(rec.body)
        where = tuple(round(float(v) * 1e4) for v in pose.position) + tuple(round(float(v) * 200) for v in pose.orientation)
        around = tuple(
            sorted(
                (o, self.bodies[o].state is not BrickState.ACTIVE or self.rested(self.bodies[o], time))
                for o in {c.other for c in contacts[rec.body]}
                if o in self.bodies
            )
        )
        return Attempt(self.version, where, around)

    def soon(self, failed: tuple[Attempt, float], time: float) -> bool:
        """Was the refusal ``failed`` (what it depended on, when) less than a rest duration ago,
        on the same stack? Then the brick waits: in a heap that still settles around it, it
        would be asked every step.

        The same stack but for lone bricks (each touching nothing but the ground when frozen
        or woken) that the refused brick did not touch (:meth:`attempt`'s bodies) counts as
        the same stack: such a change reaches no support, load path or pile of the refused
        brick. The chain's front of a domino row wakes a standing domino every few steps, and
        each wake asked every fallen domino refused behind the front again (at 120 dominoes,
        103 of 214 refusals)."""
        (key, when), version = failed, self.version
        if time - when >= self.config.rest_duration:
            return False
        if key.version == version:
            return True
        if key.around is None or key.version < self.linked_version:
            return False
        lone, since = self._lone, key.version
        return not any(lone.get(o, -1) > since for o, _ in key.around)

    def settled_around(self, failed: tuple[Attempt, float], time: float) -> bool:
        """Whether, since the refusal ``failed``, which :meth:`soon` keeps waiting on a stack
        changed only by lone bricks, a brick it touched that still moved then has come to rest
        or been frozen. Then it is asked again, after the other bricks of the step, whose piles
        may freeze it first (:meth:`StabilityExtension.update
        <stability.StabilityExtension.update>`). Every change of the stack used to ask it, and
        the chain's front of a domino row wakes a standing domino often enough that a refused
        domino was asked again soon after the one it leans on came to rest; left to wait out its
        rest duration instead, the dominoes of 12 rows of 15 to 50 stayed active longer (their
        runs 2.5% and 5.7% slower on the two engines, one arc 58%)."""
        key = failed[0]
        if key.around is None or key.version == self.version:
            return False
        bodies = self.bodies
        return any(
            not resting and o in bodies and (bodies[o].state is not BrickState.ACTIVE or self.rested(bodies[o], time))
            for o, resting in key.around
        )

    def _changed(self, rec: Record) -> None:
        """Note the change of ``rec`` (frozen or woken; the version counted already) for
        :meth:`soon`: lone when it touches nothing but the ground and fixed bodies."""
        bodies = self.bodies
        lone = (
            not rec.objects_above
            and all(bodies[o].state is BrickState.GROUND for o in rec.rests_on)
            and all(
                o == rec.body or (o in bodies and bodies[o].state is BrickState.GROUND)
                for c in rec.contacts
                for o in (c.body, c.other)
            )
        )
        if lone and len(self._lone) < LONE_KEPT:
            self._lone[rec.body] = self.version
        else:
            self.linked_version, self._lone = self.version, {}

    def contacts(self, bodies: Collection[int], now: Collection[int]) -> ContactBook:
        """This step's contact points of ``bodies`` (those of ``now`` read at once, the others
        when first looked up, and all of them before the stack next freezes or wakes a body:
        pybullet drops a body's contacts when its mass changes)."""
        self._contacts = ContactBook(self.engine, bodies, now)
        return self._contacts

    def forget_contacts(self) -> None:
        """End the step's contact points (:meth:`contacts`): the engine steps on."""
        self._contacts = None

    def freeze(
        self,
        rec: Record,
        supports: dict[int, ContactArea],
        main: ContactArea,
        polygons: list[ContactPolygon[int]],
        lift: float = 0.0,
    ) -> None:
        """Freeze ``rec`` on ``supports`` (its main contact area ``main``, every contact polygon
        ``polygons``), raised ``lift`` metres out of them (see :func:`stability._areas.overlap`),
        and find its load path. The contact polygon with a support whose area is exact is that
        area on its plane (:meth:`ContactArea.corners`), as :meth:`ContactAreas.polygons
        <stability._areas.ContactAreas.polygons>` makes it."""
        at = None
        if lift > 0.0:
            pose = self.engine.pose(rec.body)
            at = Pose(pose.position + [0.0, 0.0, lift], pose.orientation)
        if self._contacts is not None:
            self._contacts.fill()
        self.engine.set_frozen(rec.body, True, rec.box.mass, at)
        rec.lift = max(lift, 0.0)
        rec.state, rec.rests_on, rec.main_contact, rec.contacts = BrickState.FROZEN, supports, main, polygons
        rec.pile = frozenset({rec.body}) if rec.clock.fallen else frozenset()  # a debris pile's admission widens it
        self.active.pop(rec.body, None)
        rec.frozen_pose = self.engine.pose(rec.body)
        corners = rec.box.corners(rec.frozen_pose)
        low, high = corners.min(axis=0), corners.max(axis=0)
        rec.extent = (float(high[2]), float(low[0]), float(high[0]), float(low[1]), float(high[1]))
        rec.was_frozen = True
        self.box_generation += 1
        self.just_frozen.add(rec.body)
        rec.node = LoadNode(rec.box.mass, rec.frozen_pose.position, supports)
        self.frozen[rec.body] = rec
        self._seq += 1
        rec.seq = self._seq
        self.touched(rec.body)
        self.loads_fresh, self.version = False, self.version + 1
        for s in supports:
            self.bodies[s].objects_above.add(rec.body)
        self._changed(rec)
        self._prove(rec)  # both models: the load path also certifies a standing stack (stability._certificate)

    def _prove(self, rec: Record) -> None:
        """Find the load path of a brick being frozen and, with the equilibrium model, where it may
        push on each support (:mod:`stability._load_path`); note it when its centre of mass is
        not over its path.

        With the report model, an unproven brick whose centre of mass is not over its own level
        support contacts (it leans: it needs a sideways force), or that rests on a brick that
        :attr:`Record.leans`, is noted in :attr:`leaning` too: its loads reach a non-level
        contact, where the report's unlimited friction is not exact, and the stack test asks
        rigid-block equilibrium with friction of its part
        (:meth:`stability._stack_test.StackTest.run`). A proven brick adds nothing to what such
        a contact carries (its load goes down by vertical forces on level contacts, and forces
        within friction cones add up to forces within them), but a brick on it inherits the
        mark: its load may leave the path. A brick that fell (woken from the stack, frozen again
        with :attr:`Record.pile`) is not noted: it is held by the equilibrium that admitted it
        (:meth:`Record.held_by_pile`), and the collapse it fell in is already recorded: solving
        the heap again took a 16-level single file run to its collapse from 0.20 to 0.33 s.
        Source: stackdsl's own."""
        pieces = []
        level: dict[int, list[np.ndarray]] = {}  # support -> its level contact polygons' points
        for c in rec.contacts:
            support = self.bodies[c.other]
            if c.other in rec.rests_on and is_level(c):
                area = rec.rests_on[c.other]
                # an exact area's contact polygon is the area on its plane (its corners): the hull of
                # its polygon is that of the points, bit for bit, without making a ring of them
                hull = shapely.convex_hull(area.polygon) if area.exact else None
                pieces.append(support_piece(c.points, support.load_path, support.state is BrickState.GROUND, hull))
                level.setdefault(c.other, []).append(c.points)
        rec.load_path = load_path([p for p in pieces if p is not None])
        if self.config.model == "equilibrium":  # for its stack test's propagated loads only
            rec.support_regions = {s: r for s, points in level.items() if (r := share_region(points)) is not None}
        assert rec.frozen_pose is not None, "set by freeze"
        com = rec.frozen_pose.position
        rec.leans = any(self.bodies[s].leans for s in rec.rests_on)
        if proven(com, rec.load_path):
            return
        self.unproven.add(rec.body)
        if self.config.model == "report":
            own = load_path([support_piece(p, None, ground=True) for points in level.values() for p in points])
            rec.leans = rec.leans or not proven(com, own)
            if rec.leans and not rec.pile:  # a brick that fell: the debris rule's equilibrium holds it
                self.leaning.add(rec.body)

    def _settled(self, rec: Record, time: float) -> Pose | None:
        """Where ``rec`` wakes, at ``time``, on an engine whose contacts need an overlap (the
        :class:`stability._engine.Engine`'s ``contacts_need_overlap``): lowered back into its
        supports by what it was raised out of them when it froze (:attr:`Record.lift`), and by as
        much as the most any of them woken with it was lowered; None (where it is) when that is
        nothing, and on any other engine. A brick woken with it that rests on it, woken first, is
        lowered further by as much (:meth:`_lower_riders`).

        A frozen brick is raised out of the overlap an engine's soft contacts give it at rest
        (:func:`stability._areas.overlap`), so that a frozen tower keeps its heights; woken
        there, it only touches what it rests on. pybullet makes no contact for two boxes that
        touch without overlapping: each woken brick fell until it overlapped, and the column
        woken with it fell freely meanwhile, one more step for each brick under it. Ten KAPLA
        bricks of a single file woken at once (a shake past what it withstands as one body):
        the top brick fell 7.5 mm in 37 ms, past the collapse threshold, while the ground had
        moved 1.7 mm. Lowered so, each woken brick overlaps its supports as it did at rest
        and the engine carries it from its first step. On an engine whose soft contacts hold what
        touches, lowering them so made the middle block of level 5 of a 7-level Jenga tower,
        pulled, drag the level above past the threshold (7.8 mm) where every other engine and
        mode stands it: it is not done there. Source: stackdsl's own.
        """
        if not getattr(self.engine, "contacts_need_overlap", False):
            return None  # its contacts hold what only touches: where it froze
        if self._woken_at != time:
            self._woken_at, self._woken = time, {}
        supports = frozenset(rec.rests_on)
        drop = rec.lift + max((self.bodies[s].lowered[1] for s in supports if s in self._woken), default=0.0)
        rec.lowered = (time, drop)
        self._woken[rec.body] = supports
        self._lower_riders(rec.body, drop)
        if drop <= 0.0:
            return None
        pose = self.engine.pose(rec.body)
        return Pose(pose.position - [0.0, 0.0, drop], pose.orientation)

    def _lower_riders(self, body: int, drop: float) -> None:
        """The bricks woken before ``body`` at the same time that rest on it (their order of
        waking is that of the wake calls, not of the stack), lowered further when ``body``'s
        ``drop`` (m) is more than their supports' was; and so on up."""
        for rider, supports in self._woken.items():
            if body not in supports:
                continue
            rec = self.bodies[rider]
            needed = rec.lift + drop
            if needed <= rec.lowered[1] + 1e-12:
                continue
            pose = self.engine.pose(rider)
            self.engine.set_frozen(
                rider, False, rec.box.mass, Pose(pose.position - [0.0, 0.0, needed - rec.lowered[1]], pose.orientation)
            )
            rec.lowered = (rec.lowered[0], needed)
            self._lower_riders(rider, needed)

    def wake(
        self,
        body: int,
        time: float,
        reason: str,
        proved: AbstractSet[int] = frozenset(),
        hold: bool = False,
        alone: bool = False,
    ) -> list[Woken]:
        """Wake ``body`` and, recursively, what rests on it (report 3.3.7); each with its last
        load node. Nothing when ``body`` is not frozen. With ``alone``, ``body`` only, what rests
        on it still resting on it (a freeze undone: they were frozen on it while it moved, and
        are again). The events of the bodies in ``proved``
        (those a proved collapse mechanism moves) say so (:attr:`StabilityEvent.proved`); they
        and what rests on them (``hold``) are held active until they move
        (:attr:`Record.proved_at`)."""
        rec = self.bodies[body]
        if rec.state is not BrickState.FROZEN:
            return []
        if body in self.riding:  # merged with the others riding a pull or a shake: they wake together
            return self.end_ride(self.riding[body], time, reason, proved, hold)
        node = rec.node
        assert node is not None, "a frozen brick has a load node"
        if self._contacts is not None:
            self._contacts.fill()
        self.engine.set_frozen(body, False, rec.box.mass, self._settled(rec, time))
        rec.state, rec.frozen_pose, rec.node, rec.extent = BrickState.ACTIVE, None, None, None
        rec.clock.stop()
        rec.clock.fallen, rec.clock.windowed = self.config.debris, False  # fallen: the windowed rest test (with the debris rule)
        self.active[body] = rec
        del self.frozen[body]
        self.unproven.discard(body)
        self.leaning.discard(body)
        rec.leans = False
        rec.load_path, rec.support_regions, self.loads_fresh, self.version = None, {}, False, self.version + 1
        self._changed(rec)
        self.just_frozen.discard(body)
        for s in rec.rests_on:
            self.bodies[s].objects_above.discard(body)
            self.touched(s)
        rec.rests_on, rec.main_contact, rec.com_above, rec.mass_above = {}, None, None, 0.0
        rec.contacts, rec.pile, rec.held = [], frozenset(), None
        held = self.holding and not rec.still and (hold or body in proved)
        rec.proved_at = rec.box.corners(self.engine.pose(body)) if held else None
        if rec.proved_at is not None:
            rec.still_from = (rec.proved_at, time)
        woken = [Woken(body, node, StabilityEvent(time, "wake", rec.label, reason, proved=body in proved))]
        if alone:
            return woken
        for above in self.ordered(rec.objects_above):  # what rests on it, and the other bricks of its pile
            how = "rests on" if body in self.bodies[above].rests_on else "was frozen in one pile with"
            woken += self.wake(above, time, f"{how} {rec.label}", proved, rec.proved_at is not None)
        rec.objects_above = set()
        return woken

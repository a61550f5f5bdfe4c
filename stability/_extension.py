"""The stability extension: freeze what the graph proves stable, wake what it proves not.

The report's method (chapter 3) on top of any :class:`Engine`. Each physics step the
harness calls :meth:`StabilityExtension.update`; it

1. gathers contact points, of bricks at rest and when first needed, and drops those between
   two unstable (active) bricks (3.3.1);
2. builds contact areas per support and their convex hull, the main contact area (3.3.3);
3. admits a brick whose speeds have stayed under the rest threshold for the rest
   duration and whose centre of mass lies over its main contact area (3.3.4), unless
   it rests on contacts at different heights (3.5); otherwise, when leaning is on,
   tests it as a leaning brick (3.4, :mod:`stability._leaning`); an admitted brick is
   frozen (immovable, still colliding);
4. when the stack changed, propagates centre of mass above and mass above (3.3.5-3.3.6)
   and wakes every brick whose centre of mass above lies outside its main contact area,
   with everything resting on it (3.3.7);
5. wakes the frozen bricks that lean on an active brick at rest (the edge of a settled pile,
   :mod:`stability._debris`) once it has moved :data:`WATCH` from where they froze;
6. when impacts are on, compares the kinetic energy of every fast body about to touch a
   frozen brick with that brick's potential energy (3.6, :mod:`stability._impact`).

Propagation and the stack-wide test run only when the stack changes (a freeze or a
wake), never on a step where nothing did. pybullet reports no contacts between two
frozen bodies, so the extension keeps the contact graph it had when it froze them.
"""

from __future__ import annotations

import math
from collections.abc import Set as AbstractSet
from dataclasses import replace

import numpy as np
import shapely
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ._admission import Admission
from ._areas import ContactAreas, Contacts, by_body, main_area, overlap
from ._certificate import Certificate, certify
from ._config import StabilityConfig
from ._debris import Debris
from ._drag import SHRINK, PullProof, footprint
from ._engine import ContactPoint, Engine
from ._equilibrium import ContactPolygon
from ._gap import Gap, near_within
from ._geometry import FACE_TILT, Box, ContactArea, Plane, Pose, corners_of, face_overlap, signed_inside
from ._graph import BrickGraph, BrickState, GraphEdge, GraphNode
from ._impact import Impacts
from ._leaning import pair_friction
from ._load import LoadNode, propagate
from ._lp import within
from ._ride import (
    AHEAD,
    MOST_TILT,
    RIDE_DROP,
    RIDE_TILT,
    RideLimit,
    ShakenRide,
    arms_of,
    felt_gravity,
    holds_tilted,
    tilt_of,
)
from ._shake import shake_limit, sliding_parts, withstands
from ._stack import Record, StabilityEvent, Stack
from ._stack_test import StackTest

__all__ = ["LINGER", "StabilityConfig", "StabilityEvent", "StabilityExtension"]

#: Rest durations a placed brick may stay active before the stack is checked against its weight.
#: Metres below its supports' faces a placed brick's bottom face may lie and count as landed
#: (a brick lowered onto its place sinks 0.01 mm into it; one in the air lies its drop gap above).
LANDED = 1e-4
#: Metres a placed brick's corners may have moved sideways from where the hand set it down and
#: it still be frozen where it landed (:meth:`StabilityExtension._landings`).
LANDED_SLIP = 0.001
#: Seconds after a placed brick is first seen within which it is looked at for a near tie.
NEAR_TIE_WINDOW = 0.5
#: How a freeze decided by statics on a near tie begins its words (the certificate counts them).
NEAR_TIE_WORDS = "by exact statics on its placed geometry, a near tie"
LINGER = 4.0
#: Metres: how far a corner of a brick woken in a proved collapse mechanism must move from
#: where it was woken before it may be frozen again (:meth:`StabilityExtension._release`).
RELEASE = 0.0005
#: Metres: a held brick whose corners all stay this near where it was woken is kept still by the engine.
STILL = 0.00005
#: Metres beyond what a guided body travels in a step within which it touches a brick (pybullet's
#: collision margin is about 1 mm).
TOUCH = 0.0015
#: Metres a corner of an active brick that frozen bricks lean on may move before they wake (a
#: contact pad: within it the two still touch as they did).
WATCH = 0.001
#: Metres between a pushed brick whose proof is lost and its pusher beyond which the push has let
#: it go (:meth:`StabilityExtension._guided`): a finger that drives a block stays within its
#: collision margin of it; one that passes over a block fallen off the level under it is 17 mm clear.
LEFT = 0.005
#: Metres by which a pusher's box, swept along its path, may overlap a brick's box across the path
#: and still pass it (:meth:`StabilityExtension._pushes`): a side of a finger flush with a
#: neighbour's face, as written, meets its end along a line, not a face.
GRAZE = 0.0001

#: Fewest frozen bricks that ride a pull merged into one body (:meth:`StabilityExtension._riders`):
#: one brick costs the engine no more alone.
RIDERS = 2


def _order(rec: Record) -> int:
    """A record's place in the order of registration (a sort key)."""
    return rec.order


class StabilityExtension:
    """The report's stack stability system, attached to an :class:`Engine`.

    Register every body first (:meth:`add_ground`, :meth:`add_brick`), then call
    :meth:`update` once per physics step. :meth:`graph` reads the brick graph at any
    time, also when :meth:`update` is never called (the engine alone).

    Args:
        engine: the engine to drive.
        config: thresholds and rules.

    Source: report chapter 3.

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
        self._stack = Stack(engine, config or StabilityConfig())
        self._areas = ContactAreas(self._stack)
        self._admission = Admission(self._stack, self._areas)
        self._debris = Debris(self._stack, self._areas, self._admission)
        self._tests = StackTest(self._stack, self._areas)
        self._impacts = Impacts(self._stack, self._tests)
        # pulled bricks whose proof keeps what they touch frozen, with the overlap (m^2) it was proved at
        self._proofs: dict[int, tuple[PullProof, dict[int, float]]] = {}
        self._under: dict[int, frozenset[int]] = {}  # a pulled brick with no proof -> the bricks under it kept frozen
        # pulled bricks without which statics proved the stack above falls (set by each unproved guide, so
        # that a body id taken again starts afresh; dropped when the brick's ride ends, or it is forgotten)
        self._felling: set[int] = set()
        # guided body -> (stack version, kept, :meth:`_unkept`)
        self._unkept_at: dict[int, tuple[int, frozenset[int], frozenset[int]]] = {}
        self._gaps: dict[int, Gap | None] = {}  # guided body -> its gap to :meth:`_unkept` (:meth:`_touching`)
        self._limits: dict[int, RideLimit] = {}  # a tilted ride's proof, by the pulled brick (:meth:`_tilted`)
        self._shaken_rides: dict[int, ShakenRide] = {}  # how a shaken ground's riders froze, by its key in stack.rides
        self._pushers: set[int] = set()  # guided bodies a hand pushes with (guided without a pull)
        self._driven: dict[int, int] = {}  # a brick a pusher drives, as a pulled one (:meth:`_drive`) -> the pusher
        self._aims: dict[int, int] = {}  # a pusher -> the brick its push is aimed at
        # a pusher -> its hand's velocity, the axes across its path and along it (:meth:`_pushes`)
        self._push_axes: dict[int, tuple[tuple[float, ...], tuple[np.ndarray, np.ndarray], np.ndarray]] = {}
        # a frozen brick -> the pose and axes its shadows across a pusher's path were found for, and them
        self._shadows: dict[int, tuple[Pose, tuple[np.ndarray, np.ndarray], list[tuple[float, float]]]] = {}
        self._ride_hands: dict[int, str] = {}  # a guided body whose riders ride it -> "push" or "pull"

    @property
    def config(self) -> StabilityConfig:
        """The thresholds and rules, fixed when the extension is made."""
        return self._stack.config

    # registration -------------------------------------------------------------
    def add_ground(self, body: int, shape: Box | Plane, label: str = "ground", friction: float = 0.5) -> None:
        """Register an environment body (ground flag of report Figure 3): the ground
        plane or a fixed box; ``friction`` is its material's coefficient. Raises
        ValueError for a body registered already."""
        self._stack.add(Record(body, label, shape, BrickState.GROUND, len(self._stack.bodies), friction))

    def add_brick(
        self, body: int, box: Box, label: str, friction: float = 0.5, near_tie: float = 0.0, placed: bool = False
    ) -> None:
        """Register a brick; it starts active (simulated by the engine). ``placed``: set down in
        its place (by a hand, at rest): frozen once it has landed at rest face to face on frozen
        bricks or the ground with its centre of mass over their area (:meth:`_landings`).
        ``near_tie``: metres, the engine's contact margin (0: none): a brick that so lands with
        its centre of mass inside their combined area by less than this (placed or not) is
        decided by exact statics on its placed geometry, where the engine's contact points would
        decide it by chance, and its freeze says so. Raises ValueError for a body registered
        already."""
        record = Record(body, label, box, BrickState.ACTIVE, len(self._stack.bodies), friction)
        record.near_tie, record.landing = near_tie, placed or near_tie > 0.0
        if placed:
            record.set_down = box.corners(self._stack.engine.pose(body))
        self._stack.add(record)

    # queries ------------------------------------------------------------------
    def state(self, body: int) -> BrickState:
        """The state of a registered body. Raises KeyError for an unknown body."""
        return self._stack.bodies[body].state

    @property
    def quiet(self) -> bool:
        """True when no registered brick is active and none rides a shaken ground: nothing can
        move until an action."""
        return not self._stack.active and not self._stack.rides

    @property
    def riding(self) -> frozenset[int]:
        """The frozen bricks merged into one body in the engine now, each with its part: riding a
        shaken ground (:meth:`shake`), a pull or a push."""
        return frozenset(self._stack.riding)

    @property
    def moving(self) -> tuple[str, ...]:
        """The labels of the registered bricks that are active (simulated by the engine), in
        the order they were registered: what keeps the extension from being :attr:`quiet`."""
        return tuple(r.label for r in sorted(self._stack.active.values(), key=lambda r: r.order))

    # the per-step hook --------------------------------------------------------
    def update(self, time: float) -> list[StabilityEvent]:
        """One step of the algorithm of report 3.3.1 (and 3.4-3.6). ``time`` in seconds."""
        stack, config = self._stack, self._stack.config
        stack.just_frozen.clear()
        ended = self._rides(time) if stack.rides else []
        if not stack.active:
            stack.holding = True
            return ended
        events, touched = self._guided(time) if stack.guided else ([], {})
        events = ended + events
        active = list(stack.active.values())
        if len(active) > 1:
            active.sort(key=_order)
        free = [rec for rec in active if rec.body not in stack.guided] if stack.guided else active
        if any(rec.landing for rec in free):
            events += self._landings(free, time)
            free = [rec for rec in free if rec.state is BrickState.ACTIVE]
            active = [rec for rec in active if rec.state is BrickState.ACTIVE]
        # each free brick's speeds, read once for the rest clocks and the impact rule (valid while
        # the stack does not change: a freeze or a wake sets a body's velocity)
        speeds, read_at = {rec.body: stack.engine.speeds(rec.body) for rec in free}, stack.version
        resting = [rec for rec in free if self._at_rest(rec, time, speeds[rec.body])]  # every clock first: partners
        # only a brick at rest asks, only of its own contacts (and its resting partners'), and a
        # brick refused asks again once a rest duration has passed and something has changed
        held = [rec for rec in active if rec.proved_at is not None]
        if held:
            self._release(held, {rec.body for rec in resting}, time)
        due, after = [], []
        for rec in resting:
            if rec.proved_at is not None or rec.body in touched:
                continue
            if rec.failed is None or not stack.soon(rec.failed, time):
                due.append(rec)
            elif stack.settled_around(rec.failed, time):  # last: a pile asked before may take it
                after.append(rec)
        due += after
        if not stack.admitting:
            due = []
        if due:  # the step's contacts, read only when some brick asks
            settling = [r.body for r in active if r.clock.since is not None]  # the resting, and those slowing down
            contacts = stack.contacts(settling, [r.body for r in due])
            for rec in due:
                events += self._admit(rec, contacts, time)
            stack.forget_contacts()
            if stack.just_frozen:
                self._carry_above(stack.just_frozen)
        if stack.watched:
            events += [w.event for w in stack.moved_away(time, WATCH)]
        if stack.frozen:
            events += self._lingering(free, time)
        if events or not config.per_event:
            events += self._tests.run(time)
        if config.impacts:
            hits = self._impacts.check(
                free, stack.engine.timestep, time, touched, speeds if stack.version == read_at else None, WATCH
            )
            events += hits
            if any(e.kind == "wake" for e in hits):
                events += self._tests.run(time)
        return events

    def _admit(self, rec: Record, contacts: Contacts, time: float) -> list[StabilityEvent]:
        """Ask the admission tests (report 3.3.4, 3.4; the debris rule) of a resting brick that
        is due; a refused brick remembers what the refusal depended on."""
        stack, config = self._stack, self._stack.config
        if rec.state is not BrickState.ACTIVE:  # frozen with a pile earlier in this step
            return []
        attempt = None if rec.failed is None else stack.attempt(rec, contacts, time)
        if rec.failed is not None and attempt == rec.failed[0]:
            rec.failed = (attempt, time)  # nothing it rests on, touches or is has changed: wait again
            return []
        if self._admission.rocking(rec, contacts):
            return []  # on an edge of its one support, tilted to it: mid-rock, not at rest (placed or woken)
        if config.model == "equilibrium":
            found = self._admission.leaning(rec, contacts, time, limit=None)
        else:
            found = self._admission.basic(rec, contacts, time)
            if not found and config.leaning:
                found = self._admission.leaning(rec, contacts, time, limit=config.max_leaning_bodies)
        if not found and config.debris:
            found = self._debris.admit(rec, contacts, time)
        if found:
            # the asker may be left out of what froze (it lies on a brick that still moves, at the
            # edge of its settled pile): it then waits as a refused brick does, until the stack
            # changes again or a rest duration has passed; asked again at once, it was refused
            rec.failed = None if rec.state is not BrickState.ACTIVE else (stack.attempt(rec, contacts, time), time)
            return found
        # a refusal changes nothing: what it depended on is as it was before asking; but the
        # frozen bricks it lies on carry it, so they are checked against its weight
        rec.failed = (stack.attempt(rec, contacts, time) if attempt is None else attempt, time)
        woken = self._tests.carry(rec, stack.engine.pose(rec.body), self._areas.carrying(rec, contacts[rec.body]), time)
        if woken:
            rec.failed = None
        return woken

    def _landings(self, free: list[Record], time: float) -> list[StabilityEvent]:
        """Freeze each just placed brick once it has landed at rest, face to face, on frozen
        bricks or the ground (its faces within :data:`LANDED` of theirs, its speeds under the
        rest thresholds), with its centre of mass over their combined area: the report's basic
        test at the first frame at rest (report 3.3.2, 3.3.4), without the rest duration that a
        woken brick needs (:class:`StabilityConfig`). The hand sets a brick down at rest: waiting
        out the rest duration stepped each placed brick some 12 steps more (a 12-level Jenga
        tower's build 605 steps, 108 without), to freeze it where it lay. A brick on an edge's
        strip (not parallel to its support, :func:`_flat_on`), a support tilted beyond its
        friction angle (:meth:`Admission.steep <stability._admission.Admission.steep>`), or a
        centre of mass outside, is left to the engine and the admission tests, as ever.

        A centre of mass inside by less than the brick's ``near_tie`` (the engine's contact
        margin) is a near tie: statics on the placed geometry says it stands, and the engine's
        contact points, which reach that far, would tip it or keep it by chance (pybullet's 1 mm
        collision margin tipped five of 3000 random single-file stacks, each 0.15 to 0.82 mm
        inside its support's edge, and froze two others tilted at the top of a rock); its freeze
        says so (``proved``). Each brick is looked at once, when it has landed, for at most
        :data:`NEAR_TIE_WINDOW` seconds after it was first seen. Source: stackdsl's own."""
        stack, config, events = self._stack, self._stack.config, []
        for rec in free:
            if not rec.landing or rec.state is not BrickState.ACTIVE or rec.was_frozen:
                continue
            if rec.landing_from is None:
                rec.landing_from = time
            if time - rec.landing_from > NEAR_TIE_WINDOW:
                rec.landing = False
                continue
            speed, angular_speed = stack.engine.speeds(rec.body)
            if speed > config.rest_speed or angular_speed > config.rest_angular_speed:
                continue
            pose = stack.engine.pose(rec.body)
            # the faces it touches: within the face gap of a lower face is not on it (a step 0.5 mm
            # down, under a brick 0.3 mm past its one support's edge, is what it tips onto)
            supports = {o: a for o, a in self._areas.lying_on(rec, pose).items() if a.depth >= -LANDED}
            if not supports:
                continue  # in the air still: lowered onto its place within a few steps
            rec.landing = False
            if rec.set_down is not None and _slid(rec.set_down, rec.box.corners(pose)) > LANDED_SLIP:
                continue  # it moved on landing: the engine and the tests decide, and the monitor sees it move
            main = main_area(supports)
            inside = signed_inside(main.polygon, pose.position)
            names = ", ".join(stack.bodies[o].label for o in supports)
            if 0.0 <= inside < rec.near_tie:
                stack.freeze(rec, supports, main, _face_polygons(stack, rec, supports))
                reason = (
                    f"{NEAR_TIE_WORDS} on {names}: its centre of mass {inside * 1000:.2f} mm inside its support's edge, "
                    f"within the engine's {rec.near_tie * 1000:g} mm contact margin"
                )
                events.append(StabilityEvent(time, "freeze", rec.label, reason, proved=True))
            elif (
                rec.set_down is not None  # placed by a hand
                and self._areas.holds(main, pose.position)
                and not self._admission.steep(rec, supports)
                and all(_flat_on(pose, a) for a in supports.values())
            ):
                lift = overlap((), supports, self._areas.support_cos)
                stack.freeze(rec, supports, main, _face_polygons(stack, rec, supports), lift)
                events.append(StabilityEvent(time, "freeze", rec.label, f"at rest on {names}"))
        return events

    def _carry_above(self, frozen: set[int]) -> None:
        """Each brick of ``frozen`` (frozen in this step) carries the frozen bricks that lie on it
        face to face and do not rest on it yet: a brick that froze while this one was still
        active (woken by a blow, say) left it out of its supports, and its load would go to its
        other supports alone. So the brick graph, and the loads, are the geometry's whichever of
        two bricks froze first (report Figure 3's restOn; stackdsl's own rule). It knows them among
        its objects above, so that woken it wakes them too: a brick left frozen on one woken
        under it is a fixed body holding that one down, which a leaning or debris admission then
        took for a support (a random assembly's level-2 brick, frozen again "leaning on" the
        brick frozen on its edge where rigid statics has no equilibrium). Only a brick with
        a frozen brick higher than its top is looked at (one frozen on top of a stack has none),
        and only a level face (within :data:`stability._geometry.FACE_TILT`): debris lying tilted
        on debris is its pile's."""
        stack = self._stack
        records = [r for r in stack.frozen.values() if r.extent is not None]
        if not records:
            return
        table = np.array([r.extent for r in records], dtype=float)  # top z, x min, x max, y min, y max
        highest = float(table[:, 0].max())
        gap = stack.config.face_gap
        for body in sorted(frozen):
            below = stack.bodies.get(body)
            if below is None or below.state is not BrickState.FROZEN or below.extent is None or below.extent[0] + gap >= highest:
                continue
            top, x0, x1, y0, y1 = below.extent
            # the boxes higher than its top that overlap it across, in one comparison of arrays (a
            # loop over every frozen brick for each one frozen grew with the square of a domino row)
            over = (table[:, 0] > top) & (table[:, 2] >= x0) & (table[:, 1] <= x1) & (table[:, 4] >= y0) & (table[:, 3] <= y1)
            for i in np.flatnonzero(over).tolist():
                above = records[i]
                if above.body == body or body in above.rests_on or above.body in below.rests_on:
                    continue
                area = self._areas.face_to_face(above, below)
                if area is None or area.normal[2] < FACE_TILT:  # debris lying tilted on debris: a pile's own
                    continue
                above.rests_on = {**above.rests_on, body: area}
                below.objects_above.add(above.body)
                above.node = LoadNode(above.box.mass, stack.pose(above).position, above.rests_on)
                stack.touched(above.body)
                if not any(c.other == body for c in above.contacts):
                    friction = pair_friction(above.friction, below.friction)
                    above.contacts = [*above.contacts, ContactPolygon(above.body, body, area.corners(), area.normal, friction)]
                stack.loads_fresh, stack.version = False, stack.version + 1

    def _release(self, held: list[Record], resting: set[int], time: float) -> None:
        """Let go of each brick of ``held`` (in order), held active since it was woken in a
        collapse mechanism that statics proved (or woken resting on one that was:
        :attr:`Record.proved_at`), once a corner of it is :data:`RELEASE` from where it was
        woken and, at rest by the windowed test (its body in ``resting``), it is at this step
        under the rest thresholds themselves. A brick the engine keeps still (no corner
        :data:`STILL` from where it was :data:`LINGER` rest durations before, at rest) is let
        go of too, and not held again: the engine's contacts hold what the frozen stack's
        contacts could not, within a near tie, and it is left to the admission tests (it
        stayed active to the end otherwise, a "stands" with an active brick). Once one held
        brick has moved by its own thickness, the mechanism has played out: every held brick is
        let go of, and no brick is held until every brick is frozen again (what fell is a
        heap, the debris rule's, which freezes bricks that creep within the windowed test).
        Until then it is not frozen. The held bricks' poses are read in one call and their
        corners compared as one array: a collapsing single file holds ten bricks for some 30
        steps.

        A tipping brick starts from rest: a centre of mass 0.14 mm past an edge turns a stack
        of three bricks over in about 0.3 s, but for its first 0.1 s it moves slower than the
        rest threshold, and the windowed test of a woken brick finds it at rest. Frozen again,
        it lost its motion, and the same mechanism woke it again from rest, every rest
        duration: on an engine with compliant contacts such a stack was held up until the next
        brick landed, a level late. Held, it tips on (and the collapse monitor decides), or it
        comes to rest somewhere new and is asked again. Source: stackdsl's own."""
        engine, config = self._stack.engine, self._stack.config
        positions, quaternions = engine.poses_of([rec.body for rec in held])
        now = corners_of(np.array([rec.box.half_extents for rec in held]), positions, quaternions)
        proved = _farthest(now, np.array([rec.proved_at for rec in held]))
        still = _farthest(now, np.array([rec.still_from[0] for rec in held]))
        for rec, corners, moved, since in zip(held, now, proved.tolist(), still.tolist(), strict=True):
            if rec.proved_at is None:  # let go of with the others: the mechanism played out
                continue
            if moved < RELEASE:
                if since >= STILL:
                    rec.still_from = (corners, time)  # it moved: still from here on, if at all
                elif rec.body in resting and time - rec.still_from[1] >= LINGER * config.rest_duration:
                    speed, angular_speed = engine.speeds(rec.body)
                    if speed <= config.rest_speed and angular_speed <= config.rest_angular_speed:
                        rec.proved_at, rec.still = None, True  # the engine holds it: the admission tests decide
                continue
            if moved >= 2 * float(rec.box.half_extents.min()):  # fallen by its own thickness: the mechanism played out
                self._stack.holding = False  # until every brick is frozen again
                for other in self._stack.active.values():
                    other.proved_at = None
                return
            if rec.body not in resting:
                continue
            speed, angular_speed = engine.speeds(rec.body)
            if speed <= config.rest_speed and angular_speed <= config.rest_angular_speed:
                rec.proved_at = None

    def _lingering(self, active: list[Record], time: float) -> list[StabilityEvent]:
        """Check the frozen stack against the weight of every brick that has stayed active since
        it was placed for :data:`LINGER` rest durations (:meth:`carry`): once, and again a rest
        duration later if the stack or its pose (by 0.1 mm or 0.01 rad) has changed. A brick
        the engine cannot bring to rest (one that keeps trembling on a compliant contact) would
        otherwise lie on immovable bricks that no test ever asked to carry it. From then on it
        is at rest by the windowed test (:mod:`stability._rest`). Bricks woken from the stack
        are left to the debris rule, which solves them with the stack."""
        stack, events = self._stack, []
        for rec in active:
            if rec.state is not BrickState.ACTIVE or rec.was_frozen:
                continue
            if rec.placed_at is None:
                rec.placed_at = time
                continue
            if time - rec.placed_at < LINGER * stack.config.rest_duration:
                continue
            rec.clock.windowed = True  # not at rest by the report's test: the windowed one (stability._rest)
            if rec.carried is not None and time - rec.carried[0] < stack.config.rest_duration:
                continue
            pose = stack.engine.pose(rec.body)
            key = (
                stack.version,
                *(round(float(v) * 1e4) for v in pose.position),
                *(round(float(v) * 200) for v in pose.orientation),
            )
            unchanged = rec.carried is not None and rec.carried[1] == key
            rec.carried = (time, key)
            if unchanged:  # the stack and its pose as they were: asked again a rest duration on
                continue
            events += self.carry(rec.body, time, pose)
        return events

    def _at_rest(self, rec: Record, time: float, speeds: tuple[float, float]) -> bool:
        """At rest for the rest duration (report 3.3.2; a fallen brick by the windowed test
        of :mod:`stability._rest`), at ``speeds`` (m/s, rad/s: the engine's this step)."""
        speed, angular_speed = speeds
        return rec.clock.tick(speed, angular_speed, lambda: self._stack.engine.pose(rec.body), time, self._stack.config)

    def carry(self, body: int, time: float, pose: Pose | None = None) -> list[StabilityEvent]:
        """Check the frozen stack against the weight of an active brick lying on it: at
        ``pose`` (where it is about to rest: a placed brick's target) or, when None, where the
        engine has it. The frozen bricks that cannot carry it wake, with what rests on them;
        returns the events. The harness calls it when a brick is placed; the extension itself
        when a brick at rest on the stack is refused admission (it stays active, and the bricks
        under it are immovable). Source: stackdsl's own (:meth:`stability._stack_test.StackTest.carry`).
        """
        rec = self._stack.bodies[body]
        if rec.state is not BrickState.ACTIVE or not self._stack.frozen:
            return []
        where = pose if pose is not None else self._stack.engine.pose(body)
        return self._tests.carry(rec, where, self._areas.lying_on(rec, where), time)

    # wake-up (report 3.3.7) ---------------------------------------------------
    def wake(self, body: int, time: float, reason: str) -> list[StabilityEvent]:
        """Return a frozen brick and everything resting on it to the engine (report 3.3.7).

        Returns the events, one per brick woken; nothing when ``body`` is not frozen.
        """
        return [w.event for w in self._stack.wake(body, time, reason)]

    # bodies moved by an outside hand, and a moving ground -------------------------
    def lowering(self, bodies: AbstractSet[int]) -> None:
        """The bricks a hand is setting down now (body ids; any earlier set is replaced): each
        comes to rest where it is to lie, the hand stopping it there (its velocities set to
        zero as it arrives, or as something first slows its fall), so its fall is no blow and
        the impact rule (report 3.6) does not weigh it. Once the hand has let go of a brick, it
        is weighed as any other.

        A placed Jenga block lowered onto three frozen ones was weighed as a blow on each, the
        frozen stack's parts weighed again at every placement (O(N^2) over a build): 189 blows
        and 106 ms of an 18-level tower's 390 ms build, none of which the engine ever
        delivered. Source: stackdsl's own (the report weighs every blow, 3.6).
        """
        self._stack.lowered = frozenset(bodies)

    def guide(
        self,
        body: int,
        time: float,
        reason: str,
        speed: float = 0.0,
        pull: tuple[float, float, float] | None = None,
        velocity: tuple[float, float, float] | None = None,
        aim: int | None = None,
    ) -> list[StabilityEvent]:
        """An outside hand moves ``body`` from now on (a gripper pulling a brick out, a pusher), at
        ``speed`` m/s along its path: it wakes, with everything resting on it (report 3.3.7), and
        is never frozen while guided. Now, and each step, the frozen bricks it touches, or will
        within the step at the faster of its speed and the hand's, wake too, with what rests on
        them, and the active bricks it touches are not admitted: friction on a moving body is
        what drags them (a pulled brick carries the bricks above it along). A pusher set going
        at 10 m/s, still at rest in the engine, met the frozen domino it was aimed at within its
        first step, unseen, and was stopped by it.

        The frozen bricks that carry what rests on ``body`` beside it (:meth:`_beside`: the other
        blocks of a pulled Jenga block's level, the other base of a bridge) wake too: the hand
        changes the load they share, and a brick kept frozen where it came to rest under another
        load is an immovable support, tilted as it froze. A slick base brick 24 mm wide, frozen
        0.03 deg tilted after its landing at 240 Hz (its edge 6.5 um up, within the engine's
        contact depth), carried the bricks bridging it and the pulled one on that edge alone: the
        pulled brick then carried 60% of their weight instead of half, the edge held them by two
        points, not four, and the tower above rode along at 80% of the pull's speed, at pair
        friction 0.12 as at 0.32.

        A pulled brick (``pull``: its velocity, m/s) is proved first (:class:`stability._drag.PullProof`):
        when the frozen stack stands without it and the other supports of what it carries, and
        of what it rests on, hold the drag of its friction, it wakes alone and the bricks it
        slides between stay frozen, the proof asked again as its overlap with them shrinks
        (:meth:`_guided`); when the proof fails, then or later, they wake as above. Returns the
        events. Raises KeyError for an unknown body. Source: stackdsl's own.

        ``velocity`` (m/s, the hand's along its path; a pull's by default) is the direction the
        impact rule asks of a brick the body drives: a frozen brick it closes on across that
        direction is not driven into by the hand (:meth:`stability._impact.Impacts.check`).

        A body guided without a ``pull`` pushes: a frozen brick carrying others that it pushes
        along its level is driven by the hand as a pulled brick is (:meth:`_drive`). ``aim``: the
        brick the push is aimed at, when it names one; while that brick is frozen and carries
        others, the push drags from its start (:meth:`drags`)."""
        stack = self._stack
        hand = velocity if velocity is not None else pull
        if hand is not None:
            stack.hand_velocity[body] = np.asarray(hand, dtype=float)
        if pull is None and stack.bodies[body].state is not BrickState.FROZEN:
            self._pushers.add(body)
            if aim is not None:
                self._aims[body] = aim
        falls = False  # statics proved that what it carries falls without it (PullProof.falls)
        if pull is not None and stack.bodies[body].state is BrickState.FROZEN:
            near = stack.engine.near(body, speed * stack.engine.timestep + TOUCH)
            proof = PullProof(stack, body, np.asarray(pull, dtype=float), near, held=body not in self._driven)
            if proof.why is None:
                why = f"{reason}; the bricks it slides between stay frozen: statics holds them without it and against its drag"
                events = [w.event for w in stack.wake(body, time, why, alone=True)]
                stack.guided.add(body)
                stack.hand_speed[body] = speed
                self._proofs[body] = (
                    proof,
                    proof.overlaps(footprint(stack.bodies[body].box.half_extents, stack.engine.pose(body))),
                )
                return events + self._touching(body, time, {})
            reason, falls = f"{reason}; statics does not keep the bricks it slides between frozen: {proof.why}", proof.falls
            under = proof.unmoved_below(stack.pose(stack.bodies[body])) if falls else frozenset()
            return self._guide(body, time, reason, speed, falls, under)
        return self._guide(body, time, reason, speed, falls)

    def driven(self) -> list[str]:
        """The labels of the bricks a pusher drives now, as a hand pulls a brick (:meth:`_drive`)."""
        return [self._stack.bodies[b].label for b in self._driven if b in self._stack.bodies]

    def on_path(self) -> dict[int, int]:
        """The bricks a pusher drives under a proof now (body -> the pusher): the proof takes each
        as a hand takes a pulled brick, moving along the hand's path with its orientation held
        (:class:`stability._drag.PullProof`), and the bricks it slides between stay frozen, so
        the engine must move it so too (a free block pushed by a finger between frozen bricks
        rocked between the levels above and below, which give no way as a weight does, and
        was thrown). Empty once the proof is lost or the push has ended. Source: stackdsl's own.
        """
        return {b: pusher for b, pusher in self._driven.items() if b in self._proofs}

    def glide_room(self, body: int) -> float:
        """Metres guided ``body``, pulled under its proof, may be carried on along its pull before
        a glide must stop for a look at its overlaps (:meth:`PullProof.room
        <stability._drag.PullProof.room>`), or where that is less, as far as a stepped pull goes
        before it next looks at them (:meth:`PullProof.unlooked
        <stability._drag.PullProof.unlooked>`); 0 for a brick pulled without a proof, or when
        another brick moves or rides. :meth:`glides` decides. Source: stackdsl's own."""
        proved = self._gliding(body)
        if proved is None:
            return 0.0
        proof, areas = proved
        pose = self._stack.engine.pose(body)
        return max(proof.room(areas, pose), proof.unlooked(pose.position))

    def _gliding(self, body: int) -> tuple[PullProof, dict[int, float]] | None:
        """The proof of guided ``body`` and its overlaps when it alone moves: no other active
        brick, no ride, no pusher (:meth:`glides`); None else."""
        stack, proved = self._stack, self._proofs.get(body)
        if proved is None or stack.rides or self._pushers or self._driven or len(stack.active) != 1 or body not in stack.active:
            return None
        return proved

    def glides(self, body: int, to: Pose) -> bool:
        """May guided ``body``, pulled under its proof (:meth:`guide`), be carried straight from
        where it is to ``to`` (a pose on its hand's path) without the steps between? Yes when
        nothing the extension watches can change on the way: it is the only brick that moves
        (no other active brick, no ride, no pusher), every brick its proof keeps is frozen, no
        contact area the proof holds can have shrunk past the point where it is checked again
        (:data:`stability._drag.SHRINK`, as :meth:`_reprove` asks it) nor gone at ``to``
        (:meth:`PullProof.unchanged <stability._drag.PullProof.unchanged>`, a bound that grows
        with the way along the path; the step after the glide looks at the overlaps again) or
        ``to`` is short of where a stepped pull would next look at them (:meth:`PullProof.unlooked
        <stability._drag.PullProof.unlooked>`: it asks nothing of them before), a support still
        carries it (the ground plane, unbounded, always does), and within the way and
        :data:`TOUCH` it meets only the ground, what its proof keeps and frozen bricks it slides
        past (:meth:`PullProof.alongside <stability._drag.PullProof.alongside>`). The frozen
        stack is then the same whatever the pulled brick does on the way: the steps skipped would
        only have moved the brick itself, along the hand's path at its own height, and tilted it
        once it slides past its last support's edge (held by what lies on it; it falls from there
        a little sooner or later, docs/actions.md). Source: stackdsl's own."""
        stack, proved = self._stack, self._gliding(body)
        if proved is None:
            return False
        proof, areas = proved
        if any(stack.bodies[b].state is not BrickState.FROZEN for b in proof.kept) or proof.tipping(to.position):
            return False
        if not proof.unchanged(areas, to) and proof.unlooked(to.position) <= 0.0:
            return False  # its overlaps may have changed, and a stepped pull would have looked by then
        if not any(areas[s] > 0.0 or isinstance(stack.bodies[s].shape, Plane) for s in proof.supports):
            return False  # past its last support's edge (a ground plane has none)
        pose = stack.engine.pose(body)
        way = float(np.linalg.norm(to.position - pose.position)) + TOUCH
        for c in stack.engine.near(body, way, self._unkept(body, proof.kept)):
            other = stack.bodies.get(c.other)
            if other is None or other.state is BrickState.GROUND:
                continue
            if other.state is not BrickState.FROZEN or not proof.alongside(c):
                return False
        return True

    def _hand(self, body: int) -> str:
        """How the hand moves guided ``body``, in a word: "push" (a brick a pusher drives,
        :meth:`_drive`) or "pull"."""
        return "push" if body in self._driven else "pull"

    def drags(self, body: int) -> bool:
        """Whether guided ``body`` drags bricks the engine moves: a pulled brick, or a pusher's
        driven brick (:meth:`_drive`), that no proof keeps alone (:meth:`guide`: with a proof,
        the bricks it slides between stay frozen and nothing it touches moves with it). A pusher
        drags from its start while the brick it is aimed at is frozen and carries others: the
        drag it will put on them is stepped from the first (a side block of a Jenga level 11
        pushed 30 mm dragged level 12 11 mm when the steps were split from the push's start, as
        both tuned engines drag it, and 0.3 mm when they were split from the step it was first
        driven); a pusher that drives no brick carrying others drags none."""
        if body in self._pushers:
            aim = self._stack.bodies.get(self._aims.get(body, -1))
            if aim is not None and aim.state is BrickState.FROZEN and aim.objects_above:
                return True
            return any(pusher == body and brick not in self._proofs for brick, pusher in self._driven.items())
        return body not in self._proofs

    def _guide(
        self, body: int, time: float, reason: str, speed: float, falls: bool = False, under: frozenset[int] = frozenset()
    ) -> list[StabilityEvent]:
        """:meth:`guide` without a proof: ``body`` wakes with what rests on it and the bricks
        beside; or, when the engine can merge them (:meth:`_riders`), only the bricks resting on
        it and those resting on them wake, with those beside, and everything frozen above rides
        them as one rigid body (:meth:`_rides` ends the ride). With ``falls`` (statics proved
        that the frozen stack does not stand without ``body``), everything above rides it.
        The frozen bricks ``under`` it that its friction cannot drag, whatever it carries
        (:meth:`stability._drag.PullProof.unmoved_below`, asked where ``falls``), stay frozen as
        it slides on them."""
        stack = self._stack
        label = stack.bodies[body].label
        if falls:
            self._felling.add(body)
        else:  # an id of a brick forgotten may be taken again
            self._felling.discard(body)
        if under:
            self._under[body] = under
            reason += f"; {', '.join(stack.bodies[b].label for b in stack.ordered(under))} under it stay frozen: its friction cannot drag them under any load"
        above = self._above(body)
        beside = self._beside(body, above)
        carried, riders = self._riders(body, above, beside, falls)
        if riders and stack.ride(body, riders):
            events = [w.event for w in stack.wake(body, time, reason, alone=True)]
            for a in carried:
                on = label if body in stack.bodies[a].rests_on else f"what rests on {label}"
                why = f"rests on {on}, which a hand moves; the {len(riders)} bricks above ride as one rigid body"
                events += [w.event for w in stack.wake(a, time, why, alone=True)]
            for other, on in beside:
                events += [
                    w.event for w in stack.wake(other, time, f"carries {on} beside {label}, which a hand moves", alone=True)
                ]
            # frozen in these books, moved by the engine: the runtime reads and records them as moving
            self._ride_hands[body] = self._hand(body)  # said again when the ride ends, maybe after the push
            words = f"rides the {self._ride_hands[body]} of {label}, one rigid body of {len(riders)} bricks in the engine"
            events += [StabilityEvent(time, "ride", stack.bodies[b].label, words) for b in riders]
        else:
            events = [w.event for w in stack.wake(body, time, reason)]
            for other, on in beside:
                events += self.wake(other, time, f"carries {on} beside {label}, which a hand moves")
        stack.guided.add(body)
        stack.hand_speed[body] = speed
        return events + self._touching(body, time, {})

    def _riders(
        self, body: int, above: set[int], beside: list[tuple[int, str]], falls: bool = False
    ) -> tuple[list[int], list[int]]:
        """The bricks to wake, and the frozen bricks above them (``above``: everything resting on
        ``body``, :meth:`_above`) that may ride them merged into one rigid body (at least
        :data:`RIDERS`), each in the order they froze: everything above is frozen, and every
        brick beside carries nothing else (a frozen brick left on a woken one would be an
        immovable support on a moving body). The riders are empty when they may not ride, and
        then the bricks to wake are those resting on ``body``.

        The bricks on ``body`` stay bodies of their own: its friction drags them, and how far
        is decided by how each shares its load between ``body`` and the bricks beside (a side
        block of a Jenga level drags the level above at the limit of its friction: merged with
        what it carries, that level slid 22 mm where, free, it slid 0.6 mm). So do the bricks
        resting on them: their friction ties the dragged bricks into one level, which holds a
        side pull's twist that no dragged brick holds alone (docs/results/pull_coupled.py:
        0.89 of the drag alone, 1.14 tied, at equal shares); merged into the riders' body, that
        tie held less in pybullet, and 5 of 40 side pulls of a Jenga tower that stand free slid
        their level 18 to 28 mm (docs/results/actions-freeze.md).

        Not where the pull fells them (``falls``: statics proved that the frozen stack does not
        stand without ``body``): then the bricks on ``body`` ride with everything above them,
        one rigid body, until the ride's own proof fails (:meth:`_tilted`: it tilts, or comes
        near a body it did not touch). How far a side block of a Jenga level left on it and one
        other drags the tower above is a Coulomb tie at equal shares (its friction's drag is
        what the other block's friction holds), which the engines decide apart: one, free or
        merged, drags the tower at half the pull's speed, the other not at all (docs/actions.md,
        "A pull that fells the tower"). Either way the riders must be one piece: a frozen brick
        linked to the others by their contacts, each through a chain of them, which on the usual
        path may pass through the bricks woken under them (a Jenga tower's top level, three
        blocks side by side, is one piece through the level it crosses; two stacks on one
        pulled plank, linked only through the plank, ride as none)."""
        stack = self._stack
        carried = stack.bodies[body].objects_above
        if any(stack.bodies[a].state is not BrickState.FROZEN for a in above):
            return stack.ordered(carried), []
        if any(not stack.bodies[b].objects_above <= above for b, _ in beside):
            return stack.ordered(carried), []
        if falls and len(above) >= RIDERS and self._one_piece(above):
            return [], stack.ordered(above)
        woken = carried | {t for a in carried for t in stack.bodies[a].objects_above}
        riders = above - woken
        if len(riders) < RIDERS or not self._one_piece(riders, woken):
            return stack.ordered(carried), []
        return stack.ordered(woken), stack.ordered(riders)

    def _one_piece(self, bricks: set[int], through: set[int] | None = None) -> bool:
        """Whether ``bricks`` are linked into one piece by what each rests on among them and the
        bricks of ``through`` (the woken bricks they ride on: the top level of a Jenga tower, three
        blocks side by side, is one piece through the level under it, each block of which it
        crosses; two stacks on one moved plank are two, linked only through the plank)."""
        nodes = bricks | (through or set())
        index = {b: i for i, b in enumerate(sorted(nodes))}
        links = [(i, index[s]) for b, i in index.items() for s in self._stack.bodies[b].rests_on if s in index]
        rows, cols = [i for i, _ in links], [j for _, j in links]
        graph = coo_matrix((np.ones(len(links)), (rows, cols)), shape=(len(index), len(index)))
        labels = connected_components(graph, directed=False)[1]
        return len({int(labels[index[b]]) for b in bricks}) == 1

    def _above(self, body: int) -> set[int]:
        """Every brick resting on ``body``, or on one that does (what :meth:`wake` of ``body`` wakes)."""
        stack = self._stack
        above: set[int] = set()
        todo = [body]
        while todo:
            for a in stack.bodies[todo.pop()].objects_above:
                if a not in above:
                    above.add(a)
                    todo.append(a)
        return above

    def _beside(self, body: int, above: set[int]) -> list[tuple[int, str]]:
        """The frozen bricks that carry one of ``above`` (:meth:`_above` of ``body``) and are not
        woken with it, each with the label of one brick it carries, in body order."""
        stack = self._stack
        beside: dict[int, str] = {}
        for a in sorted(above):
            for s in stack.bodies[a].rests_on:
                if s != body and s not in above and stack.bodies[s].state is BrickState.FROZEN:
                    beside.setdefault(s, stack.bodies[a].label)
        return sorted(beside.items())

    def forget(self, body: int) -> None:
        """Take ``body`` out of the extension: a guided body the hand took away (it must have left
        what it touched: the harness moves it out of the scene first). Raises KeyError for an
        unknown body, ValueError for a frozen one. Source: stackdsl's own."""
        self._proofs.pop(body, None)
        self._under.pop(body, None)
        if body not in self._stack.rides:  # else its ride's end asks it
            self._felling.discard(body)
        self._unkept_at.pop(body, None)
        self._gaps.pop(body, None)
        self._pushers.discard(body)
        self._driven.pop(body, None)
        self._aims.pop(body, None)
        self._push_axes.pop(body, None)
        for brick in [b for b, pusher in self._driven.items() if pusher == body]:
            self._let_go(brick)
        self._stack.forget(body)

    def _let_go(self, brick: int) -> None:
        """The push that drove ``brick`` (:meth:`_drive`) has ended: it is a brick like any other
        again, and the frozen bricks kept resting on it are watched (:meth:`Stack.watch`), waking
        once it moves :data:`WATCH` from where it is now (a pushed block stops within a fraction
        of a millimetre once the hand does)."""
        stack = self._stack
        del self._driven[brick]
        self._proofs.pop(brick, None)
        self._unkept_at.pop(brick, None)
        self._gaps.pop(brick, None)
        stack.unguide(brick)
        rec = stack.bodies.get(brick)
        if rec is not None and rec.state is BrickState.ACTIVE:
            kept = {r.body for r in stack.frozen.values() if brick in r.rests_on}
            if kept:
                stack.watch(rec, kept)

    def _guided(self, time: float) -> tuple[list[StabilityEvent], dict[int, np.ndarray | None]]:
        """Wake the frozen bricks each guided body touches or will within a step (:data:`TOUCH`
        beyond what it travels in one); return the events and every body a guided one touches,
        with the hand's velocity that drives it (None when the hand gave none)."""
        events: list[StabilityEvent] = []
        touched: dict[int, np.ndarray | None] = {}
        for body in sorted(self._stack.guided):
            if body in self._proofs:
                events += self._reprove(body, time)
            if self._left_behind(body):
                self._let_go(body)
                continue
            events += self._touching(body, time, touched)
        return events, touched

    def _left_behind(self, body: int) -> bool:
        """Whether ``body`` is a brick a pusher drove (:meth:`_drive`), no proof keeps it, and the
        pusher is :data:`LEFT` clear of it: the push has let it go before its end, and it is a
        brick like any other again (:meth:`_let_go`). Driven to the push's end, a Jenga block
        pushed out of level 3 that fell to the ground beside the tower, the finger passing 17 mm
        above it, woke the tower's 25 other bricks 13 times in 0.55 s, each "touched by" the
        block "which a hand moves" at the push's speed, where it lay still. Source: stackdsl's own."""
        pusher = self._driven.get(body)  # a pusher forgotten has let go of what it drove (:meth:`forget`)
        if pusher is None or body in self._proofs:
            return False
        return not self._stack.engine.near(pusher, LEFT, (body,))

    def _reprove(self, body: int, time: float) -> list[StabilityEvent]:
        """Keep the proof of a pull (:meth:`guide`) or, when it no longer holds (a brick it kept
        frozen was woken, or the drag of the overlap left is not held), wake what it kept, as a
        pull without a proof does."""
        stack = self._stack
        proof, areas = self._proofs[body]
        why = next(
            (f"{stack.bodies[b].label} was woken" for b in proof.kept if stack.bodies[b].state is not BrickState.FROZEN), None
        )
        if why is None:
            pose = stack.engine.pose(body)
            if not proof.moved(pose.position):
                return []
            tipping = proof.tipping(pose.position)  # a pushed brick nearing its support's edge
            if not tipping and proof.unchanged(areas, pose):
                return []
            at = footprint(stack.bodies[body].box.half_extents, pose)
            now = proof.overlaps(at, pose)
            changed = {a for a in now if now[a] <= areas[a] - SHRINK * proof.area[a] or (areas[a] > 0.0 and now[a] == 0.0)}
            if not changed and not tipping:
                return []
            why = proof.check(at, pose.position, changed | proof.below.keys() if changed else set())
            if why is None:
                self._proofs[body] = (proof, areas | {a: now[a] for a in changed})
                return []
        del self._proofs[body]
        events: list[StabilityEvent] = []
        label = stack.bodies[body].label
        for a in stack.ordered(proof.carried):  # what rested on it, kept frozen until now
            events += self.wake(a, time, f"rests on {label}, which a hand moves: {why}")
        for b in stack.ordered(proof.beside):  # and what carries it beside it: its load changes
            if b in stack.bodies:
                events += self.wake(b, time, f"carries what rested on {label}, which a hand moves, beside it: {why}")
        how = f"{self._hand(body)}ed by hand, its proof lost: {why}"
        return events + self._guide(body, time, how, stack.hand_speed.get(body, 0.0))

    def _touching(self, body: int, time: float, touched: dict[int, np.ndarray | None]) -> list[StabilityEvent]:
        """Wake the frozen bricks guided ``body`` touches or will within a step, at the faster of
        its speed in the engine and its hand's; add every body it touches to ``touched``, with
        the hand's velocity."""
        stack, events = self._stack, []
        speed = max(stack.engine.speeds(body)[0], stack.hand_speed.get(body, 0.0))
        proved = self._proofs.get(body)
        if proved is not None:
            kept = proved[0].kept
        else:
            kept = frozenset(stack.rides[body].riders if body in stack.rides else ()) | self._under.get(body, frozenset())
        reach = speed * stack.engine.timestep + TOUCH
        if kept:  # what it may touch: the engine asked when it may have come that near (stability._gap)
            points, self._gaps[body] = near_within(
                stack, body, stack.bodies[body].box.half_diagonal, self._unkept(body, kept), reach, self._gaps.get(body)
            )
        else:
            points = stack.engine.near(body, reach)
        for c in points:
            other = stack.bodies.get(c.other)
            if other is None or other.state is BrickState.GROUND or c.other in kept:
                continue
            if proved is not None and other.state is BrickState.FROZEN and proved[0].alongside(c):
                continue  # it slides past it, never toward it
            touched[c.other] = stack.hand_velocity.get(body)
            if other.state is BrickState.FROZEN:
                way = self._pushes(c, body) if body in self._pushers else "into"
                if way == "past":
                    continue  # a pusher gliding by it, clear of it, never toward it
                if way == "into" and body in self._pushers and other.objects_above:
                    events += self._drive(c.other, body, time)
                else:
                    events += self.wake(c.other, time, f"{self._by(c, body)}, which a hand moves")
        return events

    def _by(self, contact: ContactPoint, guided: int) -> str:
        """How the frozen brick of ``contact`` (one of ``guided``'s contact points, its normal from
        that brick into ``guided``) meets it, in words for its wake: it carries it (the normal
        within the support angle of straight up), rests on it (of straight down), or is touched by
        it (a new user read "touched by L03.2" of the level under a pulled L03.2 as a blow)."""
        label = self._stack.bodies[guided].label
        up = float(contact.normal[2])
        if up >= self._areas.support_cos:
            return f"carries {label}"
        if -up >= self._areas.support_cos:
            return f"rests on {label}"
        return f"touched by {label}"

    def _pushes(self, contact: ContactPoint, pusher: int) -> str:
        """How ``pusher``, held on a straight path, meets the frozen brick of ``contact`` (one of
        the pusher's contact points, its normal from that brick into the pusher): "past" it,
        when the pusher's box, swept along the hand's velocity, misses the brick's box (their
        shadows across the path overlap by :data:`GRAZE` at most: a finger gliding over the
        block under the one it pushes, a pusher's edge by the corner of the block beside, a
        finger's side flush with the neighbour of the block it pushes, which the engine reports
        touching along their shared edge); "into" a side of it along its level (the hand's
        velocity mostly horizontal, the face turned toward it within 60 deg); else "on" it.
        A finger flush with a Jenga block's neighbour drove the neighbour as pushed and carried
        the tower above it 50 mm along, where both tuned engines left it in place.
        Source: stackdsl's own."""
        stack = self._stack
        hand = stack.hand_velocity.get(pusher)
        if hand is None or not np.any(hand[:2]):
            return "on"
        normal = np.asarray(contact.normal, dtype=float)
        own = stack.bodies[pusher].box.corners(stack.engine.pose(pusher))
        axes, along = self._across(pusher, hand)
        for axis, (low, high) in zip(axes, self._shadow(stack.bodies[contact.other], axes), strict=True):
            a = own @ axis
            if a.max() <= low + GRAZE or high <= a.min() + GRAZE:
                return "past"
        facing = -float(normal[:2] @ along)
        level = abs(float(hand[2])) <= float(np.hypot(hand[0], hand[1])) and abs(float(normal[2])) < 0.5
        return "into" if level and facing >= 0.5 else "on"

    def _across(self, pusher: int, hand: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray], np.ndarray]:
        """The two axes across ``pusher``'s path (the hand's velocity ``hand``, m/s, shape (3,)):
        level, and square to the path and to it; and the path's horizontal direction. Found once
        for a hand's velocity: a push holds it from start to end."""
        key = tuple(hand.tolist())
        found = self._push_axes.get(pusher)
        if found is None or found[0] != key:
            way = np.asarray(hand, dtype=float) / float(np.linalg.norm(hand))
            side = np.cross(way, [0.0, 0.0, 1.0])
            axes = (side / float(np.linalg.norm(side)), np.cross(way, side) / float(np.linalg.norm(side)))
            along = np.asarray(hand[:2], dtype=float) / float(np.hypot(hand[0], hand[1]))
            found = self._push_axes[pusher] = (key, axes, along)
        return found[1], found[2]

    def _shadow(self, brick: Record, axes: tuple[np.ndarray, np.ndarray]) -> list[tuple[float, float]]:
        """The least and greatest of the frozen ``brick``'s corners along each of ``axes`` (a
        pusher's, :meth:`_across`): found once for the pose it froze at and those axes."""
        pose = self._stack.pose(brick)
        found = self._shadows.get(brick.body)
        if found is None or found[0] is not pose or found[1] is not axes:
            corners = brick.box.corners(pose)
            found = self._shadows[brick.body] = (
                pose,
                axes,
                [(float((corners @ a).min()), float((corners @ a).max())) for a in axes],
            )
        return found[2]

    def _drive(self, brick: int, pusher: int, time: float) -> list[StabilityEvent]:
        """The frozen ``brick``, which carries others, is pushed by ``pusher`` along its level:
        it is driven by the hand as a pulled brick is (:meth:`guide` with the pusher's velocity:
        its friction drags what rests on it, and what it rests on). Proved, it wakes alone and the
        bricks it slides between stay frozen (:class:`stability._drag.PullProof`, asked again as
        it moves); unproved, it wakes with what rests on it and the bricks beside that carry
        that, which stay in the engine while it is driven. Until the push ends (:meth:`forget`
        of the pusher), or lets it go once no proof keeps it and the pusher is clear of it
        (:meth:`_left_behind`), it is a guided body: never frozen, and what it touches wakes.

        Woken as a plain brick, everything resting on a pushed Jenga block woke, and froze again
        a tenth of a second later on the blocks beside it, the push's drag never weighed: a side
        block of level 11 pushed 30 mm left level 12 in place where both tuned engines and raw
        pybullet dragged it past the collapse threshold. Source: stackdsl's own."""
        stack = self._stack
        hand = stack.hand_velocity[pusher]
        self._driven[brick] = pusher
        velocity = (float(hand[0]), float(hand[1]), float(hand[2]))
        why = f"pushed by {stack.bodies[pusher].label}, moved by hand"
        return self.guide(brick, time, why, stack.hand_speed.get(pusher, 0.0), pull=velocity, velocity=velocity)

    def _unkept(self, body: int, kept: frozenset[int]) -> frozenset[int]:
        """The bodies guided ``body`` may touch that ``kept`` (frozen by its pull's proof, or riding
        it) leaves out, the ground aside: the engine is asked for closest points to these only.
        Found once a stack version and ``kept``."""
        stack = self._stack
        found = self._unkept_at.get(body)
        if found is None or found[0] != stack.version or found[1] != kept:
            bodies = frozenset(b for b, r in stack.bodies.items() if b not in kept and r.state is not BrickState.GROUND)
            found = self._unkept_at[body] = (stack.version, kept, bodies)
        return found[2]

    def _rides(self, time: float) -> list[StabilityEvent]:
        """End each ride whose pull has ended or that is no longer proved one rigid body
        (:meth:`_tilted`); or, of a shake (:meth:`_shaken`), whose riders' centre of mass has
        dropped by :data:`stability._ride.RIDE_DROP` from where they froze (they fall) or that
        has tilted by :data:`stability._ride.RIDE_TILT`; the events."""
        stack, events = self._stack, []
        for pulled in [p for p in self._limits if p not in stack.rides]:
            del self._limits[pulled]
        for key in [k for k in self._shaken_rides if k not in stack.rides]:
            del self._shaken_rides[key]
        for pulled, (label, riders, ground) in list(stack.rides.items()):
            hand = self._ride_hands.get(pulled, self._hand(pulled))  # a push's ride outlives the push's books
            what = f"rode the {hand} of {label}" if ground is None else f"rode the shaken {label}"
            rested = False
            proved = ground is None and pulled in stack.guided  # a hand still moves it: its proof asked
            if ground is None:
                why = self._tilted(pulled, riders, time, what) if proved else f"{what} as one body until it ended"
            else:
                why, rested = self._shaken(riders, ground, what)
                ride = self._shaken_rides.get(pulled)
                if ride is None or ride.riders != riders or ride.frozen is not stack.bodies[riders[0]].frozen_pose:
                    ride = self._shaken_rides[pulled] = ShakenRide.of(stack, riders)
                tilt, drop = ride.tilt_and_drop(*stack.engine.pose_floats(riders[0]))
                if why is None and drop > RIDE_DROP:
                    why = f"{what} as one body until its centre of mass dropped {drop * 1000:.2f} mm"
                elif why is None and tilt > RIDE_TILT:
                    why = f"{what} as one body until it tilted {tilt:.2f} deg"
            if why is not None:
                self._limits.pop(pulled, None)
                self._shaken_rides.pop(pulled, None)
                self._ride_hands.pop(pulled, None)
                settled = self._settle(pulled, riders, time, why) if rested else None
                if settled is not None:
                    events += settled
                    continue
                # a pull's or push's ride that tipped past its proof falls (the top of a Jenga tower
                # off its last block): its bricks are said to fall, which an engine may step as
                # debris; not one that ended with its hand (it may rest tilted where it was left),
                # unless statics proved that the stack above does not stand without the pulled brick
                frozen = stack.bodies[riders[0]].frozen_pose
                tipped = proved and frozen is not None and tilt_of(stack.engine.pose(riders[0]), frozen)[0] > RIDE_TILT
                falling = frozen is not None and (tipped or pulled in self._felling)
                self._felling.discard(pulled)
                woken = [w.event for w in stack.end_ride(pulled, time, why)]
                events += [replace(e, falling=True) for e in woken] if falling else woken
        return events

    def _settle(self, pulled: int, riders: tuple[int, ...], time: float, why: str) -> list[StabilityEvent] | None:
        """Freeze again, where they lie, the bricks that rode a shaken ground as one rigid body
        and have come to rest on it, the ground stopped (:meth:`_rides`, ``why`` their ride's
        end in words): each must have moved with the first as one rigid body, and lie face to face
        on the bodies it lay on when it froze, its centre of mass over them: on the ground by
        :func:`stability._geometry.face_overlap` at the pose the ride took it to, on another
        rider by the area they froze with, moved as the ride moved them (:func:`_moved`). Returns
        the events, or None, with nothing changed, when one does not (they then wake, as a
        ride's end wakes them).

        The ride proved that nothing in them slips, opens or tips: at rest on a still ground they
        stand as they froze. Woken instead, they were a stack the engine had never held, each
        brick only touching the one under it (frozen out of the engine's overlaps,
        :func:`stability._areas.overlap`): pybullet makes no contact between boxes that only
        touch until they overlap, and its 50 solver iterations, started cold, do not hold a
        tall column. A single file of 15 KAPLA bricks that had ridden a shake table sank 0.3 mm
        a joint within 0.05 s, buckled and fell, where both tuned engines keep it standing
        (docs/results/shake-table.md). Source: stackdsl's own."""
        stack = self._stack
        poses = {b: stack.engine.pose(b) for b in riders}
        part = set(riders)
        first = stack.bodies[riders[0]].frozen_pose
        assert first is not None, "a rider is frozen"
        turn = poses[riders[0]].rotation @ first.rotation.T  # the ride's rigid motion: x -> turn x + shift
        shift = poses[riders[0]].position - turn @ first.position
        found: dict[int, dict[int, ContactArea]] = {}
        for body in riders:
            rec = stack.bodies[body]
            assert rec.frozen_pose is not None, "a rider is frozen"
            if not _rigidly(rec.frozen_pose, poses[body], turn, shift):
                return None  # it moved in the ride: not the part that froze
            supports: dict[int, ContactArea] = {}
            for s in stack.ordered(rec.rests_on):
                was = rec.rests_on[s]
                other = stack.bodies[s]
                if s in part:  # moved with it: the same area, moved as they were
                    supports[s] = _moved(was, turn, shift)
                    continue
                if other.state is not BrickState.GROUND:
                    return None
                at = None if isinstance(other.shape, Plane) else stack.pose(other)
                area = face_overlap(rec.box, poses[body], other.shape, at, stack.config.face_gap)
                if area is None or area.area <= 0.0:
                    return None
                supports[s] = area
            if not supports or not self._areas.holds(main_area(supports), poses[body].position):
                return None
            found[body] = supports
        stack.unride(pulled)
        events = []
        for body in riders:  # in the order they froze: each after what it lies on
            rec, supports = stack.bodies[body], found[body]
            fallen, windowed = rec.clock.fallen, rec.clock.windowed
            stack.wake(body, time, why, alone=True)  # its books of where it froze go
            rec.clock.fallen, rec.clock.windowed = fallen, windowed
            lift = overlap((), supports, self._areas.support_cos)
            stack.freeze(rec, supports, main_area(supports), _face_polygons(stack, rec, supports), lift)
            names = ", ".join(stack.bodies[s].label for s in supports)
            events.append(StabilityEvent(time, "freeze", rec.label, f"{why}: frozen again where it lies, on {names}"))
        return events

    def _tilted(self, pulled: int, riders: tuple[int, ...], time: float, what: str) -> str | None:
        """Why the ride of ``riders`` on the pull of ``pulled`` ends now, in words led by
        ``what``, or None while it is one rigid body (module :mod:`stability._ride`): the
        gravity its bricks feel (:func:`stability._ride.felt_gravity`) tilts up to
        :data:`RIDE_TILT` as they froze; each time it tilts past what was proved, or out of its
        cone, they are proved again (:func:`stability._ride.holds_tilted`) for :data:`AHEAD`
        times that tilt, in its direction; and it ends when it comes within :data:`TOUCH` of a
        body it did not touch when it began."""
        stack = self._stack
        first = stack.bodies[riders[0]]
        assert first.frozen_pose is not None, "a rider is frozen"
        now = stack.engine.pose(first.body)
        velocity, spin = stack.engine.velocity(riders[0])
        limit = self._limits.get(pulled)
        if limit is None:
            touching = frozenset(c.other for c in stack.engine.near(riders[0], TOUCH))
            froze = [(r.box, r.frozen_pose) for r in (stack.bodies[b] for b in riders) if r.frozen_pose is not None]
            span, across, rise = arms_of(first.frozen_pose, froze)
            limit = self._limits[pulled] = RideLimit(
                RIDE_TILT, np.zeros(2), 0.0, touching, span, across, rise, velocity, spin, time
            )
        needed, towards, swirl = felt_gravity(limit, now, first.frozen_pose, velocity, spin, time, stack.config.gravity)
        if not limit.covers(needed, towards, swirl):
            tilt, _ = tilt_of(now, first.frozen_pose)
            if not math.isfinite(needed + swirl):  # an engine's motion gone wrong: nothing is proved of it
                return f"{what} as one body until its motion was no longer finite"
            if needed >= MOST_TILT:
                return f"{what} as one body until it tilted {tilt:.2f} deg: its bricks feel gravity tilted {needed:.0f} deg"
            if float(np.linalg.norm(towards)) == 0.0:  # upright: any direction, the swirl alone
                towards = np.array([1.0, 0.0])
            why: str | None = None
            for bound, more in ((min(AHEAD * needed, MOST_TILT), AHEAD * swirl), (min(needed + RIDE_TILT, MOST_TILT), swirl)):
                if limit.loads is None:
                    limit.loads = propagate(stack.nodes([stack.bodies[b] for b in riders]))
                why = holds_tilted(stack, riders, bound, towards, more, limit.loads, lambda: limit.tied_tilt(stack, riders))
                if why is None:
                    limit.bound, limit.direction, limit.swirl = bound, towards, more
                    break
            if why is not None:
                return f"{what} as one body until it tilted {tilt:.2f} deg: {why}"
        key = (stack.registrations, tuple(stack.rides))  # the bodies it may come to touch, found once for them
        if limit.others[0] != key:
            limit.others = (key, [b for b in stack.bodies if b not in stack.riding and b not in limit.touching and b != pulled])
        others = limit.others[1]
        hit = None
        if others:
            points, limit.gap = near_within(stack, riders[0], limit.span, others, TOUCH, limit.gap)
            hit = next(iter(points), None)
        if hit is not None:
            return f"{what} as one body until it came within {TOUCH * 1000:g} mm of {stack.bodies[hit.other].label}"
        return None

    def _shaken(self, riders: tuple[int, ...], ground: int, what: str) -> tuple[str | None, bool]:
        """Why the ride of ``riders`` on the shaken ``ground`` (:meth:`shake`) ends now, in words
        led by ``what``, or None; and whether they have come to rest on it, the ground stopped
        (they are frozen again where they lie, :meth:`_settle`). It ends too when they come
        within :data:`TOUCH` of a body other than the ground and each other (what they hit may
        part them)."""
        stack = self._stack
        config = stack.config
        if stack.admitting:  # the ground has stopped
            linear, angular = stack.engine.speeds(riders[0])
            if linear <= config.rest_speed and angular <= config.rest_angular_speed:
                return f"{what} as one body until it came to rest", True
        part = set(riders)
        others = [b for b in stack.bodies if b not in part and b != ground]
        hit = next(iter(stack.engine.near(riders[0], TOUCH, others)), None) if others else None
        if hit is not None:
            return f"{what} as one body until it came within {TOUCH * 1000:g} mm of {stack.bodies[hit.other].label}", False
        return None, False

    def shake(self, acceleration: tuple[float, float], ground: int, time: float, reason: str) -> list[StabilityEvent]:
        """Every frozen brick, for a ground about to shake with peak horizontal ``acceleration``
        (m/s^2, (a_x, a_y)) that the frozen stack does not withstand as it stands
        (:meth:`withstands`): each part of it that moves on ``ground`` as one rigid body
        (:func:`stability._shake.sliding_parts`: it slides on the ground, or the ground carries
        it, and nothing in it slips or tips) rides the ground merged into one body in the engine,
        when the engine can merge, and stays frozen here ("ride" events); every other brick wakes
        with ``reason`` (why the stack does not withstand it) and why its part does not ride.

        A ride ends (its bricks wake where it took them) when the ground has stopped and the part
        is at rest, when it tilts by :data:`RIDE_TILT` or drops by :data:`RIDE_DROP`, when it
        comes within :data:`TOUCH` of another body (the engine's ``near`` of a merged brick: of
        the whole merged body), or when a rule wakes one of its bricks. Returns the events.
        Source: stackdsl's own (module :mod:`stability._shake`)."""
        stack = self._stack
        events: list[StabilityEvent] = []
        peak = math.hypot(*acceleration)
        for part, why, carried in sliding_parts(stack, self._areas, acceleration, ground):
            if why is None and stack.ride(part[0], part, ground):
                floor = stack.bodies[ground].label
                how = (
                    f"sliding on {floor}, whose friction accelerates it by at most {carried:.3g} m/s^2"
                    if carried < peak
                    else f"carried by {floor} at {carried:.3g} m/s^2"
                )
                words = (
                    f"{reason}; moves as one rigid body of {len(part)} bricks, {how}: at that no contact above"
                    f" {floor} slips, opens or tips"
                )
                # the part's first brick says why; the others which brick's ride they are in
                first = stack.bodies[part[0]].label
                events.append(StabilityEvent(time, "ride", first, words))
                events += [
                    StabilityEvent(
                        time, "ride", stack.bodies[b].label, f"moves with {first}, one rigid body of {len(part)} bricks"
                    )
                    for b in part[1:]
                ]
                continue
            said = reason  # a brick alone is simulated alone
            if len(part) > 1:
                said += f"; not as one rigid body: {why or 'the engine cannot merge them'}"
            for body in part:
                events += self.wake(body, time, said)
        return events

    def withstands(self, acceleration: tuple[float, float]) -> str | None:
        """Would the frozen stack stand on a ground accelerating horizontally by ``acceleration``
        (m/s^2, (a_x, a_y)) either way, a shake's peak: under the effective gravity
        ``(-+a_x, -+a_y, -g)`` (:func:`stability._shake.withstands`)? None when it would; else why
        not, in words."""
        ax, ay = acceleration
        g = self._stack.config.gravity
        for sign in (1.0, -1.0):
            why = withstands(self._stack, (-sign * ax, -sign * ay, -g), self._stack.config.com_margin)
            if why is not None:
                return why
        return None

    def shake_limit(self, acceleration: tuple[float, float]) -> tuple[float, str] | None:
        """The least peak acceleration (m/s^2) along ``acceleration``'s direction (either way)
        that the frozen stack does not withstand by the report's tests, and the brick and test
        that fail first, in words (:func:`stability._shake.shake_limit`); None without a frozen
        brick, a direction, or where a frozen contact is not level."""
        if acceleration == (0.0, 0.0):
            return None
        return shake_limit(self._stack, acceleration, self._stack.config.com_margin)

    def wake_all(self, time: float, reason: str) -> list[StabilityEvent]:
        """Wake every frozen brick (report 3.3.7 from the bottom); returns the events."""
        events: list[StabilityEvent] = []
        for rec in list(self._stack.in_order()):
            events += self.wake(rec.body, time, reason)
        return events

    @property
    def admitting(self) -> bool:
        """Whether bricks at rest may be frozen: False while the ground moves under them (a
        brick frozen then would stay where it was in the world while the ground moves on)."""
        return self._stack.admitting

    @admitting.setter
    def admitting(self, on: bool) -> None:
        self._stack.admitting = on

    def certificate(self, deadline: float | None = None) -> Certificate:
        """Rigid-block equilibrium of every registered brick where it is now, frozen or not
        (:mod:`stability._certificate`): the proof that a structure stands, with its margin,
        or the bricks of its collapse mechanism.

        Args:
            deadline: ``time.perf_counter()`` seconds by which its programs must be solved
                (:func:`stability._lp.within`); None, no limit.

        Raises:
            OutOfTime: the deadline passed before the proof was found."""
        with within(deadline):
            return certify(self._stack, self._areas)

    # the brick graph ----------------------------------------------------------
    def graph(self) -> BrickGraph:
        """The brick graph now: frozen bricks as remembered, active ones from live contacts.
        A frozen brick riding a pull or a shaken ground (merged) is where the engine has carried
        it, with its centre of mass above carried by the same rigid motion: its part moves as one
        body, on the contact areas and load shares it froze with.

        Loads are propagated over every brick, frozen or not, so the graph is the same
        kind of object with the extension acting or not (the engine alone).
        """
        stack = self._stack
        bricks = [r for r in stack.bodies.values() if r.state is not BrickState.GROUND]
        nodes = self._stack.nodes(bricks)
        carried = {b: stack.engine.pose(b) for b in stack.riding}
        active = [r for r in bricks if r.state is BrickState.ACTIVE]
        contacts = by_body(self._stack.engine.contact_points()) if active else {}  # a frozen stack: none read
        boxes = self._areas.boxes(active=True) if active else None
        for r in active:
            pose = self._stack.pose(r)
            supports = self._areas.supports(r, contacts[r.body], False)
            # and what it lies on face to face: the engine has no contact yet between a brick
            # woken this step and the frozen one under it (two bodies of mass 0 had none), and
            # the level-5 bricks of a tower struck at level 6 "rested on nothing"
            faces = {o: a for o, a in self._areas.lying_on(r, pose, active=True, boxes=boxes).items() if o not in supports}
            if faces:
                supports = {o: supports.get(o) or faces[o] for o in self._stack.ordered({*supports, *faces})}
            nodes[r.body] = LoadNode(r.box.mass, pose.position, supports)
        loads = propagate(nodes)
        graph_nodes, edges = [], []
        for rec in self._stack.bodies.values():
            pose = self._stack.pose(rec) if not isinstance(rec.shape, Plane) else Pose(np.array([0.0, 0.0, rec.shape.height]))
            load = loads.get(rec.body)
            com = load.com_above if load else pose.position
            if rec.body in carried:  # the rigid motion from where it froze to where it is
                then, pose = pose, carried[rec.body]
                com = pose.position + pose.rotation @ then.rotation.T @ (np.asarray(com) - then.position)
            graph_nodes.append(GraphNode(rec.label, rec.state, pose, com, load.mass_above if load else 0.0))
            if load is None:  # the ground: no node, no supports
                continue
            for s, area in nodes[rec.body].supports.items():
                edges.append(
                    GraphEdge(rec.label, self._stack.bodies[s].label, area.area, load.shares.get(s, 0.0), area.exact, area.ring)
                )
        return BrickGraph(tuple(graph_nodes), tuple(edges))


def _farthest(corners: np.ndarray, before: np.ndarray) -> np.ndarray:
    """For each of n bricks, the largest distance (m) a corner has moved: ``corners`` and
    ``before`` of shape (n, 8, 3), metres; shape (n,)."""
    farthest: np.ndarray = np.sqrt(np.square(corners - before).sum(axis=2).max(axis=1))
    return farthest


#: Metres (and, as a matrix's entries, radians) by which a part that rode as one body may differ
#: from its first brick's motion and still count as moved rigidly with it (:func:`_rigidly`).
RIGID = 1e-6


def _rigidly(was: Pose, now: Pose, turn: np.ndarray, shift: np.ndarray) -> bool:
    """Has a body moved from ``was`` to ``now`` as ``x -> turn @ x + shift`` moves (within
    :data:`RIGID`)? Source: stackdsl's own."""
    there = turn @ was.position + shift
    return bool(np.max(np.abs(there - now.position)) <= RIGID and np.max(np.abs(turn @ was.rotation - now.rotation)) <= RIGID)


def _moved(area: ContactArea, turn: np.ndarray, shift: np.ndarray) -> ContactArea:
    """``area`` moved rigidly as a body moved from ``x`` to ``turn @ x + shift`` (a rotation matrix,
    shape (3, 3), and metres, shape (3,)): its corners on its plane moved, their horizontal
    projection the new area, their mean height its height. Two faces moved alike lie on each
    other as before; intersected anew, two faces whose edges coincide to 1e-17 m gave GEOS a point,
    not their area. Source: stackdsl's own."""
    corners = area.corners() @ turn.T + shift
    return ContactArea(shapely.polygons(corners[:, :2]), float(corners[:, 2].mean()), turn @ area.normal, area.exact, area.depth)


def _face_polygons(stack: Stack, rec: Record, supports: dict[int, ContactArea]) -> list[ContactPolygon[int]]:
    """The contact polygons of ``rec`` lying face to face on ``supports`` (each exact area on its
    plane, with the pair's friction coefficient)."""
    return [
        ContactPolygon(rec.body, o, a.corners(), a.normal, pair_friction(rec.friction, stack.bodies[o].friction))
        for o, a in supports.items()
    ]


def _flat_on(pose: Pose, area: ContactArea) -> bool:
    """Does a brick at ``pose`` lie on ``area`` with a face parallel to it, within
    :data:`stability._geometry.FACE_TILT`, not on an edge's strip? Source: stackdsl's own."""
    return float(np.max(np.abs(pose.rotation.T @ np.asarray(area.normal, dtype=float)))) >= FACE_TILT


def _slid(before: np.ndarray, after: np.ndarray) -> float:
    """Metres the farthest of a box's corners (shape (8, 3) each) moved sideways."""
    return float(np.max(np.hypot(*(after[:, :2] - before[:, :2]).T)))

"""The stability extension: freeze what the graph proves stable, wake what it proves not.

The report's method (chapter 3) on top of any :class:`Engine`. Each physics step the
harness calls :meth:`StabilityExtension.update`; it

1. gathers contact points and drops those between two unstable (active) bricks (3.3.1);
2. builds contact areas per support and their convex hull, the main contact area (3.3.3);
3. admits a brick whose speeds have stayed under the rest threshold for the rest
   duration and whose centre of mass lies over its main contact area (3.3.4), unless
   it rests on contacts at different heights (3.5); otherwise, when leaning is on,
   tests it as a leaning brick (3.4, :mod:`stability._leaning`); an admitted brick is
   frozen (immovable, still colliding);
4. when the stack changed, propagates centre of mass above and mass above (3.3.5-3.3.6)
   and wakes every brick whose centre of mass above lies outside its main contact area,
   with everything resting on it (3.3.7);
5. when impacts are on, compares the kinetic energy of every fast body about to touch a
   frozen brick with that brick's potential energy (3.6, :mod:`stability._impact`).

Propagation and the stack-wide test run only when the stack changes (a freeze or a
wake), never on a step where nothing did. pybullet reports no contacts between two
frozen bodies, so the extension keeps the contact graph it had when it froze them.
"""

from __future__ import annotations

import itertools
import math
from collections import defaultdict
from collections.abc import Iterable, Sequence
from collections.abc import Set as AbstractSet
from dataclasses import dataclass, field, replace
from typing import Literal, NamedTuple

import numpy as np
from shapely.geometry import Point
from shapely.geometry.base import BaseGeometry

from ._engine import ContactPoint, Engine
from ._equilibrium import GRAVITY, ContactPolygon, RigidBlock, is_level, solve_equilibrium
from ._geometry import Box, ContactArea, Plane, Pose, combined_hull, contains, face_overlap, padded_hull
from ._graph import BrickGraph, BrickState, GraphEdge, GraphNode
from ._impact import breaks_loose, kinetic_energy, potential_energy
from ._leaning import lean_polygon, leaning_stands, pair_friction
from ._load import LoadNode, propagate, propagate_fast
from ._load_path import load_path, proven, support_piece

MAX_PILE = 32
"""Most bricks the debris rule admits at once (one equilibrium program over all of them)."""


@dataclass(frozen=True)
class StabilityConfig:
    """Thresholds and rules of the stability extension (SI units).

    Attributes:
        rest_speed: m/s; a brick faster than this is not at rest, and a body faster
            than this that is about to touch a frozen brick is an impact (report 3.3.2, 3.6).
        rest_angular_speed: rad/s; likewise for rotation (report 3.3.2).
        rest_duration: s; speeds must stay under both thresholds this long before a
            brick is admitted. The report tests one frame; a brick just woken is at rest
            for that frame and would be refrozen at once, so stackdsl asks for a duration
            (its own).
        contact_pad: m; half-width of the padding of one- and two-point contact areas
            (report 3.3.3, 3.4.2).
        support_angle: degrees; a contact whose normal is within this angle of vertical
            is one the brick rests on (stackdsl's own).
        face_gap: m; two faces within this distance (and this flat) touch face to face,
            and their overlap is the exact contact area (stackdsl's own).
        com_margin: m; the centre of mass must lie this far inside the area (0: strictly
            inside; on the edge counts as unstable).
        lean_height: m; a brick whose support areas differ in height by more than this
            is not admitted by the basic test (report 3.5).
        leaning: run the leaning rule (report 3.4).
        max_leaning_bodies: a leaning brick may touch at most this many bodies (the
            report's model handles two).
        impacts: run the impact rule (report 3.6).
        debris: admit a resting brick the other rules refuse together with every resting
            brick it touches, and they with theirs, when rigid-block equilibrium holds them
            all against what is frozen (stackdsl's own): fallen bricks leaning on each other
            are frozen again, so that what lies still costs nothing.
        per_event: run the stack-wide test only when the stack changes (a freeze or a
            wake); False runs it on every step with an active brick (for measuring).
        model: ``"report"``: the report's rules (basic test, leaning test, centre of mass
            above against the main contact area); ``"equilibrium"``: admission and the
            stack-wide test by rigid-block equilibrium (:mod:`stability._equilibrium`).
        gravity: m/s^2.

    Raises:
        ValueError: an unknown model.
    """

    rest_speed: float = 0.005
    rest_angular_speed: float = 0.05
    rest_duration: float = 0.05
    contact_pad: float = 0.001
    support_angle: float = 30.0
    face_gap: float = 0.001
    com_margin: float = 0.0
    lean_height: float = 0.002
    leaning: bool = True
    max_leaning_bodies: int = 2
    impacts: bool = True
    debris: bool = True
    per_event: bool = True
    model: str = "report"
    gravity: float = GRAVITY

    def __post_init__(self) -> None:
        if self.model not in ("report", "equilibrium"):
            raise ValueError(f"unknown stability model {self.model!r}: 'report' or 'equilibrium'")


@dataclass(frozen=True)
class StabilityEvent:
    """Something the extension did: ``kind`` is ``"freeze"``, ``"wake"`` or ``"impact"``
    (an impact the stack held; every landing brick makes one); time in s; ``source`` is
    the impactor of an impact or of the wake it caused."""

    time: float
    kind: Literal["freeze", "wake", "impact"]
    label: str
    reason: str
    source: str = ""


class _Woken(NamedTuple):
    """A brick just woken, with the load node and contact polygons it had when frozen."""

    body: int
    node: LoadNode
    contacts: list[ContactPolygon[int]]
    event: StabilityEvent


@dataclass
class _Body:
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
    rest_since: float | None = None
    frozen_pose: Pose | None = None
    node: LoadNode | None = None
    impacted: set[int] = field(default_factory=set)
    load_path: BaseGeometry | None = None
    failed: tuple[tuple[object, ...], float] | None = None  # its last refusal: what it depended on, when

    @property
    def box(self) -> Box:
        """The shape of a brick: only environment bodies may be planes. Raises TypeError for a plane."""
        if not isinstance(self.shape, Box):
            raise TypeError(f"{self.label} is a plane, not a brick")
        return self.shape


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
        self._engine = engine
        self.config = config or StabilityConfig()
        self._bodies: dict[int, _Body] = {}
        self._active: dict[int, _Body] = {}  # the active bricks, so that a step costs what moves
        self._stack: dict[int, _Body] = {}  # the frozen bricks in the order they froze: supports first
        self._unproven: set[int] = set()  # frozen bricks with no load path under their centre of mass
        self._loads_fresh = True  # com_above / mass_above of every frozen brick are up to date
        self._version = 0  # counts the changes of the frozen stack (freezes and wakes)
        self._refused: tuple[int, set[tuple[tuple[int, float | None], ...]]] = (0, set())  # piles refused, at a version
        self._support_cos = math.cos(math.radians(self.config.support_angle))

    # registration -------------------------------------------------------------
    def add_ground(self, body: int, shape: Box | Plane, label: str = "ground", friction: float = 0.5) -> None:
        """Register an environment body (ground flag of report Figure 3): the ground
        plane or a fixed box; ``friction`` is its material's coefficient."""
        self._add(_Body(body, label, shape, BrickState.GROUND, len(self._bodies), friction))

    def add_brick(self, body: int, box: Box, label: str, friction: float = 0.5) -> None:
        """Register a brick; it starts active (simulated by the engine)."""
        self._add(_Body(body, label, box, BrickState.ACTIVE, len(self._bodies), friction))
        self._active[body] = self._bodies[body]

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
        return not self._active

    # the per-step hook --------------------------------------------------------
    def update(self, time: float) -> list[StabilityEvent]:
        """One step of the algorithm of report 3.3.1 (and 3.4-3.6). ``time`` in seconds."""
        if not self._active:
            return []
        active = sorted(self._active.values(), key=lambda r: r.order)
        events: list[StabilityEvent] = []
        resting = [rec for rec in active if self._at_rest(rec, time)]  # every clock first: partners
        # only a brick at rest asks, only of its own contacts (and its resting partners'), and a
        # brick refused asks again once a rest duration has passed and something has changed
        due = [rec for rec in resting if rec.failed is None or not self._soon(rec.failed, time)]
        contacts = _by_body(self._engine.contact_points([r.body for r in resting])) if due else {}
        for rec in due:
            if rec.state is not BrickState.ACTIVE:
                continue
            if rec.failed is not None and (attempt := self._attempt(rec, contacts, time)) == rec.failed[0]:
                rec.failed = (attempt, time)  # nothing it rests on, touches or is has changed: wait again
                continue
            if self.config.model == "equilibrium":
                found = self._admit_group(rec, contacts, time, limit=None)
            else:
                found = self._admit(rec, contacts, time)
                if not found and self.config.leaning:
                    found = self._admit_group(rec, contacts, time, limit=self.config.max_leaning_bodies)
            if not found and self.config.debris:
                found = self._admit_debris(rec, contacts, time)
            rec.failed = None if found else (self._attempt(rec, contacts, time), time)  # nothing changed since asking
            events += found
        if events or not self.config.per_event:
            events += self._test_stack(time)
        if self.config.impacts:
            hits = self._impacts(active, self._engine.timestep, time)
            events += hits
            if any(e.kind == "wake" for e in hits):
                events += self._test_stack(time)
        return events

    def _at_rest(self, rec: _Body, time: float) -> bool:
        lin, ang = self._engine.velocity(rec.body)
        cfg = self.config
        if float(lin @ lin) > cfg.rest_speed**2 or float(ang @ ang) > cfg.rest_angular_speed**2:
            rec.rest_since = None
            return False
        if rec.rest_since is None:
            rec.rest_since = time
        return self._rested(rec, time)

    def _rested(self, rec: _Body, time: float) -> bool:
        return rec.rest_since is not None and time - rec.rest_since >= self.config.rest_duration - 1e-9

    # admission ------------------------------------------------------------------
    def _attempt(self, rec: _Body, contacts: dict[int, list[ContactPoint]], time: float) -> tuple[object, ...]:
        """What an admission of ``rec`` depends on: the stack (its version), the brick's pose
        to 0.1 mm and 0.01 rad, and the bodies it touches with whether each is frozen or
        at rest. A brick refused once is not asked again until one of them changes."""
        pose = self._engine.pose(rec.body)
        where = tuple(round(float(v) * 1e4) for v in pose.position) + tuple(round(float(v) * 200) for v in pose.orientation)
        around = tuple(
            sorted(
                (o, self._bodies[o].state is not BrickState.ACTIVE or self._rested(self._bodies[o], time))
                for o in {c.other for c in contacts.get(rec.body, [])}
                if o in self._bodies
            )
        )
        return (self._version, where, around)

    def _soon(self, failed: tuple[tuple[object, ...], float], time: float) -> bool:
        """Was the refusal ``failed`` (what it depended on, when) less than a rest duration ago,
        on the same stack? Then the brick waits: in a heap that still settles around it, it
        would be asked every step."""
        return failed[0][0] == self._version and time - failed[1] < self.config.rest_duration

    def _admit(self, rec: _Body, contacts: dict[int, list[ContactPoint]], time: float) -> list[StabilityEvent]:
        """Single object stability (report 3.3.4): freeze when the COM is over the support."""
        supports = self._supports(rec, contacts.get(rec.body, []), stack_only=True)
        if not supports:
            return []
        heights = [a.height for a in supports.values()]
        if max(heights) - min(heights) > self.config.lean_height and not all(a.exact for a in supports.values()):
            return []  # report 3.5: contacts at different heights (not face to face on each): a leaning brick
        main = _main(supports)
        if not self._holds(main, self._engine.pose(rec.body).position):
            return []
        held = {o: pts for o, pts in self._touching(rec, contacts).items() if self._bodies[o].state is not BrickState.ACTIVE}
        self._freeze(rec, supports, main, self._polygons(rec, held, known=supports))
        names = ", ".join(self._bodies[s].label for s in supports)
        return [StabilityEvent(time, "freeze", rec.label, f"at rest on {names}")]

    def _admit_group(
        self, rec: _Body, contacts: dict[int, list[ContactPoint]], time: float, limit: int | None
    ) -> list[StabilityEvent]:
        """Admit ``rec`` (with a resting partner it leans on, if any) when friction holds it.

        The report's leaning test (3.4): a brick touching two bodies (``limit``), at least
        one of them in the stack or the ground; with the equilibrium model any number of
        bodies (``limit`` None). The members are balanced by rigid-block equilibrium
        against what is frozen (:func:`stability.leaning_stands`).
        """
        group = self._group(rec, contacts, time, limit)
        if not group:
            return []
        polygons = {
            m.body: self._polygons(m, self._touching(m, contacts), skip={g.body for g in group[:i]}) for i, m in enumerate(group)
        }
        members = {m.body: (self._engine.pose(m.body).position, m.box.mass) for m in group}
        if not leaning_stands(members, [c for cs in polygons.values() for c in cs], self.config.gravity):
            return []
        return self._freeze_group(group, polygons, self._touching(rec, contacts), time)

    def _group(self, rec: _Body, contacts: dict[int, list[ContactPoint]], time: float, limit: int | None) -> list[_Body]:
        """``rec`` and its partner, if it leans on one: an active brick at rest that touches
        ``rec`` and otherwise only the stack (the other brick of a V). Empty when ``rec``
        cannot be admitted this way."""
        touching = self._touching(rec, contacts)
        if not self._leans(touching, limit):
            return []
        partners = [self._bodies[o] for o in touching if self._bodies[o].state is BrickState.ACTIVE]
        if not partners:
            return [rec]
        if len(partners) > 1:
            return []
        (partner,) = partners
        theirs = self._touching(partner, contacts)
        if not (self._rested(partner, time) and rec.body in theirs and self._leans(theirs, limit)):
            return []
        if any(self._bodies[o].state is BrickState.ACTIVE for o in theirs if o != rec.body):
            return []
        return [rec, partner]

    def _admit_debris(self, rec: _Body, contacts: dict[int, list[ContactPoint]], time: float) -> list[StabilityEvent]:
        """Admit ``rec`` with the resting bricks it touches, and they with theirs (all of the
        connected pile at once), when rigid-block equilibrium holds them against what is
        frozen and, with the report model, the stack test would keep them frozen; nothing
        while a brick of the pile still moves or it touches nothing frozen.

        A refused pile is refused for every member: none of them asks again until something
        it depends on changes (:meth:`_attempt`), and the pile is not solved again until the
        stack changes or one of its bricks moves faster than the rest thresholds: a pile that
        creeps below them is still the pile refused. A pile that rests on the stack and on
        the ground at once (a tower fallen against the floor) stands by friction, but the
        report's load tree cannot carry it: frozen, the stack test would wake it at once, and
        it would be frozen and woken again every rest duration (stackdsl's own).
        """
        group = self._pile(rec, contacts, time)
        if self._refused[0] != self._version:
            self._refused = (self._version, set())
        key = tuple((m.body, m.rest_since) for m in group)
        if not group or key in self._refused[1]:
            return []
        skip: set[int] = set()
        polygons = {}
        for m in group:
            polygons[m.body] = self._polygons(m, self._around(m, contacts), skip=skip)
            skip.add(m.body)
        members = {m.body: (self._engine.pose(m.body).position, m.box.mass) for m in group}
        plan = self._plan(group, polygons)
        stands = self._carried(group, plan) and leaning_stands(
            members, [c for cs in polygons.values() for c in cs], self.config.gravity
        )
        if not stands:
            self._refused[1].add(key)
            for m in group:
                m.failed = (self._attempt(m, contacts, time), time)
            return []
        inside = {m.body for m in group}
        held: dict[int, list[ContactPoint]] = {o: [] for m in group for o in self._around(m, contacts) if o not in inside}
        return self._freeze_group(group, polygons, dict(sorted(held.items(), key=lambda i: self._bodies[i[0]].order)), time, plan)

    def _carried(self, group: list[_Body], plan: dict[int, tuple[dict[int, ContactArea], ContactArea]]) -> bool:
        """Would the report's stack test (:meth:`_test_report`) keep ``group`` frozen, frozen
        as ``plan`` says? Always True with the equilibrium model (its stack test is the
        equilibrium that :func:`stability.leaning_stands` checks)."""
        if self.config.model != "report":
            return True
        nodes = self._nodes(self._frozen())
        mains = {r.body: r.main_contact for r in self._frozen()}
        for m in group:
            nodes[m.body] = LoadNode(m.box.mass, self._engine.pose(m.body).position, plan[m.body][0])
            mains[m.body] = plan[m.body][1]
        loads = propagate_fast(nodes)
        return all(main is not None and self._holds(main, loads[b][0]) for b, main in mains.items())

    def _pile(self, rec: _Body, contacts: dict[int, list[ContactPoint]], time: float) -> list[_Body]:
        """``rec`` and the active bricks connected to it by contacts, in registration order;
        empty when one of them is not at rest, or none touches a frozen brick or the ground."""
        pile, queue, held = {rec.body: rec}, [rec], False
        while queue:
            for other in self._around(queue.pop(), contacts):
                o = self._bodies[other]
                if o.state is not BrickState.ACTIVE:
                    held = True
                elif other not in pile:
                    if not self._rested(o, time) or len(pile) >= MAX_PILE:
                        return []
                    pile[other] = o
                    queue.append(o)
        return sorted(pile.values(), key=lambda r: r.order) if held else []

    def _around(self, rec: _Body, contacts: dict[int, list[ContactPoint]]) -> dict[int, list[ContactPoint]]:
        """Every registered body ``rec`` touches, with the contact points, in registration order."""
        grouped: dict[int, list[ContactPoint]] = defaultdict(list)
        for c in contacts.get(rec.body, []):
            if c.other in self._bodies:
                grouped[c.other].append(c)
        return {o: grouped[o] for o in sorted(grouped, key=lambda b: self._bodies[b].order)}

    def _plan(
        self, group: list[_Body], polygons: dict[int, list[ContactPolygon[int]]]
    ) -> dict[int, tuple[dict[int, ContactArea], ContactArea]]:
        """How the members of a group would be frozen: each one's supports and main contact
        area, from its contacts in ``polygons`` (the one between two members under the later
        of them). A member lying only on other members rests on those lower than itself."""
        members, plan = {m.body for m in group}, {}
        pad = self.config.contact_pad
        for m in group:
            areas = {c.other: _horizontal(c, pad) for c in polygons[m.body]}
            for g in group:  # the contacts with the other members, seen from this side
                if g is not m:
                    areas.update((g.body, _horizontal(c, pad, flip=True)) for c in polygons[g.body] if c.other == m.body)
            supports = {o: a for o, a in areas.items() if o not in members}
            resting = {o: a for o, a in supports.items() if a.normal[2] >= self._support_cos}
            if not resting:  # lying only on other members: on those lower than itself (no cycle)
                z = self._engine.pose(m.body).position[2]
                lower = {o: a for o, a in areas.items() if o in members and self._engine.pose(o).position[2] < z}
                resting = {o: a for o, a in lower.items() if a.normal[2] >= self._support_cos} or supports
            plan[m.body] = (resting, _main(areas))
        return plan

    def _freeze_group(
        self,
        group: list[_Body],
        polygons: dict[int, list[ContactPolygon[int]]],
        touching: dict[int, list[ContactPoint]],
        time: float,
        plan: dict[int, tuple[dict[int, ContactArea], ContactArea]] | None = None,
    ) -> list[StabilityEvent]:
        """Freeze the members of an admitted group (``group[0]`` the brick that asked) as
        ``plan`` says (:meth:`_plan` when None); the members wake together."""
        rec, events = group[0], []
        plan = plan or self._plan(group, polygons)
        for m in group:
            resting, main = plan[m.body]
            self._freeze(m, resting, main, polygons[m.body])
            on = _names(self._bodies, touching, m) if m is rec else rec.label
            if len(group) > 2:
                reason = f"at rest in a pile of {len(group)} bricks {'on' if m is rec else 'with'} {on}"
            else:
                reason = f"{'leaning on' if len(touching) > 1 else 'at rest on'} {on}"
            events.append(StabilityEvent(time, "freeze", m.label, reason))
        for a, b in itertools.pairwise(group):
            a.objects_above.add(b.body)
            b.objects_above.add(a.body)
        return events

    def _touching(self, rec: _Body, contacts: dict[int, list[ContactPoint]]) -> dict[int, list[ContactPoint]]:
        """Registered bodies ``rec`` touches, with the contact points, in registration order.

        An active brick lying on ``rec`` (its contact normal within the support angle of
        straight down) is left out: it is a load, not a support (report 3.3.1 drops
        contacts between two unstable bricks); the stack test counts it once it is frozen.
        """
        return {
            o: pts
            for o, pts in self._around(rec, contacts).items()
            if not (self._bodies[o].state is BrickState.ACTIVE and np.mean([c.normal[2] for c in pts]) < -self._support_cos)
        }

    def _leans(self, touching: dict[int, list[ContactPoint]], limit: int | None) -> bool:
        """Two bodies (report 3.4.3; up to ``limit``, any number for None), at least one in
        the stack or the ground."""
        held = [o for o in touching if self._bodies[o].state is not BrickState.ACTIVE]
        if limit is None:
            return bool(held)
        return 2 <= len(touching) <= limit and bool(held)

    def _polygons(
        self,
        rec: _Body,
        touching: dict[int, list[ContactPoint]],
        skip: AbstractSet[int] = frozenset(),
        known: dict[int, ContactArea] | None = None,
    ) -> list[ContactPolygon[int]]:
        """One contact polygon per touched body (report 3.4.2): the exact face overlap where
        ``rec`` lies face to face on it, else the contact points padded across the normal.
        ``known``: contact areas already found for some of these bodies (from :meth:`_supports`)."""
        out = []
        pose = self._engine.pose(rec.body)
        known = known or {}
        for other, points in touching.items():
            if other in skip:
                continue
            o = self._bodies[other]
            friction = pair_friction(rec.friction, o.friction)
            if other in known:
                exact = known[other] if known[other].exact else None
            else:
                exact = face_overlap(
                    rec.box, pose, o.shape, None if isinstance(o.shape, Plane) else self._pose(o), self.config.face_gap
                )
            if exact is not None:
                ring = np.asarray(exact.polygon.exterior.coords)[:-1]
                polygon = np.column_stack([ring, np.full(len(ring), exact.height)])
                out.append(ContactPolygon(rec.body, other, polygon, exact.normal, friction))
                continue
            normal = np.mean([c.normal for c in points], axis=0)
            normal /= np.linalg.norm(normal)
            polygon = lean_polygon(np.array([c.position for c in points]), normal, self.config.contact_pad)
            out.append(ContactPolygon(rec.body, other, polygon, normal, friction))
        return out

    def _holds(self, main: ContactArea, point: Sequence[float] | np.ndarray) -> bool:
        """Centre of mass over the main contact area (by ``com_margin`` when it is set)."""
        if self.config.com_margin > 0:
            return contains(main.polygon, point, self.config.com_margin)
        return main.holds(float(point[0]), float(point[1]))

    def _freeze(
        self, rec: _Body, supports: dict[int, ContactArea], main: ContactArea, polygons: list[ContactPolygon[int]]
    ) -> None:
        self._engine.set_frozen(rec.body, True, rec.box.mass)
        rec.state, rec.rests_on, rec.main_contact, rec.contacts = BrickState.FROZEN, supports, main, polygons
        self._active.pop(rec.body, None)
        rec.frozen_pose = self._engine.pose(rec.body)
        rec.node = LoadNode(rec.box.mass, rec.frozen_pose.position, supports)
        self._stack[rec.body] = rec
        self._loads_fresh, self._version = False, self._version + 1
        for s in supports:
            self._bodies[s].objects_above.add(rec.body)
        if self.config.model == "equilibrium":
            self._prove(rec)

    def _prove(self, rec: _Body) -> None:
        """Find the load path of a brick being frozen (:mod:`stability._load_path`) and note
        it when its centre of mass is not over it."""
        pieces = []
        for c in rec.contacts:
            support = self._bodies[c.other]
            if c.other in rec.rests_on and is_level(c):
                pieces.append(support_piece(c.points, support.load_path, support.state is BrickState.GROUND))
        rec.load_path = load_path([p for p in pieces if p is not None])
        assert rec.frozen_pose is not None, "set by _freeze"
        if not proven(rec.frozen_pose.position, rec.load_path):
            self._unproven.add(rec.body)

    # the stack-wide test ---------------------------------------------------------
    def _test_stack(self, time: float) -> list[StabilityEvent]:
        """The stack-wide test of the configured model; returns the wake events."""
        if self.config.model == "report":
            return self._test_report(time)  # it computes the loads on the way
        return self._test_equilibrium(time)

    def _refresh_loads(self) -> None:
        """com_above / mass_above of every frozen brick, when the stack changed since they were
        last propagated (the impact rule uses them)."""
        if self._loads_fresh:
            return
        loads = propagate_fast(self._nodes(self._frozen()))
        for rec in self._frozen():
            rec.com_above, rec.mass_above = loads[rec.body][0], loads[rec.body][1]
        self._loads_fresh = True

    def _test_equilibrium(self, time: float) -> list[StabilityEvent]:
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
        under its centre of mass (:mod:`stability._load_path`): when every one has, the
        program has a solution already, so the stack stands.
        """
        events: list[StabilityEvent] = []
        while True:
            frozen = {r.body: r for r in self._frozen()}
            if not frozen or not self._unproven:
                return events
            ground = {k for k, r in self._bodies.items() if r.state is BrickState.GROUND}
            polygons = [c for r in frozen.values() for c in r.contacts if c.other in frozen or c.other in ground]
            touched = {c.body for c in polygons} | {c.other for c in polygons}
            moving = {b for b in frozen if b not in touched}  # rests on nothing that stays
            if not moving:
                blocks = {b: RigidBlock(r.box.mass, self._pose(r).position) for b, r in frozen.items()}
                result = solve_equilibrium(blocks, polygons, gravity=self.config.gravity)
                if result.stands:
                    return events
                moving = {b for b, v in result.mechanism.items() if v > 1e-4}
            for b in sorted(moving, key=lambda k: self._bodies[k].order):
                events += self.wake(b, time, "it moves in the collapse mechanism (rigid-block equilibrium)")

    def _test_report(self, time: float) -> list[StabilityEvent]:
        """Stack-wide test (report 3.3.1, 3.3.5) with the wake-up cascade (3.3.7).

        A brick whose centre of mass above lies outside its main contact area gives way
        (for a leaning brick the main contact area is the hull of all its contact areas,
        the other brick of a V included): it and everything above it wake.
        Beyond the report: the woken bricks above it that also rest on other stack bricks
        now lean on those alone, so the test is repeated with their load on them
        (co-support re-test). Without it a tower whose two sibling bricks carry it
        together stays pinned by the sibling that did not fail first (measured on the
        slant tower; docs/design.md, where the code departs from the report).
        """
        events: list[StabilityEvent] = []
        gave_way: set[int] = set()
        leaning: dict[int, LoadNode] = {}
        while True:
            nodes = self._nodes(self._frozen())
            for body, node in leaning.items():
                kept = {s: a for s, a in node.supports.items() if s not in gave_way}
                if kept:
                    nodes[body] = LoadNode(node.mass, node.com, kept)
            loads = propagate_fast(nodes)
            failing = []
            for rec in self._frozen():
                rec.com_above, rec.mass_above = loads[rec.body][0], loads[rec.body][1]
                assert rec.main_contact is not None, "a frozen brick has a main contact area"
                if not self._holds(rec.main_contact, rec.com_above):
                    failing.append(rec)
            if not failing:
                self._loads_fresh = True
                return events
            for rec in failing:
                if rec.state is not BrickState.FROZEN:  # woken already, resting on one that failed
                    continue
                gave_way.add(rec.body)
                assert rec.main_contact is not None and rec.com_above is not None, "set for every frozen brick above"
                out = rec.main_contact.polygon.exterior.distance(Point(rec.com_above[:2])) * 1000
                for w in self._wake(rec.body, time, f"centre of mass above {out:.1f} mm outside its support"):
                    events.append(w.event)
                    if w.body != rec.body:
                        leaning[w.body] = w.node

    def _nodes(self, bricks: Iterable[_Body]) -> dict[int, LoadNode]:
        return {r.body: r.node or LoadNode(r.box.mass, self._pose(r).position, r.rests_on) for r in bricks}

    def _frozen(self) -> list[_Body]:
        """The frozen bricks, in the order they froze (each after its supports)."""
        return list(self._stack.values())

    # impacts (report 3.6) ------------------------------------------------------------
    def _impacts(self, active: list[_Body], dt: float, time: float) -> list[StabilityEvent]:
        """Fast bodies about to touch a frozen brick: wake it, or let the stack hold."""
        events: list[StabilityEvent] = []
        for rec in active:
            speed = float(np.linalg.norm(self._engine.velocity(rec.body)[0]))
            if speed <= self.config.rest_speed:
                rec.impacted.clear()
                continue
            heading = self._engine.velocity(rec.body)[0] / speed
            for hit in self._engine.near(rec.body, speed * dt * 1.5 + self.config.contact_pad):
                other = self._bodies.get(hit.other)
                if other is None or other.state is not BrickState.FROZEN or other.body in rec.impacted:
                    continue
                if not _ahead(hit, heading, self.config.contact_pad):
                    continue
                rec.impacted.add(other.body)
                kinetic = kinetic_energy(rec.box.mass, speed)
                base = min(a.height for a in other.rests_on.values())
                self._refresh_loads()
                assert other.com_above is not None, "the stack test sets it for every frozen brick"
                potential = potential_energy(other.mass_above, other.com_above[2], base, self.config.gravity)
                detail = f"impact of {rec.label} at {speed:.2f} m/s: {kinetic * 1000:.3g} mJ against {potential * 1000:.3g} mJ"
                if breaks_loose(kinetic, potential):
                    events += [replace(e, source=rec.label) for e in self.wake(other.body, time, detail)]
                else:
                    events.append(StabilityEvent(time, "impact", other.label, f"held, {detail}", rec.label))
        return events

    # wake-up (report 3.3.7) ---------------------------------------------------
    def wake(self, body: int, time: float, reason: str) -> list[StabilityEvent]:
        """Return a frozen brick and everything resting on it to the engine (report 3.3.7).

        Returns the events, one per brick woken; nothing when ``body`` is not frozen.
        """
        return [w.event for w in self._wake(body, time, reason)]

    def _wake(self, body: int, time: float, reason: str) -> list[_Woken]:
        """Wake ``body`` and, recursively, what rests on it; each with its last load node
        and contact polygons (a woken brick may still rest on the stack)."""
        rec = self._bodies[body]
        if rec.state is not BrickState.FROZEN:
            return []
        node = rec.node
        assert node is not None, "a frozen brick has a load node"
        self._engine.set_frozen(body, False, rec.box.mass)
        rec.state, rec.rest_since, rec.frozen_pose, rec.node = BrickState.ACTIVE, None, None, None
        self._active[body] = rec
        del self._stack[body]
        self._unproven.discard(body)
        rec.load_path, self._loads_fresh, self._version = None, False, self._version + 1
        for s in rec.rests_on:
            self._bodies[s].objects_above.discard(body)
        rec.rests_on, rec.main_contact, rec.com_above, rec.mass_above = {}, None, None, 0.0
        rec.contacts = []
        woken = [_Woken(body, node, rec.contacts, StabilityEvent(time, "wake", rec.label, reason))]
        for above in sorted(rec.objects_above, key=lambda b: self._bodies[b].order):
            woken += self._wake(above, time, f"rests on {rec.label}")
        rec.objects_above = set()
        return woken

    # contact areas (report 3.3.3) ---------------------------------------------
    def _supports(self, rec: _Body, contacts: Iterable[ContactPoint], stack_only: bool) -> dict[int, ContactArea]:
        """ContactPolygon areas of the bodies ``rec`` rests on, keyed by body, in registration order."""
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
        exact = face_overlap(rec.box, self._engine.pose(rec.body), other.shape, other_pose, self.config.face_gap)
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
        nodes = self._nodes(bricks)
        for r in bricks:
            if r.state is BrickState.ACTIVE:
                nodes[r.body] = LoadNode(r.box.mass, self._pose(r).position, self._supports(r, contacts.get(r.body, []), False))
        loads = propagate(nodes)
        graph_nodes, edges = [], []
        for rec in self._bodies.values():
            pose = self._pose(rec) if not isinstance(rec.shape, Plane) else Pose(np.array([0.0, 0.0, rec.shape.height]))
            load = loads.get(rec.body)
            com = load.com_above if load else pose.position
            graph_nodes.append(GraphNode(rec.label, rec.state, pose, com, load.mass_above if load else 0.0))
            if load is None:  # the ground: no node, no supports
                continue
            for s, area in nodes[rec.body].supports.items():
                edges.append(
                    GraphEdge(rec.label, self._bodies[s].label, area.area, load.shares.get(s, 0.0), area.exact, area.ring)
                )
        return BrickGraph(tuple(graph_nodes), tuple(edges))


def _ahead(hit: ContactPoint, heading: np.ndarray, pad: float) -> bool:
    """Is the body of a closest point on the impactor's path (or already touching it)?

    The gap between the two closest points runs along ``-hit.normal`` (the normal points
    from the other body into the impactor). The impactor reaches that body if the gap runs
    along its heading: forward, and less than a contact pad sideways. A body below or
    beside the path is near but is not hit.
    """
    if hit.distance <= pad:  # touching already
        return True
    gap = -hit.normal * hit.distance
    along = float(gap @ heading)
    return along > 0 and float(np.linalg.norm(gap - along * heading)) <= 2 * pad


def _main(areas: dict[int, ContactArea]) -> ContactArea:
    """The main contact area (report 3.3.3): the hull of the individual ones, at the lowest height."""
    return ContactArea(
        combined_hull(list(areas.values())), min(a.height for a in areas.values()), np.array([0.0, 0.0, 1.0]), False
    )


def _horizontal(contact: ContactPolygon[int], pad: float, flip: bool = False) -> ContactArea:
    """The horizontal projection of a leaning contact, for the graph and the wake cascade;
    ``flip``: seen from ``contact.other`` (its normal reversed)."""
    points = np.asarray(contact.points)
    normal = -contact.normal if flip else contact.normal
    return ContactArea(padded_hull(points[:, :2], pad), float(points[:, 2].mean()), normal, exact=False)


def _names(bodies: dict[int, _Body], touching: Iterable[int], but: _Body) -> str:
    """The labels of the touched bodies other than ``but``, in order."""
    return ", ".join(bodies[o].label for o in touching if o != but.body)


def _by_body(points: Iterable[ContactPoint]) -> dict[int, list[ContactPoint]]:
    grouped: dict[int, list[ContactPoint]] = defaultdict(list)
    for c in points:
        grouped[c.body].append(c)
    return grouped

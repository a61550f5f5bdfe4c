"""A pull that leaves the frozen bricks it slides between frozen: the proof (stackdsl's own).

A hand pulls a brick ``P`` out along a horizontal direction ``d`` (a Jenga block). The frozen
bricks it touches are of three kinds: those that rest on it (*carried*), those it rests on
(*below*) and those it slides past (*beside*, their contact normal across ``d``). They may stay
frozen, and the engine simulate ``P`` alone, while three things hold:

* **Statics without P.** Rigid-block equilibrium of the frozen stack with ``P`` gone
  (:func:`stability._equilibrium.solve_equilibrium`; where every contact is level, by vertical
  forces alone, :func:`stability._equilibrium.balanced_vertically`, and refused where they do
  not hold it). While it lasts the pull only takes support
  away from the bricks on ``P`` (its overlap with each shrinks), and a support added to a set of
  blocks that stand leaves them standing (the same forces, ``P``'s at zero): proved for the end,
  it holds throughout. Asked once, when the pull starts.
* **The drag on what P carries.** ``P``'s friction drags each carried brick ``A`` along ``d`` by
  ``mu N`` (Coulomb, kinetic equal to static, as the engines model it), ``N`` the load ``A`` puts
  on ``P`` by the stability model's shares (:func:`stability._load.split_load`, report 3.3.6:
  equal shares on three blocks, the lever rule on two). ``A``'s other supports must hold that
  drag, :data:`DRAG_SAFETY` times over, each within its Coulomb cone under its own share of the
  load, force and twist about the vertical both balanced (:func:`held_together`, a small linear
  program: a side block's drag acts off the level's centre line and twists it). Where frozen
  bricks rest on the carried ones, their friction ties them into one: together they must hold
  the drag :data:`TIE_SAFETY` times over, one program for them all (carried bricks that each
  hold it :data:`DRAG_SAFETY` times over hold it so tied). Asked again as the overlap shrinks
  (the shares move).
* **The drag on what P rests on.** Each brick under ``P`` is dragged by at most ``mu`` times the
  whole load on ``P``; its supports must hold that as above, under its load without ``P``'s.
* **A pushed P's own balance.** A hand that pulls holds its brick level; a finger that pushes
  does not. ``P`` pushed past its support's edge tips over it, and its end still under the
  bricks above pries them up: both tuned engines threw the tower above a KAPLA block pushed
  out along its length, where the proof had kept it frozen. So a pushed ``P`` must pass the
  report's tipping test as it moves (3.3.5): its centre of mass above, its own and the loads
  of the bricks on it by their shares, over the hull of its contacts with what it rests on
  now. Asked with the drag, and again when ``P`` has moved as far as would carry that centre
  of mass to the hull's edge with the loads on it where they were (:meth:`PullProof.tipping`).

Any brick whose contacts are not level, a pulled brick that carries bricks frozen with it in a
pile (not resting on it) or that touches a frozen brick in its way: no proof, and the extension
wakes what rests on ``P`` and the bricks beside it, as it did before (the engine decides).

:data:`DRAG_SAFETY` covers the share's indeterminacy: a block on three supports is statically
indeterminate, and an engine whose contacts load the middle one more (compliant
contacts: docs/actions.md) drags more. With equal shares the two side blocks of a Jenga level
hold the level above against twice the middle block's drag. A side block's drag acts 25 mm off
the centre line: each block of the level above holds 0.89 of it alone, and 1.14 of it tied by
the level resting on them. The tied proof takes the report's shares as they are, with a smaller
margin (:data:`TIE_SAFETY`): a model choice, measured against the engines in
docs/results/actions-freeze.md. A level tied by the top level alone, and the level under the top
one, which nothing ties, are simulated: the side pulls by the margins above, and a middle pull because
each top brick lies over the pulled block as well, its share then the engine's
(:meth:`PullProof._on_it_alone`).
Source: stackdsl's own, on Coulomb friction and the report's load shares.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
import shapely
from scipy.sparse import coo_matrix
from shapely import affinity
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from ._engine import ContactPoint
from ._equilibrium import RigidBlock, balanced_vertically, is_level, solve_equilibrium, upward
from ._geometry import ContactArea, Pose, combined_hull, contains, hull_of_union, turn_between
from ._graph import BrickState
from ._leaning import pair_friction
from ._load import Load, LoadNode, Splits, propagate, split_load
from ._lp import OPTIMAL, solve
from ._stack import Stack

DRAG_SAFETY = 1.5
"""How many times over a frozen brick's other supports must hold the drag of a pulled brick:
a middle Jenga block may carry up to 40% of the level above (equal shares: a third) and the
level still be proved held."""

TIE_SAFETY = 1.1
"""How many times over the bricks a pull drags, tied into one by the frozen bricks resting on
them, must hold the drag at the report's load shares, where one of them alone does not hold it
:data:`DRAG_SAFETY` times over: the level above a side block of a Jenga level, whose drag acts
off the level's centre line. At equal shares the tied level holds 1.14 times the drag (one
block alone 0.89; docs/results/actions-freeze.md, "A side pull proved on the tied level").
The ties must carry frozen bricks themselves: tied by the top level alone, the level holds
1.12 to 1.13 times the drag, and both tuned engines of a new user's test fell such a pull at
friction 0.3 (docs/results/actions-freeze.md); such a pull is stepped."""

LEVEL = 0.999
"""Least vertical component of a level contact's normal."""

ACROSS = 0.2
"""Largest -n . d of a touched brick's contact normal ``n`` (from it into the pulled brick) for
it to lie beside the path of a brick pulled along ``d``, or behind it: the pull slides past it
or away from it, never toward it."""

TOWARD = 0.01
"""Largest -n . d of a brick beside the pulled one when the pull starts (at rest, its contact
normals are its faces') for the proof to keep it frozen: a pull written 2.9 deg into the block
beside it (``direction: [0.05, 1, 0]``, within :data:`ACROSS`) was proved, kept that block
frozen, and went 2.2 mm into it over 100 mm, the engine unable to move it."""

LEVEL_SIDE = 0.5
"""A touched brick lies beside the pulled one only when the contact normal's vertical part is
under 1 - this (a side face, not a face it lies on or under)."""

SHRINK = 0.25
"""Fraction of a contact area of the pulled brick (with a brick it carries or rests on), as it
was when proved first, that may go before the drag is proved again with the shares of the
overlap left (:data:`DRAG_SAFETY` covers the shares' change within it): on that brick, and on
every brick the pulled one rests on (its load moves among them)."""

SLACK = 1e-12
"""Square metres (1e-6 mm^2) :meth:`PullProof.unchanged` adds to an overlap's bound, so that an
overlap found in floats on its threshold is always looked at."""

LOOK = 0.0005
"""Metres the pulled brick moves between two looks at its overlaps (2% of a Jenga block's
width: a look costs a tenth of a millisecond, a step at 40 mm/s moves 0.17 mm)."""

TRACK = 1.0
"""Metres ahead along the pull that its track on the bricks under it is drawn (:meth:`PullProof.unmoved_below`):
longer than any brick."""

PRESSED_SLACK = 0.001
"""Metres by which where a brick is pressed may pass the hull of its supports' contact areas
(:meth:`PullProof.unmoved_below`): the outer blocks of a Jenga level, 25.5 mm apart, overhang
the level under them by 0.5 mm, the whole pulled block's width resting on them. A load there
tips a brick only when it is more than the brick's weight times the distance from its
centre of mass to the hull's edge (12 mm for a Jenga block) over this, and all of it lies on
that strip."""

SIDES = 8
"""Sides of the friction pyramid inscribed in each Coulomb cone (it allows only forces the
cone allows)."""

ITERATIONS = 10_000
"""Most simplex iterations a drag program may take before it counts as not held: the proofs of
the shipped and new users' Jenga pulls take up to 193, but a tied program just past its limit
(a side pull of a stickier block, pair friction 1.06 times the level's) ran HiGHS for minutes
without an answer, deaf to SIGTERM (the pull is then stepped, as an unproved one is)."""
# HiGHS solves a drag program without its presolve: for these programs of a few hundred columns
# presolve costs more than it saves (48 programs of the two Jenga scenes: 7.5 to 7.9 ms a call
# through scipy against 9.0 to 9.6 ms, the same answer to each; docs/results/actions-freeze.md)


def footprint(half_extents: np.ndarray, pose: Pose) -> Polygon:
    """The horizontal projection of a box at ``pose``: shapely polygon, metres."""
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    corners = pose.position + (signs * half_extents) @ pose.rotation.T
    hull: Polygon = shapely.convex_hull(shapely.multipoints(corners[:, :2]))
    return hull


@dataclass(frozen=True)
class Dragged:
    """A frozen brick in a drag proof: what holds it, and the drag of a pulled brick on it.

    Attributes:
        supports: support body -> contact area (level, convex). A support that is itself a
            :class:`Dragged` of the same proof takes the friction force back (the two are tied).
        loads: support body -> (equivalent mass in kg, point of application shape (3,) in
            metres): the brick's load on it (:func:`stability._load.split_load`).
        friction: support body -> Coulomb coefficient of the pair.
        drag: shape (2,), newtons, the horizontal force a pulled brick's friction puts on it
            (zero for a brick that only ties the dragged ones).
        at: shape (2,), metres, where the drag acts.

    Source: stackdsl's own.
    """

    supports: Mapping[int, ContactArea]
    loads: Mapping[int, tuple[float, np.ndarray]]
    friction: Mapping[int, float]
    drag: np.ndarray
    at: np.ndarray


def held_together(bricks: Mapping[int, Dragged], gravity: float) -> bool:
    """Can the supports of frozen bricks hold the horizontal drags on them, together?

    Each contact of a brick with a support pushes with the brick's load share on it (its normal
    force's resultant and point fixed, :func:`stability._load.split_load`), spread over the
    corners of the contact area as the program likes, each corner's friction inside the friction
    pyramid of :data:`SIDES` sides inscribed in its Coulomb cone (so the program allows only
    what the cone allows). Every brick must balance, force and twist about the vertical; a
    friction force between two of ``bricks`` acts on both, equal and opposite (the brick on top
    ties the ones it lies on).

    Args:
        bricks: body -> :class:`Dragged`.
        gravity: m/s^2.

    Returns:
        True when such forces exist; False when they do not, a brick has no loaded support, or
        the solver finds neither within :data:`ITERATIONS`.

    Example:
        >>> from shapely.geometry import box
        >>> from stability._geometry import ContactArea
        >>> pad = ContactArea(box(-0.01, -0.01, 0.01, 0.01), 0.0, np.array([0.0, 0.0, 1.0]), True)
        >>> brick = lambda drag: Dragged({0: pad}, {0: (1.0, np.zeros(3))}, {0: 0.5}, np.array([drag, 0.0]), np.zeros(2))
        >>> held_together({1: brick(4.0)}, 9.81), held_together({1: brick(5.0)}, 9.81)
        (True, False)

    Source: Coulomb friction; stackdsl's own linear program (scipy's HiGHS).
    """
    return held_in_line(bricks, gravity) or held_by_program(bricks, gravity)  # in line: a solution of the program


def held_by_program(bricks: Mapping[int, Dragged], gravity: float) -> bool:
    """:func:`held_together` by its linear program alone (HiGHS, through scipy): arguments and
    answer as there. Source: stackdsl's own."""
    scale = max([float(np.hypot(*b.drag)) for b in bricks.values()] + [1e-12])
    origin = np.mean([np.asarray(b.at, dtype=float) for b in bricks.values()], axis=0)
    index = {body: i for i, body in enumerate(bricks)}
    rings, owner, other, mu, normal = [], [], [], [], []  # per loaded contact
    for body, brick in bricks.items():
        held = [(s, a) for s, a in brick.supports.items() if brick.loads.get(s, (0.0, None))[0] > 0.0]
        if not held:
            return False
        for s, area in held:
            rings.append(np.asarray(shapely.get_coordinates(area.polygon.exterior))[:-1] - origin)
            mass, point = brick.loads[s]
            force = mass * gravity / scale
            normal.append([force, force * (float(point[0]) - origin[0]), force * (float(point[1]) - origin[1])])
            owner.append(index[body])
            other.append(index.get(s, -1))
            mu.append(brick.friction[s])
    sizes = np.array([len(r) for r in rings])
    corner = np.concatenate(rings)  # (C, 2): every corner, relative to the origin
    contact = np.repeat(np.arange(len(rings)), sizes)  # (C,): its contact
    count, per = len(corner), 1 + SIDES  # a corner's normal force, then its weight on each pyramid edge
    # friction: (C, SIDES, 3) -> fx, fy and twist of each edge of each corner's pyramid
    edge = np.stack([np.cos(2 * np.pi * np.arange(SIDES) / SIDES), np.sin(2 * np.pi * np.arange(SIDES) / SIDES)], axis=1)
    f = np.asarray(mu)[contact][:, None, None] * edge[None, :, :]
    pull = np.concatenate([f, (corner[:, 0, None] * f[:, :, 1] - corner[:, 1, None] * f[:, :, 0])[:, :, None]], axis=2)
    cols = (np.arange(count)[:, None, None] * per + 1 + np.arange(SIDES)[None, :, None]).repeat(3, axis=2)
    on = 3 * np.asarray(owner)[contact][:, None, None] + np.arange(3)[None, None, :]
    rows, columns, data = [np.broadcast_to(on, pull.shape).ravel()], [cols.ravel()], [pull.ravel()]
    tied = np.asarray(other)[contact] >= 0  # the reaction on the other brick of a contact between two
    if tied.any():
        back = 3 * np.asarray(other)[contact][tied][:, None, None] + np.arange(3)[None, None, :]
        rows.append(np.broadcast_to(back, pull[tied].shape).ravel())
        columns.append(cols[tied].ravel())
        data.append(-pull[tied].ravel())
    first = 3 * len(bricks)  # then each contact's normal force: its resultant and its moments
    rows.append((first + 3 * contact[:, None] + np.arange(3)[None, :]).ravel())
    columns.append(np.repeat(np.arange(count) * per, 3))
    data.append(np.column_stack([np.ones(count), corner]).ravel())
    a_eq = coo_matrix(
        (np.concatenate(data), (np.concatenate(rows), np.concatenate(columns))), shape=(first + 3 * len(rings), count * per)
    )
    rhs = np.zeros(first)
    for body, brick in bricks.items():
        d, r = np.asarray(brick.drag, dtype=float) / scale, np.asarray(brick.at, dtype=float) - origin
        rhs[3 * index[body] : 3 * index[body] + 3] = [-d[0], -d[1], -float(r[0] * d[1] - r[1] * d[0])]
    cone = coo_matrix(  # each corner's pyramid weights sum to at most its normal force
        (
            np.tile(np.r_[-1.0, np.ones(SIDES)], count),
            (np.repeat(np.arange(count), per), np.arange(count * per)),
        ),
        shape=(count, count * per),
    )
    result = solve(
        np.zeros(count * per),
        a_eq,
        np.concatenate([rhs, np.asarray(normal).ravel()]),
        a_ub=cone,
        b_ub=np.zeros(count),
        iteration_limit=ITERATIONS,
        presolve=False,
    )
    return result.status == OPTIMAL


def held_in_line(bricks: Mapping[int, Dragged], gravity: float) -> bool:
    """A solution of :func:`held_together`'s program found directly, when it is a simple one: each
    brick's drag held by friction forces parallel to it (with it or against it) at two of its
    supports (or one) that are not bricks of the program, their resultant on the drag's line of
    action so that no twist is left, each within the circle its friction pyramid contains (radius
    ``mu N cos(pi / SIDES)``); the ties' friction, and every other contact's, at zero. True only
    when those forces exist and every loaded contact's load point lies on its area (its normal
    force can be spread over the area's corners); False leaves the answer to the program.

    Such forces are a solution of the program (a contact's friction spread over its corners as its
    normal force is keeps its resultant and its twist), so the answer is the program's, without
    it. A middle Jenga block's drag on a block of the level above acts midway between that
    block's two other supports: held in line while each carries at least ``safety / (2 cos(pi /
    SIDES))`` of the middle block's share (0.81 at :data:`DRAG_SAFETY`, 0.60 tied). A side block's
    drag twists the block it drags, which the program holds (or not) by the friction spread over
    the contacts. Of the 24 drag programs of ``scenarios/jenga_stands.yaml``, about 5 ms each in
    HiGHS, 14 are held in line: the 12 of its middle pull and 2 of its side pull.

    Args:
        bricks: body -> :class:`Dragged`.
        gravity: m/s^2.

    Returns:
        True when the forces above hold every brick; False when they do not, or a brick has no
        loaded support.

    Example:
        >>> from shapely.geometry import box
        >>> from stability._geometry import ContactArea
        >>> pad = lambda x: ContactArea(box(x - 0.01, -0.01, x + 0.01, 0.01), 0.0, np.array([0.0, 0.0, 1.0]), True)
        >>> loads = {8: (1.0, np.array([-0.02, 0.0, 0.0])), 9: (1.0, np.array([0.02, 0.0, 0.0]))}
        >>> brick = lambda drag: Dragged({8: pad(-0.02), 9: pad(0.02)}, loads, {8: 0.5, 9: 0.5}, np.array([0.0, drag]), np.zeros(2))
        >>> held_in_line({1: brick(9.0)}, 9.81), held_in_line({1: brick(9.1)}, 9.81)  # each takes 4.53 N at most
        (True, False)

    Source: stackdsl's own (Coulomb friction).
    """
    inscribed = math.cos(math.pi / SIDES)
    for brick in bricks.values():
        loaded = [(s, area) for s, area in brick.supports.items() if brick.loads.get(s, (0.0, None))[0] > 0.0]
        if not loaded:
            return False
        points = shapely.points([np.asarray(brick.loads[s][1], dtype=float)[:2] for s, _ in loaded])
        if not bool(np.all(shapely.covers([area.polygon for _, area in loaded], points))):
            return False  # a load point off its area: the program decides
        dx, dy = (float(v) for v in brick.drag)
        size = math.hypot(dx, dy)
        if size == 0.0:
            continue  # a tie: no friction asked of it
        rx, ry = (float(v) for v in brick.at)
        ends = []  # each support that is not a brick of the program: its load point and the friction it can give
        for s, _ in loaded:
            if s not in bricks:
                mass, point = brick.loads[s]
                ends.append((float(point[0]) - rx, float(point[1]) - ry, brick.friction[s] * mass * gravity * inscribed))
        if not any(_in_line(a, b, dx, dy, size) for a, b in itertools.combinations_with_replacement(ends, 2)):
            return False
    return True


def _in_line(a: tuple[float, float, float], b: tuple[float, float, float], dx: float, dy: float, size: float) -> bool:
    """Can two supports ``a`` and ``b`` (x, y of a load point relative to where the drag acts, m;
    the friction it can give, N) hold a drag ``(dx, dy)`` (N, of length ``size``) with forces
    parallel to it, ``-(1 - w)`` and ``-w`` times it, their resultant on its line of action? ``a``
    may be ``b``."""
    off = a[0] * dy - a[1] * dx  # the twist of the drag's share at a, per unit of share: zero on its line
    turn = (b[0] - a[0]) * dy - (b[1] - a[1]) * dx
    if turn == 0.0:  # both on one line parallel to the drag (or one support): on the drag's, or not at all
        return abs(off) <= 1e-12 * size and size <= a[2] + b[2] and (a is not b or size <= a[2])
    w = -off / turn  # outside 0 to 1, one of the two pushes along the drag: a couple against its twist
    return abs(1.0 - w) * size <= a[2] and abs(w) * size <= b[2]


class PullProof:
    """The proof that a brick pulled along ``direction`` leaves the frozen bricks it touches
    frozen (see the module docstring). Made when the pull starts, while the pulled brick is
    still frozen; :attr:`why` is None when it holds, else why not, in words.

    Args:
        stack: the extension's bodies.
        body: the pulled brick (frozen).
        direction: shape (3,), the pull's velocity (only its horizontal direction is used).
        near: the engine's contact points of ``body`` within what it travels in a step.
        held: whether the hand holds the brick level (a pull), or only pushes it (a finger):
            a pushed brick must also balance on what it rests on (the module docstring).

    Attributes:
        kept: the frozen bricks the pulled one touches that stay frozen (empty without a proof).
        why: None when proved; else the reason.
        falls: whether the proof failed on statics without the pulled brick: the frozen stack,
            rigid blocks on their frozen contacts, does not stand once it is gone.

    Source: stackdsl's own.
    """

    def __init__(self, stack: Stack, body: int, direction: np.ndarray, near: Sequence[ContactPoint], held: bool = True) -> None:
        self.stack, self.body, self.held = stack, body, held
        self._tips: tuple[np.ndarray, float] | None = None  # a pushed brick: where it was last balanced, and how far on it may go
        d = np.asarray(direction, dtype=float)[:2]
        length = float(np.hypot(*d))
        self.direction = d / length if length > 0 else d
        self.kept: frozenset[int] = frozenset()
        self.carried: dict[int, ContactArea] = {}  # carried brick -> its contact area with the pulled one when proved
        self.beside: set[int] = set()  # the other supports of the carried bricks
        self.below: dict[int, ContactArea] = {}  # frozen brick it rests on -> the contact area
        self.supports: dict[int, ContactArea] = {}  # everything it rests on (the ground too)
        self._looked: np.ndarray | None = None  # where the pulled brick was when its overlaps were last looked at
        self._seen: tuple[Pose, Polygon, dict[int, float]] | None = None  # the last overlaps found: where, its footprint, them
        self.area: dict[int, float] = {}  # carried brick or support -> m^2 of its contact when proved
        self._splits: Splits = {}  # the load splits of the last check: each check changes a few nodes
        self.falls = False
        self.why = self._start(near)

    def _start(self, near: Sequence[ContactPoint]) -> str | None:
        stack, body = self.stack, self.body
        pulled = stack.bodies[body]
        if pulled.state is not BrickState.FROZEN or not np.any(self.direction):
            return "it is not frozen"
        for a in pulled.objects_above:
            rec = stack.bodies[a]
            if rec.state is not BrickState.FROZEN or body not in rec.rests_on:
                return f"{rec.label} was frozen in one pile with it"
            self.carried[a] = rec.rests_on[body]
            self.beside |= {s for s in rec.rests_on if s != body}
        self.supports = dict(pulled.rests_on)
        self.below = {s: area for s, area in pulled.rests_on.items() if stack.bodies[s].state is BrickState.FROZEN}
        beside = set()
        for c in near:
            other = stack.bodies.get(c.other)
            if other is None or other.state is not BrickState.FROZEN or c.other in self.carried or c.other in self.below:
                continue
            if not self.alongside(c) or float(np.asarray(c.normal, dtype=float)[:2] @ self.direction) < -TOWARD:
                return f"{other.label} lies in its way"
            beside.add(c.other)
        for rec in [pulled, *(stack.bodies[b] for b in (*self.carried, *self.below))]:
            # a brick frozen under frozen ones (pushed and frozen again) keeps its contacts with
            # them seen from below, their normals down into it: level all the same
            tilted = any(not is_level(upward(c)) for c in rec.contacts)
            if tilted or any(float(a.normal[2]) < LEVEL for a in rec.rests_on.values()):
                return f"{rec.label} has a contact that is not level"
        why = self._stands_without()
        self.falls = why is not None
        if why is None:
            why = self.check(None)
        if why is None:
            self.kept = frozenset(self.carried) | frozenset(self.below) | frozenset(beside)
            self.area = {a: area.area for a, area in (self.carried | self.supports).items()}
        return why

    def _stands_without(self) -> str | None:
        """Rigid-block equilibrium of the frozen stack without the pulled brick. Where every
        contact is level (a Jenga tower), vertical forces alone must hold it
        (:func:`stability._equilibrium.balanced_vertically`): refusing where they do not is
        the safe side, and spares the program with friction, which for an 18-level tower that
        does not stand took 0.7 s (a stack that stands is held by vertical forces in 0.01 s)."""
        stack, body = self.stack, self.body
        frozen = [r for r in stack.in_order() if r.body != body]
        blocks = {r.body: RigidBlock(r.box.mass, stack.pose(r).position) for r in frozen}
        contacts = [c for c in stack.frozen_contacts(blocks) if c.body != body and c.other != body]
        if not blocks:
            return None
        vertical = balanced_vertically(blocks, contacts, stack.config.gravity)  # None: a contact is not level
        if vertical is not None:
            return (
                None
                if vertical
                else "the frozen stack does not stand without it on vertical forces alone (its contacts are level)"
            )
        if not solve_equilibrium(blocks, contacts, gravity=stack.config.gravity).stands:
            return "the frozen stack does not stand without it by rigid-block equilibrium"
        return None

    def check(
        self, pulled_at: BaseGeometry | None, position: np.ndarray | None = None, only: Collection[int] | None = None
    ) -> str | None:
        """The two drag proofs with the pulled brick's footprint ``pulled_at`` (shapely, None: as
        it lay when frozen) and its centre ``position`` (shape (3,), m; None: as frozen), of the
        carried and supporting bricks in ``only`` (None: all); None when they hold, else why not."""
        stack, body, g = self.stack, self.body, self.stack.config.gravity
        pulled = stack.bodies[body]
        nodes: dict[int, LoadNode] = stack.nodes(stack.in_order())
        under = {s: cut for s, a in self.supports.items() if (cut := a if pulled_at is None else _overlap(a, pulled_at))}
        if not under:
            return None  # it rests on nothing: it carries nothing either (it has left the tower)
        where = stack.pose(pulled).position if position is None else position
        nodes[body] = LoadNode(pulled.box.mass, np.asarray(where, dtype=float), under)
        for a, area in self.carried.items():
            node = nodes[a]
            supports = dict(node.supports)
            left = area if pulled_at is None else _overlap(area, pulled_at)
            if left is None:
                supports.pop(body, None)
            else:
                supports[body] = left
            nodes[a] = LoadNode(node.mass, node.com, supports)
        loads = propagate(nodes, self._splits)
        if not self.held:
            tips = self._balance(under, loads[body], np.asarray(where, dtype=float))
            if tips is not None:
                return tips
        dragged: dict[int, Dragged] = {}  # carried brick -> it, with the drag of the pulled brick's friction, once
        for a in self.carried:
            rec, load, held_on = stack.bodies[a], loads[a], nodes[a].supports
            if body not in held_on:
                continue
            shares = split_load(load.com_above, load.mass_above, held_on)
            mass, point = shares[body]
            friction = {s: pair_friction(rec.friction, stack.bodies[s].friction) for s in held_on}
            others = {s: v for s, v in held_on.items() if s != body}
            drag = friction[body] * mass * g * self.direction
            dragged[a] = Dragged(others, {s: shares[s] for s in others}, friction, drag, np.asarray(point[:2]))
        ties = {t for a in dragged for t in stack.bodies[a].objects_above} - set(dragged) - {body}
        asked: list[tuple[dict[int, Dragged], str]] = []  # the programs, each with what its failing says
        if ties:  # held one by one DRAG_SAFETY times over, they are held tied TIE_SAFETY (smaller) times over
            if only is None or not dragged.keys().isdisjoint(only):
                tied = self._tied(dragged, ties, nodes, loads)
                if isinstance(tied, str):
                    return tied
                asked.append(
                    (
                        tied,
                        f"the bricks it drags, tied by those resting on them, would not hold the drag of {pulled.label}'s friction",
                    )
                )
        else:
            for a, brick in dragged.items():
                if only is None or a in only:
                    if self._on_it_alone(a, nodes[a].supports[body], loads[a].com_above):
                        return (
                            f"nothing rests on {stack.bodies[a].label} and its centre of mass lies over {pulled.label}: "
                            "an engine may put all of its weight, and all of the drag, there"
                        )
                    why = f"{stack.bodies[a].label}'s other supports would not hold the drag of {pulled.label}'s friction"
                    asked.append(({a: replace(brick, drag=DRAG_SAFETY * brick.drag)}, why))
        on = split_load(loads[body].com_above, loads[body].mass_above, under)
        for b in self.below:
            if b not in under or (only is not None and b not in only):
                continue
            rec, load, held_on, area = stack.bodies[b], loads[b], nodes[b].supports, under[b]
            mu = pair_friction(rec.friction, pulled.friction)
            drag = DRAG_SAFETY * mu * on[b][0] * g * self.direction
            shares = split_load(load.com_above, load.mass_above, held_on)
            friction = {s: pair_friction(rec.friction, stack.bodies[s].friction) for s in held_on}
            why = f"{rec.label}'s supports would not hold the drag of {pulled.label}'s friction"
            asked.append(({b: Dragged(held_on, shares, friction, drag, np.asarray(area.centre_xy))}, why))
        every = {b: brick for bricks, _ in asked for b, brick in bricks.items()}
        if not every or held_together(every, g):  # one program for them all: a solve costs a few milliseconds
            return None
        return next((why for bricks, why in asked if not held_together(bricks, g)), asked[0][1])

    def _balance(self, under: Mapping[int, ContactArea], load: Load, where: np.ndarray) -> str | None:
        """The report's tipping test of a pushed brick at ``where`` (its centre, shape (3,), m)
        on its contacts ``under`` (support -> the overlap left), under ``load`` (its own and the
        loads on it): None when its centre of mass above lies over their hull, by the stability
        model's margin, else why not; when it does, how far along the push it may travel before
        its own centre of mass, the loads on it held where they are, carries that centre of mass
        to the hull's edge (:meth:`tipping`). Source: report 3.3.4-3.3.5."""
        stack, pulled = self.stack, self.stack.bodies[self.body]
        hull = combined_hull(list(under.values()))
        margin = stack.config.com_margin
        com = np.asarray(load.com_above, dtype=float)
        if not contains(hull, com[:2], margin):
            self._tips = None
            return (
                f"{pulled.label} is pushed, not held, past its support's edge: its centre of mass above, its own "
                "and the loads of the bricks on it, lies outside the hull of its contacts with what it rests on, "
                "and it tips (report 3.3.5)"
            )
        edge = float(np.max(shapely.get_coordinates(hull) @ self.direction)) - margin
        share = pulled.box.mass / load.mass_above  # of its travel, what its centre of mass above moves
        self._tips = (where[:2].copy(), (edge - float(com[:2] @ self.direction)) / share)
        return None

    def tipping(self, position: np.ndarray) -> bool:
        """Has a pushed brick, now at ``position`` (shape (3,), m), gone as far along its push
        as its last balance allowed (:meth:`_balance`)? Then it is asked again. Always False for
        a held one."""
        if self._tips is None:
            return False
        start, room = self._tips
        return float((np.asarray(position[:2], dtype=float) - start) @ self.direction) >= room

    def _on_it_alone(self, carried: int, area: ContactArea, com: np.ndarray) -> bool:
        """Could the ``carried`` brick, with nothing frozen resting on it, lie on the pulled brick
        alone: does its centre of mass (``com``, shape (3,), m) lie over their contact ``area``?
        Then its load shares among its supports are statically indeterminate with no load above
        to press it evenly onto them, and an engine's compliant contacts may put all of it on the
        pulled brick, where the drag is then held by nothing: the top level of a KAPLA tower of
        8, over the middle block of level 7 pulled at 20 mm/s, was dragged 20.8 mm and 5.2 mm by
        the two engines' tuned settings (both past its 4 mm collapse threshold), where the proof
        at equal shares held it 1.5 times over (docs/actions.md, "Pull"). Source: stackdsl's own."""
        if self.stack.bodies[carried].objects_above:
            return False
        return bool(shapely.contains_xy(area.polygon, float(com[0]), float(com[1])))

    def _tied(
        self,
        dragged: Mapping[int, Dragged],
        ties: Collection[int],
        nodes: Mapping[int, LoadNode],
        loads: Mapping[int, Load],
    ) -> dict[int, Dragged] | str:
        """The program of the ``ties``, the bricks resting on the dragged ones, tying them into
        one that must hold the drag :data:`TIE_SAFETY` times over (:func:`held_together` of the
        dragged bricks and the ties, each on its supports' load shares); or, for a tie that is not
        frozen on level contacts or carries nothing, why there is none.
        Where each dragged brick alone holds the drag :data:`DRAG_SAFETY` times over, they hold it
        tied too (the same forces scaled down, the ties' friction at zero)."""
        stack = self.stack
        bricks = {a: replace(brick, drag=TIE_SAFETY * brick.drag) for a, brick in dragged.items()}
        for t in sorted(ties):
            rec = stack.bodies[t]
            if rec.state is not BrickState.FROZEN or any(float(a.normal[2]) < LEVEL for a in rec.rests_on.values()):
                return f"{rec.label}, which rests on the bricks it drags, is not frozen on level contacts"
            if not rec.objects_above:
                return f"{rec.label}, which ties the bricks it drags, carries nothing: a top level's tie, the lightest, is left to the engine"
            held_on = nodes[t].supports
            shares = split_load(loads[t].com_above, loads[t].mass_above, held_on)
            friction = {s: pair_friction(rec.friction, stack.bodies[s].friction) for s in held_on}
            bricks[t] = Dragged(held_on, shares, friction, np.zeros(2), np.asarray(shares[next(iter(shares))][1][:2]))
        return bricks

    def unmoved_below(self, pose: Pose) -> frozenset[int]:
        """The frozen bricks under the pulled brick (:attr:`below`), now at ``pose``, that its
        friction cannot drag whatever load it carries: kept frozen when the proof fails because
        what it carries falls without it (:attr:`falls`), when the load on the pulled brick is no
        longer the report's shares but whatever the engine's falling bricks put on it. Not where
        the proof fails on the drag of what it carries, which is then the engine's: bricks kept
        frozen under the pulled one change the share of the load an engine puts on it, and
        pybullet dragged the level above further (5 of 22 pulls just under the top of 6- and
        9-level Jenga towers fell, as on tuned pybullet, where they had stood).

        A brick ``B`` under it is dragged by at most ``mu N`` (``mu`` the pair's friction, ``N``
        the pulled brick's normal force on ``B``, any size) and pressed down by that same ``N``,
        which its supports carry with its own weight and what else rests on it. Where each of
        ``B``'s supports grips it with friction at least ``mu`` and ``N`` acts inside the hull
        of those supports (the strip the pulled brick slides along, on ``B``: it cannot tip
        ``B``), a friction force parallel to the drag at each support, ``mu`` times the share
        of ``N`` it carries, balances the drag, force and twist about the vertical alike (the
        shares' moments are ``N``'s), whatever ``N``; the rest of the load needs no friction.
        The same holds down the frozen stack under ``B``, brick by brick: each must rest, on
        level contacts, only on frozen bricks or the ground, by friction at least ``mu``, and
        carry what the bricks of the chain put on it inside the hull of its own supports. A
        pulled brick slides on the bricks under it, level: a pushed one (:attr:`held` False)
        may tip onto an edge, and keeps nothing so. Empty then, and where a brick fails.

        One engine, tuned, dragged the brick under a pull that felled a KAPLA tower 27.6 mm (its
        friction on that brick under the tower's weight, which the brick's supports carry too);
        the other, tuned, did not move it (docs/actions.md, "A pull that fells the tower").
        Source: stackdsl's own, on Coulomb friction.
        """
        stack = self.stack
        if not self.held or not self.below:
            return frozenset()
        pulled = stack.bodies[self.body]
        at = footprint(pulled.box.half_extents, pose)
        track = hull_of_union([at, affinity.translate(at, *(TRACK * self.direction))])
        kept = []
        for b in self.below:
            under = stack.bodies.get(b)
            if under is None or under.state is not BrickState.FROZEN:
                continue
            mu = pair_friction(under.friction, pulled.friction)
            pressed = footprint(under.box.half_extents, stack.pose(under)).intersection(track)
            if pressed.is_empty or self._carries_unmoved(b, pressed, mu):
                kept.append(b)
        return frozenset(kept)

    def _carries_unmoved(self, body: int, pressed: BaseGeometry, mu: float) -> bool:
        """Does frozen ``body``, pressed within ``pressed`` (shapely), hold any load there against
        friction ``mu`` times it, with the frozen stack under it (:meth:`unmoved_below`)?"""
        stack = self.stack
        chain, todo, regions = {body}, [body], {body: [pressed]}
        while todo:
            rec = stack.bodies[todo.pop()]
            if not rec.rests_on or rec.body in stack.guided:
                return False
            for s, area in rec.rests_on.items():
                support = stack.bodies.get(s)
                if support is None or float(area.normal[2]) < LEVEL or pair_friction(rec.friction, support.friction) < mu:
                    return False
                if support.state is BrickState.GROUND:
                    continue
                if support.state is not BrickState.FROZEN or s in stack.guided:
                    return False
                regions.setdefault(s, []).append(area.polygon)
                if s not in chain:
                    chain.add(s)
                    todo.append(s)
        for b in chain:
            hull = combined_hull(list(stack.bodies[b].rests_on.values())).buffer(PRESSED_SLACK)
            if not all(hull.contains(r) for r in regions[b]):
                return False
        return True

    def moved(self, position: np.ndarray) -> bool:
        """Has the pulled brick, now at ``position`` (shape (3,), m), moved :data:`LOOK` since this
        was last asked yes? Then its overlaps are looked at again."""
        if self._looked is not None and float(np.linalg.norm(position - self._looked)) < LOOK:
            return False
        self._looked = np.array(position, dtype=float)
        return True

    def unlooked(self, position: np.ndarray) -> float:
        """Metres the pulled brick, now at ``position`` (shape (3,), m), may still go before
        :meth:`moved` says yes and its overlaps are next looked at: until then a stepped pull
        asks nothing of them either. 0 before the first look. Source: stackdsl's own."""
        if self._looked is None:
            return 0.0
        return max(0.0, LOOK - float(np.linalg.norm(np.asarray(position, dtype=float) - self._looked)))

    def alongside(self, contact: ContactPoint) -> bool:
        """Does the pulled brick slide past or away from the brick of ``contact`` (one of its
        contact points, the normal from that brick into it), beside it, never toward it
        (:data:`ACROSS`)? A brick it comes to lie on or under is not beside it: its friction
        drags that brick, which no proof has asked."""
        normal = np.asarray(contact.normal, dtype=float)
        return abs(float(normal[2])) < 1.0 - LEVEL_SIDE and float(normal[:2] @ self.direction) >= -ACROSS

    def overlaps(self, pulled_at: Polygon, pose: Pose | None = None) -> dict[int, float]:
        """Carried brick or support -> area (m^2) of its contact with the pulled brick at ``pulled_at``
        (its footprint at ``pose``, which :meth:`unchanged` then bounds from, when given)."""
        both = self.carried | self.supports
        found = {a: 0.0 if (o := _overlap(area, pulled_at)) is None else o.area for a, area in both.items()}
        if pose is not None:
            self._seen = (pose, pulled_at, found)
        return found

    def room(self, areas: Mapping[int, float], pose: Pose) -> float:
        """Metres the pulled brick, now at ``pose``, may still go along its pull's direction, its
        orientation kept, before :meth:`unchanged` could say no: the bound of :meth:`unchanged`
        with the way split in two, from where the overlaps were last found to ``pose`` and on
        along the pull (a footprint moved by u and then v keeps all of its overlap but
        ``|u| w_u + |v| w_v``), solved for the second. 0 when they were never found or may have
        changed already. Source: stackdsl's own."""
        if self._seen is None:
            return 0.0
        _, seen_at, seen = self._seen
        coords = shapely.get_coordinates(seen_at)
        lost = self._lost(pose, coords)
        across = coords @ np.array([-self.direction[1], self.direction[0]])
        width = float(across.max() - across.min())
        least = math.inf
        for a, found in seen.items():
            floor = areas[a] - SHRINK * self.area[a]
            if areas[a] > 0.0:
                floor = max(floor, 0.0)
            least = min(least, found - lost - floor)
        if least <= 0.0:
            return 0.0
        return least / width if width > 0.0 else math.inf

    def _lost(self, pose: Pose, coords: np.ndarray | None = None) -> float:
        """The most overlap (m^2) the footprint can have lost with any area from where
        :meth:`overlaps` last found them to ``pose``: ``|t| w + p a r`` (:meth:`unchanged`).
        Only once they were found. ``coords``: the footprint's coordinates as found then, when
        the caller has them already (shape (k, 2))."""
        assert self._seen is not None
        seen_pose, seen_at, _ = self._seen
        turn = turn_between(seen_pose.orientation, pose.orientation)
        tx, ty = (float(v) for v in np.asarray(pose.position, dtype=float)[:2] - seen_pose.position[:2])
        travel = math.hypot(tx, ty)
        lost = SLACK + turn * self.stack.bodies[self.body].box.half_diagonal * float(seen_at.length)
        if travel > 0.0:
            coords = shapely.get_coordinates(seen_at) if coords is None else coords
            across = coords @ np.array([-ty / travel, tx / travel])
            lost += travel * float(across.max() - across.min())
        return lost

    def unchanged(self, areas: Mapping[int, float], pose: Pose) -> bool:
        """Can no overlap of the pulled brick, now at ``pose``, have shrunk to ``areas`` (m^2, each
        as last proved) less :data:`SHRINK` of its proved area, nor gone, since :meth:`overlaps`
        last found them? Then they need not be found now. Moved by t and turned by an angle a
        about its centre, a footprint keeps all of its overlap with an area but ``|t| w + p a r``
        at most: ``w`` its width across t (the strip a translation leaves behind), ``p`` its
        perimeter and ``r`` the box's half diagonal (no point of it moves more than ``a r`` in
        the turn, and a convex footprint keeps every point deeper inside than that). A Jenga
        block pulled along its length (25 mm wide; it turns a few microradians a look) moves
        about 6 mm before a quarter of a square contact of 625 mm^2 may have gone, where it was
        looked at every :data:`LOOK`; the pulls of ``jenga_stands`` left out 165 of their 264
        looks. False when it may have lost that much.
        Source: stackdsl's own."""
        if self._seen is None:
            return False
        seen, lost = self._seen[2], self._lost(pose)
        return all(seen[a] - lost > areas[a] - SHRINK * self.area[a] and (areas[a] <= 0.0 or seen[a] - lost > 0.0) for a in seen)


def _overlap(area: ContactArea, pulled_at: BaseGeometry) -> ContactArea | None:
    """``area`` cut to ``pulled_at``; None when nothing of it is left."""
    cut = area.polygon.intersection(pulled_at)
    if cut.is_empty or cut.area <= 1e-10 or not isinstance(cut, Polygon):
        return None
    return ContactArea(cut, area.height, area.normal, area.exact, area.depth)

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
  load, force and twist about the vertical both balanced (:func:`drag_held`, a small linear
  program: a side block's drag acts off the level's centre line and twists it). Asked again as
  the overlap shrinks (the shares move).
* **The drag on what P rests on.** Each brick under ``P`` is dragged by at most ``mu`` times the
  whole load on ``P``; its supports must hold that as above, under its load without ``P``'s.

Any brick whose contacts are not level, a pulled brick that carries bricks frozen with it in a
pile (not resting on it) or that touches a frozen brick in its way: no proof, and the extension
wakes what rests on ``P`` and the bricks beside it, as it did before (the engine decides).

:data:`DRAG_SAFETY` covers the share's indeterminacy: a block on three supports is statically
indeterminate, and an engine whose contacts load the middle one more (compliant
contacts: docs/actions.md) drags more. With equal shares the two side blocks of a Jenga level
hold the level above against twice the middle block's drag; a side block's drag acts 25 mm off
the centre line and the level is a near tie (docs/actions.md): the proof fails, and the pull is
simulated. Source: stackdsl's own, on Coulomb friction and the report's load shares.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence

import numpy as np
import shapely
from scipy.optimize import linprog
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from ._engine import ContactPoint
from ._equilibrium import RigidBlock, balanced_vertically, is_level, solve_equilibrium
from ._geometry import ContactArea, Pose
from ._graph import BrickState
from ._leaning import pair_friction
from ._load import LoadNode, propagate, split_load
from ._stack import Stack

DRAG_SAFETY = 1.5
"""How many times over a frozen brick's other supports must hold the drag of a pulled brick:
a middle Jenga block may carry up to 40% of the level above (equal shares: a third) and the
level still be proved held."""

LEVEL = 0.999
"""Least vertical component of a level contact's normal."""

ACROSS = 0.2
"""Largest -n . d of a touched brick's contact normal ``n`` (from it into the pulled brick) for
it to lie beside the path of a brick pulled along ``d``, or behind it: the pull slides past it
or away from it, never toward it."""

LEVEL_SIDE = 0.5
"""A touched brick lies beside the pulled one only when the contact normal's vertical part is
under 1 - this (a side face, not a face it lies on or under)."""

SHRINK = 0.25
"""Fraction of a contact area of the pulled brick (with a brick it carries or rests on), as it
was when proved first, that may go before the drag is proved again with the shares of the
overlap left (:data:`DRAG_SAFETY` covers the shares' change within it): on that brick, and on
every brick the pulled one rests on (its load moves among them)."""

LOOK = 0.0005
"""Metres the pulled brick moves between two looks at its overlaps (2% of a Jenga block's
width: a look costs a tenth of a millisecond, a step at 40 mm/s moves 0.17 mm)."""

SIDES = 8
"""Sides of the friction pyramid inscribed in each Coulomb cone (it allows only forces the
cone allows)."""


def footprint(half_extents: np.ndarray, pose: Pose) -> Polygon:
    """The horizontal projection of a box at ``pose``: shapely polygon, metres."""
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    corners = pose.position + (signs * half_extents) @ pose.rotation.T
    hull: Polygon = shapely.convex_hull(shapely.multipoints(corners[:, :2]))
    return hull


def drag_held(
    supports: Mapping[int, ContactArea],
    loads: Mapping[int, tuple[float, np.ndarray]],
    friction: Mapping[int, float],
    drag: np.ndarray,
    at: np.ndarray,
    gravity: float,
) -> bool:
    """Can the supports of a frozen brick hold a horizontal ``drag`` on it?

    Args:
        supports: support body -> contact area (level, convex).
        loads: support body -> (equivalent mass in kg, point of application shape (3,) in
            metres): the brick's load on it (:func:`stability._load.split_load`).
        friction: support body -> Coulomb coefficient of the pair.
        drag: shape (2,), newtons, the horizontal force on the brick.
        at: shape (2,), metres, where it acts.
        gravity: m/s^2.

    Returns:
        True when forces exist at the vertices of each contact area, each within its inscribed
        friction pyramid under a normal force whose resultant is the support's load at its
        point, that balance ``drag`` and its twist about the vertical.

    Source: Coulomb friction; stackdsl's own linear program (scipy's HiGHS).
    """
    edges = np.array([[math.cos(2 * math.pi * k / SIDES), math.sin(2 * math.pi * k / SIDES)] for k in range(SIDES)])
    scale = max(float(np.hypot(*drag)), 1e-12)
    cols: list[tuple[int, int, np.ndarray]] = []  # (support index, vertex, position)
    rows_eq: list[dict[int, float]] = []
    rhs_eq: list[float] = []
    per = 1 + SIDES
    held = [(s, a) for s, a in supports.items() if loads.get(s, (0.0, at))[0] > 0.0]
    if not held:
        return False
    for i, (_, area) in enumerate(held):
        ring = np.asarray(shapely.get_coordinates(area.polygon.exterior))[:-1]
        for v in ring:
            cols.append((i, len(cols), v - at))
    n = len(cols) * per
    force_x, force_y, twist = {}, {}, {}
    ub_rows = []
    for j, (i, _, r) in enumerate(cols):
        s = held[i][0]
        mu = friction[s]
        for k in range(SIDES):
            c = j * per + 1 + k
            ex, ey = mu * edges[k]
            force_x[c], force_y[c] = ex, ey
            twist[c] = float(r[0] * ey - r[1] * ex)
        ub_rows.append({j * per + kk: 1.0 for kk in range(1, per)} | {j * per: -1.0})
    for i, (s, _) in enumerate(held):
        mass, point = loads[s]
        normal = mass * gravity / scale
        members = [j for j, (ii, _, _) in enumerate(cols) if ii == i]
        rel = np.asarray(point[:2], dtype=float) - at
        rows_eq.append({j * per: 1.0 for j in members})
        rhs_eq.append(normal)
        rows_eq.append({j * per: float(cols[j][2][0]) for j in members})
        rhs_eq.append(normal * float(rel[0]))
        rows_eq.append({j * per: float(cols[j][2][1]) for j in members})
        rhs_eq.append(normal * float(rel[1]))
    rows_eq += [force_x, force_y, twist]
    rhs_eq += [-float(drag[0]) / scale, -float(drag[1]) / scale, 0.0]
    a_eq = np.zeros((len(rows_eq), n))
    for r_i, row in enumerate(rows_eq):
        for c, value in row.items():
            a_eq[r_i, c] = value
    a_ub = np.zeros((len(ub_rows), n))
    for r_i, row in enumerate(ub_rows):
        for c, value in row.items():
            a_ub[r_i, c] = value
    result = linprog(
        np.zeros(n), A_ub=a_ub, b_ub=np.zeros(len(ub_rows)), A_eq=a_eq, b_eq=np.array(rhs_eq), bounds=(0, None), method="highs"
    )
    return bool(result.status == 0)


class PullProof:
    """The proof that a brick pulled along ``direction`` leaves the frozen bricks it touches
    frozen (see the module docstring). Made when the pull starts, while the pulled brick is
    still frozen; :attr:`why` is None when it holds, else why not, in words.

    Args:
        stack: the extension's bodies.
        body: the pulled brick (frozen).
        direction: shape (3,), the pull's velocity (only its horizontal direction is used).
        near: the engine's contact points of ``body`` within what it travels in a step.

    Attributes:
        kept: the frozen bricks the pulled one touches that stay frozen (empty without a proof).
        why: None when proved; else the reason.

    Source: stackdsl's own.
    """

    def __init__(self, stack: Stack, body: int, direction: np.ndarray, near: Sequence[ContactPoint]) -> None:
        self.stack, self.body = stack, body
        d = np.asarray(direction, dtype=float)[:2]
        length = float(np.hypot(*d))
        self.direction = d / length if length > 0 else d
        self.kept: frozenset[int] = frozenset()
        self.carried: dict[int, ContactArea] = {}  # carried brick -> its contact area with the pulled one when proved
        self.beside: set[int] = set()  # the other supports of the carried bricks
        self.below: dict[int, ContactArea] = {}  # frozen brick it rests on -> the contact area
        self.supports: dict[int, ContactArea] = {}  # everything it rests on (the ground too)
        self._looked: np.ndarray | None = None  # where the pulled brick was when its overlaps were last looked at
        self.area: dict[int, float] = {}  # carried brick or support -> m^2 of its contact when proved
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
            if not self.alongside(c):
                return f"{other.label} lies in its way"
            beside.add(c.other)
        for rec in [pulled, *(stack.bodies[b] for b in (*self.carried, *self.below))]:
            if any(float(a.normal[2]) < LEVEL for a in rec.rests_on.values()) or any(not is_level(c) for c in rec.contacts):
                return f"{rec.label} has a contact that is not level"
        why = self._stands_without()
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
        loads = propagate(nodes)
        for a in self.carried:
            rec, load, held_on = stack.bodies[a], loads[a], nodes[a].supports
            if body not in held_on or (only is not None and a not in only):
                continue
            shares = split_load(load.com_above, load.mass_above, held_on)
            mass, point = shares[body]
            mu = pair_friction(rec.friction, pulled.friction)
            drag = DRAG_SAFETY * mu * mass * g * self.direction
            friction = {s: pair_friction(rec.friction, stack.bodies[s].friction) for s in held_on}
            others = {s: v for s, v in held_on.items() if s != body}
            if not drag_held(others, {s: shares[s] for s in others}, friction, drag, np.asarray(point[:2]), g):
                return f"{rec.label}'s other supports would not hold the drag of its friction"
        on = split_load(loads[body].com_above, loads[body].mass_above, under)
        for b in self.below:
            if b not in under or (only is not None and b not in only):
                continue
            rec, load, held_on, area = stack.bodies[b], loads[b], nodes[b].supports, under[b]
            mu = pair_friction(rec.friction, pulled.friction)
            drag = DRAG_SAFETY * mu * on[b][0] * g * self.direction
            shares = split_load(load.com_above, load.mass_above, held_on)
            friction = {s: pair_friction(rec.friction, stack.bodies[s].friction) for s in held_on}
            if not drag_held(held_on, shares, friction, drag, np.asarray(area.centre_xy), g):
                return f"{rec.label}'s supports would not hold the drag of its friction"
        return None

    def moved(self, position: np.ndarray) -> bool:
        """Has the pulled brick, now at ``position`` (shape (3,), m), moved :data:`LOOK` since this
        was last asked yes? Then its overlaps are looked at again."""
        if self._looked is not None and float(np.linalg.norm(position - self._looked)) < LOOK:
            return False
        self._looked = np.array(position, dtype=float)
        return True

    def alongside(self, contact: ContactPoint) -> bool:
        """Does the pulled brick slide past or away from the brick of ``contact`` (one of its
        contact points, the normal from that brick into it), beside it, never toward it
        (:data:`ACROSS`)? A brick it comes to lie on or under is not beside it: its friction
        drags that brick, which no proof has asked."""
        normal = np.asarray(contact.normal, dtype=float)
        return abs(float(normal[2])) < 1.0 - LEVEL_SIDE and float(normal[:2] @ self.direction) >= -ACROSS

    def overlaps(self, pulled_at: BaseGeometry) -> dict[int, float]:
        """Carried brick or support -> area (m^2) of its contact with the pulled brick at ``pulled_at``."""
        both = self.carried | self.supports
        return {a: 0.0 if (o := _overlap(area, pulled_at)) is None else o.area for a, area in both.items()}


def _overlap(area: ContactArea, pulled_at: BaseGeometry) -> ContactArea | None:
    """``area`` cut to ``pulled_at``; None when nothing of it is left."""
    cut = area.polygon.intersection(pulled_at)
    if cut.is_empty or cut.area <= 1e-10 or not isinstance(cut, Polygon):
        return None
    return ContactArea(cut, area.height, area.normal, area.exact, area.depth)

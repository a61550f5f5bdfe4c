"""Rigid-block equilibrium of boxes placed one at a time, asked again only where a box loads.

:class:`Placing` holds boxes at their poses (the ground plane, fixed boxes, and free boxes
placed in order). After each placement it says whether forces exist that balance every free
box (:meth:`Placing.place`), in two ways:

1. **Load paths**, kept from one placement to the next. Each free box's load (its weight at its
   centre of mass and the vertical forces the boxes on it put on it) is split among the contact
   polygons it rests on (those whose normal into it is vertical: the ground, the top faces of
   level boxes), each share a vertical force at a point strictly inside its polygon, by
   :data:`INSIDE` (:func:`_split`); each share is a load on the box under it. These forces
   balance every box (forces and moments: a vertical force at a point has no moment about the
   vertical), so they are a solution of the equilibrium program: a proof that the boxes stand.
   A new box changes the loads of the boxes under it only: those are split again, from the top
   down, and nothing else is looked at. Contacts with other normals (side faces, a leaning box)
   carry no force in this proof, which is still one.
2. **The equilibrium program** (:func:`stability.solve_equilibrium`) over every free box and
   contact, only when a load path fails (a load's point outside, or on the edge of, what its
   polygons can carry; a box that rests on no level face): it decides, and names the collapse
   mechanism when no forces balance the boxes.

The load paths also bound the equilibrium margin from below (:attr:`Placing.slack`): moving
every centre of mass by the same horizontal shift moves every load's point and every share's
point by it, with the same shares, so the proof holds while every share's point stays inside
its polygon.

Source: stackdsl's own, on rigid-block equilibrium (Livesley 1978; Whiting et al. 2009); the
load paths as those of :mod:`stability._load_path`, kept incrementally.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from scipy.optimize import nnls
from shapely.geometry import Polygon

from ._contacts import PlacedBox, contacts_of
from ._equilibrium import GRAVITY, ContactPolygon, Equilibrium, RigidBlock, solve_equilibrium
from ._geometry import ContactArea, Pose
from ._graph import BrickGraph, BrickState, GraphEdge, GraphNode
from ._load import LoadNode, propagate

#: Metres inside its contact polygon's edges that a share's point must lie for the load paths
#: (nearer, the equilibrium program decides).
INSIDE = 1e-6
#: Metres within which two faces, or a corner and a face, touch: a brick placed up to 1 mm above
#: its pose (a drop gap) still lies on what is under it.
GAP = 0.0011
#: The most free boxes :meth:`Placing.proved_steps` takes (it keeps 32 n^2 bytes).
BATCH = 1000
#: A contact normal whose vertical component is at least this is vertical (0.008 degrees).
VERTICAL = 1.0 - 1e-8


@dataclass(frozen=True)
class Rest:
    """Box ``upper`` rests on ``lower`` through a level contact polygon.

    Attributes:
        upper, lower: keys; polygon: the contact (its normal into ``upper``, vertical).
        centre: (x, y) of its vertices' mean, metres; hull: its convex hull's vertices (x, y),
        counter-clockwise; units: the unit direction of each hull edge (empty when the points
        enclose no area: nothing can be carried strictly inside them).
    """

    upper: int
    lower: int
    polygon: ContactPolygon[int]
    centre: tuple[float, float]
    hull: tuple[tuple[float, float], ...]
    units: tuple[tuple[float, float], ...]

    @classmethod
    def of(cls, upper: int, lower: int, polygon: ContactPolygon[int]) -> Rest:
        """The rest through ``polygon`` (vertices of shape (k, 3), metres)."""
        points = [p[:2] for p in np.asarray(polygon.points, dtype=float).tolist()]
        centre = (sum(p[0] for p in points) / len(points), sum(p[1] for p in points) / len(points))
        hull = [tuple(points[i]) for i in _hull(points)]
        units: list[tuple[float, float]] = []
        if len(hull) >= 3:
            for (x0, y0), (x1, y1) in zip(hull, hull[1:] + hull[:1]):
                length = math.hypot(x1 - x0, y1 - y0)
                units.append(((x1 - x0) / length, (y1 - y0) / length))
        return cls(upper, lower, polygon, centre, tuple(hull), tuple(units))

    def inside(self, x: float, y: float) -> float:
        """Metres from (x, y) to the nearest edge of the hull, positive inside (-inf when the
        hull encloses no area)."""
        if not self.units:
            return -math.inf
        return min(ux * (y - hy) - uy * (x - hx) for (hx, hy), (ux, uy) in zip(self.hull, self.units))


@dataclass(frozen=True)
class Placed:
    """What :meth:`Placing.place` found.

    Attributes:
        stands: forces exist that balance every free box.
        method: ``"load paths"`` (the kept paths prove it) or ``"program"`` (the equilibrium
            program decided).
        answer: the program's answer (None with the load paths): its tension and mechanism.
    """

    stands: bool
    method: str
    answer: Equilibrium[int] | None = None


class Placing:
    """Boxes placed one at a time on the plane z = 0 and fixed boxes, with rigid-block
    equilibrium asked after each (module docstring).

    Args:
        ground: the key of the ground plane; ground_friction: its friction coefficient.
        gap: metres within which two faces, or a corner and a face, touch (:data:`GAP`).
        gravity: m/s^2, along -z.

    Attributes:
        boxes: every box by key (fixed and free), in the order added; free: the free ones' keys;
        polygons: every contact polygon (normal into its ``body``), in the order found;
        rests: every level rest, per upper box.
    """

    def __init__(self, ground: int, ground_friction: float, gap: float = GAP, gravity: float = GRAVITY) -> None:
        self.ground, self.ground_friction, self.gap, self.gravity = ground, ground_friction, gap, gravity
        self.boxes: dict[int, PlacedBox] = {}
        self.free: list[int] = []
        self.polygons: list[ContactPolygon[int]] = []
        self.rests: dict[int, dict[int, Rest]] = {}
        self._keys: list[int] = []
        self._bounds = np.zeros((16, 2, 3))  # per box (the first len(boxes) rows): its corners' low and high, widened by gap, m
        self._load: dict[int, list[float]] = {}  # free box -> (F, F x, F y, F z): N and N m about the origin
        self._given: dict[int, dict[int, tuple[float, float, float, float]]] = {}  # box -> what it puts on each support
        self._slack: dict[int, float] = {}  # box -> metres its shares' points lie inside their polygons
        self._failed: set[int] = set()  # free boxes whose load paths fail
        # proved_steps' proof of every step: per free box its load (N) and point (x, y, z, m), per rest its force (N)
        self._proof: tuple[dict[int, tuple[float, float, float, float]], dict[tuple[int, int], float]] | None = None

    def add_fixed(self, box: PlacedBox) -> None:
        """Add a fixed box (a support: nothing balances it). Raises ValueError for a key in use."""
        self._add(box)

    def place(self, boxes: Sequence[PlacedBox]) -> Placed:
        """Place the free ``boxes`` (put there together: one step) at their poses and say
        whether every free box stands (module docstring). Raises ValueError for a key in use."""
        dirty: set[int] = set()
        for box in boxes:
            dirty |= self._put(box)
        self._carry(dirty & set(self._load))
        return self.solve()

    def put(self, boxes: Sequence[PlacedBox]) -> None:
        """Place the free ``boxes`` at their poses and carry their loads, without asking whether
        they stand (:meth:`solve` asks). Raises ValueError as :meth:`place`."""
        dirty: set[int] = set()
        for box in boxes:
            dirty |= self._put(box)
        self._carry(dirty & set(self._load))

    def proved_steps(self, steps: Sequence[Sequence[PlacedBox]]) -> tuple[int, float]:
        """Place every step's free boxes (their contacts found, their loads not carried) and say
        how many steps, from the first, load paths with fixed shares prove: after each of them
        every free box placed so far stands. Also the slack of the proof after the last of them
        (metres, as :attr:`slack`; 0 when none is proved).

        The shares of each box are fixed: those of its load path in the whole structure (that of
        its own weight where that fails), each share acting at its rest's centre moved by what the
        shares' combination misses of the load's point (:func:`_split`). The loads are then linear
        in the weights placed: each box's load after every step is one running sum, found for all
        steps at once (numpy, n^2 numbers for n boxes), and so is how far inside its polygon each
        share acts. A box that rests on one placed after it, or more than :data:`BATCH` boxes,
        leave it to :meth:`place` (0 steps proved), as does one on a rest without area from its
        step on. Raises ValueError as :meth:`place`."""
        for step in steps:
            for box in step:
                self._put(box)
        n = len(self.free)
        if n == 0 or n > BATCH:
            return 0, 0.0
        index = {k: i for i, k in enumerate(self.free)}
        ends = np.cumsum([len(step) for step in steps]) - 1  # the index of each step's last box
        step_of = np.repeat(np.arange(len(steps)), [len(step) for step in steps])
        first_failed = len(steps)
        influence = np.zeros((n, 3, n))  # box, its load (F, F x, F y), per box placed: what that one's weight gives it
        carried: list[tuple[int, int, np.ndarray]] = []  # box, what it rests on, that share's force as a functional of its load
        edges: list[np.ndarray] = []  # per share, its polygon's edges' functionals (edges, 3) of its box's load
        for key in reversed(self.free):
            i = index[key]
            box = self.boxes[key]
            weight = box.box.mass * self.gravity
            influence[i, :, i] = (weight, weight * float(box.pose.position[0]), weight * float(box.pose.position[1]))
            rests = list(self.rests.get(key, {}).values())
            shares = _shares(influence[i].sum(axis=1), rests) if rests else None
            if shares is None or any((r.lower in index and index[r.lower] > i) or not r.units for r in rests):
                first_failed = min(first_failed, int(step_of[i]))
                continue
            for r, share in zip(rests, shares):
                if r.lower in index:
                    influence[index[r.lower]] += share @ influence[i]
                carried.append((i, r.lower, share[0]))
                edges.append(_edges(r, share))
        loads = np.cumsum(influence, axis=2)[:, :, ends]  # box, (F, F x, F y), after each step
        boxes = np.array([i for i, _, _ in carried], dtype=int)
        on = ends[None, :] >= boxes[:, None]  # share, step: its box is there after that step
        slack = np.full(len(steps), np.inf)
        if len(boxes):
            forces = np.einsum("rj,rjs->rs", np.array([f for _, _, f in carried]), loads[boxes])  # share, step
            inside = np.empty(forces.shape)  # share, step: its force times how far inside its polygon it acts
            four = [k for k, e in enumerate(edges) if len(e) == 4]  # a rectangle's (most): all at once
            if four:
                stacked = np.einsum("rej,rjs->res", np.stack([edges[k] for k in four]), loads[boxes[four]])
                inside[four] = stacked.min(axis=1)
            for k, e in enumerate(edges):
                if len(e) != 4:
                    inside[k] = (e @ loads[boxes[k]]).min(axis=0)
            with np.errstate(divide="ignore", invalid="ignore"):
                distance = np.where(forces > 0.0, inside / forces, -np.inf)
            slack = np.where(on, distance, np.inf).min(axis=0)
        failed = np.flatnonzero(~(slack > INSIDE))
        if len(failed):
            first_failed = min(first_failed, int(failed[0]))
        self._proof = None
        if first_failed == len(steps):  # the brick graph of the proof (:meth:`graph`)
            final = loads[:, :, -1]
            heights = np.array([float(self.boxes[k].pose.position[2]) for k in self.free])
            moment_z = influence[:, 0, :] @ heights  # the weights that reach a box, each at its own height
            points = {
                k: (float(final[i, 0]), *(float(v) / final[i, 0] for v in (final[i, 1], final[i, 2], moment_z[i])))
                for k, i in index.items()
            }
            shared = {(self.free[i], lower): float(forces[row, -1]) for row, (i, lower, _) in enumerate(carried)}
            self._proof = (points, shared)
        return first_failed, float(slack[first_failed - 1]) if first_failed else 0.0

    def solve(self) -> Placed:
        """Whether every free box stands now: by the load paths, else by the program."""
        if not self._failed:
            return Placed(True, "load paths")
        blocks = {k: RigidBlock(self.boxes[k].box.mass, self.boxes[k].pose.position) for k in self.free}
        answer = solve_equilibrium(blocks, self.polygons, gravity=self.gravity)
        return Placed(answer.stands, "program", answer)

    def _put(self, box: PlacedBox) -> set[int]:
        """Add free box ``box`` with its contacts; the boxes whose rests changed (to split anew)."""
        near = [self.boxes[k] for k in self._meeting(box)]
        self._add(box)
        found = contacts_of(box, near, self.ground, self.ground_friction, self.gap)
        for other in near:
            if other.key in self._load:  # what a free box touches, from its side too (a fixed box is not balanced)
                found += contacts_of(other, [box], None, self.ground_friction, self.gap)
        self.polygons += found
        self.free.append(box.key)
        weight = box.box.mass * self.gravity
        x, y, z = (float(v) for v in box.pose.position)
        self._load[box.key] = [weight, weight * x, weight * y, weight * z]
        self._given[box.key] = {}
        dirty = {box.key}
        for c in found:
            rest = _rest(c)
            if rest is not None and rest.lower not in self.rests.get(rest.upper, {}):
                self.rests.setdefault(rest.upper, {})[rest.lower] = rest
                dirty.add(rest.upper)
        return dirty

    @property
    def proved(self) -> bool:
        """Whether the load paths prove that every free box stands now."""
        return not self._failed

    @property
    def slack(self) -> float:
        """Metres: the least distance of a share's point inside its polygon, over every free
        box, while the load paths prove the stand (module docstring: a lower bound of the
        equilibrium margin); 0 when they do not."""
        if self._failed or not self._slack:
            return 0.0
        return max(0.0, min(self._slack.values()))

    def load(self, key: int) -> tuple[float, tuple[float, float, float]]:
        """The load on free box ``key`` in its load path: newtons, and where it acts (x, y, z of
        the centre of mass above, metres). Raises KeyError for a box that is not free."""
        force, mx, my, mz = self._load[key]
        return force, (mx / force, my / force, mz / force)

    def graph(self, labels: dict[int, str], moving: frozenset[int] = frozenset()) -> BrickGraph:
        """The brick graph of the boxes as they are: the ground (labelled ``labels[ground]``) and
        the fixed boxes as ground, the free ones frozen (held by statics) but those of ``moving``
        (a collapse mechanism) active; the edges are the level rests, their load shares
        :func:`stability.propagate`'s (report 3.3.5-3.3.6). ``labels``: key -> label, for every
        box and the ground. When :meth:`proved_steps` proved every step and nothing was placed
        since, the loads and shares are its proof's instead (the weights that reach a box, at
        their centres of mass: the report's centre of mass above, on these load paths). Raises
        KeyError for a box without a label."""
        if self._proof is not None and len(self._proof[0]) == len(self.free):
            return self._graph_of_proof(labels, moving, *self._proof)
        areas = {upper: {lower: _area(r) for lower, r in found.items()} for upper, found in self.rests.items()}
        nodes = {k: LoadNode(self.boxes[k].box.mass, self.boxes[k].pose.position, areas.get(k, {})) for k in self.free}
        loads = propagate(nodes)
        ground_pose = Pose(np.zeros(3))
        graph_nodes = [GraphNode(labels[self.ground], BrickState.GROUND, ground_pose, ground_pose.position, 0.0)]
        edges = []
        for key in self._keys:
            box = self.boxes[key]
            load = loads.get(key)
            if load is None:
                graph_nodes.append(GraphNode(labels[key], BrickState.GROUND, box.pose, box.pose.position, 0.0))
                continue
            state = BrickState.ACTIVE if key in moving else BrickState.FROZEN
            graph_nodes.append(GraphNode(labels[key], state, box.pose, load.com_above, load.mass_above))
            for lower, area in nodes[key].supports.items():
                outline = tuple((float(x), float(y)) for x, y in list(area.polygon.exterior.coords)[:-1])
                edges.append(GraphEdge(labels[key], labels[lower], area.area, load.shares.get(lower, 0.0), area.exact, outline))
        return BrickGraph(tuple(graph_nodes), tuple(edges))

    def _graph_of_proof(
        self,
        labels: dict[int, str],
        moving: frozenset[int],
        points: dict[int, tuple[float, float, float, float]],
        shared: dict[tuple[int, int], float],
    ) -> BrickGraph:
        """:meth:`graph` from :meth:`proved_steps`' proof: per free box its load (N) and where
        it acts (x, y, z, m), per rest the force it carries (N)."""
        ground_pose = Pose(np.zeros(3))
        nodes = [GraphNode(labels[self.ground], BrickState.GROUND, ground_pose, ground_pose.position, 0.0)]
        edges = []
        for key in self._keys:
            box = self.boxes[key]
            if key not in points:
                nodes.append(GraphNode(labels[key], BrickState.GROUND, box.pose, box.pose.position, 0.0))
                continue
            force, x, y, z = points[key]
            state = BrickState.ACTIVE if key in moving else BrickState.FROZEN
            nodes.append(GraphNode(labels[key], state, box.pose, np.array([x, y, z]), force / self.gravity))
            for lower, rest in self.rests.get(key, {}).items():
                share = shared.get((key, lower), 0.0) / force
                edges.append(GraphEdge(labels[key], labels[lower], _shoelace(rest.hull), share, True, rest.hull))
        return BrickGraph(tuple(nodes), tuple(edges))

    # the load paths -------------------------------------------------------------
    def _carry(self, dirty: set[int]) -> None:
        """Split again the load of every box of ``dirty`` and of every box under it whose load
        changes, from the top down (highest centre first, then the latest placed)."""
        order = {k: i for i, k in enumerate(self._keys)}
        heap = [(-float(self.boxes[k].pose.position[2]), -order[k], k) for k in dirty]
        heapq.heapify(heap)
        queued = set(dirty)
        while heap:
            _, _, key = heapq.heappop(heap)
            queued.discard(key)
            load = self._load[key]
            shares = _split(load, list(self.rests.get(key, {}).values()))
            if shares is None:
                self._failed.add(key)
                self._slack.pop(key, None)
                new: dict[int, tuple[float, float, float, float]] = {}
            else:
                self._failed.discard(key)
                new = {lower: given for lower, given, _ in shares}
                self._slack[key] = min(s for _, _, s in shares)
            old = self._given[key]
            self._given[key] = new
            for lower in old.keys() | new.keys():
                target = self._load.get(lower)
                if target is None:
                    continue  # the ground or a fixed box
                before, after = old.get(lower, (0.0, 0.0, 0.0, 0.0)), new.get(lower, (0.0, 0.0, 0.0, 0.0))
                if before == after:
                    continue
                for i in range(4):
                    target[i] += after[i] - before[i]
                if lower not in queued:
                    queued.add(lower)
                    heapq.heappush(heap, (-float(self.boxes[lower].pose.position[2]), -order[lower], lower))

    # neighbours -------------------------------------------------------------------
    def _add(self, box: PlacedBox) -> None:
        if box.key in self.boxes or box.key == self.ground:
            raise ValueError(f"box {box.key} is there already")
        self.boxes[box.key] = box
        self._keys.append(box.key)
        corners = box.box.corners(box.pose)
        n = len(self._keys) - 1
        if n == len(self._bounds):
            self._bounds = np.concatenate([self._bounds, np.zeros_like(self._bounds)])
        self._bounds[n, 0], self._bounds[n, 1] = corners.min(axis=0) - self.gap, corners.max(axis=0) + self.gap

    def _meeting(self, box: PlacedBox) -> list[int]:
        """The keys of the boxes whose bounds (widened by the gap) meet ``box``'s, in the order added."""
        if not self._keys:
            return []
        corners = box.box.corners(box.pose)
        low, high = corners.min(axis=0) - self.gap, corners.max(axis=0) + self.gap
        stacked = self._bounds[: len(self._keys)]
        meets = np.all(stacked[:, 0] <= high, axis=1) & np.all(low <= stacked[:, 1], axis=1)
        return [self._keys[i] for i in np.flatnonzero(meets).tolist()]


def load_paths_hold(boxes: Sequence[PlacedBox], polygons: Sequence[ContactPolygon[int]], gravity: float = GRAVITY) -> bool:
    """Whether load paths (the module docstring's, in one pass from the top down) prove that
    every free box of ``boxes`` stands on ``polygons`` (normals into their ``body``; any other key
    is a support): a proof when True, and no answer when False (the program then decides).
    Source: stackdsl's own."""
    loads: dict[int, list[float]] = {}
    for box in boxes:
        weight = box.box.mass * gravity
        x, y, z = (float(v) for v in box.pose.position)
        loads[box.key] = [weight, weight * x, weight * y, weight * z]
    rests: dict[int, dict[int, Rest]] = {}
    for polygon in polygons:
        rest = _rest(polygon)
        if rest is not None and rest.upper in loads:
            rests.setdefault(rest.upper, {}).setdefault(rest.lower, rest)
    for box in sorted(boxes, key=lambda b: -float(b.pose.position[2])):  # a box rests on lower ones only
        shares = _split(loads[box.key], list(rests.get(box.key, {}).values()))
        if shares is None:
            return False
        for lower, given, _ in shares:
            if lower in loads:
                carried = loads[lower]
                for i in range(4):
                    carried[i] += given[i]
    return True


def _rest(polygon: ContactPolygon[int]) -> Rest | None:
    """The level rest ``polygon`` makes (its ``body`` on its ``other`` when its normal points up
    into its body, the other way round when down), or None when its normal is not vertical."""
    nz = float(polygon.normal[2])
    if nz >= VERTICAL:
        return Rest.of(polygon.body, polygon.other, polygon)
    if nz <= -VERTICAL:
        flipped = ContactPolygon(polygon.other, polygon.body, polygon.points, -polygon.normal, polygon.friction)
        return Rest.of(polygon.other, polygon.body, flipped)
    return None


def _shoelace(hull: Sequence[tuple[float, float]]) -> float:
    """The area (m^2) of a polygon, its vertices (x, y) in order (the shoelace formula)."""
    return abs(sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(hull, [*hull[1:], *hull[:1]]))) / 2.0


def _area(rest: Rest) -> ContactArea:
    """The contact area of a rest, for the brick graph (its hull, or a sliver round its points
    where they enclose no area)."""
    points = np.asarray(rest.polygon.points, dtype=float)
    shape = shapely.MultiPoint(points[:, :2]).convex_hull
    polygon = shape if isinstance(shape, Polygon) else shape.buffer(1e-6)
    return ContactArea(polygon, float(points[:, 2].mean()), np.asarray(rest.polygon.normal, dtype=float), exact=True)


def _shares(load: np.ndarray, rests: Sequence[Rest]) -> list[np.ndarray] | None:
    """A linear split of a box's load (F, F x, F y: N, N m) among its ``rests``: per rest, the
    matrix (3, 3) of what it carries (f, f q_x, f q_y: its force and where it acts) from the
    load, None when the rule below does not fit ``load`` (the whole structure's).

    On one rest, all of it. On two, the force share of each is that of the load's point
    projected on the line through their centres (linear in the load, not clipped); on more,
    fixed shares, those :func:`_split` finds for ``load``. Each share acts at its rest's centre;
    what the shares' moments miss of the load's is shared among them in the proportions of the
    force shares for ``load``. Forces and moments sum to the load's, for every load: the same
    matrices prove every step whose shares act inside their polygons (:meth:`Placing.proved_steps`).
    Source: stackdsl's own."""
    found = _split(load.tolist() + [0.0], rests)
    if found is None:
        return None
    by_lower = {lower: given[0] / float(load[0]) for lower, given, _ in found}
    fractions = [by_lower.get(r.lower, 0.0) for r in rests]
    unit = np.eye(3)
    if len(rests) == 1:
        return [unit]
    if len(rests) == 2:
        (x0, y0), (x1, y1) = rests[0].centre, rests[1].centre
        dx, dy = x1 - x0, y1 - y0
        length = dx * dx + dy * dy
        if length < 1e-18:
            return None
        second = np.array([-(dx * x0 + dy * y0), dx, dy]) / length
        forces = [unit[0] - second, second]
    else:
        forces = [w * unit[0] for w in fractions]
    missed_x = unit[1] - sum(r.centre[0] * f for r, f in zip(rests, forces))
    missed_y = unit[2] - sum(r.centre[1] * f for r, f in zip(rests, forces))
    return [
        np.array([f, r.centre[0] * f + w * missed_x, r.centre[1] * f + w * missed_y]) for r, f, w in zip(rests, forces, fractions)
    ]


def _edges(rest: Rest, share: np.ndarray) -> np.ndarray:
    """For each edge of ``rest``'s hull, the functional (3,) of a box's load (F, F x, F y) that is
    the share's force times how far inside that edge it acts (``share``: :func:`_shares`' matrix),
    shape (edges, 3), for a hull with area."""
    hull, units = np.array(rest.hull), np.array(rest.units)
    across = units[:, 1] * hull[:, 0] - units[:, 0] * hull[:, 1]
    functionals: np.ndarray = np.outer(units[:, 0], share[2]) - np.outer(units[:, 1], share[1]) + np.outer(across, share[0])
    return functionals


def _split(load: Sequence[float], rests: Sequence[Rest]) -> list[tuple[int, tuple[float, float, float, float], float]] | None:
    """A load (N, and its moments N m: F, F x, F y, F z) split among the level ``rests`` of its
    box: per support, what it puts there (the same four), and how far (m) inside the rest's
    polygon it acts; None when this split does not fit (the module docstring's load paths).

    The shares: all on one rest; on two, the load's point projected on the line through their
    centres, clipped to the segment; on more, the least-squares shares of the centres (scipy's
    nnls). Each share acts at its rest's centre moved by what the shares' combination misses,
    and must lie :data:`INSIDE` its polygon. Source: stackdsl's own."""
    if not rests:
        return None
    force, mx, my, mz = load
    if force <= 0.0:
        return None
    x, y, z = mx / force, my / force, mz / force
    if len(rests) == 1:
        weights = [1.0]
    elif len(rests) == 2:
        (x0, y0), (x1, y1) = rests[0].centre, rests[1].centre
        dx, dy = x1 - x0, y1 - y0
        length = dx * dx + dy * dy
        t = 0.5 if length < 1e-18 else min(1.0, max(0.0, ((x - x0) * dx + (y - y0) * dy) / length))
        weights = [1.0 - t, t]
    else:
        centres = np.array([r.centre for r in rests])
        system = np.vstack([centres.T, np.full(len(rests), 10.0)])  # the shares' sum, weighted to hold
        solved, _ = nnls(system, np.array([x, y, 10.0]))
        total = float(solved.sum())
        if total <= 0.0:
            return None
        weights = (solved / total).tolist()
    missed_x = x - sum(w * r.centre[0] for w, r in zip(weights, rests))
    missed_y = y - sum(w * r.centre[1] for w, r in zip(weights, rests))
    out = []
    for w, r in zip(weights, rests):
        if w <= 1e-12:
            continue
        px, py = r.centre[0] + missed_x, r.centre[1] + missed_y
        inside = r.inside(px, py)
        if inside <= INSIDE:
            return None
        f = force * w
        out.append((r.lower, (f, f * px, f * py, f * z), inside))
    return out


def _hull(points: list[list[float]]) -> list[int]:
    """The indices of ``points`` ((x, y) each, m) on their convex hull, counter-clockwise
    (Andrew's monotone chain), without collinear ones."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))

    def cross(o: int, a: int, b: int) -> float:
        (ox, oy), (ax, ay), (bx, by) = points[o], points[a], points[b]
        return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox)

    lower: list[int] = []
    upper: list[int] = []
    for i in order:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], i) <= 1e-15:
            lower.pop()
        lower.append(i)
    for i in reversed(order):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], i) <= 1e-15:
            upper.pop()
        upper.append(i)
    return lower[:-1] + upper[:-1]

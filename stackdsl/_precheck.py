"""Checks before simulating: mistakes the compiler can see in the placements themselves.

Every brick is tested where the program will put it (after the placement error), against
what exists at the moment it is placed: the ground plane (z = 0), the fixtures, and the
bricks placed before it at their target poses; bricks placed ``together`` exist together.

* **Overlap** (always an error): two bricks, a brick and a fixture, or a brick and the
  ground interpenetrate by more than :data:`OVERLAP_TOLERANCE`. pybullet would push them
  apart at the first step, and the scene would collapse for a reason that is no part of it.
* **Floating**: a brick rests on nothing when it is placed. It *rests on* a body when,
  lowered by :data:`REST_TOLERANCE`, it would sink into that body deeper than it already
  is, at a point below its centre: a contact from below within the tolerance. A brick
  only touching something sideways, or hanging by its top on another brick's corner,
  rests on nothing. Tower generators report this at their own fields (``spacing``,
  ``bricks_per_layer``, ``shift``). Dropping a brick from the air may be meant: a
  top-level ``allow: [floating]`` silences this check (the program lists those bricks).
* **Expectations about levels never built**: ``expect.stays`` and ``expect.may_fall``
  may only name built levels (1 to the highest placed); an expected ``collapse`` level
  L ± t is checkable when its range reaches a built level, L - t <= the highest level
  (``9±1`` on an 8-level tower is fine, ``7`` on a 3-level tower is not).

Geometry: overlap depths are found by the separating-axis test on each pair of boxes
(15 axes: 3 face normals of each box and the 9 cross products of their edges), which for
convex polyhedra gives the exact penetration depth. Resting contacts between boxes that
both have an axis vertical (lying flat, on a side or on an end) are decided by the same
test on the lowered box; a contact involving a tilted box is found with pybullet's
``getClosestPoints`` on a DIRECT client, nothing stepped, with a collision margin of
0.01 mm (pybullet's default 1 mm margin rounds corners and edges by as much). Candidate
pairs come from a sweep over axis-aligned bounding boxes, so a tall tower costs little.

Source: stackdsl's own; the separating-axis test is the standard one for oriented boxes
(Gottschalk, Lin and Manocha, "OBBTree", SIGGRAPH 1996).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ._errors import FieldPath
from ._expect import _span
from ._expectations import CollapseLevel
from ._schema import Scenario

REST_TOLERANCE = 0.001
"""Metres: a brick rests on a body when lowered this far it would sink into it (from below its centre)."""
OVERLAP_TOLERANCE = 0.0001
"""Metres: bodies may interpenetrate this deep where placed (rounding of hand-written poses); deeper is an error."""
FLOATING = "floating"
"""The ``allow`` entry that silences the floating check."""

_MARGIN = 1e-5  # m: pybullet collision margin of the query bodies (its default, 1 mm, rounds corners by as much)
_EPS = 1e-6  # m: deeper by less than this is no deeper (numerical noise of the distance queries)
_VERTICAL = 1.0 - 1e-12  # |cosine| of an axis with z above which the axis counts as vertical
_CHUNK = 100_000  # candidate pairs tested at once (bounds memory on hostile files)
_MAX_FOUND = 1000  # overlaps after which the search stops (a file that bad needs no exact count)
_GROUND = -1


@dataclass(frozen=True)
class Body:
    """One brick or fixture as the program will place it.

    Attributes:
        id: the brick's id.
        half_extents: metres, along the brick's own x, y, z.
        position: metres, the centre the program uses (placement error applied).
        nominal: metres, the centre as written or generated (no placement error).
        yaw, pitch, roll: degrees (:meth:`stability.Pose.from_euler`).
        slot: placement slot (bricks placed ``together`` share one), -1 for a fixture.
        time: seconds, when it is placed (0 for a fixture).
        level: the brick's level (0 for a fixture).
        path: the scenario field that made it: ``("structure", "bricks", i)``,
            ``("structure", "tower")`` or ``("structure", "card_house")``.
    """

    id: str
    half_extents: tuple[float, float, float]
    position: tuple[float, float, float]
    nominal: tuple[float, float, float]
    yaw: float
    pitch: float
    roll: float
    slot: int
    time: float
    level: int
    path: FieldPath


@dataclass(frozen=True)
class _Problem:
    key: tuple  # what is wrong, independent of where it is reported
    order: tuple  # report order: overlaps first, then floating bricks in placement order, then expectations
    path: FieldPath
    message: str
    effect: str = ""  # what happens to the brick, for a message at timing.placement_error


def precheck(scenario: Scenario, bodies: Sequence[Body]) -> tuple[str, ...]:
    """Check the placements and expectations of a compiled scenario before anything runs.

    Args:
        scenario: the scenario (for its source map, generators, timing, ``allow`` and ``expect``).
        bodies: every brick and fixture in placement order (fixtures anywhere).

    Returns:
        The ids of the bricks that rest on nothing when placed and are allowed to
        (``allow: [floating]``), in placement order.

    Raises:
        ScenarioError: at the field to change, for the first problem in placement order
            (overlaps before floating bricks before expectations); ``more`` counts the rest
            (a generator's bricks count once per kind of problem; past 1000 overlaps the
            search stops, so the count is then a lower bound).
    """
    overlaps, floating = _inspect(bodies, [b.position for b in bodies])
    allowed = FLOATING in scenario.allow
    found: list[tuple[tuple[int, int, int], tuple[Any, ...], float]] = sorted(
        [((0, bodies[b].slot, b), ("overlap", b, s), d) for b, s, d in overlaps]
        + ([] if allowed else [((1, bodies[b].slot, b), ("floating", b), 0.0) for b in floating])
    )
    expectations = _expectation_problems(scenario, max(b.level for b in bodies))
    if found:
        _, key, depth = found[0]
        if key[0] == "overlap":
            first = _overlap_problem(scenario, bodies, key[1], key[2], depth)
        else:
            first = _floating_problem(scenario, bodies, key[1], floating)
        if scenario.timing.placement_error > 0:
            first = _blame_placement_error(scenario, bodies, first, allowed)
        # a generator's bricks that miss for one reason are one problem: count one per generator and kind
        causes = {(key[0], key[1] if bodies[key[1]].path[1] == "bricks" else bodies[key[1]].path) for _, key, _ in found}
        raise scenario.source.error(first.path, first.message, more=len(causes) - 1 + len(expectations))
    if expectations:
        first = expectations[0]
        raise scenario.source.error(first.path, first.message, more=len(expectations) - 1)
    return tuple(bodies[i].id for i in floating)


# geometry -------------------------------------------------------------------------


def _inspect(bodies: Sequence[Body], positions: Sequence[tuple[float, float, float]]) -> tuple[list, list[int]]:
    """Overlaps ``(later, other or _GROUND, depth in m)`` and floating bricks (indices) of the
    bodies at ``positions``."""
    n = len(bodies)
    centre = np.array(positions, dtype=float).reshape(n, 3)
    half = np.array([b.half_extents for b in bodies], dtype=float).reshape(n, 3)
    rotation = Rotation.from_euler("ZYX", [[b.yaw, b.pitch, b.roll] for b in bodies], degrees=True)
    axes = rotation.as_matrix().reshape(n, 3, 3)  # column k: the body's axis k in the world
    slot = np.array([b.slot for b in bodies])
    brick = slot >= 0
    reach = np.abs(axes) @ half[:, :, None]
    low, high = centre - reach[:, :, 0], centre + reach[:, :, 0]
    prism = (np.abs(axes[:, 2, :]) > _VERTICAL).any(axis=1)

    overlaps: list[tuple[int, int, float]] = []
    bottom = low[:, 2]
    for i in np.flatnonzero(brick & (bottom < -OVERLAP_TOLERANCE)):
        overlaps.append((int(i), _GROUND, float(-bottom[i])))
    grounded = brick & (bottom < REST_TOLERANCE - _EPS)

    near_a, near_b, near_depth = [], [], []
    for a, b in _candidates(low, high, REST_TOLERANCE):
        keep = brick[a] | brick[b]  # two fixtures may overlap: neither moves
        a, b = a[keep], b[keep]
        depth = _depth(centre[a], axes[a], half[a], centre[b], axes[b], half[b])
        near = depth > -REST_TOLERANCE  # the separating-axis bound: farther pairs cannot touch
        near_a.append(a[near])
        near_b.append(b[near])
        near_depth.append(depth[near])
        deep = np.flatnonzero(depth > OVERLAP_TOLERANCE)
        for a_, b_, d in zip(a[deep], b[deep], depth[deep]):
            later, other = (a_, b_) if (slot[a_], a_) > (slot[b_], b_) else (b_, a_)
            overlaps.append((int(later), int(other), float(d)))
        if len(overlaps) > _MAX_FOUND:
            return overlaps, []  # a file this bad needs no list of floating bricks
    pa, pb, depth0 = (np.concatenate(x) if x else np.zeros(0) for x in (near_a, near_b, near_depth))
    pa, pb = pa.astype(int), pb.astype(int)

    # directed candidate supports: (brick, support) where the support exists when the brick is placed
    up = np.concatenate([pa, pb])
    down = np.concatenate([pb, pa])
    before = np.concatenate([depth0, depth0])
    ok = brick[up] & (slot[down] <= slot[up])
    up, down, before = up[ok], down[ok], before[ok]
    exact = prism[up] & prism[down]
    lowered = centre[up[exact]] - [0.0, 0.0, REST_TOLERANCE]
    after = _depth(lowered, axes[up[exact]], half[up[exact]], centre[down[exact]], axes[down[exact]], half[down[exact]])
    rests = after > np.maximum(before[exact], 0.0) + _EPS
    supports = list(zip(up[exact][rests].tolist(), down[exact][rests].tolist()))
    tilted = ~exact
    if tilted.any():
        quats = rotation.as_quat().reshape(n, 4)
        supports += _tilted_supports(up[tilted], down[tilted], centre, half, quats)

    return overlaps, _floating(slot, grounded, supports)


def _floating(slot: np.ndarray, grounded: np.ndarray, supports: list[tuple[int, int]]) -> list[int]:
    """Bricks resting on nothing: not on the ground, a fixture or an earlier brick, nor on a
    brick of their own slot that rests on something (bricks placed together hold each other)."""
    held = grounded.copy()
    holds: dict[int, list[int]] = {}  # brick -> the bricks of its own slot resting on it
    for b, s in supports:
        if slot[s] < slot[b]:
            held[b] = True
        else:
            holds.setdefault(s, []).append(b)
    reached = [int(i) for i in np.flatnonzero(held)]
    while reached:
        for b in holds.get(reached.pop(), ()):
            if not held[b]:
                held[b] = True
                reached.append(b)
    order = sorted(np.flatnonzero((slot >= 0) & ~held), key=lambda i: (slot[i], i))
    return [int(i) for i in order]


def _candidates(low: np.ndarray, high: np.ndarray, gap: float):
    """Index pairs ``(a, b)`` whose bounding boxes come within ``gap`` of each other, in
    chunks: sweep and prune along the axis on which the bodies spread most."""
    n = len(low)
    axis = int(np.argmax(high.max(axis=0) - low.min(axis=0))) if n else 0
    order = np.argsort(low[:, axis], kind="stable")
    start = low[order, axis]
    end = np.searchsorted(start, high[order, axis] + gap, side="right")
    counts = np.maximum(end - np.arange(n) - 1, 0)
    total = np.cumsum(counts)
    cuts = np.searchsorted(total, np.arange(_CHUNK, int(total[-1]) if n else 0, _CHUNK), side="right")
    bounds = np.unique(np.concatenate([[0], cuts, [n]]))
    for first, last in itertools.pairwise(bounds):
        rows = np.repeat(np.arange(first, last), counts[first:last])
        steps = np.arange(len(rows)) - np.repeat(np.cumsum(counts[first:last]) - counts[first:last], counts[first:last])
        a, b = order[rows], order[rows + 1 + steps]
        close = ((low[a] <= high[b] + gap) & (low[b] <= high[a] + gap)).all(axis=1)
        yield a[close], b[close]


def _depth(ca: np.ndarray, ra: np.ndarray, ha: np.ndarray, cb: np.ndarray, rb: np.ndarray, hb: np.ndarray) -> np.ndarray:
    """Penetration depth of box pairs by the separating-axis test.

    Args:
        ca, cb: centres, shape (m, 3); ra, rb: rotation matrices, shape (m, 3, 3);
        ha, hb: half extents, shape (m, 3); metres.

    Returns:
        Shape (m,): the depth (m) when the boxes interpenetrate (exact: the shortest
        translation that separates them), else minus a lower bound of their distance.
    """
    if not len(ca):
        return np.zeros(0)
    crosses = np.cross(ra[:, :, :, None], rb[:, :, None, :], axis=1).reshape(len(ca), 3, 9)
    normals = np.concatenate([ra, rb, crosses], axis=2)  # (m, 3, 15): the candidate axes as columns
    length = np.sqrt((normals * normals).sum(axis=1))
    valid = length > 1e-6  # parallel edges give no axis
    normals = normals / np.where(valid, length, 1.0)[:, None, :]
    radius_a = (np.abs(np.swapaxes(ra, 1, 2) @ normals) * ha[:, :, None]).sum(axis=1)
    radius_b = (np.abs(np.swapaxes(rb, 1, 2) @ normals) * hb[:, :, None]).sum(axis=1)
    apart = np.abs(((cb - ca)[:, :, None] * normals).sum(axis=1))
    return np.where(valid, radius_a + radius_b - apart, np.inf).min(axis=1)


def _tilted_supports(
    up: np.ndarray, down: np.ndarray, centre: np.ndarray, half: np.ndarray, quats: np.ndarray
) -> list[tuple[int, int]]:
    """The pairs ``(brick, support)`` among the candidates where the brick rests on the
    support, by pybullet's closest points: lowered by the rest tolerance, the brick sinks
    deeper into the support at a point below its centre."""
    from ._world import direct_client  # pybullet only when a tilted brick needs it

    found = []
    with direct_client() as client:
        import pybullet

        shapes: dict[tuple[float, ...], int] = {}
        bodies: dict[int, int] = {}
        for i in sorted(set(up.tolist()) | set(down.tolist())):
            key = tuple(half[i].tolist())
            if key not in shapes:
                shapes[key] = client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=list(key))
            bodies[i] = client.createMultiBody(
                0.0, shapes[key], basePosition=centre[i].tolist(), baseOrientation=quats[i].tolist()
            )
            client.changeDynamics(bodies[i], -1, collisionMargin=_MARGIN)

        def deepest(a: int, b: int) -> tuple[float, float]:
            points = client.getClosestPoints(bodies[a], bodies[b], REST_TOLERANCE)
            if not points:
                return math.inf, math.inf
            p = min(points, key=lambda q: q[8])
            return float(p[8]), float(p[5][2])  # distance, height of the point on a

        pairs: dict[int, list[int]] = {}
        for b, s in zip(up.tolist(), down.tolist()):
            pairs.setdefault(b, []).append(s)
        for b, below in pairs.items():
            before = {s: deepest(b, s)[0] for s in below}
            lowered = centre[b] - [0.0, 0.0, REST_TOLERANCE]
            client.resetBasePositionAndOrientation(bodies[b], lowered.tolist(), quats[b].tolist())
            for s in below:
                distance, height = deepest(b, s)
                if distance < -_EPS and distance < before[s] - _EPS and height < lowered[2]:
                    found.append((b, s))
            client.resetBasePositionAndOrientation(bodies[b], centre[b].tolist(), quats[b].tolist())
    return found


# messages -------------------------------------------------------------------------


def _millimetres(metres: float) -> str:
    mm = metres * 1000
    return f"{mm:.1f}" if abs(mm) < 1e9 else f"{mm:.4g}"


def _mm(metres: float) -> str:
    return f"{_millimetres(metres)} mm"


def _at(position: Sequence[float]) -> str:
    return "(" + ", ".join(_millimetres(v) for v in position) + ") mm"


def _name(body: Body) -> str:
    if body.path[:2] == ("structure", "bricks"):
        return f"brick {body.id!r} (structure.bricks[{body.path[2]}])"
    return f"brick {body.id}"


def _overlap_problem(scenario: Scenario, bodies: Sequence[Body], b: int, s: int, depth: float) -> _Problem:
    brick = bodies[b]
    key, order = ("overlap", b, s), (0, brick.slot, b)
    into = "the ground" if s == _GROUND else _name(bodies[s])
    effect = f"reaches {depth * 1000:.2f} mm into {into}"
    what = f"{_name(brick)} placed at {_at(brick.position)} {effect}"
    limit = f"bodies may touch, or overlap by at most {_mm(OVERLAP_TOLERANCE)} (pybullet would push them apart)"
    if brick.path[1] == "bricks":
        fix = f"raise it by {depth * 1000:.2f} mm" if s == _GROUND else "move one of them"
        return _Problem(key, order, brick.path + ("at",), f"{what}; {limit}: {fix}", effect)
    if brick.path[1] == "tower" and s != _GROUND:
        t = scenario.structure.tower
        assert t is not None
        width = float(scenario.brick_type(t.brick).size[1])
        return _Problem(
            key,
            order,
            ("structure", "tower", "spacing"),
            f"{what}: the bricks of a layer are {_mm(t.spacing)} apart centre to centre and {_mm(width)} wide; "
            f"use a spacing of at least {_mm(width)}",
            effect,
        )
    return _Problem(key, order, _generator_field(scenario), f"{what}; {limit}", effect)


def _floating_problem(scenario: Scenario, bodies: Sequence[Body], b: int, floating: list[int]) -> _Problem:
    brick = bodies[b]
    key, order = ("floating", b), (1, brick.slot, b)
    silence = f"or add 'allow: [{FLOATING}]' at the top level if it is meant to drop"
    effect = "rests on nothing"
    what = (
        f"{_name(brick)} rests on nothing when it is placed (t = {brick.time:g} s): no ground, fixture or brick "
        f"placed before it is within {_mm(REST_TOLERANCE)} below it"
    )
    if brick.path[1] == "bricks":
        return _Problem(
            key,
            order,
            brick.path + ("at",),
            f"{what} (its lowest point is {_mm(_lowest(brick))} above the ground); lower it onto what should hold it, "
            f"list it after that, {silence}",
            effect,
        )
    if brick.path[1] == "tower":
        path, message = _tower_floating(scenario, bodies, b, floating)
        return _Problem(key, order, path, f"{message}; {silence}", effect)
    return _Problem(key, order, _generator_field(scenario), f"{what}; {silence}", effect)


def _lowest(body: Body) -> float:
    rotation = Rotation.from_euler("ZYX", [body.yaw, body.pitch, body.roll], degrees=True).as_matrix()
    return float(body.position[2] - np.abs(rotation[2]) @ np.array(body.half_extents))


def _tower_floating(scenario: Scenario, bodies: Sequence[Body], b: int, floating: list[int]) -> tuple[FieldPath, str]:
    """The field to change and the message for a tower whose bricks miss the layer below."""
    t = scenario.structure.tower
    assert t is not None
    length, width = (float(v) for v in scenario.brick_type(t.brick).size[:2])
    brick = bodies[b]
    level = [bodies[i].id for i in floating if bodies[i].level == brick.level]
    head = f"level {brick.level} of the tower: {', '.join(level)} rest{'s' * (len(level) == 1)} on nothing when placed"
    square = abs(math.remainder(t.turn, 180.0)) == 90.0
    n = t.bricks_per_layer
    tower: FieldPath = ("structure", "tower")
    if square and n > 1 and t.spacing >= (length + width) / (n - 1) - 1e-12:
        limit = (length + width) / (n - 1)
        outer = (n - 1) * t.spacing / 2
        most = max(1, math.ceil((length + width) / t.spacing - 1e-9))
        written = t.model_fields_set
        field = "bricks_per_layer" if "bricks_per_layer" in written and "spacing" not in written else "spacing"
        return tower + (field,), (
            f"{head}: with {n} bricks a layer {_mm(t.spacing)} apart, the outer ones are centred {_mm(outer)} "
            f"from the middle of their layer, so their near edge ({_mm(outer - width / 2)} out) is not inside "
            f"the {_mm(length / 2)} that the layer below reaches (half a brick's length); use a spacing below "
            f"{_mm(limit)} ((length + width) / (bricks_per_layer - 1)) and at least {_mm(width)} (the width), "
            f"or at most {most} brick{'s' * (most != 1)} a layer"
        )
    if t.shifts is not None and brick.level is not None and brick.level > 1:
        x, y = t.shifts[brick.level - 2]
        return tower + ("shifts", brick.level - 2), (
            f"{head}: it is moved ({_millimetres(x)}, {_millimetres(y)}) mm from the layer below, too far for its "
            f"bricks to reach it ({n} a layer, {_mm(t.spacing)} apart, each layer turned {t.turn:g} deg); use a smaller shift"
        )
    if any(abs(v) > 0 for v in t.shift):
        return tower + ("shift",), (
            f"{head}: each layer is moved ({_millimetres(t.shift[0])}, {_millimetres(t.shift[1])}) mm from the one "
            f"below, too far for its bricks to reach the layer below ({n} a layer, {_mm(t.spacing)} apart, each "
            f"layer turned {t.turn:g} deg); use a smaller shift"
        )
    return tower + ("spacing",), (
        f"{head}: the layer below does not reach under them ({n} bricks a layer, {_mm(t.spacing)} apart, each "
        f"layer turned {t.turn:g} deg); bring the bricks of a layer closer together"
    )


def _generator_field(scenario: Scenario) -> FieldPath:
    """The field of a card house to change (its own checks keep its bricks apart and on the peaks)."""
    c = scenario.structure.card_house
    return ("structure", "card_house", "spacing" if c is not None and c.spacing else "angle")


def _blame_placement_error(scenario: Scenario, bodies: Sequence[Body], problem: _Problem, allowed: bool) -> _Problem:
    """A problem that the placement error made (the poses as written have none) is
    reported at ``timing.placement_error``."""
    overlaps, floating = _inspect(bodies, [b.nominal for b in bodies])
    nominal = {("overlap", b, s) for b, s, _ in overlaps} | ({("floating", b) for b in floating} if not allowed else set())
    if problem.key in nominal:
        return problem
    brick = bodies[problem.key[1]]
    silence = f" (or add 'allow: [{FLOATING}]' at the top level)" if problem.key[0] == "floating" else ""
    message = (
        f"a placement error of up to {_mm(scenario.timing.placement_error)} (seed {scenario.seed}) moves "
        f"{_name(brick)} to {_at(brick.position)}, where it {problem.effect}; as written it does not: use a smaller "
        f"placement error or another seed{silence}"
    )
    return _Problem(problem.key, problem.order, ("timing", "placement_error"), message, problem.effect)


def _expectation_problems(scenario: Scenario, top: int) -> list[_Problem]:
    """Expectations about levels above the highest level placed (``top``)."""
    expect = scenario.expect
    problems = []
    c = expect.collapse
    if isinstance(c, CollapseLevel) and c.level - c.tolerance > top:
        written = (
            f"collapse {c.level}±{c.tolerance} (levels {c.level - c.tolerance}-{c.level + c.tolerance})"
            if c.tolerance
            else f"collapse {c.level}"
        )
        problems.append(
            _Problem(
                ("expect", "collapse"),
                (2, 0),
                ("expect", "collapse"),
                f"{written} can never be measured: the structure has {top} level{'s' * (top != 1)}, and the "
                f"collapse level is the highest level placed when a brick first moves; expect a level from 1 to "
                f"{top} (or a tolerance that reaches one), or 'stands: true'",
            )
        )
    for name in ("stays", "may_fall"):
        levels = getattr(expect, name)
        beyond = [lv for lv in levels or () if lv > top]
        if beyond:
            problems.append(
                _Problem(
                    ("expect", name),
                    (2, 1 if name == "stays" else 2),
                    ("expect", name),
                    f"level{'s' * (len(beyond) != 1)} {_span(beyond)} {'are' if len(beyond) != 1 else 'is'} never built: "
                    f"the structure has {top} level{'s' * (top != 1)}; name levels from 1 to {top}",
                )
            )
    return problems

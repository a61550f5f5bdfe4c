"""The certificate of a standing structure: rigid-block equilibrium of everything, as it is.

Whatever the extension froze and whatever the engine still moves, the bodies are solved as
they are at the end of a run: every brick a free block at its pose, the ground and fixed
bodies supports; a frozen brick's contacts those remembered when it froze (two frozen
bodies report none), an active brick's from its pose and the engine's contact points: the
exact face overlap with every body it lies on face to face, found from the poses, and for any
other pair the engine reports, its points. Where a pair's points have no area (one, two, or in
a line), frozen or not, they are taken with the corner, edge or face where the two bodies'
shapes meet (:meth:`stability._areas.ContactAreas.shaped`), bare: an engine may report one
point for two boxes not face to face, and a cantilever at rest tipped 1 deg on a table's edge,
its counterweight's edge on its back end, rested on two corners, a diagonal its centre of mass
lay off ("no equilibrium", 1.02 N of tension, ten bricks' weight, for a structure rigid statics
holds); and the leaning test's padding across the normal (report 3.4.2) made a foot's edge a
2 mm strip that carried a moment, on which an inverted V past its friction angle stood. Only
where the shapes show no contact is the padding kept. When forces exist that balance every
block, the program's solution proves that the structure stands; the margin says how far every
centre of mass could move together before it would not (:func:`stability.equilibrium_margin`),
found on the contacts themselves; a padding kept would widen it by up to its half-width, so it
is solved again with those bare points, and is 0 when only the padding holds the structure.
When none exist, the collapse mechanism names the
bricks that must move.

Most stacks need no program: when every brick is frozen and each one's centre of mass lies
over its load path (:mod:`stability._load_path`), those paths are already a solution of the
program with no tension, found brick by brick as they froze. The least distance from a centre
of mass to the edge of its path, in any direction, is then a lower bound of the margin: every
centre of mass moved together by less stays over its path (:func:`_inside`). It is the margin
(to :data:`stability._margin.MARGIN_TOLERANCE`) when a brick that carries nothing lies that
near its path's edge and its own contacts end there too (a tower's top brick,
:func:`_over_its_contacts`): no shift further that way balances that brick, whatever the rest
does. This keeps the certificate of a 60-level tower to a few milliseconds where the margin's
programs take a second. Otherwise (a load path is the part of a contact over the path below,
so a brick set back on a staggered single file has a path ending short of its support's edge,
0.2 mm from its centre of mass where the program gives 11.4) the program's margin is solved,
and reported when larger.

Source: stackdsl's own, on rigid-block equilibrium (Livesley 1978; Whiting et al. 2009).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import shapely
from shapely.geometry import Polygon

from ._areas import ContactAreas, by_body
from ._equilibrium import FINE_SIDES, LEVEL_TILT, ContactPolygon, RigidBlock, bare_contacts, solve_equilibrium
from ._friction import FRICTION_STEP, friction_share
from ._geometry import FACE_TILT, level_offset
from ._graph import BrickState
from ._leaning import pair_friction
from ._margin import MARGIN_TOLERANCE, equilibrium_margin
from ._stack import Record, Stack

#: Metres: the largest margin reported.
MARGIN_LIMIT = 0.02


@dataclass(frozen=True)
class Certificate:
    """What rigid-block equilibrium says of every registered brick where it is.

    Attributes:
        stands: forces exist that balance every brick.
        tension: newtons, the least total tension the contacts would need (0 when it stands).
        margin: metres, how far every centre of mass can move together horizontally, in any
            direction, before it would not stand (one common shift of every brick's centre of
            mass; the program's friction pyramid of eight sides, or of 32 when eight do not
            balance it as it is): the distance from 0 to the edge of the polygon of shifts that
            balance, never more than it and at most :data:`stability._margin.MARGIN_TOLERANCE`
            (0.1 mm) less (:func:`stability.equilibrium_margin`; with load paths, a lower bound
            proven that near it, :func:`_over_its_contacts`), less the most a corner of a brick
            within 0.5 deg of level lies from where it would were the brick level (0.04 mm at
            most for a flat KAPLA brick, :func:`_levelled`): a bound for the level bricks the engine settled
            tilted by its compliance as well. At most :data:`MARGIN_LIMIT`
            (20 mm); 0 when it does not stand, or when only the program's own tolerance lets it.
        mechanism: labels of the bricks that move in the collapse mechanism (empty when it
            stands).
        bricks: how many bricks were solved; active: labels of those the engine still moved.
        contacts: how many contact polygons held them.
        method: ``"load paths"`` (every brick frozen over its load path) or ``"program"``
            (the equilibrium program solved).
        friction: for a stand the program proved, the least share of every contact's friction
            coefficient with which it still balances, to :data:`stability._friction.FRICTION_STEP` above
            (:func:`stability.friction_share`); with load paths, the share their vertical forces
            need on supports out of level (:func:`_path_share`); 0 when vertical forces on level
            faces hold it, and when it does not stand.
    """

    stands: bool
    tension: float
    margin: float
    mechanism: tuple[str, ...]
    bricks: int
    active: tuple[str, ...]
    contacts: int
    method: str = "program"
    friction: float = 0.0


def certify(stack: Stack, areas: ContactAreas) -> Certificate:
    """Solve every registered brick of ``stack`` where it is (module docstring): by the load
    paths when every brick is frozen over its own (:func:`_by_load_paths`), else on every contact
    (the frozen bricks' remembered ones, and :func:`_active_contacts`) by the program
    (:func:`_by_program`).

    Raises:
        ValueError: a contact without points (not expected from the engine).
    """
    bricks = [r for r in stack.bodies.values() if r.state is not BrickState.GROUND]
    ground = {k for k, r in stack.bodies.items() if r.state is BrickState.GROUND}
    known = {r.body for r in bricks} | ground
    polygons: list[ContactPolygon[int]] = areas.shaped(
        [c for r in bricks if r.state is BrickState.FROZEN for c in r.contacts if c.other in known]
    )
    active = [r for r in bricks if r.state is BrickState.ACTIVE]
    if bricks and not active and not stack.unproven:
        return _levelled(stack, bricks, _by_load_paths(stack, bricks, polygons))
    if active:
        polygons += _active_contacts(stack, areas, active, polygons)
    return _levelled(stack, bricks, _by_program(stack, bricks, active, polygons))


def _levelled(stack: Stack, bricks: list[Record], certificate: Certificate) -> Certificate:
    """``certificate`` with its margin less the most that a corner of a brick within 0.5 deg of
    level (:data:`stability._geometry.FACE_TILT`) lies from where it would lie were the brick
    level about its centre (:func:`stability._geometry.level_offset`).

    The margin is found on the contacts as the engine settled them, and an engine's soft
    contacts tilt a stack by its compliance: on one engine a stack of 7 leaned 0.05 deg at its
    second brick to 0.12 deg at its top, which put the top face of the sixth 8.3 um past its
    centre's edge, and the margin read 0.502 mm where the exact rule of level bricks has
    0.494 mm (a near-tie sample of ``stackdsl bench verdicts``). Every contact polygon is the
    overlap of two bricks' faces, and the overlap of faces each moved by at most d contains the
    settled overlap shrunk by d, so the margin less d holds on the level bricks too. A brick
    tilted more than that is placed so (a domino, a leaning brick): its pose is the geometry,
    not the engine's give. Source: stackdsl's own."""
    if not certificate.stands or certificate.margin <= 0.0 or not bricks:
        return certificate
    rotations = np.array([stack.pose(r).rotation for r in bricks])
    near = np.abs(rotations[:, 2, :]).max(axis=1) > FACE_TILT
    if not near.any():
        return certificate
    half = np.array([r.box.half_extents for r in bricks])
    offset = float(level_offset(half[near], rotations[near]).max())
    return replace(certificate, margin=max(0.0, certificate.margin - offset))


def _by_load_paths(stack: Stack, bricks: list[Record], polygons: list[ContactPolygon[int]]) -> Certificate:
    """The certificate of ``bricks``, every one frozen over its load path (module docstring): the
    paths prove the stand; the margin is the least reach to a path's edge (:func:`_inside`) when
    that is proven the margin (:func:`_over_its_contacts`) or at :data:`MARGIN_LIMIT`, else the
    program's on the contacts (``polygons``) when larger, and the bare contacts' when a padding
    was kept (:func:`_bare_margin`; 0 when only the padding holds)."""
    reach = _inside(bricks)
    margin = min(d for d, _ in reach)
    padded = any(c.core is not None for c in polygons)

    def by_paths(width: float) -> Certificate:  # with what the paths' vertical forces need of friction
        share = _path_share(polygons, stack.config.support_angle)
        return Certificate(True, 0.0, width, (), len(bricks), (), len(polygons), "load paths", share)

    if not padded and (margin >= MARGIN_LIMIT or _over_its_contacts(bricks, polygons, reach) <= margin + MARGIN_TOLERANCE):
        return by_paths(min(margin, MARGIN_LIMIT))  # a lower bound, and the margin is at most the tolerance more
    blocks = {r.body: RigidBlock(r.box.mass, stack.pose(r).position) for r in bricks}
    if padded:  # the paths prove the stand; its margin is the bare contacts' (0: the padding's alone)
        bare = _bare_margin(blocks, polygons, stack.config.gravity)
        if not bare:
            return by_paths(bare)
        return Certificate(True, 0.0, bare, (), len(bricks), (), len(polygons), friction=_share(blocks, polygons, stack))
    shift = _margin(blocks, polygons, stack.config.gravity)
    if shift is None or shift <= margin:  # the paths' bound is the margin
        return by_paths(min(margin, MARGIN_LIMIT))
    return Certificate(True, 0.0, shift, (), len(bricks), (), len(polygons), friction=_share(blocks, polygons, stack))


def _active_contacts(
    stack: Stack, areas: ContactAreas, active: list[Record], polygons: list[ContactPolygon[int]]
) -> list[ContactPolygon[int]]:
    """The contact polygons of the ``active`` bricks that ``polygons`` (the frozen bricks') leave
    out: every brick's exact faces first, then the engine's points for the pairs no face covers.
    A face is the whole overlap, which the engine's few points of it may not span (a brick turned
    30 deg on another: pybullet's four points left out a corner of the pentagon, the centre of
    mass fell outside their hull and a still brick had "no equilibrium")."""
    pairs = {frozenset((c.body, c.other)) for c in polygons}
    found: list[ContactPolygon[int]] = []
    boxes = areas.boxes(active=True)
    for r in active:
        faces = [
            ContactPolygon(r.body, o, a.corners(), a.normal, pair_friction(r.friction, stack.bodies[o].friction))
            for o, a in areas.lying_on(r, stack.engine.pose(r.body), active=True, boxes=boxes).items()
            if frozenset((r.body, o)) not in pairs
        ]
        pairs |= {frozenset((c.body, c.other)) for c in faces}
        found += faces
    points = by_body(stack.engine.contact_points())
    for r in active:
        touching = {o: p for o, p in areas.around(r, points).items() if frozenset((r.body, o)) not in pairs}
        shaped = areas.shaped(areas.polygons(r, touching))
        found += shaped
        pairs |= {frozenset((c.body, c.other)) for c in shaped}
    return found


def _by_program(stack: Stack, bricks: list[Record], active: list[Record], polygons: list[ContactPolygon[int]]) -> Certificate:
    """The certificate of ``bricks`` on ``polygons`` by the equilibrium program: its margin when
    it stands (the bare contacts' when a padding was kept), else the tension and the collapse
    mechanism. A body touching nothing is in flight (a thrown brick that missed): no contact force
    can act on it, so it is no part of what stands, and no program that holds it could be found."""
    in_contact = {c.body for c in polygons} | {c.other for c in polygons}
    flying = {r.body for r in active if r.body not in in_contact}
    bricks = [r for r in bricks if r.body not in flying]
    active = [r for r in active if r.body not in flying]
    blocks = {r.body: RigidBlock(r.box.mass, stack.pose(r).position) for r in bricks}
    labels = {r.body: r.label for r in bricks}
    on_engine = tuple(r.label for r in sorted(active, key=lambda r: r.order))
    shift = _margin(blocks, polygons, stack.config.gravity)
    if shift is not None:  # it stands, and by how much: on the contacts themselves
        bare = _bare_margin(blocks, polygons, stack.config.gravity) if any(c.core is not None for c in polygons) else shift
        return Certificate(True, 0.0, bare, (), len(bricks), on_engine, len(polygons), friction=_share(blocks, polygons, stack))
    result = solve_equilibrium(blocks, polygons, gravity=stack.config.gravity)
    mechanism = tuple(labels[b] for b in stack.ordered(result.moving()))
    share = _share(blocks, polygons, stack) if result.stands else 0.0
    return Certificate(result.stands, result.tension, 0.0, mechanism, len(bricks), on_engine, len(polygons), friction=share)


def _share(blocks: dict[int, RigidBlock], polygons: list[ContactPolygon[int]], stack: Stack) -> float:
    return friction_share(blocks, polygons, stack.config.gravity)


def _path_share(polygons: list[ContactPolygon[int]], support_angle: float) -> float:
    """The share of the friction coefficients the load paths' vertical forces need: on a support
    (a contact whose normal is within ``support_angle`` degrees of straight up) tilted by t, a
    vertical force needs tan t of its normal part as friction, tan t / mu of the pair's
    coefficient. A brick frozen on a 20 deg ramp of pine (mu 0.5) needs 73%, where its
    certificate named no friction. Supports within :data:`stability._equilibrium.LEVEL_TILT` of
    level (an engine's noise) need none. Rounded up to :data:`stability._friction.FRICTION_STEP`,
    at most 1. Source: stackdsl's own (Coulomb's law, report eq. 12)."""
    if not polygons:
        return 0.0
    normals = np.array([c.normal for c in polygons], dtype=float).reshape(-1, 3)  # one array: a tower's hundreds
    up = normals[:, 2]
    support = up >= math.cos(math.radians(support_angle)) * np.linalg.norm(normals, axis=1)
    tan = np.hypot(normals[:, 0], normals[:, 1]) / np.where(support, up, 1.0)
    steep = support & (tan > LEVEL_TILT)
    if not steep.any():
        return 0.0
    mu = np.array([c.friction for c in polygons], dtype=float)[steep]
    if not (mu > 0.0).all():  # a frictionless support out of level: all of any friction
        return 1.0
    need = float(np.max(tan[steep] / mu))
    return min(1.0, math.ceil(need / FRICTION_STEP) * FRICTION_STEP)


def _bare_margin(blocks: dict[int, RigidBlock], polygons: list[ContactPolygon[int]], gravity: float) -> float:
    """Metres of :func:`stability.equilibrium_margin` with every padded contact polygon replaced by
    its own contact points (``core``); 0 when they alone hold nothing."""
    return _margin(blocks, bare_contacts(polygons), gravity) or 0.0


def _margin(blocks: dict[int, RigidBlock], polygons: list[ContactPolygon[int]], gravity: float) -> float | None:
    """Metres of :func:`stability.equilibrium_margin` (None: no balance), with the eight-sided
    pyramid and, when that finds none, with the fine one: between its edges eight sides keep
    only cos(pi/8) of a coefficient, and a ladder turned 30 deg against a wall, needing 95% of
    its friction out of its plane, read a margin of 0 where it has 0.66 mm."""
    found = equilibrium_margin(blocks, polygons, limit=MARGIN_LIMIT, gravity=gravity)
    if found is None:
        found = equilibrium_margin(blocks, polygons, limit=MARGIN_LIMIT, gravity=gravity, sides=FINE_SIDES)
    return found


def _inside(bricks: list[Record]) -> list[tuple[float, np.ndarray]]:
    """How far each brick's centre of mass can move, in any horizontal direction, and stay
    over its load path (proven frozen bricks): metres, the distance to the path's edge, with
    the unit direction (shape (2,)) to the nearest point of it. Every centre of mass moved
    together by less than the least of them stays over its path, so the paths still balance
    every brick: the least is a lower bound of the program's margin
    (:func:`stability.equilibrium_margin`), in every direction. (Along x and y only, the
    reach to the path's edge is more than the distance wherever the edge is not square to
    the axis: an overhang turned 45 deg read 7.1 mm, 5 / cos 45 deg, where its centre of mass
    is 5.0 mm from the edge.) A path that is a line or a point, or that does not cover the
    centre, leaves no room (0).

    shapely's functions on arrays do every brick's at once (one call for all bricks instead of
    some for each took 3 ms off the certificate of a 30-level tower). Source: stackdsl's own.
    """
    assert all(r.load_path is not None and r.frozen_pose is not None for r in bricks), "proven frozen bricks"
    xy = np.array([r.frozen_pose.position[:2] for r in bricks if r.frozen_pose is not None], dtype=float).reshape(-1, 2)
    paths = np.empty(len(bricks), dtype=object)
    paths[:] = [r.load_path for r in bricks]
    points = shapely.points(xy)
    wide = np.array([isinstance(p, Polygon) for p in paths.tolist()], dtype=bool)
    wide[wide] = shapely.covers(paths[wide], points[wide])
    out = [(0.0, np.array([1.0, 0.0]))] * len(bricks)
    if not wide.any():
        return out
    exteriors = shapely.get_exterior_ring(paths[wide])
    ends = shapely.get_coordinates(shapely.shortest_line(points[wide], exteriors)).reshape(-1, 2, 2)
    step = ends[:, 1] - ends[:, 0]
    distance = np.hypot(step[:, 0], step[:, 1])
    direction = np.where(distance[:, None] > 0, step / np.maximum(distance, 1e-300)[:, None], [1.0, 0.0])
    for i, d, u in zip(np.flatnonzero(wide).tolist(), distance.tolist(), direction, strict=True):
        out[i] = (float(d), u)
    return out


def _over_its_contacts(bricks: list[Record], polygons: list[ContactPolygon[int]], reach: list[tuple[float, np.ndarray]]) -> float:
    """Metres, an upper bound of the program's margin (:func:`stability.equilibrium_margin`)
    from the bricks that lie nearest the edge of their load paths (within
    :data:`MARGIN_TOLERANCE` of the least, :func:`_inside`) and carry nothing, on level
    contacts that all face up into them: the furthest any of their contact points lies along
    the direction to that edge, from the centre of mass (inf when no brick is such).

    Such a brick's shift is bounded whatever the rest does: the program holds its own six rows,
    with every other body as a support that may give any compressive force within friction
    (a relaxation, so its shifts include the whole program's). The brick carries nothing, so its
    weight's line must meet the hull of its contact points, but for the couple of the forces'
    horizontal parts (summing to 0, each at most (mu + tan t) / (1 - mu tan t) of its vertical
    part on a contact tilted by t), whose arm is at most the spread of the contacts' heights:
    that spread times the ratio is added. On a
    tower's top brick the bound is its path's own edge, and the path's margin is proven exact
    without a program. Source: stackdsl's own.
    """
    least = min(d for d, _ in reach)
    carrying = {c.other for c in polygons}
    own: dict[int, list[ContactPolygon[int]]] = {}
    for c in polygons:
        own.setdefault(c.body, []).append(c)
    best = math.inf
    for r, (distance, direction) in zip(bricks, reach, strict=True):
        contacts = own.get(r.body, [])
        if distance > least + MARGIN_TOLERANCE or r.body in carrying or not contacts or r.frozen_pose is None:
            continue
        normals = np.array([c.normal for c in contacts], dtype=float).reshape(-1, 3)
        normals /= np.linalg.norm(normals, axis=1)[:, None]
        if not (normals[:, 2] > 0.0).all():  # a contact that is no support from below
            continue
        tilt = float(np.max(np.hypot(normals[:, 0], normals[:, 1]) / normals[:, 2]))
        mu = max(c.friction for c in contacts)
        if mu * tilt >= 0.5:  # friction could pull down: no bound from the hull
            continue
        points = np.vstack([np.asarray(c.points, dtype=float).reshape(-1, 3) for c in contacts])
        # horizontal over vertical part of a contact force: at most (mu + tan t) / (1 - mu tan t)
        spread = float(np.ptp(points[:, 2])) * (mu + tilt) / (1.0 - mu * tilt)
        best = min(best, float(np.max((points[:, :2] - r.frozen_pose.position[:2]) @ direction)) + spread)
    return best

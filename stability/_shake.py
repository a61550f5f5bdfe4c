"""A pseudo-static check of the frozen stack under an effective gravity: a shaking ground.

A rigid stack on a base that accelerates horizontally by ``a`` moves with it as long as, in the
base's frame, every part stands under the effective gravity ``g_eff = (-a_x, -a_y, -g)``: gravity
plus the inertial force of the base's acceleration (d'Alembert). A shake's worst instant is its
peak acceleration, either way, so the stack must stand under ``g_eff`` for ``+a_peak`` and for
``-a_peak``.

Two tests, each the report's (or Coulomb's) with the tilted gravity:

* **tipping**: the resultant of a brick and everything it carries acts through its centre of
  mass above (report 3.3.5) along ``g_eff``; it must meet the plane of the brick's main contact
  area inside that area (report 3.3.4, with the line of action tilted instead of vertical). For
  a centre of mass ``h`` above the contact, the point moves by ``h a / g`` against the
  acceleration.
* **sliding**: with level contacts and a uniform acceleration every contact carries a tangential
  force ``a / g`` times its normal force (each part above it is accelerated by ``a``, held by
  its weight ``m g``); it holds while ``a / g`` is at most the pair's friction coefficient
  (Coulomb).

Both are exact on level contacts. A brick leaning on another or on a wall already needs part of
its friction at rest, and the tilt adds to it on one side: the part of the frozen stack that holds
such a contact must also stand by rigid-block equilibrium under ``g_eff`` (:func:`_leaning`).

For a single block of half-width ``b`` (along the shake) with its centre of mass ``h`` above its
base, on a base of friction coefficient ``mu``, the two give the textbook thresholds: it slides
when ``a > mu g`` and tips when ``a > g b / h``, whichever is smaller first (it tips before it
slides when ``b / h < mu``). Meriam & Kraige, *Engineering Mechanics: Statics*, chapter 6 (dry
friction: "impending tipping or slipping" of a block under a horizontal force); Shenton, "Criteria
for initiation of slide, rock, and slide-rock rigid-body modes", J. Eng. Mech. 122(7), 1996, for
the same thresholds under a base acceleration.

The stack needs no engine to answer: the records as frozen (poses, main contact areas, supports)
are enough. Source: report 3.3.4-3.3.5 with a tilted gravity; the thresholds above.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np
import shapely
from shapely.geometry import LineString, Point
from shapely.geometry.base import BaseGeometry

from ._areas import ContactAreas
from ._equilibrium import LEVEL_TILT, ContactPolygon, RigidBlock, bare_contacts, connected_part, is_level, solve_equilibrium
from ._geometry import hull_xy
from ._graph import BrickState
from ._leaning import pair_friction
from ._load import Load, propagate
from ._stack import Record, Stack

#: The friction coefficients of a part's contacts are multiplied by this in
#: :func:`sliding_parts`: a part sliding on the ground needs exactly the ground's coefficient
#: there, and the same of each contact above of that coefficient (Coulomb's static friction
#: reaches its limit). The equilibrium program's pyramid reaches its cone along the shake
#: (:func:`stability.solve_equilibrium` with ``sideways``); what is left is the engine's tilt of
#: level faces (:data:`stability._equilibrium.LEVEL_TILT`, a sine of 1e-3), which moves what a
#: contact needs by about as much: the 4 stack of scenarios/four_stack_shake_above.yaml, settled
#: by pybullet, needs its contacts' friction times 1.0001 to 1.001.
ROOM = 1.0 + 2.0 * LEVEL_TILT


def withstands(stack: Stack, effective_gravity: Sequence[float], margin: float = 0.0) -> str | None:
    """Does the frozen stack stand pseudo-statically under ``effective_gravity`` (m/s^2, shape (3,),
    pointing down: gravity plus the inertial force of the base's acceleration, ``(-a_x, -a_y, -g)``
    for a base accelerating by ``(a_x, a_y)``)? None when it does; else why not, in words, naming
    the first brick that fails the tipping or the sliding test (in the order they froze): a brick
    with the load above it, each on its own, as report 3.3.4-3.3.5 asks it; a part that moves as
    one rigid body may still hold (:func:`sliding_parts`).

    Args:
        stack: the extension's bodies (only the frozen ones are asked).
        effective_gravity: shape (3,), m/s^2, with a downward vertical part.
        margin: metres the tilted line of action must lie inside the main contact area.

    Raises:
        ValueError: an effective gravity that does not point down.

    Source: see the module docstring (report 3.3.4-3.3.5; Meriam & Kraige, Statics, ch. 6).
    """
    gx, gy, gz = (float(v) for v in effective_gravity)
    if gz >= 0:
        raise ValueError(f"an effective gravity points down, not {gx, gy, gz}")
    g, sideways = -gz, math.hypot(gx, gy)
    frozen = stack.in_order()
    if not frozen or sideways == 0.0:
        return None
    loads = propagate(stack.nodes(frozen))
    tilt = np.array([gx, gy]) / g  # the line of action's horizontal run per metre of drop
    for rec in frozen:
        slides = next(
            (
                f"would slide on {stack.bodies[s].label}: a/g = {sideways / g:.3f} > friction {mu:.3f}"
                for s in rec.rests_on
                if sideways / g > (mu := pair_friction(rec.friction, stack.bodies[s].friction))
            ),
            None,
        )
        tips = None
        if (footing := _footing(rec, loads, margin)) is not None:
            region, centre, rise = footing
            x, y = centre + rise * tilt
            if not shapely.contains_xy(region, float(x), float(y)):
                limit = g * _run_inside(region, centre, tilt) / rise if rise > 0.0 else 0.0
                tips = (
                    f"fails the tipping test (report 3.3.5): under a = {sideways:.3g} m/s^2 its centre of mass above, "
                    f"{rise * 1000:.1f} mm high above its contact area, would act outside it (it holds up to "
                    f"{limit:.3g} m/s^2, {100.0 * (1.0 - limit / sideways):.1f}% under this)"
                )
        if slides and tips:  # past both thresholds: the slide-rock mode (Shenton 1996)
            return f"{rec.label} {tips}, and {slides}"
        if slides or tips:
            return f"{rec.label} {slides or tips}"
    return _leaning(stack, frozen, (gx, gy), g)


def shake_limit(stack: Stack, direction: Sequence[float], margin: float = 0.0) -> tuple[float, str] | None:
    """The least peak acceleration (m/s^2) of a ground shaking along ``direction`` (shape (2,),
    either way) under which a frozen brick fails the tipping or the sliding test of
    :func:`withstands`, and that brick and test in words (``"post tips"``, ``"b slides on
    ground"``); None with no frozen brick, or when a frozen contact is not level (rigid-block
    equilibrium decides there, :func:`_leaning`: no such bound). ``margin``: as
    :func:`withstands`'.

    Raises:
        ValueError: ``direction`` zero.

    Source: the tests of :func:`withstands` solved for the acceleration (module docstring: a
    block tips from ``g b / h`` and slides from ``mu g``).
    """
    length = math.hypot(*(float(v) for v in direction))
    if length == 0.0:
        raise ValueError("direction: a horizontal direction, not zero")
    unit = np.array([float(direction[0]), float(direction[1])]) / length
    frozen = stack.in_order()
    if not frozen:
        return None
    blocks = {r.body: RigidBlock(r.box.mass, stack.pose(r).position) for r in frozen}
    if not all(is_level(c) for c in stack.frozen_contacts(blocks)):
        return None
    g = stack.config.gravity
    loads = propagate(stack.nodes(frozen))
    least: tuple[float, str] | None = None
    for rec in frozen:
        limits = [
            (pair_friction(rec.friction, stack.bodies[s].friction) * g, f"{rec.label} slides on {stack.bodies[s].label}")
            for s in rec.rests_on
        ]
        if (footing := _footing(rec, loads, margin)) is not None and footing[2] > 0.0:
            region, centre, rise = footing
            run = min(_run_inside(region, centre, sign * unit) for sign in (1.0, -1.0))
            limits.append((g * run / rise, f"{rec.label} tips"))
        for limit in limits:
            if least is None or limit[0] < least[0]:
                least = limit
    return least


def _footing(rec: Record, loads: Mapping[int, Load], margin: float) -> tuple[BaseGeometry, np.ndarray, float] | None:
    """What the tipping test of ``rec`` asks (report 3.3.4-3.3.5): its main contact area less
    ``margin`` (m), the horizontal place of its centre of mass above (shape (2,), m) and how high
    that lies above the area (m); None without a main contact area or a load (``loads``:
    :func:`stability._load.propagate`'s)."""
    main, load = rec.main_contact, loads.get(rec.body)
    if main is None or load is None:
        return None
    region = main.polygon.buffer(-margin) if margin > 0 else main.polygon
    return region, np.asarray(load.com_above[:2], dtype=float), float(load.com_above[2]) - main.height


def _run_inside(region: BaseGeometry, point: np.ndarray, direction: np.ndarray) -> float:
    """Metres ``point`` (shape (2,)) may move along ``direction`` (shape (2,), not zero) before it
    leaves ``region`` (a shapely polygon); 0 when it lies outside already. The tipping test's
    line of action meets the contact area ``rise a / g`` along the tilt from the centre of mass
    above, so a brick holds up to ``a = g run / rise``.

    >>> from shapely.geometry import box
    >>> round(_run_inside(box(-0.004, -0.012, 0.004, 0.012), np.zeros(2), np.array([1.0, 0.0])), 6)
    0.004
    """
    x, y = (float(v) for v in point)
    if not shapely.contains_xy(region, x, y):
        return 0.0
    unit = direction / float(np.linalg.norm(direction))
    minx, miny, maxx, maxy = region.bounds
    far = math.hypot(maxx - minx, maxy - miny) + 1.0  # past the region, whatever its size
    crossings = region.boundary.intersection(LineString([(x, y), (x + far * unit[0], y + far * unit[1])]))
    return min((Point(x, y).distance(Point(c)) for c in shapely.get_coordinates(crossings)), default=0.0)


def _leaning(stack: Stack, frozen: list[Record], sideways: tuple[float, float], gravity: float) -> str | None:
    """Why the part of the frozen stack that holds a contact which is not level (a brick leaning
    on another, as the two legs of a card house's V do, or on a wall) would not stand under
    gravity tilted by ``sideways`` (m/s^2, (x, y): the effective gravity's horizontal part), or
    None: rigid-block equilibrium of that part (:func:`stability.solve_equilibrium` with
    ``sideways``). The tests of :func:`withstands` are exact on level contacts only: there the
    tilt asks each contact for ``a / g`` of its normal force, where a leaning contact already
    needs a share of its friction at rest, and the tilt adds to it on one side. A V of KAPLA
    legs at 24 deg, needing 91% of its friction at rest, was kept riding a table shaken at 1.26
    m/s^2, which felled it on both tuned engines.

    Each contact is its bare contact points here (:attr:`stability.ContactPolygon.core`), not the
    area padded around a line or a point for the report's centre-of-mass test (3.4.2): an edge
    meets a face along a line, and a line takes no moment about itself. With the padding (1 mm
    each side of the line where the two legs of a V meet) a V of KAPLA legs at 22 deg was held up
    to 0.273 m/s^2; on its bare contacts it holds up to 0.100, and the engines' settings felled it
    from 0.07 to 0.14 m/s^2 on, where the extension had kept it frozen to 0.25
    (docs/results/shake_leaning.py). Source: rigid-block equilibrium (Livesley 1978; Whiting et al.
    2009) under the module docstring's tilted gravity; the bare contacts as
    :mod:`stability._certificate` takes them for a margin."""
    blocks = {r.body: RigidBlock(r.box.mass, stack.pose(r).position) for r in frozen}
    contacts = stack.frozen_contacts(blocks)
    steep = {b for c in contacts if not is_level(c) for b in (c.body, c.other) if b in blocks}
    if not steep:
        return None
    part, polygons = connected_part(blocks, contacts, steep)
    margin = stack.config.leaning_margin
    asked = (margin * sideways[0], margin * sideways[1])
    found = solve_equilibrium(part, bare_contacts(polygons), gravity=gravity, quick=False, sideways=asked)
    if found.stands:
        return None
    moved = [stack.bodies[b].label for b in stack.ordered(found.moving())]
    return (
        f"{', '.join(moved[:4])}{', ...' if len(moved) > 4 else ''} would move: under a = "
        f"{_asked(math.hypot(*sideways), margin)} rigid-block equilibrium of what leans fails by {found.tension:.3g} N"
    )


def _asked(acceleration: float, margin: float) -> str:
    """The acceleration (m/s^2) a part that leans was asked to stand under, in words: with its
    margin (:attr:`stability.StabilityConfig.leaning_margin`) when there is one."""
    if margin == 1.0:
        return f"{acceleration:.3g} m/s^2"
    return f"{margin:g} x {acceleration:.3g} m/s^2 (a margin for what leans)"


def sliding_parts(
    stack: Stack, areas: ContactAreas, acceleration: Sequence[float], ground: int
) -> list[tuple[list[int], str | None, float]]:
    """The frozen stack's parts on a shaking ``ground``, each with why it may not move as one
    rigid body (None when it may), for a shake of peak horizontal ``acceleration`` (m/s^2, shape
    (2,)), either way, and the most the ground accelerates it by (m/s^2, ``a_s`` below; 0 for a
    part that does not rest on the ground).

    A part is a set of frozen bricks connected by their contacts. The ground moves it by
    friction alone, so it accelerates by at most ``a_s = min(|a|, mu_0 g)``, ``mu_0`` the
    largest friction coefficient of its bricks on the ground: the ground carries it while its
    own acceleration is under that, and it slides on the ground otherwise. It moves as one rigid
    body when, in its own frame, rigid-block equilibrium holds every brick on its contacts under
    the weight and the inertial force of ``a_s`` either way (d'Alembert: gravity tilted to
    ``(-+a_s, -g)``; :func:`stability.solve_equilibrium` with ``sideways``;
    :attr:`stability.StabilityConfig.leaning_margin` times ``a_s`` for a part with a contact that
    is not level): no contact slips, opens or tips. Each contact's friction pyramid reaches its cone along the shake (:data:`ROOM`),
    since a sliding part loads the ground's contact, and every contact above of the same
    coefficient, at exactly its limit (Coulomb's law gives each layer the acceleration of the one
    under it); between its edges the pyramid lies inside the cone.
    Parts are in the order their first brick froze, each part's bricks too.

    Why not, in words: a part of one brick (it is simulated on its own), a brick touching a
    body of the environment other than ``ground`` (a fixture moves with the ground and would push
    the part), no brick on the ground, or the bricks equilibrium would move.

    Source: rigid-block equilibrium (report 3.4; Whiting et al. 2009) under the tilted gravity of
    this module's docstring; Shenton 1996 for the slide mode of a rigid block on a shaken base.
    stackdsl's own in applying it to a whole part.
    """
    ax, ay = (float(v) for v in acceleration)
    frozen = stack.in_order()
    linked: dict[int, set[int]] = {rec.body: set() for rec in frozen}
    for rec in frozen:
        for other in [*rec.rests_on, *(c.other for c in rec.contacts)]:
            if other in linked and other != rec.body:
                linked[rec.body].add(other)
                linked[other].add(rec.body)
    parts: list[tuple[list[int], str | None, float]] = []
    seen: set[int] = set()
    for rec in frozen:
        if rec.body in seen:
            continue
        part, todo = {rec.body}, [rec.body]
        while todo:
            for other in linked[todo.pop()] - part:
                part.add(other)
                todo.append(other)
        seen |= part
        bricks = [r for r in frozen if r.body in part]
        parts.append(([r.body for r in bricks], *_why_not(stack, areas, bricks, stack.bodies[ground], (ax, ay))))
    return parts


def _why_not(
    stack: Stack, areas: ContactAreas, bricks: list[Record], floor: Record, acceleration: tuple[float, float]
) -> tuple[str | None, float]:
    """Why the part of ``bricks`` may not move as one rigid body on ``floor`` (see
    :func:`sliding_parts`), or None; and the most the floor accelerates it by (m/s^2)."""
    gravity = stack.config.gravity
    peak = math.hypot(*acceleration)
    on_floor = [pair_friction(r.friction, floor.friction) for r in bricks if floor.body in r.rests_on]
    carried = min(peak, max(on_floor) * gravity) if on_floor else 0.0  # the most the ground's friction accelerates it by
    if len(bricks) < 2:
        return f"{bricks[0].label} is a part of one brick", carried
    part = {r.body for r in bricks}
    touched = [(r, o) for r in bricks for o in [*r.rests_on, *(c.other for c in r.contacts)] if o not in part]
    fixture = next(((r, o) for r, o in touched if o != floor.body and stack.bodies[o].state is BrickState.GROUND), None)
    if fixture is not None:
        return f"{fixture[0].label} touches {stack.bodies[fixture[1]].label}, which the ground carries", carried
    if not on_floor:
        return f"{bricks[0].label}'s part does not rest on {floor.label}", carried
    ax, ay = (a * carried / peak for a in acceleration) if peak > 0.0 else (0.0, 0.0)
    polygons: list[ContactPolygon[int]] = [
        replace(c, friction=c.friction * ROOM)
        for c in areas.shaped([c for r in bricks for c in r.contacts if c.other in part or c.other == floor.body])
    ]
    blocks = {r.body: RigidBlock(r.box.mass, stack.pose(r).position) for r in bricks}
    tips = _tips_whole(blocks, [c for c in polygons if c.other == floor.body], (ax, ay), gravity)
    if tips is not None:  # a necessary condition, without the program: the part as one block
        return f"at {carried:.3g} m/s^2 {tips}", carried
    scale = stack.config.leaning_margin if any(not is_level(c) for c in polygons) else 1.0
    said = f"at {_asked(carried, scale)}"
    for sign in (1.0, -1.0):
        sideways = (-sign * scale * ax, -sign * scale * ay)
        found = solve_equilibrium(blocks, polygons, gravity=gravity, quick=False, sideways=sideways)
        if not found.stands:
            moved = [stack.bodies[b].label for b in stack.ordered(found.moving())]
            return (
                f"{said} rigid-block equilibrium fails by {found.tension:.3g} N "
                f"({', '.join(moved[:4])}{', ...' if len(moved) > 4 else ''} would move)"
            ), carried
    return None, carried


def _tips_whole(
    blocks: dict[int, RigidBlock], on_floor: list[ContactPolygon[int]], sideways: tuple[float, float], gravity: float
) -> str | None:
    """Why the part of ``blocks`` would tip over as one block on its contacts with the floor
    (``on_floor``) under gravity tilted by ``sideways`` (m/s^2) either way, or None: its centre of
    mass, carried along the tilted line of action down to the floor's plane, must lie inside the
    convex hull of those contacts (report 3.3.4 with a tilted gravity; module docstring). A part
    that fails this fails rigid-block equilibrium too, which is asked only of the others (the
    program of a 60-level tower took 1.4 s)."""
    if not on_floor:
        return "the part has no contact area on the floor"
    points = np.concatenate([np.asarray(c.points, dtype=float) for c in on_floor])
    masses = np.array([b.mass for b in blocks.values()])
    centre = masses @ np.array([b.com for b in blocks.values()]) / masses.sum()
    height = float(centre[2] - points[:, 2].mean())
    hull = hull_xy(points[:, :2])
    for sign in (1.0, -1.0):
        x, y = centre[:2] + sign * np.asarray(sideways) * height / gravity
        if not shapely.contains_xy(hull, float(x), float(y)):
            return f"the part tips over as one block: its centre of mass, {height * 1000:.0f} mm up, acts outside its footing"
    return None

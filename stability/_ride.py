"""A ride that tilts: frozen bricks merged into one body, kept merged while they are proved rigid.

Frozen bricks above a pulled brick ride it merged into one body in the engine
(:meth:`stability.StabilityExtension.guide`). The engine still simulates the ride's contacts with
the bricks that carry it; the extension asks, each step, whether the bricks inside it would stay
as they froze. While the gravity they feel tilts at most :data:`RIDE_TILT` they ride as they
froze. A ride that tilts further (the top of a Jenga tower, left on one block at its edge, tips
over it for a second and more before it falls) stays one body while the report's tests hold each
of its bricks on the riders under it with that gravity (:func:`holds_tilted`): no contact inside
it then slips or tips.

The gravity a ride's bricks feel (:func:`felt_gravity`) is gravity less the ride's acceleration
(d'Alembert), turned into the frame they froze in, and tilted further by the angle of the most
its spin (``w``) and its angular acceleration about a horizontal axis (``alpha``) add at any of
its points, ``(w^2 + alpha) span``; its angular acceleration about the vertical (a side pull
twists the level it drags) is a swirl, asked of friction alone. A proof holds within
:data:`SPREAD` of the direction the gravity felt tilts in, for :data:`AHEAD` times the tilt it was
asked at (the tilt grows: a proof a few times, not one a step).

The ride ends, and its bricks wake where it took them (:meth:`stability.Stack.end_ride`), when a
proof fails, when the gravity felt tilts :data:`MOST_TILT` or more (a ride falling freely feels
none: 90 degrees), or when it comes within the extension's touching distance of a body it did
not touch when it began (what it hits may part it). Measured on ``scenarios/jenga_falls.yaml``
in docs/results/actions-freeze.md, "The top of a tower tipping off its last block". A ride of a
shaken ground keeps the simpler rule of :meth:`stability.StabilityExtension._rides`: it ends
once it tilts :data:`RIDE_TILT` or its centre of mass drops :data:`RIDE_DROP`.

Source: the report's tipping and sliding tests (3.3.4-3.3.5) under a tilted gravity, as
:mod:`stability._shake` asks them of a shaken stack; stackdsl's own in applying them to a moving
body.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace

import numpy as np
import shapely

from ._equilibrium import ContactPolygon, RigidBlock, balanced_tilted, bare_contacts
from ._gap import Gap
from ._geometry import Box, Pose, hull_xy
from ._leaning import pair_friction
from ._load import Load, propagate
from ._lp import WarmStart
from ._stack import Stack

#: Degrees the gravity a pull's riders feel may tilt from how they froze before a proof is asked
#: (:func:`holds_tilted`): within it they ride as they froze. Turning about the vertical is not
#: tilt. A shaken ground's ride ends past it.
RIDE_TILT = 0.5
#: Metres the centre of mass of a shaken ground's riders may drop (the ground's edge gone from
#: under them: they fall).
RIDE_DROP = 0.001
#: A tilted ride is proved for this many times its tilt (its tilt grows: one proof, not one a step).
AHEAD = 2.0
#: Degrees past which no tilted ride is proved: it is falling over.
MOST_TILT = 45.0
#: Degrees either side of the direction the gravity felt tilts in that a proof covers.
SPREAD = 30.0
#: Seconds over which a tilted ride's accelerations are taken (:func:`felt_gravity`).
WINDOW = 0.05
#: Directions, evenly spread, towards which tied riders are proved to stand (:func:`tied_tilt`).
TIED_DIRECTIONS = 6
#: Share of their least friction coefficient that tied riders are first asked to stand tilted
#: by (:func:`tied_tilt`): just short of where they slide (an engine's contact normals lean by up
#: to a thousandth: a Jenga tower's top, friction 0.4, holds 0.3999).
TIED_SHARE = 0.98
#: Halvings of the tilt asked of tied riders that do not stand at :data:`TIED_SHARE` of their
#: friction: the tilt found is within 1/8 of that of the most they stand.
TIED_HALVINGS = 3
#: How a failed proof of a tilted ride begins, in words (:func:`holds_tilted`).
FELT = "its bricks feel gravity tilted {tilt:.2f} deg (gravity less the ride's acceleration)"


@dataclass
class RideLimit:
    """What a ride has been proved for: up to ``bound`` degrees of tilt of the gravity its bricks
    feel, within :data:`SPREAD` of ``direction`` (shape (2,), the horizontal part of that gravity
    in the frame the riders froze in; zero: any, within :data:`RIDE_TILT`), and up to ``swirl``
    (a tangent: :func:`felt_gravity`) of turning about the vertical; ``touching``, the
    bodies it touched when it began; ``span``, ``across`` and ``rise`` (:func:`arms_of`, m); its
    first rider's ``velocity`` (m/s) and ``spin`` (rad/s),
    shape (3,) each, as read at ``when`` (s), the start of the window its accelerations are taken
    over; and those accelerations, ``accel`` (m/s^2, shape (3,)) and ``turn`` (rad/s^2), over the
    last window. Source: stackdsl's own."""

    bound: float
    direction: np.ndarray
    swirl: float
    touching: frozenset[int]
    span: float  # m from its first rider's centre to the farthest corner of any rider, as they froze
    across: float  # m, the same measured across (horizontally)
    rise: float  # m, the same measured up or down
    velocity: np.ndarray
    spin: np.ndarray
    when: float
    accel: np.ndarray = field(default_factory=lambda: np.zeros(3))
    turn: np.ndarray = field(default_factory=lambda: np.zeros(3))
    others: tuple[object, list[int]] = field(default_factory=lambda: ((), []))  # the bodies it may come to touch, and what for
    gap: Gap | None = None  # its gap to the others, as last measured (:func:`stability._gap.near_within`)
    loads: dict[int, Load] | None = None  # its riders' loads as they froze (:func:`holds_tilted`), found once
    tied: float | None = None  # :func:`tied_tilt` of its riders, found when first asked

    def tied_tilt(self, stack: Stack, riders: tuple[int, ...]) -> float:
        """:func:`tied_tilt` of the ride's ``riders``, found the first time it is asked."""
        if self.tied is None:
            self.tied = tied_tilt(stack, riders)
        return self.tied

    def covers(self, needed: float, towards: np.ndarray, swirl: float) -> bool:
        """Whether gravity felt tilted ``needed`` degrees towards ``towards`` (shape (2,)), with a
        turn about the vertical of ``swirl`` (:func:`felt_gravity`), is within what was proved: a
        swirl up to the one proved, and a tilt of at most :data:`RIDE_TILT` in any direction, or
        at most ``bound`` within :data:`SPREAD` of ``direction``."""
        if swirl > self.swirl:
            return False
        if needed <= RIDE_TILT:
            return True
        across = float(np.linalg.norm(towards) * np.linalg.norm(self.direction))
        within = across > 0.0 and float(np.dot(towards, self.direction)) >= math.cos(math.radians(SPREAD)) * across
        return needed <= self.bound and within


def felt_gravity(
    limit: RideLimit, now: Pose, then: Pose, velocity: np.ndarray, spin: np.ndarray, time: float, gravity: float
) -> tuple[float, np.ndarray, float]:
    """The tilt (degrees) a ride's proof must cover now, the direction it tilts in (shape (2,),
    the horizontal part of the gravity felt in the frame the riders froze in), and its swirl (a
    tangent: the most its angular acceleration about the vertical adds to any point's horizontal
    acceleration, over the gravity felt); from its first rider's pose ``now`` (frozen at
    ``then``), ``velocity`` and ``spin`` read at ``time``, the accelerations over the last
    :data:`WINDOW` (``limit`` keeps them, with the ride's arms) and ``gravity`` (m/s^2).

    The bricks of a body accelerating by ``a`` feel gravity minus ``a`` (d'Alembert): the first
    rider's acceleration, turned into the frozen frame, tilts it; a point ``r`` from the first
    rider's centre accelerates by ``alpha x r + w x (w x r)`` more, at most ``(w^2 + alpha)
    span`` (:attr:`RideLimit.span`, the farthest corner), added as the angle it makes against
    the gravity felt (along the direction of the tilt: a margin for what an engine's contacts
    leave of the spin, not a direction of its own). Turning about the vertical tilts nothing: a
    side pull's twist spins a Jenga tower's top up to 0.5 rad/s in 30 ms (12 rad/s^2); what its
    angular acceleration about the vertical adds, ``alpha_z`` times the farthest horizontal
    distance from the first rider's centre (``across + rise sin(tilt)``, the riders tilted from
    how they froze), is the swirl, which the proof asks of friction alone (:func:`holds_tilted`).
    Accelerations are taken over :data:`WINDOW`: an engine's contacts shake a body resting on
    others by a few rad/s^2 from one step to the next (20 rad/s^2 and 1 m/s^2 on a Jenga tower's
    tipping top in pybullet), which moves nothing. A ride falling freely feels no gravity: its
    tilt is then 90 degrees (nothing is proved for it). Source: stackdsl's own (module docstring).
    """
    if time - limit.when >= WINDOW - 1e-9:
        step = time - limit.when
        limit.accel = (velocity - limit.velocity) / step
        limit.turn = (spin - limit.spin) / step
        limit.velocity, limit.spin, limit.when = velocity, spin, time
    turned = now.rotation @ then.rotation.T
    felt = turned.T @ (np.array([0.0, 0.0, -gravity]) - limit.accel)  # in the frozen frame
    size = float(np.linalg.norm(felt))
    if size < 1e-9 or felt[2] >= 0.0:
        return 90.0, felt[:2].copy(), 0.0
    tilt = math.degrees(math.acos(min(1.0, -float(felt[2]) / size)))
    tipping = float(np.hypot(limit.turn[0], limit.turn[1]))  # about a horizontal axis: turning about the vertical is no tilt
    uneven = (float(np.dot(spin, spin)) + tipping) * limit.span
    across = limit.across + limit.rise * math.sqrt(max(0.0, 1.0 - float(turned[2, 2]) ** 2))  # tilted: rise turns across
    swirl = abs(float(limit.turn[2])) * across / size
    return tilt + math.degrees(math.atan(uneven / size)), felt[:2].copy(), swirl


def tilt_of(now: Pose, then: Pose) -> tuple[float, np.ndarray]:
    """Degrees a body has tilted from ``then`` to ``now`` (turning about the vertical is not
    tilt), and the horizontal part of gravity's direction in its frame as it was ``then`` (shape
    (2,), zero when upright).

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> q = Rotation.from_euler("y", 10, degrees=True).as_quat()
    >>> tilt, towards = tilt_of(Pose(np.zeros(3), q), Pose(np.zeros(3), np.array([0.0, 0, 0, 1])))
    >>> round(tilt, 6), np.round(towards / np.linalg.norm(towards), 6).tolist()
    (10.0, [1.0, 0.0])
    """
    turned = now.rotation @ then.rotation.T  # the rotation since it froze, in the world
    down = turned.T @ np.array([0.0, 0.0, -1.0])  # gravity's direction in the frozen frame
    tilt = math.degrees(math.acos(min(1.0, max(-1.0, -float(down[2])))))
    return tilt, down[:2].copy()


def frozen_centre(stack: Stack, riders: tuple[int, ...]) -> np.ndarray:
    """The centre of mass of the frozen ``riders`` as they froze, shape (3,), m. Source:
    stackdsl's own."""
    recs = [stack.bodies[b] for b in riders]
    masses = np.array([r.box.mass for r in recs])
    centre: np.ndarray = masses @ np.array([r.frozen_pose.position for r in recs if r.frozen_pose is not None]) / masses.sum()
    return centre


@dataclass(frozen=True)
class ShakenRide:
    """How the riders of a shaken ground froze, as a shaken ride's per-step rule asks it
    (:meth:`stability.StabilityExtension._rides`: it ends once they tilt :data:`RIDE_TILT` or their
    centre of mass drops :data:`RIDE_DROP`), found once a ride: ``riders`` (ids, the first the one
    whose pose is read) and ``frozen``, the first's pose as it froze; ``up``, the world's vertical
    in that frame (the third row of its rotation matrix), ``arm``, the riders' centre of mass from
    the first rider in that frame (m), and ``height``, the centre of mass's height as they froze
    (m). Source: stackdsl's own.

    >>> upright = Pose(np.array([0.0, 0.0, 0.004]), np.array([0.0, 0.0, 0.0, 1.0]))
    >>> ride = ShakenRide((1, 2), upright, (0.0, 0.0, 1.0), (0.0, 0.0, 0.05), 0.054)
    >>> tilt, drop = ride.tilt_and_drop((0.0, 0.0, 0.004), (0.0, math.sin(math.radians(5)), 0.0, math.cos(math.radians(5))))
    >>> round(tilt, 9), round(drop * 1000, 6)  # turned 10 degrees about y: tilted 10, the centre 0.76 mm lower
    (10.0, 0.759612)
    """

    riders: tuple[int, ...]
    frozen: Pose
    up: tuple[float, float, float]
    arm: tuple[float, float, float]
    height: float

    @classmethod
    def of(cls, stack: Stack, riders: tuple[int, ...]) -> ShakenRide:
        """The ride of frozen ``riders`` of ``stack``, as they froze."""
        first = stack.bodies[riders[0]].frozen_pose
        assert first is not None, "a rider is frozen"
        centre = frozen_centre(stack, riders)
        ux, uy, uz = first.rotation[2].tolist()
        ax, ay, az = (first.rotation.T @ (centre - first.position)).tolist()
        return cls(riders, first, (ux, uy, uz), (ax, ay, az), float(centre[2]))

    def tilt_and_drop(
        self, position: tuple[float, float, float], orientation: tuple[float, float, float, float]
    ) -> tuple[float, float]:
        """Degrees the riders have tilted from how they froze (turning about the vertical is not
        tilt; :func:`tilt_of`), and metres their centre of mass has dropped, the first rider now
        at ``position`` turned by ``orientation`` (a quaternion x, y, z, w): they move as one
        body. In floats (the third row of the rotation matrix of :attr:`Pose.rotation`'s formula);
        the shaken ride asks it every step."""
        x, y, z, w = orientation
        n = 2.0 / (x * x + y * y + z * z + w * w)
        r0, r1, r2 = n * (x * z - y * w), n * (y * z + x * w), 1.0 - n * (x * x + y * y)
        ux, uy, uz = self.up
        ax, ay, az = self.arm
        tilt = math.degrees(math.acos(min(1.0, max(-1.0, ux * r0 + uy * r1 + uz * r2))))
        return tilt, self.height - (r0 * ax + r1 * ay + r2 * az + position[2])


def arms_of(first: Pose, boxes: Iterable[tuple[Box, Pose]]) -> tuple[float, float, float]:
    """Metres from ``first`` (a ride's first rider's pose) to the farthest corner of any of
    ``boxes`` (each a box and its pose; a ride's riders as they froze): straight, across
    (horizontally) and up or down, each its own farthest. Source: stackdsl's own.

    >>> brick = Box(np.array([0.06, 0.012, 0.004]), 0.01)
    >>> low, high = Pose(np.array([0.0, 0.0, 0.004])), Pose(np.array([0.0, 0.0, 0.012]))
    >>> [round(v * 1000, 3) for v in arms_of(low, [(brick, low), (brick, high)])]  # one flat on the other
    [62.354, 61.188, 12.0]
    """
    offsets = np.concatenate([box.corners(pose) for box, pose in boxes]) - first.position
    return (
        float(np.linalg.norm(offsets, axis=1).max()),
        float(np.hypot(offsets[:, 0], offsets[:, 1]).max()),
        float(np.abs(offsets[:, 2]).max()),
    )


def holds_tilted(
    stack: Stack,
    riders: tuple[int, ...],
    tilt: float,
    towards: np.ndarray,
    swirl: float = 0.0,
    loads: Mapping[int, Load] | None = None,
    tied: Callable[[], float] | None = None,
) -> str | None:
    """Does each of the frozen ``riders`` that rests on riders alone stay where it froze on them
    under gravity tilted by up to ``tilt`` degrees within :data:`SPREAD` of ``towards`` (shape
    (2,), the horizontal part of gravity's direction in their frozen frame), and a horizontal
    acceleration in any direction of up to ``swirl`` times that gravity (a turn about the
    vertical)? None when it does; else why not, in words, naming the first that would slide or
    tip. ``loads``: what :func:`stability._load.propagate` gives the riders as they froze, when
    found already (a ride is proved many times; its riders do not change while it lasts).
    ``tied``: gives :func:`tied_tilt` of the riders, when the caller keeps it; asked only when a
    brick fails the tipping test alone.

    The report's tests with the tilted gravity (as :func:`stability._shake.withstands` asks them
    of a shaken stack), at the cone's two edges pushed out by ``1 / cos(SPREAD)`` (with upright,
    where they froze, they span the cone): under a uniform tilt every contact carries a
    tangential force ``tan(tilt)`` times its normal force, which holds while that is at most the
    pair's friction coefficient (Coulomb), with ``swirl`` added; and the resultant of a brick and what it carries,
    through its centre of mass above (report 3.3.5), meets its main contact area's plane
    ``rise tan(tilt)`` away from where it acts upright, against the tilt: that point must lie
    inside the area less the stability model's margin (report 3.3.4). A brick that fails that
    test alone may still be held by the levels that cross it: the riders then hold when, tied
    to each other, they are proved to stand under the tilt in every direction (:func:`tied_tilt`).
    The swirl is asked of friction alone: a turn about the vertical twists a level tied by the
    levels above and below it, which no block of it tips under alone (the report's test would
    charge each block with the sideways load of everything above it). A rider resting on a brick
    that is not a rider rests on a body the engine moves: the engine simulates that contact.

    Raises:
        ValueError: ``tilt`` not in [0, 90) degrees, ``towards`` zero, or ``swirl`` negative.

    Source: report 3.3.4-3.3.5 under a tilted gravity (module docstring; Meriam & Kraige,
    Statics, ch. 6, for the slide and tip thresholds of a block).
    """
    if not 0.0 <= tilt < 90.0:
        raise ValueError(f"tilt: degrees in [0, 90), not {tilt!r}")
    length = float(np.linalg.norm(towards))
    if length == 0.0:
        raise ValueError("towards: a direction, not zero")
    if not swirl >= 0.0:
        raise ValueError(f"swirl: a tangent >= 0, not {swirl!r}")
    run = math.tan(math.radians(tilt)) / math.cos(math.radians(SPREAD))
    ux, uy = (float(v) / length for v in towards)
    edges = []
    for side in (-1.0, 1.0):
        c, s = math.cos(math.radians(side * SPREAD)), math.sin(math.radians(side * SPREAD))
        edges.append((run * (ux * c - uy * s), run * (ux * s + uy * c)))
    part = set(riders)
    recs = [stack.bodies[b] for b in riders]
    if loads is None:
        loads = propagate(stack.nodes(recs))
    margin = stack.config.com_margin
    tips: str | None = None
    for rec in recs:
        if not rec.rests_on or not set(rec.rests_on) <= part:
            continue
        for support in rec.rests_on:
            mu = pair_friction(rec.friction, stack.bodies[support].friction)
            if run + swirl > mu:
                twist = f" and {swirl:.3f} more for its twist" if swirl > 0.0 else ""
                return (
                    f"{FELT.format(tilt=tilt)}, and {rec.label} slides on {stack.bodies[support].label}: it needs "
                    f"{run:.3f} of friction{twist}, and the pair has {mu:.3f}"
                )
        main, load = rec.main_contact, loads.get(rec.body)
        if tips is not None or main is None or load is None:
            continue
        rise = float(load.com_above[2]) - main.height
        region = main.polygon.buffer(-margin) if margin > 0 else main.polygon
        x, y = (float(v) for v in load.com_above[:2])
        if not all(shapely.contains_xy(region, x + rise * ex, y + rise * ey) for ex, ey in edges):
            tips = (
                f"{FELT.format(tilt=tilt)}, and {rec.label} tips: the centre of mass of it and what it carries, "
                f"{rise * 1000:.1f} mm above its contact area, acts outside it"
            )
    if tips is None:
        return None
    most = tied() if tied is not None else tied_tilt(stack, riders)
    if math.tan(math.radians(tilt)) <= most:
        return None
    return (
        f"{tips}; tied to each other by the levels they cross, the riders are proved to stand up to "
        f"{math.degrees(math.atan(most)):.2f} deg of tilt in every direction"
    )


def tied_tilt(stack: Stack, riders: tuple[int, ...]) -> float:
    """The tangent of a tilt of gravity under which, in every direction, the frozen ``riders``
    that rest on riders alone are proved to stand on each other, those that rest on anything
    else held as the ride moves them; 0 when none is.

    The report's tipping test (3.3.4-3.3.5) charges each brick alone with the centre of mass of
    everything it carries: a Jenga level's side block carries 90 mm of the levels above it on
    its 25 mm width, and fails at a tilt of 8 deg, though the levels above, crossing it, tie it
    to its neighbours, and the block they make together tips only past 22 deg (two engines' tuned
    settings, every brick free, keep those bricks within 0.03 deg of each other while a pull tips
    them 8 deg: docs/actions.md).
    Rigid-block equilibrium asks what ties them: compressive forces at the contacts among the
    riders, parallel to the tilted gravity and inside each pair's friction cone, that balance
    every free rider (:func:`stability._equilibrium.balanced_tilted`). Asked with gravity tilted
    by ``t`` towards :data:`TIED_DIRECTIONS` directions evenly spread, ``t`` first
    :data:`TIED_SHARE` of the least friction coefficient of their contacts (where the report's
    sliding test stops), then by :data:`TIED_HALVINGS` halvings of the interval left: the loads
    they stand under are a convex set (forces inside friction cones, added, stay inside them), so
    what holds towards all of them holds ``t cos(pi / TIED_DIRECTIONS)`` in every direction. A
    contact with a body outside the ride carries nothing here, and a padded contact is its bare
    points (:func:`stability._equilibrium.bare_contacts`: a line takes no moment about itself),
    both on the side of caution; with the stability model's margin
    (:attr:`stability.StabilityConfig.com_margin`), each contact is its area less that margin, as
    the report's tipping test takes it. A ride's riders do not change while it lasts: it is found
    once a ride (:attr:`RideLimit.tied`), its programs each started from the last one's basis
    (:class:`stability.WarmStart`: a 30-level tower's 9 programs took 163 ms from scratch).

    Source: rigid-block equilibrium (Livesley 1978; Whiting et al. 2009) under the tilted
    gravity of :mod:`stability._shake`; stackdsl's own in asking it of a ride's riders.
    """
    part = set(riders)
    recs = [stack.bodies[b] for b in riders]
    blocks = {
        r.body: RigidBlock(r.box.mass, r.frozen_pose.position)
        for r in recs
        if r.rests_on and set(r.rests_on) <= part and r.frozen_pose is not None
    }
    contacts = bare_contacts([c for r in recs for c in r.contacts if c.other in part and (c.body in blocks or c.other in blocks)])
    margin = stack.config.com_margin
    if margin > 0.0:
        contacts = [inset for c in contacts if (inset := _inset(c, margin)) is not None]
    if not blocks or not contacts:
        return 0.0
    least = min(c.friction for c in contacts)
    turns = [2.0 * math.pi * k / TIED_DIRECTIONS for k in range(TIED_DIRECTIONS)]
    gravity, warm = stack.config.gravity, WarmStart()  # each program starts where the last ended

    def stands(t: float) -> bool:
        return all(balanced_tilted(blocks, contacts, (t * math.cos(a), t * math.sin(a)), gravity, warm) for a in turns)

    low, high = 0.0, TIED_SHARE * least
    if stands(high):
        low = high
    else:
        for _ in range(TIED_HALVINGS):
            middle = (low + high) / 2.0
            low, high = (middle, high) if stands(middle) else (low, middle)
    return low * math.cos(math.pi / TIED_DIRECTIONS)


def _inset(contact: ContactPolygon[int], margin: float) -> ContactPolygon[int] | None:
    """``contact`` with its area, seen from above, less ``margin`` (m) all round, at its mean
    height; None when nothing is left of it (a line or a point has no area to keep)."""
    points = np.asarray(contact.points, dtype=float).reshape(-1, 3)
    area = hull_xy(points[:, :2]).buffer(-margin)
    if area.is_empty or area.geom_type != "Polygon":
        return None
    corners = np.asarray(area.exterior.coords)[:-1]
    height = np.full((len(corners), 1), float(points[:, 2].mean()))
    return replace(contact, points=np.hstack([corners, height]))

"""Bodies, poses and contact areas: the geometry of report section 3.3.3.

All lengths are metres, all areas square metres, quaternions are ``(x, y, z, w)``
(pybullet's order). Polygons are shapely polygons in the horizontal (x, y) plane:
the report projects contact areas on the ground plane ("a ray cast from the
objects centre of mass straight down", 3.3.4), so stability only needs their
horizontal projection plus a height.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from typing import Any, TypeVar, overload

import numpy as np
import numpy.typing as npt
import shapely
from scipy.spatial.transform import Rotation
from shapely.geometry import LineString, MultiPoint, Point, Polygon
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient

_T = TypeVar("_T")


class _cached(cached_property[_T]):
    """``functools.cached_property`` without its lock (Python 3.11 takes one at every first read):
    asked once of each pose, face and contact area, some thousand times in a run of a 30-level
    tower. Its functions are pure, so two threads that both find nothing cached compute the same
    value. Python finds a value cached in the instance's ``__dict__`` without calling this."""

    @overload
    def __get__(self, instance: None, owner: type[Any] | None = None) -> _cached[_T]: ...
    @overload
    def __get__(self, instance: object, owner: type[Any] | None = None) -> _T: ...
    def __get__(self, instance: object | None, owner: type[Any] | None = None) -> _T | _cached[_T]:
        if instance is None:
            return self
        if self.attrname is None:
            raise TypeError("Cannot use a cached property instance without calling __set_name__ on it.")
        value = instance.__dict__[self.attrname] = self.func(instance)
        return value


UP = np.array([0.0, 0.0, 1.0])
_CORNER_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


@lru_cache(maxsize=256)
def _quaternion(yaw: float, pitch: float, roll: float, signs: tuple[float, ...]) -> tuple[float, ...]:
    """The unit quaternion (x, y, z, w) of yaw/pitch/roll in degrees (z, y, x intrinsic), by scipy's
    ``Rotation``, once for each angle triple: a scene places many bricks at a few turns (each
    ``Rotation.from_euler`` costs about 40 us). ``signs``: the angles' signs, so that -0.0 and 0.0,
    equal as keys, keep quaternions whose zeros may differ in sign."""
    return tuple(float(c) for c in Rotation.from_euler("ZYX", [yaw, pitch, roll], degrees=True).as_quat())


def corners_of(half_extents: np.ndarray, positions: np.ndarray, quaternions: np.ndarray) -> np.ndarray:
    """The eight corners of n boxes in the world frame, shape (n, 8, 3), metres, in the order of
    :meth:`Box.corners`: half extents (n, 3) in m, positions (n, 3) in m and unit quaternions
    (x, y, z, w), (n, 4), as :meth:`Engine.poses_of <stability.Engine.poses_of>` reads them;
    rotation matrices by scipy's ``Rotation``. Source: stackdsl's own.

    >>> turned = corners_of(np.array([[0.06, 0.012, 0.004]]), np.zeros((1, 3)), np.array([[0, 0, 0.7071068, 0.7071068]]))
    >>> turned[0, -1].round(4).tolist()  # the corner (+x, +y, +z) of a brick turned 90 degrees about z
    [-0.012, 0.06, 0.004]
    """
    rotations = Rotation.from_quat(quaternions).as_matrix()
    local = _CORNER_SIGNS * np.asarray(half_extents, dtype=float)[:, None, :]
    corners: np.ndarray = np.asarray(positions, dtype=float)[:, None, :] + np.einsum("nkj,nij->nki", local, rotations)
    return corners


def box_bounds(
    half_extents: np.ndarray | Sequence[float], position: Sequence[float], quaternion: Sequence[float]
) -> tuple[list[float], list[float]]:
    """The lowest and highest corners (x, y, z, m) of the axis-aligned bounding box of a box of
    ``half_extents`` (m) at ``position`` (m) turned by the unit quaternion ``quaternion`` (x, y, z,
    w), in floats: its half width along each world axis is ``|R| h``, ``R`` the rotation matrix by
    the formula :attr:`Pose.rotation` writes out. The impact rule bounds one or two bodies a step
    with it: about 4 us a body, where scipy's ``Rotation`` for the corners (:func:`corners_of`)
    takes about 25 us a call for one or two, most of it fixed. The least and greatest of
    :func:`corners_of` but for round-off. Source: stackdsl's own.

    >>> low, high = box_bounds([0.06, 0.012, 0.004], [0.0, 0.0, 0.0], [0.0, 0.0, 0.7071068, 0.7071068])
    >>> [round(v, 4) for v in high]  # a brick turned 90 degrees about z: 12 mm along x, 60 mm along y
    [0.012, 0.06, 0.004]
    """
    a, b, c = half_extents.tolist() if isinstance(half_extents, np.ndarray) else (float(v) for v in half_extents)
    x, y, z, w = (float(v) for v in quaternion)
    n = 2.0 / (x * x + y * y + z * z + w * w)
    half = (
        abs(1 - n * (y * y + z * z)) * a + abs(n * (x * y - z * w)) * b + abs(n * (x * z + y * w)) * c,
        abs(n * (x * y + z * w)) * a + abs(1 - n * (x * x + z * z)) * b + abs(n * (y * z - x * w)) * c,
        abs(n * (x * z - y * w)) * a + abs(n * (y * z + x * w)) * b + abs(1 - n * (x * x + y * y)) * c,
    )
    centre = [float(v) for v in position]
    return [p - h for p, h in zip(centre, half, strict=True)], [p + h for p, h in zip(centre, half, strict=True)]


def turn_between(a: npt.ArrayLike, b: npt.ArrayLike) -> float:
    """Radians of the rotation from orientation ``a`` to ``b`` (quaternions x, y, z, w, shape (4,),
    of any non-zero length): no point of a body turned so about its centre moves more than this
    times its distance from the centre. Source: stackdsl's own.

    >>> round(turn_between([0, 0, 0, 1], [0, 0, math.sin(0.05), math.cos(0.05)]), 6)  # 0.1 rad about z
    0.1
    """
    p, q = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    p, q = p / math.sqrt(float(p @ p)), q / math.sqrt(float(q @ q))
    chord = min(float(np.linalg.norm(p - q)), float(np.linalg.norm(p + q)))
    return 4.0 * math.asin(min(1.0, chord / 2.0))


def moved_at_most(
    position: Sequence[float], turn: Sequence[float], position1: Sequence[float], turn1: Sequence[float], reach: float
) -> float:
    """A bound (m) on how far any point within ``reach`` m of a body's centre moves when the body
    goes from ``position``, ``turn`` to ``position1``, ``turn1`` (m, and unit quaternions x, y, z,
    w): the centre's shift plus the turn's angle (:func:`turn_between`) times ``reach``, in floats
    for the few bodies of a step (the impact rule and the watch of a leaned-on brick ask it of
    each every step, and numpy's fixed costs would be most of it). The angle's acos near 1 is off
    by some 1e-8 rad: a caller comparing the bound with a distance leaves a slack above that times
    ``reach``. Source: stackdsl's own.

    >>> round(moved_at_most((0, 0, 0), (0, 0, 0, 1), (0.003, 0.004, 0), (0, 0, math.sin(0.05), math.cos(0.05)), 0.06), 6)
    0.011
    """
    x, y, z = position
    a, b, c, d = turn
    x1, y1, z1 = position1
    a1, b1, c1, d1 = turn1
    dot = min(1.0, abs(a * a1 + b * b1 + c * c1 + d * d1))
    return math.sqrt((x1 - x) ** 2 + (y1 - y) ** 2 + (z1 - z) ** 2) + 2.0 * math.acos(dot) * reach


@dataclass(frozen=True)
class Pose:
    """A rigid-body pose.

    Attributes:
        position: shape (3,), metres, world frame.
        orientation: shape (4,), unit quaternion ``(x, y, z, w)`` (one of another non-zero
            length is normalised; one of zero length is refused, with a ValueError, where
            the rotation is first asked for: :attr:`rotation`. A pose is made for every body at
            every step, and checking there would cost more than using it).

    Source: stackdsl's own.

    >>> Pose.from_euler([0, 0, 0.004], yaw=90).rotation.round(6)[:, 0]
    array([0., 1., 0.])
    """

    position: np.ndarray
    orientation: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 1.0]))

    @classmethod
    def from_euler(cls, position: npt.ArrayLike, yaw: float = 0.0, pitch: float = 0.0, roll: float = 0.0) -> Pose:
        """Pose from a position (m) and yaw/pitch/roll in degrees (z, y, x intrinsic)."""
        angles = (float(yaw), float(pitch), float(roll))
        return cls(
            np.asarray(position, dtype=float), np.array(_quaternion(*angles, tuple(math.copysign(1.0, a) for a in angles)))
        )

    @_cached
    def rotation(self) -> np.ndarray:
        """Rotation matrix, shape (3, 3), read-only; column i is the body's axis i in the
        world. The standard unit-quaternion formula (as scipy's ``Rotation.as_matrix``),
        written out: the stability tests ask for it thousands of times a second (so the
        orientation is checked here, once, and not each time a pose is made).

        Raises:
            ValueError: the orientation is not 4 numbers (x, y, z, w) of non-zero, finite length.
        """
        orientation = self.orientation
        try:
            if type(orientation) is np.ndarray and orientation.shape == (4,) and orientation.dtype == np.float64:
                x, y, z, w = orientation.tolist()  # the same floats, without a numpy scalar each
            else:
                x, y, z, w = (float(c) for c in orientation)
        except (TypeError, ValueError):  # not four numbers
            raise ValueError(_no_rotation(self.orientation)) from None
        length = x * x + y * y + z * z + w * w
        if not 1e-12 < length < math.inf:
            raise ValueError(_no_rotation(self.orientation))
        n = 2.0 / length
        m = np.array(
            [
                [1 - n * (y * y + z * z), n * (x * y - z * w), n * (x * z + y * w)],
                [n * (x * y + z * w), 1 - n * (x * x + z * z), n * (y * z - x * w)],
                [n * (x * z - y * w), n * (y * z + x * w), 1 - n * (x * x + y * y)],
            ]
        )
        m.flags.writeable = False
        return m

    def euler_degrees(self) -> np.ndarray:
        """``(yaw, pitch, roll)`` in degrees, the inverse of :meth:`from_euler`. At a pitch of
        +-90 deg (a brick on end, a domino) yaw and roll are one turn; scipy then warns of the
        gimbal lock and sets roll to 0, which is still this pose.

        Raises:
            ValueError: the orientation is not 4 numbers (x, y, z, w) of non-zero, finite length.
        """
        _ = self.rotation  # its check of the orientation
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", "Gimbal lock detected", UserWarning)
            return np.asarray(Rotation.from_quat(self.orientation).as_euler("ZYX", degrees=True), dtype=float)


def _no_rotation(orientation: np.ndarray) -> str:
    """Why ``orientation`` is no pose's: the message of :attr:`Pose.rotation`'s ValueError."""
    return (
        f"Pose.orientation must be a quaternion (x, y, z, w) of non-zero, finite length, not {orientation!r}"
        " (no turn is (0, 0, 0, 1))"
    )


@dataclass(frozen=True)
class Box:
    """A uniform rectangular block: the only body shape stackdsl stacks.

    Attributes:
        half_extents: shape (3,), metres (a KAPLA brick is 0.06, 0.012, 0.004).
        mass: kilograms.

    Source: report 3.2 (KAPLA bricks, uniform mass distribution).

    Raises:
        ValueError: ``half_extents`` are not 3 finite positive lengths, or ``mass`` is not a
            finite positive number of kilograms.
    """

    half_extents: np.ndarray
    mass: float

    def __post_init__(self) -> None:
        half = self.half_extents  # checked in plain floats: numpy's checks cost ten times as much
        x, y, z = np.asarray(half, dtype=float).tolist() if np.shape(half) == (3,) else (math.nan,) * 3
        if not (0.0 < x < math.inf and 0.0 < y < math.inf and 0.0 < z < math.inf):
            raise ValueError(f"Box.half_extents must be 3 finite positive lengths in metres, not {self.half_extents!r}")
        if not 0.0 < self.mass < math.inf:
            raise ValueError(f"Box.mass must be a finite positive number of kg, not {self.mass!r}")

    @_cached
    def half_diagonal(self) -> float:
        """Metres from the centre to a corner: no point of the box is farther from its centre."""
        return float(np.linalg.norm(self.half_extents))

    @_cached
    def largest_moment(self) -> float:
        """kg m^2: the largest principal moment of inertia about the centre of mass,
        ``m (a^2 + b^2) / 3`` of the two largest half extents ``a`` and ``b``.

        >>> round(Box(np.array([0.06, 0.012, 0.004]), 0.0106).largest_moment, 10)
        1.32288e-05
        """
        a, b = sorted(self.half_extents.tolist())[1:]
        return float(self.mass * (a * a + b * b) / 3.0)

    def corners(self, pose: Pose) -> np.ndarray:
        """The eight corners in the world frame, shape (8, 3), metres."""
        corners: np.ndarray = pose.position + (_CORNER_SIGNS * self.half_extents) @ pose.rotation.T
        return corners

    def meets_path(self, pose: Pose, start: np.ndarray, travel: np.ndarray, grow: float = 0.0) -> bool:
        """Does a point moving in a straight line from ``start`` by ``travel`` (m, shape (3,) each,
        world frame) enter this box at ``pose``, grown by ``grow`` m on every side? The slab test,
        in the box's frame (Kay and Kajiya, "Ray tracing complex scenes", SIGGRAPH 1986).

        >>> brick = Box(np.array([0.06, 0.012, 0.004]), 0.0106)
        >>> at = Pose.from_euler([0.0, 0.0, 0.004])
        >>> brick.meets_path(at, np.array([-0.1, 0.0, 0.004]), np.array([0.05, 0.0, 0.0]))
        True
        >>> brick.meets_path(at, np.array([-0.1, 0.0, 0.02]), np.array([0.2, 0.0, 0.0]), grow=0.001)
        False
        """
        rotation = pose.rotation
        here = (np.asarray(start, dtype=float) - pose.position) @ rotation
        way = np.asarray(travel, dtype=float) @ rotation
        enter, leave = 0.0, 1.0
        for p, v, h in zip(here.tolist(), way.tolist(), (self.half_extents + grow).tolist(), strict=True):
            if abs(v) < 1e-12:
                if abs(p) > h:
                    return False
                continue
            a, b = (-h - p) / v, (h - p) / v
            enter, leave = max(enter, min(a, b)), min(leave, max(a, b))
            if enter > leave:
                return False
        return True

    def face(self, pose: Pose, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The face whose outward normal is closest to ``direction``.

        Returns:
            ``(corners, normal)``: corners shape (4, 3) in order around the face,
            normal shape (3,), both world frame.
        """
        rot = pose.rotation
        dots = rot.T @ np.asarray(direction, dtype=float)
        axis = int(np.argmax(np.abs(dots)))
        sign = 1.0 if dots[axis] >= 0 else -1.0
        u, v = [i for i in range(3) if i != axis]
        centre = pose.position + sign * self.half_extents[axis] * rot[:, axis]
        eu = self.half_extents[u] * rot[:, u]
        ev = self.half_extents[v] * rot[:, v]
        corners = np.array([centre - eu - ev, centre + eu - ev, centre + eu + ev, centre - eu + ev])
        return corners, sign * rot[:, axis]


@dataclass(frozen=True)
class Plane:
    """An infinite horizontal ground plane at ``height`` metres. Source: stackdsl's own.

    Raises:
        ValueError: a ``height`` that is not a finite number.
    """

    height: float = 0.0

    def __post_init__(self) -> None:
        if not -math.inf < self.height < math.inf:
            raise ValueError(f"Plane.height must be a finite number of metres, not {self.height!r}")


@dataclass(frozen=True)
class ContactArea:
    """The area through which one body rests on another (report Figure 3, SingleContactArea).

    Attributes:
        polygon: horizontal projection of the area (shapely, metres); convex.
        height: mean height of the contact, metres.
        normal: shape (3,), unit normal pointing from the support into the supported body.
        exact: True when computed from the two touching faces, False when it is the
            convex hull of the engine's contact points (report 3.3.3).
        depth: metres the upper face lies below the lower one, mean over the area
            (positive where they overlap); exact areas only, else 0.

    Source: report 3.3.3; the exact face overlap is stackdsl's own (pybullet reports at
    most four points a pair).
    """

    polygon: Polygon
    height: float
    normal: np.ndarray
    exact: bool
    depth: float = 0.0

    @property
    def area(self) -> float:
        """Area of the horizontal projection, square metres."""
        return float(self.polygon.area)

    def corners(self) -> np.ndarray:
        """The area's vertices on the contact plane, shape (k, 3), metres: the projection's
        vertices at the heights of the plane through the mean height with ``normal`` (exact for
        a face overlap, whose height is the plane's mean over them). A brick lying on another
        at 40 degrees along its length has corners 38 mm above and below that mean height;
        the equilibrium program's torques need them where they are. Source: stackdsl's own.

        >>> from shapely.geometry import box
        >>> tilted = ContactArea(box(0, 0, 1, 1), 2.0, np.array([-0.6, 0.0, 0.8]), True)
        >>> tilted.corners()[:, 2].tolist()  # z rises by tan = 0.75 along x
        [2.375, 2.375, 1.625, 1.625]
        """
        ring = shapely.get_coordinates(self.polygon.exterior)[:-1]  # shapely's array: no coordinate objects
        # numpy's mean (its sum, divided) and column_stack (a concatenation), without their wrappers
        centre = np.add.reduce(ring, axis=0) / len(ring)
        heights = self.height - ((ring - centre) @ self.normal[:2]) / self.normal[2]
        return np.concatenate((ring, heights[:, None]), axis=1)

    @_cached
    def ring(self) -> tuple[tuple[float, float], ...]:
        """The polygon's vertices counter-clockwise, as floats (for fast point tests)."""
        return tuple((x, y) for x, y in shapely.get_coordinates(orient(self.polygon, 1.0).exterior)[:-1].tolist())

    def holds(self, x: float, y: float, strict: bool = True) -> bool:
        """Does the point (x, y) lie over the area? ``strict``: its edge counts as outside
        (an exactly critical centre of mass is not stable). A fast test for the convex
        areas stackdsl builds; ``contains`` is the general one.

        >>> from shapely.geometry import box
        >>> a = ContactArea(box(0, 0, 1, 1), 0.0, UP, True)
        >>> a.holds(0.5, 0.5), a.holds(1.0, 0.5), a.holds(1.0, 0.5, strict=False)
        (True, False, True)
        """
        x0, y0, x1, y1 = self.bounds
        if x < x0 or x > x1 or y < y0 or y > y1:
            return False
        if self._axis_aligned:  # the bounding box is the area: done
            return not strict or (x0 < x < x1 and y0 < y < y1)
        ring = self.ring
        n = len(ring)
        for i in range(n):
            (ax, ay), (bx, by) = ring[i], ring[(i + 1) % n]
            cross = (bx - ax) * (y - ay) - (by - ay) * (x - ax)
            if cross < 0 or (strict and cross == 0):
                return False
        return True

    @_cached
    def _axis_aligned(self) -> bool:
        """A rectangle with edges along x and y (most overlaps of bricks turned 0 or 90 deg)."""
        ring = self.ring
        return len(ring) == 4 and all(
            abs(ax - bx) < 1e-12 or abs(ay - by) < 1e-12 for (ax, ay), (bx, by) in zip(ring, ring[1:] + ring[:1])
        )

    @_cached
    def bounds(self) -> tuple[float, float, float, float]:
        """(min x, min y, max x, max y) of the polygon, metres."""
        x0, y0, x1, y1 = self.polygon.bounds
        return float(x0), float(y0), float(x1), float(y1)

    @_cached
    def centre_xy(self) -> tuple[float, float]:
        """(x, y) of the centroid as floats, metres."""
        c = self.polygon.centroid
        return float(c.x), float(c.y)

    @_cached
    def centre(self) -> np.ndarray:
        """Centroid of the area at its height, shape (3,), metres."""
        c = self.polygon.centroid
        return np.array([c.x, c.y, self.height])


def needs_padding(hull: BaseGeometry, pad: float) -> bool:
    """Whether the convex hull of contact points has too little area to be a contact area
    (:func:`padded_hull` pads it by ``pad`` metres). Source: report 3.3.3."""
    return not (isinstance(hull, Polygon) and hull.area > pad * pad * 1e-3)


def padded_hull(points_xy: np.ndarray, pad: float) -> Polygon:
    """Convex hull of contact points, padded when it has no area (report 3.3.3).

    One point becomes a diamond centred on it, two points (or collinear ones) a thin
    rectangle around the segment; ``pad`` is the half-width in metres. The report pads
    two points on one side only; stackdsl pads both sides so the area is not biased.

    Args:
        points_xy: shape (k, 2), k >= 1, metres.
        pad: metres, > 0.

    Raises:
        ValueError: when no point is given.

    >>> round(padded_hull(np.array([[0.0, 0.0]]), 0.001).area * 1e6, 3)
    2.0
    >>> round(padded_hull(np.array([[0.0, 0.0], [1e-12, 0.0]]), 0.001).area * 1e6, 3)  # one point, twice (rounded)
    2.0
    """
    points_xy = np.asarray(points_xy, dtype=float).reshape(-1, 2)
    if len(points_xy) == 0:
        raise ValueError("padded_hull needs at least one contact point")
    hull = MultiPoint(points_xy).convex_hull
    if not needs_padding(hull, pad):
        return hull
    if isinstance(hull, Point) or hull.length < pad * 1e-3:  # one point, or several at one place
        return Point(points_xy.mean(axis=0)).buffer(pad, quad_segs=1)
    line = hull if isinstance(hull, LineString) else LineString(shapely.get_coordinates(hull))
    return line.buffer(pad, cap_style="flat", quad_segs=1)


def hull_xy(xy: np.ndarray) -> BaseGeometry:
    """The convex hull of points ``xy`` (shape (k, 2), metres; shapely): of a ring through them
    when there are three or more, one shapely call where their multipoint takes two and costs
    twice as much (GEOS's hull reads the same coordinates in the same order: the same hull, bit
    for bit), else of their multipoint. Source: stackdsl's own.

    >>> hull_xy(np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.5], [0.0, 1.0]])).wkt
    'POLYGON ((0 0, 0 1, 1 0, 0 0))'
    """
    points = shapely.linearrings(xy) if len(xy) >= 3 else shapely.multipoints(xy)
    return shapely.convex_hull(points)


def combined_hull(areas: list[ContactArea]) -> Polygon:
    """The main contact area: convex hull of all individual contact areas (report 3.3.3)."""
    hull: Polygon = hull_of_union([a.polygon for a in areas])
    return hull


def hull_of_union(geometries: Sequence[BaseGeometry]) -> BaseGeometry:
    """The convex hull of the union of ``geometries`` (shapely, horizontal, not empty).

    Polygons with area whose bounding boxes lie apart (a brick's contacts with its two
    supports, at its two ends) have a union that is the polygons themselves, with no vertex
    added: its hull is that of their vertices, found without the union (GEOS's overlay cost ten
    times the hull). GEOS's hull of a polygon starts at the lowest point and sorts the others
    about it, so the order in which it reads them makes no difference: the same polygon, bit
    for bit. Other geometries, and a hull that is no polygon (its direction follows the order),
    are found from the union. Source: stackdsl's own.

    >>> from shapely.geometry import box
    >>> hull_of_union([box(0, 0, 1, 1), box(2, 0, 3, 1)]).wkt
    'POLYGON ((0 0, 0 1, 3 1, 3 0, 0 0))'
    """
    if all(type(g) is Polygon and g.area > 0.0 for g in geometries) and _apart(shapely.bounds(geometries).tolist()):
        hull = shapely.convex_hull(shapely.geometrycollections(geometries))
        if type(hull) is Polygon:
            return hull
    return shapely.union_all(geometries).convex_hull


def _apart(bounds: list[list[float]]) -> bool:
    """Whether the boxes ``bounds`` (each min x, min y, max x, max y) lie apart, two by two
    (neither touching nor overlapping)."""
    for i, (ax0, ay0, ax1, ay1) in enumerate(bounds):
        for bx0, by0, bx1, by1 in bounds[:i]:
            if not (ax1 < bx0 or bx1 < ax0 or ay1 < by0 or by1 < ay0):
                return False
    return True


def contains(polygon: BaseGeometry, xy: Sequence[float] | np.ndarray, margin: float = 0.0) -> bool:
    """True when point ``xy`` (metres) lies inside ``polygon`` by more than ``margin``.

    A point on the boundary is outside: an exactly critical centre of mass is not
    stable. Source: report 3.3.4 (the downward ray cast).
    """
    if not shapely.contains_xy(polygon, float(xy[0]), float(xy[1])):
        return False
    return margin <= 0.0 or polygon.exterior.distance(Point(float(xy[0]), float(xy[1]))) > margin


def signed_inside(polygon: BaseGeometry, xy: Sequence[float] | np.ndarray) -> float:
    """Metres point ``xy`` lies inside ``polygon``'s edge (negative: outside it, by that much).

    >>> from shapely.geometry import box
    >>> round(signed_inside(box(0, 0, 1, 1), [0.25, 0.5]), 6), round(signed_inside(box(0, 0, 1, 1), [1.5, 0.5]), 6)
    (0.25, -0.5)
    """
    point = Point(float(xy[0]), float(xy[1]))
    if shapely.contains_xy(polygon, point.x, point.y):
        edge = polygon.exterior if hasattr(polygon, "exterior") else polygon.boundary
        return float(edge.distance(point))
    return -float(polygon.distance(point))


FLAT = 0.25
"""Fraction of the face gap by which the gap between a brick's face and the ground may vary over
their overlap (:func:`face_overlap`): a brick rocking on one edge of its face, its other edge
1 mm up (2.4 deg across a KAPLA brick on end), is not lying face to face on the ground, though
every corner is within the gap. The ground is flat and rigid; a brick on a brick may sit a
little out of level on a stack that settled (a flatness rule there moved 12 of 37 goldens); two
bricks' faces must be parallel instead (:data:`FACE_TILT`)."""


FACE_TILT = math.cos(math.radians(0.5))
"""Cosine of the largest relative tilt (0.5 deg) of two brick faces that lie face to face. A settled
stack's faces are parallel to 0.22 deg or better on the engines measured (soft contacts let a
brick sink unevenly: docs/design.md, "Exact contact areas"); a brick tilted 1 deg on the top edge
of another touches it along that edge, though its face is within the face gap over the whole
overlap. Left tilted by less, a brick up to 460 mm long rolls onto the face by less than a 4 mm
collapse threshold. Source: stackdsl's own."""


def level_offset(half_extents: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """Metres: how far horizontally each box's farthest corner lies from where it would lie were
    the box turned level about its centre (its most vertical axis turned onto the vertical by
    the least rotation), shape (n,), for n boxes of ``half_extents`` (n, 3) in m at
    ``rotations`` (n, 3, 3); 0 for a level box. A box tilted by t moves a corner at height h
    over its centre and w from it by about h sin t + w (1 - cos t): 8.5 um for a KAPLA brick's
    top edge at 0.12 deg, the tilt of a settled stack's top on an engine's soft contacts, where
    the exact rule of level bricks places that edge. Source: stackdsl's own.

    >>> tilted = Rotation.from_euler("y", 0.12, degrees=True).as_matrix()[None]
    >>> float(level_offset(np.array([[0.06, 0.012, 0.004]]), tilted)[0] * 1e6).__round__(1)
    8.5
    """
    half = np.asarray(half_extents, dtype=float).reshape(-1, 3)
    rotations = np.asarray(rotations, dtype=float).reshape(-1, 3, 3)
    n = np.arange(len(rotations))
    k = np.argmax(np.abs(rotations[:, 2, :]), axis=1)
    up = rotations[n, :, k] * np.sign(rotations[n, 2, k])[:, None]  # its most vertical axis, upward
    axis = np.cross(up, [0.0, 0.0, 1.0])
    angle = np.arctan2(np.linalg.norm(axis, axis=1), up[:, 2])
    unit = np.where(angle[:, None] > 0, axis / np.maximum(np.linalg.norm(axis, axis=1), 1e-300)[:, None], 0.0)
    level = Rotation.from_rotvec(unit * angle[:, None]).as_matrix() @ rotations
    moved = np.einsum("nkj,nij->nki", _CORNER_SIGNS * half[:, None, :], rotations - level)
    return np.asarray(np.hypot(moved[..., 0], moved[..., 1]).max(axis=1))


EDGE_STRIP = 0.002
"""Metres an overlap may reach along its tilt and still be one edge's strip (a steep brick's end
face under a flat one): its exact area is then that edge's contact already. Source: stackdsl's own."""


def face_overlap(
    upper: Box,
    upper_pose: Pose,
    lower: Box | Plane,
    lower_pose: Pose | None,
    gap: float,
    faces: Faces | None = None,
) -> ContactArea | None:
    """The exact contact area of two bricks touching face to face, or None.

    The upper body's bottom face and the lower body's top face (or the plane) must lie
    within ``gap`` metres of each other at every corner of their overlap: flat faces,
    horizontal or tilted together (a tall tower settles a degree or so out of level),
    and parallel to :data:`FACE_TILT` unless the overlap is an edge's strip
    (:data:`EDGE_STRIP`): a brick tilted on another's edge touches it along that edge.
    The area is the intersection of their horizontal projections, at the mean height
    of the lower face over it; its depth is how far the upper face lies below the lower
    one there, on the mean.

    An admission asks this of every support of every brick, so it works in floats (the
    arithmetic of :meth:`Box.face` and numpy's means, term for term: the same bits), with
    shapely only for the intersection.

    ``faces``: the faces found already (by their boxes' half extents and poses, with their
    horizontal projections once made); those found here are added. A brick's bottom face meets
    each of its supports, and a frozen support's top face each brick laid on it: found once,
    each serves every pair.

    Source: stackdsl's own (pybullet's four contact points cover only
    60-70% of a turned brick's overlap; the faces give it exactly).

    Raises:
        ValueError: ``lower`` is a :class:`Box` and ``lower_pose`` is None.

    >>> brick = Box(np.array([0.06, 0.012, 0.004]), 0.0106)
    >>> lower, upper = Pose.from_euler([0, 0.048, 0.004]), Pose.from_euler([0.048, 0, 0.0119], yaw=90)
    >>> area = face_overlap(brick, upper, brick, lower, 0.001)
    >>> round(area.area * 1e6), round(area.height * 1e3, 3), round(area.depth * 1e3, 3)  # mm^2, mm, mm
    (576, 8.0, 0.1)
    """
    under = _face_of(upper, upper_pose, -1.0, faces)
    bottom, down = under.corners, under.normal
    if isinstance(lower, Plane):
        (cx, cy, cz), normal = (0.0, 0.0, lower.height), (0.0, 0.0, 1.0)
        if down[2] >= -0.5:
            return None
        poly = under.horizontal()
    else:
        if lower_pose is None:
            raise ValueError("face_overlap needs the pose of a Box below")
        over = _face_of(lower, lower_pose, 1.0, faces)
        top, normal = over.corners, over.normal
        if normal[2] <= 0.5 or down[2] >= -0.5:
            return None
        cx, cy, cz = _mean_rows(top)
        poly = under.horizontal().intersection(over.horizontal())
    if not isinstance(poly, Polygon) or poly.area <= 0.0:
        return None
    # floats, without shapely's coordinate objects; the overlap of two convex faces has no hole:
    # the polygon's coordinates are its exterior's
    ring = shapely.get_coordinates(poly)[:-1].tolist()
    nx, ny, nz = normal
    bx, by, bz = _mean_rows(bottom)
    ux, uy, uz = -down[0], -down[1], -down[2]
    lower_z = [cz - ((x - cx) * nx + (y - cy) * ny) / nz for x, y in ring]
    upper_z = [bz - ((x - bx) * ux + (y - by) * uy) / uz for x, y in ring]
    gaps = [w - u for w, u in zip(lower_z, upper_z)]
    if max(abs(g) for g in gaps) > gap or (isinstance(lower, Plane) and max(gaps) - min(gaps) > gap * FLAT):
        return None
    parallel = nx * ux + ny * uy + nz * uz  # the cosine of the faces' relative tilt
    if parallel < FACE_TILT and max(gaps) - min(gaps) > EDGE_STRIP * math.sqrt(max(0.0, 1.0 - parallel * parallel)) / parallel:
        return None  # tilted on an edge: it touches along that edge, not over the overlap
    depth = _mean(gaps)
    return ContactArea(poly, _mean(lower_z), np.array(normal), exact=True, depth=depth)


_Vec = tuple[float, float, float]


@dataclass(slots=True)
class Face:
    """A box's face towards straight up or down (:func:`face_overlap`), in floats: its
    ``corners`` in order around it (m), its outward unit ``normal``, and its horizontal
    projection once made (:meth:`horizontal`). Source: stackdsl's own."""

    corners: tuple[_Vec, _Vec, _Vec, _Vec]
    normal: _Vec
    projection: Polygon | None = None

    def horizontal(self) -> Polygon:
        """The horizontal projection of the face (shapely), made the first time it is asked for."""
        if self.projection is None:
            self.projection = shapely.polygons([c[:2] for c in self.corners])
        return self.projection


Faces = dict[tuple[float, ...], Face]
"""Faces found by :func:`face_overlap`, by their boxes' half extents and poses and their side."""


def _face_of(box: Box, pose: Pose, up: float, faces: Faces | None) -> Face:
    """The face of ``box`` at ``pose`` towards straight up (``up`` 1.0) or down (-1.0): found in
    ``faces``, else found (:func:`_face`) and added to ``faces`` (unless None)."""
    half, position, orientation = box.half_extents.tolist(), pose.position.tolist(), pose.orientation.tolist()
    key = (up, *half, *position, *orientation)
    if faces is None or 0.0 in key:  # 0.0 and -0.0 are one key, and may give corners that differ in a zero's sign
        return Face(*_face(half, position, orientation, up))
    face = faces.get(key)
    if face is None:
        face = faces[key] = Face(*_face(half, position, orientation, up))
    return face


def _face(
    half_extents: list[float], position: list[float], orientation: list[float], up: float
) -> tuple[tuple[_Vec, _Vec, _Vec, _Vec], _Vec]:
    """:meth:`Box.face` towards straight up (``up`` 1.0) or down (-1.0), in floats, of a box of
    ``half_extents`` at ``position`` and ``orientation`` (a quaternion x, y, z, w): the corners
    in order around the face and its outward normal. Source: stackdsl's own."""
    x, y, z, w = orientation
    n = 2.0 / (x * x + y * y + z * z + w * w)  # Pose.rotation's formula, term for term
    m = (
        (1 - n * (y * y + z * z), n * (x * y - z * w), n * (x * z + y * w)),
        (n * (x * y + z * w), 1 - n * (x * x + z * z), n * (y * z - x * w)),
        (n * (x * z - y * w), n * (y * z + x * w), 1 - n * (x * x + y * y)),
    )
    dots = [up * c for c in m[2]]
    size = [abs(d) for d in dots]
    axis = 0 if size[0] >= size[1] and size[0] >= size[2] else (1 if size[1] >= size[2] else 2)
    sign = 1.0 if dots[axis] >= 0 else -1.0
    u, v = [i for i in range(3) if i != axis]
    px, py, pz = position
    ha, hu, hv = sign * half_extents[axis], half_extents[u], half_extents[v]
    cx, cy, cz = px + ha * m[0][axis], py + ha * m[1][axis], pz + ha * m[2][axis]
    ux, uy, uz = hu * m[0][u], hu * m[1][u], hu * m[2][u]
    vx, vy, vz = hv * m[0][v], hv * m[1][v], hv * m[2][v]
    corners = (
        (cx - ux - vx, cy - uy - vy, cz - uz - vz),
        (cx + ux - vx, cy + uy - vy, cz + uz - vz),
        (cx + ux + vx, cy + uy + vy, cz + uz + vz),
        (cx - ux + vx, cy - uy + vy, cz - uz + vz),
    )
    return corners, (sign * m[0][axis], sign * m[1][axis], sign * m[2][axis])


def _mean_rows(rows: Sequence[_Vec]) -> _Vec:
    """The mean of a few points, as numpy's ``mean(axis=0)`` sums them (in order)."""
    x = y = z = 0.0
    for px, py, pz in rows:
        x, y, z = x + px, y + py, z + pz
    return x / len(rows), y / len(rows), z / len(rows)


def _mean(values: Sequence[float]) -> float:
    """The mean of a few floats, as numpy's ``mean`` sums them (:func:`_pairwise_sum`), so that
    the result has the same bits."""
    return (0.0 + _pairwise_sum(values, 0, len(values))) / len(values)


def _pairwise_sum(a: Sequence[float], start: int, n: int) -> float:
    """The sum of ``a[start:start + n]`` as numpy's pairwise summation adds them: in order below
    eight; else in eight partial sums, each over every eighth value, added pairwise, and the
    rest in order; beyond 128 values (numpy's block), the two halves apart."""
    if n < 8:
        total = -0.0
        for v in a[start : start + n]:
            total += v
        return total
    if n <= 128:
        r = list(a[start : start + 8])
        end = start + n - n % 8
        for i in range(start + 8, end, 8):
            for j in range(8):
                r[j] += a[i + j]
        total = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
        for v in a[end : start + n]:
            total += v
        return total
    half = n // 2
    half -= half % 8
    return _pairwise_sum(a, start, half) + _pairwise_sum(a, start + half, n - half)


TOUCH = 5e-5
"""Metres by which the faces of two bodies may stand apart at a vertex of their overlap and still
touch there (:func:`touching_feature`): beyond where they overlap, or beyond the closest vertex
when they do not. A brick at rest sinks 0.01 to 0.13 mm into what it rests on (the engines' soft
contacts); a strip along a tilt of 1 deg is then at most 2.9 mm wide past where they overlap, about
an edge's strip (:data:`EDGE_STRIP`). Source: stackdsl's own."""


def touching_feature(
    body: Box,
    body_pose: Pose,
    other: Box | Plane,
    other_pose: Pose | None,
    normal: np.ndarray,
    gap: float,
) -> np.ndarray | None:
    """Where two bodies that touch across ``normal`` meet, from their shapes and poses: the
    corner, the edge or the face of their contact, as its vertices (shape (k, 3), metres,
    1 <= k; a point, a segment or a convex polygon across ``normal``), or None when the two
    faces turned towards each other do not come within ``gap`` of each other (nor overlap by
    more).

    ``normal``: unit, from ``other`` into ``body`` (an engine's contact normal). The face of
    ``body`` turned most against it and the face of ``other`` turned most along it (the plane's
    top) are projected along it and their overlap found. Over that overlap the distance between
    the two faces along ``normal`` changes linearly, so rigid bodies touch at the vertices where
    it is least: the two ends of an edge tilted on a face (a cantilever tipped 1 deg on a
    table's edge touches it along the whole edge), the vertex where two edges cross, every
    vertex of two faces flat on each other. An engine's soft contact sinks one into the other:
    every vertex where they overlap is in contact too. A vertex within :data:`TOUCH` of that
    (of the least distance, when they do not overlap) counts. A point returned lies midway
    between the two faces.

    An engine's own points may show less: one engine reports one point for two boxes that do
    not lie face to face (at the deepest corner), so a brick tilted on an edge seemed to rest on
    a point, and the certificate of a structure at rest found no equilibrium.
    Source: stackdsl's own (the reference and incident faces of box-box clipping, as in ODE's
    ``dBoxBox``; Smith, Open Dynamics Engine, 2001).

    Raises:
        ValueError: ``other`` is a :class:`Box` and ``other_pose`` is None.

    >>> brick = Box(np.array([0.06, 0.012, 0.004]), 0.0106)
    >>> table, at = Box(np.array([0.1, 0.1, 0.02]), 1.0), Pose.from_euler([-0.1, 0.0, 0.02])
    >>> up = np.array([0.0, 0.0, 1.0])
    >>> tipped = Pose.from_euler([0.015, 0.0, 0.0439], pitch=1.0)  # 1 deg on the table's edge at x = 0
    >>> sorted(np.round(touching_feature(brick, tipped, table, at, up, 0.001)[:, :2] * 1e3, 1).tolist())
    [[0.0, -12.0], [0.0, 12.0]]
    >>> rocking = Pose.from_euler([0.0, 0.0, 0.0049], pitch=1.0)  # on the ground, on its bottom edge
    >>> sorted(np.round(touching_feature(brick, rocking, Plane(0.0), None, up, 0.001)[:, :2] * 1e3, 1).tolist())
    [[59.9, -12.0], [59.9, 12.0]]
    """
    n = np.asarray(normal, dtype=float)
    n = n / np.linalg.norm(n)
    t1 = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(n, t1)
    own, own_normal = body.face(body_pose, -n)
    origin = own.mean(axis=0)

    def across(points: np.ndarray) -> Polygon:
        d = points - origin
        return Polygon(np.column_stack([d @ t1, d @ t2])).convex_hull

    overlap: BaseGeometry = across(own)
    if isinstance(other, Plane):
        other_normal, other_point = np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, other.height])
    else:
        if other_pose is None:
            raise ValueError("touching_feature needs the pose of a Box")
        top, other_normal = other.face(other_pose, n)
        other_point = top.mean(axis=0)
        overlap = overlap.intersection(across(top))
    if not isinstance(overlap, Polygon) or overlap.is_empty or overlap.area <= 0.0:
        return None
    uv = shapely.get_coordinates(overlap)[:-1]
    base = origin + uv[:, :1] * t1 + uv[:, 1:] * t2

    def height(point: np.ndarray, face_normal: np.ndarray) -> np.ndarray | None:
        """How far along ``n`` from ``base`` each vertex's line meets the face's plane."""
        slant = float(face_normal @ n)
        if abs(slant) < 0.5:  # the face turned more than 60 deg from the normal: not this contact's
            return None
        along: np.ndarray = ((point - base) @ face_normal) / slant
        return along

    h_own, h_other = height(origin, own_normal), height(other_point, other_normal)
    if h_own is None or h_other is None:
        return None
    apart = h_own - h_other  # > 0: a gap between the faces; < 0: they overlap (soft contacts)
    closest = float(apart.min())
    if not -gap <= closest <= gap:  # apart, or through each other: not these faces' contact
        return None
    near = apart <= max(closest, 0.0) + TOUCH
    points: np.ndarray = base[near] + ((h_own[near] + h_other[near]) / 2.0)[:, None] * n
    return points

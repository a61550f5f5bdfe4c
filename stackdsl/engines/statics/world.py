"""A world without dynamics: bricks stay where they are placed, and statics decides what falls.

:class:`StaticsWorld` is a :class:`~stackdsl.engines.protocol.World` whose bodies never move by
themselves. After each step in which bricks were placed (one, or a group placed together), it
asks rigid-block equilibrium (:func:`stability.load_paths_hold`, else
:func:`stability.solve_equilibrium`) of every brick standing, at
its pose, on the contacts the poses give (:func:`stability.contacts_of`, within
:data:`GAP` of each other). When no forces balance them, the bricks of the collapse mechanism
and the brick just placed fall: each is laid flat on the ground where it was, and leaves the
problem; equilibrium is asked again of the rest until it holds. The runtime's collapse monitor
sees the fallen bricks displaced at rest, so the collapse level is the level of the first
placement after which the bricks have no equilibrium. Nothing else moves: velocities are zero,
a throw is ignored, and a hand or a shake table is refused (the compiler refuses such scenes
first: :attr:`stackdsl.engines.backend.Backend.dynamics`). A run without subscribers of its own
never opens one (:mod:`stackdsl.runtime.placing` places and solves without a world); a run with a
recorder steps this world in the step loop.

Source: stackdsl's own, on rigid-block equilibrium (Livesley 1978; Whiting et al. 2009).
"""

from __future__ import annotations

from collections.abc import Collection, Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from stability import (
    CONTACT_GAP,
    Box,
    ContactPoint,
    ContactPolygon,
    PlacedBox,
    Pose,
    RigidBlock,
    contacts_of,
    load_paths_hold,
    solve_equilibrium,
)

from ..protocol import BrickSpec, EngineSettings, Vec3, World

#: Metres within which two faces, or a corner and a face, touch: bricks are placed a drop gap
#: above their poses (0.5 mm by default), and this backend takes drop gaps up to 1 mm
#: (:data:`stackdsl.engines.statics.MAX_DROP`).
GAP = CONTACT_GAP


class StaticsWorld(World):
    """The world of the statics backend (see the module's docstring).

    Args:
        engine: the run's settings (its timestep is the runtime's clock only).
        ground_friction: of the ground's material (the restitution is not used).

    Attributes:
        fallen: the bodies laid on the ground by statics, in the order they fell.
    """

    def __init__(self, engine: EngineSettings, ground_friction: float) -> None:
        self.ground = 0
        self._timestep = engine.timestep
        self._ground_friction = ground_friction
        self._bodies: dict[int, PlacedBox] = {}
        self._free: set[int] = set()  # bodies with mass: the bricks statics balances
        self._placed: list[int] = []  # placed since the last step: equilibrium is asked then
        self.fallen: list[int] = []
        self._points: dict[int, list[ContactPoint]] | None = None  # every body's contact points, while no pose changes
        self._stacked: tuple[tuple[int, ...], np.ndarray] | None = None  # the standing bodies' bounds, stacked
        self._bounds: dict[int, np.ndarray] = {}  # body -> its box's bounds, shape (2, 3): low and high corners, m
        self._polygons: dict[int, list[ContactPolygon[int]]] = {}  # body -> its contact polygons, until a neighbour moves

    @property
    def timestep(self) -> float:
        return self._timestep

    # bodies -------------------------------------------------------------------
    def create(self, spec: BrickSpec, pose: Pose, mass: float | None = None, projectile: bool = False) -> int:
        body = len(self._bodies) + 1
        self._put(PlacedBox(body, Box(np.array(spec.half_extents), spec.mass), pose, spec.friction))
        self._enter(body, spec.mass if mass is None else mass)
        return body

    def move(self, body: int, pose: Pose, mass: float) -> None:
        old = self._bodies[body]
        self._put(PlacedBox(body, old.box, pose, old.friction))
        self._enter(body, mass)

    def _put(self, body: PlacedBox) -> None:
        """Put ``body`` where it says (its contacts are found anew)."""
        self._bodies[body.key] = body
        corners = body.box.corners(body.pose)
        before = self._bounds.get(body.key)
        self._bounds[body.key] = np.array([corners.min(axis=0) - GAP, corners.max(axis=0) + GAP])
        self._points, self._stacked = None, None
        for bounds in (before, self._bounds[body.key]):  # what it left and what it meets find their contacts anew
            if bounds is not None:
                for key in self._meeting(bounds):
                    self._polygons.pop(key, None)

    def _meeting(self, bounds: np.ndarray) -> list[int]:
        """The bodies whose bounds meet ``bounds`` (shape (2, 3): low and high corners, m)."""
        keys = tuple(self._bounds)
        if self._stacked is None or self._stacked[0] != keys:
            self._stacked = (keys, np.array([self._bounds[k] for k in keys]))  # (n, 2, 3)
        stacked = self._stacked[1]
        meets = np.all(stacked[:, 0] <= bounds[1], axis=1) & np.all(bounds[0] <= stacked[:, 1], axis=1)
        return [k for k, m in zip(keys, meets.tolist()) if m]

    def _enter(self, body: int, mass: float) -> None:
        if mass > 0.0:
            self._free.add(body)
            self._placed.append(body)
        else:
            self._free.discard(body)

    def throw(self, body: int, velocity: Vec3, swept_radius: float | None) -> None:
        """Nothing moves by its velocity here: ignored."""

    def guide(self, body: int, pose: Pose, velocity: Vec3, hold: bool = True) -> None:
        """Refused: a hand moves bricks (the compiler refuses actions first)."""
        raise NotImplementedError("the statics backend cannot guide a body: it has no dynamics")

    def carry(self, body: int, pose: Pose, velocity: Vec3) -> None:
        """Refused: only a hand's body is carried (the compiler refuses actions first)."""
        raise NotImplementedError("the statics backend cannot carry a body: it has no dynamics")

    def move_ground(self, offset: Vec3, velocity: Vec3) -> None:
        """Refused: a shake table moves the ground (the compiler refuses actions first)."""
        raise NotImplementedError("the statics backend cannot move its ground: it has no dynamics")

    def set_substeps(self, substeps: int) -> None:
        """No steps to split: ignored."""

    def step(self) -> None:
        """Decide, once after bricks were placed, which of them statics lets stand (module docstring)."""
        if self._placed:
            placed, self._placed = self._placed, []
            self._settle(placed)

    def _settle(self, placed: list[int]) -> None:
        while True:
            standing = set(self._bodies).difference(self.fallen)
            free = [self._bodies[k] for k in sorted(standing & self._free)]
            if not free:
                return
            blocks = {b.key: RigidBlock(b.box.mass, b.pose.position) for b in free}
            polygons = [c for b in free for c in self._contacts(b, standing)]
            if load_paths_hold(free, polygons):
                return
            answer = solve_equilibrium(blocks, polygons)
            if answer.stands:
                return
            falling = (answer.moving() | set(placed)) & {b.key for b in free}
            for key in sorted(falling):
                self._lay_down(key)

    def _lay_down(self, key: int) -> None:
        """Lay body ``key`` flat on the ground under its centre, its longest side along its
        longest side's horizontal direction."""
        body = self._bodies[key]
        half = body.box.half_extents
        thin, long = int(np.argmin(half)), int(np.argmax(half))
        axis = body.pose.rotation[:, long]
        direction = np.array([axis[0], axis[1], 0.0])
        direction = direction / np.linalg.norm(direction) if np.linalg.norm(direction) > 1e-9 else np.array([1.0, 0.0, 0.0])
        matrix = np.zeros((3, 3))
        matrix[:, long], matrix[:, thin] = direction, [0.0, 0.0, 1.0]
        middle = 3 - thin - long
        matrix[:, middle] = np.cross(matrix[:, (middle + 1) % 3], matrix[:, (middle + 2) % 3])
        x, y = float(body.pose.position[0]), float(body.pose.position[1])
        pose = Pose(np.array([x, y, float(half[thin])]), Rotation.from_matrix(matrix).as_quat())
        self.fallen.append(key)
        self._put(PlacedBox(key, body.box, pose, body.friction))

    def _contacts(self, body: PlacedBox, standing: set[int]) -> list[ContactPolygon[int]]:
        """The contact polygons of ``body`` with the ground and the bodies of ``standing`` whose
        bounds meet its own (within :data:`GAP`), kept until one of them is put elsewhere."""
        kept = self._polygons.get(body.key)
        if kept is not None:
            return kept
        near = [self._bodies[k] for k in self._meeting(self._bounds[body.key]) if k != body.key and k in standing]
        found = contacts_of(body, near, self.ground, self._ground_friction, GAP)
        self._polygons[body.key] = found
        return found

    # reading ------------------------------------------------------------------
    def pose(self, body: int) -> Pose:
        return self._bodies[body].pose

    def poses_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        poses = [self._bodies[b].pose for b in bodies]
        return np.array([p.position for p in poses]).reshape(-1, 3), np.array([p.orientation for p in poses]).reshape(-1, 4)

    def velocity(self, body: int) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros(3), np.zeros(3)

    def velocities_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros((len(bodies), 3)), np.zeros((len(bodies), 3))

    def speeds(self, body: int) -> tuple[float, float]:
        return 0.0, 0.0

    def contact_points(self, bodies: Collection[int] | None = None) -> list[ContactPoint]:
        points = self._all_points()
        if bodies is None:
            return [p for found in points.values() for p in found]
        return [p for b in bodies for p in points.get(b, [])]

    def near(self, body: int, distance: float, among: Collection[int] | None = None) -> list[ContactPoint]:
        """What ``body`` touches (within :data:`GAP`; nothing nearer moves here)."""
        return [p for p in self._all_points().get(body, []) if among is None or p.other in among]

    def set_frozen(self, body: int, frozen: bool, mass: float, at: Pose | None = None) -> None:
        if frozen and at is not None and body in self._bodies:
            old = self._bodies[body]
            same = np.array_equal(old.pose.position, at.position) and np.array_equal(old.pose.orientation, at.orientation)
            if not same:
                self._put(PlacedBox(body, old.box, at, old.friction))

    def _all_points(self) -> dict[int, list[ContactPoint]]:
        """Every body's contact points, seen from it (each pair from both sides): the polygons'
        vertices; a fallen body touches the ground only."""
        if self._points is not None:
            return self._points
        points: dict[int, list[ContactPoint]] = {}
        fallen = set(self.fallen)
        standing = set(self._bodies).difference(fallen)
        for b in self._bodies.values():
            for c in self._contacts(b, standing) if b.key not in fallen else self._contacts(b, set()):
                normal = np.asarray(c.normal, dtype=float)
                for p in np.asarray(c.points, dtype=float):
                    points.setdefault(b.key, []).append(ContactPoint(b.key, c.other, p, normal))
                    points.setdefault(c.other, []).append(ContactPoint(c.other, b.key, p, -normal))
        self._points = points
        return points

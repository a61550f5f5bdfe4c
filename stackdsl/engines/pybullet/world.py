"""The world on pybullet: :class:`PyBulletWorld`, a :class:`~stackdsl.engines.protocol.World`
on a pybullet DIRECT client.

pybullet facts this adapter encodes (measured with pybullet 3.2.7):

* Bullet multiplies the two bodies' friction coefficients (and restitutions): each body
  gets the square root of its material's value, so a pair of one material has exactly
  the material's coefficient.
* Friction anchors stop a resting brick's creep; continuous collision detection needs a
  body in maximal coordinates.
* Bodies are created in program order, so that a run is bitwise repeatable.
* A body created after one was removed gets the removed body's id: pybullet reuses ids, so
  the adapter gives bodies ids of its own (the same as pybullet's until a body is removed).
* A step costs about 0.2 us more for every static body in the world, wherever it is, filtered
  or not: 90 us with 400 frozen bricks against 6 us with 2. Only removing a body saves it.
* A step of a settling heap costs about half as much in rigid bodies (maximal coordinates)
  as in one-link multibodies (docs/results/collapse-phase.md).
* A box that comes to touch a static plane meets it at one contact point in its first step and
  two in the next; the other corners of their face come in only as it rocks (all four after
  about 200 steps at rest). A box on a static box meets it at all four at once. Made static,
  a body keeps no contact with the static plane, and given its mass back it starts again
  from one: a domino woken 1.5 steps before the next one struck it turned about that point,
  and the chain veered off its line. So a body woken where it rested on the ground meets the
  ground as a static box whose top is the plane (:data:`GROUND_HALF`, only its pairs).

Source: stackdsl's own (the world adapter of dm_control's composer).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Collection, Iterator, Mapping, Sequence
from contextlib import contextmanager
from typing import Any, NamedTuple

import numpy as np
from scipy.spatial.transform import Rotation

from stability import ContactPoint, Pose

from ..protocol import BrickSpec, Quat, Vec3, World
from .client import direct_client
from .engine import PyBulletEngine
from .settings import PyBulletSettings


@contextmanager
def pybullet_world(
    engine: PyBulletSettings,
    ground_friction: float,
    ground_restitution: float,
    *,
    shelve: bool = True,
    movable_ground: bool = False,
) -> Iterator[PyBulletWorld]:
    """A :class:`PyBulletWorld` on an empty DIRECT client (:func:`direct_client`)."""
    with direct_client() as client:
        yield PyBulletWorld(client, engine, ground_friction, ground_restitution, shelve=shelve, movable_ground=movable_ground)


#: kg of a guided body while it is guided: a hand's grip, which no brick's contact moves
#: within a step (its inertia scaled with it).
GUIDED_MASS = 100.0
#: Half extents (m) of the box a body woken where it rested on the ground meets the ground as (its
#: top the plane z = 0; the module's facts): every corner of its face at once, as a body at rest
#: on the plane has come to meet it.
GROUND_HALF = (1000.0, 1000.0, 0.5)
#: Metres above the ground within which the lowest point of a body woken lies on it (its bounding
#: box's foot, pybullet's collision margin of 1 mm below its lowest corner included): woken there,
#: it meets the ground as that box (a body woken higher up lands on the plane as any body does).
ON_THE_GROUND = 0.003
#: kg and half extents (m) of a movable ground: a box whose top is the plane z = 0.
TABLE_MASS = 1.0e5
TABLE_HALF = (5.0, 5.0, 0.5)
#: The share of a guided body's distance from its path that its velocity makes up in one step.
GAIN = 0.5


#: Metres beyond a moving body's box within which a shelved body is put back into pybullet's
#: world (looked at again before any moving body can travel half of it).
REACH = 0.025
#: Metres from every moving body's box and from the bodies frozen last beyond which a static
#: body is shelved.
SHELVE = 0.05
#: How many of the bodies frozen last keep the static bodies near them in the world.
RECENT = 8
#: Moving bodies above which nothing is shelved, and everything shelved is put back (a heap).
CROWD = 16
_AT_REST = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


class PyBulletWorld(PyBulletEngine, World):
    """:class:`World` on a pybullet client: gravity, timestep, solver iterations and the
    ground plane are set up at once; ``ground`` is the plane's body id (a brick woken where it
    rested on the plane meets it as a box whose top is the plane, read as the ground in contacts:
    the module's facts).

    A body's velocity is read from pybullet once a step, however many ask (the rest test
    brick by brick, the substep control and the collapse monitor), and read again after
    anything that changes it (a step, a freeze or a wake); a moving body just created, moved or
    thrown has the velocity it was given, which pybullet would read back to the bit.

    Static bodies that nothing moving can reach are shelved: taken out of pybullet's world,
    their poses kept, and put back, under the same ids, before a step in which a moving body
    could reach them (within :data:`REACH` of its box, and what it may travel before the shelf
    is looked at again) or when they are woken or moved. A static body is shelved once it lies :data:`SHELVE` from
    every moving body and from the :data:`RECENT` bodies frozen last (looked at when a body
    freezes): a tower's buried levels leave the world, and its step costs what its top
    costs. Nothing is shelved while more than :data:`CROWD` bodies move. A shelved body reads
    as pybullet would read it: its pose, at rest, and no contacts (pybullet reports none
    between two static bodies). Source: stackdsl's own.

    Args:
        client: a ``pybullet_utils.bullet_client.BulletClient``.
        engine: the run's engine settings.
        ground_friction, ground_restitution: of the ground's material.
        shelve: shelve static bodies out of reach (False: every body stays in the world).
        movable_ground: the ground is a heavy box whose top is the plane z = 0, moved by
            :meth:`move_ground` (a shake table), instead of a static plane.

    A guided body (:meth:`guide`) is driven along its path by its velocity before each step
    (:meth:`_drive`); one a hand holds is made :data:`GUIDED_MASS` heavy (its inertia scaled too)
    and held up against gravity by a force for the step: the solver then moves what it
    touches, and friction drags it, as a hand does.
    pybullet moves no static body by a velocity, which is why the movable ground is a dynamic
    box of :data:`TABLE_MASS` guided the same way.
    """

    def __init__(
        self,
        client: Any,
        engine: PyBulletSettings,
        ground_friction: float,
        ground_restitution: float,
        *,
        shelve: bool = True,
        movable_ground: bool = False,
    ) -> None:
        import pybullet

        super().__init__(client)
        self._p, self._engine = pybullet, engine
        self._velocities: dict[int, Any] = {}  # this step's pybullet velocities, by body
        self._poses: dict[int, Any] = {}  # pybullet's poses read since the last step, by body (until one is moved)
        self._read_velocity = client.getBaseVelocity
        self._read_pose = client.getBasePositionAndOrientation
        self._read_box = client.getAABB
        self._get_velocity = self._velocity_now
        self._get_pose = self._pose_now
        self._shapes: dict[Vec3, int] = {}  # half extents -> collision shape
        self._made: dict[int, tuple[BrickSpec, bool]] = {}  # body -> its spec, in maximal coordinates?
        self._multibodies: dict[int, BrickSpec] = {}  # the bodies created in reduced coordinates
        self._swept: dict[int, float] = {}  # body -> radius of its swept sphere
        self._ids: dict[int, int] = {}  # body -> pybullet's id, where they differ
        self._names: dict[int, int] = {}  # pybullet's id -> body, where they differ
        self._moving: set[int] = set()  # bodies of mass above 0
        self._still: dict[int, _Box | None] = {}  # bodies of mass 0 in pybullet's world (the ground aside): box
        self._rested: set[int] = set()  # bodies that were static: woken on the ground, they meet it as a box (the module's facts)
        self._on_box: set[int] = set()  # pybullet's ids of the bodies that meet the ground as that box
        self._ground_box: int | None = None  # pybullet's id of that box, made when first needed
        self._shelf: dict[int, tuple[Any, Any, _Box]] = {}  # body -> position, orientation, bounding box
        self._shelf_box: _Box | None = None  # the shelf's bounding box (None: to be found)
        self._recent: deque[int] = deque(maxlen=RECENT)
        self._look = False  # a body froze: look for what to shelve
        self._due = 0  # steps before the shelf must be looked at again
        self._shelves = shelve
        self._substeps = 1
        self._split = False  # stepping in substeps of its own (see step), not pybullet's numSubSteps
        self._paths: dict[int, tuple[Any, Any, Vec3, float | None]] = {}  # this step's guided bodies: their path
        self._anchored: set[int] = set()  # engine ids of the pulled bricks given friction anchors (see _anchor)
        self._merged: dict[int, tuple[int, int]] = {}  # body -> its merged body, and its place among the bodies merged
        self._groups: dict[int, tuple[int, ...]] = {}  # merged body -> the bodies merged (see merge)
        self._frames: dict[int, _Parts] = {}  # merged body -> where each of its boxes lies in it
        self._carried: dict[int, tuple[Vec3, Vec3]] = {}  # body unmerged this step -> the velocity it rode with
        self._last_turn: tuple[object, np.ndarray] = (None, np.eye(3))  # a merged body's turn read, its matrix
        client.setGravity(0.0, 0.0, -engine.gravity)
        client.setTimeStep(engine.timestep)
        client.setPhysicsEngineParameter(numSolverIterations=engine.solver_iterations, numSubSteps=0)  # a kept client's own
        self._guided: dict[int, float] = {}  # guided body -> its mass while guided
        self._table = movable_ground
        self._ground_at: tuple[Vec3, Vec3] = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # a movable ground's offset and velocity
        if movable_ground:
            box = client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=list(TABLE_HALF))
            self.ground = client.createMultiBody(TABLE_MASS, box, basePosition=[0.0, 0.0, -TABLE_HALF[2]])
        else:
            self.ground = client.createMultiBody(0.0, client.createCollisionShape(pybullet.GEOM_PLANE))
        self._next: int = self.ground + 1
        self._material(self.ground, ground_friction, ground_restitution)
        self._ground_material = self._dynamics(ground_friction, ground_restitution)

    @property
    def timestep(self) -> float:
        return self._engine.timestep

    cheap_debris = True

    # ids ----------------------------------------------------------------------
    def _engine_id(self, body: int) -> int:
        return self._ids.get(body, body)

    def _body_id(self, engine_id: int) -> int:
        return self._names.get(engine_id, engine_id)

    def _bind(self, body: int, engine_id: int) -> None:
        if body == engine_id:
            self._ids.pop(body, None)
            self._names.pop(engine_id, None)
        else:
            self._ids[body], self._names[engine_id] = engine_id, body

    def _remove(self, body: int) -> None:
        engine_id = self._ids.pop(body, body)
        self._names.pop(engine_id, None)
        if engine_id in self._on_box:  # pybullet gives its id to the next body made: as new
            self._on_ground_box(engine_id, False)
        self._anchored.discard(engine_id)
        self._client.removeBody(engine_id)
        self._velocities.pop(body, None)
        self._poses.pop(body, None)

    # bodies -------------------------------------------------------------------
    def create(self, spec: BrickSpec, pose: Pose, mass: float | None = None, projectile: bool = False) -> int:
        """A body in maximal coordinates for a ``projectile`` (continuous collision detection
        needs one), else in the coordinates of the engine settings."""
        body, self._next = self._next, self._next + 1
        maximal = True if projectile else self._engine.maximal_coordinates
        mass = spec.mass if mass is None else mass
        # pybullet never moves a rigid body (maximal coordinates) made with mass 0, whatever
        # mass it is given later; one made with its mass and then given 0 moves again when given
        # one back. On a shake table an immovable body is carried (guided) while the table moves.
        carried = self._table and maximal and mass <= 0.0
        self._put(body, spec, pose.position.tolist(), pose.orientation.tolist(), spec.mass if carried else mass, maximal)
        if carried:
            self._client.changeDynamics(self._engine_id(body), -1, mass=0.0)
            self._massed(body, 0.0)
        if body in self._moving:  # created at rest
            self._velocities[body] = _AT_REST
        return body

    def _put(self, body: int, spec: BrickSpec, position: Any, orientation: Any, mass: float, maximal: bool) -> None:
        """Create ``body`` in pybullet's world."""
        self._poses.pop(body, None)
        key = spec.half_extents
        if key not in self._shapes:
            self._shapes[key] = self._client.createCollisionShape(self._p.GEOM_BOX, halfExtents=list(key))
        engine_id: int = self._client.createMultiBody(
            baseMass=mass,
            baseCollisionShapeIndex=self._shapes[key],
            basePosition=position,
            baseOrientation=orientation,
            useMaximalCoordinates=maximal,
        )
        self._bind(body, engine_id)
        self._material(body, spec.friction, spec.restitution)
        if body in self._swept:
            self._client.changeDynamics(engine_id, -1, ccdSweptSphereRadius=self._swept[body])
        self._made[body] = (spec, maximal)
        if maximal:
            self._multibodies.pop(body, None)
        else:
            self._multibodies[body] = spec
        self._massed(body, mass)

    def _massed(self, body: int, mass: float) -> None:
        """Note that ``body`` now has ``mass`` (0: static)."""
        if mass > 0.0:
            self._still.pop(body, None)
            self._moving.add(body)
            self._due = 0  # something new moves: look at the shelf before the next step
            if body in self._rested and not self._table and self._engine_id(body) not in self._on_box:
                if self._box(body, 0.0)[2] < ON_THE_GROUND:  # woken where it rested on the plane
                    self._on_ground_box(self._engine_id(body), True)
        else:
            self._moving.discard(body)
            self._still[body] = None  # its box, once asked
            self._rested.add(body)

    def _on_ground_box(self, engine_id: int, on: bool) -> None:
        """Let the body of pybullet's ``engine_id`` meet the static ground as the box of
        :data:`GROUND_HALF` instead of the plane (``on``), or as the plane again (the module's
        facts); the box is made when first asked, colliding with nothing but the bodies let meet it,
        and read as the ground in contacts."""
        box = self._ground_box
        if box is None:
            shape = self._client.createCollisionShape(self._p.GEOM_BOX, halfExtents=list(GROUND_HALF))
            box = self._ground_box = self._client.createMultiBody(0.0, shape, basePosition=[0.0, 0.0, -GROUND_HALF[2]])
            self._client.setCollisionFilterGroupMask(box, -1, 0, 0)
            self._client.changeDynamics(box, -1, **self._ground_material)
            self._names[box] = self.ground
        self._client.setCollisionFilterPair(self._engine_id(self.ground), engine_id, -1, -1, int(not on))
        self._client.setCollisionFilterPair(box, engine_id, -1, -1, int(on))
        if on:
            self._on_box.add(engine_id)
        else:
            self._on_box.discard(engine_id)

    def make_debris(self, bodies: Sequence[int]) -> list[int]:
        """Re-create in maximal coordinates (pybullet's rigid bodies) each of ``bodies`` that
        is a multibody pybullet moves (mass above 0), at the same pose and velocity, under the
        same id; returns the ids re-created.

        A step of a settling heap of rigid bodies costs pybullet about half what it costs in
        multibodies (docs/results/collapse-phase.md).
        """
        made = []
        for body in bodies:
            spec = self._multibodies.get(body)
            if spec is None or body in self._shelf or body in self._merged:
                continue  # created rigid, static, or a part of a merged body
            engine_id = self._engine_id(body)
            mass = float(self._client.getDynamicsInfo(engine_id, -1)[0])
            if mass == 0.0:
                continue  # frozen or parked: pybullet does not move it
            (position, orientation), (linear, angular) = self._read_pose(engine_id), self._read_velocity(engine_id)
            self._remove(body)
            self._put(body, spec, position, orientation, mass, True)
            self._client.resetBaseVelocity(self._engine_id(body), linear, angular)
            made.append(body)
        return made

    def _material(self, body: int, friction: float, restitution: float) -> None:
        self._client.changeDynamics(self._engine_id(body), -1, **self._dynamics(friction, restitution))

    def _dynamics(self, friction: float, restitution: float) -> dict[str, float]:
        """pybullet's dynamics of a body of a material of ``friction`` and ``restitution`` (each
        the square root: pybullet multiplies a pair's)."""
        return {
            "lateralFriction": math.sqrt(friction),
            "restitution": math.sqrt(restitution),
            "frictionAnchor": int(self._engine.friction_anchors),
        }

    # reading ------------------------------------------------------------------
    def _pose_now(self, body: int) -> Any:
        """pybullet's (position, orientation) of ``body``, read once between steps (a brick the
        soft landing watches is read after a step by the collapse monitor and again before the
        next one; an admission reads its brick's pose seven times); a shelved body's as it was
        shelved. A pose is only changed by a step and by the calls that put a body somewhere,
        each of which forgets the body's pose read."""
        shelved = self._shelf.get(body)
        if shelved is not None:
            return shelved[0], shelved[1]
        read = self._poses.get(body)
        if read is None:
            if body in self._merged:
                read = self._poses[body] = self._part_pose(*self._merged[body])
            else:
                read = self._poses[body] = self._read_pose(self._ids.get(body, body))
        return read

    def _velocity_now(self, body: int) -> Any:
        """pybullet's (linear, angular) velocity of ``body`` this step, read once."""
        read = self._velocities.get(body)
        if read is None:
            if body in self._merged:
                self._part_velocities(self._merged[body][0])
                return self._velocities[body]
            else:
                read = _AT_REST if body in self._shelf else self._read_velocity(self._ids.get(body, body))
            self._velocities[body] = read
        return read

    # the per-step tests ask these of every moving brick at every step: what was read answers at once
    def pose_floats(self, body: int) -> tuple[Vec3, Quat]:
        read: tuple[Vec3, Quat] | None = self._poses.get(body)  # never a shelved body's
        return self._pose_now(body) if read is None else read

    def velocity_floats(self, body: int) -> tuple[Vec3, Vec3]:
        read: tuple[Vec3, Vec3] | None = self._velocities.get(body)
        return self._velocity_now(body) if read is None else read

    def speeds(self, body: int) -> tuple[float, float]:
        read = self._velocities.get(body)
        linear, angular = self._velocity_now(body) if read is None else read
        return math.hypot(*linear), math.hypot(*angular)

    def contact_points(self, bodies: Collection[int] | None = None) -> list[ContactPoint]:
        if bodies is not None:
            bodies = [b for b in bodies if b not in self._shelf]  # static, touching only static bodies
        if not self._groups:
            return super().contact_points(bodies)
        if bodies is None:
            return self._parts(super().contact_points())
        asked = set(bodies)
        merged = sorted({self._merged[b][0] for b in bodies if b in self._merged})
        points = self._parts(super().contact_points([b for b in bodies if b not in self._merged] + merged))
        return [c for c in points if c.body in asked]

    def touches(self, body: int) -> bool:
        """Without building the points (a shelved body touches only static bodies; a merged
        part is answered from its merged body's points)."""
        if body in self._shelf:
            return False
        if body in self._merged:
            return bool(self.contact_points([body]))
        return bool(self._client.getContactPoints(bodyA=self._engine_id(body)))

    def near(self, body: int, distance: float, among: Collection[int] | None = None) -> list[ContactPoint]:
        """A merged body's parts answer for the whole merged body (what is near any of them), each
        point seen from the part it lies nearest; the parts of one merged body are never near
        each other. A shelved body is put back in pybullet's world first, with every shelved
        body within ``distance`` of it (a pull's proof asks what a frozen brick deep in a tower
        slides between: asked of the shelf, it found nothing), to be shelved again when no
        moving body needs them."""
        if body in self._shelf:
            reach = _grown(self._shelf[body][2], distance)
            self._unshelve([b for b, (_, _, box) in self._shelf.items() if _overlap(box, reach)])
            self._look = self._shelves
        if not self._groups:
            return super().near(body, distance, among)
        own = self._merged[body][0] if body in self._merged else body
        wanted = None if among is None else {*among, *(g for g, parts in self._groups.items() if any(b in among for b in parts))}
        if wanted is not None:
            wanted.discard(own)
        points = self._parts(super().near(own, distance, wanted))
        return points if among is None else [c for c in points if c.other in among]

    # merged bodies --------------------------------------------------------------
    def merge(self, bodies: Sequence[int]) -> bool:
        """One body of pybullet's (a one-link multibody: a rigid body given its inertia went to NaN
        in its first step, pybullet 3.2.7) whose collision shape is the boxes of
        the static ``bodies`` where they are (a compound shape), its mass theirs, its inertia the
        diagonal of their inertia tensor about its centre of mass in the world's axes (the
        products of inertia are left out: it slides and turns slowly under a pull), of their
        material; they leave pybullet's world until :meth:`unmerge`. False for fewer than two,
        a body that moves, or materials that differ. A contact point on it names the body whose
        box it lies nearest. Source: stackdsl's own."""
        if len(bodies) < 2 or any(b in self._moving or b in self._merged for b in bodies):
            return False
        specs = [self._made[b][0] for b in bodies]
        if len({(s.friction, s.restitution) for s in specs}) > 1:
            return False
        poses = [self._pose_now(b) for b in bodies]
        positions = np.array([p for p, _ in poses], dtype=float)
        masses = np.array([s.mass for s in specs], dtype=float)
        mass = float(masses.sum())
        centre = masses @ positions / mass
        rotations = Rotation.from_quat([q for _, q in poses])
        tensor = np.zeros((3, 3))
        for spec, r, arm in zip(specs, rotations, positions - centre, strict=True):
            matrix = r.as_matrix()
            tensor += matrix @ np.diag(_box_inertia(spec.half_extents, spec.mass)) @ matrix.T
            tensor += spec.mass * (float(arm @ arm) * np.eye(3) - np.outer(arm, arm))
        shape = self._client.createCollisionShapeArray(
            shapeTypes=[self._p.GEOM_BOX] * len(bodies),
            halfExtents=[list(s.half_extents) for s in specs],
            collisionFramePositions=(positions - centre).tolist(),
            collisionFrameOrientations=[list(q) for _, q in poses],
        )
        engine_id = self._client.createMultiBody(
            baseMass=mass, baseCollisionShapeIndex=shape, basePosition=centre.tolist(), useMaximalCoordinates=False
        )
        group, self._next = self._next, self._next + 1
        self._bind(group, engine_id)
        self._material(group, specs[0].friction, specs[0].restitution)
        self._client.changeDynamics(engine_id, -1, localInertiaDiagonal=np.diag(tensor).tolist())
        low, high = positions.min(axis=0), positions.max(axis=0)
        reach = max(max(s.half_extents) for s in specs)
        hx, hy, hz = ((high - low) / 2 + reach).tolist()
        half = (hx, hy, hz)
        self._made[group] = (
            BrickSpec(
                type=specs[0].type, half_extents=half, mass=mass, friction=specs[0].friction, restitution=specs[0].restitution
            ),
            False,
        )
        for index, body in enumerate(bodies):
            if body in self._shelf:
                del self._shelf[body]
                self._shelf_box = None
            else:
                self._remove(body)
            self._still.pop(body, None)
            self._merged[body] = (group, index)
        self._groups[group] = tuple(bodies)
        halves = np.array([s.half_extents for s in specs], dtype=float)
        turns = tuple((float(x), float(y), float(z), float(w)) for x, y, z, w in rotations.as_quat())
        self._frames[group] = _Parts(positions - centre, turns, rotations.inv().as_matrix(), halves)
        self._massed(group, mass)
        self._velocities[group] = _AT_REST
        return True

    def merged_groups(self) -> Mapping[int, tuple[int, ...]]:
        return self._groups  # a merged body's id is never taken again

    def unmerge(self, bodies: Sequence[int]) -> None:
        """Each of ``bodies`` a static body of pybullet's again, where its box of the merged body
        is; the merged body leaves the world."""
        group = self._merged[bodies[0]][0]
        self._part_poses(group)
        self._part_velocities(group)
        self._carried.update({b: self._velocities[b] for b in self._groups[group]})
        poses = {b: self._poses[b] for b in self._groups.pop(group)}
        for body, (position, orientation) in poses.items():
            del self._merged[body]
            self._poses.pop(body, None)
            self._velocities.pop(body, None)
            spec, maximal = self._made[body]
            self._put(body, spec, list(position), list(orientation), spec.mass, maximal)  # made with a mass: it moves when woken
            self._client.changeDynamics(self._engine_id(body), -1, mass=0.0)
            self._massed(body, 0.0)
        self._remove(group)
        self._moving.discard(group)
        del self._made[group], self._frames[group]

    def _part_poses(self, group: int) -> None:
        """Where each body merged in ``group`` is this step (its box of the merged body), read for
        all of them at once (as they come apart): each arm turned by the merged body's matrix,
        the arms as one stack of columns (to the bit each arm's own product, :meth:`_part_pose`;
        a product with the arms' rows as one array rounds differently), then the turns' Hamilton
        products in floats (numpy's fixed costs on arrays of a few are more than twenty products)."""
        parts = self._frames[group]
        (x, y, z), turn = self._pose_now(group)
        arms = (self._turned(turn) @ parts.arms[:, :, None])[:, :, 0].tolist()
        poses = self._poses
        for body, (px, py, pz), part_turn in zip(self._groups[group], arms, parts.turns, strict=True):
            poses[body] = ((x + px, y + py, z + pz), _product(turn, part_turn))

    def poses_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """The parts of a merged body asked together are read together (:meth:`_part_poses`)."""
        if self._groups:
            merged, poses = self._merged, self._poses
            for group in {merged[b][0] for b in bodies if b in merged and b not in poses}:
                self._part_poses(group)
        return super().poses_of(bodies)

    def _part_pose(self, group: int, index: int) -> tuple[Vec3, Quat]:
        """Where the ``index``-th body merged in ``group`` is this step, alone (:meth:`_part_poses`'
        arithmetic: a ride's rules and the collapse monitor read one brick of a ride of twenty a
        step, :meth:`stackdsl.runtime.bricks.Structure.displacements`)."""
        parts = self._frames[group]
        (x, y, z), turn = self._pose_now(group)
        px, py, pz = (self._turned(turn) @ parts.arms[index]).tolist()
        return (x + px, y + py, z + pz), _product(turn, parts.turns[index])

    def _turned(self, turn: Quat) -> np.ndarray:
        """:meth:`_matrix` of a merged body's ``turn`` as read this step, once for all its parts
        (the collapse monitor reads twenty bricks riding a shaken ground every step)."""
        if self._last_turn[0] is not turn:
            self._last_turn = (turn, self._matrix(turn))
        return self._last_turn[1]

    def _matrix(self, turn: Quat) -> np.ndarray:
        """The rotation matrix (shape (3, 3)) of quaternion ``turn`` (x, y, z, w), by pybullet
        (in double precision, a microsecond; scipy's Rotation takes a hundred)."""
        return np.array(self._client.getMatrixFromQuaternion(turn), dtype=float).reshape(3, 3)

    def _part_velocities(self, group: int) -> None:
        """How each body merged in ``group`` moves this step, for all of them at once (see
        :meth:`_part_poses`): the merged body's velocity at its centre plus its spin crossed with
        the body's arm, v + w x r, and its spin."""
        (vx, vy, vz), (wx, wy, wz) = self._velocity_now(group)
        arms = (self._turned(self._pose_now(group)[1]) @ self._frames[group].arms[:, :, None])[:, :, 0].tolist()
        spin = (float(wx), float(wy), float(wz))
        velocities = self._velocities
        for body, (rx, ry, rz) in zip(self._groups[group], arms, strict=True):
            velocities[body] = ((vx + wy * rz - wz * ry, vy + wz * rx - wx * rz, vz + wx * ry - wy * rx), spin)

    def _parts(self, points: list[ContactPoint]) -> list[ContactPoint]:
        """``points`` with a merged body named as the body whose box the point lies nearest."""
        out, frames = [], {}  # merged body -> its position and inverse rotation, read once a call
        for c in points:
            body, other = c.body, c.other
            for end in (body, other):
                if end in self._groups and end not in frames:
                    position, turn = self._pose_now(end)
                    frames[end] = (np.asarray(position, dtype=float), self._matrix(turn))
            if body in frames:
                body = self._part_at(body, c.position, *frames[body])
            if other in frames:
                other = self._part_at(other, c.position, *frames[other])
            same = body == c.body and other == c.other
            out.append(c if same else ContactPoint(body, other, c.position, c.normal, c.normal_force, c.distance))
        return out

    def _part_at(self, group: int, point: np.ndarray, position: np.ndarray, matrix: np.ndarray) -> int:
        """The body merged into ``group`` (at ``position``, turned by the rotation ``matrix``,
        shape (3, 3)) whose box lies nearest ``point`` (m, world)."""
        parts = self._frames[group]
        local = (np.asarray(point, dtype=float) - position) @ matrix  # in the merged body
        inside = np.einsum("nij,nj->ni", parts.back, local - parts.arms)  # in each box's own axes
        outside = np.linalg.norm(np.maximum(np.abs(inside) - parts.halves, 0.0), axis=1)
        return self._groups[group][int(np.argmin(outside))]

    # changing -----------------------------------------------------------------
    def set_frozen(self, body: int, frozen: bool, mass: float, at: Pose | None = None) -> None:
        self._velocities.pop(body, None)
        self._poses.pop(body, None)
        if body in self._shelf:
            self._unshelve([body])
        super().set_frozen(body, frozen, mass, at)
        self._massed(body, 0.0 if frozen else mass)
        carried = None if frozen else self._carried.get(body)
        if carried is not None:  # unmerged this step: it moves on as it rode
            self._client.resetBaseVelocity(self._engine_id(body), *carried)
        if frozen:
            self._recent.append(body)
            self._look = self._shelves

    def move(self, body: int, pose: Pose, mass: float) -> None:
        self._velocities.pop(body, None)
        self._poses.pop(body, None)
        if body in self._shelf:
            self._unshelve([body])
        engine_id = self._engine_id(body)
        self._client.resetBasePositionAndOrientation(engine_id, pose.position.tolist(), pose.orientation.tolist())
        self._client.resetBaseVelocity(engine_id, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])  # the pose alone keeps them
        if self._guided.pop(body, None) is not None:  # let go of: its own inertia back
            inertia = _box_inertia(self._made[body][0].half_extents, max(mass, 1e-9))
            self._client.changeDynamics(engine_id, -1, mass=mass, localInertiaDiagonal=inertia)
        else:
            self._client.changeDynamics(engine_id, -1, mass=mass)
        self._massed(body, mass)
        if mass > 0.0:
            self._velocities[body] = _AT_REST

    def guide(self, body: int, pose: Pose, velocity: Vec3, hold: bool = True) -> None:
        self._velocities.pop(body, None)
        self._poses.pop(body, None)
        if body in self._shelf:
            self._unshelve([body])
        engine_id = self._engine_id(body)
        spec = self._made[body][0]
        if body not in self._guided:
            mass = float(self._client.getDynamicsInfo(engine_id, -1)[0]) or spec.mass
            self._guided[body] = mass
            if hold:
                inertia = _box_inertia(spec.half_extents, GUIDED_MASS)
                self._client.changeDynamics(engine_id, -1, mass=GUIDED_MASS, localInertiaDiagonal=inertia)
            self._massed(body, GUIDED_MASS if hold else mass)
        position, orientation, held = pose.position.tolist(), pose.orientation.tolist(), GUIDED_MASS if hold else None
        self._paths[engine_id] = (position, orientation, velocity, held)
        self._drive(engine_id, position, orientation, velocity, held)

    def _drive(
        self,
        engine_id: int,
        position: Any,
        orientation: Any,
        velocity: Vec3,
        held: float | None,
        step: float | None = None,
        force: bool = True,
    ) -> None:
        """Drive a body along its path through the next step by its velocity alone: the path's
        velocity plus :data:`GAIN` of the way back to ``position`` and ``orientation`` (where the
        path is now) in the step. pybullet loses the contacts of a body whose pose is reset each
        step: a brick slid so over the ground plane fell through it. With ``held`` (kg) the body's
        height is driven too and its weight held up by a force for the step; else its vertical
        motion is the engine's. ``step``: seconds until the body is driven again (a substep of
        :meth:`step`'s own; the timestep by default); ``force``: False when the step's weight
        holding force is already applied."""
        (x, y, z), now = self._read_pose(engine_id)
        (_, _, vz), _ = self._read_velocity(engine_id)
        rate = GAIN / (step or self._engine.timestep)
        vx, vy = velocity[0] + rate * (position[0] - x), velocity[1] + rate * (position[1] - y)
        if held is not None:
            vz = velocity[2] + rate * (position[2] - z)
        if held is not None and force:
            self._client.applyExternalForce(
                engine_id, -1, [0.0, 0.0, held * self._engine.gravity], [x, y, z], self._p.WORLD_FRAME
            )
        tx, ty, tz = _turn(now, orientation)
        self._client.resetBaseVelocity(engine_id, [vx, vy, vz], [tx * rate, ty * rate, tz * rate])
        self._due = 0

    carries = True

    def carry(self, body: int, pose: Pose, velocity: Vec3) -> None:
        self._velocities.pop(body, None)
        self._poses.pop(body, None)
        engine_id = self._engine_id(body)
        self._client.resetBasePositionAndOrientation(engine_id, pose.position.tolist(), pose.orientation.tolist())
        self._client.resetBaseVelocity(engine_id, [float(v) for v in velocity], [0.0, 0.0, 0.0])
        # A reset pose drops the body's contacts until the next step finds them, and that step let a
        # brick carried along the ground fall free: 0.13 mm down and 0.12 deg over after each 5 mm
        # glide (0.19 mm and 0.21 deg at worst over a 200 mm pull at 5 mm/s; stepped, 0.001 mm and
        # 0.005 deg). Found again now, the step holds it as a stepped one does: 0.002 mm, 0.011 deg.
        self._client.performCollisionDetection()
        self._due = 0

    def move_ground(self, offset: Vec3, velocity: Vec3) -> None:
        if not self._table:
            raise NotImplementedError("this world's ground is a static plane: make it with movable_ground=True")
        self._ground_at = (offset, velocity)
        self._velocities.pop(self.ground, None)

    def throw(self, body: int, velocity: Vec3, swept_radius: float | None) -> None:
        self._velocities.pop(body, None)
        if body in self._shelf:
            self._unshelve([body])
        engine_id = self._engine_id(body)
        if swept_radius is not None:
            self._swept[body] = swept_radius
            self._client.changeDynamics(engine_id, -1, ccdSweptSphereRadius=swept_radius)
        linear = (float(velocity[0]), float(velocity[1]), float(velocity[2]))
        self._client.resetBaseVelocity(engine_id, linear, (0.0, 0.0, 0.0))
        if body in self._moving:  # pybullet reads back what it was given, to the bit, until the next step
            self._velocities[body] = (linear, (0.0, 0.0, 0.0))
        self._due = 0

    def step(self) -> None:
        self._carried.clear()
        if self._shelf or self._look:
            self._reach()
        if self._table:  # held where the shake puts it, every step (it is a dynamic body)
            (x, y, z), velocity = self._ground_at
            self._drive(self.ground, [x, y, z - TABLE_HALF[2]], [0.0, 0.0, 0.0, 1.0], velocity, TABLE_MASS)
        self._velocities.clear()
        self._poses.clear()
        split = self._substeps > 1 and bool(self._paths or self._table)
        if split != self._split:
            self._stepping(split)
        pulled = {engine_id for engine_id, path in self._paths.items() if path[3] is None}
        if pulled != self._anchored:
            self._anchor(pulled)
        if split:
            self._split_step()
        else:
            self._client.stepSimulation()
        self._paths.clear()

    def _split_step(self) -> None:
        """One step as :attr:`_substeps` calls of pybullet's step, each a substep long, a guided
        body (and a shaken ground) driven along its path before each: with pybullet's own
        substeps (``numSubSteps``) a body is driven once, before the first, and a pulled brick,
        stopped by friction in the others, moved in jerks under what it carried (a brick lying on one pulled 50 mm at 20 mm/s rode 37 mm of it, against 50 at a
        1/960 s timestep). Source: stackdsl's own."""
        h = self._engine.timestep / self._substeps
        for k in range(self._substeps):
            for engine_id, (position, orientation, velocity, held) in self._paths.items():
                there = [p + v * k * h for p, v in zip(position, velocity)]
                self._drive(engine_id, there, orientation, velocity, held, h, force=k > 0)
            if self._table:
                (x, y, z), velocity = self._ground_at
                there = [x + velocity[0] * k * h, y + velocity[1] * k * h, z - TABLE_HALF[2] + velocity[2] * k * h]
                self._drive(self.ground, there, [0.0, 0.0, 0.0, 1.0], velocity, TABLE_MASS, h, force=k > 0)
            self._client.stepSimulation()

    def _anchor(self, pulled: set[int]) -> None:
        """Friction anchors (pybullet's ``frictionAnchor``, which holds a sticking contact where it
        first touched) on the bricks a hand drives along a path without holding them up (engine
        ids ``pulled``: a pulled brick, a pushed one its proof moves on the finger's path), and the
        engine's own setting again on those it no longer drives. Without them pybullet's solver,
        stopped at its 50 iterations, lets a brick lying on a pulled one slip: 3.2 mm of a 50 mm
        pull at 10 mm/s, where static friction carries it all the way (0.04 mm while it is
        accelerated). On every body instead, as until 2026-11-29, they held the bricks a pull drags
        by their other contacts too, and stood near ties that every other engine and mode fell: a
        side block of level 3 of a 5-level Jenga tower (levels 4 and 5 dragged 4.8 mm at 40 mm/s,
        9.7 mm with the pulled brick's alone, 16 to 20 mm with none); a side block of level 9 of a
        10-level tower at friction 0.45 (the top level dragged 7.1 mm: 22 to 169 mm at six of seven
        speeds with the pulled brick's alone, 3 to 4 mm at ten of twelve with none). Measured by
        docs/results/pull_anchors.py. Source: stackdsl's own."""
        own = int(self._engine.friction_anchors)
        for engine_id in pulled - self._anchored:
            self._client.changeDynamics(engine_id, -1, frictionAnchor=1)
        for engine_id in self._anchored - pulled:
            self._client.changeDynamics(engine_id, -1, frictionAnchor=own)
        self._anchored = set(pulled)

    def _stepping(self, split: bool) -> None:
        """Step in substeps of :meth:`_split_step` (``split``) or pybullet's own."""
        if split:
            self._client.setPhysicsEngineParameter(fixedTimeStep=self._engine.timestep / self._substeps, numSubSteps=0)
        else:
            self._client.setPhysicsEngineParameter(
                fixedTimeStep=self._engine.timestep, numSubSteps=self._substeps if self._substeps > 1 else 0
            )
        self._split = split

    def set_substeps(self, substeps: int) -> None:
        if substeps != self._substeps:
            self._substeps = substeps
            if self._split:
                self._stepping(substeps > 1)
            else:
                self._client.setPhysicsEngineParameter(numSubSteps=substeps if substeps > 1 else 0)

    def velocities_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        v = [self._get_velocity(b) for b in bodies]
        return np.array([lin for lin, _ in v]).reshape(-1, 3), np.array([ang for _, ang in v]).reshape(-1, 3)

    # the shelf ----------------------------------------------------------------
    @property
    def shelved(self) -> frozenset[int]:
        """The bodies out of pybullet's world now (static, out of every moving body's reach)."""
        return frozenset(self._shelf)

    def _box(self, body: int, margin: float) -> _Box:
        """``body``'s bounding box in the world, grown by ``margin`` metres."""
        low, high = self._read_box(self._ids.get(body, body))
        return _grown((*low, *high), margin)

    def _speed(self, body: int) -> float:
        """m/s: how fast any point of a moving ``body`` moves (its speed, and its spin at its corners)."""
        (linear, angular), half = self._velocity_now(body), self._made[body][0].half_extents
        return math.hypot(*linear) + math.hypot(*angular) * math.hypot(*half)

    def _reach(self) -> None:
        """Before a step: put back what a moving body may reach before the shelf is looked at
        again; after a freeze, shelve what none can. The shelf is looked at again after as many
        steps (at least one) as no moving body can travel half :data:`REACH` in, at twice the
        fastest one's speed (what a collision may give it) and falling: one to eight steps of
        1/240 s while a brick settles; what lies within :data:`REACH` and that travel of a
        moving body is put back."""
        if len(self._moving) > CROWD:
            self._unshelve(list(self._shelf))
            self._look = False
            return
        if self._shelf and self._moving:
            if self._due > 0:
                self._due -= 1
            else:
                steps, travel = self._quiet(max(self._speed(b) for b in self._moving))
                if self._shelf_box is None:
                    self._shelf_box = _union([box for _, _, box in self._shelf.values()])
                shelf_box = self._shelf_box
                hit = [z for z in (self._box(b, REACH + travel) for b in self._moving) if _overlap(z, shelf_box)]
                if hit:
                    self._unshelve([b for b, (_, _, box) in self._shelf.items() if any(_overlap(box, z) for z in hit)])
                self._due = steps - 1
        if self._look:
            self._look = False
            self._shelve_out_of_reach()

    def _quiet(self, fastest: float) -> tuple[int, float]:
        """The steps (at least one) in which nothing moving at up to twice ``fastest`` m/s, and
        falling, travels half :data:`REACH`, and how far it may travel in them (m)."""
        dt, gravity = self._engine.timestep, self._engine.gravity
        fall = gravity * dt * dt  # the travel's terms in their own order: the same bits
        steps, half = 1, REACH / 2
        while steps < 64 and dt * (steps + 1) * 2.0 * fastest + fall * (steps + 1) * (steps + 2) / 2 <= half:
            steps += 1
        return steps, dt * steps * 2.0 * fastest + fall * steps * (steps + 1) / 2

    def _shelve_out_of_reach(self) -> None:
        """Shelve every static body :data:`SHELVE` from each moving body (and what it may travel
        before the shelf is looked at again: a brick thrown at 50 m/s flies 21 cm in a step) and
        from each of the bodies frozen last."""
        if self._still:
            travel = self._quiet(max(self._speed(b) for b in self._moving))[1] if self._moving else 0.0
            keep = [self._box(b, SHELVE + travel) for b in self._moving]
            keep += [_grown(self._still_box(b), SHELVE) for b in self._recent if b in self._still]
            for body in sorted(self._still):
                box = self._still_box(body)
                for z in keep:
                    if _overlap(box, z):
                        break
                else:  # out of every moving body's reach, and of the last frozen
                    self._shelve(body, box)

    def _still_box(self, body: int) -> _Box:
        """The bounding box of a static body in pybullet's world, read once."""
        box = self._still[body]
        if box is None:
            box = self._still[body] = self._box(body, 0.0)
        return box

    def _shelve(self, body: int, box: _Box) -> None:
        position, orientation = self._read_pose(self._engine_id(body))
        self._remove(body)
        del self._still[body]
        self._shelf[body] = (position, orientation, box)
        if self._shelf_box is not None:
            self._shelf_box = _union([self._shelf_box, box])

    def _unshelve(self, bodies: Sequence[int]) -> None:
        for body in sorted(bodies):
            position, orientation, _ = self._shelf.pop(body)
            spec, maximal = self._made[body]
            self._put(body, spec, position, orientation, 0.0, maximal)
        self._shelf_box = None


def _product(a: Quat, b: Quat) -> Quat:
    """The quaternion (x, y, z, w) of turning by ``b``, then by ``a`` (Hamilton's product ``a b``).
    In plain floats: pybullet's ``multiplyTransforms`` rounds to single precision (2e-7), scipy's
    Rotation costs 0.1 ms a call. Source: Hamilton's product."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def _turn(now: Quat, to: Quat) -> Vec3:
    """The shortest turn (rotation vector, rad) from orientation ``now`` to ``to`` (quaternions
    x, y, z, w), in the world's axes. pybullet's ``getAxisAngleFromQuaternion`` reads a turn under
    0.04 deg as none (single precision); this is exact to double precision for every angle.
    Source: the quaternion's logarithm, 2 atan2(|v|, w) v / |v|."""
    x, y, z, w = _product(to, (-now[0], -now[1], -now[2], now[3]))
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    sine = math.sqrt(x * x + y * y + z * z)
    if sine < 1e-300:
        return (0.0, 0.0, 0.0)
    scale = 2.0 * math.atan2(sine, w) / sine
    return (x * scale, y * scale, z * scale)


def _box_inertia(half_extents: Vec3, mass: float) -> list[float]:
    """The principal moments of inertia (kg m^2) of a uniform box of ``half_extents`` (m)."""
    a, b, c = (2.0 * h for h in half_extents)
    return [mass / 12.0 * (b * b + c * c), mass / 12.0 * (a * a + c * c), mass / 12.0 * (a * a + b * b)]


class _Parts(NamedTuple):
    """The boxes of a merged body, in the order of its bodies: where each lies from its centre of
    mass (m, shape (n, 3)), turned as (quaternions x, y, z, w), that turn's inverse as matrices
    (shape (n, 3, 3)) and its half extents (m, shape (n, 3))."""

    arms: np.ndarray
    turns: tuple[Quat, ...]
    back: np.ndarray
    halves: np.ndarray


_Box = tuple[float, float, float, float, float, float]
"""A bounding box: its lowest x, y, z and its highest, metres."""


def _union(boxes: Sequence[_Box]) -> _Box:
    """The bounding box of ``boxes`` (at least one)."""
    x0, y0, z0, x1, y1, z1 = zip(*boxes, strict=True)
    return min(x0), min(y0), min(z0), max(x1), max(y1), max(z1)


def _grown(box: _Box, margin: float) -> _Box:
    """``box`` grown by ``margin`` metres on every side."""
    return box[0] - margin, box[1] - margin, box[2] - margin, box[3] + margin, box[4] + margin, box[5] + margin


def _overlap(a: _Box, b: _Box) -> bool:
    """Do the boxes ``a`` and ``b`` overlap?"""
    return a[0] <= b[3] and a[1] <= b[4] and a[2] <= b[5] and a[3] >= b[0] and a[4] >= b[1] and a[5] >= b[2]

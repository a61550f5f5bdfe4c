"""The world on MuJoCo: :class:`MuJoCoWorld`, a :class:`stackdsl.engines.protocol.World` through MuJoCo's public API.

MuJoCo compiles a model before it simulates, and a model's bodies are fixed when it is
compiled. Bodies are declared to an ``mujoco.MjSpec``; the model is compiled when the
world is first stepped or read, and compiled again, keeping the state (``MjSpec.recompile``),
when a body is created after that. ``RunOptions(lazy_bodies=False)`` declares every brick
up front, frozen and far away, so that the model is compiled once.

Each brick is two bodies of the same box: a *free* body (a free joint), which the engine
simulates, and a *held* body (a mocap body, which the engine moves only when told), which
stands in for it while it is frozen. Freezing puts the held body at the free body's pose
and takes the free body out of the scene (collisions off, gravity compensated, far away,
at rest; asleep in extension mode); restoring does the opposite. A frozen brick is then static geometry: it
costs no degrees of freedom and MuJoCo makes no contacts between two frozen bricks, as
pybullet makes none between two bodies of mass 0 (docs/design.md, "MuJoCo", gives the measurements
that chose this over a weld equality or MuJoCo's own sleeping).

Frozen bricks that ride a pull or a shaken ground (:meth:`MuJoCoWorld.merge`) become one more
free body whose geoms are their boxes where they lie, added to the spec and compiled again; each
brick's own two bodies leave the collisions meanwhile, and a brick's pose and velocity are read
from the merged body's. Unmerged, the body leaves the spec and each brick is frozen where its box
was carried.

Materials (friction of a pair, restitution, density): :mod:`stackdsl.engines.mujoco.materials`.

While a hand holds a brick, a step is ``mj_step``'s stages run one by one, so that the hand
strikes what it meets before MuJoCo steps and the friction of what it struck is limited while
that slides (:mod:`stackdsl.engines.mujoco.hands`). With no hand at work, and nothing it struck
still sliding, a step is ``mj_step``'s, bit for bit.

Source: stackdsl's own, on MuJoCo 4.0's Python bindings.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from stability import ContactPoint, Pose

from ..protocol import BrickSpec, EngineUnstable, Quat, Vec3, World
from .culling import Culling
from .hands import BLOW_SKIN, Grip, Hands
from .materials import Bounce, Materials
from .settings import MuJoCoSettings

#: Where the free body of a frozen brick waits, and the held body of an active one: far
#: from any scene (positions are within 1 km), one slot per brick so that none overlap.
_AWAY = np.array([5000.0, 5000.0, 100.0])
_SLOT = 0.5  # m between two waiting bodies
_WAITING_SLEEP = 1e-4  # MuJoCo's sleep tolerance in extension mode, where only waiting bodies (still) sleep
#: The share of a guided body's distance from its path that its velocity makes up in one step.
GAIN = 0.5
#: kg and half extents (m) of a movable ground: a box whose top is the plane z = 0 (at 1e5 kg
#: MuJoCo's tuned solver let a 20 x 20 x 80 mm block on it tip at 1% of its tipping acceleration).
TABLE_MASS = 100.0
TABLE_HALF = (5.0, 5.0, 0.5)


class MuJoCoWorld(World):
    """:class:`stackdsl.engines.protocol.World` on MuJoCo (see the module's docstring).

    Args:
        engine: the run's engine settings (``backend: mujoco``).
        ground_friction, ground_restitution: of the ground's material.

    Body ids are stackdsl's: 0 is the ground, bricks are numbered from 1 as they are
    created; a brick keeps its id whether frozen (its held body) or not. Whether each brick
    is frozen is kept in one array, as are its bodies' addresses in the compiled model
    (found again at each compile), so that many bricks are read at once.

    >>> from stackdsl.engines.mujoco.settings import MuJoCoSettings
    >>> from stackdsl.engines.protocol import BrickSpec
    >>> world = MuJoCoWorld(MuJoCoSettings(mode="raw", timestep=0.002, solver_iterations=100), 0.5, 0.0)
    >>> b = world.create(BrickSpec(type="kapla", half_extents=(0.06, 0.012, 0.004), mass=0.0106, friction=0.5, restitution=0.0), Pose.from_euler([0, 0, 0.0045]))
    >>> for _ in range(200): world.step()
    >>> round(float(world.pose(b).position[2]), 4)
    0.004
    """

    near_is_geometric = True  # mj_geomDistance: the impact rule asks only near frozen bricks

    def __init__(
        self, engine: MuJoCoSettings, ground_friction: float, ground_restitution: float, *, movable_ground: bool = False
    ) -> None:
        import mujoco

        mujoco.set_mju_user_warning(_quiet)  # printed, MuJoCo's warnings would mix with --json: step() raises

        self._mj, self._engine = mujoco, engine
        self._extension = engine.mode == "extension"  # bricks as convex meshes (see create), waiting ones asleep
        self._elliptic = engine.elliptic_cones  # friction rows apart from the normal one: see Hands.solve
        self._hands = Hands(mujoco, engine.gravity)  # guided bricks and what they struck
        self.ground = 0
        self._substeps = 1
        self._specs: list[BrickSpec] = []
        self._meshes: dict[Vec3, str] = {}  # half extents -> the name of its convex mesh (extension mode)
        self._model: Any = None
        self._data: Any = None
        self._frozen = np.zeros(0, dtype=bool)
        # addresses in the compiled model, per brick: qpos and dof of its free joint, its mocap
        # index, its free and held geoms; geom -> stackdsl body id
        self._qpos = self._dof = self._mocap = self._free_geom = self._held_geom = np.zeros(0, dtype=int)
        self._qpos7 = np.zeros((0, 7), dtype=int)  # each free joint's 7 qpos addresses
        self._geom_body = np.zeros(0, dtype=int)
        self._read: tuple[np.ndarray, np.ndarray] | None = None  # every body's velocities, this step
        self._placed = True  # positions moved since MuJoCo last computed its geoms' poses: see near
        self._solref = (np.zeros(0), np.zeros(0))  # geoms' and pairs' contact time constants as compiled (s)
        self._bounce: Bounce | None = None  # which contacts bounce, in a world with a restitution
        self._culling: Culling | None = None  # which frozen bricks nothing moving can reach
        self._dof6 = np.zeros((0, 6), dtype=int)
        # merged bodies (see merge): group -> its bricks, its spec body and pairs; brick -> its
        # group, its arm (3,) in the group's frame and its turn (w, x, y, z) in it; each group's
        # free joint's qpos and dof address and geoms in the compiled model
        self._groups: dict[int, _Group] = {}
        self._part_of: dict[int, tuple[int, np.ndarray, np.ndarray]] = {}
        self._next_group = 0
        self._carried: dict[int, tuple[Vec3, Vec3]] = {}  # brick unmerged this step -> the velocity it rode with
        spec = mujoco.MjSpec()
        option = spec.option
        option.timestep = engine.timestep
        option.gravity = [0.0, 0.0, -engine.gravity]
        option.iterations = engine.solver_iterations
        option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC if engine.elliptic_cones else mujoco.mjtCone.mjCONE_PYRAMIDAL
        option.impratio = engine.impratio
        option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{engine.integrator.upper()}")
        if engine.sleep_tolerance is not None or self._extension:
            option.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
            option.sleep_tolerance = engine.sleep_tolerance or _WAITING_SLEEP
        self._spec = spec
        self._table = movable_ground
        self._ground_at: tuple[Vec3, Vec3] = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        if movable_ground:  # a heavy box on two slide joints, its top the plane z = 0 (MuJoCo's planes are static)
            table = spec.worldbody.add_body(name="table", pos=[0.0, 0.0, -TABLE_HALF[2]])
            for axis, name in (([1.0, 0.0, 0.0], "table_x"), ([0.0, 1.0, 0.0], "table_y")):
                table.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis)
            ground = table.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(TABLE_HALF), mass=TABLE_MASS)
        else:
            ground = spec.worldbody.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0.0, 0.0, 1.0])
        # MuJoCo compensates gravity only in a model compiled with a body that asks for it; this
        # static body (no joint, no geom) does, so that a waiting body's switch works at run time
        spec.worldbody.add_body(name="gravcomp", gravcomp=1.0)
        self._materials = Materials(engine, (ground_friction, ground_restitution))
        self._materials.surface(ground, ground_friction, ground_restitution)

    # building -----------------------------------------------------------------
    def create(self, spec: BrickSpec, pose: Pose, mass: float | None = None, projectile: bool = False) -> int:
        """A new brick at ``pose``; ``mass`` 0 creates it frozen. MuJoCo needs nothing special for a ``projectile``."""
        body = len(self._specs) + 1
        frozen = mass is not None and mass <= 0.0
        free_at, held_at = (self._away(body), pose.position) if frozen else (pose.position, self._away(body))
        free = self._spec.worldbody.add_body(name=f"free{body}", pos=list(free_at), quat=_wxyz(pose.orientation))
        free.add_freejoint(name=f"joint{body}")
        held = self._spec.worldbody.add_body(name=f"held{body}", pos=list(held_at), quat=_wxyz(pose.orientation), mocap=True)
        # With the extension, a convex mesh of the box's eight corners, not MuJoCo's box primitive:
        # the box-box collider gives two bricks crossed at an odd yaw a single contact point every
        # 16 to 30 ms, which kicks the upper one to 1.2 rad/s, so that it never stays under the
        # rest thresholds (it stayed active to the end of the run); the general convex collider
        # gives a steady set. MuJoCo alone (raw, tuned) keeps its own primitive, at its best.
        hx, hy, hz = spec.half_extents
        mesh = self._meshes.get((hx, hy, hz), f"m{len(self._meshes)}")
        if self._extension and (hx, hy, hz) not in self._meshes:  # one mesh a size: each compiled once
            corners = [c for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1) for c in (sx * hx, sy * hy, sz * hz)]
            self._spec.add_mesh(name=mesh, uservert=corners)
            self._meshes[(hx, hy, hz)] = mesh
        for name, owner in ((f"f{body}", free), (f"h{body}", held)):
            geom = owner.add_geom(name=name, mass=spec.mass, **self._shape(spec))
            self._materials.surface(geom, spec.friction, spec.restitution)
        self._specs.append(spec)
        self._frozen = np.append(self._frozen, frozen)
        names = [f"f{body}", f"h{body}"]
        self._materials.pairs_of(self._spec, names, (spec.friction, spec.restitution), self._named_materials(body))
        if self._model is not None:
            self._compile()
        return body

    def _shape(self, spec: BrickSpec) -> dict[str, Any]:
        """The geom of a brick of ``spec``: the convex mesh of its size (extension mode, made by
        :meth:`create`), else MuJoCo's box."""
        if self._extension:
            return {"type": self._mj.mjtGeom.mjGEOM_MESH, "meshname": self._meshes[spec.half_extents]}
        return {"type": self._mj.mjtGeom.mjGEOM_BOX, "size": list(spec.half_extents)}

    def _named_materials(self, skip: int = 0) -> list[tuple[str, tuple[float, float]]]:
        """Every brick's geoms (``f{i}``, ``h{i}``; brick ``skip``'s left out) and every merged
        geom, each with its material (friction, restitution), in the order their pairs are made."""
        named = [(f"{s}{i}", (b.friction, b.restitution)) for i, b in enumerate(self._specs, 1) if i != skip for s in "fh"]
        return named + [(name, g.material) for g in self._groups.values() for name in g.geom_names]

    def _away(self, body: int) -> np.ndarray:
        return _AWAY + [_SLOT * body, 0.0, 0.0]

    def _compile(self) -> None:
        mj = self._mj
        if self._model is None:
            self._model = self._spec.compile()
            self._data = mj.MjData(self._model)
        else:
            now = float(self._data.time)  # recompile keeps the state but not the clock
            self._model, self._data = self._spec.recompile(self._model, self._data)
            self._data.time = now
        m = self._model
        m.opt.timestep = self._engine.timestep / self._substeps  # a recompile takes the spec's
        self._read = None

        def ids(kind: Any, prefix: str) -> np.ndarray:
            return np.array([mj.mj_name2id(m, kind, f"{prefix}{i}") for i in range(1, len(self._specs) + 1)], dtype=int)

        joints = ids(mj.mjtObj.mjOBJ_JOINT, "joint")
        self._qpos, self._dof = m.jnt_qposadr[joints].astype(int), m.jnt_dofadr[joints].astype(int)
        self._qpos7 = self._qpos[:, None] + np.arange(7)
        self._mocap = m.body_mocapid[ids(mj.mjtObj.mjOBJ_BODY, "held")].astype(int)
        self._free_geom, self._held_geom = ids(mj.mjtObj.mjOBJ_GEOM, "f"), ids(mj.mjtObj.mjOBJ_GEOM, "h")
        self._geom_body = np.zeros(m.ngeom, dtype=int)
        self._geom_body[self._free_geom] = self._geom_body[self._held_geom] = np.arange(1, len(self._specs) + 1)
        self._dof6 = self._dof[:, None] + np.arange(6)
        for k, group in self._groups.items():
            joint = mj.mj_name2id(m, mj.mjtObj.mjOBJ_JOINT, f"mjoint{k}")
            group.qpos, group.dof = int(m.jnt_qposadr[joint]), int(m.jnt_dofadr[joint])
            group.geoms = np.array([mj.mj_name2id(m, mj.mjtObj.mjOBJ_GEOM, n) for n in group.geom_names], dtype=int)
            self._geom_body[group.geoms] = group.bricks
            if self._extension:
                m.tree_sleep_policy[m.body_treeid[m.geom_bodyid[group.geoms[0]]]] = mj.mjtSleepPolicy.mjSLEEP_NEVER
        self._hands.compiled(m)
        self._solref = (m.geom_solref[:, 0].copy(), m.pair_solref[:, 0].copy())  # as compiled: see set_substeps
        self._bounce = None
        # a shake table moves under every brick: nothing is out of its reach
        self._culling = (
            None if self._table else Culling(m, self._held_geom, self._qpos, self._dof, self._mocap, self._engine.timestep)
        )
        if self._materials.bouncy:
            reach = np.array([math.hypot(*b.half_extents) for b in self._specs])
            self._bounce = Bounce(m, self._free_geom, self._geom_body, reach, self._materials.resting())
        if self._substeps > 1:
            self._contact_times()
        for body in range(1, len(self._specs) + 1):
            self._apply(body)
        for body, grip in self._hands.guided.items():  # compiled anew from the spec: in a hand's grip again
            if grip is not None:
                Hands.grip(m, int(m.geom_bodyid[self._free_geom[body - 1]]), int(self._dof[body - 1]), grip)
        if self._table:
            table = [mj.mj_name2id(m, mj.mjtObj.mjOBJ_JOINT, name) for name in ("table_x", "table_y")]
            self._table_qpos = [int(m.jnt_qposadr[j]) for j in table]
            self._table_dof = [int(m.jnt_dofadr[j]) for j in table]
        mj.mj_forward(m, self._data)

    def _ready(self) -> tuple[Any, Any]:
        if self._model is None:
            self._compile()
        return self._model, self._data

    def _apply(self, body: int) -> None:
        """Collisions, gravity compensation and the sleep policy of ``body``'s two bodies for
        its state.

        In extension mode a free body out of the scene (frozen, or not yet placed) is allowed
        to sleep where it waits, at rest: MuJoCo then skips its six degrees of freedom in
        every stage of a step (at 30 levels its step cost 3 times less), and one in the scene
        never sleeps, the extension deciding what rests. A sleeping free body whose position is
        written wakes at the next step (measured on MuJoCo 4.0.0, tests/test_mujoco.py). With
        MuJoCo's own sleeping (``sleep_tolerance``, the tuned peer) a waiting free body never
        sleeps, as the peer was measured (docs/results/mujoco.md)."""
        m, i = self._model, body - 1
        spec = self._specs[i]
        bit = 1 << self._materials.group(spec.friction, spec.restitution)
        free, held = self._free_geom[i], self._held_geom[i]
        on, off = (held, free) if self._frozen[i] else (free, held)
        if body in self._part_of:  # its box is the merged body's: neither of its own collides
            bit = 0
        m.geom_contype[on] = m.geom_conaffinity[on] = bit
        m.geom_contype[off] = m.geom_conaffinity[off] = 0
        m.body_contype[m.geom_bodyid[on]] = m.body_conaffinity[m.geom_bodyid[on]] = bit
        m.body_contype[m.geom_bodyid[off]] = m.body_conaffinity[m.geom_bodyid[off]] = 0
        if self._culling is not None:
            self._culling.changed(i, bool(self._frozen[i]))
        m.body_gravcomp[m.geom_bodyid[free]] = 1.0 if self._frozen[i] else 0.0
        policy, tree = self._mj.mjtSleepPolicy, m.body_treeid[m.geom_bodyid[free]]
        if self._extension:
            m.tree_sleep_policy[tree] = policy.mjSLEEP_ALLOWED if self._frozen[i] else policy.mjSLEEP_NEVER
        elif self._engine.sleep_tolerance is not None:
            m.tree_sleep_policy[tree] = policy.mjSLEEP_NEVER if self._frozen[i] else policy.mjSLEEP_AUTO_ALLOWED

    # stability.Engine ----------------------------------------------------------
    @property
    def timestep(self) -> float:
        return self._engine.timestep

    def pose(self, body: int) -> Pose:
        (px, py, pz), (x, y, z, w) = self._raw_pose(body - 1)
        return Pose(np.array([px, py, pz]), np.array([x, y, z, w]) / math.sqrt(w * w + x * x + y * y + z * z))

    def _raw_pose(self, i: int) -> tuple[Vec3, Quat]:
        """Position and quaternion (x, y, z, w), as MuJoCo holds them (not normalized), of brick
        ``i`` (its body id - 1), as floats: its held body's when frozen."""
        _, d = self._ready()
        if self._part_of and i + 1 in self._part_of:
            return self._part_pose(d, i + 1)
        if self._frozen[i]:
            m = int(self._mocap[i])
            (px, py, pz), (w, x, y, z) = d.mocap_pos[m].tolist(), d.mocap_quat[m].tolist()
        else:
            q = int(self._qpos[i])
            px, py, pz, w, x, y, z = d.qpos[q : q + 7].tolist()
        return (px, py, pz), (x, y, z, w)

    def velocity(self, body: int) -> tuple[np.ndarray, np.ndarray]:
        linear, angular = self._velocities()
        return linear[body - 1].copy(), angular[body - 1].copy()

    def speeds(self, body: int) -> tuple[float, float]:
        """Speed (m/s) and angular speed (rad/s) of ``body``, read from its free joint: the
        length of an angular velocity is the same in the body frame as in the world's."""
        _, d = self._ready()
        i = body - 1
        if self._part_of and body in self._part_of:
            (a, b, c), (e, f, g) = self._part_velocity(d, body)
            return math.hypot(a, b, c), math.hypot(e, f, g)
        if self._frozen[i]:
            return 0.0, 0.0
        v = int(self._dof[i])
        a, b, c, e, f, g = d.qvel[v : v + 6].tolist()
        return math.hypot(a, b, c), math.hypot(e, f, g)

    def pose_floats(self, body: int) -> tuple[Vec3, Quat]:
        (x, y, z), (qx, qy, qz, w) = self._raw_pose(body - 1)
        n = math.sqrt(w * w + qx * qx + qy * qy + qz * qz)
        return (x, y, z), (qx / n, qy / n, qz / n, w / n)

    def velocity_floats(self, body: int) -> tuple[Vec3, Vec3]:
        _, d = self._ready()
        i = body - 1
        if self._part_of and body in self._part_of:
            return self._part_velocity(d, body)
        if self._frozen[i]:
            return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        v, q = int(self._dof[i]), int(self._qpos[i])
        angular = np.empty(3)
        self._mj.mju_rotVecQuat(angular, d.qvel[v + 3 : v + 6], d.qpos[q + 3 : q + 7])
        (a, b, c), (e, f, g) = d.qvel[v : v + 3].tolist(), angular.tolist()
        return (a, b, c), (e, f, g)

    def contact_points(self, bodies: Collection[int] | None = None) -> list[ContactPoint]:
        m, d = self._ready()
        if d.ncon == 0:
            return []
        contact = d.contact  # MuJoCo's contacts as arrays, one row each
        pair = self._geom_body[contact.geom]  # (ncon, 2) bodies
        keep = contact.exclude == 0
        if bodies is not None:
            wanted = np.zeros(len(self._frozen) + 1, dtype=bool)
            wanted[np.asarray(list(bodies), dtype=int)] = True
            keep &= wanted[pair].any(axis=1)
        rows = np.flatnonzero(keep)
        force = self._normal_forces(m, d, rows)
        n, dist = contact.frame[rows, :3], contact.dist[rows]  # frame: from geom1 into geom2
        lower, upper = contact.pos[rows] - n * (dist / 2)[:, None], contact.pos[rows] + n * (dist / 2)[:, None]
        a, b = pair[rows, 0].tolist(), pair[rows, 1].tolist()
        f, gap = force.tolist(), dist.tolist()
        points = []
        for k in range(len(rows)):
            if bodies is None or wanted[a[k]]:
                points.append(ContactPoint(a[k], b[k], lower[k], -n[k], f[k], gap[k]))
            if bodies is None or wanted[b[k]]:
                points.append(ContactPoint(b[k], a[k], upper[k], n[k], f[k], gap[k]))
        return points

    def _normal_forces(self, m: Any, d: Any, rows: np.ndarray) -> np.ndarray:
        """Normal force in N of each contact in ``rows``, as ``mj_contactForce`` gives it, read
        from the constraint forces at once: the first row of an elliptic cone or frictionless
        contact, the sum of a pyramidal cone's 2 (dim - 1) edge rows."""
        address, dim = d.contact.efc_address[rows], d.contact.dim[rows]
        if m.opt.cone == self._mj.mjtCone.mjCONE_ELLIPTIC:
            return np.asarray(d.efc_force[address], dtype=float)
        edges = np.where(dim > 1, 2 * (dim - 1), 1)
        return np.array([d.efc_force[i : i + e].sum() for i, e in zip(address.tolist(), edges.tolist(), strict=True)])

    def near(self, body: int, distance: float, among: Collection[int] | None = None) -> list[ContactPoint]:
        """The closest points within ``distance`` of ``body`` (``mj_geomDistance``), from the
        geoms' poses at the bodies' positions now: ``mj_step`` leaves the geoms where their bodies
        were when it began (its kinematics come before its integration), a step behind, and a
        body just put in place (a projectile at its launch) where it was parked, so they are
        computed again first (``mj_kinematics``, once until something moves). A KAPLA thrown
        at 8 m/s from 20 mm reached a frozen brick unseen, which stopped it."""
        m, d = self._ready()
        mj = self._mj
        if self._placed:
            mj.mj_kinematics(m, d)
            self._placed = False
        i = body - 1
        if self._part_of and body in self._part_of:
            return self._near_merged(m, d, body, distance, among)
        own = self._held_geom[i] if self._frozen[i] else self._free_geom[i]
        reach = float(m.geom_rbound[own]) + distance
        fromto = np.zeros(6)
        out = []
        # the candidates at once: colliding geoms of other bodies (of ``among``), near enough by their bounding spheres
        colliding = m.geom_contype != 0
        if self._culling is not None:  # a frozen brick out of the collision detection is still there
            colliding[self._held_geom[self._culling.out]] = True
        keep = (self._geom_body != body) & colliding
        if among is not None:
            wanted = np.zeros(len(self._frozen) + 1, dtype=bool)
            wanted[np.asarray(list(among), dtype=int)] = True
            keep &= wanted[self._geom_body]
        # an int, not the enum: numpy compares an array with a pybind11 enum element by element
        # in Python (143 us a call, a fifth of a 120-domino run)
        plane = m.geom_type == int(mj.mjtGeom.mjGEOM_PLANE)
        keep &= plane | (np.linalg.norm(d.geom_xpos - d.geom_xpos[own], axis=1) <= reach + m.geom_rbound)
        for geom in np.flatnonzero(keep).tolist():
            other = int(self._geom_body[geom])
            gap = mj.mj_geomDistance(m, d, own, geom, distance, fromto)
            if gap < distance:
                mine, theirs = fromto[:3], fromto[3:]
                n = (mine - theirs) * (1.0 if gap >= 0 else -1.0)  # from the other body into this one
                length = float(np.linalg.norm(n))
                n = n / length if length > 1e-12 else np.array([0.0, 0.0, 1.0])
                out.append(ContactPoint(body, other, theirs.copy(), n, 0.0, float(gap)))
        return out

    def set_frozen(self, body: int, frozen: bool, mass: float, at: Pose | None = None) -> None:
        if frozen != self._frozen[body - 1] or (not frozen and at is not None):
            self._put(body, at if at is not None else self.pose(body), frozen)
        carried = None if frozen else self._carried.get(body)
        if carried is not None:  # unmerged this step: it moves on as it rode (angular in its body's frame)
            _, d = self._ready()
            (vx, vy, vz), (wx, wy, wz) = carried
            v, q = int(self._dof[body - 1]), int(self._qpos[body - 1])
            qw, qx, qy, qz = d.qpos[q + 3 : q + 7].tolist()
            d.qvel[v : v + 3] = [vx, vy, vz]
            d.qvel[v + 3 : v + 6] = _rotated(qw, -qx, -qy, -qz, wx, wy, wz)
            self._read = None

    def _put(self, body: int, pose: Pose, frozen: bool) -> None:
        """``body`` at ``pose``, at rest, frozen (its held body there) or not (its free body)."""
        _, d = self._ready()
        i = body - 1
        q, mocap = self._qpos[i], self._mocap[i]
        if frozen:
            d.mocap_pos[mocap] = pose.position
            d.mocap_quat[mocap] = _wxyz(pose.orientation)
            d.qpos[q : q + 3] = self._away(body)
        else:
            d.qpos[q : q + 3] = pose.position
            d.qpos[q + 3 : q + 7] = _wxyz(pose.orientation)
            d.mocap_pos[mocap] = self._away(body)
        d.qvel[self._dof[i] : self._dof[i] + 6] = 0.0
        self._frozen[i] = frozen
        self._read = None
        self._placed = True
        self._apply(body)

    # stackdsl.engines.protocol.World -----------------------------------------------------
    cheap_debris = True

    def make_debris(self, bodies: Sequence[int]) -> list[int]:
        """Contacts at MuJoCo's default impratio (1) for the rest of the run, once a collapse is
        decided: the tuned 10 holds friction stiff against slip, which only the building needs,
        and it made a heap of fallen bricks the run's dearest part (Newton's solver on some 800
        constraint rows). The model has one impratio, so every brick is stepped so from then
        on; returns those of ``bodies`` that move (docs/design.md, "The rigid rule")."""
        m, _ = self._ready()
        m.opt.impratio = 1.0
        return [b for b in bodies if not self._frozen[b - 1]]

    def merge(self, bodies: Sequence[int]) -> bool:
        """One free body of MuJoCo's whose geoms are the boxes of the frozen ``bodies`` where
        they are (its mass and inertia MuJoCo's, from the geoms), of their material; each
        brick's own two bodies leave the collisions until :meth:`unmerge`. The model is
        compiled again with the new body (``MjSpec.recompile`` keeps the state). A contact
        point on it names the brick whose geom it lies on. False, changing nothing, for fewer
        than two bodies, one that moves or is merged already, materials that differ, a world
        with a restitution (its contacts' bounce is kept per brick: :class:`Bounce`), or one
        that culls frozen bricks now (:class:`Culling`, from 200). Source: stackdsl's own."""
        self._ready()
        if len(bodies) < 2 or any(not self._frozen[b - 1] or b in self._part_of or b in self._hands.guided for b in bodies):
            return False
        specs = [self._specs[b - 1] for b in bodies]
        material = (specs[0].friction, specs[0].restitution)
        if any((s.friction, s.restitution) != material for s in specs) or self._bounce is not None:
            return False
        if self._culling is not None and self._culling.culls:
            return False
        poses = [self.pose(b) for b in bodies]
        positions = np.array([p.position for p in poses])
        masses = np.array([s.mass for s in specs], dtype=float)
        centre = masses @ positions / float(masses.sum())
        k, self._next_group = self._next_group, self._next_group + 1
        holder = self._spec.worldbody.add_body(name=f"merged{k}", pos=centre.tolist(), quat=[1.0, 0.0, 0.0, 0.0])
        holder.add_freejoint(name=f"mjoint{k}")
        names = [f"g{k}_{body}" for body in bodies]
        for name, body, spec, pose in zip(names, bodies, specs, poses, strict=True):
            arm, turn = pose.position - centre, np.array(_wxyz(pose.orientation))
            geom = holder.add_geom(name=name, mass=spec.mass, pos=arm.tolist(), quat=turn.tolist(), **self._shape(spec))
            self._materials.surface(geom, *material)
            self._part_of[body] = (k, arm, turn)
        pairs = self._materials.pairs_of(self._spec, names, material, self._named_materials())
        self._groups[k] = _Group(tuple(bodies), names, material, holder, pairs)
        self._compile()
        _, d = self._ready()
        for body in bodies:  # out of the way: an explicit pair of materials collides whatever the bits
            d.mocap_pos[self._mocap[body - 1]] = self._away(body)
        self._placed = True
        return True

    def merged_groups(self) -> Mapping[int, tuple[int, ...]]:
        return {k: group.bricks for k, group in self._groups.items()}  # a group's number is never taken again

    def unmerge(self, bodies: Sequence[int]) -> None:
        """Each of ``bodies`` a frozen brick of its own again, where its box of the merged body
        is; the merged body leaves the model (compiled again)."""
        _, d = self._ready()
        k = self._part_of[bodies[0]][0]
        group = self._groups[k]
        poses = {b: self.pose(b) for b in group.bricks}
        motion = self._group_motion(d, group)
        self._carried.update({b: _arm_velocity(*motion, self._part_of[b][1]) for b in group.bricks})
        del self._groups[k]
        for body in group.bricks:
            del self._part_of[body]
        for pair in group.pairs:
            self._spec.delete(pair)
        self._spec.delete(group.holder)
        self._compile()
        for body, pose in poses.items():
            self._put(body, pose, True)

    def _part_pose(self, d: Any, body: int) -> tuple[Vec3, Quat]:
        """Position and quaternion (x, y, z, w) of merged ``body``: its box of its group's body,
        in floats (the collapse monitor and the ride's rules read every brick of a ride each
        step)."""
        k, arm, turn = self._part_of[body]
        q = self._groups[k].qpos
        x, y, z, qw, qx, qy, qz = d.qpos[q : q + 7].tolist()
        ax, ay, az = arm.tolist()
        rx, ry, rz = _rotated(qw, qx, qy, qz, ax, ay, az)
        tw, tx, ty, tz = turn.tolist()
        pw = qw * tw - qx * tx - qy * ty - qz * tz
        px = qw * tx + qx * tw + qy * tz - qz * ty
        py = qw * ty - qx * tz + qy * tw + qz * tx
        pz = qw * tz + qx * ty - qy * tx + qz * tw
        return (x + rx, y + ry, z + rz), (px, py, pz, pw)

    def _part_velocity(self, d: Any, body: int) -> tuple[Vec3, Vec3]:
        """Linear (m/s, of its box's centre) and angular (rad/s) velocity of merged ``body`` in
        the world frame: its group's, v + w x r (a free joint's angular velocity is in its
        body's frame), in floats."""
        k, arm, _ = self._part_of[body]
        return _arm_velocity(*self._group_motion(d, self._groups[k]), arm)

    def _group_motion(self, d: Any, group: _Group) -> tuple[Quat, Vec3, Vec3]:
        """The merged body's quaternion (w, x, y, z), linear velocity (m/s) and angular velocity
        (rad/s) turned into the world frame, read once for all its bricks."""
        q, v = group.qpos, group.dof
        qw, qx, qy, qz = d.qpos[q + 3 : q + 7].tolist()
        vx, vy, vz, lx, ly, lz = d.qvel[v : v + 6].tolist()
        return (qw, qx, qy, qz), (vx, vy, vz), _rotated(qw, qx, qy, qz, lx, ly, lz)

    def _near_merged(self, m: Any, d: Any, body: int, distance: float, among: Collection[int] | None) -> list[ContactPoint]:
        """:meth:`near` of a merged ``body``: of its whole group's body, each of its geoms
        against every colliding geom of another body near enough by their bounding spheres."""
        mj = self._mj
        group = self._groups[self._part_of[body][0]]
        owns = group.geoms
        keep = m.geom_contype != 0
        keep &= ~np.isin(self._geom_body, group.bricks) | (self._geom_body == 0)
        keep[owns] = False
        if among is not None:
            wanted = np.zeros(len(self._frozen) + 1, dtype=bool)
            wanted[np.asarray(list(among), dtype=int)] = True
            keep &= wanted[self._geom_body]
        candidates = np.flatnonzero(keep)
        if len(candidates) == 0:
            return []
        plane = m.geom_type[candidates] == int(mj.mjtGeom.mjGEOM_PLANE)
        apart = np.linalg.norm(d.geom_xpos[candidates][:, None, :] - d.geom_xpos[owns][None, :, :], axis=2)
        close = plane[:, None] | (apart <= m.geom_rbound[candidates][:, None] + m.geom_rbound[owns][None, :] + distance)
        fromto, out = np.zeros(6), []
        for c, o in zip(*np.nonzero(close), strict=True):
            geom, own = int(candidates[c]), int(owns[o])
            gap = mj.mj_geomDistance(m, d, own, geom, distance, fromto)
            if gap < distance:
                mine, theirs = fromto[:3], fromto[3:]
                n = (mine - theirs) * (1.0 if gap >= 0 else -1.0)
                length = float(np.linalg.norm(n))
                n = n / length if length > 1e-12 else np.array([0.0, 0.0, 1.0])
                out.append(ContactPoint(body, int(self._geom_body[geom]), theirs.copy(), n, 0.0, float(gap)))
        return out

    def move(self, body: int, pose: Pose, mass: float) -> None:
        m, _ = self._ready()
        grip = self._hands.guided.pop(body, None)
        if grip is not None:  # let go of: its own mass, inertia and weight back
            Hands.release(m, int(m.geom_bodyid[self._free_geom[body - 1]]), int(self._dof[body - 1]), grip)
            m.geom_gap[self._free_geom[body - 1]] = 0.0
        self._put(body, pose, mass <= 0.0)

    def guide(self, body: int, pose: Pose, velocity: Vec3, hold: bool = True) -> None:
        """Drive the brick's free body along its path by its velocity for the next step (the path's
        velocity plus :data:`GAIN` of the way back to it); with ``hold``, in a hand's grip
        (:meth:`Hands.grip <stackdsl.engines.mujoco.hands.Hands.grip>`) and its height driven too,
        else with its own mass and vertical motion. A held body strikes what it meets as a rigid
        hand does, before MuJoCo steps (:meth:`Hands.blows <stackdsl.engines.mujoco.hands.Hands.blows>`):
        its geom reports, without acting on them, the contacts within what it travels in a step
        (MuJoCo's ``gap``)."""
        m, d = self._ready()
        i = body - 1
        if self._frozen[i]:
            self._put(body, pose, False)
        if body not in self._hands.guided:
            grip = None
            if hold:
                bid, dof = int(m.geom_bodyid[self._free_geom[i]]), int(self._dof[i])
                grip = Grip.of(m, bid, dof)
                Hands.grip(m, bid, dof, grip)
            self._hands.guided[body] = grip
        q, v = self._qpos[i], self._dof[i]
        rate = GAIN / self._engine.timestep  # by its velocity alone, back towards its path (as on pybullet)
        error = pose.position - d.qpos[q : q + 3]
        d.qvel[v : v + 2] = np.asarray(velocity[:2]) + rate * error[:2]
        if hold:
            d.qvel[v + 2] = velocity[2] + rate * error[2]
            reach = math.hypot(*d.qvel[v : v + 3].tolist()) * self._engine.timestep + BLOW_SKIN
            m.geom_gap[self._free_geom[i]] = reach
        now = d.qpos[q + 3 : q + 7]
        turn = (Rotation.from_quat(pose.orientation) * Rotation.from_quat([now[1], now[2], now[3], now[0]]).inv()).as_rotvec()
        d.qvel[v + 3 : v + 6] = Rotation.from_quat([now[1], now[2], now[3], now[0]]).inv().apply(turn * rate)  # body frame
        self._read = None

    carries = True

    def carry(self, body: int, pose: Pose, velocity: Vec3) -> None:
        _, d = self._ready()
        i = body - 1
        q, v = self._qpos[i], self._dof[i]
        d.qpos[q : q + 3] = pose.position
        d.qpos[q + 3 : q + 7] = _wxyz(pose.orientation)
        d.qvel[v : v + 3] = np.asarray(velocity, dtype=float)  # a free joint's linear velocity: the world's axes
        d.qvel[v + 3 : v + 6] = 0.0
        self._read = None

    def move_ground(self, offset: Vec3, velocity: Vec3) -> None:
        if not self._table:
            raise NotImplementedError("this world's ground is a static plane: make it with movable_ground=True")
        self._ground_at = (offset, velocity)

    def throw(self, body: int, velocity: Vec3, swept_radius: float | None) -> None:
        """Give ``body`` a linear velocity, and no spin; MuJoCo has no continuous collision
        detection, so ``swept_radius`` is ignored (the substep control splits fast steps instead)."""
        _, d = self._ready()
        v = self._dof[body - 1]
        d.qvel[v : v + 3] = velocity
        d.qvel[v + 3 : v + 6] = 0.0
        self._read = None

    def step(self) -> None:
        m, d = self._ready()
        self._carried.clear()
        self._read = None
        self._placed = True
        if self._table:  # the shake table where the shake puts it, with its velocity
            (x, y, _), (vx, vy, _) = self._ground_at
            d.qpos[self._table_qpos] = [x, y]
            d.qvel[self._table_dof] = [vx, vy]
        if self._bounce is not None:
            velocities = d.qvel[self._dof6]  # (bricks, 6): linear and angular, a parked body's 0
            linear, angular = np.linalg.norm(velocities[:, :3], axis=1), np.linalg.norm(velocities[:, 3:], axis=1)
            linear[self._frozen] = angular[self._frozen] = 0.0
            self._bounce.update(float(d.time), linear, angular)
        if self._culling is not None and not self._groups:  # merged only while it culls nothing (merge)
            self._culling.update(d, self._frozen)
        began = float(d.time)
        mj, hands = self._mj, self._hands
        integrate = mj.mj_implicit if self._engine.integrator == "implicitfast" else mj.mj_Euler
        for _ in range(self._substeps):  # mj_step, stage by stage (as mj_step1 and mj_step2 run it)
            if not hands.busy:  # nothing a hand does: mj_step itself, one call
                mj.mj_step(m, d)
                continue
            mj.mj_step1(m, d)  # positions, contacts, velocities and the contacts' reference accelerations
            if hands.blows(m, d, self._frozen, self._free_geom, self._geom_body):
                mj.mj_fwdVelocity(m, d)  # the velocities changed: their reference accelerations again
            mj.mj_fwdActuation(m, d)
            mj.mj_fwdAcceleration(m, d)
            if self._elliptic:
                hands.solve(m, d, self._frozen, self._geom_body)
            else:
                mj.mj_fwdConstraint(m, d)
            mj.mj_sensorAcc(m, d)
            mj.mj_checkAcc(m, d)
            integrate(m, d)
        # MuJoCo resets a state that blew up, its time too: a step that did not take the time on
        # by half a step was reset (a cheap test; reading the warnings costs twice the step of a
        # quiet tower), and so may be the very first
        if float(d.time) - began > self._engine.timestep / 2 and began > 0.0:
            return
        bad = self._mj.mjtWarning
        if any(d.warning[w].number for w in (bad.mjWARN_BADQPOS, bad.mjWARN_BADQVEL, bad.mjWARN_BADQACC)):
            raise EngineUnstable(
                f"MuJoCo's simulation became unstable at t = {began + self._engine.timestep:.3f} s (infinite or huge positions, velocities or accelerations; "
                "MuJoCo then resets its state): nothing after it is physics"
            )

    def set_substeps(self, substeps: int) -> None:
        """Split each following step into ``substeps``, and make every contact's time constant
        (``solref``'s first number) that many times shorter meanwhile, so that it keeps the
        relation to the step its settings chose (two steps; a bouncy material's longer by its
        damping ratio, which is kept). Left at a whole step's, the soft contact let a KAPLA
        thrown end on at 4 m/s into one lying on the ground press 8 mm into its end and ride
        up over it (the struck brick slid 116 mm, 408 at least by momentum); with it, 512 mm
        (tuned MuJoCo 465, pybullet 481). Not with a restitution (:meth:`_contact_times`)."""
        if max(1, substeps) == self._substeps and self._model is not None:  # asked every step: mostly as it was
            return
        m, _ = self._ready()
        self._substeps = max(1, substeps)
        m.opt.timestep = self._engine.timestep / self._substeps
        self._contact_times()

    def _contact_times(self) -> None:
        """Every contact's time constant as compiled, over the substeps (:meth:`set_substeps`);
        in a world with a restitution, as compiled (:class:`Bounce` sets it): a spring made
        stiffer or softer in the middle of a bounce, as the substeps change with the speed,
        gains or loses energy (a KAPLA of restitution 0.5 dropped 100 mm kept 0.15 of its
        energy, not 0.25)."""
        if self._bounce is not None:
            return
        m = self._model
        (geoms, pairs), n = self._solref, float(self._substeps)
        m.geom_solref[:, 0] = geoms / n
        m.pair_solref[:, 0] = pairs / n

    def poses_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        _, d = self._ready()
        if len(bodies) <= _FEW:  # in floats: numpy's fancy indexing costs more for a few bodies
            read = [self._raw_pose(b - 1) for b in bodies]
            positions = np.array([p for p, _ in read]).reshape(len(read), 3)
            quaternions = np.array([q for _, q in read]).reshape(len(read), 4)
        else:
            index = np.asarray(bodies, dtype=int) - 1
            table = d.qpos[self._qpos7[index]]  # (n, 7): position and (w, x, y, z) of each free body
            frozen = self._frozen[index]
            if frozen.any():  # a frozen brick is its held body
                mocap = self._mocap[index[frozen]]
                table[frozen, :3], table[frozen, 3:] = d.mocap_pos[mocap], d.mocap_quat[mocap]
            positions, quaternions = table[:, :3], table[:, [4, 5, 6, 3]]
            if self._part_of:
                for row, body in enumerate(bodies):
                    if body in self._part_of:
                        positions[row], quaternions[row] = self._part_pose(d, body)
        return positions, quaternions / np.linalg.norm(quaternions, axis=1)[:, None]

    def velocities_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        linear, angular = self._velocities()
        index = np.asarray(bodies, dtype=int) - 1
        return linear[index], angular[index]

    def _velocities(self) -> tuple[np.ndarray, np.ndarray]:
        """Linear (m/s) and angular (rad/s) velocity of every body in the world frame, shape
        (bodies, 3) each, zero for a frozen one: read once a step, however many ask (the
        extension body by body, the substep control and the collapse monitor at once)."""
        if self._read is not None:
            return self._read
        _, d = self._ready()
        rows = np.flatnonzero(~self._frozen)
        linear, angular = np.zeros((len(self._frozen), 3)), np.zeros((len(self._frozen), 3))
        dof = self._dof[rows][:, None]
        linear[rows] = d.qvel[dof + np.arange(3)]
        local = d.qvel[dof + np.arange(3, 6)]  # a free joint's angular velocity is in the body frame
        wxyz = d.qpos[self._qpos[rows][:, None] + np.arange(3, 7)]
        if len(rows) <= _FEW:
            for row, w, q in zip(rows, local, wxyz, strict=True):
                self._mj.mju_rotVecQuat(angular[row], w, q)
        else:
            angular[rows] = Rotation.from_quat(wxyz[:, [1, 2, 3, 0]]).apply(local)
        for group in self._groups.values():
            motion = self._group_motion(d, group)
            for body in group.bricks:
                linear[body - 1], angular[body - 1] = _arm_velocity(*motion, self._part_of[body][1])
        self._read = (linear, angular)
        return self._read


@dataclass
class _Group:
    """Frozen bricks merged into one free body (:meth:`MuJoCoWorld.merge`): the bricks, the
    names of their geoms in it, their material, its spec body and explicit pairs, and, in the
    compiled model, its free joint's qpos and dof addresses and its geoms."""

    bricks: tuple[int, ...]
    geom_names: list[str]
    material: tuple[float, float]
    holder: Any
    pairs: list[Any]
    qpos: int = 0
    dof: int = 0
    geoms: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))


_FEW = 8
"""Up to this many bodies, :meth:`MuJoCoWorld.poses_of` reads them one by one, and so does the
velocity read for this many moving bodies (numpy's and scipy's fixed costs are larger for one
or two)."""


def _rotated(w: float, x: float, y: float, z: float, vx: float, vy: float, vz: float) -> Vec3:
    """Vector (vx, vy, vz) turned by the unit quaternion (w, x, y, z), in floats:
    v + 2 w (u x v) + 2 u x (u x v), u = (x, y, z)."""
    tx, ty, tz = 2.0 * (y * vz - z * vy), 2.0 * (z * vx - x * vz), 2.0 * (x * vy - y * vx)
    return vx + w * tx + y * tz - z * ty, vy + w * ty + z * tx - x * tz, vz + w * tz + x * ty - y * tx


def _arm_velocity(q: Quat, v: Vec3, w: Vec3, arm: np.ndarray) -> tuple[Vec3, Vec3]:
    """Linear (m/s) and angular (rad/s) velocity of a point ``arm`` (m, in the body's frame)
    from the centre of a body turned by ``q`` (w, x, y, z) and moving at ``v`` and ``w`` (world
    frame): v + w x r, r the arm turned, in floats."""
    ax, ay, az = arm.tolist()
    rx, ry, rz = _rotated(*q, ax, ay, az)
    (vx, vy, vz), (wx, wy, wz) = v, w
    return (vx + wy * rz - wz * ry, vy + wz * rx - wx * rz, vz + wx * ry - wy * rx), w


def _quiet(message: str) -> None:
    """MuJoCo's warnings, unprinted: the one that matters, an unstable simulation, is read from
    its warning counters after each step (:class:`~stackdsl.engines.protocol.EngineUnstable`)."""


def _wxyz(quaternion: Sequence[float] | np.ndarray) -> list[float]:
    """(x, y, z, w), stackdsl's and scipy's order, as (w, x, y, z), MuJoCo's."""
    x, y, z, w = (float(v) for v in quaternion)
    return [w, x, y, z]

"""The seam between a run and its physics engine: the :class:`World` protocol.

A world creates bodies, sets their materials, steps, and reads poses and velocities of many
bodies at once; it is also the :class:`stability.Engine` the stability extension drives.
One adapter per engine implements it: :class:`~stackdsl.engines.pybullet.world.PyBulletWorld`,
:class:`~stackdsl.engines.mujoco.world.MuJoCoWorld`, and
:class:`~stackdsl.engines.fake.FakeWorld` (in memory, for tests). Capabilities only some
engines have are declared here with a default, so that the runtime never asks which engine it
drives.

Source: stackdsl's own (the world adapter of dm_control's composer).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar, Protocol

import numpy as np
from pydantic import BaseModel, ConfigDict

from stability import Engine, Pose

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class BrickSpec(_Frozen):
    """A brick's body: half extents (m), mass (kg), material friction coefficient and restitution."""

    type: str
    half_extents: Vec3
    mass: float
    friction: float
    restitution: float


#: What bounds a shake table's peak acceleration on both engines (:attr:`Limits.max_shake_acceleration`).
SHAKEN = (
    "a flat KAPLA brick (mu 0.5) on a table shaken at 2 to 24 Hz slides within 35% or 2.2 mm of the closed "
    "form in every mode up to 9.81 m/s^2 (2 mu g); at 11 m/s^2 up to 2.2 times as far, from 24.5 m/s^2 the "
    "wrong way on MuJoCo"
)


@dataclass(frozen=True)
class Limits:
    """What an engine simulates faithfully, each bound measured on it (``stackdsl bench limits``,
    docs/results/limits.md) and checked by the compiler against the engine a run uses.

    Attributes:
        min_side: m, a brick's smallest side: a straight column of ten such cubes stands at
            the engine's defaults, and one cube settles within a tenth of its side in every mode.
        max_speed: m/s, the fastest projectile with substeps (``ccd`` on): a brick thrown at
            a fixed 8 mm wall stays in front of it.
        max_speed_no_substeps: m/s, the same with ``ccd`` off; such a projectile must also move
            less than the thinnest brick of the scene in one physics step.
        max_mass_ratio: a moving body's mass over that of a lighter one it can rest on or
            strike (:mod:`stackdsl.compile.limits`): a heavy KAPLA brick crossed on a light one
            this much lighter sinks into it less than half the 4 mm collapse threshold in tuned
            mode (a solver's contact gives under load).
        max_restitution: mode -> the largest restitution of a contact (of two materials, the
            geometric mean of theirs) in that mode: no KAPLA brick dropped onto the ground or a
            brick rises with more energy than it fell with (a mode not named: 1).
        measured: one line each, what was measured (quoted in the refusals); the restitution's
            per mode, ``max_restitution_MODE``.
        max_speed_by_mode: mode -> (m/s, what was measured): a mode whose own timestep and
            contacts hold less than :attr:`max_speed`.
        max_guided_speed_by_mode: mode -> (m/s, what was measured): the fastest push (its
            pusher and the brick it drives) in a mode that holds less than a
            thrown brick's limit gives it (``stackdsl.compile.limits``).
        max_pull_speed_by_mode: mode -> (m/s, what was measured): the fastest pull (``actions:
            remove``) in a mode whose pulled brick, driven by its own mass rather than held, goes
            wrong below the push's limit; a mode not named holds pulls to the push's.
    """

    min_side: float
    max_speed: float
    max_speed_no_substeps: float
    max_mass_ratio: float
    max_restitution: dict[str, float] = field(default_factory=dict)
    measured: dict[str, str] = field(default_factory=dict)
    max_speed_by_mode: dict[str, tuple[float, str]] = field(default_factory=dict)
    max_guided_speed_by_mode: dict[str, tuple[float, str]] = field(default_factory=dict)
    max_pull_speed_by_mode: dict[str, tuple[float, str]] = field(default_factory=dict)
    max_shake_acceleration: tuple[float, str] = (math.inf, "")

    def fastest(self, mode: str) -> tuple[float, str]:
        """m/s, the fastest projectile with substeps in ``mode``, and what was measured."""
        return self.max_speed_by_mode.get(mode, (self.max_speed, self.measured.get("max_speed", "")))

    def restitution(self, mode: str) -> float:
        """The largest restitution of a contact in ``mode`` (:attr:`max_restitution`)."""
        return self.max_restitution.get(mode, 1.0)


class EngineSettings(_Frozen):
    """The settings every engine has, for one run; each adapter's own class adds its own
    (:mod:`stackdsl.engines.pybullet.settings`, :mod:`stackdsl.engines.mujoco.settings`) and
    owns its defaults per mode (:attr:`DEFAULTS`).

    Attributes:
        mode: ``raw``, ``tuned`` or ``extension``.
        backend: the engine's name.
        timestep: seconds a physics step; solver_iterations: the solver's iterations a step.
        ccd: continuous collision detection (or substeps) for thrown bricks.
        gravity: m/s^2, downwards.
    """

    #: mode -> the engine's own values of that mode (fields of this class).
    DEFAULTS: ClassVar[dict[str, dict[str, object]]] = {}
    #: Whether bodies enter the engine when placed (False: every body is created up front,
    #: parked far away, and moved in when placed: cheaper where creating a body rebuilds the model).
    enters_when_placed: ClassVar[bool] = True
    #: Metres a brick is placed into what will carry it: about how far one sinks at rest on
    #: this engine, so that its first step meets the whole contact patch (0: at zero distance).
    SEAT: ClassVar[float] = 0.0
    #: Times a shake's acceleration under which a frozen part that leans must stand to be kept
    #: frozen (:attr:`stability.StabilityConfig.leaning_margin`): how far rigid-block equilibrium,
    #: on the geometry this engine settled, may be trusted to hold what the engines hold.
    LEANING_MARGIN: ClassVar[float] = 1.5
    #: The engine's name in messages, and what it simulates faithfully.
    NAME: ClassVar[str] = "the engine"
    LIMITS: ClassVar[Limits] = Limits(min_side=0.0, max_speed=math.inf, max_speed_no_substeps=math.inf, max_mass_ratio=math.inf)

    mode: str
    backend: str
    timestep: float
    solver_iterations: int
    ccd: bool = False
    gravity: float = 9.81

    @property
    def contact_margin(self) -> float:
        """Metres within which the engine's contacts, not the geometry, decide whether two bodies
        touch and where: a brick whose centre of mass is closer than this to its support
        polygon's edge is a near tie that the engine may decide either way (0: none known)."""
        return 0.0

    def details(self) -> str:
        """The engine's own settings, as text (``stackdsl compile``)."""
        return f"continuous collision detection for thrown bricks {'on' if self.ccd else 'off'}"


class EngineUnstable(RuntimeError):
    """The engine's simulation blew up in a step (MuJoCo: infinite or huge accelerations, after
    which it resets its state): what follows is not physics, so the run stops there, failed,
    with this message. Source: stackdsl's own."""


class World(Engine, Protocol):
    """What the step loop needs from an engine, beyond :class:`stability.Engine`.

    An adapter subclasses it (so that the optional capabilities' defaults apply) and
    implements the rest; no code outside an adapter asks which engine it is.

    Attributes:
        ground: the body id of the ground plane.
        cheap_debris: whether :meth:`make_debris` does anything (an optional capability;
            default False).
        carries: whether :meth:`carry` does anything (an optional capability; default False).

    Two capabilities move bodies kinematically, as a hand or a shake table does: :meth:`guide`
    (a gripper pulling a brick out, a pusher) and :meth:`move_ground` (on a world made with a
    movable ground). The adapters implement both; the defaults refuse.
    """

    ground: int
    cheap_debris: bool = False
    carries: bool = False

    def create(self, spec: BrickSpec, pose: Pose, mass: float | None = None, projectile: bool = False) -> int:
        """A new box body of ``spec`` at ``pose`` (``mass`` 0: immovable); its id. A
        ``projectile`` is thrown fast with continuous collision detection: an engine that
        needs a kind of body for that (pybullet: maximal coordinates) makes it so."""

    def move(self, body: int, pose: Pose, mass: float) -> None:
        """Put ``body`` at ``pose`` at rest with ``mass`` (a parked body entering the scene)."""

    def throw(self, body: int, velocity: Vec3, swept_radius: float | None) -> None:
        """Give ``body`` a linear velocity (m/s) and no spin; with ``swept_radius`` (m), continuous
        collision detection by a swept sphere of that radius."""

    def step(self) -> None:
        """Advance one timestep.

        Raises:
            EngineUnstable: the engine's simulation blew up in it.
        """

    def set_substeps(self, substeps: int) -> None:
        """Split each following step into ``substeps`` (1: no split)."""

    def poses_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """Positions (n, 3) in m and unit quaternions (x, y, z, w), (n, 4), of ``bodies``."""

    def velocities_of(self, bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """Linear (n, 3) in m/s and angular (n, 3) in rad/s velocities of ``bodies``."""

    def pose_floats(self, body: int) -> tuple[Vec3, Quat]:
        """:meth:`pose` as floats: the position (m) and the unit quaternion (x, y, z, w). The
        per-step tests (the soft landing, the collapse monitor) ask it of every moving brick at
        every step, where two numpy arrays would cost more than the arithmetic; an adapter
        that holds floats returns them without building a :class:`stability.Pose`."""
        pose = self.pose(body)
        x, y, z = pose.position.tolist()
        qx, qy, qz, qw = pose.orientation.tolist()
        return (x, y, z), (qx, qy, qz, qw)

    def velocity_floats(self, body: int) -> tuple[Vec3, Vec3]:
        """:meth:`velocity` as floats: linear (m/s) and angular (rad/s); see :meth:`pose_floats`."""
        linear, angular = self.velocity(body)
        (a, b, c), (d, e, f) = linear.tolist(), angular.tolist()
        return (a, b, c), (d, e, f)

    def touches(self, body: int) -> bool:
        """Whether ``body`` touches any body now: :meth:`contact_points` of it is not empty. A
        hand asks it of a pulled brick at every step once the brick has dropped below its path
        (:meth:`stackdsl.runtime.actions.Actions.after_step`); an adapter that can answer without
        building the points does."""
        return bool(self.contact_points([body]))

    # optional capabilities, with their defaults -------------------------------------
    def guide(self, body: int, pose: Pose, velocity: Vec3, hold: bool = True) -> None:
        """Move ``body`` kinematically through the next step: put it at ``pose`` with linear
        ``velocity`` (m/s) and no spin, so that what it touches feels a body moving at that
        velocity (friction drags it), while contacts and gravity cannot push it off its path
        (``hold``: a pusher in a hand). Without ``hold`` only its horizontal position, its
        orientation and its horizontal velocity are set: it keeps its mass, height and vertical
        motion, resting on what carries it and carrying its share of what rests on it (a brick
        slid out of a tower). Called before every step it is guided;
        :meth:`move` ends it. Default: refused."""
        raise NotImplementedError(f"{type(self).__name__} cannot guide a body")

    def carry(self, body: int, pose: Pose, velocity: Vec3) -> None:
        """Put a guided ``body`` (:meth:`guide`, without ``hold``) at ``pose`` moving at linear
        ``velocity`` (m/s) with no spin, its mass and guide as they are: a hand's glide over steps
        nobody needs stepped (:meth:`stackdsl.runtime.actions.Actions.glide`). Only where
        :attr:`carries`. Default: refused."""
        raise NotImplementedError(f"{type(self).__name__} cannot carry a body")

    def move_ground(self, offset: Vec3, velocity: Vec3) -> None:
        """Put the ground ``offset`` (m) from where it started, moving at ``velocity`` (m/s),
        for the next step: a shake table. Only on a world made with a movable ground
        (:func:`stackdsl.runtime.run.world_for` makes one for a program with a shake). The ground
        alone: the runtime carries the fixtures (bodies made with mass 0) along by :meth:`guide`,
        so on such a world one must be able to move again. Default: refused."""
        raise NotImplementedError(f"{type(self).__name__} cannot move its ground")

    def make_debris(self, bodies: Sequence[int]) -> list[int]:
        """Make ``bodies`` cheaper to step while debris settles after a decided collapse, at
        the same pose and velocity under the same ids; the ids made so. How is the engine's:
        pybullet re-creates them as rigid bodies, MuJoCo loosens its contacts. Default: none
        (an engine with no cheaper way)."""
        return []

    def merge(self, bodies: Sequence[int]) -> bool:
        """:meth:`stability.Engine.merge`: static ``bodies`` one rigid body the engine moves.
        Default: False (an engine that cannot; pybullet makes a compound body, MuJoCo one free
        body of their geoms, its model compiled again)."""
        return False

    def merged_groups(self) -> Mapping[int, tuple[int, ...]]:
        """Each merged body now (:meth:`merge`), by a key no later merge takes again: the bodies
        it moves as one rigid body (the collapse monitor measures them from one pose,
        :meth:`stackdsl.runtime.bricks.Structure.displacements`). Default: none."""
        return {}

    def unmerge(self, bodies: Sequence[int]) -> None:
        """:meth:`stability.Engine.unmerge`: each a frozen body of its own where it rode to; woken
        before the next step, it moves on with the velocity it rode with. Default: refused (nothing was merged)."""
        raise ValueError(f"{type(self).__name__} merged no bodies")

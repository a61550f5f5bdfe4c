"""MuJoCo's contact materials for stackdsl's bricks: :class:`Materials`.

* Friction: a pair of bodies has the geometric mean of their materials' coefficients,
  as on pybullet (:func:`stability.pair_friction`): bodies of one material collide by
  MuJoCo's own rule (the geom's coefficient, since both are equal); a pair of different
  materials is declared as an explicit contact pair with the mean.
* Restitution ``e`` becomes the damping ratio of the contact's spring-damper,
  ``zeta = -ln e / sqrt(pi^2 + ln^2 e)`` (the damped oscillator's coefficient of
  restitution); ``e = 0`` keeps the setting's own ratio (at least 1: no bounce). MuJoCo's
  contact stiffness grows as ``1 / (timeconst zeta)^2``, so a small ratio at the setting's
  time constant rang faster than the timestep could follow: a stack of three bricks of
  restitution 0.5 on tuned MuJoCo (4 ms, 2 ms steps) flew metres apart. The time constant is
  raised to at least ``2 timestep / zeta`` (:func:`time_constant`), which keeps the spring's
  period at least 4 pi timesteps and the ratio, so the bounce, as it was; a material of
  restitution 0 keeps the setting's own contact.
* Only where it matters (:class:`Bounce`): a contact takes its restitution's damping only
  while one of its two bodies moves faster than :data:`BOUNCE_SPEED`, or did so less than
  :data:`BOUNCE_HOLD` ago (its bounce under way); otherwise it has the setting's own (a
  material of restitution 0's). An underdamped contact never let a brick put down at rest
  settle: a step of free fall takes a resting brick ``g dt^2`` into the ground (39 um at 2 ms)
  and the spring throws it back above its rest, off the ground, so that it hopped without end
  (0.04 mm on tuned MuJoCo from e = 0.1), and a tower of such bricks walked apart
  (docs/design.md, "Materials").
* Density: each body's mass is the brick's, with the inertia of a uniform box.
* Collision groups: one bit of ``contype`` and ``conaffinity`` per material, at most 30.

:meth:`Materials.contact` and :meth:`Materials.pair` give the values alone, which the world
sets on its ``MjSpec`` and an exported MJCF writes (:mod:`stackdsl.draw.export`).

Source: stackdsl's own, on MuJoCo 4.0's Python bindings.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .settings import MuJoCoSettings

BOUNCE_SPEED = 0.1
"""m/s: a contact bounces only while one of its bodies moves faster than this, its speed
plus its spin times its half diagonal (the fastest of its points). A brick at rest jitters at
about ``g dt`` (0.02 m/s at 2 ms, 0.04 at 4 ms); a bounce from 0.1 m/s rises at most 0.5 mm
(``v^2 / 2 g``)."""

BOUNCE_HOLD = 0.1
"""Seconds a body's contacts keep bouncing after it was last faster than :data:`BOUNCE_SPEED`:
longer than a bounce lasts, so that a body which slows to a stop in the ground as it bounces
is thrown back, not damped where it turns. The longest, raw MuJoCo's 20 ms contact at
restitution 0.05, lasts 60 ms (half the period of its damped spring)."""


def damping_ratio(restitution: float, default: float) -> float:
    """The contact damping ratio for a coefficient of restitution (0 to 1).

    A linear spring-damper with damping ratio ``zeta`` < 1 rebounds with
    ``e = exp(-zeta pi / sqrt(1 - zeta^2))``; this is its inverse. ``e = 0`` gives
    ``default``. Source: the damped harmonic oscillator (any mechanics text).

    >>> round(damping_ratio(0.5, 1.0), 3)
    0.215
    >>> damping_ratio(0.0, 2.0)
    2.0
    """
    if restitution <= 0.0:
        return default
    log_e = math.log(min(restitution, 1.0 - 1e-9))
    return -log_e / math.sqrt(math.pi**2 + log_e**2)


def time_constant(damping: float, engine: MuJoCoSettings) -> float:
    """Seconds: the contact's ``solref`` time constant for a damping ratio ``damping``, the
    setting's own, raised to ``2 timestep / damping`` where that is longer (the module's
    description). Source: stackdsl's own, on MuJoCo's soft contact (stiffness
    ``1 / (d timeconst dampratio)^2``, MuJoCo's documentation, "Solver parameters").

    >>> from stackdsl.engines.mujoco.settings import MuJoCoSettings
    >>> tuned = MuJoCoSettings(mode="tuned", **MuJoCoSettings.DEFAULTS["tuned"])
    >>> time_constant(2.0, tuned), round(time_constant(damping_ratio(0.5, 2.0), tuned), 4)
    (0.004, 0.0186)
    """
    return max(engine.solref[0], 2.0 * engine.timestep / damping)


@dataclass(frozen=True)
class Contact:
    """MuJoCo's contact values of a geom (or of an explicit pair of geoms).

    Attributes:
        bit: ``contype`` and ``conaffinity`` (one bit a material; 0 for a pair).
        friction: a geom's (sliding, torsional, rolling) or a pair's five coefficients.
        solref: (time constant s, damping ratio); solimp: (d0, dwidth, width m, midpoint, power).
    """

    bit: int
    friction: tuple[float, ...]
    solref: tuple[float, float]
    solimp: tuple[float, ...]


class Materials:
    """The materials of one MuJoCo world, each a collision group.

    Args:
        engine: the run's engine settings (``solref``, ``solimp``).
        ground: the ground's (friction, restitution).

    Raises:
        ValueError: (from :meth:`group`) a 31st material.

    >>> from stackdsl.engines.mujoco.settings import MuJoCoSettings
    >>> materials = Materials(MuJoCoSettings(mode="raw", timestep=0.002, solver_iterations=100), (0.5, 0.0))
    >>> materials.group(0.5, 0.0), materials.group(0.6, 0.0), materials.group(0.5, 0.0)
    (0, 1, 0)
    """

    def __init__(self, engine: MuJoCoSettings, ground: tuple[float, float]) -> None:
        self._engine, self._ground = engine, ground
        self._groups: dict[tuple[float, float], int] = {}  # (friction, restitution) -> group

    def group(self, friction: float, restitution: float) -> int:
        """The collision group (0 to 29) of a material."""
        key = (friction, restitution)
        if key not in self._groups:
            if len(self._groups) >= 30:
                raise ValueError("the MuJoCo backend takes at most 30 materials in one scene")
            self._groups[key] = len(self._groups)
        return self._groups[key]

    def contact(self, friction: float, restitution: float) -> Contact:
        """The contact values of a geom of a material: its collision bit, friction (sliding,
        torsional, rolling), ``solref`` and ``solimp``."""
        e = self._engine
        return Contact(
            bit=1 << self.group(friction, restitution),
            friction=(friction, 0.005, 0.0001),
            solref=self._solref(restitution),
            solimp=(*e.solimp, 0.5, 2.0),
        )

    def pair(self, mine: tuple[float, float], other: tuple[float, float]) -> Contact:
        """The explicit contact pair of two materials, each (friction, restitution): the geometric
        means of their coefficients; ``bit`` 0 (a pair collides whatever the geoms' bits)."""
        e = self._engine
        mu, restitution = math.sqrt(mine[0] * other[0]), math.sqrt(mine[1] * other[1])
        return Contact(
            bit=0,
            friction=(mu, mu, 0.005, 0.0001, 0.0001),
            solref=self._solref(restitution),
            solimp=(*e.solimp, 0.5, 2.0),
        )

    @property
    def bouncy(self) -> bool:
        """Whether a material of the world so far, the ground's included, has a restitution."""
        return self._ground[1] > 0.0 or any(restitution > 0.0 for _, restitution in self._groups)

    def resting(self) -> tuple[float, float]:
        """``solref`` of a contact that does not bounce: a material of restitution 0's, the setting's own."""
        return self._solref(0.0)

    def _solref(self, restitution: float) -> tuple[float, float]:
        """``solref`` of a contact of ``restitution``: :func:`time_constant` and :func:`damping_ratio`."""
        zeta = damping_ratio(restitution, self._engine.solref[1])
        return time_constant(zeta, self._engine), zeta

    def surface(self, geom: Any, friction: float, restitution: float) -> None:
        """Friction, contact softness and collision group of ``geom`` (an ``MjsGeom``) for its material."""
        c = self.contact(friction, restitution)
        geom.contype = geom.conaffinity = c.bit
        geom.friction = list(c.friction)
        geom.solref = list(c.solref)
        geom.solimp = list(c.solimp)

    def pairs_of(
        self, spec: Any, names: Sequence[str], mine: tuple[float, float], others: Sequence[tuple[str, tuple[float, float]]]
    ) -> list[Any]:
        """Explicit contact pairs in ``spec`` between each geom of ``names``, of material ``mine``
        (friction, restitution), and the ground and each geom of ``others`` (name, material) of
        another material; returns the pairs made (none in a world of one material so far)."""
        if set(self._groups) == {mine}:
            return []  # one material in the scene so far: MuJoCo's own rule gives its coefficient
        made = []
        for name, material in [("ground", self._ground), *others]:
            if material == mine:
                continue
            c = self.pair(mine, material)
            for own in names:
                pair = spec.add_pair(geomname1=own, geomname2=name)
                pair.friction = list(c.friction)
                pair.solref = list(c.solref)
                pair.solimp = list(c.solimp)
                made.append(pair)
        return made


class Bounce:
    """Which contacts of a compiled MuJoCo model bounce: those of a body faster than
    :data:`BOUNCE_SPEED` (the module's description); every other contact has the setting's own
    ``solref``, so that a brick at rest settles whatever its restitution.

    A body is fast from when it moves faster than :data:`BOUNCE_SPEED` until :data:`BOUNCE_HOLD`
    after it last did. A contact of two geoms mixes their ``solref`` by their ``solmix`` weights
    (MuJoCo's ``mj_contactParam``: a weight of 0 against one above 0 gives the other's alone):
    a fast body's geom has its material's ``solref`` and weight 1, every other geom the
    setting's own and weight 0, so that a contact bounces when one of its bodies is fast. An
    explicit pair of two materials bounces when one of its two bodies is fast. The model's
    arrays are written when a body turns fast or slow, not every step.

    Args:
        model: the compiled ``MjModel``, its ``solref`` as the materials give it (bouncing).
        geoms: each brick's free geom (brick ``i`` is body ``i + 1``).
        geom_body: geom -> stackdsl's body id (0: the ground, or a geom of no brick).
        reach: m, each brick's half diagonal.
        resting: the ``solref`` of a contact that does not bounce (:meth:`Materials.resting`).
    """

    def __init__(
        self, model: Any, geoms: np.ndarray, geom_body: np.ndarray, reach: np.ndarray, resting: tuple[float, float]
    ) -> None:
        self._model, self._geoms, self._reach = model, geoms, reach
        self._resting = np.asarray(resting, dtype=float)
        self._geom_solref = np.array(model.geom_solref[geoms], dtype=float)  # (bricks, 2) each material's
        self._pair_solref = np.array(model.pair_solref, dtype=float)
        self._pair_bodies = geom_body[np.stack([model.pair_geom1, model.pair_geom2], axis=1)].reshape(-1, 2)
        model.geom_solref[:] = self._resting
        model.geom_solmix[:] = 0.0
        model.pair_solref[:] = self._resting
        self.fast = np.zeros(len(geoms), dtype=bool)
        self._until = np.full(len(geoms), -np.inf)  # s: when each body's contacts stop bouncing

    def update(self, now: float, linear: np.ndarray, angular: np.ndarray) -> None:
        """At time ``now`` (s), bodies' linear and angular speeds (m/s, rad/s, one each a brick,
        0 when frozen): the contacts of the fast ones bounce in the next step."""
        self._until[linear + angular * self._reach > BOUNCE_SPEED] = now + BOUNCE_HOLD
        fast = self._until > now
        if np.array_equal(fast, self.fast):
            return
        self.fast = fast
        m = self._model
        m.geom_solref[self._geoms] = np.where(fast[:, None], self._geom_solref, self._resting)
        m.geom_solmix[self._geoms] = fast
        if len(self._pair_bodies):
            either = np.concatenate([[False], fast])[self._pair_bodies].any(axis=1)
            m.pair_solref[:] = np.where(either[:, None], self._pair_solref, self._resting)

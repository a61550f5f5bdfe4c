"""A projectile must start clear: above the ground and outside every body in the world.

The compiler puts a projectile ``distance`` before its target point, lifted by its fall.
A projectile too big for the scene, a direction that starts it under the ground or inside
the structure, or a target point below the ground would start it inside something; the
engine then pushes it out at once, and the run measures that, not an impact. Such an
impact is refused at the field to change.

Source: stackdsl's own.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from stability import Box, Pose

from ..engines.protocol import BrickSpec
from ..lang.errors import FieldPath
from ..lang.schema import Scenario
from ..lang.schema_impacts import Impact
from .overlap import penetration
from .program import Launch

#: Metres a projectile may reach into the ground or a body at its start (contact, not overlap).
TOLERANCE = 0.0005


def check_launch(
    scenario: Scenario, index: int, impact: Impact, launch: Launch, bodies: Sequence[tuple[str, BrickSpec, Pose]]
) -> None:
    """Refuse a projectile that starts below the ground or inside a body.

    Args:
        scenario: for its source map.
        index: the impact's index in ``impacts``.
        impact: the impact as written; launch: as compiled.
        bodies: (id, spec, pose) of every brick and fixture in the world at launch time.

    Raises:
        ScenarioError: at ``impacts[index]``'s ``target.point``, ``direction`` or
            ``projectile``, whichever the scenario gave (in that order of blame).
    """
    box = Box(np.array(launch.brick.half_extents), launch.brick.mass)
    pose = Pose.from_euler(launch.position, launch.yaw, launch.pitch, 0.0)
    lowest = float(box.corners(pose)[:, 2].min())
    if lowest < -TOLERANCE:
        raise scenario.source.error(_blame(impact, index), f"the projectile would start {-lowest * 1000:.1f} mm below the ground")
    if not bodies:
        return
    centres = np.array([p.position for _, _, p in bodies])
    rotations = np.array([p.rotation for _, _, p in bodies])
    halves = np.array([s.half_extents for _, s, _ in bodies])
    n = len(bodies)
    depth = penetration(
        np.repeat(pose.position[None], n, axis=0),
        np.repeat(pose.rotation[None], n, axis=0),
        np.repeat(box.half_extents[None], n, axis=0),
        centres,
        rotations,
        halves,
    )
    worst = int(np.argmax(depth))
    if depth[worst] > TOLERANCE:
        name = bodies[worst][0]
        raise scenario.source.error(
            _blame(impact, index),
            f"the projectile would start {depth[worst] * 1000:.1f} mm inside brick {name!r}; aim it from outside the structure",
        )


def _blame(impact: Impact, index: int) -> FieldPath:
    path: FieldPath = ("impacts", index)
    if impact.target.point is not None:
        return (*path, "target", "point")
    if impact.direction is not None:
        return (*path, "direction")
    return (*path, "projectile")

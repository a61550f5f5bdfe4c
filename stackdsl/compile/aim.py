"""Where a thrown brick is aimed at a level's side: the middle of the level's outer face there.

The compiler aims at the bricks as the scenario places them; the run aims again at the same
brick as it lies when the projectile is thrown (:mod:`stackdsl.runtime.aim`), so both ask this
module the same question of different poses.

Source: stackdsl's own.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from stability import Box, Pose


def face_middle(box: Box, pose: Pose, outward: np.ndarray) -> np.ndarray:
    """The middle of the face of ``box`` at ``pose`` whose outward normal is nearest ``outward``."""
    return np.asarray(box.face(pose, outward)[0].mean(axis=0))


def outer_face(boxes: Sequence[Box], poses: Sequence[Pose], outward: np.ndarray) -> tuple[int, np.ndarray]:
    """Which brick a throw into a level's side is aimed at, and the point: of the bricks whose
    faces on the side ``outward`` (a horizontal unit vector, out of the level) are outermost, the
    one whose face's middle is nearest the middle of the level's extent across that side (the
    first of equals), at its face's middle. A course of five bricks is hit on its middle brick, a
    layer of two bricks side by side on the first.

    >>> brick = Box(np.array([0.0585, 0.0117, 0.0039]), 0.01)
    >>> at = [Pose.from_euler([0.0, y, 0.0039]) for y in (-0.04, 0.0, 0.04)]
    >>> i, point = outer_face([brick] * 3, at, np.array([-1.0, 0.0, 0.0]))
    >>> i, [round(float(v), 4) for v in point]
    (1, [-0.0585, 0.0, 0.0039])
    """
    along = np.array([-outward[1], outward[0], 0.0])  # horizontal, across the side
    faces = [box.face(pose, outward)[0] for box, pose in zip(boxes, poses, strict=True)]
    reach = [round(float((corners @ outward).max()), 9) for corners in faces]
    spread = np.array([box.corners(pose) @ along for box, pose in zip(boxes, poses, strict=True)])
    middle = (spread.min() + spread.max()) / 2
    outermost = [i for i, r in enumerate(reach) if r == max(reach)]
    nearest = min(outermost, key=lambda i: round(abs(float(faces[i].mean(axis=0) @ along) - middle), 9))
    return nearest, np.asarray(faces[nearest].mean(axis=0))


def stepped_fall(
    velocity: Sequence[float], flight: float, dt: float, gravity: float, threshold: float | None, most: int
) -> float:
    """How far a projectile thrown with ``velocity`` (m/s) falls in ``flight`` seconds from gravity,
    as the engines step it: each step (``dt``) is split into substeps as the run's
    :class:`~stackdsl.runtime.subscribers.Substeps` splits it from the projectile's speed at the
    step's start, so that it moves at most ``threshold`` in one (None: never split), at most
    ``most`` of them; and each substep ``h`` adds ``gravity h`` to its downward speed before it
    moves (pybullet's and MuJoCo's semi-implicit Euler). That fall exceeds ``gravity flight^2 / 2``
    by ``gravity h / 2`` over each substep's length: 0.5 mm over a 50 mm throw at 1 m/s in two
    substeps of a 240 Hz step, 4 mm over a 100 mm throw at 0.5 m/s in whole steps, enough to
    bring a projectile as thick as the face it is aimed at down onto the ledge under that face.

    >>> round(stepped_fall((1.0, 0.0, 0.0), 0.05, 0.05, 9.81, None, 64) * 1000, 2)  # one step
    24.53
    >>> round(stepped_fall((1.0, 0.0, 0.0), 0.05, 1e-5, 9.81, None, 64) * 1000, 2)  # g t^2 / 2
    12.26
    """
    horizontal = math.hypot(velocity[0], velocity[1])
    fall, down, t = 0.0, -float(velocity[2]), 0.0
    while t < flight - 1e-12:
        speed = math.hypot(horizontal, down)
        split = 1 if threshold is None else min(most, max(1, math.ceil(speed * dt / threshold)))
        h = dt / split
        for _ in range(split):
            part = min(h, flight - t)
            if part <= 0:
                break
            down += gravity * h
            fall += (down + float(velocity[2])) * part  # gravity's share of the move, not the throw's own
            t += part
    return fall

"""Where a thrown brick is aimed at a level's side: the middle of the level's outer face there.

The compiler aims at the bricks as the scenario places them; the run aims again at the same
brick as it lies when the projectile is thrown (:mod:`stackdsl.runtime.aim`), so both ask this
module the same question of different poses.

Source: stackdsl's own.
"""

from __future__ import annotations

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

"""The camera of a picture: an orthographic view framed on a recorded structure.

An orthographic camera measures a length the same at every depth, so a picture's scale bar is
exact. It is framed on every brick's placed pose, the fixtures and the fallen bricks near the
structure, and looks along a 3/4 diagonal; with a projectile, along the diagonal nearest the
launch point; after a collapse, across the direction the fallen bricks moved
(:func:`camera_view`).

Source: stackdsl's own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from stability import Box, Pose

from ..runtime.trajectory import ABSENT, FALLEN, Trajectory

#: How far beyond the placed structure (a fraction of its diagonal) a fallen brick is still framed.
DEBRIS_REACH = 0.5
#: The camera: its horizontal view direction is turned this far (deg) from +y towards +x, and
#: it looks down at this pitch (deg, negative: down).
CAMERA_YAW, CAMERA_PITCH = 40.0, -25.0
#: After a collapse the camera looks across the fall, this far (deg) off square and this far down.
FALL_YAW, FALL_PITCH = 15.0, -15.0
#: Empty space left around the framed bricks, a fraction of their largest extent in the picture.
MARGIN = 0.08


@dataclass(frozen=True)
class Camera:
    """An orthographic camera: ``view`` and ``projection`` are 4 x 4 matrices (row-major,
    metres) as OpenGL uses them; ``pixels_per_metre`` holds at every depth. Source: stackdsl's own."""

    view: np.ndarray
    projection: np.ndarray
    width: int
    height: int
    pixels_per_metre: float

    @classmethod
    def framing(cls, points: np.ndarray, width: int, height: int, yaw: float = CAMERA_YAW, pitch: float = CAMERA_PITCH) -> Camera:
        """The camera looking along ``yaw`` (deg, from +y towards +x) at ``pitch`` (deg, negative:
        down) whose picture of ``width`` x ``height`` pixels holds ``points`` ((n, 3), metres) with
        :data:`MARGIN` around them."""
        low, high = points.min(axis=0), points.max(axis=0)
        target = (low + high) / 2.0
        yaw, pitch = math.radians(yaw), math.radians(pitch)
        forward = np.array([math.cos(pitch) * math.sin(yaw), math.cos(pitch) * math.cos(yaw), math.sin(pitch)])
        distance = float(np.linalg.norm(high - low)) + 1.0
        eye = target - distance * forward
        view = look_at(eye, target)
        seen = (np.c_[points, np.ones(len(points))] @ view.T)[:, :3]  # camera frame: x right, y up, -z ahead
        (left, bottom, _), (right, top, _) = seen.min(axis=0), seen.max(axis=0)
        pad = MARGIN * max(right - left, top - bottom, 1e-3)
        left, right, bottom, top = left - pad, right + pad, bottom - pad, top + pad
        scale = max((right - left) / width, (top - bottom) / height)  # metres a pixel
        middle_x, middle_y = (left + right) / 2.0, (top + bottom) / 2.0
        left, right = middle_x - scale * width / 2.0, middle_x + scale * width / 2.0
        bottom, top = middle_y - scale * height / 2.0, middle_y + scale * height / 2.0
        near, far = 0.01, 2.0 * distance + 20.0  # metres in front of the eye: everything framed is between
        projection = np.diag([2.0 / (right - left), 2.0 / (top - bottom), -2.0 / (far - near), 1.0])  # OpenGL's glOrtho
        projection[:3, 3] = [-(right + left) / (right - left), -(top + bottom) / (top - bottom), -(far + near) / (far - near)]
        return cls(view, projection, width, height, 1.0 / scale)

    def pixels(self, points: np.ndarray) -> np.ndarray:
        """(n, 2) pixel coordinates (column, row; row 0 at the top) of ``points`` (n, 3), metres."""
        clip = np.c_[points, np.ones(len(points))] @ (self.projection @ self.view).T
        return np.asarray(np.c_[(clip[:, 0] + 1.0) / 2.0 * self.width, (1.0 - clip[:, 1]) / 2.0 * self.height])

    def ground_point(self, column: float, row: float) -> np.ndarray:
        """(3,) metres: the point of the ground plane (z = 0) seen at pixel (``column``, ``row``)."""
        x, y = 2.0 * column / self.width - 1.0, 1.0 - 2.0 * row / self.height
        inverse = np.linalg.inv(self.projection @ self.view)  # affine: w stays 1
        a, b = ((inverse @ [x, y, depth, 1.0])[:3] for depth in (-1.0, 1.0))  # two points on the pixel's ray
        result: np.ndarray = a + (b - a) * (a[2] / (a[2] - b[2]))
        return result


def look_at(eye: np.ndarray, target: np.ndarray, up: tuple[float, float, float] = (0.0, 0.0, 1.0)) -> np.ndarray:
    """The 4 x 4 view matrix (row-major) of a camera at ``eye`` looking at ``target`` ((3,),
    metres) with ``up`` upwards in the picture: world to camera coordinates, x right, y up,
    -z ahead (OpenGL's ``gluLookAt``).

    >>> look_at(np.array([0.0, -1.0, 0.0]), np.zeros(3)) @ [0.0, 0.0, 0.0, 1.0]
    array([ 0.,  0., -1.,  1.])
    """
    forward = (target - eye) / np.linalg.norm(target - eye)
    side = np.cross(forward, up)
    side /= np.linalg.norm(side)
    upward = np.cross(side, forward)
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = side, upward, -forward
    view[:3, 3] = -view[:3, :3] @ eye
    return view


def placed_corners(trajectory: Trajectory) -> np.ndarray:
    """(n, 3) metres: what the camera frames. The corners of every brick at its first
    recorded pose (a structure brick where it was placed, a projectile where it was thrown
    from) and of every fixture, at rest and as far as a shake carries it each way (a post
    beside a shaken tower left the frame mid-stroke); and of every later pose of a structure
    brick whose centre stays within :data:`DEBRIS_REACH` of the placed structure's extent
    (bricks that fell at its foot are in the picture, one that slid far away does not shrink it)."""
    bodies, first = np.unique(trajectory.row_body, return_index=True)
    boxes = [
        (trajectory.half_extents[b], trajectory.row_position[r], trajectory.row_orientation[r]) for b, r in zip(bodies, first)
    ]
    boxes += zip(trajectory.fixture_half_extents, trajectory.fixture_positions, trajectory.fixture_orientations)
    if not boxes:  # nothing placed: a brick's size around the origin
        return np.array([[-0.06, -0.06, 0.0], [0.06, 0.06, 0.01]])
    placed = np.concatenate([Box(half, 1.0).corners(Pose(position, quaternion)) for half, position, quaternion in boxes])
    low, high = placed.min(axis=0), placed.max(axis=0)
    fixtures = len(trajectory.fixture_positions) * 8  # the last rows of ``placed``
    if fixtures and len(trajectory.ground_offset) and trajectory.ground_offset.any():
        carried = placed[len(placed) - fixtures :]
        offsets = trajectory.ground_offset
        placed = np.concatenate([placed, carried + offsets.min(axis=0), carried + offsets.max(axis=0)])
    reach = DEBRIS_REACH * float(np.linalg.norm(high - low))
    structure = ~trajectory.projectiles[trajectory.row_body]
    near = np.all((trajectory.row_position > low - reach) & (trajectory.row_position < high + reach), axis=1)
    later = np.setdiff1d(np.flatnonzero(structure & near), first)
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    offsets = signs[None, :, :] * trajectory.half_extents[trajectory.row_body[later]][:, None, :]  # (rows, 8, 3)
    turned = np.einsum("nij,nkj->nki", Rotation.from_quat(trajectory.row_orientation[later]).as_matrix(), offsets)
    return np.concatenate([placed, (trajectory.row_position[later][:, None, :] + turned).reshape(-1, 3)])


def camera_view(trajectory: Trajectory, centre: np.ndarray) -> tuple[float, float]:
    """The camera's yaw and pitch, degrees (``centre``: (3,), metres, what it looks at):

    * with a projectile, the diagonal view (yaw 40, -40, 140 or -140 at :data:`CAMERA_PITCH`)
      that has the first projectile's launch point nearest the camera, so that the throw is not
      hidden behind the structure;
    * after a collapse, a view across the direction the fallen bricks moved (their mean
      horizontal displacement), :data:`FALL_YAW` off square and :data:`FALL_PITCH` down, so
      that a tipping part is seen in profile rather than foreshortened;
    * else the 3/4 view :data:`CAMERA_YAW`, :data:`CAMERA_PITCH`.
    """
    projectiles = np.flatnonzero(trajectory.projectiles)
    rows = np.flatnonzero(np.isin(trajectory.row_body, projectiles))
    if len(rows):
        away = trajectory.row_position[rows[0], :2] - centre[:2]
        views = [CAMERA_YAW, -CAMERA_YAW, 180.0 - CAMERA_YAW, CAMERA_YAW - 180.0]
        return min(views, key=lambda yaw: float(np.dot(away, _horizontal(yaw)))), CAMERA_PITCH
    fall = _fall(trajectory)
    if fall is None:
        return CAMERA_YAW, CAMERA_PITCH
    across = math.degrees(math.atan2(fall[0], fall[1]))  # the fall's own yaw; a view across it is 90 deg off
    views = [across + side * 90.0 + turn * FALL_YAW for side in (-1, 1) for turn in (-1, 1)]
    yaw = min(views, key=lambda v: abs((v - CAMERA_YAW + 180.0) % 360.0 - 180.0))  # nearest the usual view
    return (yaw + 180.0) % 360.0 - 180.0, FALL_PITCH


def _horizontal(yaw: float) -> list[float]:
    return [math.sin(math.radians(yaw)), math.cos(math.radians(yaw))]


def _fall(trajectory: Trajectory) -> np.ndarray | None:
    """(2,) metres: the mean horizontal displacement, from their first to their last row, of the
    structure bricks that end fallen; None when none did or they moved less than a millimetre."""
    fallen = [b for b in np.flatnonzero(~trajectory.projectiles) if _last_state(trajectory, int(b)) == FALLEN]
    if not fallen:
        return None
    moves = []
    for b in fallen:
        rows = np.flatnonzero(trajectory.row_body == b)
        moves.append(trajectory.row_position[rows[-1], :2] - trajectory.row_position[rows[0], :2])
    mean = np.mean(moves, axis=0)
    return mean if float(np.linalg.norm(mean)) > 1e-3 else None


def _last_state(trajectory: Trajectory, body: int) -> int:
    rows = np.flatnonzero(trajectory.row_body == body)
    return int(trajectory.row_state[rows[-1]]) if len(rows) else ABSENT

"""Pictures of a recorded run: a :class:`stackdsl.Trajectory` drawn at one moment.

The bricks are drawn by pybullet's TinyRenderer in a DIRECT client of their own: a z-buffered
software rasteriser that runs headless and ships with pybullet, so a picture needs no display,
no GPU and no new dependency. The camera is orthographic (a length measures the same at every
depth, so the scale bar is exact), looks at the structure from above at a 3/4 angle and is
framed once per trajectory on every brick's placed pose and the fixtures.

Colours say each brick's state (:data:`stackdsl._trajectory.STATES`): see :data:`COLOURS`.

>>> import stackdsl
>>> from stackdsl._recorder import record_program
>>> program = stackdsl.compile_scenario(stackdsl.parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 2}}"))
>>> outcome, trajectory = record_program(program)
>>> resolve_time(trajectory, "end")
5.0
>>> render(trajectory, 5.0, 160, 120).shape
(120, 160, 3)

Source: stackdsl's own.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from stability import Box, Pose

from ._trajectory import ABSENT, FALLEN, FROZEN, STATES, Frame, Trajectory
from ._world import direct_client

#: RGB (0 to 1) of a structure brick in each state, of projectiles, fixtures, the ground and
#: what lies beyond it.
COLOURS: dict[str, tuple[float, float, float]] = {
    "active": (0.87, 0.71, 0.47),  # wood
    "frozen": (0.27, 0.51, 0.71),  # steel blue
    "woken": (1.00, 0.55, 0.05),  # orange
    "fallen": (0.84, 0.12, 0.12),  # red
    "projectile": (0.58, 0.30, 0.78),  # violet
    "fixture": (0.50, 0.50, 0.50),
    "ground": (0.88, 0.87, 0.84),
    "background": (0.98, 0.98, 0.99),
}
#: Seconds after the collapse was detected that ``at="collapse"`` shows. At detection a brick has
#: moved only the collapse threshold (4 mm): nothing shows but the colours. 0.2 s later the top
#: seven levels of scenarios/slant_tower.yaml are seen tipping over level 2's edge, still in one
#: piece (0.1 s: barely moved; 0.3 s: a slab lying almost on its side, hard to read), and the top
#: brick of scenarios/hard/overhang_falls.yaml has tipped onto the ground (it does by 0.1 s).
COLLAPSE_DELAY = 0.2
#: How far beyond the placed structure (a fraction of its diagonal) a fallen brick is still framed.
DEBRIS_REACH = 0.5
#: The camera: its horizontal view direction is turned this far (deg) from +y towards +x, and
#: it looks down at this pitch (deg, negative: down).
CAMERA_YAW, CAMERA_PITCH = 40.0, -25.0
#: After a collapse the camera looks across the fall, this far (deg) off square and this far down.
FALL_YAW, FALL_PITCH = 15.0, -15.0
#: Empty space left around the framed bricks, a fraction of their largest extent in the picture.
MARGIN = 0.08
#: A picture as TinyRenderer gives it: RGB (h, w, 3) uint8, depth (h, w) (smaller is nearer), body id (h, w) (-1: none).
Layer = tuple[np.ndarray, np.ndarray, np.ndarray]
_HIDDEN, _GROUND = (1.0e3, 1.0e3, -1.0e3), 0.001  # where an absent brick is parked (out of view); the ground's half thickness, m


def resolve_time(trajectory: Trajectory, at: str | float) -> float:
    """The time (s) that ``at`` names: ``"collapse"`` (the detected collapse plus
    :data:`COLLAPSE_DELAY`, at most the end), ``"end"``, or seconds (a number or its text,
    ``"9.35"`` or ``"9.35 s"``).

    Raises:
        ValueError: ``"collapse"`` and nothing collapsed; a time outside [0, end]; anything else.
    """
    end = trajectory.end
    if at == "collapse":
        collapse = trajectory.collapse_time
        if collapse is None:
            raise ValueError(f"{trajectory.meta.get('scenario') or 'the run'} did not collapse: ask for 'end' or a time")
        return min(collapse + COLLAPSE_DELAY, end)
    if at == "end":
        return end
    try:
        time = float(at.strip().removesuffix("s")) if isinstance(at, str) else math.nan if isinstance(at, bool) else float(at)
    except (TypeError, ValueError):
        time = math.nan
    if math.isnan(time):
        raise ValueError(f"the time to draw must be 'collapse', 'end' or seconds, not {at!r}")
    if not 0.0 <= time <= end:
        raise ValueError(f"t = {time:g} s is outside the run, which lasts from 0 to {end:.2f} s")
    return time


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
        import pybullet

        low, high = points.min(axis=0), points.max(axis=0)
        target = (low + high) / 2.0
        yaw, pitch = math.radians(yaw), math.radians(pitch)
        forward = np.array([math.cos(pitch) * math.sin(yaw), math.cos(pitch) * math.cos(yaw), math.sin(pitch)])
        distance = float(np.linalg.norm(high - low)) + 1.0
        eye = target - distance * forward
        view = np.array(pybullet.computeViewMatrix(eye.tolist(), target.tolist(), [0.0, 0.0, 1.0])).reshape(4, 4).T
        seen = (np.c_[points, np.ones(len(points))] @ view.T)[:, :3]  # camera frame: x right, y up, -z ahead
        (left, bottom, _), (right, top, _) = seen.min(axis=0), seen.max(axis=0)
        pad = MARGIN * max(right - left, top - bottom, 1e-3)
        left, right, bottom, top = left - pad, right + pad, bottom - pad, top + pad
        scale = max((right - left) / width, (top - bottom) / height)  # metres a pixel
        middle_x, middle_y = (left + right) / 2.0, (top + bottom) / 2.0
        left, right = middle_x - scale * width / 2.0, middle_x + scale * width / 2.0
        bottom, top = middle_y - scale * height / 2.0, middle_y + scale * height / 2.0
        # TinyRenderer drops a fragment unless -a <= clip z <= b, with a and b read off the matrix as
        # if it were a perspective one (a = P[2,3] / (P[2,2] - 1), b = P[2,3] / (P[2,2] + 1)): choose the
        # orthographic near and far planes that make a and b the depths (m) to keep.
        closest, farthest = 0.01, 2.0 * distance + 20.0
        depth_range = 2.0 * (farthest - closest) / (farthest + closest)
        near = (closest * (2.0 + depth_range) - depth_range) / 2.0
        far = near + depth_range
        projection = np.diag([2.0 / (right - left), 2.0 / (top - bottom), -2.0 / (far - near), 1.0])  # OpenGL's glOrtho
        projection[:3, 3] = [-(right + left) / (right - left), -(top + bottom) / (top - bottom), -(far + near) / (far - near)]
        return cls(view, projection, width, height, 1.0 / scale)

    def pixels(self, points: np.ndarray) -> np.ndarray:
        """(n, 2) pixel coordinates (column, row; row 0 at the top) of ``points`` (n, 3), metres."""
        clip = np.c_[points, np.ones(len(points))] @ (self.projection @ self.view).T
        return np.c_[(clip[:, 0] + 1.0) / 2.0 * self.width, (1.0 - clip[:, 1]) / 2.0 * self.height]

    def ground_point(self, column: float, row: float) -> np.ndarray:
        """(3,) metres: the point of the ground plane (z = 0) seen at pixel (``column``, ``row``)."""
        x, y = 2.0 * column / self.width - 1.0, 1.0 - 2.0 * row / self.height
        inverse = np.linalg.inv(self.projection @ self.view)  # affine: w stays 1
        a, b = ((inverse @ [x, y, depth, 1.0])[:3] for depth in (-1.0, 1.0))  # two points on the pixel's ray
        result: np.ndarray = a + (b - a) * (a[2] / (a[2] - b[2]))
        return result


def placed_corners(trajectory: Trajectory) -> np.ndarray:
    """(n, 3) metres: what the camera frames. The corners of every brick at its first
    recorded pose (a structure brick where it was placed, a projectile where it was thrown
    from) and of every fixture; and of every later pose of a structure brick whose centre
    stays within :data:`DEBRIS_REACH` of the placed structure's extent (bricks that fell at
    its foot are in the picture, one that slid far away does not shrink it)."""
    bodies, first = np.unique(trajectory.row_body, return_index=True)
    boxes = [
        (trajectory.half_extents[b], trajectory.row_position[r], trajectory.row_orientation[r]) for b, r in zip(bodies, first)
    ]
    boxes += zip(trajectory.fixture_half_extents, trajectory.fixture_positions, trajectory.fixture_orientations)
    if not boxes:  # nothing placed: a brick's size around the origin
        return np.array([[-0.06, -0.06, 0.0], [0.06, 0.06, 0.01]])
    placed = np.concatenate([Box(half, 1.0).corners(Pose(position, quaternion)) for half, position, quaternion in boxes])
    low, high = placed.min(axis=0), placed.max(axis=0)
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


def colour_keys(trajectory: Trajectory, states: np.ndarray) -> list[str]:
    """The :data:`COLOURS` key of each body ((bodies,) state codes): its state's name, or
    ``"projectile"``."""
    return ["projectile" if projectile else STATES[state] for projectile, state in zip(trajectory.projectiles, states)]


class Scene:
    """The bodies of ``trajectory`` in a TinyRenderer client of their own, for pictures of
    ``width`` x ``height`` pixels: a box for each brick, fixture and the ground, built once;
    :meth:`render` only moves and recolours them. A context manager (or call :meth:`close`).

    A picture is two renders merged by depth: the still layer (ground, fixtures, frozen bricks),
    kept until it changes (bricks that froze since are drawn alone and merged in), and the
    bricks that may move. Raises ValueError for fewer than 16 x 16 pixels. Source: stackdsl's own.
    """

    def __init__(self, trajectory: Trajectory, width: int, height: int) -> None:
        if width < 16 or height < 16:
            raise ValueError(f"a picture must be at least 16 x 16 pixels, not {width} x {height}")
        self.trajectory, self.width, self.height = trajectory, int(width), int(height)
        self._stack = ExitStack()
        self._client: Any = self._stack.enter_context(direct_client())  # first: it silences pybullet's import
        try:
            self._build(trajectory)
        except BaseException:
            self.close()
            raise

    def _build(self, trajectory: Trajectory) -> None:
        """The camera, the light, and a body for the ground, each fixture and each brick (hidden)."""
        corners = placed_corners(trajectory)
        low, high = corners.min(axis=0), corners.max(axis=0)
        centre = (low + high) / 2.0
        self.camera = camera = Camera.framing(corners, self.width, self.height, *camera_view(trajectory, centre))
        towards, right = camera.view[2, :3], camera.view[0, :3]  # to the camera, to the picture's right
        self._light = (towards - 0.7 * right + [0.0, 0.0, 1.5]).tolist()  # from the upper left, behind the camera
        self._shapes: dict[tuple[float, ...], int] = {}
        # the ground: a square under the structure reaching past the picture's bottom corners
        seen = [camera.ground_point(column, self.height) for column in (0, self.width)]
        reach = max(float(np.abs(p[:2] - centre[:2]).max()) for p in seen) * 1.05
        reach = max(reach, float(max(high[0] - low[0], high[1] - low[1])) / 2.0 + 0.1)
        fixed = [((reach, reach, _GROUND), (*centre[:2], -_GROUND), (0, 0, 0, 1), "ground")]
        fixtures = zip(trajectory.fixture_half_extents, trajectory.fixture_positions, trajectory.fixture_orientations)
        fixed += [(tuple(half), tuple(position), tuple(quaternion), "fixture") for half, position, quaternion in fixtures]
        self._fixed = [(self._body(half, at, quaternion, key), at, quaternion) for half, at, quaternion, key in fixed]
        self.bodies = [self._body(tuple(half), _HIDDEN, (0, 0, 0, 1), "") for half in trajectory.half_extents]
        self._colours: list[str] = [""] * len(self.bodies)
        self._shown = np.full((len(self.bodies), 7), np.nan)  # where each brick's body is: NaN when hidden
        # the still layer: RGB, depth, body of each pixel, which bricks it holds, the poses it was drawn at
        self._still: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None

    def _body(self, half: tuple[float, ...], position: tuple[float, ...], quaternion: tuple[float, ...], colour: str) -> int:
        import pybullet

        key = tuple(round(h, 9) for h in half)
        if key not in self._shapes:
            self._shapes[key] = self._client.createVisualShape(pybullet.GEOM_BOX, halfExtents=list(half))
        body = int(self._client.createMultiBody(0.0, -1, self._shapes[key], list(position), list(quaternion)))
        if colour:
            self._client.changeVisualShape(body, -1, rgbaColor=[*COLOURS[colour], 1.0])
        return body

    def _show(self, wanted: np.ndarray, poses: np.ndarray) -> None:
        """Put each brick in ``wanted`` at its row of ``poses`` ((bodies, 7): position,
        quaternion), hide every other."""
        target = np.where(wanted[:, None], poses, np.nan)
        for i in np.flatnonzero(~((target == self._shown) | (np.isnan(target) & np.isnan(self._shown))).all(axis=1)):
            hidden = bool(np.isnan(target[i, 0]))
            position, quaternion = (_HIDDEN, (0.0, 0.0, 0.0, 1.0)) if hidden else (target[i, :3].tolist(), target[i, 3:].tolist())
            self._client.resetBasePositionAndOrientation(self.bodies[i], position, quaternion)
        self._shown = target

    def _shoot(self, fixed: bool) -> Layer:
        """A TinyRenderer :data:`Layer` of the bricks in view, with (``fixed``) or without the ground and fixtures."""
        import pybullet

        client, camera = self._client, self.camera
        for body, position, quaternion in self._fixed:
            client.resetBasePositionAndOrientation(body, position if fixed else _HIDDEN, quaternion)
        _, _, rgba, depth, segmentation = client.getCameraImage(
            self.width,
            self.height,
            viewMatrix=camera.view.T.ravel().tolist(),
            projectionMatrix=camera.projection.T.ravel().tolist(),
            lightDirection=self._light,
            lightAmbientCoeff=0.55,
            lightDiffuseCoeff=0.5,
            lightSpecularCoeff=0.05,
            shadow=0,
            renderer=pybullet.ER_TINY_RENDERER,
        )
        shape = (self.height, self.width)
        return np.asarray(rgba, np.uint8).reshape(*shape, 4)[:, :, :3], np.reshape(depth, shape), np.reshape(segmentation, shape)

    def render(self, frame: Frame) -> np.ndarray:
        """The picture of ``frame`` (of this scene's trajectory): (height, width, 3) uint8 RGB,
        each body outlined, the background beyond the ground filled in."""
        keys = colour_keys(self.trajectory, frame.states)
        present = (frame.states != ABSENT) & ~np.isnan(frame.positions[:, 0])
        poses = np.c_[frame.positions, frame.orientations]
        for i in np.flatnonzero(present):
            if keys[i] != self._colours[i]:
                self._client.changeVisualShape(self.bodies[i], -1, rgbaColor=[*COLOURS[keys[i]], 1.0])
                self._colours[i] = keys[i]
        still = present & (frame.states == FROZEN)  # frozen bricks cannot move: drawn once, kept
        kept = self._still
        if kept is None or (kept[3] & ~still).any() or not np.array_equal(poses[kept[3]], kept[4][kept[3]]):
            self._show(still, poses)  # one left the still layer or moved: draw it again
            kept = (*self._shoot(fixed=True), still, poses)
        elif (still & ~kept[3]).any():  # bricks froze since: add them to it
            self._show(still & ~kept[3], poses)
            kept = (*_nearer(kept[:3], self._shoot(fixed=False)), still, poses)
        self._still = kept
        rgb, depth, segmentation = kept[:3]
        moving = present & ~still
        if moving.any():
            self._show(moving, poses)
            rgb, depth, segmentation = _nearer((rgb, depth, segmentation), self._shoot(fixed=False))
        rgb = rgb.copy()
        rgb[segmentation < 0] = np.round(np.array(COLOURS["background"]) * 255).astype(np.uint8)
        edge = np.zeros(segmentation.shape, bool)
        edge[:, 1:] |= segmentation[:, 1:] != segmentation[:, :-1]
        edge[1:, :] |= segmentation[1:, :] != segmentation[:-1, :]
        rgb[edge] = (rgb[edge] * 0.55).astype(np.uint8)
        return rgb

    def close(self) -> None:
        """Disconnect the renderer's client."""
        self._stack.close()

    def __enter__(self) -> Scene:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None, trace: TracebackType | None) -> None:
        self.close()


def _nearer(base: Layer, layer: Layer) -> Layer:
    """Two pictures of one camera merged by depth, as if drawn together."""
    nearer = (layer[2] >= 0) & (layer[1] < base[1])
    rgb = np.where(nearer[..., None], layer[0], base[0])
    return rgb, np.where(nearer, layer[1], base[1]), np.where(nearer, layer[2], base[2])


def render(trajectory: Trajectory, time: float, width: int = 800, height: int = 600) -> np.ndarray:
    """The picture of ``trajectory`` at ``time`` seconds (its last frame at or before): (height, width,
    3) uint8 RGB, no overlay. Raises ValueError: fewer than 16 x 16 pixels; a trajectory with no frame."""
    with Scene(trajectory, width, height) as scene:
        return scene.render(trajectory.at(time))


def scale_bar(pixels_per_metre: float, width: int) -> tuple[float, str]:
    """The longest round length (1, 2 or 5 times a power of ten millimetres) at most a fifth
    of ``width`` pixels long: (metres, its label, e.g. ``"50 mm"``)."""
    most = 0.2 * width / pixels_per_metre  # m
    exponent = math.floor(math.log10(most * 1000.0))
    millimetres = max(m * 10.0**exponent for m in (1.0, 2.0, 5.0) if m * 10.0**exponent <= most * 1000.0 + 1e-9)
    label = f"{millimetres / 1000.0:g} m" if millimetres >= 1000.0 else f"{millimetres:g} mm"
    return millimetres / 1000.0, label


def legend_keys(trajectory: Trajectory, seen: Iterable[str]) -> list[str]:
    """The :data:`COLOURS` keys of a legend, in a fixed order: those ``seen`` (from
    :func:`colour_keys`) but ``"absent"``, and ``"fixture"`` when the run has any."""
    present = set(seen) - {"absent"}
    if len(trajectory.fixture_ids):
        present.add("fixture")
    return [key for key in (*STATES[1:], "projectile", "fixture") if key in present]


def headline(trajectory: Trajectory, time: float) -> str:
    """One line: scenario, mode, ``t = 9.35 s`` and what happened (``collapse at level 9
    (detected at 9.02 s)`` or ``stands``)."""
    meta = trajectory.meta
    collapse = meta.get("collapse")
    result = "stopped early" if meta.get("stopped") else "stands"
    if collapse is not None:
        result = f"collapse at level {collapse['level']} (detected at {float(collapse['time']):.2f} s)"
    name = str(meta.get("scenario") or meta.get("file") or "run")
    if len(name) > 60:
        name = name[:57] + "..."
    return f"{name}  ·  {meta.get('mode', '?')}  ·  t = {time:.2f} s  ·  {result}"


def picture(
    trajectory: Trajectory, at: str | float, path: str | os.PathLike[str], *, width: int = 800, height: int = 600
) -> float:
    """Write a PNG of ``trajectory`` at ``at`` (see :func:`resolve_time`), ``width`` x ``height``
    pixels: the rendered scene under a title line (:func:`headline`), with a scale bar and a
    legend of the colours present. Returns the time drawn, seconds.

    Raises:
        ValueError: ``at`` names no time of the run; ``path`` does not end in ``.png``; a
            picture smaller than 16 x 16 pixels.
        OSError: the file cannot be written.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    if Path(path).suffix.lower() != ".png":
        raise ValueError(f"a picture is written as .png, not {Path(path).name!r}")
    time = resolve_time(trajectory, at)
    band = max(16, round(height / 24))  # the title's strip, pixels
    frame = trajectory.at(time)
    with Scene(trajectory, width, height - band) as scene:
        image = scene.render(frame)
        pixels_per_metre = scene.camera.pixels_per_metre
    dpi = 100.0
    points = max(6.0, min(11.0, height / 60.0))
    figure = Figure(figsize=(width / dpi, height / dpi), dpi=dpi, facecolor="white")
    axes = figure.add_axes((0.0, 0.0, 1.0, (height - band) / height))
    axes.imshow(image, interpolation="nearest")
    axes.set_axis_off()
    title = figure.text(
        6.0 / width, 1.0 - band / 2.0 / height, headline(trajectory, time), fontsize=points, va="center", ha="left"
    )
    wide = title.get_window_extent(FigureCanvasAgg(figure).get_renderer()).width
    if wide > width - 12:  # a long scenario name: a smaller font, so that the line ends inside the picture
        title.set_fontsize(max(5.0, points * (width - 12) / wide))
    metres, label = scale_bar(pixels_per_metre, width)
    left, bottom, length = 0.04 * width, (height - band) * 0.95, metres * pixels_per_metre
    axes.plot([left, left + length], [bottom, bottom], color="black", linewidth=3, solid_capstyle="butt")
    axes.text(left + length / 2.0, bottom - 6, label, ha="center", va="bottom", fontsize=points)
    keys = legend_keys(trajectory, colour_keys(trajectory, frame.states))
    if handles := [Patch(facecolor=COLOURS[key], edgecolor="0.3", label=key) for key in keys]:
        axes.legend(handles=handles, loc="upper right", fontsize=points * 0.9, framealpha=0.85)
    figure.savefig(path, dpi=dpi, format="png")
    return time

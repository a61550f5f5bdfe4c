"""Pictures of a recorded run: a :class:`stackdsl.Trajectory` drawn at one moment.

The bricks are drawn from the recorded poses alone, by a z-buffer in numpy (:class:`Scene`):
no engine, no display, no GPU. The camera is orthographic (a length measures the same at every
depth, so the scale bar is exact), looks at the structure from above at a 3/4 angle and is
framed once per trajectory on every brick's placed pose and the fixtures; matplotlib puts the
title, the scale bar and the legend around it.

Colours say each brick's state (:data:`stackdsl.runtime.trajectory.STATES`): see :data:`COLOURS`.

>>> import stackdsl
>>> from stackdsl.runtime.recorder import record_program
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
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..runtime.trajectory import ABSENT, COLLAPSE_DELAY, FROZEN, STATES, Frame, Trajectory
from ..util.files import written
from .camera import Camera, camera_view, placed_corners

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
#: A picture being drawn: RGB (h, w, 3) uint8, depth (h, w) in m ahead of the camera (smaller
#: is nearer), and the body seen at each pixel (h, w): a brick's index, -2 the ground, -3 and on
#: the fixtures, -1 nothing.
Layer = tuple[np.ndarray, np.ndarray, np.ndarray]
_GROUND = 0.001  # the ground's half thickness, m
_AMBIENT, _DIFFUSE = 0.5, 0.5  # the light: a face lit head-on shows its colour, one turned away half of it


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


def colour_keys(trajectory: Trajectory, states: np.ndarray) -> list[str]:
    """The :data:`COLOURS` key of each body ((bodies,) state codes): its state's name, or
    ``"projectile"``."""
    return ["projectile" if projectile else STATES[state] for projectile, state in zip(trajectory.projectiles, states)]


class Scene:
    """The bodies of ``trajectory`` ready to draw as pictures of ``width`` x ``height`` pixels:
    the camera, the light, the ground and the fixtures are set up once; :meth:`render` draws
    each frame. A context manager (or call :meth:`close`).

    A picture is a z-buffer: every box's faces that look towards the camera are filled pixel
    by pixel with numpy, the nearest face winning, shaded by one light (ambient plus diffuse,
    the same factor on red, green and blue). The still layer (ground, fixtures, frozen
    bricks) is kept until it changes (a shake moves the fixtures with the ground: each frame
    has their offset); the bricks that may move are drawn over a copy of it.
    Raises ValueError for fewer than 16 x 16 pixels. Source: stackdsl's own.
    """

    def __init__(self, trajectory: Trajectory, width: int, height: int) -> None:
        if width < 16 or height < 16:
            raise ValueError(f"a picture must be at least 16 x 16 pixels, not {width} x {height}")
        self.trajectory, self.width, self.height = trajectory, int(width), int(height)
        self._build(trajectory)

    def _build(self, trajectory: Trajectory) -> None:
        """The camera, the light, the ground and each fixture."""
        corners = placed_corners(trajectory)
        low, high = corners.min(axis=0), corners.max(axis=0)
        centre = (low + high) / 2.0
        self.camera = camera = Camera.framing(corners, self.width, self.height, *camera_view(trajectory, centre))
        towards, right = camera.view[2, :3], camera.view[0, :3]  # to the camera, to the picture's right
        light = towards - 0.7 * right + [0.0, 0.0, 1.5]  # from the upper left, behind the camera
        self._light, self._towards = light / np.linalg.norm(light), towards
        # the ground: a square under the structure reaching past the picture's bottom corners
        seen = [camera.ground_point(column, self.height) for column in (0, self.width)]
        reach = max(float(np.abs(p[:2] - centre[:2]).max()) for p in seen) * 1.05
        reach = max(reach, float(max(high[0] - low[0], high[1] - low[1])) / 2.0 + 0.1)
        fixed: list[Box3] = [(-2, np.array([reach, reach, _GROUND]), np.array([*centre[:2], -_GROUND]), _UPRIGHT, "ground")]
        fixtures = zip(trajectory.fixture_half_extents, trajectory.fixture_positions, trajectory.fixture_orientations)
        fixed += [(-3 - k, np.asarray(h), np.asarray(at), np.asarray(q), "fixture") for k, (h, at, q) in enumerate(fixtures)]
        self._fixed = fixed
        self._still: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
        self._still_offset = np.zeros(3)  # the ground's offset the still layer's fixtures were drawn at

    def _canvas(self) -> Layer:
        """An empty :data:`Layer`: no colour, infinite depth, no body."""
        shape = (self.height, self.width)
        # float32 depths and int32 bodies: a 4096 x 4096 picture's layers in 336 MB, not 1 GB
        return np.zeros((*shape, 3), np.uint8), np.full(shape, np.inf, np.float32), np.full(shape, -1, np.int32)

    def _draw(self, layer: Layer, boxes: Iterable[Box3]) -> None:
        """Draw each box into ``layer`` in place, nearer faces hiding farther ones."""
        for ident, half, position, quaternion, key in boxes:
            axes = Rotation.from_quat(quaternion).as_matrix()  # columns: the box's axes in the world
            corners = position + (_SIGNS * half) @ axes.T
            pixels = self.camera.pixels(corners)
            ahead = -(np.c_[corners, np.ones(8)] @ self.camera.view.T)[:, 2]  # m in front of the camera
            colour = np.array(COLOURS[key]) * 255.0
            for (axis, side), face in _FACES.items():
                normal = side * axes[:, axis]
                if float(normal @ self._towards) <= 1e-9:
                    continue  # the face looks away from the camera
                shade = _AMBIENT + _DIFFUSE * max(0.0, float(normal @ self._light))
                _fill(layer, pixels[face], ahead[face], np.round(colour * shade).astype(np.uint8), ident)

    def _carried(self, offset: np.ndarray) -> list[Box3]:
        """The ground and the fixtures, the fixtures moved by the ground's ``offset`` (m, (3,)):
        they are bolted to it (the ground itself is drawn where it rests: a plain square, whose
        motion would not show)."""
        if not offset.any():
            return self._fixed
        return [(i, h, at + offset if i <= -3 else at, q, key) for i, h, at, q, key in self._fixed]

    def _bricks(self, which: np.ndarray, poses: np.ndarray, keys: list[str]) -> list[Box3]:
        half = self.trajectory.half_extents
        return [(int(i), half[i], poses[i, :3], poses[i, 3:], keys[i]) for i in np.flatnonzero(which)]

    def render(self, frame: Frame) -> np.ndarray:
        """The picture of ``frame`` (of this scene's trajectory): (height, width, 3) uint8 RGB,
        each body outlined, the background beyond the ground filled in."""
        keys = colour_keys(self.trajectory, frame.states)
        present = (frame.states != ABSENT) & ~np.isnan(frame.positions[:, 0])
        poses = np.c_[frame.positions, frame.orientations]
        still = present & (frame.states == FROZEN)  # frozen bricks cannot move: drawn once, kept
        kept = self._still
        offset = np.asarray(frame.ground_offset, dtype=float)
        if (
            kept is None
            or (kept[3] & ~still).any()
            or not np.array_equal(poses[kept[3]], kept[4][kept[3]])
            or not np.array_equal(offset, self._still_offset)
        ):
            layer = self._canvas()  # one left the still layer or moved, or the ground did: draw it again
            self._draw(layer, [*self._carried(offset), *self._bricks(still, poses, keys)])
            kept, self._still_offset = (*layer, still, poses), offset
        elif (still & ~kept[3]).any():  # bricks froze since: add them to it
            layer = (kept[0].copy(), kept[1].copy(), kept[2].copy())
            self._draw(layer, self._bricks(still & ~kept[3], poses, keys))
            kept = (*layer, still, poses)
        self._still = kept
        rgb, depth, segmentation = kept[0].copy(), kept[1].copy(), kept[2].copy()
        moving = present & ~still
        if moving.any():
            self._draw((rgb, depth, segmentation), self._bricks(moving, poses, keys))
        rgb[segmentation == -1] = np.round(np.array(COLOURS["background"]) * 255).astype(np.uint8)
        edge = np.zeros(segmentation.shape, bool)
        edge[:, 1:] |= segmentation[:, 1:] != segmentation[:, :-1]
        edge[1:, :] |= segmentation[1:, :] != segmentation[:-1, :]
        rgb[edge] = (rgb[edge] * 0.55).astype(np.uint8)
        return rgb

    def close(self) -> None:
        """Drop the kept still layer (a scene holds nothing outside this process)."""
        self._still = None

    def __enter__(self) -> Scene:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None, trace: TracebackType | None) -> None:
        self.close()


#: A box to draw: (body id in the picture, half extents (3,) m, position (3,) m, quaternion (x, y, z, w), colour key).
Box3 = tuple[int, np.ndarray, np.ndarray, np.ndarray, str]
_UPRIGHT = np.array([0.0, 0.0, 0.0, 1.0])
#: The 8 corners of a box as signs of its half extents, x slowest.
_SIGNS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
#: (axis, side) -> the 4 corners (rows of :data:`_SIGNS`) of that face, in order around it.
_FACES = {
    (0, -1): [0, 1, 3, 2],
    (0, 1): [4, 5, 7, 6],
    (1, -1): [0, 1, 5, 4],
    (1, 1): [2, 3, 7, 6],
    (2, -1): [0, 2, 6, 4],
    (2, 1): [1, 3, 7, 5],
}


def _fill(layer: Layer, corners: np.ndarray, ahead: np.ndarray, colour: np.ndarray, ident: int) -> None:
    """Fill the convex polygon of pixel ``corners`` ((k, 2): column, row, in order around it)
    into ``layer`` where it is nearer than what is there: its depth is the plane through the
    corners' ``ahead`` (m; an orthographic projection keeps a face's depth linear over the
    picture). A pixel is filled when its centre is inside."""
    rgb, depth, body = layer
    height, width = depth.shape
    low = np.maximum(np.floor(corners.min(axis=0)), 0).astype(int)
    high = np.minimum(np.ceil(corners.max(axis=0)), [width, height]).astype(int)
    if (high <= low).any():
        return
    (x0, y0), (x1, y1), (x2, y2) = corners[0], corners[1], corners[2]
    determinant = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    if abs(determinant) < 1e-9:
        return  # seen edge-on
    columns = np.arange(low[0], high[0]) + 0.5
    rows = (np.arange(low[1], high[1]) + 0.5)[:, None]
    sign = 1.0 if determinant > 0 else -1.0
    inside = np.ones((len(rows), len(columns)), bool)
    for k in range(len(corners)):
        (xa, ya), (xb, yb) = corners[k], corners[(k + 1) % len(corners)]
        inside &= sign * ((xb - xa) * (rows - ya) - (yb - ya) * (columns - xa)) >= 0.0
    if not inside.any():
        return
    a = ((ahead[1] - ahead[0]) * (y2 - y0) - (ahead[2] - ahead[0]) * (y1 - y0)) / determinant
    b = ((ahead[2] - ahead[0]) * (x1 - x0) - (ahead[1] - ahead[0]) * (x2 - x0)) / determinant
    z = ahead[0] + a * (columns - x0) + b * (rows - y0)
    window = (slice(low[1], high[1]), slice(low[0], high[0]))
    nearer = inside & (z < depth[window])
    depth[window][nearer] = z[nearer]
    body[window][nearer] = ident
    rgb[window][nearer] = colour


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


#: A legend's words for a colour key, where the key alone would mislead: a pusher is no projectile.
LABELS = {"projectile": "thrown or pushing"}


def legend_keys(trajectory: Trajectory, seen: Iterable[str]) -> list[str]:
    """The :data:`COLOURS` keys of a legend, in a fixed order: those ``seen`` (from
    :func:`colour_keys`) but ``"absent"``, and ``"fixture"`` when the run has any."""
    present = set(seen) - {"absent"}
    if len(trajectory.fixture_ids):
        present.add("fixture")
    return [key for key in (*STATES[1:], "projectile", "fixture") if key in present]


def headline(trajectory: Trajectory, time: float) -> str:
    """One line: scenario, engine and mode, ``t = 9.35 s`` and what happened (``collapse 9 from
    L09.1 (level 9) at 9.02 s``: the collapse level, the brick that moved first, the time it did;
    or ``stands``)."""
    meta = trajectory.meta
    collapse = meta.get("collapse")
    result = "stopped early" if meta.get("stopped") else "stands"
    if collapse is not None:
        result = f"{collapse_text(collapse)} at {float(collapse['time']):.2f} s"
    name = str(meta.get("scenario") or meta.get("file") or "run")
    if len(name) > 60:
        name = name[:57] + "..."
    engine = " ".join(str(meta[k]) for k in ("backend", "mode") if meta.get(k)) or "?"
    return f"{name}  ·  {engine}  ·  t = {time:.2f} s  ·  {result}"


def collapse_text(collapse: dict[str, Any]) -> str:
    """A trajectory's collapse record in words, as check's table says it: ``collapse 10 from
    L07.1 (level 7)`` (the collapse level, then the brick that moved first, when the record names it)."""
    text = f"collapse {collapse['level']}"
    if collapse.get("brick") and collapse.get("brick_level") is not None:
        text += f" from {collapse['brick']} (level {collapse['brick_level']})"
    return text


def picture(
    trajectory: Trajectory, at: str | float, path: str | os.PathLike[str], *, width: int = 800, height: int = 600
) -> float:
    """Write a PNG of ``trajectory`` at ``at`` (see :func:`resolve_time`), ``width`` x ``height``
    pixels: the rendered scene under a title line (:func:`headline`), with a scale bar and a
    legend of the colours present. Returns the time drawn, seconds: the time of the frame drawn,
    the last recorded at or before the time asked for.

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
    band = max(16, round(height / 24))  # the title's strip, pixels
    frame = trajectory.at(resolve_time(trajectory, at))
    time = frame.time  # the frame's own: the last at or before the time asked for
    with Scene(trajectory, width, height - band) as scene:
        image = scene.render(frame)
        pixels_per_metre = scene.camera.pixels_per_metre
    dpi = 100.0
    points = max(6.0, min(11.0, height / 60.0))
    figure = Figure(figsize=(width / dpi, height / dpi), dpi=dpi, facecolor="white")
    axes = figure.add_axes((0.0, 0.0, 1.0, (height - band) / height))
    axes.set_xlim(0, width)
    axes.set_ylim(height - band, 0)
    axes.set_axis_off()
    # the picture's pixels as they are, one to one (imshow resampled them in float64: 2 GB at 4096 x 4096)
    figure.figimage(image, 0, 0, origin="upper", zorder=-1)
    title = figure.text(
        6.0 / width, 1.0 - band / 2.0 / height, headline(trajectory, time), fontsize=points, va="center", ha="left"
    )
    wide = title.get_window_extent(FigureCanvasAgg(figure).get_renderer()).width  # type: ignore[no-untyped-call]
    if wide > width - 12:  # a long scenario name: a smaller font, so that the line ends inside the picture
        title.set_fontsize(max(5.0, points * (width - 12) / wide))
    metres, label = scale_bar(pixels_per_metre, width)
    left, bottom, length = 0.04 * width, (height - band) * 0.95, metres * pixels_per_metre
    axes.plot([left, left + length], [bottom, bottom], color="black", linewidth=3, solid_capstyle="butt")
    axes.text(left + length / 2.0, bottom - 6, label, ha="center", va="bottom", fontsize=points)
    keys = legend_keys(trajectory, colour_keys(trajectory, frame.states))
    if handles := [Patch(facecolor=COLOURS[key], edgecolor="0.3", label=LABELS.get(key, key)) for key in keys]:
        axes.legend(handles=handles, loc="upper right", fontsize=points * 0.9, framealpha=0.85)
    with written(path) as part:
        figure.savefig(part, dpi=dpi, format="png")
    return time

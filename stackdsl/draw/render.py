"""Pictures of a recorded run: a :class:`stackdsl.Trajectory` drawn at one moment.

The bricks are drawn by pybullet's TinyRenderer in a DIRECT client of their own: a z-buffered
software rasteriser that runs headless and ships with pybullet, so a picture needs no display,
no GPU and no new dependency. The camera is orthographic (a length measures the same at every
depth, so the scale bar is exact), looks at the structure from above at a 3/4 angle and is
framed once per trajectory on every brick's placed pose and the fixtures.

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
from contextlib import ExitStack
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from ..runtime.engines.pybullet_world import direct_client
from ..runtime.trajectory import ABSENT, FROZEN, STATES, Frame, Trajectory
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
#: Seconds after the collapse was detected that ``at="collapse"`` shows. At detection a brick has
#: moved only the collapse threshold (4 mm): nothing shows but the colours. 0.2 s later the top
#: seven levels of scenarios/slant_tower.yaml are seen tipping over level 2's edge, still in one
#: piece (0.1 s: barely moved; 0.3 s: a slab lying almost on its side, hard to read), and the top
#: brick of scenarios/hard/overhang_falls.yaml has tipped onto the ground (it does by 0.1 s).
COLLAPSE_DELAY = 0.2
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
    wide = title.get_window_extent(FigureCanvasAgg(figure).get_renderer()).width  # type: ignore[no-untyped-call]
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

"""A run shown live in MuJoCo's viewer (``stackdsl view FILE``), bricks coloured by state.

The viewer shows a model of its own, whatever engine runs the scene: every brick the program
places or throws is a mocap body of an MJCF model (:func:`stackdsl.draw.export.mjcf`), kept
far below the ground until it enters the world. :class:`LiveView` is a
:class:`stackdsl.runtime.recorder.Recorder` (it records the run too) that, about
:data:`FPS` times a simulated second, copies each body's pose from the engine into the
viewer's ``mocap_pos``/``mocap_quat`` and its state colour (frozen, active, woken, fallen,
projectile: :data:`stackdsl.draw.render.COLOURS`) into ``geom_rgba``, and the ground's offset
(a shake's) into the ground's mocap body, which carries the fixtures; then syncs the viewer,
sleeping so that simulated time runs at ``speed`` times wall time (a quiet wait between two
placements, which the step loop jumps over, lasts at most :data:`QUIET_HOLD` wall seconds).
:func:`play` shows a recorded trajectory the same way.

The viewer is any object with MuJoCo's passive viewer's ``sync()``, ``is_running()`` and
``lock()`` (``mujoco.viewer.launch_passive(model, data)`` opens one; it needs a display).

Source: stackdsl's own, on MuJoCo's passive viewer.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from ..compile.program import Launch, Place, Program
from ..engines.protocol import BrickSpec
from ..runtime.loop import StepLoop
from ..runtime.recorder import Recorder
from ..runtime.trajectory import STATES, Trajectory
from .export import Snapshot, body_name, colour_key, mjcf
from .render import COLOURS

#: Pictures a simulated second the viewer is sent.
FPS = 60.0
#: Wall seconds a jump of the step loop over a quiet wait is shown at most.
QUIET_HOLD = 0.25

Viewer = Any
"""MuJoCo's passive viewer handle, or anything with its ``sync``, ``is_running`` and ``lock``."""


class Scene:
    """The viewer's MuJoCo model of a set of bricks, each a mocap body, and its data.

    Every brick is unseen (transparent) at ``positions`` and ``orientations`` (where it will
    enter the world, so that the viewer's camera frames the scene) until :meth:`show` shows it.

    Args:
        ids, levels: each brick's id and level (0: a projectile).
        half_extents, positions: (bricks, 3), metres; orientations: (bricks, 4), (x, y, z, w).
        fixtures: the fixed bodies as a :class:`Snapshot` (its fixture arrays), or None.
        specs: brick id -> spec, for masses and friction.
    """

    def __init__(
        self,
        ids: list[str],
        levels: list[int],
        half_extents: np.ndarray,
        positions: np.ndarray,
        orientations: np.ndarray,
        fixtures: Snapshot | None = None,
        specs: dict[str, BrickSpec] | None = None,
    ) -> None:
        import mujoco

        n = len(ids)
        empty3, empty4 = np.zeros((0, 3)), np.zeros((0, 4))
        scene = Snapshot(
            time=0.0,
            name="stackdsl view",
            ids=list(ids),
            levels=list(levels),
            states=["active"] * n,
            half_extents=np.asarray(half_extents, dtype=float).reshape(-1, 3),
            positions=np.asarray(positions, dtype=float).reshape(-1, 3),
            orientations=np.asarray(orientations, dtype=float).reshape(-1, 4),
            fixture_ids=fixtures.fixture_ids if fixtures else [],
            fixture_half_extents=fixtures.fixture_half_extents if fixtures else empty3,
            fixture_positions=fixtures.fixture_positions if fixtures else empty3,
            fixture_orientations=fixtures.fixture_orientations if fixtures else empty4,
            specs=dict(specs or {}),
        )
        self.mujoco = mujoco
        self.model = mujoco.MjModel.from_xml_string(mjcf(scene, mocap=True))
        self.data = mujoco.MjData(self.model)
        self.ids, self.levels = list(ids), list(levels)
        self.mocap = np.array([self.model.body_mocapid[self.model.body(body_name(b)).id] for b in ids], dtype=int)
        self.geom = np.array([self.model.geom(b).id for b in ids], dtype=int)
        self.index = {b: i for i, b in enumerate(ids)}
        self.ground = int(self.model.body_mocapid[self.model.body("ground").id])  # the ground and the fixtures on it
        self.model.geom_rgba[self.geom, 3] = 0.0  # unseen until it enters the world
        mujoco.mj_kinematics(self.model, self.data)

    def show(
        self,
        bricks: list[int],
        positions: np.ndarray,
        orientations: np.ndarray,
        states: list[str],
        ground_offset: tuple[float, float, float] | np.ndarray = (0.0, 0.0, 0.0),
    ) -> None:
        """Put ``bricks`` (indices into ``ids``) at ``positions`` (m) and ``orientations`` ((x, y,
        z, w)), coloured by ``states``, and the ground with its fixtures ``ground_offset`` (m) from
        where it rests; every other brick stays where it was."""
        self.data.mocap_pos[self.ground] = ground_offset
        if bricks:
            b = np.asarray(bricks, dtype=int)
            self.data.mocap_pos[self.mocap[b]] = positions
            self.data.mocap_quat[self.mocap[b]] = np.asarray(orientations)[:, [3, 0, 1, 2]]
            for i, state in zip(bricks, states):
                self.model.geom_rgba[self.geom[i]] = (*COLOURS[colour_key(self.levels[i], state)], 1.0)
        self.mujoco.mj_kinematics(self.model, self.data)

    def aim(self, camera: Any) -> None:
        """Point a viewer's free camera (an ``mjvCamera``; take the viewer's lock first) at the
        bricks where they enter: from 2.5 model extents away, 20 deg above the ground."""
        camera.lookat[:] = self.model.stat.center
        camera.distance = 2.5 * float(self.model.stat.extent)
        camera.azimuth, camera.elevation = 120.0, -20.0

    def colour_of(self, brick: str) -> tuple[float, float, float]:
        """The colour brick ``brick`` is shown in now (r, g, b in 0..1)."""
        r, g, b = (float(c) for c in self.model.geom_rgba[self.geom[self.index[brick]], :3])
        return r, g, b

    def fixture_positions(self) -> dict[str, np.ndarray]:
        """Where each fixed body is shown now (m), carried by the ground's offset."""
        ground = self.model.body("ground").id
        geoms = [
            g for g in range(self.model.ngeom) if self.model.geom_bodyid[g] == ground and self.model.geom(g).name != "ground"
        ]
        return {self.model.geom(g).name: self.data.geom_xpos[g].copy() for g in geoms}

    def pose_of(self, brick: str) -> tuple[np.ndarray, np.ndarray]:
        """Where brick ``brick`` is shown now: position (m) and quaternion (x, y, z, w)."""
        m = self.mocap[self.index[brick]]
        return self.data.mocap_pos[m].copy(), self.data.mocap_quat[m][[1, 2, 3, 0]].copy()


def _fixed_bodies(ids: list[str], half_extents: np.ndarray, positions: np.ndarray, orientations: np.ndarray) -> Snapshot:
    """A snapshot of the fixed bodies alone (half extents, positions in m, (n, 3); unit
    quaternions (x, y, z, w), (n, 4)): what the viewer builds its static geometry from."""
    return Snapshot(
        time=0.0,
        name="",
        ids=[],
        levels=[],
        states=[],
        half_extents=np.zeros((0, 3)),
        positions=np.zeros((0, 3)),
        orientations=np.zeros((0, 4)),
        fixture_ids=ids,
        fixture_half_extents=half_extents,
        fixture_positions=positions,
        fixture_orientations=orientations,
    )


def program_scene(program: Program) -> Scene:
    """The viewer's model of every brick ``program`` places or throws, and its fixed bodies."""
    from stability import Pose

    bodies = [a for a in program.actions if isinstance(a, (Place, Launch))]
    fixtures = program.fixtures
    fixed = _fixed_bodies(
        [f.id for f in fixtures],
        np.array([f.brick.half_extents for f in fixtures], dtype=float).reshape(-1, 3),
        np.array([f.position for f in fixtures], dtype=float).reshape(-1, 3),
        np.array([Pose.from_euler(f.position, f.yaw, f.pitch, f.roll).orientation for f in fixtures], dtype=float).reshape(-1, 4),
    )
    return Scene(
        [a.id for a in bodies],
        [a.level if isinstance(a, Place) else 0 for a in bodies],
        np.array([a.brick.half_extents for a in bodies], dtype=float).reshape(-1, 3),
        np.array([a.position for a in bodies], dtype=float).reshape(-1, 3),
        np.array([Pose.from_euler(a.position, a.yaw, a.pitch, getattr(a, "roll", 0.0)).orientation for a in bodies]).reshape(
            -1, 4
        ),
        fixed,
        {a.id: a.brick for a in bodies},
    )


def _paced(viewer: Viewer, speed: float, sleep: Callable[[float], None], clock: Callable[[], float]) -> Callable[[float], bool]:
    """A function of simulated time that syncs ``viewer`` and sleeps until the wall ``clock``
    (seconds) has caught up with it at ``speed``; False once the viewer was closed."""
    last = [0.0, clock()]  # simulated and wall time of the last picture

    def shown(now: float) -> bool:
        if not viewer.is_running():
            return False
        viewer.sync()
        wall = clock()
        target = last[1] + min((now - last[0]) / speed, QUIET_HOLD)
        if target > wall:
            sleep(target - wall)
        last[0], last[1] = now, max(target, wall)
        return True

    return shown


class LiveView(Recorder):
    """Shows a run in ``viewer`` as it runs (attach it with ``run_program(..., subscribers=(view,))``).

    Args:
        program: the program being run; scene: its :func:`program_scene`.
        viewer: the viewer showing ``scene.model`` and ``scene.data``.
        speed: simulated seconds a wall second (1: real time).
        sleep, clock: how to wait and read the wall clock (``time.sleep``, ``time.perf_counter``;
            a test passes its own).
    """

    def __init__(
        self,
        program: Program,
        scene: Scene,
        viewer: Viewer,
        speed: float = 1.0,
        sleep: Callable[[float], None] = time.sleep,
        clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        super().__init__(program)
        self.scene, self.viewer = scene, viewer
        self._shown = _paced(viewer, speed, sleep, clock)
        self._every = max(1, round(1.0 / (FPS * program.engine.timestep)))
        self._next_picture = 0
        self.pictures = 0
        self.open = True

    def on_place(self, loop: StepLoop, record: Any) -> None:
        super().on_place(loop, record)
        self._picture(loop)

    def on_launch(self, loop: StepLoop, record: Any) -> None:
        super().on_launch(loop, record)
        self._picture(loop)

    def after_step(self, loop: StepLoop) -> None:
        super().after_step(loop)
        if loop.step >= self._next_picture:
            self._picture(loop)
            self._next_picture = loop.step + self._every

    def at_end(self, loop: StepLoop) -> None:
        super().at_end(loop)
        self._picture(loop)

    def _count(self, loop: StepLoop, rows: int) -> None:
        """Nothing: a live view shows its run whole, and writes no trajectory file to hold to its limit."""

    def _picture(self, loop: StepLoop) -> None:
        if not self.open:
            return
        records = self._records
        positions, quaternions = loop.world.poses_of([r.body for r in records])
        states = [STATES[s] for s in self._states(loop, records)]
        with self.viewer.lock():
            self.scene.show([self.scene.index[r.id] for r in records], positions, quaternions, states, loop.structure.offset)
        self.open = self._shown(loop.now)
        self.pictures += self.open


def trajectory_scene(trajectory: Trajectory) -> Scene:
    """The viewer's model of a recorded trajectory's bodies and fixed bodies."""
    fixed = _fixed_bodies(
        [str(f) for f in trajectory.fixture_ids.tolist()],
        trajectory.fixture_half_extents,
        trajectory.fixture_positions,
        trajectory.fixture_orientations,
    )
    first = np.unique(trajectory.row_body, return_index=True)[1]  # each body's first row (rows are in frame order)
    count = len(trajectory.ids)
    positions, orientations = np.zeros((count, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (count, 1))
    bodies = trajectory.row_body[first]
    positions[bodies], orientations[bodies] = trajectory.row_position[first], trajectory.row_orientation[first]
    return Scene(
        [str(i) for i in trajectory.ids.tolist()],
        [int(v) for v in trajectory.levels.tolist()],
        trajectory.half_extents,
        positions,
        orientations,
        fixed,
    )


def play(
    trajectory: Trajectory,
    scene: Scene,
    viewer: Viewer,
    speed: float = 1.0,
    sleep: Callable[[float], None] = time.sleep,
    clock: Callable[[], float] = time.perf_counter,
    deadline: float | None = None,
) -> int:
    """Show a recorded trajectory's frames in ``viewer`` at ``speed`` (``sleep`` and ``clock`` as
    :class:`LiveView`'s) until ``deadline`` (``clock`` seconds; None: none); the pictures shown
    (fewer when the viewer is closed or the deadline passes before the end)."""
    shown = _paced(viewer, speed, sleep, clock)
    pictures = 0
    for frame in trajectory.frames():
        if deadline is not None and clock() >= deadline:
            break
        present = np.flatnonzero(~np.isnan(frame.positions[:, 0]))
        with viewer.lock():
            scene.show(
                present.tolist(),
                frame.positions[present],
                frame.orientations[present],
                [STATES[s] for s in frame.states[present]],
                frame.ground_offset,
            )
        pictures += 1
        if not shown(frame.time):
            break
    return pictures


__all__ = ["FPS", "LiveView", "Scene", "play", "program_scene", "trajectory_scene"]

"""The recorder: a step-loop subscriber that keeps a :class:`stackdsl.Trajectory`.

It takes a frame

* when a brick is placed or a projectile thrown, when a pull, a push or a shake starts, and
  when the timeline gets an event (a freeze, a wake, an impact, the collapse);
* at each step a structure brick is first found past the collapse threshold while no
  collapse has been decided: the collapse is dated at one of these steps, back in the
  timeline, so that its moment has a frame of its own (and the collapse graph, taken then);
* :data:`FLIGHT_FRAMES` times evenly within each projectile's flight to its target;
* at the times it is asked for (``at``: a picture or an export of one moment) and
  :data:`~stackdsl.runtime.trajectory.COLLAPSE_DELAY` after each of those threshold steps (the
  moment ``at="collapse"`` shows): at the last physics step at or before each, so that the
  trajectory at that time is the run's state then, not a frame up to ``1 / rate`` earlier; a
  time the loop jumped over (nothing could move) gets a frame with no row;
* every ``1 / rate`` simulated seconds while anything moves: a body the stability
  extension has not frozen is faster than its rest speed or rest angular speed (one more
  frame when everything has come to rest);
* at the end.

A recording is held to what a trajectory file may hold, :data:`~stackdsl.runtime.trajectory.MAX_TRAJECTORY_BYTES`
(64 MiB, what ``replay`` and ``render`` read): the recorder counts its rows and frames as it keeps them, and
the step that would pass it ends the run with :class:`~stackdsl.runtime.trajectory.TrajectoryTooLarge`
(saying when, and at what rate), as does a whole trajectory larger than it, so that nothing a reader
would refuse is ever written.

Each frame also keeps the ground's offset from its rest (a shake moves it, and the fixtures
bolted to it), so that a replay, a picture or a clip moves the fixtures with the ground.

A run without a recorder does none of this: recording off is the runtime as it is.

>>> import stackdsl
>>> program = stackdsl.compile_scenario(stackdsl.parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 2}}"))
>>> outcome, trajectory = record_program(program)  # or attach Recorder(program) to run_program
>>> trajectory.ids.tolist(), trajectory.at(trajectory.end).state_names
(['L01.1', 'L01.2', 'L02.1', 'L02.2'], ['frozen', 'frozen', 'frozen', 'frozen'])

Source: stackdsl's own.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable
from typing import Any

import numpy as np

from stability import Pose

from ..compile.program import Kinematic, Launch, Program, Push, require_program
from .bricks import BrickRecord
from .collapse import CollapseMonitor
from .loop import StepLoop, Subscriber
from .outcome import Outcome
from .run import run_program
from .trajectory import (
    ABSENT,
    ACTIVE,
    ANGLE_TOLERANCE,
    COLLAPSE_DELAY,
    FALLEN,
    FRAME_BYTES,
    FROZEN,
    MAX_TRAJECTORY_BYTES,
    POSITION_TOLERANCE,
    ROW_BYTES,
    WOKEN,
    Trajectory,
    TrajectoryTooLarge,
)

#: Frames a simulated second while anything moves, by default.
RATE = 30.0
#: Frames taken evenly within each projectile's flight to its target (when it lasts that many
#: steps): a throw at 2.4 m/s crosses its 50 mm in 21 ms, less than one frame at :data:`RATE`.
FLIGHT_FRAMES = 2
_COS_HALF_TOLERANCE = math.cos(ANGLE_TOLERANCE / 2.0)


class Recorder(Subscriber):
    """Records a run of ``program``: attach it, then ask it for the run's :class:`Trajectory`
    (:func:`record_program` does both).

    >>> from stackdsl import compile_scenario, parse_scenario, run_program
    >>> program = compile_scenario(parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 2}}\\n"))
    >>> recorder = Recorder(program)
    >>> trajectory = recorder.trajectory(run_program(program, subscribers=(recorder,)))
    >>> len(trajectory.ids)
    4

    Args:
        program: the program being run.
        rate: frames per simulated second while anything moves (Hz, above 0); at most one
            frame a physics step.
        source: the scenario file, kept in the trajectory's ``meta``.
        at: seconds at which to keep a frame besides (the last step at or before each).

    Raises:
        ValueError: ``rate`` is not a number above 0; a time of ``at`` is not a number.
        TrajectoryTooLarge: (from a hook, ending the run; or from :meth:`trajectory`) the recording
            passes :data:`~stackdsl.runtime.trajectory.MAX_TRAJECTORY_BYTES`.
    """

    def __init__(self, program: Program, rate: float = RATE, source: str = "", at: Iterable[float] = ()) -> None:
        if not (isinstance(rate, (int, float)) and 0 < rate < math.inf):
            raise ValueError(f"the recording rate must be a number of frames a second above 0, not {rate!r}")
        self.program, self.rate, self.source = program, float(rate), source
        # the steps at which a frame is asked for, earliest first
        self._wanted = [self._step_of(float(t)) for t in at if 0.0 <= float(t) < math.inf]
        heapq.heapify(self._wanted)
        self.every = max(1, round(1.0 / (rate * program.engine.timestep)))  # physics steps between samples
        config = program.stability
        self._rest = (config.rest_speed, config.rest_angular_speed)
        self._records: list[BrickRecord] = []
        self._times: list[float] = []
        self._ground: list[tuple[float, float, float]] = []  # the ground's offset at each frame (a shake's)
        # per frame: the frame, the bodies with a row, their positions, quaternions and states
        self._rows: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
        # each body's last row: position (NaN before its first), quaternion, state
        self._last_position = np.zeros((0, 3))
        self._last_orientation = np.zeros((0, 4))
        self._last_state = np.zeros(0, np.int8)
        self._resting = np.zeros(0, bool)  # frozen when its last row was taken
        self._next_sample = 0
        self._moving = False
        self._seen_events = 0
        self._flight: set[int] = set()  # steps at which a projectile in flight is recorded
        self._away: set[str] = set()  # pulled bricks and pushers taken out of the scene: absent from then on
        self._graph_time: float | None = None  # when the collapse graph was taken (s), once there is one
        self._monitor: CollapseMonitor | None = None  # the run's collapse monitor (found at the first step)
        self._passed = 0  # how many threshold crossings the monitor had seen at the last step
        self._bytes = 0  # what the kept frames and rows take in the trajectory's arrays

    # hooks --------------------------------------------------------------------
    def on_place(self, loop: StepLoop, record: BrickRecord) -> None:
        self._catch_up(loop)
        self._records.append(record)
        self._frame(loop)

    def on_launch(self, loop: StepLoop, record: BrickRecord) -> None:
        self._catch_up(loop)
        self._records.append(record)
        self._frame(loop)
        launch = next((a for a in self.program.actions if isinstance(a, Launch) and a.id == record.id), None)
        if launch is not None:  # frames in the flight too, however short: a clip shows the throw
            dt, flight = self.program.engine.timestep, max(launch.arrival - launch.time, 0.0)
            steps = {loop.step + round(flight * k / (FLIGHT_FRAMES + 1) / dt) for k in range(1, FLIGHT_FRAMES + 1)}
            self._flight |= {s for s in steps if s > loop.step}

    def on_action(self, loop: StepLoop, action: Kinematic) -> None:
        """A push's pusher enters the world (made by :class:`stackdsl.runtime.actions.Actions`,
        a subscriber before this one): recorded as a projectile is, so that a replay, a clip or a
        picture shows the finger that pushed."""
        wanted = self._catch_up(loop)
        record = loop.structure.records.get(action.id) if isinstance(action, Push) else None
        entered = record is not None and record not in self._records
        if record is not None and entered:
            self._records.append(record)
        if entered or wanted or len(loop.events) != self._seen_events:  # and the bricks it woke, at its own time
            self._frame(loop)

    def after_step(self, loop: StepLoop) -> None:
        if self._monitor is None:
            self._monitor = next((s for s in loop.subscribers if isinstance(s, CollapseMonitor)), None)
        passed = self._monitor.passed if self._monitor is not None else 0
        crossed, self._passed = passed != self._passed, passed
        if crossed:  # the moment a picture or an export "at the collapse" shows, should it be dated now
            heapq.heappush(self._wanted, self._step_of(loop.now + COLLAPSE_DELAY))
        wanted = self._catch_up(loop)
        # a freeze, a wake, an impact, the collapse; a brick past the threshold (a collapse may be dated then)
        if len(loop.events) != self._seen_events or loop.step in self._flight or crossed or wanted:
            self._flight.discard(loop.step)
            self._frame(loop)
        elif loop.step >= self._next_sample:
            moving = self._anything_moves(loop)
            if moving or self._moving:  # and one frame once everything has come to rest
                self._frame(loop)
            self._moving = moving
            self._next_sample = loop.step + self.every

    def on_glide(self, loop: StepLoop, steps: int) -> None:
        """Frames over a glide (:meth:`stackdsl.runtime.loop.Subscriber.glide`), at the rate and
        at the times asked for (``at``): the hand carried a pulled brick along its straight path
        at its constant velocity, so each moving body's row is the straight way from its last
        row to where it is now, at the frame's time (a replay showed the brick in 6 mm jumps, 7 a
        second, where it slides, and an export at a time inside a glide the brick where the last
        frame left it)."""
        watched = np.array([i for i, r in enumerate(self._records) if r.moving], dtype=int)
        since = self._times[-1] if self._times else loop.now
        if not len(watched) or loop.now <= since or np.isnan(self._last_position[watched, 0]).any():
            return  # nothing to draw a way for: the frames asked for come without rows (_catch_up)
        wanted = set()
        while self._wanted and self._wanted[0] <= loop.step:
            wanted.add(heapq.heappop(self._wanted))
        while self._next_sample < loop.step:
            wanted.add(self._next_sample)
            self._next_sample += self.every
        chosen = [self._records[i] for i in watched]
        positions, _ = loop.world.poses_of([r.body for r in chosen])
        start, states = self._last_position[watched].copy(), self._states(loop, chosen)
        for step in sorted(wanted):
            at = step * loop.dt
            if at <= since:
                continue
            index = len(self._times)
            self._times.append(at)
            self._ground.append(self._ground[-1])
            now = start + (positions - start) * ((at - since) / (loop.now - since))
            self._last_position[watched] = now
            self._rows.append(
                (np.full(len(watched), index, np.int32), watched.astype(np.int32), now, self._last_orientation[watched], states)
            )
            self._count(loop, len(watched))

    def at_end(self, loop: StepLoop) -> None:
        self._catch_up(loop)
        if not self._times or self._times[-1] < loop.now:
            self._frame(loop)
        monitor = next((s for s in loop.subscribers if isinstance(s, CollapseMonitor)), None)
        if monitor is not None and monitor.graph_step is not None:
            self._graph_time = monitor.graph_step * loop.dt

    # frames -------------------------------------------------------------------
    def _step_of(self, time: float) -> int:
        """The last physics step at or before ``time`` seconds."""
        return math.floor(time / self.program.engine.timestep + 1e-6)

    def _catch_up(self, loop: StepLoop) -> bool:
        """Whether a frame is asked for at this step. A step asked for that the loop jumped over
        (every subscriber quiet: nothing moved) gets a frame of its own with no row, the scene as
        the last frame left it."""
        now = False
        while self._wanted and self._wanted[0] <= loop.step:
            step = heapq.heappop(self._wanted)
            if step == loop.step:
                now = True
            elif self._times and self._times[-1] < step * loop.dt - 1e-12:
                self._times.append(step * loop.dt)
                self._ground.append(self._ground[-1])
                self._bytes += FRAME_BYTES
        return now

    def _anything_moves(self, loop: StepLoop) -> bool:
        moving = [r for r in self._records if r.moving]
        if not moving:
            return False
        linear, angular = loop.world.velocities_of([r.body for r in moving])
        speed, spin = self._rest
        return bool(((linear**2).sum(axis=1) > speed * speed).any() or ((angular**2).sum(axis=1) > spin * spin).any())

    def _frame(self, loop: StepLoop) -> None:
        """A frame now: a row for each body that entered, moved or changed state since its
        last row. Bodies frozen since their last row are not read: they cannot move."""
        self._away |= {e.brick for e in loop.events[self._seen_events :] if e.kind == "release"}
        self._seen_events = len(loop.events)
        index = len(self._times)
        self._times.append(loop.now)
        self._ground.append(loop.structure.offset)  # set by the shake (an earlier subscriber) each step
        records = self._records
        new = len(records) - len(self._last_state)
        if new:  # bodies that entered since the last frame: no row yet
            self._last_position = np.vstack([self._last_position, np.full((new, 3), np.nan)])
            self._last_orientation = np.vstack([self._last_orientation, np.tile([0.0, 0.0, 0.0, 1.0], (new, 1))])
            self._last_state = np.concatenate([self._last_state, np.full(new, ABSENT, np.int8)])
            self._resting = np.concatenate([self._resting, np.zeros(new, bool)])
        watched = np.array([i for i, r in enumerate(records) if r.moving or not self._resting[i]], dtype=int)
        if not len(watched):
            self._count(loop, 0)
            return
        chosen = [records[i] for i in watched]
        positions, quaternions = loop.world.poses_of([r.body for r in chosen])
        states = self._states(loop, chosen)
        moved = ((positions - self._last_position[watched]) ** 2).sum(axis=1) > POSITION_TOLERANCE**2
        # turned by more than the tolerance: cos(angle / 2) = |q . q0| for unit quaternions
        turned = np.abs((quaternions * self._last_orientation[watched]).sum(axis=1)) < _COS_HALF_TOLERANCE
        changed = moved | turned | (states != self._last_state[watched]) | np.isnan(self._last_position[watched, 0])
        bodies = watched[changed]
        self._last_position[bodies], self._last_orientation[bodies] = positions[changed], quaternions[changed]
        self._last_state[bodies] = states[changed]
        self._resting[watched] = [not r.moving for r in chosen]
        self._rows.append(
            (
                np.full(len(bodies), index, np.int32),
                bodies.astype(np.int32),
                positions[changed],
                quaternions[changed],
                states[changed],
            )
        )
        self._count(loop, len(bodies))

    def _count(self, loop: StepLoop, rows: int) -> None:
        """Count a frame of ``rows`` rows; past :data:`MAX_TRAJECTORY_BYTES`, end the run."""
        self._bytes += FRAME_BYTES + rows * ROW_BYTES
        if self._bytes > MAX_TRAJECTORY_BYTES:
            raise TrajectoryTooLarge(
                f"the recording passed the {MAX_TRAJECTORY_BYTES >> 20} MiB a trajectory file may hold at t = {loop.now:.2f} s "
                f"simulated (of {self.program.duration:g} s), {len(self._times)} frames of {len(self._records)} bodies "
                f"at {self.rate:g} frames a second while anything moves"
            )

    def _states(self, loop: StepLoop, records: list[BrickRecord]) -> np.ndarray:
        """The state codes of ``records`` now (:data:`stackdsl.runtime.trajectory.STATES`): a
        structure brick farther than the collapse threshold from where it was placed has
        fallen, moving or frozen again where it came to rest."""
        threshold = self.program.collapse_threshold
        states = np.array([FROZEN if not r.moving else WOKEN if r.was_frozen else ACTIVE for r in records], np.int8)
        states[[r.settled is not None and r.settled > threshold for r in records]] = FALLEN
        states[[r.id in self._away for r in records]] = ABSENT
        moving = [i for i, r in enumerate(records) if r.structure and r.moving]
        if moving:
            far = loop.structure.displacements([records[i] for i in moving]) > threshold
            states[np.array(moving)[far]] = FALLEN
        return states

    # the result ---------------------------------------------------------------
    def trajectory(self, outcome: Outcome) -> Trajectory:
        """The recorded trajectory of the run that produced ``outcome``."""
        records, program = self._records, self.program
        placed = {a.id: a.level for a in program.placements}  # a pulled brick's level, which its record lets go of
        graphs = {"final": outcome.final_graph}
        if outcome.collapse_graph is not None:
            graphs["collapse"] = outcome.collapse_graph
        trajectory = Trajectory(
            meta=self._meta(outcome),
            ids=np.array([r.id for r in records], dtype=str),
            levels=np.array([r.level or placed.get(r.id, 0) for r in records], dtype=np.int32),
            half_extents=np.array([r.spec.half_extents for r in records], dtype=float).reshape(-1, 3),
            **self._fixture_arrays(),
            times=np.array(self._times, dtype=float),
            ground_offset=np.array(self._ground, dtype=float).reshape(-1, 3),
            **self._row_arrays(),
            events=outcome.events,
            graphs=graphs,
        )
        size = trajectory.stored_size  # the rows counted, and the header (events, graphs) besides
        if size > MAX_TRAJECTORY_BYTES:
            raise TrajectoryTooLarge(
                f"the recording takes {size / 2**20:.1f} MiB with its events and brick graphs, more than the "
                f"{MAX_TRAJECTORY_BYTES >> 20} MiB a trajectory file may hold"
            )
        return trajectory

    def _meta(self, outcome: Outcome) -> dict[str, Any]:
        """The trajectory's ``meta`` record: the program's settings and the outcome's summary."""
        program = self.program
        return {
            "scenario": program.name,
            "file": self.source,
            "mode": program.engine.mode,
            "backend": program.engine.backend,
            "model": program.stability.model,
            "timestep": program.engine.timestep,
            "collapse_threshold": program.collapse_threshold,
            "rate": self.rate,
            "collapse": outcome.collapse.model_dump(mode="json") if outcome.collapse else None,
            "collapse_graph_time": self._graph_time if outcome.collapse_graph is not None else None,
            "levels_placed": outcome.levels_placed,
            "simulated_time": outcome.simulated_time,
            "stopped": outcome.stopped,
            "judged_at": program.judged_at,
        }

    def _fixture_arrays(self) -> dict[str, np.ndarray]:
        """The program's fixtures: ids, half extents (m), positions (m) and unit quaternions."""
        fixtures = self.program.fixtures
        quaternions = [Pose.from_euler(f.position, f.yaw, f.pitch, f.roll).orientation for f in fixtures]
        return {
            "fixture_ids": np.array([f.id for f in fixtures], dtype=str),
            "fixture_half_extents": np.array([f.brick.half_extents for f in fixtures], dtype=float).reshape(-1, 3),
            "fixture_positions": np.array([f.position for f in fixtures], dtype=float).reshape(-1, 3),
            "fixture_orientations": np.array(quaternions, dtype=float).reshape(-1, 4),
        }

    def _row_arrays(self) -> dict[str, np.ndarray]:
        """The recorded rows, one a moving body a kept frame: frame, body, position (m),
        orientation and state, each an array empty of the right shape when nothing was kept."""
        rows = self._rows
        return {
            "row_frame": np.concatenate([r[0] for r in rows] or [np.zeros(0, np.int32)]),
            "row_body": np.concatenate([r[1] for r in rows] or [np.zeros(0, np.int32)]),
            "row_position": np.concatenate([r[2] for r in rows] or [np.zeros((0, 3))]),
            "row_orientation": np.concatenate([r[3] for r in rows] or [np.zeros((0, 4))]),
            "row_state": np.concatenate([r[4] for r in rows] or [np.zeros(0, np.int8)]),
        }


def record_program(
    program: Program, rate: float = RATE, *, source: str = "", timeout: float | None = None, at: Iterable[float] = ()
) -> tuple[Outcome, Trajectory]:
    """Run ``program`` with a :class:`Recorder` attached: its outcome and its trajectory.

    Args:
        program: a compiled program.
        rate: frames a simulated second while anything moves (Hz).
        source: the scenario file, kept in the trajectory.
        timeout: as :func:`stackdsl.run_program`'s.
        at: seconds at which to keep a frame besides (:class:`Recorder`).

    Raises:
        ValueError: a bad ``rate`` or ``timeout``.
        TrajectoryTooLarge: the recording passed what a trajectory file may hold (the run ends then).
        TypeError: ``program`` is not a :class:`Program` (as :func:`stackdsl.run_program`).
    """
    require_program(program, "record_program")
    recorder = Recorder(program, rate, source, at)
    outcome = run_program(program, timeout=timeout, subscribers=(recorder,))
    return outcome, recorder.trajectory(outcome)


__all__ = ["RATE", "Recorder", "record_program"]

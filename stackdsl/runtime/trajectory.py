"""A recorded run: every brick's pose and state over time, with the run's events.

A :class:`Trajectory` is what ``stackdsl run FILE --record out.npz`` writes and what the
pictures, clips and reports are drawn from. It is stored as *rows*: a row gives one body's
pose and state at one frame, and a body gets a row only when it entered the world, moved
more than :data:`POSITION_TOLERANCE` or :data:`ANGLE_TOLERANCE`, or changed state since its
last row. A body's pose at a frame is that of its last row at or before the frame, so a
frozen tower of a thousand bricks costs a row per brick, not a row per brick per frame.

Load a file with :func:`load_trajectory` (it is also a plain ``numpy.load`` archive: every
array is a number or text array, no pickles)::

    trajectory = stackdsl.load_trajectory("out.npz")
    frame = trajectory.at(trajectory.collapse_time or trajectory.end)
    frame.positions        # (bodies, 3), metres
    frame.states           # (bodies,), codes of STATES; frame.state_names: the same as words

Source: stackdsl's own.
"""

from __future__ import annotations

import json
import os
import zipfile
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..lang.files import written
from .outcome import Event, Graph

#: Format version of a trajectory file.
FORMAT = 1
#: State codes of a body at a frame: not in the world yet; moved by the engine and never
#: frozen; frozen by the stability extension; moving again after a freeze; farther than the
#: collapse threshold from where it was placed (structure bricks only; projectiles never fall).
ABSENT, ACTIVE, FROZEN, WOKEN, FALLEN = 0, 1, 2, 3, 4
STATES = ("absent", "active", "frozen", "woken", "fallen")
#: A body gets a new row when it moved farther than this (m) or turned more than
#: :data:`ANGLE_TOLERANCE` (rad) since its last row, or changed state.
POSITION_TOLERANCE = 1e-5
ANGLE_TOLERANCE = 1e-4


@dataclass(frozen=True)
class Frame:
    """Every body at one moment.

    Attributes:
        index: the frame's index; time: seconds.
        positions: (bodies, 3), metres (NaN for a body not in the world yet).
        orientations: (bodies, 4), unit quaternions (x, y, z, w) (NaN likewise).
        states: (bodies,), codes of :data:`STATES`.
    """

    index: int
    time: float
    positions: np.ndarray
    orientations: np.ndarray
    states: np.ndarray

    @property
    def state_names(self) -> list[str]:
        """Each body's state by name: ``"absent"``, ``"active"``, ``"frozen"``, ``"woken"`` or ``"fallen"``."""
        return [STATES[s] for s in self.states]


@dataclass(frozen=True)
class Trajectory:
    """A recorded run.

    Attributes:
        meta: scenario, file, mode, model, timestep (s), collapse_threshold (m), rate (Hz),
            collapse (the :class:`stackdsl.Collapse` as a dict, or None), levels_placed,
            simulated_time (s), stopped.
        ids: (bodies,), each body's id, in the order they entered the world.
        levels: (bodies,), a structure brick's level; 0 for a projectile.
        half_extents: (bodies, 3), metres.
        fixtures: ids (fixtures,), half extents (fixtures, 3), positions (fixtures, 3) and
            orientations (fixtures, 4) of the immovable bodies (walls, ramps).
        times: (frames,), seconds, increasing.
        row_frame, row_body: (rows,), the frame and the body of each row.
        row_position, row_orientation: (rows, 3) and (rows, 4); row_state: (rows,).
        events: the run's timeline; graphs: ``"final"`` and, after a collapse, ``"collapse"``.
    """

    meta: dict[str, Any]
    ids: np.ndarray
    levels: np.ndarray
    half_extents: np.ndarray
    fixture_ids: np.ndarray
    fixture_half_extents: np.ndarray
    fixture_positions: np.ndarray
    fixture_orientations: np.ndarray
    times: np.ndarray
    row_frame: np.ndarray
    row_body: np.ndarray
    row_position: np.ndarray
    row_orientation: np.ndarray
    row_state: np.ndarray
    events: tuple[Event, ...]
    graphs: dict[str, Graph]

    # questions ----------------------------------------------------------------
    @property
    def projectiles(self) -> np.ndarray:
        """(bodies,) booleans: True for a projectile."""
        return np.asarray(self.levels == 0)

    @property
    def end(self) -> float:
        """Seconds, the time of the last frame."""
        return float(self.times[-1]) if len(self.times) else 0.0

    @property
    def collapse_time(self) -> float | None:
        """Seconds, when the first collapse was detected; None when the structure stood."""
        collapse = self.meta.get("collapse")
        return None if collapse is None else float(collapse["time"])

    def frame_index(self, time: float) -> int:
        """The last frame at or before ``time`` seconds (the first frame for earlier times).

        Raises:
            ValueError: the trajectory has no frame.
        """
        if not len(self.times):
            raise ValueError("the trajectory has no frame")
        return max(0, int(np.searchsorted(self.times, time + 1e-9, side="right")) - 1)

    def frame(self, index: int) -> Frame:
        """Every body at frame ``index`` (negative counts from the end).

        Raises:
            IndexError: no such frame.
        """
        count = len(self.times)
        if not -count <= index < count:
            raise IndexError(f"frame {index} of {count}")
        index %= count
        n = len(self.ids)
        positions, orientations = np.full((n, 3), np.nan), np.full((n, 4), np.nan)
        states = np.zeros(n, dtype=np.int8)
        upto = int(np.searchsorted(self.row_frame, index, side="right"))  # rows are in frame order
        if upto:
            bodies = self.row_body[:upto]
            last = upto - 1 - np.unique(bodies[::-1], return_index=True)[1]  # each body's last row
            b = bodies[last]
            positions[b], orientations[b], states[b] = self.row_position[last], self.row_orientation[last], self.row_state[last]
        return Frame(index, float(self.times[index]), positions, orientations, states)

    def at(self, time: float) -> Frame:
        """Every body as last recorded at or before ``time`` seconds."""
        return self.frame(self.frame_index(time))

    def frames(self, indices: Iterator[int] | list[int] | None = None) -> Iterator[Frame]:
        """The frames at ``indices`` (increasing; default: all), each built from the last."""
        wanted = range(len(self.times)) if indices is None else indices
        n = len(self.ids)
        positions, orientations = np.full((n, 3), np.nan), np.full((n, 4), np.nan)
        states = np.zeros(n, dtype=np.int8)
        row = 0
        for index in wanted:
            upto = int(np.searchsorted(self.row_frame, index, side="right"))
            if upto < row:
                raise ValueError("frame indices must increase")
            s = slice(row, upto)
            b = self.row_body[s]
            positions[b], orientations[b], states[b] = self.row_position[s], self.row_orientation[s], self.row_state[s]
            row = upto
            yield Frame(index, float(self.times[index]), positions.copy(), orientations.copy(), states.copy())

    # files --------------------------------------------------------------------
    def save(self, path: str | os.PathLike[str]) -> None:
        """Write a compressed ``.npz`` archive at ``path`` (read it with :func:`load_trajectory`).

        Raises:
            OSError: the file cannot be written.
        """
        header = {
            "format": FORMAT,
            "meta": self.meta,
            "events": [e.model_dump(mode="json") for e in self.events],
            "graphs": {k: g.model_dump(mode="json") for k, g in self.graphs.items()},
        }
        arrays = {name: getattr(self, name) for name in _ARRAYS}
        with written(path) as part, open(part, "wb") as f:  # np.savez_compressed adds '.npz' to a name without it
            np.savez_compressed(f, header=np.array(json.dumps(header)), **arrays)


_ARRAYS = (
    "ids",
    "levels",
    "half_extents",
    "fixture_ids",
    "fixture_half_extents",
    "fixture_positions",
    "fixture_orientations",
    "times",
    "row_frame",
    "row_body",
    "row_position",
    "row_orientation",
    "row_state",
)


def load_trajectory(path: str | os.PathLike[str]) -> Trajectory:
    """Read a trajectory written by ``stackdsl run FILE --record PATH`` (:meth:`Trajectory.save`).

    Raises:
        OSError: the file cannot be read.
        ValueError: it is not a stackdsl trajectory, or of a newer format.
    """
    try:
        with np.load(Path(path), allow_pickle=False) as data:
            header = json.loads(str(data["header"]))
            arrays = {name: data[name] for name in _ARRAYS}
    except KeyError as exc:
        raise ValueError(f"{path}: not a stackdsl trajectory (no {exc} array)") from None
    except (json.JSONDecodeError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        raise ValueError(f"{path}: not a stackdsl trajectory, or a damaged one ({type(exc).__name__}: {exc})") from None
    except ValueError as exc:  # numpy: not an archive at all, or one holding pickled objects
        why = "it holds pickled objects, which stackdsl never writes" if "pickle" in str(exc) else "not a numpy archive"
        raise ValueError(f"{path}: not a stackdsl trajectory ({why})") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise ValueError(
            f"{path}: a trajectory of format {header.get('format') if isinstance(header, dict) else '?'}; this stackdsl reads {FORMAT}"
        )
    return Trajectory(
        meta=header["meta"],
        events=tuple(Event(**e) for e in header["events"]),
        graphs={k: Graph(**g) for k, g in header["graphs"].items()},
        **arrays,
    )

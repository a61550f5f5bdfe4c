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
    trajectory.fixture_positions_at(frame.index)  # (fixtures, 3): carried by a shake's ground

The fixtures (walls, ramps) are bolted to the ground: stored once, at rest, with the ground's
offset at each frame (``ground_offset``, zero but while a shake moves it), which carries them.
A file written before the offset was recorded reads as a ground that never moved.

Source: stackdsl's own.
"""

from __future__ import annotations

import json
import math
import os
import re
import zipfile
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from numbers import Real
from pathlib import Path
from typing import Any

import numpy as np
import pydantic

from ..lang.bounds import MAX_COORDINATE, MAX_SIDE
from ..util.files import written
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
#: Seconds after the collapse was detected that ``at="collapse"`` shows (a picture, an
#: export; the recorder keeps a frame then). At detection a brick has
#: moved only the collapse threshold (4 mm): nothing shows but the colours. 0.2 s later the top
#: seven levels of scenarios/slant_tower.yaml are seen tipping over level 2's edge, still in one
#: piece (0.1 s: barely moved; 0.3 s: a slab lying almost on its side, hard to read), and the top
#: brick of scenarios/hard/overhang_falls.yaml has tipped onto the ground (it does by 0.1 s).
COLLAPSE_DELAY = 0.2


def _absent(positions: np.ndarray, orientations: np.ndarray, states: np.ndarray) -> None:
    """NaN, in place, where a body is absent: a brick taken out of the scene is recorded where
    the engine parks it, kilometres away, which no reader should take for a pose."""
    gone = states == ABSENT
    if gone.any():
        positions[gone], orientations[gone] = np.nan, np.nan


@dataclass(frozen=True)
class Frame:
    """Every body at one moment.

    Attributes:
        index: the frame's index; time: seconds.
        positions: (bodies, 3), metres (NaN for a body absent: not in the world yet, or taken
            out of the scene, as a brick a hand pulled out and let go of).
        orientations: (bodies, 4), unit quaternions (x, y, z, w) (NaN likewise).
        states: (bodies,), codes of :data:`STATES`.
        ground_offset: (3,), metres: how far a shake has moved the ground (and the fixtures
            bolted to it) from where it rests.
    """

    index: int
    time: float
    positions: np.ndarray
    orientations: np.ndarray
    states: np.ndarray
    ground_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def state_names(self) -> list[str]:
        """Each body's state by name: ``"absent"``, ``"active"``, ``"frozen"``, ``"woken"`` or ``"fallen"``."""
        return [STATES[s] for s in self.states]


@dataclass(frozen=True)
class Trajectory:
    """A recorded run.

    Attributes:
        meta: scenario, file, mode, backend (from this version on), model, timestep (s), collapse_threshold (m), rate (Hz),
            collapse (the :class:`stackdsl.Collapse` as a dict, or None), collapse_graph_time (s, when
            the collapse graph was taken: when the collapse began; None without one), levels_placed,
            simulated_time (s), stopped, judged_at (the moment the scenario's expectations judge,
            ``"collapse"`` or ``"end"``: :attr:`shown_at`; absent from files written before it).
        ids: (bodies,), each body's id, in the order they entered the world.
        levels: (bodies,), a structure brick's level; 0 for a projectile.
        half_extents: (bodies, 3), metres.
        fixtures: ids (fixtures,), half extents (fixtures, 3), positions (fixtures, 3) and
            orientations (fixtures, 4) of the immovable bodies (walls, ramps), with the ground at rest.
        times: (frames,), seconds, increasing.
        ground_offset: (frames, 3), metres: the ground's offset from its rest at each frame (a
            shake moves it, and the fixtures with it: :meth:`fixture_positions_at`); zeros when
            not given (a file written before it was recorded).
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
    ground_offset: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    def __post_init__(self) -> None:
        if not len(self.ground_offset) and len(self.times):  # never recorded: the ground stood still
            object.__setattr__(self, "ground_offset", np.zeros((len(self.times), 3)))

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

    @property
    def shown_at(self) -> str:
        """The moment a picture, a replay's opening frame or an export shows when none is asked
        for: the one the scenario's expectations judge (``meta["judged_at"]``,
        :attr:`stackdsl.lang.expectations.Expect.judged_at`): ``"end"`` for final positions
        (``toppled``, ``stays``, ``moved``) or when nothing collapsed, else ``"collapse"``."""
        return "end" if self.meta.get("judged_at") == "end" or self.collapse_time is None else "collapse"

    def fixture_positions_at(self, index: int) -> np.ndarray:
        """(fixtures, 3), metres: where the fixtures are at frame ``index`` (negative counts from
        the end), carried with the ground by a shake.

        Raises:
            IndexError: no such frame.
        """
        count = len(self.times)
        if not -count <= index < count:
            raise IndexError(f"frame {index} of {count}")
        return np.asarray(self.fixture_positions + self.ground_offset[index])

    def frame_index(self, time: float) -> int:
        """The last frame at or before ``time`` seconds of the run. The run starts at 0 s; a time
        from 0 to the first frame (taken when the first body enters) gives the first frame, and
        one after :attr:`end` the last (nothing moves after the run).

        Raises:
            TypeError: ``time`` is not a number (a string, a bool).
            ValueError: ``time`` is negative (before the run) or not finite; the trajectory has
                no frame.
        """
        if isinstance(time, bool) or not isinstance(time, Real):
            raise TypeError(f"time must be a number of seconds into the run, not {time!r}")
        if not 0.0 <= time < math.inf:
            raise ValueError(f"time must be a finite number of seconds from 0 (the run's start), not {time!r}")
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
        _absent(positions, orientations, states)
        return Frame(index, float(self.times[index]), positions, orientations, states, self.ground_offset[index].copy())

    def at(self, time: float) -> Frame:
        """Every body as last recorded at or before ``time`` seconds of the run (the frame of
        :meth:`frame_index`: from 0 to the first frame, the first; after :attr:`end`, the last).

        Raises:
            TypeError: ``time`` is not a number.
            ValueError: ``time`` is negative or not finite; the trajectory has no frame.
        """
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
            offset = self.ground_offset[index].copy()
            shown, turned = positions.copy(), orientations.copy()
            _absent(shown, turned, states)
            yield Frame(index, float(self.times[index]), shown, turned, states.copy(), offset)

    # files --------------------------------------------------------------------
    def save(self, path: str | os.PathLike[str]) -> None:
        """Write a compressed ``.npz`` archive at ``path`` (read it with :func:`load_trajectory`).

        Raises:
            OSError: the file cannot be written.
        """
        header, arrays = self._stored()
        size = stored_bytes(header, arrays)
        if size > MAX_TRAJECTORY_BYTES:  # what load_trajectory would refuse is not written
            raise TrajectoryTooLarge(
                f"the trajectory's arrays take {size / 2**20:.1f} MiB, more than the {MAX_TRAJECTORY_BYTES >> 20} MiB "
                "a trajectory file may hold"
            )
        with written(path) as part, open(part, "wb") as f:  # np.savez_compressed adds '.npz' to a name without it
            np.savez_compressed(f, header=header, **arrays)

    @property
    def stored_size(self) -> int:
        """Bytes the trajectory's arrays take in its file once read (:func:`stored_bytes`): what
        :func:`load_trajectory` checks against :data:`MAX_TRAJECTORY_BYTES`."""
        return stored_bytes(*self._stored())

    def _stored(self) -> tuple[np.ndarray, dict[str, Any]]:
        """The header record (a text array of JSON) and the arrays, as :meth:`save` writes them."""
        header = {
            "format": FORMAT,
            "meta": self.meta,
            "events": [e.model_dump(mode="json") for e in self.events],
            "graphs": {k: g.model_dump(mode="json") for k, g in self.graphs.items()},
        }
        return np.array(json.dumps(header)), {name: np.asarray(getattr(self, name)) for name in _ARRAYS}


def stored_bytes(header: np.ndarray, arrays: dict[str, np.ndarray]) -> int:
    """Bytes ``header`` and ``arrays`` take as ``.npy`` members of an archive, each its data and
    a header of :data:`NPY_HEADER_BYTES` (the sizes :func:`load_trajectory` adds up)."""
    return sum(int(a.nbytes) + NPY_HEADER_BYTES for a in (header, *arrays.values()))


#: Metres: the farthest from the origin a recorded position (a body's, a fixture's, the ground's
#: offset) may be. A scene is placed within :data:`stackdsl.lang.bounds.MAX_COORDINATE` (1 km) of
#: the origin, a tower's own offsets reach at most 10 km further, and the fastest throw (100 m/s)
#: slides at most 360 km in the longest run (3600 s): a thousand kilometres holds every run; a
#: position beyond it is a damaged or hand-made file, which a picture's camera cannot frame.
MAX_POSITION = 1000 * MAX_COORDINATE
#: Metres: a body's half extents are at most half the longest side a brick may have.
MAX_HALF_EXTENT = MAX_SIDE / 2
#: A stored orientation is a unit quaternion: its length may differ from 1 by this much (the
#: recorder writes them to float precision); a zero or huge one is no orientation.
QUATERNION_TOLERANCE = 1e-3
#: A body's id in a trajectory file: the characters of a scenario's ids and the ids it generates.
_ID = re.compile(r"[A-Za-z0-9_.-]{1,200}")
#: Bytes a trajectory file may take on disk, and its arrays once read (a 200-level tower recorded
#: at 30 Hz for its whole run holds a few MB): a file larger, or claiming more, is refused before
#: anything is read. What reads one holds several copies: ``render`` peaked at 864 MB on 63 MiB of
#: arrays and at 1260 MB on 100 MiB, so 64 MiB keeps every command under 1.5 GB (the golden
#: snapshot's limit is 16 MiB of JSON, :data:`stackdsl.draw.replay.MAX_GOLDEN_BYTES`).
MAX_TRAJECTORY_BYTES = 64 << 20
#: Bytes a ``.npy`` member's header takes in a trajectory file, at most (numpy pads each to a
#: multiple of 64; a trajectory's are 128): what :func:`stored_bytes` adds for each array.
NPY_HEADER_BYTES = 128
#: Bytes a frame adds to a trajectory's arrays (its time and the ground's offset, float64) and a
#: row (frame and body, int32; position and quaternion, float64; state, int8), as the recorder
#: stores them: what :class:`stackdsl.runtime.recorder.Recorder` counts against
#: :data:`MAX_TRAJECTORY_BYTES` as it records.
FRAME_BYTES = 8 + 3 * 8
ROW_BYTES = 4 + 4 + 3 * 8 + 4 * 8 + 1


class TrajectoryTooLarge(ValueError):
    """A recording that would take more than :data:`MAX_TRAJECTORY_BYTES`, the most a trajectory
    file may hold (what :func:`load_trajectory`, and so ``replay`` and ``render``, read): it is
    neither kept nor written. ``str()`` is one line saying when it passed the limit."""


#: Each array: its dtype kind ("U" text, "i" integer, "f" float) and its shape (None: any length,
#: an int: that size; names stand for lengths that must agree across arrays).
_LAYOUT: dict[str, tuple[str, tuple[str | int, ...]]] = {
    "ids": ("U", ("bodies",)),
    "levels": ("i", ("bodies",)),
    "half_extents": ("f", ("bodies", 3)),
    "fixture_ids": ("U", ("fixtures",)),
    "fixture_half_extents": ("f", ("fixtures", 3)),
    "fixture_positions": ("f", ("fixtures", 3)),
    "fixture_orientations": ("f", ("fixtures", 4)),
    "times": ("f", ("frames",)),
    "row_frame": ("i", ("rows",)),
    "row_body": ("i", ("rows",)),
    "row_position": ("f", ("rows", 3)),
    "row_orientation": ("f", ("rows", 4)),
    "row_state": ("i", ("rows",)),
    "ground_offset": ("f", ("frames", 3)),
}
#: The arrays a trajectory file holds, in the order they are written.
_ARRAYS = tuple(_LAYOUT)
#: The arrays a file written by an earlier stackdsl lacks, each with what stands for it: the
#: ground's offset was not recorded before fixtures were drawn moving with a shake.
_LATER: dict[str, Callable[[dict[str, np.ndarray]], np.ndarray]] = {
    "ground_offset": lambda arrays: np.zeros((len(arrays["times"]), 3)),
}


def load_trajectory(path: str | os.PathLike[str]) -> Trajectory:
    """Read a trajectory written by ``stackdsl run FILE --record PATH`` (:meth:`Trajectory.save`),
    checked as a scenario file is before anything uses it: the archive's members and their
    claimed sizes (at most :data:`MAX_TRAJECTORY_BYTES`, from each array's own header, before
    it is read), the header record and its ``meta``, every array's dtype and shape, finite
    numbers, and indices that point into the arrays they name.

    Raises:
        OSError: the file cannot be read.
        ValueError: ``"PATH: not a stackdsl trajectory: WHAT"``, or of a newer format.
    """
    path = Path(path)
    header, arrays = _read_archive(path)
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise ValueError(
            f"{path}: a trajectory of format {header.get('format') if isinstance(header, dict) else '?'}; this stackdsl reads {FORMAT}"
        )
    try:
        meta = _checked_header(header)
        _check_arrays(arrays)
        events = tuple(Event(**e) for e in header["events"])
        if not all(math.isfinite(e.time) for e in events):
            raise _Bad("an event's time is NaN or infinite")
        return Trajectory(
            meta=meta,
            events=events,
            graphs={k: Graph(**g) for k, g in header["graphs"].items()},
            **arrays,
        )
    except (_Bad, TypeError, pydantic.ValidationError) as exc:
        what = (
            str(exc).splitlines()[0]
            if not isinstance(exc, pydantic.ValidationError)
            else f"a bad event or graph ({exc.error_count()} errors)"
        )
        raise ValueError(f"{path}: not a stackdsl trajectory: {what}") from None


def _read_archive(path: Path) -> tuple[Any, dict[str, np.ndarray]]:
    """The decoded header record (not yet checked) and the arrays of the archive at ``path``,
    those an earlier stackdsl did not write filled in from :data:`_LATER`.

    Raises:
        OSError: the file cannot be read.
        ValueError: ``"PATH: not a stackdsl trajectory..."``, naming what is not one.
    """
    try:
        _check_sizes(path)
        with np.load(path, allow_pickle=False) as data:
            if "header" not in data.files:
                raise _Bad("it has no header record")
            try:
                header = json.loads(str(data["header"]))
            except RecursionError:
                raise _Bad("its header record is nested too deeply to be one stackdsl writes") from None
            missing = [name for name in _ARRAYS if name not in data.files and name not in _LATER]
            if missing:
                raise _Bad(f"it has no {missing[0]!r} array")
            arrays = {name: data[name] for name in _ARRAYS if name in data.files}
            arrays |= {name: make(arrays) for name, make in _LATER.items() if name not in arrays}
    except _Bad as exc:
        raise ValueError(f"{path}: not a stackdsl trajectory: {exc}") from None
    except zipfile.BadZipFile:
        raise ValueError(f"{path}: not a stackdsl trajectory, or a damaged one: it is not a whole .npz archive") from None
    except (json.JSONDecodeError, EOFError, zlib.error) as exc:
        raise ValueError(f"{path}: not a stackdsl trajectory, or a damaged one ({type(exc).__name__}: {exc})") from None
    except ValueError as exc:  # numpy: not an archive at all, or one holding pickled objects
        why = "it holds pickled objects, which stackdsl never writes" if "pickle" in str(exc) else "not a numpy archive"
        raise ValueError(f"{path}: not a stackdsl trajectory ({why})") from None
    return header, arrays


class _Bad(Exception):
    """What is wrong with a trajectory file (one line)."""


def _check_sizes(path: Path) -> None:
    """Refuse an archive whose arrays would take more than :data:`MAX_TRAJECTORY_BYTES` once
    read, by each member's own ``.npy`` header (a zip's sizes can lie, and so can a header's
    shape: both are checked) before numpy reads any of it; a file larger than that is refused
    before it is opened as an archive (its directory alone could be the file's size)."""
    size = path.stat().st_size
    if size > MAX_TRAJECTORY_BYTES:
        raise _Bad(f"it is larger than {MAX_TRAJECTORY_BYTES >> 20} MiB ({size >> 20} MiB)")
    total = 0
    with zipfile.ZipFile(path) as archive:
        for info in archive.infolist():
            with archive.open(info) as member:
                version = np.lib.format.read_magic(member)
                if version == (1, 0):
                    shape, _, dtype = np.lib.format.read_array_header_1_0(member)
                elif version == (2, 0):
                    shape, _, dtype = np.lib.format.read_array_header_2_0(member)
                else:
                    raise _Bad(f"{info.filename} is a .npy of version {version}, which stackdsl never writes")
            claimed = int(np.prod(shape, dtype=np.float64) * dtype.itemsize)
            if claimed > info.file_size:
                raise _Bad(f"{info.filename} claims {claimed} bytes but holds {info.file_size}")
            total += info.file_size
            if total > MAX_TRAJECTORY_BYTES:
                raise _Bad(f"its arrays take more than {MAX_TRAJECTORY_BYTES >> 20} MiB once read")


def _checked_header(header: dict[str, Any]) -> dict[str, Any]:
    """The header's ``meta``, after checking the records a drawing reads."""
    meta = header.get("meta")
    if not isinstance(meta, dict):
        raise _Bad("its header has no meta record")
    if (
        not isinstance(header.get("events"), list)
        or not isinstance(header.get("graphs"), dict)
        or "final" not in header["graphs"]
    ):
        raise _Bad("its header lacks the events or the final brick graph")
    collapse = meta.get("collapse")
    if collapse is not None:
        ok = isinstance(collapse, dict) and all(
            isinstance(collapse.get(k), (int, float)) and not isinstance(collapse.get(k), bool) for k in ("time", "level")
        )
        if not ok or not math.isfinite(float(collapse["time"])):
            raise _Bad("its meta record's collapse has no time and level")
    if meta.get("judged_at") not in (None, "collapse", "end"):
        raise _Bad("its meta record's judged_at is neither 'collapse' nor 'end'")
    return meta


def _check_arrays(arrays: dict[str, np.ndarray]) -> None:
    """Dtypes, shapes that agree, finite numbers, sizes a run can reach, unit quaternions,
    unique ids, times that go forwards, indices within the arrays they name."""
    lengths = _check_layout(arrays)
    _check_magnitudes(arrays)
    _check_quaternions(arrays)
    _check_ids([str(i) for i in arrays["ids"].tolist()] + [str(i) for i in arrays["fixture_ids"].tolist()])
    if (np.diff(arrays["times"]) < 0).any():
        raise _Bad("its times go backwards")
    for name, limit in (
        ("row_frame", lengths.get("frames", 0)),
        ("row_body", lengths.get("bodies", 0)),
        ("row_state", len(STATES)),
    ):
        values = arrays[name]
        if len(values) and (values.min() < 0 or values.max() >= limit):
            raise _Bad(f"its {name!r} array points outside 0..{limit - 1}")


def _check_layout(arrays: dict[str, np.ndarray]) -> dict[str, int]:
    """Each array's dtype, dimensions and columns as :data:`_LAYOUT` says, lengths that agree
    along each named axis, and finite floats; returns each named axis's length."""
    lengths: dict[str, int] = {}
    for name, (kind, shape) in _LAYOUT.items():
        array = arrays[name]
        if array.dtype.kind != kind and not (kind == "i" and array.dtype.kind == "u"):
            raise _Bad(f"its {name!r} array holds {array.dtype} values")
        if array.ndim != len(shape):
            raise _Bad(f"its {name!r} array has {array.ndim} dimensions, not {len(shape)}")
        for axis, want in zip(array.shape, shape):
            if isinstance(want, int):
                if axis != want:
                    raise _Bad(f"its {name!r} array has {axis} columns, not {want}")
            elif lengths.setdefault(want, axis) != axis:
                raise _Bad(f"its {name!r} array has {axis} {want}, the others {lengths[want]}")
        if kind == "f" and not np.isfinite(array).all():
            raise _Bad(f"its {name!r} array holds NaN or infinite values")
    return lengths


def _check_magnitudes(arrays: dict[str, np.ndarray]) -> None:
    """Half extents above 0 and at most :data:`MAX_HALF_EXTENT`; positions within
    :data:`MAX_POSITION` of the origin."""
    if not (arrays["half_extents"] > 0).all() or not (arrays["fixture_half_extents"] > 0).all():
        raise _Bad("a body's half extents are not above 0")
    for name in ("half_extents", "fixture_half_extents"):
        if len(arrays[name]) and float(arrays[name].max()) > MAX_HALF_EXTENT:
            raise _Bad(
                f"its {name!r} array holds {float(arrays[name].max()):.3g} m, beyond a brick's (at most {MAX_HALF_EXTENT:g} m)"
            )
    for name in ("row_position", "fixture_positions", "ground_offset"):
        if len(arrays[name]) and float(np.abs(arrays[name]).max()) > MAX_POSITION:
            raise _Bad(
                f"its {name!r} array holds a coordinate of {float(np.abs(arrays[name]).max()):.3g} m, "
                f"beyond {MAX_POSITION / 1000:g} km from the origin, farther than any run goes"
            )


def _check_quaternions(arrays: dict[str, np.ndarray]) -> None:
    """Every orientation a unit quaternion, within :data:`QUATERNION_TOLERANCE`."""
    for name in ("row_orientation", "fixture_orientations"):
        q = arrays[name].astype(np.float64)
        scale = np.abs(q).max(axis=1, initial=0.0)  # scaled first: 1e308 squared overflows
        norms = scale * np.linalg.norm(q / np.where(scale > 0, scale, 1.0)[:, None], axis=1)
        wrong = np.flatnonzero(np.abs(norms - 1.0) > QUATERNION_TOLERANCE)
        if len(wrong):
            raise _Bad(f"its {name!r} array holds a quaternion of length {norms[wrong[0]]:.3g} (row {wrong[0]}), not a unit one")


def _check_ids(ids: list[str]) -> None:
    """Every body's id (bricks, projectiles and fixtures): letters, digits, ``_``, ``.`` and ``-``
    (what a scenario's ids and the ids it generates are made of), unique, and not the ground's:
    an exported scene (MJCF, URDF) names each body by it, and the graph and the timeline name
    the ground so."""
    from ..lang.grammar import GROUND

    seen: set[str] = set()
    for i in ids:
        if not _ID.fullmatch(i):
            raise _Bad(f"a body's id is {i[:60]!r}, not letters, digits, '_', '.' and '-'")
        if i.lower() == GROUND:
            raise _Bad(f"a body has the ground's id {i!r}")
        if i in seen:
            raise _Bad(f"two bodies have the id {i!r}")
        seen.add(i)

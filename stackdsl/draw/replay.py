"""The interactive replay: a recorded run as one HTML page that plays it in 3D (three.js).

:func:`write_replay` writes a single self-contained file: the trajectory's arrays (base64 of
little-endian typed arrays), its events and brick graphs, the state colours of
:data:`stackdsl.draw.render.COLOURS`, the page's own script and style, and three.js
(:data:`THREE_VERSION`, vendored in ``stackdsl/draw/vendor/``, gzip-compressed and
base64-encoded; the page inflates it with the browser's ``DecompressionStream`` and imports
it from a ``blob:`` address). Nothing is fetched from the network.

The page orbits and zooms (three.js's ``OrbitControls``), scrubs a timeline with a mark for
every event, steps frame by frame and event by event, slows down around impacts and the
collapse, colours bricks by state, shows a clicked brick's id, level, state, pose, last
support event and its rests-on edges with their load shares (from the brick graph nearest
in time), and draws a golden snapshot's final poses as ghosts when they differ from the
run's. A body's pose at a time is that of its last row at or before the time, as
:meth:`stackdsl.Trajectory.at`.

Tests and scripts read the page through ``window.stackdslReplay``: ``ready``, ``error``,
``seek(t)``, ``seekEvent(t)`` (an event's time: its frame, or the first frame after it),
``time()``, ``frame()``, ``frameTime()``, ``poses()``, ``select(id)``, ``selected()``,
``screenPosition(id)``, ``nextEvent()``, ``prevEvent()``, ``play()``, ``pause()``,
``ghosts()``, ``loadMs`` (docs/design.md, "The replay page").

>>> import stackdsl
>>> from stackdsl.runtime.recorder import record_program
>>> program = stackdsl.compile_scenario(stackdsl.parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 2}}"))
>>> outcome, trajectory = record_program(program)
>>> data = replay_data(trajectory)
>>> data["ids"], data["frames"] == len(trajectory.times), data["ghosts"]
(['L01.1', 'L01.2', 'L02.1', 'L02.2'], True, [])

Source: stackdsl's own.
"""

from __future__ import annotations

import base64
import gzip
import html
import json
import math
import os
import re
import stat
import warnings
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import pydantic
from pydantic import BaseModel, ConfigDict, Field, StrictFloat, StrictInt, StrictStr, model_validator

from ..lang.errors import ScenarioWarning
from ..runtime.outcome import Graph
from ..runtime.trajectory import MAX_POSITION, STATES, Frame, Trajectory
from ..util.files import written
from .render import COLOURS

#: The three.js release vendored in ``stackdsl/draw/vendor/`` (npm ``three``, MIT licence).
THREE_VERSION = "0.170.0"
#: Vendored files the page inlines: three.js's module build and its orbit controls.
VENDORED = ("three.module.min.js", "OrbitControls.js")
#: A golden brick whose final pose is this far (m) or turned this much (deg) from the run's is a ghost.
GHOST_DISTANCE = 1e-3
GHOST_ANGLE = 1.0
#: Events the timeline marks large, and around which playback slows down.
KEY_EVENTS = ("launch", "impact", "collapse")


@cache
def _vendored(name: str) -> str:
    """A vendored file, gzip-compressed and base64-encoded (compressed once a process)."""
    data = resources.files(__package__).joinpath("vendor", name).read_bytes()
    return base64.b64encode(gzip.compress(data, 9, mtime=0)).decode("ascii")


@cache
def _page_file(name: str) -> str:
    """The page's own script, style or template (``stackdsl/draw/page/``)."""
    return resources.files(__package__).joinpath("page", name).read_text(encoding="utf-8")


def _b64(array: np.ndarray, dtype: str) -> str:
    """``array`` as base64 of a little-endian typed array of ``dtype`` (``'<f4'``, ``'<i4'``...)."""
    return base64.b64encode(np.ascontiguousarray(array, dtype=dtype).tobytes()).decode("ascii")


def _graph(graph: Graph) -> dict[str, Any]:
    """A brick graph for the page: each brick's level, state, centre of mass and mass above, and
    its rests-on edges (support, contact area mm^2, load share)."""
    edges: dict[str, list[list[Any]]] = {}
    for e in graph.edges:
        edges.setdefault(e.upper, []).append([e.support, e.area_mm2, e.load_share])
    return {
        n.id: {
            "level": n.level,
            "state": n.state,
            "com_above_mm": list(n.com_above_mm),
            "mass_above_g": n.mass_above_g,
            "rests_on": edges.get(n.id, []),
        }
        for n in graph.nodes
    }


def _golden_quaternion(brick: dict[str, Any]) -> list[float] | None:
    """The orientation of a golden snapshot's brick, (x, y, z, w): a stored quaternion, else its
    yaw, pitch and roll (degrees, intrinsic z-y-x, as :meth:`stability.Pose.from_euler`)."""
    from scipy.spatial.transform import Rotation

    for key, value in brick.items():
        if key.startswith("quat") and isinstance(value, list) and len(value) == 4:
            return [float(v) for v in value]
    angles = brick.get("yaw_pitch_roll_deg")
    if isinstance(angles, list) and len(angles) == 3:
        return [float(c) for c in Rotation.from_euler("ZYX", angles, degrees=True).as_quat()]
    return None


def ghosts(trajectory: Trajectory, golden: dict[str, Any] | None) -> list[dict[str, Any]]:
    """The golden snapshot's final bricks that differ from the run's final pose or state.

    Args:
        trajectory: the run.
        golden: a golden snapshot (:meth:`stackdsl.Outcome.golden`, as stored in ``golden/``), or None.

    Returns:
        For each brick of the golden's ``final_graph`` whose position is more than
        :data:`GHOST_DISTANCE` or orientation more than :data:`GHOST_ANGLE` from the run's last
        recorded pose, whose state differs, or which the run does not have: ``{id, position
        (m), quaternion (x, y, z, w), half_extents (m, the run's brick or the golden's first
        brick's), state, why}``. Empty when the golden matches or is missing.
    """
    final = (golden or {}).get("final_graph")
    if not isinstance(final, dict) or not len(trajectory.times):
        return []
    last = trajectory.frame(-1)
    index = {str(b): i for i, b in enumerate(trajectory.ids.tolist())}
    run_states = {n.id: n.state for n in trajectory.graphs["final"].nodes}
    out = []
    for brick, fields in final.items():
        if not isinstance(fields, dict) or not isinstance(fields.get("position_mm"), list):
            continue
        position = np.asarray(fields["position_mm"], dtype=float) / 1000.0
        quaternion = _golden_quaternion(fields)
        if quaternion is None or position.shape != (3,):
            continue
        i = index.get(brick)
        why = (
            ["not in this run"]
            if i is None
            else _ghost_why(last, i, position, quaternion, fields.get("state"), run_states.get(brick))
        )
        if why:
            half = trajectory.half_extents[i] if i is not None else trajectory.half_extents[0]
            out.append(
                {
                    "id": brick,
                    "position": position.tolist(),
                    "quaternion": quaternion,
                    "half_extents": [float(h) for h in half],
                    "state": fields.get("state", ""),
                    "why": "; ".join(why),
                }
            )
    return out


def _ghost_why(
    last: Frame, i: int, position: np.ndarray, quaternion: list[float], golden_state: Any, run_state: str | None
) -> list[str]:
    """How the golden's brick, body ``i`` of the run (``position`` in m, ``quaternion`` x, y, z,
    w, ``golden_state``), differs from it in the run's ``last`` frame (``run_state``), in words:
    farther than :data:`GHOST_DISTANCE`, turned more than :data:`GHOST_ANGLE`, another state;
    empty when it does not."""
    from scipy.spatial.transform import Rotation

    why = []
    moved = float(np.linalg.norm(last.positions[i] - position))
    turned = float(np.degrees((Rotation.from_quat(last.orientations[i]).inv() * Rotation.from_quat(quaternion)).magnitude()))
    if moved > GHOST_DISTANCE:
        why.append(f"{moved * 1000:.1f} mm away")
    if turned > GHOST_ANGLE:
        why.append(f"turned {turned:.1f} deg")
    if golden_state and run_state and golden_state != run_state:
        why.append(f"{golden_state} in the golden, {run_state} here")
    return why


def replay_data(trajectory: Trajectory, golden: dict[str, Any] | None = None, note: str | None = None) -> dict[str, Any]:
    """Everything the page reads, as JSON values: the trajectory's arrays (base64: times
    float64, positions, quaternions and the ground's offset at each frame float32, frames and
    bodies int32, states uint8), ids, levels, half extents, fixtures (at rest: the page moves
    them with the ground's offset), events, brick graphs with their times, state names and
    colours, the golden's ghosts (:func:`ghosts`), how many final bricks the golden has (None:
    no golden, or a sweep's, which has none), ``note``, a line the page shows in their place
    (:func:`sweep_note`), and the moment the page opens at (``opening``,
    :attr:`stackdsl.Trajectory.shown_at`: the collapse, or the end)."""
    meta = trajectory.meta
    collapse = meta.get("collapse")
    graphs = {"final": {"time": trajectory.end, "label": "at the end", "bricks": _graph(trajectory.graphs["final"])}}
    if "collapse" in trajectory.graphs and collapse is not None:
        # taken when the collapse began (the step its first brick passed the threshold), not when
        # it was decided, which can be seconds later; a file without the graph's time has the
        # collapse's, the same but where a brick that passed first came back within the threshold
        taken = meta.get("collapse_graph_time")
        graphs["collapse"] = {
            "time": float(taken if isinstance(taken, (int, float)) else collapse["time"]),
            "label": "when the collapse began",
            "bricks": _graph(trajectory.graphs["collapse"]),
        }
    return {
        "three": THREE_VERSION,
        "meta": {k: meta.get(k) for k in ("scenario", "file", "mode", "model", "backend", "rate", "collapse", "stopped")},
        "end": trajectory.end,
        "frames": len(trajectory.times),
        "ids": [str(i) for i in trajectory.ids.tolist()],
        "levels": [int(v) for v in trajectory.levels.tolist()],
        "half_extents": trajectory.half_extents.astype(float).round(6).tolist(),
        "fixtures": [
            {"id": str(f), "half_extents": h.tolist(), "position": p.tolist(), "quaternion": q.tolist()}
            for f, h, p, q in zip(
                trajectory.fixture_ids.tolist(),
                trajectory.fixture_half_extents,
                trajectory.fixture_positions,
                trajectory.fixture_orientations,
            )
        ],
        "times": _b64(trajectory.times, "<f8"),
        "row_frame": _b64(trajectory.row_frame, "<i4"),
        "row_body": _b64(trajectory.row_body, "<i4"),
        "row_position": _b64(trajectory.row_position, "<f4"),
        "row_orientation": _b64(trajectory.row_orientation, "<f4"),
        "row_state": _b64(trajectory.row_state, "u1"),
        "ground_offset": _b64(trajectory.ground_offset, "<f4"),
        "states": list(STATES),
        "colours": {k: "#" + "".join(f"{round(255 * c):02x}" for c in v) for k, v in COLOURS.items()},
        "key_events": list(KEY_EVENTS),
        "events": [e.model_dump(mode="json") for e in trajectory.events],
        "graphs": graphs,
        "ghosts": ghosts(trajectory, golden),
        "golden_bricks": len(final) if isinstance(final := (golden or {}).get("final_graph"), dict) else None,
        "golden_note": note,
        "opening": trajectory.shown_at,
    }


def _script_json(value: Any) -> str:
    """JSON safe inside a ``<script>`` element and still JSON: every ``<``, ``>`` and ``&`` written
    as its JSON escape (``\\u003c``, ``\\u003e``, ``\\u0026``), so no ``</script``, ``<!--`` or
    ``-->`` of the run's text can end the element or change how it is parsed (the HTML standard's
    restrictions on script content), and ``JSON.parse`` reads it back as written."""
    text = json.dumps(value, separators=(",", ":"), ensure_ascii=False)
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def replay_html(trajectory: Trajectory, golden: dict[str, Any] | None = None, note: str | None = None) -> str:
    """The replay page of ``trajectory`` as one HTML text (see the module's docstring)."""
    meta = trajectory.meta
    title = f"{meta.get('scenario') or meta.get('file') or 'run'} · stackdsl replay"
    parts = {
        "{{title}}": html.escape(title),
        "{{style}}": _page_file("replay.css"),
        "{{data}}": _script_json(replay_data(trajectory, golden, note)),
        "{{three}}": _vendored(VENDORED[0]),
        "{{orbit}}": _vendored(VENDORED[1]),
        "{{script}}": _page_file("replay.js").replace("</", "<\\/"),
    }
    # one pass: a run's text that spells a placeholder (a scenario named "{{three}}") stays text
    return re.sub(r"\{\{[a-z]+\}\}", lambda m: parts.get(m.group(0), m.group(0)), _page_file("replay.html"))


def write_replay(
    trajectory: Trajectory, path: str | os.PathLike[str], golden: dict[str, Any] | None = None, note: str | None = None
) -> Path:
    """Write the replay page of ``trajectory`` at ``path`` (under a temporary name, renamed
    when complete).

    Args:
        trajectory: a recorded run.
        path: the HTML file to write.
        golden: the scenario's golden snapshot (JSON data), whose final poses that differ from
            the run's are drawn as ghosts; None (or a sweep's golden, which has no poses): no ghosts.
        note: a line the page shows where the ghosts are listed (what a sweep's golden says of
            this sample, :func:`sweep_note`); None: none.

    Returns:
        ``path``.

    Raises:
        OSError: the file cannot be written.
    """
    text = replay_html(trajectory, golden, note)
    with written(path) as part:
        Path(part).write_text(text, encoding="utf-8")
    return Path(path)


#: Bytes a golden snapshot may have: a 5000-brick scene's (the most a scenario places) is a few MB; a
#: 15 MiB one peaked at 224 MB read and checked (a 50 MB one took 792 MB and 15 s).
MAX_GOLDEN_BYTES = 16 << 20
#: Lists and objects nested in one another in a golden snapshot: it has 5 (a brick's rests-on
#: entries); deeper is no snapshot stackdsl writes.
MAX_GOLDEN_DEPTH = 16
#: A golden brick's position (mm, each coordinate) is at most this far from the origin: a recorded
#: position's bound (:data:`stackdsl.runtime.trajectory.MAX_POSITION`).
MAX_GOLDEN_MM = MAX_POSITION * 1000
#: A golden quaternion is written to 3 decimals: its length is 1 within this.
GOLDEN_QUATERNION_TOLERANCE = 0.01

_Finite = Annotated[StrictFloat, Field(allow_inf_nan=False, ge=-MAX_GOLDEN_MM, le=MAX_GOLDEN_MM)]
_Number = Annotated[StrictFloat, Field(allow_inf_nan=False)]
_Angle = Annotated[StrictFloat, Field(allow_inf_nan=False, ge=-3600.0, le=3600.0)]


class GoldenError(ValueError):
    """A golden snapshot stackdsl cannot use, or not this run's: ``str()`` is one line, ``FILE: why``."""

    def __init__(self, file: str | os.PathLike[str], why: str) -> None:
        super().__init__(f"{file}: {why}")
        self.file, self.why = str(file), why


class GoldenWarning(ScenarioWarning):
    """A golden snapshot of this scenario whose bricks are not all this run's (the scenario changed
    since it was taken): those bricks are drawn as ghosts "not in this run"."""


class _GoldenBrick(BaseModel):
    """What the replay reads of a golden brick (other fields are kept as written)."""

    model_config = ConfigDict(extra="allow", frozen=True)

    position_mm: Annotated[list[_Finite], Field(min_length=3, max_length=3)]
    quaternion_xyzw: Annotated[list[_Number], Field(min_length=4, max_length=4)] | None = None
    yaw_pitch_roll_deg: Annotated[list[_Angle], Field(min_length=3, max_length=3)] | None = None
    state: StrictStr | None = None
    level: StrictInt | None = None

    @model_validator(mode="after")
    def _orientation(self) -> _GoldenBrick:
        if self.quaternion_xyzw is None and self.yaw_pitch_roll_deg is None:
            raise ValueError("a brick needs its orientation: quaternion_xyzw (or yaw_pitch_roll_deg)")
        if self.quaternion_xyzw is not None:
            length = math.hypot(*self.quaternion_xyzw)
            if abs(length - 1.0) > GOLDEN_QUATERNION_TOLERANCE:
                raise ValueError(f"quaternion_xyzw has length {length:.3g}, not 1: it is no orientation")
        return self


class _Golden(BaseModel):
    """A golden snapshot as the replay reads it (:meth:`stackdsl.Outcome.golden`; other fields kept)."""

    model_config = ConfigDict(extra="allow", frozen=True)

    scenario: StrictStr | None = None
    final_graph: dict[str, _GoldenBrick]
    collapse_graph: dict[str, _GoldenBrick] | None = None


#: A sweep's golden snapshot's key for grid cell N (``stackdsl.pytest_plugin``'s sweep items write them).
SWEEP_CELL = re.compile(r"cell (0|[1-9][0-9]{0,5})")


class _SweepCell(BaseModel):
    """One grid cell of a sweep's golden snapshot: its grid values and each sample's collapse level."""

    model_config = ConfigDict(extra="allow", frozen=True)

    grid: dict[str, Any] = {}
    collapse_levels: list[Annotated[StrictInt, Field(ge=1)] | None]


class _SweepGolden(BaseModel):
    """A sweep's golden snapshot: ``{scenario, mode, samples, "cell 0": {grid, collapse_levels}, ...}``
    (each sample's collapse level, None where it stood; no brick poses)."""

    model_config = ConfigDict(extra="allow", frozen=True)

    scenario: StrictStr | None = None
    mode: StrictStr | None = None
    samples: Annotated[StrictInt, Field(ge=1)]


def is_sweep_golden(data: Any) -> bool:
    """Whether ``data`` (a golden snapshot's JSON) is a sweep's: no ``final_graph``, and a
    ``cell N`` key (:data:`SWEEP_CELL`)."""
    return isinstance(data, dict) and "final_graph" not in data and any(SWEEP_CELL.fullmatch(str(k)) for k in data)


def sweep_note(
    path: str | os.PathLike[str],
    golden: dict[str, Any],
    cell: int,
    sample: int,
    level: int | None,
    mode: str | None,
    reseeded: bool = False,
) -> str:
    """What a sweep's golden snapshot (:func:`is_sweep_golden`, read by :func:`read_golden`) says
    of the sample replayed, in one line: it holds no poses, so no ghosts; then the collapse level
    of cell ``cell``'s sample ``sample`` there against this run's ``level`` (None: it stood), or
    why they are not compared: the run's ``mode`` is not the golden's, ``reseeded`` (``--seed``
    draws other samples), or the golden has no such sample.

    >>> sweep_note("g.json", {"mode": "raw", "samples": 2, "cell 0": {"collapse_levels": [4, None]}}, 0, 1, None, "raw")
    "g.json is a sweep's golden snapshot (each sample's collapse level, no poses: no ghosts are drawn); sample 1 of cell 0 stands there and stands here: the same"
    """
    head = f"{path} is a sweep's golden snapshot (each sample's collapse level, no poses: no ghosts are drawn)"
    taken = golden.get("mode")
    levels = (golden.get(f"cell {cell}") or {}).get("collapse_levels") or []
    if reseeded:
        return f"{head}; --seed draws other samples than the golden's: not compared"
    if taken is not None and mode is not None and taken != mode:
        return f"{head}; it was taken in {taken} mode and this run is in {mode} mode: not compared"
    if not 0 <= sample < len(levels):
        return f"{head}; it holds no sample {sample} of cell {cell}: not compared"

    def said(n: int | None) -> str:
        return "stands" if n is None else f"collapses at level {n}"

    there = levels[sample]
    return f"{head}; sample {sample} of cell {cell} {said(there)} there and {said(level)} here: " + (
        "the same" if there == level else "they differ"
    )


def _depth_exceeds(data: Any, limit: int) -> bool:
    """Whether lists and objects in ``data`` nest deeper than ``limit`` (walked without recursion)."""
    stack = [(data, 1)]
    while stack:
        value, depth = stack.pop()
        if isinstance(value, (list, dict)):
            if depth > limit:
                return True
            stack += [(v, depth + 1) for v in (value.values() if isinstance(value, dict) else value)]
    return False


#: pydantic's error types, in words (the value found is said after).
_SAID = {
    "float_type": "expected a number",
    "int_type": "expected a whole number",
    "string_type": "expected text",
    "finite_number": "expected a finite number",
    "less_than_equal": "out of range",
    "greater_than_equal": "out of range",
    "dict_type": "expected an object",
    "model_type": "expected an object",
    "model_attributes_type": "expected an object",
    "list_type": "expected a list",
    "too_short": "expected {n} numbers",
    "too_long": "expected {n} numbers",
    "missing": "missing",
}


def _first_problem(exc: pydantic.ValidationError) -> str:
    """The first error of a golden snapshot's validation, as ``final_graph.L01.1.position_mm[0]: why``."""
    error = exc.errors()[0]
    where = ""
    for part in error["loc"]:
        where += f"[{part}]" if isinstance(part, int) else (f".{part}" if where else str(part))
    kind = error["type"]
    why = _SAID.get(kind, str(error["msg"]).removeprefix("Value error, "))
    context = error.get("ctx") or {}
    if kind in ("too_short", "too_long"):
        why = why.format(n=context.get("min_length", context.get("max_length")))
    if kind in ("less_than_equal", "greater_than_equal"):
        angle = "yaw_pitch_roll_deg" in error["loc"]
        why += (
            ": an angle is within 3600 deg" if angle else f": a position is within {MAX_GOLDEN_MM:g} mm (1000 km) of the origin"
        )
    if kind not in ("missing", "value_error") and "input" in error:
        shown = json.dumps(error["input"], ensure_ascii=False, default=str)
        why += f", not {shown if len(shown) <= 40 else shown[:37] + '...'}"
    return f"{where}: {why}" if where else why


def read_golden(path: str | os.PathLike[str] | None, trajectory: Trajectory | None = None) -> dict[str, Any] | None:
    """A golden snapshot's JSON data, checked once (:class:`_Golden`) before anything reads it.

    Args:
        path: the snapshot; None: no golden.
        trajectory: the run it is drawn beside: the golden must be of the same scenario (its
            ``scenario`` name, when it has one) and have some brick of the run; a golden with bricks
            the run does not have gives a :class:`GoldenWarning`.

    Returns:
        The data as written; None when ``path`` is None or no file is there. A sweep's golden
        (:func:`is_sweep_golden`: each sample's collapse level, no poses) is returned too, once
        its ``samples`` and cells are checked; it draws no ghosts (:func:`sweep_note` says what
        it holds of the sample replayed).

    Raises:
        GoldenError: one line naming the file: not a regular file, larger than
            :data:`MAX_GOLDEN_BYTES`, not UTF-8 JSON, nested deeper than :data:`MAX_GOLDEN_DEPTH`, no
            ``final_graph`` mapping brick ids to bricks, a brick without a position (3 finite
            numbers of mm within 1000 km) or an orientation (a unit quaternion), text where a number
            belongs; a sweep's without whole ``samples`` or with a cell whose ``collapse_levels``
            are not levels; another scenario's, or without a brick of the run.
    """
    if path is None:
        return None
    path = Path(path)
    if not path.exists():
        return None

    def bad(why: str) -> GoldenError:
        return GoldenError(path, f"not a golden snapshot stackdsl can draw: {why}")

    try:
        info = path.stat()
        if not stat.S_ISREG(info.st_mode):
            raise bad("it is not a regular file")
        if info.st_size > MAX_GOLDEN_BYTES:
            raise bad(f"it is larger than {MAX_GOLDEN_BYTES >> 20} MiB")
        data = json.loads(path.read_text(encoding="utf-8"))
    except GoldenError:
        raise
    except OSError as exc:
        raise GoldenError(path, str(exc.strerror or exc)) from None
    except UnicodeDecodeError:
        raise bad("it is not UTF-8 text") from None
    except RecursionError:
        raise bad(f"lists and objects are nested more than {MAX_GOLDEN_DEPTH} levels deep") from None
    except ValueError as exc:
        raise bad(f"it is not JSON ({str(exc).splitlines()[0]})") from None
    if not isinstance(data, dict):
        raise bad(f"it is a JSON {type(data).__name__.replace('list', 'array').replace('str', 'string')}, not an object")
    if _depth_exceeds(data, MAX_GOLDEN_DEPTH):
        raise bad(f"lists and objects are nested more than {MAX_GOLDEN_DEPTH} levels deep")
    if is_sweep_golden(data):
        _read_sweep(data, path, trajectory)
        return data
    try:
        golden = _Golden.model_validate(data)
    except pydantic.ValidationError as exc:
        raise bad(_first_problem(exc)) from None
    if trajectory is not None:
        _belongs(golden, trajectory, path)
    return data


def _read_sweep(data: dict[str, Any], path: Path, trajectory: Trajectory | None) -> None:
    """Check a sweep's golden snapshot (:class:`_SweepGolden`, each ``cell N`` a
    :class:`_SweepCell`), and that it is of the scenario of ``trajectory`` (by name) when given.

    Raises:
        GoldenError: as :func:`read_golden` says.
    """
    try:
        golden = _SweepGolden.model_validate(data)
    except pydantic.ValidationError as exc:
        raise GoldenError(path, f"not a sweep's golden snapshot stackdsl can read: {_first_problem(exc)}") from None
    for key, cell in data.items():
        if SWEEP_CELL.fullmatch(str(key)):
            try:
                _SweepCell.model_validate(cell)
            except pydantic.ValidationError as exc:
                said = _first_problem(exc)
                raise GoldenError(path, f"not a sweep's golden snapshot stackdsl can read: {key}.{said}") from None
    name = trajectory.meta.get("scenario") if trajectory is not None else None
    if golden.scenario is not None and isinstance(name, str) and golden.scenario != name:
        raise GoldenError(
            path, f"the golden snapshot of scenario {golden.scenario!r}, and this run is of {name!r}: give this scenario's golden"
        )


def _belongs(golden: _Golden, trajectory: Trajectory, path: Path) -> None:
    """Refuse the golden of another scenario (its name, or no brick in common with the run); warn
    of the golden's bricks the run does not have."""
    name = trajectory.meta.get("scenario")
    if golden.scenario is not None and isinstance(name, str) and golden.scenario != name:
        raise GoldenError(
            path, f"the golden snapshot of scenario {golden.scenario!r}, and this run is of {name!r}: give this scenario's golden"
        )
    ids = [str(i) for i in trajectory.ids.tolist()]
    run = set(ids)
    theirs = [b for b in golden.final_graph if b not in run]
    if len(theirs) == len(golden.final_graph):
        shown = ", ".join(list(golden.final_graph)[:3]) or "none"
        raise GoldenError(path, f"none of the golden snapshot's bricks ({shown}) is in this run: it is another scene's")
    if theirs:
        shown = ", ".join(theirs[:3]) + (", ..." if len(theirs) > 3 else "")
        warnings.warn(
            GoldenWarning(
                f"{path}: warning: {len(theirs)} of the golden snapshot's {len(golden.final_graph)} bricks "
                f"{'is' if len(theirs) == 1 else 'are'} not in this run ({shown}): the scene changed since it was taken; "
                f"{'it is drawn as a ghost' if len(theirs) == 1 else 'they are drawn as ghosts'}"
            ),
            stacklevel=3,
        )


__all__ = [
    "THREE_VERSION",
    "GoldenError",
    "GoldenWarning",
    "ghosts",
    "is_sweep_golden",
    "read_golden",
    "replay_data",
    "replay_html",
    "sweep_note",
    "write_replay",
]

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
``seek(t)``, ``time()``, ``frame()``, ``poses()``, ``select(id)``, ``selected()``,
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
import os
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..lang.files import written
from ..runtime.outcome import Graph
from ..runtime.trajectory import STATES, Trajectory
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
    from scipy.spatial.transform import Rotation

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
        why = []
        if i is None:
            why.append("not in this run")
        else:
            moved = float(np.linalg.norm(last.positions[i] - position))
            turned = float(
                np.degrees((Rotation.from_quat(last.orientations[i]).inv() * Rotation.from_quat(quaternion)).magnitude())
            )
            if moved > GHOST_DISTANCE:
                why.append(f"{moved * 1000:.1f} mm away")
            if turned > GHOST_ANGLE:
                why.append(f"turned {turned:.1f} deg")
            if fields.get("state") and run_states.get(brick) and fields["state"] != run_states[brick]:
                why.append(f"{fields['state']} in the golden, {run_states[brick]} here")
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


def replay_data(trajectory: Trajectory, golden: dict[str, Any] | None = None) -> dict[str, Any]:
    """Everything the page reads, as JSON values: the trajectory's arrays (base64: times
    float64, positions, quaternions and the ground's offset at each frame float32, frames and
    bodies int32, states uint8), ids, levels, half extents, fixtures (at rest: the page moves
    them with the ground's offset), events, brick graphs with their times, state names and
    colours, the golden's ghosts (:func:`ghosts`) and how many final bricks the golden has (None:
    no golden)."""
    meta = trajectory.meta
    collapse = meta.get("collapse")
    graphs = {"final": {"time": trajectory.end, "label": "at the end", "bricks": _graph(trajectory.graphs["final"])}}
    if "collapse" in trajectory.graphs and collapse is not None:
        graphs["collapse"] = {
            "time": float(collapse.get("decided", collapse["time"])),
            "label": "when the collapse was decided",
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
    }


def _script_json(value: Any) -> str:
    """JSON safe inside a ``<script>`` element: no ``</``, no ``<!--``."""
    return json.dumps(value, separators=(",", ":"), ensure_ascii=False).replace("</", "<\\/").replace("<!--", "<\\!--")


def replay_html(trajectory: Trajectory, golden: dict[str, Any] | None = None) -> str:
    """The replay page of ``trajectory`` as one HTML text (see the module's docstring)."""
    meta = trajectory.meta
    title = f"{meta.get('scenario') or meta.get('file') or 'run'} · stackdsl replay"
    parts = {
        "{{title}}": html.escape(title),
        "{{style}}": _page_file("replay.css"),
        "{{data}}": _script_json(replay_data(trajectory, golden)),
        "{{three}}": _vendored(VENDORED[0]),
        "{{orbit}}": _vendored(VENDORED[1]),
        "{{script}}": _page_file("replay.js").replace("</", "<\\/"),
    }
    page = _page_file("replay.html")
    for key, value in parts.items():
        page = page.replace(key, value)
    return page


def write_replay(trajectory: Trajectory, path: str | os.PathLike[str], golden: dict[str, Any] | None = None) -> Path:
    """Write the replay page of ``trajectory`` at ``path`` (under a temporary name, renamed
    when complete).

    Args:
        trajectory: a recorded run.
        path: the HTML file to write.
        golden: the scenario's golden snapshot (JSON data), whose final poses that differ from
            the run's are drawn as ghosts; None: no ghosts.

    Returns:
        ``path``.

    Raises:
        OSError: the file cannot be written.
    """
    text = replay_html(trajectory, golden)
    with written(path) as part:
        Path(part).write_text(text, encoding="utf-8")
    return Path(path)


def read_golden(path: str | os.PathLike[str] | None) -> dict[str, Any] | None:
    """A golden snapshot's JSON data, or None when ``path`` is None, missing, or not a JSON object."""
    if path is None:
        return None
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


__all__ = ["THREE_VERSION", "ghosts", "read_golden", "replay_data", "replay_html", "write_replay"]

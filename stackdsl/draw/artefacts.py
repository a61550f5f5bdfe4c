"""What a person looks at after one run: its trajectory file, a picture, a clip, a brick-graph plot
and the interactive 3D replay (:mod:`stackdsl.draw.replay`, with the golden snapshot's ghosts).

:func:`draw_run` writes them into one folder per scenario; ``stackdsl check --report DIR``
does this for every scenario, in the worker that ran it, and the HTML report
(:mod:`stackdsl.batch.htmlreport`) links them.

Source: stackdsl's own.
"""

from __future__ import annotations

import hashlib
import re
import time
import warnings
from collections.abc import Callable
from pathlib import Path

from ..runtime.trajectory import Trajectory

#: The files of one run, by kind: written in this order.
FILES = {
    "trajectory": "trajectory.npz",
    "picture": "picture.png",
    "graph": "graph.png",
    "clip": "clip.gif",
    "replay": "replay.html",
}
#: Wall seconds the drawing of one run is budgeted in the pool's estimates (picture, plot and
#: a clip of a few hundred frames: measured 2 to 15 s on the shipped scenarios).
DRAW_ESTIMATE = 6.0
#: Characters a folder name has at most.
MAX_NAME = 80
#: Wall seconds drawing may add to a run's own limit before its worker is stopped.
DRAW_LIMIT = 300.0


def folder_name(file: str, mode: str = "", taken: set[str] | None = None) -> str:
    """A folder name for one scenario's files: its path with every run of characters other
    than letters, digits, ``_`` and ``-`` turned into ``-`` (and the mode, when given), at
    most :data:`MAX_NAME` characters (a longer one keeps its end and a hash of the whole);
    ``-2``, ``-3``... when ``taken`` already holds it (the name is then added to ``taken``).

    >>> folder_name("scenarios/hard/tall_100.yaml")
    'scenarios-hard-tall_100'
    >>> folder_name("../my scenarios/a.yaml", "raw")
    'my-scenarios-a-raw'
    """
    stem = re.sub(r"\.(yaml|yml)$", "", file)
    name = re.sub(r"[^A-Za-z0-9_-]+", "-", f"{stem}-{mode}" if mode else stem).strip("-") or "scenario"
    if len(name) > MAX_NAME:  # file systems allow 255 bytes a name: the end, and a hash of the whole
        name = f"{name[-(MAX_NAME - 9) :].lstrip('-')}-{hashlib.sha1(name.encode()).hexdigest()[:8]}"
    if taken is None:
        return name
    unique, k = name, 1
    while unique in taken:
        k += 1
        unique = f"{name}-{k}"
    taken.add(unique)
    return unique


def golden_of(trajectory: Trajectory) -> Path | None:
    """The golden snapshot of the scenario file a trajectory was recorded from
    (:func:`stackdsl.verdicts.snapshot.scenario_golden_path`), or None when it names no file."""
    from ..verdicts.snapshot import scenario_golden_path

    file = trajectory.meta.get("file")
    return scenario_golden_path(file) if isinstance(file, str) and file else None


def draw_run(trajectory: Trajectory, folder: str | Path, deadline: float | None = None) -> tuple[dict[str, str], str, float]:
    """Write :data:`FILES` for one recorded run into ``folder`` (made if missing).

    The picture is at the moment the scenario's expectations judge (:attr:`stackdsl.Trajectory.shown_at`:
    the end for final positions, such as a toppled domino row; else the collapse when there was
    one, else the end); the brick-graph plot likewise. A file that cannot be drawn is left out, and the first such failure is
    returned as one line; the others are still drawn. The clip, the one long drawing, stops
    at ``deadline`` (``time.perf_counter()`` seconds; None: none) and is then left out. The
    scenario's golden snapshot is read for the replay's ghosts only when it is a regular file
    (a FIFO would block the reader); one that is not, or not this run's, is left out and said.

    Returns:
        (kind -> file name written, in ``folder``; the first failure or ``''``; wall seconds).
    """
    from .animate import animate
    from .graphplot import plot_graph
    from .render import picture
    from .replay import GoldenError, GoldenWarning, read_golden, write_replay

    start = time.perf_counter()
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    shown = trajectory.shown_at  # the moment the expectations judge: the end for a toppled domino row
    at = shown if shown == "end" or "collapse" in trajectory.graphs else "end"
    graph = trajectory.graphs["collapse" if at == "collapse" else "final"]
    name = trajectory.meta.get("scenario", "")
    steps: dict[str, Callable[[Path], object]] = {
        "trajectory": lambda path: trajectory.save(path),
        "picture": lambda path: picture(trajectory, shown, path),
        "graph": lambda path: plot_graph(graph, path, title=f"{name}: brick graph at the {at}"),
        "clip": lambda path: animate(trajectory, path, deadline=deadline),
        "replay": lambda path: write_replay(trajectory, path, golden),
    }
    written: dict[str, str] = {}
    failure = ""
    try:  # a golden that is not this run's, or that stackdsl cannot use: the replay is drawn without it
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", GoldenWarning)  # its bricks not in this run: the page's ghosts say so
            golden = read_golden(golden_of(trajectory), trajectory)
    except GoldenError as exc:
        golden, failure = None, f"replay drawn without its golden: {exc}"
    for kind, step in steps.items():
        try:
            step(out / FILES[kind])
            written[kind] = FILES[kind]
        except Exception as exc:  # one picture that fails must not hide the others or the verdict
            message = (str(exc).splitlines() or [""])[0]
            failure = failure or f"{kind} not drawn: {type(exc).__name__}: {message}"
    return written, failure, time.perf_counter() - start

"""``stackdsl bench record``: what recording costs, on the 30-level tower, in one run.

The shipped 30-level 4 stack (``scenarios/four_stack.yaml``, or any scenario given) runs
alternately with recording off (no recorder attached: the runtime as it is without one),
with the recorder at its default rate and with a frame at every physics step, ``repeats``
times each, in this one process; the medians and their ratios to "off" are the result.
Alternating spreads the machine's drift over every setting alike.

With ``--before PYTHON`` it also times the same check in another stackdsl install (the
virtualenv of an older commit, say) and in this one, round after round, so that "recording
off costs nothing" is measured against the code from before recording existed.

Source: stackdsl's own.
"""

from __future__ import annotations

import gc
import statistics
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..compile.compiler import compile_scenario
from ..compile.program import Program
from ..lang.loader import load_scenario
from ..runtime.recorder import RATE, Recorder
from ..runtime.run import run_program


@dataclass(frozen=True)
class RecordCost:
    """One setting's cost: ``wall`` the median seconds of its runs, ``runs`` all of them,
    ``frames`` and ``size`` (bytes of the saved .npz) when it recorded."""

    setting: str
    wall: float
    runs: tuple[float, ...]
    frames: int = 0
    size: int = 0


def record_costs(
    scenario: str | Path = "scenarios/four_stack.yaml", repeats: int = 7, mode: str | None = None
) -> list[RecordCost]:
    """Run ``scenario`` with recording off, at the default rate and every step, alternately.

    Raises:
        stackdsl.ScenarioError: a bad scenario.
        ValueError: ``repeats`` below 1.
    """
    if repeats < 1:
        raise ValueError(f"repeats must be at least 1, not {repeats}")
    program = compile_scenario(load_scenario(scenario), mode)
    every_step = 1.0 / program.engine.timestep
    settings: dict[str, Callable[[], tuple[int, int]]] = {
        "recording off": lambda: _run(program, None),
        f"recording at {RATE:g} Hz while moving": lambda: _run(program, RATE),
        "recording every step while moving": lambda: _run(program, every_step),
    }
    runs: dict[str, list[float]] = {name: [] for name in settings}
    sizes: dict[str, tuple[int, int]] = {}
    _run(program, None)  # warm-up: imports, caches
    for _ in range(repeats):
        for name, run in settings.items():
            gc.collect()
            start = time.perf_counter()
            sizes[name] = run()
            runs[name].append(time.perf_counter() - start)
    return [RecordCost(name, statistics.median(r), tuple(r), *sizes[name]) for name, r in runs.items()]


def _run(program: Program, rate: float | None) -> tuple[int, int]:
    """One run, timed by the caller, the trajectory saved as ``--record`` would: (frames, bytes)."""
    if rate is None:
        run_program(program)
        return 0, 0
    recorder = Recorder(program, rate)
    trajectory = recorder.trajectory(run_program(program, subscribers=(recorder,)))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "run.npz"
        trajectory.save(path)
        return len(trajectory.times), path.stat().st_size


def format_record_costs(rows: list[RecordCost], scenario: str) -> str:
    """The costs as a table: median wall seconds, ratio to recording off, frames, file size."""
    base = rows[0].wall
    lines = [
        f"{scenario}: {len(rows[0].runs)} runs each, alternating, in one process",
        f"{'setting':<38} {'median wall':>12} {'ratio to off':>13} {'frames':>7} {'file':>9}   runs (s)",
    ]
    for r in rows:
        size = f"{r.size / 1024:.0f} KiB" if r.size else "-"
        runs = " ".join(f"{t:.3f}" for t in r.runs)
        lines.append(f"{r.setting:<38} {r.wall:>10.3f} s {r.wall / base:>13.3f} {r.frames or '-':>7} {size:>9}   {runs}")
    return "\n".join(lines)


#: The check timed in each interpreter by :func:`before_and_after` (a program text, run with ``python -c``).
_TIMED_CHECK = """
import statistics, sys, time, stackdsl
path, runs = sys.argv[1], int(sys.argv[2])
list(stackdsl.check([path], jobs=1))  # warm-up: imports, caches
for _ in range(runs):
    start = time.perf_counter()
    results = list(stackdsl.check([path], jobs=1))
    print(f"{time.perf_counter() - start:.6f}")
"""


def check_interpreter(python: str) -> str:
    """What is wrong with ``python`` as the ``--before`` interpreter (not there, not a Python,
    no stackdsl in it), in one line, or ``''``."""
    import subprocess

    try:
        done = subprocess.run([python, "-c", "import stackdsl"], capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        return "cannot run it: it did not import stackdsl within 60 s"
    except OSError as exc:  # not there, a folder, not executable: the OS's reason, not its errno
        kind = "a folder, not a program" if Path(python).is_dir() else (exc.strerror or str(exc)).lower()
        return f"cannot run it: {kind}"
    if done.returncode:
        last = (done.stderr.strip().splitlines() or ["(no message)"])[-1]
        return f"not a Python with stackdsl installed: {last}"
    return ""


def before_and_after(
    before: str, scenario: str | Path = "scenarios/four_stack.yaml", rounds: int = 10, runs: int = 5
) -> dict[str, list[float]]:
    """Time ``stackdsl.check([scenario])`` (one job, in-process, so without the command's start-up)
    in another install's Python (``before``: e.g. the virtualenv of an older commit) and in this
    one, ``runs`` times each per round, the two alternating for ``rounds`` rounds.

    Returns:
        ``{"before": seconds, "after": seconds}``, every run.

    Raises:
        subprocess.CalledProcessError: an interpreter failed (not a stackdsl, a bad scenario).
        ValueError: ``rounds`` or ``runs`` below 1.
    """
    import subprocess
    import sys

    if rounds < 1 or runs < 1:
        raise ValueError(f"rounds and runs must be at least 1, not {rounds} and {runs}")
    path = str(Path(scenario).resolve())
    times: dict[str, list[float]] = {"before": [], "after": []}
    for _ in range(rounds):
        for name, python in (("before", before), ("after", sys.executable)):
            out = subprocess.run(
                [python, "-c", _TIMED_CHECK, path, str(runs)], capture_output=True, text=True, check=True, cwd=Path(path).parent
            )
            times[name] += [float(x) for x in out.stdout.split()]
    return times


def format_before_and_after(times: dict[str, list[float]], before: str, scenario: str) -> str:
    """The medians, quartiles and the ratio after / before, as lines."""
    lines = [f"{scenario}: check in-process, {len(times['after'])} runs each, alternating rounds"]
    for name, label in (("before", f"before ({before})"), ("after", "after (this stackdsl, recording off)")):
        q = statistics.quantiles(times[name], n=4) if len(times[name]) > 1 else [times[name][0]] * 3
        lines.append(f"  {label}: median {statistics.median(times[name]):.3f} s, quartiles {q[0]:.3f}-{q[2]:.3f} s")
    lines.append(f"  ratio after / before: {statistics.median(times['after']) / statistics.median(times['before']):.3f}")
    return "\n".join(lines)

"""What the stability models cost: ``stackdsl bench solve`` and ``stackdsl bench height``.

``solve``: the wall time of one rigid-block equilibrium solve for towers of 10 to 100 bricks.

``height``: upright towers as they grow, per stability model.

Upright 4 stacks of 10 to 200 levels, each setting on each height in a fresh worker process
(:func:`stackdsl.bench.bench.run_matrix`), the wall time per brick, the ratio of each setting's wall
time to the first setting's on the same tower, and the exponent of wall time in bricks (a
power-law fit over all heights). Then the profiles of the 30-level tower and the tallest one in
each setting, by a sampling profiler (pyinstrument, the ``profile`` extra): where the wall time
goes (the physics steps, the stability extension's admission and stack-wide test, the collapse
monitor), and per step, the engine's step against everything else.

Source: stackdsl's own.
"""

from __future__ import annotations

import os
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from stability import solve_equilibrium

from ..compile.compiler import compile_scenario
from ..lang.loader import parse_scenario
from ..runtime.run import RunOptions, run_program
from ..verdicts.oracle import structure
from .bench import WARM_UP, Cell, Scene, fit_exponent, program_for, run_matrix

DEFAULT_LEVELS = (10, 20, 30, 60, 100, 200)
DEFAULT_SETTINGS = ("extension report", "extension equilibrium")

PARTS = {
    "physics steps (the engine's step)": (("engines/pybullet/world.py", "step"), ("engines/mujoco/world.py", "step")),
    "stability extension, all of it": (("_extension.py", "update"),),
    "  admission by rigid-block equilibrium": (("_admission.py", "leaning"),),
    "  admission by the basic test": (("_admission.py", "basic"),),
    "  the debris rule": (("_debris.py", "admit"),),
    "  stack-wide test": (("_stack_test.py", "run"),),
    "collapse monitor": (("runtime/collapse.py", "after_step"),),
    "placing bricks": (("runtime/loop.py", "place"),),
}
"""Profile rows: label -> the (file name, function name) pairs whose time, inclusive, is shown."""

PHYSICS = "physics steps (the engine's step)"
"""The row of the engine's own work."""

SAMPLE = 0.0002
"""Seconds between two samples of the profiler."""


def towers(levels: Sequence[int]) -> list[Scene]:
    """The upright 4 stacks of the given heights."""
    return [Scene("upright", n, n, f"tower: {{levels: {n}}}", None) for n in levels]


def measure_heights(
    settings: Sequence[str], levels: Sequence[int], repeats: int, jobs: int, progress: Callable[[Cell], None]
) -> list[Cell]:
    """Every setting on every tower, built to the top (see :func:`stackdsl.bench.bench.run_matrix`)."""
    return run_matrix(list(settings), towers(levels), repeats=repeats, repeat_below=30.0, jobs=jobs, progress=progress)


@dataclass(frozen=True)
class Profile:
    """Where one run's wall time went: seconds per :data:`PARTS` row, of ``total`` seconds, by a
    sampling profiler (which slows the Python it samples); and, from the fastest of
    :data:`PLAIN` runs without it, its wall time and the engine's steps' share (``engine``, as
    the step loop times them), in ``steps`` physics steps."""

    setting: str
    levels: int
    total: float
    parts: dict[str, float]
    steps: int
    wall: float
    engine: float

    @property
    def per_step(self) -> tuple[float, float]:
        """Seconds per physics step, without the profiler: the engine's step, and everything else."""
        return self.engine / self.steps, (self.wall - self.engine) / self.steps


PLAIN = 3
"""Runs without the profiler, of which the fastest gives the per-step times."""


def profile_tower(setting: str, levels: int) -> Profile:
    """Run one tower (after an untimed warm-up run) :data:`PLAIN` times as it is, then once
    under pyinstrument's sampling profiler, and split its time (:data:`PARTS`). Raises
    ImportError without pyinstrument (the ``profile`` extra)."""
    from pyinstrument import Profiler

    run_program(program_for(WARM_UP, setting), RunOptions())
    program = program_for(towers([levels])[0], setting)
    fastest = min((run_program(program, RunOptions()) for _ in range(PLAIN)), key=lambda o: o.wall_time)
    profiler = Profiler(interval=SAMPLE)
    profiler.start()
    outcome = run_program(program, RunOptions())
    session = profiler.stop()
    root = session.root_frame()
    total = _inclusive(root, (("runtime/run.py", "run_program"),))
    parts = {label: _inclusive(root, where) for label, where in PARTS.items()}
    return Profile(setting, levels, total, parts, outcome.steps, fastest.wall_time, fastest.engine_time)


def _inclusive(frame: Any, where: tuple[tuple[str, str], ...]) -> float:
    """Seconds sampled in the calls of any (file, function) of ``where`` under ``frame``, each
    call counted once (not again for a call of the same within it)."""
    path = (frame.file_path or "").replace(os.sep, "/")
    if any(frame.function == function and path.endswith(file) for file, function in where):
        return float(frame.time)
    return sum(_inclusive(child, where) for child in frame.children)


def format_heights(cells: list[Cell], settings: Sequence[str]) -> str:
    """The table: per height, each setting's wall time, ms per brick, steps, and its ratio to the first."""
    by = {(c.setting, c.parameter): c for c in cells}
    heights = sorted({int(c.parameter) for c in cells})
    first = settings[0]
    head = "| levels | bricks | " + " | ".join(f"{s}: wall, per brick, steps" for s in settings)
    head += "".join(f" | {s} / {first}" for s in settings[1:]) + " |"
    lines = [head, "|" + "---:|" * (2 + 2 * len(settings) - 1)]
    for n in heights:
        row = [by.get((s, n)) for s in settings]
        bricks = next(c.bricks for c in row if c is not None)
        cols = [f"{c.wall:.2f} s, {c.wall / c.bricks * 1000:.1f} ms, {c.steps}" if c else "" for c in row]
        base = by.get((first, n))
        ratios = [f"{c.wall / base.wall:.2f}" if c and base else "" for c in row[1:]]
        lines.append(f"| {n} | {bricks} | " + " | ".join(cols + ratios) + " |")
    lines.append("")
    for s in settings:
        mine = [(c.bricks, c.wall) for c in cells if c.setting == s]
        if len(mine) >= 2:
            low, high = min(heights), max(heights)
            lines.append(f"exponent of wall time in bricks, {s}, {low} to {high} levels: {fit_exponent(mine):.2f}")
    return "\n".join(lines)


def format_profiles(profiles: list[Profile]) -> str:
    """The profile table: seconds and share of the sampled run per part, one column per setting
    and height; then the steps and, from the runs without the profiler, the wall time and per
    step the engine's step against everything else."""
    head = "| part | " + " | ".join(f"{p.setting}, {p.levels} levels" for p in profiles) + " |"
    lines = [head, "|---|" + "---:|" * len(profiles)]
    lines.append("| the run, sampled | " + " | ".join(f"{p.total:.2f} s" for p in profiles) + " |")
    for label in PARTS:
        cols = [f"{p.parts[label]:.2f} s ({p.parts[label] / p.total:.0%})" for p in profiles]
        lines.append(f"| {label} | " + " | ".join(cols) + " |")
    lines.append("| physics steps taken | " + " | ".join(str(p.steps) for p in profiles) + " |")
    lines.append("| wall time, without the profiler | " + " | ".join(f"{p.wall:.3f} s" for p in profiles) + " |")
    lines.append("| per step: the engine's step | " + " | ".join(f"{p.per_step[0] * 1e6:.0f} us" for p in profiles) + " |")
    lines.append("| per step: everything else | " + " | ".join(f"{p.per_step[1] * 1e6:.0f} us" for p in profiles) + " |")
    ratio = [f"{p.per_step[1] / p.per_step[0]:.1f}" if p.per_step[0] > 0 else "" for p in profiles]
    lines.append("| everything else / the engine's step | " + " | ".join(ratio) + " |")
    return "\n".join(lines)


@dataclass(frozen=True)
class SolveTime:
    """One row of ``stackdsl bench solve``: bricks, contacts, and the median wall time (s)
    of a solve as the model does it (level contacts: the vertical program first) and of the
    full program alone, with the full program's number of variables."""

    bricks: int
    contacts: int
    variables: int
    median: float
    full: float


def solve_times(sizes: tuple[int, ...] = (10, 25, 50, 100), repeats: int = 5) -> list[SolveTime]:
    """Time the equilibrium solve of the first ``n`` bricks of a 4 stack, for each n in ``sizes``.

    Raises:
        ValueError: a size below 1.
    """
    rows = []
    for n in sizes:
        if n < 1:
            raise ValueError(f"a tower needs at least one brick, got {n}")
        program = compile_scenario(parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: {(n + 1) // 2}}}}}\n"))
        blocks, contacts = structure(program.placements[:n], program.fixtures, program.ground_friction)
        times: dict[bool, list[float]] = {True: [], False: []}
        for quick in (True, False):
            for _ in range(repeats):
                start = time.perf_counter()
                result = solve_equilibrium(blocks, contacts, quick=quick)
                times[quick].append(time.perf_counter() - start)
                if not result.stands:
                    raise AssertionError(f"the {n}-brick tower should stand")
        variables = sum(len(c.points) for c in contacts) * 10
        rows.append(SolveTime(n, len(contacts), variables, statistics.median(times[True]), statistics.median(times[False])))
    return rows


def format_solve_times(rows: list[SolveTime]) -> str:
    """The table ``stackdsl bench solve`` prints (markdown)."""
    lines = [
        "| bricks | contacts | a solve (vertical program first) | the full program | its variables |",
        "|---:|---:|---:|---:|---:|",
    ]
    lines += [f"| {r.bricks} | {r.contacts} | {r.median * 1000:.1f} ms | {r.full * 1000:.1f} ms | {r.variables} |" for r in rows]
    return "\n".join(lines)

"""``stackdsl bench verdicts``: each mode's verdicts on random assemblies against the oracle.

Assembly ``k`` is drawn from ``SeedSequence(seed, spawn_key=(k,))`` (:mod:`stackdsl._assemblies`),
judged by rigid-block equilibrium brick by brick in placing order, and run in every setting
of :data:`SETTINGS`. A setting agrees with the oracle on an assembly when it gives the same
collapse level (or both say it stands). Agreement is reported over every assembly and over
those whose oracle margin exceeds :data:`MARGIN` (a verdict that a smaller move of the
centres of mass would flip is one no simulation can be held to); the misjudged ones are
written out as scenario files.

Source: stackdsl's own.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: Metres: the oracle margin above which a setting must agree.
MARGIN = 0.001

#: name -> (mode, stability model).
SETTINGS: dict[str, tuple[str, str]] = {
    "raw": ("raw", "report"),
    "tuned": ("tuned", "report"),
    "extension (report)": ("extension", "report"),
    "extension (equilibrium)": ("extension", "equilibrium"),
}


@dataclass(frozen=True)
class Verdicts:
    """One assembly: its index, file text, bricks, the oracle's level (None: stands) and margin
    (m), and each setting's level and wall time (s); ``error``: a run's internal error, else ''."""

    index: int
    text: str
    bricks: int
    oracle: int | None
    margin: float
    levels: dict[str, int | None]
    walls: dict[str, float]
    error: str = ""


def verdicts(seed: int, index: int) -> Verdicts:
    """Draw, judge and run assembly ``index`` of ``seed`` (a worker's task)."""
    from ._assemblies import assembly, judge
    from ._compiler import compile_scenario
    from ._loader import parse_scenario
    from ._runtime import run_program

    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index,)))
    text = assembly(rng, f"assembly {seed}-{index}")
    scenario = parse_scenario(text, f"assembly_{index}.yaml")
    oracle = judge(compile_scenario(scenario))
    levels: dict[str, int | None] = {}
    walls: dict[str, float] = {}
    error = ""
    try:
        for name, (mode, model) in SETTINGS.items():
            outcome = run_program(compile_scenario(scenario, mode, model), timeout=60.0)
            levels[name] = outcome.collapse.level if outcome.collapse else None
            walls[name] = outcome.wall_time
    except Exception as exc:  # this assembly's internal error, reported with it
        error = f"{type(exc).__name__}: {exc}"
    bricks = len(scenario.structure.bricks or [])
    return Verdicts(index, text, bricks, oracle.collapse_level, oracle.margin, levels, walls, error)


def run_verdicts(seed: int, count: int, jobs: int, each: Callable[[Verdicts], None] = lambda v: None) -> list[Verdicts]:
    """Assemblies 0 to ``count - 1`` of ``seed`` on ``jobs`` processes, in index order."""
    from ._pool import fan_out

    tasks = [(seed, k) for k in range(count)]
    results: list[Verdicts] = []
    iterator: Iterator[Verdicts] = fan_out(verdicts, tasks, [2.0] * count, jobs, here=False)
    for v in iterator:
        results.append(v)
        each(v)
    return sorted(results, key=lambda v: v.index)


def agrees(v: Verdicts, setting: str) -> bool:
    """The setting's collapse level is the oracle's (both None: both stand)."""
    return setting in v.levels and v.levels[setting] == v.oracle


def format_verdicts(results: list[Verdicts], out: Path | None, seconds: float) -> str:
    """The agreement table, and the misjudged assemblies with a margin above :data:`MARGIN`
    (written to ``out`` as scenario files when it is given)."""
    sure = [v for v in results if v.margin > MARGIN and not v.error]
    stands = sum(v.oracle is None for v in results)
    lines = [
        f"{len(results)} random assemblies ({stands} stand by the oracle), {len(sure)} with an oracle margin above "
        f"{MARGIN * 1000:g} mm; {seconds:.0f} s wall",
        f"{'setting':<26} {'agree, all':>12} {'agree, margin > 1 mm':>22} {'median wall':>12}",
    ]
    for name in SETTINGS:
        every = sum(agrees(v, name) for v in results)
        margin = sum(agrees(v, name) for v in sure)
        wall = float(np.median([v.walls[name] for v in results if name in v.walls] or [0.0]))
        lines.append(
            f"{name:<26} {every / max(1, len(results)):>11.1%} {margin:>10}/{len(sure):<5} {margin / max(1, len(sure)):>5.1%} "
            f"{wall * 1000:>9.0f} ms"
        )
    wrong = [(v, n) for v in sure for n in SETTINGS if not agrees(v, n)]
    if wrong:
        lines.append("misjudged (margin above 1 mm): assembly, setting, measured, oracle, margin")
    for v, name in wrong:
        where = ""
        if out is not None:
            out.mkdir(parents=True, exist_ok=True)
            path = out / f"assembly_{v.index:04d}.yaml"
            path.write_text(v.text)
            where = f"  {path}"
        lines.append(
            f"  {v.index:4d}  {name:<24} {_level(v.levels.get(name))} (oracle {_level(v.oracle)}), margin {v.margin * 1000:.1f} mm{where}"
        )
    if not wrong:
        lines.append(f"no assembly with a margin above {MARGIN * 1000:g} mm misjudged: no files written")
    elif out is not None:
        lines.append(f"(their files are in {out})")
    errors = [v for v in results if v.error]
    for v in errors:
        lines.append(f"  {v.index:4d}  internal error: {v.error}")
    return "\n".join(lines)


def _level(level: int | None) -> str:
    return "stands" if level is None else f"collapse {level}"


def timed(seed: int, count: int, jobs: int, each: Callable[[Verdicts], None] = lambda v: None) -> tuple[list[Verdicts], float]:
    """:func:`run_verdicts` and its wall seconds."""
    start = time.perf_counter()
    results = run_verdicts(seed, count, jobs, each)
    return results, time.perf_counter() - start

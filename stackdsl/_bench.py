"""Benchmarks: measurements that take too long for the tests, each a command with its output.

``stackdsl bench solve``: the wall time of one rigid-block equilibrium solve
(:func:`stability.solve_equilibrium`) for 4-stack towers of 10, 25, 50 and 100 bricks, the
size of the program the equilibrium model solves when a brick is frozen.

Source: stackdsl's own.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass

from stability import solve_equilibrium

from ._compiler import compile_scenario
from ._loader import parse_scenario
from ._oracle import structure


@dataclass(frozen=True)
class SolveTime:
    """One row of ``stackdsl bench solve``: bricks, LP size, median and max wall time (s)."""

    bricks: int
    contacts: int
    variables: int
    median: float
    worst: float


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
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            result = solve_equilibrium(blocks, contacts)
            times.append(time.perf_counter() - start)
        if not result.stands:
            raise AssertionError(f"the {n}-brick tower should stand")
        variables = sum(len(c.points) for c in contacts) * 10
        rows.append(SolveTime(n, len(contacts), variables, statistics.median(times), max(times)))
    return rows


def format_solve_times(rows: list[SolveTime]) -> str:
    """The table ``stackdsl bench solve`` prints (markdown)."""
    lines = ["| bricks | contacts | LP variables | median solve | worst of runs |", "|---:|---:|---:|---:|---:|"]
    lines += [f"| {r.bricks} | {r.contacts} | {r.variables} | {r.median * 1000:.1f} ms | {r.worst * 1000:.1f} ms |" for r in rows]
    return "\n".join(lines)

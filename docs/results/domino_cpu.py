"""The domino row's cost per setting in CPU time, which a shared machine inflates less than wall time.

Builds a row of ``COUNT`` dominoes the way ``stackdsl bench dominoes`` does
(:func:`stackdsl.bench.dominoes.domino_row`), runs it once untimed in each setting, then
``REPEATS`` times, and prints per setting the median CPU time of this process
(``time.process_time``), the median wall time, the steps, and the dominoes toppled and thrown
out of the row. On a machine shared with other jobs the wall time is mostly waiting for a core;
the CPU time is the run's own work, so ratios of CPU times are what the settings cost.
``--profile`` prints instead a cProfile of one warm run of the extension, in CPU time;
``--runs N [SETTING]`` runs one setting (the extension unless given) N times and prints
nothing but the toppled count, for a sampling profiler or an instruction count (``valgrind
--tool=callgrind``: the counts of 1 and of 3 runs differ by two warm runs, whatever the
machine's load).

    python docs/results/domino_cpu.py COUNT REPEATS [SETTING,SETTING...]
    python docs/results/domino_cpu.py COUNT --profile
    python docs/results/domino_cpu.py COUNT --runs N [SETTING]

Output: docs/results/dominoes.md.
"""

from __future__ import annotations

import cProfile
import os
import pstats
import statistics
import sys
import time

from stackdsl import compile_scenario, parse_scenario, run_program
from stackdsl.bench.dominoes import domino_row, row_count

DEFAULT = "raw 240 Hz,MuJoCo tuned sleeping,extension report"


def cost(count: int, setting: str, repeats: int) -> str:
    """One line: the median CPU and wall time (s) of ``repeats`` warm runs, steps, toppled, left."""
    program = compile_scenario(parse_scenario(domino_row(count, setting), f"dominoes-{count}.yaml"))
    run_program(program)
    cpus, walls, outcome = [], [], None
    for _ in range(repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        outcome = run_program(program)
        cpus.append(time.process_time() - cpu)
        walls.append(time.perf_counter() - wall)
    assert outcome is not None
    toppled, left = row_count(outcome)
    return (
        f"{setting}: cpu {statistics.median(cpus):.3f} s, wall {statistics.median(walls):.2f} s, "
        f"{outcome.steps} steps, {toppled} toppled, {left} left the row"
    )


def profile(count: int) -> None:
    """A cProfile (CPU time) of one warm run of the extension on ``count`` dominoes."""
    program = compile_scenario(parse_scenario(domino_row(count, "extension report"), f"dominoes-{count}.yaml"))
    run_program(program)
    profiler = cProfile.Profile(time.process_time)
    profiler.enable()
    run_program(program)
    profiler.disable()
    pstats.Stats(profiler).sort_stats("cumulative").print_stats(40)


def main(argv: list[str]) -> None:
    count = int(argv[0])
    print(f"{count} dominoes: load average {os.getloadavg()[0]:.1f}", flush=True)
    if argv[1] == "--profile":
        profile(count)
        return
    if argv[1] == "--runs":
        setting = argv[3] if len(argv) > 3 else "extension report"
        program = compile_scenario(parse_scenario(domino_row(count, setting), f"dominoes-{count}.yaml"))
        for _ in range(int(argv[2])):
            outcome = run_program(program)
        print(f"{row_count(outcome)[0]} toppled")
        return
    for setting in (argv[2] if len(argv) > 2 else DEFAULT).split(","):
        print(cost(count, setting, int(argv[1])), f"(load {os.getloadavg()[0]:.1f})", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])

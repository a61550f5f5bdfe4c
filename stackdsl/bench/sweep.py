"""``stackdsl bench sweep``: samples a second of a sweep, on each executor, in one run.

The scene is the shipped random single-file stack (``sweeps/random_single_file.yaml``) built
to 10 levels, or any sweep file's (``stackdsl bench sweep FILE``: what that sweep will take on
each executor). The same samples run with one process, with two (stackdsl's pool: this process
and one worker) and on a local Dask cluster of two single-threaded worker processes; the
cluster's start and a warm-up batch on each of its workers are timed apart, as a cluster is
started once for many sweeps; stackdsl's pool starts its workers within its time (measured
apart too, for the table). Parallel efficiency is the two-way rate over twice the one-way
rate. Every executor's per-sample results but the wall time must be the same. A second table
(:func:`loaded`) runs the samples again while one core is kept busy: ``-j 1`` against ``-j
auto``, which must never be the slower.

Source: stackdsl's own.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from ..batch.sweep import SampleResult, SweepOptions, collect, dask_executor, run_batch, run_sweep
from ..lang.errors import ScenarioError
from ..lang.loader import load_scenario, parse_scenario
from ..lang.sampling import Template

SCENE = """stackdsl: 1
name: random single-file stack, 10 levels
structure:
  tower:
    levels: 10
    bricks_per_layer: 1
    turn: 0
    shift: {uniform: [-60 mm, 60 mm], per: layer}
timing:
  settle: 0.2 s
sweep:
  samples: 1
"""


@dataclass(frozen=True)
class Throughput:
    """One executor's run: ``seconds`` of wall time for ``samples``; ``startup``: seconds to start
    its workers (a Dask cluster: before, not in ``seconds``; stackdsl's pool: within ``seconds``,
    measured apart), 0 for one process."""

    executor: str
    samples: int
    seconds: float
    startup: float = 0.0

    @property
    def rate(self) -> float:
        """Samples a second."""
        return self.samples / self.seconds


def template(samples: int | None, scene: str | Path | None = None) -> Template:
    """The benchmark's scene (or ``scene``, a sweep file's) with ``samples`` samples a grid cell
    (None: the file's own count).

    Raises:
        ScenarioError: ``scene`` is not a valid scenario, or has nothing random to sweep.
    """
    scenario = parse_scenario(SCENE, "bench-sweep.yaml") if scene is None else load_scenario(scene)
    if scenario.template is None:
        raise ScenarioError("this scenario has no sweep and no random field: nothing to sample", file=str(scene))
    template: Template = scenario.template
    return template if samples is None else template.with_samples(samples)


def title(t: Template) -> str:
    """The table's first line: the scene and how many samples each executor runs."""
    cells = f" ({t.cells} grid cells x {t.samples})" if t.cells > 1 else ""
    return f"{t.data.get('name', 'sweep')}: {t.cells * t.samples} samples{cells} on each executor"


def throughputs(t: Template, each: Callable[[Throughput], None] = lambda row: None) -> tuple[list[Throughput], bool]:
    """Run every sample of ``t`` on each executor: (their throughputs, whether every executor
    gave the same per-sample results); ``each`` sees each executor's row as it is measured."""
    samples = t.cells * t.samples
    options = SweepOptions(timeout=None)
    rows, runs = [], []
    for jobs in (1, 2):
        start = time.perf_counter()
        runs.append(collect(run_sweep(t, options, jobs=jobs)))
        startup = _pool_startup(jobs) if jobs > 1 else 0.0
        rows.append(Throughput(f"{jobs} process{'es' * (jobs > 1)} (-j {jobs})", samples, time.perf_counter() - start, startup))
        each(rows[-1])
    start = time.perf_counter()
    with dask_executor("local:2") as (executor, threads, _):
        warm = [executor.submit(run_batch, t, 0, [0], options) for _ in range(threads)]
        for future in warm:  # each worker imports stackdsl and pybullet once
            future.result()
        ready = time.perf_counter() - start
        start = time.perf_counter()
        runs.append(collect(run_sweep(t, options, executor=executor, workers=threads)))
        rows.append(Throughput(f"Dask LocalCluster, {threads} workers", samples, time.perf_counter() - start, ready))
        each(rows[-1])
    same = all(_plain(r) == _plain(runs[0]) for r in runs[1:])
    return rows, same


#: Seconds a busy core spins before the loaded rows are measured: the 1-minute load average,
#: which ``-j auto`` reads, is then above 0.6.
SPIN_UP = 60.0


def loaded(
    t: Template, each: Callable[[Throughput], None] = lambda row: None, spin_up: float = SPIN_UP
) -> tuple[list[Throughput], float]:
    """The same samples on a machine one core of which is busy (a process spinning, started
    ``spin_up`` seconds before): with one process (``-j 1``) and with ``-j auto`` (one per free
    core, :func:`stackdsl.batch.address.free_cores`, read after the spin-up). Returns the two
    rows and the load average ``-j auto`` saw. The spinner is stopped however this ends."""
    import os
    import subprocess
    import sys

    from ..batch.address import free_cores

    samples = t.cells * t.samples
    options = SweepOptions(timeout=None)
    spinner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(spin_up)
        load, auto = os.getloadavg()[0], free_cores()
        rows = []
        for name, jobs in (("-j 1", 1), (f"-j auto ({auto} process{'es' * (auto > 1)})", auto)):
            start = time.perf_counter()
            collect(run_sweep(t, options, jobs=jobs))
            rows.append(Throughput(f"busy core: {name}", samples, time.perf_counter() - start))
            each(rows[-1])
        return rows, load
    finally:
        spinner.kill()
        spinner.wait()


def _pool_startup(workers: int) -> float:
    """Seconds for stackdsl's pool to start ``workers`` processes and have each import what a
    run needs (part of the pool's wall time above, measured alone here)."""
    from ..batch.pool import Workers

    start = time.perf_counter()
    pool = Workers(workers, warm=run_batch)
    try:
        while pool.ready < workers:
            pool.collect(timeout=None)
        return time.perf_counter() - start
    finally:
        pool.stop()


def _plain(results: list[SampleResult]) -> list[SampleResult]:
    return [replace(r, wall_time=0.0) for r in results]


HEADER = f"{'executor':<32} {'wall':>9} {'samples/s':>10} {'start-up':>9} {'efficiency: with start-up':>26} {'once up':>8}"


def format_row(r: Throughput, one: Throughput) -> str:
    """One executor's line: its wall time and rate, its parallel efficiency with its workers'
    start-up counted and once they are up (its rate over its workers' count times ``one``'s, the
    one-process row's). stackdsl's pool starts its workers within its wall time, a Dask cluster
    before it."""
    workers = 1 if r is one else 2
    within = not r.executor.startswith("Dask")
    total = r.seconds + (0.0 if within else r.startup)
    running = r.seconds - (r.startup if within else 0.0)
    startup = f"{wall_text(r.startup)} s" if r.startup else "-"
    return (
        f"{r.executor:<32} {wall_text(r.seconds):>7} s {r.rate:>10.1f} {startup:>9} "
        f"{r.samples / total / (workers * one.rate):>26.0%} {r.samples / running / (workers * one.rate):>8.0%}"
    )


def wall_text(seconds: float) -> str:
    """``seconds`` of wall time as the table prints it, without the unit: hundredths under 10 s
    (six samples of a small stack took 0.05 s, which tenths printed as 0.0), tenths above.

    >>> wall_text(0.0496), wall_text(12.34)
    ('0.05', '12.3')
    """
    return f"{seconds:.2f}" if seconds < 10 else f"{seconds:.1f}"


def footer(same: bool) -> str:
    """The table's last lines: whether every executor gave the same per-sample results."""
    return (
        "per-sample results identical on every executor: " + ("yes" if same else "NO") + "\n"
        "(the pool's wall includes starting its workers; Dask's is from its first batch on, its cluster and a "
        "warm-up batch a worker being its start-up)"
    )


def format_throughputs(name: str, rows: list[Throughput], same: bool) -> str:
    """The whole table (``name``: its first line, see :func:`title`)."""
    return "\n".join([name, HEADER, *(format_row(r, rows[0]) for r in rows), footer(same)])

"""Check many scenario files: load all, compile all, then run them on an executor.

Nothing runs unless every file loads and compiles: a bad file stops the whole check
before any simulation. Runs are farmed out through ``concurrent.futures.Executor``:
in-process for one job, a spawn process pool otherwise (each worker creates its own
pybullet client; clients do not survive pickling).

Source: stackdsl's own (docs/design.md, data flow: check).
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterator
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from ._compiler import compile_scenario
from ._errors import ScenarioError
from ._expect import Verdict, describe, evaluate
from ._loader import load_scenario
from ._program import Program
from ._runtime import run_program
from ._schema import Expect


@dataclass(frozen=True)
class CheckResult:
    """One scenario checked.

    Attributes:
        file, scenario, mode, model: what ran (model: the stability model).
        verdicts: one per expectation (empty: the file expects nothing).
        collapse_level: measured, or None when the structure stood.
        levels_placed: how many levels were built.
        simulated_time, wall_time: seconds.
        drift: metres, the largest displacement of a brick that stood (``Outcome.drift``).
        steps_per_brick: physics steps taken per placed brick.
    """

    file: str
    scenario: str
    mode: str
    model: str
    verdicts: tuple[Verdict, ...]
    collapse_level: int | None
    levels_placed: int
    simulated_time: float
    wall_time: float
    drift: float = 0.0
    steps_per_brick: float = 0.0

    @property
    def passed(self) -> bool:
        """True when every expectation held."""
        return all(v.passed for v in self.verdicts)

    @property
    def expected(self) -> str:
        return ", ".join(v.expected for v in self.verdicts) or "(nothing)"

    @property
    def measured(self) -> str:
        described = describe(self.collapse_level)
        extra = [v.measured for v in self.verdicts if v.name == "stays"]
        return ", ".join([described, *extra])


class ScenarioErrors(Exception):
    """Several files failed to load or compile; ``errors`` holds one ScenarioError each."""

    def __init__(self, errors: list[ScenarioError]) -> None:
        super().__init__("\n".join(str(e) for e in errors))
        self.errors = errors


def discover(paths: list[str | Path]) -> list[Path]:
    """Scenario files named by ``paths``: files as given, folders searched for ``*.yaml``/``*.yml``.

    Raises:
        ScenarioErrors: a path does not exist, or a folder holds no scenario file.
    """
    files, errors = [], []
    for raw in paths:
        path = Path(raw)
        if path.is_dir():
            found = sorted(p for p in path.rglob("*") if p.suffix in (".yaml", ".yml") and p.is_file())
            if not found:
                errors.append(ScenarioError("no scenario files (*.yaml) in this folder", file=str(path)))
            files += found
        elif path.is_file():
            files.append(path)
        else:
            errors.append(ScenarioError("no such file or folder", file=str(path)))
    if errors:
        raise ScenarioErrors(errors)
    return files


def prepare(
    files: list[Path], mode: str | None = None, modes: tuple[str, ...] = (), model: str | None = None
) -> list[tuple[Path, Program, Expect]]:
    """Load and compile every file (in each of ``modes`` when given, with the stability
    ``model`` when given); nothing is simulated.

    Raises:
        ScenarioErrors: one error per bad file.
    """
    prepared, errors = [], []
    for path in files:
        try:
            scenario = load_scenario(path)
            for m in modes or (mode,):
                prepared.append((path, compile_scenario(scenario, m, model), scenario.expect))
        except ScenarioError as exc:
            errors.append(exc)
    if errors:
        raise ScenarioErrors(errors)
    return prepared


def check(
    paths: list[str | Path],
    mode: str | None = None,
    jobs: int | None = None,
    executor: Executor | None = None,
    model: str | None = None,
) -> Iterator[CheckResult]:
    """Check every scenario under ``paths``; results come in file order as they finish.

    Every file is loaded and compiled before this returns (so bad input raises here,
    before anything is simulated); the runs happen as the iterator is consumed.

    Args:
        paths: files or folders.
        mode: overrides each scenario's engine mode.
        model: overrides each scenario's stability model.
        jobs: worker processes (default: one per core, at most one per file); 1 runs
            in this process.
        executor: run on this executor instead (e.g. a Dask client's executor).

    Raises:
        ScenarioErrors: a file is missing or invalid (before anything runs).
    """
    return _results(prepare(discover(paths), mode, model=model), jobs, executor)


def _results(prepared: list[tuple[Path, Program, Expect]], jobs: int | None, executor: Executor | None) -> Iterator[CheckResult]:
    own = executor is None
    if own:
        executor = make_executor(jobs or min(len(prepared), os.cpu_count() or 1))
    try:
        futures = [executor.submit(judge, str(path), program, expect) for path, program, expect in prepared]
        for future in futures:
            yield future.result()
    finally:
        if own:
            executor.shutdown(cancel_futures=True)


def compare(
    paths: list[str | Path],
    modes: tuple[str, ...] = ("raw", "tuned", "extension"),
    jobs: int | None = None,
    model: str | None = None,
) -> dict[str, dict[str, CheckResult]]:
    """Check every scenario in every mode, all in one run on one executor.

    Returns:
        file -> mode -> :class:`CheckResult`, files in order.

    Raises:
        ScenarioErrors: a file is missing or invalid (before anything runs).
    """
    prepared = prepare(discover(paths), modes=modes, model=model)
    table: dict[str, dict[str, CheckResult]] = {}
    for r in _results(prepared, jobs, None):
        table.setdefault(r.file, {})[r.mode] = r
    return table


def judge(file: str, program: Program, expect: Expect) -> CheckResult:
    """Run one program and check its expectations (the unit of work sent to workers)."""
    outcome = run_program(program)
    return CheckResult(
        file=file,
        scenario=program.name,
        mode=program.engine.mode,
        model=str(program.stability.get("model", "report")),
        verdicts=tuple(evaluate(expect, outcome, program.collapse_threshold)),
        collapse_level=outcome.collapse.level if outcome.collapse else None,
        levels_placed=outcome.levels_placed,
        simulated_time=outcome.simulated_time,
        wall_time=outcome.wall_time,
        drift=outcome.drift,
        steps_per_brick=outcome.steps / max(outcome.bricks_placed, 1),
    )


def make_executor(jobs: int) -> Executor:
    """In-process for ``jobs <= 1``, else a pool of ``jobs`` spawned processes."""
    if jobs <= 1:
        return SerialExecutor()
    return ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn"))


class SerialExecutor(Executor):
    """Runs each task in the calling process when it is submitted."""

    def submit(self, fn: Callable, /, *args, **kwargs) -> Future:
        future: Future = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # handed to the caller through the future
            future.set_exception(exc)
        return future

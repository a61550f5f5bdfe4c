"""Run a sweep: every sample of every grid cell, in batches, on any executor.

A sweep's unit of work is a *batch*: several samples of one cell, drawn, compiled and run in
one task (a worker process costs more to start than a small scene to run). Batches go to
stackdsl's own process pool (``-j N``, :mod:`stackdsl.batch.pool`) or to any
``concurrent.futures.Executor``, such as a Dask cluster's (:func:`dask_executor`). Sample ``k``
of cell ``c`` is drawn from its own seed (:mod:`stackdsl.lang.sampling`) and pybullet repeats a run
bitwise, so every per-sample result but the wall time is the same whatever runs it, in
whatever order.

Source: stackdsl's own.
"""

from __future__ import annotations

import logging
import math
import shutil
import socket
import tempfile
import time
from collections.abc import Callable, Generator, Iterable, Iterator, Sequence
from concurrent.futures import Executor
from contextlib import contextmanager
from dataclasses import asdict, dataclass, replace
from typing import TYPE_CHECKING, Any, NamedTuple

from ..compile.compiler import compile_scenario
from ..lang.errors import ScenarioError, format_path, warnings_as_lines
from ..lang.sampling import Template
from ..lang.units import split_quantity
from ..runtime.run import run_program
from ..util.extras import installed, missing
from .address import parse_address
from .pool import WorkerLost, fan_out, on_executor

if TYPE_CHECKING:
    from ..lang.distributions import Distribution
    from ..lang.schema import Scenario

#: Samples a batch holds at most; a sweep is cut into about this many batches a worker, so that
#: the workers finish together.
MAX_BATCH = 32
BATCHES_A_WORKER = 6
#: Batches handed to an executor ahead of its results, a worker thread: enough to keep it busy,
#: few enough that a sweep's batches are made as they are needed.
WINDOW = 4


@dataclass(frozen=True)
class SampleResult:
    """One sample run.

    Attributes:
        cell, sample: which one; seed: the seed its run drew its placement error from.
        parameters: what it drew and took from the grid (column -> number in SI, angles in
            degrees; the column named with its unit: ``timing.placement_error [m]``).
        collapse_level: the level at which it collapsed, or None when it stood.
        levels_placed: levels built; wall_time, simulated_time: seconds.
        oracle_level: with the oracle, rigid-block equilibrium's collapse level on the sample's
            placed poses (None: stands); oracle: ``"ok"``, ``"off"`` or why it gave no answer.
        stopped: why the run stopped early (its timeout), else ``""``.
        error: an internal error of this sample's run, one line, else ``""``.
        bad_input: a sample the language refuses (a drawn value out of its field's range), one
            message at file:line:col, else ``""``.
        draws: how many draws the sample took to meet the file's ``require:`` (1 without).
        levels: the levels of the sample's tower when built in full (a grid or a distribution
            may set them), 0 without a tower or for a bad input.
        margin: metres, the run's signed margin (:attr:`stackdsl.Outcome.margin`: positive it
            stands, negative it collapsed), None when it has none.
        held: whether one run's expectations held, when a search judged them
            (:func:`stackdsl.batch.search.run_judged`), else None.
        still_margin: with ``held``, the signed distance of the run's largest tilt and slip to the
            expectation ``still:``'s bounds, a share of each bound
            (:meth:`stackdsl.lang.expectations.Still.margin`), when the file expects it; else None.
    """

    cell: int
    sample: int
    seed: int
    parameters: dict[str, Any]
    collapse_level: int | None
    levels_placed: int
    wall_time: float
    simulated_time: float
    oracle_level: int | None = None
    oracle: str = "off"
    stopped: str = ""
    error: str = ""
    bad_input: str = ""
    draws: int = 1
    levels: int = 0
    margin: float | None = None
    held: bool | None = None
    still_margin: float | None = None

    def row(self) -> dict[str, Any]:
        """Plain data for CSV and JSON Lines (``parameters`` spread into their own fields)."""
        data = asdict(self)
        parameters = data.pop("parameters")
        return {**data, **parameters}


#: How a sample the sweep's budget (:class:`Budget`) ran out before starts its ``stopped``.
BUDGET_SPENT = "timeout: the sweep's budget ran out"
#: Why a sample of a sweep another of whose samples was refused as bad input was not run (:meth:`Budget.refuse`).
NOT_RUN_REFUSED = "not run: another sample of the sweep was refused as bad input"


class Budget:
    """Wall seconds a whole sweep may take (``check --timeout``: one budget for a file, not for
    each of its runs), shared by all its batches: the clock starts when the first batch is handed
    out (pickled for a worker, or run in this process) and every batch reads it as a deadline in
    wall-clock time (``time.time()``; the workers run on this machine, or on a Dask cluster's
    whose clocks agree to far better than a run's length). A sample that starts after it is
    not run (:data:`BUDGET_SPENT`); one that starts before runs with what is left as its timeout.
    Source: stackdsl's own."""

    def __init__(self, seconds: float, started: float | None = None) -> None:
        self.seconds, self.started = seconds, started
        self.refused = False  # a sample was refused as bad input: the sweep is refused whole (:meth:`refuse`)

    def left(self) -> float:
        """Seconds left, starting the clock if it has not started; none once :meth:`refuse` is called."""
        if self.started is None:
            self.started = time.time()
        return 0.0 if self.refused else self.seconds - (time.time() - self.started)

    def refuse(self) -> None:
        """A sample was refused as bad input, so the whole sweep is: the samples of its batches
        in this process that have not started are not run (a worker's copy runs its batch on;
        ``check`` ran a sweep of 150 samples for 15.9 s to refuse it at sample 7, where ``sweep``
        stops at once)."""
        self.refused = True

    def __reduce__(self) -> tuple[Any, ...]:
        if self.started is None:  # handed to a worker: the clock starts now, for every batch after
            self.started = time.time()
        return (Budget, (self.seconds, self.started))

    def __repr__(self) -> str:
        return f"Budget({self.seconds!r}, {self.started!r})"


@dataclass(frozen=True)
class SweepOptions:
    """How each sample runs: ``mode``, ``model`` and ``backend`` override the file's; ``oracle``
    also asks rigid-block equilibrium; ``timeout``: wall seconds a run may take (None: no limit);
    ``budget``: the whole sweep's (:class:`Budget`; None: none beyond each run's ``timeout``)."""

    mode: str | None = None
    model: str | None = None
    oracle: bool = False
    timeout: float | None = 100.0
    backend: str | None = None
    budget: Budget | None = None


@warnings_as_lines()  # in a worker too: a sample's warnings as the command shows them
def run_batch(template: Template, cell: int, samples: Sequence[int], options: SweepOptions) -> list[SampleResult]:
    """Draw, compile and run ``samples`` of ``cell`` (the unit of work a worker is given).

    A sample the language refuses, or whose run fails, is that sample's result (``bad_input``,
    ``error``), not an exception: the others still run. Ctrl-C still interrupts. With a
    ``budget``, a sample runs with at most what is left of it as its timeout, and a sample the
    budget ran out before is not run: its result is stopped (:data:`BUDGET_SPENT`).
    """
    out = []
    for k in samples:
        if options.budget is None:
            out.append(_one(template, cell, k, options))
            continue
        left = options.budget.left()
        if left <= 0:
            why = NOT_RUN_REFUSED if options.budget.refused else BUDGET_SPENT
            out.append(SampleResult(cell, k, 0, {}, None, 0, 0.0, 0.0, stopped=why))
            continue
        timeout = left if options.timeout is None else min(options.timeout, left)
        out.append(_one(template, cell, k, replace(options, timeout=timeout)))
        if out[-1].bad_input:
            options.budget.refuse()
    return out


def _one(template: Template, cell: int, k: int, options: SweepOptions) -> SampleResult:
    parameters: dict[str, Any] = {}
    seed = 0
    try:
        parameters = template.parameters(cell, k)
        scenario = template.scenario(cell, k)
        seed = scenario.seed
        program = compile_scenario(scenario, options.mode, options.model, options.backend, draw_time=options.timeout)
        if program.draws > 1:  # redrawn to meet 'require:': what the run drew
            parameters = template.parameters(cell, k, program.draws - 1)
            seed = template.scenario(cell, k, attempt=program.draws - 1).seed
    except ScenarioError as exc:
        return SampleResult(cell, k, seed, parameters, None, 0, 0.0, 0.0, bad_input=str(which_sample(exc, template, cell, k)))
    try:
        outcome = run_program(program, timeout=options.timeout)
        oracle_level, oracle = _oracle(program) if options.oracle else (None, "off")
        return SampleResult(
            cell,
            k,
            seed,
            parameters,
            outcome.collapse.level if outcome.collapse else None,
            outcome.levels_placed,
            outcome.wall_time,
            outcome.simulated_time,
            oracle_level,
            oracle,
            stopped=outcome.stopped or "",
            draws=program.draws,
            levels=scenario.structure.tower.levels if scenario.structure.tower else 0,
            margin=outcome.margin,
        )
    except Exception as exc:  # MemoryError included: this sample's internal error
        message = (str(exc).splitlines() or [""])[0]
        detail = f"{type(exc).__name__}: {message}"
        return SampleResult(cell, k, seed, parameters, None, 0, 0.0, 0.0, error=f"internal error: {detail}")


def compile_cells(
    template: Template,
    mode: str | None = None,
    model: str | None = None,
    backend: str | None = None,
    cells: Iterable[int] = (0,),
    draw_time: float | None = None,
) -> dict[int, int]:
    """Compile sample 0 of each of ``cells``, before any sample runs: what the compiler refuses in
    one is refused in the file as a whole, once, as ``check`` refuses a file (a ``require:`` that
    none of a sample's :data:`stackdsl.compile.require.MAX_DRAWS` draws meets is hopeless for
    every sample: they draw from the same distributions). A refusal at a field a grid value
    filled in is placed at that value (:meth:`stackdsl.lang.sampling.Template.scenario`).
    ``draw_time``: as :func:`stackdsl.compile_scenario`'s (a run's ``--timeout``).

    Returns:
        Each cell's highest level placed in its sample 0 (for :func:`compile_bounds`' ``tops``).

    Raises:
        ScenarioError: the first cell's refusal, saying which sample and cell.
    """
    tops = {}
    for c in cells:
        try:
            tops[c] = compile_scenario(template.scenario(c, 0), mode, model, backend, draw_time=draw_time).levels
        except ScenarioError as exc:
            raise which_sample(exc, template, c, 0) from None
    return tops


#: Compiles :func:`compile_bounds` makes at most, over all cells (the first cells first).
MAX_BOUND_COMPILES = 1000


def compile_bounds(
    template: Template,
    mode: str | None = None,
    model: str | None = None,
    backend: str | None = None,
    cells: Iterable[int] = (0,),
    draw_time: float | None = None,
    tops: dict[int, int] | None = None,
) -> None:
    """Compile, in each of ``cells``, a sample with each distribution at each value that bounds
    what it draws (every choice, a uniform's ends, a normal's clip: :meth:`Template.bounds`),
    the other distributions drawing what they draw in sample 0, before any sample runs: a value
    a distribution can draw that makes the scene refused (a ``choice`` of a domino count that
    leaves out the domino a push names) is bad input, said at the distribution, with the field
    and the words of the refusal, rather than when a sample happens to draw it mid-sweep. A
    bound that fails the file's ``require:`` is never run as drawn, and is passed over. At most
    :data:`MAX_BOUND_COMPILES` compiles (a huge grid: its first cells). Call it after
    :func:`compile_cells`, which says what every sample 0 is refused for.

    ``tops``: each cell's highest level placed in sample 0 (:func:`compile_cells`' return); given,
    a cell's collapse statistic beyond the highest level any of its samples can build is refused
    too (:func:`stackdsl.compile.precheck.unreachable_statistics`), once every bound of the cell
    is compiled.

    Raises:
        ScenarioError: at the distribution that can draw the value; at a statistic no sample can measure.
    """
    bounds = template.bounds()
    sampled = tops is not None and template.random
    left = MAX_BOUND_COMPILES
    parsed: dict[tuple[str, ...], list[Any]] = {}  # the file's require:, parsed once
    for c in cells:
        built: dict[str, list[int]] = {}  # distribution (its field) -> the top of each pinned sample
        whole = True  # every bound of the cell compiled
        for d, value in bounds:
            if left <= 0:
                return
            left -= 1
            scenario = template.pinned(c, d, value)
            if scenario.require and not meets_require(scenario, parsed):
                whole = False
                continue
            try:
                built.setdefault(format_path(d.path), []).append(
                    compile_scenario(scenario, mode, model, backend, draw_time=draw_time).levels
                )
            except ScenarioError as exc:
                raise _bound_refused(template, c, d, value, exc) from None
        if tops is not None and c in tops:  # a bound passed over (require:): the levels it builds are not known
            _reachable(template, c, tops[c] if whole else None, built, sampled)


#: Compiles :func:`compile_placement_errors` makes at most, over all cells (the first first).
MAX_PLACEMENT_COMPILES = 2000


def compile_placement_errors(
    template: Template,
    mode: str | None = None,
    model: str | None = None,
    backend: str | None = None,
    cells: Iterable[int] = (0,),
    draw_time: float | None = None,
) -> None:
    """Compile every sample of each of ``cells`` whose scene has a placement error, before any
    sample runs: each sample draws its own offsets from its own seed, and one that moves a brick
    into another (a card house's leaning bricks, 2 mm of error) is bad input, said at the field
    that gives the error with the seed that does it, rather than after the samples before it have
    run (a sweep of 600 runs was refused 20 s in). Sample 0 of each cell is
    :func:`compile_cells`'. At most :data:`MAX_PLACEMENT_COMPILES` compiles (600 of a small
    card house take about a second); a file with ``require:`` runs later draws where a sample
    fails it, so its samples are checked as they run.

    Raises:
        ScenarioError: the first sample refused, as :func:`which_sample` says it.
    """
    if "require" in template.data or not template.random:
        return
    left = MAX_PLACEMENT_COMPILES
    for c in cells:
        if template.scenario(c, 0).timing.placement_error <= 0:
            continue
        for k in range(1, samples_run(template)):
            if left <= 0:
                return
            left -= 1
            try:
                compile_scenario(template.scenario(c, k), mode, model, backend, draw_time=draw_time)
            except ScenarioError as exc:
                raise which_sample(exc, template, c, k) from None


def meets_require(scenario: Scenario, parsed: dict[tuple[str, ...], list[Any]]) -> bool:
    """Whether ``scenario`` meets its file's ``require:`` conditions (``parsed``: each list of
    conditions parsed once, by their texts, filled as they are met)."""
    from ..compile.require import quantities
    from ..lang.expressions import parse

    texts = tuple(scenario.require)
    conditions = parsed.get(texts) or parsed.setdefault(texts, [parse(text) for text in texts])
    values = quantities(scenario, {name for condition in conditions for name in condition.names})
    return all(condition.holds(values) for condition in conditions)


def _bound_refused(template: Template, c: int, d: Distribution, value: Any, exc: ScenarioError) -> ScenarioError:
    """The error of a ``value`` distribution ``d`` can draw that makes the scene of cell ``c``
    refused (``exc``): said at the distribution, with the refused field and its words."""
    drawn = f"{'a choice' if d.kind == 'choice' else 'a value'} this distribution can draw, {value!r}"
    cell = f" in grid cell {c} ({template.label(c)})" if template.grid else ""
    where = "" if exc.field == format_path(d.path) else f" at {exc.field}" + (f" (line {exc.line})" if exc.line else "")
    return template.source.error(d.path, f"{drawn}, makes the scene refused{cell}{where}: {exc.message}")


def _reachable(template: Template, c: int, top: int | None, built: dict[str, list[int]], sampled: bool) -> None:
    """Refuse cell ``c``'s statistical expectations that no samples can pass
    (:func:`stackdsl.compile.precheck.unreachable_statistics`). The highest level its samples
    build is sample 0's ``top``, or, when one distribution changes what is built, the highest of
    its bounds' (``built``: each distribution's pinned samples' tops); when two or more do, their
    draws may add up beyond any one's bound, and ``top`` None is a bound passed over: the levels
    are then not judged. ``sampled``: the samples draw (:attr:`Template.random`), so P(stands) is
    judged by a confidence interval."""
    from ..compile.precheck import unreachable_statistics

    varying = [levels for levels in built.values() if any(t != top for t in levels)]
    highest = None if top is None or len(varying) > 1 else max([top, *(varying[0] if varying else [])])
    scenario = template.scenario(c, 0)
    label = f"{c} ({template.label(c)})" if template.grid else ""
    unreachable_statistics(scenario, highest, template.values(c), label, sampled)


def which_sample(exc: ScenarioError, template: Template, cell: int, k: int) -> ScenarioError:
    """``exc`` (a sample's refusal) saying which sample and grid cell, unless it says so already,
    and, when it is at a field no distribution draws, what the sample drew (:func:`drew`)."""
    if exc.field.startswith("sweep.grid"):  # at the grid value, which says itself what it is
        return exc
    if not exc.message.startswith("sample "):  # the compiler's checks: say which sample
        where = f" of grid cell {cell} ({template.label(cell)})"
        exc.message = f"sample {k}" + (where if template.grid else "") + f": {exc.message}" + drew(exc, template, cell, k)
    return exc


def drew(exc: ScenarioError, template: Template, cell: int, k: int, shown: int = 4) -> str:
    """What cell ``cell``'s sample ``k`` drew, said after a refusal ``exc`` at a field none of its
    distributions draws (an action naming a domino that a drawn count leaves out): the drawn value
    that made it is one of these. ``""`` when it is at a distribution, when the sample drew
    nothing once a sample, or when the file has ``require:`` (the sample run may be a later draw)."""
    drawn = template.drawn(cell, k)
    at_one = any(exc.field == format_path(d.path) for d in template.distributions)
    if not drawn or at_one or "require" in template.data:
        return ""
    said = [f"{field} = {_short(value)}" for field, value in drawn.items()]
    more = f" and {len(said) - shown} more" if len(said) > shown else ""
    return f" (this sample drew {', '.join(said[:shown])}{more})"


def _short(value: Any) -> str:
    """A drawn value as written, its number to 4 significant digits: ``'63.16 mm'``, ``'3'``.

    >>> _short("63.163371523854984 mm"), _short(3), _short(0.12345678)
    ('63.16 mm', '3', '0.1235')
    """
    try:
        number, unit = split_quantity(value)
    except ValueError:
        return str(value)
    return f"{number:.4g}" + (f" {unit}" if unit else "")


def _oracle(program: Any) -> tuple[int | None, str]:
    from ..verdicts.oracle import equilibrium_collapse

    try:
        return equilibrium_collapse(program).collapse_level, "ok"
    except ValueError as exc:  # bricks that do not lie flat
        return None, str(exc)


def batch_size(template: Template, workers: int) -> int:
    """Samples a batch of ``template`` holds: about :data:`BATCHES_A_WORKER` batches a worker,
    at most :data:`MAX_BATCH` samples each."""
    total = template.cells * template.samples
    return max(1, min(MAX_BATCH, math.ceil(total / (max(1, workers) * BATCHES_A_WORKER))))


def batches(template: Template, workers: int) -> Iterator[tuple[int, range]]:
    """(cell, samples) batches covering the sweep, generated as they are taken, each of
    :func:`batch_size` samples at most; a batch never mixes cells. A sweep that draws nothing
    runs sample 0 of each cell alone (:func:`samples_run`): its other samples are the same run."""
    size, samples = batch_size(template, workers), samples_run(template)
    for c in range(template.cells):
        for start in range(0, samples, size):
            yield c, range(start, min(start + size, samples))


def samples_run(template: Template) -> int:
    """How many samples of each cell run: ``template.samples``, or 1 when nothing is drawn
    (``Template.random``), every sample being the same run (an exact sweep of 100000 samples ran
    them all, 15 minutes of one result)."""
    return template.samples if template.random else 1


def run_sweep(
    template: Template,
    options: SweepOptions = SweepOptions(),
    *,
    jobs: int = 1,
    executor: Executor | None = None,
    workers: int | None = None,
) -> Generator[list[SampleResult], None, None]:
    """Run every sample of ``template``; yields each batch's results as it finishes (in any
    order: sort by (cell, sample) for a table).

    Args:
        options: how each sample runs.
        jobs: processes of stackdsl's pool, this one included (1: all here, in order).
        executor: run the batches on it instead (a Dask client's executor, say).
        workers: how many the executor runs at once (for cutting the batches); default ``jobs``.

    Closing the generator cancels the batches not started and stops the pool's workers.
    """
    tasks = ((template, cell, samples, options) for cell, samples in batches(template, workers or jobs))
    if executor is not None:
        return on_executor(executor, run_batch, tasks, window=WINDOW * (workers or jobs))
    size = batch_size(template, workers or jobs)
    limit = None if options.timeout is None else (options.timeout + 10.0) * size
    cost = _estimate(template, options) * size
    return fan_out(run_batch, tasks, cost, jobs, limit=limit, lost=_lost, here=False)


def _estimate(template: Template, options: SweepOptions) -> float:
    """Wall seconds a sample takes, by the compiler's estimate for sample 0 of cell 0."""
    try:
        scenario = template.scenario(0, 0)
        return compile_scenario(scenario, options.mode, options.model, options.backend, draw_time=options.timeout).wall_estimate
    except ScenarioError:
        return 0.1


def _lost(task: tuple[Any, ...], error: WorkerLost) -> list[SampleResult]:
    """The results of a batch whose worker died or was stopped: each sample's internal error."""
    template, cell, samples, _ = task
    return [
        SampleResult(cell, k, 0, template.parameters(cell, k), None, 0, 0.0, 0.0, error=f"internal error: {error}")
        for k in samples
    ]


class ClusterLost(RuntimeError):
    """The Dask scheduler went away in the middle of a sweep: the client's connection to it
    closed, and the batches it held were cancelled with it. The message is one line."""

    def __init__(self, address: str) -> None:
        self.address = address
        super().__init__(f"the Dask scheduler at {address} went away")


class DaskCluster(NamedTuple):
    """What :func:`dask_executor` gives: the cluster's executor, its worker threads when it
    was reached (for cutting a sweep into batches), and ``connected()``, the workers connected
    to the scheduler now, by the client's latest word from it (never waits; None: not known)."""

    executor: Executor
    threads: int
    connected: Callable[[], int | None]


@contextmanager
def dask_executor(address: str, on_lost: Callable[[list[str]], None] | None = None) -> Iterator[DaskCluster]:
    """A Dask cluster's executor and how many worker threads it has: ``address`` is a
    scheduler's (``tcp://host:8786``, through ``distributed.Client``) or ``local:N``, which starts
    a ``LocalCluster`` of N single-threaded worker processes here (closed on exit), with
    :data:`LOCAL_CLUSTER_CONFIG` and without Dask's ``MALLOC_TRIM_THRESHOLD_``
    (:func:`_worker_environment`; start a cluster of your own's workers likewise).

    A worker that dies mid-sweep loses nothing: the scheduler runs the batches it held again on
    the others (a batch is a pure function of its samples, so its results are the same).
    ``on_lost`` is called at the end with the addresses of the workers that left meanwhile.
    While the client is open, distributed's own log records below CRITICAL are not printed
    (its reconnection attempts log whole tracebacks): what matters is said by the caller.

    Raises:
        ValueError: a malformed address (:func:`stackdsl.batch.address.parse_address`).
        OSError: no scheduler answers there, or what answers is not one.
        ScenarioError: Dask's distributed is not installed (the ``dask`` extra).
        ClusterLost: raised out of the ``with`` body when the scheduler went away meanwhile
            (whatever the body raised, a cancelled future most often).
    """
    if not installed("dask"):
        raise ScenarioError(missing("dask", "a sweep on a Dask cluster"), file="--dask")
    address = parse_address(address)
    import dask
    from distributed import Client, LocalCluster

    cluster, scratch = None, None
    with _quiet_distributed():
        try:
            if address.startswith("local:"):
                # the workers' scratch space in a folder of this run's, removed at the end
                scratch = tempfile.mkdtemp(prefix="stackdsl-dask-")
                settings = LOCAL_CLUSTER_CONFIG | {
                    "distributed.nanny.pre-spawn-environ": _worker_environment(),
                    "temporary-directory": scratch,  # nothing of Dask's is left in $TMPDIR
                }
                # our own workers' restarts and shutdown are not the user's news: errors only
                logging.getLogger("distributed").setLevel(logging.ERROR)
                with dask.config.set(settings):
                    cluster = LocalCluster(
                        n_workers=int(address.removeprefix("local:")),
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=":0",  # its HTTP server on a free port: no warning when 8787 is taken
                        local_directory=scratch,
                    )
                client = Client(cluster)
            else:
                client = _connect(Client, address)
            try:
                workers = client.nthreads()
                threads = sum(workers.values()) or 1
                try:
                    yield DaskCluster(client.get_executor(pure=False), threads, lambda: _connected(client))
                except Exception:
                    if client.status != "running":  # the connection closed: its futures were cancelled
                        raise ClusterLost(address) from None
                    raise
                if on_lost is not None:
                    lost = sorted(set(workers) - set(client.nthreads()))
                    if lost:
                        on_lost(lost)
            finally:
                client.close()
        finally:
            if cluster is not None:
                cluster.close()
            if scratch is not None:
                shutil.rmtree(scratch, ignore_errors=True)


def _connected(client: Any) -> int | None:
    """The workers connected to ``client``'s scheduler, from the identity the client asks it
    for every ``distributed.client.scheduler-info-interval`` (2 s; asking here could wait on
    a scheduler that is gone); None when the client has none or is not connected."""
    if client.status != "running":
        return None
    count = getattr(client, "_scheduler_identity", {}).get("n_workers")
    return count if isinstance(count, int) else None


class _BelowCritical(logging.Filter):
    """Drops distributed's log records below CRITICAL."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not (record.name.startswith("distributed") and record.levelno < logging.CRITICAL)


@contextmanager
def _quiet_distributed() -> Iterator[None]:
    """No record of distributed's below CRITICAL is printed meanwhile: its loggers carry levels
    of their own (``distributed.client``: warning), so the filter is on the handlers, the one
    distributed adds to its ``distributed`` logger and the root's."""
    import distributed  # noqa: F401  (its import sets up its logging handler)

    quiet = _BelowCritical()
    handlers = [*logging.getLogger("distributed").handlers, *logging.getLogger().handlers, logging.lastResort]
    for handler in handlers:
        if handler is not None:
            handler.addFilter(quiet)
    try:
        yield
    finally:
        for handler in handlers:
            if handler is not None:
                handler.removeFilter(quiet)


def _connect(client: Any, address: str) -> Any:
    """A ``distributed.Client`` of the scheduler at ``address``, or OSError saying that there is
    none (something else answering there is not one: Dask may read its bytes as a message
    size and try to allocate exabytes)."""
    _probe(address)
    try:
        return client(address, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError) as exc:
        raise OSError(f"no Dask scheduler answers at {address}: {exc}") from None
    except Exception as exc:  # MemoryError, a protocol error: bytes that are not Dask's
        raise OSError(f"not a Dask scheduler at {address} ({type(exc).__name__})") from None


#: Seconds to wait for a scheduler to answer.
CONNECT_TIMEOUT = 10.0


def _probe(address: str) -> None:
    """Raise OSError unless what listens at a ``tcp://`` address speaks first, as a Dask
    scheduler does (its handshake, at once on connection): a server that waits for the
    client to speak (HTTP, say) would leave ``distributed.Client`` waiting for ever."""
    if not address.startswith("tcp://"):
        return
    host, _, port = address.removeprefix("tcp://").rpartition(":")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT) as probe:
            probe.settimeout(CONNECT_TIMEOUT)
            first = probe.recv(8)
    except TimeoutError:
        raise OSError(f"not a Dask scheduler at {address}: it sent nothing in {CONNECT_TIMEOUT:g} s") from None
    except OSError as exc:
        raise OSError(f"no Dask scheduler answers at {address}: {exc.strerror or exc}") from None
    if not first:
        raise OSError(f"not a Dask scheduler at {address}: it closed the connection")


#: Dask settings of the local clusters stackdsl starts: no sampling profiler in the workers
#: (it takes the interpreter lock from the runs every 10 ms).
LOCAL_CLUSTER_CONFIG: dict[str, Any] = {"distributed.worker.profile.enabled": False}


def _worker_environment() -> dict[str, Any]:
    """Dask's environment for new worker processes without ``MALLOC_TRIM_THRESHOLD_``: Dask's
    nanny sets it to 64 KiB to hand memory back sooner, and a pybullet client, made and freed
    once a run, then costs a run 50-70% more (measured: 83-100 ms a sample against 56-65 ms)."""
    import dask

    environment = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}))
    environment.pop("MALLOC_TRIM_THRESHOLD_", None)
    # read when a worker imports distributed: a worker's own errors are not the user's news either
    # (a sweep stopped by SIGTERM on a loaded machine printed a worker's "Failed to communicate
    # with scheduler during heartbeat"); a worker that leaves is reported by the sweep itself
    environment["DASK_LOGGING__DISTRIBUTED"] = "critical"
    return environment


def collect(
    results: Generator[list[SampleResult], None, None],
    each: Callable[[list[SampleResult]], None] = lambda b: None,
    *,
    stop_at_bad_input: bool = False,
) -> list[SampleResult]:
    """Every result of :func:`run_sweep`, sorted by (cell, sample); ``each`` sees each batch as it
    comes. With ``stop_at_bad_input``, the batches not yet done are cancelled once a sample is
    refused as bad input (the sweep is refused as a whole: nothing after it is of use)."""
    out: list[SampleResult] = []
    try:
        for batch in results:
            out.extend(batch)
            each(batch)
            if stop_at_bad_input and any(r.bad_input for r in batch):
                break
    finally:
        results.close()
    return sorted(out, key=lambda r: (r.cell, r.sample))

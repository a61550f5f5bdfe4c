"""Check many scenario files: load all, compile all, then run them.

Nothing runs unless every file loads and compiles: a bad file stops the whole check
before any simulation. An internal error (a bug) met while one file is read or compiled is
that file's result instead (:func:`prepare`'s ``broken``), and the other files run. Runs are shared between this process and spawned worker processes
(:mod:`stackdsl.batch.pool`; each run creates its own pybullet client, clients do not survive
pickling), or farmed out on a caller's ``concurrent.futures.Executor``.

Every run has a wall-clock limit (``timeout``, default :data:`stackdsl.batch.judge.TIMEOUT`); workers also have
a memory limit (:data:`stackdsl.batch.guard.MEMORY_LIMIT`). A run or a sweep's batch that raises,
runs out of memory or whose worker dies, and a sweep whose samples cannot be judged, is that
scenario's internal error (``CheckResult.error``); the other scenarios still run.

Source: stackdsl's own.
"""

from __future__ import annotations

import traceback
from collections.abc import Callable, Generator, Iterable, Sequence
from concurrent.futures import Executor
from dataclasses import replace
from itertools import chain
from numbers import Integral
from pathlib import Path
from typing import Any, NamedTuple

from ..compile.compiler import BACKEND_DEFAULTS, compile_scenario
from ..compile.program import Program
from ..draw.artefacts import DRAW_ESTIMATE, DRAW_LIMIT
from ..lang.errors import ScenarioError, ScenarioErrors
from ..lang.expectations import Expect
from ..lang.loader import load_scenario
from ..lang.sampling import Template
from ..lang.scenario_file import file_problem
from ..lang.schema import Scenario
from ..lang.schema_marks import XFail
from ..runtime.run import check_timeout
from ..verdicts.check_result import CheckResult
from ..verdicts.expect import expected_texts
from .address import free_cores
from .check_sweep import run_unit, sweep_result, sweep_tasks
from .judge import KILL_AFTER, TIMEOUT, failed, internal, lost
from .keywords import KeywordError, parse_keywords
from .pool import fan_out, on_executor
from .sweep import SampleResult, compile_bounds, compile_cells, compile_placement_errors, samples_run, which_sample


class Prepared(NamedTuple):
    """A scenario file ready to run: its compiled ``program`` (a sweep's: sample 0 of cell 0),
    ``expect``, the sweep's ``template`` (None: one run), and the file's ``xfail`` mark when it
    holds on this run (None: none does)."""

    path: Path
    program: Program
    expect: Expect
    template: Template | None = None
    xfail: XFail | None = None


def discover(paths: list[str | Path]) -> list[Path]:
    """Scenario files named by ``paths``: files as given, folders searched for ``*.yaml`` and
    ``*.yml``; a file named twice (``t.yaml ./t.yaml``, a folder and a file in it, a link) is
    listed once, where it first comes.

    Raises:
        ScenarioErrors: a path is empty, does not exist, is not a regular file (a device, a
            FIFO, a broken link, also one found in a folder) or is over the loader's size cap
            (decided from ``os.stat``, nothing is opened), or a folder holds no scenario file.
    """
    files, errors = [], []
    for raw in paths:
        path = Path(raw)
        if str(raw) == "":  # Path("") is ".": an unset $DIR in a script ran the folder it was in
            errors.append(ScenarioError("an empty path: give a scenario file or a folder", file=repr(str(raw))))
            continue
        if path.is_dir():
            named = sorted(p for p in path.rglob("*") if p.suffix in SCENARIO_SUFFIXES and not p.is_dir())
            found = [p for p in named if p.is_file()]
            errors += [ScenarioError(file_problem(p) or "not a regular file", file=str(p)) for p in named if not p.is_file()]
            if not named:
                errors.append(ScenarioError("no scenario files (*.yaml, *.yml) in this folder", file=str(path)))
            files += found
        elif (problem := file_problem(path)) is None:
            files.append(path)
        else:
            errors.append(ScenarioError(problem, file=str(path)))
    if errors:
        raise ScenarioErrors(errors)
    return _once(files)


#: The suffixes of the files a folder is searched for.
SCENARIO_SUFFIXES = (".yaml", ".yml")


def _once(files: list[Path]) -> list[Path]:
    """``files`` with each file once (the same device and inode: by any name), where it first comes."""
    seen: set[tuple[int, int]] = set()
    kept = []
    for path in files:
        try:
            info = path.stat()
        except OSError:  # gone since it was found: loading it will say so
            kept.append(path)
            continue
        if (info.st_dev, info.st_ino) not in seen:
            seen.add((info.st_dev, info.st_ino))
            kept.append(path)
    return kept


def prepare(
    files: list[Path],
    mode: str | None = None,
    modes: tuple[str, ...] = (),
    model: str | None = None,
    backends: tuple[str | None, ...] = (None,),
    refused: list[CheckResult] | None = None,
    seed: int | None = None,
    timeout: float | None = None,
    broken: list[CheckResult] | None = None,
    skipped: list[CheckResult] | None = None,
) -> list[Prepared]:
    """Load and compile every file (on each of ``backends``, in each of ``modes`` when
    given, with the stability ``model`` when given); nothing is simulated. A run the file's
    ``skip`` mark holds on (:mod:`stackdsl.lang.schema_marks`: on the backend, mode and model it
    would run with) is not compiled: it is a result in ``skipped`` (left out when None); a run
    its ``xfail`` mark holds on is prepared with that mark.

    Args:
        refused: given (a comparison), a file that compiles as written but that a compared
            engine or mode refuses (beyond what it simulates faithfully) gets a result here
            with :attr:`CheckResult.refused`, in place of an error.
        broken: given, a file whose reading or compiling hits an internal error (a bug, not
            bad input) gets a result here for each of its runs, with :attr:`CheckResult.error`
            and the traceback, and the other files are prepared still; None: the error is raised.
        seed: replaces every file's ``seed`` when given.
        timeout: the runs' wall seconds, which a random file's draws to meet ``require:`` may
            take too (at most :data:`stackdsl.compile.require.DRAW_TIME`, the default).

    Raises:
        ScenarioErrors: one error per bad file.
    """
    prepared, errors = [], []
    bugs: list[CheckResult] = []
    for path in files:
        scenario = None
        try:
            scenario = load_scenario(path, seed)
            runs = [(m, b) for b in backends for m in modes or (mode,)]
            prepared += _prepare_file(path, scenario, runs, model, timeout, refused, skipped)
        except ScenarioError as exc:
            errors.append(exc)
        except Exception as exc:  # a bug: said with the file it was met in, still exit 3
            if broken is None:
                exc.add_note(f"while reading {path}")
                raise
            prepared = [p for p in prepared if p.path != path]  # none of this file's runs: it is one result a run
            _forget_results(path, refused, skipped)
            bugs += [_broken(path, scenario, m, model, b, exc) for b in backends for m in modes or (mode,)]
    if errors:
        raise ScenarioErrors(errors, _refused_summary(len(errors), len(files), bugs))
    if broken is not None:
        broken += bugs
    return prepared


def _forget_results(path: Path, *found: list[CheckResult] | None) -> None:
    """Drop the results of file ``path`` from each list of ``found`` (None: not kept): a file an
    internal error was met in is one result a run, its bug."""
    for results in found:
        if results is not None:
            results[:] = [r for r in results if r.file != str(path)]


def _refused_summary(errors: int, files: int, bugs: list[CheckResult]) -> str:
    """The line under the ``errors`` of bad files, among ``files`` read: that none was run when
    there are several (a folder: every file is read before any runs), and the ``bugs`` met,
    which were not run either (said, so that the bug is not lost behind the bad input)."""
    summary = ""
    if files > 1:
        summary = f"{errors} of {files} files refused; none was run (check the good ones by name to run them)"
    if bugs:
        summary += f"{'; ' if summary else ''}{_bugs(bugs)}"
    return summary


def _prepare_file(
    path: Path,
    scenario: Scenario,
    runs: list[tuple[str | None, str | None]],
    model: str | None,
    timeout: float | None,
    refused: list[CheckResult] | None,
    skipped: list[CheckResult] | None,
) -> list[Prepared]:
    """:func:`prepare` of one file, ``scenario``: each of its ``runs`` (mode, backend: None for the
    file's own) compiled, but those its ``skip`` mark holds on (results in ``skipped``) and those a
    compared engine or mode refuses (results in ``refused``, :func:`_compiled`).

    Raises:
        ScenarioError: the file is bad input.
    """
    sweep = scenario.template if scenario.sweep is not None else None
    prepared = []
    for m, backend in runs:
        run = (backend or scenario.engine.backend, m or scenario.engine.mode, model or scenario.stability.model)
        if scenario.skip is not None and scenario.skip.applies(*run):
            if skipped is not None:
                skipped.append(_skipped(path, scenario, *run))
            continue
        xfail = scenario.xfail if scenario.xfail is not None and scenario.xfail.applies(*run) else None
        program = _compiled(path, scenario, sweep, (m, model, backend), timeout, refused)
        if program is not None:
            prepared.append(Prepared(path, program, scenario.expect, sweep, xfail))
    return prepared


def _compiled(
    path: Path,
    scenario: Scenario,
    sweep: Template | None,
    run: tuple[str | None, str | None, str | None],
    timeout: float | None,
    refused: list[CheckResult] | None,
) -> Program | None:
    """The program of one ``run`` (mode, model, backend) of ``scenario``, every grid cell of a
    ``sweep`` compiled too before anything runs; None when a compared engine or mode refuses what
    the file as written takes (a result in ``refused``).

    Raises:
        ScenarioError: bad input, of the file as written (a sweep's at the sample that shows it), or
            a sweep whose runs cannot end within ``timeout`` (:func:`within_budget`).
    """
    m, model, backend = run
    try:
        try:
            program = compile_scenario(scenario, m, model, backend, draw_time=timeout)
        except ScenarioError as exc:
            raise exc if sweep is None else which_sample(exc, sweep, 0, 0) from None
        if sweep is not None:  # every grid cell, before anything of any file runs
            tops = {0: program.levels} | compile_cells(sweep, m, model, backend, range(1, sweep.cells), timeout)
            compile_bounds(sweep, m, model, backend, range(sweep.cells), timeout, tops)
            compile_placement_errors(sweep, m, model, backend, range(sweep.cells), timeout)
    except ScenarioError as exc:
        if refused is None or (m is None and backend is None):
            raise
        compile_scenario(scenario, None, model, draw_time=timeout)  # as written: a bad file is an error still
        refused.append(_refusal(path, scenario, m, model, backend, exc))
        return None
    if sweep is not None:  # a sweep past its budget is bad input in every engine and mode, not a refusal
        within_budget(sweep, program, timeout)
    return program


def run_key(p: Prepared) -> tuple[str, str, str]:
    """What names a prepared run among the results: a file runs once on each backend and mode
    (:func:`result_key` of its :class:`CheckResult`)."""
    return (str(p.path), p.program.engine.backend, p.program.engine.mode)


def result_key(r: CheckResult) -> tuple[str, str, str]:
    """The :func:`run_key` of the run ``r`` is the result of."""
    return (r.file, r.backend, r.mode)


def estimates(prepared: Sequence[Prepared]) -> dict[tuple[str, ...], float]:
    """The compiler's estimate of each prepared run's wall seconds (a sweep's runs added up,
    :func:`sweep_runs`), by its :func:`run_key`: what a progress line weighs a finished run by."""
    return {
        run_key(p): sweep_runs(p.template, p.program)[1] if p.template is not None else p.program.wall_estimate for p in prepared
    }


def sweep_runs(template: Template, program: Program) -> tuple[int, float]:
    """A sweep's runs and the wall seconds they take added up, as on one core, by the compiler's
    estimate (:attr:`stackdsl.Program.wall_estimate` of its first cell's sample 0, for each run)."""
    runs = template.cells * samples_run(template)
    return runs, runs * program.wall_estimate


def within_budget(template: Template, program: Program, timeout: float | None) -> None:
    """Refuse a sweep that cannot end within ``timeout``, the wall seconds ``check`` gives a whole
    file: its runs added up, by the compiler's estimate (:func:`sweep_runs`), past ``timeout``
    (a sweep of 100000 samples under ``--timeout 5`` queued 10 hours of runs). The estimate is
    a floor (it leaves out starting each run); a sweep it lets through still stops when its
    budget runs out (:class:`stackdsl.batch.sweep.Budget`). Source: stackdsl's own.

    Raises:
        ScenarioError: at the file's ``sweep.samples`` (or ``sweep``), with the runs, the estimate
            and the samples that fit.
    """
    if timeout is None:
        return
    runs, seconds = sweep_runs(template, program)
    if seconds <= timeout:
        return
    each = seconds / runs
    fit = max(0, int(timeout / each) // template.cells) if template.random else 0
    fits = f"at most {fit} samples fit" if fit else "not one run of each cell fits"
    path = ("sweep", "samples") if ("sweep", "samples") in template.source.values else ("sweep",)
    raise template.source.error(
        path,
        f"this sweep makes {runs} runs ({_many(template.cells, 'cell')} x {_many(samples_run(template), 'sample')}), about {seconds:.3g} s "
        f"of wall time by the compiler's estimate ({each:.2g} s a run), past --timeout {timeout:g} s, which bounds the "
        f"whole file: {fits}; give fewer samples or a longer --timeout",
    )


def _many(n: int, thing: str) -> str:
    return f"{n} {thing}{'s' * (n != 1)}"


def _broken(path: Path, scenario: Any, mode: str | None, model: str | None, backend: str | None, exc: Exception) -> CheckResult:
    """The result of a run that an internal error met while its file was read or compiled:
    nothing ran; its error is one line, its traceback the whole (``--debug``)."""
    return CheckResult(
        file=str(path),
        scenario=(scenario.name if scenario is not None else "") or path.stem,
        mode=mode or (scenario.engine.mode if scenario is not None else "?"),
        model=model or (scenario.stability.model if scenario is not None else "?"),
        verdicts=(),
        collapse_level=None,
        levels_placed=0,
        simulated_time=0.0,
        wall_time=0.0,
        backend=backend or (scenario.engine.backend if scenario is not None else "?"),
        error=internal(exc),
        traceback="".join(traceback.format_exception(exc)),
    )


def _skipped(path: Path, scenario: Any, backend: str, mode: str, model: str) -> CheckResult:
    """The result of a run the file's ``skip`` mark holds on: nothing ran; it says the reason."""
    return CheckResult(
        file=str(path),
        scenario=scenario.name or path.stem,
        mode=mode,
        model=model,
        verdicts=(),
        collapse_level=None,
        levels_placed=0,
        simulated_time=0.0,
        wall_time=0.0,
        backend=backend,
        skipped=scenario.skip.reason,
        expects=", ".join(expected_texts(scenario.expect).values()),
    )


def _bugs(results: list[CheckResult]) -> str:
    """``'1 file hit an internal error (KeyError: 'x' in a.yaml)'``."""
    files = list(dict.fromkeys(r.file for r in results))
    first = results[0]
    return (
        f"{len(files)} file{'s' if len(files) > 1 else ''} hit an internal error "
        f"({first.error.removeprefix('internal error: ')} in {first.file})"
    )


def _refusal(
    path: Path, scenario: Any, mode: str | None, model: str | None, backend: str | None, exc: ScenarioError
) -> CheckResult:
    """A comparison's cell for a scene an engine or mode refused: nothing ran."""
    return CheckResult(
        file=str(path),
        scenario=scenario.name or "scenario",
        mode=mode or scenario.engine.mode,
        model=model or scenario.stability.model,
        verdicts=(),
        collapse_level=None,
        levels_placed=0,
        simulated_time=0.0,
        wall_time=0.0,
        backend=backend or scenario.engine.backend,
        refused=exc.message,
        expects=", ".join(expected_texts(scenario.expect).values()),
    )


def check_jobs(jobs: int | None) -> None:
    """Refuse a number of runs at the same time that is not a whole number >= 1 (None: one per
    free core).

    Raises:
        TypeError: ``jobs`` is not a whole number (a float, a string, a bool).
        ValueError: ``jobs`` is below 1.
    """
    if jobs is None:
        return
    if isinstance(jobs, bool) or not isinstance(jobs, Integral):
        raise TypeError(f"jobs must be a whole number of runs at the same time (>= 1) or None, not {jobs!r}")
    if jobs < 1:
        raise ValueError(f"jobs must be at least 1, not {jobs}")


def _known(backend: str | None, mode: str | None, model: str | None) -> None:
    """Raise ValueError for an override no scenario could take, before any file is read."""
    if backend is not None and backend not in BACKEND_DEFAULTS:
        raise ValueError(f"unknown backend {backend!r}; known: {', '.join(BACKEND_DEFAULTS)}")
    modes = BACKEND_DEFAULTS[backend] if backend is not None else {m for known in BACKEND_DEFAULTS.values() for m in known}
    if mode is not None and mode not in modes:
        raise ValueError(f"unknown mode {mode!r}; known: {', '.join(sorted(modes))}")
    if model is not None and model not in ("report", "equilibrium"):
        raise ValueError(f"unknown stability model {model!r}: 'report' or 'equilibrium'")


def select(prepared: list[Prepared], pattern: str | Sequence[str] | None) -> list[Prepared]:
    """The scenarios that ``pattern`` selects, in order: a ``-k`` expression of pytest's
    (:mod:`stackdsl.batch.keywords`: words matched, ignoring case, in the file's path or the
    scenario's name, joined by ``and``, ``or``, ``not`` and parentheses), or several (``-k`` given
    more than once: a scenario any of them selects); all of them when ``pattern`` is None or
    empty.

    Raises:
        ScenarioErrors: ``pattern`` cannot be read (:class:`stackdsl.batch.keywords.KeywordError`,
            said at ``-k``), or selects none.
    """
    return select_comparison(prepared, [], pattern)[0]


def select_comparison(
    prepared: list[Prepared], results: list[CheckResult], pattern: str | Sequence[str] | None
) -> tuple[list[Prepared], list[CheckResult]]:
    """:func:`select` on a check's runs and its results known before anything runs (a comparison's
    refused cells, skipped runs, files an internal error met) alike, each by its file's path or
    its scenario's name.

    Raises:
        ScenarioErrors: ``pattern`` cannot be read, or selects neither a run nor a result.
    """
    texts = [t for t in ([pattern] if isinstance(pattern, str) else pattern or []) if t]
    if not texts:
        return prepared, results
    expressions = []
    for text in texts:
        try:
            expressions.append(parse_keywords(text))
        except KeywordError as exc:
            raise ScenarioErrors([ScenarioError(f"cannot read {text!r}: {exc}", file="-k")]) from None

    def chosen(*names: str) -> bool:
        return any(e.matches(*names) for e in expressions)

    runs = [p for p in prepared if chosen(str(p.path), p.program.name)]
    cells = [r for r in results if chosen(r.file, r.scenario)]
    if not runs and not cells:
        files = len({str(p.path) for p in prepared} | {r.file for r in results})
        shown = " or ".join(repr(t) for t in texts)
        raise ScenarioErrors([ScenarioError(f"no scenario's path or name matches {shown} ({files} files)", file="-k")])
    return runs, cells


def check(
    paths: str | Path | Sequence[str | Path],
    mode: str | None = None,
    jobs: int | None = None,
    executor: Executor | None = None,
    model: str | None = None,
    pattern: str | Sequence[str] | None = None,
    timeout: float | None = TIMEOUT,
    seed: int | None = None,
    backend: str | None = None,
) -> Generator[CheckResult, None, None]:
    """Check every scenario under ``paths``; results come as each run finishes.

    Every file is loaded and compiled before this returns (so bad input raises here,
    before anything is simulated); the runs happen as the iterator is consumed, and
    closing it early (e.g. after the first failure) cancels the runs not yet started and
    stops the workers. With one job, results come in file order.

    Args:
        paths: files or folders, or one of them.
        mode: overrides each scenario's engine mode.
        model: overrides each scenario's stability model.
        jobs: runs at the same time, this process included (default: one per free core, :func:`stackdsl.batch.address.free_cores`);
            1 runs everything here. Work estimated below a worker's start-up runs here
            whatever ``jobs`` says (see :mod:`stackdsl.batch.pool`).
        executor: run on this executor instead (e.g. a Dask client's executor).
        pattern: a ``-k`` expression of pytest's over the file paths and scenario names, or
            several (any of them), as :func:`select` reads them.
        timeout: wall seconds each file may take (None: no limit): one run, or a sweep's runs
            all together (one budget for the file, :class:`stackdsl.batch.sweep.Budget`). A sweep
            whose runs the compiler estimates past it is refused before anything runs
            (:func:`within_budget`, a ScenarioError); a run stopped by it, or a sweep whose
            budget ran out before its last samples, is a failed result whose ``stopped`` says so.
        seed: replaces every file's ``seed`` (its random draws and placement error) when given.
        backend: overrides each scenario's engine (``"pybullet"`` or ``"mujoco"``).

    A file that hits an internal error (a bug) while it is read or compiled is a result with
    its ``error``, first; the other files still run. A run the file's ``skip`` mark holds on is
    a result with its reason in ``skipped``, first, and nothing runs; one its ``xfail`` mark holds
    on has the mark's reason in ``xfail`` (its :attr:`CheckResult.verdict` is XFAIL or XPASS).

    Raises:
        ScenarioErrors: a file is missing or invalid, or ``pattern`` selects nothing
            (before anything runs).
        ValueError: ``jobs`` below 1; a negative or not-a-number ``timeout``; an unknown
            ``backend``, ``mode`` (on that backend, or on any) or ``model``.
        TypeError: ``jobs`` is not a whole number or ``timeout`` not a number.
    """
    _known(backend, mode, model)
    check_jobs(jobs)
    check_timeout(timeout)
    listed = [paths] if isinstance(paths, (str, Path)) else list(paths)  # one path, not its letters
    broken: list[CheckResult] = []
    skipped: list[CheckResult] = []
    prepared = prepare(
        discover(listed), mode, model=model, backends=(backend,), seed=seed, timeout=timeout, broken=broken, skipped=skipped
    )
    prepared, known = select_comparison(prepared, broken + skipped, pattern)
    return _after(known, run_checks(prepared, jobs, executor, timeout))


def _after(first: list[CheckResult], then: Generator[CheckResult, None, None]) -> Generator[CheckResult, None, None]:
    """``first``, then what ``then`` yields; closing this closes ``then`` (its runs are cancelled)."""
    try:
        yield from first
        yield from then
    finally:
        then.close()


def run_checks(
    prepared: list[Prepared],
    jobs: int | None = None,
    executor: Executor | None = None,
    timeout: float | None = TIMEOUT,
    folders: list[str] | None = None,
) -> Generator[CheckResult, None, None]:
    """:func:`judge` every prepared scenario, yielding results as each finishes (see
    :func:`check`); with ``folders`` (one per prepared scenario), each run is recorded and
    drawn into its folder (:func:`stackdsl.draw.artefacts.draw_run`)."""
    if folders is not None and len(folders) != len(prepared):
        raise ValueError(f"{len(folders)} folders for {len(prepared)} scenarios")
    where: list[str | None] = list(folders) if folders is not None else [None] * len(prepared)
    check_jobs(jobs)
    jobs = free_cores() if jobs is None else jobs
    tasks: list[tuple[Any, ...]] = []
    costs: list[float] = []
    pending: dict[int, int] = {}
    drawing = DRAW_ESTIMATE if folders else 0.0
    for i, (p, folder) in enumerate(zip(prepared, where)):
        if p.template is None:
            tasks.append(("run", str(p.path), p.program, p.expect, timeout, folder))
            costs.append(p.program.wall_estimate + drawing)  # the compiler's work budget, in seconds
        else:
            units = sweep_tasks(i, p.template, p.program, timeout, jobs)
            tasks += units
            costs += [p.program.wall_estimate * len(u[4]) for u in units]
            pending[i] = len(units)
    if executor is not None:
        stream = on_executor(executor, run_unit, tasks)
    else:
        # a sweep's batches share its one budget (sweep_tasks): none outlasts the timeout either
        limit = None if timeout is None else timeout + KILL_AFTER + (DRAW_LIMIT if folders else 0.0)
        stream = fan_out(run_unit, tasks, costs, jobs, limit=limit, lost=lost)
    return _gathered(stream, prepared, pending, where)


def _gathered(
    stream: Generator[Any, None, None], prepared: list[Prepared], pending: dict[int, int], where: list[str | None]
) -> Generator[CheckResult, None, None]:
    """Results as they finish: single runs at once, a sweep when its last batch is back; each
    with its file's ``xfail`` mark when it holds on the run (:func:`marked`)."""
    samples: dict[int, list[SampleResult]] = {i: [] for i in pending}
    broken: dict[int, tuple[str, str]] = {}  # a sweep's first batch that raised: its error and traceback
    # a file runs once on each backend and mode: that names its run among the results
    marks: dict[tuple[str, str, str], XFail | None] = {run_key(p): p.xfail for p in prepared}
    try:
        for item in stream:
            if isinstance(item, CheckResult):
                yield marked(item, marks.get(result_key(item)))
                continue
            kind, i, *rest = item
            if kind == "broken":
                broken.setdefault(i, (rest[0], rest[1]))
            else:
                samples[i] += rest[0]
            pending[i] -= 1
            if not pending[i]:
                yield marked(_swept(prepared[i], samples.pop(i), broken.pop(i, None), where[i]), prepared[i].xfail)
    finally:
        stream.close()


def marked(result: CheckResult, xfail: XFail | None) -> CheckResult:
    """``result`` with the ``xfail`` mark that holds on its run (None: as it is): its reason and
    strictness (strict not given: false, pytest's default)."""
    if xfail is None:
        return result
    return replace(result, xfail=xfail.reason, strict=bool(xfail.strict))


def _swept(p: Prepared, samples: list[SampleResult], broken: tuple[str, str] | None, folder: str | None) -> CheckResult:
    """A sweep's result once its batches are back: its verdicts, or its internal error (a batch
    that raised, or one in judging the samples), which is this file's alone."""
    assert p.template is not None
    if broken is not None:
        return failed(str(p.path), p.program, p.expect, *broken)
    ordered = sorted(samples, key=lambda r: (r.cell, r.sample))
    try:
        result: CheckResult = sweep_result(str(p.path), p.template, p.program, p.expect, ordered, folder)
    except Exception as exc:  # MemoryError included
        return failed(str(p.path), p.program, p.expect, internal(exc), traceback.format_exc())
    return result


def compare(
    paths: list[str | Path],
    modes: tuple[str, ...] = ("raw", "tuned", "extension"),
    jobs: int | None = None,
    model: str | None = None,
    pattern: str | Sequence[str] | None = None,
    timeout: float | None = TIMEOUT,
) -> dict[str, dict[str, CheckResult]]:
    """Check every scenario in every mode, all in one run (one set of workers for all modes).

    Args:
        paths, jobs, model, pattern, timeout: as for :func:`check`.
        modes: engine modes, one column each.

    Returns:
        file -> mode -> :class:`CheckResult`, files in order.

    Raises:
        ScenarioErrors: a file is missing or invalid (before anything runs).
        ValueError, TypeError: a bad ``jobs`` or ``timeout``, as for :func:`check` (before
            anything is read).
    """
    check_jobs(jobs)
    check_timeout(timeout)
    refusals: list[CheckResult] = []
    broken: list[CheckResult] = []
    skipped: list[CheckResult] = []
    files = discover(paths)
    prepared = prepare(files, modes=modes, model=model, refused=refusals, timeout=timeout, broken=broken, skipped=skipped)
    prepared, refused = select_comparison(prepared, refusals + broken + skipped, pattern)
    return tabulate(prepared, modes, chain(refused, run_checks(prepared, jobs, timeout=timeout)), files=files)


def tabulate(
    prepared: list[Prepared],
    modes: tuple[str, ...],
    results: Iterable[CheckResult],
    each: Callable[[CheckResult], None] = lambda r: None,
    files: Sequence[str | Path] = (),
) -> dict[str, dict[str, CheckResult]]:
    """``results`` (in any order) as file -> column -> result, files in the order of ``files``
    when given (a file all of whose runs were skipped has no prepared run), else of
    ``prepared``; a column is a mode, or ``"backend mode"`` when ``modes`` name backends
    too; ``each`` is called with every result as it comes."""
    table: dict[str, dict[str, CheckResult]] = {str(f): {} for f in files}
    table.update({str(p.path): {} for p in prepared if str(p.path) not in table})
    for r in results:
        table.setdefault(r.file, {})[r.mode if r.mode in modes else f"{r.backend} {r.mode}"] = r
        each(r)
    return {file: {m: row[m] for m in modes if m in row} for file, row in table.items() if row}

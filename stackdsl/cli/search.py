"""``stackdsl search``: a file's ``search:`` block, a threshold or counterexamples, run, written
and printed (:mod:`stackdsl.batch.search`).

Source: stackdsl's own.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import re
import sys
import time
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from ..engines.registry import backend, names
from ..lang.errors import ScenarioError, SourceMap
from ..lang.schema_search import MAX_SEARCH_RUNS
from ..util.extras import installed, missing
from .args import COMMANDS, add_engine_overrides, add_executor, add_seed, output_folder
from .outputs import Input, Output, check_outputs


def add_search(
    sub: Any, parents: list[argparse.ArgumentParser], epilog: str, jobs_type: Any, models: list[str], modes: list[str]
) -> None:
    """Add ``search`` to the ``stackdsl`` parser's subcommands."""
    p = sub.add_parser(
        "search",
        parents=parents,
        help=COMMANDS["search"],
        description="Run FILE's search: block. threshold: the value of one field where the verdict changes, bracketed on "
        "each run's signed margin (Brent's method, then bisection on the verdict), printed as an interval with the runs "
        "it cost and the verdict on each side, with margin.png. counterexample: draws of the file's distributions that "
        "break its expectation (Optuna's TPE sampler on the signed margin), each shrunk and written as a plain scenario "
        "file (counterexample_N.yaml) that stackdsl run reproduces. The runs go to --out as a sweep's do.",
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("file", help="a scenario with a search: block")
    p.add_argument("--runs", type=int, help="override the search's runs (its budget)")
    add_seed(p)
    add_executor(p)
    p.add_argument("--out", default=None, help="folder for the files, made if missing (default: a new private folder)")
    p.add_argument(
        "--report",
        metavar="DIR",
        help="also write DIR/index.html: the search as one row, as check --report shows a sweep (its verdict, interval or "
        "counterexamples, the picture, links to the runs' files); the files go to DIR/<file's stem> unless --out is given",
    )
    add_engine_overrides(p, modes, models, names())
    p.set_defaults(func=_search)


def _search(args: argparse.Namespace) -> int:
    from ..batch.search import Evaluator, judged
    from ..batch.sweep import SweepOptions, dask_executor
    from ..lang.loader import load_scenario

    scenario = load_scenario(args.file, args.seed)
    if scenario.search is None:
        raise ScenarioError("this scenario has no search: block (threshold: or counterexample:)", file=args.file)
    engine_name = args.backend or scenario.engine.backend
    extra = backend(engine_name).extra
    if extra is not None and not installed(extra):
        raise scenario.source.error(("engine", "backend"), missing(extra))
    search = scenario.search
    if search.counterexample is not None and not installed("search"):
        raise scenario.source.error(("search", "counterexample"), missing("search"))
    if args.runs is not None:  # the file's bounds: a threshold needs both ends and one between (max(3, 1) made 3 of 1)
        least = 3 if search.threshold is not None else 1
        if not least <= args.runs <= MAX_SEARCH_RUNS:
            kind = "a threshold search (both ends and one between)" if least == 3 else "a search"
            raise ScenarioError(f"--runs of {kind} must be from {least} to {MAX_SEARCH_RUNS}, not {args.runs}", file="--runs")
    out = None
    if args.report is not None and args.out is None:  # the row's files beside its page
        args.out = str(Path(args.report) / _safe(Path(args.file).stem))
    outputs = [Output("--out", args.out, "the search's output", folder=True)] if args.out is not None else []
    outputs += [Output("--report", args.report, "the report", folder=True, inside=("index.html",))] if args.report else []
    if outputs:
        made = check_outputs(outputs, [Input(args.file, "the scenario searched")])
        out = made[0] if args.out is not None else None
    data, source = _data(args.file, args.seed)
    from ..batch.guard import TIMEOUT

    options = SweepOptions(args.mode, args.model, False, TIMEOUT if args.timeout is None else args.timeout, args.backend)
    if search.threshold is not None:  # the field and its ends checked before anything is made or runs
        template, value_of = _threshold_template(data, source, search.threshold, options)
    else:
        template, expected = _counterexample_template(scenario, data, source)
    if args.timeout is not None:  # --timeout bounds the whole search: refused up front if it cannot fit
        from ..batch.search import within_time
        from ..batch.sweep import Budget

        spec_any = search.threshold or search.counterexample
        assert spec_any is not None
        within_time(template, spec_any, options, args.jobs if not args.dask else 1, args.timeout)
        budget = Budget(args.timeout)
        budget.left()  # the clock starts now
        options = dataclasses.replace(options, budget=budget)
    if out is None:
        out = output_folder(None, f"stackdsl-search-{Path(args.file).stem[:40]}-")
    started = time.perf_counter()
    with ExitStack() as stack:
        executor, jobs = None, args.jobs
        if args.dask:
            try:
                executor, jobs, _ = stack.enter_context(dask_executor(args.dask))
            except (ValueError, OSError, TimeoutError) as exc:  # a malformed address, no scheduler there
                raise ScenarioError(str(exc), file="--dask") from None
        judge = scenario.expect if search.threshold is not None and judged(scenario.expect) else None
        evaluator = stack.enter_context(Evaluator(options, jobs, executor, judge))
        engine = f"{engine_name} {args.mode or scenario.engine.mode}"
        where = f"Dask {args.dask}" if args.dask else f"{jobs} process{'es' if jobs != 1 else ''}"
        if search.threshold is not None:
            spec = search.threshold if args.runs is None else search.threshold.model_copy(update={"runs": args.runs})
            print(
                f"stackdsl search: threshold of {spec.field} in [{spec.between[0]}, {spec.between[1]}], {engine}, on {where}, writing to {out}",
                flush=True,
            )
            status, row = _threshold(args, template, value_of, spec, evaluator, out, started)
            return _reported(args, scenario, engine_name, status, row, out, started)
        spec_c = search.counterexample
        assert spec_c is not None
        if args.runs is not None:
            spec_c = spec_c.model_copy(update={"runs": args.runs})
        print(f"stackdsl search: counterexamples in {spec_c.runs} runs, {engine}, on {where}, writing to {out}", flush=True)
        status, row = _counterexamples(args, scenario, template, expected, spec_c, evaluator, out, started)
        return _reported(args, scenario, engine_name, status, row, out, started)


def _data(file: str, seed: int | None) -> tuple[dict[str, Any], SourceMap]:
    """The file's plain data and its source map (read as :func:`stackdsl.load_scenario` reads it)."""
    from ..lang.loader import read_data

    return read_data(file, seed)


def _as_it_is(value: Any) -> Any:
    return value


def _say(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def _threshold_template(data: dict[str, Any], source: SourceMap, spec: Any, options: Any) -> tuple[Any, Callable[[Any], Any]]:
    """The file as a template whose one-field grid is the field searched (its ends checked as a
    sweep's grid values are, and compiled on the command line's mode, model and backend:
    ``options``, a :class:`stackdsl.batch.sweep.SweepOptions`; errors said at the search's field or
    ends), and what puts a probe's value in the grid (the whole list, for one number of a list)."""
    from ..batch.search import in_list
    from ..compile.compiler import compile_scenario
    from ..lang.sampling import Template

    data = {k: copy.deepcopy(v) for k, v in data.items() if k not in ("sweep", "expect")}  # a run's verdict is what counts
    key: str = spec.field
    value_of: Callable[[Any], Any] = _as_it_is
    if (one := in_list(data, spec.field)) is not None:  # one number of a list: the grid gives the whole list
        key, value_of = one
    data["sweep"] = {"samples": 1, "grid": {key: [value_of(v) for v in spec.between]}}
    here = source.values.get(("search", "threshold", "field"))
    ends = [source.values.get(("search", "threshold", "between", i)) for i in (0, 1)]
    values, keys = dict(source.values), dict(source.keys)
    if here is not None:  # the grid's key and values are the search's field and ends: errors point there
        keys[("sweep", "grid", key)] = source.keys.get(("search", "threshold", "field"), here)
        values[("sweep",)] = values[("sweep", "grid")] = values[("sweep", "grid", key)] = here  # a path is found node by node
        for i, at in enumerate(ends):
            if at is not None:
                values[("sweep", "grid", key, i)] = at
    mapped = dataclasses.replace(source, values=values, keys=keys)
    try:
        template = Template.of(data, mapped)
        assert template is not None
        template.scenario(0, 0, checked=True)
        template.scenario(1, 0)
        for end in (0, 1):  # what the compiler refuses at an end (a spacing that overlaps the bricks): said there, first
            try:
                compile_scenario(template.scenario(end, 0), options.mode, options.model, options.backend)
            except ScenarioError as exc:
                if not (exc.field or "").startswith("sweep"):  # elsewhere, made so by the end: said so
                    exc.message += f" (with the search's {('lower', 'upper')[end]} end, {spec.field} = {spec.between[end]})"
                raise
        low, high = spec.ends
        middle: Any = (low + high) / 2 if not spec.unit else f"{(low + high) / 2:g} {spec.unit}"
        try:  # a value between the ends, as the search proposes them: a field of whole numbers takes none
            between = Template.of({**data, "sweep": {"samples": 1, "grid": {key: [value_of(middle)]}}}, mapped)
            assert between is not None
            between.scenario(0, 0, checked=True)
        except ScenarioError as exc:
            if not (exc.field or "").startswith("sweep"):
                raise
            raise source.error(
                ("search", "threshold", "field"),
                f"{spec.field} does not take {middle}, between the ends, as the search proposes: "
                f"{exc.message.split(': ', 1)[-1]}; a threshold search moves its field by fractions, so search a field "
                "that takes any value between its ends (a length, a speed, a time), or list whole values in a sweep's grid",
            ) from None
    except ScenarioError as exc:  # the grid is the search's own: said at its field or its ends
        if not (exc.field or "").startswith("sweep"):
            raise
        end_at = re.search(r"\[(\d)\]$", exc.field or "")
        blamed: tuple[str | int, ...] = ("search", "threshold", "between" if "value" in exc.message else "field")
        if end_at is not None and blamed[-1] == "between":
            blamed += (int(end_at[1]),)
        message = re.sub(  # the grid's two cells are the search's ends
            r"sample 0 of grid cell ([01]) \(",
            lambda m: f"the search's {('lower', 'upper')[int(m[1])]} end (",
            exc.message.replace("the grid key", "the field").replace("grid value", "value"),
        )
        raise source.error(blamed, message) from None
    return template, value_of


def _threshold(
    args: argparse.Namespace, template: Any, value_of: Callable[[Any], Any], spec: Any, evaluator: Any, out: Path, started: float
) -> tuple[int, Row | None]:
    """Run a threshold search, write its files and print its answer; the exit status and its
    report row (None: a run was bad input, nothing written)."""
    from ..batch.search import find_threshold, followed, stands, tie_band
    from ..compile.compiler import compile_scenario
    from ..draw.searchplot import plot_margin

    options = evaluator.options  # the engine's tie band: the reported interval's ends carry it
    engine = compile_scenario(template.scenario(0, 0), options.mode, options.model, options.backend).engine
    found = find_threshold(template, spec, evaluator, _say, value_of, tie_band(engine.mode, engine.contact_margin))
    wall = time.perf_counter() - started
    results = [r for _, r in found.probes]
    if found.bad_input:
        print(found.bad_input, file=sys.stderr)
        return 2, None
    written = _write_runs(results, out)
    name, unit, bracketed = followed(results)  # what the search bracketed on: the axis says which
    judged = any(r.held is not None for r in results)
    picture = plot_margin(
        [v for v, _ in found.probes],
        bracketed,
        [stands(r) for _, r in found.probes],
        found.interval,
        spec.field,
        spec.unit,
        out / "margin.png",
        (name, unit),
        ("expectations held", "expectations failed") if judged else ("stands", "collapses"),
    )
    grid = found.grid_runs(spec.step, spec.ends)
    summary: dict[str, Any] = {
        "kind": "threshold",
        "field": spec.field,
        "unit": spec.unit,
        "interval": None if found.interval is None else list(found.interval),
        "runs_interval": None if not found.found else [found.low, found.high],
        "tie_band": list(found.widened),
        "below": found.below,
        "above": found.above,
        "runs": found.runs,
        "grid_runs": grid,
        "method": found.method,
        "bracketed_on": f"{name} [{unit}]" if unit else name,
        "changes": found.changes,
        "message": found.message,
        "wall_time": wall,
    }
    (out / "search.json").write_text(json.dumps(summary, indent=2) + "\n")
    if found.interval is not None:
        (low, high), widened = found.interval, found.widened
        print(
            f"threshold of {spec.field}: between {low:.6g} and {high:.6g} {spec.unit} "
            f"(width {high - low:.3g} {spec.unit}; {found.below} below, {found.above} above)".replace("  ", " ")
        )
        if any(widened):
            print(
                f"  the runs' interval, {found.low:.6g} to {found.high:.6g} {spec.unit}, widened by the engine's tie band "
                f"({widened[0]:.3g} and {widened[1]:.3g} {spec.unit}): within it the engine decides the verdict either way"
            )
        if high - low - widened[0] - widened[1] <= spec.step * (1.0 + 1e-9):  # the runs' interval, within the tolerance
            print(
                f"{found.runs} runs ({found.method}); a grid of the same resolution takes {grid} ({grid / found.runs:.1f}x as many)"
            )
        else:  # --runs spent first: no resolution reached to set a grid against
            print(
                f"{found.runs} runs ({found.method}), spent before the runs' interval was {spec.step:g} {spec.unit} wide: "
                "the interval above is as narrow as they got, not the threshold to the tolerance".replace("  ", " ")
            )
        if found.changes > 1:
            print(f"note: the verdict changes {found.changes} times among the runs: the interval is the narrowest change")
    if found.message:
        print(f"{'note' if found.found else 'no threshold'}: {found.message}")
    print(f"{found.runs} runs in {wall:.1f} s; wrote {', '.join(p.name for p in written)}, {picture.name}, search.json in {out}")
    expected = f"a threshold of {spec.field} in [{spec.between[0]}, {spec.between[1]}] to {spec.step:g} {spec.unit}"
    if found.interval is not None:
        measured = (
            f"between {found.interval[0]:.6g} and {found.interval[1]:.6g} {spec.unit} ({found.below} below, {found.above} above); "
            f"{found.runs} runs, a grid takes {grid}"
        )
    else:
        measured = f"no threshold: {found.message}; {found.runs} runs"
    row = Row(expected, measured, results, [picture, *written, out / "search.json"], found.error)
    if found.error:
        print(f"stackdsl: a run hit an internal error: {found.error}", file=sys.stderr)
        return 3, row
    return (0 if found.found and not found.message else 1), row


def _counterexample_template(scenario: Any, data: dict[str, Any], source: SourceMap) -> tuple[Any, bool]:
    """The file as a template of one sample a cell (its sweep's grid and expectations left aside),
    and whether the file expects a stand (the verdict a counterexample breaks).

    Raises:
        ScenarioError: at ``expect``, when it says neither.
    """
    from ..batch.search import expects_stand
    from ..lang.sampling import Template

    expected = expects_stand(scenario)
    if expected is None:
        raise scenario.source.error(
            ("expect",),
            "a counterexample search needs an expectation that the structure stands (stands: true, p_stands: '>= ...') "
            "or collapses (collapse: N, p_stands: '<= ...')",
        )
    data = {k: v for k, v in data.items() if k not in ("sweep", "expect")}  # the expectation is read above
    data["sweep"] = {"samples": 1}
    template = Template.of(data, source)
    assert template is not None
    return template, expected


def _counterexamples(
    args: argparse.Namespace,
    scenario: Any,
    template: Any,
    expected: bool,
    spec: Any,
    evaluator: Any,
    out: Path,
    started: float,
) -> tuple[int, Row | None]:
    """Run a counterexample search, write its files and print what it found; the exit status and
    its report row (None: every run was bad input, nothing written)."""
    from ..batch.search import counterexample_file, find_counterexamples

    seed = template.seed if args.seed is None else args.seed
    found = find_counterexamples(template, spec, not expected, evaluator, seed, _say, batch=max(1, evaluator.jobs))
    wall = time.perf_counter() - started
    if not found.results and found.outside:  # every proposal failed require:: nothing to judge, never "none found"
        said = template.source.error(
            ("require",),
            f"none of the search's {found.outside} proposals meets it, whatever the other draws: the search proposes "
            "the drawn fields' values within their distributions' ranges; give ranges where it can hold",
        )
        print(said, file=sys.stderr)
        return 2, None
    if found.bad_input and all(r.bad_input for r in found.results):  # no run to judge: bad input, never "none found"
        print(found.bad_input, file=sys.stderr)
        return 2, None
    written = _write_runs(found.results, out)
    files = []
    sought = "a stand" if not expected else "a collapse"
    for i, f in enumerate(found.found, 1):
        values = f.shrunk or f.values
        run = f.shrunk_result or f.result
        drawn = ", ".join(f"{d.label} = {v}" for d, v in values.items())
        note = f"A counterexample to {Path(args.file).name} (stackdsl search, run {f.first_run}, shrunk): {drawn}."
        path = out / f"counterexample_{i}.yaml"
        path.write_text(counterexample_file(template, values, scenario.expect, not expected, note))
        files.append(path)
        margin = "" if run.margin is None else f", margin {run.margin * 1000:+.3f} mm"
        print(
            f"counterexample {i} (found at run {f.first_run}): {drawn}: {'stands' if run.collapse_level is None else f'collapses at level {run.collapse_level}'}{margin}; wrote {path}"
        )
        print(f"  reproduce: stackdsl run {path}")
    summary = {
        "kind": "counterexample",
        "sought": sought,
        "found": len(found.found),
        "first": found.first,
        "search_runs": found.search_runs,
        "shrink_runs": found.shrink_runs,
        "outside_require": found.outside,
        "files": [str(p) for p in files],
        "wall_time": wall,
    }
    (out / "search.json").write_text(json.dumps(summary, indent=2) + "\n")
    outside = f", {found.outside} of them proposals that fail require: (not run)" if found.outside else ""
    if not found.found:
        print(f"no counterexample in {found.search_runs} runs{outside}: {sought} was never reached")
    print(
        f"{len(found.results)} runs ({found.search_runs} searching, {found.shrink_runs} shrinking) in {wall:.1f} s; wrote {', '.join(p.name for p in written)}, search.json in {out}"
    )
    expected_text = f"no counterexample ({sought}) in {spec.runs} runs"
    measured = (
        f"{len(found.found)} counterexample{'s' * (len(found.found) != 1)}, the first at run {found.first}"
        if found.found
        else f"none in {found.search_runs} runs"
    )
    row = Row(expected_text, measured, found.results, [*written, *files, out / "search.json"], found.error)
    if found.error:
        print(f"stackdsl: a run hit an internal error: {found.error}", file=sys.stderr)
        return 3, row
    return (1 if found.found else 0), row


def _write_runs(results: list[Any], out: Path) -> list[Path]:
    from ..batch.sweep_out import PARQUET_MISSING, write_samples

    table, jsonl, parquet = write_samples(results, out)
    if parquet is None:
        print(f"stackdsl: {PARQUET_MISSING}", file=sys.stderr)
    return [table, jsonl, *([parquet] if parquet else [])]


@dataclasses.dataclass
class Row:
    """What a search's row in the HTML report says: what it asked (``expected``) and found
    (``measured``), its runs, the files it wrote (the first, a picture when it is a PNG) and an
    internal error of a run (one line, or ``""``)."""

    expected: str
    measured: str
    results: list[Any]
    files: list[Path]
    error: str = ""


def _reported(
    args: argparse.Namespace, scenario: Any, engine: str, status: int, row: Row | None, out: Path | None, started: float
) -> int:
    """``--report DIR``: ``DIR/index.html`` with the search as one row, as ``check --report`` shows a
    sweep (:func:`stackdsl.batch.htmlreport.write_report`): PASS when the search's exit status is
    0, its picture and links to its files. Returns ``status``."""
    if args.report is None or row is None or out is None:
        return status
    from ..batch.htmlreport import write_report
    from ..batch.report import rerun_command
    from ..verdicts.check_result import CheckResult
    from ..verdicts.expect import Verdict

    pictures = [("picture", row.files[0].name)] if row.files and row.files[0].suffix == ".png" else []
    kinds = {"samples.csv": "samples", "samples.parquet": "parquet", "samples.jsonl": "jsonl"}
    links = [(kinds.get(f.name, f"file {f.name}"), f.name) for f in row.files if f.suffix != ".png"]
    mode = args.mode or scenario.engine.mode
    result = CheckResult(
        file=args.file,
        scenario=scenario.name,
        mode=mode,
        model=args.model or scenario.stability.model,
        backend=engine,
        verdicts=(Verdict(name="search", passed=status == 0, expected=row.expected, measured=row.measured),),
        collapse_level=None,
        levels_placed=max((r.levels_placed for r in row.results), default=0),
        simulated_time=sum(r.simulated_time for r in row.results),
        wall_time=time.perf_counter() - started,
        error=row.error,
        sweep=row.measured,
        folder=str(out),
        artefacts=tuple([*pictures, *links]),
    )
    command = rerun_command(
        "search", args.file, mode=args.mode, model=args.model, backend=args.backend, seed=args.seed, timeout=args.timeout
    )
    page = write_report(
        [result], args.report, total=1, wall=result.wall_time, commands=[command], argv=sys.argv[1:], title="stackdsl search"
    )
    print(f"wrote {page}")
    return status


def _safe(name: str) -> str:
    """``name`` with only letters, digits, ``-`` and ``_`` (a folder name), at most 40 characters."""
    import re

    return re.sub(r"[^A-Za-z0-9_-]", "_", name)[:40] or "search"

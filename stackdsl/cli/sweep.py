"""``stackdsl sweep``: every sample of a scenario's sweep, its files, summary and verdicts.

Source: stackdsl's own.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..engines.registry import backend, names
from ..lang.errors import ScenarioError
from ..util.extras import installed, missing
from .args import COMMANDS, INTERNAL, add_engine_overrides, add_executor, add_seed, output_folder
from .outputs import Input, Output, check_outputs

if TYPE_CHECKING:  # imported when a sweep runs: `stackdsl --help` stays quick
    from ..batch.sweep import SampleResult
    from ..lang.expectations import Expect
    from ..lang.sampling import Template
    from ..lang.schema import Scenario


def add_sweep(
    sub: Any, parents: list[argparse.ArgumentParser], epilog: str, jobs_type: Any, models: list[str], modes: list[str]
) -> None:
    """Add ``sweep`` to the ``stackdsl`` parser's subcommands."""
    p = sub.add_parser(
        "sweep",
        parents=parents,
        help=COMMANDS["sweep"],
        description="Run every sample of FILE's sweep (its random fields drawn from the k-th child of its seed, for each "
        "grid cell), write samples.csv and samples.jsonl, histograms and the grid plot to --out, and print for each "
        "grid cell the distribution of collapse levels and the verdict of each statistical expectation (PASS or "
        "FAIL when its 95%% confidence interval decides, else INCONCLUSIVE with the samples that would decide it).",
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("file", help="a scenario with a sweep: or random fields")
    p.add_argument("--samples", type=int, help="override the sweep's samples a cell")
    add_seed(p)
    add_executor(p)
    p.add_argument(
        "--oracle", action="store_true", help="also the equilibrium oracle's collapse level of each sample, and the agreement"
    )
    p.add_argument(
        "--out",
        default=None,
        help="folder for the files, made if missing; the files of an earlier sweep there are replaced, and those this one "
        "does not write removed (default: a new "
        "private folder stackdsl-sweep-NAME-* in the temporary directory)",
    )
    add_engine_overrides(p, modes, models, names())
    p.set_defaults(func=_sweep)


def _sweep(args: argparse.Namespace) -> int:
    from ..batch.sweep import (
        ClusterLost,
        SweepOptions,
        collect,
        compile_bounds,
        compile_cells,
        compile_placement_errors,
        dask_executor,
        run_sweep,
        samples_run,
    )
    from ..lang.loader import load_scenario
    from .progress import Lines

    scenario = load_scenario(args.file, args.seed)
    template = scenario.template
    if template is None:
        raise ScenarioError(
            "this scenario has no sweep and no random field: each run would be the same (use stackdsl run)", file=args.file
        )
    engine_name = args.backend or scenario.engine.backend
    _need_engine(args, scenario, engine_name)
    if args.samples is not None:
        template = template.with_samples(args.samples)
    out, earlier = _out_folder(args, template) if args.out is not None else (None, [])
    options = SweepOptions(args.mode, args.model, args.oracle, args.timeout, args.backend)
    # as check does: what the compiler refuses in any cell is bad input, said before anything runs
    tops = compile_cells(template, options.mode, options.model, options.backend, range(template.cells), options.timeout)
    compile_bounds(template, options.mode, options.model, options.backend, range(template.cells), options.timeout, tops)
    compile_placement_errors(template, options.mode, options.model, options.backend, range(template.cells), options.timeout)
    engine = f"{engine_name} {args.mode or scenario.engine.mode}"  # which engine ran, said once
    total = template.cells * samples_run(template)
    start = time.perf_counter()

    made = out is None
    if out is None:  # a new folder of this user's only (mode 0700), never a shared, predictable path
        out = output_folder(None, f"stackdsl-sweep-{_safe(Path(args.file).stem)}-")

    done = [0]  # samples back so far (said when a Dask scheduler goes away)

    def run(where: str, status: Callable[[], str | None] | None = None, **executor: Any) -> list[Any]:
        print(
            f"stackdsl sweep: {_count(template.cells, 'cell')} x {_count(template.samples, 'sample')}"
            + (
                f" (nothing is drawn: one run a cell stands for its {template.samples})"
                if total < template.cells * template.samples
                else ""
            )
            + f", {engine}, on {where}, "
            f"writing to {out}" + (f" (replacing {', '.join(earlier)} of an earlier sweep there)" if earlier else ""),
            flush=True,
        )

        def each(batch: list[Any]) -> None:
            done[0] += len(batch)
            lines.advance(len(batch))

        with Lines(total, "sweep", status=status) as lines:
            batches = run_sweep(template, options, **executor)
            return collect(batches, each, stop_at_bad_input=True)

    if args.dask:
        try:
            with dask_executor(args.dask, _say_lost) as (executor, threads, connected):  # reached before anything is said
                results = run(f"Dask {args.dask}", partial(_no_worker, connected), executor=executor, workers=threads)
        except ClusterLost as exc:  # as a worker lost from stackdsl's own pool: the run is cut short, exit 3
            _forget(out, made)
            print(f"stackdsl: {exc} after {done[0]} of {total} samples; nothing written", file=sys.stderr)
            return INTERNAL
        except ValueError as exc:
            _forget(out, made)
            raise ScenarioError(str(exc), file="--dask") from None
        except (OSError, TimeoutError) as exc:
            _forget(out, made)
            raise ScenarioError(str(exc), file="--dask") from None
        except ScenarioError:
            _forget(out, made)
            raise
    else:
        results = run(_count(args.jobs, "process", "processes"), jobs=args.jobs)
    wall = time.perf_counter() - start
    bad = [r for r in results if r.bad_input]
    if bad:
        print(bad[0].bad_input, file=sys.stderr)
        print(
            f"stackdsl: sample {bad[0].sample}{f' of grid cell {bad[0].cell}' if template.grid else ''} refused as bad "
            f"input; the sweep stopped there ({len(results)} of {total} samples drawn), nothing written",
            file=sys.stderr,
        )
        _forget(out, made)
        return 2
    return _write(args, template, scenario.expect, results, out, (total, wall))


def _need_engine(args: argparse.Namespace, scenario: Scenario, engine_name: str) -> None:
    """Nothing when the engine the sweep runs on (``--backend``, else the scenario's) is
    installed; said once, before any sample is drawn.

    Raises:
        ScenarioError: its extra is missing, at ``--backend`` or at the file's ``engine.backend``.
    """
    extra = backend(engine_name).extra
    if extra is not None and not installed(extra):
        if args.backend:
            raise ScenarioError(missing(extra), file="--backend")
        raise scenario.source.error(("engine", "backend"), missing(extra))


def _out_folder(args: argparse.Namespace, template: Template) -> tuple[Path, list[str]]:
    """The ``--out`` folder, checked before anything runs, and the files an earlier sweep left
    there (also those this one does not write: removed once it has written its own, and said).

    Raises:
        ScenarioError: the folder is refused as an output (:func:`stackdsl.cli.outputs.check_outputs`).
    """
    from ..batch.sweep_out import any_sweep_files, file_names

    (out,) = check_outputs(
        [Output("--out", args.out, "the sweep's output", folder=True, inside=file_names(template.cells))],
        [Input(args.file, "the scenario swept")],
    )
    return out, [name for name in any_sweep_files() if (out / name).is_file()]


def _write(
    args: argparse.Namespace,
    template: Template,
    expect: Expect,
    results: list[SampleResult],
    out: Path,
    timing: tuple[int, float],
) -> int:
    """A finished sweep's files in ``out`` (samples, plots; an earlier sweep's others removed),
    each cell's distribution and verdicts printed, the command that reruns the first sample that
    did not finish, and ``timing``: how many samples ran in how many wall seconds; the exit status:
    3 an internal error, 1 a verdict not PASS or a sample stopped, else 0."""
    from ..batch.report import rerun_command
    from ..batch.sweep_out import PARQUET_MISSING, remove_leftovers, report, verdicts, write_plots, write_samples

    total, wall = timing
    table, jsonl, parquet = write_samples(results, out)
    if parquet is None:
        print(f"stackdsl: {PARQUET_MISSING}", file=sys.stderr)
    plots = write_plots(template, results, out, expect)
    remove_leftovers(out, [table, jsonl, *([parquet] if parquet else []), *plots])  # the folder holds this sweep's files alone
    for line in report(template, expect, results):
        print(line)
    unfinished = next((r for r in results if r.error or r.stopped), None)
    if unfinished is not None:  # the first that did not finish, as run takes it alone
        again = rerun_command(
            "run",
            args.file,
            mode=args.mode,
            model=args.model,
            backend=args.backend,
            seed=args.seed,
            sample=unfinished.sample,
            cell=unfinished.cell if template.grid else None,
            timeout=args.timeout,
        )
        print(f"more: {again}")
    print(
        f"{_count(total, 'sample')} in {wall:.1f} s ({total / wall:.1f} a second); wrote {table}, {jsonl.name}, "
        + (f"{parquet.name}, " if parquet else "")
        + ", ".join(p.name for p in plots)
    )
    judged = verdicts(template, expect, results)
    if any(r.error for r in results):
        print(f"stackdsl: {sum(bool(r.error) for r in results)} samples hit an internal error", file=sys.stderr)
        return 3
    return 0 if all(v.outcome == "PASS" for _, v in judged) and not any(r.stopped for r in results) else 1


def _safe(name: str) -> str:
    """``name`` with only letters, digits, ``-`` and ``_`` (for a folder name), at most 40 characters."""
    return re.sub(r"[^A-Za-z0-9_-]", "_", name)[:40] or "sweep"


def _forget(folder: Path, made: bool) -> None:
    """Remove the default folder made for this sweep when nothing was written into it."""
    if made:
        try:
            folder.rmdir()
        except OSError:
            pass  # not empty, or gone: leave it


def _no_worker(connected: Callable[[], int | None]) -> str | None:
    """The progress line's status on a Dask cluster: said while no worker is connected."""
    return "no worker connected to the scheduler: waiting for one" if connected() == 0 else None


def _say_lost(workers: list[str]) -> None:
    """Say which Dask workers left during a sweep, and that nothing was lost with them."""
    print(
        f"stackdsl sweep: {len(workers)} Dask worker{'s' * (len(workers) != 1)} left during the sweep "
        f"({', '.join(workers)}); the scheduler ran the batches {'they' if len(workers) != 1 else 'it'} held "
        "again on the others, so every sample is in the results",
        file=sys.stderr,
        flush=True,
    )


def _count(n: int, one: str, many: str | None = None) -> str:
    """``n`` and the noun, singular for 1: ``_count(1, "sample")`` is ``"1 sample"``."""
    return f"{n} {one if n == 1 else many or one + 's'}"

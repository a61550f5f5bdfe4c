"""A sweep as one row of ``stackdsl check``: its batches beside the other runs, one verdict.

``check`` sends a sweep's batches (:func:`stackdsl.batch.sweep.batches`) to the same pool as the
other scenarios' runs, so one set of workers serves every file; when a sweep's last batch is
back, :func:`sweep_result` turns its samples into a :class:`stackdsl.CheckResult`: one verdict
per statistical expectation and grid cell (PASS or FAIL when the 95% interval decides, else
not held: INCONCLUSIVE, with the samples that would decide it), the samples' files and plots
in the report folder when there is one.

Source: stackdsl's own.
"""

from __future__ import annotations

import traceback
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..lang.expectations import Expect
from ..lang.sampling import Template
from ..verdicts.expect import Verdict
from ..verdicts.stats import summary
from .judge import failed, internal, judge
from .sweep import BUDGET_SPENT, NOT_RUN_REFUSED, Budget, SampleResult, SweepOptions, batches, run_batch
from .sweep_out import by_cell, failure_lines, levels_built, measured, verdicts, write_plots, write_samples


def sweep_tasks(index: int, template: Template, program: Any, timeout: float | None, workers: int) -> list[tuple[Any, ...]]:
    """The batch tasks of prepared scenario ``index``: ``("batch", index, template, cell, samples,
    options)``, run with the compiled program's mode and model; ``timeout`` bounds the whole
    sweep (one :class:`stackdsl.batch.sweep.Budget` shared by its batches), not each run."""
    budget = None if timeout is None else Budget(timeout)
    options = SweepOptions(program.engine.mode, program.stability.model, False, timeout, program.engine.backend, budget)
    return [("batch", index, template, cell, samples, options) for cell, samples in batches(template, workers)]


def run_unit(kind: str, *args: Any) -> Any:
    """One task of ``check``: ``("batch", index, ...)`` runs a sweep's batch and returns
    ``("batch", index, results)``; anything else is :func:`stackdsl.batch.judge.judge`'s.

    Nothing it raises leaves it (Ctrl-C aside): an internal error is that file's alone, so that
    the other files still run. A batch's is ``("broken", index, error, traceback)`` (the sweep's
    result says it once its other batches are back), a run's its failed result."""
    try:
        if kind == "batch":
            index, template, cell, samples, options = args
            return ("batch", index, run_batch(template, cell, samples, options))
        return judge(*args)
    except Exception as exc:  # MemoryError included
        if kind == "batch":
            return ("broken", args[0], internal(exc), traceback.format_exc())
        file, program, expect, *_ = args
        return failed(file, program, expect, internal(exc), traceback.format_exc())


def sweep_result(
    file: str, template: Template, program: Any, expect: Expect, results: Sequence[SampleResult], folder: str | None
) -> Any:
    """One :class:`stackdsl.CheckResult` for a whole sweep."""
    from ..verdicts.check_result import CheckResult

    decided = verdicts(template, expect, results)
    judged = [
        Verdict(
            name="statistic",
            passed=v.outcome == "PASS",
            expected=v.expected,
            measured=f"{v.outcome.lower()}: {v.measured}",
            at=expect.at(v.field),
            inconclusive=v.outcome == "INCONCLUSIVE",
        )
        for _, v in decided
    ]
    explanation = failure_lines(template, expect, decided, shown=False)  # check shows each place's line (its report)
    errors = [r for r in results if r.error]
    bad = [r for r in results if r.bad_input]
    levels = max((r.levels_placed for r in results), default=0)
    artefacts = _write_files(template, expect, results, Path(folder)) if folder is not None and not bad else ()
    return CheckResult(
        file=file,
        scenario=program.name,
        mode=program.engine.mode,
        model=program.stability.model,
        backend=program.engine.backend,
        verdicts=tuple(judged),
        collapse_level=None,
        levels_placed=levels,
        simulated_time=sum(r.simulated_time for r in results),
        wall_time=sum(r.wall_time for r in results),
        explanation=tuple(explanation),
        error=f"{errors[0].error} (sample {errors[0].sample})" if errors else "",
        stopped=_stopped(results),
        bad_input=bad[0].bad_input if bad else "",
        sweep=_described(template, results),
        folder=folder or "",
        artefacts=artefacts,
    )


def _write_files(template: Template, expect: Expect, results: Sequence[SampleResult], out: Path) -> tuple[tuple[str, str], ...]:
    """A sweep's files written in ``out`` (its samples and plots), as a result's artefacts: kind
    and file name, the first plot its picture."""
    table, lines, parquet = write_samples(results, out)
    plots = write_plots(template, results, out, expect)
    artefacts: tuple[tuple[str, str], ...] = (("picture", plots[0].name),) if plots else ()
    artefacts += (("samples", table.name), *((("parquet", parquet.name),) if parquet else ()), ("jsonl", lines.name))
    return artefacts + tuple((f"plot {p.stem}", p.name) for p in plots)


def _stopped(results: Sequence[SampleResult]) -> str:
    """Why a sweep's samples stopped before their end, one line, or ``""``: the --timeout spent
    before every sample ran, or how many stopped early and the first one's reason."""
    unrun = sum(r.stopped == BUDGET_SPENT for r in results)
    if unrun:
        return (
            f"{BUDGET_SPENT} after {len(results) - unrun} of {len(results)} samples: --timeout bounds the whole sweep "
            "file; give fewer samples or a longer --timeout"
        )
    stopped = [r for r in results if r.stopped and r.stopped != NOT_RUN_REFUSED]  # the bad input says why for those
    return f"{len(stopped)} samples stopped early: {stopped[0].stopped}" if stopped else ""


def _described(template: Template, results: Sequence[SampleResult]) -> str:
    """check's "measured" text of a sweep: the mean level and P(stands) of its one cell, or its size."""
    if template.cells > 1:
        return f"{template.cells} cells x {template.samples} samples"
    s = summary(measured(by_cell(results, 1)[0]), levels_built(results))
    mean = "no collapse" if s.mean is None else f"mean {s.mean:.2f}"
    return f"{mean}, P(stands) {s.p_stands:.2f}, n={s.n}"

"""One scenario judged: run a program under a wall-clock limit and check its expectations.

:func:`judge` is the unit of work ``stackdsl check`` sends to its workers; :func:`failed` and
:func:`lost` give a result for a run that produced no outcome (an internal error, a timeout,
a worker that died).

Source: stackdsl's own.
"""

from __future__ import annotations

import inspect
import time
import traceback
from dataclasses import replace
from typing import Any

from ..compile.program import Program
from ..draw.artefacts import draw_run
from ..lang.expectations import Expect
from ..runtime.outcome import Graph, Outcome, describe_certificate
from ..runtime.recorder import record_program
from ..runtime.run import run_program
from ..runtime.trajectory import TrajectoryTooLarge
from ..verdicts.check_result import CheckResult
from ..verdicts.expect import Verdict, evaluate, explain, moved_levels
from ..verdicts.stats import expected_text
from .guard import TIMEOUT as TIMEOUT
from .pool import WorkerLost, WorkerTimedOut
from .sweep import SampleResult
from .sweep_out import expectations

#: A worker whose run has not stopped itself this many seconds after its timeout (the
#: engine stuck inside one call) is ended from outside.
KILL_AFTER = 10.0


def run_guarded(program: Program, timeout: float | None = TIMEOUT) -> Outcome:
    """``run_program(program)`` with a wall-clock limit of ``timeout`` seconds (None: none),
    where the runtime takes one (see :func:`stopped_by`)."""
    if timeout is not None and "timeout" in inspect.signature(run_program).parameters:
        return run_program(program, timeout=timeout)
    return run_program(program)


def stopped_by(outcome: Outcome) -> str:
    """What stopped a run before its end, one line (the runtime's ``Outcome.stopped``:
    ``'timeout after 100 s at t = 12.5 s simulated (of 201 s)'``), or ``''`` when it ran to
    its end."""
    return str(getattr(outcome, "stopped", None) or "")


def judge(file: str, program: Program, expect: Expect, timeout: float | None = TIMEOUT, folder: str | None = None) -> CheckResult:
    """Run one program and check its expectations (the unit of work sent to workers); with
    ``folder``, record the run and draw its files there (a file that cannot be drawn is
    the result's ``draw_error``, not a failed expectation).

    An exception in the run (MemoryError included) is returned as the result's ``error``,
    with its traceback, not raised; Ctrl-C still interrupts. ``timeout`` bounds the drawing
    too: a clip not done by then is left out (the result's ``draw_error`` says so).
    """
    deadline = None if timeout is None else time.perf_counter() + timeout
    too_large = ""  # why the run was not drawn: its recording passed what a trajectory file may hold
    try:
        if folder is None:
            outcome, trajectory = run_guarded(program, timeout), None
        else:
            try:
                outcome, trajectory = record_program(program, source=file, timeout=timeout)
            except TrajectoryTooLarge as exc:  # judged still, from a run without a recorder; not drawn
                left = None if deadline is None else max(deadline - time.perf_counter(), 0.0)
                outcome, trajectory, too_large = run_guarded(program, left), None, f"not drawn: {exc}"
        stopped = stopped_by(outcome)
        result = CheckResult(
            file=file,
            scenario=program.name,
            mode=program.engine.mode,
            model=_model(program),
            backend=program.engine.backend,
            verdicts=tuple(evaluate(expect, outcome, program.collapse_threshold)),
            collapse_level=outcome.collapse.level if outcome.collapse else None,
            first_moved=outcome.collapse.brick if outcome.collapse else "",
            first_moved_level=outcome.collapse.brick_level if outcome.collapse else None,
            moved_levels=moved_levels(outcome, program.collapse_threshold),
            levels_placed=outcome.levels_placed,
            simulated_time=outcome.simulated_time,
            wall_time=outcome.wall_time,
            drift=outcome.drift,
            steps_per_brick=outcome.steps / max(outcome.bricks_placed, 1),
            explanation=() if stopped else tuple(explain(expect, outcome, program.collapse_threshold)),
            stopped=stopped,
            certificate=describe_certificate(outcome.certificate) if outcome.certificate else "",
            margin_mm=outcome.certificate.margin_mm if outcome.certificate else None,
            margin=outcome.margin,
            first_moved_ended=outcome.displacement.get(outcome.collapse.brick) if outcome.collapse else None,
            threshold=program.collapse_threshold,
        )
        if folder is None or trajectory is None:
            return result if not too_large else replace(result, draw_error=too_large)
        written, draw_error, draw_time = draw_run(trajectory, folder, deadline)
        return replace(result, folder=folder, artefacts=tuple(written.items()), draw_error=draw_error, draw_time=draw_time)
    except Exception as exc:  # MemoryError included
        return failed(file, program, expect, internal(exc), traceback.format_exc())


def internal(exc: BaseException) -> str:
    """An internal error as a result's one line: ``'internal error: KeyError: 'x''``, or
    ``'internal error: out of memory'``."""
    if isinstance(exc, MemoryError):
        return "internal error: out of memory"
    message = (str(exc).splitlines() or [""])[0]
    return f"internal error: {type(exc).__name__}: {message}"


def lost(task: tuple[Any, ...], error: WorkerLost) -> Any:
    """The result of a task (as :func:`stackdsl.batch.check_sweep.run_unit` takes it) whose worker
    died or was stopped: a run's failed result, or a batch's samples each with the error."""
    if task[0] == "batch":
        _, index, _, cell, samples, _ = task
        return (
            "batch",
            index,
            [SampleResult(cell, k, 0, {}, None, 0, 0.0, 0.0, error=f"internal error: {error}") for k in samples],
        )
    _, file, program, expect, timeout, _ = task
    if isinstance(error, WorkerTimedOut):
        return failed(file, program, expect, stopped=f"timeout after {timeout:g} s (the run did not stop; its worker was ended)")
    return failed(file, program, expect, f"internal error: {error} running this scenario")


def failed(file: str, program: Program, expect: Expect, error: str = "", traceback: str = "", stopped: str = "") -> CheckResult:
    """A result for a run that produced no outcome: ``error`` or ``stopped`` says why (one line)."""
    return CheckResult(
        file=file,
        scenario=program.name,
        mode=program.engine.mode,
        model=_model(program),
        backend=program.engine.backend,
        verdicts=unmeasured(expect, program),
        collapse_level=None,
        levels_placed=0,
        simulated_time=0.0,
        wall_time=0.0,
        error=error,
        stopped=stopped,
        traceback=traceback,
    )


def unmeasured(expect: Expect, program: Program) -> tuple[Verdict, ...]:
    """A failed verdict per expectation, measured as ``'not measured'`` (a run without an
    outcome; a sweep's statistics, those of ``expect.cells`` too, without samples)."""
    nothing = _nothing(program)
    forms = expectations(expect) + [f for rule in expect.cells or [] for f in expectations(rule)]
    return tuple(
        v.model_copy(update={"passed": False, "measured": "not measured"})
        for v in evaluate(expect, nothing, program.collapse_threshold)
    ) + tuple(
        Verdict(name="statistic", passed=False, expected=text, measured="not measured")
        for text in dict.fromkeys(expected_text(f) for f in forms)
    )


def _nothing(program: Program) -> Outcome:
    """The outcome of a run that produced none: nothing built, nothing moved, every field set
    (the expectations read any of them: ``stays`` reads ``levels_placed``, ``toppled`` ``unplaced``)."""
    empty = Graph(nodes=(), edges=())
    return Outcome(
        scenario=program.name,
        mode=program.engine.mode,
        backend=program.engine.backend,
        collapse=None,
        events=(),
        final_graph=empty,
        collapse_graph=None,
        displacement={},
        drift=0.0,
        kinetic_energy=0.0,
        levels_placed=0,
        bricks_placed=0,
        simulated_time=0.0,
        wall_time=0.0,
        steps=0,
        steps_skipped=0,
    )


def _model(program: Program) -> str:
    return program.stability.model

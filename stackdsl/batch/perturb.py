"""Fragility: each scenario rerun under changes that should not matter, and how many of its
verdicts held (``stackdsl check --perturb N``).

A verdict that holds under a 10 micrometre nudge, a timestep 1% off, 10% more or fewer
solver iterations and the other engine (:mod:`stackdsl.compile.perturb`) is *robust*; one that
flips under any of them is *fragile*, and the report names what flipped it and to what. The
certificate's margin (how far every centre of mass could move before the stand would not hold)
is given beside it: a stand whose margin is under the engine's contact margin is a *near tie*,
which only luck keeps from flipping.

A sweep is not perturbed: its samples are draws already, and its verdicts statistics of them.

Source: stackdsl's own.
"""

from __future__ import annotations

import traceback
from collections import Counter
from collections.abc import Callable, Generator, Sequence
from dataclasses import dataclass
from typing import Any

from ..compile.compiler import BACKEND_DEFAULTS, compile_scenario
from ..compile.perturb import Perturbation, perturb, perturbations
from ..compile.program import Program
from ..engines.registry import backend as registered
from ..lang.errors import ScenarioError
from ..lang.loader import load_scenario
from ..verdicts.check_result import CheckResult
from .address import free_cores
from .check import Prepared, result_key, run_key
from .check_sweep import run_unit
from .judge import KILL_AFTER, TIMEOUT, failed, internal, lost
from .pool import fan_out
from .sweep import Budget


@dataclass(frozen=True)
class Perturbed:
    """One perturbed run: what was changed (:attr:`Perturbation.label`) and its result, or why
    it did not run (``skipped``: the other engine is not installed or refuses the scene)."""

    label: str
    result: CheckResult | None
    skipped: str = ""


@dataclass(frozen=True)
class Fragility:
    """A scenario's verdicts under perturbation.

    Attributes:
        nominal: the run as written.
        runs: the perturbed runs, in :func:`stackdsl.compile.perturb.perturbations`' order.
        contact_margin: metres, the engine's contact margin (:attr:`EngineSettings.contact_margin`):
            a stand whose certificate's margin is under it is a near tie.
        note: why the scenario was not perturbed (a sweep), else ``""``.
    """

    nominal: CheckResult
    runs: tuple[Perturbed, ...] = ()
    contact_margin: float = 0.0
    note: str = ""

    @property
    def ran(self) -> list[tuple[str, CheckResult]]:
        """The perturbed runs that ran: (label, result)."""
        return [(p.label, p.result) for p in self.runs if p.result is not None]

    def held(self) -> dict[str, tuple[int, int]]:
        """Each expectation of the nominal run (by what it expects, ``'collapse 9±1'``) ->
        (perturbed runs in which it held, perturbed runs that ran)."""
        counts: dict[str, tuple[int, int]] = {}
        for v in self.nominal.verdicts:
            held = sum(_holds(r, v.name, v.expected) for _, r in self.ran)
            counts[v.expected] = (held, len(self.ran))
        return counts

    @property
    def flips(self) -> list[str]:
        """What flipped a verdict, one line each: ``'timestep +1%: expected collapse 9, measured
        collapse 10'``; a run that failed for another reason (an error, a timeout) says that."""
        lines = []
        for label, r in self.ran:
            if r.error or r.stopped:
                lines.append(f"{label}: {r.error or r.stopped}")
                continue
            for v in r.verdicts:
                nominal = next((n for n in self.nominal.verdicts if n.name == v.name and n.expected == v.expected), None)
                if nominal is not None and v.passed != nominal.passed:
                    lines.append(f"{label}: expected {v.expected}, measured {v.measured}")
        return lines

    @property
    def fragile(self) -> bool:
        """A verdict flipped (or a perturbed run failed to finish)."""
        return bool(self.flips)

    @property
    def margin_mm(self) -> float | None:
        """The smallest certificate margin, mm, of the nominal and the perturbed runs that
        stand; None when none has one."""
        margins = [r.margin_mm for r in (self.nominal, *(r for _, r in self.ran)) if r.margin_mm is not None]
        return min(margins) if margins else None

    @property
    def near_tie(self) -> bool:
        """The nominal stand's margin is under the engine's contact margin."""
        m = self.nominal.margin_mm
        return m is not None and m < self.contact_margin * 1000

    @property
    def verdict(self) -> str:
        """``ROBUST``, ``FRAGILE``, or ``NOT PERTURBED``."""
        if self.note:
            return "NOT PERTURBED"
        return "FRAGILE" if self.fragile else "ROBUST"

    def as_json(self) -> dict[str, Any]:
        """Plain data for ``check --perturb N --json``."""
        return {
            "file": self.nominal.file,
            "backend": self.nominal.backend,
            "mode": self.nominal.mode,
            "verdict": self.verdict,
            "held": {expected: {"held": h, "of": n} for expected, (h, n) in self.held().items()},
            "flipped_by": self.flips,
            "margin_mm": self.nominal.margin_mm,
            "least_margin_mm": self.margin_mm,
            "near_tie": self.near_tie,
            "runs": [
                {"perturbation": p.label, "measured": p.result.measured, "passed": p.result.passed}
                if p.result is not None
                else {"perturbation": p.label, "skipped": p.skipped}
                for p in self.runs
            ],
            "note": self.note,
        }


def _holds(result: CheckResult, name: str, expected: str) -> bool:
    return any(v.name == name and v.expected == expected and v.passed for v in result.verdicts) and not (
        result.error or result.stopped
    )


def perturbed_runs(
    prepared: Sequence[Prepared],
    nominal: Sequence[CheckResult],
    count: int,
    jobs: int | None = None,
    timeout: float | None = TIMEOUT,
    seed: int | None = None,
    each: Callable[[], None] = lambda: None,
) -> Generator[Fragility, None, None]:
    """Rerun each of ``prepared`` (whose runs as written are ``nominal``, by file, backend and
    mode) under ``count`` perturbations each, on ``jobs`` processes; a :class:`Fragility` per
    scenario, in the order of ``prepared``, once all its runs are back.

    Args:
        seed: the seed the scenarios were prepared with (``check --seed``), for the other engine's
            compile.
        each: called as each perturbed run finishes (a progress line).

    Raises:
        ValueError: ``count`` is below 1.
    """
    if count < 1:
        raise ValueError(f"--perturb takes a number of runs of at least 1, not {count}")
    by_key = {result_key(r): r for r in nominal}
    # one budget a scenario: what --timeout leaves after its run as written, shared by its reruns
    budgets = [None if timeout is None else Budget(max(0.0, timeout - _wall(by_key.get(run_key(p))))) for p in prepared]
    tasks: list[tuple[Any, ...]] = []
    costs: list[float] = []
    slots: list[list[Perturbed | None]] = []
    notes: list[str] = []
    for i, p in enumerate(prepared):
        backend = p.program.engine.backend
        others = [b for b in BACKEND_DEFAULTS if b != backend and registered(b).dynamics]  # another engine that moves
        chosen = perturbations(count, others[0] if others else None)
        slots.append([None] * len(chosen))
        notes.append("a sweep: its samples are draws already" if p.template is not None else "")
        if p.template is not None:
            continue
        for j, change in enumerate(chosen):
            program, skipped = _program(p, change, seed)
            if program is None:
                slots[i][j] = Perturbed(change.label, None, skipped)
                continue
            tasks.append(("perturbed", i, j, change.label, str(p.path), program, p.expect, budgets[i]))
            costs.append(program.wall_estimate)
    jobs = free_cores() if jobs is None else jobs
    limit = None if timeout is None else timeout + KILL_AFTER
    for i, j, label, result in fan_out(run_perturbed, tasks, costs, jobs, limit=limit, lost=_lost):
        slots[i][j] = Perturbed(label, None, SPENT.format(timeout=timeout)) if result is None else Perturbed(label, result)
        each()
    for i, p in enumerate(prepared):
        key = (str(p.path), p.program.engine.backend, p.program.engine.mode)
        first = by_key.get(key) or failed(str(p.path), p.program, p.expect, "not run")
        runs = tuple(s for s in slots[i] if s is not None)
        yield Fragility(first, runs, p.program.engine.contact_margin, notes[i])


def _program(p: Prepared, change: Perturbation, seed: int | None) -> tuple[Program | None, str]:
    """The perturbed program of ``p``, or None and why it cannot run (the other engine not
    installed, or beyond what it simulates)."""
    if change.kind != "backend":
        return perturb(p.program, change), ""
    try:
        scenario = load_scenario(p.path, seed)
        return compile_scenario(scenario, p.program.engine.mode, p.program.stability.model, change.backend), ""
    except ScenarioError as exc:
        return None, exc.message


#: Why a perturbed run did not run: its scenario's share of --timeout was spent.
SPENT = "--timeout {timeout:g} s, which bounds a scenario's perturbed check whole, was spent (or stopped them)"


def within_budget(prepared: Sequence[Prepared], count: int, timeout: float | None) -> None:
    """Refuse, before anything runs, a perturbed check that cannot end within ``timeout``: a
    scenario's run as written and its ``count`` reruns, by the compiler's estimate
    (:attr:`stackdsl.Program.wall_estimate` each), past the ``timeout`` that bounds them all
    (``--perturb 100 --timeout 1`` took a hundred times the timeout). As a sweep file's
    (:func:`stackdsl.batch.check.within_budget`), the estimate is a floor; reruns it lets through
    still stop when the budget is spent. A sweep is not perturbed. Source: stackdsl's own.

    Raises:
        ScenarioError: naming the file, with the runs, the estimate and the reruns that fit.
    """
    if timeout is None:
        return
    for p in prepared:
        each = p.program.wall_estimate
        if p.template is not None or (count + 1) * each <= timeout:
            continue
        fit = int(timeout / each) - 1 if each > 0 else count
        fits = f"at most {fit} reruns fit" if fit > 0 else "no rerun fits after the run as written"
        raise ScenarioError(
            f"--perturb {count}: the run as written and {count} reruns take about {(count + 1) * each:.3g} s of wall "
            f"time by the compiler's estimate ({each:.2g} s a run), past --timeout {timeout:g} s, which bounds a "
            f"scenario's perturbed check whole: {fits}; give a smaller --perturb or a longer --timeout",
            file=str(p.path),
        )


def _wall(result: CheckResult | None) -> float:
    return 0.0 if result is None else result.wall_time + result.draw_time


def run_perturbed(kind: str, i: int, j: int, label: str, *judged: Any) -> tuple[int, int, str, CheckResult | None]:
    """One perturbed run (a module-level function, for the workers): its place and its result
    (:func:`stackdsl.batch.check_sweep.run_unit`'s, which never raises for a run's own error),
    run with what its scenario's :class:`~stackdsl.batch.sweep.Budget` has left as its timeout;
    None when nothing is left."""
    file, program, expect, budget = judged
    left = None if budget is None else budget.left()
    if left is not None and left <= 0:
        return i, j, label, None
    try:
        result = run_unit("run", file, program, expect, left, None)
    except Exception as exc:  # pragma: no cover - run_unit returns a run's errors as its result
        result = failed(file, program, expect, internal(exc), traceback.format_exc())
    if budget is not None and (result.stopped or "").startswith("timeout"):
        return i, j, label, None  # stopped by what the budget had left: not a verdict that flipped
    return i, j, label, result


def _lost(task: tuple[Any, ...], error: Any) -> tuple[int, int, str, CheckResult]:
    """A perturbed run whose worker died or was stopped: its failed result, in its place."""
    _, i, j, label, file, program, expect, budget = task
    timeout = None if budget is None else budget.seconds
    return i, j, label, lost(("run", file, program, expect, timeout, None), error)


def fragility_lines(fragile: Sequence[Fragility], count: int) -> list[str]:
    """``check --perturb N``'s table: a row a scenario (``ROBUST``, ``FRAGILE`` or ``NOT
    PERTURBED``), each expectation with how many perturbed runs it held in, the certificate's
    margin, then what flipped each fragile verdict, and a summary line."""
    lines = ["", f"perturbed {count} times each: {covered(count)}"]
    width = max([len("scenario"), *(len(f.nominal.file) for f in fragile)])
    lines.append(f"{'':<13} {'scenario':<{width}}  {'held':<28} margin")
    for f in fragile:
        held = ", ".join(f"{expected} {h}/{n}" for expected, (h, n) in f.held().items()) or "(expects nothing)"
        margin = "" if f.nominal.margin_mm is None else f"{f.nominal.margin_mm:.1f} mm"
        if f.near_tie:
            margin += f" (a near tie: under {f.nominal.backend}'s {f.contact_margin * 1000:g} mm contact margin)"
        lines.append(f"{f.verdict:<13} {f.nominal.file:<{width}}  {f.note or held:<28} {margin}".rstrip())
        lines += [f"{'':<14}flipped by {flip}" for flip in f.flips]
        unrun = Counter(p.skipped for p in f.runs if p.result is None)
        for why, n in unrun.items():
            label = next(p.label for p in f.runs if p.result is None and p.skipped == why)
            lines.append(f"{'':<14}{label if n == 1 else f'{n} reruns'}: not run: {why}")
    perturbed = [f for f in fragile if not f.note]  # a sweep, say, is listed NOT PERTURBED and counted apart
    fragile_ones = sum(f.fragile for f in perturbed)
    ties = sum(f.near_tie for f in perturbed)
    unperturbed = len(fragile) - len(perturbed)
    lines.append(
        f"{len(perturbed)} scenarios perturbed: {len(perturbed) - fragile_ones} robust, {fragile_ones} fragile"
        + (f", {ties} near ties" if ties else "")
        + (f"; {unperturbed} not perturbed" if unperturbed else "")
    )
    return lines


#: The kinds of perturbation in words, for the table's heading, in the order :func:`perturbations` takes them.
_KINDS = {
    "jitter": "placement jitter 10 µm",
    "timestep": "timestep ±1%",
    "iterations": "solver iterations ±10%",
    "backend": "the other engine",
}


def covered(count: int) -> str:
    """The kinds of perturbation ``count`` reruns take, in words (:func:`perturbations` takes them
    in turn, the other engine fourth): the heading said every kind, the other engine too, of
    ``--perturb 3``, which never runs it. Source: stackdsl's own.

    >>> covered(3)
    'placement jitter 10 µm, timestep ±1%, solver iterations ±10% (the other engine from --perturb 4 on)'
    >>> covered(4)
    'placement jitter 10 µm, timestep ±1%, solver iterations ±10%, the other engine'
    """
    kinds = {p.kind for p in perturbations(count, "the other")}
    words = ", ".join(w for k, w in _KINDS.items() if k in kinds)
    if "backend" not in kinds:
        words += " (the other engine from --perturb 4 on)"
    return words

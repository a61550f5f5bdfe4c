"""Ask where it breaks: the value of one field where the verdict changes (a threshold), and draws
of a file's distributions that break its expectation (counterexamples), both searched with the
signed margin of each run's verdict (:attr:`stackdsl.Outcome.margin`).

- **Threshold** (:func:`find_threshold`). Both ends of the interval run first (together on the
  pool), then Brent's method (``scipy.optimize.brentq``) brackets the root of the signed margin:
  on a boundary statics decides the margin is continuous and nearly linear, and the bracket
  closes in a few runs. A margin that is not continuous (a shake that overturns a block: the
  stand's margin is its static margin, the collapse's how far the proof was past its limit)
  does not stop it: Brent's method keeps a bracket of opposite verdicts and falls back to
  bisection when interpolation does not shrink it; and whatever bracket it leaves wider than
  the tolerance is bisected on the verdict alone. The answer is the pair of runs nearest each
  other with opposite verdicts, an interval that holds the change when the verdict changes once.
- **Counterexample** (:func:`find_counterexamples`). Optuna's TPE sampler proposes values of the
  distributions drawn once a sample (a batch as wide as the pool at a time) and is told the signed
  margin, oriented so that the verdict the file does not expect is negative; a run with that
  verdict is a counterexample. Each is shrunk towards the distributions' centres (a uniform's
  middle, a normal's mean, a choice's first item), one distribution at a time, keeping a move only
  while the run still breaks the expectation (as hypothesis shrinks a failing example), then
  written as a plain scenario file (:func:`counterexample_file`).

Every run is a :class:`stackdsl.batch.sweep.SampleResult` (its ``sample`` is the run's number in
the search), so a search writes its runs as a sweep does (:func:`stackdsl.batch.sweep_out.write_samples`).

Source: stackdsl's own; Brent's method (R. P. Brent, "Algorithms for Minimization without
Derivatives", 1973, ch. 4, as scipy implements it); the TPE sampler (Bergstra et al., "Algorithms
for Hyper-Parameter Optimization", NeurIPS 2011, as Optuna implements it).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..lang.distributions import INSIDE, Distribution
from ..lang.errors import ScenarioError
from ..lang.expectations import Expect
from ..lang.sampling import Template
from ..lang.schema import Scenario
from ..lang.schema_search import Counterexample, Threshold
from ..lang.schema_sweep import grid_name
from .pool import WorkerLost, Workers
from .sweep import BUDGET_SPENT, SampleResult, SweepOptions, meets_require, run_batch

#: The least |signed margin| a probe gives Brent's method (metres): a run on the boundary itself
#: (margin 0) still has a side, its verdict's.
LEAST = 1e-9


def stands(result: SampleResult) -> bool | None:
    """Whether a run stood, or with its expectations judged (:func:`run_judged`) whether they held
    (None: it has no verdict: refused, stopped, an internal error, or undecided)."""
    if result.bad_input or result.error or result.stopped:
        return None
    if result.held is not None:
        return result.held
    if result.margin is None:
        return None
    return result.collapse_level is None


def judged(expect: Expect) -> bool:
    """Whether a threshold search judges ``expect`` on each run (one run's expectations beyond
    ``stands`` alone: ``toppled: all``, ``stays``, ``still``, a collapse level), rather than its stand or
    collapse (and then its signed margin)."""
    others = (expect.collapse, expect.stands_until, expect.stays, expect.moved, expect.toppled, expect.still)
    return expect.per_run and any(o is not None for o in others)


def run_judged(template: Template, cell: int, k: int, options: SweepOptions, expect: Expect) -> SampleResult:
    """Sample ``k`` of ``cell`` run as :func:`stackdsl.batch.sweep.run_batch` runs it, with one run's
    expectations ``expect`` judged on its outcome (:func:`stackdsl.verdicts.expect.evaluate`): its
    ``held``. A sample refused is its ``bad_input``; an exception its ``error``."""
    from ..compile.compiler import compile_scenario
    from ..runtime.run import run_program
    from ..verdicts.expect import evaluate
    from .sweep import which_sample

    parameters = template.parameters(cell, k)
    try:
        scenario = template.scenario(cell, k)
        program = compile_scenario(scenario, options.mode, options.model, options.backend, draw_time=options.timeout)
        if expect.still is not None:  # the template's own expectations are left aside: the motion is watched for ``expect``
            program = program.model_copy(update={"watch_motion": True})
    except ScenarioError as exc:
        return SampleResult(cell, k, 0, parameters, None, 0, 0.0, 0.0, bad_input=str(which_sample(exc, template, cell, k)))
    try:
        outcome = run_program(program, timeout=options.timeout)
        held = all(v.passed for v in evaluate(expect, outcome, program.collapse_threshold))
        still = None
        if expect.still is not None and outcome.peak_tilt is not None and outcome.peak_slip is not None:
            still = expect.still.margin(outcome.peak_tilt, outcome.peak_slip)
    except Exception as exc:  # MemoryError included: this run's internal error
        message = (str(exc).splitlines() or [""])[0]
        return SampleResult(
            cell, k, scenario.seed, parameters, None, 0, 0.0, 0.0, error=f"internal error: {type(exc).__name__}: {message}"
        )
    return SampleResult(
        cell,
        k,
        scenario.seed,
        parameters,
        outcome.collapse.level if outcome.collapse else None,
        outcome.levels_placed,
        outcome.wall_time,
        outcome.simulated_time,
        stopped=outcome.stopped or "",
        margin=outcome.margin,
        held=None if outcome.stopped else held,
        still_margin=None if outcome.stopped else still,
    )


def followed(results: Sequence[SampleResult]) -> tuple[str, str, list[float | None]]:
    """What a threshold search bracketed on, for each of ``results`` (its runs): the name of the
    quantity, its unit (``""``: a pure number) and its value a run (None: the run has none), as
    :func:`find_threshold` follows it: with ``still:`` judged, the share of its bound the largest
    tilt or slip leaves (:attr:`SampleResult.still_margin`, ``1 - peak / bound``); with other
    expectations judged, the verdict alone (+1 held, -1 failed: the search bisects); else the
    signed margin (:attr:`SampleResult.margin`), in mm. Source: stackdsl's own."""
    if any(r.still_margin is not None for r in results):
        return "still's margin, 1 - peak / bound", "", [r.still_margin for r in results]
    if any(r.held is not None for r in results):
        return "expectations (+1 held, -1 failed)", "", [None if r.held is None else 1.0 if r.held else -1.0 for r in results]
    return "signed margin", "mm", [None if r.margin is None else r.margin * 1000 for r in results]


def verdict_word(result: SampleResult) -> str:
    """``"stands"``, ``"collapses at level N"`` (``"held"``, ``"failed"`` with its expectations
    judged), or why the run has no verdict."""
    if result.held is not None and not (result.bad_input or result.error or result.stopped):
        return "expectations held" if result.held else "expectations failed"
    if result.bad_input:
        return "bad input"
    if result.error or result.stopped:
        return (result.error or result.stopped).split(":")[0]
    if result.margin is None:
        return "undecided"
    return "stands" if result.collapse_level is None else f"collapses at level {result.collapse_level}"


class Evaluator:
    """Runs of templates' sample 0 (or sample k), in the order given: in this process (one job, or one
    run), on stackdsl's pool (``jobs`` worker processes kept for the whole search, started when
    first needed) or on a caller's executor (a Dask client's). A worker lost is that run's internal
    error. Use as a context manager (the pool's workers end with it)."""

    def __init__(
        self, options: SweepOptions, jobs: int = 1, executor: Executor | None = None, expect: Expect | None = None
    ) -> None:
        self.options, self.jobs, self.executor, self.expect = options, jobs, executor, expect
        self._pool: Workers | None = None
        self.runs = 0

    def __enter__(self) -> Evaluator:
        return self

    def __exit__(self, *exc: object) -> None:
        if self._pool is not None:
            self._pool.stop()

    def run(self, tasks: Sequence[tuple[Template, int]]) -> list[SampleResult]:
        """The result of sample ``k`` of cell 0 of each ``(template, k)``; each result's ``sample``
        is the run's number in the search (counted from 0 over every call)."""
        if self.executor is not None:
            futures = [self.executor.submit(_one_run, t, k, self.options, self.expect) for t, k in tasks]
            out = [f.result() for f in futures]
        elif self.jobs == 1 or len(tasks) == 1:
            out = [_one_run(t, k, self.options, self.expect) for t, k in tasks]
        else:
            out = self._on_pool(tasks)
        numbered = [dataclasses.replace(r, sample=self.runs + i) for i, r in enumerate(out)]
        self.runs += len(numbered)
        return numbered

    def _on_pool(self, tasks: Sequence[tuple[Template, int]]) -> list[SampleResult]:
        if self._pool is None:
            self._pool = Workers(self.jobs, warm=_one_run)
        pool, limit = self._pool, None if self.options.timeout is None else self.options.timeout + 10.0
        out: list[SampleResult | None] = [None] * len(tasks)
        pending, running = list(enumerate(tasks)), dict[int, int]()
        while pending or running:
            for done in pool.collect(timeout=0 if pending and pool.ready else None):
                i = running.pop(done.ticket)
                if isinstance(done.error, WorkerLost):
                    pool.add()
                    out[i] = SampleResult(
                        0, 0, 0, tasks[i][0].parameters(0, 0), None, 0, 0.0, 0.0, error=f"internal error: {done.error}"
                    )
                else:
                    out[i] = done.value()
            while pending and pool.ready:
                i, (template, k) = pending.pop(0)
                running[pool.submit(_one_run, template, k, self.options, self.expect, limit=limit)] = i
        return [r for r in out if r is not None]


def _one_run(template: Template, k: int, options: SweepOptions, expect: Expect | None) -> SampleResult:
    """Sample ``k`` of cell 0, its expectations judged when ``expect`` is given (a task of the pool).
    With the search's ``budget`` (:class:`stackdsl.batch.sweep.Budget`), the run's timeout is at
    most what is left of it, and a run the budget ran out before is not made: its result is
    stopped (:data:`stackdsl.batch.sweep.BUDGET_SPENT`)."""
    if options.budget is not None:
        left = options.budget.left()
        if left <= 0:
            return SampleResult(0, k, 0, {}, None, 0, 0.0, 0.0, stopped=BUDGET_SPENT)
        options = dataclasses.replace(options, timeout=left if options.timeout is None else min(options.timeout, left))
    if expect is not None:
        return run_judged(template, 0, k, options, expect)
    return run_batch(template, 0, [k], options)[0]


def least_runs(spec: Threshold | Counterexample, jobs: int) -> int:
    """The runs a search makes however its runs turn out: a threshold search's both ends and the
    bisections that narrow its interval to the tolerance, ``2 + ceil(log2(width / tolerance))``
    (Brent's method takes no more on a margin it can interpolate); a counterexample search's
    first round (``jobs`` runs, at most its ``runs``). What ``--timeout`` must fit
    (:func:`within_time`). Source: stackdsl's own."""
    if isinstance(spec, Threshold):
        low, high = spec.ends
        return min(spec.runs, 2 + max(0, math.ceil(math.log2((high - low) / spec.step))))
    return min(spec.runs, max(1, jobs))


def within_time(template: Template, spec: Threshold | Counterexample, options: SweepOptions, jobs: int, timeout: float) -> None:
    """Refuse a search that cannot end within ``timeout``, the wall seconds ``--timeout`` gives the
    whole search: the runs it makes however they turn out (:func:`least_runs`), each by the
    compiler's estimate of sample 0's run (:attr:`stackdsl.Program.wall_estimate`), shared among
    ``jobs`` processes, past it (as ``check`` refuses a sweep:
    :func:`stackdsl.batch.check.within_budget`). The estimate is a floor; a search it lets through
    still stops when its budget runs out (:class:`stackdsl.batch.sweep.Budget`).

    Raises:
        ScenarioError: at the file's ``search``, with the runs, the estimate and the timeout.
    """
    from ..compile.compiler import compile_scenario

    program = compile_scenario(template.scenario(0, 0), options.mode, options.model, options.backend)
    runs = least_runs(spec, jobs)
    seconds = math.ceil(runs / max(1, jobs)) * program.wall_estimate
    if seconds > timeout:
        raise template.source.error(
            ("search",),
            f"this search makes at least {runs} run{'s' * (runs != 1)}, about {seconds:.3g} s of wall time by the "
            f"compiler's estimate ({program.wall_estimate:.2g} s a run), past --timeout {timeout:g} s, which bounds the "
            "whole search: give a wider tolerance or a longer --timeout",
        )


# --- threshold -------------------------------------------------------------------------------


def threshold_template(template: Template, value: Any) -> Template:
    """``template`` (whose grid is the one field searched) with that field at ``value`` (as a
    file writes it): one cell."""
    ((path, key, _),) = template.grid
    return dataclasses.replace(template, grid=((path, key, (value,)),))


def in_list(data: dict[str, Any], field: str) -> tuple[str, Callable[[Any], Any]] | None:
    """For a field that names one number of a list of numbers in ``data`` (``structure.bricks.0.at.0``,
    the x of a brick's position), the list's own key and a function putting a value in its place
    in a copy of the list; None for any other field (a grid key names it whole).

    >>> key, put = in_list({"structure": {"bricks": [{"at": [0, 0, "4 mm"]}]}}, "structure.bricks.0.at.0")
    >>> key, put("2 mm")
    ('structure.bricks.0.at', ['2 mm', 0, '4 mm'])
    """
    *head, last = grid_name(field).split(".")
    if not head or not last.isdigit():
        return None
    node: Any = data
    for seg in head:
        if isinstance(node, dict) and seg in node:
            node = node[seg]
        elif isinstance(node, list) and seg.isdigit() and int(seg) < len(node):
            node = node[int(seg)]
        else:
            return None
    i = int(last)
    if not isinstance(node, list) or i >= len(node) or any(isinstance(v, (dict, list)) for v in node):
        return None
    base = list(node)
    return ".".join(head), lambda value: [*base[:i], value, *base[i + 1 :]]


def written(value: float, unit: str) -> Any:
    """A number of ``unit`` as a file writes it: ``"24.000000001 mm"``, or the bare number."""
    return f"{value!r} {unit}" if unit else value


@dataclass
class ThresholdFound:
    """A threshold search's answer.

    Attributes:
        field, unit: the field searched and the unit of the numbers here (as ``between`` is written).
        probes: (value, result) of each run, in the order run.
        low, high: the interval holding the change: the nearest two values run with opposite
            verdicts (None: no change was found; ``message`` says why).
        below, above: the verdicts at ``low`` and ``high``.
        method: ``"brent"`` (the margin's root bracketed), ``"brent, then bisection on the
            verdict"``, or ``"bisection on the verdict"`` (Brent's method could not run).
        changes: how many times the verdict changes among the probes in value order (1 when it
            is monotone over them).
        widened: how far each end of the reported interval (:attr:`interval`) lies beyond
            ``low`` and ``high`` (numbers of ``unit``): the engine's tie band (:func:`tie_widening`).
        bad_input, error: a run refused as bad input or its internal error, else ``""``.
    """

    field: str
    unit: str
    probes: list[tuple[float, SampleResult]] = dataclasses.field(default_factory=list)
    low: float | None = None
    high: float | None = None
    below: str = ""
    above: str = ""
    method: str = "brent"
    changes: int = 0
    widened: tuple[float, float] = (0.0, 0.0)
    message: str = ""
    bad_input: str = ""
    error: str = ""

    @property
    def found(self) -> bool:
        return self.low is not None

    @property
    def runs(self) -> int:
        return len(self.probes)

    @property
    def interval(self) -> tuple[float, float] | None:
        """The interval reported: ``low`` and ``high`` moved out by :attr:`widened` (None: no change found)."""
        if self.low is None or self.high is None:
            return None
        return self.low - self.widened[0], self.high + self.widened[1]

    @property
    def width(self) -> float:
        """``high - low``; 0 when no change was found (nothing left to narrow)."""
        return 0.0 if self.low is None or self.high is None else self.high - self.low

    def grid_runs(self, step: float, ends: tuple[float, float]) -> int:
        """Runs a grid over ``ends`` with spacing ``step`` takes (both ends included): what a
        sweep would need to pin the change down as closely."""
        return math.floor((ends[1] - ends[0]) / step + 1e-9) + 1


class _Stop(Exception):
    """A probe with no verdict, or the runs spent: the search stops where it is."""


def find_threshold(
    template: Template,
    spec: Threshold,
    evaluator: Evaluator,
    progress: Callable[[str], None] = lambda line: None,
    value_of: Callable[[Any], Any] = lambda v: v,
    tie: float = 0.0,
) -> ThresholdFound:
    """Where the verdict changes along ``spec.field`` between ``spec.between``'s ends, to
    ``spec.step`` (the tolerance), in at most ``spec.runs`` runs (the module's description).
    ``template``: the file with a one-field grid on the field searched (its one value is replaced
    by each probe's, ``value_of`` the value as written: the whole list, for one number of a
    list, :func:`in_list`). ``progress`` is told one line a run. ``tie``: metres of signed margin
    within which the engine, not statics, decides the verdict (:func:`tie_band`): the reported
    interval's ends carry it (:func:`tie_widening`)."""
    from scipy.optimize import brentq

    low, high = spec.ends
    unit, step = spec.unit, spec.step
    found = ThresholdFound(spec.field, unit)

    def probe(values: Sequence[float]) -> list[SampleResult]:
        results = evaluator.run([(threshold_template(template, value_of(written(v, unit))), 0) for v in values])
        for v, r in zip(values, results):
            found.probes.append((v, r))
            margin = "" if r.margin is None else f", margin {r.margin * 1000:+.3f} mm"
            if r.still_margin is not None:  # the margin the search follows: the share of still's bound left
                margin = f", still's margin {r.still_margin:+.3f}"
            progress(f"run {len(found.probes)}: {spec.field} = {v:.6g} {unit}: {verdict_word(r)}{margin}".replace("  ", " "))
            if r.bad_input:
                found.bad_input = r.bad_input
            elif r.error:
                found.error = r.error
            if stands(r) is None:
                raise _Stop(f"the run at {v:.6g} {unit} has no verdict ({verdict_word(r)})".replace("  ", " "))
        return results

    def signed(r: SampleResult) -> float:
        if r.held is not None and r.still_margin is not None:  # continuous in the motion: Brent's method converges
            return max(r.still_margin, LEAST) if r.held else min(r.still_margin, -LEAST)
        if r.held is not None:  # the expectations' verdict alone: Brent's method bisects
            return 1.0 if r.held else -1.0
        margin = r.margin if r.margin is not None else 0.0
        return max(margin, LEAST) if stands(r) else min(margin, -LEAST)

    try:
        ends = probe([low, high])
    except _Stop as stop:
        found.message = str(stop)
        return found
    if stands(ends[0]) == stands(ends[1]):
        found.message = f"the verdict is the same at both ends ({verdict_word(ends[0])}): no change between them"
        _bracket(found)
        return found

    def margin_at(x: float) -> float:
        known = next((r for v, r in found.probes if v == x), None)
        if known is not None:  # Brent's method asks for both ends again
            return signed(known)
        if len(found.probes) >= spec.runs:
            raise _Stop(f"the runs were spent ({spec.runs})")
        return signed(probe([x])[0])

    try:
        brentq(margin_at, low, high, xtol=step * 0.99, rtol=4 * float(np.finfo(float).eps), maxiter=spec.runs)
    except _Stop as stop:
        found.message = str(stop)
    except (RuntimeError, ValueError) as exc:  # not converged in maxiter; a probe without a sign
        found.message = f"Brent's method stopped: {exc}"
    _bracket(found)
    bisected = False
    while not found.message and found.width > step and len(found.probes) < spec.runs:
        assert found.low is not None and found.high is not None
        bisected = True
        try:
            probe([(found.low + found.high) / 2])
        except _Stop as stop:
            found.message = str(stop)
        _bracket(found)
    if bisected:
        found.method = "brent, then bisection on the verdict"
    if found.found and found.width > step and not found.message:
        found.message = f"the runs were spent ({spec.runs}) before the interval was {step:g} {unit} wide"
    found.widened = tie_widening(found, tie)
    return found


def tie_band(mode: str, contact_margin: float) -> float:
    """Metres of signed margin within which a statics-decided verdict is the engine's to decide:
    in the extension mode, which decides near ties by statics on the placed geometry, the exact
    tie (:data:`stackdsl.runtime.support.EXACT_TIE`, 0.1 mm: a centre of mass that close to its
    support's edge, which statics cannot tell either); in the other modes also the engine's
    contact margin (``contact_margin``, :attr:`stackdsl.engines.protocol.EngineSettings.contact_margin`,
    1 mm on pybullet: its contact points tip or keep such a brick). Source: stackdsl's own."""
    from ..runtime.support import EXACT_TIE

    return EXACT_TIE if mode == "extension" else max(EXACT_TIE, contact_margin)


def tie_widening(found: ThresholdFound, tie: float) -> tuple[float, float]:
    """How far to move each end of ``found``'s interval out (numbers of its unit) so that it holds
    statics' boundary (where the signed margin of the parts as placed crosses zero: the closed
    form) although the engine decides verdicts within ``tie`` metres of it either way
    (:func:`tie_band`): the field's width of the band, ``tie / slope``, the slope of the signed
    margin along the field from the two stands nearest the interval whose margins differ by at
    least ``tie`` (a stand's margin is its certificate's, continuous and nearly linear where
    statics decides). An end is moved when its run could lie in the band: a stand with a margin
    under ``tie``, or any collapse (a collapse's margin is how far its proof went past its limit,
    not its placed margin, when it was placed inside). Nothing is moved (0, 0) when no change
    was found, ``tie`` is 0, the runs' expectations were judged (the verdict is not statics'), or
    no slope shows (a flat margin: not a statics-decided boundary). Source: stackdsl's own.

    Example: MuJoCo's single-file stack tipped at 23.9991 mm, its centre of mass 0.002 mm inside
    the edge; with a slope of 2.5 (60 mm - 5 s / 2) and a 0.1 mm band the end moves 0.04 mm out.
    """
    low, high = found.low, found.high
    if low is None or high is None or tie <= 0 or any(r.held is not None for _, r in found.probes):
        return 0.0, 0.0
    kept = sorted(
        ((v, r.margin) for v, r in found.probes if stands(r) and r.margin is not None),
        key=lambda p: min(abs(p[0] - low), abs(p[0] - high)),
    )
    slope = None
    for (a, ma), (b, mb) in itertools.combinations(kept, 2):  # the nearest pair whose margins differ by the band
        if abs(ma - mb) >= tie and a != b:
            slope = abs(ma - mb) / abs(a - b)
            break
    if slope is None:
        return 0.0, 0.0
    band = tie / slope
    ends = {v: r for v, r in found.probes}

    def moved(v: float) -> float:
        r = ends[v]
        could_tie = not stands(r) or r.margin is None or r.margin < tie
        return band if could_tie else 0.0

    return moved(low), moved(high)


def _bracket(found: ThresholdFound) -> None:
    """The nearest two probes with opposite verdicts (the narrowest such adjacent pair in value
    order), and how many times the verdict changes in that order."""
    decided = sorted(((v, r) for v, r in found.probes if stands(r) is not None), key=lambda p: p[0])
    pairs = [(a, b) for a, b in itertools.pairwise(decided) if stands(a[1]) != stands(b[1])]
    found.changes = len(pairs)
    if not pairs:
        found.low = found.high = None
        return
    (a, ra), (b, rb) = min(pairs, key=lambda p: p[1][0] - p[0][0])
    found.low, found.high, found.below, found.above = a, b, verdict_word(ra), verdict_word(rb)


# --- counterexample --------------------------------------------------------------------------


def expects_stand(scenario: Scenario) -> bool | None:
    """Whether the file expects its structure to stand (True), to collapse (False), or neither
    is read from its expectation (None): ``stands: true`` or a lower bound on P(stands)
    (``'>= 0.99'``) expect a stand; one run's ``collapse`` level or an upper bound on P(stands)
    (``'<= 0.1'``) a collapse; P(stands) within a tolerance, or statistics of the level alone,
    neither."""
    expect: Expect = scenario.expect
    if expect.stands:
        return True
    if expect.collapse is not None and not expect.statistical:
        return False
    p = expect.p_stands
    if p is not None and p.op in (">=", ">"):
        return True
    if p is not None and p.op in ("<=", "<"):
        return False
    return None


def searched(template: Template) -> list[Distribution]:
    """The distributions a counterexample search varies: those drawn once a sample that no grid
    field replaces (per-layer and per-brick draws keep sample 0's)."""
    grid = [path for path, _, _ in template.grid]
    return [d for d in template.distributions if d.per == "sample" and not any(d.path[: len(p)] == p for p in grid)]


def centre(d: Distribution) -> Any:
    """Where a draw of ``d`` is simplest, as a file writes it: a uniform's middle, a normal's mean
    (within its clip), a choice's first item."""
    if d.kind == "choice":
        return d.values[0]
    if d.kind == "uniform":
        return _as_written(d, (d.values[0] + d.values[1]) / 2)
    mean, _, low, high = d.values
    return _as_written(d, min(max(mean, low), high))


def _as_written(d: Distribution, x: float) -> Any:
    return f"{float(x)!r} {d.unit}" if d.unit else float(x)


def _number(value: Any) -> float:
    """A uniform's or normal's value, as a file writes it, as a number of its unit."""
    if isinstance(value, str):
        return float(value.split()[0])
    return float(value)


def pinned(template: Template, values: dict[Distribution, Any]) -> Template:
    """``template`` with each distribution of ``values`` giving that value (as a file writes it)."""
    return dataclasses.replace(
        template,
        distributions=tuple(dataclasses.replace(d, pinned=(values[d],)) if d in values else d for d in template.distributions),
    )


@dataclass
class Found:
    """A counterexample: its values (distribution -> value as written), its run, and after
    shrinking the simplest values that still break the expectation with their run."""

    values: dict[Distribution, Any]
    result: SampleResult
    shrunk: dict[Distribution, Any] = field(default_factory=dict)
    shrunk_result: SampleResult | None = None
    first_run: int = 0


@dataclass
class CounterexamplesFound:
    """A counterexample search's answer: what it found, every run (its ``runs`` in the order run),
    how many runs the search itself took before the first counterexample (``first``, 1-based; None
    when none was found) and how many shrinking took; ``spent``: the search's time budget ran out."""

    found: list[Found] = field(default_factory=list)
    results: list[SampleResult] = field(default_factory=list)
    first: int | None = None
    search_runs: int = 0
    shrink_runs: int = 0
    bad_input: str = ""
    error: str = ""
    spent: bool = False
    outside: int = 0  # proposals no draw of the others made meet the file's require: (not run)


#: Draws of the other distributions tried before a proposal counts as outside ``require:``.
REQUIRE_TRIES = 20


def _meets(template: Template, values: dict[Distribution, Any], parsed: dict[tuple[str, ...], list[Any]]) -> bool:
    """Whether ``values`` (a proposal of the searched distributions) can meet the file's
    ``require:``: one of :data:`REQUIRE_TRIES` draws of the rest does, as a sweep's sample is
    drawn again until it does."""
    t = pinned(template, values)
    return any(meets_require(t.scenario(0, 0, attempt=a), parsed) for a in range(REQUIRE_TRIES))


def find_counterexamples(
    template: Template,
    spec: Counterexample,
    want_stand: bool,
    evaluator: Evaluator,
    seed: int,
    progress: Callable[[str], None] = lambda line: None,
    batch: int = 1,
) -> CounterexamplesFound:
    """Search ``template``'s distributions drawn once a sample (:func:`searched`) for runs whose
    verdict is the one the file does not expect (``want_stand``: a stand is sought; else a
    collapse), Optuna's TPE sampler (seeded by ``seed``) minimising the signed margin oriented so;
    ``batch`` runs a round. Stops at ``spec.find`` counterexamples or ``spec.runs`` runs, then
    shrinks each (:func:`shrink`) in at most ``spec.shrink`` runs.

    Raises:
        ScenarioError: no distribution to search (at the file).
        ImportError: Optuna is not installed (the ``search`` extra).
    """
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    ds = searched(template)
    if not ds:
        raise ScenarioError(
            "a counterexample search varies the distributions drawn once a sample, and this file has none",
            file=template.source.file,
        )
    sign = -1.0 if want_stand else 1.0  # minimised: negative when the verdict sought is reached
    sampler = optuna.samplers.TPESampler(seed=seed, n_startup_trials=min(10, max(2, spec.runs // 10)), multivariate=True)
    study = optuna.create_study(direction="minimize", sampler=sampler)
    out = CounterexamplesFound()
    parsed: dict[tuple[str, ...], list[Any]] = {}  # the file's require:, parsed once
    names = {d: f"{i}:{d.label}" for i, d in enumerate(ds)}
    while len(out.found) < spec.find and out.search_runs < spec.runs and not out.spent:
        if (step := secant_step(study, ds, names)) is not None:
            study.enqueue_trial(step, skip_if_exists=True)
        trials = [study.ask() for _ in range(min(batch, spec.runs - out.search_runs))]
        proposals = [{d: _suggest(t, names[d], d) for d in ds} for t in trials]
        if "require" in template.data:  # a proposal no draw makes meet require: is not run, and counts as a run
            kept = [_meets(template, values, parsed) for values in proposals]
            for trial, ok in zip(trials, kept):
                if not ok:
                    study.tell(trial, state=optuna.trial.TrialState.FAIL)
                    out.search_runs += 1
                    out.outside += 1
                    progress(f"proposal {out.search_runs}: fails require:, not run")
            trials = [t for t, ok in zip(trials, kept) if ok]
            proposals = [v for v, ok in zip(proposals, kept) if ok]
            if not trials:
                continue
        results = evaluator.run([(pinned(template, values), 0) for values in proposals])
        for trial, values, result in zip(trials, proposals, results):
            out.results.append(result)
            out.search_runs += 1
            verdict = stands(result)
            if result.stopped == BUDGET_SPENT:
                out.spent = True
            if verdict is None:
                study.tell(trial, state=optuna.trial.TrialState.FAIL)
                out.bad_input = out.bad_input or result.bad_input
                out.error = out.error or result.error
                progress(f"run {result.sample + 1}: {verdict_word(result)}")
                continue
            assert result.margin is not None
            study.tell(trial, sign * (max(result.margin, LEAST) if verdict else min(result.margin, -LEAST)))
            hit = verdict == want_stand
            progress(
                f"run {result.sample + 1}: {verdict_word(result)}, margin {result.margin * 1000:+.3f} mm{'  COUNTEREXAMPLE' if hit else ''}"
            )
            if hit and len(out.found) < spec.find:
                out.found.append(Found(values, result, first_run=out.search_runs))
                out.first = out.first or out.search_runs
    for f in out.found:
        f.shrunk, f.shrunk_result, made = shrink(template, f.values, f.result, want_stand, evaluator, spec.shrink, progress)
        out.shrink_runs += len(made)
        out.results.extend(made)
    return out


#: How far past the margin's root a secant step aims, as a share of the step (a run exactly on
#: the boundary is a tie: past it, the verdict sought is proved).
OVERSHOOT = 0.2


def secant_step(study: Any, ds: Sequence[Distribution], names: dict[Distribution, str]) -> dict[str, Any] | None:
    """A proposal the signed margin itself makes (Optuna's trial parameters, to enqueue), or None:
    of the completed trials, the best two that draw the same choices and differ in the numbers
    (a uniform's or normal's value), the straight line through their margins extended to where it
    crosses zero and :data:`OVERSHOOT` of its step beyond, each number kept within its range.
    Where statics decides, the margin is close to linear in each number, so one step lands on the
    verdict sought; where it is flat (a margin another direction bounds), no step is made.
    Source: stackdsl's own (the secant method on the margin)."""
    import optuna

    done = sorted((t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE), key=lambda t: t.value)
    numbers = [d for d in ds if d.kind != "choice"]
    if len(done) < 2 or not numbers:
        return None
    best = done[0]
    for other in done[1:]:
        if any(best.params[names[d]] != other.params[names[d]] for d in ds if d.kind == "choice"):
            continue
        v1, v2 = best.value, other.value
        if v2 - v1 <= 1e-12:
            continue
        t = v1 / (v2 - v1) * (1 + OVERSHOOT)  # along best - other, from best: v1 + t (v1 - v2) = -OVERSHOOT v1
        step = dict(best.params)
        moved = False
        for d in numbers:
            a, b = best.params[names[d]], other.params[names[d]]
            low, high = best.distributions[names[d]].low, best.distributions[names[d]].high
            x = min(max(a + t * (a - b), low), high)
            moved = moved or abs(x - a) > 1e-12 * max(1.0, abs(a))
            step[names[d]] = x
        if moved:
            return step
        return None
    return None


def _suggest(trial: Any, name: str, d: Distribution) -> Any:
    """Optuna's proposal for ``d``, as a file writes it: a uniform over its ends less
    :data:`stackdsl.lang.distributions.INSIDE` of its width at each, a normal over its
    clip or 4 standard deviations about its mean, whichever is narrower, a choice by its index."""
    if d.kind == "choice":
        return d.values[trial.suggest_categorical(name, list(range(len(d.values))))]
    if d.kind == "uniform":  # its ends themselves are degenerate draws (Distribution.bounds): kept out
        low, high = d.values
        low, high = low + INSIDE * (high - low), high - INSIDE * (high - low)
    else:
        mean, sd, clip_low, clip_high = d.values
        low, high = max(mean - 4 * sd, clip_low), min(mean + 4 * sd, clip_high)
    return _as_written(d, trial.suggest_float(name, float(low), float(high)))


#: Runs shrinking spends on one distribution at most: its centre, then halving the way there.
SHRINK_STEPS = 6


def shrink(
    template: Template,
    values: dict[Distribution, Any],
    result: SampleResult,
    want_stand: bool,
    evaluator: Evaluator,
    runs: int,
    progress: Callable[[str], None] = lambda line: None,
) -> tuple[dict[Distribution, Any], SampleResult, list[SampleResult]]:
    """The counterexample ``values`` (whose run is ``result``) moved towards the simplest that
    still breaks the expectation, in at most ``runs`` runs: for each distribution in file order,
    its :func:`centre` is tried, then (a number) halfway from where it is towards the nearest
    value known to break nothing, up to :data:`SHRINK_STEPS` runs a distribution, each move kept
    when the run's verdict is still the one sought. Returns the values, their run and the runs
    made."""
    best, best_result, made = dict(values), result, list[SampleResult]()
    for d in values:
        target = centre(d)
        if best[d] == target:
            continue
        far = target  # the nearest value to the centre known to break nothing (or not yet tried)
        for attempt in range(SHRINK_STEPS):
            if len(made) >= runs:
                return best, best_result, made
            if attempt == 0:
                candidate = target
            elif d.kind == "choice":
                break
            else:
                here, there = _number(best[d]), _number(far)
                if math.isclose(here, there, rel_tol=1e-9, abs_tol=1e-12):
                    break
                candidate = _as_written(d, (here + there) / 2)
            trial = {**best, d: candidate}
            (run,) = evaluator.run([(pinned(template, trial), 0)])
            made.append(run)
            progress(f"shrink {len(made)}: {d.label} = {candidate}: {verdict_word(run)}")
            if run.stopped == BUDGET_SPENT:
                return best, best_result, made
            if stands(run) == want_stand:
                best, best_result = trial, run
                if attempt == 0:
                    break
            else:
                far = candidate
    return best, best_result, made


def counterexample_file(template: Template, values: dict[Distribution, Any], expect: Expect, want_stand: bool, note: str) -> str:
    """A plain scenario file (YAML text) of ``template``'s sample 0 with ``values`` fixed: the
    drawn values written in, no ``sweep``, ``search`` or ``require``, and one run's expectation:
    the file's own when it is one run's, else the one its statistics stand for (``stands: true``
    for a lower bound on P(stands); ``collapse: 500±499``, any level, for an upper bound), so that
    ``stackdsl run`` of it fails as the search's run did. ``note`` opens its description."""
    from ..lang.yaml_out import yaml_text

    data = pinned(template, values).plain(0, 0)  # the sample's own plain data, the values put in
    data = {k: v for k, v in data.items() if k not in ("sweep", "search", "require")}
    if expect.statistical:
        data["expect"] = {"collapse": "500±499"} if want_stand else {"stands": True}
    data["description"] = note + ("\n" + str(data["description"]) if data.get("description") else "")
    return yaml_text(data)

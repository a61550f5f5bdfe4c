"""``stackdsl bench verdicts``: each setting's verdicts on random assemblies against the oracle.

Assembly ``k`` is drawn from ``SeedSequence(seed, spawn_key=(k,))`` (:mod:`stackdsl.verdicts.assemblies`),
judged by rigid-block equilibrium brick by brick in placing order, and run in every
:class:`Setting` of the plan: raw and tuned pybullet, tuned MuJoCo, and the extension with
each stability model on each engine, the extension at each drop gap of :data:`GAPS` (the
others at the scenario's, 0.5 mm). One task runs every setting and gap of one assembly. A run
agrees with the oracle when it gives the same collapse level (or both say it stands).
Agreement is reported over every assembly, over those whose oracle margin exceeds
:data:`MARGIN` (a verdict that a smaller move of the centres of mass would flip is one no
simulation can be held to), over those from :data:`NEAR` to :data:`MARGIN`, and above the
margin for the assemblies without and with a leaning brick apart. A run that says the
structure stands while a structure brick is still simulated by the engine at its end (state
``active`` in the final brick graph) is counted per setting: the target is none. The
misjudged assemblies are written out as scenario files.

:func:`run_single_file` runs the random single-file stack (``sweeps/random_single_file.yaml``,
:data:`SINGLE_FILE`) in the extension settings and compares each sample's collapse level with
the exact centre-of-mass rule of :mod:`stackdsl.bench.random_stack` (the harmonic stack's condition)
on its placed centres, listing every disagreement with the sample's margin
(:func:`exact_margin`).

Units: metres and seconds in code; the tables print millimetres. Source: stackdsl's own.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ..lang.schema import Scenario

#: Metres: the oracle margin above which a setting must agree, and the lower end of the
#: near-tie column (from NEAR to MARGIN).
MARGIN = 0.001
NEAR = 0.0002
#: Metres: a margin under this is an exact tie (the certificate's own near-tie width: a brick
#: within 0.1 mm of its support's edge).
EXACT_TIE = 0.0001
#: Metres: the drop gaps the extension settings run at (the scenario's own is 0.5 mm).
GAPS: tuple[float, ...] = (0.0, 0.0005, 0.001, 0.002)
DEFAULT_GAP = 0.0005
ENGINES: tuple[str, ...] = ("pybullet", "mujoco")
#: Wall seconds a run may take.
TIMEOUT = 60.0
#: The journal's name in the output folder (:class:`Journal`).
JOURNAL = "assemblies.jsonl"


@dataclass(frozen=True)
class Setting:
    """How one run goes: its table name, mode, stability model and engine (backend)."""

    name: str
    mode: str
    model: str
    backend: str

    @property
    def extension(self) -> bool:
        """Whether the stability extension runs (it is what the drop gaps and the
        "stands with an active brick" count are about)."""
        return self.mode == "extension"


#: Every setting, in table order.
SETTINGS: dict[str, Setting] = {
    s.name: s
    for s in (
        Setting("raw pybullet", "raw", "report", "pybullet"),
        Setting("tuned pybullet", "tuned", "report", "pybullet"),
        Setting("tuned mujoco", "tuned", "report", "mujoco"),
        Setting("ext report pybullet", "extension", "report", "pybullet"),
        Setting("ext equilibrium pybullet", "extension", "equilibrium", "pybullet"),
        Setting("ext report mujoco", "extension", "report", "mujoco"),
        Setting("ext equilibrium mujoco", "extension", "equilibrium", "mujoco"),
    )
}

#: (setting name, drop gap in metres) pairs to run.
Plan = tuple[tuple[str, float], ...]

#: The families ``stackdsl bench verdicts --families`` chooses from: the random assemblies, the
#: random single-file stack (here), the near ties (:mod:`stackdsl.bench.near_tie`) and the
#: shake table (:mod:`stackdsl.bench.shake_family`).
FAMILIES: tuple[str, ...] = ("assemblies", "single-file", "near-tie", "shake")


def family_settings(engines: Sequence[str] = ENGINES, baselines: bool = True) -> list[str]:
    """The settings a family of samples runs in (each at the scenario's own drop gap): the
    extension settings of ``engines`` and, with ``baselines``, their raw and tuned settings,
    in table order."""
    return [n for n, s in SETTINGS.items() if s.backend in engines and (baselines or s.extension)]


def plan(engines: Sequence[str] = ENGINES, gaps: Sequence[float] = GAPS, baselines: bool = True) -> Plan:
    """The runs of each assembly: the extension settings of ``engines`` at each of ``gaps``,
    and with ``baselines`` the raw and tuned settings of ``engines`` at :data:`DEFAULT_GAP`.

    Raises:
        ValueError: an unknown engine, no engine, or no gap.
    """
    unknown = [e for e in engines if e not in ENGINES]
    if unknown or not engines:
        raise ValueError(f"engines are some of {', '.join(ENGINES)}, not {', '.join(unknown) or 'none'}")
    if not gaps:
        raise ValueError("give at least one drop gap")
    out: list[tuple[str, float]] = []
    for s in SETTINGS.values():
        if s.backend not in engines:
            continue
        if s.extension:
            out += [(s.name, float(g)) for g in gaps]
        elif baselines:
            out.append((s.name, DEFAULT_GAP))
    return tuple(out)


@dataclass(frozen=True)
class Run:
    """One run: its setting's name and drop gap (m), collapse level (None: stands), wall time
    (s), the structure bricks still ``active`` in its final brick graph, and an internal error
    or the reason it stopped early ('' when it ran to its end); ``certified``: its verdict has a
    certificate (:class:`stackdsl.Certificate`; a "stands" one of rigid-block equilibrium);
    ``tie``: the certificate's words when it calls the verdict a near tie
    (:func:`stackdsl.verdicts.golden_compare.near_tie`), else ''; ``proof``: how the
    certificate proves a collapse (its kind, as "off its support"), else ''; ``margin``: a
    "stands" certificate's margin (m, :attr:`stackdsl.Certificate.margin_mm`), else None."""

    setting: str
    gap: float
    level: int | None
    wall: float
    active: tuple[str, ...] = ()
    error: str = ""
    certified: bool = True
    tie: str = ""
    proof: str = ""
    margin: float | None = None

    @property
    def stands_active(self) -> bool:
        """It says the structure stands while a structure brick is still simulated at the end."""
        return not self.error and self.level is None and bool(self.active)


@dataclass(frozen=True)
class Verdicts:
    """One assembly: its index, file text, bricks, whether a brick leans (is placed tilted),
    the oracle's level (None: stands) and margin (m), and its runs; ``error``: an internal
    error that kept it from being drawn, judged or run, else ''."""

    index: int
    text: str
    bricks: int
    leaning: bool
    oracle: int | None
    margin: float
    runs: tuple[Run, ...]
    error: str = ""
    friction: float = 0.0

    @property
    def friction_tie(self) -> bool:
        """A step that stands needs nearly all of its friction
        (:attr:`stackdsl.verdicts.assemblies.Judgement.friction_tie`): a tie the margin does not
        measure, banded as one (:attr:`band_margin`)."""
        from ..verdicts.assemblies import FRICTION_TIE

        return self.friction >= FRICTION_TIE

    @property
    def band_margin(self) -> float:
        """Metres: the margin its agreement band is chosen by, 0 for a friction tie."""
        return 0.0 if self.friction_tie else self.margin

    def run(self, setting: str, gap: float) -> Run | None:
        """The run of ``setting`` at ``gap`` (m), or None."""
        return next((r for r in self.runs if r.setting == setting and abs(r.gap - gap) < 1e-9), None)


def run_setting(scenario: Scenario, setting: Setting, gap: float, timeout: float = TIMEOUT) -> Run:
    """Compile ``scenario`` in ``setting`` with the drop gap ``gap`` (m, put in its ``timing``)
    and run it for at most ``timeout`` wall seconds; an internal error is the run's ``error``,
    not an exception."""
    from ..compile.compiler import compile_scenario
    from ..runtime.run import run_program
    from ..verdicts.golden_compare import near_tie

    try:
        timing = scenario.timing.model_copy(update={"drop_gap": gap})
        program = compile_scenario(scenario.model_copy(update={"timing": timing}), setting.mode, setting.model, setting.backend)
        outcome = run_program(program, timeout=timeout)
    except Exception as exc:  # this run's internal error, reported with it
        message = (str(exc).splitlines() or [""])[0]
        return Run(setting.name, gap, None, 0.0, error=f"{type(exc).__name__}: {message}")
    active = tuple(n.id for n in outcome.final_graph.nodes if n.state == "active" and n.level is not None)
    level = outcome.collapse.level if outcome.collapse else None
    c = outcome.certificate
    certified = c is not None and (c.verdict == "collapse" if level is not None else c.kind == "equilibrium")
    proof = c.kind if c is not None and level is not None else ""
    margin = c.margin_mm / 1000 if c is not None and c.margin_mm is not None and level is None else None
    return Run(
        setting.name,
        gap,
        level,
        outcome.wall_time,
        active,
        outcome.stopped or "",
        certified,
        near_tie(outcome, program),
        proof,
        margin,
    )


def verdicts(seed: int, index: int, runs: Plan | None = None) -> Verdicts:
    """Draw, judge and run assembly ``index`` of ``seed`` in every (setting, gap) of ``runs``
    (default: :func:`plan`'s); a worker's task."""
    from ..compile.compiler import compile_scenario
    from ..lang.loader import parse_scenario
    from ..verdicts.assemblies import assembly, judge
    from ..verdicts.oracle import _flat

    runs = plan() if runs is None else runs
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index,)))
    text = ""
    try:
        text = assembly(rng, f"assembly {seed}-{index}")
        scenario = parse_scenario(text, f"assembly_{index}.yaml")
        program = compile_scenario(scenario)
        oracle = judge(program)
    except Exception as exc:  # this assembly's internal error, reported with it
        return Verdicts(index, text, 0, False, None, 0.0, (), f"{type(exc).__name__}: {exc}")
    leaning = not all(_flat(p) for p in program.placements)
    done = tuple(run_setting(scenario, SETTINGS[name], gap) for name, gap in runs)
    return Verdicts(
        index, text, len(program.placements), leaning, oracle.collapse_level, oracle.margin, done, "", oracle.friction
    )


def run_verdicts(
    seed: int,
    count: int,
    jobs: int,
    each: Callable[[Verdicts], None] = lambda v: None,
    runs: Plan | None = None,
    done: dict[int, Verdicts] | None = None,
) -> list[Verdicts]:
    """Assemblies 0 to ``count - 1`` of ``seed`` on ``jobs`` processes, in index order; each
    runs ``runs`` (default: :func:`plan`'s). Those in ``done`` (index -> verdicts: a journal's,
    :class:`Journal`) are not run again. A task whose worker dies is that assembly's error."""
    from ..batch.pool import WorkerLost, fan_out

    runs = plan() if runs is None else runs
    done = done or {}
    tasks = [(seed, k, runs) for k in range(count) if k not in done]

    def lost(task: tuple[Any, ...], error: WorkerLost) -> Verdicts:
        return Verdicts(task[1], "", 0, False, None, 0.0, (), f"worker lost: {error}")

    results: list[Verdicts] = [v for k, v in done.items() if k < count]
    iterator: Iterator[Verdicts] = fan_out(verdicts, tasks, [0.3 * len(runs)] * len(tasks), jobs, here=False, lost=lost)
    for v in iterator:
        results.append(v)
        each(v)
    return sorted(results, key=lambda v: v.index)


class Journal:
    """The assemblies a run has finished, one JSON line each in ``path`` after a header line
    (the seed, the plan and a digest of stackdsl's source), so that a run stopped part way
    resumes where it stopped: ``stackdsl bench verdicts --out DIR`` again. The journal of
    another seed, plan or source is refused, so that one table never mixes two programs'
    verdicts.

    Raises:
        ValueError: ``path`` holds another run's journal, or a line that is not one.
        OSError: it cannot be read or written.

    Source: stackdsl's own.
    """

    def __init__(self, path: Path, seed: int, runs: Plan) -> None:
        self.path = path
        self.header = {"seed": seed, "plan": [list(r) for r in runs], "source": source_digest()}

    def load(self) -> dict[int, Verdicts]:
        """The finished assemblies, by index (none when there is no journal yet)."""
        if not self.path.exists():
            return {}
        lines = self.path.read_text(encoding="utf-8").splitlines()
        try:
            header = json.loads(lines[0]) if lines else None
            if header != self.header:
                raise ValueError(f"{self.path} holds the runs of another seed, plan or source of stackdsl: give another --out")
            out = {}
            for line in lines[1:]:
                fields = json.loads(line)
                fields["runs"] = tuple(Run(**{**r, "active": tuple(r["active"])}) for r in fields["runs"])
                out[fields["index"]] = Verdicts(**fields)
        except (json.JSONDecodeError, TypeError, KeyError) as exc:
            raise ValueError(f"{self.path} is not a journal of stackdsl bench verdicts: {exc}") from None
        return out

    def add(self, v: Verdicts) -> None:
        """Append one finished assembly (the header first, into a new journal)."""
        new = not self.path.exists()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with self.path.open("a", encoding="utf-8") as f:
            if new:
                f.write(json.dumps(self.header) + "\n")
            f.write(json.dumps(dataclasses.asdict(v)) + "\n")


def source_digest() -> str:
    """A SHA-256 (16 hex digits) of the Python source that decides a verdict: the ``stability``
    package and stackdsl's language, compiler, engines, runtime and oracle (not the commands,
    the benches or the drawings, which only show it). The same for the same code, wherever it
    is installed."""
    import stability
    import stackdsl

    assert stability.__file__ is not None and stackdsl.__file__ is not None, "packages with an __init__.py"
    here = Path(stackdsl.__file__).parent
    roots = [Path(stability.__file__).parent, *(here / p for p in ("lang", "compile", "engines", "runtime", "verdicts"))]
    digest = hashlib.sha256()
    for root in roots:
        for f in sorted(root.rglob("*.py")):
            digest.update(f"{root.name}/{f.relative_to(root)}".encode() + b"\0" + f.read_bytes())
    return digest.hexdigest()[:16]


def agrees(v: Verdicts, setting: str, gap: float = DEFAULT_GAP) -> bool:
    """The run's collapse level is the oracle's (both None: both stand); False without a run."""
    r = v.run(setting, gap)
    return r is not None and not r.error and r.level == v.oracle


@dataclass(frozen=True)
class Row:
    """One (setting, gap) row of the agreement table: for each subset of assemblies,
    (agreeing runs, runs), runs with an error or a stop left out; ``stands_active``: runs
    that say "stands" with a structure brick still active at the end; ``uncertified``: runs
    whose verdict has no certificate; ``errors``: runs with an error or stopped early;
    ``wall``: median wall seconds a run."""

    setting: str
    gap: float
    every: tuple[int, int]
    sure: tuple[int, int]
    near: tuple[int, int]
    flat: tuple[int, int]
    leaning: tuple[int, int]
    stands_active: int
    errors: int
    wall: float
    uncertified: int = 0


def rows(results: Sequence[Verdicts], runs: Plan) -> list[Row]:
    """The agreement table's rows, one per (setting, gap) of ``runs``, counted from the runs."""
    good = [v for v in results if not v.error]
    sure = [v for v in good if v.band_margin > MARGIN]
    near = [v for v in good if NEAR < v.band_margin <= MARGIN]

    def count(subset: Sequence[Verdicts], name: str, gap: float) -> tuple[int, int]:
        ran = [v for v in subset if (r := v.run(name, gap)) is not None and not r.error]
        return sum(agrees(v, name, gap) for v in ran), len(ran)

    out = []
    for name, gap in runs:
        mine = [r for v in good if (r := v.run(name, gap)) is not None]
        out.append(
            Row(
                name,
                gap,
                count(good, name, gap),
                count(sure, name, gap),
                count(near, name, gap),
                count([v for v in sure if not v.leaning], name, gap),
                count([v for v in sure if v.leaning], name, gap),
                sum(r.stands_active for r in mine),
                sum(bool(r.error) for r in mine),
                float(np.median([r.wall for r in mine if not r.error] or [0.0])),
                sum(not r.error and not r.certified for r in mine),
            )
        )
    return out


def _cell(pair: tuple[int, int]) -> str:
    agree, total = pair
    return f"{agree:>4}/{total:<4} {agree / total:>4.0%}" if total else f"{'-':>9}     "


def format_verdicts(results: list[Verdicts], out: Path | None, seconds: float, runs: Plan | None = None) -> str:
    """The agreement table of ``runs`` (default: :func:`plan`'s), and the misjudged assemblies
    with a margin above :data:`NEAR` (written to ``out`` as scenario files when it is given),
    each with its proof and the certificate's near-tie words."""
    runs = plan() if runs is None else runs
    from ..verdicts.assemblies import FRICTION_TIE

    good = [v for v in results if not v.error]
    sure = [v for v in good if v.band_margin > MARGIN]
    near = [v for v in good if NEAR < v.band_margin <= MARGIN]
    stands = sum(v.oracle is None for v in good)
    leaning = sum(v.leaning for v in good)
    lines = [
        f"{len(results)} random assemblies ({stands} stand by the oracle, {leaning} with a leaning brick), "
        f"{len(sure)} with an oracle margin above {MARGIN * 1000:g} mm ({sum(v.leaning for v in sure)} leaning), "
        f"{len(near)} from {NEAR * 1000:g} to {MARGIN * 1000:g} mm, {sum(v.friction_tie for v in good)} friction ties "
        f"(a step that stands needs {FRICTION_TIE:.0%} or more of its friction: banded with the ties); {seconds:.0f} s wall",
        "agreement with the oracle, agreeing/runs: every assembly; margin > 1 mm; margin 0.2-1 mm; margin > 1 mm "
        "without and with a leaning brick. 'stand+active': stands with a structure brick still active at the end; "
        "'no cert.': a verdict without its certificate",
        f"{'setting':<25} {'gap':>6}  {'all':^14} {'margin > 1 mm':^14} {'0.2-1 mm':^14} {'flat, > 1 mm':^14} "
        f"{'leaning, > 1':^14} {'stand+active':>12} {'no cert.':>8} {'errors':>6} {'median wall':>11}",
    ]
    for row in rows(results, runs):
        active = f"{row.stands_active:>12}" if SETTINGS[row.setting].extension else f"{'(no ext.)':>12}"
        lines.append(
            f"{row.setting:<25} {row.gap * 1000:>3.1f} mm  {_cell(row.every)} {_cell(row.sure)} {_cell(row.near)} "
            f"{_cell(row.flat)} {_cell(row.leaning)} {active} {row.uncertified:>8} {row.errors:>6} {row.wall * 1000:>8.0f} ms"
        )
    wrong = [
        (v, name, gap)
        for v in good
        if v.band_margin > NEAR
        for name, gap in runs
        if (r := v.run(name, gap)) and not r.error and not agrees(v, name, gap)
    ]
    if wrong:
        lines.append(
            f"misjudged (margin above {NEAR * 1000:g} mm): assembly, setting, gap, measured (proof), oracle, margin; "
            "the certificate's words"
        )
    written: set[int] = set()
    for v, name, gap in wrong:
        where = ""
        if out is not None:
            path = out / f"assembly_{v.index:04d}.yaml"
            if v.index not in written:
                out.mkdir(parents=True, exist_ok=True)
                path.write_text(v.text)
                written.add(v.index)
            where = f"  {path.name}"
        r = v.run(name, gap)
        lean = ", leaning" if v.leaning else ""
        proof = f" ({r.proof})" if r and r.proof else ""
        tie = f"; {r.tie}" if r and r.tie else ""
        lines.append(
            f"  {v.index:4d}  {name:<25} {gap * 1000:.1f} mm  {_level(r.level if r else None)}{proof} (oracle {_level(v.oracle)}), "
            f"margin {v.margin * 1000:.2f} mm{lean}{where}{tie}"
        )
    if not wrong:
        lines.append(f"no assembly with a margin above {NEAR * 1000:g} mm misjudged: no files written")
    elif out is not None:
        lines.append(f"(their files are in {out})")
    lines += _stands_active([(f"{v.index:4d}", r) for v in good for r in v.runs])
    failed = [line for v in results for line in _failures(f"{v.index:4d}", v.error, v.runs, at_gap=True)]
    return "\n".join(lines + (["runs that stopped with an internal error:", *failed] if failed else []))


#: Metres: the half-width of a KAPLA brick, the margin of a single file of bricks across it
#: (every brick of the single-file stacks is centred on y = 0).
HALF_WIDTH = 0.012
#: Metres: how far below the true margin a certificate's margin may be.
MARGIN_SLACK = 0.0005


def certificate_margins(pairs: Sequence[tuple[str, float, Run]], settings: Sequence[str]) -> list[str]:
    """Each setting's "stands" certificate margins against the true margins of ``pairs``
    ((label, true margin in m, run) of samples the exact rule says stand): how many, how many
    above the true margin, how many more than :data:`MARGIN_SLACK` below it, the largest
    excess and shortfall (mm), then a line for each margin above the true one."""
    lines = [
        "certificate margins of the stands it agrees on, against the true margin: runs with one; above the true "
        f"margin; more than {MARGIN_SLACK * 1000:g} mm below it; largest excess and shortfall",
    ]
    above: list[tuple[str, float, Run]] = []
    for name in settings:
        mine = [(label, true, r) for label, true, r in pairs if r.setting == name and r.margin is not None and not r.error]
        diffs = [r.margin - true for _, true, r in mine if r.margin is not None]
        above += [(label, true, r) for label, true, r in mine if r.margin is not None and r.margin > true]
        over = sum(d > 0 for d in diffs)
        short = sum(d < -MARGIN_SLACK for d in diffs)
        lines.append(
            f"  {name:<25} {len(mine):>6} {over:>6} {short:>6}  {max(diffs, default=0.0) * 1000:+.3f} mm "
            f"{min(diffs, default=0.0) * 1000:+.3f} mm"
        )
    for label, true, r in above:
        assert r.margin is not None
        lines.append(f"  above: {label}  {r.setting:<25} certificate {r.margin * 1000:.3f} mm, true {true * 1000:.3f} mm")
    return lines


def _stands_active(runs: Sequence[tuple[str, Run]]) -> list[str]:
    """One line for each run that says "stands" with a structure brick still active at its end."""
    found = [(label, r) for label, r in runs if r.stands_active]
    lines = ["stands with a structure brick active at the end: assembly or sample, setting, gap, bricks"] if found else []
    return lines + [f"  {label}  {r.setting:<25} {r.gap * 1000:.1f} mm  {', '.join(r.active)}" for label, r in found]


def _failures(label: str, error: str, runs: Sequence[Run], at_gap: bool) -> list[str]:
    """One line for a task's internal error and one for each of its runs that failed or stopped."""
    lines = [f"  {label}  internal error: {error}"] if error else []
    for r in runs:
        if r.error:
            where = f" at {r.gap * 1000:.1f} mm" if at_gap else ""
            lines.append(f"  {label}  {r.setting}{where}: {r.error}")
    return lines


def _level(level: int | None) -> str:
    return "stands" if level is None else f"collapse {level}"


def timed(
    seed: int,
    count: int,
    jobs: int,
    each: Callable[[Verdicts], None] = lambda v: None,
    runs: Plan | None = None,
    done: dict[int, Verdicts] | None = None,
) -> tuple[list[Verdicts], float]:
    """:func:`run_verdicts` and its wall seconds (of this run: those ``done`` before cost none)."""
    start = time.perf_counter()
    results = run_verdicts(seed, count, jobs, each, runs, done)
    return results, time.perf_counter() - start


# --- the random single-file stack against the exact rule -----------------------------------

#: The random single-file stack of ``sweeps/random_single_file.yaml``: 40 levels, each brick's
#: centre x(k+1) = x(k) + U(-60 mm, 60 mm); ``{seed}`` is put in.
SINGLE_FILE = """stackdsl: 1
name: random single-file stack
seed: {seed}
structure:
  tower:
    levels: 40
    bricks_per_layer: 1
    turn: 0
    shift: {{uniform: [-60 mm, 60 mm], per: layer}}
timing:
  settle: 0.2 s
sweep:
  samples: 1
"""
#: Samples a single-file task runs (each in every setting).
SINGLE_FILE_BATCH = 25


@dataclass(frozen=True)
class Sample:
    """One random single-file stack: its sample number, the exact rule's collapse level on its
    placed centres (None: all 40 stand) and margin (m, :func:`exact_margin`), and its runs
    (at the scenario's drop gap); ``error``: why it could not be drawn, else ''."""

    sample: int
    exact: int | None
    margin: float
    runs: tuple[Run, ...]
    error: str = ""


def exact_margin(x: Sequence[float] | np.ndarray, length: float = 0.120) -> tuple[int | None, float]:
    """The exact rule's collapse level of bricks placed at centres ``x`` (m, bottom first,
    shape (N,)) and its margin (m): how far the centre of mass of the bricks above some brick
    must move (relative to that brick) to change the level. Each prefix that stands could fail
    by its smallest interface margin; the prefix that fails would stand only if its largest
    overhang were undone. (:func:`stackdsl.bench.random_stack.interface_margins`: L/2 - |mean of
    x(j+1..n) - x(j)|.)

    >>> level, margin = exact_margin([0.0, 0.05, 0.1])  # fails at 3 by 15 mm; 2 stood by 10 mm
    >>> level, round(margin * 1000, 3)
    (3, 10.0)
    """
    from .random_stack import collapse_level, interface_margins

    x = np.asarray(x, dtype=float)
    level = collapse_level(x, length)
    last = len(x) if level is None else level
    margin = float("inf")
    for n in range(2, last + 1):
        m = interface_margins(x[:n], length)
        margin = min(margin, float(-m.min()) if n == level else float(m.min()))
    return level, margin


def single_file_batch(seed: int, samples: Sequence[int], settings: Sequence[str]) -> list[Sample]:
    """Draw and run ``samples`` of the random single-file stack of ``seed`` in each of
    ``settings`` (names of :data:`SETTINGS`); a worker's task."""
    from ..compile.compiler import compile_scenario
    from ..lang.loader import parse_scenario

    sweep = parse_scenario(SINGLE_FILE.format(seed=seed), "single_file.yaml").template
    assert sweep is not None
    out = []
    for k in samples:
        try:
            scenario = sweep.scenario(0, k)
            places = sorted(compile_scenario(scenario).placements, key=lambda p: p.level)
            level, margin = exact_margin([p.position[0] for p in places])
        except Exception as exc:  # this sample's internal error, reported with it
            out.append(Sample(k, None, 0.0, (), f"{type(exc).__name__}: {exc}"))
            continue
        runs = tuple(run_setting(scenario, SETTINGS[name], scenario.timing.drop_gap) for name in settings)
        out.append(Sample(k, level, margin, runs))
    return out


def run_single_file(
    seed: int, count: int, jobs: int, settings: Sequence[str], each: Callable[[list[Sample]], None] = lambda b: None
) -> list[Sample]:
    """Samples 0 to ``count - 1`` of the random single-file stack of ``seed``, each run in
    ``settings``, on ``jobs`` processes, in sample order."""
    from ..batch.pool import WorkerLost, fan_out

    tasks = [
        (seed, tuple(range(s, min(s + SINGLE_FILE_BATCH, count))), tuple(settings)) for s in range(0, count, SINGLE_FILE_BATCH)
    ]

    def lost(task: tuple[Any, ...], error: WorkerLost) -> list[Sample]:
        return [Sample(k, None, 0.0, (), f"worker lost: {error}") for k in task[1]]

    results: list[Sample] = []
    costs = [0.3 * len(t[1]) * len(settings) for t in tasks]
    for batch in fan_out(single_file_batch, tasks, costs, jobs, here=False, lost=lost):
        results += batch
        each(batch)
    return sorted(results, key=lambda s: s.sample)


def format_single_file(samples: list[Sample], settings: Sequence[str], seconds: float) -> str:
    """Agreement of each setting with the exact rule, and every disagreement with its margin
    (a near tie when under :data:`MARGIN`)."""
    good = [s for s in samples if not s.error]
    sure = [s for s in good if s.margin > MARGIN]
    lines = [
        f"{len(samples)} random single-file stacks (seed's samples 0-{len(samples) - 1}), {len(sure)} with a margin "
        f"above {MARGIN * 1000:g} mm; {seconds:.0f} s wall",
        "agreement with the exact centre-of-mass rule, agreeing/runs",
        f"{'setting':<25} {'all':^14} {'margin > 1 mm':^14} {'0.2-1 mm':^14} {'stand+active':>12} {'no cert.':>8} "
        f"{'errors':>6} {'median wall':>11}",
    ]
    for name in settings:

        def count(subset: Sequence[Sample], name: str = name) -> tuple[int, int]:
            ran = [(s, r) for s in subset for r in s.runs if r.setting == name and not r.error]
            return sum(r.level == s.exact for s, r in ran), len(ran)

        mine = [r for s in good for r in s.runs if r.setting == name]
        walls = [r.wall for r in mine if not r.error] or [0.0]
        lines.append(
            f"{name:<25} {_cell(count(good))} {_cell(count(sure))} {_cell(count([s for s in good if NEAR < s.margin <= MARGIN]))} "
            f"{sum(r.stands_active for r in mine):>12} {sum(not r.error and not r.certified for r in mine):>8} "
            f"{sum(bool(r.error) for r in mine):>6} {float(np.median(walls)) * 1000:>8.0f} ms"
        )
    wrong = [(s, r) for s in good for r in s.runs if not r.error and r.level != s.exact]
    lines.append(
        f"disagreements: {len(wrong)} ({sum(s.margin < EXACT_TIE for s, _ in wrong)} exact ties under "
        f"{EXACT_TIE * 1000:g} mm, {sum(bool(r.tie) for _, r in wrong)} that the certificate calls a near tie)"
        + (": sample, setting, measured (proof), exact rule, margin; the certificate's words" if wrong else "")
    )
    for s, r in wrong:
        tie = f"; {r.tie}" if r.tie else "; the certificate says no near tie"
        proof = f" ({r.proof})" if r.proof else ""
        lines.append(
            f"  {s.sample:5d}  {r.setting:<25} {_level(r.level)}{proof} (exact {_level(s.exact)}), margin {s.margin * 1000:.3f} mm"
            f"{'  exact tie' if s.margin < EXACT_TIE else ''}{tie}"
        )
    lines += certificate_margins(
        [(f"{s.sample:5d}", min(s.margin, HALF_WIDTH), r) for s in good if s.exact is None for r in s.runs if r.level is None],
        settings,
    )
    lines += _stands_active([(f"{s.sample:5d}", r) for s in good for r in s.runs])
    failed = [line for s in samples for line in _failures(f"{s.sample:5d}", s.error, s.runs, at_gap=False)]
    lines += ["runs that stopped with an internal error:", *failed] if failed else []
    return "\n".join(lines)

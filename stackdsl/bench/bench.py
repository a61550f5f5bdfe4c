"""Benchmarks: measurements that take too long for the tests, each a command with its output.

``stackdsl bench`` runs the speed-against-error matrix: every engine setting (:data:`SETTINGS`,
pybullet's and MuJoCo's) on the same scenes, in one run. What it writes, with each setting's
wall time as a ratio to the extension's on the same scene, is :mod:`stackdsl.bench.out`'s.
The stability models' own costs are in :mod:`stackdsl.bench.cost`.

Source: stackdsl's own.
"""

from __future__ import annotations

import functools
import resource
import statistics
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..batch.guard import SPAWN
from ..compile.compiler import compile_scenario
from ..compile.program import Program
from ..lang.loader import parse_scenario
from ..runtime.run import RunOptions, run_program
from ..verdicts.closed_form import log_cabin, single_file
from .lean import LeanOutcome


@dataclass(frozen=True)
class Setting:
    """One row of the matrix: the scenario's ``mode`` and stability ``model``, engine fields
    written into it (``backend`` among them), and whether bricks enter the world as they
    are placed (``lazy_bodies``, see :class:`stackdsl.runtime.run.RunOptions`; None: the
    runtime's rule); ``lean``: run by the peer engine's own loop (:mod:`stackdsl.bench.lean_mujoco`,
    :mod:`stackdsl.bench.lean_pybullet`), not stackdsl's."""

    mode: str
    model: str = "report"
    engine: tuple[tuple[str, str | int | float], ...] = ()
    lazy_bodies: bool | None = None
    lean: bool = False

    @property
    def backend(self) -> str:
        """The engine it runs on: ``pybullet`` unless its engine fields name another."""
        return str(dict(self.engine).get("backend", "pybullet"))


_MUJOCO = (("backend", "mujoco"),)
_SLEEPING = (*_MUJOCO, ("sleep_tolerance", 1e-4))
LEAN_SLEEP_TOLERANCE = 1e-3
"""The lean MuJoCo peer's sleep tolerance (m/s), chosen by measurement as the peer's best: the
faster of 1e-4 and MuJoCo's default 1e-3 that keeps the bench scenes' levels. With the drop gap
(:mod:`stackdsl.bench.lean_mujoco`), 1e-3 fell at the same level as 1e-4 on all 16 bench scenes
(the 14 slant scenes, the upright 4 stacks of 30 and 60 levels: error 0 on 14, -1 on the 3.5 mm
cabin and the 7 mm single file at both, as before) and took 0.23 to 0.62 of 1e-4's wall time on
the towers and the cabins of 4.5 to 9.5 mm (one bench run, two cells at a time, load 3.5 to 8 on
2 cores; docs/results/speed-against-error.md, "The lean MuJoCo peer's placement and sleep
tolerance"). "MuJoCo lean 1e-4" runs the other, to check that again."""
_LEAN = (*_MUJOCO, ("sleep_tolerance", LEAN_SLEEP_TOLERANCE))
LEAN_TOLERANCE = 1e-10
"""The lean MuJoCo peer's solver tolerance (MuJoCo's ``tolerance``; its default is 1e-8), chosen
by measurement as the faster of 1e-8 and 1e-10 whose towers still stand
(docs/results/actions.md, "The lean peer's settings")."""

SETTINGS: dict[str, Setting] = {
    "raw 240 Hz": Setting("raw"),
    "pybullet lean": Setting("raw", lean=True),
    "raw 1 kHz 150 it": Setting("raw", engine=(("timestep", "1 ms"), ("solver_iterations", 150))),
    "tuned": Setting("tuned"),
    "extension report": Setting("extension"),
    "extension equilibrium": Setting("extension", "equilibrium"),
    "MuJoCo raw": Setting("raw", engine=_MUJOCO),
    "MuJoCo tuned": Setting("tuned", engine=_MUJOCO),
    "MuJoCo tuned sleeping": Setting("tuned", engine=_SLEEPING, lazy_bodies=True),
    "MuJoCo tuned sleeping parked": Setting("tuned", engine=_SLEEPING, lazy_bodies=False),
    "MuJoCo lean": Setting("tuned", engine=_LEAN, lean=True),
    "MuJoCo lean 1e-4": Setting("tuned", engine=_SLEEPING, lean=True),
    "MuJoCo extension": Setting("extension", engine=_MUJOCO),
}
"""Engine settings compared, by name. pybullet's first (raw pybullet also run by its own lean
loop, :mod:`stackdsl.bench.lean_pybullet`: the peer as a pybullet user writes it); then
MuJoCo's: its defaults, the
tuned settings, those with MuJoCo's own sleeping (tolerance 1e-4) with bricks added to the
model as they are placed and with every brick declared up front and parked (the runtime's
default on MuJoCo), tuned sleeping MuJoCo run by its own lean loop
(:mod:`stackdsl.bench.lean_mujoco`: the peer at its best, at :data:`LEAN_SLEEP_TOLERANCE`, the
column the README's ratios come from; and at 1e-4, to check that choice), and the extension."""

DEFAULT_SETTINGS = tuple(name for name in SETTINGS if name != "MuJoCo lean 1e-4")
"""The settings ``stackdsl bench`` runs unless ``--settings`` names others: all but the lean
peer at 1e-4, which only re-checks the choice of :data:`LEAN_SLEEP_TOLERANCE` (and costs the
most of any lean cell)."""


@dataclass(frozen=True)
class Scene:
    """A benchmark scene: ``family`` and its parameter, YAML structure, closed-form answer.

    ``closed_form`` is the collapse level, or None when the structure stands; ``levels``
    is how many are built (a slant tower a few beyond its collapse level).
    """

    family: str
    parameter: float
    levels: int
    structure: str
    closed_form: int | None


UPRIGHT = (10, 20, 30, 60, 100)
"""The heights of the upright 4 stacks, in levels."""


def scenes(quick: bool = False, upright: Sequence[int] = UPRIGHT) -> list[Scene]:
    """The scene families: slanted log-cabin towers (shifts 3 to 14 mm), single-file slanted
    stacks, and upright 4 stacks of ``upright`` levels."""
    if quick:
        return [Scene("upright", 3, 3, "tower: {levels: 3}", None)]
    out = []
    for s in (3.5, 4.5, 5.5, 6.5, 9, 9.5, 10.5, 11, 13, 14):  # no ties (docs/results/speed-against-error.md): not 3, 5, 8
        n = log_cabin(s / 1000)
        out.append(Scene("slant log cabin", s, n + 2, f"tower: {{levels: {n + 2}, spacing: 96 mm, shift: {s} mm}}", n))
    for s in (7, 9, 11, 13):
        n = single_file(s / 1000)
        out.append(Scene("single file", s, n + 2, f"tower: {{levels: {n + 2}, bricks_per_layer: 1, turn: 0, shift: {s} mm}}", n))
    for levels in upright:
        out.append(Scene("upright", levels, levels, f"tower: {{levels: {levels}}}", None))
    return out


@dataclass(frozen=True)
class Cell:
    """One measured cell of the matrix (times in s, lengths in mm, memory in MB).

    ``error`` is the collapse level measured minus the closed form, in levels, with
    "stands" counted as one level above the top; ``drift`` the largest displacement of a
    standing structure brick before the first collapse. ``engine``, ``after_collapse`` and
    ``certificate`` are parts of the median run's wall time: in the engine's own steps, after
    the collapse was decided, and proving that the structure stands (:class:`stackdsl.Outcome`).
    """

    setting: str
    family: str
    parameter: float
    bricks: int
    closed_form: int | None
    collapse_level: int | None
    error: int
    drift: float
    wall: float
    walls: str
    engine: float
    after_collapse: float
    simulated: float
    speed: float
    peak_memory: float
    steps: int
    steps_skipped: int
    certificate: float = 0.0


WARM_UP = Scene("warm-up", 1, 1, "tower: {levels: 1}", None)
"""The untimed scene each benchmark worker runs first (see :func:`measure`)."""

TIMING = (
    "every cell timed alike, extension and peers: the median of {repeats} runs in rounds, each run in a fresh "
    "process after one untimed 1-level tower of its own setting{below}"
)
"""How :func:`run_matrix` times every cell, as ``stackdsl bench`` prints it (``{repeats}``: runs a
cell; ``{below}``: the exception ``--repeat-below`` makes, if any).

Every setting is timed the same way. The bench once ran a short run (under 0.5 s) five more
times in its warm worker and kept the median: that cut the extension's times by 8 to 53% and the
peer's by 0 to 6% (an independent harness with fresh processes, docs/results/independent_timing.py),
and the level-2 cabin read 3.70x where fresh processes gave 1.81x; and a cell over 30 s ran
once, the 60-level peer cells among them."""


def program_for(scene: Scene, setting: str) -> Program:
    """Compile ``scene`` under ``setting`` (see :data:`SETTINGS`)."""
    chosen = SETTINGS[setting]
    extra = "".join(f", {k}: {v}" for k, v in chosen.engine)
    text = f"stackdsl: 1\nstructure: {{{scene.structure}}}\nengine: {{mode: {chosen.mode}{extra}}}\n"
    return compile_scenario(parse_scenario(text, f"{scene.family}-{scene.parameter}.yaml"), model=chosen.model)


def measure(scene: Scene, setting: str, options: RunOptions) -> Cell:
    """Run one cell once (in its own process, for its peak memory); :func:`run_matrix` repeats
    it in rounds and :func:`combine` takes the median (:data:`TIMING`).

    A one-level tower in the same setting runs first, untimed: the worker is a fresh
    process, and its first run would also pay one-off costs (lazy imports, first calls into
    shapely and scipy, about 0.2 s) that belong to no scene."""
    if SETTINGS[setting].lean:
        return _measure_lean(scene, setting, options.settle)
    options = replace(options, lazy_bodies=SETTINGS[setting].lazy_bodies)
    run_program(program_for(WARM_UP, setting), options)
    program = program_for(scene, setting)
    o = run_program(program, options)
    measured = o.collapse.level if o.collapse else None
    top = scene.levels + 1
    error = (measured or top) - (scene.closed_form or top)
    return Cell(
        setting=setting,
        family=scene.family,
        parameter=scene.parameter,
        bricks=len(program.placements),
        closed_form=scene.closed_form,
        collapse_level=measured,
        error=error,
        drift=round(o.drift * 1000, 3),
        wall=round(o.wall_time, 4),
        walls=f"{o.wall_time:.3f}",
        engine=round(o.engine_time, 4),
        after_collapse=round(o.after_collapse, 4),
        simulated=round(o.simulated_time, 3),
        speed=round(o.simulated_time / o.wall_time, 1) if o.wall_time > 0 else 0.0,
        peak_memory=round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        steps=o.steps,
        steps_skipped=o.steps_skipped,
        certificate=round(o.certificate_time, 5),
    )


def _measure_lean(scene: Scene, setting: str, settle: float | None) -> Cell:
    """:func:`measure` of a lean setting: the peer's own loop, after its own warm-up run, going on
    ``settle`` seconds after a collapse is decided, as stackdsl's runs do (``RunOptions.settle``)."""
    from . import lean_mujoco, lean_pybullet

    # each peer's own loop on its own engine (a lean setting names one of these two)
    runners: dict[str, Callable[[Program], LeanOutcome]] = {
        "mujoco": functools.partial(lean_mujoco.run_lean, tolerance=LEAN_TOLERANCE, settle=settle),
        "pybullet": functools.partial(lean_pybullet.run_lean, settle=settle),
    }
    run_lean = runners[SETTINGS[setting].backend]
    run_lean(program_for(WARM_UP, setting))
    program = program_for(scene, setting)
    o = run_lean(program)
    top = scene.levels + 1
    return Cell(
        setting=setting,
        family=scene.family,
        parameter=scene.parameter,
        bricks=len(program.placements),
        closed_form=scene.closed_form,
        collapse_level=o.level,
        error=(o.level or top) - (scene.closed_form or top),
        drift=0.0,
        wall=round(o.wall, 4),
        walls=f"{o.wall:.3f}",
        engine=round(o.engine, 4),
        after_collapse=round(o.after_collapse, 4),
        simulated=round(o.simulated, 3),
        speed=round(o.simulated / o.wall, 1) if o.wall > 0 else 0.0,
        peak_memory=round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        steps=o.steps,
        steps_skipped=0,
    )


def run_matrix(
    settings: list[str],
    scene_list: list[Scene],
    repeats: int = 3,
    repeat_below: float = float("inf"),
    jobs: int = 2,
    progress: Callable[[Cell], None] = lambda c: None,
    after_collapse: float | None = 0.0,
) -> list[Cell]:
    """Every setting on every scene, each run in a fresh worker process (one process tree).

    A cell is measured ``repeats`` times in rounds, every cell once a round, and its wall
    time is the median (:func:`combine`); a cell whose first run takes ``repeat_below``
    seconds or more runs once (by default none: every cell, extension and peer, is timed
    alike). Rounds, not runs back to back, because the machine's speed drifts: on the
    development machine the same Python loop took 0.24 to 0.41 s within a minute, so the settings compared on a scene must sample the same stretches of the run.
    ``progress`` is called with each cell once its last run is in.

    Every run stops at its first collapse and ends ``after_collapse`` seconds after it is
    decided (0: at the decision, where the lean peers stop too; None: the scene's settle time,
    2 s, which times the falling debris as well), an upright tower's too: a setting that
    fells a tower that stands is wrong there, and its error says so, but a peer's loop would
    not build on a heap either.
    """
    options = RunOptions(stop_at_collapse=True, settle=after_collapse)
    tasks = [(scene, setting, options) for scene in scene_list for setting in settings]
    tasks.sort(key=lambda t: -_cost(*t[:2]))  # the longest first: the pool ends together
    context = SPAWN  # spawned workers that end with this process and leave Ctrl-C to it
    runs: dict[tuple[str, float, str], list[Cell]] = {}
    cells = []
    # a Pool, not a ProcessPoolExecutor: its max_tasks_per_child needs Python 3.11
    with context.Pool(processes=jobs, maxtasksperchild=1) as pool:
        rounds = max(1, repeats)
        for round_ in range(rounds):
            arguments = [(scene, setting, options) for scene, setting, options in tasks]
            for run in pool.imap_unordered(_measure, arguments):  # each as it finishes
                done = runs.setdefault((run.family, run.parameter, run.setting), [])
                done.append(run)
                if round_ == rounds - 1 or done[0].wall >= repeat_below:
                    cells.append(combine(done))
                    progress(cells[-1])
            tasks = [t for t in tasks if runs[(t[0].family, t[0].parameter, t[1])][0].wall < repeat_below]
    order = {s: i for i, s in enumerate(settings)}
    return sorted(cells, key=lambda c: (c.family, c.parameter, order[c.setting]))


def combine(runs: list[Cell]) -> Cell:
    """One cell from its runs (one run each): the median wall time, every run's wall time,
    the engine and after-collapse split of the run nearest the median, the largest peak
    memory. Raises ValueError for no runs.

    >>> a, b, c = (Cell("s", "f", 1.0, 2, None, None, 0, 0.0, w, f"{w:.3f}", w / 2, 0.0, 1.0, 1 / w, m, 10, 0)
    ...            for w, m in ((0.3, 90.0), (0.1, 95.0), (0.2, 99.0)))
    >>> cell = combine([a, b, c]); cell.wall, cell.walls, cell.engine, cell.peak_memory
    (0.2, '0.100 0.200 0.300', 0.1, 99.0)
    """
    if not runs:
        raise ValueError("a cell needs at least one run")
    wall = statistics.median(r.wall for r in runs)
    middle = min(runs, key=lambda r: abs(r.wall - wall))
    return replace(
        runs[0],
        wall=round(wall, 4),
        walls=" ".join(f"{r.wall:.3f}" for r in sorted(runs, key=lambda r: r.wall)),
        engine=middle.engine,
        after_collapse=middle.after_collapse,
        certificate=middle.certificate,
        speed=round(runs[0].simulated / wall, 1) if wall > 0 else 0.0,
        peak_memory=max(r.peak_memory for r in runs),
    )


def _measure(arguments: tuple[Scene, str, RunOptions]) -> Cell:
    return measure(*arguments)


def _cost(scene: Scene, setting: str) -> float:
    """A guess of a cell's wall time, to start the longest first."""
    steps_per_second = {
        "raw 240 Hz": 240,
        "pybullet lean": 240,
        "raw 1 kHz 150 it": 3000,
        "tuned": 3000,
        "MuJoCo raw": 300,
        "MuJoCo tuned": 1500,
        "MuJoCo tuned sleeping": 1500,
        "MuJoCo tuned sleeping parked": 500,
        "MuJoCo lean": 500,
        "MuJoCo lean 1e-4": 500,
    }.get(setting, 5)
    return scene.levels * 2 * steps_per_second * scene.levels


def savings(repeats: int = 3) -> list[tuple[str, str, float, int]]:
    """Each "model only what a scene needs" switch off in turn, in extension mode (report
    model), on the scene where it acts: the 30-level 4 stack, the 100-level one for the buried
    bricks shelved, and the log cabin shifted 3.5 mm a level for the fallen bricks as rigid
    bodies. Rows of (what is off, scene, median wall time in s, physics steps); the first row of
    each scene has nothing off."""
    tower = Scene("upright", 30, 30, "tower: {levels: 30}", None)
    tall = Scene("upright", 100, 100, "tower: {levels: 100}", None)
    cabin = next(s for s in scenes(upright=()) if s.family == "slant log cabin" and s.parameter == 3.5)
    rows = []
    for scene, name, options in (
        (tower, "nothing (all on)", RunOptions()),
        (tower, "jump over quiet steps", RunOptions(jump=False)),
        (tower, "bodies enter when placed", RunOptions(lazy_bodies=False)),
        (tower, "only the rules a scene needs", RunOptions(needed_rules=False)),
        (tower, "stack test per event", RunOptions(per_event=False)),
        (tall, "nothing (all on)", RunOptions()),
        (tall, "buried bricks shelved", RunOptions(shelve=False)),
        (cabin, "nothing (all on)", RunOptions()),
        (cabin, "fallen bricks as rigid bodies", RunOptions(cheap_debris=False)),
    ):
        program = program_for(scene, "extension report")
        outcomes = [run_program(program, options) for _ in range(repeats)]
        median = statistics.median(o.wall_time for o in outcomes)
        rows.append((name, scene_label(scene.family, scene.parameter), median, outcomes[0].steps))
    return rows


def scene_label(family: str, parameter: float) -> str:
    """A scene as the bench's tables name it.

    >>> scene_label("slant log cabin", 3.5), scene_label("upright", 30)
    ('slant log cabin, 3.5 mm', 'upright, 30 levels')
    """
    return f"{family}, {parameter:g} {'levels' if family == 'upright' else 'mm'}"


def fit_exponent(points: Sequence[tuple[float, float]]) -> float:
    """Slope of log(wall) against log(bricks): the exponent of a power law fit."""
    x, y = np.log([p[0] for p in points]), np.log([p[1] for p in points])
    return float(np.polyfit(x, y, 1)[0])

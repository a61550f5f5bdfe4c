"""Benchmarks: measurements that take too long for the tests, each a command with its output.

``stackdsl bench`` runs the speed-against-error matrix: every engine setting on the same
scenes, in one run, with each setting's wall time as a ratio to the extension's on the same
scene (:func:`ratios`). The stability models' own costs are in :mod:`stackdsl._bench_cost`.

Source: stackdsl's own.
"""

from __future__ import annotations

import csv
import resource
import statistics
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ._closed_form import log_cabin, single_file
from ._compiler import compile_scenario
from ._loader import parse_scenario
from ._pool import SPAWN
from ._program import Program
from ._runtime import RunOptions, run_program

#: Engine settings compared: (mode, stability model, engine overrides).
SETTINGS: dict[str, tuple[str, str, dict[str, str | int]]] = {
    "raw 240 Hz": ("raw", "report", {}),
    "raw 1 kHz 150 it": ("raw", "report", {"timestep": "1 ms", "solver_iterations": 150}),
    "tuned": ("tuned", "report", {}),
    "extension report": ("extension", "report", {}),
    "extension equilibrium": ("extension", "equilibrium", {}),
}


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


def scenes(quick: bool = False) -> list[Scene]:
    """The scene families: slanted log-cabin towers (shifts 3 to 14 mm), single-file slanted
    stacks, and upright 4 stacks of 10 to 100 levels."""
    if quick:
        return [Scene("upright", 3, 3, "tower: {levels: 3}", None)]
    out = []
    for s in (3.5, 4.5, 5.5, 6.5, 9, 9.5, 10.5, 11, 13, 14):  # no ties (docs/results.md): not 3, 5, 8
        n = log_cabin(s / 1000)
        out.append(Scene("slant log cabin", s, n + 2, f"tower: {{levels: {n + 2}, spacing: 96 mm, shift: {s} mm}}", n))
    for s in (7, 9, 11, 13):
        n = single_file(s / 1000)
        out.append(Scene("single file", s, n + 2, f"tower: {{levels: {n + 2}, bricks_per_layer: 1, turn: 0, shift: {s} mm}}", n))
    for levels in (10, 20, 30, 60, 100):
        out.append(Scene("upright", levels, levels, f"tower: {{levels: {levels}}}", None))
    return out


@dataclass(frozen=True)
class Cell:
    """One measured cell of the matrix (times in s, lengths in mm, memory in MB).

    ``error`` is the collapse level measured minus the closed form, in levels, with
    "stands" counted as one level above the top; ``drift`` the largest displacement of a
    standing structure brick before the first collapse.
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
    simulated: float
    speed: float
    peak_memory: float
    steps: int
    steps_skipped: int


WARM_UP = Scene("warm-up", 1, 1, "tower: {levels: 1}", None)
"""The untimed scene each benchmark worker runs first (see :func:`measure`)."""


def program_for(scene: Scene, setting: str) -> Program:
    """Compile ``scene`` under ``setting`` (see :data:`SETTINGS`)."""
    mode, model, engine = SETTINGS[setting]
    extra = "".join(f", {k}: {v}" for k, v in engine.items())
    text = f"stackdsl: 1\nstructure: {{{scene.structure}}}\nengine: {{mode: {mode}{extra}}}\n"
    return compile_scenario(parse_scenario(text, f"{scene.family}-{scene.parameter}.yaml"), model=model)


def measure(scene: Scene, setting: str, repeats: int, repeat_below: float, options: RunOptions) -> Cell:
    """Run one cell (in its own process, for its peak memory): the median of ``repeats``
    runs, or one run when that takes longer than ``repeat_below`` seconds.

    A one-level tower in the same setting runs first, untimed: the worker is a fresh
    process, and its first run would also pay one-off costs (lazy imports, first calls into
    shapely and scipy, about 0.2 s) that belong to no scene."""
    run_program(program_for(WARM_UP, setting), options)
    program = program_for(scene, setting)
    outcomes = [run_program(program, options)]
    while len(outcomes) < repeats and outcomes[0].wall_time < repeat_below:
        outcomes.append(run_program(program, options))
    o = outcomes[0]
    walls = sorted(x.wall_time for x in outcomes)
    wall = statistics.median(walls)
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
        wall=round(wall, 4),
        walls=" ".join(f"{w:.3f}" for w in walls),
        simulated=round(o.simulated_time, 3),
        speed=round(o.simulated_time / wall, 1),
        peak_memory=round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        steps=o.steps,
        steps_skipped=o.steps_skipped,
    )


def run_matrix(
    settings: list[str],
    scene_list: list[Scene],
    repeats: int = 3,
    repeat_below: float = 30.0,
    jobs: int = 2,
    progress: Callable[[Cell], None] = lambda c: None,
) -> list[Cell]:
    """Every setting on every scene, each cell in a fresh worker process (one process tree).

    Slant towers stop at their first collapse; upright towers are built to the top
    whatever happens, so that every setting simulates the same seconds.
    """
    tasks = []
    for scene in scene_list:
        options = RunOptions(stop_at_collapse=scene.closed_form is not None)
        tasks += [(scene, setting, options) for setting in settings]
    tasks.sort(key=lambda t: -_cost(*t[:2]))  # the longest first: the pool ends together
    context = SPAWN  # spawned workers that end with this process and leave Ctrl-C to it
    cells = []
    # a Pool, not a ProcessPoolExecutor: its max_tasks_per_child needs Python 3.11
    with context.Pool(processes=jobs, maxtasksperchild=1) as pool:
        results = [
            pool.apply_async(measure, (scene, setting, repeats, repeat_below, options)) for scene, setting, options in tasks
        ]
        for r in results:
            cell = r.get()
            progress(cell)
            cells.append(cell)
    order = {s: i for i, s in enumerate(settings)}
    return sorted(cells, key=lambda c: (c.family, c.parameter, order[c.setting]))


def _cost(scene: Scene, setting: str) -> float:
    """A guess of a cell's wall time, to start the longest first."""
    steps_per_second = {"raw 240 Hz": 240, "raw 1 kHz 150 it": 3000, "tuned": 3000}.get(setting, 5)
    return scene.levels * 2 * steps_per_second * scene.levels


def savings(repeats: int = 3) -> list[tuple[str, float, int]]:
    """The 30-level 4 stack in extension mode with each "model only what a scene needs"
    switch off in turn: (what is off, median wall time in s, physics steps)."""
    scene = Scene("upright", 30, 30, "tower: {levels: 30}", None)
    program = program_for(scene, "extension report")
    rows = []
    for name, options in (
        ("nothing (all on)", RunOptions()),
        ("jump over quiet steps", RunOptions(jump=False)),
        ("bodies enter when placed", RunOptions(lazy_bodies=False)),
        ("only the rules a scene needs", RunOptions(needed_rules=False)),
        ("stack test per event", RunOptions(per_event=False)),
    ):
        outcomes = [run_program(program, options) for _ in range(repeats)]
        rows.append((name, statistics.median(o.wall_time for o in outcomes), outcomes[0].steps))
    return rows


def fit_exponent(points: Sequence[tuple[float, float]]) -> float:
    """Slope of log(wall) against log(bricks): the exponent of a power law fit."""
    x, y = np.log([p[0] for p in points]), np.log([p[1] for p in points])
    return float(np.polyfit(x, y, 1)[0])


def write_outputs(cells: list[Cell], saved: list[tuple[str, float, int]], folder: Path) -> dict[str, Any]:
    """Write bench.csv, bench.md, wall_vs_error.png and wall_vs_height.png into ``folder``;
    return the target checks."""
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / "bench.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(asdict(cells[0])))
        writer.writeheader()
        writer.writerows(asdict(c) for c in cells)
    targets = check_targets(cells)
    (folder / "bench.md").write_text(markdown(cells, saved, targets))
    plot_error(cells, folder / "wall_vs_error.png")
    plot_height(cells, folder / "wall_vs_height.png")
    return targets


def check_targets(cells: list[Cell]) -> dict[str, Any]:
    """The benchmark's targets, as measured: slant errors, the 30-level speed ratio, exponents."""
    by = {(c.setting, c.family, c.parameter): c for c in cells}
    slant = [c for c in cells if c.family != "upright"]
    out: dict[str, Any] = {
        "slant errors": {s: [c.error for c in slant if c.setting == s] for s in SETTINGS if any(c.setting == s for c in slant)}
    }
    raw, ext = by.get(("raw 240 Hz", "upright", 30)), by.get(("extension report", "upright", 30))
    if raw and ext:
        out["30-level speed-up, raw 240 Hz / extension"] = raw.wall / ext.wall
    out["exponents"] = {
        s: fit_exponent([(c.bricks, c.wall) for c in cells if c.setting == s and c.family == "upright"])
        for s in SETTINGS
        if sum(c.setting == s and c.family == "upright" for c in cells) >= 2
    }
    return out


def markdown(cells: list[Cell], saved: list[tuple[str, float, int]], targets: dict[str, Any]) -> str:
    """The tables of ``bench.md``."""
    settings = [s for s in SETTINGS if any(c.setting == s for c in cells)]
    lines = ["| scene | closed form | " + " | ".join(settings) + " |", "|---|---|" + "---|" * len(settings)]
    keys = sorted({(c.family, c.parameter) for c in cells}, key=lambda k: (k[0], k[1]))
    by = {(c.setting, c.family, c.parameter): c for c in cells}
    for family, parameter in keys:
        first = next(c for c in cells if (c.family, c.parameter) == (family, parameter))
        label = f"{family}, {parameter:g} {'levels' if family == 'upright' else 'mm'}"
        expected = "stands" if first.closed_form is None else str(first.closed_form)
        row = []
        for s in settings:
            c = by.get((s, family, parameter))
            row.append(
                ""
                if c is None
                else f"{'stands' if c.collapse_level is None else c.collapse_level} ({c.error:+d}), {c.wall:.2f} s, {c.drift:.2f} mm"
            )
        lines.append(f"| {label} | {expected} | " + " | ".join(row) + " |")
    lines += ["", "Each cell: collapse level (error in levels), median wall time, drift of the standing bricks.", ""]
    lines += [
        "| setting | simulated s per wall s (all cells) | mean abs. error, slant scenes (levels) | peak memory (MB) | upright: exponent of wall time in bricks |",
        "|---|---:|---:|---:|---:|",
    ]
    for s in settings:
        mine = [c for c in cells if c.setting == s]
        slant = [abs(c.error) for c in mine if c.family != "upright"]
        speed = sum(c.simulated for c in mine) / sum(c.wall for c in mine)
        exponent = targets["exponents"].get(s)
        lines.append(
            f"| {s} | {speed:.1f} | {f'{statistics.mean(slant):.2f}' if slant else '-'} | "
            f"{max(c.peak_memory for c in mine):.0f} | {'' if exponent is None else f'{exponent:.2f}'} |"
        )
    lines += ["", *ratios(cells)]
    if saved:
        lines += ["", "| switched off (30-level 4 stack, extension) | median wall time | physics steps |", "|---|---:|---:|"]
        lines += [f"| {name} | {wall:.3f} s | {steps} |" for name, wall, steps in saved]
    ratio = targets.get("30-level speed-up, raw 240 Hz / extension")
    if ratio:
        lines += ["", f"30-level 4 stack: raw 240 Hz takes {ratio:.0f} times the extension's wall time."]
    return "\n".join(lines) + "\n"


def _pareto(points: list[tuple[float, float, str]]) -> list[tuple[float, float, str]]:
    """The points no other point beats in both wall time and error."""
    front = [p for p in points if not any(q[0] <= p[0] and q[1] <= p[1] and q != p for q in points)]
    return sorted(front)


def plot_error(cells: list[Cell], path: Path) -> None:
    """Wall time against error, one point per setting (all scenes summed), Pareto front drawn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    points = []
    for i, s in enumerate(SETTINGS):
        mine = [c for c in cells if c.setting == s]
        if not mine:
            continue
        wall = sum(c.wall for c in mine)
        error = statistics.mean(abs(c.error) for c in mine)
        points.append((wall, error, s))
        ax.scatter([c.wall for c in mine], [abs(c.error) for c in mine], s=12, alpha=0.35, color=f"C{i}")
        ax.scatter([wall], [error], s=70, color=f"C{i}", edgecolor="k", zorder=3, label=s)
    front = _pareto(points)
    ax.plot(
        [p[0] for p in front],
        [p[1] for p in front],
        "k--",
        lw=1,
        marker="o",
        mfc="none",
        ms=12,
        label="Pareto front (per setting)",
    )
    ax.set_xscale("log")
    ax.set_xlabel("wall time, s (large: all scenes summed; small: one cell)")
    ax.set_ylabel("|collapse level - closed form|, levels (mean)")
    ax.set_title("Speed against error: every setting on the same scenes")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_height(cells: list[Cell], path: Path) -> None:
    """Wall time against tower height (bricks), log-log, with the fitted exponent per setting."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for s in SETTINGS:
        mine = sorted((c.bricks, c.wall) for c in cells if c.setting == s and c.family == "upright")
        if len(mine) < 2:
            continue
        k = fit_exponent(mine)
        ax.plot([m[0] for m in mine], [m[1] for m in mine], "o-", label=f"{s}: wall ~ bricks^{k:.2f}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("bricks in the upright 4 stack")
    ax.set_ylabel("wall time, s")
    ax.set_title("Cost against tower height")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


BASE = "extension report"
"""The setting every other is measured against in :func:`ratios`."""


def ratios(cells: list[Cell], base: str = BASE) -> list[str]:
    """Markdown lines: per scene, each setting's wall time divided by ``base``'s on the same
    scene in the same run (above 1: slower than ``base``), then the geometric mean per setting
    over the scenes of each family. Empty without ``base``'s cells."""
    settings = [s for s in SETTINGS if s != base and any(c.setting == s for c in cells)]
    by = {(c.setting, c.family, c.parameter): c for c in cells}
    keys = sorted({(c.family, c.parameter) for c in cells if c.setting == base})
    if not keys or not settings:
        return []
    lines = [
        f"| scene | {base} | " + " | ".join(f"{s} / {base}" for s in settings) + " |",
        "|---|---:|" + "---:|" * len(settings),
    ]
    logs: dict[tuple[str, str], list[float]] = {}
    for family, parameter in keys:
        ref = by[(base, family, parameter)]
        row = []
        for s in settings:
            c = by.get((s, family, parameter))
            row.append(f"{c.wall / ref.wall:.2f}" if c else "")
            if c:
                logs.setdefault((family, s), []).append(float(np.log(c.wall / ref.wall)))
        label = f"{family}, {parameter:g} {'levels' if family == 'upright' else 'mm'}"
        lines.append(f"| {label} | {ref.wall:.2f} s | " + " | ".join(row) + " |")
    for family in sorted({f for f, _ in keys}):
        means = [f"{np.exp(np.mean(logs[(family, s)])):.2f}" if (family, s) in logs else "" for s in settings]
        lines.append(f"| {family}: geometric mean | | " + " | ".join(means) + " |")
    return lines

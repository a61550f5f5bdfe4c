"""``stackdsl bench actions`` and ``stackdsl bench folder``: scenes a hand acts on, and the shipped
folder, with every side timed alike.

The actions family (:func:`action_scenes`): Jenga pulls of 12 and 18 levels (the shipped
``scenarios/jenga_stands.yaml`` and ``scenarios/jenga_falls.yaml``, and the same scenes built to
18 levels), the rows of 30 and 120 dominoes pushed over (``scenarios/dominoes_30.yaml`` and a row
written like it), and the 4 stack on a shake table below and above its threshold
(``scenarios/four_stack_shake_below.yaml``, ``..._above.yaml``). The sides (:data:`SIDES`): the
extension on pybullet and on MuJoCo and raw pybullet, through stackdsl's runtime; and the lean
MuJoCo peer (:mod:`stackdsl.bench.lean_mujoco`), tuned MuJoCo with its own sleeping at
:data:`PEER_SLEEP_TOLERANCE` and the bench's solver tolerance
(:data:`stackdsl.bench.bench.LEAN_TOLERANCE`), driving the same guided bodies in its own loop,
and the same peer on cheaper contacts (:data:`CHEAP_PEER`), whose ratios the output gives too.

Every cell is timed the same way (:data:`TIMING`): ``repeats`` runs, in rounds (every cell once
a round, as :func:`stackdsl.bench.bench.run_matrix` does), each run in a fresh process that first
runs a one-level tower on its own side, untimed, then the cell's scene; the wall time is from
the compiled program to the run's result, and the cell's is the median. Every cell's verdict is
judged against its scene's expectations: stackdsl's runs by :func:`stackdsl.verdicts.expect.evaluate`,
the peer's by :func:`peer_verdicts`, the same rules on what the peer's loop measured.

``stackdsl bench folder`` times ``stackdsl check FOLDER`` as a user runs it (a fresh
``python -m stackdsl`` each time, ``-j 1`` and ``-j auto``), then each of its scenarios on its own
settings against the lean peer, as the actions family does.

Source: stackdsl's own.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..batch.guard import SPAWN
from ..compile.compiler import compile_scenario
from ..compile.program import Program
from ..lang.errors import ScenarioError, ScenarioWarning
from ..lang.expectations import Expect, bricks_of, levels_of
from ..lang.loader import parse_scenario
from .lean import LeanOutcome

#: The lean peer's sleep tolerance on the actions family (m/s), as the peer is asked to run.
PEER_SLEEP_TOLERANCE = 1e-4


@dataclass(frozen=True)
class Side:
    """How a cell runs: the ``mode`` and ``backend`` its scenario is compiled with (None: the
    file's own), and whether the lean MuJoCo peer runs it (``lean``) instead of stackdsl's runtime."""

    mode: str | None
    backend: str | None
    lean: bool = False
    engine: tuple[tuple[str, bool | float], ...] = ()  # the lean peer's settings changed from tuned's


CHEAP_PEER = "MuJoCo lean pyramidal"
"""The lean peer on cheaper contacts: pyramidal friction cones, impratio 1 and MuJoCo's default
sleep tolerance, 1e-3. On the actions family's scenes it keeps every verdict of the tuned peer and
runs up to twice as fast (Jenga pulls and pushes most; docs/results/actions.md, "A cheaper peer");
tuned's elliptic cones stay the reference, as the settings that keep the slant scenes' closed
forms (docs/engines.md)."""

SIDES: dict[str, Side] = {
    "extension": Side("extension", "pybullet"),
    "MuJoCo extension": Side("extension", "mujoco"),
    "raw pybullet": Side("raw", "pybullet"),
    "MuJoCo lean": Side("tuned", "mujoco", lean=True),
    CHEAP_PEER: Side(
        "tuned", "mujoco", lean=True, engine=(("elliptic_cones", False), ("impratio", 1.0), ("sleep_tolerance", 1e-3))
    ),
}
"""The actions family's sides, by name (see the module's description)."""

AS_WRITTEN = "file's own settings"
"""The folder's own side: each scenario on its own engine and mode, through stackdsl's runtime."""

_ALL_SIDES: dict[str, Side] = {**SIDES, AS_WRITTEN: Side(None, None)}

#: What the tables' last column is, said under each.
RATIO = "peer / this: the {peer} peer's median wall time over the row's (above 1, the row's side is faster)"

TIMING = (
    "every cell timed alike: {repeats} run(s) in rounds, each in a fresh process that first runs a one-level "
    "tower on its own side, untimed; wall time from the compiled program to the run's result; the median is kept"
)
"""How every cell is timed, as the output says it (``{repeats}``: the runs a cell)."""

_WARM_UP = "stackdsl: 1\nstructure: {tower: {levels: 1}}\n"


@dataclass(frozen=True)
class Scene:
    """A scene of the family: its ``name``, scenario ``text`` and where it comes from
    (``source``: a file, or what it is written like)."""

    name: str
    text: str
    source: str


def _read(path: Path) -> str:
    return path.read_text(encoding="utf-8")


def action_scenes(folder: Path = Path("scenarios")) -> list[Scene]:
    """The actions family's scenes, from ``folder``'s shipped files and written like them.

    Raises:
        OSError: a shipped file is missing.
    """
    stands, falls = _read(folder / "jenga_stands.yaml"), _read(folder / "jenga_falls.yaml")

    def taller(text: str) -> str:  # 18 levels: 54 blocks, built by 27 s; the second pull 9 s later than at 12
        return (
            text.replace("levels: 12", "levels: 18")
            .replace("after level 12", "after level 18")
            .replace("at: 22 s", "at: 31 s")
            .replace("collapse: 12", "collapse: 18")  # it falls once all 18 levels are placed
        )

    def pushed(text: str) -> str:  # the middle block of level 5 slid 30 mm out by a finger, not pulled
        head, _ = text.split("actions:\n", 1)
        return (
            head.replace("brick_types:\n", "brick_types:\n  finger: {size: [10 mm, 10 mm, 10 mm], material: maple}\n")
            + "actions:\n  - push: {target: {brick: L05.2}, direction: +x, speed: 40 mm/s, distance: 30 mm,"
            " at: after level 12, pusher: finger}\n"
            "expect:\n  moved: L05.2\n  stays: [1-4, L05.1, L05.3, 6-12]\n"
        )

    return [
        Scene("Jenga 12 stands", stands, str(folder / "jenga_stands.yaml")),
        Scene("Jenga 12 falls", falls, str(folder / "jenga_falls.yaml")),
        Scene("Jenga 18 stands", taller(stands), "jenga_stands.yaml at 18 levels"),
        Scene("Jenga 18 falls", taller(falls), "jenga_falls.yaml at 18 levels"),
        Scene("Jenga 12 push", pushed(stands), "jenga_stands.yaml, its middle block of level 5 pushed 30 mm"),
        Scene("30 dominoes", _read(folder / "dominoes_30.yaml"), str(folder / "dominoes_30.yaml")),
        Scene("120 dominoes", domino_row(120), "dominoes_30.yaml with 120"),
        Scene("shake below", _read(folder / "four_stack_shake_below.yaml"), str(folder / "four_stack_shake_below.yaml")),
        Scene("shake above", _read(folder / "four_stack_shake_above.yaml"), str(folder / "four_stack_shake_above.yaml")),
    ]


def domino_row(count: int) -> str:
    """``scenarios/dominoes_30.yaml``'s row with ``count`` dominoes (40 mm apart, one placed every
    0.1 s, the finger pushing the first 0.5 s after the last is placed), all to topple."""
    bricks = "\n".join(f"    - {{id: d{i + 1:03d}, at: [{i * 40} mm, 0, 60 mm], pitch: 90, level: 1}}" for i in range(count))
    return (
        f"stackdsl: 1\nname: {count} dominoes pushed over\nbrick_types:\n  finger: {{size: [20 mm, 10 mm, 10 mm]}}\n"
        f"structure:\n  bricks:\n{bricks}\ntiming: {{interval: 0.1 s, settle: {max(2.0, 0.06 * count):g} s}}\nactions:\n"
        f"  - push: {{target: {{brick: d001, offset: [0, 0, 45 mm]}}, direction: [1, 0, 0], speed: 0.2 m/s, "
        f"distance: 15 mm, at: {0.1 * count + 0.5:g} s, pusher: finger, id: finger}}\nexpect:\n  toppled: all\n"
    )


def tiny_scenes() -> list[Scene]:
    """Scenes small enough for a smoke run: a 3-level Jenga tower with a block pulled, 4 dominoes
    pushed over, a 2-level 4 stack on a shake table below its threshold."""
    jenga = (
        "stackdsl: 1\nmaterials: {maple: {density: 700 kg/m^3, friction: 0.4}}\n"
        "brick_types: {jenga: {size: [75 mm, 25 mm, 15 mm], material: maple}}\nground: {material: maple}\n"
        "structure: {tower: {levels: 5, bricks_per_layer: 3, spacing: 25.5 mm, turn: 90, brick: jenga}}\n"
        "timing: {interval: 0.2 s, settle: 0.2 s}\n"
        "actions: [{remove: {brick: L02.1, at: after level 5, speed: 80 mm/s}}]\nexpect: {stands: true}\n"
    )
    shake = (
        "stackdsl: 1\nstructure: {tower: {levels: 2, bricks_per_layer: 2, spacing: 96 mm, turn: 90}}\n"
        "timing: {interval: 0.2 s, settle: 0.2 s}\n"
        "actions: [{shake: {amplitude: 5 mm, frequency: 2 Hz, duration: 0.5 s, direction: [1, 0], at: after level 2}}]\n"
        "expect: {stands: true}\n"
    )
    return [Scene("tiny Jenga", jenga, "smoke"), Scene("4 dominoes", domino_row(4), "smoke"), Scene("tiny shake", shake, "smoke")]


def program_for(text: str, source: str, side: str) -> Program:
    """``text`` compiled for ``side`` (a name of :data:`SIDES`, or :data:`AS_WRITTEN`); the lean
    peer's with MuJoCo's own sleeping at :data:`PEER_SLEEP_TOLERANCE`.

    Raises:
        ScenarioError: the scene is refused on that side (a pull too fast for raw pybullet, say).
    """
    chosen = _ALL_SIDES[side]
    program = compile_scenario(parse_scenario(text, source), mode=chosen.mode, backend=chosen.backend)
    return as_peer(program, side) if chosen.lean else program


def as_peer(program: Program, side: str) -> Program:
    """``program`` (compiled for tuned MuJoCo) on the lean peer ``side``'s settings: MuJoCo's own
    sleeping at :data:`PEER_SLEEP_TOLERANCE`, then what the side changes (:attr:`Side.engine`)."""
    engine = program.engine.model_copy(update={"sleep_tolerance": PEER_SLEEP_TOLERANCE, **dict(_ALL_SIDES[side].engine)})
    return program.model_copy(update={"engine": engine})


@dataclass(frozen=True)
class Run:
    """One timed run of a cell: wall seconds, whether every expectation held (None: the side
    could not run it, ``verdict`` says why), the verdict's words, simulated seconds and steps."""

    scene: str
    side: str
    wall: float
    passed: bool | None
    verdict: str
    simulated: float = 0.0
    steps: int = 0


def run_cell(scene: Scene, side: str) -> Run:
    """Run ``scene`` on ``side`` once, timed, after a one-level tower on the same side, untimed
    (the process's first calls into its engine and libraries); meant for a fresh process. The
    scene's warnings (:class:`ScenarioWarning`) are not shown: a cell is run for its time, as
    often as it is repeated, and ``stackdsl check`` says them (:func:`check_times` keeps them)."""
    from .bench import LEAN_TOLERANCE
    from .lean_mujoco import run_lean

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ScenarioWarning)
            program = program_for(scene.text, scene.source, side)
    except ScenarioError as exc:
        return Run(scene.name, side, 0.0, None, "refused: " + str(exc).splitlines()[0])
    expect = parse_scenario(scene.text, scene.source).expect
    warm = program_for(_WARM_UP, "warm-up.yaml", side)
    if _ALL_SIDES[side].lean:
        try:
            run_lean(warm, tolerance=LEAN_TOLERANCE)
        except ValueError as exc:
            return Run(scene.name, side, 0.0, None, str(exc))
        try:
            start = time.perf_counter()
            lean = run_lean(program, tolerance=LEAN_TOLERANCE, settle=None)
            wall = time.perf_counter() - start
        except ValueError as exc:
            return Run(scene.name, side, 0.0, None, str(exc))
        passed, words = peer_verdicts(expect, program, lean)
        return Run(scene.name, side, wall, passed, words, lean.simulated, lean.steps)
    from ..runtime.run import run_program
    from ..verdicts.expect import describe_outcome, evaluate

    run_program(warm)
    start = time.perf_counter()
    outcome = run_program(program)
    wall = time.perf_counter() - start
    verdicts = evaluate(expect, outcome, program.collapse_threshold)
    failed = [f"{v.name}: {v.measured}" for v in verdicts if not v.passed]
    words = "; ".join(failed) if failed else describe_outcome(outcome, program.collapse_threshold)
    if expect.toppled is not None and not failed:  # as the peer's cell says it (peer_verdicts)
        count = f"{len(outcome.toppled)} of {len(outcome.displacement) + len(outcome.unplaced)} toppled"
        words = f"{words}; {count}" if _judges_more(expect) else count
    return Run(scene.name, side, wall, all(v.passed for v in verdicts), words, outcome.simulated_time, outcome.steps)


def peer_verdicts(expect: Expect, program: Program, lean: LeanOutcome) -> tuple[bool, str]:
    """Whether what the lean peer measured meets ``expect`` (the rules of
    :func:`stackdsl.verdicts.expect.evaluate` on the peer's collapse level, final displacements and
    toppled bricks), and in words: the failed expectations, else what it measured (with the brick
    farthest from its place at the end: ``collapse at level 11 (L12.1 ended 9.3 mm from its
    place)``, ``stands, moved 2.2 mm at most``). ``collapse``, ``stands``, ``stays`` and ``toppled``
    are judged; the others are not."""
    from ..lang.expectations import CollapseLevel

    threshold = program.collapse_threshold
    level = {p.id: p.level for p in program.placements}
    failed = []
    said = "stands" if lean.level is None else f"collapse at level {lean.level}"
    if lean.moved:  # how far it came: a peer that drags a level 9 mm and one that throws it 200 mm read alike
        brick, far = max(lean.moved.items(), key=lambda item: item[1])
        if lean.level is not None:
            said += f" ({brick} ended {far * 1000:.1f} mm from its place)"
        elif far >= 0.001:
            said += f", moved {far * 1000:.1f} mm at most"
    if isinstance(expect.collapse, CollapseLevel):
        c = expect.collapse
        if lean.level is None or abs(lean.level - c.level) > c.tolerance:
            failed.append(f"collapse: {said}")
    if expect.stands and lean.level is not None:
        failed.append(f"stands: {said}")
    if expect.stays:
        levels, starts = set(levels_of(expect.stays)), bricks_of(expect.stays)
        moved = [b for b, d in lean.moved.items() if d > threshold and (level[b] in levels or b.startswith(starts))]
        if moved:
            at = sorted({level[b] for b in moved})
            bricks = "1 brick" if len(moved) == 1 else f"{len(moved)} bricks"
            failed.append(f"stays: {bricks} of level{'s' if len(at) > 1 else ''} {', '.join(map(str, at))} moved")
    toppled = f"{len(lean.toppled)} of {len(lean.moved)} toppled"
    if expect.toppled is not None:
        least, most = expect.toppled.allows(len(program.placements) - len(lean.removed))
        if not least <= len(lean.toppled) <= most:
            failed.append(f"toppled: {toppled}")
        said = f"{said}; {toppled}" if _judges_more(expect) else toppled
    return not failed, "; ".join(failed) if failed else said


def _judges_more(expect: Expect) -> bool:
    """Whether ``expect`` asks of the collapse, or of what stands or stays, beside the toppled
    count: a cell that held says both (a new user's "collapse: 8, toppled: 0" read only "0 of 16
    toppled")."""
    return expect.collapse is not None or bool(expect.stands) or bool(expect.stays)


def _run_cell(arguments: tuple[Scene, str]) -> Run:
    return run_cell(*arguments)


@dataclass(frozen=True)
class Cell:
    """A cell's runs: the median wall time (s) and every run's, its first run's verdict, and
    whether the runs' verdicts agreed among themselves."""

    scene: str
    side: str
    wall: float
    walls: tuple[float, ...]
    passed: bool | None
    verdict: str
    steady: bool


def run_cells(
    scenes: Sequence[Scene],
    sides: Sequence[str],
    repeats: int = 3,
    jobs: int = 1,
    progress: Callable[[Run], None] = lambda r: None,
) -> list[Cell]:
    """Every side on every scene, ``repeats`` runs each in rounds, each run in a fresh spawned
    process (:data:`TIMING`); cells in the order of ``scenes``, then ``sides``."""
    tasks = [(scene, side) for scene in scenes for side in sides]
    runs: dict[tuple[str, str], list[Run]] = {}
    with SPAWN.Pool(processes=jobs, maxtasksperchild=1) as pool:
        for _ in range(max(1, repeats)):
            for run in pool.imap_unordered(_run_cell, tasks):
                runs.setdefault((run.scene, run.side), []).append(run)
                progress(run)
            tasks = [t for t in tasks if runs[(t[0].name, t[1])][0].passed is not None]  # a side that cannot run it: once
    cells = []
    for scene in scenes:
        for side in sides:
            done = runs[(scene.name, side)]
            walls = tuple(sorted(r.wall for r in done))
            first = done[0]
            steady = len({(r.passed, r.verdict) for r in done}) == 1
            cells.append(Cell(scene.name, side, statistics.median(walls), walls, first.passed, first.verdict, steady))
    return cells


def format_cells(cells: Sequence[Cell], repeats: int, peer: str = "MuJoCo lean") -> str:
    """A Markdown table of :func:`run_cells`' cells: each cell's verdict against its scene's
    expectation (PASS, or FAIL and that it disagrees with the expectation, on every side alike),
    its median wall time and every run's, and the peer's wall time over the cell's (``peer /
    this``), then how every cell was timed."""
    peers = {c.scene: c.wall for c in cells if c.side == peer and c.passed is not None}
    lines = [
        "| scene | side | verdict | wall (s), median | runs (s) | peer / this |",
        "|---|---|---|---:|---|---:|",
    ]
    for c in cells:
        if c.passed is None:
            lines.append(f"| {c.scene} | {c.side} | not run: {c.verdict} | | | |")
            continue
        mark = "PASS" if c.passed else "FAIL (disagrees with the expectation)"
        if not c.steady:
            mark += " (not every run agreed)"
        ratio = f"{peers[c.scene] / c.wall:.1f}" if c.scene in peers and c.side != peer and c.wall > 0 else ""
        runs = " ".join(f"{w:.2f}" for w in c.walls)
        lines.append(f"| {c.scene} | {c.side} | {mark}: {c.verdict} | {c.wall:.2f} | {runs} | {ratio} |")
    lines += ["", RATIO.format(peer=peer), *overall(cells, peer)]
    for other in dict.fromkeys(c.side for c in cells if c.side != peer and _ALL_SIDES[c.side].lean):  # and each other peer
        lines += [f"against the {other} peer:", *(f"  {line}" for line in overall(cells, other))]
    lines.append(TIMING.format(repeats=repeats) + ".")
    return "\n".join(lines)


def overall(cells: Sequence[Cell], peer: str = "MuJoCo lean") -> list[str]:
    """A line for each side but ``peer``: over the scenes both ran, the peer's summed median wall
    time over the side's, and the geometric mean of the rows' ``peer / this`` (each scene
    weighed alike, where the sums weigh the long scenes); and how many of its cells passed, and
    of those the peer did not run; then how many of the peer's passed."""
    peers = {c.scene: c.wall for c in cells if c.side == peer and c.passed is not None}
    lines = []
    for side in dict.fromkeys(c.side for c in cells if c.side != peer):
        both = [c for c in cells if c.side == side and c.passed is not None and c.scene in peers and c.wall > 0]
        if not both:
            continue
        mine, theirs = sum(c.wall for c in both), sum(peers[c.scene] for c in both)
        ratios = [peers[c.scene] / c.wall for c in both]
        mean = statistics.geometric_mean(ratios) if min(ratios) > 0 else 0.0
        passed = sum(bool(c.passed) for c in both)
        alone = [c for c in cells if c.side == side and c.passed is not None and c not in both]
        more = (  # its rows the peer did not run: a failure there read as if every row had passed
            f" (and {sum(bool(c.passed) for c in alone)} of {len(alone)} PASS where the peer did not run)" if alone else ""
        )
        lines.append(
            f"overall, {side}: {theirs:.2f} s of the peer's over {mine:.2f} s = {theirs / mine:.1f}x summed, "
            f"{mean:.1f}x the geometric mean of {len(both)} rows; {passed} of {len(both)} PASS{more}"
        )
    # and the peer's own verdicts: a peer that failed two scenes read as if every side had passed
    judged = [c for c in cells if c.side == peer and c.passed is not None]
    if lines and judged:
        lines.append(f"overall, {peer}: {sum(bool(c.passed) for c in judged)} of {len(judged)} PASS")
    return lines


def folder_scenes(folder: Path) -> list[Scene]:
    """Every scenario file under ``folder`` (as ``stackdsl check`` finds them) that is not a
    sweep, as scenes named by their path below ``folder``.

    Raises:
        ScenarioErrors: as :func:`stackdsl.batch.check.discover`.
    """
    from ..batch.check import discover

    scenes = []
    for path in discover([folder]):
        text = path.read_text(encoding="utf-8")
        if "\nsweep:" in text:
            continue
        scenes.append(Scene(str(path.relative_to(folder)), text, str(path)))
    return scenes


@dataclass(frozen=True)
class CheckTime:
    """``stackdsl check FOLDER -j jobs``: wall seconds of each run (a fresh process each), the
    exit code of the first, its last line (how many passed and failed) and the warnings it gave
    (``file:line:col: warning: ...``, each once)."""

    jobs: str
    walls: tuple[float, ...]
    exit_code: int
    summary: str = ""
    warnings: tuple[str, ...] = ()

    @property
    def wall(self) -> float:
        """The median wall time, s."""
        return statistics.median(self.walls)


def check_times(folder: Path, jobs: Sequence[str] = ("1", "auto"), repeats: int = 1) -> list[CheckTime]:
    """Time ``python -m stackdsl check FOLDER -j J`` for each of ``jobs``, ``repeats`` times each in
    rounds, each a fresh process as a user runs it (its start and imports included)."""
    walls: dict[str, list[float]] = {j: [] for j in jobs}
    codes: dict[str, int] = {}
    said: dict[str, str] = {}
    warned: dict[str, tuple[str, ...]] = {}
    command = [sys.executable, "-m", "stackdsl", "check", str(folder)]
    for _ in range(max(1, repeats)):
        for j in jobs:
            start = time.perf_counter()
            done = subprocess.run([*command, "-j", j], capture_output=True, env={**os.environ, "PYTHONHASHSEED": "0"})
            walls[j].append(time.perf_counter() - start)
            codes.setdefault(j, done.returncode)
            said.setdefault(j, _last_line(done.stdout) or _last_line(done.stderr))  # a refusal says why on stderr
            lines = done.stderr.decode(errors="replace").splitlines()
            warned.setdefault(j, tuple(dict.fromkeys(line for line in lines if ": warning: " in line)))
    return [CheckTime(j, tuple(walls[j]), codes[j], said[j], warned[j]) for j in jobs]


def _last_line(output: bytes) -> str:
    """The last line of ``output`` that is not blank, "" if none."""
    return next((line for line in reversed(output.decode(errors="replace").splitlines()) if line.strip()), "")


def format_check_times(times: Sequence[CheckTime], folder: Path, files: int) -> str:
    """A Markdown table of :func:`check_times`; under it, a note when a run refused bad input
    (exit code 2: its time is of a refusal, not of the folder's runs)."""
    lines = [
        f"`stackdsl check {folder}` ({files} file{'' if files == 1 else 's'}), each run a fresh `python -m stackdsl` process:",
        "",
        "| -j | wall (s), median | runs (s) | exit code | the first run's last line |",
        "|---|---:|---|---:|---|",
    ]
    for t in times:
        runs = " ".join(f"{w:.1f}" for w in sorted(t.walls))
        lines.append(f"| {t.jobs} | {t.wall:.1f} | {runs} | {t.exit_code} | {t.summary.replace('|', '/')} |")
    if any(t.exit_code == 2 for t in times):
        lines += ["", "exit code 2: check refused bad input and ran nothing, or only part: its time is not the folder's"]
    said = dict.fromkeys(w for t in times for w in t.warnings)
    if said:
        lines += ["", "its warnings (the cells below compile the same files and do not say them again):", *said]
    return "\n".join(lines)

"""Where an action scene's time goes: each phase's wall time, and the parts of the extension's work in it.

    python docs/results/action_costs.py "Jenga 12 stands" 18,22
    python docs/results/action_costs.py "Jenga 18 stands" 27,31
    python docs/results/action_costs.py "Jenga 12 falls" 18,22,22.2,24,24.7
    python docs/results/action_costs.py "Jenga 12 falls" 18,22,22.2,24,24.7 --peer   # and the lean peer's phases
    python docs/results/action_costs.py "30 dominoes" 3.5 --runs 5
    python docs/results/action_costs.py "120 dominoes" 12.5 --runs 2

Runs SCENE (a cell of ``stackdsl bench actions``, by its name, from the project's folder; or a
scenario file) with the extension on pybullet ``--runs`` times in this process, after a one-level tower, untimed (as
``stackdsl bench actions`` warms a cell's process), and keeps the fastest run. The
phases are the stretches of simulated time between the cuts (seconds, comma-separated): the wall
time of each, its steps, the mean number of active bricks the extension hands the engine, and
the time of each part of :data:`PARTS` charged to the phase its call began in. Each part is its
function wrapped in ``time.perf_counter``, inclusive (a part called inside another counts in
both; the wrapping adds about a microsecond a call; a part never called is left out). Admissions
are split by their answer: a freeze, or a refusal.

With ``--peer``, the lean MuJoCo peer of ``stackdsl bench actions`` (``stackdsl/bench/lean_mujoco.py``,
its settings and solver tolerance as the bench gives them) runs the same scene as many times, after
its own warm-up, and its fastest run's wall time is charged to the same phases, a watch interval
(1/60 s of simulated time) at a time: two more rows, its wall time and its wall time over the
extension's, phase by phase.

Output: docs/results/actions.md, "Where the time goes".
"""

from __future__ import annotations

import argparse
import importlib
import itertools
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from stackdsl.bench.actions import _WARM_UP, action_scenes, program_for
from stackdsl.bench.bench import LEAN_TOLERANCE
from stackdsl.runtime.loop import StepLoop, Subscriber
from stackdsl.runtime.run import run_in, run_program, world_for

PARTS = (
    ("the engine's steps", "stackdsl.engines.pybullet.world:PyBulletWorld.step"),
    ("the extension's update, all", "stability._extension:StabilityExtension.update"),
    ("- a pull's or push's proof kept", "stability._extension:StabilityExtension._reprove"),
    ("-- its statics checks", "stability._drag:PullProof.check"),
    ("--- their friction programs (in line, else HiGHS)", "stability._drag:held_together"),
    ("- rides", "stability._extension:StabilityExtension._rides"),
    ("- landings of placed bricks", "stability._extension:StabilityExtension._landings"),
    ("- admissions", "stability._extension:StabilityExtension._admit"),
    ("- the stack test", "stability._stack_test:StackTest.run"),
    ("- the impact rule", "stability._impact:Impacts.check"),
    ("-- its barriers", "stability._impact:Impacts._barrier"),
    ("placing bricks", "stackdsl.runtime.loop:StepLoop.place"),
    ("the collapse monitor", "stackdsl.runtime.collapse:CollapseMonitor.after_step"),
)
"""(row name, module:Class.method or module:function) of each part timed."""

FREEZES, REFUSALS = "-- of which freezes", "-- of which refusals"
"""The rows of the admissions that froze bricks, and of those that did not."""


class _Books:
    """Each part's seconds and calls by phase, the phases' wall times, steps and active bricks."""

    def __init__(self, cuts: list[float]) -> None:
        self.cuts, self.now = cuts, 0.0
        n = len(cuts) + 1
        names = [name for name, _ in PARTS]
        at = names.index("- admissions") + 1
        names[at:at] = [FREEZES, REFUSALS]
        self.seconds: dict[str, list[float]] = {name: [0.0] * n for name in names}
        self.calls: dict[str, list[int]] = {name: [0] * n for name in self.seconds}
        self.steps, self.active = [0] * n, [0] * n
        self.marks: list[float] = []

    def phase(self) -> int:
        return sum(self.now >= c for c in self.cuts)


def _wrap(books: _Books, name: str, where: str) -> Callable[[], None]:
    """Wrap the function at ``where`` so that its time goes to ``name``; returns the undo."""
    module_name, attr = where.split(":")
    module = importlib.import_module(module_name)
    owner: Any = module
    *path, last = attr.split(".")
    for part in path:
        owner = getattr(owner, part)
    original = getattr(owner, last)

    def timed(*args: Any, **kwargs: Any) -> Any:
        k = books.phase()
        start = time.perf_counter()
        result = original(*args, **kwargs)
        spent = time.perf_counter() - start
        books.seconds[name][k] += spent
        books.calls[name][k] += 1
        if last == "_admit":
            which = FREEZES if any(e.kind == "freeze" for e in result) else REFUSALS
            books.seconds[which][k] += spent
            books.calls[which][k] += 1
        if last == "update":
            books.steps[k] += 1
            books.active[k] += len(args[0]._stack.active)
        return result

    setattr(owner, last, timed)
    return lambda: setattr(owner, last, original)


class _Clock(Subscriber):
    """Keeps the books' simulated time, and the wall time at each cut."""

    def __init__(self, books: _Books) -> None:
        self.books = books

    def before_step(self, loop: StepLoop) -> None:
        books = self.books
        books.now = loop.now
        while len(books.marks) < len(books.cuts) and loop.now >= books.cuts[len(books.marks)]:
            books.marks.append(time.perf_counter())


def scene(name: str) -> str:
    """The scenario text of ``name``: a cell of the actions family, or a file's path."""
    cells = {s.name: s.text for s in action_scenes()}
    return cells[name] if name in cells else Path(name).read_text(encoding="utf-8")


def measure(name: str, cuts: list[float]) -> tuple[_Books, float]:
    """One run of the scene ``name`` (:func:`scene`): its books and its wall time (s), from the
    compiled program on."""
    program = program_for(scene(name), name, "extension")
    books = _Books(cuts)
    undo = [_wrap(books, name, where) for name, where in PARTS]
    try:
        start = time.perf_counter()
        with world_for(program) as world:
            run_in(world, program, subscribers=(_Clock(books),))
        end = time.perf_counter()
    finally:
        for u in reversed(undo):
            u()
    books.marks = [start, *books.marks, *[end] * (len(cuts) - len(books.marks)), end]  # a cut never reached: the end
    return books, end - start


def peer(name: str, cuts: list[float]) -> list[float]:
    """One run of the scene ``name`` by the lean MuJoCo peer, as ``stackdsl bench actions`` runs
    it: the wall time (s) of each phase between ``cuts``, then of the whole run, from its model on."""
    from stackdsl.bench import lean_mujoco

    program = program_for(scene(name), name, "MuJoCo lean")
    walls = [0.0] * (len(cuts) + 1)
    owner: Any = lean_mujoco._LeanRun
    original = owner.step

    def timed(run: Any) -> bool:
        k = sum(float(run.data.time) >= c for c in cuts)
        start = time.perf_counter()
        ended: bool = original(run)
        walls[k] += time.perf_counter() - start
        return ended

    owner.step = timed
    try:
        start = time.perf_counter()
        lean_mujoco.run_lean(program, tolerance=LEAN_TOLERANCE, settle=None)
        whole = time.perf_counter() - start
    finally:
        owner.step = original
    walls[0] += whole - sum(walls)  # building its model, and its steps' bookkeeping between them
    return [*walls, whole]


def table(books: _Books, wall: float, peers: list[float] | None = None) -> str:
    """The books as a markdown table: a column a phase, then the whole run; with ``peers`` (the
    lean peer's wall times, :func:`peer`), its rows too."""
    edges = ["0", *(f"{c:g}" for c in books.cuts), "end"]
    heads = [f"{a} to {b} s" for a, b in itertools.pairwise(edges)]
    lines = ["| | " + " | ".join(heads) + " | whole run |", "|---" + "|---:" * (len(heads) + 1) + "|"]
    walls = [b - a for a, b in itertools.pairwise(books.marks)]
    lines.append("| wall (ms) | " + " | ".join(f"{w * 1000:.0f}" for w in walls) + f" | {wall * 1000:.0f} |")
    if peers is not None:
        lines.append("| the lean MuJoCo peer's wall (ms) | " + " | ".join(f"{w * 1000:.0f}" for w in peers) + " |")
        ratios = [f"{p / w:.1f}" if w > 0 else "-" for p, w in zip(peers, [*walls, wall])]
        lines.append("| peer / this | " + " | ".join(ratios) + " |")
    lines.append("| steps | " + " | ".join(str(s) for s in books.steps) + f" | {sum(books.steps)} |")
    mean = [f"{a / s:.1f}" if s else "-" for a, s in zip(books.active, books.steps)]
    lines.append("| active bricks, mean | " + " | ".join(mean) + " | |")
    for name, seconds in books.seconds.items():
        calls = books.calls[name]
        if not any(calls):
            continue  # a part this scene never calls
        cells = [f"{t * 1000:.0f} ({n})" if n else "" for t, n in zip(seconds, calls)]
        lines.append(f"| {name} (ms, calls) | " + " | ".join(cells) + f" | {sum(seconds) * 1000:.0f} ({sum(calls)}) |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", help="a cell of `stackdsl bench actions`, or a scenario file")
    parser.add_argument("cuts", nargs="?", default="", help="comma-separated simulated times, s")
    parser.add_argument("--runs", type=int, default=3, help="runs; the fastest is kept (default 3)")
    parser.add_argument("--peer", action="store_true", help="also the lean MuJoCo peer's wall time by phase")
    args = parser.parse_args()
    cuts = sorted(float(c) for c in args.cuts.split(",") if c.strip())
    run_program(program_for(_WARM_UP, "warm-up", "extension"))
    best = min((measure(args.scene, cuts) for _ in range(max(1, args.runs))), key=lambda m: m[1])
    peers = None
    if args.peer:
        from stackdsl.bench.lean_mujoco import run_lean

        run_lean(program_for(_WARM_UP, "warm-up", "MuJoCo lean"), tolerance=LEAN_TOLERANCE)  # as the bench warms it
        peers = min((peer(args.scene, cuts) for _ in range(max(1, args.runs))), key=lambda w: w[-1])
    sides = "the extension on pybullet" + (" and the lean MuJoCo peer" if args.peer else "")
    print(f"{args.scene}: the fastest of {args.runs} runs, {sides}\n")
    print(table(*best, peers))


if __name__ == "__main__":
    main()

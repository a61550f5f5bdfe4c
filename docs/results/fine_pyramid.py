"""What the finer and the wider friction pyramids cost, started from the eight-sided program or from scratch.

    python docs/results/fine_pyramid.py [SCENARIO ...]   # default: the bench's 4.5 mm slant log cabin

A program that the eight-sided pyramid fails by a small tension is asked again: with the
pyramid around the cone (only for a verdict, the debris rule's piles) and with 32 sides
(:func:`stability.solve_equilibrium`). Both now start where the eight-sided program ended: the
wider one from its basis by the primal simplex, the 32-sided one by column generation from its
edges (:func:`stability._lp.solve_by_columns`). This runs each scenario once with the extension,
going on 2 s after a collapse as ``stackdsl check`` does, records every such program as it is
asked (with the eight-sided basis it started from), then solves each again both ways and prints
per scenario: the programs, the mean wall time and simplex iterations of a program each way,
whether the verdicts are the same, and the most the least tensions differ, as a share of the
blocks' weight (a program stands when its least tension is at most 1e-7 of it).

Output: docs/results/programs.md ("The finer and the wider pyramid").
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

import stability._equilibrium as equilibrium_module
import stability._lp as lp_module
from stability._lp import WarmStart
from stackdsl import compile_scenario, parse_scenario
from stackdsl.bench.bench import program_for, scenes
from stackdsl.runtime.run import RunOptions, run_program

ROOT = Path(__file__).resolve().parents[2]
SETTLE = 2.0
"""Seconds a run goes on after its collapse (a scenario's own settle time, as ``stackdsl check``)."""

ASKED: list[tuple[str, tuple[Any, ...], WarmStart]] = []
"""The programs the run going now asked for: ("fine" or "wider", ``_solve``'s arguments, the start)."""


def _record() -> Any:
    """Wrap ``_solve`` to record each finer and wider program with a copy of the basis it
    started from; returns the original."""
    original = equilibrium_module._solve

    def recorded(*args: Any, **options: Any) -> Any:
        if options.get("start") is not None:
            ASKED.append(("fine", args, options["start"][1].copy()))
        elif options.get("primal"):
            ASKED.append(("wider", args, options["warm"].copy()))
        return original(*args, **options)

    equilibrium_module._solve = recorded  # type: ignore[assignment]
    return original


def _solved(solve: Any, kind: str, args: tuple[Any, ...], start: WarmStart | None) -> tuple[float, int, Any]:
    """Wall time, simplex iterations and answer of one program, from ``start`` or from scratch."""
    pivots = [0]
    program_solve = lp_module.LinearProgram.solve

    def counted(self: Any, warm: Any = None) -> Any:
        solution = program_solve(self, warm)
        pivots[0] += solution.iterations
        return solution

    lp_module.LinearProgram.solve = counted  # type: ignore[method-assign]
    try:
        tick = time.perf_counter()
        if start is None:
            found = solve(*args)
        elif kind == "fine":
            found = solve(*args, start=(8, start.copy()))
        else:
            found = solve(*args, warm=start.copy(), primal=True)
        return time.perf_counter() - tick, pivots[0], found
    finally:
        lp_module.LinearProgram.solve = program_solve  # type: ignore[method-assign]


def _weight(args: tuple[Any, ...]) -> float:
    """Newtons: the weight of a program's free blocks (``_solve``'s blocks and gravity)."""
    blocks, gravity = args[0], args[3]
    return float(sum(b.mass for b in blocks.values()) * gravity)


def _run(name: str) -> None:
    if name.endswith((".yaml", ".yml")):
        path = ROOT / name if not Path(name).is_absolute() else Path(name)
        program = compile_scenario(parse_scenario(path.read_text(), str(path)))
    else:
        family, _, shift = name.rpartition(" ")
        (scene,) = [s for s in scenes() if s.family == family and s.parameter == float(shift.removesuffix("mm"))]
        program = program_for(scene, "extension report")
    run_program(program, RunOptions(stop_at_collapse=True, settle=SETTLE))


def main(names: list[str]) -> None:
    print(
        "| scene | kind | programs | from the eight-sided, ms | iterations | from scratch, ms | iterations | same verdicts | tension apart, most |"
    )
    print("|---|---|---:|---:|---:|---:|---:|---|---:|")
    solve = _record()
    try:
        for name in names:
            ASKED.clear()
            _run(name)
            asked = list(ASKED)
            for kind in ("fine", "wider"):
                mine = [(args, start) for k, args, start in asked if k == kind]
                if not mine:
                    continue
                started = [_solved(solve, kind, args, start) for args, start in mine]
                scratch = [_solved(solve, kind, args, None) for args, _ in mine]
                verdicts = all(a[2].stands == b[2].stands for a, b in zip(started, scratch, strict=True))
                apart = max(abs(a[2].tension - b[2].tension) / _weight(args) for (a, b, (args, _)) in zip(started, scratch, mine))
                n = len(mine)
                print(
                    f"| {Path(name).stem if name.endswith('.yaml') else name} | {'32 sides' if kind == 'fine' else 'around the cone'} | {n} | "
                    f"{sum(s[0] for s in started) / n * 1000:.1f} | {sum(s[1] for s in started) / n:.0f} | "
                    f"{sum(s[0] for s in scratch) / n * 1000:.1f} | {sum(s[1] for s in scratch) / n:.0f} | "
                    f"{'yes' if verdicts else 'NO'} | {apart:.1e} |"
                )
    finally:
        equilibrium_module._solve = solve  # type: ignore[assignment]


if __name__ == "__main__":
    main(sys.argv[1:] or ["slant log cabin 4.5"])

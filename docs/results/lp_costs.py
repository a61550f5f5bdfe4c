"""What the stability model's linear programs cost: through scipy's ``linprog`` and through highspy.

    python docs/results/lp_costs.py [SCENARIO ...]    # default: six shipped scenarios

Runs each scenario once with the extension (the programs it solves are recorded as they are
asked: the equilibrium program, its vertical-force test, a pull's drag program, the load split's
least change, and each direction of a stand's margin), then solves every recorded program
``REPEATS`` times both ways in this process and prints, per scenario, the programs' count and the mean wall time a program
through scipy's ``linprog(method="highs")`` and through :func:`stability._lp.solve`, with
whether the two agree (status, optimal value within 1e-9, and the equality duals within 1e-9
where the program was solved). The margin's programs are also timed as the margin asks them: one
program kept, its shift column changed direction after direction and solved again from the last
basis (:class:`stability._lp.LinearProgram`), against a new ``linprog`` each time.

Output: docs/results/programs.md.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from scipy import sparse
from scipy.optimize import linprog

import stability._drag as drag_module
import stability._equilibrium as equilibrium_module
import stability._load as load_module
import stability._margin as margin_module
from stability._lp import OPTIMAL, LinearProgram, solve
from stackdsl import compile_scenario, parse_scenario, run_program

ROOT = Path(__file__).resolve().parents[2]
DEFAULT = (
    "scenarios/card_house.yaml",
    "scenarios/jenga_stands.yaml",
    "scenarios/jenga_falls.yaml",
    "scenarios/four_stack_shake_above.yaml",
    "scenarios/slant_tower.yaml",
    "scenarios/lean_wall_stands.yaml",
)
REPEATS = 5


PROGRAMS: list[dict[str, Any]] = []
"""The programs the run going now asked for (cleared for each scenario)."""
SHIFTS: dict[int, tuple[Any, list[np.ndarray]]] = {}
"""The margin's programs of shifts the run asked for, with the directions asked of each."""


def _record() -> Callable[[], None]:
    """Wrap the modules' ``solve`` to record each program in :data:`PROGRAMS`, and the margin's
    ``_reach`` to record each program of shifts and its directions in :data:`SHIFTS`; returns
    what puts the originals back."""
    originals = (equilibrium_module.solve, drag_module.solve, load_module.solve, margin_module._ShiftProgram._reach)

    def undo() -> None:
        equilibrium_module.solve, drag_module.solve, load_module.solve = originals[:3]  # type: ignore[assignment]
        margin_module._ShiftProgram._reach = originals[3]  # type: ignore[method-assign]

    def recording(original: Any) -> Any:
        def solve_recorded(cost: np.ndarray, a_eq: Any, b_eq: np.ndarray, **options: Any) -> Any:
            PROGRAMS.append({"cost": cost, "a_eq": a_eq, "b_eq": b_eq, **options})
            return original(cost, a_eq, b_eq, **options)

        return solve_recorded

    equilibrium_module.solve = recording(equilibrium_module.solve)  # type: ignore[assignment]
    drag_module.solve = recording(drag_module.solve)  # type: ignore[assignment]
    load_module.solve = recording(load_module.solve)  # type: ignore[assignment]
    reach = margin_module._ShiftProgram._reach

    def reach_recorded(self: Any, direction: np.ndarray) -> Any:
        SHIFTS.setdefault(id(self), (self, []))[1].append(np.asarray(direction, dtype=float))
        return reach(self, direction)

    margin_module._ShiftProgram._reach = reach_recorded  # type: ignore[method-assign]
    return undo


def _scipy(program: dict[str, Any]) -> Any:
    options = {}
    if program.get("iteration_limit") is not None:
        options["maxiter"] = program["iteration_limit"]
    if program.get("presolve") is False:
        options["presolve"] = False
    bounds = (0, None) if program.get("upper") is None else list(zip(np.zeros(len(program["cost"])), program["upper"]))
    return linprog(
        program["cost"],
        A_eq=program["a_eq"],
        b_eq=program["b_eq"],
        A_ub=program.get("a_ub"),
        b_ub=program.get("b_ub"),
        bounds=bounds,
        method="highs",
        options=options,
    )


def _ours(program: dict[str, Any]) -> Any:
    return solve(
        program["cost"],
        program["a_eq"],
        program["b_eq"],
        **{k: v for k, v in program.items() if k not in ("cost", "a_eq", "b_eq")},
    )


def _timed(call: Any, argument: Any) -> tuple[float, Any]:
    call(argument)
    start = time.perf_counter()
    for _ in range(REPEATS):
        result = call(argument)
    return (time.perf_counter() - start) / REPEATS, result


def _agree(theirs: Any, ours: Any) -> bool:
    if (theirs.status == 0) != (ours.status == OPTIMAL):
        return False
    if ours.status != OPTIMAL:
        return True
    duals = np.asarray(theirs.eqlin.marginals, dtype=float)
    return bool(abs(theirs.fun - ours.fun) <= 1e-9 and np.allclose(duals, ours.eq_duals, atol=1e-9))


def _margin_costs(shifts: dict[int, tuple[Any, list[np.ndarray]]]) -> tuple[int, float, float]:
    """The margin's programs as it asks them: (directions, s through linprog, s kept and warm)."""
    cold = warm = 0.0
    count = 0
    for program, directions in shifts.values():
        n = program.a.shape[1]
        bounds = np.vstack([np.column_stack([np.zeros(n), program.upper]), [[0.0, program.limit]]])
        cost = np.zeros(n + 1)
        cost[-1] = -1.0
        start = time.perf_counter()
        for d in directions:
            a = sparse.hstack([program.a, sparse.csr_matrix((program.shift @ d)[:, None])])
            linprog(cost, A_eq=a.tocsr(), b_eq=program.rhs, bounds=bounds, method="highs")
        cold += time.perf_counter() - start
        start = time.perf_counter()
        kept = None
        rows = np.flatnonzero(program.shift.any(axis=1))
        for d in directions:
            column = program.shift @ d
            if kept is None:
                kept = LinearProgram(
                    cost,
                    sparse.hstack([program.a, sparse.csr_matrix(column[:, None])]),
                    program.rhs,
                    upper=np.append(program.upper, program.limit),
                )
            else:
                kept.set_column(n, rows, column[rows])
            kept.solve()
        warm += time.perf_counter() - start
        count += len(directions)
    return count, cold, warm


def main(files: list[str]) -> None:
    print(
        "| scenario | programs | linprog, ms a program | highspy, ms a program | agree | margin directions | margin through linprog, ms | margin kept and warm, ms |"
    )
    print("|---|---:|---:|---:|---|---:|---:|---:|")
    undo = _record()
    try:
        for name in files:
            PROGRAMS.clear()
            SHIFTS.clear()
            path = ROOT / name if not Path(name).is_absolute() else Path(name)
            run_program(compile_scenario(parse_scenario(path.read_text(), str(path))))
            theirs_time = ours_time = 0.0
            agree = True
            programs, shifts = list(PROGRAMS), dict(SHIFTS)
            for program in programs:
                t, theirs = _timed(_scipy, program)
                o, ours = _timed(_ours, program)
                theirs_time, ours_time = theirs_time + t, ours_time + o
                agree = agree and _agree(theirs, ours)
            count, cold, warm = _margin_costs(shifts)
            n = max(len(programs), 1)
            print(
                f"| {Path(name).stem} | {len(programs)} | {theirs_time / n * 1000:.2f} | {ours_time / n * 1000:.2f} | "
                f"{'yes' if agree else 'NO'} | {count} | {cold * 1000:.1f} | {warm * 1000:.1f} |"
            )
    finally:
        undo()


if __name__ == "__main__":
    main(sys.argv[1:] or list(DEFAULT))

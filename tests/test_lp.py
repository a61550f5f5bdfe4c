"""The stability model's linear programs through highspy (stability/_lp.py) against scipy's linprog."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import sparse
from scipy.optimize import linprog

from stability._lp import INFEASIBLE, ITERATION_LIMIT, OPTIMAL, LinearProgram, WarmStart, solve, solve_by_columns


def _random_program(seed: int, rows: int = 12, columns: int = 40) -> tuple[np.ndarray, sparse.csr_matrix, np.ndarray]:
    """A feasible program with a unique optimum (random costs), as dense as the equilibrium's."""
    rng = np.random.default_rng(seed)
    a = sparse.random(rows, columns, density=0.3, random_state=rng, format="csr")
    x = rng.uniform(0.0, 1.0, columns)
    return rng.uniform(0.1, 1.0, columns), a, a @ x


@pytest.mark.parametrize("seed", range(8))
def test_a_program_has_scipys_optimum_and_duals(seed):
    cost, a, b = _random_program(seed)
    ours = solve(cost, a, b)
    theirs = linprog(cost, A_eq=a, b_eq=b, bounds=(0, None), method="highs")
    assert ours.status == OPTIMAL and theirs.status == 0
    assert ours.fun == pytest.approx(theirs.fun, rel=1e-9, abs=1e-12)
    assert np.allclose(ours.x, theirs.x, atol=1e-9)
    assert np.allclose(ours.eq_duals, theirs.eqlin.marginals, atol=1e-9)


def test_inequalities_and_upper_bounds_are_kept():
    # max x0 + x1 with x0 + 2 x1 <= 4, x0 <= 3, x1 <= 5
    found = solve(
        np.array([-1.0, -1.0]),
        np.zeros((0, 2)),
        np.zeros(0),
        a_ub=np.array([[1.0, 2.0]]),
        b_ub=np.array([4.0]),
        upper=np.array([3.0, 5.0]),
    )
    assert found.status == OPTIMAL
    assert found.x.tolist() == pytest.approx([3.0, 0.5])


def test_an_infeasible_program_says_so():
    # x0 + x1 = -1 with both >= 0
    assert solve(np.zeros(2), np.array([[1.0, 1.0]]), np.array([-1.0])).status == INFEASIBLE


def test_the_iteration_limit_stops_the_solver():
    cost, a, b = _random_program(3, rows=30, columns=120)
    assert solve(cost, a, b, iteration_limit=1, presolve=False).status == ITERATION_LIMIT


def test_a_changed_column_solves_as_a_new_program():
    """The margin's search changes one column between solves: warm, the answer is a cold solve's."""
    cost, a, b = _random_program(5)
    rng = np.random.default_rng(9)
    program = LinearProgram(cost, a, b)
    program.solve()
    for _ in range(5):
        column = int(rng.integers(a.shape[1]))
        values = rng.uniform(0.0, 1.0, a.shape[0])
        program.set_column(column, np.arange(a.shape[0]), values)
        changed = a.tolil()
        changed[:, column] = values[:, None]
        a = changed.tocsr()
        assert program.solve().fun == pytest.approx(solve(cost, a, b).fun, rel=1e-9, abs=1e-12)


def test_shapes_that_disagree_are_refused():
    with pytest.raises(ValueError, match="cannot have a matrix"):
        LinearProgram(np.zeros(3), np.zeros((2, 4)), np.zeros(2))


def test_the_results_script_solves_a_scenes_programs_both_ways_alike(capsys):
    """docs/results/lp_costs.py on a leaning wall that stands: its programs and its margin's."""
    import importlib.util
    import sys
    from pathlib import Path

    script = Path(__file__).parent.parent / "docs" / "results" / "lp_costs.py"
    spec = importlib.util.spec_from_file_location("lp_costs", script)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["lp_costs"] = module
    spec.loader.exec_module(module)
    from stability import _equilibrium

    before = _equilibrium.solve
    module.main(["scenarios/lean_wall_stands.yaml"])
    row = capsys.readouterr().out.splitlines()[-1].split("|")
    assert row[1].strip() == "lean_wall_stands" and int(row[2]) > 0, row
    assert row[5].strip() == "yes" and int(row[6]) > 0, row  # both ways agree; the margin asked directions
    assert _equilibrium.solve is before  # the recording is undone


@pytest.mark.parametrize(
    "cost, a, b",
    [
        ([1.0, 2.0], [[1.0, np.nan]], [3.0]),  # HiGHS alone calls this optimal, its value NaN
        ([1.0, np.inf], [[1.0, 1.0]], [3.0]),
        ([1.0, 1.0], [[1.0, 1.0]], [np.inf]),
    ],
)
def test_a_number_that_is_not_finite_is_refused_as_scipy_refuses_it(cost, a, b):
    with pytest.raises(ValueError, match="must be finite"):
        solve(np.array(cost), np.array(a), np.array(b))
    with pytest.raises(ValueError):
        linprog(cost, A_eq=a, b_eq=b, bounds=(0, None), method="highs")


def test_an_inequality_needs_its_matrix_and_its_bound_and_a_changed_column_finite_values():
    with pytest.raises(ValueError, match="both their matrix"):
        LinearProgram(np.zeros(2), np.ones((1, 2)), np.ones(1), a_ub=np.ones((1, 2)))
    program = LinearProgram(np.ones(2), np.ones((1, 2)), np.ones(1))
    with pytest.raises(ValueError, match="must be finite"):
        program.set_column(0, [0], [np.nan])


def test_a_program_the_simplex_does_not_finish_in_time_is_solved_by_the_interior_point_method(monkeypatch):
    """A program of 246 rows whose contacts lay microns apart kept HiGHS's simplex pivoting for
    minutes (a tuned MuJoCo tower's stand took 395 s to certify); past SIMPLEX_SECONDS the
    program is solved again by the interior point method, and the solver goes back to HiGHS's
    choice for the next solve. Here the simplex is given no time at all."""
    from stability import _lp

    cost, a, b = _random_program(3, rows=60, columns=200)
    program = LinearProgram(cost, a, b)
    runs: list[str] = []
    solver = program._solver

    class Watched:
        def __getattr__(self, name):
            return getattr(solver, name)

        def run(self):
            runs.append(solver.getOptionValue("solver")[1])
            return solver.run()

    program._solver = Watched()
    monkeypatch.setattr(_lp, "SIMPLEX_SECONDS", 0.0)
    ours = program.solve()
    theirs = linprog(cost, A_eq=a, b_eq=b, bounds=(0, None), method="highs")
    assert runs == ["choose", "ipm"]
    assert ours.status == OPTIMAL and ours.fun == pytest.approx(theirs.fun, rel=1e-7)
    assert solver.getOptionValue("solver")[1] == "choose"


def test_a_sequence_of_programs_warm_started_finds_what_each_finds_alone_in_fewer_iterations():
    """A search asks one program after another, each a little different: started from the last
    one's basis it finds each one's optimum, and pivots less; a program of another shape starts
    from scratch."""
    cost, a, _ = _random_program(11, rows=40, columns=160)
    rng = np.random.default_rng(2)
    warm, pivots = WarmStart(), {"warm": 0, "cold": 0}
    for _ in range(6):
        changed = a.copy()
        changed.data = changed.data * rng.uniform(0.97, 1.03, changed.nnz)
        rhs = changed @ rng.uniform(0.0, 1.0, a.shape[1])
        started, alone = solve(cost, changed, rhs, warm=warm), solve(cost, changed, rhs)
        assert started.status == alone.status == OPTIMAL
        assert started.fun == pytest.approx(alone.fun, rel=1e-9)
        pivots["warm"] += started.iterations
        pivots["cold"] += alone.iterations
    assert warm.shape == a.shape
    assert pivots["warm"] < 0.6 * pivots["cold"], pivots
    other = _random_program(12, rows=10, columns=30)
    assert solve(*other, warm=warm).fun == pytest.approx(solve(*other).fun, rel=1e-9)
    assert warm.shape == (10, 30)


@pytest.mark.parametrize("seed", range(6))
def test_a_program_solved_by_columns_has_the_whole_programs_optimum(seed):
    """From a part of the unknowns that holds a solution, the unknowns whose reduced costs are
    negative are added until none is: the whole program's optimum, and a solution of it."""
    rng = np.random.default_rng(seed)
    cost, a, _ = _random_program(seed, rows=20, columns=200)
    first = rng.choice(200, 60, replace=False)
    x = np.zeros(200)
    x[first] = rng.uniform(0.0, 1.0, 60)
    b = a @ x
    ours, whole, part = solve_by_columns(cost, a, b, first), solve(cost, a, b), solve(cost[first], a[:, first], b)
    assert ours.status == whole.status == part.status == OPTIMAL
    assert part.fun > whole.fun * (1 + 1e-6)  # the part alone is worse: columns had to be added
    assert ours.fun == pytest.approx(whole.fun, rel=1e-9)
    assert np.allclose(a @ ours.x, b, atol=1e-9) and ours.x.min() >= -1e-12
    assert ours.fun == pytest.approx(cost @ ours.x, rel=1e-9)


def test_a_program_whose_first_unknowns_hold_no_solution_is_solved_whole():
    # x0 alone cannot meet the second row: the whole program is solved from scratch
    a = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0]])
    ours = solve_by_columns(np.array([1.0, 1.0, 1.5]), a, np.array([1.0, 1.0]), np.array([0]))
    assert ours.status == OPTIMAL and ours.x.tolist() == [0.0, 0.0, 1.0] and ours.fun == 1.5


def test_columns_added_to_a_program_are_checked():
    program = LinearProgram(np.array([1.0]), np.array([[1.0]]), np.array([1.0]))
    with pytest.raises(ValueError, match="shape"):
        program.add_columns(np.array([1.0]), sparse.csc_matrix(np.ones((2, 1))))
    with pytest.raises(ValueError, match="finite"):
        program.add_columns(np.array([np.nan]), sparse.csc_matrix(np.ones((1, 1))))
    program.add_columns(np.array([0.5]), sparse.csc_matrix(np.ones((1, 1))))
    assert program.solve().x.tolist() == [0.0, 1.0]

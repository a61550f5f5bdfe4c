"""Linear programs solved by HiGHS through highspy, its own Python interface, kept between solves.

The stability model's programs are small (tens to a few thousand unknowns) and many: a Jenga
pull's proof asks one each time a quarter of a contact area has gone, a standing structure's
margin one per direction searched, a fallen pile's admission one per try. For such programs
scipy's ``linprog`` costs more around HiGHS than HiGHS itself: on the 2-level cabin that falls
(two programs of 6 and 18 rows), 3.2 ms a call of which 0.6 ms in HiGHS. :class:`LinearProgram`
hands the matrix to HiGHS as it is (compressed columns), and keeps the solver: a program solved
again with one column changed (:meth:`LinearProgram.set_column`) starts from the last basis, a
few pivots instead of a solve from scratch, as the margin's search along one direction after
another does (:mod:`stability._margin`).

The answers are HiGHS's, as through scipy: the status, the optimal value and the duals of the
equality rows in scipy's sign (the change of the optimal value per unit of the row's right-hand
side). Where a program has more than one optimal point, the point may differ between HiGHS
versions, as it may through scipy.

Source: stackdsl's own, on HiGHS (Huangfu and Hall, "Parallelizing the dual revised simplex
method", Mathematical Programming Computation 10, 2018).
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass

import numpy as np
from highspy._core import HighsBasis, HighsLp, HighsModelStatus, MatrixFormat, kHighsInf
from highspy._core import _Highs as _Solver  # the solver itself: ``highspy.Highs`` adds callbacks and logs a banner
from scipy import sparse

OPTIMAL, ITERATION_LIMIT, INFEASIBLE, UNBOUNDED, OTHER = 0, 1, 2, 3, 4
"""A solution's status, numbered as scipy's ``linprog`` numbers them."""

_STATUS = {
    HighsModelStatus.kOptimal: OPTIMAL,
    HighsModelStatus.kIterationLimit: ITERATION_LIMIT,
    HighsModelStatus.kInfeasible: INFEASIBLE,
    HighsModelStatus.kUnbounded: UNBOUNDED,
    HighsModelStatus.kUnboundedOrInfeasible: INFEASIBLE,
}


_PRIMAL = 4
"""HiGHS's ``simplex_strategy`` of the primal simplex."""

PRICE = 1e-9
"""Reduced cost below which :func:`solve_by_columns` adds an unknown left out (HiGHS's own
tolerance for an optimal basis is 1e-7: a column it would not enter is not added again)."""

_DEADLINE: ContextVar[float | None] = ContextVar("stability_lp_deadline", default=None)

SIMPLEX_SECONDS = 2.0
"""Seconds HiGHS's simplex may take on one program before it is solved again by the interior
point method (the stability model's programs take milliseconds)."""


class OutOfTime(Exception):
    """A program of a :func:`within` scope was asked, or still being solved, past its deadline:
    nothing the scope was finding is an answer. Source: stackdsl's own."""


@contextmanager
def within(deadline: float | None) -> Iterator[None]:
    """Solve every program asked in this scope by ``deadline`` (seconds of ``time.perf_counter``;
    None: no limit), or raise :class:`OutOfTime`: HiGHS is given the time left as its time limit,
    and a program asked once it has passed is not solved. A run's wall-time budget then holds
    for statics too: a 3-level tower struck by 100 bricks, which lay about it, was certified in
    387 programs over 106 blocks and 1273 contacts, 87 s of a 100 s budget, one program 15 s.

    >>> with within(time.perf_counter() - 1.0):
    ...     solve(np.array([1.0]), np.zeros((0, 1)), np.zeros(0))
    Traceback (most recent call last):
    ...
    stability._lp.OutOfTime: a linear program asked 1.0 s past its deadline
    """
    token = _DEADLINE.set(deadline)
    try:
        yield
    finally:
        _DEADLINE.reset(token)


@dataclass(frozen=True)
class Solution:
    """What HiGHS found.

    Attributes:
        status: :data:`OPTIMAL` (0), :data:`ITERATION_LIMIT`, :data:`INFEASIBLE`,
            :data:`UNBOUNDED` or :data:`OTHER`; ``x``, ``fun`` and ``eq_duals`` are HiGHS's
            last iterate unless it is :data:`OPTIMAL`.
        x: shape (n,), the unknowns.
        fun: the objective's value at ``x``.
        eq_duals: shape (equality rows,), each row's dual: how much the optimal value changes
            per unit of its right-hand side (scipy's ``eqlin.marginals``).
        iterations: the simplex iterations HiGHS took.
    """

    status: int
    x: np.ndarray
    fun: float
    eq_duals: np.ndarray
    iterations: int = 0


class WarmStart:
    """The basis the last of a sequence of programs ended on, for the next one of the same shape
    (rows and unknowns) to start from: a search that asks one program after another, each a
    little different, pivots on from where the last stopped instead of from scratch. The
    answers are the same (whether a program has a solution, and its optimal value, do not
    depend on where the simplex starts; where it has many, the one found may differ); a program
    an iteration limit stops may get further. Measured on a tied ride's programs (the 72 riders
    of a 30-level Jenga tower's top, 216 rows and 864 unknowns, towards six directions, then at
    smaller tilts): 65 to 177 simplex iterations a program against 331 to 468 from scratch, 6 to
    11 ms against 16 to 22. Source: stackdsl's own, on HiGHS's ``setBasis``.

    >>> warm = WarmStart()
    >>> solve(np.array([1.0, 2.0]), np.array([[1.0, 1.0]]), np.array([3.0]), warm=warm).x.tolist()
    [3.0, 0.0]
    >>> solve(np.array([1.0, 2.0]), np.array([[1.0, 1.0]]), np.array([4.0]), warm=warm).x.tolist()
    [4.0, 0.0]
    """

    def __init__(self) -> None:
        self.shape: tuple[int, int] | None = None
        self.basis: HighsBasis | None = None

    def copy(self) -> WarmStart:
        """Another start from the same basis (a program solved from the copy leaves this one's
        basis as it was)."""
        other = WarmStart()
        other.shape, other.basis = self.shape, self.basis
        return other


class LinearProgram:
    """``min cost x`` subject to ``a_eq x = b_eq``, ``a_ub x <= b_ub`` and ``0 <= x <= upper``,
    held by one HiGHS solver to be solved, changed and solved again.

    Args:
        cost: shape (n,).
        a_eq: shape (m, n), any scipy sparse matrix or array; ``b_eq`` shape (m,).
        a_ub, b_ub: shape (k, n) and (k,), or None.
        upper: shape (n,), each unknown's upper bound (inf: none); None, none at all.
        iteration_limit: simplex iterations before HiGHS stops (:data:`ITERATION_LIMIT`).
        presolve: let HiGHS simplify the program first (its default).
        primal: solve by the primal simplex, not HiGHS's choice (the dual): the method for a
            program started from a basis that is feasible for it, or nearly, but not optimal
            (a program with more unknowns than the one the basis is of, or the same program
            with its friction widened: 77 iterations against 1369 by the dual simplex from the
            same basis).

    Raises:
        ValueError: the shapes do not agree, ``a_ub`` comes without ``b_ub`` or the other way
            round, or a cost, coefficient or right-hand side is not
            finite (NaN or infinite), as scipy's ``linprog`` refuses them: HiGHS would answer
            "optimal" with a NaN objective.

    Source: stackdsl's own (module docstring).

    >>> program = LinearProgram(np.array([1.0, 2.0]), np.array([[1.0, 1.0]]), np.array([3.0]))
    >>> solution = program.solve()
    >>> solution.status, solution.x.tolist(), solution.fun, solution.eq_duals.tolist()
    (0, [3.0, 0.0], 3.0, [1.0])
    >>> program.set_column(0, [0], [0.5])  # x0 counts half in the row now
    >>> program.solve().x.tolist()
    [6.0, 0.0]
    """

    def __init__(
        self,
        cost: np.ndarray,
        a_eq: sparse.spmatrix | np.ndarray,
        b_eq: np.ndarray,
        *,
        a_ub: sparse.spmatrix | np.ndarray | None = None,
        b_ub: np.ndarray | None = None,
        upper: np.ndarray | None = None,
        iteration_limit: int | None = None,
        presolve: bool = True,
        primal: bool = False,
    ) -> None:
        cost = np.asarray(cost, dtype=float)
        b_eq = np.asarray(b_eq, dtype=float)
        n, equalities = len(cost), len(b_eq)
        blocks = [sparse.csc_matrix(a_eq)]
        lower_rows, upper_rows = [b_eq], [b_eq]
        if (a_ub is None) != (b_ub is None):
            raise ValueError("a program's inequalities need both their matrix a_ub and their right-hand side b_ub")
        if a_ub is not None and b_ub is not None:
            blocks.append(sparse.csc_matrix(a_ub))
            b_ub = np.asarray(b_ub, dtype=float)
            lower_rows.append(np.full(len(b_ub), -kHighsInf))
            upper_rows.append(b_ub)
        matrix = sparse.vstack(blocks, format="csc") if len(blocks) > 1 else blocks[0]
        if matrix.shape != (sum(len(r) for r in lower_rows), n):
            raise ValueError(
                f"a program of {n} unknowns and {equalities} equalities cannot have a matrix of shape {matrix.shape}"
            )
        matrix.sort_indices()
        if not all(np.isfinite(v).all() for v in (cost, matrix.data, *upper_rows)):
            raise ValueError("a linear program's costs, coefficients and right-hand sides must be finite, not NaN or infinite")
        lp = HighsLp()
        lp.num_col_, lp.num_row_ = n, matrix.shape[0]
        lp.col_cost_ = cost
        lp.col_lower_ = np.zeros(n)
        bound = np.full(n, kHighsInf) if upper is None else np.asarray(upper, dtype=float)
        lp.col_upper_ = np.where(np.isinf(bound), kHighsInf, bound)
        lp.row_lower_ = np.concatenate(lower_rows)
        lp.row_upper_ = np.concatenate(upper_rows)
        lp.a_matrix_.format_ = MatrixFormat.kColwise
        lp.a_matrix_.start_ = matrix.indptr
        lp.a_matrix_.index_ = matrix.indices
        lp.a_matrix_.value_ = matrix.data
        self._solver = _Solver()
        self._solver.setOptionValue("output_flag", False)
        if iteration_limit is not None:
            self._solver.setOptionValue("simplex_iteration_limit", int(iteration_limit))
        if not presolve:
            self._solver.setOptionValue("presolve", "off")
        if primal:
            self._solver.setOptionValue("simplex_strategy", _PRIMAL)
        self._solver.passModel(lp)
        self._equalities = equalities
        self._limit = float(kHighsInf)  # HiGHS's time limit as last set

    def add_columns(self, cost: np.ndarray, matrix: sparse.spmatrix) -> None:
        """Add unknowns (>= 0, no upper bound) of costs ``cost`` (shape (k,)) and equality rows'
        coefficients ``matrix`` (shape (equalities, k)) after the others; the next :meth:`solve`
        starts from the last basis, the new unknowns at 0. Raises ValueError for a cost or
        coefficient that is not finite, or a matrix of another shape."""
        cost = np.asarray(cost, dtype=float)
        columns = sparse.csc_matrix(matrix)
        if columns.shape != (self._solver.getNumRow(), len(cost)) or self._equalities != self._solver.getNumRow():
            raise ValueError(
                f"{len(cost)} new unknowns of a program of {self._equalities} equalities cannot have a matrix of shape {columns.shape}"
            )
        if not (np.isfinite(cost).all() and np.isfinite(columns.data).all()):
            raise ValueError("a linear program's costs and coefficients must be finite, not NaN or infinite")
        columns.sort_indices()
        k = len(cost)
        self._solver.addCols(
            k, cost, np.zeros(k), np.full(k, kHighsInf), columns.nnz, columns.indptr[:-1], columns.indices, columns.data
        )

    def set_column(self, column: int, rows: list[int] | np.ndarray, values: list[float] | np.ndarray) -> None:
        """Set the coefficients of ``column`` in ``rows`` to ``values`` (the next :meth:`solve`
        starts from the last basis). Raises ValueError for a value that is not finite."""
        if not np.isfinite(np.asarray(values, dtype=float)).all():
            raise ValueError("a linear program's coefficients must be finite, not NaN or infinite")
        for row, value in zip(rows, values, strict=True):
            self._solver.changeCoeff(int(row), int(column), float(value))

    def solve(self, warm: WarmStart | None = None) -> Solution:
        """Solve the program as it is now: by HiGHS's choice of method (the dual simplex), and
        when that has not finished in :data:`SIMPLEX_SECONDS`, again by its interior point
        method; from ``warm``'s basis when it is of a program of this shape, which then keeps
        the basis this one ends on. Raises :class:`OutOfTime` in a :func:`within` scope whose
        deadline has passed, or passes while HiGHS solves it."""
        solver = self._solver
        shape = (solver.getNumRow(), solver.getNumCol())
        if warm is not None and warm.basis is not None and warm.shape == shape:
            solver.setBasis(warm.basis)
        deadline = _DEADLINE.get()
        self._time_limit(min(self._left(deadline), SIMPLEX_SECONDS))
        solver.run()
        if solver.getModelStatus() == HighsModelStatus.kTimeLimit:
            # a program of 246 rows, badly scaled by contacts microns apart, kept the simplex
            # pivoting for minutes; the interior point method said it infeasible in 0.02 s
            solver.setOptionValue("solver", "ipm")
            self._time_limit(self._left(deadline))
            solver.run()
            solver.setOptionValue("solver", "choose")
            if solver.getModelStatus() == HighsModelStatus.kTimeLimit:
                raise OutOfTime("a linear program ran past its deadline")
        status = _STATUS.get(solver.getModelStatus(), OTHER)
        if warm is not None and (basis := solver.getBasis()).valid:
            warm.shape, warm.basis = shape, basis
        solution = solver.getSolution()
        x = np.asarray(solution.col_value, dtype=float)
        duals = np.asarray(solution.row_dual, dtype=float)[: self._equalities]
        info = solver.getInfo()
        return Solution(status, x, float(info.objective_function_value), duals, int(info.simplex_iteration_count))

    def _time_limit(self, seconds: float) -> None:
        """HiGHS's time limit for the next run, set only when it changes (a program is solved
        thousands of times in a run, mostly with no deadline)."""
        if seconds != self._limit:
            self._solver.setOptionValue("time_limit", seconds)
            self._limit = seconds

    @staticmethod
    def _left(deadline: float | None) -> float:
        """Seconds left until ``deadline`` (HiGHS's infinity for none). Raises :class:`OutOfTime`
        once it has passed."""
        if deadline is None:
            return float(kHighsInf)
        left = deadline - time.perf_counter()
        if left <= 0.0:
            raise OutOfTime(f"a linear program asked {-left:.1f} s past its deadline")
        return left


def solve(
    cost: np.ndarray,
    a_eq: sparse.spmatrix | np.ndarray,
    b_eq: np.ndarray,
    *,
    a_ub: sparse.spmatrix | np.ndarray | None = None,
    b_ub: np.ndarray | None = None,
    upper: np.ndarray | None = None,
    iteration_limit: int | None = None,
    presolve: bool = True,
    warm: WarmStart | None = None,
    primal: bool = False,
) -> Solution:
    """Solve a program once (:class:`LinearProgram`'s arguments and errors), from ``warm``'s
    basis (:meth:`LinearProgram.solve`).

    >>> solve(np.array([-1.0]), np.zeros((0, 1)), np.zeros(0), upper=np.array([2.0])).x.tolist()
    [2.0]
    """
    return LinearProgram(
        cost, a_eq, b_eq, a_ub=a_ub, b_ub=b_ub, upper=upper, iteration_limit=iteration_limit, presolve=presolve, primal=primal
    ).solve(warm)


def solve_by_columns(
    cost: np.ndarray, a_eq: sparse.spmatrix | np.ndarray, b_eq: np.ndarray, first: np.ndarray, warm: WarmStart | None = None
) -> Solution:
    """Solve ``min cost x`` subject to ``a_eq x = b_eq`` and ``x >= 0`` by column generation:
    on the unknowns ``first`` alone (indices, shape (k,)) from ``warm``'s basis, a basis of
    that smaller program; then, while an unknown left out has a negative reduced cost under
    the equalities' duals (``cost - a_eq.T @ duals`` below :data:`PRICE`), with every such
    unknown added, by the primal simplex from the basis the last solve ended on. An unknown
    left out whose reduced cost is not negative cannot lower the optimum, so it is the whole
    program's, and every unknown not added is 0 in the answer (Dantzig and Wolfe's pricing).
    When the smaller program has no optimum the whole one is solved from scratch.

    Each pivot then prices the unknowns taken in, not all of them. Measured on the 32-sided
    friction pyramids of a fallen 40-brick log cabin (276 rows, 16,368 unknowns), started from
    the optimum of the eight-sided one: 80 ms and 964 pivots over 3 rounds, against 613 ms and
    2,729 pivots for the whole program from scratch, to the same optimum.

    Raises:
        ValueError: as :class:`LinearProgram`.
        OutOfTime: as :meth:`LinearProgram.solve`.

    Source: Dantzig and Wolfe, "Decomposition principle for linear programs" (Operations
    Research 8, 1960), on HiGHS; stackdsl's own.

    >>> a = np.array([[1.0, 1.0, 1.0]])
    >>> solution = solve_by_columns(np.array([3.0, 2.0, 1.0]), a, np.array([2.0]), np.array([0]))
    >>> solution.x.tolist(), solution.fun
    ([0.0, 0.0, 2.0], 2.0)
    """
    cost = np.asarray(cost, dtype=float)
    matrix = sparse.csc_matrix(a_eq)
    inside = np.zeros(len(cost), dtype=bool)
    taken = [np.asarray(first, dtype=int)]
    inside[taken[0]] = True
    program = LinearProgram(cost[taken[0]], matrix[:, taken[0]], b_eq, primal=True)
    solution = program.solve(warm)
    pivots = solution.iterations
    while solution.status == OPTIMAL:
        reduced = cost - matrix.T @ solution.eq_duals
        new = np.flatnonzero((reduced < -PRICE) & ~inside)
        if not len(new):
            x = np.zeros(len(cost))
            x[np.concatenate(taken)] = solution.x
            return Solution(OPTIMAL, x, solution.fun, solution.eq_duals, pivots)
        program.add_columns(cost[new], matrix[:, new])
        inside[new] = True
        taken.append(new)
        solution = program.solve()
        pivots += solution.iterations
    return solve(cost, matrix, b_eq)

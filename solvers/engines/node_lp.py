r"""The node LPs of ``milp``'s branch and bound: the lifted LP of :mod:`~blockmpec.solvers.engines.lifted_lp` as
HiGHS holds it, re-solved as the search changes its bounds.

The search changes only the bounds of pair rows (static and copy), the bounds and ``z`` coefficients of the ``zeta``
rows, and the bounds of ``lam`` and ``z``, always in the lifted LP's row and column numbers.  Two holders take those
changes, with one interface:

* :class:`LiftedNodes`: the lifted LP itself, solved by the dual simplex from the last basis;
* :class:`NullSpaceNodes`: the same LP in the null-space coordinates of :mod:`~blockmpec.solvers.linalg.null_space`
  (``w = offset + T xi``): a lifted row ``r`` kept there is ``A_r T xi`` with its bounds shifted by
  ``A_r offset``, and ``lam``, ``z_i``, ``zeta_i`` are columns of both (``T`` is the identity there).  The two LPs
  have the same points and the same minimum at every node.  Two HiGHS models take every change: ``full``, the
  whole LP, for the interior point, and ``sparse``, the LP without the rows that are free or *sleeping* (the
  root's dormant rows; a sleeping row is appended once it is set to an equality, an active pair's row): a
  relaxation, for the dual simplex, whose Farkas proofs of infeasibility hold for the whole LP.

Every LP runs through :class:`~blockmpec.solvers.engines.highs.HighsLP`; the holders keep the current arrays, which
the interior point and the Farkas check read.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from blockmpec.deadline import NEVER, Deadline
from blockmpec.result import Status

#: feasibility tolerances of the node LPs: a first solve at the loose one, the answer at the tight one (the lifted
#: LPs are degenerate: the dual simplex at the tight one from scratch was much slower or stalled)
LOOSE_LP_TOL = 1e-7
LP_TOL = 1e-9
#: HiGHS's interior point: IPX (HiGHS's "ipm" name may run its newer HiPO first)
INTERIOR_SOLVER = "ipx"


def linear_program(A, c, row_lower, row_upper, col_lower, col_upper):
    """The arrays as a :class:`~blockmpec.formulations.pyomo_compile.LinearProgram` (no named groups)."""
    from blockmpec.formulations.pyomo_compile import LinearProgram

    return LinearProgram(c=np.asarray(c, float), A=sp.csr_array(A), row_lower=np.array(row_lower, float),
                         row_upper=np.array(row_upper, float), col_lower=np.array(col_lower, float),
                         col_upper=np.array(col_upper, float), columns={}, rows={}, objective_sign=1.0)


@dataclass
class InteriorPoint:
    """One interior-point solve: row duals (None: HiGHS gave none), column values (None: none) and, after a
    crossover, HiGHS's basis (column and row status arrays)."""

    y: np.ndarray | None
    v: np.ndarray | None
    basis: tuple | None = None


def interior_point(A, c, row_lower, row_upper, col_lower, col_upper, deadline: Deadline, crossover: bool = False,
                   tolerance: float | None = None) -> InteriorPoint:
    """The LP ``min c^T v`` s.t. ``row_lower <= A v <= row_upper``, ``col_lower <= v <= col_upper`` by HiGHS's interior
    point IPX (with its crossover if ``crossover``), at feasibility ``tolerance`` (HiGHS's default if None).

    Its duals are taken when HiGHS ends optimal or "unknown" (IPX stopped near the optimum without meeting its
    tolerances: its duals still give a bound, :func:`~blockmpec.solvers.engines.lifted_lp.dual_bound`)."""
    from blockmpec.solvers.engines.highs import IPM_WITHOUT_CROSSOVER, HighsLP

    if deadline.expired():
        return InteriorPoint(None, None)
    hl = HighsLP(linear_program(A, c, row_lower, row_upper, col_lower, col_upper),
                 "ipm" if crossover else IPM_WITHOUT_CROSSOVER)
    if tolerance is not None:
        hl.set_feasibility_tolerances(tolerance)
    out = hl.solve(deadline=deadline)
    y = np.asarray(out.row_dual, float)
    if out.raw_status not in ("kOptimal", "kUnknown") or y.size != A.shape[0] or not np.all(np.isfinite(y)):
        return InteriorPoint(None, None)
    v = np.asarray(out.v, float)
    return InteriorPoint(y, v if np.all(np.isfinite(v)) else None, hl.basis_status() if crossover else None)


class TrackedLP:
    """A :class:`~blockmpec.solvers.engines.highs.HighsLP` of ``min c^T v`` s.t. ``rl <= A v <= ru``,
    ``cl <= v <= cu`` whose current arrays are kept here through every change."""

    def __init__(self, A, c, rl, ru, cl, cu) -> None:
        from blockmpec.solvers.engines.highs import HighsLP

        self.A = sp.csr_array(A, copy=True)
        self.c, self.rl, self.ru = np.array(c, float), np.array(rl, float), np.array(ru, float)
        self.cl, self.cu = np.array(cl, float), np.array(cu, float)
        self.hl = HighsLP(linear_program(self.A, self.c, self.rl, self.ru, self.cl, self.cu), "dual-simplex")

    def set_row_bounds(self, rows, lower, upper) -> None:
        rows = np.asarray(rows, dtype=np.int64)
        self.rl[rows], self.ru[rows] = lower, upper
        self.hl.set_row_bounds(rows, self.rl[rows], self.ru[rows])

    def set_column_bounds(self, cols, lower, upper) -> None:
        cols = np.asarray(cols, dtype=np.int64)
        self.cl[cols], self.cu[cols] = lower, upper
        self.hl.set_column_bounds(cols, self.cl[cols], self.cu[cols])

    def set_coefficients(self, rows, cols, values) -> None:
        rows, cols, values = np.atleast_1d(rows), np.atleast_1d(cols), np.atleast_1d(np.asarray(values, float))
        for r, c, v in zip(rows, cols, values):
            self.A[int(r), int(c)] = v  # an entry of the matrix's structure (the z coefficient of a zeta row)
        self.hl.set_coefficients(rows, cols, values)

    def add_rows(self, M, lower, upper) -> None:
        M = sp.csr_array(M)
        self.A = sp.csr_array(sp.vstack([self.A, M], format="csr"))
        self.rl, self.ru = np.r_[self.rl, lower], np.r_[self.ru, upper]
        self.hl.add_rows(M, lower, upper)

    @property
    def n_rows(self) -> int:
        return self.A.shape[0]

    def arrays(self) -> tuple:
        """``(A (CSC), c, row_lower, row_upper, col_lower, col_upper)`` as HiGHS holds them now."""
        return sp.csc_array(self.A), self.c, self.rl, self.ru, self.cl, self.cu


class LiftedNodes:
    """The node LPs on the lifted LP itself (module docstring); ``lift`` is the identity."""

    def __init__(self, A, c, rl, ru, cl, cu) -> None:
        self.model = TrackedLP(A, c, rl, ru, cl, cu)
        self.iteration_limit = max(5_000, sum(A.shape))

    def set_row_bounds(self, rows, lower, upper) -> None:
        self.model.set_row_bounds(rows, lower, upper)

    def set_column_bounds(self, cols, lower, upper) -> None:
        self.model.set_column_bounds(cols, lower, upper)

    def set_coefficients(self, rows, cols, values) -> None:
        self.model.set_coefficients(rows, cols, values)

    def lift(self, xi: np.ndarray) -> np.ndarray:
        return np.asarray(xi, float)

    def active(self) -> TrackedLP:
        """The model that runs and answers now."""
        return self.model

    def use(self, which: str) -> None:
        """One model only: ``"full"`` and ``"sparse"`` are the same."""


class NullSpaceNodes:
    """The node LPs in null-space coordinates (module docstring).

    Parameters
    ----------
    reduced : NullSpaceLP
        The root LP in null-space coordinates (:func:`~blockmpec.solvers.linalg.null_space.null_space_lp`).
    A_lifted : sparse matrix
        The lifted LP's matrix.
    layout : Layout
        The lifted LP's layout.
    row_lower, row_upper : ndarray
        The lifted LP's current row bounds.
    sleeping : ndarray of int, optional
        Lifted rows left out of the sparse model until they become equalities.
    """

    def __init__(self, reduced, A_lifted, layout, row_lower, row_upper, sleeping=None) -> None:
        n_pairs = layout.z.stop - layout.z.start
        self.T, self.offset = sp.csr_array(reduced.T), np.asarray(reduced.offset, float)
        mapped = np.flatnonzero(reduced.lifted_row >= 0)
        self.row = np.full(A_lifted.shape[0], -1, dtype=np.int64)  # lifted row -> row of the null-space LP
        self.row[reduced.lifted_row[mapped]] = mapped
        self.shift = np.asarray(A_lifted @ self.offset, float)
        M = sp.csr_array(reduced.A)
        q = (M.shape[1] - 1 - 2 * n_pairs) // (n_pairs + 1)
        self.col = np.full(A_lifted.shape[1], -1, dtype=np.int64)  # lifted column -> column (lam, z, zeta)
        self.col[layout.lam] = 0
        self.col[layout.z.start:layout.z.stop] = 1 + q + np.arange(n_pairs)
        for i, _, zeta in layout.copies:
            self.col[zeta] = 1 + q + n_pairs + i
        lower, upper = np.array(reduced.row_lower, float), np.array(reduced.row_upper, float)
        lifted = reduced.lifted_row[mapped]
        lower[mapped] = np.asarray(row_lower, float)[lifted] - self.shift[lifted]
        upper[mapped] = np.asarray(row_upper, float)[lifted] - self.shift[lifted]
        self.sleeping = np.zeros(M.shape[0], dtype=bool)
        if sleeping is not None:
            self.sleeping[self.row[np.asarray(sleeping, dtype=np.int64)]] = True
        held = (np.isfinite(lower) | np.isfinite(upper)) & ~self.sleeping
        self.position = np.full(M.shape[0], -1, dtype=np.int64)  # null-space row -> sparse model row (-1: out)
        self.position[held] = np.arange(int(held.sum()))
        self.M = M
        self.full = TrackedLP(M, reduced.c, lower, upper, reduced.col_lower, reduced.col_upper)
        self.sparse = TrackedLP(M[np.flatnonzero(held)], reduced.c, lower[held], upper[held], reduced.col_lower,
                                reduced.col_upper)
        self.iteration_limit = max(5_000, sum(M.shape))
        self._using = self.full

    @classmethod
    def of(cls, reduced, A_lifted, layout, rows_used: np.ndarray, row_lower, row_upper, sleeping=None):
        """The node LPs, or None when a row the search changes (``rows_used``) is not a row of the null-space LP
        (it vanished: its value is a constant there)."""
        row = np.full(A_lifted.shape[0], -1, dtype=np.int64)
        row[reduced.lifted_row[reduced.lifted_row >= 0]] = 1
        if np.any(row[rows_used] < 0):
            return None
        return cls(reduced, A_lifted, layout, row_lower, row_upper, sleeping)

    def use(self, which: str) -> None:
        """Run, answer and give points from the ``"full"`` or the ``"sparse"`` model."""
        self._using = self.full if which == "full" else self.sparse

    def active(self) -> TrackedLP:
        return self._using

    def _null_rows(self, rows) -> np.ndarray:
        r = self.row[np.asarray(rows, dtype=np.int64)]
        if np.any(r < 0):
            raise RuntimeError("null-space node LP: a changed row is not in the LP")
        return r

    def _cols(self, cols) -> np.ndarray:
        c = self.col[np.asarray(cols, dtype=np.int64)]
        if np.any(c < 0):
            raise RuntimeError("null-space node LP: a changed column is not in the LP")
        return c

    def set_row_bounds(self, rows, lower, upper) -> None:
        rows = np.asarray(rows, dtype=np.int64)
        nr = self._null_rows(rows)
        lower = np.broadcast_to(np.asarray(lower, float), rows.shape) - self.shift[rows]
        upper = np.broadcast_to(np.asarray(upper, float), rows.shape) - self.shift[rows]
        self.full.set_row_bounds(nr, lower, upper)
        at = self.position[nr]
        held = at >= 0
        self.sparse.set_row_bounds(at[held], lower[held], upper[held])
        # a row outside the sparse model is appended once its bounds are set (a sleeping one: to an equality)
        add = ~held & (np.isfinite(lower) | np.isfinite(upper)) & (~self.sleeping[nr] | (lower == upper))
        if add.any():
            new, first = nr[add], self.sparse.n_rows
            self.sparse.add_rows(self.M[new], lower[add], upper[add])
            self.position[new] = first + np.arange(new.size)

    def set_column_bounds(self, cols, lower, upper) -> None:
        c = self._cols(cols)
        self.full.set_column_bounds(c, lower, upper)
        self.sparse.set_column_bounds(c, lower, upper)

    def set_coefficients(self, rows, cols, values) -> None:
        nr, c = self._null_rows(rows), self._cols(cols)
        values = np.atleast_1d(np.asarray(values, float))
        for r, col, v in zip(nr, c, values):
            self.M[int(r), int(col)] = float(v)  # for when the row is appended to the sparse model
        self.full.set_coefficients(nr, c, values)
        at = self.position[nr]
        if np.any(at >= 0):
            self.sparse.set_coefficients(at[at >= 0], c[at >= 0], values[at >= 0])

    def lift(self, xi: np.ndarray) -> np.ndarray:
        """The lifted point ``offset + T xi`` of a point ``xi`` of the null-space LP."""
        return self.offset + self.T @ np.asarray(xi, float)


def simplex(model: TrackedLP, iteration_limit: int, deadline: Deadline = NEVER):
    """One node LP by the dual simplex from the model's last basis: at ``LOOSE_LP_TOL`` first, then from that basis
    at ``LP_TOL`` (a few iterations), whose answer alone is used; each within ``iteration_limit`` simplex iterations.
    An LP infeasible at the loose tolerance is infeasible at the tight one (a smaller set): no second solve.
    Returns ``(LPOutcome, solves)``."""
    hl = model.hl
    hl.set_iteration_limit(iteration_limit)
    out, solves = None, 0
    for tol in (LOOSE_LP_TOL, LP_TOL):
        hl.set_feasibility_tolerances(tol)
        out = hl.solve(deadline=deadline)
        solves += 1
        if out.status in (Status.TIME_LIMIT, Status.INFEASIBLE, Status.ITERATION_LIMIT):
            break
    return out, solves

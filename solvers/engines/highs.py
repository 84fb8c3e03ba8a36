"""The one HiGHS wrapper: every highspy object lives in this module, and HiGHS's statuses are mapped here once.

* :class:`HighsLP`: one LP held by HiGHS, re-solved warm after changes.  It is built from a compiled
  :class:`~blockmpec.formulations.LinearProgram` and, optionally, the
  :class:`~blockmpec.solvers.engines.scaling.Scaling` that puts it in load units; every setter (costs, row and
  column bounds, coefficients, rows added, tolerances, basis, presolve, iteration limit) takes values in the
  problem's units and every answer (:class:`LPOutcome`, :meth:`HighsLP.dual_ray`) comes back in them, through the
  scaling.  The deadline is an argument of :meth:`HighsLP.solve`.
* :func:`highs_mip`: HiGHS's branch and cut on a MILP, with its :class:`MipInfo`.
* :func:`solve_lp`, :func:`small_lp`: one-off LPs; :func:`static_lp_solution`: ``(lam, x, u, z)`` from the duals.

HiGHS's model status becomes a :class:`~blockmpec.result.Status` by :data:`HIGHS_STATUS` only; ``raw_status``
keeps HiGHS's name for messages.  Modules outside this one import only the names in ``__all__``, never highspy
(``tests/test_layering.py``); the functions below that take a ``highspy.Highs`` are this module's own (and the
tests').  highspy is imported when a model is loaded, never at module import.

Dual signs: HiGHS reports row duals ``y`` with ``c - A^T y = reduced costs`` for the minimisation it solves; for
a ``<=`` row active in a minimisation ``y <= 0``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from blockmpec.deadline import NEVER, Deadline
from blockmpec.formulations import LinearProgram
from blockmpec.result import Solution, Status
from blockmpec.solvers.engines.scaling import Scaling
from blockmpec.solvers.plan import BASIS_ALGORITHMS, lp_algorithm

__all__ = ["AT_LOWER", "AT_UPPER", "BASIC", "FEASIBILITY_TOL", "HIGHS_DEFAULT_FEASIBILITY_TOL", "HIGHS_STATUS",
           "IPM_WITHOUT_CROSSOVER", "LPOutcome", "HighsLP", "MECHANISM_FEASIBILITY_TOL", "MipInfo", "highs_mip",
           "small_lp", "solve_lp", "static_lp_solution"]


@dataclass
class LPOutcome:
    """One HiGHS solve: status, primal column values, row duals and bookkeeping."""

    status: Status
    raw_status: str
    objective: float
    v: np.ndarray
    row_dual: np.ndarray
    iterations: int
    message: str = ""
    #: the solve holds a feasible primal point (whatever the status: a time limit with an incumbent)
    has_feasible_point: bool = False


#: HiGHS model status -> :class:`Status`, for LPs and MILPs alike; any other status is ``ERROR``.
#: ``kSolutionLimit`` is HiGHS's stop on a MIP work limit other than time (nodes, leaves,
#: improving solutions), hence ``ITERATION_LIMIT``; ``kInterrupt`` (a callback or signal stopped the
#: run), ``kObjectiveBound``/``kObjectiveTarget`` (limits blockmpec never sets), ``kMemoryLimit`` and
#: the load/presolve/solve/postsolve errors are ``ERROR``.
HIGHS_STATUS: dict[str, Status] = {
    "kOptimal": Status.OPTIMAL,
    "kInfeasible": Status.INFEASIBLE,
    "kUnbounded": Status.UNBOUNDED,
    "kUnboundedOrInfeasible": Status.INFEASIBLE_OR_UNBOUNDED,
    "kTimeLimit": Status.TIME_LIMIT,
    "kIterationLimit": Status.ITERATION_LIMIT,
    "kSolutionLimit": Status.ITERATION_LIMIT,
}


def highs_lp(A, c, row_lower, row_upper, col_lower, col_upper):
    """``min c^T x`` s.t. ``row_lower <= A x <= row_upper``, ``col_lower <= x <= col_upper`` as a
    ``highspy.HighsLp`` (column-wise matrix; infinite bounds as ``+-inf``)."""
    import highspy

    A = sp.csc_array(A)
    model = highspy.HighsLp()
    model.num_col_, model.num_row_ = A.shape[1], A.shape[0]
    model.col_cost_ = np.asarray(c, float)
    model.col_lower_, model.col_upper_ = np.asarray(col_lower, float), np.asarray(col_upper, float)
    model.row_lower_, model.row_upper_ = np.asarray(row_lower, float), np.asarray(row_upper, float)
    model.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    model.a_matrix_.start_, model.a_matrix_.index_, model.a_matrix_.value_ = A.indptr, A.indices, A.data
    return model


def highs_model(lp: LinearProgram):
    """A compiled LP as a ``highspy.HighsLp`` (:func:`highs_lp` of its arrays)."""
    return highs_lp(lp.A, lp.c, lp.row_lower, lp.row_upper, lp.col_lower, lp.col_upper)


def new_highs():
    """A ``highspy.Highs`` instance, its log on only while a run is verbose (:func:`blockmpec.progress.verbose_enabled`)."""
    import highspy

    from blockmpec.progress import verbose_enabled

    h = highspy.Highs()
    h.setOptionValue("output_flag", verbose_enabled())
    return h


def change_applied(status) -> bool:
    """Whether a model change of a ``highspy.Highs`` (its ``HighsStatus`` return value) was applied."""
    import highspy

    return status != highspy.HighsStatus.kError


def set_deadline(highs, deadline: Deadline) -> bool:
    """Give a ``highspy.Highs`` the time left before ``deadline``; False when none is left.

    HiGHS compares its ``time_limit`` with the instance's cumulative run clock, so the limit is that clock plus the
    time left (``inf`` without a deadline)."""
    if not deadline.finite:
        highs.setOptionValue("time_limit", float("inf"))
        return True
    remaining = deadline.remaining()
    if remaining <= 0:
        return False
    highs.setOptionValue("time_limit", float(highs.getRunTime() + remaining))
    return True


def use_interior_point(highs, crossover: bool, solver: str = "ipx") -> None:
    """Select HiGHS's interior point IPX (``solver="ipx"``), with or without its crossover to a basis.

    Not ``solver="ipm"``: with the optional wheel ``highspy-extras`` installed, HiGHS 1.15 runs its newer
    HiPO first under that name (it stalled on the 4x3 wall's lifted root LP of ``milp``), so the same code
    took another path on a machine with the wheel.  HiGHS without the value ``"ipx"`` takes ``"ipm"``,
    which is IPX there.  ``solver``: another of HiGHS's interior-point names, for comparisons.
    """
    import highspy

    if highs.setOptionValue("solver", solver) != highspy.HighsStatus.kOk:
        highs.setOptionValue("solver", "ipm")
    highs.setOptionValue("run_crossover", "on" if crossover else "off")


#: HiGHS's primal and dual feasibility tolerances for the limit-analysis LPs (HiGHS's default: 1e-7).  They are
#: absolute in load units, so 1e-7 shows as relative violations of 1e-7..1e-5 on light interfaces; the verifier
#: then rejects the point: the kinematic LP on a 600-block wall left ``z`` at -8e-6 of its size, and the static LP
#: of the 2,032-block wall by HiGHS's IPM with crossover had a multiplier-sign residual of 4.4e-6 (1.6e-7 with
#: 1e-9; lam 1.7e-7 and 1.1e-7 below the block IPM's, whose complementarity residual is 6.7e-10).
FEASIBILITY_TOL = 1e-9

#: Feasibility tolerance of the mechanism LPs: the kinematic LP (2) (primal and dual) and the split pieces' mechanism
#: LPs (primal; :mod:`~blockmpec.solvers.engines.piece_lp`).  At 1e-9 the kinematic LP of the 2,042-stone wall
#: stopped 3.3e-8 from the block IPM's exact static LP (largest residual of (3) 1.1e-7, 46 s); at 1e-10 4.1e-9
#: (1.3e-8, 93 s).  The static LPs keep 1e-9.
MECHANISM_FEASIBILITY_TOL = 1e-10

#: HiGHS's own primal and dual feasibility tolerance, which :meth:`HighsLP.solve` retries at after a solve error at
#: tighter ones
HIGHS_DEFAULT_FEASIBILITY_TOL = 1e-7


def set_feasibility_tolerances(highs, tol: float = FEASIBILITY_TOL) -> None:
    """Set HiGHS's primal and dual feasibility tolerances of a ``highspy.Highs`` to ``tol`` (default
    :data:`FEASIBILITY_TOL`)."""
    for name in ("primal_feasibility_tolerance", "dual_feasibility_tolerance"):
        highs.setOptionValue(name, float(tol))


def set_threads(highs, threads: int) -> None:
    """Set HiGHS's ``threads`` option so that the next ``run()`` accepts it.

    HiGHS starts a task scheduler of ``threads`` workers on the first ``run()`` and
    refuses a later run whose ``threads`` differs from that size (model status
    ``kNotset``, "scheduler has already been initialized").  highspy up to 1.15 shut
    the scheduler down after every run; 1.16 keeps it, one per calling thread.  So the
    calling thread's scheduler is shut down here (blocking, about 0.3 ms) and the next
    run starts one of the requested size; other threads' solves are not touched on
    1.16 (``resetThreadScheduler``), and on older highspy there was nothing to keep.
    """
    reset = getattr(type(highs), "resetThreadScheduler", None) or type(highs).resetGlobalScheduler
    reset(True)
    highs.setOptionValue("threads", int(threads))


def highs_status(highs, interior_without_crossover: bool = False) -> tuple[Status, str]:
    """``(status, raw_name)`` of a ``highspy.Highs`` after ``run()``: the one HiGHS status map.

    ``raw_name`` is HiGHS's own name (``"kOptimal"``, ``"kUnboundedOrInfeasible"`` ...), kept for
    ``Result.raw_status`` and messages; callers branch on ``status`` only.  HiGHS's interior point without
    crossover ends ``kUnknown`` when it stops at its tolerances without a basis: with
    ``interior_without_crossover`` that run is ``OPTIMAL`` when HiGHS calls both its primal and dual points
    feasible.  Whether a run holds a feasible point at all (a time-limited MIP with an incumbent) is the other
    axis: :func:`has_feasible_point`.
    """
    raw = highs.getModelStatus().name
    if interior_without_crossover and raw == "kUnknown" and has_feasible_point(highs, dual=True):
        return Status.OPTIMAL, raw
    return HIGHS_STATUS.get(raw, Status.ERROR), raw


def _option_value(highs, name: str):
    """A HiGHS option's value (highspy up to 1.15 returns ``(status, value)``, later ones the value)."""
    value = highs.getOptionValue(name)
    return value[1] if isinstance(value, tuple) else value


def has_feasible_point(highs, dual: bool = False) -> bool:
    """Whether a ``highspy.Highs`` holds a feasible primal point after ``run()`` (and, with ``dual``, a feasible
    dual point too), whatever its model status (an incumbent of a MIP stopped at its time limit)."""
    info = highs.getInfo()
    feasible = int(FEASIBLE_SOLUTION_STATUS)
    primal = int(info.primal_solution_status) == feasible
    return primal and (not dual or int(info.dual_solution_status) == feasible)


#: HiGHS's ``SolutionStatus.kSolutionStatusFeasible``
FEASIBLE_SOLUTION_STATUS = 2


@dataclass(frozen=True)
class MipInfo:
    """What a HiGHS MIP run proved, in HiGHS's (minimisation) objective.

    ``primal_bound`` is the incumbent's objective (``inf`` without one) and ``dual_bound`` the
    best bound, so ``dual_bound <= optimum <= primal_bound``; ``gap`` is HiGHS's relative gap
    ``mip_gap = |primal_bound - dual_bound| / |primal_bound|`` (``inf`` without an incumbent),
    ``nodes`` the branch-and-bound nodes, ``has_solution`` whether HiGHS holds a feasible point.
    """

    status: Status
    raw_status: str
    message: str
    primal_bound: float
    dual_bound: float
    gap: float
    nodes: int
    has_solution: bool


def mip_info(highs) -> MipInfo:
    """:class:`MipInfo` of a ``highspy.Highs`` after ``run()`` on a model with integer columns."""
    status, raw = highs_status(highs)
    info = highs.getInfo()
    has_solution = has_feasible_point(highs)
    primal = float(info.objective_function_value) if has_solution else float("inf")
    return MipInfo(status, raw, highs.modelStatusToString(highs.getModelStatus()), primal,
                   float(info.mip_dual_bound), float(info.mip_gap), int(info.mip_node_count), has_solution)


def highs_mip(A, c, row_lower, row_upper, col_lower, col_upper, integer, *, deadline: Deadline = NEVER,
              rel_gap: float, abs_gap: float, feasibility_tol: float, threads: int = 1, start=None,
              record=None) -> tuple[MipInfo, np.ndarray | None]:
    """``min c^T v`` over the rows and bounds with ``v_j`` integer where ``integer``, by HiGHS's branch and cut
    within ``deadline``: its :class:`MipInfo` and its best point (None without one).

    ``start``: a point to start from; ``record(dual_bound, primal_bound, force=False)``: called from HiGHS's MIP
    callbacks (periodically, and with ``force=True`` at every improving solution)."""
    import highspy

    h = new_highs()
    set_threads(h, threads)
    h.setOptionValue("mip_rel_gap", float(rel_gap))
    h.setOptionValue("mip_abs_gap", float(abs_gap))
    h.setOptionValue("mip_feasibility_tolerance", float(feasibility_tol))
    h.setOptionValue("primal_feasibility_tolerance", float(feasibility_tol))
    if not set_deadline(h, deadline):
        h.setOptionValue("time_limit", 0.0)
    model = highs_lp(A, c, row_lower, row_upper, col_lower, col_upper)
    model.integrality_ = [highspy.HighsVarType.kInteger if k else highspy.HighsVarType.kContinuous for k in integer]
    h.passModel(model)
    if start is not None:
        sol = highspy.HighsSolution()
        sol.col_value = np.asarray(start, float).tolist()
        sol.value_valid = True
        h.setSolution(sol)
    if record is not None:
        def on_interrupt(e):
            d = e.data_out
            record(float(d.mip_dual_bound), float(d.mip_primal_bound))

        def on_improving(e):
            d = e.data_out
            record(float(d.mip_dual_bound), float(d.objective_function_value), force=True)

        h.cbMipInterrupt.subscribe(on_interrupt)
        h.cbMipImprovingSolution.subscribe(on_improving)
    h.run()
    info = mip_info(h)
    point = np.asarray(h.getSolution().col_value, float) if info.has_solution else None
    return info, point


def solve_lp(c, A, row_lower, row_upper, col_lower, col_upper,
             deadline: Deadline = NEVER) -> tuple[Status, np.ndarray | None, float]:
    """``min c^T x`` s.t. ``row_lower <= A x <= row_upper``, ``col_lower <= x <= col_upper`` by HiGHS, once (for
    the small one-off LPs of the library: no scaling, no re-solves): ``(status, x or None, optimum)``."""
    A = sp.csc_array(np.atleast_2d(A) if not sp.issparse(A) else A)
    h = new_highs()
    h.passModel(highs_lp(A, c, row_lower, row_upper, col_lower, col_upper))
    if not set_deadline(h, deadline):
        return Status.TIME_LIMIT, None, float("nan")
    h.run()
    status, _ = highs_status(h)
    if status is not Status.OPTIMAL:
        return status, None, float("nan")
    return status, np.asarray(h.getSolution().col_value, float), float(h.getInfo().objective_function_value)


def small_lp(c, A_ub, b_ub, col_lower, col_upper) -> tuple[Status, float]:
    """``min c^T x`` s.t. ``A_ub x <= b_ub``, ``col_lower <= x <= col_upper`` (dense, small) by HiGHS:
    ``(status, optimum)``."""
    A = np.atleast_2d(np.asarray(A_ub, float))
    status, _, value = solve_lp(c, A, np.full(A.shape[0], -np.inf), np.asarray(b_ub, float), col_lower, col_upper)
    return status, value


def static_lp_solution(lp: LinearProgram, outcome: LPOutcome) -> Solution:
    """``(lam, x, u, z_u, z_f)`` from a solve of a static LP built by ``blockmpec.formulations.static_lp``.

    The LP is solved as ``min -lam``; with HiGHS's dual signs the mechanism is
    ``u = -y_eq`` (equilibrium rows) and the flow multipliers are ``z = -y`` (the
    ``<=`` rows), so that ``E^T u + N_u z_u + N z_f = 0`` and ``f_l^T u = 1``, where
    ``N`` is the friction operator the LP was built with.
    """
    return Solution(
        multiplier=float(lp.values("lam", outcome.v)[0]),
        x=lp.values("x", outcome.v),
        u=-lp.row_values("equilibrium", outcome.row_dual),
        z_u=-lp.row_values("unilateral", outcome.row_dual),
        z_f=-lp.row_values("friction", outcome.row_dual),
    )


#: HiGHS's interior point IPX without its crossover (no basis; the run ends ``kUnknown`` at its tolerances, read
#: as ``OPTIMAL`` when HiGHS calls both points feasible): an algorithm of :class:`HighsLP` only, not a user's choice
IPM_WITHOUT_CROSSOVER = "ipm-without-crossover"
#: ``highspy.HighsBasisStatus`` values of the basis arrays of :meth:`HighsLP.basis_status` and
#: :meth:`HighsLP.set_basis`
AT_LOWER, BASIC, AT_UPPER = 0, 1, 2


class HighsLP:
    """One LP held by HiGHS, in the units of its problem; re-solves after changes are warm.

    Parameters
    ----------
    lp : LinearProgram
        The problem (its arrays are read once; :meth:`set_row_upper` also updates ``lp.row_upper``, every other
        setter changes HiGHS's model only, so ``lp`` may be shared between several models).
    algorithm : str
        One of :data:`~blockmpec.solvers.plan.BASIS_ALGORITHMS` or :data:`IPM_WITHOUT_CROSSOVER`
        (``"auto"``: :func:`~blockmpec.solvers.plan.lp_algorithm`).
    threads : int
        HiGHS's ``threads`` (0: HiGHS's default).
    scaling : Scaling, optional
        The units reduction HiGHS solves in (:class:`~blockmpec.solvers.engines.scaling.Scaling`: ``R A C``);
        values go in and come out in ``lp``'s units.  ``row_scale``, ``column_scale``: the same as two arrays.
    """

    def __init__(self, lp: LinearProgram, algorithm: str = "auto", threads: int = 0, scaling: Scaling | None = None,
                 row_scale: np.ndarray | None = None, column_scale: np.ndarray | None = None) -> None:
        if algorithm not in (*BASIS_ALGORITHMS, IPM_WITHOUT_CROSSOVER):
            raise ValueError(f"algorithm must be one of {BASIS_ALGORITHMS}; got {algorithm!r}")
        self.lp = lp
        self.scaling = scaling if scaling is not None else Scaling.of(lp, row_scale, column_scale)
        h = new_highs()
        if threads:
            set_threads(h, threads)
        h.passModel(highs_model(self.scaling.apply(lp)))
        self._highs = h
        self.algorithm = algorithm
        #: the algorithm of the latest solve (for the run's plan)
        self.last_algorithm = algorithm
        self._first = True

    @property
    def row_scale(self) -> np.ndarray:
        """``R`` of :attr:`scaling`."""
        return self.scaling.row

    @property
    def column_scale(self) -> np.ndarray:
        """``C`` of :attr:`scaling`."""
        return self.scaling.column

    # ------------------------------------------------------------------ algorithm and options
    def set_algorithm(self, algorithm: str) -> None:
        """Set HiGHS's solver for the next solve: ``algorithm`` as :func:`~blockmpec.solvers.plan.lp_algorithm`
        resolves it (``"auto"``: the dual simplex on a warm re-solve), recorded in :attr:`last_algorithm`.  Every
        :meth:`solve` calls it."""
        h = self._highs
        if algorithm != IPM_WITHOUT_CROSSOVER:
            algorithm = lp_algorithm(algorithm, self.lp.A.shape[0], need_basis=True, warm=not self._first)
        self.last_algorithm = algorithm
        if algorithm in ("ipm", IPM_WITHOUT_CROSSOVER):
            use_interior_point(h, crossover=algorithm == "ipm")
        else:
            h.setOptionValue("solver", "simplex")
            strategy = {"simplex": 0, "dual-simplex": 1, "primal-simplex": 4}[algorithm]
            h.setOptionValue("simplex_strategy", strategy)

    def set_feasibility_tolerances(self, tol: float | None = None, *, primal: float | None = None,
                                   dual: float | None = None) -> None:
        """HiGHS's primal and dual feasibility tolerances (absolute, in the scaled LP's units): both ``tol``, or
        only those given as ``primal``, ``dual``; without any, both :data:`FEASIBILITY_TOL`."""
        if tol is None and primal is None and dual is None:
            tol = FEASIBILITY_TOL
        primal, dual = (tol, tol) if tol is not None else (primal, dual)
        for name, value in (("primal_feasibility_tolerance", primal), ("dual_feasibility_tolerance", dual)):
            if value is not None:
                self._highs.setOptionValue(name, float(value))

    def feasibility_tolerances(self) -> tuple[float, float]:
        """HiGHS's ``(primal, dual)`` feasibility tolerances now."""
        return (float(_option_value(self._highs, "primal_feasibility_tolerance")),
                float(_option_value(self._highs, "dual_feasibility_tolerance")))

    def set_presolve(self, on: bool) -> None:
        """HiGHS's presolve: ``"choose"`` (its default) or ``"off"``."""
        self._highs.setOptionValue("presolve", "choose" if on else "off")

    def set_iteration_limit(self, iterations: int) -> None:
        """HiGHS's simplex iteration limit of each later solve (the status is then ``ITERATION_LIMIT``)."""
        self._highs.setOptionValue("simplex_iteration_limit", int(iterations))

    # ------------------------------------------------------------------ the model, in the problem's units
    def set_costs(self, columns, costs) -> None:
        """Costs of ``columns`` (HiGHS's model only)."""
        columns = np.asarray(columns, dtype=np.int32)
        self._highs.changeColsCost(columns.size, columns, self.scaling.costs(columns, costs))

    def set_row_bounds(self, rows, lower, upper) -> None:
        """Lower and upper bounds of ``rows`` (HiGHS's model only; ``+-inf`` for none)."""
        rows = np.asarray(rows, dtype=np.int32)
        _checked(self._highs.changeRowsBounds(rows.size, rows, self.scaling.row_values(rows, lower),
                                              self.scaling.row_values(rows, upper)))

    def set_row_upper(self, rows: np.ndarray, upper: np.ndarray) -> None:
        """Change the upper bounds of ``rows`` (lower bounds kept), in HiGHS's model and in ``lp.row_upper``."""
        rows = np.asarray(rows, dtype=np.int32)
        self.lp.row_upper[rows] = upper
        self._highs.changeRowsBounds(rows.size, rows, self.scaling.row_values(rows, self.lp.row_lower[rows]),
                                     self.scaling.row_values(rows, upper))

    def set_column_bounds(self, columns, lower, upper) -> None:
        """Lower and upper bounds of ``columns`` (HiGHS's model only; ``+-inf`` for none)."""
        columns = np.asarray(columns, dtype=np.int32)
        _checked(self._highs.changeColsBounds(columns.size, columns, self.scaling.column_values(columns, lower),
                                              self.scaling.column_values(columns, upper)))

    def set_coefficients(self, rows, columns, values) -> None:
        """Matrix entries ``A[rows[j], columns[j]] = values[j]`` (HiGHS's model only; the basis is kept)."""
        rows, columns = np.asarray(rows, dtype=np.int64), np.asarray(columns, dtype=np.int64)
        scaled = self.scaling.coefficients(rows, columns, values)
        for r, c, v in zip(rows.tolist(), columns.tolist(), scaled.tolist()):
            _checked(self._highs.changeCoeff(r, c, v))

    def add_rows(self, matrix, lower, upper) -> None:
        """Append the rows ``lower <= matrix v <= upper`` (``matrix`` sparse, one row per new row; the new rows are
        unscaled: the scaling gets a 1 per row)."""
        rows = sp.csr_array(matrix)
        cols = self.scaling.column
        scaled = rows @ sp.diags(cols)
        scaled = sp.csr_array(scaled)
        _checked(self._highs.addRows(rows.shape[0], np.asarray(lower, float), np.asarray(upper, float), int(scaled.nnz),
                                     scaled.indptr[:-1].astype(np.int32), scaled.indices.astype(np.int32), scaled.data))
        self.scaling = Scaling(np.concatenate([self.scaling.row, np.ones(rows.shape[0])]), cols)

    # ------------------------------------------------------------------ basis
    def basis_status(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The current basis as integer arrays (:data:`AT_LOWER`, :data:`BASIC`, :data:`AT_UPPER` ...) of columns
        and rows, or None without a valid basis."""
        basis = self._highs.getBasis()
        if not basis.valid:
            return None
        return (np.fromiter((int(s) for s in basis.col_status), int, len(basis.col_status)),
                np.fromiter((int(s) for s in basis.row_status), int, len(basis.row_status)))

    def set_basis(self, col_status: np.ndarray, row_status: np.ndarray) -> bool:
        """Install a basis (integer ``HighsBasisStatus`` values); the next solve starts from it."""
        import highspy as hs

        basis = hs.HighsBasis()
        basis.col_status = [hs.HighsBasisStatus(int(v)) for v in col_status]
        basis.row_status = [hs.HighsBasisStatus(int(v)) for v in row_status]
        basis.valid = True
        ok = self._highs.setBasis(basis) == hs.HighsStatus.kOk
        if ok:
            self._first = False
        return ok

    def clear_basis(self) -> None:
        """Forget the basis and the factorisation (the next solve is cold)."""
        self._highs.clearSolver()

    # ------------------------------------------------------------------ solve
    def solve(self, algorithm: str | None = None, deadline: Deadline = NEVER, cold: bool = False) -> LPOutcome:
        """Solve within ``deadline`` (warm from the previous basis unless ``cold``); ``algorithm`` overrides once.

        A deadline already passed returns ``TIME_LIMIT`` without running HiGHS.  After a solve error at feasibility
        tolerances tighter than HiGHS's own, one run at :data:`HIGHS_DEFAULT_FEASIBILITY_TOL`
        (:meth:`_retry_at_default_tolerances`)."""
        h = self._highs
        if not set_deadline(h, deadline):
            nan = np.full(self.lp.c.size, np.nan)
            return LPOutcome(Status.TIME_LIMIT, "kTimeLimit", float("nan"), nan, np.full(self.lp.A.shape[0], np.nan),
                             0, message="time limit reached before the LP")
        if cold:
            h.clearSolver()
        self.set_algorithm(algorithm or self.algorithm)
        h.run()
        self._first = False
        status, raw = highs_status(h, interior_without_crossover=self.last_algorithm == IPM_WITHOUT_CROSSOVER)
        retried = ""
        if status is Status.ERROR:
            status, raw, retried = self._retry_at_default_tolerances(raw)
        info = h.getInfo()
        iterations = int(max(info.simplex_iteration_count, 0) + max(info.ipm_iteration_count, 0))
        sol = h.getSolution()
        v, y = np.asarray(sol.col_value, float), np.asarray(sol.row_dual, float)
        if v.size == self.lp.c.size and y.size == self.scaling.row.size:
            v, y = self.scaling.primal(v), self.scaling.dual(y)
        else:
            v, y = np.full(self.lp.c.size, np.nan), np.full(self.scaling.row.size, np.nan)
        obj = float(info.objective_function_value) if status is Status.OPTIMAL else float("nan")
        return LPOutcome(status, raw, obj, v, y, iterations,
                         message=h.modelStatusToString(h.getModelStatus()) + retried,
                         has_feasible_point=has_feasible_point(h))

    def dual_ray(self) -> np.ndarray | None:
        """HiGHS's dual ray after an infeasible solve (a Farkas certificate to check), in the problem's units, or
        None when HiGHS has none."""
        try:
            _, has_ray, ray = self._highs.getDualRay()
        except Exception:  # noqa: BLE001 - highspy raises when it holds no ray
            return None
        return self.scaling.dual(ray) if has_ray else None

    def _retry_at_default_tolerances(self, raw: str) -> tuple[Status, str, str]:
        """After a solve error (``kSolveError``, ``kNotset``) at feasibility tolerances tighter than HiGHS's own:
        one run at :data:`HIGHS_DEFAULT_FEASIBILITY_TOL`, the tolerances then restored; ``(status, raw, note)``.

        Measured: the static LP of a 304-stone ``stone-wall`` with ``mu`` 1.2, whose optimal forces are unbounded
        (self-stress, see :mod:`blockmpec.solvers.static_lp`), ends ``kSolveError`` by every HiGHS algorithm at
        1e-9 and ``kOptimal`` at 1e-7 (its kinematic LP alike); the verifier then judges the point."""
        h = self._highs
        names = ("primal_feasibility_tolerance", "dual_feasibility_tolerance")
        tight = {name: float(_option_value(h, name)) for name in names}
        if all(value >= HIGHS_DEFAULT_FEASIBILITY_TOL for value in tight.values()):
            return Status.ERROR, raw, ""
        set_feasibility_tolerances(h, HIGHS_DEFAULT_FEASIBILITY_TOL)
        try:
            h.run()
        finally:
            for name, value in tight.items():
                h.setOptionValue(name, value)
        status, retried_raw = highs_status(h)
        note = (f" (at feasibility tolerances {max(tight.values()):g} HiGHS ended {raw}; this is its run at its "
                f"default {HIGHS_DEFAULT_FEASIBILITY_TOL:g})")
        return status, retried_raw, note


def _checked(status) -> None:
    """Raise when HiGHS refused a model change (its ``HighsStatus`` is ``kError``)."""
    if not change_applied(status):
        raise RuntimeError("HiGHS refused a model change")

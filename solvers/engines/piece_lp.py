r"""Piece LPs of the MPEC (4): an exact local descent and a certificate of local minimality.

A *piece* of the feasible set of (4) fixes, for every pair ``i`` of (3), which side of
``0 <= s_i _|_ z_i >= 0`` is zero (``s_i = -G_i w`` the pair slack, ``z_i = w[pair_column[i]]``):
``S`` (``s_i = 0``, ``z_i >= 0``) or ``Z`` (``z_i = 0``, ``s_i >= 0``).  On a piece every row of
(3) is linear, so ``min lam`` over it is the linear program ::

    (PLP)  min lam  s.t.  A w = rhs,  G_S w = 0,  G_Z w <= 0,  z_S >= 0,  z_Z = 0,

and each of its feasible points solves (3) exactly (one side of every pair is a bound).

Local minimality.  At a point ``w*`` of (4) let ``B`` be its biactive pairs (``z_i = s_i = 0``).
The relaxed LP ::

    (RLP)  min lam  s.t.  A w = rhs,  G_S w = 0,  G_Z w <= 0,  z_S >= 0,  z_Z = 0  (pairs not in B),
                          G_B w <= 0,  z_B >= 0                                  (pairs in B)

contains every point of (4) near ``w*`` (near ``w*`` a pair outside ``B`` keeps its positive side
positive, hence its other side zero).  So if ``lam(w*)`` is the optimum of (RLP), ``w*`` is a local
minimum of (4) (strong stationarity, Scheel & Scholtes 2000).  Otherwise each biactive pair that the
minimiser of (RLP) leaves positive on one side only moves to that piece, and the next piece is solved (at most ``rounds``
pieces; the multiplier never increases from one piece to the next, as the previous minimiser lies
on the next piece).

Rounding the start.  A start that solves (3) only approximately (an interior-point fixed point,
products ``z_i s_i`` of 1e-10) may round onto an empty piece (measured on the 2,032-block wall:
HiGHS proves the rounded piece infeasible).  So the first LP leaves *ambiguous* pairs free (both
sides ``>= 0``, as in (RLP)): those whose smaller side, relative to its largest value over all pairs,
is more than a fraction (:data:`AMBIGUOUS`, first 1e-3) of the larger side; if its minimiser leaves both sides of a free pair
positive, the pair goes to its relatively smaller side and the LP is solved again.  When that
ends without a solution of (3), a coarser threshold is tried (:data:`AMBIGUOUS`).

LP algorithm.  Dual simplex (a vertex, exact zeros) below ``IPM_PAIRS`` pairs; above, HiGHS's
interior point without crossover (measured on the 2,032-block wall, first piece: dual simplex
110 s CPU, interior point with crossover 102 s, without 34 s), whose zeros are exact to its
tolerance; ``zero_tol`` and the certificate's tolerance are set accordingly.

Units: HiGHS solves in the units of :func:`blockmpec.solvers.nlp.nlp_scaling` (each block's rows
over its load, pair slacks in the reciprocal units of their multipliers), so that "zero" means
``<= zero_tol`` in units for every pair alike.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from blockmpec.result import Status


@dataclass
class PieceOutcome:
    """A piece-LP descent: the best exact point, its multiplier and whether (RLP) certified it."""

    status: Status
    w: np.ndarray | None
    multiplier: float
    certified: bool
    pieces: int
    lp_solves: int
    lp_time_s: float
    biactive: int
    message: str
    trace: list[dict] = field(default_factory=list)


class PieceLP:
    """One HiGHS model of (PLP)/(RLP) over ``w``; the piece is set by bounds and re-solved.

    Parameters
    ----------
    form : CompiledMCP
    column_scale, row_scale, slack_scale : ndarray
        The units of :func:`blockmpec.solvers.nlp.nlp_scaling`.
    time_limit : float
        Seconds for every LP together (HiGHS ``time_limit`` of each solve is the time left).
    interior : bool
        HiGHS's interior point without crossover (else dual simplex, warm after a bound change).
    """

    def __init__(self, form, column_scale: np.ndarray, row_scale: np.ndarray, slack_scale: np.ndarray,
                 time_limit: float = math.inf, interior: bool = False) -> None:
        from blockmpec.formulations._pyomo import LinearProgram
        from blockmpec.solvers.engines.highs import HighsLP

        self.form = form
        n, p = form.n_columns, form.n_pairs
        m_eq = form.A.shape[0]
        self.pair_rows = (m_eq + np.arange(p)).astype(np.int32)
        self.z_cols = np.asarray(form.pair_column)
        self.z_unit = column_scale[self.z_cols]
        self.s_unit = slack_scale
        c = np.zeros(n)
        c[form.lam] = 1.0
        col_lower = np.full(n, -math.inf)
        col_lower[self.z_cols] = 0.0
        lp = LinearProgram(c=c, A=sp.vstack([form.A, form.G]).tocsr(),
                           row_lower=np.concatenate([form.rhs, np.full(p, -math.inf)]),
                           row_upper=np.concatenate([form.rhs, np.zeros(p)]),
                           col_lower=col_lower, col_upper=np.full(n, math.inf), columns={}, rows={},
                           objective_sign=1.0)
        self.lp = HighsLP(lp, row_scale=np.concatenate([row_scale, 1.0 / slack_scale]), column_scale=column_scale)
        h = self.lp.highs
        self.interior = interior
        if interior:
            h.setOptionValue("solver", "ipm")
            h.setOptionValue("run_crossover", "off")
        else:
            h.setOptionValue("solver", "simplex")
            h.setOptionValue("simplex_strategy", 1)  # dual
        self.deadline = time.perf_counter() + time_limit
        self.lp_solves = 0
        self.lp_time_s = 0.0

    def sides(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(z^, s^)``: the pair multipliers and slacks of ``w`` in units (negative parts cut)."""
        z = np.maximum(w[self.z_cols], 0.0) / self.z_unit
        s = np.maximum(-(self.form.G @ w), 0.0) / self.s_unit
        return z, s

    def set_piece(self, slack_zero: np.ndarray, free: np.ndarray | None = None) -> None:
        """Pairs with ``slack_zero`` on side ``S``, the others on ``Z``; pairs in ``free`` relaxed (RLP)."""
        free = np.zeros_like(slack_zero) if free is None else free
        h, lp = self.lp.highs, self.lp
        p = slack_zero.size
        row_lower = np.where(slack_zero & ~free, 0.0, -math.inf)
        col_upper = np.where(~slack_zero & ~free, 0.0, math.inf)
        h.changeRowsBounds(p, self.pair_rows, lp.row_scale[self.pair_rows] * row_lower, np.zeros(p))
        cols = self.z_cols.astype(np.int32)
        h.changeColsBounds(p, cols, np.zeros(p), col_upper / lp.column_scale[cols])

    def dual_sign_violations(self, out: LPSolution, slack_zero: np.ndarray, biactive: np.ndarray,
                             tol: float) -> int:
        """How many biactive pairs' duals of a solved piece are infeasible for (RLP) (0: ``out`` is optimal for it).

        (RLP) relaxes, on a biactive pair, ``G_i w = 0`` to ``G_i w <= 0`` (side ``S``: its row dual must
        be ``<= 0``, HiGHS's sign for an active upper bound of a minimisation) or ``z_i = 0`` to ``z_i >= 0``
        (side ``Z``: the reduced cost of ``z_i`` must be ``>= 0``).  Counted in units, against ``tol``.
        """
        reduced = self.lp.lp.c - self.lp.lp.A.T @ out.row_dual
        row_dual = out.row_dual[self.pair_rows] * self.s_unit  # dual of the row (G_i w) / S_i
        col_dual = reduced[self.z_cols] * self.z_unit  # reduced cost of z^_i
        bad_s = biactive & slack_zero & (row_dual > tol)
        bad_z = biactive & ~slack_zero & (col_dual < -tol)
        return int(bad_s.sum() + bad_z.sum())

    def solve(self, cold: bool = False) -> LPSolution | None:
        """Solve the current piece (dual simplex: warm from the last basis unless ``cold``); None past the deadline.

        Measured on the 510-block wall: after relaxing the biactive pairs' bounds the warm dual simplex
        took 14,514 iterations (10.9 s), a cold solve 4,118 (2.3 s); (RLP) is solved cold.
        """
        remaining = self.deadline - time.perf_counter()
        if remaining <= 0:
            return None
        h = self.lp.highs
        if cold:
            h.clearSolver()
        # HiGHS's presolve declared the 2,032-block wall's relaxed LP infeasible before its interior point
        # (which then ended "kInfeasible"); it contains the piece's minimiser, and without presolve it
        # solves (kOptimal, lam 0.42265 < the piece's 0.42327).  The pieces keep presolve (without it the
        # first piece took 2x longer)
        h.setOptionValue("presolve", "off" if (cold and self.interior) else "choose")
        h.setOptionValue("time_limit", float(remaining) if math.isfinite(remaining) else math.inf)
        t0 = time.perf_counter()
        h.run()
        self.lp_time_s += time.perf_counter() - t0
        self.lp_solves += 1
        raw = h.getModelStatus().name
        info = h.getInfo()
        # HiGHS's interior point without crossover ends "kUnknown" when it stops at its tolerances
        # without a basis; its point counts when HiGHS calls both primal and dual solutions feasible
        feasible = info.primal_solution_status == 2 and info.dual_solution_status == 2
        if raw == "kOptimal" or (self.interior and raw == "kUnknown" and feasible):
            status = Status.OPTIMAL
        elif raw == "kTimeLimit":
            status = Status.TIME_LIMIT
        elif raw == "kInfeasible":
            status = Status.INFEASIBLE
        else:
            status = Status.NUMERICAL
        sol = h.getSolution()
        w = self.lp.column_scale * np.asarray(sol.col_value, float)
        y = self.lp.row_scale * np.asarray(sol.row_dual, float)
        return LPSolution(status, raw, float(w[self.form.lam]) if w.size else math.nan, w, y)


@dataclass
class LPSolution:
    """One piece LP solve: status, HiGHS's name for it, ``lam``, the point ``w`` and the row duals."""

    status: Status
    raw_status: str
    objective: float
    v: np.ndarray
    row_dual: np.ndarray


#: pairs from which the piece LPs use HiGHS's interior point (no crossover) instead of the dual simplex
IPM_PAIRS = 10_000
#: a side of a pair counts as zero at most this (units); the certificate's relative tolerance on lam
ZERO_TOL = {False: 1e-9, True: 1e-7}
LAM_TOL = {False: 1e-9, True: 1e-7}
#: a pair is ambiguous at the start when its relatively smaller side exceeds this fraction of the larger; the
#: roundings tried in turn while the piece LPs find no solution of (3) (measured from the fixed point: 15x10
#: wall, 1e-3 frees a pair whose rounding is then empty, 0.1 is certified at once; 2,032-block wall, 0.1 gives
#: an empty first piece, 1e-3 a solution of (3)); the finer first, as a failed LP costs most on large structures
AMBIGUOUS = (1e-3, 0.1)


def _relative(v: np.ndarray) -> np.ndarray:
    return v / max(float(v.max(initial=0.0)), 1e-300)


def piece_descent(form, scaling, w_start: np.ndarray, time_limit: float = math.inf, rounds: int = 10,
                  interior: bool | None = None) -> PieceOutcome:
    """Local descent over the pieces of (4) from ``w_start`` (a solution of (3), possibly approximate).

    The first piece puts pair ``i`` on side ``S`` when its slack is relatively the smaller side,
    ``s^_i / max s^ <= z^_i / max z^`` (units of ``scaling``), and leaves ambiguous pairs free (module
    docstring).  Each round solves (PLP); when its minimiser is complementary, the biactive pairs (both
    sides ``<= ZERO_TOL``) are checked: if the piece's duals are feasible for (RLP), or (RLP) solved
    cold does not go below ``lam`` by more than ``LAM_TOL max(1, |lam|)``, the point is a certified local
    minimum; otherwise each biactive pair that (RLP) put on one side moves to it.
    ``interior``: None chooses by size (:data:`IPM_PAIRS`).

    Returns
    -------
    PieceOutcome
        ``status`` ``LOCALLY_OPTIMAL`` (certified; ``w`` solves (3) exactly), ``ITERATION_LIMIT`` (``rounds``
        LPs without a certificate; ``w`` the best complementary point, if any), ``TIME_LIMIT``, or the
        failure of an LP (``w`` None when no complementary point was found).
    """
    interior = form.n_pairs >= IPM_PAIRS if interior is None else interior
    plp = PieceLP(form, *scaling, time_limit=time_limit, interior=interior)
    z, s = plp.sides(np.asarray(w_start, float))
    zr, sr = _relative(z), _relative(s)
    trace: list[dict] = []
    for k, ambiguous in enumerate(AMBIGUOUS):
        free = (np.minimum(zr, sr) > ambiguous * np.maximum(zr, sr)) | (np.maximum(zr, sr) < 1e-12)
        out = _descend(plp, sr <= zr, free, rounds, interior, trace)
        # no solution of (3) from this rounding (an empty piece, or HiGHS's interior point stopping without a
        # feasible point, as it does on an empty piece): the next rounding
        if out.w is not None or out.status in (Status.TIME_LIMIT, Status.ITERATION_LIMIT) or k == len(AMBIGUOUS) - 1:
            return out
    raise AssertionError("unreachable")


def _descend(plp: PieceLP, slack_zero: np.ndarray, free: np.ndarray, rounds: int, interior: bool,
             trace: list[dict]) -> PieceOutcome:
    """The rounds of :func:`piece_descent` from one rounding of the start (``slack_zero``, ``free``)."""
    zero_tol, lam_tol = ZERO_TOL[interior], LAM_TOL[interior]
    best_w, best_lam, biactive = None, math.inf, 0
    status, message = Status.ITERATION_LIMIT, f"{rounds} piece LPs without a certificate"
    for k in range(rounds):
        plp.set_piece(slack_zero, free=free)
        out = plp.solve()
        if out is None or out.status is Status.TIME_LIMIT:
            status, message = Status.TIME_LIMIT, f"time limit in piece LP {k + 1}"
            break
        if out.status is not Status.OPTIMAL:
            status, message = out.status, f"piece LP {k + 1}: HiGHS {out.raw_status}"
            break
        w, lam = out.v, out.objective
        z, s = plp.sides(w)
        both_positive = free & (z > zero_tol) & (s > zero_tol)
        rec = {"piece": len(trace) + 1, "multiplier": lam, "free": int(free.sum()),
               "not_complementary": int(both_positive.sum())}
        trace.append(rec)
        if both_positive.any():  # a free pair left off its piece: put it on its smaller side, solve again
            slack_zero = np.where(free, _relative(s) <= _relative(z), slack_zero)
            free = np.zeros_like(free)
            continue
        free = np.zeros_like(free)
        slack_zero = np.where(s <= zero_tol, True, np.where(z <= zero_tol, False, slack_zero))
        if lam <= best_lam:
            best_w, best_lam = w, lam
        both_zero = (z <= zero_tol) & (s <= zero_tol)
        biactive = int(both_zero.sum())
        wrong_sign = plp.dual_sign_violations(out, slack_zero, both_zero, tol=zero_tol)
        rec.update(biactive=biactive, wrong_dual_signs=wrong_sign)
        if wrong_sign == 0:  # the piece's duals are dual feasible for (RLP): certified without solving it
            status = Status.LOCALLY_OPTIMAL
            message = (f"piece LP {k + 1}: lam = {lam:.10g}, certified local minimum of (4) (its duals are "
                       f"feasible for the relaxed LP over its {biactive} biactive pairs)")
            best_w, best_lam = w, lam
            break
        plp.set_piece(slack_zero, free=both_zero)
        relaxed = plp.solve(cold=True)
        if relaxed is None or relaxed.status is Status.TIME_LIMIT:
            status, message = Status.TIME_LIMIT, f"time limit in the relaxed LP of piece LP {k + 1}"
            break
        rec["relaxed_multiplier"] = relaxed.objective
        if relaxed.status is not Status.OPTIMAL:
            status, message = relaxed.status, f"relaxed LP of piece LP {k + 1}: HiGHS {relaxed.raw_status}"
            break
        if relaxed.objective >= lam - lam_tol * max(1.0, abs(lam)):
            status = Status.LOCALLY_OPTIMAL
            message = (f"piece LP {k + 1}: lam = {lam:.10g}, certified local minimum of (4) (the relaxed LP "
                       f"over its {biactive} biactive pairs does not go lower)")
            best_w, best_lam = w, lam
            break
        # a biactive pair goes to the side (RLP) left at zero when it left the other one positive; otherwise it
        # stays (the piece's minimiser, zero on both sides, lies on the next piece whatever these pairs do)
        z2, s2 = plp.sides(relaxed.v)
        moved = np.where(both_zero & (z2 > zero_tol) & (s2 <= zero_tol), True,
                         np.where(both_zero & (s2 > zero_tol) & (z2 <= zero_tol), False, slack_zero))
        if np.array_equal(moved, slack_zero):
            status = Status.ITERATION_LIMIT
            message = (f"piece LP {k + 1}: lam = {lam:.10g}; the relaxed LP goes lower ({relaxed.objective:.10g}) "
                       f"but moves no biactive pair to one side: not certified")
            break
        slack_zero = moved
    return PieceOutcome(status, best_w, best_lam, status is Status.LOCALLY_OPTIMAL, len(trace), plp.lp_solves,
                        plp.lp_time_s, biactive, message, trace)

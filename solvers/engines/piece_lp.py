r"""Piece LPs of the MPEC (4): an exact local descent and a certificate of local minimality.

A *piece* of the feasible set of (4) fixes, for every pair ``i`` of (3), which side of
``0 <= s_i _|_ z_i >= 0`` is zero (``s_i = -G_i w`` the pair slack, ``z_i = w[pair_column[i]]``):
``S`` (``s_i = 0``, ``z_i >= 0``) or ``Z`` (``z_i = 0``, ``s_i >= 0``).  On a piece every row of
(3) is linear, so ``min lam`` over it is the linear program ::

    (PLP)  min lam  s.t.  A w = rhs,  G_S w = 0,  G_Z w <= 0,  z_S >= 0,  z_Z = 0,

and each of its feasible points solves (3) exactly (one side of every pair is a bound).

The split.  The pair rows ``G`` are nonzero in the ``x`` columns only, the equilibrium rows in
``(lam, x)`` only, compatibility and normalisation in ``(u, z)`` only.  So (PLP) is two LPs that no row
couples: the *static half* ``min lam`` s.t. equilibrium, ``G_S x = 0``, ``G_Z x <= 0``
(:func:`static_program`, :func:`static_piece`) and the *kinematic half*, a mechanism ``f_l^T u = 1``,
compatibility, ``z_S >= 0``, ``z_Z = 0`` (:func:`kinematic_program`, :func:`mechanism_piece`; ``min 1^T z``
gives a vertex with few active pairs).  ``milp``'s polish (:meth:`~blockmpec.solvers.milp.MILPSolver.polish`)
is these two functions; ``nlp``'s piece route (:func:`piece_descent`) uses them through :class:`SplitPieces`.

Local minimality.  At a point ``w*`` of (4) let ``B`` be its biactive pairs (``z_i = s_i = 0``).
The relaxed LP ::

    (RLP)  min lam  s.t.  A w = rhs,  G_S w = 0,  G_Z w <= 0,  z_S >= 0,  z_Z = 0  (pairs not in B),
                          G_B w <= 0,  z_B >= 0                                  (pairs in B)

contains every point of (4) near ``w*`` (near ``w*`` a pair outside ``B`` keeps its positive side
positive, hence its other side zero).  So if ``lam(w*)`` is the optimum of (RLP), ``w*`` is a local
minimum of (4) (strong stationarity, Scheel & Scholtes 2000).  (RLP) splits as (PLP) does, and its
kinematic half, with no cost, is feasible at ``w*``: (RLP) is the static LP with ``G_i x = 0`` on the
support of ``z*`` and ``G_i x <= 0`` elsewhere.  Conversely every point of that static LP near ``x*``, with
``(u*, z*)``, is a point of (4): the certificate is exact, and a point is a local minimum iff its
``(lam, x)`` is optimal for the static LP on its own support (:meth:`SplitPieces.certificate` checks the
duals).  The split descent (:func:`piece_descent`) therefore only chooses mechanisms: a static LP on a
mechanism's support is a certified local minimum, and a mechanism that frees a pair whose equality has a
positive dual may lower ``lam`` further.

The whole route (:func:`whole_piece_descent`, :class:`PieceLP`; the route before the split, kept for
measurement and as the tests' independent check of the certificate) solves (PLP) and (RLP) as one HiGHS
LP each: if (RLP) goes lower, each biactive pair that its minimiser leaves positive on one side only moves to
that piece, and the next piece is solved (at most ``rounds`` pieces).

Rounding the start.  A start that solves (3) only approximately (an interior-point fixed point,
products ``z_i s_i`` of 1e-10) may round onto an empty piece.  So the first LP leaves *ambiguous* pairs free
(both sides ``>= 0``, as in (RLP)): those whose smaller side, relative to its largest value over all pairs, is
more than a fraction (:data:`AMBIGUOUS`, first 1e-3) of the larger side; if its minimiser leaves both sides of a
free pair positive, the pair goes to its relatively smaller side and the LP is solved again.  When that
ends without a solution of (3), a coarser threshold is tried (:data:`AMBIGUOUS`).  The split route lets
the first mechanism use the same pairs (slack the smaller side, or ambiguous).

LP algorithms.  Whole route: dual simplex (a vertex, exact zeros) below
:data:`~blockmpec.solvers.plan.PIECE_LP_IPM_PAIRS` pairs, HiGHS's interior point without crossover above.  Split
route: mechanisms by HiGHS's dual simplex (warm; primal feasibility 1e-10); static halves by HiGHS's dual simplex
below :data:`~blockmpec.solvers.plan.PIECE_LP_BLOCK_IPM_PAIRS` pairs and by the block interior-point method above
(:func:`static_piece_ipm`).  The measurements behind both thresholds are in the changelog.

Units: HiGHS solves in the units of :meth:`LoadUnits.mcp <blockmpec.solvers.engines.scaling.LoadUnits.mcp>` (each block's rows
over its load, pair slacks in the reciprocal units of their multipliers), so that "zero" means
``<= zero_tol`` in units for every pair alike.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from blockmpec.deadline import NEVER, Deadline
from blockmpec.result import Status
from blockmpec.solvers.engines.highs import IPM_WITHOUT_CROSSOVER, MECHANISM_FEASIBILITY_TOL, HighsLP, LPOutcome
from blockmpec.solvers.engines.scaling import MCPScaling, Scaling
from blockmpec.solvers.plan import BLOCK_IPM_RULES, piece_lp_static_engine, piece_lp_whole_engine

__all__ = ["Certificate", "PieceLP", "PieceOutcome", "STATIC_ENGINES", "SplitPieces", "closed_interfaces",
           "kinematic_program", "mechanism_piece", "piece_descent", "static_piece", "static_piece_ipm",
           "static_program", "whole_piece_descent"]

if TYPE_CHECKING:
    from blockmpec.formulations.pyomo_compile import LinearProgram


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
    #: the split route: seconds in the static and in the kinematic LPs, and the certificate of ``w``
    static_time_s: float = 0.0
    kinematic_time_s: float = 0.0
    certificate: Certificate | None = None


class PieceLP:
    """One HiGHS model of (PLP)/(RLP) over ``w``; the piece is set by bounds and re-solved.

    Parameters
    ----------
    form : CompiledMCP
    scaling : MCPScaling
        The units of (3) (:meth:`LoadUnits.mcp <blockmpec.solvers.engines.scaling.LoadUnits.mcp>`).
    deadline : Deadline
        The run's deadline (HiGHS's time limit of each solve is the time left).
    interior : bool
        HiGHS's interior point without crossover (else dual simplex, warm after a bound change).
    """

    def __init__(self, form, scaling: MCPScaling, deadline: Deadline = NEVER, interior: bool = False) -> None:
        from blockmpec.formulations.pyomo_compile import LinearProgram

        self.form = form
        n, p = form.n_columns, form.n_pairs
        m_eq = form.A.shape[0]
        self.pair_rows = (m_eq + np.arange(p)).astype(np.int32)
        self.z_cols = np.asarray(form.pair_column)
        self.z_unit = scaling.column[self.z_cols]
        self.s_unit = scaling.slack
        c = np.zeros(n)
        c[form.lam] = 1.0
        col_lower = np.full(n, -math.inf)
        col_lower[self.z_cols] = 0.0
        lp = LinearProgram(c=c, A=sp.vstack([form.A, form.G]).tocsr(),
                           row_lower=np.concatenate([form.rhs, np.full(p, -math.inf)]),
                           row_upper=np.concatenate([form.rhs, np.zeros(p)]),
                           col_lower=col_lower, col_upper=np.full(n, math.inf), columns={}, rows={},
                           objective_sign=1.0)
        self.interior = interior
        self.lp = HighsLP(lp, IPM_WITHOUT_CROSSOVER if interior else "dual-simplex",
                          scaling=scaling.lp_scaling(np.arange(m_eq), np.arange(n)))
        self.deadline = deadline
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
        p = slack_zero.size
        row_lower = np.where(slack_zero & ~free, 0.0, -math.inf)
        col_upper = np.where(~slack_zero & ~free, 0.0, math.inf)
        self.lp.set_row_bounds(self.pair_rows, row_lower, np.zeros(p))
        self.lp.set_column_bounds(self.z_cols, np.zeros(p), col_upper)

    def dual_sign_violations(self, out: LPOutcome, slack_zero: np.ndarray, biactive: np.ndarray,
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

    def solve(self, cold: bool = False) -> LPOutcome | None:
        """Solve the current piece (dual simplex: warm from the last basis unless ``cold``); None past the deadline.
        Its ``objective`` is ``lam`` of its point; any status but ``OPTIMAL``, ``TIME_LIMIT`` and ``INFEASIBLE`` is
        ``NUMERICAL``.

        Measured on the 510-block wall: after relaxing the biactive pairs' bounds the warm dual simplex
        took 14,514 iterations (10.9 s), a cold solve 4,118 (2.3 s); (RLP) is solved cold.
        """
        if self.deadline.expired():
            return None
        # HiGHS's presolve declared the 2,032-block wall's relaxed LP infeasible before its interior point
        # (which then ended "kInfeasible"); it contains the piece's minimiser, and without presolve it
        # solves (kOptimal, lam 0.42265 < the piece's 0.42327).  The pieces keep presolve (without it the
        # first piece took 2x longer)
        self.lp.set_presolve(not (cold and self.interior))
        t0 = time.perf_counter()
        out = self.lp.solve(deadline=self.deadline, cold=cold)
        self.lp_time_s += time.perf_counter() - t0
        self.lp_solves += 1
        if out.status not in (Status.OPTIMAL, Status.TIME_LIMIT, Status.INFEASIBLE):
            out.status = Status.NUMERICAL
        out.objective = float(out.v[self.form.lam]) if out.v.size else math.nan
        return out


#: a side of a pair counts as zero at most this (units); the certificate's relative tolerance on lam
ZERO_TOL = {False: 1e-9, True: 1e-7}
LAM_TOL = {False: 1e-9, True: 1e-7}
#: a pair is ambiguous at the start when its relatively smaller side exceeds this fraction of the larger; the
#: roundings tried in turn while the piece LPs find no solution of (3) (measured from the fixed point: 15x10
#: wall, 1e-3 frees a pair whose rounding is then empty, 0.1 is certified at once; 2,032-block wall, 0.1 gives
#: an empty first piece, 1e-3 a solution of (3)); the finer first, as a failed LP costs most on large structures
AMBIGUOUS = (1e-3, 0.1)


def relative_to_largest(v: np.ndarray) -> np.ndarray:
    """``v / max(max_i v_i, 1e-300)``: each entry relative to the largest (a nonnegative ``v``), for
    comparing the two sides ``z`` and ``s`` of the pairs in their own scales (the whole route's first piece takes
    ``s_i / max s <= z_i / max z``)."""
    return v / max(float(v.max(initial=0.0)), 1e-300)


def whole_piece_descent(form, scaling, w_start: np.ndarray, deadline: Deadline = NEVER, rounds: int = 10,
                        interior: bool | None = None) -> PieceOutcome:
    """Local descent over the pieces of (4) from ``w_start``, each piece solved as one whole LP (:class:`PieceLP`).

    The route before :func:`piece_descent` (kept for measurement: ``nlp`` option ``piece_lps="whole"``).
    The first piece puts pair ``i`` on side ``S`` when its slack is relatively the smaller side,
    ``s^_i / max s^ <= z^_i / max z^`` (units of ``scaling``), and leaves ambiguous pairs free (module
    docstring).  Each round solves (PLP); when its minimiser is complementary, the biactive pairs (both
    sides ``<= ZERO_TOL``) are checked: if the piece's duals are feasible for (RLP), or (RLP) solved
    cold does not go below ``lam`` by more than ``LAM_TOL max(1, |lam|)``, the point is a certified local
    minimum; otherwise each biactive pair that (RLP) put on one side moves to it.
    ``interior``: None chooses by size (:func:`blockmpec.solvers.plan.piece_lp_whole_engine`).

    Returns
    -------
    PieceOutcome
        ``status`` ``LOCALLY_OPTIMAL`` (certified; ``w`` solves (3) exactly), ``ITERATION_LIMIT`` (``rounds``
        LPs without a certificate; ``w`` the best complementary point, if any), ``TIME_LIMIT``, or the
        failure of an LP (``w`` None when no complementary point was found).
    """
    interior = piece_lp_whole_engine(form.n_pairs) == "ipm" if interior is None else interior
    plp = PieceLP(form, scaling, deadline=deadline, interior=interior)
    z, s = plp.sides(np.asarray(w_start, float))
    zr, sr = relative_to_largest(z), relative_to_largest(s)
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
            slack_zero = np.where(free, relative_to_largest(s) <= relative_to_largest(z), slack_zero)
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


# ---------------------------------------------------------------------------------------------------------------
# The split piece LPs: (PLP) is a static LP in (lam, x) and a kinematic LP in (u, z), which no row couples.


def static_program(form) -> LinearProgram:
    """The static half of (PLP) over ``v = (lam, x)``: rows ``equilibrium`` ``A[eq] (lam, x) = rhs`` and
    ``pairs`` ``G x <= 0`` (a piece sets ``G_S x >= 0`` by row bounds); columns ``lam`` (0) and ``x``; no cost.

    The pair rows of (3) are nonzero in the ``x`` columns only and the equilibrium rows in ``(lam, x)`` only,
    so this LP and :func:`kinematic_program` together are (PLP) (``milp`` builds the same two for its polish).
    """
    from blockmpec.formulations.pyomo_compile import LinearProgram

    eq = form.equilibrium
    cols = np.r_[form.lam, np.arange(form.x.start, form.x.stop)]
    A = sp.csr_array(sp.vstack([form.A[eq][:, cols], form.G[:, cols]], format="csr"))
    n, p = cols.size, form.n_pairs
    n_eq = eq.stop - eq.start
    return LinearProgram(
        c=np.zeros(n), A=A, row_lower=np.r_[form.rhs[eq], np.full(p, -np.inf)],
        row_upper=np.r_[form.rhs[eq], np.zeros(p)], col_lower=np.full(n, -np.inf), col_upper=np.full(n, np.inf),
        columns={"lam": np.array([0]), "x": np.arange(1, n)},
        rows={"equilibrium": np.arange(n_eq), "pairs": np.arange(n_eq, n_eq + p)}, objective_sign=1.0)


def kinematic_program(form) -> LinearProgram:
    """The kinematic half of (PLP) over ``(u, z)``: rows ``compatibility`` ``A[cp] (u, z) = 0``, ``live``
    ``f_l^T u = 1`` and ``total`` ``1^T z`` (free unless a caller bounds it); ``z >= 0`` (a piece sets
    ``z_Z = 0`` by column bounds); no cost."""
    from blockmpec.formulations.pyomo_compile import LinearProgram

    cp, nm = form.compatibility, form.normalisation
    cols = np.r_[np.arange(form.u.start, form.u.stop), np.arange(form.z.start, form.z.stop)]
    nk, nu, p = cols.size, form.u.stop - form.u.start, form.n_pairs
    total = sp.csr_array(np.r_[np.zeros(nu), np.ones(p)].reshape(1, -1))
    A = sp.csr_array(sp.vstack([form.A[cp][:, cols], form.A[nm][:, cols], total], format="csr"))
    n_cp = cp.stop - cp.start
    return LinearProgram(
        c=np.zeros(nk), A=A, row_lower=np.r_[np.zeros(n_cp), 1.0, -np.inf], row_upper=np.r_[np.zeros(n_cp), 1.0, np.inf],
        col_lower=np.r_[np.full(nu, -np.inf), np.zeros(p)], col_upper=np.full(nk, np.inf),
        columns={"u": np.arange(nu), "z": np.arange(nu, nk)},
        rows={"compatibility": np.arange(n_cp), "live": np.array([n_cp]), "total": np.array([n_cp + 1])},
        objective_sign=1.0)


def static_piece(hl: HighsLP, slack_zero: np.ndarray, sense: float = 1.0, deadline: Deadline = NEVER):
    """``min sense * lam`` over the static half of the piece: ``G_i x = 0`` where ``slack_zero``, else ``<= 0``.

    ``hl`` is a :class:`~blockmpec.solvers.engines.highs.HighsLP` of :func:`static_program` (any scaling);
    re-solves are warm (dual simplex after a bound change).  Only HiGHS's model changes, not ``hl.lp``.  Returns its
    ``LPOutcome`` (``v = (lam, x)``, the row duals in HiGHS's signs), or None when ``deadline`` has passed.
    """
    lp = hl.lp
    rows = lp.rows["pairs"]
    hl.set_row_bounds(rows, np.where(slack_zero, 0.0, -np.inf), np.zeros(rows.size))
    cost = np.zeros(lp.c.size)
    cost[lp.columns["lam"][0]] = sense
    hl.set_costs(np.arange(cost.size), cost)
    if deadline.expired():
        return None
    return hl.solve(deadline=deadline)


def mechanism_piece(hl: HighsLP, allowed: np.ndarray, cost: np.ndarray | None = None, deadline: Deadline = NEVER):
    """A mechanism of the kinematic half of the piece: ``f_l^T u = 1``, ``z_i >= 0`` where ``allowed``, else 0.

    ``min cost^T z`` (default ``1^T z``, in the LP's units: the mechanism with the least total multiplier,
    a vertex, so with few active pairs).  ``hl`` is a ``HighsLP`` of :func:`kinematic_program`.  Returns its
    ``LPOutcome`` (``v = (u, z)``), or None when ``deadline`` has passed.
    """
    lp = hl.lp
    hl.set_row_bounds(lp.rows["live"], [1.0], [1.0])
    hl.set_row_bounds(lp.rows["total"], [-np.inf], [np.inf])
    zcols = lp.columns["z"]
    hl.set_column_bounds(zcols, np.zeros(zcols.size), np.where(allowed, np.inf, 0.0))
    c = np.zeros(lp.c.size)
    c[zcols] = 1.0 if cost is None else cost
    hl.set_costs(np.arange(c.size), c)
    if deadline.expired():
        return None
    return hl.solve(deadline=deadline)


def closed_interfaces(slack_zero: np.ndarray, pair_interface: np.ndarray, pair_kind: np.ndarray,
                      n_interfaces: int) -> np.ndarray:
    """Interfaces whose forces a piece fixes at zero: both no-tension rows, both friction rows or three rows
    ``G_i x = 0``.

    An interface's four pair rows bound a pointed cone in ``(t, n, m)``; two opposite facets (the two
    no-tension rows, or the two friction rows) or any three facets meet only at 0.
    """
    from blockmpec.formulations.compiled import FRICTION, UNILATERAL

    def count(kind=None):
        mask = slack_zero if kind is None else slack_zero & (pair_kind == kind)
        return np.bincount(pair_interface[mask], minlength=n_interfaces)

    return (count(UNILATERAL) >= 2) | (count(FRICTION) >= 2) | (count() >= 3)


def static_piece_ipm(lp: LinearProgram, slack_zero: np.ndarray, scaling: Scaling, deadline: Deadline, pair_interface: np.ndarray, pair_kind: np.ndarray, tol: float = 1e-9):
    """:func:`static_piece` (min ``lam``) by the block interior-point method (:mod:`~blockmpec.solvers.linalg.block_ipm`).

    An interior-point method needs a strictly feasible interior.  An interface that the piece closes
    (:func:`closed_interfaces`: its forces are 0) has none, so its columns and rows are left out (``x_k = 0``).
    The block IPM needs the same number of inequality rows in every interface, so the other equalities
    ``G_i x = 0`` are extra equality rows and every pair row stays an inequality, ``G_i x <= S_i`` (slack one
    unit, never active) on the piece's equalities and ``G_i x <= 0`` elsewhere.  ``lp`` is a
    :func:`static_program`, ``scaling`` its units (:class:`~blockmpec.solvers.engines.scaling.Scaling`).  Returns an ``LPOutcome`` in the terms of
    ``lp``: ``v = (lam, x)``; the dual of a pair row is the sum of its two rows' duals, and a closed
    interface's pair duals are the least-squares solution of its columns' stationarity (``<= 0`` on rows that
    are inequalities).  The point is not a vertex: it is near the analytic centre of the optimal face, exact to
    ``tol`` (relative residuals).
    """
    from scipy.optimize import lsq_linear

    from blockmpec.formulations.pyomo_compile import LinearProgram
    from blockmpec.solvers.engines.block_lp import BlockLP

    pairs = lp.rows["pairs"]
    eq_rows = lp.rows["equilibrium"]
    x_cols = lp.columns["x"].reshape(-1, 3)
    n_if = x_cols.shape[0]
    closed = closed_interfaces(slack_zero, pair_interface, pair_kind, n_if)
    open_pair = ~closed[pair_interface]
    keep_cols = np.r_[lp.columns["lam"], x_cols[~closed].ravel()]
    keep_pairs = pairs[open_pair]
    eq_pairs = pairs[slack_zero & open_pair]
    A = lp.A.tocsr()
    rows = np.r_[eq_rows, keep_pairs, eq_pairs]
    A_ipm = sp.csr_array(A[rows][:, keep_cols])
    p_unit = scaling.row_units(keep_pairs)  # S_i
    upper = np.r_[lp.row_upper[eq_rows], np.where(slack_zero[open_pair], p_unit, 0.0), np.zeros(eq_pairs.size)]
    lower = np.r_[lp.row_lower[eq_rows], np.full(keep_pairs.size, -np.inf), np.zeros(eq_pairs.size)]
    c = np.zeros(keep_cols.size)
    c[0] = 1.0
    n_keep = keep_cols.size
    ipm_lp = LinearProgram(c=c, A=A_ipm, row_lower=lower, row_upper=upper, col_lower=np.full(n_keep, -np.inf),
                           col_upper=np.full(n_keep, np.inf), columns={}, rows={}, objective_sign=1.0)
    ipm = BlockLP(ipm_lp, np.arange(1, n_keep).reshape(-1, 3), Scaling(scaling.row[rows], scaling.column[keep_cols]),
                  tol=tol, deadline=deadline.end, rules=BLOCK_IPM_RULES)
    out = ipm.solve()
    status = Status.OPTIMAL if out.status in (Status.OPTIMAL, Status.ACCEPTABLE) else out.status
    v = np.zeros(lp.c.size)
    y = np.zeros(lp.A.shape[0])
    if out.v.size == n_keep and np.all(np.isfinite(out.v)):
        v[keep_cols] = out.v
        n_eq, n_kp = eq_rows.size, keep_pairs.size
        y[eq_rows] = out.row_dual[:n_eq]
        y[keep_pairs] = out.row_dual[n_eq:n_eq + n_kp]
        y[eq_pairs] += out.row_dual[n_eq + n_kp:]
        # closed interfaces: G_k^T y_k = -(A_eq[:, k])^T w on their three columns (reduced costs zero)
        At = A.T.tocsr()
        target = -(At[:, eq_rows] @ y[eq_rows])
        for k in np.flatnonzero(closed):
            cols = x_cols[k]
            own = pairs[pair_interface == k]
            Gk = At[cols][:, own].toarray()  # (3, 4): columns are the pair rows
            free = slack_zero[pair_interface == k]
            sol = lsq_linear(Gk, target[cols], bounds=(np.full(own.size, -np.inf), np.where(free, np.inf, 0.0)))
            y[own] = sol.x
    objective = float(v[lp.columns["lam"][0]]) if status is Status.OPTIMAL else math.nan
    return LPOutcome(status, out.raw_status, objective, v, y, out.iterations, out.message)


#: a multiplier above this (units, in a mechanism LP's vertex) puts its pair's row among the static equalities
SUPPORT_TOL = 1e-12
#: the split certificate's tolerance on the static LP's dual feasibility and its primal rows (units)
DUAL_TOL = 1e-9
#: the same for the block IPM's static LPs (solved to relative residuals 1e-9, not to a vertex)
IPM_DUAL_TOL = 1e-7
#: static LP engines of the split pieces: HiGHS's dual simplex (a vertex, warm re-solves) or the block IPM
STATIC_ENGINES = ("auto", "dual-simplex", "block-ipm")
#: mechanism cost of a pair whose static equality raises lam (its dual, relative to the largest such dual,
#: times this, plus 1): a vertex then avoids those pairs where it can
AVOID_WEIGHT = 1e3
#: most cost per unit of relative start slack in the first mechanism LP (pairs whose start slack is not ~0 are
#: avoided where a mechanism can do without them)
START_SLACK_WEIGHT = 1e3


@dataclass
class Certificate:
    """The split certificate of a point ``w`` of (4): is ``(lam, x)`` optimal for (RLP) at ``w``?

    ``support``: pairs with ``z_i > 0`` (their rows must be equalities); ``stationarity``: largest reduced
    cost of the static LP's (free) columns, in units; ``wrong_signs``: pair rows off the support whose dual
    is positive (relaxing ``G_i x = 0`` to ``<= 0`` would lower ``lam``); ``complementarity``: largest slack
    on the support and ``primal``: largest pair violation (units); ``lam_gap``: ``|lam(w) - the LP's optimum|``
    relative to ``max(1, |lam|)``.  ``holds`` when all five are within tolerance.
    """

    holds: bool
    support: int
    biactive: int
    stationarity: float
    wrong_signs: int
    complementarity: float
    primal: float
    lam_gap: float = 0.0


class SplitPieces:
    """The two halves of (PLP) as two HiGHS models, re-solved warm: :func:`static_piece` and :func:`mechanism_piece`.

    ``form``, the units ``scaling`` and ``deadline`` are those of :class:`PieceLP`;
    ``static_engine="auto"`` is :func:`blockmpec.solvers.plan.piece_lp_static_engine`.
    """

    def __init__(self, form, scaling: MCPScaling, deadline: Deadline = NEVER, static_engine: str = "auto") -> None:
        if static_engine not in STATIC_ENGINES:
            raise ValueError(f"static_engine must be one of {STATIC_ENGINES}; got {static_engine!r}")
        if static_engine == "auto":
            static_engine = piece_lp_static_engine(form.n_pairs)
        self.static_engine = static_engine
        interior = static_engine == "block-ipm"
        #: a slack or multiplier counts as zero at most this (units); the certificate's tolerance
        self.zero_tol = ZERO_TOL[interior]
        self.dual_tol = IPM_DUAL_TOL if interior else DUAL_TOL
        self.lam_tol = LAM_TOL[interior]

        self.form = form
        eq, cp, nm = form.equilibrium, form.compatibility, form.normalisation
        s_cols = np.r_[form.lam, np.arange(form.x.start, form.x.stop)]
        k_cols = np.r_[np.arange(form.u.start, form.u.stop), np.arange(form.z.start, form.z.stop)]
        self.s_cols, self.k_cols = s_cols, k_cols
        self.z_unit = scaling.column[form.pair_column]
        self.s_unit = scaling.slack
        self.static = HighsLP(static_program(form), "dual-simplex", scaling=scaling.lp_scaling(np.r_[eq], s_cols))
        self.kinematic = HighsLP(kinematic_program(form), "dual-simplex",
                                 scaling=scaling.lp_scaling(np.r_[cp, nm], k_cols, pair_rows=False, ones=1))
        # HiGHS's default primal feasibility tolerance (1e-7 in units) left the compatibility rows of the 2,032-block
        # wall's mechanism at 8.8e-7 relative in the verifier (tolerance 1e-6); 1e-10 there: 3e-11 (one run)
        self.kinematic.set_feasibility_tolerances(primal=MECHANISM_FEASIBILITY_TOL)
        self.deadline = deadline
        self.lp_solves = 0
        self.lp_time_s = 0.0
        self.static_time_s = 0.0
        self.kinematic_time_s = 0.0

    def sides(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(z^, s^)``: the pair multipliers and slacks of ``w`` in units (negative parts cut)."""
        z = np.maximum(w[self.form.pair_column], 0.0) / self.z_unit
        s = np.maximum(-(self.form.G @ w), 0.0) / self.s_unit
        return z, s

    def _timed(self, solve, kind: str):
        t0 = time.perf_counter()
        out = solve()
        dt = time.perf_counter() - t0
        self.lp_time_s += dt
        setattr(self, f"{kind}_time_s", getattr(self, f"{kind}_time_s") + dt)
        if out is not None:
            self.lp_solves += 1
        return out

    def static_lp(self, slack_zero: np.ndarray):
        """:func:`static_piece` (min ``lam``) on this structure's static LP; None past the deadline."""
        if self.static_engine == "block-ipm":
            if self.deadline.expired():
                return None
            form = self.form
            return self._timed(lambda: static_piece_ipm(self.static.lp, slack_zero, self.static.scaling,
                                                        self.deadline, form.pair_interface,
                                                        form.pair_kind), "static")
        return self._timed(lambda: static_piece(self.static, slack_zero, deadline=self.deadline), "static")

    def mechanism(self, allowed: np.ndarray, weight: np.ndarray | None = None):
        """:func:`mechanism_piece` with cost ``weight`` per unit multiplier ``z^_i`` (default 1); None past the deadline."""
        cost = (np.ones(allowed.size) if weight is None else weight) / self.z_unit
        return self._timed(lambda: mechanism_piece(self.kinematic, allowed, cost, deadline=self.deadline), "kinematic")

    def point(self, static_out, mechanism_out) -> np.ndarray:
        """``w`` from the two halves; multipliers at most :data:`SUPPORT_TOL` (units) set to exact zeros."""
        form = self.form
        w = np.zeros(form.n_columns)
        w[self.s_cols] = static_out.v
        w[self.k_cols] = mechanism_out.v
        z = w[form.pair_column]
        w[form.pair_column] = np.where(z / self.z_unit > SUPPORT_TOL, z, 0.0)
        return w

    def support(self, mechanism_out) -> np.ndarray:
        """Pairs whose multiplier in the mechanism LP's point exceeds :data:`SUPPORT_TOL` (units)."""
        z = self.kinematic.lp.values("z", mechanism_out.v)
        return z / self.z_unit > SUPPORT_TOL

    def certificate(self, w: np.ndarray, static_out, tol: float | None = None) -> Certificate:
        """Check that ``(lam, x)`` of ``w`` with the static LP's row duals certifies ``w`` a local minimum of (4).

        Near ``w`` a pair with ``z_i > 0`` keeps ``s_i = 0``; every other pair may take any ``s_i >= 0`` with
        ``z_i = 0`` and ``(u, z)`` unchanged.  So (RLP) at ``w`` is ``min lam`` s.t. equilibrium,
        ``G_i x = 0`` on the support of ``z``, ``G_i x <= 0`` elsewhere (its kinematic half is feasible, with no
        cost), and ``w`` is a local minimum of (4) iff ``(lam, x)`` is optimal for it: the duals ``y`` (HiGHS's
        signs) must make the reduced costs ``c - A^T y`` of the free columns zero and ``y_i <= 0`` on every pair
        row off the support, and ``lam`` of ``w`` must be the optimum of ``static_out``, whose duals they are.  The support is read from ``w`` itself, not from the piece the LP was solved on: a
        point solved with an equality on a pair whose multiplier is zero fails when that row's dual is positive.
        """
        form, lp = self.form, self.static.lp
        tol = self.dual_tol if tol is None else tol
        z, s = self.sides(w)
        on = z > 0
        y = static_out.row_dual
        c = np.zeros(lp.c.size)
        c[lp.columns["lam"][0]] = 1.0  # min lam
        reduced = self.static.scaling.costs(np.arange(c.size), c - lp.A.T @ y)  # in units
        pair_dual = y[lp.rows["pairs"]] * self.s_unit  # dual of the row (G_i x) / S_i
        wrong = int(np.sum(~on & (pair_dual > tol)))
        g = (form.G @ w) / self.s_unit  # pair rows in units (<= 0 when admissible)
        primal = float(np.max(g, initial=0.0))
        comp = float(np.max(s[on], initial=0.0))
        stationarity = float(np.max(np.abs(reduced), initial=0.0)) if np.all(np.isfinite(reduced)) else math.inf
        # the duals certify the LP's optimum: lam of w must be that optimum
        lam, lam_lp = float(w[form.lam]), float(static_out.objective)
        lam_gap = abs(lam - lam_lp) / max(1.0, abs(lam)) if math.isfinite(lam_lp) else math.inf
        holds = stationarity <= tol and wrong == 0 and comp <= tol and primal <= tol and lam_gap <= self.lam_tol
        return Certificate(holds, int(on.sum()), int(np.sum(~on & (s <= tol))), stationarity, wrong, comp, primal,
                           lam_gap)


def piece_descent(form, scaling, w_start: np.ndarray, deadline: Deadline = NEVER, rounds: int = 10,
                  static_engine: str = "auto") -> PieceOutcome:
    """Local descent over the pieces of (4) from ``w_start``, each piece's LP solved as its two halves.

    1. A mechanism (:func:`mechanism_piece`) on the pairs that may carry a multiplier at the start: those
       whose slack is relatively the smaller side or ambiguous (:data:`AMBIGUOUS`, the same rounding as
       :func:`whole_piece_descent`), each multiplier costing ``1 + START_SLACK_WEIGHT * s^_i / max s^`` (a
       vertex, few active pairs, avoiding pairs whose start slack is not ~0).
    2. The static LP (:func:`static_piece`) with ``G_i x = 0`` exactly on that mechanism's support: its
       minimiser with the mechanism solves (3) (``z_i = 0`` off the support), and the static LP *is* the
       relaxed LP (RLP) at that point (:meth:`SplitPieces.certificate`), so its duals certify it a local minimum
       of (4); the certificate is checked, not assumed.
    3. Descent: a support pair whose row dual is positive would lower ``lam`` if its multiplier could vanish.
       A new mechanism on the pairs with zero slack at the current ``x`` (so the current ``(lam, x)`` stays
       feasible and ``lam`` cannot rise), costing those pairs ``1 + AVOID_WEIGHT * dual / max dual``; when
       its support differs, the static LP on it is the next point (kept if ``lam`` fell).  At most ``rounds``
       mechanisms; stops when no support pair has a positive dual or the mechanism keeps its support.

    Returns
    -------
    PieceOutcome
        ``LOCALLY_OPTIMAL`` when the best point's certificate holds (``w`` solves (3) exactly);
        ``NUMERICAL`` with that point when its certificate fails; ``TIME_LIMIT``; or, with ``w`` None, the
        failure of the first LPs (no mechanism or an empty static piece for every rounding).
    """
    pieces = SplitPieces(form, scaling, deadline=deadline, static_engine=static_engine)
    z, s = pieces.sides(np.asarray(w_start, float))
    zr, sr = relative_to_largest(z), relative_to_largest(s)
    trace: list[dict] = []
    first = None
    message = ""
    for ambiguous in AMBIGUOUS:
        allowed = (sr <= zr) | (np.minimum(zr, sr) > ambiguous * np.maximum(zr, sr)) | (np.maximum(zr, sr) < 1e-12)
        mech = pieces.mechanism(allowed, 1.0 + START_SLACK_WEIGHT * sr)
        if mech is None or mech.status is Status.TIME_LIMIT:
            return _outcome(Status.TIME_LIMIT, None, None, pieces, trace, "time limit in the first mechanism LP")
        if mech.status is not Status.OPTIMAL:
            message = f"mechanism LP (ambiguous {ambiguous:g}): HiGHS {mech.raw_status}"
            trace.append({"piece": len(trace) + 1, "lp": "mechanism", "status": mech.raw_status,
                          "allowed": int(allowed.sum())})
            continue
        support = pieces.support(mech)
        st = pieces.static_lp(support)
        if st is None or st.status is Status.TIME_LIMIT:
            return _outcome(Status.TIME_LIMIT, None, None, pieces, trace, "time limit in the first static LP")
        trace.append({"piece": len(trace) + 1, "lp": "static", "status": st.raw_status, "multiplier": st.objective,
                      "allowed": int(allowed.sum()), "support": int(support.sum())})
        if st.status is Status.OPTIMAL:
            first = (mech, st, support)
            break
        message = f"static LP on the mechanism's support (ambiguous {ambiguous:g}): HiGHS {st.raw_status}"
    if first is None:
        return _outcome(Status.NUMERICAL, None, None, pieces, trace, f"no solution of (3) from the start: {message}")
    mech, st, support = first
    best_w, best_st = pieces.point(st, mech), st
    status, message = Status.ITERATION_LIMIT, f"{rounds} mechanisms without a stationary support"
    for k in range(rounds):
        lam = best_st.objective
        y = best_st.row_dual[pieces.static.lp.rows["pairs"]] * pieces.s_unit
        raising = support & (y > pieces.dual_tol)
        trace[-1]["raising"] = int(raising.sum())
        if not raising.any():
            status, message = Status.LOCALLY_OPTIMAL, f"lam = {lam:.10g}: no equality of the support raises lam"
            break
        _, s_now = pieces.sides(best_w)
        weight = 1.0 + AVOID_WEIGHT * np.where(raising, y, 0.0) / float(y[raising].max())
        mech2 = pieces.mechanism(s_now <= pieces.zero_tol, weight)
        if mech2 is None or mech2.status is Status.TIME_LIMIT:
            status, message = Status.TIME_LIMIT, f"time limit in mechanism LP {k + 2}"
            break
        if mech2.status is not Status.OPTIMAL:  # the current mechanism is feasible for it: round-off
            status, message = Status.LOCALLY_OPTIMAL, f"lam = {lam:.10g}; mechanism LP {k + 2}: HiGHS {mech2.raw_status}"
            break
        support2 = pieces.support(mech2)
        if np.array_equal(support2, support) or not (raising & ~support2).any():
            status, message = Status.LOCALLY_OPTIMAL, (f"lam = {lam:.10g}: no mechanism on the zero slacks frees a "
                                                       f"pair whose equality raises lam")
            break
        st2 = pieces.static_lp(support2)
        if st2 is None or st2.status is Status.TIME_LIMIT:
            status, message = Status.TIME_LIMIT, f"time limit in static LP {k + 2}"
            break
        trace.append({"piece": len(trace) + 1, "lp": "static", "status": st2.raw_status, "multiplier": st2.objective,
                      "allowed": int((s_now <= pieces.zero_tol).sum()), "support": int(support2.sum())})
        if st2.status is not Status.OPTIMAL or st2.objective > lam - pieces.lam_tol * max(1.0, abs(lam)):
            status, message = Status.LOCALLY_OPTIMAL, f"lam = {lam:.10g}: the next support does not lower lam"
            break
        best_w, best_st, support = pieces.point(st2, mech2), st2, support2
    # the certificate: the best point with its own static LP's duals (kept with the outcome)
    cert = pieces.certificate(best_w, best_st)
    trace[-1].update(certificate=cert.holds, stationarity=cert.stationarity, wrong_dual_signs=cert.wrong_signs,
                     biactive=cert.biactive)
    if cert.holds:  # also when a later mechanism or static LP ran out of time: the best point is certified
        return _outcome(Status.LOCALLY_OPTIMAL, best_w, best_st.objective, pieces, trace,
                        f"{message}; certified local minimum of (4) (the static LP's duals are feasible for the relaxed "
                        f"LP over its {cert.biactive} biactive pairs)", cert)
    if status is Status.TIME_LIMIT:
        return _outcome(status, best_w, best_st.objective, pieces, trace, message, cert)
    return _outcome(Status.NUMERICAL, best_w, best_st.objective, pieces, trace,
                    f"{message}; certificate failed (stationarity {cert.stationarity:.1e}, {cert.wrong_signs} wrong "
                    f"dual signs, complementarity {cert.complementarity:.1e}, primal {cert.primal:.1e})", cert)


def _outcome(status: Status, w, lam, pieces: SplitPieces, trace: list[dict], message: str,
             cert: Certificate | None = None) -> PieceOutcome:
    return PieceOutcome(status, w, math.inf if lam is None else float(lam), status is Status.LOCALLY_OPTIMAL,
                        len(trace), pieces.lp_solves, pieces.lp_time_s, 0 if cert is None else cert.biactive, message,
                        trace, pieces.static_time_s, pieces.kinematic_time_s, cert)

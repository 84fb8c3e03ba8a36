r"""The LP loop shared by ``fixed-point`` and ``slp``: a sequence of modified associative LPs.

Step LP at given normal forces ``n*`` (one ``<=`` row pair per interface ``k``)::

    max  lam
    s.t. E x + f_d + lam f_l = 0,   N_u^T x <= 0,
         |t_k| <= -s_k n_k - (tan(phi_k) - s_k) n*_k          (friction rows)

with slope ``s = tan(psi) + alpha (tan(phi) - tan(psi))``.  ``alpha = 0`` is the
modified LP (5) of the fixed-point method; ``alpha > 0`` tilts the surface towards
Coulomb's (the SLP of Gilbert et al.).  At ``n = n*`` the right-hand side equals
``-tan(phi) n*``: every such surface passes through the Coulomb point at ``n*``.

Persistence: the step LP is built (Pyomo), compiled and loaded into HiGHS once;
a new ``n*`` changes only the friction rows' upper bounds (``set_row_upper``) and
the next solve starts from the previous basis.

Mechanism: the duals of the step LP give ``u = -y_eq``, ``z_u = -y_uni``,
``z_f = -y_fric`` with ``E^T u + N_u z_u + N_s z_f = 0`` and ``f_l^T u = 1``, where
``N_s`` is the friction operator with slope ``s`` (``= V_f`` when ``alpha = 0``).

Tie-break (``tie_break="closest"``): the step LP's optimal forces need not be
unique; a second persistent LP picks, among (numerically) optimal points, the one
closest to ``n*`` in the 1-norm::

    min  sum_k d_k
    s.t. the step LP's constraints (same n*),  lam >= lam* - delta,
         n_k - d_k <= n*_k,   -n_k - d_k <= -n*_k,   d >= 0

with ``lam*`` the step LP's optimum and ``delta = 1e-10 max(1, |lam*|)``.  Any optimal
primal point and any optimal dual point of an LP are complementary, so the duals
of the step LP and ``x`` of the tie-break LP form a consistent pair.  The
tie-break only changes row upper bounds between iterations too, so it is warm.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from blockmpec.operators import Operators, normal
from blockmpec.result import Solution, Status
from blockmpec.solver import RunOutput
from blockmpec.verify import positive_part_ratio
from blockmpec.solvers.engines.highs import static_lp_solution

TIE_BREAKS = ("closest", "none")
STARTS = ("associative", "zero")


def tie_break_delta(lam: float) -> float:
    """How far below the step LP's optimum the tie-break LP may let ``lam`` go."""
    return 1e-10 * max(1.0, abs(lam))


@dataclass
class Step:
    """One step of the sequence: the LP outcome at a given ``n*``."""

    status: Status
    raw_status: str
    message: str
    solution: Solution = field(default_factory=Solution)
    lp_iterations: int = 0
    tie_break_used: bool = False


class LPSequence:
    """Persistent HiGHS LPs for the modified associative LPs at varying ``n*``.

    Parameters
    ----------
    ops : Operators
    alpha : float
        Tilt of the friction surface (0: eq. (5)).
    tie_break : {"closest", "none"}
    algorithm : str
        HiGHS algorithm (see :data:`blockmpec.solvers.engines.highs.ALGORITHMS`).
    need_associative : bool
        Also compile the associative static LP (1), for the ``"associative"`` start.
    feasibility_tol : float
        HiGHS primal and dual feasibility tolerances (HiGHS default 1e-7).  The
        sequence feeds each LP's forces into the next one, and light interfaces
        (top courses) have forces ~1, so 1e-7 absolute row violations show as
        ~1e-7 relative interface violations; 1e-9 keeps them well below.
    """

    def __init__(self, ops: Operators, alpha: float = 0.0, tie_break: str = "closest",
                 algorithm: str = "auto", need_associative: bool = True, feasibility_tol: float = 1e-9) -> None:
        import pyomo.environ as pyo

        from blockmpec.formulations import compile_linear, static_lp
        from blockmpec.solvers.engines.highs import HighsLP

        self.ops = ops
        c = ops.n_interfaces
        self.slope = ops.dilatancy + alpha * (ops.friction - ops.dilatancy)
        self.cohesion_factor = ops.friction - self.slope  # cohesion_k = -factor_k n*_k
        self.lp_solves = 0
        self.lp_time_s = {"associative": 0.0, "step": 0.0, "tie_break": 0.0}
        self.alpha = float(alpha)
        self._step_cold = True  # the next step LP solve is its first
        self._tie_cold = True

        step = static_lp(ops, friction=self.slope, cohesion=np.zeros(c), name="modified-lp")
        self.step_lp = compile_linear(step)
        self.step_highs = HighsLP(self.step_lp, algorithm, **_scales(self.step_lp, ops))

        self.tie_lp = None
        self.tie_highs = None
        if tie_break == "closest":
            tie = static_lp(ops, friction=self.slope, cohesion=np.zeros(c), name="tie-break-lp")
            m = tie.model
            m.objective.deactivate()
            m.n_star = pyo.Param(range(c), mutable=True, initialize=0.0)
            m.lam_floor = pyo.Param(mutable=True, initialize=-1e30)
            m.d = pyo.Var(range(c), within=pyo.NonNegativeReals)
            m.deviation_up = pyo.Constraint(range(c), rule=lambda mm, k: mm.x[3 * k + 1] - mm.d[k] <= mm.n_star[k])
            m.deviation_down = pyo.Constraint(range(c), rule=lambda mm, k: -mm.x[3 * k + 1] - mm.d[k] <= -mm.n_star[k])
            m.floor = pyo.Constraint(expr=-m.lam <= -m.lam_floor)
            m.tie_objective = pyo.Objective(expr=sum(m.d.values()), sense=pyo.minimize)
            tie.variables["d"] = list(m.d.values())
            tie.constraints["deviation_up"] = list(m.deviation_up.values())
            tie.constraints["deviation_down"] = list(m.deviation_down.values())
            tie.constraints["floor"] = [m.floor]
            self.tie_lp = compile_linear(tie)
            row = int(self.tie_lp.rows["floor"][0])
            col = int(self.tie_lp.columns["lam"][0])
            a = self.tie_lp.A[[row], :].toarray().ravel()
            if not (a[col] == -1.0 and np.count_nonzero(a) == 1 and np.isfinite(self.tie_lp.row_upper[row])):
                raise RuntimeError("tie-break LP: the floor row did not compile to -lam <= -lam_floor")
            self.tie_highs = HighsLP(self.tie_lp, algorithm, **_scales(self.tie_lp, ops, ("d",)))

        self.assoc_lp = None
        self.assoc_highs = None
        if need_associative:
            self.assoc_lp = compile_linear(static_lp(ops))
            self.assoc_highs = HighsLP(self.assoc_lp, algorithm, **_scales(self.assoc_lp, ops))
        for highs in (self.step_highs, self.tie_highs, self.assoc_highs):
            if highs is not None:
                highs.highs.setOptionValue("primal_feasibility_tolerance", float(feasibility_tol))
                highs.highs.setOptionValue("dual_feasibility_tolerance", float(feasibility_tol))

    # ------------------------------------------------------------------ warm starts
    def _start_from_associative_basis(self) -> str | None:
        """Give the first step LP the associative LP's optimal basis (it is primal feasible).

        With ``n* = n_assoc`` the step LP's friction rows
        ``+-t + tan(psi) n <= -(tan(phi) - tan(psi)) n*`` are active at ``x_assoc`` exactly
        where the associative rows ``+-t + tan(phi) n <= 0`` are, so the associative
        basis describes the same (feasible) vertex: primal simplex starts from it instead
        of a cold solve.  Returns the algorithm for that solve, or None (basis refused).
        """
        statuses = self.assoc_highs.basis_status()
        if statuses is None:
            return None
        col, row = _map_basis(self.assoc_lp, self.step_lp, *statuses, ("x", "lam"),
                              ("equilibrium", "unilateral", "friction"))
        return "primal-simplex" if self.step_highs.set_basis(col, row) else None

    def _start_tie_break_from_step_basis(self, n: np.ndarray, n_star: np.ndarray) -> str | None:
        """Give the first tie-break LP the step LP's basis, extended to a primal feasible one.

        The step LP's optimal vertex with ``d_k = |n_k - n*_k|`` is feasible for the
        tie-break LP: ``d_k`` basic, the deviation row that holds ``d_k`` nonbasic at its
        bound, the other deviation row and the ``lam`` floor basic (``2c + 1`` new basic
        variables for ``2c + 1`` new rows).
        """
        statuses = self.step_highs.basis_status()
        if statuses is None:
            return None
        tie = self.tie_lp
        col, row = _map_basis(self.step_lp, tie, *statuses, ("x", "lam"), ("equilibrium", "unilateral", "friction"))
        col[tie.columns["d"]] = BASIC
        up_tight = n >= n_star  # d = n - n*: row n - d <= n* holds d
        row[tie.rows["deviation_up"]] = np.where(up_tight, AT_UPPER, BASIC)
        row[tie.rows["deviation_down"]] = np.where(up_tight, BASIC, AT_UPPER)
        row[tie.rows["floor"]] = BASIC
        return "primal-simplex" if self.tie_highs.set_basis(col, row) else None

    # ------------------------------------------------------------------ helpers
    def _timed(self, kind: str, solve, *args):
        t0 = time.perf_counter()
        out = solve(*args)
        self.lp_time_s[kind] += time.perf_counter() - t0
        self.lp_solves += 1
        return out

    def facts(self) -> dict[str, Any]:
        """LP solves so far and seconds spent per LP kind (associative start, step, tie-break)."""
        return {"lp_solves": self.lp_solves, "lp_time_s": {k: round(v, 6) for k, v in self.lp_time_s.items()}}

    def _set_time_limit(self, highs, deadline: float) -> bool:
        remaining = deadline - time.perf_counter()
        if remaining <= 0:
            return False
        if np.isfinite(remaining):
            # HiGHS compares time_limit with the instance's cumulative run clock
            highs.highs.setOptionValue("time_limit", float(highs.highs.getRunTime() + remaining))
        return True

    def associative(self, deadline: float = float("inf")) -> Step:
        """Solve the associative static LP (1) (the ``"associative"`` start)."""
        if self.assoc_highs is None:
            raise RuntimeError("the associative LP was not compiled")
        if not self._set_time_limit(self.assoc_highs, deadline):
            return Step(Status.TIME_LIMIT, "", "time limit reached before the associative LP")
        out = self._timed("associative", self.assoc_highs.solve)
        if out.status is not Status.OPTIMAL:
            return Step(out.status, out.raw_status, f"associative start LP: {out.message}",
                        lp_iterations=out.iterations)
        return Step(Status.OPTIMAL, out.raw_status, out.message, static_lp_solution(self.assoc_lp, out), out.iterations)

    def step(self, n_star: np.ndarray, deadline: float = float("inf")) -> Step:
        """Solve the step LP at ``n_star`` (then the tie-break LP if enabled).

        ``n_star`` must be compressive (``<= 0``); :func:`run_sequence` clips it.
        """
        cohesion = -self.cohesion_factor * n_star
        rhs = np.repeat(cohesion, 2)  # rows 2k, 2k+1 of interface k
        lp = self.step_lp
        self.step_highs.set_row_upper(lp.rows["friction"], rhs)
        if not self._set_time_limit(self.step_highs, deadline):
            return Step(Status.TIME_LIMIT, "", "time limit reached before a step LP")
        first_algorithm = None
        if self._step_cold and self.assoc_highs is not None and self.alpha == 0.0:
            first_algorithm = self._start_from_associative_basis()
        self._step_cold = False
        out = self._timed("step", self.step_highs.solve, first_algorithm)
        if out.status is not Status.OPTIMAL:
            return Step(out.status, out.raw_status, f"modified LP: {out.message}", lp_iterations=out.iterations)
        sol = static_lp_solution(lp, out)
        iterations = out.iterations
        if self.tie_highs is None:
            return Step(Status.OPTIMAL, out.raw_status, out.message, sol, iterations)

        tie = self.tie_lp
        self.tie_highs.set_row_upper(tie.rows["friction"], rhs)
        self.tie_highs.set_row_upper(tie.rows["deviation_up"], n_star)
        self.tie_highs.set_row_upper(tie.rows["deviation_down"], -n_star)
        lam = sol.multiplier
        self.tie_highs.set_row_upper(tie.rows["floor"], np.array([-(lam - tie_break_delta(lam))]))
        if not self._set_time_limit(self.tie_highs, deadline):
            return Step(Status.TIME_LIMIT, "", "time limit reached before a tie-break LP", sol, iterations)
        first_algorithm = self._start_tie_break_from_step_basis(normal(sol.x), n_star) if self._tie_cold else None
        self._tie_cold = False
        tout = self._timed("tie_break", self.tie_highs.solve, first_algorithm)
        iterations += tout.iterations
        if tout.status is not Status.OPTIMAL:
            # keep the step LP's own point; the caller records the failure
            return Step(Status.OPTIMAL, out.raw_status, f"tie-break LP: {tout.message}", sol, iterations, False)
        sol.x = tie.values("x", tout.v)
        sol.multiplier = float(tie.values("lam", tout.v)[0])
        return Step(Status.OPTIMAL, out.raw_status, out.message, sol, iterations, True)


def _scales(lp, ops, normal_like=()) -> dict:
    """HiGHS works in load units (:mod:`blockmpec.solvers.engines.scaling`): each block's tolerances its own."""
    from blockmpec.solvers.engines.scaling import load_scaling

    row_scale, column_scale = load_scaling(lp, ops, normal_like)
    return {"row_scale": row_scale, "column_scale": column_scale}


#: highspy.HighsBasisStatus values
AT_LOWER, BASIC, AT_UPPER = 0, 1, 2


def _map_basis(src, dst, col_status, row_status, column_groups, row_groups):
    """Basis statuses of ``src`` carried to ``dst`` through named column and row groups.

    Entries of ``dst`` outside the groups are left ``AT_LOWER`` (the caller sets them).
    """
    col = np.full(dst.c.size, AT_LOWER)
    row = np.full(dst.A.shape[0], AT_LOWER)
    for g in column_groups:
        src_cols, dst_cols = src.columns[g], dst.columns[g]
        keep = (src_cols >= 0) & (dst_cols >= 0)
        col[dst_cols[keep]] = col_status[src_cols[keep]]
    for g in row_groups:
        row[dst.rows[g]] = row_status[src.rows[g]]
    return col, row


def run_sequence(
    seq: LPSequence,
    *,
    start: str,
    relaxation: float,
    stop_on: str,
    tol: float,
    max_iterations: int,
    time_limit: float,
    min_iterations: int = 1,
) -> tuple[RunOutput, dict[str, Any]]:
    r"""Iterate ``n* -> LP step -> n``, ``n* <- min(n* + relaxation (n - n*), 0)``.

    ``n*`` is kept compressive (``<= 0``, as the unilateral rows make every ``n``):
    a round-off tension of the size of the LP feasibility tolerance would otherwise
    give a negative cohesion and could make the next step LP infeasible.

    Parameters
    ----------
    seq : LPSequence
    start : {"associative", "zero"}
        ``n*`` of the first step: normal forces of the associative LP (1), or 0.
    relaxation : float in (0, 1]
    stop_on : {"normal", "multiplier"}
        ``"normal"``: stop when ``||n - n*|| <= tol ||n||`` (fixed point);
        ``"multiplier"``: stop when ``|lam_k - lam_{k-1}| <= tol`` and ``k >= min_iterations``.
    tol : float
    max_iterations : int
    time_limit : float
        Seconds for the whole loop (the associative start included).
    min_iterations : int
        Fewest step LPs before the stopping test may succeed.

    Returns
    -------
    RunOutput, dict
        The run output (status CONVERGED, ITERATION_LIMIT, TIME_LIMIT, or the LP's
        failure status) and a dict of loop facts (``stopped_by``, ``lam_start``).
    """
    t0 = time.perf_counter()
    deadline = t0 + time_limit
    ops = seq.ops
    trace: list[dict[str, Any]] = []
    facts: dict[str, Any] = {"lam_start": None, "tie_break_failures": 0}
    if start == "associative":
        first = seq.associative(deadline)
        if first.status is not Status.OPTIMAL:
            return RunOutput(first.status, Solution(), 0, trace, first.message, first.raw_status,
                             extra=seq.facts()), facts
        n_star = np.minimum(normal(first.solution.x), 0.0)
        facts["lam_start"] = first.solution.multiplier
    else:
        n_star = np.zeros(ops.n_interfaces)

    last: Solution | None = None
    lam_prev: float | None = None
    raw = ""
    for k in range(1, max_iterations + 1):
        step = seq.step(n_star, deadline)
        raw = step.raw_status
        if step.status is not Status.OPTIMAL:
            status = step.status
            msg = f"iteration {k}: {step.message}"
            if status is Status.TIME_LIMIT:
                msg = f"time limit {time_limit:g} s reached at iteration {k}; returning the last iterate"
            sol = last if last is not None else Solution()
            return RunOutput(status, sol, k - 1, trace, msg, raw, extra=seq.facts()), facts
        if seq.tie_highs is not None and not step.tie_break_used:
            facts["tie_break_failures"] += 1
        sol = step.solution
        n = normal(sol.x)
        n_norm = float(np.linalg.norm(n))
        n_change = float(np.linalg.norm(n - n_star)) / n_norm if n_norm > 0 else float(np.linalg.norm(n - n_star))
        lam = float(sol.multiplier)
        lam_change = None if lam_prev is None else abs(lam - lam_prev)
        trace.append({
            "iteration": k,
            "time_s": time.perf_counter() - t0,
            "multiplier": lam,
            "n_change": n_change,
            "lam_change": lam_change,
            "friction_admissibility": positive_part_ratio(ops.N_f.T @ sol.x),
            "lp_iterations": step.lp_iterations,
        })
        last = sol
        if stop_on == "normal":
            done = n_change <= tol and k >= min_iterations
        else:
            done = lam_prev is not None and lam_change <= tol and k >= min_iterations
        if done:
            return RunOutput(Status.CONVERGED, sol, k, trace, "", raw, extra=seq.facts()), facts
        lam_prev = lam
        # normal forces are compressive; round-off tension (within the LP's feasibility
        # tolerance) would give a negative cohesion and can make the next LP infeasible
        n_star = np.minimum(n_star + relaxation * (n - n_star), 0.0)
        if time.perf_counter() >= deadline:
            return RunOutput(Status.TIME_LIMIT, sol, k, trace,
                             f"time limit {time_limit:g} s reached after iteration {k}; returning the last iterate",
                             raw, extra=seq.facts()), facts
    return RunOutput(Status.ITERATION_LIMIT, last if last is not None else Solution(), max_iterations, trace,
                     f"no convergence in {max_iterations} iterations; returning the last iterate", raw,
                     extra=seq.facts()), facts

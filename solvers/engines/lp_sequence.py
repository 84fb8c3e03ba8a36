r"""The LP loop shared by ``fixed-point`` and ``slp``: a sequence of modified associative LPs.

Step LP at given normal forces ``n*`` (:func:`blockmpec.formulations.modified_lp`)::

    max  lam
    s.t. E x + f_d + lam f_l = 0,   N_u^T x <= 0,
         |t_k| <= -s_k n_k - (tan(phi_k) - s_k) n*_k          (friction rows)

with slope ``s = tan(psi) + alpha (tan(phi) - tan(psi))``.  ``alpha = 0`` is the
modified LP (5) of the fixed-point method; ``alpha > 0`` tilts the surface towards
Coulomb's (the SLP of Gilbert et al.).  At ``n = n*`` the right-hand side equals
``-tan(phi) n*``: every such surface passes through the Coulomb point at ``n*``.

Mechanism: the duals of the step LP give ``u = -y_eq``, ``z_u = -y_uni``,
``z_f = -y_fric`` with ``E^T u + N_u z_u + N_s z_f = 0`` and ``f_l^T u = 1``, where
``N_s`` is the friction operator with slope ``s`` (``= V_f`` when ``alpha = 0``).

Tie-break: the step LP's optimal forces need not be unique; a second LP
(:func:`blockmpec.formulations.tie_break_lp`) keeps ``lam >= lam* - delta``
(``delta = 1e-10 max(1, |lam*|)``) and picks one optimal point by its objective
``sum_k w_k |n_k - n*_k| + sum_k c_k n_k``.  Rules (:data:`TIE_BREAKS`):

* ``"closest"``: ``w = 1, c = 0``: the optimal forces closest to ``n*`` (1-norm).
  Once ``n*`` is optimal for its own LP, ``F(n*) = n*`` exactly.
* ``"least-compressed"``: ``c_k = -(tan(phi_k) - s_k)``, ``w = 1e-3``: the optimal
  forces with the smallest total next-step cohesion ``-sum (tan(phi) - s) n``, which
  can only lower the next step's ``lam``; closeness breaks the remaining ties.
* ``"min-lambda"``: ``c_k = -(tan(phi_k) - s_k) zeta_k / max``, ``w = 1e-3``, with
  ``zeta_k`` the step LP's friction multipliers of interface ``k`` (both rows): the
  optimal forces that minimise the first-order estimate of the next step's
  ``lam`` (``d lam / d cohesion_k = zeta_k``, LP sensitivity).
* ``"on-oscillation"``: no tie-break LP until ``||n - n*||`` fails to decrease,
  then ``"closest"``.
* ``"none"``: the step LP's vertex as HiGHS returns it.

Any optimal primal and dual point of one LP are complementary, so the duals of
the step LP and ``x`` of the tie-break LP form a consistent pair.

Starts (:data:`STARTS`): ``"associative"`` (normal forces of the static LP (1)),
``"zero"`` (``n* = 0``: no cohesion), ``"dead-load"`` (a statically admissible
field under the dead load alone: the LP (1) with ``lam`` fixed at 0; when there is
none, i.e. the structure needs ``lam < 0``, the associative start), ``"random"``
(``n* = r * n_assoc``, ``r_k`` uniform in [0, 1] from a seeded generator).

Acceleration (``"anderson"``): Anderson mixing of depth ``m`` on ``n*`` (type II):
with residuals ``f_j = F(n*_j) - n*_j`` and the differences ``dF``, ``dX`` of the
last ``m`` iterates, ``gamma = argmin ||f_k - dF gamma||`` and
``n*_{k+1} = n*_k - dX gamma + omega (f_k - dF gamma)``.  A step LP that is not
optimal at an accelerated ``n*`` is retried at the plain update (memory cleared).
The stopping test stays ``||n - n*|| <= tol ||n||`` on the LP's own output.

Persistence: the LPs are built (Pyomo, in :mod:`blockmpec.formulations`),
compiled (through the compiled-formulation cache) and loaded into HiGHS once; a new ``n*`` changes only row upper bounds
(and, for the weighted tie-breaks, costs) and each solve starts from the previous
basis.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from blockmpec import facts as fact_names
from blockmpec.deadline import NEVER, Deadline
from blockmpec.formulations.sequence import StepLPs
from blockmpec.formulations.static_lp import cohesion_factor, surface_slope
from blockmpec.result import RunOutput, Solution, Status
from blockmpec.solvers.engines.highs import AT_LOWER, AT_UPPER, BASIC, FEASIBILITY_TOL, static_lp_solution
from blockmpec.verify import positive_part_ratio

TIE_BREAKS = ("closest", "least-compressed", "min-lambda", "on-oscillation", "none")
STARTS = ("associative", "zero", "dead-load", "random")
ACCELERATIONS = ("none", "anderson")
#: a folded tie-break hands over to exact "closest" steps once ||n - n*|| <= FOLD_SETTLE_TOL ||n||,
#: or after FOLD_STALL_STEPS steps without halving its best ||n - n*||
FOLD_SETTLE_TOL = 1e-6
FOLD_STALL_STEPS = 8
#: weight of the closeness term under the weighted tie-break rules (the rule's own costs are scaled to max 1)
CLOSENESS_WEIGHT = 1e-3


def _normal(x: np.ndarray, lps: StepLPs) -> np.ndarray:
    """The normal forces ``n_k`` of contact forces ``x`` (at ``lps.normal_index``: ``x = (t_k, n_k, m_k)`` per
    interface in 2D, ``(t1, t2, n)`` per contact point in 3D)."""
    return x[lps.normal_index]


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
    #: True: x from the tie-break LP; False: that LP failed (x from the step LP); None: none was run
    tie_break_used: bool | None = None


class LPSequence:
    """Persistent HiGHS LPs for the modified associative LPs at varying ``n*``.

    Parameters
    ----------
    lps : StepLPs
        The compiled LPs (:func:`blockmpec.formulations.step_lps` with the sequence's ``alpha``; its tie-break
        LP unless ``tie_break`` is ``"none"``, its associative LP for the ``"associative"``, ``"dead-load"``
        and ``"random"`` starts).
    units : LoadUnits
        The problem's load units (:class:`~blockmpec.solvers.engines.scaling.LoadUnits`): HiGHS works in them.
    alpha : float
        Tilt of the friction surface the LPs were compiled with (0: eq. (5)).
    tie_break : one of :data:`TIE_BREAKS`
    algorithm : str
        HiGHS algorithm (see :data:`blockmpec.solvers.plan.BASIS_ALGORITHMS`).
    feasibility_tol : float
        HiGHS primal and dual feasibility tolerances (HiGHS default 1e-7).  The
        sequence feeds each LP's forces into the next one, and light interfaces
        (top courses) have forces ~1, so 1e-7 absolute row violations show as
        ~1e-7 relative interface violations; 1e-9 keeps them well below.
    fold_weight : float
        0: a weighted tie-break rule runs as its own LP after each step.  ``> 0``:
        the rule's costs (scaled to max 1) times ``fold_weight`` are folded into the
        step LP's objective (``max lam + fold_weight * sum_k w_k n_k``: one LP per
        step; exact regularisation when small enough), and the tie-break LP runs
        only as ``"closest"`` in the closing steps (see :func:`run_sequence`).
    """

    def __init__(self, lps: StepLPs, units, alpha: float = 0.0, tie_break: str = "closest",
                 algorithm: str = "auto", feasibility_tol: float = FEASIBILITY_TOL, fold_weight: float = 0.0) -> None:
        from blockmpec.solvers.engines.highs import HighsLP

        if tie_break != "none" and lps.tie_break is None:
            raise ValueError(f"LP sequence: tie-break rule {tie_break!r} needs the tie-break LP (step_lps(tie_break=True))")
        self.lps = lps
        self.units = units
        c = lps.friction.size
        self.n_interfaces = c
        self.slope = lps.slope
        self.cohesion_factor = lps.cohesion_factor  # cohesion_k = -factor_k n*_k
        self.lp_solves = 0
        self.lp_time_s = {"associative": 0.0, "step": 0.0, "tie_break": 0.0}
        self.alpha = float(alpha)
        self.tie_break = tie_break
        self._step_cold = True  # the next step LP solve is its first
        self._tie_cold = True
        self._tie_rule = "closest"  # the cost vector now loaded in the tie-break LP
        self.fold_weight = float(fold_weight)
        self._last_z_f = None
        self._step_folded = False  # the step LP's objective now carries folded costs

        self.step_lp = lps.step
        self.step_highs = HighsLP(self.step_lp, algorithm, scaling=units.static(self.step_lp))

        self.tie_lp = None
        self.tie_highs = None
        if tie_break != "none":
            self.tie_lp = lps.tie_break
            row = int(self.tie_lp.rows["floor"][0])
            col = int(self.tie_lp.columns["lam"][0])
            a = self.tie_lp.A[[row], :].toarray().ravel()
            if not (a[col] == -1.0 and np.count_nonzero(a) == 1 and np.isfinite(self.tie_lp.row_upper[row])):
                raise RuntimeError("tie-break LP: the floor row did not compile to -lam <= -lam_floor")
            self.tie_highs = HighsLP(self.tie_lp, algorithm, scaling=units.static(self.tie_lp, ("d",)))
            self._normal_columns = self.tie_lp.columns["x"][lps.normal_index]
            self._d_columns = self.tie_lp.columns["d"]

        self.assoc_lp = lps.associative
        self.assoc_highs = None
        if self.assoc_lp is not None:
            self.assoc_highs = HighsLP(self.assoc_lp, algorithm, scaling=units.static(self.assoc_lp))
        for highs in (self.step_highs, self.tie_highs, self.assoc_highs):
            if highs is not None:
                highs.set_feasibility_tolerances(feasibility_tol)

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
    def _timed(self, kind: str, solve, *args, **kwargs):
        t0 = time.perf_counter()
        out = solve(*args, **kwargs)
        self.lp_time_s[kind] += time.perf_counter() - t0
        self.lp_solves += 1
        return out

    def facts(self) -> dict[str, Any]:
        """LP solves so far and seconds spent per LP kind (associative start, step, tie-break)."""
        return {fact_names.LP_SOLVES: self.lp_solves, fact_names.LP_TIME_S: {k: round(v, 6) for k, v in self.lp_time_s.items()}}

    def associative(self, deadline: Deadline = NEVER) -> Step:
        """Solve the associative static LP (1) (the ``"associative"`` start)."""
        if self.assoc_highs is None:
            raise RuntimeError("the associative LP was not compiled")
        if deadline.expired():
            return Step(Status.TIME_LIMIT, "", "time limit reached before the associative LP")
        out = self._timed("associative", self.assoc_highs.solve, deadline=deadline)
        if out.status is not Status.OPTIMAL:
            return Step(out.status, out.raw_status, f"associative start LP: {out.message}",
                        lp_iterations=out.iterations)
        return Step(Status.OPTIMAL, out.raw_status, out.message, static_lp_solution(self.assoc_lp, out), out.iterations)

    def dead_load(self, deadline: Deadline = NEVER) -> Step:
        """A statically admissible force field under the dead load alone (the ``"dead-load"`` start).

        The associative LP (1) with ``lam`` fixed at 0 (column bounds ``[0, 0]``);
        HiGHS returns a vertex of that feasible set.  The bounds are restored after.
        """
        if self.assoc_highs is None:
            raise RuntimeError("the associative LP was not compiled")
        if deadline.expired():
            return Step(Status.TIME_LIMIT, "", "time limit reached before the dead-load LP")
        col = self.assoc_lp.columns["lam"][:1]
        self.assoc_highs.set_column_bounds(col, [0.0], [0.0])
        try:
            out = self._timed("associative", self.assoc_highs.solve, deadline=deadline)
        finally:
            self.assoc_highs.set_column_bounds(col, [-np.inf], [np.inf])
        if out.status is not Status.OPTIMAL:
            return Step(out.status, out.raw_status, f"dead-load start LP: {out.message}",
                        lp_iterations=out.iterations)
        return Step(Status.OPTIMAL, out.raw_status, out.message, static_lp_solution(self.assoc_lp, out), out.iterations)

    def set_alpha(self, alpha: float) -> None:
        """Tilt the friction rows of the step (and tie-break) LP to ``alpha`` (the SLP's schedule).

        Changes the ``n`` coefficient ``s_k`` of both friction rows of every interface in
        HiGHS (the basis is kept) and the cohesion factor ``tan(phi) - s``.
        """
        if alpha == self.alpha:
            return
        lps = self.lps
        slope = np.broadcast_to(surface_slope(lps.friction, lps.dilatancy, alpha), (self.n_interfaces,))
        for lp, highs in ((self.step_lp, self.step_highs), (self.tie_lp, self.tie_highs)):
            if highs is None:
                continue
            contact = lps.friction_contact  # the contact of each friction row (2D: two rows per interface)
            highs.set_coefficients(lp.rows["friction"], lp.columns["x"][lps.normal_index][contact], slope[contact])
        self.alpha = float(alpha)
        self.slope = slope
        self.cohesion_factor = cohesion_factor(lps.friction, slope)

    def set_sensitivity(self, z_f: np.ndarray | None) -> None:
        """Friction multipliers for the first folded ``"min-lambda"`` step (e.g. the associative LP's)."""
        self._last_z_f = None if z_f is None else np.asarray(z_f, float)

    def _rule_weights(self, rule: str, z_f: np.ndarray | None) -> np.ndarray:
        """Weights ``w >= 0`` (max 1) of a weighted rule: the objective term is ``-sum_k w_k n_k``."""
        c = self.n_interfaces
        weight = self.cohesion_factor * np.ones(c)
        if rule == "min-lambda":
            zeta = np.zeros(c) if z_f is None else np.bincount(self.lps.friction_contact, np.maximum(z_f, 0.0), c)
            weight = weight * zeta
        top = float(np.max(weight, initial=0.0))
        return weight / top if top > 0 else np.zeros(c)

    def _fold_costs(self, weights: np.ndarray | None) -> None:
        """Step LP objective ``min -lam - fold_weight sum_k w_k n_k`` (``weights=None``: plain ``-lam``)."""
        cols = self.step_lp.columns["x"][self.lps.normal_index].astype(np.int32)
        cost = np.zeros(cols.size) if weights is None else -self.fold_weight * weights
        self.step_highs.set_costs(cols, cost)
        self._step_folded = weights is not None

    def _set_tie_costs(self, rule: str, z_f: np.ndarray | None) -> None:
        """Load the tie-break LP's costs for ``rule`` (see the module docstring)."""
        if rule == "closest" and self._tie_rule == "closest":
            return
        c = self.n_interfaces
        if rule == "closest":
            n_cost, d_cost = np.zeros(c), np.ones(c)
        else:
            n_cost, d_cost = -self._rule_weights(rule, z_f), np.full(c, CLOSENESS_WEIGHT)
        cols = np.concatenate([self._normal_columns, self._d_columns]).astype(np.int32)
        self.tie_highs.set_costs(cols, np.concatenate([n_cost, d_cost]))
        self._tie_rule = rule

    def step(self, n_star: np.ndarray, deadline: Deadline = NEVER, rule: str | None = None,
             first_from_associative: bool = True) -> Step:
        """Solve the step LP at ``n_star`` (then the tie-break LP under ``rule``).

        ``n_star`` must be compressive (``<= 0``); :func:`run_sequence` clips it.
        ``rule``: a tie-break rule, ``"none"`` or None (= the sequence's own rule).
        ``first_from_associative``: the first step LP starts from the associative
        LP's basis (valid when ``n*`` are that LP's normal forces).
        """
        rule = self.tie_break if rule is None else rule
        cohesion = -self.cohesion_factor * n_star
        rhs = cohesion[self.lps.friction_contact]  # every friction row of contact k
        lp = self.step_lp
        folded = self.fold_weight > 0 and rule in ("least-compressed", "min-lambda")
        if folded:
            self._fold_costs(self._rule_weights(rule, self._last_z_f))
        elif self._step_folded:
            self._fold_costs(None)
        self.step_highs.set_row_upper(lp.rows["friction"], rhs)
        if deadline.expired():
            return Step(Status.TIME_LIMIT, "", "time limit reached before a step LP")
        first_algorithm = None
        if self._step_cold and first_from_associative and self.assoc_highs is not None and self.alpha == 0.0:
            first_algorithm = self._start_from_associative_basis()
        self._step_cold = False
        out = self._timed("step", self.step_highs.solve, first_algorithm, deadline=deadline)
        if out.status is not Status.OPTIMAL:
            return Step(out.status, out.raw_status, f"modified LP: {out.message}", lp_iterations=out.iterations)
        sol = static_lp_solution(lp, out)
        self._last_z_f = sol.z_f
        iterations = out.iterations
        if self.tie_highs is None or rule in ("none", "on-oscillation") or folded:
            return Step(Status.OPTIMAL, out.raw_status, out.message, sol, iterations)

        tie = self.tie_lp
        self._set_tie_costs(rule, sol.z_f)
        self.tie_highs.set_row_upper(tie.rows["friction"], rhs)
        self.tie_highs.set_row_upper(tie.rows["deviation_up"], n_star)
        self.tie_highs.set_row_upper(tie.rows["deviation_down"], -n_star)
        lam = sol.multiplier
        self.tie_highs.set_row_upper(tie.rows["floor"], np.array([-(lam - tie_break_delta(lam))]))
        if deadline.expired():
            return Step(Status.TIME_LIMIT, "", "time limit reached before a tie-break LP", sol, iterations)
        first_algorithm = self._start_tie_break_from_step_basis(_normal(sol.x, self.lps), n_star) if self._tie_cold else None
        self._tie_cold = False
        tout = self._timed("tie_break", self.tie_highs.solve, first_algorithm, deadline=deadline)
        iterations += tout.iterations
        if tout.status is not Status.OPTIMAL:
            # keep the step LP's own point; the caller records the failure
            return Step(Status.OPTIMAL, out.raw_status, f"tie-break LP: {tout.message}", sol, iterations, False)
        sol.x = tie.values("x", tout.v)
        sol.multiplier = float(tie.values("lam", tout.v)[0])
        return Step(Status.OPTIMAL, out.raw_status, out.message, sol, iterations, True)




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


class Anderson:
    """Anderson mixing (type II, depth ``memory``) of a fixed-point map on ``n*``; see the module docstring."""

    def __init__(self, memory: int, relaxation: float) -> None:
        self.memory = int(memory)
        self.relaxation = float(relaxation)
        self.reset()

    def reset(self) -> None:
        self.x_prev: np.ndarray | None = None
        self.f_prev: np.ndarray | None = None
        self.dX: list[np.ndarray] = []
        self.dF: list[np.ndarray] = []

    def update(self, x: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Next iterate from ``x`` and ``g = F(x)``."""
        f = g - x
        if self.x_prev is not None:
            self.dX.append(x - self.x_prev)
            self.dF.append(f - self.f_prev)
            if len(self.dX) > self.memory:
                self.dX.pop(0)
                self.dF.pop(0)
        self.x_prev, self.f_prev = x.copy(), f.copy()
        if not self.dF:
            return x + self.relaxation * f
        dF = np.column_stack(self.dF)
        dX = np.column_stack(self.dX)
        gamma, *_ = np.linalg.lstsq(dF, f, rcond=1e-10)
        return x - dX @ gamma + self.relaxation * (f - dF @ gamma)


def run_sequence(
    seq: LPSequence,
    *,
    start: str,
    relaxation: float,
    stop_on: str,
    tol: float,
    max_iterations: int,
    deadline: Deadline = NEVER,
    min_iterations: int = 1,
    acceleration: str = "none",
    memory: int = 5,
    seed: int = 0,
    alpha_schedule=None,
    stall_steps: int | None = None,
) -> tuple[RunOutput, dict[str, Any]]:
    r"""Iterate ``n* -> LP step -> n``, ``n* <- min(n* + relaxation (n - n*), 0)`` (or Anderson's update).

    ``n*`` is kept compressive (``<= 0``, as the unilateral rows make every ``n``):
    a round-off tension of the size of the LP feasibility tolerance would otherwise
    give a negative cohesion and could make the next step LP infeasible.  One
    :class:`~blockmpec.solvers.engines.stopping.StoppingCriterion` decides and writes the trace.

    Parameters
    ----------
    seq : LPSequence
    start : one of :data:`STARTS`
    relaxation : float in (0, 1]
    stop_on : {"normal", "multiplier"}
        ``"normal"``: stop when ``||n - n*|| <= tol ||n||`` (fixed point);
        ``"multiplier"``: stop when ``|lam_k - lam_{k-1}| <= tol`` and ``k >= min_iterations``.
    tol : float
    max_iterations : int
    deadline : Deadline
        The run's deadline (the start LP included).
    min_iterations : int
        Fewest step LPs before the stopping test may succeed.
    acceleration : {"none", "anderson"}
    memory : int
        Anderson depth.
    seed : int
        Seed of the ``"random"`` start.
    alpha_schedule : callable, optional
        ``k -> alpha`` of step ``k`` (1-based) for the SLP (:meth:`LPSequence.set_alpha`).
    stall_steps : int, optional
        ``stop_on="normal"``: stop with ``NUMERICAL`` when the smallest ``||n - n*|| / ||n||`` so far has not halved in
        this many steps (after any folded steps): the iteration wanders instead of converging (seen on irregular
        stone walls, where the map ``n* -> n`` does not contract); None never stops for that.

    Returns
    -------
    RunOutput, dict
        The run output (status CONVERGED, ITERATION_LIMIT, TIME_LIMIT; the start LP's failure status, which is the
        associative LP's (1) for every start but ``"zero"``; ``NUMERICAL`` when a step LP fails: the step LP is the
        iteration's problem, not (3), so its infeasibility proves nothing of the structure) and a dict of loop facts
        (``lam_start``: the associative multiplier when it was computed, ``tie_break_failures``, ``step_failure``:
        the failed step LP's status or None).
    """
    from blockmpec.solvers.engines.stopping import StoppingCriterion

    measure = "n_change" if stop_on == "normal" else "lam_change"
    crit = StoppingCriterion(tol, max_iterations, deadline, measure_name=measure).start()
    facts: dict[str, Any] = {"lam_start": None, "tie_break_failures": 0, "start_used": start, "step_failure": None}

    def output(status, sol, message, raw=""):
        return RunOutput(status, sol if sol is not None else Solution(), crit.iterations, crit.trace, message, raw,
                         extra=seq.facts()), facts

    from_associative_basis = start in ("associative", "dead-load")
    if start in ("associative", "random"):
        first = seq.associative(deadline)
        if first.status is not Status.OPTIMAL:
            return output(first.status, None, first.message, first.raw_status)
        facts["lam_start"] = first.solution.multiplier
        seq.set_sensitivity(first.solution.z_f)
        n_star = np.minimum(_normal(first.solution.x, seq.lps), 0.0)
        if start == "random":
            n_star = n_star * np.random.default_rng(seed).uniform(0.0, 1.0, n_star.size)
    elif start == "dead-load":
        first = seq.dead_load(deadline)
        if first.status is not Status.OPTIMAL and first.status is not Status.TIME_LIMIT:
            # no equilibrium under the dead load alone (lam < 0 is needed), or no answer: start from the
            # associative forces (whose LP (1) decides about the structure)
            facts["start_used"] = "associative"
            first = seq.associative(deadline)
            if first.status is Status.OPTIMAL:
                facts["lam_start"] = first.solution.multiplier
                seq.set_sensitivity(first.solution.z_f)
        if first.status is not Status.OPTIMAL:
            return output(first.status, None, first.message, first.raw_status)
        n_star = np.minimum(_normal(first.solution.x, seq.lps), 0.0)
    else:
        n_star = np.zeros(seq.n_interfaces)

    anderson = Anderson(memory, relaxation) if acceleration == "anderson" else None
    rule = None if seq.tie_break != "on-oscillation" else "none"
    # folded tie-break: one LP per step until n settles (or stalls), then exact "closest" steps close the loop
    folding = seq.fold_weight > 0 and seq.tie_break in ("least-compressed", "min-lambda")
    best_change, since_best = np.inf, 0
    stall_best, stall_since = np.inf, 0  # the stall test's own record (after the folded steps)
    last: Solution | None = None
    lam_prev: float | None = None
    n_change_prev = np.inf
    plain_next = n_star
    while True:
        if alpha_schedule is not None:
            seq.set_alpha(alpha_schedule(crit.iterations + 1))
        step = seq.step(n_star, deadline, rule, first_from_associative=from_associative_basis)
        if step.status is not Status.OPTIMAL and anderson is not None and step.status is not Status.TIME_LIMIT \
                and not np.array_equal(n_star, plain_next):
            # the accelerated n* gave no optimal LP: take the plain update instead, memory cleared
            anderson.reset()
            n_star = plain_next
            step = seq.step(n_star, deadline, rule)
        if step.status is not Status.OPTIMAL:
            k = crit.iterations + 1
            if step.status is Status.TIME_LIMIT:
                return output(step.status, last, f"time limit reached at iteration {k}; returning the last iterate",
                              step.raw_status)
            # a step LP (5) is the iteration's own problem, not (3): its failure (infeasible, unbounded, ...) proves
            # nothing of the structure, so the run reports a failed iteration, never the LP's status
            facts["step_failure"] = step.status.value
            return output(Status.NUMERICAL, last, f"iteration {k}: the step LP is {step.status.value} ({step.message}); "
                          "the iteration failed, which does not show that (3) has no solution", step.raw_status)
        if step.tie_break_used is False:
            facts["tie_break_failures"] += 1
        sol = step.solution
        n = _normal(sol.x, seq.lps)
        n_norm = float(np.linalg.norm(n))
        n_change = float(np.linalg.norm(n - n_star)) / n_norm if n_norm > 0 else float(np.linalg.norm(n - n_star))
        lam = float(sol.multiplier)
        lam_change = None if lam_prev is None else abs(lam - lam_prev)
        value = n_change if stop_on == "normal" else (np.inf if lam_change is None else lam_change)
        values = {"multiplier": lam, "friction_admissibility": positive_part_ratio(seq.lps.coulomb @ sol.x),
                  "lp_iterations": step.lp_iterations}
        values["n_change" if stop_on != "normal" else "lam_change"] = n_change if stop_on != "normal" else lam_change
        if not np.isfinite(value):  # no lam_change at the first SLP step: record without a decision
            crit.iterations += 1
            crit.record(**{measure: None}, **values)
            status = Status.ITERATION_LIMIT if crit.iterations >= max_iterations else None
        else:
            status = crit.check(value, **values)
        last = sol
        if status is Status.CONVERGED and crit.iterations < min_iterations:
            status = None
        if folding:
            since_best = 0 if n_change < 0.5 * best_change else since_best + 1
            best_change = min(best_change, n_change)
            if status is Status.CONVERGED or n_change <= FOLD_SETTLE_TOL or since_best >= FOLD_STALL_STEPS:
                # a folded step's duals carry the folded costs: close with exact steps
                folding, rule, status = False, "closest", None
        if stall_steps is not None and stop_on == "normal" and not folding and status is None:
            stall_since = 0 if n_change < 0.5 * stall_best else stall_since + 1
            stall_best = min(stall_best, n_change)
            if stall_since >= stall_steps:
                return output(Status.NUMERICAL, sol, f"the iteration wanders: ||n - n*||/||n|| has not halved in "
                              f"{stall_steps} steps (smallest {stall_best:.2e}, last {n_change:.2e}); returning the last "
                              "iterate", step.raw_status)
        if status is Status.CONVERGED:
            return output(status, sol, "", step.raw_status)
        if status is Status.ITERATION_LIMIT:
            return output(status, sol, f"no convergence in {max_iterations} iterations; returning the last iterate",
                          step.raw_status)
        if status is Status.TIME_LIMIT or deadline.expired():
            return output(Status.TIME_LIMIT, sol, f"time limit reached after iteration "
                          f"{crit.iterations}; returning the last iterate", step.raw_status)
        if status is not None:
            return output(status, sol, f"iteration {crit.iterations}: non-finite convergence measure", step.raw_status)
        if rule == "none" and seq.tie_break == "on-oscillation" and n_change >= n_change_prev:
            rule = "closest"  # n stopped settling: from now on the closest optimal forces
        n_change_prev = n_change
        lam_prev = lam
        # normal forces are compressive; round-off tension (within the LP's feasibility
        # tolerance) would give a negative cohesion and can make the next LP infeasible
        plain_next = np.minimum(n_star + relaxation * (n - n_star), 0.0)
        n_star = plain_next if anderson is None else np.minimum(anderson.update(n_star, n), 0.0)

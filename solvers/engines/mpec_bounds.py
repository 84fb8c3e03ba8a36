r"""The LP bounds of ``milp``: bounds on ``lam``, the forces, the slacks and the multipliers at every solution of (3).

Notation of :mod:`blockmpec.formulations.mpec_milp`.  Two polyhedra hold every solution of (3):

* the statically admissible set ``S = {(lam, x) : A[equilibrium] (lam, x) = rhs, G x <= 0}``, and
* the kinematic set ``K = {(u, z) : compatibility, z >= 0}`` with a normalisation: ``f_l^T u = 1`` (that of (3)) or
  ``1^T z = 1`` (that of the mixed-integer model, (N)).

Each bound below is the optimum of one LP over one of them, widened by its round-off margin (:func:`widen`):

* ``lam_upper = max lam`` over ``S`` (the associative multiplier, an upper bound of every solution) and
  ``lam_static_min = min lam`` over ``S``;
* ``lam_kinematic = min -f_d^T u`` over ``K`` with ``f_l^T u = 1``: by the work identity (W)
  ``lam = -f_d^T u + x^T B z`` and ``x^T B z >= 0``, a lower bound on ``lam``;
* the dissipation bound ``lam_dissipation``: (W) with each product ``B_e x_r z_i`` bounded below by
  ``B_e upper_e z_i``, ``upper_e = max x_r`` over ``S ∩ {s_i = 0}`` (conditional bound tightening: ``z_i > 0`` forces
  ``s_i = 0``), one LP over ``K``;
* ``slack_max_i = max s_i`` over ``S`` with ``lam`` in ``[lam_static_min, lam_upper]`` (the big-M of pair ``i``);
* ``z_max_i = max z_i`` and ``tau_max = max f_l^T u`` over ``K`` with ``1^T z = 1``.

Every LP runs cold (HiGHS's warm re-solves after a change of costs were seen to end "optimal" at a wrong value) and
within a deadline; a bound whose LP did not end optimal, or was not reached in time, is left at its trivial value
(``inf``, ``1`` for ``z_max``), which is valid too, and the record says which kinds are complete.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import scipy.sparse as sp

from blockmpec.deadline import Deadline
from blockmpec.formulations.compiled import FRICTION
from blockmpec.result import Status

#: relative margin and absolute margin (times the largest bound) added to proven slack and multiplier bounds
BOUND_MARGIN_REL = 1e-4
BOUND_MARGIN_ABS = 1e-6
#: relative widening of LP-derived bounds (round-off of the LP optima)
LP_MARGIN = 1e-6
#: relative widening of the lam lower bounds of the kinematic LPs, solved at ``BOUND_LP_TOL``
LAM_MARGIN = 1e-8
#: HiGHS's feasibility tolerances of the kinematic bound LPs (below milp's certificate tolerance, so that a root
#: bound can close the gap) and of the static ones; a reduced cost within the latter on a free column counts as zero
#: in the weak-duality value that certifies each optimum
BOUND_LP_TOL = 1e-10
STATIC_LP_TOL = 1e-9


class BoundFailure(Exception):
    """A bound LP whose failure leaves ``milp`` without a bound it needs.

    Parameters
    ----------
    status : Status
        The LP's status.
    message : str
        What failed, for the run's message.
    proof : bool
        The status says something of (3) itself (the associative LP ``max lam`` over ``S``: infeasible means ``S``
        is empty, so (3) has no solution; unbounded means no collapse), and is the run's status.
    """

    def __init__(self, status: Status, message: str, proof: bool = False) -> None:
        super().__init__(message)
        self.status = status
        self.proof = proof

    @property
    def run_status(self) -> Status:
        """The status of a run that stops here."""
        if self.status is Status.TIME_LIMIT:
            return Status.TIME_LIMIT
        if self.proof and self.status in (Status.UNBOUNDED, Status.INFEASIBLE, Status.INFEASIBLE_OR_UNBOUNDED):
            return self.status
        return Status.ERROR


def widen(lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """LP-derived bounds widened by ``LP_MARGIN`` (relative) and ``BOUND_MARGIN_REL`` of the finite width."""
    width = np.abs(upper - lower)
    width = np.where(np.isfinite(width), width, 0.0)
    return (lower - LP_MARGIN * np.maximum(1.0, np.abs(lower)) - BOUND_MARGIN_REL * width,
            upper + LP_MARGIN * np.maximum(1.0, np.abs(upper)) + BOUND_MARGIN_REL * width)


def static_program(form):
    """``S`` as a :class:`~blockmpec.formulations.pyomo_compile.LinearProgram` over ``(lam, x)`` (no cost)."""
    from blockmpec.solvers.engines.piece_lp import static_program as piece_static

    return piece_static(form)


def kinematic_program(form):
    """``K`` as a :class:`~blockmpec.formulations.pyomo_compile.LinearProgram` over ``(u, z)``: rows
    ``compatibility``, ``live`` (``f_l^T u``) and ``total`` (``1^T z``), whose bounds pick the normalisation."""
    from blockmpec.solvers.engines.piece_lp import kinematic_program as piece_kinematic

    return piece_kinematic(form)


class _CertifiedLP:
    """One bound LP held by HiGHS (:class:`~blockmpec.solvers.engines.highs.HighsLP`) with its current bounds kept
    here: each optimum is taken from the weak-duality value of the solve's row duals
    (:func:`~blockmpec.solvers.engines.lifted_lp.dual_bound`), a valid bound whatever HiGHS's answer, so re-solves
    may be warm (HiGHS's warm re-solves after a change of costs were seen to end "optimal" at a wrong value, which
    the certificate catches); a solve whose duals certify nothing is repeated cold, whose optimum is taken."""

    def __init__(self, lp, tolerance: float) -> None:
        from blockmpec.solvers.engines.highs import HighsLP

        self.lp = lp
        # the primal simplex: after a change of costs the last basis stays primal feasible (wall 6 of ferris-tinloi,
        # 40 slack bounds: 0.08 s an LP warm by the primal simplex, 0.15 s by the dual, 1.2 s cold)
        self.hl = HighsLP(lp, "primal-simplex")
        self.hl.set_feasibility_tolerances(tolerance)
        self.tolerance = max(tolerance, STATIC_LP_TOL)
        self.A = sp.csc_array(lp.A)
        self.rl, self.ru = lp.row_lower.copy(), lp.row_upper.copy()
        self.cl, self.cu = lp.col_lower.copy(), lp.col_upper.copy()
        self.solves = 0

    def set_row_bounds(self, rows, lower, upper) -> None:
        rows = np.atleast_1d(rows)
        self.rl[rows], self.ru[rows] = lower, upper
        self.hl.set_row_bounds(rows, self.rl[rows], self.ru[rows])

    def set_column_bounds(self, cols, lower, upper) -> None:
        cols = np.atleast_1d(cols)
        self.cl[cols], self.cu[cols] = lower, upper
        self.hl.set_column_bounds(cols, self.cl[cols], self.cu[cols])

    def solve(self, cost: np.ndarray, deadline: Deadline, cold: bool = True):
        """``min cost^T v``: HiGHS's outcome (cold unless ``cold`` is False)."""
        self.hl.set_costs(np.arange(cost.size), cost)
        self.solves += 1
        return self.hl.solve(deadline=deadline, cold=cold)

    def minimum(self, cost: np.ndarray, deadline: Deadline) -> float | None:
        """A certified lower bound on ``min cost^T v`` (the optimum within HiGHS's tolerances), or None when neither
        the warm solve's duals nor a cold solve give one."""
        from blockmpec.solvers.engines.lifted_lp import dual_bound

        for cold in (False, True):
            out = self.solve(cost, deadline, cold)
            if out.status is not Status.OPTIMAL:
                continue
            value = dual_bound(self.A, cost, self.rl, self.ru, self.cl, self.cu, out.row_dual, tol=self.tolerance,
                               correct=False)
            if np.isfinite(value):
                return float(value)
            if cold:
                return float(out.objective)
        return None


class BoundLPs:
    """The bound LPs of one structure's (3): a HiGHS model of ``S`` and one of ``K`` (see the module docstring).

    Parameters
    ----------
    form : CompiledMCP
        Problem (3), in the units the bounds are wanted in.
    """

    def __init__(self, form) -> None:
        self.form = form
        self.static = static_program(form)
        self.kinematic = kinematic_program(form)
        self.static_lp = _CertifiedLP(self.static, STATIC_LP_TOL)
        self.kinematic_lp = _CertifiedLP(self.kinematic, BOUND_LP_TOL)

    @property
    def n_lps(self) -> int:
        """LPs solved so far."""
        return self.static_lp.solves + self.kinematic_lp.solves

    # ------------------------------------------------------------------ one LP
    def _optimum(self, model, cost: np.ndarray, deadline: Deadline):
        """``min cost^T v`` over ``model`` (cold): the LP's outcome."""
        return model.solve(cost, deadline)

    def _static_optimum(self, cost: np.ndarray, deadline: Deadline) -> float | None:
        """A certified lower bound on ``min cost^T (lam, x)`` over ``S`` as the model holds it now (None: none)."""
        return self.static_lp.minimum(cost, deadline)

    def _x_cost(self, j: int, direction: float) -> np.ndarray:
        cost = np.zeros(self.static.c.size)
        cost[1 + j] = direction  # the x columns of the static LP follow lam
        return cost

    def set_lam_range(self, lower: float, upper: float) -> None:
        """Bound ``lam`` in the model of ``S`` (``-inf, inf``: free again)."""
        self.static_lp.set_column_bounds(0, lower, upper)

    # ------------------------------------------------------------------ lam
    def associative(self, deadline: Deadline) -> tuple[float, float, np.ndarray]:
        """``(max lam, min lam, x at the max)`` over ``S``; raises :class:`BoundFailure` (``proof``: the associative
        LP's status is the answer of (3))."""
        cost = np.zeros(self.static.c.size)
        cost[0] = -1.0
        up = self._optimum(self.static_lp, cost, deadline)
        if up.status is not Status.OPTIMAL:
            raise BoundFailure(up.status, f"associative LP (max lam): {up.status.value}", proof=True)
        cost[0] = 1.0
        lo = self._optimum(self.static_lp, cost, deadline)
        if lo.status is not Status.OPTIMAL:
            raise BoundFailure(lo.status, f"min lam over the statically admissible set is {lo.status.value}: the "
                               "slacks have no LP bound, so no valid big-M exists")
        return float(up.v[0]), float(lo.v[0]), self.static.values("x", up.v)

    def kinematic_minimum(self, deadline: Deadline) -> float | None:
        """``min -f_d^T u`` over ``K`` with ``f_l^T u = 1`` (None when not optimal), widened."""
        return self._kinematic_lower(np.zeros(self.form.n_pairs), deadline)

    def _kinematic_lower(self, z_cost: np.ndarray, deadline: Deadline) -> float | None:
        kp, hl = self.kinematic, self.kinematic_lp
        hl.set_row_bounds(kp.rows["live"], 1.0, 1.0)
        hl.set_row_bounds(kp.rows["total"], -np.inf, np.inf)
        value = hl.minimum(np.r_[-self.form.f_d, z_cost], deadline)
        if value is None:
            return None
        return float(value - LAM_MARGIN * max(1.0, abs(value)))

    def dissipation_minimum(self, B: sp.coo_array, upper: np.ndarray, deadline: Deadline) -> float | None:
        r"""A lower bound on lam from the work identity with the friction work bounded below.

        At a solution of (3) with ``f_l^T u = 1``: ``lam = -f_d^T u + sum_e B_e x_r z_i``.  Each ``B_e < 0`` and
        ``x_r <= upper_e`` whenever ``z_i > 0``, so ``B_e x_r z_i >= B_e upper_e z_i`` and ::

            lam >= min { -f_d^T u + c^T z : compatibility, f_l^T u = 1, z >= 0 },  c_i = sum_e B_e upper_e,

        an LP over a superset of the kinematic part of every solution.  None when some ``B_e > 0`` or ``upper_e``
        is not finite (no sign argument) or the LP is not optimal.
        """
        if np.any(B.data > 0) or not np.all(np.isfinite(upper)):
            return None
        cz = np.zeros(self.form.n_pairs)
        np.add.at(cz, B.col, B.data * upper)
        return self._kinematic_lower(cz, deadline)

    # ------------------------------------------------------------------ forces
    def force_bounds(self, B: sp.coo_array, lower: bool, deadline: Deadline) -> dict:
        """Bounds of the forces ``x_r`` of the work identity: over ``S`` (``x_lower``, ``x_upper``) and over
        ``S ∩ {s_i = 0}`` for each product ``x_r z_i`` (``product_lower``, ``product_upper``, one per entry of
        ``B``; conditional bound tightening), the lower ones only if ``lower``.  Out of time, the bounds not
        reached stay infinite (``complete`` False); an LP that fails leaves its bound infinite."""
        nx = self.form.pair_matrix.shape[1]
        out = {"x_lower": np.full(nx, -np.inf), "x_upper": np.full(nx, np.inf),
               "product_lower": np.full(B.nnz, -np.inf), "product_upper": np.full(B.nnz, np.inf), "complete": False}
        for j in np.unique(B.row):
            if deadline.expired():
                return out
            if lower:
                out["x_lower"][j] = self._bound_or(self._x_cost(j, 1.0), 1.0, -np.inf, deadline)
            out["x_upper"][j] = -self._bound_or(self._x_cost(j, -1.0), 1.0, -np.inf, deadline)
        rows = self.static.rows["pairs"]
        for e in range(B.nnz):
            if deadline.expired():
                return out
            row = int(rows[int(B.col[e])])
            self.static_lp.set_row_bounds(row, 0.0, 0.0)
            try:
                if lower:
                    out["product_lower"][e] = self._bound_or(self._x_cost(int(B.row[e]), 1.0), 1.0, -np.inf, deadline)
                out["product_upper"][e] = -self._bound_or(self._x_cost(int(B.row[e]), -1.0), 1.0, -np.inf, deadline)
            finally:
                self.static_lp.set_row_bounds(row, -np.inf, 0.0)
        out["complete"] = not deadline.expired()
        return out

    def _bound_or(self, cost: np.ndarray, sign: float, fallback: float, deadline: Deadline) -> float:
        value = self._static_optimum(cost, deadline)
        return fallback if value is None else sign * value

    def implied_nonpositive(self) -> np.ndarray:
        """``x_r <= 0`` implied exactly by ``G x <= 0``: the two friction rows of an interface add up to a positive
        multiple of ``e_r`` (Coulomb: ``(t + tan(phi) n) + (-t + tan(phi) n) = 2 tan(phi) n``)."""
        form = self.form
        Gx = form.pair_matrix.tocsr()
        out = np.zeros(Gx.shape[1], dtype=bool)
        for k in range(form.n_interfaces):
            pairs = np.flatnonzero((form.pair_interface == k) & (form.pair_kind == FRICTION))
            if pairs.size != 2:
                continue
            v = (Gx[[pairs[0]]] + Gx[[pairs[1]]]).toarray().ravel()
            scale = np.abs(Gx[pairs].data).max(initial=0.0)
            big = np.flatnonzero(np.abs(v) > 1e-14 * scale)
            if big.size == 1 and v[big[0]] > 0:
                out[big[0]] = True
        return out

    # ------------------------------------------------------------------ slacks and multipliers
    def slack_bounds(self, lam_lower: float, lam_upper: float, deadline: Deadline) -> tuple[np.ndarray, bool]:
        """``(slack_max, complete)``: ``max s_i`` over ``S ∩ {lam_lower <= lam <= lam_upper}`` per pair, widened
        (0 where the maximum is 0: the pair row is tight on all of it); ``inf`` where not reached or the LP
        failed."""
        Gx = self.form.pair_matrix.tocsr()
        npair = Gx.shape[0]
        smax = np.full(npair, np.inf)
        self.set_lam_range(lam_lower, lam_upper)
        try:
            for i in range(npair):
                if deadline.expired():
                    break
                a, b = Gx.indptr[i], Gx.indptr[i + 1]
                cost = np.zeros(self.static.c.size)
                cost[1 + Gx.indices[a:b]] = Gx.data[a:b]  # min G_i x = -max s_i
                value = self._static_optimum(cost, deadline)
                if value is not None:
                    smax[i] = max(-value, 0.0)
        finally:
            self.set_lam_range(-np.inf, np.inf)
        finite = smax[np.isfinite(smax)]
        scale = float(max(finite.max(initial=0.0), 1e-300))
        widened = np.where(smax <= 1e-12 * scale, 0.0, smax * (1.0 + BOUND_MARGIN_REL) + BOUND_MARGIN_ABS * scale)
        return widened, bool(np.all(np.isfinite(smax)))

    def multiplier_bounds(self, per_pair: bool, deadline: Deadline) -> tuple[np.ndarray, float, bool]:
        """``(z_max, tau_max, complete)``: ``max z_i`` (``per_pair``; else the trivial 1) and ``max f_l^T u`` over
        ``K`` with ``1^T z = 1``, widened; the trivial bound (1, ``inf``) where an LP failed or was not reached."""
        kp, hl = self.kinematic, self.kinematic_lp
        hl.set_row_bounds(kp.rows["live"], -np.inf, np.inf)
        hl.set_row_bounds(kp.rows["total"], 1.0, 1.0)
        nu, npair = kp.columns["u"].size, kp.columns["z"].size
        cost = np.zeros(kp.c.size)
        cost[:nu] = -self.form.f_l
        value = hl.minimum(cost, deadline)
        tau_max = -value * (1 + LP_MARGIN) + LP_MARGIN if value is not None else np.inf
        z_max = np.ones(npair)
        complete = True
        for i in range(npair if per_pair else 0):
            if deadline.expired():
                complete = False
                break
            cost = np.zeros(kp.c.size)
            cost[kp.columns["z"][i]] = -1.0
            value = hl.minimum(cost, deadline)
            if value is not None:
                zi = -value
                z_max[i] = 0.0 if zi <= 1e-12 else min(1.0, zi * (1 + BOUND_MARGIN_REL) + BOUND_MARGIN_ABS)
        return z_max, float(tau_max), complete


def root_bounds(lps: BoundLPs, B: sp.coo_array, products: bool, envelope: bool, deadline: Deadline,
                associative: tuple | None = None):
    """The bounds on ``lam`` (:class:`~blockmpec.formulations.mpec_milp.MPECBounds` without its model bounds).

    ``lam_upper`` is the associative multiplier, ``lam_lower`` the largest of the LP lower bounds (``min lam`` over
    ``S``, the kinematic minimum and, with ``products``, the dissipation bound), each widened.  ``envelope`` also
    bounds the forces from below (for the work envelope of the mixed-integer model).  Raises
    :class:`BoundFailure` when the associative LP or ``min lam`` over ``S`` fails.  ``associative``: the result
    of :meth:`BoundLPs.associative` when the caller has it already.
    """
    from blockmpec.formulations.mpec_milp import MPECBounds

    t0, n0 = time.perf_counter(), lps.n_lps
    lam_assoc, lam_min, x_assoc = associative if associative is not None else lps.associative(deadline)
    lam_upper = lam_assoc + LP_MARGIN * max(1.0, abs(lam_assoc))
    lam_lower = lam_min - LP_MARGIN * max(1.0, abs(lam_min))
    kin = lps.kinematic_minimum(deadline)  # one LP: before the many of the force bounds
    nx = lps.form.pair_matrix.shape[1]
    x_lower, x_upper = np.full(nx, -np.inf), np.full(nx, np.inf)
    product_lower = product_upper = diss = None
    if products or envelope:
        lps.set_lam_range(lam_lower, lam_upper)
        try:
            found = lps.force_bounds(B, envelope, deadline)
        finally:
            lps.set_lam_range(-np.inf, np.inf)
        if found["complete"]:
            x_lower, x_upper = widen(found["x_lower"], found["x_upper"])
            product_lower, product_upper = widen(found["product_lower"], found["product_upper"])
            # exact signs: x_r <= 0 wherever the pair rows imply it (no LP round-off involved)
            nonpositive = lps.implied_nonpositive()
            x_upper[nonpositive] = np.minimum(x_upper[nonpositive], 0.0)
            product_upper = np.where(nonpositive[B.row], np.minimum(product_upper, 0.0), product_upper)
            if products:
                diss = lps.dissipation_minimum(B, np.minimum(x_upper[B.row], product_upper), deadline)
        else:
            product_lower = product_upper = None
    lower = max([lam_lower] + [v for v in (kin, diss) if v is not None])
    return MPECBounds(lam_associative=lam_assoc, lam_static_min=lam_min, lam_kinematic=kin, lam_dissipation=diss,
                      lam_lower=lower, lam_upper=lam_upper, slack_max=None, z_max=None, tau_max=None, x_lower=x_lower,
                      x_upper=x_upper, product_lower=product_lower, product_upper=product_upper,
                      x_associative=x_assoc, n_lps=lps.n_lps - n0, time_s=time.perf_counter() - t0)


def model_bounds(lps: BoundLPs, bd, per_pair_multipliers: bool, deadline: Deadline):
    """``bd`` with the model's bounds: ``slack_max`` over ``S ∩ {lam_static_min <= lam <= lam_upper}``, ``z_max``
    and ``tau_max`` over ``K`` with ``1^T z = 1`` (:meth:`BoundLPs.slack_bounds`,
    :meth:`BoundLPs.multiplier_bounds`); ``models_complete`` says whether every slack bound was proven in time
    (the big-M model needs them all; a multiplier bound not reached keeps its trivial value 1)."""
    t0, n0 = time.perf_counter(), lps.n_lps
    low = bd.lam_static_min - LP_MARGIN * max(1.0, abs(bd.lam_static_min))
    slack_max, slacks_done = lps.slack_bounds(low, bd.lam_upper, deadline)
    # a multiplier bound not reached stays the trivial 1 (valid): only the slack bounds decide completeness
    z_max, tau_max, _ = lps.multiplier_bounds(per_pair_multipliers, deadline)
    return dataclasses.replace(bd, slack_max=slack_max, z_max=z_max, tau_max=tau_max, models_complete=slacks_done,
                               n_lps=bd.n_lps + lps.n_lps - n0, time_s=bd.time_s + time.perf_counter() - t0)

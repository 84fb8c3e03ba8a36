r"""``milp``: certified global minimum of the MPEC (4) by a mixed-integer program.

With ``sense="max"`` the same machinery certifies the global *maximum* of ``lam``
over the solutions of the MCP (3) (the largest non-associative multiplier); see
"Maximisation" below.  Such a result is never the minimum of (4): it records
``extra["sense"] = "max"``.

Model: :mod:`blockmpec.formulations.mpec_bigm` (one binary per complementarity pair,
multipliers normalised by ``1^T z = 1`` so that ``z_i <= y_i`` is exact), built
with Pyomo and compiled by :func:`blockmpec.formulations.mpec_bigm.compile_mixed_integer`
(``compile_linear`` plus an integrality array read from ``v.is_binary()``);
solved by highspy directly (``HighsLp.integrality_``).

Run (all timed):

1. **Bounds by LPs.**  On the statically admissible set
   ``S = {E x + f_d + lam f_l = 0, N_u^T x <= 0, N_f^T x <= 0}``:
   ``lam_upper = max lam`` (the associative multiplier; the force part of every
   solution of (3) lies in ``S``) and ``lam_lower = min lam``; for each of the
   ``4c`` slacks ``s_i = -[N^T x]_i``, ``smax_i = max s_i`` over
   ``S ∩ {lam_lower <= lam <= lam_upper}`` (``slack_bounds="row"``), or from
   ``nmin_k = min n_k`` (``"normal"``): ``s_u <= -nmin L`` (the two rocking
   slacks add up to ``-n L``), ``s_f <= -2 tan(phi) nmin``.  Valid for every
   solution of (3).  ``M_i = bigm_scale (smax_i (1 + 1e-4) + 1e-6 max_j smax_j)``:
   with the margin a slack *at* ``M_i`` cannot happen under a proven bound, so it
   flags a too-small one.  ``smax_i = 0`` fixes ``y_i = 1``.  Further LPs give
   ``zmax_i = max z_i`` and ``tau_max`` on ``{compatibility, 1^T z = 1, z >= 0}``
   and ``lam_kinematic = min -f_d^T u`` on the non-associative kinematic set;
   ``lam >= max(lam_lower, lam_kinematic)``.  LP optima are widened by
   ``LP_MARGIN`` (relative) before use.  The LPs are solved cold: HiGHS warm
   re-solves after cost changes were measured to return wrong "optimal" values.
2. **Incumbent.**  If the associative optimum's active set admits a mechanism
   with the non-associative flow ``V_f``, that point solves (3) and is passed to
   HiGHS as a start (an upper bound only).
3. **MILP** with ``tau = f_l^T u >= 0``: a relaxation of (4), so HiGHS's dual
   bound is a certified lower bound on the minimum multiplier.
4. **Polish**: with the binaries' pattern fixed (``y_i = 1``: slack ``= 0``;
   ``y_i = 0``: ``z_i = 0``) two exact LPs give ``(lam, x)`` (min ``lam``) and
   ``(u, z)`` (``f_l^T u = 1``, min ``1^T z``); complementarity holds by
   construction, so the residuals are at round-off.  If the ``(u, z)`` LP is
   infeasible the relaxation's optimum had ``tau = 0`` (not a solution of (3)):
   status NUMERICAL with the lower bound in the message.

Status ``OPTIMAL`` only when HiGHS closed the gap (``mip_rel_gap`` or
``mip_abs_gap``, plus ``CERTIFICATE_TOL`` for the solver tolerances), no slack
sits at its big-M, ``bigm_scale >= 1`` (shrunken bounds are not proven, so they never
certify, even when no slack reaches them) and the polished multiplier does not
undercut the dual bound.
A slack at its big-M gives LOCALLY_OPTIMAL (the polished point solves (3), but
the certificate is void); a time limit gives TIME_LIMIT with the best polished
point and its gap.

Maximisation (``sense="max"``)
------------------------------
Every bound, cut and fixing above is a property of the *set* of solutions of
(3), not of the objective, so the MILP with ``tau >= 0`` is a relaxation for
either sense: HiGHS's dual bound is then an upper bound on the maximum.  In
detail: ``lam_upper`` (the associative multiplier) bounds every solution from
above and ``max(lam_lower, lam_kinematic)`` from below; the slack and multiplier
bounds and the fixed binaries hold at every solution; the associative-pattern
incumbent, when it exists, solves (3) and is feasible for both senses (for the
maximum it attains the upper bound ``lam_upper`` itself, so it is optimal); the
``tau = 0`` fallback re-solves the restriction ``tau >= tau_restart`` whose point
is a lower bound on the maximum while the relaxation's dual bound stays the
certified upper bound.  The polish maximises ``lam`` over the face of the
pattern (any point of the face, with the pattern's mechanism, solves (3)).  The
certificate flips: the polished multiplier must not *exceed* the dual bound,
and the gap is ``dual_bound - lam >= 0``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from blockmpec.registry import register_solver
from blockmpec.result import Solution, Status
from blockmpec.solver import RunOutput, SolverBase


@dataclass
class MILPOptions:
    """Options of the ``milp`` method."""

    time_limit: float = field(default=60.0, metadata={"help": "seconds for the whole run (bounds + MILP + polish)"})
    mip_rel_gap: float = field(default=1e-9, metadata={"help": "HiGHS relative gap |primal - dual| / |primal|"})
    mip_abs_gap: float = field(default=1e-9, metadata={"help": "HiGHS absolute gap on lam"})
    feasibility_tol: float = field(default=1e-9, metadata={
        "help": "HiGHS mip_ and primal_feasibility_tolerance (the dual bound is exact up to about this)"})
    bigm_scale: float = field(default=1.0, metadata={
        "help": "factor on the proven slack bounds (< 1 only to test detection; never certifies)"})
    slack_bounds: str = field(default="row", metadata={"help": "row: one LP per slack | normal: one LP per interface"})
    multiplier_bounds: bool = field(default=True, metadata={"help": "tighten z_i <= y_i to z_i <= zmax_i y_i by LPs"})
    incumbent: bool = field(default=True, metadata={
        "help": "start from the associative optimum when its active set admits a V_f mechanism"})
    warm_bounds: bool = field(default=False, metadata={
        "help": "warm-start the bound LPs (faster; HiGHS warm re-solves were measured to err, see _bounds)"})
    threads: int = field(default=1, metadata={"help": "HiGHS threads"})
    sense: str = field(default="min", metadata={
        "help": "min: the MPEC (4), min lam over solutions of (3) | max: max lam over the same set"})
    verbose: bool = field(default=False, metadata={"help": "print the HiGHS log"})

    def __post_init__(self) -> None:
        if not self.time_limit > 0:
            raise ValueError(f"time_limit must be > 0 seconds; got {self.time_limit}")
        if not 0 <= self.mip_rel_gap < 1:
            raise ValueError(f"mip_rel_gap must be in [0, 1); got {self.mip_rel_gap}")
        if not self.mip_abs_gap >= 0:
            raise ValueError(f"mip_abs_gap must be >= 0; got {self.mip_abs_gap}")
        if not 1e-12 <= self.feasibility_tol <= 1e-4:
            raise ValueError(f"feasibility_tol must be in [1e-12, 1e-4]; got {self.feasibility_tol}")
        if not (self.bigm_scale > 0 and np.isfinite(self.bigm_scale)):
            raise ValueError(f"bigm_scale must be a finite number > 0; got {self.bigm_scale}")
        if self.sense not in ("min", "max"):
            raise ValueError(f"sense must be 'min' or 'max'; got {self.sense!r}")
        if self.slack_bounds not in ("row", "normal"):
            raise ValueError(f"slack_bounds must be 'row' or 'normal'; got {self.slack_bounds!r}")
        for name in ("multiplier_bounds", "incumbent", "warm_bounds", "verbose"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name} must be True or False; got {getattr(self, name)!r}")
        if isinstance(self.threads, bool) or not isinstance(self.threads, int) or self.threads < 1:
            raise ValueError(f"threads must be an integer >= 1; got {self.threads!r}")


#: relative margin and absolute margin (times the largest bound) added to proven slack bounds
BOUND_MARGIN_REL = 1e-4
BOUND_MARGIN_ABS = 1e-6
#: relative widening of LP-derived bounds on lam (round-off of the LP optima)
LP_MARGIN = 1e-6
#: HiGHS solves the MILP to its feasibility tolerances (option feasibility_tol), so its dual bound and
#: the exact (polished) multiplier of the same pattern may differ by about this much (times
#: max(1, |lam|)) without any real gap; a larger difference voids the certificate.
CERTIFICATE_TOL = 1e-7
#: a slack within this (times the largest bound) of its M is "at its bound"
ACTIVE_TOL = 1e-7


@register_solver
class MILPSolver(SolverBase):
    """Global minimum (or, ``sense="max"``, maximum) of the non-associative multiplier by a big-M MILP (HiGHS).

    ``certifies_minimum``: status OPTIMAL with ``sense="min"`` (``extra["sense"] == "min"``)
    is a proven global minimum of (4).  With ``sense="max"`` OPTIMAL certifies the
    maximum instead; the comparator must not take it as the minimum.
    """

    name = "milp"
    problem = "non-associative"
    summary = ("certified global minimum of the MPEC (4) (sense=max: maximum of lam over solutions of (3)): "
               "big-M MILP with LP-proven bounds, HiGHS")
    certifies_minimum = True
    requires = ("highspy", "pyomo")
    Options = MILPOptions

    def setup(self, ops):
        import dataclasses

        from blockmpec.formulations import compile_linear, kinematic_lp, static_lp
        from blockmpec.formulations.mpec_bigm import mpec_bigm
        from blockmpec.solvers.engines.highs import HighsLP

        self.ops = ops
        self.problem_milp = mpec_bigm(ops, sense=self.options.sense)
        self.static = compile_linear(static_lp(ops))
        # the non-associative kinematic LP: flow by V_f (tan psi)
        self.kinematic = compile_linear(kinematic_lp(dataclasses.replace(ops, N_f=ops.V_f)))
        self.bound_lp = HighsLP(self.static, "dual-simplex")
        self.polish_static = HighsLP(self.static, "dual-simplex")
        self.polish_kinematic = HighsLP(self.kinematic, "dual-simplex")
        self.kinematic_bound = HighsLP(self.kinematic, "dual-simplex")

    # ------------------------------------------------------------------ bounds
    def _bounds(self, deadline: float) -> tuple[str | None, dict]:
        """LP bounds on lam and on every slack; returns (failure message or None, data)."""
        import scipy.sparse as sp

        ops, lp, hl = self.ops, self.static, self.bound_lp
        h = hl.highs
        lam_col = int(lp.columns["lam"][0])
        x_cols = lp.columns["x"]
        n_col = lp.c.size
        out = {}
        n_lp = 0

        def solve_with_cost(cost: np.ndarray):
            nonlocal n_lp
            h.changeColsCost(n_col, np.arange(n_col, dtype=np.int32), cost)
            # HiGHS measures time_limit on the instance's cumulative run clock
            h.setOptionValue("time_limit", h.getRunTime() + max(deadline - time.perf_counter(), 1e-3))
            n_lp += 1
            if not self.options.warm_bounds:
                h.clearSolver()
            return hl.solve()

        cost = np.zeros(n_col)
        cost[lam_col] = -1.0
        up = solve_with_cost(cost)
        if up.status is not Status.OPTIMAL:
            return f"associative LP (max lam): {up.status.value}", {"lp_status": up.status}
        cost[lam_col] = 1.0
        lo = solve_with_cost(cost)
        if lo.status is not Status.OPTIMAL:
            return (f"min lam over the statically admissible set is {lo.status.value}: the slacks have no "
                    "LP bound, so no valid big-M exists", {"lp_status": lo.status})
        # widen by a round-off margin: the LP optima are exact only up to HiGHS's tolerances
        lam_upper, lam_lower = float(up.v[lam_col]), float(lo.v[lam_col])
        out["lam_associative"], out["lam_static_min"] = lam_upper, lam_lower
        out["x_associative"] = lp.values("x", up.v)
        lam_upper += LP_MARGIN * max(1.0, abs(lam_upper))
        lam_lower -= LP_MARGIN * max(1.0, abs(lam_lower))
        h.changeColBounds(lam_col, lam_lower, lam_upper)
        # Bound LPs are solved cold by default (warm_bounds=False): measured on a 160-block arch, warm
        # *primal* simplex re-solves (HiGHS 1.15) returned "optimal" slack maxima up to 0.02 below the cold
        # optimum (an invalid big-M), and a warm dual simplex returned a wrong max z_i (1.0, cold 0.5).
        hl.algorithm = "dual-simplex"
        c = ops.n_interfaces
        NT = sp.vstack([ops.N_u.T, ops.N_f.T], format="csr")
        if self.options.slack_bounds == "row":
            smax = np.empty(4 * c)
            for i in range(4 * c):
                a, b = NT.indptr[i], NT.indptr[i + 1]
                cost = np.zeros(n_col)
                cost[x_cols[NT.indices[a:b]]] = NT.data[a:b]  # min [N^T x]_i = -max s_i
                r = solve_with_cost(cost)
                if r.status is not Status.OPTIMAL:
                    return f"slack bound LP {i}: {r.status.value} ({r.raw_status})", {"lp_status": r.status}
                smax[i] = max(-r.objective, 0.0)
        else:
            nmin = np.empty(c)
            for k in range(c):
                cost = np.zeros(n_col)
                cost[x_cols[3 * k + 1]] = 1.0
                r = solve_with_cost(cost)
                if r.status is not Status.OPTIMAL:
                    return f"normal-force bound LP {k}: {r.status.value}", {"lp_status": r.status}
                nmin[k] = min(r.objective, 0.0)
            smax = np.concatenate([np.repeat(-nmin * ops.length, 2), np.repeat(-2.0 * ops.friction * nmin, 2)])
        h.changeColBounds(lam_col, -np.inf, np.inf)
        if self.options.multiplier_bounds:
            zmax = self._multiplier_bounds(deadline)
            out["zmax"] = zmax
            n_lp += zmax.size
        self.kinematic_bound.highs.clearSolver()
        kin = self.kinematic_bound.solve()
        out["lam_kinematic"] = (kin.objective - LP_MARGIN * max(1.0, abs(kin.objective))
                                if kin.status is Status.OPTIMAL else None)
        out.update(lam_upper=lam_upper, lam_lower=lam_lower, smax=smax, n_bound_lps=n_lp)
        return None, out

    def _multiplier_bounds(self, deadline: float) -> np.ndarray:
        """``max z_i`` over ``{E^T u + N_u z_u + V_f z_f = 0, 1^T z = 1, z >= 0}``, one LP per pair."""
        import highspy
        import scipy.sparse as sp

        ops = self.ops
        c, b3 = ops.n_interfaces, ops.E.shape[0]
        nz = 4 * c
        A = sp.vstack([sp.hstack([ops.E.T, ops.N_u, ops.V_f]),
                       sp.hstack([sp.csr_array((1, b3)), sp.csr_array(np.ones((1, nz)))])], format="csc")
        h = highspy.Highs()
        h.setOptionValue("output_flag", False)
        h.setOptionValue("simplex_strategy", 1)  # dual: see the note in _bounds
        lp = highspy.HighsLp()
        lp.num_col_, lp.num_row_ = A.shape[1], A.shape[0]
        lp.col_cost_ = np.zeros(A.shape[1])
        lp.col_lower_ = np.concatenate([np.full(b3, -np.inf), np.zeros(nz)])
        lp.col_upper_ = np.concatenate([np.full(b3, np.inf), np.ones(nz)])
        rhs = np.zeros(A.shape[0])
        rhs[-1] = 1.0
        lp.row_lower_, lp.row_upper_ = rhs, rhs
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_, lp.a_matrix_.index_, lp.a_matrix_.value_ = A.indptr, A.indices, A.data
        h.passModel(lp)
        zmax = np.ones(nz + 1)
        # tau_max = max f_l^T u (last entry)
        h.changeColsCost(b3, np.arange(b3, dtype=np.int32), -ops.f_l)
        h.run()
        zmax[nz] = -h.getInfo().objective_function_value if h.getModelStatus().name == "kOptimal" else np.inf
        h.changeColsCost(b3, np.arange(b3, dtype=np.int32), np.zeros(b3))
        for i in range(nz):
            h.changeColCost(b3 + i, -1.0)
            if i:
                h.changeColCost(b3 + i - 1, 0.0)
            h.setOptionValue("time_limit", h.getRunTime() + max(deadline - time.perf_counter(), 1e-3))
            if not self.options.warm_bounds:
                h.clearSolver()
            h.run()
            if h.getModelStatus().name == "kOptimal":
                zmax[i] = min(1.0, -h.getInfo().objective_function_value)
            # otherwise keep the trivial bound 1
        return zmax

    # ------------------------------------------------------------------ polish
    def _mechanism(self, active: np.ndarray):
        """``(u, z_u, z_f)`` with ``f_l^T u = 1`` and ``z_i = 0`` off ``active`` (min ``1^T z``), or None."""
        kp = self.kinematic
        hk = self.polish_kinematic
        g = hk.highs
        zcols = np.concatenate([kp.columns["z_u"], kp.columns["z_f"]]).astype(np.int32)
        upper = np.where(active, np.inf, 0.0)
        g.changeColsBounds(zcols.size, zcols, np.zeros(zcols.size), upper)
        cost = np.zeros(kp.c.size)
        cost[zcols] = 1.0
        g.changeColsCost(cost.size, np.arange(cost.size, dtype=np.int32), cost)
        ru = hk.solve()
        if ru.status is not Status.OPTIMAL:
            return None
        return kp.values("u", ru.v), kp.values("z_u", ru.v), kp.values("z_f", ru.v)

    def _polish(self, active_u: np.ndarray, active_f: np.ndarray):
        """Exact LPs for the pattern; returns (Solution or None, message)."""
        # (lam, x): min lam (sense="max": max lam), slack = 0 on active rows
        lp = self.static
        hl = self.polish_static
        h = hl.highs
        rows = np.concatenate([lp.rows["unilateral"], lp.rows["friction"]]).astype(np.int32)
        active = np.concatenate([active_u, active_f])
        lower = np.where(active, 0.0, -np.inf)
        h.changeRowsBounds(rows.size, rows, lower, np.zeros(rows.size))
        cost = np.zeros(lp.c.size)
        cost[lp.columns["lam"][0]] = 1.0 if self.options.sense == "min" else -1.0
        h.changeColsCost(cost.size, np.arange(cost.size, dtype=np.int32), cost)
        rx = hl.solve()
        if rx.status is not Status.OPTIMAL:
            return None, f"polish LP for (lam, x) is {rx.status.value}"
        # (u, z): f_l^T u = 1, z_i = 0 off the pattern, min 1^T z
        mech = self._mechanism(active)
        if mech is None:
            return None, ("polish LP for (u, z) is infeasible: the pattern admits no mechanism with "
                          "f_l^T u > 0 (the relaxation's optimum has tau = 0)")
        u, z_u, z_f = mech
        sol = Solution(multiplier=float(lp.values("lam", rx.v)[0]), x=lp.values("x", rx.v), u=u, z_u=z_u, z_f=z_f)
        return sol, ""

    def _associative_incumbent(self, bd: dict):
        """A solution of (3) at the associative optimum, if its active set admits a V_f mechanism.

        The associative LP's ``(lam, x)`` is statically admissible; with ``z`` allowed
        only on its active constraints, any ``(u, z)`` of the compatibility LP makes
        the triple a solution of (3) (an upper bound on the minimum; for the maximum it
        attains the upper bound ``lam_associative``, so it is the maximum), else None.
        """
        ops = self.ops
        x = bd["x_associative"]
        slack = -np.concatenate([ops.N_u.T @ x, ops.N_f.T @ x])
        active = slack <= 1e-9 * max(1.0, float(np.abs(slack).max(initial=0.0)))
        mech = self._mechanism(active)
        if mech is None:
            return None
        u, z_u, z_f = mech
        return Solution(multiplier=bd["lam_associative"], x=x, u=u, z_u=z_u, z_f=z_f)

    # ------------------------------------------------------------------ run
    def run(self) -> RunOutput:
        import highspy

        from blockmpec.formulations.mpec_bigm import compile_mixed_integer

        opt = self.options
        maximise = opt.sense == "max"
        # "bound" is the dual bound's side: a lower bound on the minimum, an upper bound on the maximum
        bound_word = "upper" if maximise else "lower"
        t_start = time.perf_counter()
        deadline = t_start + opt.time_limit
        ops = self.ops
        c = ops.n_interfaces
        fail, bd = self._bounds(deadline)
        t_bounds = time.perf_counter() - t_start
        if fail:
            st = bd.get("lp_status", Status.ERROR)
            st = st if st in (Status.UNBOUNDED, Status.INFEASIBLE, Status.TIME_LIMIT) else Status.ERROR
            return RunOutput(st, message=fail, extra={"bound_time_s": t_bounds, "sense": opt.sense})
        smax = bd["smax"]
        scale = float(max(smax.max(), 1e-300))
        proven = smax * (1.0 + BOUND_MARGIN_REL) + BOUND_MARGIN_ABS * scale
        M = opt.bigm_scale * proven
        M_u, M_f = M[: 2 * c], M[2 * c:]

        m = self.problem_milp.model
        for i in range(2 * c):
            m.M_u[i] = float(M_u[i])
            m.M_f[i] = float(M_f[i])
        m.lam_lower = bd["lam_lower"]
        m.lam_upper = bd["lam_upper"]
        m.tau_min = 0.0
        tau_max = bd.get("zmax", [np.inf])[-1]
        if np.isfinite(tau_max):
            m.tau_max = float(tau_max * (1.0 + BOUND_MARGIN_REL))
            m.work_mccormick.activate()
        zmax = bd.get("zmax", np.ones(4 * c + 1))[:-1] * (1.0 + BOUND_MARGIN_REL) + BOUND_MARGIN_ABS
        zmax = np.minimum(zmax, 1.0)
        for i in range(2 * c):
            m.zmax_u[i] = float(zmax[i])
            m.zmax_f[i] = float(zmax[2 * c + i])
        if bd.get("lam_kinematic") is not None:
            m.lam_kinematic = bd["lam_kinematic"]
            m.dead_work_lower.activate()
            m.lam_lower = max(bd["lam_lower"], bd["lam_kinematic"])
        t0 = time.perf_counter()
        lp, integrality = compile_mixed_integer(self.problem_milp)
        t_compile = time.perf_counter() - t0
        # HiGHS minimises lp.c^T v = sign * lam (sign = -1 for the maximum); lam-space value = sign * objective
        sign = float(lp.objective_sign)
        y_cols = np.concatenate([lp.columns["y_u"], lp.columns["y_f"]])
        fixed_active = smax <= 1e-12 * scale  # constraint active on all of S: y_i = 1
        lp.col_lower[y_cols[fixed_active]] = 1.0
        fixed_idle = (bd["zmax"][:-1] <= 1e-12) & ~fixed_active if "zmax" in bd else np.zeros(4 * c, bool)
        lp.col_upper[y_cols[fixed_idle]] = 0.0  # z_i = 0 in every normalised mechanism: y_i = 0

        h = highspy.Highs()
        h.setOptionValue("output_flag", bool(opt.verbose))
        h.setOptionValue("threads", int(opt.threads))
        h.setOptionValue("mip_rel_gap", float(opt.mip_rel_gap))
        h.setOptionValue("mip_abs_gap", float(opt.mip_abs_gap))
        h.setOptionValue("mip_feasibility_tolerance", float(opt.feasibility_tol))
        h.setOptionValue("primal_feasibility_tolerance", float(opt.feasibility_tol))
        h.setOptionValue("time_limit", float(max(deadline - time.perf_counter(), 1e-3)))
        A = lp.A.tocsc()
        model = highspy.HighsLp()
        model.num_col_, model.num_row_ = A.shape[1], A.shape[0]
        model.col_cost_ = lp.c
        model.col_lower_, model.col_upper_ = lp.col_lower, lp.col_upper
        model.row_lower_, model.row_upper_ = lp.row_lower, lp.row_upper
        model.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        model.a_matrix_.start_ = A.indptr
        model.a_matrix_.index_ = A.indices
        model.a_matrix_.value_ = A.data
        model.integrality_ = [highspy.HighsVarType.kInteger if k else highspy.HighsVarType.kContinuous
                              for k in integrality]
        h.passModel(model)
        incumbent = self._associative_incumbent(bd) if opt.incumbent else None
        if incumbent is not None:
            # the same point in the MILP's normalisation 1^T z = 1
            z = np.concatenate([incumbent.z_u, incumbent.z_f])
            scale_z = float(z.sum())
            v0 = np.zeros(lp.c.size)
            for group, val in (("lam", [incumbent.multiplier]), ("x", incumbent.x), ("u", incumbent.u / scale_z),
                               ("z_u", incumbent.z_u / scale_z), ("z_f", incumbent.z_f / scale_z),
                               ("y_u", (incumbent.z_u > 0).astype(float)), ("y_f", (incumbent.z_f > 0).astype(float)),
                               ("tau", [1.0 / scale_z])):
                cols = lp.columns[group]
                v0[cols[cols >= 0]] = np.asarray(val, float)[cols >= 0]
            start = highspy.HighsSolution()
            start.col_value = v0.tolist()
            start.value_valid = True
            h.setSolution(start)
        t1 = time.perf_counter()
        h.run()
        t_milp = time.perf_counter() - t1
        raw = h.getModelStatus()
        raw_name = raw.name
        info = h.getInfo()
        nodes = int(info.mip_node_count)
        dual_bound = sign * float(info.mip_dual_bound)  # in lam: <= min lam (min), >= max lam (max)
        extra = {
            "sense": opt.sense,
            "lam_upper_associative": bd["lam_associative"],
            "lam_lower_static": bd["lam_static_min"],
            "lam_lower_kinematic": bd.get("lam_kinematic"),
            "tau_max": float(bd.get("zmax", [np.nan])[-1]),
            "bigm_unilateral": M_u.tolist(),
            "bigm_friction": M_f.tolist(),
            "bigm_scale": opt.bigm_scale,
            "multiplier_bound": "exact: 1^T z = 1 normalisation, z_i <= y_i",
            "n_binaries": int(integrality.sum()),
            "n_fixed_binaries": int(fixed_active.sum() + fixed_idle.sum()),
            "n_bound_lps": bd["n_bound_lps"],
            "bound_time_s": t_bounds,
            "compile_time_s": t_compile,
            "milp_time_s": t_milp,
            "nodes": nodes,
            "dual_bound": dual_bound,
            "mip_gap": float(info.mip_gap),
            "bigm_active": [],
            "incumbent_associative": None if incumbent is None else incumbent.multiplier,
        }
        trace = [{"iteration": 0, "time_s": t_bounds, "stage": "bounds", "multiplier": bd["lam_upper"]},
                 {"iteration": 1, "time_s": time.perf_counter() - t_start, "stage": "milp",
                  "multiplier": sign * float(info.objective_function_value), "dual_bound": dual_bound,
                  "nodes": nodes}]
        has_point = int(info.primal_solution_status) == 2
        if raw_name == "kInfeasible" or not has_point:
            if raw_name == "kInfeasible":
                if opt.bigm_scale < 1:
                    msg = (f"the MILP is infeasible with bigm_scale = {opt.bigm_scale} < 1: the scaled slack "
                           "bounds cut off every solution of (3); the proven bounds (bigm_scale = 1) are needed")
                    st = Status.INFEASIBLE
                else:
                    msg = ("HiGHS reports the MILP infeasible although its bounds are proven valid for every "
                           "solution of (3): a numerical failure (tolerances), not a proof of infeasibility")
                    st = Status.NUMERICAL
            elif raw_name == "kTimeLimit" and incumbent is not None:
                extra["gap_abs"] = max(0.0, sign * (incumbent.multiplier - dual_bound))
                return RunOutput(Status.TIME_LIMIT, incumbent, nodes, trace,
                                 f"time limit: the associative-pattern solution lam {incumbent.multiplier:.10g}, "
                                 f"dual bound {dual_bound:.10g}", raw_name, extra)
            elif raw_name == "kTimeLimit":
                msg, st = "time limit before any feasible point", Status.TIME_LIMIT
            else:
                msg, st = f"HiGHS: {h.modelStatusToString(raw)}", Status.ERROR
            return RunOutput(st, Solution(), nodes, trace, msg, raw_name, extra)

        v = np.asarray(h.getSolution().col_value, float)
        active = np.concatenate([lp.values("y_u", v), lp.values("y_f", v)]) >= 0.5
        if self._mechanism(active) is None and time.perf_counter() < deadline:
            # The relaxation's optimum has tau = 0 (no mechanism with f_l^T u > 0 for its pattern).  Its
            # dual bound stays the certified bound (lower for min, upper for max); re-solve the
            # restriction tau >= tau_restart, whose points all solve (3), for a point on the other side.
            tau_restart = 1e-6 * (bd["zmax"][-1] if np.isfinite(bd.get("zmax", [np.inf])[-1]) else 1.0)
            h.changeColBounds(int(lp.columns["tau"][0]), float(tau_restart), highspy.kHighsInf)
            h.setOptionValue("time_limit", h.getRunTime() + max(deadline - time.perf_counter(), 1e-3))
            h.run()
            raw = h.getModelStatus()
            raw_name = raw.name
            info2 = h.getInfo()
            extra["tau_restart"] = tau_restart
            extra["restart_nodes"] = int(info2.mip_node_count)
            if int(info2.primal_solution_status) != 2:
                return RunOutput(Status.NUMERICAL, Solution(), nodes, trace,
                                 f"the relaxation's optimum has tau = 0 and the restriction tau >= {tau_restart:.3g} "
                                 f"found no point ({raw_name}); the MILP {bound_word} bound {dual_bound:.10g} stands",
                                 raw_name, extra)
            v = np.asarray(h.getSolution().col_value, float)
        y = np.concatenate([lp.values("y_u", v), lp.values("y_f", v)])
        x_milp = lp.values("x", v)
        slack = -np.concatenate([ops.N_u.T @ x_milp, ops.N_f.T @ x_milp])
        off = y < 0.5
        at_bound = off & (slack >= M - ACTIVE_TOL * opt.bigm_scale * scale)
        extra["bigm_active"] = np.flatnonzero(at_bound).tolist()
        extra["milp_multiplier"] = float(lp.values("lam", v)[0])
        extra["tau"] = float(lp.values("tau", v)[0])
        active = y >= 0.5
        sol, pmsg = self._polish(active[: 2 * c], active[2 * c:])
        extra["n_active_pairs"] = int(active.sum())
        if sol is None:
            return RunOutput(Status.NUMERICAL, Solution(), nodes, trace,
                             f"{pmsg}; the MILP {bound_word} bound {dual_bound:.10g} stands", raw_name, extra)
        lam = sol.multiplier
        extra["polished_minus_milp"] = lam - extra["milp_multiplier"]
        gap_abs = max(0.0, sign * (lam - dual_bound))  # min: lam - bound; max: bound - lam
        extra["gap_abs"] = gap_abs
        extra["gap_rel"] = gap_abs / max(abs(lam), 1e-12)
        trace.append({"iteration": 2, "time_s": time.perf_counter() - t_start, "stage": "polish",
                      "multiplier": lam, "dual_bound": dual_bound})
        tol = CERTIFICATE_TOL * max(1.0, abs(lam))
        closed = gap_abs <= max(opt.mip_abs_gap, opt.mip_rel_gap * abs(lam)) + tol
        # a point of (3) beyond the relaxation's bound (below it for min, above it for max) is impossible
        undercut = sign * (lam - dual_bound) < -tol
        if raw_name == "kOptimal" and closed and not undercut:
            st, msg = Status.OPTIMAL, (f"certified global {'maximum' if maximise else 'minimum'}; "
                                       f"gap {gap_abs:.2e}, {nodes} nodes")
        elif raw_name == "kTimeLimit":
            st, msg = Status.TIME_LIMIT, f"time limit: best lam {lam:.10g}, dual bound {dual_bound:.10g}"
        elif undercut:
            st = Status.NUMERICAL
            msg = (f"the polished point lam {lam:.10g} {'exceeds' if maximise else 'undercuts'} the MILP dual "
                   f"bound {dual_bound:.10g}: certificate void")
        elif raw_name == "kOptimal":
            st = Status.LOCALLY_OPTIMAL
            msg = (f"HiGHS optimal but the polished lam {lam:.10g} and the dual bound {dual_bound:.10g} differ "
                   f"by {gap_abs:.2e}")
            if "tau_restart" in extra:
                msg += (f" (the relaxation's optimum had tau = 0; lam is the {opt.sense}imum over tau >= "
                        f"{extra['tau_restart']:.3g}, not certified globally)")
        else:
            st, msg = Status.ERROR, f"HiGHS: {h.modelStatusToString(raw)}"
        if extra["bigm_active"]:
            # the point solves (3) (polished), but the bounds that define the MILP were too small
            st = Status.TIME_LIMIT if raw_name == "kTimeLimit" else Status.LOCALLY_OPTIMAL
            msg = (f"{len(extra['bigm_active'])} slack(s) at their big-M bound (bigm_scale = {opt.bigm_scale}): "
                   f"the point solves (3) but the certificate of global {'maxim' if maximise else 'minim'}ality "
                   f"is void. {msg}")
        elif opt.bigm_scale < 1 and st is Status.OPTIMAL:
            # No slack reached its (shrunken) M, but the MILP was solved over a restriction of the solution
            # set of (3): a better point may lie in the cut-off part, so nothing is certified.
            st = Status.LOCALLY_OPTIMAL
            msg = (f"bigm_scale = {opt.bigm_scale} < 1: the slack bounds are not proven, so the certificate of "
                   f"global {'maxim' if maximise else 'minim'}ality is void (no slack reached them). {msg}")
        return RunOutput(st, sol, nodes, trace, msg, raw_name, extra)

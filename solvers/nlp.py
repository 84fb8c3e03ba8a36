r"""``nlp``: the MPEC (4) by a relaxed-complementarity NLP (Ferris & Tin-Loi 2001 style).

Problem.  The MPEC (4) is ``min lam`` over the solutions of the MCP (3), read from its compiled formulation
(:func:`blockmpec.formulations.compile_mcp`: ``A w = rhs``, pair rows ``G w <= 0``, multipliers
``z = w[pair_column]``), with the pair slacks ``s = -G w`` as extra variables; the NLP's variables are
``v = (w, s)``, ``w = (lam, x, u, z)``::

    min  lam
    s.t. A w = rhs                              (equilibrium, compatibility, normalisation)
         G w + s = 0                            (slack definitions, 4c rows)
         z_i s_i / P <= eps                     (relaxed complementarity, 4c rows)
         z >= 0, s >= 0

(Scholtes relaxation), ``P = max(z^0) * max(s^0)`` the product of the typical magnitudes of ``z`` and ``s`` at the
start, each in its pair's units, so ``eps`` is scale-free.  ``eps`` runs from ``eps_initial`` down to
``eps_final`` by the factor ``eps_factor``, each stage warm-started from the one before (primal point and, with the
setting ``warm_start``, Ipopt's multipliers; a failed warm stage is tried once more without them).

Units.  Ipopt solves in the units of :meth:`LoadUnits.mcp <blockmpec.solvers.engines.scaling.LoadUnits.mcp>`:
block ``i``'s equilibrium rows over its load ``l_i``, interface ``k``'s forces in ``(l_k, l_k, l_k L_k)``, the
mechanism and multipliers in the reciprocal units, each slack in the reciprocal unit of its multiplier, so
``z^_i s^_i = z_i s_i`` (a work in ``lam`` units) and Ipopt's absolute tolerances hold block by block.  An interface
with ``tan(phi) = 0`` has ``t_k`` fixed at 0 (its pair rows ``+-t_k <= 0`` force it).

Ipopt (through cyipopt) gets exact sparse derivatives: the Jacobian is the constant matrix of the linear rows plus
``s_i/P`` and ``z_i/P`` per product row, the Hessian of the Lagrangian ``y_i / P`` on each ``(z_i, s_i)``.  It runs
with ``mumps_pivtol = 1e-8``, ``mu_strategy = adaptive`` and ``bound_relax_factor = min(1e-8, eps/10)`` (its bound
relaxation must not exceed ``eps``); ``ipopt_options`` override them.  Within a stage the time limit is Ipopt's
``max_wall_time`` and the iteration callback, which stops Ipopt once the time left is shorter than its longest
iteration so far.  A :class:`~blockmpec.solvers.engines.stopping.StoppingCriterion` writes one trace record per
Ipopt solve.

Penalty NLP (``complementarity="penalty"``, Leyffer, López-Calva & Nocedal 2006): the product rows become the term
``rho sum_i z^_i s^_i`` of the objective (``rho`` dimensionless), so every row is linear; ``rho`` runs from
``penalty`` up by ``penalty_factor`` (at most ``penalty_stages`` stages) until every ``z^_i s^_i <= eps_final P``.
Ipopt then runs with ``mu_strategy = monotone`` and ``mu_init = bound_push = bound_frac = 1e-6`` (the start
already satisfies the linear rows).

Starts (``start``): ``"associative"`` (the static LP's solution, which satisfies every row but the non-associative
flow rule; its multiplier bounds every solution of (3) above, so ``lam_NA_min <= lam_nlp <= lam_assoc``),
``"cold"`` (Ipopt's push from 0) or ``"fixed-point"`` (the registered method's solution of (3), its time counted
in this run).  The NLP finds a *local* minimum of (4).

Finishing.  With the setting ``polish`` a few semismooth Newton steps on (3) make the last stage's products
``z_i s_i`` exact zeros (kept only if Newton converged and ``lam`` moved by at most ``1e-6 max(1, |lam|)``).  With
the stages' point is then finished on its pattern (:func:`~blockmpec.solvers.engines.exact_point.exact_solution`:
the piece LPs with every pair's zero side fixed as the point has it), so the reported ``lam`` is that of an exact
solution of (3).  With the setting ``piece_lp`` (and always on the ``pieces`` route) the point goes to
:func:`~blockmpec.solvers.engines.piece_lp.piece_descent`: with every pair's zero side fixed, (4) is an LP whose
minimiser solves (3) exactly; its static half's duals certify a local minimum of (4) (checked, not assumed).  After
the stages its point is kept only when certified and its ``lam`` is not higher.

Route (``route``): ``"ipopt"`` runs the stages above; ``"pieces"`` sends the fixed point's solution of (3) straight
to the piece LPs, whatever ``start`` says; ``"auto"`` takes ``"pieces"`` from
:data:`~blockmpec.solvers.plan.NLP_PIECE_ROUTE_BLOCKS` free blocks on (``docs/methods/nlp.md``
gives the measurements).  The run's stages are its :func:`~blockmpec.solvers.plan.nlp_plan`.

Status: ``LOCALLY_OPTIMAL`` when Ipopt solved every stage (or the piece LPs certified their point), ``ACCEPTABLE``
when some stage ended at Ipopt's "solved to acceptable level", otherwise the stage's failure
(``ITERATION_LIMIT``, ``TIME_LIMIT``, ``NUMERICAL`` or ``ERROR``) with the last iterate; on the ``pieces`` route,
the piece LPs' limit, or ``CONVERGED`` with their best point when its certificate fails (an exact solution of (3),
not proven a local minimum).  Ipopt's "Infeasible_Problem_Detected" is local, so it
maps to ``NUMERICAL``; only an infeasible associative start LP gives ``INFEASIBLE``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from blockmpec import options as check
from blockmpec.method import SolverBase
from blockmpec.options import CommonOptions
from blockmpec.registry import register_solver
from blockmpec.result import RunOutput, Solution, Status
from blockmpec.solvers import plan

#: Ipopt ApplicationReturnStatus -> (our status, short name)
_IPOPT_STATUS = {
    0: (Status.LOCALLY_OPTIMAL, "Solve_Succeeded"),
    1: (Status.ACCEPTABLE, "Solved_To_Acceptable_Level"),
    # Ipopt converged to a point of local infeasibility of the relaxed NLP: no proof
    # that (3) has no solution (e.g. eta = 0.05, mu = 100, where milp certifies one)
    2: (Status.NUMERICAL, "Infeasible_Problem_Detected"),
    3: (Status.ERROR, "Search_Direction_Becomes_Too_Small"),
    4: (Status.ERROR, "Diverging_Iterates"),
    5: (Status.ERROR, "User_Requested_Stop"),
    6: (Status.ERROR, "Feasible_Point_Found"),
    -1: (Status.ITERATION_LIMIT, "Maximum_Iterations_Exceeded"),
    -2: (Status.ERROR, "Restoration_Failed"),
    -3: (Status.ERROR, "Error_In_Step_Computation"),
    -4: (Status.TIME_LIMIT, "Maximum_CpuTime_Exceeded"),
    -5: (Status.TIME_LIMIT, "Maximum_WallTime_Exceeded"),
    -10: (Status.ERROR, "Not_Enough_Degrees_Of_Freedom"),
    -11: (Status.ERROR, "Invalid_Problem_Definition"),
    -12: (Status.ERROR, "Invalid_Option"),
    -13: (Status.ERROR, "Invalid_Number_Detected"),
}

_INF = 1e20
#: Ipopt's User_Requested_Stop: returned when :meth:`RelaxedMPEC.intermediate` keeps the deadline
_USER_STOP = 5
#: penalty NLP: Ipopt's mu_init, bound_push and bound_frac of the first stage (measured on the 10x10 wall
#: from the fixed point: 86 iterations, against 315 with Ipopt's defaults and adaptive mu)
_PENALTY_MU_INIT = 1e-6
STARTS = ("associative", "cold", "fixed-point")
COMPLEMENTARITY = ("relaxed", "penalty")
PIECE_LPS = ("split", "whole")
ROUTES = plan.NLP_ROUTES

#: starts taken from a registered method's solution: (method, its options); the associative start is
#: the static LP's solution, the fixed-point start a solution of (3)
_START_METHODS = {"associative": ("static-lp", {}), "fixed-point": ("fixed-point", {})}

#: statuses of a start method whose solution the NLP may start from
_USABLE_START = (Status.OPTIMAL, Status.CONVERGED, Status.LOCALLY_OPTIMAL, Status.ACCEPTABLE)


@dataclass
class NLPOptions(CommonOptions):
    """Options of the relaxed-complementarity NLP."""

    eps_initial: float = field(default=1e-4, metadata={"help": "relaxation of the first stage (scale-free)"})
    eps_final: float = field(default=1e-9, metadata={"help": "relaxation of the last stage"})
    eps_factor: float = field(default=0.1, metadata={"help": "eps of the next stage = factor * eps, in (0, 1)"})
    start: str = field(default="associative", metadata={
        "help": "associative (the static LP's solution) | cold (Ipopt's default push from 0) | fixed-point (the "
                "fixed point's solution of (3), its time counted in this run)"})
    complementarity: str = field(default="relaxed", metadata={
        "help": "relaxed (Scholtes rows z_i s_i <= eps, eps schedule) | penalty (min lam + rho sum z_i s_i)"})
    route: str = field(default="auto", metadata={
        "help": "auto (pieces from 100 free blocks on, else ipopt) | ipopt (the relaxed NLP stages) | pieces (the "
                "fixed point's solution of (3) to exact piece LPs that certify a local minimum of (4))"})

    def __post_init__(self) -> None:
        super().__post_init__()
        check.positive(self, "eps_initial", "eps_final")
        if self.eps_final > self.eps_initial:
            raise ValueError(f"eps_final ({self.eps_final}) must be <= eps_initial ({self.eps_initial})")
        check.interval(self, "eps_factor", 0, 1)
        check.choice(self, "start", STARTS)
        check.choice(self, "complementarity", COMPLEMENTARITY)
        check.choice(self, "route", ROUTES)


@dataclass
class NLPSettings:
    """Engine settings of ``nlp`` (experiments: ``studies/lab``).

    Attributes
    ----------
    max_iter : int
        Ipopt iterations per stage.
    tol : float
        Ipopt's ``tol``.
    warm_start : bool
        Pass Ipopt the previous stage's multipliers (``warm_start_init_point``).
    polish, polish_iterations : bool, int
        Finish with semismooth Newton steps on (3) from the last stage (kept only if ``lam`` moves <= 1e-6).
    penalty, penalty_factor, penalty_stages : float, float, int
        ``complementarity="penalty"``: ``rho`` of the first stage, its factor per stage (> 1), the most stages.
    ipopt_options : dict
        Extra Ipopt options ``{name: value}`` (floats as floats).
    piece_lp : bool
        Finish the Ipopt stages with the piece-LP descent (:mod:`~blockmpec.solvers.engines.piece_lp`): kept when
        certified and ``lam`` is not higher.
    piece_lps : {"split", "whole"}
        Each piece LP as its static and kinematic halves (the static by the block IPM on large structures), or
        as one HiGHS LP (the route before; for measurement).
    """

    max_iter: int = 3000
    tol: float = 1e-9
    warm_start: bool = True
    polish: bool = True
    polish_iterations: int = 20
    penalty: float = 100.0
    penalty_factor: float = 10.0
    penalty_stages: int = 4
    ipopt_options: dict = field(default_factory=dict)
    piece_lp: bool = False
    piece_lps: str = "split"

    def __post_init__(self) -> None:
        check.positive(self, "tol", "penalty")
        check.integer(self, "max_iter", "polish_iterations", minimum=0)
        check.interval(self, "penalty_factor", 1, math.inf)
        check.integer(self, "penalty_stages", minimum=1)
        check.boolean(self, "warm_start", "polish", "piece_lp")
        check.choice(self, "piece_lps", PIECE_LPS)
        if not isinstance(self.ipopt_options, dict):
            raise ValueError(f"ipopt_options must be a dict {{name: value}}; got {self.ipopt_options!r}")
        for k, v in self.ipopt_options.items():
            if not isinstance(k, str) or isinstance(v, bool) or not isinstance(v, (str, int, float)):
                raise ValueError(f"ipopt_options[{k!r}] must map a name to a str, int or float; got {v!r}")


def eps_schedule(options: NLPOptions, settings: NLPSettings) -> list[float]:
    """The eps of every stage, from ``eps_initial`` down to ``eps_final`` (included); penalty: the rho."""
    if options.complementarity == "penalty":
        return [settings.penalty * settings.penalty_factor ** k for k in range(settings.penalty_stages)]
    eps = [float(options.eps_initial)]
    while eps[-1] > options.eps_final * (1 + 1e-12):
        eps.append(max(eps[-1] * options.eps_factor, float(options.eps_final)))
    return eps


class RelaxedMPEC:
    """cyipopt callbacks of the relaxed NLP in units; variables ``v^ = (w^, s^)`` with ``w = D w^``, ``s = S s^``.

    ``D`` (``scaling.column``, one entry per column of ``w``) and ``S`` (``scaling.slack``, one per
    pair) come from the :class:`~blockmpec.solvers.engines.scaling.MCPScaling` ``scaling``; the equality rows are
    multiplied by ``scaling.row``
    and each slack row ``G_i w + s_i = 0`` by ``1 / S_i`` (its ``s^_i`` coefficient stays 1).
    The product rows are ``z^_i s^_i / P``: since ``S_i`` is the reciprocal of the unit of
    ``z_i``, ``z^_i s^_i = z_i s_i`` (a work in ``lam`` units), and ``P`` is measured on the
    scaled start.
    """

    def __init__(self, form, scale: float, scaling) -> None:
        import scipy.sparse as sp

        self.form = form
        p = form.n_pairs
        n_w = form.n_columns
        self.n_pairs = p
        self.i_w = slice(0, n_w)
        self.i_s = slice(n_w, n_w + p)
        self.n = n_w + p
        #: the units of ``(w, s)``: ``v = units * v^``
        self.units = scaling.with_slacks()
        A_eq, G, rhs = scaling.nlp_rows(form)  # R A D w^ = R rhs; (G w + s) / S = 0
        A = sp.bmat([[A_eq, None], [G, sp.eye_array(p)]], format="csr")
        self.m_lin = A.shape[0]
        self.m = self.m_lin + p
        A.sum_duplicates()
        self.A = A
        A = A.tocoo()
        self.scale = float(scale)
        z_cols = np.asarray(form.pair_column)
        s_cols = self.i_s.start + np.arange(p)
        prod_rows = self.m_lin + np.arange(p)
        self.z_cols, self.s_cols = z_cols, s_cols
        self._jac_rows = np.concatenate([A.row, prod_rows, prod_rows]).astype(np.int32)
        self._jac_cols = np.concatenate([A.col, z_cols, s_cols]).astype(np.int32)
        self._jac_lin = A.data.astype(float)
        # Lagrangian Hessian: d2(z_i s_i)/dz_i ds_i; lower triangle (s columns after z columns).
        self._hess_rows = s_cols.astype(np.int32)
        self._hess_cols = z_cols.astype(np.int32)
        self.rhs = np.concatenate([rhs, np.zeros(p)])
        self.grad = np.zeros(self.n)
        self.grad[form.lam] = 1.0
        self.start_clock(math.inf)

    def to_units(self, v: np.ndarray) -> np.ndarray:
        """``(w, s)`` -> ``(w^, s^)``."""
        return np.asarray(v, float) / self.units

    def from_units(self, v: np.ndarray) -> np.ndarray:
        """``(w^, s^)`` -> ``(w, s)``."""
        return np.asarray(v, float) * self.units

    # ---- cyipopt interface
    def objective(self, v):
        return float(v[self.form.lam])

    def gradient(self, v):
        return self.grad

    def constraints(self, v):
        z, s = v[self.z_cols], v[self.i_s]
        return np.concatenate([self.A @ v, z * s / self.scale])

    def jacobianstructure(self):
        return self._jac_rows, self._jac_cols

    def jacobian(self, v):
        z, s = v[self.z_cols], v[self.i_s]
        return np.concatenate([self._jac_lin, s / self.scale, z / self.scale])

    def hessianstructure(self):
        return self._hess_rows, self._hess_cols

    def hessian(self, v, lagrange, obj_factor):
        return np.asarray(lagrange[self.m_lin:], float) / self.scale

    def intermediate(self, alg_mod, iter_count, obj_value, inf_pr, inf_du, mu, d_norm, regularization_size,
                     alpha_du, alpha_pr, ls_trials):
        """Ipopt's per-iteration callback (regular and restoration iterations): count, time, keep the deadline.

        Returns False (Ipopt stops with ``User_Requested_Stop``, read as the time limit through
        ``deadline_hit``) once the wall-clock time left before ``deadline`` is shorter than the
        longest iteration seen so far: Ipopt's own ``max_wall_time`` is tested only after an
        iteration has finished, so its last iteration overran the limit by up to one iteration
        (several MUMPS factorisations when the inertia is corrected; 5.2 s on the 2,032-block wall).
        """
        now = time.perf_counter()
        self.longest_iteration_s = max(self.longest_iteration_s, now - self._last_iteration_at)
        self._last_iteration_at = now
        self.iterations = int(iter_count)
        if now + self.longest_iteration_s >= self.deadline:
            self.deadline_hit = True
            return False
        return True

    def start_clock(self, deadline: float) -> None:
        """Reset the iteration count and clock before an Ipopt solve that must end by ``deadline`` (perf_counter)."""
        self.iterations = 0
        self.deadline = deadline
        self.deadline_hit = False
        self.longest_iteration_s = 0.0
        self._last_iteration_at = time.perf_counter()

    # ---- helpers
    def bounds(self, eps: float):
        lb = np.full(self.n, -_INF)
        ub = np.full(self.n, _INF)
        lb[self.z_cols] = 0.0
        lb[self.i_s] = 0.0
        # friction tan(phi_k) = 0: the pair rows +-t_k <= 0 force t_k = 0; fixed (Ipopt drops the
        # column), so that t_k is an exact zero rather than round-off of either sign
        frictionless = self.form.x.start + self.form.shear_of(self.form.friction == 0)
        lb[frictionless] = ub[frictionless] = 0.0
        cl = np.concatenate([self.rhs, np.full(self.n_pairs, -_INF)])
        cu = np.concatenate([self.rhs, np.full(self.n_pairs, float(eps))])
        return lb, ub, cl, cu

    def split(self, v) -> Solution:
        """The solution at the scaled point ``v^``."""
        return self.form.unpack(self.from_units(v)[self.i_w])


class PenaltyMPEC(RelaxedMPEC):
    """The penalty NLP of (4): ``min lam + rho sum_i z^_i s^_i`` over the linear rows and bounds.

    No product rows (``m = m_lin``); the products ``z^_i s^_i = z_i s_i`` are works in ``lam``
    units, so ``rho`` is dimensionless.  Gradient ``rho s^_i`` on ``z^_i``, ``rho z^_i`` on ``s^_i``;
    Hessian of the Lagrangian ``obj_factor * rho`` on each ``(s^_i, z^_i)`` (constant pattern).
    """

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.m = self.m_lin
        A = self.A.tocoo()
        self._jac_rows = A.row.astype(np.int32)
        self._jac_cols = A.col.astype(np.int32)
        self._jac_lin = A.data.astype(float)
        self.rhs = self.rhs[: self.m_lin]
        self.rho = 1.0

    def objective(self, v):
        return float(v[self.form.lam] + self.rho * np.dot(v[self.z_cols], v[self.i_s]))

    def gradient(self, v):
        g = self.grad.copy()
        g[self.z_cols] += self.rho * v[self.i_s]
        g[self.i_s] += self.rho * v[self.z_cols]
        return g

    def constraints(self, v):
        return self.A @ v

    def jacobian(self, v):
        return self._jac_lin

    def hessian(self, v, lagrange, obj_factor):
        return np.full(self.n_pairs, float(obj_factor) * self.rho)

    def bounds(self, eps: float):
        lb, ub, cl, cu = super().bounds(eps)
        return lb, ub, cl[: self.m_lin], cu[: self.m_lin]


def _typical_work(z: np.ndarray, s: np.ndarray) -> float:
    """``max(z) max(s)`` (a factor taken as 1 where it is 0 or there are no pairs)."""
    zs = float(np.max(z)) if z.size else 0.0
    ss = float(np.max(s)) if s.size else 0.0
    return (zs if zs > 0 else 1.0) * (ss if ss > 0 else 1.0)


def without_free_sliding(form, solution: Solution) -> Solution:
    """The solution with the common part of each zero-dilatancy interface's sliding multipliers removed.

    At ``tan(psi_k) = 0`` the two multipliers ``z_f+, z_f-`` of interface ``k`` enter (3) only
    through ``z_f+ - z_f-`` (the flow's normal part ``tan(psi_k) (z_f+ + z_f-)`` vanishes), so
    ``z_f+- -> z_f+- - c`` leaves every equality row unchanged.  On an unloaded interface (both
    friction slacks ~0) nothing bounds ``c``: measured on two blocks at eta = 50, mu = 1, Ipopt's
    barrier left ``z_f+- = 1e5`` with slacks ``-8e-11`` (inside its bound relaxation), a
    complementarity work of 1.6e-5 that the verifier rejected.  ``c = max(0, min(z_f+, z_f-))``
    only shrinks the products ``z_f s_f``.
    """
    contact = form.pair_interface[form.friction_pairs]
    free = form.dilatancy[contact] == 0
    if solution.z_f is None or not free.any():
        return solution
    k = contact.size // max(form.n_interfaces, 1)  # friction rows per contact: 2 in 2D, the pyramid's sides in 3D
    z_f = solution.z_f.reshape(-1, k)  # the rows of each contact, as form.pair_interface orders them
    common = np.where(free[::k], np.maximum(z_f.min(axis=1), 0.0), 0.0)
    solution.z_f = (z_f - common[:, None]).ravel()
    return solution


@register_solver
class RelaxedNLP(SolverBase):
    """MPEC (4) by Scholtes-relaxed complementarity, Ipopt (cyipopt), eps homotopy."""

    name = "nlp"
    problem = "non-associative"
    summary = "MPEC (4): Scholtes-relaxed NLP solved by Ipopt over a decreasing eps schedule"
    requires = ("cyipopt", "highspy", "pyomo")
    Options = NLPOptions
    Settings = NLPSettings

    def setup(self, ops):
        from blockmpec.formulations import compile_mcp
        from blockmpec.solvers.engines.scaling import LoadUnits

        self.ops = ops
        self.form = compile_mcp(ops)  # (3), compiled once
        opt = self.options
        self.route = plan.nlp_route(opt.route, self.form.n_blocks)
        # the route decides: the Ipopt stages from the chosen start (and the piece LPs if the settings say so), or
        # the fixed point's solution straight to the piece LPs
        self.start = "fixed-point" if self.route == "pieces" else opt.start
        self.use_ipopt = self.route == "ipopt"
        self.use_pieces = self.route == "pieces" or self.settings.piece_lp
        self.start_solver = None
        if self.start in _START_METHODS:  # the start is the registered method's adapter itself
            from blockmpec.registry import get_solver

            method, start_options = _START_METHODS[self.start]
            self.start_solver = get_solver(method)(**start_options)
            self.start_solver.verify_tol = self.verify_tol
            self.start_solver.setup(ops)
        st = self.settings
        self.plan = plan.nlp_plan(self.route, self.start, opt.complementarity, len(eps_schedule(opt, st)),
                                  polish=st.polish and st.polish_iterations > 0,
                                  piece_lps=st.piece_lps if self.use_pieces else None, n_pairs=self.form.n_pairs)
        self.scaling = LoadUnits.of(ops).mcp(self.form)
        self.nlp = None  # built in run(): its scale depends on the starting point
        self.start_time_s = 0.0  # seconds of the start's solve (part of the run's solve time)

    def _start_point(self, stop):
        """``(v0, P, failure status or None, message, associative multiplier or None)``.

        ``v0 = (w0, s0)`` is the start's solution (associative: the static LP's; fixed-point: the
        registered method's, run here with the time left on ``stop``) with ``s0 = -G w0``
        (negative parts of ``z0`` and ``s0`` cut to 0), or None for a cold start.
        ``P = max(z^0) max(s^0)`` in the units of :attr:`scaling`; cold: ``max|f^_d| / sum|f^_l|``
        (a force times the size of ``z`` implied by ``f_l^T u = 1``, in units).
        """
        from blockmpec import facts

        form = self.form
        if self.start_solver is None:
            f_d, f_l = self.scaling.loads(form)
            force = float(np.max(np.abs(f_d))) if f_d.size else 1.0
            scale = force / max(float(np.sum(np.abs(f_l))), 1e-300)
            return None, (scale if scale > 0 else 1.0), None, "cold start", None
        name = self.start
        t0 = time.perf_counter()
        start = self.start_solver.run(stop.deadline)
        self.start_time_s = time.perf_counter() - t0
        if start.status not in _USABLE_START or start.solution is None or start.solution.multiplier is None:
            return (None, 1.0, start.status, f"{name} start failed: {start.status.value} ({start.message})", None)
        sol = start.solution
        w0 = form.pack(sol)
        s0 = np.maximum(form.slack(w0), 0.0)
        z0 = np.maximum(form.multipliers(w0), 0.0)
        w0[form.pair_column] = z0
        scale = _typical_work(*self.scaling.pair_sides(form, z0, s0))
        lam_associative = sol.multiplier if name == "associative" else start.extra.get(facts.ASSOCIATIVE_MULTIPLIER)
        return np.concatenate([w0, s0]), scale, None, f"{name} start lam = {sol.multiplier:.9g}", lam_associative

    def run(self, deadline) -> RunOutput:
        import cyipopt

        from blockmpec import facts
        from blockmpec.solvers.engines.exact_point import exact_solution
        from blockmpec.solvers.engines.stopping import StoppingCriterion

        opt, st = self.options, self.settings
        schedule = eps_schedule(opt, st) if self.use_ipopt else []
        # writes the trace (one record per Ipopt solve, measure eps) and keeps the time limit; the
        # stages stop on Ipopt's status, so its iteration limit (every solve twice, and the polish) never binds
        penalty = opt.complementarity == "penalty"
        # the trace's measure: the stage's eps, or its rho in the penalty NLP
        stop = StoppingCriterion(opt.eps_final, 2 * len(schedule) + 2, deadline,
                                 measure_name="rho" if penalty else "eps").start()
        self.plan.start("start")
        v0, scale, fail, start_msg, lam_associative = self._start_point(stop)
        if fail is not None:
            passed_on = (Status.UNBOUNDED, Status.INFEASIBLE, Status.INFEASIBLE_OR_UNBOUNDED, Status.TIME_LIMIT)
            return RunOutput(fail if fail in passed_on else Status.ERROR, message=start_msg,
                             raw_status="static LP" if self.start == "associative" else self.start)
        nlp = (PenaltyMPEC if penalty else RelaxedMPEC)(self.form, scale, self.scaling)
        self.nlp = nlp
        v = np.zeros(nlp.n) if v0 is None else nlp.to_units(v0)
        final, raw, message, total_iter = Status.LOCALLY_OPTIMAL, "", "", 0
        if self.use_ipopt:
            self.plan.start("ipopt")
            v, final, raw, message, total_iter = self._ipopt_stages(cyipopt, nlp, v, schedule, scale, stop)
        trace = stop.trace
        solution = without_free_sliding(self.form, nlp.split(v))
        n_stages = len({t["stage"] for t in trace})
        extra = {"stages": n_stages, "ipopt_solves": len(trace), "scale": scale, "start": self.start, "route": self.route,
                 "start_time_s": self.start_time_s, "complementarity": opt.complementarity}
        if lam_associative is not None:
            extra[facts.ASSOCIATIVE_MULTIPLIER] = lam_associative
        if not message and self.use_ipopt:
            last = trace[-1]
            final_value = (f"final rho = {last['rho']:.3g}, max z_i s_i / P = {last.get('max_work', math.nan):.3g}"
                           if penalty else f"final eps = {last['eps']:.3g}")
            message = f"{n_stages} stages ({len(trace)} Ipopt solves), {final_value}; {start_msg}"
            if "polish" in self.plan:
                self.plan.start("polish")
                solution, note = self._polish(solution, stop)
                message += f"; {note}"
                extra["polish"] = note
            # the lam of an exact solution of (3): the point finished on its pattern's piece LPs
            self.plan.start("exact")
            solution, note = exact_solution(self.form, self.scaling, solution, stop.deadline)
            message += f"; {note}"
        if "pieces" in self.plan and (not self.use_ipopt or final in (Status.LOCALLY_OPTIMAL, Status.ACCEPTABLE)):
            self.plan.start("pieces")
            solution, final, note = self._piece_finish(solution, final, stop, extra)
            message = f"{message}; {note}" if message else f"{start_msg}; {note}"
        return RunOutput(final, solution, iterations=total_iter, trace=trace, message=message, raw_status=raw,
                         extra=extra)

    def _ipopt_stages(self, cyipopt, nlp: RelaxedMPEC, v: np.ndarray, schedule: list[float], scale: float, stop):
        """The Ipopt stages of ``schedule`` from the scaled point ``v``, each warm from the one before, until one
        fails (penalty: until every product ``z^_i s^_i <= eps_final P``); ``(v, status, raw, message, iterations)``
        with ``raw`` Ipopt's name of the last solve and ``message`` empty unless a stage failed."""
        opt = self.options
        penalty = isinstance(nlp, PenaltyMPEC)
        mult, final, raw, message, total = None, Status.LOCALLY_OPTIMAL, "", "", 0
        for k, eps in enumerate(schedule):
            if penalty:
                nlp.rho = eps
            status, name, info, v_new, iterations, last_raw = self._stage(cyipopt, nlp, k, eps, v, mult, stop)
            total += iterations
            raw = raw if last_raw is None else last_raw
            if status in (Status.LOCALLY_OPTIMAL, Status.ACCEPTABLE):
                v = np.asarray(v_new, float)
                mult = (np.asarray(info["mult_g"], float), np.asarray(info["mult_x_L"], float),
                        np.asarray(info["mult_x_U"], float))
                if status is Status.ACCEPTABLE:
                    final = Status.ACCEPTABLE
                if penalty:
                    work = float(np.max(v[nlp.z_cols] * v[nlp.i_s], initial=0.0)) / scale
                    stop.trace[-1]["max_work"] = work
                    if work <= opt.eps_final:
                        break
                continue
            # a failed stage: keep its iterate if it is finite, report and stop
            if np.all(np.isfinite(v_new)):
                v = np.asarray(v_new, float)
            final = status
            message = f"stage {k + 1} (eps = {eps:.3g}) ended with Ipopt status {name}: {info.get('status_msg', b'')!r}"
            break
        return v, final, raw, message, total

    def _stage(self, cyipopt, nlp: RelaxedMPEC, k: int, eps: float, v: np.ndarray, mult, stop):
        """Stage ``k`` at ``eps`` from ``v``: one Ipopt solve (warm with the multipliers ``mult`` when the settings
        say so), and after a failed warm solve one more from ``v`` without them.  Each solve is a record of ``stop``.
        Returns ``(status, Ipopt's name, info, point, Ipopt iterations, name of the last solve or None)``."""
        attempts = [True, False] if self.settings.warm_start and mult is not None else [False]
        iterations, last_raw = 0, None
        for use_mult in attempts:
            remaining = stop.remaining()
            if remaining <= 0:
                return (Status.TIME_LIMIT, "time_limit", {"status_msg": "time limit before the stage"}, v, iterations,
                        last_raw)
            t0 = time.perf_counter()
            v_new, info = self.solve_stage(cyipopt, nlp, eps, v, mult if use_mult else None, remaining)
            dt = time.perf_counter() - t0
            code = int(info["status"])
            status, name = _IPOPT_STATUS.get(code, (Status.ERROR, f"ipopt_status_{code}"))
            if nlp.deadline_hit and code == _USER_STOP:  # our callback stopped it: the time limit
                status, name = Status.TIME_LIMIT, "time_limit_callback"
            iterations += nlp.iterations
            lam_k = float(v_new[self.form.lam] * nlp.units[self.form.lam])
            stop.check(eps, stage=k + 1, multiplier=lam_k, ipopt_status=name,
                       ipopt_iterations=nlp.iterations, warm_multipliers=use_mult, stage_time_s=dt,
                       longest_iteration_s=nlp.longest_iteration_s)
            last_raw = name
            if status.is_success or status is Status.TIME_LIMIT:
                break
        return status, name, info, v_new, iterations, last_raw

    def solve_stage(self, cyipopt, nlp: RelaxedMPEC, eps: float, v: np.ndarray, mult, remaining: float):
        """One Ipopt solve of the relaxed NLP ``nlp`` at ``eps`` from ``v`` (with multipliers ``mult`` if given),
        within ``remaining`` seconds, with the settings' Ipopt options (``ipopt_options`` last: a study may set,
        e.g., one ``output_file`` per stage before each call)."""
        from blockmpec.progress import verbose_enabled

        opt = self.settings
        lb, ub, cl, cu = nlp.bounds(eps)
        problem = cyipopt.Problem(n=nlp.n, m=nlp.m, problem_obj=nlp, lb=lb, ub=ub, cl=cl, cu=cu)
        problem.add_option("print_level", 5 if verbose_enabled() else 0)
        problem.add_option("sb", "yes")
        problem.add_option("mumps_pivtol", 1e-8)
        problem.add_option("tol", float(opt.tol))
        penalty = isinstance(nlp, PenaltyMPEC)
        problem.add_option("max_iter", int(opt.max_iter))
        if penalty:
            # the start solves the linear rows: stay near it (push 1e-6, not 1e-2) with a small fixed barrier
            problem.add_option("mu_strategy", "monotone")
            problem.add_option("mu_init", _PENALTY_MU_INIT)
            problem.add_option("bound_push", _PENALTY_MU_INIT)
            problem.add_option("bound_frac", _PENALTY_MU_INIT)
        else:
            problem.add_option("mu_strategy", "adaptive")
            # Ipopt relaxes bounds by bound_relax_factor: keep that well below eps
            problem.add_option("bound_relax_factor", float(min(1e-8, 0.1 * eps)))
        if math.isfinite(remaining):
            problem.add_option("max_wall_time", float(max(remaining, 1e-3)))
        if mult is not None:
            problem.add_option("warm_start_init_point", "yes")
            problem.add_option("warm_start_bound_push", 1e-9)
            problem.add_option("warm_start_bound_frac", 1e-9)
            problem.add_option("warm_start_slack_bound_push", 1e-9)
            problem.add_option("warm_start_slack_bound_frac", 1e-9)
            problem.add_option("warm_start_mult_bound_push", 1e-9)
            problem.add_option("mu_init", 1e-9 if penalty else float(max(min(1e-4, eps), 1e-9)))
        for name, value in opt.ipopt_options.items():
            problem.add_option(name, value)
        nlp.start_clock(time.perf_counter() + remaining)
        if mult is not None:
            return problem.solve(v, lagrange=mult[0], zl=mult[1], zu=mult[2])
        return problem.solve(v)

    def _piece_finish(self, solution: Solution, status: Status, stop, extra: dict) -> tuple[Solution, Status, str]:
        """The piece-LP descent (:func:`~blockmpec.solvers.engines.piece_lp.piece_descent`) from ``solution``.

        Its point solves (3) exactly (one side of every pair is a bound of the LP) and, when certified,
        is a local minimum of (4).  After Ipopt's stages it replaces their point only when certified and
        ``lam`` is not higher (by ``1e-9 max(1, |lam|)``); without the stages (``ipopt=False``) its outcome
        is the run's: ``LOCALLY_OPTIMAL`` when certified, else its status with its best point (or the start's).
        """
        from blockmpec import facts
        from blockmpec.solvers.engines.piece_lp import piece_descent, whole_piece_descent

        if stop.out_of_time():
            return solution, status if self.use_ipopt else Status.TIME_LIMIT, "no time left for the piece LPs"
        t0 = time.perf_counter()
        descent = piece_descent if self.settings.piece_lps == "split" else whole_piece_descent
        out = descent(self.form, self.scaling, self.form.pack(solution), deadline=stop.deadline)
        dt = time.perf_counter() - t0
        stop.check(0.0, stage="piece-lp", multiplier=float(out.multiplier), ipopt_status="", ipopt_iterations=0,
                   piece_status=out.status.value, certified=out.certified, piece_lps=out.pieces,
                   biactive=out.biactive, stage_time_s=dt)
        extra[facts.LP_SOLVES] = out.lp_solves
        extra[facts.LP_TIME_S] = out.lp_time_s
        extra["piece_certified"] = out.certified
        extra["piece_lp_trace"] = out.trace  # one record per piece LP: lam, free/biactive pairs, certificate
        extra["piece_lps"] = self.settings.piece_lps
        if self.settings.piece_lps == "split":
            extra["static_lp_time_s"] = out.static_time_s
            extra["kinematic_lp_time_s"] = out.kinematic_time_s
        lam = solution.multiplier
        better = out.w is not None and (lam is None or out.multiplier <= lam + 1e-9 * max(1.0, abs(lam)))
        if self.use_ipopt and not (out.certified and better):
            return solution, status, f"piece LPs not kept ({out.message})"
        if out.w is None:
            failed = out.status if out.status is Status.TIME_LIMIT else Status.NUMERICAL
            return solution, failed, f"piece LPs found no solution of (3): {out.message}"
        # the interior-point LPs leave the free common part of zero-dilatancy sliding multipliers large
        # (two blocks: z_f+- = 7519), which without_free_sliding removes
        new = without_free_sliding(self.form, self.form.unpack(out.w))
        new.x[self.form.shear_of(self.form.friction == 0)] = 0.0  # tan(phi_k) = 0 forces t_k = 0 (exact zero)
        # not certified: a limit, or a piece whose duals do not certify a local minimum; its point is an exact
        # solution of (3) all the same (CONVERGED: a solution of the MCP, no claim of minimality)
        status = (Status.LOCALLY_OPTIMAL if out.certified else
                  out.status if out.status in (Status.TIME_LIMIT, Status.ITERATION_LIMIT) else Status.CONVERGED)
        return new, status, out.message

    def _polish(self, solution: Solution, stop) -> tuple[Solution, str]:
        """Semismooth Newton steps on (3) from the NLP point (:mod:`blockmpec.solvers.engines.newton_system`).

        The relaxed point leaves products ``z_i s_i`` of order ``eps`` and bound
        multipliers of order Ipopt's tolerance; a few Fischer–Burmeister Newton steps
        make them exact.  The polished point is kept only if Newton converged and
        ``|lam_polished - lam| <= 1e-6 max(1, |lam|)`` (the same local solution).
        ``stop`` is the run's criterion (time left; the polish is one more trace record).
        """
        from blockmpec.solvers.engines.newton_system import MCPSystem, semismooth_newton

        if stop.out_of_time():
            return solution, "no time left for the polish"
        t0 = time.perf_counter()
        system = MCPSystem(self.form, solution)
        out = semismooth_newton(system, system.pack(solution), tol=1e-12,
                                max_iterations=self.settings.polish_iterations, deadline=stop.deadline)
        dt = time.perf_counter() - t0
        lam, lam_new = solution.multiplier, out.solution.multiplier
        ok = out.status is Status.CONVERGED and abs(lam_new - lam) <= 1e-6 * max(1.0, abs(lam))
        stop.check(0.0, stage="polish", multiplier=float(lam_new), ipopt_status="", ipopt_iterations=0,
                   newton_iterations=out.iterations, newton_status=out.status.value, accepted=ok, stage_time_s=dt)
        if ok:
            # tan(phi_k) = 0 forces t_k = 0 (pair rows +-t_k <= 0): Newton's round-off there is set to the exact zero
            out.solution.x[self.form.shear_of(self.form.friction == 0)] = 0.0
            note = f"polished by {out.iterations} Newton steps (lam {lam:.10g} -> {lam_new:.10g})"
            return out.solution, note
        return solution, f"polish rejected ({out.status.value}, lam {lam:.10g} -> {lam_new:.10g}); raw NLP point kept"

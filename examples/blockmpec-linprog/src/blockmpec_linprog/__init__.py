r"""Two blockmpec methods through ``scipy.optimize.linprog``: a third-party plug-in, as a researcher would write one.

``linprog`` (associative) solves the static LP (1) of the paper (Nodargi, Intrigila, Bisegna)::

    max lam   subject to   E x + f_d + lam f_l = 0,   N_u^T x <= 0,   N_f^T x <= 0,

and reads the collapse mechanism from its duals: with ``linprog``'s marginals ``y`` of the equalities and ``w <= 0``
of the inequalities (minimising ``-lam``), ``u = -y``, ``z_u = -w_u`` and ``z_f = -w_f`` satisfy
``E^T u + N_u z_u + N_f z_f = 0`` and ``f_l^T u = 1``: the associative flow rule and the normalisation.

``linprog-fixed-point`` (non-associative) is the paper's fixed point (6) on the normal forces: from the associative
point, solve the LP (5) with the friction rows at the dilatancy and cohesion from the previous normal forces ``n*``,
``V_f^T x <= (V_f - N_f)^T x*``, until ``n = n*``; its duals then satisfy the non-associative flow rule
``E^T u + N_u z_u + V_f z_f = 0``, so the point solves (3).

Both see only the assembled problem (``setup(ops)``: matrices in blockmpec's canonical frame and units); blockmpec
verifies their points, times them and reports them in the user's units.  They are registered by the entry points of
this package's ``pyproject.toml``, group ``blockmpec.methods``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.optimize import linprog

import blockmpec as bm
from blockmpec.options import CommonOptions, choice, integer, positive

#: linprog's HiGHS methods
LINPROG_METHODS = ("highs", "highs-ds", "highs-ipm")


@dataclass
class LinprogOptions(CommonOptions):
    """The options of ``linprog`` (and ``time_limit``, ``verbose`` of every method)."""

    method: str = field(default="highs", metadata={"help": "linprog's method: highs, highs-ds or highs-ipm"})

    def __post_init__(self) -> None:
        super().__post_init__()  # time_limit and verbose
        choice(self, "method", LINPROG_METHODS)


@dataclass
class FixedPointOptions(LinprogOptions):
    """The options of ``linprog-fixed-point``."""

    max_iterations: int = field(default=200, metadata={"help": "LPs (5) at most"})
    tol: float = field(default=1e-10, metadata={"help": "stop when ||n - n*|| <= tol ||n||"})

    def __post_init__(self) -> None:
        super().__post_init__()
        integer(self, "max_iterations", minimum=1)
        positive(self, "tol")


def solve_lp(ops: bm.Operators, flow: sp.sparray, rhs: np.ndarray, method: str, deadline) -> tuple[bm.Status, object]:
    """``max lam`` s.t. ``E x + f_d + lam f_l = 0``, ``N_u^T x <= 0``, ``flow^T x <= rhs``, by ``linprog`` within
    ``deadline``: the status and linprog's result."""
    n_u, n_f = ops.N_u.shape[1], flow.shape[1]  # no-tension and friction rows (2D: two of each per interface)
    n_x = ops.E.shape[1]
    objective = np.zeros(n_x + 1)
    objective[-1] = -1.0
    a_eq = sp.hstack([ops.E, sp.csr_array(ops.f_l.reshape(-1, 1))], format="csr")
    a_ub = sp.vstack([sp.hstack([ops.N_u.T, sp.csr_array((n_u, 1))]), sp.hstack([flow.T, sp.csr_array((n_f, 1))])],
                     format="csr")
    options = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}
    if deadline.finite:
        options["time_limit"] = deadline.remaining()
    res = linprog(objective, A_ub=a_ub, b_ub=np.concatenate([np.zeros(n_u), rhs]), A_eq=a_eq, b_eq=-ops.f_d,
                  bounds=(None, None), method=method, options=options)
    if res.status == 1 and "time" in res.message.lower():
        return bm.Status.TIME_LIMIT, res
    return {0: bm.Status.OPTIMAL, 1: bm.Status.ITERATION_LIMIT, 2: bm.Status.INFEASIBLE,
            3: bm.Status.UNBOUNDED}.get(res.status, bm.Status.NUMERICAL), res


def point(ops: bm.Operators, res) -> bm.Solution:
    """The LP's optimum as a point of (3): forces and multiplier from the primal, mechanism from the duals."""
    n_u = ops.N_u.shape[1]
    w = -res.ineqlin.marginals
    return bm.Solution(multiplier=float(res.x[-1]), x=res.x[:-1], u=-res.eqlin.marginals, z_u=w[:n_u], z_f=w[n_u:])


class StaticLinprog(bm.SolverBase):
    """The static LP (1) by ``scipy.optimize.linprog``."""

    name = "linprog"
    problem = "associative"
    summary = "static LP (1) by scipy.optimize.linprog (plug-in example)"
    requires = ("scipy",)
    Options = LinprogOptions

    def setup(self, ops: bm.Operators) -> None:
        self.ops = ops

    def run(self, deadline) -> bm.RunOutput:
        if deadline.expired():
            return bm.RunOutput(bm.Status.TIME_LIMIT, message="time limit reached before the LP")
        status, res = solve_lp(self.ops, self.ops.N_f, np.zeros(self.ops.N_f.shape[1]), self.options.method, deadline)
        solution = point(self.ops, res) if status is bm.Status.OPTIMAL else bm.Solution()
        return bm.RunOutput(status, solution, iterations=int(res.nit), message=res.message, raw_status=str(res.status))


class FixedPointLinprog(StaticLinprog):
    """The paper's fixed point (6) by ``scipy.optimize.linprog``: one LP (5) per iteration."""

    name = "linprog-fixed-point"
    problem = "non-associative"
    summary = "the fixed point (6) on the normal forces, LPs by scipy.optimize.linprog (plug-in example)"
    Options = FixedPointOptions

    def run(self, deadline) -> bm.RunOutput:
        ops, opts = self.ops, self.options
        flow, cohesion = ops.N_f, ops.V_f - ops.N_f  # LP (1) first: the associative start
        rhs, n_star, step = np.zeros(ops.N_f.shape[1]), None, np.inf
        trace = []
        for k in range(opts.max_iterations + 1):
            if deadline.expired():
                return bm.RunOutput(bm.Status.TIME_LIMIT, iterations=k, trace=trace, message="time limit reached")
            status, res = solve_lp(ops, flow, rhs, opts.method, deadline)
            if status is not bm.Status.OPTIMAL:
                return bm.RunOutput(status, iterations=k, trace=trace, message=f"LP {k}: {res.message}")
            x = res.x[:-1]
            n = x[ops.normal_index]  # the normal forces (2D: x = (t, n, m) per interface; 3D: (t1, t2, n) per point)
            if n_star is not None:
                step = np.linalg.norm(n - n_star) / max(np.linalg.norm(n), 1e-300)
            trace.append({"iteration": k, "time_s": deadline.elapsed(), "multiplier": float(res.x[-1]),
                          "normal_change": float(step)})
            if step <= opts.tol:
                return bm.RunOutput(bm.Status.CONVERGED, point(ops, res), iterations=k, trace=trace,
                                    message=f"||n - n*|| / ||n|| = {step:.2g} after {k} LPs (5)")
            n_star = n
            flow, rhs = ops.V_f, cohesion.T @ x
        return bm.RunOutput(bm.Status.ITERATION_LIMIT, iterations=opts.max_iterations, trace=trace,
                            message=f"||n - n*|| / ||n|| = {step:.2g} after {opts.max_iterations} LPs (5)")

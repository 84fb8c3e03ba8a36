r"""``mcp-newton``: a solution of the MCP (3) by a semismooth Newton method (stand-in for PATH).

Problem
-------
The MCP (3) is read from its compiled formulation
(:func:`blockmpec.formulations.compile_mcp`): with the pair slacks ``s = -G w`` and
multipliers ``z = w[pair_column]`` it is the square system in ``w = (lam, x, u, z)``
(``1 + 3c + 3b + 4c`` unknowns and equations)::

    A w = rhs                                (equilibrium, compatibility, normalisation)
    phi(z_i, s_i) = 0,  i = 1..4c            (complementarity)

where ``phi(a, b) = a + b - sqrt(a^2 + b^2)`` is the Fischer–Burmeister function
(zero iff ``a, b >= 0`` and ``a b = 0``), applied to scaled pairs.  Rows and
unknowns are scaled by typical magnitudes from the starting point; see
:class:`blockmpec.solvers.engines.newton_system.MCPSystem`.

Method
------
Semismooth Newton with an Armijo line search on ``Psi = ||Phi||^2 / 2`` and a
Levenberg–Marquardt fallback (``nu = regularisation * ||Phi||``), then steepest
descent, when the Newton direction does not exist or is not a descent direction
(:func:`blockmpec.solvers.engines.newton_system.semismooth_newton`).  It starts from the associative
solution (static LP (1) with HiGHS and its duals), which satisfies (3) except the
friction flow.

The Jacobian is singular at every solution of a hyperstatic structure (the forces
``x`` of the rigid part are not unique), and the Fischer–Burmeister merit can have
stationary points that are not solutions.  With ``continuation`` the dilatancy is
therefore moved from the friction value (where the associative solution solves
(3) exactly) to its own value, ``tan(psi_t) = (1 - t) tan(phi) + t tan(psi)``,
``t: 0 -> 1`` (:meth:`~blockmpec.formulations.CompiledMCP.with_dilatancy`): each
step is a Newton solve of at most ``step_iterations`` iterations from the previous
solution; the step in ``t`` starts at 1 (direct solve), is halved after a failure
and doubled after a success.  One
:class:`~blockmpec.solvers.engines.stopping.StoppingCriterion` spans the run: it
counts every Newton iteration against ``max_iterations``, keeps ``time_limit``
and writes the trace (``iteration, time_s, residual, merit, step, direction,
multiplier, continuation``).

The answer is *a* solution of (3), not necessarily the minimum of (4); its
multiplier lies between the non-associative minimum and the associative one.

Status: ``CONVERGED`` when ``||Phi||_inf <= tol``; ``ITERATION_LIMIT``,
``TIME_LIMIT`` or ``NUMERICAL`` (stalled line search) with the last iterate.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from blockmpec import options as check
from blockmpec.registry import register_solver
from blockmpec.result import Status
from blockmpec.solver import RunOutput, SolverBase


@dataclass
class NewtonOptions:
    """Options of the semismooth Newton method."""

    tol: float = field(default=1e-12, metadata={"help": "stop when the scaled ||Phi||_inf <= tol"})
    max_iterations: int = field(default=2000, metadata={"help": "Newton iterations in total"})
    step_iterations: int = field(default=30, metadata={"help": "Newton iterations per continuation step"})
    step_tol: float = field(default=1e-7,
                            metadata={"help": "tolerance of the intermediate continuation steps (the last uses tol)"})
    continuation: bool = field(default=True,
                               metadata={"help": "continuation in the dilatancy from tan(phi) to tan(psi)"})
    min_step: float = field(default=1e-4, metadata={"help": "smallest continuation step before giving up"})
    sigma: float = field(default=1e-4, metadata={"help": "Armijo sufficient-decrease constant, in (0, 0.5)"})
    backtrack: float = field(default=0.5, metadata={"help": "step reduction factor of the line search, in (0, 1)"})
    max_backtracks: int = field(default=40, metadata={"help": "step reductions before a direction is given up"})
    regularisation: float = field(default=1.0,
                                  metadata={"help": "Levenberg-Marquardt fallback: nu = regularisation * ||Phi||"})
    time_limit: float = field(default=float("inf"), metadata={"help": "seconds"})

    def __post_init__(self) -> None:
        check.positive(self, "tol", "step_tol", "regularisation")
        check.integer(self, "max_iterations", "step_iterations", "max_backtracks", minimum=0)
        check.interval(self, "sigma", 0, 0.5)
        check.interval(self, "backtrack", 0, 1)
        check.boolean(self, "continuation")
        check.interval(self, "min_step", 0, 1, closed="right")
        check.positive(self, "time_limit", finite=False)


@register_solver
class MCPNewton(SolverBase):
    """Semismooth (Fischer–Burmeister) Newton method for the MCP (3)."""

    name = "mcp-newton"
    problem = "non-associative"
    summary = "MCP (3): Fischer-Burmeister semismooth Newton from the associative solution (PATH stand-in)"
    requires = ("highspy", "pyomo", "scipy")
    Options = NewtonOptions

    def setup(self, ops):
        from blockmpec.formulations import compile_mcp
        from blockmpec.solvers.static_lp import StaticLP

        self.ops = ops
        self.form = compile_mcp(ops)  # (3), compiled once
        self.start_lp = StaticLP(time_limit=self.options.time_limit)  # the associative start
        self.start_lp.setup(ops)

    def run(self) -> RunOutput:
        from blockmpec import facts
        from blockmpec.solvers.engines.newton_system import MCPSystem, semismooth_newton
        from blockmpec.solvers.engines.stopping import StoppingCriterion

        opt = self.options
        form = self.form
        # one criterion for the run: every Newton iteration, the time limit, the trace
        stop = StoppingCriterion(opt.tol, opt.max_iterations, opt.time_limit, measure_name="residual").start()
        start = self.start_lp.run()
        if start.status is not Status.OPTIMAL:
            passed_on = (Status.UNBOUNDED, Status.INFEASIBLE, Status.INFEASIBLE_OR_UNBOUNDED, Status.TIME_LIMIT)
            return RunOutput(start.status if start.status in passed_on else Status.ERROR,
                             message=f"associative start failed: {start.status.value} ({start.message})",
                             raw_status="static LP")
        solution = start.solution
        t_done, dt = 0.0, 1.0
        status, message = Status.ITERATION_LIMIT, ""
        n_steps = n_failed = 0
        while True:
            remaining = stop.remaining()
            budget = opt.max_iterations - stop.iterations
            if remaining <= 0 or budget <= 0:
                status = Status.TIME_LIMIT if remaining <= 0 else Status.ITERATION_LIMIT
                message = f"{status.value} at continuation parameter t = {t_done:.4g}"
                break
            t_next = min(1.0, t_done + dt)
            final = t_next >= 1.0
            step_form = form if final else form.with_dilatancy((1 - t_next) * form.friction + t_next * form.dilatancy)
            system = MCPSystem(step_form, solution)
            limit = budget if not opt.continuation else min(budget, opt.step_iterations)
            out = semismooth_newton(
                system, system.pack(solution), tol=opt.tol if final else max(opt.tol, opt.step_tol),
                max_iterations=limit, sigma=opt.sigma, backtrack=opt.backtrack, max_backtracks=opt.max_backtracks,
                regularisation=opt.regularisation, stop=stop, continuation=t_next,
            )
            if out.status is Status.CONVERGED:
                n_steps += 1
                solution, t_done = out.solution, t_next
                if final:
                    status, message = Status.CONVERGED, out.message
                    break
                dt = min(2 * dt, 1.0)
                continue
            n_failed += 1
            if not opt.continuation or out.status is Status.TIME_LIMIT:
                solution, status, message = out.solution, out.status, out.message
                break
            dt /= 2
            if dt < opt.min_step:
                status = Status.NUMERICAL
                message = (f"continuation stalled at t = {t_done:.4g} (step < {opt.min_step:g}); "
                           f"last attempt: {out.message}")
                if t_done == 0.0:
                    solution = out.solution
                break
        kinds = [r["direction"] for r in stop.trace]
        extra = {facts.ASSOCIATIVE_MULTIPLIER: start.solution.multiplier,
                 "continuation_reached": t_done,
                 "continuation_steps": n_steps,
                 "continuation_failures": n_failed,
                 "newton_steps": kinds.count("newton"),
                 "levenberg_marquardt_steps": kinds.count("levenberg-marquardt"),
                 "gradient_steps": kinds.count("gradient")}
        if status is not Status.CONVERGED and t_done < 1.0 and n_steps > 0:
            message += " (the returned iterate solves (3) with an intermediate dilatancy only)"
        return RunOutput(status, solution, iterations=stop.iterations, trace=stop.trace, message=message,
                         raw_status=status.value, extra=extra)

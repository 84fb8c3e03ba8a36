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
(:func:`blockmpec.solvers.engines.newton_system.semismooth_newton`).

Start (``start``).  (3) has many solutions and Newton finds the one near its
start, so the start decides the answer:

* ``"fixed-point"`` (default): the solution of the registered ``fixed-point``
  method with its own defaults (which aim at the minimum of (4)); Newton then
  solves (3) at ``tan(psi)`` from it (usually it already meets ``tol`` or
  needs a few polishing steps).
* ``"dead-load"`` / ``"random"``: one step of ``fixed-point`` from the normal
  forces under the dead load alone, or from the associative forces scaled by
  seeded uniform factors in [0, 1] (``seed``): the LP (5) with those forces'
  cohesion gives ``(lam, x, u, z)`` that solve (3) except the friction flow.
* ``"nlp"``: the solution of the registered ``nlp`` method (MPEC (4) by a
  relaxed NLP).
* ``"associative"``: the associative solution (static LP (1) with HiGHS and its
  duals), which solves (3) with the dilatancy ``tan(phi)``; with
  ``continuation`` the dilatancy is moved from there to its own value,
  ``tan(psi_t) = (1 - t) tan(phi) + t tan(psi)``, ``t: 0 -> 1``
  (:meth:`~blockmpec.formulations.CompiledMCP.with_dilatancy`): each step is a
  Newton solve of at most ``step_iterations`` iterations from the previous
  solution; the step in ``t`` starts at 1 (direct solve), is halved after a
  failure and doubled after a success.  It follows the branch of the
  associative solution and mostly returns the associative multiplier (the
  behaviour before the strategy study).

From the other starts Newton solves (3) at ``tan(psi)`` directly: with
setting ``fallback``, in at most ``step_iterations`` iterations, and a start that fails,
or from which Newton does not converge, is followed by the associative path within
the remaining time and iterations (without it, with the whole budget)
(``Result.extra["start"]`` names the start that gave the answer).  One
:class:`~blockmpec.solvers.engines.stopping.StoppingCriterion` spans the run: it
counts every Newton iteration against ``max_iterations``, keeps the run's deadline
(the start's solver runs within it too) and writes the trace
(``iteration, time_s, residual, merit, step, direction, multiplier, continuation``).

The Jacobian is singular at every solution of a hyperstatic structure (the forces
``x`` of the rigid part are not unique), and the Fischer–Burmeister merit can have
stationary points that are not solutions; hence the continuation and the fallback.

The answer is *a* solution of (3), not necessarily the minimum of (4); its
multiplier lies between the non-associative minimum and the associative one.
The default start was chosen by ``studies/lab/mcp_newton_strategies.py`` on the
heuristic suite (``studies/lab/heuristic_suite.py``): from the fixed point's solution
the run is verified and within 1 % of the certified minimum on all 56 certified
structures (28 of 28 where the minimum lies below the associative multiplier,
against 1 of 28 from the associative start), within 2 % of the best verified value
on the 3 large walls, never below a certificate, at a median solve time 1.07x the
associative start's.  The dead-load, random and nlp starts reach fewer minima
(26, 12-21 and 26 of 28) and none of the large walls' best values.

Status: ``CONVERGED`` when ``||Phi||_inf <= tol``; ``ITERATION_LIMIT``,
``TIME_LIMIT`` or ``NUMERICAL`` (stalled line search) with the last iterate.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from blockmpec import options as check
from blockmpec.method import SolverBase
from blockmpec.options import CommonOptions
from blockmpec.registry import register_solver
from blockmpec.result import RunOutput, Status
from blockmpec.solvers import plan

#: starting points of the Newton iteration (see the module docstring)
STARTS = ("fixed-point", "dead-load", "random", "nlp", "associative")

#: the options of the registered method each start runs (``fixed-point`` one step for the perturbed starts)
_START_METHODS = {
    "fixed-point": ("fixed-point", {}),
    "dead-load": ("fixed-point", {"start": "dead-load", "max_iterations": 1}),
    "random": ("fixed-point", {"start": "random", "max_iterations": 1}),
    "nlp": ("nlp", {}),
}

#: statuses of a start whose solution is worth starting Newton from
_USABLE_START = (Status.OPTIMAL, Status.CONVERGED, Status.LOCALLY_OPTIMAL, Status.ACCEPTABLE,
                 Status.ITERATION_LIMIT, Status.TIME_LIMIT)


@dataclass
class NewtonOptions(CommonOptions):
    """Options of the semismooth Newton method."""

    start: str = field(default="fixed-point", metadata={
        "help": "the starting point: fixed-point | dead-load | random | nlp | associative (continuation in the "
                "dilatancy from the associative solution)"})
    seed: int = field(default=0, metadata={"help": "seed of the random start"})
    tol: float = field(default=1e-12, metadata={"help": "stop when the scaled ||Phi||_inf <= tol"})
    max_iterations: int = field(default=2000, metadata={"help": "Newton iterations in total"})

    def __post_init__(self) -> None:
        super().__post_init__()
        check.choice(self, "start", STARTS)
        check.integer(self, "seed", minimum=0)
        check.positive(self, "tol")
        check.integer(self, "max_iterations", minimum=0)


@dataclass
class NewtonSettings:
    """Engine settings of the semismooth Newton method (experiments: ``studies/lab``).

    Attributes
    ----------
    fallback : bool
        After a failed start or a Newton run that does not converge, the associative path.
    step_iterations : int
        Newton iterations per continuation step (and from a non-associative start, with fallback).
    step_tol : float
        Tolerance of the intermediate continuation steps (the last uses ``tol``).
    continuation : bool
        Associative start: continuation in the dilatancy from ``tan(phi)`` to ``tan(psi)``.
    min_step : float
        Smallest continuation step before giving up.
    sigma, backtrack, max_backtracks : float, float, int
        Armijo's sufficient-decrease constant, the step reduction factor and the most reductions.
    regularisation : float
        Levenberg-Marquardt fallback: ``nu = regularisation * ||Phi||``.
    """

    fallback: bool = True
    step_iterations: int = 30
    step_tol: float = 1e-7
    continuation: bool = True
    min_step: float = 1e-4
    sigma: float = 1e-4
    backtrack: float = 0.5
    max_backtracks: int = 40
    regularisation: float = 1.0

    def __post_init__(self) -> None:
        check.boolean(self, "fallback", "continuation")
        check.positive(self, "step_tol", "regularisation")
        check.integer(self, "step_iterations", "max_backtracks", minimum=0)
        check.interval(self, "sigma", 0, 0.5)
        check.interval(self, "backtrack", 0, 1)
        check.interval(self, "min_step", 0, 1, closed="right")


@register_solver
class MCPNewton(SolverBase):
    """Semismooth (Fischer–Burmeister) Newton method for the MCP (3)."""

    name = "mcp-newton"
    problem = "non-associative"
    summary = "MCP (3): Fischer-Burmeister semismooth Newton from the fixed point's solution (PATH stand-in)"
    requires = ("highspy", "pyomo", "scipy")
    Options = NewtonOptions
    Settings = NewtonSettings

    def setup(self, ops):
        from blockmpec.formulations import compile_mcp
        from blockmpec.registry import get_solver
        from blockmpec.solvers.static_lp import StaticLP

        opt = self.options
        self.ops = ops
        self.form = compile_mcp(ops)  # (3), compiled once
        self.start_lp = None
        if opt.start == "associative" or self.settings.fallback:
            self.start_lp = StaticLP()  # the associative start (within the run's deadline)
            self.start_lp.verify_tol = self.verify_tol
            self.start_lp.setup(ops)
        self.start_solver = None
        if opt.start != "associative":
            method, start_options = _START_METHODS[opt.start]
            start_options = dict(start_options)
            if opt.start == "random":
                start_options["seed"] = opt.seed
            self.start_solver = get_solver(method)(**start_options)  # the registered method, not a copy
            self.start_solver.verify_tol = self.verify_tol
            self.start_solver.setup(ops)
        self.plan = plan.mcp_newton_plan(opt.start, fallback=opt.start != "associative" and self.settings.fallback)

    # ------------------------------------------------------------------ paths

    def _newton(self, form, solution, stop, max_iterations, tol, t):
        from blockmpec.solvers.engines.newton_system import MCPSystem, semismooth_newton

        st = self.settings
        system = MCPSystem(form, solution)
        return semismooth_newton(
            system, system.pack(solution), tol=tol, max_iterations=max_iterations, sigma=st.sigma,
            backtrack=st.backtrack, max_backtracks=st.max_backtracks, regularisation=st.regularisation,
            stop=stop, continuation=t)

    def _budget(self, stop):
        """(status, message) when the run's time or iterations are spent, else None."""
        if stop.out_of_time():
            return Status.TIME_LIMIT
        if self.options.max_iterations - stop.iterations <= 0:
            return Status.ITERATION_LIMIT
        return None

    def _associative_path(self, stop, counts):
        """Static LP (1), then the continuation in the dilatancy ``tan(phi) -> tan(psi)``."""
        opt, st = self.options, self.settings
        form = self.form
        start = self.start_lp.run(stop.deadline)
        if start.status is not Status.OPTIMAL:
            passed_on = (Status.UNBOUNDED, Status.INFEASIBLE, Status.INFEASIBLE_OR_UNBOUNDED, Status.TIME_LIMIT)
            return (start.status if start.status in passed_on else Status.ERROR, start.solution,
                    f"associative start failed: {start.status.value} ({start.message})", None)
        solution = start.solution
        t_done, dt = 0.0, 1.0
        status, message = Status.ITERATION_LIMIT, ""
        while True:
            spent = self._budget(stop)
            if spent is not None:
                status = spent
                message = f"{status.value} at continuation parameter t = {t_done:.4g}"
                break
            budget = opt.max_iterations - stop.iterations
            t_next = min(1.0, t_done + dt)
            final = t_next >= 1.0
            step_form = form if final else form.with_dilatancy((1 - t_next) * form.friction + t_next * form.dilatancy)
            limit = budget if not st.continuation else min(budget, st.step_iterations)
            out = self._newton(step_form, solution, stop, limit, opt.tol if final else max(opt.tol, st.step_tol),
                               t_next)
            if out.status is Status.CONVERGED:
                counts["continuation_steps"] += 1
                solution, t_done = out.solution, t_next
                if final:
                    status, message = Status.CONVERGED, out.message
                    break
                dt = min(2 * dt, 1.0)
                continue
            counts["continuation_failures"] += 1
            if not st.continuation or out.status is Status.TIME_LIMIT:
                solution, status, message = out.solution, out.status, out.message
                break
            dt /= 2
            if dt < st.min_step:
                status = Status.NUMERICAL
                message = (f"continuation stalled at t = {t_done:.4g} (step < {st.min_step:g}); "
                           f"last attempt: {out.message}")
                if t_done == 0.0:
                    solution = out.solution
                break
        counts["continuation_reached"] = t_done
        if status is not Status.CONVERGED and t_done < 1.0 and counts["continuation_steps"] > 0:
            message += " (the returned iterate solves (3) with an intermediate dilatancy only)"
        return status, solution, message, start.solution.multiplier

    def _started_path(self, stop):
        """The start's solver (registered method) within the run's deadline, then Newton at ``tan(psi)``."""
        opt = self.options
        start = self.start_solver.run(stop.deadline)
        from blockmpec import facts

        lam_assoc = start.extra.get(facts.ASSOCIATIVE_MULTIPLIER)
        if start.status not in _USABLE_START or start.solution.multiplier is None:
            return start.status, start.solution, f"{opt.start} start failed: {start.status.value}", lam_assoc
        spent = self._budget(stop)
        if spent is not None:
            return spent, start.solution, f"{spent.value} after the {opt.start} start", lam_assoc
        # near a solution Newton converges in a few steps; past step_iterations it wanders (leave time for the fallback)
        limit = opt.max_iterations - stop.iterations
        if self.settings.fallback:
            limit = min(limit, self.settings.step_iterations)
        out = self._newton(self.form, start.solution, stop, limit, opt.tol, 1.0)
        return out.status, out.solution, out.message, lam_assoc

    def run(self, deadline) -> RunOutput:
        from blockmpec import facts
        from blockmpec.solvers.engines.stopping import StoppingCriterion

        opt = self.options
        # one criterion for the run: every Newton iteration, the deadline, the trace
        stop = StoppingCriterion(opt.tol, opt.max_iterations, deadline, measure_name="residual").start()
        counts = {"continuation_reached": 0.0, "continuation_steps": 0, "continuation_failures": 0}
        start_used = opt.start
        lam_assoc = None
        self.plan.start("start")
        self.plan.start("newton")
        if opt.start == "associative":
            status, solution, message, lam_assoc = self._associative_path(stop, counts)
        else:
            status, solution, message, lam_assoc = self._started_path(stop)
            if status is not Status.CONVERGED and self.settings.fallback and self._budget(stop) is None:
                first = f"{opt.start} start: {message}"
                self.plan.start("fallback")
                status, solution, message, lam_assoc = self._associative_path(stop, counts)
                start_used = "associative"
                message = f"{message} (fallback after {first})"
        kinds = [r["direction"] for r in stop.trace]
        extra = {"start": start_used, **counts, "newton_steps": kinds.count("newton"),
                 "levenberg_marquardt_steps": kinds.count("levenberg-marquardt"),
                 "gradient_steps": kinds.count("gradient")}
        if lam_assoc is not None:
            extra[facts.ASSOCIATIVE_MULTIPLIER] = lam_assoc
        return RunOutput(status, solution, iterations=stop.iterations, trace=stop.trace, message=message,
                         raw_status=status.value, extra=extra)

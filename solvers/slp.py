r"""``slp``: the sequential-LP heuristic of Gilbert, Casapulla & Ahmed (2006).

Reference: M. Gilbert, C. Casapulla, H.M. Ahmed, "Limit analysis of masonry block
structures with non-associative frictional joints using linear programming",
Computers & Structures 84 (2006) 873-887.  Each iteration solves an associative
LP whose Coulomb surface is replaced by a modified surface fixed by the normal
forces of the previous iteration; iterations stop when the collapse multiplier
no longer changes.

Reading implemented here (the full text was not available to check the exact
form of ``alpha``; this reading is stated so it can be checked).  LP ``k`` at
normal forces ``n*`` has friction rows, per interface::

    |t| <= -tan(psi) n - (tan(phi) - tan(psi)) ((1 - alpha) n* + alpha n)
         = -s n - (tan(phi) - s) n*,     s = tan(psi) + alpha (tan(phi) - tan(psi))

a line through the Coulomb point ``(n*, -tan(phi) n*)`` whose slope departs from
the dilatancy slope by the fraction ``alpha`` of the way to Coulomb's: ``alpha``
says how far each LP's surface may follow normal forces away from the previous
ones (``alpha = 0``: eq. (5) of the fixed-point method; ``alpha = 1``: the
associative LP).  Relaxation: ``n* <- beta n + (1 - beta) n*``.  Published
defaults ``alpha = 0.01``, ``beta = 0.6``.  Stopping test, as published, on the
multiplier: ``|lam_k - lam_{k-1}| <= tol``, compared from the second LP step on
(at least 2 steps: the first step at the associative forces usually returns
``lam_1 = lam_assoc`` and would stop at once).  The default ``tol = 1e-6`` is this
package's choice, not a published value.  The step LPs are the fixed point's
(:mod:`blockmpec.solvers.engines.lp_sequence`): built once, warm re-solves; ``tie_break`` defaults
to ``"none"`` as published.

``alpha_schedule="halving"`` tilts step ``k`` by ``alpha / 2^(k-1)`` (0 once below
1e-6): the surface starts near Coulomb's and returns to the modified LP (5) of the
fixed point, as schedules that let ``alpha`` decay do; the coefficients change in
the persistent HiGHS LP (:meth:`~blockmpec.solvers.engines.lp_sequence.LPSequence.set_alpha`).

With ``alpha = 0``, ``beta = 1`` an SLP step is exactly a fixed-point step (same
LP, same update).

What the result means.  Nothing checks ``n = n*``, so at the stop the forces may
violate Coulomb's condition ``N_f^T x <= 0`` by up to ``(tan(phi) - s) |n - n*|``
per row; the Nodargi et al. paper reports a friction-admissibility error around
10% for this method.  With ``alpha > 0`` the mechanism (duals of the LP) also has
dilatancy ``s > tan(psi)``, so compatibility with ``V_f`` is not exact either.  The
shared verifier checks (3) with ``V_f``: expect it to mark an SLP result
unverified (status NUMERICAL) -- that is the honest outcome, not a failure of the
code.  ``extra["friction_admissibility"]`` and the trace report the error.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from blockmpec import options as check
from blockmpec.facts import ASSOCIATIVE_MULTIPLIER
from blockmpec.method import SolverBase
from blockmpec.options import CommonOptions
from blockmpec.registry import register_solver
from blockmpec.result import RunOutput, Status
from blockmpec.solvers.plan import BASIS_ALGORITHMS

ALPHA_SCHEDULES = ("constant", "halving")


def alpha_of_step(alpha: float, schedule: str, k: int) -> float:
    """The tilt of step ``k`` (1-based) under ``schedule``."""
    if schedule == "constant":
        return alpha
    a = alpha * 0.5 ** (k - 1)
    return a if a >= 1e-6 else 0.0


@dataclass
class SLPOptions(CommonOptions):
    """Options of the SLP heuristic (Gilbert, Casapulla & Ahmed's published values by default)."""

    alpha: float = field(default=0.01, metadata={
        "help": "in [0, 1]: slope of each LP's friction surface, tan(psi) + alpha (tan(phi) - tan(psi))"})
    alpha_schedule: str = field(default="constant", metadata={
        "help": "constant | halving: alpha_k = alpha / 2^(k-1), 0 once below 1e-6 (surface tilted back to (5))"})
    beta: float = field(default=0.6, metadata={"help": "relaxation in (0, 1]: n* <- beta n + (1 - beta) n*"})
    tol: float = field(default=1e-6, metadata={"help": "stop when |lam_k - lam_(k-1)| <= tol (k >= 2)"})
    max_iterations: int = field(default=500, metadata={"help": "most LP steps"})

    def __post_init__(self) -> None:
        super().__post_init__()
        check.interval(self, "alpha", 0, 1, closed="both")
        check.choice(self, "alpha_schedule", ALPHA_SCHEDULES)
        check.interval(self, "beta", 0, 1, closed="right")
        check.positive(self, "tol")
        check.integer(self, "max_iterations", minimum=2)


@dataclass
class SLPSettings:
    """Engine settings of the SLP (experiments: ``studies/lab``): a tie-break rule of the fixed point's
    (:data:`~blockmpec.solvers.engines.lp_sequence.TIE_BREAKS`; ``"none"`` as published) and the HiGHS algorithm."""

    tie_break: str = "none"
    algorithm: str = "auto"

    def __post_init__(self) -> None:
        from blockmpec.solvers.engines.lp_sequence import TIE_BREAKS

        check.choice(self, "tie_break", TIE_BREAKS)
        check.choice(self, "algorithm", BASIS_ALGORITHMS)


@register_solver
class SLP(SolverBase):
    """Non-associative limit analysis by the SLP heuristic of Gilbert et al. (2006)."""

    name = "slp"
    problem = "non-associative"
    exact_solution = False
    summary = "SLP heuristic (Gilbert et al. 2006): LP sequence stopped on the multiplier; friction not enforced"
    requires = ("highspy", "pyomo")
    Options = SLPOptions
    Settings = SLPSettings

    def setup(self, ops):
        from blockmpec.formulations import step_lps
        from blockmpec.solvers.engines.lp_sequence import LPSequence
        from blockmpec.solvers.engines.scaling import LoadUnits
        from blockmpec.solvers.plan import slp_plan

        self.ops = ops
        o, st = self.options, self.settings
        self.plan = slp_plan(o.alpha, o.alpha_schedule)
        lps = step_lps(ops, alpha=o.alpha, tie_break=st.tie_break != "none", associative=True)
        self.sequence = LPSequence(lps, LoadUnits.of(ops), alpha=o.alpha, tie_break=st.tie_break,
                                   algorithm=st.algorithm)

    def run(self, deadline) -> RunOutput:
        from blockmpec.solvers.engines.lp_sequence import run_sequence

        o = self.options
        self.plan.start("steps")
        out, facts = run_sequence(self.sequence, start="associative", relaxation=o.beta, stop_on="multiplier",
                                  tol=o.tol, max_iterations=o.max_iterations, deadline=deadline,
                                  min_iterations=2,
                                  alpha_schedule=None if o.alpha_schedule == "constant"
                                  else (lambda k: alpha_of_step(o.alpha, o.alpha_schedule, k)))
        out.extra.update({ASSOCIATIVE_MULTIPLIER: facts["lam_start"], "tie_break_failures": facts["tie_break_failures"]})
        if out.trace:
            last = out.trace[-1]
            out.extra["friction_admissibility"] = last["friction_admissibility"]
            out.extra["n_change"] = last["n_change"]
        if out.status is Status.CONVERGED:
            last = out.trace[-1]
            out.message = (f"multiplier settled in {out.iterations} LP steps (|lam_k - lam_(k-1)| = "
                           f"{last['lam_change']:.2e} <= {o.tol:g}); SLP does not check normal forces: "
                           f"||n - n*||/||n|| = {last['n_change']:.2e}, friction admissibility error "
                           f"{last['friction_admissibility']:.2e}")
        return out

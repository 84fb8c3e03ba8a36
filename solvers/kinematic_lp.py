"""``kinematic-lp``: the associative kinematic LP (2) with HiGHS, in load units (:mod:`blockmpec.solvers.engines.scaling`).

The interface forces are the duals of the compatibility rows (``x = y_c``) and
the multiplier is the dual of the normalisation row, which equals the optimal
value ``-f_d^T u``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from blockmpec import options as check
from blockmpec.method import SolverBase
from blockmpec.options import CommonOptions
from blockmpec.registry import register_solver
from blockmpec.result import RunOutput, Solution, Status
from blockmpec.solvers.plan import BASIS_ALGORITHMS


@dataclass
class KinematicLPOptions(CommonOptions):
    """Options of ``kinematic-lp`` (HiGHS only: the block IPM needs the static LP's shape)."""

    algorithm: str = field(default="auto", metadata={
        "help": "auto (HiGHS's dual simplex) | simplex | dual-simplex | primal-simplex | ipm"})

    def __post_init__(self) -> None:
        super().__post_init__()
        check.choice(self, "algorithm", BASIS_ALGORITHMS)


@register_solver
class KinematicLP(SolverBase):
    """Associative limit analysis by the kinematic theorem (2), solved by HiGHS."""

    name = "kinematic-lp"
    problem = "associative"
    summary = "associative kinematic LP (2) with HiGHS; forces from the duals"
    requires = ("highspy", "pyomo")
    Options = KinematicLPOptions

    def setup(self, ops):
        from blockmpec.formulations import compile_linear, kinematic_lp
        from blockmpec.solvers.engines.highs import MECHANISM_FEASIBILITY_TOL, HighsLP
        from blockmpec.solvers.engines.scaling import LoadUnits
        from blockmpec.solvers.plan import kinematic_lp_plan, lp_algorithm

        self.ops = ops
        self.units = LoadUnits.of(ops)
        self.lp = compile_linear(kinematic_lp(ops))
        algorithm = lp_algorithm(self.options.algorithm, self.lp.A.shape[0], need_basis=True)
        self.engine = HighsLP(self.lp, algorithm, scaling=self.units.kinematic(self.lp))
        self.plan = kinematic_lp_plan(algorithm)
        # z >= 0 are column bounds, held by HiGHS only to its primal feasibility tolerance (see FEASIBILITY_TOL and
        # MECHANISM_FEASIBILITY_TOL: at 1e-10 the kinematic LP agrees with the exact static LP to 1e-8 at 2,000 blocks)
        self.engine.set_feasibility_tolerances(MECHANISM_FEASIBILITY_TOL)

    def run(self, deadline) -> RunOutput:
        self.plan.start("kinematic")
        out = self.engine.solve(deadline=deadline)
        lp = self.lp
        sol = Solution()
        message = out.message
        if out.status is Status.OPTIMAL:
            sol = Solution(
                multiplier=float(out.objective * lp.objective_sign + lp.objective_offset),
                x=lp.row_values("compatibility", out.row_dual),
                u=lp.values("u", out.v),
                z_u=lp.values("z_u", out.v),
                z_f=lp.values("z_f", out.v),
            )
        elif out.status in (Status.INFEASIBLE, Status.INFEASIBLE_OR_UNBOUNDED):
            out.status, message = self._no_mechanism(out.status, deadline)
        elif out.status is Status.UNBOUNDED:
            message = "the kinematic LP is unbounded: no equilibrium exists (e.g. unstable under dead load)"
            out.status = Status.INFEASIBLE  # a dual with an unbounded objective proves the static LP infeasible
        return RunOutput(out.status, sol, out.iterations, message=message, raw_status=out.raw_status)

    def _no_mechanism(self, status: Status, deadline) -> tuple[Status, str]:
        """Status and message when the kinematic LP has no feasible mechanism.

        By LP duality its dual, the static LP (1), is then infeasible *or* unbounded, and both
        happen (a frictionless block between two walls has neither an equilibrium nor a
        mechanism).  One static LP solve (HiGHS's dual simplex, load units) says which, within
        the run's ``deadline``.
        """
        if deadline.expired():
            return status, (f"the kinematic LP is {status.value}: no feasible mechanism; the time limit left no "
                            "time to tell an infeasible static LP from an unbounded one")
        from blockmpec.formulations import compile_linear, static_lp
        from blockmpec.solvers.engines.lp_engine import cold_lp_engine

        self.plan.start("static")
        static = cold_lp_engine(compile_linear(static_lp(self.ops)), "dual-simplex", self.units).solve(
            deadline=deadline)
        if static.status is Status.UNBOUNDED:
            return Status.UNBOUNDED, ("the kinematic LP is infeasible and the static LP unbounded: no collapse "
                                      "mechanism exists for this live load")
        if static.status is Status.INFEASIBLE:
            return Status.INFEASIBLE, ("the kinematic LP is infeasible and so is the static LP: no equilibrium "
                                       "exists (e.g. unstable under dead load), and no mechanism either")
        return Status.INFEASIBLE_OR_UNBOUNDED, (
            f"the kinematic LP is {status.value} ({static.status.value} for the static LP): infeasible or "
            "unbounded: the structure may be unstable under dead load, or no mechanism exists")

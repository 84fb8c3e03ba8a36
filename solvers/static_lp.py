"""``static-lp``: the associative static LP (1) with HiGHS or the block interior-point method.

The collapse mechanism comes from the duals (:func:`blockmpec.solvers.engines.highs.static_lp_solution`):
``u = -y_eq`` (equilibrium rows) and ``z = -y`` (inequality rows), which with
HiGHS's sign convention gives ``E^T u + N_u z_u + N_f z_f = 0`` and ``f_l^T u = 1``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from blockmpec import options as check
from blockmpec.registry import register_solver
from blockmpec.result import Solution, Status
from blockmpec.solver import RunOutput, SolverBase


@dataclass
class LPOptions:
    """Options of the HiGHS LP adapters."""

    algorithm: str = field(default="auto", metadata={
        "help": "auto | simplex | dual-simplex | primal-simplex | ipm (HiGHS) | block-ipm (blockmpec.solvers.engines.block_ipm)"})
    time_limit: float = field(default=check.DEFAULT_TIME_LIMIT_S, metadata={
        "help": "seconds (HiGHS time_limit; the block IPM checks its clock every iteration); default 600 "
                "(blockmpec.options.DEFAULT_TIME_LIMIT_S: finite, ~13x the 10,046-block wall's LP), inf for none"})
    factor_processes: int | str = field(default="auto", metadata={
        "help": "auto | 1 | 2: processes for the block IPM's supernodal Cholesky (K of 30,000 rows or more, about "
                "10,000 blocks); 2 starts a worker process that factorises and solves one subtree half; auto: 2 "
                "with the supernodal Cholesky when two CPUs are usable, else 1 "
                "(studies/lp_timing.py --ipm-settings one_process,default). Other engines run as with 1"})

    def __post_init__(self) -> None:
        from blockmpec.solvers.engines.block_ipm import FACTOR_PROCESSES
        from blockmpec.solvers.engines.lp_engine import ALGORITHMS

        check.choice(self, "algorithm", ALGORITHMS)
        check.positive(self, "time_limit", finite=False)
        check.choice(self, "factor_processes", FACTOR_PROCESSES)


@register_solver
class StaticLP(SolverBase):
    """Associative limit analysis by the static theorem (1).

    ``algorithm="auto"``: HiGHS's dual simplex for small LPs, the block interior-point
    method (:mod:`blockmpec.solvers.engines.block_ipm`) for large or stiff LPs: the one rule is
    :func:`blockmpec.solvers.engines.lp_engine.select_algorithm`.
    """

    name = "static-lp"
    problem = "associative"
    summary = "associative static LP (1) with HiGHS or a block IPM; mechanism from the duals"
    requires = ("highspy", "pyomo")
    Options = LPOptions

    def setup(self, ops):
        from blockmpec.formulations import static_lp
        from blockmpec.formulations._pyomo import compiled_linear
        from blockmpec.solvers.engines.block_ipm import BlockIPM
        from blockmpec.solvers.engines.highs import HighsLP, set_feasibility_tolerances
        from blockmpec.solvers.engines.lp_engine import cold_lp_engine

        self.ops = ops
        self.lp = compiled_linear(static_lp, ops)  # cached per structure (content hash of ops)
        self.engine = cold_lp_engine(self.lp, self.options.algorithm, self.options.time_limit, ops=ops)
        if isinstance(self.engine, BlockIPM):
            self.engine.settings(factor_processes=self.options.factor_processes)
        if isinstance(self.engine, HighsLP):
            # the mechanism's z >= 0 are duals, held by HiGHS to its dual feasibility tolerance (FEASIBILITY_TOL)
            set_feasibility_tolerances(self.engine.highs)

    def run(self) -> RunOutput:
        from blockmpec.solvers.engines.highs import static_lp_solution

        out = self.engine.solve()
        sol = static_lp_solution(self.lp, out) if out.status.is_success else Solution()
        message = out.message
        if out.status is Status.UNBOUNDED:
            message = "the static LP is unbounded: no collapse mechanism exists for this live load"
        elif out.status is Status.INFEASIBLE:
            message = "the static LP is infeasible: no equilibrium exists (e.g. unstable under dead load)"
        elif out.status is Status.INFEASIBLE_OR_UNBOUNDED:
            message = (f"the static LP is infeasible or unbounded ({out.raw_status}): the structure may be unstable "
                       "under dead load, or no mechanism exists")
        extra = {}
        factoriser = getattr(self.engine, "_factoriser", None)
        if getattr(factoriser, "processes", 1) == 2:  # the worker process's CPU is not in this process's clock
            extra = {"factor_processes": 2, "factor_worker_cpu_s": factoriser.worker_cpu_s,
                     "factor_worker_factorisations": factoriser.worker_factorisations}
        return RunOutput(out.status, sol, out.iterations, message=message, raw_status=out.raw_status, extra=extra)

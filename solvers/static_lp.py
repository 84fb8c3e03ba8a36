"""``static-lp``: the associative static LP (1) with HiGHS or the block interior-point method.

The collapse mechanism comes from the duals (:func:`blockmpec.solvers.engines.highs.static_lp_solution`):
``u = -y_eq`` (equilibrium rows) and ``z = -y`` (inequality rows), which with
HiGHS's sign convention gives ``E^T u + N_u z_u + N_f z_f = 0`` and ``f_l^T u = 1``.

Fallback.  Under ``algorithm="auto"`` a block-IPM run that ends without a solution (``numerical``, ``error``,
``iteration_limit``) is followed, in the time left, by HiGHS's interior point with crossover on the same LP: the
answer is then HiGHS's, and the plan and the message name both.  Where the block IPM fails: stone walls with a
friction coefficient of about 1 or more.  There, wedged stones admit *self-stress*: interface forces in equilibrium
with no load (``E x = 0``) that satisfy every row of (1) and compress some interfaces.  Adding any multiple of one
to an optimal ``x`` keeps it optimal, so the optimal face is unbounded, the central path has no end point, and the
interior iterates can lose accuracy near the optimum; a simplex vertex is unaffected.  ``lam`` and the mechanism are
unique as usual; the forces are not (the measurements: ``docs/performance-irregular.md``).  The stages are the
plan's (:func:`~blockmpec.solvers.plan.static_lp_plan`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from blockmpec import options as check
from blockmpec.errors import OptionError
from blockmpec.method import SolverBase
from blockmpec.options import CommonOptions
from blockmpec.registry import register_solver
from blockmpec.result import RunOutput, Solution, Status
from blockmpec.solvers.plan import LP_ALGORITHMS

#: block-IPM outcomes after which ``algorithm="auto"`` solves the LP again with HiGHS (module docstring)
BLOCK_IPM_FAILURES = (Status.NUMERICAL, Status.ERROR, Status.ITERATION_LIMIT)


@dataclass
class LPOptions(CommonOptions):
    """Options of ``static-lp``."""

    algorithm: str = field(default="auto", metadata={
        "help": "auto (HiGHS's dual simplex for small LPs, the block interior-point method for large or stiff ones) "
                "| simplex | dual-simplex | primal-simplex | ipm (HiGHS) | block-ipm"})

    def __post_init__(self) -> None:
        super().__post_init__()
        check.choice(self, "algorithm", LP_ALGORITHMS)


@dataclass
class LPSettings:
    """Engine settings of ``static-lp`` (experiments: ``studies/lab``).

    Attributes
    ----------
    factor_processes : {"auto", 1, 2}
        Processes of the block IPM's supernodal Cholesky (``K`` of 30,000 rows or more, about 10,000 blocks):
        2 starts a worker process that factorises and solves one subtree half; ``"auto"``: 2 when two CPUs are
        usable (``studies/lab/lp_timing.py --ipm-settings one_process,default``).
    """

    factor_processes: int | str = "auto"


@register_solver
class StaticLP(SolverBase):
    """Associative limit analysis by the static theorem (1).

    ``algorithm="auto"``: HiGHS's dual simplex for small LPs, the block interior-point
    method (:mod:`blockmpec.solvers.linalg.block_ipm`) for large or stiff LPs: the one rule is
    :func:`blockmpec.solvers.plan.lp_algorithm`.
    """

    name = "static-lp"
    problem = "associative"
    summary = "associative static LP (1) with HiGHS or a block IPM; mechanism from the duals"
    requires = ("highspy", "pyomo")
    Options = LPOptions
    Settings = LPSettings

    def setup(self, ops):
        from blockmpec.formulations import static_lp
        from blockmpec.formulations.pyomo_compile import compiled_linear
        from blockmpec.solvers.engines.block_lp import BlockLP
        from blockmpec.solvers.engines.scaling import LoadUnits
        from blockmpec.solvers.plan import describe_block_ipm, static_lp_plan

        processes = self.settings.factor_processes
        if isinstance(processes, bool) or processes not in ("auto", 1, 2):  # True == 1 is no choice of processes
            raise OptionError(f"static-lp setting factor_processes must be auto, 1 or 2; got "
                              f"{self.settings.factor_processes!r}")
        self.ops = ops
        self.lp = compiled_linear(static_lp, ops)  # cached per structure (content hash of ops)
        self.units = LoadUnits.of(ops)
        self.engine = self._lp_engine(self.options.algorithm)
        block_ipm = isinstance(self.engine, BlockLP)
        if block_ipm:
            self.engine.settings(factor_processes=self.settings.factor_processes)
        self.plan = static_lp_plan("block-ipm" if block_ipm else self.engine.algorithm,
                                   fallback=self.options.algorithm == "auto",
                                   block_ipm=describe_block_ipm(self.engine) if block_ipm else "")

    def _lp_engine(self, algorithm: str):
        """The LP's engine for ``algorithm`` (:func:`~blockmpec.solvers.engines.lp_engine.cold_lp_engine`, in load
        units); a HiGHS engine holds the mechanism's ``z >= 0`` (its duals) to FEASIBILITY_TOL."""
        from blockmpec.solvers.engines.highs import HighsLP
        from blockmpec.solvers.engines.lp_engine import cold_lp_engine

        engine = cold_lp_engine(self.lp, algorithm, self.units)
        if isinstance(engine, HighsLP):
            engine.set_feasibility_tolerances()
        return engine

    def _highs_after_block_ipm(self, failed, deadline):
        """HiGHS's interior point with crossover on the LP, after a block-IPM run ``failed`` (module docstring)."""
        self.plan.start("fallback")
        out = self._lp_engine("ipm").solve(deadline=deadline)
        out.iterations += failed.iterations
        out.message = (f"{out.message} (HiGHS's interior point with crossover, after the block IPM ended "
                       f"{failed.status.value}: {failed.message})")
        return out

    def run(self, deadline) -> RunOutput:
        from blockmpec.solvers.engines.highs import static_lp_solution

        self.plan.start(self.plan.stages[0].key)
        out = self.engine.solve(deadline=deadline)
        if "fallback" in self.plan and out.status in BLOCK_IPM_FAILURES and not deadline.expired():
            out = self._highs_after_block_ipm(out, deadline)
        sol = static_lp_solution(self.lp, out) if out.status.is_success else Solution()
        extra: dict = {}
        factoriser = getattr(self.engine, "_factoriser", None)
        if getattr(factoriser, "processes", 1) == 2:  # the worker process's CPU is not in this process's clock
            extra.update({"factor_processes": 2, "factor_worker_cpu_s": factoriser.worker_cpu_s,
                          "factor_worker_factorisations": factoriser.worker_factorisations})
        return RunOutput(out.status, sol, out.iterations, message=self._message(out), raw_status=out.raw_status,
                         extra=extra)

    @staticmethod
    def _message(out) -> str:
        """The run's message: what an unbounded, infeasible or undecided static LP means."""
        if out.status is Status.UNBOUNDED:
            return "the static LP is unbounded: no collapse mechanism exists for this live load"
        if out.status is Status.INFEASIBLE:
            return "the static LP is infeasible: no equilibrium exists (e.g. unstable under dead load)"
        if out.status is Status.INFEASIBLE_OR_UNBOUNDED:
            return (f"the static LP is infeasible or unbounded ({out.raw_status}): the structure may be unstable "
                    "under dead load, or no mechanism exists")
        return out.message

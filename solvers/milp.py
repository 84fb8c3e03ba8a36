r"""``milp``: the certified global minimum of the MPEC (4), or the global maximum of ``lam`` over the solutions of (3).

A run has four stages, each within its share of the one time limit (:data:`BUDGET`, declared once):

1. **incumbents**: the associative optimum's pattern and the verified points of the ``heuristic`` methods
   (``fixed-point``, ``nlp``), each finished on its pattern's piece LPs (:meth:`MILPSolver.polish`), so an exact
   solution of (3); the best is the incumbent, and every later stop returns it unless the search finds better.
2. **bounds** (:mod:`~blockmpec.solvers.engines.mpec_bounds`): LP bounds on ``lam`` (the associative multiplier
   above; below, the largest of ``min lam`` over the statically admissible set, the kinematic bound and the
   dissipation bound of the work identity), then the bounds of the model (slacks, multipliers).  An incumbent that
   meets the lower bound within ``CERTIFICATE_TOL`` is certified here, with no search.  Bounds not reached within
   the stage's share keep their trivial values (valid, weaker).
3. **search**: ``engine="auto"`` runs the branch and bound over the complementarity pairs on the lifted LP of
   :mod:`~blockmpec.solvers.engines.complementarity_bnb` (``"bnb"``, ``sense="min"`` up to
   :data:`~blockmpec.solvers.plan.MILP_BNB_MAX_PAIRS` pairs) or HiGHS's branch and cut on the big-M model of
   :mod:`~blockmpec.formulations.mpec_milp` (``"highs"``; it needs every big-M proven in stage 2).  Both are
   relaxations of (4), so their dual bound is a certified bound on the minimum (an upper bound on the maximum).
4. **certify**: the search's point, finished on its pattern, against the incumbent; ``OPTIMAL`` only when the engine
   closed its gap, the point meets the bound within ``CERTIFICATE_TOL`` (times ``max(1, |lam|)``), no slack sits at
   its big-M, ``bigm_scale >= 1`` and every bound LP behind the bound was optimal.  Any other stop returns the best
   verified point, the bound and the gap (status ``TIME_LIMIT`` when the time ran out).

``sense="max"``: every bound and cut is a property of the *set* of solutions of (3), so the same model is a
relaxation for either sense; the certificate flips (the point must not exceed the bound; gap ``bound - lam``).

Statuses: ``infeasible`` only on a proof that (3) has no solution (the associative LP infeasible, the lifted
relaxation infeasible in every branch on checked Farkas certificates, or the big-M model with LP-proven bounds
proven infeasible).  A restriction (``bigm_scale < 1``) or a failed bound LP proves nothing of (3): ``error``.

Units: the stages run on (3) in per-block units (:func:`per_block_units`), so that the engines' absolute
tolerances hold block by block; the point, the bounds and the gaps are returned in the problem's units, and the
certificate is checked again there.

Facts in ``extra`` (names of :mod:`blockmpec.facts`): ``bound``, ``gap_abs``, ``gap_rel``, ``sense``,
``associative_multiplier``, ``lp_solves``, ``engine``; ``trace`` records ``(time_s, bound, incumbent, gap_abs)``
at every stage and over the search.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from blockmpec import facts
from blockmpec import options as check
from blockmpec.deadline import Deadline
from blockmpec.errors import OptionError
from blockmpec.method import SolverBase
from blockmpec.options import CommonOptions
from blockmpec.registry import get_solver, register_solver
from blockmpec.result import RunOutput, Solution, Status
from blockmpec.solvers import plan
from blockmpec.solvers.engines.milp_search import CERTIFICATE_TOL, lifting_options  # noqa: F401 (lifting_options: API)

__all__ = ["MILPSolver", "MILPOptions", "MILPSettings", "Budget", "BUDGET", "Stop", "ENGINES", "LIFTINGS", "ROOT_LPS",
           "BNB_DEFAULT_LIFTING", "BNB_DEFAULT_ROOT_LP", "CERTIFICATE_TOL", "lifting_options", "heuristic_names"]

ENGINES = plan.MILP_ENGINES
#: defaults of the bnb engine's settings (None in MILPSettings: "not set")
BNB_DEFAULT_LIFTING = "rlt-full"
BNB_DEFAULT_ROOT_LP = "ipm"
LIFTINGS = ("friction", "mechanism", "all", "rlt", "rlt-full")
ROOT_LPS = ("simplex", "ipm", "ipm-lifted")  # see complementarity_bnb.ROOT_LPS


@dataclass(frozen=True)
class Budget:
    """How a run's time limit is split between its stages (declared once: :data:`BUDGET`).

    Attributes
    ----------
    heuristic_share : float
        Each heuristic method runs within this share of the time limit (and at most ``heuristic_max_s``).
    heuristic_max_s : float
    bounds_share : float
        The bound LPs on ``lam`` (and, for engine="bnb", the model's bounds) stop this share of the time limit after
        they start (their unreached bounds stay trivial, which is valid); the search has the rest.  HiGHS's big-M
        model needs every slack bound, so engine="highs" proves them within the search's time.
    """

    heuristic_share: float = 0.1
    heuristic_max_s: float = 60.0
    bounds_share: float = 0.25

    def heuristic(self, deadline: Deadline) -> Deadline:
        """The deadline of one heuristic method."""
        return deadline.within(max(min(self.heuristic_share * deadline.seconds, self.heuristic_max_s), 1e-3))

    def bounds(self, deadline: Deadline) -> Deadline:
        """The deadline of the bound LPs, from now."""
        return deadline.within(self.bounds_share * deadline.seconds)


#: the one budget of every milp run
BUDGET = Budget()


@dataclass
class MILPOptions(CommonOptions):
    """Options of the ``milp`` method."""

    engine: str = field(default="auto", metadata={
        "help": "auto (the branch and bound over the pairs up to 400 pairs, HiGHS's big-M MILP above) | highs | bnb"})
    sense: str = field(default="min", metadata={
        "help": "min: the MPEC (4), least lam over the solutions of (3) | max: the largest lam over the same set"})
    mip_rel_gap: float = field(default=1e-9, metadata={"help": "stop when |incumbent - bound| <= this |incumbent|"})
    threads: int = field(default=1, metadata={"help": "the engine's threads"})

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.engine == "scip":
            raise ValueError("engine: 'scip' was removed on 2026-12-06 (no test ran it, and it certified nothing "
                             "the default does not); one of auto, highs, bnb")
        check.choice(self, "engine", ENGINES)
        check.choice(self, "sense", ("min", "max"))
        check.interval(self, "mip_rel_gap", 0, 1, closed="left")
        check.integer(self, "threads", minimum=1)


@dataclass
class MILPSettings:
    """Engine settings of ``milp`` (the module docstring explains each).

    Attributes
    ----------
    lam_branching : bool
        engine=bnb: also branch on ``lam`` (bisect the node's interval).
    lifting : str or None
        engine=bnb (None: :data:`BNB_DEFAULT_LIFTING`): one of :data:`LIFTINGS`.
    root_lp : str or None
        engine=bnb (None: :data:`BNB_DEFAULT_ROOT_LP`): one of :data:`ROOT_LPS`.
    mip_abs_gap : float
        Absolute gap on ``lam``.
    feasibility_tol : float
        Engine feasibility tolerance (the dual bound is exact up to about this).
    bigm_scale : float
        Factor on the proven slack bounds (< 1 only to test detection; never certifies).
    multiplier_bounds, envelope, dissipation_bound : bool
        Tighten ``z_i <= y_i`` by LPs; McCormick envelope of the work identity; the dissipation bound on ``lam``.
    heuristic : str
        Methods (comma-separated) whose verified points, polished on their patterns, are incumbents ('' for none).
    incumbent : bool
        Start from incumbents: the associative optimum's pattern (when it admits a mechanism) and the ``heuristic``
        methods' points (False: the search alone finds points).
    """

    lam_branching: bool = False
    lifting: str | None = None
    root_lp: str | None = None
    mip_abs_gap: float = 1e-9
    feasibility_tol: float = 1e-9
    bigm_scale: float = 1.0
    multiplier_bounds: bool = True
    envelope: bool = False
    dissipation_bound: bool = True
    heuristic: str = "fixed-point,nlp"
    incumbent: bool = True

    @property
    def sets_bnb_options(self) -> bool:
        """A setting of engine="bnb" is set (``lam_branching``, ``lifting`` or ``root_lp``)."""
        return self.lam_branching or self.lifting is not None or self.root_lp is not None

    def __post_init__(self) -> None:
        check.interval(self, "feasibility_tol", 1e-12, 1e-4, closed="both")
        check.positive(self, "bigm_scale")
        if not (isinstance(self.mip_abs_gap, (int, float)) and self.mip_abs_gap >= 0):
            raise ValueError(f"mip_abs_gap must be >= 0; got {self.mip_abs_gap!r}")
        if self.lifting is not None:
            check.choice(self, "lifting", LIFTINGS)
        if self.root_lp is not None:
            check.choice(self, "root_lp", ROOT_LPS)
        check.boolean(self, "lam_branching", "multiplier_bounds", "envelope", "dissipation_bound", "incumbent")
        if not isinstance(self.heuristic, str):
            raise ValueError(f"heuristic must be method names (comma-separated) or ''; got {self.heuristic!r}")
        from blockmpec.registry import list_solvers

        known = list_solvers("non-associative")
        for name in heuristic_names(self.heuristic):
            if name not in known or name == "milp":
                raise ValueError(f"heuristic: {name!r} is not a heuristic method; one of "
                                 f"{', '.join(m for m in known if m != 'milp')}")


def heuristic_names(heuristic: str) -> list[str]:
    """The method names of the ``heuristic`` setting (comma-separated; '' for none)."""
    return [name.strip() for name in heuristic.split(",") if name.strip()]


def _check_engine_settings(options: MILPOptions, settings: MILPSettings) -> None:
    """The options and settings that only fit together (raises ValueError naming them)."""
    if settings.sets_bnb_options and options.engine not in ("bnb", "auto"):
        raise ValueError("lam_branching, lifting and root_lp are settings of engine='bnb'")
    if settings.sets_bnb_options and options.engine == "auto" and options.sense != "min":
        raise ValueError("lam_branching, lifting and root_lp are settings of engine='bnb', which bounds the "
                         "minimum only (sense='max' runs engine='highs')")
    if options.engine == "bnb" and options.sense != "min":
        raise ValueError("engine='bnb' bounds the minimum only; use engine='highs' for sense='max'")


class Stop:
    """What a run found and proved so far, in the MILP's units: the best exact point, the bound, the trace."""

    def __init__(self, sense: str, t_start: float) -> None:
        self.sign = -1.0 if sense == "max" else 1.0  # min: lam - bound >= 0
        self.t_start = t_start
        self.best: Solution | None = None
        self.best_source = ""
        self.bound = -math.inf * self.sign
        self.trace: list[dict] = []

    def offer(self, sol: Solution | None, source: str) -> bool:
        """Keep ``sol`` if it is better than the best so far (lower ``lam`` for the minimum); True if kept."""
        if sol is None or sol.multiplier is None:
            return False
        if self.best is not None and self.sign * (sol.multiplier - self.best.multiplier) >= 0:
            return False
        self.best, self.best_source = sol, source
        return True

    def raise_bound(self, bound: float | None) -> None:
        """A new certified bound (kept only if it is stronger)."""
        if bound is not None and np.isfinite(bound) and self.sign * (bound - self.bound) > 0:
            self.bound = float(bound)

    @property
    def gap(self) -> float | None:
        """``lam - bound`` (min) or ``bound - lam`` (max), at least 0; None without a point or a bound."""
        if self.best is None or not np.isfinite(self.bound):
            return None
        return max(0.0, self.sign * (self.best.multiplier - self.bound))

    def record(self, stage: str) -> None:
        lam = None if self.best is None else self.best.multiplier
        self.trace.append({"iteration": len(self.trace), "stage": stage, "time_s": time.perf_counter() - self.t_start,
                           "bound": self.bound if np.isfinite(self.bound) else None, "incumbent": lam,
                           "gap_abs": self.gap})

    def facts(self) -> dict:
        """The bound and gap facts of this stop."""
        gap = self.gap
        out = {facts.BOUND: self.bound if np.isfinite(self.bound) else None}
        if gap is not None:
            out[facts.GAP_ABS] = gap
            out[facts.GAP_REL] = gap / max(abs(self.best.multiplier), 1e-12)
        return out

    def summary(self) -> str:
        """``best lam .., bound .., gap ..`` for messages."""
        lam = "no point of (3)" if self.best is None else f"best lam {self.best.multiplier:.10g}"
        bound = f"bound {self.bound:.10g}" if np.isfinite(self.bound) else "no bound"
        gap = "" if self.gap is None else f", gap {self.gap:.2e}"
        return f"{lam}, {bound}{gap}"


@register_solver
class MILPSolver(SolverBase):
    """Global minimum (or, ``sense="max"``, maximum) of the non-associative multiplier; see the module docstring.

    ``certifies_minimum``: status OPTIMAL with ``sense="min"`` (``extra["sense"] == "min"``) is a proven global
    minimum of (4).  With ``sense="max"`` OPTIMAL certifies the maximum instead; the comparator must not take it
    as the minimum.
    """

    name = "milp"
    problem = "non-associative"
    summary = ("certified global minimum of the MPEC (4) (sense=max: maximum of lam over solutions of (3)): "
               "LP bounds from the work identity, then a branch and bound over the pairs on a lifted LP "
               "(engine=auto; or HiGHS's big-M MILP)")
    certifies_minimum = True
    requires = ("highspy", "pyomo")
    Options = MILPOptions
    Settings = MILPSettings

    def __init__(self, **kwargs) -> None:
        super().__init__(**kwargs)
        try:
            _check_engine_settings(self.options, self.settings)
        except ValueError as exc:
            raise OptionError(f"method {self.name!r}: {exc}") from None

    def setup(self, ops):
        from blockmpec.formulations import compile_mcp
        from blockmpec.formulations.mpec_milp import work_matrix
        from blockmpec.solvers.engines.highs import HighsLP
        from blockmpec.solvers.engines.mpec_bounds import BoundLPs
        from blockmpec.solvers.engines.scaling import LoadUnits

        self.ops = ops
        original = compile_mcp(ops)
        #: (3) in per-block units and the inverse that travels with it (:meth:`MCPScaling.apply`)
        self.units = LoadUnits.of(ops).mcp(original).apply(original)
        form = self.form = self.units.form
        self._w_unit = self.units.unit
        #: the multiplier unit ``s`` of the MILP's per-block units (a power of two): ``lam = s lam^``
        self.lam_unit = self.units.lam_unit
        self.engine = self._resolve_engine(form)
        self.plan = plan.milp_plan(self.engine, self.settings.incumbent)
        self.lifting = self.settings.lifting or BNB_DEFAULT_LIFTING
        self.root_lp = self.settings.root_lp or BNB_DEFAULT_ROOT_LP
        self.work = work_matrix(form)
        self.bound_lps = BoundLPs(form)
        self.static, self.kinematic = self.bound_lps.static, self.bound_lps.kinematic
        self.polish_static = HighsLP(self.static, "dual-simplex")
        self.polish_kinematic = HighsLP(self.kinematic, "dual-simplex")

    def _resolve_engine(self, form) -> str:
        """``engine`` unless ``"auto"``: then ``"bnb"`` for ``sense="min"`` with a bnb setting set or at most
        :data:`~blockmpec.solvers.plan.MILP_BNB_MAX_PAIRS` pairs, else ``"highs"``."""
        opt = self.options
        if opt.engine == "auto" and opt.sense == "min" and self.settings.sets_bnb_options:
            return "bnb"
        return plan.milp_engine(opt.engine, opt.sense, form.n_pairs)

    # ------------------------------------------------------------------ 2. bounds
    def root_bounds(self, deadline: Deadline, associative: tuple | None = None):
        """The LP bounds on ``lam`` (:func:`~blockmpec.solvers.engines.mpec_bounds.root_bounds`) in the MILP's
        units, within ``deadline``; raises :class:`~blockmpec.solvers.engines.mpec_bounds.BoundFailure`."""
        from blockmpec.solvers.engines.mpec_bounds import root_bounds

        st = self.settings
        return root_bounds(self.bound_lps, self.work, st.dissipation_bound, st.envelope, deadline, associative)

    def model_bounds(self, bd, deadline: Deadline):
        """``bd`` with the model's slack and multiplier bounds (:func:`~.mpec_bounds.model_bounds`)."""
        from blockmpec.solvers.engines.mpec_bounds import model_bounds

        return model_bounds(self.bound_lps, bd, self.settings.multiplier_bounds, deadline)

    def lp_bounds(self, deadline: Deadline):
        """Every LP bound of the MILP: :meth:`root_bounds` then :meth:`model_bounds` (after :meth:`setup`)."""
        return self.model_bounds(self.root_bounds(deadline), deadline)

    # ------------------------------------------------------------------ 3. the search's models (tests, studies)
    def branch_and_bound(self, bd, **overrides):
        """:func:`~blockmpec.solvers.engines.milp_search.branch_and_bound` on this structure."""
        from blockmpec.solvers.engines.milp_search import branch_and_bound

        return branch_and_bound(self, bd, **overrides)

    def build_mip(self, bd, tau_min: float = 0.0):
        """:func:`~blockmpec.solvers.engines.milp_search.build_mip` on this structure."""
        from blockmpec.solvers.engines.milp_search import build_mip

        return build_mip(self, bd, tau_min)

    def start_vector(self, mip, sol: Solution | None):
        """:func:`~blockmpec.solvers.engines.milp_search.start_vector` on this structure."""
        from blockmpec.solvers.engines.milp_search import start_vector

        return start_vector(self, mip, sol)

    # ------------------------------------------------------------------ the pattern's exact point
    def pattern_mechanism(self, active: np.ndarray):
        """The mechanism of the pattern ``active``: ``min 1^T z`` over the compatible ``(u, z)`` with
        ``f_l^T u = 1`` and ``z_i = 0`` off ``active``; ``(u, z)`` in the MILP's units, or None when the pattern
        admits no mechanism (:func:`~blockmpec.solvers.engines.piece_lp.mechanism_piece`)."""
        from blockmpec.solvers.engines.piece_lp import mechanism_piece

        out = mechanism_piece(self.polish_kinematic, active)
        if out.status is not Status.OPTIMAL:
            return None
        return self.kinematic.values("u", out.v), self.kinematic.values("z", out.v)

    def polish(self, active: np.ndarray) -> tuple[Solution | None, str]:
        """The exact point of (3) on the pattern ``active``: the static piece LP (``min lam``, ``max`` for
        ``sense="max"``, with ``G_i x = 0`` on ``active``) and :meth:`pattern_mechanism`; together they satisfy
        (3) with that active set.  ``(Solution, "")`` in the MILP's units, or ``(None, why)``."""
        from blockmpec.solvers.engines.piece_lp import static_piece

        out = static_piece(self.polish_static, active, sense=1.0 if self.options.sense == "min" else -1.0)
        if out.status is not Status.OPTIMAL:
            return None, f"polish LP for (lam, x) is {out.status.value}"
        mech = self.pattern_mechanism(active)
        if mech is None:
            return None, ("polish LP for (u, z) is infeasible: the pattern admits no mechanism with f_l^T u > 0 "
                          "(the relaxation's optimum has tau = 0)")
        return self._solution(float(out.v[0]), self.static.values("x", out.v), *mech), ""

    def _solution(self, lam: float, x: np.ndarray, u: np.ndarray, z: np.ndarray) -> Solution:
        form = self.form
        w = np.zeros(form.n_columns)
        w[form.lam], w[form.x], w[form.u], w[form.z] = lam, x, u, z
        return form.unpack(w)

    # ------------------------------------------------------------------ 1. incumbents
    def _incumbents(self, stop: Stop, lam_assoc: float, x_assoc: np.ndarray, deadline: Deadline) -> None:
        """Offer ``stop`` the associative optimum's pattern point and every heuristic's verified point, each
        finished on its pattern (an exact solution of (3))."""
        slack = -(self.form.pair_matrix @ x_assoc)
        active = slack <= 1e-9 * max(1.0, float(np.abs(slack).max(initial=0.0)))
        mech = self.pattern_mechanism(active)
        if mech is not None:
            stop.offer(self._solution(lam_assoc, x_assoc, *mech), "associative")
        for name in heuristic_names(self.settings.heuristic):
            if deadline.expired():
                break
            stop.offer(self._heuristic_point(name, BUDGET.heuristic(deadline)), name)

    def _heuristic_point(self, name: str, deadline: Deadline) -> Solution | None:
        """The registered method ``name``'s point within ``deadline``, if the shared verifier accepts it, finished
        on its pattern in the MILP's units (None otherwise)."""
        heuristic = get_solver(name)()
        heuristic.verify_tol = self.verify_tol
        heuristic.setup(self.ops)
        out = heuristic.run(deadline)
        if not (out.status.is_success and heuristic.verified(out.solution)):
            return None
        w = self.form.pack(self.scaled(out.solution))
        return self.polish(self.form.multipliers(w) > self.form.slack(w))[0]

    # ------------------------------------------------------------------ run
    def run(self, deadline: Deadline) -> RunOutput:
        """Stages 1-4 on the scaled (3), then the point, the bounds and the gaps back in the problem's units."""
        stop = Stop(self.options.sense, time.perf_counter())
        self._n_lps_before = self.bound_lps.n_lps
        out = self._run_scaled(deadline, stop)
        out.extra.setdefault(facts.BOUND, None)
        self._to_problem_units(out)
        if out.status is Status.OPTIMAL:
            self._recertify(out)
        return out

    def _run_scaled(self, deadline: Deadline, stop: Stop) -> RunOutput:
        from blockmpec.solvers.engines.mpec_bounds import BoundFailure

        try:
            associative = self.bound_lps.associative(deadline)
        except BoundFailure as fail:
            return self._failed(stop, fail)
        if self.settings.incumbent:
            self.plan.start("incumbent")
            self._incumbents(stop, associative[0], associative[2], deadline)
        stop.record("incumbent")
        bounds_deadline = BUDGET.bounds(deadline)
        self.plan.start("bounds")
        try:
            bd = self.root_bounds(bounds_deadline, associative)
        except BoundFailure as fail:
            return self._failed(stop, fail)
        stop.raise_bound(bd.lam_upper if stop.sign < 0 else bd.lam_lower)
        stop.record("bounds")
        extra = self._extra(bd)
        if self._closed(stop):
            extra[facts.ENGINE] = "root"
            word = "maximum" if stop.sign < 0 else "minimum"
            return self._finish(stop, Status.OPTIMAL, extra,
                                f"certified global {word} at the root: the incumbent meets the LP bound", "root")
        bd = self.model_bounds(bd, bounds_deadline if self.engine == "bnb" else deadline)
        extra = self._extra(bd)
        stop.record("model bounds")
        self.plan.start("engine")
        if self.engine == "bnb":
            from blockmpec.solvers.engines.milp_search import bnb_search

            return bnb_search(self, bd, stop, deadline, extra)
        from blockmpec.solvers.engines.milp_search import bigm_search

        return bigm_search(self, bd, stop, deadline, extra)

    def _closed(self, stop: Stop) -> bool:
        """The incumbent meets the bound within the certificate tolerance (a restriction never certifies)."""
        gap = stop.gap
        return (gap is not None and self.settings.bigm_scale >= 1
                and gap <= CERTIFICATE_TOL * max(1.0, abs(stop.best.multiplier)))

    def _extra(self, bd) -> dict:
        """The bound facts of ``bd`` for ``extra``."""
        return {facts.SENSE: self.options.sense, facts.ASSOCIATIVE_MULTIPLIER: bd.lam_associative,
                facts.LP_SOLVES: self.bound_lps.n_lps - self._n_lps_before, facts.ENGINE: self.engine,
                "lam_static_min": bd.lam_static_min, "lam_kinematic": bd.lam_kinematic,
                "lam_dissipation": bd.lam_dissipation, "bound_time_s": bd.time_s, "nodes": 0, "bigm": [],
                "bigm_active": [], "bounds_complete": bool(bd.models_complete)}

    def _failed(self, stop: Stop, fail) -> RunOutput:
        """A bound LP failed (``fail``): its status, with the best point found (a time limit keeps it)."""
        status = fail.run_status
        if status is Status.TIME_LIMIT:
            return self._finish(stop, Status.TIME_LIMIT, {}, f"time limit in the bound LPs: {fail}")
        stop.best = None if status in (Status.INFEASIBLE, Status.UNBOUNDED) else stop.best
        return self._finish(stop, status, {}, str(fail))

    def _finish(self, stop: Stop, status: Status, extra: dict, message: str, raw: str = "", nodes: int = 0,
                stage: str = "stop") -> RunOutput:
        """The run's output: ``stop``'s best point, bound and gap with ``status``; the message ends with them."""
        stop.record(stage)
        extra = {facts.SENSE: self.options.sense, facts.LP_SOLVES: self.bound_lps.n_lps - self._n_lps_before,
                 **extra, **stop.facts()}
        extra.setdefault("incumbent_source", stop.best_source or None)
        return RunOutput(status, stop.best if stop.best is not None else Solution(), nodes, stop.trace,
                         f"{message}; {stop.summary()}", raw or status.value, extra)

    # ------------------------------------------------------------------ units
    def scaled(self, sol: Solution) -> Solution:
        """A point of (3) in the problem's units -> the same point in the MILP's units (:meth:`MCPScaling.apply`)."""
        return self.form.unpack(self.units.to_units(self.form.pack(sol)))

    def unscaled(self, sol: Solution) -> Solution:
        """A point of (3) in the MILP's units -> the same point in the problem's units (the inverse of
        :meth:`scaled`)."""
        return self.form.unpack(self.units.from_units(self.form.pack(sol)))

    def _to_problem_units(self, out: RunOutput) -> None:
        """The point, the bounds, the gaps and the trace of ``out`` from the MILP's units to the problem's."""
        unit = self.lam_unit
        if out.solution is not None and out.solution.multiplier is not None:
            out.solution = self.unscaled(out.solution)
        if out.extra.get("bigm"):  # slack bounds of the scaled pair rows S G C: slack = slack^ / S
            out.extra["bigm"] = (np.asarray(out.extra["bigm"]) * unit / self._w_unit[self.form.pair_column]).tolist()
        if unit == 1.0:
            return
        for key in (facts.ASSOCIATIVE_MULTIPLIER, facts.BOUND, facts.GAP_ABS, "lam_static_min", "lam_kinematic",
                    "lam_dissipation", "engine_multiplier", "polished_minus_engine"):
            if isinstance(out.extra.get(key), float):
                out.extra[key] *= unit
        for row in out.trace:
            for key in ("bound", "incumbent", "gap_abs"):
                if isinstance(row.get(key), float):
                    row[key] *= unit
        out.extra["lam_unit"] = unit
        out.message += f" (lam values in this message in units of {unit:g})"

    def _recertify(self, out: RunOutput) -> None:
        """The certificate checked again in the problem's own units: the returned ``lam`` against the bound (the
        scaled bound times the exact power of two ``s``); a miss voids it (LOCALLY_OPTIMAL)."""
        opt = self.options
        sign = -1.0 if opt.sense == "max" else 1.0
        lam, bound = out.solution.multiplier, float(out.extra[facts.BOUND])
        tol = CERTIFICATE_TOL * max(1.0, abs(lam))
        gap = sign * (lam - bound)
        out.extra[facts.GAP_ABS] = max(0.0, gap)
        out.extra[facts.GAP_REL] = max(0.0, gap) / max(abs(lam), 1e-12)
        if -tol <= gap <= max(self.settings.mip_abs_gap, opt.mip_rel_gap * abs(lam)) + tol:
            return
        out.status = Status.LOCALLY_OPTIMAL
        out.message = (f"in the problem's units lam {lam:.10g} and the bound {bound:.10g} differ by {gap:.2e} "
                       f"(tolerance {tol:.2e}): certificate void. {out.message}")


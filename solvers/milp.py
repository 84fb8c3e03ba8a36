r"""``milp``: certified global minimum of the MPEC (4) by a mixed-integer program.

With ``sense="max"`` the same machinery certifies the global *maximum* of ``lam``
over the solutions of the MCP (3) (the largest non-associative multiplier); such a
result is never the minimum of (4): it records ``extra["sense"] = "max"``.

The model is read from the compiled MCP (:func:`blockmpec.formulations.compile_mcp`)
and built by :func:`blockmpec.formulations.mpec_milp.mpec_milp` (normalisation
``1^T z = 1``, LP-proven big-M or SOS1 complementarity, the work identity
``lam tau = -f_d^T u + x^T B z`` and its McCormick envelope; the module docstring
derives every row).  A run has five stages, all timed:

1. **bounds** (:meth:`MILPSolver.lp_bounds` -> :class:`MPECBounds`).  On the statically
   admissible set ``S = {A[equilibrium] (lam, x) = rhs, G x <= 0}`` (which contains
   the force part of every solution of (3)): ``lam_upper = max lam`` (the
   associative multiplier), ``lam_lower = min lam``; ``slack_max_i = max s_i``
   over ``S ∩ {lam_lower <= lam <= lam_upper}`` (``slack_bounds="row"``: one LP per
   pair; ``"normal"``: one LP per interface for ``min n_k``, then the slack maximum
   over that interface's own rows with ``n_k >= min n_k``, a superset); ``x_lower``,
   ``x_upper`` for the normal forces that multiply a flow multiplier in ``B``
   (``envelope=True``).  On the kinematic set ``K = {compatibility, 1^T z = 1, z >= 0}``:
   ``z_max_i = max z_i`` and ``tau_max = max f_l^T u``; ``lam_kinematic = min -f_d^T u``
   over the non-associative kinematic set.  ``dissipation_bound=True`` (default): for each
   product ``x_r z_i`` of the work identity, ``max x_r`` over ``S ∩ {s_i = 0}`` (conditional
   OBBT; ``n_k <= 0`` exactly where the two friction rows imply it), then ``lam_dissipation``
   = an LP of the identity with the friction work bounded below
   (:meth:`MILPSolver._dissipation_minimum` derives it); ``lam_lower`` is the largest of
   these bounds.  The kinematic LPs run at ``BOUND_LP_TOL`` and are widened by
   ``LAM_MARGIN``; every other LP optimum is widened by
   ``LP_MARGIN`` (relative), each slack bound by ``BOUND_MARGIN_REL`` and
   ``BOUND_MARGIN_ABS`` times the largest one, so that a slack *at* ``M_i`` cannot
   happen under a proven bound and flags a too-small one.  LPs are solved cold
   (warm re-solves after cost changes were measured to return wrong "optimal" values).
2. **build**: the mixed-integer model; pairs with ``slack_max_i = 0`` get ``y_i = 1``,
   pairs with ``z_max_i = 0`` get ``y_i = 0``.
3. **solve**.  Incumbent first: the associative-pattern point (when its active set admits
   a mechanism) and the verified points of the ``heuristic`` methods (``fixed-point`` and ``nlp``)
   polished on their patterns, the best one.  If it meets ``lam_lower`` within ``CERTIFICATE_TOL`` it is certified at the root
   (no search).  Otherwise the engine: ``engine="auto"`` (the default) is ``"bnb"`` for ``sense="min"``
   on structures of at most :data:`~blockmpec.solvers.plan.MILP_BNB_MAX_PAIRS` pairs and ``"highs"`` otherwise
   (:meth:`MILPSolver._resolve_engine`; ``extra["engine"]`` names the one that ran).  HiGHS on the
   big-M model (``engine="highs"``), SCIP (``engine="scip"``, SOS1 sets ``{s_i, z_i}``) or the branch
   and bound over the pairs of :mod:`blockmpec.solvers.engines.complementarity_bnb` (``engine="bnb"``, a lifted LP
   bound, no big-M; ``lifting`` picks the products in that LP: ``"friction"`` copies ``z_i x`` for
   the friction pairs, ``"rlt"`` copies for every pair with the products ``lam u`` and ``x u^T`` (normal and
   tangential forces), whose root bound is the minimum of the 2x2, 3x2 and 2x4 running-bond walls,
   ``"rlt-full"`` those products with the moments too (root bound the minimum of the 5x2 wall, where
   ``"rlt"`` stops at 0.558 against 0.6); ``lam_branching`` also
   bisects ``lam``; ``root_lp="ipm"`` solves the root LP by the interior point first and drops the
   rows with zero dual there, a relaxation; with ``"rlt-full"`` it solves that LP in null-space coordinates,
   equilibrium and compatibility solved once (:mod:`blockmpec.solvers.linalg.null_space`: the same LP with
   about 60 % of the rows and 45 % of the columns, 3-4x faster by IPX; ``root_lp="ipm-lifted"`` solves the
   lifted LP itself); defaults ``lifting="rlt-full"``, ``root_lp="ipm"``), started
   from the incumbent.  ``tau >= 0`` makes the model a
   relaxation of (4), so the engine's dual bound is a certified bound on the minimum
   (an upper bound on the maximum).
4. **polish**: with the pattern of the engine's point fixed (active pair: slack 0;
   inactive: ``z_i = 0``) two exact LPs give ``(lam, x)`` (min ``lam``; max for
   ``sense="max"``) and ``(u, z)`` (``f_l^T u = 1``, min ``1^T z``); complementarity
   holds by construction.  If the ``(u, z)`` LP is infeasible the relaxation's
   optimum had ``tau = 0`` (not a solution of (3)): the restriction
   ``tau >= tau_restart`` is solved for a genuine point while the relaxation's bound stands.
5. **certify**: status ``OPTIMAL`` only when the engine closed its gap, the polished
   multiplier meets the bound within ``CERTIFICATE_TOL`` (times ``max(1, |lam|)``), no
   slack sits at its big-M, ``bigm_scale >= 1`` and every bound LP was optimal.  A
   slack at its big-M gives ``LOCALLY_OPTIMAL`` (the point solves (3), the certificate
   is void); a time limit gives ``TIME_LIMIT`` with the best polished point, the bound
   and the gap.  Every stop reports its bound (``extra["bound"]``; None before any) and its best point.

Statuses (issue 41): ``infeasible`` only on a proof that (3) has no solution: the associative LP infeasible (no
statically admissible field), the branch and bound's lifted relaxation infeasible in every branch with each pruning
on a checked Farkas certificate, or the big-M model (a relaxation of (3) with LP-proven bounds) proven infeasible by
its engine.  A model made a restriction by ``bigm_scale < 1``, or a bound LP that fails, proves nothing of (3):
``error``, with the reason.

Maximisation (``sense="max"``): every bound, cut and fixing is a property of the
*set* of solutions of (3), so the same model is a relaxation for either sense and
its dual bound is an upper bound on the maximum; the associative-pattern incumbent
attains ``lam_upper`` itself.  The certificate flips: the polished multiplier must
not *exceed* the bound, and the gap is ``bound - lam >= 0``.

Units: stages 1-5 run on (3) in per-block units (:meth:`MCPScaling.apply <blockmpec.solvers.engines.scaling.MCPScaling.apply>`: each block's
equilibrium rows divided by its load ``l_i``, interface forces in ``l_k``, multipliers in the
reciprocal units, ``lam`` in the power of two :attr:`~blockmpec.solvers.engines.scaling.LoadUnits.lam_unit`),
the system the LP methods solve (:mod:`blockmpec.solvers.engines.scaling`), so that the engines'
absolute tolerances hold for a 1e-5 block on a unit block and under dead point loads 1e10 times the
weights.  The point, the bounds, the gaps and the big-M bounds are returned in the problem's units,
and the certificate is checked again there (:meth:`MILPSolver._recertify`).

Facts in ``extra`` (names of :mod:`blockmpec.facts`): ``bound``, ``gap_abs``,
``gap_rel``, ``sense``, ``associative_multiplier``, ``lp_solves``; and ``trace``
records ``(time_s, bound, incumbent, gap_abs)`` over the run.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from blockmpec import facts
from blockmpec import options as check
from blockmpec.deadline import Deadline
from blockmpec.errors import OptionError
from blockmpec.method import SolverBase
from blockmpec.options import CommonOptions
from blockmpec.registry import get_solver, register_solver
from blockmpec.result import RunOutput, Solution, Status
from blockmpec.solvers import plan

ENGINES = plan.MILP_ENGINES
#: defaults of the bnb engine's settings (None in MILPSettings: "not set"): the best measured
#: (``python studies/lab/certificate_study.py suite --configs highs,bnb-rltfull-ipm``)
BNB_DEFAULT_LIFTING = "rlt-full"
BNB_DEFAULT_ROOT_LP = "ipm"
LIFTINGS = ("friction", "mechanism", "all", "rlt", "rlt-full")
ROOT_LPS = ("simplex", "ipm", "ipm-rows", "ipm-lifted")  # see complementarity_bnb.ROOT_LPS


def lifting_options(form, lifting: str, slack_max: np.ndarray) -> dict:
    """The arguments of :class:`~blockmpec.solvers.engines.complementarity_bnb.ComplementarityBnB` that
    ``lifting`` (:data:`LIFTINGS`) sets: which copies of the static field, the products ``lam u``, the forces
    tied to ``u`` (``x u^T``: normal and tangential ones for ``"rlt"``, all for ``"rlt-full"``), and the
    LP-proven slack bounds (``slack_max``), which the ``rlt`` liftings do without."""
    return dict(slack_max=None if lifting.startswith("rlt") else slack_max,
                all_copies=lifting in ("all", "rlt", "rlt-full"), lam_mechanism=lifting != "friction",
                force_mechanism={"rlt": np.sort(np.r_[form.n, form.t]), "rlt-full": True}.get(lifting))


@dataclass
class MILPOptions(CommonOptions):
    """Options of the ``milp`` method."""

    engine: str = field(default="auto", metadata={
        "help": "auto (the branch and bound over the pairs up to 400 pairs, HiGHS's big-M MILP above) | highs | "
                "scip (needs pyscipopt) | bnb"})
    sense: str = field(default="min", metadata={
        "help": "min: the MPEC (4), least lam over the solutions of (3) | max: the largest lam over the same set"})
    mip_rel_gap: float = field(default=1e-9, metadata={"help": "stop when |incumbent - bound| <= this |incumbent|"})
    threads: int = field(default=1, metadata={"help": "the engine's threads"})

    def __post_init__(self) -> None:
        super().__post_init__()
        check.choice(self, "engine", ENGINES)
        check.choice(self, "sense", ("min", "max"))
        check.interval(self, "mip_rel_gap", 0, 1, closed="left")
        check.integer(self, "threads", minimum=1)


@dataclass
class MILPSettings:
    """Engine settings of ``milp`` (experiments: ``studies/lab``; the module docstring explains each).

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
    slack_bounds : {"row", "normal"}
        One LP per slack, or one per interface.
    multiplier_bounds, envelope, dissipation_bound : bool
        Tighten ``z_i <= y_i`` by LPs; McCormick envelope of the work identity; the dissipation bound on ``lam``.
    heuristic : str
        Methods (comma-separated) whose verified points, polished on their patterns, are further incumbents
        ('' for none).  Default ``"fixed-point,nlp"``: on the 9-block door wall at mu 0.8 the fixed point's
        polished point is 0.7150, nlp's the minimum 0.7058 (0.4 s), which the branch and bound then only has to
        prove (a better incumbent prunes more).
    bilinear : bool
        engine=scip: the work identity's products as exact bilinear constraints.
    incumbent : bool
        Start from the associative optimum when its active set admits a mechanism.
    warm_bounds : bool
        Warm-start the bound LPs (faster; HiGHS warm re-solves after cost changes were measured to err).
    """

    lam_branching: bool = False
    lifting: str | None = None
    root_lp: str | None = None
    mip_abs_gap: float = 1e-9
    feasibility_tol: float = 1e-9
    bigm_scale: float = 1.0
    slack_bounds: str = "row"
    multiplier_bounds: bool = True
    envelope: bool = False
    dissipation_bound: bool = True
    heuristic: str = "fixed-point,nlp"
    bilinear: bool = False
    incumbent: bool = True
    warm_bounds: bool = False

    @property
    def sets_bnb_options(self) -> bool:
        """A setting of engine="bnb" is set (``lam_branching``, ``lifting`` or ``root_lp``)."""
        return self.lam_branching or self.lifting is not None or self.root_lp is not None

    def __post_init__(self) -> None:
        check.interval(self, "feasibility_tol", 1e-12, 1e-4, closed="both")
        check.positive(self, "bigm_scale")
        check.choice(self, "slack_bounds", ("row", "normal"))
        if not (isinstance(self.mip_abs_gap, (int, float)) and self.mip_abs_gap >= 0):
            raise ValueError(f"mip_abs_gap must be >= 0; got {self.mip_abs_gap!r}")
        if self.lifting is not None:
            check.choice(self, "lifting", LIFTINGS)
        if self.root_lp is not None:
            check.choice(self, "root_lp", ROOT_LPS)
        check.boolean(self, "lam_branching", "multiplier_bounds", "envelope", "dissipation_bound", "bilinear",
                      "incumbent", "warm_bounds")
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
        raise ValueError("engine='bnb' bounds the minimum only; use engine='highs' or 'scip' for sense='max'")
    if settings.bilinear and options.engine != "scip":
        raise ValueError("bilinear=True needs engine='scip' (HiGHS has no bilinear constraints)")


#: relative margin and absolute margin (times the largest bound) added to proven slack bounds
BOUND_MARGIN_REL = 1e-4
BOUND_MARGIN_ABS = 1e-6
#: relative widening of LP-derived bounds (round-off of the LP optima)
LP_MARGIN = 1e-6
#: relative widening of the lam lower bounds of the kinematic LPs, solved with feasibility
#: tolerances BOUND_LP_TOL (below CERTIFICATE_TOL, so that a root bound can close the gap)
LAM_MARGIN = 1e-8
BOUND_LP_TOL = 1e-10
#: the engine solves to its feasibility tolerances, so its dual bound and the exact (polished)
#: multiplier of the same pattern may differ by about this much (times max(1, |lam|)) without any
#: real gap; a larger difference voids the certificate.
CERTIFICATE_TOL = 1e-7
#: a slack within this (times the largest bound) of its M is "at its bound"
ACTIVE_TOL = 1e-7


def _widen(lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """LP-derived bounds widened by ``LP_MARGIN`` (relative) and ``BOUND_MARGIN_REL`` of the finite width."""
    width = np.abs(upper - lower)
    width = np.where(np.isfinite(width), width, 0.0)
    return (lower - LP_MARGIN * np.maximum(1.0, np.abs(lower)) - BOUND_MARGIN_REL * width,
            upper + LP_MARGIN * np.maximum(1.0, np.abs(upper)) + BOUND_MARGIN_REL * width)


class BoundFailure(Exception):
    """A bound LP of ``milp`` that did not end optimal (raised by :meth:`MILPSolver.root_bounds` and
    :meth:`MILPSolver.model_bounds`).

    Parameters
    ----------
    status : Status
        The bound LP's status.
    message : str
        What failed, for the run's message.
    proof : bool
        The status says something of (3) itself (the associative LP ``max lam`` over the statically admissible
        set ``S``: infeasible means ``S`` is empty, so (3) has no solution; unbounded means no collapse), and is
        the run's status; any other bound LP's failure only means that ``milp`` has no bound (status ``ERROR``),
        or ran out of time (``TIME_LIMIT``).
    """

    def __init__(self, status: Status, message: str, proof: bool = False) -> None:
        super().__init__(message)
        self.status = status
        self.proof = proof

    @property
    def run_status(self) -> Status:
        """The status of a run that stops here."""
        if self.status is Status.TIME_LIMIT:
            return Status.TIME_LIMIT
        if self.proof and self.status in (Status.UNBOUNDED, Status.INFEASIBLE, Status.INFEASIBLE_OR_UNBOUNDED):
            return self.status
        return Status.ERROR


@register_solver
class MILPSolver(SolverBase):
    """Global minimum (or, ``sense="max"``, maximum) of the non-associative multiplier by a MILP.

    ``certifies_minimum``: status OPTIMAL with ``sense="min"`` (``extra["sense"] == "min"``)
    is a proven global minimum of (4).  With ``sense="max"`` OPTIMAL certifies the
    maximum instead; the comparator must not take it as the minimum.
    """

    name = "milp"
    problem = "non-associative"
    summary = ("certified global minimum of the MPEC (4) (sense=max: maximum of lam over solutions of (3)): "
               "LP bounds from the work identity, then a branch and bound over the pairs on a lifted LP "
               "(engine=auto; or HiGHS big-M MILP, or SCIP SOS1)")
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

    def skip_reason(self, ops) -> str | None:
        import importlib.util

        if self.options.engine == "scip" and importlib.util.find_spec("pyscipopt") is None:
            return "milp engine='scip' needs pyscipopt (pip install pyscipopt)"
        return None

    def setup(self, ops):
        from blockmpec.formulations import compile_mcp
        from blockmpec.solvers.engines.highs import HighsLP
        from blockmpec.solvers.engines.piece_lp import kinematic_program, static_program

        self.ops = ops
        # the MILP, its bounds and its polish all work on (3) in per-block units (ops.units)
        from blockmpec.solvers.engines.scaling import LoadUnits

        original = compile_mcp(ops)
        #: (3) in per-block units and the inverse that travels with it (:meth:`MCPScaling.apply`)
        self.units = LoadUnits.of(ops).mcp(original).apply(original)
        form = self.units.form
        self._w_unit = self.units.unit
        #: the multiplier unit ``s`` of the MILP's per-block units (a power of two): ``lam = s lam^``
        self.lam_unit = self.units.lam_unit
        self.form = form
        self.engine = self._resolve_engine(form)
        self.plan = plan.milp_plan(self.engine, self.settings.incumbent)
        self.lifting = self.settings.lifting or BNB_DEFAULT_LIFTING
        self.root_lp = self.settings.root_lp or BNB_DEFAULT_ROOT_LP
        # the static LP over (lam, x) and the kinematic LP over (u, z) that (3) splits into (piece_lp's)
        self.static = static_program(form)
        self.kinematic = kinematic_program(form)
        self.bound_lp = HighsLP(self.static, "dual-simplex")
        self.polish_static = HighsLP(self.static, "dual-simplex")
        self.polish_kinematic = HighsLP(self.kinematic, "dual-simplex")
        self.kinematic_bound = HighsLP(self.kinematic, "dual-simplex")
        self.kinematic_bound.set_feasibility_tolerances(BOUND_LP_TOL)

    # ------------------------------------------------------------------ 1. bounds
    def _solve_cost(self, hl, cost: np.ndarray, deadline: Deadline):
        hl.set_costs(np.arange(cost.size), cost)
        if not self.settings.warm_bounds:
            hl.clear_basis()
        self._n_lps += 1
        return hl.solve(deadline=deadline)

    def _resolve_engine(self, form) -> str:
        """The engine that runs: ``engine`` unless it is ``"auto"``, which picks ``"bnb"`` (its lifted LP is
        the stronger bound: every structure of the heuristic suite certified in 0.24x the total time of
        ``"highs"``, running-bond walls of 13-14 blocks within 60 s where ``"highs"`` stops at 7) for
        ``sense="min"`` with at most :data:`~blockmpec.solvers.plan.MILP_BNB_MAX_PAIRS` pairs or any bnb setting
        set, else ``"highs"`` (:func:`blockmpec.solvers.plan.milp_engine`)."""
        opt = self.options
        if opt.engine == "auto" and opt.sense == "min" and self.settings.sets_bnb_options:
            return "bnb"
        return plan.milp_engine(opt.engine, opt.sense, form.n_pairs)

    def lp_bounds(self, deadline: Deadline):
        """Every LP bound of the MILP: :meth:`root_bounds` then :meth:`model_bounds` (after :meth:`setup`).

        Parameters
        ----------
        deadline : Deadline
            When the bound LPs stop.

        Returns
        -------
        MPECBounds
            The bounds on ``lam`` and the model's bounds ``slack_max``, ``z_max``, ``tau_max``, in the MILP's
            per-block units (:meth:`MCPScaling.apply <blockmpec.solvers.engines.scaling.MCPScaling.apply>`; ``lam`` in units of :attr:`lam_unit`).

        Raises
        ------
        BoundFailure
            A bound LP did not end optimal.
        """
        return self.model_bounds(self.root_bounds(deadline), deadline)

    def _x_bound(self, j: int, direction: float, deadline: Deadline) -> float:
        """``min direction * x_j`` over the static LP's current set; raises ``BoundFailure``."""
        cost = np.zeros(self.static.c.size)
        cost[1 + j] = direction  # x columns of the static LP start after lam
        r = self._solve_cost(self.bound_lp, cost, deadline)
        if r.status is not Status.OPTIMAL:
            raise BoundFailure(r.status, f"bound LP of x[{j}]: {r.status.value} ({r.raw_status})")
        return float(r.objective)

    def root_bounds(self, deadline: Deadline):
        """The LP bounds on ``lam`` (enough for a root certificate), after :meth:`setup`.

        ``lam_upper`` is ``max lam`` over the statically admissible set ``S`` (the associative multiplier),
        ``lam_static_min`` is ``min lam`` over ``S``, and ``lam_lower`` the largest of the lower bounds proven by
        LPs (the kinematic minimum ``min -f_d^T u`` over the non-associative mechanisms with ``f_l^T u = 1`` and
        the work identity's bound), each widened by its round-off margin.

        Parameters
        ----------
        deadline : Deadline
            When the bound LPs stop.

        Returns
        -------
        MPECBounds
            Bounds in the MILP's per-block units whose model bounds (``slack_max``, ``z_max``, ``tau_max``) are
            not computed yet (None; :meth:`model_bounds` adds them).

        Raises
        ------
        BoundFailure
            A bound LP did not end optimal (``proof``: the associative LP's status is the answer of (3)).
        """
        from blockmpec.formulations.mpec_milp import MPECBounds, work_matrix

        t0 = time.perf_counter()
        self._n_lps = 0
        form, lp, hl = self.form, self.static, self.bound_lp
        cost = np.zeros(lp.c.size)
        cost[0] = -1.0
        up = self._solve_cost(hl, cost, deadline)
        if up.status is not Status.OPTIMAL:
            raise BoundFailure(up.status, f"associative LP (max lam): {up.status.value}", proof=True)
        cost[0] = 1.0
        lo = self._solve_cost(hl, cost, deadline)
        if lo.status is not Status.OPTIMAL:
            raise BoundFailure(lo.status, f"min lam over the statically admissible set is {lo.status.value}: the "
                                "slacks have no LP bound, so no valid big-M exists")
        lam_assoc, lam_min = float(up.v[0]), float(lo.v[0])
        x_assoc = lp.values("x", up.v)
        lam_upper = lam_assoc + LP_MARGIN * max(1.0, abs(lam_assoc))
        lam_lower = lam_min - LP_MARGIN * max(1.0, abs(lam_min))
        hl.set_column_bounds([0], [lam_lower], [lam_upper])
        nx = form.pair_matrix.shape[1]
        x_lower, x_upper = np.full(nx, -np.inf), np.full(nx, np.inf)
        need_products = self.settings.envelope or self.settings.dissipation_bound
        Bw = work_matrix(form) if need_products else None
        product_lower = product_upper = None
        diss = None
        if need_products:
            try:
                self._product_bounds(Bw, x_lower, x_upper, deadline)
            except BoundFailure as fail:
                if fail.status is not Status.TIME_LIMIT:
                    raise
                need_products = False  # out of time: lam keeps its plain LP bounds (valid), no envelope
                x_lower[:], x_upper[:] = -np.inf, np.inf
                self._products = None
        if need_products:
            x_lower, x_upper = _widen(x_lower, x_upper)
            product_lower, product_upper = self._products
            product_lower, product_upper = _widen(product_lower, product_upper)
            # exact signs: x_r <= 0 wherever the pair rows imply it (no LP round-off involved)
            nonpositive = self._implied_nonpositive()
            x_upper[nonpositive] = np.minimum(x_upper[nonpositive], 0.0)
            product_upper = np.where(nonpositive[Bw.row], np.minimum(product_upper, 0.0), product_upper)
            if self.settings.dissipation_bound:
                diss = self._dissipation_minimum(Bw, np.minimum(x_upper[Bw.row], product_upper), deadline)
        hl.set_column_bounds([0], [-np.inf], [np.inf])
        kin = self._kinematic_minimum(deadline)
        lower = max([lam_lower] + [v for v in (kin, diss) if v is not None])
        return MPECBounds(lam_associative=lam_assoc, lam_static_min=lam_min, lam_kinematic=kin,
                          lam_dissipation=diss, lam_lower=lower, lam_upper=lam_upper,
                          slack_max=None, z_max=None, tau_max=None, x_lower=x_lower, x_upper=x_upper,
                          product_lower=product_lower if need_products else None,
                          product_upper=product_upper if need_products else None, x_associative=x_assoc,
                          n_lps=self._n_lps, time_s=time.perf_counter() - t0)

    def _product_bounds(self, Bw, x_lower: np.ndarray, x_upper: np.ndarray, deadline: Deadline) -> None:
        """Bounds of the ``x_r`` of the work identity over ``S`` (in place) and over ``S ∩ {s_i = 0}``
        for each product ``x_r z_i`` (conditional OBBT; kept in ``self._products``)."""
        lp, hl = self.static, self.bound_lp
        for j in np.unique(Bw.row):
            if self.settings.envelope:
                x_lower[j] = self._x_bound(j, 1.0, deadline)
            x_upper[j] = -self._x_bound(j, -1.0, deadline)
        # conditional OBBT: bounds of x_r over S ∩ {s_i = 0} for each product x_r z_i of B
        rows = lp.rows["pairs"]
        product_lower, product_upper = np.full(Bw.nnz, -np.inf), np.full(Bw.nnz, np.inf)
        for e in range(Bw.nnz):
            i = int(Bw.col[e])
            hl.set_row_bounds(rows[i:i + 1], [0.0], [0.0])
            try:
                if self.settings.envelope:
                    product_lower[e] = self._x_bound(int(Bw.row[e]), 1.0, deadline)
                product_upper[e] = -self._x_bound(int(Bw.row[e]), -1.0, deadline)
            except BoundFailure as fail:
                if fail.status is Status.TIME_LIMIT:
                    raise
                # the pair is never active on S (or the LP failed): no conditional bound is
                # claimed, the product keeps the unconditional bounds (always valid)
                product_lower[e], product_upper[e] = -np.inf, np.inf
            finally:
                hl.set_row_bounds(rows[i:i + 1], [-np.inf], [0.0])
        self._products = (product_lower, product_upper)

    def model_bounds(self, bd, deadline: Deadline):
        """The root bounds ``bd`` with the model's bounds added.

        ``slack_max_i = max s_i`` over ``S ∩ {lam_static_min <= lam <= lam_upper}`` (the big-M of pair ``i``),
        ``z_max_i = max z_i`` and ``tau_max = max f_l^T u`` over the kinematic set with ``1^T z = 1``, each an LP
        optimum widened by its round-off margin.

        Parameters
        ----------
        bd : MPECBounds
            The bounds of :meth:`root_bounds`.
        deadline : Deadline
            When the bound LPs stop.

        Returns
        -------
        MPECBounds
            ``bd`` with ``slack_max``, ``z_max`` and ``tau_max`` set.

        Raises
        ------
        BoundFailure
            A bound LP did not end optimal.
        """
        import dataclasses

        t0 = time.perf_counter()
        n0 = self._n_lps
        lp, hl = self.static, self.bound_lp
        # the slacks are bounded over S ∩ {lam_static_min <= lam <= lam_associative} (widened)
        hl.set_column_bounds([0], [bd.lam_static_min - LP_MARGIN * max(1.0, abs(bd.lam_static_min))], [bd.lam_upper])
        Gx = self.form.pair_matrix.tocsr()
        npair = Gx.shape[0]
        x_lower = bd.x_lower.copy()
        try:
            if self.settings.slack_bounds == "row":
                smax = np.empty(npair)
                for i in range(npair):
                    a, b = Gx.indptr[i], Gx.indptr[i + 1]
                    cost = np.zeros(lp.c.size)
                    cost[1 + Gx.indices[a:b]] = Gx.data[a:b]  # min G_i x = -max s_i
                    r = self._solve_cost(hl, cost, deadline)
                    if r.status is not Status.OPTIMAL:
                        raise BoundFailure(r.status, f"slack bound LP {i}: {r.status.value} ({r.raw_status})")
                    smax[i] = max(-r.objective, 0.0)
            else:
                smax = self._slack_bounds_by_normal(lambda j, d: self._x_bound(j, d, deadline), x_lower)
        finally:
            hl.set_column_bounds([0], [-np.inf], [np.inf])
        scale = float(max(smax.max(initial=0.0), 1e-300))
        slack_max = np.where(smax <= 1e-12 * scale, 0.0,
                             smax * (1.0 + BOUND_MARGIN_REL) + BOUND_MARGIN_ABS * scale)
        z_max, tau_max = self._multiplier_bounds(deadline)
        return dataclasses.replace(bd, slack_max=slack_max, z_max=z_max, tau_max=tau_max,
                                   n_lps=bd.n_lps + self._n_lps - n0, time_s=bd.time_s + time.perf_counter() - t0)

    def _implied_nonpositive(self) -> np.ndarray:
        """``x_r <= 0`` implied exactly by ``G x <= 0``: the two friction rows of an interface add up to
        a positive multiple of ``e_r`` (Coulomb: ``(t + tan(phi) n) + (-t + tan(phi) n) = 2 tan(phi) n``)."""
        from blockmpec.formulations.compiled import FRICTION

        form = self.form
        Gx = form.pair_matrix.tocsr()
        out = np.zeros(Gx.shape[1], dtype=bool)
        for k in range(form.n_interfaces):
            pairs = np.flatnonzero((form.pair_interface == k) & (form.pair_kind == FRICTION))
            if pairs.size != 2:
                continue
            v = sp.csr_array(Gx[[pairs[0]]] + Gx[[pairs[1]]])
            v.eliminate_zeros()
            scale = np.abs(Gx[pairs].data).max(initial=0.0)
            big = np.flatnonzero(np.abs(v.toarray().ravel()) > 1e-14 * scale)
            if big.size == 1 and v.toarray().ravel()[big[0]] > 0:
                out[big[0]] = True
        return out

    def _dissipation_minimum(self, Bw, upper: np.ndarray, deadline: Deadline) -> float | None:
        r"""A lower bound on lam from the work identity with the friction work bounded below.

        At a solution of (3) with ``f_l^T u = 1``: ``lam = -f_d^T u + sum_e B_e x_r z_i`` (identity (W)
        of :mod:`blockmpec.formulations.mpec_milp`).  Each ``B_e < 0`` and ``x_r <= upper_e`` whenever
        ``z_i > 0`` (conditional bound: the pair is active), so ``B_e x_r z_i >= B_e upper_e z_i`` and ::

            lam >= min { -f_d^T u + c^T z : compatibility, f_l^T u = 1, z >= 0 },  c_i = sum_e B_e upper_e,

        an LP over a superset of the kinematic part of every solution.  None when some
        ``B_e > 0`` or ``upper_e`` is not finite (no sign argument) or the LP is not optimal.
        """
        form, kp, hk = self.form, self.kinematic, self.kinematic_bound
        if np.any(Bw.data > 0) or not np.all(np.isfinite(upper)):
            return None
        cz = np.zeros(form.n_pairs)
        np.add.at(cz, Bw.col, Bw.data * upper)
        hk.set_row_bounds(kp.rows["live"], [1.0], [1.0])
        hk.set_row_bounds(kp.rows["total"], [-np.inf], [np.inf])
        cost = np.r_[-form.f_d, cz]
        r = self._solve_cost(hk, cost, deadline)
        if r.status is not Status.OPTIMAL:
            return None
        return float(r.objective - LAM_MARGIN * max(1.0, abs(r.objective)))

    def _slack_bounds_by_normal(self, x_bound, x_lower: np.ndarray) -> np.ndarray:
        """``slack_bounds="normal"``: ``nmin_k = min n_k`` over ``S`` (one LP per interface), then
        ``max s_i`` over the interface's own polytope ``{G_k x_k <= 0, n_k >= nmin_k}`` (a superset of
        the projection of ``S``, so the bound is valid); the small LPs are solved by HiGHS."""
        from blockmpec.solvers.engines.highs import small_lp

        form = self.form
        Gx = form.pair_matrix.toarray()
        smax = np.empty(form.n_pairs)
        for k in range(form.n_interfaces):
            nk = int(form.n[k])
            x_lower[nk] = x_bound(nk, 1.0)
            pairs = np.flatnonzero(form.pair_interface == k)
            cols = np.flatnonzero(np.any(Gx[pairs] != 0.0, axis=0) | (np.arange(Gx.shape[1]) == nk))
            lower = np.where(cols == nk, x_lower[nk], -np.inf)
            Gk = Gx[np.ix_(pairs, cols)]
            for i, row in zip(pairs, Gk):
                status, value = small_lp(row, Gk, np.zeros(pairs.size), lower, np.full(cols.size, np.inf))
                if status is not Status.OPTIMAL:
                    raise BoundFailure(Status.ERROR, f"interface slack LP of pair {i}: {status.value}")
                smax[i] = max(-value, 0.0)
        return smax

    def _multiplier_bounds(self, deadline: Deadline) -> tuple[np.ndarray, float]:
        """``max z_i`` and ``max f_l^T u`` over ``K = {compatibility, 1^T z = 1, z >= 0}``."""
        kp, hk = self.kinematic, self.kinematic_bound
        hk.set_row_bounds(kp.rows["live"], [-np.inf], [np.inf])
        hk.set_row_bounds(kp.rows["total"], [1.0], [1.0])
        nu = kp.columns["u"].size
        npair = kp.columns["z"].size
        cost = np.zeros(kp.c.size)
        cost[: nu] = -self.form.f_l
        r = self._solve_cost(hk, cost, deadline)
        tau_max = -r.objective * (1 + LP_MARGIN) + LP_MARGIN if r.status is Status.OPTIMAL else np.inf
        z_max = np.ones(npair)
        if self.settings.multiplier_bounds:
            for i in range(npair):
                cost = np.zeros(kp.c.size)
                cost[kp.columns["z"][i]] = -1.0
                r = self._solve_cost(hk, cost, deadline)
                if r.status is Status.OPTIMAL:  # otherwise keep the trivial bound 1
                    zi = -r.objective
                    z_max[i] = 0.0 if zi <= 1e-12 else min(1.0, zi * (1 + BOUND_MARGIN_REL) + BOUND_MARGIN_ABS)
        return z_max, float(tau_max)

    def _kinematic_minimum(self, deadline: Deadline) -> float | None:
        """``min -f_d^T u`` over compatibility, ``f_l^T u = 1``, ``z >= 0`` (None when not optimal)."""
        kp, hk = self.kinematic, self.kinematic_bound
        hk.set_row_bounds(kp.rows["live"], [1.0], [1.0])
        hk.set_row_bounds(kp.rows["total"], [-np.inf], [np.inf])
        cost = np.zeros(kp.c.size)
        cost[: kp.columns["u"].size] = -self.form.f_d
        r = self._solve_cost(hk, cost, deadline)
        if r.status is not Status.OPTIMAL:
            return None
        return float(r.objective - LAM_MARGIN * max(1.0, abs(r.objective)))

    # ------------------------------------------------------------------ 2. build
    def build_mip(self, bd, tau_min: float = 0.0):
        """The MILP of (4) for the engine that runs (:func:`~blockmpec.formulations.mpec_milp.mpec_milp`).

        Complementarity by big-M rows ``s_i <= M_i (1 - y_i)``, ``z_i <= z_max_i y_i`` with ``M_i = bigm_scale
        slack_max_i`` (HiGHS) or by SOS1 sets ``{s_i, z_i}`` (the other engines); a pair whose
        ``slack_max_i = 0`` is fixed active (``y_i = 1``) and one whose ``z_max_i = 0`` fixed idle (``z_i = 0``).

        Parameters
        ----------
        bd : MPECBounds
            The bounds of :meth:`lp_bounds`.
        tau_min : float
            Lower bound of ``tau = f_l^T u`` (the restart after a relaxation point with ``tau = 0``).

        Returns
        -------
        MixedIntegerMPEC
            The model, in the MILP's per-block units.
        """
        from blockmpec.formulations import mpec_milp as fm

        opt = self.options
        M = self.settings.bigm_scale * bd.slack_max
        complementarity = "bigm" if self.engine == "highs" else "sos1"
        mip = fm.mpec_milp(self.form, bd, sense=opt.sense, complementarity=complementarity, bigm=M,
                           envelope=self.settings.envelope, tau_min=tau_min)
        zcols = self.form.pair_column
        fixed_active = bd.slack_max == 0.0  # the pair row is active on all of S
        fixed_idle = (bd.z_max == 0.0) & ~fixed_active  # z_i = 0 in every normalised mechanism
        if "y" in mip.columns:
            y = mip.columns["y"]
            mip.col_lower[y[fixed_active]] = 1.0
            mip.col_upper[y[fixed_idle]] = 0.0
        else:
            mip.col_upper[zcols[fixed_idle]] = 0.0
        self._n_fixed = int(fixed_active.sum() + fixed_idle.sum())
        return mip

    def start_vector(self, mip, sol: Solution | None) -> np.ndarray | None:
        """The MILP's column values at a solution ``sol`` of (3): its start for the engine.

        ``(u, z)`` divided by ``1^T z`` (the model's normalisation ``1^T z = 1``), ``tau = f_l^T u``,
        ``y_i = [z_i > 0]``, ``s = max(slack, 0)`` and the products ``p = x_r z_i``, ``q = lam tau`` where the
        model has those columns.

        Parameters
        ----------
        mip : MixedIntegerMPEC
            The model of :meth:`build_mip`.
        sol : Solution or None
            A solution of (3) in the MILP's units (:meth:`scaled`).

        Returns
        -------
        ndarray or None
            One value per column of ``mip``; None if ``sol`` is None.
        """
        if sol is None:
            return None
        form = self.form
        w = form.pack(sol)
        zsum = float(w[form.z].sum())
        w[form.u] /= zsum
        w[form.z] /= zsum
        v = np.zeros(mip.n_columns)
        v[: w.size] = w
        tau = float(self.form.f_l @ w[form.u])
        v[mip.columns["tau"]] = tau
        z = w[form.pair_column]
        if "y" in mip.columns:
            v[mip.columns["y"]] = (z > 0).astype(float)
        if "s" in mip.columns:
            v[mip.columns["s"]] = np.maximum(form.slack(w), 0.0)
        if "p" in mip.columns:
            xr, zi, _ = mip.work_products
            v[mip.columns["p"]] = w[xr] * w[zi]
            v[mip.columns["q"]] = sol.multiplier * tau
        return v

    # ------------------------------------------------------------------ 3. solve
    def branch_and_bound(self, bd, **overrides):
        """The branch and bound of :mod:`~blockmpec.solvers.engines.complementarity_bnb` on this structure.

        Parameters
        ----------
        bd : MPECBounds
            The LP bounds (:meth:`lp_bounds`): ``lam_lower <= lam <= lam_upper``, pairs with ``slack_max_i = 0``
            fixed active and pairs with ``z_max_i = 0`` fixed idle.
        **overrides
            Replace any keyword argument of
            :class:`~blockmpec.solvers.engines.complementarity_bnb.ComplementarityBnB` (studies and tests).

        Returns
        -------
        ComplementarityBnB
            Not yet run; the settings' ``lifting``, ``root_lp`` and ``lam_branching``, its leaves polished by
            :meth:`polish`.
        """
        from blockmpec.formulations.mpec_milp import work_matrix
        from blockmpec.solvers.engines.complementarity_bnb import ComplementarityBnB

        kwargs = dict(fixed_active=bd.slack_max == 0.0, fixed_idle=bd.z_max == 0.0,
                      lam_branching=self.settings.lam_branching, root_lp=self.root_lp,
                      **lifting_options(self.form, self.lifting, bd.slack_max))
        kwargs.update(overrides)
        return ComplementarityBnB(self.form, work_matrix(self.form), bd.lam_lower, bd.lam_upper,
                                  lambda active: self.polish(active)[0], **kwargs)

    def _solve_bnb(self, bd, incumbent: Solution | None, deadline: Deadline, t0: float):
        """engine="bnb": (MIPRun with lam-unit bounds, best polished Solution or None, the branch and bound that
        ran (its LP count and root timings), seconds to build its lifted LP)."""
        tb = time.perf_counter()
        bnb = self.branch_and_bound(bd)
        t_build = time.perf_counter() - tb
        run, best = bnb.solve(deadline, incumbent, t0=t0)
        return run, best, bnb, t_build

    def _solve(self, mip, deadline: Deadline, start: np.ndarray | None, t0: float):
        from blockmpec.solvers.engines import mip as engines

        opt, st = self.options, self.settings
        kw = dict(rel_gap=opt.mip_rel_gap, abs_gap=st.mip_abs_gap, feasibility_tol=st.feasibility_tol,
                  threads=opt.threads, start=start, t0=t0)
        if self.engine == "scip":
            return engines.solve_scip(mip, deadline, bilinear=st.bilinear, **kw)
        return engines.solve_highs(mip, deadline, **kw)

    # ------------------------------------------------------------------ 4. polish
    def pattern_mechanism(self, active: np.ndarray):
        """The mechanism of the pattern ``active``: the kinematic half of its piece LP.

        ``min 1^T z`` over the compatible ``(u, z)`` with ``f_l^T u = 1``, ``z >= 0`` and ``z_i = 0`` for every
        pair off ``active`` (:func:`~blockmpec.solvers.engines.piece_lp.mechanism_piece`, shared with ``nlp``).

        Parameters
        ----------
        active : ndarray of bool, shape (n_pairs,)
            The pairs allowed to open.

        Returns
        -------
        tuple of ndarray or None
            ``(u, z)`` in the MILP's units, or None where the LP is not optimal (no mechanism with
            ``f_l^T u > 0`` on the pattern).
        """
        from blockmpec.solvers.engines.piece_lp import mechanism_piece

        kp = self.kinematic
        ru = mechanism_piece(self.polish_kinematic, active)
        if ru.status is not Status.OPTIMAL:
            return None
        return kp.values("u", ru.v), kp.values("z", ru.v)

    def polish(self, active: np.ndarray) -> tuple[Solution | None, str]:
        """The exact point of (3) on the pattern ``active``: its piece LP in two halves.

        The static half (:func:`~blockmpec.solvers.engines.piece_lp.static_piece`) minimises ``lam`` (maximises,
        ``sense="max"``) over the statically admissible ``(lam, x)`` with ``G_i x = 0`` on the active pairs; the
        kinematic half is :meth:`pattern_mechanism`.  Together they satisfy (3) with that active set
        (:mod:`blockmpec.solvers.engines.piece_lp`, shared with ``nlp``).

        Parameters
        ----------
        active : ndarray of bool, shape (n_pairs,)
            One flag per pair: the pairs whose row is held at zero slack and may open.

        Returns
        -------
        tuple
            ``(Solution, "")`` in the MILP's units, or ``(None, message)`` saying which half has no point.
        """
        from blockmpec.solvers.engines.piece_lp import static_piece

        lp = self.static
        rx = static_piece(self.polish_static, active, sense=1.0 if self.options.sense == "min" else -1.0)
        if rx.status is not Status.OPTIMAL:
            return None, f"polish LP for (lam, x) is {rx.status.value}"
        mech = self.pattern_mechanism(active)
        if mech is None:
            return None, ("polish LP for (u, z) is infeasible: the pattern admits no mechanism with "
                          "f_l^T u > 0 (the relaxation's optimum has tau = 0)")
        return self._solution(float(rx.v[0]), lp.values("x", rx.v), *mech), ""

    def _solution(self, lam: float, x: np.ndarray, u: np.ndarray, z: np.ndarray) -> Solution:
        form = self.form
        w = np.zeros(form.n_columns)
        w[form.lam], w[form.x], w[form.u], w[form.z] = lam, x, u, z
        return form.unpack(w)

    def _associative_incumbent(self, bd) -> Solution | None:
        """A solution of (3) at the associative optimum, if its active set admits a mechanism.

        The associative LP's ``(lam, x)`` is statically admissible; with ``z`` allowed only on
        its active pairs, any ``(u, z)`` of the compatibility LP makes the triple a solution of (3)
        (an upper bound on the minimum; for the maximum it attains ``lam_upper``), else None.
        """
        slack = -(self.form.pair_matrix @ bd.x_associative)
        active = slack <= 1e-9 * max(1.0, float(np.abs(slack).max(initial=0.0)))
        mech = self.pattern_mechanism(active)
        if mech is None:
            return None
        return self._solution(bd.lam_associative, bd.x_associative, *mech)

    def _incumbent(self, bd, deadline: Deadline) -> Solution | None:
        """The best of the associative-pattern point and the verified points of the ``heuristic`` methods (each a
        quarter of the time left, at most 30 s), each polished on its pattern (so an exact solution of (3)); None
        when none exists."""
        opt = self.options
        best = self._associative_incumbent(bd)
        for name in heuristic_names(self.settings.heuristic):
            if deadline.expired():
                break
            # the registered method's own adapter, within a quarter of the time left (at most 30 s); its point is
            # an incumbent only when the shared verifier accepts it at the run's verify_tol
            heuristic = get_solver(name)()
            heuristic.verify_tol = self.verify_tol
            heuristic.setup(self.ops)
            out = heuristic.run(deadline.within(max(min(0.25 * deadline.remaining(), 30.0), 1e-3)))
            if out.status.is_success and heuristic.verified(out.solution):
                res = out
                w = self.form.pack(self.scaled(res.solution))
                s, z = self.form.slack(w), self.form.multipliers(w)
                sol, _ = self.polish(z > s)
                lower = sol is not None and best is not None and sol.multiplier < best.multiplier
                if sol is not None and (best is None or lower != (opt.sense == "max")):
                    best = sol
        return best

    def _root_certificate(self, incumbent: Solution, bd, trace: list, t_build: float) -> RunOutput | None:
        """OPTIMAL without search when the incumbent meets the LP bound on lam (within CERTIFICATE_TOL)."""
        maximise = self.options.sense == "max"
        bound = bd.lam_upper if maximise else bd.lam_lower
        lam = incumbent.multiplier
        gap = max(0.0, (bound - lam) if maximise else (lam - bound))
        if gap > CERTIFICATE_TOL * max(1.0, abs(lam)) or self.settings.bigm_scale < 1:
            return None
        extra = {facts.SENSE: self.options.sense, facts.ASSOCIATIVE_MULTIPLIER: bd.lam_associative,
                 facts.BOUND: bound, facts.GAP_ABS: gap, facts.GAP_REL: gap / max(abs(lam), 1e-12),
                 facts.LP_SOLVES: bd.n_lps, facts.ENGINE: "root", "lam_kinematic": bd.lam_kinematic,
                 "lam_dissipation": bd.lam_dissipation, "bound_time_s": bd.time_s, "build_time_s": t_build,
                 "search_time_s": 0.0, "nodes": 0, "bigm_active": [], "bigm": []}
        word = "maximum" if maximise else "minimum"
        return RunOutput(Status.OPTIMAL, incumbent, 0, trace,
                         f"certified global {word} at the root: the incumbent meets the LP bound; gap {gap:.2e}",
                         "root", extra)

    def _pattern(self, mip, v: np.ndarray) -> np.ndarray:
        """Active pairs of an engine point: ``y_i = 1`` (big-M) or ``z_i > s_i`` (SOS1)."""
        if "y" in mip.columns:
            return v[mip.columns["y"]] >= 0.5
        s, z = v[mip.columns["s"]], v[self.form.pair_column]
        return z > s

    # ------------------------------------------------------------------ run
    def run(self, deadline: Deadline) -> RunOutput:
        """Stages 1-5 on the scaled (3), then the point, the bounds and the gaps back in the problem's units."""
        out = self._run_scaled(deadline)
        out.extra.setdefault(facts.BOUND, None)  # every stop reports its bound (None: none proven yet)
        unit = self.lam_unit
        if out.solution is not None and out.solution.multiplier is not None:
            out.solution = self.unscaled(out.solution)
        if out.extra.get("bigm"):  # slack bounds of the scaled pair rows S G C: slack = slack^ / S
            out.extra["bigm"] = (np.asarray(out.extra["bigm"]) * unit
                                 / self._w_unit[self.form.pair_column]).tolist()
        if unit != 1.0:
            for key in (facts.ASSOCIATIVE_MULTIPLIER, facts.BOUND, facts.GAP_ABS, "lam_static_min", "lam_kinematic",
                        "lam_dissipation", "engine_multiplier", "incumbent_associative", "polished_minus_engine"):
                if isinstance(out.extra.get(key), float):
                    out.extra[key] *= unit
            for row in out.trace:
                for key in ("bound", "incumbent", "gap_abs"):
                    if isinstance(row.get(key), float):
                        row[key] *= unit
            out.extra["lam_unit"] = unit
            out.message += f" (lam values in this message in units of {unit:g})"
        if out.status is Status.OPTIMAL:
            self._recertify(out)
        return out

    def _recertify(self, out: RunOutput) -> None:
        """The certificate checked again in the problem's own units: the returned ``lam`` (a point of
        (3), verified by the runner's residuals) against the bound (the scaled bound times the exact
        power of two ``s``), with the tolerances of :meth:`_certify`; a miss voids it (LOCALLY_OPTIMAL)."""
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

    def scaled(self, sol: Solution) -> Solution:
        """A point of (3) in the problem's units -> the same point in the MILP's units (:meth:`MCPScaling.apply <blockmpec.solvers.engines.scaling.MCPScaling.apply>`)."""
        return self.form.unpack(self.units.to_units(self.form.pack(sol)))

    def unscaled(self, sol: Solution) -> Solution:
        """A point of (3) in the MILP's units -> the same point in the problem's units: ``w = unit * w^``
        (:meth:`MCPScaling.apply <blockmpec.solvers.engines.scaling.MCPScaling.apply>`), the inverse of :meth:`scaled`."""
        return self.form.unpack(self.units.from_units(self.form.pack(sol)))

    def _run_scaled(self, deadline: Deadline) -> RunOutput:
        opt = self.options
        maximise = opt.sense == "max"
        bound_word = "upper" if maximise else "lower"
        t_start = self._t_start = time.perf_counter()
        self.plan.start("bounds")
        try:
            bd = self.root_bounds(deadline)
        except BoundFailure as fail:
            return RunOutput(fail.run_status, message=str(fail),
                             extra={"bound_time_s": time.perf_counter() - t_start, facts.SENSE: opt.sense,
                                    facts.LP_SOLVES: self._n_lps})
        trace = [{"iteration": 0, "stage": "bounds", "time_s": bd.time_s,
                  "bound": bd.lam_lower if not maximise else bd.lam_upper, "incumbent": None, "gap_abs": None}]
        if self.settings.incumbent:
            self.plan.start("incumbent")
        incumbent = self._incumbent(bd, deadline) if self.settings.incumbent else None
        if incumbent is not None:
            trace.append({"iteration": len(trace), "stage": "incumbent", "time_s": time.perf_counter() - t_start,
                          "bound": bd.lam_upper if maximise else bd.lam_lower, "incumbent": incumbent.multiplier,
                          "gap_abs": abs(incumbent.multiplier - (bd.lam_upper if maximise else bd.lam_lower))})
            root = self._root_certificate(incumbent, bd, trace, 0.0)
            if root is not None:
                return root
        try:
            bd = self.model_bounds(bd, deadline)
        except BoundFailure as fail:
            extra = {"bound_time_s": time.perf_counter() - t_start, facts.SENSE: opt.sense,
                     facts.LP_SOLVES: self._n_lps, facts.BOUND: bd.lam_upper if maximise else bd.lam_lower}
            if incumbent is not None and fail.status is Status.TIME_LIMIT:
                gap = abs(incumbent.multiplier - extra[facts.BOUND])
                extra[facts.GAP_ABS], extra[facts.GAP_REL] = gap, gap / max(abs(incumbent.multiplier), 1e-12)
                return RunOutput(Status.TIME_LIMIT, incumbent, 0, trace, f"time limit in the bound LPs: {fail}; "
                                 f"best lam {incumbent.multiplier:.10g}, bound {extra[facts.BOUND]:.10g}",
                                 "bounds", extra)
            return RunOutput(fail.run_status, message=str(fail), extra=extra)
        self.plan.start("engine")
        if self.engine == "bnb":  # its own lifted LP: the big-M model is not built
            return self._run_bnb(bd, incumbent, deadline, trace)
        t0 = time.perf_counter()
        mip = self.build_mip(bd)
        t_build = time.perf_counter() - t0
        run = self._solve(mip, deadline, self.start_vector(mip, incumbent), t_start)
        trace += [dict(r, iteration=len(trace) + k, stage="search") for k, r in enumerate(run.trace)]
        sign = mip.objective_sign
        bound = sign * run.dual_bound  # in lam: <= min lam (min), >= max lam (max)
        extra = {
            facts.SENSE: opt.sense,
            facts.ASSOCIATIVE_MULTIPLIER: bd.lam_associative,
            facts.BOUND: bound,
            facts.LP_SOLVES: bd.n_lps,
            facts.ENGINE: self.engine,
            "lam_static_min": bd.lam_static_min,
            "lam_kinematic": bd.lam_kinematic,
            "lam_dissipation": bd.lam_dissipation,
            "tau_max": bd.tau_max,
            "bigm": mip.bigm.tolist(),
            "bigm_scale": self.settings.bigm_scale,
            "n_binaries": int(mip.integer.sum()),
            "n_sos1": len(mip.sos1),
            "n_fixed_pairs": self._n_fixed,
            "bound_time_s": bd.time_s,
            "build_time_s": t_build,
            "search_time_s": run.time_s,
            "nodes": run.nodes,
            "bigm_active": [],
            "incumbent_associative": None if incumbent is None else incumbent.multiplier,
        }
        if not run.has_point:
            return self._no_point(run, incumbent, bound, extra, trace)
        v = run.point
        active = self._pattern(mip, v)
        if self.pattern_mechanism(active) is None and not deadline.expired():
            # The relaxation's optimum has tau = 0 (its pattern admits no mechanism with f_l^T u > 0).
            # Its bound stays the certified one; the restriction tau >= tau_restart has only points of (3).
            tau_restart = 1e-6 * (bd.tau_max if np.isfinite(bd.tau_max) else 1.0)
            extra["tau_restart"] = tau_restart
            rerun = self._solve(self.build_mip(bd, tau_min=tau_restart), deadline, None, t_start)
            extra["restart_nodes"] = rerun.nodes
            if not rerun.has_point:
                return RunOutput(Status.NUMERICAL, Solution(), run.nodes, trace,
                                 f"the relaxation's optimum has tau = 0 and the restriction tau >= {tau_restart:.3g} "
                                 f"found no point ({rerun.raw_status}); the {bound_word} bound {bound:.10g} stands",
                                 rerun.raw_status, extra)
            v = rerun.point
            active = self._pattern(mip, v)
            run = rerun  # its status decides; the relaxation's bound (above) stands
        # a slack at its big-M in the engine's point: the bound behind the model was not proven
        slack = self.form.slack(v[: self.form.n_columns])
        scale = float(max(bd.slack_max.max(initial=0.0), 1e-300))
        at_bound = ~active & (slack >= mip.bigm - ACTIVE_TOL * self.settings.bigm_scale * scale) & (mip.bigm > 0)
        extra["bigm_active"] = np.flatnonzero(at_bound).tolist()
        extra["engine_multiplier"] = float(v[self.form.lam])
        extra["tau"] = float(v[mip.columns["tau"][0]])
        extra["n_active_pairs"] = int(active.sum())
        self.plan.start("polish")
        sol, pmsg = self.polish(active)
        if sol is None:
            return RunOutput(Status.NUMERICAL, Solution(), run.nodes, trace,
                             f"{pmsg}; the {bound_word} bound {bound:.10g} stands", run.raw_status, extra)
        return self._certify(sol, run, bound, bd, extra, trace)

    def _run_bnb(self, bd, incumbent, deadline: Deadline, trace: list) -> RunOutput:
        """Stages 3-5 with engine="bnb": its points are polished patterns already, its bound is in lam."""
        run, best, bnb, t_build = self._solve_bnb(bd, incumbent, deadline, self._t_start)
        trace += [dict(r, iteration=len(trace) + k, stage="search") for k, r in enumerate(run.trace)]
        bound = float(run.dual_bound)
        extra = {facts.SENSE: "min", facts.ASSOCIATIVE_MULTIPLIER: bd.lam_associative, facts.BOUND: bound,
                 facts.LP_SOLVES: bd.n_lps + bnb.n_lps, facts.ENGINE: "bnb", "lam_static_min": bd.lam_static_min,
                 "lam_kinematic": bd.lam_kinematic, "lam_dissipation": bd.lam_dissipation, "bound_time_s": bd.time_s,
                 "build_time_s": t_build, "search_time_s": run.time_s, "nodes": run.nodes, "bigm_active": [],
                 "bigm": [], "engine_multiplier": None if best is None else best.multiplier,
                 "root_interior_time_s": bnb.ipm_time, "root_crossover_runs": bnb.crossover_runs}
        if best is None:
            return self._bnb_without_point(run, bnb, bound, extra, trace)
        return self._certify(best, run, bound, bd, extra, trace)

    def _bnb_without_point(self, run, bnb, bound: float, extra: dict, trace: list) -> RunOutput:
        """engine="bnb" ended without a point of (3).  An infinite bound with every node closed on a proof (each
        infeasible node LP pruned on a checked Farkas certificate of the lifted relaxation, which holds every solution
        of (3); no leaf closed by a pattern LP that HiGHS alone called infeasible) proves that (3) has no solution:
        status ``INFEASIBLE``.  Otherwise the time ran out, or the search could not decide (``ERROR``)."""
        if run.status is Status.TIME_LIMIT:
            return RunOutput(Status.TIME_LIMIT, Solution(), run.nodes, trace,
                             f"time limit: no point of (3) found; bound {bound:.10g}", run.raw_status, extra)
        if np.isinf(bound) and bound > 0 and run.status in (Status.OPTIMAL, Status.INFEASIBLE):
            extra["infeasibility_proofs"] = bnb.farkas_proofs
            if bnb.unproven_closures == 0:
                return RunOutput(Status.INFEASIBLE, Solution(), run.nodes, trace,
                                 f"(3) has no solution: the lifted relaxation, which holds every solution of (3), is "
                                 f"infeasible in every branch ({run.nodes} node(s); {bnb.farkas_proofs} node LP(s) "
                                 "pruned on a checked Farkas certificate)", "infeasible", extra)
            return RunOutput(Status.ERROR, Solution(), run.nodes, trace,
                             f"no point of (3) found: every branch closed, {bnb.unproven_closures} of them by a pattern "
                             "LP that HiGHS called infeasible without a checked certificate, so this is not a proof "
                             "that (3) has no solution", run.raw_status, extra)
        return RunOutput(Status.ERROR, Solution(), run.nodes, trace,
                         f"no point of (3) found; bound {bound:.10g} ({run.message})", run.raw_status, extra)

    def _no_point(self, run, incumbent, bound, extra, trace) -> RunOutput:
        opt = self.options
        if run.status is Status.INFEASIBLE:
            if self.settings.bigm_scale < 1:  # a restriction of (3): its infeasibility proves nothing of (3)
                return RunOutput(Status.ERROR, Solution(), run.nodes, trace,
                                 f"the MILP is infeasible with bigm_scale = {self.settings.bigm_scale} < 1: the scaled slack "
                                 "bounds cut off every solution of (3); the proven bounds (bigm_scale = 1) are needed",
                                 run.raw_status, extra)
            # every bound and cut of the model holds at every solution of (3) (LP-proven, bigm_scale = 1), so the
            # model is a relaxation of (3): its infeasibility, proven by the engine's branch and bound, is (3)'s
            return RunOutput(Status.INFEASIBLE, Solution(), run.nodes, trace,
                             f"(3) has no solution: {self.engine} proves the mixed-integer model infeasible, and the "
                             "model holds every solution of (3) (its big-M and multiplier bounds are LP-proven)",
                             run.raw_status, extra)
        if run.status is Status.TIME_LIMIT and incumbent is not None:
            sign = -1.0 if opt.sense == "max" else 1.0
            gap = max(0.0, sign * (incumbent.multiplier - bound))
            extra[facts.GAP_ABS], extra[facts.GAP_REL] = gap, gap / max(abs(incumbent.multiplier), 1e-12)
            return RunOutput(Status.TIME_LIMIT, incumbent, run.nodes, trace,
                             f"time limit: the associative-pattern solution lam {incumbent.multiplier:.10g}, "
                             f"bound {bound:.10g}", run.raw_status, extra)
        if run.status is Status.TIME_LIMIT:
            return RunOutput(Status.TIME_LIMIT, Solution(), run.nodes, trace,
                             f"time limit before any point of (3); bound {bound:.10g}", run.raw_status, extra)
        return RunOutput(Status.ERROR, Solution(), run.nodes, trace, run.message, run.raw_status, extra)

    # ------------------------------------------------------------------ 5. certify
    def _certify(self, sol: Solution, run, bound: float, bd, extra: dict, trace: list) -> RunOutput:
        opt = self.options
        maximise = opt.sense == "max"
        sign = -1.0 if maximise else 1.0
        lam = sol.multiplier
        extra["polished_minus_engine"] = lam - extra["engine_multiplier"]
        gap_abs = max(0.0, sign * (lam - bound))  # min: lam - bound; max: bound - lam
        extra[facts.GAP_ABS] = gap_abs
        extra[facts.GAP_REL] = gap_abs / max(abs(lam), 1e-12)
        trace.append({"iteration": len(trace), "stage": "polish", "time_s": time.perf_counter() - self._t_start,
                      "bound": bound, "incumbent": lam, "gap_abs": gap_abs})
        tol = CERTIFICATE_TOL * max(1.0, abs(lam))
        closed = gap_abs <= max(self.settings.mip_abs_gap, opt.mip_rel_gap * abs(lam)) + tol
        undercut = sign * (lam - bound) < -tol  # a point of (3) beyond the relaxation's bound is impossible
        word = "maximum" if maximise else "minimum"
        if run.status is Status.OPTIMAL and closed and not undercut and bd.verified:
            st, msg = Status.OPTIMAL, f"certified global {word}; gap {gap_abs:.2e}, {run.nodes} nodes"
        elif run.status is Status.TIME_LIMIT:
            st, msg = Status.TIME_LIMIT, f"time limit: best lam {lam:.10g}, bound {bound:.10g}, gap {gap_abs:.2e}"
        elif undercut:
            st = Status.NUMERICAL
            msg = (f"the polished point lam {lam:.10g} {'exceeds' if maximise else 'undercuts'} the engine's "
                   f"bound {bound:.10g}: certificate void")
        elif run.status is Status.OPTIMAL:
            st = Status.LOCALLY_OPTIMAL
            msg = f"engine optimal but the polished lam {lam:.10g} and the bound {bound:.10g} differ by {gap_abs:.2e}"
            if "tau_restart" in extra:
                msg += (f" (the relaxation's optimum had tau = 0; lam is the {opt.sense}imum over tau >= "
                        f"{extra['tau_restart']:.3g}, not certified globally)")
        else:
            st, msg = Status.ERROR, run.message
        if extra["bigm_active"]:
            st = Status.TIME_LIMIT if run.status is Status.TIME_LIMIT else Status.LOCALLY_OPTIMAL
            msg = (f"{len(extra['bigm_active'])} slack(s) at their big-M bound (bigm_scale = {self.settings.bigm_scale}): "
                   f"the point solves (3) but the certificate of global {'maxim' if maximise else 'minim'}ality "
                   f"is void. {msg}")
        elif self.settings.bigm_scale < 1 and st is Status.OPTIMAL:
            # no slack reached its (shrunken) M, but the model was a restriction: nothing is certified
            st = Status.LOCALLY_OPTIMAL
            msg = (f"bigm_scale = {self.settings.bigm_scale} < 1: the slack bounds are not proven, so the certificate of "
                   f"global {'maxim' if maximise else 'minim'}ality is void (no slack reached them). {msg}")
        return RunOutput(st, sol, run.nodes, trace, msg, run.raw_status, extra)

"""Which engines a method runs on a structure: every size threshold of the library, the rules that read them, and
the plan of a run.

Each method asks this module once, in its set-up, which engines to run (:func:`lp_algorithm`,
:func:`fixed_point_engine`, :func:`nlp_route`, :func:`milp_engine`, ...) and gets its :class:`Plan`: the stages its
run may take, in order (the builders at the end of this module).  ``run`` starts each stage it runs
(:meth:`Plan.start`), and :func:`blockmpec.run_solver` records :meth:`Plan.ran` as ``Result.extra["plan"]``: the
plan that runs is the plan recorded.  The thresholds were measured; each comment names the study that measured it.

Thresholds of the linear algebra (:mod:`blockmpec.solvers.linalg`) are handed to it as an
:class:`~blockmpec.solvers.linalg.block_ipm.AutoRules` (it imports nothing of the library).
"""

from __future__ import annotations

from dataclasses import dataclass

from blockmpec.solvers.linalg.block_ipm import AutoRules

#: the documented API: the thresholds, the engine choices and the plans
__all__ = ["LP_BLOCK_IPM_ROWS", "LP_BLOCK_IPM_LOAD_SPREAD", "FIXED_POINT_INTERIOR_BLOCKS",
           "FIXED_POINT_SIMPLEX_FALLBACK_BLOCKS", "FIXED_POINT_STALL_STEPS", "NLP_PIECE_ROUTE_BLOCKS",
           "PIECE_LP_BLOCK_IPM_PAIRS", "PIECE_LP_IPM_PAIRS", "MILP_BNB_MAX_PAIRS", "BLOCK_IPM_RULES",
           "INTERIOR_FIXED_POINT_RULES", "HIGHS_ALGORITHMS", "LP_ALGORITHMS", "BASIS_ALGORITHMS",
           "FIXED_POINT_ENGINES", "NLP_ROUTES", "MILP_ENGINES", "lp_algorithm", "fixed_point_engine",
           "fixed_point_interior_fallback", "fixed_point_fallback", "fixed_point_relaxed_fallback",
           "FIXED_POINT_3D_RELAXATION", "FIXED_POINT_STEPS_SHARE", "nlp_route", "milp_engine",
           "piece_lp_static_engine", "piece_lp_whole_engine", "describe_block_ipm", "static_lp_plan",
           "kinematic_lp_plan", "slp_plan", "nlp_plan", "fixed_point_plan", "mcp_newton_plan", "milp_plan", "Stage",
           "Plan"]

# ---------------------------------------------------------------------------------------------- LP engines
#: a cold LP with more rows than this, or whose block loads differ by more than ``LP_BLOCK_IPM_LOAD_SPREAD``,
#: runs on the block IPM (HiGHS's IPM with crossover when a basis is needed); below, HiGHS's dual simplex.
#: Measured (``studies/lab/lp_timing.py``): 1,001-block wall, HiGHS IPM + crossover 9.7 s, block IPM 1.6 s;
#: 10,046 blocks, HiGHS > 900 s, block IPM 47 s.  A 1e-3 block on a unit block (loads 1e-6 apart): HiGHS's
#: absolute tolerances give lam = 0.65 instead of 0.5; the block IPM in load units gets 0.5.
LP_BLOCK_IPM_ROWS = 2_000
LP_BLOCK_IPM_LOAD_SPREAD = 1e4

# ---------------------------------------------------------------------------------------------- fixed point
#: ``engine="auto"`` takes the interior engine from this many free blocks up (the simplex engine's warm LP
#: steps below); ``studies/lab/fixed_point_ratio.py``
FIXED_POINT_INTERIOR_BLOCKS = 500
#: ``engine="auto"`` falls back to the simplex engine after an unverified interior run only below this many free
#: blocks: on the 2,032-block wall the simplex engine made 13 steps in 400 s without converging (each step LP and its
#: tie-break about 14 s, while the 1,010-block wall needs 53 steps) and at 2,420 blocks it does not finish one step
#: in 600 s, so a fallback there only uses up the time limit
FIXED_POINT_SIMPLEX_FALLBACK_BLOCKS = 2_000
#: ``engine="auto"``: the simplex engine's LP steps stop when their smallest ``||n - n*||/||n||`` has not halved in this
#: many steps (the map wanders instead of converging, as on irregular stone walls: 292 stones, 0.03-0.05 for 280
#: steps), and the interior engine takes over in the time left; on the built-in walls the steps converge long before.
#: The interior engine's damped LP steps (:func:`~blockmpec.solvers.engines.interior_fixed_point.sequence_then_newton`)
#: stop by the same rule (2,042 stones: 0.07-0.12 from step 40 to 90; 1,005 stones: halved every ~40 steps)
FIXED_POINT_STALL_STEPS = 50

# ---------------------------------------------------------------------------------------------- nlp
#: ``route="auto"`` takes the piece route from this many free blocks on.  Measured (``studies/lab/nlp_scaling.py``):
#: the Ipopt stages solve the 50-block wall in ~6 s and at most ~69 blocks within 60 s; the piece route solves the
#: 2,032-block wall within 60 s.  Below, Ipopt's local minima are kept (10x5 wall: 0.50530 against the pieces'
#: 0.50582 from the fixed point)
NLP_PIECE_ROUTE_BLOCKS = 100
#: the piece LPs' static halves run on the block IPM from this many complementarity pairs (HiGHS's dual simplex
#: below), and their whole LPs on HiGHS's interior point from ``PIECE_LP_IPM_PAIRS``
#: (``studies/lab/piece_lp_engines.py``, in git history up to e31e02c)
PIECE_LP_BLOCK_IPM_PAIRS = 4_000
PIECE_LP_IPM_PAIRS = 10_000

# ---------------------------------------------------------------------------------------------- milp
#: ``engine="auto"`` runs the branch and bound (sense="min") on structures of at most this many complementarity
#: pairs, HiGHS's big-M MILP above it and for sense="max".  The lifted LP of the branch and bound grows like
#: pairs^2 (124 pairs, the 4x3 running-bond wall: 29,929 rows; 352 pairs: 233,575 rows); above this neither
#: engine certifies a running-bond wall in 10 minutes (``studies/lab/certificate_study.py``)
MILP_BNB_MAX_PAIRS = 400

# ---------------------------------------------------------------------------------------------- block IPM
#: the block IPM's "auto" settings (:class:`~blockmpec.solvers.linalg.block_ipm.AutoRules`):
#: * ``supernodal_rows``: the supernodal Cholesky for a symmetric ``K`` of at least this many rows, SuperLU
#:   below (faster factorisations from ~4,000 blocks, but slower Python solves until ~10,000 blocks;
#:   ``studies/lab/lp_timing.py --factorisations``);
#: * ``two_process_rows``: the supernodal Cholesky in two processes from this size of ``K`` when two CPUs are
#:   usable (10,050 blocks 19.5 -> 14.1 s, 100,014 blocks 339 -> 251 s wall; ``--ipm-settings one_process,default``);
#: * ``corrector_rows``: four Gondzio correctors from this size of ``K``, two below (10,050 blocks 54 -> 47
#:   iterations; on the 3x4 wall four made ``K`` singular; ``--ipm-settings two_correctors,four_correctors``);
#: * ``compiled_kernel_blocks``: the compiled per-interface kernels (numba installed) from this many interface
#:   blocks (about 4,000 free blocks; importing numba costs 0.5-1 s; ``--kernels numpy,compiled``);
#: * ``compiled_symbolic_rows``: the compiled symbolic factorisation from this many rows (0.16 s against 1.7 s at
#:   300,042 rows; below, importing numba costs more than it saves).
BLOCK_IPM_RULES = AutoRules(supernodal_rows=30_000, two_process_rows=30_000, corrector_rows=30_000,
                            compiled_kernel_blocks=8_000, compiled_symbolic_rows=20_000)
#: the interior fixed point takes hundreds of iterations, so its compiled kernels pay from ~2,000 free blocks:
#: 2,420 blocks 50-53 s against 62-73 s with numpy (two runs each)
INTERIOR_FIXED_POINT_RULES = AutoRules(supernodal_rows=30_000, two_process_rows=30_000, corrector_rows=30_000,
                                       compiled_kernel_blocks=4_000, compiled_symbolic_rows=20_000)

#: HiGHS's algorithms
HIGHS_ALGORITHMS = ("simplex", "dual-simplex", "primal-simplex", "ipm")
#: every algorithm a user may name for a cold LP
LP_ALGORITHMS = ("auto", *HIGHS_ALGORITHMS, "block-ipm")
#: algorithms that leave a basis for warm re-solves (the LP sequences need one)
BASIS_ALGORITHMS = ("auto", *HIGHS_ALGORITHMS)
#: fixed-point engines
FIXED_POINT_ENGINES = ("auto", "simplex", "interior")
#: nlp routes
NLP_ROUTES = ("auto", "ipopt", "pieces")
#: milp engines
MILP_ENGINES = ("auto", "highs", "bnb")


def lp_algorithm(algorithm: str, n_rows: int, load_spread: float = 1.0, need_basis: bool = False,
                 warm: bool = False) -> str:
    """The LP algorithm ``"auto"`` stands for (any other name is returned unchanged).

    A cold solve of a model with more than :data:`LP_BLOCK_IPM_ROWS` rows, or whose block loads differ by more
    than :data:`LP_BLOCK_IPM_LOAD_SPREAD`, uses the block IPM when the caller needs no basis, HiGHS's IPM with
    crossover when it does (warm re-solves of a sequence start from a basis); everything else, and every warm
    re-solve, uses HiGHS's dual simplex."""
    if algorithm != "auto":
        return algorithm
    if warm:
        return "dual-simplex"
    if n_rows > LP_BLOCK_IPM_ROWS or load_spread > LP_BLOCK_IPM_LOAD_SPREAD:
        return "ipm" if need_basis else "block-ipm"
    return "dual-simplex"


def fixed_point_engine(engine: str, n_free_blocks: int) -> str:
    """The fixed-point engine ``"auto"`` stands for: ``"interior"`` from :data:`FIXED_POINT_INTERIOR_BLOCKS` free
    blocks up, else ``"simplex"`` (2D and 3D alike)."""
    if engine != "auto":
        return engine
    return "interior" if n_free_blocks >= FIXED_POINT_INTERIOR_BLOCKS else "simplex"


def fixed_point_interior_fallback(engine: str, n_free_blocks: int) -> bool:
    """Whether a simplex run that does not verify falls back to the interior engine (``engine="auto"`` below
    :data:`FIXED_POINT_INTERIOR_BLOCKS` free blocks, where the simplex engine runs first)."""
    return engine == "auto" and n_free_blocks < FIXED_POINT_INTERIOR_BLOCKS


#: ``engine="auto"``, the simplex engine first with the interior engine planned after it: the LP steps get at most this
#: share of the time left, so that the interior engine gets its turn.  On a 200-voussoir dome (1,600 contact points,
#: ~7 s per LP step) the LP steps used the whole 300 s limit (44 steps, not converged) while the interior engine alone
#: verifies λ 0.39322 in 35 s (``studies/lab/three_d_scale.py --sizes= --domes 10x20 --fixed-point --time-limit 300``)
FIXED_POINT_STEPS_SHARE = 0.5

#: 3D, ``engine="auto"``: after LP steps and an interior run that do not reach a solution of (3), a second
#: sequence with this relaxation and the "closest" tie-break, without the stall rule, in the time left.  On the
#: built-in dome the 2D defaults wander (``||n - n*||/||n||`` 0.4-0.5 for 400 steps on 24 voussoirs); relaxation 0.3
#: with "closest" converges (72 voussoirs: 203 steps, 32 s; 0.2: 517 steps, 41 s; ``studies/lab/three_d_fixed_point.py``)
FIXED_POINT_3D_RELAXATION = 0.3


def fixed_point_relaxed_fallback(engine: str, n_free_blocks: int, dim: int) -> bool:
    """Whether unverified LP steps (and the interior run after them) are followed by the relaxed "closest" sequence
    (:data:`FIXED_POINT_3D_RELAXATION`; ``engine="auto"`` in 3D where the simplex engine runs first)."""
    return engine == "auto" and dim == 3 and n_free_blocks < FIXED_POINT_INTERIOR_BLOCKS


def fixed_point_fallback(engine: str, n_free_blocks: int, dim: int = 2) -> bool:
    """Whether an unverified interior run falls back to the simplex engine (``engine="auto"`` in 2D below
    :data:`FIXED_POINT_SIMPLEX_FALLBACK_BLOCKS` free blocks; never in 3D, where the interior engine runs from
    :data:`FIXED_POINT_INTERIOR_BLOCKS` free blocks and HiGHS's step LPs of that size do not finish one step in
    minutes: a 979-block wall of 16,016 contact points none in 600 s, an 800-voussoir dome of 6,400 none in 110 s)."""
    return engine == "auto" and dim == 2 and n_free_blocks < FIXED_POINT_SIMPLEX_FALLBACK_BLOCKS


def nlp_route(route: str, n_free_blocks: int) -> str:
    """The nlp route ``"auto"`` stands for: ``"pieces"`` from :data:`NLP_PIECE_ROUTE_BLOCKS` free blocks on, else
    ``"ipopt"``."""
    if route != "auto":
        return route
    return "pieces" if n_free_blocks >= NLP_PIECE_ROUTE_BLOCKS else "ipopt"


def milp_engine(engine: str, sense: str, n_pairs: int) -> str:
    """The milp engine ``"auto"`` stands for: the branch and bound for ``sense="min"`` up to
    :data:`MILP_BNB_MAX_PAIRS` complementarity pairs, HiGHS's big-M MILP otherwise."""
    if engine != "auto":
        return engine
    return "bnb" if sense == "min" and n_pairs <= MILP_BNB_MAX_PAIRS else "highs"


def piece_lp_static_engine(n_pairs: int) -> str:
    """The engine of a piece LP's static half: ``"block-ipm"`` from :data:`PIECE_LP_BLOCK_IPM_PAIRS` pairs, else
    HiGHS's ``"dual-simplex"``."""
    return "block-ipm" if n_pairs >= PIECE_LP_BLOCK_IPM_PAIRS else "dual-simplex"


def piece_lp_whole_engine(n_pairs: int) -> str:
    """The HiGHS algorithm of a whole piece LP: ``"ipm"`` from :data:`PIECE_LP_IPM_PAIRS` pairs, else the simplex."""
    return "ipm" if n_pairs >= PIECE_LP_IPM_PAIRS else "simplex"


def describe_block_ipm(engine) -> str:
    """One plan step naming what a block IPM engine chooses (factorisation, processes, correctors, kernels), read
    before it factorises anything."""
    if engine.supernodal:
        processes = engine.supernodal_processes
        kind = f"supernodal Cholesky in {processes} process{'es' if processes > 1 else ''}"
    else:
        kind = "SuperLU LDL^T"
    kernels = "compiled kernels" if engine.block_kernels is not None else "numpy kernels"
    return f"block IPM ({kind}, {engine.corrector_count} correctors, {kernels})"


# ---------------------------------------------------------------------------------------------- the plan of a run
@dataclass(frozen=True)
class Stage:
    """One stage of a method's run: ``key`` (what ``run`` starts it by), ``name`` (the words recorded in
    ``Result.extra["plan"]``) and ``when`` (empty: every run takes it; else the condition, in words)."""

    key: str
    name: str
    when: str = ""


class Plan:
    """The stages a method's run may take, in order, as its set-up chose them (the builders below).

    ``run`` starts each stage it runs by its key (:meth:`start`, which refuses a stage the plan does not hold), and
    ``Result.extra["plan"]`` is :meth:`ran`: the names of the stages started, in order (a stage with a condition
    appears only when it ran).  :meth:`describe` lists every stage with its condition.
    """

    def __init__(self, *stages: Stage) -> None:
        self.stages = tuple(stages)
        self._ran: list[str] = []

    def __contains__(self, key: str) -> bool:
        return any(stage.key == key for stage in self.stages)

    def __getitem__(self, key: str) -> Stage:
        for stage in self.stages:
            if stage.key == key:
                return stage
        raise KeyError(f"the plan has no stage {key!r}: {[stage.key for stage in self.stages]}")

    def __repr__(self) -> str:
        return f"Plan({self.describe()})"

    def begin(self) -> None:
        """Forget the stages of an earlier run (:func:`blockmpec.run_solver` calls it before ``run``)."""
        self._ran = []

    def start(self, key: str) -> Stage:
        """Record that the run starts the stage ``key``; returns it."""
        stage = self[key]
        self._ran.append(stage.name)
        return stage

    def ran(self) -> list[str]:
        """The names of the stages started since :meth:`begin`, in order."""
        return list(self._ran)

    def describe(self) -> list[str]:
        """Every stage's name, with its condition when it has one."""
        return [f"{stage.name} ({stage.when})" if stage.when else stage.name for stage in self.stages]


def static_lp_plan(algorithm: str, fallback: bool, block_ipm: str = "block IPM") -> Plan:
    """``static-lp``: the static LP (1) by ``algorithm`` (resolved by :func:`lp_algorithm`), and with ``fallback``
    HiGHS's interior point with crossover when the block IPM ends without a solution; ``block_ipm`` names the block
    IPM's choices (:func:`describe_block_ipm`)."""
    if algorithm != "block-ipm":
        return Plan(Stage(algorithm, f"static LP (1): HiGHS {algorithm}"))
    stages = [Stage("block-ipm", f"static LP (1): {block_ipm}")]
    if fallback:
        stages.append(Stage("fallback", "static LP (1): HiGHS ipm", "if the block IPM ends without a solution"))
    return Plan(*stages)


def kinematic_lp_plan(algorithm: str) -> Plan:
    """``kinematic-lp``: the kinematic LP (2) by HiGHS's ``algorithm`` (resolved by :func:`lp_algorithm`), and one
    static LP (1) when (2) has no mechanism, to tell an infeasible (1) from an unbounded one."""
    return Plan(Stage("kinematic", f"kinematic LP (2): HiGHS {algorithm}"),
                Stage("static", "static LP (1): HiGHS dual-simplex", "if the kinematic LP has no feasible mechanism"))


def slp_plan(alpha: float, schedule: str) -> Plan:
    """``slp``: the LP steps of the modified surfaces."""
    return Plan(Stage("steps", f"SLP: HiGHS LP steps (alpha {alpha:g}, {schedule})"))


def nlp_plan(route: str, start: str, complementarity: str, stages: int, polish: bool, piece_lps: str | None,
             n_pairs: int) -> Plan:
    """``nlp``: on the ``"pieces"`` route the fixed point's solution of (3) then the piece LPs; on the ``"ipopt"``
    route the start, ``stages`` Ipopt stages, the Newton polish (``polish``), the exact point on the stages' pattern
    and the piece LPs (``piece_lps`` not None), the last three when the stages succeed."""
    pieces = f"piece LPs ({piece_lps}, static halves: {piece_lp_static_engine(n_pairs)})"
    if route == "pieces":
        return Plan(Stage("start", "start: fixed-point"), Stage("pieces", pieces))
    plan = [Stage("start", f"start: {start}"), Stage("ipopt", f"Ipopt: {stages} {complementarity} stages")]
    if polish:
        plan.append(Stage("polish", "polish: semismooth Newton on (3)", "if the stages succeed"))
    plan.append(Stage("exact", "exact point: piece LPs on the point's pattern", "if the stages succeed"))
    if piece_lps is not None:
        plan.append(Stage("pieces", pieces, "if the stages succeed"))
    return Plan(*plan)


def fixed_point_plan(engine: str, fallback: bool, start: str, tie_break: str, relaxed: bool = False) -> Plan:
    """``fixed-point``: the interior fixed point on (3) or the simplex engine's LP steps, and with ``fallback`` the
    other engine when the first does not verify; with ``relaxed`` (:func:`fixed_point_relaxed_fallback`, 3D) the
    relaxed "closest" LP steps when the simplex engine's do not verify."""
    interior = Stage("interior", "interior fixed point on (3): block IPM")
    simplex = Stage("simplex", f"fixed point: HiGHS LP steps (start {start}, tie-break {tie_break})")
    first, other = (interior, simplex) if engine == "interior" else (simplex, interior)
    stages = [first]
    if fallback:
        stages.append(Stage(other.key, other.name, "if the first engine's point does not verify"))
    if relaxed:
        stages.append(Stage("relaxed", f"fixed point: HiGHS LP steps relaxed by {FIXED_POINT_3D_RELAXATION} "
                            "(tie-break closest)", "if the stages before do not verify"))
    return Plan(*stages)


def mcp_newton_plan(start: str, fallback: bool) -> Plan:
    """``mcp-newton``: a start, then the semismooth Newton on (3); with ``fallback`` the associative start and the
    continuation in the dilatancy when Newton from the start does not converge."""
    stages = [Stage("start", f"start: {start}"), Stage("newton", "semismooth Newton on (3)")]
    if fallback:
        stages.append(Stage("fallback", "start: associative, then semismooth Newton on (3)",
                            "if Newton from the start does not converge"))
    return Plan(*stages)


def milp_plan(engine: str, incumbent: bool) -> Plan:
    """``milp``: incumbents from the associative pattern and the heuristics (``incumbent``), the LP bounds, the
    engine (:func:`milp_engine`; not when the incumbent meets the LP bound) and, for a MILP engine, the polish of its
    pattern by piece LPs (the branch and bound polishes its leaves itself)."""
    stages = [Stage("incumbent", "incumbent: the associative pattern's and the heuristics' points, finished by piece "
                    "LPs")] if incumbent else []
    stages.append(Stage("bounds", "LP bounds"))
    if engine == "bnb":
        stages.append(Stage("engine", "engine: branch and bound over the pairs (leaves polished by piece LPs)",
                            "unless the incumbent meets the LP bound"))
        return Plan(*stages)
    return Plan(*stages, Stage("engine", f"engine: {engine} MILP", "unless the incumbent meets the LP bound"),
                Stage("polish", "polish: piece LPs on the engine's pattern", "if the engine found a point"))

"""Which engines a method runs on a structure: every size threshold of the library, and the rules that read them.

Each method asks this module once, in its set-up, which engines to run (:func:`lp_algorithm`,
:func:`fixed_point_engine`, :func:`nlp_route`, :func:`milp_engine`, :func:`block_ipm_rules`), and records the
chain that ran in ``Result.extra["plan"]`` (a list of steps, in order).  The thresholds were measured; each
comment names the study that measured it.

Thresholds of the linear algebra (:mod:`blockmpec.solvers.linalg`) are handed to it as an
:class:`~blockmpec.solvers.linalg.block_ipm.AutoRules` (it imports nothing of the library).
"""

from __future__ import annotations

from blockmpec.solvers.linalg.block_ipm import AutoRules

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
#: (``studies/lab/piece_lp_engines.py``)
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
#: the supernodal Cholesky's fronts of at least this many rows get ``front_threads`` BLAS threads when that is
#: set above 1 (smaller ones stay on one; ``studies/lab/cholesky_choice.py``)
THREADED_FRONT_ROWS = 1_000

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
MILP_ENGINES = ("auto", "highs", "scip", "bnb")


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


#: engines whose kernels are written for 2D interfaces ``(t, n, m)`` with two no-tension and two friction rows:
#: a 3D problem (contact points, a friction pyramid) runs on the generic engines instead
ENGINES_2D_ONLY = ("interior",)


def fixed_point_engine(engine: str, n_free_blocks: int, dim: int = 2) -> str:
    """The fixed-point engine ``"auto"`` stands for: ``"interior"`` from :data:`FIXED_POINT_INTERIOR_BLOCKS` free
    blocks up, else ``"simplex"``; always ``"simplex"`` in 3D (the interior engine's kernels are 2D)."""
    if engine != "auto":
        return engine
    if dim == 3:
        return "simplex"
    return "interior" if n_free_blocks >= FIXED_POINT_INTERIOR_BLOCKS else "simplex"


def fixed_point_interior_fallback(engine: str, n_free_blocks: int, dim: int = 2) -> bool:
    """Whether a simplex run that does not verify falls back to the interior engine (``engine="auto"`` below
    :data:`FIXED_POINT_INTERIOR_BLOCKS` free blocks, where the simplex engine runs first; never in 3D)."""
    return engine == "auto" and n_free_blocks < FIXED_POINT_INTERIOR_BLOCKS and dim == 2


#: 3D, ``engine="auto"``: after LP steps that do not reach a solution of (3) (the stall rule above), a second
#: sequence with this relaxation and the "closest" tie-break, without the stall rule, in the time left.  On the
#: built-in dome the 2D defaults wander (``||n - n*||/||n||`` 0.4-0.5 for 400 steps on 24 voussoirs); relaxation 0.3
#: with "closest" converges (72 voussoirs: 203 steps, 32 s; 0.2: 517 steps, 41 s; ``studies/lab/three_d_fixed_point.py``)
FIXED_POINT_3D_RELAXATION = 0.3


def fixed_point_relaxed_fallback(engine: str, dim: int) -> bool:
    """Whether unverified LP steps are followed by the relaxed "closest" sequence (:data:`FIXED_POINT_3D_RELAXATION`;
    ``engine="auto"`` in 3D, where no interior engine follows)."""
    return engine == "auto" and dim == 3


def fixed_point_fallback(engine: str, n_free_blocks: int) -> bool:
    """Whether an unverified interior run falls back to the simplex engine (``engine="auto"`` below
    :data:`FIXED_POINT_SIMPLEX_FALLBACK_BLOCKS` free blocks)."""
    return engine == "auto" and n_free_blocks < FIXED_POINT_SIMPLEX_FALLBACK_BLOCKS


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
    """One plan step naming what a block IPM engine chose (factorisation, processes, correctors, kernels)."""
    factoriser = engine.factoriser
    name = type(factoriser).__name__
    if name == "SupernodalCholesky":
        kind = f"supernodal Cholesky in {factoriser.processes} process{'es' if factoriser.processes > 1 else ''}"
    else:
        kind = "SuperLU LDL^T"
    kernels = "compiled kernels" if engine.block_kernels is not None else "numpy kernels"
    return f"block IPM ({kind}, {engine.corrector_count} correctors, {kernels})"


def choose(method: str, ops, options) -> list[str]:
    """The engine chain ``method`` will run on the structure of ``ops`` with ``options`` (its ``Options``), before
    it runs: the rules above applied to the structure's size.  ``Result.extra["plan"]`` records what did run.

    Parameters
    ----------
    method : str
        A registered method name.
    ops : Operators
        The assembled structure (only its sizes and load spread are read).
    options : the method's ``Options``
    """
    from blockmpec.solvers.engines.scaling import LoadUnits

    blocks = ops.n_free_blocks
    pairs = ops.N_u.shape[1] + ops.N_f.shape[1]  # no-tension and friction rows (2D: two of each per interface)
    static_rows = ops.E.shape[0] + pairs  # equilibrium rows and the pairs' rows
    if method == "static-lp":
        algorithm = lp_algorithm(options.algorithm, static_rows, LoadUnits.of(ops).load_spread)
        return [f"static LP (1): {'block IPM' if algorithm == 'block-ipm' else f'HiGHS {algorithm}'}"]
    if method == "kinematic-lp":
        kinematic_rows = ops.E.shape[1] + 1  # compatibility, normalisation
        return [f"kinematic LP (2): HiGHS {lp_algorithm(options.algorithm, kinematic_rows, need_basis=True)}"]
    if method == "fixed-point":
        engine = fixed_point_engine(options.engine, blocks, ops.dim)
        if engine == "interior":
            chain = ["interior fixed point on (3): block IPM"]
            if fixed_point_fallback(options.engine, blocks):
                chain.append("if unverified: the simplex engine's LP steps")
            return chain
        chain = [f"fixed point: HiGHS LP steps (start {options.start}, tie-break {options.tie_break})"]
        if fixed_point_interior_fallback(options.engine, blocks, ops.dim):
            chain.append("if unverified: the interior fixed point on (3)")
        if fixed_point_relaxed_fallback(options.engine, ops.dim):
            chain.append(f"if unverified: HiGHS LP steps relaxed by {FIXED_POINT_3D_RELAXATION} (tie-break closest)")
        return chain
    if method == "slp":
        return ["SLP: HiGHS LP steps"]
    if method == "nlp":
        route = nlp_route(options.route, blocks)
        if route == "pieces":
            return ["start: fixed-point", f"piece LPs (static halves: {piece_lp_static_engine(pairs)})"]
        return [f"start: {options.start}", f"Ipopt: {options.complementarity} stages"]
    if method == "mcp-newton":
        return [f"start: {options.start}", "semismooth Newton on (3)"]
    if method == "milp":
        return ["LP bounds", f"engine: {milp_engine(options.engine, options.sense, pairs)}", "polish: piece LPs"]
    return []

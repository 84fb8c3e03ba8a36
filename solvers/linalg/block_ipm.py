r"""A primal-dual interior-point method for LPs whose inequalities are block-separable.

Limit-analysis LPs have this shape: every yield row (no-tension, friction) touches
the three forces ``(t_k, n_k, m_k)`` of one interface only, and the few columns
without yield rows (``lam``) are free.  For a compiled :class:`~blockmpec.formulations.LinearProgram`
brought to the form::

    min  c^T v   s.t.   A v = b   (y: w),      G v + s = h,  s >= 0   (y >= 0),

with ``v`` free and split into *block* columns ``v_B`` (each inequality row lies in
one block) and *border* columns ``v_F`` (no inequality rows), one Newton step of
Mehrotra's predictor-corrector method reduces to

* ``H = G^T D G`` with ``D = diag(y / s)``: block diagonal (one small SPD block per
  interface).  ``H^{-1}`` is read off the inverse of each block's scaled augmented
  matrix ``[[0, B^T], [B, -I]]``, ``B = D^{1/2} G`` (never by forming ``H``: near the
  optimum ``d`` spans 1e-10..1e10 within one interface); these per-interface inverses and products run
  as numpy gufuncs or, with the optional numba, as compiled loops (``kernels`` setting,
  :mod:`blockmpec.solvers.linalg.block_kernels`);
* ``K = A_B H^{-1} A_B^T``: sparse, symmetric positive definite, of the size of
  the equilibrium rows (3 per block), with the sparsity of the block contact graph
  (a 2D mesh for walls).  It is assembled on its fixed *structural* pattern: each
  interface's dense ``a_i H_i^{-1} a_i^T`` (``a_i``: its columns of ``A_B`` on the few
  rows they touch) is scattered into the pattern's data array by a precomputed index,
  without sparse products.  After a relative diagonal shift (``diagonal_shift``: 1e-16, round-off
  level; 1e-12 before) it is factorised once per iteration by a supernodal multifrontal
  Cholesky (dense BLAS-3 on fronts; SuperLU's ``L D L^T`` when ``K`` is not symmetric, as in the
  interior fixed point,
  or when a pivot is not positive), with a fill-reducing ordering (METIS nested
  dissection, or minimum degree without pymetis) computed once from that pattern
  (:mod:`blockmpec.solvers.linalg.cholesky`);
* the border columns by a bordered (Schur) solve: ``K W = [r, A_F]`` and a dense
  ``|F| x |F|`` system ``(A_F^T W_F) dv_F = A_F^T W_r + q_F``;
* the block unknowns ``(dv_i, dy_i)`` by exact per-block solves, and iterative
  refinement, first of the reduced system, then of the whole Newton system.  The
  predictor, corrector and Gondzio correctors only choose sigma and the step lengths:
  each is one solve with ``K``, unrefined; only their sum (the step taken, a Newton
  direction for the summed complementarity target) is refined on the whole system.
  Every direction returned satisfies the block equations exactly (a last correction
  of ``dw`` alone, which would leave ``dv`` and ``dy`` behind, is not made).
  Near the optimum of large walls the factors of ``K`` become too inaccurate for the
  stationary refinement (``dw += P e`` with the bordered solve ``P`` diverges once
  ``||I - T P|| >= 1``, ``T`` the exact reduced operator).  When it misses its target a refined
  direction falls back to GMRES on ``T P z = e`` (``x = P z``), preconditioned by the same
  factors (:meth:`BlockIPM._krylov_refinement`); where it converges nothing changes.

Each iteration takes Mehrotra's predictor and corrector plus up to four of
Gondzio's centrality correctors.  The problem is scaled first (``row_scale``,
``column_scale``; :mod:`blockmpec.solvers.engines.scaling` gives load units) and the inequality rows
to unit largest entry.  When the residuals stop improving (accuracy lost in ``K``)
the best iterate is returned: ``ACCEPTABLE`` if its residuals are at most 1e-6
(the shared verifier still checks it), ``NUMERICAL`` otherwise.  Diverging iterates
(an infeasible or unbounded LP; an interior-point method cannot prove which) end
with ``NUMERICAL`` and say so.

Residuals (stopping test, all relative, of the scaled problem)::

    primal  max(||A v - b||_inf / (1 + ||b||_inf), ||G v + s - h||_inf / (1 + ||h||_inf))
    dual    ||c - A^T w + G^T y||_inf / (1 + ||c||_inf)
    gap     |c^T v - (b^T w - h^T y)| / (1 + |c^T v|)

The dual is reported in HiGHS's sign convention (``c - A^T y_row = reduced
costs``): ``y_row = w`` on equality rows, ``-y`` on ``<=`` rows and ``+y`` on ``>=``
rows (which are negated internally), so :func:`blockmpec.solvers.engines.highs.static_lp_solution`
reads the mechanism as it does for HiGHS.

Why not a general LP code: on a 10,000-block wall HiGHS's interior-point solver
(IPX) needs ~16 s per iteration here and did not finish in 900 s; the block
structure makes the same step a batch of 7-by-7 inversions plus one sparse
factorisation of a mesh matrix (``studies/lab/lp_timing.py``).  Without a basis the
point returned is close to the analytic centre of the optimal face, not a vertex,
so it cannot start HiGHS's warm simplex re-solves (the fixed point needs them).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from enum import Enum

import numpy as np
import scipy.sparse as sp

from .cholesky import (
    SingularMatrixError,
    SupernodalCholesky,
    SymmetricFactoriser,
    compiled_kernels_available,
    structural_pattern,
    two_processes_available,
    usable_cpus,
)

__all__ = ["AutoRules", "BlockIPM", "DEFAULT_SETTINGS", "EXACT_INNER_SETTINGS", "FACTORISATIONS", "IPMIterate",
           "IPMOutcome", "IPMStatus", "KERNELS", "WIDE_DIAGONAL_SHIFT", "compiled_kernels_available",
           "single_blas_thread"]


class IPMStatus(str, Enum):
    """Why :meth:`BlockIPM.solve` stopped (the values are the library's status names; the engines map them)."""

    OPTIMAL = "optimal"  #: every residual at most ``tol``
    ACCEPTABLE = "acceptable"  #: stalled or stopped with the best iterate's residuals at most ``acceptable_tol``
    ITERATION_LIMIT = "iteration_limit"
    TIME_LIMIT = "time_limit"
    NUMERICAL = "numerical"  #: stalled, diverged (an infeasible or unbounded LP) or a singular ``K``

    @property
    def is_success(self) -> bool:
        """True for the statuses whose point is an answer (``optimal``, ``acceptable``)."""
        return self in (IPMStatus.OPTIMAL, IPMStatus.ACCEPTABLE)


@dataclass
class IPMOutcome:
    """One solve: status, primal column values ``v`` and row duals in HiGHS's sign convention (see the module
    docstring), and bookkeeping; the fields of :class:`blockmpec.solvers.engines.highs.LPOutcome`."""

    status: IPMStatus
    raw_status: str
    objective: float
    v: np.ndarray
    row_dual: np.ndarray
    iterations: int
    message: str = ""


#: iteration parameters (:meth:`BlockIPM.settings`):
#: ``refinements`` most reduced-system corrections (one solve with ``K`` each) of a refined direction;
#: ``lazy_refinement``: predictor, corrector and Gondzio correctors with at most ``inner_refinements``
#: reduced corrections, made only while the equality rows' error exceeds ``inner_tolerance`` relative
#: to ``|A| |dv|``, and no whole-system refinement, then ``final_sweeps`` whole-system refinements of
#: their sum only; ``correctors``: most Gondzio correctors per iteration, each accepted if the shorter of the
#: two steps becomes at least ``gondzio_accept`` times longer (1: not shorter), its trial step
#: ``min(1, gondzio_factor * step + gondzio_delta)``; ``step_fraction`` of the step to the boundary;
#: ``sigma = max(sigma_min, (mu_aff / mu)^sigma_power)``.
#: Most inner directions are accurate to ~1e-8 after one solve, so ``inner_tolerance`` 1e-6 (below) skips
#: their correction; with four correctors and ``gondzio_accept`` 1 as well (``fewer_solves`` of ``studies/lab/_ipm_settings.py``)
#: a thin-voussoir arch, where some inner directions are off by up to 0.16, stalls at a residual of
#: 1e-8..1e-6 instead of reaching 1e-9, so the correctors stay at two, accepted only if they lengthen the step.
#: ``krylov_iterations``: when the ``refinements`` stationary corrections of a refined direction do not
#: reach their target, at most this many GMRES iterations on the reduced (bordered) system, preconditioned
#: by the factors of ``K`` (0: none; directions whose stationary refinement converges are unchanged);
#: GMRES takes over at once when a stationary correction shrinks the error by less than the factor
#: ``krylov_switch`` (1: only after all ``refinements`` corrections, the behaviour before it existed).
#: GMRES's first step is the stationary correction with the best damping, so the switch costs nothing
#: where the stationary refinement would have converged slowly.  On walls up to 10,050 blocks every
#: correction of a refined direction shrinks the error by a factor <= 0.02 (studies/lab/lp_timing.py
#: traces): the switch never fires there and their iterates are unchanged.
#: ``inner_tolerance`` 1e-6 (the inner directions' reduced correction skipped once the equality rows hold to
#: 1e-6 relative to ``|A| |dv|``; the step taken is still refined to the absolute target) is the default since it
#: saves solves with ``K`` at every size measured, with the same lam and verifier residuals at round-off
#: (``python studies/lab/lp_timing.py --walls 20x50,40x60,70x70,50x200,100x100,180x181 --algorithms block-ipm
#: --ipm-settings exact_inner,wide_shift`` -- the default then had the diagonal shift 1e-12 --, CPU s,
#: iterations, solves with K, one run each pair): 1,010 blocks 0.61 ->
#: 0.57 s (21 -> 21, 193 -> 142); 2,420 2.79 -> 2.34 s (32 -> 30, 278 -> 184); 4,935 8.9 -> 7.8 s (44 -> 43,
#: 395 -> 288); 10,025 12.0 -> 10.4 s (38 -> 37, 349 -> 243); 10,050 19.1 -> 14.8 s (53 -> 49, 516 -> 356);
#: 32,670 85.1 -> 78.4 s (64 -> 66, 778 -> 675); 100,014 480 -> 438 s (82 -> 79, 1,306 -> 1,242; ``--walls 316x316``).
#: The interior fixed point (:class:`~blockmpec.solvers.engines.interior_fixed_point.InteriorFixedPoint`),
#: measured with 0, keeps 0 (:data:`EXACT_INNER_SETTINGS`).
#: ``diagonal_shift``: ``K + delta diag(K)`` is what is factorised.  At 1e-12 (the value before) the factors were
#: too inaccurate a preconditioner late on large walls, where ``K`` is very ill-conditioned: the refinement took
#: up to 16 solves with ``K`` per iteration and GMRES.  At round-off level (1e-16) the 100,014-block LP took
#: 312 s instead of 457 s CPU (77 / 79 iterations, 541 / 1,242 solves, the same lam), and 32,670 blocks 68 s
#: instead of 100 s; up to 10,050 blocks the times stay within +-10 % and the iteration
#: counts within the round-off spread (``python studies/lab/lp_timing.py --walls 20x50,40x60,70x70,50x200,100x100,
#: 180x181 --algorithms block-ipm --ipm-settings wide_shift,default``, and ``--walls 316x316``; docs/performance.md).  The
#: interior fixed point keeps 1e-12: its stall at 2,420 blocks stays with 1e-16 too (85 iterations, 2.4e-3).
DEFAULT_SETTINGS = {"refinements": 8, "lazy_refinement": True, "inner_refinements": 1, "inner_tolerance": 1e-6,
                    "final_sweeps": 4, "correctors": "auto", "gondzio_accept": 1.01, "gondzio_factor": 1.5,
                    "gondzio_delta": 0.1, "step_fraction": 0.995, "sigma_power": 3.0, "sigma_min": 0.0,
                    "krylov_iterations": 40, "krylov_switch": 0.1, "diagonal_shift": 1e-16, "kernels": "auto",
                    "factor_processes": "auto", "compiled_solves": "auto", "compiled_factorisation": "auto",
                    "compiled_products": "auto"}
#: the diagonal shift before 1e-16: what the interior fixed point and the comparison sets below were measured with
WIDE_DIAGONAL_SHIFT = 1e-12
#: every inner direction corrected to the absolute target: the default before ``inner_tolerance`` 1e-6, what the
#: interior fixed point runs, and the base of the comparison sets below (each measured with it, and with the
#: former diagonal shift)
EXACT_INNER_SETTINGS = {**DEFAULT_SETTINGS, "inner_tolerance": 0.0, "diagonal_shift": WIDE_DIAGONAL_SHIFT,
                        "correctors": 2}
#: ``correctors``: the most Gondzio correctors per iteration, or ``"auto"``: :data:`LARGE_CORRECTORS` when ``K``
#: has at least ``rules.corrector_rows`` (:class:`AutoRules`) rows, else :data:`SMALL_CORRECTORS`.  On large walls more correctors
#: cut the crawl's iterations by more than they cost: ``python studies/lab/lp_timing.py --walls 100x100,180x181,316x316
#: --algorithms block-ipm --ipm-settings two_correctors,default`` (docs/performance.md).  On small LPs four correctors made the
#: 3x4 wall's K singular in floating point before convergence (``acceptable`` instead of ``optimal``) and took 17
#: iterations against 15 on 10x20 (``--walls 3x4,5x4,10x20 --ipm-settings two_correctors,four_correctors``), so below
#: that size they stay at two.
SMALL_CORRECTORS, LARGE_CORRECTORS = 2, 4
#: Near the optimum of large walls the reduced refinement converges slowly (``K`` very ill-conditioned):
#: with 3 corrections and 2 sweeps (``short_refinement``) the step's equality-row error
#: reached the primal residual (1e-12 -> 4e-7) on a 32,580-block wall, which stalled ``ACCEPTABLE`` after
#: 70 iterations (165 s CPU) and failed at 100,014 blocks (``NUMERICAL`` after 82); with 8 and 4 it
#: stays <= 4e-9 and the 32k wall is ``OPTIMAL`` in 62 (134 s).  The early exits keep walls at ~10 solves
#: per iteration until the last few (up to ~45).  At 100,014 blocks even 8 and 4 do not converge in the
#: last ~10 iterations (primal residual 2e-7..1e-5): ``ACCEPTABLE`` after 87, verifier 8e-8 (> 1e-8).
#: The GMRES fallback (``krylov_iterations``) removes the stall: with 3 and 2 the 32,670-block wall
#: (``courses=180, blocks_per_course=181``) is ``OPTIMAL`` in 63 iterations, primal residual <= 3e-12
#: throughout, 0.84x the CPU time of the stationary refinement (``ACCEPTABLE`` after 74; one run).  With
#: the defaults the 100,014-block wall is ``OPTIMAL`` after 80 iterations (831 s CPU, primal residual
#: <= 7e-12 throughout, GMRES in 36 of them), verifier 1.8e-10.  With GMRES taking over after the
#: first slow correction (``krylov_switch`` 0.1) it needs 1,306 instead of 1,487 solves with K (82
#: iterations either way; GMRES in 42, 378 solves in them), verifier 3.6e-10 (studies/lab/lp_timing.py).
#: The named settings sets that experiments compare (``--ipm-settings NAME,...``: ``short_refinement``, ``previous``,
#: ``two_correctors`` ...) live with the experiments, in ``studies/lab/_ipm_settings.py``.
#: ``compiled_solves``: the supernodal Cholesky's solves with vectors by compiled loops calling the same BLAS
#: (:mod:`blockmpec.solvers.linalg.cholesky_kernels`, numba; the same solutions bit for bit): ``"auto"`` (when the
#: kernels are compiled, :attr:`BlockIPM.block_kernels`), True (needs numba) or False
COMPILED_SOLVES = ("auto", True, False)
#: ``compiled_factorisation``: the supernodal Cholesky's numeric factorisation by a compiled loop over supernodes
#: calling the same LAPACK/BLAS on the same fronts (:class:`~blockmpec.solvers.linalg.cholesky_kernels.FactorPlan`;
#: the same factors bit for bit): ``"auto"`` (when the kernels are compiled), True (needs numba) or False
COMPILED_FACTORISATION = COMPILED_SOLVES
#: ``compiled_products``: the products with ``A``, ``A_B``, ``G`` and their transposes by compiled row loops on the
#: CPUs this process may use (:class:`~blockmpec.solvers.linalg.block_kernels.SparseProducts`; scipy's sums in
#: scipy's order, the same numbers bit for bit) and the first block solve of a direction without ``dy`` (the same
#: ``dv``): ``"auto"`` (when the kernels are compiled), True (needs numba) or False
COMPILED_PRODUCTS = COMPILED_SOLVES
#: ``factor_processes``: ``"auto"`` (2 for a supernodal ``K`` of at least ``rules.two_process_rows`` (:class:`AutoRules`) rows when
#: this process may run on two or more CPUs, else 1), 1 or 2
FACTOR_PROCESSES = ("auto", 1, 2)

#: factorisations of K: ``"auto"`` (the supernodal Cholesky for a symmetric K of at least
#: ``rules.supernodal_rows`` (:class:`AutoRules`) rows, SuperLU otherwise), ``"supernodal"``, ``"superlu"``
#: (:mod:`blockmpec.solvers.linalg.cholesky`)
FACTORISATIONS = ("auto", "supernodal", "superlu")
#: the per-interface work (``kernels`` setting): the block inverses, the block products and the assembly of
#: ``K``'s values.  ``"numpy"``: numpy's gufuncs (LAPACK/BLAS once per 7-by-7 block); ``"compiled"``: one compiled
#: loop each (:mod:`blockmpec.solvers.linalg.block_kernels`, needs the optional numba); ``"auto"``: compiled when
#: numba is installed and the LP has at least ``rules.compiled_kernel_blocks`` (:class:`AutoRules`) interface blocks, numpy otherwise
KERNELS = ("auto", "numpy", "compiled")


@dataclass(frozen=True)
class AutoRules:
    """The sizes at which the ``"auto"`` settings switch (the library's are :data:`blockmpec.solvers.plan.BLOCK_IPM_RULES`,
    with their measurements).  :meth:`never` keeps every ``"auto"`` on the simple path.

    Attributes
    ----------
    supernodal_rows : float
        ``factorisation="auto"``: the supernodal Cholesky for a symmetric ``K`` of at least this many rows, SuperLU below.
    two_process_rows : float
        ``factor_processes="auto"``: two processes from this many rows of ``K`` (two usable CPUs, POSIX).
    corrector_rows : float
        ``correctors="auto"``: :data:`LARGE_CORRECTORS` from this many rows of ``K``, :data:`SMALL_CORRECTORS` below.
    compiled_kernel_blocks : float
        ``kernels="auto"``: the compiled kernels (numba installed) from this many interface blocks, numpy below.
    compiled_symbolic_rows : float
        The supernodal Cholesky's symbolic factorisation compiled (numba installed) from this many rows.
    """

    supernodal_rows: float
    two_process_rows: float
    corrector_rows: float
    compiled_kernel_blocks: float
    compiled_symbolic_rows: float

    @classmethod
    def never(cls) -> AutoRules:
        """Rules under which no ``"auto"`` setting ever switches: SuperLU, one process, two correctors, numpy."""
        return cls(math.inf, math.inf, math.inf, math.inf, math.inf)



#: smallest s/y in the block systems (a primal regularisation of fully active blocks)
SLACK_RATIO_FLOOR = 1e-14


@dataclass
class IPMIterate:
    """A primal-dual point ``(v, s, w, y)`` (internal signs, see the module docstring)."""

    v: np.ndarray
    s: np.ndarray
    w: np.ndarray
    y: np.ndarray

    def copy(self) -> IPMIterate:
        return IPMIterate(self.v.copy(), self.s.copy(), self.w.copy(), self.y.copy())


class BlockIPM:
    """Mehrotra predictor-corrector IPM for a compiled LP with block-separable inequalities.

    Parameters
    ----------
    lp : LP in matrix form
        Any object with ``c`` (n,), ``A`` (sparse, m x n), ``row_lower``, ``row_upper`` (m,), ``col_lower``,
        ``col_upper`` (n,), as :class:`blockmpec.formulations.LinearProgram`: ``min c^T v`` s.t.
        ``row_lower <= A v <= row_upper``.  All columns must be free; every row an equality or one-sided
        inequality.  ``row_upper`` is written by :meth:`set_row_upper`.
    block_columns : ndarray of int, shape (n_blocks, k)
        Columns of each block (e.g. ``x[3i:3i+3]`` of interface ``i``).  Every
        column not listed is a border column and must appear in no inequality row.
    tol : float
        Relative primal, dual and gap tolerance (see the module docstring).
    max_iterations : int
    deadline : float
        End time of the solves on :func:`time.perf_counter`'s clock (``inf``: none; :meth:`solve` may move it).
        The clock is read before and after each factorisation and before each corrector, so a
        solve overshoots its deadline by at most one factorisation and one direction.
    row_scale, column_scale : ndarray, optional
        Positive diagonal scalings ``R`` of the rows and ``C`` of the columns, as for
        :class:`blockmpec.solvers.engines.highs.HighsLP`: the method works on ``R A C``, ``R b``, ``C c``
        for the equality rows; inequality rows are scaled to unit largest entry
        after ``C`` (their part of ``R`` is not needed).  Tolerances apply to the
        scaled problem, so a good scaling makes every block's equilibrium hold
        relative to its own loads (see :mod:`blockmpec.solvers.engines.scaling`).
    ordering : str
        Fill-reducing ordering of ``K``: ``"auto"``, ``"metis"`` or ``"mmd"``
        (:data:`blockmpec.solvers.linalg.cholesky.ORDERINGS`).
    rules : AutoRules, optional
        The sizes at which the ``"auto"`` settings switch (default :meth:`AutoRules.never`).
    """

    #: the iteration parameters a new engine starts from (:meth:`settings` changes them)
    default_settings = DEFAULT_SETTINGS

    def __init__(self, lp, block_columns: np.ndarray, tol: float = 1e-9,
                 max_iterations: int = 200, deadline: float = math.inf,
                 row_scale: np.ndarray | None = None, column_scale: np.ndarray | None = None,
                 ordering: str = "auto", rules: AutoRules | None = None) -> None:
        self.lp = lp
        self.ordering = ordering
        #: the sizes at which the "auto" settings switch
        self.rules = AutoRules.never() if rules is None else rules
        self.tol = float(tol)
        self.max_iterations = int(max_iterations)
        self.deadline = float(deadline)
        self.settings(**self.default_settings)
        #: directions refined by GMRES after the stationary refinement stalled (all solves), and
        #: the solves with K that GMRES made for them
        self.krylov_steps = 0
        self.krylov_solves = 0
        #: factorisations where the Cholesky met a nonpositive pivot and SuperLU's LDL^T was used
        self.cholesky_fallbacks = 0
        # a stalled run whose best iterate is this good is ACCEPTABLE (a success that the
        # shared verifier still checks at its own tolerance, 1e-6 by default)
        self.acceptable_tol = max(1e3 * self.tol, 1e-6)
        n = lp.c.size
        if np.any(np.isfinite(lp.col_lower)) or np.any(np.isfinite(lp.col_upper)):
            raise ValueError("block IPM: every column must be free (no variable bounds)")
        lo, up = lp.row_lower, lp.row_upper
        eq = np.isfinite(lo) & np.isfinite(up) & (lo == up)
        le = ~eq & np.isfinite(up) & ~np.isfinite(lo)
        ge = ~eq & np.isfinite(lo) & ~np.isfinite(up)
        if not np.all(eq | le | ge):
            raise ValueError("block IPM: ranged or free rows are not supported")
        A = lp.A.tocsr()
        self.eq_rows = np.flatnonzero(eq)
        self.in_rows = np.flatnonzero(le | ge)
        self.in_sign = np.where(le[self.in_rows], 1.0, -1.0)  # ">=" rows negated to "<="
        self._in_position = np.full(A.shape[0], -1)
        self._in_position[self.in_rows] = np.arange(self.in_rows.size)
        self.row_scale = np.ones(self.eq_rows.size) if row_scale is None else np.asarray(row_scale, float)[self.eq_rows]
        self.column_scale = np.ones(n) if column_scale is None else np.asarray(column_scale, float)
        R, C = sp.diags(self.row_scale), sp.diags(self.column_scale)
        self.A = (R @ A[self.eq_rows] @ C).tocsr()
        self.b = self.row_scale * lo[self.eq_rows].astype(float)
        G = sp.diags(self.in_sign) @ A[self.in_rows] @ C
        self.in_scale = 1.0 / np.maximum(abs(G).max(axis=1).toarray().ravel(), 1e-300)
        G = sp.diags(self.in_scale) @ G
        self.h = self.in_scale * np.where(self.in_sign > 0, up[self.in_rows], -lo[self.in_rows]).astype(float)
        self.c = self.column_scale * lp.c.astype(float)

        block_columns = np.asarray(block_columns, dtype=np.int64)
        self.n_blocks, self.k = block_columns.shape
        block_of = np.full(n, -1)
        block_of[block_columns.ravel()] = np.repeat(np.arange(self.n_blocks), self.k)
        self._local_of = np.full(n, -1)  # each block column's place within its block
        self._local_of[block_columns.ravel()] = np.tile(np.arange(self.k), self.n_blocks)
        self.block_columns = block_columns
        self.border = np.flatnonzero(block_of < 0)
        # each inequality row: its block and its dense local row g_r (length k)
        G = G.tocoo()
        row_block = np.full(G.shape[0], -1)
        blocks_of_entries = block_of[G.col]
        if np.any(blocks_of_entries < 0):
            raise ValueError("block IPM: a border column appears in an inequality row")
        row_block[G.row] = blocks_of_entries
        check = np.zeros(G.shape[0], dtype=bool)
        check[G.row] = blocks_of_entries != row_block[G.row]
        if np.any(check) or np.any(row_block < 0):
            raise ValueError("block IPM: an inequality row spans two blocks or is empty")
        self.G = G.tocsr()
        #: the inequality matrix of the dual rows ``c - A^T w + G_dual^T y = 0``: ``G`` for an LP
        #: (a subclass for the MCP (3) has ``G_phi`` in the primal rows and ``G_psi`` here)
        self.G_dual = self.G
        counts = np.bincount(row_block, minlength=self.n_blocks)
        if counts.min() != counts.max() or counts[0] == 0:
            raise ValueError("block IPM: every block needs the same number of inequality rows")
        self.rows_per_block = int(counts[0])
        self.block_rows = np.argsort(row_block, kind="stable").reshape(self.n_blocks, self.rows_per_block)
        self.g_blocks = self.dense_blocks(self.G)
        #: each inequality row's place in the flattened (n_blocks, rows_per_block) block solutions (the gather that
        #: turns the block solves' dual parts into ``dy`` in row order)
        self.dy_of_solution = np.empty(G.shape[0], dtype=np.int64)
        self.dy_of_solution[self.block_rows.ravel()] = np.arange(self.block_rows.size)
        self.g_dual_blocks = self.g_blocks  # the dual rows' blocks (G_dual's; the same for an LP)
        #: K is symmetric (an LP): H^{-1} is symmetrised against round-off; False when G_dual != G
        self.symmetric = True
        self.A_B = self.A[:, block_columns.ravel()].tocsr()  # columns in block order
        self.A_F = self.A[:, self.border].toarray() if self.border.size else np.zeros((self.A.shape[0], 0))
        self._abs_A_B, self._abs_A_F = abs(self.A_B), np.abs(self.A_F)
        self._factoriser: SymmetricFactoriser | SupernodalCholesky | None = None
        self._superlu: SymmetricFactoriser | None = None
        #: the factorisation of K (:data:`FACTORISATIONS`)
        self.factorisation = "auto"
        #: weights ``w > 0`` of the complementarity targets (one per inequality row, in ``self.h``'s order):
        #: the iterates follow the weighted central path ``s_i y_i = w_i mu``, ``mu = mean(s o y / w)``.
        #: ``None``: all ones, the central path itself (the same iterates, bit for bit).  Read at every
        #: iteration (:meth:`before_iteration` may change them).  The weights change the path, never the
        #: LP's solutions (the study that measured what they change, studies/lab/ipm_crawl.py, is in git history up to e31e02c)
        self.path_weights: np.ndarray | None = None
        #: the structural pattern of ``K = A_B H^{-1} A_B^T`` (CSC, :func:`structural_pattern`): every entry any
        #: iterate can make nonzero; the iteration assembles and factorises ``K`` on it
        self.K_pattern = structural_pattern(self.A_B, self.k)
        #: the fixed maps that assemble ``K``'s values on :attr:`K_pattern` (:meth:`_reduced_scatter`): ``K_slots``
        #: the dense ``a_i = A_B[r_i, cols_i]`` per block, ``K_targets`` the position in ``K_pattern.data`` of each
        #: entry of ``a_i H_i^{-1} a_i^T`` (padding: ``K_pattern.nnz``), ``K_diagonal`` the positions of the diagonal
        self.K_slots, self.K_targets, self.K_diagonal = self._reduced_scatter()
        #: compiled products per sparse matrix (:meth:`_sparse_products`) and the parallel assembly of ``K``, made on
        #: first use
        self._products_cache: dict = {}
        self._reduced_assembly = None

    def dense_blocks(self, G: sp.sparray) -> np.ndarray:
        """The rows of an inequality matrix ``G`` (this LP's pattern) as dense per-block arrays,
        shape ``(n_blocks, rows_per_block, k)``."""
        G = sp.coo_array(G)
        g = np.zeros((G.shape[0], self.k))
        np.add.at(g, (G.row, self._local_of[G.col]), G.data)
        return g[self.block_rows]

    def settings(self, **values) -> None:
        """Set iteration parameters (names of :data:`DEFAULT_SETTINGS`; the sets experiments compare: ``studies/lab/_ipm_settings.py``)."""
        unknown = set(values) - set(DEFAULT_SETTINGS)
        if unknown:
            raise ValueError(f"block IPM: unknown setting(s) {', '.join(sorted(unknown))}")
        kernels = values.get("kernels")
        if kernels is not None:
            if kernels not in KERNELS:
                raise ValueError(f"block IPM: unknown kernels {kernels!r}; use one of {', '.join(KERNELS)}")
            if kernels == "compiled" and not compiled_kernels_available():
                raise ValueError('block IPM: kernels="compiled" needs numba (pip install "blockmpec[fast]")')
        processes = values.get("factor_processes")
        if processes is not None and processes not in FACTOR_PROCESSES:
            raise ValueError(f"block IPM: factor_processes must be one of {', '.join(map(str, FACTOR_PROCESSES))}, "
                             f"not {processes!r}")
        for name in ("compiled_solves", "compiled_factorisation", "compiled_products"):
            compiled = values.get(name)
            if compiled is None:
                continue
            if not (compiled is True or compiled is False or compiled == "auto"):  # 1 == True, yet no choice
                raise ValueError(f"block IPM: {name} must be one of {', '.join(map(str, COMPILED_SOLVES))}, "
                                 f"not {compiled!r}")
            if compiled is True and not compiled_kernels_available():
                raise ValueError(f'block IPM: {name}=True needs numba (pip install "blockmpec[fast]")')
        correctors = values.get("correctors")
        if correctors is not None and correctors != "auto" and not (
                isinstance(correctors, (int, np.integer)) and not isinstance(correctors, bool) and correctors >= 0):
            raise ValueError(f'block IPM: correctors must be "auto" or a count >= 0, not {correctors!r}')
        for name, value in values.items():
            chosen = name in ("factor_processes", "compiled_solves", "compiled_factorisation", "compiled_products",
                              "correctors")
            setattr(self, name, value if chosen else type(DEFAULT_SETTINGS[name])(value))

    @property
    def block_kernels(self):
        """The compiled kernels module (:mod:`blockmpec.solvers.linalg.block_kernels`) when the ``kernels`` setting
        chooses them for this LP (``"auto"``: numba installed and at least ``rules.compiled_kernel_blocks`` interface
        blocks), else None (numpy)."""
        compiled = self.kernels == "compiled" or (
            self.kernels == "auto" and self.n_blocks >= self.rules.compiled_kernel_blocks
            and compiled_kernels_available())
        if not compiled:
            return None
        from . import block_kernels

        return block_kernels

    def _sparse_products(self, M):
        """The compiled products of the sparse matrix ``M``
        (:class:`~blockmpec.solvers.linalg.block_kernels.SparseProducts`, made once per matrix object: a subclass
        or study that replaces ``self.G`` gets new ones), or None where scipy multiplies (``compiled_products``:
        ``"auto"`` with the compiled kernels, True, or False)."""
        if not self.uses_compiled_products():
            return None
        from .block_kernels import SparseProducts

        products = self._products_cache.get(id(M))
        if products is None or products.matrix is not M:
            products = self._products_cache[id(M)] = SparseProducts(M)
        return products

    def uses_compiled_products(self) -> bool:
        """Whether the sparse products ``A v``, ``A^T y`` and ``G v`` and the assembly of ``K`` run compiled (the same
        numbers): the ``compiled_products`` setting True, or ``"auto"`` with the compiled kernels
        (:attr:`block_kernels`)."""
        return self.compiled_products is True or (self.compiled_products == "auto" and self.block_kernels is not None)

    def _times(self, M, x: np.ndarray) -> np.ndarray:
        """``M @ x`` for one of the LP's sparse matrices (compiled where :meth:`_sparse_products` says so; the same
        numbers)."""
        products = self._sparse_products(M)
        return M @ x if products is None else products.times(x)

    def _offset_minus_times(self, M, offset: np.ndarray, x: np.ndarray) -> np.ndarray:
        """``-offset - M @ x`` (compiled in one pass where :meth:`_sparse_products` says so; the same numbers)."""
        products = self._sparse_products(M)
        return -offset - M @ x if products is None else products.offset_minus_times(offset, x)

    def _transpose_times(self, M, y: np.ndarray) -> np.ndarray:
        """``M.T @ y`` (as :meth:`_times`)."""
        products = self._sparse_products(M)
        return M.T @ y if products is None else products.transpose_times(y)

    def _A_B_times_with_bound(self, dv_B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(A_B dv_B, |A_B| |dv_B|)``, compiled in one pass where :meth:`_sparse_products` says so."""
        products = self._sparse_products(self.A_B)
        if products is None:
            return self.A_B @ dv_B, self._abs_A_B @ np.abs(dv_B)
        return products.times_with_bound(dv_B)

    def set_row_upper(self, rows: np.ndarray, upper: np.ndarray) -> None:
        """Change the upper bounds of ``<=`` rows ``rows`` of the compiled LP (as :class:`HighsLP` does)."""
        rows = np.asarray(rows)
        position = self._in_position[rows]
        if np.any(position < 0) or np.any(self.in_sign[position] < 0):
            raise ValueError("block IPM: set_row_upper applies to '<=' inequality rows only")
        self.lp.row_upper[rows] = upper
        self.h[position] = self.in_scale[position] * upper

    # ------------------------------------------------------------------ linear algebra
    def block_systems(self, it: IPMIterate) -> tuple[np.ndarray, np.ndarray]:
        r"""Per-block scaled augmented matrices and the scaling ``sqrt(d)``, ``d = y/s``.

        The Newton step's block equations ``G_i^T dy_i = a_i``, ``G_i dv_i - S_i Y_i^{-1} dy_i = b_i``
        have the matrix ``[[0, G_i^T], [G_i, -D_i^{-1}]]``; with ``P = diag(I, D_i^{1/2})`` it
        becomes ``[[0, B_i^T], [B_i, -I]]``, ``B_i = D_i^{1/2} G_i``, whose condition number is
        about ``cond(B_i)`` rather than ``max d / min d`` (near the optimum ``d`` spans
        1e-10..1e10 within one interface).  ``H_i^{-1} = (G_i^T D_i G_i)^{-1}`` is the top-left
        block of its inverse.  Forming ``H_i`` and inverting it instead loses all accuracy.
        """
        k, r = self.k, self.rows_per_block
        sqrt_d = self.block_scaling(it)
        M = np.zeros((self.n_blocks, k + r, k + r))
        M[:, :k, k:] = np.swapaxes(self.g_dual_blocks * sqrt_d[:, :, None], 1, 2)  # B_dual^T (B^T for an LP)
        M[:, k:, :k] = self.g_blocks * sqrt_d[:, :, None]  # B
        idx = np.arange(r)
        M[:, k + idx, k + idx] = -1.0
        return M, sqrt_d

    def block_scaling(self, it: IPMIterate) -> np.ndarray:
        """The scaling ``sqrt(d)`` of the block systems at ``it`` (:meth:`block_systems`).

        ``d_j = y_j / max(s_j, SLACK_RATIO_FLOOR y_j)`` for every inequality row ``j`` (``y`` its dual, ``s`` its
        slack), gathered by block.

        Returns
        -------
        ndarray, shape (n_blocks, rows_per_block)
        """
        d = it.y / np.maximum(it.s, SLACK_RATIO_FLOOR * it.y)
        return np.sqrt(d)[self.block_rows]

    def _reduced_scatter(self):
        r"""Fixed maps that assemble ``K = A_B H^{-1} A_B^T`` on its structural pattern.

        Block ``i`` of ``A_B`` (its ``k`` columns) touches a few rows ``r_i`` (the equilibrium rows of
        the two blocks an interface joins): ``a_i = A_B[r_i, cols_i]``, dense, padded to the largest
        count.  ``K = sum_i E_i a_i H_i^{-1} a_i^T E_i^T``: each product is scattered into the data
        array of the pattern (CSC, :func:`structural_pattern`) by a precomputed index (padding goes
        to a spare slot).  Returns ``(a, targets, diagonal positions)``.
        """
        k, nb = self.k, self.n_blocks
        A = sp.coo_array(self.A_B)
        A.sum_duplicates()
        block = A.col // k
        order = np.lexsort((A.row, block))
        block, row, col, val = block[order], A.row[order], A.col[order], A.data[order]
        key = block.astype(np.int64) * self.A_B.shape[0] + row
        unique_key, first = np.unique(key, return_index=True)
        unique_block = unique_key // self.A_B.shape[0]
        counts = np.bincount(unique_block, minlength=nb)
        slots = int(max(counts.max(initial=0), 1))
        start = np.concatenate([[0], np.cumsum(counts)[:-1]])
        slot_of_unique = np.arange(unique_key.size) - start[unique_block]
        rows = np.full((nb, slots), -1, dtype=np.int64)
        rows[unique_block, slot_of_unique] = unique_key % self.A_B.shape[0]
        slot = slot_of_unique[np.searchsorted(unique_key, key)]
        a = np.zeros((nb, slots, k))
        a[block, slot, col % k] = val
        P = self.K_pattern
        n_rows = P.shape[0]
        pattern_key = np.repeat(np.arange(n_rows, dtype=np.int64), np.diff(P.indptr)) * n_rows + P.indices
        valid = (rows[:, :, None] >= 0) & (rows[:, None, :] >= 0)
        entry_key = rows[:, None, :] * n_rows + rows[:, :, None]  # (i, j) -> column rows[j], row rows[i]
        targets = np.full(valid.shape, P.nnz, dtype=np.int64)
        targets[valid] = np.searchsorted(pattern_key, entry_key[valid])
        if np.any(pattern_key[targets[valid]] != entry_key[valid]):
            raise RuntimeError("block IPM: K has an entry outside its structural pattern")
        diagonal = np.searchsorted(pattern_key, np.arange(n_rows, dtype=np.int64) * (n_rows + 1))
        return a, targets.ravel(), diagonal

    def inverse_blocks(self, it: IPMIterate):
        r"""``(H^{-1} per block, block factors)`` at ``it``, with ``H_i = G_i^T D_i G_i`` (``D = diag(y / s)``) the
        Hessian block of interface ``i``, inverted through its scaled augmented matrix (:meth:`block_systems`).

        The block factors are ``(M^{-1}, sqrt(d), H~)``: the inverse of every block's scaled augmented
        matrix (:meth:`block_systems`), the scaling, and ``H~`` the top-left ``k x k`` block of
        ``M^{-1}`` (``H^{-1}`` before symmetrisation), contiguous, for solves whose primal right-hand
        side is zero (:meth:`_block_dual_solve`).  (Folding the scaling into ``M^{-1}`` once,
        ``diag(I, D^{1/2}) M^{-1} diag(I, D^{1/2})``, saves two products per solve but changes the
        solutions by up to 4e-13 relative, through cancellation, and with them the iterates: the
        10,050-block wall took 56 instead of 53 iterations.)"""
        k = self.k
        kernels = self.block_kernels
        if kernels is not None and type(self).block_systems is BlockIPM.block_systems:
            # compiled, M built inside the loop (the same numbers bit for bit); a subclass that changes the block
            # systems (a study's regularised blocks) takes the general path below
            sqrt_d = self.block_scaling(it)
            M_inv, top_left, Hinv = kernels.inverse_scaled_blocks(self.g_blocks, self.g_dual_blocks, sqrt_d,
                                                                  self.symmetric)
            return Hinv, (M_inv, sqrt_d, top_left)
        M, sqrt_d = self.block_systems(it)
        # LU with partial pivoting, per block (compiled: Gauss-Jordan with the same pivots)
        M_inv = np.linalg.inv(M) if kernels is None else kernels.inverse_blocks(M)
        top_left = np.ascontiguousarray(M_inv[:, :k, :k])
        Hinv = 0.5 * (top_left + np.swapaxes(top_left, 1, 2)) if self.symmetric else top_left
        return Hinv, (M_inv, sqrt_d, top_left)

    def reduced_values(self, Hinv: np.ndarray) -> np.ndarray:
        """The values of the reduced matrix ``K = A_B H^{-1} A_B^T + delta diag(K)`` (``delta``: the
        ``diagonal_shift`` setting, plus 1e-300 on the diagonal) on :attr:`K_pattern`.

        Parameters
        ----------
        Hinv : ndarray, shape (n_blocks, k, k)
            ``H_i^{-1}`` per block (:meth:`inverse_blocks`).

        Returns
        -------
        ndarray, shape (K_pattern.nnz,)
            In ``K_pattern.data`` order: ``K = sum_i E_i a_i H_i^{-1} a_i^T E_i^T`` scattered by :attr:`K_targets`.
        """
        a = self.K_slots
        kernels = self.block_kernels
        if kernels is None:
            products = np.matmul(np.matmul(a, Hinv), np.swapaxes(a, 1, 2))
            values = np.bincount(self.K_targets, weights=products.reshape(-1), minlength=self.K_pattern.nnz + 1)
            values = values[:-1]
        elif self.uses_compiled_products():
            # on the usable CPUs, the same numbers bit for bit (kernels.ReducedAssembly)
            if self._reduced_assembly is None:
                self._reduced_assembly = kernels.ReducedAssembly(self.K_targets, self.K_pattern.nnz)
            values = self._reduced_assembly.values(a, Hinv)
        else:
            values = kernels.reduced_values(a, Hinv, self.K_targets, self.K_pattern.nnz)
        # a relative diagonal shift (diagonal_shift K_ii, plus 1e-300) keeps the pivots nonzero where a
        # block's forces are all fixed by active rows; iterative refinement against the exact block solves
        # removes its effect on the direction.  The larger the shift, the less accurate the factors as a
        # preconditioner where K is ill-conditioned (late iterations of large walls), and the more solves the
        # refinement needs: hence round-off level by default (a nonpositive pivot goes to SuperLU's LDL^T)
        diagonal = self.K_diagonal
        values[diagonal] += self.diagonal_shift * np.abs(values[diagonal]) + 1e-300
        return values

    def reduced_csc(self, values: np.ndarray) -> sp.csc_array:
        """``K`` as a CSC matrix on :attr:`K_pattern` with the given values (:meth:`reduced_values`)."""
        P = self.K_pattern
        return sp.csc_array((values, P.indices, P.indptr), shape=P.shape)

    def reduced_matrix(self, it: IPMIterate):
        """``(K, blocks)``: ``K = A_B H^{-1} A_B^T + delta diag(K)`` at ``it`` by sparse products (scipy
        drops the exact zeros, e.g. at the starting point) and the block factors ``(M^{-1}, sqrt(d))``.

        For studies and tests: the iteration assembles the same matrix on its fixed structural
        pattern (:meth:`reduced_values`; equal to round-off), without sparse products.
        """
        k, nb = self.k, self.n_blocks
        Hinv, blocks = self.inverse_blocks(it)
        indptr = np.arange(0, nb * k * k + 1, k)
        indices = (np.arange(nb)[:, None, None] * k + np.arange(k)[None, None, :]).repeat(k, axis=1).ravel()
        Hinv_mat = sp.csr_array((Hinv.ravel(), indices, indptr), shape=(nb * k, nb * k))
        K = (self.A_B @ Hinv_mat @ self.A_B.T).tocsc()
        K = K + sp.diags(self.diagonal_shift * np.abs(K.diagonal()) + 1e-300, format="csc")
        return K, blocks

    @property
    def factoriser(self) -> SymmetricFactoriser | SupernodalCholesky:
        """The factoriser of ``K``, its ordering computed once from ``K``'s structural pattern:
        :class:`SupernodalCholesky` for a symmetric ``K`` (``factorisation`` ``"supernodal"``, or
        ``"auto"`` from ``rules.supernodal_rows`` rows on), SuperLU (:class:`SymmetricFactoriser`) otherwise."""
        if self._factoriser is None:
            if self.factorisation not in FACTORISATIONS:
                raise ValueError(f"block IPM: unknown factorisation {self.factorisation!r}; "
                                 f"use one of {', '.join(FACTORISATIONS)}")
            if self.factorisation == "supernodal" and not self.supernodal:
                raise ValueError("block IPM: the supernodal Cholesky needs a symmetric K")
            self._factoriser = (SupernodalCholesky(self.K_pattern, self.ordering,
                                                   processes=self.supernodal_processes,
                                                   compiled_symbolic_rows=self.rules.compiled_symbolic_rows,
                                                   **self._cholesky_choices())
                                if self.supernodal
                                else SymmetricFactoriser(self.K_pattern, self.ordering))
        return self._factoriser

    @property
    def supernodal(self) -> bool:
        """Whether :attr:`factoriser` is the supernodal Cholesky (decided without building it)."""
        return self.symmetric and (self.factorisation == "supernodal" or (
            self.factorisation == "auto" and self.K_pattern.shape[0] >= self.rules.supernodal_rows))

    def _cholesky_choices(self) -> dict[str, bool]:
        """The supernodal Cholesky's ``compiled_solves`` and ``compiled_factorisation``: the settings, ``"auto"``
        resolved to whether the block kernels are compiled (either way the same numbers bit for bit)."""
        compiled = self.block_kernels is not None
        return {name: compiled if getattr(self, name) == "auto" else getattr(self, name)
                for name in ("compiled_solves", "compiled_factorisation")}

    @property
    def corrector_count(self) -> int:
        """Gondzio correctors per iteration at most: the ``correctors`` setting, ``"auto"`` resolved by the size of
        ``K`` (``rules.corrector_rows``)."""
        if self.correctors != "auto":
            return int(self.correctors)
        return LARGE_CORRECTORS if self.K_pattern.shape[0] >= self.rules.corrector_rows else SMALL_CORRECTORS

    @property
    def supernodal_processes(self) -> int:
        """Processes of the supernodal Cholesky: the ``factor_processes`` setting, ``"auto"`` resolved to 2 when
        ``K`` has at least ``rules.two_process_rows`` rows, this process may run on two CPUs or more and the
        platform is POSIX."""
        if self.factor_processes != "auto":
            return int(self.factor_processes)
        return 2 if (self.K_pattern.shape[0] >= self.rules.two_process_rows and usable_cpus() >= 2
                     and two_processes_available()) else 1

    def factorise(self, it: IPMIterate):
        """Factorise the Newton system at ``it``: the block matrices, ``H^{-1}`` (top-left of their inverses),
        ``K = A_B H^{-1} A_B^T`` and its factors.

        Returns
        -------
        factors : tuple
            ``(blocks, solve_K, W_F, S_F_inverse)``: the scaled block systems (:meth:`block_systems` and their
            inverses), a function solving with ``K``, ``K^{-1} A_F`` and the inverse of the border's Schur complement
            ``A_F^T K^{-1} A_F``; what :meth:`direction` and :meth:`refined_direction` take.
        """
        Hinv, blocks = self.inverse_blocks(it)
        values = self.reduced_values(Hinv)
        factoriser = self.factoriser
        solve_K = None
        if isinstance(factoriser, SupernodalCholesky):
            # the settings may have changed since it was made; a worker process keeps its first choice
            for name, value in self._cholesky_choices().items():
                setattr(factoriser, name, value)
            solve_K = factoriser.factorise_values(values)
            if solve_K is None:
                # a pivot lost definiteness in floating point: SuperLU's LDL^T (same ordering), which
                # takes any nonzero pivot; its solves are counted with the Cholesky's
                if self._superlu is None:
                    self._superlu = SymmetricFactoriser(self.K_pattern, self.ordering, perm=factoriser.perm)
                self.cholesky_fallbacks += 1
                solve_lu = self._superlu.factorise(self.reduced_csc(values))

                def solve_K(rhs, _solve=solve_lu, _counter=factoriser):
                    _counter.solves += 1
                    return _solve(rhs)
        else:
            solve_K = factoriser.factorise(self.reduced_csc(values))
        W_F = solve_K(self.A_F) if self.A_F.shape[1] else self.A_F
        # the small dense Schur complement A_F^T K^{-1} A_F, inverted once (np.linalg.solve
        # on a 1-by-1 matrix costs milliseconds per call)
        S_F_inverse = np.linalg.inv(self.A_F.T @ W_F)
        return blocks, solve_K, W_F, S_F_inverse

    def block_solve(self, blocks, rhs_dual: np.ndarray, rhs_primal: np.ndarray, with_dy: bool = True):
        """Solve ``G_i^T dy_i = rhs_dual_i``, ``G_i dv_i - (s/y)_i dy_i = rhs_primal_i`` for every block ``i``.

        Parameters
        ----------
        blocks : tuple
            The block factors ``(M^{-1}, sqrt(d), H~)`` of :meth:`inverse_blocks`.
        rhs_dual : ndarray, shape (n_blocks * k,)
        rhs_primal : ndarray, shape (inequality rows,)
        with_dy : bool
            False allows ``dy`` to be left out (None; the compiled kernel then reads only ``dv``'s rows of the block
            inverses, with :meth:`uses_compiled_products`: the same ``dv``).

        Returns
        -------
        tuple of ndarray
            ``(dv, dy)``: ``dv`` in block order, ``dy`` in the inequality rows' order (or None).
        """
        M_inv, sqrt_d, _ = blocks
        kernels = self.block_kernels
        if kernels is not None:
            with_dy = with_dy or not self.uses_compiled_products()
            return kernels.block_solve(M_inv, sqrt_d, rhs_dual, rhs_primal, self.block_rows, with_dy)
        k = self.k
        rhs = np.empty((self.n_blocks, M_inv.shape[1]))
        rhs[:, :k] = rhs_dual.reshape(self.n_blocks, k)
        rhs[:, k:] = sqrt_d * rhs_primal[self.block_rows]
        sol = self.block_product(M_inv, rhs)
        # dy by a gather from the block-ordered solutions (a scatter into the rows is slower)
        return sol[:, :k].ravel(), (sqrt_d * sol[:, k:]).reshape(-1)[self.dy_of_solution]

    @staticmethod
    def block_product(M_inv: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """``M_inv[i] @ rhs[i]`` for every block (``(n, q, q)`` by ``(n, q)``), by ``matmul``: the numpy block solve
        (a replaceable attribute: a study may swap in ``einsum``, the same sums in another order)."""
        return np.matmul(M_inv, rhs[:, :, None])[:, :, 0]

    def _block_dual_solve(self, blocks, rhs_dual: np.ndarray) -> np.ndarray:
        """``dv`` of :meth:`block_solve` with ``rhs_primal = 0``: ``H~_i rhs_dual_i`` (``dy`` not formed)."""
        top_left = blocks[2]
        rhs = rhs_dual.reshape(self.n_blocks, self.k)
        kernels = self.block_kernels
        if kernels is not None:
            return kernels.block_product(top_left, rhs).reshape(-1)
        # einsum: half the time of matmul on a stack of 3-by-3 products
        return np.einsum("bij,bj->bi", top_left, rhs).reshape(-1)

    def direction(self, it: IPMIterate, factors, r_b, r_h, r_c, r_mu, refinements: int | None = None,
                   tolerance: float = 0.0):
        r"""Newton direction for residuals ``r_*`` and complementarity target ``r_mu``.

        Equations: ``A dv = -r_b``; ``G dv + ds = -r_h``; ``-A^T dw + G^T dy = -r_c``;
        ``Y ds + S dy = r_mu``.  Per block, ``G dv - (s/y) dy = -r_h - r_mu/y``.  The block
        equations hold exactly; ``dw`` is corrected (at most ``refinements`` times) until the
        equality rows' error ``e = -r_b - A dv`` is at most ``max(0.1 tol (1 + ||b||),
        tolerance || |A| |dv| ||)`` (infinity norms).
        """
        blocks, solve_K, W_F, S_F_inverse = factors
        bc = self.block_columns.ravel()
        kernels = self.block_kernels
        rhs_primal = -r_h - r_mu / it.y if kernels is None else kernels.primal_rhs(r_h, r_mu, it.y)
        rhs_dual = -r_c[bc]

        def reduced_solve(e_eq: np.ndarray, e_border: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            """``K dw + A_F dv_F = e_eq``, ``A_F^T dw = e_border`` (bordered solve)."""
            W_r = solve_K(e_eq)
            if not self.border.size:
                return W_r, np.zeros(0)
            dv_F = S_F_inverse @ (self.A_F.T @ W_r - e_border)
            return W_r - W_F @ dv_F, dv_F

        dv0, _ = self.block_solve(blocks, rhs_dual, rhs_primal, with_dy=False)  # the block step for dw = 0
        dw, dv_F = reduced_solve(self._offset_minus_times(self.A_B, r_b, dv0), r_c[self.border])
        target = 1e-1 * self.tol * (1 + _inf(self.b))
        corrections = self.refinements if refinements is None else refinements
        krylov = refinements is None and self.krylov_iterations > 0
        best = None
        previous_error = np.inf
        for done in range(corrections + 1):
            dv_B, dy = self.block_solve(blocks, rhs_dual + self._transpose_times(self.A_B, dw), rhs_primal)
            if done == corrections and not krylov:
                # a further correction of dw alone would leave dv_B and dy behind (one solve wasted)
                break
            # iterative refinement: K was assembled from inverted blocks, the block
            # solves are exact; correct dw until A dv = -r_b holds to round-off
            if tolerance > 0:
                A_dv_B, bound_B = self._A_B_times_with_bound(dv_B)
            else:
                A_dv_B, bound_B = self._times(self.A_B, dv_B), None
            e_eq, e_border = self._equality_errors(r_b, r_c, dw, dv_F, A_dv_B)
            limit = target
            if tolerance > 0:
                limit = max(target, tolerance * _inf(bound_B + self._abs_A_F @ np.abs(dv_F)))
            error = max(_inf(e_eq), _inf(e_border))
            if error <= limit:
                break
            if krylov and (best is None or error < best[0]):
                best = (error, dw, dv_F, dv_B, dy, e_eq, e_border)
            # a correction that shrank the error by less than `krylov_switch` shows that the
            # factors are too inaccurate for the stationary refinement (||I - T P|| not small):
            # it would spend the remaining corrections slowly or not converge at all
            slow = done > 0 and error > self.krylov_switch * previous_error
            previous_error = error
            if krylov and (done == corrections or slow):
                # the stationary refinement did not converge (K's factors too inaccurate):
                # GMRES from its best correction, preconditioned by the same factors
                dw, dv_F, dv_B, dy = self._krylov_refinement(blocks, reduced_solve, rhs_primal, r_b, r_c, limit,
                                                                  *best)
                break
            ddw, ddv_F = reduced_solve(e_eq, e_border)
            dw = dw + ddw
            dv_F = dv_F + ddv_F
        dv = np.zeros(self.c.size)
        dv[bc] = dv_B
        dv[self.border] = dv_F
        ds = self._offset_minus_times(self.G, r_h, dv)
        return dv, ds, dw, dy

    def _equality_errors(self, r_b, r_c, dw, dv_F, A_dv_B) -> tuple[np.ndarray, np.ndarray]:
        """Errors of a direction in the equality rows, ``-r_b - A dv``, and in the border's dual
        rows, ``r_c[F] - A_F^T dw`` (the rows the reduced solve answers for); ``A_dv_B = A_B dv_B``."""
        return -r_b - A_dv_B - self.A_F @ dv_F, r_c[self.border] - self.A_F.T @ dw

    def _krylov_refinement(self, blocks, reduced_solve, rhs_primal, r_b, r_c, limit, error, dw, dv_F, dv_B, dy,
                           e_eq, e_border):
        r"""Correct ``(dw, dv_F)`` by right-preconditioned GMRES on the bordered reduced system.

        The exact reduced operator is ``T (x_w, x_F) = (A_B H^{-1} A_B^T x_w + A_F x_F, A_F^T x_w)``,
        with ``H^{-1} A_B^T x_w`` taken from the exact block solves (``dv_B`` is affine in ``dw``).
        The stationary refinement ``x += P e`` (``P``: the bordered solve with the factors of
        ``K``) converges only while ``||I - T P|| < 1``; near the optimum of large walls ``K``
        is so ill-conditioned that its factors violate this.  GMRES on ``T P z = e``,
        ``x = P z`` (at most ``krylov_iterations`` steps, one solve with ``K`` each) only needs
        ``T P`` to have clustered eigenvalues, and its residual is the true one.  The result
        replaces the stationary one only if its equality-row error is smaller.
        """
        from scipy.sparse.linalg import LinearOperator, gmres

        m, f = e_eq.size, e_border.size
        bc = self.block_columns.ravel()

        def preconditioned(z: np.ndarray) -> np.ndarray:
            x_w, x_F = reduced_solve(z[:m], z[m:])
            x_B = self._block_dual_solve(blocks, self._transpose_times(self.A_B, x_w))
            return np.concatenate([self._times(self.A_B, x_B) + self.A_F @ x_F, self.A_F.T @ x_w])

        operator = LinearOperator((m + f, m + f), matvec=preconditioned, dtype=float)
        self.krylov_steps += 1
        solves_before = self.factoriser.solves
        budget = self.krylov_iterations
        while budget > 0:
            # restarted from the true residual: one cycle cannot reduce it by much more than
            # 1e-10 in floating point; the 2-norm bound implies the infinity-norm target
            steps = [0]
            z, _ = gmres(operator, np.concatenate([e_eq, e_border]), rtol=0.0, atol=limit,
                         restart=min(budget, 20), maxiter=1, callback=lambda _: steps.__setitem__(0, steps[0] + 1),
                         callback_type="pr_norm")
            budget -= max(steps[0], 1)
            x_w, x_F = reduced_solve(z[:m], z[m:])
            new_dw, new_dv_F = dw + x_w, dv_F + x_F
            new_dv_B, new_dy = self.block_solve(blocks, -r_c[bc] + self._transpose_times(self.A_B, new_dw), rhs_primal)
            new_e_eq, new_e_border = self._equality_errors(r_b, r_c, new_dw, new_dv_F, self._times(self.A_B, new_dv_B))
            new_error = max(_inf(new_e_eq), _inf(new_e_border))
            if not new_error < error:
                break
            dw, dv_F, dv_B, dy, e_eq, e_border, error = new_dw, new_dv_F, new_dv_B, new_dy, new_e_eq, new_e_border, new_error
            if error <= limit:
                break
        self.krylov_solves += self.factoriser.solves - solves_before
        return dw, dv_F, dv_B, dy

    def refined_direction(self, it: IPMIterate, factors, r_b, r_h, r_c, r_mu, direction=None,
                           sweeps: int = 2):
        """:meth:`direction` (or a given ``direction``), then refinement on the whole (unreduced) Newton system.

        The reduced solve loses accuracy when ``y/s`` spans many decades (thin
        voussoirs carrying thrusts 1e3 times their weight); one or two corrections
        with the same factors restore the linear equations to round-off.
        """
        dv, ds, dw, dy = self.direction(it, factors, r_b, r_h, r_c, r_mu) if direction is None else direction
        scale = 1e-2 * self.tol
        kernels = self.block_kernels
        for _ in range(sweeps):
            e_b = self._offset_minus_times(self.A, r_b, dv)
            if kernels is not None:
                e_h, e_mu, e_h_inf, e_mu_inf = kernels.newton_errors(r_h, self._times(self.G, dv), ds, r_mu, it.y,
                                                                     it.s, dy)
            else:
                e_h = -r_h - self._times(self.G, dv) - ds
                e_mu = r_mu - (it.y * ds + it.s * dy)
                e_h_inf, e_mu_inf = _inf(e_h), _inf(e_mu)
            e_c = -r_c + self._transpose_times(self.A, dw) - self._transpose_times(self.G_dual, dy)
            if (_inf(e_b) <= scale * (1 + _inf(self.b)) and _inf(e_c) <= scale * (1 + _inf(self.c))
                    and e_h_inf <= scale * (1 + _inf(self.h)) and e_mu_inf <= scale * max(_inf(r_mu), 1e-300)):
                break
            cv, cs, cw, cy = self.direction(it, factors, -e_b, -e_h, -e_c, e_mu)
            dv, ds, dw, dy = dv + cv, ds + cs, dw + cw, dy + cy
        return dv, ds, dw, dy

    def max_step(self, z: np.ndarray, dz: np.ndarray) -> float:
        """The longest step to the boundary of ``z >= 0`` along ``dz``, at most one:
        ``min(1, min over dz_i < 0 of -z_i / dz_i)`` (no masked copies: one division in place; compiled, one pass
        with the same divisions)."""
        kernels = self.block_kernels
        if kernels is not None:
            return kernels.max_step(z, dz)
        ratio = np.divide(z, dz, out=np.full(z.shape, -np.inf), where=dz < 0)
        return float(min(1.0, -ratio.max())) if ratio.size else 1.0

    # ------------------------------------------------------------------ iteration
    def residuals(self, it: IPMIterate):
        r_b = self._times(self.A, it.v) - self.b
        r_h = self._times(self.G, it.v) + it.s - self.h
        r_c = self.c - self._transpose_times(self.A, it.w) + self._transpose_times(self.G_dual, it.y)
        return r_b, r_h, r_c

    def measures(self, it: IPMIterate, residuals=None) -> tuple[float, float, float]:
        """Relative (primal, dual, gap) of an iterate (``residuals``: its :meth:`residuals`, if known)."""
        r_b, r_h, r_c = self.residuals(it) if residuals is None else residuals
        primal = max(_inf(r_b) / (1 + _inf(self.b)), _inf(r_h) / (1 + _inf(self.h)))
        dual = _inf(r_c) / (1 + _inf(self.c))
        return primal, dual, self.gap(it)

    def gap(self, it: IPMIterate) -> float:
        """The relative duality gap ``|c^T v - (b^T w - h^T y)| / (1 + |c^T v|)``."""
        pobj = self.c @ it.v
        dobj = self.b @ it.w - self.h @ it.y
        return abs(pobj - dobj) / (1 + abs(pobj))

    def _path_weights(self) -> np.ndarray | None:
        """:attr:`path_weights` checked (one positive finite weight per inequality row), or None (all ones: the
        iteration then skips multiplying and dividing by them, which changes no number)."""
        p = self.h.size
        if self.path_weights is None:
            return None
        weights = np.asarray(self.path_weights, dtype=float)
        if weights.shape != (p,):
            raise ValueError(f"block IPM: path_weights has shape {weights.shape}, expected ({p},) "
                             "(one per inequality row)")
        bad = np.flatnonzero(~(np.isfinite(weights) & (weights > 0)))
        if bad.size:
            raise ValueError(f"block IPM: path_weights must be positive and finite; row {int(bad[0])} has {weights[bad[0]]}")
        return weights

    def _centring_target(self, it: IPMIterate, ds, dy, scale: float, weights) -> np.ndarray:
        """Mehrotra's corrector target ``scale w - s y - ds dy`` (``w``: the path weights, None: ones)."""
        kernels = self.block_kernels
        if kernels is not None:
            return kernels.centring_target(it.s, it.y, ds, dy, scale, weights)
        return (scale if weights is None else scale * weights) - it.s * it.y - ds * dy

    def _centrality_correction(self, it: IPMIterate, ds, dy, tp: float, td: float, low: float, high: float,
                               weights) -> np.ndarray:
        """Gondzio's correction: the trial products ``p = (s + tp ds) (y + td dy)`` brought into ``[low w, high w]``,
        ``max(clip(p, low w, high w) - p, -high w)`` (``w``: the path weights, None: ones)."""
        kernels = self.block_kernels
        if kernels is not None:
            return kernels.centrality_correction(it.s, ds, it.y, dy, tp, td, low, high, weights)
        products = (it.s + tp * ds) * (it.y + td * dy)
        lo, hi = (low, high) if weights is None else (low * weights, high * weights)
        return np.maximum(np.clip(products, lo, hi) - products, -hi)

    def before_iteration(self, it: IPMIterate) -> None:
        """Called at the start of every iteration with the current iterate; the LP's data
        (e.g. ``self.h``) may be changed here.  Does nothing: subclasses that move the LP
        along with its iterate (an interior-point fixed point) override it."""

    def initial_point(self) -> IPMIterate:
        """Mehrotra's starting point.

        One Newton step on the linear equations from ``v = 0, w = 0, s = y = 1``
        (complementarity target kept at ``s y``), then ``s`` and ``y`` shifted to be
        positive and of the size of the mean complementarity product.
        """
        p = self.h.size
        it = IPMIterate(np.zeros(self.c.size), np.ones(p), np.zeros(self.b.size), np.ones(p))
        r_b, r_h, r_c = self.residuals(it)
        dv, ds, dw, dy = self.direction(it, self.factorise(it), r_b, r_h, r_c, np.zeros(p))
        it = IPMIterate(dv, 1.0 + ds, dw, 1.0 + dy)
        it.s += max(-1.5 * it.s.min(), 0.0)
        it.y += max(-1.5 * it.y.min(), 0.0)
        sy = float(it.s @ it.y)
        it.s += max(0.5 * sy / max(it.y.sum(), 1e-300), 1e-8)
        it.y += max(0.5 * sy / max(it.s.sum(), 1e-300), 1e-8)
        return it

    def solve(self, deadline: float | None = None) -> IPMOutcome:
        """Run Mehrotra's method from :meth:`initial_point`; the outcome in HiGHS's conventions.

        ``deadline``: a new end time (perf_counter's clock; None keeps the one given before).
        BLAS runs on one thread meanwhile (:func:`single_blas_thread`).
        """
        if deadline is not None:
            self.deadline = float(deadline)
        with single_blas_thread():
            try:
                return self._solve()
            finally:
                if isinstance(self._factoriser, SupernodalCholesky):
                    self._factoriser.close()  # its worker process, if any (``factor_processes`` 2)

    def _solve(self) -> IPMOutcome:
        t0 = time.perf_counter()
        deadline = self.deadline
        self.trace = []
        try:
            it = self.initial_point()
        except SingularMatrixError:
            return IPMOutcome(IPMStatus.NUMERICAL, "block-ipm: numerical", float("nan"), np.full(self.lp.c.size, np.nan),
                             np.full(self.lp.A.shape[0], np.nan), 0,
                             "K is singular in floating point at the starting point")
        correctors = self.corrector_count
        p = self.h.size
        status, message = IPMStatus.ITERATION_LIMIT, f"no convergence in {self.max_iterations} iterations"
        best, best_error, best_k = it.copy(), np.inf, 0
        best_measures = (np.inf, np.inf, np.inf)
        #: one row per iteration: residuals, mu, step lengths, sigma, correctors and K solves used
        self.trace = []
        k = 0
        for k in range(self.max_iterations + 1):
            self.before_iteration(it)
            weights = self._path_weights()  # read every iteration: before_iteration may change them
            r_b, r_h, r_c = self.residuals(it)
            primal, dual, gap = self.measures(it, (r_b, r_h, r_c))
            error = max(primal, dual, gap)
            mu = float(it.s @ (it.y if weights is None else it.y / weights)) / p
            if error < best_error:
                best, best_error, best_k = it.copy(), error, k
                best_measures = (primal, dual, gap)
            if error <= self.tol:
                status, message = IPMStatus.OPTIMAL, "optimal"
                break
            # near the optimum the reduced matrix K loses accuracy (its scaling y/s spans
            # ~1e-24..1e24); when the residuals stop improving, keep the best iterate
            if error > 1e3 * best_error or k - best_k >= 8:
                status = IPMStatus.ACCEPTABLE if best_error <= self.acceptable_tol else IPMStatus.NUMERICAL
                message = (f"stopped at relative residual {best_error:.1e} (primal {best_measures[0]:.1e}, dual "
                           f"{best_measures[1]:.1e}, gap {best_measures[2]:.1e}; tolerance {self.tol:g}): "
                           "the reduced system lost accuracy")
                break
            big = max(_inf(it.v), _inf(it.w), _inf(it.y))
            if not np.isfinite(big) or big > 1e13:
                status = IPMStatus.NUMERICAL
                message = ("interior-point iterates diverge (|v|, |w| or |y| > 1e13): the LP is probably "
                           "infeasible or unbounded")
                break
            if k == self.max_iterations:
                break
            solves0, krylov0, krylov_solves0 = self.factoriser.solves, self.krylov_steps, self.krylov_solves
            factors = None  # the previous factors dropped first: the factorisation may reuse their memory
            if time.perf_counter() <= deadline:
                try:
                    factors = self.factorise(it)
                except SingularMatrixError:
                    # K singular in floating point (its LDL^T met a zero pivot): no Newton step from here
                    status = IPMStatus.ACCEPTABLE if best_error <= self.acceptable_tol else IPMStatus.NUMERICAL
                    message = (f"K is singular in floating point at iteration {k}; best relative residual "
                               f"{best_error:.1e} (tolerance {self.tol:g})")
                    break
            if factors is None or time.perf_counter() > deadline:
                # checked before and after the factorisation (the costliest step): the run
                # overshoots its limit by at most one factorisation
                status, message = IPMStatus.TIME_LIMIT, f"time limit reached after {time.perf_counter() - t0:.3g} s"
                break
            lazy = self.lazy_refinement
            inner = self.inner_refinements if lazy else None
            loose = self.inner_tolerance if lazy else 0.0
            eta = self.step_fraction
            # predictor (affine scaling)
            dv, ds, dw, dy = self.direction(it, factors, r_b, r_h, r_c, -it.s * it.y, inner, loose)
            ap = self.max_step(it.s, ds)
            ad = self.max_step(it.y, dy)
            dual_aff = it.y + ad * dy
            mu_aff = float((it.s + ap * ds) @ (dual_aff if weights is None else dual_aff / weights)) / p
            sigma = min(1.0, max((mu_aff / mu) ** self.sigma_power, self.sigma_min))
            # corrector
            r_mu = self._centring_target(it, ds, dy, sigma * mu, weights)
            if lazy:
                dv, ds, dw, dy = self.direction(it, factors, r_b, r_h, r_c, r_mu, inner, loose)
            else:
                dv, ds, dw, dy = self.refined_direction(it, factors, r_b, r_h, r_c, r_mu)
            ap = eta * self.max_step(it.s, ds)
            ad = eta * self.max_step(it.y, dy)
            # Gondzio's centrality correctors: aim at a longer step whose
            # complementarity products lie in [0.1, 10] sigma mu
            zeros_b, zeros_h, zeros_c = np.zeros_like(r_b), np.zeros_like(r_h), np.zeros_like(r_c)
            used = 0
            for _ in range(correctors):
                if time.perf_counter() > deadline:
                    break
                tp, td = min(1.0, self.gondzio_factor * ap + self.gondzio_delta), min(1.0, self.gondzio_factor * ad + self.gondzio_delta)
                correction = self._centrality_correction(it, ds, dy, tp, td, 0.1 * sigma * mu, 10.0 * sigma * mu,
                                                         weights)
                if lazy:
                    cv, cs, cw, cy = self.direction(it, factors, zeros_b, zeros_h, zeros_c, correction, inner, loose)
                else:
                    cv, cs, cw, cy = self.refined_direction(it, factors, zeros_b, zeros_h, zeros_c, correction)
                nv, ns, nw, ny = dv + cv, ds + cs, dw + cw, dy + cy
                nap = eta * self.max_step(it.s, ns)
                nad = eta * self.max_step(it.y, ny)
                if min(nap, nad) < self.gondzio_accept * min(ap, ad):
                    break
                dv, ds, dw, dy, ap, ad = nv, ns, nw, ny, nap, nad
                r_mu = r_mu + correction
                used += 1
            if lazy:
                dv, ds, dw, dy = self.refined_direction(it, factors, r_b, r_h, r_c, r_mu, (dv, ds, dw, dy),
                                                         sweeps=self.final_sweeps)
                ap = eta * self.max_step(it.s, ds)
                ad = eta * self.max_step(it.y, dy)
            self.trace.append({"k": k, "mu": mu, "primal": primal, "dual": dual, "gap": gap, "sigma": sigma,
                               "step_primal": ap, "step_dual": ad, "correctors": used,
                               "centrality": float(np.min(it.s * it.y if weights is None
                                                          else it.s * it.y / weights)) / mu,
                               "solves": self.factoriser.solves - solves0, "krylov": self.krylov_steps - krylov0,
                               "krylov_solves": self.krylov_solves - krylov_solves0,
                               "fact_over_solve": (self.factoriser.factorise_s / self.factoriser.factorisations)
                               / max(self.factoriser.solve_s / max(self.factoriser.solves, 1), 1e-9),
                               "time_s": time.perf_counter() - t0})
            it.v += ap * dv
            it.s += ap * ds
            it.w += ad * dw
            it.y += ad * dy
        if status is not IPMStatus.OPTIMAL and best_error < np.inf:
            it = best
            if status is IPMStatus.ITERATION_LIMIT and best_error <= self.acceptable_tol:
                status = IPMStatus.ACCEPTABLE
                message += f"; best relative residual {best_error:.1e}"
        # back to the compiled LP's units: v = C v^, w = R w^, y = S y^
        row_dual = np.zeros(self.lp.A.shape[0])
        row_dual[self.eq_rows] = self.row_scale * it.w
        row_dual[self.in_rows] = -self.in_sign * self.in_scale * it.y
        objective = float(self.c @ it.v) if status.is_success else float("nan")
        return IPMOutcome(status, f"block-ipm: {status.value}", objective, self.column_scale * it.v, row_dual, k, message)


def single_blas_thread():
    """A context in which numpy's and scipy's BLAS use one thread (``threadpoolctl``).

    The method's dense BLAS calls are tiny (a length-``m`` dot product, a batch of 7-by-7
    inverses): multithreaded OpenBLAS spends milliseconds of CPU per call starting and spinning
    its threads.  One thread: the 10,050-block wall in 0.61x the CPU time (28.7 s against
    46.7 s, same 53 iterations; ``studies/lab/lp_timing.py``).
    """
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def _inf(a: np.ndarray) -> float:
    return float(np.max(np.abs(a))) if a.size else 0.0

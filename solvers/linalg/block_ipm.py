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

Why not a general LP code: the block structure makes an interior-point step a batch of 7-by-7 inversions plus
one sparse factorisation of a mesh matrix (the measurements against HiGHS's IPX: ``docs/performance.md``).  Without a basis the
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
from .ipm_direction import NewtonDirection, largest_magnitude
from .reduced_system import FACTORISATIONS, ReducedSystem

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



@dataclass
class IPMIterate:
    """A primal-dual point ``(v, s, w, y)`` (internal signs, see the module docstring)."""

    v: np.ndarray
    s: np.ndarray
    w: np.ndarray
    y: np.ndarray

    def copy(self) -> IPMIterate:
        return IPMIterate(self.v.copy(), self.s.copy(), self.w.copy(), self.y.copy())


class BlockIPM(ReducedSystem, NewtonDirection):
    """Mehrotra predictor-corrector IPM for a compiled LP with block-separable inequalities (its reduced Newton
    system: :class:`~blockmpec.solvers.linalg.reduced_system.ReducedSystem`; its directions and measures:
    :class:`~blockmpec.solvers.linalg.ipm_direction.NewtonDirection`).

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

    @property
    def supernodal_processes(self) -> int:
        """Processes of the supernodal Cholesky: the ``factor_processes`` setting, ``"auto"`` resolved to 2 when
        ``K`` has at least ``rules.two_process_rows`` rows, this process may run on two CPUs or more and the
        platform is POSIX."""
        if self.factor_processes != "auto":
            return int(self.factor_processes)
        return 2 if (self.K_pattern.shape[0] >= self.rules.two_process_rows and usable_cpus() >= 2
                     and two_processes_available()) else 1

    def set_row_upper(self, rows: np.ndarray, upper: np.ndarray) -> None:
        """Change the upper bounds of ``<=`` rows ``rows`` of the compiled LP (as :class:`HighsLP` does)."""
        rows = np.asarray(rows)
        position = self._in_position[rows]
        if np.any(position < 0) or np.any(self.in_sign[position] < 0):
            raise ValueError("block IPM: set_row_upper applies to '<=' inequality rows only")
        self.lp.row_upper[rows] = upper
        self.h[position] = self.in_scale[position] * upper

    @property
    def corrector_count(self) -> int:
        """Gondzio correctors per iteration at most: the ``correctors`` setting, ``"auto"`` resolved by the size of
        ``K`` (``rules.corrector_rows``)."""
        if self.correctors != "auto":
            return int(self.correctors)
        return LARGE_CORRECTORS if self.K_pattern.shape[0] >= self.rules.corrector_rows else SMALL_CORRECTORS

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
            big = max(largest_magnitude(it.v), largest_magnitude(it.w), largest_magnitude(it.y))
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


r"""Repeated sparse factorisations of one symmetric positive definite pattern (the block IPM's ``K``).

``K = A_B H^{-1} A_B^T + delta diag(K)`` changes its values at every interior-point
iteration but never its *structural* pattern: entry ``(i, j)`` can be nonzero only if
rows ``i`` and ``j`` of ``A_B`` share a block of ``H^{-1}``, i.e. ``pattern(K) =
pattern(|A_B| E |A_B|^T)`` with ``E`` the block-diagonal matrix of ones.  The fill-reducing
ordering is computed once from that pattern, never from one numerical ``K``: at the
IPM's starting point many entries of ``H^{-1}`` are exact zeros that scipy drops, and
an ordering of that sparser matrix gave 17x more fill on later ones (1,000 blocks).

``K`` is symmetric positive definite (``H^{-1}`` is, and ``A_B`` has full row rank on
a structure whose every free block has an interface), so it needs no pivoting.  Two
factorisations of a symmetric permutation ``P K P^T``:

* :class:`SupernodalCholesky` (the block IPM's default for a symmetric ``K``): a
  multifrontal supernodal Cholesky written with scipy's LAPACK/BLAS (``potrf``,
  ``trsm``, ``syrk`` on dense fronts), its symbolic analysis done once per pattern;
* :class:`SymmetricFactoriser`: SuperLU with the natural column order, symmetric mode
  and diagonal pivots only (``diag_pivot_thresh = 0``), i.e. an ``L D L^T`` in LU form;
  it also takes the non-symmetric ``K`` of the interior fixed point.

``SupernodalCholesky(..., processes=2)`` splits its elimination tree into two subtree halves and their top
(:meth:`SupernodalCholesky.subtree_halves`) and hands one half of every factorisation and solve to a
worker process (:class:`HalfWorker`, a fresh Python process, not a fork; the block IPM's default from
``rules.two_process_rows`` rows of ``K``).  Threads cannot do it: scipy's LAPACK wrappers and each front's numpy
work hold the GIL.

Orderings (:data:`ORDERINGS`):

* ``"metis"``: METIS nested dissection (``pymetis``, MIT/Apache-2.0), the ordering
  of choice for the 2D mesh pattern of a wall;
* ``"mmd"``: SuperLU's minimum degree on ``K`` (``MMD_AT_PLUS_A``), pure scipy, the
  fallback when pymetis is not installed;
* ``"auto"``: ``"metis"`` if importable, else ``"mmd"``.

The factorisation packages measured against it (fill, time, licence) are in ``docs/performance.md``.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import threading
import time
from collections.abc import Mapping
from types import MappingProxyType

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .cpus import usable_cpus  # noqa: F401 - the CPUs "auto" counts, capped by BLOCKMPEC_CPUS
from .subtree_split import SubtreeSplit
from .supernodal_solves import SupernodalSolves

__all__ = ["ORDERINGS", "SingularMatrixError", "SupernodalCholesky", "SymmetricFactoriser", "metis_available",
           "structural_pattern", "two_processes_available"]

ORDERINGS = ("auto", "metis", "mmd")


def two_processes_available() -> bool:
    """Whether this interpreter can run a :class:`HalfWorker`: a POSIX system (the worker inherits file
    descriptors) and a known Python executable to start it with (not so in some embedded interpreters)."""
    import sys

    return os.name == "posix" and bool(sys.executable)


def metis_available() -> bool:
    """Whether ``pymetis`` (with ``CSRAdjacency``, 2025.2 or later) can be imported."""
    try:
        import pymetis
    except ImportError:
        return False
    return hasattr(pymetis, "CSRAdjacency")


def structural_pattern(A: sp.sparray, block_size: int) -> sp.csc_array:
    """Pattern (all values 1) of ``A E A^T``, ``E`` block-diagonal with dense ``block_size`` blocks.

    Every entry that ``A H A^T`` can hold for any block-diagonal ``H`` with that block
    structure, plus the diagonal.
    """
    A = sp.csr_array(A)
    n_cols = A.shape[1]
    if n_cols % block_size:
        raise ValueError(f"structural_pattern: {n_cols} columns are not a multiple of the block size {block_size}")
    absA = sp.csr_array((np.ones(A.nnz), A.indices, A.indptr), shape=A.shape)
    # A E A^T = (A B)(A B)^T with B (n_cols x n_blocks) summing each block's columns
    B = sp.csr_array((np.ones(n_cols), (np.arange(n_cols), np.arange(n_cols) // block_size)),
                     shape=(n_cols, n_cols // block_size))
    AB = absA @ B
    P = (AB @ AB.T + sp.eye_array(A.shape[0], format="csr")).tocsc()
    P.sort_indices()
    return sp.csc_array((np.ones(P.nnz), P.indices, P.indptr), shape=P.shape)


def fill_reducing_ordering(pattern: sp.sparray, method: str = "auto") -> np.ndarray:
    """A symmetric permutation ``p`` (``K[p][:, p]`` is factorised) from a symmetric pattern."""
    if method not in ORDERINGS:
        raise ValueError(f"unknown ordering {method!r}; use one of {', '.join(ORDERINGS)}")
    if method == "auto":
        method = "metis" if metis_available() else "mmd"
    n = pattern.shape[0]
    if method == "metis":
        import pymetis

        graph = sp.csr_array(pattern)
        graph = sp.csr_array((np.ones(graph.nnz), graph.indices, graph.indptr), shape=graph.shape)
        graph.setdiag(0)
        graph.eliminate_zeros()
        graph.sort_indices()
        perm, _ = pymetis.nested_dissection(adjacency=pymetis.CSRAdjacency(graph.indptr, graph.indices))
        p = np.asarray(perm, dtype=np.int64)  # perm[i]: the old index of new position i
    else:
        lu = spla.splu(sp.csc_matrix(pattern + n * sp.eye_array(n, format="csc")), permc_spec="MMD_AT_PLUS_A",
                       diag_pivot_thresh=0.0, options={"SymmetricMode": True})
        p = np.argsort(lu.perm_c)  # perm_c[i] is the new position of column i
    if p.size != n or np.any(np.sort(p) != np.arange(n)):
        raise RuntimeError(f"fill-reducing ordering {method!r} did not return a permutation")
    return p


class SingularMatrixError(RuntimeError):
    """A factorisation met an exactly zero pivot (the matrix is singular in floating point)."""


class SymmetricFactoriser:
    """Factorise matrices with one fixed symmetric positive definite pattern, ordering computed once.

    Parameters
    ----------
    pattern : sparse matrix
        The structural pattern (every entry any factorised matrix may hold), e.g.
        :func:`structural_pattern`.
    ordering : str
        One of :data:`ORDERINGS`.
    perm : ndarray, optional
        A symmetric permutation to use instead of computing one.
    """

    def __init__(self, pattern: sp.sparray, ordering: str = "auto", perm: np.ndarray | None = None) -> None:
        self.ordering = ("metis" if metis_available() else "mmd") if ordering == "auto" else ordering
        self.perm = fill_reducing_ordering(pattern, self.ordering) if perm is None else np.asarray(perm)
        self.inverse_perm = np.empty_like(self.perm)
        self.inverse_perm[self.perm] = np.arange(self.perm.size)
        #: nonzeros of L + U of the last factorisation (fill diagnostics)
        self.factor_nnz = 0
        #: factorisations done and their total time (s)
        self.factorisations = 0
        self.factorise_s = 0.0
        #: solves with the factors (each a pair of triangular solves per right-hand side column)
        self.solves = 0
        self.solve_s = 0.0

    def factorise(self, K: sp.sparray):
        """``solve(rhs)`` for ``K x = rhs`` (``rhs`` a vector or a matrix of columns)."""
        p, inv_p = self.perm, self.inverse_perm
        t0 = time.process_time()
        try:
            lu = spla.splu(sp.csc_matrix(K)[p][:, p], permc_spec="NATURAL", diag_pivot_thresh=0.0,
                           options={"SymmetricMode": True})
        except RuntimeError as error:  # SuperLU: "Factor is exactly singular"
            raise SingularMatrixError(f"SuperLU: {error}") from None
        self.factor_nnz = int(lu.nnz)
        self.factorisations += 1
        self.factorise_s += time.process_time() - t0

        def solve(rhs: np.ndarray) -> np.ndarray:
            t = time.process_time()
            x = lu.solve(rhs[p])[inv_p]
            self.solves += 1
            self.solve_s += time.process_time() - t
            return x

        return solve


#: CHOLMOD's relaxed amalgamation rule (``nrelax``, ``zrelax``): a supernode and its parent are merged
#: when the merged one has at most ``columns[i]`` columns and at most ``zeros[i]`` of its stored entries
#: are explicit zeros (and always when it has at most ``columns[0]``); scaled here by ``relax``
RELAXED_COLUMNS = (4, 16, 48)
RELAXED_ZEROS = (0.8, 0.1, 0.05)
#: a child's update matrix is added into its parent's front block by block (slices) when its rows
#: fall into at most this many runs of consecutive rows of the parent, else by a flat index
#: (``np.add.at``).  ``python studies/lab/cholesky_choice.py --walls 100x100,316x316 --methods supernodal-metis
#: --extend-add-runs 2,8`` (one factorisation at an interior point, CPU s, one run): 10,050 blocks 0.10 with 2
#: runs against 0.12 with 8; 100,014 blocks 1.57 against 1.74, its flat indices 429 MB against 350 MB and
#: its analysis 10.0 s against 6.2 s.  (Adding with ``flat[index] += ...``, which buffers, 8 runs was the best.)
EXTEND_ADD_RUNS = 2


#: seconds the first factorisation waits for a starting worker process (:meth:`SupernodalCholesky._wait_for_worker`)
FIRST_WORKER_WAIT = 2.0


@functools.cache
def compiled_kernels_available() -> bool:
    """Whether numba is installed (the compiled kernels' only extra requirement); numba is not imported."""
    import importlib.util

    return importlib.util.find_spec("numba") is not None


def _columns_of(structure: list[np.ndarray], columns) -> list[np.ndarray]:
    """The rows of the given columns of ``L`` from :func:`column_structures`' list."""
    return [structure[j] for j in columns]


def column_structures(lower: sp.sparray) -> tuple[list[np.ndarray], np.ndarray]:
    """Symbolic Cholesky factorisation: the rows of every column of ``L`` and the elimination tree.

    ``lower``: the lower triangle of a symmetric pattern (CSC).  Column ``j`` of ``L`` has the rows of
    column ``j`` of ``lower``, ``j`` itself and, for every child ``c`` (``parent(c) = j``), the rows of
    column ``c`` below ``j``; ``parent(j)`` is its first row below the diagonal (``-1``: a root).
    Returns ``(rows of each column, sorted, starting with j; parent)``.
    """
    lower = sp.csc_array(lower)
    lower.sort_indices()
    n = lower.shape[0]
    indptr, indices = lower.indptr, lower.indices.astype(np.int64)
    pending: list[list[np.ndarray] | None] = [None] * n
    structure: list[np.ndarray] = [None] * n  # type: ignore[list-item]
    parent = np.full(n, -1, dtype=np.int64)
    for j in range(n):
        own = indices[indptr[j]:indptr[j + 1]]
        parts = pending[j]
        if parts is None and own.size and own[0] == j:
            rows = own
        else:
            rows = np.concatenate([[j], own] + (parts or []))
            rows.sort()  # then unique: np.unique's hashing took 2.5 of the 6.2 s at 300,042 columns
            rows = rows[np.concatenate(([True], rows[1:] != rows[:-1]))]
        pending[j] = None
        structure[j] = rows
        if rows.size > 1:
            p = int(rows[1])
            parent[j] = p
            if pending[p] is None:
                pending[p] = [rows[1:]]
            else:
                pending[p].append(rows[1:])
    return structure, parent


class SupernodalCholesky(SupernodalSolves, SubtreeSplit):
    r"""Multifrontal supernodal Cholesky ``P K P^T = L~ L~^T`` of matrices with one fixed SPD pattern.

    Symbolic analysis once: the fill-reducing ordering (as :class:`SymmetricFactoriser`), the
    structure of ``L`` and its elimination tree (:func:`column_structures`), fundamental supernodes (``j + 1`` joins ``j`` when
    ``parent(j) = j + 1`` and ``|L_{*j}| = |L_{*,j+1}| + 1``) merged by relaxed amalgamation
    (:data:`RELAXED_COLUMNS`, :data:`RELAXED_ZEROS`), and for every supernode the map from the
    matrix's values to its dense frontal matrix and from its update matrix into its parent's.

    Numeric factorisation (each call): supernodes in increasing column order (children before
    parents); front ``F`` = the supernode's columns of ``K`` plus its children's update matrices
    (extend-add); ``L11 = chol(F11)``, ``L21 = F21 L11^{-T}`` (LAPACK/BLAS: ``potrf``, ``trsm``), update
    ``F22 - L21 L21^T`` (``gemm``) for the parent.  Dense BLAS-3 work on fronts instead of SuperLU's
    LU: about half the floating-point work (symmetry) at a higher rate.

    Solves: forward and backward substitution by supernodes, ``L11`` by ``trsv`` and ``L21`` by a
    matrix-vector product with the rows below (BLAS-2 per supernode, like SuperLU's own solve).

    ``K`` must be symmetric positive definite: a nonpositive pivot (a matrix the diagonal shift does not
    keep definite in floating point) makes :meth:`factorise_values` return ``None``.

    Sizes: ``front_threads`` BLAS threads for the fronts of at least ``threaded_front_rows`` rows (others one;
    multithreaded BLAS on every front made a 32,670-block factorisation 11x slower in CPU, its threads spinning
    between thousands of tiny calls); ``compiled_symbolic="auto"`` compiles the symbolic factorisation (numba
    installed) for a pattern of at least ``compiled_symbolic_rows`` rows.  The library's values are in
    :mod:`blockmpec.solvers.plan`.
    """

    def __init__(self, pattern: sp.sparray, ordering: str = "auto", relax: float = 4.0, front_threads: int = 1,
                 threaded_front_rows: float = 0, extend_add_runs: int = EXTEND_ADD_RUNS,
                 processes: int = 1, compiled_symbolic: str | bool = "auto", compiled_solves: bool = False,
                 compiled_factorisation: bool = False, compiled_symbolic_rows: float = math.inf) -> None:
        t0 = time.process_time()
        if processes not in (1, 2):
            raise ValueError(f"supernodal Cholesky: processes must be 1 or 2, not {processes!r}")
        if processes == 2 and not two_processes_available():
            raise ValueError("supernodal Cholesky: processes=2 needs a POSIX system and sys.executable (to start "
                             "its worker process)")
        #: 2: one subtree half of every factorisation and solve runs in a worker process (:class:`HalfWorker`)
        self.processes = int(processes)
        # the worker process starts now (set up at the first factorisation): its imports overlap the analysis below
        self._worker: HalfWorker | None = HalfWorker() if processes == 2 else None
        #: CPU seconds of the worker process through its latest factorisation (``processes=2``; not in this
        #: process's ``time.process_time()``)
        self.worker_cpu_s = 0.0
        #: factorisations shared with the worker (the others, while it started, were done here alone)
        self.worker_factorisations = 0
        #: BLAS threads for the dense work on fronts of at least ``threaded_front_rows`` rows (others: one)
        self.front_threads = int(front_threads)
        self.threaded_front_rows = int(threaded_front_rows)
        #: children whose rows fall into at most this many runs of their parent's are added by slices
        self.extend_add_runs = int(extend_add_runs)
        #: solves with vectors by the compiled loops of :mod:`blockmpec.solvers.linalg.cholesky_kernels` (numba;
        #: the same BLAS calls, the same solutions bit for bit) instead of a Python loop over the supernodes
        self.compiled_solves = bool(compiled_solves)
        self._solve_structure: tuple | None = None
        #: factorisations by the compiled loop over supernodes of
        #: :class:`~blockmpec.solvers.linalg.cholesky_kernels.FactorPlan` (numba; the same LAPACK/BLAS calls on the
        #: same fronts, the same factors bit for bit) instead of the Python loop, when ``front_threads`` is 1
        self.compiled_factorisation = bool(compiled_factorisation)
        self._factor_plans: dict = {}
        self.ordering = ("metis" if metis_available() else "mmd") if ordering == "auto" else ordering
        pattern = sp.csc_array(pattern)
        pattern.sort_indices()
        n = pattern.shape[0]
        self.n = n
        self.perm = fill_reducing_ordering(pattern, self.ordering)
        self.inverse_perm = np.empty_like(self.perm)
        self.inverse_perm[self.perm] = np.arange(n)
        # the permuted pattern, each entry carrying its position in `pattern.data` (+1)
        tagged = sp.csc_matrix((np.arange(1, pattern.nnz + 1, dtype=float), pattern.indices, pattern.indptr),
                               shape=pattern.shape)
        permuted = tagged[self.perm][:, self.perm].tocsc()
        permuted.sort_indices()
        self._pattern = pattern
        # structure of L (symbolic factorisation) and the elimination tree
        lower = sp.tril(permuted, format="csc")
        self.compiled_symbolic = (n >= compiled_symbolic_rows and compiled_kernels_available()
                                  if compiled_symbolic == "auto" else bool(compiled_symbolic))
        if self.compiled_symbolic:
            from blockmpec.solvers.linalg.cholesky_kernels import symbolic_factorisation

            counts, parent, rows_of = symbolic_factorisation(lower)
        else:
            structure, parent = column_structures(lower)
            counts = np.array([rows.size for rows in structure], dtype=np.int64)
            rows_of = functools.partial(_columns_of, structure)
            del structure  # held by rows_of until the supernodes' rows are taken
        joins = np.zeros(n, dtype=bool)
        joins[1:] = (parent[:-1] == np.arange(1, n)) & (counts[:-1] == counts[1:] + 1)
        starts = np.flatnonzero(~joins)
        ends = np.append(starts[1:], n)
        supernode_of = np.repeat(np.arange(starts.size), ends - starts)
        last_parent = parent[ends - 1]
        supernode_parent = np.where(last_parent >= 0, supernode_of[np.maximum(last_parent, 0)], -1)
        # relaxed amalgamation (children before parents): merge each supernode's group into its
        # parent's group when the merged one passes CHOLMOD's rule; merged groups are connected
        # subtrees of the elimination tree, so a topological renumbering makes each one contiguous
        limits = tuple(relax * c for c in RELAXED_COLUMNS)
        width = (ends - starts).astype(np.int64)
        rows = counts[starts].astype(np.int64)
        true = np.add.reduceat(counts.astype(np.int64), starts)
        merged_into = np.full(starts.size, -1)
        for s in range(starts.size):
            q = int(supernode_parent[s])
            if q < 0:
                continue
            w = width[s] + width[q]
            m = width[s] + rows[q]
            stored = w * m - w * (w - 1) // 2
            zeros = 1.0 - (true[s] + true[q]) / stored
            if (w <= limits[0] or (w <= limits[1] and zeros <= RELAXED_ZEROS[0])
                    or (w <= limits[2] and zeros <= RELAXED_ZEROS[1]) or zeros <= RELAXED_ZEROS[2]):
                merged_into[s] = q
                width[q], rows[q], true[q] = w, m, true[s] + true[q]
        top = np.arange(starts.size)
        for s in range(starts.size - 1, -1, -1):
            if merged_into[s] >= 0:
                top[s] = top[merged_into[s]]
        # new order: groups by their top supernode, each group's columns in their old order
        column_top = top[supernode_of]
        order = np.lexsort((np.arange(n), column_top))  # order[new] = old position
        new_position = np.empty(n, dtype=np.int64)
        new_position[order] = np.arange(n)
        tops = np.unique(column_top)
        first = np.searchsorted(column_top[order], tops)
        end = np.append(first[1:], n)
        self.rows = []
        # each group's last column (old numbering): its rows below it
        for f, e, last_rows in zip(first, end, rows_of(ends[tops] - 1)):
            below = np.sort(new_position[last_rows[1:]])
            self.rows.append(np.concatenate([np.arange(f, e), below]).astype(np.int64))
        del rows_of
        self.perm = self.perm[order]
        self.inverse_perm[self.perm] = np.arange(n)
        permuted = tagged[self.perm][:, self.perm].tocsc()
        permuted.sort_indices()
        lower = sp.tril(permuted, format="csc")
        lower.sort_indices()
        lower_source = lower.data.astype(np.int64) - 1  # pattern.data index of each lower entry
        first, end = first.astype(np.int64), end.astype(np.int64)
        supernode_of = np.repeat(np.arange(first.size), end - first)
        self.first, self.end = first, end
        ns = first.size
        self.children: list[list[int]] = [[] for _ in range(ns)]
        #: each child's rows below its columns as positions in its parent's rows (None: no rows below)
        self._relative_rows: list[np.ndarray | None] = [None] * ns
        self._relative: list | None = None
        for s in range(ns):
            width = int(end[s] - first[s])
            R = self.rows[s]
            if R.size > width:
                p_s = int(supernode_of[R[width]])
                self.children[p_s].append(s)
                rel = np.searchsorted(self.rows[p_s], R[width:])
                if not np.array_equal(self.rows[p_s][rel], R[width:]):
                    raise RuntimeError("supernodal Cholesky: a child's structure is not in its parent's")
                self._relative_rows[s] = rel.astype(np.int64)
        # assembly: each lower entry of permuted K into its supernode's front (flat index)
        column_of = np.repeat(np.arange(n), np.diff(lower.indptr))
        s_of = supernode_of[column_of]
        order = np.argsort(s_of, kind="stable")  # entries are in column order already: stays sorted
        self._assembly_offsets = np.searchsorted(s_of, np.arange(ns + 1))
        destination = np.empty(lower.nnz, dtype=np.int64)
        for s in range(ns):
            a, b = self._assembly_offsets[s], self._assembly_offsets[s + 1]
            R = self.rows[s]
            local_row = np.searchsorted(R, lower.indices[a:b])
            destination[a:b] = (column_of[a:b] - first[s]) * R.size + local_row  # column-major front
        del order
        #: for each entry of the permuted ``K``'s lower triangle (in its CSC order, grouped by supernode), its flat
        #: position in its supernode's front (column-major, the front's rows ``self.rows[s]``)
        self.assembly_destination = destination
        self._assembly_source = lower_source
        #: the rows below each supernode's diagonal block (its panel's rows after the first ``width``; the solves' gathers)
        self.below_rows = [self.rows[s][int(end[s] - first[s]):] for s in range(ns)]
        #: each supernode's first column as a Python int (a BLAS offset in every solve: no numpy scalar per call)
        self._first_columns = first.tolist()
        #: entries stored in the supernodes' panels (lower trapezoids, amalgamation zeros included)
        self.stored_nnz = int(sum(self.rows[s].size * w - w * (w - 1) // 2
                                  for s, w in enumerate((end - first).tolist())))
        self.supernodes = ns
        #: nonzeros of L (structural, without amalgamation zeros) + U, as SuperLU counts its L + U
        self.factor_nnz = 2 * int(counts.sum())
        #: floating-point operations of one numeric factorisation (:meth:`front_flops` summed): the dense work no
        #: implementation of this ordering avoids
        self.factor_flops = float(self.front_flops().sum())
        self.analyse_s = time.process_time() - t0
        self.factorisations = 0
        self.factorise_s = 0.0
        #: wall-clock time of the factorisations (below their CPU time when ``front_threads`` > 1 pays)
        self.factorise_wall_s = 0.0
        self.solves = 0
        self.solve_s = 0.0
        #: the first factorisation waited for the worker process (and warmed this process's half meanwhile)
        self._waited_for_worker = False
        if self._worker is not None:
            self._worker.set_up(self)  # sent now: the worker unpickles and warms up while the caller prepares K

    @property
    def relative(self) -> list:
        """Each child's extend-add plan into its parent's front (:meth:`_extend_add_plan`; None for a supernode
        without rows below), made on first use: only the Python factorisation reads them (at 100,014 blocks they
        took 0.3 s and 430 MB, which the compiled factorisation and the worker process's set-up do without)."""
        if self._relative is None:
            parent = self.supernode_parents()
            self._relative = [None if rel is None else
                              self._extend_add_plan(rel, self.rows[parent[s]].size,
                                                    int(self.end[parent[s]] - self.first[parent[s]]),
                                                    self.extend_add_runs)
                              for s, rel in enumerate(self._relative_rows)]
        return self._relative

    @property
    def extend_add_index_bytes(self) -> int:
        """Bytes of the flat extend-add indices (children added by slices need none)."""
        return int(sum(plan[1].nbytes for plan in self.relative if plan is not None and plan[1] is not None))

    @staticmethod
    def _extend_add_plan(rel: np.ndarray, parent_rows: int, parent_width: int, most_runs: int = EXTEND_ADD_RUNS):
        """How a child's update matrix is added into its parent's front (rows ``rel`` of the parent).

        ``(runs, None)``: maximal runs of consecutive parent rows (split at the parent's own columns),
        each ``(u0, u1, f0, f1)``, added block by block (lower triangle only) when there are at most
        ``most_runs``; else ``(None, flat index)`` into the parent's front (``col * m + row``).
        """
        breaks = np.flatnonzero((np.diff(rel) != 1) | (rel[1:] == parent_width)) + 1
        bounds = np.concatenate([[0], breaks, [rel.size]])
        if bounds.size - 1 <= most_runs:
            runs = [(int(u0), int(u1), int(rel[u0]), int(rel[u0]) + int(u1 - u0)) for u0, u1 in zip(bounds[:-1], bounds[1:])]
            return runs, None
        index_type = np.int32 if parent_rows * parent_rows < 2**31 else np.int64
        rel = rel.astype(index_type)
        return None, (rel[:, None] * index_type(parent_rows) + rel[None, :]).ravel()

    def factorise(self, K: sp.sparray):
        """``solve(rhs)`` for ``K x = rhs``, ``K`` a sparse matrix within the pattern; None if not definite."""
        return self.factorise_values(self.pattern_values(K))

    def pattern_values(self, K: sp.sparray) -> np.ndarray:
        """``K``'s values on the structural pattern (``pattern.data`` order; zero where ``K`` has no entry)."""
        K = sp.coo_array(K)
        K.sum_duplicates()
        pattern = self._pattern
        values = np.zeros(pattern.nnz)
        rows, columns = K.row, K.col
        key_K = columns.astype(np.int64) * self.n + rows
        key_P = np.repeat(np.arange(self.n, dtype=np.int64), np.diff(pattern.indptr)) * self.n + pattern.indices
        where = np.searchsorted(key_P, key_K)
        if np.any(where >= key_P.size) or np.any(key_P[np.minimum(where, key_P.size - 1)] != key_K):
            raise ValueError("supernodal Cholesky: the matrix has entries outside its structural pattern")
        values[where] = K.data
        return values

    def factorise_values(self, values: np.ndarray):
        """``solve(rhs)`` for ``K x = rhs`` with ``K``'s values given on the pattern (``pattern.data`` order);
        None if a pivot is not positive."""
        t0, wall0 = time.process_time(), time.perf_counter()
        diagonal_blocks: list[np.ndarray | None] = [None] * self.supernodes
        below_blocks: list[np.ndarray | None] = [None] * self.supernodes
        self.start_worker()
        if self._worker is not None and not self._waited_for_worker:
            self._wait_for_worker()
        if self._worker is not None and self._worker.ready():
            # one BLAS thread, as in the worker: the two processes' arithmetic is the same whatever BLAS threads the
            # caller runs with, so a shared factorisation's numbers equal those made here while the worker starts
            with _blas_controller().limit(limits=1):
                factorised = self._worker.factorise(values, diagonal_blocks, below_blocks)
            solver = self._worker.solver
            self.worker_factorisations += 1
        elif self._worker is not None:
            # while a worker starts: its halves and top here (the serial factors), its solves' arithmetic, so that the
            # iterates do not depend on when it is ready
            with _blas_controller().limit(limits=1):
                factorised = self._worker.serial_factorise(values, diagonal_blocks, below_blocks)
            solver = self._worker.serial_solver
        else:
            factorised = self.factor_supernodes(range(self.supernodes), values, {}, diagonal_blocks, below_blocks)
            solver = self.solver
        if not factorised:
            return None
        self.factorisations += 1
        self.factorise_s += time.process_time() - t0
        self.factorise_wall_s += time.perf_counter() - wall0
        return solver(diagonal_blocks, below_blocks)

    def _wait_for_worker(self) -> None:
        """Before the first factorisation with a worker that is still starting: warm this process's half (its plan
        and the first touch of its factor array, on ``K = I``), then wait for the worker at most
        :data:`FIRST_WORKER_WAIT` seconds.  A factorisation here alone costs about twice a shared one, and the
        worker's warm-up overlaps this one's, so the first factorisation is usually shared; if the worker is later,
        it runs here alone as before (the same factors either way)."""
        self._waited_for_worker = True
        worker = self._worker
        if worker.ready():
            return
        if self.compiled_factorisation:
            self.factor_supernodes(worker.mine, self.identity_values(), {}, [None] * self.supernodes,
                                   [None] * self.supernodes)
        worker.wait_ready(FIRST_WORKER_WAIT, required=False)

    def identity_values(self) -> np.ndarray:
        """The values of ``K = I`` on the pattern (``pattern.data`` order): what the warm-ups factorise."""
        pattern = self._pattern
        values = np.zeros(pattern.nnz)
        values[pattern.indices == np.repeat(np.arange(self.n), np.diff(pattern.indptr))] = 1.0
        return values

    def start_worker(self, wait: bool = False) -> None:
        """With ``processes=2``, start the worker process if it is not running (:class:`HalfWorker`).  It starts in
        the background: until it has its set-up, factorisations are done here alone, the same factors bit for bit.
        ``wait``: return only once it is ready."""
        if self.processes == 2:
            if self._worker is None:
                self._worker = HalfWorker()
            if self._worker.chol is None:
                self._worker.set_up(self)
            if wait:
                self._worker.wait_ready()

    @property
    def worker(self) -> HalfWorker | None:
        """The worker process that factorises and solves one subtree half (``processes=2``; None when there is
        none: ``processes=1``, or after :meth:`close`)."""
        return self._worker

    @property
    def factor_plans(self) -> Mapping:
        """The compiled factorisation plans made so far (:meth:`factor_plan`), read-only, by their supernodes."""
        return MappingProxyType(self._factor_plans)

    def __getstate__(self) -> dict:
        """The symbolic analysis without the worker process (what a :class:`HalfWorker` receives)."""
        return {**self.__dict__, "_worker": None, "processes": 1, "_factor_plans": {}, "_relative": None}

    def close(self) -> None:
        """Stop the worker process (``processes=2``); the next factorisation starts a new one."""
        if self._worker is not None:
            self._worker.close()
            self._worker = None

    def factor_supernodes(self, supernodes, values: np.ndarray, updates: dict[int, np.ndarray],
                          diagonal_blocks: list, below_blocks: list) -> bool:
        """Factorise the given supernodes in their order (each after its children): ``L11``/``L21`` into
        ``diagonal_blocks[s]``/``below_blocks[s]``, update matrices left in ``updates`` for parents not given.

        ``values``: ``K``'s values on the pattern (:meth:`pattern_values`).  False if a pivot is not positive.
        A union of whole subtrees needs no update from outside it (``studies/lab/cholesky_choice.py --side-by-side``
        factorises two of them in two processes).  With :attr:`compiled_factorisation` (and one BLAS thread per
        front) the loop is compiled (:meth:`factor_plan`); its blocks are views of one array."""
        if self.compiled_factorisation and self.front_threads == 1:
            return self.factor_plan(supernodes).factorise(self, values, updates, diagonal_blocks, below_blocks)
        from scipy.linalg.blas import dsyrk, dtrsm
        from scipy.linalg.lapack import dpotrf

        threaded = _blas_controller() if self.front_threads > 1 else None
        destination, offsets, source = self.assembly_destination, self._assembly_offsets, self._assembly_source
        for s in supernodes:
            m, width = self.rows[s].size, int(self.end[s] - self.first[s])
            F = np.zeros((m, m), order="F")  # the front; its lower triangle holds the values
            flat = F.T.reshape(-1)  # a view: flat[col * m + row]
            a, b = offsets[s], offsets[s + 1]
            flat[destination[a:b]] = values[source[a:b]]
            for c in self.children[s]:
                update = updates.pop(c)
                runs, index = self.relative[c]
                if index is not None:
                    # unbuffered (the indices are distinct): 3-4x faster than `flat[index] += ...`
                    # on numpy >= 1.25, the same sums bit for bit
                    np.add.at(flat, index, update.T.reshape(-1))
                else:
                    for i, (u0, u1, f0, f1) in enumerate(runs):
                        for v0, v1, g0, g1 in runs[:i + 1]:
                            F[f0:f1, g0:g1] += update[u0:u1, v0:v1]
            if threaded is not None and m >= self.threaded_front_rows:
                with threaded.limit(limits=self.front_threads):
                    L11, L21, update = _dense_front(F, width, dpotrf, dtrsm, dsyrk)
            else:
                L11, L21, update = _dense_front(F, width, dpotrf, dtrsm, dsyrk)
            if L11 is None:
                return False
            diagonal_blocks[s] = L11
            below_blocks[s] = L21
            if update is not None:
                updates[s] = update
        return True

    def factor_plan(self, supernodes):
        """The compiled factorisation's plan for this set of supernodes
        (:class:`~blockmpec.solvers.linalg.cholesky_kernels.FactorPlan`), made on first use and kept with its
        workspace."""
        from .cholesky_kernels import FactorPlan

        members = np.fromiter(supernodes, dtype=np.int64)
        key = members.tobytes()
        plan = self._factor_plans.get(key)
        if plan is None:
            plan = self._factor_plans[key] = FactorPlan(self, members)
        return plan

    def drop_factor_plan(self, supernodes) -> None:
        """Forget the compiled factorisation's plan for this set of supernodes (its workspace freed), if made."""
        self._factor_plans.pop(np.fromiter(supernodes, dtype=np.int64).tobytes(), None)

class HalfWorker:
    r"""One subtree half of a :class:`SupernodalCholesky`'s factorisations and solves, run by a worker process.

    Set-up (once): the halves and their top (:meth:`SupernodalCholesky.subtree_halves`); one shared-memory file
    (:func:`_shared_file`) holding ``K``'s values, the solve vector, the change the worker's half makes to the top's
    rows, and the update matrices of the worker's subtree roots.  The worker is a fresh Python process
    (:func:`_serve_half`, started by :mod:`subprocess` from the directory that holds this package; not forked:
    forking a process that runs BLAS threads is unsafe, and a pool's daemonic worker may not start
    :mod:`multiprocessing` children).  It starts when the Cholesky is made, so that its imports (about 0.7 s, numba's
    kernels included) overlap the symbolic analysis; at the end of the analysis (:meth:`set_up`) it receives the
    analysis (without the Python factorisation's extend-add plans), pickled and sent over a socket by a thread of
    this process, and warms up on ``K = I`` (its half's plan, the first touch of its factor array, the compiled
    loops' first calls) before it reports ready.  Until then
    :meth:`SupernodalCholesky.factorise_values` factorises here alone, by the same halves and top
    (:meth:`serial_factorise`); the first factorisation waits for it (:meth:`SupernodalCholesky._wait_for_worker`).
    At 100,014 blocks this start took the LP's first four factorisations from 2.8, 1.9, 1.2 and 0.7 s to 2.2 (1.7 s
    of it waiting), 0.4, 0.4 and 0.4 s (a one-off timing of its ``factorise_values``, one run each).

    Factorisation: this process factorises half 0 while the worker factorises half 1 and keeps its blocks of
    ``L~``; the worker's root update matrices come back through shared memory, then this process factorises the
    top.  The factors are those of the serial factorisation, bit for bit.

    Solve (a vector at a time): the two halves' forward substitutions side by side (the worker's returns its rows
    and its change to the top's rows), the top's forward and backward substitution here, then the two halves'
    backward substitutions side by side.  The kernels are the serial solve's; only the sums into the top's rows
    are grouped differently, so solutions agree to round-off.

    The worker's CPU time does not count in this process's ``time.process_time()``; it is reported with every
    factorisation (:attr:`SupernodalCholesky.worker_cpu_s`).
    """

    def __init__(self) -> None:
        """Start the worker process.  It imports what it needs (numpy, scipy, this module and, when installed, the
        compiled kernels) and then waits for its set-up (:meth:`set_up`), so that its start overlaps the symbolic
        analysis that precedes the set-up."""
        import socket
        import subprocess
        import sys
        import weakref
        from multiprocessing.connection import Connection

        self.chol: SupernodalCholesky | None = None
        fd = _shared_file(0)  # sized by set_up, before the worker maps it
        #: the shared memory's file until :meth:`set_up` maps and closes it (closed by :func:`_stop_worker` if never)
        self._unmapped_fds = [fd]
        # the worker imports this very module (the directory that holds its top-level package comes first on its
        # path): found through sys.modules, so that this module imports nothing outside its own package
        package_root = os.path.dirname(os.path.dirname(os.path.abspath(sys.modules[__name__.split(".")[0]].__file__)))
        here, there = socket.socketpair()
        code = (f"import sys; sys.path.insert(0, {package_root!r}); "
                f"from {__name__} import _serve_half; "
                f"_serve_half({there.fileno()}, {fd})")
        try:
            process = subprocess.Popen([sys.executable, "-c", code], pass_fds=(there.fileno(), fd),
                                       stdin=subprocess.DEVNULL)
        except BaseException:
            os.close(fd)
            raise
        finally:
            there.close()
        self.connection = Connection(here.detach())
        self.process = process
        self._send_error: BaseException | None = None
        self._ready = False
        #: the thread that sends the set-up (one, once :meth:`set_up` ran)
        self._senders: list[threading.Thread] = []
        self._finalizer = weakref.finalize(self, _stop_worker, self.connection, process, self._senders,
                                           self._unmapped_fds)

    @property
    def unmapped_fds(self) -> tuple[int, ...]:
        """The file descriptors of the shared memory still open and not yet mapped: its file until :meth:`set_up`
        maps and closes it (closed when the worker stops if it never was)."""
        return tuple(self._unmapped_fds)

    def set_up(self, chol: SupernodalCholesky) -> None:
        """Split ``chol``'s supernodes into two subtree halves and their top, size the shared memory and send the
        worker the symbolic analysis (pickled and sent by a thread: this process factorises meanwhile)."""
        import mmap
        import pickle

        self.chol = chol
        (mine, theirs), top = chol.subtree_halves()
        self.mine, self.theirs, self.top = mine.tolist(), theirs.tolist(), top.tolist()

        def own_rows(supernodes: list[int]) -> np.ndarray:
            return np.concatenate([np.arange(chol.first[s], chol.end[s]) for s in supernodes] + [np.zeros(0, np.int64)])

        self.their_rows, self.top_rows = own_rows(self.theirs), own_rows(self.top)
        in_top = set(self.top)
        parent = chol.supernode_parents()
        self.their_roots = [s for s in self.theirs if int(parent[s]) in in_top]
        sizes = [int(chol.rows[s].size - (chol.end[s] - chol.first[s])) for s in self.their_roots]
        ends = np.cumsum([r * r for r in sizes], dtype=np.int64)
        self.root_blocks = [(int(e - r * r), int(e), r) for e, r in zip(ends, sizes)]
        layout = _shared_layout(chol._pattern.nnz, chol.n, self.top_rows.size, int(ends[-1]) if sizes else 0)
        fd = self._unmapped_fds.pop()
        os.ftruncate(fd, 8 * layout["total"])
        self._memory = mmap.mmap(fd, 8 * layout["total"])
        os.close(fd)
        self.values, self.x, self.top_change, self.root_updates = _shared_arrays(self._memory, layout)
        self.generation = 0
        setup = {"chol": chol, "theirs": self.theirs, "their_roots": self.their_roots,
                 "root_blocks": self.root_blocks, "their_rows": self.their_rows, "top_rows": self.top_rows,
                 "layout": layout}

        def send_setup() -> None:  # the worker unpickles and warms up while this process factorises
            try:
                self.connection.send_bytes(pickle.dumps(setup, protocol=5))
            except OSError as error:
                self._send_error = error

        sender = threading.Thread(target=send_setup, name="blockmpec-cholesky-setup", daemon=True)
        self._senders.append(sender)
        sender.start()

    def wait_ready(self, timeout: float = 120.0, required: bool = True) -> bool:
        """Wait at most ``timeout`` seconds for the worker to have its set-up (:meth:`ready`); whether it has.
        ``required``: a RuntimeError if it has not."""
        if self._ready:
            return True
        if not self._senders:
            if required:
                raise RuntimeError("supernodal Cholesky: its worker process was never set up")
            return False
        deadline = time.perf_counter() + timeout
        self._senders[0].join(timeout)
        if not self._senders[0].is_alive() and self._send_error is None:
            self.connection.poll(max(deadline - time.perf_counter(), 0.0))
        ready = self.ready()
        if required and not ready:
            raise RuntimeError(f"supernodal Cholesky: its worker process was not ready within {timeout:g} s")
        return ready

    def ready(self) -> bool:
        """Whether the worker has its set-up (never waits).  A worker that ended before it was ready is an error."""
        if not self._ready:
            if not self._senders or self._senders[0].is_alive():
                if self.process.poll() is not None:
                    self.close()
                    raise RuntimeError("supernodal Cholesky: its worker process did not start (its error is "
                                       "printed above)")
                return False
            if self._send_error is None and self.connection.poll(0):
                self._ready = self._answer() == "ready"
            if not self._ready and (self._send_error is not None or self.process.poll() is not None):
                self.close()
                raise RuntimeError("supernodal Cholesky: its worker process did not start (its error is printed "
                                   "above)")
        return self._ready

    def close(self) -> None:
        """Stop the worker process."""
        self._finalizer()

    def _send(self, command: str) -> None:
        try:
            self.connection.send(command)
        except OSError:
            raise RuntimeError("supernodal Cholesky: its worker process ended unexpectedly") from None

    def _answer(self):
        try:
            return self.connection.recv()
        except (EOFError, OSError):
            raise RuntimeError("supernodal Cholesky: its worker process ended unexpectedly") from None

    def serial_factorise(self, values: np.ndarray, diagonal_blocks: list, below_blocks: list) -> bool:
        """Factorise ``K`` in this process alone, half 0, half 1, then the top: the serial factors bit for bit (the
        same calls on the same fronts), made while the worker starts.  It also readies this process's workspace of
        half 0 and the top; half 1's is dropped once the worker factorises (:meth:`factorise`)."""
        chol, updates = self.chol, {}
        return (chol.factor_supernodes(self.mine, values, updates, diagonal_blocks, below_blocks)
                and chol.factor_supernodes(self.theirs, values, updates, diagonal_blocks, below_blocks)
                and chol.factor_supernodes(self.top, values, updates, diagonal_blocks, below_blocks))

    def factorise(self, values: np.ndarray, diagonal_blocks: list, below_blocks: list) -> bool:
        """Factorise ``K`` (values on the pattern) with the worker; this process keeps half 0's and the top's blocks."""
        chol = self.chol
        chol.drop_factor_plan(self.theirs)  # made by serial_factorise, if it ran: the worker holds that half now
        self.values[:] = values
        self._send("factorise")
        updates: dict[int, np.ndarray] = {}
        mine_factorised = chol.factor_supernodes(self.mine, values, updates, diagonal_blocks, below_blocks)
        theirs_factorised, chol.worker_cpu_s = self._answer()  # always collected: both processes stay in step
        self.generation += 1
        if not (mine_factorised and theirs_factorised):
            return False
        for s, (a, b, r) in zip(self.their_roots, self.root_blocks):
            updates[s] = np.array(self.root_updates[a:b].reshape(r, r, order="F"), order="F")
        return chol.factor_supernodes(self.top, values, updates, diagonal_blocks, below_blocks)

    def solver(self, diagonal_blocks: list, below_blocks: list):
        """``solve(rhs)`` with the factors of the latest :meth:`factorise` (a vector or a matrix of columns)."""
        chol, generation = self.chol, self.generation
        p, inv_p = chol.perm, chol.inverse_perm
        panels = chol.solve_panels(diagonal_blocks, below_blocks)
        mine, top = self.mine, self.top
        mine_backwards, top_backwards = mine[::-1], top[::-1]

        def solve_vector(rhs: np.ndarray) -> np.ndarray:
            x = np.array(rhs[p], dtype=float)
            self.x[:] = x
            self._send("forward")
            chol.forward(x, mine, diagonal_blocks, below_blocks, panels)
            self._answer()
            x[self.their_rows] = self.x[self.their_rows]
            x[self.top_rows] += self.top_change
            chol.forward(x, top, diagonal_blocks, below_blocks, panels)
            chol.backward(x, top_backwards, diagonal_blocks, below_blocks, panels)
            self.x[self.top_rows] = x[self.top_rows]
            self._send("backward")
            chol.backward(x, mine_backwards, diagonal_blocks, below_blocks, panels)
            self._answer()
            x[self.their_rows] = self.x[self.their_rows]
            return x[inv_p]

        def current() -> None:
            if generation != self.generation:
                raise RuntimeError("supernodal Cholesky: these factors were replaced by a later factorisation")

        return _counted_solve(chol, solve_vector, current, single_thread=True)

    def serial_solver(self, diagonal_blocks: list, below_blocks: list):
        """``solve(rhs)`` in this process alone, with the numbers of :meth:`solver` bit for bit: the same substitutions
        on the two halves and the top, the worker's half's change to the top's rows summed apart and added as the
        worker's is, a matrix one column at a time.  For the factorisations made here while the worker starts
        (:meth:`SupernodalCholesky.factorise_values`), so that a run's iterates do not depend on when it became
        ready (with the serial solve they differed in round-off, and the iteration counts of one LP varied)."""
        chol = self.chol
        p, inv_p = chol.perm, chol.inverse_perm
        panels = chol.solve_panels(diagonal_blocks, below_blocks)
        mine, theirs, top = self.mine, self.theirs, self.top
        mine_backwards, theirs_backwards, top_backwards = mine[::-1], theirs[::-1], top[::-1]
        their_rows, top_rows = self.their_rows, self.top_rows

        def solve_vector(rhs: np.ndarray) -> np.ndarray:
            x = np.array(rhs[p], dtype=float)
            theirs_x = x.copy()  # what the worker reads from the shared vector
            top_before = theirs_x[top_rows]
            chol.forward(theirs_x, theirs, diagonal_blocks, below_blocks, panels)
            top_change = theirs_x[top_rows] - top_before
            chol.forward(x, mine, diagonal_blocks, below_blocks, panels)
            x[their_rows] = theirs_x[their_rows]
            x[top_rows] += top_change
            chol.forward(x, top, diagonal_blocks, below_blocks, panels)
            chol.backward(x, top_backwards, diagonal_blocks, below_blocks, panels)
            theirs_x = x.copy()
            chol.backward(theirs_x, theirs_backwards, diagonal_blocks, below_blocks, panels)
            chol.backward(x, mine_backwards, diagonal_blocks, below_blocks, panels)
            x[their_rows] = theirs_x[their_rows]
            return x[inv_p]

        return _counted_solve(chol, solve_vector, single_thread=True)


def _counted_solve(chol: SupernodalCholesky, solve_vector, check=None, single_thread: bool = False):
    """``solve(rhs)`` for a vector or a matrix of columns (one :func:`solve_vector` each), counted in ``chol``'s
    solves and their CPU time; ``check()`` first, if given (it raises when the factors are no longer valid).
    ``single_thread``: BLAS on one thread meanwhile, as in the worker process (the two-process solves, whose numbers
    must not depend on the caller's BLAS threads)."""

    def solve(rhs: np.ndarray) -> np.ndarray:
        if check is not None:
            check()
        t = time.process_time()
        rhs = np.asarray(rhs, dtype=float)
        with _blas_controller().limit(limits=1) if single_thread else contextlib.nullcontext():
            x = solve_vector(rhs) if rhs.ndim == 1 else np.column_stack(
                [solve_vector(rhs[:, j]) for j in range(rhs.shape[1])] + [np.zeros((chol.n, 0))])
        chol.solves += 1
        chol.solve_s += time.process_time() - t
        return x

    return solve


def _shared_layout(values: int, n: int, top_rows: int, root_updates: int) -> dict:
    """Offsets (in float64s) of a :class:`HalfWorker`'s shared arrays in its shared-memory file."""
    sizes = {"values": values, "x": n, "top_change": top_rows, "root_updates": root_updates}
    layout, offset = {}, 0
    for name, size in sizes.items():
        layout[name] = (offset, size)
        offset += size
    layout["total"] = max(offset, 1)
    return layout


def _shared_arrays(memory, layout: dict) -> list[np.ndarray]:
    """``values, x, top_change, root_updates``: float64 views of the shared-memory file."""
    return [np.frombuffer(memory, dtype=np.float64, count=size, offset=8 * offset)
            for offset, size in (layout[name] for name in ("values", "x", "top_change", "root_updates"))]


def _shared_file(size: int) -> int:
    """A file descriptor of ``size`` zero bytes that no path names, to be mapped by this process and the worker:
    ``memfd_create`` (Linux) or an unlinked temporary file (in ``/dev/shm`` when it exists)."""
    if hasattr(os, "memfd_create"):
        fd = os.memfd_create("blockmpec-cholesky")
    else:  # pragma: no cover - not Linux
        import tempfile

        fd = os.dup(tempfile.TemporaryFile(dir="/dev/shm" if os.path.isdir("/dev/shm") else None).fileno())
    os.ftruncate(fd, size)
    return fd


def _serve_half(socket_fd: int, memory_fd: int) -> None:  # pragma: no cover - runs in the worker process
    """The worker process of :class:`HalfWorker`: factorises and solves with its half until told to stop."""
    import mmap
    import pickle
    from multiprocessing.connection import Connection

    from threadpoolctl import threadpool_limits

    connection = Connection(socket_fd)
    if compiled_kernels_available():  # the compiled kernels loaded while the set-up is made and sent
        from . import cholesky_kernels  # noqa: F401
    try:
        setup = pickle.loads(connection.recv_bytes())
    except (EOFError, OSError):
        return
    if setup is None:  # stopped before its set-up
        return
    chol, theirs = setup["chol"], setup["theirs"]
    their_rows, top_rows, their_roots, root_blocks = (setup[k] for k in ("their_rows", "top_rows", "their_roots",
                                                                         "root_blocks"))
    memory = mmap.mmap(memory_fd, 8 * setup["layout"]["total"])
    os.close(memory_fd)
    values, shared_x, top_change, root_updates = _shared_arrays(memory, setup["layout"])
    backwards = theirs[::-1]
    with threadpool_limits(limits=1, user_api="blas"):
        # warm-up while this process's owner factorises alone: the half's plan, its factor array's first touch and the
        # compiled loops' first calls (loaded from numba's cache), on K = I (no answer depends on it)
        identity = chol.identity_values()
        diagonal_blocks, below_blocks = [None] * chol.supernodes, [None] * chol.supernodes
        if chol.factor_supernodes(theirs, identity, {}, diagonal_blocks, below_blocks):
            panels = chol.solve_panels(diagonal_blocks, below_blocks)
            x = np.zeros(chol.n)
            chol.forward(x, theirs, diagonal_blocks, below_blocks, panels)
            chol.backward(x, backwards, diagonal_blocks, below_blocks, panels)
        del identity
        diagonal_blocks, below_blocks, panels = [], [], None
        try:
            connection.send("ready")
        except OSError:  # closed during the warm-up: nothing left to do
            return
        while True:
            try:
                command = connection.recv()
            except (EOFError, OSError):
                return
            if command is None:
                return
            if command == "factorise":
                # the earlier factors dropped first (the compiled factorisation then reuses their array), never used
                panels = None
                diagonal_blocks, below_blocks = [None] * chol.supernodes, [None] * chol.supernodes
                updates: dict[int, np.ndarray] = {}
                factorised = chol.factor_supernodes(theirs, values, updates, diagonal_blocks, below_blocks)
                if factorised:
                    for s, (a, b, _) in zip(their_roots, root_blocks):
                        root_updates[a:b] = updates.pop(s).ravel(order="F")
                    panels = chol.solve_panels(diagonal_blocks, below_blocks)
                connection.send((factorised, time.process_time()))
            elif command == "forward":
                x = np.array(shared_x)
                top_before = x[top_rows]
                chol.forward(x, theirs, diagonal_blocks, below_blocks, panels)
                shared_x[their_rows] = x[their_rows]
                top_change[:] = x[top_rows] - top_before
                connection.send(True)
            elif command == "backward":
                x = np.array(shared_x)
                chol.backward(x, backwards, diagonal_blocks, below_blocks, panels)
                shared_x[their_rows] = x[their_rows]
                connection.send(True)


def _stop_worker(connection, process, senders: list, unmapped_fds: list) -> None:
    """Ask a :class:`HalfWorker`'s process to stop and reap it; kill it if it has not ended within a second
    (or if its set-up is still being sent a second later).  Closes the shared memory's file if it was never set up."""
    import subprocess

    while unmapped_fds:
        os.close(unmapped_fds.pop())
    for sender in senders:
        sender.join(timeout=1.0)
    if any(sender.is_alive() for sender in senders):  # the worker does not read its set-up: a message would interleave
        process.kill()
        for sender in senders:
            sender.join()
    else:
        try:
            connection.send(None)
        except (OSError, ValueError):
            pass
    connection.close()
    try:
        process.wait(timeout=1.0)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


def _dense_front(F: np.ndarray, width: int, dpotrf, dtrsm, dsyrk):
    """``(L11, L21, F22 - L21 L21^T)`` of a front whose first ``width`` columns are eliminated
    (``L21``, the update: None when the front has no rows below); ``L11`` None if a pivot is not positive."""
    L11, info = dpotrf(F[:width, :width], lower=1, clean=1)
    if info:
        return None, None, None
    if F.shape[0] == width:
        return L11, None, None
    L21 = dtrsm(1.0, L11, F[width:, :width], side=1, lower=1, trans_a=1)
    # the update matrix F22 - L21 L21^T (lower triangle; syrk on a Fortran copy, in place)
    update = dsyrk(-1.0, L21, beta=1.0, c=np.array(F[width:, width:], order="F"), lower=1, overwrite_c=1)
    return L11, L21, update


_BLAS_CONTROLLER = None


def _blas_controller():
    """threadpoolctl's controller of the loaded BLAS libraries (made once: its introspection takes ms)."""
    global _BLAS_CONTROLLER
    if _BLAS_CONTROLLER is None:
        from threadpoolctl import ThreadpoolController

        _BLAS_CONTROLLER = ThreadpoolController().select(user_api="blas")
    return _BLAS_CONTROLLER

r"""Repeated sparse factorisations of one symmetric positive definite pattern (the block IPM's ``K``).

``K = A_B H^{-1} A_B^T + 1e-12 diag(K)`` changes its values at every interior-point
iteration but never its *structural* pattern: entry ``(i, j)`` can be nonzero only if
rows ``i`` and ``j`` of ``A_B`` share a block of ``H^{-1}``, i.e. ``pattern(K) =
pattern(|A_B| E |A_B|^T)`` with ``E`` the block-diagonal matrix of ones.  The fill-reducing
ordering is computed once from that pattern, never from one numerical ``K``: at the
IPM's starting point many entries of ``H^{-1}`` are exact zeros that scipy drops, and
an ordering of that sparser matrix gave 17x more fill on later ones (1,000 blocks).

``K`` is symmetric positive definite (``H^{-1}`` is, and ``A_B`` has full row rank on
a structure whose every free block has an interface), so it needs no pivoting: after a
symmetric permutation ``P K P^T`` it is factorised by SuperLU with the natural column
order, symmetric mode and diagonal pivots only (``diag_pivot_thresh = 0``), i.e. an
``L D L^T`` in LU form.  Orderings (:data:`ORDERINGS`):

* ``"metis"``: METIS nested dissection (``pymetis``, MIT/Apache-2.0), the ordering
  of choice for the 2D mesh pattern of a wall;
* ``"mmd"``: SuperLU's minimum degree on ``K`` (``MMD_AT_PLUS_A``), pure scipy, the
  fallback when pymetis is not installed;
* ``"auto"``: ``"metis"`` if importable, else ``"mmd"``.

Measured on one mid-iteration ``K`` of a wall (``studies/cholesky_choice.py``): 10,046
blocks (30,150 rows): METIS 5.0M nonzeros in ``L+U`` against MMD's 5.8M; 100,016 blocks
(300,042 rows): METIS 71M nonzeros, 7-13 s per factorisation, against MMD's 101M and
18-35 s.  CHOLMOD (``sksparse-minimal``/``cholespy`` wheels; their bundled Supernodal
module is GPL) took 19 s and ``qdldl`` (Apache-2.0, AMD) 29 s on the same 100k matrix.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

ORDERINGS = ("auto", "metis", "mmd")


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


class SymmetricFactoriser:
    """Factorise matrices with one fixed symmetric positive definite pattern, ordering computed once.

    Parameters
    ----------
    pattern : sparse matrix
        The structural pattern (every entry any factorised matrix may hold), e.g.
        :func:`structural_pattern`.
    ordering : str
        One of :data:`ORDERINGS`.
    """

    def __init__(self, pattern: sp.sparray, ordering: str = "auto") -> None:
        self.ordering = ("metis" if metis_available() else "mmd") if ordering == "auto" else ordering
        self.perm = fill_reducing_ordering(pattern, self.ordering)
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
        t0 = time.perf_counter()
        lu = spla.splu(sp.csc_matrix(K)[p][:, p], permc_spec="NATURAL", diag_pivot_thresh=0.0,
                       options={"SymmetricMode": True})
        self.factor_nnz = int(lu.nnz)
        self.factorisations += 1
        self.factorise_s += time.perf_counter() - t0

        def solve(rhs: np.ndarray) -> np.ndarray:
            t = time.perf_counter()
            x = lu.solve(rhs[p])[inv_p]
            self.solves += 1
            self.solve_s += time.perf_counter() - t
            return x

        return solve

r"""The reduced Newton system of the block interior-point method (:mod:`blockmpec.solvers.linalg.block_ipm`).

Eliminating the slacks and the interface blocks' own variables from the Newton system of the LP leaves, for the
border columns (``lam``, the multipliers of the equality rows), the reduced matrix

.. math:: K = A_B\, H^{-1} A_B^T,

where ``H`` is block diagonal (one small dense block per interface: its columns' ``G_i^T D_i G_i`` plus a shift) and
``A_B`` the equality rows restricted to the block columns.  :class:`ReducedSystem` holds what builds and solves it:
the per-block dense rows, the block inverses (numpy or the compiled kernels of
:mod:`~blockmpec.solvers.linalg.block_kernels`), the scatter of ``a_i H_i^{-1} a_i^T`` into ``K``'s fixed pattern,
its factorisation (SuperLU or the supernodal Cholesky of :mod:`~blockmpec.solvers.linalg.cholesky`, chosen by
size), and the block back-substitutions.  It is a part of :class:`~blockmpec.solvers.linalg.block_ipm.BlockIPM`,
whose state (``A_B``, ``block_rows``, settings, rules) it reads.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from .cholesky import SupernodalCholesky, SymmetricFactoriser

if TYPE_CHECKING:
    from .block_ipm import IPMIterate

#: factorisations of K: ``"auto"`` (the supernodal Cholesky for a symmetric K of at least
#: ``rules.supernodal_rows`` (:class:`~blockmpec.solvers.linalg.block_ipm.AutoRules`) rows, SuperLU otherwise),
#: ``"supernodal"``, ``"superlu"`` (:mod:`blockmpec.solvers.linalg.cholesky`)
FACTORISATIONS = ("auto", "supernodal", "superlu")

#: smallest s/y in the block systems (a primal regularisation of fully active blocks)
SLACK_RATIO_FLOOR = 1e-14


class ReducedSystem:
    """The reduced system ``K = A_B H^{-1} A_B^T`` of :class:`~blockmpec.solvers.linalg.block_ipm.BlockIPM` (see the
    module docstring): blocks, assembly, factorisation and solves."""

    def dense_blocks(self, G: sp.sparray) -> np.ndarray:
        """The rows of an inequality matrix ``G`` (this LP's pattern) as dense per-block arrays,
        shape ``(n_blocks, rows_per_block, k)``."""
        G = sp.coo_array(G)
        g = np.zeros((G.shape[0], self.k))
        np.add.at(g, (G.row, self._local_of[G.col]), G.data)
        return g[self.block_rows]

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
        if kernels is not None and type(self).block_systems is ReducedSystem.block_systems:
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

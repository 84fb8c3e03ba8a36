r"""The triangular solves of the supernodal Cholesky (:mod:`blockmpec.solvers.linalg.cholesky`).

With ``P K P^T = L~ L~^T`` (``L~`` unit-free lower triangular, stored by supernodes: a dense lower-triangular
diagonal block of each supernode's columns and a dense block of its rows below), ``K x = rhs`` is
``x = P^T L~^{-T} L~^{-1} P rhs``: the forward substitution visits the supernodes in increasing order (``trsv`` on a
supernode's entries, ``gemv`` for the rows below), the backward one in decreasing order (``gemv`` with the
transposed block, then ``trsv``); a matrix of right-hand sides takes ``trsm`` and ``gemm``.  With the compiled
solves (:mod:`~blockmpec.solvers.linalg.cholesky_kernels`) one compiled loop does either pass.
:class:`SupernodalSolves` is a part of :class:`~blockmpec.solvers.linalg.cholesky.SupernodalCholesky`, whose
supernodal structure it reads.
"""

from __future__ import annotations

import time

import numpy as np


class SupernodalSolves:
    """Forward and backward substitution by supernodes (see the module docstring)."""

    def solve_structure(self) -> tuple:
        """``(first, width, below_count, below, below_start)``: each supernode's first column, its columns, its rows
        below them (all int64, by supernode) and those rows, concatenated (``below[below_start[s]:][:below_count[s]]``);
        what :class:`~blockmpec.solvers.linalg.cholesky_kernels.SolvePanels` reads.  Made once."""
        if self._solve_structure is None:
            counts = np.array([b.size for b in self.below_rows], dtype=np.int64)
            self._solve_structure = (self.first.astype(np.int64), (self.end - self.first).astype(np.int64), counts,
                                     np.concatenate([*self.below_rows, np.zeros(0)]).astype(np.int64),
                                     np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64))
        return self._solve_structure

    def solve_panels(self, diagonal_blocks: list, below_blocks: list):
        """The factors of one factorisation for the compiled solves (:attr:`compiled_solves`), else None."""
        if not self.compiled_solves:
            return None
        from .cholesky_kernels import SolvePanels

        return SolvePanels(self.solve_structure(), diagonal_blocks, below_blocks)

    def forward(self, x: np.ndarray, supernodes, diagonal_blocks: list, below_blocks: list, panels=None) -> None:
        """``L~ y = x`` over the given supernodes (in increasing order), in place on the vector ``x``: ``trsv`` on each
        supernode's entries (BLAS offsets), ``gemv`` for the rows below; by the compiled loop with ``panels``
        (:meth:`solve_panels`)."""
        if panels is not None:
            panels.forward(x, supernodes)
            return
        from scipy.linalg.blas import dgemv, dtrsv

        first, below = self._first_columns, self.below_rows
        for s in supernodes:
            f = first[s]
            dtrsv(diagonal_blocks[s], x, offx=f, lower=1, overwrite_x=1)
            L21 = below_blocks[s]
            if L21 is not None:
                x[below[s]] -= dgemv(1.0, L21, x, offx=f)

    def backward(self, x: np.ndarray, supernodes, diagonal_blocks: list, below_blocks: list, panels=None) -> None:
        """``L~^T z = x`` over the given supernodes (in decreasing order), in place on the vector ``x`` (compiled with
        ``panels``)."""
        if panels is not None:
            panels.backward(x, supernodes)
            return
        from scipy.linalg.blas import dgemv, dtrsv

        first, below = self._first_columns, self.below_rows
        for s in supernodes:
            f = first[s]
            L21 = below_blocks[s]
            if L21 is not None:
                dgemv(-1.0, L21, x[below[s]], beta=1.0, y=x, offy=f, trans=1, overwrite_y=1)
            dtrsv(diagonal_blocks[s], x, offx=f, lower=1, trans=1, overwrite_x=1)

    def solver(self, diagonal_blocks: list[np.ndarray], below_blocks: list[np.ndarray | None]):
        """``solve(rhs)`` with the factors ``diagonal_blocks``, ``below_blocks`` of :meth:`factor_supernodes` (what
        :meth:`factorise` returns): ``x = P^T L~^{-T} L~^{-1} P rhs`` by supernodes (BLAS ``trsv``/``trsm``,
        ``gemv``/``gemm``); a vector or a matrix of columns."""
        from scipy.linalg.blas import dtrsm

        p, inv_p = self.perm, self.inverse_perm
        spans = list(zip(self.first.tolist(), self.end.tolist()))
        below = self.below_rows
        panels = self.solve_panels(diagonal_blocks, below_blocks)
        order = range(self.supernodes)

        def solve(rhs: np.ndarray) -> np.ndarray:
            t = time.process_time()
            x = np.array(rhs[p], dtype=float, order="F")
            if x.ndim == 1:
                self.forward(x, order, diagonal_blocks, below_blocks, panels)
                self.backward(x, order[::-1], diagonal_blocks, below_blocks, panels)
            else:
                for s in order:
                    f, e = spans[s]
                    xs = dtrsm(1.0, diagonal_blocks[s], x[f:e], lower=1)
                    x[f:e] = xs
                    L21 = below_blocks[s]
                    if L21 is not None:
                        x[below[s]] -= L21 @ xs
                for s in reversed(order):
                    f, e = spans[s]
                    L21 = below_blocks[s]
                    xs = x[f:e] if L21 is None else x[f:e] - L21.T @ x[below[s]]
                    x[f:e] = dtrsm(1.0, diagonal_blocks[s], xs, lower=1, trans_a=1)
            self.solves += 1
            self.solve_s += time.process_time() - t
            return x[inv_p]

        return solve

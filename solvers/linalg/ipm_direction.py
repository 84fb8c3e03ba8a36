r"""The Newton direction of the block interior-point method (:mod:`blockmpec.solvers.linalg.block_ipm`) and what
measures an iterate.

For the LP in the block IPM's standard form (equalities ``A v = b``, inequalities ``G v + s = h``, ``s, y >= 0``)
a Newton direction solves the linearised optimality conditions with the complementarity target ``r_mu``
(``sigma mu`` for Mehrotra's corrector, the centrality corrections of Gondzio's for the others): eliminating ``ds``
and ``dy`` gives the block-diagonal ``H`` and the reduced system ``K dw = rhs``
(:class:`~blockmpec.solvers.linalg.reduced_system.ReducedSystem`), whose solution is refined (stationary iterative
refinement, then GMRES on ``K`` when it stalls) until the equality rows hold to the inner tolerance.
:class:`NewtonDirection` holds the direction, its refinement, the longest step that keeps ``s, y > 0``, and the
relative residuals, measures and gap that the iteration's stopping tests read.  It is a part of
:class:`~blockmpec.solvers.linalg.block_ipm.BlockIPM`, whose state it reads.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .block_ipm import IPMIterate


def largest_magnitude(a: np.ndarray) -> float:
    """``max |a_i|`` (0 for an empty array)."""
    return float(np.max(np.abs(a))) if a.size else 0.0


class NewtonDirection:
    """The Newton direction, the step and the measures of an iterate of
    :class:`~blockmpec.solvers.linalg.block_ipm.BlockIPM` (see the module docstring)."""

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
        target = 1e-1 * self.tol * (1 + largest_magnitude(self.b))
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
                limit = max(target, tolerance * largest_magnitude(bound_B + self._abs_A_F @ np.abs(dv_F)))
            error = max(largest_magnitude(e_eq), largest_magnitude(e_border))
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
            new_error = max(largest_magnitude(new_e_eq), largest_magnitude(new_e_border))
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
                e_h_inf, e_mu_inf = largest_magnitude(e_h), largest_magnitude(e_mu)
            e_c = -r_c + self._transpose_times(self.A, dw) - self._transpose_times(self.G_dual, dy)
            if (largest_magnitude(e_b) <= scale * (1 + largest_magnitude(self.b)) and largest_magnitude(e_c) <= scale * (1 + largest_magnitude(self.c))
                    and e_h_inf <= scale * (1 + largest_magnitude(self.h)) and e_mu_inf <= scale * max(largest_magnitude(r_mu), 1e-300)):
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
        primal = max(largest_magnitude(r_b) / (1 + largest_magnitude(self.b)), largest_magnitude(r_h) / (1 + largest_magnitude(self.h)))
        dual = largest_magnitude(r_c) / (1 + largest_magnitude(self.c))
        return primal, dual, self.gap(it)

    def gap(self, it: IPMIterate) -> float:
        """The relative duality gap ``|c^T v - (b^T w - h^T y)| / (1 + |c^T v|)``."""
        pobj = self.c @ it.v
        dobj = self.b @ it.w - self.h @ it.y
        return abs(pobj - dobj) / (1 + abs(pobj))

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

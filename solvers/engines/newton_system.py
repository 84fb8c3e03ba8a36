r"""Shared pieces of the non-associative solvers ``nlp`` and ``mcp-newton``.

Both state problem (3) directly from the assembled operators (no Pyomo model)::

    E x + f_d + lam f_l = 0                      (3b equilibrium, 3b rows)
    E^T u + N_u z_u + V_f z_f = 0                (3c compatibility, 3c rows)
    f_l^T u = 1                                  (normalisation, 1 row)
    0 <= s_u = -N_u^T x  ⟂  z_u >= 0             (2c pairs)
    0 <= s_f = -N_f^T x  ⟂  z_f >= 0             (2c pairs)

with ``c`` interfaces and ``b`` free blocks.  This module provides the associative
starting point (the static LP (1) solved by HiGHS with its duals as mechanism) and
a small helper for the stacked complementarity data.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from blockmpec.operators import Operators
from blockmpec.result import Solution, Status


def constraint_operator(ops: Operators) -> sp.csr_array:
    """``N = [N_u, N_f]`` (3c x 4c): the slacks of all pairs are ``s = -N^T x``."""
    return sp.hstack([ops.N_u, ops.N_f], format="csr")


def flow_operator(ops: Operators) -> sp.csr_array:
    """``[N_u, V_f]`` (3c x 4c): compatibility reads ``E^T u + [N_u, V_f] z = 0``."""
    return sp.hstack([ops.N_u, ops.V_f], format="csr")


# --------------------------------------------------------------------------- semismooth Newton


def fischer_burmeister(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""``phi(a, b) = a + b - sqrt(a^2 + b^2)`` and an element of its generalised gradient.

    ``phi(a, b) = 0`` iff ``a >= 0, b >= 0, a b = 0``.  Where ``(a, b) != 0`` the
    gradient is ``(1 - a/r, 1 - b/r)``, ``r = sqrt(a^2 + b^2)``; at ``a = b = 0`` the
    element ``(1 - 1/sqrt(2), 1 - 1/sqrt(2))`` of the Clarke generalised gradient
    (``(1 - xi, 1 - rho)`` with ``xi^2 + rho^2 <= 1``) is used.

    Returns
    -------
    phi, dphi_da, dphi_db : ndarray
    """
    r = np.hypot(a, b)
    phi = a + b - r
    zero = r <= 1e-300
    r_safe = np.where(zero, 1.0, r)
    da = np.where(zero, 1.0 - np.sqrt(0.5), 1.0 - a / r_safe)
    db = np.where(zero, 1.0 - np.sqrt(0.5), 1.0 - b / r_safe)
    # 1 - a/r is round-off when b/a is below machine precision: drop it (keeps the factorisation clean)
    da[np.abs(da) < 1e-14] = 0.0
    db[np.abs(db) < 1e-14] = 0.0
    return phi, da, db


@dataclass
class NewtonOutcome:
    """Result of :func:`semismooth_newton`.

    Attributes
    ----------
    status : Status
        ``CONVERGED``, ``ITERATION_LIMIT``, ``TIME_LIMIT`` or ``NUMERICAL``.
    solution : Solution
        The last iterate.
    iterations : int
    trace : list of dict
        Per iteration: merit, residual (inf-norm of the scaled ``Phi``), step length, direction kind, time_s
        (elapsed since the call started).
    message : str
    """

    status: Status
    solution: Solution
    iterations: int
    trace: list
    message: str


def with_dilatancy(ops: Operators, dilatancy: np.ndarray) -> Operators:
    """``ops`` with the friction flow operator ``V_f`` built from another ``tan(psi)`` per interface."""
    import dataclasses

    coef = np.broadcast_to(np.asarray(dilatancy, float), ops.friction.shape).copy()
    return dataclasses.replace(ops, V_f=ops.friction_operator(coef), dilatancy=coef)


class MCPSystem:
    r"""The MCP (3) as a square semismooth system ``Phi(w) = 0`` with Fischer–Burmeister pairs.

    Unknowns ``w = (lam, x, u, z)``, ``z = (z_u, z_f)``, i.e. ``1 + 3c + 3b + 4c`` values;
    equations (same count)::

        Phi = [ (E x + f_d + lam f_l) / r_eq             (3b)
                (E^T u + N_u z_u + V_f z_f) / r_comp     (3c)
                f_l^T u - 1                              (1)
                phi(z / z_scale, s / s_scale) ]          (4c),  s = -[N_u, N_f]^T x

    The row scales ``r_eq, r_comp`` and the pair scales ``z_scale, s_scale`` are
    typical magnitudes (from the starting point), so ``||Phi||`` is scale-free.  The
    Newton iteration works in scaled unknowns ``w = D w_hat`` with
    ``D = diag(1, x_scale, u_scale, z_scale)``.
    """

    def __init__(self, ops: Operators, start: Solution) -> None:
        self.ops = ops
        b3, c3 = ops.E.shape
        self.N = constraint_operator(ops)
        self.F = flow_operator(ops)
        p = self.N.shape[1]
        o = np.cumsum([0, 1, c3, b3, p])
        self.i_lam, self.i_x, self.i_u, self.i_z = (slice(o[k], o[k + 1]) for k in range(4))
        self.n = int(o[-1])
        self.n_pairs = p

        def typical(v: np.ndarray) -> float:
            m = float(np.max(np.abs(v))) if v.size else 0.0
            return m if m > 0 and np.isfinite(m) else 1.0

        z0 = np.concatenate([start.z_u, start.z_f])
        s0 = -(self.N.T @ start.x)
        self.x_scale = typical(start.x)
        self.u_scale = typical(start.u)
        self.z_scale = typical(z0)
        self.s_scale = typical(s0)
        self.r_eq = max(typical(ops.f_d), abs(start.multiplier or 0.0) * typical(ops.f_l), 1e-300)
        self.r_comp = max(typical(ops.E.T @ start.u), typical(self.F @ z0))
        self.col_scale = np.concatenate([[1.0], np.full(c3, self.x_scale), np.full(b3, self.u_scale),
                                         np.full(p, self.z_scale)])
        self.row_scale = np.concatenate([np.full(b3, 1.0 / self.r_eq), np.full(c3, 1.0 / self.r_comp), [1.0],
                                         np.ones(p)])
        Z = None
        fl = sp.csr_array(ops.f_l.reshape(-1, 1))
        # constant part of the (unscaled) Jacobian of the first 3b + 3c + 1 rows
        self._J_lin = sp.bmat([[fl, ops.E, Z, Z], [Z, Z, ops.E.T, self.F],
                               [Z, Z, sp.csr_array(ops.f_l.reshape(1, -1)), Z]], format="csr")
        self._NT = self.N.T.tocsr()

    def pack(self, sol: Solution) -> np.ndarray:
        """Scaled unknowns ``w_hat`` of a solution."""
        w = np.concatenate([[sol.multiplier], sol.x, sol.u, sol.z_u, sol.z_f])
        return w / self.col_scale

    def unpack(self, w_hat: np.ndarray) -> Solution:
        """The solution at scaled unknowns ``w_hat``."""
        w = w_hat * self.col_scale
        z = w[self.i_z]
        h = self.n_pairs // 2
        return Solution(multiplier=float(w[0]), x=w[self.i_x].copy(), u=w[self.i_u].copy(),
                        z_u=z[:h].copy(), z_f=z[h:].copy())

    def residual(self, w_hat: np.ndarray, jacobian: bool = False):
        """``Phi(w_hat)`` (scaled) and, if asked, an element of its generalised Jacobian (CSC)."""
        ops = self.ops
        w = w_hat * self.col_scale
        lam, x, u, z = w[0], w[self.i_x], w[self.i_u], w[self.i_z]
        s = -(self._NT @ x)
        a, b = z / self.z_scale, s / self.s_scale
        phi, da, db = fischer_burmeister(a, b)
        lin = np.concatenate([ops.E @ x + ops.f_d + lam * ops.f_l, ops.E.T @ u + self.F @ z, [ops.f_l @ u - 1.0]])
        Phi = np.concatenate([lin, phi]) * self.row_scale
        if not jacobian:
            return Phi
        p = self.n_pairs
        # d phi / dx = db / s_scale * (-N^T);  d phi / dz = da / z_scale
        J_x = sp.diags_array(-db / self.s_scale) @ self._NT
        J_z = sp.diags_array(da / self.z_scale)
        b3, c3 = ops.E.shape
        J_fb = sp.hstack([sp.csr_array((p, 1)), J_x, sp.csr_array((p, b3)), J_z], format="csr")
        J = sp.vstack([self._J_lin, J_fb], format="csr")
        J = sp.diags_array(self.row_scale) @ J @ sp.diags_array(self.col_scale)
        return Phi, J.tocsc()


def semismooth_newton(system: MCPSystem, w0: np.ndarray, *, tol: float = 1e-10, max_iterations: int = 100,
                      sigma: float = 1e-4, backtrack: float = 0.5, max_backtracks: int = 40,
                      regularisation: float = 1.0, descent_rho: float = 1e-8, descent_power: float = 2.1,
                      newton_refinements: int = 3, time_limit: float = float("inf")) -> NewtonOutcome:
    r"""Globalised semismooth Newton method on ``Phi(w) = 0`` (De Luca–Facchinei–Kanzow style).

    At each iterate an element ``J`` of the generalised Jacobian is formed and the
    Newton direction ``J d = -Phi`` is tried, computed as ``(J^T J + delta I) d = -J^T Phi``
    with a round-off shift ``delta = 1e-12 max diag(J^T J)`` and ``newton_refinements``
    steps of iterated Tikhonov refinement (it tends to the least-norm
    least-squares step when ``J`` is singular, which it is at every solution of a
    hyperstatic structure; SuperLU factorises the positive definite matrix safely).
    If ``d`` is not a sufficient descent direction of the
    merit ``Psi = ||Phi||^2 / 2`` (``grad Psi^T d > -descent_rho ||d||^descent_power``),
    or its line search fails, the Levenberg–Marquardt direction
    ``(J^T J + nu I) d = -J^T Phi`` with ``nu = regularisation * ||Phi||`` is used
    (always a descent direction), and as a last resort the steepest descent
    ``-J^T Phi``.  The step length is Armijo's: the largest ``t = backtrack^k`` with
    ``Psi(w + t d) <= Psi(w) + sigma t grad Psi^T d``.

    Stops with ``CONVERGED`` when ``||Phi||_inf <= tol`` (``Phi`` is scaled, see
    :class:`MCPSystem`), ``ITERATION_LIMIT``, ``TIME_LIMIT``, or ``NUMERICAL`` when
    no direction yields a step (stalled line search).
    """
    from scipy.sparse.linalg import splu

    t_start = time.perf_counter()
    w = np.asarray(w0, float).copy()
    trace: list[dict] = []
    Phi, J = system.residual(w, jacobian=True)
    merit = 0.5 * float(Phi @ Phi)
    n = w.size
    ident = sp.eye_array(n, format="csc")
    for k in range(1, max_iterations + 1):
        res = float(np.max(np.abs(Phi))) if Phi.size else 0.0
        if res <= tol:
            return NewtonOutcome(Status.CONVERGED, system.unpack(w), k - 1, trace,
                                 f"converged: ||Phi||_inf = {res:.3g} <= {tol:g} after {k - 1} iterations")
        if time.perf_counter() - t_start > time_limit:
            return NewtonOutcome(Status.TIME_LIMIT, system.unpack(w), k - 1, trace,
                                 f"time limit: ||Phi||_inf = {res:.3g} after {k - 1} iterations")
        grad = J.T @ Phi

        JTJ = (J.T @ J).tocsc()
        diag_max = float(JTJ.diagonal().max()) if n else 1.0

        def regularised(nu: float, refinements: int = 0):
            # (J^T J + nu I) d = -J^T Phi: symmetric positive definite for nu > 0, so the
            # factorisation never meets a zero pivot (SuperLU on a singular J can fail badly).
            # Refinement d += (J^T J + nu I)^{-1} (-J^T Phi - J^T J d) (iterated Tikhonov) removes
            # the damping of small singular values and tends to the least-norm least-squares step.
            try:
                with np.errstate(all="ignore"):
                    lu = splu((JTJ + nu * ident).tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                              options={"SymmetricMode": True})
                    d = lu.solve(-grad)
                    for _ in range(refinements):
                        d = d + lu.solve(-grad - JTJ @ d)
            except (RuntimeError, ValueError):
                return None
            return d if np.all(np.isfinite(d)) else None

        def newton():
            # Gauss-Newton with a round-off-level shift: the Newton step J d = -Phi when J is
            # nonsingular, the least-norm least-squares step when it is not.
            d = regularised(1e-12 * max(diag_max, 1e-300), refinements=newton_refinements)
            if d is None or grad @ d > -descent_rho * np.linalg.norm(d) ** descent_power:
                return None
            return d

        def levenberg_marquardt():
            d = regularised(regularisation * np.sqrt(2.0 * merit))
            return d if d is not None and grad @ d < 0 else None

        step = None
        candidates = (("newton", newton), ("levenberg-marquardt", levenberg_marquardt), ("gradient", lambda: -grad))
        for kind, make in candidates:
            d = make()
            if d is None:
                continue
            slope = float(grad @ d)
            if not slope < 0:
                continue
            t = 1.0
            for _ in range(max_backtracks + 1):
                w_try = w + t * d
                Phi_try = system.residual(w_try)
                merit_try = 0.5 * float(Phi_try @ Phi_try)
                if np.isfinite(merit_try) and merit_try <= merit + sigma * t * slope:
                    step = (kind, t, w_try, merit_try)
                    break
                t *= backtrack
            if step is not None:
                break
        if step is None:
            return NewtonOutcome(Status.NUMERICAL, system.unpack(w), k - 1, trace,
                                 f"line search stalled at ||Phi||_inf = {res:.3g} after {k - 1} iterations")
        kind, t, w, _ = step
        Phi, J = system.residual(w, jacobian=True)
        merit = 0.5 * float(Phi @ Phi)
        trace.append({"iteration": k, "merit": merit, "residual": float(np.max(np.abs(Phi))), "step": t,
                      "direction": kind, "multiplier": float(w[0]), "time_s": time.perf_counter() - t_start})
    res = float(np.max(np.abs(Phi)))
    status = Status.CONVERGED if res <= tol else Status.ITERATION_LIMIT
    return NewtonOutcome(status, system.unpack(w), max_iterations, trace,
                         f"{'converged' if status is Status.CONVERGED else 'iteration limit'}: "
                         f"||Phi||_inf = {res:.3g} after {max_iterations} iterations")

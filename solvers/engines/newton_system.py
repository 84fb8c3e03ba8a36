r"""The MCP (3) as a semismooth Fischer–Burmeister system, and its Newton method.

Used by ``mcp-newton`` (the whole method) and ``nlp`` (its polish).  Problem (3) is
read from the compiled formulation :class:`~blockmpec.formulations.CompiledMCP`
(``A w = rhs``, pair rows ``G w <= 0`` with ``pair_column``), never from the
operators::

    A w = rhs                                          (equilibrium, compatibility, normalisation)
    0 <= s_i = -G_i w   _|_   w[pair_column[i]] >= 0   (4c pairs)

with ``w = (lam, x, u, z)``, ``c`` interfaces and ``b`` free blocks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from blockmpec.deadline import NEVER, Deadline
from blockmpec.formulations import CompiledMCP
from blockmpec.result import Solution, Status
from blockmpec.solvers.engines.stopping import StoppingCriterion

__all__ = ["MCPSystem", "NewtonOutcome", "fischer_burmeister", "semismooth_newton"]

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
        This call's records of its :class:`~blockmpec.solvers.engines.stopping.StoppingCriterion`: per
        iteration ``residual`` (inf-norm of the scaled ``Phi``), merit, step length, direction kind,
        multiplier and ``time_s`` (elapsed since the criterion started).
    message : str
    """

    status: Status
    solution: Solution
    iterations: int
    trace: list
    message: str


class MCPSystem:
    r"""The MCP (3) as a square semismooth system ``Phi(w) = 0`` with Fischer–Burmeister pairs.

    Unknowns ``w = (lam, x, u, z)`` of the compiled formulation ``form``
    (``1 + 3c + 3b + 4c`` values); equations (same count)::

        Phi = [ (A w - rhs)[equilibrium] / r_eq          (3b)
                (A w - rhs)[compatibility] / r_comp      (3c)
                (A w - rhs)[normalisation]               (1)
                phi(z / z_scale, s / s_scale) ]          (4c),  z = w[pair_column],  s = -G w

    The row scales ``r_eq, r_comp`` and the pair scales ``z_scale, s_scale`` are
    typical magnitudes (from the starting point), so ``||Phi||`` is scale-free:
    ``r_eq = max(|f_d|_inf, |lam_0| |f_l|_inf)``, ``r_comp`` the larger of the two
    compatibility terms at the start.  The Newton iteration works in scaled unknowns
    ``w = D w_hat`` with ``D = diag(1, x_scale, u_scale, z_scale)``.
    """

    def __init__(self, form: CompiledMCP, start: Solution) -> None:
        self.form = form
        self.n = form.n_columns
        self.n_pairs = form.n_pairs

        def typical(v: np.ndarray) -> float:
            m = float(np.max(np.abs(v))) if v.size else 0.0
            return m if m > 0 and np.isfinite(m) else 1.0

        w0 = form.pack(start)
        z0 = form.multipliers(w0)
        compatibility = form.compatibility
        self.x_scale = typical(start.x)
        self.u_scale = typical(start.u)
        self.z_scale = typical(z0)
        self.s_scale = typical(form.slack(w0))
        self.r_eq = max(typical(form.f_d), abs(start.multiplier or 0.0) * typical(form.f_l), 1e-300)
        self.r_comp = max(typical(form.block(compatibility, form.u) @ start.u),
                          typical(form.block(compatibility, form.z) @ z0))
        self.col_scale = np.ones(self.n)
        self.col_scale[form.x] = self.x_scale
        self.col_scale[form.u] = self.u_scale
        self.col_scale[form.z] = self.z_scale
        self.row_scale = np.ones(form.A.shape[0] + self.n_pairs)
        self.row_scale[form.equilibrium] = 1.0 / self.r_eq
        self.row_scale[compatibility] = 1.0 / self.r_comp
        self._pair_rows = np.arange(self.n_pairs)

    def pack(self, sol: Solution) -> np.ndarray:
        """Scaled unknowns ``w_hat`` of a solution."""
        return self.form.pack(sol) / self.col_scale

    def unpack(self, w_hat: np.ndarray) -> Solution:
        """The solution at scaled unknowns ``w_hat``."""
        return self.form.unpack(w_hat * self.col_scale)

    def residual(self, w_hat: np.ndarray, jacobian: bool = False):
        """``Phi(w_hat)`` (scaled) and, if asked, an element of its generalised Jacobian (CSC)."""
        form = self.form
        w = w_hat * self.col_scale
        a, b = form.multipliers(w) / self.z_scale, form.slack(w) / self.s_scale
        phi, da, db = fischer_burmeister(a, b)
        Phi = np.concatenate([form.A @ w - form.rhs, phi]) * self.row_scale
        if not jacobian:
            return Phi
        # d phi / dw = db / s_scale * (-G)  +  da / z_scale at the pair's multiplier column
        J_s = sp.diags_array(-db / self.s_scale) @ form.G
        J_z = sp.csr_array(sp.diags_array(da / self.z_scale) @ sp.csr_array(
            (np.ones(self.n_pairs), (self._pair_rows, form.pair_column)), shape=(self.n_pairs, self.n)))
        J = sp.vstack([form.A, J_s + J_z], format="csr")
        J = sp.diags_array(self.row_scale) @ J @ sp.diags_array(self.col_scale)
        return Phi, J.tocsc()


def semismooth_newton(system: MCPSystem, w0: np.ndarray, *, tol: float = 1e-10, max_iterations: int = 100,
                      sigma: float = 1e-4, backtrack: float = 0.5, max_backtracks: int = 40,
                      regularisation: float = 1.0, descent_rho: float = 1e-8, descent_power: float = 2.1,
                      newton_refinements: int = 3, deadline: Deadline = NEVER,
                      stop: StoppingCriterion | None = None, **record) -> NewtonOutcome:
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
    :class:`MCPSystem`), ``ITERATION_LIMIT`` after ``max_iterations`` steps,
    ``TIME_LIMIT``, or ``NUMERICAL`` when no direction yields a step (stalled line
    search).  Every step is counted and recorded by a
    :class:`~blockmpec.solvers.engines.stopping.StoppingCriterion` on ``||Phi||_inf``
    (trace keys ``iteration, time_s, residual, merit, step, direction, multiplier``
    and ``record``): ``stop`` when given (a caller's run-wide criterion: its time and
    iteration limits and its ``tol`` apply too, and the records go to its trace),
    else a new one with ``tol``, ``max_iterations`` and ``deadline``.
    """
    from scipy.sparse.linalg import splu

    if stop is None:
        stop = StoppingCriterion(tol, max_iterations, deadline, measure_name="residual").start()
    first_record = len(stop.trace)
    w = np.asarray(w0, float).copy()
    Phi, J = system.residual(w, jacobian=True)
    merit = 0.5 * float(Phi @ Phi)
    res = float(np.max(np.abs(Phi))) if Phi.size else 0.0
    n = w.size
    ident = sp.eye_array(n, format="csc")

    def outcome(status: Status, k: int, message: str) -> NewtonOutcome:
        return NewtonOutcome(status, system.unpack(w), k, stop.trace[first_record:], message)

    if res <= tol:
        return outcome(Status.CONVERGED, 0, f"converged: ||Phi||_inf = {res:.3g} <= {tol:g} after 0 iterations")
    if stop.out_of_time():
        return outcome(Status.TIME_LIMIT, 0, f"time limit: ||Phi||_inf = {res:.3g} after 0 iterations")
    for k in range(1, max_iterations + 1):
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
            return outcome(Status.NUMERICAL, k - 1,
                           f"line search stalled at ||Phi||_inf = {res:.3g} after {k - 1} iterations")
        kind, t, w, _ = step
        Phi, J = system.residual(w, jacobian=True)
        merit = 0.5 * float(Phi @ Phi)
        res = float(np.max(np.abs(Phi)))
        status = stop.check(res, merit=merit, step=t, direction=kind, multiplier=float(w[0]), **record)
        if res <= tol:
            return outcome(Status.CONVERGED, k, f"converged: ||Phi||_inf = {res:.3g} <= {tol:g} after {k} iterations")
        if status is not None:  # the criterion's own limits (a run-wide budget): stop here
            return outcome(status, k, f"{status.value.replace('_', ' ')}: ||Phi||_inf = {res:.3g} after {k} iterations")
    return outcome(Status.ITERATION_LIMIT, max_iterations,
                   f"iteration limit: ||Phi||_inf = {res:.3g} after {max_iterations} iterations")

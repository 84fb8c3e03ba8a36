r"""The exact Coulomb cone for the associative 3D problem: a second-order cone program by Clarabel.

The LP-based methods linearise the cone ``||(t1, t2)|| <= -mu n`` at each contact point by an inscribed pyramid of
``s`` sides (:mod:`blockmpec.three_d.operators`), so their associative multiplier is a lower bound of the cone's.
:func:`exact_cone` solves the static problem (1) with the cone itself::

    max lam   s.t.   E x + f_d + lam f_l = 0,   n_j <= 0,   (-mu n_j, t1_j, t2_j) in SOC(3)  for every point j

with Clarabel (an interior-point conic solver, Apache-2.0; ``pip install "blockmpec[cone]"``), and brackets it by
the inscribed pyramid's ``lam`` (``static-lp``) and the circumscribed one's (the pyramid of friction
``mu / cos(pi / s)``, which contains the cone): ``lam_inscribed <= lam_cone <= lam_circumscribed``.  The pyramid's
error is ``(lam_cone - lam_inscribed) / lam_cone``.

The answer is checked like every other: the equilibrium residual of :func:`blockmpec.verify.residuals` and the
cone's own admissibility ``max_j (||t_j|| + mu n_j)_+ / max_j |n_j|``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from blockmpec.errors import OptionError, SolverUnavailableError


@dataclass
class ConeResult:
    """The exact cone's multiplier and the pyramid's bracket.

    Attributes
    ----------
    status : str
        Clarabel's status (``Solved`` for an optimum).
    multiplier : float or None
        ``lam`` with the exact cone.
    inscribed, circumscribed : float or None
        ``lam`` of ``static-lp`` with the inscribed pyramid and with the circumscribed one (verified, else None).
    pyramid_sides : int
    relative_error : float or None
        ``(lam_cone - lam_inscribed) / lam_cone``: how much the inscribed pyramid underestimates.
    equilibrium, cone_admissibility : float
        The verifier's equilibrium residual of the cone's forces and their cone admissibility.
    solve_time_s : float
        Clarabel's solve time.
    x : ndarray or None
        The cone's contact forces (canonical problem; :func:`blockmpec.three_d.report.contact_forces` reads them).
    """

    status: str
    multiplier: float | None
    inscribed: float | None
    circumscribed: float | None
    pyramid_sides: int
    relative_error: float | None
    equilibrium: float
    cone_admissibility: float
    solve_time_s: float
    x: np.ndarray | None = None


def cone_program(ops) -> tuple[sp.csc_matrix, np.ndarray, np.ndarray, list]:
    """``(P-free) min c^T z  s.t.  A z + s = b, s in K`` of the exact-cone static problem, ``z = (lam, x)``."""
    import clarabel

    n_x = ops.E.shape[1]
    nz = 1 + n_x
    eq = sp.hstack([sp.csr_array(ops.f_l.reshape(-1, 1)), ops.E]).tocsr()
    p = ops.n_contacts
    normal = 1 + ops.normal_index
    shear = 1 + ops.shear_index
    nonneg = sp.csr_array((np.ones(p), (np.arange(p), normal)), shape=(p, nz))
    rows = np.arange(3 * p).reshape(p, 3)
    soc = sp.csr_array((np.concatenate([ops.friction, -np.ones(p), -np.ones(p)]),
                        (np.concatenate([rows[:, 0], rows[:, 1], rows[:, 2]]),
                         np.concatenate([normal, shear[:, 0], shear[:, 1]]))), shape=(3 * p, nz))
    A = sp.vstack([eq, nonneg, soc]).tocsc()
    b = np.concatenate([-ops.f_d, np.zeros(p), np.zeros(3 * p)])
    c = np.zeros(nz)
    c[0] = -1.0
    cones = [clarabel.ZeroConeT(eq.shape[0]), clarabel.NonnegativeConeT(p)] + [clarabel.SecondOrderConeT(3)] * p
    return sp.csc_matrix(A), b, c, cones


def _cone_admissibility(ops, x: np.ndarray) -> float:
    """``max_j (||t_j|| + mu n_j)_+ / max_j |n_j|``: the worst excess over the cone against the largest normal force
    (an interior-point answer leaves round-off at unloaded points, which a point-wise ratio would magnify)."""
    q = x.reshape(-1, 3)
    n = q[:, 2]
    t = np.linalg.norm(q[:, :2], axis=1)
    excess = np.maximum(t + ops.friction * n, 0.0)
    scale = float(np.max(np.abs(n), initial=0.0))
    return float(excess.max(initial=0.0) / scale) if scale > 0 else 0.0


def exact_cone(structure, pyramid: bool = True, tol: float = 1e-9) -> ConeResult:
    """Solve the associative 3D problem with the exact Coulomb cone (module docstring).

    Parameters
    ----------
    structure : Structure3D
    pyramid : bool
        Also solve ``static-lp`` with the inscribed and the circumscribed pyramid (the bracket and the error).
    tol : float
        Clarabel's gap and feasibility tolerances.

    Raises
    ------
    SolverUnavailableError
        When Clarabel is not installed.
    """
    try:
        import clarabel
    except ImportError:
        raise SolverUnavailableError("the exact cone needs Clarabel: pip install \"blockmpec[cone]\"") from None
    from blockmpec.operators import assemble
    from blockmpec.result import Solution
    from blockmpec.solver import solve
    from blockmpec.verify import residuals

    if getattr(structure, "dim", 2) != 3:
        raise OptionError("exact_cone: a 2D structure's friction is exact already (give a Structure3D)")
    ops = assemble(structure)
    P = sp.csc_matrix((1 + ops.E.shape[1], 1 + ops.E.shape[1]))
    A, b, c, cones = cone_program(ops)
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = tol
    t0 = time.perf_counter()
    sol = clarabel.DefaultSolver(P, c, A, b, cones, settings).solve()
    elapsed = time.perf_counter() - t0
    status = str(sol.status)
    lam, x, eq, adm = None, None, math.inf, math.inf
    if status == "Solved":
        z = np.asarray(sol.x)
        lam, x = float(z[0]), z[1:]
        eq = residuals(ops, Solution(multiplier=lam, x=x), associative=True)["equilibrium"]
        adm = _cone_admissibility(ops, x)
    inscribed = circumscribed = None
    if pyramid:
        low = solve(structure, "static-lp")
        inscribed = low.multiplier if low.success else None
        widened = structure.with_material(friction=structure.friction / math.cos(math.pi / structure.pyramid_sides),
                                          dilatancy=structure.dilatancy / math.cos(math.pi / structure.pyramid_sides))
        high = solve(widened, "static-lp")
        circumscribed = high.multiplier if high.success else None
    error = None if lam is None or inscribed is None or lam == 0 else (lam - inscribed) / lam
    return ConeResult(status=status, multiplier=lam, inscribed=inscribed, circumscribed=circumscribed,
                      pyramid_sides=structure.pyramid_sides, relative_error=error, equilibrium=eq,
                      cone_admissibility=adm, solve_time_s=elapsed, x=x)

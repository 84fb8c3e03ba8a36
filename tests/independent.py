r"""A second, independent statement of the limit-analysis problems, for the tests' reference values.

Written from the geometry of a :class:`blockmpec.Structure` (its block polygons, interface segments, densities,
friction and load settings) with numpy, scipy and, optionally, SCIP: nothing from ``blockmpec.operators``,
``formulations``, ``solvers``, ``units`` or ``verify`` is used, the problem is posed in the structure's own frame and
units (no canonical frame, no scaling), and the solvers are others than the library's engines (scipy's own copy of
HiGHS for the LPs; SCIP with its SoPlex for the MPEC).  A value quoted in a test that the library's output once
suggested is checked here against this statement before it counts as a reference (``tests/README.md``).

The statement (the paper's equations, each interface ``k`` with its segment from ``start`` to ``end``, length ``L``,
tangent ``tau``, normal ``nu = rot90(tau)`` pointing from its minus block into its plus block, midpoint ``M``):
the plus block exerts on the minus block the force ``t tau + n nu`` at ``M`` and the couple ``m`` (the minus block
on the plus block the opposite), so a free block ``i`` with centroid ``c_i`` is in equilibrium when the sum of those
forces, of their moments ``(M - c_i) x F`` and couples, of its weight ``W_i`` (down, at ``c_i``) and of ``lam``
times its live load (``live_direction * live_factor * W_i`` along ``x``, at ``c_i``), and of its point loads,
vanishes: ``E x + f_d + lam f_l = 0``.  Admissibility: ``n L/2 + m <= 0``, ``n L/2 - m <= 0`` (the resultant
inside the joint, no tension) and ``t + mu n <= 0``, ``-t + mu n <= 0`` (Coulomb).  The flow of (3) is the
transpose: ``E^T u + N_u z_u + V z_f = 0``, ``V`` with ``tan(psi)`` in place of ``mu``, ``f_l^T u = 1``, and each
multiplier complementary to its row.

* :func:`associative_multiplier`: the static LP (1), ``max lam`` (scipy.optimize.linprog, HiGHS).
* :func:`mpec`: the least (or largest) ``lam`` over the solutions of (3), problem (4), with every complementary pair
  an SOS1 constraint in SCIP (pyscipopt; ``None`` when it is not installed), then polished: the pairs' sides that SCIP
  left at zero fixed, ``lam`` minimised (maximised) again by an LP, so the value is exact to round-off and SCIP's
  dual bound certifies it to its tolerance.  ``mpec(..., at=lam)`` asks instead whether ``lam`` is a collapse
  multiplier of (3) and returns the range of ``lam`` over the solution pattern found there.

``python tests/independent.py`` prints every reference value of ``tests/references.py`` from this statement.
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass

import numpy as np
import scipy.optimize

#: SCIP through pyscipopt is optional (the ``scip`` test lane, tests/README.md)
HAS_SCIP = importlib.util.find_spec("pyscipopt") is not None


@dataclass
class Problem:
    """The operators of (1)-(4) for one structure, in its own frame and units (dense: the structures are small)."""

    E: np.ndarray  # (3 free blocks, 3 interfaces)
    f_d: np.ndarray
    f_l: np.ndarray
    N_u: np.ndarray  # (3 interfaces, 2 interfaces): columns = gradients of the unilateral rows
    N_f: np.ndarray
    V: np.ndarray


def _area_centroid(polygon: np.ndarray) -> tuple[float, np.ndarray]:
    x, y = polygon[:, 0], polygon[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = cross.sum() / 2
    return area, np.array([((x + xn) * cross).sum(), ((y + yn) * cross).sum()]) / (6 * area)


def problem(structure) -> Problem:
    """The operators of ``structure``, written from its geometry."""
    n = structure.n_blocks
    free = [i for i in range(n) if not structure.fixed[i]]
    row = {block: 3 * r for r, block in enumerate(free)}
    geometry = [_area_centroid(np.asarray(structure.polygon(i), float)) for i in range(n)]
    centroid = np.array([c for _, c in geometry])
    weight = np.array([a for a, _ in geometry]) * np.asarray(structure.density, float)
    f_d, f_l = np.zeros(3 * len(free)), np.zeros(3 * len(free))
    for block in free:
        f_d[row[block] + 1] = -weight[block]
        f_l[row[block]] = structure.live_direction * structure.live_factor * weight[block]
    for load in structure.point_loads:
        if structure.fixed[load.block]:
            continue
        force = np.asarray(load.force, float)
        arm = np.asarray(load.point, float) - centroid[load.block]
        target = f_l if load.kind == "live" else f_d
        target[row[load.block]:row[load.block] + 3] += [force[0], force[1], arm[0] * force[1] - arm[1] * force[0]]

    faces = structure.interfaces
    mu = np.where(np.isnan(faces.friction), structure.friction, faces.friction)
    psi = np.where(np.isnan(faces.dilatancy), structure.dilatancy, faces.dilatancy)
    c = len(faces)
    E = np.zeros((3 * len(free), 3 * c))
    N_u, N_f, V = np.zeros((3 * c, 2 * c)), np.zeros((3 * c, 2 * c)), np.zeros((3 * c, 2 * c))
    for k in range(c):
        start, end = np.asarray(faces.start[k], float), np.asarray(faces.end[k], float)
        length = float(np.hypot(*(end - start)))
        tau = (end - start) / length
        nu = np.array([-tau[1], tau[0]])
        mid = (start + end) / 2
        for block, sign in ((int(faces.minus[k]), 1.0), (int(faces.plus[k]), -1.0)):
            if block not in row:
                continue
            arm = mid - centroid[block]
            for j, direction in enumerate((tau, nu)):  # shear, normal: a unit force along direction at mid
                E[row[block]:row[block] + 3, 3 * k + j] = sign * np.array(
                    [direction[0], direction[1], arm[0] * direction[1] - arm[1] * direction[0]])
            E[row[block] + 2, 3 * k + 2] = sign  # the couple
        rows = slice(3 * k, 3 * k + 3)
        N_u[rows, 2 * k], N_u[rows, 2 * k + 1] = [0, length / 2, 1], [0, length / 2, -1]
        N_f[rows, 2 * k], N_f[rows, 2 * k + 1] = [1, mu[k], 0], [-1, mu[k], 0]
        V[rows, 2 * k], V[rows, 2 * k + 1] = [1, psi[k], 0], [-1, psi[k], 0]
    return Problem(E, f_d, f_l, N_u, N_f, V)


def associative_multiplier(structure) -> float:
    """The optimum of the static LP (1): ``max lam`` s.t. ``E x + f_d + lam f_l = 0``, ``N_u^T x <= 0``,
    ``N_f^T x <= 0`` (scipy.optimize.linprog with HiGHS, tolerances 1e-10)."""
    status, lam = static_lp(structure)
    if status != "optimal":
        raise RuntimeError(f"static LP: {status}")
    return lam


def static_lp(structure) -> tuple[str, float | None]:
    """``(status, lam)`` of the static LP (1): "optimal", "infeasible" (no equilibrium for any lam) or "unbounded"
    (no collapse)."""
    p = problem(structure)
    n_x = p.E.shape[1]
    cost = np.zeros(1 + n_x)
    cost[0] = -1.0
    A_ub = np.hstack([np.zeros((2 * p.N_u.shape[1], 1)), np.vstack([p.N_u.T, p.N_f.T])])
    run = scipy.optimize.linprog(cost, A_ub=A_ub, b_ub=np.zeros(A_ub.shape[0]),
                                 A_eq=np.hstack([p.f_l[:, None], p.E]), b_eq=-p.f_d, bounds=(None, None),
                                 method="highs", options={"primal_feasibility_tolerance": 1e-10,
                                                          "dual_feasibility_tolerance": 1e-10})
    if run.status == 2:
        return "infeasible", None
    if run.status == 3:
        return "unbounded", None
    if run.status != 0:
        raise RuntimeError(f"static LP: {run.message}")
    return "optimal", float(run.x[0])


@dataclass
class MPECResult:
    """What :func:`mpec` found: ``status`` ("optimal", "infeasible", "feasible" for ``at=``, or SCIP's status at a
    limit); ``multiplier`` the polished ``lam`` (the least/largest over the solution pattern SCIP found), ``bound``
    SCIP's dual bound; for ``at=``, ``lam_range`` the least and largest ``lam`` over the pattern found there."""

    status: str
    multiplier: float | None = None
    bound: float | None = None
    lam_range: tuple[float, float] | None = None
    seconds: float = 0.0


def _columns(p: Problem):
    """Column layout of the MCP (3)'s unknowns ``(lam, x, u, z_u, z_f, s_u, s_f)``, ``s = -N^T x >= 0``."""
    n_x, n_u, n_p = p.E.shape[1], p.E.shape[0], p.N_u.shape[1]
    sizes = {"lam": 1, "x": n_x, "u": n_u, "z_u": n_p, "z_f": n_p, "s_u": n_p, "s_f": n_p}
    out, at = {}, 0
    for name, size in sizes.items():
        out[name] = np.arange(at, at + size)
        at += size
    return out, at


def _equalities(p: Problem):
    """The linear rows of (3): equilibrium, compatibility, normalisation and the slack definitions, ``A w = b``."""
    col, n = _columns(p)
    blocks = []

    def rows(count, parts, rhs):
        A = np.zeros((count, n))
        for name, matrix in parts:
            A[:, col[name]] = matrix
        blocks.append((A, rhs))

    rows(p.E.shape[0], [("lam", p.f_l[:, None]), ("x", p.E)], -p.f_d)
    rows(p.E.shape[1], [("u", p.E.T), ("z_u", p.N_u), ("z_f", p.V)], np.zeros(p.E.shape[1]))
    rows(1, [("u", p.f_l[None, :])], np.ones(1))
    eye = np.eye(p.N_u.shape[1])
    rows(p.N_u.shape[1], [("x", p.N_u.T), ("s_u", eye)], np.zeros(p.N_u.shape[1]))
    rows(p.N_f.shape[1], [("x", p.N_f.T), ("s_f", eye)], np.zeros(p.N_f.shape[1]))
    return np.vstack([a for a, _ in blocks]), np.concatenate([b for _, b in blocks]), col, n


def _polish(p: Problem, zero: np.ndarray, sense: int) -> float | None:
    """``sense * lam`` minimised over (3) with the columns ``zero`` fixed at 0 (a complementarity pattern): an LP."""
    A, b, col, n = _equalities(p)
    bounds = [(None, None)] * n
    for name in ("z_u", "z_f", "s_u", "s_f"):
        for j in col[name]:
            bounds[j] = (0.0, 0.0) if zero[j] else (0.0, None)
    cost = np.zeros(n)
    cost[col["lam"][0]] = sense
    run = scipy.optimize.linprog(cost, A_eq=A, b_eq=b, bounds=bounds, method="highs",
                                 options={"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10})
    return float(run.x[col["lam"][0]]) if run.status == 0 else None


def mpec(structure, sense: str = "min", at: float | None = None, time_limit: float = 600.0) -> MPECResult | None:
    """Problem (4) by SCIP with SOS1 pairs, polished by an LP on the pattern found (see the module docstring).

    ``sense``: "min" (the least collapse multiplier) or "max"; ``at``: instead, a point of (3) with ``lam = at``
    (within SCIP's feasibility tolerance 1e-9) and the range of ``lam`` over its pattern.  None without pyscipopt."""
    if not HAS_SCIP:
        return None
    import pyscipopt

    p = problem(structure)
    A, b, col, n = _equalities(p)
    model = pyscipopt.Model()
    model.hideOutput()
    model.setParam("limits/time", time_limit)
    model.setParam("limits/gap", 0.0)
    model.setParam("numerics/feastol", 1e-9)
    w = []
    for j in range(n):
        nonneg = any(j in col[name] for name in ("z_u", "z_f", "s_u", "s_f"))
        w.append(model.addVar(lb=0.0 if nonneg else None, ub=None))
    for i in range(A.shape[0]):
        nz = np.flatnonzero(A[i])
        model.addCons(pyscipopt.quicksum(float(A[i, j]) * w[j] for j in nz) == float(b[i]))
    for z, s in (("z_u", "s_u"), ("z_f", "s_f")):
        for j, k in zip(col[z], col[s]):
            model.addConsSOS1([w[j], w[k]])
    lam = w[col["lam"][0]]
    # a valid inequality (not a constraint of (3), implied by it): u^T (E x + f_d + lam f_l) = 0 with f_l^T u = 1 and
    # E^T u = -N_u z_u - V z_f gives lam = -f_d^T u + (N_u^T x)^T z_u + (V^T x)^T z_f, and with complementarity
    # (V^T x)^T z_f = sum_k (tan psi_k - mu_k) n_k (z_f,2k + z_f,2k+1) >= 0, so lam >= -f_d^T u: the kinematic bound,
    # which SCIP's relaxation (pairs dropped) would otherwise miss
    model.addCons(lam + pyscipopt.quicksum(float(p.f_d[i]) * w[j] for i, j in enumerate(col["u"]) if p.f_d[i]) >= 0)
    if at is not None:
        model.addCons(lam == at)
    else:
        model.setObjective(lam, "minimize" if sense == "min" else "maximize")
    model.optimize()
    status, seconds = model.getStatus(), model.getSolvingTime()
    if status == "infeasible":
        return MPECResult("infeasible", seconds=seconds)
    if model.getNSols() == 0:
        return MPECResult(status, seconds=seconds)
    point = np.array([model.getVal(v) for v in w])
    zero = np.zeros(n, bool)
    for z, s in (("z_u", "s_u"), ("z_f", "s_f")):
        for j, k in zip(col[z], col[s]):
            zero[j if point[j] <= point[k] else k] = True
    if at is not None:
        low, high = _polish(p, zero, 1.0), _polish(p, zero, -1.0)
        return MPECResult("feasible", at, lam_range=(low, high), seconds=seconds)
    sign = 1.0 if sense == "min" else -1.0
    return MPECResult(status, _polish(p, zero, sign), model.getDualbound(), seconds=seconds)


if __name__ == "__main__":  # python tests/independent.py: every reference value from this statement
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from references import report

    report()

r"""The MPEC (4) as a mixed-integer linear program: one binary per complementarity pair.

Problem (4) is ``min lam`` over the solutions of the MCP (3) (``sense="min"``);
``sense="max"`` gives ``max lam`` over the same set, the largest non-associative
multiplier.  Everything below (switches, normalisation, cuts) is a property of
the *set* of solutions of (3), so it holds for both senses::

    E x + f_d + lam f_l = 0                       (equilibrium)
    E^T u + N_u z_u + V_f z_f = 0                 (compatibility, non-associative flow)
    f_l^T u = 1                                   (normalisation)
    0 <= s_u = -N_u^T x   _|_  z_u >= 0           (2c unilateral pairs)
    0 <= s_f = -N_f^T x   _|_  z_f >= 0           (2c friction pairs)

Mixed-integer statement
-----------------------
Each pair ``i`` gets a binary ``y_i``: ``y_i = 1`` lets the flow multiplier be
positive and closes the constraint (``s_i = 0``); ``y_i = 0`` forces ``z_i = 0``::

    s_i <= M_i (1 - y_i),        z_i <= y_i.

*Slack bounds ``M_i``* (the only big-M of the model) are data: the solver proves
them by linear programs, ``M_i >= max s_i`` over the statically admissible set
``{E x + f_d + lam f_l = 0, N_u^T x <= 0, N_f^T x <= 0, lam_lower <= lam <= lam_upper}``,
which contains the force part of every solution of (3).

*Multipliers need no guessed bound* (scaling argument).  ``(u, z_u, z_f)`` enter
(3) homogeneously except for the normalisation, and ``z != 0`` at every solution
(``z = 0`` gives ``E^T u = 0``, hence ``u = 0`` for a structure tied to its fixed
blocks, contradicting ``f_l^T u = 1``).  So each solution of (3) can be rescaled to
the normalisation ::

    1^T z_u + 1^T z_f = 1,      tau := f_l^T u > 0,

and back (divide ``u, z`` by ``tau``).  Under this normalisation ``0 <= z_i <= 1``
exactly, so ``z_i <= y_i`` is the *exact* bound, not a big-M.  The model imposes
``tau >= tau_min``.  With ``tau_min = 0`` the MILP is a **relaxation** of (4)
(for ``sense="min"`` its optimum is a certified lower bound on the minimum, for
``sense="max"`` an upper bound on the maximum; a point with ``tau > 0`` is a
solution of (3)); with ``tau_min > 0`` every feasible point is a solution of (3).

Valid cuts
----------
At any solution of (3) (in the original normalisation) the work identity reads
``lam = -f_d^T u + D`` with the friction dissipation
``D = -sum_k (tan phi_k - tan psi_k) n_k (z_f[2k] + z_f[2k+1]) >= 0``.  Rescaled,
``lam tau = -f_d^T u + D``.  With ``lam <= lam_upper`` (the associative
multiplier bounds every non-associative one: ``x`` is statically admissible),
``lam >= lam_lower`` and ``0 <= tau <= tau_max``:

* ``dead_work_cut``:  ``-f_d^T u <= lam_upper tau``;
* ``work_mccormick``: ``-f_d^T u <= lam tau <= tau_max lam + lam_lower (tau - tau_max)``
  (McCormick's over-estimator of ``lam tau``; active only when the solver sets
  ``tau_max = max f_l^T u`` over ``{compatibility, 1^T z = 1, z >= 0}``);
* ``dead_work_lower``: ``-f_d^T u >= lam_kinematic tau`` where ``lam_kinematic`` is
  the optimum of the non-associative kinematic LP ``min -f_d^T u`` s.t.
  compatibility (flow ``V_f``), ``f_l^T u = 1``, ``z >= 0``.  That LP being bounded,
  ``-f_d^T u >= lam_kinematic f_l^T u`` holds on its whole cone, also at
  ``tau = 0`` (active only when the solver sets it);
* ``sliding_direction``: ``y_f[2k] + y_f[2k+1] <= 1``.  Both friction rows of an
  interface active means ``t = n = 0``, hence ``m = 0`` and both rocking rows are
  active too; the common part ``min(z_f[2k], z_f[2k+1])`` of the two sliding
  multipliers is a pure opening ``(0, 2 tan psi, 0)`` that the rocking pair
  reproduces (``N_u (a, a) = (0, a L, 0)``).  So every solution of (3) has a
  representative with at most one sliding direction per interface.  Without this
  cut ``z_f[2k] = z_f[2k+1] = 1/2`` and ``u = 0`` would satisfy the normalised
  system when ``psi = 0`` (the two friction directions cancel): a spurious point.

The switches ``z_i <= zmax_i y_i`` may use ``zmax_i = max z_i`` over
``{compatibility, 1^T z = 1, z >= 0}`` (``<= 1``), a tightening valid for every
normalised solution.  The bounds ``lam_lower <= lam <= lam_upper`` are column
bounds.  The redundant pair ``n <= 0`` is absent (``N_u`` has the two rocking
rows only).

The numbers ``M``, ``zmax``, ``lam_lower``, ``lam_upper``, ``lam_kinematic``,
``tau_max`` and ``tau_min`` are mutable ``Param`` s; set them (and activate the
optional cuts) before compiling.
"""

from __future__ import annotations

import numpy as np
import pyomo.environ as pyo
from pyomo.core.expr.numeric_expr import LinearExpression

from blockmpec.operators import Operators
from blockmpec.formulations._pyomo import LinearProgram, PyomoProblem, compile_linear, sparse_rows


def _dot(coef: np.ndarray, variables: list) -> LinearExpression:
    nz = np.flatnonzero(coef)
    return LinearExpression(constant=0.0, linear_coefs=coef[nz].tolist(), linear_vars=[variables[i] for i in nz])


def mpec_bigm(
    ops: Operators,
    slack_bound_unilateral: np.ndarray | None = None,
    slack_bound_friction: np.ndarray | None = None,
    lam_lower: float = -1.0,
    lam_upper: float = 1.0,
    tau_min: float = 0.0,
    sense: str = "min",
) -> PyomoProblem:
    """Build the mixed-integer form of (4) described in the module docstring.

    Parameters
    ----------
    ops : Operators
    slack_bound_unilateral, slack_bound_friction : ndarray, shape (2c,), optional
        ``M_i`` of the unilateral and friction pairs (default 1: placeholders).
    lam_lower, lam_upper : float
        Bounds of ``lam`` (``lam_upper`` also enters ``dead_work_cut``).
    tau_min : float
        Lower bound of ``tau = f_l^T u`` (0: relaxation; > 0: restriction).
    sense : {"min", "max"}
        Minimise (problem (4)) or maximise ``lam``.  :func:`compile_mixed_integer`
        returns the cost of ``min lam`` or ``min -lam`` (``objective_sign = -1``).

    Returns
    -------
    PyomoProblem
        Variable groups ``lam, x, u, z_u, z_f, y_u, y_f, tau``; constraint groups
        ``equilibrium, unilateral, friction, unilateral_bigm, friction_bigm,
        unilateral_switch, friction_switch, compatibility, normalisation,
        live_work, dead_work_cut, dead_work_lower, work_mccormick,
        sliding_direction`` (``dead_work_lower`` and ``work_mccormick`` start deactivated).
    """
    if sense not in ("min", "max"):
        raise ValueError(f"sense must be 'min' or 'max'; got {sense!r}")
    c = ops.n_interfaces
    b3 = ops.E.shape[0]
    Mu = np.ones(2 * c) if slack_bound_unilateral is None else np.asarray(slack_bound_unilateral, float)
    Mf = np.ones(2 * c) if slack_bound_friction is None else np.asarray(slack_bound_friction, float)
    m = pyo.ConcreteModel(name="mpec-bigm")
    m.lam_lower = pyo.Param(mutable=True, initialize=float(lam_lower))
    m.lam_upper = pyo.Param(mutable=True, initialize=float(lam_upper))
    m.tau_min = pyo.Param(mutable=True, initialize=float(tau_min))
    m.lam_kinematic = pyo.Param(mutable=True, initialize=0.0)
    m.tau_max = pyo.Param(mutable=True, initialize=1.0)
    m.M_u = pyo.Param(range(2 * c), mutable=True, initialize=dict(enumerate(Mu.tolist())))
    m.M_f = pyo.Param(range(2 * c), mutable=True, initialize=dict(enumerate(Mf.tolist())))
    m.zmax_u = pyo.Param(range(2 * c), mutable=True, initialize=1.0)
    m.zmax_f = pyo.Param(range(2 * c), mutable=True, initialize=1.0)

    m.lam = pyo.Var(bounds=(m.lam_lower, m.lam_upper))
    m.x = pyo.Var(range(3 * c))
    m.u = pyo.Var(range(b3))
    m.z_u = pyo.Var(range(2 * c), bounds=(0.0, 1.0))
    m.z_f = pyo.Var(range(2 * c), bounds=(0.0, 1.0))
    m.y_u = pyo.Var(range(2 * c), within=pyo.Binary)
    m.y_f = pyo.Var(range(2 * c), within=pyo.Binary)
    m.tau = pyo.Var(bounds=(m.tau_min, None))
    lam, xs, us = [m.lam], list(m.x.values()), list(m.u.values())
    zu, zf, yu, yf = (list(v.values()) for v in (m.z_u, m.z_f, m.y_u, m.y_f))

    eq = sparse_rows([(ops.E, xs), (ops.f_l.reshape(-1, 1), lam)], b3)
    m.equilibrium = pyo.Constraint(range(b3), rule=lambda _, i: eq(i) == -float(ops.f_d[i]))
    uni = sparse_rows([(ops.N_u.T, xs)], 2 * c)
    fri = sparse_rows([(ops.N_f.T, xs)], 2 * c)
    m.unilateral = pyo.Constraint(range(2 * c), rule=lambda _, i: uni(i) <= 0.0)
    m.friction = pyo.Constraint(range(2 * c), rule=lambda _, i: fri(i) <= 0.0)
    # s_i <= M_i (1 - y_i) with s = -N^T x:   -[N^T x]_i + M_i y_i <= M_i
    m.unilateral_bigm = pyo.Constraint(range(2 * c), rule=lambda mm, i: -uni(i) + mm.M_u[i] * mm.y_u[i] <= mm.M_u[i])
    m.friction_bigm = pyo.Constraint(range(2 * c), rule=lambda mm, i: -fri(i) + mm.M_f[i] * mm.y_f[i] <= mm.M_f[i])
    m.unilateral_switch = pyo.Constraint(range(2 * c), rule=lambda mm, i: mm.z_u[i] - mm.zmax_u[i] * mm.y_u[i] <= 0.0)
    m.friction_switch = pyo.Constraint(range(2 * c), rule=lambda mm, i: mm.z_f[i] - mm.zmax_f[i] * mm.y_f[i] <= 0.0)

    # at most one sliding direction per interface (see "Valid cuts")
    m.sliding_direction = pyo.Constraint(range(c), rule=lambda mm, k: mm.y_f[2 * k] + mm.y_f[2 * k + 1] <= 1)
    comp = sparse_rows([(ops.E.T, us), (ops.N_u, zu), (ops.V_f, zf)], 3 * c)
    m.compatibility = pyo.Constraint(range(3 * c), rule=lambda _, i: comp(i) == 0.0)
    m.normalisation = pyo.Constraint(
        expr=LinearExpression(constant=0.0, linear_coefs=[1.0] * (4 * c), linear_vars=zu + zf) == 1.0)
    m.live_work = pyo.Constraint(expr=m.tau - _dot(ops.f_l, us) == 0.0)
    m.dead_work_cut = pyo.Constraint(expr=_dot(-ops.f_d, us) - m.lam_upper * m.tau <= 0.0)
    # lam tau >= -f_d^T u with McCormick's over-estimator of lam tau (tau in [0, tau_max], lam >= lam_lower)
    m.work_mccormick = pyo.Constraint(
        expr=_dot(-ops.f_d, us) - m.tau_max * m.lam - m.lam_lower * m.tau <= -m.lam_lower * m.tau_max)
    m.work_mccormick.deactivate()
    m.dead_work_lower = pyo.Constraint(expr=_dot(-ops.f_d, us) - m.lam_kinematic * m.tau >= 0.0)
    m.dead_work_lower.deactivate()
    m.objective = pyo.Objective(expr=m.lam, sense=pyo.minimize if sense == "min" else pyo.maximize)
    return PyomoProblem(
        name="mpec-bigm",
        model=m,
        variables={"lam": lam, "x": xs, "u": us, "z_u": zu, "z_f": zf, "y_u": yu, "y_f": yf, "tau": [m.tau]},
        constraints={
            "equilibrium": list(m.equilibrium.values()),
            "unilateral": list(m.unilateral.values()),
            "friction": list(m.friction.values()),
            "unilateral_bigm": list(m.unilateral_bigm.values()),
            "friction_bigm": list(m.friction_bigm.values()),
            "unilateral_switch": list(m.unilateral_switch.values()),
            "friction_switch": list(m.friction_switch.values()),
            "compatibility": list(m.compatibility.values()),
            "normalisation": [m.normalisation],
            "live_work": [m.live_work],
            "dead_work_cut": [m.dead_work_cut],
            "dead_work_lower": [m.dead_work_lower],
            "work_mccormick": [m.work_mccormick],
            "sliding_direction": list(m.sliding_direction.values()),
        },
    )


def compile_mixed_integer(problem: PyomoProblem) -> tuple[LinearProgram, np.ndarray]:
    """:func:`compile_linear` plus the integrality of each column.

    Returns
    -------
    lp : LinearProgram
    integrality : ndarray of int, shape (n_columns,)
        1 for a column whose Pyomo variable is integer (binary included), else 0.
    """
    active = {g: cs for g, cs in problem.constraints.items() if all(con.active for con in cs)}
    lp = compile_linear(PyomoProblem(problem.name, problem.model, problem.variables, active))
    integrality = np.zeros(lp.c.size, dtype=int)
    for group, variables in problem.variables.items():
        cols = lp.columns[group]
        for col, v in zip(cols, variables):
            if col >= 0 and (v.is_integer() or v.is_binary()):
                integrality[col] = 1
    return lp, integrality

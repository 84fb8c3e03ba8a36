r"""The tie-break LP of the fixed point: among the optimal forces of a step LP (5), pick one.

A step LP (5) (:func:`~blockmpec.formulations.static_lp.modified_lp`) at normal
forces ``n*`` often has many optimal force fields ``x``; the fixed point's map
``n* -> n`` is only single-valued once one of them is chosen.  The tie-break LP
keeps the step LP's constraints, holds ``lam`` at the step's optimum (less a
tolerance ``delta``) and minimises a weighted sum of the deviations from ``n*``
and of the normal forces::

    min  sum_k w_k d_k  +  sum_k c_k n_k
    s.t. E x + f_d + lam f_l = 0,  N_u^T x <= 0,
         [N_s^T x]_{2k+j} <= cohesion_k                 (the step LP's friction rows)
         -lam <= -lam_floor                                   (lam >= lam* - delta)
         n_k - d_k <= n*_k,   -n_k - d_k <= -n*_k,   d >= 0   (d_k >= |n_k - n*_k|)

At the optimum ``d_k = |n_k - n*_k|`` wherever ``w_k > 0``.  The weights select the
rule (set by the solver per step; this module fixes only the shape): ``w = 1,
c = 0`` is the point closest to ``n*`` in the 1-norm; ``c_k > 0`` prefers less
compression (``n_k`` closer to 0) on interface ``k``.  The right-hand sides
(cohesion, ``n*``, ``lam_floor``) are mutable parameters, so that one compiled LP
serves every step: the solver changes only row bounds and costs.
"""

from __future__ import annotations

import numpy as np
import pyomo.environ as pyo

from blockmpec.formulations.pyomo_compile import PyomoProblem
from blockmpec.formulations.static_lp import modified_lp
from blockmpec.operators import Operators


def tie_break_lp(ops: Operators, n_star: np.ndarray | None = None, slope: np.ndarray | None = None,
                 name: str = "tie-break-lp") -> PyomoProblem:
    """Build the tie-break LP of the step LP (5) at ``n_star`` (default 0), with unit weights ``w`` and ``c = 0``.

    Parameters
    ----------
    ops : Operators
    n_star : ndarray, shape (c,), optional
        The step's normal forces (compressive, ``<= 0``).
    slope : ndarray, shape (c,), optional
        Slope of the friction rows (default ``tan(psi)``; see :func:`modified_lp`).

    Returns
    -------
    PyomoProblem
        Groups: variables ``lam``, ``x``, ``d``; constraints ``equilibrium``,
        ``unilateral``, ``friction``, ``deviation_up``, ``deviation_down``, ``floor``.
    """
    c = ops.n_contacts
    n_star = np.zeros(c) if n_star is None else np.asarray(n_star, float)
    problem = modified_lp(ops, n_star, slope=slope, name=name)
    m = problem.model
    m.objective.deactivate()
    m.n_star = pyo.Param(range(c), mutable=True, initialize=dict(enumerate(n_star.tolist())))
    m.lam_floor = pyo.Param(mutable=True, initialize=-1e30)
    m.d = pyo.Var(range(c), within=pyo.NonNegativeReals)
    normal = [m.x[int(j)] for j in ops.normal_index]
    m.deviation_up = pyo.Constraint(range(c), rule=lambda mm, k: normal[k] - mm.d[k] <= mm.n_star[k])
    m.deviation_down = pyo.Constraint(range(c), rule=lambda mm, k: -normal[k] - mm.d[k] <= -mm.n_star[k])
    m.floor = pyo.Constraint(expr=-m.lam <= -m.lam_floor)
    m.tie_objective = pyo.Objective(expr=sum(m.d.values()), sense=pyo.minimize)
    problem.name = name
    problem.variables["d"] = list(m.d.values())
    problem.constraints["deviation_up"] = list(m.deviation_up.values())
    problem.constraints["deviation_down"] = list(m.deviation_down.values())
    problem.constraints["floor"] = [m.floor]
    return problem

r"""The MPEC (4): the smallest collapse multiplier over the solutions of the MCP (3)::

    min  lam
    s.t. (lam, x, u, z_u, z_f) solves (3)

Built as :func:`blockmpec.formulations.mcp.mcp` plus the objective; the complementarity
pairs stay ``pyomo.mpec.Complementarity`` components (a reformulation such as
``mpec.simple_nonlinear`` or a relaxation is the solver adapter's business).
"""

from __future__ import annotations

import pyomo.environ as pyo

from blockmpec.formulations.mcp import evaluate_mcp, mcp
from blockmpec.formulations.pyomo_compile import PyomoProblem
from blockmpec.operators import Operators

__all__ = ["evaluate_mcp", "mpec"]


def mpec(ops: Operators, name: str = "mpec") -> PyomoProblem:
    """Build the MPEC (4): the MCP (3) of :func:`~blockmpec.formulations.mcp.mcp` with ``min lam``.

    Returns
    -------
    PyomoProblem
        Same handles as :func:`~blockmpec.formulations.mcp.mcp`; the objective is ``model.objective``.
    """
    problem = mcp(ops, name=name)
    problem.model.objective = pyo.Objective(expr=problem.model.lam, sense=pyo.minimize)
    return problem

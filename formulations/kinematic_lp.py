r"""The kinematic LP (2)::

    min  -f_d^T u
    s.t. E^T u + N_u z_u + N_f z_f = 0     (compatibility, associative flow)
         f_l^T u = 1                        (normalisation)
         z_u >= 0, z_f >= 0

Its optimal value equals the static LP's (LP duality); the duals of the
compatibility rows are the interface forces ``x``.
"""

from __future__ import annotations

import pyomo.environ as pyo

from blockmpec.formulations.pyomo_compile import PyomoProblem, linear_dot, sparse_rows
from blockmpec.operators import Operators


def kinematic_lp(ops: Operators) -> PyomoProblem:
    """Build (2) from the operators."""
    nx = ops.E.shape[1]
    b3 = ops.E.shape[0]
    m = pyo.ConcreteModel(name="kinematic-lp")
    m.u = pyo.Var(range(b3))
    m.z_u = pyo.Var(range(ops.N_u.shape[1]), within=pyo.NonNegativeReals)
    m.z_f = pyo.Var(range(ops.N_f.shape[1]), within=pyo.NonNegativeReals)
    us, zu, zf = list(m.u.values()), list(m.z_u.values()), list(m.z_f.values())
    comp = sparse_rows([(ops.E.T, us), (ops.N_u, zu), (ops.N_f, zf)], nx)
    m.compatibility = pyo.Constraint(range(nx), rule=lambda _, i: comp(i) == 0.0)
    m.normalisation = pyo.Constraint(expr=linear_dot(ops.f_l, us) == 1.0)
    m.objective = pyo.Objective(expr=linear_dot(-ops.f_d, us), sense=pyo.minimize)
    return PyomoProblem(
        name="kinematic-lp",
        model=m,
        variables={"u": us, "z_u": zu, "z_f": zf},
        constraints={"compatibility": list(m.compatibility.values()), "normalisation": [m.normalisation]},
    )

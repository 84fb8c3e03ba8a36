r"""The static LP (1) and the modified associative LP (5).

Static theorem (1)::

    max  lam
    s.t. E x + f_d + lam f_l = 0        (equilibrium, one row per free-block dof)
         N_u^T x <= 0                    (no tension: |m| <= -n L/2)
         N_f^T x <= 0                    (Coulomb: |t| <= -mu n)

Modified LP (5) of the fixed-point method: the friction rows use ``tan(psi)`` and
a cohesion ``-n*_k (tan(phi) - tan(psi))`` per interface::

    |t_k| <= -n_k tan(psi) - n*_k (tan(phi) - tan(psi))
    i.e. [N_psi^T x]_{2k+j} <= cohesion_k,  j = 0, 1.

The cohesion is a mutable ``Param``: only the right-hand side changes between
fixed-point iterations.

``split_multiplier=True`` gives every free block its own copy ``lam_i`` of the
multiplier in its equilibrium rows, tied by the chain ``lam_0 = lam_1 = ... =
lam_{b-1}``.  The problem is the same; but ``lam`` no longer has a column with
one entry per block, which makes the normal matrix ``A D A^T`` of an
interior-point method dense (order ``b x b``) -- on a 10,000-block wall that
turned a minutes-long solve into a quarter of an hour.
"""

from __future__ import annotations

import numpy as np
import pyomo.environ as pyo
import scipy.sparse as sp

from blockmpec.formulations.pyomo_compile import PyomoProblem, sparse_rows
from blockmpec.operators import Operators


def static_lp(ops: Operators, friction: np.ndarray | None = None, cohesion: np.ndarray | None = None,
              name: str = "static-lp", split_multiplier: bool = False) -> PyomoProblem:
    """Build (1), or (5) when ``friction``/``cohesion`` are given.

    Parameters
    ----------
    ops : Operators
    friction : ndarray, shape (c,), optional
        Friction coefficient per contact in the friction rows (default ``ops.friction``).
    cohesion : ndarray, shape (c,), optional
        Right-hand side of every friction row of each contact (default 0).

    Row counts and the contact of each friction row come from the operators' layout
    (``ops.friction_contact``): the same statement in 2D (contacts = interfaces) and 3D (contact points).
    split_multiplier : bool
        One copy of ``lam`` per free block, chained by equalities (see the module docstring).
    """
    c = ops.n_contacts
    b3 = ops.E.shape[0]
    n_u, n_f = ops.N_u.shape[1], ops.N_f.shape[1]
    friction_contact = ops.friction_contact.tolist()
    N_f = ops.N_f if friction is None else ops.friction_operator(friction)
    coh = np.zeros(c) if cohesion is None else np.asarray(cohesion, float)
    m = pyo.ConcreteModel(name=name)
    m.lam = pyo.Var()
    m.x = pyo.Var(range(ops.E.shape[1]))
    xs = list(m.x.values())
    lam = [m.lam]
    constraints = {}
    if split_multiplier and b3 > ops.block_dofs:
        b = b3 // ops.block_dofs
        m.lam_copy = pyo.Var(range(1, b))
        copies = lam + list(m.lam_copy.values())
        rows = np.arange(b3)
        F_l = sp.csr_array((ops.f_l, (rows, rows // ops.block_dofs)), shape=(b3, b))
        eq = sparse_rows([(ops.E, xs), (F_l, copies)], b3)
        m.multiplier_chain = pyo.Constraint(range(1, b), rule=lambda _, i: copies[i] - copies[i - 1] == 0.0)
        constraints["multiplier_chain"] = list(m.multiplier_chain.values())
    else:
        eq = sparse_rows([(ops.E, xs), (ops.f_l.reshape(-1, 1), lam)], b3)
    m.equilibrium = pyo.Constraint(range(b3), rule=lambda _, i: eq(i) == -float(ops.f_d[i]))
    uni = sparse_rows([(ops.N_u.T, xs)], n_u)
    m.unilateral = pyo.Constraint(range(n_u), rule=lambda _, i: uni(i) <= 0.0)
    m.cohesion = pyo.Param(range(c), mutable=True, initialize=dict(enumerate(coh.tolist())))
    fr = sparse_rows([(N_f.T, xs)], n_f)
    m.friction = pyo.Constraint(range(n_f), rule=lambda mm, i: fr(i) <= mm.cohesion[friction_contact[i]])
    m.objective = pyo.Objective(expr=m.lam, sense=pyo.maximize)
    return PyomoProblem(
        name=name,
        model=m,
        variables={"lam": lam, "x": xs},
        constraints={
            "equilibrium": list(m.equilibrium.values()),
            "unilateral": list(m.unilateral.values()),
            "friction": list(m.friction.values()),
            **constraints,
        },
    )


def surface_slope(friction: np.ndarray, dilatancy: np.ndarray, alpha: float) -> np.ndarray:
    """The slope ``s = tan(psi) + alpha (tan(phi) - tan(psi))`` of the friction rows of a modified LP (5) tilted by
    ``alpha`` (``alpha = 0``: eq. (5), ``s = tan(psi)``; ``alpha = 1``: Coulomb's ``tan(phi)``)."""
    return dilatancy + alpha * (friction - dilatancy)


def cohesion_factor(friction: np.ndarray, slope: np.ndarray) -> np.ndarray:
    """``tan(phi) - s``: the factor of ``-n*`` in the friction rows' right-hand side of a modified LP (5) of slope
    ``s`` (:func:`modified_lp`)."""
    return friction - slope


def modified_lp(ops: Operators, n_star: np.ndarray, slope: np.ndarray | None = None,
                name: str = "modified-lp") -> PyomoProblem:
    """The modified associative LP (5) at normal forces ``n_star`` (shape (c,)).

    Friction rows ``|t_k| <= -s_k n_k - (tan(phi_k) - s_k) n*_k`` with slope ``s``
    (default ``tan(psi)``: eq. (5); ``s`` between ``tan(psi)`` and ``tan(phi)`` is the
    SLP's tilted surface).  Every such row passes through the Coulomb point at
    ``n = n*``.  The cohesion is the mutable ``Param`` ``model.cohesion``.
    """
    s = ops.dilatancy if slope is None else np.asarray(slope, float)
    cohesion = -np.asarray(n_star, float) * cohesion_factor(ops.friction, s)
    return static_lp(ops, friction=s, cohesion=cohesion, name=name)

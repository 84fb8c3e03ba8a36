r"""The non-associative limit-analysis MCP (3) as a Pyomo model with ``pyomo.mpec``.

Unknowns: ``lam`` (free), ``x`` (3c, free), ``u`` (3b, free), ``z_u >= 0`` and
``z_f >= 0`` (2c each).  Conditions::

    E x + f_d + lam f_l = 0                      (equilibrium, 3b rows)
    E^T u + N_u z_u + V_f z_f = 0                (compatibility, 3c rows; V_f uses tan(psi))
    f_l^T u = 1                                  (normalisation)
    N_u^T x <= 0   _|_   z_u >= 0                (unilateral pairs, 2c)
    N_f^T x <= 0   _|_   z_f >= 0                (friction pairs, 2c; N_f uses tan(phi))

The pairs are ``pyomo.mpec.Complementarity`` components built with
``complements(expr <= 0, z >= 0)``; all rows come from the sparse operators via
:func:`blockmpec.formulations.pyomo_compile.sparse_rows`.  The bounds ``z >= 0`` are stated both
as variable domains and as the second member of each pair.

The model is a statement of the problem, not a solver input: the linear
compiler cannot handle ``Complementarity`` components (deactivate them first).
:func:`evaluate_mcp` loads a :class:`~blockmpec.result.Solution` into the model
and evaluates every row and pair through Pyomo (``pyo.value``), an independent
cross-check of the operator-based verifier :func:`blockmpec.verify.residuals`.
"""

from __future__ import annotations

import numpy as np
import pyomo.environ as pyo
from pyomo.mpec import Complementarity, complements

from blockmpec.formulations.pyomo_compile import PyomoProblem, linear_dot, sparse_rows
from blockmpec.operators import Operators
from blockmpec.result import Solution


def mcp(ops: Operators, name: str = "mcp", dilatancy: np.ndarray | None = None) -> PyomoProblem:
    """Build the MCP (3).

    Parameters
    ----------
    ops : Operators
    name : str
    dilatancy : ndarray, shape (c,), optional
        ``tan(psi)`` per interface in the flow rows (default ``ops.dilatancy``); the
        continuation of ``mcp-newton`` uses other values.

    Returns
    -------
    PyomoProblem
        ``variables``: ``"lam"`` (1), ``"x"`` (3c), ``"u"`` (3b), ``"z_u"``, ``"z_f"`` (2c).
        ``constraints``: ``"equilibrium"`` (3b), ``"compatibility"`` (3c),
        ``"normalisation"`` (1), ``"unilateral"``, ``"friction"`` (2c each: the pair rows
        ``N_u^T x <= 0``, ``N_f^T x <= 0``) ``Constraint`` data, and ``"unilateral_pairs"``,
        ``"friction_pairs"`` (2c each) ``Complementarity`` data, in operator order.
    """
    c = ops.n_contacts
    nx, b3 = ops.E.shape[1], ops.E.shape[0]
    n_u, n_f = ops.N_u.shape[1], ops.N_f.shape[1]
    V_f = ops.V_f if dilatancy is None else ops.friction_operator(np.broadcast_to(dilatancy, (c,)))
    m = pyo.ConcreteModel(name=name)
    m.lam = pyo.Var()
    m.x = pyo.Var(range(nx))
    m.u = pyo.Var(range(b3))
    m.z_u = pyo.Var(range(n_u), within=pyo.NonNegativeReals)
    m.z_f = pyo.Var(range(n_f), within=pyo.NonNegativeReals)
    lam = [m.lam]
    xs, us = list(m.x.values()), list(m.u.values())
    zu, zf = list(m.z_u.values()), list(m.z_f.values())

    eq = sparse_rows([(ops.E, xs), (ops.f_l.reshape(-1, 1), lam)], b3)
    m.equilibrium = pyo.Constraint(range(b3), rule=lambda _, i: eq(i) == -float(ops.f_d[i]))
    comp = sparse_rows([(ops.E.T, us), (ops.N_u, zu), (V_f, zf)], nx)
    m.compatibility = pyo.Constraint(range(nx), rule=lambda _, i: comp(i) == 0.0)
    m.normalisation = pyo.Constraint(expr=linear_dot(ops.f_l, us) == 1.0)

    # the pair constraints are written once, as rows g(x) <= 0; each pair complements
    # the body of its row with its multiplier (compile_mcp compiles the rows)
    uni = sparse_rows([(ops.N_u.T, xs)], n_u)
    fr = sparse_rows([(ops.N_f.T, xs)], n_f)
    m.unilateral = pyo.Constraint(range(n_u), rule=lambda _, i: uni(i) <= 0.0)
    m.friction = pyo.Constraint(range(n_f), rule=lambda _, i: fr(i) <= 0.0)
    m.unilateral_pairs = Complementarity(
        range(n_u), rule=lambda mm, i: complements(mm.unilateral[i].body <= 0.0, mm.z_u[i] >= 0))
    m.friction_pairs = Complementarity(
        range(n_f), rule=lambda mm, i: complements(mm.friction[i].body <= 0.0, mm.z_f[i] >= 0))
    return PyomoProblem(
        name=name,
        model=m,
        variables={"lam": lam, "x": xs, "u": us, "z_u": zu, "z_f": zf},
        constraints={
            "equilibrium": list(m.equilibrium.values()),
            "compatibility": list(m.compatibility.values()),
            "normalisation": [m.normalisation],
            "unilateral": list(m.unilateral.values()),
            "friction": list(m.friction.values()),
            "unilateral_pairs": [m.unilateral_pairs[i] for i in range(n_u)],
            "friction_pairs": [m.friction_pairs[i] for i in range(n_f)],
        },
    )


def load_solution(problem: PyomoProblem, solution: Solution) -> None:
    """Set the model's variable values from ``solution`` (fields that are None are skipped)."""
    values = {"lam": None if solution.multiplier is None else [solution.multiplier],
              "x": solution.x, "u": solution.u, "z_u": solution.z_u, "z_f": solution.z_f}
    for group, vals in values.items():
        if vals is None or group not in problem.variables:
            continue
        vars_ = problem.variables[group]
        vals = np.asarray(vals, float).reshape(-1)
        if vals.size != len(vars_):
            raise ValueError(f"solution field {group!r} has {vals.size} entries; the model has {len(vars_)}")
        for v, val in zip(vars_, vals.tolist()):
            v.set_value(val, skip_validation=True)


def _pair_values(pairs: list) -> tuple[np.ndarray, np.ndarray]:
    """``(g, z)`` of pairs ``g(x) <= 0 _|_ z >= 0``, each side evaluated by Pyomo.

    The sides are read from ``ComplementarityData._args`` (pyomo.mpec keeps the two
    relational expressions there; it has no public accessor) and put in the form
    ``lower <= body <= upper``; ``g`` is ``body - upper`` and ``z`` is ``body - lower``.
    """
    g = np.empty(len(pairs))
    z = np.empty(len(pairs))
    for i, pair in enumerate(pairs):
        lo0, body0, up0 = pair._canonical_expression(pair._args[0])
        lo1, body1, up1 = pair._canonical_expression(pair._args[1])
        g[i] = pyo.value(body0) - pyo.value(up0)
        z[i] = pyo.value(body1) - pyo.value(lo1)
        if lo0 is not None or up1 is not None:
            raise ValueError(f"pair {pair.name} is not of the form g <= 0 _|_ z >= 0")
    return g, z


def evaluate_mcp(problem: PyomoProblem, solution: Solution) -> dict[str, np.ndarray]:
    """Load ``solution`` into the MCP model and evaluate (3) through Pyomo.

    Parameters
    ----------
    problem : PyomoProblem
        From :func:`mcp` (or :func:`blockmpec.formulations.mpec.mpec`).
    solution : Solution
        Needs every field (lam, x, u, z_u, z_f).

    Returns
    -------
    dict[str, ndarray]
        ``"equilibrium"`` (3b) and ``"compatibility"`` (3c): row residuals
        ``body - rhs``; ``"normalisation"`` (1): ``f_l^T u - 1``;
        ``"unilateral_slack"``, ``"friction_slack"`` (2c): ``N_u^T x``, ``N_f^T x``;
        ``"z_u"``, ``"z_f"``: the multipliers as read back from the pairs;
        ``"unilateral_product"``, ``"friction_product"``: ``g_i z_i`` per pair.
        Each value is computed by ``pyo.value`` from the model's own expressions.
    """
    load_solution(problem, solution)
    out: dict[str, np.ndarray] = {}
    for group in ("equilibrium", "compatibility", "normalisation"):
        cons = problem.constraints[group]
        out[group] = np.array([pyo.value(con.body) - pyo.value(con.upper) for con in cons])
    for kind in ("unilateral", "friction"):
        g, z = _pair_values(problem.constraints[f"{kind}_pairs"])
        out[f"{kind}_slack"] = g
        out["z_u" if kind == "unilateral" else "z_f"] = z
        out[f"{kind}_product"] = g * z
    return out


def mcp_violation(values: dict[str, np.ndarray]) -> dict[str, float]:
    """Absolute violations of (3) from :func:`evaluate_mcp` values (max norms).

    Returns
    -------
    dict[str, float]
        ``equilibrium``, ``compatibility``, ``normalisation`` (max |row|),
        ``unilateral_admissibility``, ``friction_admissibility`` (max positive slack),
        ``multiplier_sign`` (max negative part of ``z``),
        ``unilateral_complementarity``, ``friction_complementarity`` (max |g z|).
    """
    def mx(a: np.ndarray) -> float:
        return float(np.max(a)) if a.size else 0.0

    return {
        "equilibrium": mx(np.abs(values["equilibrium"])),
        "compatibility": mx(np.abs(values["compatibility"])),
        "normalisation": mx(np.abs(values["normalisation"])),
        "unilateral_admissibility": mx(np.maximum(values["unilateral_slack"], 0.0)),
        "friction_admissibility": mx(np.maximum(values["friction_slack"], 0.0)),
        "multiplier_sign": mx(np.maximum(-np.concatenate([values["z_u"], values["z_f"]]), 0.0)),
        "unilateral_complementarity": mx(np.abs(values["unilateral_product"])),
        "friction_complementarity": mx(np.abs(values["friction_product"])),
    }

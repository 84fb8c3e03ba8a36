"""Helpers: sparse rows into Pyomo, and a compiled matrix form of linear models."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pyomo.environ as pyo
import scipy.sparse as sp
from pyomo.core.expr.numeric_expr import LinearExpression
from pyomo.repn.plugins.standard_form import LinearStandardFormCompiler


@dataclass
class PyomoProblem:
    """A Pyomo model with typed handles to its variable and constraint groups.

    Attributes
    ----------
    name : str
    model : pyomo.environ.ConcreteModel
    variables : dict[str, list]
        Group name -> list of ``VarData`` in operator order (e.g. ``"x"`` has 3c entries).
    constraints : dict[str, list]
        Group name -> list of ``ConstraintData`` in operator order.
    """

    name: str
    model: pyo.ConcreteModel
    variables: dict[str, list] = field(default_factory=dict)
    constraints: dict[str, list] = field(default_factory=dict)


def sparse_rows(blocks: list[tuple[sp.sparray, list]], n_rows: int):
    """A rule for an indexed Constraint body: row ``i`` of ``sum_k A_k @ vars_k``.

    Parameters
    ----------
    blocks : list of (matrix, variables)
        Each matrix has ``n_rows`` rows and one column per variable in its list.
    n_rows : int

    Returns
    -------
    callable
        ``body(i) -> LinearExpression`` (no per-element Python loops over entries
        beyond slicing the CSR arrays of row ``i``).
    """
    A = sp.hstack([sp.csr_array(m) for m, _ in blocks], format="csr")
    A.sum_duplicates()
    A.eliminate_zeros()
    assert A.shape[0] == n_rows
    cols = [v for _, vs in blocks for v in vs]
    indptr, indices, data = A.indptr, A.indices.tolist(), A.data.tolist()

    def body(i: int) -> LinearExpression:
        a, b = indptr[i], indptr[i + 1]
        return LinearExpression(constant=0.0, linear_coefs=data[a:b], linear_vars=[cols[j] for j in indices[a:b]])

    return body


def linear_dot(coef: np.ndarray, variables: list) -> LinearExpression:
    """``sum_i coef[i] * variables[i]`` over the nonzero coefficients, as one LinearExpression."""
    nz = np.flatnonzero(coef)
    return LinearExpression(constant=0.0, linear_coefs=coef[nz].tolist(), linear_vars=[variables[i] for i in nz])


@dataclass
class LinearProgram:
    r"""A compiled linear model: :math:`\min c^T v` s.t. ``row_lower <= A v <= row_upper``,
    ``col_lower <= v <= col_upper``.

    ``columns[g][i]`` is the column of element ``i`` of variable group ``g`` (-1
    when the variable appears nowhere); ``rows[g][i]`` the row of element ``i`` of
    constraint group ``g``.  ``objective_sign`` is -1 when the model maximised (then
    ``c`` is the negated objective).
    """

    c: np.ndarray
    A: sp.csr_array
    row_lower: np.ndarray
    row_upper: np.ndarray
    col_lower: np.ndarray
    col_upper: np.ndarray
    columns: dict[str, np.ndarray]
    rows: dict[str, np.ndarray]
    objective_sign: float
    objective_offset: float = 0.0

    def values(self, group: str, v: np.ndarray) -> np.ndarray:
        """Values of variable group ``group`` from a column vector ``v``."""
        col = self.columns[group]
        return np.where(col >= 0, v[np.maximum(col, 0)], 0.0)

    def row_values(self, group: str, y: np.ndarray) -> np.ndarray:
        """Entries of a row vector ``y`` (e.g. duals) for constraint group ``group``."""
        return y[self.rows[group]]


def compile_linear(problem: PyomoProblem) -> LinearProgram:
    """Compile a linear Pyomo problem to a :class:`LinearProgram` (once)."""
    model = problem.model
    info = LinearStandardFormCompiler().write(model, mixed_form=True, set_sense=pyo.minimize)
    col_of = {id(v): k for k, v in enumerate(info.columns)}
    row_of = {id(r.constraint): k for k, r in enumerate(info.rows)}
    bound_type = np.array([r.bound_type for r in info.rows], dtype=int)
    rhs = np.asarray(info.rhs, dtype=float)
    row_lower = np.where(bound_type <= 0, rhs, -np.inf)
    row_upper = np.where(bound_type >= 0, rhs, np.inf)
    col_lower = np.array([-np.inf if v.lb is None else v.lb for v in info.columns], dtype=float)
    col_upper = np.array([np.inf if v.ub is None else v.ub for v in info.columns], dtype=float)
    columns = {g: np.array([col_of.get(id(v), -1) for v in vs], dtype=int) for g, vs in problem.variables.items()}
    rows = {g: np.array([row_of[id(c)] for c in cs], dtype=int) for g, cs in problem.constraints.items()}
    # a model without objective (the MCP) compiles to c = 0
    sign = -1.0 if info.objectives and info.objectives[0].sense == pyo.maximize else 1.0
    c = np.asarray(info.c.toarray()).reshape(-1) if info.c.shape[0] else np.zeros(len(info.columns))
    c = c if c.size == len(info.columns) else np.zeros(len(info.columns))
    return LinearProgram(
        c=c,
        A=sp.csr_array(info.A),
        row_lower=row_lower,
        row_upper=row_upper,
        col_lower=col_lower,
        col_upper=col_upper,
        columns=columns,
        rows=rows,
        objective_sign=sign,
        objective_offset=float(np.asarray(info.c_offset).reshape(-1)[0]) if len(info.c_offset) else 0.0,
    )

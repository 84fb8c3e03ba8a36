"""Helpers: sparse rows into Pyomo, a compiled matrix form of linear models, and its cache.

Build and compile run with Python's cyclic garbage collector paused (Pyomo's
``PauseGC``): a model is hundreds of thousands of small objects, none of them garbage,
and the collector's passes over them were 3/4 of the build time (1,001-block wall:
build 1.8 s -> 0.45 s, compile 0.9 s -> 0.5 s in one run).

:func:`compiled_linear` caches compiled models per structure, keyed by a content hash
of the operators (every array of :class:`~blockmpec.operators.Operators`) and of the
builder's arguments: in memory (the last :data:`MEMORY_CACHE_SIZE` models) and, only
when the environment variable ``BLOCKMPEC_CACHE_DIR`` names a directory, on disk there
(nothing is ever written by default).  Each call returns its own copy, which engines
may modify (``set_row_upper``).
"""

from __future__ import annotations

import functools
import hashlib
import os
from collections import OrderedDict
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np
import pyomo.environ as pyo
import scipy.sparse as sp
from pyomo.common.gc_manager import PauseGC
from pyomo.core.expr.numeric_expr import LinearExpression
from pyomo.repn.plugins.standard_form import LinearStandardFormCompiler

#: compiled models kept in memory by :func:`compiled_linear`
MEMORY_CACHE_SIZE = 8
#: environment variable naming an on-disk cache directory (opt-in)
CACHE_DIR_VARIABLE = "BLOCKMPEC_CACHE_DIR"


def pause_gc(builder):
    """Decorator: run a model builder with the cyclic garbage collector paused (see the module docstring)."""

    @functools.wraps(builder)
    def wrapper(*args, **kwargs):
        with PauseGC():
            return builder(*args, **kwargs)

    return wrapper


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


@pause_gc
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


def _hash_value(h, value) -> None:
    """Feed ``value`` (array, sparse matrix, number, string, None, tuple/list/dict of those) into ``h``."""
    if value is None or isinstance(value, (bool, int, float, str)):
        h.update(f"{type(value).__name__}:{value!r};".encode())
    elif sp.issparse(value):
        m = sp.csr_array(value)
        m.sort_indices()
        h.update(f"sparse{m.shape}{m.dtype};".encode())
        for a in (m.indptr, m.indices, m.data):
            h.update(np.ascontiguousarray(a).tobytes())
    elif isinstance(value, np.ndarray):
        h.update(f"array{value.shape}{value.dtype};".encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, (tuple, list)):
        h.update(f"seq{len(value)};".encode())
        for v in value:
            _hash_value(h, v)
    elif isinstance(value, dict):
        h.update(f"dict{len(value)};".encode())
        for k in sorted(value):
            h.update(f"{k!s}=".encode())
            _hash_value(h, value[k])
    elif hasattr(value, "__dataclass_fields__"):
        h.update(f"{type(value).__qualname__};".encode())
        for f in fields(value):
            h.update(f"{f.name}=".encode())
            _hash_value(h, getattr(value, f.name))
    else:
        raise TypeError(f"compiled_linear: cannot hash an argument of type {type(value).__name__}")


@functools.lru_cache(maxsize=1)
def _formulations_source_hash() -> str:
    """SHA-256 of the formulations' source files: a changed builder never reads an old disk cache."""
    h = hashlib.sha256()
    for path in sorted(Path(__file__).parent.glob("*.py")):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def content_hash(builder, *args, **kwargs) -> str:
    """SHA-256 of the formulations' source, a builder's name and the contents of its arguments."""
    h = hashlib.sha256(f"{_formulations_source_hash()};{builder.__module__}.{builder.__qualname__};".encode())
    _hash_value(h, list(args))
    _hash_value(h, kwargs)
    return h.hexdigest()


_memory_cache: OrderedDict[str, LinearProgram] = OrderedDict()


def _copy(lp: LinearProgram) -> LinearProgram:
    return LinearProgram(
        c=lp.c.copy(), A=lp.A.copy(), row_lower=lp.row_lower.copy(), row_upper=lp.row_upper.copy(),
        col_lower=lp.col_lower.copy(), col_upper=lp.col_upper.copy(),
        columns={g: v.copy() for g, v in lp.columns.items()}, rows={g: v.copy() for g, v in lp.rows.items()},
        objective_sign=lp.objective_sign, objective_offset=lp.objective_offset,
    )


def _save(lp: LinearProgram, path: Path) -> None:
    A = sp.csr_array(lp.A)
    arrays = {"c": lp.c, "A_data": A.data, "A_indices": A.indices, "A_indptr": A.indptr,
              "A_shape": np.array(A.shape), "row_lower": lp.row_lower, "row_upper": lp.row_upper,
              "col_lower": lp.col_lower, "col_upper": lp.col_upper,
              "scalars": np.array([lp.objective_sign, lp.objective_offset])}
    arrays.update({f"columns/{g}": v for g, v in lp.columns.items()})
    arrays.update({f"rows/{g}": v for g, v in lp.rows.items()})
    tmp = path.with_suffix(f".{os.getpid()}.tmp.npz")
    np.savez(tmp, **arrays)
    os.replace(tmp, path)


def _load(path: Path) -> LinearProgram:
    with np.load(path) as f:
        A = sp.csr_array((f["A_data"], f["A_indices"], f["A_indptr"]), shape=tuple(f["A_shape"]))
        sign, offset = (float(v) for v in f["scalars"])
        return LinearProgram(
            c=f["c"], A=A, row_lower=f["row_lower"], row_upper=f["row_upper"], col_lower=f["col_lower"],
            col_upper=f["col_upper"],
            columns={k.split("/", 1)[1]: f[k] for k in f.files if k.startswith("columns/")},
            rows={k.split("/", 1)[1]: f[k] for k in f.files if k.startswith("rows/")},
            objective_sign=sign, objective_offset=offset,
        )


def compiled_linear(builder, *args, **kwargs) -> LinearProgram:
    """``compile_linear(builder(*args, **kwargs))``, cached by :func:`content_hash` (see the module docstring).

    ``builder`` is a formulation builder (e.g. :func:`blockmpec.formulations.static_lp`)
    whose model depends only on its arguments.  A cache miss builds the Pyomo model and
    compiles it; a hit returns a copy of the compiled matrices without building.
    """
    try:
        key = content_hash(builder, *args, **kwargs)
    except TypeError:  # an argument without a content hash: no caching
        return compile_linear(pause_gc(builder)(*args, **kwargs))
    lp = _memory_cache.get(key)
    directory = os.environ.get(CACHE_DIR_VARIABLE)
    path = Path(directory) / f"{key}.npz" if directory else None
    if lp is None and path is not None and path.is_file():
        try:
            lp = _load(path)
        except (OSError, ValueError, KeyError):
            lp = None  # a damaged cache file is rebuilt and overwritten
    if lp is None:
        lp = compile_linear(pause_gc(builder)(*args, **kwargs))
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
            _save(lp, path)
    _memory_cache[key] = lp
    _memory_cache.move_to_end(key)
    while len(_memory_cache) > MEMORY_CACHE_SIZE:
        _memory_cache.popitem(last=False)
    return _copy(lp)


def clear_cache() -> None:
    """Empty the in-memory cache of :func:`compiled_linear` (the on-disk one is the user's directory)."""
    _memory_cache.clear()

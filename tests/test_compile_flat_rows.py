"""compile_linear's direct reading of flat rows equals Pyomo's LinearStandardFormCompiler, entry for entry.

``compile_linear`` reads models built from ``sparse_rows``/``linear_dot`` without Pyomo's
expression walk, and hands every other model to Pyomo's compiler.  Either way the
matrices, bounds, row and column maps must be exactly those of Pyomo's compiler
(``compile_with_pyomo``): engines and the block IPM's ordering depend on them.
"""

import numpy as np
import pyomo.environ as pyo
import pytest
import scipy.sparse as sp

import blockmpec as bm
from blockmpec.formulations import kinematic_lp, mcp, modified_lp, pyomo_compile, static_lp, tie_break_lp
from blockmpec.formulations.pyomo_compile import (
    PyomoProblem,
    compile_linear,
    compile_with_pyomo,
    linear_dot,
    sparse_rows,
)
from helpers import assert_same_program


def _mcp_rows(ops):
    """The MCP's linear rows with its complementarity blocks deactivated, as compile_mcp compiles them."""
    problem = mcp(ops)
    for comp in (problem.model.unilateral_pairs, problem.model.friction_pairs):
        comp.deactivate()
    groups = {g: problem.constraints[g] for g in ("equilibrium", "compatibility", "normalisation", "unilateral",
                                                   "friction")}
    return PyomoProblem(problem.name, problem.model, problem.variables, groups)


BUILDERS = {
    "static-lp": lambda ops: static_lp(ops),
    "static-lp split multiplier": lambda ops: static_lp(ops, split_multiplier=True),
    "modified-lp": lambda ops: modified_lp(ops, -np.linspace(0.5, 2.0, ops.n_interfaces)),
    "kinematic-lp": kinematic_lp,
    "tie-break-lp": lambda ops: tie_break_lp(ops, -np.ones(ops.n_interfaces)),
    "mcp rows": _mcp_rows,
}


@pytest.mark.parametrize("case", ["wall", "round-arch", "two-blocks"])
@pytest.mark.parametrize("builder", list(BUILDERS))
def test_every_formulation_compiles_flat_and_equals_pyomos_compiler(case, builder):
    ops = bm.assemble(bm.cases.build_case(case))
    problem = BUILDERS[builder](ops)
    flat = pyomo_compile.compile_flat_rows(problem)
    assert flat is not None, f"{builder} no longer compiles on the flat path"
    assert_same_program(flat, compile_with_pyomo(problem))


def _toy(kind: str) -> PyomoProblem:
    """A small model that the flat reader must decline (or read through its general loop)."""
    m = pyo.ConcreteModel()
    m.x = pyo.Var(range(3), bounds=(-1.0, 4.0))
    m.y = pyo.Var()
    xs = list(m.x.values())
    rows = sparse_rows([(sp.csr_array(np.array([[1.0, 2.0, 0.0], [0.0, -1.0, 3.0]])), xs)], 2)
    m.a = pyo.Constraint(range(2), rule=lambda _, i: rows(i) <= 1.0 + i)
    m.objective = pyo.Objective(expr=linear_dot(np.array([1.0, 0.0, -2.0]), xs), sense=pyo.maximize)
    if kind == "ranged":
        m.r = pyo.Constraint(expr=pyo.inequality(-2.0, rows(0), 5.0))
    elif kind == "mutable coefficient":
        m.p = pyo.Param(mutable=True, initialize=2.5)
        m.r = pyo.Constraint(expr=m.p * m.x[0] + m.y >= 0.5)
    elif kind == "fixed variable":
        m.y.fix(3.0)
        m.r = pyo.Constraint(expr=m.x[0] + m.y <= 7.0)
    elif kind == "repeated variable":
        m.r = pyo.Constraint(expr=m.x[0] + 2.0 * m.x[0] - m.y == 0.0)
    elif kind == "constant in body":
        m.r = pyo.Constraint(expr=m.x[1] + 4.0 - m.y <= 2.0)
    elif kind == "expression component":
        m.e = pyo.Expression(expr=m.x[0] - m.y)
        m.r = pyo.Constraint(expr=m.e <= 1.0)
    return PyomoProblem("toy", m, {"x": xs, "y": [m.y]}, {"a": list(m.a.values())})


@pytest.mark.parametrize("kind", ["plain", "ranged", "mutable coefficient", "fixed variable", "repeated variable",
                                  "constant in body", "expression component"])
def test_compile_linear_equals_pyomos_compiler_on_models_outside_the_bulk_path(kind):
    problem = _toy(kind)
    assert_same_program(compile_linear(problem), compile_with_pyomo(problem))


@pytest.mark.parametrize("kind,flat", [("plain", True), ("ranged", True), ("constant in body", True),
                                       ("mutable coefficient", False), ("fixed variable", False),
                                       ("repeated variable", False), ("expression component", False)])
def test_flat_reader_declines_what_pyomos_compiler_must_do(kind, flat):
    """Symbolic coefficients, fixed or repeated variables and named expressions go to Pyomo's compiler."""
    assert (pyomo_compile.compile_flat_rows(_toy(kind)) is not None) is flat


def test_a_changed_parameter_bound_is_read_at_compile_time():
    ops = bm.assemble(bm.cases.wall())
    problem = static_lp(ops)
    problem.model.cohesion[0] = 0.25
    lp = compile_linear(problem)
    assert lp.row_upper[lp.rows["friction"][0]] == 0.25 and lp.row_upper[lp.rows["friction"][1]] == 0.25
    assert_same_program(lp, compile_with_pyomo(problem))

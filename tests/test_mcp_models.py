"""Pyomo statements of the MCP (3) and the MPEC (4), cross-checked against the operator verifier."""

import numpy as np
import pyomo.environ as pyo
import pytest
from pyomo.mpec import Complementarity

import blockmpec as bm
from blockmpec.formulations.mcp import evaluate_mcp, mcp, mcp_violation
from blockmpec.formulations.mpec import mpec
from blockmpec.operators import assemble
from blockmpec.verify import positive_part_ratio, residuals


@pytest.fixture(scope="module")
def two_blocks_ops():
    return assemble(bm.cases.two_blocks(eta=3.0, mu=0.65))


def test_mcp_sizes_and_handles(two_blocks_ops):
    ops = two_blocks_ops
    c, b3 = ops.n_interfaces, ops.E.shape[0]
    p = mcp(ops)
    sizes = {g: len(v) for g, v in p.variables.items()}
    assert sizes == {"lam": 1, "x": 3 * c, "u": b3, "z_u": 2 * c, "z_f": 2 * c}
    assert len(p.constraints["equilibrium"]) == b3
    assert len(p.constraints["compatibility"]) == 3 * c
    assert len(p.constraints["normalisation"]) == 1
    assert len(p.constraints["unilateral_pairs"]) == 2 * c
    assert len(p.constraints["friction_pairs"]) == 2 * c
    comps = list(p.model.component_objects(Complementarity))
    assert {cc.local_name for cc in comps} == {"unilateral_pairs", "friction_pairs"}
    assert all(v.lb == 0 for v in p.variables["z_u"] + p.variables["z_f"])
    assert not list(p.model.component_objects(pyo.Objective))


def test_mpec_is_mcp_plus_min_lam(two_blocks_ops):
    p = mpec(two_blocks_ops)
    objs = list(p.model.component_data_objects(pyo.Objective, active=True))
    assert len(objs) == 1
    assert objs[0].sense == pyo.minimize
    assert objs[0].expr is p.model.lam


@pytest.mark.parametrize("case", [bm.cases.two_blocks(eta=3.0, mu=0.65), bm.cases.wall()])
def test_pyomo_model_agrees_with_verifier_on_fixed_point(case):
    """The Pyomo rows, evaluated by pyo.value, equal the operator products, and both call it a solution."""
    ops = assemble(case)
    res = bm.solve(ops, "fixed-point", tie_break="none")
    assert res.status is bm.Status.CONVERGED
    sol = res.solution
    vals = evaluate_mcp(mpec(ops), sol)
    lam, x, u, z_u, z_f = sol.multiplier, sol.x, sol.u, sol.z_u, sol.z_f
    np.testing.assert_allclose(vals["equilibrium"], ops.E @ x + ops.f_d + lam * ops.f_l, atol=1e-12)
    np.testing.assert_allclose(vals["compatibility"], ops.E.T @ u + ops.N_u @ z_u + ops.V_f @ z_f, atol=1e-12)
    np.testing.assert_allclose(vals["normalisation"], [ops.f_l @ u - 1.0], atol=1e-12)
    np.testing.assert_allclose(vals["unilateral_slack"], ops.N_u.T @ x, atol=1e-12)
    np.testing.assert_allclose(vals["friction_slack"], ops.N_f.T @ x, atol=1e-12)
    np.testing.assert_array_equal(vals["z_u"], z_u)
    np.testing.assert_array_equal(vals["z_f"], z_f)
    # the verifier's friction measure computed from the Pyomo values is the verifier's own
    ref = residuals(ops, sol, associative=False)
    assert positive_part_ratio(vals["friction_slack"]) == pytest.approx(ref["friction_admissibility"], abs=1e-15)
    assert max(ref.values()) <= 1e-7
    viol = mcp_violation(vals)
    scale = max(1.0, float(np.abs(x).max()), float(np.abs(np.concatenate([z_u, z_f])).max()))
    assert max(viol.values()) <= 1e-7 * scale**2


def test_pyomo_model_rejects_associative_mechanism(two_blocks_ops):
    """The associative LP mechanism has dilatancy: both checks see the compatibility violation."""
    ops = two_blocks_ops
    res = bm.solve(ops, "static-lp")
    vals = evaluate_mcp(mcp(ops), res.solution)
    viol = mcp_violation(vals)
    ref = residuals(ops, res.solution, associative=False)
    assert viol["compatibility"] > 1e-3
    assert ref["compatibility"] > 1e-3
    assert viol["friction_admissibility"] <= 1e-9  # the forces themselves are admissible

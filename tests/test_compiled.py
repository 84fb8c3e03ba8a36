"""The compiled MCP (3) (``blockmpec.formulations.compile_mcp``) against the operators.

``CompiledMCP`` is what ``nlp``, ``mcp-newton`` and ``milp`` read instead of the
operators, so every block must equal its operator entry for entry (no tolerance):
``E``, ``E^T``, ``[N_u, V_f]``, ``[N_u, N_f]^T``, ``f_l``, ``f_d``; the pairs must
sit where the named slices say; ``with_dilatancy`` must equal the flow operator
built at the new ``tan(psi)``; and the Pyomo model itself (``evaluate_mcp``) must
give ``A w - rhs`` at any point.
"""

import numpy as np
import pytest
import scipy.sparse as sp

import blockmpec as bm
from blockmpec.formulations import compile_mcp, evaluate_mcp, mcp
from blockmpec.formulations.compiled import FRICTION, UNILATERAL

CASES = {
    "two-blocks-dilatant": lambda: bm.cases.two_blocks(eta=3, mu=0.65, dilatancy=0.2),
    "round-arch": lambda: bm.cases.round_arch(n_voussoirs=8),
    "wall-3x3": lambda: bm.cases.wall(3, 3, mu=0.6, dilatancy=0.1),
}


@pytest.fixture(scope="module", params=list(CASES))
def compiled(request):
    ops = bm.assemble(CASES[request.param]())
    return ops, compile_mcp(ops)


def assert_same_sparse(a, b):
    a, b = sp.csr_array(a), sp.csr_array(b)
    assert a.shape == b.shape
    assert (a != b).nnz == 0, f"{(a != b).nnz} entries differ"


def test_blocks_equal_the_operators(compiled):
    ops, form = compiled
    c, b = ops.n_interfaces, ops.n_free_blocks
    assert form.n_columns == 1 + 3 * c + 3 * b + 4 * c
    assert form.A.shape == (3 * b + 3 * c + 1, form.n_columns) and form.G.shape == (4 * c, form.n_columns)
    eq, comp, norm = form.equilibrium, form.compatibility, form.normalisation
    # equilibrium: [f_l, E, 0, 0] w = -f_d
    assert_same_sparse(form.block(eq, form.x), ops.E)
    np.testing.assert_array_equal(form.f_l, ops.f_l)
    np.testing.assert_array_equal(form.f_d, ops.f_d)
    assert form.block(eq, form.u).nnz == 0 and form.block(eq, form.z).nnz == 0
    # compatibility: [0, 0, E^T, N_u | V_f] w = 0
    assert_same_sparse(form.block(comp, form.u), ops.E.T)
    assert_same_sparse(form.block(comp, form.z), sp.hstack([ops.N_u, ops.V_f]))
    assert_same_sparse(form.block(comp, form.z_u), ops.N_u)
    assert_same_sparse(form.block(comp, form.z_f), ops.V_f)
    assert form.block(comp, slice(0, form.u.start)).nnz == 0
    np.testing.assert_array_equal(form.rhs[comp], 0.0)
    # normalisation: f_l^T u = 1
    assert_same_sparse(form.block(norm, form.u), ops.f_l.reshape(1, -1))
    assert form.block(norm, form.x).nnz == 0 and form.block(norm, form.z).nnz == 0
    np.testing.assert_array_equal(form.rhs[norm], [1.0])
    # pair rows: [N_u, N_f]^T x <= 0, nothing outside the x columns
    assert_same_sparse(form.pair_matrix, sp.hstack([ops.N_u, ops.N_f]).T)
    assert_same_sparse(form.G[:, form.x], form.pair_matrix)
    assert form.G.nnz == form.pair_matrix.nnz
    np.testing.assert_array_equal(form.friction, ops.friction)
    np.testing.assert_array_equal(form.dilatancy, ops.dilatancy)


def test_pair_layout(compiled):
    ops, form = compiled
    c = ops.n_interfaces
    # pair i (row i of G) complements the multiplier column pair_column[i]: z_u then z_f, in operator order
    np.testing.assert_array_equal(form.pair_column, np.arange(form.z.start, form.z.stop))
    np.testing.assert_array_equal(form.pair_column[form.unilateral], np.arange(form.z_u.start, form.z_u.stop))
    np.testing.assert_array_equal(form.pair_column[form.friction_pairs], np.arange(form.z_f.start, form.z_f.stop))
    np.testing.assert_array_equal(form.pair_kind[form.unilateral], UNILATERAL)
    np.testing.assert_array_equal(form.pair_kind[form.friction_pairs], FRICTION)
    # two pairs of each kind per interface, interface k's pairs touching only its own forces (t_k, n_k, m_k)
    np.testing.assert_array_equal(np.bincount(form.pair_interface, minlength=c), np.full(c, 4))
    rows, cols = form.pair_matrix.nonzero()
    np.testing.assert_array_equal(cols // 3, form.pair_interface[rows])
    np.testing.assert_array_equal(form.t, np.arange(0, 3 * c, 3))
    np.testing.assert_array_equal(form.n, form.t + 1)
    np.testing.assert_array_equal(form.m, form.t + 2)
    # pack/unpack/slack/multipliers on a random point
    rng = np.random.default_rng(0)
    w = rng.normal(size=form.n_columns)
    sol = form.unpack(w)
    np.testing.assert_array_equal(form.pack(sol), w)
    np.testing.assert_array_equal(sol.z_u, w[form.z_u])
    np.testing.assert_array_equal(form.multipliers(w), np.concatenate([sol.z_u, sol.z_f]))
    np.testing.assert_allclose(form.slack(w), -np.concatenate([ops.N_u.T @ sol.x, ops.N_f.T @ sol.x]), rtol=1e-14,
                               atol=1e-14)
    assert compile_mcp(ops) is form  # compiled once per structure


@pytest.mark.parametrize("dilatancy", ["zero", "friction", "random", "scalar"])
def test_with_dilatancy_is_exact(compiled, dilatancy):
    ops, form = compiled
    c = ops.n_interfaces
    d = {"zero": np.zeros(c), "friction": ops.friction, "random": np.random.default_rng(3).uniform(0, 0.6, c),
         "scalar": 0.3}[dilatancy]
    other = form.with_dilatancy(d)
    d_vec = np.broadcast_to(d, (c,))
    np.testing.assert_array_equal(other.dilatancy, d_vec)
    np.testing.assert_array_equal(other.friction, form.friction)
    # the flow block is the friction operator built at d, entry for entry; nothing else moves
    assert_same_sparse(other.block(form.compatibility, form.z_f), ops.friction_operator(d_vec))
    mask = np.ones(form.n_columns, bool)
    mask[form.z_f] = False
    assert_same_sparse(other.A[:, mask], form.A[:, mask])
    assert_same_sparse(other.G, form.G)
    np.testing.assert_array_equal(other.rhs, form.rhs)
    # back at the structure's own dilatancy: the compiled system itself
    assert_same_sparse(other.with_dilatancy(ops.dilatancy).A, form.A)


def test_pyomo_model_evaluates_to_the_compiled_rows(compiled):
    ops, form = compiled
    rng = np.random.default_rng(7)
    w = rng.normal(size=form.n_columns)
    w[form.z] = np.abs(w[form.z])
    values = evaluate_mcp(mcp(ops), form.unpack(w))
    r = form.A @ w - form.rhs
    for group in ("equilibrium", "compatibility", "normalisation"):
        np.testing.assert_allclose(values[group], r[getattr(form, group)], rtol=1e-12, atol=1e-12)
    g = -form.slack(w)  # pair rows g(x) = G w <= 0
    np.testing.assert_allclose(values["unilateral_slack"], g[form.unilateral], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(values["friction_slack"], g[form.friction_pairs], rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(np.concatenate([values["z_u"], values["z_f"]]), form.multipliers(w))

"""The root LP of ``milp`` in null-space coordinates (``solvers/linalg/null_space.py``) is derived, not trusted.

Its basis solves equilibrium and compatibility to round-off; a certified minimiser, lifted and written in its
coordinates, satisfies every row; the map back reproduces the lifted point; and its interior-point bound equals the
lifted LP's and never exceeds the certified minimum.
"""

import functools

import numpy as np
import pytest
import scipy.linalg as sla

import blockmpec as bm
from blockmpec.deadline import Deadline
from blockmpec.solvers.linalg.null_space import null_space_lp, static_null_space
from blockmpec.solvers.milp import MILPSettings
from helpers import CERTIFIED_TOL, LIFTING_CASES, assert_certified, margin, solve_with

#: small structures of every family, two with a minimum below the associative multiplier
CASES = LIFTING_CASES


@functools.cache
def certified(case_id: str) -> bm.Result:
    res = bm.solve(CASES[case_id](), "milp")
    assert_certified(res)
    return res


def _root(case_id: str, root_lp: str = "ipm"):
    """``(solver, branch and bound at the root pattern)`` with the rlt-full lifting and 60 s for its LPs."""
    from blockmpec.solvers.milp import MILPSolver

    solver = MILPSolver(engine="bnb", settings=MILPSettings(lifting="rlt-full", root_lp=root_lp))
    solver.setup(bm.operators.assemble(CASES[case_id]()))
    bnb = solver.branch_and_bound(solver.lp_bounds(Deadline(60)))
    bnb.deadline = Deadline(60)
    bnb.apply_node(bnb.root, bnb.lam_lower, bnb.lam_cap)
    return solver, bnb


@pytest.mark.parametrize("basis", ["tree", "cycles"])
@pytest.mark.parametrize("case_id", list(CASES))
def test_the_basis_solves_equilibrium_and_compatibility(case_id, basis):
    """``E N = 0`` with ``N`` of full column rank ``nx - 3 (blocks)`` (either basis), ``E x_d = -f_d``,
    ``E x_l = -f_l``, and ``u = L z`` is compatible (``E^T u + F z = 0``) for every ``z`` with ``C z = 0``, and
    only for those."""
    from blockmpec.solvers.milp import MILPSolver

    solver = MILPSolver(engine="bnb")
    solver.setup(bm.operators.assemble(CASES[case_id]()))
    form = solver.form
    space = static_null_space(form, basis)
    assert space is not None
    E = form.block(form.equilibrium, form.x).toarray()
    F = form.block(form.compatibility, form.z).toarray()
    N = space.N.toarray()
    nx = E.shape[1]
    assert N.shape == (nx, nx - E.shape[0])
    assert np.linalg.matrix_rank(N) == N.shape[1]
    scale = np.abs(E).max()
    assert np.abs(E @ N).max() <= 1e-12 * scale * max(1.0, np.abs(N).max())
    assert np.abs(E @ space.x_d + form.f_d).max() <= 1e-12 * scale * max(1.0, np.abs(space.x_d).max())
    assert np.abs(E @ space.x_l + form.f_l).max() <= 1e-12 * scale * max(1.0, np.abs(space.x_l).max())
    C, L = space.C.toarray(), space.L.toarray()
    consistent = sla.null_space(C)
    assert consistent.shape[1] > 0
    assert np.abs(E.T @ L @ consistent + F @ consistent).max() <= 1e-10 * max(1.0, np.abs(F).max())
    # a z outside the null space of C is not compatible with any u (the rows C z are the obstruction)
    z = C.T[:, :1].ravel()
    u = np.linalg.lstsq(E.T, -F @ z, rcond=None)[0]
    assert np.abs(E.T @ u + F @ z).max() > 1e-6
    np.testing.assert_allclose(space.live_work, form.f_l @ L, rtol=0, atol=1e-14)
    assert space.N.nnz < 0.5 * N.size or N.shape[1] < 10  # one fundamental cycle per column: sparse


@pytest.mark.parametrize("case_id", list(CASES))
def test_a_certified_minimiser_satisfies_every_row_of_the_null_space_lp(case_id):
    """The certified minimiser, lifted (``x^(i) = z_i x``, ...) and written in null-space coordinates, satisfies
    every row and column bound of the root LP there; the map back (``offset + T xi``) is the lifted point on every
    column but ``W`` (a function of the others)."""
    res = certified(case_id)
    solver, bnb = _root(case_id)
    form, lay = solver.form, bnb.layout
    w = form.pack(solver.scaled(res.solution))
    lifted = lay.lift(w[form.lam], w[form.x], w[form.u], w[form.z])
    space = static_null_space(form)
    c, rl, ru, cl, cu = bnb.lp_arrays()
    reduced = null_space_lp(bnb.lifted_matrix, c, rl, ru, cl, cu, lay, space)
    xi = reduced.coordinates(lifted, space, lay)
    not_w = np.ones(lifted.size, dtype=bool)
    not_w[lay.w] = False
    scale = max(1.0, float(np.abs(lifted).max()))
    np.testing.assert_allclose((reduced.offset + reduced.T @ xi)[not_w], lifted[not_w], rtol=0, atol=1e-9 * scale)
    r = reduced.A @ xi
    tol = 1e-7 * scale
    assert np.all(r >= reduced.row_lower - tol) and np.all(r <= reduced.row_upper + tol)
    assert np.all(xi >= reduced.col_lower - tol) and np.all(xi <= reduced.col_upper + tol)
    assert xi[0] == pytest.approx(res.multiplier, abs=1e-9)
    # the rows it keeps from the lifted LP keep their place and bounds
    kept = reduced.lifted_row >= 0
    assert np.all(np.diff(reduced.lifted_row[kept]) > 0)
    assert reduced.A.shape[0] < bnb.lifted_matrix.shape[0] and reduced.A.shape[1] < bnb.lifted_matrix.shape[1]


@pytest.mark.parametrize("case_id", ["wall-2x2", pytest.param("wall-4x2-stack-mu0.4", marks=pytest.mark.slow),
                                     "two-blocks"])
def test_the_null_space_root_bound_is_the_lifted_root_bound(case_id):
    """The root's interior point on the null-space LP (``root_lp="ipm"``) and on the lifted LP
    (``root_lp="ipm-lifted"``) give the same bound, at most the certified minimum; the first says it ran in
    null-space coordinates and marks dormant rows of the lifted LP from its duals."""
    minimum = certified(case_id).multiplier
    bounds = {}
    for root_lp in ("ipm", "ipm-lifted"):
        _, bnb = _root(case_id, root_lp)
        bounds[root_lp] = bnb.interior_root()
        assert bnb.null_space_root is (root_lp == "ipm")
        assert bnb.dormant.any()
        assert bounds[root_lp] <= minimum + margin(CERTIFIED_TOL, minimum)
    assert bounds["ipm"] == pytest.approx(bounds["ipm-lifted"], abs=margin(CERTIFIED_TOL, minimum))


def test_liftings_without_every_force_tied_keep_the_lifted_root():
    """``lifting="rlt"`` ties the normal and tangential forces only: its rows (X) are not the null-space ones, so
    the root LP stays the lifted one, and ``milp`` still certifies the same minimum."""
    from blockmpec.solvers.milp import MILPSolver

    solver = MILPSolver(engine="bnb", settings=MILPSettings(lifting="rlt", root_lp="ipm"))
    solver.setup(bm.operators.assemble(CASES["wall-2x2"]()))
    bnb = solver.branch_and_bound(solver.lp_bounds(Deadline(60)))
    bnb.apply_node(bnb.root, bnb.lam_lower, bnb.lam_cap)
    assert bnb.null_space_root_lp(*bnb.lp_arrays()) is None
    res = solve_with(CASES["wall-2x2"](), "milp", settings=dict(lifting="rlt"))
    assert_certified(res)
    assert res.multiplier == pytest.approx(certified("wall-2x2").multiplier, abs=1e-7)


def test_root_lp_ipm_lifted_certifies_the_same_minimum():
    """``root_lp="ipm-lifted"`` (the root LP before the null-space coordinates) stays available and certifies the
    same minimum as the default."""
    res = solve_with(CASES["wall-3x2-opening"](), "milp", settings=dict(root_lp="ipm-lifted"))
    assert_certified(res)
    assert res.multiplier == pytest.approx(certified("wall-3x2-opening").multiplier, abs=1e-7)


def test_an_unknown_basis_is_one_clear_error():
    from blockmpec.solvers.milp import MILPSolver

    solver = MILPSolver(engine="bnb")
    solver.setup(bm.operators.assemble(CASES["wall-2x2"]()))
    with pytest.raises(ValueError, match="unknown basis 'loops'; use one of tree, cycles"):
        static_null_space(solver.form, "loops")


def test_a_null_space_lp_that_fails_its_check_leaves_the_lifted_root(monkeypatch):
    """If a row that should vanish on the null space did not hold (``null_space_lp`` raises), the root keeps the
    lifted LP and still gives its bound: the reformulation is an acceleration, never a source of wrong bounds."""
    import blockmpec.solvers.linalg.null_space as ns

    def broken(*args, **kwargs):
        raise ValueError("null-space LP: a row of equilibrium or compatibility does not hold on the null space")

    monkeypatch.setattr(ns, "null_space_lp", broken)
    minimum = certified("wall-2x2").multiplier
    _, bnb = _root("wall-2x2")
    bound = bnb.interior_root()
    assert not bnb.null_space_root
    assert minimum - margin(CERTIFIED_TOL, minimum) <= bound <= minimum + margin(CERTIFIED_TOL, minimum)

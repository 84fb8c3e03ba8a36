"""The root LP of ``milp``'s branch and bound by its interior point (issue 12's record of root-LP engines, measured by
``studies/lab/root_lp_engines.py``): IPX's dual bound on the lifted root LP meets the certified minimum of the 2x2
running-bond wall, never above it; the same LP in null-space coordinates (what ``root_lp="ipm"`` solves) gives the
same bound on fewer rows; a lifting without the products with the mechanism gives a weaker bound.

Built here from the library (not from the study), so that the study's own port to the new API is not a condition of
these checks."""

import pytest
import scipy.sparse as sp
from milp_runs import milp_solver, solve_milp

import blockmpec as bm
from blockmpec.deadline import Deadline
from blockmpec.solvers.engines.bnb_root import NULL_SPACE_IPM_TOL
from blockmpec.solvers.engines.lifted_lp import dual_bound
from blockmpec.solvers.engines.node_lp import interior_point
from helpers import CERTIFIED_TOL, margin


@pytest.fixture(scope="module")
def minimum():
    res = solve_milp(bm.cases.wall(2, 2, mu=0.65), engine="highs")
    assert res.status is bm.Status.OPTIMAL, res.message
    return res.multiplier


def root_lp(lifting: str = "rlt-full", null_space: bool = False):
    """``(A, c, row_lower, row_upper, col_lower, col_upper)`` of the root's lifted LP of the 2x2 running-bond wall
    (``null_space``: the same LP in null-space coordinates), in the MILP's per-block units (lam unit 1 here)."""
    solver = milp_solver(engine="bnb", lifting=lifting, root_lp="ipm")
    solver.setup(bm.operators.assemble(bm.cases.wall(2, 2, mu=0.65)))
    assert solver.lam_unit == 1.0
    bnb = solver.branch_and_bound(solver.lp_bounds(Deadline(60)))
    bnb.apply_node(bnb.root, bnb.lam_lower, bnb.lam_cap)
    c, rl, ru, cl, cu = bnb.lp_arrays()
    if null_space:
        return bnb.null_space_root_lp(c, rl, ru, cl, cu).arrays
    return sp.csc_array(bnb.lifted_matrix), c, rl, ru, cl, cu


def interior_bound(lp, tolerance=None) -> float:
    """The dual bound of IPX's row duals (no crossover) on ``lp``: the bound ``milp`` takes from it."""
    A, c, rl, ru, cl, cu = lp
    point = interior_point(A, c, rl, ru, cl, cu, Deadline(60), tolerance=tolerance)
    assert point.y is not None
    return dual_bound(A, c, rl, ru, cl, cu, point.y)


def test_ipx_bound_on_the_root_lp_is_the_certified_minimum(minimum):
    bound = interior_bound(root_lp())
    assert bound <= minimum + margin(CERTIFIED_TOL, minimum)
    assert minimum - bound <= margin(CERTIFIED_TOL, minimum)


def test_the_null_space_root_lp_gives_the_lifted_bound(minimum):
    """The null-space LP (the one ``root_lp="ipm"`` solves) is the same LP in other coordinates: its bound equals
    IPX's on the lifted LP and meets the certified minimum, on fewer rows and columns."""
    lifted, reduced = root_lp(), root_lp(null_space=True)
    assert reduced[0].shape[0] < lifted[0].shape[0] and reduced[0].shape[1] < lifted[0].shape[1]
    bound = interior_bound(reduced, NULL_SPACE_IPM_TOL)
    assert bound <= minimum + margin(CERTIFIED_TOL, minimum)
    assert abs(bound - interior_bound(lifted)) <= margin(CERTIFIED_TOL, minimum)


def test_liftings_without_the_force_products_give_a_weaker_bound(minimum):
    bounds = {lifting: interior_bound(root_lp(lifting)) for lifting in ("friction", "rlt", "rlt-full")}
    assert max(bounds.values()) <= minimum + margin(CERTIFIED_TOL, minimum)
    assert minimum - bounds["rlt-full"] <= margin(CERTIFIED_TOL, minimum)
    assert bounds["friction"] < minimum - 0.1

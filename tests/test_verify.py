"""The shared verifier: each residual detects what it is meant to detect."""

import numpy as np
import pytest

import blockmpec as bm
from blockmpec.result import Solution
from blockmpec.verify import positive_part_ratio, residuals


@pytest.fixture(scope="module")
def lp_solution():
    s = bm.cases.two_blocks(eta=3, mu=0.65)
    return bm.assemble(s), bm.solve(s, "static-lp").solution


def test_exact_solution_has_round_off_residuals(lp_solution):
    ops, sol = lp_solution
    res = residuals(ops, sol, associative=True)
    assert max(res.values()) < 1e-12


def test_each_residual_detects_its_violation(lp_solution):
    ops, sol = lp_solution
    x = sol.x.copy()
    x[0] += 1.0  # perturb a shear force: breaks equilibrium and friction admissibility
    bad = residuals(ops, Solution(sol.multiplier, x, sol.u, sol.z_u, sol.z_f), True)
    assert bad["equilibrium"] > 1e-3
    u = sol.u * 2
    bad = residuals(ops, Solution(sol.multiplier, sol.x, u, sol.z_u, sol.z_f), True)
    assert bad["normalisation"] == pytest.approx(1.0) and bad["compatibility"] > 1e-3
    bad = residuals(ops, Solution(sol.multiplier, sol.x, sol.u, sol.z_u, -sol.z_f), True)
    assert bad["multiplier_sign"] > 0.1
    # a multiplier on an inactive constraint breaks complementarity
    z_u = sol.z_u + 1.0
    bad = residuals(ops, Solution(sol.multiplier, sol.x, sol.u, z_u, sol.z_f), True)
    assert bad["unilateral_complementarity"] > 1e-3


def test_associative_mechanism_fails_non_associative_compatibility(lp_solution):
    # at eta=3, mu=0.65 the associative mechanism (A2-1) dilates by friction: with psi = 0 flow it is incompatible
    ops, sol = lp_solution
    assert residuals(ops, sol, associative=False)["compatibility"] > 1e-3


def test_positive_part_ratio():
    assert positive_part_ratio(np.array([-1.0, -2.0])) == 0.0
    assert positive_part_ratio(np.array([3.0, -4.0])) == pytest.approx(0.6)
    assert positive_part_ratio(np.zeros(3)) == 0.0


def test_local_measures_see_a_violation_that_global_norms_hide():
    # a 1e-2 block on a 1 x 1 block: move the light block's interface force out of its admissible set
    polys = [
        [[-2, -0.1], [3, -0.1], [3, 0], [-2, 0]],
        [[0, 0], [1, 0], [1, 1], [0, 1]],
        [[0.5, 1], [0.51, 1], [0.51, 1.02], [0.5, 1.02]],
    ]
    s = bm.make_structure(polys, [True, False, False], friction=0.65)
    ops = bm.assemble(s)
    sol = bm.solve(s, "static-lp").solution
    k = int(np.flatnonzero(ops.plus_dof == 1)[0])  # the light block's interface
    x = sol.x.copy()
    x[3 * k] += 2 * abs(x[3 * k + 1])  # shear far beyond mu |n|
    res = residuals(ops, Solution(sol.multiplier, x, sol.u, sol.z_u, sol.z_f), True)
    assert res["friction_admissibility"] < 1e-3  # the paper's global measure barely notices
    assert res["local_admissibility"] > 0.1
    assert res["equilibrium"] > 0.1  # and the light block is out of equilibrium

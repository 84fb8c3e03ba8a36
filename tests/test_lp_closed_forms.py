"""Associative limit analysis: closed forms, published values and LP duality."""

import itertools

import numpy as np
import pytest

import blockmpec as bm
from helpers import assert_success, two_block_associative

ETAS = [1, 1.5, 2, 3, 4, 5]
MUS = [0.2, 0.3, 0.5, 0.65, 0.8, 1.0, 1.2, 1.5]


@pytest.mark.parametrize(("eta", "mu"), list(itertools.product(ETAS, MUS)))
def test_two_blocks_static_lp_matches_closed_form(eta, mu):
    res = bm.solve(bm.cases.two_blocks(eta=eta, mu=mu), "static-lp")
    assert_success(res, two_block_associative(eta, mu), rtol=1e-8)


def test_two_blocks_paper_value():
    res = bm.solve(bm.cases.two_blocks(eta=3, mu=0.65), "static-lp")
    assert round(res.multiplier, 5) == 0.41973


@pytest.mark.parametrize(("width", "height", "mu"), [(1, 2, 0.65), (1, 1, 0.3), (0.4, 0.175, 0.65), (2, 1, 1.5)])
@pytest.mark.parametrize("method", ["static-lp", "kinematic-lp"])
def test_single_block_closed_form(width, height, mu, method):
    res = bm.solve(bm.cases.single_block(width=width, height=height, mu=mu), method)
    assert_success(res, min(mu, width / height), rtol=1e-9)


def test_round_arch_matches_paper_table1():
    res = bm.solve(bm.cases.round_arch(), "static-lp")
    assert_success(res)
    assert round(res.multiplier, 5) == 0.16034


def _suite():
    return {
        "two-blocks": bm.cases.two_blocks(),
        "single-block": bm.cases.single_block(),
        "round-arch": bm.cases.round_arch(),
        "arch-on-buttresses": bm.cases.arch_on_buttresses(),
        "wall-running": bm.cases.wall(),
        "wall-stack": bm.cases.wall(courses=4, blocks_per_course=3, bond="stack"),
        "wall-opening": bm.cases.wall(courses=6, blocks_per_course=6, openings=[(2, 1, 4, 2)]),
    }


@pytest.mark.parametrize("name", list(_suite()))
def test_static_and_kinematic_agree_with_tiny_residuals(name):
    structure = _suite()[name]
    static = bm.solve(structure, "static-lp")
    kinematic = bm.solve(structure, "kinematic-lp")
    assert_success(static)
    assert_success(kinematic)
    np.testing.assert_allclose(static.multiplier, kinematic.multiplier, rtol=1e-9)
    for res in (static, kinematic):
        assert res.max_residual <= 1e-9, res.residuals
    # the duality gap closes: lam = -f_d^T u for the associative problem
    ops = bm.assemble(structure)
    np.testing.assert_allclose(-ops.f_d @ static.solution.u, static.multiplier, rtol=1e-9)


@pytest.mark.parametrize("algorithm", ["simplex", "dual-simplex", "primal-simplex", "ipm"])
def test_lp_algorithms_agree(algorithm):
    structure = bm.cases.wall(courses=6, blocks_per_course=4)
    ref = bm.solve(structure, "static-lp").multiplier
    res = bm.solve(structure, "static-lp", algorithm=algorithm)
    assert_success(res, ref, rtol=1e-8)


def test_mechanism_is_normalised_and_does_positive_work():
    res = bm.solve(bm.cases.wall(), "static-lp")
    ops = bm.assemble(bm.cases.wall())
    assert abs(ops.f_l @ res.solution.u - 1) < 1e-12
    assert np.all(res.solution.z_u >= -1e-12) and np.all(res.solution.z_f >= -1e-12)


def test_no_collapse_is_reported_as_unbounded():
    # a block wedged between two fixed blocks cannot be pushed sideways: no mechanism
    polys = [
        [[-1, -1], [3, -1], [3, 0], [-1, 0]],
        [[-1, 0], [0, 0], [0, 1], [-1, 1]],
        [[0, 0], [1, 0], [1, 1], [0, 1]],
        [[1, 0], [2, 0], [2, 1], [1, 1]],
        [[-1, 1], [3, 1], [3, 2], [-1, 2]],
    ]
    s = bm.make_structure(polys, [True, True, False, True, True], friction=0.5)
    for method in ("static-lp", "kinematic-lp"):
        res = bm.solve(s, method)
        assert res.status is bm.Status.UNBOUNDED, (method, res.status, res.message)
        assert not res.success


def test_unstable_under_dead_load_is_reported_as_infeasible():
    # the block's centroid overhangs its only support, and friction (mu = 0.5) is too weak to let a
    # horizontal force of either sign hold it: no lam gives equilibrium
    polys = [[[0, -1], [1, -1], [1, 0], [0, 0]], [[0.5, 0], [2.5, 0], [2.5, 1], [0.5, 1]]]
    s = bm.make_structure(polys, [True, False], friction=0.5)
    for method in ("static-lp", "kinematic-lp"):
        res = bm.solve(s, method)
        assert res.status is bm.Status.INFEASIBLE, (method, res.status, res.message)
        assert not res.success and "equilibrium" in res.message


def test_closed_form_table_spot_values():
    cf = bm.cases.closed_form
    assert round(cf("two-blocks", "associative", eta=3, mu=0.65), 5) == 0.41973
    assert cf("two-blocks", "non-associative", eta=3, mu=0.65) == pytest.approx(1 / 3)
    assert cf("two-blocks", "non-associative", eta=1, mu=0.3) == pytest.approx(0.3)
    assert cf("single-block", "non-associative", width=1, height=4, mu=0.65) == pytest.approx(0.25)
    assert cf("round-arch", "associative") is None
    # with dilatancy equal to friction the non-associative problem is the associative one
    assert cf("two-blocks", "non-associative", eta=3, mu=0.65, dilatancy=0.65) == cf("two-blocks", "associative", eta=3, mu=0.65)


@pytest.mark.parametrize("name", ["two-blocks", "round-arch", "wall-running", "wall-opening"])
def test_split_multiplier_formulation_is_the_same_lp(name):
    # lam copied per block and chained by equalities: same optimum, same verified mechanism from the duals
    from blockmpec.formulations import compile_linear, static_lp
    from blockmpec.solvers.engines.highs import HighsLP, static_lp_solution

    structure = _suite()[name]
    ops = bm.assemble(structure)
    lp = compile_linear(static_lp(ops, split_multiplier=True))
    sol = static_lp_solution(lp, HighsLP(lp, "dual-simplex").solve())
    assert sol.multiplier == pytest.approx(bm.solve(structure, "static-lp").multiplier, rel=1e-9)
    assert max(bm.residuals(ops, sol, associative=True).values()) < 1e-9

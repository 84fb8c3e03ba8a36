"""Stiff and extreme cases (associative LPs): correct answers or a clear status.

Each case documents its outcome; the non-associative methods have their own.
"""

import itertools

import pytest

import blockmpec as bm
from conftest import assert_success


@pytest.mark.parametrize(("eta", "mu"), list(itertools.product([0.05, 0.5, 5, 50], [1e-4, 1e-2, 1.0, 10.0, 100.0])))
def test_two_blocks_extreme_friction_and_slenderness(eta, mu):
    structure = bm.cases.two_blocks(eta=eta, mu=mu)
    static = bm.solve(structure, "static-lp")
    kinematic = bm.solve(structure, "kinematic-lp")
    assert_success(static)
    assert_success(kinematic, static.multiplier, rtol=1e-8)
    expected = bm.cases.closed_form("two-blocks", "associative", eta=eta, mu=mu)
    if expected is not None:
        assert static.multiplier == pytest.approx(expected, rel=1e-7)
    else:
        # squat blocks, mu > 1: the blocks slide (lam = mu) or rock as a pair, never below 1/(eta+mu) ...
        assert static.multiplier <= min(mu, 2 / eta) + 1e-9


@pytest.mark.parametrize(("eta", "mu"), [(0.05, 1.2), (0.2, 1.5), (0.3, 2.0)])
def test_paper_a21_formula_undercuts_a_verified_optimum_for_squat_blocks(eta, mu):
    """Documented outcome: for mu > 1, eta < 1 the paper's A2-1 value is below the LP optimum,
    which an admissible stress field (static LP) and a mechanism (kinematic LP) both certify."""
    a21 = 1 / (eta * (1 - mu**2) + mu)
    static = bm.solve(bm.cases.two_blocks(eta=eta, mu=mu), "static-lp")
    assert_success(static)
    assert a21 < static.multiplier - 1e-3
    assert bm.cases.closed_form("two-blocks", "associative", eta=eta, mu=mu) is None


@pytest.mark.parametrize("size", [1e-3, 1.0, 1e3])
def test_arch_multiplier_independent_of_size(size):
    res = bm.solve(bm.cases.round_arch(radius=size, thickness=0.15 * size), "static-lp")
    assert_success(res)
    assert round(res.multiplier, 5) == 0.16034


def _block_on_block(big: float, small: float):
    # a big x big block carrying a small x 2 small block: the small block topples first at lam = b/h = 0.5
    polys = [
        [[-2 * big, -big / 10], [3 * big, -big / 10], [3 * big, 0], [-2 * big, 0]],
        [[0, 0], [big, 0], [big, big], [0, big]],
        [[big / 2, big], [big / 2 + small, big], [big / 2 + small, big + 2 * small], [big / 2, big + 2 * small]],
    ]
    return bm.make_structure(polys, [True, False, False], friction=0.65)


@pytest.mark.parametrize("ratio", [1e-1, 1e-2])
def test_mixing_large_and_small_blocks(ratio):
    s = _block_on_block(1.0, ratio)
    assert len(s.interfaces) == 2
    for method in ("static-lp", "kinematic-lp"):
        assert_success(bm.solve(s, method), 0.5, rtol=1e-7)


@pytest.mark.parametrize(("big", "small"), [(1.0, 1e-3), (1e3, 1e-3)])
def test_mixing_huge_and_tiny_blocks_gives_a_clear_status(big, small):
    """Documented outcome: from a 1e-3 size ratio (1e-6 in weight) on, the tiny block's loads fall
    below the LP solver's absolute tolerances.  The answer may be wrong, but the verifier's
    block-wise equilibrium residual catches it: the status is 'numerical', never a silent success."""
    s = _block_on_block(big, small)
    assert len(s.interfaces) == 2
    for method in ("static-lp", "kinematic-lp"):
        res = bm.solve(s, method)
        if res.success:
            assert res.multiplier == pytest.approx(0.5, rel=1e-7)
        else:
            assert res.status in (bm.Status.NUMERICAL, bm.Status.INFEASIBLE, bm.Status.UNBOUNDED)
            assert res.status is not bm.Status.NUMERICAL or "verifier disagrees" in res.message


def test_nearly_collinear_edges_within_tolerance_make_an_interface():
    tilt = 1e-9
    polys = [[[-1, -1], [2, -1], [2, 0], [-1, 0]], [[0, 0], [1, tilt], [1, 2], [0, 2]]]
    s = bm.make_structure(polys, [True, False], friction=0.65)
    assert len(s.interfaces) == 1
    assert_success(bm.solve(s, "static-lp"), 0.5, rtol=1e-7)


def test_edges_clearly_not_collinear_make_no_interface():
    polys = [[[-1, -1], [2, -1], [2, 0], [-1, 0]], [[0, 0], [1, 1e-3], [1, 2], [0, 2]]]
    with pytest.raises(bm.StructureError, match="block 1 touches no other block"):
        bm.make_structure(polys, [True, False], friction=0.65)


def test_dilatancy_equal_to_friction_is_accepted():
    s = bm.cases.two_blocks(eta=3, mu=0.65, dilatancy=0.65)
    ops = bm.assemble(s)
    assert ops.is_associative and (ops.V_f != ops.N_f).nnz == 0


def test_zero_friction_gives_zero_multiplier():
    # no friction: the live load slides the blocks at once
    assert_success(bm.solve(bm.cases.two_blocks(eta=2, mu=0.0), "static-lp"), 0.0)


def test_large_wall_solves():
    s = bm.cases.wall(courses=20, blocks_per_course=10)
    static = bm.solve(s, "static-lp")
    assert_success(static)
    assert 0 < static.multiplier < 0.65

"""Associative limit analysis: closed forms, published values and LP duality."""

import itertools

import numpy as np
import pytest
from references import ROUND_ARCH_ASSOCIATIVE, ROUND_ARCH_PUBLISHED, TWO_BLOCKS_ASSOCIATIVE

import blockmpec as bm
from helpers import assert_success, two_block_associative

ETAS = [1, 1.5, 2, 3, 4, 5]
MUS = [0.2, 0.3, 0.5, 0.65, 0.8, 1.0, 1.2, 1.5]


@pytest.mark.parametrize(("eta", "mu"), list(itertools.product(ETAS, MUS)))
def test_two_blocks_static_lp_matches_closed_form(eta, mu):
    res = bm.solve(bm.cases.two_blocks(eta=eta, mu=mu), "static-lp")
    assert_success(res, two_block_associative(eta, mu), rtol=1e-9)  # 6.7e-16 measured


def test_two_blocks_paper_value():
    """Paper Sect. 3: A2-1 at eta = 3, mu = 0.65, lam = 1/2.3825, printed 0.41973."""
    res = bm.solve(bm.cases.two_blocks(eta=3, mu=0.65), "static-lp")
    assert_success(res, TWO_BLOCKS_ASSOCIATIVE, rtol=1e-12)  # 0 measured
    assert round(res.multiplier, 5) == 0.41973


@pytest.mark.parametrize(("width", "height", "mu"), [(1, 2, 0.65), (1, 1, 0.3), (0.4, 0.175, 0.65), (2, 1, 1.5)])
@pytest.mark.parametrize("method", ["static-lp", "kinematic-lp"])
def test_single_block_closed_form(width, height, mu, method):
    res = bm.solve(bm.cases.single_block(width=width, height=height, mu=mu), method)
    assert_success(res, min(mu, width / height), rtol=1e-9)  # 0 measured


def test_round_arch_matches_paper_table1():
    res = bm.solve(bm.cases.round_arch(), "static-lp")
    assert_success(res, ROUND_ARCH_ASSOCIATIVE, rtol=1e-9)  # the independent LP (references.py): 1.1e-12 measured
    assert round(res.multiplier, 5) == ROUND_ARCH_PUBLISHED


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
    assert cf("two-blocks", "associative", eta=3, mu=0.65) == pytest.approx(TWO_BLOCKS_ASSOCIATIVE, rel=1e-15)
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


def _frictionless_block_between_walls() -> bm.Structure:
    # no friction: the walls cannot carry the block's weight (no equilibrium), and a horizontal live
    # load only presses it against a wall (no mechanism): static LP infeasible, kinematic LP infeasible
    polys = [[[-1, -1], [0, -1], [0, 2], [-1, 2]], [[0, 0], [1, 0], [1, 1], [0, 1]], [[1, -1], [2, -1], [2, 2], [1, 2]]]
    return bm.make_structure(polys, [True, False, True], friction=0.0)


def test_no_equilibrium_and_no_mechanism_is_infeasible_for_both_lps():
    # the kinematic LP's infeasibility alone proves only "static LP infeasible or unbounded"; it used
    # to be reported as UNBOUNDED ("no mechanism exists") for this structure, which has no equilibrium
    s = _frictionless_block_between_walls()
    for method in ("static-lp", "kinematic-lp"):
        res = bm.solve(s, method)
        assert res.status is bm.Status.INFEASIBLE, (method, res.status, res.message)
        assert "equilibrium" in res.message and "no collapse mechanism exists" not in res.message


class _FakeHighs:
    def __init__(self, name):
        import highspy

        self.status = getattr(highspy.HighsModelStatus, name)

    def getModelStatus(self):  # noqa: N802 (highspy's spelling)
        return self.status


@pytest.mark.parametrize(("raw", "status"), [
    ("kOptimal", bm.Status.OPTIMAL), ("kInfeasible", bm.Status.INFEASIBLE), ("kUnbounded", bm.Status.UNBOUNDED),
    ("kUnboundedOrInfeasible", bm.Status.INFEASIBLE_OR_UNBOUNDED), ("kTimeLimit", bm.Status.TIME_LIMIT),
    ("kIterationLimit", bm.Status.ITERATION_LIMIT), ("kSolutionLimit", bm.Status.ITERATION_LIMIT),
    ("kInterrupt", bm.Status.ERROR), ("kMemoryLimit", bm.Status.ERROR), ("kSolveError", bm.Status.ERROR),
    ("kNotset", bm.Status.ERROR), ("kObjectiveBound", bm.Status.ERROR),
])
def test_one_highs_status_map(raw, status):
    from blockmpec.solvers.engines.highs import highs_status

    assert highs_status(_FakeHighs(raw)) == (status, raw)
    assert not (status is bm.Status.INFEASIBLE_OR_UNBOUNDED and status.is_success)


def test_infeasible_or_unbounded_static_lp_message_is_truthful(monkeypatch):
    # HiGHS's kUnboundedOrInfeasible (it proved one of the two without deciding which) must not be
    # reported as "no collapse mechanism": the structure may as well be unstable under dead load
    import blockmpec.solvers.engines.highs as highs

    monkeypatch.setattr(highs, "highs_status", lambda h, **_: (bm.Status.INFEASIBLE_OR_UNBOUNDED, "kUnboundedOrInfeasible"))
    res = bm.solve(_frictionless_block_between_walls(), "static-lp", algorithm="dual-simplex")
    assert res.status is bm.Status.INFEASIBLE_OR_UNBOUNDED and not res.success
    assert res.raw_status == "kUnboundedOrInfeasible"
    assert "unstable under dead load" in res.message and "no collapse mechanism" not in res.message


def test_mip_info_reads_bounds_gap_and_nodes():
    import highspy

    from blockmpec.solvers.engines.highs import mip_info

    # min -x - y  s.t.  2x + 2y <= 5, x, y integer in [0, 3]: optimum -2, LP relaxation -2.5
    h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    h.addVars(2, np.zeros(2), np.full(2, 3.0))
    h.changeColsCost(2, np.arange(2, dtype=np.int32), np.array([-1.0, -1.0]))
    h.addRow(-highspy.kHighsInf, 5.0, 2, np.arange(2, dtype=np.int32), np.array([2.0, 2.0]))
    h.changeColsIntegrality(2, np.arange(2, dtype=np.int32), np.array([highspy.HighsVarType.kInteger] * 2))
    h.run()
    info = mip_info(h)
    assert info.status is bm.Status.OPTIMAL and info.raw_status == "kOptimal" and info.has_solution
    assert info.primal_bound == pytest.approx(-2.0) and info.dual_bound == pytest.approx(-2.0)
    assert info.gap <= 1e-9 and info.nodes >= 0
    h.changeRowBounds(0, 3.0, 3.5)  # 3 <= 2x + 2y <= 3.5 has no integer point
    h.run()
    info = mip_info(h)
    assert info.status is bm.Status.INFEASIBLE and not info.has_solution and info.primal_bound == np.inf

"""The plan: every size threshold in one module, one function that names the engine chain before a run, and the
chain that ran in ``Result.extra["plan"]``."""

import pytest

import blockmpec as bm
from blockmpec.solvers import plan


@pytest.mark.parametrize("method", ["static-lp", "kinematic-lp", "fixed-point", "slp", "mcp-newton", "milp"])
@pytest.mark.parametrize("shape", [(3, 2), pytest.param((12, 15), marks=pytest.mark.slow)])
def test_the_chain_named_before_the_run_is_the_one_that_ran(method, shape):
    wall = bm.cases.wall(*shape)
    ops = bm.assemble(wall)
    if method == "milp" and shape != (3, 2):
        pytest.skip("milp on a 180-block wall needs minutes")
    options = {"time_limit": 60.0}
    res = bm.solve(ops, method, **options)
    predicted = plan.choose(method, ops, bm.get_solver(method).Options(**options))
    ran = res.extra["plan"]
    assert predicted and ran, (predicted, ran)
    # the first step names the same engine (what ran adds detail: the block IPM's factorisation, LP counts ...)
    first_words = predicted[0].split(":")[0]
    assert ran[0].startswith(first_words), (predicted, ran)
    if "block IPM" in predicted[0] or "HiGHS" in predicted[0]:
        engine = "block IPM" if "block IPM" in predicted[0] else predicted[0].split("HiGHS ")[1].split()[0]
        assert engine in ran[0], (predicted, ran)


def test_the_thresholds_switch_engines_where_the_plan_says():
    assert plan.lp_algorithm("auto", plan.LP_BLOCK_IPM_ROWS) == "dual-simplex"
    assert plan.lp_algorithm("auto", plan.LP_BLOCK_IPM_ROWS + 1) == "block-ipm"
    assert plan.lp_algorithm("auto", plan.LP_BLOCK_IPM_ROWS + 1, need_basis=True) == "ipm"
    assert plan.lp_algorithm("auto", 10, load_spread=2 * plan.LP_BLOCK_IPM_LOAD_SPREAD) == "block-ipm"
    assert plan.lp_algorithm("auto", 10**6, warm=True) == "dual-simplex"
    assert plan.lp_algorithm("ipm", 10) == "ipm"
    n = plan.FIXED_POINT_INTERIOR_BLOCKS
    assert (plan.fixed_point_engine("auto", n - 1), plan.fixed_point_engine("auto", n)) == ("simplex", "interior")
    assert plan.fixed_point_engine("simplex", 10 * n) == "simplex"
    m = plan.FIXED_POINT_SIMPLEX_FALLBACK_BLOCKS
    assert plan.fixed_point_fallback("auto", m - 1) and not plan.fixed_point_fallback("auto", m)
    assert not plan.fixed_point_fallback("interior", 10)
    k = plan.NLP_PIECE_ROUTE_BLOCKS
    assert (plan.nlp_route("auto", k - 1), plan.nlp_route("auto", k)) == ("ipopt", "pieces")
    p = plan.MILP_BNB_MAX_PAIRS
    assert (plan.milp_engine("auto", "min", p), plan.milp_engine("auto", "min", p + 1)) == ("bnb", "highs")
    assert plan.milp_engine("auto", "max", 4) == "highs"

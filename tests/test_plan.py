"""The plan: every size threshold in one module; the stages set-up chose (``solver.plan``) are the stages the run
takes, and those that ran are ``Result.extra["plan"]``."""

import pytest

import blockmpec as bm
from blockmpec.solvers import plan

METHODS = ["static-lp", "kinematic-lp", "fixed-point", "slp", "mcp-newton", "milp", "nlp"]


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("shape", [(3, 2), pytest.param((12, 15), marks=pytest.mark.slow)])
def test_the_plan_set_up_chose_is_the_plan_that_ran(method, shape):
    if method in ("milp", "nlp") and shape != (3, 2):
        pytest.skip("milp and nlp on a 180-block wall need minutes")
    solver = bm.get_solver(method)(time_limit=60.0)
    res = bm.run_solver(solver, bm.cases.wall(*shape))
    assert res.success or method == "slp", res.message  # the SLP's points leave dilatancy: not verified
    planned = solver.plan.stages
    ran = res.extra["plan"]
    # every stage that ran is a stage of the plan, in the plan's order, and every unconditional stage ran
    names = [stage.name for stage in planned]
    assert all(name in names for name in ran), (ran, solver.plan)
    assert [names.index(name) for name in ran] == sorted(names.index(name) for name in ran), (ran, solver.plan)
    assert all(stage.name in ran for stage in planned if not stage.when), (ran, solver.plan)


def test_a_fallback_stage_is_recorded_only_when_it_ran():
    """static-lp's plan on a large LP holds the block IPM and, if it fails, HiGHS; a run that succeeds records one."""
    wall = bm.cases.wall(20, 50)
    solver = bm.get_solver("static-lp")()
    res = bm.run_solver(solver, wall)
    assert [stage.key for stage in solver.plan.stages] == ["block-ipm", "fallback"]
    assert res.success and res.extra["plan"] == [solver.plan.stages[0].name]
    assert res.extra["plan"][0].startswith("static LP (1): block IPM (SuperLU")
    with pytest.raises(KeyError, match="no stage"):
        solver.plan.start("simplex")


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
    assert not plan.fixed_point_fallback("auto", plan.FIXED_POINT_INTERIOR_BLOCKS, dim=3)
    k = plan.NLP_PIECE_ROUTE_BLOCKS
    assert (plan.nlp_route("auto", k - 1), plan.nlp_route("auto", k)) == ("ipopt", "pieces")
    p = plan.MILP_BNB_MAX_PAIRS
    assert (plan.milp_engine("auto", "min", p), plan.milp_engine("auto", "min", p + 1)) == ("bnb", "highs")
    assert plan.milp_engine("auto", "max", 4) == "highs"

"""Non-associative limit analysis: the fixed-point method and the SLP heuristic.

Checks against the closed-form two-block results of Nodargi, Intrigila & Bisegna
(Sect. 3: minimum non-associative multiplier mu if mu <= 1/eta else 1/eta, and every
solution of (3) at most the associative multiplier), the round arch (no sliding in
the associative mechanism, so associative and non-associative lam agree: 0.16034
in the paper's Table 1; full precision from the independent LP, references.py), and
the shared verifier of (3).
"""

import math

import numpy as np
import pytest
from references import ROUND_ARCH_ASSOCIATIVE, STACK_WALL_4X2_MINIMUM, TWO_BLOCKS_ASSOCIATIVE

import blockmpec as bm
from blockmpec.errors import OptionError
from helpers import assert_reported_unverified, assert_residuals_within, solve_with, two_block_nonassociative_min

RESIDUAL_TOL = 1e-7
#: the fixed point's lam against closed forms and certified minima: 5.2e-10 at most measured (two blocks at eta = 5,
#: mu = 1.2; 0 elsewhere); its tie-break may lower lam by 1e-10 by design
FIXED_POINT = 1e-9


def associative(case):
    res = bm.solve(case, "static-lp")
    assert res.status is bm.Status.OPTIMAL
    return res


def assert_mcp_solution(res):
    assert_residuals_within(res, RESIDUAL_TOL, bm.Status.CONVERGED)


# ------------------------------------------------------------------ two blocks


@pytest.mark.parametrize("eta", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("mu", [0.3, 0.5, 0.65, 0.8, 1.0, 1.2])
def test_two_blocks_fixed_point_between_bounds(eta, mu):
    case = bm.cases.two_blocks(eta=eta, mu=mu)
    lam_assoc = associative(case).multiplier
    res = bm.solve(case, "fixed-point")
    assert_mcp_solution(res)
    assert two_block_nonassociative_min(eta, mu) - 1e-9 <= res.multiplier <= lam_assoc + 1e-9


def test_two_blocks_paper_point():
    """eta = 3, mu = 0.65: associative 1/2.3825 (paper Sect. 3: A2-1, printed 0.41973), NA minimum 1/3 (NA2)."""
    case = bm.cases.two_blocks(eta=3, mu=0.65)
    lam_assoc = associative(case).multiplier
    assert lam_assoc == pytest.approx(TWO_BLOCKS_ASSOCIATIVE, rel=1e-12)  # 0 measured
    assert round(lam_assoc, 5) == 0.41973  # the digits the paper prints
    for tie_break in ("closest", "none"):
        res = bm.solve(case, "fixed-point", tie_break=tie_break)
        assert_mcp_solution(res)
        assert 1 / 3 - 1e-9 <= res.multiplier <= lam_assoc + 1e-9


# ------------------------------------------------------------------ round arch


def test_round_arch_same_for_all_methods():
    case = bm.cases.round_arch()
    ref = associative(case)
    z = np.concatenate([ref.solution.z_u, ref.solution.z_f])
    # the associative mechanism has no sliding ...
    assert np.abs(ref.solution.z_f).max() <= 1e-9 * np.abs(z).max()
    # ... so the non-associative analysis gives the same multiplier (paper Table 1; the independent LP's value, whose
    # least over (3) SCIP certifies to be the same, references.py), and slp's LPs are the associative LP: it verifies
    for method in ("static-lp", "fixed-point", "slp"):
        res = bm.solve(case, method)
        assert res.success, (method, res.message)
        assert res.multiplier == pytest.approx(ROUND_ARCH_ASSOCIATIVE, rel=1e-9), method  # 1.1e-12 measured
    assert_mcp_solution(bm.solve(case, "fixed-point"))


# ------------------------------------------------------------------ walls


@pytest.mark.parametrize("courses,blocks", [(10, 5), pytest.param(10, 20, marks=pytest.mark.slow)])
def test_fixed_point_converges_on_running_bond_walls(courses, blocks):
    case = bm.cases.wall(courses, blocks)
    lam_assoc = associative(case).multiplier
    res = bm.solve(case, "fixed-point")
    assert_mcp_solution(res)
    assert res.multiplier <= lam_assoc + 1e-9
    tr = res.trace[-1]
    assert tr["n_change"] <= 1e-9
    assert res.extra["lp_solves"] >= res.iterations


# ------------------------------------------------------------------ built-in cases


BUILT_IN = {
    "round-arch": bm.cases.round_arch,
    "arch-on-buttresses": bm.cases.arch_on_buttresses,
    "wall": bm.cases.wall,
}


@pytest.mark.parametrize("name", list(BUILT_IN))
def test_fixed_point_and_slp_below_associative(name):
    case = BUILT_IN[name]()
    lam_assoc = associative(case).multiplier
    fp = bm.solve(case, "fixed-point")
    assert_mcp_solution(fp)
    assert fp.multiplier <= lam_assoc + 1e-9
    assert fp.residuals["friction_admissibility"] <= 1e-6
    slp = bm.solve(case, "slp")
    assert slp.iterations >= 2
    assert math.isfinite(slp.extra["friction_admissibility"])  # its own measure, the paper's Table 2
    if slp.success:  # on the arches (no sliding): the associative lam
        assert slp.multiplier == pytest.approx(lam_assoc, rel=1e-9)
    else:  # on the wall its point is no solution of (3) (compatibility 0.13): reported unverified
        assert_reported_unverified(slp)
        assert slp.multiplier <= lam_assoc + 1e-9


@pytest.mark.parametrize("name", list(BUILT_IN) + ["two-blocks"])
@pytest.mark.parametrize("tie_break", ["closest", "none"])
def test_tie_break_choice_keeps_convergence(name, tie_break):
    case = bm.build_case(name)
    lam_assoc = associative(case).multiplier
    res = bm.solve(case, "fixed-point", tie_break=tie_break)
    assert_mcp_solution(res)
    assert res.multiplier <= lam_assoc + 1e-9


@pytest.mark.parametrize("name", list(BUILT_IN) + ["two-blocks"])
@pytest.mark.parametrize("tie_break", ["closest", "none"])
def test_associative_friction_gives_associative_multiplier(name, tie_break):
    case = bm.build_case(name, dilatancy=0.65)  # psi = phi
    lam_assoc = associative(case).multiplier
    res = bm.solve(case, "fixed-point", start="associative", tie_break=tie_break)
    assert_mcp_solution(res)
    assert res.multiplier == pytest.approx(lam_assoc, abs=1e-9)
    assert res.iterations == 1


@pytest.mark.parametrize("tie_break", ["closest", "none"])
def test_relaxation_still_converges(tie_break):
    case = bm.cases.wall(10, 5)
    res = bm.solve(case, "fixed-point", tie_break=tie_break, relaxation=0.5)
    assert_mcp_solution(res)
    assert res.multiplier <= associative(case).multiplier + 1e-9


# ------------------------------------------------------------------ SLP vs fixed point


@pytest.mark.parametrize("tie_break", ["closest", "none"])
def test_slp_with_alpha0_beta1_is_the_fixed_point_step(tie_break):
    case = bm.cases.wall(10, 5)
    k = 6
    fp = bm.solve(case, "fixed-point", start="associative", tie_break=tie_break, max_iterations=k, tol=1e-300)
    slp = solve_with(case, "slp", settings=dict(tie_break=tie_break), alpha=0.0, beta=1.0, max_iterations=k,
                     tol=1e-300)
    m = min(len(fp.trace), len(slp.trace))
    assert m >= 2
    for a, b in zip(fp.trace[:m], slp.trace[:m]):
        assert a["multiplier"] == b["multiplier"]
        assert a["n_change"] == b["n_change"]
    if len(fp.trace) == len(slp.trace):
        np.testing.assert_array_equal(fp.solution.x, slp.solution.x)


def test_slp_stops_on_multiplier_not_normal_forces():
    res = bm.solve(bm.cases.wall(10, 5), "slp")
    assert res.iterations >= 2
    last = res.trace[-1]
    assert last["lam_change"] <= res.options["tol"]
    # it stops there, so its point on this wall is no solution of (3) (compatibility 1.8e-3): reported unverified,
    # with the change of normal forces it did not check
    assert_reported_unverified(res)
    assert "does not check normal forces" in res.message


# ------------------------------------------------------------------ statuses and options


def test_an_infeasible_step_is_no_proof_and_another_start_is_tried():
    # zero start: no cohesion and tan(psi) = 0 leave the arch no shear capacity at all, so the first step LP is
    # infeasible; that proves nothing about (3) (issue 41): the run goes on from the other starts (then, under
    # engine="auto", the interior engine), never reporting infeasible
    res = bm.solve(bm.cases.round_arch(), "fixed-point", start="zero")
    assert res.status is not bm.Status.INFEASIBLE
    assert res.extra["failed_starts"][0].startswith("zero start: iteration 1: the step LP is infeasible")
    assert res.success and res.verified, res.message
    assert res.multiplier <= bm.solve(bm.cases.round_arch(), "static-lp").multiplier + 1e-9


def test_iteration_limit_returns_last_iterate():
    res = bm.solve(bm.cases.wall(10, 5), "fixed-point", max_iterations=2)
    assert res.status is bm.Status.ITERATION_LIMIT
    assert res.iterations == 2 and len(res.trace) == 2
    assert res.multiplier == res.trace[-1]["multiplier"]
    # the last step's point: in equilibrium (5e-16 measured) but not yet friction admissible (0.05), so not verified
    assert res.residuals["equilibrium"] <= 1e-12 and res.residuals["friction_admissibility"] > 1e-3
    assert not res.success and "no convergence in 2 iterations" in res.message


def test_time_limit_status():
    res = bm.solve(bm.cases.wall(10, 5), "fixed-point", time_limit=1e-9)
    assert res.status is bm.Status.TIME_LIMIT


def test_trace_fields():
    res = bm.solve(bm.cases.wall(), "fixed-point", start="associative", tie_break="none")
    for k, row in enumerate(res.trace, start=1):
        assert row["iteration"] == k
        for key in ("time_s", "multiplier", "n_change", "friction_admissibility"):
            assert math.isfinite(row[key])
    assert res.extra["lp_solves"] == res.iterations + 1  # associative start + one LP per step


@pytest.mark.parametrize("method,options", [
    ("fixed-point", {"relaxation": 0.0}),
    ("fixed-point", {"relaxation": 1.5}),
    ("fixed-point", {"tol": 0.0}),
    ("fixed-point", {"tie_break": "nearest"}),
    ("fixed-point", {"start": "cold"}),
    ("fixed-point", {"max_iterations": 0}),
    ("slp", {"alpha": -0.1}),
    ("slp", {"beta": 0.0}),
    ("slp", {"max_iterations": 1}),
])
def test_bad_options(method, options):
    name = next(iter(options))
    with pytest.raises(OptionError, match=name):
        bm.solve(bm.cases.two_blocks(), method, **options)


# ------------------------------------------------------------------ aiming at the minimum (issue 13)

#: strategies of the study (studies/lab/fixed_point_strategies.py) that must stay sound: options, and engine settings
#: under "settings" (``solve_with``)
STRATEGIES = [
    {"start": "associative", "tie_break": "closest"},
    {"start": "associative", "tie_break": "min-lambda"},
    {"start": "associative", "tie_break": "least-compressed"},
    {"start": "dead-load", "tie_break": "least-compressed"},
    {"start": "dead-load", "tie_break": "on-oscillation"},
    {"start": "random", "seed": 3, "tie_break": "min-lambda"},
    {"start": "dead-load", "tie_break": "least-compressed", "settings": {"acceleration": "anderson"}},
    {"start": "dead-load", "tie_break": "least-compressed", "settings": {"fold_weight": 1e-4}},
]


def certified_minimum(case):
    res = bm.solve(case, "milp", time_limit=60.0)
    assert res.status is bm.Status.OPTIMAL and res.success, res.message
    return res.multiplier


@pytest.mark.parametrize("eta,mu", [(3, 0.65), (5, 1.2), (2.5, 0.9), (4, 0.5), (6, 0.3)])
def test_default_fixed_point_reaches_the_two_block_closed_form_minimum(eta, mu):
    case = bm.cases.two_blocks(eta=eta, mu=mu)
    minimum = bm.cases.closed_form("two-blocks", "non-associative", eta=eta, mu=mu)
    assert minimum < associative(case).multiplier - 1e-3  # a point where the minimum is below the associative
    res = bm.solve(case, "fixed-point")
    assert_mcp_solution(res)
    assert res.multiplier == pytest.approx(minimum, abs=FIXED_POINT)


def test_default_fixed_point_reaches_the_certified_minimum_of_the_stack_wall():
    case = bm.cases.wall(4, 2, bond="stack")
    minimum = STACK_WALL_4X2_MINIMUM  # SCIP's certificate of the independent statement (references.py)
    assert certified_minimum(case) == pytest.approx(minimum, abs=1e-12)  # milp's: 0 measured
    assert minimum < associative(case).multiplier - 1e-3
    res = bm.solve(case, "fixed-point")
    assert_mcp_solution(res)
    assert res.multiplier == pytest.approx(minimum, abs=FIXED_POINT)  # 0 measured


def test_old_default_is_an_option_and_returns_the_associative_solution():
    case = bm.cases.two_blocks(eta=3, mu=0.65)
    res = bm.solve(case, "fixed-point", start="associative", tie_break="closest")
    assert_mcp_solution(res)
    assert res.iterations == 1
    assert res.multiplier == pytest.approx(associative(case).multiplier, abs=1e-9)
    assert res.extra["associative_multiplier"] == pytest.approx(res.multiplier, abs=1e-9)


@pytest.mark.parametrize("case", [
    bm.cases.two_blocks(eta=4, mu=0.9),
    bm.cases.wall(5, 2, bond="stack"),
    bm.cases.wall(3, 2, openings=[[0.5, 0.5, 1.5, 1.0]]),
], ids=["two-blocks", "stack-5x2", "running-3x2-opening"])
def test_no_strategy_falls_below_the_certificate(case):
    minimum = certified_minimum(case)
    for options in STRATEGIES:
        res = solve_with(case, "fixed-point", **options)
        assert res.status is bm.Status.CONVERGED, (options, res.message)
        assert_mcp_solution(res)
        assert res.multiplier >= minimum - 1e-7, options
        assert res.residuals["friction_admissibility"] <= 1e-6


@pytest.mark.parametrize("options", [{}, {"start": "random", "seed": 7}, {"multistart": 3}])
def test_fixed_point_is_deterministic(options):
    case = bm.cases.wall(10, 5)
    a = bm.solve(case, "fixed-point", **options)
    b = bm.solve(case, "fixed-point", **options)
    assert a.multiplier == b.multiplier  # bitwise
    assert a.iterations == b.iterations
    np.testing.assert_array_equal(a.solution.x, b.solution.x)


def test_multistart_keeps_the_lowest_verified_run():
    case = bm.cases.wall(10, 5)
    res = bm.solve(case, "fixed-point", multistart=3)
    assert_mcp_solution(res)
    runs = res.extra["multistart_runs"]
    assert len(runs) == 3
    converged = [lam for lam, _, _, status in runs if status == "converged"]
    assert res.multiplier == min(converged)


def test_tie_break_lp_is_a_formulation():
    """The tie-break LP is built in formulations/ and holds the step LP (5) as its first rows."""
    from blockmpec.formulations import compile_linear, modified_lp, tie_break_lp

    ops = bm.assemble(bm.cases.wall())
    n_star = -np.linspace(1.0, 2.0, ops.n_interfaces)
    step = compile_linear(modified_lp(ops, n_star))
    tie = compile_linear(tie_break_lp(ops, n_star))
    for group in ("equilibrium", "unilateral", "friction"):
        np.testing.assert_array_equal(tie.row_upper[tie.rows[group]], step.row_upper[step.rows[group]])
    np.testing.assert_array_equal(tie.row_upper[tie.rows["deviation_up"]], n_star)
    np.testing.assert_array_equal(tie.row_upper[tie.rows["deviation_down"]], -n_star)
    # friction rows' right-hand side: the cohesion -(tan(phi) - tan(psi)) n* of each interface, twice
    np.testing.assert_allclose(step.row_upper[step.rows["friction"]], np.repeat(-ops.friction * n_star, 2))


@pytest.mark.slow
def test_auto_fixed_point_leaves_wandering_lp_steps_for_the_interior_engine():
    """On an irregular stone wall the LP steps' map ``n* -> n`` does not contract (``||n - n*||`` wanders at a few
    per cent): ``engine="auto"`` stops them once their smallest change has not halved in
    ``plan.FIXED_POINT_STALL_STEPS`` steps and the interior engine verifies a solution of (3) at or below the
    associative multiplier; ``engine="simplex"`` alone keeps iterating to its limit."""
    from blockmpec.solvers import plan

    wall = bm.cases.stone_wall()  # 95 stones
    auto = bm.solve(wall, "fixed-point")
    associative = bm.solve(wall, "static-lp").multiplier
    assert auto.success and auto.multiplier <= associative + 1e-9
    assert auto.extra["engine"] == "simplex, then interior" and auto.extra["simplex_status"] == "numerical"
    steps = [r for r in auto.trace if r.get("engine") == "simplex" and r.get("n_change") is not None]
    assert len(steps) >= plan.FIXED_POINT_STALL_STEPS
    simplex = bm.solve(wall, "fixed-point", engine="simplex", max_iterations=3 * plan.FIXED_POINT_STALL_STEPS)
    assert simplex.status is bm.Status.ITERATION_LIMIT and not simplex.success

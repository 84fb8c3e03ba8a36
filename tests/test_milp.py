"""The ``milp`` method: certified global minimum of the non-associative MPEC (4), and maximum.

Checks: the closed-form two-block minimum over a grid (with a closed gap), a case
where the global minimum lies far below the associative value, published
arch values, ``lam_milp <= lam_associative`` on built-in cases, round-off
residuals after polishing, and that too small big-M bounds are reported instead
of silently giving a wrong answer.  With ``sense="max"``: the paper's statement
that on the two-block problem the largest non-associative multiplier equals the
associative one (its Fig. 6c = Fig. 6a) over the same grid, ``min <= max`` on
built-in cases, and the flipped certificate logic.
"""

import functools
import itertools

import numpy as np
import pytest
from milp_runs import milp_solver, solve_milp

import blockmpec as bm
from blockmpec.deadline import Deadline
from blockmpec.result import Status
from helpers import LIFTING_CASES, assert_certified, two_block_associative, two_block_nonassociative_min

ETAS = [1, 2, 3, 4, 5]
MUS = [0.3, 0.5, 0.65, 0.8, 1.0, 1.2, 1.5]
#: residuals of (3) at a polished point (exact LPs on its pattern at HiGHS's feasibility tolerance 1e-9)
POLISHED_TOL = 1e-7
#: the certified multiplier of a closed-form case against its formula: measured 0 (min, 35 two-block cases) and
#: 2.2e-16 (max, 70 runs); the polished point is an LP optimum, exact to round-off
EXACT_TOL = 1e-12

pytest.importorskip("highspy")


SMALL_CASES = {
    "round-arch": bm.cases.round_arch,
    "arch-on-buttresses": bm.cases.arch_on_buttresses,
    "wall-2x2": lambda: bm.cases.wall(2, 2),
    "wall-3x2-stack": lambda: bm.cases.wall(3, 2, bond="stack"),
    "two-blocks": lambda: bm.cases.two_blocks(eta=3, mu=0.65),
    "single-block": lambda: bm.cases.single_block(width=1, height=2, mu=0.65),
}


@functools.cache
def solved(case_id: str, method: str, **options) -> bm.Result:
    """One run per (case, method, options) for the whole module (the arches take ~1 s each)."""
    if method == "milp":
        return solve_milp(SMALL_CASES[case_id](), **options)
    return bm.solve(SMALL_CASES[case_id](), method, **options)


@pytest.mark.parametrize(("eta", "mu"), list(itertools.product(ETAS, MUS)))
def test_two_blocks_closed_form_minimum(eta, mu):
    res = solve_milp(bm.cases.two_blocks(eta=eta, mu=mu))
    assert_certified(res)
    expected = mu if mu <= 1 / eta else 1 / eta  # the paper's Sect. 3 (Fig. 5b/6b)
    assert expected == pytest.approx(two_block_nonassociative_min(eta, mu), abs=1e-12)
    assert abs(res.multiplier - expected) <= EXACT_TOL


def test_two_blocks_global_minimum_below_associative_and_heuristic_value():
    """eta = 3, mu = 1.5: the certified minimum is 1/3 (both blocks rock together).

    The associative multiplier is 2/3, and a local method started from the
    associative mechanism (the right block rocking alone, no sliding) may stop at
    the MCP solution lam = 2/3; the MILP proves that nothing below 1/3 exists and
    finds 1/3.
    """
    res = solve_milp(bm.cases.two_blocks(eta=3, mu=1.5))
    assert_certified(res)
    assert res.multiplier == pytest.approx(1 / 3, abs=EXACT_TOL)
    assert two_block_associative(3, 1.5) == pytest.approx(2 / 3, abs=1e-12)
    assert res.extra["associative_multiplier"] == pytest.approx(2 / 3, abs=EXACT_TOL)
    # the bound is the LP bound widened by milp's margins (measured 1e-8 below the minimum)
    assert res.extra["bound"] >= 1 / 3 - 1e-7


def test_round_arch_published_value():
    """The paper's Table 1: 0.16034 (every method; the arch collapses by rocking alone).  SCIP on the MPEC written
    from (3) with SOS1 pairs (pyscipopt 6.3.0, issue 53's scratch check) certifies 0.1603447650884432."""
    res = solved("round-arch", "milp")
    assert_certified(res)
    assert round(res.multiplier, 5) == 0.16034
    assert res.multiplier == pytest.approx(0.1603447650884432, abs=EXACT_TOL)  # measured 3e-16 apart


@pytest.mark.parametrize("case_id", list(SMALL_CASES))
def test_not_above_associative(case_id):
    structure = SMALL_CASES[case_id]()
    assoc = solved(case_id, "static-lp")
    res = solved(case_id, "milp", engine="highs")  # the big-M model's engine (the default "auto" runs bnb here)
    assert_certified(res)
    assert res.multiplier <= assoc.multiplier + 1e-9
    # every recorded big-M bound covers the slack of the returned solution
    ops = bm.operators.assemble(structure)
    x = res.solution.x
    c = ops.n_interfaces
    M = np.array(res.extra["bigm"])
    if M.size == 0:  # certified at the root from the LP bound on lam: no big-M model was built
        assert res.extra["nodes"] == 0 and "root" in res.message
        return
    assert M.shape == (4 * c,) and np.all(np.isfinite(M)) and np.all(M >= 0)
    slack = -np.concatenate([ops.N_u.T @ x, ops.N_f.T @ x])  # independent of the compiled model
    assert np.all(slack <= M)


@pytest.mark.parametrize(
    "structure",
    [bm.cases.two_blocks(eta=3, mu=0.65, dilatancy=0.65), bm.cases.two_blocks(eta=3, mu=1.5, dilatancy=1.5),
     bm.cases.wall(2, 2, dilatancy=0.65), bm.cases.round_arch(dilatancy=0.65)],
    ids=["two-blocks-0.65", "two-blocks-1.5", "wall-2x2", "round-arch"],
)
def test_associative_flow_gives_the_lp_multiplier(structure):
    """With psi = phi the MCP (3) is the optimality system of the LP (1): its minimum is the LP value."""
    assoc = bm.solve(structure, "static-lp")
    res = solve_milp(structure)
    assert_certified(res)
    assert abs(res.multiplier - assoc.multiplier) <= EXACT_TOL  # measured 0 on all four


def test_single_block_closed_form():
    res = solve_milp(bm.cases.single_block(width=1, height=2, mu=0.65))
    assert_certified(res)
    assert res.multiplier == pytest.approx(0.5, abs=EXACT_TOL)  # min(mu, width / height)
    res = solve_milp(bm.cases.single_block(width=1, height=1, mu=0.3))
    assert_certified(res)
    assert res.multiplier == pytest.approx(0.3, abs=EXACT_TOL)


@pytest.mark.parametrize("scale", [0.95, 0.8, 0.5, 0.01])
@pytest.mark.parametrize("mu", [0.65, 1.5])
def test_too_small_bigm_is_detected(scale, mu):
    """Shrunken slack bounds cut off the optimum: never reported as a certified optimum."""
    structure = bm.cases.two_blocks(eta=3, mu=mu)
    res = solve_milp(structure, engine="highs", bigm_scale=scale)
    assert res.status is not Status.OPTIMAL and res.status is not Status.INFEASIBLE  # a restriction proves nothing
    if res.status is Status.ERROR:
        assert "bigm_scale" in res.message
    else:
        assert res.extra["bigm_active"], res.message
        assert "certificate" in res.message


def test_thread_count_may_change_between_solves_in_one_process():
    """HiGHS refuses a run whose ``threads`` differs from its running scheduler's size
    (highspy 1.16 keeps the scheduler between runs): an LP with HiGHS's default thread
    count, then milp with one thread, then two, must all certify the closed form."""
    structure = bm.cases.two_blocks(eta=3, mu=1.5)
    assert bm.solve(structure, "static-lp").status is Status.OPTIMAL
    expected = two_block_nonassociative_min(3, 1.5)
    for threads in (1, 2, 1):
        res = solve_milp(structure, threads=threads)
        assert res.status is Status.OPTIMAL, f"threads={threads}: {res.message}"
        assert res.multiplier == pytest.approx(expected, abs=1e-7)


def test_time_limit_returns_polished_incumbent_and_gap():
    """A stop at the time limit returns the best exact point found (here the associative optimum's pattern point,
    which is ready before any heuristic or bound LP), its bound and its gap; the 6x3 wall's root LP alone takes over
    a minute."""
    res = solve_milp(bm.cases.wall(6, 3), time_limit=2.0)
    assert res.status is Status.TIME_LIMIT
    assert res.verified and max(res.residuals.values()) <= POLISHED_TOL
    assert res.extra["bound"] is not None and res.extra["bound"] <= res.multiplier
    assert res.extra["gap_abs"] == pytest.approx(res.multiplier - res.extra["bound"], abs=1e-12)
    assert "best lam" in res.message and "bound" in res.message and "gap" in res.message


def test_spurious_zero_live_work_point_is_not_certified(monkeypatch):
    """Without the sliding-direction cut, z_f[2k] = z_f[2k+1] = 1/2 with u = 0 solves the normalised
    system (psi = 0): the relaxation's optimum then has tau = f_l^T u = 0.  The solver must notice
    (no mechanism for the pattern), fall back to the restriction tau >= tau_restart for a genuine
    solution, and not claim a certificate."""
    import blockmpec.formulations.mpec_milp as fm

    build = fm.mpec_milp

    def without_cut(*args, **kwargs):
        mip = build(*args, **kwargs)
        rows = np.setdiff1d(np.arange(mip.A.shape[0]), mip.rows["sliding_direction"])
        mip.row_lower[mip.rows["sliding_direction"]] = -np.inf  # the rows stay, unbinding
        mip.row_upper[mip.rows["sliding_direction"]] = np.inf
        assert rows.size < mip.A.shape[0]
        return mip

    monkeypatch.setattr(fm, "mpec_milp", without_cut)
    res = solve_milp(bm.cases.two_blocks(eta=3, mu=1.5), engine="highs", incumbent=False)
    assert res.status is not Status.OPTIMAL
    assert "tau_restart" in res.extra
    assert res.extra["bound"] < 1 / 3 - 1e-3
    assert res.multiplier == pytest.approx(1 / 3, abs=EXACT_TOL)  # the restriction's point solves (3)
    assert max(res.residuals.values()) <= POLISHED_TOL


@pytest.mark.parametrize(
    ("option", "value"),
    [("time_limit", 0.0), ("mip_rel_gap", -1e-3), ("threads", 0), ("sense", "maximum"), ("sense", ""),
     ("engine", "gurobi")],
)
def test_bad_options(option, value):
    with pytest.raises(bm.errors.OptionError, match=option):
        bm.solve(bm.cases.two_blocks(), "milp", **{option: value})


def test_the_scip_engine_is_gone_with_a_clear_message():
    with pytest.raises(bm.errors.OptionError, match="'scip' was removed"):
        bm.solve(bm.cases.two_blocks(), "milp", engine="scip")


@pytest.mark.parametrize(("setting", "value"), [("mip_abs_gap", -1.0), ("bigm_scale", 0.0), ("lifting", "square"),
                                                ("root_lp", "pdlp"), ("root_lp", "ipm-rows")])
def test_bad_settings(setting, value):
    from blockmpec.solvers.milp import MILPSettings

    with pytest.raises(ValueError, match=setting):
        MILPSettings(**{setting: value})


def test_settings_are_not_options():
    """The engine settings go in a MILPSettings, not to bm.solve (which names the valid options)."""
    with pytest.raises(bm.errors.OptionError, match="lifting"):
        bm.solve(bm.cases.two_blocks(), "milp", lifting="rlt")


# ----------------------------------------------------------------------------- sense="max"


@pytest.mark.parametrize(("eta", "mu"), list(itertools.product(ETAS, MUS)))
def test_two_blocks_maximum_is_the_associative_multiplier(eta, mu):
    """Paper Sect. 3 / Fig. 6c = Fig. 6a: the largest non-associative multiplier is the associative one.

    Checked with the associative-pattern incumbent (default) and without it, so that the
    maximum is found and certified by branch and bound alone.
    """
    structure = bm.cases.two_blocks(eta=eta, mu=mu)
    assoc = bm.solve(structure, "static-lp")
    assert assoc.status is Status.OPTIMAL
    for incumbent in (True, False):
        res = solve_milp(structure, sense="max", incumbent=incumbent)
        assert_certified(res, "max")
        assert abs(res.multiplier - assoc.multiplier) <= EXACT_TOL, (incumbent, res.multiplier, assoc.multiplier)
        assert res.extra["associative_multiplier"] == pytest.approx(assoc.multiplier, abs=EXACT_TOL)


@pytest.mark.parametrize("case_id", list(SMALL_CASES))
def test_minimum_not_above_maximum(case_id):
    lo = solved(case_id, "milp")
    hi = solved(case_id, "milp", sense="max")
    assoc = solved(case_id, "static-lp")
    assert_certified(lo, "min")
    assert_certified(hi, "max")
    assert lo.multiplier <= hi.multiplier + 1e-9
    assert hi.multiplier <= assoc.multiplier + 1e-9


def test_round_arch_maximum_equals_minimum():
    lo = solved("round-arch", "milp")
    hi = solved("round-arch", "milp", sense="max")
    assert_certified(hi, "max")
    assert round(hi.multiplier, 5) == round(lo.multiplier, 5) == 0.16034


@pytest.mark.parametrize("scale", [0.95, 0.8, 0.5, 0.01])
@pytest.mark.parametrize("mu", [0.65, 1.5])
def test_maximum_with_too_small_bigm_is_not_certified(scale, mu):
    """Shrunken slack bounds give a restriction: never a certified maximum, even when no slack
    reaches its bound (at mu = 0.65, bigm_scale = 0.95 the maximiser's slacks all stay below)."""
    res = solve_milp(bm.cases.two_blocks(eta=3, mu=mu), sense="max", bigm_scale=scale)
    assert res.status is not Status.OPTIMAL and res.status is not Status.INFEASIBLE
    assert "bigm_scale" in res.message
    if res.status is not Status.ERROR:
        assert "certificate" in res.message and "maximality" in res.message


def test_maximum_after_a_zero_live_work_relaxation_point(monkeypatch):
    """The tau = 0 fallback under maximisation: when the relaxation's pattern admits no mechanism,
    the restriction tau >= tau_restart supplies a point of (3) (a lower bound on the maximum) and the
    relaxation's dual bound stays the upper bound; the answer is the associative value 2/3."""
    from blockmpec.solvers.milp import MILPSolver

    mechanism = MILPSolver.pattern_mechanism
    calls = {"n": 0}

    def first_call_fails(self, active):
        calls["n"] += 1
        return None if calls["n"] == 1 else mechanism(self, active)

    monkeypatch.setattr(MILPSolver, "pattern_mechanism", first_call_fails)
    res = solve_milp(bm.cases.two_blocks(eta=3, mu=1.5), sense="max", incumbent=False)
    assert calls["n"] >= 2 and "tau_restart" in res.extra
    assert res.status is Status.OPTIMAL, res.message  # the restriction's point meets the relaxation's bound
    assert res.extra["bound"] >= 2 / 3 - 1e-7  # CERTIFICATE_TOL
    assert res.multiplier == pytest.approx(2 / 3, abs=EXACT_TOL)
    assert max(res.residuals.values()) <= POLISHED_TOL


# ----------------------------------------------------------------------------- issue 12: engines, bounds, trace

MODEL_ENGINES = ["highs"]
ENGINES = MODEL_ENGINES + ["bnb"]


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize(("eta", "mu"), list(itertools.product([1, 3, 5], [0.3, 0.65, 1.5])))
def test_every_engine_certifies_the_closed_form(engine, eta, mu):
    """Each engine, with and without the work envelope, certifies the closed-form two-block minimum."""
    expected = bm.cases.closed_form("two-blocks", "non-associative", eta=eta, mu=mu)
    for envelope in (False, True):
        res = solve_milp(bm.cases.two_blocks(eta=eta, mu=mu), engine=engine, envelope=envelope)
        assert_certified(res)
        assert abs(res.multiplier - expected) <= EXACT_TOL, (envelope, res.multiplier, expected)


@pytest.mark.parametrize("engine", MODEL_ENGINES)
@pytest.mark.parametrize("case_id", ["wall-2x2", "wall-3x2-stack", "round-arch", "single-block"])
def test_every_model_row_holds_at_a_solution(engine, case_id):
    """The bounds are derived, not trusted: at a certified solution of (3), rescaled to 1^T z = 1 with
    p = x_r z_i and q = lam tau, every row and column bound of the mixed-integer model (big-M or SOS1
    slacks, switches, work identity, McCormick envelopes, lam tau envelope, dead-work cuts) holds."""
    structure = SMALL_CASES[case_id]()
    res = solved(case_id, "milp")
    assert_certified(res)
    solver = milp_solver(engine=engine, envelope=True)
    solver.setup(bm.operators.assemble(structure))
    bd = solver.lp_bounds(Deadline(60))
    mip = solver.build_mip(bd)
    v = solver.start_vector(mip, solver.scaled(res.solution))  # the model is in per-block units
    r = mip.A @ v
    scale = max(1.0, float(np.abs(v).max()))
    tol = 1e-7 * scale
    assert np.all(r >= mip.row_lower - tol) and np.all(r <= mip.row_upper + tol)
    assert np.all(v >= mip.col_lower - tol) and np.all(v <= mip.col_upper + tol)
    assert mip.rows["work_identity"].size == 1


def test_heuristics_never_below_the_certificate():
    """No verified heuristic result lies below a certified minimum; the heuristics that solve (3) (every one but the
    SLP, whose tilted friction surface leaves dilatancy) verify on these small cases."""
    from helpers import HEURISTIC_TOL, HEURISTICS, margin

    for case_id in ("wall-2x2", "two-blocks", "round-arch"):
        lo = solved(case_id, "milp")
        assert_certified(lo)
        results = {method: solved(case_id, method) for method in HEURISTICS}
        verified = {m: r for m, r in results.items() if r.verified and r.status.is_success}
        assert set(HEURISTICS) - {"slp"} <= set(verified), (case_id, {m: r.status for m, r in results.items()})
        for method, res in verified.items():
            assert res.multiplier >= lo.multiplier - margin(HEURISTIC_TOL, lo.multiplier), (case_id, method)


@pytest.mark.parametrize("options", [{"engine": e} for e in ENGINES]
                         + [{"engine": "bnb", "lifting": lifting, "root_lp": "ipm"} for lifting in ("rlt", "rlt-full")],
                         ids=lambda o: "-".join(o.values()))
@pytest.mark.slow
def test_bound_never_exceeds_a_verified_point(options):
    """On a time-out the bound (and every bound in the trace) lies below every verified point of (3):
    the run's own polished point and each verified heuristic result.  A heuristic's lam is that of
    an exact solution of (3) only to ``margin(HEURISTIC_TOL)``, so that exact solution's lam, which
    the bound must not exceed, is at most the heuristic's lam plus the margin (a bound that meets
    the minimum exactly may lie above the heuristic's lam minus the margin)."""
    from helpers import HEURISTIC_TOL, margin

    structure = bm.cases.wall(3, 3)
    res = solve_milp(structure, time_limit=5.0, **options)
    assert res.status in (Status.TIME_LIMIT, Status.OPTIMAL), res.message
    assert res.verified and res.extra["bound"] is not None  # every stop returns its best point and its bound
    points = [res.multiplier]
    for method in ("fixed-point", "nlp"):
        h = bm.solve(structure, method)
        assert h.verified and h.status.is_success, (method, h.message)
        points.append(h.multiplier + margin(HEURISTIC_TOL, h.multiplier))
    bounds = [res.extra["bound"]] + [r["bound"] for r in res.trace if r.get("bound") is not None]
    assert max(bounds) <= min(points) + 1e-7  # CERTIFICATE_TOL: a bound may meet an exact point to within it
    # the trace records time, bound, incumbent and gap, in time order
    search = [r for r in res.trace if r.get("stage") == "search"]
    assert search and all({"time_s", "bound", "incumbent", "gap_abs"} <= set(r) for r in search)
    times = [r["time_s"] for r in res.trace]
    assert times == sorted(times)


@pytest.mark.slow
def test_rlt_full_certifies_the_5x2_running_bond_wall():
    """Issue 12's hardest 60 s target, end to end (not timed): with the moments' products the lifted root LP
    certifies the 5x2 running-bond wall, every heuristic's verified point lies above the certified bound, and
    the certified point solves (3) (``rlt`` stops at a root bound of 0.558 there: studies/lab/certificate_study.py)."""
    from helpers import HEURISTIC_TOL, margin

    structure = bm.cases.wall(5, 2, bond="running", mu=0.65)
    res = solve_milp(structure, engine="bnb", lifting="rlt-full", root_lp="ipm", time_limit=300.0)
    assert res.status is Status.OPTIMAL and res.verified, res.message
    bound = res.extra["bound"]
    assert bound <= res.multiplier + 1e-12 and res.multiplier - bound <= 1e-7 * max(1.0, abs(res.multiplier))
    for method in ("fixed-point", "nlp", "mcp-newton"):
        h = bm.solve(structure, method)
        assert h.verified and h.status.is_success, (method, h.message)
        assert h.multiplier + margin(HEURISTIC_TOL, h.multiplier) >= bound - 1e-9, method


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("scale", [0.8, 0.01])
def test_too_small_bigm_is_detected_by_every_engine(engine, scale):
    res = solve_milp(bm.cases.two_blocks(eta=3, mu=1.5), engine=engine, bigm_scale=scale)
    assert res.status is not Status.OPTIMAL
    assert "bigm_scale" in res.message or res.extra["bigm_active"], res.message


def test_bnb_needs_min():
    with pytest.raises(bm.errors.OptionError, match="bnb"):
        solve_milp(bm.cases.two_blocks(), engine="bnb", sense="max")


def test_auto_engine_runs_bnb_for_the_minimum_and_highs_otherwise(monkeypatch):
    """engine="auto" (the default): bnb for sense="min" on a small structure, highs for sense="max" and
    above MILP_BNB_MAX_PAIRS; both certify the same minimum; bnb's settings with sense="max" are refused."""
    from blockmpec.solvers import plan

    structure = bm.cases.wall(2, 2)
    by_bnb = solve_milp(structure, incumbent=False, heuristic="")  # no root certificate: an engine runs
    assert_certified(by_bnb)
    assert by_bnb.extra["engine"] == "bnb"
    # the root's interior points ran (root_lp="ipm" is the default), inside the search's time
    assert 0 < by_bnb.extra["root_interior_time_s"] <= by_bnb.extra["search_time_s"]
    assert by_bnb.extra["root_crossover_runs"] >= 0
    assert solve_milp(structure, sense="max").extra["engine"] in ("highs", "root")
    monkeypatch.setattr(plan, "MILP_BNB_MAX_PAIRS", 0)
    by_highs = solve_milp(structure, incumbent=False, heuristic="")
    assert_certified(by_highs)
    assert by_highs.extra["engine"] == "highs"
    assert by_highs.multiplier == pytest.approx(by_bnb.multiplier, abs=1e-7)
    with pytest.raises(bm.errors.OptionError, match="bnb"):
        solve_milp(structure, lifting="rlt", sense="max")


@pytest.mark.parametrize("options", [{"lifting": "friction", "root_lp": "simplex"}, {}], ids=["friction", "default"])
@pytest.mark.parametrize("case_id", ["wall-2x2", "two-blocks"])
def test_bnb_without_any_incumbent_finds_and_certifies_the_minimum(options, case_id):
    """No associative-pattern start and no heuristic: the search itself must find the point (before the fix
    an infinite incumbent made the prune tolerance infinite, and the run ended with no point at all)."""
    structure = {"wall-2x2": lambda: bm.cases.wall(2, 2), "two-blocks": lambda: bm.cases.two_blocks(eta=3, mu=0.65)}
    res = solve_milp(structure[case_id](), engine="bnb", incumbent=False, heuristic="", **options)
    assert_certified(res)
    reference = solve_milp(structure[case_id](), engine="highs")
    assert_certified(reference)
    assert res.multiplier == pytest.approx(reference.multiplier, abs=1e-7)


@pytest.mark.parametrize("case_id", ["wall-2x2", "wall-3x2-stack", "round-arch", "arch-on-buttresses"])
def test_bnb_and_highs_certify_the_same_minimum(case_id):
    """The lifted-LP branch and bound (no big-M) and the big-M MILP certify the same value."""
    ref = solved(case_id, "milp")
    res = solved(case_id, "milp", engine="bnb")
    assert_certified(ref)
    assert_certified(res)
    assert abs(res.multiplier - ref.multiplier) <= 1e-7


def test_dissipation_bound_is_below_every_certified_minimum():
    """The LP bound of the work identity (conditional OBBT on n) never exceeds the certified minimum,
    and on the stack wall it is tight (certified at the root, no search)."""
    for case_id in SMALL_CASES:
        res = solved(case_id, "milp")
        assert_certified(res)
        diss = res.extra["lam_dissipation"]
        assert diss is None or diss <= res.multiplier + 1e-9, (case_id, diss, res.multiplier)
    stack = solve_milp(bm.cases.wall(6, 2, bond="stack"))
    assert_certified(stack)
    assert stack.extra["nodes"] == 0 and "root" in stack.message


# ----------------------------------------------------------------------------- issue 16: per-block units


@pytest.mark.parametrize("engine", ["highs", "bnb"])
@pytest.mark.parametrize("small", [1e-3, 1e-5])
def test_tiny_block_on_big_block_is_certified_in_per_block_units(engine, small):
    """A small x 2 small block on a unit block: its loads are 1e-6 / 1e-10 of the big block's, below
    the engines' absolute tolerances unless each block's rows are in its own units.  The minimum is
    the toppling of the small block, lam = 0.5 (before the units: -0.65 / 0.65 'numerical')."""
    from helpers import block_on_block

    res = solve_milp(block_on_block(1.0, small), engine=engine, heuristic="")
    assert_certified(res)
    assert res.multiplier == pytest.approx(0.5, rel=1e-9)


@pytest.mark.parametrize("engine", ["highs", "bnb"])
def test_huge_dead_point_loads_are_certified_in_the_problems_units(engine):
    """Dead point loads 1e10 times the weights: lam ~3.3e9 is certified; the MILP runs with lam in
    a power-of-two unit, and the bound, the gap and the big-M bounds come back in the problem's
    units: the bound meets the returned lam, and every returned slack lies under its big-M (engine
    "highs"; "bnb" has no big-M)."""
    import json
    from pathlib import Path

    from blockmpec.structure_file import structure_from_dict

    d = json.loads((Path(bm.__file__).parent / "data" / "leaning-pier.json").read_text())
    d["point_loads"] = [{"block": b, "point": p, "force": [0, -1e10], "kind": "dead"}
                        for b, p in [(1, [0.5, 0.25]), (2, [0.4, 1.0]), (3, [1.5, 0.25])]]
    structure = structure_from_dict(d)
    assoc = bm.solve(structure, "static-lp")
    res = solve_milp(structure, engine=engine, heuristic="", incumbent=False)
    assert_certified(res)
    assert res.extra["engine"] == engine
    unit = res.extra["lam_unit"]
    assert unit > 1e9 and np.log2(unit) == round(np.log2(unit))
    assert res.multiplier == pytest.approx(assoc.multiplier, rel=1e-9)
    assert abs(res.extra["bound"] - res.multiplier) <= 1e-7 * res.multiplier
    ops = bm.operators.assemble(structure)
    slack = -np.concatenate([ops.N_u.T @ res.solution.x, ops.N_f.T @ res.solution.x])
    M = np.array(res.extra["bigm"])
    assert (M.size == 0) == (engine == "bnb")
    if engine == "highs":
        assert M.shape == slack.shape and np.all(slack <= M)


# ----------------------------------------------------------------------------- issue 12: liftings of the bnb engine

LIFTINGS = ["friction", "mechanism", "all", "rlt", "rlt-full"]

def _lifted(structure, lifting: str):
    """(solver in per-block units, ComplementarityBnB with no incumbent) for ``lifting``."""
    solver = milp_solver(engine="bnb", lifting=lifting, root_lp="simplex")
    solver.setup(bm.operators.assemble(structure))
    return solver, solver.branch_and_bound(solver.lp_bounds(Deadline(60)))


def _at_root(structure, lifting: str):
    """The ComplementarityBnB of :func:`_lifted` with the root pattern applied (no cap from an incumbent) and 60 s
    for its LPs: ready for the root's interior points."""
    _, bnb = _lifted(structure, lifting)
    bnb.deadline = Deadline(60)
    bnb.apply_node(bnb.root, bnb.lam_lower, bnb.lam_cap)
    return bnb


@functools.cache
def certified_minimum(case_id: str) -> bm.Result:
    res = solve_milp(LIFTING_CASES[case_id]())
    assert_certified(res)
    return res


@pytest.mark.parametrize("lifting", LIFTINGS)
@pytest.mark.parametrize("case_id", list(LIFTING_CASES))
def test_every_lifted_row_holds_at_a_certified_solution(lifting, case_id):
    """The lifted LP is derived, not trusted: the certified minimiser (big-M MILP), lifted (``x^(i) = z_i x``,
    ``zeta = lam z``, ``v = lam u``, ``W = x u^T``), satisfies every row and column bound of the root LP,
    the copies' own pair rows ``G_i x^(i) = 0`` included; so the root bound cannot exceed the minimum,
    and with ``lam`` fixed at the minimum the LP stays feasible."""
    res = certified_minimum(case_id)
    solver, bnb = _lifted(LIFTING_CASES[case_id](), lifting)
    form = solver.form
    w = form.pack(solver.scaled(res.solution))
    v = bnb.layout.lift(w[form.lam], w[form.x], w[form.u], w[form.z])
    bnb.apply_node(bnb.root, bnb.lam_lower, bnb.lam_cap)
    _, row_lower, row_upper, col_lower, col_upper = bnb.lp_arrays()
    r = bnb.lifted_matrix @ v
    tol = 1e-7 * max(1.0, float(np.abs(v).max()))
    assert np.all(r >= row_lower - tol) and np.all(r <= row_upper + tol)
    assert np.all(v >= col_lower - tol) and np.all(v <= col_upper + tol)
    lam = w[form.lam]
    assert bnb.root_bound() <= lam + 1e-7 * max(1.0, abs(lam))
    fixed = bnb.root_bound(lam - 1e-9, lam + 1e-9)
    if (lifting, case_id) == ("rlt-full", "wall-4x2-stack-mu0.4"):
        # HiGHS's dual simplex ends this LP in a solve error (nan; the engine never prunes on it), never infeasible
        assert fixed != np.inf
    else:
        assert np.isfinite(fixed)


def test_rlt_root_bound_is_the_running_bond_minimum():
    """On the 2x2 running-bond wall (minimum 0.65 = mu) the products with the mechanism close the gap at the
    root; the friction-pair copies alone give 0.16 (the branch and bound has to close the rest)."""
    bounds = {lifting: _lifted(bm.cases.wall(2, 2), lifting)[1].root_bound() for lifting in ("friction", "rlt")}
    assert bounds["friction"] < 0.2
    assert bounds["rlt"] == pytest.approx(0.65, abs=1e-7)


@pytest.mark.parametrize(("lifting", "lam_branching", "root_lp"),
                         [("rlt", False, "simplex"), ("friction", True, "simplex"), ("rlt", True, "simplex"),
                          ("rlt", False, "ipm")])
@pytest.mark.parametrize(("eta", "mu"), [(1, 0.3), (3, 0.65), (5, 1.5)])
def test_liftings_and_lam_branching_certify_the_closed_form(lifting, lam_branching, root_lp, eta, mu):
    expected = bm.cases.closed_form("two-blocks", "non-associative", eta=eta, mu=mu)
    res = solve_milp(bm.cases.two_blocks(eta=eta, mu=mu), engine="bnb", lifting=lifting,
                   lam_branching=lam_branching, heuristic="", root_lp=root_lp)
    assert_certified(res)
    assert abs(res.multiplier - expected) <= 1e-7


@pytest.mark.parametrize(("lifting", "lam_branching", "root_lp"),
                         [("rlt", False, "simplex"), ("friction", True, "simplex"), ("rlt", False, "ipm"),
                          ("friction", False, "ipm"), ("rlt-full", False, "ipm")])
@pytest.mark.parametrize("case_id", ["wall-2x2", "wall-3x2-opening", "arch-6"])
def test_liftings_certify_the_big_m_minimum(lifting, lam_branching, root_lp, case_id):
    ref = certified_minimum(case_id)
    res = solve_milp(LIFTING_CASES[case_id](), engine="bnb", lifting=lifting, lam_branching=lam_branching,
                   root_lp=root_lp)
    assert_certified(res)
    assert abs(res.multiplier - ref.multiplier) <= 1e-7


def test_dual_bound_is_weak_duality():
    """min w0 + w1 s.t. w0 + w1 >= 1, w0 - w1 = 0, w0 free, w1 in [0, 3]: optimum 1 at y = (1, 0); any y gives a
    bound <= 1; a y leaving a reduced cost on the free column gives -inf (after its correction fails), a wrong-signed
    dual of the one-sided row is dropped."""
    import scipy.sparse as sp

    from blockmpec.solvers.engines.complementarity_bnb import dual_bound

    A = sp.csc_array(np.array([[1.0, 1.0], [1.0, -1.0]]))
    c, rl, ru = np.array([1.0, 1.0]), np.array([1.0, 0.0]), np.array([np.inf, 0.0])
    cl, cu = np.array([-np.inf, 0.0]), np.array([np.inf, 3.0])
    assert dual_bound(A, c, rl, ru, cl, cu, np.array([1.0, 0.0])) == pytest.approx(1.0, abs=1e-15)
    # y = (0.5, 0.5): d = (0, 1), w1 >= 0 -> bound 0.5
    assert dual_bound(A, c, rl, ru, cl, cu, np.array([0.5, 0.5])) == pytest.approx(0.5, abs=1e-15)
    # y = (2, 0): d = (-1, -1) on the free w0, no correction -> -inf; corrected on the rows -> a valid bound <= 1
    assert dual_bound(A, c, rl, ru, cl, cu, np.array([2.0, 0.0]), correct=False) == -np.inf
    assert dual_bound(A, c, rl, ru, cl, cu, np.array([2.0, 0.0])) <= 1.0 + 1e-12
    # a wrong sign on the >= row is dropped: y = (-1, 1) -> (0, 1): d = (0, 2), bound 0
    assert dual_bound(A, c, rl, ru, cl, cu, np.array([-1.0, 1.0]), correct=False) == pytest.approx(0.0, abs=1e-15)


def test_open_reduced_cost_is_what_makes_the_bound_infinite():
    """The LP of the test above: y = (2, 0) leaves d = (-1, -1), towards w0's open upper bound (1) and w1's finite
    one; y = (1, 0) leaves none; a wrong-signed dual is cleaned first, as the bound does: y = (-1, 0) -> (0, 0), d = c."""
    import scipy.sparse as sp

    from blockmpec.solvers.engines.complementarity_bnb import open_reduced_cost

    A = sp.csc_array(np.array([[1.0, 1.0], [1.0, -1.0]]))
    c, rl, ru = np.array([1.0, 1.0]), np.array([1.0, 0.0]), np.array([np.inf, 0.0])
    cl, cu = np.array([-np.inf, 0.0]), np.array([np.inf, 3.0])
    assert open_reduced_cost(A, c, rl, ru, cl, cu, np.array([2.0, 0.0])) == pytest.approx(1.0, abs=1e-15)
    assert open_reduced_cost(A, c, rl, ru, cl, cu, np.array([1.0, 0.0])) == 0.0
    assert open_reduced_cost(A, c, rl, ru, cl, cu, np.array([-1.0, 0.0])) == pytest.approx(1.0, abs=1e-15)


@pytest.mark.parametrize("lifting", ["friction", "rlt"])
@pytest.mark.parametrize("case_id", ["wall-2x2", "wall-3x2-opening"])
def test_dormant_rows_give_a_relaxation(lifting, case_id):
    """root_lp="ipm" drops rows (those with zero interior-point dual), so its root bound can only be lower than
    the full LP's, and never above the certified minimum; rows were in fact dropped, and the ones woken again
    are exactly the dormant rows violated at the LP point."""
    import scipy.sparse as sp

    from blockmpec.solvers.engines import complementarity_bnb as cb

    lam = certified_minimum(case_id).multiplier
    full = _lifted(LIFTING_CASES[case_id](), lifting)[1].root_bound()
    bnb = _at_root(LIFTING_CASES[case_id](), lifting)
    interior = bnb.interior_root()
    assert bnb.dormant.any()
    # the interior point's dual bound is a lower bound too (weak duality); on the 2x2 wall (an interior point that
    # converges) it meets the LP's optimum; with the opening IPX stops short ("unknown"; with rlt no bound until its
    # crossover re-run), so only the inequality is asserted there
    assert interior <= full + 1e-7 * max(1.0, abs(full))
    if case_id == "wall-2x2":
        assert interior >= full - 1e-7
    st, bound, v = bnb.solve_node(bnb.root, bnb.lam_lower, bnb.lam_cap)
    assert st is Status.OPTIMAL
    assert bound <= full + 1e-7 * max(1.0, abs(full))
    assert bound <= lam + 1e-7 * max(1.0, abs(lam))
    # the last LP point violates no row it carries: every violated dormant row was woken, unless the rounds ran out
    rows = bnb.dormant_candidates
    sleeping = bnb.dormant[rows]
    violated = sleeping & (sp.csr_array(bnb.lifted_matrix)[rows] @ v > cb.SEPARATION_TOL)
    assert not violated.any() or bnb.woken > 0


def test_milp_and_its_engine_accept_the_same_root_lps():
    """milp keeps its own ROOT_LPS (importing the engine at start-up would pull in Pyomo); the two must agree."""
    from blockmpec.solvers import milp
    from blockmpec.solvers.engines import complementarity_bnb

    assert milp.ROOT_LPS == complementarity_bnb.ROOT_LPS


def test_lifting_options_need_bnb():
    with pytest.raises(bm.errors.OptionError, match="lifting"):
        solve_milp(bm.cases.two_blocks(), engine="highs", lifting="rlt")
    with pytest.raises(ValueError, match="lifting"):
        solve_milp(bm.cases.two_blocks(), engine="bnb", lifting="square")
    with pytest.raises(bm.errors.OptionError, match="root_lp"):
        solve_milp(bm.cases.two_blocks(), engine="highs", root_lp="ipm")
    with pytest.raises(ValueError, match="root_lp"):
        solve_milp(bm.cases.two_blocks(), engine="bnb", root_lp="pdlp")


def test_a_failed_interior_point_is_repaired_by_crossover(monkeypatch):
    """An interior point that gives no duals (simulated: every run without crossover returns none) is re-run once
    with crossover, whose basic duals still close the root at the certified minimum, bound below it."""
    lam = certified_minimum("wall-2x2").multiplier
    bnb = _at_root(LIFTING_CASES["wall-2x2"](), "rlt-full")
    from blockmpec.solvers.engines.node_lp import InteriorPoint

    solution = bnb.interior_solution
    monkeypatch.setattr(bnb, "interior_solution",
                        lambda *a, crossover=False, **k: solution(*a, crossover=crossover, **k) if crossover
                        else InteriorPoint(None, None))
    bound = bnb.interior_root(lam)
    assert bnb.crossover_runs >= 1
    assert bound <= lam + 1e-7 * max(1.0, abs(lam))
    assert lam - bound <= 1e-7 * max(1.0, abs(lam))


@pytest.mark.slow
def test_the_arch_on_buttresses_is_closed_by_the_root_interior_point():
    """The arch on buttresses (8 voussoirs, mu = 0.4), where IPX without crossover gives no bound on either root
    LP: the root's interior points (with the crossover repair) close it at the big-M minimum, no simplex needed."""
    structure = bm.cases.arch_on_buttresses(n_voussoirs=8, mu=0.4)
    ref = solve_milp(structure, engine="highs")
    assert_certified(ref)
    bnb = _at_root(structure, "rlt-full")
    bound = bnb.interior_root(ref.multiplier)
    assert bound <= ref.multiplier + 1e-7 * max(1.0, abs(ref.multiplier))
    assert ref.multiplier - bound <= 1e-7 * max(1.0, abs(ref.multiplier))


@pytest.mark.parametrize("lifting", ["rlt", "rlt-full"])
def test_interior_root_stops_after_one_run_when_it_closes(lifting):
    """root_lp="ipm": when the first interior point's dual bound already meets the incumbent, nothing else runs
    (with lifting="rlt-full" that first run leaves the moments' rows out); without an incumbent the whole LP and
    the LP without the dormant rows both run.  Either bound stays below the certified minimum."""
    lam = certified_minimum("wall-2x2").multiplier
    runs = {}
    for target in (lam, np.inf):
        bnb = _at_root(LIFTING_CASES["wall-2x2"](), lifting)
        before = bnb.n_lps
        recorded = []
        bound = bnb.interior_root(target, recorded.append)
        runs[target] = bnb.n_lps - before
        assert bound <= lam + 1e-7 * max(1.0, abs(lam))
        assert lam - bound <= 1e-7 * max(1.0, abs(lam))
        assert ("ipm0" in bnb.root_timing) == (lifting == "rlt-full" and np.isfinite(target))
        # the trace hears of every run's bound as it arrives: one per run, never falling, the last the result
        assert len(recorded) == runs[target] and recorded == sorted(recorded) and recorded[-1] == bound
    assert runs == {lam: 1, np.inf: 2}


# ----------------------------------------------------------------------------- issue 41: node LPs, fixings, door wall


def _null_space_nodes(structure, node_lp="interior"):
    """(solver, ComplementarityBnB) after the root's interior point, its node LPs in null-space coordinates."""
    solver = milp_solver(engine="bnb")
    solver.setup(bm.operators.assemble(structure))
    bnb = solver.branch_and_bound(solver.lp_bounds(Deadline(60)), node_lp=node_lp)
    bnb.deadline = Deadline(60)
    bnb.apply_node(bnb.root, bnb.lam_lower, bnb.lam_cap)
    bnb.interior_root()
    assert bnb.nodes_in_null_space
    return solver, bnb


@pytest.mark.parametrize("case_id", ["wall-2x2", "wall-3x2-opening"])
def test_null_space_node_lps_are_the_lifted_node_lps(case_id):
    """At the root and at nodes with pairs fixed either way, the node LP in null-space coordinates (interior point,
    every row) and the same node LP on the lifted LP (dual simplex, every row) have the same minimum, and the
    null-space LP's point, lifted, satisfies the lifted LP's rows (but the rows (X) of ``W = x u^T``, which the lifted
    point leaves at zero).  Either can be infeasible only together."""
    import scipy.sparse as sp

    from blockmpec.solvers.engines.complementarity_bnb import ComplementarityBnB

    structure = LIFTING_CASES[case_id]()
    solver, bnb = _null_space_nodes(structure)
    lifted = solver.branch_and_bound(solver.lp_bounds(Deadline(60)), root_lp="simplex")
    lifted.deadline = Deadline(60)
    assert isinstance(lifted, ComplementarityBnB) and not lifted.nodes_in_null_space
    rng = np.random.default_rng(7)
    states = [bnb.root.copy()]
    for _ in range(6):
        state = bnb.root.copy()
        free = np.flatnonzero(state == 0)
        pick = rng.choice(free, size=min(3, free.size), replace=False)
        state[pick] = rng.choice([-1, 1], size=pick.size)
        states.append(state)
    A = sp.csr_array(lifted.lifted_matrix)
    for state in states:
        st_null, bound_null, v_null = bnb.solve_node(state, bnb.lam_lower, np.inf)
        st_lift, bound_lift, _ = lifted.solve_node(state, lifted.lam_lower, np.inf)
        assert (st_null is Status.INFEASIBLE) == (st_lift is Status.INFEASIBLE), (state, st_null, st_lift)
        if st_lift is Status.OPTIMAL and st_null is Status.OPTIMAL:
            assert bound_null == pytest.approx(bound_lift, abs=1e-7)
            _, row_lower, row_upper, _, _ = lifted.lp_arrays()
            keep = np.ones(A.shape[0], dtype=bool)
            keep[lifted.layout.tied_rows.ravel()] = False  # rows (X) of W = x u^T, which the lifted point leaves at 0
            r = (A @ v_null)[keep]
            tol = 1e-6 * max(1.0, float(np.abs(v_null).max()))
            assert np.all(r >= row_lower[keep] - tol)
            assert np.all(r <= row_upper[keep] + tol)


def test_an_unchecked_infeasible_node_is_not_pruned(monkeypatch):
    """A node LP that HiGHS calls infeasible is pruned only when its dual ray checks as a Farkas certificate: with
    every check failing (simulated), no node is pruned as infeasible, and the run does not certify on them."""
    from blockmpec.solvers.engines import complementarity_bnb as cb

    monkeypatch.setattr(cb, "proves_infeasible", lambda *args, **kwargs: False)
    res = solve_milp(bm.cases.wall(3, 3, bond="stack", openings=[(1.0, 0.0, 2.0, 0.5)]), heuristic="", time_limit=30)
    assert res.status is not Status.INFEASIBLE and res.status is not Status.OPTIMAL, res.message


@pytest.mark.slow
def test_door_wall_is_certified_with_node_lps_in_null_space():
    """Issue 41's door wall (3 courses of 1 x 0.5 blocks, 3 per course, the bottom middle block left out) at mu 0.65:
    certified (6 s at load 3; 300 s before, bound 0.566), at nlp's point, and the bound lies below every verified
    heuristic point."""
    from helpers import HEURISTIC_TOL, HEURISTICS, margin

    wall = bm.cases.wall(courses=3, blocks_per_course=3, block_length=1, block_height=0.5,
                         openings=[(1.0, 0.0, 2.0, 0.5)], mu=0.65)
    assert wall.n_free == 9
    res = bm.solve(wall, "milp", time_limit=300)
    assert_certified(res)
    assert res.extra["engine"] == "bnb"
    assert res.multiplier == pytest.approx(0.5852298662, abs=1e-9)
    for method in ("fixed-point", "nlp"):
        if method in HEURISTICS:
            h = bm.solve(wall, method)
            if h.verified and h.status.is_success:
                assert h.multiplier + margin(HEURISTIC_TOL, h.multiplier) >= res.extra["bound"] - 1e-9, method

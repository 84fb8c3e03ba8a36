"""The interior-point fixed point (``fixed-point`` with ``engine="interior"``).

One interior-point run of Newton's method on (3), written as the step LP (5) with
``n* = n`` (:mod:`blockmpec.solvers.engines.interior_fixed_point`).  Checked here: its
answers are solutions of (3) by the shared verifier at 1e-8; they never exceed the
associative multiplier nor fall below a closed-form minimum; the aim term brings them
near the minimum on two blocks (within 1e-3, not onto it); where (3) has one multiplier they match the simplex
fixed point; the trace is the StoppingCriterion's; the ``auto`` rule and bad options.
"""

from __future__ import annotations

import numpy as np
import pytest

import blockmpec as bm
from blockmpec.cases import closed_form
from blockmpec.deadline import Deadline
from blockmpec.formulations import step_lps
from blockmpec.solvers import plan
from blockmpec.solvers.engines.interior_fixed_point import InteriorFixedPoint, run_interior
from blockmpec.solvers.engines.scaling import LoadUnits
from helpers import solve_with

VERIFY_TOL = 1e-8
TWO_BLOCK_GRID = [(3.0, 0.65), (5.0, 1.2), (2.0, 0.3), (4.0, 0.5), (1.5, 0.9)]


@pytest.mark.parametrize(("eta", "mu"), TWO_BLOCK_GRID)
def test_two_blocks_verified_between_minimum_and_associative(eta, mu):
    ops = bm.assemble(bm.cases.two_blocks(eta=eta, mu=mu))
    res = bm.solve(ops, "fixed-point", engine="interior", verify_tol=VERIFY_TOL)
    assert res.success, res.message
    assert res.status is bm.Status.CONVERGED
    assoc = bm.solve(ops, "static-lp").multiplier
    minimum = closed_form("two-blocks", "non-associative", eta=eta, mu=mu)
    assert res.multiplier <= assoc + 1e-9 * max(1.0, assoc)
    assert res.multiplier >= minimum - 1e-9


@pytest.mark.parametrize(("eta", "mu"), [(3.0, 0.65), (5.0, 1.2)])
def test_aim_term_brings_the_two_block_multiplier_near_the_minimum(eta, mu):
    """Issue 13's cases: the associative 0.41973 / 0.353, the minimum 1/3 / 0.2 (closed forms, paper Sect. 3).

    The aim term brings the run near the minimum, not onto it: 7.7e-5 and 4.3e-4 above it (relative, measured), a
    solution of (3) inside the continuum of solutions; without the aim term the run stops higher (0.396 / 0.330)."""
    ops = bm.assemble(bm.cases.two_blocks(eta=eta, mu=mu))
    minimum = closed_form("two-blocks", "non-associative", eta=eta, mu=mu)
    aimed = bm.solve(ops, "fixed-point", engine="interior", verify_tol=VERIFY_TOL)
    plain = solve_with(ops, "fixed-point", settings=dict(interior_weight=0.0), engine="interior",
                       verify_tol=VERIFY_TOL)
    assert aimed.success and plain.success
    assert minimum - 1e-9 <= aimed.multiplier <= (1 + 1e-3) * minimum  # 4.3e-4 above at most, measured
    assert plain.multiplier > aimed.multiplier + 1e-2


@pytest.mark.parametrize("structure", [
    bm.cases.single_block(),
    bm.cases.two_blocks(eta=1.0, mu=0.65, dilatancy=0.65),  # associative flow: (3) is the LP's KKT system
    bm.cases.wall(courses=3, blocks_per_course=2, mu=0.8, dilatancy=0.8),
])
def test_matches_simplex_fixed_point_where_the_multiplier_is_unique(structure):
    ops = bm.assemble(structure)
    interior = bm.solve(ops, "fixed-point", engine="interior", verify_tol=VERIFY_TOL)
    simplex = bm.solve(ops, "fixed-point", engine="simplex", verify_tol=VERIFY_TOL)
    assert interior.success and simplex.success
    assert interior.multiplier == pytest.approx(simplex.multiplier, rel=1e-7, abs=1e-9)


def test_wall_verified_and_not_above_associative():
    ops = bm.assemble(bm.cases.wall(courses=6, blocks_per_course=3))
    res = bm.solve(ops, "fixed-point", engine="interior", verify_tol=VERIFY_TOL)
    assert res.success, res.message
    assert res.multiplier <= bm.solve(ops, "static-lp").multiplier + 1e-9


def test_trace_is_the_stopping_criterion_s_and_facts_are_named():
    ops = bm.assemble(bm.cases.two_blocks(eta=3.0, mu=0.65))
    res = bm.solve(ops, "fixed-point", engine="interior")
    assert res.trace and all("kkt_residual" in rec and "time_s" in rec for rec in res.trace)
    assert [rec["iteration"] for rec in res.trace] == list(range(1, len(res.trace) + 1))
    assert res.trace[-1]["kkt_residual"] <= 1e-9
    # the aim term is on at the start and exactly off at the end
    assert res.trace[0]["fold_weight"] > 0 and res.trace[-2]["fold_weight"] == 0.0
    assert res.extra["lp_solves"] == 1 and res.extra["lp_time_s"]["interior"] > 0
    assert res.extra["engine"] == "interior"


def test_exact_coupling_reads_coulomb_rows_and_dilatant_flow():
    """G (primal rows) carries tan(phi), G_dual tan(psi): they differ only in the friction rows' n entries."""
    ops = bm.assemble(bm.cases.two_blocks(eta=3.0, mu=0.65, dilatancy=0.2))
    eng = _engine(ops)
    diff = (eng.G - eng.G_dual).tocoo()
    diff.eliminate_zeros()
    assert set(diff.row.tolist()) == set(eng.friction_position.tolist())
    assert set(diff.col.tolist()) == set(eng.normal_columns.tolist())
    # in the LP's own units the added entry is tan(phi) - tan(psi)
    rows, cols = diff.row, diff.col
    unscaled = diff.data / (eng.in_scale[rows] * eng.column_scale[cols])
    assert np.allclose(unscaled, 0.65 - 0.2)


def test_lagged_coupling_is_kept_for_the_measurement_and_does_not_converge_here():
    """The lead's first proposal (n* := n before each LP iteration) stalls on two blocks (docstring)."""
    ops = bm.assemble(bm.cases.two_blocks(eta=3.0, mu=0.65))
    lagged = _engine(ops, coupling="lagged").solve()
    exact = _engine(ops).solve()
    assert exact.status is bm.Status.OPTIMAL
    assert lagged.status is not bm.Status.OPTIMAL


def test_auto_engine_rule():
    assert plan.fixed_point_engine("auto", plan.FIXED_POINT_INTERIOR_BLOCKS - 1) == "simplex"
    assert plan.fixed_point_engine("auto", plan.FIXED_POINT_INTERIOR_BLOCKS) == "interior"
    assert plan.fixed_point_engine("simplex", 10 ** 6) == "simplex"
    ops = bm.assemble(bm.cases.two_blocks())
    res = bm.solve(ops, "fixed-point")
    assert res.extra.get("engine") == "simplex"
    assert len(res.extra["plan"]) == 1 and res.extra["plan"][0].startswith("fixed point: ")


def test_time_limit_before_the_run_says_so():
    ops = bm.assemble(bm.cases.two_blocks())
    lps = _lps(ops)
    out, facts = run_interior(lps.step, lps.associative, LoadUnits.of(ops), tol=1e-9, max_iterations=50,
                              deadline=Deadline(0.0), fold_weight=0.1)
    assert out.status is bm.Status.TIME_LIMIT and facts["lp_solves"] == 0


def test_bad_engine_option_is_one_line():
    ops = bm.assemble(bm.cases.two_blocks())
    with pytest.raises(bm.OptionError) as err:
        bm.solve(ops, "fixed-point", engine="barrier")
    assert "engine" in str(err.value) and "\n" not in str(err.value)


def test_bad_engine_setting_is_one_line():
    from blockmpec.solvers.fixed_point import FixedPointSettings

    with pytest.raises(ValueError) as err:
        FixedPointSettings(interior_weight=-1.0)
    assert "interior_weight" in str(err.value) and "\n" not in str(err.value)


def test_auto_falls_back_to_the_simplex_engine_when_the_interior_run_fails(monkeypatch):
    """Under ``engine="auto"`` an interior run that ends without a solution of (3) hands over to the simplex
    engine: here the interior run gets 3 iterations (it needs about 8), the simplex engine 2 steps suffice."""
    monkeypatch.setattr(plan, "FIXED_POINT_INTERIOR_BLOCKS", 1)
    ops = bm.assemble(bm.cases.two_blocks(eta=3.0, mu=0.65))
    res = bm.solve(ops, "fixed-point", max_iterations=3, verify_tol=VERIFY_TOL)
    assert res.extra["engine"] == "interior, then simplex"
    assert len(res.extra["plan"]) == 2 and res.extra["plan"][0].startswith("interior fixed point")
    assert res.extra["interior_status"] != "converged"
    assert res.success and res.multiplier == pytest.approx(1.0 / 3.0, rel=1e-9)
    assert set(res.extra["lp_time_s"]) >= {"interior", "step"}
    explicit = bm.solve(ops, "fixed-point", engine="interior", max_iterations=3)
    assert not explicit.success and explicit.extra["engine"] == "interior"


def test_auto_skips_the_simplex_fallback_on_large_structures(monkeypatch):
    """From ``FIXED_POINT_SIMPLEX_FALLBACK_BLOCKS`` free blocks up a failed interior run is returned as it is (the simplex
    engine could not finish there): the same failing run as above, with the cap lowered to the structure's size."""
    monkeypatch.setattr(plan, "FIXED_POINT_INTERIOR_BLOCKS", 1)
    ops = bm.assemble(bm.cases.two_blocks(eta=3.0, mu=0.65))
    monkeypatch.setattr(plan, "FIXED_POINT_SIMPLEX_FALLBACK_BLOCKS", ops.n_free_blocks)
    res = bm.solve(ops, "fixed-point", max_iterations=3, verify_tol=VERIFY_TOL)
    assert res.extra["engine"] == "interior"
    assert not res.success and res.status is not bm.Status.CONVERGED
    assert "no simplex fallback" in res.message
    monkeypatch.setattr(plan, "FIXED_POINT_SIMPLEX_FALLBACK_BLOCKS", ops.n_free_blocks + 1)
    assert bm.solve(ops, "fixed-point", max_iterations=3).extra["engine"] == "interior, then simplex"


def test_the_lp_steps_leave_the_interior_engine_its_share_of_the_time(monkeypatch):
    """Below ``FIXED_POINT_INTERIOR_BLOCKS`` (``engine="auto"``) the LP steps run under a deadline of at most
    ``FIXED_POINT_STEPS_SHARE`` of the time left, so that the interior engine planned after them gets the rest; with
    ``engine="simplex"`` (nothing planned after them) they get the whole run's."""
    from blockmpec.solvers.engines import lp_sequence

    ops = bm.assemble(bm.cases.two_blocks(eta=3.0, mu=0.65))
    run_sequence = lp_sequence.run_sequence
    for engine, share in (("auto", plan.FIXED_POINT_STEPS_SHARE), ("simplex", 1.0)):
        given = []

        def recording(*args, given=given, **kwargs):
            given.append(kwargs["deadline"].remaining())
            return run_sequence(*args, **kwargs)

        monkeypatch.setattr(lp_sequence, "run_sequence", recording)
        assert bm.solve(ops, "fixed-point", engine=engine, time_limit=100.0).success
        assert given and share * 100.0 - 5.0 <= given[0] <= share * 100.0 + 1e-9, (engine, given)


def _lps(ops):
    """The compiled step LP (5) (``tan(psi)`` rows) and static LP (1) of ``ops`` (:func:`step_lps`)."""
    return step_lps(ops, tie_break=False)


def _step_lp(ops):
    return _lps(ops).step


def _engine(ops, **options) -> InteriorFixedPoint:
    """The interior fixed point on ``ops``'s step LP (5), in its load units."""
    lps = _lps(ops)
    return InteriorFixedPoint(lps.step, lps.associative, LoadUnits.of(ops), **options)


def test_fixed_coupling_is_the_step_lp_at_the_given_normal_forces():
    """``coupling="fixed"`` with ``n*`` set solves the LP (5) at ``n*``: the same lam as HiGHS on that LP."""
    from blockmpec.formulations import compile_linear, modified_lp
    from blockmpec.solvers.engines.highs import HighsLP

    ops = bm.assemble(bm.cases.wall(courses=3, blocks_per_course=2))
    n_star = np.minimum(bm.solve(ops, "static-lp").solution.x[1::3], 0.0)
    eng = _engine(ops, coupling="fixed")
    eng.set_n_star(n_star)
    out = eng.solve()
    reference = HighsLP(compile_linear(modified_lp(ops, n_star, slope=ops.dilatancy))).solve()
    assert out.status is bm.Status.OPTIMAL and reference.status is bm.Status.OPTIMAL
    assert out.objective == pytest.approx(reference.objective, rel=1e-8)


def test_warm_start_from_a_solution_of_3_is_a_fixed_point_of_the_step_lp():
    """A solution of (3) solves the LP (5) at its own normal forces: started there, the fixed-coupling
    run stops before its first step with the same multiplier (the best iterate and the warm start hooks)."""
    ops = bm.assemble(bm.cases.wall(courses=4, blocks_per_course=3))
    exact = _engine(ops)
    assert exact.solve().status is bm.Status.OPTIMAL
    best = exact.best_iterate
    assert exact.best_error <= 1e-9
    fixed = _engine(ops, coupling="fixed")
    fixed.set_n_star(exact.normal_forces(best))
    fixed.start_iterate = best
    out = fixed.solve()
    assert out.status is bm.Status.OPTIMAL and out.iterations == 0
    lam = exact.column_scale[exact.lam_column] * best.v[exact.lam_column]
    assert -out.objective == pytest.approx(lam, rel=1e-12)


def test_kept_aim_forces_paired_with_their_step_lp_duals_solve_3():
    """``keep_aim``: the run solves the aimed problem, whose duals are no mechanism of (3); where the aimed
    forces are optimal for their own LP (5), that LP's duals complete them to a solution of (3)
    (any optimal primal and dual of one LP are complementary; the changelog, 2026-11-28)."""
    from blockmpec.result import Solution
    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.verify import residuals

    ops = bm.assemble(bm.cases.wall(courses=8, blocks_per_course=10))
    lp = _step_lp(ops)
    aimed = _engine(ops, fold_weight=0.1, fold_off=0.0, fold_knee=1e-300)
    aimed.keep_aim = True
    out = aimed.solve()
    assert out.status is bm.Status.OPTIMAL and aimed.current_fold == 0.1
    forces = static_lp_solution(lp, out)
    assert max(residuals(ops, forces, associative=False).values()) > 1e-3
    step = _engine(ops, coupling="fixed")
    step.set_n_star(np.minimum(forces.x[1::3], 0.0))
    duals = static_lp_solution(lp, step.solve())
    assert duals.multiplier == pytest.approx(forces.multiplier, rel=1e-8)
    paired = Solution(multiplier=forces.multiplier, x=forces.x, u=duals.u, z_u=duals.z_u, z_f=duals.z_f)
    assert max(residuals(ops, paired, associative=False).values()) <= VERIFY_TOL
    assert paired.multiplier <= bm.solve(ops, "static-lp").multiplier + 1e-9


def test_central_path_continuation_from_an_early_iterate_reaches_a_solution_of_3():
    """:func:`continue_central_path` from the 3rd iterate of the plain run on a 10x10 wall (105 blocks): the
    weighted path through that point ends at a verified solution of (3), below the associative multiplier."""
    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.solvers.engines.interior_fixed_point import continue_central_path
    from blockmpec.verify import residuals

    ops = bm.assemble(bm.cases.wall(courses=10, blocks_per_course=10))
    early = _engine(ops, max_iterations=3)
    early.solve()
    steps = []
    end, facts = continue_central_path(early, early.best_iterate, tol=1e-9, deadline=Deadline(60.0),
                                       record=lambda **values: steps.append(values))
    assert 0 < facts["steps"] == len(steps) and facts["factorisations"] >= facts["steps"]
    assert max(early.measures(end)) <= 1e-9
    assert steps[-1]["mu"] < 1e-3 * steps[0]["mu"]
    out = early.outcome_at(end)
    assert out.status is bm.Status.OPTIMAL and out.iterations == 0
    sol = static_lp_solution(early.lp, out)
    assert max(residuals(ops, sol, associative=False).values()) <= VERIFY_TOL
    assert sol.multiplier <= bm.solve(ops, "static-lp").multiplier + 1e-9


def test_continuation_ends_at_its_last_point_when_k_is_singular(monkeypatch):
    """A singular ``K`` during the continuation (SuperLU's zero pivot) ends it at its last accepted point, with
    the steps made so far, instead of an exception."""
    from blockmpec.solvers.engines.interior_fixed_point import continue_central_path
    from blockmpec.solvers.linalg.cholesky import SingularMatrixError

    ops = bm.assemble(bm.cases.wall(courses=10, blocks_per_course=10))
    early = _engine(ops, max_iterations=3)
    early.solve()
    factorise, calls = early.factorise, [0]

    def failing(z):
        calls[0] += 1
        if calls[0] > 4:
            raise SingularMatrixError("SuperLU: Factor is exactly singular")
        return factorise(z)

    monkeypatch.setattr(early, "factorise", failing)
    steps = []
    end, facts = continue_central_path(early, early.best_iterate, tol=1e-9, deadline=Deadline(60.0),
                                       record=lambda **values: steps.append(values))
    assert calls[0] == 5 and facts["steps"] == len(steps) and facts["factorisations"] <= 4
    assert np.all(np.isfinite(end.v)) and np.all(end.s > 0) and np.all(end.y > 0)


def test_continuation_stops_when_mu_crawls(monkeypatch):
    """The continuation stops once ``mu`` has not fallen tenfold in ``CONTINUATION_DECADE_STEPS`` steps (with the
    limit at 3 on the 10x10 wall, where it converges at its own pace otherwise), unconverged, with ``mu`` above a tenth
    of the last decade's."""
    import blockmpec.solvers.engines.interior_fixed_point as ifp

    ops = bm.assemble(bm.cases.wall(courses=10, blocks_per_course=10))
    early = _engine(ops, max_iterations=3)
    early.solve()
    full_steps = []
    ifp.continue_central_path(early, early.best_iterate, tol=1e-9, deadline=Deadline(60.0),
                              record=lambda **values: full_steps.append(values["mu"]))
    monkeypatch.setattr(ifp, "CONTINUATION_DECADE_STEPS", 3)
    steps = []
    end, facts = ifp.continue_central_path(early, early.best_iterate, tol=1e-9, deadline=Deadline(60.0),
                                           record=lambda **values: steps.append(values["mu"]))
    assert max(early.measures(end)) > 1e-9 and facts["steps"] < len(full_steps)
    # it stopped exactly when three steps in a row had not brought mu down tenfold since the last decade
    mu0 = float(early.best_iterate.s @ early.best_iterate.y) / early.best_iterate.s.size
    decade, since = mu0, 0
    for mu in steps:
        since += 1
        if mu <= 0.1 * decade:
            decade, since = mu, 0
    assert since == 3


@pytest.mark.slow
def test_a_stalled_interior_run_is_continued_and_the_steps_are_traced():
    """``run_interior`` continues a run that stalls (here: a tolerance of 1e-17, below round-off) along its
    central path; the steps count as iterations and are traced; unconverged, the status says so."""
    ops = bm.assemble(bm.cases.wall(courses=4, blocks_per_course=3))
    lps = _lps(ops)
    units = LoadUnits.of(ops)
    out, facts = run_interior(lps.step, lps.associative, units, tol=1e-17, max_iterations=60, deadline=Deadline(30.0),
                              fold_weight=0.0, sequence=False)
    assert out.status is not bm.Status.CONVERGED
    assert facts["continuation_steps"] > 0
    traced = [rec for rec in out.trace if rec.get("stage") == "continuation"]
    assert len(traced) == facts["continuation_steps"]
    assert [rec["iteration"] for rec in out.trace] == list(range(1, len(out.trace) + 1))
    assert "continuation" in out.message
    plain, plain_facts = run_interior(lps.step, lps.associative, units, tol=1e-17, max_iterations=60,
                                      deadline=Deadline(30.0), fold_weight=0.0, continuation=False, sequence=False)
    assert plain_facts["continuation_steps"] == 0 and len(plain.trace) < len(out.trace)


def _stone_wall(stones, irregularity, seed=0):
    height = 0.3 * np.sqrt(stones / 2.0)
    return bm.cases.stone_wall(width=2 * height, height=height, stone_size=0.3, irregularity=irregularity, seed=seed)


def test_damped_interior_lp_steps_then_newton_reach_a_solution_of_3():
    """The interior engine's last stage (:func:`sequence_then_newton`) on a 62-stone wall: damped interior-point
    step LPs until ``||n - n*|| / ||n||`` reaches a checkpoint, then Newton on (3) from there; its point is a
    solution of (3) by the shared verifier, not above the associative multiplier."""
    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.solvers.engines.interior_fixed_point import sequence_then_newton
    from blockmpec.verify import residuals

    ops = bm.assemble(_stone_wall(60, 0.5))
    lps = step_lps(ops, tie_break=False, associative=True)
    traced = []
    newton, out, facts = sequence_then_newton(lps.step, lps.associative, LoadUnits.of(ops), tol=1e-9, max_steps=200,
                                              deadline=Deadline(120.0), record=lambda **v: traced.append(v))
    assert out is not None and out.status is bm.Status.OPTIMAL
    assert facts["sequence_lps"] > 1 and facts["sequence_newton_runs"] >= 1
    assert facts["sequence_n_change"] <= 1e-2  # Newton started at a checkpoint
    assert [v["stage"] for v in traced].count("sequence") == facts["sequence_lps"]
    solution = static_lp_solution(lps.step, out)
    assert max(residuals(ops, solution, associative=False).values()) <= VERIFY_TOL
    assoc = bm.solve(ops, "static-lp").multiplier
    assert solution.multiplier <= assoc * (1 + 1e-9)


@pytest.mark.slow
def test_irregular_wall_where_the_interior_run_stalls_is_solved_by_the_lp_steps_and_newton():
    """517 stones (irregularity 0.7): Newton on (3) from Mehrotra's start stalls and its continuation does not
    converge; the damped LP steps and Newton then give a verified solution of (3) below the associative
    multiplier.  Without that stage (setting ``interior_sequence=False``) the run ends without one."""
    wall = _stone_wall(500, 0.7)
    res = bm.solve(wall, "fixed-point", verify_tol=VERIFY_TOL)
    assert res.success and res.status is bm.Status.CONVERGED, res.message
    assert res.extra["engine"] == "interior" and res.extra["sequence_lps"] > 0
    assert "damped interior-point LP steps" in res.message
    assert res.multiplier <= bm.solve(wall, "static-lp").multiplier * (1 + 1e-9)
    without = solve_with(wall, "fixed-point", {"interior_sequence": False}, engine="interior")
    assert not without.success and without.extra["sequence_lps"] == 0


@pytest.mark.slow
def test_crawling_continuation_leaves_the_lp_steps_their_iterations():
    """A 516-stone wall (irregularity 0.7, seed 1) where the continuation crawls (``mu`` 1.6e-6 to 1.1e-6 in 2,500
    steps): it stops after ``CONTINUATION_DECADE_STEPS``, and the damped LP steps and Newton give a verified
    solution of (3) below the associative multiplier within the default 500 iterations (before: ``numerical``,
    the continuation had used them all)."""
    from blockmpec.solvers.engines.interior_fixed_point import CONTINUATION_DECADE_STEPS

    wall = _stone_wall(500, 0.7, seed=1)
    res = bm.solve(wall, "fixed-point", engine="interior", verify_tol=VERIFY_TOL)
    assert res.success and res.status is bm.Status.CONVERGED, res.message
    assert 0 < res.extra["continuation_steps"] <= CONTINUATION_DECADE_STEPS < 2500
    assert res.extra["sequence_lps"] > 0
    assert res.multiplier <= bm.solve(wall, "static-lp").multiplier * (1 + 1e-9)

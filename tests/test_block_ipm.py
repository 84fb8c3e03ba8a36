"""The block interior-point method's linear algebra: Newton directions and their solves with ``K``.

The reduced solve (``K dw = ...``, then exact per-block solves) is refined iteratively; a
direction it returns must satisfy every block equation of the Newton system exactly (to
round-off), so that only the equality rows ``A dv = -r_b`` carry the remaining error of the
reduced solve, and it must not spend a solve with ``K`` whose result it does not use.
"""

import numpy as np
import pytest
import scipy.sparse as sp

import blockmpec as bm
from blockmpec.formulations import compile_linear, static_lp
from blockmpec.solvers.engines.block_lp import BlockLP, interface_blocks
from blockmpec.solvers.engines.lp_engine import cold_lp_engine
from blockmpec.solvers.engines.scaling import LoadUnits
from blockmpec.solvers.linalg.block_ipm import DEFAULT_SETTINGS, EXACT_INNER_SETTINGS
from helpers import wall_block_ipm_off_path


@pytest.fixture(scope="module")
def wall_ipm():
    """The block IPM on the static LP of a 10x20 wall in load units, with an iterate off the central path
    (products s y spread over ~8 decades, as near the optimum)."""
    return wall_block_ipm_off_path(spread=3.0, seed=7)


def _newton_residuals(ipm, it, direction, r_b, r_h, r_c, r_mu):
    """Residuals of the four Newton equations (module docstring of block_ipm) at ``direction``."""
    dv, ds, dw, dy = direction
    return {"equality": -r_b - ipm.A @ dv,
            "inequality": -r_h - ipm.G @ dv - ds,
            "dual": -r_c + ipm.A.T @ dw - ipm.G.T @ dy,
            "complementarity": r_mu - (it.y * ds + it.s * dy)}


@pytest.mark.parametrize("refinements", [0, 1, 3])
def test_direction_satisfies_every_block_equation_and_wastes_no_solve(wall_ipm, refinements):
    ipm, it = wall_ipm
    factors = ipm.factorise(it)
    r_b, r_h, r_c = ipm.residuals(it)
    r_mu = 0.1 * float(it.s @ it.y) / it.s.size - it.s * it.y
    solves = ipm.factoriser.solves
    direction = ipm.direction(it, factors, r_b, r_h, r_c, r_mu, refinements)
    used = ipm.factoriser.solves - solves
    # one reduced solve, then at most `refinements` corrections, each of them used
    assert 1 <= used <= 1 + refinements
    res = _newton_residuals(ipm, it, direction, r_b, r_h, r_c, r_mu)
    size = max(np.max(np.abs(d)) for d in direction)
    # the block equations (dual rows, inequality rows, complementarity) hold to round-off
    assert np.max(np.abs(res["dual"])) <= 1e-10 * max(size, 1.0)
    assert np.max(np.abs(res["inequality"])) <= 1e-10 * max(size, 1.0)
    assert np.max(np.abs(res["complementarity"])) <= 1e-10 * max(np.max(np.abs(r_mu)), size)


def test_inner_tolerance_skips_corrections_of_accurate_directions(wall_ipm):
    """With a relative ``tolerance`` the reduced solve is corrected only while the equality rows'
    error exceeds it: a loose one leaves one solve, the absolute target (0) asks for a correction."""
    ipm, it = wall_ipm
    factors = ipm.factorise(it)
    r_b, r_h, r_c = ipm.residuals(it)
    r_mu = -it.s * it.y
    used = {}
    for tolerance in (0.0, 1e6):
        solves = ipm.factoriser.solves
        direction = ipm.direction(it, factors, r_b, r_h, r_c, r_mu, 1, tolerance)
        used[tolerance] = ipm.factoriser.solves - solves
        res = _newton_residuals(ipm, it, direction, r_b, r_h, r_c, r_mu)
        assert np.max(np.abs(res["dual"])) <= 1e-10 * max(max(np.max(np.abs(d)) for d in direction), 1.0)
    assert used == {0.0: 2, 1e6: 1}


def test_refined_direction_solves_the_whole_newton_system(wall_ipm):
    """Whole-system refinement of an unrefined direction brings the equality rows to round-off too."""
    ipm, it = wall_ipm
    factors = ipm.factorise(it)
    r_b, r_h, r_c = ipm.residuals(it)
    r_mu = -it.s * it.y
    rough = ipm.direction(it, factors, r_b, r_h, r_c, r_mu, 0)
    refined = ipm.refined_direction(it, factors, r_b, r_h, r_c, r_mu, rough, sweeps=ipm.final_sweeps)
    res = _newton_residuals(ipm, it, refined, r_b, r_h, r_c, r_mu)
    assert np.max(np.abs(res["equality"])) <= 1e-2 * ipm.tol * (1 + np.max(np.abs(ipm.b)))
    # refinement can only have helped: the rough direction's equality error is not smaller
    rough_res = _newton_residuals(ipm, it, rough, r_b, r_h, r_c, r_mu)
    assert np.max(np.abs(res["equality"])) <= np.max(np.abs(rough_res["equality"]))


@pytest.fixture(scope="module")
def mild_wall_ipm():
    """The 10x20 wall's IPM at an iterate whose products ``s y`` spread over ~2 decades:
    its Newton directions are attainable to ~1e-13 (the target is 1e-10)."""
    ops = bm.assemble(bm.cases.wall(10, 20))
    lp = compile_linear(static_lp(ops))
    ipm = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
    it = ipm.initial_point()
    rng = np.random.default_rng(7)
    it.s *= np.exp(rng.normal(0.0, 1.0, it.s.size))
    it.y *= np.exp(rng.normal(0.0, 1.0, it.y.size))
    return ipm, it


def _factors_with_shift(ipm, it, shift):
    """The factors of ``_factorise(it)``, but of ``K + shift diag(K)``: an inaccurate ``K``, as the
    factors of the very ill-conditioned ``K`` near the optimum of a 100,000-block wall are."""
    K, blocks = ipm.reduced_matrix(it)
    solve_K = ipm.factoriser.factorise(K + shift * sp.diags(K.diagonal(), format="csc"))
    W_F = solve_K(ipm.A_F)
    return blocks, solve_K, W_F, np.linalg.inv(ipm.A_F.T @ W_F)


def test_krylov_refinement_converges_where_the_stationary_one_does_not(mild_wall_ipm):
    """With factors of ``K + 1e-2 diag(K)`` the stationary refinement ``dw += P e`` diverges
    (``||I - T P|| > 1``); GMRES preconditioned by the same factors meets the target."""
    ipm, it = mild_wall_ipm
    factors = _factors_with_shift(ipm, it, 1e-2)
    r_b, r_h, r_c = ipm.residuals(it)
    r_mu = 0.1 * float(it.s @ it.y) / it.s.size - it.s * it.y
    target = 1e-1 * ipm.tol * (1 + np.max(np.abs(ipm.b)))
    errors = {}
    for krylov in (0, DEFAULT_SETTINGS["krylov_iterations"]):
        ipm.settings(krylov_iterations=krylov)
        direction = ipm.direction(it, factors, r_b, r_h, r_c, r_mu)
        res = _newton_residuals(ipm, it, direction, r_b, r_h, r_c, r_mu)
        errors[krylov] = np.max(np.abs(res["equality"]))
        # the block equations hold exactly either way
        assert np.max(np.abs(res["dual"])) <= 1e-10 * max(max(np.max(np.abs(d)) for d in direction), 1.0)
    ipm.settings(**DEFAULT_SETTINGS)
    assert errors[0] > 1e3 * target
    assert errors[DEFAULT_SETTINGS["krylov_iterations"]] <= target


def test_krylov_fallback_leaves_converging_directions_unchanged(mild_wall_ipm):
    """With accurate factors the stationary refinement converges: no GMRES, the same direction."""
    ipm, it = mild_wall_ipm
    factors = ipm.factorise(it)
    r_b, r_h, r_c = ipm.residuals(it)
    r_mu = -it.s * it.y
    directions, steps = {}, {}
    for krylov in (0, DEFAULT_SETTINGS["krylov_iterations"]):
        ipm.settings(krylov_iterations=krylov)
        before = ipm.krylov_steps
        directions[krylov] = ipm.direction(it, factors, r_b, r_h, r_c, r_mu)
        steps[krylov] = ipm.krylov_steps - before
    ipm.settings(**DEFAULT_SETTINGS)
    assert steps == {0: 0, DEFAULT_SETTINGS["krylov_iterations"]: 0}
    for a, b in zip(directions[0], directions[DEFAULT_SETTINGS["krylov_iterations"]], strict=True):
        np.testing.assert_array_equal(a, b)


def test_early_switch_to_gmres_saves_solves_and_meets_the_target(mild_wall_ipm):
    """With factors of ``K + 1e-3 diag(K)`` a stationary correction shrinks the error by ~0.3 only:
    GMRES taking over after the first slow correction (``krylov_switch``) meets the target with fewer
    solves than after all ``refinements`` stationary ones, and both give the same direction."""
    ipm, it = mild_wall_ipm
    factors = _factors_with_shift(ipm, it, 1e-3)
    r_b, r_h, r_c = ipm.residuals(it)
    r_mu = 0.1 * float(it.s @ it.y) / it.s.size - it.s * it.y
    target = 1e-1 * ipm.tol * (1 + np.max(np.abs(ipm.b)))
    solves, directions = {}, {}
    for switch in (DEFAULT_SETTINGS["krylov_switch"], np.inf):
        ipm.settings(krylov_switch=switch)
        before, steps = ipm.factoriser.solves, ipm.krylov_steps
        directions[switch] = ipm.direction(it, factors, r_b, r_h, r_c, r_mu)
        solves[switch] = ipm.factoriser.solves - before
        assert ipm.krylov_steps == steps + 1  # GMRES ran either way
        res = _newton_residuals(ipm, it, directions[switch], r_b, r_h, r_c, r_mu)
        assert np.max(np.abs(res["equality"])) <= target
    ipm.settings(**DEFAULT_SETTINGS)
    assert solves[DEFAULT_SETTINGS["krylov_switch"]] < solves[np.inf]
    for a, b in zip(directions[DEFAULT_SETTINGS["krylov_switch"]], directions[np.inf], strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-6 * max(np.max(np.abs(b)), 1.0))


def test_gmres_direction_equals_the_direct_one(mild_wall_ipm):
    """GMRES from the first reduced solve (no stationary correction) and the stationary refinement with
    exact factors solve the same Newton system: the same direction, to the refinement's target.  The factors
    are those of ``K + 1e-12 diag(K)`` (the former diagonal shift), whose first reduced solve misses the target,
    so that GMRES runs."""
    from blockmpec.solvers.linalg.block_ipm import WIDE_DIAGONAL_SHIFT

    ipm, it = mild_wall_ipm
    ipm.settings(diagonal_shift=WIDE_DIAGONAL_SHIFT)
    factors = ipm.factorise(it)
    r_b, r_h, r_c = ipm.residuals(it)
    r_mu = 0.1 * float(it.s @ it.y) / it.s.size - it.s * it.y
    ipm.settings(refinements=8, krylov_iterations=0)
    direct = ipm.direction(it, factors, r_b, r_h, r_c, r_mu)
    ipm.settings(refinements=0, krylov_iterations=DEFAULT_SETTINGS["krylov_iterations"])
    steps = ipm.krylov_steps
    krylov = ipm.direction(it, factors, r_b, r_h, r_c, r_mu)
    ipm.settings(**DEFAULT_SETTINGS)
    assert ipm.krylov_steps == steps + 1
    for a, b in zip(krylov, direct, strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-7 * max(np.max(np.abs(b)), 1.0))


@pytest.mark.slow
def test_defaults_solve_a_wall_to_the_verifier_tolerance():
    """The default settings give a point the shared verifier accepts at 1e-8, and HiGHS's lambda."""
    from blockmpec.solvers.engines.highs import HighsLP, static_lp_solution

    ops = bm.assemble(bm.cases.wall(10, 20))
    lp = compile_linear(static_lp(ops))
    ipm = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
    assert ipm.inner_tolerance == DEFAULT_SETTINGS["inner_tolerance"]
    out = ipm.solve()
    assert out.status is bm.Status.OPTIMAL
    residuals = bm.verify.residuals(ops, static_lp_solution(lp, out), associative=True)
    assert max(residuals.values()) <= 1e-8
    simplex = HighsLP(compile_linear(static_lp(ops)), "dual-simplex").solve()
    assert -out.objective == pytest.approx(-simplex.objective, rel=1e-8)


def test_default_inner_tolerance_saves_solves_with_k_to_the_same_optimum():
    """The default ``inner_tolerance`` skips corrections of inner directions that are already accurate: fewer
    solves with ``K`` than with every inner direction corrected (``EXACT_INNER_SETTINGS``), the same lambda."""
    assert DEFAULT_SETTINGS["inner_tolerance"] > 0 and EXACT_INNER_SETTINGS["inner_tolerance"] == 0
    ops = bm.assemble(bm.cases.wall(10, 20))
    runs = {}
    for name, settings in (("default", DEFAULT_SETTINGS), ("exact", EXACT_INNER_SETTINGS)):
        ipm = cold_lp_engine(compile_linear(static_lp(ops)), "block-ipm", LoadUnits.of(ops))
        ipm.settings(**settings)
        out = ipm.solve()
        assert out.status is bm.Status.OPTIMAL
        runs[name] = (ipm.factoriser.solves, out.objective)
    assert runs["default"][0] < runs["exact"][0]
    assert runs["default"][1] == pytest.approx(runs["exact"][1], rel=1e-8)


def test_interior_fixed_point_keeps_every_inner_direction_corrected():
    """Newton on (3) was measured with every inner direction corrected: the interior fixed point keeps that
    setting, not the LP default's ``inner_tolerance``."""
    from blockmpec.formulations import step_lps
    from blockmpec.solvers.engines.interior_fixed_point import InteriorFixedPoint

    ops = bm.assemble(bm.cases.wall(4, 5))
    lps = step_lps(ops, tie_break=False)
    engine = InteriorFixedPoint(lps.step, lps.associative, LoadUnits.of(ops))
    assert {name: getattr(engine, name) for name in EXACT_INNER_SETTINGS} == EXACT_INNER_SETTINGS


def test_solve_runs_blas_on_one_thread_and_restores_it():
    """Multithreaded OpenBLAS spends milliseconds per tiny call (block_ipm.single_blas_thread):
    every iteration runs with one BLAS thread, and the caller's setting comes back afterwards."""
    import threadpoolctl

    def blas_threads():
        return [info["num_threads"] for info in threadpoolctl.threadpool_info() if info["user_api"] == "blas"]

    seen = []

    class Recording(BlockLP):
        def before_iteration(self, it):
            seen.append(blas_threads())

    before = blas_threads()
    lp = compile_linear(static_lp(bm.assemble(bm.cases.wall())))
    out = Recording(lp, interface_blocks(lp)).solve()
    assert out.status is bm.Status.OPTIMAL
    assert seen and all(threads and set(threads) == {1} for threads in seen)
    assert blas_threads() == before


def test_reduced_values_on_the_pattern_equal_the_sparse_product(wall_ipm):
    """K assembled on its structural pattern by the precomputed scatter (what the iteration factorises)
    equals A_B H^{-1} A_B^T + delta diag(K) (delta: diagonal_shift) by sparse products, to round-off, entry by entry."""
    ipm, it = wall_ipm
    K_product, _ = ipm.reduced_matrix(it)
    Hinv, _ = ipm.inverse_blocks(it)
    K_scatter = ipm.reduced_csc(ipm.reduced_values(Hinv))
    assert K_scatter.nnz == ipm.K_pattern.nnz >= K_product.nnz
    difference = abs(K_scatter - K_product).max()
    assert difference <= 1e-13 * abs(K_product).max()
    assert np.array_equal(K_scatter.diagonal() > 0, np.ones(K_scatter.shape[0], dtype=bool))


def test_diagonal_shift_changes_the_path_never_the_optimum():
    """The diagonal shift of ``K`` only changes how well its factors precondition the refinement: with the default
    (round-off level) and the former 1e-12 the LP ends optimal at the same lambda, and ``K``'s diagonal carries the
    shift (relative to the unshifted product)."""
    from blockmpec.solvers.linalg.block_ipm import WIDE_DIAGONAL_SHIFT

    WIDE_SHIFT_SETTINGS = {**DEFAULT_SETTINGS, "diagonal_shift": WIDE_DIAGONAL_SHIFT}  # the default before 1e-16
    ops = bm.assemble(bm.cases.wall(10, 20))
    lp = compile_linear(static_lp(ops))
    lams = []
    for settings in (DEFAULT_SETTINGS, WIDE_SHIFT_SETTINGS):
        ipm = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
        ipm.settings(**settings)
        out = ipm.solve()
        assert out.status is bm.Status.OPTIMAL
        lams.append(-out.objective)
        it = ipm.initial_point()
        Hinv, _ = ipm.inverse_blocks(it)
        shifted = ipm.reduced_values(Hinv)[ipm.K_diagonal]
        ipm.settings(diagonal_shift=0.0)
        plain = ipm.reduced_values(Hinv)[ipm.K_diagonal]
        # the shift added, to within one rounding of K_ii (the default's shift is itself of round-off size)
        error = np.abs((shifted - plain) - settings["diagonal_shift"] * plain)
        assert np.all(error <= np.finfo(float).eps * np.abs(plain) + 1e-280)
    assert abs(lams[0] - lams[1]) <= 1e-9 * abs(lams[1])


def test_auto_correctors_follow_the_size_of_k():
    """``correctors="auto"`` (the default): two Gondzio correctors below ``rules.corrector_rows`` rows of ``K``, four
    from there; a count is taken as given, anything else is one clear error.  The interior fixed point keeps two."""
    import dataclasses

    from blockmpec.solvers.linalg import block_ipm
    from blockmpec.solvers.plan import BLOCK_IPM_RULES

    assert DEFAULT_SETTINGS["correctors"] == "auto" and EXACT_INNER_SETTINGS["correctors"] == 2
    ops = bm.assemble(bm.cases.wall(4, 5))
    ipm = cold_lp_engine(compile_linear(static_lp(ops)), "block-ipm", LoadUnits.of(ops))
    rows = ipm.K_pattern.shape[0]
    assert ipm.rules == BLOCK_IPM_RULES and rows < BLOCK_IPM_RULES.corrector_rows
    assert ipm.corrector_count == block_ipm.SMALL_CORRECTORS
    ipm.rules = dataclasses.replace(BLOCK_IPM_RULES, corrector_rows=rows)
    assert ipm.corrector_count == block_ipm.LARGE_CORRECTORS
    ipm.rules = dataclasses.replace(BLOCK_IPM_RULES, corrector_rows=rows + 1)
    assert ipm.corrector_count == block_ipm.SMALL_CORRECTORS
    ipm.settings(correctors=3)
    assert ipm.corrector_count == 3
    for bad in (-1, 2.5, "many", True):
        with pytest.raises(ValueError, match='correctors must be "auto" or a count'):
            ipm.settings(correctors=bad)


def test_a_singular_k_ends_the_solve_with_a_status(monkeypatch):
    """A factorisation that meets an exactly zero pivot (SuperLU's "Factor is exactly singular") ends the solve with
    the best iterate and a status that says so, never an exception; at the starting point, ``numerical``."""
    from blockmpec.solvers.linalg.cholesky import SingularMatrixError, SymmetricFactoriser

    ops = bm.assemble(bm.cases.wall(4, 5))
    lp = compile_linear(static_lp(ops))
    factorise = SymmetricFactoriser.factorise

    def failing_from(count):
        def patched(self, K):
            if self.factorisations >= count:
                raise SingularMatrixError("SuperLU: Factor is exactly singular")
            return factorise(self, K)
        return patched

    monkeypatch.setattr(SymmetricFactoriser, "factorise", failing_from(6))
    out = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops)).solve()
    assert out.status in (bm.Status.ACCEPTABLE, bm.Status.NUMERICAL) and "singular" in out.message
    assert out.iterations == 5 and np.all(np.isfinite(out.v))
    monkeypatch.setattr(SymmetricFactoriser, "factorise", failing_from(0))
    out = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops)).solve()
    assert out.status is bm.Status.NUMERICAL and "starting point" in out.message


def test_block_ipm_stops_in_the_iteration_its_deadline_passes(monkeypatch):
    """The block IPM reads the clock before and after each factorisation: a deadline that passes during the third
    iteration's factorisation (the fourth, after the starting point's) ends the solve there, with the time limit and
    the two iterations made before it (its overshoot is at most one factorisation).  The clock is the engine's own,
    faked: no dependence on the machine's speed."""
    import types

    from blockmpec.solvers.linalg import block_ipm

    ops = bm.assemble(bm.cases.wall(4, 5))
    lp = compile_linear(static_lp(ops))
    row_scale, column_scale = LoadUnits.of(ops).static(lp)
    engine = block_ipm.BlockIPM(lp, interface_blocks(lp), deadline=1.0, row_scale=row_scale,
                                column_scale=column_scale)
    clock = {"now": 0.0, "factorisations": 0}
    factorise = engine.factorise

    def factorise_then_tick(it):
        clock["factorisations"] += 1
        if clock["factorisations"] == 4:
            clock["now"] = 2.0  # the deadline (1.0 on this clock) passes during the third iteration's factorisation
        return factorise(it)

    monkeypatch.setattr(engine, "factorise", factorise_then_tick)
    monkeypatch.setattr(block_ipm, "time", types.SimpleNamespace(perf_counter=lambda: clock["now"],
                                                               process_time=block_ipm.time.process_time))
    out = engine.solve()
    assert out.status is block_ipm.IPMStatus.TIME_LIMIT and out.iterations == 2, (out.status, out.message)
    assert clock["factorisations"] == 4
    clock["now"], clock["factorisations"] = 0.0, -100  # the same LP with the deadline far away: optimal
    assert engine.solve().status is block_ipm.IPMStatus.OPTIMAL

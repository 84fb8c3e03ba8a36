"""The cold LP engines: the block interior-point method against HiGHS, and engine selection.

The block IPM (solvers/_block_ipm.py) is an independent implementation of the
same static LP (1), so every case is a cross-check against HiGHS's simplex; the
closed forms of the two-block problem pin both.
"""


import numpy as np
import pytest

import blockmpec as bm
from blockmpec.deadline import Deadline
from blockmpec.formulations import compile_linear, kinematic_lp, static_lp
from blockmpec.solvers.engines.block_lp import BlockLP, interface_blocks
from blockmpec.solvers.engines.highs import HighsLP
from blockmpec.solvers.engines.lp_engine import cold_lp_engine
from blockmpec.solvers.engines.scaling import LoadUnits
from blockmpec.solvers.plan import LP_BLOCK_IPM_ROWS
from helpers import assert_success, block_on_block, solve_with, two_block_associative


def _scaled(structure, factor):
    return bm.make_structure([structure.polygon(i) * factor for i in range(structure.n_blocks)], structure.fixed,
                             friction=structure.friction)


def _overhanging(mu):
    base = [[-3, -1], [0, -1], [0, 0], [-3, 0]]
    block = [[-0.3, 0], [0.7, 0], [0.7, 1.0], [-0.3, 1.0]]
    return bm.make_structure([base, block], [True, False], friction=mu)


STRUCTURES = {
    "two-blocks": lambda: bm.cases.two_blocks(eta=3, mu=0.65),
    "two-blocks-mu-1e-4": lambda: bm.cases.two_blocks(eta=3, mu=1e-4),
    "two-blocks-mu-100": lambda: bm.cases.two_blocks(eta=0.05, mu=100.0),
    "two-blocks-eta-50": lambda: bm.cases.two_blocks(eta=50, mu=0.65),
    "single-block": lambda: bm.cases.single_block(),
    "round-arch": lambda: bm.cases.round_arch(),
    "arch-on-buttresses": lambda: bm.cases.arch_on_buttresses(),
    "wall-5x4": lambda: bm.cases.wall(),
    "wall-10x20": lambda: bm.cases.wall(10, 20),
    "wall-5x4-size-1e-3": lambda: _scaled(bm.cases.wall(), 1e-3),
    "wall-5x4-size-1e3": lambda: _scaled(bm.cases.wall(), 1e3),
    "overhanging-negative-lam": lambda: _overhanging(0.65),
    # 984 thin voussoirs carry thrusts ~1e3 times their weight: y/s spans many decades, and the
    # IPM stalled with a 2e-5 compatibility error before whole-system refinement
    "arch-984-thin-voussoirs": lambda: bm.cases.arch_on_buttresses(n_voussoirs=984),
}


@pytest.mark.parametrize("name", list(STRUCTURES))
def test_block_ipm_matches_highs_simplex(name):
    structure = STRUCTURES[name]()
    simplex = bm.solve(structure, "static-lp", algorithm="dual-simplex")
    ipm = bm.solve(structure, "static-lp", algorithm="block-ipm")
    assert_success(simplex)
    assert_success(ipm)
    assert ipm.multiplier == pytest.approx(simplex.multiplier, rel=1e-7, abs=1e-9)


@pytest.mark.parametrize(("eta", "mu"), [(3.0, 0.65), (0.5, 0.3), (5.0, 2.0)])
def test_block_ipm_two_block_closed_form(eta, mu):
    expected = two_block_associative(eta, mu)
    if expected is None:
        pytest.skip("closed form not valid here")
    res = bm.solve(bm.cases.two_blocks(eta=eta, mu=mu), "static-lp", algorithm="block-ipm")
    assert_success(res, expected, rtol=1e-7)


def test_block_ipm_infeasible_lp_is_a_clear_non_success():
    """Too little friction to hold the overhanging block with any live load: the LP is infeasible.
    An interior-point method cannot prove it; it must not claim success, and must say why."""
    res = bm.solve(_overhanging(0.3), "static-lp", algorithm="block-ipm")
    assert not res.success
    assert res.status is not bm.Status.OPTIMAL
    assert res.message


def test_block_ipm_rejects_lp_without_block_structure():
    """The kinematic LP has bounded columns (z >= 0): not the form the block IPM solves."""
    ops = bm.assemble(bm.cases.wall())
    lp = compile_linear(kinematic_lp(ops))
    with pytest.raises(ValueError, match="free"):
        BlockLP(lp, np.arange(3).reshape(1, 3))


def test_block_ipm_time_limit_gives_a_status():
    ops = bm.assemble(bm.cases.wall(10, 20))
    lp = compile_linear(static_lp(ops))
    ipm = BlockLP(lp, interface_blocks(lp))
    out = ipm.solve(Deadline(1e-9))
    assert out.status is bm.Status.TIME_LIMIT


def test_block_ipm_set_row_upper_changes_the_cohesion():
    """Cohesion c on every friction row raises lam; the re-solve sees the new right-hand side."""
    ops = bm.assemble(bm.cases.two_blocks(eta=3, mu=0.3))
    c = ops.n_interfaces
    lp = compile_linear(static_lp(ops, cohesion=np.zeros(c)))
    ipm = BlockLP(lp, interface_blocks(lp))
    lam0 = -ipm.solve().objective
    ipm.set_row_upper(lp.rows["friction"], np.full(2 * c, 0.05))
    lam1 = -ipm.solve().objective
    highs = HighsLP(lp, "dual-simplex")
    assert lam1 > lam0
    assert lam1 == pytest.approx(-highs.solve().objective, rel=1e-7)


def test_auto_engine_uses_the_block_ipm_above_the_threshold():
    small = compile_linear(static_lp(bm.assemble(bm.cases.wall())))
    large = compile_linear(static_lp(bm.assemble(bm.cases.wall(20, 30))))
    assert small.A.shape[0] <= LP_BLOCK_IPM_ROWS < large.A.shape[0]
    assert isinstance(cold_lp_engine(small, "auto"), HighsLP)
    assert isinstance(cold_lp_engine(large, "auto"), BlockLP)
    # a small LP whose block loads span more than LP_BLOCK_IPM_LOAD_SPREAD also goes to the block IPM
    stiff_ops = bm.assemble(block_on_block(1.0, 1e-3))
    stiff = compile_linear(static_lp(stiff_ops))
    assert stiff.A.shape[0] <= LP_BLOCK_IPM_ROWS
    assert isinstance(cold_lp_engine(stiff, "auto", LoadUnits.of(stiff_ops)), BlockLP)
    assert isinstance(cold_lp_engine(small, "auto", LoadUnits.of(bm.assemble(bm.cases.wall()))), HighsLP)


def test_lp_sequence_time_limit_counts_from_the_instance_clock():
    """HiGHS compares time_limit with an instance's cumulative run time: a remaining budget must be
    added to it, or later warm solves of the sequence stop at once."""
    from blockmpec.formulations import step_lps
    from blockmpec.solvers.engines.highs import highs_model, new_highs, set_deadline
    from blockmpec.solvers.engines.lp_sequence import LPSequence

    ops = bm.assemble(bm.cases.wall(10, 20))
    seq = LPSequence(step_lps(ops), LoadUnits.of(ops))
    assert seq.associative().status is bm.Status.OPTIMAL
    h = new_highs()  # an instance that has run once, as the sequence's has
    h.passModel(highs_model(seq.assoc_highs.lp))
    h.run()
    assert h.getRunTime() > 0
    assert set_deadline(h, Deadline(10.0))
    assert h.getOptionValue("time_limit")[1] >= h.getRunTime() + 9.0
    assert not set_deadline(h, Deadline(0.0))  # no time left: the caller does not solve


@pytest.mark.slow
def test_fixed_point_reports_its_lp_time_per_kind():
    res = solve_with(bm.cases.wall(10, 20), "fixed-point", settings=dict(fold_weight=0.0))  # a tie-break LP after every step
    assert_success(res)
    lp_time = res.extra["lp_time_s"]
    assert set(lp_time) == {"associative", "step", "tie_break"}
    assert all(v > 0 for v in lp_time.values())
    assert sum(lp_time.values()) <= res.solve_time_s
    assert res.extra["lp_solves"] == 1 + 2 * res.iterations


def test_block_ipm_unbounded_lp_is_a_clear_non_success():
    """A block boxed in by fixed blocks on three sides cannot collapse: the static LP is unbounded
    (HiGHS proves it); the block IPM's iterates diverge and it says so instead of claiming a value."""
    blocks = [[[-1, -1], [2, -1], [2, 0], [-1, 0]], [[-1, 0], [0, 0], [0, 1], [-1, 1]],
              [[1, 0], [2, 0], [2, 1], [1, 1]], [[0, 0], [1, 0], [1, 1], [0, 1]]]
    structure = bm.make_structure(blocks, [True, True, True, False], friction=0.6)
    assert bm.solve(structure, "static-lp", algorithm="dual-simplex").status is bm.Status.UNBOUNDED
    res = bm.solve(structure, "static-lp", algorithm="block-ipm")
    assert not res.success and res.multiplier is None
    assert "infeasible or unbounded" in res.message


@pytest.mark.parametrize("seed", [0, 1])
def test_highs_scaling_returns_values_and_duals_in_the_lp_units(seed):
    """Any positive row and column scaling of the static LP gives the same lam, and forces and mechanism
    (v = C v^, y = R y^) that verify in the LP's units: the unscaling of solvers.engines.highs.HighsLP is exact.
    (Forces and mechanism themselves need not agree: this LP has several optimal vertices.)"""
    from blockmpec.solvers.engines.highs import static_lp_solution

    ops = bm.assemble(bm.cases.wall())
    lp = compile_linear(static_lp(ops))
    rng = np.random.default_rng(seed)
    row_scale = 10.0 ** rng.uniform(-3, 3, lp.A.shape[0])
    column_scale = 10.0 ** rng.uniform(-3, 3, lp.c.size)
    plain = static_lp_solution(lp, HighsLP(lp, "dual-simplex").solve())
    scaled = static_lp_solution(lp, HighsLP(lp, "dual-simplex", row_scale=row_scale, column_scale=column_scale).solve())
    assert scaled.multiplier == pytest.approx(plain.multiplier, rel=1e-9)
    res = bm.verify.residuals(ops, scaled, associative=True)
    assert max(res.values()) < 1e-6, res


def test_load_scaling_puts_each_block_in_its_own_units():
    """A 1e-3 x 2e-3 block on a unit block: its equilibrium rows are scaled by 1/its load (5e5 times the
    big block's) and its interface's forces measured in its own load."""
    ops = bm.assemble(block_on_block(1.0, 1e-3))
    lp = compile_linear(static_lp(ops))
    units = LoadUnits.of(ops)
    row_scale, column_scale = units.static(lp)
    loads = units.units.block_load
    assert loads[0] / loads[1] == pytest.approx(1.0 / 2e-6, rel=1e-9)  # areas 1 and 1e-3 x 2e-3
    eq = lp.rows["equilibrium"].reshape(-1, 3)
    assert np.allclose(row_scale[eq[1]] * loads[1], 1.0) and np.allclose(row_scale[eq[0]] * loads[0], 1.0)
    small_interface = int(np.argmin(ops.length))
    t, n = lp.columns["x"][3 * small_interface: 3 * small_interface + 2]
    assert column_scale[t] == column_scale[n] == pytest.approx(loads[1])


def _interior_point(engine, seed):
    """A generic interior point of the block IPM: every entry of H^{-1} nonzero."""
    from blockmpec.solvers.linalg.block_ipm import IPMIterate

    rng = np.random.default_rng(seed)
    p = engine.h.size
    return IPMIterate(np.zeros(engine.c.size), 10.0 ** rng.uniform(-3, 3, p), np.zeros(engine.b.size),
                      10.0 ** rng.uniform(-3, 3, p))


@pytest.mark.parametrize("ordering", ["mmd", "metis"])
def test_block_ipm_ordering_has_the_fill_of_a_fresh_ordering(ordering):
    """The ordering of K is computed once, from K's structural pattern, not from the first K: at the
    starting point (s = y = 1) H^{-1} has exact zeros, that K is sparser than every later one, and its
    minimum-degree ordering gave 17x more fill at 1,000 blocks (here, 600 blocks: 10x; METIS 2x).  Fill (nonzeros of the factors) of the engine's cached
    ordering on a later K is that of a fresh ordering of that K."""
    from blockmpec.solvers.linalg.block_ipm import IPMIterate
    from blockmpec.solvers.linalg.cholesky import SymmetricFactoriser, metis_available, structural_pattern

    if ordering == "metis" and not metis_available():
        pytest.skip("pymetis not installed")
    ops = bm.assemble(bm.cases.wall(20, 30))
    lp = compile_linear(static_lp(ops))
    row_scale, column_scale = LoadUnits.of(ops).static(lp)  # as static-lp runs it
    engine = BlockLP(lp, interface_blocks(lp), ordering=ordering, row_scale=row_scale, column_scale=column_scale)
    p, n = engine.h.size, engine.c.size
    start = IPMIterate(np.zeros(n), np.ones(p), np.zeros(engine.b.size), np.ones(p))
    K_start, _ = engine.reduced_matrix(start)
    # H^{-1}'s structural zeros at s = y = 1 come out of LAPACK's block inverses as exact zeros or, with other
    # BLAS kernels (OpenBLAS on AVX-512), as round-off of 1e-19 beside entries of 1e-1; scipy drops only the
    # former.  The entries of round-off size are dropped here, so the sparse starting K of the bug is made on
    # every machine.
    K_start.data[np.abs(K_start.data) <= 1e-14 * np.abs(K_start.data).max()] = 0.0
    K_start.eliminate_zeros()
    K_later, _ = engine.reduced_matrix(_interior_point(engine, 0))
    # every entry K can hold lies in the structural pattern; the starting K misses many of them
    pattern = structural_pattern(engine.A_B, engine.k)
    assert abs(K_later).astype(bool).multiply(pattern.astype(bool)).nnz == K_later.nnz
    assert K_start.nnz < 0.8 * K_later.nnz
    engine.factorise(start)  # the engine's first factorisation is at the sparse starting K
    engine.factoriser.factorise(K_later)
    fresh = SymmetricFactoriser(K_later, ordering)
    fresh.factorise(K_later)
    assert engine.factoriser.factor_nnz <= 1.05 * fresh.factor_nnz
    # the stale ordering (from the starting K, as before the fix) is what this test catches
    stale = SymmetricFactoriser(K_start, ordering)
    stale.factorise(K_later)
    assert stale.factor_nnz > 1.5 * fresh.factor_nnz


@pytest.mark.slow
def test_block_ipm_factorises_every_iteration_with_one_ordering():
    """A whole solve: the ordering is made once, and the final factors have no more fill than a fresh
    ordering of a generic K (the fill of the structural pattern)."""
    from blockmpec.solvers.linalg.cholesky import SymmetricFactoriser

    ops = bm.assemble(bm.cases.wall(20, 30))
    lp = compile_linear(static_lp(ops))
    engine = BlockLP(lp, interface_blocks(lp), ordering="mmd")
    assert engine.solve().status is bm.Status.OPTIMAL
    perm = engine.factoriser.perm.copy()
    K_later, _ = engine.reduced_matrix(_interior_point(engine, 1))
    fresh = SymmetricFactoriser(K_later, "mmd")
    fresh.factorise(K_later)
    assert engine.factoriser.factorisations > 10
    assert engine.factoriser.factor_nnz <= 1.05 * fresh.factor_nnz
    engine.factoriser.factorise(K_later)
    assert np.array_equal(engine.factoriser.perm, perm)


@pytest.mark.slow
def test_block_ipm_lazy_refinement_saves_solves_with_the_same_lam():
    """Refining only the final direction of each iteration (not the predictor, corrector and each
    Gondzio corrector on their own) needs fewer solves with K and gives the same lam."""
    from blockmpec.solvers.linalg.block_ipm import DEFAULT_SETTINGS, EXACT_INNER_SETTINGS

    # the settings before lazy refinement: every direction refined on its own (and every inner one to the target)
    PREVIOUS_SETTINGS = {**EXACT_INNER_SETTINGS, "lazy_refinement": False}
    ops = bm.assemble(bm.cases.wall(20, 30))
    lp = compile_linear(static_lp(ops))
    row_scale, column_scale = LoadUnits.of(ops).static(lp)
    runs = {}
    for name, settings in (("previous", PREVIOUS_SETTINGS), ("default", DEFAULT_SETTINGS)):
        engine = BlockLP(lp, interface_blocks(lp), row_scale=row_scale, column_scale=column_scale)
        engine.settings(**settings)
        out = engine.solve()
        assert out.status is bm.Status.OPTIMAL
        assert len(engine.trace) == out.iterations
        runs[name] = (out.objective, engine.factoriser.solves)
    assert runs["default"][0] == pytest.approx(runs["previous"][0], rel=1e-9)
    assert runs["default"][1] < 0.9 * runs["previous"][1]


@pytest.mark.slow
def test_block_ipm_thin_voussoirs_reach_the_tolerance():
    """984 thin voussoirs (y/s spanning many decades): the whole-system refinement of the final
    direction reaches the 1e-9 tolerance (OPTIMAL, not merely ACCEPTABLE) and HiGHS's lam to 1e-9."""
    structure = STRUCTURES["arch-984-thin-voussoirs"]()
    ipm = bm.solve(structure, "static-lp", algorithm="block-ipm")
    simplex = bm.solve(structure, "static-lp", algorithm="dual-simplex")
    assert ipm.status is bm.Status.OPTIMAL
    assert ipm.multiplier == pytest.approx(simplex.multiplier, rel=1e-9)


def test_block_ipm_rejects_an_unknown_setting():
    ops = bm.assemble(bm.cases.wall())
    lp = compile_linear(static_lp(ops))
    with pytest.raises(ValueError, match="unknown setting"):
        BlockLP(lp, interface_blocks(lp)).settings(corectors=3)


@pytest.mark.parametrize("method", ["static-lp", "kinematic-lp"])
def test_highs_lps_hold_the_tightened_feasibility_tolerances(method):
    """Both associative LPs run HiGHS below its default tolerance 1e-7: the static LP at ``FEASIBILITY_TOL`` (1e-9;
    at 1e-7 the static LP of the 2,032-block wall by HiGHS's IPM came back with a multiplier-sign residual of
    4.4e-6, which the verifier rejects), the kinematic LP at ``MECHANISM_FEASIBILITY_TOL`` (1e-10; at 1e-9 it
    stopped 3.3e-8 from the exact static LP on a 2,042-stone wall)."""
    from blockmpec.solvers.engines.highs import FEASIBILITY_TOL, MECHANISM_FEASIBILITY_TOL

    solver = bm.get_solver(method)(algorithm="dual-simplex")
    solver.setup(bm.assemble(bm.cases.wall(courses=3, blocks_per_course=2)))
    expected = FEASIBILITY_TOL if method == "static-lp" else MECHANISM_FEASIBILITY_TOL
    assert solver.engine.feasibility_tolerances() == (expected, expected)

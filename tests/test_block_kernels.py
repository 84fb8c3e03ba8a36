"""The block IPM's compiled per-interface kernels (:mod:`blockmpec.solvers.linalg.block_kernels`, numba).

Each kernel is checked against the numpy expression it replaces, on the engine's own blocks at an iterate whose
``y/s`` spans many decades (as near the optimum), and whole solves with each choice of kernels must end at the
same optimum: the static LP (symmetric ``K``) and the interior fixed point (``G_dual != G``).  The choice itself:
``"auto"`` keeps numpy below ``rules.compiled_kernel_blocks`` (:data:`blockmpec.solvers.plan.BLOCK_IPM_RULES`), and ``"compiled"`` without numba is one clear error.
"""

import dataclasses

import numpy as np
import pytest

import blockmpec as bm
from blockmpec.formulations import compile_linear, static_lp
from blockmpec.solvers.engines.lp_engine import cold_lp_engine
from blockmpec.solvers.engines.scaling import LoadUnits
from blockmpec.solvers.linalg import block_ipm
from blockmpec.solvers.plan import BLOCK_IPM_RULES
from helpers import wall_block_ipm_off_path

pytest.importorskip("numba")
from blockmpec.solvers.linalg import block_kernels  # noqa: E402


@pytest.fixture(scope="module")
def wall_ipm():
    """The block IPM on a 10x20 wall's static LP with an iterate whose products s y spread over ~11 decades."""
    return wall_block_ipm_off_path(spread=4.0, seed=3)


def test_inverse_blocks_as_accurate_as_lapack(wall_ipm):
    """Gauss-Jordan with partial pivoting inverts every augmented block as accurately as LAPACK's LU (numpy):
    the residual ``M X - I`` of each block is within a small factor of LAPACK's, relative to ``|M| |X|``."""
    ipm, it = wall_ipm
    M, _ = ipm.block_systems(it)
    assert np.ptp(np.log10(np.abs(M[M != 0]))) > 6  # the blocks are badly scaled
    compiled, lapack = block_kernels.inverse_blocks(M), np.linalg.inv(M)

    def residual(X):
        scale = np.matmul(np.abs(M), np.abs(X)).max(axis=(1, 2))
        return np.abs(np.matmul(M, X) - np.eye(M.shape[1])).max(axis=(1, 2)) / scale

    eps = np.finfo(float).eps
    assert residual(compiled).max() <= 50 * eps
    assert residual(compiled).max() <= 10 * max(residual(lapack).max(), eps)


def test_inverse_blocks_raises_on_a_singular_block_as_numpy_does():
    M = np.stack([np.eye(3), np.zeros((3, 3)), np.eye(3)])
    with pytest.raises(np.linalg.LinAlgError, match="block 1"):
        block_kernels.inverse_blocks(M)
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.inv(M)


def test_inverse_scaled_blocks_are_the_stacked_path_bit_for_bit(wall_ipm):
    """The fused kernel builds each ``M_i`` inside its loop: ``M^{-1}``, ``H~`` and ``H^{-1}`` are those of building
    the stack ``M`` (numpy) and inverting it, bit for bit, for a symmetric LP and for ``G_dual != G`` (the interior
    fixed point's blocks, ``H^{-1} = H~``), and the IPM's compiled path returns them; a singular block raises."""
    ipm, it = wall_ipm
    M, sqrt_d = ipm.block_systems(it)
    stacked = block_kernels.inverse_blocks(M)
    top_left = np.ascontiguousarray(stacked[:, :ipm.k, :ipm.k])
    X, fused_top_left, H = block_kernels.inverse_scaled_blocks(ipm.g_blocks, ipm.g_dual_blocks, sqrt_d, True)
    assert np.array_equal(X, stacked) and np.array_equal(fused_top_left, top_left)
    assert np.array_equal(H, 0.5 * (top_left + np.swapaxes(top_left, 1, 2)))
    ipm.settings(kernels="compiled")
    Hinv, (M_inv, _, ipm_top_left) = ipm.inverse_blocks(it)
    ipm.settings(kernels="auto")
    assert np.array_equal(Hinv, H) and np.array_equal(M_inv, stacked) and np.array_equal(ipm_top_left, top_left)
    g_dual = ipm.g_blocks * np.random.default_rng(4).uniform(0.5, 1.0, ipm.g_blocks.shape)
    M_dual = M.copy()
    M_dual[:, :ipm.k, ipm.k:] = np.swapaxes(g_dual * sqrt_d[:, :, None], 1, 2)
    X, fused_top_left, H = block_kernels.inverse_scaled_blocks(ipm.g_blocks, g_dual, sqrt_d, False)
    stacked = block_kernels.inverse_blocks(M_dual)
    assert np.array_equal(X, stacked) and np.array_equal(fused_top_left, stacked[:, :ipm.k, :ipm.k])
    assert H is fused_top_left
    with pytest.raises(np.linalg.LinAlgError, match="block 0"):
        block_kernels.inverse_scaled_blocks(np.zeros_like(ipm.g_blocks), ipm.g_dual_blocks, sqrt_d, True)


def test_parallel_kernels_give_the_same_numbers_on_any_number_of_threads(wall_ipm, monkeypatch):
    """The block inverses and block solves run their blocks on the CPUs this process may use: on one thread
    (``BLOCKMPEC_CPUS=1``), on all, and from two Python threads at once, the results are the same bit for bit."""
    from concurrent.futures import ThreadPoolExecutor

    ipm, it = wall_ipm
    sqrt_d = ipm.block_scaling(it)
    rng = np.random.default_rng(6)
    rhs_dual, rhs_primal = rng.normal(size=ipm.n_blocks * ipm.k), rng.normal(size=ipm.h.size)

    def run():
        X, top_left, H = block_kernels.inverse_scaled_blocks(ipm.g_blocks, ipm.g_dual_blocks, sqrt_d, True)
        return (X, top_left, H, *block_kernels.block_solve(X, sqrt_d, rhs_dual, rhs_primal, ipm.block_rows))

    everywhere = run()
    with ThreadPoolExecutor(2) as pool:
        side_by_side = [f.result() for f in [pool.submit(run) for _ in range(2)]]
    monkeypatch.setenv("BLOCKMPEC_CPUS", "1")
    one_thread = run()
    for other in (one_thread, *side_by_side):
        assert all(np.array_equal(a, b) for a, b in zip(everywhere, other, strict=True))


def test_max_step_is_numpys(wall_ipm):
    """The compiled step to the boundary is the numpy path's, exactly (the same divisions), with and without a
    blocking component."""
    ipm, _ = wall_ipm
    rng = np.random.default_rng(7)
    z = 10.0 ** rng.uniform(-8, 2, 1000)
    for dz in (rng.normal(size=1000), np.abs(rng.normal(size=1000)), -1e-12 * z, np.zeros(1000)):
        ipm.settings(kernels="numpy")
        expected = ipm.max_step(z, dz)
        ipm.settings(kernels="compiled")
        assert ipm.max_step(z, dz) == expected == block_kernels.max_step(z, dz)
    ipm.settings(kernels="auto")
    assert block_kernels.max_step(np.zeros(0), np.zeros(0)) == 1.0


def test_block_product_and_reduced_values_match_numpy(wall_ipm):
    ipm, it = wall_ipm
    ipm.settings(kernels="numpy")
    Hinv, (M_inv, sqrt_d, top_left) = ipm.inverse_blocks(it)
    rng = np.random.default_rng(5)
    rhs = rng.normal(size=(ipm.n_blocks, M_inv.shape[1]))
    expected = np.matmul(M_inv, rhs[:, :, None])[:, :, 0]
    assert np.allclose(block_kernels.block_product(M_inv, rhs), expected, rtol=1e-13,
                       atol=1e-13 * np.abs(M_inv).max() * np.abs(rhs).max())
    # the 3-by-3 products of the dual block solves go through the same kernel
    small = rhs[:, :ipm.k]
    assert np.allclose(block_kernels.block_product(top_left, small), np.einsum("bij,bj->bi", top_left, small),
                       rtol=1e-13, atol=1e-13 * np.abs(top_left).max() * np.abs(small).max())
    # the fused block solve against the numpy path's gathers, products and scatters
    blocks = (M_inv, sqrt_d, top_left)
    rhs_dual, rhs_primal = rng.normal(size=ipm.n_blocks * ipm.k), rng.normal(size=ipm.h.size)
    numpy_dv, numpy_dy = ipm.block_solve(blocks, rhs_dual, rhs_primal)
    compiled_dv, compiled_dy = block_kernels.block_solve(M_inv, sqrt_d, rhs_dual, rhs_primal, ipm.block_rows)
    for compiled, expected in ((compiled_dv, numpy_dv), (compiled_dy, numpy_dy)):
        assert np.abs(compiled - expected).max() <= 1e-13 * np.abs(expected).max()
    numpy_values = ipm.reduced_values(Hinv)
    ipm.settings(kernels="compiled")
    compiled_values = ipm.reduced_values(Hinv)
    scale = np.abs(numpy_values).max()
    assert np.abs(compiled_values - numpy_values).max() <= 1e-13 * scale
    ipm.settings(kernels="auto")


def _solve(lp, ops, kernels, engine=None):
    ipm = engine or cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
    ipm.settings(kernels=kernels)
    assert (ipm.block_kernels is None) == (kernels == "numpy")
    return ipm.solve()


@pytest.mark.slow
def test_static_lp_same_optimum_with_either_kernels():
    ops = bm.assemble(bm.cases.wall(10, 20))
    lp = compile_linear(static_lp(ops))
    outs = [_solve(lp, ops, kernels) for kernels in ("numpy", "compiled")]
    assert all(out.status is bm.Status.OPTIMAL for out in outs)
    assert outs[1].objective == pytest.approx(outs[0].objective, rel=1e-8)
    lam = [float(lp.values("lam", out.v)[0]) for out in outs]
    assoc = bm.solve(ops, "static-lp").multiplier  # HiGHS, independent of both
    assert lam == pytest.approx([assoc, assoc], rel=1e-7)


def test_interior_fixed_point_same_solution_with_either_kernels():
    """The non-symmetric blocks of (3) (``G_dual != G``) through the compiled inverse: the same solution."""
    from blockmpec.formulations import step_lps
    from blockmpec.solvers.engines.interior_fixed_point import InteriorFixedPoint

    ops = bm.assemble(bm.cases.wall(4, 5))
    lps = step_lps(ops, tie_break=False)
    outs = [_solve(lps.step, ops, kernels, engine=InteriorFixedPoint(lps.step, lps.associative, LoadUnits.of(ops)))
            for kernels in ("numpy", "compiled")]
    assert all(out.status is bm.Status.OPTIMAL for out in outs)
    assert outs[1].objective == pytest.approx(outs[0].objective, rel=1e-7)
    assert np.allclose(outs[1].v, outs[0].v, rtol=1e-6, atol=1e-6 * np.abs(outs[0].v).max())


def test_auto_compiles_from_the_threshold_on(wall_ipm, monkeypatch):
    ipm, _ = wall_ipm
    assert ipm.rules == BLOCK_IPM_RULES and ipm.n_blocks < BLOCK_IPM_RULES.compiled_kernel_blocks
    ipm.settings(kernels="auto")
    assert ipm.block_kernels is None
    monkeypatch.setattr(ipm, "rules", dataclasses.replace(BLOCK_IPM_RULES, compiled_kernel_blocks=ipm.n_blocks))
    assert ipm.block_kernels is block_kernels
    ipm.settings(kernels="numpy")
    assert ipm.block_kernels is None
    ipm.settings(kernels="compiled")
    assert ipm.block_kernels is block_kernels
    ipm.settings(kernels="auto")


def test_unknown_or_unavailable_kernels_are_one_clear_error(wall_ipm, monkeypatch):
    ipm, _ = wall_ipm
    with pytest.raises(ValueError, match="unknown kernels 'fortran'"):
        ipm.settings(kernels="fortran")
    monkeypatch.setattr(block_ipm, "compiled_kernels_available", lambda: False)
    with pytest.raises(ValueError, match=r"needs numba .*blockmpec\[fast\]"):
        ipm.settings(kernels="compiled")
    monkeypatch.setattr(ipm, "rules", dataclasses.replace(BLOCK_IPM_RULES, compiled_kernel_blocks=0))
    ipm.settings(kernels="auto")
    assert ipm.block_kernels is None  # auto without numba: numpy, whatever the size



def test_sparse_products_are_scipys_bit_for_bit(wall_ipm, monkeypatch):
    """``M x``, ``M^T y``, ``(M x, |M| |x|)`` and ``-y - M x`` by the compiled row loops equal scipy's ``M @ x``,
    ``M.T @ y``, ``abs(M) @ np.abs(x)`` and ``-y - M @ x`` bit for bit, for each of the engine's matrices, on one thread and on all, with entries
    spread over many decades (so that another order of the sums would round differently)."""
    import scipy.sparse as sp

    ipm, _ = wall_ipm
    rng = np.random.default_rng(11)
    wide = sp.random_array((300, 500), density=0.05, format="csr", rng=rng)
    wide.data *= 10.0 ** rng.uniform(-8, 8, wide.nnz)
    for M in (ipm.A, ipm.A_B, ipm.G, wide):
        x = rng.normal(size=M.shape[1]) * 10.0 ** rng.uniform(-6, 6, M.shape[1])
        y = rng.normal(size=M.shape[0]) * 10.0 ** rng.uniform(-6, 6, M.shape[0])
        products = block_kernels.SparseProducts(M)
        for cpus in ("2", "1"):
            monkeypatch.setenv("BLOCKMPEC_CPUS", cpus)
            assert np.array_equal(products.times(x), M @ x)
            assert np.array_equal(products.transpose_times(y), M.T @ y)
            times, bound = products.times_with_bound(x)
            assert np.array_equal(times, M @ x) and np.array_equal(bound, abs(M) @ np.abs(x))
            assert np.array_equal(products.offset_minus_times(y, x), -y - M @ x)
    # the sums do depend on their order here: a reversed order rounds differently somewhere
    x = rng.normal(size=wide.shape[1]) * 10.0 ** rng.uniform(-6, 6, wide.shape[1])
    reversed_rows = [sum(v * x[j] for v, j in zip(wide.data[a:b][::-1], wide.indices[a:b][::-1]))
                     for a, b in zip(wide.indptr[:-1], wide.indptr[1:])]
    assert not np.array_equal(np.array(reversed_rows, dtype=float), wide @ x)


def test_block_solve_without_dy_gives_the_same_dv(wall_ipm):
    """The first block solve of a direction needs ``dv`` alone: the kernel that reads only ``dv``'s rows of the block
    inverses gives the full solve's ``dv`` bit for bit."""
    ipm, it = wall_ipm
    sqrt_d = ipm.block_scaling(it)
    X, _, _ = block_kernels.inverse_scaled_blocks(ipm.g_blocks, ipm.g_dual_blocks, sqrt_d, True)
    rng = np.random.default_rng(12)
    rhs_dual, rhs_primal = rng.normal(size=ipm.n_blocks * ipm.k), rng.normal(size=ipm.h.size)
    dv, dy = block_kernels.block_solve(X, sqrt_d, rhs_dual, rhs_primal, ipm.block_rows)
    dv_alone, none = block_kernels.block_solve(X, sqrt_d, rhs_dual, rhs_primal, ipm.block_rows, with_dy=False)
    assert none is None and dy is not None
    assert np.array_equal(dv_alone, dv)


def test_compiled_products_leave_the_iterates_bit_for_bit():
    """``compiled_products`` (on by default with the compiled kernels) changes no number: the whole static LP takes
    the same iterations to the same primal and dual solution, bit for bit, as with scipy's products; a bad value of
    the setting is one clear error."""
    ops = bm.assemble(bm.cases.wall(10, 20))
    lp = compile_linear(static_lp(ops))
    outs, traces = [], []
    for products in (False, True):
        ipm = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
        ipm.settings(kernels="compiled", compiled_products=products)
        assert ipm.uses_compiled_products() is products
        outs.append(ipm.solve())
        traces.append([(row["mu"], row["step_primal"], row["step_dual"]) for row in ipm.trace])
    assert outs[0].status is bm.Status.OPTIMAL and outs[0].iterations == outs[1].iterations
    assert np.array_equal(outs[0].v, outs[1].v) and np.array_equal(outs[0].row_dual, outs[1].row_dual)
    assert traces[0] == traces[1]
    with pytest.raises(ValueError, match="compiled_products must be one of"):
        ipm.settings(compiled_products=1)


def test_reduced_assembly_and_max_step_are_the_serial_numbers(wall_ipm, monkeypatch):
    """The parallel assembly of ``K``'s values sums each value's products in the scatter's order: the serial
    kernel's values bit for bit, on one thread and on all; the chunked step to the boundary is the serial one."""
    ipm, it = wall_ipm
    Hinv, _ = ipm.inverse_blocks(it)
    serial = block_kernels.reduced_values(ipm.K_slots, Hinv, ipm.K_targets, ipm.K_pattern.nnz)
    assembly = block_kernels.ReducedAssembly(ipm.K_targets, ipm.K_pattern.nnz)
    rng = np.random.default_rng(13)
    z = 10.0 ** rng.uniform(-5, 5, 300_001)
    for cpus in ("2", "1"):
        monkeypatch.setenv("BLOCKMPEC_CPUS", cpus)
        assert np.array_equal(assembly.values(ipm.K_slots, Hinv), serial)
        dz = rng.normal(size=z.size)
        assert block_kernels.max_step(z, dz) == min(1.0, np.min(-z[dz < 0] / dz[dz < 0]))


@pytest.mark.parametrize("threads", [1, 2])
def test_centring_targets_are_numpys_bit_for_bit(monkeypatch, threads):
    """Gondzio's correction, Mehrotra's corrector target and the block solves' primal right-hand side, one compiled
    pass each: numpy's numbers bit for bit, with and without path weights, on values over 24 decades (products
    below, inside and above the band), on one thread and on two."""
    monkeypatch.setattr(block_kernels, "usable_cpus", lambda: threads)
    rng = np.random.default_rng(7)
    p = 5000
    s, y = 10.0 ** rng.uniform(-12, 12, p), 10.0 ** rng.uniform(-12, 12, p)
    ds, dy = -s * rng.uniform(-2, 1.2, p), -y * rng.uniform(-2, 1.2, p)
    r_h, r_mu = rng.standard_normal(p), rng.standard_normal(p) * 1e-3
    sigma, mu, tp, td = 0.37, 2.3e-4, 0.61, 0.43
    for weights in (None, 10.0 ** rng.uniform(-1, 1, p)):
        w = 1.0 if weights is None else weights
        products = (s + tp * ds) * (y + td * dy)
        expected = np.maximum(np.clip(products, 0.1 * sigma * mu * w, 10.0 * sigma * mu * w) - products,
                              -10.0 * sigma * mu * w)
        low_or_high = (expected != 0)  # the band's both sides and its inside occur
        assert 0 < low_or_high.sum() < p
        got = block_kernels.centrality_correction(s, ds, y, dy, tp, td, 0.1 * sigma * mu, 10.0 * sigma * mu, weights)
        assert np.array_equal(got, expected)
        target = block_kernels.centring_target(s, y, ds, dy, sigma * mu, weights)
        assert np.array_equal(target, sigma * mu * w - s * y - ds * dy)
    assert np.array_equal(block_kernels.primal_rhs(r_h, r_mu, y), -r_h - r_mu / y)


def test_newton_errors_are_numpys_bit_for_bit(monkeypatch):
    """The whole-system refinement's inequality and complementarity errors and their largest magnitudes in one
    compiled pass: numpy's numbers bit for bit, on one thread and on two; a NaN anywhere makes its maximum NaN, as
    numpy's does."""
    rng = np.random.default_rng(11)
    p = 3001
    r_h, G_dv, ds, r_mu, y, s, dy = (rng.standard_normal(p) * 10.0 ** rng.uniform(-8, 8, p) for _ in range(7))
    for threads in (1, 2):
        monkeypatch.setattr(block_kernels, "usable_cpus", lambda: threads)
        e_h, e_mu, h_inf, mu_inf = block_kernels.newton_errors(r_h, G_dv, ds, r_mu, y, s, dy)
        expected_h, expected_mu = -r_h - G_dv - ds, r_mu - (y * ds + s * dy)
        assert np.array_equal(e_h, expected_h) and np.array_equal(e_mu, expected_mu)
        assert h_inf == np.max(np.abs(expected_h)) and mu_inf == np.max(np.abs(expected_mu))
    ds[1234] = np.nan
    _, _, h_inf, mu_inf = block_kernels.newton_errors(r_h, G_dv, ds, r_mu, y, s, dy)
    assert np.isnan(h_inf) and np.isnan(mu_inf)

"""Timing benchmarks (pytest-benchmark) of the pipeline stages; not run by default.

Every test here is marked ``benchmark``.  ``pyproject.toml`` puts ``-m "not benchmark"``
in pytest's ``addopts``, so a plain ``python -m pytest`` (CI) deselects them: nothing
here is timed, or even run, in CI.  A later ``-m`` on the command line replaces the
one in ``addopts``, so they run, in one process (``-n 0``: pytest-benchmark times nothing under xdist's workers),
with::

    python -m pytest -m benchmark -n 0 tests/test_benchmarks.py
    python -m pytest -m benchmark -n 0 tests/test_benchmarks.py --benchmark-json out.json   # keep the timings

(Deselection by marker was chosen over pytest-benchmark's ``--benchmark-skip`` because
it also works where the plugin is not installed.)  Cost growth with size is measured
by the studies of ``docs/performance.md``, not here.

Each benchmark also checks its result, so a benchmark of a broken stage fails:

* assembly of a 1,001-block running-bond wall: operator shapes ``E (3b x 3c)``,
  ``N_u, N_f (3c x 2c)``, and the live load is the horizontal image of the dead load
  (``sum f_l,x = -sum f_d,y``: unit-density weight as live load);
* Pyomo build + compile of the static LP (1) of that wall: ``3b`` equilibrium rows,
  ``2c`` unilateral and ``2c`` friction rows, ``3c + 1`` columns ``(x, lam)``; and a
  cache hit of the same compile (``compiled_linear``), equal to a fresh compile;
* ``static-lp`` on the two-block problem (closed form, Sect. 3 of the paper) and on
  the 1,001-block wall (verified success);
* ``fixed-point`` on a 10 x 20 wall, ``nlp`` on the 5 x 4 wall: verified solutions of
  (3), whose ``lam`` cannot exceed the associative one (their ``x`` is feasible in (1));
* ``milp`` on a 2 x 2 wall: a certified minimum, at most ``lam`` of any verified
  solution of (3) (here the fixed point's) and of the associative LP;
* the comparator (``blockmpec.bench.compare.compare``) on the two-block problem with three
  methods in isolated worker processes: every answer graded against the closed forms.

Nothing here imports ``studies/`` (issue 40): the scaling study is run by CI on its own.
"""

from __future__ import annotations

import numpy as np
import pytest

import blockmpec as bm
from helpers import assert_success, two_block_associative

pytestmark = pytest.mark.benchmark

WALL_1K = {"courses": 22, "blocks_per_course": 45}  # 1,001 free blocks (running bond)


@pytest.fixture(scope="module")
def wall_1k():
    return bm.cases.wall(**WALL_1K)


@pytest.fixture(scope="module")
def wall_1k_ops(wall_1k):
    return bm.assemble(wall_1k)


def test_assembly_wall_1k(benchmark, wall_1k):
    ops = benchmark(bm.assemble, wall_1k)
    b, c = wall_1k.n_free, len(wall_1k.interfaces)
    assert b == 1001
    assert ops.n_interfaces == c
    assert ops.E.shape == (3 * b, 3 * c)
    assert ops.N_u.shape == ops.N_f.shape == (3 * c, 2 * c)
    np.testing.assert_allclose(ops.f_l[0::3].sum(), -ops.f_d[1::3].sum(), rtol=1e-12)
    assert ops.f_d[1::3].sum() < 0


def test_static_lp_build_and_compile_wall_1k(benchmark, wall_1k_ops):
    from blockmpec.formulations import compile_linear, static_lp

    lp = benchmark.pedantic(lambda: compile_linear(static_lp(wall_1k_ops)), rounds=3)
    b, c = wall_1k_ops.n_free_blocks, wall_1k_ops.n_interfaces
    assert {k: len(v) for k, v in lp.rows.items()} == {"equilibrium": 3 * b, "unilateral": 2 * c, "friction": 2 * c}
    assert lp.A.shape == (3 * b + 4 * c, 3 * c + 1)


def test_static_lp_compile_cache_hit_wall_1k(benchmark, wall_1k_ops):
    """A second compile of the same structure is a cache hit (a copy of the matrices, no Pyomo build)."""
    from blockmpec.formulations import compile_linear, static_lp
    from blockmpec.formulations.pyomo_compile import compiled_linear

    fresh = compile_linear(static_lp(wall_1k_ops))
    compiled_linear(static_lp, wall_1k_ops)
    lp = benchmark(compiled_linear, static_lp, wall_1k_ops)
    assert lp.A.shape == fresh.A.shape and (lp.A != fresh.A).nnz == 0
    assert np.array_equal(lp.row_upper, fresh.row_upper)


def test_static_lp_solve_two_blocks(benchmark):
    ops = bm.assemble(bm.cases.two_blocks(eta=3.0, mu=0.65))
    res = benchmark(bm.solve, ops, "static-lp")
    assert_success(res, two_block_associative(3.0, 0.65))


def test_static_lp_solve_wall_1k(benchmark, wall_1k_ops):
    res = benchmark.pedantic(bm.solve, args=(wall_1k_ops, "static-lp"), rounds=1)
    assert_success(res)
    # sliding of the whole wall on its base is a mechanism with lam = mu: an upper bound
    assert 0 < res.multiplier <= 0.65 + 1e-9


def test_fixed_point_wall_10x20(benchmark):
    ops = bm.assemble(bm.cases.wall(courses=10, blocks_per_course=20))
    associative = bm.solve(ops, "static-lp")
    assert_success(associative)
    res = benchmark.pedantic(bm.solve, args=(ops, "fixed-point"), rounds=2)
    assert_success(res)
    assert res.multiplier <= associative.multiplier + 1e-9


def test_nlp_wall_5x4(benchmark):
    ops = bm.assemble(bm.cases.wall())
    associative = bm.solve(ops, "static-lp")
    res = benchmark.pedantic(bm.solve, args=(ops, "nlp"), rounds=2)
    assert_success(res)
    assert res.multiplier <= associative.multiplier + 1e-9


def test_milp_wall_2x2(benchmark):
    ops = bm.assemble(bm.cases.wall(courses=2, blocks_per_course=2))
    associative = bm.solve(ops, "static-lp")
    fixed_point = bm.solve(ops, "fixed-point")
    assert_success(fixed_point)
    res = benchmark.pedantic(bm.solve, args=(ops, "milp"), kwargs={"time_limit": 60.0}, rounds=2)
    assert_success(res)
    assert res.status is bm.Status.OPTIMAL  # certified global minimum of (4)
    assert res.multiplier <= fixed_point.multiplier + 1e-7
    assert res.multiplier <= associative.multiplier + 1e-9


def test_compare_two_blocks_isolated(benchmark):
    """The comparator end to end: three methods, each solve in a worker process, graded against the closed forms."""
    from blockmpec.bench.compare import compare

    case = {"two-blocks": ("two-blocks", {"eta": 3.0, "mu": 0.65})}
    df = benchmark.pedantic(compare, args=(case, ["static-lp", "fixed-point", "milp"]), kwargs={"progress": False},
                            rounds=2)
    assert df["success"].all() and set(df["reference_source"]) == {"closed-form"}
    assert (df["abs_rel_error"] < 1e-8).all() and not df["new_best"].any() and (df["anomaly"] == "").all()
    np.testing.assert_allclose(df["multiplier"], [two_block_associative(3.0, 0.65), 1 / 3, 1 / 3], rtol=1e-8)

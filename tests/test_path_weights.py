"""Weighted central paths in the block IPM (``BlockIPM.path_weights``).

The weights change the path the iterates follow, never the LP's solution: a weighted run must end at the central
path's optimum (the same lambda, verified at 1e-8), and unit weights must give the central path itself, bit for bit.
How much the path's iterations change with weights of every kind was ``studies/lab/ipm_crawl.py``'s question (in
git history up to e31e02c).
"""

import numpy as np
import pytest

import blockmpec as bm
from blockmpec.formulations import compile_linear, static_lp
from blockmpec.solvers.engines.highs import static_lp_solution
from blockmpec.solvers.engines.lp_engine import cold_lp_engine
from blockmpec.solvers.engines.scaling import LoadUnits


def _wall_lp(courses: int, blocks_per_course: int):
    """``(lp, ops)``: the static LP (1) of a running-bond wall."""
    ops = bm.assemble(bm.cases.wall(courses, blocks_per_course))
    return compile_linear(static_lp(ops)), ops


def _engine(lp, ops, weights=None):
    engine = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
    engine.path_weights = weights
    return engine


def test_unit_weights_give_the_central_path_bit_for_bit():
    lp, ops = _wall_lp(8, 10)
    plain = _engine(lp, ops)
    out = plain.solve()
    ones = _engine(lp, ops, np.ones(plain.h.size))
    out_ones = ones.solve()
    assert out.iterations == out_ones.iterations
    assert np.array_equal(out.v, out_ones.v) and np.array_equal(out.row_dual, out_ones.row_dual)
    assert [t["mu"] for t in plain.trace] == [t["mu"] for t in ones.trace]


@pytest.mark.parametrize("seed", [0, 1])
def test_weighted_paths_end_at_the_central_paths_optimum(seed):
    """Weights spread over two decades per row (seeded): another path, the same optimum -- optimal, the central path's
    lambda to 1e-8 and verified at 1e-8."""
    lp, ops = _wall_lp(8, 10)
    plain = _engine(lp, ops).solve()
    assert plain.status is bm.Status.OPTIMAL
    engine = _engine(lp, ops)
    weights = 10.0 ** np.random.default_rng(seed).uniform(-1.0, 1.0, engine.h.size)
    engine.path_weights = weights
    out = engine.solve()
    assert out.status is bm.Status.OPTIMAL
    lam, lam_plain = float(lp.values("lam", out.v)[0]), float(lp.values("lam", plain.v)[0])
    assert lam == pytest.approx(lam_plain, rel=1e-8)
    residuals = bm.verify.residuals(ops, static_lp_solution(lp, out), associative=True)
    assert max(residuals.values()) <= 1e-8


@pytest.mark.parametrize("weights, message", [(np.ones(3), "shape"), ("negative", "row 5")])
def test_bad_path_weights_are_named(weights, message):
    lp, ops = _wall_lp(2, 2)
    engine = _engine(lp, ops)
    if isinstance(weights, str):
        weights = np.ones(engine.h.size)
        weights[5] = -1.0
    engine.path_weights = weights
    with pytest.raises(ValueError, match=message):
        engine.solve()

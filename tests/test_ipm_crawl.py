"""Weighted central paths in the block IPM (``BlockIPM.path_weights``) and studies/ipm_crawl.py.

The weights change the path the iterates follow, never the LP's solution: a weighted run must end at
the central path's optimum (the same lambda, verified at 1e-8), and unit weights must give the central
path itself, bit for bit.
"""

import numpy as np
import pytest

import blockmpec as bm
from blockmpec.solvers.engines.highs import static_lp_solution
from blockmpec.solvers.engines.scaling import LoadUnits
from blockmpec.solvers.engines.lp_engine import cold_lp_engine
from helpers import load_study


@pytest.fixture(scope="module")
def crawl():
    return load_study("ipm_crawl")


def _engine(lp, ops, weights=None):
    engine = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
    engine.path_weights = weights
    return engine


def test_unit_weights_give_the_central_path_bit_for_bit(crawl):
    lp, ops = crawl.wall_lp("8x10")
    plain = _engine(lp, ops)
    out = plain.solve()
    ones = _engine(lp, ops, np.ones(plain.h.size))
    out_ones = ones.solve()
    assert out.iterations == out_ones.iterations
    assert np.array_equal(out.v, out_ones.v) and np.array_equal(out.row_dual, out_ones.row_dual)
    assert [t["mu"] for t in plain.trace] == [t["mu"] for t in ones.trace]


def test_weights_from_the_solution_shorten_the_path_to_the_same_optimum(crawl):
    """The oracle of the study: weights that make every row leave the crawl at once take fewer
    iterations, and the point they reach is the LP's optimum (verified, the central path's lambda)."""
    lp, ops = crawl.wall_lp("20x50")
    plain, recorder = crawl.run(lp, ops)
    assert recorder.start is not None and recorder.previous is not None
    weights = crawl.solution_weights(recorder.start, recorder.previous, clip=10.0)
    assert weights.min() >= 0.1 and weights.max() <= 10.0 and weights.min() < 1 < weights.max()
    engine = _engine(lp, ops, weights)
    out = engine.solve()
    assert out.status is bm.Status.OPTIMAL
    assert out.iterations < plain["iterations"]
    lam = float(lp.values("lam", out.v)[0])
    assert lam == pytest.approx(plain["lam"], rel=1e-8)
    residuals = bm.verify.residuals(ops, static_lp_solution(lp, out), associative=True)
    assert max(residuals.values()) <= 1e-8


def test_the_crawl_is_not_lost_centrality(crawl):
    """Once the residuals are small, the rows that stop the steps are centred (products within
    [0.1, 10] mu) in most iterations: the short steps are the path's curvature (study docstring)."""
    rows, summary = crawl.diagnose("20x50")
    assert summary["status"] == "optimal" and summary["crawl_iterations"] >= 5
    assert summary["blocking_rows_centred"] >= 0.8
    assert summary["median_shorter_step"] < 0.9


@pytest.mark.parametrize("weights, message", [(np.ones(3), "shape"), ("negative", "row 5")])
def test_bad_path_weights_are_named(crawl, weights, message):
    lp, ops = crawl.wall_lp("2x2")
    engine = _engine(lp, ops)
    if isinstance(weights, str):
        weights = np.ones(engine.h.size)
        weights[5] = -1.0
    engine.path_weights = weights
    with pytest.raises(ValueError, match=message):
        engine.solve()


def test_mapping_a_wall_onto_itself_keeps_every_weight(crawl):
    """The coarse-to-fine map of the study sends each row to the same row of the nearest interface of the
    same orientation: a wall mapped onto itself gets its own weights back, row for row."""
    lp, ops = crawl.wall_lp("8x10")
    _, recorder = crawl.run(lp, ops)
    weights = crawl.solution_weights(recorder.start, recorder.previous)
    other = _engine(lp, ops)
    wall = crawl.named_wall("8x10")
    mapped = crawl.mapped_weights((recorder.engine, wall, weights), (other, wall))
    np.testing.assert_array_equal(mapped, weights)


def test_einsum_block_products_are_the_engine_block_solve_to_round_off(crawl):
    """``--roundoff`` swaps only the order of the per-block sums: one block product agrees with the engine's to
    round-off, and the whole run reaches the same lambda."""
    lp, ops = crawl.wall_lp("8x10")
    engine = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
    blocks, *_ = engine.factorise(engine.initial_point())
    M_inv = blocks[0]
    rhs = np.random.default_rng(0).standard_normal(M_inv.shape[:2])
    ours, theirs = engine.block_product(M_inv, rhs), crawl.einsum_block_product(M_inv, rhs)
    assert np.allclose(ours, theirs, rtol=1e-12, atol=1e-12 * np.abs(ours).max())
    rows = crawl.roundoff("8x10")
    assert [row["status"] for row in rows] == ["optimal", "optimal"]
    assert rows[1]["lam"] == pytest.approx(rows[0]["lam"], rel=1e-8)


def test_projection_onto_the_final_face_keeps_the_optimum_and_rejects_the_start(crawl):
    """``face_projection`` (the study's ``--polish``): the optimal iterate projected onto its own partition's face
    stays feasible at the optimum; the starting point projected onto that face violates the rows it keeps free
    (an early finish with the right partition still fails)."""
    lp, ops = crawl.wall_lp("8x10")
    plain, recorder = crawl.run(lp, ops)
    engine, final = recorder.engine, recorder.previous
    active = final.y > final.s
    assert 0 < active.sum() < active.size
    optimum = float(engine.c @ final.v)
    violation, objective = crawl.face_projection(engine, final, active)
    assert violation <= 1e-9
    assert abs(objective - optimum) <= 1e-9 * (1 + abs(optimum))
    start_violation, _ = crawl.face_projection(engine, engine.initial_point(), active)
    assert start_violation > 1e-3


def test_polish_summary_counts_within_the_run(crawl):
    rows, summary = crawl.polish("8x10", kappas=(100.0,))
    assert summary["status"] == "optimal" and summary["probe_iterations"] == len(rows) == summary["iterations"] + 1
    for tol in ("1e-08", "1e-09"):
        for name in ("oracle", "s<100y"):
            assert 0 <= summary[f"{name}_saves_at_{tol}"] < len(rows)
    # the last iterate is optimal: every guess there is the final partition, whose projection is feasible
    assert rows[-1]["oracle_violation"] <= 1e-8 and rows[-1]["oracle_objective_error"] <= 1e-8


def test_ties_lowers_friction_and_so_lambda(crawl):
    """``--ties``: lowering the friction (up to 1e-2 of it) can only lower the associative optimum, never raise it."""
    rows = crawl.ties("8x10", [0.0, 1e-2])
    assert [row["status"] for row in rows] == ["optimal", "optimal"]
    assert rows[1]["lam"] <= rows[0]["lam"] + 1e-9


def test_wall_names_are_parsed_once_for_every_study():
    """``studies/_walls.py`` reads the ``"CxB"`` wall names of every study: courses first, then blocks per course,
    with options passed to :func:`blockmpec.cases.wall`; a malformed name is one clear error naming it."""
    walls = load_study("_walls")
    assert walls.wall_shape(" 3X4 ") == (3, 4)
    assert walls.wall_shapes("2x5,,10x20") == [(2, 5), (10, 20)]
    wall = walls.named_wall("3x4", mu=0.4)
    reference = bm.cases.wall(courses=3, blocks_per_course=4, mu=0.4)
    assert wall.n_free == reference.n_free and np.array_equal(wall.interface_friction(), reference.interface_friction())
    for bad in ("3by4", "3x", "3x4x5"):
        with pytest.raises(ValueError, match=f"wall '{bad}': expected CxB"):
            walls.wall_shape(bad)


def test_arc_step_is_the_first_exit_along_the_ellipse(crawl):
    """``arc_step``: the largest a in [0, pi/2] keeping ``z + sin(t) first + (1 - cos t) second`` positive up to a.
    Closed forms: ``1 - 2 sin a`` leaves at pi/6; ``1 - 1.5 (1 - cos a)`` at acos(1/3); an arc that stays positive
    gives pi/2."""
    ones = np.ones(1)
    assert crawl.arc_step(ones, -2 * ones, 0 * ones) == pytest.approx(np.pi / 6, abs=1e-9)
    assert crawl.arc_step(ones, 0 * ones, -1.5 * ones) == pytest.approx(np.arccos(1 / 3), abs=1e-9)
    assert crawl.arc_step(np.ones(2), np.array([-2.0, 0.0]), np.array([0.0, -1.5])) == pytest.approx(np.pi / 6, abs=1e-9)
    assert crawl.arc_step(ones, 0.5 * ones, 0.3 * ones) == np.pi / 2


def test_arc_search_reaches_the_engines_optimum(crawl):
    """The arc-search variant of ``--arc`` is a method for the same LP: it must end optimal at the engine's lambda."""
    rows = {row["method"]: row for row in crawl.arc("8x10")}
    assert rows["arc search"]["status"] == "optimal"
    assert rows["the engine as set"]["status"] == "optimal"
    assert rows["arc search"]["lam"] == pytest.approx(rows["the engine as set"]["lam"], abs=1e-8)
    assert rows["Mehrotra, no correctors"]["lam"] == pytest.approx(rows["the engine as set"]["lam"], abs=1e-8)

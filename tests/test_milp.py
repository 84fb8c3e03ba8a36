"""The ``milp`` method: certified global minimum of the non-associative MPEC (4).

Checks: the closed-form two-block minimum over a grid (with a closed gap), a case
where the global minimum lies far below the associative value, published
arch values, ``lam_milp <= lam_associative`` on built-in cases, round-off
residuals after polishing, and that too small big-M bounds are reported instead
of silently giving a wrong answer.
"""

import itertools

import numpy as np
import pytest

import blockmpec as bm
from blockmpec.result import Status
from conftest import two_block_associative, two_block_nonassociative_min

ETAS = [1, 2, 3, 4, 5]
MUS = [0.3, 0.5, 0.65, 0.8, 1.0, 1.2, 1.5]
POLISHED_TOL = 1e-7

pytest.importorskip("highspy")


def assert_certified(res: bm.Result) -> None:
    assert res.status is Status.OPTIMAL, f"{res.status.value}: {res.message}"
    assert res.verified
    assert res.extra["bigm_active"] == []
    # closed gap: the polished (exact) multiplier meets the branch-and-bound dual bound
    assert res.extra["gap_abs"] <= 1e-7 * max(1.0, abs(res.multiplier))
    assert res.extra["dual_bound"] <= res.multiplier + 1e-7
    assert max(res.residuals.values()) <= POLISHED_TOL, res.residuals


@pytest.mark.parametrize(("eta", "mu"), list(itertools.product(ETAS, MUS)))
def test_two_blocks_closed_form_minimum(eta, mu):
    res = bm.solve(bm.cases.two_blocks(eta=eta, mu=mu), "milp")
    assert_certified(res)
    expected = mu if mu <= 1 / eta else 1 / eta
    assert expected == pytest.approx(two_block_nonassociative_min(eta, mu), abs=1e-12)
    assert abs(res.multiplier - expected) <= 1e-7


def test_two_blocks_global_minimum_below_associative_and_heuristic_value():
    """eta = 3, mu = 1.5: the certified minimum is 1/3 (both blocks rock together).

    The associative multiplier is 2/3, and a local method started from the
    associative mechanism (the right block rocking alone, no sliding) may stop at
    the MCP solution lam = 2/3; the MILP proves that nothing below 1/3 exists and
    finds 1/3.
    """
    res = bm.solve(bm.cases.two_blocks(eta=3, mu=1.5), "milp")
    assert_certified(res)
    assert res.multiplier == pytest.approx(1 / 3, abs=1e-9)
    assert two_block_associative(3, 1.5) == pytest.approx(2 / 3, abs=1e-12)
    assert res.extra["lam_upper_associative"] == pytest.approx(2 / 3, abs=1e-9)
    assert res.extra["dual_bound"] >= 1 / 3 - 1e-7


def test_round_arch_published_value():
    res = bm.solve(bm.cases.round_arch(), "milp")
    assert_certified(res)
    assert round(res.multiplier, 5) == 0.16034


@pytest.mark.parametrize(
    "structure",
    [
        bm.cases.round_arch(),
        bm.cases.arch_on_buttresses(),
        bm.cases.wall(2, 2),
        bm.cases.wall(3, 2, bond="stack"),
        bm.cases.two_blocks(eta=3, mu=0.65),
        bm.cases.single_block(width=1, height=2, mu=0.65),
    ],
    ids=["round-arch", "arch-on-buttresses", "wall-2x2", "wall-3x2-stack", "two-blocks", "single-block"],
)
def test_not_above_associative(structure):
    assoc = bm.solve(structure, "static-lp")
    res = bm.solve(structure, "milp")
    assert_certified(res)
    assert res.multiplier <= assoc.multiplier + 1e-9
    # every recorded big-M bound covers the slack of the returned solution
    ops = bm.operators.assemble(structure)
    x = res.solution.x
    c = ops.n_interfaces
    M = np.array(res.extra["bigm_unilateral"] + res.extra["bigm_friction"])
    assert M.shape == (4 * c,) and np.all(np.isfinite(M)) and np.all(M > 0)
    slack = -np.concatenate([ops.N_u.T @ x, ops.N_f.T @ x])
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
    res = bm.solve(structure, "milp")
    assert_certified(res)
    assert abs(res.multiplier - assoc.multiplier) <= 1e-8


def test_single_block_closed_form():
    res = bm.solve(bm.cases.single_block(width=1, height=2, mu=0.65), "milp")
    assert_certified(res)
    assert res.multiplier == pytest.approx(0.5, abs=1e-9)
    res = bm.solve(bm.cases.single_block(width=1, height=1, mu=0.3), "milp")
    assert_certified(res)
    assert res.multiplier == pytest.approx(0.3, abs=1e-9)


@pytest.mark.parametrize("scale", [0.95, 0.8, 0.5, 0.01])
@pytest.mark.parametrize("mu", [0.65, 1.5])
def test_too_small_bigm_is_detected(scale, mu):
    """Shrunken slack bounds cut off the optimum: never reported as a certified optimum."""
    structure = bm.cases.two_blocks(eta=3, mu=mu)
    res = bm.solve(structure, "milp", bigm_scale=scale)
    assert res.status is not Status.OPTIMAL
    if res.status is Status.INFEASIBLE:
        assert "bigm_scale" in res.message
    else:
        assert res.extra["bigm_active"], res.message
        assert "certificate" in res.message


def test_time_limit_returns_polished_incumbent_and_gap():
    res = bm.solve(bm.cases.wall(3, 3), "milp", time_limit=2.0)
    assert res.status is Status.TIME_LIMIT
    if res.multiplier is not None:
        assert max(res.residuals.values()) <= POLISHED_TOL
        assert res.extra["dual_bound"] <= res.multiplier + 1e-9
        assert res.extra["gap_abs"] >= 0


def test_spurious_zero_live_work_point_is_not_certified(monkeypatch):
    """Without the sliding-direction cut, z_f[2k] = z_f[2k+1] = 1/2 with u = 0 solves the normalised
    system (psi = 0): the relaxation's optimum then has tau = f_l^T u = 0.  The solver must notice
    (no mechanism for the pattern), fall back to the restriction tau >= tau_restart for a genuine
    solution, and not claim a certificate."""
    import formulations.mpec_bigm as fm

    compile_orig = fm.compile_mixed_integer

    def without_cut(problem):
        problem.model.sliding_direction.deactivate()
        problem.constraints.pop("sliding_direction", None)
        return compile_orig(problem)

    monkeypatch.setattr(fm, "compile_mixed_integer", without_cut)
    res = bm.solve(bm.cases.two_blocks(eta=3, mu=1.5), "milp", incumbent=False)
    assert res.status is not Status.OPTIMAL
    assert "tau_restart" in res.extra
    assert res.extra["dual_bound"] < 1 / 3 - 1e-3
    assert res.multiplier == pytest.approx(1 / 3, abs=1e-9)  # the restriction's point solves (3)
    assert max(res.residuals.values()) <= POLISHED_TOL


@pytest.mark.parametrize(
    ("option", "value"),
    [("time_limit", 0.0), ("mip_rel_gap", -1e-3), ("mip_abs_gap", -1.0), ("bigm_scale", 0.0),
     ("slack_bounds", "tight"), ("threads", 0)],
)
def test_bad_options(option, value):
    with pytest.raises(bm.errors.OptionError, match=option):
        bm.solve(bm.cases.two_blocks(), "milp", **{option: value})


def test_normal_force_bounds_give_the_same_minimum():
    res = bm.solve(bm.cases.two_blocks(eta=3, mu=1.5), "milp", slack_bounds="normal")
    assert_certified(res)
    assert res.multiplier == pytest.approx(1 / 3, abs=1e-9)

"""The ``mcp-newton`` method: a solution of the MCP (3) by semismooth Newton (PATH stand-in).

Checks: the two-block bounds of Nodargi, Intrigila & Bisegna (Sect. 3: every
solution of (3) lies between the non-associative minimum ``mu`` if ``mu <= 1/eta``
else ``1/eta`` and the associative multiplier), the default start reaching that
closed-form minimum and never falling below a certificate, the former associative
start kept as an option, the round arch of their Table 1 (0.16034; full precision from the
independent LP, references.py), the associative
control, the Fischer–Burmeister function, and failures (iteration and time limits)
reported as statuses.
"""

import numpy as np
import pytest
from references import ROUND_ARCH_ASSOCIATIVE, ROUND_ARCH_PUBLISHED

import blockmpec as bm
from blockmpec.result import Status
from helpers import (
    assert_residuals_within,
    solve_with,
    two_block_associative,
    two_block_nonassociative_min,
)

TOL = 1e-6


def assert_mcp_solution(res):
    assert_residuals_within(res, TOL, Status.CONVERGED)


@pytest.mark.parametrize("eta", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("mu", [0.3, 0.65, 1.0])
def test_two_blocks_between_bounds(eta, mu):
    res = bm.solve(bm.cases.two_blocks(eta=eta, mu=mu), "mcp-newton")
    assert_mcp_solution(res)
    assert two_block_nonassociative_min(eta, mu) - 1e-9 <= res.multiplier <= two_block_associative(eta, mu) + 1e-9


@pytest.mark.parametrize(("eta", "mu"), [(3, 0.65), (5, 1.2), (1.5, 0.9)])
def test_default_reaches_the_two_block_minimum(eta, mu):
    """The default start (the fixed point's solution) gives the closed-form minimum min(mu, 1/eta), which
    lies below the associative multiplier here (1/3 against 1/2.3825 = 0.41973 at eta = 3, mu = 0.65)."""
    res = bm.solve(bm.cases.two_blocks(eta=eta, mu=mu), "mcp-newton")
    assert_mcp_solution(res)
    assert two_block_nonassociative_min(eta, mu) < two_block_associative(eta, mu) - 1e-3
    # 2.6e-9 measured at eta = 5, mu = 1.2 (the fixed point's start: n converged to 1e-9), 0 at the others
    assert res.multiplier == pytest.approx(two_block_nonassociative_min(eta, mu), rel=1e-8)
    assert res.extra["start"] == "fixed-point"


@pytest.mark.parametrize("start", ["fixed-point", "dead-load", "random", "associative"])
@pytest.mark.parametrize("case", [bm.cases.wall(3, 1, bond="stack", block_height=1.5),
                                  bm.cases.round_arch(n_voussoirs=6, thickness=0.15)], ids=["stack-3x1", "arch-6"])
def test_never_below_the_milp_certificate(case, start):
    cert = bm.solve(case, "milp")
    assert cert.status is Status.OPTIMAL
    res = bm.solve(case, "mcp-newton", start=start)
    assert_mcp_solution(res)
    assert res.multiplier >= cert.multiplier - 1e-9 * max(1.0, abs(cert.multiplier))


def test_associative_start_keeps_the_former_behaviour():
    res = bm.solve(bm.cases.two_blocks(eta=3, mu=0.65), "mcp-newton", start="associative")
    assert_mcp_solution(res)
    assert res.multiplier == pytest.approx(two_block_associative(3, 0.65), rel=1e-9)  # 1/2.3825, not 1/3 (0 measured)


def test_time_limit_is_honoured():
    """A deadline that passes before the first iteration (1 ns: whatever the machine's speed) ends the run with the
    time limit, without a success."""
    res = bm.solve(bm.cases.wall(12, 10), "mcp-newton", time_limit=1e-9)
    assert res.status is Status.TIME_LIMIT
    assert not res.success


def test_round_arch_table_1():
    res = bm.solve(bm.cases.round_arch(), "mcp-newton")
    assert_mcp_solution(res)
    assert res.multiplier == pytest.approx(ROUND_ARCH_ASSOCIATIVE, rel=1e-9)  # 1.1e-12 measured
    assert round(res.multiplier, 5) == ROUND_ARCH_PUBLISHED


@pytest.mark.parametrize("case", [bm.cases.two_blocks(eta=3, mu=0.65, dilatancy=0.65),
                                  bm.cases.wall(5, 4, mu=0.65, dilatancy=0.65)], ids=["two-blocks", "wall-5x4"])
def test_associative_control_gives_the_lp_multiplier(case):
    lp = bm.solve(case, "static-lp")
    res = bm.solve(case, "mcp-newton")
    assert_mcp_solution(res)
    assert res.multiplier == pytest.approx(lp.multiplier, abs=1e-9)


def test_wall_needs_iterations_and_stays_below_the_lp():
    case = bm.cases.wall(5, 4)
    lp = bm.solve(case, "static-lp")
    res = bm.solve(case, "mcp-newton", start="associative")
    assert_mcp_solution(res)
    assert res.iterations > 0
    assert res.multiplier <= lp.multiplier + 1e-9
    for t in res.trace:
        assert {"iteration", "merit", "step", "time_s", "direction"} <= set(t)
        assert 0 < t["step"] <= 1


def test_iteration_limit_is_a_status():
    res = bm.solve(bm.cases.wall(5, 4), "mcp-newton", start="associative", max_iterations=1)
    assert res.status is Status.ITERATION_LIMIT
    assert not res.success


def test_without_continuation():
    res = solve_with(bm.cases.two_blocks(eta=2, mu=0.65), "mcp-newton", settings=dict(continuation=False),
                     start="associative")
    assert_mcp_solution(res)
    assert res.multiplier <= two_block_associative(2, 0.65) + 1e-9


@pytest.mark.parametrize("bad", [dict(tol=0.0), dict(max_iterations=-1), dict(start="origin"), dict(seed=-1),
                                 dict(time_limit=0.0)])
def test_bad_options(bad):
    with pytest.raises(bm.OptionError, match=next(iter(bad))):
        bm.solve(bm.cases.single_block(), "mcp-newton", **bad)


@pytest.mark.parametrize("bad", [dict(sigma=0.7), dict(backtrack=1.0), dict(regularisation=-1.0),
                                 dict(continuation="yes"), dict(min_step=2.0), dict(fallback="no")])
def test_bad_settings(bad):
    """A bad engine setting is one line naming it."""
    from blockmpec.solvers.mcp_newton import NewtonSettings

    with pytest.raises(ValueError, match=next(iter(bad))) as err:
        NewtonSettings(**bad)
    assert "\n" not in str(err.value)


def test_fischer_burmeister():
    from blockmpec.solvers.engines.newton_system import fischer_burmeister

    rng = np.random.default_rng(1)
    a, b = rng.normal(size=200), rng.normal(size=200)
    phi, da, db = fischer_burmeister(a, b)
    # zero exactly on the complementarity set, nonzero off it
    zero, _, _ = fischer_burmeister(np.array([0.0, 2.0, 0.0]), np.array([3.0, 0.0, 0.0]))
    np.testing.assert_allclose(zero, 0.0, atol=1e-15)
    assert np.all(np.abs(phi[(a < 0) | (b < 0)]) > 0)
    # gradient = finite differences away from the kink at the origin
    h = 1e-7
    np.testing.assert_allclose(da, (fischer_burmeister(a + h, b)[0] - fischer_burmeister(a - h, b)[0]) / (2 * h),
                               atol=1e-6)
    np.testing.assert_allclose(db, (fischer_burmeister(a, b + h)[0] - fischer_burmeister(a, b - h)[0]) / (2 * h),
                               atol=1e-6)
    # at the kink: an element (1 - xi, 1 - rho) with xi^2 + rho^2 <= 1 of the generalised gradient
    _, da0, db0 = fischer_burmeister(np.zeros(1), np.zeros(1))
    assert (1 - da0[0]) ** 2 + (1 - db0[0]) ** 2 <= 1 + 1e-12
